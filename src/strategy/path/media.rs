//! The volumetric walk of `path`: path tracing in scenes with participating media
//! ([`crate::medium`]), used by `path` whenever a scene has media (Mitsuba 3's `volpath`
//! integrator; scenes of surfaces only keep [`super::trace`], bit for bit).
//!
//! Each segment of a path first samples a free flight in the medium it travels in
//! ([`crate::medium::Medium::sample_flight`]); a collision before the next surface is a scattering vertex
//! whose direction is drawn from the phase function, otherwise the segment reaches the surface
//! as in the surface walk. Emitters are found as in `path`: next-event estimation at every
//! non-delta vertex — surfaces, and points in media whose `sample_emitters` is set — combined
//! with the directions the vertices sample by the power heuristic [Veach 1997, ch. 9], the
//! light's throughput multiplied by the transmittance of its shadow ray (evaluated in closed
//! form through every medium it crosses). Surfaces that let a ray pass (Mitsuba's `null`
//! material, the holes of masks, culled back faces) are passed here rather than in the ray cast,
//! so that a medium boundary passed still changes the medium; passing is not a bounce and keeps
//! the MIS weights of the vertex before it (Mitsuba's null interactions).
//!
//! `max_depth` counts scattering events at surfaces and in media alike (Mitsuba's `max_depth`
//! minus one, as for `path`); Russian roulette follows [`Walk::roulette`] after `rr_depth`
//! events (the albedo variant uses σ_s / σ_t's largest channel at a medium vertex).

use super::{BsdfSampling, Direct, DirectionSampler, Roulette, Walk, receiver};
use crate::bsdf::{Bsdf, TransportMode};
use crate::geometry::{Ray, spawn_ray};
use crate::light::{PointPdf, Receiver};
use crate::medium::{Flight, spectral_estimate};
use crate::sampling::{Rng, power_heuristic};
use crate::scene::light_selection::{Emitter, LightContext, LocalWeights};
use crate::scene::{Scene, SurfaceHit};
use glam::Vec3;

/// A vertex that scatters: a surface with its BSDF, or a point in a medium with its phase
/// function. Next-event estimation asks both the same questions.
enum Scatterer<'a> {
    Surface {
        hit: &'a SurfaceHit,
        bsdf: &'a Bsdf,
        wo: Vec3,
        sampling: BsdfSampling,
    },
    Medium {
        p: Vec3,
        d: Vec3,
        phase: crate::medium::phase::Phase,
    },
}

impl Scatterer<'_> {
    fn p(&self) -> Vec3 {
        match self {
            Scatterer::Surface { hit, .. } => hit.p,
            Scatterer::Medium { p, .. } => *p,
        }
    }

    /// f_s |cos θ| (a phase function's value in a medium) toward world direction `wi`, and the
    /// density with which the vertex's own sampling draws `wi`; `None` where it gives nothing.
    fn eval(&self, wi: Vec3) -> Option<(Vec3, f32)> {
        match self {
            Scatterer::Surface {
                hit,
                bsdf,
                wo,
                sampling,
            } => {
                let wi_local = hit.frame.to_local(wi);
                // As in `path`: a direction the geometric normal puts on the other side leaks.
                if wi.dot(hit.ng) * wi_local.z <= 0.0 {
                    return None;
                }
                let f = bsdf.eval(*wo, wi_local, TransportMode::Radiance);
                (f != Vec3::ZERO).then(|| (f * wi_local.z.abs(), sampling.pdf(&(), bsdf, *wo, wi_local)))
            }
            Scatterer::Medium { d, phase, .. } => {
                let p = phase.eval(*d, wi);
                (p > 0.0).then_some((Vec3::splat(p), p))
            }
        }
    }

    /// The start of a shadow ray toward direction `wi`: off the surface, or the point itself.
    fn shadow_ray(&self, wi: Vec3) -> Ray {
        match self {
            Scatterer::Surface { hit, .. } => spawn_ray(hit.p, hit.ng, wi),
            Scatterer::Medium { p, .. } => Ray::new(*p, wi),
        }
    }

    fn receiver(&self) -> Receiver {
        match self {
            Scatterer::Surface { hit, bsdf, wo, .. } => receiver(hit, bsdf, *wo),
            // A phase function receives from every direction.
            Scatterer::Medium { p, d, .. } => Receiver {
                p: *p,
                n: *d,
                two_sided: true,
            },
        }
    }
}

/// The medium a shadow ray toward `wi` starts in: across the surface when it bounds media.
fn medium_toward(scene: &Scene, v: &Scatterer, medium: Option<u32>, wi: Vec3) -> Option<u32> {
    match v {
        Scatterer::Surface { hit, .. } => scene.medium_across(hit, wi).unwrap_or(medium),
        Scatterer::Medium { .. } => medium,
    }
}

/// Next-event estimation at `v` (in `medium`): one emitter picked by `lights`, a point or
/// direction on it, the shadow ray's transmittance, and the power heuristic against the vertex's
/// own sampling (none for delta lights). Draws one number for the light and two for the point.
fn direct(
    scene: &Scene,
    v: &Scatterer,
    medium: Option<u32>,
    lights: &LightContext,
    weights: &Option<LocalWeights>,
    mis: bool,
    rng: &mut Rng,
) -> Vec3 {
    let (u_light, u_point) = (rng.uniform(), rng.uniform2());
    let Some((emitter, pmf)) = lights.choose(scene, weights, u_light) else {
        return Vec3::ZERO;
    };
    let p = v.p();
    // (direction, radiance or intensity term, light density in solid angle (0: delta), shadow
    // ray length)
    let (wi, li, pdf_light_w, dist) = match emitter {
        Emitter::Area(i) => {
            let light = &scene.lights[i];
            let lp = lights.sample_point(light, &scene.primitives[light.prim as usize], u_point);
            let to_light = lp.p - p;
            let dist2 = to_light.length_squared();
            if dist2 == 0.0 {
                return Vec3::ZERO;
            }
            let wi = to_light / dist2.sqrt();
            let cos_light = lp.n.dot(wi).abs();
            let le = light.le(lp.n, -wi);
            if le == Vec3::ZERO || cos_light == 0.0 {
                return Vec3::ZERO;
            }
            let pdf_w = match lp.pdf {
                PointPdf::Area(pdf_a) => pmf * pdf_a * dist2 / cos_light,
                PointPdf::SolidAngle(pdf_w) => pmf * pdf_w,
            };
            (wi, le, pdf_w, dist2.sqrt())
        }
        Emitter::Delta(i) => {
            let Some(s) = scene.delta_lights[i].illuminate(p) else {
                return Vec3::ZERO;
            };
            (s.wi, s.li / pmf, 0.0, s.dist)
        }
        Emitter::Environment => {
            let Some(s) = scene.environment.as_ref().and_then(|e| e.sample(u_point)) else {
                return Vec3::ZERO;
            };
            if s.le == Vec3::ZERO {
                return Vec3::ZERO;
            }
            (s.wi, s.le, pmf * s.pdf_w, f32::INFINITY)
        }
    };
    let Some((f, pdf_vertex)) = v.eval(wi) else {
        return Vec3::ZERO;
    };
    let mut shadow = v.shadow_ray(wi);
    // Short of the light's point (a light on a surface is not hidden by that surface).
    shadow.t_max = dist * (1.0 - 1e-4);
    let tr = scene.transmittance(medium_toward(scene, v, medium, wi), &shadow, rng);
    if tr == Vec3::ZERO {
        return Vec3::ZERO;
    }
    if pdf_light_w == 0.0 {
        return f * li * tr;
    }
    let weight = if mis {
        power_heuristic(pdf_light_w, pdf_vertex)
    } else {
        1.0
    };
    f * li * tr * (weight / pdf_light_w)
}

/// One path sample in a scene with media: radiance arriving along `ray` (module doc).
pub fn trace(scene: &Scene, params: &Walk, sampling: BsdfSampling, mut ray: Ray, rng: &mut Rng) -> Vec3 {
    let (mut l, mut beta) = (Vec3::ZERO, Vec3::ONE);
    // The hero channel that draws every free flight, and Π p_c / p_h of the flights so far
    // (module doc of [`crate::medium`]): every estimate is `spectral_estimate(beta, ratio)`.
    let hero = crate::path_space::media::MediaWalk::draw_hero(rng);
    let mut ratio = Vec3::ONE;
    let mut medium = scene.camera_medium;
    // The density with which the last scattering vertex drew `ray`'s direction, whether it was
    // a delta lobe (or the camera, or a medium that samples no emitters: emission found is then
    // counted whole), and its light selection for the MIS weight of emission found.
    let (mut prev_pdf_w, mut prev_specular) = (0.0f32, true);
    let mut prev_lights: Option<LightContext> = None;
    let mut weights = None;
    // Distance from the last scattering vertex, across passed surfaces (an area light's
    // solid-angle density needs it).
    let mut travelled = 0.0f32;
    let nee = params.direct != Direct::Bsdf;
    let mut depth = 0u32;
    loop {
        let hit = scene.intersect_any(&ray);
        if let Some(m) = medium {
            let med = &scene.media[m as usize];
            let t_hit = hit.as_ref().map_or(f32::INFINITY, |h| h.t);
            match med.sample_flight(ray.o, ray.d, t_hit, hero, rng) {
                Flight::Pass { weight, ratio: r } => {
                    beta *= weight;
                    ratio *= r;
                }
                Flight::Scatter {
                    p, weight, ratio: r, ..
                } => {
                    beta *= weight;
                    ratio *= r;
                    if depth >= params.max_depth || beta == Vec3::ZERO {
                        break;
                    }
                    let v = Scatterer::Medium {
                        p,
                        d: ray.d,
                        phase: med.phase,
                    };
                    let lights =
                        (nee && med.sample_emitters).then(|| params.lights.at(scene, p, || v.receiver(), &mut weights));
                    if let Some(lights) = &lights {
                        l += spectral_estimate(beta, ratio)
                            * direct(scene, &v, medium, lights, &weights, params.direct == Direct::Mis, rng);
                    }
                    let (wi, pdf) = med.phase.sample(ray.d, rng.uniform2());
                    prev_pdf_w = pdf;
                    prev_specular = lights.is_none();
                    prev_lights = lights;
                    travelled = 0.0;
                    depth += 1;
                    let albedo = || med.albedo_at(p).max_element();
                    if !survives_roulette(params, depth, (&mut beta, ratio), albedo, rng) {
                        break;
                    }
                    ray = Ray::new(p, wi);
                    continue;
                }
            }
        }
        let Some(hit) = hit else {
            if let Some(env) = &scene.environment {
                let le = env.le(ray.d);
                let weight = emission_weight(params, prev_specular, prev_pdf_w, || {
                    prev_lights.as_ref().map_or(0.0, |c| c.pdf_environment_w(scene, ray.d))
                });
                l += spectral_estimate(beta, ratio) * le * weight;
            }
            break;
        };
        travelled += hit.t;
        if scene.passes_through(&hit, ray.d) {
            if let Some(next) = scene.medium_across(&hit, ray.d) {
                medium = next;
            }
            ray = spawn_ray(hit.p, hit.ng, ray.d);
            continue;
        }
        if let Some(light_index) = scene.light_index_of(hit.prim) {
            let le = scene.lights[light_index].le(hit.ng, -ray.d);
            if le != Vec3::ZERO {
                let weight = emission_weight(params, prev_specular, prev_pdf_w, || {
                    let cos_light = hit.ng.dot(ray.d).abs();
                    prev_lights
                        .as_ref()
                        .map_or(0.0, |c| c.pdf_w(scene, light_index, travelled, cos_light))
                });
                l += spectral_estimate(beta, ratio) * le * weight;
            }
        }
        if depth >= params.max_depth {
            break;
        }
        let bsdf = scene.bsdf(&hit);
        let wo = hit.frame.to_local(-ray.d);
        let v = Scatterer::Surface {
            hit: &hit,
            bsdf: &bsdf,
            wo,
            sampling,
        };
        let lights = (nee && !bsdf.is_delta()).then(|| params.lights.at(scene, hit.p, || v.receiver(), &mut weights));
        if let Some(lights) = &lights {
            l += spectral_estimate(beta, ratio)
                * direct(scene, &v, medium, lights, &weights, params.direct == Direct::Mis, rng);
        }
        let Some(s) = sampling.sample(&(), &bsdf, wo, rng) else {
            break;
        };
        let wi = hit.frame.to_world(s.wi);
        if wi.dot(hit.ng) * s.wi.z <= 0.0 || s.pdf_w <= 0.0 {
            break;
        }
        let vertex_weight = s.f * (s.wi.z.abs() / s.pdf_w);
        beta *= vertex_weight;
        prev_pdf_w = s.pdf_w;
        prev_specular = s.delta;
        prev_lights = lights;
        travelled = 0.0;
        if let Some(next) = scene.medium_across(&hit, wi) {
            medium = next;
        }
        depth += 1;
        if !survives_roulette(params, depth, (&mut beta, ratio), || vertex_weight.max_element(), rng) {
            break;
        }
        ray = spawn_ray(hit.p, hit.ng, wi);
    }
    l
}

/// The MIS weight of emission a sampled direction found (as in `path`): whole after a delta
/// lobe, the camera or a vertex without light sampling; none under `"nee"`; else the power
/// heuristic against the light density `pdf_light_w` of the vertex's light sampling.
#[inline]
fn emission_weight(params: &Walk, prev_specular: bool, prev_pdf_w: f32, pdf_light_w: impl FnOnce() -> f32) -> f32 {
    if prev_specular || params.direct == Direct::Bsdf {
        1.0
    } else if params.direct == Direct::Nee {
        0.0
    } else {
        power_heuristic(prev_pdf_w, pdf_light_w())
    }
}

/// Russian roulette after `rr_depth` events: survive with q = min(0.95, the path estimate's or
/// the vertex albedo's largest channel) and carry 1/q. False when the path ends.
#[inline]
fn survives_roulette(
    params: &Walk,
    depth: u32,
    (beta, ratio): (&mut Vec3, Vec3),
    albedo: impl FnOnce() -> f32,
    rng: &mut Rng,
) -> bool {
    if *beta == Vec3::ZERO {
        return false;
    }
    if depth <= params.rr_depth {
        return true;
    }
    let q = match params.roulette {
        Roulette::Throughput => spectral_estimate(*beta, ratio).max_element(),
        Roulette::Albedo => albedo(),
    }
    .min(0.95);
    if rng.uniform() >= q {
        return false;
    }
    *beta /= q;
    true
}
