//! Disney's thin-surface principled model as Mitsuba 3 defines it (`principledthin`; Burley
//! 2015, §4 "thin surfaces"): a two-dimensional sheet with nothing inside, symmetric between
//! its sides. For `wo` on either side (mirrored to the front), f is the sum of
//!
//! - diffuse, retro-reflection, fake subsurface and sheen as in [`super::Principled`], weighted
//!   (1 − spec_trans)(1 − diff_trans/2);
//! - Lambertian transmission (1 − spec_trans)(diff_trans/2) base/π (`diff_trans` ∈ [0, 2], as
//!   Burley's);
//! - glossy reflection spec_trans F_thin D G / (4 cos θo cos θi) with F_thin the dielectric
//!   Fresnel of η blended towards Schlick's tinted by the base colour (`spec_tint`);
//! - glossy transmission spec_trans base (1 − F) D' G' / (4 cos θo cos θi): the reflection
//!   through a microfacet, mirrored to the other side (a sheet bends nothing), with roughness
//!   scaled by 0.65 η − 0.35 [Burley 2015, Figure 15].
//!
//! Mitsuba's sheet reflects specularly only in proportion to spec_trans (its main glossy lobes
//! both carry that weight), which we keep. Sampling is Mitsuba's mixture of the four lobes,
//! ∝ spec_trans/2 · rate for the two glossy ones and (1 − spec_trans)(1 − d) · rate,
//! (1 − spec_trans) d · rate for the two diffuse ones (d = diff_trans/2).

use super::microfacet::Microfacet;
use super::principled::{
    DisneyParams, PrincipledParam, sampling_rates, schlick, schlick_r0, specular_distribution, tint,
};
use super::{BsdfSample, fresnel_signed, positive, reflect};
use crate::error::{Error, Result};
use crate::sampling::sample_cosine_hemisphere;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Mitsuba's `principledthin`. Weights in [0, 1], `diff_trans` in [0, 2], `eta` > 0.
#[derive(Clone, Debug, PartialEq)]
pub struct PrincipledThin {
    /// Base colour, roughness, anisotropy, spec_trans (the glossy lobes' share), the tints,
    /// sheen and flatness.
    pub shared: DisneyParams,
    /// Burley's diffuse transmission in [0, 2] (Mitsuba halves it).
    pub diff_trans: f32,
    /// The sheet's relative index of refraction (default 1.5).
    pub eta: f32,
    /// Sampling rates of specular reflection, specular transmission, diffuse reflection and
    /// diffuse transmission (Mitsuba's `*_sampling_rate`, 1 each by default).
    pub rates: [f32; 4],
}

/// A pair mirrored so that `wo` is on the front side.
struct Front {
    wo: Vec3,
    wi: Vec3,
    /// The half vector of `wo` and `wi` mirrored to `wo`'s side (transmission is a reflection
    /// mirrored through the sheet).
    h: Vec3,
}

impl Front {
    #[inline]
    fn new(wo: Vec3, wi: Vec3) -> Option<Self> {
        if wo.z == 0.0 {
            return None;
        }
        let s = wo.z.signum();
        let (wo, wi) = (wo * s, wi * s);
        let h = (wo + wi.with_z(wi.z.abs())).normalize_or_zero();
        Some(Self { wo, wi, h })
    }

    #[inline]
    fn reflect(&self) -> bool {
        self.wi.z > 0.0
    }

    #[inline]
    fn transmit(&self) -> bool {
        self.wi.z < 0.0
    }

    /// Mitsuba's `mac_mic_compatibility` with `wo` on the front side.
    #[inline]
    fn compatible(&self, reflection: bool) -> bool {
        let wi_side = if reflection {
            self.wi.dot(self.h)
        } else {
            -self.wi.dot(self.h)
        };
        self.wo.dot(self.h) > 0.0 && wi_side > 0.0
    }
}

impl PrincipledThin {
    /// Mitsuba's default sheet: base colour 0.5, roughness 0.5, η 1.5, the rest 0.
    pub fn mitsuba_default() -> Self {
        Self {
            shared: DisneyParams::default(),
            diff_trans: 0.0,
            eta: 1.5,
            rates: [1.0; 4],
        }
    }

    /// The glossy reflection's distribution.
    #[inline]
    fn reflection_distribution(&self) -> Microfacet {
        specular_distribution(self.shared.roughness, self.shared.anisotropic)
    }

    /// The glossy transmission's distribution: roughness scaled by 0.65 η − 0.35.
    #[inline]
    fn transmission_distribution(&self) -> Microfacet {
        specular_distribution(
            (0.65 * self.eta - 0.35) * self.shared.roughness,
            self.shared.anisotropic,
        )
    }

    /// Diffuse transmission's share d = diff_trans / 2.
    #[inline]
    fn d(&self) -> f32 {
        0.5 * self.diff_trans
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let Some(p) = Front::new(wo, wi) else {
            return Vec3::ZERO;
        };
        let (st, d) = (self.shared.spec_trans, self.d());
        let cos = (p.wo.z * p.wi.z).abs();
        if cos == 0.0 {
            return Vec3::ZERO;
        }
        let mut value = Vec3::ZERO;
        if st > 0.0 {
            let f_dielectric = fresnel_signed(p.wo.dot(p.h), self.eta);
            if p.reflect() && p.compatible(true) {
                let dist = self.reflection_distribution();
                let f_schlick = schlick(
                    tint(self.shared.base_color) * schlick_r0(self.eta),
                    p.wo.dot(p.h),
                    self.eta,
                );
                let f_thin = Vec3::splat(f_dielectric).lerp(f_schlick, self.shared.spec_tint);
                value += f_thin * (st * dist.d(p.h) * dist.g(p.wo, p.wi, p.h) / (4.0 * cos));
            }
            if p.transmit() && p.compatible(false) {
                let dist = self.transmission_distribution();
                value += self.shared.base_color
                    * (st * (1.0 - f_dielectric) * dist.d(p.h) * dist.g(p.wo, p.wi, p.h) / (4.0 * cos));
            }
        }
        if p.reflect() && st < 1.0 && d < 1.0 {
            let w = (1.0 - st) * (1.0 - d);
            value += self.shared.diffuse_and_sheen((p.wo, p.wi, p.h), (w, w));
        }
        if p.transmit() && st < 1.0 && d > 0.0 {
            value += self.shared.base_color * ((1.0 - st) * d * FRAC_1_PI);
        }
        value
    }

    /// (specular reflection, specular transmission, diffuse reflection, diffuse transmission),
    /// summing to 1.
    #[inline]
    fn lobe_probabilities(&self) -> [f32; 4] {
        let (st, d) = (self.shared.spec_trans, self.d());
        let [r_sr, r_st, r_dr, r_dt] = self.rates;
        let p = [
            0.5 * st * r_sr,
            0.5 * st * r_st,
            r_dr * (1.0 - st) * (1.0 - d),
            r_dt * (1.0 - st) * d,
        ];
        let total: f32 = p.iter().sum();
        if total > 0.0 { p.map(|x| x / total) } else { [0.0; 4] }
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(p) = Front::new(wo, wi) else {
            return 0.0;
        };
        let [p_sr, p_st, p_dr, p_dt] = self.lobe_probabilities();
        let mut pdf = 0.0;
        if self.shared.spec_trans > 0.0 {
            let dh_dwi = 1.0 / (4.0 * p.wi.with_z(p.wi.z.abs()).dot(p.h)).abs();
            if p.reflect() && p.compatible(true) {
                pdf += p_sr * self.reflection_distribution().pdf(p.wo, p.h) * dh_dwi;
            }
            if p.transmit() && p.compatible(false) {
                pdf += p_st * self.transmission_distribution().pdf(p.wo, p.h) * dh_dwi;
            }
        }
        if p.reflect() {
            pdf += p_dr * p.wi.z * FRAC_1_PI;
        }
        if p.transmit() {
            pdf += p_dt * -p.wi.z * FRAC_1_PI;
        }
        if pdf.is_finite() { pdf } else { 0.0 }
    }

    pub fn sample(&self, wo: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let s = wo.z.signum();
        let front = wo * s;
        let [p_sr, p_st, p_dr, _] = self.lobe_probabilities();
        let wi = if u_lobe < p_sr + p_st {
            let dist = if u_lobe < p_sr {
                self.reflection_distribution()
            } else {
                self.transmission_distribution()
            };
            let (m, _) = dist.sample(front, u)?;
            let wi = reflect(front, m);
            // Mitsuba's checks on the direction it returns: a reflection sees m's front, a
            // transmission (the reflection mirrored) its back.
            let (wi, wi_side) = if u_lobe < p_sr {
                (wi, wi.dot(m))
            } else {
                (wi.with_z(-wi.z), wi.with_z(-wi.z).dot(-m))
            };
            let on_side = if u_lobe < p_sr { wi.z > 0.0 } else { wi.z < 0.0 };
            if !(front.dot(m) > 0.0 && wi_side > 0.0 && on_side) {
                return None;
            }
            wi
        } else if u_lobe < p_sr + p_st + p_dr {
            sample_cosine_hemisphere(u)
        } else {
            -sample_cosine_hemisphere(u)
        };
        let wi = wi * s;
        let pdf_w = self.pdf(wo, wi);
        (pdf_w > 0.0).then(|| BsdfSample {
            wi,
            f: self.eval(wo, wi),
            pdf_w,
            delta: false,
        })
    }

    /// Whether a diffuse lobe (reflection or transmission) has weight.
    pub fn has_diffuse(&self) -> bool {
        self.shared.spec_trans < 1.0 && self.shared.base_color.max_element() > 0.0
    }

    /// A per-channel bound on ∫ f |cos θi| dωi: the diffuse and sheen bound
    /// ([`DisneyParams::diffuse_and_sheen_bound`]) at their weight, diffuse transmission, and
    /// both glossy lobes at most spec_trans max(1, F_thin) and spec_trans base.
    pub fn albedo(&self) -> Vec3 {
        let (st, d) = (self.shared.spec_trans, self.d());
        let w = (1.0 - st) * (1.0 - d);
        let glossy =
            (tint(self.shared.base_color) * schlick_r0(self.eta)).max(Vec3::ONE) * st + self.shared.base_color * st;
        self.shared.diffuse_and_sheen_bound((w, w)) + self.shared.base_color * ((1.0 - st) * d) + glossy
    }

    /// Sets a textured parameter to its value at a hit (a number from any channel); false when
    /// the model has no such parameter.
    pub fn set(&mut self, param: PrincipledParam, c: Vec3) -> bool {
        if param == PrincipledParam::DiffTrans {
            self.diff_trans = c.x;
            return true;
        }
        self.shared.set(param, c)
    }

    /// The ranges the model needs (the loader checks them field by field first).
    pub fn validate(&self) -> Result<()> {
        self.shared.validate()?;
        if !(0.0..=2.0).contains(&self.diff_trans) {
            return Err(Error::new(format!(
                "diff_trans must lie in [0, 2], got {}",
                self.diff_trans
            )));
        }
        positive("eta", self.eta)?;
        sampling_rates(&self.rates)
    }
}
