//! Mitsuba 3's `disk` and `cylinder`, in TOML and in Mitsuba XML: the tessellation against the
//! analytic shapes (area, vertices, shading normals), Mitsuba 3.9.1's own texture coordinates
//! and normals at probed points, export → import round trips, emission, and the refusal of
//! degenerate input with one line.

use glam::{DAffine3, DVec3, Vec2, Vec3};
use photon_bench::bsdf::Bsdf;
use photon_bench::geometry::{Primitive, Ray};
use photon_bench::scene::Scene;
use photon_bench::scene::export::export_file;
use photon_bench::scene::load::{load_scene_bytes, load_scene_with_stats};
use std::f64::consts::PI;
use std::path::Path;

/// A camera, a white material and a point light: what every test scene needs besides its shape.
const TOML_BASE: &str = "[camera]\neye = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov_y = 40\nresolution = [8, 8]\n\
    [materials.white]\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n\
    [[lights]]\ntype = \"point\"\nposition = [0, 0, 20]\nintensity = [1, 1, 1]\n";

fn toml_scene(shapes: &str) -> Scene {
    let text = format!("{TOML_BASE}{shapes}");
    load_scene_bytes(Path::new("mem/s.toml"), text.as_bytes())
        .unwrap_or_else(|e| panic!("{e}\n{text}"))
        .0
}

fn xml(body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 10" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/><rfilter type="box"/></film>
    </sensor>
    <emitter type="point"><point name="position" value="0, 0, 20"/><rgb name="intensity" value="1"/></emitter>
    {body}
</scene>"#
    )
}

fn xml_scene(body: &str) -> (Scene, Vec<String>) {
    let text = xml(body);
    let (scene, stats) =
        load_scene_bytes(Path::new("mem/s.xml"), text.as_bytes()).unwrap_or_else(|e| panic!("{e}\n{text}"));
    (scene, stats.warnings)
}

fn triangles(scene: &Scene) -> Vec<[DVec3; 3]> {
    (scene.primitives.iter())
        .map(|p| match p {
            Primitive::Triangle(t) => t.map(|v| v.as_dvec3()),
            Primitive::Sphere { .. } => panic!("a sphere among the triangles"),
        })
        .collect()
}

fn area(scene: &Scene) -> f64 {
    triangles(scene)
        .iter()
        .map(|[a, b, c]| 0.5 * (*b - *a).cross(*c - *a).length())
        .sum()
}

/// Every shading normal of every triangle.
fn normals(scene: &Scene) -> Vec<(DVec3, Vec3)> {
    let mut out = Vec::new();
    for (t, a) in triangles(scene).iter().zip(&scene.attrs) {
        let ns = a.normals.expect("a tessellated shape has shading normals");
        for k in 0..3 {
            out.push((t[k], ns[k]));
        }
    }
    out
}

/// Relative error of the tessellation's area against `exact`, printed for the record.
fn area_error(what: &str, scene: &Scene, exact: f64) -> f64 {
    let e = area(scene) / exact - 1.0;
    eprintln!(
        "{what}: {} triangles, area relative error {e:.4e}",
        scene.primitives.len()
    );
    e
}

#[test]
fn a_disk_has_the_analytic_area_vertices_on_its_ellipse_and_the_plane_normal() {
    // The unit disk, and an elliptic one (semi-axes 2 and 0.5) turned and moved.
    let unit = toml_scene("[[shapes]]\ntype = \"disk\"\nmaterial = \"white\"\n");
    assert_eq!(
        unit.primitives.len(),
        512 * 27,
        "13 rings of two triangles per segment, and the fan"
    );
    let e = area_error("unit disk", &unit, PI);
    // A 512-gon has (2π/512)²/6 = 2.51e-5 less area than its circle.
    assert!((e + 2.51e-5).abs() < 2e-7, "{e:e}");
    let m = DAffine3::from_translation(DVec3::new(1.0, 2.0, 3.0))
        * DAffine3::from_rotation_x(30f64.to_radians())
        * DAffine3::from_scale(DVec3::new(2.0, 0.5, 1.0));
    let ellipse = toml_scene(
        "[[shapes]]\ntype = \"disk\"\nmaterial = \"white\"\n\
         transform = { scale = [2, 0.5, 1], rotate_x = 30, translate = [1, 2, 3] }\n",
    );
    let e = area_error("elliptic disk", &ellipse, PI * 2.0 * 0.5);
    assert!(e.abs() < 1e-4 && (e + 2.51e-5).abs() < 1e-6, "{e:e}");
    let normal = (m.matrix3.inverse().transpose() * DVec3::Z).normalize();
    let to_local = m.inverse();
    for (p, n) in normals(&ellipse) {
        let l = to_local.transform_point3(p);
        assert!(l.z.abs() < 1e-6 && l.truncate().length() < 1.0 + 1e-6, "{l}");
        assert!((n.length() - 1.0).abs() < 1e-6, "{n}");
        assert!((n.as_dvec3() - normal).length() < 1e-6, "{n} vs {normal}");
    }
    // The boundary: vertices on the ellipse itself (up to f32 rounding).
    let on_rim = normals(&ellipse)
        .iter()
        .filter(|(p, _)| (to_local.transform_point3(*p).truncate().length() - 1.0).abs() < 1e-6)
        .count();
    assert!(on_rim >= 2 * 512, "{on_rim}");
}

#[test]
fn a_cylinder_has_the_analytic_area_vertices_on_the_tube_and_radial_normals() {
    let default = toml_scene("[[shapes]]\ntype = \"cylinder\"\nmaterial = \"white\"\n");
    // As long as its radius: ⌈1 / (16 · 2π/512)⌉ = 6 rings.
    assert_eq!(default.primitives.len(), 2 * 512 * 6);
    let e = area_error("unit cylinder", &default, 2.0 * PI);
    // The tube's sides are (π/512)²/6 = 6.27e-6 short of its circumference.
    assert!((e + 6.27e-6).abs() < 2e-7, "{e:e}");
    // Mitsuba's parameters, then our transform (uniform scale 2, a turn, a move).
    let scene = toml_scene(
        "[[shapes]]\ntype = \"cylinder\"\nmaterial = \"white\"\np0 = [1, 2, 3]\np1 = [2, 0, 4]\nradius = 0.5\n\
         transform = { scale = 2, rotate_y = 40, translate = [0.5, -1, 2] }\n",
    );
    let m = DAffine3::from_translation(DVec3::new(0.5, -1.0, 2.0))
        * DAffine3::from_rotation_y(40f64.to_radians())
        * DAffine3::from_scale(DVec3::splat(2.0));
    let (p0, p1) = (
        m.transform_point3(DVec3::new(1.0, 2.0, 3.0)),
        m.transform_point3(DVec3::new(2.0, 0.0, 4.0)),
    );
    let (h, r) = ((p1 - p0).length(), 1.0);
    let e = area_error("transformed cylinder", &scene, 2.0 * PI * r * h);
    assert!(e.abs() < 1e-4 && (e + 6.27e-6).abs() < 1e-6, "{e:e}");
    let axis = (p1 - p0) / h;
    for (p, n) in normals(&scene) {
        let along = (p - p0).dot(axis);
        let radial = p - p0 - along * axis;
        assert!((-1e-5..=h + 1e-5).contains(&along), "{along}");
        assert!((radial.length() - r).abs() < 1e-5 * h, "{}", radial.length());
        assert!((n.length() - 1.0).abs() < 1e-6, "{n}");
        let n = n.as_dvec3();
        assert!(
            n.dot(axis).abs() < 1e-6 && n.dot(radial.normalize()) > 1.0 - 1e-6,
            "{n} at {p}"
        );
    }
}

/// A hit's (u, v), shading normal and geometric normal, by a ray from `o` along `d`.
fn probe(scene: &Scene, o: [f32; 3], d: [f32; 3]) -> (Vec2, Vec3, Vec3) {
    let ray = Ray::new(Vec3::from(o), Vec3::from(d).normalize());
    let hit = scene.intersect(&ray).expect("the probe ray hits the shape");
    (scene.uv(&hit), hit.frame.n, hit.ng)
}

/// Mitsuba 3.9.1's `si.uv` and `si.sh_frame.n` (= `si.n`) for a ray, printed by
/// `mi.load_dict({'type': 'scene', 's': shape}).ray_intersect(mi.Ray3f(o, d))` in the
/// `scalar_rgb` variant (pip `mitsuba==3.9.1`), the shape written as the XML below.
struct MitsubaProbe {
    shape: &'static str,
    o: [f32; 3],
    d: [f32; 3],
    uv: [f32; 2],
    n: [f32; 3],
}

/// 1/√2, which Mitsuba prints as 0.7071068.
const H: f32 = std::f32::consts::FRAC_1_SQRT_2;

const PROBES: &[MitsubaProbe] = &[
    MitsubaProbe {
        shape: r#"<shape type="disk"/>"#,
        o: [0.3, 0.4, 1.0],
        d: [0.0, 0.0, -1.0],
        uv: [0.5000001, 0.1475837],
        n: [0.0, 0.0, 1.0],
    },
    MitsubaProbe {
        shape: r#"<shape type="disk"/>"#,
        o: [-0.5, -0.1, 1.0],
        d: [0.0, 0.0, -1.0],
        uv: [0.5099019, 0.5314165],
        n: [0.0, 0.0, 1.0],
    },
    // From behind: the normal is the front side's.
    MitsubaProbe {
        shape: r#"<shape type="disk"/>"#,
        o: [0.2, -0.6, -1.0],
        d: [0.0, 0.0, 1.0],
        uv: [0.6324555, 0.8012082],
        n: [0.0, 0.0, 1.0],
    },
    // Inside the central fan, and just below the seam (v → 1).
    MitsubaProbe {
        shape: r#"<shape type="disk"/>"#,
        o: [0.03, 0.01, 1.0],
        d: [0.0, 0.0, -1.0],
        uv: [0.03162277, 0.05120818],
        n: [0.0, 0.0, 1.0],
    },
    MitsubaProbe {
        shape: r#"<shape type="disk"/>"#,
        o: [0.7, -0.004, 1.0],
        d: [0.0, 0.0, -1.0],
        uv: [0.7000114, 0.9990906],
        n: [0.0, 0.0, 1.0],
    },
    MitsubaProbe {
        shape: r#"<shape type="disk"><boolean name="flip_normals" value="true"/></shape>"#,
        o: [0.3, 0.4, 1.0],
        d: [0.0, 0.0, -1.0],
        uv: [0.5, 0.1475837],
        n: [0.0, 0.0, -1.0],
    },
    MitsubaProbe {
        shape: r#"<shape type="disk"><transform name="to_world"><scale x="2" y="0.5" z="1"/><rotate x="1" angle="-90"/><translate y="1"/></transform></shape>"#,
        o: [0.6, 2.0, 0.1],
        d: [0.0, -1.0, 0.0],
        uv: [0.3605551, 0.9064165],
        n: [0.0, 1.0, -4.371139e-08],
    },
    MitsubaProbe {
        shape: r#"<shape type="cylinder"/>"#,
        o: [-2.0, 3.464102, 0.25],
        d: [0.5, -0.8660254, 0.0],
        uv: [0.3333334, 0.25],
        n: [-0.5, 0.8660254, 0.0],
    },
    MitsubaProbe {
        shape: r#"<shape type="cylinder"/>"#,
        o: [4.0 * H, -4.0 * H, 0.75],
        d: [-H, H, 0.0],
        uv: [0.8749999, 0.7499999],
        n: [H, -H, 0.0],
    },
    // Either side of the seam.
    MitsubaProbe {
        shape: r#"<shape type="cylinder"/>"#,
        o: [3.0, -0.05, 0.5],
        d: [-1.0, 0.0, 0.0],
        uv: [0.992039, 0.5],
        n: [0.9987493, -0.05, 0.0],
    },
    MitsubaProbe {
        shape: r#"<shape type="cylinder"/>"#,
        o: [3.0, 0.05, 0.5],
        d: [-1.0, 0.0, 0.0],
        uv: [0.007961063, 0.5],
        n: [0.9987493, 0.05, 0.0],
    },
    // From inside: the normal still points out.
    MitsubaProbe {
        shape: r#"<shape type="cylinder"/>"#,
        o: [0.0, 0.0, 0.5],
        d: [0.0, 1.0, 0.0],
        uv: [0.25, 0.5],
        n: [0.0, 1.0, 0.0],
    },
    MitsubaProbe {
        shape: r#"<shape type="cylinder"><boolean name="flip_normals" value="true"/></shape>"#,
        o: [3.0, 0.3, 0.5],
        d: [-1.0, 0.0, 0.0],
        uv: [0.04849333, 0.5],
        n: [-0.9539392, -0.2999999, 0.0],
    },
    MitsubaProbe {
        shape: r#"<shape type="cylinder"><point name="p0" value="1, 2, 3"/><point name="p1" value="2, 0, 4"/><float name="radius" value="0.5"/></shape>"#,
        o: [1.5, 1.0, 10.0],
        d: [0.0, 0.0, -1.0],
        uv: [0.3237918, 0.5912871],
        n: [-0.1825742, 0.3651484, 0.9128709],
    },
    MitsubaProbe {
        shape: r#"<shape type="cylinder"><point name="p0" value="1, 2, 3"/><point name="p1" value="2, 0, 4"/><float name="radius" value="0.5"/></shape>"#,
        o: [10.0, 1.0, 3.5],
        d: [-1.0, 0.0, 0.0],
        uv: [0.04174465, 0.5912871],
        n: [0.912871, 0.3651482, -0.1825746],
    },
    MitsubaProbe {
        shape: r#"<shape type="cylinder"><point name="p0" value="1, 2, 3"/><point name="p1" value="2, 0, 4"/><float name="radius" value="0.5"/></shape>"#,
        o: [1.5, -10.0, 3.5],
        d: [0.0, 1.0, 0.0],
        uv: [0.6827683, 0.788675],
        n: [-0.5773502, -0.5773503, -0.5773504],
    },
    // An axis along −z: Mitsuba's frame for it turns the azimuth the other way.
    MitsubaProbe {
        shape: r#"<shape type="cylinder"><point name="p1" value="0, 0, -1"/></shape>"#,
        o: [3.0, 0.3, -0.5],
        d: [-1.0, 0.0, 0.0],
        uv: [0.9515066, 0.5],
        n: [0.9539392, 0.2999999, 0.0],
    },
    // An axis in the xy plane: the sign of its z (+0, −0, or a difference below f32's
    // resolution) picks Mitsuba's frame, half a turn apart; `mi.load_string` of the XML.
    MitsubaProbe {
        shape: r#"<shape type="cylinder"><point name="p1" value="1, 0, 0"/></shape>"#,
        o: [0.5, 0.3, 5.0],
        d: [0.0, 0.0, -1.0],
        uv: [0.4515067, 0.5],
        n: [0.0, 0.2999999, 0.9539392],
    },
    MitsubaProbe {
        shape: r#"<shape type="cylinder"><point name="p1" value="1, 0, -0"/></shape>"#,
        o: [0.5, 0.3, 5.0],
        d: [0.0, 0.0, -1.0],
        uv: [0.9515066, 0.5],
        n: [0.0, 0.2999999, 0.9539392],
    },
    MitsubaProbe {
        shape: r#"<shape type="cylinder"><point name="p0" value="0, 0, 1e-9"/><point name="p1" value="1, 0, 0"/></shape>"#,
        o: [0.5, 0.3, 5.0],
        d: [0.0, 0.0, -1.0],
        uv: [0.9515066, 0.5],
        n: [0.0, 0.2999999, 0.9539392],
    },
    MitsubaProbe {
        shape: r#"<shape type="cylinder"><point name="p0" value="0, 0, 1.00000001"/><point name="p1" value="1, 0, 1"/></shape>"#,
        o: [0.5, 0.3, 5.0],
        d: [0.0, 0.0, -1.0],
        uv: [0.4515066, 0.5],
        n: [0.0, 0.3, 0.9539392],
    },
    // A mirroring to_world: Mitsuba keeps the normals outward.
    MitsubaProbe {
        shape: r#"<shape type="cylinder"><transform name="to_world"><scale x="-1"/></transform></shape>"#,
        o: [3.0, 0.3, 0.5],
        d: [-1.0, 0.0, 0.0],
        uv: [0.4515067, 0.4999999],
        n: [0.9539392, 0.3, 0.0],
    },
    MitsubaProbe {
        shape: r#"<shape type="cylinder"><point name="p1" value="0, 2, 0"/><float name="radius" value="0.5"/><transform name="to_world"><rotate z="1" angle="30"/></transform></shape>"#,
        o: [3.0, 1.0, 0.2],
        d: [-1.0, 0.0, 0.0],
        uv: [0.9345051, 0.4450626],
        n: [0.7937254, 0.4582576, 0.3999999],
    },
];

#[test]
fn texture_coordinates_and_normals_are_mitsubas_at_probed_points() {
    for p in PROBES {
        let (scene, _) = xml_scene(p.shape);
        let (uv, ns, ng) = probe(&scene, p.o, p.d);
        let what = format!("{} from {:?}", p.shape, p.o);
        // The disk's v is interpolated linearly between vertices (≤ 1.1e-4 off on its rings, ≤
        // 9.3e-4 in its central fan); everything else is closer.
        let in_fan = p.shape.contains("disk") && p.o[0].hypot(p.o[1]) < 1.0 / 16.0;
        let tol = if in_fan { 1e-3 } else { 2e-4 };
        assert!(
            (uv - Vec2::from(p.uv)).abs().max_element() < tol,
            "{what}: uv {uv} vs Mitsuba's {:?}",
            p.uv
        );
        let n = Vec3::from(p.n);
        assert!((ns - n).length() < 1e-4, "{what}: shading normal {ns} vs Mitsuba's {n}");
        // The facet's own normal is within half a segment (π/512) of the surface's.
        assert!(
            ng.dot(n) > (std::f32::consts::PI / 512.0).cos() - 1e-6,
            "{what}: facet {ng} vs {n}"
        );
    }
}

#[test]
fn an_emitting_disk_is_an_area_light_of_all_its_triangles_and_one_sided_bsdfs_stay_one_sided() {
    let (scene, warnings) = xml_scene(
        r#"<shape type="disk"><transform name="to_world"><scale value="0.5"/></transform>
            <emitter type="area"><rgb name="radiance" value="3"/></emitter></shape>
        <shape type="cylinder"><bsdf type="diffuse"/></shape>"#,
    );
    assert!(warnings.is_empty(), "{warnings:?}");
    let disk = 512 * 27;
    assert_eq!(scene.lights.len(), disk);
    assert!(
        scene
            .lights
            .iter()
            .all(|l| (l.prim as usize) < disk && !l.emission.two_sided)
    );
    let light_area: f64 = scene.lights.iter().map(|l| f64::from(l.area)).sum();
    assert!((light_area / (PI * 0.25) - 1.0).abs() < 1e-4, "{light_area}");
    // A bare diffuse is black from behind, as in Mitsuba; the tube's front is its outside.
    let tube = &scene.materials[scene.attrs[disk].material as usize];
    assert!(matches!(tube.bsdf, Bsdf::OneSided(_)), "{:?}", tube.bsdf);
}

/// A TOML scene of disks and cylinders (flipped, transformed, mirrored, emitting) written as
/// Mitsuba XML and read back gives the same triangles, normals and texture coordinates.
#[test]
fn disks_and_cylinders_survive_export_and_import() {
    let dir = tempfile::tempdir().unwrap();
    let toml = dir.path().join("round.toml");
    std::fs::write(
        &toml,
        format!(
            "{TOML_BASE}[[shapes]]\ntype = \"disk\"\nmaterial = \"white\"\nflip_normals = true\n\
             transform = [{{ scale = [0.3, 0.2, 1], rotate_x = 70 }}, {{ translate = [0.1, 0.2, 0.3] }}]\n\
             emission = {{ radiance = [1, 2, 3] }}\n\
             [[shapes]]\ntype = \"disk\"\nmaterial = \"white\"\n\
             [[shapes]]\ntype = \"cylinder\"\nmaterial = \"white\"\np0 = [0.1, -0.2, 0.3]\np1 = [-0.4, 0.5, 0.1]\n\
             radius = 0.15\nflip_normals = true\n\
             [[shapes]]\ntype = \"cylinder\"\nmaterial = \"white\"\n\
             transform = {{ scale = [-1, 1, 2], rotate_z = 10, translate = [1, 1, 1] }}\n"
        ),
    )
    .unwrap();
    let xml_path = dir.path().join("round.xml");
    let warnings = export_file(&toml, &xml_path).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    let text = std::fs::read_to_string(&xml_path).unwrap();
    assert!(
        text.contains("<shape type=\"disk\">") && text.contains("<shape type=\"cylinder\">"),
        "{text}"
    );
    let (a, _) = load_scene_with_stats(&toml).unwrap();
    let (b, _) = load_scene_with_stats(&xml_path).unwrap();
    assert_eq!(a.primitives.len(), b.primitives.len());
    for (i, (pa, pb)) in a.primitives.iter().zip(&b.primitives).enumerate() {
        assert_eq!(pa, pb, "triangle {i}");
        let (x, y) = (&a.attrs[i], &b.attrs[i]);
        assert_eq!(
            (x.normals, x.uv, x.emission),
            (y.normals, y.uv, y.emission),
            "triangle {i}"
        );
    }
    assert_eq!(a.lights.len(), 512 * 27);
}

/// The error of loading `text` (TOML unless it starts with `<`): one line naming the file.
fn error(text: &str) -> String {
    let name = if text.starts_with('<') {
        "mem/s.xml"
    } else {
        "mem/s.toml"
    };
    let e = match load_scene_bytes(Path::new(name), text.as_bytes()) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    };
    assert!(!e.contains('\n') && e.starts_with(&format!("{name}: ")), "{e}");
    e
}

#[test]
fn degenerate_disks_and_cylinders_are_refused_with_one_line() {
    let cylinder = |extra: &str| format!("{TOML_BASE}[[shapes]]\ntype = \"cylinder\"\nmaterial = \"white\"\n{extra}\n");
    let disk = |extra: &str| format!("{TOML_BASE}[[shapes]]\ntype = \"disk\"\nmaterial = \"white\"\n{extra}\n");
    let cases: Vec<(String, &[&str])> = vec![
        (
            cylinder("radius = 0"),
            &["shapes[0].radius: expected a positive finite number, got 0"],
        ),
        (
            cylinder("radius = -1"),
            &["shapes[0].radius: expected a positive", "-1"],
        ),
        (
            cylinder("p0 = [0, 1, 2]\np1 = [0, 1, 2]"),
            &["shapes[0].p1: expected a point other than p0", "[0, 1, 2]"],
        ),
        (
            cylinder("p1 = [0, 0, 0]"),
            &["shapes[0].p1: expected a point other than p0"],
        ),
        (
            cylinder("p0 = [0, 0, 1]"),
            &["shapes[0].p0: expected a point other than p1", "[0, 0, 1] for both"],
        ),
        (
            cylinder("p0 = [nan, 0, 0]"),
            &["shapes[0].p0: expected finite coordinates"],
        ),
        (
            cylinder("radius = inf"),
            &["shapes[0].radius: expected a positive finite number"],
        ),
        (
            cylinder("transform = { scale = [1, 0, 1] }"),
            &["shapes[0].transform.scale"],
        ),
        (disk("radius = 2"), &["shapes[0].radius: unknown field `radius`"]),
        (disk("flip_normals = 1"), &["shapes[0].flip_normals"]),
        (
            xml(r#"<shape type="cylinder"><float name="radius" value="0"/></shape>"#),
            &["line 7, <float name=\"radius\">: radius: expected a positive number, got 0"],
        ),
        (
            xml(r#"<shape type="cylinder"><float name="radius" value="NaN"/></shape>"#),
            &["<float name=\"radius\">", "finite"],
        ),
        (
            xml(r#"<shape type="cylinder"><point name="p0" value="0, 0, 1"/></shape>"#),
            &[
                "<point name=\"p0\">: p0: expected a point other than p1",
                "[0, 0, 1] for both",
            ],
        ),
        (
            xml(r#"<shape type="cylinder"><point name="p0" x="1"/><point name="p1" x="1"/></shape>"#),
            &["<point name=\"p1\">: p1: expected a point other than p0"],
        ),
        (
            xml(r#"<shape type="disk"><float name="radius" value="2"/></shape>"#),
            &[
                "<float name=\"radius\">",
                "unsupported property of <shape type=\"disk\">",
            ],
        ),
        (
            xml(r#"<shape type="disk"><transform name="to_world"><scale z="0"/></transform></shape>"#),
            &["<shape type=\"disk\">.transform", "degenerate"],
        ),
        (
            xml(r#"<shape type="sphere"><boolean name="flip_normals" value="true"/></shape>"#),
            &["<shape type=\"sphere\">", "flip_normals", "disks and cylinders only"],
        ),
    ];
    for (text, expected) in cases {
        let e = error(&text);
        for part in expected {
            assert!(e.contains(part), "{e:?} lacks {part:?}");
        }
    }
}

/// Mitsuba samples an elliptic or sheared tube's light as a round tube's (wrongly): an
/// emitting one is warned about.
#[test]
fn an_emitting_tube_made_elliptic_is_warned_about() {
    let tube = |t: &str, emitter: &str| {
        xml_scene(&format!(
            r#"<shape type="cylinder"><transform name="to_world">{t}</transform><bsdf type="diffuse"/>{emitter}</shape>"#
        ))
        .1
    };
    let area = r#"<emitter type="area"><rgb name="radiance" value="1"/></emitter>"#;
    let warnings = tube(r#"<scale x="2"/>"#, area);
    assert!(
        warnings.len() == 1 && warnings[0].contains("<shape type=\"cylinder\">") && warnings[0].contains("elliptic"),
        "{warnings:?}"
    );
    // Not emitting, it renders as Mitsuba renders it.
    assert!(tube(r#"<scale x="2"/>"#, "").is_empty());
    // A uniform scale, a stretch along the axis and a mirror keep it round.
    for t in [
        r#"<scale value="3"/>"#,
        r#"<scale z="5"/><rotate x="1" angle="33"/>"#,
        r#"<scale y="-1"/>"#,
    ] {
        let warnings = tube(t, area);
        assert!(warnings.is_empty(), "{t}: {warnings:?}");
    }
}
