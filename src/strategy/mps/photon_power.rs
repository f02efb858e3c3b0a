//! Where a Metropolis photon is stored and what power it gets: the storage point on a path,
//! the power F of a deposit [Fan et al. 2005, §3.2] (as printed, or normalised by the
//! renderer's importance), repeated paths merged into one photon, and the maps' effective
//! sample size.

use super::*;
use crate::bsdf::SurfaceKind;
use crate::color::luminance;
use crate::metropolis::{State, incoming};
use crate::path_space::{Vertex, light_throughput, pdf_eye_side};
use crate::photon::{Photon, flags};
use crate::scene::Scene;
use glam::{DVec3, Vec3};

/// Kish's effective sample size (Σ w)² / Σ w² of the photons' luminance powers (0 for none).
pub fn effective_sample_size(photons: &[Photon]) -> f64 {
    let (sum, sum_sq) = photons.iter().fold((0.0, 0.0), |(s, q), p| {
        let w = luminance(p.power()) as f64;
        (s + w, q + w * w)
    });
    if sum_sq > 0.0 { sum * sum / sum_sq } else { 0.0 }
}

/// Which map a path stores into, at which vertex, with which flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Map {
    Global,
    Caustic,
}

/// The storage point of a path (see the module doc), if it has one.
///
/// The final gather's camera path stops at the first surface that is not purely specular, x_d,
/// whatever lobe the path took there: a smooth plastic whose coating the path took is still
/// where the renderer shades, reads the caustic map and sends gather rays (which sample the
/// whole model, coating included). So x_d is the first vertex from the eye that is not purely
/// specular, the global map's point the next vertex toward the light whose lobe is not a
/// delta (a gather ray goes on through a coating, [`super::super::photon_map`]'s final
/// gather), and a path that reaches x_d through its coating straight from the light through
/// delta lobes only stores nothing: the gather ray counts that light itself.
pub fn storage_point(scene: &Scene, path: &[Vertex]) -> Option<(Map, usize, u8)> {
    let diffuse = |v: &Vertex| !v.delta && v.bsdf(scene).kind() == SurfaceKind::Diffuse;
    let k = path.len() - 1;
    let d = (1..k).rev().find(|&i| path[i].can_end_connection())?;
    if path[d].bsdf(scene).kind() != SurfaceKind::Diffuse {
        return None;
    }
    let s = (0..d).rev().find(|&i| !path[i].delta)?;
    if s >= 1 {
        if !diffuse(&path[s]) {
            return None;
        }
        let mut f = 0;
        if s >= 2 {
            f |= flags::INDIRECT;
            if path[1..s].iter().all(|v| v.delta) {
                f |= flags::CAUSTIC;
            }
        }
        Some((Map::Global, s, f))
    } else if d >= 2 && !path[d].delta {
        Some((Map::Caustic, d, flags::CAUSTIC | flags::INDIRECT))
    } else {
        None
    }
}

/// A photon being accumulated: where, from where, and its power so far.
#[derive(Clone, Copy, Debug)]
pub(super) struct Deposit {
    pub(super) map: Map,
    pub(super) p: Vec3,
    pub(super) from: Vec3,
    pub(super) wi: Vec3,
    pub(super) n: Vec3,
    pub(super) flags: u8,
    /// F of one whole visit (weight 1).
    pub(super) unit: Vec3,
    pub(super) power: DVec3,
}

impl Deposit {
    /// The deposit of `state`: per unit weight B_Y f_map / (N f_Y), times q(X_eye, x_s) with
    /// the importon normalisation (whose 1 / q_s(x_s) is applied when the photon is emitted);
    /// `None` when the path stores nothing.
    pub(super) fn of(scene: &Scene, state: &State, b_y: f64, n: u64, power: PhotonPower) -> Option<Self> {
        let path = &state.path;
        let (map, s, flags) = storage_point(scene, path)?;
        let f_map = light_throughput(scene, path, s);
        let q_eye = match power {
            PhotonPower::Paper => 1.0,
            PhotonPower::Importon => (s..path.len() - 1)
                .map(|i| pdf_eye_side(scene, path, i) as f64)
                .product(),
        };
        let unit = (f_map.as_dvec3() * (b_y * q_eye / (n as f64 * state.f_y as f64))).as_vec3();
        if !unit.is_finite() || unit == Vec3::ZERO {
            return None;
        }
        let v = &path[s];
        let wi = incoming(path, s);
        let n = if v.ng.dot(wi) >= 0.0 { v.ng } else { -v.ng };
        Some(Self {
            map,
            p: v.p,
            from: path[s - 1].p,
            wi,
            n,
            flags,
            unit,
            power: DVec3::ZERO,
        })
    }

    /// Same storage point, previous vertex and incoming direction (the direction tells apart
    /// light from infinitely far away, whose vertex has no position).
    pub(super) fn same_photon(&self, o: &Deposit) -> bool {
        self.map == o.map && self.p == o.p && self.from == o.from && self.wi == o.wi
    }

    pub(super) fn add(&mut self, weight: f32) {
        self.power += self.unit.as_dvec3() * weight as f64;
    }
}

/// One photon per repeated path across chains: deposits with the same storage point and the
/// same previous vertex (the paper's "repeated paths", §3.2) are summed, in chain order. Chains
/// resampled from the same B_eye path start on the same storage point; as separate photons
/// they would stack at one position and shrink the k-nearest radius around it. Applied to the
/// chains' first photons, the only ones that can repeat across chains (every later path is a
/// continuous random perturbation of its own chain's).
pub(super) fn merge_repeated_paths(mut deposits: Vec<Deposit>) -> Vec<Deposit> {
    let key = |d: &Deposit| {
        let b = |v: Vec3| v.to_array().map(f32::to_bits);
        (d.map as u8, b(d.p), b(d.from), b(d.wi))
    };
    // Stable: equal keys stay in chain order, so sums do not depend on the thread count.
    deposits.sort_by_key(key);
    let mut out: Vec<Deposit> = Vec::with_capacity(deposits.len());
    for d in deposits {
        match out.last_mut() {
            Some(last) if last.same_photon(&d) => last.power += d.power,
            _ => out.push(d),
        }
    }
    out
}
