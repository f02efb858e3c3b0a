//! `path` with NEE + MIS, with NEE only, with BSDF sampling only, with uniform hemisphere
//! sampling, and with local light selection and cone sampling of sphere lights estimate the
//! same integral: their image means agree within a statistical tolerance on `cornell-empty`
//! (almost all light indirect), `cornell-spheres` (caustics through glass, mirror reflections)
//! and `desk-lamp` (a sphere light inside a transmitting shade, a quad light: the scene where
//! the light sampling options matter).

use photon_bench::color::luminance;
use photon_bench::film::Film;
use photon_bench::light::{LightSelection, SphereSampling};
use photon_bench::scene::load::load_scene_bytes;
use photon_bench::scene::{Scene, load_scene};
use photon_bench::strategy::Strategy;
use photon_bench::strategy::path::{BsdfSampling, Direct, Path, PathParams};

/// Mean and standard error of the image-mean luminance over independent seeds.
fn mean_and_se(scene: &Scene, params: PathParams, seeds: u64, spp: u32) -> (f64, f64) {
    let strategy = Path::new(params);
    let means: Vec<f64> = (0..seeds)
        .map(|seed| {
            let mut film = Film::new(scene.camera.width, scene.camera.height);
            strategy.render_pass(scene, 1000 + seed, 0..spp, &mut film);
            luminance(film.image().mean()) as f64
        })
        .collect();
    let m = means.iter().sum::<f64>() / seeds as f64;
    let var = means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (seeds - 1) as f64;
    (m, (var / seeds as f64).sqrt())
}

fn assert_agree(scene_file: &str, spp: u32) {
    let scene = load_scene(std::path::Path::new(scene_file)).unwrap();
    assert_agree_on(&scene, scene_file, spp);
}

fn assert_agree_on(scene: &Scene, scene_file: &str, spp: u32) {
    let local = |direct, sphere_light_sampling| PathParams {
        direct,
        light_selection: LightSelection::Local,
        sphere_light_sampling,
        ..PathParams::default()
    };
    let variants = [
        PathParams::default(),
        PathParams {
            direct: Direct::Nee,
            ..PathParams::default()
        },
        PathParams {
            direct: Direct::Bsdf,
            ..PathParams::default()
        },
        PathParams {
            bsdf_sampling: BsdfSampling::Uniform,
            ..PathParams::default()
        },
        PathParams {
            sphere_light_sampling: SphereSampling::Cone,
            ..PathParams::default()
        },
        local(Direct::Mis, SphereSampling::Area),
        local(Direct::Mis, SphereSampling::Cone),
        local(Direct::Nee, SphereSampling::Cone),
    ];
    let (m0, se0) = mean_and_se(scene, variants[0].clone(), 8, spp);
    assert!(
        m0 > 0.0 && se0 < 0.01 * m0,
        "{scene_file}: the baseline itself must be precise: {m0} ± {se0}"
    );
    for v in &variants[1..] {
        let (m, se) = mean_and_se(scene, v.clone(), 8, spp);
        let z = (m - m0).abs() / (se * se + se0 * se0).sqrt();
        // |z| < 4.5 fails by chance with probability < 1e-5.
        assert!(
            z < 4.5,
            "{scene_file} {v:?}: mean {m} ± {se} vs MIS {m0} ± {se0} (z = {z:.1})"
        );
    }
}

#[test]
fn path_variants_agree_on_cornell_empty() {
    assert_agree("scenes/cornell-empty.toml", 16);
}

#[test]
fn path_variants_agree_on_cornell_spheres() {
    assert_agree("scenes/cornell-spheres.toml", 4);
}

#[test]
fn path_variants_agree_on_desk_lamp() {
    let file = "scenes/desk-lamp.toml";
    let text = std::fs::read_to_string(file)
        .unwrap()
        .replace("resolution = [160, 120]", "resolution = [40, 30]");
    let (scene, _) = load_scene_bytes(std::path::Path::new(file), text.as_bytes()).unwrap();
    assert_agree_on(&scene, file, 64);
}
