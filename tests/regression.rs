//! The regression check: `experiments/ci.toml` (a tiny scene, few samples, three seeds) run
//! now must not be significantly worse than the committed run in `results/baseline/`
//! (`bench compare` exits 0); a candidate whose error grew must be flagged (exit 1); bad
//! input is refused (exit 2).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bench(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bench")).args(args).output().unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// `experiments/ci.toml` with its scenes and references taken from this repository and its
/// results written into `out`.
fn ci_experiment(out: &Path) -> PathBuf {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let ci = std::fs::read_to_string(repo.join("experiments/ci.toml")).unwrap();
    let scenes = format!(
        "scenes = [\"{}\"]\nreferences = \"{}\"\noutput = \"{}\"",
        repo.join("scenes/ci-tiny.toml").display(),
        repo.join("references").display(),
        out.join("results").display()
    );
    let text = ci.replace("scenes = [\"../scenes/ci-tiny.toml\"]", &scenes);
    assert_ne!(text, ci, "experiments/ci.toml names ../scenes/ci-tiny.toml");
    let path = out.join("ci.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn the_ci_experiment_shows_no_regression_against_the_committed_baseline() {
    let tmp = tempfile::tempdir().unwrap();
    let exp = ci_experiment(tmp.path());
    let o = bench(&["run", exp.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let run = text(&o.stdout).trim().to_string();
    let baseline = Path::new(env!("CARGO_MANIFEST_DIR")).join("results/baseline");

    let o = bench(&["compare", baseline.to_str().unwrap(), &run]);
    let table = text(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{table}{}", text(&o.stderr));
    assert!(
        table.contains("0 regression(s)") && table.contains("checkpoints only in baseline: 0"),
        "{table}"
    );
    assert!(table.contains("rel_mse") && table.contains("path-uniform"), "{table}");

    // A candidate whose error grew far beyond the seed-to-seed spread is a regression.
    let mut rows = photon_bench::report::rows::read_csv(&Path::new(&run).join("metrics.csv")).unwrap();
    for r in &mut rows {
        r.mse = r.mse * 1e3 + 1e6;
    }
    let worse = tmp.path().join("worse");
    photon_bench::report::rows::write_csv(&rows, &worse.join("metrics.csv")).unwrap();
    let o = bench(&["compare", baseline.to_str().unwrap(), worse.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stdout));
    assert!(text(&o.stdout).contains("REGRESSION"));

    // Bad input: exit status 2 and one line.
    for args in [
        vec!["compare", baseline.to_str().unwrap(), "nowhere"],
        vec!["compare", "nowhere", &run],
    ] {
        let o = bench(&args);
        assert_eq!(o.status.code(), Some(2));
        assert_eq!(text(&o.stderr).trim_end().lines().count(), 1, "{}", text(&o.stderr));
    }
    // No checkpoint in common: refused too.
    let other = tmp.path().join("other");
    for r in &mut rows {
        r.scene = "elsewhere".into();
    }
    photon_bench::report::rows::write_csv(&rows, &other.join("metrics.csv")).unwrap();
    let o = bench(&["compare", baseline.to_str().unwrap(), other.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("no checkpoint"));
}
