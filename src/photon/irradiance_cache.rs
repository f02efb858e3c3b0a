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
//! a surface that x does not) is left out [Ward 1988, §3.2].
//!
//! **Gradients** (optional) [Ward & Heckbert 1992, *Irradiance Gradients*]: a record may carry
//! the rotational gradient ∇_r E_i and the translational gradient ∇_t E_i of its irradiance,
//! and then contributes E_i + (n_i × n) · ∇_r E_i + (x − x_i) · ∇_t E_i instead of E_i,
//! a first-order extrapolation that removes most of the interpolation's
//! blotches where irradiance changes across a record's region. Both are estimated from the
//! record's own gather ([`gradients`]) when it is stratified in [`PolarStrata`]:
//! - rotational: ∇_r E = ∫ L(ω) (n × ω) dω, with cosine-distributed samples
//!   ≈ π/(MN) Σ L_jk (n × ω_jk) / cos θ_jk — each sample's tan θ times its azimuthal tangent
//!   (Ward & Heckbert's rotational gradient, written as a vector);
//! - translational: as x moves by δ, what the hemisphere sees shifts across the boundaries
//!   between neighbouring strata — across the cone θ = θ_j⁻ by δ cos θ / r in θ, across the
//!   half-plane φ = φ_k⁻ by δ / (r sin θ) in φ — and each boundary trades the cosine-weighted
//!   solid angle swept for the radiance difference across it, with r the nearer of the two hit
//!   distances (Ward & Heckbert's translational gradient; in the form used by Křivánek &
//!   Gautron 2009, *Practical Global Illumination with Irradiance Caching*):
//!   ∇_t E = Σ_k [ u_k (2π/N) Σ_{j≥1} sin θ_j⁻ cos² θ_j⁻ (L_jk − L_(j−1)k) / min(r_jk, r_(j−1)k) +
//!   v_k⁻ Σ_j (sin θ_j⁺ − sin θ_j⁻) (L_jk − L_j(k−1)) / min(r_jk, r_j(k−1)) ],
//!   with sin² θ_j⁻ = j/M and sin² θ_j⁺ = (j+1)/M the stratum's bounds, u_k the tangent at its
//!   central azimuth 2π(k+½)/N and v_k⁻ the tangent perpendicular to its boundary azimuth
//!   2πk/N, pointing to growing φ (the second sum: ∫ cos θ sin θ dθ / (r sin θ) over the
//!   stratum).
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
    /// Ward & Heckbert's gradients, if estimated: rotational and translational, one spatial
    /// vector per colour channel.
    pub gradients: Option<Gradients>,
}

/// The irradiance gradients of a record [Ward & Heckbert 1992]: `rotational[c]` and
/// `translational[c]` are the gradient vectors (world space) of colour channel c.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Gradients {
    pub rotational: [Vec3; 3],
    pub translational: [Vec3; 3],
}

impl CacheRecord {
    /// The record's irradiance extrapolated to x with normal n: E_i, plus, with gradients,
    /// (n_i × n) · ∇_r E_i + (x − x_i) · ∇_t E_i per channel [Ward & Heckbert 1992],
    /// clamped at zero (a steep gradient must not turn light negative).
    pub fn irradiance_at(&self, x: Vec3, n: Vec3) -> Vec3 {
        let Some(g) = &self.gradients else { return self.e };
        let (rot, d) = (self.n.cross(n), x - self.p);
        let delta = Vec3::from_array(std::array::from_fn(|c| {
            rot.dot(g.rotational[c]) + d.dot(g.translational[c])
        }));
        (self.e + delta).max(Vec3::ZERO)
    }
}

/// A gather stratified for gradient estimation: M strata in θ (equal cosine-weighted solid
/// angle: sin² θ uniform) times N in φ, one ray each [Ward & Heckbert 1992, §2].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PolarStrata {
    pub m: usize,
    pub n: usize,
}

impl PolarStrata {
    /// M ≈ √(G/π) and N = G / M (Ward's N ≈ π M), so that M·N ≤ G, with M, N ≥ 1.
    pub fn for_rays(g: usize) -> Self {
        let m = ((g as f32 / std::f32::consts::PI).sqrt().round() as usize).max(1);
        Self { m, n: (g / m).max(1) }
    }

    pub fn len(&self) -> usize {
        self.m * self.n
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The local direction (z up) of stratum (j, k), jittered by `u` ∈ [0, 1)²: sin² θ =
    /// (j + u.x)/M, φ = 2π(k + u.y)/N; cosine-distributed over the hemisphere as a whole.
    pub fn direction(&self, j: usize, k: usize, u: glam::Vec2) -> Vec3 {
        let sin2 = ((j as f32 + u.x) / self.m as f32).min(1.0);
        let phi = std::f32::consts::TAU * (k as f32 + u.y) / self.n as f32;
        let sin = sin2.sqrt();
        Vec3::new(sin * phi.cos(), sin * phi.sin(), (1.0 - sin2).max(0.0).sqrt())
    }
}

/// Ward & Heckbert's gradients from a gather in `strata` (see the module doc), in the local
/// frame of the record (z: its normal): `l[j·N + k]` the radiance and `r[j·N + k]` the hit
/// distance (∞ for escaped rays) of stratum (j, k), `wi[j·N + k]` its local direction.
/// Returns (rotational, translational) per channel; both vectors lie in the tangent plane.
pub fn gradients(strata: PolarStrata, l: &[Vec3], r: &[f32], wi: &[Vec3]) -> ([Vec3; 3], [Vec3; 3]) {
    use std::f32::consts::{PI, TAU};
    let (m, n) = (strata.m, strata.n);
    let at = |j: usize, k: usize| j * n + k;
    let mut rot = [Vec3::ZERO; 3];
    let mut trans = [Vec3::ZERO; 3];
    let add = |g: &mut [Vec3; 3], dir: Vec3, v: Vec3| {
        for (c, gc) in g.iter_mut().enumerate() {
            *gc += dir * v[c];
        }
    };
    // Rotational: (n × ω) / cos θ = tan θ times the azimuthal tangent (−sin φ, cos φ, 0).
    let scale = PI / strata.len() as f32;
    for (i, w) in wi.iter().enumerate() {
        if w.z > 1e-4 {
            add(&mut rot, Vec3::new(-w.y, w.x, 0.0) / w.z, l[i] * scale);
        }
    }
    let sin_at = |t: f32| (t / m as f32).min(1.0).sqrt();
    let cos_at = |t: f32| (1.0 - (t / m as f32).min(1.0)).sqrt();
    for k in 0..n {
        let phi_c = TAU * (k as f32 + 0.5) / n as f32;
        let phi_b = TAU * k as f32 / n as f32;
        let u_k = Vec3::new(phi_c.cos(), phi_c.sin(), 0.0);
        let v_k = Vec3::new(-phi_b.sin(), phi_b.cos(), 0.0);
        let k_prev = (k + n - 1) % n;
        // Boundaries between θ strata j − 1 and j at this azimuth.
        for j in 1..m {
            let (s, c) = (sin_at(j as f32), cos_at(j as f32));
            let d = r[at(j, k)].min(r[at(j - 1, k)]);
            if d.is_finite() && d > 0.0 {
                let w = TAU / n as f32 * s * c * c / d;
                add(&mut trans, u_k, (l[at(j, k)] - l[at(j - 1, k)]) * w);
            }
        }
        // Boundaries between φ strata k − 1 and k in every θ stratum.
        if n > 1 {
            for j in 0..m {
                let d = r[at(j, k)].min(r[at(j, k_prev)]);
                if d.is_finite() && d > 0.0 {
                    let w = (sin_at(j as f32 + 1.0) - sin_at(j as f32)) / d;
                    add(&mut trans, v_k, (l[at(j, k)] - l[at(j, k_prev)]) * w);
                }
            }
        }
    }
    (rot, trans)
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
                sum += w * record.irradiance_at(x, n);
                weights += w;
            }
        });
        (weights > 0.0).then(|| sum / weights)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Frame;
    use crate::photon::test_scenes::polygon_irradiance;
    use crate::sampling::Rng;

    /// A wall of radiance 1 at x = 1 facing −x, above the horizon of every receiver below:
    /// y ∈ [−1, 1], z ∈ [0.2, 1.2]. Nothing else: other rays escape.
    const WALL: [Vec3; 4] = [
        Vec3::new(1.0, -1.0, 0.2),
        Vec3::new(1.0, 1.0, 0.2),
        Vec3::new(1.0, 1.0, 1.2),
        Vec3::new(1.0, -1.0, 1.2),
    ];

    fn wall_hit(o: Vec3, d: Vec3) -> Option<f32> {
        if d.x <= 0.0 {
            return None;
        }
        let t = (1.0 - o.x) / d.x;
        let p = o + d * t;
        (p.y.abs() <= 1.0 && (0.2..=1.2).contains(&p.z)).then_some(t)
    }

    /// Exact irradiance from the wall (Lambert's polygon formula).
    fn exact(x: Vec3, n: Vec3) -> f32 {
        polygon_irradiance(&WALL, Vec3::ONE, x, n).x
    }

    /// A record at `x` (normal `n`) from a jittered M × N gather of the wall, with gradients.
    fn gathered(x: Vec3, n: Vec3, strata: PolarStrata, seed: u64) -> CacheRecord {
        let frame = Frame::from_normal(n);
        let mut rng = Rng::for_task(seed, [7, 0, 0]);
        let (mut l, mut r, mut wi) = (Vec::new(), Vec::new(), Vec::new());
        for j in 0..strata.m {
            for k in 0..strata.n {
                let w = strata.direction(j, k, rng.uniform2());
                let hit = wall_hit(x, frame.to_world(w));
                l.push(if hit.is_some() { Vec3::ONE } else { Vec3::ZERO });
                r.push(hit.unwrap_or(f32::INFINITY));
                wi.push(w);
            }
        }
        let e = l.iter().copied().sum::<Vec3>() * (std::f32::consts::PI / strata.len() as f32);
        let (rot, trans) = gradients(strata, &l, &r, &wi);
        CacheRecord {
            p: x,
            n,
            e,
            r: 1.0,
            gradients: Some(Gradients {
                rotational: rot.map(|g| frame.to_world(g)),
                translational: trans.map(|g| frame.to_world(g)),
            }),
        }
    }

    /// Ward & Heckbert's estimates from one 16 × 50 gather against central differences of the
    /// exact irradiance: translational along x (towards the wall) and y (along it, off centre),
    /// rotational about x and y. A wrong sign or a missing cos θ factor is far outside 10 %.
    #[test]
    fn gradients_match_finite_differences_of_the_exact_irradiance() {
        let x0 = Vec3::new(0.0, 0.3, 0.0);
        let strata = PolarStrata::for_rays(800);
        assert_eq!((strata.m, strata.n), (16, 50));
        let h = 1e-3;
        let mut got = [Vec3::ZERO; 2];
        let seeds = [1, 2, 3, 4];
        for seed in seeds {
            let g = gathered(x0, Vec3::Z, strata, seed).gradients.unwrap();
            got[0] += g.translational[0] / seeds.len() as f32;
            got[1] += g.rotational[0] / seeds.len() as f32;
        }
        let [trans, rot] = got;
        let fd = |f: &dyn Fn(f32) -> f32| (f(h) - f(-h)) / (2.0 * h);
        let want_tx = fd(&|d| exact(x0 + Vec3::X * d, Vec3::Z));
        let want_ty = fd(&|d| exact(x0 + Vec3::Y * d, Vec3::Z));
        // Rotating n by δ about axis a changes E by δ a · ∇_r E.
        let tilt = |a: Vec3| move |d: f32| exact(x0, glam::Quat::from_axis_angle(a, d) * Vec3::Z);
        let (want_rx, want_ry) = (fd(&tilt(Vec3::X)), fd(&tilt(Vec3::Y)));
        eprintln!("trans {trans} vs ({want_tx}, {want_ty}); rot {rot} vs ({want_rx}, {want_ry})");
        let close = |got: f32, want: f32, scale: f32| (got - want).abs() < 0.1 * scale;
        let t_scale = want_tx.abs().max(want_ty.abs());
        assert!(
            close(trans.x, want_tx, t_scale) && close(trans.y, want_ty, t_scale),
            "{trans}"
        );
        assert!(trans.z.abs() < 1e-6, "tangent to the surface");
        let r_scale = want_rx.abs().max(want_ry.abs());
        assert!(
            close(rot.x, want_rx, r_scale) && close(rot.y, want_ry, r_scale),
            "{rot}"
        );
    }

    /// The point of gradients: records 0.2 apart on the floor in front of the wall, the cache
    /// queried between them; with gradients the mean error against the exact irradiance falls
    /// to well under half of Ward's plain weighted average's.
    #[test]
    fn gradients_reduce_interpolation_error() {
        let strata = PolarStrata::for_rays(800);
        let grid = [-0.3f32, -0.1, 0.1, 0.3];
        let records: Vec<CacheRecord> = grid
            .iter()
            .flat_map(|&x| grid.iter().map(move |&y| Vec3::new(x, y, 0.0)))
            .enumerate()
            .map(|(i, p)| CacheRecord {
                // The exact value at the record, so that only interpolation error remains
                // (the gather's own noise would blur the comparison); gradients as gathered.
                e: Vec3::splat(exact(p, Vec3::Z)),
                ..gathered(p, Vec3::Z, strata, i as u64)
            })
            .collect();
        let plain: Vec<CacheRecord> = records.iter().map(|r| CacheRecord { gradients: None, ..*r }).collect();
        let (mut with, mut without) = (IrradianceCache::new(0.3), IrradianceCache::new(0.3));
        with.extend(records);
        without.extend(plain);
        let (mut err_with, mut err_without, mut count) = (0.0f64, 0.0f64, 0);
        for i in 0..=12 {
            for j in 0..=12 {
                let x = Vec3::new(-0.3 + 0.05 * i as f32, -0.3 + 0.05 * j as f32, 0.0);
                let want = exact(x, Vec3::Z) as f64;
                let a = with.interpolate(x, Vec3::Z).unwrap().x as f64;
                let b = without.interpolate(x, Vec3::Z).unwrap().x as f64;
                err_with += (a - want).abs() / want;
                err_without += (b - want).abs() / want;
                count += 1;
            }
        }
        let (err_with, err_without) = (err_with / count as f64, err_without / count as f64);
        eprintln!("mean relative error: {err_with:.4} with gradients, {err_without:.4} without");
        assert!(err_with < 0.5 * err_without, "{err_with} vs {err_without}");
    }

    fn record(p: Vec3, n: Vec3, e: f32, r: f32) -> CacheRecord {
        CacheRecord {
            p,
            n,
            e: Vec3::splat(e),
            r,
            gradients: None,
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
