//! `bench perf --strategies` and `bench perf --experiment`: the throughput of strategies,
//! measured through the [`Strategy`] trait exactly as experiments run them — each repeat builds
//! the strategy afresh, prepares it and renders the first `samples` samples into a fresh film,
//! and the median and spread over the repeats are reported, never a single timing — with every
//! counter the strategy keeps as a rate (light paths, connections, photons, gathers, mutations
//! … per second).
//!
//! Pixel samples per second are what an equal-time budget buys: the figure to read beside a
//! strategy's error per sample. A progressive strategy starts over at sample 0 each repeat, as
//! the equal-time film of a run does.

use crate::error::{Context, Result};
use crate::experiment::Experiment;
use crate::film::Film;
use crate::scene::Scene;
use crate::strategy::{Registry, Strategy};
use std::time::Instant;

/// One strategy's throughput on one scene.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct StrategyThroughput {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    /// The label the strategy has in its experiment file (the kind for `--strategies`).
    pub label: String,
    /// The strategy kind.
    pub strategy: String,
    /// The strategy's parameters as given (inline TOML; defaults fill the rest).
    pub params: String,
    pub threads: usize,
    /// Seconds of `prepare` (photon maps, chains' first states, B_eye …): median, lowest and
    /// highest over the repeats.
    pub prepare_s: f64,
    pub prepare_s_min: f64,
    pub prepare_s_max: f64,
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

/// Measures each of `kinds` (all of `registry` when empty) with default parameters on `scene`.
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
    let cases = kinds
        .iter()
        .map(|kind| {
            Ok(Case {
                scene,
                label: kind,
                kind,
                params: toml::Table::new(),
                build: registry.get(kind)?.build,
                samples,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    measure_cases(&cases, repeats, &mut |_, _| {})
}

/// Makes `scene`'s image `downscale` times smaller on each side (at least 1 pixel), same
/// camera and field of view: expensive strategies are then timed in seconds, not minutes.
/// Rates per pixel sample keep their meaning; costs per image (photon tracing, chains) do not
/// shrink.
pub fn downscale(scene: &mut Scene, downscale: u32) {
    scene.camera = scene.camera.downscaled(downscale);
}

/// Measures every strategy of an experiment on every scene it runs on, in the file's order
/// (scenes outer): the experiment's labels and parameters; each repeat renders `samples` spp,
/// or when `None` the strategy's largest equal-samples checkpoint (its `spp`; 1 without one),
/// so a suite gives fast strategies enough samples to time and slow ones few. Time budgets are
/// not used. `progress` is told each case before it is measured.
pub fn measure_experiment(
    experiment: &Experiment,
    downscale: u32,
    samples: Option<u32>,
    repeats: u32,
    progress: &mut dyn FnMut(&str, &str),
) -> Result<Vec<StrategyThroughput>> {
    let scenes = experiment
        .scenes
        .iter()
        .map(|file| {
            let mut scene = file.load().context(experiment.file.display())?;
            self::downscale(&mut scene, downscale);
            Ok((file, scene))
        })
        .collect::<Result<Vec<_>>>()?;
    let mut cases = Vec::new();
    for (file, scene) in &scenes {
        for spec in &experiment.strategies {
            if spec.runs_on(file) {
                cases.push(Case {
                    scene,
                    label: &spec.label,
                    kind: &spec.kind,
                    params: spec.params.clone(),
                    build: spec.registration.build,
                    samples: samples.unwrap_or_else(|| spec.spp.iter().copied().max().unwrap_or(1)),
                });
            }
        }
    }
    measure_cases(&cases, repeats, progress)
}

/// What to measure: a strategy built from a label, kind and parameters, on a scene, rendering
/// `samples` spp per repeat.
struct Case<'a> {
    scene: &'a Scene,
    label: &'a str,
    kind: &'a str,
    params: toml::Table,
    build: fn(toml::Table) -> Result<Box<dyn Strategy>>,
    samples: u32,
}

/// One repeat: preparation and render seconds and the counters' advance during rendering.
struct Repeat {
    prepare_s: f64,
    seconds: f64,
    advanced: Vec<(String, f64)>,
}

/// Every case `repeats` times, in rounds (every case once per round, and the machine
/// calibration of [`calibration_rate`] at the start of each), so that each case's
/// spread covers the slow drift of the machine over the whole measurement, not a moment of
/// it. The calibration row comes last.
fn measure_cases(
    cases: &[Case],
    repeats: u32,
    progress: &mut dyn FnMut(&str, &str),
) -> Result<Vec<StrategyThroughput>> {
    let mut runs: Vec<Vec<Repeat>> = cases.iter().map(|_| Vec::new()).collect();
    let mut calibration = Vec::new();
    for _ in 0..repeats.max(1) {
        progress("-", CALIBRATION);
        calibration.push(calibration_rate());
        for (case, runs) in cases.iter().zip(&mut runs) {
            progress(&case.scene.name, case.label);
            runs.push(measure_repeat(case)?);
        }
    }
    let mut rows: Vec<StrategyThroughput> = cases
        .iter()
        .zip(runs)
        .map(|(case, runs)| summarize(case, runs))
        .collect();
    rows.push(calibration_row(calibration));
    Ok(rows)
}

fn measure_repeat(case: &Case) -> Result<Repeat> {
    let (scene, seed) = (case.scene, 0);
    let mut strategy = (case.build)(case.params.clone())?;
    crate::strategy::check_scene(&*strategy, scene)?;
    let start = Instant::now();
    strategy.prepare(scene, seed)?;
    let prepare_s = start.elapsed().as_secs_f64();
    let before = strategy.counters();
    let mut film = Film::new(scene.camera.width, scene.camera.height);
    let start = Instant::now();
    strategy.render_pass(scene, seed, 0..case.samples, &mut film);
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
    Ok(Repeat {
        prepare_s,
        seconds,
        advanced,
    })
}

/// Median and range of the repeats; the counters of the median render.
fn summarize(case: &Case, mut runs: Vec<Repeat>) -> StrategyThroughput {
    let scene = case.scene;
    let mut prepare: Vec<f64> = runs.iter().map(|r| r.prepare_s).collect();
    prepare.sort_by(f64::total_cmp);
    runs.sort_by(|a, b| a.seconds.total_cmp(&b.seconds));
    let pixel_samples = case.samples as f64 * scene.camera.pixel_count() as f64;
    let rate = |r: &Repeat| pixel_samples / r.seconds;
    let median = &runs[runs.len() / 2];
    let counters_per_s = median
        .advanced
        .iter()
        .map(|(name, d)| format!("{name}={:.0}", d / median.seconds))
        .collect::<Vec<_>>()
        .join(";");
    StrategyThroughput {
        scene: scene.name.clone(),
        width: scene.camera.width,
        height: scene.camera.height,
        label: case.label.to_string(),
        strategy: case.kind.to_string(),
        params: inline_toml(&case.params),
        threads: rayon::current_num_threads(),
        prepare_s: prepare[prepare.len() / 2],
        prepare_s_min: prepare[0],
        prepare_s_max: prepare[prepare.len() - 1],
        samples: case.samples,
        repeats: runs.len() as u32,
        pixel_samples_per_s: rate(median),
        pixel_samples_per_s_min: rate(&runs[runs.len() - 1]),
        pixel_samples_per_s_max: rate(&runs[0]),
        counters_per_s,
        cpu: crate::util::cpu_model(),
        git_revision: crate::util::git_revision(),
    }
}

/// The label of the machine calibration row (see [`calibration_rate`]).
pub const CALIBRATION: &str = "machine-calibration";

/// One measurement of the machine calibration, in steps per second: a fixed arithmetic
/// workload (xoshiro256++ uniform floats, square roots and a running sum; 64 tasks on the
/// thread pool). Its rate stands for the machine's clock × cores × thread count, so that a
/// committed baseline can be read on another machine. It does not move with anything in the
/// renderer; it does not capture memory bandwidth or SIMD width either, so cross-machine
/// verdicts are approximate and the table says so.
pub fn calibration_rate() -> f64 {
    use rayon::prelude::*;
    const TASKS: u64 = 64;
    const STEPS: u64 = 1 << 18;
    let start = std::time::Instant::now();
    let sum = (0..TASKS)
        .into_par_iter()
        .map(|t| {
            let mut rng = crate::sampling::Rng::for_task(t, [0, 0, 0]);
            let mut acc = 0.0f32;
            for _ in 0..STEPS {
                let x = rng.uniform();
                acc += (x * x + 0.5).sqrt();
            }
            acc
        })
        .sum::<f32>();
    std::hint::black_box(sum);
    (TASKS * STEPS) as f64 / start.elapsed().as_secs_f64()
}

/// The calibration row of a perf CSV from its measurements (median and range, in the
/// pixel-samples columns).
pub fn calibration_row(mut rates: Vec<f64>) -> StrategyThroughput {
    if rates.is_empty() {
        rates.push(calibration_rate());
    }
    rates.sort_by(f64::total_cmp);
    StrategyThroughput {
        scene: "-".into(),
        width: 0,
        height: 0,
        label: CALIBRATION.into(),
        strategy: "-".into(),
        params: "{}".into(),
        threads: rayon::current_num_threads(),
        prepare_s: 0.0,
        prepare_s_min: 0.0,
        prepare_s_max: 0.0,
        samples: 0,
        repeats: rates.len() as u32,
        pixel_samples_per_s: rates[rates.len() / 2],
        pixel_samples_per_s_min: rates[0],
        pixel_samples_per_s_max: rates[rates.len() - 1],
        counters_per_s: String::new(),
        cpu: crate::util::cpu_model(),
        git_revision: crate::util::git_revision(),
    }
}

/// A parameter table on one line: `{ a = 1, b = { c = 2 } }`, `{}` when empty.
fn inline_toml(table: &toml::Table) -> String {
    let fields: Vec<String> = table
        .iter()
        .map(|(k, v)| match v {
            toml::Value::Table(t) => format!("{k} = {}", inline_toml(t)),
            v => format!("{k} = {v}"),
        })
        .collect();
    if fields.is_empty() {
        "{}".into()
    } else {
        format!("{{ {} }}", fields.join(", "))
    }
}
