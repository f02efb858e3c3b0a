//! Smooth-shaded meshes: where interpolated shading normals differ from the faces' geometric
//! normals, every strategy must estimate the image `path` estimates (the rendering equation
//! with the shading normal's cosine, as Mitsuba integrates it). Light sub-paths need Veach's
//! adjoint correction for that [Veach 1997, eq. (5.19)]; path space gets it from its geometry
//! term ([`photon_bench::path_space::geometry`]). Before that term took the shading cosine,
//! `bdpt` sat 0.3 % below `path` on Mitsuba's material-preview scenes.

mod agreement;

use agreement::{assert_agrees, image_mean};
use glam::Vec3;
use photon_bench::scene::load::load_scene_with_stats;
use std::fmt::Write;

/// An octahedron subdivided `levels` times and pushed onto the unit sphere, with each vertex's
/// normal its position: faces up to ~20° off their vertices' normals at one level.
fn coarse_sphere_obj(levels: u32) -> String {
    let mut tris: Vec<[Vec3; 3]> = Vec::new();
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    for (a, b) in [(x, z), (z, -x), (-x, -z), (-z, x)] {
        tris.push([a, b, y]);
        tris.push([b, a, -y]);
    }
    for _ in 0..levels {
        tris = tris
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = ((a + b).normalize(), (b + c).normalize(), (c + a).normalize());
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect();
    }
    let mut obj = String::new();
    for t in &tris {
        for v in t {
            writeln!(obj, "v {} {} {}\nvn {} {} {}", v.x, v.y, v.z, v.x, v.y, v.z).unwrap();
        }
    }
    for i in 0..tris.len() {
        let k = 3 * i + 1;
        writeln!(obj, "f {k}//{k} {}//{} {}//{}", k + 1, k + 1, k + 2, k + 2).unwrap();
    }
    obj
}

const SCENE: &str = r#"[camera]
eye = [0, 1.2, 3.2]
look_at = [0, 0.5, 0]
fov_y = 40
resolution = [16, 12]

[materials.white]
type = "diffuse"
reflectance = [0.7, 0.7, 0.7]
[materials.red]
type = "diffuse"
reflectance = [0.8, 0.3, 0.2]
[materials.lamp]
type = "diffuse"
reflectance = [0, 0, 0]

[[shapes]]
type = "quad"
material = "white"
center = [0, 0, 0]
size = [4, 4]
facing = "+y"
[[shapes]]
type = "mesh"
material = "red"
file = "ball.obj"
transform = { scale = 0.5, translate = [0, 0.5, 0] }
[[shapes]]
type = "quad"
material = "lamp"
center = [0.6, 2, 0.4]
size = [0.8, 0.8]
facing = "-y"
emission = { radiance = [8, 8, 8] }
"#;

/// `bdpt`, `light` and `vcm` in its connection-only mode agree with `path` within 4 standard
/// errors of the image mean on a coarse smooth-shaded ball, whose shading normals are up to
/// ~20° off its faces' (with geometric cosines in path space, `bdpt` read 0.7 % high here, z = 7).
#[test]
fn strategies_agree_with_path_on_smooth_shaded_meshes() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("ball.obj"), coarse_sphere_obj(1)).unwrap();
    let path = dir.path().join("ball.toml");
    std::fs::write(&path, SCENE).unwrap();
    let (scene, _) = load_scene_with_stats(&path).unwrap();
    let reference = image_mean(&scene, "path", "max_depth = 6", 1024);
    for (kind, params, spp) in [
        ("bdpt", "max_depth = 6", 256),
        ("light", "max_depth = 6", 512),
        ("vcm", "max_depth = 6\nmode = \"bpt\"", 256),
    ] {
        assert_agrees(kind, image_mean(&scene, kind, params, spp), reference);
    }
}
