//! Ideal specular reflection: a delta lobe toward the mirror direction of `wo`, scaled by a
//! per-channel reflectance R.
//!
//! As a distribution, f_s(wo, wi) = R δ(wi − reflect(wo)) / |cos θi| [pbrt-v4, §9.3], so the
//! sampled weight f_s |cos θi| / pdf is exactly R.
//!
//! Parameters: `reflectance` R in [0, 1] per channel.

use super::BsdfSample;
use glam::Vec3;

#[derive(Clone, Debug, PartialEq)]
pub struct Mirror {
    /// Reflectance R per channel, in [0, 1].
    pub reflectance: Vec3,
}

impl Mirror {
    /// The mirror direction (−wo.x, −wo.y, wo.z), chosen with probability 1.
    #[inline]
    pub fn sample(&self, wo: Vec3) -> Option<BsdfSample> {
        BsdfSample::mirrored(wo, self.reflectance)
    }
}
