//! Same experiment and seed → bit-identical image, for any thread count (in preparation and
//! in rendering) and any split of the samples into passes; a different seed gives a different
//! image.

use photon_bench::film::{Film, Image};
use photon_bench::scene::Scene;
use photon_bench::scene::load::load_scene_bytes;
use photon_bench::strategy::{self, Strategy};
use std::ops::Range;

fn render(scene: &Scene, strategy: &dyn Strategy, seed: u64, passes: &[Range<u32>], threads: usize) -> Image {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| {
        let mut film = Film::new(scene.camera.width, scene.camera.height);
        for p in passes {
            strategy.render_pass(scene, seed, p.clone(), &mut film);
        }
        film.image()
    })
}

fn bits(img: &Image) -> Vec<u32> {
    img.pixels.iter().flat_map(|p| p.to_array()).map(f32::to_bits).collect()
}

#[test]
fn every_strategy_is_bit_identical_across_thread_counts_and_pass_splits() {
    // cornell-spheres (mirror, glass, caustics) at 32 × 32, so that the slowest strategies
    // (final gathering) stay cheap; every code path is still exercised.
    let file = std::path::Path::new("scenes/cornell-spheres.toml");
    let text = std::fs::read_to_string(file)
        .unwrap()
        .replace("resolution = [128, 128]", "resolution = [32, 32]");
    let (scene, _) = load_scene_bytes(file, text.as_bytes()).unwrap();
    assert_eq!(scene.camera.width, 32, "the resolution replacement must apply");
    for kind in strategy::kinds() {
        // Preparation too (photon tracing, MPS's chains and the merging of their photons,
        // irradiance caches): on 1 thread and on 3.
        let prepared = |threads: usize| {
            let mut s = strategy::build(kind, toml::Table::new()).unwrap();
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| s.prepare(&scene, 7)).unwrap();
            s
        };
        let (s, s3) = (prepared(1), prepared(3));
        let whole = std::slice::from_ref(&(0..4));
        let one = render(&scene, s.as_ref(), 7, whole, 1);
        let two = render(&scene, s.as_ref(), 7, whole, 2);
        let four_split = render(&scene, s.as_ref(), 7, &[0..1, 1..3, 3..4], 4);
        assert_eq!(bits(&one), bits(&two), "{kind}: 1 vs 2 threads");
        assert_eq!(bits(&one), bits(&four_split), "{kind}: one pass vs three");
        let prepared_on_3 = render(&scene, s3.as_ref(), 7, whole, 2);
        assert_eq!(bits(&one), bits(&prepared_on_3), "{kind}: prepared on 1 vs 3 threads");
        let other_seed = render(&scene, s.as_ref(), 8, whole, 2);
        assert_ne!(bits(&one), bits(&other_seed), "{kind}: the seed must matter");
    }
}
