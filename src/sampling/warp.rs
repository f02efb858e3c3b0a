//! Warps from [0,1)² to common domains. Each `sample_*` has a `*_pdf` sibling giving the density
//! of the returned point in the measure named in its doc (solid angle or area); the chi-square
//! tests in this module's tests check every pair against each other.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI, TAU};

/// Uniform point on the unit disc by Shirley–Chiu's concentric map (area pdf 1/π).
#[inline]
pub fn sample_concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, (PI / 4.0) * (o.y / o.x))
    } else {
        (o.y, PI / 2.0 - (PI / 4.0) * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Cosine-weighted direction on the hemisphere z > 0 (Malley's method).
#[inline]
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = sample_concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Solid-angle pdf of [`sample_cosine_hemisphere`]: cos θ / π.
#[inline]
pub fn cosine_hemisphere_pdf(w: Vec3) -> f32 {
    w.z.max(0.0) * FRAC_1_PI
}

/// Uniform direction on the hemisphere z > 0.
#[inline]
pub fn sample_uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = TAU * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Solid-angle pdf of [`sample_uniform_hemisphere`]: 1 / 2π on z > 0.
#[inline]
pub fn uniform_hemisphere_pdf(w: Vec3) -> f32 {
    if w.z > 0.0 { 0.5 * FRAC_1_PI } else { 0.0 }
}

/// Uniform direction on the unit sphere.
#[inline]
pub fn sample_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = TAU * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Solid-angle pdf of [`sample_uniform_sphere`]: 1 / 4π.
#[inline]
pub fn uniform_sphere_pdf() -> f32 {
    0.25 * FRAC_1_PI
}

/// Uniform direction in the cone of half-angle θ_max around +z.
#[inline]
pub fn sample_uniform_cone(u: Vec2, cos_theta_max: f32) -> Vec3 {
    let cos_theta = 1.0 - u.x * (1.0 - cos_theta_max);
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let phi = TAU * u.y;
    Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta)
}

/// Solid-angle pdf of [`sample_uniform_cone`]: 1 / (2π (1 − cos θ_max)) inside the cone.
#[inline]
pub fn uniform_cone_pdf(w: Vec3, cos_theta_max: f32) -> f32 {
    if w.z >= cos_theta_max {
        1.0 / (TAU * (1.0 - cos_theta_max))
    } else {
        0.0
    }
}

/// Uniform barycentric coordinates (b0, b1) on a triangle; b2 = 1 − b0 − b1. Area pdf 1/A.
#[inline]
pub fn sample_uniform_triangle(u: Vec2) -> Vec2 {
    // Heitz 2019, "A Low-Distortion Map Between Triangle and Square".
    let (b0, b1) = if u.x < u.y {
        let b0 = u.x / 2.0;
        (b0, u.y - b0)
    } else {
        let b1 = u.y / 2.0;
        (u.x - b1, b1)
    };
    Vec2::new(b0, b1)
}

/// Converts a solid-angle density at `x` toward a point at squared distance `dist2`, whose
/// surface makes `|cos θ'|` with the connecting segment, into an area density at that point:
/// p_A = p_ω |cos θ'| / r² [Veach 1997, eq. (8.10)].
#[inline]
pub fn pdf_w_to_a(pdf_w: f32, dist2: f32, cos_there: f32) -> f32 {
    pdf_w * cos_there.abs() / dist2
}

/// Inverse of [`pdf_w_to_a`].
#[inline]
pub fn pdf_a_to_w(pdf_a: f32, dist2: f32, cos_there: f32) -> f32 {
    let c = cos_there.abs();
    if c == 0.0 { 0.0 } else { pdf_a * dist2 / c }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;
    use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_statistic, chi2_test_directions};

    /// χ² of a warp of the unit square against its solid-angle pdf.
    fn assert_warp_passes(name: &str, warp: impl Fn(Vec2) -> Vec3, pdf: impl Fn(Vec3) -> f32, seed: u64) {
        let report = chi2_test_directions(
            |rng: &mut Rng| {
                let w = warp(rng.uniform2());
                Some((w, pdf(w)))
            },
            &pdf,
            DirectionTest {
                seed,
                ..DirectionTest::default()
            },
        );
        assert!(report.passes(CHI2_ALPHA), "{name}: {report:?}");
        assert!((report.pdf_integral - 1.0).abs() < 1e-4, "{name}: {report:?}");
    }

    #[test]
    fn cosine_hemisphere_passes_chi2() {
        assert_warp_passes("cosine", sample_cosine_hemisphere, cosine_hemisphere_pdf, 1);
    }

    #[test]
    fn uniform_hemisphere_passes_chi2() {
        assert_warp_passes("hemisphere", sample_uniform_hemisphere, uniform_hemisphere_pdf, 2);
    }

    #[test]
    fn uniform_sphere_passes_chi2() {
        assert_warp_passes("sphere", sample_uniform_sphere, |_| uniform_sphere_pdf(), 3);
    }

    #[test]
    fn uniform_cone_passes_chi2() {
        for (k, cos_theta_max) in [0.95f32, 0.6, -0.3].into_iter().enumerate() {
            assert_warp_passes(
                &format!("cone cos θmax = {cos_theta_max}"),
                |u| sample_uniform_cone(u, cos_theta_max),
                |w| uniform_cone_pdf(w, cos_theta_max),
                10 + k as u64,
            );
        }
    }

    #[test]
    fn chi2_rejects_cosine_samples_tested_against_the_uniform_pdf() {
        let report = chi2_test_directions(
            |rng: &mut Rng| {
                let w = sample_cosine_hemisphere(rng.uniform2());
                Some((w, uniform_hemisphere_pdf(w)))
            },
            uniform_hemisphere_pdf,
            DirectionTest::default(),
        );
        assert_eq!(report.pdf_mismatches, 0);
        assert!(report.chi2.p_value < 1e-12, "{report:?}");
        assert!(!report.passes(CHI2_ALPHA));
    }

    #[test]
    fn uniform_triangle_passes_chi2_on_congruent_sub_triangles() {
        // Split the triangle b0, b1 ≥ 0, b0 + b1 ≤ 1 into k² congruent sub-triangles: grid cell
        // (i, j) holds a lower one (frac sum < 1) and, when i + j ≤ k − 2, an upper one.
        let k = 12;
        let n = 120_000;
        let mut counts = vec![0.0f64; k * k * 2];
        let mut rng = Rng::for_task(4, [0, 0, 0]);
        for _ in 0..n {
            let b = sample_uniform_triangle(rng.uniform2());
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0, "{b}");
            let (x, y) = (b.x * k as f32, b.y * k as f32);
            let (i, j) = ((x as usize).min(k - 1), (y as usize).min(k - 1));
            let upper = usize::from(x.fract() + y.fract() >= 1.0 && i + j + 2 <= k);
            counts[(i * k + j) * 2 + upper] += 1.0;
        }
        let expected_per_cell = n as f64 / (k * k) as f64;
        let expected: Vec<f64> = (0..k * k * 2)
            .map(|c| {
                let (i, j, upper) = (c / 2 / k, c / 2 % k, c % 2 == 1);
                let exists = if upper { i + j + 2 <= k } else { i + j < k };
                if exists { expected_per_cell } else { 0.0 }
            })
            .collect();
        let chi2 = chi2_statistic(&counts, &expected, 5.0);
        assert_eq!(chi2.dof, k * k - 1);
        assert!(chi2.p_value > CHI2_ALPHA, "{chi2:?}");
    }
}
