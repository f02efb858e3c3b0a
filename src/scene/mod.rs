//! Scenes as plain data: camera, materials, primitives, lights and user paths. Strategies read
//! a [`Scene`]; nothing mutates it after loading.
//!
//! `load` reads `scenes/*.toml` (format documented in `docs/user-guide.md` and in [`desc`]) with OBJ/MTL
//! meshes through tobj, validates every field, and assembles the runtime scene here. Mitsuba 3
//! XML scenes (`scenes/*.xml`) are translated into the same description by [`mitsuba`] first.
//!
//! Files: [`desc`] (the serde model of `scenes/*.toml`), [`load`] (our TOML to a validated
//! [`Scene`]), [`mitsuba`] (Mitsuba 3 XML to the same description), [`export`] (a scene as
//! Mitsuba 3 XML, for cross-checks), [`limits`] (what every reader refuses). What does not live
//! here: rendering, sampling decisions, strategies; nothing here mutates a `Scene` after loading.

pub mod desc;
pub mod export;
pub mod light_selection;
pub mod limits;
pub mod load;
pub mod mitsuba;

pub use load::load_scene;

use crate::bsdf::Bsdf;
use crate::camera::Camera;
use crate::color::luminance;
use crate::error::Result;
use crate::geometry::{Accel, Frame, Hit, Primitive, Ray};
use crate::light::{AreaLight, Emission};
use crate::sampling::Distribution1D;
use glam::{Vec2, Vec3};
use std::path::PathBuf;

/// A named material.
#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    pub bsdf: Bsdf,
}

/// What a primitive is made of, besides its shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimAttrs {
    /// Index into `Scene::materials`.
    pub material: u32,
    /// Per-vertex shading normals of a triangle (from OBJ files), if any.
    pub normals: Option<[Vec3; 3]>,
    /// Emission, if the primitive is (part of) an area light.
    pub emission: Option<Emission>,
}

/// A user path for Metropolis photon sampling's UP proposal [Fan et al. 2005, §4.3]: a point on
/// a light, then surface points, the last on a diffuse surface; `cone_deg` holds the cone
/// half-angle β of each segment.
#[derive(Clone, Debug, PartialEq)]
pub struct UserPath {
    pub points: Vec<Vec3>,
    pub cone_deg: Vec<f32>,
}

/// The runtime scene.
pub struct Scene {
    pub name: String,
    /// The file it was loaded from.
    pub source: PathBuf,
    /// The Mitsuba scene parameters it was loaded with (`--param`, an experiment's `params`),
    /// sorted by name; empty for a TOML scene.
    pub params: Vec<(String, String)>,
    /// Hash of the scene file and every file it references (hex), recorded with every result.
    pub content_hash: String,
    pub camera: Camera,
    pub materials: Vec<Material>,
    pub primitives: Vec<Primitive>,
    pub attrs: Vec<PrimAttrs>,
    pub lights: Vec<AreaLight>,
    /// Light index of each primitive (`u32::MAX` for none).
    light_of_prim: Vec<u32>,
    /// Light selection ∝ emitted power (luminance).
    pub light_selection: Distribution1D,
    pub user_paths: Vec<UserPath>,
    pub accel: Accel,
}

/// A ray's hit on a surface, with its local shading frame.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    pub t: f32,
    pub p: Vec3,
    /// Unit geometric normal (triangles: from the winding; spheres: outward).
    pub ng: Vec3,
    /// Shading frame; `frame.n` is the shading normal, on the same side as `ng`.
    pub frame: Frame,
    pub prim: u32,
    pub material: u32,
}

/// Smallest barycentric coordinate of a triangle hit point, 2⁻¹⁶: about 256 ULPs of the
/// coordinates for a triangle as large as its distance from the origin.
pub const MIN_BARYCENTRIC: f32 = 1.0 / 65536.0;

/// Moves barycentrics (b1, b2) on or next to an edge or a vertex inside the triangle, so that
/// every barycentric, b0 = 1 − b1 − b2 included, is at least [`MIN_BARYCENTRIC`].
///
/// Why: at a concave edge (a floor meeting a wall) a hit exactly on the edge also lies on the
/// wall's plane, and the ray offset along the floor's normal keeps it there; a ray leaving
/// into the wall then starts on the wall and passes it at t ≈ 0, a light leak. Pulled inside,
/// the point is a fixed fraction of the triangle off every edge, and such rays hit the wall.
/// Points elsewhere are untouched, and moved points stay on the triangle: no bias beyond
/// shading a point 2⁻¹⁶ of a triangle away from the hit.
#[inline]
pub fn pull_off_edges(b: Vec2) -> Vec2 {
    let b = b.max(Vec2::splat(MIN_BARYCENTRIC));
    let sum = b.x + b.y;
    if sum > 1.0 - MIN_BARYCENTRIC {
        b * ((1.0 - MIN_BARYCENTRIC) / sum)
    } else {
        b
    }
}

impl Scene {
    /// Assembles a scene from validated parts; fails when nothing emits light.
    #[allow(clippy::too_many_arguments)]
    pub fn assemble(
        name: String,
        source: PathBuf,
        content_hash: String,
        camera: Camera,
        materials: Vec<Material>,
        primitives: Vec<Primitive>,
        attrs: Vec<PrimAttrs>,
        user_paths: Vec<UserPath>,
    ) -> Result<Scene> {
        assert_eq!(primitives.len(), attrs.len());
        let mut lights = Vec::new();
        let mut light_of_prim = vec![u32::MAX; primitives.len()];
        for (i, (prim, a)) in primitives.iter().zip(&attrs).enumerate() {
            if let Some(emission) = a.emission {
                let area = prim.area();
                if area > 0.0 && emission.le.max_element() > 0.0 {
                    light_of_prim[i] = lights.len() as u32;
                    lights.push(AreaLight {
                        prim: i as u32,
                        emission,
                        area,
                    });
                }
            }
        }
        let weights: Vec<f32> = lights.iter().map(|l| luminance(l.power()).max(0.0)).collect();
        let Some(light_selection) = Distribution1D::new(&weights) else {
            crate::bail!(
                "{}: the scene has no light with positive power (add an `emission` to a shape)",
                source.display()
            );
        };
        let accel = Accel::build(&primitives);
        Ok(Scene {
            params: Vec::new(),
            name,
            source,
            content_hash,
            camera,
            materials,
            primitives,
            attrs,
            lights,
            light_of_prim,
            light_selection,
            user_paths,
            accel,
        })
    }

    /// Closest surface hit along `ray`.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceHit> {
        self.accel.intersect(ray).map(|h| self.surface_hit(ray, h))
    }

    /// True when nothing blocks the segment of `ray` up to its `t_max`.
    #[inline]
    pub fn unoccluded(&self, ray: &Ray) -> bool {
        self.accel.unoccluded(ray)
    }

    /// Builds the surface description of a hit. Hit points are recomputed from barycentrics
    /// (triangles) or reprojected onto the sphere, which keeps them on the surface to within
    /// a few ULPs: the robust ray offset relies on it.
    pub fn surface_hit(&self, ray: &Ray, hit: Hit) -> SurfaceHit {
        let i = hit.prim as usize;
        let attrs = &self.attrs[i];
        let (p, ng, ns, tangent) = match self.primitives[i] {
            Primitive::Triangle([a, b, c]) => {
                let bary = pull_off_edges(hit.b);
                let b0 = 1.0 - bary.x - bary.y;
                let p = b0 * a + bary.x * b + bary.y * c;
                let ng = (b - a).cross(c - a).normalize();
                let ns = match attrs.normals {
                    Some([na, nb, nc]) => {
                        let n = (b0 * na + bary.x * nb + bary.y * nc).normalize_or_zero();
                        if n == Vec3::ZERO {
                            ng
                        } else if n.dot(ng) < 0.0 {
                            -n
                        } else {
                            n
                        }
                    }
                    None => ng,
                };
                (p, ng, ns, b - a)
            }
            Primitive::Sphere { center, radius } => {
                let dir = (ray.at(hit.t) - center).normalize();
                let n = dir;
                // Tangent along increasing longitude around the sphere's y axis.
                (center + radius * dir, n, n, Vec3::new(-dir.z, 0.0, dir.x))
            }
        };
        SurfaceHit {
            t: hit.t,
            p,
            ng,
            frame: Frame::from_normal_tangent(ns, tangent),
            prim: hit.prim,
            material: attrs.material,
        }
    }

    #[inline]
    pub fn bsdf(&self, hit: &SurfaceHit) -> &Bsdf {
        &self.materials[hit.material as usize].bsdf
    }

    /// The light a primitive belongs to, if it emits.
    #[inline]
    pub fn light_of(&self, prim: u32) -> Option<&AreaLight> {
        let l = self.light_of_prim[prim as usize];
        (l != u32::MAX).then(|| &self.lights[l as usize])
    }

    /// Index of the light a primitive belongs to, if it emits.
    #[inline]
    pub fn light_index_of(&self, prim: u32) -> Option<usize> {
        let l = self.light_of_prim[prim as usize];
        (l != u32::MAX).then_some(l as usize)
    }

    /// The bounding box of every primitive (lower, upper corner); the unit cube for a scene
    /// without primitives.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for prim in &self.primitives {
            let (a, b) = match *prim {
                Primitive::Triangle(v) => (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2])),
                Primitive::Sphere { center, radius } => (center - radius, center + radius),
            };
            lo = lo.min(a);
            hi = hi.max(b);
        }
        if lo.x > hi.x { (Vec3::ZERO, Vec3::ONE) } else { (lo, hi) }
    }

    /// Total emitted power of all lights, per channel.
    pub fn total_power(&self) -> Vec3 {
        self.lights.iter().map(|l| l.power()).sum()
    }
}
