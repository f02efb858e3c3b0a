//! The acceleration structure: an obvhs compressed-wide BVH (CWBVH) over triangles and analytic
//! spheres, with closest-hit and shadow (any-hit, early exit) queries.
//!
//! obvhs hands the traversal closure an index into `bvh.primitive_indices`, not into our input
//! order; we copy the primitives into BVH order once at build time so the hot loop reads them
//! contiguously, and map hits back to input ids.
//!
//! **BVH space.** obvhs's node test clamps every child's entry distance to an absolute 10⁻⁴
//! (`cwbvh::node::EPSILON`): a child box the ray leaves before t = 10⁻⁴ is culled. In world
//! units that made geometry closer than 0.1 mm to a ray's origin invisible (rays leaving a
//! floor next to a wall escaped through the wall), and a scene in millimetres rendered black.
//! So the BVH lives in a space scaled by a power of two, `k`, chosen so that the scene's extent
//! becomes 2²⁴: the clamp then sits at 6·10⁻¹² of the extent, far below f32 resolution, at every
//! scale. Power-of-two scaling is exact, so primitives are still intersected in world space
//! with the world ray; only obvhs sees scaled origins and distances.

use super::Ray;
use glam::{Vec2, Vec3, Vec3A};
use obvhs::{Boundable, BvhBuildParams, aabb::Aabb, cwbvh::CwBvh};
use std::time::Duration;

/// A geometric primitive in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Primitive {
    /// Vertices in counter-clockwise order seen from the side the geometric normal points to.
    Triangle([Vec3; 3]),
    Sphere {
        center: Vec3,
        radius: f32,
    },
}

/// The closest hit of a ray.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the ray.
    pub t: f32,
    /// Index of the primitive in the slice the accelerator was built from.
    pub prim: u32,
    /// Barycentric coordinates (b1, b2) of the hit on a triangle (b0 = 1 − b1 − b2); unused
    /// for spheres.
    pub b: Vec2,
}

impl Primitive {
    pub fn aabb_min_max(&self) -> (Vec3, Vec3) {
        match *self {
            Primitive::Triangle([a, b, c]) => (a.min(b).min(c), a.max(b).max(c)),
            Primitive::Sphere { center, radius } => (center - Vec3::splat(radius), center + Vec3::splat(radius)),
        }
    }

    /// Surface area.
    pub fn area(&self) -> f32 {
        match *self {
            Primitive::Triangle([a, b, c]) => 0.5 * (b - a).cross(c - a).length(),
            Primitive::Sphere { radius, .. } => 4.0 * std::f32::consts::PI * radius * radius,
        }
    }

    /// Unit geometric normal at surface point `p` (triangles: from the winding; spheres: outward).
    pub fn geometric_normal(&self, p: Vec3) -> Vec3 {
        match *self {
            Primitive::Triangle([a, b, c]) => (b - a).cross(c - a).normalize(),
            Primitive::Sphere { center, .. } => (p - center).normalize(),
        }
    }

    /// Ray–primitive intersection for t ∈ (0, ray.t_max): distance and barycentrics.
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, Vec2)> {
        match *self {
            Primitive::Triangle([v0, v1, v2]) => intersect_triangle(o, d, t_max, v0, v1 - v0, v2 - v0),
            Primitive::Sphere { center, radius } => {
                intersect_sphere(o, d, t_max, center, radius).map(|t| (t, Vec2::ZERO))
            }
        }
    }
}

/// Möller–Trumbore, two-sided, in f32, on a triangle given by a vertex and its two edges.
#[inline(always)]
fn intersect_triangle(o: Vec3, d: Vec3, t_max: f32, v0: Vec3, e1: Vec3, e2: Vec3) -> Option<(f32, Vec2)> {
    let pvec = d.cross(e2);
    let det = e1.dot(pvec);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv_det = 1.0 / det;
    let tvec = o - v0;
    let b1 = tvec.dot(pvec) * inv_det;
    if !(0.0..=1.0).contains(&b1) {
        return None;
    }
    let qvec = tvec.cross(e1);
    let b2 = d.dot(qvec) * inv_det;
    if b2 < 0.0 || b1 + b2 > 1.0 {
        return None;
    }
    let t = e2.dot(qvec) * inv_det;
    (t > 0.0 && t < t_max).then_some((t, Vec2::new(b1, b2)))
}

/// Ray–sphere intersection in the numerically careful form of Haines et al. 2019 ("Precision
/// Improvements for Ray/Sphere Intersection", Ray Tracing Gems ch. 7): the discriminant is
/// computed from the perpendicular offset, avoiding cancellation for distant or tiny spheres.
#[inline(always)]
fn intersect_sphere(o: Vec3, d: Vec3, t_max: f32, center: Vec3, radius: f32) -> Option<f32> {
    let f = o - center;
    let b = -f.dot(d);
    let perp = f + b * d;
    let disc = radius * radius - perp.length_squared();
    if disc < 0.0 {
        return None;
    }
    let sq = disc.sqrt();
    let q = if b >= 0.0 { b + sq } else { b - sq };
    let c = f.length_squared() - radius * radius;
    let (mut t0, mut t1) = (c / q, q);
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    // Roots closer than a tiny fraction of the radius are the surface the ray left from.
    let t_min = 1e-5 * radius;
    if t0 > t_min && t0 < t_max {
        Some(t0)
    } else if t1 > t_min && t1 < t_max {
        Some(t1)
    } else {
        None
    }
}

/// A primitive as the traversal loop reads it: triangles with precomputed edges.
#[derive(Clone, Copy, Debug)]
enum Shape {
    Triangle { v0: Vec3, e1: Vec3, e2: Vec3 },
    Sphere { center: Vec3, radius: f32 },
}

impl Shape {
    fn new(p: &Primitive) -> Self {
        match *p {
            Primitive::Triangle([v0, v1, v2]) => Shape::Triangle {
                v0,
                e1: v1 - v0,
                e2: v2 - v0,
            },
            Primitive::Sphere { center, radius } => Shape::Sphere { center, radius },
        }
    }

    #[inline(always)]
    fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, Vec2)> {
        match *self {
            Shape::Triangle { v0, e1, e2 } => intersect_triangle(o, d, t_max, v0, e1, e2),
            Shape::Sphere { center, radius } => intersect_sphere(o, d, t_max, center, radius).map(|t| (t, Vec2::ZERO)),
        }
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
    bvh: CwBvh,
    /// Primitives in BVH order.
    prims: Vec<Shape>,
    /// Input index of each primitive in BVH order.
    ids: Vec<u32>,
    /// World → BVH space scale, a power of two (see the module doc).
    k: f32,
}

/// log2 of the scene extent in BVH space.
const BVH_EXTENT_LOG2: i32 = 24;

/// The power of two that maps an extent `e` to about 2^[`BVH_EXTENT_LOG2`].
fn bvh_scale(extent: f32) -> f32 {
    let e = if extent.is_finite() && extent > 0.0 {
        BVH_EXTENT_LOG2 - extent.log2().ceil() as i32
    } else {
        0
    };
    2f32.powi(e.clamp(-64, 64))
}

impl Accel {
    pub fn build(primitives: &[Primitive]) -> Self {
        let (lo, hi) = primitives
            .iter()
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), p| {
                let (a, b) = p.aabb_min_max();
                (lo.min(a), hi.max(b))
            });
        let k = bvh_scale((hi - lo).max_element());
        let bounds: Vec<Bounds> = primitives
            .iter()
            .map(|p| {
                // Pad by a few ULPs of the coordinates: axis-aligned quads (every wall of a
                // Cornell box) have flat boxes, which slab tests can miss at grazing t. The
                // floor of the pad is relative to the scene's extent, so it scales with it.
                let (lo, hi) = p.aabb_min_max();
                let (lo, hi) = (lo * k, hi * k);
                let floor = Vec3::splat(2f32.powi(BVH_EXTENT_LOG2 - 10));
                let pad = Vec3::splat(1e-6) * lo.abs().max(hi.abs()).max(floor);
                Bounds(Aabb::new(Vec3A::from(lo - pad), Vec3A::from(hi + pad)))
            })
            .collect();
        let bvh = obvhs::cwbvh::builder::build_cwbvh(&bounds, BvhBuildParams::medium_build(), &mut Duration::default());
        let ids = bvh.primitive_indices.clone();
        let prims = ids.iter().map(|&i| Shape::new(&primitives[i as usize])).collect();
        Self { bvh, prims, ids, k }
    }

    pub fn len(&self) -> usize {
        self.prims.len()
    }

    pub fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }

    /// The ray in BVH space: origin and distances times `k`, the direction as is.
    fn obvhs_ray(&self, ray: &Ray) -> obvhs::ray::Ray {
        // Adding +0 turns −0 components into +0: obvhs picks slab order from `d < 0` but the
        // inverse from the sign bit, so a −0 component would invert that slab and miss.
        obvhs::ray::Ray::new(
            Vec3A::from(ray.o * self.k),
            Vec3A::from(ray.d) + Vec3A::ZERO,
            0.0,
            ray.t_max * self.k,
        )
    }

    /// Closest hit along `ray` within (0, t_max).
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if self.prims.is_empty() {
            return None;
        }
        let mut hit = obvhs::ray::RayHit::none();
        let mut b = Vec2::ZERO;
        let (o, d, k) = (ray.o, ray.d, self.k);
        let found = self.bvh.ray_traverse(self.obvhs_ray(ray), &mut hit, |r, id| {
            // World-space test against the world t_max (exact: k is a power of two).
            match self.prims[id].intersect(o, d, r.tmax / k) {
                Some((t, bary)) => {
                    b = bary;
                    t * k
                }
                None => f32::INFINITY,
            }
        });
        // `b` holds the barycentrics of the last accepted (hence closest) candidate: the
        // closure only returns t < tmax, and obvhs shrinks tmax on every accepted hit.
        found.then(|| Hit {
            t: hit.t / k,
            prim: self.ids[hit.primitive_id as usize],
            b,
        })
    }

    /// True when nothing blocks `ray` within (0, t_max). Stops at the first blocker.
    pub fn unoccluded(&self, ray: &Ray) -> bool {
        if self.prims.is_empty() {
            return true;
        }
        let (o, d, k) = (ray.o, ray.d, self.k);
        self.bvh.ray_traverse_miss(self.obvhs_ray(ray), |r, id| {
            self.prims[id]
                .intersect(o, d, r.tmax / k)
                .map_or(f32::INFINITY, |(t, _)| t * k)
        })
    }
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

    /// obvhs culls child boxes the ray leaves before t = 10⁻⁴ (in its own units); in world
    /// units that hid a floor 10 µm below a ray's origin, and every surface of a scene
    /// measured in micrometres. The scaled BVH space finds them at every scale.
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
