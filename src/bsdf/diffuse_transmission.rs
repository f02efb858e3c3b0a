//! Diffuse reflection plus diffuse transmission, e.g. a lamp shade or thin paper:
//!
//! f_s(wo, wi) = R/π when wi is on the side of `wo`, T/π on the opposite side.
//!
//! The model is reciprocal and, being thin, has no index of refraction, so radiance and
//! importance transport agree. Sampling picks reflection or transmission with probability
//! ∝ luminance of R and T, then a cosine-weighted direction on that side; the pdf is
//! p_R cos θi/π on the side of `wo` and (1 − p_R) cos θi/π on the other.
//!
//! Parameters: `reflectance` R and `transmittance` T in [0, 1] per channel with R + T ≤ 1
//! (callers must check, e.g. with [`super::Bsdf::validate`]).

use super::{BsdfSample, lobe_probability};
use crate::sampling::sample_cosine_hemisphere;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

#[derive(Clone, Debug, PartialEq)]
pub struct DiffuseTransmission {
    /// Diffuse reflectance R per channel, in [0, 1].
    pub reflectance: Vec3,
    /// Diffuse transmittance T per channel, in [0, 1]; R + T ≤ 1.
    pub transmittance: Vec3,
}

impl DiffuseTransmission {
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let c = wo.z * wi.z;
        if c > 0.0 {
            self.reflectance * FRAC_1_PI
        } else if c < 0.0 {
            self.transmittance * FRAC_1_PI
        } else {
            Vec3::ZERO
        }
    }

    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(p_reflect) = lobe_probability(self.reflectance, self.transmittance) else {
            return 0.0;
        };
        let c = wo.z * wi.z;
        let p_side = if c > 0.0 {
            p_reflect
        } else if c < 0.0 {
            1.0 - p_reflect
        } else {
            0.0
        };
        p_side * wi.z.abs() * FRAC_1_PI
    }

    /// Reflects when `u_lobe` < p_R, transmits otherwise.
    pub fn sample(&self, wo: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let p_reflect = lobe_probability(self.reflectance, self.transmittance)?;
        let wi = sample_cosine_hemisphere(u);
        let wi = if u_lobe < p_reflect {
            wi.with_z(wi.z.copysign(wo.z))
        } else {
            wi.with_z(-wi.z.copysign(wo.z))
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
