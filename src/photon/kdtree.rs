//! A balanced, pointer-free kd-tree over points [Bentley 1975], as the photon map uses it
//! [Jensen 1996; Christensen 1999, §1.2].
//!
//! Layout: a complete binary tree of median splits whose leaves are buckets of at most
//! [`LEAF_SIZE`] items ([`NEAREST_LEAF_SIZE`] for trees built for nearest-item lookups). The
//! items are reordered so that every leaf is a contiguous range (the root holds `0..n`, a
//! node's range `lo..hi` splits at `mid = lo + (hi − lo) / 2`; each leaf's start is kept in a
//! table, so that descents carry no ranges), and all leaves lie at the same depth, so the inner
//! nodes need no pointers: node k's children are 2k + 1 and 2k + 2, and each stores only
//! its split plane (a coordinate and an axis). Items left of `mid` have a coordinate ≤ the
//! split, items right of it ≥. The positions are also kept apart in [`Lanes3`] blocks, each
//! leaf's in blocks of its own (padded with infinities: leaf `l` owns blocks
//! `l·B .. (l + 1)·B`, B = leaf size / [`LANES`]), so that a leaf's squared distances are
//! computed [`LANES`] at a time in SIMD registers from one contiguous stretch of memory and
//! only the items within the search bound are read.
//!
//! Why buckets: the earlier tree (every node an item, leaves of 12) computed a distance at
//! every inner node of the descent, one at a time; profiles of the final gather and of Jensen's
//! grid put half their time in that descent (docs/design.md, "Performance").
//!
//! The split axis is the longest side of the range's bounding box. Building selects medians
//! with `select_nth_unstable` (O(n) each, O(n log n) in all), splitting large ranges over
//! rayon; the result depends only on the input, not on the number of threads.
//!
//! Queries:
//! - [`KdTree::k_nearest`]: the k nearest items within a maximum radius that pass a filter
//!   (candidates collected unsorted, cut back to the k nearest by selection whenever 2k are
//!   held) — Jensen's N-nearest search with the normal / back-side test of the radiance
//!   estimate as the filter. Its first bound is guessed from the density of the query's leaf
//!   (a disc of about 2k items of a surface that dense), searched again with a larger guess
//!   and then without one when fewer than k pass within it, so that the candidates are few
//!   from the start;
//!   [`KdTree::k_nearest_slots`] names the items found by their place in the blocks, for
//!   callers that read a payload laid out as the positions are.
//! - [`KdTree::nearest_where`]: the nearest item passing a predicate — Christensen's lookup of
//!   the nearest photon with a similar normal [Christensen 1999, §2.2].
//! - [`KdTree::for_each_within`]: every item within a radius, in no particular order.
//! - [`KdTree::search_blocks`]: the search itself, handing whole leaf blocks to the caller,
//!   for queries that test a payload laid out as the positions are ([`KdTree::lanes_of`]) —
//!   [`super::facing::FacingTree`] tests normals so, eight at a time.
//!
//! Radii are inclusive: an item at distance exactly `max_radius` is found. Squared distances
//! are (dx² + dy²) + dz², in this order, as glam's `length_squared` computes them.

use glam::Vec3;
use wide::f32x8;

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

/// Distances computed together (one SIMD register of `wide::f32x8`).
pub const LANES: usize = 8;

/// Leaves of [`KdTree::build`] hold at most this many items, two SIMD batches of distances:
/// k = 50 searches ran 1.1× faster than with leaves of 8 (`bench perf --spp 4`, twice).
pub const LEAF_SIZE: usize = 2 * LANES;

/// Leaves of [`KdTree::build_for_nearest`]: one SIMD batch. A nearest-item search visits few
/// leaves, so a shallower tree buys less than the extra distances cost (the precomputed
/// lookups of `photon_guided` ran 1.1× faster than with leaves of 16).
pub const NEAREST_LEAF_SIZE: usize = LANES;

/// Ranges larger than this are split in parallel while building.
const PARALLEL_BUILD: usize = 1 << 15;

/// Enough for any tree that fits in memory: each level of the descent leaves at most one
/// node on the stack.
const STACK: usize = 64;

/// The k-nearest search's first bound is a disc holding about this many times k items of a
/// surface as dense as the query's leaf. Measured (`bench perf --spp 4`, `cargo bench --bench
/// kdtree -- knn`): 2 gave 1.1–1.2× the k = 50 queries/s of no guess; 1.5 and 3 less; a
/// second search was needed for 6 % of unfiltered queries and 22 % of Jensen's side-filtered
/// ones (photons on the other side thin the leaf's density).
const GUESS_SCALE: f32 = 2.0;

/// A found item: its index in [`KdTree::items`] and its squared distance to the query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbour {
    pub index: u32,
    pub dist2: f32,
}

/// A vector per item for [`LANES`] items, one array per coordinate (32-byte aligned, so that
/// each array is one SIMD load).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Lanes3 {
    pub x: [f32; LANES],
    pub y: [f32; LANES],
    pub z: [f32; LANES],
}

impl Lanes3 {
    pub const fn splat(v: f32) -> Self {
        Self {
            x: [v; LANES],
            y: [v; LANES],
            z: [v; LANES],
        }
    }

    fn set(&mut self, lane: usize, v: Vec3) {
        (self.x[lane], self.y[lane], self.z[lane]) = (v.x, v.y, v.z);
    }

    /// The lanes' dot products with `n`, summed in glam's order ((x + y) + z), so that they
    /// equal `Vec3::dot` bit for bit.
    #[inline]
    pub fn dot(&self, n: Vec3) -> f32x8 {
        let c = |a: [f32; LANES], q: f32| f32x8::from(a) * f32x8::splat(q);
        (c(self.x, n.x) + c(self.y, n.y)) + c(self.z, n.z)
    }

    /// The lanes' squared distances to `p`, as glam's `length_squared` of the difference.
    #[inline]
    pub fn distance2(&self, p: Vec3) -> f32x8 {
        let d = |a: [f32; LANES], q: f32| f32x8::from(a) - f32x8::splat(q);
        let (dx, dy, dz) = (d(self.x, p.x), d(self.y, p.y), d(self.z, p.z));
        (dx * dx + dy * dy) + dz * dz
    }
}

/// The tree; see the module doc.
#[derive(Clone, Debug)]
pub struct KdTree<T> {
    items: Vec<T>,
    /// Item positions, [`KdTree::blocks_per_leaf`] blocks per leaf in leaf order, the lanes
    /// past a leaf's items at infinity.
    blocks: Vec<Lanes3>,
    blocks_per_leaf: u32,
    /// Area of surface per item around each leaf (the product of its items' two largest box
    /// extents over their count; ∞, i.e. no guess, where that is 0): the k-nearest search's
    /// first guess of its radius.
    leaf_area: Vec<f32>,
    /// Where each leaf's items start, and the item count last: leaf `l` holds
    /// `leaf_start[l]..leaf_start[l + 1]`. The search reads a leaf's range here instead of
    /// carrying ranges down every descent.
    leaf_start: Vec<u32>,
    /// Split plane of each inner node (heap order): its coordinate as an [`order_key`] and its
    /// axis (0, 1, 2). Every leaf lies below the last of them, at the same depth.
    planes: Vec<(u32, u32)>,
}

/// Depth at which halving `n` items leaves at most `leaf` in every range.
fn leaf_depth(n: usize, leaf: usize) -> u32 {
    let mut depth = 0;
    while n.div_ceil(1 << depth) > leaf {
        depth += 1;
    }
    depth
}

impl<T: KdPoint + Send> KdTree<T> {
    /// Builds the tree for k-nearest and radius queries, reordering `items` (their new order
    /// is [`KdTree::items`]). Panics if there are more than `u32::MAX` items.
    pub fn build(items: Vec<T>) -> Self {
        Self::build_with_leaves(items, LEAF_SIZE)
    }

    /// Builds the tree for [`KdTree::nearest_where`] queries (smaller leaves).
    pub fn build_for_nearest(items: Vec<T>) -> Self {
        Self::build_with_leaves(items, NEAREST_LEAF_SIZE)
    }

    fn build_with_leaves(mut items: Vec<T>, leaf: usize) -> Self {
        assert!(
            items.len() <= u32::MAX as usize,
            "a kd-tree holds at most 2³² − 1 items"
        );
        let depth = leaf_depth(items.len(), leaf);
        // Each split's plane, recorded at its median's index when it is made (per-item arrays
        // split into disjoint halves for the parallel build), then gathered into heap order.
        let mut planes = vec![(0.0f32, 0u8); items.len()];
        build_range(&mut items, &mut planes, depth);
        let inner = (1usize << depth) - 1;
        let mut node_planes = vec![(0u32, 0u32); inner];
        let mut leaf_area = vec![f32::INFINITY; inner + 1];
        let mut leaf_start = vec![items.len() as u32; inner + 2];
        for_each_node(inner, items.len() as u32, |node, lo, hi| {
            if node >= inner {
                leaf_start[node - inner] = lo;
            }
            if node < inner {
                let mid = (lo + (hi - lo) / 2) as usize;
                node_planes[node] = (order_key(planes[mid].0), planes[mid].1 as u32);
            } else if hi > lo {
                let (mut a, mut b) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
                for it in &items[lo as usize..hi as usize] {
                    (a, b) = (a.min(it.position()), b.max(it.position()));
                }
                let mut e = (b - a).to_array();
                e.sort_by(f32::total_cmp);
                let area = e[1] * e[2] / (hi - lo) as f32;
                // Coincident or collinear items give no density to guess from.
                if area > 0.0 {
                    leaf_area[node - inner] = area;
                }
            }
        });
        let mut tree = Self {
            items,
            blocks: Vec::new(),
            blocks_per_leaf: leaf.div_ceil(LANES) as u32,
            leaf_area,
            leaf_start,
            planes: node_planes,
        };
        tree.blocks = tree.lanes_of(KdPoint::position, f32::INFINITY);
        assert!(
            tree.blocks.len() * LANES <= u32::MAX as usize,
            "a kd-tree's slots are numbered in 32 bits"
        );
        tree
    }
}

/// Orders `items` into the subtree of `levels` more splits: the median on the longest axis of
/// the range's box goes to the middle, the lower half left of it, the upper half from it on.
fn build_range<T: KdPoint + Send>(items: &mut [T], planes: &mut [(f32, u8)], levels: u32) {
    let n = items.len();
    if levels == 0 || n < 2 {
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
    planes[mid] = (items[mid].position()[axis], axis as u8);
    let (left, right) = items.split_at_mut(mid);
    let (planes_left, planes_right) = planes.split_at_mut(mid);
    if n > PARALLEL_BUILD {
        rayon::join(
            || build_range(left, planes_left, levels - 1),
            || build_range(right, planes_right, levels - 1),
        );
    } else {
        build_range(left, planes_left, levels - 1);
        build_range(right, planes_right, levels - 1);
    }
}

/// Calls `visit(node, lo, hi)` for every node of the complete tree with `inner` inner nodes over
/// `n` items (leaves are the nodes from `inner` on), with the item range the descent gives it.
fn for_each_node(inner: usize, n: u32, mut visit: impl FnMut(usize, u32, u32)) {
    let mut todo = vec![(0usize, 0u32, n)];
    while let Some((node, lo, hi)) = todo.pop() {
        visit(node, lo, hi);
        if node < inner {
            let mid = lo + (hi - lo) / 2;
            todo.push((2 * node + 1, lo, mid));
            todo.push((2 * node + 2, mid, hi));
        }
    }
}

/// The float's bits as an integer that orders as the float does, for every float but NaN
/// (−0 taken as +0, so that equal floats have equal keys): a ≥ b ⇔ key(a) ≥ key(b).
#[inline]
fn order_key(f: f32) -> u32 {
    let bits = (f + 0.0).to_bits();
    bits ^ (((bits as i32) >> 31) as u32 | 0x8000_0000)
}

/// The float of an [`order_key`].
#[inline]
fn from_order_key(key: u32) -> f32 {
    f32::from_bits(key ^ (!(((key as i32) >> 31) as u32) | 0x8000_0000))
}

/// Swaps the farthest of `found` to its front (the k-nearest queries' output order).
fn put_farthest_first(found: &mut [Neighbour]) {
    if let Some(far) = (0..found.len()).max_by(|&a, &b| found[a].dist2.total_cmp(&found[b].dist2)) {
        found.swap(0, far);
    }
}

/// Moves the `k` smallest of `found` (by `dist2`) to its front, the largest of them at
/// index k − 1. The k-nearest search collects candidates unsorted and calls this once it holds
/// k and then whenever it holds 2k: amortised O(1) per candidate without the unpredictable
/// branches of a heap's sift (a bounded max-heap was 25 % of a k = 50 search's profile).
#[inline]
fn keep_k_nearest(found: &mut [Neighbour], k: usize) {
    // Squared distances are ≥ 0 and never NaN here, so their bits order as they do.
    found.select_nth_unstable_by_key(k - 1, |n| n.dist2.to_bits());
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

    /// Positions of one block of [`KdTree::search_blocks`].
    #[inline]
    pub fn block(&self, block: usize) -> &Lanes3 {
        &self.blocks[block]
    }

    /// Heap bytes used by the tree beyond the items themselves.
    pub fn overhead_bytes(&self) -> usize {
        self.blocks.len() * size_of::<Lanes3>() + self.planes.len() * 8 + self.leaf_start.len() * 4
    }

    /// A vector per item (`value`) laid out as the tree lays out positions: the blocks of
    /// leaf `l` are `l·B .. (l + 1)·B`, lanes past the leaf's items set to `pad`. For payloads
    /// a query tests [`LANES`] at a time beside the distances (see [`KdTree::search_blocks`]).
    pub fn lanes_of(&self, value: impl Fn(&T) -> Vec3, pad: f32) -> Vec<Lanes3> {
        let mut blocks = vec![Lanes3::splat(pad); self.block_count()];
        self.for_each_slot(|block, lane, item| blocks[block].set(lane, value(item)));
        blocks
    }

    /// A value per item in the block layout of [`KdTree::lanes_of`] (lanes past a leaf's items
    /// set to `pad`): `slots_of(..)[block][lane]` belongs to the item in that slot.
    pub fn slots_of<V: Copy>(&self, value: impl Fn(&T) -> V, pad: V) -> Vec<[V; LANES]> {
        let mut blocks = vec![[pad; LANES]; self.block_count()];
        self.for_each_slot(|block, lane, item| blocks[block][lane] = value(item));
        blocks
    }

    fn block_count(&self) -> usize {
        (self.planes.len() + 1) * self.blocks_per_leaf as usize
    }

    /// Calls `f(block, lane, item)` for every item's slot in the block layout.
    fn for_each_slot(&self, mut f: impl FnMut(usize, usize, &T)) {
        let (inner, per_leaf) = (self.planes.len(), self.blocks_per_leaf as usize);
        for_each_node(inner, self.items.len() as u32, |node, lo, hi| {
            if node >= inner {
                let first = (node - inner) * per_leaf;
                for (j, item) in self.items[lo as usize..hi as usize].iter().enumerate() {
                    f(first + j / LANES, j % LANES, item);
                }
            }
        });
    }

    /// Core of every query: visits, nearest subtrees first, every item whose squared distance
    /// to `p` is ≤ the bound that `visit` returns (initially `bound2`); `visit` gets the index
    /// and squared distance and returns the new bound (it may only shrink).
    #[inline]
    fn search(&self, p: Vec3, bound2: f32, mut visit: impl FnMut(u32, f32) -> f32) {
        self.search_blocks(p, bound2, |block, start, len, bound2| {
            self.visit_block(p, block, start, len, bound2, &mut visit)
        });
    }

    /// The search itself: calls `leaf(block, start, len, bound2)` for every block of a leaf
    /// whose cell is within the bound, nearest leaves first — `block` indexes
    /// [`KdTree::lanes_of`]'s layout, its lanes `0..len` hold items `start..start + len` —
    /// and takes the bound it returns (it may only shrink).
    #[inline]
    pub fn search_blocks(&self, p: Vec3, bound2: f32, mut leaf: impl FnMut(usize, u32, u32, f32) -> f32) {
        let mut bound2 = bound2;
        if self.items.is_empty() || bound2.is_nan() || bound2 < 0.0 {
            return;
        }
        let inner = self.planes.len();
        let q = p.to_array();
        let kq = q.map(order_key);
        // (node, squared distance to its slab); the root first.
        let mut stack = [(0u32, 0f32); STACK];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let (mut node, plane2) = stack[top];
            if plane2 > bound2 {
                continue;
            }
            while (node as usize) < inner {
                // Branch-free descent (the side taken is unpredictable): the near child is
                // the right one when the query is on the split's upper side; the far one is
                // kept when its slab is within the bound. No item range is carried down: the
                // leaf's comes from `leaf_start` (8 fewer instructions a level, 8-byte stack
                // entries).
                let (key, axis) = self.planes[node as usize];
                // The side is decided on integer keys picked by conditional moves: the chain
                // from one level's load to the next is then load, two moves, a compare (1.45×
                // faster nearest lookups than indexing the query by the axis and subtracting
                // floats on that chain). The float distance to the plane is off the chain.
                let qa = if axis == 0 { kq[0] } else { kq[1] };
                let qa = if axis == 2 { kq[2] } else { qa };
                let right = qa >= key;
                let delta = q[axis as usize] - from_order_key(key);
                let far2 = delta * delta;
                stack[top] = (2 * node + 2 - right as u32, far2);
                top += (far2 <= bound2) as usize;
                node = 2 * node + 1 + right as u32;
            }
            let l = node as usize - inner;
            let (lo, hi) = (self.leaf_start[l], self.leaf_start[l + 1]);
            let first = l * self.blocks_per_leaf as usize;
            for (b, start) in (lo..hi).step_by(LANES).enumerate() {
                bound2 = leaf(first + b, start, (hi - start).min(LANES as u32), bound2);
            }
        }
    }

    /// Squared distances from `p` to the items of a block, and the bit mask of its first `len`
    /// lanes within `bound2`.
    #[inline]
    fn within_bound(&self, p: Vec3, block: usize, len: u32, bound2: f32) -> (f32x8, u32) {
        let d2 = self.blocks[block].distance2(p);
        (d2, d2.simd_le(f32x8::splat(bound2)).to_bitmask() & ((1u32 << len) - 1))
    }

    /// Distances from `p` to the items of one block ([`LANES`] at once), then `visit` for
    /// those within the bound, in item order; returns the bound after the visits.
    #[inline]
    fn visit_block(
        &self,
        p: Vec3,
        block: usize,
        start: u32,
        len: u32,
        mut bound2: f32,
        visit: &mut impl FnMut(u32, f32) -> f32,
    ) -> f32 {
        let (d2, mut within) = self.within_bound(p, block, len, bound2);
        if within == 0 {
            return bound2;
        }
        let d2 = d2.to_array();
        while within != 0 {
            let i = within.trailing_zeros() as usize;
            within &= within - 1;
            if d2[i] <= bound2 {
                bound2 = visit(start + i as u32, d2[i]);
            }
        }
        bound2
    }

    /// The (up to) `k` nearest items within `max_radius` of `p` for which `filter` holds,
    /// written to `out` (cleared first; reuse it to avoid an allocation per query): `out[0]` is
    /// the farthest, the rest in no useful order. Ties at equal distance are broken
    /// arbitrarily but deterministically. Density estimates and Jensen's grid only sum over the
    /// set, so they skip the sort of [`KdTree::k_nearest`].
    pub fn k_nearest_into(
        &self,
        p: Vec3,
        k: usize,
        max_radius: f32,
        mut filter: impl FnMut(&T) -> bool,
        out: &mut Vec<Neighbour>,
    ) {
        self.k_nearest_blockwise::<false>(p, k, max_radius, out, |_, start, within| {
            let (mut keep, mut lanes) = (0, within);
            while lanes != 0 {
                let i = lanes.trailing_zeros();
                lanes &= lanes - 1;
                keep |= (filter(&self.items[(start + i) as usize]) as u32) << i;
            }
            keep
        });
    }

    /// [`KdTree::k_nearest_into`] with the filter applied to a whole block at once, and each
    /// item named by its *slot* in the layout of [`KdTree::lanes_of`] (block · [`LANES`] +
    /// lane) instead of its index: `mask(block, start, within)` gets a block of
    /// [`KdTree::search_blocks`] and the bit mask of its lanes within the search bound, and
    /// returns the mask of those that pass. For payloads laid out as the positions are, tested
    /// in SIMD and then read from the blocks the search has just brought into the cache rather
    /// than from the items (whose loads were half of a Jensen grid's build).
    pub fn k_nearest_slots(
        &self,
        p: Vec3,
        k: usize,
        max_radius: f32,
        out: &mut Vec<Neighbour>,
        mask: impl FnMut(usize, u32, u32) -> u32,
    ) {
        self.k_nearest_blockwise::<true>(p, k, max_radius, out, mask);
    }

    /// The k-nearest search of [`KdTree::k_nearest_into`] (`SLOTS` false: items named by
    /// index) and [`KdTree::k_nearest_slots`] (true: by slot).
    fn k_nearest_blockwise<const SLOTS: bool>(
        &self,
        p: Vec3,
        k: usize,
        max_radius: f32,
        out: &mut Vec<Neighbour>,
        mut mask: impl FnMut(usize, u32, u32) -> u32,
    ) {
        out.clear();
        if k == 0 {
            return;
        }
        let max_r2 = max_radius * max_radius;
        let room = k.saturating_mul(2).min(self.items.len());
        out.resize(room + LANES, Neighbour { index: 0, dist2: 0.0 });
        // First with the bound guessed from the density around the query's leaf; when fewer
        // than k items pass within it, once more with the guess grown by what was missing (× 4
        // when nothing passed), then without a guess — at most three searches, also where
        // fewer than k items pass in the whole radius. The k nearest are exact either way: all
        // items within the bound were candidates.
        let guess = GUESS_SCALE * k as f32 / std::f32::consts::PI;
        let mut collect = |guess| self.collect_k_nearest::<SLOTS>(p, k, max_r2, guess, out, &mut mask);
        let count = match collect(guess) {
            Ok(count) => count,
            Err(found) => {
                let grown = guess * if found > 0 { 1.5 * k as f32 / found as f32 } else { 4.0 };
                collect(grown)
                    .or_else(|_| collect(f32::INFINITY))
                    .expect("a search without a guess holds what passes")
            }
        };
        if count > k {
            keep_k_nearest(&mut out[..count], k);
            out.truncate(k);
            // The selection left the farthest of the k at k − 1, the last of any equal ones:
            // where `put_farthest_first`'s scan would find it.
            out.swap(0, k - 1);
        } else {
            out.truncate(count);
            put_farthest_first(out);
        }
    }

    /// The candidate collection of [`KdTree::k_nearest_blockwise`] into `out` (sized 2k + a
    /// block): returns how many it holds, the k nearest (or all passing, if fewer) among the
    /// first k of them when more. The bound starts at `max_r2`, lowered at the query's leaf to
    /// `guess` × that leaf's area per item (a disc holding about `guess` · π items of a surface
    /// of that density); `Err(count)` when that lowered bound held fewer than k passing items,
    /// so the answer may lie beyond it.
    fn collect_k_nearest<const SLOTS: bool>(
        &self,
        p: Vec3,
        k: usize,
        max_r2: f32,
        guess: f32,
        out: &mut [Neighbour],
        mask: &mut impl FnMut(usize, u32, u32) -> u32,
    ) -> std::result::Result<usize, usize> {
        let room = out.len() - LANES;
        // Candidates within the bound are appended unsorted, a block at a time without a branch
        // per lane (every lane is written, the count advances by the passing ones); the bound
        // is the k-th nearest held, found by selection whenever 2k are held — and already once
        // k are when there is no guess (a guessed bound holds about 2k, so selecting at k as
        // well cost a selection per query for nothing: photon_map's direct estimates ran
        // 1.03–1.10× faster without it).
        let (mut count, mut bounded, mut first, mut guessed) = (0usize, false, true, false);
        self.search_blocks(p, max_r2, |block, start, len, mut bound2| {
            if first {
                first = false;
                let r2 = guess * self.leaf_area[block / self.blocks_per_leaf as usize];
                if r2 < bound2 {
                    (bound2, guessed, bounded) = (r2, true, true);
                }
            }
            let (d2, within) = self.within_bound(p, block, len, bound2);
            if within == 0 {
                return bound2;
            }
            let keep = mask(block, start, within) & within;
            let base = if SLOTS { (block * LANES) as u32 } else { start };
            for (i, dist2) in d2.to_array().into_iter().enumerate() {
                out[count] = Neighbour {
                    index: base + i as u32,
                    dist2,
                };
                count += (keep >> i) as usize & 1;
            }
            if count >= k && (count >= room || !bounded) {
                keep_k_nearest(&mut out[..count], k);
                (count, bounded) = (k, true);
                return out[k - 1].dist2;
            }
            bound2
        });
        if count >= k || !guessed { Ok(count) } else { Err(count) }
    }

    /// [`KdTree::k_nearest_into`] for a filter in two parts, `cheap` && `costly`, where
    /// `costly` is expensive (a ray): the k nearest items within `max_radius` passing both,
    /// `out[0]` the farthest. `costly` runs once per item at most, and only on items that
    /// `cheap` passes and that are no farther than the k-th nearest item passing both (all
    /// within `max_radius` when fewer pass): nothing is tested that the answer could do
    /// without. A k-nearest search that filters as it goes tests every item within its bound
    /// before the bound has shrunk to the k-th nearest — about twice as many.
    ///
    /// First the k nearest `cheap` items are found and all tested; while fewer than k passed,
    /// the shell beyond them (its outer radius grown by the pass rate so far) is collected,
    /// sorted by distance and tested in that order until k have passed.
    pub fn k_nearest_tested(
        &self,
        p: Vec3,
        k: usize,
        max_radius: f32,
        mut cheap: impl FnMut(&T) -> bool,
        mut costly: impl FnMut(&T) -> bool,
        out: &mut Vec<Neighbour>,
    ) {
        self.k_nearest_into(p, k, max_radius, &mut cheap, out);
        let held = out.len();
        let Some(mut inner2) = out.iter().map(|n| n.dist2).max_by(f32::total_cmp) else {
            return;
        };
        // Those passing to the front, the others kept behind them until it is known whether
        // a shell follows.
        let mut passed = 0;
        for i in 0..held {
            if costly(&self.items[out[i].index as usize]) {
                out.swap(passed, i);
                passed += 1;
            }
        }
        let max_r2 = max_radius * max_radius;
        // Shells only when k were held (fewer: every item within the radius that `cheap`
        // passes was tested) and fewer than k passed.
        let shells = held == k && passed < k && inner2 < max_r2;
        // Items at the farthest distance the search held: tested, though others at that
        // distance may not be.
        let mut tested_at_inner: Vec<u32> = if shells {
            out.iter().filter(|n| n.dist2 == inner2).map(|n| n.index).collect()
        } else {
            Vec::new()
        };
        out.truncate(passed);
        while shells && out.len() < k && inner2 < max_r2 {
            let passed = out.len();
            let outer2 = if inner2 > 0.0 {
                // Items on a surface grow with r²: about 1.5× the candidates still needed at
                // the pass rate so far, 4× the area when nothing passed yet.
                let grow = if passed > 0 {
                    1.0 + 1.5 * (k - passed) as f32 / passed as f32
                } else {
                    4.0
                };
                (inner2 * grow).min(max_r2)
            } else {
                max_r2
            };
            let mut shell = Vec::new();
            self.search(p, outer2, |index, dist2| {
                let new = dist2 > inner2 || (dist2 == inner2 && !tested_at_inner.contains(&index));
                if new && cheap(&self.items[index as usize]) {
                    shell.push(Neighbour { index, dist2 });
                }
                outer2
            });
            shell.sort_unstable_by_key(|n| (n.dist2.to_bits(), n.index));
            for n in &shell {
                if costly(&self.items[n.index as usize]) {
                    out.push(*n);
                    if out.len() == k {
                        break;
                    }
                }
            }
            tested_at_inner = shell.iter().filter(|n| n.dist2 == outer2).map(|n| n.index).collect();
            inner2 = outer2;
        }
        put_farthest_first(out);
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
#[path = "kdtree_tests.rs"]
mod tests;
