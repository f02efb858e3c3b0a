//! Every experiment file the repository ships parses, validates, and builds every strategy it
//! names with its parameters: a typo in one (a parameter renamed in the code, a scene file
//! moved) is caught here instead of minutes into a run.

use photon_bench::experiment::config::Experiment;

#[test]
fn every_shipped_experiment_file_is_valid() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 5, "{files:?}");
    for file in files {
        let exp = Experiment::load(&file).unwrap_or_else(|e| panic!("{e}"));
        for scene in &exp.scenes {
            assert!(
                scene.file.is_file(),
                "{}: scene {} is missing",
                file.display(),
                scene.file.display()
            );
        }
        for spec in &exp.strategies {
            spec.instantiate()
                .unwrap_or_else(|e| panic!("{}: {}: {e}", file.display(), spec.label));
        }
    }
}
