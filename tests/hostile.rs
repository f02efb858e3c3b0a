//! The hostile-input corpus `tests/hostile/` through the `bench` binary.
//!
//! - `scenes/*.toml` (with OBJ files under `scenes/meshes/`): broken scenes. Each goes through
//!   `bench run` (an experiment naming it) and `bench reference`.
//! - `experiments/*.toml`: broken experiment files, through `bench run`.
//! - `valid/*.toml`: scenes that look hostile but are valid (a camera inside a closed box, a
//!   zero-power light beside a real one, micrometre and 10⁶ scales …): `bench reference`
//!   renders them.
//!
//! Every broken file says what it breaks in its first comment and lists the substrings its
//! error must contain in `# expect: …` lines (the field, and what was expected); an experiment
//! whose error lies in a scene it names says which in `# names: <scene file>`. For each, the
//! binary must exit with status 2, print exactly one line on stderr, `error: <file>: …`,
//! containing every expected substring, never panic, and create no file anywhere in the
//! (copied) corpus directory, the output directories included.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/hostile")
}

/// Copies the corpus into a fresh temporary directory (the binary runs there).
fn copy_corpus() -> tempfile::TempDir {
    fn copy(from: &Path, to: &Path) {
        std::fs::create_dir_all(to).unwrap();
        for entry in std::fs::read_dir(from).unwrap() {
            let entry = entry.unwrap();
            let target = to.join(entry.file_name());
            if entry.file_type().unwrap().is_dir() {
                copy(&entry.path(), &target);
            } else {
                std::fs::copy(entry.path(), &target).unwrap();
            }
        }
    }
    let dir = tempfile::tempdir().unwrap();
    copy(&corpus(), dir.path());
    dir
}

/// Every file and directory under `root`, relative to it.
fn listing(root: &Path) -> BTreeSet<PathBuf> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeSet<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            out.insert(path.strip_prefix(root).unwrap().to_path_buf());
            if path.is_dir() {
                walk(root, &path, out);
            }
        }
    }
    let mut out = BTreeSet::new();
    walk(root, root, &mut out);
    out
}

/// The `*.toml` files of a corpus directory with their `# expect:` (or `# warns:`) lines.
fn entries(sub: &str, tag: &str) -> Vec<(String, Vec<String>)> {
    let dir = corpus().join(sub);
    let mut out = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|x| x != "toml") {
            continue;
        }
        let text = String::from_utf8_lossy(&std::fs::read(&path).unwrap()).into_owned();
        let expects = text
            .lines()
            .filter_map(|l| l.strip_prefix(tag))
            .map(|l| l.trim().to_string())
            .collect();
        out.push((path.file_name().unwrap().to_string_lossy().into_owned(), expects));
    }
    out.sort();
    assert!(!out.is_empty(), "no corpus under {}", dir.display());
    out
}

fn bench(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bench"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

/// Runs `bench args` in `root` and checks the refusal; returns a description of what is wrong,
/// if anything.
fn refusal_problems(root: &Path, args: &[&str], file: &str, expects: &[String]) -> Vec<String> {
    let before = listing(root);
    let o = bench(root, args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    let mut problems = Vec::new();
    let what = format!("`bench {}`", args.join(" "));
    if o.status.code() != Some(2) {
        problems.push(format!("{what}: exit status {:?}, expected 2", o.status.code()));
    }
    if err.contains("panicked") {
        problems.push(format!("{what}: panicked: {err}"));
    }
    let lines: Vec<&str> = err.lines().collect();
    if lines.len() != 1 {
        problems.push(format!("{what}: {} lines on stderr, expected 1: {err:?}", lines.len()));
    }
    let prefix = format!("error: {file}: ");
    if !err.starts_with(&prefix) {
        problems.push(format!("{what}: stderr does not start with {prefix:?}: {err:?}"));
    }
    for e in expects {
        if !err.contains(e.as_str()) {
            problems.push(format!("{what}: expected {e:?} in {err:?}"));
        }
    }
    let created: Vec<_> = listing(root).difference(&before).cloned().collect();
    if !created.is_empty() {
        problems.push(format!("{what}: created {created:?}"));
    }
    problems
}

#[test]
fn every_hostile_scene_is_refused_with_one_line_naming_file_and_field_and_writes_nothing() {
    let dir = copy_corpus();
    let root = dir.path();
    let mut problems = Vec::new();
    let scenes = entries("scenes", "# expect:");
    assert!(scenes.len() >= 60, "the corpus shrank: {}", scenes.len());
    for (name, expects) in &scenes {
        assert!(!expects.is_empty(), "scenes/{name} lists no `# expect:`");
        let scene = format!("scenes/{name}");
        // An experiment that would render the scene into `out/`.
        std::fs::write(
            root.join("hostile-scene.toml"),
            format!("scenes = [\"{scene}\"]\nspp = [1]\noutput = \"out\"\nreferences = \"refs\"\n[[strategy]]\nkind = \"path\"\n"),
        )
        .unwrap();
        problems.extend(refusal_problems(root, &["run", "hostile-scene.toml"], &scene, expects));
        problems.extend(refusal_problems(
            root,
            &["reference", &scene, "--spp", "1", "--out", "refs"],
            &scene,
            expects,
        ));
    }
    assert!(
        problems.is_empty(),
        "{} problems:\n{}",
        problems.len(),
        problems.join("\n")
    );
}

#[test]
fn every_hostile_experiment_is_refused_with_one_line_naming_file_and_field_and_writes_nothing() {
    let dir = copy_corpus();
    let root = dir.path();
    let mut problems = Vec::new();
    let experiments = entries("experiments", "# expect:");
    assert!(experiments.len() >= 25, "the corpus shrank: {}", experiments.len());
    for (name, expects) in &experiments {
        assert!(!expects.is_empty(), "experiments/{name} lists no `# expect:`");
        let file = format!("experiments/{name}");
        // An error in a scene the experiment names starts with that scene (`# names:`).
        let text = std::fs::read_to_string(root.join(&file)).unwrap();
        let named = text.lines().find_map(|l| l.strip_prefix("# names: ")).unwrap_or(&file);
        problems.extend(refusal_problems(root, &["run", &file], named, expects));
    }
    assert!(
        problems.is_empty(),
        "{} problems:\n{}",
        problems.len(),
        problems.join("\n")
    );
}

/// Odd but valid scenes render; a camera inside a closed box whose only light is outside sees
/// black. A camera inside closed geometry is not an error: it cannot be detected cheaply in
/// general (any closed mesh), and it is a legitimate scene (an interior).
#[test]
fn hostile_looking_valid_scenes_render() {
    let dir = copy_corpus();
    let root = dir.path();
    for (name, warns) in entries("valid", "# warns:") {
        let scene = format!("valid/{name}");
        let o = bench(root, &["reference", &scene, "--spp", "2", "--out", "refs"]);
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{scene}: {err}");
        assert!(!err.contains("panicked"), "{scene}: {err}");
        assert_eq!(err.lines().count(), warns.len().min(1), "{scene}: {err}");
        for w in &warns {
            assert!(err.contains(w.as_str()), "{scene}: expected {w:?} in {err:?}");
        }
        let stem = name.trim_end_matches(".toml");
        let image = photon_bench::film::read_exr(&root.join("refs").join(format!("{stem}.exr"))).unwrap();
        assert!(image.pixels.iter().all(|p| p.is_finite()), "{scene}");
        let mean = image.mean();
        if stem == "camera-inside-closed-box" {
            assert!(
                image.pixels.iter().all(|p| *p == glam::Vec3::ZERO),
                "light leaks in: {mean}"
            );
        } else if stem != "resolution-one-pixel" {
            assert!(mean.max_element() > 0.0, "{scene} renders black");
        }
    }
}

/// 10⁹ × 10⁹ pixels would need 10¹⁸ pixel accumulators: refused from the numbers alone, in
/// well under a second (an attempt to allocate would abort or take forever).
#[test]
fn an_absurd_resolution_is_refused_before_any_allocation() {
    let dir = copy_corpus();
    let start = std::time::Instant::now();
    let o = bench(
        dir.path(),
        &[
            "reference",
            "scenes/resolution-absurd.toml",
            "--spp",
            "1",
            "--out",
            "refs",
        ],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(start.elapsed().as_secs_f64() < 5.0, "{:?}", start.elapsed());
}

/// A film within the side and pixel limits but over the memory limit is refused when the scene
/// loads, before any film exists; `PHOTON_BENCH_MEMORY_LIMIT` sets the limit.
#[test]
fn a_film_over_the_memory_limit_is_refused_and_one_under_it_renders() {
    let dir = copy_corpus();
    let root = dir.path();
    let scene = std::fs::read_to_string(root.join("valid/tiny.toml"))
        .unwrap()
        .replace("resolution = [8, 6]", "resolution = [8192, 8192]");
    std::fs::write(root.join("big.toml"), scene).unwrap();
    let before = listing(root);
    let o = Command::new(env!("CARGO_BIN_EXE_bench"))
        .current_dir(root)
        .env("PHOTON_BENCH_MEMORY_LIMIT", "1G")
        .args(["reference", "big.toml", "--spp", "1", "--out", "refs"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(
        err.trim_end(),
        "error: big.toml: camera.resolution: a 8192 × 8192 film needs about 2.75 GiB, more than the \
         memory limit of 1.00 GiB (set PHOTON_BENCH_MEMORY_LIMIT to change it)"
    );
    assert_eq!(listing(root), before);
    // The same limit lets a small film through; a malformed limit is an error, not ignored.
    for (limit, ok) in [("1G", true), ("lots", false)] {
        let o = Command::new(env!("CARGO_BIN_EXE_bench"))
            .current_dir(root)
            .env("PHOTON_BENCH_MEMORY_LIMIT", limit)
            .args(["reference", "valid/tiny.toml", "--spp", "1", "--out", "refs", "--force"])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.success(), ok, "{limit}: {err}");
        if !ok {
            assert!(err.starts_with("error: PHOTON_BENCH_MEMORY_LIMIT: "), "{err}");
        }
    }
}
