//! Reporting: turns result rows and images into files a researcher reads: the CSV, plots and
//! the run summary. Like [`crate::metrics`], it never sees a scene.

pub mod bars;
pub mod convergence;
pub mod html;
pub mod plot;
pub mod rows;
pub mod stats;

pub use convergence::{write_plots, write_summary};
