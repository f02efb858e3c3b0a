//! The consistent strategies (`ppm`, `sppm`, `vcm`) must converge: their error against a path-traced
//! reference falls as passes grow, and the image mean approaches the reference's — on a
//! diffuse scene, on one with caustics and glass (cornell-spheres) and on one with glossy
//! surfaces the eye paths pass through (cornell-glossy).

use photon_bench::color::luminance;
use photon_bench::film::{Film, Image};
use photon_bench::scene::Scene;
use photon_bench::scene::load::load_scene_bytes;
use photon_bench::strategy::{self, Strategy};

fn scene(file: &str, resolution: &str) -> Scene {
    let text = std::fs::read_to_string(file).unwrap();
    let line = text.lines().find(|l| l.starts_with("resolution")).unwrap();
    let text = text.replace(line, &format!("resolution = {resolution}"));
    load_scene_bytes(std::path::Path::new(file), text.as_bytes()).unwrap().0
}

/// The images of `kind` after each of `checkpoints` passes, in one progressive render.
fn progressive(scene: &Scene, kind: &str, params: &str, seed: u64, checkpoints: &[u32]) -> Vec<Image> {
    let mut s: Box<dyn Strategy> = strategy::build(kind, toml::from_str(params).unwrap()).unwrap();
    s.prepare(scene, seed).unwrap();
    let mut film = Film::new(scene.camera.width, scene.camera.height);
    let mut done = 0;
    checkpoints
        .iter()
        .map(|&k| {
            s.render_pass(scene, seed, done..k, &mut film);
            done = k;
            film.image()
        })
        .collect()
}

/// Side of the square pixel blocks whose mean luminances [`block_mse`] compares. The first row
/// of blocks, which holds the ceiling light, is left out: the few pixels across its edge, whose
/// coverage even 64 eye samples estimate only to a few %, would dominate every measure.
const BLOCK: u32 = 4;

/// MSE of the mean luminances of BLOCK × BLOCK pixel blocks below the first row of blocks.
/// Blocks rather than pixels keep the measure on the photon estimates, not on the antialiasing
/// of edges (which `ppm`'s fixed hit points never refine).
fn block_mse(a: &Image, b: &Image) -> f64 {
    let blocks = |img: &Image| -> Vec<f64> {
        let (bw, bh) = (img.width / BLOCK, img.height / BLOCK);
        let mut sums = vec![0.0; (bw * bh) as usize];
        for y in 0..bh * BLOCK {
            for x in 0..bw * BLOCK {
                sums[((y / BLOCK) * bw + x / BLOCK) as usize] += luminance(img.get(x, y)) as f64;
            }
        }
        sums
    };
    let bw = (a.width / BLOCK) as usize;
    let (ba, bb) = (&blocks(a)[bw..], &blocks(b)[bw..]);
    let n = (BLOCK * BLOCK) as f64;
    ba.iter().zip(bb).map(|(p, q)| ((p - q) / n).powi(2)).sum::<f64>() / ba.len() as f64
}

/// Mean luminance below the first row of blocks (the region [`block_mse`] compares).
fn mean_luminance(image: &Image) -> f64 {
    let rows = BLOCK..image.height;
    let n = (rows.len() as u32 * image.width) as f64;
    rows.flat_map(|y| (0..image.width).map(move |x| (x, y)))
        .map(|(x, y)| luminance(image.get(x, y)) as f64)
        .sum::<f64>()
        / n
}

/// `sppm` and `vcm` (and its merging-only mode) against a 4096-spp path reference, after 4, 16 and 64 passes, summed over two seeds
/// (block MSE, the reference's own noise subtracted; means below the first block row): the
/// error must fall by 2.5× or more from 4 to 64 passes (the method's error falls roughly like
/// k^−2/3, so 16× the passes give about 6×, less where the bias of blurring a caustic or a
/// glossy lobe dominates), and after 64 passes the image mean must be within 2 % of the
/// reference's. With direct light from light sampling and from photons.
#[test]
fn sppm_and_vcm_converge_to_the_path_traced_reference() {
    let checkpoints = [4, 16, 64];
    for (file, resolution) in [
        ("scenes/cornell-empty.toml", "[24, 24]"),
        ("scenes/cornell-spheres.toml", "[24, 24]"),
        ("scenes/cornell-glossy.toml", "[24, 18]"),
    ] {
        let scene = scene(file, resolution);
        let reference = progressive(&scene, "path", "", 1, &[4096]).remove(0);
        let other = progressive(&scene, "path", "", 2, &[4096]).remove(0);
        let noise = block_mse(&reference, &other) / 2.0;
        for (kind, params) in [
            ("sppm", "initial_radius = 0.015\nphotons_per_pass = 10000"),
            (
                "sppm",
                "initial_radius = 0.015\nphotons_per_pass = 10000\ndirect = \"photons\"",
            ),
            ("vcm", ""),
            ("vcm", "mode = \"ppm\"\nradius_factor = 0.01"),
        ] {
            let mut errors = [-2.0 * noise; 3];
            let mut last_mean = 0.0;
            for seed in [11, 12] {
                let images = progressive(&scene, kind, params, seed, &checkpoints);
                for (e, image) in errors.iter_mut().zip(&images) {
                    *e += block_mse(image, &reference);
                }
                last_mean += mean_luminance(&images[2]) / 2.0;
            }
            let what = format!("{file}: {kind} [{}]", params.replace('\n', ", "));
            assert!(
                errors[0] > 2.5 * errors[2],
                "{what}: MSE after 4, 16, 64 passes {errors:?} (reference noise {noise})"
            );
            let rel = last_mean / mean_luminance(&reference) - 1.0;
            assert!(rel.abs() < 0.02, "{what}: image mean {rel:+.4} off the reference's");
        }
    }
}

/// `ppm` converges to the radiance at its fixed hit points: with direct light from photons and
/// from light sampling it shares the hit points (the same streams), so the two renders must
/// (where light arrives directly)
/// approach each other — their difference falls by 3× from 4 to 64 passes — while their mean
/// stays within 2 % of `path`'s (the fixed points sample the pixels without bias; on scenes
/// without the light's reflection in a mirror, which 4 fixed points per pixel estimate only to
/// several %).
#[test]
fn ppm_converges_at_its_fixed_hit_points() {
    for (file, resolution) in [
        ("scenes/cornell-empty.toml", "[24, 24]"),
        ("scenes/cornell-box.toml", "[24, 24]"),
    ] {
        let scene = scene(file, resolution);
        let reference = progressive(&scene, "path", "", 1, &[1024]).remove(0);
        let base = "initial_radius = 0.015\nphotons_per_pass = 10000\neye_samples = 4\n";
        let render = |direct: &str| progressive(&scene, "ppm", &format!("{base}direct = \"{direct}\""), 5, &[4, 64]);
        let (nee, photons) = (render("nee"), render("photons"));
        let (early, late) = (block_mse(&nee[0], &photons[0]), block_mse(&nee[1], &photons[1]));
        assert!(
            early > 3.0 * late,
            "{file}: difference after 4 and 64 passes {early} → {late}"
        );
        for image in [&nee[1], &photons[1]] {
            let rel = mean_luminance(image) / mean_luminance(&reference) - 1.0;
            assert!(rel.abs() < 0.02, "{file}: ppm's image mean {rel:+.4} off path's");
        }
    }
}
