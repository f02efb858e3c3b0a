//! The SD-tree of practical path guiding [Müller, Gross & Novák 2017, §3]: a binary tree over
//! space whose leaves each hold a quadtree over directions (a *D-tree*) approximating the
//! incident radiance there.
//!
//! **Directions** are mapped to the unit square by the cylindrical (equal-area) map
//! (cos θ, φ) → ((cos θ + 1) / 2, φ / 2π) [§3.2], so a density on the square is a density on
//! the sphere divided by 4π.
//!
//! **D-tree**: each node splits its square into 4 quadrants and keeps, per quadrant, the
//! energy recorded there and the child node (or none: a leaf, uniform inside). Sampling descends
//! choosing quadrants ∝ energy; the pdf is the product of 4 · (quadrant energy / node energy)
//! over the levels. After an iteration the tree is rebuilt from the energies it recorded: a
//! quadrant holding more than ρ of the total energy is subdivided, up to depth 20 [§3.3].
//!
//! **S-tree**: a leaf splits (at the midpoint of its box, the axes in turn x, y, z) when the
//! previous iteration recorded more than c √(2^k) samples in it, k the iteration [§3.3].

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Deepest quadtree level [§3.3].
pub const MAX_DTREE_DEPTH: u32 = 20;
/// Deepest S-tree level.
pub const MAX_STREE_DEPTH: u32 = 48;
/// No child.
const NONE: u32 = u32::MAX;

/// The cylindrical map of a unit direction to [0, 1]².
#[inline]
pub fn dir_to_square(d: Vec3) -> Vec2 {
    let cos_theta = d.z.clamp(-1.0, 1.0);
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    Vec2::new(
        ((cos_theta + 1.0) * 0.5).clamp(0.0, 1.0),
        (phi / (2.0 * PI)).clamp(0.0, 1.0),
    )
}

/// The inverse of [`dir_to_square`].
#[inline]
pub fn square_to_dir(p: Vec2) -> Vec3 {
    let cos_theta = 2.0 * p.x - 1.0;
    let phi = 2.0 * PI * p.y;
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta)
}

#[derive(Clone, Copy, Debug)]
struct QuadNode {
    sum: [f64; 4],
    child: [u32; 4],
}

impl QuadNode {
    const EMPTY: Self = Self {
        sum: [0.0; 4],
        child: [NONE; 4],
    };

    fn total(&self) -> f64 {
        self.sum.iter().sum()
    }
}

/// Which quadrant of the unit square `p` is in, and `p` in that quadrant's own unit square.
#[inline]
fn quadrant(p: Vec2) -> (usize, Vec2) {
    let (qx, qy) = (p.x >= 0.5, p.y >= 0.5);
    let q = qx as usize | ((qy as usize) << 1);
    let local = Vec2::new(
        if qx { 2.0 * p.x - 1.0 } else { 2.0 * p.x },
        if qy { 2.0 * p.y - 1.0 } else { 2.0 * p.y },
    );
    (q, local.clamp(Vec2::ZERO, Vec2::ONE))
}

/// A directional quadtree (module doc).
#[derive(Clone, Debug)]
pub struct DTree {
    nodes: Vec<QuadNode>,
    /// Statistical weight of the records (samples).
    pub samples: f64,
}

impl Default for DTree {
    fn default() -> Self {
        Self {
            nodes: vec![QuadNode::EMPTY],
            samples: 0.0,
        }
    }
}

impl DTree {
    /// Total energy recorded.
    pub fn energy(&self) -> f64 {
        self.nodes[0].total()
    }

    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Adds `value` (an estimate of L_i / p) at direction `d`.
    pub fn record(&mut self, d: Vec3, value: f64) {
        if !(value.is_finite() && value > 0.0) {
            self.samples += 1.0;
            return;
        }
        self.samples += 1.0;
        let mut p = dir_to_square(d);
        let mut node = 0usize;
        loop {
            let (q, local) = quadrant(p);
            self.nodes[node].sum[q] += value;
            let child = self.nodes[node].child[q];
            if child == NONE {
                return;
            }
            node = child as usize;
            p = local;
        }
    }

    /// A direction drawn ∝ the recorded energy (uniform over the sphere when there is none),
    /// from uniform numbers `u` (one per level, drawn as needed).
    pub fn sample(&self, mut u: impl FnMut() -> f32) -> Vec3 {
        if self.energy() <= 0.0 {
            return square_to_dir(Vec2::new(u(), u()));
        }
        let (mut origin, mut size) = (Vec2::ZERO, 1.0f32);
        let mut node = 0usize;
        loop {
            let n = &self.nodes[node];
            let total = n.total();
            let mut x = u() as f64 * total;
            let mut q = 3;
            for (i, s) in n.sum.iter().enumerate() {
                if x < *s {
                    q = i;
                    break;
                }
                x -= s;
            }
            // Never a quadrant without energy (rounding at the end of the scan).
            while n.sum[q] <= 0.0 {
                q -= 1;
            }
            size *= 0.5;
            origin += Vec2::new((q & 1) as f32, (q >> 1) as f32) * size;
            let child = n.child[q];
            if child == NONE {
                let p = origin + Vec2::new(u(), u()) * size;
                return square_to_dir(p.clamp(Vec2::ZERO, Vec2::ONE));
            }
            node = child as usize;
        }
    }

    /// Solid-angle pdf of [`DTree::sample`] at direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        let uniform = 1.0 / (4.0 * PI);
        if self.energy() <= 0.0 {
            return uniform;
        }
        let mut p = dir_to_square(d);
        let mut node = 0usize;
        let mut density = 1.0f64;
        loop {
            let n = &self.nodes[node];
            let (q, local) = quadrant(p);
            let total = n.total();
            if n.sum[q] <= 0.0 || total <= 0.0 {
                return 0.0;
            }
            density *= 4.0 * n.sum[q] / total;
            let child = n.child[q];
            if child == NONE {
                return (density as f32) * uniform;
            }
            node = child as usize;
            p = local;
        }
    }

    /// The structure for the next iteration: every quadrant holding more than `rho` of the
    /// total energy subdivided (where the old tree was coarser, a quadrant's energy is taken
    /// as a quarter of its parent's), up to [`MAX_DTREE_DEPTH`], with no energy recorded.
    pub fn refined(&self, rho: f64) -> DTree {
        let total = self.energy();
        let mut out = DTree {
            nodes: vec![QuadNode::EMPTY],
            samples: 0.0,
        };
        if total <= 0.0 {
            return out;
        }
        // (new node, old node or NONE, the energy of each of its quadrants if old is NONE, depth)
        let mut stack = vec![(0usize, 0u32, 0.0f64, 1u32)];
        while let Some((new, old, even, depth)) = stack.pop() {
            for q in 0..4 {
                let (energy, old_child) = if old == NONE {
                    (even, NONE)
                } else {
                    let n = &self.nodes[old as usize];
                    (n.sum[q], n.child[q])
                };
                if depth < MAX_DTREE_DEPTH && energy > rho * total {
                    let index = out.nodes.len() as u32;
                    out.nodes.push(QuadNode::EMPTY);
                    out.nodes[new].child[q] = index;
                    stack.push((index as usize, old_child, energy / 4.0, depth + 1));
                }
            }
        }
        out
    }

    /// The same structure with no energy recorded.
    pub fn cleared(&self) -> DTree {
        let mut out = self.clone();
        for n in &mut out.nodes {
            n.sum = [0.0; 4];
        }
        out.samples = 0.0;
        out
    }
}

/// One leaf of the S-tree: the D-tree guiding this iteration and the one being recorded.
#[derive(Clone, Debug, Default)]
pub struct Leaf {
    pub sampling: DTree,
    pub building: DTree,
}

#[derive(Clone, Copy, Debug)]
enum SNode {
    /// Children at these indices, split at the box's midpoint along `axis`.
    Inner {
        axis: u8,
        children: [u32; 2],
    },
    Leaf(u32),
}

/// The spatio-directional tree.
#[derive(Clone, Debug)]
pub struct SdTree {
    lo: Vec3,
    size: f32,
    nodes: Vec<SNode>,
    pub leaves: Vec<Leaf>,
}

impl SdTree {
    /// One leaf over the cube around `lo`..`hi` (a cube, so the splits stay balanced).
    pub fn new(lo: Vec3, hi: Vec3) -> Self {
        let size = (hi - lo).max_element().max(1e-6) * 1.001;
        let centre = 0.5 * (lo + hi);
        Self {
            lo: centre - Vec3::splat(0.5 * size),
            size,
            nodes: vec![SNode::Leaf(0)],
            leaves: vec![Leaf::default()],
        }
    }

    /// The leaf whose box holds `p` (points outside go to the nearest box).
    pub fn leaf(&self, p: Vec3) -> u32 {
        let mut local = ((p - self.lo) / self.size).clamp(Vec3::ZERO, Vec3::ONE);
        let mut node = 0usize;
        loop {
            match self.nodes[node] {
                SNode::Leaf(l) => return l,
                SNode::Inner { axis, children } => {
                    let a = axis as usize;
                    let upper = local[a] >= 0.5;
                    local[a] = if upper { 2.0 * local[a] - 1.0 } else { 2.0 * local[a] };
                    node = children[upper as usize] as usize;
                }
            }
        }
    }

    /// Ends an iteration (k = its index, 2^k samples per pixel): the recorded trees become the
    /// sampling trees; leaves that recorded more than c √(2^k) samples split (each half taking
    /// half the samples, until under the threshold); the building trees get the refined
    /// structure with no energy.
    pub fn end_iteration(&mut self, k: u32, c: f64, rho: f64) {
        let threshold = c * 2f64.powf(k as f64 / 2.0);
        let mut stack = vec![(0usize, 0u32)];
        while let Some((node, depth)) = stack.pop() {
            match self.nodes[node] {
                SNode::Inner { children, .. } => {
                    stack.push((children[0] as usize, depth + 1));
                    stack.push((children[1] as usize, depth + 1));
                }
                SNode::Leaf(l) => {
                    let samples = self.leaves[l as usize].building.samples;
                    if samples > threshold && depth < MAX_STREE_DEPTH {
                        let mut half = self.leaves[l as usize].clone();
                        half.building.samples = samples / 2.0;
                        self.leaves[l as usize] = half.clone();
                        let other = self.leaves.len() as u32;
                        self.leaves.push(half);
                        let first = self.nodes.len() as u32;
                        self.nodes.push(SNode::Leaf(l));
                        self.nodes.push(SNode::Leaf(other));
                        self.nodes[node] = SNode::Inner {
                            axis: (depth % 3) as u8,
                            children: [first, first + 1],
                        };
                        stack.push((node, depth));
                    }
                }
            }
        }
        for leaf in &mut self.leaves {
            let recorded = std::mem::take(&mut leaf.building);
            leaf.building = recorded.refined(rho);
            leaf.sampling = recorded;
        }
    }

    pub fn dtree_nodes(&self) -> usize {
        self.leaves.iter().map(|l| l.sampling.node_count()).sum()
    }
}

/// Chi-square test of a sampler of directions against its solid-angle pdf, over a 16 × 16 grid
/// of the cylindrical square (cells of equal solid angle), the pdf integrated over each cell by
/// 8 × 8 midpoints: the expected counts must sum to the samples drawn (the pdf integrates to 1
/// within 2 %) and χ² must stay within 5 standard deviations of its degrees of freedom.
/// `sample` returning `None` is a rejected sample (it counts towards `n`).
#[cfg(test)]
pub(crate) fn assert_samples_pdf(n: usize, mut sample: impl FnMut() -> Option<Vec3>, pdf: impl Fn(Vec3) -> f32) {
    let cells = 16usize;
    let mut counts = vec![0f64; cells * cells];
    for _ in 0..n {
        let Some(d) = sample() else { continue };
        let p = dir_to_square(d);
        let (x, y) = (
            ((p.x * cells as f32) as usize).min(cells - 1),
            ((p.y * cells as f32) as usize).min(cells - 1),
        );
        counts[y * cells + x] += 1.0;
    }
    let (mut chi2, mut dof, mut total) = (0.0, 0, 0.0);
    for y in 0..cells {
        for x in 0..cells {
            let mut p = 0.0f64;
            for j in 0..8 {
                for i in 0..8 {
                    let uv = Vec2::new(
                        (x as f32 + (i as f32 + 0.5) / 8.0) / cells as f32,
                        (y as f32 + (j as f32 + 0.5) / 8.0) / cells as f32,
                    );
                    p += pdf(square_to_dir(uv)) as f64;
                }
            }
            // Each cell is 4π / cells² of solid angle.
            let p = p / 64.0 * 4.0 * std::f64::consts::PI / (cells * cells) as f64;
            total += p;
            let expected = p * n as f64;
            if expected > 5.0 {
                chi2 += (counts[y * cells + x] - expected).powi(2) / expected;
                dof += 1;
            }
        }
    }
    assert!((total - 1.0).abs() < 0.02, "the pdf integrates to {total}");
    let limit = dof as f64 + 5.0 * (2.0 * dof as f64).sqrt();
    assert!(chi2 < limit, "chi2 {chi2} over {dof} cells (limit {limit})");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn the_cylindrical_map_round_trips() {
        let mut rng = Rng::for_task(1, [0, 0, 0]);
        for _ in 0..1000 {
            let p = rng.uniform2();
            let d = square_to_dir(p);
            assert!((d.length() - 1.0).abs() < 1e-5);
            assert!((dir_to_square(d) - p).abs().max_element() < 1e-4, "{p}");
        }
    }

    /// A D-tree trained on a lobe: its sampler must follow its pdf. Chi-square over a 16 × 16
    /// grid of the square (equal solid angle per cell), 200 000 samples, against the pdf
    /// integrated over each cell by 8 × 8 midpoints.
    #[test]
    fn dtree_sampling_matches_its_pdf() {
        let mut rng = Rng::for_task(2, [0, 0, 0]);
        let mut tree = DTree::default();
        let lobe = Vec3::new(0.3, -0.5, 0.8).normalize();
        for round in 0..4 {
            for _ in 0..20_000 {
                let d = square_to_dir(rng.uniform2());
                tree.record(d, (d.dot(lobe).max(0.0) as f64).powi(8) + 0.01);
            }
            if round < 3 {
                tree = tree.refined(0.01);
            }
        }
        assert!(
            tree.node_count() > 20,
            "refinement must build a deep tree: {}",
            tree.node_count()
        );
        assert_samples_pdf(200_000, || Some(tree.sample(|| rng.uniform())), |d| tree.pdf(d));
    }

    #[test]
    fn leaves_split_past_the_sample_threshold_and_keep_their_trees() {
        let mut t = SdTree::new(Vec3::ZERO, Vec3::ONE);
        for i in 0..5000 {
            let p = Vec3::new((i % 100) as f32 / 100.0, 0.3, 0.3);
            let l = t.leaf(p) as usize;
            t.leaves[l].building.record(Vec3::Z, 1.0);
        }
        t.end_iteration(0, 1000.0, 0.01);
        assert!(t.leaves.len() >= 4, "{} leaves", t.leaves.len());
        assert!(t.leaves.iter().all(|l| l.sampling.energy() > 0.0));
        assert!(t.leaf(Vec3::splat(0.1)) != t.leaf(Vec3::splat(0.9)));
    }
}
