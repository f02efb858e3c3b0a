//! Smooth plastic (Mitsuba's `plastic`: a delta coating over a diffuse base) in the strategies:
//! those that treat each sample's delta flag render it as `path` does, the others refuse it.

mod agreement;

use agreement::{assert_agrees, image_mean};
use photon_bench::scene::Scene;
use photon_bench::scene::load::load_scene_with_stats;
use photon_bench::strategy::{self, Strategy};

const SCENE: &str = r#"[camera]
eye = [0, 0.5, 2.6]
look_at = [0, 0.4, 0]
fov_y = 50
resolution = [12, 9]

[materials.white]
type = "diffuse"
reflectance = [0.7, 0.7, 0.7]
[materials.shiny]
type = "plastic"
diffuse_reflectance = [0.1, 0.3, 0.6]
ior = 1.5

[[shapes]]
type = "box"
material = "white"
min = [-1, 0, -1]
max = [1, 2, 3]
[[shapes]]
type = "sphere"
material = "shiny"
center = [0, 0.45, 0]
radius = 0.45
[[shapes]]
type = "quad"
material = "white"
center = [0, 1.99, 0]
size = [0.6, 0.6]
facing = "-y"
emission = { radiance = [8, 8, 8] }
"#;

fn scene() -> Scene {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plastic.toml");
    std::fs::write(&path, SCENE).unwrap();
    load_scene_with_stats(&path).unwrap().0
}

#[test]
fn strategies_that_class_vertices_by_surface_refuse_smooth_plastic() {
    let scene = scene();
    for kind in strategy::kinds() {
        let s: Box<dyn Strategy> = strategy::build(kind, toml::Table::new()).unwrap();
        match (kind, strategy::check_scene(&*s, &scene)) {
            ("path" | "ppg" | "photon_guided" | "photon_map", r) => assert!(r.is_ok(), "{kind}: {r:?}"),
            (_, Ok(())) => panic!("{kind} accepted a smooth plastic it does not render"),
            (_, Err(e)) => {
                let e = e.to_string();
                assert!(
                    e.lines().count() == 1 && e.contains(&format!("`{kind}`")) && e.contains("\"shiny\""),
                    "{e}"
                );
            }
        }
    }
}

/// A closed box (our diffuse walls reflect on both sides) around a plastic sphere that shows the
/// light in its coating and the walls in both lobes: the unbiased strategies agree with `path`
/// within 4 standard errors of the image mean, `photon_map` within 5 %.
#[test]
fn strategies_that_take_smooth_plastic_agree_with_path() {
    let scene = scene();
    let path = image_mean(&scene, "path", "max_depth = 32", 256);
    for (kind, spp) in [("photon_guided", 64), ("ppg", 64)] {
        assert_agrees(kind, image_mean(&scene, kind, "max_depth = 32", spp), path);
    }
    let (m, _) = image_mean(&scene, "photon_map", "max_depth = 32", 4);
    assert!((m / path.0 - 1.0).abs() < 0.05, "photon_map: {m} vs path {}", path.0);
}
