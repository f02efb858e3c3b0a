//! The indirect photons as Jensen's guiding searches them: a kd-tree of decoded photons whose
//! normals and incoming directions are also laid out as the tree lays out positions, so that
//! the side test of every k-nearest search runs eight photons at a time.
//!
//! Why: the per-vertex pdf's search keeps only photons that arrived on the side the vertex
//! faces (ω_p · n > 0 and n_p · n > 0); tested one record at a time, behind a branch each,
//! that test doubled the cost of a k = 50 search (3.1–3.9 µs against 1.9–2.0 µs without it,
//! one thread, cornell-box photons). The photons found are the same set.

use super::GuidePhoton;
use crate::photon::kdtree::{LANES, Lanes3};
use crate::photon::{KdTree, Neighbour};
use glam::Vec3;
use wide::f32x8;

/// Guiding photons in a kd-tree, with their normals, directions and fluxes in SIMD blocks.
#[derive(Clone, Debug)]
pub struct GuideMap {
    tree: KdTree<GuidePhoton>,
    normals: Vec<Lanes3>,
    directions: Vec<DirectionsAndFluxes>,
}

/// A block's incoming directions ω_p and, in the same cache line as their z, the flux
/// luminances ΔΦ: the grid's build reads both for the photons found, from blocks the side
/// test has just loaded (reading them from the photons, then from an array of their own, was
/// a cache miss per photon: half of a grid's build).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(128))]
struct DirectionsAndFluxes {
    direction: Lanes3,
    flux: [f32; LANES],
}

impl GuideMap {
    /// Builds the tree over `photons` (reordering them).
    pub fn build(photons: Vec<GuidePhoton>) -> Self {
        let tree = KdTree::build(photons);
        // Padding lanes: zero vectors, which fail the strict side test.
        let normals = tree.lanes_of(|p| p.normal, 0.0);
        let fluxes = tree.slots_of(|p| p.flux, 0.0);
        let directions = (tree.lanes_of(|p| p.direction, 0.0).into_iter().zip(fluxes))
            .map(|(direction, flux)| DirectionsAndFluxes { direction, flux })
            .collect();
        Self {
            tree,
            normals,
            directions,
        }
    }

    /// The incoming direction ω_p and flux luminance ΔΦ of the photon in `slot` (a
    /// [`Neighbour::index`] of [`GuideMap::k_nearest_on_side`]).
    #[inline]
    pub fn direction_and_flux(&self, slot: u32) -> (Vec3, f32) {
        let (block, lane) = (slot as usize / LANES, slot as usize % LANES);
        let DirectionsAndFluxes { direction: d, flux } = &self.directions[block];
        (Vec3::new(d.x[lane], d.y[lane], d.z[lane]), flux[lane])
    }

    /// The photons, in tree order (the search names them by slot, not by their index here).
    pub fn items(&self) -> &[GuidePhoton] {
        self.tree.items()
    }

    pub fn len(&self) -> usize {
        self.tree.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tree.is_empty()
    }

    /// The (up to) `k` nearest photons within `max_radius` of `p` that arrived on the side the
    /// unit normal `n` faces: ω_p · n > 0 and n_p · n > 0, computed as `Vec3::dot` computes
    /// them. Written to `out` as [`KdTree::k_nearest_into`] writes it, but each photon named by
    /// its slot ([`KdTree::k_nearest_slots`]; read it with [`GuideMap::direction_and_flux`]).
    pub fn k_nearest_on_side(&self, p: Vec3, n: Vec3, k: usize, max_radius: f32, out: &mut Vec<Neighbour>) {
        let zero = f32x8::splat(0.0);
        self.tree.k_nearest_slots(p, k, max_radius, out, |block, _, _| {
            let facing =
                self.directions[block].direction.dot(n).simd_gt(zero) & self.normals[block].dot(n).simd_gt(zero);
            facing.to_bitmask()
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Rng, sample_uniform_sphere};

    #[test]
    fn the_side_test_in_blocks_keeps_the_same_photons_as_one_at_a_time() {
        let mut rng = Rng::for_task(3, [0, 0, 0]);
        let photons: Vec<GuidePhoton> = (0..6_000)
            .map(|i| {
                let position = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform() * 0.1);
                // A third of the normals exactly ±z, so that side tests meet zeros and ties.
                let normal = match i % 3 {
                    0 => Vec3::Z,
                    1 => -Vec3::Z,
                    _ => sample_uniform_sphere(rng.uniform2()),
                };
                let direction = sample_uniform_sphere(rng.uniform2());
                GuidePhoton {
                    position,
                    direction,
                    normal,
                    flux: rng.uniform(),
                }
            })
            .collect();
        let map = GuideMap::build(photons);
        let (mut got, mut want) = (Vec::new(), Vec::new());
        for q in 0..500 {
            let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform() * 0.1);
            let n = if q % 4 == 0 {
                Vec3::Z
            } else {
                sample_uniform_sphere(rng.uniform2())
            };
            let (k, r) = ([1usize, 50, 200][q % 3], [0.05f32, f32::INFINITY][q % 2]);
            map.k_nearest_on_side(p, n, k, r, &mut got);
            let side = |ph: &GuidePhoton| ph.direction.dot(n) > 0.0 && ph.normal.dot(n) > 0.0;
            map.tree.k_nearest_into(p, k, r, side, &mut want);
            let distances = |v: &[Neighbour]| {
                let mut d: Vec<f32> = v.iter().map(|nb| nb.dist2).collect();
                d.sort_by(f32::total_cmp);
                d
            };
            assert_eq!(distances(&got), distances(&want), "query {q}");
            // Each slot holds the photon it reports: its distance, side and flux.
            for nb in &got {
                let (direction, flux) = map.direction_and_flux(nb.index);
                let ph = map
                    .items()
                    .iter()
                    .find(|ph| ph.direction == direction && ph.flux == flux)
                    .expect("a slot holds a photon of the map");
                assert_eq!(ph.position.distance_squared(p), nb.dist2);
                assert!(side(ph), "query {q}: a photon from the wrong side");
            }
        }
    }
}
