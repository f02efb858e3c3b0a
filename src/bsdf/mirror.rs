//! Ideal specular reflection: a delta lobe toward the mirror direction of `wo`, scaled by a
//! per-channel reflectance R.
//!
//! As a distribution, f_s(wo, wi) = R δ(wi − reflect(wo)) / |cos θi| [pbrt-v4, §9.3], so the
//! sampled weight f_s |cos θi| / pdf is exactly R.
//!
//! Parameters: `reflectance` R in [0, 1] per channel.

use super::{BsdfSample, reflect_z};
use glam::Vec3;

#[derive(Clone, Debug, PartialEq)]
pub struct Mirror {
    /// Reflectance R per channel, in [0, 1].
    pub reflectance: Vec3,
}

impl Mirror {
    /// Zero: a delta lobe has no value at any given pair of directions.
    #[inline]
    pub fn eval(&self, _wo: Vec3, _wi: Vec3) -> Vec3 {
        Vec3::ZERO
    }

    /// Zero: a delta lobe has no solid-angle density.
    #[inline]
    pub fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }

    /// The mirror direction (−wo.x, −wo.y, wo.z), chosen with probability 1.
    #[inline]
    pub fn sample(&self, wo: Vec3) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let wi = reflect_z(wo);
        Some(BsdfSample {
            wi,
            f: self.reflectance / wi.z.abs(),
            pdf_w: 1.0,
            delta: true,
        })
    }
}
