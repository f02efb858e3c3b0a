//! Result rows: one per (scene × strategy × seed × spp checkpoint), carrying everything that
//! produced the numbers, written as a tidy CSV.

use crate::error::{Context, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One checkpoint of one run. Column order is the CSV's.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Row {
    pub experiment: String,
    pub run_id: String,
    pub scene: String,
    pub scene_hash: String,
    pub reference_hash: String,
    pub reference_spp: u32,
    /// The strategy's label in the experiment (defaults to its kind).
    pub strategy: String,
    pub kind: String,
    /// Every parameter as `key=value`, `;`-separated, defaults included.
    pub params: String,
    pub seed: u64,
    pub spp: u32,
    pub width: u32,
    pub height: u32,
    pub threads: usize,
    pub git_revision: String,
    pub cpu: String,
    /// Preparation time (all phases), seconds.
    pub prep_s: f64,
    /// Rendering time up to this checkpoint, seconds.
    pub render_s: f64,
    /// prep_s + render_s.
    pub total_s: f64,
    /// Preparation phases as `name=seconds`, `;`-separated.
    pub phases: String,
    /// Samples dropped because they were NaN or infinite.
    pub non_finite: u64,
    pub mse: f64,
    pub rmse: f64,
    pub rel_mse: f64,
    pub mse_trimmed: f64,
    pub rel_mse_trimmed: f64,
    pub rms_rel_lum: f64,
    pub rms_rel_lum_excluded: u64,
    /// 1 / (MSE · total_s).
    pub efficiency: f64,
    pub mean_r: f64,
    pub mean_g: f64,
    pub mean_b: f64,
    /// EXR image of this checkpoint, relative to the run directory.
    pub image: String,
}

/// Writes rows as CSV with a header, atomically.
pub fn write_csv(rows: &[Row], path: &Path) -> Result<()> {
    crate::util::write_atomic_with(path, |tmp| {
        let mut w = csv::Writer::from_path(tmp).context(tmp.display())?;
        for r in rows {
            w.serialize(r).context(path.display())?;
        }
        w.flush().context(path.display())
    })
}

/// Reads rows written by [`write_csv`].
pub fn read_csv(path: &Path) -> Result<Vec<Row>> {
    let mut r = csv::Reader::from_path(path).context(path.display())?;
    r.deserialize().map(|row| row.context(path.display())).collect()
}
