//! Disney's principled model as Mitsuba 3 defines it (`principled`): Burley's "Physically
//! Based Shading at Disney" (2012) and its BSDF extension ("Extending the Disney BRDF to a BSDF
//! with Integrated Subsurface Scattering", 2015), with the weights, Fresnel blends and sampling
//! of Mitsuba 3's `principled.cpp` and `principledhelpers.h`. The thin-surface variant is
//! [`super::PrincipledThin`].
//!
//! With weights w_brdf = (1 − metallic)(1 − spec_trans) and w_bsdf = (1 − metallic) spec_trans,
//! on the front side (cos θo > 0) f is the sum of
//!
//! - diffuse with retro-reflection [Burley 2015, eqs. 4–5], or Hanrahan–Krueger's flattened
//!   "fake subsurface" as `flatness` blends towards it:
//!   w_brdf (base/π) lerp((1 − F_o/2)(1 − F_i/2) + R_R (F_o + F_i + F_o F_i (R_R − 1)), f_ss, flatness),
//!   R_R = 2 roughness cos²θ_d, F_x = (1 − cos θ_x)⁵ (Schlick's weight);
//! - sheen: sheen (1 − metallic) F_d lerp(1, base/lum(base), sheen_tint);
//! - the main anisotropic GGX lobe, F_p D G / (4 cos θo cos θi), α from roughness² and
//!   `anisotropic` [Burley 2012, addenda B.2]; its Fresnel F_p blends the dielectric Fresnel
//!   of η, Schlick's of the base colour (metallic) and Schlick's of η tinted by the base colour
//!   (spec_tint) — `principled_fresnel`;
//! - transmission through the same microfacets [Walter 2007, eq. 21], tinted by √base and
//!   weighted by w_bsdf, radiance compressed by 1/η² as in our [`super::RoughDielectric`];
//! - clearcoat: ¼ clearcoat F_cc D_cc G_cc with GTR1's D_cc of α = lerp(0.1, 0.001, gloss),
//!   Schlick's F_cc of R₀ = 0.04 and the separable GGX G_cc of α = 0.25.
//!
//! From behind (cos θo < 0) only the main lobe remains: reflection with Fresnel w_bsdf F and
//! transmission; an opaque principled surface (w_bsdf = 0) is black from behind.
//!
//! **Decisions, where Mitsuba's definition departs from Burley's or is ambiguous** (written also
//! in `docs/design.md`):
//! - The clearcoat lobe is Mitsuba's: its value has no 1/(4 cos θo cos θi) (Burley's G_cc folds
//!   it into a separable G; Mitsuba's `clearcoat_G` is the plain G1 product). We reproduce
//!   Mitsuba, so that its scenes render as Mitsuba renders them.
//! - Sheen is evaluated wherever its own mask holds (front side, reflection, metallic < 1),
//!   as Mitsuba's vectorised variants do; its scalar variant also needs w_brdf > 0 (it tests
//!   the diffuse mask first), which differs only at spec_trans = 1 exactly.
//! - Mitsuba's sampler draws from the back side only when w_bsdf > 0 while its `pdf` is then
//!   positive; there the value is zero, so our sampler and `pdf` both give nothing.
//!
//! Sampling is Mitsuba's one-sample mixture: on the front side, diffuse (cosine-weighted)
//! with probability ∝ w_brdf · rate_d, clearcoat (GTR1 normals) ∝ ¼ clearcoat · rate_cc, and the
//! main lobe ∝ rate_s, split between reflection and transmission by 1 − w_bsdf (1 − F) and
//! w_bsdf (1 − F) at the sampled visible normal; from behind, reflection and transmission with
//! F and 1 − F. `pdf` is that mixture's density, so sample, `eval` and `pdf` agree by
//! construction.

use super::microfacet::{Microfacet, MicrofacetType};
use super::rough_dielectric::refract_through;
use super::{BsdfSample, TransportMode, fresnel_signed, positive, reflect, unit};
use crate::color::luminance;
use crate::error::{Error, Result};
use crate::sampling::sample_cosine_hemisphere;
use glam::{FloatExt, Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// The parameters both principled models read, with Mitsuba's defaults
/// ([`DisneyParams::default`]): every weight in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DisneyParams {
    /// The base colour (`base_color`), in [0, 1] per channel; default 0.5.
    pub base_color: Vec3,
    /// Default 0.5.
    pub roughness: f32,
    pub anisotropic: f32,
    /// The share of transmission (`spec_trans`): of the dielectric part in [`Principled`], of
    /// the glossy lobes in [`super::PrincipledThin`].
    pub spec_trans: f32,
    pub spec_tint: f32,
    pub sheen: f32,
    pub sheen_tint: f32,
    pub flatness: f32,
}

impl Default for DisneyParams {
    fn default() -> Self {
        Self {
            base_color: Vec3::splat(0.5),
            roughness: 0.5,
            anisotropic: 0.0,
            spec_trans: 0.0,
            spec_tint: 0.0,
            sheen: 0.0,
            sheen_tint: 0.0,
            flatness: 0.0,
        }
    }
}

impl DisneyParams {
    /// The field a textured parameter sets, if it is one of these.
    fn field(&mut self, param: PrincipledParam) -> Option<&mut f32> {
        use PrincipledParam::*;
        Some(match param {
            Roughness => &mut self.roughness,
            Anisotropic => &mut self.anisotropic,
            SpecTrans => &mut self.spec_trans,
            SpecTint => &mut self.spec_tint,
            Sheen => &mut self.sheen,
            SheenTint => &mut self.sheen_tint,
            Flatness => &mut self.flatness,
            BaseColor | Metallic | Clearcoat | ClearcoatGloss | DiffTrans => return None,
        })
    }

    /// Sets a textured parameter (the base colour, or one of the shared numbers from any
    /// channel); false for a parameter that is not shared.
    pub(super) fn set(&mut self, param: PrincipledParam, c: Vec3) -> bool {
        if param == PrincipledParam::BaseColor {
            self.base_color = c;
            return true;
        }
        match self.field(param) {
            Some(f) => {
                *f = c.x;
                true
            }
            None => false,
        }
    }

    /// Every shared weight in [0, 1] and the base colour too.
    pub(super) fn validate(&self) -> Result<()> {
        unit("base_color", self.base_color)?;
        for (name, x) in [
            ("roughness", self.roughness),
            ("anisotropic", self.anisotropic),
            ("spec_trans", self.spec_trans),
            ("spec_tint", self.spec_tint),
            ("sheen", self.sheen),
            ("sheen_tint", self.sheen_tint),
            ("flatness", self.flatness),
        ] {
            unit(name, Vec3::splat(x))?;
        }
        Ok(())
    }

    /// Burley's diffuse with retro-reflection (or its flattened blend) and sheen, for `wo`, `wi`
    /// on the upper side with reflection half vector `h`, weighted (w_diffuse, w_sheen); f
    /// without the cosine [Burley 2015, eqs. 4–5; Mitsuba's `principled.cpp`].
    #[inline]
    pub(super) fn diffuse_and_sheen(&self, (wo, wi, h): (Vec3, Vec3, Vec3), (w_diffuse, w_sheen): (f32, f32)) -> Vec3 {
        let mut value = Vec3::ZERO;
        let cos_d = h.dot(wi);
        if w_diffuse > 0.0 {
            let (f_o, f_i) = (schlick_weight(wi.z.abs()), schlick_weight(wo.z.abs()));
            let f_diff = (1.0 - 0.5 * f_i) * (1.0 - 0.5 * f_o);
            let r_r = 2.0 * self.roughness * cos_d * cos_d;
            let f_retro = r_r * (f_o + f_i + f_o * f_i * (r_r - 1.0));
            let lobe = if self.flatness > 0.0 {
                let f_ss90 = 0.5 * r_r;
                let f_ss = 1.0.lerp(f_ss90, f_o) * 1.0.lerp(f_ss90, f_i);
                let ss = 1.25 * (f_ss * (1.0 / (wo.z.abs() + wi.z.abs()) - 0.5) + 0.5);
                (f_diff + f_retro).lerp(ss, self.flatness)
            } else {
                f_diff + f_retro
            };
            value += self.base_color * (w_diffuse * FRAC_1_PI * lobe);
        }
        if self.sheen > 0.0 && w_sheen > 0.0 {
            value += self.sheen_colour() * (self.sheen * w_sheen * schlick_weight(cos_d.abs()));
        }
        value
    }

    /// The sheen's colour: white blended towards the base colour's hue by `sheen_tint`.
    #[inline]
    fn sheen_colour(&self) -> Vec3 {
        Vec3::ONE.lerp(tint(self.base_color), self.sheen_tint)
    }

    /// A per-channel bound on ∫ f |cos θi| dωi of [`DisneyParams::diffuse_and_sheen`]:
    /// f_diff + f_retro ≤ 1 + 2 · 3 and the fake subsurface ≤ 1.25 (2 + ½), each over cos/π;
    /// the sheen ≤ π sheen max(1, its colour).
    pub(super) fn diffuse_and_sheen_bound(&self, (w_diffuse, w_sheen): (f32, f32)) -> Vec3 {
        self.base_color * (7.0 * w_diffuse) + self.sheen_colour().max(Vec3::ONE) * (PI * self.sheen * w_sheen)
    }
}

/// Mitsuba's `principled`. Every weight lies in [0, 1]; `eta` > 0 (interior over exterior).
#[derive(Clone, Debug, PartialEq)]
pub struct Principled {
    /// Base colour, roughness, anisotropy, spec_trans (the dielectric part's share that is
    /// transmission), the tints, sheen and flatness.
    pub shared: DisneyParams,
    pub metallic: f32,
    /// η of the dielectric part; Mitsuba derives it from `specular` when `eta` is not given:
    /// η = 2 / (1 − √(0.08 specular)) − 1 ([`Principled::eta_of_specular`]).
    pub eta: f32,
    pub clearcoat: f32,
    pub clearcoat_gloss: f32,
    /// Sampling rates of the diffuse, main specular and clearcoat lobes (Mitsuba's
    /// `diffuse_reflectance_sampling_rate`, `main_specular_sampling_rate`,
    /// `clearcoat_sampling_rate`; 1 each by default).
    pub rates: [f32; 3],
    /// Wrapped in Mitsuba's `twosided`: the back side is the front side mirrored (only without
    /// transmission, as Mitsuba requires).
    pub two_sided: bool,
}

/// Mitsuba's default Fresnel reflectance at normal incidence of the clearcoat.
const CLEARCOAT_R0: f32 = 0.04;
/// Mitsuba's roughness of the clearcoat's shadowing (Burley's 0.25).
const CLEARCOAT_G_ALPHA: f32 = 0.25;

impl Principled {
    /// Mitsuba's η for a `specular` value: the index whose Schlick R₀ is 0.08 specular.
    pub fn eta_of_specular(specular: f32) -> f32 {
        2.0 / (1.0 - (0.08 * specular).sqrt()) - 1.0
    }

    /// Mitsuba's default material: base colour 0.5, roughness 0.5, specular 0.5, the rest 0.
    pub fn mitsuba_default() -> Self {
        Self {
            shared: DisneyParams::default(),
            metallic: 0.0,
            eta: Self::eta_of_specular(0.5),
            clearcoat: 0.0,
            clearcoat_gloss: 0.0,
            rates: [1.0; 3],
            two_sided: false,
        }
    }

    /// Sets a textured parameter to its value at a hit (a number from any channel); false when
    /// the model has no such parameter.
    pub fn set(&mut self, param: PrincipledParam, c: Vec3) -> bool {
        let own = match param {
            PrincipledParam::Metallic => &mut self.metallic,
            PrincipledParam::Clearcoat => &mut self.clearcoat,
            PrincipledParam::ClearcoatGloss => &mut self.clearcoat_gloss,
            _ => return self.shared.set(param, c),
        };
        *own = c.x;
        true
    }

    /// The ranges the model needs (the loader checks them field by field first).
    pub fn validate(&self) -> Result<()> {
        self.shared.validate()?;
        for (name, x) in [
            ("metallic", self.metallic),
            ("clearcoat", self.clearcoat),
            ("clearcoat_gloss", self.clearcoat_gloss),
        ] {
            unit(name, Vec3::splat(x))?;
        }
        positive("eta", self.eta)?;
        sampling_rates(&self.rates)?;
        if self.two_sided && self.shared.spec_trans > 0.0 {
            return Err(Error::new(
                "a two-sided principled material cannot transmit (spec_trans must be 0)",
            ));
        }
        Ok(())
    }

    /// (w_brdf, w_bsdf): the weights of the opaque dielectric and the transmitting parts.
    #[inline]
    fn weights(&self) -> (f32, f32) {
        let dielectric = 1.0 - self.metallic;
        (
            dielectric * (1.0 - self.shared.spec_trans),
            dielectric * self.shared.spec_trans,
        )
    }

    #[inline]
    fn distribution(&self) -> Microfacet {
        specular_distribution(self.shared.roughness, self.shared.anisotropic)
    }

    #[inline]
    fn clearcoat_distribution(&self) -> Gtr1 {
        Gtr1 {
            alpha: 0.1.lerp(0.001, self.clearcoat_gloss),
        }
    }

    /// The pair as the one-sided model sees it: mirrored to the front when two-sided.
    #[inline]
    fn sided(&self, wo: Vec3, wi: Vec3) -> (Vec3, Vec3) {
        if self.two_sided && wo.z < 0.0 {
            (wo.with_z(-wo.z), wi.with_z(-wi.z))
        } else {
            (wo, wi)
        }
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        let (wo, wi) = self.sided(wo, wi);
        let Some(pair) = Pair::new(wo, wi, self.eta) else {
            return Vec3::ZERO;
        };
        let (w_brdf, w_bsdf) = self.weights();
        let (front, h) = (pair.front, pair.h);
        let d = self.distribution();
        let f_dielectric = fresnel_signed(wo.dot(h), self.eta);
        let mut value = Vec3::ZERO;
        if pair.reflect && pair.compatible(true) {
            if f_dielectric > 0.0 {
                let f_p = self.principled_fresnel(f_dielectric, wo.dot(h), front, w_bsdf);
                value += f_p * (d.d(h) * d.g(wo, wi, h) / (4.0 * (wo.z * wi.z).abs()));
            }
            if self.clearcoat > 0.0 && front {
                let f_cc = schlick(Vec3::splat(CLEARCOAT_R0), wo.dot(h), self.eta).x;
                let g_cc = smith_ggx1(wo, h, CLEARCOAT_G_ALPHA) * smith_ggx1(wi, h, CLEARCOAT_G_ALPHA);
                value += Vec3::splat(0.25 * self.clearcoat * f_cc * self.clearcoat_distribution().d(h) * g_cc);
            }
        }
        if !pair.reflect && w_bsdf > 0.0 && pair.compatible(false) && f_dielectric < 1.0 {
            let eta = pair.eta_path;
            let scale = match mode {
                TransportMode::Radiance => 1.0 / (eta * eta),
                TransportMode::Importance => 1.0,
            };
            let (wo_h, wi_h) = (wo.dot(h), wi.dot(h));
            let denom = wo_h + eta * wi_h;
            let t = scale * (1.0 - f_dielectric) * d.d(h) * d.g(wo, wi, h) * eta * eta * wo_h * wi_h
                / (wo.z * wi.z * denom * denom);
            if t.is_finite() {
                value += self.shared.base_color.map(f32::sqrt) * (w_bsdf * t.abs());
            }
        }
        if pair.reflect && front {
            value += self
                .shared
                .diffuse_and_sheen((wo, wi, h), (w_brdf, 1.0 - self.metallic));
        }
        value
    }

    /// Mitsuba's `principled_fresnel`: on the front side the dielectric Fresnel blended with
    /// Schlick's of the base colour (metallic) and of η tinted by the base colour (spec_tint);
    /// from behind, the dielectric Fresnel times w_bsdf.
    #[inline]
    fn principled_fresnel(&self, f_dielectric: f32, cos_h: f32, front: bool, w_bsdf: f32) -> Vec3 {
        if !front {
            return Vec3::splat(w_bsdf * f_dielectric);
        }
        let metal = schlick(self.shared.base_color, cos_h, self.eta) * self.metallic;
        // Mitsuba takes R₀ of η or 1/η by side; R₀ is the same for both.
        let tinted = schlick(tint(self.shared.base_color) * schlick_r0(self.eta), cos_h, self.eta)
            * ((1.0 - self.metallic) * self.shared.spec_tint);
        Vec3::splat((1.0 - self.metallic) * (1.0 - self.shared.spec_tint) * f_dielectric) + metal + tinted
    }

    /// The lobe probabilities of the mixture for a pair on side `front` whose main-lobe normal
    /// has dielectric Fresnel `f`: (diffuse, clearcoat, transmission, reflection), summing to 1.
    #[inline]
    fn lobe_probabilities(&self, front: bool, f: f32) -> [f32; 4] {
        let (w_brdf, w_bsdf) = self.weights();
        let [rate_d, rate_s, rate_cc] = self.rates;
        let p = if front {
            [
                w_brdf * rate_d,
                0.25 * self.clearcoat * rate_cc,
                rate_s * w_bsdf * (1.0 - f),
                rate_s * (1.0 - w_bsdf * (1.0 - f)),
            ]
        } else {
            [0.0, 0.0, 1.0 - f, f]
        };
        let total: f32 = p.iter().sum();
        if total > 0.0 { p.map(|x| x / total) } else { [0.0; 4] }
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi) = self.sided(wo, wi);
        let Some(pair) = Pair::new(wo, wi, self.eta) else {
            return 0.0;
        };
        let (_, w_bsdf) = self.weights();
        if !pair.front && w_bsdf <= 0.0 {
            return 0.0;
        }
        let h = pair.h;
        let [p_diffuse, p_clearcoat, p_transmit, p_reflect] =
            self.lobe_probabilities(pair.front, fresnel_signed(wo.dot(h), self.eta));
        let wi_h = wi.dot(h);
        let dh_dwi = if pair.reflect {
            1.0 / (4.0 * wi_h).abs()
        } else {
            let denom = wo.dot(h) + pair.eta_path * wi_h;
            (pair.eta_path * pair.eta_path * wi_h / (denom * denom)).abs()
        };
        let wo_up = wo * wo.z.signum();
        let mut pdf = 0.0;
        if pair.reflect {
            if pair.compatible(true) {
                pdf += p_reflect * self.distribution().pdf(wo_up, h) * dh_dwi;
                pdf += p_clearcoat * self.clearcoat_distribution().pdf(h) * dh_dwi;
            }
            pdf += p_diffuse * wi.z.max(0.0) * FRAC_1_PI;
        } else if pair.compatible(false) {
            pdf += p_transmit * self.distribution().pdf(wo_up, h) * dh_dwi;
        }
        if pdf.is_finite() { pdf } else { 0.0 }
    }

    pub fn sample(&self, wo: Vec3, u: Vec2, u_lobe: f32, mode: TransportMode) -> Option<BsdfSample> {
        let flip = self.two_sided && wo.z < 0.0;
        let wo = if flip { wo.with_z(-wo.z) } else { wo };
        let sample = self.sample_one_sided(wo, u, u_lobe, mode)?;
        Some(if flip {
            BsdfSample {
                wi: sample.wi.with_z(-sample.wi.z),
                ..sample
            }
        } else {
            sample
        })
    }

    fn sample_one_sided(&self, wo: Vec3, u: Vec2, u_lobe: f32, mode: TransportMode) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let front = wo.z > 0.0;
        let (_, w_bsdf) = self.weights();
        if !front && w_bsdf <= 0.0 {
            return None;
        }
        // The diffuse and clearcoat shares do not depend on F on the front side (the main
        // lobe's two parts sum to rate_s), so the main lobe's normal is drawn only when needed.
        let [p_diffuse, p_clearcoat, ..] = self.lobe_probabilities(front, 0.0);
        let wi = if u_lobe < p_diffuse {
            sample_cosine_hemisphere(u)
        } else if u_lobe < p_diffuse + p_clearcoat {
            let m = self.clearcoat_distribution().sample(u);
            let wi = reflect(wo, m);
            (wo.dot(m) > 0.0 && wi.dot(m) > 0.0 && wi.z > 0.0).then_some(wi)?
        } else {
            let wo_up = wo * wo.z.signum();
            let (m, _) = self.distribution().sample(wo_up, u)?;
            let [.., p_transmit, _] = self.lobe_probabilities(front, fresnel_signed(wo.dot(m), self.eta));
            let m_side = m * wo.z.signum();
            if u_lobe < p_diffuse + p_clearcoat + p_transmit {
                let wi = refract_through(wo, m, self.eta)?.normalize_or_zero();
                (wo.dot(m_side) > 0.0 && wi.dot(m_side) < 0.0 && wo.z * wi.z < 0.0).then_some(wi)?
            } else {
                let wi = reflect(wo, m);
                (wo.dot(m_side) > 0.0 && wi.dot(m_side) > 0.0 && wo.z * wi.z > 0.0).then_some(wi)?
            }
        };
        let pdf_w = self.pdf(wo, wi);
        (pdf_w > 0.0).then(|| BsdfSample {
            wi,
            f: self.eval(wo, wi, mode),
            pdf_w,
            delta: false,
        })
    }

    /// Whether some lobe is diffuse (the diffuse part or the sheen riding on it).
    pub fn has_diffuse(&self) -> bool {
        let (w_brdf, _) = self.weights();
        w_brdf > 0.0 && self.shared.base_color.max_element() > 0.0
    }

    /// A per-channel bound on ∫ f |cos θi| dωi over every `wo` (Disney's model is not energy
    /// conserving: retro-reflection, sheen and tinted Schlick terms can exceed 1): the diffuse
    /// and sheen bound ([`DisneyParams::diffuse_and_sheen_bound`]); main lobe ≤ max F_p (its
    /// D G/(4 cos θo) integrates to at most 1); transmission ≤ √base w_bsdf (importance);
    /// clearcoat ≤ clearcoat ∫ D_cc dω.
    pub fn albedo(&self) -> Vec3 {
        let (w_brdf, w_bsdf) = self.weights();
        let diffuse_and_sheen = self.shared.diffuse_and_sheen_bound((w_brdf, 1.0 - self.metallic));
        let f0_tint = tint(self.shared.base_color) * schlick_r0(self.eta);
        let main = Vec3::splat((1.0 - self.metallic) * (1.0 - self.shared.spec_tint) + self.metallic)
            + f0_tint.max(Vec3::ONE) * ((1.0 - self.metallic) * self.shared.spec_tint);
        let transmission = self.shared.base_color.map(f32::sqrt) * w_bsdf;
        let clearcoat = self.clearcoat * self.clearcoat_distribution().integral();
        diffuse_and_sheen + main + transmission + Vec3::splat(clearcoat)
    }
}

/// A pair of directions as the principled model classes it.
struct Pair {
    wo: Vec3,
    wi: Vec3,
    /// `wo` on the front side (cos θo > 0).
    front: bool,
    reflect: bool,
    /// η along the path: η for `wo` outside, 1/η inside.
    eta_path: f32,
    /// The (generalised) half vector, turned to +z.
    h: Vec3,
}

impl Pair {
    #[inline]
    fn new(wo: Vec3, wi: Vec3, eta: f32) -> Option<Self> {
        if wo.z == 0.0 || wi.z == 0.0 {
            return None;
        }
        let front = wo.z > 0.0;
        let reflect = wo.z * wi.z > 0.0;
        let eta_path = if front { eta } else { 1.0 / eta };
        let h = (wo + wi * if reflect { 1.0 } else { eta_path }).normalize_or_zero();
        let h = if h.z < 0.0 { -h } else { h };
        (h != Vec3::ZERO).then_some(Self {
            wo,
            wi,
            front,
            reflect,
            eta_path,
            h,
        })
    }

    /// Mitsuba's `mac_mic_compatibility`: both directions see the microfacet's front from the
    /// side the macro-surface puts them on (reflection) or `wi` its back (transmission).
    #[inline]
    fn compatible(&self, reflection: bool) -> bool {
        let m = self.h * self.wo.z.signum();
        let wi_side = if reflection { self.wi.dot(m) } else { -self.wi.dot(m) };
        self.wo.dot(m) > 0.0 && wi_side > 0.0
    }
}

/// GTR1 ("generalised Trowbridge–Reitz", γ = 1), the clearcoat's normal distribution
/// [Burley 2012, eq. 4 of addenda B], sampled over all normals (Mitsuba's `GTR1Isotropic`).
#[derive(Clone, Copy, Debug)]
struct Gtr1 {
    alpha: f32,
}

impl Gtr1 {
    #[inline]
    fn d(self, m: Vec3) -> f32 {
        let a2 = self.alpha * self.alpha;
        let d = (a2 - 1.0) / (PI * a2.ln() * (1.0 + (a2 - 1.0) * m.z * m.z));
        if d * m.z > 1e-20 { d } else { 0.0 }
    }

    /// Density of [`Gtr1::sample`] over normals: D(m) cos θm.
    #[inline]
    fn pdf(self, m: Vec3) -> f32 {
        if m.z < 0.0 { 0.0 } else { m.z * self.d(m) }
    }

    #[inline]
    fn sample(self, u: Vec2) -> Vec3 {
        let a2 = self.alpha * self.alpha;
        let cos2 = (1.0 - a2.powf(1.0 - u.y)) / (1.0 - a2);
        let (sin_t, cos_t) = ((1.0 - cos2).max(0.0).sqrt(), cos2.max(0.0).sqrt());
        let phi = 2.0 * PI * u.x;
        Vec3::new(phi.cos() * sin_t, phi.sin() * sin_t, cos_t)
    }

    /// ∫ D(m) dω over the hemisphere: 2 (α² − 1)/ln α² · artanh(b)/b, b = √(1 − α²).
    fn integral(self) -> f32 {
        let a2 = self.alpha * self.alpha;
        let b = (1.0 - a2).sqrt();
        2.0 * (a2 - 1.0) / a2.ln() * b.atanh() / b
    }
}

/// The main lobe's GGX distribution (visible normals sampled): α = max(0.001, roughness²) scaled
/// by the aspect √(1 − 0.9 anisotropic) [Burley 2012, addenda B.2; Mitsuba's
/// `calc_dist_params`].
#[inline]
pub(super) fn specular_distribution(roughness: f32, anisotropic: f32) -> Microfacet {
    let r2 = roughness * roughness;
    let aspect = (1.0 - 0.9 * anisotropic).sqrt();
    Microfacet::new(
        MicrofacetType::Ggx,
        (r2 / aspect).max(0.001),
        (r2 * aspect).max(0.001),
        true,
    )
}

/// Schlick's weight (1 − cos)⁵, cos clamped to [0, 1].
#[inline]
pub(super) fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Schlick's Fresnel of reflectance `r0` at normal incidence for a cosine `cos` signed by side;
/// leaving the denser medium it uses the refracted cosine (1 under total internal reflection),
/// as Mitsuba's `calc_schlick`.
#[inline]
pub(super) fn schlick(r0: Vec3, cos: f32, eta: f32) -> Vec3 {
    let outside = cos >= 0.0;
    let (eta_it, eta_ti) = if outside { (eta, 1.0 / eta) } else { (1.0 / eta, eta) };
    let w = if eta_it > 1.0 {
        schlick_weight(cos.abs())
    } else {
        let cos_t2 = 1.0 - (1.0 - cos * cos) * eta_ti * eta_ti;
        schlick_weight(cos_t2.max(0.0).sqrt())
    };
    r0 + (Vec3::ONE - r0) * w
}

/// Schlick's R₀ = ((η − 1)/(η + 1))².
#[inline]
pub(super) fn schlick_r0(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// The base colour's hue, c / lum(c) (white for black), which `spec_tint` and `sheen_tint`
/// blend towards.
#[inline]
pub(super) fn tint(c: Vec3) -> Vec3 {
    let lum = luminance(c);
    if lum > 0.0 { c / lum } else { Vec3::ONE }
}

/// The separable GGX masking of the clearcoat (Mitsuba's `smith_ggx1`): G1 of isotropic α,
/// zero where `v` sees the back of the microfacet `h`.
#[inline]
fn smith_ggx1(v: Vec3, h: Vec3, alpha: f32) -> f32 {
    if v.dot(h) * v.z <= 0.0 {
        return 0.0;
    }
    let cos2 = v.z * v.z;
    if cos2 >= 1.0 {
        return 1.0;
    }
    let tan2 = (1.0 - cos2) / cos2;
    2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt())
}

/// A parameter of the principled models that a texture can drive
/// ([`super::ColorParam::Principled`]); all but the base colour are numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PrincipledParam {
    BaseColor,
    Roughness,
    Anisotropic,
    Metallic,
    SpecTrans,
    SpecTint,
    Sheen,
    SheenTint,
    Flatness,
    Clearcoat,
    ClearcoatGloss,
    /// `principledthin`'s diffuse transmission, in [0, 2].
    DiffTrans,
}

/// Sampling rates: finite, non-negative, some positive.
pub(super) fn sampling_rates(rates: &[f32]) -> Result<()> {
    if rates.iter().all(|r| r.is_finite() && *r >= 0.0) && rates.iter().any(|r| *r > 0.0) {
        Ok(())
    } else {
        Err(Error::new(format!(
            "sampling rates must be finite and ≥ 0, some positive, got {rates:?}"
        )))
    }
}
