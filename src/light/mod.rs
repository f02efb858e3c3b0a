//! Area lights: any emissive primitive (quad and mesh triangles, spheres). Each emissive
//! primitive is one light.
//!
//! Photon emission (and light sub-paths) choose lights in proportion to their emitted power and
//! points uniformly by area. Next-event estimation on eye paths ([`LightSampling`]) chooses
//! either by power or by a local estimate of each light's contribution at the shading point
//! ([`LightSelection`]), and samples sphere lights either by area or uniformly in the cone they
//! subtend ([`SphereSampling`]); [`crate::scene::light_selection::LightContext`] keeps both choices for one shading point, so
//! that the MIS weight of a BSDF-sampled hit on a light uses the density light sampling there
//! would have had.

//!
//! What lives here: emission, points on lights and their densities ([`AreaLight`],
//! [`sphere_cone`]), and the per-receiver light selection of next-event estimation
//! ([`crate::scene::light_selection`], which reads the scene). What does not: the scene's list of lights (a [`crate::scene::Scene`] field)
//! and any integrator logic.

pub mod delta;
pub mod environment;
pub mod equal_area;
pub mod picture;
pub mod projector;
pub mod sphere_cone;

#[cfg(test)]
mod tests;

pub use sphere_cone::{sample_sphere_cone, sphere_cone_pdf};

use crate::geometry::{Frame, Primitive};
use crate::sampling::{sample_concentric_disk, sample_uniform_sphere, sample_uniform_triangle};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Where a ray of light arriving from infinitely far away (from unit direction `toward_light`,
/// pointing from the scene to the light) starts: a point drawn with `u` uniformly on the disc
/// of radius R that faces the light one radius beyond the centre of the scene's bounding
/// sphere (`center`, R), density 1 / πR² over the disc. Every ray of that bundle that can
/// reach the scene crosses the disc, so a surface point x receives such rays with area density
/// |cos θ_x| / πR² [pbrt-v4, §12.5 and §13.9: infinite lights in light and bidirectional
/// tracing]. Directional and environment light, in photon tracing and in path space, start here.
pub fn parallel_ray_origin(toward_light: Vec3, (center, radius): (Vec3, f32), u: Vec2) -> Vec3 {
    let disc = sample_concentric_disk(u) * radius;
    center + radius * toward_light + Frame::from_normal(toward_light).to_world(Vec3::new(disc.x, disc.y, 0.0))
}

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
    #[inline]
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

crate::declare_choice! {
/// How next-event estimation picks one light among the scene's emissive primitives.
///
/// `"power"` picks light i with probability Φᵢ / Σ Φ (luminance of the emitted power,
/// `Scene::light_selection`): one table for the whole scene, blind to where the shading point
/// is. `"local"` picks ∝ an estimate of light i's unoccluded contribution at the shading point,
/// [`crate::scene::light_selection::local_weight`] = Y(Leᵢ) · Ωᵢ(x) · c̄ᵢ(x) (solid angle times an upper bound of the receiver
/// cosine), the per-point importance many-light samplers use [Shirley, Wang & Zimmerman 1996,
/// "Monte Carlo Techniques for Direct Lighting Calculations", ACM TOG 15(1); Conty Estevez &
/// Kulla 2018, "Importance Sampling of Many Lights with Adaptive Tree Splitting", HPG, whose
/// bounding-cone cosine bound this borrows]. Why: with power selection a weak light next to the
/// shading point (Jensen 1995's bulb inside its lamp shade) is rarely picked although it
/// dominates there. It costs O(#lights) per vertex, so scenes with more than
/// [`LOCAL_SELECTION_MAX_LIGHTS`] emissive primitives fall back to power selection. `"uniform"`
/// picks every emissive primitive with the same probability, Mitsuba 3's emitter selection (for
/// scenes whose emitters are single shapes, such as spheres): with it a cross-check against
/// Mitsuba compares estimators with the same noise, not only the same mean.
///
/// Unbiasedness: a light gets weight 0 only when it provably contributes nothing at the
/// point (one-sided emitter facing away, or entirely below the horizon of a reflect-only
/// BSDF); any other light's weight is positive (up to f32 underflow of Ω for a light seen
/// exactly edge-on, whose contribution ∝ cos θ' vanishes with it). With MIS a zero-probability
/// light is covered by BSDF sampling anyway, as long as the MIS weight uses the same pmf
/// ([`crate::scene::light_selection::LightContext::pdf_w`]).
pub enum LightSelection { Power = "power", Local = "local", Uniform = "uniform" }
}

#[allow(clippy::derivable_impls)] // the derives live in `declare_choice!`
impl Default for LightSelection {
    fn default() -> Self {
        Self::Power
    }
}

crate::declare_choice! {
/// How next-event estimation samples a point on a sphere light (triangles are always sampled
/// uniformly by area).
///
/// `"area"` samples the whole sphere uniformly by area: from outside, half the points lie on
/// the far side, hidden by the sphere itself, and the solid-angle pdf varies with 1/cos θ'
/// across the visible cap. `"cone"` samples directions uniformly inside the cone the sphere
/// subtends at the shading point x and takes the near intersection, pdf 1 / (2π (1 − cos θmax))
/// with sin θmax = r / |c − x| [Shirley, Wang & Zimmerman 1996; the approach of pbrt-v3's
/// `Sphere::Sample(ref, u)`]: every sample lands on the visible cap and the estimator of an
/// unoccluded sphere's irradiance has only the receiver cosine's variance. At points on or
/// inside the sphere (|c − x|² ≤ 1.0001 r², pbrt's margin) there is no cone and area sampling
/// is used.
pub enum SphereSampling { Area = "area", Cone = "cone" }
}

#[allow(clippy::derivable_impls)] // the derives live in `declare_choice!`
impl Default for SphereSampling {
    fn default() -> Self {
        Self::Area
    }
}

/// Light sampling options of next-event estimation on eye paths (`path`, `photon_guided`,
/// `photon_map`'s direct term).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LightSampling {
    pub selection: LightSelection,
    pub sphere: SphereSampling,
}

/// Largest number of lights [`LightSelection::Local`] evaluates at every vertex; scenes with
/// more emissive primitives (an emissive OBJ mesh) use power selection instead. Every shipped
/// scene has at most four.
pub const LOCAL_SELECTION_MAX_LIGHTS: usize = 64;

/// Points closer to a sphere's centre than this factor times r² count as on or inside it:
/// pbrt's margin, so that a point on the sphere itself never builds a degenerate cone.
const SPHERE_INSIDE: f32 = 1.0001;

/// The point next-event estimation samples lights for.
#[derive(Clone, Copy, Debug)]
pub struct Receiver {
    pub p: Vec3,
    /// Unit shading normal turned to the side of ωo.
    pub n: Vec3,
    /// The BSDF transmits: light from both sides of the surface counts.
    pub two_sided: bool,
}

/// How a sampled light point's density is expressed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PointPdf {
    /// Density per unit area on the light (uniform area sampling: 1 / A).
    Area(f32),
    /// Density per unit solid angle at the receiver (cone sampling of a sphere).
    SolidAngle(f32),
}

/// A point sampled on a light for a receiver.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub p: Vec3,
    /// Unit geometric normal at `p`.
    pub n: Vec3,
    pub pdf: PointPdf,
}
