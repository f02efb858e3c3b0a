//! Normalised modified Phong [Lafortune & Willems 1994, "Using the Modified Phong Reflectance
//! Model for Physically Based Rendering"]:
//!
//! f_s(wo, wi) = kd/π + ks (n + 2)/(2π) cos^n α,
//!
//! α the angle between `wi` and the mirror direction of `wo` (cos α clamped at 0), on the side
//! of `wo` only. The factor (n + 2)/(2π) makes the specular lobe's albedo exactly ks at normal
//! incidence and less elsewhere, so the model conserves energy whenever kd + ks ≤ 1 per
//! channel. It is reciprocal: cos α = wi · reflect(wo) = wo · reflect(wi).
//!
//! Sampling picks the diffuse lobe (cosine-weighted) or the specular lobe with probabilities
//! ∝ luminance of kd and ks. The specular lobe draws wi ∝ cos^n α over the whole sphere around
//! the mirror direction, pdf (n + 1)/(2π) cos^n α [Lafortune & Willems 1994, §4]; a direction
//! that falls on the other side of the surface is rejected (`None`), so the pdf, the mixture
//! of both densities, integrates to less than 1 near grazing incidence.
//!
//! Parameters: `diffuse` kd and `specular` ks in [0, 1] per channel with **kd + ks ≤ 1**
//! (callers must check, e.g. with [`super::Bsdf::validate`]); `exponent` n ≥ 0 (1 is broad,
//! 10 glossy, 200+ nearly mirror).

use super::{BsdfSample, lobe_probability, reflect_z};
use crate::geometry::Frame;
use crate::sampling::sample_cosine_hemisphere;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, TAU};

#[derive(Clone, Debug, PartialEq)]
pub struct Phong {
    /// Diffuse reflectance kd per channel, in [0, 1].
    pub diffuse: Vec3,
    /// Specular reflectance ks per channel, in [0, 1]; kd + ks ≤ 1.
    pub specular: Vec3,
    /// Phong exponent n ≥ 0.
    pub exponent: f32,
}

impl Phong {
    /// cos α = wi · reflect(wo), clamped at 0.
    #[inline]
    fn cos_alpha(wo: Vec3, wi: Vec3) -> f32 {
        wi.dot(reflect_z(wo)).max(0.0)
    }

    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z * wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let n = self.exponent;
        let lobe = (n + 2.0) / TAU * Self::cos_alpha(wo, wi).powf(n);
        self.diffuse * FRAC_1_PI + self.specular * lobe
    }

    /// Mixture density (1 − p_s) cos θi / π + p_s (n + 1)/(2π) cos^n α on the side of `wo`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z * wi.z <= 0.0 {
            return 0.0;
        }
        let Some(p_spec) = lobe_probability(self.specular, self.diffuse) else {
            return 0.0;
        };
        let n = self.exponent;
        let pdf_diffuse = wi.z.abs() * FRAC_1_PI;
        let pdf_spec = (n + 1.0) / TAU * Self::cos_alpha(wo, wi).powf(n);
        (1.0 - p_spec) * pdf_diffuse + p_spec * pdf_spec
    }

    /// Samples the specular lobe when `u_lobe` < p_s, the diffuse lobe otherwise.
    pub fn sample(&self, wo: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let p_spec = lobe_probability(self.specular, self.diffuse)?;
        let wi = if u_lobe < p_spec {
            // cos α = u^{1/(n+1)}, φ uniform, around the mirror direction.
            let cos_alpha = u.x.powf(1.0 / (self.exponent + 1.0));
            let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
            let (sin_phi, cos_phi) = (TAU * u.y).sin_cos();
            let local = Vec3::new(sin_alpha * cos_phi, sin_alpha * sin_phi, cos_alpha);
            let wi = Frame::from_normal(reflect_z(wo)).to_world(local);
            if wi.z * wo.z <= 0.0 {
                return None;
            }
            wi
        } else {
            let wi = sample_cosine_hemisphere(u);
            wi.with_z(wi.z.copysign(wo.z))
        };
        let pdf_w = self.pdf(wo, wi);
        (pdf_w > 0.0).then(|| BsdfSample {
            wi,
            f: self.eval(wo, wi),
            pdf_w,
            delta: false,
        })
    }
}
