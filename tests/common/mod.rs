//! Helpers shared by the integration tests.

use std::path::Path;

/// A temporary project: `scenes/tiny.toml` (cornell-empty at 16 × 12) and
/// `experiments/tiny.toml` holding `experiment`.
pub fn tiny_project(experiment: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    for sub in ["scenes", "experiments"] {
        std::fs::create_dir_all(root.join(sub)).unwrap();
    }
    let scene = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-empty.toml"))
        .unwrap()
        .replace("resolution = [80, 60]", "resolution = [16, 12]");
    std::fs::write(root.join("scenes/tiny.toml"), scene).unwrap();
    std::fs::write(root.join("experiments/tiny.toml"), experiment).unwrap();
    dir
}
