//! The eye pass of progressive photon mapping: camera paths through delta and glossy surfaces
//! to the first surface that stores photons, where they leave a *visible point* (a "hit
//! point" in Hachisuka et al. 2008, §3.1; a "visible point" in pbrt-v3's SPPM).
//!
//! **Decision: where a visible point is made.** Photons are stored on surfaces with a diffuse
//! component ([`SurfaceKind::Diffuse`], [`crate::photon::trace`]), so the eye path stops at the
//! first such surface and keeps its throughput β there. Delta surfaces (mirrors, glass) and
//! purely glossy ones, which store no photons, are passed by sampling their BSDF, as
//! Hachisuka et al. 2008 trace "specular and glossy" reflections in the ray-tracing pass. A
//! path that exceeds `max_depth` or leaves the scene makes no visible point.
//!
//! **Decision: a delta lobe beside the diffuse one** (Mitsuba's smooth `plastic`). Photons
//! measure only the non-delta part of a surface's reflection, so stopping there would lose the
//! coating's mirror image (pbrt-v3's SPPM stops at any surface with a diffuse component and
//! does lose it). The eye path samples the model instead: when the delta lobe is chosen
//! (probability P_δ) it goes on through it, as through a mirror; otherwise the visible point
//! is made here with throughput β / (1 − P_δ). Each part is then estimated without bias in
//! expectation and one eye path still makes at most one visible point.
//!
//! **Direct light.** Emitters seen from the camera or through delta bounces are added where
//! they are hit. What else reaches the eye path straight from a light depends on
//! [`DirectLight`]: with `"nee"` every non-delta vertex (the glossy ones passed and the visible
//! point) samples one light ([`estimate_direct`], light sampling only) and photons count from
//! their second hit on; with `"photons"` the visible point sees direct light through its
//! photons too, and an emitter hit after a glossy bounce is added where it is hit (point, spot
//! and directional lights, which cannot be hit, are sampled at the glossy vertex instead).

use super::DirectLight;
use crate::bsdf::{SurfaceKind, TransportMode};
use crate::geometry::{Ray, spawn_ray};
use crate::light::LightSampling;
use crate::sampling::Rng;
use crate::scene::{Scene, SurfaceHit};
use crate::strategy::path::{BsdfSampling, Direct, all_delta_lights, estimate_direct, receiver};
use glam::Vec3;

/// A surface point of an eye path with its throughput.
#[derive(Clone, Copy, Debug)]
pub struct Shading {
    pub hit: SurfaceHit,
    /// Direction towards the previous vertex, in the shading frame.
    pub wo: Vec3,
    /// Throughput β of the eye path up to this point (f_s |cos θ| / p of every bounce before it).
    pub beta: Vec3,
}

/// What one eye path found: the emission it saw, the vertices where direct light is sampled,
/// and its visible point.
#[derive(Clone, Debug, Default)]
pub struct EyePath {
    /// β-weighted emission hit along the path (Le seen directly, through delta bounces, or
    /// after glossy ones with `"photons"`).
    pub emitted: Vec3,
    /// Vertices that sample a light each pass (empty with `"photons"`).
    pub nee: Vec<Shading>,
    /// Where the path met a photon-storing surface.
    pub visible: Option<Shading>,
}

/// Traces the eye path of `ray` (see the module doc), drawing from `rng`.
pub fn trace_eye(scene: &Scene, mut ray: Ray, max_depth: u32, direct: DirectLight, rng: &mut Rng) -> EyePath {
    let mut out = EyePath::default();
    let mut beta = Vec3::ONE;
    let mut count_emission = true;
    let mut depth = 0u32;
    loop {
        let Some(hit) = scene.intersect(&ray) else {
            if count_emission && let Some(env) = &scene.environment {
                out.emitted += beta * env.le(ray.d);
            }
            break;
        };
        if count_emission && let Some(light) = scene.light_index_of(hit.prim) {
            out.emitted += beta * scene.lights[light].le(hit.ng, -ray.d);
        }
        let bsdf = scene.bsdf(&hit);
        let wo = hit.frame.to_local(-ray.d);
        let here = Shading { hit, wo, beta };
        let kind = bsdf.kind();
        if kind != SurfaceKind::Specular && direct == DirectLight::Nee {
            out.nee.push(here);
        }
        // With photons for direct light, emitters behind a glossy bounce are found by hitting
        // them; point, spot and directional lights cannot be hit, so they are sampled here.
        if kind == SurfaceKind::Glossy && direct == DirectLight::Photons && !scene.delta_lights.is_empty() {
            out.emitted += beta * all_delta_lights(scene, &here.hit, &bsdf, wo, &mut ());
        }
        // A surface with a delta lobe beside its diffuse one (smooth plastic): the visible
        // point takes the diffuse part, the delta lobe the rest, one of the two chosen by
        // sampling the model (module doc).
        let p_delta = (kind == SurfaceKind::Diffuse).then(|| bsdf.delta_probability(wo));
        if p_delta == Some(0.0) {
            out.visible = Some(here);
            break;
        }
        let (u, u_lobe) = (rng.uniform2(), rng.uniform());
        let sample = bsdf.sample(wo, u, u_lobe, TransportMode::Radiance);
        if let Some(p_delta) = p_delta
            && sample.is_some_and(|s| !s.delta)
        {
            out.visible = Some(Shading {
                beta: beta / (1.0 - p_delta),
                ..here
            });
            break;
        }
        if depth >= max_depth {
            break;
        }
        let Some(s) = sample else {
            break;
        };
        let wi = hit.frame.to_world(s.wi);
        if wi.dot(hit.ng) * s.wi.z <= 0.0 || s.pdf_w <= 0.0 {
            break;
        }
        beta *= s.f * (s.wi.z.abs() / s.pdf_w);
        if beta == Vec3::ZERO || !beta.is_finite() {
            break;
        }
        count_emission = s.delta || direct == DirectLight::Photons;
        depth += 1;
        ray = spawn_ray(hit.p, hit.ng, wi);
    }
    out
}

/// One light-sampling estimate of the direct light reaching the eye through `path`'s
/// light-sampling vertices (zero without any), drawing from `rng`.
pub fn sample_direct(scene: &Scene, path: &EyePath, rng: &mut Rng) -> Vec3 {
    let lights = LightSampling::default();
    let mut l = Vec3::ZERO;
    for v in &path.nee {
        let bsdf = scene.bsdf(&v.hit);
        let mut weights = None;
        let context = lights.at(scene, v.hit.p, || receiver(&v.hit, &bsdf, v.wo), &mut weights);
        l += v.beta
            * estimate_direct(
                scene,
                &v.hit,
                &bsdf,
                v.wo,
                rng,
                Direct::Nee,
                (&context, &weights),
                (&BsdfSampling::Importance, &()),
                &mut (),
            );
    }
    l
}
