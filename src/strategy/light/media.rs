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
//! Where a light path starts, and what light from infinity meets: [`crate::path_space::media::emission_ray`].

use super::{LightTracing, Splat, next_ratio, survival};
use crate::bsdf::TransportMode;
use crate::path_space::Vertex;
use crate::path_space::media::{Flights, MediaWalk, emission_ray, transmittance_between};
use crate::path_space::walk::{sample_light_vertex, scatter};
use crate::sampling::Rng;
use crate::scene::Scene;
use glam::Vec3;

impl LightTracing {
    /// [`LightTracing::connect`] through media: joins the light sub-path `sub` (throughput
    /// ratio `a` for ≥ 2 vertices) to the eye, with the transmittance of the joining segment,
    /// followed from the eye, which lies in the camera's medium, so that the media it crosses
    /// are known whatever the light path guessed about where it started.
    fn connect_through_media(
        &self,
        scene: &Scene,
        (sub, a): (&[Vertex], Vec3),
        flights: &Flights,
        rng: &mut Rng,
        out: &mut Vec<Splat>,
    ) {
        self.join(scene, (sub, flights.estimate(a)), rng, out, |x, eye, rng| {
            transmittance_between(scene, eye, scene.camera_medium, x, rng)
        });
    }

    /// Traces one light path through the scene's media and pushes its splats (module doc).
    pub(super) fn trace_through_media(&self, scene: &Scene, rng: &mut Rng, out: &mut Vec<Splat>) {
        let hero = MediaWalk::draw_hero(rng);
        let max_depth = self.params.max_depth as usize;
        let mut sub = Vec::with_capacity(max_depth + 1);
        let Some(x0) = sample_light_vertex(scene, rng) else {
            return;
        };
        sub.push(x0);
        self.connect_through_media(scene, (&sub, Vec3::ZERO), &Flights::ONE, rng, out);
        let Some((mut ray, mut walk)) = emission_ray(scene, &x0, hero, rng) else {
            return;
        };
        let mut a = Vec3::ZERO;
        let mut a1_lum = 0.0;
        for i in 1..=max_depth {
            let Some(next) = walk.next_vertex(scene, ray, false, rng) else {
                return;
            };
            sub.push(next);
            let Some(next) = next_ratio(scene, &sub, a) else {
                return;
            };
            a = next;
            if i == 1 {
                a1_lum = crate::color::luminance(walk.flights.estimate(a));
            }
            self.connect_through_media(scene, (&sub, a), &walk.flights, rng, out);
            if i == max_depth {
                return;
            }
            if i >= self.params.rr_depth as usize {
                let Some(q) = survival(crate::color::luminance(walk.flights.estimate(a)), a1_lum, rng) else {
                    return;
                };
                a /= q;
            }
            // The direction of travel from the new vertex.
            let x = sub[i];
            let d = match x.kind {
                crate::path_space::VertexKind::Medium(m) => {
                    scene.media[m as usize].phase.sample(ray.d, rng.uniform2()).0
                }
                _ => match scatter(scene, &mut sub, TransportMode::Importance, rng) {
                    Some(step) => step.wi,
                    None => return,
                },
            };
            ray = walk.leave(scene, &x, d);
        }
    }
}
