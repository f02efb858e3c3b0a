//! Runs an experiment: every cell (scene × strategy × seed), rendered progressively through
//! the equal-samples (`spp`) and equal-time (`seconds`) checkpoints, each checkpoint compared
//! with the scene's reference.
//!
//! Everything that can be refused (the experiment file, scenes, references, strategy
//! parameters) is checked before anything is written.
//!
//! Cells are cached: each completed cell's rows and images go to
//! `<output>/<name>/cells/<hash>/`, written into a hidden temporary directory and renamed into
//! place, so a cell is either complete or absent even when the process is killed. The hash
//! ([`cell_hash`]) covers everything the cell's results depend on; a later run of the same
//! experiment reuses cached cells instead of rendering them again (unless `force`), so a killed
//! run is resumed by running it again. A run renders into a hidden
//! `<output>/<name>/.<run-id>.partial/` directory that is renamed to `<run-id>/` only when
//! complete, so `results/` never shows half a run, and a new run never overwrites an old one.
//!
//! A killed run leaves those temporaries behind. Each holds an [`OWNER`] file naming the host
//! and process that writes it; the next run removes the ones whose process is gone from this
//! host ([`remove_leftovers`]) and leaves alone those of live processes and of other hosts (a
//! shared results directory on a cluster), which a run there removes.
//!
//! Files: this one (run, shards, merge, the plan of cells), [`cell`] (one cell through its
//! checkpoints), [`cache`] (cell hashes and the cache), [`run_dir`] (run directories and their
//! owners), [`images`] (strips and progression grids). Plots, CSV and summaries are the
//! report's ([`crate::report`]).

mod cache;
mod cell;
mod images;
mod progress;
mod run_dir;

pub use cache::cell_hash;
use cache::*;
use cell::*;
use images::*;
use run_dir::*;
pub use run_dir::{OWNER, remove_leftovers};

use super::config::{Experiment, StrategySpec};
use super::reference::{self, Reference};
use crate::error::{Context, Result};
use crate::report::rows::write_csv;
use crate::scene::Scene;
use progress::Progress;
use std::path::{Path, PathBuf};

/// A scene with its reference, loaded and checked.
struct Prepared {
    /// The scene, as the experiment names it.
    file: crate::scene::load::SceneSource,
    scene: Scene,
    reference: Reference,
}

/// What a run did.
#[derive(Debug)]
pub struct Outcome {
    /// The run directory.
    pub dir: PathBuf,
    /// Cells taken from the cache.
    pub cached: usize,
    /// Cells rendered (and cached).
    pub rendered: usize,
}

/// Loads every scene with its reference, refusing bad input before anything is written.
fn prepare_all(exp: &Experiment) -> Result<Vec<Prepared>> {
    let mut prepared = Vec::new();
    for path in &exp.scenes {
        let scene = path.load()?;
        for spec in exp.strategies.iter().filter(|spec| spec.runs_on(path)) {
            crate::strategy::check_scene(&*spec.instantiate()?, &scene)?;
        }
        let reference = reference::load(&exp.references, &scene)?;
        prepared.push(Prepared {
            file: path.clone(),
            scene,
            reference,
        });
    }
    Ok(prepared)
}

/// One shard of an experiment for clusters: `index` of `count` (0 ≤ index < count).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    /// Parses `i/n` (1 ≤ i ≤ n, as job arrays count) into the 0-based shard.
    pub fn parse(text: &str) -> Result<Shard> {
        let bad = || crate::error::Error::new(format!("--shard: expected i/n with 1 <= i <= n, got `{text}`"));
        let (i, n) = text.split_once('/').ok_or_else(bad)?;
        let (i, n): (usize, usize) = (
            i.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if i == 0 || i > n {
            return Err(bad());
        }
        Ok(Shard { index: i - 1, count: n })
    }

    /// Whether the cell at plan position `k` belongs to this shard (round robin, so every
    /// shard gets a similar mix of scenes and strategies).
    fn owns(&self, k: usize) -> bool {
        k % self.count == self.index
    }
}

/// Renders only the cells of `shard` into the cell cache (`<output>/<name>/cells/`) and
/// assembles no run: `bench merge` (or a plain `bench run`) assembles the run once every shard
/// has finished. Returns (cached, rendered) cell counts. Shards must run the same binary: the
/// cell hash includes it.
pub fn run_shard(exp: &Experiment, force: bool, shard: Shard) -> Result<(usize, usize)> {
    let prepared = prepare_all(exp)?;
    let env = Environment {
        run_id: format!("shard-{}-of-{}", shard.index + 1, shard.count),
        threads: rayon::current_num_threads(),
        git_revision: crate::util::git_revision(),
        cpu: crate::util::cpu_model(),
    };
    let cells_dir = exp.output.join(&exp.name).join("cells");
    let owned = |k: usize| shard.owns(k);
    let mine = plan(exp, &prepared).enumerate().filter(|(k, _)| owned(*k)).count();
    let mut progress = Progress::new(mine, to_render(exp, &prepared, force, owned)?);
    let (mut cached, mut rendered) = (0, 0);
    for (k, (p, spec, seed)) in plan(exp, &prepared).enumerate() {
        if !owned(k) {
            continue;
        }
        let name = format!("{} · {} · seed {seed}", p.scene.name, spec.label);
        progress.start_cell(&name);
        let params = param_string(spec)?;
        let hash = cell_hash(&p.scene, &p.reference, spec, &params, seed);
        if !force && load_cell(&cells_dir.join(&hash)).is_some() {
            cached += 1;
            progress.finish_cell(&name, None);
        } else {
            let start = std::time::Instant::now();
            store_cell(&cells_dir, &hash, |tmp| render_cell(exp, p, spec, seed, &env, tmp))?;
            rendered += 1;
            progress.finish_cell(&name, Some(start.elapsed().as_secs_f64()));
        }
    }
    progress.finish();
    Ok((cached, rendered))
}

/// Joins shard outputs into one run: copies the cells found under each of `imports` (other
/// machines' `<output>/<name>/cells/` directories; empty when the shards shared a file
/// system) into this cell cache, refuses if any cell of the plan is still missing, and
/// assembles the run from the cache (rendering nothing).
pub fn merge(exp: &Experiment, imports: &[PathBuf]) -> Result<Outcome> {
    let prepared = prepare_all(exp)?;
    let cells_dir = exp.output.join(&exp.name).join("cells");
    let mut missing = 0;
    for (p, spec, seed) in plan(exp, &prepared) {
        let params = param_string(spec)?;
        let hash = cell_hash(&p.scene, &p.reference, spec, &params, seed);
        let cell = cells_dir.join(&hash);
        if load_cell(&cell).is_some() {
            continue;
        }
        match imports.iter().map(|d| d.join(&hash)).find(|c| load_cell(c).is_some()) {
            Some(source) => copy_cell(&source, &cells_dir, &hash)?,
            None => missing += 1,
        }
    }
    if missing > 0 {
        return Err(crate::error::Error::new(format!(
            "{}: {missing} cell(s) of the plan are in no shard output; run the missing shards (bench run {} --shard i/n) with the same binary, or pass their cells directories",
            exp.file.display(),
            exp.file.display()
        )));
    }
    run(exp, false)
}

/// How many cells of the plan that `owns` (by plan position) are not in the cache (all of them
/// with `force`).
fn to_render(exp: &Experiment, prepared: &[Prepared], force: bool, owns: impl Fn(usize) -> bool) -> Result<usize> {
    let cells_dir = exp.output.join(&exp.name).join("cells");
    let mut n = 0;
    for (k, (p, spec, seed)) in plan(exp, prepared).enumerate() {
        if !owns(k) {
            continue;
        }
        let hash = cell_hash(&p.scene, &p.reference, spec, &param_string(spec)?, seed);
        if force || load_cell(&cells_dir.join(&hash)).is_none() {
            n += 1;
        }
    }
    Ok(n)
}

/// Every cell of the experiment in plan order: scene, strategy, seed.
fn plan<'a>(
    exp: &'a Experiment,
    prepared: &'a [Prepared],
) -> impl Iterator<Item = (&'a Prepared, &'a StrategySpec, u64)> {
    prepared.iter().flat_map(move |p| {
        exp.strategies
            .iter()
            .filter(move |spec| spec.runs_on(&p.file))
            .flat_map(move |spec| exp.seeds.iter().map(move |&seed| (p, spec, seed)))
    })
}

/// Runs `exp` and returns the directory holding its results. Cached cells are reused unless
/// `force`, which renders every cell again and replaces its cache entry.
pub fn run(exp: &Experiment, force: bool) -> Result<Outcome> {
    // Refuse bad input before anything is written.
    let prepared = prepare_all(exp)?;

    let base = exp.output.join(&exp.name);
    let removed = remove_leftovers(&base);
    if removed > 0 {
        eprintln!(
            "{}: removed {removed} temporary directories of killed runs",
            base.display()
        );
    }
    let run_id = new_run_id(&base);
    let partial = base.join(format!(".{run_id}.partial"));
    let final_dir = base.join(&run_id);
    create_owned_dir(&partial, "images")?;
    let result = run_into(exp, &prepared, &run_id, &partial, force).and_then(|counts| {
        let _ = std::fs::remove_file(partial.join(OWNER));
        std::fs::rename(&partial, &final_dir)
            .context(final_dir.display())
            .map(|()| counts)
    });
    if result.is_err() {
        let _ = std::fs::remove_dir_all(&partial);
    }
    result.map(|(cached, rendered)| Outcome {
        dir: final_dir,
        cached,
        rendered,
    })
}

/// Puts the reference of every scene (EXR, sidecar and preview) into `<dir>/references/`, so
/// that a run directory holds everything its errors were measured against (hard links where
/// the file system allows, copies elsewhere).
fn copy_references(exp: &Experiment, prepared: &[Prepared], dir: &Path) -> Result<()> {
    let to = dir.join("references");
    std::fs::create_dir_all(&to).context(to.display())?;
    for p in prepared {
        let exr = reference::exr_path(&exp.references, &p.scene.name);
        for from in [exr.clone(), exr.with_extension("json"), exr.with_extension("png")] {
            let (Some(name), true) = (from.file_name(), from.is_file()) else {
                continue;
            };
            let target = to.join(name);
            if std::fs::hard_link(&from, &target).is_err() {
                std::fs::copy(&from, &target).context(from.display())?;
            }
        }
    }
    Ok(())
}

/// Renders (or takes from the cache) every cell into `dir`; returns (cached, rendered) counts.
fn run_into(exp: &Experiment, prepared: &[Prepared], run_id: &str, dir: &Path, force: bool) -> Result<(usize, usize)> {
    std::fs::write(dir.join("experiment.toml"), &exp.text).context(dir.display())?;
    let mut progress = Progress::new(plan(exp, prepared).count(), to_render(exp, prepared, force, |_| true)?);
    let env = Environment {
        run_id: run_id.to_string(),
        threads: rayon::current_num_threads(),
        git_revision: crate::util::git_revision(),
        cpu: crate::util::cpu_model(),
    };
    let cells_dir = exp.output.join(&exp.name).join("cells");
    let (mut rows, mut cached, mut rendered) = (Vec::new(), 0, 0);
    for p in prepared {
        for spec in exp.strategies.iter().filter(|s| s.runs_on(&p.file)) {
            let params = param_string(spec)?;
            for &seed in &exp.seeds {
                let name = format!("{} · {} · seed {seed}", p.scene.name, spec.label);
                progress.start_cell(&name);
                let hash = cell_hash(&p.scene, &p.reference, spec, &params, seed);
                let cell = cells_dir.join(&hash);
                let start = std::time::Instant::now();
                let mut cell_rows = match load_cell(&cell).filter(|_| !force) {
                    Some(r) => {
                        cached += 1;
                        progress.finish_cell(&name, None);
                        r
                    }
                    None => {
                        rendered += 1;
                        let r = store_cell(&cells_dir, &hash, |tmp| render_cell(exp, p, spec, seed, &env, tmp))?;
                        progress.finish_cell(&name, Some(start.elapsed().as_secs_f64()));
                        r
                    }
                };
                link_images(&cell, &cell_rows, dir)?;
                for r in &mut cell_rows {
                    r.experiment = exp.name.clone();
                    r.run_id = run_id.to_string();
                    // Cells cached before the column existed read it as NaN.
                    r.reference_mse = p.reference.noise_mse();
                }
                rows.extend(cell_rows);
            }
        }
    }
    progress.finish();
    for warning in reference::noise_warnings(&rows) {
        eprintln!("warning: {warning}");
    }
    copy_references(exp, prepared, dir)?;
    write_csv(&rows, &dir.join("metrics.csv"))?;
    crate::report::rows::write_long_csv(&rows, &dir.join("metrics_long.csv"))?;
    write_previews(exp, &rows, dir)?;
    write_strips(exp, prepared, &rows, dir)?;
    crate::report::write_plots(&rows, dir)?;
    let gathers = crate::report::final_gather::comparisons(&rows, dir)?;
    crate::report::final_gather::write_csv(&gathers, dir)?;
    let baseline = exp.baseline.as_deref();
    crate::report::ratios::write_csv(&crate::report::ratios::ratios(&rows, baseline), dir)?;
    crate::report::write_summary(&exp.name, &exp.description, &rows, baseline, &gathers, dir)?;
    crate::report::html::write_index(&rows, &gathers, dir, exp.exposure as f64)?;
    Ok((cached, rendered))
}

#[cfg(test)]
mod tests {
    use super::{CounterClock, utc_stamp};

    #[test]
    fn counters_of_the_second_film_count_its_own_work() {
        let owned = |v: &[(&str, f64)]| v.iter().map(|(n, x)| (n.to_string(), *x)).collect::<Vec<_>>();
        // After prepare: 10 rays traced by prepare, 200 photons stored.
        let clock = CounterClock::new(owned(&[("rays", 10.0), ("photons", 200.0)]));
        // The first film starts right after prepare and renders 50 rays.
        let first = owned(&[("rays", 10.0), ("photons", 200.0)]);
        assert_eq!(
            clock.at(&first, &owned(&[("rays", 60.0), ("photons", 200.0)])),
            "rays=60;photons=200"
        );
        // The second film starts at 60 and renders 30 more: prepare's 10 + its own 30.
        let second = owned(&[("rays", 60.0), ("photons", 200.0)]);
        assert_eq!(
            clock.at(&second, &owned(&[("rays", 90.0), ("photons", 200.0)])),
            "rays=40;photons=200"
        );
        // A counter the strategy starts reporting later is taken as counted from zero.
        assert_eq!(clock.at(&second, &owned(&[("late", 5.0)])), "late=5");
        // A film that did no work records prepare's share only.
        assert_eq!(clock.at(&second, &second), "rays=10;photons=200");
    }

    #[test]
    fn utc_stamp_matches_known_dates() {
        assert_eq!(utc_stamp(0), "1970-01-01T00-00-00Z");
        assert_eq!(utc_stamp(951_782_400), "2000-02-29T00-00-00Z");
        assert_eq!(utc_stamp(1_795_305_600 + 3_661), "2026-11-22T01-01-01Z");
    }
}
