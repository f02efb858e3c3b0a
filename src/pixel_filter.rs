//! Pixel reconstruction filters (Mitsuba's `box`, `tent` and `gaussian` rfilters) by *filter
//! importance sampling* [Ernst et al. 2006, "Filter Importance Sampling", IEEE RT; the film of
//! pbrt-v4]: a pixel's sample position is drawn around the pixel centre with density ∝ the filter,
//! and the sample counts for that pixel only, with weight 1.
//!
//! **Why not splatting with weights (Mitsuba's film).** Mitsuba adds every sample to each pixel
//! within the filter's radius with weight f(x − c) and divides by the summed weights. The value
//! it converges to, ∫ f(x − c) L(x) dx / ∫ f (over the image), is the one importance sampling
//! converges to too; but importance sampling keeps every pixel's samples its own, so the
//! per-pixel statistics (confidence intervals, the Welch test against Mitsuba), the determinism
//! of row-parallel rendering and the independence of neighbouring pixels' errors all hold as for
//! the box filter. Both filters here are non-negative, so every sample's weight is exactly 1;
//! Mitsuba's filters with negative lobes (Lanczos, Mitchell, Catmull–Rom) are refused.
//!
//! **Image borders.** Mitsuba's film only holds samples inside the image, so a border pixel's
//! filter is cut at the image edge and renormalised. Here each axis's offset is drawn from the
//! filter restricted to the image ([`PixelFilter::sample`]), which is the same thing for these
//! separable filters.
//!
//! **Splats** (light tracing, bidirectional connections to the pinhole, Metropolis paths) land
//! at a raster position x and belong to every pixel p whose (cut, renormalised) filter covers
//! x, with weight h_p(x) = f(x − c_p) / ∫_image f(· − c_p): the same h_p that eye samples of
//! pixel p are drawn from, so both estimate the same pixel value. A splat goes to *one* of
//! those pixels, chosen ∝ h_p(x) and scaled by Σ_p h_p(x) ([`PixelFilter::splat_one`]): the
//! same expectation as spreading it ([`PixelFilter::splat`]), and the noise of one pixel, as
//! an eye sample has. Spread splats average their noise over ~16 pixels (Mitsuba's Gaussian),
//! which made splatting strategies look 1.5–2.7× better per pixel against `path` on Veach's
//! scene than with a box filter (docs/user-guide.md).
//!
//! **Decision: Mitsuba's discretized filters.** Sampling and weights use one table of the 1-D
//! filter, so that the eye samples' density and the splats' weights are exactly the same
//! function. The table is the filter as Mitsuba 3's CPU film applies it
//! (`ReconstructionFilter::eval_discretized`, the only one its scalar variants use): over
//! [0, r] in MI_FILTER_RESOLUTION = 31 steps, each holding the filter's value at the step's
//! inner edge, mirrored to [−r, 0]. Measured against Mitsuba 3.9.1 `scalar_rgb` on the textured
//! room (96 px, 16 × 64 spp): with the continuous Gaussian 6.7 % of pixels had p < 0.05 (5 %
//! expected), with this table 5.5 %; the tent (radius 1.5) went from failing (p < 0.001 in
//! 0.30 %, 0.27 % allowed) to passing. Mitsuba's JIT variants (LLVM, CUDA) evaluate the
//! continuous filter, which differs from the steps by at most the filter's change over r / 31
//! pixel. The box filter keeps its own path, bit for bit what it always was.

use crate::sampling::Distribution1D;
use glam::Vec2;

/// Bins of the tabulated 1-D filter: a multiple of 2 × [`MITSUBA_RESOLUTION`].
pub const BINS: usize = 62 * 16;

/// Mitsuba's `MI_FILTER_RESOLUTION`: steps of its discretized filter over [0, r].
pub const MITSUBA_RESOLUTION: usize = 31;

/// The widest filter half-width in pixels (the loaders refuse wider ones): a splat then covers
/// at most `2 r + 1` pixels per axis, so the covered pixels fit a fixed window on the stack
/// (splatting sits in the light-tracing hot path).
pub const MAX_RADIUS: f32 = 16.0;

/// Pixels per axis a filter of radius [`MAX_RADIUS`] can cover.
const MAX_COVERED: usize = 2 * MAX_RADIUS as usize + 1;

/// A pixel filter.
#[derive(Clone, Debug, PartialEq)]
pub enum PixelFilter {
    /// The pixel's own square (Mitsuba's `box`, radius ½).
    Box,
    /// A separable filter of half-width `radius` pixels, tabulated.
    Separable(Separable),
}

/// The kind and parameters of a separable filter, as written in a scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FilterKind {
    /// max(0, 1 − |x| / r) (Mitsuba's `tent`; default r = 1).
    Tent { radius: f32 },
    /// max(0, exp(−x² / 2σ²) − exp(−r² / 2σ²)) with r = 4σ (Mitsuba's `gaussian`; σ = 0.5).
    Gaussian { stddev: f32 },
}

/// A tabulated separable filter.
#[derive(Clone)]
pub struct Separable {
    pub kind: FilterKind,
    radius: f32,
    /// The 1-D filter over [−r, r] in [`BINS`] bins, normalised to a density.
    table: Distribution1D,
}

impl std::fmt::Debug for Separable {
    /// The kind says it all; the table is a function of it.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:?}", self.kind)
    }
}

impl PartialEq for Separable {
    /// The table is a function of the kind.
    fn eq(&self, other: &Self) -> bool {
        self.kind == other.kind
    }
}

impl FilterKind {
    /// The filter's half-width in pixels.
    pub fn radius(&self) -> f32 {
        match *self {
            FilterKind::Tent { radius } => radius,
            FilterKind::Gaussian { stddev } => 4.0 * stddev,
        }
    }

    /// The 1-D filter at offset `x` (unnormalised), as Mitsuba evaluates it.
    pub fn eval(&self, x: f32) -> f32 {
        match *self {
            FilterKind::Tent { radius } => (1.0 - x.abs() / radius).max(0.0),
            FilterKind::Gaussian { stddev } => {
                let alpha = -1.0 / (2.0 * stddev * stddev);
                let r = 4.0 * stddev;
                ((alpha * x * x).exp() - (alpha * r * r).exp()).max(0.0)
            }
        }
    }
}

impl PixelFilter {
    /// A separable filter of `kind`; the caller has checked its parameter is positive and finite
    /// and its radius at most [`MAX_RADIUS`].
    pub fn separable(kind: FilterKind) -> Self {
        let radius = kind.radius();
        assert!(
            radius <= MAX_RADIUS,
            "pixel filter radius {radius} beyond {MAX_RADIUS} (loaders check)"
        );
        // Mitsuba's scalar film (`ReconstructionFilter::eval_discretized`): |x| in bin
        // ⌊|x| · R / r⌋ of R = MI_FILTER_RESOLUTION = 31 takes the filter at the bin's inner edge.
        let per_side = BINS / 2;
        let weights: Vec<f32> = (0..BINS)
            .map(|i| {
                let from_centre = if i < per_side { per_side - 1 - i } else { i - per_side };
                let mitsuba_bin = (from_centre * MITSUBA_RESOLUTION) / per_side;
                kind.eval(radius * mitsuba_bin as f32 / MITSUBA_RESOLUTION as f32)
            })
            .collect();
        let table = Distribution1D::new(&weights).expect("a filter with positive weight");
        PixelFilter::Separable(Separable { kind, radius, table })
    }

    /// The raster position of a sample of pixel (`x`, `y`) of a `width` × `height` image drawn
    /// with `u ∈ [0, 1)²`: the box filter's x + u, else the pixel centre plus an offset per axis
    /// drawn from the filter cut at the image edges.
    #[inline]
    pub fn sample(&self, (x, y): (u32, u32), u: Vec2, (width, height): (u32, u32)) -> Vec2 {
        match self {
            PixelFilter::Box => Vec2::new(x as f32, y as f32) + u,
            PixelFilter::Separable(s) => Vec2::new(s.sample_axis(x, u.x, width), s.sample_axis(y, u.y, height)),
        }
    }

    /// Calls `add(pixel index, weight)` for every pixel of a `width` × `height` image whose
    /// filter covers raster position `raster` (module doc); the weights of one pixel's filter
    /// integrate to 1 over the image.
    #[inline]
    pub fn splat(&self, raster: Vec2, (width, height): (u32, u32), mut add: impl FnMut(u32, f32)) {
        match self {
            PixelFilter::Box => {
                let (px, py) = ((raster.x as u32).min(width - 1), (raster.y as u32).min(height - 1));
                add(py * width + px, 1.0);
            }
            PixelFilter::Separable(s) => {
                let (xs, ys) = (s.covering(raster.x, width), s.covering(raster.y, height));
                for &(py, wy) in ys.as_slice() {
                    for &(px, wx) in xs.as_slice() {
                        add(py * width + px, wx * wy);
                    }
                }
            }
        }
    }
}

impl PixelFilter {
    /// One pixel for a contribution landing at `raster`, chosen with `u` ∈ [0, 1) ∝ the weights
    /// [`PixelFilter::splat`] gives, and the sum of those weights to scale it by: the same
    /// expectation per pixel as spreading it, with the noise of one pixel, as an eye sample
    /// drawn by the filter has (spreading averages a splat's noise over its neighbours, which
    /// per-pixel error metrics would reward). `u` is not read for the box filter.
    #[inline]
    pub fn splat_one(&self, raster: Vec2, (width, height): (u32, u32), u: f32) -> Option<(u32, f32)> {
        match self {
            PixelFilter::Box => {
                let (px, py) = ((raster.x as u32).min(width - 1), (raster.y as u32).min(height - 1));
                Some((py * width + px, 1.0))
            }
            PixelFilter::Separable(s) => {
                let (xs, ys) = (s.covering(raster.x, width), s.covering(raster.y, height));
                let (xs, ys) = (xs.as_slice(), ys.as_slice());
                let (sx, sy): (f32, f32) = (xs.iter().map(|w| w.1).sum(), ys.iter().map(|w| w.1).sum());
                // x by u, then y by what is left of u inside x's share.
                let (px, rest) = pick(xs, u * sx)?;
                let (py, _) = pick(ys, (rest * sy).min(sy * (1.0 - f32::EPSILON)))?;
                Some((py * width + px, sx * sy))
            }
        }
    }
}

/// The entry of `items` (index, weight) whose cumulative range holds `target`, and where
/// `target` falls inside it, as a fraction; the last entry takes a target past the end.
fn pick(items: &[(u32, f32)], target: f32) -> Option<(u32, f32)> {
    let mut acc = 0.0;
    for &(i, w) in items {
        if target < acc + w {
            return Some((i, ((target - acc) / w).clamp(0.0, 1.0)));
        }
        acc += w;
    }
    items.last().map(|&(i, _)| (i, 1.0 - f32::EPSILON))
}

impl Separable {
    /// Cumulative density of the tabulated filter at offset `t` (clamped to [−r, r]).
    fn cdf(&self, t: f32) -> f32 {
        let x = ((t + self.radius) / (2.0 * self.radius) * BINS as f32).clamp(0.0, BINS as f32);
        let i = (x as usize).min(BINS - 1);
        let (cdf, pmf) = self.table.slices();
        cdf[i] + pmf[i] * (x - i as f32)
    }

    /// Density of the tabulated filter at offset `t` (per pixel).
    fn pdf(&self, t: f32) -> f32 {
        if t.abs() >= self.radius {
            return 0.0;
        }
        let i = (((t + self.radius) / (2.0 * self.radius) * BINS as f32) as usize).min(BINS - 1);
        self.table.pmf(i) * BINS as f32 / (2.0 * self.radius)
    }

    /// The offsets that stay inside [0, `size`] around the centre of pixel `p`, as cumulative
    /// densities (lo, hi).
    fn window(&self, p: u32, size: u32) -> (f32, f32) {
        let c = p as f32 + 0.5;
        (self.cdf(-c), self.cdf(size as f32 - c))
    }

    /// A coordinate of pixel `p` (of `size` along this axis) drawn with `u`.
    fn sample_axis(&self, p: u32, u: f32, size: u32) -> f32 {
        let (lo, hi) = self.window(p, size);
        let target = lo + u * (hi - lo);
        let (cdf, pmf) = self.table.slices();
        // The bin whose cumulative range holds the target, then linear inside it.
        let i = cdf[1..].partition_point(|&c| c <= target).min(BINS - 1);
        let frac = if pmf[i] > 0.0 { (target - cdf[i]) / pmf[i] } else { 0.5 };
        let t = -self.radius + (i as f32 + frac.clamp(0.0, 1.0)) * 2.0 * self.radius / BINS as f32;
        (p as f32 + 0.5 + t).clamp(0.0, size as f32 * (1.0 - f32::EPSILON))
    }

    /// The pixels along one axis whose filter covers coordinate `x`, with their weights.
    fn covering(&self, x: f32, size: u32) -> Covering {
        let first = (x - self.radius - 0.5).ceil().max(0.0) as u32;
        let last = ((x + self.radius - 0.5).floor().max(0.0) as u32).min(size - 1);
        let mut out = Covering {
            items: [(0, 0.0); MAX_COVERED],
            len: 0,
        };
        for p in first..=last {
            let (lo, hi) = self.window(p, size);
            let w = self.pdf(x - (p as f32 + 0.5)) / (hi - lo);
            if w > 0.0 && w.is_finite() && out.len < MAX_COVERED {
                out.items[out.len] = (p, w);
                out.len += 1;
            }
        }
        out
    }
}

/// The pixels along one axis that a filter covers, with their weights, in a fixed window.
struct Covering {
    items: [(u32, f32); MAX_COVERED],
    len: usize,
}

impl Covering {
    fn as_slice(&self) -> &[(u32, f32)] {
        &self.items[..self.len]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn filters() -> Vec<PixelFilter> {
        vec![
            PixelFilter::separable(FilterKind::Gaussian { stddev: 0.5 }),
            PixelFilter::separable(FilterKind::Tent { radius: 1.0 }),
            PixelFilter::separable(FilterKind::Gaussian { stddev: 1.3 }),
        ]
    }

    /// Each pixel's splat weights integrate to one over the image (its filter, cut at the
    /// edges and renormalised, is a density), for pixels inside and at the border.
    #[test]
    fn splat_weights_of_a_pixel_integrate_to_one() {
        let size = (7u32, 5u32);
        for f in filters() {
            let n = 700;
            let mut sums = vec![0.0f64; 35];
            for i in 0..n {
                for j in 0..n {
                    let r = Vec2::new(
                        (i as f32 + 0.5) / n as f32 * size.0 as f32,
                        (j as f32 + 0.5) / n as f32 * size.1 as f32,
                    );
                    f.splat(r, size, |p, w| sums[p as usize] += w as f64);
                }
            }
            let cell = (size.0 * size.1) as f64 / (n * n) as f64;
            for (p, s) in sums.iter().enumerate() {
                assert!(
                    (s * cell - 1.0).abs() < 5e-3,
                    "{f:?}: pixel {p} integrates to {}",
                    s * cell
                );
            }
        }
    }

    /// A pixel's samples follow the density its splat weights give (χ² over bins of the
    /// footprint), also for border pixels, and never leave the image.
    #[test]
    fn samples_follow_the_splat_density() {
        let size = (6u32, 4u32);
        let mut rng = Rng::for_task(3, [0, 0, 0]);
        for f in filters() {
            for pixel in [(0u32, 0u32), (2, 1), (5, 3)] {
                let bins = 24usize;
                let (lo, hi) = (Vec2::ZERO, Vec2::new(size.0 as f32, size.1 as f32));
                let n = 200_000;
                let mut observed = vec![0.0f64; bins * bins];
                for _ in 0..n {
                    let r = f.sample(pixel, rng.uniform2(), size);
                    assert!(r.x >= lo.x && r.y >= lo.y && r.x < hi.x && r.y < hi.y, "{r}");
                    let b = |v: f32, h: f32| ((v / h * bins as f32) as usize).min(bins - 1);
                    observed[b(r.y, hi.y) * bins + b(r.x, hi.x)] += 1.0;
                }
                // Expected counts from the splat weights, by midpoint quadrature in each bin.
                let index = pixel.1 * size.0 + pixel.0;
                let mut expected = vec![0.0f64; bins * bins];
                // Fine enough to resolve the filter's 31 steps per side.
                let q = 32;
                for (k, e) in expected.iter_mut().enumerate() {
                    let (bx, by) = ((k % bins) as f32, (k / bins) as f32);
                    for a in 0..q {
                        for b in 0..q {
                            let r = Vec2::new(
                                (bx + (a as f32 + 0.5) / q as f32) / bins as f32 * hi.x,
                                (by + (b as f32 + 0.5) / q as f32) / bins as f32 * hi.y,
                            );
                            f.splat(r, size, |p, w| {
                                if p == index {
                                    *e += w as f64;
                                }
                            });
                        }
                    }
                    *e *= (hi.x * hi.y) as f64 / (bins * bins * q * q) as f64 * n as f64;
                }
                let chi2 = crate::sampling::chi2::chi2_statistic(&observed, &expected, 5.0);
                assert!(chi2.p_value > 1e-4, "{f:?} pixel {pixel:?}: {chi2:?}");
            }
        }
    }

    /// Choosing one pixel per splat gives each pixel, in expectation over `u`, exactly the
    /// weight spreading gives it.
    #[test]
    fn one_pixel_splats_have_the_spread_weights_in_expectation() {
        let size = (6u32, 5u32);
        for f in filters() {
            for r in [Vec2::new(0.2, 0.3), Vec2::new(2.7, 2.5), Vec2::new(5.9, 4.1)] {
                let mut spread = vec![0.0f64; 30];
                f.splat(r, size, |p, w| spread[p as usize] += w as f64);
                let n = 100_000;
                let mut chosen = vec![0.0f64; 30];
                for i in 0..n {
                    let (p, w) = f.splat_one(r, size, (i as f32 + 0.5) / n as f32).unwrap();
                    chosen[p as usize] += w as f64 / n as f64;
                }
                for (p, (a, b)) in spread.iter().zip(&chosen).enumerate() {
                    assert!((a - b).abs() < 2e-3 * a.max(0.1), "{f:?} at {r}, pixel {p}: {a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn the_box_filter_is_the_pixel_square() {
        let f = PixelFilter::Box;
        assert_eq!(f.sample((3, 2), Vec2::new(0.25, 0.5), (8, 8)), Vec2::new(3.25, 2.5));
        let mut hits = Vec::new();
        f.splat(Vec2::new(3.9, 2.1), (8, 8), |p, w| hits.push((p, w)));
        assert_eq!(hits, vec![(2 * 8 + 3, 1.0)]);
    }

    #[test]
    fn mitsubas_gaussian_vanishes_at_four_standard_deviations() {
        let g = FilterKind::Gaussian { stddev: 0.5 };
        assert_eq!(g.radius(), 2.0);
        assert_eq!(g.eval(2.0), 0.0);
        assert!((g.eval(0.0) - (1.0 - (-8.0f32).exp())).abs() < 1e-6);
    }
}
