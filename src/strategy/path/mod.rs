//! `kind = "path"`: unidirectional path tracing with BSDF importance sampling, next-event
//! estimation and multiple importance sampling (power heuristic) [Veach 1997, ch. 9], with
//! Russian roulette. The baseline every paper in this harness compares against.
//!
//! Parameters: [`PathParams`] (all optional; `bench list path` prints them with their
//! defaults and ranges).
//!
//! **Decision: defaults `"power"` and `"area"`.** At equal samples neither option was worse on
//! any shipped scene (docs/path.md), but both cost time per sample — local selection +20 % on
//! `cornell-box`, where it gains nothing; cone sampling +28 % on `lantern`, since it traces a
//! shadow ray for every sample where area sampling skips the far side — and local selection
//! ignores occlusion, so it is not never-worse. The old defaults also keep every committed
//! result and the regression baseline bit-identical; experiments opt in.

pub mod media;

use super::{Declared, Strategy, render_pixels};
use crate::bsdf::{Bsdf, BsdfSample, TransportMode};
use crate::error::Result;
use crate::film::Film;
use crate::geometry::{Ray, spawn_ray, spawn_shadow_ray_along};
use crate::light::delta::DeltaIncidence;
use crate::light::{LightSampling, LightSelection, PointPdf, Receiver, SphereSampling};
use crate::params::{Params, Range};
use crate::sampling::{Rng, power_heuristic, sample_uniform_hemisphere, sample_uniform_sphere, uniform_sphere_pdf};
use crate::scene::light_selection::{Emitter, LightContext, LocalWeights};
use crate::scene::{Scene, SurfaceHit};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

crate::declare_choice! {
    /// How light from emitters is gathered at each vertex: `"mis"` combines light sampling and
    /// BSDF sampling with the power heuristic; `"nee"` uses light sampling only; `"bsdf"` only
    /// counts emitters hit by BSDF-sampled rays.
    pub enum Direct { Mis = "mis", Nee = "nee", Bsdf = "bsdf" }
}

crate::declare_choice! {
/// What Russian roulette's survival probability follows, once a path is past `rr_depth`.
///
/// `"throughput"` continues with q = min(0.95, max channel of the path throughput β), the
/// modern default (pbrt). `"albedo"` continues with q = min(0.95, max channel of the vertex's
/// own scattering weight f_s |cos θ| / p_bsdf) — roulette on the surface reflectance, the way
/// Arvo & Kirk (1990) introduced it and the way 1995-era path tracers (Jensen 1995 cites it for
/// its photons and paths) terminated paths. The two agree for cosine-sampled Lambertian paths.
/// They differ once directions are *guided*: β then carries the guiding weight s of Jensen's
/// eq. (11), which is small exactly for directions towards bright light, so throughput roulette
/// kills the paths guiding aimed best (measured on `cornell-empty`, docs/reproductions/jensen1995.md: it undoes most of
/// the variance reduction); albedo roulette does not see s.
    pub enum Roulette { Throughput = "throughput", Albedo = "albedo" }
}

crate::declare_choice! {
    /// How non-delta BSDFs choose the next direction: `"uniform"` samples them uniformly over
    /// the hemisphere of `wo` (the sphere for transmitting BSDFs) instead of by their own pdf,
    /// the way Jensen 1995 made its reference images.
    pub enum BsdfSampling { Importance = "importance", Uniform = "uniform" }
}

crate::declare_params! {
    /// Parameters of `kind = "path"`.
    pub struct PathParams {
        /// Maximum number of scattering events; 0 shows only emitters seen directly.
        /// (Mitsuba's `max_depth` counts segments: its 5 is our 4.)
        max_depth: u32 = 16, range Range::int(0, 1024);
        /// Russian roulette starts after this many scattering events.
        rr_depth: u32 = 3, range Range::int(0, 1024);
        /// What Russian roulette's survival probability follows: the path throughput or the
        /// vertex's albedo ([`Roulette`]).
        roulette: Roulette = Roulette::Throughput;
        /// How emitted light is gathered ([`Direct`]).
        direct: Direct = Direct::Mis;
        /// How non-delta BSDFs choose the next direction ([`BsdfSampling`]).
        bsdf_sampling: BsdfSampling = BsdfSampling::Importance;
        /// How next-event estimation picks a light: ∝ emitted power, or ∝ an estimate of each
        /// light's unoccluded contribution at the shading point ([`LightSelection`]).
        light_selection: LightSelection = LightSelection::Power;
        /// Sphere lights sampled uniformly by area, or uniformly in the cone they subtend at
        /// the shading point ([`SphereSampling`]).
        sphere_light_sampling: SphereSampling = SphereSampling::Area;
    }
}

impl PathParams {
    /// The light sampling options of next-event estimation.
    pub fn light_sampling(&self) -> LightSampling {
        LightSampling {
            selection: self.light_selection,
            sphere: self.sphere_light_sampling,
        }
    }
}

/// The path-tracing strategy.
pub struct Path {
    pub params: PathParams,
}

impl Path {
    pub fn new(params: PathParams) -> Self {
        Self { params }
    }
}

impl Declared for Path {
    const KIND: &'static str = "path";
    const SUMMARY: &'static str = "path tracing with BSDF importance sampling, NEE and MIS (Veach 1997)";
    type Params = PathParams;

    fn new(params: PathParams) -> Result<Self> {
        params.check("")?;
        Ok(Self::new(params))
    }
}

impl Strategy for Path {
    fn capabilities(&self) -> crate::strategy::Capabilities {
        crate::strategy::Capabilities {
            point_lights: self.params.direct != Direct::Bsdf,
            directional_lights: self.params.direct != Direct::Bsdf,
            media: true,
            ..crate::strategy::Capabilities::ALL
        }
    }

    fn kind(&self) -> &'static str {
        Self::KIND
    }

    fn params(&self) -> Vec<(String, String)> {
        self.params.columns()
    }

    fn render_pass(&self, scene: &Scene, seed: u64, samples: std::ops::Range<u32>, film: &mut Film) {
        render_pixels(scene, seed, samples, film, |ray, rng| {
            radiance(scene, &self.params, *ray, rng)
        });
    }
}

/// Receives every ray a path traces, and (for learning methods such as practical path
/// guiding) every scattering event and every contribution.
pub trait RayTally {
    fn closest(&mut self, ray: &Ray);
    fn shadow(&mut self, ray: &Ray);
    /// A direction `wi` (world) was sampled at `p` with solid-angle pdf `pdf_w` (a lobe
    /// probability when `delta`); `beta` is the path throughput after this vertex's weight,
    /// before Russian roulette.
    #[inline(always)]
    fn scattered(&mut self, p: Vec3, wi: Vec3, pdf_w: f32, beta: Vec3, delta: bool) {
        let _ = (p, wi, pdf_w, beta, delta);
    }
    /// `l` (throughput and MIS weight included) was added to the path's estimate.
    #[inline(always)]
    fn contributed(&mut self, l: Vec3) {
        let _ = l;
    }
}

impl RayTally for () {
    #[inline(always)]
    fn closest(&mut self, _: &Ray) {}
    #[inline(always)]
    fn shadow(&mut self, _: &Ray) {}
}

/// How a path picks its next direction at a vertex. Path tracing uses the BSDF (or uniform)
/// sampling of [`BsdfSampling`]; photon-guided path tracing [Jensen 1995] plugs in a pdf built
/// from nearby photons. The per-vertex state (e.g. Jensen's grid) is built once and shared by
/// the direction sample and by the MIS weight of light sampling.
pub trait DirectionSampler: Sync {
    /// State built at a vertex before anything is sampled there.
    type Vertex;
    fn vertex(&self, scene: &Scene, hit: &SurfaceHit, bsdf: &Bsdf, wo: Vec3) -> Self::Vertex;
    /// A local direction with f_s and its solid-angle pdf (or discrete probability if delta).
    fn sample(&self, v: &Self::Vertex, bsdf: &Bsdf, wo: Vec3, rng: &mut Rng) -> Option<BsdfSample>;
    /// Solid-angle pdf with which [`DirectionSampler::sample`] would produce `wi` (for MIS).
    fn pdf(&self, v: &Self::Vertex, bsdf: &Bsdf, wo: Vec3, wi: Vec3) -> f32;
}

impl DirectionSampler for BsdfSampling {
    type Vertex = ();

    #[inline]
    fn vertex(&self, _: &Scene, _: &SurfaceHit, _: &Bsdf, _: Vec3) {}

    /// BSDF importance sampling, or uniform sampling of the hemisphere of `wo` (the sphere for
    /// transmitting models); delta models always sample their own lobes.
    #[inline]
    fn sample(&self, _: &(), bsdf: &Bsdf, wo: Vec3, rng: &mut Rng) -> Option<BsdfSample> {
        let (u, u_lobe) = (rng.uniform2(), rng.uniform());
        if *self == BsdfSampling::Importance || bsdf.is_delta() {
            return bsdf.sample(wo, u, u_lobe, TransportMode::Radiance);
        }
        let wi = if bsdf.is_transmissive() {
            sample_uniform_sphere(u)
        } else {
            let w = sample_uniform_hemisphere(u);
            if wo.z < 0.0 { Vec3::new(w.x, w.y, -w.z) } else { w }
        };
        let pdf_w = uniform_pdf(bsdf, wo, wi);
        let f = bsdf.eval(wo, wi, TransportMode::Radiance);
        (pdf_w > 0.0).then_some(BsdfSample {
            wi,
            f,
            pdf_w,
            delta: false,
        })
    }

    #[inline]
    fn pdf(&self, _: &(), bsdf: &Bsdf, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            BsdfSampling::Importance => bsdf.pdf(wo, wi),
            BsdfSampling::Uniform => uniform_pdf(bsdf, wo, wi),
        }
    }
}

/// Solid-angle pdf of the uniform sampling mode.
fn uniform_pdf(bsdf: &Bsdf, wo: Vec3, wi: Vec3) -> f32 {
    if bsdf.is_transmissive() {
        uniform_sphere_pdf()
    } else if wo.z * wi.z > 0.0 {
        0.5 * FRAC_1_PI
    } else {
        0.0
    }
}

/// The receiver of next-event estimation at `hit` for a BSDF seen from local `wo`: the shading
/// normal turned to `wo`'s side, two-sided when the BSDF transmits.
#[inline]
pub fn receiver(hit: &SurfaceHit, bsdf: &Bsdf, wo: Vec3) -> Receiver {
    Receiver {
        p: hit.p,
        n: if wo.z < 0.0 { -hit.frame.n } else { hit.frame.n },
        two_sided: bsdf.is_transmissive(),
    }
}

/// Light sampling at `hit` [Veach 1997, eq. (9.12) with the power heuristic]: picks a light
/// with `lights` (∝ power or ∝ its local contribution estimate), a point on it (uniformly by
/// area, or in the cone a sphere subtends), and returns the MIS-weighted contribution
/// f_s |cos θi| Le w_light / p_light,ω. Always draws one number for the light and two for the
/// point, whatever it returns.
#[allow(clippy::too_many_arguments)]
pub(crate) fn estimate_direct<S: DirectionSampler>(
    scene: &Scene,
    hit: &SurfaceHit,
    bsdf: &Bsdf,
    wo: Vec3,
    rng: &mut Rng,
    direct: Direct,
    (lights, weights): (&LightContext, &Option<LocalWeights>),
    (sampler, vertex): (&S, &S::Vertex),
    tally: &mut impl RayTally,
) -> Vec3 {
    let (u_light, u_point) = (rng.uniform(), rng.uniform2());
    let (light_index, pmf) = match lights.choose(scene, weights, u_light) {
        None => return Vec3::ZERO,
        Some((Emitter::Environment, pmf)) => {
            return environment_direct(scene, hit, bsdf, wo, u_point, pmf, direct, (sampler, vertex), tally);
        }
        Some((Emitter::Delta(i), pmf)) => return delta_direct(scene, hit, bsdf, wo, i, pmf, tally),
        Some((Emitter::Area(i), pmf)) => (i, pmf),
    };
    let light = &scene.lights[light_index];
    let lp = lights.sample_point(light, &scene.primitives[light.prim as usize], u_point);
    let to_light = lp.p - hit.p;
    let dist2 = to_light.length_squared();
    if dist2 == 0.0 {
        return Vec3::ZERO;
    }
    let wi = to_light / dist2.sqrt();
    let le = light.le(lp.n, -wi);
    let cos_light = lp.n.dot(wi).abs();
    if le == Vec3::ZERO || cos_light == 0.0 {
        return Vec3::ZERO;
    }
    let wi_local = hit.frame.to_local(wi);
    let f = bsdf.eval(wo, wi_local, TransportMode::Radiance);
    if f == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let shadow = spawn_shadow_ray_along(hit.p, hit.ng, lp.p, lp.n, wi);
    tally.shadow(&shadow);
    if !scene.unoccluded(&shadow) {
        return Vec3::ZERO;
    }
    // p_ω = pmf · p_A · r² / |cos θ'| [Veach 1997, eq. (8.10)] for area sampling.
    let pdf_light_w = match lp.pdf {
        PointPdf::Area(pdf_a) => pmf * pdf_a * dist2 / cos_light,
        PointPdf::SolidAngle(pdf_w) => pmf * pdf_w,
    };
    let weight = match direct {
        Direct::Mis => power_heuristic(pdf_light_w, sampler.pdf(vertex, bsdf, wo, wi_local)),
        _ => 1.0,
    };
    f * le * (wi_local.z.abs() * weight / pdf_light_w)
}

/// f_s toward the light-sampled world direction `wi` at `hit`, and `wi` in the shading frame;
/// `None` when the BSDF gives nothing there or when the geometric normal disagrees with the
/// shading frame about `wi`'s side (as for BSDF-sampled directions: such a direction leaks
/// light).
#[inline]
fn light_sample_f(hit: &SurfaceHit, bsdf: &Bsdf, wo: Vec3, wi: Vec3) -> Option<(Vec3, Vec3)> {
    let wi_local = hit.frame.to_local(wi);
    if wi.dot(hit.ng) * wi_local.z <= 0.0 {
        return None;
    }
    let f = bsdf.eval(wo, wi_local, TransportMode::Radiance);
    (f != Vec3::ZERO).then_some((f, wi_local))
}

/// The shadow ray from surface point `p` (geometric normal `ng`) toward a delta light: up to
/// just short of a point, spot or projector (a light on a surface is not hidden by it), to infinity for
/// directional light.
#[inline]
pub(crate) fn delta_shadow_ray(p: Vec3, ng: Vec3, s: &DeltaIncidence) -> Ray {
    let mut ray = spawn_ray(p, ng, s.wi);
    ray.t_max = s.dist * (1.0 - 1e-5);
    ray
}

/// Next-event estimation toward delta light `i`, picked with probability `pmf`: the one
/// direction it arrives from and a shadow ray, f_s |cos θi| Li / pmf with no MIS weight (no
/// BSDF sample can hit a delta light, so light sampling is the only technique).
fn delta_direct(
    scene: &Scene,
    hit: &SurfaceHit,
    bsdf: &Bsdf,
    wo: Vec3,
    i: usize,
    pmf: f32,
    tally: &mut impl RayTally,
) -> Vec3 {
    let Some(s) = scene.delta_lights[i].illuminate(hit.p) else {
        return Vec3::ZERO;
    };
    let Some((f, wi_local)) = light_sample_f(hit, bsdf, wo, s.wi) else {
        return Vec3::ZERO;
    };
    let shadow = delta_shadow_ray(hit.p, hit.ng, &s);
    tally.shadow(&shadow);
    if !scene.unoccluded(&shadow) {
        return Vec3::ZERO;
    }
    f * s.li * (wi_local.z.abs() / pmf)
}

/// The light every delta light sends to `hit` toward `wo` (each taken with probability 1):
/// for estimators that find the other emitters by hitting them, as a gather ray through a
/// glossy vertex does, since no BSDF sample can hit a delta light.
pub(crate) fn all_delta_lights(
    scene: &Scene,
    hit: &SurfaceHit,
    bsdf: &Bsdf,
    wo: Vec3,
    tally: &mut impl RayTally,
) -> Vec3 {
    let mut l = Vec3::ZERO;
    for i in 0..scene.delta_lights.len() {
        l += delta_direct(scene, hit, bsdf, wo, i, 1.0, tally);
    }
    l
}

/// Next-event estimation toward the environment, picked with probability `pmf`: a direction
/// from its importance sampling, a shadow ray to infinity, MIS against the BSDF's density as
/// for area lights.
#[allow(clippy::too_many_arguments)]
fn environment_direct<S: DirectionSampler>(
    scene: &Scene,
    hit: &SurfaceHit,
    bsdf: &Bsdf,
    wo: Vec3,
    u: Vec2,
    pmf: f32,
    direct: Direct,
    (sampler, vertex): (&S, &S::Vertex),
    tally: &mut impl RayTally,
) -> Vec3 {
    let Some(env) = &scene.environment else {
        return Vec3::ZERO;
    };
    let Some(s) = env.sample(u) else {
        return Vec3::ZERO;
    };
    if s.le == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let Some((f, wi_local)) = light_sample_f(hit, bsdf, wo, s.wi) else {
        return Vec3::ZERO;
    };
    let shadow = spawn_ray(hit.p, hit.ng, s.wi);
    tally.shadow(&shadow);
    if !scene.unoccluded(&shadow) {
        return Vec3::ZERO;
    }
    let pdf_light_w = pmf * s.pdf_w;
    let weight = match direct {
        Direct::Mis => power_heuristic(pdf_light_w, sampler.pdf(vertex, bsdf, wo, wi_local)),
        _ => 1.0,
    };
    f * s.le * (wi_local.z.abs() * weight / pdf_light_w)
}

/// Radiance arriving along `ray` (one path sample).
#[inline]
pub fn radiance(scene: &Scene, params: &PathParams, ray: Ray, rng: &mut Rng) -> Vec3 {
    radiance_traced(scene, params, ray, rng, &mut ())
}

/// [`radiance`], reporting every ray it traces to `tally` (for `bench perf`; `()` ignores them
/// and compiles away).
pub fn radiance_traced(scene: &Scene, params: &PathParams, ray: Ray, rng: &mut Rng, tally: &mut impl RayTally) -> Vec3 {
    let walk = Walk {
        max_depth: params.max_depth,
        rr_depth: params.rr_depth,
        roulette: params.roulette,
        direct: params.direct,
        lights: params.light_sampling(),
    };
    if !scene.media.is_empty() {
        // Scenes with participating media take the volumetric walk (its rays are not tallied).
        return media::trace(scene, &walk, params.bsdf_sampling, ray, rng);
    }
    trace(scene, &walk, &params.bsdf_sampling, ray, rng, tally)
}

/// The vertex's scattering weight f_s |cos θi| / p_bsdf(ωi) as the BSDF's own sampling would
/// give it for the chosen direction, whatever pdf chose it: for a Lambertian surface its
/// reflectance ρ. [`Roulette::Albedo`] survives with this.
fn scattering_albedo(bsdf: &Bsdf, wo: Vec3, s: &BsdfSample) -> Vec3 {
    let p_bsdf = if s.delta { s.pdf_w } else { bsdf.pdf(wo, s.wi) };
    if p_bsdf > 0.0 {
        s.f * (s.wi.z.abs() / p_bsdf)
    } else {
        Vec3::ONE
    }
}

/// The parameters of the random walk shared by every path-tracing variant.
#[derive(Clone, Copy, Debug)]
pub struct Walk {
    pub max_depth: u32,
    pub rr_depth: u32,
    pub roulette: Roulette,
    pub direct: Direct,
    pub lights: LightSampling,
}

/// One path sample: radiance arriving along `ray`, choosing directions with `sampler`.
pub fn trace<S: DirectionSampler>(
    scene: &Scene,
    params: &Walk,
    sampler: &S,
    mut ray: Ray,
    rng: &mut Rng,
    tally: &mut impl RayTally,
) -> Vec3 {
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    // Solid-angle pdf of the BSDF sample that produced `ray`, and whether it was a delta lobe
    // (or the camera), which decide how emission found by this ray is weighted.
    let mut prev_pdf_w = 0.0f32;
    let mut prev_specular = true;
    // The light selection of the vertex that produced `ray` (where it did light sampling): the
    // light pdf of the MIS weight must be the one light sampling had there.
    let mut prev_lights: Option<LightContext> = None;
    let mut weights = None;
    let nee = params.direct != Direct::Bsdf;
    let mut depth = 0u32;
    loop {
        tally.closest(&ray);
        let Some(hit) = scene.intersect(&ray) else {
            // The ray leaves the scene: the environment's light, weighted as an area light's.
            if let Some(env) = &scene.environment {
                let le = env.le(ray.d);
                let weight = if prev_specular || params.direct == Direct::Bsdf {
                    1.0
                } else if params.direct == Direct::Nee {
                    0.0
                } else {
                    let pdf_light_w = prev_lights.as_ref().map_or(0.0, |c| c.pdf_environment_w(scene, ray.d));
                    power_heuristic(prev_pdf_w, pdf_light_w)
                };
                l += beta * le * weight;
                tally.contributed(beta * le * weight);
            }
            break;
        };

        // Emission seen along the ray.
        if let Some(light_index) = scene.light_index_of(hit.prim) {
            let light = &scene.lights[light_index];
            let le = light.le(hit.ng, -ray.d);
            if le != Vec3::ZERO {
                let weight = if prev_specular || params.direct == Direct::Bsdf {
                    1.0
                } else if params.direct == Direct::Nee {
                    0.0
                } else {
                    let cos_light = hit.ng.dot(ray.d).abs();
                    let pdf_light_w = prev_lights
                        .as_ref()
                        .map_or(0.0, |c| c.pdf_w(scene, light_index, hit.t, cos_light));
                    power_heuristic(prev_pdf_w, pdf_light_w)
                };
                l += beta * le * weight;
                tally.contributed(beta * le * weight);
            }
        }
        if depth >= params.max_depth {
            break;
        }

        let bsdf = scene.bsdf(&hit);
        let wo = hit.frame.to_local(-ray.d);
        let vertex = sampler.vertex(scene, &hit, &bsdf, wo);
        let lights = (nee && !bsdf.is_delta()).then(|| {
            params
                .lights
                .at(scene, hit.p, || receiver(&hit, &bsdf, wo), &mut weights)
        });
        if let Some(lights) = &lights {
            let light_choice = (lights, &weights);
            let direct = params.direct;
            let ld = beta
                * estimate_direct(
                    scene,
                    &hit,
                    &bsdf,
                    wo,
                    rng,
                    direct,
                    light_choice,
                    (sampler, &vertex),
                    tally,
                );
            l += ld;
            tally.contributed(ld);
        }

        let Some(s) = sampler.sample(&vertex, &bsdf, wo, rng) else {
            break;
        };
        let wi = hit.frame.to_world(s.wi);
        // A shading normal may disagree with the geometric one: such directions are light
        // leaks (or blocked), never valid transport.
        if wi.dot(hit.ng) * s.wi.z <= 0.0 {
            break;
        }
        beta *= s.f * (s.wi.z.abs() / s.pdf_w);
        tally.scattered(hit.p, wi, s.pdf_w, beta, s.delta);
        prev_pdf_w = s.pdf_w;
        prev_specular = s.delta;
        prev_lights = lights;
        depth += 1;

        if depth > params.rr_depth {
            let q = match params.roulette {
                Roulette::Throughput => beta.max_element(),
                Roulette::Albedo => scattering_albedo(&bsdf, wo, &s).max_element(),
            }
            .min(0.95);
            if rng.uniform() >= q {
                break;
            }
            beta /= q;
        }
        if beta == Vec3::ZERO {
            break;
        }
        ray = spawn_ray(hit.p, hit.ng, wi);
    }
    l
}
