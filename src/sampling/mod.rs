//! Sampling: warps from the unit square (each `sample_*` with its `*_pdf` sibling), seeded
//! random-number streams and their purposes ([`stream`]), discrete distributions and multiple importance sampling weights.
//!
//! What lives here: the numerical building blocks every estimator uses; nothing here knows
//! about scenes, BSDFs or strategies. Every stream purpose of the crate is listed in [`stream`]
//! and nowhere else.

pub mod chi2;
pub mod distribution;
pub mod photon_grid;
pub mod rng;
pub mod stream;
pub mod warp;

pub use distribution::Distribution1D;
pub use rng::{Rng, stream_seed};
pub use warp::*;

use glam::Vec2;

/// Power heuristic with β = 2 [Veach 1997, eq. (9.13)], one sample from each strategy.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a2, b2) = (pdf_a * pdf_a, pdf_b * pdf_b);
    if a2.is_infinite() {
        return 1.0;
    }
    if a2 + b2 == 0.0 { 0.0 } else { a2 / (a2 + b2) }
}

/// A stratified 2-D point set of `n` points (Latin hypercube: each coordinate hits each of
/// its n strata once, each point is uniform on [0, 1)²).
pub fn latin_hypercube(n: usize, rng: &mut Rng) -> Vec<Vec2> {
    let mut perm: Vec<u32> = (0..n as u32).collect();
    for i in (1..n).rev() {
        let j = ((rng.uniform() * (i + 1) as f32) as usize).min(i);
        perm.swap(i, j);
    }
    let inv = 1.0 / n as f32;
    (0..n)
        .map(|i| {
            let u = rng.uniform2();
            Vec2::new(
                ((i as f32 + u.x) * inv).min(1.0 - f32::EPSILON),
                ((perm[i] as f32 + u.y) * inv).min(1.0 - f32::EPSILON),
            )
        })
        .collect()
}
