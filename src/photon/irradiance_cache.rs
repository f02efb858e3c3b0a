//! Irradiance caching [Ward, Rubinstein & Clear 1988, *A Ray Tracing Solution for Diffuse
//! Interreflection*]: indirect irradiance computed (by a final gather) at sparse records and
//! interpolated in between, on Lambertian surfaces where it varies slowly.
//!
//! A record i holds its position x_i, unit normal n_i, irradiance E_i and R_i, the harmonic
//! mean distance to the surfaces its gather rays hit. At a point x with normal n the record
//! weighs [Ward 1988, eq. (2)]
//!
//! w_i(x, n) = 1 / (|x − x_i| / R_i + √(1 − n · n_i)),
//!
//! and records with w_i > 1/a (a: the `error`) are used: E(x) = Σ w_i E_i / Σ w_i
//! [eq. (3)]. A record lying in front of x (d_i = (x − x_i) · (n + n_i)/2 < −0.01 R_i: it sees
//! a surface that x does not) is left out [Ward 1988, §3.2]. Gradients
//! [Ward & Heckbert 1992] are not used.
//!
//! Decisions:
//! - **Index.** Records sit in a kd-tree over their positions; a query visits the records
//!   within a · max R_i of x and keeps those that pass the weight test. The cache is filled in
//!   rounds (see `photon_map`'s deterministic pre-pass) and the tree rebuilt after each round,
//!   so it is read-only while rendering (no locks, no order-dependent insertions).
//! - **Sum order.** The kd-tree's traversal order, which depends only on the records and the
//!   order they were added in: the interpolated value is bit-identical on any thread count.
//! - **Clamped R.** R_i is clamped by the caller to [min, max] distances: near corners R → 0
//!   would ask for a record at every point, and in open space R → ∞ would stretch one record
//!   over everything (the clamp of later practice, e.g. Tabellion & Lamorlette 2004).

use super::kdtree::{KdPoint, KdTree};
use glam::Vec3;

/// One cached irradiance value [Ward 1988, §3].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CacheRecord {
    /// Position x_i.
    pub p: Vec3,
    /// Unit normal n_i, on the side the irradiance arrives from.
    pub n: Vec3,
    /// Irradiance E_i (W/m²; indirect only when the caller gathers indirect light only).
    pub e: Vec3,
    /// Harmonic mean distance R_i to the surfaces seen from x_i (clamped by the caller).
    pub r: f32,
}

impl KdPoint for CacheRecord {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}

/// Ward's irradiance cache: records and their kd-tree.
#[derive(Clone, Debug)]
pub struct IrradianceCache {
    /// Ward's a: records with weight above 1/a are used.
    error: f32,
    /// Every record, in the order added.
    records: Vec<CacheRecord>,
    tree: KdTree<CacheRecord>,
    /// The largest R_i (bounds every query's search radius: a · max R).
    max_r: f32,
}

impl IrradianceCache {
    /// An empty cache with Ward's accuracy parameter a = `error` (> 0; 0.1–0.3 is typical).
    pub fn new(error: f32) -> Self {
        Self {
            error,
            records: Vec::new(),
            tree: KdTree::build(Vec::new()),
            max_r: 0.0,
        }
    }

    pub fn error(&self) -> f32 {
        self.error
    }

    /// Number of records.
    pub fn len(&self) -> usize {
        self.records.len()
    }

    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// The records, in the order they were added.
    pub fn records(&self) -> &[CacheRecord] {
        &self.records
    }

    /// Memory held: each record twice (insertion order and tree) plus the tree's axes.
    pub fn bytes(&self) -> usize {
        2 * self.records.len() * std::mem::size_of::<CacheRecord>() + self.tree.overhead_bytes()
    }

    /// Adds records, in the given order, and rebuilds the index.
    pub fn extend(&mut self, records: impl IntoIterator<Item = CacheRecord>) {
        let before = self.records.len();
        self.records.extend(records);
        if self.records.len() == before {
            return;
        }
        self.max_r = self.records.iter().fold(0.0, |m, r| m.max(r.r));
        self.tree = KdTree::build(self.records.clone());
    }

    /// Ward's weight w_i(x, n) of `record` [Ward 1988, eq. (2)], or 0 when the record lies in
    /// front of x. Infinite (exactly at the record) is capped at 10⁶.
    pub fn weight(record: &CacheRecord, x: Vec3, n: Vec3) -> f32 {
        let d = x - record.p;
        if d.dot(n + record.n) * 0.5 < -0.01 * record.r {
            return 0.0;
        }
        let denominator = d.length() / record.r + (1.0 - n.dot(record.n)).max(0.0).sqrt();
        1.0 / denominator.max(1e-6)
    }

    /// The interpolated irradiance at `x` (unit normal `n`): Σ w_i E_i / Σ w_i over the records
    /// with w_i > 1/a [Ward 1988, eq. (3)]; `None` when no record is valid there.
    pub fn interpolate(&self, x: Vec3, n: Vec3) -> Option<Vec3> {
        if self.records.is_empty() {
            return None;
        }
        let threshold = 1.0 / self.error;
        let items = self.tree.items();
        let (mut sum, mut weights) = (Vec3::ZERO, 0.0f32);
        self.tree.for_each_within(x, self.error * self.max_r, |index, _| {
            let record = &items[index as usize];
            let w = Self::weight(record, x, n);
            if w > threshold {
                sum += w * record.e;
                weights += w;
            }
        });
        (weights > 0.0).then(|| sum / weights)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(p: Vec3, n: Vec3, e: f32, r: f32) -> CacheRecord {
        CacheRecord {
            p,
            n,
            e: Vec3::splat(e),
            r,
        }
    }

    #[test]
    fn weight_follows_ward() {
        let r = record(Vec3::ZERO, Vec3::Z, 1.0, 0.5);
        // In the plane, 0.1 away: w = 1 / (0.1 / 0.5) = 5.
        let w = IrradianceCache::weight(&r, Vec3::new(0.1, 0.0, 0.0), Vec3::Z);
        assert!((w - 5.0).abs() < 1e-5, "{w}");
        // Tilted normal: + √(1 − cos θ).
        let n = Vec3::new(0.6, 0.0, 0.8);
        let w = IrradianceCache::weight(&r, Vec3::new(0.1, 0.0, 0.0), n);
        assert!((w - 1.0 / (0.2 + 0.2f32.sqrt())).abs() < 1e-5, "{w}");
        // A record above the plane of x is in front of it: unusable.
        let above = record(Vec3::new(0.0, 0.0, 0.05), Vec3::Z, 1.0, 0.5);
        assert_eq!(IrradianceCache::weight(&above, Vec3::ZERO, Vec3::Z), 0.0);
        // At the record itself: capped, finite.
        assert!(IrradianceCache::weight(&r, Vec3::ZERO, Vec3::Z).is_finite());
    }

    #[test]
    fn interpolation_uses_valid_records_only() {
        let mut cache = IrradianceCache::new(0.2);
        assert_eq!(cache.interpolate(Vec3::ZERO, Vec3::Z), None);
        cache.extend([
            record(Vec3::ZERO, Vec3::Z, 1.0, 0.5),
            record(Vec3::new(0.08, 0.0, 0.0), Vec3::Z, 3.0, 0.5),
            // Facing the other way (the back of a thin wall): never used from the front.
            record(Vec3::new(0.04, 0.0, 0.0), -Vec3::Z, 100.0, 0.5),
        ]);
        assert_eq!(cache.len(), 3);
        // Valid region of each record: |x − x_i| < a R = 0.1.
        let e = cache.interpolate(Vec3::new(0.04, 0.0, 0.0), Vec3::Z).unwrap();
        assert!((e.x - 2.0).abs() < 1e-5, "halfway between 1 and 3: {e}");
        let e = cache.interpolate(Vec3::new(0.01, 0.0, 0.0), Vec3::Z).unwrap();
        let (w0, w1) = (1.0 / (0.01 / 0.5), 1.0 / (0.07 / 0.5));
        assert!((e.x - (w0 + 3.0 * w1) / (w0 + w1)).abs() < 1e-4, "{e}");
        assert_eq!(
            cache.interpolate(Vec3::new(0.25, 0.0, 0.0), Vec3::Z),
            None,
            "beyond a·R"
        );
        assert_eq!(
            cache.interpolate(Vec3::new(0.04, 0.0, 0.0), Vec3::X),
            None,
            "normal too different"
        );
        let back = cache.interpolate(Vec3::new(0.04, 0.0, 0.0), -Vec3::Z).unwrap();
        assert_eq!(back.x, 100.0);
    }

    #[test]
    fn interpolation_does_not_depend_on_the_rounds_records_came_in() {
        let recs: Vec<CacheRecord> = (0..200)
            .map(|i| {
                let t = i as f32 * 0.618_034;
                record(Vec3::new(t.fract(), (t * 7.0).fract(), 0.0), Vec3::Z, i as f32, 0.3)
            })
            .collect();
        let mut at_once = IrradianceCache::new(0.3);
        at_once.extend(recs.iter().copied());
        let mut in_rounds = IrradianceCache::new(0.3);
        for chunk in recs.chunks(37) {
            in_rounds.extend(chunk.iter().copied());
        }
        for i in 0..50 {
            let x = Vec3::new(i as f32 / 50.0, (i as f32 * 0.37).fract(), 0.0);
            let (a, b) = (at_once.interpolate(x, Vec3::Z), in_rounds.interpolate(x, Vec3::Z));
            assert_eq!(
                a.map(|v| v.to_array().map(f32::to_bits)),
                b.map(|v| v.to_array().map(f32::to_bits))
            );
        }
    }
}
