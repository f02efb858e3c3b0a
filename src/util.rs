//! Small shared utilities: content hashes, atomic file writes, provenance.

use crate::error::{Context, Result};
use std::path::{Component, Path, PathBuf};

/// 64-bit FNV-1a over bytes, as 16 hex digits. Used to identify scene, reference and
/// configuration content in result rows (not for security).
pub fn content_hash(parts: &[&[u8]]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for part in parts {
        for &b in *part {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
        // Separate parts so that ("ab", "c") and ("a", "bc") differ.
        h ^= 0xff;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// Writes `bytes` to `path` atomically: a temporary file in the same directory, flushed and
/// synced, then renamed over the target. A reader never sees a partial file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(path, |tmp| std::fs::write(tmp, bytes).context(tmp.display()))
}

/// Runs `write` on a temporary path beside `path`, then renames it into place.
pub fn write_atomic_with(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).context(dir.display())?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let result = write(&tmp).and_then(|()| {
        std::fs::File::open(&tmp)
            .and_then(|f| f.sync_all())
            .context(tmp.display())?;
        std::fs::rename(&tmp, path).context(path.display())
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Joins `rel` to `base` and removes `.` and `name/..` pairs lexically, so that messages show
/// `scenes/x.toml` rather than `experiments/../scenes/x.toml`. Absolute `rel` wins.
pub fn join_clean(base: &Path, rel: &str) -> PathBuf {
    let mut out = PathBuf::new();
    for c in base.join(rel).components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir if matches!(out.components().next_back(), Some(Component::Normal(_))) => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    if out.as_os_str().is_empty() {
        PathBuf::from(".")
    } else {
        out
    }
}

/// The git revision the binary was built from: the commit, `-dirty` when the sources that went
/// into the binary differed from it, `unknown` when built outside a git checkout (`build.rs`).
/// Fixed at compile time, so it does not depend on the directory the binary runs in.
pub fn git_revision() -> String {
    env!("PHOTON_BENCH_GIT_REVISION").to_string()
}

/// The CPU model name from /proc/cpuinfo, or "unknown".
pub fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hash_separates_parts_and_is_stable() {
        assert_ne!(content_hash(&[b"ab", b"c"]), content_hash(&[b"a", b"bc"]));
        assert_eq!(content_hash(&[b"scene"]), content_hash(&[b"scene"]));
        assert_eq!(content_hash(&[b"x"]).len(), 16);
    }

    #[test]
    fn join_clean_removes_dot_dot_lexically() {
        assert_eq!(
            join_clean(Path::new("experiments"), "../scenes/a.toml"),
            Path::new("scenes/a.toml")
        );
        assert_eq!(join_clean(Path::new(""), "../a"), Path::new("../a"));
        assert_eq!(join_clean(Path::new("x/y"), "./../../z"), Path::new("z"));
        assert_eq!(join_clean(Path::new("x"), "/abs/b"), Path::new("/abs/b"));
        assert_eq!(join_clean(Path::new("x"), ".."), Path::new("."));
    }

    #[test]
    fn atomic_write_replaces_content_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
