//! The volumetric walk of `light`: light tracing in scenes with participating media
//! ([`crate::medium`]), taken whenever a scene has media (scenes of surfaces only keep the
//! surface walk of [`super`], bit for bit).
//!
//! A light sub-path x₀ x₁ … is drawn as in the surface walk — x₀ and its emitted direction by
//! the densities of [`crate::path_space::pdf_light_side`] — but each segment first samples a
//! free flight in the medium it travels in ([`crate::medium::Medium::sample_flight`]): a
//! collision before the next surface is a vertex in the medium
//! ([`crate::path_space::VertexKind::Medium`]), whose next direction is drawn from the phase
//! function, otherwise the segment reaches the surface. Surfaces that let a ray pass (`null`
//! boundaries, mask holes) are passed, changing the medium, and are not vertices. Every vertex,
//! in a medium or on a non-specular surface, is joined to the eye and splatted as in the surface
//! walk, the value multiplied by the transmittance of the joining segment through every medium
//! and boundary it crosses ([`crate::scene::Scene::transmittance`]).
//!
//! **Estimator.** The geometric ratio A_i of the surface walk (Le G Π f_s G over the area
//! densities, a medium vertex contributing its phase function as f_s and no cosine) times the
//! flights' weights: T σ_s / (σ_t T) of the hero channel at each collision and T / T at each
//! passage ([`crate::medium::Flight`]), with the spectral estimate of [`crate::medium`] (one hero
//! channel per light path, divided by the mean over channels of the flights' density ratios).
//! `max_depth` counts scattering events in media and at surfaces alike, as in `path`.
//!
//! **Where a light path starts** (the camera's medium is known; a light's is not):
//! an area light emits into the medium its surface bounds on the side it emits to, or, when the
//! surface bounds none, the medium of the point ([`crate::scene::Scene::medium_at`]); a point,
//! spot or projector light into the medium of its position. Light from infinitely far away
//! (environment, directional) starts at the disc outside the scene's bounding sphere in the
//! medium found there: a homogeneous medium there fills all space out to infinity, whose
//! transmittance e^{−σ_t·∞} is 0 in every channel with σ_t > 0 — as `path`'s rays and shadow
//! rays that leave the scene inside such a medium never reach the environment.

use super::{LightTracing, Splat, next_ratio, survival};
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, spawn_ray, spawn_shadow_ray};
use crate::light::parallel_ray_origin;
use crate::medium::{Flight, spectral_estimate};
use crate::path_space::walk::{sample_light_vertex, scatter};
use crate::path_space::{Vertex, VertexKind};
use crate::sampling::{Rng, sample_cosine_hemisphere};
use crate::scene::Scene;
use glam::Vec3;

/// A light path's spectral bookkeeping: the hero channel that draws every free flight, the
/// product of the flights' weights and of their density ratios p_c / p_h.
struct Spectral {
    hero: usize,
    flights: Vec3,
    ratio: Vec3,
}

impl Spectral {
    /// The estimate of a throughput `a` (the geometric ratio A_i) carried by these flights.
    #[inline]
    fn estimate(&self, a: Vec3) -> Vec3 {
        spectral_estimate(a * self.flights, self.ratio)
    }
}

/// The medium a ray leaving vertex `x` along `d` travels in, `arrived_in` being the medium the
/// walk reached `x` in (for x₀: the medium of its point): across the surface when `x` lies on
/// one that bounds media.
fn medium_leaving(scene: &Scene, x: &Vertex, arrived_in: Option<u32>, d: Vec3) -> Option<u32> {
    match x.kind {
        VertexKind::Surface | VertexKind::Light(_) => scene.medium_across_prim(x.prim, x.ng, d).unwrap_or(arrived_in),
        _ => arrived_in,
    }
}

/// The first ray of a light path from x₀ (module doc of [`super`] and of
/// [`crate::path_space`] for the densities), and the medium it starts in; `None` when the
/// light emits nothing that way.
fn emission_ray(scene: &Scene, x0: &Vertex, spectral: &mut Spectral, rng: &mut Rng) -> Option<(Ray, Option<u32>)> {
    match x0.kind {
        VertexKind::Light(l) => {
            let mut local = sample_cosine_hemisphere(rng.uniform2());
            if scene.lights[l as usize].emission.two_sided && rng.uniform() < 0.5 {
                local.z = -local.z;
            }
            let d = x0.frame.to_world(local);
            let medium = medium_leaving(scene, x0, scene.medium_at(x0.p), d);
            Some((spawn_ray(x0.p, x0.ng, d), medium))
        }
        VertexKind::DeltaLight(j) => {
            let e = scene.delta_lights[j as usize].emit(rng.uniform2(), scene.bounding_sphere())?;
            Some((Ray::new(x0.p, e.dir), scene.medium_at(x0.p)))
        }
        VertexKind::Environment | VertexKind::Directional(_) => {
            let origin = parallel_ray_origin(-x0.ng, scene.bounding_sphere(), rng.uniform2());
            let medium = scene.medium_at(origin);
            if let Some(m) = medium {
                let m = &scene.media[m as usize];
                if m.density.is_none() {
                    // The infinite stretch of a homogeneous medium before the disc.
                    spectral.flights *= Vec3::select(m.sigma_t.cmpgt(Vec3::ZERO), Vec3::ZERO, Vec3::ONE);
                    if spectral.flights == Vec3::ZERO {
                        return None;
                    }
                }
            }
            Some((Ray::new(origin, x0.ng), medium))
        }
        VertexKind::Surface | VertexKind::Medium(_) | VertexKind::Eye => None,
    }
}

impl LightTracing {
    /// [`LightTracing::connect`] through media: joins the light sub-path `sub` (throughput
    /// ratio `a` for ≥ 2 vertices) to the eye, with the transmittance of the joining segment,
    /// followed from the eye, which lies in the camera's medium, so that the media it crosses
    /// are known whatever the light path guessed about where it started.
    fn connect_through_media(
        &self,
        scene: &Scene,
        (sub, a): (&[Vertex], Vec3),
        spectral: &Spectral,
        rng: &mut Rng,
        out: &mut Vec<Splat>,
    ) {
        self.join(scene, (sub, spectral.estimate(a)), rng, out, |x, eye, rng| {
            let ray = if x.is_at_infinity() {
                Ray::new(eye.p, -x.ng)
            } else {
                let (ray, dist) = spawn_shadow_ray(eye.p, eye.ng, x.p, x.ng);
                if !(dist > 0.0 && ray.d.is_finite()) {
                    return Vec3::ZERO;
                }
                ray
            };
            scene.transmittance(scene.camera_medium, &ray, rng)
        });
    }

    /// Traces one light path through the scene's media and pushes its splats (module doc).
    pub(super) fn trace_through_media(&self, scene: &Scene, rng: &mut Rng, out: &mut Vec<Splat>) {
        let hero = ((rng.uniform() * 3.0) as usize).min(2);
        let mut spectral = Spectral {
            hero,
            flights: Vec3::ONE,
            ratio: Vec3::ONE,
        };
        let max_depth = self.params.max_depth as usize;
        let mut sub = Vec::with_capacity(max_depth + 1);
        let Some(x0) = sample_light_vertex(scene, rng) else {
            return;
        };
        sub.push(x0);
        self.connect_through_media(scene, (&sub, Vec3::ZERO), &spectral, rng, out);
        let Some((mut ray, mut medium)) = emission_ray(scene, &x0, &mut spectral, rng) else {
            return;
        };
        let mut a = Vec3::ZERO;
        let mut a1_lum = 0.0;
        for i in 1..=max_depth {
            // The next vertex: a collision in the medium, or the first surface that does not let
            // the ray pass.
            let next = loop {
                let hit = scene.intersect_any(&ray);
                if let Some(m) = medium {
                    let t_hit = hit.as_ref().map_or(f32::INFINITY, |h| h.t);
                    match scene.media[m as usize].sample_flight(ray.o, ray.d, t_hit, spectral.hero, rng) {
                        Flight::Pass { weight, ratio } => {
                            spectral.flights *= weight;
                            spectral.ratio *= ratio;
                        }
                        Flight::Scatter { p, weight, ratio, .. } => {
                            spectral.flights *= weight;
                            spectral.ratio *= ratio;
                            break Some(Vertex::in_medium(p, m));
                        }
                    }
                }
                let Some(hit) = hit else { break None };
                if scene.passes_through(&hit, ray.d) {
                    medium = scene.medium_across(&hit, ray.d).unwrap_or(medium);
                    ray = spawn_ray(hit.p, hit.ng, ray.d);
                    continue;
                }
                break Some(Vertex::surface(scene, &hit));
            };
            let Some(next) = next else { return };
            if spectral.flights == Vec3::ZERO {
                return;
            }
            sub.push(next);
            let Some(next) = next_ratio(scene, &sub, a) else {
                return;
            };
            a = next;
            if i == 1 {
                a1_lum = crate::color::luminance(spectral.estimate(a));
            }
            self.connect_through_media(scene, (&sub, a), &spectral, rng, out);
            if i == max_depth {
                return;
            }
            if i >= self.params.rr_depth as usize {
                let Some(q) = survival(crate::color::luminance(spectral.estimate(a)), a1_lum, rng) else {
                    return;
                };
                a /= q;
            }
            // The direction of travel from the new vertex.
            let x = sub[i];
            ray = match x.kind {
                VertexKind::Medium(m) => {
                    let (w, _) = scene.media[m as usize].phase.sample(ray.d, rng.uniform2());
                    Ray::new(x.p, w)
                }
                _ => {
                    let Some(step) = scatter(scene, &mut sub, TransportMode::Importance, rng) else {
                        return;
                    };
                    medium = medium_leaving(scene, &x, medium, step.wi);
                    spawn_ray(x.p, x.ng, step.wi)
                }
            };
        }
    }
}
