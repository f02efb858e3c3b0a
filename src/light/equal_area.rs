//! pbrt-v4's environment images: a square image over the whole sphere by Clarberg's
//! equal-area octahedral mapping ("Fast Equal-Area Mapping of the (Hemi)Sphere using SIMD",
//! 2008; pbrt-v4 §3.8.3, `EqualAreaSquareToSphere` and its inverse), read by nearest texel as
//! pbrt's `ImageInfiniteLight` reads it.
//!
//! The mapping folds the square [0, 1]² onto an octahedron: the inner diamond |u′| + |v′| ≤ 1
//! (u′ = 2u − 1, v′ = 2v − 1) is the +z hemisphere, the four corners the −z one. Every texel
//! covers the same solid angle, 4π / N², so the radiance is piecewise constant per texel in
//! solid angle and sampling is exact: a texel with probability ∝ its largest channel, a point
//! uniformly in it, solid-angle density P_texel N² / 4π. Texel (x, y) covers
//! [x/N, (x + 1)/N] × [y/N, (y + 1)/N], y = 0 the image's first (top) row, as pbrt indexes it.

use crate::sampling::Distribution1D;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
use std::sync::Arc;

/// A square equal-area environment image with its sampling distribution.
#[derive(Clone, Debug)]
pub struct EqualAreaMap {
    /// Texels per side.
    pub n: u32,
    /// Linear RGB, row-major, row 0 the image's top row.
    pub texels: Arc<[Vec3]>,
    texel_choice: Distribution1D,
}

/// The unit direction at point `p` of the square [0, 1]² (pbrt-v4's `EqualAreaSquareToSphere`).
pub fn square_to_sphere(p: Vec2) -> Vec3 {
    let (u, v) = (2.0 * p.x - 1.0, 2.0 * p.y - 1.0);
    let (up, vp) = (u.abs(), v.abs());
    // Signed distance from the diagonal |u| + |v| = 1 (positive inside: the +z hemisphere).
    let signed = 1.0 - (up + vp);
    let r = 1.0 - signed.abs();
    let phi = if r == 0.0 { 1.0 } else { (vp - up) / r + 1.0 } * FRAC_PI_4;
    let z = (1.0 - r * r).copysign(signed);
    let (sin_phi, cos_phi) = phi.sin_cos();
    let s = r * (2.0 - r * r).max(0.0).sqrt();
    Vec3::new(cos_phi.copysign(u) * s, sin_phi.copysign(v) * s, z)
}

/// The point of the square for unit direction `d` (pbrt-v4's `EqualAreaSphereToSquare`, with
/// an exact arctangent where pbrt uses a polynomial fit).
pub fn sphere_to_square(d: Vec3) -> Vec2 {
    let (x, y, z) = (d.x.abs(), d.y.abs(), d.z.abs());
    let r = (1.0 - z).max(0.0).sqrt();
    let (a, b) = (x.max(y), x.min(y));
    let b = if a == 0.0 { 0.0 } else { b / a };
    let mut phi = b.atan() / FRAC_PI_2;
    if x < y {
        phi = 1.0 - phi;
    }
    let mut v = phi * r;
    let mut u = r - v;
    if d.z < 0.0 {
        (u, v) = (1.0 - v, 1.0 - u);
    }
    Vec2::new(0.5 * (u.copysign(d.x) + 1.0), 0.5 * (v.copysign(d.y) + 1.0))
}

impl EqualAreaMap {
    /// Builds the map and its sampling distribution; `None` unless the image is square with
    /// finite non-negative texels, not all black.
    pub fn new(width: u32, height: u32, texels: Arc<[Vec3]>) -> Option<Self> {
        if width != height || width == 0 || texels.len() != (width * height) as usize {
            return None;
        }
        if texels.iter().any(|t| !t.is_finite() || t.min_element() < 0.0) {
            return None;
        }
        let weights: Vec<f32> = texels.iter().map(|t| t.max_element()).collect();
        let texel_choice = Distribution1D::new(&weights)?;
        Some(Self {
            n: width,
            texels,
            texel_choice,
        })
    }

    /// The texel index under square point `p` (clamped into the image).
    #[inline]
    fn texel(&self, p: Vec2) -> usize {
        let n = self.n as f32;
        let x = ((p.x * n) as i64).clamp(0, self.n as i64 - 1) as usize;
        let y = ((p.y * n) as i64).clamp(0, self.n as i64 - 1) as usize;
        y * self.n as usize + x
    }

    /// Radiance toward unit direction `d` of the map's frame.
    #[inline]
    pub fn eval(&self, d: Vec3) -> Vec3 {
        self.texels[self.texel(sphere_to_square(d))]
    }

    /// A direction of the map's frame drawn by `u`, with its solid-angle density (that of the
    /// direction as returned, so that it agrees with `pdf` also on a texel's border).
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let (i, _, u_rest) = self.texel_choice.sample(u.x);
        let n = self.n as usize;
        let p = Vec2::new((i % n) as f32 + u_rest, (i / n) as f32 + u.y) / self.n as f32;
        let d = square_to_sphere(p).normalize();
        (d, self.pdf(d))
    }

    /// Solid-angle density of [`EqualAreaMap::sample`] toward `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        let n = self.n as f32;
        self.texel_choice.pmf(self.texel(sphere_to_square(d))) * n * n / (4.0 * PI)
    }

    /// Mean radiance over the sphere: every texel covers the same solid angle.
    pub fn mean(&self) -> Vec3 {
        let sum: glam::DVec3 = self.texels.iter().map(|t| t.as_dvec3()).sum();
        (sum / self.texels.len() as f64).as_vec3()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;
    use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_test_directions};

    /// The two maps are inverse, and the square's area maps to solid angle at the constant
    /// ratio 4π (the Jacobian of a small square around random points, by finite differences).
    #[test]
    fn the_mapping_is_bijective_and_equal_area() {
        let mut rng = Rng::for_task(3, [0, 0, 0]);
        for _ in 0..2000 {
            let p = rng.uniform2() * 0.998 + Vec2::splat(0.001);
            let d = square_to_sphere(p);
            assert!((d.length() - 1.0).abs() < 1e-5, "{p}: {d}");
            let back = sphere_to_square(d);
            assert!((back - p).length() < 2e-5, "{p} → {d} → {back}");
            let h = 1e-3;
            let (a, b) = (
                square_to_sphere(p + Vec2::new(h, 0.0)),
                square_to_sphere(p + Vec2::new(0.0, h)),
            );
            let (a, b, d) = (a.as_dvec3(), b.as_dvec3(), d.as_dvec3());
            let area = (a - d).cross(b - d).length() / (h as f64 * h as f64);
            // Skip the folds (the diagonals and the axes), where the difference straddles them.
            let (u, v) = (2.0 * p.x - 1.0, 2.0 * p.y - 1.0);
            let near_fold = (1.0 - u.abs() - v.abs()).abs() < 3e-3 || u.abs() < 3e-3 || v.abs() < 3e-3;
            if !near_fold {
                assert!((area / (4.0 * std::f64::consts::PI) - 1.0).abs() < 2e-2, "{p}: {area}");
            }
        }
        // The centre is +z, the corners −z, and the axes of the square lie in the planes x = 0
        // and y = 0.
        assert!((square_to_sphere(Vec2::splat(0.5)) - Vec3::Z).length() < 1e-6);
        assert!((square_to_sphere(Vec2::ZERO) + Vec3::Z).length() < 1e-6);
        assert!(square_to_sphere(Vec2::new(0.9, 0.5)).y.abs() < 1e-6);
    }

    fn test_map() -> EqualAreaMap {
        let n = 8u32;
        let texels: Vec<Vec3> = (0..n * n)
            .map(|i| {
                Vec3::new(0.1 + (i % 7) as f32, 0.2, if i == 27 { 40.0 } else { 0.3 }) * ((i % 5 != 0) as u8 as f32)
            })
            .collect();
        EqualAreaMap::new(n, n, texels.into()).unwrap()
    }

    #[test]
    fn sampling_matches_its_density() {
        let map = test_map();
        let report = chi2_test_directions(
            |rng: &mut Rng| Some(map.sample(rng.uniform2())),
            |d| map.pdf(d),
            DirectionTest {
                seed: 17,
                ..DirectionTest::default()
            },
        );
        assert!(report.passes(CHI2_ALPHA), "{report:?}");
    }

    /// E[L(ω)/p(ω)] over the sampler is ∫ L dω = 4π × the mean texel.
    #[test]
    fn importance_sampled_radiance_estimates_the_mean() {
        let map = test_map();
        let mut rng = Rng::for_task(5, [0, 0, 0]);
        let n = 200_000;
        let sum: f64 = (0..n)
            .map(|_| {
                let (d, pdf) = map.sample(rng.uniform2());
                (map.eval(d).z / pdf) as f64
            })
            .sum();
        let expected = 4.0 * std::f64::consts::PI * map.mean().z as f64;
        assert!(
            (sum / n as f64 / expected - 1.0).abs() < 1e-2,
            "{} vs {expected}",
            sum / n as f64
        );
    }
}
