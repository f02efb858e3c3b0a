//! The cell cache: a cell (scene × strategy × seed) is stored under the hash of everything
//! that produced it (scene and reference hashes, strategy and every parameter, seed, binary),
//! reused on resume and across shards, and linked into each run directory.

use super::*;
use crate::error::{Context, Result};
use crate::experiment::config::StrategySpec;
use crate::experiment::reference::Reference;
use crate::report::rows::{Row, read_csv, write_csv};
use crate::scene::Scene;
use std::path::{Path, PathBuf};

/// Copies a complete cell directory into the cache under `hash`, atomically.
pub(super) fn copy_cell(source: &Path, cells: &Path, hash: &str) -> Result<()> {
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
pub(super) fn image_files(exr: &Path) -> [PathBuf; 3] {
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

/// Identifies the binary for cell hashes: the package version and a hash of the executable,
/// so that any rebuild with changed code invalidates the cache.
pub(super) fn binary_id() -> &'static str {
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
pub(super) fn load_cell(cell: &Path) -> Option<Vec<Row>> {
    let rows = read_csv(&cell.join("rows.csv")).ok()?;
    rows.iter().all(|r| cell.join(&r.image).exists()).then_some(rows)
}

/// Renders a cell into `<cells>/.tmp-<hash>-<pid>@<host>/` and renames it to `<cells>/<hash>/`.
/// The name itself names the writer, so a process killed between creating the directory and
/// writing its [`OWNER`] file still leaves a temporary the next run can attribute.
pub(super) fn store_cell(cells: &Path, hash: &str, render: impl FnOnce(&Path) -> Result<Vec<Row>>) -> Result<Vec<Row>> {
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

/// Links (or copies, across file systems) a cell's images into the run directory.
pub(super) fn link_images(cell: &Path, rows: &[Row], dir: &Path) -> Result<()> {
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
