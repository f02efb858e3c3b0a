//! Mitsuba 3 XML scenes (`scenes/*.xml`): read into the same [`SceneDesc`] a TOML scene file
//! becomes, and written from one ([`export`]).
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
//! | `<default name value>`, `$name` in any attribute | substituted before anything is read; an undefined `$name` is an error |
//! | `<bsdf id>` at the top level, `<ref id>` in a shape | a material named by the id |
//! | `sensor` `perspective`: `fov`, `fov_axis` (x, y, diagonal, smaller, larger; default x), `to_world` | `camera`: `eye`, `look_at`, `up`, `fov_y` |
//! | `near_clip`, `far_clip`, `sampler`, top-level `integrator` | ignored with a warning (no clipping planes; the experiment picks spp and strategy) |
//! | `film` `hdrfilm`: `width`, `height` (defaults 768 × 576), `rfilter` | `camera.resolution`; a filter other than `box` is warned about (our film is a box filter); `pixel_format`, `component_format`, `file_format`, `banner`, `sample_border` only change output files and are accepted |
//! | `shape` `rectangle` | `quad` with corner (−1, −1, 0), edges 2x and 2y (so [−1, 1]² in the xy plane, front +z), then `to_world` |
//! | `shape` `cube` | `box` [−1, 1]³, then `to_world` |
//! | `shape` `sphere`: `center` (default 0), `radius` (default 1), `to_world` | `sphere` with the same fields (Mitsuba applies `to_world` after centre and radius, as we do) |
//! | `shape` `obj`: `filename`, `face_normals`, `to_world` | `mesh`; `face_normals = true` ignores the file's normals |
//! | `bsdf` `diffuse` (`reflectance`, default 0.5) | `diffuse` |
//! | `bsdf` `conductor` with `material = "none"` (the default): `specular_reflectance` | `mirror` (named metals need a Fresnel conductor we do not have: error) |
//! | `bsdf` `roughconductor` (`alpha` or `alpha_u`/`alpha_v`, `specular_reflectance`) | `ward` with no diffuse part, α as Ward's roughness, **with a warning**: our glossy model approximates the microfacet lobe |
//! | `bsdf` `dielectric` (`int_ior`, `ext_ior`: numbers or Mitsuba's named media; defaults bk7 and air) | `dielectric` with `ior = int_ior / ext_ior` |
//! | `bsdf` `twosided` around one reflecting BSDF | that BSDF: our reflection models are two-sided. A bare reflecting BSDF is one-sided in Mitsuba (black from behind), so it is read with a warning |
//! | a shape without a BSDF | Mitsuba's default, `diffuse` 0.5 (one-sided: warned) |
//! | `emitter` `area` in a shape: `radiance` | `emission = { radiance, two_sided = false }`: Mitsuba's area lights emit on the front side only, as ours do by default |
//!
//! Colours are `rgb` (three numbers, or one for grey), `float`, or a `spectrum` with one number
//! (a constant spectrum); textures and wavelength lists are errors. Lengths keep their units.
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

pub mod export;

use super::desc::{self, CameraDesc, Fixed, MaterialDesc, SceneDesc, ShapeDesc, TransformDesc, TransformStep, Triple};
use crate::error::{Error, Result};
use glam::{DMat3, DMat4, DVec3, DVec4};
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
}

/// Reads a Mitsuba 3 XML scene. `file` names it in messages; `dir` anchors relative OBJ paths.
pub fn import(file: &str, dir: &Path, text: &str) -> Result<Imported> {
    let doc = Document::parse(text).map_err(|e| Error::new(format!("{file}: XML syntax error: {e}")))?;
    let mut r = Reader {
        file,
        doc: &doc,
        dir,
        defaults: BTreeMap::new(),
        warnings: Vec::new(),
        materials: BTreeMap::new(),
        bsdf_ids: BTreeMap::new(),
    };
    r.scene(doc.root_element())
}

/// A property element or a nested object, by its `name`.
struct Obj<'a, 'i> {
    node: Node<'a, 'i>,
    props: BTreeMap<String, Node<'a, 'i>>,
    /// Nested objects (`bsdf`, `emitter`, `film`, `rfilter`, `ref`, …) in document order.
    children: Vec<Node<'a, 'i>>,
}

struct Reader<'a, 'i> {
    file: &'a str,
    doc: &'a Document<'i>,
    dir: &'a Path,
    /// `<default name value>`: what `$name` stands for.
    defaults: BTreeMap<String, String>,
    warnings: Vec<String>,
    materials: BTreeMap<String, MaterialDesc>,
    /// Material name of each top-level `<bsdf id>`.
    bsdf_ids: BTreeMap<String, String>,
}

impl<'a, 'i> Reader<'a, 'i> {
    /// `line L, <tag type="…" id="…" name="…">`: how messages name an element.
    fn label(&self, n: Node) -> String {
        let line = self.doc.text_pos_at(n.range().start).row;
        let mut tag = format!("<{}", n.tag_name().name());
        for key in ["type", "id", "name"] {
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

    /// Splits an object's children into properties (by name) and nested objects.
    fn obj(&self, node: Node<'a, 'i>) -> Result<Obj<'a, 'i>> {
        let mut props = BTreeMap::new();
        let mut children = Vec::new();
        for c in node.children() {
            if c.is_text() && !c.text().unwrap_or("").trim().is_empty() {
                return Err(self.err(node, format!("unexpected text {:?}", c.text().unwrap_or("").trim())));
            }
            if !c.is_element() {
                continue;
            }
            if PROPERTY_TAGS.contains(&c.tag_name().name()) {
                let name = self.required(c, "name")?;
                if props.insert(name.clone(), c).is_some() {
                    return Err(self.err(c, format!("property {name:?} is given twice")));
                }
            } else {
                children.push(c);
            }
        }
        Ok(Obj { node, props, children })
    }

    /// Refuses any property the caller did not read: nothing is silently ignored.
    fn finish(&self, o: &Obj) -> Result<()> {
        match o.props.values().next() {
            None => Ok(()),
            Some(&p) => Err(self.err(
                p,
                format!(
                    "unsupported property of <{} type=\"{}\"> (photon-bench does not read it)",
                    o.node.tag_name().name(),
                    o.node.attribute("type").unwrap_or("")
                ),
            )),
        }
    }

    fn take(&self, o: &mut Obj<'a, 'i>, name: &str, tags: &[&str]) -> Result<Option<Node<'a, 'i>>> {
        match o.props.remove(name) {
            None => Ok(None),
            Some(p) if tags.contains(&p.tag_name().name()) => Ok(Some(p)),
            Some(p) => Err(self.err(p, format!("expected {name:?} as one of <{}>", tags.join(">, <")))),
        }
    }

    fn float(&self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<f64>> {
        self.take(o, name, &["float", "integer"])?
            .map(|p| self.number(p, "value"))
            .transpose()
    }

    fn integer(&self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<i64>> {
        let Some(p) = self.take(o, name, &["integer"])? else {
            return Ok(None);
        };
        let text = self.required(p, "value")?;
        text.trim()
            .parse::<i64>()
            .map(Some)
            .map_err(|_| self.err(p, format!("value: expected an integer, got {text:?}")))
    }

    fn boolean(&self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<bool>> {
        let Some(p) = self.take(o, name, &["boolean"])? else {
            return Ok(None);
        };
        match self.required(p, "value")?.as_str() {
            "true" => Ok(Some(true)),
            "false" => Ok(Some(false)),
            other => Err(self.err(p, format!("value: expected true or false, got {other:?}"))),
        }
    }

    fn string(&self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<(Node<'a, 'i>, String)>> {
        self.take(o, name, &["string"])?
            .map(|p| Ok((p, self.required(p, "value")?)))
            .transpose()
    }

    /// A colour: `rgb` (one or three numbers), `float`, or a `spectrum` holding one number.
    fn colour(&self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<Triple>> {
        if let Some(c) = o.children.iter().find(|c| c.attribute("name") == Some(name)) {
            return Err(self.err(
                *c,
                format!("{name}: textures are not supported; give an <rgb> or a <float>"),
            ));
        }
        let Some(p) = self.take(o, name, &["rgb", "float", "spectrum"])? else {
            return Ok(None);
        };
        let text = self.required(p, "value")?;
        if text.contains(':') {
            return Err(self.err(
                p,
                "value: wavelength:value spectra are not supported (photon-bench renders RGB); \
                 give one number or an <rgb>",
            ));
        }
        match (p.tag_name().name(), self.numbers(p, "value", &text)?.as_slice()) {
            (_, [v]) => Ok(Some(Fixed([*v; 3]))),
            ("rgb", [r, g, b]) => Ok(Some(Fixed([*r, *g, *b]))),
            _ => Err(self.err(
                p,
                format!("value: expected one number or (for <rgb>) three, got {text:?}"),
            )),
        }
    }

    fn point(&self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<DVec3>> {
        let Some(p) = self.take(o, name, &["point", "vector"])? else {
            return Ok(None);
        };
        if p.attribute("value").is_some() {
            return self.triple_attr(p, "value").map(Some);
        }
        Ok(Some(DVec3::new(
            self.coord(p, "x", 0.0)?,
            self.coord(p, "y", 0.0)?,
            self.coord(p, "z", 0.0)?,
        )))
    }

    /// A `<transform name>` as a 4 × 4 matrix acting on column vectors.
    fn transform(&self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<(Node<'a, 'i>, DMat4)>> {
        let Some(t) = self.take(o, name, &["transform"])? else {
            return Ok(None);
        };
        let mut m = DMat4::IDENTITY;
        for op in t.children().filter(Node::is_element) {
            let step = match op.tag_name().name() {
                "translate" => {
                    let v = if op.attribute("value").is_some() {
                        self.triple_attr(op, "value")?
                    } else {
                        self.coords(op, 0.0)?
                    };
                    DMat4::from_translation(v)
                }
                "scale" => {
                    let v = if let Some(text) = self.attr(op, "value")? {
                        match self.numbers(op, "value", &text)?.as_slice() {
                            [s] => DVec3::splat(*s),
                            [x, y, z] => DVec3::new(*x, *y, *z),
                            _ => {
                                return Err(self.err(op, format!("value: expected one or three numbers, got {text:?}")));
                            }
                        }
                    } else {
                        self.coords(op, 1.0)?
                    };
                    DMat4::from_scale(v)
                }
                "rotate" => {
                    let axis = if op.attribute("value").is_some() {
                        self.triple_attr(op, "value")?
                    } else {
                        self.coords(op, 0.0)?
                    };
                    let angle = self.number(op, "angle")?;
                    let Some(axis) = axis.try_normalize() else {
                        return Err(self.err(op, "expected a non-zero rotation axis"));
                    };
                    DMat4::from_axis_angle(axis, angle.to_radians())
                }
                "matrix" => {
                    let text = self.required(op, "value")?;
                    match self.numbers(op, "value", &text)?.as_slice() {
                        v if v.len() == 16 => DMat4::from_cols_array(&[
                            v[0], v[4], v[8], v[12], v[1], v[5], v[9], v[13], v[2], v[6], v[10], v[14], v[3], v[7],
                            v[11], v[15],
                        ]),
                        v if v.len() == 9 => DMat4::from_mat3(DMat3::from_cols_array(&[
                            v[0], v[3], v[6], v[1], v[4], v[7], v[2], v[5], v[8],
                        ])),
                        v => {
                            return Err(self.err(op, format!("value: expected 16 or 9 numbers, got {}", v.len())));
                        }
                    }
                }
                "lookat" => {
                    let origin = self.triple_attr(op, "origin")?;
                    let target = self.triple_attr(op, "target")?;
                    let up = self.triple_attr(op, "up")?;
                    let Some(dir) = (target - origin).try_normalize() else {
                        return Err(self.err(op, "target must differ from origin"));
                    };
                    let Some(left) = up.cross(dir).try_normalize() else {
                        return Err(self.err(op, "up must be non-zero and not parallel to target - origin"));
                    };
                    let new_up = dir.cross(left);
                    DMat4::from_cols(
                        left.extend(0.0),
                        new_up.extend(0.0),
                        dir.extend(0.0),
                        origin.extend(1.0),
                    )
                }
                other => {
                    return Err(self.err(
                        op,
                        format!("unsupported transform operation <{other}> (translate, rotate, scale, matrix, lookat)"),
                    ));
                }
            };
            m = step * m;
        }
        if !m.to_cols_array().iter().all(|x| x.is_finite()) {
            return Err(self.err(t, "the composed transform is not finite"));
        }
        if m.row(3) != DVec4::new(0.0, 0.0, 0.0, 1.0) {
            return Err(self.err(t, "the last row must be 0 0 0 1 (affine transforms only)"));
        }
        Ok(Some((t, m)))
    }

    // -----------------------------------------------------------------------------------------

    fn scene(&mut self, root: Node<'a, 'i>) -> Result<Imported> {
        if root.tag_name().name() != "scene" {
            return Err(self.err(root, "expected a Mitsuba 3 <scene> root element"));
        }
        // Defaults first: `$name` may appear anywhere, also before its <default>.
        for n in root.children().filter(|n| n.has_tag_name("default")) {
            let name = self.required(n, "name")?;
            let value = self
                .attr(n, "value")?
                .ok_or_else(|| self.err(n, "expected a `value` attribute"))?;
            if self.defaults.insert(name.clone(), value).is_some() {
                return Err(self.err(n, format!("default {name:?} is given twice")));
            }
        }
        let mut camera = None;
        let mut shapes = Vec::new();
        let mut labels = Vec::new();
        let elements: Vec<Node> = root.children().filter(Node::is_element).collect();
        // Named BSDFs first, so that a <ref> may precede the definition it names.
        for &n in &elements {
            if n.has_tag_name("bsdf") {
                let Some(id) = self.attr(n, "id")? else {
                    return Err(self.err(n, "a top-level <bsdf> needs an `id` for shapes to <ref> it"));
                };
                let m = self.bsdf(n)?;
                if self.bsdf_ids.contains_key(&id) || self.materials.contains_key(&id) {
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
                "default" | "bsdf" => {}
                "sensor" => {
                    if camera.is_some() {
                        return Err(self.err(n, "a second <sensor>: photon-bench renders one camera per scene"));
                    }
                    camera = Some(self.sensor(n)?);
                }
                "shape" => {
                    labels.push(self.label(n));
                    shapes.push(self.shape(n, shapes.len())?);
                }
                "integrator" => self.warn(
                    n,
                    "ignored: the experiment file chooses the strategy (Mitsuba's max_depth N is our max_depth N - 1)",
                ),
                "emitter" => {
                    return Err(self.err(
                        n,
                        "unsupported emitter: photon-bench has area lights only (put <emitter type=\"area\"> inside a <shape>)",
                    ));
                }
                other => {
                    return Err(self.err(
                        n,
                        format!(
                            "unsupported element <{other}> (photon-bench reads default, sensor, bsdf, shape and integrator)"
                        ),
                    ));
                }
            }
        }
        let Some(camera) = camera else {
            return Err(Error::new(format!(
                "{}: no <sensor>: add <sensor type=\"perspective\"> with a fov, a to_world and a film",
                self.file
            )));
        };
        if !shapes.iter().any(|s| {
            s.common()
                .2
                .is_some_and(|e: &desc::EmissionDesc| e.radiance.iter().any(|&c| c > 0.0))
        }) {
            return Err(Error::new(format!(
                "{}: no light: add <emitter type=\"area\"><rgb name=\"radiance\" value=\"…\"/></emitter> with a \
                 positive channel to a <shape>",
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
            },
            shape_labels: labels,
            warnings: std::mem::take(&mut self.warnings),
        })
    }

    fn sensor(&mut self, n: Node<'a, 'i>) -> Result<CameraDesc> {
        let kind = self.required(n, "type")?;
        if kind != "perspective" {
            return Err(self.err(
                n,
                format!("unsupported sensor {kind:?}: photon-bench has a pinhole camera (perspective)"),
            ));
        }
        let mut o = self.obj(n)?;
        let Some(fov) = self.float(&mut o, "fov")? else {
            return Err(self.err(n, "expected <float name=\"fov\"> (focal_length is not supported)"));
        };
        if !(fov > 0.0 && fov < 180.0) {
            return Err(self.err(n, format!("fov: expected degrees in (0, 180), got {fov}")));
        }
        let axis = match self.string(&mut o, "fov_axis")? {
            None => "x".to_string(),
            Some((_, a)) => a,
        };
        for clip in ["near_clip", "far_clip"] {
            if let Some(p) = o.props.get(clip).copied() {
                self.float(&mut o, clip)?;
                self.warn(p, "ignored: photon-bench's camera has no clipping planes");
            }
        }
        let m = match self.transform(&mut o, "to_world")? {
            Some((_, m)) => m,
            None => DMat4::IDENTITY,
        };
        let (mut width, mut height) = (None, None);
        for c in o.children.clone() {
            match c.tag_name().name() {
                "film" => {
                    if width.is_some() {
                        return Err(self.err(c, "a second <film>"));
                    }
                    let (w, h) = self.film(c)?;
                    (width, height) = (Some(w), Some(h));
                }
                "sampler" => self.warn(c, "ignored: the experiment file sets the samples per pixel"),
                other => return Err(self.err(c, format!("unsupported element <{other}> in a sensor (film, sampler)"))),
            }
        }
        self.finish(&o)?;
        let (w, h) = (
            width.unwrap_or(DEFAULT_WIDTH as u32),
            height.unwrap_or(DEFAULT_HEIGHT as u32),
        );

        // Mitsuba's camera frame: columns left, up, forward, position.
        let col = |i: usize| m.col(i).truncate();
        let (left, up, fwd, eye) = (col(0), col(1), col(2), col(3));
        let rigid = [left, up, fwd].iter().all(|c| (c.length() - 1.0).abs() < 1e-4)
            && left.dot(up).abs() < 1e-4
            && left.dot(fwd).abs() < 1e-4
            && up.dot(fwd).abs() < 1e-4;
        if !rigid {
            return Err(self.err(
                n,
                "to_world: expected a rotation and translation only (no scale or shear on a camera)",
            ));
        }
        if DMat3::from_cols(left, up, fwd).determinant() < 0.0 {
            return Err(self.err(n, "to_world: a mirrored camera (negative determinant) is not supported"));
        }
        let (wf, hf) = (w as f64, h as f64);
        let t = (0.5 * fov.to_radians()).tan();
        let half_h = match axis.as_str() {
            "x" => t * hf / wf,
            "y" => t,
            "diagonal" => t * hf / (wf * wf + hf * hf).sqrt(),
            "smaller" if w < h => t * hf / wf,
            "smaller" => t,
            "larger" if w > h => t * hf / wf,
            "larger" => t,
            other => {
                return Err(self.err(
                    n,
                    format!("fov_axis: expected x, y, diagonal, smaller or larger, got {other:?}"),
                ));
            }
        };
        Ok(CameraDesc {
            eye: Fixed(eye.to_array()),
            look_at: Fixed((eye + fwd).to_array()),
            up: Fixed(up.to_array()),
            fov_y: 2.0 * half_h.atan().to_degrees(),
            resolution: Fixed([w, h]),
        })
    }

    fn film(&mut self, n: Node<'a, 'i>) -> Result<(u32, u32)> {
        let kind = self.required(n, "type")?;
        if kind != "hdrfilm" {
            return Err(self.err(n, format!("unsupported film {kind:?} (hdrfilm)")));
        }
        let mut o = self.obj(n)?;
        let mut size = [0u32; 2];
        for (i, (key, default)) in [("width", DEFAULT_WIDTH), ("height", DEFAULT_HEIGHT)]
            .into_iter()
            .enumerate()
        {
            let node = o.props.get(key).copied().unwrap_or(n);
            let v = self.integer(&mut o, key)?.unwrap_or(default);
            if !(1..=i64::from(super::load::MAX_RESOLUTION_SIDE)).contains(&v) {
                return Err(self.err(
                    node,
                    format!("{key}: expected 1..={}, got {v}", super::load::MAX_RESOLUTION_SIDE),
                ));
            }
            size[i] = v as u32;
        }
        // These choose how Mitsuba writes its output file, not the image's values.
        for key in ["pixel_format", "component_format", "file_format"] {
            self.string(&mut o, key)?;
        }
        for key in ["banner", "sample_border"] {
            self.boolean(&mut o, key)?;
        }
        let mut box_filter = false;
        for c in o.children.clone() {
            match c.tag_name().name() {
                "rfilter" => {
                    box_filter = self.attr(c, "type")?.as_deref() == Some("box");
                    if !box_filter {
                        self.warn(
                            c,
                            "photon-bench's film is a box filter (each sample counts in its own pixel); \
                             Mitsuba's images with this filter are slightly blurrier",
                        );
                    }
                }
                other => return Err(self.err(c, format!("unsupported element <{other}> in a film (rfilter)"))),
            }
        }
        if !box_filter && !o.children.iter().any(|c| c.has_tag_name("rfilter")) {
            self.warn(
                n,
                "no <rfilter>: Mitsuba's default is a Gaussian; photon-bench's film is a box filter \
                 (add <rfilter type=\"box\"/> for equal images)",
            );
        }
        self.finish(&o)?;
        Ok((size[0], size[1]))
    }

    /// A BSDF element as one of our materials.
    fn bsdf(&mut self, n: Node<'a, 'i>) -> Result<MaterialDesc> {
        let kind = self.required(n, "type")?;
        if kind == "twosided" {
            let o = self.obj(n)?;
            self.finish(&o)?;
            let inner: Vec<Node> = o.children.iter().copied().filter(|c| c.has_tag_name("bsdf")).collect();
            if let Some(&c) = o.children.iter().find(|c| !c.has_tag_name("bsdf")) {
                return Err(self.err(c, "unexpected element in a twosided BSDF"));
            }
            let [inner] = inner[..] else {
                return Err(self.err(
                    n,
                    "expected exactly one nested <bsdf> (a different back side is not supported)",
                ));
            };
            let m = self.one_bsdf(inner)?;
            if matches!(m, MaterialDesc::Dielectric(_)) {
                return Err(self.err(inner, "a dielectric cannot be two-sided (Mitsuba refuses it too)"));
            }
            return Ok(m);
        }
        let m = self.one_bsdf(n)?;
        if !matches!(m, MaterialDesc::Dielectric(_)) {
            self.warn(
                n,
                "one-sided in Mitsuba 3 (black from behind), two-sided in photon-bench; wrap it in \
                 <bsdf type=\"twosided\"> for equal renders",
            );
        }
        Ok(m)
    }

    fn one_bsdf(&mut self, n: Node<'a, 'i>) -> Result<MaterialDesc> {
        let kind = self.required(n, "type")?;
        let mut o = self.obj(n)?;
        let m = match kind.as_str() {
            "diffuse" => MaterialDesc::Diffuse(desc::Diffuse {
                reflectance: self.colour(&mut o, "reflectance")?.unwrap_or(Fixed([0.5; 3])),
            }),
            "conductor" | "roughconductor" => {
                if let Some((p, material)) = self.string(&mut o, "material")?
                    && material != "none"
                {
                    return Err(self.err(
                        p,
                        format!(
                            "material {material:?}: named metals need a Fresnel conductor, which photon-bench \
                             does not have; use material=\"none\" with a specular_reflectance"
                        ),
                    ));
                }
                for key in ["eta", "k"] {
                    if let Some(&p) = o.props.get(key) {
                        return Err(self.err(
                            p,
                            "complex indices of refraction are not supported (material=\"none\" only)",
                        ));
                    }
                }
                let reflectance = self.colour(&mut o, "specular_reflectance")?.unwrap_or(Fixed([1.0; 3]));
                if kind == "conductor" {
                    MaterialDesc::Mirror(desc::Mirror { reflectance })
                } else {
                    if let Some((p, d)) = self.string(&mut o, "distribution")?
                        && !(d == "beckmann" || d == "ggx")
                    {
                        return Err(self.err(p, format!("distribution: expected beckmann or ggx, got {d:?}")));
                    }
                    self.boolean(&mut o, "sample_visible")?;
                    let alpha = self.float(&mut o, "alpha")?;
                    let au = self.float(&mut o, "alpha_u")?;
                    let av = self.float(&mut o, "alpha_v")?;
                    let (ax, ay) = match (alpha, au, av) {
                        (a, None, None) => (a.unwrap_or(0.1), a.unwrap_or(0.1)),
                        (None, Some(u), Some(v)) => (u, v),
                        _ => return Err(self.err(n, "expected either alpha or both alpha_u and alpha_v")),
                    };
                    self.warn(
                        n,
                        "approximated by photon-bench's Ward model (alpha as its roughness, no Fresnel term); \
                         renders will differ from Mitsuba's microfacet conductor",
                    );
                    MaterialDesc::Ward(desc::Ward {
                        diffuse: Fixed([0.0; 3]),
                        specular: reflectance,
                        alpha_x: ax,
                        alpha_y: ay,
                    })
                }
            }
            "dielectric" => {
                let int_ior = self.ior(&mut o, "int_ior", 1.5046)?;
                let ext_ior = self.ior(&mut o, "ext_ior", 1.000277)?;
                for key in ["specular_reflectance", "specular_transmittance"] {
                    if let Some(c) = self.colour(&mut o, key)?
                        && c.0 != [1.0; 3]
                    {
                        return Err(self.err(n, format!("{key}: only 1 (clear glass) is supported, got {:?}", c.0)));
                    }
                }
                MaterialDesc::Dielectric(desc::Dielectric { ior: int_ior / ext_ior })
            }
            other => {
                return Err(self.err(
                    n,
                    format!("unsupported BSDF {other:?} (diffuse, conductor, roughconductor, dielectric, twosided)"),
                ));
            }
        };
        if let Some(&c) = o.children.first() {
            return Err(self.err(c, "unexpected element in a BSDF"));
        }
        self.finish(&o)?;
        Ok(m)
    }

    fn ior(&self, o: &mut Obj<'a, 'i>, key: &str, default: f64) -> Result<f64> {
        let Some(p) = self.take(o, key, &["float", "string"])? else {
            return Ok(default);
        };
        let text = self.required(p, "value")?;
        let v = match NAMED_IOR.iter().find(|(name, _)| *name == text) {
            Some(&(_, v)) => v,
            None => self.number(p, "value")?,
        };
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(p, format!("value: expected a positive index of refraction, got {v}")))
        }
    }

    fn shape(&mut self, n: Node<'a, 'i>, index: usize) -> Result<ShapeDesc> {
        let kind = self.required(n, "type")?;
        let mut o = self.obj(n)?;
        let transform = self.transform(&mut o, "to_world")?.map(|(_, m)| matrix_step(m));
        if let Some(true) = self.boolean(&mut o, "flip_normals")? {
            return Err(self.err(n, "flip_normals=\"true\" is not supported"));
        }
        let mut material = None;
        let mut emission = None;
        for c in o.children.clone() {
            match c.tag_name().name() {
                "bsdf" | "ref" if material.is_some() => {
                    return Err(self.err(c, "a second BSDF for this shape"));
                }
                "bsdf" => {
                    let m = self.bsdf(c)?;
                    let name = match self.attr(c, "id")? {
                        Some(id) => id,
                        None => format!("shape{index}"),
                    };
                    if self.materials.contains_key(&name) {
                        return Err(self.err(c, format!("id {name:?} is used twice")));
                    }
                    self.materials.insert(name.clone(), m);
                    material = Some(name);
                }
                "ref" => {
                    let id = self.required(c, "id")?;
                    let Some(name) = self.bsdf_ids.get(&id) else {
                        return Err(self.err(c, format!("no top-level <bsdf id=\"{id}\"> to refer to")));
                    };
                    material = Some(name.clone());
                }
                "emitter" => {
                    if emission.is_some() {
                        return Err(self.err(c, "a second emitter for this shape"));
                    }
                    emission = Some(self.area(c)?);
                }
                other => {
                    return Err(self.err(
                        c,
                        format!("unsupported element <{other}> in a shape (bsdf, ref, emitter)"),
                    ));
                }
            }
        }
        let material = match material {
            Some(m) => m,
            None => {
                // Mitsuba gives a shape without a BSDF a one-sided diffuse 0.5.
                let name = "mitsuba-default".to_string();
                self.materials
                    .entry(name.clone())
                    .or_insert(MaterialDesc::Diffuse(desc::Diffuse {
                        reflectance: Fixed([0.5; 3]),
                    }));
                self.warn(
                    n,
                    "no BSDF: Mitsuba's default diffuse 0.5 (one-sided in Mitsuba, two-sided in photon-bench)",
                );
                name
            }
        };
        let shape = match kind.as_str() {
            "rectangle" => ShapeDesc::Quad(desc::Quad {
                material,
                corner: Some(Fixed([-1.0, -1.0, 0.0])),
                edge_u: Some(Fixed([2.0, 0.0, 0.0])),
                edge_v: Some(Fixed([0.0, 2.0, 0.0])),
                center: None,
                size: None,
                facing: None,
                subdivide: None,
                transform,
                emission,
            }),
            "cube" => ShapeDesc::Box(desc::Cuboid {
                material,
                min: Some(Fixed([-1.0; 3])),
                max: Some(Fixed([1.0; 3])),
                center: None,
                size: None,
                subdivide: None,
                transform,
                emission,
            }),
            "sphere" => ShapeDesc::Sphere(desc::Sphere {
                material,
                center: Fixed(self.point(&mut o, "center")?.unwrap_or(DVec3::ZERO).to_array()),
                radius: self.float(&mut o, "radius")?.unwrap_or(1.0),
                transform,
                emission,
            }),
            "obj" => {
                let Some((p, file)) = self.string(&mut o, "filename")? else {
                    return Err(self.err(n, "expected <string name=\"filename\">"));
                };
                let face_normals = self.boolean(&mut o, "face_normals")?.unwrap_or(false);
                let path = self.dir.join(&file);
                let text = std::fs::read(&path)
                    .map_err(|e| self.err(p, format!("filename: cannot read {}: {e}", path.display())))?;
                let has_normals = text
                    .split(|&b| b == b'\n')
                    .any(|l| l.trim_ascii_start().starts_with(b"vn "));
                if !face_normals && !has_normals {
                    self.warn(
                        n,
                        "the OBJ has no normals: Mitsuba smooths vertex normals, photon-bench shades flat \
                         (face_normals=\"true\" makes both flat)",
                    );
                }
                ShapeDesc::Mesh(desc::Mesh {
                    material,
                    file,
                    face_normals,
                    transform,
                    emission,
                })
            }
            other => {
                return Err(self.err(n, format!("unsupported shape {other:?} (obj, rectangle, cube, sphere)")));
            }
        };
        self.finish(&o)?;
        Ok(shape)
    }

    fn area(&mut self, n: Node<'a, 'i>) -> Result<desc::EmissionDesc> {
        let kind = self.required(n, "type")?;
        if kind != "area" {
            return Err(self.err(n, format!("unsupported emitter {kind:?} in a shape (area)")));
        }
        let mut o = self.obj(n)?;
        let Some(radiance) = self.colour(&mut o, "radiance")? else {
            return Err(self.err(n, "expected a radiance (<rgb name=\"radiance\" value=\"r, g, b\"/>)"));
        };
        if !radiance.iter().all(|&c| c >= 0.0) {
            return Err(self.err(n, format!("radiance: expected each channel >= 0, got {:?}", radiance.0)));
        }
        if let Some(&c) = o.children.first() {
            return Err(self.err(c, "unexpected element in an emitter"));
        }
        self.finish(&o)?;
        Ok(desc::EmissionDesc {
            radiance,
            two_sided: false,
        })
    }
}

/// A 4 × 4 affine matrix as one `matrix` step of our transform format (row-major).
fn matrix_step(m: DMat4) -> TransformDesc {
    let row = |i: usize| Fixed(m.row(i).to_array());
    TransformDesc(vec![TransformStep {
        matrix: Some(Fixed([row(0), row(1), row(2), row(3)])),
        ..TransformStep::default()
    }])
}
