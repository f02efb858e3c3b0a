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

use super::desc::{self, ConeDeg, MaterialDesc, Scale, SceneDesc, ShapeDesc, TransformDesc, Triple};
use super::{Material, PrimAttrs, Scene, UserPath};
use crate::bsdf::{Bsdf, Dielectric, DiffuseTransmission, Lambertian, Mirror, Phong, Ward};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::geometry::Primitive;
use crate::light::Emission;
use crate::resources::{check_memory, film_bytes, memory_limit};
use crate::util::content_hash;
use glam::{DAffine3, DMat3, DVec3, Vec3};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// Largest magnitude accepted for any coordinate, size or translation, before and after
/// transforming. f32 keeps about 7 significant digits, so beyond this a scene of ordinary
/// detail loses its geometry to rounding.
pub const MAX_COORD: f64 = 1e7;
/// Largest image side, in pixels.
pub const MAX_RESOLUTION_SIDE: u32 = 16384;
/// Largest image, in pixels (64 Mpixel): refused before any film is allocated.
pub const MAX_PIXELS: u64 = 64 << 20;
/// Largest emitted radiance per channel; keeps light powers finite in f32.
pub const MAX_RADIANCE: f64 = 1e10;
/// Largest Phong exponent; beyond it the lobe is a mirror for any practical purpose.
pub const MAX_PHONG_EXPONENT: f64 = 1e6;
/// Largest `subdivide` of a quad or box: 2 · 1024² ≈ 2 M triangles per face.
pub const MAX_SUBDIVIDE: i64 = 1024;
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
    let (scene, stats) = load_scene_with_stats(path)?;
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
    Ok(scene)
}

/// Loads and validates a scene file, and says what it skipped.
pub fn load_scene_with_stats(path: &Path) -> Result<(Scene, LoadStats)> {
    let bytes =
        std::fs::read(path).map_err(|e| Error::new(format!("{}: cannot read the scene file: {e}", path.display())))?;
    load_scene_bytes(path, &bytes)
}

/// Loads a scene from its bytes; `path` names it in messages, gives the default name and
/// anchors relative mesh paths.
pub fn load_scene_bytes(path: &Path, bytes: &[u8]) -> Result<(Scene, LoadStats)> {
    let ctx = Ctx {
        file: path.display().to_string(),
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
    let (desc, shape_labels, warnings) = if is_mitsuba(path) {
        let imported = super::mitsuba::import(&ctx.file, &dir, text)?;
        (imported.desc, Some(imported.shape_labels), imported.warnings)
    } else {
        (parse_desc(&ctx, text)?, None, Vec::new())
    };

    let mut b = Builder {
        ctx: &ctx,
        dir,
        primitives: Vec::new(),
        attrs: Vec::new(),
        hashed: vec![bytes.to_vec()],
        stats: LoadStats {
            warnings,
            ..LoadStats::default()
        },
    };
    let camera = camera(&ctx, &desc.camera)?;
    let (materials, material_index) = materials(&ctx, &desc.materials)?;
    for (i, shape) in desc.shapes.iter().enumerate() {
        let field = match &shape_labels {
            Some(labels) => labels[i].clone(),
            None => format!("shapes[{i}]"),
        };
        b.shape(&field, shape, &material_index)?;
    }
    if !b
        .attrs
        .iter()
        .any(|a| a.emission.is_some_and(|e| e.le.max_element() > 0.0))
    {
        return Err(ctx.whole(
            "no light: give at least one shape `emission = { radiance = [r, g, b] }` with a \
             positive channel",
        ));
    }
    let user_paths = user_paths(&ctx, &desc.user_paths, &b.primitives, &b.attrs)?;

    if let Some(name) = &desc.name
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
    let name = desc.name.clone().unwrap_or_else(|| {
        path.file_stem()
            .map(|s| s.to_string_lossy().into_owned())
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
    let scene = Scene::assemble(
        name,
        path.to_path_buf(),
        hash,
        camera,
        materials,
        primitives,
        attrs,
        user_paths,
    )?;
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
    let bytes =
        std::fs::read(path).map_err(|e| Error::new(format!("{}: cannot read the scene file: {e}", path.display())))?;
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

/// Parses the TOML and deserializes the model, turning byte spans into key paths and
/// line/column positions.
fn parse_desc(ctx: &Ctx, text: &str) -> Result<SceneDesc> {
    let doc = DeTable::parse(text).map_err(|e| {
        let at = e
            .span()
            .map(|s| format!(" at {}", line_col(text, s.start)))
            .unwrap_or_default();
        ctx.whole(format!("TOML syntax error{at}: {}", e.message()))
    })?;
    let root = Spanned::new(doc.span(), DeValue::Table(doc.get_ref().clone()));
    let e = match SceneDesc::deserialize(toml::de::Deserializer::from(doc)) {
        Ok(desc) => return Ok(desc),
        Err(e) => e,
    };
    let Some(span) = e.span() else {
        return Err(ctx.whole(e.message()));
    };
    let mut path = Vec::new();
    find_path(&root, span.start, &mut path);
    let (path, message, pos) =
        refine_tagged(&root, &path).unwrap_or_else(|| (path, e.message().to_string(), span.start));
    let field = path_string(&path);
    let msg = format!("{message} ({})", line_col(text, pos));
    Err(if field.is_empty() {
        ctx.whole(msg)
    } else {
        ctx.err(&field, msg)
    })
}

/// One step of a key path.
#[derive(Clone, Debug, PartialEq)]
enum Seg {
    Key(String),
    Index(usize),
}

fn path_string(path: &[Seg]) -> String {
    let mut s = String::new();
    for seg in path {
        match seg {
            Seg::Key(k) => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(&key_string(k));
            }
            Seg::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

/// A key as it would be written in TOML: bare when possible, quoted otherwise.
fn key_string(k: &str) -> String {
    let bare = !k.is_empty() && k.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if bare { k.to_string() } else { format!("{k:?}") }
}

fn line_col(text: &str, pos: usize) -> String {
    let before = text.get(..pos).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    format!("line {line}, column {col}")
}

fn span_contains(span: std::ops::Range<usize>, pos: usize) -> bool {
    span.contains(&pos) || (span.is_empty() && span.start == pos)
}

/// Appends to `path` the keys leading to the deepest key or value whose span holds `pos`.
/// Tables of an array of tables (`[[shapes]]`) span only their header, so children are
/// searched even when their parent's span does not hold `pos`.
fn find_path(v: &Spanned<DeValue>, pos: usize, path: &mut Vec<Seg>) -> bool {
    match v.get_ref() {
        DeValue::Table(t) => {
            for (k, val) in t.iter() {
                path.push(Seg::Key(k.get_ref().to_string()));
                if span_contains(k.span(), pos) {
                    return true;
                }
                if find_path(val, pos, path) || span_contains(val.span(), pos) {
                    return true;
                }
                path.pop();
            }
            false
        }
        DeValue::Array(a) => {
            for (i, item) in a.iter().enumerate() {
                path.push(Seg::Index(i));
                if find_path(item, pos, path) || span_contains(item.span(), pos) {
                    return true;
                }
                path.pop();
            }
            false
        }
        _ => false,
    }
}

fn lookup<'a, 'i>(root: &'a Spanned<DeValue<'i>>, path: &[Seg]) -> Option<&'a Spanned<DeValue<'i>>> {
    let mut v = root;
    for seg in path {
        v = match (v.get_ref(), seg) {
            (DeValue::Table(t), Seg::Key(k)) => t.get(k.as_str())?,
            (DeValue::Array(a), Seg::Index(i)) => a.get(*i)?,
            _ => return None,
        };
    }
    Some(v)
}

/// serde deserializes an internally tagged enum (`type = "sphere"`) from a buffered copy of
/// the table, which loses positions: an error inside a shape or material points at the whole
/// `shapes` array or `materials` table, not even at the element. This deserializes each
/// element's variant struct again, straight from the document, which does carry positions, and
/// returns the key path, message and position of the first error found.
fn refine_tagged(root: &Spanned<DeValue>, path: &[Seg]) -> Option<(Vec<Seg>, String, usize)> {
    let Some(Seg::Key(collection)) = path.first() else {
        return None;
    };
    // Deeper paths (e.g. `shapes[2].type` for an unknown type) are already precise.
    if !(collection == "shapes" || collection == "materials") || path.len() > 2 {
        return None;
    }
    let is_shape = collection == "shapes";
    let elements: Vec<(Seg, &Spanned<DeValue>)> = match lookup(root, &path[..1])?.get_ref() {
        DeValue::Array(a) => a.iter().enumerate().map(|(i, v)| (Seg::Index(i), v)).collect(),
        DeValue::Table(t) => t.iter().map(|(k, v)| (Seg::Key(k.get_ref().to_string()), v)).collect(),
        _ => return None,
    };
    for (seg, node) in elements {
        let at = vec![path[0].clone(), seg];
        let DeValue::Table(table) = node.get_ref() else {
            continue;
        };
        let Some(kind) = table.get("type") else {
            return Some((at, "missing field `type`".into(), node.span().start));
        };
        let Some(kind) = kind.get_ref().as_str() else {
            continue;
        };
        let mut inner = DeTable::new();
        for (k, v) in table.iter() {
            if k.get_ref() != "type" {
                inner.insert(k.clone(), v.clone());
            }
        }
        let value = Spanned::new(node.span(), DeValue::Table(inner));
        let de = toml::de::ValueDeserializer::from(value);
        let err = match (is_shape, kind) {
            (true, "quad") => desc::Quad::deserialize(de).err(),
            (true, "box") => desc::Cuboid::deserialize(de).err(),
            (true, "sphere") => desc::Sphere::deserialize(de).err(),
            (true, "mesh") => desc::Mesh::deserialize(de).err(),
            (false, "diffuse") => desc::Diffuse::deserialize(de).err(),
            (false, "mirror") => desc::Mirror::deserialize(de).err(),
            (false, "dielectric") => desc::Dielectric::deserialize(de).err(),
            (false, "phong") => desc::Phong::deserialize(de).err(),
            (false, "ward") => desc::Ward::deserialize(de).err(),
            (false, "diffuse_transmission") => desc::DiffuseTransmission::deserialize(de).err(),
            // serde itself reports unknown types, precisely, at the `type` value.
            _ => None,
        };
        let Some(err) = err else {
            continue;
        };
        let pos = err.span().map_or(node.span().start, |s| s.start);
        let mut refined = Vec::new();
        find_path(root, pos, &mut refined);
        // Keep the refined path only if it lies inside this element.
        if !refined.starts_with(&at) {
            refined = at;
        }
        return Some((refined, err.message().to_string(), pos));
    }
    None
}

// ---------------------------------------------------------------------------------------------
// Stage 3: meaning. Small validators first; each returns the value in the type the renderer uses.

/// A number as a reader would write it: exponents for very large or small magnitudes.
fn num(v: f64) -> String {
    let a = v.abs();
    if v.is_finite() && a != 0.0 && !(1e-4..1e7).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// A computed number (a distance, a determinant) to 4 significant digits.
fn approx(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        return "0".to_string();
    }
    if !v.is_finite() || !(1e-4..1e7).contains(&a) {
        return format!("{v:.3e}");
    }
    let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

fn triple(v: impl Into<Triple>) -> String {
    let v = v.into();
    format!("[{}, {}, {}]", num(v[0]), num(v[1]), num(v[2]))
}

fn dvec(v: Triple) -> DVec3 {
    DVec3::from_array(v.0)
}

fn rgb(v: Triple) -> Vec3 {
    dvec(v).as_vec3()
}

fn is_coord(v: f64) -> bool {
    v.is_finite() && v.abs() <= MAX_COORD
}

impl Ctx {
    /// A point or vector: finite, every coordinate within ±[`MAX_COORD`].
    fn coords(&self, field: &str, v: Triple) -> Result<DVec3> {
        if v.iter().all(|&c| is_coord(c)) {
            Ok(dvec(v))
        } else {
            Err(self.err(
                field,
                format!(
                    "expected finite coordinates of magnitude at most {}, got {}",
                    num(MAX_COORD),
                    triple(v)
                ),
            ))
        }
    }

    /// A length such as a radius: positive, finite, at most [`MAX_COORD`].
    fn positive(&self, field: &str, v: f64) -> Result<f64> {
        if v > 0.0 && is_coord(v) {
            Ok(v)
        } else {
            Err(self.err(field, format!("expected a positive finite number, got {}", num(v))))
        }
    }

    /// Positive sizes per axis.
    fn sizes<const N: usize>(&self, field: &str, v: [f64; N]) -> Result<[f64; N]> {
        if v.iter().all(|&c| c > 0.0 && is_coord(c)) {
            Ok(v)
        } else {
            let list: Vec<String> = v.iter().map(|&c| num(c)).collect();
            Err(self.err(
                field,
                format!("expected positive finite sizes, got [{}]", list.join(", ")),
            ))
        }
    }

    /// A reflectance-like colour: every channel in [0, 1].
    fn unit_rgb(&self, field: &str, v: Triple) -> Result<Triple> {
        if v.iter().all(|c| (0.0..=1.0).contains(c)) {
            Ok(v)
        } else {
            Err(self.err(field, format!("expected each channel in [0, 1], got {}", triple(v))))
        }
    }

    /// Two colours whose sum must not exceed 1 per channel (energy conservation).
    fn energy(&self, field: &str, what: &str, a: Triple, b: Triple) -> Result<()> {
        if (0..3).all(|i| a[i] + b[i] <= 1.0 + 1e-6) {
            Ok(())
        } else {
            let sum = [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
            Err(self.err(
                field,
                format!(
                    "{what} must not exceed 1 in any channel (energy conservation), got {}",
                    triple(sum)
                ),
            ))
        }
    }
}

fn camera(ctx: &Ctx, c: &desc::CameraDesc) -> Result<Camera> {
    let [w, h] = c.resolution.0;
    if !(1..=MAX_RESOLUTION_SIDE).contains(&w) || !(1..=MAX_RESOLUTION_SIDE).contains(&h) {
        return Err(ctx.err(
            "camera.resolution",
            format!("expected width and height in 1..={MAX_RESOLUTION_SIDE}, got [{w}, {h}]"),
        ));
    }
    if w as u64 * h as u64 > MAX_PIXELS {
        return Err(ctx.err(
            "camera.resolution",
            format!("{w} × {h} pixels exceeds the limit of {} Mpixel", MAX_PIXELS >> 20),
        ));
    }
    // Before any film is allocated: a film this machine cannot hold is refused here, not
    // killed by the kernel halfway through a run.
    let film = format!("a {w} × {h} film");
    check_memory(&film, film_bytes(w, h), memory_limit()?).map_err(|e| ctx.err("camera.resolution", e))?;
    if !(c.fov_y > 0.0 && c.fov_y < 180.0) {
        return Err(ctx.err(
            "camera.fov_y",
            format!("expected degrees in (0, 180), got {}", num(c.fov_y)),
        ));
    }
    let eye = ctx.coords("camera.eye", c.eye)?;
    let look_at = ctx.coords("camera.look_at", c.look_at)?;
    let up = ctx.coords("camera.up", c.up)?;
    let dir = look_at - eye;
    // Closer than f32 can resolve at these coordinates counts as equal.
    let scale = eye.abs().max_element().max(look_at.abs().max_element());
    if dir.length() <= 1e-6 * scale || dir.length() == 0.0 {
        return Err(ctx.err(
            "camera.look_at",
            format!("must differ from camera.eye, both are {}", triple(c.eye)),
        ));
    }
    let sin = dir.normalize().cross(up.normalize_or_zero()).length();
    if sin.is_nan() || sin <= 1e-3 {
        return Err(ctx.err(
            "camera.up",
            format!(
                "must be non-zero and not parallel to the view direction (look_at - eye), got {}",
                triple(c.up)
            ),
        ));
    }
    Ok(Camera::new(
        eye.as_vec3(),
        look_at.as_vec3(),
        up.as_vec3(),
        c.fov_y as f32,
        w,
        h,
    ))
}

/// Validates every material and builds them in name order; returns the name → index map.
fn materials(ctx: &Ctx, descs: &BTreeMap<String, MaterialDesc>) -> Result<(Vec<Material>, BTreeMap<String, u32>)> {
    let mut out = Vec::with_capacity(descs.len());
    let mut index = BTreeMap::new();
    for (name, d) in descs {
        let field = format!("materials.{}", key_string(name));
        validate_material(ctx, &field, d)?;
        index.insert(name.clone(), out.len() as u32);
        out.push(Material {
            name: name.clone(),
            bsdf: make_bsdf(d).map_err(|e| e.context(format!("{}: {field}", ctx.file)))?,
        });
    }
    Ok((out, index))
}

fn validate_material(ctx: &Ctx, field: &str, d: &MaterialDesc) -> Result<()> {
    let f = |key: &str| format!("{field}.{key}");
    match d {
        MaterialDesc::Diffuse(m) => {
            ctx.unit_rgb(&f("reflectance"), m.reflectance)?;
        }
        MaterialDesc::Mirror(m) => {
            ctx.unit_rgb(&f("reflectance"), m.reflectance)?;
        }
        MaterialDesc::Dielectric(m) => {
            if !(m.ior > 0.0 && (m.ior as f32).is_finite()) {
                return Err(ctx.err(
                    &f("ior"),
                    format!("expected a positive finite number, got {}", num(m.ior)),
                ));
            }
        }
        MaterialDesc::Phong(m) => {
            ctx.unit_rgb(&f("diffuse"), m.diffuse)?;
            ctx.unit_rgb(&f("specular"), m.specular)?;
            ctx.energy(field, "diffuse + specular", m.diffuse, m.specular)?;
            if !(0.0..=MAX_PHONG_EXPONENT).contains(&m.exponent) {
                return Err(ctx.err(
                    &f("exponent"),
                    format!(
                        "expected a number in [0, {}], got {}",
                        num(MAX_PHONG_EXPONENT),
                        num(m.exponent)
                    ),
                ));
            }
        }
        MaterialDesc::Ward(m) => {
            ctx.unit_rgb(&f("diffuse"), m.diffuse)?;
            ctx.unit_rgb(&f("specular"), m.specular)?;
            ctx.energy(field, "diffuse + specular", m.diffuse, m.specular)?;
            for (key, a) in [("alpha_x", m.alpha_x), ("alpha_y", m.alpha_y)] {
                if !(a > 0.0 && a <= 1.0) {
                    return Err(ctx.err(&f(key), format!("expected a roughness in (0, 1], got {}", num(a))));
                }
            }
        }
        MaterialDesc::DiffuseTransmission(m) => {
            ctx.unit_rgb(&f("reflectance"), m.reflectance)?;
            ctx.unit_rgb(&f("transmittance"), m.transmittance)?;
            ctx.energy(field, "reflectance + transmittance", m.reflectance, m.transmittance)?;
        }
    }
    Ok(())
}

/// Turns a validated material description into its reflectance model: the one place that
/// knows both the file's material types and the [`Bsdf`] variants.
fn make_bsdf(d: &MaterialDesc) -> Result<Bsdf> {
    let bsdf = match d {
        MaterialDesc::Diffuse(m) => Bsdf::Lambertian(Lambertian {
            reflectance: rgb(m.reflectance),
        }),
        MaterialDesc::Mirror(m) => Bsdf::Mirror(Mirror {
            reflectance: rgb(m.reflectance),
        }),
        MaterialDesc::Dielectric(m) => Bsdf::Dielectric(Dielectric::clear(m.ior as f32)),
        MaterialDesc::Phong(m) => Bsdf::Phong(Phong {
            diffuse: rgb(m.diffuse),
            specular: rgb(m.specular),
            exponent: m.exponent as f32,
        }),
        MaterialDesc::Ward(m) => Bsdf::Ward(Ward {
            diffuse: rgb(m.diffuse),
            specular: rgb(m.specular),
            alpha_x: m.alpha_x as f32,
            alpha_y: m.alpha_y as f32,
        }),
        MaterialDesc::DiffuseTransmission(m) => Bsdf::DiffuseTransmission(DiffuseTransmission {
            reflectance: rgb(m.reflectance),
            transmittance: rgb(m.transmittance),
        }),
    };
    // The description was validated field by field; this is the models' own check, kept as a
    // second line of defence (f64 → f32 rounding could tip a sum over 1).
    bsdf.validate()?;
    Ok(bsdf)
}

/// An affine map from shape space to world space.
#[derive(Clone, Copy, Debug)]
struct Xform {
    m: DAffine3,
    /// Inverse transpose of the linear part: maps normals.
    normal_matrix: DMat3,
    /// The map mirrors: triangle windings must be reversed to keep their front side.
    flips: bool,
}

impl Xform {
    fn point(&self, p: DVec3) -> DVec3 {
        self.m.transform_point3(p)
    }
}

/// Composes a transform description into one affine map, refusing non-finite, non-affine and
/// degenerate ones.
fn transform(ctx: &Ctx, field: &str, t: Option<&TransformDesc>) -> Result<Xform> {
    let steps = t.map_or(&[][..], |t| &t.0[..]);
    let mut m = DAffine3::IDENTITY;
    for (j, step) in steps.iter().enumerate() {
        let field = if steps.len() == 1 {
            format!("{field}.transform")
        } else {
            format!("{field}.transform[{j}]")
        };
        let step_m = if let Some(rows) = step.matrix {
            let others = step.scale.is_some()
                || step.rotate_x.is_some()
                || step.rotate_y.is_some()
                || step.rotate_z.is_some()
                || step.translate.is_some();
            if others {
                return Err(ctx.err(
                    &field,
                    "`matrix` cannot share a step with scale/rotate/translate; use a list of \
                     steps, e.g. [{ matrix = … }, { translate = … }]",
                ));
            }
            if !rows.iter().flat_map(|r| r.iter()).all(|&x| is_coord(x)) {
                return Err(ctx.err(
                    &format!("{field}.matrix"),
                    format!("expected finite entries of magnitude at most {}", num(MAX_COORD)),
                ));
            }
            if rows[3].0 != [0.0, 0.0, 0.0, 1.0] {
                return Err(ctx.err(
                    &format!("{field}.matrix"),
                    "the last row must be [0, 0, 0, 1] (affine transforms only)",
                ));
            }
            let col = |j: usize| DVec3::new(rows[0][j], rows[1][j], rows[2][j]);
            DAffine3::from_mat3_translation(DMat3::from_cols(col(0), col(1), col(2)), col(3))
        } else {
            let s = match step.scale {
                None => DVec3::ONE,
                Some(Scale::Uniform(s)) => DVec3::splat(s),
                Some(Scale::PerAxis(s)) => dvec(s),
            };
            if !s.to_array().iter().all(|&c| c != 0.0 && is_coord(c)) {
                return Err(ctx.err(
                    &format!("{field}.scale"),
                    format!("expected non-zero finite factors, got {}", triple(s.to_array())),
                ));
            }
            let mut r = DMat3::IDENTITY;
            for (key, angle, rot) in [
                ("rotate_x", step.rotate_x, DMat3::from_rotation_x as fn(f64) -> DMat3),
                ("rotate_y", step.rotate_y, DMat3::from_rotation_y),
                ("rotate_z", step.rotate_z, DMat3::from_rotation_z),
            ] {
                if let Some(deg) = angle {
                    if !is_coord(deg) {
                        return Err(ctx.err(
                            &format!("{field}.{key}"),
                            format!("expected a finite angle in degrees, got {}", num(deg)),
                        ));
                    }
                    r = rot(deg.to_radians()) * r;
                }
            }
            let tr = match step.translate {
                Some(tr) => ctx.coords(&format!("{field}.translate"), tr)?,
                None => DVec3::ZERO,
            };
            DAffine3::from_mat3_translation(r * DMat3::from_diagonal(s), tr)
        };
        m = step_m * m;
    }
    let l = m.matrix3;
    let det = l.determinant();
    let stretch = l.x_axis.length().max(l.y_axis.length()).max(l.z_axis.length());
    let field = format!("{field}.transform");
    if !(det.is_finite() && det.abs() > 1e-12 * stretch.powi(3)) {
        return Err(ctx.err(
            &field,
            format!("degenerate transform (determinant {}): it flattens shapes", approx(det)),
        ));
    }
    if !m.translation.to_array().iter().all(|&c| is_coord(c)) {
        return Err(ctx.err(
            &field,
            format!(
                "the composed translation {} exceeds magnitude {}",
                triple(m.translation.to_array()),
                num(MAX_COORD)
            ),
        ));
    }
    Ok(Xform {
        m,
        normal_matrix: l.inverse().transpose(),
        flips: det < 0.0,
    })
}

/// Builds primitives shape by shape and remembers every file it read for the content hash.
struct Builder<'a> {
    ctx: &'a Ctx,
    /// Directory of the scene file: relative mesh paths start here.
    dir: PathBuf,
    primitives: Vec<Primitive>,
    attrs: Vec<PrimAttrs>,
    /// The scene file's bytes, then every mesh and MTL file's bytes in reading order.
    hashed: Vec<Vec<u8>>,
    stats: LoadStats,
}

/// Why a triangle could not be added.
enum TriangleError {
    /// Zero area at f32 precision.
    Degenerate,
    /// A transformed vertex, as a message.
    OutOfRange(String),
}

impl Builder<'_> {
    fn shape(&mut self, field: &str, shape: &ShapeDesc, material_index: &BTreeMap<String, u32>) -> Result<()> {
        let ctx = self.ctx;
        let (material_name, t, emission) = shape.common();
        let Some(&material) = material_index.get(material_name) else {
            let known: Vec<String> = material_index.keys().map(|k| key_string(k)).collect();
            let known = if known.is_empty() {
                "no materials are defined".to_string()
            } else {
                format!("defined: {}", known.join(", "))
            };
            return Err(ctx.err(
                &format!("{field}.material"),
                format!("no material named {material_name:?} ({known})"),
            ));
        };
        let emission = match emission {
            None => None,
            Some(e) => {
                let ok = e.radiance.iter().all(|&c| (0.0..=MAX_RADIANCE).contains(&c));
                if !ok {
                    return Err(ctx.err(
                        &format!("{field}.emission.radiance"),
                        format!(
                            "expected each channel finite in [0, {}], got {}",
                            num(MAX_RADIANCE),
                            triple(e.radiance)
                        ),
                    ));
                }
                Some(Emission {
                    le: rgb(e.radiance),
                    two_sided: e.two_sided,
                })
            }
        };
        let attrs = PrimAttrs {
            material,
            normals: None,
            emission,
        };
        let xf = transform(ctx, field, t)?;
        match shape {
            ShapeDesc::Quad(q) => {
                let (corner, u, v) = quad_frame(ctx, field, q)?;
                let n = self.subdivision(field, q.subdivide, 2)?;
                self.quad(field, &xf, corner, u, v, n, attrs)
            }
            ShapeDesc::Box(b) => {
                let (lo, hi) = match (b.min, b.max, b.center, b.size) {
                    (Some(lo), Some(hi), None, None) => {
                        let lo = ctx.coords(&format!("{field}.min"), lo)?;
                        let hi = ctx.coords(&format!("{field}.max"), hi)?;
                        if !lo.cmplt(hi).all() {
                            return Err(ctx.err(
                                &format!("{field}.max"),
                                format!(
                                    "expected max > min on every axis, got min = {}, max = {}",
                                    triple(lo.to_array()),
                                    triple(hi.to_array())
                                ),
                            ));
                        }
                        (lo, hi)
                    }
                    (None, None, Some(c), Some(s)) => {
                        let c = ctx.coords(&format!("{field}.center"), c)?;
                        let s = DVec3::from_array(ctx.sizes(&format!("{field}.size"), s.0)?);
                        (c - 0.5 * s, c + 0.5 * s)
                    }
                    _ => {
                        return Err(ctx.err(field, "a box needs either `min` and `max` or `center` and `size`"));
                    }
                };
                let n = self.subdivision(field, b.subdivide, 12)?;
                let d = hi - lo;
                let (x, y, z) = (d.x * DVec3::X, d.y * DVec3::Y, d.z * DVec3::Z);
                // Six faces, each edge_u × edge_v pointing out of the box.
                let faces = [
                    (lo, z, y),
                    (DVec3::new(hi.x, lo.y, lo.z), y, z),
                    (lo, x, z),
                    (DVec3::new(lo.x, hi.y, lo.z), z, x),
                    (lo, y, x),
                    (DVec3::new(lo.x, lo.y, hi.z), x, y),
                ];
                for (corner, u, v) in faces {
                    self.quad(field, &xf, corner, u, v, n, attrs)?;
                }
                Ok(())
            }
            ShapeDesc::Sphere(s) => {
                let center = ctx.coords(&format!("{field}.center"), s.center)?;
                let radius = ctx.positive(&format!("{field}.radius"), s.radius)?;
                // A sphere stays a sphere only under a similarity: LᵀL = s² I.
                let l = xf.m.matrix3;
                let g = l.transpose() * l;
                let s2 = (g.x_axis.x + g.y_axis.y + g.z_axis.z) / 3.0;
                let off = (g - DMat3::from_diagonal(DVec3::splat(s2))).to_cols_array();
                if off.iter().any(|x| x.abs() > 1e-6 * s2) {
                    return Err(ctx.err(
                        &format!("{field}.transform"),
                        "a sphere accepts only rotations, translations and uniform scale",
                    ));
                }
                let c = xf.point(center);
                let r = radius * s2.sqrt();
                if !(c.to_array().iter().all(|&x| is_coord(x)) && r > 0.0 && is_coord(r)) {
                    return Err(ctx.err(
                        field,
                        format!(
                            "the transformed sphere (center {}, radius {}) exceeds magnitude {}",
                            triple(c.to_array()),
                            num(r),
                            num(MAX_COORD)
                        ),
                    ));
                }
                self.primitives.push(Primitive::Sphere {
                    center: c.as_vec3(),
                    radius: r as f32,
                });
                self.attrs.push(attrs);
                Ok(())
            }
            ShapeDesc::Mesh(m) => self.mesh(field, m, &xf, attrs),
        }
    }

    /// The validated `subdivide` of `field` (default 1), after checking that the
    /// `triangles_per_cell` · n² triangles it adds fit in the memory limit.
    fn subdivision(&mut self, field: &str, subdivide: Option<i64>, triangles_per_cell: u64) -> Result<u32> {
        let Some(n) = subdivide else { return Ok(1) };
        let field = format!("{field}.subdivide");
        if !(1..=MAX_SUBDIVIDE).contains(&n) {
            return Err(self.ctx.err(
                &field,
                format!("expected an integer in 1..={MAX_SUBDIVIDE} (cells per edge), got {n}"),
            ));
        }
        let triangles = self.primitives.len() as u64 + triangles_per_cell * (n * n) as u64;
        check_memory("the scene's triangles", triangles * BYTES_PER_TRIANGLE, memory_limit()?)
            .map_err(|e| self.ctx.err(&field, e))?;
        if n > 1 && !self.hashed.iter().any(|h| h == SUBDIVIDE_HASH_TAG) {
            self.hashed.push(SUBDIVIDE_HASH_TAG.to_vec());
        }
        Ok(n as u32)
    }

    /// Adds the parallelogram corner + s·u + t·v as an n × n grid of cells, two triangles each,
    /// facing u × v. Cell corners are computed from the integer grid indices (never by
    /// accumulating steps), so neighbouring cells share their vertices exactly: no cracks.
    #[allow(clippy::too_many_arguments)]
    fn quad(
        &mut self,
        field: &str,
        xf: &Xform,
        corner: DVec3,
        u: DVec3,
        v: DVec3,
        n: u32,
        attrs: PrimAttrs,
    ) -> Result<()> {
        let at = |i: u32, j: u32| corner + u * (f64::from(i) / f64::from(n)) + v * (f64::from(j) / f64::from(n));
        for j in 0..n {
            for i in 0..n {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                self.cell(field, xf, [a, b, c, d], attrs)?;
            }
        }
        Ok(())
    }

    /// Adds one parallelogram a b c d (counter-clockwise about its front) as two triangles.
    fn cell(&mut self, field: &str, xf: &Xform, [a, b, c, d]: [DVec3; 4], attrs: PrimAttrs) -> Result<()> {
        for tri in [[a, b, c], [a, c, d]] {
            match self.triangle(xf, tri, None, attrs) {
                Ok(()) => {}
                Err(TriangleError::OutOfRange(msg)) => return Err(self.ctx.err(field, msg)),
                Err(TriangleError::Degenerate) => {
                    return Err(self.ctx.err(
                        field,
                        "the shape has zero area at f32 precision after transforming (too \
                         small for its distance from the origin)",
                    ));
                }
            }
        }
        Ok(())
    }

    /// Transforms and adds one triangle, given CCW about its intended front side.
    fn triangle(
        &mut self,
        xf: &Xform,
        v: [DVec3; 3],
        normals: Option<[DVec3; 3]>,
        attrs: PrimAttrs,
    ) -> std::result::Result<(), TriangleError> {
        let mut w = v.map(|p| xf.point(p));
        for p in w {
            if !p.to_array().iter().all(|&c| is_coord(c)) {
                return Err(TriangleError::OutOfRange(format!(
                    "a transformed vertex {} exceeds magnitude {}",
                    triple(p.to_array()),
                    num(MAX_COORD)
                )));
            }
        }
        let mut n = normals.and_then(|ns| {
            let ns = ns.map(|n| (xf.normal_matrix * n).normalize_or_zero().as_vec3());
            ns.iter().all(|n| n.is_finite() && *n != Vec3::ZERO).then_some(ns)
        });
        if xf.flips {
            w.swap(1, 2);
            if let Some(ns) = n.as_mut() {
                ns.swap(1, 2);
            }
        }
        let p = w.map(|p| p.as_vec3());
        if is_degenerate(p) {
            return Err(TriangleError::Degenerate);
        }
        self.primitives.push(Primitive::Triangle(p));
        self.attrs.push(PrimAttrs { normals: n, ..attrs });
        Ok(())
    }

    fn mesh(&mut self, field: &str, m: &desc::Mesh, xf: &Xform, attrs: PrimAttrs) -> Result<()> {
        let ctx = self.ctx;
        let file_field = format!("{field}.file");
        let path = self.dir.join(&m.file);
        let shown = path.display();
        let bytes = read_regular_file(&path).map_err(|e| ctx.err(&file_field, format!("cannot read {shown}: {e}")))?;
        self.stats.files_read.push(path.clone());
        let obj_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        // MTL libraries are read for the hash only; the scene's `material` is used, so tobj
        // gets none (which also keeps its MTL parser, which can panic on short colour lines,
        // away from our inputs).
        let mtl = std::cell::RefCell::new(Vec::<(PathBuf, Vec<u8>)>::new());
        let options = tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ignore_points: true,
            ignore_lines: true,
        };
        let parsed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            tobj::load_obj_buf(&mut &bytes[..], &options, |p| {
                let p = obj_dir.join(p);
                if let Ok(b) = read_regular_file(&p) {
                    mtl.borrow_mut().push((p, b));
                }
                Err(tobj::LoadError::GenericFailure)
            })
        }));
        let models = match parsed {
            Ok(Ok((models, _materials))) => models,
            Ok(Err(e)) => return Err(ctx.err(&file_field, format!("{shown}: {e}"))),
            Err(_) => {
                return Err(ctx.err(&file_field, format!("{shown}: the OBJ parser failed")));
            }
        };
        self.hashed.push(bytes);
        for (p, b) in mtl.into_inner() {
            self.stats.files_read.push(p);
            self.hashed.push(b);
        }

        let (mut added, mut skipped) = (0usize, 0usize);
        for model in &models {
            let mesh = &model.mesh;
            let pos = &mesh.positions;
            if let Some(bad) = pos.iter().position(|x| !x.is_finite() || x.abs() as f64 > MAX_COORD) {
                return Err(ctx.err(
                    &file_field,
                    format!(
                        "{shown}: vertex {} of object {:?} has a non-finite or huge coordinate",
                        bad / 3 + 1,
                        model.name
                    ),
                ));
            }
            let n_vertices = pos.len() / 3;
            let has_normals = !m.face_normals && !mesh.normals.is_empty() && mesh.normals.len() == pos.len();
            let vertex = |i: usize| DVec3::new(pos[3 * i] as f64, pos[3 * i + 1] as f64, pos[3 * i + 2] as f64);
            let normal = |i: usize| {
                let n = &mesh.normals;
                DVec3::new(n[3 * i] as f64, n[3 * i + 1] as f64, n[3 * i + 2] as f64)
            };
            for tri in mesh.indices.chunks(3) {
                let &[i, j, k] = tri else {
                    return Err(ctx.err(&file_field, format!("{shown}: a face is not a triangle")));
                };
                let idx = [i as usize, j as usize, k as usize];
                if idx.iter().any(|&i| i >= n_vertices) {
                    return Err(ctx.err(&file_field, format!("{shown}: a face index is out of range")));
                }
                let normals = has_normals.then(|| idx.map(normal));
                match self.triangle(xf, idx.map(vertex), normals, attrs) {
                    Ok(()) => added += 1,
                    Err(TriangleError::Degenerate) => skipped += 1,
                    Err(TriangleError::OutOfRange(msg)) => {
                        return Err(ctx.err(field, format!("{shown}: {msg}")));
                    }
                }
            }
        }
        if added == 0 {
            let why = if skipped > 0 {
                format!("all {skipped} triangles are degenerate (zero area)")
            } else {
                "no triangles".to_string()
            };
            return Err(ctx.err(&file_field, format!("{shown}: {why}")));
        }
        self.stats.degenerate_triangles_skipped += skipped;
        Ok(())
    }
}

/// Reads a file, refusing devices and pipes (`/dev/zero` would never end).
fn read_regular_file(path: &Path) -> std::io::Result<Vec<u8>> {
    if !std::fs::metadata(path)?.is_file() {
        return Err(std::io::Error::other("not a regular file"));
    }
    std::fs::read(path)
}

/// A triangle is degenerate when its normal is not computable in f32: zero or non-finite
/// cross product, or one so small against the edges that its direction is rounding noise.
fn is_degenerate([a, b, c]: [Vec3; 3]) -> bool {
    let cross = (b - a).cross(c - a).length();
    let edge2 = (b - a)
        .length_squared()
        .max((c - a).length_squared())
        .max((c - b).length_squared());
    !(cross.is_finite() && cross > 1e-6 * edge2)
}

/// The corner and edges of a quad from either of its two forms.
fn quad_frame(ctx: &Ctx, field: &str, q: &desc::Quad) -> Result<(DVec3, DVec3, DVec3)> {
    let f = |k: &str| format!("{field}.{k}");
    let (corner, u, v) = match (q.corner, q.edge_u, q.edge_v, q.center, q.size, &q.facing) {
        (Some(c), Some(u), Some(v), None, None, None) => (
            ctx.coords(&f("corner"), c)?,
            ctx.coords(&f("edge_u"), u)?,
            ctx.coords(&f("edge_v"), v)?,
        ),
        (None, None, None, Some(c), Some(size), facing) => {
            let c = ctx.coords(&f("center"), c)?;
            let [a, b] = ctx.sizes(&f("size"), size.0)?;
            let facing = facing.as_deref().unwrap_or("+y");
            let (n, ea, eb) = match facing {
                "+x" | "-x" => (DVec3::X, DVec3::Y, DVec3::Z),
                "+y" | "-y" => (DVec3::Y, DVec3::X, DVec3::Z),
                "+z" | "-z" => (DVec3::Z, DVec3::X, DVec3::Y),
                other => {
                    return Err(ctx.err(
                        &f("facing"),
                        format!(
                            "expected one of \"+x\", \"-x\", \"+y\", \"-y\", \"+z\", \"-z\", \
                             got {other:?}"
                        ),
                    ));
                }
            };
            let n = if facing.starts_with('-') { -n } else { n };
            let (ea, eb) = (a * ea, b * eb);
            // Order the edges so that edge_u × edge_v points along the facing axis.
            let (u, v) = if ea.cross(eb).dot(n) > 0.0 { (ea, eb) } else { (eb, ea) };
            (c - 0.5 * (u + v), u, v)
        }
        _ => {
            return Err(ctx.err(
                field,
                "a quad needs either `corner`, `edge_u` and `edge_v`, or `center` and `size` \
                 (with an optional `facing`)",
            ));
        }
    };
    if u.cross(v).length() <= 1e-9 * u.length() * v.length() {
        return Err(ctx.err(
            field,
            format!(
                "zero-area quad: edge_u {} and edge_v {} are parallel or zero",
                triple(u.to_array()),
                triple(v.to_array())
            ),
        ));
    }
    Ok((corner, u, v))
}

fn user_paths(
    ctx: &Ctx,
    descs: &[desc::UserPathDesc],
    primitives: &[Primitive],
    attrs: &[PrimAttrs],
) -> Result<Vec<UserPath>> {
    if descs.is_empty() {
        return Ok(Vec::new());
    }
    let (lo, hi) = primitives
        .iter()
        .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), p| {
            let (a, b) = p.aabb_min_max();
            (lo.min(a), hi.max(b))
        });
    let tolerance = USER_PATH_LIGHT_TOLERANCE * (hi - lo).as_dvec3().length();
    let mut out = Vec::with_capacity(descs.len());
    for (i, d) in descs.iter().enumerate() {
        let field = format!("user_paths[{i}]");
        if d.points.len() < 2 {
            return Err(ctx.err(
                &format!("{field}.points"),
                format!(
                    "expected at least 2 points (a light point, then surface points), got {}",
                    d.points.len()
                ),
            ));
        }
        let mut points = Vec::with_capacity(d.points.len());
        for (j, &p) in d.points.iter().enumerate() {
            points.push(ctx.coords(&format!("{field}.points[{j}]"), p)?);
        }
        let segments = points.len() - 1;
        let cones = match &d.cone_deg {
            ConeDeg::All(c) => vec![*c; segments],
            ConeDeg::PerSegment(c) if c.len() == segments => c.clone(),
            ConeDeg::PerSegment(c) => {
                return Err(ctx.err(
                    &format!("{field}.cone_deg"),
                    format!("expected one angle or one per segment ({segments}), got {}", c.len()),
                ));
            }
        };
        if let Some(&bad) = cones.iter().find(|&&c| !(c > 0.0 && c <= 90.0)) {
            return Err(ctx.err(
                &format!("{field}.cone_deg"),
                format!("expected cone half-angles in (0, 90] degrees, got {}", num(bad)),
            ));
        }
        let dist = primitives
            .iter()
            .zip(attrs)
            .filter(|(_, a)| a.emission.is_some_and(|e| e.le.max_element() > 0.0))
            .map(|(p, _)| distance_to(p, points[0]))
            .fold(f64::INFINITY, f64::min);
        if dist.is_nan() || dist > tolerance {
            return Err(ctx.err(
                &format!("{field}.points[0]"),
                format!(
                    "must lie on an emissive surface: {} is {} from the nearest light (tolerance {})",
                    triple(points[0].to_array()),
                    approx(dist),
                    approx(tolerance)
                ),
            ));
        }
        out.push(UserPath {
            points: points.iter().map(|p| p.as_vec3()).collect(),
            cone_deg: cones.iter().map(|&c| c as f32).collect(),
        });
    }
    Ok(out)
}

/// Distance from `p` to the surface of a primitive.
fn distance_to(prim: &Primitive, p: DVec3) -> f64 {
    match *prim {
        Primitive::Triangle([a, b, c]) => {
            let q = closest_point_on_triangle(p, a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
            (p - q).length()
        }
        Primitive::Sphere { center, radius } => ((p - center.as_dvec3()).length() - radius as f64).abs(),
    }
}

/// Closest point to `p` on triangle abc, by the Voronoi regions of its vertices, edges and
/// face [Ericson 2005, Real-Time Collision Detection, §5.1.5].
fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;
    use glam::Vec2;

    fn shipped(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenes")
            .join(format!("{name}.toml"))
    }

    fn bounds(scene: &Scene) -> (Vec3, Vec3) {
        scene
            .primitives
            .iter()
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), p| {
                let (a, b) = p.aabb_min_max();
                (lo.min(a), hi.max(b))
            })
    }

    fn near(a: Vec3, b: Vec3) -> bool {
        (a - b).abs().max_element() < 1e-5
    }

    /// A small valid scene to build variations on: a floor, a light above it.
    const BASE: &str = r#"
[camera]
eye = [0, 1, 4]
look_at = [0, 1, 0]
fov_y = 40
resolution = [16, 12]
[materials.white]
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
[[shapes]]
type = "quad"
material = "white"
center = [0, 0, 0]
size = [2, 2]
[[shapes]]
type = "quad"
material = "white"
center = [0, 2, 0]
size = [0.5, 0.5]
facing = "-y"
emission = { radiance = [1, 1, 1] }
"#;

    fn load_str(text: &str) -> Result<(Scene, LoadStats)> {
        load_scene_bytes(Path::new("mem/test.toml"), text.as_bytes())
    }

    #[test]
    fn cornell_empty_loads_with_an_upward_light_the_camera_cannot_see() {
        let (scene, stats) = load_scene_with_stats(&shipped("cornell-empty")).unwrap();
        assert_eq!(scene.name, "cornell-empty");
        assert_eq!((scene.camera.width, scene.camera.height), (80, 60));
        assert_eq!(scene.lights.len(), 2, "one quad light, two triangles");
        assert_eq!(stats.triangles, 12);
        let (lo, hi) = bounds(&scene);
        assert!(near(lo, Vec3::ZERO) && near(hi, Vec3::new(0.556, 0.5488, 0.5592)));
        for light in &scene.lights {
            let prim = &scene.primitives[light.prim as usize];
            let n = prim.geometric_normal(Vec3::ZERO);
            assert!(near(n, Vec3::Y), "the light faces up: {n}");
            assert!(!light.emission.two_sided);
            // The eye is below the light, on its dark side.
            let (a, _) = prim.aabb_min_max();
            assert!((scene.camera.eye - a).dot(n) < 0.0);
        }
        let hit = centre_hit(&scene);
        assert!((hit.p.z - 0.5592).abs() < 1e-4, "centre ray hits the back wall");
        assert!(near(hit.ng, -Vec3::Z));
    }

    #[test]
    fn cornell_spheres_loads_with_two_spheres_and_a_downward_light() {
        let (scene, stats) = load_scene_with_stats(&shipped("cornell-spheres")).unwrap();
        assert_eq!(stats.spheres, 2);
        assert_eq!(scene.lights.len(), 2);
        for light in &scene.lights {
            let n = scene.primitives[light.prim as usize].geometric_normal(Vec3::ZERO);
            assert!(near(n, -Vec3::Y), "the light faces down: {n}");
        }
        let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["chrome", "glass", "green", "red", "white"]);
        let (lo, hi) = bounds(&scene);
        assert!(near(lo, Vec3::ZERO) && near(hi, Vec3::new(0.556, 0.5488, 0.5592)));
        for p in &scene.primitives {
            if let Primitive::Sphere { center, radius } = *p {
                assert!((center.y - radius).abs() < 1e-6, "resting on the floor");
            }
        }
        let hit = centre_hit(&scene);
        assert!((hit.p.z - 0.5592).abs() < 1e-4, "centre ray hits the back wall");
    }

    fn centre_hit(scene: &Scene) -> super::super::SurfaceHit {
        let c = &scene.camera;
        let ray = c.generate_ray(Vec2::new(c.width as f32, c.height as f32) * 0.5);
        scene.intersect(&ray).expect("the centre ray hits the box")
    }

    #[test]
    fn name_defaults_to_the_file_stem_and_hash_tracks_content() {
        let (a, _) = load_str(BASE).unwrap();
        assert_eq!(a.name, "test");
        let (b, _) = load_str(&BASE.replace("fov_y = 40", "fov_y = 41")).unwrap();
        assert_ne!(a.content_hash, b.content_hash);
        let (c, _) = load_str(&format!("name = \"named\"\n{BASE}")).unwrap();
        assert_eq!(c.name, "named");
    }

    #[test]
    fn transformed_box_has_the_expected_world_bounds_and_faces_outward() {
        for (transform, lo, hi) in [
            (
                "{ scale = [2, 1, 1], rotate_y = 90, translate = [1, 2, 3] }",
                Vec3::new(0.5, 1.5, 2.0),
                Vec3::new(1.5, 2.5, 4.0),
            ),
            // A mirroring transform keeps the faces pointing out.
            ("{ scale = [-1, 1, 1] }", Vec3::splat(-0.5), Vec3::splat(0.5)),
            // Steps apply in list order: move, then rotate about the origin.
            (
                "[{ translate = [2, 0, 0] }, { rotate_z = 90 }]",
                Vec3::new(-0.5, 1.5, -0.5),
                Vec3::new(0.5, 2.5, 0.5),
            ),
            (
                "{ matrix = [[0, -1, 0, 0], [1, 0, 0, 2], [0, 0, 3, 0], [0, 0, 0, 1]] }",
                Vec3::new(-0.5, 1.5, -1.5),
                Vec3::new(0.5, 2.5, 1.5),
            ),
        ] {
            let text = format!(
                "{BASE}[[shapes]]\ntype = \"box\"\nmaterial = \"white\"\n\
                 min = [-0.5, -0.5, -0.5]\nmax = [0.5, 0.5, 0.5]\ntransform = {transform}\n"
            );
            let (scene, _) = load_str(&text).unwrap();
            let boxed = &scene.primitives[4..];
            assert_eq!(boxed.len(), 12);
            let (mut b_lo, mut b_hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
            for p in boxed {
                let (a, b) = p.aabb_min_max();
                (b_lo, b_hi) = (b_lo.min(a), b_hi.max(b));
            }
            assert!(near(b_lo, lo) && near(b_hi, hi), "{transform}: {b_lo} {b_hi}");
            let centre = 0.5 * (lo + hi);
            for p in boxed {
                let Primitive::Triangle([a, b, c]) = *p else {
                    panic!("boxes are triangles")
                };
                let mid = (a + b + c) / 3.0;
                assert!(p.geometric_normal(mid).dot(mid - centre) > 0.0, "{transform}");
            }
        }
    }

    #[test]
    fn quads_face_the_requested_axis_in_both_forms() {
        for (facing, n) in [
            ("+x", Vec3::X),
            ("-x", -Vec3::X),
            ("+y", Vec3::Y),
            ("-y", -Vec3::Y),
            ("+z", Vec3::Z),
            ("-z", -Vec3::Z),
        ] {
            let text = format!(
                "{BASE}[[shapes]]\ntype = \"quad\"\nmaterial = \"white\"\ncenter = [0, 1, 0]\n\
                 size = [0.2, 0.4]\nfacing = \"{facing}\"\n"
            );
            let (scene, _) = load_str(&text).unwrap();
            for p in &scene.primitives[4..] {
                assert!(near(p.geometric_normal(Vec3::ZERO), n), "{facing}");
            }
            let area: f32 = scene.primitives[4..].iter().map(|p| p.area()).sum();
            assert!((area - 0.08).abs() < 1e-6);
        }
        let text = format!(
            "{BASE}[[shapes]]\ntype = \"quad\"\nmaterial = \"white\"\ncorner = [0, 0, 0]\n\
             edge_u = [1, 0, 0]\nedge_v = [0, 2, 0]\n"
        );
        let (scene, _) = load_str(&text).unwrap();
        for p in &scene.primitives[4..] {
            assert!(near(p.geometric_normal(Vec3::ZERO), Vec3::Z), "edge_u × edge_v");
        }
    }

    #[test]
    fn transformed_sphere_moves_and_scales_uniformly() {
        let text = format!(
            "{BASE}[[shapes]]\ntype = \"sphere\"\nmaterial = \"white\"\ncenter = [1, 0, 0]\n\
             radius = 0.5\ntransform = {{ scale = 2, rotate_z = 90, translate = [0, 0, 1] }}\n"
        );
        let (scene, _) = load_str(&text).unwrap();
        let Primitive::Sphere { center, radius } = scene.primitives[4] else {
            panic!("a sphere")
        };
        assert!(near(center, Vec3::new(0.0, 2.0, 1.0)), "{center}");
        assert!((radius - 1.0).abs() < 1e-6);
    }

    #[test]
    fn user_paths_expand_one_cone_angle_to_every_segment() {
        let text = format!(
            "{BASE}[[user_paths]]\npoints = [[0.1, 2, 0], [0, 0, 0], [0, 1, 1]]\ncone_deg = 5\n\
             [[user_paths]]\npoints = [[0, 2, 0.2], [0, 0, 0]]\ncone_deg = [3.5]\n"
        );
        let (scene, _) = load_str(&text).unwrap();
        assert_eq!(scene.user_paths.len(), 2);
        assert_eq!(scene.user_paths[0].cone_deg, [5.0, 5.0]);
        assert_eq!(scene.user_paths[1].cone_deg, [3.5]);
        assert_eq!(scene.user_paths[0].points[1], Vec3::ZERO);
    }

    /// The module doc of `desc` is the format's reference (and the README's): it must load.
    #[test]
    fn the_documented_example_loads() {
        let source = include_str!("desc.rs");
        let example: String = source
            .lines()
            .filter_map(|l| l.strip_prefix("//!"))
            .map(|l| l.strip_prefix(' ').unwrap_or(l))
            .skip_while(|l| *l != "```toml")
            .skip(1)
            .take_while(|l| *l != "```")
            .map(|l| format!("{l}\n"))
            .collect();
        assert!(example.contains("[[user_paths]]"));
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("meshes")).unwrap();
        let obj = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nf 1 2 3\n";
        std::fs::write(dir.path().join("meshes/bunny.obj"), obj).unwrap();
        let path = dir.path().join("example.toml");
        std::fs::write(&path, &example).unwrap();
        let (scene, stats) = load_scene_with_stats(&path).unwrap();
        assert_eq!(scene.name, "cornell-empty");
        assert_eq!(scene.materials.len(), 6);
        assert_eq!(stats.spheres, 1);
        // Two quads (the second with `subdivide = 4`), a box with `subdivide = 2`, a triangle.
        assert_eq!(stats.triangles, 2 + 2 * 4 * 4 + 12 * 2 * 2 + 1);
        assert_eq!(scene.user_paths.len(), 1);
    }

    #[test]
    fn computed_numbers_print_with_four_significant_digits() {
        assert_eq!(approx(0.008999998855590774), "0.009");
        assert_eq!(approx(0.00101672143992588), "0.001017");
        assert_eq!(approx(-123.456), "-123.5");
        assert_eq!(approx(0.0), "0");
        assert_eq!(approx(2.5e-9), "2.500e-9");
        assert_eq!(num(1e8), "1e8");
        assert_eq!(num(-1.0), "-1");
    }

    #[test]
    fn closest_point_on_triangle_covers_every_region() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        for (p, q) in [
            (DVec3::new(0.2, 0.2, 1.0), DVec3::new(0.2, 0.2, 0.0)),  // face
            (DVec3::new(-1.0, -1.0, 0.0), a),                        // vertex a
            (DVec3::new(2.0, -0.5, 0.0), b),                         // vertex b
            (DVec3::new(-0.5, 2.0, 0.0), c),                         // vertex c
            (DVec3::new(0.5, -1.0, 0.0), DVec3::new(0.5, 0.0, 0.0)), // edge ab
            (DVec3::new(-1.0, 0.5, 0.0), DVec3::new(0.0, 0.5, 0.0)), // edge ac
            (DVec3::new(1.0, 1.0, 0.0), DVec3::new(0.5, 0.5, 0.0)),  // edge bc
        ] {
            assert!((closest_point_on_triangle(p, a, b, c) - q).length() < 1e-12, "{p}");
        }
    }

    #[test]
    fn key_paths_name_the_field_of_an_array_of_tables() {
        let text = BASE.replace("size = [0.5, 0.5]", "size = [0.5, \"x\"]");
        let Err(e) = load_str(&text) else {
            panic!("a string size must fail")
        };
        let e = e.to_string();
        assert!(e.starts_with("mem/test.toml: shapes[1].size"), "{e}");
        assert!(e.contains("line 19"), "{e}");
    }

    /// Every outcome of loading must be a scene or a one-line error naming the file.
    fn assert_graceful(path: &Path, bytes: &[u8]) {
        if let Err(e) = load_scene_bytes(path, bytes) {
            let msg = e.to_string();
            assert!(!msg.contains('\n'), "{msg}");
            assert!(msg.starts_with(&path.display().to_string()), "{msg}");
        }
    }

    #[test]
    fn random_bytes_never_panic() {
        let path = Path::new("fuzz/random.toml");
        let mut rng = Rng::for_task(0x5cee, [1, 0, 0]);
        let alphabet = b"[]{}=\"'.,#-+_ \n0123456789eabcdfinxyz";
        for i in 0..400 {
            let len = rng.below(300) as usize;
            let bytes: Vec<u8> = (0..len)
                .map(|_| {
                    if i % 2 == 0 {
                        rng.below(256) as u8
                    } else {
                        alphabet[rng.below(alphabet.len() as u32) as usize]
                    }
                })
                .collect();
            assert_graceful(path, &bytes);
        }
    }

    #[test]
    fn deeply_nested_input_is_refused_without_overflow() {
        let path = Path::new("fuzz/deep.toml");
        let n = 100_000;
        for text in [
            format!("a = {}{}", "[".repeat(n), "]".repeat(n)),
            format!("camera = {}1{}", "{a=".repeat(n), "}".repeat(n)),
            format!("camera{} = 1", ".x".repeat(n)),
        ] {
            assert!(load_scene_bytes(path, text.as_bytes()).is_err());
        }
    }

    #[test]
    fn mutated_obj_files_never_panic() {
        let dir = tempfile::tempdir().unwrap();
        let scene_path = dir.path().join("m.toml");
        let scene = format!("{BASE}[[shapes]]\ntype = \"mesh\"\nmaterial = \"white\"\nfile = \"m.obj\"\n");
        std::fs::write(&scene_path, &scene).unwrap();
        std::fs::write(dir.path().join("m.mtl"), "newmtl a\nKd 0.5 0.5 0.5\n").unwrap();
        let obj: &[u8] = b"mtllib m.mtl\no tri\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n\
            vt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nusemtl a\nf 1/1/1 2/2/1 3/3/1\nf -3//1 -1//1 -2//1\n";
        let interesting = b"0123456789-/ .\nfvn#e";
        let mut rng = Rng::for_task(0x5cee, [3, 0, 0]);
        for i in 0..300 {
            let mut bytes = obj.to_vec();
            let at = rng.below(bytes.len() as u32) as usize;
            match i % 3 {
                0 => bytes[at] = rng.below(256) as u8,
                1 => bytes[at] = interesting[rng.below(interesting.len() as u32) as usize],
                _ => {
                    bytes.remove(at);
                }
            }
            std::fs::write(dir.path().join("m.obj"), &bytes).unwrap();
            assert_graceful(&scene_path, scene.as_bytes());
        }
    }

    #[test]
    fn single_byte_mutations_of_the_shipped_scenes_never_panic() {
        // Bytes that turn one valid token into another: digits, signs, brackets, quotes.
        let interesting = b"0123456789-+.eE[]{}\"=,#\n nax_";
        for name in ["cornell-empty", "cornell-spheres"] {
            let path = shipped(name);
            let original = std::fs::read(&path).unwrap();
            let mut rng = Rng::for_task(0x5cee, [2, name.len() as u64, 0]);
            for i in 0..300 {
                let mut bytes = original.clone();
                let at = rng.below(bytes.len() as u32) as usize;
                match i % 3 {
                    0 => bytes[at] = rng.below(256) as u8,
                    1 => bytes[at] = interesting[rng.below(interesting.len() as u32) as usize],
                    _ => {
                        bytes.remove(at);
                    }
                }
                assert_graceful(&path, &bytes);
            }
        }
    }
}
