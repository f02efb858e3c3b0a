//! The three scenes of Fan, Chenney & Lai 2005, Table 1 (`scenes/rooms.toml`,
//! `scenes/lantern.toml`, `scenes/box.toml`): they load at the documented resolutions, the
//! camera never sees the light directly in Rooms and Lantern, and every user path is a real
//! light path of its scene: each segment, traced from one point toward the next, hits the
//! scene at the next point; the first point is on the emitting side of a light, the last on a
//! diffuse surface; at a mirror the next segment is the reflected direction and at glass the
//! refracted one (Snell's law), within the path's cone angle.

use glam::{Vec2, Vec3};
use photon_bench::bsdf::{Bsdf, SurfaceKind};
use photon_bench::geometry::{Primitive, Ray, spawn_ray};
use photon_bench::scene::{Scene, SurfaceHit, load_scene};
use std::path::Path;

fn scene(name: &str) -> Scene {
    load_scene(&Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{name}.toml"))).unwrap()
}

/// Length of the diagonal of the scene's bounding box.
fn diagonal(scene: &Scene) -> f32 {
    let (lo, hi) = scene.primitives.iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), p| {
        let (a, b) = p.aabb_min_max();
        (lo.min(a), hi.max(b))
    });
    (hi - lo).length()
}

fn angle_deg(a: Vec3, b: Vec3) -> f32 {
    a.normalize().dot(b.normalize()).clamp(-1.0, 1.0).acos().to_degrees()
}

/// Mirror reflection of travel direction `d` at normal `n`.
fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// Refraction of unit travel direction `d` at a smooth interface with normal `n` (outward,
/// toward the medium of index 1) and inside index `ior`, in world space; `None` under total
/// internal reflection.
fn refract(d: Vec3, n: Vec3, ior: f32) -> Option<Vec3> {
    let (n, eta) = if d.dot(n) < 0.0 { (n, 1.0 / ior) } else { (-n, ior) };
    let cos_i = -d.dot(n);
    let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    (k >= 0.0).then(|| eta * d + (eta * cos_i - k.sqrt()) * n)
}

fn material_name<'a>(scene: &'a Scene, hit: &SurfaceHit) -> &'a str {
    &scene.materials[hit.material as usize].name
}

/// Checks every user path of `scene` and returns, per path, the material names of its
/// vertices after the light point.
fn check_user_paths(scene: &Scene) -> Vec<Vec<String>> {
    let tol = 1e-3 * diagonal(scene);
    let mut materials = Vec::new();
    for (j, up) in scene.user_paths.iter().enumerate() {
        let pts = &up.points;
        assert_eq!(up.cone_deg.len(), pts.len() - 1);
        // The light point, found from the second point: it must be on a light, visible from
        // there, and emit toward it.
        let back = (pts[0] - pts[1]).normalize();
        let from1 = scene.intersect(&Ray::new(pts[1] + 1e-4 * diagonal(scene) * back, back));
        let light_hit = from1.unwrap_or_else(|| panic!("path {j}: nothing seen from point 1 toward point 0"));
        assert!(
            (light_hit.p - pts[0]).length() < tol,
            "path {j}: point 0 {} not visible from point 1 (hit {} instead)",
            pts[0],
            light_hit.p
        );
        let light = scene
            .light_of(light_hit.prim)
            .unwrap_or_else(|| panic!("path {j}: point 0 is not on a light"));
        assert!(
            light.le(light_hit.ng, -back).max_element() > 0.0,
            "path {j}: the light does not emit toward point 1"
        );

        let mut hit = light_hit;
        let mut names = Vec::new();
        for i in 0..pts.len() - 1 {
            let d = (pts[i + 1] - pts[i]).normalize();
            let next = scene
                .intersect(&spawn_ray(hit.p, hit.ng, d))
                .unwrap_or_else(|| panic!("path {j}: the ray from point {i} toward point {} escapes", i + 1));
            assert!(
                (next.p - pts[i + 1]).length() < tol,
                "path {j}: the ray from point {i} toward point {} {} hits {} ({}) first",
                i + 1,
                pts[i + 1],
                next.p,
                material_name(scene, &next)
            );
            let last = i + 2 == pts.len();
            let bsdf = scene.bsdf(&next);
            if last {
                assert_eq!(
                    bsdf.kind(),
                    SurfaceKind::Diffuse,
                    "path {j}: the last point is not diffuse"
                );
            } else if bsdf.is_delta() {
                // The next segment must leave in the specular direction, within its cone.
                let out = (pts[i + 2] - pts[i + 1]).normalize();
                let expected = match &*bsdf {
                    Bsdf::Mirror(_) => reflect(d, next.ng),
                    Bsdf::Dielectric(g) => refract(d, next.ng, g.ior)
                        .unwrap_or_else(|| panic!("path {j}: total internal reflection at point {}", i + 1)),
                    other => panic!("path {j}: unexpected delta BSDF {other:?}"),
                };
                let err = angle_deg(expected, out);
                assert!(
                    err < up.cone_deg[i + 1],
                    "path {j}: at point {} ({}) the next segment is {err}° off the specular direction (cone {}°)",
                    i + 1,
                    material_name(scene, &next),
                    up.cone_deg[i + 1]
                );
            }
            names.push(material_name(scene, &next).to_string());
            hit = next;
        }
        materials.push(names);
    }
    materials
}

/// True when some primary ray through a pixel (centre and four inner points) hits a light.
fn camera_sees_a_light(scene: &Scene) -> bool {
    let c = &scene.camera;
    let offsets = [(0.5, 0.5), (0.1, 0.1), (0.9, 0.1), (0.1, 0.9), (0.9, 0.9)];
    (0..c.height).any(|y| {
        (0..c.width).any(|x| {
            offsets.iter().any(|&(dx, dy)| {
                let ray = c.generate_ray(Vec2::new(x as f32 + dx, y as f32 + dy));
                scene.intersect(&ray).is_some_and(|h| scene.light_of(h.prim).is_some())
            })
        })
    })
}

#[test]
fn rooms_loads_and_its_user_paths_go_through_the_doorway() {
    let s = scene("rooms");
    assert_eq!((s.camera.width, s.camera.height), (192, 108));
    assert_eq!(s.lights.len(), 2, "one quad light (two triangles)");
    assert!(!camera_sees_a_light(&s), "the light must be hidden in the other room");
    let paths = check_user_paths(&s);
    assert_eq!(paths.len(), 5);
    for (j, (names, up)) in paths.iter().zip(&s.user_paths).enumerate() {
        assert_eq!(
            names.len(),
            2,
            "path {j}: light, a lit-room surface, a camera-room surface"
        );
        // From the lit room (x > 4.15) into the camera room (x < 4).
        assert!(
            up.points[1].x > 4.15 && up.points[2].x < 4.0,
            "path {j} does not cross the dividing wall"
        );
    }
}

#[test]
fn lantern_loads_and_hides_its_light() {
    let s = scene("lantern");
    assert_eq!((s.camera.width, s.camera.height), (171, 128));
    assert_eq!(s.lights.len(), 1, "one sphere light");
    assert!(s.user_paths.is_empty());
    assert!(!camera_sees_a_light(&s), "the light must be hidden in the lantern");
    // The light is inside the lantern box, and the box is closed but for its cut-outs: rays
    // from the light straight up, down and along a diagonal end on the lantern or the table.
    let l = &s.primitives[s.lights[0].prim as usize];
    let (lo, hi) = l.aabb_min_max();
    let c = 0.5 * (lo + hi);
    for d in [
        Vec3::Y,
        -Vec3::Y,
        Vec3::new(1.0, 0.0, 1.0).normalize(),
        Vec3::new(-1.0, 0.3, 1.0).normalize(),
    ] {
        let h = s.intersect(&Ray::new(c + 0.05 * d, d)).unwrap();
        assert!(
            (h.p - c).length() < 0.3,
            "the ray along {d} leaves the lantern at {}",
            h.p
        );
    }
}

#[test]
fn box_user_paths_follow_the_caustics_through_the_glass_ball() {
    let s = scene("box");
    assert_eq!((s.camera.width, s.camera.height), (160, 120));
    let paths = check_user_paths(&s);
    assert_eq!(paths.len(), 10, "the paper's ten user paths");
    let direct = ["glass", "glass", "white"];
    let via_mirror = ["mirror", "glass", "glass", "white"];
    assert_eq!(paths.iter().filter(|p| *p == &direct).count(), 5, "{paths:?}");
    assert_eq!(paths.iter().filter(|p| *p == &via_mirror).count(), 5, "{paths:?}");
    // The last point is on the floor.
    for up in &s.user_paths {
        assert!(up.points.last().unwrap().y.abs() < 1e-6);
    }
}

#[test]
fn a_bent_user_path_is_caught() {
    // The checker itself: move the exit point of a glass path 20° around the sphere (still on
    // it), so that the chord through the glass turns by 10°, and the check must fail.
    let mut s = scene("box");
    let center = s
        .primitives
        .iter()
        .zip(&s.attrs)
        .find_map(|(p, a)| match p {
            Primitive::Sphere { center, .. } if s.materials[a.material as usize].name == "glass" => Some(*center),
            _ => None,
        })
        .unwrap();
    let up = &mut s.user_paths[0];
    let exit = up.points[2] - center;
    let axis = Vec3::Y.cross(exit).normalize();
    up.points[2] = center + glam::Quat::from_axis_angle(axis, 20f32.to_radians()) * exit;
    let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| check_user_paths(&s)));
    assert!(caught.is_err());
}
