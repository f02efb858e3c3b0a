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
use wide::f32x8;

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

/// Cell of a local direction `w` (z > 0) in an m × n grid: the inverse warp T⁻¹, with
/// libm's atan2 deciding φ's interval. The polynomial [`fast_phi`] decides it instead wherever
/// it cannot differ (more than [`FAST_PHI_MARGIN`] from every interval border, twice its
/// measured worst error): the same cell for every direction, so the pdf still agrees with the
/// sampler exactly, at a fraction of the cost (atan2 was 3 % of a guided render).
#[inline]
fn cell_of(w: Vec3, m: usize, n: usize) -> usize {
    let t = fast_phi(w.y, w.x) * (n as f32 / TAU);
    if (t - t.round()).abs() > FAST_PHI_MARGIN * (n as f32 / TAU) {
        return cell_at(w, t / n as f32, m, n);
    }
    atan2_cell(w, m, n)
}

/// The cell of `w` with φ from libm's atan2: what [`cell_of`] always returns.
#[inline]
fn atan2_cell(w: Vec3, m: usize, n: usize) -> usize {
    let mut v = w.y.atan2(w.x) / TAU;
    if v < 0.0 {
        v += 1.0;
    }
    cell_at(w, v, m, n)
}

/// Radians from a φ border within which [`cell_of`] asks libm's atan2 (the test
/// `fast_phi_matches_atan2` bounds [`fast_phi`]'s error by half of it).
const FAST_PHI_MARGIN: f32 = 4e-5;

/// Row-major cell of the local direction `w` whose v = φ / 2π is given.
#[inline]
fn cell_at(w: Vec3, v: f32, m: usize, n: usize) -> usize {
    let u = (1.0 - w.z * w.z).clamp(0.0, 1.0);
    let i = ((u * m as f32) as usize).min(m - 1);
    let j = ((v * n as f32) as usize).min(n - 1);
    i * n + j
}

/// Minimax polynomial for atan on [0, 1]: atan t ≈ t · Σ ATAN_POLY[i] · t^(2(4 − i)), evaluated by
/// Horner's rule in t², highest power first (one rule for [`fast_phi`] and [`photon_cells8`], so
/// their cells agree bit for bit; adding a negative coefficient rounds as subtracting its
/// magnitude).
const ATAN_POLY: [f32; 5] = [0.0208351, -0.085133, 0.180141, -0.3302995, 0.999866];

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
    let mut a = ATAN_POLY[1..].iter().fold(ATAN_POLY[0], |acc, &c| acc * t2 + c) * t;
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

/// The cell a photon's local direction is binned into (see [`fast_phi`]), one at a time: what
/// [`photon_cells8`] computes eight at a time.
#[cfg(test)]
fn photon_cell(w: Vec3, m: usize, n: usize) -> usize {
    cell_at(w, fast_phi(w.y, w.x) / TAU, m, n)
}

/// Adds each photon's flux to the cell its direction falls in ([`cell_at`] with [`fast_phi`]'s
/// φ), in the photons' order (so every cell's sum is rounded as a one-at-a-time loop rounds
/// it), skipping directions below the surface and fluxes that are not positive and finite.
/// The cells are found eight photons at a time ([`photon_cells8`]): one at a time, the
/// arctangent's division and polynomial were a third of a Jensen grid's build, latency that
/// lanes overlap.
fn bin_photons(photons: impl IntoIterator<Item = (Vec3, f32)>, m: usize, n: usize, flux: &mut [f32]) {
    let mut photons = photons.into_iter();
    loop {
        let (mut x, mut y, mut z, mut phi) = ([0.0f32; 8], [0.0f32; 8], [0.0f32; 8], [0.0f32; 8]);
        let mut len = 0;
        for (w, p) in photons.by_ref().take(8) {
            (x[len], y[len], z[len], phi[len]) = (w.x, w.y, w.z, p);
            len += 1;
        }
        let (cells, counted) = photon_cells8(f32x8::from(x), f32x8::from(y), f32x8::from(z), m, n);
        for i in 0..len {
            if counted[i] && phi[i] > 0.0 && phi[i].is_finite() {
                flux[cells[i]] += phi[i];
            }
        }
        if len < 8 {
            return;
        }
    }
}

/// [`photon_cell`] of eight local directions (lanes of x, y, z), lane by lane with the same
/// operations in the same order, so the same cells bit for bit; and whether each direction is
/// above the surface (z > 0).
#[inline]
fn photon_cells8(x: f32x8, y: f32x8, z: f32x8, m: usize, n: usize) -> ([usize; 8], [bool; 8]) {
    let (ax, ay) = (x.abs(), y.abs());
    let swap = ax.simd_gt(ay);
    let (lo, hi) = (swap.bitselect(ay, ax), swap.bitselect(ax, ay));
    let t = lo / hi;
    let t2 = t * t;
    let c = |v: f32| f32x8::splat(v);
    let mut a = ATAN_POLY[1..].iter().fold(c(ATAN_POLY[0]), |acc, &k| acc * t2 + c(k)) * t;
    a = ay.simd_gt(ax).bitselect(c(std::f32::consts::FRAC_PI_2) - a, a);
    a = x.simd_lt(c(0.0)).bitselect(c(std::f32::consts::PI) - a, a);
    a = y.simd_lt(c(0.0)).bitselect(c(TAU) - a, a);
    let phi = hi.simd_eq(c(0.0)).bitselect(c(0.0), a);
    let v = phi / c(TAU);
    let u = (c(1.0) - z * z).max(c(0.0)).min(c(1.0));
    let (u_scaled, v_scaled) = ((u * c(m as f32)).to_array(), (v * c(n as f32)).to_array());
    let above = z.simd_gt(c(0.0)).to_bitmask();
    let cells = std::array::from_fn(|l| {
        let i = (u_scaled[l] as usize).min(m - 1);
        let j = (v_scaled[l] as usize).min(n - 1);
        i * n + j
    });
    (cells, std::array::from_fn(|l| above & (1 << l) != 0))
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
        bin_photons(photons, m, n, &mut flux);
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
    direction_in_cell(m, n, c, p_cell, u_rem, u.y)
}

/// A uniform point of cell `c` (chosen with probability `p_cell`) under the warp T, and its
/// solid-angle pdf. The cell choice spent u.x; its remainder `u_rem` is reused for the
/// cell's u coordinate, and `v` drives its v coordinate.
#[inline]
fn direction_in_cell(m: usize, n: usize, c: usize, p_cell: f32, u_rem: f32, v: f32) -> (Vec3, f32) {
    let (i, j) = (c / n, c % n);
    let uu = (i as f32 + u_rem) / m as f32;
    let vv = (j as f32 + v) / n as f32;
    let cos_theta = (1.0 - uu).max(0.0).sqrt();
    let sin_theta = uu.sqrt();
    let (sin_phi, cos_phi) = (TAU * vv).sin_cos();
    let w = Vec3::new(sin_theta * cos_phi, sin_theta * sin_phi, cos_theta);
    (w, solid_angle_pdf(m, n, cos_theta, p_cell))
}

/// Solid-angle pdf of a direction at cos θ in a cell chosen with probability `p_cell`: the
/// cosine density times the cell's share relative to a uniform grid.
#[inline]
fn solid_angle_pdf(m: usize, n: usize, cos_theta: f32, p_cell: f32) -> f32 {
    cos_theta * FRAC_1_PI * p_cell * (m * n) as f32
}

/// [`PhotonGrid::pdf`] on a grid's cell probabilities given as a slice.
#[inline]
fn pdf_cells(m: usize, n: usize, pmf: &[f32], w: Vec3) -> f32 {
    if w.z <= 0.0 {
        return 0.0;
    }
    solid_angle_pdf(m, n, w.z, pmf[cell_of(w, m, n)])
}

/// 32 cell weights: one cache line.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
struct Line([u16; 32]);

/// Many grids of one shape stored compactly for the precomputed pdfs of `photon_guided`: each
/// grid's cell probabilities as 16-bit weights relative to its largest cell, starting on a
/// cache line (a 4 × 16 grid is 128 bytes, a quarter of the float cdf and pmf), so that the
/// grids of a scene stay in cache and a vertex's pdf costs one or two line reads.
///
/// The stored weights *are* the distribution: sampling picks cell c with probability
/// w_c / Σ w exactly and the pdf reports the same, so the estimator stays unbiased. They
/// differ from the float grid by the rounding, at most 1/131 070 of the largest cell's
/// probability; a cell with positive probability keeps weight ≥ 1 (never rounded to zero, so
/// no direction the grid allows is lost) and an empty one (ε = 0) keeps 0.
#[derive(Clone, Debug)]
pub struct QuantizedGrids {
    m: usize,
    n: usize,
    lines: Vec<Line>,
    /// Each grid's Σ w, summed once when it is pushed.
    totals: Vec<u32>,
}

impl QuantizedGrids {
    pub fn new(m: usize, n: usize) -> Self {
        Self {
            m,
            n,
            lines: Vec::new(),
            totals: Vec::new(),
        }
    }

    /// Lines per grid.
    fn stride(&self) -> usize {
        (self.m * self.n).div_ceil(32)
    }

    /// Appends `grid` (of this shape) as grid number [`QuantizedGrids::len`].
    pub fn push(&mut self, grid: &PhotonGrid) {
        assert_eq!((grid.m, grid.n), (self.m, self.n), "one shape for all grids");
        let pmf = grid.cells.slices().1;
        let max = pmf.iter().copied().fold(0.0f32, f32::max);
        let start = self.lines.len();
        self.lines.resize(start + self.stride(), Line::default());
        for (c, &p) in pmf.iter().enumerate() {
            let w = if p > 0.0 {
                (p / max * 65535.0).round().max(1.0)
            } else {
                0.0
            };
            self.lines[start + c / 32].0[c % 32] = w as u16;
        }
        let lines = &self.lines[start..];
        self.totals.push(lines.iter().flat_map(|l| l.0).map(u32::from).sum());
    }

    /// Asks the processor to start loading grid `i` into cache: a vertex that has just found
    /// its record needs the grid only after its light sample and shadow ray, which hide the
    /// load (the grids of a scene exceed the second-level cache).
    #[inline]
    pub fn prefetch(&self, i: usize) {
        #[cfg(target_arch = "x86_64")]
        for line in self.lines[i * self.stride()..(i + 1) * self.stride()].iter() {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            // SAFETY: a prefetch never faults and reads nothing into the program's state; the
            // address is a live element of `self.lines`.
            unsafe { _mm_prefetch::<_MM_HINT_T0>((line as *const Line).cast()) };
        }
    }

    pub fn len(&self) -> usize {
        self.lines.len() / self.stride().max(1)
    }

    pub fn is_empty(&self) -> bool {
        self.lines.is_empty()
    }

    /// Memory held, in bytes.
    pub fn bytes(&self) -> usize {
        self.lines.len() * std::mem::size_of::<Line>()
    }

    /// The weights of grid `i` (padded to whole lines with zeros) and their sum.
    #[inline]
    fn weights(&self, i: usize) -> (&[Line], u32) {
        (&self.lines[i * self.stride()..(i + 1) * self.stride()], self.totals[i])
    }

    /// [`PhotonGrid::sample`] of grid `i`.
    #[inline]
    pub fn sample(&self, i: usize, u: Vec2) -> (Vec3, f32) {
        let (lines, total) = self.weights(i);
        // The cell c with Σ_{c' < c} w ≤ u·W < Σ_{c' ≤ c} w (never an empty one). u·W is exact
        // in f64 (24 by 23 bits), and for the integer prefix sums P_c, P_c > u·W ⟺
        // P_c > ⌊u·W⌋: the cell is the number of prefix sums ≤ ⌊u·W⌋, counted without a branch
        // per cell (the data-dependent exit of a scan mispredicted at every vertex).
        let target = u.x as f64 * total as f64;
        let floor = target as u32;
        let cells = self.m * self.n;
        let (mut prefix, mut below, mut c) = (0u32, 0u32, 0usize);
        for line in lines {
            for &w in &line.0 {
                prefix += u32::from(w);
                // The cells passed are the first c: `below` ends as P_{c−1}.
                let passed = prefix <= floor;
                below += u32::from(w) * u32::from(passed);
                c += usize::from(passed);
            }
        }
        // u·W < W, so c < cells; the guard only keeps a corrupt grid from indexing past it.
        let c = c.min(cells - 1);
        let w = lines[c / 32].0[c % 32];
        let u_rem = ((target - below as f64) / w as f64).clamp(0.0, (1.0 - f32::EPSILON) as f64);
        direction_in_cell(self.m, self.n, c, w as f32 / total as f32, u_rem as f32, u.y)
    }

    /// [`PhotonGrid::pdf`] of grid `i`.
    #[inline]
    pub fn pdf(&self, i: usize, w: Vec3) -> f32 {
        if w.z <= 0.0 {
            return 0.0;
        }
        let (lines, total) = self.weights(i);
        let c = cell_of(w, self.m, self.n);
        let p_cell = lines[c / 32].0[c % 32] as f32 / total as f32;
        solid_angle_pdf(self.m, self.n, w.z, p_cell)
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
        assert!(worst < FAST_PHI_MARGIN / 2.0, "worst error {worst} rad");
    }
    use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_test_directions};

    /// Eight at a time, the cells are [`photon_cell`]'s one at a time, bit for bit: over random
    /// directions of the sphere, the axes and diagonals (ties of |x| and |y|, zeros, x = y = 0),
    /// negative zeros, and directions on or below the surface, for several grid shapes; and a
    /// grid built from photons in any count (not a multiple of eight) sums each cell in the
    /// photons' order.
    #[test]
    fn cells_eight_at_a_time_are_the_cells_one_at_a_time() {
        let mut rng = Rng::for_task(11, [0, 0, 0]);
        let mut special = vec![Vec3::Z, -Vec3::Z, Vec3::new(-0.0, 0.0, 1.0), Vec3::new(0.0, -0.0, 0.5)];
        for k in 0..64 {
            // Borders of 4 × 16 and 8 × 32 grids and 400 angles across each (± 2 · 10⁻⁵ rad,
            // [`fast_phi`]'s error): where the least difference in the arctangent changes the
            // cell.
            for i in -200..=200 {
                let a = k as f32 * std::f32::consts::FRAC_PI_8 / 4.0 + i as f32 * 1e-7;
                for z in [0.0, -0.0, 0.3, -0.3, 1e-7] {
                    special.push(Vec3::new(a.cos(), a.sin(), z));
                    special.push(Vec3::new(a.cos() * 0.5, -a.sin() * 0.5, z));
                }
            }
        }
        // θ borders (u = sin²θ = i/m for m = 3, 4, 8) and 100 heights across each.
        for (i, m) in [(1, 4), (2, 4), (3, 4), (1, 3), (2, 3), (1, 8), (5, 8), (7, 8)] {
            for j in -50..=50 {
                let z = (1.0 - i as f32 / m as f32).sqrt() + j as f32 * 1e-7;
                let r = (1.0 - z * z).max(0.0).sqrt();
                special.push(Vec3::new(r * 0.6, r * 0.8, z));
            }
        }
        let random = (0..20_000).map(|_| crate::sampling::sample_uniform_sphere(rng.uniform2()));
        let dirs: Vec<Vec3> = special.into_iter().chain(random).collect();
        for (m, n) in [(4, 16), (1, 1), (3, 7), (8, 32)] {
            for chunk in dirs.chunks(8) {
                let lane = |f: fn(&Vec3) -> f32| {
                    let mut a = [0.0f32; 8];
                    chunk.iter().zip(&mut a).for_each(|(w, l)| *l = f(w));
                    f32x8::from(a)
                };
                let (cells, above) = photon_cells8(lane(|w| w.x), lane(|w| w.y), lane(|w| w.z), m, n);
                for (l, w) in chunk.iter().enumerate() {
                    assert_eq!(above[l], w.z > 0.0, "{w}");
                    if w.z > 0.0 {
                        assert_eq!(cells[l], photon_cell(*w, m, n), "{w} in {m} × {n}");
                    }
                }
            }
        }
        for count in [0usize, 1, 7, 8, 9, 50, 203] {
            let photons: Vec<(Vec3, f32)> = (0..count)
                .map(|i| {
                    (
                        dirs[i * 7 % dirs.len()],
                        if i % 13 == 5 { f32::NAN } else { 0.1 + (i % 5) as f32 },
                    )
                })
                .collect();
            let mut one_at_a_time = vec![0.0f32; 64];
            for &(w, phi) in &photons {
                if w.z > 0.0 && phi > 0.0 && phi.is_finite() {
                    one_at_a_time[photon_cell(w, 4, 16)] += phi;
                }
            }
            let mut binned = vec![0.0f32; 64];
            bin_photons(photons, 4, 16, &mut binned);
            assert_eq!(binned, one_at_a_time, "{count} photons");
        }
    }

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

    /// `cell_of` takes the polynomial's φ only away from borders: it is the exact atan2 cell
    /// everywhere, also for directions sampled at and next to the borders.
    #[test]
    fn cell_of_is_the_atan2_cell() {
        let mut rng = crate::sampling::Rng::for_task(6, [0, 0, 0]);
        for (m, n) in [(4, 16), (3, 7), (8, 32), (1, 1)] {
            for k in 0..200_000 {
                let w = if k % 2 == 0 {
                    sample_uniform_hemisphere(rng.uniform2())
                } else {
                    // On a border, or a few ULPs from one.
                    let j = (rng.uniform() * n as f32) as u32;
                    let phi = TAU * j as f32 / n as f32 + (rng.uniform() - 0.5) * 1e-5 * (k % 7) as f32;
                    let z = rng.uniform();
                    let s = (1.0 - z * z).sqrt();
                    Vec3::new(s * phi.cos(), s * phi.sin(), z)
                };
                assert_eq!(cell_of(w, m, n), atan2_cell(w, m, n), "{m}x{n} at {w}");
            }
        }
    }

    #[test]
    fn quantized_grids_sample_their_own_pdf() {
        for (m, n, eps, empty) in [
            (4, 16, 0.01, EmptyCells::Shared),
            (2, 8, 0.1, EmptyCells::Each),
            (8, 32, 0.01, EmptyCells::Shared),
            (4, 16, 0.0, EmptyCells::Shared),
        ] {
            let mut grids = QuantizedGrids::new(m, n);
            grids.push(&PhotonGrid::build(photons(1), m, n, eps, empty));
            grids.push(&PhotonGrid::build(photons(m as u64 + 7), m, n, eps, empty));
            assert_eq!(grids.len(), 2);
            let report = chi2_test_directions(
                |rng: &mut Rng| Some(grids.sample(1, rng.uniform2())),
                |w| grids.pdf(1, w),
                DirectionTest::default(),
            );
            assert!(report.passes(CHI2_ALPHA), "{m}x{n} ε={eps}: {report:?}");
        }
    }

    /// The counted cell is the scan's — the first cell whose prefix sum of weights exceeds u·W,
    /// never an empty one — and the sample the same bits, at u on and a few ULPs around every
    /// cell's border (where the count and the scan could part), for grids with empty cells
    /// inside and at both ends.
    #[test]
    fn quantized_sampling_picks_the_cell_a_scan_picks() {
        for (m, n, eps, seed) in [(4, 16, 0.0, 2), (4, 16, 0.01, 3), (8, 32, 0.0, 5), (3, 7, 0.0, 1)] {
            let mut grids = QuantizedGrids::new(m, n);
            grids.push(&PhotonGrid::build(photons(seed), m, n, eps, EmptyCells::Shared));
            let (lines, total) = grids.weights(0);
            let w: Vec<u32> = (0..m * n).map(|c| u32::from(lines[c / 32].0[c % 32])).collect();
            assert_eq!(w.iter().sum::<u32>(), total);
            assert!(eps > 0.0 || w.contains(&0), "{m}x{n}: empty cells to test");
            // The scan: cells in order, empty ones skipped, until the running sum exceeds u·W.
            let scan = |u: Vec2| {
                let target = u.x as f64 * total as f64;
                let mut below = 0u32;
                for c in (0..m * n).filter(|&c| w[c] > 0) {
                    if (below + w[c]) as f64 > target {
                        let u_rem = ((target - below as f64) / w[c] as f64).clamp(0.0, (1.0 - f32::EPSILON) as f64);
                        return (
                            c,
                            direction_in_cell(m, n, c, w[c] as f32 / total as f32, u_rem as f32, u.y),
                        );
                    }
                    below += w[c];
                }
                unreachable!("u·W < W")
            };
            let mut prefix = 0u32;
            for c in 0..m * n {
                prefix += w[c];
                let border = prefix as f32 / total as f32;
                let mut u = border;
                for _ in 0..4 {
                    u = f32::from_bits(u.to_bits().saturating_sub(1));
                }
                for _ in 0..8 {
                    if (0.0..1.0).contains(&u) {
                        let u = Vec2::new(u, 0.5);
                        let (cell, want) = scan(u);
                        assert!(w[cell] > 0);
                        assert_eq!(grids.sample(0, u), want, "{m}x{n} at u = {u} (border of {c})");
                    }
                    u = f32::from_bits(u.to_bits() + 1);
                }
            }
        }
    }

    /// The stored grid is the float grid up to the rounding of each cell to 1/65 535 of the
    /// largest; cells keep their support (a tiny ε share stays positive, ε = 0 stays empty),
    /// and a sample's reported pdf is the pdf of its direction.
    #[test]
    fn quantized_grids_keep_the_grid_and_its_support() {
        let (m, n) = (4, 16);
        for (eps, empty) in [
            (1e-7, EmptyCells::Shared),
            (0.0, EmptyCells::Shared),
            (0.01, EmptyCells::Each),
        ] {
            let grid = PhotonGrid::build(photons(2), m, n, eps, empty);
            let mut grids = QuantizedGrids::new(m, n);
            grids.push(&grid);
            let p_max = (0..m * n).map(|c| grid.cells.pmf(c)).fold(0.0, f32::max);
            let mut rng = Rng::for_task(9, [0, 0, 0]);
            for _ in 0..2_000 {
                let w = sample_uniform_hemisphere(rng.uniform2());
                let (a, b) = (grids.pdf(0, w), grid.pdf(w));
                // Each weight is p_c · S ± 1 with S = 65 535 / p_max, so their sum is S ± cells:
                // |a − b| ≤ (b · cells + cells · cos θ / π) / S to first order.
                let cells = (m * n) as f32;
                let bound = (b * cells + cells * w.z * FRAC_1_PI) * p_max / 65535.0;
                assert!((a - b).abs() <= 1e-5 * b + 1.01 * bound, "ε {eps}: {a} vs {b}");
                assert_eq!(a > 0.0, b > 0.0, "ε {eps}: same support at {w}");
                let (ws, pdf) = grids.sample(0, rng.uniform2());
                assert!(ws.z > 0.0 && pdf > 0.0);
                assert!(
                    (pdf - grids.pdf(0, ws)).abs() <= 1e-4 * pdf,
                    "{pdf} vs {}",
                    grids.pdf(0, ws)
                );
            }
        }
        // u at the very top of [0, 1) still lands in a cell with weight.
        let mut grids = QuantizedGrids::new(m, n);
        grids.push(&PhotonGrid::build(photons(2), m, n, 0.0, EmptyCells::Shared));
        let (w, pdf) = grids.sample(0, Vec2::new(1.0 - f32::EPSILON / 2.0, 0.5));
        assert!(pdf > 0.0 && (pdf - grids.pdf(0, w)).abs() <= 1e-4 * pdf);
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
