//! Mitsuba 3's `pplastic` without polarisation (what its RGB variants render): Baek et al.'s
//! 2018 pBRDF ("Simultaneous Acquisition of Polarimetric SVBRDF and Normals"), a rough
//! specular reflection added to a diffuse lobe that two smooth refractions attenuate,
//!
//!   f = k_s F(wo·h) D(h) G(wo, wi, h) / (4 cos θo cos θi) + ρ/π (1 − F(cos θo)) (1 − F(cos θi)),
//!
//! F the dielectric Fresnel reflectance at relative index η. Unlike `roughplastic` the two lobes
//! do not exchange light (no internal reflection, no tabulated coating): the specular lobe is
//! never more than the light both refractions take from the diffuse one, so the sum does not
//! create energy, but it loses some. Sampling picks the specular lobe with probability
//! mean(k_s) / (mean(ρ) + mean(k_s)) — ρ's mean over its whole texture, fixed when the material
//! is built, as Mitsuba's `parameters_changed` does — then a microfacet normal (visible or all
//! normals) or a cosine-weighted direction.

use super::microfacet::Microfacet;
use super::{BsdfSample, fresnel_dielectric, to_upper};
use crate::sampling::sample_cosine_hemisphere;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

#[derive(Clone, Debug, PartialEq)]
pub struct Pplastic {
    /// ρ, the diffuse lobe's reflectance.
    pub diffuse_reflectance: Vec3,
    /// k_s, scaling the specular lobe (1 for physical realism).
    pub specular_reflectance: Vec3,
    /// Relative index of refraction η (inside over outside).
    pub ior: f32,
    pub distribution: Microfacet,
    /// Probability of sampling the specular lobe.
    pub specular_probability: f32,
}

impl Pplastic {
    /// The model with the sampling weight Mitsuba gives it: `mean_diffuse` is the mean of ρ over
    /// the surface (its texture's mean when textured), averaged over channels.
    pub fn new(diffuse: Vec3, specular: Vec3, ior: f32, distribution: Microfacet, mean_diffuse: f32) -> Self {
        let s_mean = specular.element_sum() / 3.0;
        let total = mean_diffuse + s_mean;
        Self {
            diffuse_reflectance: diffuse,
            specular_reflectance: specular,
            ior,
            distribution,
            specular_probability: if total > 0.0 { s_mean / total } else { 0.5 },
        }
    }

    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z * wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let (wo, wi) = to_upper(wo, wi);
        let specular = self.distribution.reflection(wo, wi).map_or(Vec3::ZERO, |(h, dg)| {
            self.specular_reflectance * (fresnel_dielectric(wo.dot(h), self.ior) * dg)
        });
        let t = (1.0 - fresnel_dielectric(wo.z, self.ior)) * (1.0 - fresnel_dielectric(wi.z, self.ior));
        specular + self.diffuse_reflectance * (FRAC_1_PI * t)
    }

    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z * wi.z <= 0.0 {
            return 0.0;
        }
        let (wo, wi) = to_upper(wo, wi);
        let p = self.specular_probability;
        p * self.distribution.reflection_pdf(wo, wi) + (1.0 - p) * wi.z * FRAC_1_PI
    }

    pub fn sample(&self, wo: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let wo_up = wo.with_z(wo.z.abs());
        let wi_up = if u_lobe < self.specular_probability {
            self.distribution.sample_reflection(wo_up, u)?
        } else {
            sample_cosine_hemisphere(u)
        };
        BsdfSample::on_side_of(wo, wi_up, |wi| self.pdf(wo, wi), |wi| self.eval(wo, wi))
    }
}
