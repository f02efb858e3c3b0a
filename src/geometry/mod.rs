//! Rays, local frames, robust ray spawning and the acceleration structure.
//!
//! What lives here: geometry that knows nothing about materials, lights or light transport.
//! What does not: shading, sampling decisions, scene loading.

pub mod accel;
pub mod primitive;

pub use accel::Accel;
pub use primitive::{Hit, Primitive};

use glam::Vec3;

/// A ray `o + t d` for `t ∈ (0, t_max)`; `d` is unit length.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
    pub t_max: f32,
}

impl Ray {
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Self {
            o,
            d,
            t_max: f32::INFINITY,
        }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.o + t * self.d
    }
}

/// An orthonormal frame (s, t, n); local coordinates put n on +z.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// A frame around unit normal `n` (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { s, t, n }
    }

    /// A frame around unit normal `n` whose first axis follows `tangent` projected onto the
    /// tangent plane (anisotropic BSDFs need a stable tangent); falls back to
    /// [`Frame::from_normal`] when the tangent is degenerate.
    pub fn from_normal_tangent(n: Vec3, tangent: Vec3) -> Self {
        let s = tangent - n * n.dot(tangent);
        let len = s.length();
        if len.is_nan() || len <= 1e-6 {
            return Self::from_normal(n);
        }
        let s = s / len;
        Self { s, t: n.cross(s), n }
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Moves a surface point off its surface along the geometric normal `ng`, toward the side `d`
/// points to, by a few ULPs of the point's coordinates (Wächter & Binder 2019, "A Fast and
/// Robust Method for Avoiding Self-Intersection", Ray Tracing Gems ch. 6); rays spawned from the
/// offset point then use t_min = 0.
///
/// Unlike the original, whose fallback for coordinates near zero adds an absolute 2⁻¹⁶ (right
/// for scenes of size about 1, far too much for a scene in kilometres written in metres ÷ 10⁶,
/// where it jumped across whole objects), both branches here are relative to the point's
/// largest coordinate magnitude `m`: a coordinate smaller than `m / 32` moves by `m · 2⁻¹⁶`, the
/// others by 256 ULPs. The offset is therefore invariant under scaling the scene. Its one
/// blind spot, shared by every method that sees only the point: a hit much closer to the world
/// origin than the vertices of its (tilted) triangle, whose rounding error follows the
/// vertices, not the point.
#[inline]
pub fn offset_ray_origin(p: Vec3, ng: Vec3, d: Vec3) -> Vec3 {
    const NEAR_ZERO: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let n = if ng.dot(d) < 0.0 { -ng } else { ng };
    let m = p.abs().max_element().max(f32::MIN_POSITIVE);
    let of_i = (n * INT_SCALE).as_ivec3();
    let offset = |p: f32, o: i32| -> f32 {
        let bits = p.to_bits() as i32;
        f32::from_bits((bits + if p < 0.0 { -o } else { o }) as u32)
    };
    let p_i = Vec3::new(offset(p.x, of_i.x), offset(p.y, of_i.y), offset(p.z, of_i.z));
    let pick = |p: f32, pi: f32, n: f32| {
        if p.abs() < NEAR_ZERO * m {
            p + FLOAT_SCALE * m * n
        } else {
            pi
        }
    };
    Vec3::new(pick(p.x, p_i.x, n.x), pick(p.y, p_i.y, n.y), pick(p.z, p_i.z, n.z))
}

/// A ray leaving surface point `p` (geometric normal `ng`) in unit direction `d`.
#[inline]
pub fn spawn_ray(p: Vec3, ng: Vec3, d: Vec3) -> Ray {
    Ray::new(offset_ray_origin(p, ng, d), d)
}

/// The rest of a finite segment after it passed through the surface at `p` (geometric normal
/// `ng`) along `d`, up to the segment's end point `end`: from the offset origin *aimed at `end`*,
/// with `t_max` in the units of `d` (the direction is `d` turned by the offset's few ULPs, and
/// as long). A ray parallel to `d` would carry the offset's sideways shift to the far end, where
/// a surface met at a grazing angle — the emitter a shadow ray stops just short of — is struck
/// before `end`: shadow rays past a `null` medium boundary or a mask hole then lost the light of
/// an area light just beyond it (docs/design.md, "2026-11-28: shadow rays past a passed
/// surface"). `None` when `end` lies behind the offset origin.
#[inline]
pub fn spawn_ray_to_end(p: Vec3, ng: Vec3, d: Vec3, end: Vec3) -> Option<Ray> {
    let o = offset_ray_origin(p, ng, d);
    let t = (end - o).dot(d) / d.length_squared();
    (t > 0.0).then(|| Ray {
        o,
        d: (end - o) / t,
        t_max: t,
    })
}

/// A shadow ray from surface point `p` (normal `ng`) to surface point `q` (normal `ng_q`);
/// both ends are offset so neither surface occludes the segment. Returns the ray and the
/// distance between the original points.
#[inline]
pub fn spawn_shadow_ray(p: Vec3, ng: Vec3, q: Vec3, ng_q: Vec3) -> (Ray, f32) {
    let to_q = q - p;
    let dist = to_q.length();
    (spawn_shadow_ray_along(p, ng, q, ng_q, to_q / dist), dist)
}

/// [`spawn_shadow_ray`]'s ray for a caller that has already computed the unit direction
/// `d = (q − p) / |q − p|` (with `length`): the same ray, bit for bit, without a square root
/// and three divisions more (next-event estimation has it).
#[inline]
pub fn spawn_shadow_ray_along(p: Vec3, ng: Vec3, q: Vec3, ng_q: Vec3, d: Vec3) -> Ray {
    debug_assert!(d == (q - p) / (q - p).length());
    let o = offset_ray_origin(p, ng, d);
    let q_off = offset_ray_origin(q, ng_q, -d);
    let seg = q_off - o;
    let len = seg.length();
    Ray {
        o,
        d: seg / len,
        t_max: len * (1.0 - 1e-5),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal_and_round_trips() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.4, 0.866).normalize(),
            Vec3::new(0.0, -1e-8, -1.0).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(n).abs() < 1e-5 && f.t.dot(n).abs() < 1e-5);
            assert!((f.s.cross(f.t) - n).length() < 1e-5, "right-handed");
            let v = Vec3::new(0.2, -0.7, 0.4);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    /// Scaling the scene scales the offset: a point on the wall x = 0 of a box of size 0.5·s
    /// moves off the wall by a fixed fraction of s. (The absolute 2⁻¹⁶ of the original method
    /// moved it 15 µm at every scale: 30 box sizes at s = 10⁻⁶.)
    #[test]
    fn offset_is_invariant_under_scaling_the_scene() {
        let p = Vec3::new(0.0, 0.3, 0.4);
        let d = Vec3::new(1.0, 0.2, 0.1).normalize();
        let base = (offset_ray_origin(p, Vec3::X, d) - p) / 1.0;
        for scale in [1e-6f32, 1e-3, 1.0, 1e3, 1e6] {
            let q = p * scale;
            let off = (offset_ray_origin(q, Vec3::X, d) - q) / scale;
            assert!(off.x > 0.0, "scale {scale}: lands on the side of d");
            assert!(
                (off - base).abs().max_element() <= 1e-2 * base.length(),
                "scale {scale}: {off} vs {base}"
            );
        }
    }

    #[test]
    fn offset_origin_lands_on_the_requested_side_at_every_scale() {
        let ng = Vec3::new(0.2, 0.9, -0.1).normalize();
        for scale in [1e-4f32, 1e-2, 1.0, 1e2, 1e4] {
            let p = Vec3::new(0.37, -1.3, 2.1) * scale;
            let up = offset_ray_origin(p, ng, ng);
            let down = offset_ray_origin(p, ng, -ng);
            assert!((up - p).dot(ng) > 0.0, "scale {scale}");
            assert!((down - p).dot(ng) < 0.0, "scale {scale}");
            assert!(
                (up - p).length() < 1e-3 * scale.max(1.0),
                "offset stays tiny at scale {scale}"
            );
        }
    }
}
