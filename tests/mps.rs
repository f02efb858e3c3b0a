//! Metropolis photon sampling: the photon powers hold the flux a photon map must hold.
//!
//! - Radiance does not depend on the unit of length: a scene scaled by 10 renders the same
//!   image. With the importon normalisation MPS does; the paper's printed power formula
//!   carries the measure of the eye sub-paths and renders a scaled scene far too bright (the
//!   reason the normalisation exists; `photon_power = "paper"` keeps the formula selectable).
//! - The global map holds the flux that reaches the storage points: in a closed box whose
//!   every diffuse point the final gather can reach, the same total as standard photon
//!   tracing's global map.
//! - The rendered image matches path tracing in mean.

use photon_bench::camera::Camera;
use photon_bench::color::luminance;
use photon_bench::film::Film;
use photon_bench::photon::{CausticStorage, TraceParams, trace_photons};
use photon_bench::scene::Scene;
use photon_bench::scene::load::load_scene_bytes;
use photon_bench::strategy::{self, Strategy};
use std::path::Path;

/// A scene file with every length (camera position, shape centres, sizes, radii) times `s`.
fn scaled_scene(file: &str, s: f64, width: u32, height: u32) -> Scene {
    fn scale(v: &mut toml::Value, s: f64) {
        match v {
            toml::Value::Float(x) => *x *= s,
            toml::Value::Integer(i) => *v = toml::Value::Float(*i as f64 * s),
            toml::Value::Array(a) => a.iter_mut().for_each(|x| scale(x, s)),
            _ => {}
        }
    }
    fn walk(v: &mut toml::Value, s: f64) {
        match v {
            toml::Value::Table(t) => {
                for (k, x) in t.iter_mut() {
                    if ["eye", "look_at", "center", "size", "radius"].contains(&k.as_str()) {
                        scale(x, s);
                    } else {
                        walk(x, s);
                    }
                }
            }
            toml::Value::Array(a) => a.iter_mut().for_each(|x| walk(x, s)),
            _ => {}
        }
    }
    let path = Path::new(file);
    let mut doc: toml::Value = toml::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    walk(&mut doc, s);
    let (mut scene, _) = load_scene_bytes(path, toml::to_string(&doc).unwrap().as_bytes()).unwrap();
    let c = &scene.camera;
    scene.camera = Camera::new(c.eye, c.look_at, c.up, c.fov_y_deg, width, height);
    scene
}

fn mean_luminance(scene: &Scene, strategy: &mut dyn Strategy, spp: u32) -> f64 {
    mean_luminance_seeded(scene, strategy, spp, 5)
}

fn mean_luminance_seeded(scene: &Scene, strategy: &mut dyn Strategy, spp: u32, seed: u64) -> f64 {
    strategy.prepare(scene, seed).unwrap();
    let mut film = Film::new(scene.camera.width, scene.camera.height);
    strategy.render_pass(scene, seed, 0..spp, &mut film);
    let img = film.image();
    img.pixels.iter().map(|p| luminance(*p) as f64).sum::<f64>() / img.pixels.len() as f64
}

fn mps(power: &str) -> Box<dyn Strategy> {
    let table: toml::Table = toml::from_str(&format!(
        "mutations = 150000\nb_samples = 50000\nimportons = 300000\ngather_rays = 12\nphoton_power = \"{power}\""
    ))
    .unwrap();
    strategy::build("mps", table).unwrap()
}

fn counter(s: &dyn Strategy, name: &str) -> f64 {
    s.counters().into_iter().find(|(k, _)| k == name).unwrap().1
}

#[test]
fn importon_normalised_photons_render_a_scaled_scene_alike_and_the_paper_formula_does_not() {
    let one = scaled_scene("scenes/cornell-spheres.toml", 1.0, 24, 24);
    let ten = scaled_scene("scenes/cornell-spheres.toml", 10.0, 24, 24);
    let a = mean_luminance(&one, mps("importon").as_mut(), 2);
    let b = mean_luminance(&ten, mps("importon").as_mut(), 2);
    eprintln!("importon {a} {b}");
    assert!((a / b - 1.0).abs() < 0.02, "importon: scale 1 → {a}, scale 10 → {b}");
    let pa = mean_luminance(&one, mps("paper").as_mut(), 2);
    let pb = mean_luminance(&ten, mps("paper").as_mut(), 2);
    eprintln!("paper {pa} {pb}");
    assert!(pb > 10.0 * pa, "paper: scale 1 → {pa}, scale 10 → {pb}");
}

#[test]
fn mps_matches_path_tracing_in_mean() {
    let scene = scaled_scene("scenes/cornell-empty.toml", 1.0, 32, 24);
    let reference = mean_luminance(
        &scene,
        strategy::build("path", toml::Table::new()).unwrap().as_mut(),
        256,
    );
    let m = mean_luminance(&scene, mps("importon").as_mut(), 2);
    eprintln!("mean {m} {reference}");
    assert!((m / reference - 1.0).abs() < 0.04, "mps {m} vs path {reference}");
}

/// The luminance flux standard photon tracing (200 000 paths) stores in its global map.
fn traced_global_flux(scene: &Scene) -> f64 {
    let traced = trace_photons(
        scene,
        &TraceParams {
            photons: 200_000,
            max_depth: 16,
            store_direct: true,
            caustics: CausticStorage::Both,
        },
        9,
    );
    traced.global.iter().map(|p| luminance(p.power()) as f64).sum()
}

#[test]
fn global_map_holds_the_flux_photon_tracing_stores() {
    let scene = scaled_scene("scenes/cornell-empty.toml", 1.0, 32, 24);
    let mut s = mps("importon");
    s.prepare(&scene, 9).unwrap();
    let stored = counter(s.as_ref(), "global_power_y");
    let reference = traced_global_flux(&scene);
    eprintln!("power {stored} {reference}");
    assert!(
        (stored / reference - 1.0).abs() < 0.05,
        "MPS global map {stored} vs photon tracing {reference}"
    );
}

/// A scene file with its text passed through `edit`, at `width` × `height`.
fn edited_scene(file: &str, edit: impl FnOnce(String) -> String, width: u32, height: u32) -> Scene {
    let path = Path::new(file);
    let text = edit(std::fs::read_to_string(path).unwrap());
    let (mut scene, _) = load_scene_bytes(path, text.as_bytes()).unwrap();
    let c = &scene.camera;
    scene.camera = Camera::new(c.eye, c.look_at, c.up, c.fov_y_deg, width, height);
    scene
}

/// MPS under point, spot, directional and environment light (x₀ a point without area or a
/// direction; the chain of `tests/metropolis.rs`): in the closed Cornell box lit by a point and
/// a spot light instead of its area light, the global map holds the flux photon tracing stores
/// (within 5 %) and the image matches bidirectional path tracing in mean (within 4 %; `path`
/// cannot see the lights' caustics through cornell-spheres' mirror and glass, `bdpt` can); in
/// the open box under a sky and a sun the image matches `bdpt` in mean too.
#[test]
fn mps_renders_delta_and_environment_light() {
    let delta_lights = "\n[[lights]]\ntype = \"point\"\nposition = [0.2, 0.45, 0.3]\nintensity = [0.4, 0.35, 0.3]\n\
                        [[lights]]\ntype = \"spot\"\nposition = [0.4, 0.5, 0.1]\ntarget = [0.3, 0.0, 0.4]\n\
                        intensity = [1.5, 1.5, 1.2]\ncutoff_angle = 35\n";
    let room = edited_scene(
        "scenes/cornell-spheres.toml",
        |t| t.replace("emission = { radiance = [17, 12, 4], two_sided = false }", "") + delta_lights,
        32,
        24,
    );
    assert!(room.lights.is_empty() && room.delta_lights.len() == 2);
    let mut s = mps("importon");
    let m = mean_luminance(&room, s.as_mut(), 2);
    let stored = counter(s.as_ref(), "global_power_y");
    let reference = traced_global_flux(&room);
    assert!(
        (stored / reference - 1.0).abs() < 0.05,
        "MPS global map {stored} vs photon tracing {reference}"
    );
    let bdpt = mean_luminance(&room, strategy::build("bdpt", toml::Table::new()).unwrap().as_mut(), 64);
    assert!((m / bdpt - 1.0).abs() < 0.04, "room: mps {m} vs bdpt {bdpt}");

    let sky = "\n[environment]\ntype = \"constant\"\nradiance = [0.3, 0.4, 0.6]\n\
               [[lights]]\ntype = \"directional\"\ndirection = [0.3, -1, 0.4]\nirradiance = [2, 1.8, 1.5]\n";
    let open = edited_scene(
        "scenes/cornell-spheres.toml",
        |t| {
            let ceiling = "[[shapes]] # ceiling\ntype = \"quad\"\nmaterial = \"white\"\ncenter = [0.278, 0.5488, 0.2796]\nsize = [0.556, 0.5592]\nfacing = \"-y\"\n";
            assert!(t.contains(ceiling));
            t.replace(ceiling, "")
                .replace("emission = { radiance = [17, 12, 4], two_sided = false }", "")
                + sky
        },
        32,
        24,
    );
    let m = mean_luminance(&open, mps("importon").as_mut(), 2);
    let bdpt = mean_luminance(&open, strategy::build("bdpt", toml::Table::new()).unwrap().as_mut(), 64);
    assert!((m / bdpt - 1.0).abs() < 0.04, "open box: mps {m} vs bdpt {bdpt}");
}

/// MPS with smooth plastic (cornell-plastic: two plastic spheres in the closed box). The final
/// gather shades at a plastic whichever lobe a path took there and sends gather rays through
/// the whole model, and a gather ray that lands on a plastic reads the map there or goes on
/// through the coating; storage points, importons and q follow the same rules
/// (`mps::storage_point`, `mps::importons`). Over 6 seeds of 600 000 mutations, the global map
/// holds the flux photon tracing stores (within 5 %: photons are stored at a plastic with all
/// the flux that arrives, whatever lobe comes next) and the image is within 6 % of `bdpt`'s,
/// with the spheres' bases as shipped and with dark bases, where the coatings carry the
/// spheres. (The 6 %: at this tiny size and budget MPS reads −3.4 % against `bdpt` with
/// diffuse spheres too, while `photon_map` reads +2.8 %; at the scene's 128 × 128 both read
/// about +1 %, docs/user-guide.md. One seed is not enough: single runs spread by ±3 % in flux
/// and ±6 % in image mean.)
#[test]
fn mps_renders_smooth_plastic() {
    for dark in [false, true] {
        let room = edited_scene(
            "scenes/cornell-plastic.toml",
            |t| match dark {
                false => t,
                true => t
                    .replace(
                        "diffuse_reflectance = [0.1, 0.27, 0.36]",
                        "diffuse_reflectance = [0.01, 0.02, 0.03]",
                    )
                    .replace(
                        "diffuse_reflectance = [0.8, 0.8, 0.8]",
                        "diffuse_reflectance = [0.02, 0.02, 0.02]",
                    ),
            },
            32,
            24,
        );
        let (mut flux, mut image) = (0.0, 0.0);
        let seeds = 6;
        for seed in 0..seeds {
            let mut s = strategy::build(
                "mps",
                toml::from_str("mutations = 600000\nb_samples = 50000\nimportons = 300000\ngather_rays = 12").unwrap(),
            )
            .unwrap();
            image += mean_luminance_seeded(&room, s.as_mut(), 2, seed) / seeds as f64;
            flux += counter(s.as_ref(), "global_power_y") / seeds as f64;
        }
        let reference = traced_global_flux(&room);
        assert!(
            (flux / reference - 1.0).abs() < 0.05,
            "dark bases {dark}: MPS global map {flux} vs photon tracing {reference}"
        );
        let bdpt = mean_luminance(
            &room,
            strategy::build("bdpt", toml::Table::new()).unwrap().as_mut(),
            256,
        );
        assert!(
            (image / bdpt - 1.0).abs() < 0.06,
            "dark bases {dark}: mps {image} vs bdpt {bdpt}"
        );
    }
}
