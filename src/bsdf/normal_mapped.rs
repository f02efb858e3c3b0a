//! A normal map around any model, as Mitsuba 3.9's `normalmap` evaluates it.
//!
//! The map gives a normal m = normalise(2c − 1) in the hit's shading frame, whose +x axis is
//! ∂p/∂u (the texture's tangent space). The nested model is evaluated in a frame around m, with
//! three rules measured on Mitsuba 3.9.1 (`scalar_rgb`, its `BSDF.eval` against closed forms;
//! docs/user-guide.md, "Normal maps"):
//!
//! - **The normal the eye sees.** When m faces away from the eye while the eye is on the
//!   surface's side (eye · m and eye_z of opposite signs), the model is evaluated around m with
//!   its tangential part reversed, (−m_x, −m_y, m_z): grazing views of steep maps are never
//!   black where the map faces away.
//! - **Shadowing of the light direction** [Chiang, Li & Burley 2019, "Taming the Shadow
//!   Terminator"]: the value is multiplied by Smith's GGX masking G₁ of the light direction about
//!   the unmapped normal, with α² = min(1, tan²θ_m / 8) (θ_m: the angle between m and the
//!   unmapped normal), and is zero unless the light direction is on the same side of both
//!   normals.
//! - **Cosines.** The nested model's cosine is the one about m; our callers multiply by the
//!   cosine about the unmapped normal, so the value carries |cos θ_m| / |cos θ| of the light
//!   direction.
//!
//! The eye and the light are `wo` and `wi` in radiance transport, `wi` and `wo` in importance
//! transport: `eval(wo, wi, Importance)` is `eval(wi, wo, Radiance)`, so that paths traced from
//! the lights converge to the same image as paths traced from the eye (Mitsuba's own particle
//! tracer swaps the roles instead; its path tracer is what the corpus compares with).
//!
//! **Sampling.** Which normal the model is evaluated around depends on the eye, which importance
//! transport samples rather than knows; and `pdf` has no transport mode. So sampling is a
//! mixture, the same in both modes: the frame `wo` would see as the eye with probability
//! [`OWN_FRAME_SHARE`], the other with the rest, the nested model sampled in the frame chosen;
//! `pdf` is the mixture's density. A delta lobe sampled in the frame the eye does not see
//! carries nothing. For a map without tangential part both frames are one, sampled alone.
//!
//! Back sides: a two-sided reflecting model (our default) sees the map mirrored below the
//! surface, as Mitsuba's `twosided(normalmap(…))` does by flipping both directions; a one-sided
//! one ([`Bsdf::OneSided`] inside) is black there, as Mitsuba's bare `normalmap` is; a
//! transmitting model has one map and two media, as Mitsuba's.
//!
//! Decision (docs/design.md): Mitsuba 3.9.1 orients the new frame's tangent with ∂p/∂u taken in
//! world coordinates against m in local ones (mixed spaces); ours projects the local ∂p/∂u
//! (+x). Only anisotropic nested models can tell.

use super::{Bsdf, BsdfSample, TransportMode, reflect_z};
use crate::geometry::Frame;
use glam::{Vec2, Vec3};

/// Probability of sampling in the frame `wo` sees as the eye (the one radiance transport
/// evaluates in); the other frame gets the rest, which importance transport needs wherever the
/// eye it samples sees the other normal.
pub const OWN_FRAME_SHARE: f32 = 0.75;

/// A model under a normal map ([`Bsdf::NormalMapped`]).
#[derive(Clone, Debug, PartialEq)]
pub struct NormalMapped {
    pub nested: Bsdf,
    /// The mapped normal m in the hit's shading frame (+x along ∂p/∂u), unit length.
    pub normal: Vec3,
}

/// How the map sees a pair of directions: mirrored above the surface (both z negated) when the
/// nested model is two-sided and the pair is below ([`NormalMapped::above`]).
#[derive(Clone, Copy)]
struct Side {
    mirrored: bool,
}

impl Side {
    #[inline]
    fn up(self, w: Vec3) -> Vec3 {
        if self.mirrored { w.with_z(-w.z) } else { w }
    }
}

impl NormalMapped {
    /// The model `nested` under the map colour `c` (the normal 2c − 1, normalised).
    pub fn new(nested: Bsdf, c: Vec3) -> Self {
        let mut b = Self {
            nested,
            normal: Vec3::Z,
        };
        b.set_colour(c);
        b
    }

    /// The model `nested` with the unmapped normal (a bump map's before its normal is set at a
    /// hit).
    pub fn flat(nested: Bsdf) -> Self {
        Self {
            nested,
            normal: Vec3::Z,
        }
    }

    /// Sets the map colour read at a hit; one that gives no direction (2c − 1 = 0) leaves the
    /// unmapped normal.
    pub fn set_colour(&mut self, c: Vec3) {
        self.normal = (2.0 * c - Vec3::ONE).try_normalize().unwrap_or(Vec3::Z);
    }

    /// True when both directions of a pair below the surface see the map mirrored (a two-sided
    /// reflecting nested model).
    fn mirrors_back(&self) -> bool {
        match &self.nested {
            Bsdf::OneSided(_) | Bsdf::PrincipledThin(_) => false,
            // The principled model has its own back side unless two-sided.
            Bsdf::Principled(p) => p.two_sided,
            b => !b.is_transmissive(),
        }
    }

    /// Whether the map tilts the normal at all sideways (otherwise both frames are one).
    fn has_two_frames(&self) -> bool {
        self.normal.x != 0.0 || self.normal.y != 0.0
    }

    /// The normal seen from `eye` (above the surface after mirroring): m, or m with its
    /// tangential part reversed when m faces away from the eye on the eye's side.
    #[inline]
    fn normal_seen_from(&self, eye: Vec3) -> Vec3 {
        let m = self.normal;
        if eye.dot(m) * eye.z < 0.0 { reflect_z(m) } else { m }
    }

    #[inline]
    fn frame(n: Vec3) -> Frame {
        Frame::from_normal_tangent(n, Vec3::X)
    }

    /// The side a pair whose side is decided by `key` (the eye when evaluating, `wo` when
    /// sampling) is seen from.
    #[inline]
    fn above(&self, key: Vec3) -> Side {
        Side {
            mirrored: key.z < 0.0 && self.mirrors_back(),
        }
    }

    /// Smith's GGX masking G₁ of a direction with cosine `cos_theta` about the unmapped normal,
    /// with α² = min(1, tan²θ_m / 8) [Chiang et al. 2019].
    pub fn shadowing(&self, cos_theta: f32) -> f32 {
        let c2 = cos_theta * cos_theta;
        if c2 == 0.0 {
            return 0.0;
        }
        let m_z2 = self.normal.z * self.normal.z;
        let alpha2 = ((1.0 - m_z2) / (8.0 * m_z2)).min(1.0);
        let tan2 = (1.0 - c2).max(0.0) / c2;
        2.0 / (1.0 + (1.0 + alpha2 * tan2).sqrt())
    }

    /// The factor the nested model's value carries for light direction `light` (unmapped, seen
    /// from above when mirrored) and `light_m` (the same about the nested model's normal): G₁
    /// times |cos θ_m| / |cos θ|, zero unless both cosines have one sign.
    #[inline]
    fn light_factor(&self, light: Vec3, light_m: Vec3) -> f32 {
        if light.z * light_m.z <= 0.0 {
            return 0.0;
        }
        self.shadowing(light.z) * (light_m.z / light.z)
    }

    /// The eye and the light among (`wo`, `wi`) in `mode`.
    #[inline]
    fn eye_light(wo: Vec3, wi: Vec3, mode: TransportMode) -> (Vec3, Vec3) {
        match mode {
            TransportMode::Radiance => (wo, wi),
            TransportMode::Importance => (wi, wo),
        }
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        let (eye, _) = Self::eye_light(wo, wi, mode);
        let side = self.above(eye);
        let frame = Self::frame(self.normal_seen_from(side.up(eye)));
        let (wo, wi) = (side.up(wo), side.up(wi));
        let (wo_m, wi_m) = (frame.to_local(wo), frame.to_local(wi));
        let (_, light) = Self::eye_light(wo, wi, mode);
        let (_, light_m) = Self::eye_light(wo_m, wi_m, mode);
        let factor = self.light_factor(light, light_m);
        if factor == 0.0 {
            return Vec3::ZERO;
        }
        self.nested.eval(wo_m, wi_m, mode) * factor
    }

    /// The frames sampling chooses from `wo` and their probabilities.
    #[inline]
    fn sampling_frames(&self, wo_up: Vec3) -> [(Vec3, f32); 2] {
        let own = self.normal_seen_from(wo_up);
        if self.has_two_frames() {
            [(own, OWN_FRAME_SHARE), (reflect_z(own), 1.0 - OWN_FRAME_SHARE)]
        } else {
            [(own, 1.0), (own, 0.0)]
        }
    }

    /// Density of [`NormalMapped::sample`]: the mixture over both frames of the nested model's
    /// density, each where both directions keep their side in that frame.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let side = self.above(wo);
        let (wo, wi) = (side.up(wo), side.up(wi));
        let mut pdf = 0.0;
        for (n, share) in self.sampling_frames(wo) {
            if share == 0.0 {
                continue;
            }
            let frame = Self::frame(n);
            let (wo_m, wi_m) = (frame.to_local(wo), frame.to_local(wi));
            if wo.z * wo_m.z > 0.0 && wi.z * wi_m.z > 0.0 {
                pdf += share * self.nested.pdf(wo_m, wi_m);
            }
        }
        pdf
    }

    pub fn sample(&self, wo: Vec3, u: Vec2, u_lobe: f32, mode: TransportMode) -> Option<BsdfSample> {
        let side = self.above(wo);
        let wo_up = side.up(wo);
        let [(own, share), (other, rest)] = self.sampling_frames(wo_up);
        let (n, share, u_lobe) = if u_lobe < share {
            (own, share, u_lobe / share)
        } else {
            (other, rest, (u_lobe - share) / rest)
        };
        let frame = Self::frame(n);
        let wo_m = frame.to_local(wo_up);
        if wo_up.z * wo_m.z <= 0.0 {
            return None;
        }
        let s = self.nested.sample(wo_m, u, u_lobe.min(1.0 - f32::EPSILON), mode)?;
        let wi_up = frame.to_world(s.wi);
        if wi_up.z * s.wi.z <= 0.0 {
            return None;
        }
        let wi = side.up(wi_up);
        if !s.delta {
            let pdf_w = self.pdf(wo, wi);
            return (pdf_w > 0.0).then(|| BsdfSample {
                wi,
                f: self.eval(wo, wi, mode),
                pdf_w,
                delta: false,
            });
        }
        self.delta_through(n, wo_up, wi_up, (s.f, s.pdf_w * share), mode)
            .map(|(f, pdf_w)| BsdfSample {
                wi,
                f,
                pdf_w,
                delta: true,
            })
    }

    /// A delta lobe of the nested model around normal `n` from `wo` to `wi` (both above after
    /// mirroring), coefficient `f` and probability `p`: its value and probability here, if the
    /// eye sees `n`.
    fn delta_through(
        &self,
        n: Vec3,
        wo: Vec3,
        wi: Vec3,
        (f, p): (Vec3, f32),
        mode: TransportMode,
    ) -> Option<(Vec3, f32)> {
        let (eye, light) = Self::eye_light(wo, wi, mode);
        if self.normal_seen_from(eye) != n {
            return None;
        }
        let factor = self.light_factor(light, Self::frame(n).to_local(light));
        (factor > 0.0).then_some((f * factor, p))
    }

    /// [`Bsdf::delta_lobe`]: the nested model's delta lobes in either frame, where the eye sees
    /// that frame's normal.
    pub fn delta_lobe(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Option<(Vec3, f32)> {
        let side = self.above(wo);
        let (wo, wi) = (side.up(wo), side.up(wi));
        self.sampling_frames(wo)
            .into_iter()
            .filter(|&(_, share)| share > 0.0)
            .find_map(|(n, share)| {
                let frame = Self::frame(n);
                let (wo_m, wi_m) = (frame.to_local(wo), frame.to_local(wi));
                if wo.z * wo_m.z <= 0.0 || wi.z * wi_m.z <= 0.0 {
                    return None;
                }
                let (f, p) = self.nested.delta_lobe(wo_m, wi_m, mode)?;
                self.delta_through(n, wo, wi, (f, p * share), mode)
            })
    }

    /// Probability that sampling from `wo` draws a delta lobe of the nested model.
    pub fn delta_probability(&self, wo: Vec3) -> f32 {
        let side = self.above(wo);
        let wo = side.up(wo);
        self.sampling_frames(wo)
            .into_iter()
            .map(|(n, share)| {
                let wo_m = Self::frame(n).to_local(wo);
                if share == 0.0 || wo.z * wo_m.z <= 0.0 {
                    0.0
                } else {
                    share * self.nested.delta_probability(wo_m)
                }
            })
            .sum()
    }
}
