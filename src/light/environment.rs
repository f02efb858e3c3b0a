//! Light from infinitely far away: Mitsuba 3's `constant` emitter (the same radiance from every
//! direction) and `envmap` (a latitude–longitude image), and pbrt-v4's square equal-area images
//! ([`super::equal_area`]), importance-sampled.
//!
//! Conventions, as Mitsuba 3.9's `envmap` in its RGB variants: a world direction ω toward the
//! environment is turned into the map's frame by the inverse of `to_world` (a rotation here),
//! d = R⁻¹ ω, then u = atan2(d.x, −d.z) / 2π (wrapped into [0, 1)) and v = acos(d.y) / π. The
//! radiance is `scale` times the bilinear interpolation of the texels, periodic in u with
//! texel x centred at u = (x + ½)/W, and with rows at v = y/(H − 1) (row 0 at the +y pole, row
//! H − 1 at the −y pole, clamped between). Texels are linear RGB (OpenEXR as it is; PNG and
//! JPEG decoded from sRGB).
//!
//! Sampling (our own; any density positive wherever the radiance is gives the same expected
//! image): the bilinear function lives on W × (H − 1) cells between neighbouring texel centres;
//! a cell is chosen with probability ∝ the largest channel of its four corners (an upper bound
//! of the radiance inside it, so a cell with light is never skipped) times the solid angle of
//! its band of latitudes, and (u, v) uniformly inside it. Its solid-angle density is
//! p(ω) = P_cell · W (H − 1) / (2π² sin θ) [the Jacobian dω = 2π² sin θ du dv].
//!
//! Power (for choosing between the environment and the scene's area lights by power): Φ = π R²
//! ∫ L(ω) dω with R the scene's bounding-sphere radius, pbrt-v4's figure for an infinite light:
//! the flux that the light's parallel beams from every direction carry through a disc of the
//! scene's size.

use crate::color::luminance;
use crate::sampling::Distribution1D;
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI, TAU};
use std::sync::Arc;

/// A latitude–longitude environment image with its sampling distribution.
#[derive(Clone, Debug)]
pub struct EnvMap {
    pub width: u32,
    pub height: u32,
    /// Linear RGB, row-major, row 0 at the +y pole.
    pub texels: Arc<[Vec3]>,
    /// Cell choice: W × (H − 1) cells, row-major.
    cells: Distribution1D,
}

/// What the environment's radiance is.
#[derive(Clone, Debug)]
pub enum Radiance {
    Constant(Vec3),
    Map(EnvMap),
    /// pbrt-v4's equal-area square image, in its own frame (+z its centre).
    EqualArea(super::equal_area::EqualAreaMap),
}

/// Light arriving from infinitely far away.
#[derive(Clone, Debug)]
pub struct Environment {
    pub radiance: Radiance,
    /// Multiplies the radiance (Mitsuba's `scale`).
    pub scale: f32,
    /// Maps a world direction into the map's frame (the inverse of `to_world`'s rotation).
    pub world_to_local: Mat3,
    /// Its inverse.
    pub local_to_world: Mat3,
}

/// A direction sampled toward the environment.
#[derive(Clone, Copy, Debug)]
pub struct EnvSample {
    /// Unit world direction toward the environment.
    pub wi: Vec3,
    /// Radiance arriving from there.
    pub le: Vec3,
    /// Solid-angle density of `wi`.
    pub pdf_w: f32,
}

impl EnvMap {
    /// Builds the map and its sampling distribution; `None` when every texel is black (or a
    /// texel is negative or not finite, or the image has fewer than 2 rows).
    pub fn new(width: u32, height: u32, texels: Arc<[Vec3]>) -> Option<Self> {
        if height < 2 || width == 0 || texels.len() != (width * height) as usize {
            return None;
        }
        if texels.iter().any(|t| !t.is_finite() || t.min_element() < 0.0) {
            return None;
        }
        let (w, h) = (width as usize, height as usize);
        let mut weights = Vec::with_capacity(w * (h - 1));
        for j in 0..h - 1 {
            let (t0, t1) = (PI * j as f32 / (h - 1) as f32, PI * (j + 1) as f32 / (h - 1) as f32);
            let band = (t0.cos() - t1.cos()).max(0.0);
            for i in 0..w {
                let i1 = (i + 1) % w;
                let corners = [
                    texels[j * w + i],
                    texels[j * w + i1],
                    texels[(j + 1) * w + i],
                    texels[(j + 1) * w + i1],
                ];
                let bound = corners.iter().fold(0.0f32, |m, c| m.max(c.max_element()));
                weights.push(bound * band);
            }
        }
        let cells = Distribution1D::new(&weights)?;
        Some(Self {
            width,
            height,
            texels,
            cells,
        })
    }

    /// The bilinear radiance at map coordinates (u, v).
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.width as usize, self.height as usize);
        let x = (uv.x - uv.x.floor()) * w as f32 - 0.5;
        let y = uv.y.clamp(0.0, 1.0) * (h - 1) as f32;
        let (x0, y0) = (x.floor(), y.floor().min((h - 2) as f32));
        let (fx, fy) = (x - x0, y - y0);
        let i0 = (x0 as i64).rem_euclid(w as i64) as usize;
        let i1 = (i0 + 1) % w;
        let j0 = y0 as usize;
        let t = |i: usize, j: usize| self.texels[j * w + i];
        let top = t(i0, j0).lerp(t(i1, j0), fx);
        let bottom = t(i0, j0 + 1).lerp(t(i1, j0 + 1), fx);
        top.lerp(bottom, fy)
    }

    /// (u, v) with density ∝ the cell bounds, and that density per unit (u, v) area.
    #[inline]
    fn sample_uv(&self, u: Vec2) -> (Vec2, f32) {
        let (w, h) = (self.width as f32, self.height as f32);
        let (cell, pmf, u_rest) = self.cells.sample(u.x);
        let (i, j) = (cell % self.width as usize, cell / self.width as usize);
        // Within the cell: u from texel centre i to i + 1, v from row j to j + 1.
        let uv = Vec2::new((i as f32 + 0.5 + u_rest) / w, (j as f32 + u.y) / (h - 1.0));
        (Vec2::new(uv.x - uv.x.floor(), uv.y), pmf * w * (h - 1.0))
    }

    /// Density per unit (u, v) area of [`EnvMap::sample_uv`] at (u, v).
    #[inline]
    fn pdf_uv(&self, uv: Vec2) -> f32 {
        let (w, h) = (self.width as f32, self.height as f32);
        let x = (uv.x - uv.x.floor()) * w - 0.5;
        let i = (x.floor() as i64).rem_euclid(self.width as i64) as usize;
        let j = ((uv.y.clamp(0.0, 1.0) * (h - 1.0)).floor() as usize).min(self.height as usize - 2);
        self.cells.pmf(j * self.width as usize + i) * w * (h - 1.0)
    }

    /// Solid-angle density of [`Environment::sample`] toward unit direction `d` of the map's
    /// frame, whose (u, v) is `uv`.
    #[inline]
    fn pdf_w(&self, d: Vec3, uv: Vec2) -> f32 {
        let sin_t = (1.0 - d.y * d.y).max(0.0).sqrt();
        if sin_t > 0.0 {
            self.pdf_uv(uv) / (2.0 * PI * PI * sin_t)
        } else {
            0.0
        }
    }

    /// Mean radiance over the sphere of directions, ∫ L dω / 4π: the bilinear function is
    /// linear in u across a cell (its midpoint in u is exact) and is integrated against sin θ
    /// over 16 sub-bands of each row of cells.
    fn mean(&self) -> Vec3 {
        const SUB: usize = 16;
        let (w, h) = (self.width as usize, self.height as usize);
        let mut sum = glam::DVec3::ZERO;
        let mut solid_angle = 0.0f64;
        for k in 0..(h - 1) * SUB {
            let (v0, v1) = (
                k as f64 / ((h - 1) * SUB) as f64,
                (k + 1) as f64 / ((h - 1) * SUB) as f64,
            );
            let band = ((std::f64::consts::PI * v0).cos() - (std::f64::consts::PI * v1).cos()) * std::f64::consts::TAU
                / w as f64;
            for i in 0..w {
                let uv = Vec2::new((i as f32 + 1.0) / w as f32, (0.5 * (v0 + v1)) as f32);
                sum += self.eval(uv).as_dvec3() * band;
                solid_angle += band;
            }
        }
        (sum / solid_angle.max(1e-30)).as_vec3()
    }
}

/// Map coordinates (u, v) of a unit direction in the map's frame.
#[inline]
pub fn direction_to_uv(d: Vec3) -> Vec2 {
    let u = d.x.atan2(-d.z) / TAU;
    Vec2::new(u - u.floor(), d.y.clamp(-1.0, 1.0).acos() * FRAC_1_PI)
}

/// The unit direction in the map's frame at (u, v), and sin θ.
#[inline]
pub fn uv_to_direction(uv: Vec2) -> (Vec3, f32) {
    let (sin_t, cos_t) = (uv.y * PI).sin_cos();
    let (sin_p, cos_p) = (uv.x * TAU).sin_cos();
    (Vec3::new(sin_p * sin_t, cos_t, -cos_p * sin_t), sin_t)
}

impl Environment {
    /// A uniform environment (Mitsuba's `constant`).
    pub fn constant(radiance: Vec3) -> Self {
        Self {
            radiance: Radiance::Constant(radiance),
            scale: 1.0,
            world_to_local: Mat3::IDENTITY,
            local_to_world: Mat3::IDENTITY,
        }
    }

    /// An environment map turned by `local_to_world` (a rotation) and scaled.
    pub fn map(map: EnvMap, local_to_world: Mat3, scale: f32) -> Self {
        Self::of(Radiance::Map(map), local_to_world, scale)
    }

    /// Any radiance turned by `local_to_world` (a rotation) and scaled.
    pub fn of(radiance: Radiance, local_to_world: Mat3, scale: f32) -> Self {
        Self {
            radiance,
            scale,
            world_to_local: local_to_world.transpose(),
            local_to_world,
        }
    }

    /// Radiance arriving from world direction `w` (unit, pointing toward the environment).
    #[inline]
    pub fn le(&self, w: Vec3) -> Vec3 {
        match &self.radiance {
            Radiance::Constant(l) => *l * self.scale,
            Radiance::Map(m) => m.eval(direction_to_uv(self.world_to_local * w)) * self.scale,
            Radiance::EqualArea(m) => m.eval(self.world_to_local * w) * self.scale,
        }
    }

    /// A direction toward the environment for a receiver, by `u`; `None` for a direction of
    /// zero density (a pole, where the map's parameterization degenerates).
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<EnvSample> {
        match &self.radiance {
            Radiance::Constant(l) => {
                let wi = crate::sampling::sample_uniform_sphere(u);
                Some(EnvSample {
                    wi,
                    le: *l * self.scale,
                    pdf_w: 1.0 / (4.0 * PI),
                })
            }
            Radiance::Map(m) => {
                let (uv, pdf_uv) = m.sample_uv(u);
                let (d, sin_t) = uv_to_direction(uv);
                if sin_t <= 0.0 || pdf_uv <= 0.0 {
                    return None;
                }
                // The density and radiance of the direction as returned (rounded to f32), so
                // that they agree bit for bit with `pdf` and `le` there, also on a cell border.
                let wi = (self.local_to_world * d).normalize();
                let local = self.world_to_local * wi;
                let uv = direction_to_uv(local);
                let pdf_w = m.pdf_w(local, uv);
                (pdf_w > 0.0).then(|| EnvSample {
                    wi,
                    le: m.eval(uv) * self.scale,
                    pdf_w,
                })
            }
            Radiance::EqualArea(m) => {
                let (d, _) = m.sample(u);
                let wi = (self.local_to_world * d).normalize();
                let local = self.world_to_local * wi;
                let pdf_w = m.pdf(local);
                (pdf_w > 0.0).then(|| EnvSample {
                    wi,
                    le: m.eval(local) * self.scale,
                    pdf_w,
                })
            }
        }
    }

    /// Solid-angle density with which [`Environment::sample`] returns world direction `w`.
    #[inline]
    pub fn pdf(&self, w: Vec3) -> f32 {
        match &self.radiance {
            Radiance::Constant(_) => 1.0 / (4.0 * PI),
            Radiance::Map(m) => {
                let d = self.world_to_local * w;
                m.pdf_w(d, direction_to_uv(d))
            }
            Radiance::EqualArea(m) => m.pdf(self.world_to_local * w),
        }
    }

    /// Mean radiance over all directions, per channel.
    pub fn mean_radiance(&self) -> Vec3 {
        match &self.radiance {
            Radiance::Constant(l) => *l * self.scale,
            Radiance::Map(m) => m.mean() * self.scale,
            Radiance::EqualArea(m) => m.mean() * self.scale,
        }
    }

    /// Power for light selection: π R² ∫ L dω (luminance), R the scene's bounding radius.
    pub fn power(&self, scene_radius: f32) -> f32 {
        PI * scene_radius * scene_radius * 4.0 * PI * luminance(self.mean_radiance()).max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;
    use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_test_directions};

    /// A small map with a bright spot, a dark band and a black cell, turned by a rotation.
    fn test_map() -> Environment {
        let (w, h) = (16u32, 9u32);
        let mut texels = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let mut c = Vec3::new(0.2 + 0.05 * x as f32, 0.1, 0.3 + 0.02 * y as f32);
                if (x, y) == (5, 3) {
                    c = Vec3::splat(40.0);
                }
                if y == 6 {
                    c *= 0.01;
                }
                if x >= 12 && y >= 7 {
                    c = Vec3::ZERO;
                }
                texels.push(c);
            }
        }
        let map = EnvMap::new(w, h, texels.into()).unwrap();
        let r = Mat3::from_axis_angle(Vec3::new(0.3, 1.0, -0.2).normalize(), 0.7);
        Environment::map(map, r, 1.5)
    }

    #[test]
    fn uv_and_direction_are_inverse_maps_with_mitsubas_axes() {
        // u = 0 looks down −z, u = ¼ down +x; v = 0 is +y.
        assert!((uv_to_direction(Vec2::new(0.0, 0.5)).0 - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        assert!((uv_to_direction(Vec2::new(0.25, 0.5)).0 - Vec3::X).length() < 1e-6);
        assert!((uv_to_direction(Vec2::new(0.3, 0.0)).0 - Vec3::Y).length() < 1e-6);
        for uv in [Vec2::new(0.1, 0.2), Vec2::new(0.6, 0.9), Vec2::new(0.99, 0.5)] {
            let back = direction_to_uv(uv_to_direction(uv).0);
            assert!((back - uv).length() < 1e-5, "{uv} -> {back}");
        }
    }

    /// Texel x is centred at u = (x + ½)/W, row y at v = y/(H − 1); in between, bilinear and
    /// periodic in u.
    #[test]
    fn the_map_is_read_at_mitsubas_texel_positions() {
        let texels: Vec<Vec3> = (0..8).map(|i| Vec3::splat(i as f32)).collect();
        let m = EnvMap::new(4, 2, texels.into()).unwrap();
        assert_eq!(m.eval(Vec2::new(0.125, 0.0)), Vec3::splat(0.0));
        assert_eq!(m.eval(Vec2::new(0.375, 0.0)), Vec3::splat(1.0));
        assert_eq!(m.eval(Vec2::new(0.125, 1.0)), Vec3::splat(4.0));
        assert_eq!(m.eval(Vec2::new(0.25, 0.5)), Vec3::splat(2.5));
        // Between the last and the first column.
        assert_eq!(m.eval(Vec2::new(0.0, 0.0)), Vec3::splat(1.5));
    }

    #[test]
    fn sampling_a_map_matches_its_pdf() {
        let env = test_map();
        let report = chi2_test_directions(
            |rng: &mut Rng| env.sample(rng.uniform2()).map(|s| (s.wi, s.pdf_w)),
            |w| env.pdf(w),
            DirectionTest {
                theta_bins: 16,
                phi_bins: 32,
                n_samples: 400_000,
                pdf_rel_tol: 2e-3,
                ..DirectionTest::default()
            },
        );
        assert!(report.passes(CHI2_ALPHA), "{report:?}");
        assert!((report.pdf_integral - 1.0).abs() < 2e-3, "{report:?}");
    }

    /// The estimator L / p of the mean radiance is unbiased: its average over samples is the
    /// mean by quadrature, and every sample's radiance is the map's own value there.
    #[test]
    fn importance_sampled_radiance_estimates_the_mean() {
        let env = test_map();
        let mut rng = Rng::for_task(5, [0, 0, 0]);
        let n = 400_000;
        let mut sum = glam::DVec3::ZERO;
        for _ in 0..n {
            if let Some(s) = env.sample(rng.uniform2()) {
                assert!((s.le - env.le(s.wi)).abs().max_element() <= 1e-3 * s.le.max_element().max(1.0));
                sum += (s.le / s.pdf_w).as_dvec3();
            }
        }
        let estimate = sum / n as f64 / (4.0 * std::f64::consts::PI);
        let mean = env.mean_radiance().as_dvec3();
        assert!(
            ((estimate - mean) / mean).abs().max_element() < 0.01,
            "{estimate} vs {mean}"
        );
    }

    #[test]
    fn a_constant_environment_samples_the_sphere_uniformly() {
        let env = Environment::constant(Vec3::new(1.0, 2.0, 3.0));
        let report = chi2_test_directions(
            |rng: &mut Rng| env.sample(rng.uniform2()).map(|s| (s.wi, s.pdf_w)),
            |w| env.pdf(w),
            DirectionTest::default(),
        );
        assert!(report.passes(CHI2_ALPHA), "{report:?}");
        assert_eq!(env.le(Vec3::X), Vec3::new(1.0, 2.0, 3.0));
    }
}
