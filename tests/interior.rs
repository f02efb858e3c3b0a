//! `scenes/interior.toml`, the stand-in for Christensen 1999's interior (§3.2, 1.05 M polygons),
//! and the `subdivide` key that meshes it: the scene loads on a clean checkout with at least
//! 500 000 triangles, identically every time; subdivision keeps the surface and its hash
//! tracks it; bad values are one-line errors naming the field.

use photon_bench::geometry::Primitive;
use photon_bench::scene::load::{load_scene_bytes, load_scene_with_stats};
use std::path::Path;

#[test]
fn interior_has_at_least_500k_triangles_and_loads_identically_twice() {
    let path = Path::new("scenes/interior.toml");
    let (a, stats) = load_scene_with_stats(path).unwrap();
    assert!(stats.triangles >= 500_000, "{} triangles", stats.triangles);
    assert_eq!(stats.degenerate_triangles_skipped, 0);
    assert!(stats.files_read.is_empty(), "generated at load time, no mesh file");
    let (b, _) = load_scene_with_stats(path).unwrap();
    assert_eq!(a.content_hash, b.content_hash);
    assert!(a.primitives == b.primitives, "same triangles in the same order");
    assert!(a.attrs == b.attrs);
    // Two ceiling panels, each two triangles, are the only lights.
    assert_eq!(a.lights.len(), 4);
    // The committed reference was made from this very scene (same hash).
    let sidecar = std::fs::read_to_string("references/interior.json").unwrap();
    assert!(
        sidecar.contains(&format!("\"scene_hash\": \"{}\"", a.content_hash)),
        "references/interior.json is stale: run the command it records"
    );
}

/// A one-quad scene (plus a light) with the floor's `subdivide` line replaced by `extra`.
fn floor_scene(extra: &str) -> String {
    format!(
        r#"
[camera]
eye = [0, 1, -3]
look_at = [0, 0, 0]
fov_y = 40
resolution = [8, 8]
[materials.white]
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
[[shapes]]
type = "quad"
material = "white"
center = [0, 0, 0]
size = [2, 1]
facing = "+y"
{extra}
[[shapes]]
type = "quad"
material = "white"
center = [0, 2, 0]
size = [0.5, 0.5]
facing = "-y"
emission = {{ radiance = [1, 1, 1] }}
"#
    )
}

fn load(text: &str) -> photon_bench::Result<photon_bench::scene::Scene> {
    load_scene_bytes(Path::new("floor.toml"), text.as_bytes()).map(|(s, _)| s)
}

/// The one-line error of loading `text`.
fn error(text: &str) -> String {
    match load(text) {
        Ok(_) => panic!("loaded, but an error was expected"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn subdivision_keeps_the_surface_and_changes_the_hash() {
    let plain = load(&floor_scene("")).unwrap();
    let one = load(&floor_scene("subdivide = 1")).unwrap();
    let meshed = load(&floor_scene("subdivide = 5")).unwrap();
    // The floor: 2 triangles, then 2 · 5² = 50; the light adds 2.
    assert_eq!(plain.primitives.len(), 4);
    assert_eq!(meshed.primitives.len(), 52);
    let area = |s: &photon_bench::scene::Scene| -> f64 { s.primitives.iter().map(|p| p.area() as f64).sum() };
    assert!((area(&meshed) - area(&plain)).abs() < 1e-5, "same total area");
    for p in &meshed.primitives[..50] {
        let Primitive::Triangle(v) = p else {
            panic!("a triangle")
        };
        // Every vertex lies in the floor's plane and rectangle, every triangle faces +y.
        assert!(v.iter().all(|q| q.y == 0.0 && q.x.abs() <= 1.0 && q.z.abs() <= 0.5));
        assert!((v[1] - v[0]).cross(v[2] - v[0]).y > 0.0);
    }
    // Equal cells of area 2 / 25, two triangles each.
    assert!(meshed.primitives[..50].iter().all(|p| (p.area() - 0.04).abs() < 1e-6));
    assert_eq!(plain.content_hash.len(), meshed.content_hash.len());
    assert_ne!(plain.content_hash, meshed.content_hash);
    assert_ne!(plain.content_hash, one.content_hash, "the file differs");
}

#[test]
fn bad_subdivide_values_are_one_line_errors_naming_the_field() {
    for (value, expected) in [
        ("0", "expected an integer in 1..=1024 (cells per edge), got 0"),
        ("-3", "got -3"),
        ("1025", "got 1025"),
        ("2.5", "invalid type"),
        ("\"4\"", "invalid type"),
    ] {
        let err = error(&floor_scene(&format!("subdivide = {value}")));
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.starts_with("floor.toml: shapes[0].subdivide"), "{err}");
        assert!(err.contains(expected), "`{expected}` in `{err}`");
    }
    // Boxes take it too, and are checked the same way.
    let boxed = floor_scene("").replace(
        "[[shapes]]\ntype = \"quad\"\nmaterial = \"white\"\ncenter = [0, 0, 0]\nsize = [2, 1]\nfacing = \"+y\"\n",
        "[[shapes]]\ntype = \"box\"\nmaterial = \"white\"\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nsubdivide = 0\n",
    );
    let err = error(&boxed);
    assert!(
        err.starts_with("floor.toml: shapes[0].subdivide: expected an integer"),
        "{err}"
    );
    let ok = boxed.replace("subdivide = 0", "subdivide = 3");
    assert_eq!(load(&ok).unwrap().primitives.len(), 12 * 9 + 2);
}
