//! Chi-square goodness-of-fit tests for samplers.
//!
//! The test follows the one Mitsuba runs on every BSDF and warp: histogram many samples, integrate
//! the claimed density over each histogram cell for the expected counts, pool the sparse cells
//! and compare with Pearson's statistic X² = Σ (O − E)² / E. Under the null hypothesis
//! ("the sampler draws from this pdf") X² follows a χ² distribution with (cells − 1) degrees of
//! freedom, whose upper tail is the regularised upper incomplete gamma function
//! Q(k/2, X²/2) [Press et al., *Numerical Recipes*, 3rd ed., §6.2 and §14.3.4].
//!
//! - [`chi2_statistic`] turns observed and expected counts into a [`Chi2Result`].
//! - [`chi2_test_directions`] runs the whole test for a sampler of directions on the sphere
//!   against its solid-angle pdf, including samples the sampler rejects and a check that the
//!   pdf it reports equals the pdf function.
//! - [`integrate_sphere`] integrates a function of direction by nested adaptive Simpson
//!   quadrature (also used for brute-force albedo checks in tests).

use crate::sampling::Rng;
use glam::Vec3;
use std::f64::consts::{PI, TAU};

/// Outcome of a χ² test.
#[derive(Debug, Clone, Copy)]
pub struct Chi2Result {
    /// Pearson's X² over the pooled cells (infinite when a cell with zero expectation was hit).
    pub statistic: f64,
    /// Degrees of freedom: number of cells after pooling, minus one.
    pub dof: usize,
    /// Probability of a statistic at least this large under the null hypothesis.
    pub p_value: f64,
}

/// Pearson's statistic for `observed` against `expected` counts (same length, same total).
///
/// Cells whose expected count is below `min_expected` are pooled into one cell, as in Mitsuba's
/// test, so the χ² approximation stays valid; if the pool itself stays below `min_expected` it
/// is merged into the smallest regular cell. A cell with zero expectation but a nonzero count
/// gives an infinite statistic and p = 0: the sampler produced something impossible.
pub fn chi2_statistic(observed: &[f64], expected: &[f64], min_expected: f64) -> Chi2Result {
    assert_eq!(
        observed.len(),
        expected.len(),
        "chi2_statistic: observed and expected must have the same number of cells"
    );
    let impossible = Chi2Result {
        statistic: f64::INFINITY,
        dof: observed.len().saturating_sub(1),
        p_value: 0.0,
    };
    // Regular cells and the pool of sparse ones.
    let mut cells: Vec<(f64, f64)> = Vec::with_capacity(observed.len());
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for (&o, &e) in observed.iter().zip(expected) {
        if e <= 0.0 && o > 0.0 {
            return impossible;
        }
        if e < min_expected {
            pool_o += o;
            pool_e += e;
        } else {
            cells.push((o, e));
        }
    }
    if pool_e >= min_expected || (cells.is_empty() && pool_e > 0.0) {
        cells.push((pool_o, pool_e));
    } else if pool_e > 0.0 || pool_o > 0.0 {
        // Too little mass for a cell of its own: merge into the smallest regular cell.
        if let Some(smallest) = cells.iter_mut().min_by(|a, b| a.1.total_cmp(&b.1)) {
            smallest.0 += pool_o;
            smallest.1 += pool_e;
        }
    }
    let statistic: f64 = cells.iter().map(|&(o, e)| (o - e) * (o - e) / e).sum();
    let dof = cells.len().saturating_sub(1);
    let p_value = if dof == 0 { 1.0 } else { chi2_upper_tail(statistic, dof) };
    Chi2Result {
        statistic,
        dof,
        p_value,
    }
}

/// P(X ≥ x) for X ~ χ²(dof): Q(dof/2, x/2).
pub fn chi2_upper_tail(x: f64, dof: usize) -> f64 {
    if x.is_nan() {
        return 0.0;
    }
    regularized_gamma_q(0.5 * dof as f64, 0.5 * x)
}

/// ln Γ(x) for x > 0 by the Lanczos approximation (g = 7, nine terms), with the reflection
/// formula below 1/2; relative error about 1e-15.
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Γ(x) Γ(1 − x) = π / sin(πx).
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, &c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (TAU).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma function Q(a, x) = Γ(a, x) / Γ(a), a > 0, x ≥ 0.
///
/// Uses the series for P = 1 − Q when x < a + 1 and the continued fraction for Q otherwise,
/// evaluated with the modified Lentz method [Numerical Recipes, 3rd ed., §6.2].
pub fn regularized_gamma_q(a: f64, x: f64) -> f64 {
    assert!(a > 0.0, "regularized_gamma_q: a must be positive");
    if x <= 0.0 {
        return 1.0;
    }
    if x.is_infinite() {
        return 0.0;
    }
    const EPS: f64 = 1e-15;
    const TINY: f64 = 1e-300;
    let log_prefactor = -x + a * x.ln() - ln_gamma(a);
    if x < a + 1.0 {
        // P(a, x) = e^{−x} x^a / Γ(a) Σ_n x^n / (a (a+1) … (a+n)).
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * EPS {
                break;
            }
        }
        (1.0 - sum * log_prefactor.exp()).clamp(0.0, 1.0)
    } else {
        // Q(a, x) = e^{−x} x^a / Γ(a) · 1/(x+1−a− 1(1−a)/(x+3−a− 2(2−a)/(x+5−a− …))).
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + an / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < EPS {
                break;
            }
        }
        (log_prefactor.exp() * h).clamp(0.0, 1.0)
    }
}

/// Adaptive Simpson quadrature of `f` over [a, b]: `panels` equal panels, each refined until
/// the Richardson error estimate is below its share of `eps` (absolute) or below 1e-6 of the
/// piece's own integral (f32 integrands are noisier than that), at most `max_depth` halvings
/// deep.
pub fn adaptive_simpson(f: &dyn Fn(f64) -> f64, a: f64, b: f64, eps: f64, panels: usize, max_depth: u32) -> f64 {
    const REL_FLOOR: f64 = 1e-6;
    fn recurse(
        f: &dyn Fn(f64) -> f64,
        (a, fa): (f64, f64),
        (m, fm): (f64, f64),
        (b, fb): (f64, f64),
        whole: f64,
        eps: f64,
        depth: u32,
    ) -> f64 {
        let (lm, rm) = (0.5 * (a + m), 0.5 * (m + b));
        let (flm, frm) = (f(lm), f(rm));
        let left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
        let right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
        let delta = left + right - whole;
        // The relative floor stops refinement at the noise level of f32 integrands.
        let tol = eps.max(REL_FLOOR * (left + right).abs());
        if depth == 0 || delta.abs() <= 15.0 * tol {
            return left + right + delta / 15.0;
        }
        recurse(f, (a, fa), (lm, flm), (m, fm), left, 0.5 * eps, depth - 1)
            + recurse(f, (m, fm), (rm, frm), (b, fb), right, 0.5 * eps, depth - 1)
    }
    let panels = panels.max(1);
    let h = (b - a) / panels as f64;
    let eps_panel = eps / panels as f64;
    let mut total = 0.0;
    let mut x0 = a;
    let mut f0 = f(a);
    for i in 1..=panels {
        let x1 = if i == panels { b } else { a + h * i as f64 };
        let xm = 0.5 * (x0 + x1);
        let (fm, f1) = (f(xm), f(x1));
        let whole = (x1 - x0) / 6.0 * (f0 + 4.0 * fm + f1);
        total += recurse(f, (x0, f0), (xm, fm), (x1, f1), whole, eps_panel, max_depth);
        (x0, f0) = (x1, f1);
    }
    total
}

/// Unit direction with polar angle θ (from +z) and azimuth φ.
#[inline]
fn spherical_direction(theta: f64, phi: f64) -> Vec3 {
    let (sin_t, cos_t) = theta.sin_cos();
    let (sin_p, cos_p) = phi.sin_cos();
    Vec3::new((sin_t * cos_p) as f32, (sin_t * sin_p) as f32, cos_t as f32)
}

/// ∫ f(ω) dω over the cell cos θ ∈ [z0, z1], φ ∈ [φ0, φ1] of the sphere.
///
/// Integrates in (θ, φ) with the Jacobian sin θ rather than in (cos θ, φ), so that lobes
/// concentrated near the poles (narrow glossy lobes around the normal) stay resolved.
/// `eps` is the absolute error target for the cell.
pub fn integrate_cell(f: &dyn Fn(Vec3) -> f64, (z0, z1): (f64, f64), (phi0, phi1): (f64, f64), eps: f64) -> f64 {
    const PANELS: usize = 12;
    const MAX_DEPTH: u32 = 10;
    let (theta0, theta1) = (z1.clamp(-1.0, 1.0).acos(), z0.clamp(-1.0, 1.0).acos());
    let eps_inner = eps / (theta1 - theta0).max(1e-12) / 4.0;
    let over_phi = |theta: f64| {
        let sin_theta = theta.sin();
        if sin_theta <= 0.0 {
            // The pole: the φ-integral is multiplied by sin θ = 0.
            return 0.0;
        }
        let g = |phi: f64| f(spherical_direction(theta, phi));
        sin_theta * adaptive_simpson(&g, phi0, phi1, eps_inner, PANELS, MAX_DEPTH)
    };
    adaptive_simpson(&over_phi, theta0, theta1, eps, PANELS, MAX_DEPTH)
}

/// ∫ f(ω) dω over the whole sphere, summed over a `theta_bins` × `phi_bins` grid of cells in
/// (cos θ, φ), each by [`integrate_cell`]; `eps` is the absolute error target per cell.
pub fn integrate_sphere(f: &dyn Fn(Vec3) -> f64, theta_bins: usize, phi_bins: usize, eps: f64) -> f64 {
    let mut total = 0.0;
    for i in 0..theta_bins {
        for j in 0..phi_bins {
            let (z, phi) = cell_bounds(i, j, theta_bins, phi_bins);
            total += integrate_cell(f, z, phi, eps);
        }
    }
    total
}

/// Bounds in cos θ and φ of cell (i, j) of a `theta_bins` × `phi_bins` grid over the sphere.
fn cell_bounds(i: usize, j: usize, theta_bins: usize, phi_bins: usize) -> ((f64, f64), (f64, f64)) {
    let dz = 2.0 / theta_bins as f64;
    let dphi = TAU / phi_bins as f64;
    (
        (-1.0 + dz * i as f64, -1.0 + dz * (i + 1) as f64),
        (dphi * j as f64, dphi * (j + 1) as f64),
    )
}

/// Cell of a unit direction in the grid of [`cell_bounds`].
fn cell_of(w: Vec3, theta_bins: usize, phi_bins: usize) -> (usize, usize) {
    let z = (w.z as f64).clamp(-1.0, 1.0);
    let i = (((z + 1.0) * 0.5 * theta_bins as f64) as usize).min(theta_bins - 1);
    let mut phi = (w.y as f64).atan2(w.x as f64);
    if phi < 0.0 {
        phi += TAU;
    }
    let j = ((phi / TAU * phi_bins as f64) as usize).min(phi_bins - 1);
    (i, j)
}

/// Parameters of [`chi2_test_directions`].
#[derive(Clone, Copy, Debug)]
pub struct DirectionTest {
    /// Number of calls to the sampler.
    pub n_samples: usize,
    /// Cells in cos θ over [−1, 1] (keep it even so the horizon is a cell boundary).
    pub theta_bins: usize,
    /// Cells in φ over [0, 2π).
    pub phi_bins: usize,
    /// Seed of the sampler's random stream.
    pub seed: u64,
    /// Cells expected to hold fewer samples are pooled.
    pub min_expected: f64,
    /// Largest accepted relative difference between the pdf the sampler reports and `pdf(wi)`.
    pub pdf_rel_tol: f32,
}

impl Default for DirectionTest {
    /// 100k samples in 10 × 20 cells, pooling below 5 expected samples, pdf tolerance 1e-3.
    fn default() -> Self {
        Self {
            n_samples: 100_000,
            theta_bins: 10,
            phi_bins: 20,
            seed: 1,
            min_expected: 5.0,
            pdf_rel_tol: 1e-3,
        }
    }
}

/// Everything [`chi2_test_directions`] found.
#[derive(Clone, Copy, Debug)]
pub struct DirectionReport {
    /// The χ² test of the histogram (with rejected samples as one more cell).
    pub chi2: Chi2Result,
    /// ∫ pdf dω over the sphere.
    pub pdf_integral: f64,
    /// Fraction of calls that returned `None`.
    pub rejected_fraction: f64,
    /// Samples whose reported pdf differs from `pdf(wi)` by more than the tolerance.
    pub pdf_mismatches: usize,
    /// The first such sample: (wi, reported pdf, pdf(wi)).
    pub first_mismatch: Option<(Vec3, f32, f32)>,
    /// Samples that were not finite unit vectors or reported a pdf ≤ 0 or non-finite.
    pub invalid_samples: usize,
}

impl DirectionReport {
    /// True when the histogram passes at significance `alpha`, every sample was a valid unit
    /// vector with a positive pdf equal to `pdf(wi)`, and the pdf integrates to at most 1.
    pub fn passes(&self, alpha: f64) -> bool {
        self.chi2.p_value >= alpha
            && self.pdf_mismatches == 0
            && self.invalid_samples == 0
            && self.pdf_integral <= 1.0 + 1e-3
    }
}

/// Significance level of the χ² tests in this crate: rejects at p < 1e-4, a Bonferroni-style
/// margin that keeps a suite of dozens of (deterministic, fixed-seed) tests free of flukes.
pub const CHI2_ALPHA: f64 = 1e-4;

/// χ² test of a direction sampler against its solid-angle density.
///
/// `sample` draws one direction from the given stream and returns it with the pdf it claims,
/// or `None` when it rejects (e.g. a glossy lobe below the horizon); `pdf` is the density under
/// test. Directions are histogrammed over the whole sphere in (cos θ, φ); the expected count of
/// each cell is n ∫_cell pdf dω (by [`integrate_cell`]) and the rejected samples form one
/// extra cell with expectation n (1 − ∫ pdf dω).
pub fn chi2_test_directions(
    mut sample: impl FnMut(&mut Rng) -> Option<(Vec3, f32)>,
    pdf: impl Fn(Vec3) -> f32,
    test: DirectionTest,
) -> DirectionReport {
    let DirectionTest {
        n_samples,
        theta_bins,
        phi_bins,
        seed,
        min_expected,
        pdf_rel_tol,
    } = test;
    assert!(theta_bins > 0 && phi_bins > 0 && n_samples > 0);
    let n_cells = theta_bins * phi_bins;

    // Histogram the sampler, checking each sample's reported pdf on the way.
    let mut rng = Rng::for_task(seed, [0x0c41_2ec5, 0, 0]);
    let mut observed = vec![0.0f64; n_cells + 1];
    let (mut pdf_mismatches, mut invalid_samples) = (0, 0);
    let mut first_mismatch = None;
    for _ in 0..n_samples {
        let Some((wi, pdf_reported)) = sample(&mut rng) else {
            observed[n_cells] += 1.0;
            continue;
        };
        if !wi.is_finite() || (wi.length() - 1.0).abs() > 1e-3 || !(pdf_reported > 0.0 && pdf_reported.is_finite()) {
            invalid_samples += 1;
            continue;
        }
        let pdf_true = pdf(wi);
        if (pdf_reported - pdf_true).abs() > pdf_rel_tol * pdf_true.abs().max(pdf_reported) {
            pdf_mismatches += 1;
            first_mismatch.get_or_insert((wi, pdf_reported, pdf_true));
        }
        let (i, j) = cell_of(wi, theta_bins, phi_bins);
        observed[i * phi_bins + j] += 1.0;
    }

    // Expected counts from the pdf; the error target keeps every cell's count within 0.01.
    let n = n_samples as f64;
    let eps = 0.01 / n;
    let pdf64 = |w: Vec3| pdf(w) as f64;
    let mut expected = vec![0.0f64; n_cells + 1];
    for i in 0..theta_bins {
        for j in 0..phi_bins {
            let (z, phi) = cell_bounds(i, j, theta_bins, phi_bins);
            expected[i * phi_bins + j] = n * integrate_cell(&pdf64, z, phi, eps);
        }
    }
    let pdf_integral = expected[..n_cells].iter().sum::<f64>() / n;
    expected[n_cells] = n * (1.0 - pdf_integral).max(0.0);

    DirectionReport {
        chi2: chi2_statistic(&observed, &expected, min_expected),
        pdf_integral,
        rejected_fraction: observed[n_cells] / n,
        pdf_mismatches,
        first_mismatch,
        invalid_samples,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ln_gamma_matches_factorials_and_half_integers() {
        for (x, g) in [(1.0, 1.0), (2.0, 1.0), (5.0, 24.0), (10.0, 362_880.0)] {
            assert!((ln_gamma(x) - f64::ln(g)).abs() < 1e-12, "Γ({x})");
        }
        assert!((ln_gamma(0.5) - 0.5 * PI.ln()).abs() < 1e-12);
        assert!((ln_gamma(1.5) - (0.5 * PI.sqrt()).ln()).abs() < 1e-12);
        assert!((ln_gamma(0.1) - 9.513_507_698_668_732_f64.ln()).abs() < 1e-12);
    }

    #[test]
    fn upper_incomplete_gamma_matches_closed_forms() {
        for x in [0.01, 0.3, 1.0, 2.5, 7.0, 30.0] {
            // Q(1, x) = e^{−x}; the χ²(2) tail is e^{−x/2}.
            assert!((regularized_gamma_q(1.0, x) - (-x).exp()).abs() < 1e-13);
            assert!((chi2_upper_tail(x, 2) - (-x / 2.0).exp()).abs() < 1e-13);
            // Q(2, x) = (1 + x) e^{−x}.
            let q2 = (1.0 + x) * (-x).exp();
            assert!((regularized_gamma_q(2.0, x) - q2).abs() < 1e-13);
        }
    }

    #[test]
    fn chi2_tail_matches_table_critical_values() {
        // Standard 5 % and 0.1 % critical values.
        for (x, dof, p) in [
            (3.841_458_820_694_124, 1, 0.05),
            (18.307_038_053_275_146, 10, 0.05),
            (29.588_298_445_074_41, 10, 0.001),
            (124.342_113_404_090_4, 100, 0.05),
        ] {
            let q = chi2_upper_tail(x, dof);
            assert!((q - p).abs() < 1e-6 * p, "dof {dof}: {q} vs {p}");
        }
    }

    #[test]
    fn statistic_pools_sparse_cells_and_flags_impossible_ones() {
        let r = chi2_statistic(&[10.0, 20.0, 1.0, 2.0], &[10.0, 20.0, 2.0, 1.0], 2.5);
        // The two sparse cells pool to (3, 3): a perfect fit with 3 cells.
        assert_eq!(r.dof, 2);
        assert_eq!(r.statistic, 0.0);
        assert_eq!(r.p_value, 1.0);
        // With a threshold of 5 the pool (3, 3) is too small and joins the (10, 10) cell.
        let r = chi2_statistic(&[10.0, 20.0, 1.0, 2.0], &[10.0, 20.0, 2.0, 1.0], 5.0);
        assert_eq!(r.dof, 1);
        assert_eq!(r.statistic, 0.0);
        let r = chi2_statistic(&[10.0, 1.0], &[11.0, 0.0], 5.0);
        assert_eq!(r.p_value, 0.0);
        assert!(r.statistic.is_infinite());
    }

    #[test]
    fn sphere_quadrature_resolves_narrow_lobes() {
        // A narrow normalised lobe ∝ cos^n around a tilted axis, the worst case for the grid.
        let axis = Vec3::new(0.3, -0.5, 0.812_403_8).normalize();
        let n = 500.0;
        let lobe = |w: Vec3| {
            let c = w.dot(axis).max(0.0) as f64;
            (n + 1.0) / TAU * c.powf(n)
        };
        let total = integrate_sphere(&lobe, 10, 20, 1e-8);
        // f32 directions put ~n·6e-8 = 3e-5 of rounding noise into cos^n.
        assert!((total - 1.0).abs() < 2e-4, "{total}");
        let area = integrate_sphere(&|_| 1.0, 4, 4, 1e-10);
        assert!((area - 4.0 * PI).abs() < 1e-8, "{area}");
    }
}
