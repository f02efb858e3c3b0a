//! Conductors (metals) with a complex index of refraction η + ik, as Mitsuba 3's `conductor`
//! (smooth, a delta lobe) and `roughconductor` (a microfacet lobe).
//!
//! The Fresnel reflectance of a conductor is [`fresnel_conductor`]; η = 0, k = 1 gives F = 1, a
//! perfect mirror, which is Mitsuba's default (`material = "none"`). Measured metals come from
//! [`super::named_conductors::NAMED_CONDUCTORS`]. `specular_reflectance` multiplies F (a
//! non-physical tint Mitsuba offers, default 1).
//!
//! The rough lobe is the Cook–Torrance microfacet BRDF [Walter et al. 2007, eq. 20]
//!
//! f_s(wo, wi) = F(wo·h) D(h) G(wo, wi, h) / (4 |cos θo| |cos θi|),  h = (wo + wi)/|wo + wi|,
//!
//! sampled by drawing a microfacet normal m ([`Microfacet::sample`]) and reflecting wo about it:
//! p(wi) = p(m) / (4 |wi·m|) [Walter et al. 2007, eq. 14].
//!
//! **Sidedness**: Mitsuba's conductors are one-sided (black from behind); ours reflect on the
//! side of `wo`, like every reflection model here (Mitsuba's `twosided` wrapper is the exact
//! equivalent; the importer warns about one-sided materials).

use super::microfacet::Microfacet;
use super::named_conductors::NAMED_CONDUCTORS;
use super::{BsdfSample, to_upper};
use glam::{Vec2, Vec3};

/// Unpolarised Fresnel reflectance of a conductor with relative complex index η + ik for
/// cos θi ∈ [0, 1] (Moeller, "Optics", 1988; the same expression as Mitsuba's
/// `fresnel_conductor`): with a² + b² = √((η² − k² − sin²θ)² + 4η²k²) and
/// a = √((a² + b² + η² − k² − sin²θ)/2),
/// R_s = (a² + b² + cos²θ − 2a cos θ)/(a² + b² + cos²θ + 2a cos θ),
/// R_p = R_s (( a² + b²) cos²θ + sin⁴θ − 2a cos θ sin²θ)/((a² + b²) cos²θ + sin⁴θ + 2a cos θ sin²θ),
/// F = (R_s + R_p)/2. Evaluated per RGB channel.
pub fn fresnel_conductor(cos_theta_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    let c = cos_theta_i.clamp(0.0, 1.0);
    let (c2, s2) = (c * c, 1.0 - c * c);
    let s4 = s2 * s2;
    let channel = |eta: f32, k: f32| {
        let t1 = eta * eta - k * k - s2;
        let a2pb2 = (t1 * t1 + 4.0 * k * k * eta * eta).max(0.0).sqrt();
        let a = (0.5 * (a2pb2 + t1)).max(0.0).sqrt();
        let (term1, term2) = (a2pb2 + c2, 2.0 * c * a);
        let r_s = (term1 - term2) / (term1 + term2);
        let (term3, term4) = (a2pb2 * c2 + s4, term2 * s2);
        let r_p = r_s * (term3 - term4) / (term3 + term4);
        let f = 0.5 * (r_s + r_p);
        if f.is_finite() { f.clamp(0.0, 1.0) } else { 1.0 }
    };
    Vec3::new(channel(eta.x, k.x), channel(eta.y, k.y), channel(eta.z, k.z))
}

/// The complex index of refraction of a conductor and Mitsuba's reflectance tint.
#[derive(Clone, Debug, PartialEq)]
pub struct ConductorIor {
    /// Real part η per channel, ≥ 0.
    pub eta: Vec3,
    /// Imaginary part (extinction) k per channel, ≥ 0.
    pub k: Vec3,
    /// Multiplies the Fresnel term, in [0, 1] per channel.
    pub specular_reflectance: Vec3,
}

impl ConductorIor {
    /// The perfect mirror: η = 0, k = 1 (F = 1), Mitsuba's `material = "none"`.
    pub fn mirror() -> Self {
        Self {
            eta: Vec3::ZERO,
            k: Vec3::ONE,
            specular_reflectance: Vec3::ONE,
        }
    }

    /// One of Mitsuba's measured conductors ("Au", "Cu", …) with no tint; `None` for an unknown
    /// name ([`named_conductor_list`] lists them).
    pub fn named(name: &str) -> Option<Self> {
        NAMED_CONDUCTORS
            .iter()
            .find(|(n, _, _)| *n == name)
            .map(|&(_, eta, k)| Self {
                eta: Vec3::from(eta),
                k: Vec3::from(k),
                specular_reflectance: Vec3::ONE,
            })
    }

    /// specular_reflectance · F(cos θ).
    #[inline]
    pub fn reflectance(&self, cos_theta: f32) -> Vec3 {
        self.specular_reflectance * fresnel_conductor(cos_theta, self.eta, self.k)
    }
}

/// The names of Mitsuba's measured conductors, comma-separated, for error messages.
pub fn named_conductor_list() -> String {
    NAMED_CONDUCTORS
        .iter()
        .map(|(n, _, _)| *n)
        .collect::<Vec<_>>()
        .join(", ")
}

/// A smooth conductor: a delta reflection lobe weighted by the conductor's Fresnel term.
#[derive(Clone, Debug, PartialEq)]
pub struct Conductor {
    pub ior: ConductorIor,
}

impl Conductor {
    /// The mirror direction with weight specular_reflectance · F(cos θo).
    pub fn sample(&self, wo: Vec3) -> Option<BsdfSample> {
        BsdfSample::mirrored(wo, self.ior.reflectance(wo.z.abs()))
    }
}

/// A rough conductor: the microfacet lobe above with a conductor's Fresnel term.
#[derive(Clone, Debug, PartialEq)]
pub struct RoughConductor {
    pub ior: ConductorIor,
    pub distribution: Microfacet,
}

impl RoughConductor {
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z * wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let (wo, wi) = to_upper(wo, wi);
        self.distribution
            .reflection(wo, wi)
            .map_or(Vec3::ZERO, |(h, dg)| self.ior.reflectance(wo.dot(h)) * dg)
    }

    /// p(m)/(4 |wi·m|) with m = h.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z * wi.z <= 0.0 {
            return 0.0;
        }
        let (wo, wi) = to_upper(wo, wi);
        self.distribution.reflection_pdf(wo, wi)
    }

    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let wo_up = wo.with_z(wo.z.abs());
        let wi_up = self.distribution.sample_reflection(wo_up, u)?;
        BsdfSample::on_side_of(wo, wi_up, |wi| self.pdf(wo, wi), |wi| self.eval(wo, wi))
    }
}
