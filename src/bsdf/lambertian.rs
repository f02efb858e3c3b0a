//! Lambertian (ideal diffuse) reflection, f_s = ρ/π, on the side of `wo`; sampled
//! cosine-weighted, pdf cos θi/π, so every sample's weight f_s |cos θi| / pdf is exactly ρ.
//!
//! Parameters: `reflectance` ρ in [0, 1] per channel.

use super::BsdfSample;
use crate::sampling::{cosine_hemisphere_pdf, sample_cosine_hemisphere};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

#[derive(Clone, Debug, PartialEq)]
pub struct Lambertian {
    /// Reflectance ρ per channel, in [0, 1].
    pub reflectance: Vec3,
}

impl Lambertian {
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z * wi.z > 0.0 {
            self.reflectance * FRAC_1_PI
        } else {
            Vec3::ZERO
        }
    }

    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z * wi.z > 0.0 {
            cosine_hemisphere_pdf(Vec3::new(wi.x, wi.y, wi.z.abs()))
        } else {
            0.0
        }
    }

    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let mut wi = sample_cosine_hemisphere(u);
        if wo.z < 0.0 {
            wi.z = -wi.z;
        }
        let pdf_w = cosine_hemisphere_pdf(Vec3::new(wi.x, wi.y, wi.z.abs()));
        (pdf_w > 0.0).then(|| BsdfSample {
            wi,
            f: self.reflectance * FRAC_1_PI,
            pdf_w,
            delta: false,
        })
    }
}
