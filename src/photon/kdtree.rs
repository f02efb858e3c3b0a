//! A balanced, pointer-free kd-tree over points [Bentley 1975], as the photon map uses it
//! [Jensen 1996; Christensen 1999, §1.2].
//!
//! Layout: the items themselves are reordered into a median-split array. The node of the
//! index range `lo..hi` is the item at `mid = (lo + hi) / 2`; its children are the ranges
//! `lo..mid` and `mid + 1..hi`; the only extra storage is the split axis of every node (one
//! byte per item). Items left of `mid` have a coordinate ≤ the node's, items right of it ≥.
//! Ranges of at most [`LEAF_SIZE`] items are leaves, scanned linearly (their order is
//! arbitrary), which saves the deepest, least selective levels of the descent.
//!
//! The split axis is the longest side of the range's bounding box. Building selects medians
//! with `select_nth_unstable` (O(n) each, O(n log n) in all), splitting large ranges over
//! rayon; the result depends only on the input, not on the number of threads.
//!
//! Queries:
//! - [`KdTree::k_nearest`]: the k nearest items within a maximum radius that pass a filter,
//!   the farthest first (a bounded max-heap during the search) — Jensen's N-nearest search with
//!   the normal / back-side test of the radiance estimate as the filter.
//! - [`KdTree::nearest_where`]: the nearest item passing a predicate — Christensen's lookup of
//!   the nearest photon with a similar normal [Christensen 1999, §2.2].
//! - [`KdTree::for_each_within`]: every item within a radius, in no particular order.
//!
//! Radii are inclusive: an item at distance exactly `max_radius` is found.

use glam::Vec3;

/// Anything with a position can live in the tree.
pub trait KdPoint {
    fn position(&self) -> Vec3;
}

impl KdPoint for Vec3 {
    #[inline]
    fn position(&self) -> Vec3 {
        *self
    }
}

impl KdPoint for [f32; 3] {
    #[inline]
    fn position(&self) -> Vec3 {
        Vec3::from_array(*self)
    }
}

impl KdPoint for super::Photon {
    #[inline]
    fn position(&self) -> Vec3 {
        Vec3::from_array(self.position)
    }
}

/// Ranges with at most this many items are leaves. 12 measured 1.2–1.5× kiddo's k-NN rate
/// on `benches/kdtree.rs`, 6 only 1.1×.
pub const LEAF_SIZE: usize = 12;

/// Ranges larger than this are split in parallel while building.
const PARALLEL_BUILD: usize = 1 << 15;

/// Enough for any tree that fits in memory: each level of the descent leaves at most one
/// range on the stack.
const STACK: usize = 64;

/// A found item: its index in [`KdTree::items`] and its squared distance to the query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbour {
    pub index: u32,
    pub dist2: f32,
}

/// The tree; see the module doc.
#[derive(Clone, Debug)]
pub struct KdTree<T> {
    items: Vec<T>,
    /// Split axis (0, 1, 2) of the node at each index; unused for leaf items.
    axes: Vec<u8>,
}

impl<T: KdPoint + Send> KdTree<T> {
    /// Builds the tree, reordering `items` (their new order is [`KdTree::items`]).
    /// Panics if there are more than `u32::MAX` items.
    pub fn build(mut items: Vec<T>) -> Self {
        assert!(
            items.len() <= u32::MAX as usize,
            "a kd-tree holds at most 2³² − 1 items"
        );
        let mut axes = vec![0u8; items.len()];
        build_range(&mut items, &mut axes);
        Self { items, axes }
    }
}

fn build_range<T: KdPoint + Send>(items: &mut [T], axes: &mut [u8]) {
    let n = items.len();
    if n <= LEAF_SIZE {
        return;
    }
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for it in items.iter() {
        let p = it.position();
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let ext = hi - lo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let mid = n / 2;
    items.select_nth_unstable_by(mid, |a, b| a.position()[axis].total_cmp(&b.position()[axis]));
    axes[mid] = axis as u8;
    let (left, rest) = items.split_at_mut(mid);
    let right = &mut rest[1..];
    let (axes_left, axes_rest) = axes.split_at_mut(mid);
    let axes_right = &mut axes_rest[1..];
    if n > PARALLEL_BUILD {
        rayon::join(|| build_range(left, axes_left), || build_range(right, axes_right));
    } else {
        build_range(left, axes_left);
        build_range(right, axes_right);
    }
}

/// The bounded max-heap of the k-nearest search, ordered by `dist2`.
struct MaxHeap<'a> {
    v: &'a mut Vec<Neighbour>,
    k: usize,
}

impl MaxHeap<'_> {
    #[inline]
    fn push(&mut self, n: Neighbour) {
        let v = &mut *self.v;
        if v.len() < self.k {
            // Sift up.
            v.push(n);
            let mut i = v.len() - 1;
            while i > 0 {
                let parent = (i - 1) / 2;
                if v[parent].dist2 >= n.dist2 {
                    break;
                }
                v[i] = v[parent];
                i = parent;
            }
            v[i] = n;
        } else {
            // Replace the root and sift down.
            let len = v.len();
            let mut i = 0;
            loop {
                let l = 2 * i + 1;
                if l >= len {
                    break;
                }
                let r = l + 1;
                let c = if r < len && v[r].dist2 > v[l].dist2 { r } else { l };
                if v[c].dist2 <= n.dist2 {
                    break;
                }
                v[i] = v[c];
                i = c;
            }
            v[i] = n;
        }
    }
}

impl<T: KdPoint> KdTree<T> {
    /// The items, in tree order; [`Neighbour::index`] indexes this slice.
    #[inline]
    pub fn items(&self) -> &[T] {
        &self.items
    }

    /// The items, in tree order (for updating their payload; moving them breaks the tree, so
    /// only change what [`KdPoint::position`] does not read).
    #[inline]
    pub fn items_mut(&mut self) -> &mut [T] {
        &mut self.items
    }

    pub fn into_items(self) -> Vec<T> {
        self.items
    }

    #[inline]
    pub fn len(&self) -> usize {
        self.items.len()
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Heap bytes used by the tree beyond the items themselves.
    pub fn overhead_bytes(&self) -> usize {
        self.axes.len()
    }

    /// Core of every query: visits, nearest subtrees first, every item whose squared distance
    /// to `p` is ≤ the bound that `visit` returns (initially `bound2`); `visit` gets the index
    /// and squared distance and returns the new bound (it may only shrink).
    #[inline]
    fn search(&self, p: Vec3, bound2: f32, mut visit: impl FnMut(u32, f32) -> f32) {
        let mut bound2 = bound2;
        if self.items.is_empty() || bound2.is_nan() || bound2 < 0.0 {
            return;
        }
        let mut stack = [(0u32, 0u32, 0f32); STACK];
        let mut top = 0usize;
        stack[0] = (0, self.items.len() as u32, 0.0);
        top += 1;
        while top > 0 {
            top -= 1;
            let (mut lo, mut hi, plane2) = stack[top];
            if plane2 > bound2 {
                continue;
            }
            loop {
                let n = (hi - lo) as usize;
                if n <= LEAF_SIZE {
                    for i in lo..hi {
                        let d2 = (self.items[i as usize].position() - p).length_squared();
                        if d2 <= bound2 {
                            bound2 = visit(i, d2);
                        }
                    }
                    break;
                }
                let mid = lo + (hi - lo) / 2;
                let q = self.items[mid as usize].position();
                let d2 = (q - p).length_squared();
                if d2 <= bound2 {
                    bound2 = visit(mid, d2);
                }
                let axis = self.axes[mid as usize] as usize;
                let delta = p[axis] - q[axis];
                let (near, far) = if delta < 0.0 {
                    ((lo, mid), (mid + 1, hi))
                } else {
                    ((mid + 1, hi), (lo, mid))
                };
                let far2 = delta * delta;
                if far.0 < far.1 && far2 <= bound2 {
                    debug_assert!(top < STACK);
                    stack[top] = (far.0, far.1, far2);
                    top += 1;
                }
                if near.0 >= near.1 {
                    break;
                }
                (lo, hi) = near;
            }
        }
    }

    /// The (up to) `k` nearest items within `max_radius` of `p` for which `filter` holds,
    /// written to `out` (cleared first; reuse it to avoid an allocation per query) in max-heap
    /// order: `out[0]` is the farthest, the rest in no useful order. Ties at equal distance are
    /// broken arbitrarily but deterministically. Density estimates and Jensen's grid only sum
    /// over the set, so they skip the sort of [`KdTree::k_nearest`].
    pub fn k_nearest_into(
        &self,
        p: Vec3,
        k: usize,
        max_radius: f32,
        mut filter: impl FnMut(&T) -> bool,
        out: &mut Vec<Neighbour>,
    ) {
        out.clear();
        if k == 0 {
            return;
        }
        out.reserve(k.min(self.items.len()));
        let mut heap = MaxHeap { v: out, k };
        let max_r2 = max_radius * max_radius;
        self.search(p, max_r2, |index, dist2| {
            let full = heap.v.len() == heap.k;
            if (!full || dist2 < heap.v[0].dist2) && filter(&self.items[index as usize]) {
                heap.push(Neighbour { index, dist2 });
            }
            if heap.v.len() == heap.k {
                heap.v[0].dist2
            } else {
                max_r2
            }
        });
    }

    /// [`KdTree::k_nearest_into`] into a new vector, sorted by increasing distance.
    pub fn k_nearest(&self, p: Vec3, k: usize, max_radius: f32, filter: impl FnMut(&T) -> bool) -> Vec<Neighbour> {
        let mut out = Vec::new();
        self.k_nearest_into(p, k, max_radius, filter, &mut out);
        out.sort_unstable_by(|a, b| a.dist2.total_cmp(&b.dist2));
        out
    }

    /// The nearest item within `max_radius` of `p` that satisfies `predicate`
    /// [Christensen 1999, §2.2: nearest photon with a similar normal].
    pub fn nearest_where(&self, p: Vec3, max_radius: f32, mut predicate: impl FnMut(&T) -> bool) -> Option<Neighbour> {
        let mut best: Option<Neighbour> = None;
        self.search(p, max_radius * max_radius, |index, dist2| {
            let bound = best.map_or(f32::INFINITY, |b| b.dist2);
            if dist2 < bound && predicate(&self.items[index as usize]) {
                best = Some(Neighbour { index, dist2 });
                return dist2;
            }
            bound.min(max_radius * max_radius)
        });
        best
    }

    /// Calls `visit(index, dist2)` for every item within `radius` of `p`, in no particular order.
    pub fn for_each_within(&self, p: Vec3, radius: f32, mut visit: impl FnMut(u32, f32)) {
        let r2 = radius * radius;
        self.search(p, r2, |index, dist2| {
            visit(index, dist2);
            r2
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn random_points(n: usize, seed: u64, duplicates: bool) -> Vec<Vec3> {
        let mut rng = Rng::for_task(seed, [0, 0, 0]);
        let mut pts: Vec<Vec3> = (0..n)
            .map(|_| Vec3::new(rng.uniform(), rng.uniform() * 0.5, rng.uniform() * 2.0))
            .collect();
        if duplicates {
            // Many exact duplicates and points sharing one coordinate (ties at every split).
            for i in 0..n {
                if i % 3 == 0 {
                    pts[i] = pts[i / 5];
                } else if i % 3 == 1 {
                    pts[i].x = 0.5;
                }
            }
        }
        pts
    }

    fn brute_force(pts: &[Vec3], p: Vec3, k: usize, r: f32, keep: impl Fn(&Vec3) -> bool) -> Vec<f32> {
        let mut d: Vec<f32> = pts
            .iter()
            .filter(|q| keep(q))
            .map(|q| (*q - p).length_squared())
            .filter(|&d2| d2 <= r * r)
            .collect();
        d.sort_by(f32::total_cmp);
        d.truncate(k);
        d
    }

    fn check_k_nearest(pts: &[Vec3], seed: u64) {
        let tree = KdTree::build(pts.to_vec());
        let mut sorted_in = pts.to_vec();
        let mut sorted_tree = tree.items().to_vec();
        sorted_in.sort_by(|a, b| a.to_array().partial_cmp(&b.to_array()).unwrap());
        sorted_tree.sort_by(|a, b| a.to_array().partial_cmp(&b.to_array()).unwrap());
        assert_eq!(sorted_in, sorted_tree, "the tree holds exactly the input");
        let mut rng = Rng::for_task(seed, [1, 0, 0]);
        let mut out = Vec::new();
        for q in 0..300 {
            let p = Vec3::new(
                rng.uniform() * 1.4 - 0.2,
                rng.uniform() * 0.7 - 0.1,
                rng.uniform() * 2.4 - 0.2,
            );
            let p = if q % 10 == 0 && !pts.is_empty() {
                pts[q % pts.len()]
            } else {
                p
            };
            let k = [1usize, 2, 7, 50, 1000][q % 5];
            let r = [0.01f32, 0.1, 0.3, f32::INFINITY][q % 4];
            let filtered = q % 3 == 0;
            let keep = |v: &Vec3| !filtered || v.z > 0.7;
            tree.k_nearest_into(p, k, r, keep, &mut out);
            if let Some(first) = out.first() {
                assert!(
                    out.iter().all(|n| n.dist2 <= first.dist2),
                    "heap order: the farthest first"
                );
            }
            let mut got: Vec<f32> = out.iter().map(|n| n.dist2).collect();
            got.sort_unstable_by(f32::total_cmp);
            let want = brute_force(pts, p, k, r, keep);
            assert_eq!(got, want, "query {q}: k {k}, r {r}, filtered {filtered}");
            let mut idx: Vec<u32> = out.iter().map(|n| n.index).collect();
            for n in &out {
                let it = tree.items()[n.index as usize];
                assert_eq!((it - p).length_squared(), n.dist2);
                assert!(keep(&it));
            }
            idx.sort_unstable();
            idx.dedup();
            assert_eq!(idx.len(), out.len(), "no item is returned twice");
        }
    }

    #[test]
    fn k_nearest_matches_brute_force_on_random_points() {
        for (n, seed) in [(2_000usize, 1u64), (37, 2), (7, 3), (6, 4), (100_000, 5)] {
            check_k_nearest(&random_points(n, seed, false), seed);
        }
    }

    #[test]
    fn k_nearest_matches_brute_force_with_duplicate_points() {
        check_k_nearest(&random_points(3_000, 6, true), 6);
        check_k_nearest(&vec![Vec3::splat(0.25); 500], 7);
    }

    #[test]
    fn empty_and_single_point_trees() {
        let empty: KdTree<Vec3> = KdTree::build(Vec::new());
        assert!(empty.is_empty());
        assert!(empty.k_nearest(Vec3::ZERO, 5, f32::INFINITY, |_| true).is_empty());
        assert!(empty.nearest_where(Vec3::ZERO, f32::INFINITY, |_| true).is_none());
        let one = KdTree::build(vec![Vec3::new(1.0, 2.0, 3.0)]);
        let r = one.k_nearest(Vec3::ZERO, 5, f32::INFINITY, |_| true);
        assert_eq!(r, vec![Neighbour { index: 0, dist2: 14.0 }]);
        assert!(
            one.k_nearest(Vec3::ZERO, 5, 3.7, |_| true).is_empty(),
            "outside the radius"
        );
        assert_eq!(
            one.k_nearest(Vec3::ZERO, 5, 14f32.sqrt(), |_| true).len(),
            1,
            "inclusive"
        );
        assert!(one.k_nearest(Vec3::ZERO, 0, f32::INFINITY, |_| true).is_empty());
        assert!(one.k_nearest(Vec3::ZERO, 1, f32::NAN, |_| true).is_empty());
    }

    #[test]
    fn nearest_where_matches_brute_force() {
        let pts = random_points(20_000, 8, true);
        let tree = KdTree::build(pts.clone());
        let mut rng = Rng::for_task(8, [2, 0, 0]);
        for q in 0..500 {
            let p = Vec3::new(rng.uniform(), rng.uniform() * 0.5, rng.uniform() * 2.0);
            let r = [0.02f32, 0.2, f32::INFINITY][q % 3];
            // A selective predicate: about 1 point in 40 passes.
            let keep = |v: &Vec3| ((v.x * 1000.0) as u32).is_multiple_of(40);
            let got = tree.nearest_where(p, r, keep).map(|n| n.dist2);
            let want = brute_force(&pts, p, 1, r, keep).first().copied();
            assert_eq!(got, want, "query {q}");
        }
        assert!(tree.nearest_where(Vec3::ZERO, f32::INFINITY, |_| false).is_none());
    }

    #[test]
    fn for_each_within_visits_exactly_the_points_in_the_ball() {
        let pts = random_points(5_000, 9, true);
        let tree = KdTree::build(pts.clone());
        for (i, r) in [(0usize, 0.05f32), (17, 0.2), (400, 0.0)] {
            let p = pts[i];
            let mut got = Vec::new();
            tree.for_each_within(p, r, |_, d2| got.push(d2));
            got.sort_by(f32::total_cmp);
            assert_eq!(got, brute_force(&pts, p, usize::MAX, r, |_| true));
        }
    }

    #[test]
    fn build_is_deterministic_across_thread_counts() {
        let pts = random_points(200_000, 10, true);
        let build = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| KdTree::build(pts.clone()))
        };
        let (a, b) = (build(1), build(2));
        assert_eq!(a.items(), b.items());
        assert_eq!(a.axes, b.axes);
    }
}
