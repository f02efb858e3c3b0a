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
