//! pbrt-v4's layered models `coateddiffuse` and `coatedconductor` [Pharr, Jakob & Humphreys,
//! *Physically Based Rendering*, 4th ed., §14.3 "Scattering from Layered Surfaces"]: a
//! dielectric coating (smooth or rough, relative index η) over a diffuse or conductor base, with
//! an optional homogeneous slab between them (`thickness`, single-scattering `albedo`,
//! Henyey–Greenstein `g`; σ_t = 1, so the slab's optical depth is its thickness).
//!
//! There is no closed form: pbrt evaluates the model by random walks between the two
//! interfaces, and so do we, step for step, so that a pbrt scene renders pbrt's material:
//! - `eval` estimates f(wo, wi) from `n_samples` walks entering through the coating along `wo`
//!   with next-event connections to `wi` (both interfaces' samples and densities combined by
//!   the power heuristic), plus the coating's own reflection [pbrt-v4, eq. (14.37)–(14.39)];
//! - `sample` follows one walk from `wo` until it leaves the coating; its weight
//!   f·|cos θi|/pdf is the walk's product of interface (and phase) weights;
//! - `pdf` estimates the density of `sample` by pbrt's approximation (the coating's reflection
//!   plus a transmit–reflect–transmit term, mixed with 10 % of the uniform sphere density).
//!
//! Walks end by Russian roulette after four events when the throughput falls below ¼, and after
//! `max_depth` events in any case (pbrt's defaults: 10 events, 1 sample, thickness 0.01,
//! albedo 0, g 0).
//!
//! **Estimates, not values.** `eval` and `pdf` are unbiased estimate and approximation, and they
//! are deterministic functions of their arguments: the walks draw their random numbers from a
//! stream seeded by a hash of the directions (and, for `sample`, of its uniform numbers), as
//! pbrt's do. A sample therefore reports f = weight · pdf(wo, wi) / |cos θi| with
//! `pdf_w` = pdf(wo, wi): its weight f·|cos θi|/pdf_w is the walk's, while its density is the
//! same number every other technique computes for that pair. This is pbrt's
//! `pdfIsProportional` contract. It keeps every estimator that combines techniques by MIS
//! unbiased (the weights of all techniques are built from the same deterministic numbers and
//! still sum to one for every path) and every one-sample mixture unbiased as long as the branch
//! that drew the BSDF sample keeps the sample's f ([`super::BsdfSample::of_mixture`]); it breaks
//! Metropolis proposals whose acceptance needs the true density of a sampled direction, which
//! is why `mlt` and `mps` refuse these models ([`crate::strategy::Capabilities`]).
//!
//! **Decision: a smooth coating on a smooth conductor without a scattering slab is one mirror
//! lobe.** Every walk then leaves in the mirror direction, so the model is a delta reflection
//! whose coefficient is the walk's expectation, the geometric series of reflections between
//! coating and conductor cut where pbrt's `max_depth` cuts it ([`Coated::mirror_reflectance`]).
//! We use that value rather than one walk's noisy estimate: the same mean, no noise, and a
//! delta lobe that [`super::Bsdf::delta_lobe`] can evaluate. With a scattering slab such a
//! model is refused ([`Coated::validate`]).

use super::rough_dielectric::Lobes;
use super::{Bsdf, BsdfSample, Dielectric, RoughDielectric, TransportMode, fresnel_dielectric, reflect_z, refract};
use crate::error::{Error, Result};
use crate::geometry::Frame;
use crate::sampling::{Rng, power_heuristic};
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// A coating over a base, evaluated by random walks (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Coated {
    /// The dielectric coating on top (+z is outside; its `ior` is η_coat / η_outside).
    pub coat: Coat,
    /// The base under the coating: [`Bsdf::Lambertian`] (`coateddiffuse`), or
    /// [`Bsdf::Conductor`] / [`Bsdf::RoughConductor`] (`coatedconductor`, its η and k relative
    /// to the coating).
    pub base: Bsdf,
    /// Optical depth of the slab between coating and base (σ_t = 1), ≥ 0.
    pub thickness: f32,
    /// Single-scattering albedo of the slab per channel, in [0, 1]; zero for a clear slab that
    /// only absorbs.
    pub albedo: Vec3,
    /// Henyey–Greenstein asymmetry of the slab's phase function, in (−1, 1).
    pub g: f32,
    /// Largest number of scattering events of a walk, ≥ 1.
    pub max_depth: u32,
    /// Walks per evaluation of `eval` and `pdf`, ≥ 1.
    pub n_samples: u32,
    /// Weight `eval`'s connections as pbrt-v4 does ([`Coated::connection_density`]); false (the
    /// default) for the unbiased weights.
    pub pbrt_weights: bool,
}

/// The dielectric coating of a [`Coated`] model.
#[derive(Clone, Debug, PartialEq)]
pub enum Coat {
    Smooth(Dielectric),
    Rough(RoughDielectric),
}

/// One interface of the layered model: the coating (top) or the base (bottom).
#[derive(Clone, Copy)]
enum Interface<'a> {
    Top(&'a Coat),
    Bottom(&'a Bsdf),
}

/// A direction an interface scattered into, with its value and density (as pbrt's
/// `BSDFSample`, restricted to the lobes asked for).
#[derive(Clone, Copy)]
struct Scatter {
    wi: Vec3,
    f: Vec3,
    pdf: f32,
    specular: bool,
}

impl Scatter {
    /// f |cos θi| / pdf.
    #[inline]
    fn weight(&self) -> Vec3 {
        self.f * self.wi.z.abs() / self.pdf
    }
}

impl Interface<'_> {
    #[inline]
    fn is_specular(self) -> bool {
        match self {
            Interface::Top(Coat::Smooth(_)) => true,
            Interface::Top(Coat::Rough(_)) => false,
            Interface::Bottom(b) => b.is_delta(),
        }
    }

    #[inline]
    fn f(self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        match self {
            Interface::Top(Coat::Smooth(_)) => Vec3::ZERO,
            Interface::Top(Coat::Rough(d)) => d.eval(wo, wi, mode),
            Interface::Bottom(b) => b.eval(wo, wi, mode),
        }
    }

    #[inline]
    fn pdf(self, wo: Vec3, wi: Vec3, lobes: Lobes) -> f32 {
        match self {
            Interface::Top(Coat::Smooth(_)) => 0.0,
            Interface::Top(Coat::Rough(d)) => d.pdf_lobes(wo, wi, lobes),
            Interface::Bottom(_) if lobes == Lobes::Transmission => 0.0,
            Interface::Bottom(b) => b.pdf(wo, wi),
        }
    }

    /// Samples the interface from `wo` within `lobes`; `None` when nothing carries light (pbrt's
    /// `!bs || !bs->f || bs->pdf == 0 || bs->wi.z == 0`).
    fn sample(self, wo: Vec3, uc: f32, u: Vec2, mode: TransportMode, lobes: Lobes) -> Option<Scatter> {
        let s = match self {
            Interface::Top(Coat::Smooth(d)) => smooth_sample(d.ior, wo, uc, mode, lobes)?,
            Interface::Top(Coat::Rough(d)) => {
                let s = d.sample_lobes(wo, u, uc, mode, lobes)?;
                Scatter {
                    wi: s.wi,
                    f: s.f,
                    pdf: s.pdf_w,
                    specular: false,
                }
            }
            // The bases reflect only.
            Interface::Bottom(_) if lobes == Lobes::Transmission => return None,
            Interface::Bottom(b) => {
                let s = b.sample(wo, u, uc, mode)?;
                Scatter {
                    wi: s.wi,
                    f: s.f,
                    pdf: s.pdf_w,
                    specular: s.delta,
                }
            }
        };
        (s.pdf > 0.0 && s.wi.z != 0.0 && s.f.cmpgt(Vec3::ZERO).any()).then_some(s)
    }
}

/// pbrt-v4's smooth `DielectricBxDF` restricted to `lobes`: reflection f = F/|cos θi|, refraction
/// f = (1 − F)/|cos θi| (÷ η² for radiance), each drawn with its share of the allowed lobes.
fn smooth_sample(ior: f32, wo: Vec3, uc: f32, mode: TransportMode, lobes: Lobes) -> Option<Scatter> {
    let eta = if wo.z > 0.0 { ior } else { 1.0 / ior };
    let r = fresnel_dielectric(wo.z.abs(), eta);
    let reflect = lobes.choose_reflection(r, uc)?;
    let pdf = lobes.share(r, reflect)?;
    if reflect {
        let wi = reflect_z(wo);
        return Some(Scatter {
            wi,
            f: Vec3::splat(r / wi.z.abs()),
            pdf,
            specular: true,
        });
    }
    let wi = refract(wo, eta)?;
    let scale = match mode {
        TransportMode::Radiance => 1.0 / (eta * eta),
        TransportMode::Importance => 1.0,
    };
    Some(Scatter {
        wi,
        f: Vec3::splat((1.0 - r) * scale / wi.z.abs()),
        pdf,
        specular: true,
    })
}

/// Transmittance of the slab along `w` over a depth `dz`: e^(−|dz / cos θ|) (σ_t = 1).
#[inline]
fn tr(dz: f32, w: Vec3) -> f32 {
    if dz.abs() <= f32::MIN_POSITIVE {
        1.0
    } else {
        (-(dz / w.z).abs()).exp()
    }
}

/// The Henyey–Greenstein phase function for cos θ between two directions pointing away from the
/// scattering point (pbrt's convention: forward scattering has cos θ = −1 for g > 0).
#[inline]
pub(super) fn henyey_greenstein(cos_theta: f32, g: f32) -> f32 {
    let denom = 1.0 + g * g + 2.0 * g * cos_theta;
    (1.0 - g * g) / (4.0 * PI * denom * denom.max(0.0).sqrt())
}

/// Samples the Henyey–Greenstein phase function around `wo` exactly (so p/pdf = 1): cos θ by
/// inverting its CDF [pbrt-v4, eq. (11.17)].
pub(super) fn sample_henyey_greenstein(wo: Vec3, g: f32, u: Vec2) -> (Vec3, f32) {
    let cos_theta = if g.abs() < 1e-3 {
        1.0 - 2.0 * u.x
    } else {
        -(1.0 + g * g - ((1.0 - g * g) / (1.0 + g - 2.0 * g * u.x)).powi(2)) / (2.0 * g)
    }
    .clamp(-1.0, 1.0);
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let (s, c) = (TAU * u.y).sin_cos();
    let wi = Frame::from_normal(wo).to_world(Vec3::new(sin_theta * c, sin_theta * s, cos_theta));
    (wi, henyey_greenstein(cos_theta, g))
}

/// The random stream of one estimate: seeded by the bits of its arguments, so that an estimate
/// is a deterministic function of them (and of nothing else, such as the thread that asks).
fn walk_stream(a: Vec3, b: [f32; 3]) -> Rng {
    let bits = |v: [f32; 3]| {
        v.iter()
            .fold(0u64, |h, x| crate::sampling::rng::mix64(h ^ u64::from(x.to_bits())))
    };
    Rng::for_task(bits(a.to_array()), [bits(b), 0x01a7_e5ed, 0])
}

/// One uniform number and one uniform point.
#[inline]
fn draw(rng: &mut Rng) -> (f32, Vec2) {
    (rng.uniform(), rng.uniform2())
}

impl Coated {
    fn top(&self) -> Interface<'_> {
        Interface::Top(&self.coat)
    }

    fn bottom(&self) -> Interface<'_> {
        Interface::Bottom(&self.base)
    }

    /// The slab's optical depth as the walks use it: never zero, so that the two interfaces
    /// stay apart (pbrt clamps to the smallest normal float as well; its transmittance is 1).
    fn depth(&self) -> f32 {
        self.thickness.max(f32::MIN_POSITIVE)
    }

    fn scatters(&self) -> bool {
        self.albedo.cmpgt(Vec3::ZERO).any()
    }

    /// True for a smooth coating on a smooth conductor with a clear slab: a single mirror lobe
    /// (module documentation).
    pub fn is_mirror(&self) -> bool {
        matches!(self.coat, Coat::Smooth(_)) && self.base.is_delta() && !self.scatters()
    }

    /// True when the model has a delta lobe (the smooth coating's reflection) beside smooth
    /// ones (light that crossed the coating).
    pub fn mixes_delta(&self) -> bool {
        matches!(self.coat, Coat::Smooth(_)) && !self.is_mirror()
    }

    /// The probability that `sample` from `wo` returns a delta lobe.
    pub fn delta_probability(&self, wo: Vec3) -> f32 {
        match &self.coat {
            _ if self.is_mirror() => 1.0,
            Coat::Smooth(d) => fresnel_dielectric(wo.z.abs(), d.ior),
            Coat::Rough(_) => 0.0,
        }
    }

    /// The coefficient of the mirror lobe of [`Coated::is_mirror`] models for cos θo = `mu`:
    /// R + (1 − R)² Σ_{k<K} (T² R_b)^(k+1) R^k, the expectation of pbrt's walk, with R the
    /// coating's Fresnel reflectance (the same from both sides of a refracted pair), T the slab's
    /// transmittance along the refracted direction, R_b the base's reflectance there and
    /// K = ⌊max_depth / 2⌋ the exits a walk of `max_depth` events can reach. The η² of the
    /// two crossings cancel in radiance transport.
    pub fn mirror_reflectance(&self, mu: f32) -> Vec3 {
        let Coat::Smooth(d) = &self.coat else {
            return Vec3::ZERO;
        };
        let r = fresnel_dielectric(mu, d.ior);
        let Some(inside) = refract(Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu), d.ior) else {
            return Vec3::splat(r);
        };
        let base = self.base.sample(-inside, Vec2::ZERO, 0.0, TransportMode::Radiance);
        let r_b = base.map_or(Vec3::ZERO, |s| s.f * s.wi.z.abs() / s.pdf_w);
        let round_trip = tr(self.thickness, inside).powi(2) * r_b;
        let mut term = (1.0 - r) * (1.0 - r) * round_trip;
        let mut sum = Vec3::ZERO;
        for _ in 0..self.max_depth / 2 {
            sum += term;
            term *= round_trip * r;
        }
        Vec3::splat(r) + sum
    }

    /// pbrt's estimate of f(wo, wi): the coating's reflection plus `n_samples` walks.
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        if self.is_mirror() || wo.z == 0.0 {
            return Vec3::ZERO;
        }
        self.eval_with(wo, wi, mode, &mut walk_stream(wo, wi.to_array()))
    }

    /// [`Coated::eval`] with the walks' random numbers from `rng`.
    pub(super) fn eval_with(&self, wo: Vec3, wi: Vec3, mode: TransportMode, rng: &mut Rng) -> Vec3 {
        // Two-sided: seen from below, the same layers mirrored.
        let (wo, wi) = if wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) };
        let same_side = wi.z > 0.0;
        let (top, bottom) = (self.top(), self.bottom());
        // Light leaves through the coating toward wi above, through the base toward wi below.
        let (exit, non_exit, exit_z) = if same_side {
            (top, bottom, self.depth())
        } else {
            (bottom, top, 0.0)
        };
        let n = self.n_samples.max(1) as f32;
        let mut f = if same_side { top.f(wo, wi, mode) * n } else { Vec3::ZERO };
        for _ in 0..self.n_samples.max(1) {
            let (uc, u) = draw(rng);
            let Some(wos) = top.sample(wo, uc, u, mode, Lobes::Transmission) else {
                continue;
            };
            // The walk's connections to wi go through this presampled refraction of wi.
            let (uc, u) = draw(rng);
            let Some(wis) = exit.sample(wi, uc, u, mode.adjoint(), Lobes::Transmission) else {
                continue;
            };
            f += self.walk_toward(&wos, &wis, wi, (exit, non_exit, exit_z), mode, rng);
        }
        f / n
    }

    /// One walk of [`Coated::eval`] from inside the coating (`wos`), summing its next-event
    /// connections to `wi` (through `wis`) [pbrt-v4, `LayeredBxDF::f`].
    fn walk_toward(
        &self,
        wos: &Scatter,
        wis: &Scatter,
        wi: Vec3,
        (exit, non_exit, exit_z): (Interface<'_>, Interface<'_>, f32),
        mode: TransportMode,
        rng: &mut Rng,
    ) -> Vec3 {
        let mut f = Vec3::ZERO;
        let mut beta = wos.weight();
        let mut z = self.depth();
        let mut w = wos.wi;
        for depth in 0..self.max_depth {
            if depth > 3 && beta.max_element() < 0.25 {
                let q = (1.0 - beta.max_element()).max(0.0);
                if rng.uniform() < q {
                    break;
                }
                beta /= 1.0 - q;
            }
            if !self.scatters() {
                z = if z == self.depth() { 0.0 } else { self.depth() };
                beta *= tr(self.depth(), w);
            } else {
                let dz = -(1.0 - rng.uniform()).ln() * w.z.abs();
                let zp = if w.z > 0.0 { z + dz } else { z - dz };
                if zp == z {
                    continue;
                }
                if 0.0 < zp && zp < self.depth() {
                    // A scattering event in the slab: connect through wis, then scatter.
                    let p_wis = henyey_greenstein((-w).dot(-wis.wi), self.g);
                    let wt = if exit.is_specular() {
                        1.0
                    } else {
                        power_heuristic(wis.pdf, p_wis)
                    };
                    f += beta * self.albedo * p_wis * wt * tr(zp - exit_z, wis.wi) * wis.f / wis.pdf;
                    let (w_next, p) = sample_henyey_greenstein(-w, self.g, rng.uniform2());
                    if w_next.z == 0.0 {
                        continue;
                    }
                    beta *= self.albedo;
                    w = w_next;
                    z = zp;
                    let toward_exit = (z < exit_z && w.z > 0.0) || (z > exit_z && w.z < 0.0);
                    if toward_exit && !exit.is_specular() {
                        let f_exit = exit.f(-w, wi, mode);
                        if f_exit != Vec3::ZERO {
                            let wt = power_heuristic(p, self.connection_density(exit, w, wi));
                            f += beta * tr(zp - exit_z, w) * f_exit * wt;
                        }
                    }
                    continue;
                }
                z = zp.clamp(0.0, self.depth());
            }
            let (uc, u) = draw(rng);
            if z == exit_z {
                // Reflection back into the slab at the interface light leaves through.
                let Some(bs) = exit.sample(-w, uc, u, mode, Lobes::Reflection) else {
                    break;
                };
                beta *= bs.weight();
                w = bs.wi;
                continue;
            }
            if !non_exit.is_specular() {
                // Next event through the presampled wis.
                let wt = if exit.is_specular() {
                    1.0
                } else {
                    power_heuristic(wis.pdf, non_exit.pdf(-w, -wis.wi, Lobes::All))
                };
                f += beta * non_exit.f(-w, -wis.wi, mode) * wis.wi.z.abs() * wt * tr(self.depth(), wis.wi) * wis.f
                    / wis.pdf;
            }
            let Some(bs) = non_exit.sample(-w, uc, u, mode, Lobes::Reflection) else {
                break;
            };
            beta *= bs.weight();
            w = bs.wi;
            if !exit.is_specular() {
                // Next event by the direction just sampled.
                let f_exit = exit.f(-w, wi, mode);
                if f_exit != Vec3::ZERO {
                    let wt = if non_exit.is_specular() {
                        1.0
                    } else {
                        power_heuristic(bs.pdf, self.connection_density(exit, w, wi))
                    };
                    f += beta * tr(self.depth(), bs.wi) * f_exit * wt;
                }
            }
        }
        f
    }

    /// The density with which the presampled refraction of `wi` (`wis` in `eval`) would have
    /// drawn −`w`, the direction in which a walk travelling along `w` meets the exit interface:
    /// the competing technique's density in the power heuristic of the connection through that
    /// interface, p(wi → −w).
    ///
    /// **Finding: pbrt-v4 (`LayeredBxDF::f`) uses p(−w → wi) here**, the density of the reverse
    /// transmission, which differs from it by the refraction's Jacobian: its two techniques'
    /// weights then do not sum to one and its estimate of f is biased wherever the coating is
    /// rough — measurably not reciprocal, and not the model its own `Sample_f` draws
    /// (`coated_tests.rs`). `pbrt_weights` keeps pbrt's form for renders that must match pbrt.
    fn connection_density(&self, exit: Interface<'_>, w: Vec3, wi: Vec3) -> f32 {
        if self.pbrt_weights {
            exit.pdf(-w, wi, Lobes::Transmission)
        } else {
            exit.pdf(wi, -w, Lobes::Transmission)
        }
    }

    /// pbrt's approximation of the density of [`Coated::sample`]; zero below the surface of
    /// `wo`, where the opaque bases send nothing (pbrt keeps its uniform tenth there too).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.is_mirror() || wo.z * wi.z <= 0.0 {
            return 0.0;
        }
        self.pdf_with(wo, wi, &mut walk_stream(wi, wo.to_array()))
    }

    /// [`Coated::pdf`] with the estimate's random numbers from `rng`.
    pub(super) fn pdf_with(&self, wo: Vec3, wi: Vec3, rng: &mut Rng) -> f32 {
        let (wo, wi) = if wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) };
        let (top, bottom) = (self.top(), self.bottom());
        let n = self.n_samples.max(1);
        let mut pdf_sum = n as f32 * top.pdf(wo, wi, Lobes::Reflection);
        for _ in 0..n {
            // Transmit, reflect at the base, transmit [pbrt-v4, eqs. (14.40)–(14.41)].
            let (uc, u) = draw(rng);
            let wos = top.sample(wo, uc, u, TransportMode::Radiance, Lobes::Transmission);
            let (uc, u) = draw(rng);
            let wis = top.sample(wi, uc, u, TransportMode::Importance, Lobes::Transmission);
            let (Some(wos), Some(wis)) = (wos, wis) else {
                continue;
            };
            if top.is_specular() {
                pdf_sum += bottom.pdf(-wos.wi, -wis.wi, Lobes::All);
                continue;
            }
            let (uc, u) = draw(rng);
            let Some(rs) = bottom.sample(-wos.wi, uc, u, TransportMode::Radiance, Lobes::All) else {
                continue;
            };
            if bottom.is_specular() {
                pdf_sum += top.pdf(-rs.wi, wi, Lobes::All);
            } else {
                let r_pdf = bottom.pdf(-wos.wi, -wis.wi, Lobes::All);
                pdf_sum += power_heuristic(wis.pdf, r_pdf) * r_pdf;
                let t_pdf = top.pdf(-rs.wi, wi, Lobes::All);
                pdf_sum += power_heuristic(rs.pdf, t_pdf) * t_pdf;
            }
        }
        0.1 / (4.0 * PI) + 0.9 * pdf_sum / n as f32
    }

    /// One walk from `wo` until it leaves through the coating [pbrt-v4, `LayeredBxDF::Sample_f`],
    /// reported as the module documentation says (weight of the walk, density `pdf(wo, wi)`).
    pub fn sample(&self, wo: Vec3, u: Vec2, u_lobe: f32, mode: TransportMode) -> Option<BsdfSample> {
        if self.is_mirror() {
            return BsdfSample::mirrored(wo, self.mirror_reflectance(wo.z.abs()));
        }
        let mut rng = walk_stream(wo, [u.x, u.y, u_lobe]);
        let (weight, wi, specular) = self.walk_from(wo, u, u_lobe, mode, &mut rng)?;
        if specular {
            // The coating's own reflection: its discrete probability and value.
            let (f, pdf_w) = weight;
            return Some(BsdfSample {
                wi,
                f,
                pdf_w,
                delta: true,
            });
        }
        let (f, pdf) = weight;
        let pdf_w = self.pdf(wo, wi);
        (pdf_w > 0.0 && pdf > 0.0).then(|| BsdfSample {
            wi,
            f: f / pdf * pdf_w,
            pdf_w,
            delta: false,
        })
    }

    /// A walk's (f, pdf) products, direction out and whether every event was specular.
    fn walk_from(
        &self,
        wo: Vec3,
        u: Vec2,
        u_lobe: f32,
        mode: TransportMode,
        rng: &mut Rng,
    ) -> Option<((Vec3, f32), Vec3, bool)> {
        let flip = wo.z < 0.0;
        let wo = if flip { -wo } else { wo };
        let out = |w: Vec3| if flip { -w } else { w };
        let bs = self.top().sample(wo, u_lobe, u, mode, Lobes::All)?;
        if bs.wi.z > 0.0 {
            return Some(((bs.f, bs.pdf), out(bs.wi), bs.specular));
        }
        let mut specular_path = bs.specular;
        let mut f = bs.f * bs.wi.z.abs();
        let mut pdf = bs.pdf;
        let mut z = self.depth();
        let mut w = bs.wi;
        for depth in 0..self.max_depth {
            let rr_beta = f.max_element() / pdf;
            if depth > 3 && rr_beta < 0.25 {
                let q = (1.0 - rr_beta).max(0.0);
                if rng.uniform() < q {
                    return None;
                }
                pdf *= 1.0 - q;
            }
            if w.z == 0.0 {
                return None;
            }
            if self.scatters() {
                let dz = -(1.0 - rng.uniform()).ln() * w.z.abs();
                let zp = if w.z > 0.0 { z + dz } else { z - dz };
                if zp == z {
                    return None;
                }
                if 0.0 < zp && zp < self.depth() {
                    let (w_next, p) = sample_henyey_greenstein(-w, self.g, rng.uniform2());
                    if w_next.z == 0.0 {
                        return None;
                    }
                    f *= self.albedo * p;
                    pdf *= p;
                    specular_path = false;
                    w = w_next;
                    z = zp;
                    continue;
                }
                z = zp.clamp(0.0, self.depth());
            } else {
                z = if z == self.depth() { 0.0 } else { self.depth() };
                f *= tr(self.depth(), w);
            }
            let interface = if z == 0.0 { self.bottom() } else { self.top() };
            let (uc, u) = draw(rng);
            let bs = interface.sample(-w, uc, u, mode, Lobes::All)?;
            f *= bs.f;
            pdf *= bs.pdf;
            specular_path &= bs.specular;
            // Only the coating transmits: a refraction there leaves the layers.
            let left = w.z * bs.wi.z > 0.0;
            w = bs.wi;
            if left {
                return Some(((f, pdf), out(w), specular_path));
            }
            f *= bs.wi.z.abs();
        }
        None
    }

    /// One walk of `sample` from `wo` (radiance), as its weight f |cos θi| / pdf and direction.
    #[cfg(test)]
    pub(super) fn walk_for_tests(&self, wo: Vec3, u: Vec2, u_lobe: f32, rng: &mut Rng) -> Option<(Vec3, Vec3)> {
        let ((f, pdf), wi, _) = self.walk_from(wo, u, u_lobe, TransportMode::Radiance, rng)?;
        Some((f * wi.z.abs() / pdf, wi))
    }

    /// Parameter ranges (the message names the parameter).
    pub fn validate(&self) -> Result<()> {
        let fail = |what: String| Err(Error::new(what));
        let ior = match &self.coat {
            Coat::Smooth(d) => d.ior,
            Coat::Rough(d) => {
                d.distribution.validate()?;
                d.ior
            }
        };
        if !(ior.is_finite() && ior > 0.0) {
            return fail(format!("the coating's ior must be a positive number, got {ior}"));
        }
        if !matches!(
            self.base,
            Bsdf::Lambertian(_) | Bsdf::Conductor(_) | Bsdf::RoughConductor(_)
        ) {
            return fail("a coating's base must be diffuse or a conductor".into());
        }
        self.base.validate()?;
        if !(self.thickness.is_finite() && self.thickness >= 0.0) {
            return fail(format!("thickness must be a number ≥ 0, got {}", self.thickness));
        }
        if !(self.albedo.is_finite() && self.albedo.cmpge(Vec3::ZERO).all() && self.albedo.cmple(Vec3::ONE).all()) {
            return fail(format!("albedo must lie in [0, 1] per channel, got {}", self.albedo));
        }
        if !(self.g.is_finite() && self.g.abs() < 1.0) {
            return fail(format!("g must lie in (−1, 1), got {}", self.g));
        }
        if !(1..=100).contains(&self.max_depth) {
            return fail(format!("maxdepth must lie in [1, 100], got {}", self.max_depth));
        }
        if !(1..=64).contains(&self.n_samples) {
            return fail(format!("nsamples must lie in [1, 64], got {}", self.n_samples));
        }
        if matches!(self.coat, Coat::Smooth(_)) && self.base.is_delta() && self.scatters() {
            return fail(
                "a scattering slab (albedo > 0) between a smooth coating and a smooth conductor is not supported \
                 (its walks mix delta and smooth lobes of one origin); give the coating or the conductor a roughness"
                    .into(),
            );
        }
        Ok(())
    }
}
