//! Sampling: warps from the unit square (each `sample_*` with its `*_pdf` sibling), seeded
//! random-number streams, discrete distributions and multiple importance sampling weights.

pub mod chi2;
pub mod distribution;
pub mod photon_grid;
pub mod rng;
pub mod warp;

pub use distribution::Distribution1D;
pub use rng::{Rng, stream_seed};
pub use warp::*;

/// Power heuristic with β = 2 [Veach 1997, eq. (9.13)], one sample from each strategy.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a2, b2) = (pdf_a * pdf_a, pdf_b * pdf_b);
    if a2.is_infinite() {
        return 1.0;
    }
    if a2 + b2 == 0.0 { 0.0 } else { a2 / (a2 + b2) }
}
