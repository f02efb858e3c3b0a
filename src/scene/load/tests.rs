//! Tests of the loader: the shipped scenes, transforms, user paths, number formatting, error
//! locations, and fuzzing (random bytes, mutated scenes and OBJ files never panic).

use super::*;
use crate::sampling::Rng;
use glam::Vec2;
use glam::Vec3;

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

/// The module doc of `desc` is the format's reference (and the user guide's): it must load.
#[test]
fn the_documented_example_loads() {
    let source = include_str!("../desc/mod.rs");
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
    std::fs::write(
        dir.path().join("meshes/hair.txt"),
        "0.3 0.1 0.3 0.005\n0.35 0.2 0.3 0.005\n",
    )
    .unwrap();
    std::fs::create_dir(dir.path().join("textures")).unwrap();
    let sky = crate::film::Image {
        width: 4,
        height: 2,
        pixels: vec![glam::Vec3::ONE; 8],
    };
    crate::film::write_exr(&sky, &dir.path().join("textures/sky.exr")).unwrap();
    image::RgbImage::from_pixel(2, 2, image::Rgb([128, 128, 255]))
        .save(dir.path().join("textures/tiles_normals.png"))
        .unwrap();
    let path = dir.path().join("example.toml");
    std::fs::write(&path, &example).unwrap();
    let (scene, stats) = load_scene_with_stats(&path).unwrap();
    assert_eq!(scene.name, "cornell-empty");
    assert_eq!(scene.materials.len(), 22);
    for (name, principled) in [("car_paint", true), ("leaf_sheet", false)] {
        let m = scene.materials.iter().find(|m| m.name == name).unwrap();
        assert!(
            matches!(
                (&m.bsdf, principled),
                (crate::bsdf::Bsdf::Principled(_), true) | (crate::bsdf::Bsdf::PrincipledThin(_), false)
            ),
            "{name}: {:?}",
            m.bsdf
        );
    }
    let tiles = scene.materials.iter().find(|m| m.name == "tiles").unwrap();
    assert!(
        matches!(tiles.bsdf, crate::bsdf::Bsdf::NormalMapped(_)),
        "the tiles are normal-mapped"
    );
    let blend = scene.materials.iter().find(|m| m.name == "worn_gold").unwrap();
    assert!(
        blend.bsdf.mixes_delta(),
        "the blend holds a smooth gold beside a rough plastic"
    );
    let leaf = scene.materials.iter().find(|m| m.name == "leaf").unwrap();
    assert_eq!(
        leaf.opacity.as_ref().map(|o| o.range()),
        Some((0.2, 1.0)),
        "the leaf is masked"
    );
    let floor = scene.materials.iter().find(|m| m.name == "floor").unwrap();
    assert_eq!(floor.textures.len(), 1, "the checkerboard floor is textured");
    assert_eq!(stats.spheres, 1);
    // Two quads (the second with `subdivide = 4`), a box with `subdivide = 2`, a disk (13 rings
    // and a fan of 512 segments), a cylinder twice as long as its radius (⌈2 · 512 / (16 · 2π)⌉
    // = 11 rings), a triangle from the OBJ file and one written in the scene, and a linear curve
    // of one segment (radius 0.005, length √0.0125: ⌈0.1118 · 256 / (16 · 2π · 0.005)⌉ = 57
    // rings of 256 around, two caps of 63 rings and a fan of 256 at the pole).
    assert_eq!(
        stats.triangles,
        2 + 2 * 4 * 4
            + 12 * 2 * 2
            + 512 * (2 * 13 + 1)
            + 2 * 512 * 11
            + 1
            + 1
            + 2 * 256 * 57
            + 2 * (2 * 256 * 63 + 256)
    );
    assert_eq!(scene.user_paths.len(), 1);
    assert!(scene.environment.is_some());
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
