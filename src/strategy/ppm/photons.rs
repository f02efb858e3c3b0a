//! The photon pass of progressive photon mapping and the gather at a visible point
//! [Hachisuka et al. 2008, §3.2; Hachisuka & Jensen 2009, §3].

use super::eye::Shading;
use crate::bsdf::TransportMode;
use crate::photon::{KdPoint, KdTree, trace_photon_path};
use crate::sampling::{Rng, stream};
use crate::scene::Scene;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Photon paths per parallel task: a fixed split, so that the photon list is the same on any
/// number of threads.
const BLOCK: u64 = 1024;

/// A photon of one pass, at full precision (the passes' photons are dropped after the gather,
/// so the 24-byte records of the photon map would only add rounding).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FluxPhoton {
    pub p: Vec3,
    /// Unit direction towards where the photon came from.
    pub wi: Vec3,
    /// Shading normal on the side the photon arrived on.
    pub n: Vec3,
    /// ΔΦ, with N = the pass's photon paths.
    pub power: Vec3,
}

impl KdPoint for FluxPhoton {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}

/// The photons of pass `pass` and the rays they cost.
pub struct PhotonPass {
    pub photons: KdTree<FluxPhoton>,
    pub rays: u64,
}

/// Traces `paths` photon paths for pass `pass` (path i draws from `[PPM_PHOTON, i, pass]`) and
/// keeps every hit after at least `min_bounces` scattering events.
pub fn photon_pass(scene: &Scene, seed: u64, pass: u64, paths: u64, max_depth: u32, min_bounces: u32) -> PhotonPass {
    let blocks: Vec<(Vec<FluxPhoton>, u64)> = (0..paths.div_ceil(BLOCK))
        .into_par_iter()
        .map(|b| {
            let mut photons = Vec::new();
            let mut rays = 0;
            for i in b * BLOCK..((b + 1) * BLOCK).min(paths) {
                let mut rng = Rng::for_task(seed, [stream::PPM_PHOTON, i, pass]);
                rays += trace_photon_path(scene, max_depth, paths, &mut rng, |hit| {
                    if hit.bounces >= min_bounces {
                        photons.push(FluxPhoton {
                            p: hit.p,
                            wi: hit.wi,
                            n: hit.n,
                            power: hit.power,
                        });
                    }
                })
                .rays;
            }
            (photons, rays)
        })
        .collect();
    let rays = blocks.iter().map(|b| b.1).sum();
    let photons = blocks.into_iter().flat_map(|b| b.0).collect();
    PhotonPass {
        photons: KdTree::build(photons),
        rays,
    }
}

/// What the photons of one pass deposit at one visible point: Φ_i = β Σ f_s(x, ω, ω_p) ΔΦ_p
/// over the photons p within `radius` [Hachisuka et al. 2008, eq. (10)], and M_i, the photons
/// found (on the visible point's side of the surface).
pub fn gather(scene: &Scene, photons: &KdTree<FluxPhoton>, vp: &Shading, radius: f32) -> (DVec3, u32) {
    let bsdf = scene.bsdf(&vp.hit);
    let side = if vp.wo.z < 0.0 { -vp.hit.frame.n } else { vp.hit.frame.n };
    let mut phi = DVec3::ZERO;
    let mut m = 0u32;
    let items = photons.items();
    photons.for_each_within(vp.hit.p, radius, |index, _| {
        let photon = &items[index as usize];
        if photon.n.dot(side) <= 0.0 {
            return;
        }
        m += 1;
        let wi = vp.hit.frame.to_local(photon.wi);
        let f = bsdf.eval(vp.wo, wi, TransportMode::Radiance);
        phi += (vp.beta * f * photon.power).as_dvec3();
    });
    (phi, m)
}
