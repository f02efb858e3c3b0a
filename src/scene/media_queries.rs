//! What the volumetric walks ask the scene about media: the transmittance of a segment through
//! every medium and medium boundary it crosses, and the medium a point lies in.

use super::Scene;
use crate::geometry::{Ray, spawn_ray, spawn_ray_to_end};
use crate::sampling::Rng;
use glam::Vec3;

/// Directions along which [`Scene::medium_at`] looks for the nearest medium boundary: a fixed
/// pair (not axis-aligned, so that a probe does not run along a box's faces).
const PROBES: [Vec3; 2] = [
    Vec3::new(0.267_261_24, 0.801_783_7, 0.534_522_5),
    Vec3::new(-0.267_261_24, -0.801_783_7, -0.534_522_5),
];

impl Scene {
    /// The transmittance of `ray` up to its `t_max`, starting in `medium`: 0 when an opaque
    /// surface blocks it, else the product over the media it crosses of their transmittance
    /// (closed form in a homogeneous medium, ratio tracking in a heterogeneous one), changing
    /// medium at the boundaries it passes ([`Scene::medium_across`]).
    pub fn transmittance(&self, mut medium: Option<u32>, ray: &Ray, rng: &mut Rng) -> Vec3 {
        let mut tr = Vec3::ONE;
        let end = ray.at(ray.t_max);
        let mut segment = *ray;
        loop {
            let hit = self.intersect_any(&segment);
            let length = hit.as_ref().map_or(segment.t_max, |h| h.t);
            if let Some(m) = medium {
                tr *= self.media[m as usize].transmittance_along(segment.o, segment.d, length, rng);
            }
            let Some(hit) = hit else { return tr };
            if tr == Vec3::ZERO || !self.passes_through(&hit, segment.d) {
                return Vec3::ZERO;
            }
            if let Some(next) = self.medium_across(&hit, segment.d) {
                medium = next;
            }
            segment = if segment.t_max.is_finite() {
                match spawn_ray_to_end(hit.p, hit.ng, segment.d, end) {
                    Some(next) => next,
                    None => return tr,
                }
            } else {
                spawn_ray(hit.p, hit.ng, segment.d)
            };
        }
    }

    /// The medium the point `p` lies in, for walks that start inside the scene rather than at
    /// the camera (light sub-paths). **Decision:** the side facing `p` of the nearest surface
    /// that bounds media along one of two fixed probe rays (surfaces that bound none are looked
    /// through); where neither probe meets such a surface, `p` lies in the open space around
    /// the camera and so in the camera's medium (Mitsuba's sensor `medium`). A light outside
    /// every boundary while the camera sits inside a bounded medium is thus taken to be in the
    /// camera's medium; scenes that put the camera in a medium describe open space so.
    pub fn medium_at(&self, p: Vec3) -> Option<u32> {
        if self.media.is_empty() {
            return None;
        }
        for d in PROBES {
            let mut ray = Ray::new(p, d);
            while let Some(hit) = self.intersect_any(&ray) {
                if let Some(m) = self.medium_across(&hit, -d) {
                    return m;
                }
                ray = spawn_ray(hit.p, hit.ng, d);
            }
        }
        self.camera_medium
    }
}
