//! Mitsuba 3.9.1's `projector` (`src/emitters/projector.cpp`): a pinhole camera run backwards,
//! projecting a picture of irradiance E(u, v) into the scene from a point.
//!
//! Quantities, in the projector's frame (columns x, y and the axis z; Mitsuba's `to_world`,
//! whose `lookat` makes x the left and y the up of the picture):
//! - the image plane at z = 1 spans [−t_x, t_x] × [−t_y, t_y], t_x = tan(fov_x / 2) and
//!   t_y = t_x H / W for a W × H picture (1 × 1 for a constant), area A = 4 t_x t_y;
//! - unit direction l meets it at (l_x, l_y) / l_z and reads the picture at
//!   (u, v) = (½ − ½ (l_x / l_z) / t_x, ½ − ½ (l_y / l_z) / t_y) — u grows to the right and v
//!   downward as seen from the projector, so the picture stands upright as a camera with the
//!   same `to_world` would see it; nothing leaves outside [0, 1]² or behind;
//! - intensity I(l) = π s E(u, v) / l_z³ (s the `scale`), so the irradiance on the plane z = 1,
//!   I cos θ / r² = I l_z³, is π s E: a constant picture lights a facing plane evenly (Mitsuba's
//!   `sample_direction` returns π s E / (z² cos θ), the same over r², z = r l_z);
//! - power Φ = ∫ I dω = π s A ∫ E du dv, since dω = A l_z³ du dv on the image plane;
//! - emission: (u, v) from a [`PictureSampler`] with density p(u, v), the direction's solid-angle
//!   density p / (A l_z³), the power per ray π s A E / p (Mitsuba's `sample_ray` weight; Mitsuba
//!   samples texels by luminance, we by a bound of each cell: the same expectation).

use super::picture::PictureSampler;
use crate::texture::Texture;
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;

/// A projector: a point light whose intensity is a picture seen through a pinhole (module doc).
#[derive(Clone, Debug)]
pub struct Projector {
    pub position: Vec3,
    /// Columns x (the picture's left), y (its up) and the axis; orthonormal.
    pub frame: Mat3,
    /// (t_x, t_y): the image plane at distance 1 spans ±t_x × ±t_y.
    tan_half: Vec2,
    /// π s × the irradiance's colour: what multiplies the picture's value (the picture's value
    /// is 1 without one).
    factor: Vec3,
    pub picture: Option<Texture>,
    sampler: PictureSampler,
    /// Φ (module doc), integrated once.
    power: Vec3,
}

/// A ray leaving a projector: its unit world direction, the power it carries (π s A E / p) and
/// the solid-angle density of its direction.
#[derive(Clone, Copy, Debug)]
pub struct ProjectedRay {
    pub dir: Vec3,
    pub power: Vec3,
    pub pdf_dir: f32,
}

impl PartialEq for Projector {
    fn eq(&self, other: &Self) -> bool {
        (self.position, self.frame, self.tan_half, self.factor)
            == (other.position, other.frame, other.tan_half, other.factor)
            && self.picture == other.picture
    }
}

impl Projector {
    /// A projector at `position` with `frame` (orthonormal columns x, y, axis), an image plane
    /// of half-extents `tan_half` at distance 1, irradiance `scale` × colour `irradiance` × the
    /// `picture`'s value (non-negative and finite: checked by the loader).
    pub fn new(
        position: Vec3,
        frame: Mat3,
        tan_half: Vec2,
        scale: f32,
        irradiance: Vec3,
        picture: Option<Texture>,
    ) -> Self {
        let mut projector = Self {
            position,
            frame,
            tan_half,
            factor: PI * scale * irradiance,
            sampler: PictureSampler::new(picture.as_ref()),
            picture,
            power: Vec3::ZERO,
        };
        projector.power = projector.area() * projector.mean_irradiance();
        projector
    }

    /// A = 4 t_x t_y, the image plane's area at distance 1.
    #[inline]
    pub fn area(&self) -> f32 {
        4.0 * self.tan_half.x * self.tan_half.y
    }

    /// The emitted power Φ = A ∫ π s E du dv.
    pub fn power(&self) -> Vec3 {
        self.power
    }

    /// π s E(u, v).
    #[inline]
    fn irradiance(&self, uv: Vec2) -> Vec3 {
        match &self.picture {
            None => self.factor,
            Some(t) => self.factor * t.eval(uv),
        }
    }

    /// ∫ π s E du dv over [0, 1]² (a picture's by a 256 × 256 midpoint rule: the power only
    /// sets the light's selection probability; every ray's weight is exact).
    fn mean_irradiance(&self) -> Vec3 {
        const N: usize = 256;
        if self.picture.is_none() {
            return self.factor;
        }
        let mut sum = glam::DVec3::ZERO;
        for j in 0..N {
            for i in 0..N {
                let uv = Vec2::new((i as f32 + 0.5) / N as f32, (j as f32 + 0.5) / N as f32);
                sum += self.irradiance(uv).as_dvec3();
            }
        }
        (sum / (N * N) as f64).as_vec3()
    }

    /// Where unit world direction `w` meets the picture, and l_z (the cosine to the axis);
    /// `None` behind the projector or outside the picture.
    #[inline]
    fn picture_point(&self, w: Vec3) -> Option<(Vec2, f32)> {
        let l = self.frame.transpose() * w;
        if l.z <= 0.0 {
            return None;
        }
        let uv = Vec2::splat(0.5) - 0.5 * Vec2::new(l.x, l.y) / (l.z * self.tan_half);
        (uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all()).then_some((uv, l.z))
    }

    /// The intensity I toward unit world direction `w`: π s E / l_z³.
    #[inline]
    pub fn intensity_toward(&self, w: Vec3) -> Vec3 {
        self.divided_toward(w, 1.0)
    }

    /// I / `d` toward unit world direction `w`.
    #[inline]
    pub fn divided_toward(&self, w: Vec3, d: f32) -> Vec3 {
        match self.picture_point(w) {
            Some((uv, cos)) => self.irradiance(uv) / (cos * cos * cos * d),
            None => Vec3::ZERO,
        }
    }

    /// Solid-angle density with which [`Projector::emit`] sends a ray along unit world
    /// direction `w`: p(u, v) / (A l_z³).
    #[inline]
    pub fn pdf_dir(&self, w: Vec3) -> f32 {
        match self.picture_point(w) {
            Some((uv, cos)) => self.sampler.pdf(uv) / (self.area() * cos * cos * cos),
            None => 0.0,
        }
    }

    /// A ray leaving the projector with `u` (module doc); `None` where it carries nothing.
    #[inline]
    pub fn emit(&self, u: Vec2) -> Option<ProjectedRay> {
        let (uv, pdf_uv) = self.sampler.sample(u);
        let on_plane = Vec3::new(
            self.tan_half.x * (1.0 - 2.0 * uv.x),
            self.tan_half.y * (1.0 - 2.0 * uv.y),
            1.0,
        );
        let local = on_plane.normalize();
        let power = self.irradiance(uv) * (self.area() / pdf_uv);
        (pdf_uv > 0.0 && power.max_element() > 0.0).then(|| ProjectedRay {
            dir: (self.frame * local).normalize(),
            power,
            pdf_dir: pdf_uv / (self.area() * local.z * local.z * local.z),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;
    use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_test_directions};
    use crate::texture::{Bitmap, Filter, UvTransform, Wrap};

    /// A 4 × 2 picture: row 0 (the top) red, green, blue, white; row 1 dark.
    fn picture(filter: Filter) -> Texture {
        let (r, g, b, k) = (Vec3::X, Vec3::Y, Vec3::Z, Vec3::splat(0.1));
        Texture::Bitmap(Bitmap {
            width: 4,
            height: 2,
            texels: vec![r, g, b, Vec3::ONE, k, k, k, k].into(),
            filter,
            wrap: Wrap::Clamp,
            to_uv: UvTransform::default(),
        })
    }

    /// Looking along −z with up +y, as Mitsuba's `lookat` makes it: x = up × axis = −x (the
    /// picture's left), y = axis × x = +y.
    fn frame() -> Mat3 {
        let (axis, up) = (-Vec3::Z, Vec3::Y);
        let x = up.cross(axis).normalize();
        Mat3::from_cols(x, axis.cross(x), axis)
    }

    fn projector(filter: Filter) -> Projector {
        let tx = 20f32.to_radians().tan();
        Projector::new(
            Vec3::new(0.0, 0.0, 2.0),
            frame(),
            Vec2::new(tx, tx / 2.0),
            1.5,
            Vec3::new(1.0, 2.0, 1.0),
            Some(picture(filter)),
        )
    }

    /// Seen from the projector (looking along −z, up +y, so its right is +x), the top-left
    /// texel lands up and to the left, the top-right one up and to the right; on the plane
    /// z = 1 (distance 1) the irradiance I cos θ / r² is π s E, whatever the angle.
    #[test]
    fn the_picture_stands_upright_and_lights_a_facing_plane_by_its_irradiance() {
        let p = projector(Filter::Nearest);
        let (tx, ty) = (p.tan_half.x, p.tan_half.y);
        let on_plane = |x: f32, y: f32| {
            let d = Vec3::new(x, y, 1.0) - p.position;
            let w = d.normalize();
            let cos = w.dot(-Vec3::Z);
            p.divided_toward(w, d.length_squared()) * cos
        };
        let factor = PI * 1.5 * Vec3::new(1.0, 2.0, 1.0);
        let near = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 1e-4 * b.max_element().max(1.0);
        // Left of the picture as seen from the projector: −x in the world.
        assert!(near(on_plane(-0.9 * tx, 0.9 * ty), factor * Vec3::X));
        assert!(near(on_plane(-0.4 * tx, 0.9 * ty), factor * Vec3::Y));
        assert!(near(on_plane(0.4 * tx, 0.9 * ty), factor * Vec3::Z));
        assert!(near(on_plane(0.9 * tx, 0.9 * ty), factor));
        assert!(near(on_plane(0.9 * tx, -0.5 * ty), factor * 0.1));
        // Outside the picture and behind the projector: nothing.
        assert_eq!(on_plane(1.01 * tx, 0.0), Vec3::ZERO);
        assert_eq!(on_plane(0.0, -1.01 * ty), Vec3::ZERO);
        assert_eq!(p.intensity_toward(Vec3::Z), Vec3::ZERO);
    }

    /// The emission sampler against its density (χ² over the sphere, each ray's reported
    /// density the density at it), and the rays' mean power the projector's power.
    #[test]
    fn emitted_rays_follow_their_density_and_average_to_the_power() {
        for filter in [Filter::Nearest, Filter::Bilinear] {
            let p = projector(filter);
            let report = chi2_test_directions(
                |rng| p.emit(rng.uniform2()).map(|r| (r.dir, r.pdf_dir)),
                |w| p.pdf_dir(w),
                DirectionTest {
                    n_samples: 200_000,
                    theta_bins: 40,
                    phi_bins: 40,
                    ..DirectionTest::default()
                },
            );
            assert!(report.passes(CHI2_ALPHA), "{filter:?}: {report:?}");
            assert!((report.pdf_integral - 1.0).abs() < 2e-3, "{report:?}");

            let mut rng = Rng::for_task(5, [0, 0, 0]);
            let n = 200_000;
            let mut sum = glam::DVec3::ZERO;
            for _ in 0..n {
                if let Some(r) = p.emit(rng.uniform2()) {
                    // The power per ray is I / p_ω, the intensity over the density.
                    let expected = p.intensity_toward(r.dir) / r.pdf_dir;
                    assert!(
                        (r.power - expected).abs().max_element() <= 2e-3 * expected.max_element(),
                        "{r:?} vs {expected}"
                    );
                    sum += r.power.as_dvec3();
                }
            }
            let rel = (sum / n as f64 / p.power().as_dvec3() - glam::DVec3::ONE)
                .abs()
                .max_element();
            assert!(rel < 0.01, "{filter:?}: mean power off by {rel}");
        }
    }
}
