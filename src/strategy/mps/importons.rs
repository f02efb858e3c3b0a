//! Importons: camera rays plus one gather ray, whose density estimates the renderer's own
//! importance q at a photon (the `importon` photon power), with area probes at surface edges
//! and a line-of-sight rule so that importance does not leak through thin walls.

use super::*;
use crate::bsdf::SurfaceKind;
use crate::bsdf::TransportMode;
use crate::geometry::{Frame, Ray};
use crate::path_space::walk::{extend_eye_to_diffuse, scatter, trace_from};
use crate::path_space::{Vertex, direction};
use crate::photon::{EstimateParams, Photon, PhotonMap};
use crate::sampling::{Rng, latin_hypercube, sample_concentric_disk};
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;

/// The renderer's importance, as densities of importons: where camera paths first meet a
/// diffuse surface (caustic map lookups) and where their first gather ray lands (global map
/// lookups).
pub struct Importons {
    pub(super) caustic: PhotonMap,
    pub(super) global: PhotonMap,
    pub(super) estimate: EstimateParams,
    pub(super) paths: u64,
    pub(super) rule: DensityRule,
}

/// How [`Importons`] turn the importons near a point into 1 / q_s (see
/// [`Importons::inverse_density`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DensityRule {
    /// Probe rays measuring the surface area inside the estimate's disc (0: the whole disc
    /// π r²): [`surface_area_in_ball`].
    pub edge_probes: usize,
    /// `Some(ε)`: count only importons, and area, in sight of the point, so that importance
    /// does not leak through a thin wall. `None`: count everything in the ball, as a photon
    /// estimate does. In sight: the segment between the two points, each lifted along its
    /// normal by ε + d / 4 (d their distance), is free. The d / 4 carries the segment over
    /// the surface itself where it curves (on a sphere of radius R a chord of length d sinks
    /// d² / 8R below its ends, less than d / 4 for d < 2R) and over anything lower than that;
    /// a wall stops it.
    pub sight_lift: Option<f32>,
}

impl DensityRule {
    pub(super) fn in_sight(&self, scene: &Scene, p: Vec3, n: Vec3, q: Vec3, n_q: Vec3) -> bool {
        let Some(eps) = self.sight_lift else { return true };
        let lift = eps + 0.25 * p.distance(q);
        let (a, b) = (p + n * lift, q + n_q * lift);
        let len = a.distance(b);
        len <= lift
            || scene.unoccluded(&Ray {
                o: a,
                d: (b - a) / len,
                t_max: len,
            })
    }
}

impl Importons {
    /// Traces `paths` importon paths: a camera ray through a raster point uniform over the
    /// image, specular bounces (lobes sampled) to the first diffuse hit x_d, one BSDF-sampled
    /// gather ray from it, specular bounces to the next diffuse hit — exactly how the final
    /// gather generates the eye sub-paths that read each map.
    pub fn trace(
        scene: &Scene,
        paths: u64,
        max_edges: usize,
        estimate: EstimateParams,
        rule: DensityRule,
        seed: u64,
    ) -> Self {
        const BLOCK: u64 = 4096;
        let blocks: Vec<(Vec<Photon>, Vec<Photon>)> = (0..paths.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let (mut caustic, mut global) = (Vec::new(), Vec::new());
                for i in b * BLOCK..((b + 1) * BLOCK).min(paths) {
                    let mut rng = Rng::for_task(seed, [crate::sampling::stream::IMPORTON, i, 0]);
                    let mut rev = vec![Vertex::eye(scene, &mut rng)];
                    if !extend_eye_to_diffuse(scene, &mut rev, max_edges, &mut rng) {
                        continue;
                    }
                    let Some(ip) = importon(scene, &rev) else { continue };
                    caustic.push(ip);
                    let Some(hit) = scatter(scene, &mut rev, TransportMode::Radiance, &mut rng)
                        .and_then(|step| trace_from(scene, &rev[rev.len() - 1], step.wi))
                    else {
                        continue;
                    };
                    rev.push(hit);
                    follow_gather(scene, &mut rev, 2 * max_edges, &mut rng, |rev| {
                        global.extend(importon(scene, rev));
                    });
                }
                (caustic, global)
            })
            .collect();
        let (mut caustic, mut global) = (Vec::new(), Vec::new());
        for (c, g) in blocks {
            caustic.extend(c);
            global.extend(g);
        }
        Self {
            caustic: PhotonMap::build(caustic),
            global: PhotonMap::build(global),
            estimate,
            paths,
            rule,
        }
    }

    /// 1 / q_s(p): the reciprocal of the density (per unit area) with which the renderer's eye
    /// sub-paths reach `p` on the side of `n`, for lookups in `map`; `None` where no importon
    /// came near (the renderer never looks there).
    ///
    /// The estimate is A / (k / paths), k the importons within the k-nearest radius r (or all
    /// within `max_radius` when fewer) and A the area of surface inside that ball on which they
    /// could lie. Given r, k − 1 importons fall uniformly in A, so with A exact E[A / k] = 1 / q_s
    /// (λ A(r_k) is Gamma(k) distributed for importons of local density λ). A = π r² is exact
    /// only inside a flat surface; within r of an edge or a corner the disc reaches past the
    /// surface and π r² overstates A, so 1 / q_s comes out too large there (`rooms`: +3 %
    /// luminance). With `edge_probes` > 0, A is measured instead: [`surface_area_in_ball`].
    ///
    /// Importance leaks through walls as photon power does [Fan et al. 2005, §3.1]: the ball
    /// around a point of the floor beside a thin wall holds importons from the floor behind it,
    /// where the gather may look far more (or less) often. With a `sight_lift` the count and
    /// the area both keep only what is in sight of `p`, so the estimate stays on its side.
    pub(super) fn inverse_density(&self, scene: &Scene, map: Map, p: Vec3, n: Vec3, rng: &mut Rng) -> Option<f64> {
        let m = match map {
            Map::Global => &self.global,
            Map::Caustic => &self.caustic,
        };
        if m.is_empty() {
            return None;
        }
        let rule = &self.rule;
        let est = m.irradiance_where(p, n, &self.estimate, |imp| {
            rule.in_sight(scene, p, n, imp.position(), imp.normal())
        });
        if est.photons == 0 || est.radius <= 0.0 {
            return None;
        }
        let r = est.radius;
        let area = if rule.edge_probes == 0 {
            std::f64::consts::PI * (r as f64).powi(2)
        } else {
            surface_area_in_ball(scene, p, n, r, self.estimate.normal_dot, rule, rng)
        };
        (area > 0.0).then(|| area * self.paths as f64 / est.photons as f64)
    }
}

/// An unbiased estimate of the area of the surfaces inside the ball of radius `r` around `p`
/// that a density estimate on the side of `n` reads: diffuse surfaces whose normal, turned to
/// face the probe, passes the importons' normal test (n_y · n ≥ `normal_dot`). `rule.edge_probes` points
/// uniform (Latin-hypercube stratified) on the tangent disc of radius r each cast a ray along
/// −n from height r above it, over 2r; a first hit y inside the ball on such a surface counts
/// 1 / (n_y · n), the Jacobian from the disc's projected area to the surface's. Exact in
/// expectation for any surface seen from above as a height field over the disc: a flat
/// surface's open edges and corners, walls standing on it (nothing under them is seen),
/// curved surfaces. With the rule's `sight_lift` a hit also has to be in sight of `p` (the
/// floor behind a thin wall does not count). What it cannot know is where a surface is seen
/// from above yet never reached by importons (the floor under a wall box without a bottom
/// face).
pub fn surface_area_in_ball(
    scene: &Scene,
    p: Vec3,
    n: Vec3,
    r: f32,
    normal_dot: f32,
    rule: &DensityRule,
    rng: &mut Rng,
) -> f64 {
    let probes = rule.edge_probes;
    let frame = Frame::from_normal(n);
    let mut sum = 0.0f64;
    for u in latin_hypercube(probes, rng) {
        let d = sample_concentric_disk(u) * r;
        let ray = Ray {
            o: p + frame.s * d.x + frame.t * d.y + n * r,
            d: -n,
            t_max: 2.0 * r,
        };
        let Some(hit) = scene.intersect(&ray) else { continue };
        let n_y = if hit.ng.dot(n) >= 0.0 { hit.ng } else { -hit.ng };
        let cos = n_y.dot(n);
        if cos >= normal_dot.max(1e-3)
            && hit.p.distance_squared(p) <= r * r
            && scene.bsdf(&hit).kind() == SurfaceKind::Diffuse
            && rule.in_sight(scene, p, n, hit.p, n_y)
        {
            sum += 1.0 / cos as f64;
        }
    }
    std::f64::consts::PI * (r as f64).powi(2) * sum / probes as f64
}

/// Follows a gather ray's eye sub-path `rev` as the final gather does (keeping at most
/// `max_vertices` vertices), calling `read` wherever it reads the global map: through specular
/// bounces to the next surface that is not purely specular, read there; at a smooth plastic the
/// gather reads the map with probability 1 − P_δ and weight 1 / (1 − P_δ), once per landing in
/// expectation, so `read` is called at every landing, and the walk goes on through the coating
/// with probability P_δ (its lobe, sampled from the model, as the gather samples it).
fn follow_gather(
    scene: &Scene,
    rev: &mut Vec<Vertex>,
    max_vertices: usize,
    rng: &mut Rng,
    mut read: impl FnMut(&[Vertex]),
) {
    loop {
        if !extend_eye_to_diffuse(scene, rev, max_vertices, rng) {
            return;
        }
        read(rev);
        let n = rev.len();
        if !rev[n - 1].mixed || n >= max_vertices {
            return;
        }
        let Some(step) = scatter(scene, rev, TransportMode::Radiance, rng).filter(|s| s.delta) else {
            return;
        };
        match trace_from(scene, &rev[n - 1], step.wi) {
            Some(v) => rev.push(v),
            None => return,
        }
    }
}

/// An importon at the last vertex of an eye sub-path, if it is diffuse: unit "power", the
/// direction it came from and the normal on that side.
pub(super) fn importon(scene: &Scene, rev: &[Vertex]) -> Option<Photon> {
    let v = rev[rev.len() - 1];
    if v.delta || v.bsdf(scene).kind() != SurfaceKind::Diffuse {
        return None;
    }
    let wi = direction(&v, &rev[rev.len() - 2]).0;
    let n = if v.ng.dot(wi) >= 0.0 { v.ng } else { -v.ng };
    Some(Photon::new(v.p, Vec3::ONE, wi, n, 0))
}
