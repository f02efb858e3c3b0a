//! Mitsuba 3 XML scenes (`scenes/*.xml`): read into the same [`SceneDesc`] a TOML scene file
//! becomes, and written from one ([`super::export`]).
//!
//! **Decision: the XML loader produces a [`SceneDesc`].** Everything downstream of the
//! description — validation, the f32 geometry, the content hash, references, experiments — is
//! the TOML path's, unchanged; this module only translates. The content hash of an XML scene
//! covers the XML file's bytes and every OBJ (and MTL) it references, exactly as a TOML
//! scene's covers its own bytes and meshes.
//!
//! What is read (everything else is an error naming the element; nothing is silently skipped):
//!
//! | Mitsuba 3 | photon-bench |
//! |---|---|
//! | `<default name value>`, `$name` in any attribute | substituted before anything is read; an undefined `$name` is an error; a default already given (by an including file) stands |
//! | parameters from outside ([`import_with`]: `--param`, an experiment's `params`) | `$name` stands for them over any `<default>`; one the scene never uses is an error |
//! | `<include filename>` (top level) | the included file's `<scene>` elements, read in its place with this scene's defaults and named BSDFs; its bytes join the content hash; cycles and nesting beyond 16 files are errors |
//! | `<path value>` (top level) | a directory (relative to the file) where relative file names — OBJ files, includes — are looked up first, the latest `<path>` first, before the file's own directory |
//! | `<bsdf id>` at the top level, `<ref id>` in a shape | a material named by the id |
//! | `sensor` `perspective`: `fov`, `fov_axis` (x, y, diagonal, smaller, larger; default x), `to_world` | `camera`: `eye`, `look_at`, `up`, `fov_y` |
//! | `sensor` `thinlens`: as `perspective`, and `aperture_radius` (required), `focus_distance` (default 10⁴, Mitsuba's far clip) | `camera.lens = { type = "thin", … }` |
//! | `sensor` `orthographic`: `to_world` with a scale in x and y (camera space [−1, 1] × [−1/aspect, 1/aspect]) | `camera.lens = { type = "orthographic", width, height }` |
//! | `near_clip`, `far_clip`, `sampler`, top-level `integrator` | ignored with a warning (no clipping planes; the experiment picks spp and strategy) |
//! | `film` `hdrfilm`: `width`, `height` (defaults 768 × 576), `rfilter`, `crop_offset_x`, `crop_offset_y`, `crop_width`, `crop_height` | `camera.resolution`, `camera.filter`, `camera.crop`; `pixel_format`, `component_format`, `file_format`, `banner`, `sample_border` only change output files and are accepted |
//! | `shape` `rectangle` | `quad` with corner (−1, −1, 0), edges 2x and 2y (so [−1, 1]² in the xy plane, front +z), then `to_world` |
//! | `shape` `cube` | `box` [−1, 1]³, then `to_world` |
//! | `shape` `sphere`: `center` (default 0), `radius` (default 1), `to_world` | `sphere` with the same fields (Mitsuba applies `to_world` after centre and radius, as we do) |
//! | `shape` `disk`: `flip_normals`, `to_world` | `disk` (the unit disk, front +z; a non-uniform scale makes an ellipse), tessellated with Mitsuba's normal and (u, v) at every vertex |
//! | `shape` `linearcurve`: `filename`, `to_world` (moves the points, not the radii) | `linear_curve` with the same file, tessellated (a sphere per control point, touching cones between; Mitsuba's (u, v)); not as an emitter |
//! | `shape` `bsplinecurve`: `filename`, `to_world` | `bspline_curve`: open tubes about cubic B-splines, tessellated, back faces culled as Embree culls them; not as an emitter |
//! | `shape` `cylinder`: `p0`, `p1`, `radius` (defaults 0, (0, 0, 1), 1), `flip_normals`, `to_world` | `cylinder` with the same fields (Mitsuba's frame about the axis, so its (u, v)), tessellated likewise; a radius ≤ 0 or p0 = p1 is refused, an emitting tube made elliptic or sheared by `to_world` warned about (Mitsuba samples its light as a round one's) |
//! | `shape` `obj`: `filename`, `face_normals`, `to_world` | `mesh`; `face_normals = true` ignores the file's normals |
//! | `shape` `shapegroup` `id` at the top level, `shape` `instance` with `<ref id>` and `to_world` | a copy of each of the group's shapes per instance, the instance's `to_world` after the shape's own (flattened); emitters, nested groups and mirroring instances refused |
//! | `bsdf` `diffuse` (`reflectance`, default 0.5) | `diffuse` |
//! | `bsdf` `conductor` with `material = "none"` (the default) and no `eta`/`k`: `specular_reflectance` | `mirror` (the same perfect mirror) |
//! | `bsdf` `conductor` with a named `material` (one of Mitsuba's 71; an unknown name is an error listing them) or `eta`/`k` (unbounded colours) | `conductor` |
//! | `bsdf` `roughconductor` (`material` or `eta`/`k`, `specular_reflectance`, `distribution`, `alpha` or `alpha_u`/`alpha_v`, `sample_visible`) | `rough_conductor` with the same fields and Mitsuba's defaults (Beckmann, α 0.1, visible normals) |
//! | `bsdf` `roughdielectric` (`int_ior`, `ext_ior`, `specular_reflectance`, `specular_transmittance`, the distribution's fields) | `rough_dielectric` with `ior = int_ior / ext_ior` |
//! | `bsdf` `roughplastic` (`int_ior` default polypropylene 1.49, `ext_ior`, `diffuse_reflectance` default 0.5, `specular_reflectance`, `nonlinear`, the distribution's fields; isotropic) | `rough_plastic` with `ior = int_ior / ext_ior` |
//! | `bsdf` `dielectric` (`int_ior`, `ext_ior`: numbers or Mitsuba's named media; defaults bk7 and air) | `dielectric` with `ior = int_ior / ext_ior` |
//! | `bsdf` `thindielectric` (`int_ior`, `ext_ior`, `specular_reflectance`, `specular_transmittance`) | `thin_dielectric` with `ior = int_ior / ext_ior` and both filters (two-sided, as Mitsuba's) |
//! | `bsdf` `polarizer` (`transmittance`; `theta`, `polarizing` read and ignored) | as Mitsuba's RGB variants evaluate it: `thin_dielectric` with `ior = 1` (no reflection) and `transmittance` ½ of it, with a warning (polarization is not tracked) |
//! | `bsdf` `twosided` around one reflecting BSDF | that BSDF: our reflection models are two-sided. A bare reflecting BSDF is one-sided in Mitsuba (black from behind), so it is read with a warning |
//! | a shape without a BSDF | Mitsuba's default, `diffuse` 0.5 (one-sided: warned) |
//! | `medium` `homogeneous` (`sigma_t`, `scale`, `albedo` a colour or a `constvolume`/`gridvolume`, `sample_emitters`, a nested `phase` `isotropic` or `hg`) and `heterogeneous` (a `gridvolume` `sigma_t`) — top level with an `id`, or nested in a shape (`name="interior"`/`"exterior"`) or the sensor | `[media.NAME]` `homogeneous` / `heterogeneous` ([`crate::medium`]); `<ref name="interior|exterior" id>` in shapes and `<ref name="medium" id>` in the sensor name them; `has_spectral_extinction` and a grid's `raw` are read without effect |
//! | `bsdf` `null` | `type = "null"`: rays pass it; a medium's boundary |
//! | `emitter` `area` in a shape: `radiance` | `emission = { radiance, two_sided = false }`: Mitsuba's area lights emit on the front side only, as ours do by default |
//! | `emitter` `point` (`intensity`, `position` or `to_world`), `spot` (`intensity`, `cutoff_angle`, `beam_width`, `texture`, `to_world`), `projector` (`irradiance`: a colour or a picture, `scale`, `fov`, `fov_axis`, `to_world` without shear or mirroring; its uniform scale multiplies `scale`, as in Mitsuba), `directional` (`irradiance`, `direction` or `to_world`) | `[[lights]]` of the same type, Mitsuba's defaults made explicit where they depend on nothing else |
//! | `emitter` `constant` (`radiance`), `envmap` (`filename`, `scale`, `to_world`) | `[environment]` |
//!
//! Colours are `rgb` (three numbers, or one for grey), `float`, or a `spectrum`: one number (a
//! constant spectrum), wavelength:value pairs in `value` or in a `filename` (`.spd`: a pair per
//! line), or `type="blackbody"` with a `temperature` (emitters only), converted to RGB as
//! Mitsuba 3's RGB variants convert them ([`crate::spectrum`]: reflectances D65-weighted and
//! clamped to [0, 1], emission neither). Colours of `diffuse` (`reflectance`) and `roughplastic`
//! (`diffuse_reflectance`) may be `checkerboard` or `bitmap` textures, nested or named
//! (`<ref name="reflectance" id="…"/>` to a top-level `<texture id>`), with a `to_uv` transform;
//! other textured parameters are errors. Lengths keep their units.
//!
//! **Transforms.** The operations inside `<transform name="to_world">` apply in document order,
//! each after the ones before (`M = op · M`): `translate` (`x`, `y`, `z` or `value`),
//! `scale` (`x`, `y`, `z`, or `value` with one or three numbers), `rotate` (axis from `x`, `y`,
//! `z` or `value`, right-handed `angle` in degrees), `matrix` (16 numbers row-major, or 9) and
//! `lookat` (`origin`, `target`, `up`). A shape's transform becomes one `matrix` step of our
//! format.
//!
//! **Camera.** Mitsuba's camera looks down its local +z with +y up and +x to the *left*
//! (`lookat` builds the columns left = up × dir, up, dir, origin). The camera's `to_world` must
//! be such a rigid map (orthonormal columns, positive determinant): a scaled or mirrored camera
//! is refused rather than rendered differently. `fov` along `fov_axis` becomes our vertical
//! `fov_y` through the image's aspect ratio (tan(fov_y/2) = tan(fov_x/2) · h / w).
//!
//! Errors read `<file>: line L, <element as written>: <what was expected>`; warnings have the
//! same form and are printed by [`super::load_scene`].
//!
//! Files: this one (the reader and the `<scene>` element), [`values`] (properties, colours,
//! transforms), [`sensor`] (sensor and film), [`materials`] (BSDFs), [`textures`] (textures),
//! [`shapes`] (shapes), [`emitters`] (area emitters, the environment, delta lights). The importer produces a [`super::desc::SceneDesc`] and never calls the loader, which
//! validates it like any TOML scene; writing XML lives in [`super::export`].

mod emitters;
mod materials;
mod media;
mod sensor;
mod shapes;
mod textures;
mod values;

use super::desc::{self, MaterialDesc, SceneDesc};
use crate::error::{Error, Result};
use glam::DVec3;
use roxmltree::{Document, Node};
use std::collections::BTreeMap;
use std::path::Path;

/// Mitsuba's default film size.
const DEFAULT_WIDTH: i64 = 768;
const DEFAULT_HEIGHT: i64 = 576;

/// Mitsuba 3's named indices of refraction (its `dielectric` plugin's table), so that scenes
/// writing `int_ior="water"` read as Mitsuba reads them.
pub const NAMED_IOR: &[(&str, f64)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.333),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.47),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.575),
    ("diamond", 2.419),
];

/// The element names that carry a property (`<float name="fov" value="45"/>`).
const PROPERTY_TAGS: &[&str] = &[
    "float",
    "integer",
    "boolean",
    "string",
    "rgb",
    "spectrum",
    "point",
    "vector",
    "transform",
];

/// A Mitsuba scene read into our description.
#[derive(Debug)]
pub struct Imported {
    pub desc: SceneDesc,
    /// For each of `desc.shapes`, how errors name it: `line L, <shape type="…">`.
    pub shape_labels: Vec<String>,
    /// Approximations and ignored settings, one line each, already prefixed with the file.
    pub warnings: Vec<String>,
    /// Every file `<include>`d (at any depth) with its bytes, in reading order: they belong
    /// to the scene's content hash as the scene file does.
    pub included: Vec<(std::path::PathBuf, Vec<u8>)>,
}

/// How deep `<include>`s may nest (a cycle is refused before that).
const MAX_INCLUDE_DEPTH: usize = 16;

/// Reads a Mitsuba 3 XML scene. `file` names it in messages; `dir` anchors relative paths
/// (OBJ files, `<include>`s, `<path>`s).
pub fn import(file: &str, dir: &Path, text: &str) -> Result<Imported> {
    import_with(file, dir, text, &[])
}

/// [`import`] with scene parameters given from outside (`bench … --param name=value`, an
/// experiment's `params`), as `mitsuba -D name=value` or `mi.load_file(…, name=value)`: each
/// stands for `$name` over any `<default>` of the scene. A parameter the scene never uses
/// is an error (a misspelt name would otherwise change nothing silently).
pub fn import_with(file: &str, dir: &Path, text: &str, params: &[(String, String)]) -> Result<Imported> {
    let doc = Document::parse(text).map_err(|e| Error::new(format!("{file}: XML syntax error: {e}")))?;
    let mut defaults = BTreeMap::new();
    for (name, value) in params {
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(Error::new(format!(
                "{file}: parameter {name:?}: expected a name of letters, digits and '_'"
            )));
        }
        if defaults.insert(name.clone(), value.clone()).is_some() {
            return Err(Error::new(format!("{file}: parameter {name:?} is given twice")));
        }
    }
    let used = std::cell::RefCell::new(std::collections::BTreeSet::new());
    let mut r = Reader {
        used: &used,
        file,
        doc: &doc,
        dir,
        root_dir: dir,
        search: Vec::new(),
        including: vec![
            std::fs::canonicalize(dir.join(Path::new(file).file_name().unwrap_or_default())).unwrap_or_default(),
        ],
        defaults,
        warnings: Vec::new(),
        materials: BTreeMap::new(),
        bsdf_ids: BTreeMap::new(),
        emitter_ids: BTreeMap::new(),
        texture_ids: BTreeMap::new(),
        sampler_ids: std::collections::BTreeSet::new(),
        media: BTreeMap::new(),
        shapegroups: BTreeMap::new(),
    };
    let imported = r.scene(doc.root_element())?;
    if let Some((name, _)) = params.iter().find(|(name, _)| !used.borrow().contains(name)) {
        return Err(Error::new(format!(
            "{file}: parameter {name:?}: the scene has no ${name} (its parameters are the names it writes as $name)"
        )));
    }
    Ok(imported)
}

/// What the top-level elements of a scene and of the files it includes add up to.
#[derive(Default)]
struct SceneParts {
    camera: Option<desc::CameraDesc>,
    environment: Option<desc::EnvironmentDesc>,
    lights: Vec<desc::LightDesc>,
    shapes: Vec<desc::ShapeDesc>,
    labels: Vec<String>,
    included: Vec<(std::path::PathBuf, Vec<u8>)>,
}

/// A property element or a nested object, by its `name`.
struct Obj<'a, 'i> {
    node: Node<'a, 'i>,
    props: BTreeMap<String, Node<'a, 'i>>,
    /// Nested objects (`bsdf`, `emitter`, `film`, `rfilter`, `ref`, …) in document order.
    children: Vec<Node<'a, 'i>>,
}

struct Reader<'a, 'i> {
    /// Every `$name` substituted so far (in this file and the files it includes).
    used: &'a std::cell::RefCell<std::collections::BTreeSet<String>>,
    file: &'a str,
    doc: &'a Document<'i>,
    dir: &'a Path,
    /// The directory of the scene file being imported (not of an included one): Mitsuba's file
    /// resolver looks there, not in an included file's directory, for the files it names.
    root_dir: &'a Path,
    /// `<path value>` directories, the latest first: relative file names are looked up there
    /// before `dir` (Mitsuba's file resolver).
    search: Vec<std::path::PathBuf>,
    /// The files being read, outermost first (canonical paths): an `<include>` of one of
    /// them is a cycle.
    including: Vec<std::path::PathBuf>,
    /// `<default name value>`: what `$name` stands for.
    defaults: BTreeMap<String, String>,
    warnings: Vec<String>,
    materials: BTreeMap<String, MaterialDesc>,
    /// Material name of each top-level `<bsdf id>`.
    bsdf_ids: BTreeMap<String, String>,
    /// Each top-level `<emitter type="area" id>`, for shapes to `<ref>`.
    emitter_ids: BTreeMap<String, crate::scene::desc::EmissionDesc>,
    /// Each top-level `<texture id>`, for BSDFs to `<ref>`.
    texture_ids: BTreeMap<String, crate::scene::desc::TextureDesc>,
    /// Each top-level `<sampler id>`, which a sensor may `<ref>` (and we ignore).
    sampler_ids: std::collections::BTreeSet<String>,
    /// Every medium by name: top-level `<medium id>`s and those nested in shapes and sensors.
    media: BTreeMap<String, desc::MediumDesc>,
    /// Each top-level `<shape type="shapegroup" id>`, for instances to `<ref>`.
    shapegroups: BTreeMap<String, shapes::ShapeGroup>,
}

impl<'a, 'i> Reader<'a, 'i> {
    /// `line L, <tag type="…" id="…" name="…">`: how messages name an element.
    fn label(&self, n: Node) -> String {
        let line = self.doc.text_pos_at(n.range().start).row;
        let mut tag = format!("<{}", n.tag_name().name());
        for key in ["type", "id", "name", "filename"] {
            if let Some(v) = n.attribute(key) {
                tag.push_str(&format!(" {key}=\"{v}\""));
            }
        }
        format!("line {line}, {tag}>")
    }

    fn err(&self, n: Node, msg: impl std::fmt::Display) -> Error {
        Error::new(format!("{}: {}: {msg}", self.file, self.label(n)))
    }

    fn warn(&mut self, n: Node, msg: impl std::fmt::Display) {
        let w = format!("{}: {}: {msg}", self.file, self.label(n));
        self.warnings.push(w);
    }

    /// An attribute with every `$name` replaced by its `<default>`.
    fn attr(&self, n: Node, key: &str) -> Result<Option<String>> {
        let Some(raw) = n.attribute(key) else {
            return Ok(None);
        };
        let mut out = String::new();
        let mut rest = raw;
        while let Some(at) = rest.find('$') {
            out.push_str(&rest[..at]);
            let after = &rest[at + 1..];
            let len = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            let name = &after[..len];
            if name.is_empty() {
                return Err(self.err(
                    n,
                    format!("{key}: a `$` must be followed by a parameter name, got {raw:?}"),
                ));
            }
            let Some(value) = self.defaults.get(name) else {
                return Err(self.err(
                    n,
                    format!("{key}: ${name} is not defined (add <default name=\"{name}\" value=\"…\"/> to the scene)"),
                ));
            };
            out.push_str(value);
            self.used.borrow_mut().insert(name.to_string());
            rest = &after[len..];
        }
        out.push_str(rest);
        Ok(Some(out))
    }

    fn required(&self, n: Node, key: &str) -> Result<String> {
        self.attr(n, key)?
            .ok_or_else(|| self.err(n, format!("expected a `{key}` attribute")))
    }

    /// Numbers separated by commas and/or white space, each finite.
    fn numbers(&self, n: Node, key: &str, text: &str) -> Result<Vec<f64>> {
        text.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .map(|s| match s.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(self.err(n, format!("{key}: expected finite numbers, got {text:?}"))),
            })
            .collect()
    }

    fn number(&self, n: Node, key: &str) -> Result<f64> {
        let text = self.required(n, key)?;
        match self.numbers(n, key, &text)?.as_slice() {
            [v] => Ok(*v),
            _ => Err(self.err(n, format!("{key}: expected one finite number, got {text:?}"))),
        }
    }

    fn triple_attr(&self, n: Node, key: &str) -> Result<DVec3> {
        let text = self.required(n, key)?;
        match self.numbers(n, key, &text)?.as_slice() {
            [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
            _ => Err(self.err(n, format!("{key}: expected three finite numbers, got {text:?}"))),
        }
    }

    /// A coordinate from `key` (default `default`) for the `x`/`y`/`z` attribute forms.
    /// The `x`, `y`, `z` attributes of a transform operation, each `default` when absent.
    fn coords(&self, n: Node, default: f64) -> Result<DVec3> {
        Ok(DVec3::new(
            self.coord(n, "x", default)?,
            self.coord(n, "y", default)?,
            self.coord(n, "z", default)?,
        ))
    }

    fn coord(&self, n: Node, key: &str, default: f64) -> Result<f64> {
        match n.attribute(key) {
            None => Ok(default),
            Some(_) => self.number(n, key),
        }
    }

    // -----------------------------------------------------------------------------------------

    fn scene(&mut self, root: Node<'a, 'i>) -> Result<Imported> {
        let mut parts = SceneParts::default();
        self.scene_elements(root, &mut parts)?;
        let SceneParts {
            camera,
            environment,
            lights,
            shapes,
            labels,
            included,
        } = parts;
        let Some(camera) = camera else {
            return Err(Error::new(format!(
                "{}: no <sensor>: add <sensor type=\"perspective\"> with a fov, a to_world and a film",
                self.file
            )));
        };
        if environment.is_none()
            && lights.is_empty()
            && !shapes.iter().any(|s| {
                s.common()
                    .2
                    .is_some_and(|e: &desc::EmissionDesc| e.radiance.iter().any(|&c| c > 0.0))
            })
        {
            return Err(Error::new(format!(
                "{}: no light: add <emitter type=\"area\"><rgb name=\"radiance\" value=\"…\"/></emitter> with a \
                 positive channel to a <shape>, or an <emitter type=\"point\">, \"spot\", \"projector\", \"directional\", \"constant\" or \"envmap\"",
                self.file
            )));
        }
        Ok(Imported {
            desc: SceneDesc {
                name: None,
                camera,
                materials: std::mem::take(&mut self.materials),
                shapes,
                user_paths: Vec::new(),
                environment,
                lights,
                media: std::mem::take(&mut self.media),
            },
            shape_labels: labels,
            warnings: std::mem::take(&mut self.warnings),
            included,
        })
    }

    /// Reads the top-level elements of `root` (a `<scene>`) into `parts`, in document order;
    /// an `<include>` reads the included scene's elements in its place.
    fn scene_elements(&mut self, root: Node<'a, 'i>, parts: &mut SceneParts) -> Result<()> {
        if root.tag_name().name() != "scene" {
            return Err(self.err(root, "expected a Mitsuba 3 <scene> root element"));
        }
        // Defaults first: `$name` may appear anywhere, also before its <default>. A default an
        // including file (or the command line) gave already stands, as in Mitsuba.
        let mut own = std::collections::BTreeSet::new();
        for n in root.children().filter(|n| n.has_tag_name("default")) {
            let name = self.required(n, "name")?;
            let value = self
                .attr(n, "value")?
                .ok_or_else(|| self.err(n, "expected a `value` attribute"))?;
            if !own.insert(name.clone()) {
                return Err(self.err(n, format!("default {name:?} is given twice")));
            }
            self.defaults.entry(name).or_insert(value);
        }
        let elements: Vec<Node> = root.children().filter(Node::is_element).collect();
        // Search directories before any file is named: Mitsuba resolves file names when it
        // builds the objects, after the whole file (every <path> in it) has been read.
        for &n in elements.iter().filter(|n| n.has_tag_name("path")) {
            let value = self.required(n, "value")?;
            self.search.insert(0, self.dir.join(value));
        }
        // Named textures, BSDFs and area emitters first, so that a <ref> may precede the
        // definition it names.
        for &n in elements.iter().filter(|n| n.has_tag_name("sampler")) {
            if let Some(id) = self.attr(n, "id")? {
                self.sampler_ids.insert(id);
            }
        }
        for &n in elements.iter().filter(|n| n.has_tag_name("texture")) {
            let Some(id) = self.attr(n, "id")? else {
                return Err(self.err(n, "a top-level <texture> needs an `id` for BSDFs to <ref> it"));
            };
            let t = self.texture(n)?;
            if self.texture_ids.insert(id.clone(), t).is_some() {
                return Err(self.err(n, format!("id {id:?} is used twice")));
            }
        }
        for &n in elements.iter().filter(|n| n.has_tag_name("medium")) {
            let Some(id) = self.attr(n, "id")? else {
                return Err(self.err(
                    n,
                    "a top-level <medium> needs an `id` for shapes and sensors to <ref> it",
                ));
            };
            let m = self.medium(n)?;
            if self.media.insert(id.clone(), m).is_some() {
                return Err(self.err(n, format!("id {id:?} is used twice")));
            }
        }
        for &n in &elements {
            if n.has_tag_name("emitter") && n.attribute("type") == Some("area") {
                let Some(id) = self.attr(n, "id")? else {
                    return Err(self.err(n, "a top-level area <emitter> needs an `id` for shapes to <ref> it"));
                };
                let e = self.area(n)?;
                if self.emitter_ids.insert(id.clone(), e).is_some() || self.bsdf_ids.contains_key(&id) {
                    return Err(self.err(n, format!("id {id:?} is used twice")));
                }
            }
            if n.has_tag_name("bsdf") {
                let Some(id) = self.attr(n, "id")? else {
                    return Err(self.err(n, "a top-level <bsdf> needs an `id` for shapes to <ref> it"));
                };
                let m = self.bsdf(n)?;
                if self.bsdf_ids.contains_key(&id)
                    || self.materials.contains_key(&id)
                    || self.emitter_ids.contains_key(&id)
                {
                    return Err(self.err(n, format!("id {id:?} is used twice")));
                }
                self.bsdf_ids.insert(id.clone(), id.clone());
                self.materials.insert(id, m);
            }
        }
        for n in root.children() {
            if n.is_text() && !n.text().unwrap_or("").trim().is_empty() {
                return Err(self.err(root, format!("unexpected text {:?}", n.text().unwrap_or("").trim())));
            }
        }
        for &n in &elements {
            match n.tag_name().name() {
                "default" | "bsdf" | "texture" | "path" | "medium" => {}
                "include" => self.include(n, parts)?,
                "sensor" => {
                    if parts.camera.is_some() {
                        return Err(self.err(n, "a second <sensor>: photon-bench renders one camera per scene"));
                    }
                    parts.camera = Some(self.sensor(n)?);
                }
                "shape" if n.attribute("type") == Some("shapegroup") => self.shapegroup(n)?,
                "shape" if n.attribute("type") == Some("instance") => {
                    self.instance(n, &mut parts.shapes, &mut parts.labels)?;
                }
                "shape" => {
                    parts.labels.push(self.label(n));
                    let shape = self.shape(n, &format!("shape{}", parts.shapes.len()))?;
                    parts.shapes.push(shape);
                }
                "integrator" => self.warn(
                    n,
                    "ignored: the experiment file chooses the strategy (Mitsuba's max_depth N is our max_depth N - 1)",
                ),
                "sampler" => self.warn(n, "ignored: the experiment file sets the samples per pixel"),
                "emitter" if n.attribute("type") == Some("area") => {}
                "emitter" if matches!(n.attribute("type"), Some("constant" | "envmap")) => {
                    if parts.environment.is_some() {
                        return Err(self.err(n, "a second environment emitter: photon-bench takes one per scene"));
                    }
                    parts.environment = Some(self.environment(n)?);
                }
                "emitter"
                    if matches!(
                        n.attribute("type"),
                        Some("point" | "spot" | "projector" | "directional")
                    ) =>
                {
                    let light = self.delta_light(n)?;
                    parts.lights.push(light);
                }
                "emitter" => {
                    return Err(self.err(
                        n,
                        "unsupported emitter (photon-bench reads area, point, spot, projector, directional, constant and envmap)",
                    ));
                }
                other => {
                    return Err(self.err(
                        n,
                        format!(
                            "unsupported element <{other}> (photon-bench reads default, include, path, sensor, bsdf, texture, medium, shape, integrator and sampler)"
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// `<include filename>`: the file (looked up first in the including file's directory, as
    /// Mitsuba's parser does, then as [`Reader::resolve`] says) must be a `<scene>`; its elements
    /// are read here, sharing this scene's defaults, named BSDFs and search directories.
    /// Relative names inside it resolve as in the main file (the `<path>` directories, then the
    /// main file's directory), then in the included file's own directory.
    fn include(&mut self, n: Node<'a, 'i>, parts: &mut SceneParts) -> Result<()> {
        let name = self.required(n, "filename")?;
        let own = self.dir.join(&name);
        let path = if Path::new(&name).is_relative() && own.is_file() {
            own
        } else {
            self.resolve(&name)
        };
        if self.including.len() > MAX_INCLUDE_DEPTH {
            return Err(self.err(n, format!("includes nest deeper than {MAX_INCLUDE_DEPTH} files")));
        }
        let canonical = std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone());
        if self.including.contains(&canonical) {
            return Err(self.err(n, format!("filename: {} includes itself (a cycle)", path.display())));
        }
        let bytes = crate::util::read_input(&path, "included scene", crate::util::MAX_TEXT_INPUT)
            .map_err(|e| self.err(n, format!("filename: cannot read {}: {e}", path.display())))?;
        let file = path.display().to_string();
        let text = std::str::from_utf8(&bytes).map_err(|e| {
            Error::new(format!(
                "{file}: not valid UTF-8 (first bad byte at offset {})",
                e.valid_up_to()
            ))
        })?;
        let doc = Document::parse(text).map_err(|e| Error::new(format!("{file}: XML syntax error: {e}")))?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let mut including = std::mem::take(&mut self.including);
        including.push(canonical);
        let mut inner = Reader {
            used: self.used,
            file: &file,
            doc: &doc,
            dir: &dir,
            root_dir: self.root_dir,
            search: self.search.clone(),
            including,
            defaults: std::mem::take(&mut self.defaults),
            warnings: std::mem::take(&mut self.warnings),
            materials: std::mem::take(&mut self.materials),
            bsdf_ids: std::mem::take(&mut self.bsdf_ids),
            emitter_ids: std::mem::take(&mut self.emitter_ids),
            texture_ids: std::mem::take(&mut self.texture_ids),
            sampler_ids: std::mem::take(&mut self.sampler_ids),
            media: std::mem::take(&mut self.media),
            shapegroups: std::mem::take(&mut self.shapegroups),
        };
        let read = inner.scene_elements(doc.root_element(), parts);
        self.defaults = inner.defaults;
        self.warnings = inner.warnings;
        self.materials = inner.materials;
        self.bsdf_ids = inner.bsdf_ids;
        self.emitter_ids = inner.emitter_ids;
        self.media = inner.media;
        self.shapegroups = inner.shapegroups;
        self.texture_ids = inner.texture_ids;
        self.sampler_ids = inner.sampler_ids;
        self.including = inner.including;
        self.including.pop();
        read?;
        parts.included.push((path, bytes));
        Ok(())
    }

    /// A relative file name as Mitsuba's file resolver finds it: in the `<path>` directories
    /// (the latest first), then in the main scene file's directory; beyond Mitsuba, then in the
    /// directory of the (included) file that names it. Absolute names as they are. A name found
    /// nowhere resolves against the naming file's directory, so that the error names it there.
    pub(super) fn resolve(&self, name: &str) -> std::path::PathBuf {
        let p = Path::new(name);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        self.search
            .iter()
            .chain([&self.root_dir.to_path_buf(), &self.dir.to_path_buf()])
            .map(|d| d.join(p))
            .find(|c| c.is_file())
            .unwrap_or_else(|| self.dir.join(p))
    }
}
