//! Sub-paths through participating media ([`crate::medium`]), for the estimators built on path
//! space (`light`'s volumetric walk, `bdpt`'s sub-paths in scenes with media).
//!
//! A walk samples a free flight on each segment in the medium it travels in: a collision before
//! the next surface is a vertex in the medium ([`VertexKind::Medium`]), otherwise the segment
//! reaches the surface. Surfaces that let a ray pass (`null` boundaries, mask holes) are passed,
//! changing the medium, and are not vertices. The flights' weights (T σ_s / p_h at a collision,
//! T / P_h across a segment) and density ratios p_c / p_h under the walk's hero channel h are
//! kept apart from the path's geometric ratio f / p in [`Flights`], so that path-space f and
//! densities stay those of surfaces with a phase function for f_s at medium vertices, and an
//! estimate is the geometric ratio times the flights with [`crate::medium`]'s hero-channel
//! spectral estimate.

use super::{Vertex, VertexKind};
use crate::geometry::{Ray, spawn_ray, spawn_shadow_ray};
use crate::light::parallel_ray_origin;
use crate::medium::{Flight, spectral_estimate};
use crate::sampling::{Rng, sample_cosine_hemisphere};
use crate::scene::Scene;
use glam::Vec3;

/// The free flights of a (sub-)path: the product of their weights, and of their density ratios
/// p_c / p_h per channel ([`crate::medium::Flight`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Flights {
    pub weight: Vec3,
    pub ratio: Vec3,
}

impl Flights {
    /// No flight yet (or a path in vacuum).
    pub const ONE: Self = Self {
        weight: Vec3::ONE,
        ratio: Vec3::ONE,
    };

    /// The estimate of a path whose geometric ratio f / p (surfaces, phase functions, the
    /// camera) is `a` and whose flights are these: the balance heuristic over channels
    /// ([`spectral_estimate`]).
    #[inline]
    pub fn estimate(&self, a: Vec3) -> Vec3 {
        spectral_estimate(a * self.weight, self.ratio)
    }

    #[inline]
    fn take(&mut self, weight: Vec3, ratio: Vec3) {
        self.weight *= weight;
        self.ratio *= ratio;
    }
}

/// A walk through media: the hero channel that draws every free flight, the medium the walk
/// is in, and its flights so far.
#[derive(Clone, Copy, Debug)]
pub struct MediaWalk {
    pub hero: usize,
    pub medium: Option<u32>,
    pub flights: Flights,
}

impl MediaWalk {
    /// A walk starting in `medium` with hero channel `hero`.
    pub fn new(hero: usize, medium: Option<u32>) -> Self {
        Self {
            hero,
            medium,
            flights: Flights::ONE,
        }
    }

    /// The hero channel, drawn with one number uniformly among the three.
    pub fn draw_hero(rng: &mut Rng) -> usize {
        ((rng.uniform() * 3.0) as usize).min(2)
    }

    /// The next vertex along `ray`: a collision in the medium, or the first surface that does
    /// not let the ray pass (passing the others and changing medium there). Where the ray
    /// leaves the scene: the environment vertex when `to_environment` is set and the scene has
    /// one (an eye walk), else `None`; also `None` when the flights carry nothing.
    pub fn next_vertex(&mut self, scene: &Scene, mut ray: Ray, to_environment: bool, rng: &mut Rng) -> Option<Vertex> {
        let next = loop {
            let hit = scene.intersect_any(&ray);
            if let Some(m) = self.medium {
                let t_hit = hit.as_ref().map_or(f32::INFINITY, |h| h.t);
                match scene.media[m as usize].sample_flight(ray.o, ray.d, t_hit, self.hero, rng) {
                    Flight::Pass { weight, ratio } => self.flights.take(weight, ratio),
                    Flight::Scatter { p, weight, ratio, .. } => {
                        self.flights.take(weight, ratio);
                        break Some(Vertex::in_medium(p, m));
                    }
                }
            }
            let Some(hit) = hit else {
                break (to_environment && scene.environment.is_some()).then(|| Vertex::environment(-ray.d));
            };
            if scene.passes_through(&hit, ray.d) {
                self.medium = scene.medium_across(&hit, ray.d).unwrap_or(self.medium);
                ray = spawn_ray(hit.p, hit.ng, ray.d);
                continue;
            }
            break Some(Vertex::surface(scene, &hit));
        };
        next.filter(|_| self.flights.weight != Vec3::ZERO)
    }

    /// The ray leaving vertex `x` along unit `d` (from the point itself in a medium, off the
    /// surface otherwise), entering the medium across `x`'s surface when it bounds media.
    pub fn leave(&mut self, scene: &Scene, x: &Vertex, d: Vec3) -> Ray {
        self.medium = medium_leaving(scene, x, self.medium, d);
        match x.kind {
            VertexKind::Medium(_) => Ray::new(x.p, d),
            _ => spawn_ray(x.p, x.ng, d),
        }
    }
}

/// The medium a ray leaving vertex `x` along `d` travels in, `arrived_in` being the medium the
/// walk reached `x` in (for x₀: the medium of its point): across the surface when `x` lies on
/// one that bounds media.
pub fn medium_leaving(scene: &Scene, x: &Vertex, arrived_in: Option<u32>, d: Vec3) -> Option<u32> {
    match x.kind {
        VertexKind::Surface | VertexKind::Light(_) => scene.medium_across_prim(x.prim, x.ng, d).unwrap_or(arrived_in),
        _ => arrived_in,
    }
}

/// The first ray of a light path from x₀, drawn with the densities of
/// [`super::pdf_light_side`], and the walk that follows it (hero channel `hero`); `None` when
/// the light emits nothing that way.
///
/// **Where a light path starts** (the camera's medium is known; a light's is not): an area light
/// emits into the medium its surface bounds on the side it emits to, or, when the surface bounds
/// none, the medium of the point ([`Scene::medium_at`]); a point, spot or projector light into
/// the medium of its position. Light from infinitely far away (environment, directional) starts
/// at the disc outside the scene's bounding sphere in the medium found there: a homogeneous
/// medium there fills all space out to infinity, whose transmittance e^{−σ_t·∞} is 0 in every
/// channel with σ_t > 0 — as `path`'s rays and shadow rays that leave the scene inside such a
/// medium never reach the environment.
pub fn emission_ray(scene: &Scene, x0: &Vertex, hero: usize, rng: &mut Rng) -> Option<(Ray, MediaWalk)> {
    match x0.kind {
        VertexKind::Light(l) => {
            let mut local = sample_cosine_hemisphere(rng.uniform2());
            if scene.lights[l as usize].emission.two_sided && rng.uniform() < 0.5 {
                local.z = -local.z;
            }
            let d = x0.frame.to_world(local);
            let mut walk = MediaWalk::new(hero, scene.medium_at(x0.p));
            Some((walk.leave(scene, x0, d), walk))
        }
        VertexKind::DeltaLight(j) => {
            let e = scene.delta_lights[j as usize].emit(rng.uniform2(), scene.bounding_sphere())?;
            Some((Ray::new(x0.p, e.dir), MediaWalk::new(hero, scene.medium_at(x0.p))))
        }
        VertexKind::Environment | VertexKind::Directional(_) => {
            let origin = parallel_ray_origin(-x0.ng, scene.bounding_sphere(), rng.uniform2());
            let mut walk = MediaWalk::new(hero, scene.medium_at(origin));
            if let Some(m) = walk.medium {
                let m = &scene.media[m as usize];
                if m.density.is_none() {
                    // The infinite stretch of a homogeneous medium before the disc.
                    walk.flights.weight *= Vec3::select(m.sigma_t.cmpgt(Vec3::ZERO), Vec3::ZERO, Vec3::ONE);
                    if walk.flights.weight == Vec3::ZERO {
                        return None;
                    }
                }
            }
            Some((Ray::new(origin, x0.ng), walk))
        }
        VertexKind::Surface | VertexKind::Medium(_) | VertexKind::Eye => None,
    }
}

/// The transmittance of the straight segment from eye-side vertex `z`, which its walk reached in
/// medium `arrived_in`, to vertex `x` (toward it, for a vertex at infinity), through every
/// medium and boundary it crosses ([`Scene::transmittance`]); 0 when a surface blocks it.
/// Followed from the eye side, whose media are known from the camera on, whatever a light path
/// guessed about where it started.
pub fn transmittance_between(scene: &Scene, z: &Vertex, arrived_in: Option<u32>, x: &Vertex, rng: &mut Rng) -> Vec3 {
    let ray = if x.is_at_infinity() {
        spawn_ray(z.p, z.ng, -x.ng)
    } else {
        let (ray, dist) = spawn_shadow_ray(z.p, z.ng, x.p, x.ng);
        if !(dist > 0.0 && ray.d.is_finite()) {
            return Vec3::ZERO;
        }
        ray
    };
    scene.transmittance(medium_leaving(scene, z, arrived_in, ray.d), &ray, rng)
}
