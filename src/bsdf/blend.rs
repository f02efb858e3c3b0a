//! A linear blend of two models, as Mitsuba 3's `blendbsdf`: f = (1 − w) f₀ + w f₁ with the
//! weight w in [0, 1] (a texture's luminance where the material is textured).
//!
//! Sampling picks model 1 with probability w and model 0 otherwise, as Mitsuba does, and
//! reports what the *blend* does in the sampled direction, so that `sample`, `pdf` and `eval`
//! agree by construction: a non-delta sample carries the blend's f and its density
//! (1 − w) p₀ + w p₁ (each model's `pdf` is the density of its non-delta samples); a delta
//! sample carries the sum over both models of every delta lobe into that direction —
//! coefficients weighted by (1 − w) and w, probabilities likewise ([`Bsdf::delta_lobe`]) — so
//! that two mirrors blended (two smooth conductors, a conductor and a dielectric's reflection)
//! are one lobe of the summed coefficient, as path space needs it.
//!
//! Mitsuba 3.9.1 differs where one model has a delta lobe: its delta samples divide by
//! w · 1 + (1 − w) p₀(ω), a discrete probability added to the other model's density, which is
//! not a probability of anything and weighs the delta lobe down wherever the other model
//! reflects ( `docs/user-guide.md`, "Blended materials"). Between two non-delta models the two
//! agree exactly.

use super::{Bsdf, BsdfSample, TransportMode};
use glam::{Vec2, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct Blend {
    /// w: the share of `bsdfs[1]`.
    pub weight: f32,
    pub bsdfs: [Bsdf; 2],
}

impl Blend {
    /// The two models with their shares, (1 − w, f₀) and (w, f₁).
    #[inline]
    fn parts(&self) -> [(f32, &Bsdf); 2] {
        [(1.0 - self.weight, &self.bsdfs[0]), (self.weight, &self.bsdfs[1])]
    }

    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        self.parts()
            .iter()
            .filter(|(w, _)| *w > 0.0)
            .map(|(w, b)| *w * b.eval(wo, wi, mode))
            .sum()
    }

    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.parts()
            .iter()
            .filter(|(w, _)| *w > 0.0)
            .map(|(w, b)| w * b.pdf(wo, wi))
            .sum()
    }

    pub fn sample(&self, wo: Vec3, u: Vec2, u_lobe: f32, mode: TransportMode) -> Option<BsdfSample> {
        let w = self.weight;
        // Model 1 for u_lobe < w, rescaled so that each model sees a uniform number.
        let (b, u_lobe) = if u_lobe < w {
            (&self.bsdfs[1], u_lobe / w)
        } else {
            (&self.bsdfs[0], ((u_lobe - w) / (1.0 - w)).min(1.0 - f32::EPSILON))
        };
        let s = b.sample(wo, u, u_lobe, mode)?;
        if s.delta {
            let (f, pdf_w) = self.delta_lobe(wo, s.wi, mode)?;
            return (pdf_w > 0.0).then_some(BsdfSample { f, pdf_w, ..s });
        }
        let pdf_w = self.pdf(wo, s.wi);
        (pdf_w > 0.0).then(|| BsdfSample {
            f: self.eval(wo, s.wi, mode),
            pdf_w,
            ..s
        })
    }

    /// The blend's delta lobes into `wi`: the sums of both models' coefficients and
    /// probabilities, each weighted by its share.
    pub fn delta_lobe(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Option<(Vec3, f32)> {
        let mut sum: Option<(Vec3, f32)> = None;
        for (w, b) in self.parts() {
            if w > 0.0
                && let Some((f, p)) = b.delta_lobe(wo, wi, mode)
            {
                let (f0, p0) = sum.unwrap_or((Vec3::ZERO, 0.0));
                sum = Some((f0 + w * f, p0 + w * p));
            }
        }
        sum
    }

    /// The probability that sampling from `wo` picks a delta lobe.
    pub fn delta_probability(&self, wo: Vec3) -> f32 {
        self.parts()
            .iter()
            .map(|(w, b)| if *w > 0.0 { w * b.delta_probability(wo) } else { 0.0 })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{albedo_by_sampling, blend, microfacet, rough_conductor, rough_plastic, test_wos};
    use super::super::{Conductor, ConductorIor, Dielectric, Lambertian, MicrofacetType, Mirror};
    use super::*;
    use crate::sampling::Rng;
    use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_test_directions};

    fn gold() -> Bsdf {
        Bsdf::Conductor(Conductor {
            ior: ConductorIor::named("Au").unwrap(),
        })
    }

    /// Mitsuba's documentation scene: a black rough plastic blended with a smooth gold.
    fn plastic_and_gold(w: f32) -> Bsdf {
        blend(
            w,
            rough_plastic(0.0, 1.49, microfacet(MicrofacetType::Ggx, 0.3, 0.3, true), false),
            gold(),
        )
    }

    /// With a delta model in the blend, the non-delta samples follow `pdf` (χ²) and the delta
    /// ones are the rest, w of them here, all in the mirror direction with the blend's
    /// coefficient and probability.
    #[test]
    fn a_blend_with_a_mirror_samples_its_pdf_and_the_mirror_takes_its_share() {
        for (k, wo) in test_wos().into_iter().enumerate() {
            let w = 0.35;
            let bsdf = plastic_and_gold(w);
            assert!(bsdf.mixes_delta() && !bsdf.is_delta());
            assert!((bsdf.delta_probability(wo) - w).abs() < 1e-6);
            let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
            let report = chi2_test_directions(
                |rng: &mut Rng| {
                    let s = bsdf.sample(wo, rng.uniform2(), rng.uniform(), TransportMode::Radiance)?;
                    if s.delta {
                        assert!((s.wi - mirror).length() < 1e-5);
                        assert!((s.pdf_w - w).abs() < 1e-6);
                        let (f, p) = gold().delta_lobe(wo, mirror, TransportMode::Radiance).unwrap();
                        assert!((s.f - w * f).length() < 1e-5 && (p - 1.0).abs() < 1e-6);
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

    /// Energy is linear in the weight: the blend's albedo (by its own sampler) is (1 − w) and
    /// w of its models' (by theirs), within 4 standard errors.
    #[test]
    fn a_blends_albedo_is_the_weighted_sum_of_its_models() {
        let models = [
            plastic_and_gold(0.4),
            blend(
                0.7,
                Bsdf::Lambertian(Lambertian {
                    reflectance: Vec3::splat(0.6),
                }),
                gold(),
            ),
        ];
        for bsdf in models {
            let Bsdf::Blend(b) = &bsdf else { unreachable!() };
            for wo in test_wos() {
                let mode = TransportMode::Radiance;
                let (a, se) = albedo_by_sampling(&bsdf, wo, mode, 200_000);
                let (a0, se0) = albedo_by_sampling(&b.bsdfs[0], wo, mode, 200_000);
                let (a1, se1) = albedo_by_sampling(&b.bsdfs[1], wo, mode, 200_000);
                let w = b.weight as f64;
                let expected = (1.0 - w) * a0 + w * a1;
                let tol = 4.0 * (se * se + ((1.0 - w) * se0).powi(2) + (w * se1).powi(2)).sqrt() + 1e-6;
                assert!((a - expected).abs() < tol, "wo {wo}: {a} vs {expected} ± {tol}");
            }
        }
    }

    /// Two delta models reflecting into the same direction are one lobe: a mirror blended with a
    /// glass's reflection sums their coefficients and probabilities (a glass also refracts,
    /// a lobe of its own), and sampling the blend reports that sum whichever model it picked.
    #[test]
    fn coinciding_delta_lobes_of_a_blend_add_up() {
        let mirror = Bsdf::Mirror(Mirror {
            reflectance: Vec3::splat(0.9),
        });
        let glass = Bsdf::Dielectric(Dielectric::clear(1.5));
        let w = 0.25;
        let both = blend(w, mirror.clone(), glass.clone());
        assert!(both.is_delta() && !both.mixes_delta());
        let mode = TransportMode::Radiance;
        let wo = Vec3::new(0.3, -0.2, 0.8).normalize();
        let reflected = Vec3::new(-wo.x, -wo.y, wo.z);
        let (fm, pm) = mirror.delta_lobe(wo, reflected, mode).unwrap();
        let (fg, pg) = glass.delta_lobe(wo, reflected, mode).unwrap();
        let (f, p) = both.delta_lobe(wo, reflected, mode).unwrap();
        assert!((f - ((1.0 - w) * fm + w * fg)).length() < 1e-6, "{f}");
        assert!((p - ((1.0 - w) * pm + w * pg)).abs() < 1e-6, "{p}");
        for u_lobe in [0.01, 0.2, 0.3, 0.99] {
            let s = both.sample(wo, Vec2::ZERO, u_lobe, mode).unwrap();
            if (s.wi - reflected).length() < 1e-5 {
                assert!(
                    (s.f - f).length() < 1e-6 && (s.pdf_w - p).abs() < 1e-6,
                    "u_lobe {u_lobe}"
                );
            } else {
                // The glass's refraction, chosen with w (1 − F).
                let (ft, pt) = glass.delta_lobe(wo, s.wi, mode).unwrap();
                assert!((s.f - w * ft).length() < 1e-6 && (s.pdf_w - w * pt).abs() < 1e-6);
            }
        }
        // A weight of 0 or 1 is the one model.
        let only_gold = rough_conductor(Some("Au"), microfacet(MicrofacetType::Ggx, 0.2, 0.2, true));
        let edge = blend(1.0, mirror, only_gold.clone());
        let (wi, u) = (Vec3::new(-0.2, 0.3, 0.7).normalize(), Vec2::new(0.3, 0.6));
        assert_eq!(edge.eval(wo, wi, mode), only_gold.eval(wo, wi, mode));
        assert_eq!(edge.pdf(wo, wi), only_gold.pdf(wo, wi));
        let (a, b) = (
            edge.sample(wo, u, 0.7, mode).unwrap(),
            only_gold.sample(wo, u, 0.7, mode).unwrap(),
        );
        assert_eq!((a.wi, a.f, a.pdf_w), (b.wi, b.f, b.pdf_w));
    }
}
