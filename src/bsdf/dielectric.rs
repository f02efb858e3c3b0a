//! Smooth dielectric interface (glass, water): specular reflection and refraction weighted by
//! the exact unpolarised Fresnel reflectance, both delta lobes.
//!
//! The outside is the side +z points to; `ior` = η_interior / η_exterior. For a direction `wo`
//! on the side with index η_o, the path continues into index η_t, and η = η_t / η_o (`ior` when
//! `wo` is outside, 1/`ior` inside). `sample` picks reflection with probability F(cos θo, η)
//! and refraction with probability 1 − F, so each sample's weight f_s |cos θi| / pdf is 1 for
//! reflection and `tint` (Importance) or `tint`/η² (Radiance) for refraction: radiance is
//! compressed into the denser medium while importance is not, which makes the adjoint BSDF of
//! refraction differ from the BSDF [Veach 1997, §5.2, eqs. (5.19)–(5.22)]. Total internal
//! reflection (sin θt ≥ 1) gives F = 1.
//!
//! Parameters: `ior` > 0 (1 gives an invisible interface); `tint` in [0, 1] per channel, a
//! colour filter applied to refracted light only (reflection off a dielectric is uncoloured).

use super::{BsdfSample, TransportMode, reflect_z};
use glam::Vec3;

#[derive(Clone, Debug, PartialEq)]
pub struct Dielectric {
    /// Relative index of refraction η_interior / η_exterior, > 0 (e.g. 1.5 for glass in air).
    pub ior: f32,
    /// Filter on refracted light per channel, in [0, 1]; `Vec3::ONE` for clear glass.
    pub tint: Vec3,
}

impl Dielectric {
    /// Clear dielectric (tint 1) with relative index `ior`.
    pub fn clear(ior: f32) -> Self {
        Self { ior, tint: Vec3::ONE }
    }

    /// Relative index η = η_t / η_o across the interface for a path leaving along `wo`.
    #[inline]
    pub fn eta_toward(&self, wo: Vec3) -> f32 {
        if wo.z > 0.0 { self.ior } else { 1.0 / self.ior }
    }

    /// Reflects with probability F, refracts with probability 1 − F (`u_lobe` decides).
    pub fn sample(&self, wo: Vec3, u_lobe: f32, mode: TransportMode) -> Option<BsdfSample> {
        if wo.z == 0.0 || self.ior.is_nan() || self.ior <= 0.0 {
            return None;
        }
        let eta = self.eta_toward(wo);
        let f_r = fresnel_dielectric(wo.z.abs(), eta);
        if u_lobe < f_r {
            // Specular reflection, weight F / F = 1.
            let wi = reflect_z(wo);
            return Some(BsdfSample {
                wi,
                f: Vec3::splat(f_r / wi.z.abs()),
                pdf_w: f_r,
                delta: true,
            });
        }
        // Refraction, weight (1 − F)/(1 − F) · tint, and 1/η² for radiance [Veach 1997, §5.2].
        let wi = refract(wo, eta)?;
        let f_t = 1.0 - f_r;
        let scale = match mode {
            TransportMode::Radiance => 1.0 / (eta * eta),
            TransportMode::Importance => 1.0,
        };
        Some(BsdfSample {
            wi,
            f: self.tint * (f_t * scale / wi.z.abs()),
            pdf_w: f_t,
            delta: true,
        })
    }
}

/// Unpolarised Fresnel reflectance of a smooth dielectric interface,
/// F = (r_s² + r_p²)/2 with r_s = (cos θi − η cos θt)/(cos θi + η cos θt) and
/// r_p = (η cos θi − cos θt)/(η cos θi + cos θt) [Born & Wolf; pbrt-v4, eq. (9.6)].
///
/// `cos_theta_i` ≥ 0 is measured on the incident side and `eta` = η_t / η_i. Returns 1 under
/// total internal reflection. Fresnel reflectance is the same from both sides of a refracted
/// pair: F(cos θi, η) = F(cos θt, 1/η). An index-matched interface (η = 1) reflects nothing,
/// exactly, as Mitsuba's `fresnel` makes it (the formula leaves ~1e-13 near grazing angles).
pub fn fresnel_dielectric(cos_theta_i: f32, eta: f32) -> f32 {
    if eta == 1.0 {
        return 0.0;
    }
    let cos_i = cos_theta_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    (0.5 * (r_s * r_s + r_p * r_p)).min(1.0)
}

/// [`fresnel_dielectric`] for a cosine `c` signed by side: `eta` = η_inside/η_outside seen from
/// outside (c > 0), its inverse from inside (Mitsuba's `fresnel`). At c = 0 both give 1
/// (η ≠ 1) or 0 (η = 1).
#[inline]
pub(crate) fn fresnel_signed(c: f32, eta: f32) -> f32 {
    fresnel_dielectric(c.abs(), if c > 0.0 { eta } else { 1.0 / eta })
}

/// Refracted direction of `w` through the interface z = 0, or `None` under total internal
/// reflection. `w` points away from the surface on the side sign(w.z), the result points away
/// on the other side, and `eta` = η_t / η_i. Snell's law η_i sin θi = η_t sin θt: the tangential
/// part is −w_⊥/η and |cos θt| = √(1 − sin²θi/η²) [pbrt-v4, eq. (9.4)].
pub fn refract(w: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = w.z.abs();
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(Vec3::new(-w.x / eta, -w.y / eta, -cos_t.copysign(w.z)))
}
