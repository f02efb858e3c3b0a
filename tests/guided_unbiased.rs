//! Jensen 1995 claims photon guiding adds no bias: no direction gets zero probability. The
//! image mean of `photon_guided` (both readings of the empty-cell rule, and the defensive BSDF
//! mixture) must agree with `path` within a statistical tolerance on `cornell-empty`, where
//! almost all light is indirect and the guided pdf matters most.

use photon_bench::film::Film;
use photon_bench::scene::load::load_scene_bytes;
use photon_bench::scene::{Scene, luminance};
use photon_bench::strategy::{self, Strategy};

/// Mean and standard error of the image-mean luminance over independent seeds.
fn mean_and_se(scene: &Scene, kind: &str, params: &str, seeds: u64, spp: u32) -> (f64, f64) {
    let means: Vec<f64> = (0..seeds)
        .map(|seed| {
            let mut s: Box<dyn Strategy> = strategy::build(kind, toml::from_str(params).unwrap()).unwrap();
            s.prepare(scene, 500 + seed).unwrap();
            let mut film = Film::new(scene.camera.width, scene.camera.height);
            s.render_pass(scene, 500 + seed, 0..spp, &mut film);
            luminance(film.image().mean()) as f64
        })
        .collect();
    let m = means.iter().sum::<f64>() / seeds as f64;
    let var = means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (seeds - 1) as f64;
    (m, (var / seeds as f64).sqrt())
}

#[test]
fn photon_guided_agrees_with_path_on_cornell_empty() {
    let text = std::fs::read_to_string("scenes/cornell-empty.toml")
        .unwrap()
        .replace("resolution = [80, 60]", "resolution = [32, 24]");
    let (scene, _) = load_scene_bytes(std::path::Path::new("scenes/cornell-empty.toml"), text.as_bytes()).unwrap();
    let (m0, se0) = mean_and_se(&scene, "path", "", 8, 32);
    assert!(se0 < 0.01 * m0, "baseline precise enough: {m0} ± {se0}");
    for params in [
        "photons = 20000",
        "photons = 20000\nempty_cells = \"shared\"",
        "photons = 20000\nbsdf_mixture = 0.25",
    ] {
        let (m, se) = mean_and_se(&scene, "photon_guided", params, 8, 32);
        let z = (m - m0).abs() / (se * se + se0 * se0).sqrt();
        // |z| < 4.5 fails by chance with probability < 1e-5; a biased pdf (e.g. ε = 0 leaving
        // directions unsampled, or a missing cos θ in the pdf) moves the mean by far more.
        assert!(z < 4.5, "{params}: mean {m} ± {se} vs path {m0} ± {se0} (z = {z:.1})");
    }
}
