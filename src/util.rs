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

/// Largest experiment, scene (TOML or Mitsuba XML) or sidecar file read: far above any real
/// one (the largest shipped scene is a few kB; a Mitsuba scene inlining its geometry a few MB).
pub const MAX_TEXT_INPUT: u64 = 64 << 20;
/// Largest mesh file read (OBJ, PLY, Mitsuba's serialized): meshes are read whole into memory,
/// and 4 GiB is beyond the triangle limit of a scene ([`crate::scene::limits`]).
pub const MAX_MESH_INPUT: u64 = 4 << 30;
/// Largest EXR read (a reference or a run's image): 4 GiB holds a 16k × 16k RGBA f32 image.
pub const MAX_IMAGE_INPUT: u64 = 4 << 30;
/// Largest CSV read (`metrics.csv` of a run): millions of rows.
pub const MAX_CSV_INPUT: u64 = 4 << 30;

/// Checks that `path` is a regular file (after symbolic links) of at most `limit` bytes, before
/// anything reads it: a device (`/dev/zero`), FIFO, socket or directory would read forever or
/// fail late, and a file larger than any real input of its kind would fill memory. `what`
/// names the kind of input in the one-line error ("experiment file", "mesh").
pub fn check_input(path: &Path, what: &str, limit: u64) -> Result<u64> {
    let meta = std::fs::metadata(path)
        .map_err(|e| crate::error::Error::new(format!("{}: cannot read the {what}: {e}", path.display())))?;
    if !meta.is_file() {
        return Err(crate::error::Error::new(format!(
            "{}: expected a regular file (the {what}), found {}",
            path.display(),
            file_kind(&meta)
        )));
    }
    if meta.len() > limit {
        return Err(too_large(path, what, meta.len(), limit));
    }
    Ok(meta.len())
}

fn too_large(path: &Path, what: &str, size: u64, limit: u64) -> crate::error::Error {
    crate::error::Error::new(format!(
        "{}: {} is larger than any {what} (limit {})",
        path.display(),
        human_bytes(size),
        human_bytes(limit)
    ))
}

/// What a non-regular file is, for messages.
fn file_kind(meta: &std::fs::Metadata) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    let t = meta.file_type();
    if t.is_dir() {
        "a directory"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_fifo() {
        "a FIFO (named pipe)"
    } else if t.is_socket() {
        "a socket"
    } else {
        "something other than a file"
    }
}

/// `3.1 GiB`, `640 KiB`, `12 B`.
pub fn human_bytes(n: u64) -> String {
    let units = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = n as f64;
    let mut k = 0;
    while v >= 1024.0 && k + 1 < units.len() {
        v /= 1024.0;
        k += 1;
    }
    if k == 0 {
        format!("{n} B")
    } else {
        format!("{v:.1} {}", units[k])
    }
}

/// Reads an input file whole after [`check_input`], and never more than `limit` bytes even if
/// the file grows while it is read.
pub fn read_input(path: &Path, what: &str, limit: u64) -> Result<Vec<u8>> {
    use std::io::Read;
    let size = check_input(path, what, limit)?;
    let file = std::fs::File::open(path)
        .map_err(|e| crate::error::Error::new(format!("{}: cannot read the {what}: {e}", path.display())))?;
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| crate::error::Error::new(format!("{}: cannot read the {what}: {e}", path.display())))?;
    if bytes.len() as u64 > limit {
        return Err(too_large(path, what, bytes.len() as u64, limit));
    }
    Ok(bytes)
}

/// Whether `path` ends in `.gz` (any case): a gzip-compressed file, as pbrt-v4 reads them.
pub fn is_gzip(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("gz"))
}

/// The bytes of a gzip stream, decompressed; at most `limit` bytes of output (a message, not a
/// panic, for a damaged stream or one that would expand beyond it).
pub fn gunzip(bytes: &[u8], limit: u64) -> std::result::Result<Vec<u8>, String> {
    use std::io::Read;
    let mut out = Vec::new();
    flate2::read::GzDecoder::new(bytes)
        .take(limit + 1)
        .read_to_end(&mut out)
        .map_err(|e| format!("not a readable gzip stream: {e}"))?;
    if out.len() as u64 > limit {
        return Err(format!("expands to more than {limit} bytes"));
    }
    Ok(out)
}

/// [`read_input`] of a UTF-8 text file.
pub fn read_input_to_string(path: &Path, what: &str, limit: u64) -> Result<String> {
    String::from_utf8(read_input(path, what, limit)?).map_err(|e| {
        crate::error::Error::new(format!(
            "{}: the {what} is not valid UTF-8 (first bad byte at offset {})",
            path.display(),
            e.utf8_error().valid_up_to()
        ))
    })
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

/// A label as used in file names: characters outside letters, digits, `-`, `_` and `.` become
/// `-`, runs of `-` one, and none at the end (`path[max_depth=4]` → `path-max_depth-4`).
pub fn file_stem(label: &str) -> String {
    let mapped: String = label
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '-'
            }
        })
        .collect();
    let mut out = String::with_capacity(mapped.len());
    for c in mapped.chars() {
        if !(c == '-' && out.ends_with('-')) {
            out.push(c);
        }
    }
    out.trim_end_matches('-').to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inputs_that_are_not_regular_files_or_too_large_are_refused_before_reading() {
        let dir = tempfile::tempdir().unwrap();
        let msg = |r: Result<Vec<u8>>| r.unwrap_err().to_string();
        let zero = msg(read_input(Path::new("/dev/zero"), "scene file", MAX_TEXT_INPUT));
        assert_eq!(
            zero,
            "/dev/zero: expected a regular file (the scene file), found a character device"
        );
        let d = msg(read_input(dir.path(), "mesh", MAX_MESH_INPUT));
        assert!(
            d.ends_with("expected a regular file (the mesh), found a directory"),
            "{d}"
        );
        let fifo = dir.path().join("pipe");
        assert!(
            std::process::Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .unwrap()
                .success()
        );
        // Opening a FIFO without a writer would block: the check must come first.
        assert!(msg(read_input(&fifo, "experiment file", MAX_TEXT_INPUT)).ends_with("found a FIFO (named pipe)"));
        let big = dir.path().join("big.toml");
        std::fs::write(&big, vec![b'#'; 3000]).unwrap();
        assert_eq!(
            msg(read_input(&big, "experiment file", 2048)),
            format!(
                "{}: 2.9 KiB is larger than any experiment file (limit 2.0 KiB)",
                big.display()
            )
        );
        assert_eq!(read_input(&big, "experiment file", 3000).unwrap().len(), 3000);
        assert!(msg(read_input(&dir.path().join("absent"), "mesh", 10)).contains("cannot read the mesh"));
        std::fs::write(&big, [0xff, 0xfe]).unwrap();
        assert!(msg(read_input_to_string(&big, "scene file", 10).map(String::into_bytes)).contains("not valid UTF-8"));
        assert_eq!(human_bytes(3 << 30), "3.0 GiB");
    }

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
