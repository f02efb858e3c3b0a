//! `bench`: the command line of photon-bench. Parsing and dispatch only; the work lives in the
//! library. Every failure prints one line `error: …` and exits with status 2.

use clap::{Parser, Subcommand};
use photon_bench::error::{Error, Result};
use photon_bench::experiment::{self, Experiment, reference};
use photon_bench::light::{LightSelection, SphereSampling};
use photon_bench::perf::PERF_PHOTONS;
use photon_bench::strategy::path::{BsdfSampling, Direct, PathParams, Roulette};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "bench",
    version = concat!(env!("CARGO_PKG_VERSION"), " (", env!("PHOTON_BENCH_GIT_REVISION"), ")"),
    about = "Benchmark Monte Carlo light-transport strategies against reference images"
)]
struct Cli {
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(short = 'j', long, global = true)]
    threads: Option<usize>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run an experiment file: every scene × strategy × seed × spp, compared with references.
    Run {
        /// The experiment file, e.g. experiments/cornell.toml.
        experiment: PathBuf,
        /// Render every cell again instead of reusing cached cells (and replace the cache).
        #[arg(long)]
        force: bool,
        /// Render only shard i of n (1 <= i <= n, e.g. $SLURM_ARRAY_TASK_ID/16) into the cell
        /// cache; assemble the run afterwards with `bench merge`.
        #[arg(long)]
        shard: Option<String>,
    },
    /// Join shard outputs into one run: import cells, check that none is missing, assemble.
    Merge {
        /// The experiment file the shards ran.
        experiment: PathBuf,
        /// Other machines' `results/<name>/cells` directories to import (none when the shards
        /// shared a file system).
        cells: Vec<PathBuf>,
    },
    /// Render a converged reference image of a scene with `path` into references/.
    Reference {
        /// The scene file, e.g. scenes/cornell-empty.toml.
        scene: PathBuf,
        /// A Mitsuba scene parameter, NAME=VALUE (repeatable): `$NAME` in the scene stands for
        /// VALUE over its <default> (as `mitsuba -D`); the scene is then named
        /// <stem>-NAME-VALUE, and so is its reference.
        #[arg(long = "param", value_name = "NAME=VALUE")]
        params: Vec<String>,
        /// Samples per pixel.
        #[arg(long)]
        spp: u32,
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Output directory.
        #[arg(long, default_value = "references")]
        out: PathBuf,
        #[arg(long, default_value_t = PathParams::default().max_depth)]
        max_depth: u32,
        #[arg(long, default_value_t = PathParams::default().rr_depth)]
        rr_depth: u32,
        /// throughput | albedo (what Russian roulette's survival probability follows)
        #[arg(long, default_value = "throughput")]
        roulette: String,
        /// mis | nee | bsdf
        #[arg(long, default_value = "mis")]
        direct: String,
        /// importance | uniform (uniform: no importance sampling, as Jensen 1995's reference)
        #[arg(long, default_value = "importance")]
        bsdf_sampling: String,
        /// power | local | uniform (how next-event estimation picks a light)
        #[arg(long, default_value = "power")]
        light_selection: String,
        /// area | cone (how next-event estimation samples sphere lights)
        #[arg(long, default_value = "area")]
        sphere_light_sampling: String,
        /// Replace an existing reference.
        #[arg(long)]
        force: bool,
    },
    /// Render one image of a scene with any strategy: an EXR, a PNG preview and its provenance (.json).
    Render {
        /// The scene file, e.g. scenes/veach-mis.xml.
        scene: PathBuf,
        /// The strategy kind (`bench list` shows every kind and parameter).
        #[arg(long)]
        strategy: String,
        /// A strategy parameter, NAME=VALUE (repeatable), as in an experiment's [[strategy]]
        /// table: VALUE is a TOML value, or a string (`--set mode=bpt`).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// A Mitsuba scene parameter, NAME=VALUE (repeatable; see `bench reference`).
        #[arg(long = "param", value_name = "NAME=VALUE")]
        params: Vec<String>,
        /// Samples per pixel.
        #[arg(long)]
        spp: u32,
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// The EXR to write (a PNG preview and its provenance, .json, go beside it).
        #[arg(long)]
        out: PathBuf,
        /// Replace an existing image.
        #[arg(long)]
        force: bool,
    },
    /// Measure throughput: `path` paths/s, rays/s and raw BVH closest-hit rays/s; photons/s,
    /// k-NN queries/s and guided-pdf builds/s.
    Perf {
        /// The scene (default: Mitsuba 3's Cornell box at 256×256, the peer's benchmark scene).
        #[arg(long, default_value = "scenes/cornell-box.toml")]
        scene: PathBuf,
        /// A Mitsuba scene parameter of --scene, NAME=VALUE (repeatable; see `bench reference`).
        #[arg(long = "param", value_name = "NAME=VALUE")]
        params: Vec<String>,
        #[arg(long, default_value_t = 16)]
        spp: u32,
        /// Scattering events; 4 equals Mitsuba's max_depth = 5.
        #[arg(long, default_value_t = 4)]
        max_depth: u32,
        /// Also append the figures to this CSV file.
        #[arg(long)]
        csv: Option<PathBuf>,
        /// Instead: photon-map scale series on the scene (BVH build; photons traced/s; kd-tree
        /// build time and k-NN queries/s for N = 25 000 … 1 600 000 global photons).
        #[arg(long)]
        photon_scale: bool,
        /// Instead: the throughput of these strategy kinds (comma-separated; every registered
        /// kind when given alone) with default parameters, through the strategy trait:
        /// preparation seconds, pixel samples/s (median and range of --repeats renders of
        /// --samples spp) and every counter as a rate. With --csv, rows of their own columns.
        #[arg(long, num_args = 0.., value_delimiter = ',')]
        strategies: Option<Vec<String>>,
        /// Instead: the throughput of every strategy of this experiment file (labels and
        /// parameters as written) on each of its scenes, as --strategies measures it, plus a
        /// machine calibration row; its budgets are not used. The perf suite is
        /// experiments/perf.toml; compare two such --csv files with `bench compare --perf`.
        #[arg(long, conflicts_with_all = ["strategies", "photon_scale"])]
        experiment: Option<PathBuf>,
        /// With --strategies or --experiment: divide each scene's image width and height by
        /// this (same camera and field of view), so that costly strategies time in seconds.
        #[arg(long, default_value_t = 1)]
        downscale: u32,
        /// Samples per pixel of each timed render of --strategies (default 1) or --experiment
        /// (default: each strategy's largest `spp` checkpoint).
        #[arg(long)]
        samples: Option<u32>,
        /// Timed renders per strategy of --strategies (median and range are reported).
        #[arg(long, default_value_t = 5)]
        repeats: u32,
    },
    /// Measure each photon-map strategy's map where its final gather reads it: RMS relative
    /// error against path-traced radiance at gather-ray hits, for every scene, strategy and
    /// seed of an experiment (a CSV table on stdout; nothing is written to results/).
    MapError {
        /// The experiment file, e.g. experiments/mps05.toml.
        experiment: PathBuf,
        /// Gather-ray hits to probe per scene.
        #[arg(long, default_value_t = 2000)]
        probes: usize,
        /// Path-traced samples per probe for its reference radiance.
        #[arg(long, default_value_t = 1024)]
        probe_spp: u32,
        /// Seed of the probes (the strategies use the experiment's seeds).
        #[arg(long, default_value_t = 0)]
        probe_seed: u64,
    },
    /// Redraw every plot of a run directory from its metrics.csv alone.
    Plot {
        /// A run directory, e.g. results/cornell/<run-id>.
        run: PathBuf,
        /// A metric to plot (repeatable): mse, rmse, rel_mse, mse_trimmed, rel_mse_trimmed,
        /// rms_rel_lum, flip, mse_ldr. Default: mse, rel_mse and flip.
        #[arg(long = "metric", value_name = "METRIC")]
        metrics: Vec<String>,
    },
    /// Compare a candidate run with a baseline run: exit status 1 on a significant error
    /// regression (with --perf: a slowdown beyond the measured noise), 0 otherwise, 2 on bad
    /// input.
    Compare {
        /// The baseline run directory, e.g. results/baseline (with --perf: a perf CSV, e.g.
        /// results/baseline/perf.csv).
        baseline: PathBuf,
        /// The candidate run directory, e.g. results/ci/<run-id> (with --perf: a perf CSV).
        candidate: PathBuf,
        /// Compare speed: two CSV files of `bench perf --experiment … --csv`.
        #[arg(long)]
        perf: bool,
    },
    /// List the strategies with every parameter's default (as TOML an experiment file takes),
    /// range and meaning, and the shipped scenes.
    List {
        /// Only this strategy kind.
        kind: Option<String>,
        /// The parameter reference as Markdown (docs/strategies.md) instead.
        #[arg(long)]
        markdown: bool,
    },
    /// Write a scene as an equivalent Mitsuba 3 XML scene (for cross-checking with Mitsuba 3).
    ExportMitsuba {
        /// The scene file, e.g. scenes/cornell-spheres.toml.
        scene: PathBuf,
        /// The XML file to write (default: <scene file stem>.xml in the current directory).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
}

fn main() -> ExitCode {
    refuse_a_processor_without_the_build_target();
    cli_main()
}

/// Parses the command line and runs it. Kept out of `main` so that nothing compiled for the
/// build's target (AVX instructions, [`refuse_a_processor_without_the_build_target`]) runs
/// before the processor check.
#[inline(never)]
fn cli_main() -> ExitCode {
    // Usage errors keep the one-line `error: …` / exit 2 promise; help and version print as usual.
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e)
            if matches!(
                e.kind(),
                clap::error::ErrorKind::DisplayHelp | clap::error::ErrorKind::DisplayVersion
            ) =>
        {
            e.exit()
        }
        Err(e) => {
            eprintln!("error: {}", one_line_usage_error(&e.to_string(), &subcommand_named()));
            return ExitCode::from(2);
        }
    };
    match run(cli) {
        Ok(Status::Success) => ExitCode::SUCCESS,
        Ok(Status::Regression) => ExitCode::from(1),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

/// clap's usage error on one line, detail kept: the message, what it lists (missing arguments,
/// valid values), its tips (`a similar subcommand exists: 'run'`), and the help of the
/// subcommand the usage line names.
fn one_line_usage_error(text: &str, subcommand: &Option<String>) -> String {
    let mut lines = text.lines().map(str::trim).filter(|l| !l.is_empty());
    let mut message = lines
        .next()
        .unwrap_or("invalid arguments")
        .trim_start_matches("error: ")
        .to_string();
    let mut details = Vec::new();
    let mut help = match subcommand {
        Some(name) => format!("bench {name} --help"),
        None => "bench --help".to_string(),
    };
    for line in lines {
        if let Some(usage) = line.strip_prefix("Usage: ") {
            let words: Vec<&str> = usage
                .split_whitespace()
                .take_while(|w| !w.starts_with(['<', '[', '-']))
                .collect();
            help = format!("{} --help", words.join(" "));
        } else if !line.starts_with("For more information") {
            details.push(line.to_string());
        }
    }
    if !details.is_empty() {
        let joiner = if message.ends_with(':') { " " } else { "; " };
        message = format!("{message}{joiner}{}", details.join(", "));
    }
    format!("{message} (see `{help}`)")
}

/// The subcommand the command line names, if any (for the help a usage error points to).
fn subcommand_named() -> Option<String> {
    use clap::CommandFactory;
    let cli = Cli::command();
    let names: Vec<String> = cli.get_subcommands().map(|c| c.get_name().to_string()).collect();
    std::env::args().skip(1).find(|a| names.contains(a))
}

/// How a command that did not fail ended.
enum Status {
    Success,
    /// `bench compare` found a regression.
    Regression,
}

fn run(cli: Cli) -> Result<Status> {
    if let Some(n) = cli.threads {
        if n == 0 || n > 4096 {
            return Err(Error::new(format!("--threads: expected 1..=4096, got {n}")));
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .map_err(|e| Error::new(e.to_string()))?;
    }
    run_command(cli.command)
}

fn run_command(command: Command) -> Result<Status> {
    match command {
        Command::Compare {
            baseline,
            candidate,
            perf: true,
        } => {
            use photon_bench::perf::compare;
            let (base, cand) = (compare::read_csv(&baseline)?, compare::read_csv(&candidate)?);
            let comparison = compare::compare(&base, &cand)
                .map_err(|e| e.context(format!("{} vs {}", baseline.display(), candidate.display())))?;
            print!("{}", compare::table(&comparison));
            Ok(if comparison.slowdowns() > 0 {
                Status::Regression
            } else {
                Status::Success
            })
        }
        Command::Compare {
            baseline,
            candidate,
            perf: false,
        } => {
            let read = |dir: &PathBuf| {
                let csv = dir.join("metrics.csv");
                if !csv.is_file() {
                    return Err(Error::new(format!(
                        "{}: no metrics.csv; expected a run directory",
                        dir.display()
                    )));
                }
                photon_bench::report::rows::read_csv(&csv)
            };
            let (base, cand) = (read(&baseline)?, read(&candidate)?);
            let comparison = photon_bench::report::compare::compare(&base, &cand)
                .map_err(|e| e.context(format!("{} vs {}", baseline.display(), candidate.display())))?;
            print!("{}", photon_bench::report::compare::table(&comparison));
            Ok(if comparison.regressions() > 0 {
                Status::Regression
            } else {
                Status::Success
            })
        }
        Command::Run {
            experiment,
            force,
            shard: Some(shard),
        } => {
            let shard = experiment::Shard::parse(&shard)?;
            let exp = Experiment::load(&experiment)?;
            let (cached, rendered) = experiment::run_shard(&exp, force, shard)?;
            eprintln!(
                "shard {}/{}: {cached} cells cached, {rendered} rendered",
                shard.index + 1,
                shard.count
            );
            Ok(Status::Success)
        }
        Command::Merge { experiment, cells } => {
            let exp = Experiment::load(&experiment)?;
            let outcome = experiment::merge(&exp, &cells)?;
            println!("{}", outcome.dir.display());
            Ok(Status::Success)
        }
        Command::Run {
            experiment,
            force,
            shard: None,
        } => {
            let exp = Experiment::load(&experiment)?;
            let outcome = experiment::run(&exp, force)?;
            eprintln!("cells: {} cached, {} rendered", outcome.cached, outcome.rendered);
            println!("{}", outcome.dir.display());
            Ok(Status::Success)
        }
        Command::Reference {
            scene,
            params: scene_params,
            spp,
            seed,
            out,
            max_depth,
            rr_depth,
            roulette,
            direct,
            bsdf_sampling,
            light_selection,
            sphere_light_sampling,
            force,
        } => {
            if spp == 0 || spp > 1 << 24 {
                return Err(Error::new(format!("--spp: expected 1..={}, got {spp}", 1 << 24)));
            }
            let params = PathParams {
                max_depth,
                rr_depth,
                direct: parse_enum::<Direct>("--direct", &direct)?,
                bsdf_sampling: parse_enum::<BsdfSampling>("--bsdf-sampling", &bsdf_sampling)?,
                roulette: parse_enum::<Roulette>("--roulette", &roulette)?,
                light_selection: parse_enum::<LightSelection>("--light-selection", &light_selection)?,
                sphere_light_sampling: parse_enum::<SphereSampling>("--sphere-light-sampling", &sphere_light_sampling)?,
            };
            let scene = scene_source(scene, &scene_params)?.load()?;
            let existing = reference::exr_path(&out, &scene.name);
            if existing.exists() && !force {
                return Err(Error::new(format!(
                    "{}: a reference exists already; pass --force to replace it",
                    existing.display()
                )));
            }
            let bar = indicatif::ProgressBar::new(spp as u64);
            let exr = reference::make(&scene, &out, spp, seed, params, |done| bar.set_position(done as u64))?;
            bar.finish_and_clear();
            println!("{}", exr.display());
            Ok(Status::Success)
        }
        Command::Render {
            scene,
            strategy,
            set,
            params: scene_params,
            spp,
            seed,
            out,
            force,
        } => {
            if spp == 0 || spp > 1 << 24 {
                return Err(Error::new(format!("--spp: expected 1..={}, got {spp}", 1 << 24)));
            }
            if out.extension().and_then(|e| e.to_str()) != Some("exr") {
                return Err(Error::new(format!(
                    "--out: expected a file name ending in .exr, got {}",
                    out.display()
                )));
            }
            if out.exists() && !force {
                return Err(Error::new(format!(
                    "{}: exists already; pass --force to replace it",
                    out.display()
                )));
            }
            let params = experiment::render::params_from_args(&set)?;
            let scene = scene_source(scene, &scene_params)?.load()?;
            let strategy = experiment::render::prepare(&scene, &strategy, params, seed)?;
            let bar = indicatif::ProgressBar::new(spp as u64);
            let exr = experiment::render::render(&scene, &*strategy, spp, seed, &out, |done| {
                bar.set_position(done as u64)
            })?;
            bar.finish_and_clear();
            println!("{}", exr.display());
            Ok(Status::Success)
        }
        Command::Perf {
            scene,
            params: scene_params,
            spp,
            max_depth,
            csv,
            photon_scale,
            strategies,
            experiment,
            downscale,
            samples,
            repeats,
        } => {
            if downscale == 0 || downscale > 1 << 12 {
                return Err(Error::new(format!("--downscale: expected 1..=4096, got {downscale}")));
            }
            if spp == 0 || spp > 1 << 16 {
                return Err(Error::new(format!("--spp: expected 1..={}, got {spp}", 1 << 16)));
            }
            if let Some(samples @ (0 | 65537..)) = samples {
                return Err(Error::new(format!(
                    "--samples: expected 1..={}, got {samples}",
                    1 << 16
                )));
            }
            if repeats == 0 || repeats > 1000 {
                return Err(Error::new(format!("--repeats: expected 1..=1000, got {repeats}")));
            }
            if let Some(file) = experiment {
                let exp = Experiment::load(&file)?;
                let bar = indicatif::ProgressBar::new_spinner();
                let rows =
                    photon_bench::perf::measure_experiment(&exp, downscale, samples, repeats, &mut |scene, label| {
                        bar.set_message(format!("{scene} / {label}"))
                    })?;
                bar.finish_and_clear();
                print_throughputs(&rows, repeats);
                if let Some(path) = csv {
                    photon_bench::perf::append_csv(&rows, &path)?;
                }
                return Ok(Status::Success);
            }
            let mut scene = scene_source(scene, &scene_params)?.load()?;
            if let Some(kinds) = strategies {
                photon_bench::perf::strategies::downscale(&mut scene, downscale);
                let registry = photon_bench::strategy::Registry::builtin();
                for kind in &kinds {
                    registry
                        .get(kind)
                        .map_err(|e| Error::new(format!("--strategies: {e}")))?;
                }
                let rows =
                    photon_bench::perf::measure_strategies(&scene, &registry, &kinds, samples.unwrap_or(1), repeats)?;
                print_throughputs(&rows, repeats);
                if let Some(path) = csv {
                    photon_bench::perf::append_csv(&rows, &path)?;
                }
                return Ok(Status::Success);
            }
            if photon_scale {
                let sizes = [25_000, 50_000, 100_000, 200_000, 400_000, 500_000, 800_000, 1_600_000];
                let points = photon_bench::perf::measure_photon_scale(&scene, &sizes, 100_000);
                let Some(first) = points.first() else {
                    return Err(Error::new(format!("{}: no photon stored", scene.source.display())));
                };
                println!(
                    "{}: {} primitives, BVH build {:.3} s; photons traced {:.0}/s emitted, {:.0}/s stored; \
                     {} threads ({}), git {}",
                    first.scene,
                    first.primitives,
                    first.bvh_build_s,
                    first.photons_emitted_per_s,
                    first.photons_stored_per_s,
                    first.threads,
                    first.cpu,
                    first.git_revision
                );
                println!(
                    "  {:>9}  {:>13}  {:>16}  {:>14}",
                    "N", "kd build s", "ns / (N log2 N)", "k-NN q/s (50)"
                );
                for p in &points {
                    println!(
                        "  {:>9}  {:>13.4}  {:>16.2}  {:>14.0}",
                        p.photons, p.kdtree_build_s, p.kdtree_build_ns_per_n_log2_n, p.knn_queries_per_s
                    );
                }
                if let Some(path) = csv {
                    photon_bench::perf::append_csv(&points, &path)?;
                }
                return Ok(Status::Success);
            }
            // No Russian roulette, like Mitsuba's path integrator below its rr_depth.
            let params = PathParams {
                max_depth,
                rr_depth: max_depth,
                ..PathParams::default()
            };
            let r = photon_bench::perf::measure_path(&scene, &params, spp);
            println!(
                "{} {}x{} spp {} max_depth {} on {} threads ({}), git {}",
                r.scene, r.width, r.height, r.spp, r.max_depth, r.threads, r.cpu, r.git_revision
            );
            println!("  paths/s            {:>12.0}", r.paths_per_s);
            println!(
                "  rays/s             {:>12.0}  ({} closest + {} shadow)",
                r.rays_per_s, r.closest_rays, r.shadow_rays
            );
            println!(
                "  raw closest-hit/s  {:>12.0}  (BVH only, same rays)",
                r.raw_closest_rays_per_s
            );
            println!(
                "  photons/s          {:>12.0}  ({} stored of {PERF_PHOTONS} emitted)",
                r.photons_per_s, r.photons_stored
            );
            println!(
                "  k-NN queries/s     {:>12.0}  (k = 50, global map)",
                r.knn_queries_per_s
            );
            println!(
                "  guided pdfs/s      {:>12.0}  (per-vertex pdf as photon_guided builds it: k = 50 + 4x16 grid)",
                r.guided_pdfs_per_s
            );
            println!(
                "  gather rays/s      {:>12.0}  (photon_map final gather, precomputed irradiance)",
                r.gather_rays_per_s
            );
            println!(
                "  MH steps/s         bd {:.0}  pm {:.0}  cp {:.0}  lp {:.0}  ls {:.0}  up {:.0}  mc {:.0}  (each proposal alone)",
                r.bd_mutations_per_s,
                r.pm_mutations_per_s,
                r.cp_mutations_per_s,
                r.lp_mutations_per_s,
                r.ls_mutations_per_s,
                r.up_mutations_per_s,
                r.mc_mutations_per_s
            );
            // Issue 21's measure: time per stored photon of MPS over photon tracing's.
            let traced_stored_per_s = r.photons_per_s * r.photons_stored as f64 / PERF_PHOTONS as f64;
            println!(
                "  MPS photons/s      {:>12.0}  (stored per second of Metropolis sampling; {:.1}x photon tracing's time per stored photon)",
                r.mps_photons_per_s,
                traced_stored_per_s / r.mps_photons_per_s
            );
            println!(
                "    paper's power    {:>12.0}  (the chain alone, photon_power = \"paper\"; {:.1}x)",
                r.mps_paper_photons_per_s,
                traced_stored_per_s / r.mps_paper_photons_per_s
            );
            if let Some(path) = csv {
                photon_bench::perf::append_csv(std::slice::from_ref(&r), &path)?;
            }
            Ok(Status::Success)
        }
        Command::Plot { run, metrics } => {
            photon_bench::report::redraw(&run, &metrics)?;
            println!("{}", run.join("plots").display());
            Ok(Status::Success)
        }
        Command::ExportMitsuba { scene, output } => {
            let output = output.unwrap_or_else(|| {
                let stem = scene
                    .file_stem()
                    .map(|s| s.to_os_string())
                    .unwrap_or_else(|| "scene".into());
                PathBuf::from(stem).with_extension("xml")
            });
            if output == scene {
                return Err(Error::new(format!(
                    "{}: refusing to overwrite the scene being exported; pass --output",
                    output.display()
                )));
            }
            for w in photon_bench::scene::export::export_file(&scene, &output)? {
                eprintln!("warning: {w}");
            }
            println!("{}", output.display());
            Ok(Status::Success)
        }
        Command::MapError {
            experiment,
            probes,
            probe_spp,
            probe_seed,
        } => {
            if !(1..=1_000_000).contains(&probes) {
                return Err(Error::new(format!("--probes: expected 1..=1000000, got {probes}")));
            }
            if !(2..=1 << 20).contains(&probe_spp) {
                return Err(Error::new(format!(
                    "--probe-spp: expected 2..={}, got {probe_spp}",
                    1 << 20
                )));
            }
            let exp = Experiment::load(&experiment)?;
            experiment::map_error::run(&exp, probes, probe_spp, probe_seed, &mut std::io::stdout().lock())?;
            Ok(Status::Success)
        }
        Command::List { kind, markdown } => {
            let registry = photon_bench::strategy::Registry::builtin();
            if markdown {
                print!("{}", photon_bench::strategy::registry::reference_markdown(&registry));
                return Ok(Status::Success);
            }
            if let Some(kind) = kind {
                print!("{}", registry.get(&kind)?.toml_listing());
                return Ok(Status::Success);
            }
            println!("# strategies: each table below is valid in an experiment file, with every default");
            for r in registry.iter() {
                println!("\n{}", r.toml_listing());
            }
            println!("# scenes (scenes/*.toml, scenes/*.xml):");
            let mut names: Vec<String> = std::fs::read_dir("scenes")
                .map(|d| {
                    d.filter_map(|e| e.ok())
                        .map(|e| e.path())
                        .filter(|p| p.extension().is_some_and(|x| x == "toml" || x == "xml"))
                        .map(|p| p.display().to_string())
                        .collect()
                })
                .unwrap_or_default();
            names.sort();
            for n in names {
                println!("#   {n}");
            }
            Ok(Status::Success)
        }
    }
}

/// Parses a snake_case enum value the way experiment files spell it.
fn parse_enum<T: serde::de::DeserializeOwned>(flag: &str, value: &str) -> Result<T> {
    T::deserialize(toml::Value::String(value.to_string())).map_err(|e| Error::new(format!("{flag}: {}", e.message())))
}

/// The table of `bench perf --strategies` / `--experiment`: one line per case, grouped by scene.
fn print_throughputs(rows: &[photon_bench::perf::StrategyThroughput], repeats: u32) {
    let Some(first) = rows.first() else {
        return;
    };
    println!(
        "{} prepare + render repeats per case, {} threads ({}), git {}",
        repeats, first.threads, first.cpu, first.git_revision
    );
    let mut scene = "";
    for r in rows {
        if r.scene != scene {
            scene = &r.scene;
            println!("{} {}x{}", r.scene, r.width, r.height);
            println!(
                "  {:<26} {:>5} {:>10}  {:>16}  {:>23}  counters per second",
                "strategy", "spp", "prepare s", "pixel samples/s", "range"
            );
        }
        println!(
            "  {:<26} {:>5} {:>10.3}  {:>16.0}  {:>11.0}–{:<11.0}  {}",
            r.label,
            r.samples,
            r.prepare_s,
            r.pixel_samples_per_s,
            r.pixel_samples_per_s_min,
            r.pixel_samples_per_s_max,
            r.counters_per_s.replace(';', "  ")
        );
    }
}

/// A scene file with `--param NAME=VALUE` arguments.
fn scene_source(file: PathBuf, params: &[String]) -> Result<photon_bench::scene::load::SceneSource> {
    let params = params
        .iter()
        .map(|p| {
            p.split_once('=')
                .map(|(k, v)| (k.trim().to_string(), v.to_string()))
                .ok_or_else(|| Error::new(format!("--param: expected NAME=VALUE, got {p:?}")))
        })
        .collect::<Result<_>>()?;
    Ok(photon_bench::scene::load::SceneSource {
        file,
        params,
        name: None,
    })
}

/// The build targets x86-64-v3 on x86-64 (`.cargo/config.toml`); on a processor without its
/// features, one line and exit status 2 instead of an illegal instruction. Everything compiled
/// here may use AVX encodings, so the check is integer code on the processor's own answer
/// (`cpuid`, and `xgetbv` for the operating system's support of the 256-bit registers; the
/// standard library's `is_x86_feature_detected!` answers "yes" at compile time for a feature
/// the build targets) and its refusal writes a fixed message through the standard library.
/// Tested by running `bench --version` under `qemu-x86_64 -cpu Nehalem` (docs/user-guide.md).
#[inline(always)]
fn refuse_a_processor_without_the_build_target() {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    {
        use std::arch::x86_64::{__cpuid, __cpuid_count, _xgetbv};
        let bit = |word: u32, b: u32| word & (1 << b) != 0;
        // SAFETY: cpuid exists on every x86-64 processor; xgetbv only runs where cpuid reports
        // OSXSAVE, i.e. where the instruction is enabled.
        let supported = unsafe {
            let leaf1 = __cpuid(1);
            let (fma, osxsave, avx) = (bit(leaf1.ecx, 12), bit(leaf1.ecx, 27), bit(leaf1.ecx, 28));
            let leaf7_ebx = if __cpuid(0).eax >= 7 {
                __cpuid_count(7, 0).ebx
            } else {
                0
            };
            let (avx2, bmi2) = (bit(leaf7_ebx, 5), bit(leaf7_ebx, 8));
            fma && avx && avx2 && bmi2 && osxsave && _xgetbv(0) & 0b110 == 0b110
        };
        if !supported {
            processor_lacks_the_build_target();
        }
    }
}

#[cold]
#[inline(never)]
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
fn processor_lacks_the_build_target() -> ! {
    use std::io::Write;
    let _ = std::io::stderr().write_all(
        b"error: this build needs a processor with AVX2, FMA and BMI2 (x86-64-v3, .cargo/config.toml); \
rebuild with RUSTFLAGS=\"-C target-cpu=x86-64\" cargo build --release\n",
    );
    std::process::exit(2)
}
