//! Records the git revision the binary is built from (not the directory it later runs in):
//! `PHOTON_BENCH_GIT_REVISION` is the commit (12 hex digits) with `-dirty` when the sources
//! that go into the binary (`src/`, `build.rs`, `Cargo.toml`, `Cargo.lock`) differ from it, or
//! `unknown` outside a git checkout (a source tarball).

use std::path::Path;
use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let dir = std::env::var("CARGO_MANIFEST_DIR").ok()?;
    let out = Command::new("git").arg("-C").arg(dir).args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    for path in ["src", "build.rs", "Cargo.toml", "Cargo.lock"] {
        println!("cargo:rerun-if-changed={path}");
    }
    let revision = match git(&["rev-parse", "--short=12", "HEAD"]) {
        Some(commit) if !commit.is_empty() => {
            let status = git(&[
                "status",
                "--porcelain",
                "--",
                "src",
                "build.rs",
                "Cargo.toml",
                "Cargo.lock",
            ]);
            let dirty = status.is_none_or(|s| !s.is_empty());
            if let Some(git_dir) = git(&["rev-parse", "--absolute-git-dir"]) {
                // Commits, checkouts and staging change these; edits to the sources above
                // re-run this script through their own rerun-if-changed lines.
                for file in ["HEAD", "index", "logs/HEAD", "packed-refs"] {
                    let p = Path::new(&git_dir).join(file);
                    if p.exists() {
                        println!("cargo:rerun-if-changed={}", p.display());
                    }
                }
            }
            if dirty { format!("{commit}-dirty") } else { commit }
        }
        _ => "unknown".to_string(),
    };
    println!("cargo:rustc-env=PHOTON_BENCH_GIT_REVISION={revision}");
}
