//! `bench perf --strategies`: the throughput of every registered strategy, measured through the
//! [`Strategy`] trait exactly as experiments run it — preparation timed once, then a few
//! repeats of rendering the first `samples` samples into a fresh film (the median and the
//! spread, never a single timing) — with every counter the strategy keeps as a rate (light
//! paths, connections, photons, gathers, mutations … per second).
//!
//! Pixel samples per second are what an equal-time budget buys: the figure to read beside a
//! strategy's error per sample. A progressive strategy starts over at sample 0 each repeat, as
//! the equal-time film of a run does.

use crate::error::Result;
use crate::film::Film;
use crate::scene::Scene;
use crate::strategy::{Registry, Strategy};
use std::time::Instant;

/// One strategy's throughput on one scene.
#[derive(Clone, Debug, serde::Serialize)]
pub struct StrategyThroughput {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    /// The strategy kind (default parameters).
    pub strategy: String,
    pub threads: usize,
    /// Seconds of `prepare` (photon maps, chains' first states, B_eye …).
    pub prepare_s: f64,
    /// Samples per pixel rendered by each repeat.
    pub samples: u32,
    pub repeats: u32,
    /// Pixel samples per second (samples × pixels / render seconds): median, lowest and highest
    /// over the repeats.
    pub pixel_samples_per_s: f64,
    pub pixel_samples_per_s_min: f64,
    pub pixel_samples_per_s_max: f64,
    /// Every counter that rendering advanced, per second of the median repeat:
    /// `name=rate;…`.
    pub counters_per_s: String,
    pub cpu: String,
    pub git_revision: String,
}

/// Measures each of `kinds` (all of `registry` when empty) on `scene`.
pub fn measure_strategies(
    scene: &Scene,
    registry: &Registry,
    kinds: &[String],
    samples: u32,
    repeats: u32,
) -> Result<Vec<StrategyThroughput>> {
    let kinds: Vec<String> = if kinds.is_empty() {
        registry.kinds().into_iter().map(String::from).collect()
    } else {
        kinds.to_vec()
    };
    kinds
        .iter()
        .map(|kind| {
            let mut strategy = registry.build(kind, toml::Table::new())?;
            measure_one(scene, strategy.as_mut(), samples, repeats.max(1))
        })
        .collect()
}

/// One repeat: render seconds and the counters' advance.
struct Repeat {
    seconds: f64,
    advanced: Vec<(String, f64)>,
}

fn measure_one(scene: &Scene, strategy: &mut dyn Strategy, samples: u32, repeats: u32) -> Result<StrategyThroughput> {
    let seed = 0;
    let start = Instant::now();
    strategy.prepare(scene, seed)?;
    let prepare_s = start.elapsed().as_secs_f64();
    let mut runs: Vec<Repeat> = (0..repeats)
        .map(|_| {
            let before = strategy.counters();
            let mut film = Film::new(scene.camera.width, scene.camera.height);
            let start = Instant::now();
            strategy.render_pass(scene, seed, 0..samples, &mut film);
            let seconds = start.elapsed().as_secs_f64();
            std::hint::black_box(film.image());
            let advanced = strategy
                .counters()
                .into_iter()
                .filter_map(|(name, v)| {
                    let was = before.iter().find(|(n, _)| *n == name).map_or(0.0, |(_, w)| *w);
                    (v != was).then_some((name, v - was))
                })
                .collect();
            Repeat { seconds, advanced }
        })
        .collect();
    runs.sort_by(|a, b| a.seconds.total_cmp(&b.seconds));
    let pixel_samples = samples as f64 * scene.camera.pixel_count() as f64;
    let rate = |r: &Repeat| pixel_samples / r.seconds;
    let median = &runs[runs.len() / 2];
    let counters_per_s = median
        .advanced
        .iter()
        .map(|(name, d)| format!("{name}={:.0}", d / median.seconds))
        .collect::<Vec<_>>()
        .join(";");
    Ok(StrategyThroughput {
        scene: scene.name.clone(),
        width: scene.camera.width,
        height: scene.camera.height,
        strategy: strategy.kind().to_string(),
        threads: rayon::current_num_threads(),
        prepare_s,
        samples,
        repeats,
        pixel_samples_per_s: rate(median),
        pixel_samples_per_s_min: rate(&runs[runs.len() - 1]),
        pixel_samples_per_s_max: rate(&runs[0]),
        counters_per_s,
        cpu: crate::util::cpu_model(),
        git_revision: crate::util::git_revision(),
    })
}
