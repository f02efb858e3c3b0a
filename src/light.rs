//! Area lights: any emissive primitive (quad and mesh triangles, spheres). Each emissive
//! primitive is one light; lights are chosen in proportion to their emitted power.

use crate::geometry::Primitive;
use crate::sampling::{sample_uniform_sphere, sample_uniform_triangle};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Emission attached to a primitive: constant radiance `le` leaving the side its geometric
/// normal points to, or both sides when `two_sided`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emission {
    pub le: Vec3,
    pub two_sided: bool,
}

/// One emissive primitive.
#[derive(Clone, Copy, Debug)]
pub struct AreaLight {
    /// Index of the primitive in `Scene::primitives`.
    pub prim: u32,
    pub emission: Emission,
    pub area: f32,
}

/// A point sampled uniformly on a light's surface.
#[derive(Clone, Copy, Debug)]
pub struct LightPoint {
    pub p: Vec3,
    /// Unit geometric normal.
    pub n: Vec3,
    /// Area density of the point on this light (1 / area).
    pub pdf_a: f32,
}

impl AreaLight {
    /// Radiance leaving the light at a point with normal `n` in direction `w`.
    #[inline]
    pub fn le(&self, n: Vec3, w: Vec3) -> Vec3 {
        if self.emission.two_sided || n.dot(w) > 0.0 {
            self.emission.le
        } else {
            Vec3::ZERO
        }
    }

    /// Emitted power Φ = π A Le per side [Lambertian emitter], per channel.
    pub fn power(&self) -> Vec3 {
        let sides = if self.emission.two_sided { 2.0 } else { 1.0 };
        self.emission.le * (PI * self.area * sides)
    }

    /// A uniformly distributed point on the light's surface.
    pub fn sample_point(&self, prim: &Primitive, u: Vec2) -> LightPoint {
        let p = match *prim {
            Primitive::Triangle([a, b, c]) => {
                let bary = sample_uniform_triangle(u);
                bary.x * a + bary.y * b + (1.0 - bary.x - bary.y) * c
            }
            Primitive::Sphere { center, radius } => center + radius * sample_uniform_sphere(u),
        };
        LightPoint {
            p,
            n: prim.geometric_normal(p),
            pdf_a: 1.0 / self.area,
        }
    }
}
