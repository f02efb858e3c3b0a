//! `bench export-mitsuba`: a scene description written as an equivalent Mitsuba 3 XML scene.
//!
//! Decisions, each chosen so that Mitsuba 3 renders the same image as our `path`:
//! - the camera is a `perspective` (or `thinlens`) sensor with `fov_axis="y"` (our `fov_y` as
//!   is) and a `lookat`, or an `orthographic` one whose `to_world` scales its camera space to
//!   the view's extent; the film is an `hdrfilm` with our pixel filter and crop window;
//! - reflecting materials are wrapped in `twosided`, since ours reflect on both sides and
//!   Mitsuba's are black from behind; a `mirror` is a `conductor` with `material="none"`; a
//!   `dielectric` gets `ext_ior = 1` (Mitsuba's default outside is air, 1.000277);
//! - a `ward` with no diffuse part becomes a `roughconductor` (Beckmann, α as Ward's α), with a
//!   warning: the two lobes are alike but not equal. `phong`, `ward` with a diffuse part and
//!   `diffuse_transmission` have no Mitsuba 3 counterpart and are refused;
//! - a quad is a `rectangle` and a box a `cube`, with the `to_world` matrix that maps Mitsuba's
//!   [−1, 1]² (or ³) onto them (our transform included), so the triangles are ours; spheres
//!   keep `center` and `radius`, disks and cylinders their Mitsuba parameters (`p0`, `p1`,
//!   `radius`, `flip_normals`) and our transform as `to_world`, so that both sides tessellate
//!   the same description; meshes keep their OBJ file (made absolute when the XML goes
//!   to another directory) with `face_normals="true"` when the OBJ has no normals (Mitsuba
//!   would smooth them; we shade flat);
//! - two-sided emission is refused (Mitsuba's area lights emit from the front only);
//! - user paths (Metropolis photon sampling) have no Mitsuba form and are left out, with a
//!   warning. No integrator is written: the caller (e.g. `scripts/crosscheck_mitsuba.py`)
//!   chooses it.
//!
//! Reading the file back ([`super::mitsuba::import`]) gives the same scene: same triangles and spheres to
//! float precision, same camera rays, same materials (`tests/mitsuba.rs`).

use super::desc::{
    self, Color, EnvironmentDesc, Fixed, MaterialDesc, Roughness, SceneDesc, ShapeDesc, TextureDesc, Triple,
};
use super::load::{load_scene_with_stats, quad_corner_edges, read_desc, shape_transform};
use crate::error::{Context, Error, Result};
use glam::{DAffine3, DMat3, DMat4, DVec3};
use std::fmt::Write;
use std::path::{Path, PathBuf};

mod materials;
mod media;
use materials::material_xml;

/// Mitsuba's rectangle and cube are two and twelve triangles: a subdivided quad or box (the
/// same surface, more triangles: what scale measurements need) cannot be written as one.
fn subdivided(subdivide: Option<i64>) -> bool {
    subdivide.is_some_and(|n| n > 1)
}

const SUBDIVIDE_REFUSED: &str = "subdivide has no Mitsuba 3 equivalent (its rectangle and cube are not subdivided)";

/// Writes `scene` (a TOML, Mitsuba or pbrt-v4 scene file) as Mitsuba 3 XML to `out`; returns
/// the warnings (approximations and what was left out), one line each.
pub fn export_file(scene: &Path, out: &Path) -> Result<Vec<String>> {
    // The scene must load as it is: export never writes what `bench run` would refuse.
    let (_, stats) = load_scene_with_stats(scene)?;
    let desc = if super::load::is_mitsuba(scene) {
        let text = crate::util::read_input_to_string(scene, "scene file", crate::util::MAX_TEXT_INPUT)?;
        let dir = scene.parent().unwrap_or(Path::new(""));
        super::mitsuba::import(&scene.display().to_string(), dir, &text)?.desc
    } else if super::pbrt::is_pbrt(scene) {
        super::pbrt::import_file(scene)?.desc
    } else {
        read_desc(scene)?
    };
    let out_dir = out
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let stem = out
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().to_string());
    let Exported {
        xml,
        mut warnings,
        meshes,
    } = to_xml(&desc, scene, (out_dir, &stem))?;
    warnings.splice(0..0, stats.warnings);
    // The meshes of `triangles` shapes first, then the file that names them: each written
    // whole (atomically), and only once the whole export has succeeded.
    for (path, bytes) in &meshes {
        crate::util::write_atomic(path, bytes)?;
    }
    std::fs::write(out, xml).context(out.display())?;
    Ok(warnings)
}

/// What [`to_xml`] makes: the XML, its warnings, and the mesh files it names (path, bytes).
pub struct Exported {
    pub xml: String,
    pub warnings: Vec<String>,
    pub meshes: Vec<(PathBuf, Vec<u8>)>,
}

/// The XML text of a scene description read from `scene`; mesh paths are written relative to
/// `out_dir` when it is the scene's own directory, absolute otherwise. A `triangles` shape
/// becomes a PLY file beside the output, `<stem>-triangles-<i>.ply`, returned with its bytes
/// for the caller to write.
pub fn to_xml(desc: &SceneDesc, scene: &Path, (out_dir, stem): (&Path, &str)) -> Result<Exported> {
    let mut meshes = Vec::new();
    let file = scene.display().to_string();
    let err = |field: &str, msg: &str| Error::new(format!("{file}: {field}: {msg}"));
    let mut warnings = Vec::new();
    let mut x = String::new();
    let c = &desc.camera;
    let _ = writeln!(x, "<?xml version=\"1.0\" encoding=\"utf-8\"?>");
    let _ = writeln!(
        x,
        "<!-- Exported by photon-bench from {}. Mitsuba 3, scalar_rgb; our path max_depth N is \
         Mitsuba's N + 1. -->",
        escape(&file.replace("--", "-"))
    );
    let _ = writeln!(x, "<scene version=\"3.0.0\">");
    let scene_dir = scene.parent().unwrap_or(Path::new(""));
    let files = Files { scene_dir, out_dir };
    x.push_str(&media::media_xml(desc, &files, &file)?);
    let [fw, fh] = c.resolution.0;
    match c.lens {
        Some(desc::LensDesc::Orthographic(o)) => {
            // Mitsuba's orthographic camera space spans [−1, 1] × [−1/aspect, 1/aspect]; its
            // to_world's scale sizes the view.
            let width = o.width.unwrap_or(o.height * fw as f64 / fh as f64);
            let _ = writeln!(x, "    <sensor type=\"orthographic\">");
            let _ = writeln!(x, "        <transform name=\"to_world\">");
            let _ = writeln!(
                x,
                "            <scale x=\"{}\" y=\"{}\"/>",
                0.5 * width,
                0.5 * o.height * fw as f64 / fh as f64
            );
        }
        lens => {
            if let Some(desc::LensDesc::Thin(t)) = lens {
                let _ = writeln!(x, "    <sensor type=\"thinlens\">");
                let _ = writeln!(
                    x,
                    "        <float name=\"aperture_radius\" value=\"{}\"/>",
                    t.aperture_radius
                );
                let _ = writeln!(
                    x,
                    "        <float name=\"focus_distance\" value=\"{}\"/>",
                    t.focus_distance
                );
            } else {
                let _ = writeln!(x, "    <sensor type=\"perspective\">");
            }
            let _ = writeln!(x, "        <string name=\"fov_axis\" value=\"y\"/>");
            let _ = writeln!(x, "        <float name=\"fov\" value=\"{}\"/>", c.fov_y.unwrap_or(45.0));
            let _ = writeln!(x, "        <transform name=\"to_world\">");
        }
    }
    if c.flip_x {
        // Mirrored before it is placed: the frame's first column turns around.
        let _ = writeln!(x, "            <scale x=\"-1\"/>");
    }
    let _ = writeln!(
        x,
        "            <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>",
        nums(&c.eye.0),
        nums(&c.look_at.0),
        nums(&c.up.0)
    );
    let _ = writeln!(x, "        </transform>");
    let _ = writeln!(x, "        <film type=\"hdrfilm\">");
    let _ = writeln!(x, "            <integer name=\"width\" value=\"{}\"/>", c.resolution[0]);
    let _ = writeln!(
        x,
        "            <integer name=\"height\" value=\"{}\"/>",
        c.resolution[1]
    );
    if let Some(crop) = c.crop {
        let [ox, oy] = crop.offset.map_or([0, 0], |o| o.0);
        for (name, v) in [
            ("crop_offset_x", ox),
            ("crop_offset_y", oy),
            ("crop_width", crop.size[0]),
            ("crop_height", crop.size[1]),
        ] {
            let _ = writeln!(x, "            <integer name=\"{name}\" value=\"{v}\"/>");
        }
    }
    let _ = writeln!(x, "            {}", rfilter_xml(c.filter));
    let _ = writeln!(x, "            <string name=\"pixel_format\" value=\"rgb\"/>");
    let _ = writeln!(x, "        </film>");
    x.push_str(&media::medium_refs(&[("medium", c.medium.as_deref())], "        "));
    let _ = writeln!(x, "    </sensor>");

    for (name, m) in &desc.materials {
        let field = format!("materials.{name}");
        x.push_str(&material_xml(
            m,
            false,
            &escape(name),
            &field,
            &file,
            &files,
            &mut warnings,
        )?);
    }

    for (i, shape) in desc.shapes.iter().enumerate() {
        let field = format!("shapes[{i}]");
        let (material, transform, emission) = shape.common();
        let t = shape_transform(&file, &field, transform)?;
        let mut props = String::new();
        let kind = match shape {
            ShapeDesc::Triangles(tri) => {
                let name = format!("{stem}-triangles-{i}.ply");
                meshes.push((out_dir.join(&name), triangles_ply(tri)));
                let _ = writeln!(props, "        <string name=\"filename\" value=\"{}\"/>", escape(&name));
                if tri.normals.is_none() {
                    // Ours shade a mesh without normals flat; Mitsuba would smooth it.
                    let _ = writeln!(props, "        <boolean name=\"face_normals\" value=\"true\"/>");
                }
                if transform.is_some() {
                    props.push_str(&matrix(t));
                }
                "ply"
            }
            ShapeDesc::Quad(q) => {
                if subdivided(q.subdivide) {
                    return Err(err(&field, SUBDIVIDE_REFUSED));
                }
                let (corner, u, v) = quad_corner_edges(&file, &field, q)?;
                // [−1, 1]² onto corner + s·u + t·v; the third column only has to keep the map
                // invertible and orientation-preserving (u × v is the front side in both).
                let n = u.cross(v).normalize() * (0.25 * u.length() * v.length()).sqrt();
                let q = DAffine3::from_mat3_translation(DMat3::from_cols(0.5 * u, 0.5 * v, n), corner + 0.5 * (u + v));
                props.push_str(&matrix(t * q));
                "rectangle"
            }
            ShapeDesc::Box(b) => {
                if subdivided(b.subdivide) {
                    return Err(err(&field, SUBDIVIDE_REFUSED));
                }
                let (lo, hi) = match (b.min, b.max, b.center, b.size) {
                    (Some(lo), Some(hi), _, _) => (dvec(lo), dvec(hi)),
                    (_, _, Some(c), Some(s)) => (dvec(c) - 0.5 * dvec(s), dvec(c) + 0.5 * dvec(s)),
                    _ => return Err(err(&field, "a box needs either `min` and `max` or `center` and `size`")),
                };
                let q = DAffine3::from_mat3_translation(DMat3::from_diagonal(0.5 * (hi - lo)), 0.5 * (lo + hi));
                props.push_str(&matrix(t * q));
                "cube"
            }
            ShapeDesc::Sphere(s) => {
                let _ = writeln!(
                    props,
                    "        <point name=\"center\" value=\"{}\"/>",
                    nums(&s.center.0)
                );
                let _ = writeln!(props, "        <float name=\"radius\" value=\"{}\"/>", s.radius);
                if transform.is_some() {
                    props.push_str(&matrix(t));
                }
                "sphere"
            }
            ShapeDesc::Disk(d) => {
                props.push_str(&flip_normals(d.flip_normals));
                if transform.is_some() {
                    props.push_str(&matrix(t));
                }
                "disk"
            }
            ShapeDesc::Cylinder(c) => {
                props.push_str(&cylinder_props(c));
                if transform.is_some() {
                    props.push_str(&matrix(t));
                }
                "cylinder"
            }
            ShapeDesc::LinearCurve(c) | ShapeDesc::BsplineCurve(c) => {
                let _ = writeln!(
                    props,
                    "        <string name=\"filename\" value=\"{}\"/>",
                    escape(&files.written(&c.file).display().to_string())
                );
                if transform.is_some() {
                    props.push_str(&matrix(t));
                }
                if matches!(shape, ShapeDesc::LinearCurve(_)) {
                    "linearcurve"
                } else {
                    "bsplinecurve"
                }
            }
            ShapeDesc::Mesh(m) => {
                let path = scene_dir.join(&m.file);
                if crate::util::is_gzip(&path) {
                    return Err(err(
                        &format!("{field}.file"),
                        "Mitsuba 3 does not read gzip-compressed meshes; decompress it first",
                    ));
                }
                let written = files.written(&m.file);
                let kind = match path
                    .extension()
                    .and_then(|e| e.to_str())
                    .map(str::to_ascii_lowercase)
                    .as_deref()
                {
                    Some("ply") => "ply",
                    Some("serialized") => "serialized",
                    _ => "obj",
                };
                // Whether the file has normals decides nothing when the scene smooths (both
                // renderers then shade smooth) and everything when it does not: a file without
                // normals is shaded flat here, so Mitsuba must be told to.
                let has_normals = {
                    let bytes = crate::util::read_input(&path, "mesh", crate::util::MAX_MESH_INPUT)
                        .map_err(|e| err(&format!("{field}.file"), &format!("{e}")))?;
                    crate::scene::load::mesh_file_has_normals(&bytes, kind, m.shape_index)
                        .map_err(|e| err(&format!("{field}.file"), &e))?
                };
                let _ = writeln!(
                    props,
                    "        <string name=\"filename\" value=\"{}\"/>",
                    escape(&written.display().to_string())
                );
                if m.face_normals || (!has_normals && !m.smooth_normals) {
                    let _ = writeln!(props, "        <boolean name=\"face_normals\" value=\"true\"/>");
                }
                // Mitsuba's flip_normals turns the winding's normals, which decide where the
                // file has none (or they are ignored).
                if m.reverse_orientation && (m.face_normals || !has_normals) {
                    let _ = writeln!(props, "        <boolean name=\"flip_normals\" value=\"true\"/>");
                }
                if let Some(i) = m.shape_index {
                    let _ = writeln!(props, "        <integer name=\"shape_index\" value=\"{i}\"/>");
                }
                if transform.is_some() {
                    props.push_str(&matrix(t));
                }
                kind
            }
        };
        let _ = writeln!(x, "    <shape type=\"{kind}\">");
        x.push_str(&props);
        let _ = writeln!(x, "        <ref id=\"{}\"/>", escape(material));
        let (interior, exterior) = shape.media();
        x.push_str(&media::medium_refs(
            &[("interior", interior), ("exterior", exterior)],
            "        ",
        ));
        if let Some(e) = emission {
            if e.two_sided {
                return Err(err(
                    &format!("{field}.emission.two_sided"),
                    "Mitsuba 3's area lights emit from the front side only; two-sided emission cannot be exported",
                ));
            }
            let _ = writeln!(
                x,
                "        <emitter type=\"area\">\n            <rgb name=\"radiance\" value=\"{}\"/>\n        </emitter>",
                nums(&e.radiance.0)
            );
        }
        let _ = writeln!(x, "    </shape>");
    }
    match &desc.environment {
        None => {}
        Some(EnvironmentDesc::Constant(c)) => {
            let _ = writeln!(
                x,
                "    <emitter type=\"constant\">\n        <rgb name=\"radiance\" value=\"{}\"/>\n    </emitter>",
                nums(&c.radiance.0)
            );
        }
        Some(EnvironmentDesc::Envmap(m)) if m.mapping.as_deref() == Some("equal_area") => {
            return Err(Error::new(format!(
                "{file}: environment.mapping: pbrt-v4's equal-area map has no Mitsuba 3 equivalent"
            )));
        }
        Some(EnvironmentDesc::Envmap(m)) => {
            let t = shape_transform(&file, "environment", m.transform.as_ref())?;
            let _ = writeln!(
                x,
                "    <emitter type=\"envmap\">\n        <string name=\"filename\" value=\"{}\"/>\n        \
                 <float name=\"scale\" value=\"{}\"/>\n{}    </emitter>",
                escape(&files.written(&m.file).display().to_string()),
                m.scale.unwrap_or(1.0),
                matrix(t)
            );
        }
    }
    for (i, l) in desc.lights.iter().enumerate() {
        if let desc::LightDesc::Spot(s) = l
            && s.falloff.as_deref() == Some("smoothstep")
        {
            return Err(Error::new(format!(
                "{file}: lights[{i}].falloff: pbrt-v4's smoothstep spot has no Mitsuba 3 equivalent"
            )));
        }
        x.push_str(&delta_light_xml(l, &files)?);
    }
    let _ = writeln!(x, "</scene>");
    if !desc.user_paths.is_empty() {
        warnings.push(format!(
            "{file}: user_paths: left out ({} user paths; Mitsuba 3 scenes have no such element)",
            desc.user_paths.len()
        ));
    }
    Ok(Exported {
        xml: x,
        warnings,
        meshes,
    })
}

/// The camera's pixel filter as Mitsuba's `<rfilter>` (the box when none is given: our default,
/// not Mitsuba's).
fn rfilter_xml(f: Option<desc::FilterDesc>) -> String {
    match f {
        None | Some(desc::FilterDesc::Box(_)) => "<rfilter type=\"box\"/>".to_string(),
        Some(desc::FilterDesc::Tent(t)) => format!(
            "<rfilter type=\"tent\"><float name=\"radius\" value=\"{}\"/></rfilter>",
            t.radius.unwrap_or(1.0)
        ),
        Some(desc::FilterDesc::Gaussian(g)) => format!(
            "<rfilter type=\"gaussian\"><float name=\"stddev\" value=\"{}\"/></rfilter>",
            g.stddev.unwrap_or(0.5)
        ),
    }
}

/// A point, spot, projector or directional light as Mitsuba's emitter of the same name (a spot
/// or a projector through a `lookat` with the loader's up).
fn delta_light_xml(l: &desc::LightDesc, files: &Files) -> Result<String> {
    Ok(match l {
        desc::LightDesc::Point(p) => format!(
            "    <emitter type=\"point\">\n        <point name=\"position\" value=\"{}\"/>\n        \
             <rgb name=\"intensity\" value=\"{}\"/>\n    </emitter>\n",
            nums(&p.position.0),
            nums(&p.intensity.0)
        ),
        desc::LightDesc::Directional(d) => format!(
            "    <emitter type=\"directional\">\n        <vector name=\"direction\" value=\"{}\"/>\n        \
             <rgb name=\"irradiance\" value=\"{}\"/>\n    </emitter>\n",
            nums(&d.direction.0),
            nums(&d.irradiance.0)
        ),
        desc::LightDesc::Spot(s) => {
            let picture = match &s.texture {
                Some(t) => files.color("texture", &Color::Texture(t.clone()), "        ")?,
                None => String::new(),
            };
            let angle = |name: &str, v: Option<f64>| {
                v.map(|v| format!("        <float name=\"{name}\" value=\"{v}\"/>\n"))
                    .unwrap_or_default()
            };
            format!(
                "    <emitter type=\"spot\">\n{}        <rgb name=\"intensity\" value=\"{}\"/>\n{}{}{picture}    </emitter>\n",
                lookat_xml(s.position, s.target, s.direction, s.up),
                nums(&s.intensity.0),
                angle("cutoff_angle", s.cutoff_angle),
                angle("beam_width", s.beam_width)
            )
        }
        desc::LightDesc::Projector(p) => {
            let irradiance = files.color(
                "irradiance",
                p.irradiance.as_ref().unwrap_or(&Color::Rgb(Fixed([1.0; 3]))),
                "        ",
            )?;
            format!(
                "    <emitter type=\"projector\">\n{}        <float name=\"fov\" value=\"{}\"/>\n        \
                 <string name=\"fov_axis\" value=\"{}\"/>\n        <float name=\"scale\" value=\"{}\"/>\n{irradiance}    </emitter>\n",
                lookat_xml(p.position, p.target, p.direction, p.up),
                p.fov,
                p.fov_axis.as_deref().unwrap_or("x"),
                p.scale.unwrap_or(1.0)
            )
        }
    })
}

/// A spot's or a projector's `to_world` as a `lookat` with the loader's frame: the same up
/// (given, or the loader's default) so that a picture keeps its orientation.
fn lookat_xml(
    position: desc::Triple,
    target: Option<desc::Triple>,
    direction: Option<desc::Triple>,
    up: Option<desc::Triple>,
) -> String {
    let origin = dvec(position);
    let target = match (target, direction) {
        (Some(t), _) => dvec(t),
        (None, Some(d)) => origin + dvec(d),
        (None, None) => origin - DVec3::Y,
    };
    let axis = (target - origin).normalize_or_zero();
    let up = match up {
        Some(u) => dvec(u),
        None if axis.y.abs() > 0.9 => DVec3::X,
        None => DVec3::Y,
    };
    format!(
        "        <transform name=\"to_world\">\n            <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>\n        </transform>\n",
        nums(&origin.to_array()),
        nums(&target.to_array()),
        nums(&up.to_array())
    )
}

/// A cylinder's axis and radius, Mitsuba's defaults written out, and its `flip_normals`.
fn cylinder_props(c: &desc::Cylinder) -> String {
    format!(
        "        <point name=\"p0\" value=\"{}\"/>\n        <point name=\"p1\" value=\"{}\"/>\n        \
         <float name=\"radius\" value=\"{}\"/>\n{}",
        nums(&c.p0.unwrap_or(Fixed([0.0; 3])).0),
        nums(&c.p1.unwrap_or(Fixed([0.0, 0.0, 1.0])).0),
        c.radius.unwrap_or(1.0),
        flip_normals(c.flip_normals)
    )
}

/// `flip_normals` when set (Mitsuba's default is false).
fn flip_normals(flip: bool) -> String {
    if flip {
        "        <boolean name=\"flip_normals\" value=\"true\"/>\n".to_string()
    } else {
        String::new()
    }
}

fn dvec(v: Triple) -> DVec3 {
    DVec3::from_array(v.0)
}

/// Numbers as Rust prints f64: the shortest text that reads back to the same value.
fn nums(v: &[f64]) -> String {
    v.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(", ")
}

/// A `to_world` holding one row-major matrix.
fn matrix(m: DAffine3) -> String {
    let m = DMat4::from(m);
    let rows: Vec<String> = (0..4).map(|i| nums(&m.row(i).to_array())).collect();
    format!(
        "        <transform name=\"to_world\">\n            <matrix value=\"{}\"/>\n        </transform>\n",
        rows.join(", ")
    )
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

/// Where the scene's files are and where the XML goes.
struct Files<'a> {
    scene_dir: &'a Path,
    out_dir: &'a Path,
}

impl Files<'_> {
    /// A file the scene names (relative to its directory) as the written XML must name it:
    /// as it is when the XML goes to the same directory, by its absolute path otherwise.
    fn written(&self, file: &str) -> PathBuf {
        let same_dir = match (self.scene_dir.canonicalize(), self.out_dir.canonicalize()) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        };
        let path = self.scene_dir.join(file);
        if same_dir {
            PathBuf::from(file)
        } else {
            path.canonicalize().unwrap_or(path)
        }
    }

    /// A colour parameter: `<rgb>`, or the texture as a nested `<texture>`; an error for a
    /// scaled bitmap (Mitsuba's has no factor).
    fn color(&self, name: &str, c: &Color, indent: &str) -> Result<String> {
        let t = match c {
            Color::Rgb(v) => return Ok(format!("{indent}<rgb name=\"{name}\" value=\"{}\"/>\n", nums(&v.0))),
            Color::Texture(t) => t,
        };
        if let TextureDesc::Bitmap(b) = &**t
            && b.scale.is_some_and(|s| s != 1.0)
        {
            return Err(Error::new(format!(
                "{}: {name}: a scaled bitmap (pbrt's scale) has no Mitsuba 3 equivalent",
                b.file
            )));
        }
        let inner = format!("{indent}    ");
        let (kind, mut props, to_uv) = match &**t {
            TextureDesc::Checkerboard(c) => (
                "checkerboard",
                format!(
                    "{inner}<rgb name=\"color0\" value=\"{}\"/>\n{inner}<rgb name=\"color1\" value=\"{}\"/>\n",
                    nums(&c.color0.unwrap_or(Fixed([0.4; 3])).0),
                    nums(&c.color1.unwrap_or(Fixed([0.2; 3])).0)
                ),
                c.to_uv.as_ref(),
            ),
            TextureDesc::Bitmap(b) => {
                let mut props = format!(
                    "{inner}<string name=\"filename\" value=\"{}\"/>\n",
                    escape(&self.written(&b.file).display().to_string())
                );
                for (key, v) in [("filter_type", &b.filter), ("wrap_mode", &b.wrap)] {
                    if let Some(v) = v {
                        let _ = writeln!(props, "{inner}<string name=\"{key}\" value=\"{}\"/>", escape(v));
                    }
                }
                if let Some(raw) = b.raw {
                    let _ = writeln!(props, "{inner}<boolean name=\"raw\" value=\"{raw}\"/>");
                }
                ("bitmap", props, b.to_uv.as_ref())
            }
            TextureDesc::MeshAttribute(m) => {
                let mut props = format!("{inner}<string name=\"name\" value=\"{}\"/>\n", escape(&m.name));
                if let Some(s) = m.scale {
                    let _ = writeln!(props, "{inner}<float name=\"scale\" value=\"{}\"/>", nums(&[s]));
                }
                ("mesh_attribute", props, None)
            }
        };
        if let Some(t) = to_uv {
            // As a 4 × 4 matrix: the 2 × 2 block upper left, the offset in the last column.
            let [a, b] = match t.matrix {
                Some(m) => [m[0].0, m[1].0],
                None => {
                    let s = t.scale.map_or([1.0; 2], |s| s.0);
                    let o = t.offset.map_or([0.0; 2], |o| o.0);
                    [[s[0], 0.0, o[0]], [0.0, s[1], o[1]]]
                }
            };
            let m = [
                a[0], a[1], 0.0, a[2], b[0], b[1], 0.0, b[2], 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
            ];
            let _ = writeln!(
                props,
                "{inner}<transform name=\"to_uv\">\n{inner}    <matrix value=\"{}\"/>\n{inner}</transform>",
                nums(&m)
            );
        }
        Ok(format!(
            "{indent}<texture type=\"{kind}\" name=\"{name}\">\n{props}{indent}</texture>\n"
        ))
    }
}

/// A `triangles` shape as an ASCII PLY file: positions, normals and (u, v) where given, and the
/// faces wound so that, where there are normals, each triangle's winding agrees with them
/// (Mitsuba's front side is the winding's; ours the normals').
fn triangles_ply(t: &desc::Triangles) -> Vec<u8> {
    let n = t.positions.len();
    let indices: Vec<usize> = match &t.indices {
        Some(i) => i.iter().map(|&k| k as usize).collect(),
        None => (0..n).collect(),
    };
    let mut out =
        format!("ply\nformat ascii 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\n");
    if t.normals.is_some() {
        out += "property float nx\nproperty float ny\nproperty float nz\n";
    }
    if t.uv.is_some() {
        out += "property float u\nproperty float v\n";
    }
    let _ = write!(
        out,
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        indices.len() / 3
    );
    for k in 0..n {
        let mut line = words(&t.positions[k].0);
        if let Some(ns) = &t.normals {
            line = format!("{line} {}", words(&ns[k].0));
        }
        if let Some(uv) = &t.uv {
            line = format!("{line} {}", words(&uv[k].0));
        }
        let _ = writeln!(out, "{line}");
    }
    for f in indices.chunks(3) {
        let [a, b, c] = [f[0], f[1], f[2]];
        let flip = t.normals.as_ref().is_some_and(|ns| {
            let p = |k: usize| DVec3::from_array(t.positions[k].0);
            let normal = (p(b) - p(a)).cross(p(c) - p(a));
            let shading: DVec3 = [a, b, c].iter().map(|&k| DVec3::from_array(ns[k].0)).sum();
            normal.dot(shading) < 0.0
        });
        let _ = writeln!(out, "3 {a} {} {}", if flip { c } else { b }, if flip { b } else { c });
    }
    out.into_bytes()
}

/// Numbers separated by spaces (PLY's ASCII format).
fn words(v: &[f64]) -> String {
    v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(" ")
}
