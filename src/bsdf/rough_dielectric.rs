//! A rough dielectric interface (frosted glass), as Mitsuba 3's `roughdielectric`: microfacet
//! reflection and refraction of Walter et al. 2007 ("Microfacet Models for Refraction through
//! Rough Surfaces").
//!
//! Sides as in [`super::Dielectric`]: +z is the outside and `ior` = η_interior / η_exterior; for
//! `wo` on the side with index η_o, η = η_t/η_o is `ior` when `wo` is outside and 1/`ior`
//! inside. With the microfacet normal m oriented to +z,
//!
//! - reflection (wo, wi on one side): m = h_r ∝ wo + wi and
//!   f_r = F(wo·m) D(m) G(wo, wi, m) / (4 |cos θo| |cos θi|)            [Walter 2007, eq. 20];
//! - transmission: m = h_t ∝ −(wo + η wi) and
//!   f_t = s (1 − F) D G η² |wo·m| |wi·m| / (|cos θo| |cos θi| (wo·m + η wi·m)²)   [eq. 21],
//!
//! where s = 1/η² when the path carries radiance and 1 when it carries importance: radiance is
//! compressed into the denser medium [Veach 1997, §5.2], the factor eq. 21 leaves out and
//! Mitsuba adds. With it, f_t of importance at (wo, wi) equals f_t of radiance at (wi, wo),
//! the adjoint relation bidirectional methods rely on.
//!
//! Sampling as Mitsuba: m from the distribution for `wo` (mirrored to the upper side, visible
//! normals unless `sample_visible = false`, in which case the roughness is widened by
//! 1.2 − 0.2 √|cos θo| [Walter 2007, §5.3]), reflection with probability F(wo·m) and
//! refraction otherwise, p(wi) = p(m) · (F or 1 − F) · |∂ωm/∂ωi| with the Jacobians
//! 1/(4 |wi·m|) and η² |wi·m| / (wo·m + η wi·m)² [eqs. 14, 17].
//!
//! Parameters: `ior` > 0 and ≠ 1; `specular_reflectance` and `specular_transmittance`, filters
//! in [0, 1] on the two lobes (Mitsuba's names; default 1).

use super::microfacet::Microfacet;
use super::{BsdfSample, TransportMode, fresnel_signed};
use glam::{Vec2, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct RoughDielectric {
    /// Relative index of refraction η_interior / η_exterior.
    pub ior: f32,
    pub distribution: Microfacet,
    pub specular_reflectance: Vec3,
    pub specular_transmittance: Vec3,
}

/// The half vector of a pair and whether it is a reflection, or `None` for a degenerate pair.
struct HalfVector {
    m: Vec3,
    reflect: bool,
    /// η = η_t / η_o for `wo`'s side.
    eta: f32,
}

impl RoughDielectric {
    /// η_t / η_o for a path leaving along `wo`.
    #[inline]
    fn eta_toward(&self, wo: Vec3) -> f32 {
        if wo.z > 0.0 { self.ior } else { 1.0 / self.ior }
    }

    /// The microfacet normal that maps `wo` to `wi` (oriented to +z), where both directions see
    /// its front from their own side (the χ⁺ of G1, which `eval`, `pdf` and `sample` share).
    #[inline]
    fn half_vector(&self, wo: Vec3, wi: Vec3) -> Option<HalfVector> {
        if wo.z == 0.0 || wi.z == 0.0 {
            return None;
        }
        let reflect = wo.z * wi.z > 0.0;
        let eta = self.eta_toward(wo);
        let m = (wo + wi * if reflect { 1.0 } else { eta }).normalize_or_zero();
        let m = if m.z < 0.0 { -m } else { m };
        let ok = m.z > 0.0 && wo.dot(m) * wo.z > 0.0 && wi.dot(m) * wi.z > 0.0;
        ok.then_some(HalfVector { m, reflect, eta })
    }

    /// Fresnel reflectance of the microfacet m for `wo`.
    #[inline]
    fn fresnel(&self, wo: Vec3, m: Vec3) -> f32 {
        fresnel_signed(wo.dot(m), self.ior)
    }

    /// The distribution `sample` draws m from (widened for all-normal sampling).
    #[inline]
    fn sampling_distribution(&self, wo: Vec3) -> Microfacet {
        if self.distribution.sample_visible {
            self.distribution
        } else {
            self.distribution.scaled(1.2 - 0.2 * wo.z.abs().sqrt())
        }
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        let Some(HalfVector { m, reflect, eta }) = self.half_vector(wo, wi) else {
            return Vec3::ZERO;
        };
        let d = self.distribution.d(m);
        if d == 0.0 {
            return Vec3::ZERO;
        }
        let g = self.distribution.g(wo, wi, m);
        let f = self.fresnel(wo, m);
        let cos = (wo.z * wi.z).abs();
        if reflect {
            return self.specular_reflectance * (f * d * g / (4.0 * cos));
        }
        let (wo_m, wi_m) = (wo.dot(m), wi.dot(m));
        let denom = wo_m + eta * wi_m;
        if denom == 0.0 {
            return Vec3::ZERO;
        }
        let scale = match mode {
            TransportMode::Radiance => 1.0 / (eta * eta),
            TransportMode::Importance => 1.0,
        };
        let value = scale * (1.0 - f) * d * g * eta * eta * (wo_m * wi_m).abs() / (cos * denom * denom);
        self.specular_transmittance * value
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.pdf_lobes(wo, wi, Lobes::All)
    }

    /// The density of [`RoughDielectric::sample_lobes`] restricted to `lobes`: the chosen
    /// lobe's share is F or 1 − F among both lobes and 1 when only one may be drawn (pbrt-v4's
    /// `BxDFReflTransFlags`, which its layered models use).
    pub fn pdf_lobes(&self, wo: Vec3, wi: Vec3, lobes: Lobes) -> f32 {
        let Some(HalfVector { m, reflect, eta }) = self.half_vector(wo, wi) else {
            return 0.0;
        };
        let wo_up = if wo.z < 0.0 { -wo } else { wo };
        let p_m = self.sampling_distribution(wo).pdf(wo_up, m);
        let Some(share) = lobes.share(self.fresnel(wo, m), reflect) else {
            return 0.0;
        };
        let wi_m = wi.dot(m);
        let jacobian = if reflect {
            1.0 / (4.0 * wi_m.abs())
        } else {
            let denom = wo.dot(m) + eta * wi_m;
            eta * eta * wi_m.abs() / (denom * denom)
        };
        let p = p_m * share * jacobian;
        if p.is_finite() { p } else { 0.0 }
    }

    /// Draws m, then reflects (`u_lobe` < F) or refracts through it.
    pub fn sample(&self, wo: Vec3, u: Vec2, u_lobe: f32, mode: TransportMode) -> Option<BsdfSample> {
        self.sample_lobes(wo, u, u_lobe, mode, Lobes::All)
    }

    /// [`RoughDielectric::sample`] drawing only `lobes`: reflection or refraction through the
    /// sampled m when only one is allowed, its density [`RoughDielectric::pdf_lobes`].
    pub fn sample_lobes(
        &self,
        wo: Vec3,
        u: Vec2,
        u_lobe: f32,
        mode: TransportMode,
        lobes: Lobes,
    ) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        // Mitsuba samples with −wo below the surface: D is even in (x, y), so m serves both.
        let wo_up = if wo.z < 0.0 { -wo } else { wo };
        let (m, _) = self.sampling_distribution(wo).sample(wo_up, u)?;
        // All-normal sampling can draw a microfacet that faces away from wo (G1 = 0): no path.
        if wo.dot(m) * wo.z <= 0.0 {
            return None;
        }
        let reflect = lobes.choose_reflection(self.fresnel(wo, m), u_lobe)?;
        let wi = if reflect {
            super::reflect(wo, m)
        } else {
            refract_through(wo, m, self.ior)?
        };
        let wi = wi.normalize_or_zero();
        // A reflection that leaves below the surface (or a refraction that stays above) is
        // shadowed by the microfacets around m: Mitsuba gives it weight zero, we reject it, and
        // `pdf` must not count it under the other lobe.
        if (wo.z * wi.z > 0.0) != reflect {
            return None;
        }
        let pdf_w = self.pdf_lobes(wo, wi, lobes);
        (pdf_w > 0.0).then(|| BsdfSample {
            wi,
            f: self.eval(wo, wi, mode),
            pdf_w,
            delta: false,
        })
    }
}

/// Which lobes of a dielectric interface a sampler may draw (pbrt-v4's `BxDFReflTransFlags`):
/// its layered models walk through a coating by asking for transmission alone or reflection
/// alone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobes {
    All,
    Reflection,
    Transmission,
}

impl Lobes {
    /// The probability of drawing reflection (`reflect`) or refraction given the Fresnel
    /// reflectance `f` of the interface; `None` when the lobe is excluded or has no weight.
    #[inline]
    pub fn share(self, f: f32, reflect: bool) -> Option<f32> {
        let p = match (self, reflect) {
            (Lobes::All, true) => f,
            (Lobes::All, false) => 1.0 - f,
            (Lobes::Reflection, true) => (f > 0.0) as u8 as f32,
            (Lobes::Transmission, false) => (f < 1.0) as u8 as f32,
            _ => 0.0,
        };
        (p > 0.0).then_some(p)
    }

    /// Whether `u` (uniform) draws reflection given Fresnel reflectance `f`; `None` when no
    /// allowed lobe carries light.
    #[inline]
    pub fn choose_reflection(self, f: f32, u: f32) -> Option<bool> {
        match self {
            Lobes::All => Some(u < f),
            Lobes::Reflection => (f > 0.0).then_some(true),
            Lobes::Transmission => (f < 1.0).then_some(false),
        }
    }
}

/// Refracts `w` through a microfacet with normal `m` of an interface with relative index
/// `ior` (inside over outside; `m` and +z point outside): Snell's law about m, `None` under total
/// internal reflection.
#[inline]
pub(super) fn refract_through(w: Vec3, m: Vec3, ior: f32) -> Option<Vec3> {
    let c = w.dot(m);
    let eta = if c > 0.0 { ior } else { 1.0 / ior };
    let sin2_t = (1.0 - c * c).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-w / eta + (c / eta - cos_t.copysign(c)) * m)
}
