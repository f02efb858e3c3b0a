//! Reporting: turns result rows and images into files a researcher reads: the CSV, plots and
//! the run summary. Like [`crate::metrics`], it never sees a scene.
//!
//! What lives here: CSV rows, statistics over seeds, plots, `summary.md`, `index.html`,
//! `bench compare`. Reports read result rows and the image files of a run directory, nothing
//! else: no scene, no strategy, no experiment file; what a strategy wants shown it writes as a
//! figure ([`crate::figure`]).

pub mod bars;
pub mod chart;
pub mod compare;
pub mod convergence;
pub mod counters;
pub mod final_gather;
pub mod html;
pub mod page;
pub mod photons;
pub mod plot;
pub mod ratios;
pub mod rows;
pub mod stats;

pub use convergence::{write_plots, write_summary};

/// `bench plot`: redraws the plots of a run directory from its `metrics.csv` alone, for the
/// metrics named (unknown names are refused before anything is drawn), or for
/// [`convergence::PLOTTED_METRICS`] when none is.
pub fn redraw(run_dir: &std::path::Path, metrics: &[String]) -> crate::error::Result<()> {
    let metrics: Vec<&rows::Metric> = if metrics.is_empty() {
        convergence::PLOTTED_METRICS
            .iter()
            .map(|m| convergence::metric_named(m))
            .collect::<crate::error::Result<_>>()?
    } else {
        metrics
            .iter()
            .map(|m| convergence::metric_named(m))
            .collect::<crate::error::Result<_>>()?
    };
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
    convergence::write_plots_of(&rows, run_dir, &metrics)
}
