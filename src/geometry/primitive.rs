//! Geometric primitives (triangles and analytic spheres) and their ray intersection tests,
//! shared by the scalar code and the 4-wide leaves of the BVH ([`super::accel`]), which
//! repeats [`intersect_triangle`]'s arithmetic lane by lane.

use glam::{Vec2, Vec3};

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
pub(super) fn intersect_triangle(o: Vec3, d: Vec3, t_max: f32, v0: Vec3, e1: Vec3, e2: Vec3) -> Option<(f32, Vec2)> {
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
pub(super) fn intersect_sphere(o: Vec3, d: Vec3, t_max: f32, center: Vec3, radius: f32) -> Option<f32> {
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
