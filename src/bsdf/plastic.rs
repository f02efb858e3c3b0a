//! A smooth plastic, as Mitsuba 3's `plastic`: a diffuse base under a smooth dielectric coating,
//! the coating's ideal (delta) reflection plus the base's light that crossed the coating twice
//! [Weidlich & Wilkie 2007; Mitsuba's documentation of `plastic`].
//!
//! Reflection of the coating: a delta lobe in the mirror direction with weight R_s F(cos θo, η).
//! The base, per unit solid angle:
//!
//! f_d(wo, wi) = ρ / (1 − F_dr) · (1 − F(cos θo)) (1 − F(cos θi)) / (π η²),
//!
//! where F is the dielectric Fresnel reflectance of the coating (relative index η) and F_dr the
//! coating's reflectance for diffuse light from inside, whose inter-reflections between base
//! and coating 1/(1 − F_dr) sums (ρ/(1 − ρ F_dr) with `nonlinear`, the exact geometric series).
//! F_dr is Mitsuba's `fresnel_diffuse_reflectance(1/η)`: Egan & Hilgeman's 1973 fit for
//! 1/η < 1 and d'Eon & Irving's 2011 fit otherwise (within 0.1–0.6 % of the integral
//! 2 ∫ F(μ) μ dμ over the usual indices), so that the same scene renders the same image.
//!
//! Sampling, as Mitsuba: the delta lobe with probability p_s = F(cos θo) s / (F s + (1 − F)(1 −
//! s)), s = mean(R_s)/(mean(ρ) + mean(R_s)), the cosine-weighted base otherwise. `eval` and
//! `pdf` describe the base alone (a delta lobe has no density); a sample of the coating is
//! flagged `delta`, with `pdf_w` its probability p_s. Like our other models it reflects on the
//! side of `wo`; Mitsuba's one-sidedness is the `one_sided` wrapper the importer puts around it.

use super::{BsdfSample, fresnel_dielectric, to_upper};
use crate::sampling::sample_cosine_hemisphere;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

#[derive(Clone, Debug, PartialEq)]
pub struct Plastic {
    pub diffuse_reflectance: Vec3,
    pub specular_reflectance: Vec3,
    /// Relative index of refraction of the coating, η = η_interior / η_exterior.
    pub ior: f32,
    pub nonlinear: bool,
}

/// Mitsuba's `fresnel_diffuse_reflectance(eta)`: the Fresnel reflectance at an interface of
/// relative index `eta`, averaged over cosine-distributed incident light, by the fits of Egan &
/// Hilgeman (1973) for eta < 1 and d'Eon & Irving (2011) otherwise.
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    let inv = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        // Horner's scheme in 1/eta of d'Eon & Irving's polynomial.
        [0.919_317f32, -3.4793, 6.753_35, -7.809_89, 4.985_54, -1.368_81]
            .iter()
            .rev()
            .fold(0.0, |acc, &c| acc * inv + c)
    }
}

impl Plastic {
    /// The coating's reflectance for diffuse light from inside, F_dr.
    #[inline]
    fn internal_reflectance(&self) -> f32 {
        fresnel_diffuse_reflectance(1.0 / self.ior)
    }

    /// Probability of sampling the coating's reflection for cos θo = `mu` (> 0).
    #[inline]
    pub(super) fn specular_probability(&self, mu: f32) -> f32 {
        let d_mean = self.diffuse_reflectance.element_sum() / 3.0;
        let s_mean = self.specular_reflectance.element_sum() / 3.0;
        let s = if d_mean + s_mean > 0.0 {
            s_mean / (d_mean + s_mean)
        } else {
            0.5
        };
        let f = fresnel_dielectric(mu, self.ior);
        let (p_spec, p_diff) = (f * s, (1.0 - f) * (1.0 - s));
        if p_spec + p_diff > 0.0 {
            p_spec / (p_spec + p_diff)
        } else {
            0.0
        }
    }

    /// The base's f_d (the delta lobe has no value here); reflects on the side of `wo`.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z * wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let (wo, wi) = to_upper(wo, wi);
        let rho = self.diffuse_reflectance;
        let f_dr = self.internal_reflectance();
        let bounce = if self.nonlinear {
            Vec3::ONE - rho * f_dr
        } else {
            Vec3::splat(1.0 - f_dr)
        };
        let (f_o, f_i) = (fresnel_dielectric(wo.z, self.ior), fresnel_dielectric(wi.z, self.ior));
        rho / bounce * (FRAC_1_PI / (self.ior * self.ior) * (1.0 - f_o) * (1.0 - f_i))
    }

    /// Density of the base's cosine sampling times the probability of choosing it.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z * wi.z <= 0.0 {
            return 0.0;
        }
        let (wo, wi) = to_upper(wo, wi);
        (1.0 - self.specular_probability(wo.z)) * wi.z * FRAC_1_PI
    }

    pub fn sample(&self, wo: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let mu = wo.z.abs();
        let p_spec = self.specular_probability(mu);
        if u_lobe < p_spec {
            // The coating's mirror reflection, chosen with probability p_spec.
            let weight = self.specular_reflectance * fresnel_dielectric(mu, self.ior);
            return BsdfSample::mirrored(wo, weight).map(|s| BsdfSample { pdf_w: p_spec, ..s });
        }
        BsdfSample::on_side_of(
            wo,
            sample_cosine_hemisphere(u),
            |wi| self.pdf(wo, wi),
            |wi| self.eval(wo, wi),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{albedo_by_quadrature, albedo_by_sampling, test_wos};
    use super::super::{Bsdf, TransportMode};
    use super::*;
    use crate::sampling::Rng;
    use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_test_directions};

    fn plastic(rho: f32, ior: f32, nonlinear: bool) -> Bsdf {
        Bsdf::Plastic(Plastic {
            diffuse_reflectance: Vec3::splat(rho),
            specular_reflectance: Vec3::ONE,
            ior,
            nonlinear,
        })
    }

    /// The base's samples follow `pdf` (χ²); the coating's delta samples are the rest, with
    /// probability 1 − ∫ pdf, and land in the mirror direction.
    #[test]
    fn the_base_samples_its_pdf_and_the_coating_takes_the_rest() {
        for (k, wo) in test_wos().into_iter().enumerate() {
            let bsdf = plastic(0.6, 1.5, false);
            let report = chi2_test_directions(
                |rng: &mut Rng| {
                    let s = bsdf.sample(wo, rng.uniform2(), rng.uniform(), TransportMode::Radiance)?;
                    if s.delta {
                        assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-5);
                        return None;
                    }
                    Some((s.wi, s.pdf_w))
                },
                |wi| bsdf.pdf(wo, wi),
                DirectionTest {
                    seed: k as u64,
                    ..DirectionTest::default()
                },
            );
            assert!(report.passes(CHI2_ALPHA), "wo {wo}: {report:?}");
        }
    }

    /// Energy: the coating reflects F(cos θo), the base returns ρ (1 − F(cos θo)) up to the
    /// fitted F_dr (Mitsuba's 0.1 % fit; exact reciprocity would make it ρ (1 − F) exactly);
    /// sampling and quadrature of the base agree; white plastic loses nothing beyond 1 %.
    #[test]
    fn plastic_reflects_fresnel_plus_the_base_behind_it() {
        for nonlinear in [false, true] {
            for wo in test_wos() {
                let mu = wo.z.abs();
                let bsdf = plastic(0.7, 1.5, nonlinear);
                let Bsdf::Plastic(p) = &bsdf else { unreachable!() };
                let f = f64::from(fresnel_dielectric(mu, p.ior));
                let base = albedo_by_quadrature(&bsdf, wo, TransportMode::Radiance);
                let (sampled, se) = albedo_by_sampling(&bsdf, wo, TransportMode::Radiance, 200_000);
                assert!(
                    (sampled - (f + base)).abs() < 4.0 * se + 1e-3,
                    "{sampled} ± {se} vs {f} + {base}"
                );
                if !nonlinear {
                    // ρ/(1 − F_dr) (1 − F_o)(1 − F_dr,ext)/η² with (1 − F_dr,ext) = η² (1 − F_dr).
                    let expected = 0.7 * (1.0 - f);
                    assert!(
                        (base / expected - 1.0).abs() < 0.01,
                        "base {base} vs ρ(1 − F) = {expected}"
                    );
                }
            }
        }
        let white = plastic(1.0, 1.5, false);
        for wo in test_wos() {
            let (a, _) = albedo_by_sampling(&white, wo, TransportMode::Radiance, 100_000);
            assert!(a < 1.01, "white plastic at {wo}: albedo {a}");
        }
    }

    #[test]
    fn fresnel_diffuse_reflectance_matches_the_integral() {
        // 2 ∫ F(μ, η) μ dμ by the midpoint rule against the fits.
        for eta in [1.0 / 1.5, 1.0 / 1.33, 1.33, 1.5, 2.0] {
            let n = 200_000;
            let integral: f64 = (0..n)
                .map(|i| {
                    let mu = (i as f64 + 0.5) / n as f64;
                    2.0 * f64::from(fresnel_dielectric(mu as f32, eta)) * mu / n as f64
                })
                .sum();
            let fit = f64::from(fresnel_diffuse_reflectance(eta));
            assert!(
                (fit - integral).abs() < 0.01 * integral.max(0.05),
                "η {eta}: fit {fit} vs {integral}"
            );
        }
    }
}
