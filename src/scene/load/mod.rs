//! Loading `scenes/*.toml` (format: [`super::desc`]) into a validated [`Scene`].
//!
//! Loading runs in three stages, each with its own kind of error:
//! 1. TOML syntax (`TOML syntax error at line L, column C: …`);
//! 2. the serde model: unknown keys, wrong types, unknown `type`s, located by key path and
//!    line/column (`shapes[3].radius: invalid type: string "a", expected f64 (line 12, …)`);
//! 3. meaning: ranges, references, degeneracies, files (`shapes[3].radius: expected a positive
//!    finite number, got -1`).
//!
//! Every error is one line that starts with the scene file and names the field. Nothing here
//! panics on any input: the fuzz tests below feed random bytes and mutated scenes.
//!
//! Geometry is validated and transformed in f64 and only then rounded to the f32 the renderer
//! uses; a triangle that rounding collapses is refused (quads, boxes) or skipped and counted
//! (meshes, [`LoadStats`]).
//!
//! Files: this one (entry points, statistics, hashing), [`locate`] (stages 1–2: errors located
//! by key path and line/column), [`validate`] (stage 3: values, camera, materials), [`transform`](mod@transform)
//! (shape transforms in f64), [`mesh`] (primitives, `subdivide`, OBJ), [`curved`] (disks and
//! cylinders as triangles), [`user_paths`](mod@user_paths) (the UP
//! proposal's paths), `tests.rs` (including the fuzz tests). What does not live here: the
//! Mitsuba importer ([`super::mitsuba`]) and anything a renderer does with the scene.

mod curved;
mod curves;
pub(crate) use curved::cylinder_frame;
mod environment;
mod lights;
mod locate;
mod media;
mod mesh;
mod mesh_formats;
mod principled;
pub use mesh_formats::mesh_file_has_normals;
mod rough;
pub(crate) use rough::PLASTIC_DEFAULT_IOR;
#[cfg(test)]
mod tests;
mod textures;
mod transform;
mod user_paths;
mod validate;

use locate::*;
use mesh::*;
use transform::*;
use user_paths::*;
use validate::*;

use super::desc::{self, SceneDesc, TransformDesc};
use super::{Emitters, Scene};
use crate::error::{Error, Result};
use crate::geometry::Primitive;
use crate::util::content_hash;
use glam::{DAffine3, DVec3};
use std::fmt;
use std::path::{Path, PathBuf};

pub use super::limits::*;

/// Memory budgeted per triangle when checking a subdivided shape against the memory limit: the
/// primitive, its attributes, its BVH share and its light entry, rounded up.
const BYTES_PER_TRIANGLE: u64 = 256;
/// Enters the content hash of every scene that subdivides a shape: bump it when the
/// tessellation changes, so that references and cached cells made with the old one go stale.
const SUBDIVIDE_HASH_TAG: &[u8] = b"photon-bench subdivide v1";
/// A user path's first point must lie within this fraction of the scene's bounding-box diagonal
/// from an emissive surface.
pub const USER_PATH_LIGHT_TOLERANCE: f64 = 1e-3;

/// What loading found, beyond the scene itself.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadStats {
    pub triangles: usize,
    pub spheres: usize,
    /// Mesh triangles skipped because their area is zero at f32 precision.
    pub degenerate_triangles_skipped: usize,
    /// Files read besides the scene file (meshes and their MTL libraries).
    pub files_read: Vec<PathBuf>,
    /// Approximations made while reading a Mitsuba scene, one line each (empty for TOML).
    pub warnings: Vec<String>,
}

/// Loads and validates a scene file. Skipped degenerate mesh triangles are reported on stderr;
/// use [`load_scene_with_stats`] to handle them yourself.
pub fn load_scene(path: &Path) -> Result<Scene> {
    SceneSource::file(path).load()
}

/// Loads and validates a scene file, and says what it skipped.
pub fn load_scene_with_stats(path: &Path) -> Result<(Scene, LoadStats)> {
    let bytes = crate::util::read_input(path, "scene file", crate::util::MAX_TEXT_INPUT)?;
    load_scene_bytes(path, &bytes)
}

/// A scene as an experiment or a command names it: a file, the scene parameters to set (a
/// Mitsuba scene's `$name`s, as `mitsuba -D name=value`) and the name to know it by.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SceneSource {
    pub file: PathBuf,
    /// `(name, value)` in the order given; each must be used by the scene.
    pub params: Vec<(String, String)>,
    /// The scene's name (labels rows, names references and images); default: the scene's own
    /// name, and with parameters its file stem followed by them (`veach-mis` with
    /// `roughness = 0.1` is `veach-mis-roughness-0.1`).
    pub name: Option<String>,
}

impl SceneSource {
    /// The file alone, as it is.
    pub fn file(file: impl Into<PathBuf>) -> Self {
        Self {
            file: file.into(),
            ..Self::default()
        }
    }

    /// The name the scene will have when loaded without its own `name`: for strategies'
    /// `scenes = [...]` and messages before loading.
    pub fn key(&self) -> String {
        if let Some(name) = &self.name {
            return name.clone();
        }
        let stem = self
            .file
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        if self.params.is_empty() {
            stem
        } else {
            // In name order, so that the same parameters give the same name however they were
            // listed (the command line keeps their order, an experiment's table sorts them).
            let params: Vec<String> = self.sorted_params().iter().map(|(k, v)| format!("{k}={v}")).collect();
            crate::util::file_stem(&format!("{stem}[{}]", params.join(",")))
        }
    }

    /// The parameters sorted by name.
    pub fn sorted_params(&self) -> Vec<(String, String)> {
        let mut params = self.params.clone();
        params.sort();
        params
    }

    pub fn load(&self) -> Result<Scene> {
        let (scene, stats) = self.load_with_stats()?;
        report_stats(&self.file, &stats);
        Ok(scene)
    }

    pub fn load_with_stats(&self) -> Result<(Scene, LoadStats)> {
        let bytes = crate::util::read_input(&self.file, "scene file", crate::util::MAX_TEXT_INPUT)?;
        load_source_bytes(self, &bytes)
    }
}

/// Prints loading's warnings and skipped triangles on stderr.
fn report_stats(path: &Path, stats: &LoadStats) {
    for w in &stats.warnings {
        eprintln!("warning: {w}");
    }
    if stats.degenerate_triangles_skipped > 0 {
        eprintln!(
            "warning: {}: skipped {} degenerate mesh triangle(s)",
            path.display(),
            stats.degenerate_triangles_skipped
        );
    }
}

/// Loads a scene from its bytes; `path` names it in messages, gives the default name and
/// anchors relative mesh paths.
pub fn load_scene_bytes(path: &Path, bytes: &[u8]) -> Result<(Scene, LoadStats)> {
    load_source_bytes(&SceneSource::file(path), bytes)
}

/// [`load_scene_bytes`] for a [`SceneSource`]: its parameters and name apply.
pub fn load_source_bytes(source: &SceneSource, bytes: &[u8]) -> Result<(Scene, LoadStats)> {
    let path = source.file.as_path();
    let ctx = Ctx {
        file: path.display().to_string(),
    };
    // pbrt-v4 reads gzip-compressed scene files; the hash below still covers the file's bytes.
    let plain;
    let bytes = if super::pbrt::is_pbrt(path) && crate::util::is_gzip(path) {
        plain = crate::util::gunzip(bytes, crate::util::MAX_TEXT_INPUT).map_err(|e| ctx.whole(e))?;
        &plain[..]
    } else {
        bytes
    };
    let text = std::str::from_utf8(bytes).map_err(|e| {
        ctx.whole(format!(
            "not valid UTF-8 (first bad byte at offset {})",
            e.valid_up_to()
        ))
    })?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    // Mitsuba scenes become the same description; only how shapes are named in errors and
    // the warnings differ. The hash below covers the XML bytes and meshes as for TOML.
    let (desc, shape_labels, warnings, included) = if is_mitsuba(path) {
        let imported = super::mitsuba::import_with(&ctx.file, &dir, text, &source.params)?;
        (
            imported.desc,
            Some(imported.shape_labels),
            imported.warnings,
            imported.included,
        )
    } else if super::pbrt::is_pbrt(path) && source.params.is_empty() {
        let imported = super::pbrt::import(&ctx.file, &dir, text)?;
        (
            imported.desc,
            Some(imported.shape_labels),
            imported.warnings,
            imported.included,
        )
    } else if let Some((name, _)) = source.params.first() {
        return Err(ctx.whole(format!(
            "parameter {name:?}: scene parameters apply to Mitsuba XML scenes (`$name`), not to TOML scenes"
        )));
    } else {
        (parse_desc(&ctx, text)?, None, Vec::new(), Vec::new())
    };

    let mut b = Builder {
        ctx: &ctx,
        dir,
        primitives: Vec::new(),
        attrs: Vec::new(),
        mesh_attributes: Default::default(),
        shape_starts: Vec::new(),
        hashed: vec![bytes.to_vec()],
        stats: LoadStats {
            warnings,
            ..LoadStats::default()
        },
    };
    // Included Mitsuba files are part of the scene's content, as meshes are; so are the
    // parameters set from outside.
    for (file, bytes) in included {
        b.hashed.push(bytes);
        b.stats.files_read.push(file);
    }
    for (name, value) in &source.sorted_params() {
        b.hashed.push(format!("param {name}={value}").into_bytes());
    }
    let camera = camera(&ctx, &desc.camera)?;
    // The filter changes every pixel; a Mitsuba scene's default one is not in its bytes.
    if let crate::pixel_filter::PixelFilter::Separable(s) = &camera.filter {
        b.hashed
            .push(format!("photon-bench pixel filter v1: {:?}", s.kind).into_bytes());
    }
    // Shapes first, so that `mesh_attribute` textures find the meshes' attributes; materials
    // are numbered in name order, as `materials` numbers them.
    let material_index: std::collections::BTreeMap<String, u32> = (desc.materials.keys().enumerate())
        .map(|(i, name)| (name.clone(), i as u32))
        .collect();
    let shape_field = |i: usize| match &shape_labels {
        Some(labels) => labels[i].clone(),
        None => format!("shapes[{i}]"),
    };
    for (i, shape) in desc.shapes.iter().enumerate() {
        let field = shape_field(i);
        b.shape_starts.push((b.primitives.len(), field.clone()));
        b.shape(&field, shape, &material_index)?;
    }
    let mut textures = textures::Textures::new(&b.dir);
    textures.meshes = Some(textures::MeshData {
        attributes: &b.mesh_attributes,
        attrs: &b.attrs,
        shape_starts: &b.shape_starts,
    });
    let (materials, built_index) = materials(&ctx, &desc.materials, &mut textures)?;
    debug_assert_eq!(built_index, material_index);
    b.hashed.append(&mut textures.hashed);
    b.stats.files_read.append(&mut textures.files_read);
    for (i, shape) in desc.shapes.iter().enumerate() {
        let field = shape_field(i);
        let (material, _, emission) = shape.common();
        if emission.is_some() && materials[material_index[material] as usize].opacity.is_some() {
            // A masked emitter would emit only where its rays stop at it.
            return Err(ctx.err(
                &format!("{field}.material"),
                format!("material {material:?} is a mask: an emitter cannot be masked"),
            ));
        }
    }
    let environment = match &desc.environment {
        Some(e) => Some(environment::environment(
            &ctx,
            &b.dir,
            e,
            &mut b.hashed,
            &mut b.stats.files_read,
        )?),
        None => None,
    };
    // Lights' pictures through the same reader: an image a material already read is not
    // decoded again (nor hashed twice).
    let delta = (desc.lights.iter().enumerate())
        .map(|(i, l)| lights::delta_light(&ctx, i, l, &mut textures))
        .collect::<Result<Vec<_>>>()?;
    b.hashed.append(&mut textures.hashed);
    b.stats.files_read.append(&mut textures.files_read);
    let environment_emits = environment
        .as_ref()
        .is_some_and(|e| e.mean_radiance().max_element() > 0.0);
    let delta_emits = delta.iter().any(|l| l.power(1.0).max_element() > 0.0);
    if !environment_emits
        && !delta_emits
        && !b
            .attrs
            .iter()
            .any(|a| a.emission.is_some_and(|e| e.le.max_element() > 0.0))
    {
        return Err(ctx.whole(
            "no light: give at least one shape `emission = { radiance = [r, g, b] }` with a \
             positive channel, a `[[lights]]` entry, or an `[environment]`",
        ));
    }
    let user_paths = user_paths(&ctx, &desc.user_paths, &b.primitives, &b.attrs)?;
    let (media, medium_index) = media::media(&ctx, &b.dir, &desc.media, &mut b.hashed, &mut b.stats.files_read)?;
    if let (Some(m), false) = (media.iter().find(|m| !m.sample_emitters), delta.is_empty()) {
        // Only light sampling reaches a point, spot, projector or directional light: a medium
        // that samples no emitters would scatter none of their light (Mitsuba renders it so).
        return Err(ctx.err(
            &format!("media.{}.sample_emitters", key_string(&m.name)),
            "expected true in a scene with point, spot, projector or directional lights (only light sampling reaches them)",
        ));
    }
    let camera_medium = media::medium_ref(&ctx, "camera.medium", desc.camera.medium.as_deref(), &medium_index)?;
    for (i, shape) in desc.shapes.iter().enumerate() {
        let field = shape_field(i);
        let (interior, exterior) = shape.media();
        let interior = media::medium_ref(&ctx, &format!("{field}.interior"), interior, &medium_index)?;
        let exterior = media::medium_ref(&ctx, &format!("{field}.exterior"), exterior, &medium_index)?;
        let end = b.shape_starts.get(i + 1).map_or(b.attrs.len(), |s| s.0);
        for a in &mut b.attrs[b.shape_starts[i].0..end] {
            (a.interior, a.exterior) = (interior, exterior);
        }
    }

    let explicit = source.name.clone().or_else(|| desc.name.clone());
    if let Some(name) = &explicit
        && !is_file_name_safe(name)
    {
        // The name labels result rows and becomes part of file names (`references/<name>.exr`,
        // `images/<name>_…`): a separator or a leading dot would put files elsewhere.
        return Err(ctx.err(
            "name",
            format!(
                "expected a non-empty name without '/', '\\', control characters or a leading \
                 '.' or space, got {name:?}"
            ),
        ));
    }
    let name = explicit.unwrap_or_else(|| {
        Some(source.key())
            .filter(|k| !k.is_empty())
            .unwrap_or_else(|| "scene".to_string())
    });
    let parts: Vec<&[u8]> = b.hashed.iter().map(Vec::as_slice).collect();
    let hash = content_hash(&parts);
    let Builder {
        primitives,
        attrs,
        mut stats,
        ..
    } = b;
    stats.triangles = primitives
        .iter()
        .filter(|p| matches!(p, Primitive::Triangle(_)))
        .count();
    stats.spheres = primitives.len() - stats.triangles;
    let mut scene = Scene::assemble_with_emitters(
        name,
        path.to_path_buf(),
        hash,
        camera,
        materials,
        primitives,
        attrs,
        user_paths,
        Emitters { environment, delta },
    )?;
    scene.params = source.sorted_params();
    scene.media = media;
    scene.camera_medium = camera_medium;
    Ok((scene, stats))
}

/// Whether a scene file is a Mitsuba 3 XML scene (by its extension, `.xml`).
pub fn is_mitsuba(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("xml"))
}

/// Reads and deserializes a TOML scene file's description without building the scene.
pub(crate) fn read_desc(path: &Path) -> Result<SceneDesc> {
    let ctx = Ctx {
        file: path.display().to_string(),
    };
    let bytes = crate::util::read_input(path, "scene file", crate::util::MAX_TEXT_INPUT)?;
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        ctx.whole(format!(
            "not valid UTF-8 (first bad byte at offset {})",
            e.valid_up_to()
        ))
    })?;
    parse_desc(&ctx, text)
}

/// A shape's transform as one validated affine map (for the Mitsuba exporter); `file` and
/// `field` name it in errors.
pub(crate) fn shape_transform(file: &str, field: &str, t: Option<&TransformDesc>) -> Result<DAffine3> {
    let ctx = Ctx { file: file.to_string() };
    transform(&ctx, field, t).map(|x| x.m)
}

/// A quad's corner and edges, whichever form it is written in (for the Mitsuba exporter).
pub(crate) fn quad_corner_edges(file: &str, field: &str, q: &desc::Quad) -> Result<(DVec3, DVec3, DVec3)> {
    let ctx = Ctx { file: file.to_string() };
    quad_frame(&ctx, field, q)
}

/// A name that can be used as (part of) a file name in any directory: non-empty, no path
/// separator or control character, and no leading dot or surrounding white space.
fn is_file_name_safe(name: &str) -> bool {
    !name.is_empty()
        && name.trim() == name
        && !name.starts_with('.')
        && !name.chars().any(|c| c == '/' || c == '\\' || c.is_control())
}

/// The scene file's name, prefixed to every message.
struct Ctx {
    file: String,
}

impl Ctx {
    /// An error about one field.
    fn err(&self, field: &str, msg: impl fmt::Display) -> Error {
        Error::new(format!("{}: {field}: {msg}", self.file))
    }

    /// An error about the file as a whole.
    fn whole(&self, msg: impl fmt::Display) -> Error {
        Error::new(format!("{}: {msg}", self.file))
    }
}

// ---------------------------------------------------------------------------------------------
// Stages 1 and 2: TOML and the serde model.

// ---------------------------------------------------------------------------------------------
// Stage 3: meaning. Small validators first; each returns the value in the type the renderer uses.
