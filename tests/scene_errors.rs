//! Every class of bad scene input gives a one-line error that names the file and the field.
//! Scenes are written to a temporary directory and loaded through the public `load_scene`.

use glam::Vec3;
use photon_bench::geometry::Primitive;
use photon_bench::scene::{Scene, load_scene};
use std::path::PathBuf;

/// A small valid scene: a floor and a light above it, looked at from the front. Tests edit it
/// by text replacement (`edit`) or by appending (`with`).
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

fn edit(from: &str, to: &str) -> String {
    assert!(BASE.contains(from), "BASE lacks {from:?}");
    BASE.replacen(from, to, 1)
}

fn with(extra: &str) -> String {
    format!("{BASE}\n{extra}\n")
}

/// Writes `scene` as `x.toml` (and `files` beside it) into a fresh temporary directory.
struct Dir {
    dir: tempfile::TempDir,
}

impl Dir {
    fn new(scene: &str, files: &[(&str, &[u8])]) -> Self {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("x.toml"), scene).unwrap();
        for (name, bytes) in files {
            let p = dir.path().join(name);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, bytes).unwrap();
        }
        Self { dir }
    }

    fn scene_path(&self) -> PathBuf {
        self.dir.path().join("x.toml")
    }

    fn load(&self) -> photon_bench::Result<Scene> {
        load_scene(&self.scene_path())
    }
}

/// Loads a scene that must fail; checks that the message is one line naming the file.
fn error_with_files(scene: &str, files: &[(&str, &[u8])]) -> String {
    let dir = Dir::new(scene, files);
    match dir.load() {
        Ok(_) => panic!("expected an error for:\n{scene}"),
        Err(e) => {
            let msg = e.to_string();
            assert!(!msg.contains('\n'), "not one line: {msg}");
            let prefix = format!("{}: ", dir.scene_path().display());
            assert!(msg.starts_with(&prefix), "does not name the file: {msg}");
            msg[prefix.len()..].to_string()
        }
    }
}

fn error(scene: &str) -> String {
    error_with_files(scene, &[])
}

/// Asserts that the error starts with `field: ` and contains every one of `parts`.
#[track_caller]
fn assert_error(msg: &str, field: &str, parts: &[&str]) {
    assert!(msg.starts_with(&format!("{field}: ")), "wrong field in: {msg}");
    for p in parts {
        assert!(msg.contains(p), "{p:?} missing in: {msg}");
    }
}

fn sphere(extra: &str) -> String {
    with(&format!(
        "[[shapes]]\ntype = \"sphere\"\nmaterial = \"white\"\ncenter = [0, 0.5, 0]\n{extra}"
    ))
}

#[test]
fn the_base_scene_is_valid() {
    let scene = Dir::new(BASE, &[]).load().unwrap();
    assert_eq!(scene.lights.len(), 2);
}

#[test]
fn toml_syntax_errors_give_line_and_column() {
    let msg = error(&edit("fov_y = 40", "fov_y = = 40"));
    assert!(msg.starts_with("TOML syntax error at line 5, column"), "{msg}");
}

#[test]
fn misspelled_keys_are_refused_everywhere() {
    let cases = [
        (edit("[camera]", "nmae = \"x\"\n[camera]"), "nmae"),
        (edit("fov_y", "fovy"), "camera.fovy"),
        (edit("reflectance", "reflectanse"), "materials.white.reflectanse"),
        (edit("size = [2, 2]", "sise = [2, 2]"), "shapes[0].sise"),
        (edit("size = [0.5, 0.5]", "sise = [0.5, 0.5]"), "shapes[1].sise"),
        (
            edit("radiance = [1, 1, 1] }", "radiance = [1, 1, 1], two_side = true }"),
            "shapes[1].emission.two_side",
        ),
        (
            edit("facing = \"-y\"", "facing = \"-y\"\ntransform = { rotate = 3 }"),
            "shapes[1].transform.rotate",
        ),
        (
            with("[[user_paths]]\npoint = [[0, 2, 0], [0, 0, 0]]\ncone_deg = 5"),
            "user_paths[0].point",
        ),
    ];
    for (scene, field) in cases {
        let field_tail = field.rsplit('.').next().unwrap();
        assert_error(&error(&scene), field, &["unknown field", field_tail]);
    }
}

#[test]
fn wrong_types_name_the_field() {
    assert_error(
        &error(&edit("fov_y = 40", "fov_y = \"wide\"")),
        "camera.fov_y",
        &["invalid type", "line 5"],
    );
    assert_error(
        &error(&sphere("radius = \"big\"")),
        "shapes[2].radius",
        &["invalid type", "string"],
    );
    assert_error(
        &error(&edit("reflectance = [0.5, 0.5, 0.5]", "reflectance = 0.5")),
        "materials.white.reflectance",
        &["invalid type"],
    );
    assert_error(
        &error(&edit("resolution = [16, 12]", "resolution = [16, -12]")),
        "camera.resolution[1]",
        &["-12"],
    );
    assert_error(&error(&sphere("")), "shapes[2]", &["missing field `radius`"]);
    // Arrays must have exactly their length: extra elements are not silently dropped.
    assert_error(
        &error(&edit("resolution = [16, 12]", "resolution = [16, 12, 3]")),
        "camera.resolution",
        &["invalid length 3, expected an array of 2 elements"],
    );
    assert_error(
        &error(&edit("center = [0, 0, 0]", "center = [0, 0, 0, 1]")),
        "shapes[0].center",
        &["invalid length 4"],
    );
    assert_error(
        &error(&edit("center = [0, 0, 0]", "center = [0, 0]")),
        "shapes[0].center",
        &["invalid length 2"],
    );
}

#[test]
fn unknown_types_and_materials_are_refused() {
    assert_error(
        &error(&edit("type = \"diffuse\"", "type = \"metal\"")),
        "materials.white.type",
        &["metal"],
    );
    assert_error(
        &error(&edit("type = \"quad\"", "type = \"quadd\"")),
        "shapes[0].type",
        &["quadd"],
    );
    assert_error(
        &error(&edit("material = \"white\"", "material = \"whte\"")),
        "shapes[0].material",
        &["no material named \"whte\"", "defined: white"],
    );
    assert_error(
        &error(&edit("type = \"quad\"\n", "")),
        "shapes[0]",
        &["missing field `type`"],
    );
}

#[test]
fn non_finite_and_huge_coordinates_are_refused() {
    assert_error(
        &error(&edit("center = [0, 0, 0]", "center = [nan, 0, 0]")),
        "shapes[0].center",
        &["finite", "NaN"],
    );
    assert_error(
        &error(&edit("eye = [0, 1, 4]", "eye = [inf, 1, 4]")),
        "camera.eye",
        &["inf"],
    );
    assert_error(
        &error(&edit("center = [0, 0, 0]", "center = [1e8, 0, 0]")),
        "shapes[0].center",
        &["1e8"],
    );
    assert_error(
        &error(&edit("facing = \"-y\"", "facing = \"-y\"\ntransform = { scale = 1e7 }")),
        "shapes[1]",
        &["exceeds magnitude 1e7"],
    );
}

#[test]
fn degenerate_transforms_are_refused() {
    let quad_with = |t: &str| edit("size = [2, 2]", &format!("size = [2, 2]\ntransform = {t}"));
    assert_error(
        &error(&quad_with("{ scale = [1, 0, 1] }")),
        "shapes[0].transform.scale",
        &["non-zero"],
    );
    assert_error(
        &error(&quad_with(
            "{ matrix = [[1, 0, 0, 0], [0, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]] }",
        )),
        "shapes[0].transform",
        &["degenerate"],
    );
    assert_error(
        &error(&quad_with(
            "{ matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]] }",
        )),
        "shapes[0].transform.matrix",
        &["last row"],
    );
    assert_error(
        &error(&quad_with(
            "[{ rotate_x = 90 }, { matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], translate = [1, 0, 0] }]",
        )),
        "shapes[0].transform[1]",
        &["cannot share a step"],
    );
    assert_error(
        &error(&sphere("radius = 1\ntransform = { scale = [1, 2, 1] }")),
        "shapes[2].transform",
        &["uniform scale"],
    );
}

#[test]
fn degenerate_shapes_are_refused() {
    let quad = |body: &str| with(&format!("[[shapes]]\ntype = \"quad\"\nmaterial = \"white\"\n{body}"));
    assert_error(
        &error(&quad("corner = [0, 0, 0]\nedge_u = [1, 0, 0]\nedge_v = [2, 0, 0]")),
        "shapes[2]",
        &["zero-area quad"],
    );
    assert_error(
        &error(&quad("center = [0, 0, 0]\nsize = [1, 0]")),
        "shapes[2].size",
        &["positive"],
    );
    assert_error(
        &error(&quad("corner = [0, 0, 0]\nsize = [1, 1]")),
        "shapes[2]",
        &["either `corner`"],
    );
    assert_error(
        &error(&quad("center = [0, 0, 0]\nsize = [1, 1]\nfacing = \"up\"")),
        "shapes[2].facing",
        &["\"up\""],
    );
    for radius in ["-1", "0", "nan"] {
        assert_error(
            &error(&sphere(&format!("radius = {radius}"))),
            "shapes[2].radius",
            &["expected a positive finite number, got"],
        );
    }
    assert_error(&error(&sphere("radius = -1")), "shapes[2].radius", &["got -1"]);
    let cuboid = |body: &str| with(&format!("[[shapes]]\ntype = \"box\"\nmaterial = \"white\"\n{body}"));
    assert_error(
        &error(&cuboid("min = [0, 0, 0]\nmax = [1, 0, 1]")),
        "shapes[2].max",
        &["max > min"],
    );
    assert_error(
        &error(&cuboid("min = [0, 0, 0]\nsize = [1, 1, 1]")),
        "shapes[2]",
        &["`min` and `max`"],
    );
}

#[test]
fn materials_must_conserve_energy_and_stay_in_range() {
    assert_error(
        &error(&edit("[0.5, 0.5, 0.5]", "[1.2, 0.5, 0.5]")),
        "materials.white.reflectance",
        &["[0, 1]", "1.2"],
    );
    let material = |body: &str| with(&format!("[materials.m]\n{body}"));
    assert_error(
        &error(&material(
            "type = \"phong\"\ndiffuse = [0.6, 0.5, 0.5]\nspecular = [0.5, 0.5, 0.5]\nexponent = 10",
        )),
        "materials.m",
        &["diffuse + specular", "energy", "1.1"],
    );
    assert_error(
        &error(&material(
            "type = \"phong\"\ndiffuse = [0.1, 0.1, 0.1]\nspecular = [0.1, 0.1, 0.1]\nexponent = -1",
        )),
        "materials.m.exponent",
        &["-1"],
    );
    assert_error(
        &error(&material(
            "type = \"ward\"\ndiffuse = [0.1, 0.1, 0.1]\nspecular = [0.1, 0.1, 0.1]\nalpha_x = 0.1\nalpha_y = 0",
        )),
        "materials.m.alpha_y",
        &["(0, 1]"],
    );
    assert_error(
        &error(&material(
            "type = \"diffuse_transmission\"\nreflectance = [0.5, 0.5, 0.5]\ntransmittance = [0.6, 0.1, 0.1]",
        )),
        "materials.m",
        &["reflectance + transmittance"],
    );
    for ior in ["0", "-1.5", "nan", "inf"] {
        assert_error(
            &error(&material(&format!("type = \"dielectric\"\nior = {ior}"))),
            "materials.m.ior",
            &["positive finite"],
        );
    }
    assert_error(
        &error(&material("type = \"mirror\"\nreflectance = [1, 1, -0.1]")),
        "materials.m.reflectance",
        &["-0.1"],
    );
}

/// Metals and microfacet materials load with Mitsuba's defaults, and every wrong field is
/// named.
#[test]
fn microfacet_materials_load_and_refuse_bad_fields() {
    use photon_bench::bsdf::{Bsdf, MicrofacetType};
    let material = |body: &str| {
        with(&format!(
            "[materials.m]\n{body}\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"m\"\ncenter = [0, 0.5, 0]\nradius = 0.2"
        ))
    };
    let load = |body: &str| {
        let scene = Dir::new(&material(body), &[]).load().unwrap();
        scene.materials.iter().find(|m| m.name == "m").unwrap().bsdf.clone()
    };
    let Bsdf::RoughConductor(c) = load("type = \"rough_conductor\"\nmaterial = \"Au\"") else {
        panic!()
    };
    assert_eq!(c.distribution.kind, MicrofacetType::Beckmann);
    assert_eq!(c.distribution.alpha_u, 0.1);
    assert!(c.ior.k.x > 3.0 && c.ior.eta.x < 0.5, "gold: {:?}", c.ior);
    let Bsdf::RoughConductor(c) = load(
        "type = \"rough_conductor\"\ndistribution = \"ggx\"\nalpha_u = 0.05\nalpha_v = 0.3\nsample_visible = false",
    ) else {
        panic!()
    };
    assert_eq!(
        (c.distribution.kind, c.distribution.alpha_v),
        (MicrofacetType::Ggx, 0.3)
    );
    assert!(!c.distribution.sample_visible);
    assert!(matches!(
        load("type = \"conductor\"\nmaterial = \"Cu\""),
        Bsdf::Conductor(_)
    ));
    let Bsdf::RoughDielectric(d) = load("type = \"rough_dielectric\"\nior = 1.33\nalpha = 0.2") else {
        panic!()
    };
    assert_eq!(d.ior, 1.33);
    let Bsdf::RoughPlastic(p) = load("type = \"rough_plastic\"\ndiffuse_reflectance = [0.2, 0.4, 0.6]") else {
        panic!()
    };
    assert_eq!((p.ior, p.diffuse_reflectance), (1.49, glam::Vec3::new(0.2, 0.4, 0.6)));

    let cases: &[(&str, &str, &[&str])] = &[
        (
            "type = \"conductor\"\nmaterial = \"Unobtainium\"",
            "materials.m.material",
            &["unknown conductor", "Au"],
        ),
        (
            "type = \"conductor\"\nmaterial = \"Au\"\neta = [1, 1, 1]",
            "materials.m.material",
            &["either a named material or eta and k"],
        ),
        ("type = \"conductor\"\nk = [1, -1, 1]", "materials.m.k", &["[0, 1e4]"]),
        (
            "type = \"rough_conductor\"\ndistribution = \"phong\"",
            "materials.m.distribution",
            &["beckmann", "ggx"],
        ),
        (
            "type = \"rough_conductor\"\nalpha = 0.1\nalpha_u = 0.2\nalpha_v = 0.2",
            "materials.m.alpha",
            &["not both"],
        ),
        (
            "type = \"rough_conductor\"\nalpha_u = 0.2",
            "materials.m",
            &["together"],
        ),
        (
            "type = \"rough_conductor\"\nalpha = -0.1",
            "materials.m.alpha",
            &["roughness", "-0.1"],
        ),
        (
            "type = \"rough_conductor\"\nalpha_u = 0.1\nalpha_v = nan",
            "materials.m.alpha_v",
            &["roughness"],
        ),
        ("type = \"rough_dielectric\"\nior = 1", "materials.m.ior", &["not 1"]),
        (
            "type = \"rough_dielectric\"\nior = 1.5\nspecular_transmittance = [2, 1, 1]",
            "materials.m.specular_transmittance",
            &["[0, 1]"],
        ),
        (
            "type = \"rough_plastic\"\nalpha_u = 0.1\nalpha_v = 0.3",
            "materials.m",
            &["isotropic"],
        ),
        (
            "type = \"rough_plastic\"\ndiffuse_reflectance = [0.5, 1.5, 0.5]",
            "materials.m.diffuse_reflectance",
            &["[0, 1]"],
        ),
        (
            "type = \"rough_plastic\"\nroughness = 0.3",
            "materials.m",
            &["roughness"],
        ),
    ];
    for (body, field, parts) in cases {
        assert_error(&error(&material(body)), field, parts);
    }
}

#[test]
fn emission_must_be_non_negative_and_some_light_must_shine() {
    for radiance in ["[1, -1, 1]", "[1, nan, 1]", "[inf, 1, 1]"] {
        assert_error(
            &error(&edit("radiance = [1, 1, 1]", &format!("radiance = {radiance}"))),
            "shapes[1].emission.radiance",
            &["expected each channel finite"],
        );
    }
    let msg = error(&edit("emission = { radiance = [1, 1, 1] }", ""));
    assert!(msg.starts_with("no light"), "{msg}");
    let msg = error(&edit("radiance = [1, 1, 1]", "radiance = [0, 0, 0]"));
    assert!(msg.starts_with("no light"), "{msg}");
}

#[test]
fn camera_settings_are_checked_before_anything_is_allocated() {
    for (res, part) in [
        ("[0, 12]", "1..=16384"),
        ("[20000, 10]", "1..=16384"),
        ("[16384, 16384]", "64 Mpixel"),
    ] {
        assert_error(
            &error(&edit("resolution = [16, 12]", &format!("resolution = {res}"))),
            "camera.resolution",
            &[part],
        );
    }
    for fov in ["0", "180", "-5", "nan"] {
        assert_error(
            &error(&edit("fov_y = 40", &format!("fov_y = {fov}"))),
            "camera.fov_y",
            &["(0, 180)"],
        );
    }
    assert_error(
        &error(&edit("look_at = [0, 1, 0]", "look_at = [0, 1, 4]")),
        "camera.look_at",
        &["must differ from camera.eye"],
    );
    assert_error(
        &error(&edit("look_at = [0, 1, 0]", "look_at = [0, 1, 0]\nup = [0, 0, -2]")),
        "camera.up",
        &["parallel"],
    );
    assert_error(
        &error(&edit("look_at = [0, 1, 0]", "look_at = [0, 1, 0]\nup = [0, 0, 0]")),
        "camera.up",
        &["non-zero"],
    );
}

#[test]
fn user_paths_are_checked() {
    let path = |body: &str| with(&format!("[[user_paths]]\n{body}"));
    assert_error(
        &error(&path("points = [[0, 2, 0]]\ncone_deg = 5")),
        "user_paths[0].points",
        &["at least 2 points"],
    );
    assert_error(
        &error(&path("points = [[0, 1.5, 0], [0, 0, 0]]\ncone_deg = 5")),
        "user_paths[0].points[0]",
        &["must lie on an emissive surface"],
    );
    // On the floor, which does not emit.
    assert_error(
        &error(&path("points = [[0, 0, 0], [0, 0, 0]]\ncone_deg = 5")),
        "user_paths[0].points[0]",
        &["emissive"],
    );
    for cone in ["0", "-3", "[5, 0]", "95"] {
        assert_error(
            &error(&path(&format!(
                "points = [[0, 2, 0], [0, 0, 0], [1, 0, 0]]\ncone_deg = {cone}"
            ))),
            "user_paths[0].cone_deg",
            &["(0, 90]"],
        );
    }
    assert_error(
        &error(&path("points = [[0, 2, 0], [0, 0, 0], [1, 0, 0]]\ncone_deg = [5]")),
        "user_paths[0].cone_deg",
        &["one per segment (2), got 1"],
    );
}

fn mesh_scene(file: &str, extra: &str) -> String {
    with(&format!(
        "[[shapes]]\ntype = \"mesh\"\nmaterial = \"white\"\nfile = \"{file}\"\n{extra}"
    ))
}

const TRI_OBJ: &[u8] = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 4 3\n";

#[test]
fn mesh_without_normals_loads_relative_to_the_scene_file() {
    let dir = Dir::new(
        &mesh_scene("meshes/quad.obj", "transform = { translate = [0, 0, -1] }"),
        &[("meshes/quad.obj", TRI_OBJ)],
    );
    let scene = dir.load().unwrap();
    let mesh = &scene.primitives[4..];
    assert_eq!(mesh.len(), 2, "the quad face is triangulated");
    for (p, a) in mesh.iter().zip(&scene.attrs[4..]) {
        assert!(a.normals.is_none());
        let Primitive::Triangle(v) = p else {
            panic!("a triangle")
        };
        assert!(v.iter().all(|v| v.z == -1.0));
        assert!((p.geometric_normal(Vec3::ZERO) - Vec3::Z).length() < 1e-6);
    }
}

#[test]
fn mesh_with_normals_keeps_them_as_shading_normals() {
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0.6 0 0.8\nvn 0 0 1\nf 1//1 2//2 3//3\n";
    let dir = Dir::new(
        &mesh_scene("tri.obj", "transform = { rotate_y = 90 }"),
        &[("tri.obj", obj)],
    );
    let scene = dir.load().unwrap();
    let normals = scene.attrs[4].normals.expect("OBJ normals are kept");
    // Rotated by 90° about y: +z becomes +x, (0.6, 0, 0.8) becomes (0.8, 0, -0.6).
    assert!((normals[0] - Vec3::X).length() < 1e-6, "{normals:?}");
    assert!((normals[1] - Vec3::new(0.8, 0.0, -0.6)).length() < 1e-6, "{normals:?}");
}

#[test]
fn mesh_emission_makes_every_triangle_a_light_and_files_enter_the_hash() {
    let scene = mesh_scene("quad.obj", "emission = { radiance = [2, 2, 2], two_sided = true }");
    let a = Dir::new(&scene, &[("quad.obj", TRI_OBJ)]).load().unwrap();
    assert_eq!(a.lights.len(), 4);
    let obj2 = [TRI_OBJ, b"# a comment\n"].concat();
    let b = Dir::new(&scene, &[("quad.obj", &obj2)]).load().unwrap();
    assert_ne!(a.content_hash, b.content_hash, "the OBJ's bytes are hashed");
}

#[test]
fn missing_or_unreadable_mtl_is_ignored_but_a_present_one_is_hashed() {
    let obj = [b"mtllib gone.mtl\nusemtl red\n".as_slice(), TRI_OBJ].concat();
    let scene = mesh_scene("m.obj", "");
    Dir::new(&scene, &[("m.obj", &obj)]).load().unwrap();
    // A malformed MTL (a colour with one component) is never parsed, so cannot crash us.
    let obj = [b"mtllib m.mtl\nusemtl red\n".as_slice(), TRI_OBJ].concat();
    let a = Dir::new(&scene, &[("m.obj", &obj), ("m.mtl", b"newmtl red\nKd 0.5\n")])
        .load()
        .unwrap();
    let b = Dir::new(&scene, &[("m.obj", &obj), ("m.mtl", b"newmtl red\nKd 0.6\n")])
        .load()
        .unwrap();
    assert_ne!(a.content_hash, b.content_hash);
}

#[test]
fn bad_meshes_give_one_line_errors_naming_the_file() {
    let msg = error(&mesh_scene("meshes/missing.obj", ""));
    assert_error(&msg, "shapes[2].file", &["cannot read", "missing.obj"]);
    let msg = error(&mesh_scene("/dev/zero", ""));
    assert_error(&msg, "shapes[2].file", &["/dev/zero", "expected a regular file"]);

    let cases: [(&[u8], &str); 5] = [
        (b"v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "non-finite"),
        (b"v 0 0 0\nv 1e9 0 0\nv 0 1 0\nf 1 2 3\n", "huge"),
        (b"v 0 0 0\nv 1 0 0\n", "no triangles"),
        (
            b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
            "all 1 triangles are degenerate",
        ),
        (b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 9\n", "out of bounds"),
    ];
    for (obj, part) in cases {
        let msg = error_with_files(&mesh_scene("bad.obj", ""), &[("bad.obj", obj)]);
        assert_error(&msg, "shapes[2].file", &["bad.obj", part]);
    }
}

#[test]
fn degenerate_mesh_triangles_are_skipped_and_counted() {
    let obj = [TRI_OBJ, b"v 2 0 0\nf 1 2 5\n"].concat();
    let dir = Dir::new(&mesh_scene("m.obj", ""), &[("m.obj", &obj)]);
    let (scene, stats) = photon_bench::scene::load::load_scene_with_stats(&dir.scene_path()).unwrap();
    assert_eq!(stats.degenerate_triangles_skipped, 1);
    assert_eq!(scene.primitives.len(), 4 + 2);
    assert_eq!(stats.files_read.len(), 1);
}

#[test]
fn an_empty_name_is_refused() {
    assert_error(&error(&format!("name = \" \"\n{BASE}")), "name", &["non-empty"]);
}

#[test]
fn unreadable_scene_file_names_the_file() {
    let msg = match load_scene(std::path::Path::new("does/not/exist.toml")) {
        Ok(_) => panic!("expected an error"),
        Err(e) => e.to_string(),
    };
    assert!(msg.starts_with("does/not/exist.toml: cannot read"), "{msg}");
}
