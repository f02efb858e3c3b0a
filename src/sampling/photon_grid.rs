//! The photon-built direction pdf of Jensen 1995, "Importance Driven Path Tracing using the
//! Photon Map", §3.
//!
//! At a diffuse point, the incoming directions of nearby photons are mapped to the unit square
//! by the inverse of the cosine warp T(u, v) = (θ, φ) = (arccos √(1 − u), 2πv) [Jensen 1995,
//! eq. (9); the text prints "cos" for "arccos"], i.e. u = sin²θ, v = φ / 2π. The photons'
//! reflected flux ΔΦ_r = f_r ΔΦ_i (luminance) is accumulated in an m × n grid over (u, v)
//! (m θ-intervals × n φ-intervals; the paper uses 4 × 16). A direction is sampled by picking a
//! cell ∝ its flux and a uniform point in it, then applying T.
//!
//! Because T maps the uniform density on the square to the cosine density on the hemisphere,
//! the solid-angle pdf of a direction in cell c is
//! p(ω) = (cos θ / π) · cells · Φ_c / Φ_total,
//! and the estimator's weight for a Lambertian surface f_r cos θ / p(ω) = ρ · Φ_total /
//! (cells · Φ_c) is the paper's scaling factor s [eq. (11)].
//!
//! Empty cells: the paper "eliminate\[s\] all regions with zero energy (probability) by adding a
//! small fraction of the overall energy stored within the unit square to these regions". Two
//! readings, both selectable ([`EmptyCells`]): the fraction ε of Φ_total is *shared* by all
//! empty cells (the project digest's decision, `NOTES.md`), or *each* empty cell receives
//! ε · Φ_total. Either way no direction of the hemisphere has zero probability, so the
//! estimator stays unbiased. With no photon at all the grid is uniform, i.e. plain cosine
//! sampling.

use super::Distribution1D;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, TAU};

crate::declare_choice! {
    /// How the energy given to empty cells is computed from ε.
    pub enum EmptyCells {
        /// All empty cells together receive ε · Φ_total.
        Shared = "shared",
        /// Every empty cell receives ε · Φ_total.
        Each = "each",
    }
}

/// Jensen's piecewise-constant pdf over the cosine-warped hemisphere (local frame, +z = n).
#[derive(Clone, Debug)]
pub struct PhotonGrid {
    /// θ-intervals (over u = sin²θ).
    m: usize,
    /// φ-intervals (over v = φ / 2π).
    n: usize,
    /// Cell selection ∝ flux, cells in row-major (u, v) order.
    cells: Distribution1D,
}

/// Cell of a local direction `w` (z > 0) in an m × n grid: the inverse warp T⁻¹.
#[inline]
fn cell_of(w: Vec3, m: usize, n: usize) -> usize {
    let mut v = w.y.atan2(w.x) / TAU;
    if v < 0.0 {
        v += 1.0;
    }
    cell_at(w, v, m, n)
}

/// Row-major cell of the local direction `w` whose v = φ / 2π is given.
#[inline]
fn cell_at(w: Vec3, v: f32, m: usize, n: usize) -> usize {
    let u = (1.0 - w.z * w.z).clamp(0.0, 1.0);
    let i = ((u * m as f32) as usize).min(m - 1);
    let j = ((v * n as f32) as usize).min(n - 1);
    i * n + j
}

/// Polynomial atan2 in [0, 2π) (max error ≈ 1e-5 rad), for binning photons only. Where a
/// photon lands decides nothing but the pdf's shape, so an error at a cell border cannot bias
/// the estimator; `pdf` keeps the exact `cell_of`, which must agree with `sample`. libm's atan2
/// was 9 % of a guided render's profile.
#[inline]
fn fast_phi(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = if ax > ay { (ay, ax) } else { (ax, ay) };
    if hi == 0.0 {
        return 0.0;
    }
    let t = lo / hi;
    let t2 = t * t;
    // Minimax polynomial for atan on [0, 1].
    let mut a = ((((0.0208351 * t2 - 0.085133) * t2 + 0.180141) * t2 - 0.3302995) * t2 + 0.999866) * t;
    if ay > ax {
        a = std::f32::consts::FRAC_PI_2 - a;
    }
    if x < 0.0 {
        a = std::f32::consts::PI - a;
    }
    if y < 0.0 {
        a = TAU - a;
    }
    a
}

/// The cell a photon's local direction is binned into (see [`fast_phi`]).
#[inline]
fn photon_cell(w: Vec3, m: usize, n: usize) -> usize {
    cell_at(w, fast_phi(w.y, w.x) / TAU, m, n)
}

impl PhotonGrid {
    /// Builds the grid from photons given as (incoming direction in the local frame, reflected
    /// flux luminance f_r ΔΦ). Directions below the surface (z ≤ 0) and non-positive or
    /// non-finite fluxes are ignored. `epsilon` is the fraction of the total flux given to empty
    /// cells, as `empty` says.
    pub fn build(
        photons: impl IntoIterator<Item = (Vec3, f32)>,
        m: usize,
        n: usize,
        epsilon: f32,
        empty: EmptyCells,
    ) -> Self {
        assert!(m > 0 && n > 0, "grid must have cells");
        let mut flux = vec![0.0f32; m * n];
        for (w, phi) in photons {
            if w.z > 0.0 && phi > 0.0 && phi.is_finite() {
                flux[photon_cell(w, m, n)] += phi;
            }
        }
        let total: f32 = flux.iter().sum();
        let empty_cells = empty;
        let empty = flux.iter().filter(|&&f| f == 0.0).count();
        if total == 0.0 {
            flux.fill(1.0);
        } else if empty > 0 {
            let share = match empty_cells {
                EmptyCells::Shared => epsilon.max(0.0) * total / empty as f32,
                EmptyCells::Each => epsilon.max(0.0) * total,
            };
            // ε = 0 reproduces a grid that can miss directions: it is allowed (for studying the
            // bias) but then the pdf is zero there.
            flux.iter_mut().filter(|f| **f == 0.0).for_each(|f| *f = share);
        }
        let cells = Distribution1D::new(&flux)
            .unwrap_or_else(|| Distribution1D::new(&vec![1.0; m * n]).expect("uniform weights"));
        Self { m, n, cells }
    }

    /// Number of cells m · n.
    pub fn cell_count(&self) -> usize {
        self.m * self.n
    }

    /// Samples a local direction (z > 0); returns it with its solid-angle pdf.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let (cdf, pmf) = self.cells.slices();
        sample_cells(self.m, self.n, cdf, pmf, u)
    }

    /// Solid-angle pdf of `sample` for local direction `w`.
    #[inline]
    pub fn pdf(&self, w: Vec3) -> f32 {
        pdf_cells(self.m, self.n, self.cells.slices().1, w)
    }
}

/// [`PhotonGrid::sample`] on a grid's cell distribution given as slices.
#[inline]
fn sample_cells(m: usize, n: usize, cdf: &[f32], pmf: &[f32], u: Vec2) -> (Vec3, f32) {
    let (c, p_cell, u_rem) = Distribution1D::sample_slices(cdf, pmf, u.x);
    let (i, j) = (c / n, c % n);
    // A uniform point in the cell: u.x was spent on the cell choice and is reused via its
    // remainder for the u coordinate; u.y drives v.
    let uu = (i as f32 + u_rem) / m as f32;
    let vv = (j as f32 + u.y) / n as f32;
    let cos_theta = (1.0 - uu).max(0.0).sqrt();
    let sin_theta = uu.sqrt();
    let phi = TAU * vv;
    let w = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta);
    (w, cos_theta * FRAC_1_PI * p_cell * (m * n) as f32)
}

/// [`PhotonGrid::pdf`] on a grid's cell probabilities given as a slice.
#[inline]
fn pdf_cells(m: usize, n: usize, pmf: &[f32], w: Vec3) -> f32 {
    if w.z <= 0.0 {
        return 0.0;
    }
    w.z * FRAC_1_PI * pmf[cell_of(w, m, n)] * (m * n) as f32
}

/// Many grids of one shape stored flat in one array (each its cumulative weights then its
/// cell probabilities), so that a precomputed pdf is one contiguous read instead of three
/// scattered ones; sampling and pdf are exactly [`PhotonGrid`]'s.
#[derive(Clone, Debug)]
pub struct FlatGrids {
    m: usize,
    n: usize,
    data: Vec<f32>,
}

impl FlatGrids {
    pub fn new(m: usize, n: usize) -> Self {
        Self { m, n, data: Vec::new() }
    }

    /// Floats per grid: m·n + 1 cumulative weights, m·n probabilities.
    fn stride(&self) -> usize {
        2 * self.m * self.n + 1
    }

    /// Appends `grid` (of this shape) as grid number [`FlatGrids::len`].
    pub fn push(&mut self, grid: &PhotonGrid) {
        assert_eq!((grid.m, grid.n), (self.m, self.n), "one shape for all grids");
        let (cdf, pmf) = grid.cells.slices();
        self.data.extend_from_slice(cdf);
        self.data.extend_from_slice(pmf);
    }

    pub fn len(&self) -> usize {
        self.data.len() / self.stride()
    }

    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// Memory held, in bytes.
    pub fn bytes(&self) -> usize {
        self.data.len() * std::mem::size_of::<f32>()
    }

    #[inline]
    fn slices(&self, i: usize) -> (&[f32], &[f32]) {
        let cells = self.m * self.n;
        let grid = &self.data[i * self.stride()..(i + 1) * self.stride()];
        grid.split_at(cells + 1)
    }

    /// [`PhotonGrid::sample`] of grid `i`.
    #[inline]
    pub fn sample(&self, i: usize, u: Vec2) -> (Vec3, f32) {
        let (cdf, pmf) = self.slices(i);
        sample_cells(self.m, self.n, cdf, pmf, u)
    }

    /// [`PhotonGrid::pdf`] of grid `i`.
    #[inline]
    pub fn pdf(&self, i: usize, w: Vec3) -> f32 {
        pdf_cells(self.m, self.n, self.slices(i).1, w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_phi_matches_atan2() {
        let mut rng = crate::sampling::Rng::for_task(5, [0, 0, 0]);
        let mut worst = 0.0f32;
        for k in 0..100_000 {
            let (x, y) = if k < 8 {
                // The axes and diagonals exactly.
                let a = k as f32 * std::f32::consts::FRAC_PI_4;
                (a.cos(), a.sin())
            } else {
                (rng.uniform() * 2.0 - 1.0, rng.uniform() * 2.0 - 1.0)
            };
            let mut exact = y.atan2(x);
            if exact < 0.0 {
                exact += TAU;
            }
            let got = fast_phi(y, x);
            assert!((0.0..=TAU).contains(&got), "{got} out of [0, 2π] at ({x}, {y})");
            let d = (got - exact).abs();
            worst = worst.max(d.min(TAU - d));
        }
        assert!(worst < 2e-5, "worst error {worst} rad");
    }
    use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_test_directions};
    use crate::sampling::{Rng, sample_uniform_hemisphere};

    /// A photon set concentrated around one direction, plus a few strays.
    fn photons(seed: u64) -> Vec<(Vec3, f32)> {
        let mut rng = Rng::for_task(seed, [0, 0, 0]);
        let lobe = Vec3::new(0.5, -0.3, 0.81).normalize();
        (0..50)
            .map(|k| {
                let w = if k < 40 {
                    (lobe + 0.2 * (sample_uniform_hemisphere(rng.uniform2()) - Vec3::Z)).normalize()
                } else {
                    sample_uniform_hemisphere(rng.uniform2())
                };
                (w, 0.5 + rng.uniform())
            })
            .collect()
    }

    #[test]
    fn photon_grid_sampler_passes_chi2_against_its_pdf() {
        for (m, n, eps) in [(4, 16, 0.01), (2, 8, 0.1), (8, 32, 0.01)] {
            let grid = PhotonGrid::build(photons(m as u64), m, n, eps, EmptyCells::Shared);
            let report = chi2_test_directions(
                |rng: &mut Rng| Some(grid.sample(rng.uniform2())),
                |w| grid.pdf(w),
                DirectionTest::default(),
            );
            assert!(report.passes(CHI2_ALPHA), "{m}x{n} ε={eps}: {report:?}");
        }
    }

    #[test]
    fn weight_is_jensens_scaling_factor() {
        let grid = PhotonGrid::build(photons(1), 4, 16, 0.01, EmptyCells::Each);
        let mut rng = Rng::for_task(2, [0, 0, 0]);
        let rho = 0.7;
        for _ in 0..100 {
            let (w, pdf) = grid.sample(rng.uniform2());
            let c = cell_of(w, 4, 16);
            // s = ρ Φ_total / (cells Φ_c) [eq. (11)], with Φ_c / Φ_total the cell's probability.
            let s = rho / (64.0 * grid.cells.pmf(c));
            let weight = rho * FRAC_1_PI * w.z / pdf;
            assert!((weight - s).abs() < 1e-4 * s, "{weight} vs {s}");
        }
    }

    #[test]
    fn every_direction_keeps_a_positive_pdf() {
        let grid = PhotonGrid::build(photons(3), 4, 16, 0.01, EmptyCells::Shared);
        let mut rng = Rng::for_task(4, [0, 0, 0]);
        for _ in 0..1000 {
            let w = sample_uniform_hemisphere(rng.uniform2());
            assert!(grid.pdf(w) > 0.0 || w.z == 0.0);
        }
        // ε is the share of all flux given to the empty cells together.
        let flux_of_empty: f32 = (0..64).map(|c| grid.cells.pmf(c)).filter(|&p| p < 0.01 / 30.0).sum();
        assert!(flux_of_empty <= 0.0101, "{flux_of_empty}");
    }

    #[test]
    fn each_empty_cell_gets_epsilon_of_the_total() {
        let one = vec![(Vec3::new(0.0, 0.0, 1.0), 2.0)];
        let grid = PhotonGrid::build(one, 4, 16, 0.01, EmptyCells::Each);
        // One full cell with flux Φ, 63 empty cells with 0.01 Φ each.
        let total = 1.0 + 63.0 * 0.01;
        assert!((grid.cells.pmf(0) - 1.0 / total).abs() < 1e-6);
        assert!((grid.cells.pmf(5) - 0.01 / total).abs() < 1e-6);
        let shared = PhotonGrid::build(vec![(Vec3::Z, 2.0)], 4, 16, 0.01, EmptyCells::Shared);
        assert!((shared.cells.pmf(5) - 0.01 / 63.0 / 1.01).abs() < 1e-7);
    }

    #[test]
    fn no_photons_gives_cosine_sampling() {
        let grid = PhotonGrid::build(std::iter::empty(), 4, 16, 0.01, EmptyCells::Each);
        let w = Vec3::new(0.3, 0.4, 0.866).normalize();
        assert!((grid.pdf(w) - w.z * FRAC_1_PI).abs() < 1e-6);
    }

    #[test]
    fn photons_below_the_surface_are_ignored() {
        let below = vec![(Vec3::new(0.0, 0.6, -0.8), 5.0)];
        let grid = PhotonGrid::build(below, 4, 16, 0.01, EmptyCells::Shared);
        let w = Vec3::new(0.0, 0.6, 0.8);
        assert!((grid.pdf(w) - w.z * FRAC_1_PI).abs() < 1e-6, "uniform grid expected");
    }
}
