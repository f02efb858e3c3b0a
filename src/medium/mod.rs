//! Participating media: light scattered and absorbed between surfaces, for the volumetric walk
//! of `path` ([`crate::strategy::path::media`]).
//!
//! A medium fills the inside or the outside of closed surfaces (Mitsuba 3's `interior` and
//! `exterior` references on a shape; the camera's `medium`). We render Mitsuba's
//! `homogeneous` medium: an extinction coefficient σ_t constant in space (per RGB channel, in
//! inverse scene units, times `scale`), a single-scattering albedo α = σ_s / σ_t that may vary in
//! space (a constant, or a [`grid::GridVolume`]), and a phase function ([`phase::Phase`]).
//!
//! **Distance sampling.** Each path picks a *hero* channel h uniformly and draws every free
//! flight from that channel's density σ_h e^{−σ_h t}; the path's estimate divides by the mean
//! over channels of the density each channel would have given the same path, so that the
//! estimator is single-sample MIS with the balance heuristic over the three channels [Wilkie et
//! al. 2014, "Hero wavelength spectral sampling"; pbrt-v4's `VolPathIntegrator` and its ratios
//! r_u]: a collision weighs T(t) σ_s(x) / p_h(t) with p_c(t) = σ_c e^{−σ_c t}, a segment passed
//! weighs T(t_max) / P_h(t_max) with P_c = e^{−σ_c t_max}, and the path carries Π p_c / p_h per
//! channel ([`spectral_estimate`]). With a grey σ_t the weights reduce to α and 1. **Decision:**
//! Mitsuba's `volpath` also draws one channel per path but divides by that channel's density
//! alone, which has the same expectation and unbounded weights where σ_t is coloured (a
//! channel whose σ_t is far above the hero's); dividing by the channels' mean bounds them by 3.
//! (A per-collision mixture of the channels, tried first, is unbiased too but multiplies ratios
//! of up to 3 along deep paths: the white-furnace test of `tests/media.rs` failed with it.)
//!
//! **Transmittance along shadow rays** is evaluated, not estimated: T = e^{−σ_t d} per channel
//! (Mitsuba's `volpath` estimates it by tracking, which is unbiased and noisier).

pub mod grid;
pub mod phase;

use crate::sampling::Rng;
use glam::Vec3;
use grid::GridVolume;
use phase::Phase;

/// Where in a medium the single-scattering albedo comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum Albedo {
    Constant(Vec3),
    /// A 3-D texture over world space (Mitsuba's `gridvolume`).
    Grid(GridVolume),
}

/// A participating medium: homogeneous (Mitsuba 3's `homogeneous`) or, with a `density`,
/// heterogeneous (its `heterogeneous`).
#[derive(Clone, Debug, PartialEq)]
pub struct Medium {
    pub name: String,
    /// σ_t per channel, in inverse scene units (Mitsuba's `sigma_t` × `scale`) of a homogeneous
    /// medium; unused when `density` is set.
    pub sigma_t: Vec3,
    /// The extinction of a heterogeneous medium, varying in space.
    pub density: Option<Density>,
    /// α = σ_s / σ_t.
    pub albedo: Albedo,
    pub phase: Phase,
    /// Whether scattering events in the medium sample emitters (Mitsuba's `sample_emitters`,
    /// default true); false leaves them to phase sampling alone, which is cheaper where
    /// emitters cannot be seen anyway (media inside glass).
    pub sample_emitters: bool,
}

/// The extinction σ_t(x) = `scale` · grid(x) of a heterogeneous medium inside the world box
/// that holds its grid's unit cube (vacuum outside it, as Mitsuba's `heterogeneous` clips rays
/// to its volume's bounding box), with the majorant σ̄ = `scale` · max(grid).
#[derive(Clone, Debug, PartialEq)]
pub struct Density {
    pub grid: GridVolume,
    pub scale: f32,
    pub majorant: f32,
    /// The world-space box of the grid's unit cube after its `to_world`.
    pub bounds: (Vec3, Vec3),
}

impl Density {
    pub fn new(grid: GridVolume, scale: f32) -> Self {
        let m = grid.to_world();
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for i in 0..8 {
            let corner = Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32);
            let w = m.transform_point3(corner);
            (lo, hi) = (lo.min(w), hi.max(w));
        }
        Self {
            majorant: scale * grid.max(),
            grid,
            scale,
            bounds: (lo, hi),
        }
    }

    /// σ_t at `x` (inside the bounds).
    #[inline]
    pub fn sigma_t(&self, x: Vec3) -> Vec3 {
        self.grid.eval(x) * self.scale
    }

    /// The part [t0, t1) of the ray (o, d) within [0, t_max] that lies in the bounds, if any
    /// (the slab test).
    fn clip(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32)> {
        let inv = d.recip();
        let (a, b) = ((self.bounds.0 - o) * inv, (self.bounds.1 - o) * inv);
        let (near, far) = (a.min(b), a.max(b));
        // NaN (0 · ∞ on a face) compares false and drops out of max/min.
        let t0 = near.max_element().max(0.0);
        let t1 = far.min_element().min(t_max);
        (t0 < t1).then_some((t0, t1))
    }

    /// Delta tracking [Woodcock et al. 1965] against the majorant σ̄ with *spectral* tracking's
    /// probabilities [Kutz et al. 2017, "Spectral and decomposition tracking", §4]: a tentative
    /// collision at x is real with probability P = mean_c σ_t,c(x) / σ̄ and weighs
    /// σ_s(x) / (σ̄ P) (the albedo when σ_t is grey), else null with weight
    /// (σ̄ − σ_t(x)) / (σ̄ (1 − P)) (1 when grey). Unbiased for any σ_t ≤ σ̄.
    fn track(&self, albedo: &Albedo, o: Vec3, d: Vec3, t_max: f32, rng: &mut Rng) -> Flight {
        let pass = |weight| Flight::Pass {
            weight,
            ratio: Vec3::ONE,
        };
        let Some((t0, t1)) = self.clip(o, d, t_max) else {
            return pass(Vec3::ONE);
        };
        let mut weight = Vec3::ONE;
        let mut t = t0;
        loop {
            t += -(-rng.uniform()).ln_1p() / self.majorant;
            if t >= t1 || weight == Vec3::ZERO {
                return pass(weight);
            }
            let x = o + d * t;
            let sigma_t = self.sigma_t(x);
            let p_real = (sigma_t.element_sum() / (3.0 * self.majorant)).clamp(0.0, 1.0);
            if rng.uniform() < p_real {
                let weight = weight * sigma_t * albedo_at(albedo, x) / (self.majorant * p_real);
                return Flight::Scatter {
                    t,
                    p: x,
                    weight,
                    ratio: Vec3::ONE,
                };
            }
            weight *= (Vec3::splat(self.majorant) - sigma_t) / (self.majorant * (1.0 - p_real));
        }
    }

    /// Ratio tracking [Novák et al. 2014]: an unbiased estimate of the transmittance of the
    /// ray (o, d) up to `t_max`, Π (1 − σ_t(xᵢ) / σ̄) over tentative collisions.
    fn ratio_tracking(&self, o: Vec3, d: Vec3, t_max: f32, rng: &mut Rng) -> Vec3 {
        let Some((t0, t1)) = self.clip(o, d, t_max) else {
            return Vec3::ONE;
        };
        let mut tr = Vec3::ONE;
        let mut t = t0;
        loop {
            t += -(-rng.uniform()).ln_1p() / self.majorant;
            if t >= t1 {
                return tr;
            }
            tr *= Vec3::ONE - self.sigma_t(o + d * t) / self.majorant;
            if tr.max_element() <= 0.0 {
                return Vec3::ZERO;
            }
        }
    }
}

/// α at `p` for an albedo description.
#[inline]
fn albedo_at(albedo: &Albedo, p: Vec3) -> Vec3 {
    match albedo {
        Albedo::Constant(a) => *a,
        Albedo::Grid(g) => g.eval(p),
    }
}

/// The outcome of free-flight sampling along a segment ([`Medium::sample_flight`]). `weight`
/// is T σ_s / p_h (a collision, albedo included) or T / P_h (a pass) under the path's hero
/// channel h, and `ratio` each channel's density over the hero's, p_c / p_h: the path carries
/// the product of the ratios so that its estimate divides by the mean over channels (module
/// doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Flight {
    /// A collision at distance `t` < t_max, at point `p`.
    Scatter { t: f32, p: Vec3, weight: Vec3, ratio: Vec3 },
    /// The whole segment passed.
    Pass { weight: Vec3, ratio: Vec3 },
}

impl Medium {
    /// α at point `p`.
    #[inline]
    pub fn albedo_at(&self, p: Vec3) -> Vec3 {
        albedo_at(&self.albedo, p)
    }

    /// The transmittance of the segment of length `t` from `o` along unit `d`: in closed form in
    /// a homogeneous medium, by ratio tracking in a heterogeneous one.
    #[inline]
    pub fn transmittance_along(&self, o: Vec3, d: Vec3, t: f32, rng: &mut Rng) -> Vec3 {
        match &self.density {
            None => self.transmittance(t),
            Some(density) if density.majorant > 0.0 => density.ratio_tracking(o, d, t, rng),
            Some(_) => Vec3::ONE,
        }
    }

    /// T(t) = e^{−σ_t t} per channel (an infinite `t` gives 0 where σ_t > 0, 1 where it is 0).
    #[inline]
    pub fn transmittance(&self, t: f32) -> Vec3 {
        let e = |s: f32| if s == 0.0 { 1.0 } else { (-s * t).exp() };
        Vec3::new(e(self.sigma_t.x), e(self.sigma_t.y), e(self.sigma_t.z))
    }

    /// Free-flight sampling along the ray from `o` in unit direction `d` up to `t_max`: in a
    /// homogeneous medium with the path's hero channel `hero` (0, 1, 2), one number drawing the
    /// distance by inverting the hero's exponential (module doc); in a heterogeneous one by
    /// delta tracking ([`Density`]).
    pub fn sample_flight(&self, o: Vec3, d: Vec3, t_max: f32, hero: usize, rng: &mut Rng) -> Flight {
        if let Some(density) = &self.density {
            if density.majorant <= 0.0 {
                return Flight::Pass {
                    weight: Vec3::ONE,
                    ratio: Vec3::ONE,
                };
            }
            return density.track(&self.albedo, o, d, t_max, rng);
        }
        let u = rng.uniform();
        let sigma_h = self.sigma_t[hero];
        // −ln(1 − u) / σ: u < 1 always, so the logarithm is finite; σ = 0 never collides.
        let t = if sigma_h > 0.0 {
            -(-u).ln_1p() / sigma_h
        } else {
            f32::INFINITY
        };
        if t < t_max {
            let tr = self.transmittance(t);
            let density = self.sigma_t * tr;
            let p = o + d * t;
            Flight::Scatter {
                t,
                p,
                weight: tr * self.sigma_t * self.albedo_at(p) / density[hero],
                ratio: density / density[hero],
            }
        } else {
            let tr = self.transmittance(t_max);
            let ratio = tr / tr[hero];
            Flight::Pass { weight: ratio, ratio }
        }
    }
}

/// A path's estimate from its hero-channel throughput `beta` and its density ratios `ratio`
/// (the products of [`Flight`]'s): β / mean_c(p_c / p_h), the balance heuristic over channels.
#[inline]
pub fn spectral_estimate(beta: Vec3, ratio: Vec3) -> Vec3 {
    let mean = ratio.element_sum() / 3.0;
    if mean > 0.0 && mean.is_finite() {
        beta / mean
    } else {
        Vec3::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn medium(sigma_t: Vec3, albedo: Vec3) -> Medium {
        Medium {
            name: "m".into(),
            sigma_t,
            density: None,
            albedo: Albedo::Constant(albedo),
            phase: Phase::Isotropic,
            sample_emitters: true,
        }
    }

    /// The collision estimator is unbiased for the transmittance: passing estimates average to
    /// T(t_max), and for a test function f the collisions average ∫₀^t_max f(t) T(t) σ_s dt,
    /// both per channel, with very different σ_t per channel (the hero's ratios must carry each).
    #[test]
    fn flights_estimate_the_transmittance_and_the_collision_integral() {
        let m = medium(Vec3::new(0.2, 1.5, 6.0), Vec3::new(0.9, 0.5, 0.3));
        let t_max = 1.3;
        let f = |t: f32| 1.0 + t * t;
        let n = 2_000_000;
        let mut rng = Rng::for_task(11, [0, 0, 0]);
        let (mut pass, mut collide) = (Vec3::ZERO.as_dvec3(), Vec3::ZERO.as_dvec3());
        for _ in 0..n {
            let hero = ((rng.uniform() * 3.0) as usize).min(2);
            match m.sample_flight(Vec3::ZERO, Vec3::X, t_max, hero, &mut rng) {
                Flight::Pass { weight, ratio } => pass += spectral_estimate(weight, ratio).as_dvec3(),
                Flight::Scatter { t, weight, ratio, .. } => {
                    collide += (spectral_estimate(weight, ratio) * f(t)).as_dvec3();
                }
            }
        }
        let (pass, collide) = (pass / n as f64, collide / n as f64);
        for c in 0..3 {
            let s = m.sigma_t[c] as f64;
            let a = [0.9, 0.5, 0.3][c];
            let expected_pass = (-s * t_max as f64).exp();
            // ∫₀^T (1 + t²) s e^{−st} dt, by Simpson on 20 000 panels.
            let k = 20_000;
            let h = t_max as f64 / k as f64;
            let g = |t: f64| (1.0 + t * t) * s * (-s * t).exp();
            let simpson = (0..k)
                .map(|i| {
                    let t0 = i as f64 * h;
                    h / 6.0 * (g(t0) + 4.0 * g(t0 + h / 2.0) + g(t0 + h))
                })
                .sum::<f64>();
            let expected_collide = a * simpson;
            assert!(
                (pass[c] - expected_pass).abs() < 4e-3 * expected_pass.max(0.05),
                "channel {c}: pass {} vs {expected_pass}",
                pass[c]
            );
            assert!(
                (collide[c] - expected_collide).abs() < 5e-3 * expected_collide,
                "channel {c}: collisions {} vs {expected_collide}",
                collide[c]
            );
        }
    }

    #[test]
    fn grey_media_weigh_by_the_albedo_and_pass_with_one() {
        let m = medium(Vec3::splat(2.0), Vec3::new(0.8, 0.6, 0.4));
        let mut rng = Rng::for_task(5, [0, 0, 0]);
        for _ in 0..1000 {
            let hero = ((rng.uniform() * 3.0) as usize).min(2);
            match m.sample_flight(Vec3::ZERO, Vec3::Y, 0.7, hero, &mut rng) {
                Flight::Pass { weight, ratio } => {
                    assert!((weight - Vec3::ONE).abs().max_element() < 1e-5 && ratio == Vec3::ONE);
                }
                Flight::Scatter { t, p, weight, .. } => {
                    assert!(t < 0.7 && (p - Vec3::Y * t).length() < 1e-6);
                    assert!((weight - Vec3::new(0.8, 0.6, 0.4)).abs().max_element() < 1e-5);
                }
            }
        }
    }
}
