//! Rendering one cell: prepare the strategy (timed by phase), render progressively through
//! the spp checkpoints and the time budgets, and turn each checkpoint into a result row with
//! its images, metrics, counters and provenance.

use super::*;
use crate::error::Result;
use crate::experiment::config::{Experiment, MAX_SPP, StrategySpec};
use crate::experiment::reference::Reference;
use crate::film::{Film, write_exr, write_png};
use crate::metrics;
use crate::metrics::write_error_png;
use crate::report::rows::{BUDGET_SECONDS, BUDGET_SPP, Row, format_counters};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Every parameter of a strategy as `key=value;…`, defaults included.
pub(super) fn param_string(spec: &StrategySpec) -> Result<String> {
    Ok(spec
        .instantiate()?
        .params()
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(";"))
}

/// What every row of a run records about the machine and the run.
pub(super) struct Environment {
    pub(super) run_id: String,
    pub(super) threads: usize,
    pub(super) git_revision: String,
    pub(super) cpu: String,
}

/// One checkpoint's image, written into `dir/images/` (EXR, sRGB PNG and false-colour error
/// PNG), and its row.
pub(super) struct Checkpoint<'a> {
    pub(super) dir: &'a Path,
    pub(super) stem: String,
    pub(super) template: &'a Row,
    pub(super) reference: &'a Reference,
    pub(super) scene: &'a str,
}

impl Checkpoint<'_> {
    pub(super) fn record(&self, film: &Film, spp: u32, prep_s: f64, render_s: f64, counters: String) -> Result<Row> {
        let image = film.image();
        let m = metrics::compare(&image, &self.reference.image).map_err(|e| e.context(self.scene))?;
        let exr = PathBuf::from("images").join(format!("{}.exr", self.stem));
        write_exr(&image, &self.dir.join(&exr))?;
        write_png(&image, &self.dir.join(exr.with_extension("png")), 0.0)?;
        let error_png = PathBuf::from("images").join(format!("{}_error.png", self.stem));
        write_error_png(&image, &self.reference.image, &self.dir.join(error_png))?;
        let mean = image.mean();
        let total_s = prep_s + render_s;
        Ok(Row {
            spp,
            prep_s,
            render_s,
            total_s,
            non_finite: film.non_finite(),
            mse: m.mse,
            rmse: m.rmse,
            rel_mse: m.rel_mse,
            mse_trimmed: m.mse_trimmed,
            rel_mse_trimmed: m.rel_mse_trimmed,
            rms_rel_lum: m.rms_rel_lum,
            rms_rel_lum_excluded: m.rms_rel_lum_excluded,
            flip: m.flip,
            mse_ldr: m.mse_ldr,
            efficiency: metrics::efficiency(m.mse, total_s),
            mean_r: mean.x as f64,
            mean_g: mean.y as f64,
            mean_b: mean.z as f64,
            image: exr.display().to_string(),
            counters,
            ..self.template.clone()
        })
    }
}

/// Renders one cell (scene × strategy × seed) through the strategy's budgets and writes its images into
/// `dir/images/`; returns its rows, equal-samples checkpoints first.
///
/// Equal samples: one progressive render through the `spp` checkpoints. Equal time: the same
/// prepared strategy renders a fresh film in passes of doubling size (1, 2, 4 … samples), each
/// pass capped to what the measured throughput predicts fits in the time left, until
/// preparation + rendering reaches each `seconds` budget; every checkpoint has at least one
/// sample, so a preparation longer than the budget shows as `total_s` above it.
pub(super) fn render_cell(
    exp: &Experiment,
    p: &Prepared,
    spec: &StrategySpec,
    seed: u64,
    env: &Environment,
    dir: &Path,
) -> Result<Vec<Row>> {
    let mut strategy = spec.instantiate()?;
    crate::strategy::check_scene(&*strategy, &p.scene)?;
    let params = param_string(spec)?;
    let start = Instant::now();
    let phases = strategy.prepare(&p.scene, seed)?;
    let prep_s = start.elapsed().as_secs_f64();
    let phases = phases
        .iter()
        .map(|ph| format!("{}={:.6}", ph.name, ph.seconds))
        .collect::<Vec<_>>()
        .join(";");
    let mut template = Row {
        experiment: exp.name.clone(),
        run_id: env.run_id.clone(),
        scene: p.scene.name.clone(),
        scene_hash: p.scene.content_hash.clone(),
        reference_hash: p.reference.hash.clone(),
        reference_spp: p.reference.info.spp,
        strategy: spec.label.clone(),
        kind: strategy.kind().to_string(),
        params,
        seed,
        budget: BUDGET_SPP.to_string(),
        budget_value: 0.0,
        spp: 0,
        width: p.scene.camera.width,
        height: p.scene.camera.height,
        threads: env.threads,
        git_revision: env.git_revision.clone(),
        cpu: env.cpu.clone(),
        prep_s,
        render_s: 0.0,
        total_s: 0.0,
        phases,
        non_finite: 0,
        mse: 0.0,
        rmse: 0.0,
        rel_mse: 0.0,
        mse_trimmed: 0.0,
        rel_mse_trimmed: 0.0,
        rms_rel_lum: 0.0,
        rms_rel_lum_excluded: 0,
        flip: 0.0,
        mse_ldr: 0.0,
        efficiency: 0.0,
        mean_r: 0.0,
        mean_g: 0.0,
        mean_b: 0.0,
        image: String::new(),
        counters: String::new(),
        reference_mse: p.reference.noise_mse(),
    };
    let counters = CounterClock::new(strategy.counters());
    let (width, height) = (p.scene.camera.width, p.scene.camera.height);
    let stem = format!("{}_{}_seed{seed}", p.scene.name, spec.file_stem());
    for figure in strategy.figures(&p.scene, seed) {
        let path = dir.join("images").join(format!("{stem}{}", figure.suffix));
        figure.write_png(&path)?;
    }
    let mut rows = Vec::new();

    // Equal samples: checkpoints of one progressive render.
    let mut film = Film::new(width, height);
    let (mut render_s, mut done) = (0.0, 0u32);
    let film_start = strategy.counters();
    for &spp in &spec.spp {
        let t = Instant::now();
        strategy.render_pass(&p.scene, seed, done..spp, &mut film);
        render_s += t.elapsed().as_secs_f64();
        done = spp;
        template.budget_value = spp as f64;
        let checkpoint = Checkpoint {
            dir,
            stem: format!("{stem}_spp{spp}"),
            template: &template,
            reference: &p.reference,
            scene: &p.scene.name,
        };
        let counted = counters.at(&film_start, &strategy.counters());
        rows.push(checkpoint.record(&film, spp, prep_s, render_s, counted)?);
    }

    // Equal time: doubling passes until each budget.
    template.budget = BUDGET_SECONDS.to_string();
    let mut film = Film::new(width, height);
    let (mut render_s, mut done, mut pass) = (0.0f64, 0u32, 1u32);
    let film_start = strategy.counters();
    for &budget in &spec.seconds {
        while done == 0 || (prep_s + render_s < budget && done < MAX_SPP) {
            let left_s = budget - prep_s - render_s;
            let per_sample_s = if done > 0 { render_s / done as f64 } else { 0.0 };
            let fits = if per_sample_s > 0.0 {
                (left_s / per_sample_s).clamp(1.0, u32::MAX as f64) as u32
            } else {
                u32::MAX
            };
            let n = pass.min(fits).min(MAX_SPP - done).max(1);
            let t = Instant::now();
            strategy.render_pass(&p.scene, seed, done..done + n, &mut film);
            render_s += t.elapsed().as_secs_f64();
            done += n;
            pass = pass.saturating_mul(2);
        }
        template.budget_value = budget;
        let checkpoint = Checkpoint {
            dir,
            stem: format!("{stem}_t{budget}s"),
            template: &template,
            reference: &p.reference,
            scene: &p.scene.name,
        };
        let counted = counters.at(&film_start, &strategy.counters());
        rows.push(checkpoint.record(&film, done, prep_s, render_s, counted)?);
    }
    Ok(rows)
}

/// Attributes a strategy's counters to the render of each film. Counters are cumulative
/// since `prepare` ([`crate::strategy::Strategy::counters`]), and the equal-time film is
/// rendered after the equal-samples one by the same prepared strategy, so a checkpoint records
/// `now − at the film's start + after prepare`: work counted while rendering (zero after
/// prepare) counts only this film's passes, work done by `prepare` is kept (it belongs to every
/// film), and quantities that rendering leaves unchanged (photons stored, bytes) pass through.
/// A counter that is neither (a running ratio) would be misreported: count its numerator and
/// denominator instead.
pub(super) struct CounterClock {
    pub(super) after_prepare: Vec<(String, f64)>,
}

impl CounterClock {
    pub(super) fn new(after_prepare: Vec<(String, f64)>) -> Self {
        Self { after_prepare }
    }

    /// The `counters` column of a checkpoint of the film that started at `film_start`.
    pub(super) fn at(&self, film_start: &[(String, f64)], now: &[(String, f64)]) -> String {
        let value = |list: &[(String, f64)], name: &str| list.iter().find(|(n, _)| n == name).map_or(0.0, |(_, v)| *v);
        let counted: Vec<(String, f64)> = now
            .iter()
            .map(|(name, v)| {
                let start = value(film_start, name);
                let prepared = value(&self.after_prepare, name);
                (name.clone(), v - start + prepared)
            })
            .collect();
        format_counters(&counted)
    }
}
