//! Reporting: turns result rows and images into files a researcher reads: the CSV, plots and
//! the run summary. Like [`crate::metrics`], it never sees a scene.
//!
//! What lives here: CSV rows, statistics over seeds, plots, `summary.md`, `index.html`,
//! `bench compare`. Reports read result rows and the image files of a run directory, nothing
//! else: no scene, no strategy, no experiment file; what a strategy wants shown it writes as a
//! figure ([`crate::figure`]).

pub mod bars;
pub mod compare;
pub mod convergence;
pub mod counters;
pub mod final_gather;
pub mod html;
pub mod photons;
pub mod plot;
pub mod ratios;
pub mod rows;
pub mod stats;

pub use convergence::{write_plots, write_summary};

/// `bench plot`: redraws every plot of a run directory from its `metrics.csv` alone.
pub fn redraw(run_dir: &std::path::Path) -> crate::error::Result<()> {
    let csv = run_dir.join("metrics.csv");
    if !csv.is_file() {
        return Err(crate::error::Error::new(format!(
            "{}: no metrics.csv; expected a run directory",
            run_dir.display()
        )));
    }
    let rows = rows::read_csv(&csv)?;
    if rows.is_empty() {
        return Err(crate::error::Error::new(format!("{}: no rows", csv.display())));
    }
    write_plots(&rows, run_dir)
}
