//! The `bench` binary end to end on a tiny scene: a reference, a run, its outputs; and the
//! refusals — bad experiment files, unknown strategies, stale references — each a one-line
//! error with exit status 2 that leaves nothing under the output directory.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bench(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bench"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

mod common;

/// A temporary project: `scenes/tiny.toml` (cornell-empty at 16 × 12) and an experiment.
fn project() -> tempfile::TempDir {
    common::tiny_project(EXPERIMENT)
}

const EXPERIMENT: &str = r#"
scenes = ["../scenes/tiny.toml"]
spp = [1, 2]
seeds = 2
[[strategy]]
kind = "path"
[[strategy]]
kind = "path"
label = "uniform"
bsdf_sampling = "uniform"
"#;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn assert_refused(o: &Output, expected: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "exit status; stderr: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.starts_with("error: "), "{err}");
    for e in expected {
        assert!(err.contains(e), "expected `{e}` in `{err}`");
    }
}

/// Entries of `results/tiny/` besides the cell cache: run directories and partial runs.
fn run_dirs(root: &Path) -> Vec<PathBuf> {
    match std::fs::read_dir(root.join("results/tiny")) {
        Ok(d) => d.map(|e| e.unwrap().path()).filter(|p| !p.ends_with("cells")).collect(),
        Err(_) => Vec::new(),
    }
}

/// Completed cells in the cache (hidden temporaries left out).
fn cached_cells(root: &Path) -> Vec<PathBuf> {
    match std::fs::read_dir(root.join("results/tiny/cells")) {
        Ok(d) => d
            .map(|e| e.unwrap().path())
            .filter(|p| !p.file_name().unwrap().to_string_lossy().starts_with('.'))
            .collect(),
        Err(_) => Vec::new(),
    }
}

/// `bench reference scenes/tiny.toml --spp <spp>` in the project, which must succeed.
fn make_reference(root: &Path, spp: u32) {
    let o = bench(root, &["reference", "scenes/tiny.toml", "--spp", &spp.to_string()]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn reference_then_run_writes_a_complete_result_directory() {
    let p = project();
    let root = p.path();
    let o = bench(root, &["reference", "scenes/tiny.toml", "--spp", "8"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(root.join("references/tiny.exr").exists() && root.join("references/tiny.json").exists());
    // A second reference without --force would overwrite: refused.
    assert_refused(
        &bench(root, &["reference", "scenes/tiny.toml", "--spp", "8"]),
        &["--force"],
    );

    let o = bench(root, &["--threads", "2", "run", "experiments/tiny.toml"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // stderr is a pipe here, as in a CI or batch log: one line per finished cell, the last
    // one with nothing left.
    let progress: Vec<String> = stderr(&o)
        .lines()
        .filter(|l| l.starts_with('['))
        .map(String::from)
        .collect();
    assert_eq!(progress.len(), 4, "{progress:?}");
    assert!(
        progress[0].starts_with("[1/4] tiny · path · seed 0: rendered in "),
        "{progress:?}"
    );
    assert!(
        progress[1].contains(" left") && !progress[3].contains(" left"),
        "{progress:?}"
    );
    let dirs = run_dirs(root);
    assert_eq!(
        dirs.len(),
        1,
        "exactly one run directory and no leftover partial: {dirs:?}"
    );
    let run = &dirs[0];
    let rows = photon_bench::report::rows::read_csv(&run.join("metrics.csv")).unwrap();
    assert_eq!(rows.len(), 2 * 2 * 2, "strategies × seeds × checkpoints");
    for r in &rows {
        assert_eq!(r.threads, 2);
        assert!(r.mse.is_finite() && r.mse > 0.0);
        assert!(r.params.contains("bsdf_sampling="));
        assert!(run.join(&r.image).exists() && run.join(&r.image).with_extension("png").exists());
    }
    let long = std::fs::read_to_string(run.join("metrics_long.csv")).unwrap();
    assert!(long.contains(",params,bsdf_sampling,uniform"), "{long}");
    for f in [
        "summary.md",
        "experiment.toml",
        "plots/tiny_mse_vs_spp.svg",
        "plots/tiny_mse_vs_time.png",
    ] {
        assert!(run.join(f).exists(), "{f}");
    }

    let summary = std::fs::read_to_string(run.join("summary.md")).unwrap();
    for text in [
        "### rel_mse",
        "95 % CI",
        "| uniform | 2 spp | 2 |",
        "### ratios to `",
        "| 2 spp | 2/2 |",
    ] {
        assert!(summary.contains(text), "summary lacks {text:?}:\n{summary}");
    }
    let svg = std::fs::read_to_string(run.join("plots/tiny_mse_vs_spp.svg")).unwrap();
    assert!(svg.contains("<polygon"), "CI bands are drawn");
    for f in [
        "plots/tiny_mse_equal_spp.svg",
        "plots/tiny_timing.png",
        "images/tiny_strip_spp2.png",
        "images/tiny_uniform_seed1_spp1_error.png",
    ] {
        assert!(run.join(f).exists(), "{f}");
    }
    let strip = image::open(run.join("images/tiny_strip_spp2.png")).unwrap();
    assert_eq!(
        (strip.width(), strip.height()),
        (3 * 16 + 2 * 2, 12),
        "two strategies and the reference"
    );
    let progression = image::open(run.join("images/tiny_progression_spp.png")).unwrap();
    assert_eq!(
        (progression.width(), progression.height()),
        (2 * 16 + 2, 3 * 12 + 2 * 2),
        "two spp checkpoints as columns; two strategies and the reference as rows"
    );
    let ratios = std::fs::read_to_string(run.join("ratios.csv")).unwrap();
    assert_eq!(ratios.lines().count(), 2, "one strategy against the first:\n{ratios}");
    assert_offline_page(run);

    // `bench plot` redraws every plot from metrics.csv alone.
    let bare = root.join("bare");
    std::fs::create_dir_all(&bare).unwrap();
    std::fs::copy(run.join("metrics.csv"), bare.join("metrics.csv")).unwrap();
    let o = bench(root, &["plot", "bare"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut plots: Vec<String> = std::fs::read_dir(run.join("plots"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let mut redrawn: Vec<String> = std::fs::read_dir(bare.join("plots"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    plots.sort();
    redrawn.sort();
    assert_eq!(plots, redrawn);
    assert_refused(&bench(root, &["plot", "nowhere"]), &["nowhere", "metrics.csv"]);
    // The default plots cover MSE, relMSE and FLIP; `--metric` draws others.
    for metric in ["mse", "rel_mse", "flip"] {
        assert!(
            plots.contains(&format!("tiny_{metric}_vs_spp.svg")),
            "{metric}: {plots:?}"
        );
    }
    let o = bench(root, &["plot", "bare", "--metric", "rms_rel_lum"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(bare.join("plots/tiny_rms_rel_lum_vs_spp.png").exists());
    assert_refused(
        &bench(root, &["plot", "bare", "--metric", "psnr"]),
        &["--metric", "psnr", "rel_mse"],
    );

    // A second run never overwrites the first; it takes every cell from the cache.
    let o = bench(root, &["run", "experiments/tiny.toml"]);
    assert!(o.status.success());
    assert!(stderr(&o).contains("cells: 4 cached, 0 rendered"), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("[4/4] tiny · uniform · seed 1: cached"),
        "{}",
        stderr(&o)
    );
    assert_eq!(run_dirs(root).len(), 2);
    assert_eq!(cached_cells(root).len(), 4);
}

/// `index.html` loads nothing from outside the run directory, every link resolves, and the
/// viewer's data and script are inline (scripts/test_report_page.py drives it in a browser).
fn assert_offline_page(run: &Path) {
    let html = std::fs::read_to_string(run.join("index.html")).unwrap();
    assert!(!html.contains("http:") && !html.contains("https:"), "a URL in the page");
    for remote in ["src=\"//", "href=\"//", "url(", "<script src", "import("] {
        assert!(!html.contains(remote), "{remote} in the page");
    }
    assert!(html.contains("id=\"viewer-data\"") && html.contains("window.viewer"));
    assert!(run.join("references/tiny.exr").exists() && run.join("references/tiny.json").exists());
    let mut links = 0;
    for attr in ["src=\"", "href=\""] {
        for part in html.split(attr).skip(1) {
            let link = &part[..part.find('"').unwrap()];
            assert!(run.join(link).exists(), "broken link {link}");
            links += 1;
        }
    }
    assert!(links > 10, "{links} links");
}

/// The command a refusal quotes between backticks, as words.
fn quoted_command(err: &str) -> Vec<String> {
    let start = err.find("`bench ").expect("a quoted bench command") + 1;
    let end = start + err[start..].find('`').unwrap();
    err[start..end].split_whitespace().skip(1).map(String::from).collect()
}

#[test]
fn the_missing_reference_hint_writes_where_the_experiment_reads() {
    let p = project();
    let root = p.path();
    // Run from another directory than the project's: the hint must still be right.
    let elsewhere = root.join("elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    let o = bench(&elsewhere, &["run", "../experiments/tiny.toml"]);
    assert_refused(&o, &["reference missing", "--out"]);
    let args: Vec<String> = quoted_command(&stderr(&o))
        .into_iter()
        .map(|a| if a == "<N>" { "4".to_string() } else { a })
        .collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let made = bench(&elsewhere, &args);
    assert!(made.status.success(), "{args:?}: {}", stderr(&made));
    let o = bench(&elsewhere, &["run", "../experiments/tiny.toml"]);
    assert!(o.status.success(), "after following the hint: {}", stderr(&o));
    // The run keeps the reference it measured against; a 4-spp reference is mostly noise, and
    // the run says so.
    let run = &run_dirs(root)[0];
    assert!(run.join("references/tiny.exr").exists() && run.join("references/tiny.json").exists());
    assert!(
        stderr(&o).contains("the reference's own noise (4 spp)"),
        "{}",
        stderr(&o)
    );
    let rows = photon_bench::report::rows::read_csv(&run.join("metrics.csv")).unwrap();
    assert!(
        rows.iter()
            .all(|r| r.reference_mse > 0.0 && r.reference_mse.is_finite())
    );
}

#[test]
fn stale_reference_is_refused_with_the_command_that_regenerates_it() {
    let p = project();
    let root = p.path();
    make_reference(root, 2);
    let scene = std::fs::read_to_string(root.join("scenes/tiny.toml")).unwrap();
    std::fs::write(
        root.join("scenes/tiny.toml"),
        scene.replace("[0.73, 0.73, 0.73]", "[0.7, 0.7, 0.7]"),
    )
    .unwrap();
    let o = bench(root, &["run", "experiments/tiny.toml"]);
    assert_refused(&o, &["references/tiny.exr", "bench reference scenes/tiny.toml --spp 2"]);
    assert!(run_dirs(root).is_empty(), "nothing written");
    // Following the quoted command makes the experiment run.
    let args = quoted_command(&stderr(&o));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    assert!(bench(root, &args).status.success(), "{args:?}");
    assert!(bench(root, &["run", "experiments/tiny.toml"]).status.success());
}

/// `bench render`: one image by any strategy with its provenance, bit-identical on 1 and 2
/// threads; an existing image, an unknown strategy or parameter and a wrong file name are
/// refused with one line and nothing written.
#[test]
fn render_writes_one_image_by_any_strategy_with_its_provenance() {
    let p = project();
    let root = p.path();
    let render = |threads: &str, out: &str, extra: &[&str]| {
        let mut args = vec![
            "--threads",
            threads,
            "render",
            "scenes/tiny.toml",
            "--strategy",
            "bdpt",
            "--set",
            "max_depth=3",
            "--spp",
            "2",
            "--seed",
            "5",
            "--out",
            out,
        ];
        args.extend_from_slice(extra);
        bench(root, &args)
    };
    let o = render("1", "out/one.exr", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = render("2", "out/two.exr", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let read = |name: &str| photon_bench::film::read_exr(&root.join("out").join(name)).unwrap();
    assert_eq!(read("one.exr").pixels, read("two.exr").pixels, "1 and 2 threads");
    assert!(read("one.exr").pixels.iter().any(|p| p.max_element() > 0.0));
    let png = image::open(root.join("out/one.png")).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (read("one.exr").width, read("one.exr").height));
    let info: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(root.join("out/one.json")).unwrap()).unwrap();
    assert_eq!(info["strategy"], "bdpt");
    assert_eq!(info["seed"], 5);
    assert_eq!(info["spp"], 2);
    assert_eq!(info["threads"], 1);
    assert_eq!(info["params"][0], serde_json::json!(["max_depth", "3"]));
    assert!(info["scene_hash"].as_str().is_some_and(|h| !h.is_empty()));

    assert_refused(&render("1", "out/one.exr", &[]), &["out/one.exr", "--force"]);
    assert!(render("1", "out/one.exr", &["--force"]).status.success());
    let files = || std::fs::read_dir(root.join("out")).unwrap().count();
    let before = files();
    assert_refused(
        &bench(
            root,
            &[
                "render",
                "scenes/tiny.toml",
                "--strategy",
                "nope",
                "--spp",
                "1",
                "--out",
                "out/n.exr",
            ],
        ),
        &["nope"],
    );
    assert_refused(&render("1", "out/n.exr", &["--set", "radius=2"]), &["radius"]);
    assert_refused(
        &render("1", "out/n.exr", &["--set", "max_depth"]),
        &["--set", "NAME=VALUE"],
    );
    assert_refused(&render("1", "out/n.png", &[]), &["--out", ".exr"]);
    assert_eq!(files(), before, "nothing written by a refused render");
}

#[test]
fn bad_input_is_refused_before_anything_is_written() {
    let p = project();
    let root = p.path();
    assert_refused(
        &bench(root, &["run", "experiments/tiny.toml"]),
        &["reference missing", "bench reference scenes/tiny.toml"],
    );
    make_reference(root, 2);
    let cases: [(&str, &[&str]); 5] = [
        ("kind = \"path\"\n[[strategy]]", &["strategy[1]", "used twice"]),
        (
            "bsdf_sampling = \"uniform\"",
            &["strategy[1] (path)", "unknown variant"],
        ),
        ("seeds = 2", &["experiments/tiny.toml"]),
        ("spp = [1, 2]", &["spp"]),
        ("scenes = [\"../scenes/tiny.toml\"]", &["scenes/missing.toml"]),
    ];
    let replacements = [
        "kind = \"path\"\n[[strategy]]\nkind = \"path\"\n[[strategy]]",
        "bsdf_sampling = \"unifrom\"",
        "seeds = \"two\"",
        "spp = [0]",
        "scenes = [\"../scenes/missing.toml\"]",
    ];
    for ((needle, expected), replacement) in cases.iter().zip(replacements) {
        std::fs::write(
            root.join("experiments/tiny.toml"),
            EXPERIMENT.replacen(needle, replacement, 1),
        )
        .unwrap();
        assert_refused(&bench(root, &["run", "experiments/tiny.toml"]), expected);
        assert!(run_dirs(root).is_empty(), "nothing written for {replacement}");
    }
    assert_refused(
        &bench(root, &["run", "experiments/nope.toml"]),
        &["experiments/nope.toml"],
    );
    assert_refused(
        &bench(root, &["reference", "scenes/tiny.toml", "--spp", "0"]),
        &["--spp"],
    );
    assert_refused(&bench(root, &["--threads", "0", "list"]), &["--threads"]);
}

#[test]
fn sweeps_and_time_budgets_give_labelled_rows_and_spp_rows_are_deterministic() {
    let p = project();
    let root = p.path();
    assert!(
        bench(root, &["reference", "scenes/tiny.toml", "--spp", "4"])
            .status
            .success()
    );
    let experiment = r#"
scenes = ["../scenes/tiny.toml"]
spp = [1, 2]
seconds = [0.02, 0.05]
seeds = 2
[[strategy]]
kind = "path"
max_depth = [1, 3]
"#;
    std::fs::write(root.join("experiments/tiny.toml"), experiment).unwrap();
    let mut runs = Vec::new();
    for _ in 0..2 {
        let o = bench(root, &["run", "experiments/tiny.toml"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let dir = PathBuf::from(String::from_utf8_lossy(&o.stdout).trim());
        runs.push(photon_bench::report::rows::read_csv(&root.join(dir).join("metrics.csv")).unwrap());
    }
    let rows = &runs[0];
    assert_eq!(rows.len(), 2 * 2 * (2 + 2), "strategies × seeds × checkpoints");
    let labels: Vec<&str> = rows.iter().map(|r| r.strategy.as_str()).collect();
    assert!(labels.contains(&"path[max_depth=1]") && labels.contains(&"path[max_depth=3]"));
    for r in rows.iter().filter(|r| r.strategy == "path[max_depth=1]") {
        assert!(r.params.contains("max_depth=1"), "{}", r.params);
    }
    let timed: Vec<_> = rows.iter().filter(|r| r.budget == "seconds").collect();
    assert_eq!(timed.len(), 8);
    for r in &timed {
        assert!(r.spp >= 1 && r.total_s > 0.0);
        assert!(r.budget_value == 0.02 || r.budget_value == 0.05);
        // Passes go on until the budget is reached.
        assert!(r.total_s >= r.budget_value, "{} < {}", r.total_s, r.budget_value);
    }
    // Equal samples: the same metrics bit for bit in every run.
    let spp_rows = |rows: &[photon_bench::report::rows::Row]| -> Vec<(String, u64, u32, u64)> {
        rows.iter()
            .filter(|r| r.budget == "spp")
            .map(|r| (r.strategy.clone(), r.seed, r.spp, r.mse.to_bits()))
            .collect()
    };
    assert_eq!(spp_rows(&runs[0]), spp_rows(&runs[1]));
    assert_eq!(spp_rows(&runs[0]).len(), 8);
}

#[test]
fn a_killed_run_resumes_from_its_cached_cells_with_identical_results() {
    let p = project();
    let root = p.path();
    let scene = std::fs::read_to_string(root.join("scenes/tiny.toml")).unwrap();
    std::fs::write(
        root.join("scenes/tiny.toml"),
        scene.replace("resolution = [16, 12]", "resolution = [48, 36]"),
    )
    .unwrap();
    assert!(
        bench(root, &["reference", "scenes/tiny.toml", "--spp", "4"])
            .status
            .success()
    );
    let experiment = "scenes = [\"../scenes/tiny.toml\"]\nspp = [1, 128]\nseeds = 3\n\
        [[strategy]]\nkind = \"path\"\n[[strategy]]\nkind = \"path\"\nlabel = \"uniform\"\nbsdf_sampling = \"uniform\"\n";
    std::fs::write(root.join("experiments/tiny.toml"), experiment).unwrap();

    // Kill (SIGKILL) the run as soon as its first cell is cached.
    let mut child = Command::new(env!("CARGO_BIN_EXE_bench"))
        .current_dir(root)
        .args(["--threads", "1", "run", "experiments/tiny.toml"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    while cached_cells(root).is_empty() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before a cell was cached"
        );
        assert!(started.elapsed().as_secs() < 120, "no cell cached in two minutes");
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let cached = cached_cells(root).len();
    assert!((1..6).contains(&cached), "{cached} of 6 cells cached when killed");
    // No finished run, and every cached cell is complete.
    assert!(
        run_dirs(root)
            .iter()
            .all(|d| d.file_name().unwrap().to_string_lossy().ends_with(".partial"))
    );
    for cell in cached_cells(root) {
        let rows = photon_bench::report::rows::read_csv(&cell.join("rows.csv")).unwrap();
        assert_eq!(rows.len(), 2);
        assert!(rows.iter().all(|r| cell.join(&r.image).exists()));
    }

    // The killed run left its partial run directory (and perhaps a cell's temporary), which
    // name their writer; a temporary of a live process on this host must survive.
    let hidden = |root: &Path| -> Vec<PathBuf> {
        let results = root.join("results/tiny");
        [results.clone(), results.join("cells")]
            .iter()
            .flat_map(|d| std::fs::read_dir(d).unwrap().map(|e| e.unwrap().path()))
            .filter(|p| p.is_dir() && p.file_name().unwrap().to_string_lossy().starts_with('.'))
            .collect()
    };
    let leftovers = hidden(root);
    assert!(!leftovers.is_empty(), "a killed run leaves its partial directory");
    // Each names the killed process in its owner file or, a cell temporary killed before it
    // wrote that file (or while writing it), in its name (`.tmp-<hash>-<pid>@<host>`).
    let owner = |dir: &Path| -> String {
        let written = std::fs::read_to_string(dir.join(photon_bench::experiment::run::OWNER)).unwrap_or_default();
        Some(written).filter(|o| !o.trim().is_empty()).unwrap_or_else(|| {
            let name = dir.file_name().unwrap().to_string_lossy().to_string();
            let (left, host) = name.split_once('@').expect("an owner file or an owner in the name");
            format!("{host} {}", left.rsplit_once('-').unwrap().1)
        })
    };
    for dir in &leftovers {
        let owner = owner(dir);
        assert!(owner.trim().ends_with(&format!(" {}", child.id())), "{owner}");
    }
    let live = root.join("results/tiny/cells/.tmp-live");
    std::fs::create_dir_all(&live).unwrap();
    let host = owner(&leftovers[0]);
    let host = host.trim().rsplit_once(' ').unwrap().0.to_string();
    std::fs::write(
        live.join(photon_bench::experiment::run::OWNER),
        format!("{host} {}\n", std::process::id()),
    )
    .unwrap();

    // Running again removes the dead run's temporaries, renders only the missing cells ...
    let o = bench(root, &["run", "experiments/tiny.toml"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let msg = format!("cells: {cached} cached, {} rendered", 6 - cached);
    assert!(stderr(&o).contains(&msg), "expected {msg:?} in {}", stderr(&o));
    assert!(
        stderr(&o).contains("temporary directories of killed runs"),
        "{}",
        stderr(&o)
    );
    assert_eq!(
        hidden(root),
        vec![live.clone()],
        "only the live process's temporary is left"
    );
    std::fs::remove_dir_all(&live).unwrap();
    let resumed = root.join(String::from_utf8_lossy(&o.stdout).trim());
    // ... and gives the metrics of a run from scratch, bit for bit.
    let o = bench(root, &["run", "--force", "experiments/tiny.toml"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("cells: 0 cached, 6 rendered"), "{}", stderr(&o));
    let fresh = root.join(String::from_utf8_lossy(&o.stdout).trim());
    let key = |dir: &Path| -> Vec<(String, u64, u32, [u64; 3])> {
        photon_bench::report::rows::read_csv(&dir.join("metrics.csv"))
            .unwrap()
            .iter()
            .map(|r| {
                (
                    r.strategy.clone(),
                    r.seed,
                    r.spp,
                    [r.mse.to_bits(), r.rel_mse.to_bits(), r.mean_r.to_bits()],
                )
            })
            .collect()
    };
    assert_eq!(key(&resumed).len(), 12);
    assert_eq!(key(&resumed), key(&fresh));
    for r in photon_bench::report::rows::read_csv(&resumed.join("metrics.csv")).unwrap() {
        assert!(resumed.join(&r.image).exists(), "{}", r.image);
    }
}

/// Copies a project directory (scenes, experiments, references) to a fresh temporary one, as
/// a second cluster machine would check it out.
fn clone_project(from: &Path) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for sub in ["scenes", "experiments", "references"] {
        std::fs::create_dir_all(dir.path().join(sub)).unwrap();
        for e in std::fs::read_dir(from.join(sub)).unwrap() {
            let e = e.unwrap();
            std::fs::copy(e.path(), dir.path().join(sub).join(e.file_name())).unwrap();
        }
    }
    dir
}

/// The error metrics of a run, in a fixed order.
fn error_metrics(run: &Path) -> Vec<(String, u64, u32, u64)> {
    let mut rows: Vec<_> = photon_bench::report::rows::read_csv(&run.join("metrics.csv"))
        .unwrap()
        .into_iter()
        .map(|r| (r.strategy, r.seed, r.spp, r.mse.to_bits()))
        .collect();
    rows.sort();
    rows
}

#[test]
fn shards_on_two_machines_merge_into_the_results_of_one_run() {
    let a = project();
    let ra = a.path();
    assert!(
        bench(ra, &["reference", "scenes/tiny.toml", "--spp", "4"])
            .status
            .success()
    );
    let b = clone_project(ra);
    let rb = b.path();

    let o = bench(ra, &["run", "experiments/tiny.toml", "--shard", "1/2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(run_dirs(ra).is_empty(), "a shard assembles no run");
    // Half the plan is missing on machine A: merging now is refused, nothing assembled.
    assert_refused(&bench(ra, &["merge", "experiments/tiny.toml"]), &["missing", "--shard"]);
    assert!(run_dirs(ra).is_empty());

    let o = bench(rb, &["run", "experiments/tiny.toml", "--shard", "2/2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        cached_cells(ra).len() + cached_cells(rb).len(),
        4,
        "the shards split the 4 cells"
    );
    let cells_b = rb.join("results/tiny/cells");
    let o = bench(ra, &["merge", "experiments/tiny.toml", cells_b.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let merged = PathBuf::from(String::from_utf8_lossy(&o.stdout).trim());
    let merged = if merged.is_absolute() { merged } else { ra.join(merged) };

    let o = bench(ra, &["run", "experiments/tiny.toml", "--force"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let single = PathBuf::from(String::from_utf8_lossy(&o.stdout).trim());
    let single = if single.is_absolute() { single } else { ra.join(single) };
    assert_eq!(
        error_metrics(&merged),
        error_metrics(&single),
        "bit-identical error metrics"
    );

    assert_refused(
        &bench(ra, &["run", "experiments/tiny.toml", "--shard", "3/2"]),
        &["--shard"],
    );
}

#[test]
fn strategy_counters_are_recorded_per_checkpoint_and_kept_by_the_cell_cache() {
    let p = project();
    let root = p.path();
    assert!(
        bench(root, &["reference", "scenes/tiny.toml", "--spp", "4"])
            .status
            .success()
    );
    let experiment = r#"
scenes = ["../scenes/tiny.toml"]
spp = [1, 2]
seconds = [0.05]
[[strategy]]
kind = "path"
[[strategy]]
kind = "photon_map"
photons = 2000
gather_rays = 4
spp = [2]
"#;
    std::fs::write(root.join("experiments/tiny.toml"), experiment).unwrap();
    let mut runs = Vec::new();
    for _ in 0..2 {
        let o = bench(root, &["run", "experiments/tiny.toml"]);
        assert!(o.status.success(), "{}", stderr(&o));
        runs.push(root.join(String::from_utf8_lossy(&o.stdout).trim()));
    }
    let rows = photon_bench::report::rows::read_csv(&runs[0].join("metrics.csv")).unwrap();
    // photon_map renders its own budgets only: 2 spp and the time budget.
    assert_eq!(rows.len(), 3 + 2);
    let budgets: Vec<(&str, f64)> = rows
        .iter()
        .filter(|r| r.kind == "photon_map")
        .map(|r| (r.budget.as_str(), r.budget_value))
        .collect();
    assert_eq!(budgets, [("spp", 2.0), ("seconds", 0.05)]);
    use photon_bench::report::rows::counter;
    let pixels = 16.0 * 12.0;
    for r in &rows {
        if r.kind == "path" {
            assert_eq!(r.counters, "", "path counts nothing");
            continue;
        }
        // Nearly every camera ray of the empty box ends on a wall: up to spp × pixels × 4
        // primary gather rays, plus 12 per secondary gather. The equal-time row counts its
        // own film only (not the equal-samples film rendered before it).
        let rays = counter(r, "gather_rays").unwrap();
        let most = r.spp as f64 * pixels * 4.0 + 12.0 * counter(r, "secondary_gathers").unwrap();
        assert!(
            rays <= most && rays > 0.97 * most,
            "{} {}: {} of at most {most}",
            r.budget,
            r.spp,
            r.counters
        );
        assert!(counter(r, "global_photons").unwrap() > 2000.0, "{}", r.counters);
        assert_eq!(counter(r, "bytes_per_photon"), Some(24.0));
    }
    // The second run takes both cells from the cache, counters included.
    let again = photon_bench::report::rows::read_csv(&runs[1].join("metrics.csv")).unwrap();
    let counters =
        |rows: &[photon_bench::report::rows::Row]| -> Vec<String> { rows.iter().map(|r| r.counters.clone()).collect() };
    assert_eq!(counters(&rows), counters(&again));
    let summary = std::fs::read_to_string(runs[0].join("summary.md")).unwrap();
    assert!(summary.contains("### counters"), "{summary}");
    assert!(summary.contains("| photon_map | 2 spp | 1 |"), "{summary}");
    let html = std::fs::read_to_string(runs[0].join("index.html")).unwrap();
    assert!(html.contains("<th>gather_rays</th>"));
}

#[test]
fn christensen_comparison_is_computed_from_the_rows_and_images_of_a_run() {
    let p = project();
    let root = p.path();
    assert!(
        bench(root, &["reference", "scenes/tiny.toml", "--spp", "4"])
            .status
            .success()
    );
    let experiment = r#"
scenes = ["../scenes/tiny.toml"]
spp = [1, 2]
seeds = 2
[[strategy]]
kind = "photon_map"
label = "direct"
photons = 3000
gather_rays = 4
[[strategy]]
kind = "photon_map"
label = "pre4"
photons = 3000
gather_rays = 4
precomputed_irradiance = { every = 4 }
[[strategy]]
kind = "photon_map"
label = "other"
photons = 3000
gather_rays = 8
precomputed_irradiance = { every = 4 }
"#;
    std::fs::write(root.join("experiments/tiny.toml"), experiment).unwrap();
    let o = bench(root, &["run", "experiments/tiny.toml"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let run = root.join(String::from_utf8_lossy(&o.stdout).trim());
    let rows = photon_bench::report::rows::read_csv(&run.join("metrics.csv")).unwrap();
    let mut csv = csv::Reader::from_path(run.join("final_gather.csv")).unwrap();
    let header = csv.headers().unwrap().clone();
    let records: Vec<csv::StringRecord> = csv.records().map(|r| r.unwrap()).collect();
    // `pre4` against `direct` at 2 checkpoints × 2 seeds; `other` has no direct-lookup twin.
    assert_eq!(records.len(), 4);
    let field = |rec: &csv::StringRecord, name: &str| -> String {
        rec[header.iter().position(|h| h == name).unwrap()].to_string()
    };
    let num = |rec: &csv::StringRecord, name: &str| -> f64 { field(rec, name).parse().unwrap() };
    for rec in &records {
        assert_eq!(
            (field(rec, "variant"), field(rec, "direct")),
            ("pre4".into(), "direct".into())
        );
        let at = |label: &str| {
            rows.iter()
                .find(|r| {
                    r.strategy == label
                        && r.seed.to_string() == field(rec, "seed")
                        && r.spp.to_string() == field(rec, "spp")
                })
                .unwrap()
        };
        let (d, v) = (at("direct"), at("pre4"));
        assert_eq!(num(rec, "gather_s_direct"), d.render_s);
        assert_eq!(num(rec, "speedup"), d.render_s / v.render_s);
        let pre: f64 = v
            .phases
            .split(';')
            .find_map(|p| p.strip_prefix("irradiance_precompute="))
            .unwrap()
            .parse()
            .unwrap();
        assert_eq!(num(rec, "precompute_s"), pre);
        if d.render_s > v.render_s {
            assert_eq!(
                num(rec, "precompute_pct_of_saved"),
                100.0 * pre / (d.render_s - v.render_s)
            );
        }
        let image = |r: &photon_bench::report::rows::Row| photon_bench::film::read_exr(&run.join(&r.image)).unwrap();
        let between = photon_bench::metrics::compare(&image(v), &image(d)).unwrap().mse;
        assert_eq!(num(rec, "mse_between"), between);
        assert!(between > 0.0);
        assert_eq!((num(rec, "mse_direct"), num(rec, "mse_variant")), (d.mse, v.mse));
        assert_eq!(num(rec, "bytes_per_photon"), 24.0);
        assert!(num(rec, "global_photons") > 3000.0);
        assert!(num(rec, "irradiance_lookups") > 0.0);
        // The variant's density estimates include one per precomputed photon.
        assert!(num(rec, "estimates_variant") >= num(rec, "global_photons") / 4.0);
        assert!(num(rec, "map_bytes_variant") > num(rec, "map_bytes_direct"));
    }
    let summary = std::fs::read_to_string(run.join("summary.md")).unwrap();
    assert!(summary.contains("### final gathering"), "{summary}");
    assert!(summary.contains("| pre4 | direct | 2 | 2 |"), "{summary}");
    assert!(
        std::fs::read_to_string(run.join("index.html"))
            .unwrap()
            .contains("final_gather.csv")
    );
    assert_fig1_images_written_and_linked(&run);
    // A second run reuses every cell from the cache and still has (and links) every figure.
    let o = bench(root, &["run", "experiments/tiny.toml"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("0 rendered"), "{}", stderr(&o));
    assert_fig1_images_written_and_linked(&root.join(String::from_utf8_lossy(&o.stdout).trim()));
}

/// Christensen 1999 Fig. 1 (a)–(e) for every photon-map cell of the run above: the photon map,
/// the irradiance at the image points and what the gather reads for all three, the precomputed
/// irradiance only for the two with `precomputed_irradiance`; each PNG of the scene's
/// resolution and linked from summary.md and index.html.
fn assert_fig1_images_written_and_linked(run: &Path) {
    let summary = std::fs::read_to_string(run.join("summary.md")).unwrap();
    let index = std::fs::read_to_string(run.join("index.html")).unwrap();
    assert!(summary.contains("### photon-map figures"), "{summary}");
    for label in ["direct", "pre4", "other"] {
        for seed in [0, 1] {
            for (suffix, present) in [
                ("_photons.png", true),
                ("_fig1b_irradiance.png", true),
                ("_fig1cd_precomputed.png", label != "direct"),
                ("_fig1e_gather_sees.png", true),
            ] {
                let rel = format!("images/tiny_{label}_seed{seed}{suffix}");
                let path = run.join(&rel);
                assert_eq!(path.is_file(), present, "{rel}");
                if present {
                    let png = image::open(&path).unwrap();
                    assert_eq!((png.width(), png.height()), (16, 12), "{rel}");
                    assert!(summary.contains(&format!("]({rel})")), "{rel} in summary.md");
                    assert!(index.contains(&format!("src=\"{rel}\"")), "{rel} in index.html");
                }
            }
        }
    }
}

/// `bench map-error` prints one CSV row per photon-map strategy and seed (strategies without a
/// map are skipped), is the same for any thread count, and refuses bad arguments in one line.
#[test]
fn map_error_prints_a_row_per_photon_map_strategy_and_seed() {
    let p = project();
    let root = p.path();
    let exp = format!("{EXPERIMENT}[[strategy]]\nkind = \"photon_map\"\nphotons = 20000\n");
    std::fs::write(root.join("experiments/tiny.toml"), exp).unwrap();
    let args = [
        "map-error",
        "experiments/tiny.toml",
        "--probes",
        "60",
        "--probe-spp",
        "16",
    ];
    let out = bench(root, &args);
    assert!(out.status.success(), "{}", stderr(&out));
    let table = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = table.lines().collect();
    assert_eq!(lines.len(), 3, "header and one row per seed: {table}");
    assert!(lines[0].starts_with("scene,strategy,seed,prep_s,probes,probe_spp,map_rms_rel"));
    for (seed, line) in lines[1..].iter().enumerate() {
        let cols: Vec<&str> = line.split(',').collect();
        assert_eq!(&cols[..3], &["tiny", "photon_map", &seed.to_string()], "{line}");
        let ratio: f64 = cols[9].parse().unwrap();
        assert!(ratio > 0.5 && ratio < 2.0, "map mean ratio {ratio}");
    }
    let one = bench(root, &[&["--threads", "1"][..], &args[..]].concat());
    let strip_time = |t: &str| -> Vec<String> {
        t.lines()
            .map(|l| {
                let mut c: Vec<&str> = l.split(',').collect();
                c.remove(3);
                c.join(",")
            })
            .collect()
    };
    assert_eq!(
        strip_time(&table),
        strip_time(&String::from_utf8(one.stdout).unwrap()),
        "same table on one thread"
    );
    assert_refused(
        &bench(root, &["map-error", "experiments/tiny.toml", "--probes", "0"]),
        &["--probes"],
    );
    assert_refused(
        &bench(root, &["map-error", "experiments/nope.toml"]),
        &["experiments/nope.toml"],
    );
}

/// Usage errors stay one line with exit status 2, but keep clap's detail: what is missing, the
/// suggestion for a typo, and the help of the subcommand at fault.
#[test]
fn usage_errors_name_what_is_missing_and_suggest_fixes() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    assert_refused(&bench(root, &["run"]), &["<EXPERIMENT>", "`bench run --help`"]);
    assert_refused(&bench(root, &["lsit"]), &["'lsit'", "'list'", "`bench --help`"]);
    assert_refused(
        &bench(root, &["reference", "s.toml", "--spp", "x"]),
        &["'x'", "--spp", "`bench reference --help`"],
    );
    assert_refused(
        &bench(root, &["run", "x.toml", "--forse"]),
        &["'--forse'", "--force", "`bench run --help`"],
    );
}

/// Rows record the revision the binary was built from, whatever directory it runs in: here a
/// fresh git repository of its own, whose revision must not be taken for the code's.
#[test]
fn provenance_is_the_revision_the_binary_was_built_from() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let git = |args: &[&str]| {
        let o = std::process::Command::new("git")
            .current_dir(root)
            .args(args)
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "git {args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        String::from_utf8_lossy(&o.stdout).trim().to_string()
    };
    git(&["init", "-q"]);
    std::fs::write(root.join("a.txt"), "a").unwrap();
    git(&["add", "a.txt"]);
    git(&["-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "other"]);
    let other = git(&["rev-parse", "--short=12", "HEAD"]);

    let built = env!("PHOTON_BENCH_GIT_REVISION");
    let o = bench(root, &["--version"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains(built));
    std::fs::create_dir_all(root.join("scenes")).unwrap();
    let scene = std::fs::read_to_string("scenes/cornell-empty.toml")
        .unwrap()
        .replace("resolution = [80, 60]", "resolution = [8, 6]");
    std::fs::write(root.join("scenes/tiny.toml"), scene).unwrap();
    let o = bench(root, &["reference", "scenes/tiny.toml", "--spp", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let sidecar = std::fs::read_to_string(root.join("references/tiny.json")).unwrap();
    assert!(sidecar.contains(&format!("\"git_revision\": \"{built}\"")), "{sidecar}");
    assert!(
        !sidecar.contains(&other),
        "the other repository's revision was recorded"
    );
    // The checkout this test runs in built the binary: the revision names its commit.
    let ours = std::process::Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .output()
        .unwrap();
    let ours = String::from_utf8_lossy(&ours.stdout).trim().to_string();
    if !ours.is_empty() {
        assert!(built.starts_with(&ours), "{built} vs {ours}");
    }
}

#[test]
fn exposure_brightens_the_previews_and_leaves_the_metrics_and_the_cells_alone() {
    let p = project();
    let root = p.path();
    assert!(
        bench(root, &["reference", "scenes/tiny.toml", "--spp", "8"])
            .status
            .success()
    );
    assert!(bench(root, &["run", "experiments/tiny.toml"]).status.success());
    let rel = "images/tiny_path_seed0_spp2.png";
    let first_preview = std::fs::read(run_dirs(root)[0].join(rel)).unwrap();
    let text = std::fs::read_to_string(root.join("experiments/tiny.toml")).unwrap();
    std::fs::write(
        root.join("experiments/tiny.toml"),
        text.replace("seeds = 2", "seeds = 2\nexposure = 1\nbaseline = \"uniform\""),
    )
    .unwrap();
    let o = bench(root, &["run", "experiments/tiny.toml"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("cells: 4 cached, 0 rendered"), "{}", stderr(&o));
    let mut runs = run_dirs(root);
    runs.sort();
    let mean = |run: &Path, rel: &str| -> f64 {
        let img = image::open(run.join(rel)).unwrap().to_rgb8();
        img.pixels()
            .map(|p| p.0.iter().map(|&c| c as f64).sum::<f64>())
            .sum::<f64>()
            / img.len() as f64
    };
    assert!(mean(&runs[1], rel) > 1.1 * mean(&runs[0], rel), "one stop brighter");
    // The first run's preview, a hard link to the cell's, is untouched.
    assert_eq!(std::fs::read(runs[0].join(rel)).unwrap(), first_preview);
    let rows = |run: &Path| photon_bench::report::rows::read_csv(&run.join("metrics.csv")).unwrap();
    let mse = |rows: Vec<photon_bench::report::rows::Row>| rows.iter().map(|r| r.mse).collect::<Vec<_>>();
    assert_eq!(mse(rows(&runs[0])), mse(rows(&runs[1])));
    // The ratio table now compares with `uniform`.
    let baselines = |run: &Path| -> Vec<String> {
        let mut r = csv::Reader::from_path(run.join("ratios.csv")).unwrap();
        let col = r.headers().unwrap().iter().position(|h| h == "baseline").unwrap();
        r.records().map(|rec| rec.unwrap()[col].to_string()).collect()
    };
    assert_eq!(baselines(&runs[0]), ["path"]);
    assert_eq!(baselines(&runs[1]), ["uniform"]);
}

/// `bench` with `args` in `dir`, killed (and the test failed) after 20 s: an input that is
/// read forever must not hang the suite.
fn bench_within_20_s(dir: &Path, args: &[&str]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_bench"))
        .current_dir(dir)
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > std::time::Duration::from_secs(20) {
            child.kill().unwrap();
            panic!("bench {args:?} still running after 20 s");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

#[test]
fn inputs_that_are_not_regular_files_or_too_large_are_refused_at_once() {
    let p = project();
    let root = p.path();
    make_reference(root, 2);
    let exp = std::fs::read_to_string(root.join("experiments/tiny.toml")).unwrap();
    std::fs::write(
        root.join("experiments/zero-scene.toml"),
        exp.replace("../scenes/tiny.toml", "/dev/zero"),
    )
    .unwrap();
    let scene = std::fs::read_to_string(root.join("scenes/tiny.toml")).unwrap();
    std::fs::write(
        root.join("scenes/zero-mesh.toml"),
        format!("{scene}\n[[shapes]]\ntype = \"mesh\"\nfile = \"/dev/zero\"\nmaterial = \"white\"\n"),
    )
    .unwrap();
    assert!(
        std::process::Command::new("mkfifo")
            .arg(root.join("experiments/fifo.toml"))
            .status()
            .unwrap()
            .success()
    );
    // A sparse 100 MB experiment file: larger than any real one.
    std::fs::File::create(root.join("experiments/huge.toml"))
        .unwrap()
        .set_len(100 << 20)
        .unwrap();
    let before: Vec<PathBuf> = walk(root);
    for (args, expected) in [
        (
            vec!["run", "/dev/zero"],
            vec!["/dev/zero", "regular file", "experiment file", "character device"],
        ),
        (
            vec!["reference", "/dev/zero", "--spp", "1"],
            vec!["/dev/zero", "scene file", "character device"],
        ),
        (
            vec!["run", "experiments/zero-scene.toml"],
            vec!["/dev/zero", "scene file"],
        ),
        (
            vec!["reference", "scenes/zero-mesh.toml", "--spp", "1"],
            vec!["/dev/zero", "expected a regular file"],
        ),
        (vec!["run", "experiments/fifo.toml"], vec!["fifo.toml", "FIFO"]),
        (vec!["run", "experiments"], vec!["experiments", "directory"]),
        (
            vec!["run", "experiments/huge.toml"],
            vec!["huge.toml", "100.0 MiB is larger than any experiment file"],
        ),
        (vec!["plot", "/dev"], vec!["/dev", "metrics.csv"]),
    ] {
        let o = bench_within_20_s(root, &args);
        assert_refused(&o, &expected);
    }
    // A reference EXR replaced by a device.
    std::fs::remove_file(root.join("references/tiny.exr")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", root.join("references/tiny.exr")).unwrap();
    let o = bench_within_20_s(root, &["run", "experiments/tiny.toml"]);
    assert_refused(&o, &["references/tiny.exr", "character device"]);
    assert_eq!(walk(root), before, "nothing written");
}

/// Every path under `root`, sorted.
fn walk(root: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let path = e.unwrap().path();
            if path.is_dir() && !path.is_symlink() {
                stack.push(path.clone());
            }
            out.push(path);
        }
    }
    out.sort();
    out
}

/// `bench perf --strategies` measures every registered strategy through the strategy trait:
/// one table row and one CSV row each, positive finite rates with a range around the median,
/// and each strategy's own counters as rates; an unknown kind is refused in one line.
#[test]
fn perf_measures_every_registered_strategy() {
    let dir = project();
    let root = dir.path();
    let o = bench(
        root,
        &[
            "perf",
            "--scene",
            "scenes/tiny.toml",
            "--strategies",
            "--repeats",
            "3",
            "--csv",
            "perf.csv",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    let kinds = photon_bench::strategy::kinds();
    let mut reader = csv::Reader::from_path(root.join("perf.csv")).unwrap();
    let headers = reader.headers().unwrap().clone();
    let col = |name: &str| headers.iter().position(|h| h == name).unwrap();
    let rows: Vec<csv::StringRecord> = reader.records().map(Result::unwrap).collect();
    assert_eq!(
        rows.len(),
        kinds.len() + 1,
        "a row per kind and the machine calibration"
    );
    assert_eq!(&rows[kinds.len()][col("label")], "machine-calibration");
    for (row, kind) in rows.iter().zip(&kinds) {
        assert_eq!(&row[col("strategy")], *kind);
        assert!(
            stdout.lines().any(|l| l.trim_start().starts_with(kind)),
            "{kind} in {stdout}"
        );
        let rate = |c: &str| row[col(c)].parse::<f64>().unwrap();
        let (median, lo, hi) = (
            rate("pixel_samples_per_s"),
            rate("pixel_samples_per_s_min"),
            rate("pixel_samples_per_s_max"),
        );
        assert!(
            median.is_finite() && lo > 0.0 && lo <= median && median <= hi,
            "{kind}: {lo} {median} {hi}"
        );
        assert_eq!(&row[col("repeats")], "3");
    }
    let counters = |kind: &str| rows[kinds.iter().position(|k| *k == kind).unwrap()][col("counters_per_s")].to_string();
    assert!(counters("light").contains("light_paths="), "{}", counters("light"));
    assert!(counters("sppm").contains("photon_paths="), "{}", counters("sppm"));

    let o = bench(
        root,
        &["perf", "--scene", "scenes/tiny.toml", "--strategies", "path,nope"],
    );
    assert_refused(&o, &["--strategies", "unknown strategy kind `nope`", "bdpt"]);
}

/// The perf suite round trip: `bench perf --experiment` measures an experiment's labelled
/// strategies at their own `spp`; `bench compare --perf` finds nothing against the same run,
/// flags (exit 1) a case made slower than its measured spread allows, and refuses a file that
/// is not a perf CSV in one line.
#[test]
fn perf_suite_measures_an_experiment_and_compare_flags_a_slowdown() {
    let dir = project();
    let root = dir.path();
    let suite = "scenes = [\"../scenes/tiny.toml\"]\nspp = [1, 4]\nseeds = 1\n\
        [[strategy]]\nkind = \"path\"\nspp = [4]\n\
        [[strategy]]\nkind = \"light\"\nlabel = \"light-rr0\"\nrr_depth = 0\nspp = [1]\n";
    std::fs::write(root.join("experiments/suite.toml"), suite).unwrap();
    let o = bench(
        root,
        &[
            "perf",
            "--experiment",
            "experiments/suite.toml",
            "--repeats",
            "3",
            "--csv",
            "base.csv",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(root.join("base.csv")).unwrap();
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let headers = reader.headers().unwrap().clone();
    let col = |name: &str| headers.iter().position(|h| h == name).unwrap();
    let rows: Vec<csv::StringRecord> = reader.records().map(Result::unwrap).collect();
    let cells: Vec<(&str, &str, &str)> = rows
        .iter()
        .map(|r| (&r[col("label")], &r[col("samples")], &r[col("params")]))
        .collect();
    assert_eq!(
        cells,
        [
            ("path", "4", "{}"),
            ("light-rr0", "1", "{ rr_depth = 0 }"),
            ("machine-calibration", "0", "{}")
        ]
    );

    let o = bench(root, &["compare", "--perf", "base.csv", "base.csv"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stdout));
    assert!(String::from_utf8_lossy(&o.stdout).contains("0 slower"));

    // The verdicts on fixed numbers (the measured ranges depend on the machine's load): each
    // case's range set to ±1 % of its median, and a candidate in which `path` renders at a
    // third of the baseline's rate.
    let write = |name: &str, slow: f64| {
        let mut w = csv::Writer::from_path(root.join(name)).unwrap();
        w.write_record(&headers).unwrap();
        for r in &rows {
            let mut r: Vec<String> = r.iter().map(String::from).collect();
            let scale = if r[col("label")] == "path" { slow } else { 1.0 };
            let median = r[col("pixel_samples_per_s")].parse::<f64>().unwrap() * scale;
            for (c, f) in [
                ("pixel_samples_per_s", 1.0),
                ("pixel_samples_per_s_min", 0.99),
                ("pixel_samples_per_s_max", 1.01),
            ] {
                r[col(c)] = (median * f).to_string();
            }
            w.write_record(&r).unwrap();
        }
        w.flush().unwrap();
    };
    write("fixed.csv", 1.0);
    write("slow.csv", 1.0 / 3.0);
    let o = bench(root, &["compare", "--perf", "fixed.csv", "slow.csv"]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(1), "{stdout}");
    let flagged: Vec<&str> = stdout.lines().filter(|l| l.contains("SLOWER")).collect();
    assert!(flagged.len() == 1 && flagged[0].contains("path"), "{stdout}");

    std::fs::write(root.join("bad.csv"), "a,b\n1,2\n").unwrap();
    let o = bench(root, &["compare", "--perf", "base.csv", "bad.csv"]);
    assert_refused(&o, &["bad.csv", "bench perf --csv"]);
}

/// `--param NAME=VALUE` is for Mitsuba scenes: on a TOML scene, or without `=`, it is refused
/// in one line and nothing is written.
#[test]
fn scene_parameters_on_the_command_line_are_checked() {
    let dir = project();
    let root = dir.path();
    let o = bench(
        root,
        &["reference", "scenes/tiny.toml", "--spp", "1", "--param", "fov=30"],
    );
    assert_refused(&o, &["tiny.toml", "\"fov\"", "Mitsuba XML"]);
    let o = bench(root, &["reference", "scenes/tiny.toml", "--spp", "1", "--param", "fov"]);
    assert_refused(&o, &["--param", "NAME=VALUE"]);
    assert!(!root.join("references").exists());
}

/// A reference of a Mitsuba scene rendered with `--param` names itself after the parameters
/// and its sidecar's command repeats them, so that the command remakes the same reference.
#[test]
fn a_parametrised_reference_records_its_parameters() {
    let dir = project();
    let root = dir.path();
    std::fs::write(
        root.join("scenes/p.xml"),
        r#"<scene version="3.0.0">
    <default name="fov" value="40"/>
    <sensor type="perspective">
        <float name="fov" value="$fov"/>
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film>
    </sensor>
    <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter></shape>
</scene>"#,
    )
    .unwrap();
    let o = bench(root, &["reference", "scenes/p.xml", "--spp", "1", "--param", "fov=30"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let sidecar = std::fs::read_to_string(root.join("references/p-fov-30.json")).unwrap();
    let info: serde_json::Value = serde_json::from_str(&sidecar).unwrap();
    let command = info["command"].as_str().unwrap();
    assert!(
        command.starts_with("bench reference scenes/p.xml --param fov=30 --spp 1"),
        "{command}"
    );
}
