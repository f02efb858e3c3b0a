//! A rough plastic, as Mitsuba 3's `roughplastic`: a diffuse base under a rough dielectric
//! coating, the microfacet reflection of the coating plus the base's light that crossed the
//! coating twice [Weidlich & Wilkie 2007, "Arbitrarily Layered Micro-Facet Surfaces"; Mitsuba's
//! documentation of `roughplastic`].
//!
//! f_s(wo, wi) = R_s F(wo·h, η) D(h) G(wo, wi, h) / (4 cos θo cos θi)
//!             + ρ / (1 − R_i) · T(cos θo) T(cos θi) / (π η²),
//!
//! where T(μ) is the fraction of light from direction μ that the rough interface transmits
//! (its Fresnel transmittance averaged over the visible microfacets, shadowing included), R_i the
//! interface's reflectance for diffuse light from inside (∫ R(μ, 1/η) 2μ dμ), and 1/(1 − R_i)
//! sums the light bounced between base and coating. `nonlinear = true` uses ρ/(1 − ρ R_i)
//! instead, the exact sum of that geometric series, which saturates colours as in reality;
//! Mitsuba's default (false) keeps ρ linear.
//!
//! T and R_i are tabulated once per material exactly as Mitsuba does: T at 64 values of μ
//! spaced evenly in [10⁻⁶, 1] and read by linear interpolation, each by an n × n Gauss–Legendre
//! rule over the unit square mapped through the visible-normal sampler (n = 32 for η > 1, 128
//! otherwise), and R_i as twice the mean of R(μ) μ over the same 64 values.
//!
//! Sampling: the glossy lobe with probability ∝ (1 − T(cos θo)) · s and the cosine-weighted
//! diffuse lobe ∝ T(cos θo) · (1 − s), s = mean(R_s)/(mean(ρ) + mean(R_s)) (channel means), as
//! Mitsuba. The distribution is isotropic (Mitsuba refuses anisotropic rough plastic).
//!
//! Parameters: `diffuse_reflectance` ρ and `specular_reflectance` R_s in [0, 1] per channel,
//! `ior` η = η_interior/η_exterior > 0 and ≠ 1 (Mitsuba's default: polypropylene 1.49 in air),
//! the microfacet distribution, `nonlinear`.

use super::microfacet::Microfacet;
use super::{BsdfSample, fresnel_dielectric, fresnel_signed, to_upper};
use crate::sampling::sample_cosine_hemisphere;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;
use std::sync::Arc;

/// Entries of the transmittance table T(μ) (Mitsuba's `MI_ROUGH_TRANSMITTANCE_RES`).
pub const TRANSMITTANCE_RES: usize = 64;

#[derive(Clone, Debug, PartialEq)]
pub struct RoughPlastic {
    pub diffuse_reflectance: Vec3,
    pub specular_reflectance: Vec3,
    pub ior: f32,
    pub distribution: Microfacet,
    pub nonlinear: bool,
    tables: Arc<CoatingTables>,
}

/// The coating's transmittance T(μ) and internal diffuse reflectance R_i.
#[derive(Debug, PartialEq)]
struct CoatingTables {
    external_transmittance: [f32; TRANSMITTANCE_RES],
    internal_reflectance: f32,
}

impl RoughPlastic {
    /// A rough plastic; tabulates the coating (a few milliseconds).
    pub fn new(
        diffuse_reflectance: Vec3,
        specular_reflectance: Vec3,
        ior: f32,
        distribution: Microfacet,
        nonlinear: bool,
    ) -> Self {
        let distribution = Microfacet {
            alpha_v: distribution.alpha_u,
            sample_visible: true,
            ..distribution
        };
        let tables = Arc::new(CoatingTables::new(&distribution, ior));
        Self {
            diffuse_reflectance,
            specular_reflectance,
            ior,
            distribution,
            nonlinear,
            tables,
        }
    }

    /// The coating's interface reflectance for diffuse light from inside, R_i.
    pub fn internal_reflectance(&self) -> f32 {
        self.tables.internal_reflectance
    }

    /// T(μ) by linear interpolation in the table.
    #[inline]
    pub fn transmittance(&self, mu: f32) -> f32 {
        let t = &self.tables.external_transmittance;
        let x = mu.clamp(0.0, 1.0) * (TRANSMITTANCE_RES - 1) as f32;
        let i = (x as usize).min(TRANSMITTANCE_RES - 2);
        let f = x - i as f32;
        t[i] + (t[i + 1] - t[i]) * f
    }

    /// Probability of sampling the glossy lobe for cos θo = `mu`.
    #[inline]
    fn specular_probability(&self, mu: f32) -> f32 {
        let (d_mean, s_mean) = (
            self.diffuse_reflectance.element_sum() / 3.0,
            self.specular_reflectance.element_sum() / 3.0,
        );
        if d_mean + s_mean <= 0.0 {
            return 0.5;
        }
        let s = s_mean / (d_mean + s_mean);
        let t = self.transmittance(mu);
        let (p_spec, p_diff) = ((1.0 - t) * s, t * (1.0 - s));
        if p_spec + p_diff > 0.0 {
            p_spec / (p_spec + p_diff)
        } else {
            0.5
        }
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z * wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let (wo, wi) = to_upper(wo, wi);
        let specular = self.distribution.reflection(wo, wi).map_or(Vec3::ZERO, |(h, dg)| {
            self.specular_reflectance * (fresnel_dielectric(wo.dot(h).max(0.0), self.ior) * dg)
        });
        let rho = self.diffuse_reflectance;
        let r_i = self.tables.internal_reflectance;
        let bounce = if self.nonlinear {
            Vec3::ONE - rho * r_i
        } else {
            Vec3::splat(1.0 - r_i)
        };
        let diffuse =
            rho / bounce * (FRAC_1_PI / (self.ior * self.ior) * self.transmittance(wo.z) * self.transmittance(wi.z));
        specular + diffuse
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z * wi.z <= 0.0 {
            return 0.0;
        }
        let (wo, wi) = to_upper(wo, wi);
        let p_spec = self.specular_probability(wo.z);
        p_spec * self.distribution.reflection_pdf(wo, wi) + (1.0 - p_spec) * wi.z * FRAC_1_PI
    }

    pub fn sample(&self, wo: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let wo_up = wo.with_z(wo.z.abs());
        let wi_up = if u_lobe < self.specular_probability(wo_up.z) {
            self.distribution.sample_reflection(wo_up, u)?
        } else {
            sample_cosine_hemisphere(u)
        };
        BsdfSample::on_side_of(wo, wi_up, |wi| self.pdf(wo, wi), |wi| self.eval(wo, wi))
    }
}

impl CoatingTables {
    fn new(distribution: &Microfacet, eta: f32) -> Self {
        let mus: Vec<f32> = (0..TRANSMITTANCE_RES)
            .map(|i| (i as f32 / (TRANSMITTANCE_RES - 1) as f32).max(1e-6))
            .collect();
        // About a million visible-normal samples per material: the angles run in parallel (the
        // sums are per angle and added in a fixed order, so the tables do not depend on the
        // thread count).
        use rayon::prelude::*;
        let transmittance: Vec<f64> = mus
            .par_iter()
            .map(|&mu| interface_transmittance(distribution, mu, eta))
            .collect();
        let mut external_transmittance = [0.0; TRANSMITTANCE_RES];
        for (t, v) in external_transmittance.iter_mut().zip(transmittance) {
            *t = v as f32;
        }
        let reflectance: Vec<f64> = mus
            .par_iter()
            .map(|&mu| interface_reflectance(distribution, mu, 1.0 / eta) * mu as f64)
            .collect();
        let internal = reflectance.iter().sum::<f64>() / TRANSMITTANCE_RES as f64;
        Self {
            external_transmittance,
            internal_reflectance: (2.0 * internal) as f32,
        }
    }
}

/// The direction with cos θ = `mu` in the x–z plane.
fn direction(mu: f32) -> Vec3 {
    Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu)
}

/// ∫ over visible normals of a rough interface seen from cos θ = `mu` of `g(wi, m)`, by the
/// Gauss–Legendre rule Mitsuba uses (`eval_reflectance` / `eval_transmittance`).
fn visible_normal_quadrature(distribution: &Microfacet, mu: f32, eta: f32, g: impl Fn(Vec3, Vec3) -> f32) -> f64 {
    let n = if eta > 1.0 { 32 } else { 128 };
    let (nodes, weights) = gauss_legendre(n);
    let wi = direction(mu);
    let mut sum = 0.0;
    for (x, wx) in nodes.iter().zip(&weights) {
        for (y, wy) in nodes.iter().zip(&weights) {
            let u = Vec2::new((0.5 * x + 0.5) as f32, (0.5 * y + 0.5) as f32);
            if let Some((m, _)) = distribution.sample(wi, u) {
                sum += g(wi, m) as f64 * wx * wy * 0.25;
            }
        }
    }
    sum
}

/// Fraction of light arriving from cos θ = `mu` that a rough interface of relative index `eta`
/// transmits: (1 − F) G1 over the visible microfacets.
fn interface_transmittance(distribution: &Microfacet, mu: f32, eta: f32) -> f64 {
    visible_normal_quadrature(distribution, mu, eta, |wi, m| {
        let c = wi.dot(m);
        let f = fresnel_signed(c, eta);
        let eta_t = if c > 0.0 { eta } else { 1.0 / eta };
        let sin2_t = (1.0 - c * c).max(0.0) / (eta_t * eta_t);
        if sin2_t >= 1.0 {
            return 0.0;
        }
        let cos_t = (1.0 - sin2_t).sqrt();
        let wt = -wi / eta_t + (c / eta_t - cos_t.copysign(c)) * m;
        if wt.z * wi.z >= 0.0 {
            return 0.0;
        }
        distribution.smith_g1(wt, m) * (1.0 - f)
    })
}

/// Fraction of light arriving from cos θ = `mu` that a rough interface of relative index `eta`
/// reflects: F G1 over the visible microfacets.
fn interface_reflectance(distribution: &Microfacet, mu: f32, eta: f32) -> f64 {
    visible_normal_quadrature(distribution, mu, eta, |wi, m| {
        let c = wi.dot(m);
        let wr = 2.0 * c * m - wi;
        if wr.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let f = fresnel_signed(c, eta);
        distribution.smith_g1(wr, m) * f
    })
}

/// Nodes and weights of the n-point Gauss–Legendre rule on [−1, 1] (Newton's method on the
/// Legendre polynomial from the usual cosine guesses).
fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut nodes, mut weights) = (vec![0.0; n], vec![0.0; n]);
    for i in 0..n {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut derivative = 1.0;
        for _ in 0..100 {
            // P_n(x) and P_n'(x) by the three-term recurrence.
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            derivative = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let step = p1 / derivative;
            x -= step;
            if step.abs() < 1e-15 {
                break;
            }
        }
        nodes[i] = x;
        weights[i] = 2.0 / ((1.0 - x * x) * derivative * derivative);
    }
    (nodes, weights)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in [1usize, 2, 5, 32, 128] {
            let (x, w) = gauss_legendre(n);
            for degree in 0..(2 * n).min(40) {
                let quad: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(degree as i32)).sum();
                let exact = if degree % 2 == 1 {
                    0.0
                } else {
                    2.0 / (degree as f64 + 1.0)
                };
                assert!(
                    (quad - exact).abs() < 1e-12,
                    "n = {n}, degree {degree}: {quad} vs {exact}"
                );
            }
        }
    }
}
