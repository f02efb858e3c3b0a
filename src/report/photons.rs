//! Links to the photon-map figures a run wrote beside its renders ([`crate::figure`]: the
//! strategies draw them, the run writes them). [`crate::figure::FIGURES`] lists every suffix
//! with its caption; `summary.md` and `index.html` link the files that exist ([`figure_links`]).
//! Like every report, this sees only result rows and the files in the run directory.

use super::rows::Row;
use crate::figure::FIGURES;
use std::path::Path;

/// The figures of `scene`'s cells that exist in the run directory `dir`: (path relative to
/// `dir`, caption naming the strategy and seed), cell by cell in row order, each cell's in
/// [`FIGURES`] order.
pub fn figure_links(rows: &[Row], scene: &str, dir: &Path) -> Vec<(String, String)> {
    let mut cells: Vec<(String, &str, u64)> = Vec::new();
    for r in rows.iter().filter(|r| r.scene == scene) {
        // `images/<cell>_spp<N>.exr` or `images/<cell>_t<T>s.exr`: the cell is all before the last `_`.
        let image = Path::new(&r.image);
        let Some(stem) = image.file_stem().map(|s| s.to_string_lossy().into_owned()) else {
            continue;
        };
        let cell = stem.rsplit_once('_').map_or(stem.as_str(), |(a, _)| a);
        let prefix = image.with_file_name(cell).display().to_string();
        if !cells.iter().any(|(p, _, _)| *p == prefix) {
            cells.push((prefix, &r.strategy, r.seed));
        }
    }
    let mut links = Vec::new();
    for (prefix, strategy, seed) in cells {
        for (suffix, caption) in FIGURES {
            let rel = format!("{prefix}{suffix}");
            if dir.join(&rel).is_file() {
                links.push((rel, format!("{strategy} · seed {seed} · {caption}")));
            }
        }
    }
    links
}

/// The `summary.md` section of [`figure_links`] (empty when there is none).
pub fn markdown(rows: &[Row], scene: &str, dir: &Path) -> String {
    let links = figure_links(rows, scene, dir);
    if links.is_empty() {
        return String::new();
    }
    let mut md = String::from(
        "### photon-map figures\n\nChristensen 1999, Fig. 1, for each photon-map cell. Radiance and E/π are \
         shown like the renders (linear, clamped to 1, sRGB); photon counts on a log scale.\n\n",
    );
    for (rel, caption) in links {
        md.push_str(&format!("- [{caption}]({rel})\n"));
    }
    md.push('\n');
    md
}
