//! Helpers the feature tests share (`tests/environment.rs`, `tests/plastic.rs`,
//! `tests/delta_lights.rs`, `tests/crop.rs`, `tests/lens.rs`, …): loading a scene written by
//! the test, rendering one image, comparing strategies by their image means, and checking that
//! bad input is refused with one line.

use photon_bench::film::{Film, Image};
use photon_bench::scene::Scene;
use photon_bench::scene::load::load_scene_with_stats;
use photon_bench::strategy;
use std::path::Path;

#[allow(dead_code)]
/// Writes scene `text` to `dir/name` (the extension says TOML or Mitsuba XML) and loads it.
pub fn load_text(dir: &Path, name: &str, text: &str) -> photon_bench::error::Result<Scene> {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    load_scene_with_stats(&path).map(|(s, _)| s)
}

#[allow(dead_code)]
/// One image of `scene` by strategy `kind` with TOML `params`: `spp` samples per pixel under
/// `seed`; the strategy must accept the scene.
pub fn render_image(scene: &Scene, kind: &str, params: &str, spp: u32, seed: u64) -> Image {
    let mut s = strategy::build(kind, toml::from_str(params).unwrap()).unwrap();
    strategy::check_scene(&*s, scene).unwrap();
    s.prepare(scene, seed).unwrap();
    let mut film = Film::new(scene.camera.width, scene.camera.height);
    s.render_pass(scene, seed, 0..spp, &mut film);
    film.image()
}

#[allow(dead_code)] // not every test binary that includes this module compares means
/// Mean (over 6 seeds) of the image-mean of r + g + b that strategy `kind` with `params`
/// renders at `spp`, and its standard error; the strategy must accept the scene.
pub fn image_mean(scene: &Scene, kind: &str, params: &str, spp: u32) -> (f64, f64) {
    let v: Vec<f64> = (0..6u64)
        .map(|seed| {
            let img = render_image(scene, kind, params, spp, seed);
            img.pixels.iter().map(|p| f64::from(p.x + p.y + p.z)).sum::<f64>() / img.pixels.len() as f64
        })
        .collect();
    let m = v.iter().sum::<f64>() / v.len() as f64;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
    (m, (var / v.len() as f64).sqrt())
}

#[allow(dead_code)]
/// Asserts that an unbiased strategy's mean agrees with the baseline's within 4 standard errors.
pub fn assert_agrees(kind: &str, (m, se): (f64, f64), (m0, se0): (f64, f64)) {
    let z = (m - m0) / (se * se + se0 * se0).sqrt();
    assert!(z.abs() < 4.0, "{kind}: {m} ± {se} vs path {m0} ± {se0} (z = {z:.2})");
}

/// Asserts that `err` is one line holding every text of `expect` (a field name, the value).
#[allow(dead_code)] // not every test binary that includes this module refuses input
pub fn assert_refused(err: &str, expect: &[&str]) {
    assert_eq!(err.lines().count(), 1, "{err}");
    for e in expect {
        assert!(err.contains(e), "{err:?} lacks {e:?}");
    }
}

#[allow(dead_code)]
/// Over `images` (one per seed), the mean of r + g + b over `pixels`, averaged, and its
/// standard error.
pub fn region_mean(images: &[Image], pixels: &[(u32, u32)]) -> (f64, f64) {
    let per_image: Vec<f64> = images
        .iter()
        .map(|img| {
            let sum: f64 = pixels
                .iter()
                .map(|&(x, y)| f64::from(img.get(x, y).element_sum()))
                .sum();
            sum / pixels.len() as f64
        })
        .collect();
    let n = per_image.len() as f64;
    let m = per_image.iter().sum::<f64>() / n;
    let var = per_image.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}
