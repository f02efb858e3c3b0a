//! Lights described by a Dirac delta: a point (Mitsuba's `point`), a spot (`spot`) and parallel
//! light from one direction (`directional`). No ray can hit them, so they are reached only by
//! next-event estimation and by paths that start on them; a strategy that finds light only by
//! hitting emitters (a BSDF-only path tracer) cannot render them and says so.
//!
//! Quantities as Mitsuba 3.9.1 defines them (`src/emitters/{point,spot,directional}.cpp`):
//! - `point`: radiant intensity I [W/sr], the same in every direction; the irradiance at x is
//!   I cos θ / r² and the emitted power 4π I.
//! - `spot`: I times a falloff (1 inside the beam of half-angle θ_b, a linear ramp in angle
//!   (θ_c − θ)/(θ_c − θ_b) down to 0 at the cutoff θ_c), so the power is
//!   I ∫ falloff dω = 2π I (1 − (sin θ_c − sin θ_b)/(θ_c − θ_b)) (the ramp integrated by parts;
//!   2π I (1 − cos θ_c) when θ_b = θ_c).
//! - pbrt-v4's `spot` (`Spot::smoothstep`): I times smoothstep(cos θ_c, cos θ_b, cos θ), a
//!   cubic ramp in cos θ rather than Mitsuba's linear one in θ, so the power is
//!   2π I ((1 − cos θ_b) + (cos θ_b − cos θ_c)/2) (the smoothstep integrates to ½ over its ramp).
//! - a spot's `texture` ([`SpotTexture`]): the intensity times a picture projected through the
//!   cone, its power integrated numerically.
//! - `projector` ([`Projector`]): a picture of irradiance seen through a pinhole, intensity
//!   π s E(u, v) / cos³ θ inside its rectangle of view.
//! - `directional`: irradiance E [W/m²] on a surface facing the light, arriving along one
//!   direction; the power that reaches a scene of bounding radius R is π R² E.
//!
//! Photons (and light sub-paths) leave a point, a spot or a projector at its position: a point in a
//! uniformly distributed direction, a spot uniformly inside its cutoff cone (Mitsuba's
//! `sample_ray`), each carrying intensity × falloff / density; a projector's where its picture is
//! bright ([`super::picture`]). Directional photons start on a
//! disc of radius R facing the light, one R beyond the scene's centre, as environment photons do.

use super::projector::Projector;
use crate::geometry::Frame;
use crate::sampling::{sample_uniform_cone, sample_uniform_sphere, uniform_sphere_pdf};
use crate::texture::Texture;
use glam::Mat3;
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// A light of zero extent in position or direction.
#[derive(Clone, Debug, PartialEq)]
pub enum DeltaLight {
    /// Radiant `intensity` I [W/sr] from `position` in every direction.
    Point {
        position: Vec3,
        intensity: Vec3,
    },
    Spot(Spot),
    Projector(Projector),
    /// Parallel light travelling along unit `direction` with `irradiance` E [W/m²] on a
    /// surface facing it.
    Directional {
        direction: Vec3,
        irradiance: Vec3,
    },
}

/// A spot light: intensity I along its unit `axis`, falling off between the beam and the cutoff
/// half-angles, linearly in angle (Mitsuba) or by a smoothstep in cos θ (pbrt-v4).
#[derive(Clone, Debug, PartialEq)]
pub struct Spot {
    pub position: Vec3,
    pub axis: Vec3,
    pub intensity: Vec3,
    /// Mitsuba's `texture`: the intensity times a picture projected through the cone.
    pub texture: Option<SpotTexture>,
    /// Half-angle θ_c beyond which the spot is dark, in radians.
    cutoff: f32,
    cos_cutoff: f32,
    /// cos θ_b of the beam's half-angle.
    cos_beam: f32,
    /// 1 / (θ_c − θ_b), infinite when the beam fills the cone (the ramp is then empty).
    inv_transition: f32,
    /// pbrt-v4's falloff, smoothstep(cos θ_c, cos θ_b, cos θ), instead of Mitsuba's.
    smoothstep: bool,
}

/// A spot's projected picture (Mitsuba 3.9.1's `spot` with a `texture`): direction w, in the
/// spot's frame l = (x, y, z) (z the axis), reads the texture at
/// (u, v) = ½ + ½ (l_x / l_z, l_y / l_z) / tan θ_c — the cone's cross-section inscribed in the
/// picture (probed with Mitsuba's `sample_direction` on a ramp texture).
#[derive(Clone, Debug, PartialEq)]
pub struct SpotTexture {
    /// The spot's frame: columns x, y and the axis, orthonormal and right-handed.
    pub frame: Mat3,
    pub texture: Texture,
    /// tan θ_c of the spot's cutoff.
    tan_cutoff: f32,
    /// ∫ I · falloff · picture dω, integrated once when the picture is set ([`Spot::power`]).
    power: Vec3,
}

impl SpotTexture {
    /// The texture's value toward unit world direction `w` (zero behind the spot).
    #[inline]
    pub fn value(&self, w: Vec3) -> Vec3 {
        let l = self.frame.transpose() * w;
        if l.z <= 0.0 {
            return Vec3::ZERO;
        }
        let uv = Vec2::new(l.x / l.z, l.y / l.z) / self.tan_cutoff * 0.5 + Vec2::splat(0.5);
        self.texture.eval(uv)
    }
}

impl Spot {
    /// A spot with half-angles in radians, `0 < beam <= cutoff < π/2` (checked by the loader).
    pub fn new(position: Vec3, axis: Vec3, intensity: Vec3, cutoff: f32, beam: f32) -> Self {
        Self {
            position,
            axis: axis.normalize(),
            intensity,
            texture: None,
            cutoff,
            cos_cutoff: cutoff.cos(),
            cos_beam: beam.cos(),
            inv_transition: 1.0 / (cutoff - beam),
            smoothstep: false,
        }
    }

    /// pbrt-v4's spot: half-angles θ_c (`coneangle`) and θ_b (`coneangle − conedeltaangle`),
    /// smoothstep falloff in cos θ between them.
    pub fn smoothstep(position: Vec3, axis: Vec3, intensity: Vec3, cutoff: f32, beam: f32) -> Self {
        Self {
            smoothstep: true,
            ..Self::new(position, axis, intensity, cutoff, beam)
        }
    }

    /// The spot with a projected picture (Mitsuba's `texture`); `frame` its frame (columns x, y,
    /// and the axis, which must be this spot's).
    pub fn with_texture(self, frame: Mat3, texture: Texture) -> Self {
        let mut spot = Self {
            texture: Some(SpotTexture {
                frame,
                texture,
                tan_cutoff: self.cutoff.tan(),
                power: Vec3::ZERO,
            }),
            ..self
        };
        let power = spot.pictured_power(frame);
        if let Some(t) = &mut spot.texture {
            t.power = power;
        }
        spot
    }

    /// The spot's intensity toward unit world direction `w`: I · falloff, times the projected
    /// picture's value there if it has one.
    #[inline]
    pub fn intensity_toward(&self, w: Vec3) -> Vec3 {
        self.divided_toward(w, 1.0)
    }

    /// I · (falloff / `d`) toward `w`, times the picture's value if there is one (in this order,
    /// so that an unpictured spot's figures keep their rounding).
    #[inline]
    fn divided_toward(&self, w: Vec3, d: f32) -> Vec3 {
        let falloff = self.falloff(w);
        if falloff <= 0.0 {
            return Vec3::ZERO;
        }
        let i = self.intensity * (falloff / d);
        match &self.texture {
            None => i,
            Some(t) => i * t.value(w),
        }
    }

    /// ∫ I · falloff · picture dω: the emitted power (for a pictured spot integrated once when
    /// the picture is set: it only sets the light's selection probability; every photon's
    /// weight is exact).
    pub fn power(&self) -> Vec3 {
        match &self.texture {
            Some(t) => t.power,
            None => self.intensity * self.falloff_solid_angle(),
        }
    }

    /// A pictured spot's power by a 512 × 512 midpoint rule over the cone's tangent plane in
    /// `frame`, dω = ds dt / (1 + s² + t²)^{3/2}.
    fn pictured_power(&self, frame: Mat3) -> Vec3 {
        const N: usize = 512;
        let tan = self.cutoff.tan() as f64;
        let step = 2.0 * tan / N as f64;
        let mut sum = glam::DVec3::ZERO;
        for j in 0..N {
            for i in 0..N {
                let (s, u) = (-tan + (i as f64 + 0.5) * step, -tan + (j as f64 + 0.5) * step);
                let r2 = 1.0 + s * s + u * u;
                let w = (frame * Vec3::new(s as f32, u as f32, 1.0)).normalize();
                sum += self.intensity_toward(w).as_dvec3() * (step * step / (r2 * r2.sqrt()));
            }
        }
        sum.as_vec3()
    }

    /// Whether the falloff is pbrt-v4's smoothstep.
    pub fn is_smoothstep(&self) -> bool {
        self.smoothstep
    }

    /// The falloff factor in [0, 1] toward unit world direction `w` (Mitsuba's `falloff_curve`).
    #[inline]
    pub fn falloff(&self, w: Vec3) -> f32 {
        let cos_theta = self.axis.dot(w);
        if cos_theta <= self.cos_cutoff {
            0.0
        } else if cos_theta >= self.cos_beam {
            1.0
        } else if self.smoothstep {
            let t = ((cos_theta - self.cos_cutoff) / (self.cos_beam - self.cos_cutoff)).clamp(0.0, 1.0);
            t * t * (3.0 - 2.0 * t)
        } else {
            ((self.cutoff - cos_theta.clamp(-1.0, 1.0).acos()) * self.inv_transition).clamp(0.0, 1.0)
        }
    }

    /// ∫ falloff dω over the sphere (module doc).
    pub fn falloff_solid_angle(&self) -> f32 {
        let (c, b) = (self.cutoff as f64, self.cos_beam.clamp(-1.0, 1.0).acos() as f64);
        let integral = if self.smoothstep {
            let (cos_c, cos_b) = (c.cos(), b.cos());
            TAU as f64 * ((1.0 - cos_b) + 0.5 * (cos_b - cos_c))
        } else if c - b > 1e-6 {
            TAU as f64 * (1.0 - (c.sin() - b.sin()) / (c - b))
        } else {
            TAU as f64 * (1.0 - c.cos())
        };
        integral as f32
    }
}

/// Light arriving at a receiver from a delta light.
#[derive(Clone, Copy, Debug)]
pub struct DeltaIncidence {
    /// Unit direction from the receiver toward the light.
    pub wi: Vec3,
    /// Distance to the light; infinite for directional light.
    pub dist: f32,
    /// What multiplies f_s |cos θi| in the reflected radiance: I · falloff / r² for a point or
    /// a spot, E for directional light.
    pub li: Vec3,
}

/// A ray leaving a delta light and the power it carries per unit of selection probability
/// and per photon (divide by p_light · N).
#[derive(Clone, Copy, Debug)]
pub struct DeltaEmission {
    pub origin: Vec3,
    pub dir: Vec3,
    pub power: Vec3,
    /// Solid-angle density of `dir` at the light (points, spots and projectors; 0 for directional light,
    /// whose direction is fixed and whose origin has area density 1 / π R²).
    pub pdf_dir: f32,
}

impl DeltaLight {
    /// The light reaching point `x` (before visibility); `None` where it sends nothing (outside
    /// a spot's cone, at the light's own position).
    #[inline]
    pub fn illuminate(&self, x: Vec3) -> Option<DeltaIncidence> {
        let toward = |position: Vec3| {
            let d = position - x;
            let dist2 = d.length_squared();
            (dist2 > 0.0).then(|| (d / dist2.sqrt(), dist2))
        };
        let s = match *self {
            DeltaLight::Point { position, intensity } => {
                let (wi, dist2) = toward(position)?;
                DeltaIncidence {
                    wi,
                    dist: dist2.sqrt(),
                    li: intensity / dist2,
                }
            }
            DeltaLight::Spot(ref spot) => {
                let (wi, dist2) = toward(spot.position)?;
                let li = spot.divided_toward(-wi, dist2);
                if li.max_element() <= 0.0 {
                    return None;
                }
                DeltaIncidence {
                    wi,
                    dist: dist2.sqrt(),
                    li,
                }
            }
            DeltaLight::Projector(ref p) => {
                let (wi, dist2) = toward(p.position)?;
                DeltaIncidence {
                    wi,
                    dist: dist2.sqrt(),
                    li: p.divided_toward(-wi, dist2),
                }
            }
            DeltaLight::Directional { direction, irradiance } => DeltaIncidence {
                wi: -direction,
                dist: f32::INFINITY,
                li: irradiance,
            },
        };
        (s.li.max_element() > 0.0).then_some(s)
    }

    /// Whether the light sits at a point (a point, a spot or a projector) rather than infinitely far away.
    #[inline]
    pub fn is_positional(&self) -> bool {
        !matches!(self, DeltaLight::Directional { .. })
    }

    /// The light's position (points, spots and projectors; `None` for directional light).
    #[inline]
    pub fn position(&self) -> Option<Vec3> {
        match *self {
            DeltaLight::Point { position, .. } => Some(position),
            DeltaLight::Spot(ref spot) => Some(spot.position),
            DeltaLight::Projector(ref p) => Some(p.position),
            DeltaLight::Directional { .. } => None,
        }
    }

    /// Radiant intensity I f(ω) leaving a point, a spot or a projector in unit world direction `w` (zero
    /// for directional light, which has no intensity).
    #[inline]
    pub fn intensity(&self, w: Vec3) -> Vec3 {
        match *self {
            DeltaLight::Point { intensity, .. } => intensity,
            DeltaLight::Spot(ref spot) => spot.intensity_toward(w),
            DeltaLight::Projector(ref p) => p.intensity_toward(w),
            DeltaLight::Directional { .. } => Vec3::ZERO,
        }
    }

    /// Solid-angle density with which [`DeltaLight::emit`] sends a point's, a spot's or a
    /// projector's ray in unit world direction `w` (0 for directional light).
    #[inline]
    pub fn pdf_emit_dir(&self, w: Vec3) -> f32 {
        match *self {
            DeltaLight::Point { .. } => uniform_sphere_pdf(),
            DeltaLight::Spot(ref spot) if spot.axis.dot(w) >= spot.cos_cutoff => 1.0 / (TAU * (1.0 - spot.cos_cutoff)),
            DeltaLight::Projector(ref p) => p.pdf_dir(w),
            _ => 0.0,
        }
    }

    /// Emitted power Φ (module doc); `scene_radius` is R for directional light.
    pub fn power(&self, scene_radius: f32) -> Vec3 {
        match *self {
            DeltaLight::Point { intensity, .. } => intensity * (4.0 * PI),
            DeltaLight::Spot(ref spot) => spot.power(),
            DeltaLight::Projector(ref p) => p.power(),
            DeltaLight::Directional { irradiance, .. } => irradiance * (PI * scene_radius * scene_radius),
        }
    }

    /// A ray leaving the light with `u` (module doc); the scene's bounding sphere
    /// (`center`, `radius`) places directional light. `None` where the sample carries nothing.
    pub fn emit(&self, u: Vec2, (center, radius): (Vec3, f32)) -> Option<DeltaEmission> {
        let e = match *self {
            DeltaLight::Point { position, intensity } => DeltaEmission {
                origin: position,
                dir: sample_uniform_sphere(u),
                power: intensity / uniform_sphere_pdf(),
                pdf_dir: uniform_sphere_pdf(),
            },
            DeltaLight::Spot(ref spot) => {
                let local = sample_uniform_cone(u, spot.cos_cutoff);
                let dir = Frame::from_normal(spot.axis).to_world(local).normalize();
                let pdf_dir = self.pdf_emit_dir(dir);
                DeltaEmission {
                    origin: spot.position,
                    dir,
                    power: spot.divided_toward(dir, pdf_dir),
                    pdf_dir,
                }
            }
            DeltaLight::Projector(ref p) => {
                let ray = p.emit(u)?;
                DeltaEmission {
                    origin: p.position,
                    dir: ray.dir,
                    power: ray.power,
                    pdf_dir: ray.pdf_dir,
                }
            }
            DeltaLight::Directional { direction, irradiance } => DeltaEmission {
                origin: super::parallel_ray_origin(-direction, (center, radius), u),
                dir: direction,
                power: irradiance * (PI * radius * radius),
                pdf_dir: 0.0,
            },
        };
        (e.power.is_finite() && e.power.max_element() > 0.0).then_some(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn spot(cutoff_deg: f32, beam_deg: f32) -> Spot {
        Spot::new(
            Vec3::ZERO,
            Vec3::new(0.3, -1.0, 0.2),
            Vec3::ONE,
            cutoff_deg.to_radians(),
            beam_deg.to_radians(),
        )
    }

    /// ∫ falloff dω in closed form against a midpoint quadrature in θ, for Mitsuba's and
    /// pbrt-v4's falloffs.
    #[test]
    fn spot_falloff_integral_matches_quadrature() {
        let cases = [(20.0, 15.0), (60.0, 10.0), (30.0, 30.0), (80.0, 1.0)];
        for (c, b, pbrt) in cases.iter().flat_map(|&(c, b)| [(c, b, false), (c, b, true)]) {
            let s = if pbrt {
                let m = spot(c, b);
                Spot::smoothstep(m.position, m.axis, m.intensity, m.cutoff, m.cos_beam.acos())
            } else {
                spot(c, b)
            };
            let n = 200_000;
            let dtheta = std::f64::consts::PI / n as f64;
            let frame = Frame::from_normal(s.axis);
            let quad: f64 = (0..n)
                .map(|i| {
                    let theta = (i as f64 + 0.5) * dtheta;
                    let w = frame.to_world(Vec3::new(theta.sin() as f32, 0.0, theta.cos() as f32));
                    s.falloff(w) as f64 * std::f64::consts::TAU * theta.sin() * dtheta
                })
                .sum();
            let closed = s.falloff_solid_angle() as f64;
            assert!(
                (closed / quad - 1.0).abs() < 1e-3,
                "cutoff {c} beam {b}, pbrt's falloff {pbrt}: {closed} vs {quad}"
            );
        }
    }

    /// A 2 × 2 picture, one colour per quadrant (nearest texels): row 0 (v < ½) is the frame's
    /// −y half, column 0 (u < ½) its −x half.
    fn quadrants() -> Texture {
        use crate::texture::{Bitmap, Filter, UvTransform, Wrap};
        Texture::Bitmap(Bitmap {
            width: 2,
            height: 2,
            texels: std::sync::Arc::from(vec![
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.0, 2.0, 0.0),
                Vec3::new(0.0, 0.0, 3.0),
                Vec3::new(4.0, 4.0, 4.0),
            ]),
            filter: Filter::Nearest,
            wrap: Wrap::Clamp,
            to_uv: UvTransform::default(),
        })
    }

    /// A spot at the origin pointing along −y with the frame x = +x, y = +z (as `lookat` with
    /// up +z gives), beam 25° inside a cutoff of `cutoff_deg`, projecting `picture`.
    fn pictured(picture: Texture, cutoff_deg: f32) -> Spot {
        let axis = -Vec3::Y;
        let frame = Mat3::from_cols(Vec3::X, Vec3::Z, axis);
        assert!(
            (frame.x_axis.cross(frame.y_axis) - axis).length() < 1e-6,
            "right-handed"
        );
        Spot::new(
            Vec3::ZERO,
            axis,
            Vec3::splat(2.0),
            cutoff_deg.to_radians(),
            25f32.to_radians(),
        )
        .with_texture(frame, picture)
    }

    /// A pictured spot's intensity is I · falloff · T(u, v) with (u, v) = ½ + ½ (l_x / l_z,
    /// l_y / l_z) / tan θ_c in its frame (Mitsuba's mapping): each quadrant of the cone shows
    /// its texel, the edge of the picture meets the cone where l_x / l_z = tan θ_c, and nothing
    /// leaves behind the spot. Its illumination is that intensity over r².
    #[test]
    fn a_pictured_spot_projects_its_texels_through_its_frame() {
        let spot = pictured(quadrants(), 35.0);
        let light = DeltaLight::Spot(spot.clone());
        let tan = 35f32.to_radians().tan();
        // Directions in the frame (x = world +x, y = world +z, axis = world −y).
        let world = |lx: f32, ly: f32| (Vec3::X * lx + Vec3::Z * ly - Vec3::Y).normalize();
        for (lx, ly, texel) in [
            (-0.1, -0.1, Vec3::new(1.0, 0.0, 0.0)),
            (0.1, -0.1, Vec3::new(0.0, 2.0, 0.0)),
            (-0.1, 0.1, Vec3::new(0.0, 0.0, 3.0)),
            (0.1, 0.1, Vec3::splat(4.0)),
        ] {
            let w = world(lx, ly);
            assert_eq!(light.intensity(w), Vec3::splat(2.0) * texel, "({lx}, {ly})");
            let at = w * 2.0;
            let s = light.illuminate(at).unwrap();
            assert!((s.li - Vec3::splat(2.0) * texel / 4.0).abs().max_element() < 1e-6);
        }
        // Near the cone's edge along ±x, the outer columns are read.
        let picture = spot.texture.as_ref().unwrap();
        let uv_edge = |lx: f32| picture.value(world(lx, 0.01));
        assert_eq!(uv_edge(0.999 * tan), Vec3::splat(4.0));
        assert_eq!(uv_edge(-0.999 * tan), Vec3::new(0.0, 0.0, 3.0));
        // Behind the spot: nothing.
        assert_eq!(light.intensity(Vec3::Y), Vec3::ZERO);
    }

    /// The mean power of emitted samples is the light's power (each sample is an unbiased
    /// estimate of Φ), and a spot's samples stay in its cone.
    #[test]
    fn emitted_samples_average_to_the_power() {
        let lights = [
            DeltaLight::Point {
                position: Vec3::ONE,
                intensity: Vec3::new(1.0, 2.0, 3.0),
            },
            DeltaLight::Spot(spot(40.0, 25.0)),
            DeltaLight::Spot(Spot::smoothstep(Vec3::ZERO, Vec3::Y, Vec3::ONE, 0.6, 0.3)),
            DeltaLight::Spot(pictured(quadrants(), 35.0)),
            DeltaLight::Directional {
                direction: Vec3::new(0.0, -1.0, 0.0),
                irradiance: Vec3::splat(2.0),
            },
        ];
        let bounds = (Vec3::ZERO, 3.0);
        let mut rng = Rng::for_task(7, [0, 0, 0]);
        for light in lights {
            let n = 200_000;
            let mut sum = glam::DVec3::ZERO;
            for _ in 0..n {
                if let Some(e) = light.emit(rng.uniform2(), bounds) {
                    sum += e.power.as_dvec3();
                    if let DeltaLight::Spot(s) = &light {
                        assert!(s.axis.dot(e.dir) >= s.cos_cutoff - 1e-6);
                    }
                    if let DeltaLight::Directional { .. } = light {
                        assert!((e.origin - bounds.0).length() <= bounds.1 * 1.4143);
                    }
                }
            }
            let mean = sum / n as f64;
            let power = light.power(bounds.1).as_dvec3();
            let rel = (mean / power - glam::DVec3::ONE).abs().max_element();
            assert!(rel < 0.01, "{light:?}: mean {mean} vs power {power}");
        }
    }

    #[test]
    fn illumination_follows_the_inverse_square_law_and_the_cone() {
        let p = DeltaLight::Point {
            position: Vec3::new(0.0, 2.0, 0.0),
            intensity: Vec3::splat(8.0),
        };
        let s = p.illuminate(Vec3::ZERO).unwrap();
        assert_eq!(s.li, Vec3::splat(2.0));
        assert_eq!(s.wi, Vec3::Y);
        assert_eq!(s.dist, 2.0);
        assert!(p.illuminate(Vec3::new(0.0, 2.0, 0.0)).is_none());
        let sp = DeltaLight::Spot(Spot::new(Vec3::Y, -Vec3::Y, Vec3::ONE, 0.5, 0.25));
        assert_eq!(sp.illuminate(Vec3::ZERO).unwrap().li, Vec3::ONE);
        // Outside the cutoff (tan 0.5 ≈ 0.546 at distance 1).
        assert!(sp.illuminate(Vec3::new(0.6, 0.0, 0.0)).is_none());
        // In the ramp: at angle 0.375 the falloff is one half.
        let x = Vec3::new(0.375f32.tan(), 0.0, 0.0);
        let li = sp.illuminate(x).unwrap().li.x * (Vec3::Y - x).length_squared();
        assert!((li - 0.5).abs() < 1e-4, "{li}");
    }
}
