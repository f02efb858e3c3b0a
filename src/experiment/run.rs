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

use super::config::{Experiment, MAX_SPP, StrategySpec};
use super::reference::{self, Reference};
use crate::error::{Context, Result};
use crate::film::{Film, image_strip, read_exr, write_exr, write_png};
use crate::metrics;
use crate::metrics::write_error_png;
use crate::report::rows::{BUDGET_SECONDS, BUDGET_SPP, Row, format_counters, read_csv, write_csv};
use crate::scene::{Scene, load_scene};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A scene with its reference, loaded and checked.
struct Prepared {
    /// The scene file, as the experiment names it.
    file: PathBuf,
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
        let scene = load_scene(path)?;
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
    let (mut cached, mut rendered) = (0, 0);
    for (k, (p, spec, seed)) in plan(exp, &prepared).enumerate() {
        if !shard.owns(k) {
            continue;
        }
        let params = param_string(spec)?;
        let hash = cell_hash(&p.scene, &p.reference, spec, &params, seed);
        if !force && load_cell(&cells_dir.join(&hash)).is_some() {
            cached += 1;
        } else {
            store_cell(&cells_dir, &hash, |tmp| render_cell(exp, p, spec, seed, &env, tmp))?;
            rendered += 1;
        }
    }
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

/// Copies a complete cell directory into the cache under `hash`, atomically.
fn copy_cell(source: &Path, cells: &Path, hash: &str) -> Result<()> {
    store_cell(cells, hash, |tmp| {
        let rows = read_csv(&source.join("rows.csv"))?;
        for r in &rows {
            for rel in image_files(Path::new(&r.image)) {
                let from = source.join(&rel);
                std::fs::copy(&from, tmp.join(&rel)).context(from.display())?;
            }
        }
        Ok(rows)
    })
    .map(|_| ())
}

/// The files of one checkpoint image: the EXR, its PNG preview and its error map
/// (`x.exr`, `x.png`, `x_error.png`), as paths relative to a cell or run directory.
fn image_files(exr: &Path) -> [PathBuf; 3] {
    let stem = exr
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    [
        exr.to_path_buf(),
        exr.with_extension("png"),
        exr.with_file_name(format!("{stem}_error.png")),
    ]
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

/// Identifies the binary for cell hashes: the package version and a hash of the executable,
/// so that any rebuild with changed code invalidates the cache.
fn binary_id() -> &'static str {
    static ID: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    ID.get_or_init(|| {
        let exe = std::env::current_exe()
            .and_then(std::fs::read)
            .map(|bytes| crate::util::content_hash(&[&bytes]))
            .unwrap_or_else(|_| "unknown".to_string());
        format!("{}+{exe}", env!("CARGO_PKG_VERSION"))
    })
}

/// The content hash of a cell: the strategy's label, kind and every parameter (defaults
/// included), its budgets (its own or the experiment's), the seed, the scene's name and hash, the reference's hash and the
/// binary ([`binary_id`]). The experiment's name, description and other cells do not enter.
pub fn cell_hash(scene: &Scene, reference: &Reference, spec: &StrategySpec, params: &str, seed: u64) -> String {
    let spp = format!("{:?}", spec.spp);
    let seconds = format!("{:?}", spec.seconds.iter().map(|s| s.to_bits()).collect::<Vec<_>>());
    crate::util::content_hash(&[
        b"photon-bench cell v1",
        spec.label.as_bytes(),
        spec.kind.as_bytes(),
        params.as_bytes(),
        spp.as_bytes(),
        seconds.as_bytes(),
        &seed.to_le_bytes(),
        scene.name.as_bytes(),
        scene.content_hash.as_bytes(),
        reference.hash.as_bytes(),
        binary_id().as_bytes(),
    ])
}

/// The rows of a cached cell, or `None` when it is absent or unreadable.
fn load_cell(cell: &Path) -> Option<Vec<Row>> {
    let rows = read_csv(&cell.join("rows.csv")).ok()?;
    rows.iter().all(|r| cell.join(&r.image).exists()).then_some(rows)
}

/// Renders a cell into `<cells>/.tmp-<hash>-<pid>@<host>/` and renames it to `<cells>/<hash>/`.
/// The name itself names the writer, so a process killed between creating the directory and
/// writing its [`OWNER`] file still leaves a temporary the next run can attribute.
fn store_cell(cells: &Path, hash: &str, render: impl FnOnce(&Path) -> Result<Vec<Row>>) -> Result<Vec<Row>> {
    let tmp = cells.join(format!(".tmp-{hash}-{}@{}", std::process::id(), host_name()));
    let _ = std::fs::remove_dir_all(&tmp);
    create_owned_dir(&tmp, "images")?;
    let result = render(&tmp).and_then(|rows| {
        write_csv(&rows, &tmp.join("rows.csv"))?;
        let target = cells.join(hash);
        if target.exists() {
            // Replaced on --force (or written meanwhile by a concurrent run).
            std::fs::remove_dir_all(&target).context(target.display())?;
        }
        let _ = std::fs::remove_file(tmp.join(OWNER));
        std::fs::rename(&tmp, &target).context(target.display())?;
        Ok(rows)
    });
    if result.is_err() {
        let _ = std::fs::remove_dir_all(&tmp);
    }
    result
}

/// The file in a run's temporary directories that names their writer: `<host> <pid>`.
pub const OWNER: &str = ".owner";

/// This machine's name, as the kernel reports it (`unknown` where it cannot be read).
fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .or_else(|_| std::env::var("HOSTNAME"))
        .unwrap_or_else(|_| "unknown".to_string())
}

/// Creates the temporary directory `dir` (and `dir/sub`) with its [`OWNER`] file.
fn create_owned_dir(dir: &Path, sub: &str) -> Result<()> {
    std::fs::create_dir_all(dir.join(sub)).context(dir.display())?;
    let owner = format!("{} {}\n", host_name(), std::process::id());
    std::fs::write(dir.join(OWNER), owner).context(dir.join(OWNER).display())
}

/// The writer `<host> <pid>` a cell temporary's name `.tmp-<hash>-<pid>@<host>` gives.
fn owner_in_name(dir: &Path) -> Option<String> {
    let name = dir.file_name()?.to_str()?.strip_prefix(".tmp-")?;
    let (left, host) = name.split_once('@')?;
    let (_, pid) = left.rsplit_once('-')?;
    Some(format!("{host} {pid}"))
}

/// Is the temporary directory `dir` an orphan: written by a process of this host that no longer
/// runs? The writer is the one its owner file names, else (no file, or an empty one) the one
/// its name names (cell temporaries); with neither (a run directory killed between its creation and its owner
/// file) it is one once a day old. Where processes cannot be looked up (no `/proc`), nothing
/// is.
fn is_orphan(dir: &Path, host: &str) -> bool {
    if !Path::new("/proc/self").exists() {
        return false;
    }
    // An owner file killed while being written is empty: the name decides then.
    let written = std::fs::read_to_string(dir.join(OWNER))
        .ok()
        .filter(|o| !o.trim().is_empty());
    match written.or_else(|| owner_in_name(dir)) {
        Some(owner) => match owner.trim().rsplit_once(' ') {
            Some((h, pid)) => {
                h == host
                    && pid
                        .parse::<u32>()
                        .is_ok_and(|pid| pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists())
            }
            None => false,
        },
        None => std::fs::metadata(dir)
            .and_then(|m| m.modified())
            .is_ok_and(|t| t.elapsed().is_ok_and(|age| age.as_secs() > 24 * 3600)),
    }
}

/// Removes the orphaned temporaries of killed runs under `base` (`.<run-id>.partial/` and
/// `cells/.tmp-*/`, see the module doc); returns how many.
pub fn remove_leftovers(base: &Path) -> usize {
    let host = host_name();
    let mut removed = 0;
    let candidates = |dir: &Path, keep: &dyn Fn(&str) -> bool| -> Vec<PathBuf> {
        std::fs::read_dir(dir)
            .map(|d| {
                d.filter_map(|e| e.ok())
                    .filter(|e| e.file_type().is_ok_and(|t| t.is_dir()))
                    .filter(|e| keep(&e.file_name().to_string_lossy()))
                    .map(|e| e.path())
                    .collect()
            })
            .unwrap_or_default()
    };
    let partial = |n: &str| n.starts_with('.') && n.ends_with(".partial");
    let tmp = |n: &str| n.starts_with(".tmp-");
    for dir in candidates(base, &partial)
        .into_iter()
        .chain(candidates(&base.join("cells"), &tmp))
    {
        if is_orphan(&dir, &host) && std::fs::remove_dir_all(&dir).is_ok() {
            removed += 1;
        }
    }
    removed
}

/// Links (or copies, across file systems) a cell's images into the run directory.
fn link_images(cell: &Path, rows: &[Row], dir: &Path) -> Result<()> {
    let link = |rel: &Path| -> Result<()> {
        let (from, to) = (cell.join(rel), dir.join(rel));
        if std::fs::hard_link(&from, &to).is_err() {
            std::fs::copy(&from, &to).context(from.display())?;
        }
        Ok(())
    };
    for r in rows {
        for rel in image_files(Path::new(&r.image)) {
            link(&rel)?;
        }
    }
    // The cell's other images: photon distribution and Christensen 1999 Fig. 1 figures.
    if let Ok(entries) = std::fs::read_dir(cell.join("images")) {
        for entry in entries.flatten() {
            let rel = Path::new("images").join(entry.file_name());
            if !dir.join(&rel).exists() {
                link(&rel)?;
            }
        }
    }
    Ok(())
}

/// A run id that sorts by time and never collides with an earlier run in `base`.
fn new_run_id(base: &Path) -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let stamp = utc_stamp(secs);
    let mut id = stamp.clone();
    let mut n = 2;
    while base.join(&id).exists() || base.join(format!(".{id}.partial")).exists() {
        id = format!("{stamp}-{n}");
        n += 1;
    }
    id
}

/// `YYYY-MM-DDTHH-MM-SSZ` for seconds since the Unix epoch (civil-from-days, Hinnant 2013).
fn utc_stamp(secs: u64) -> String {
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}-{:02}-{:02}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

/// Renders (or takes from the cache) every cell into `dir`; returns (cached, rendered) counts.
fn run_into(exp: &Experiment, prepared: &[Prepared], run_id: &str, dir: &Path, force: bool) -> Result<(usize, usize)> {
    std::fs::write(dir.join("experiment.toml"), &exp.text).context(dir.display())?;
    let cells = plan(exp, prepared).count();
    let bar = ProgressBar::new(cells as u64).with_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
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
                bar.set_message(format!("{} · {} · seed {seed}", p.scene.name, spec.label));
                let hash = cell_hash(&p.scene, &p.reference, spec, &params, seed);
                let cell = cells_dir.join(&hash);
                let mut cell_rows = match load_cell(&cell).filter(|_| !force) {
                    Some(r) => {
                        cached += 1;
                        r
                    }
                    None => {
                        rendered += 1;
                        store_cell(&cells_dir, &hash, |tmp| render_cell(exp, p, spec, seed, &env, tmp))?
                    }
                };
                link_images(&cell, &cell_rows, dir)?;
                for r in &mut cell_rows {
                    r.experiment = exp.name.clone();
                    r.run_id = run_id.to_string();
                }
                rows.extend(cell_rows);
                bar.inc(1);
            }
        }
    }
    bar.finish_and_clear();
    write_csv(&rows, &dir.join("metrics.csv"))?;
    write_strips(exp, prepared, &rows, dir)?;
    crate::report::write_plots(&rows, dir)?;
    let gathers = crate::report::final_gather::comparisons(&rows, dir)?;
    crate::report::final_gather::write_csv(&gathers, dir)?;
    crate::report::ratios::write_csv(&crate::report::ratios::ratios(&rows), dir)?;
    crate::report::write_summary(&exp.name, &exp.description, &rows, &gathers, dir)?;
    crate::report::html::write_index(&rows, &gathers, dir)?;
    Ok((cached, rendered))
}

/// Per scene, at the largest spp checkpoint and at the largest time budget: the first seed's
/// image of every strategy side by side, then the reference ([`crate::report::html::strip_path`]).
fn write_strips(exp: &Experiment, prepared: &[Prepared], rows: &[Row], dir: &Path) -> Result<()> {
    let Some(&seed) = exp.seeds.first() else { return Ok(()) };
    let checkpoints = [
        (BUDGET_SPP, exp.spp.last().map(|&s| s as f64)),
        (BUDGET_SECONDS, exp.seconds.last().copied()),
    ];
    for p in prepared {
        for (budget, value) in checkpoints {
            let Some(value) = value else { continue };
            let mut images = Vec::new();
            for spec in &exp.strategies {
                let row = rows.iter().find(|r| {
                    r.scene == p.scene.name
                        && r.strategy == spec.label
                        && r.seed == seed
                        && r.budget == budget
                        && r.budget_value == value
                });
                if let Some(r) = row {
                    images.push(read_exr(&dir.join(&r.image))?);
                }
            }
            let mut all: Vec<&crate::film::Image> = images.iter().collect();
            all.push(&p.reference.image);
            let strip = image_strip(&all, 2);
            let path = dir.join(crate::report::html::strip_path(&p.scene.name, budget, value));
            write_png(&strip, &path, 0.0)?;
        }
        write_progression(exp, p, rows, seed, dir)?;
    }
    Ok(())
}

/// The equal-spp progression of one scene ([`crate::report::html::progression_path`]), when the
/// experiment has two spp checkpoints or more. A strategy without some checkpoint leaves that
/// place black.
fn write_progression(exp: &Experiment, p: &Prepared, rows: &[Row], seed: u64, dir: &Path) -> Result<()> {
    if exp.spp.len() < 2 {
        return Ok(());
    }
    let (w, h) = (p.reference.image.width, p.reference.image.height);
    let blank = crate::film::Image::new(w, h);
    let mut images: Vec<Vec<crate::film::Image>> = Vec::new();
    for spec in exp
        .strategies
        .iter()
        .filter(|s| s.runs_on(&p.file) && !s.spp.is_empty())
    {
        let mut row = Vec::new();
        for &spp in &exp.spp {
            let found = rows.iter().find(|r| {
                r.scene == p.scene.name
                    && r.strategy == spec.label
                    && r.seed == seed
                    && r.budget == BUDGET_SPP
                    && r.budget_value == spp as f64
            });
            row.push(match found {
                Some(r) => read_exr(&dir.join(&r.image))?,
                None => blank.clone(),
            });
        }
        images.push(row);
    }
    if images.is_empty() {
        return Ok(());
    }
    images.push(vec![p.reference.image.clone()]);
    let grid_rows: Vec<Vec<&crate::film::Image>> = images.iter().map(|r| r.iter().collect()).collect();
    let grid = crate::film::image_grid(&grid_rows, 2);
    write_png(
        &grid,
        &dir.join(crate::report::html::progression_path(&p.scene.name)),
        0.0,
    )
}

/// Every parameter of a strategy as `key=value;…`, defaults included.
fn param_string(spec: &StrategySpec) -> Result<String> {
    Ok(spec
        .instantiate()?
        .params()
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(";"))
}

/// What every row of a run records about the machine and the run.
struct Environment {
    run_id: String,
    threads: usize,
    git_revision: String,
    cpu: String,
}

/// One checkpoint's image, written into `dir/images/` (EXR, sRGB PNG and false-colour error
/// PNG), and its row.
struct Checkpoint<'a> {
    dir: &'a Path,
    stem: String,
    template: &'a Row,
    reference: &'a Reference,
    scene: &'a str,
}

impl Checkpoint<'_> {
    fn record(&self, film: &Film, spp: u32, prep_s: f64, render_s: f64, counters: String) -> Result<Row> {
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
fn render_cell(
    exp: &Experiment,
    p: &Prepared,
    spec: &StrategySpec,
    seed: u64,
    env: &Environment,
    dir: &Path,
) -> Result<Vec<Row>> {
    let mut strategy = spec.instantiate()?;
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
struct CounterClock {
    after_prepare: Vec<(String, f64)>,
}

impl CounterClock {
    fn new(after_prepare: Vec<(String, f64)>) -> Self {
        Self { after_prepare }
    }

    /// The `counters` column of a checkpoint of the film that started at `film_start`.
    fn at(&self, film_start: &[(String, f64)], now: &[(String, f64)]) -> String {
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
