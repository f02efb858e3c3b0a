//! The photon map [Jensen 1996] and Christensen's precomputed irradiance [Christensen 1999]:
//! the machinery the photon-based strategies share.
//!
//! - [`record`]: the 24-byte photon record (RGBE power and irradiance, octahedral direction
//!   and normal, flags).
//! - [`trace`]: photon tracing from the lights with Russian roulette; global and caustic maps.
//! - [`kdtree`]: a balanced, pointer-free kd-tree with k-nearest and "nearest with a
//!   predicate" queries.
//! - [`estimate`]: irradiance and radiance density estimates.
//! - [`irradiance`]: irradiance precomputed at every k-th photon and its nearest-photon lookup.
//! - [`irradiance_cache`]: Ward's irradiance cache (records, weights, interpolation).
//!
//! Typical use:
//! ```no_run
//! # use photon_bench::photon::*;
//! let scene = photon_bench::scene::load_scene(std::path::Path::new("scenes/cornell-spheres.toml"))?;
//! let traced = trace_photons(&scene, &TraceParams::default(), 7);
//! let global = PhotonMap::build(traced.global);
//! let params = EstimateParams { nearest: 50, max_radius: 0.05, ..EstimateParams::default() };
//! let e = global.irradiance(glam::Vec3::ZERO, glam::Vec3::Y, &params).value;
//! let fast = precompute_irradiance(&global, 4, &params);
//! let e_fast = fast.irradiance_at(glam::Vec3::ZERO, glam::Vec3::Y, 0.9);
//! # Ok::<(), photon_bench::Error>(())
//! ```
//!
//! What does not live here: strategies (which decide how many photons, which maps and how
//! renders read them: [`crate::strategy`]) and anything that writes files; [`picture`] draws the
//! photon distribution figure a strategy returns.

pub mod estimate;
pub mod facing;
pub mod irradiance;
pub mod irradiance_cache;
pub mod kdtree;
pub mod picture;
pub mod record;
pub mod trace;

#[cfg(test)]
pub(crate) mod test_scenes;

pub use estimate::{Estimate, EstimateParams, Filter};
pub use facing::{Facing, FacingTree};
pub use irradiance::{IrradianceMap, precompute_irradiance};
pub use kdtree::{KdPoint, KdTree, Neighbour};
pub use record::{Photon, Rgbe, flags};
pub use trace::{CausticStorage, PhotonHit, TraceParams, TracedPath, TracedPhotons, trace_photon_path, trace_photons};

/// A photon map: photons sorted into a kd-tree for nearest-neighbour queries [Jensen 1996;
/// Christensen 1999, §1.2]. The density estimates live in [`estimate`].
#[derive(Clone, Debug)]
pub struct PhotonMap {
    tree: KdTree<Photon>,
}

impl PhotonMap {
    /// Sorts `photons` into a kd-tree (O(n log n), parallel, deterministic).
    pub fn build(photons: Vec<Photon>) -> Self {
        Self {
            tree: KdTree::build(photons),
        }
    }

    /// The photons, in kd-tree order.
    #[inline]
    pub fn photons(&self) -> &[Photon] {
        self.tree.items()
    }

    #[inline]
    pub fn tree(&self) -> &KdTree<Photon> {
        &self.tree
    }

    #[inline]
    pub fn len(&self) -> usize {
        self.tree.len()
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.tree.is_empty()
    }

    /// Memory held: the records plus the tree's split axes (one byte per photon).
    pub fn bytes(&self) -> usize {
        self.len() * Photon::BYTES + self.tree.overhead_bytes()
    }
}
