//! # photon-bench
//!
//! A benchmarking harness for Monte Carlo light transport. Strategies run side by side on
//! shared scenes; their images are compared with converged references and the error, timings
//! and everything that produced them are recorded as CSV, images and plots.
//!
//! Strategies (one module each under [`strategy`]):
//! - `path`: unidirectional path tracing with BSDF importance sampling, next-event estimation
//!   and multiple importance sampling (Veach 1997, ch. 9), the baseline of every paper below.
//!
//! Papers this harness reproduces as strategies land: Jensen 1995, "Importance Driven Path
//! Tracing using the Photon Map"; Christensen 1999, "Faster Photon Map Global Illumination";
//! Fan, Chenney & Lai 2005, "Metropolis Photon Sampling".
//!
//! Data flows one way: experiment file → plan → scene → strategy → film → metrics → report.

pub mod bsdf;
pub mod camera;
pub mod color;
pub mod error;
pub mod experiment;
pub mod figure;
pub mod film;
pub mod geometry;
pub mod light;
pub mod medium;
pub mod metrics;
pub mod metropolis;
pub mod params;
pub mod path_space;
pub mod perf;
pub mod photon;
pub mod pixel_filter;
pub mod report;
pub mod resources;
pub mod sampling;
pub mod scene;
pub mod spectrum;
pub mod strategy;
pub mod texture;
pub mod util;

pub use error::{Error, Result};
