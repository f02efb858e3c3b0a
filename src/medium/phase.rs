//! Phase functions: how a medium scatters light at a point, as densities over the sphere of
//! outgoing directions (each integrates to 1, so sampling one exactly leaves the weight 1).
//!
//! Directions here are *propagation* directions: `d` the direction light (or the path) was
//! travelling before the event, `w` the one it travels after; θ is the angle between them, so
//! cos θ = 1 means "straight on". Mitsuba 3 writes the same densities with wᵢ = −d (its `hg`
//! plugin evaluates HG at dot(wo, wi) = −cos θ with the sign folded in); the χ² tests of
//! this module pin the convention: g > 0 scatters forward.

use crate::geometry::Frame;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// 1 / 4π, the isotropic density.
const INV_FOUR_PI: f32 = 0.25 / PI;

/// A phase function (Mitsuba's `isotropic` and `hg`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Phase {
    Isotropic,
    /// Henyey & Greenstein 1941: p(θ) = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}), the mean
    /// cosine g in (−1, 1) (forward scattering for g > 0).
    HenyeyGreenstein {
        g: f32,
    },
}

impl Phase {
    /// The density of scattering from propagation direction `d` into `w` (both unit), per
    /// steradian of `w`.
    #[inline]
    pub fn eval(&self, d: Vec3, w: Vec3) -> f32 {
        match *self {
            Phase::Isotropic => INV_FOUR_PI,
            Phase::HenyeyGreenstein { g } => henyey_greenstein(d.dot(w), g),
        }
    }

    /// A direction `w` drawn with density [`Phase::eval`] (exactly: its weight is 1), and that
    /// density.
    #[inline]
    pub fn sample(&self, d: Vec3, u: Vec2) -> (Vec3, f32) {
        let cos_theta = match *self {
            Phase::Isotropic => 1.0 - 2.0 * u.x,
            Phase::HenyeyGreenstein { g } => sample_hg_cos(g, u.x),
        };
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let (sin_phi, cos_phi) = (2.0 * PI * u.y).sin_cos();
        let frame = Frame::from_normal(d);
        let w = frame.to_world(Vec3::new(sin_theta * cos_phi, sin_theta * sin_phi, cos_theta));
        let w = w.normalize();
        (w, self.eval(d, w))
    }

    /// The mean cosine g (0 for isotropic scattering).
    pub fn mean_cosine(&self) -> f32 {
        match *self {
            Phase::Isotropic => 0.0,
            Phase::HenyeyGreenstein { g } => g,
        }
    }
}

/// HG's density at cos θ.
#[inline]
fn henyey_greenstein(cos_theta: f32, g: f32) -> f32 {
    let denom = 1.0 + g * g - 2.0 * g * cos_theta;
    INV_FOUR_PI * (1.0 - g * g) / (denom * denom.max(0.0).sqrt())
}

/// cos θ by inverting HG's cumulative distribution in cos θ [Henyey & Greenstein 1941; the
/// form of pbrt-v4's `SampleHenyeyGreenstein`, θ measured from the propagation direction];
/// near g = 0 the isotropic inverse (the closed form loses every digit there).
#[inline]
fn sample_hg_cos(g: f32, u: f32) -> f32 {
    if g.abs() < 1e-3 {
        return 1.0 - 2.0 * u;
    }
    let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;
    use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_test_directions, integrate_sphere};

    const PHASES: [Phase; 5] = [
        Phase::Isotropic,
        Phase::HenyeyGreenstein { g: 0.0 },
        Phase::HenyeyGreenstein { g: 0.7 },
        Phase::HenyeyGreenstein { g: -0.4 },
        Phase::HenyeyGreenstein { g: 0.95 },
    ];

    #[test]
    fn densities_integrate_to_one() {
        let d = Vec3::new(0.3, -0.5, 0.8).normalize();
        for phase in PHASES {
            let total = integrate_sphere(&|w| phase.eval(d, w) as f64, 16, 16, 1e-7);
            assert!((total - 1.0).abs() < 1e-3, "{phase:?}: ∫p = {total}");
        }
    }

    #[test]
    fn sampling_follows_the_density_chi2() {
        let d = Vec3::new(-0.2, 0.4, 0.9).normalize();
        for (i, phase) in PHASES.into_iter().enumerate() {
            let report = chi2_test_directions(
                |rng: &mut Rng| Some(phase.sample(d, rng.uniform2())),
                |w| phase.eval(d, w),
                DirectionTest {
                    n_samples: 200_000,
                    seed: i as u64,
                    ..DirectionTest::default()
                },
            );
            assert!(report.passes(CHI2_ALPHA), "{phase:?}: {report:?}");
        }
    }

    #[test]
    fn positive_g_scatters_forward_with_mean_cosine_g() {
        let d = Vec3::Z;
        for phase in PHASES {
            let mut rng = Rng::for_task(3, [0, 0, 0]);
            let n = 400_000;
            let mean = (0..n)
                .map(|_| phase.sample(d, rng.uniform2()).0.dot(d) as f64)
                .sum::<f64>()
                / n as f64;
            let g = phase.mean_cosine() as f64;
            assert!((mean - g).abs() < 0.01, "{phase:?}: mean cosine {mean}, expected {g}");
        }
    }
}
