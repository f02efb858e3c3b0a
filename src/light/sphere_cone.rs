//! Cone sampling of sphere lights [Shirley, Wang & Zimmerman 1996]: directions uniform in the
//! cone a sphere subtends at the receiver, the near intersection as the light point.

use super::{LightSample, PointPdf, SPHERE_INSIDE};
use crate::geometry::Frame;
use glam::{Vec2, Vec3};
use std::f32::consts::TAU;

/// The cone a sphere of radius r subtends from a point at squared distance d² > r² from its
/// centre: 1 − cos θmax, computed as sin²θmax / (1 + cos θmax) so that small, distant spheres
/// do not lose it to cancellation.
#[inline]
pub(crate) fn one_minus_cos_max(r2: f32, d2: f32) -> f32 {
    let sin2 = (r2 / d2).min(1.0);
    sin2 / (1.0 + (1.0 - sin2).sqrt())
}

/// Solid-angle density of [`sample_sphere_cone`]: uniform in the cone, 1 / (2π (1 − cos θmax)).
/// `None` when `x` is on or inside the sphere (no cone: area sampling is used there).
#[inline]
pub fn sphere_cone_pdf(center: Vec3, radius: f32, x: Vec3) -> Option<f32> {
    let (d2, r2) = ((center - x).length_squared(), radius * radius);
    (d2 > SPHERE_INSIDE * r2).then(|| 1.0 / (TAU * one_minus_cos_max(r2, d2)))
}

/// A point on the part of a sphere visible from `x`, reached by a direction uniform in the cone
/// the sphere subtends [Shirley, Wang & Zimmerman 1996]; `None` when `x` is on or inside.
///
/// The direction makes angle θ with the axis x → c, cos θ = 1 − u₀ (1 − cos θmax); its near
/// intersection with the sphere is found as the angle α at the centre between c → x and
/// c → p: from the triangle x, c, p (|c − x| = d, |p − c| = r), d sin θ = r sin(θ + α) gives
/// cos α = (d/r) sin²θ + cos θ √(1 − (d/r)² sin²θ), which stays accurate for distant spheres
/// where intersecting the ray would cancel. The point is then exact on the sphere.
pub fn sample_sphere_cone(center: Vec3, radius: f32, x: Vec3, u: Vec2) -> Option<LightSample> {
    let to_c = center - x;
    let (d2, r2) = (to_c.length_squared(), radius * radius);
    if d2 <= SPHERE_INSIDE * r2 {
        return None;
    }
    let omc_max = one_minus_cos_max(r2, d2);
    let omc = u.x * omc_max;
    let cos_t = 1.0 - omc;
    let sin2_t = omc * (2.0 - omc);
    // (d/r)² sin²θ ≤ 1 inside the cone; rounding may step past it at the silhouette.
    let k = (d2 / r2 * sin2_t).min(1.0);
    let cos_a = (d2 / r2).sqrt() * sin2_t + cos_t * (1.0 - k).sqrt();
    let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
    let phi = TAU * u.y;
    // Frame around the axis c → x; the point lies on the side the direction leans to.
    let w = -to_c / d2.sqrt();
    let frame = Frame::from_normal(w);
    let n = frame.to_world(Vec3::new(sin_a * phi.cos(), sin_a * phi.sin(), cos_a));
    Some(LightSample {
        p: center + radius * n,
        n,
        pdf: PointPdf::SolidAngle(1.0 / (TAU * omc_max)),
    })
}
