//! The acceleration structure: an obvhs compressed-wide BVH (CWBVH) over triangles and analytic
//! spheres, with closest-hit and shadow (any-hit, early exit) queries.
//!
//! obvhs hands the traversal closure an index into `bvh.primitive_indices`, not into our input
//! order; we copy the primitives into BVH order once at build time so the hot loop reads them
//! contiguously, and map hits back to input ids.

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
}

impl Accel {
    pub fn build(primitives: &[Primitive]) -> Self {
        let bounds: Vec<Bounds> = primitives
            .iter()
            .map(|p| {
                // Pad by a few ULPs of the coordinates: axis-aligned quads (every wall of a
                // Cornell box) have flat boxes, which slab tests can miss at grazing t.
                let (lo, hi) = p.aabb_min_max();
                let pad = Vec3::splat(1e-6) * lo.abs().max(hi.abs()).max(Vec3::splat(1e-3));
                Bounds(Aabb::new(Vec3A::from(lo - pad), Vec3A::from(hi + pad)))
            })
            .collect();
        let bvh = obvhs::cwbvh::builder::build_cwbvh(&bounds, BvhBuildParams::medium_build(), &mut Duration::default());
        let ids = bvh.primitive_indices.clone();
        let prims = ids.iter().map(|&i| Shape::new(&primitives[i as usize])).collect();
        Self { bvh, prims, ids }
    }

    pub fn len(&self) -> usize {
        self.prims.len()
    }

    pub fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }

    fn obvhs_ray(ray: &Ray) -> obvhs::ray::Ray {
        // Adding +0 turns −0 components into +0: obvhs picks slab order from `d < 0` but the
        // inverse from the sign bit, so a −0 component would invert that slab and miss.
        obvhs::ray::Ray::new(Vec3A::from(ray.o), Vec3A::from(ray.d) + Vec3A::ZERO, 0.0, ray.t_max)
    }

    /// Closest hit along `ray` within (0, t_max).
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if self.prims.is_empty() {
            return None;
        }
        let mut hit = obvhs::ray::RayHit::none();
        let mut b = Vec2::ZERO;
        let (o, d) = (ray.o, ray.d);
        let found = self.bvh.ray_traverse(Self::obvhs_ray(ray), &mut hit, |r, id| {
            match self.prims[id].intersect(o, d, r.tmax) {
                Some((t, bary)) => {
                    b = bary;
                    t
                }
                None => f32::INFINITY,
            }
        });
        // `b` holds the barycentrics of the last accepted (hence closest) candidate: the
        // closure only returns t < tmax, and obvhs shrinks tmax on every accepted hit.
        found.then(|| Hit {
            t: hit.t,
            prim: self.ids[hit.primitive_id as usize],
            b,
        })
    }

    /// True when nothing blocks `ray` within (0, t_max). Stops at the first blocker.
    pub fn unoccluded(&self, ray: &Ray) -> bool {
        if self.prims.is_empty() {
            return true;
        }
        let (o, d) = (ray.o, ray.d);
        self.bvh.ray_traverse_miss(Self::obvhs_ray(ray), |r, id| {
            self.prims[id].intersect(o, d, r.tmax).map_or(f32::INFINITY, |(t, _)| t)
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
