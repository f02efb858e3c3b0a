//! Christensen's lookup as a query of its own: the nearest point whose normal lies within a
//! cone around the query's normal [Christensen 1999, §2.2], over a [`KdTree`] that keeps the
//! normals beside the positions, [`super::kdtree::LANES`] per block.
//!
//! Why not [`KdTree::nearest_where`] with the normal test as its predicate: that form reads
//! each candidate's record (and decodes its normal) one at a time behind a chain of
//! data-dependent branches, which profiles of the final gather and of the precomputed Jensen
//! pdfs showed to be most of a lookup's time. Here a leaf block is one SIMD test (distance
//! below the best so far, within the radius, normal in the cone) and one branch. The answer is
//! the same item: the first nearest in the tree's visiting order, as `nearest_where` gives it
//! (the tests compare both, and brute force).

use super::kdtree::{KdPoint, KdTree, LANES, Lanes3, Neighbour};
use glam::Vec3;
use wide::f32x8;

/// Items with a position, a unit normal and a 32-bit payload each, for
/// [`FacingTree::nearest_facing`].
#[derive(Clone, Debug)]
pub struct FacingTree<T> {
    tree: KdTree<T>,
    /// The items' normals and payloads in the tree's block layout ([`KdTree::lanes_of`]);
    /// padding lanes have a zero normal (and an infinite position, so they never pass).
    blocks: Vec<FacingBlock>,
}

/// One block of eight items' normals and payloads: 128 bytes, two cache lines, the payloads in
/// the line of the normals' z, which the normal test has just read. A lookup answers with the
/// payload from there instead of reading the found item (a cache miss per lookup: two thirds of
/// the final gather's own lookup time, 2026-11-27 profile).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(128))]
struct FacingBlock {
    normals: Lanes3,
    payload: [u32; LANES],
}

/// What [`FacingTree::nearest_facing`] finds: the item (index and squared distance), its
/// normal and its payload.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Facing {
    pub neighbour: Neighbour,
    pub normal: Vec3,
    pub payload: u32,
}

impl<T: KdPoint + Send> FacingTree<T> {
    /// Builds the tree (reordering `items`) with `normal` giving each item's unit normal and
    /// `payload` what [`FacingTree::nearest_facing`] returns with it.
    pub fn build(items: Vec<T>, normal: impl Fn(&T) -> Vec3, payload: impl Fn(&T) -> u32) -> Self {
        let tree = KdTree::build_for_nearest(items);
        let normals = tree.lanes_of(normal, 0.0);
        let payloads = tree.slots_of(payload, 0);
        let blocks = normals
            .into_iter()
            .zip(payloads)
            .map(|(normals, payload)| FacingBlock { normals, payload })
            .collect();
        Self { tree, blocks }
    }
}

impl<T: KdPoint> FacingTree<T> {
    /// The items, in tree order; [`Neighbour::index`] indexes this slice.
    pub fn items(&self) -> &[T] {
        self.tree.items()
    }

    pub fn len(&self) -> usize {
        self.tree.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tree.is_empty()
    }

    /// Heap bytes used beyond the items themselves.
    pub fn overhead_bytes(&self) -> usize {
        self.tree.overhead_bytes() + self.blocks.len() * size_of::<FacingBlock>()
    }

    /// The nearest item within `max_radius` of `p` (inclusive) whose normal n_p has
    /// n_p · `n` > `min_dot`, the dot product computed as `Vec3::dot` computes it; among
    /// items at the same distance, the one [`KdTree::nearest_where`] would return. Its normal
    /// and payload come from the tree's blocks: reading the item is not needed for them.
    pub fn nearest_facing(&self, p: Vec3, n: Vec3, min_dot: f32, max_radius: f32) -> Option<Facing> {
        let max_r2 = max_radius * max_radius;
        let (max_r2_lanes, min_dot_lanes) = (f32x8::splat(max_r2), f32x8::splat(min_dot));
        let mut best: Option<Facing> = None;
        self.tree.search_blocks(p, max_r2, |block, start, _len, bound2| {
            let d2 = self.tree.block(block).distance2(p);
            let best2 = f32x8::splat(best.map_or(f32::INFINITY, |b| b.neighbour.dist2));
            let facing = &self.blocks[block];
            let passing = d2.simd_lt(best2) & d2.simd_le(max_r2_lanes) & facing.normals.dot(n).simd_gt(min_dot_lanes);
            if !passing.any() {
                return bound2;
            }
            // The nearest passing lane, the first of equals (as a one-at-a-time visit in item
            // order keeps it).
            let d2 = passing.bitselect(d2, f32x8::splat(f32::INFINITY));
            let nearest = d2.to_array().into_iter().fold(f32::INFINITY, f32::min);
            let first = d2.simd_eq(f32x8::splat(nearest)).to_bitmask().trailing_zeros();
            let (lane, normals) = (first as usize, &facing.normals);
            best = Some(Facing {
                neighbour: Neighbour {
                    index: start + first,
                    dist2: nearest,
                },
                normal: Vec3::new(normals.x[lane], normals.y[lane], normals.z[lane]),
                payload: facing.payload[lane],
            });
            nearest
        });
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Rng, sample_uniform_sphere as uniform_sphere};

    /// A point with a normal; positions on a coarse lattice so that many queries meet ties.
    #[derive(Clone, Copy, Debug, PartialEq)]
    struct Oriented {
        p: Vec3,
        n: Vec3,
    }

    impl KdPoint for Oriented {
        fn position(&self) -> Vec3 {
            self.p
        }
    }

    fn oriented(count: usize, seed: u64) -> Vec<Oriented> {
        let mut rng = Rng::for_task(seed, [0, 0, 0]);
        (0..count)
            .map(|i| {
                let p = Vec3::new(rng.uniform(), rng.uniform() * 0.5, rng.uniform() * 2.0);
                // Every third point snapped to a 0.05 lattice: exact duplicates and equal distances.
                let p = if i % 3 == 0 { (p * 20.0).round() / 20.0 } else { p };
                let n = if i % 5 == 0 {
                    Vec3::Y
                } else {
                    uniform_sphere(rng.uniform2())
                };
                Oriented { p, n }
            })
            .collect()
    }

    #[test]
    fn nearest_facing_is_nearest_where_with_the_normal_test() {
        for (count, seed) in [(20_000usize, 1u64), (9, 2), (1, 3), (0, 4)] {
            let items = oriented(count, seed);
            let payload = |o: &Oriented| o.p.x.to_bits() ^ o.n.z.to_bits();
            let facing = FacingTree::build(items.clone(), |o| o.n, payload);
            let tree = KdTree::build_for_nearest(items.clone());
            assert_eq!(facing.items(), tree.items(), "same tree order");
            let mut rng = Rng::for_task(seed, [1, 0, 0]);
            for q in 0..2_000 {
                let p = if q % 4 == 0 && count > 0 {
                    items[q % count].p
                } else {
                    Vec3::new(
                        rng.uniform() * 1.2 - 0.1,
                        rng.uniform() * 0.6 - 0.05,
                        rng.uniform() * 2.2 - 0.1,
                    )
                };
                let n = if q % 3 == 0 {
                    Vec3::Y
                } else {
                    uniform_sphere(rng.uniform2())
                };
                let min_dot = [0.9f32, 0.0, -1.5, 0.999][q % 4];
                let r = [0.03f32, 0.2, f32::INFINITY][q % 3];
                let found = facing.nearest_facing(p, n, min_dot, r);
                if let Some(f) = found {
                    let item = &facing.items()[f.neighbour.index as usize];
                    assert_eq!(f.payload, payload(item), "the found item's payload");
                    assert_eq!(f.normal, item.n, "the found item's normal");
                }
                let got = found.map(|f| f.neighbour);
                let want = tree.nearest_where(p, r, |o| o.n.dot(n) > min_dot);
                assert_eq!(got, want, "query {q} of {count} items: r {r}, cos {min_dot}");
                // And against brute force: nothing passing is nearer.
                let brute = items
                    .iter()
                    .filter(|o| o.n.dot(n) > min_dot && (o.p - p).length_squared() <= r * r)
                    .map(|o| (o.p - p).length_squared())
                    .min_by(f32::total_cmp);
                assert_eq!(got.map(|g| g.dist2), brute, "query {q}");
            }
        }
    }

    #[test]
    fn the_radius_is_inclusive_and_padding_never_passes() {
        let items = vec![
            Oriented {
                p: Vec3::new(3.0, 0.0, 0.0),
                n: Vec3::Z,
            },
            Oriented {
                p: Vec3::new(0.0, 5.0, 0.0),
                n: Vec3::Z,
            },
        ];
        let facing = FacingTree::build(items, |o| o.n, |_| 0);
        let at = |r: f32, min_dot: f32| {
            facing
                .nearest_facing(Vec3::ZERO, Vec3::Z, min_dot, r)
                .map(|f| f.neighbour.dist2)
        };
        assert_eq!(at(3.0, 0.5), Some(9.0), "an item exactly at the radius is found");
        assert_eq!(at(2.999, 0.5), None);
        assert_eq!(at(f32::INFINITY, 1.0), None, "the cone test is strict");
        // Padding lanes have zero normals and infinite positions: a test every real item fails
        // (min_dot < −1) still finds only the two items.
        assert_eq!(at(f32::INFINITY, -2.0), Some(9.0));
        assert_eq!(at(f32::NAN, -2.0), None);
    }
}
