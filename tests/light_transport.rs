//! The strategies that splat from the lights (`light`) must agree with `path` — not only in
//! the image mean but region by region, so that a splat landing in the wrong pixel fails as
//! surely as a missing cosine — on scenes whose paths they can all sample (no specular surface
//! seen directly: light tracing cannot connect a mirror to the pinhole).

use photon_bench::color::luminance;
use photon_bench::film::Film;
use photon_bench::scene::Scene;
use photon_bench::scene::load::load_scene_bytes;
use photon_bench::strategy::{self, Strategy};

/// Blocks per image side: 4 × 3 regions.
const BLOCKS: (u32, u32) = (4, 3);

/// Per block of the image, the mean luminance over `seeds` independent renders and its
/// standard error.
fn block_means(scene: &Scene, kind: &str, params: &str, seeds: u64, spp: u32) -> Vec<(f64, f64)> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let per_seed: Vec<Vec<f64>> = (0..seeds)
        .map(|seed| {
            let mut s: Box<dyn Strategy> = strategy::build(kind, toml::from_str(params).unwrap()).unwrap();
            s.prepare(scene, 900 + seed).unwrap();
            let mut film = Film::new(w, h);
            s.render_pass(scene, 900 + seed, 0..spp, &mut film);
            let image = film.image();
            let mut sums = vec![0.0; (BLOCKS.0 * BLOCKS.1) as usize];
            for y in 0..h {
                for x in 0..w {
                    let b = (y * BLOCKS.1 / h) * BLOCKS.0 + x * BLOCKS.0 / w;
                    sums[b as usize] += luminance(image.get(x, y)) as f64;
                }
            }
            let per_block = (w * h) as f64 / sums.len() as f64;
            sums.into_iter().map(|s| s / per_block).collect()
        })
        .collect();
    (0..per_seed[0].len())
        .map(|b| {
            let v: Vec<f64> = per_seed.iter().map(|s| s[b]).collect();
            let m = v.iter().sum::<f64>() / seeds as f64;
            let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (seeds - 1) as f64;
            (m, (var / seeds as f64).sqrt())
        })
        .collect()
}

fn scene(file: &str, resolution: &str) -> Scene {
    let text = std::fs::read_to_string(file).unwrap();
    let line = text.lines().find(|l| l.starts_with("resolution")).unwrap();
    let text = text.replace(line, &format!("resolution = {resolution}"));
    load_scene_bytes(std::path::Path::new(file), text.as_bytes()).unwrap().0
}

/// Every block of `kind` within 4.5 standard errors of `path`'s (a chance failure of one of 12
/// blocks has probability < 1e-4); the worst z is returned for the message.
fn assert_agrees(scene: &Scene, name: &str, kind: &str, params: &str, spp: u32) {
    assert_agrees_with(scene, name, ("path", 16), kind, params, spp);
}

/// [`assert_agrees`] against another reference strategy at its default parameters and
/// `spp` samples per pixel.
fn assert_agrees_with(
    scene: &Scene,
    name: &str,
    (reference_kind, reference_spp): (&str, u32),
    kind: &str,
    params: &str,
    spp: u32,
) {
    let reference = block_means(scene, reference_kind, "", 8, reference_spp);
    let candidate = block_means(scene, kind, params, 8, spp);
    let mut worst = (0.0f64, 0);
    for (b, ((m0, se0), (m, se))) in reference.iter().zip(&candidate).enumerate() {
        let z = (m - m0) / (se * se + se0 * se0).sqrt();
        if z.abs() > worst.0.abs() {
            worst = (z, b);
        }
    }
    let (z, b) = worst;
    assert!(
        z.abs() < 4.5,
        "{name}: {kind} {params:?} block {b}: {:.5} ± {:.5} vs {reference_kind} {:.5} ± {:.5} (z = {z:.1})",
        candidate[b].0,
        candidate[b].1,
        reference[b].0,
        reference[b].1
    );
}

#[test]
fn light_tracing_agrees_with_path_region_by_region() {
    for (file, resolution) in [
        ("scenes/cornell-empty.toml", "[32, 24]"),
        ("scenes/cornell-box.toml", "[24, 24]"),
        ("scenes/cornell-glossy.toml", "[24, 24]"),
    ] {
        let s = scene(file, resolution);
        assert_agrees(&s, file, "light", "", 16);
        // Roulette from the first scattering event and a short depth limit change nothing but
        // the noise (the depth limit is `path`'s own).
        assert_agrees(&s, file, "light", "rr_depth = 0", 16);
    }
}

#[test]
fn bidirectional_path_tracing_agrees_with_path_region_by_region() {
    for (file, resolution) in [
        ("scenes/cornell-empty.toml", "[32, 24]"),
        ("scenes/cornell-glossy.toml", "[24, 24]"),
        // A chrome and a glass sphere seen directly: only BDPT's eye techniques see them.
        ("scenes/cornell-spheres.toml", "[24, 24]"),
    ] {
        let s = scene(file, resolution);
        assert_agrees(&s, file, "bdpt", "", 4);
        assert_agrees(&s, file, "bdpt", "rr_depth = 0\nmax_depth = 16", 4);
    }
}

/// `vcm` with merging turned off is BDPT with VCM's streams and must agree with `path`
/// like `bdpt` does; with merging at its default radius (0.3 % of the scene's bounding
/// radius, about 1.5 mm in these 0.55 m boxes) its bias is far below what 8 seeds resolve,
/// so the full method must agree too — a merge with a wrong normalisation or weight does not.
#[test]
fn vertex_connection_and_merging_agrees_with_path_region_by_region() {
    for (file, resolution) in [
        ("scenes/cornell-empty.toml", "[32, 24]"),
        ("scenes/cornell-spheres.toml", "[24, 24]"),
    ] {
        let s = scene(file, resolution);
        assert_agrees(&s, file, "vcm", "mode = \"bpt\"", 4);
        assert_agrees(&s, file, "vcm", "", 4);
    }
}

/// With merging turned off `vcm` is the same estimator as `bdpt` (same techniques, same
/// power-heuristic weights), so against `bdpt`'s much smaller error bars on the scene where
/// BDPT's eye techniques matter most it must still agree block by block.
#[test]
fn vertex_connection_without_merging_matches_bdpt() {
    let file = "scenes/cornell-spheres.toml";
    let s = scene(file, "[24, 24]");
    assert_agrees_with(&s, file, ("bdpt", 16), "vcm", "mode = \"bpt\"", 16);
}

/// Practical path guiding is unbiased as long as the BSDF keeps a share of the mixture: region
/// by region it agrees with `path`, with the paper's mixture and iterations combined by inverse
/// variance, and with a guide-heavy mixture and the last iteration only, on a
/// scene lit indirectly, one with specular spheres and one with glossy surfaces. A spatial
/// threshold below the paper's gives these small images a real S-tree to guide with.
#[test]
fn practical_path_guiding_agrees_with_path_region_by_region() {
    for (file, resolution) in [
        ("scenes/cornell-empty.toml", "[32, 24]"),
        ("scenes/cornell-spheres.toml", "[24, 24]"),
        ("scenes/cornell-glossy.toml", "[24, 24]"),
    ] {
        let s = scene(file, resolution);
        assert_agrees(
            &s,
            file,
            "ppg",
            "training_iterations = 4\nspatial_threshold = 500.0",
            16,
        );
        assert_agrees(
            &s,
            file,
            "ppg",
            "training_iterations = 4\nspatial_threshold = 500.0\nbsdf_fraction = 0.25\ncombine = \"last\"",
            16,
        );
    }
}

/// Mitsuba's microfacet materials (rough gold, frosted glass, rough plastic) through every
/// unbiased strategy: the bidirectional ones evaluate the rough dielectric in both transport
/// modes (radiance is compressed by 1/η² on refraction, importance is not), light tracing
/// connects glossy vertices to the eye, and the guided samplers mix their guides with the new
/// lobes; region by region each must agree with `path`.
#[test]
fn every_unbiased_strategy_agrees_with_path_on_microfacet_materials() {
    let file = "scenes/cornell-microfacet.toml";
    let s = scene(file, "[24, 24]");
    for (kind, params, spp) in [
        ("light", "", 16),
        ("bdpt", "", 4),
        ("vcm", "mode = \"bpt\"", 4),
        ("ppg", "training_iterations = 4\nspatial_threshold = 500.0", 16),
        ("photon_guided", "", 8),
    ] {
        assert_agrees(&s, file, kind, params, spp);
    }
}
