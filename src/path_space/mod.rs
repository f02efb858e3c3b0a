//! Path space [Veach 1997, ch. 8]: light-to-eye paths X = (x₀ on a light, x₁, …, x_k at the
//! eye) as lists of [`Vertex`], their contribution f(X) in the area-product measure, and the
//! area densities with which sub-path sampling produces each vertex (what the Metropolis
//! proposals of [`crate::metropolis`] need for their transition densities).
//!
//! **Contribution** [Fan et al. 2005, eq. (3); Veach 1997, eq. (8.7)]:
//! f(X) = Le(x₀→x₁) G(x₀,x₁) Π_{i=1}^{k−1} f_s(x_{i−1}→x_i→x_{i+1}) G(x_i,x_{i+1}),
//! with G(a,b) = |cos θ_a| |cos θ_b| / |a − b|², θ_b (the end nearer the eye) against the
//! shading normal ([`geometry`]; visibility is checked by whoever builds a new edge: traced
//! edges are visible by construction, connections cast a shadow ray). The last
//! factor, for the edge to the eye, is the camera's importance in raster units:
//! C(x_{k−1}) = du/dA(x_{k−1}) = s² |cos θ_x| / (r² cos³ θ_cam) ([`camera_factor`]), zero outside
//! the image. With it, ∫ f dμ is the sum over pixels of the pixel values (pixel area 1), so the
//! normalisation B = ∫ f_Y dμ is the total luminance reaching the image, the paper's B_eye.
//!
//! **Cameras** (Veach 1997 makes the lens point a vertex of the path): x_k is the pinhole, a point
//! of a thin lens's disc, or the point of an orthographic camera's film rectangle behind x_{k−1}.
//! *Thin lens*: x_k is a vertex of its own whose measure is the lens disc's area divided by the
//! disc's (a probability measure, so that a pinhole is its limit and x_k's density is 1 for
//! every technique: the eye side always draws it uniformly, and no technique ends a light walk
//! on the lens). C(x_{k−1}) is then the pinhole's factor seen from x_k, with the raster
//! position where the ray x_k → x_{k−1} crosses the plane of focus (a pixel value is the
//! lens-averaged radiance through it, as the path tracer estimates it). *Orthographic*: the
//! direction is a delta, so the path's measure lives on x_{k−1} and x_k is determined by it
//! (the film point behind it, [`eye_toward`]); C(x_{k−1}) = du/dA_film |cos θ_x| (the film area
//! behind dA(x) is |cos θ_x| dA(x)), and a connection to the eye is deterministic, as next-event
//! estimation toward a directional light is. The environment seen straight ahead (k = 1) is a
//! delta in both directions: only the eye walk makes it, so its vertex is specular (`delta`
//! set by the walk) and C is du/dA_film, the coefficient of the delta.
//!
//! **Specular vertices** (only delta lobes: mirrors, smooth glass) carry the coefficient of
//! their delta distribution in f and the probability of choosing their lobe in the densities
//! ("dropped deltas"). Each density below then has the same delta factors as f, so every
//! ratio f / p and f(Y) T(X|Y) / (f(X) T(Y|X)) is that of the true measures [Veach 1997,
//! §8.3.2 and §10.3.5]; a connection (deterministic edge) must join two non-delta vertices.
//! A model with both kinds of lobe (smooth plastic) splits path space into components [Veach
//! 1997, §8.3.2]: its vertex is specular in the paths that took the delta lobe there and
//! non-delta in the others, so `Vertex::delta` is a property of the path, set by the walk that
//! sampled the lobe (`mixed` vertices), and a connection or merge ending there takes the
//! non-delta lobe ([`Vertex::as_endpoint`]; [`walk::join`] does it). This is pbrt-v3's
//! per-vertex `delta` of bidirectional methods.
//!
//! **Light from infinitely far away** (environment and directional light) [Veach 1997,
//! §8.3.3 on emitters at infinity; pbrt-v4 §13.9]: x₀ is a direction, not a point — the vertex
//! stores the unit direction ω in which its light travels into the scene (in `ng`), and its
//! measure is solid angle. The edge (x₀, x₁) then has G = |cos θ₁| (no distance, no cosine
//! at x₀; [`direction`] reports distance 1 for it), Le is the environment's radiance arriving
//! from −ω (a directional light's irradiance E, the coefficient of its delta in direction),
//! the light side draws x₀ with the environment's importance sampling (a directional light:
//! the probability of choosing it) and x₁ through the disc of [`crate::light::parallel_ray_origin`],
//! area density |cos θ₁| / πR², and the eye side reaches x₀ by a ray that leaves the scene, with
//! the BSDF's solid-angle density (never a directional light's delta).
//!
//! **Layered models** (pbrt-v4's coated materials, [`crate::bsdf::Coated`]) have only estimates
//! of f_s and of their sampling density p̃. Densities then enter only MIS weights, where the
//! same deterministic p̃ for every technique keeps the weights a partition of one; but a walk's
//! f / p must be the walk's own weight, not f̃ / p̃ at the direction it drew (that ratio is
//! biased: the direction was drawn from the walk's true density, not from p̃). So the walk
//! records its sample ([`Vertex::sampled`]), and f_s on that pair of edges is the f the sample
//! reported, weight × p̃ ([`scattering_at`]); every other pair (a connection, a merge) reads
//! the model's estimate. Metropolis proposals need true densities and refuse these models.
//!
//! Directions at a surface vertex must lie on the sides that the shading frame and the
//! geometric normal agree on (as in the path tracer); otherwise f = 0.
//!
//! What does not live here: the Markov chain and its proposals ([`crate::metropolis`]) and any
//! strategy; this is the measure-theoretic layer both read.

pub mod bidirectional;
pub mod media;
pub mod walk;

use crate::bsdf::{Bsdf, TransportMode};
use crate::camera::Lens;
use crate::geometry::{Frame, spawn_ray, spawn_shadow_ray};
use crate::light::delta::DeltaLight;
use crate::sampling::Rng;
use crate::scene::{Scene, SurfaceHit};
use crate::texture::TexPoint;
use glam::{Vec2, Vec3};
use std::borrow::Cow;
use std::f32::consts::{FRAC_1_PI, PI};

/// What a vertex is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VertexKind {
    /// x₀, a point on light `index` of `Scene::lights`.
    Light(u32),
    /// x₀, the position of point, spot or projector light `index` of `Scene::delta_lights`. It has no
    /// normal (`ng` is zero): its emission is an intensity, so the edge leaving it has no
    /// cosine at x₀ ([`cos_at`]), and its "area density" is the probability of choosing it, a
    /// delta that every technique able to make such a path shares (the eye side can never
    /// hit it, and the pinhole never sees it).
    DeltaLight(u32),
    /// x₀, the environment: light arriving from infinitely far away along direction −`ng`
    /// (module doc).
    Environment,
    /// x₀, directional light `index` of `Scene::delta_lights`, travelling along `ng`: a delta
    /// in direction, which the eye side can never reach (module doc).
    Directional(u32),
    /// A scattering point.
    Surface,
    /// A scattering point inside medium `index` of `Scene::media`: no surface, so no normal
    /// and no cosine ([`cos_at`] is 1); its f_s is the medium's phase function ([`scattering_at`]),
    /// and σ_s and the transmittance are carried by the walk's free flights, which also made
    /// the point (made by the walks of [`media`]).
    Medium(u32),
    /// x_k, on the camera: the pinhole, a lens point or a film point (module doc, "Cameras").
    Eye,
}

/// One vertex of a path.
#[derive(Clone, Copy, Debug)]
pub struct Vertex {
    pub p: Vec3,
    /// Unit geometric normal (the eye: the view direction).
    pub ng: Vec3,
    /// Shading frame (surface vertices).
    pub frame: Frame,
    /// Primitive the vertex lies on (`u32::MAX` for the eye).
    pub prim: u32,
    pub material: u32,
    /// Where its textures are read (surface vertices of textured materials; zero otherwise).
    pub tex: TexPoint,
    pub kind: VertexKind,
    /// The path scatters here through a delta lobe: a "specular" vertex, S in Heckbert's
    /// grammar. Fixed by the material for models with only delta lobes (mirror, smooth
    /// dielectric) or none; for a model with both (`mixed`) it records the lobe the path took.
    pub delta: bool,
    /// The material has a delta lobe beside a non-delta one (Mitsuba's smooth `plastic`): the
    /// vertex is made non-delta (the end a connection or a merge sees, [`Vertex::as_endpoint`])
    /// and becomes delta when the walk leaving it samples the delta lobe
    /// ([`walk::sample_direction`]). Module doc, "Specular vertices".
    pub mixed: bool,
    /// The walk's own sample here when the material is a stochastic model (pbrt's layered
    /// models, [`crate::bsdf::Bsdf::is_stochastic`]); `None` otherwise. Module doc, "Layered
    /// models".
    pub sampled: Option<SampledScattering>,
}

/// What a walk drew at a vertex of a stochastic model: the direction it left along (world), the
/// mode it sampled in and the f the sample reported, which stands for f_s on the walk's own
/// pair of edges ([`scattering_at`]).
#[derive(Clone, Copy, Debug)]
pub struct SampledScattering {
    pub toward: Vec3,
    pub mode: TransportMode,
    pub f: Vec3,
}

impl Vertex {
    /// A scattering vertex at a ray hit.
    pub fn surface(scene: &Scene, hit: &SurfaceHit) -> Self {
        let bsdf = scene.bsdf(hit);
        Self {
            p: hit.p,
            ng: hit.ng,
            frame: hit.frame,
            prim: hit.prim,
            material: hit.material,
            tex: scene.texture_point(hit),
            kind: VertexKind::Surface,
            delta: bsdf.is_delta(),
            mixed: bsdf.mixes_delta(),
            sampled: None,
        }
    }

    /// A light vertex x₀ at point `p` (normal `n`) of light `light`.
    pub fn light(scene: &Scene, light: usize, p: Vec3, n: Vec3) -> Self {
        let prim = scene.lights[light].prim;
        Self {
            p,
            ng: n,
            frame: Frame::from_normal(n),
            prim,
            material: scene.attrs[prim as usize].material,
            tex: TexPoint::default(),
            kind: VertexKind::Light(light as u32),
            delta: false,
            mixed: false,
            sampled: None,
        }
    }

    /// x₀ at delta light `j` of `Scene::delta_lights`: the position of a point, spot or projector light,
    /// the direction of a directional light.
    pub fn delta_light(scene: &Scene, j: usize) -> Self {
        match scene.delta_lights[j] {
            DeltaLight::Directional { direction, .. } => {
                Self::at_infinity(VertexKind::Directional(j as u32), direction)
            }
            ref light => Self {
                p: light.position().unwrap_or(Vec3::ZERO),
                ng: Vec3::ZERO,
                frame: Frame::from_normal(Vec3::Z),
                prim: u32::MAX,
                material: u32::MAX,
                tex: TexPoint::default(),
                kind: VertexKind::DeltaLight(j as u32),
                delta: false,
                mixed: false,
                sampled: None,
            },
        }
    }

    /// x₀ on the environment, its light travelling along unit `travel` (from the light into
    /// the scene; an eye ray leaving the scene along d reaches the vertex with `travel` = −d).
    pub fn environment(travel: Vec3) -> Self {
        Self::at_infinity(VertexKind::Environment, travel)
    }

    /// A vertex infinitely far away whose light travels along `travel` (module doc). Its
    /// position is never read: [`direction`] and [`visible`] use `travel`.
    fn at_infinity(kind: VertexKind, travel: Vec3) -> Self {
        Self {
            p: Vec3::ZERO,
            ng: travel,
            frame: Frame::from_normal(travel),
            prim: u32::MAX,
            material: u32::MAX,
            tex: TexPoint::default(),
            kind,
            delta: false,
            mixed: false,
            sampled: None,
        }
    }

    /// A scattering vertex at point `p` inside medium `medium` of `Scene::media`.
    pub fn in_medium(p: Vec3, medium: u32) -> Self {
        Self {
            p,
            ng: Vec3::ZERO,
            frame: Frame::from_normal(Vec3::Z),
            prim: u32::MAX,
            material: u32::MAX,
            tex: TexPoint::default(),
            kind: VertexKind::Medium(medium),
            delta: false,
            mixed: false,
            sampled: None,
        }
    }

    /// The eye vertex x_k of a new eye sub-path: the pinhole, a point drawn uniformly on a thin
    /// lens (nothing is drawn for the other cameras), or the eye point of an orthographic
    /// camera, which the walk's first ray moves to its film point ([`walk::first_eye_vertex`]).
    pub fn eye(scene: &Scene, rng: &mut Rng) -> Self {
        let cam = &scene.camera;
        let p = match cam.lens {
            Lens::Thin { .. } => cam.lens_point(rng.uniform2()),
            _ => cam.eye,
        };
        Self::eye_at(scene, p)
    }

    /// The eye vertex at point `p` of the lens or the film.
    pub fn eye_at(scene: &Scene, p: Vec3) -> Self {
        let forward = scene.camera.forward();
        Self {
            p,
            ng: forward,
            frame: Frame::from_normal(forward),
            prim: u32::MAX,
            material: u32::MAX,
            tex: TexPoint::default(),
            kind: VertexKind::Eye,
            delta: false,
            mixed: false,
            sampled: None,
        }
    }

    /// The same point as x₀ of a path, when it lies on a light (an eye path that hit an emitter).
    pub fn as_light(&self, scene: &Scene) -> Option<Self> {
        if self.kind == VertexKind::Environment {
            return Some(*self);
        }
        if self.prim == u32::MAX {
            return None;
        }
        let light = scene.light_index_of(self.prim)?;
        Some(Self::light(scene, light, self.p, self.ng))
    }

    /// x₀ of a path: a point on an area light, a point, spot or projector light, the environment or a
    /// directional light.
    #[inline]
    pub fn is_light(&self) -> bool {
        !matches!(self.kind, VertexKind::Surface | VertexKind::Eye | VertexKind::Medium(_))
    }

    /// Environment or directional light: a direction rather than a point (module doc).
    #[inline]
    pub fn is_at_infinity(&self) -> bool {
        matches!(self.kind, VertexKind::Environment | VertexKind::Directional(_))
    }

    /// Can the eye side's random walk reach this light vertex (an emitting surface or the
    /// environment; never a point, spot or directional light, whose measure is a delta)?
    #[inline]
    pub fn is_hittable_light(&self) -> bool {
        matches!(self.kind, VertexKind::Light(_) | VertexKind::Environment)
    }

    #[inline]
    pub fn is_surface(&self) -> bool {
        self.kind == VertexKind::Surface
    }

    /// A scattering vertex: on a surface, or at a point in a medium.
    #[inline]
    pub fn scatters(&self) -> bool {
        matches!(self.kind, VertexKind::Surface | VertexKind::Medium(_))
    }

    /// A point of a surface, with its material: a scattering vertex or a point on an area light
    /// (which a bidirectional mutation may keep as an interior vertex of a new path).
    #[inline]
    pub fn on_surface(&self) -> bool {
        matches!(self.kind, VertexKind::Surface | VertexKind::Light(_))
    }

    /// Can a deterministic edge (a connection) end here in this path? Not where the path
    /// scatters through a delta lobe.
    #[inline]
    pub fn connectible(&self) -> bool {
        !self.delta
    }

    /// Can a connection or a merge end at this vertex of a sub-path, whatever lobe the walk took
    /// when it went on from here? Everywhere but on models with only delta lobes.
    #[inline]
    pub fn can_end_connection(&self) -> bool {
        !self.delta || self.mixed
    }

    /// The vertex as the end of a connection or a merge: on a model with both kinds of lobe,
    /// the non-delta one (a deterministic edge meets only a density, never a delta).
    #[inline]
    pub fn as_endpoint(&self) -> Self {
        Self {
            delta: self.delta && !self.mixed,
            ..*self
        }
    }

    #[inline]
    pub fn bsdf<'a>(&self, scene: &'a Scene) -> Cow<'a, Bsdf> {
        let at = crate::scene::SurfacePoint {
            p: self.p,
            ng: self.ng,
            frame: &self.frame,
            prim: self.prim,
        };
        scene.bsdf_of(self.material, at, || self.tex)
    }

    /// The opacity α of a surface vertex's material there ([`crate::scene::Material::opacity`]).
    #[inline]
    pub fn opacity(&self, scene: &Scene) -> f32 {
        scene.materials[self.material as usize].opacity_at(|| self.tex.uv)
    }
}

/// Unit direction from `a` to `b`, and the squared distance; 1 when either lies at infinity
/// (its measure is solid angle: the distance drops out of G and of every density conversion).
#[inline]
pub fn direction(a: &Vertex, b: &Vertex) -> (Vec3, f32) {
    if a.is_at_infinity() {
        return (a.ng, 1.0);
    }
    if b.is_at_infinity() {
        return (-b.ng, 1.0);
    }
    let d = b.p - a.p;
    let d2 = d.length_squared();
    if d2 > 0.0 {
        (d / d2.sqrt(), d2)
    } else {
        (Vec3::ZERO, 0.0)
    }
}

/// |cos θ| of direction `d` at vertex `v`: 1 at a point, spot or projector light, whose emission is an
/// intensity (Le G becomes I |cos θ₁| / r² [Veach 1997, §8.1.1 on point sources]), and at a
/// light infinitely far away (module doc).
#[inline]
pub fn cos_at(v: &Vertex, d: Vec3) -> f32 {
    match v.kind {
        VertexKind::DeltaLight(_) | VertexKind::Environment | VertexKind::Directional(_) | VertexKind::Medium(_) => 1.0,
        VertexKind::Light(_) | VertexKind::Surface | VertexKind::Eye => v.ng.dot(d).abs(),
    }
}

/// |cos θ_b| / |a − b|²: turns a solid-angle density at `a` into an area density at `b` (1
/// when `b` lies at infinity, whose densities are solid-angle ones).
#[inline]
pub fn solid_angle_to_area(a: &Vertex, b: &Vertex) -> f32 {
    let (d, d2) = direction(a, b);
    if d2 == 0.0 { 0.0 } else { cos_at(b, d) / d2 }
}

/// The eye vertex that a connection from `x` meets, given the path's eye vertex `eye`: `eye`
/// itself (pinhole, lens point), or for an orthographic camera the film point behind `x`
/// (module doc, "Cameras"; `eye` when there is none: [`camera_factor`] is then `None`).
pub fn eye_toward(scene: &Scene, x: &Vertex, eye: &Vertex) -> Vertex {
    let cam = &scene.camera;
    match cam.is_orthographic() && !x.is_at_infinity() {
        true => cam.film_point(x.p).map_or(*eye, |(o, _)| Vertex::eye_at(scene, o)),
        false => *eye,
    }
}

/// The camera factor C(x) = du/dA(x) of a vertex `x` seen from eye vertex `eye` (module doc,
/// "Cameras"), with its raster position (du/dω for the environment, whose measure is solid
/// angle); `None` outside the image or behind the camera, and for point, spot and directional
/// light (a delta the camera cannot see).
pub fn camera_factor(scene: &Scene, x: &Vertex, eye: &Vertex) -> Option<(Vec2, f32)> {
    if matches!(x.kind, VertexKind::DeltaLight(_) | VertexKind::Directional(_)) {
        return None;
    }
    let cam = &scene.camera;
    let (raster, c) = if cam.is_orthographic() {
        if x.is_at_infinity() {
            // The environment straight ahead: a specular edge only the eye walk makes.
            (cam.film_raster(eye.p).filter(|_| x.delta)?, cam.raster_per_film_area())
        } else {
            let (_, raster) = cam.film_point(x.p)?;
            (raster, cam.raster_per_film_area() * cos_at(x, -cam.forward()))
        }
    } else {
        let (d, r2) = if x.is_at_infinity() {
            (-x.ng, 1.0)
        } else {
            let d = x.p - eye.p;
            let r2 = d.length_squared();
            if r2 == 0.0 {
                return None;
            }
            (d / r2.sqrt(), r2)
        };
        let raster = cam.raster_from(eye.p, d)?;
        (raster, cam.raster_per_solid_angle(d) * cos_at(x, d) / r2)
    };
    (c > 0.0 && c.is_finite()).then_some((raster, c))
}

/// A direction leaving surface vertex `v` in world space, as a local direction, provided the
/// shading frame and the geometric normal put it on the same side.
#[inline]
fn local_dir(v: &Vertex, w: Vec3) -> Option<Vec3> {
    let l = v.frame.to_local(w);
    (l.z * w.dot(v.ng) > 0.0).then_some(l)
}

/// f_s(x_{i−1} → x_i → x_{i+1}) at surface vertex i (radiance flows from i−1 to i+1).
pub fn scattering(scene: &Scene, path: &[Vertex], i: usize) -> Vec3 {
    scattering_at(scene, &path[i], &path[i + 1], &path[i - 1])
}

/// f_s at surface vertex `v` for radiance arriving from `light_side` and leaving toward
/// `eye_side` ([`scattering`] of the vertex between them). On the edge a walk drew at a
/// stochastic model ([`Vertex::sampled`]) it is the f that sample reported, so that a path's
/// f / p is the walk's weight (module doc, "Layered models").
pub fn scattering_at(scene: &Scene, v: &Vertex, eye_side: &Vertex, light_side: &Vertex) -> Vec3 {
    if let VertexKind::Medium(m) = v.kind {
        // Light arrives travelling along −(v → light side) and leaves along v → eye side.
        let phase = &scene.media[m as usize].phase;
        return Vec3::splat(phase.eval(-direction(v, light_side).0, direction(v, eye_side).0));
    }
    let (Some(wo), Some(wi)) = (
        local_dir(v, direction(v, eye_side).0),
        local_dir(v, direction(v, light_side).0),
    ) else {
        return Vec3::ZERO;
    };
    if let Some(s) = &v.sampled {
        let drawn = match s.mode {
            TransportMode::Radiance => light_side,
            TransportMode::Importance => eye_side,
        };
        if direction(v, drawn).0.dot(s.toward) > 1.0 - 1e-6 {
            return s.f;
        }
    }
    let bsdf = v.bsdf(scene);
    if v.delta {
        bsdf.delta_lobe(wo, wi, TransportMode::Radiance)
            .map_or(Vec3::ZERO, |(f, _)| f)
    } else {
        bsdf.eval(wo, wi, TransportMode::Radiance)
    }
}

/// Geometry term G(x_i, x_{i+1}) of an edge, `a` = x_i on the light side, `b` = x_{i+1} on the
/// eye side, without visibility: |cos θ_a| |cos θ_b| / |a − b|², where θ_b is measured against
/// b's *shading* normal when b is a surface vertex, θ_a against a's geometric normal. That is
/// the rendering equation with shading normals, L(b→·) = ∫ f_s L(a→b) |n_s(b)·ω| dω with
/// dω = |n_g(a)·ω| / |a − b|² dA(a), what `path` (and Mitsuba) integrate, so every strategy
/// built on path space estimates the same image as `path` on smooth-shaded meshes; light
/// sub-paths, whose densities convert with geometric cosines, get Veach's adjoint correction
/// for shading normals [Veach 1997, eq. (5.19)] from the ratio f / p without further code.
#[inline]
pub fn geometry(a: &Vertex, b: &Vertex) -> f32 {
    let (d, d2) = direction(a, b);
    if d2 == 0.0 {
        0.0
    } else {
        let cos_b = if b.is_surface() {
            b.frame.n.dot(d).abs()
        } else {
            cos_at(b, d)
        };
        cos_at(a, d) * cos_b / d2
    }
}

/// Emitted radiance Le(x₀ → x₁) (the intensity I(x₀ → x₁) at a point, spot or projector light, the
/// irradiance E of a directional light).
pub fn emitted(scene: &Scene, path: &[Vertex]) -> Vec3 {
    let d = direction(&path[0], &path[1]).0;
    match path[0].kind {
        VertexKind::Light(l) => scene.lights[l as usize].le(path[0].ng, d),
        VertexKind::DeltaLight(j) => scene.delta_lights[j as usize].intensity(d),
        VertexKind::Environment => scene.environment.as_ref().map_or(Vec3::ZERO, |env| env.le(-d)),
        VertexKind::Directional(j) => match scene.delta_lights[j as usize] {
            DeltaLight::Directional { irradiance, .. } => irradiance,
            _ => Vec3::ZERO,
        },
        VertexKind::Surface | VertexKind::Eye | VertexKind::Medium(_) => Vec3::ZERO,
    }
}

/// Le G Π f_s G up to vertex `upto` (excluded: its f_s is not applied): the flux density that
/// the light sub-path x₀ … x_upto brings to x_upto, f_map(X_map) of [Fan et al. 2005, eq. (2)].
pub fn light_throughput(scene: &Scene, path: &[Vertex], upto: usize) -> Vec3 {
    debug_assert!(upto >= 1 && upto < path.len());
    let mut t = emitted(scene, path) * geometry(&path[0], &path[1]);
    for i in 1..upto {
        if t == Vec3::ZERO {
            return t;
        }
        t *= scattering(scene, path, i) * geometry(&path[i], &path[i + 1]);
    }
    t
}

/// A path's contribution f(X) (per channel) and the raster position of its last edge; `None`
/// for a malformed path or one outside the image. Visibility is not checked.
pub fn contribution(scene: &Scene, path: &[Vertex]) -> Option<(Vec3, Vec2)> {
    let k = path.len().checked_sub(1)?;
    if k == 0 || !path[0].is_light() || path[k].kind != VertexKind::Eye {
        return None;
    }
    let (raster, c) = camera_factor(scene, &path[k - 1], &path[k])?;
    let f = if k == 1 {
        emitted(scene, path) * c
    } else {
        light_throughput(scene, path, k - 1) * scattering(scene, path, k - 1) * c
    };
    Some((f, raster))
}

/// Area density with which the *light* side produces vertex i from i−1 (and i−2): x₀ by
/// choosing a light ∝ power and a point uniformly on it (a point, spot or directional light:
/// the probability of choosing it; the environment: that times its solid-angle density), x₁
/// by cosine-distributed emission (a point: uniform over the sphere; a spot: uniform in its
/// cutoff cone; light from infinity: through the disc, |cos θ₁| / πR²), later vertices by
/// sampling the BSDF at x_{i−1} (its lobe probability if specular).
pub fn pdf_light_side(scene: &Scene, path: &[Vertex], i: usize) -> f32 {
    match (i, path[0].kind) {
        (0, VertexKind::Light(l)) => {
            let light = &scene.lights[l as usize];
            scene.light_selection.pmf(l as usize) / light.area
        }
        (0, VertexKind::DeltaLight(j) | VertexKind::Directional(j)) => {
            scene.light_selection.pmf(scene.lights.len() + j as usize)
        }
        (0, VertexKind::Environment) => match (&scene.environment, scene.environment_index()) {
            (Some(env), Some(e)) => scene.light_selection.pmf(e) * env.pdf(-path[0].ng),
            _ => 0.0,
        },
        (0 | 1, VertexKind::Surface | VertexKind::Eye | VertexKind::Medium(_)) => 0.0,
        (1, VertexKind::Environment | VertexKind::Directional(_)) => {
            let radius = scene.bounding_sphere().1;
            solid_angle_to_area(&path[0], &path[1]) / (PI * radius * radius)
        }
        (1, VertexKind::DeltaLight(j)) => {
            let (d, _) = direction(&path[0], &path[1]);
            scene.delta_lights[j as usize].pdf_emit_dir(d) * solid_angle_to_area(&path[0], &path[1])
        }
        (1, VertexKind::Light(l)) => {
            let (d, _) = direction(&path[0], &path[1]);
            let cos = path[0].ng.dot(d);
            let light = &scene.lights[l as usize];
            let pdf_w = if light.emission.two_sided {
                0.5 * cos.abs() * FRAC_1_PI
            } else {
                cos.max(0.0) * FRAC_1_PI
            };
            pdf_w * solid_angle_to_area(&path[0], &path[1])
        }
        _ => pdf_light_step(scene, &path[i], &path[i - 1], &path[i - 2]),
    }
}

/// [`pdf_light_side`] of vertex `x` (index ≥ 2) generated from surface vertex `v`, itself
/// reached from `before`: the BSDF's density at `v` in importance transport, as an area density.
pub fn pdf_light_step(scene: &Scene, x: &Vertex, v: &Vertex, before: &Vertex) -> f32 {
    if let VertexKind::Medium(m) = v.kind {
        return phase_density(scene, m, x, v, before);
    }
    if !v.is_surface() {
        return 0.0;
    }
    let (Some(wo), Some(wi)) = (local_dir(v, direction(v, before).0), local_dir(v, direction(v, x).0)) else {
        return 0.0;
    };
    direction_pdf(scene, v, wo, wi, TransportMode::Importance) * solid_angle_to_area(v, x)
}

/// The area density of vertex `x` drawn from medium vertex `v` (of medium `m`), reached from
/// `before`: the phase function sampled for the direction of travel after the one the walk
/// arrived in, as an area density (no cosine at a point in a medium). It ignores the free
/// flight that places `x` along the ray: a pseudo-density (module doc of
/// [`bidirectional`], "Media").
fn phase_density(scene: &Scene, m: u32, x: &Vertex, v: &Vertex, before: &Vertex) -> f32 {
    let phase = &scene.media[m as usize].phase;
    phase.eval(-direction(v, before).0, direction(v, x).0) * solid_angle_to_area(v, x)
}

/// Area density with which the *eye* side produces vertex i from i+1 (and i+2): x_{k−1} by a
/// raster position uniform over the whole image from the path's eye vertex (module doc,
/// "Cameras"; the eye vertex's own density is 1), earlier vertices by sampling the BSDF at
/// x_{i+1}.
pub fn pdf_eye_side(scene: &Scene, path: &[Vertex], i: usize) -> f32 {
    let k = path.len() - 1;
    pdf_eye_step(scene, &path[i], &path[i + 1], (i + 1 < k).then(|| &path[i + 2]))
}

/// [`pdf_eye_side`] of vertex `x` generated from `v`, itself reached from `before`; `before` is
/// `None` when `v` is the eye (x is then the first vertex the camera sees).
pub fn pdf_eye_step(scene: &Scene, x: &Vertex, v: &Vertex, before: Option<&Vertex>) -> f32 {
    if !x.scatters() && !x.is_hittable_light() {
        return 0.0;
    }
    let Some(before) = before else {
        let pixels = scene.camera.pixel_count() as f32;
        return camera_factor(scene, x, v).map_or(0.0, |(_, c)| c / pixels);
    };
    if let VertexKind::Medium(m) = v.kind {
        return phase_density(scene, m, x, v, before);
    }
    if !v.is_surface() {
        return 0.0;
    }
    let (Some(wo), Some(wi)) = (local_dir(v, direction(v, before).0), local_dir(v, direction(v, x).0)) else {
        return 0.0;
    };
    direction_pdf(scene, v, wo, wi, TransportMode::Radiance) * solid_angle_to_area(v, x)
}

/// Solid-angle density (or lobe probability at a specular vertex) of sampling `wi` from `wo`.
fn direction_pdf(scene: &Scene, v: &Vertex, wo: Vec3, wi: Vec3, mode: TransportMode) -> f32 {
    let bsdf = v.bsdf(scene);
    if v.delta {
        bsdf.delta_lobe(wo, wi, mode).map_or(0.0, |(_, p)| p)
    } else {
        bsdf.pdf(wo, wi)
    }
}

/// Is the straight segment between two vertices free of occluders (for a vertex at infinity,
/// the ray from the other one toward it)?
pub fn visible(scene: &Scene, a: &Vertex, b: &Vertex) -> bool {
    if let Some((far, near)) = match (a.is_at_infinity(), b.is_at_infinity()) {
        (true, false) => Some((a, b)),
        (false, true) => Some((b, a)),
        _ => None,
    } {
        return scene.unoccluded(&spawn_ray(near.p, near.ng, -far.ng));
    }
    let (ray, dist) = spawn_shadow_ray(a.p, a.ng, b.p, b.ng);
    dist > 0.0 && ray.d.is_finite() && scene.unoccluded(&ray)
}

/// Index of the first non-specular vertex seen from the eye (x_d of E S* D), if the eye
/// sub-path reaches one before the light.
pub fn first_diffuse_from_eye(path: &[Vertex]) -> Option<usize> {
    (1..path.len() - 1).rev().find(|&i| !path[i].delta)
}
