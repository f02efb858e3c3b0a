//! The acceleration structure: a 4-wide bounding volume hierarchy whose node tests and
//! triangle tests run four lanes at a time (the `wide` crate: SSE on x86-64, NEON on aarch64,
//! plain scalar code elsewhere), with closest-hit and shadow (any-hit, early exit) queries.
//!
//! **Why our own traversal.** The renderer used obvhs's compressed wide BVH (CWBVH), a GPU
//! layout whose child boxes are quantised to bytes: every node visit decoded them again, and
//! profiles of `path` put 42 % of its time in that traversal (issue 21). Here the topology still
//! comes from obvhs's PLOC builder (a BVH2 of SAH quality), collapsed to four children per
//! node by repeatedly opening the child of largest surface area, as Embree's BVH4 does; boxes
//! are stored as plain f32, one SIMD lane per child, and each leaf's triangles are packed four to
//! a SIMD block with their edges precomputed.
//!
//! **Exactness.** A block's triangle test is [`intersect_triangle`]'s Möller–Trumbore lane by
//! lane, the same operations in the same order (no fused multiply-add), so distances and
//! barycentrics are bit-identical to the scalar test's. Box tests cannot cull a box the ray
//! meets: boxes are padded by a few ULPs of their coordinates (flat boxes of axis-aligned quads
//! are otherwise missed at grazing angles), the far slab distance is enlarged by 1 + 2γ₃ (pbrt-v4
//! §6.8.2, "Bounds3::IntersectP"), and direction components of zero get a huge finite inverse
//! instead of ∞ so that no slab product is ∞ · 0. Entry distances are clamped at 0, with no
//! absolute epsilon, so geometry any distance from a ray's origin is found at every scale.

use super::Ray;
use super::primitive::{Hit, Primitive, intersect_sphere};
use glam::{Vec2, Vec3, Vec3A};
use obvhs::{Boundable, BvhBuildParams, aabb::Aabb, bvh2::Bvh2};
use std::time::Duration;
use wide::f32x4;

const LANES: usize = 4;
/// A child reference with this bit set is a leaf: a run of [`Block`]s.
const LEAF: u32 = 1 << 31;
/// Bits of a leaf reference that hold its block count minus one.
const COUNT_BITS: u32 = 5;
const MAX_LEAF_BLOCKS: usize = 1 << COUNT_BITS;
/// 1 + 2γ₃ with γₙ = nu / (1 − nu), u = 2⁻²⁴: enlarges a slab's far distance past any rounding
/// of the three operations that computed it (pbrt-v4 §6.8.2 uses the same bound).
const FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// An inner node: the boxes of up to four children, one lane per child. Unused lanes hold an
/// empty box (min +∞, max −∞), which no ray enters whatever its direction.
#[derive(Clone, Copy)]
struct Node {
    /// [min x, max x, min y, max y, min z, max z] of the four children.
    bounds: [f32x4; 6],
    /// Node index, or [`LEAF`] | first block << [`COUNT_BITS`] | (blocks − 1).
    child: [u32; LANES],
}

impl Node {
    const EMPTY: Node = Node {
        bounds: [
            f32x4::splat(f32::INFINITY),
            f32x4::splat(f32::NEG_INFINITY),
            f32x4::splat(f32::INFINITY),
            f32x4::splat(f32::NEG_INFINITY),
            f32x4::splat(f32::INFINITY),
            f32x4::splat(f32::NEG_INFINITY),
        ],
        child: [u32::MAX; LANES],
    };

    fn set_child(&mut self, lane: usize, min: Vec3, max: Vec3, child: u32) {
        let mut b = self.bounds.map(|v| v.to_array());
        for axis in 0..3 {
            b[2 * axis][lane] = min[axis];
            b[2 * axis + 1][lane] = max[axis];
        }
        self.bounds = b.map(f32x4::new);
        self.child[lane] = child;
    }
}

/// Up to four triangles of a leaf, structure of arrays (v₀ and the edges e₁ = v₁ − v₀,
/// e₂ = v₂ − v₀), or one sphere. Unused triangle lanes are all zero: det = 0 rejects them.
enum Block {
    Triangles {
        v0: [f32x4; 3],
        e1: [f32x4; 3],
        e2: [f32x4; 3],
        id: [u32; LANES],
    },
    Sphere {
        center: Vec3,
        radius: f32,
        id: u32,
    },
}

/// A ray prepared for the lanes: origin and direction splatted, the slab planes it meets
/// first per axis (by the sign of the direction) and the inverse direction.
struct Query {
    o: [f32x4; 3],
    d: [f32x4; 3],
    inv_d: [f32x4; 3],
    near: [usize; 3],
    far: [usize; 3],
    ray: Ray,
}

impl Query {
    fn new(ray: &Ray) -> Self {
        let o = ray.o.to_array();
        let d = ray.d.to_array();
        // A zero component gets a huge finite inverse: slab products stay finite or ±∞, never
        // ∞ · 0 = NaN for a ray in a box's face plane.
        let inv = d.map(|x| if x.abs() < 1e-30 { 1e30 } else { 1.0 / x });
        let near = std::array::from_fn(|a| 2 * a + usize::from(inv[a] < 0.0));
        Query {
            o: o.map(f32x4::splat),
            d: d.map(f32x4::splat),
            inv_d: inv.map(f32x4::splat),
            near,
            far: near.map(|n| n ^ 1),
            ray: *ray,
        }
    }

    /// Which of `node`'s children the ray enters within [0, t_max] (a bit per lane), and
    /// the distances at which it enters them.
    #[inline(always)]
    fn enter(&self, node: &Node, t_max: f32) -> (u32, f32x4) {
        let slab = |plane: usize, axis: usize| (node.bounds[plane] - self.o[axis]) * self.inv_d[axis];
        let t_near = slab(self.near[0], 0)
            .fast_max(slab(self.near[1], 1))
            .fast_max(slab(self.near[2], 2).fast_max(f32x4::ZERO));
        let t_far = slab(self.far[0], 0)
            .fast_min(slab(self.far[1], 1))
            .fast_min(slab(self.far[2], 2).fast_min(f32x4::splat(t_max)))
            * f32x4::splat(FAR_SCALE);
        (t_near.simd_le(t_far).to_bitmask(), t_near)
    }

    /// Möller–Trumbore on four triangles, exactly as [`intersect_triangle`] computes it
    /// (glam's cross and dot products, term by term): lanes that hit within (0, t_max), and
    /// every lane's t, b₁, b₂.
    #[inline(always)]
    fn triangles(&self, v0: &[f32x4; 3], e1: &[f32x4; 3], e2: &[f32x4; 3], t_max: f32) -> (u32, [f32x4; 3]) {
        let cross = |a: [f32x4; 3], b: [f32x4; 3]| {
            [
                a[1] * b[2] - b[1] * a[2],
                a[2] * b[0] - b[2] * a[0],
                a[0] * b[1] - b[0] * a[1],
            ]
        };
        let dot = |a: [f32x4; 3], b: [f32x4; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let pvec = cross(self.d, *e2);
        let det = dot(*e1, pvec);
        let inv_det = f32x4::ONE / det;
        let tvec = [self.o[0] - v0[0], self.o[1] - v0[1], self.o[2] - v0[2]];
        let b1 = dot(tvec, pvec) * inv_det;
        let qvec = cross(tvec, *e1);
        let b2 = dot(self.d, qvec) * inv_det;
        let t = dot(*e2, qvec) * inv_det;
        let ok = det.simd_ne(f32x4::ZERO)
            & det.abs().simd_lt(f32x4::splat(f32::INFINITY))
            & b1.simd_ge(f32x4::ZERO)
            & b1.simd_le(f32x4::ONE)
            & b2.simd_ge(f32x4::ZERO)
            & (b1 + b2).simd_le(f32x4::ONE)
            & t.simd_gt(f32x4::ZERO)
            & t.simd_lt(f32x4::splat(t_max));
        (ok.to_bitmask(), [t, b1, b2])
    }
}

/// The traversal stack: 64 entries inline, spilling to the heap only for trees deeper than any
/// a real scene produces (each level pushes at most three entries).
struct Stack {
    inline: [(u32, f32); 64],
    len: usize,
    spill: Vec<(u32, f32)>,
}

impl Stack {
    fn new() -> Self {
        Stack {
            inline: [(0, 0.0); 64],
            len: 0,
            spill: Vec::new(),
        }
    }

    #[inline(always)]
    fn push(&mut self, entry: (u32, f32)) {
        if self.len < self.inline.len() {
            self.inline[self.len] = entry;
            self.len += 1;
        } else {
            self.spill.push(entry);
        }
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        if let Some(e) = self.spill.pop() {
            return Some(e);
        }
        self.len = self.len.checked_sub(1)?;
        Some(self.inline[self.len])
    }
}

struct Bounds(Aabb);

impl Boundable for Bounds {
    fn aabb(&self) -> Aabb {
        self.0
    }
}

/// BVH over a fixed set of primitives.
pub struct Accel {
    nodes: Vec<Node>,
    blocks: Vec<Block>,
    /// The root's reference (always an inner node when there are primitives).
    root: u32,
    primitive_count: usize,
}

impl Accel {
    pub fn build(primitives: &[Primitive]) -> Self {
        let mut accel = Accel {
            nodes: Vec::new(),
            blocks: Vec::new(),
            root: 0,
            primitive_count: primitives.len(),
        };
        if primitives.is_empty() {
            return accel;
        }
        let bounds = padded_bounds(primitives);
        let params = BvhBuildParams {
            max_prims_per_leaf: LANES as u32,
            ..BvhBuildParams::medium_build()
        };
        let bvh2 = obvhs::bvh2::builder::build_bvh2(&bounds, params, &mut Duration::default());
        let root = &bvh2.nodes[0];
        if root.is_leaf() {
            // A single leaf still hangs below an inner node: traversal starts at a node.
            let leaf = accel.leaf(&bvh2, root, primitives);
            let mut node = Node::EMPTY;
            node.set_child(0, root.aabb.min.into(), root.aabb.max.into(), leaf);
            accel.nodes.push(node);
        } else {
            accel.root = accel.collapse(&bvh2, 0, primitives);
        }
        accel
    }

    pub fn len(&self) -> usize {
        self.primitive_count
    }

    pub fn is_empty(&self) -> bool {
        self.primitive_count == 0
    }

    /// Turns the subtree of BVH2 node `index` (an inner node) into 4-wide nodes; returns the
    /// new node's index.
    fn collapse(&mut self, bvh2: &Bvh2, index: usize, primitives: &[Primitive]) -> u32 {
        let first = bvh2.nodes[index].first_index as usize;
        let mut kids = vec![first, first + 1];
        // Open the largest inner child until four children (Embree's BVH4 collapse).
        while kids.len() < LANES {
            let largest = (0..kids.len())
                .filter(|&i| !bvh2.nodes[kids[i]].is_leaf())
                .max_by(|&a, &b| half_area(bvh2, kids[a]).total_cmp(&half_area(bvh2, kids[b])));
            let Some(i) = largest else { break };
            let grand = bvh2.nodes[kids[i]].first_index as usize;
            kids[i] = grand;
            kids.push(grand + 1);
        }
        let slot = self.nodes.len();
        self.nodes.push(Node::EMPTY);
        let mut node = Node::EMPTY;
        for (lane, &k) in kids.iter().enumerate() {
            let n = &bvh2.nodes[k];
            let child = if n.is_leaf() {
                self.leaf(bvh2, n, primitives)
            } else {
                self.collapse(bvh2, k, primitives)
            };
            node.set_child(lane, n.aabb.min.into(), n.aabb.max.into(), child);
        }
        self.nodes[slot] = node;
        slot as u32
    }

    /// Packs a BVH2 leaf's primitives into blocks (triangles four at a time, spheres one per
    /// block); a leaf too large for one reference becomes a node over smaller leaves.
    fn leaf(&mut self, bvh2: &Bvh2, n: &obvhs::bvh2::node::Bvh2Node, primitives: &[Primitive]) -> u32 {
        let range = n.first_index as usize..(n.first_index + n.prim_count) as usize;
        let ids: Vec<u32> = bvh2.primitive_indices[range].to_vec();
        self.leaf_of(&ids, primitives)
    }

    fn leaf_of(&mut self, ids: &[u32], primitives: &[Primitive]) -> u32 {
        let triangles: Vec<u32> = ids
            .iter()
            .copied()
            .filter(|&i| matches!(primitives[i as usize], Primitive::Triangle(_)))
            .collect();
        let spheres = ids.len() - triangles.len();
        let blocks = triangles.len().div_ceil(LANES) + spheres;
        if blocks > MAX_LEAF_BLOCKS {
            let mut node = Node::EMPTY;
            let slot = self.nodes.len();
            self.nodes.push(Node::EMPTY);
            for (lane, part) in ids.chunks(ids.len().div_ceil(LANES)).enumerate() {
                let (min, max) = part.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &i| {
                    let (a, b) = padded(&primitives[i as usize]);
                    (lo.min(a), hi.max(b))
                });
                let child = self.leaf_of(part, primitives);
                node.set_child(lane, min, max, child);
            }
            self.nodes[slot] = node;
            return slot as u32;
        }
        let first = self.blocks.len() as u32;
        assert!(
            first < (1 << (31 - COUNT_BITS)),
            "too many primitives for the BVH's leaf references"
        );
        for quad in triangles.chunks(LANES) {
            self.blocks.push(triangle_block(quad, primitives));
        }
        for &i in ids {
            if let Primitive::Sphere { center, radius } = primitives[i as usize] {
                self.blocks.push(Block::Sphere { center, radius, id: i });
            }
        }
        LEAF | first << COUNT_BITS | (blocks as u32 - 1)
    }

    fn leaf_blocks(&self, leaf: u32) -> &[Block] {
        let first = ((leaf & !LEAF) >> COUNT_BITS) as usize;
        let count = (leaf & (MAX_LEAF_BLOCKS as u32 - 1)) as usize + 1;
        &self.blocks[first..first + count]
    }

    /// Closest hit along `ray` within (0, t_max).
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        let q = Query::new(ray);
        let mut t_max = ray.t_max;
        let mut found: Option<(u32, Vec2)> = None;
        let mut stack = Stack::new();
        let mut current = self.root;
        loop {
            if current & LEAF == 0 {
                let node = &self.nodes[current as usize];
                let (mask, t_near) = q.enter(node, t_max);
                if mask != 0 {
                    current = visit_nearest_first(node, mask, t_near, &mut stack);
                    continue;
                }
            } else {
                for block in self.leaf_blocks(current) {
                    if let Some(hit) = intersect_block(&q, block, t_max) {
                        (t_max, found) = (hit.0, Some((hit.1, hit.2)));
                    }
                }
            }
            // Pop the next entry the ray can still reach before its closest hit so far.
            loop {
                let Some((next, t_enter)) = stack.pop() else {
                    return found.map(|(prim, b)| Hit { t: t_max, prim, b });
                };
                if t_enter <= t_max {
                    current = next;
                    break;
                }
            }
        }
    }

    /// True when nothing blocks `ray` within (0, t_max). Stops at the first blocker.
    pub fn unoccluded(&self, ray: &Ray) -> bool {
        if self.nodes.is_empty() {
            return true;
        }
        let q = Query::new(ray);
        let mut stack = Stack::new();
        stack.push((self.root, 0.0));
        while let Some((current, _)) = stack.pop() {
            if current & LEAF == 0 {
                let node = &self.nodes[current as usize];
                let (mut mask, _) = q.enter(node, ray.t_max);
                while mask != 0 {
                    stack.push((node.child[mask.trailing_zeros() as usize], 0.0));
                    mask &= mask - 1;
                }
            } else if self
                .leaf_blocks(current)
                .iter()
                .any(|b| intersect_block(&q, b, ray.t_max).is_some())
            {
                return false;
            }
        }
        true
    }
}

/// Pushes the entered children of `node` but the nearest, farthest first, and returns the
/// nearest: closest-hit traversal then finds near hits early and prunes far subtrees.
#[inline(always)]
fn visit_nearest_first(node: &Node, mut mask: u32, t_near: f32x4, stack: &mut Stack) -> u32 {
    let t = t_near.to_array();
    if mask & (mask - 1) == 0 {
        return node.child[mask.trailing_zeros() as usize];
    }
    let mut entered = [(0u32, 0f32); LANES];
    let mut n = 0;
    while mask != 0 {
        let lane = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        // Insertion by entry distance, descending, so the nearest ends last.
        let mut j = n;
        while j > 0 && entered[j - 1].1 < t[lane] {
            entered[j] = entered[j - 1];
            j -= 1;
        }
        entered[j] = (node.child[lane], t[lane]);
        n += 1;
    }
    for &e in &entered[..n - 1] {
        stack.push(e);
    }
    entered[n - 1].0
}

/// The closest hit of `q`'s ray with `block` within (0, t_max): (t, input id, barycentrics).
#[inline(always)]
fn intersect_block(q: &Query, block: &Block, t_max: f32) -> Option<(f32, u32, Vec2)> {
    match block {
        Block::Triangles { v0, e1, e2, id } => {
            let (mut mask, [t, b1, b2]) = q.triangles(v0, e1, e2, t_max);
            if mask == 0 {
                return None;
            }
            let (t, b1, b2) = (t.to_array(), b1.to_array(), b2.to_array());
            let mut best = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if t[lane] < t[best] {
                    best = lane;
                }
            }
            Some((t[best], id[best], Vec2::new(b1[best], b2[best])))
        }
        &Block::Sphere { center, radius, id } => {
            intersect_sphere(q.ray.o, q.ray.d, t_max, center, radius).map(|t| (t, id, Vec2::ZERO))
        }
    }
}

fn triangle_block(quad: &[u32], primitives: &[Primitive]) -> Block {
    let mut lanes = [[[0f32; LANES]; 3]; 3];
    let mut id = [u32::MAX; LANES];
    for (lane, &i) in quad.iter().enumerate() {
        let Primitive::Triangle([a, b, c]) = primitives[i as usize] else {
            unreachable!("triangle blocks hold triangles")
        };
        for (k, v) in [a, b - a, c - a].iter().enumerate() {
            for axis in 0..3 {
                lanes[k][axis][lane] = v[axis];
            }
        }
        id[lane] = i;
    }
    let [v0, e1, e2] = lanes.map(|v| v.map(f32x4::new));
    Block::Triangles { v0, e1, e2, id }
}

/// A primitive's box, padded by a few ULPs of its coordinates with a floor relative to
/// nothing but the coordinates themselves (see the module doc).
fn padded(p: &Primitive) -> (Vec3, Vec3) {
    let (lo, hi) = p.aabb_min_max();
    let pad = Vec3::splat(4.0 * f32::EPSILON) * lo.abs().max(hi.abs()) + Vec3::splat(f32::MIN_POSITIVE);
    (lo - pad, hi + pad)
}

fn padded_bounds(primitives: &[Primitive]) -> Vec<Bounds> {
    primitives
        .iter()
        .map(|p| {
            let (lo, hi) = padded(p);
            Bounds(Aabb::new(Vec3A::from(lo), Vec3A::from(hi)))
        })
        .collect()
}

fn half_area(bvh2: &Bvh2, index: usize) -> f32 {
    bvh2.nodes[index].aabb.half_area()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Rng, sample_uniform_sphere};

    fn brute_force(prims: &[Primitive], ray: &Ray) -> Option<(u32, f32)> {
        let mut best: Option<(u32, f32)> = None;
        for (i, p) in prims.iter().enumerate() {
            if let Some((t, _)) = p.intersect(ray.o, ray.d, ray.t_max)
                && best.is_none_or(|(_, bt)| t < bt)
            {
                best = Some((i as u32, t));
            }
        }
        best
    }

    #[test]
    fn bvh_agrees_with_brute_force() {
        let mut rng = Rng::for_task(11, [0, 0, 0]);
        let mut prims = Vec::new();
        for _ in 0..300 {
            let c = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.0 - 2.0;
            let e = |r: &mut Rng| Vec3::new(r.uniform(), r.uniform(), r.uniform()) * 0.4 - 0.2;
            prims.push(Primitive::Triangle([c + e(&mut rng), c + e(&mut rng), c + e(&mut rng)]));
        }
        for _ in 0..40 {
            let c = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.0 - 2.0;
            prims.push(Primitive::Sphere {
                center: c,
                radius: 0.05 + 0.1 * rng.uniform(),
            });
        }
        let accel = Accel::build(&prims);
        let mut hits = 0;
        for _ in 0..4000 {
            let o = sample_uniform_sphere(rng.uniform2()) * 3.0 * rng.uniform();
            let d = sample_uniform_sphere(rng.uniform2());
            let t_max = if rng.uniform() < 0.5 {
                f32::INFINITY
            } else {
                3.0 * rng.uniform()
            };
            let ray = Ray { o, d, t_max };
            let expected = brute_force(&prims, &ray);
            let got = accel.intersect(&ray);
            assert_eq!(expected.map(|e| e.0), got.map(|g| g.prim), "ray {ray:?}");
            if let (Some((_, te)), Some(g)) = (expected, got) {
                assert_eq!(te, g.t);
                hits += 1;
            }
            assert_eq!(accel.unoccluded(&ray), expected.is_none());
        }
        assert!(hits > 200, "the test must exercise hits, got {hits}");
    }

    /// obvhs's CWBVH culled child boxes the ray leaves before t = 10⁻⁴ (in its own units): in
    /// world units that hid a floor 10 µm below a ray's origin, and every surface of a scene
    /// measured in micrometres. Entry distances clamp at 0 with no absolute epsilon: found at
    /// every scale.
    #[test]
    fn hits_closer_than_obvhs_epsilon_are_found_at_every_scale() {
        for s in [1e-6f32, 1e-3, 1.0, 1e3, 1e6] {
            let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z) * s;
            let floor = [
                Primitive::Triangle([v(-1.0, 0.0, -1.0), v(-1.0, 0.0, 1.0), v(1.0, 0.0, 1.0)]),
                Primitive::Triangle([v(-1.0, 0.0, -1.0), v(1.0, 0.0, 1.0), v(1.0, 0.0, -1.0)]),
            ];
            let accel = Accel::build(&floor);
            let ray = Ray::new(v(0.0, 1.0, 4.0), Vec3::new(0.0, -0.25, -1.0).normalize());
            let h = accel
                .intersect(&ray)
                .unwrap_or_else(|| panic!("scale {s}: camera ray misses"));
            assert!((h.t - 4.1231 * s).abs() < 1e-4 * s, "scale {s}: t = {}", h.t);
            let ray = Ray::new(v(0.1, 1e-5, 0.2), -Vec3::Y);
            let h = accel
                .intersect(&ray)
                .unwrap_or_else(|| panic!("scale {s}: near floor missed"));
            assert!((h.t - 1e-5 * s).abs() < 1e-8 * s, "scale {s}: t = {}", h.t);
            assert!(!accel.unoccluded(&ray), "scale {s}");
        }
    }

    /// The stack spills to the heap past its inline entries and pops in LIFO order.
    #[test]
    fn stack_spills_and_pops_in_order() {
        let mut stack = Stack::new();
        for i in 0..200u32 {
            stack.push((i, i as f32));
        }
        for i in (0..200u32).rev() {
            assert_eq!(stack.pop(), Some((i, i as f32)));
        }
        assert_eq!(stack.pop(), None);
    }

    /// Hundreds of triangles in one box (no split can separate them) give leaves larger than
    /// one reference holds, split under nodes of their own; nested triangles shrinking toward a
    /// point give a deep tree. Both still agree with brute force, hit by hit.
    #[test]
    fn coincident_and_nested_primitives_agree_with_brute_force() {
        let mut rng = Rng::for_task(12, [0, 0, 0]);
        let mut prims = Vec::new();
        for i in 0..300 {
            let z = i as f32 * 1e-3;
            prims.push(Primitive::Triangle([
                Vec3::new(-1.0, -1.0, z),
                Vec3::new(1.0, -1.0, z + 0.05 * rng.uniform()),
                Vec3::new(0.0, 1.0, z),
            ]));
        }
        for i in 0..60 {
            let s = 0.8f32.powi(i);
            let c = Vec3::new(3.0, 0.0, 0.0) + Vec3::splat(s);
            prims.push(Primitive::Triangle([c, c + Vec3::X * s, c + Vec3::Y * s]));
        }
        // Also as one leaf of every primitive: too many blocks for a reference, so split.
        let mut one_leaf = Accel {
            nodes: Vec::new(),
            blocks: Vec::new(),
            root: 0,
            primitive_count: prims.len(),
        };
        let ids: Vec<u32> = (0..prims.len() as u32).collect();
        one_leaf.root = one_leaf.leaf_of(&ids, &prims);
        assert_eq!(
            one_leaf.root & LEAF,
            0,
            "a leaf of {} primitives must be split",
            prims.len()
        );
        let mut hits = 0;
        for accel in [Accel::build(&prims), one_leaf] {
            for _ in 0..3000 {
                let target = if rng.uniform() < 0.5 {
                    Vec3::new(rng.uniform() - 0.5, rng.uniform() - 0.5, 0.15)
                } else {
                    Vec3::new(3.0, 0.0, 0.0) + Vec3::splat(rng.uniform().powi(4))
                };
                let o = target + sample_uniform_sphere(rng.uniform2()) * 2.0;
                let ray = Ray::new(o, (target - o).normalize());
                let expected = brute_force(&prims, &ray);
                let got = accel.intersect(&ray);
                assert_eq!(expected.map(|e| e.1), got.map(|g| g.t), "ray {ray:?}");
                hits += usize::from(got.is_some());
                assert_eq!(accel.unoccluded(&ray), expected.is_none());
            }
        }
        assert!(hits > 2000, "the test must exercise hits, got {hits}");
    }

    #[test]
    fn barycentrics_reconstruct_the_hit_point() {
        let tri = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let far = Primitive::Sphere {
            center: Vec3::splat(10.0),
            radius: 1.0,
        };
        let accel = Accel::build(&[Primitive::Triangle(tri), far]);
        // −Z has −0 x and y components: a case obvhs' slab test gets wrong unless sanitised.
        let ray = Ray::new(Vec3::new(0.2, 0.3, 1.0), -Vec3::Z);
        let h = accel.intersect(&ray).unwrap();
        let p = (1.0 - h.b.x - h.b.y) * tri[0] + h.b.x * tri[1] + h.b.y * tri[2];
        assert!((p - Vec3::new(0.2, 0.3, 0.0)).length() < 1e-6);
        assert!((h.t - 1.0).abs() < 1e-6);
    }
}
