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
mod media_queries;
pub mod mitsuba;
pub mod pbrt;

pub use load::load_scene;

use crate::bsdf::{Bsdf, ColorParam};
use crate::camera::Camera;
use crate::color::luminance;
use crate::error::Result;
use crate::geometry::{Accel, Frame, Hit, Primitive, Ray};
use crate::light::delta::DeltaLight;
use crate::light::environment::Environment;
use crate::light::{AreaLight, Emission};
use crate::sampling::Distribution1D;
use crate::texture::{Scalar, TexPoint, Texture};
use glam::{Mat3, Vec2, Vec3};
use light_selection::Emitter;
use std::borrow::Cow;
use std::f32::consts::PI;
use std::path::PathBuf;

/// A named material: a reflectance model, some of whose colours may vary over the surface.
#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    /// The model; a textured parameter holds the texture's largest value here, so that the
    /// model's class ([`Bsdf::kind`]) is the one of its most reflective point.
    pub bsdf: Bsdf,
    /// Parameters driven by textures, replaced in `bsdf` at every hit ([`Material::bsdf_at`]).
    pub textures: Vec<(ColorParam, Texture)>,
    /// Mitsuba's `mask`: the probability α in (0, 1] that light meeting the surface scatters by
    /// `bsdf` rather than passing straight through ([`Scene::intersect`]); `None` is opaque.
    pub opacity: Option<Scalar>,
    /// Mitsuba's `bumpmap`: the height field whose gradient sets the normal of the model (a
    /// [`Bsdf::NormalMapped`]) at every hit ([`Scene::bsdf_of`]); `None` otherwise.
    pub bump: Option<Bump>,
}

/// A bump map's height field: `scale` × the luminance of `height` at (u, v).
#[derive(Clone, Debug)]
pub struct Bump {
    pub height: Texture,
    pub scale: f32,
}

impl Material {
    /// An untextured material.
    pub fn new(name: impl Into<String>, bsdf: Bsdf) -> Self {
        Self {
            name: name.into(),
            bsdf,
            textures: Vec::new(),
            opacity: None,
            bump: None,
        }
    }

    /// The model at surface coordinates `uv` (computed only for a textured material): borrowed
    /// when nothing is textured, the model with its textures evaluated otherwise.
    #[inline]
    pub fn bsdf_at(&self, at: impl FnOnce() -> TexPoint) -> Cow<'_, Bsdf> {
        if self.textures.is_empty() {
            return Cow::Borrowed(&self.bsdf);
        }
        let at = at();
        let mut bsdf = self.bsdf.clone();
        for (param, texture) in &self.textures {
            let value = if param.is_number() {
                Vec3::splat(texture.eval_number_at(&at))
            } else {
                texture.eval_at(&at)
            };
            bsdf.set_color(*param, value);
        }
        Cow::Owned(bsdf)
    }

    /// The opacity α at surface coordinates `uv` (computed only for a textured mask): 1 without
    /// a mask.
    #[inline]
    pub fn opacity_at(&self, uv: impl FnOnce() -> Vec2) -> f32 {
        match &self.opacity {
            None => 1.0,
            Some(Scalar::Constant(a)) => *a,
            Some(a) => a.at(uv()),
        }
    }

    /// Whether the model depends on the tangent somewhere: anisotropic as built, or with
    /// textured α_u, α_v (which may differ at a hit though their largest values agree).
    pub fn is_anisotropic(&self) -> bool {
        self.bsdf.is_anisotropic()
            || self.textures.iter().any(|(p, _)| {
                matches!(
                    p,
                    ColorParam::AlphaU | ColorParam::AlphaV | ColorParam::AlphaURemapped | ColorParam::AlphaVRemapped
                )
            })
    }

    /// Whether the shading frame's tangent must be ∂p/∂u: for an anisotropic model, and for a
    /// normal map (its normals live in the texture's tangent space).
    pub fn needs_dp_du(&self) -> bool {
        self.is_anisotropic() || matches!(self.bsdf, Bsdf::NormalMapped(_))
    }

    /// Whether anything about the material varies with (u, v).
    fn is_textured(&self) -> bool {
        !self.textures.is_empty() || matches!(self.opacity, Some(Scalar::Texture(_))) || self.bump.is_some()
    }
}

/// Where a primitive's texture coordinates (u, v) come from, as Mitsuba 3 defines them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum UvMap {
    /// A triangle without texture coordinates: (u, v) = its barycentrics (b₁, b₂).
    Barycentric,
    /// Per-vertex (u, v), interpolated.
    Vertices([Vec2; 3]),
    /// A sphere: u = φ / 2π and v = θ / π of the hit's direction from the centre in the
    /// sphere's own frame (`world_to_local`), θ from its +z axis, φ from +x towards +y.
    Sphere { world_to_local: Mat3 },
}

/// What a primitive is made of, besides its shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimAttrs {
    /// Index into `Scene::materials`.
    pub material: u32,
    /// Per-vertex shading normals of a triangle (from mesh files, disks and cylinders), if any.
    pub normals: Option<[Vec3; 3]>,
    /// Emission, if the primitive is (part of) an area light.
    pub emission: Option<Emission>,
    /// Texture coordinates.
    pub uv: UvMap,
    /// Rays meeting the back of the primitive (its geometric normal facing along them) pass
    /// through it, as Embree culls the inside of Mitsuba's open B-spline tubes
    /// ([`Scene::passes_through`]).
    pub cull_back: bool,
    /// The media inside and outside the primitive's surface (indices into `Scene::media`;
    /// Mitsuba's `interior` and `exterior`): a ray crossing it enters the one on the side it
    /// goes to ([`Scene::medium_across`]).
    pub interior: Option<u32>,
    pub exterior: Option<u32>,
}

impl PrimAttrs {
    /// A primitive of `material` with no shading normals, emission or texture coordinates.
    pub fn new(material: u32) -> Self {
        Self {
            material,
            normals: None,
            emission: None,
            uv: UvMap::Barycentric,
            cull_back: false,
            interior: None,
            exterior: None,
        }
    }
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
    /// Point, spot and directional lights (Mitsuba's `point`, `spot`, `directional`).
    pub delta_lights: Vec<DeltaLight>,
    /// Light from infinitely far away (Mitsuba's `constant` and `envmap` emitters), if any.
    pub environment: Option<Environment>,
    /// Emitter selection ∝ emitted power (luminance) over every emitter in [`Scene::emitter`]'s
    /// order: the area lights (so area light i is entry i), the delta lights, the environment.
    pub light_selection: Distribution1D,
    pub user_paths: Vec<UserPath>,
    pub accel: Accel,
    /// The bounding box of every primitive, computed once ([`Scene::bounds`]).
    bounds: (Vec3, Vec3),
    /// Whether some material has an opacity mask (only then do rays test opacity).
    masked: bool,
    /// Participating media ([`crate::medium`]), referenced by [`PrimAttrs::interior`] and
    /// [`PrimAttrs::exterior`]; empty for a scene of surfaces only.
    pub media: Vec<crate::medium::Medium>,
    /// The medium the camera sits in (Mitsuba's sensor `medium`).
    pub camera_medium: Option<u32>,
}

/// The emitters that are not shapes: at most one environment and any number of delta lights.
#[derive(Clone, Debug, Default)]
pub struct Emitters {
    pub environment: Option<Environment>,
    pub delta: Vec<DeltaLight>,
}

/// Where on a surface a model is evaluated: what a bump map needs besides (u, v).
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint<'a> {
    pub p: Vec3,
    pub ng: Vec3,
    pub frame: &'a Frame,
    pub prim: u32,
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
    /// Barycentrics (b₁, b₂) of a triangle hit (zero for spheres), for texture coordinates.
    pub bary: Vec2,
}

/// A uniform number in [0, 1) from the bits of a point and a direction (SplitMix64's finaliser
/// over each coordinate): the choice of [`Scene::passes_through`].
#[inline]
fn opacity_sample(p: Vec3, d: Vec3) -> f32 {
    let mix = |mut z: u64| {
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    let h = [p.x, p.y, p.z, d.x, d.y, d.z]
        .iter()
        .fold(0x9e37_79b9_7f4a_7c15u64, |h, x| mix(h ^ u64::from(x.to_bits())));
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
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
        Self::assemble_with_emitters(
            name,
            source,
            content_hash,
            camera,
            materials,
            primitives,
            attrs,
            user_paths,
            Emitters::default(),
        )
    }

    /// [`Scene::assemble`] with emitters that are not shapes (delta lights, an environment).
    #[allow(clippy::too_many_arguments)]
    pub fn assemble_with_emitters(
        name: String,
        source: PathBuf,
        content_hash: String,
        camera: Camera,
        materials: Vec<Material>,
        primitives: Vec<Primitive>,
        attrs: Vec<PrimAttrs>,
        user_paths: Vec<UserPath>,
        Emitters {
            environment,
            delta: delta_lights,
        }: Emitters,
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
        let bounds = bounds_of(&primitives);
        let scene_radius = bounding_sphere(bounds).1;
        let power = |p: Vec3| luminance(p).max(0.0);
        let mut weights: Vec<f32> = lights.iter().map(|l| power(l.power())).collect();
        weights.extend(delta_lights.iter().map(|l| power(l.power(scene_radius))));
        weights.extend(environment.iter().map(|e| e.power(scene_radius).max(0.0)));
        let Some(light_selection) = Distribution1D::new(&weights) else {
            crate::bail!(
                "{}: the scene has no light with positive power (add an `emission` to a shape)",
                source.display()
            )
        };
        let accel = Accel::build(&primitives);
        let masked = materials.iter().any(|m| m.opacity.is_some()) || attrs.iter().any(|a| a.cull_back);
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
            delta_lights,
            environment,
            light_selection,
            user_paths,
            accel,
            bounds,
            masked,
            media: Vec::new(),
            camera_medium: None,
        })
    }

    /// Closest surface hit along `ray`. A hit on a masked material ([`Material::opacity`]) counts
    /// with probability α there and is passed through otherwise ([`Scene::passes_through`]).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceHit> {
        let hit = self.surface_hit(ray, self.accel.intersect(ray)?);
        if self.masked {
            self.through_masks(ray, hit)
        } else {
            Some(hit)
        }
    }

    /// True when nothing blocks the segment of `ray` up to its `t_max` (masks let the segment
    /// through as they let [`Scene::intersect`]'s rays through).
    #[inline]
    pub fn unoccluded(&self, ray: &Ray) -> bool {
        if self.masked {
            self.intersect(ray).is_none()
        } else {
            self.accel.unoccluded(ray)
        }
    }

    /// The opacity α of the surface at a hit: 1 without a mask.
    #[inline]
    pub fn opacity(&self, hit: &SurfaceHit) -> f32 {
        self.materials[hit.material as usize].opacity_at(|| self.uv(hit))
    }

    /// Whether a ray along `d` meeting a masked surface at `hit` passes through it.
    ///
    /// Mitsuba's `mask` is the mixture α f_s + (1 − α) δ(ω_i + ω_o): light scatters by the
    /// material with probability α and goes on unchanged otherwise. We draw that choice as part
    /// of the ray cast, as pbrt-v4 does with alpha textures, instead of making the pass-through
    /// a delta lobe of the BSDF: every surface a ray returns is then opaque, shadow rays carry
    /// the transmittance Π (1 − α) as an unbiased 0/1 estimate, and every strategy (next-event
    /// estimation and connections to point lights through the holes of a leaf included)
    /// renders masks without knowing of them — each vertex of a path is kept with its α by the
    /// ray that found it, a factor every technique's density shares, so f / p and MIS weights
    /// are unchanged. Density estimation is the exception: a photon stands for all the light
    /// arriving at its point, so its stored power is divided by α ([`crate::photon`]).
    ///
    /// The uniform number is a hash of the hit point and the direction (not a random stream),
    /// so that the same ray always meets the same surface: images stay bit-identical for any
    /// thread count, and a Metropolis chain re-testing an unchanged edge sees what it saw.
    /// Unlike Mitsuba's path tracer, a pass-through is not a bounce (it does not count toward
    /// `max_depth`), as in pbrt.
    ///
    /// A primitive that culls its back ([`PrimAttrs::cull_back`]) lets every ray meeting its back
    /// through, as if it were not there (Embree's and so Mitsuba's curves).
    #[inline]
    pub fn passes_through(&self, hit: &SurfaceHit, d: Vec3) -> bool {
        if self.attrs[hit.prim as usize].cull_back && hit.ng.dot(d) > 0.0 {
            return true;
        }
        let alpha = self.opacity(hit);
        alpha < 1.0 && opacity_sample(hit.p, d) >= alpha
    }

    /// The medium a ray leaving `hit` along `d` travels in, when the primitive bounds media
    /// (Mitsuba's `target_medium`: the exterior on the side the geometric normal faces, the
    /// interior behind it); `None` when it does not, and the ray stays in the medium it was in.
    #[inline]
    pub fn medium_across(&self, hit: &SurfaceHit, d: Vec3) -> Option<Option<u32>> {
        self.medium_across_prim(hit.prim, hit.ng, d)
    }

    /// [`Scene::medium_across`] at a point of primitive `prim` with geometric normal `ng`.
    #[inline]
    pub fn medium_across_prim(&self, prim: u32, ng: Vec3, d: Vec3) -> Option<Option<u32>> {
        let a = &self.attrs[prim as usize];
        if a.interior.is_none() && a.exterior.is_none() {
            return None;
        }
        Some(if ng.dot(d) > 0.0 { a.exterior } else { a.interior })
    }

    /// The first surface along `ray` *without* passing masks: the volumetric walk passes them
    /// itself, since a medium boundary it passes still changes the medium.
    #[inline]
    pub fn intersect_any(&self, ray: &Ray) -> Option<SurfaceHit> {
        Some(self.surface_hit(ray, self.accel.intersect(ray)?))
    }

    /// Follows `ray` on through the masked surfaces it passes ([`Scene::passes_through`]).
    #[cold]
    fn through_masks(&self, ray: &Ray, mut hit: SurfaceHit) -> Option<SurfaceHit> {
        let end = ray.at(ray.t_max);
        let mut t_before = 0.0;
        while self.passes_through(&hit, ray.d) {
            t_before += hit.t;
            let next = if ray.t_max.is_finite() {
                crate::geometry::spawn_ray_to_end(hit.p, hit.ng, ray.d, end)?
            } else {
                crate::geometry::spawn_ray(hit.p, hit.ng, ray.d)
            };
            hit = self.surface_hit(&next, self.accel.intersect(&next)?);
        }
        hit.t += t_before;
        Some(hit)
    }

    /// Builds the surface description of a hit. Hit points are recomputed from barycentrics
    /// (triangles) or reprojected onto the sphere, which keeps them on the surface to within
    /// a few ULPs: the robust ray offset relies on it.
    pub fn surface_hit(&self, ray: &Ray, hit: Hit) -> SurfaceHit {
        let i = hit.prim as usize;
        let attrs = &self.attrs[i];
        let mut bary = Vec2::ZERO;
        // The tangent ∂p/∂u orients anisotropic models and a normal map's tangent space (the
        // texture's); other materials keep the frame they always had (so that their images stay
        // bit-identical to earlier versions).
        let material = &self.materials[attrs.material as usize];
        let needs_dp_du = material.needs_dp_du();
        let (p, ng, ns, tangent) = match self.primitives[i] {
            Primitive::Triangle([a, b, c]) => {
                bary = pull_off_edges(hit.b);
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
                let tangent = if needs_dp_du {
                    triangle_dp_du([a, b, c], attrs.uv)
                } else {
                    b - a
                };
                (p, ng, ns, tangent)
            }
            Primitive::Sphere { center, radius } => {
                let dir = (ray.at(hit.t) - center).normalize();
                let n = dir;
                // Anisotropic models: the tangent along increasing u (longitude about the
                // sphere's own z axis), Mitsuba's dp/du; otherwise longitude about world y.
                let tangent = match attrs.uv {
                    UvMap::Sphere { world_to_local } if needs_dp_du => {
                        let l = world_to_local * dir;
                        world_to_local.transpose() * Vec3::new(-l.y, l.x, 0.0)
                    }
                    _ => Vec3::new(-dir.z, 0.0, dir.x),
                };
                (center + radius * dir, n, n, tangent)
            }
        };
        SurfaceHit {
            t: hit.t,
            p,
            ng,
            frame: Frame::from_normal_tangent(ns, tangent),
            prim: hit.prim,
            material: attrs.material,
            bary,
        }
    }

    /// The reflectance model at a hit, its textures evaluated there.
    #[inline]
    pub fn bsdf(&self, hit: &SurfaceHit) -> Cow<'_, Bsdf> {
        let at = SurfacePoint {
            p: hit.p,
            ng: hit.ng,
            frame: &hit.frame,
            prim: hit.prim,
        };
        self.bsdf_of(hit.material, at, || self.tex_point(hit))
    }

    /// The model of `material` at a point of a surface, with texture coordinates `uv`: its
    /// textures evaluated there and, under a bump map, the normal of the displaced surface.
    #[inline]
    pub fn bsdf_of(&self, material: u32, at: SurfacePoint, tex: impl FnOnce() -> TexPoint) -> Cow<'_, Bsdf> {
        let material = &self.materials[material as usize];
        let Some(bump) = &material.bump else {
            return material.bsdf_at(tex);
        };
        let tex = tex();
        let mut bsdf = material.bsdf_at(|| tex).into_owned();
        if let Bsdf::NormalMapped(b) = &mut bsdf {
            b.normal = self.bumped_normal(bump, &at, tex.uv);
        }
        Cow::Owned(bsdf)
    }

    /// The normal a bump map gives, in the point's shading frame (Mitsuba 3's `bumpmap`): the
    /// surface's ∂p/∂u and ∂p/∂v lose their normal components and gain the height's slopes
    /// (∂h/∂u, ∂h/∂v) along the normal; the displaced normal is their cross product, turned to
    /// the geometric normal's side.
    fn bumped_normal(&self, bump: &Bump, at: &SurfacePoint, uv: Vec2) -> Vec3 {
        let slope = bump.scale * bump.height.gradient_number(uv);
        let (dp_du, dp_dv) = self.dp_duv(at.prim, at.p);
        let (du, dv) = (at.frame.to_local(dp_du), at.frame.to_local(dp_dv));
        let n = Vec3::new(du.x, du.y, slope.x).cross(Vec3::new(dv.x, dv.y, slope.y));
        let n = if n.dot(at.frame.to_local(at.ng)) < 0.0 { -n } else { n };
        n.try_normalize().unwrap_or(Vec3::Z)
    }

    /// ∂p/∂u and ∂p/∂v of primitive `prim` at its point `p` (Mitsuba's, from [`UvMap`]).
    fn dp_duv(&self, prim: u32, p: Vec3) -> (Vec3, Vec3) {
        let i = prim as usize;
        match self.primitives[i] {
            Primitive::Triangle(tri) => triangle_dp_duv(tri, self.attrs[i].uv),
            Primitive::Sphere { center, radius } => {
                let dir = (p - center).normalize();
                let world_to_local = match self.attrs[i].uv {
                    UvMap::Sphere { world_to_local } => world_to_local,
                    _ => Mat3::IDENTITY,
                };
                sphere_dp_duv(world_to_local, world_to_local * dir, radius)
            }
        }
    }

    /// Where a hit's textures are read when its material has textures, zero otherwise (what
    /// a path vertex keeps to evaluate its model later).
    #[inline]
    pub fn texture_point(&self, hit: &SurfaceHit) -> TexPoint {
        if !self.materials[hit.material as usize].is_textured() {
            TexPoint::default()
        } else {
            self.tex_point(hit)
        }
    }

    /// Where a hit's textures are read: its (u, v), primitive and barycentrics.
    #[inline]
    pub fn tex_point(&self, hit: &SurfaceHit) -> TexPoint {
        TexPoint {
            uv: self.uv(hit),
            prim: hit.prim,
            bary: hit.bary,
        }
    }

    /// Texture coordinates (u, v) of a hit ([`UvMap`]).
    pub fn uv(&self, hit: &SurfaceHit) -> Vec2 {
        let i = hit.prim as usize;
        match self.attrs[i].uv {
            UvMap::Barycentric => hit.bary,
            UvMap::Vertices([a, b, c]) => (1.0 - hit.bary.x - hit.bary.y) * a + hit.bary.x * b + hit.bary.y * c,
            UvMap::Sphere { world_to_local } => {
                let Primitive::Sphere { center, .. } = self.primitives[i] else {
                    return hit.bary;
                };
                let d = world_to_local * (hit.p - center).normalize_or_zero();
                let theta = d.z.clamp(-1.0, 1.0).acos();
                let mut phi = d.y.atan2(d.x);
                if phi < 0.0 {
                    phi += 2.0 * PI;
                }
                Vec2::new(phi / (2.0 * PI), theta / PI)
            }
        }
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
        self.bounds
    }

    /// Total emitted power of every emitter, per channel (for directional light and the
    /// environment, what crosses the scene's bounding sphere, as their photons carry it).
    pub fn total_power(&self) -> Vec3 {
        let radius = self.bounding_sphere().1;
        let area: Vec3 = self.lights.iter().map(|l| l.power()).sum();
        let delta: Vec3 = self.delta_lights.iter().map(|l| l.power(radius)).sum();
        let environment = self
            .environment
            .as_ref()
            .map_or(Vec3::ZERO, |e| e.mean_radiance() * (4.0 * PI * PI * radius * radius));
        area + delta + environment
    }

    /// The number of emitters [`Scene::emitter`] numbers: area lights, delta lights and the
    /// environment.
    #[inline]
    pub fn emitter_count(&self) -> usize {
        self.lights.len() + self.delta_lights.len() + usize::from(self.environment.is_some())
    }

    /// Emitter `i` in the order of [`Scene::light_selection`].
    #[inline]
    pub fn emitter(&self, i: usize) -> Emitter {
        let areas = self.lights.len();
        if i < areas {
            Emitter::Area(i)
        } else if i < areas + self.delta_lights.len() {
            Emitter::Delta(i - areas)
        } else {
            Emitter::Environment
        }
    }

    /// The index of the environment among the emitters, if there is one.
    #[inline]
    pub fn environment_index(&self) -> Option<usize> {
        self.environment
            .as_ref()
            .map(|_| self.lights.len() + self.delta_lights.len())
    }

    /// The probability that selection by power picks the environment (0 without one).
    #[inline]
    pub fn environment_power_share(&self) -> f32 {
        self.environment_index().map_or(0.0, |i| self.light_selection.pmf(i))
    }

    /// The scene's bounding sphere (centre, radius > 0): where directional and environment
    /// photons come from.
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        bounding_sphere(self.bounds)
    }
}

/// The sphere around a bounding box (centre, radius > 0).
fn bounding_sphere((lo, hi): (Vec3, Vec3)) -> (Vec3, f32) {
    (0.5 * (lo + hi), (0.5 * (hi - lo).length()).max(f32::MIN_POSITIVE))
}

/// The bounding box of `primitives` (lower, upper corner); the unit cube when there are none.
fn bounds_of(primitives: &[Primitive]) -> (Vec3, Vec3) {
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for prim in primitives {
        let (a, b) = match *prim {
            Primitive::Triangle(v) => (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2])),
            Primitive::Sphere { center, radius } => (center - radius, center + radius),
        };
        lo = lo.min(a);
        hi = hi.max(b);
    }
    if lo.x > hi.x { (Vec3::ZERO, Vec3::ONE) } else { (lo, hi) }
}

/// The direction of ∂p/∂u on triangle a b c, which orients the shading frame (anisotropic
/// models follow it): from the vertices' texture coordinates when they have some and they are
/// not degenerate, otherwise b − a (∂p/∂u of the barycentric parameterization), as Mitsuba.
#[inline]
fn triangle_dp_du(tri: [Vec3; 3], uv: UvMap) -> Vec3 {
    triangle_dp_duv(tri, uv).0
}

/// ∂p/∂u and ∂p/∂v of a triangle: from its vertices' (u, v), or (b₁, b₂) without them (then
/// b − a and c − a); degenerate coordinates fall back to the latter.
fn triangle_dp_duv([a, b, c]: [Vec3; 3], uv: UvMap) -> (Vec3, Vec3) {
    if let UvMap::Vertices([ta, tb, tc]) = uv {
        let (d1, d2) = (tb - ta, tc - ta);
        let det = d1.x * d2.y - d1.y * d2.x;
        if det.abs() > 1e-12 {
            let (e1, e2) = (b - a, c - a);
            return ((e1 * d2.y - e2 * d1.y) / det, (e2 * d1.x - e1 * d2.x) / det);
        }
    }
    (b - a, c - a)
}

/// ∂p/∂u and ∂p/∂v of a sphere of `radius` at local unit direction `l` (u = φ / 2π, v = θ / π
/// in its own frame, [`UvMap::Sphere`]), in world coordinates.
fn sphere_dp_duv(world_to_local: Mat3, l: Vec3, radius: f32) -> (Vec3, Vec3) {
    let sin_theta = (l.x * l.x + l.y * l.y).sqrt();
    let (cos_phi, sin_phi) = if sin_theta > 0.0 {
        (l.x / sin_theta, l.y / sin_theta)
    } else {
        (1.0, 0.0)
    };
    let du = 2.0 * PI * radius * Vec3::new(-l.y, l.x, 0.0);
    let dv = PI * radius * Vec3::new(l.z * cos_phi, l.z * sin_phi, -sin_theta);
    let to_world = world_to_local.transpose();
    (to_world * du, to_world * dv)
}
