//! Sub-path sampling as in bidirectional path tracing [Veach 1997, §10.2]: light sub-paths
//! grow from a point on a light, eye sub-paths from the camera, each vertex drawn with exactly
//! the density that [`pdf_light_side`] / [`pdf_eye_side`] report, and path-tracing samples of
//! whole paths for the normalisation B and the chains' first states.

use super::{
    Vertex, VertexKind, camera_factor, contribution, direction, emitted, geometry, pdf_eye_side, pdf_eye_step,
    pdf_light_side, scattering, scattering_at, visible,
};
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, spawn_ray};
use crate::light::parallel_ray_origin;
use crate::sampling::{Rng, sample_cosine_hemisphere};
use crate::scene::Scene;
use crate::scene::light_selection::Emitter;
use glam::{Vec2, Vec3};

/// The first surface hit along `ray`, as a vertex.
#[inline]
pub fn trace(scene: &Scene, ray: &Ray) -> Option<Vertex> {
    scene.intersect(ray).map(|hit| Vertex::surface(scene, &hit))
}

/// The first surface hit along `ray`, or where it leaves the scene when the scene has an
/// environment: the vertex x₀ on the environment the eye side reaches (its walk ends there).
#[inline]
pub fn trace_eye(scene: &Scene, ray: &Ray) -> Option<Vertex> {
    match scene.intersect(ray) {
        Some(hit) => Some(Vertex::surface(scene, &hit)),
        None => scene.environment.as_ref().map(|_| Vertex::environment(-ray.d)),
    }
}

/// The first surface hit leaving vertex `v` in unit direction `d`.
#[inline]
pub fn trace_from(scene: &Scene, v: &Vertex, d: Vec3) -> Option<Vertex> {
    trace(scene, &spawn_ray(v.p, v.ng, d))
}

/// A direction sampled at a surface vertex ([`scatter`]).
#[derive(Clone, Copy, Debug)]
pub struct Step {
    /// The direction, world space, unit.
    pub wi: Vec3,
    /// A delta lobe made it: the vertex is specular in the path that goes on this way.
    pub delta: bool,
    /// f_s |cos θ| / p_ω (a delta lobe: its coefficient |cos θ| over its probability), the
    /// factor the walk's throughput takes on.
    pub weight: Vec3,
}

/// Samples, with the BSDF in `mode`, the direction in which the walk leaves the last vertex of
/// `walk` (reached from the one before it), and records in that vertex which kind of lobe made
/// it ([`Vertex::mixed`]). `None` when the BSDF absorbs or the shading and geometric normals
/// disagree.
pub fn scatter(scene: &Scene, walk: &mut [Vertex], mode: TransportMode, rng: &mut Rng) -> Option<Step> {
    let n = walk.len();
    let (v, from) = (&walk[n - 1], &walk[n - 2]);
    let wo = v.frame.to_local(direction(v, from).0);
    let (u, u_lobe) = (rng.uniform2(), rng.uniform());
    let bsdf = v.bsdf(scene);
    let s = bsdf.sample(wo, u, u_lobe, mode)?;
    if s.pdf_w <= 0.0 || s.f == Vec3::ZERO {
        return None;
    }
    let wi = v.frame.to_world(s.wi);
    if wi.dot(v.ng) * s.wi.z <= 0.0 {
        return None;
    }
    if bsdf.is_stochastic() {
        walk[n - 1].sampled = Some(super::SampledScattering {
            toward: wi,
            mode,
            f: s.f,
        });
    }
    walk[n - 1].delta = s.delta;
    Some(Step {
        wi,
        delta: s.delta,
        weight: s.f * (s.wi.z.abs() / s.pdf_w),
    })
}

/// A light vertex x₀: an emitter chosen ∝ power, a point uniformly on it (the position of a
/// point, spot or projector light, the direction of a directional light, a direction from the
/// environment's importance sampling). `None` when the environment's sample carries nothing.
pub fn sample_light_vertex(scene: &Scene, rng: &mut Rng) -> Option<Vertex> {
    let (i, _, _) = scene.light_selection.sample(rng.uniform());
    match scene.emitter(i) {
        Emitter::Area(l) => {
            let light = &scene.lights[l];
            let lp = light.sample_point(&scene.primitives[light.prim as usize], rng.uniform2());
            Some(Vertex::light(scene, l, lp.p, lp.n))
        }
        Emitter::Delta(j) => Some(Vertex::delta_light(scene, j)),
        Emitter::Environment => {
            let s = scene.environment.as_ref()?.sample(rng.uniform2())?;
            Some(Vertex::environment(-s.wi))
        }
    }
}

/// Appends `n` light-side vertices to `path` (x₀ first; an empty `path` starts at a light).
/// False when a ray escapes or a BSDF absorbs.
pub fn extend_light_side(scene: &Scene, path: &mut Vec<Vertex>, n: usize, rng: &mut Rng) -> bool {
    for _ in 0..n {
        let next = match path.len() {
            0 => sample_light_vertex(scene, rng),
            1 => {
                let x0 = path[0];
                match x0.kind {
                    VertexKind::Light(l) => {
                        let mut local = sample_cosine_hemisphere(rng.uniform2());
                        if scene.lights[l as usize].emission.two_sided && rng.uniform() < 0.5 {
                            local.z = -local.z;
                        }
                        trace_from(scene, &x0, x0.frame.to_world(local))
                    }
                    VertexKind::DeltaLight(j) => {
                        let light = &scene.delta_lights[j as usize];
                        light
                            .emit(rng.uniform2(), scene.bounding_sphere())
                            .and_then(|e| trace(scene, &Ray::new(x0.p, e.dir)))
                    }
                    VertexKind::Environment | VertexKind::Directional(_) => {
                        let origin = parallel_ray_origin(-x0.ng, scene.bounding_sphere(), rng.uniform2());
                        trace(scene, &Ray::new(origin, x0.ng))
                    }
                    _ => return false,
                }
            }
            len => scatter(scene, path, TransportMode::Importance, rng)
                .and_then(|step| trace_from(scene, &path[len - 1], step.wi)),
        };
        match next {
            Some(v) => path.push(v),
            None => return false,
        }
    }
    true
}

/// Appends `n` eye-side vertices to `rev`, an eye sub-path stored from the eye (`rev[0]` is
/// the eye vertex): the first by a raster position uniform over the image, then by BSDF sampling.
pub fn extend_eye_side(scene: &Scene, rev: &mut Vec<Vertex>, n: usize, rng: &mut Rng) -> bool {
    for _ in 0..n {
        match step_eye(scene, rev, rng) {
            Some(v) => rev.push(v),
            None => return false,
        }
    }
    true
}

/// The next eye-side vertex after `rev`'s last (whose lobe it records, [`scatter`]): a surface,
/// or x₀ on the environment where the walk leaves a scene that has one (the walk ends there).
fn step_eye(scene: &Scene, rev: &mut [Vertex], rng: &mut Rng) -> Option<Vertex> {
    match rev.len() {
        1 => {
            let cam = &scene.camera;
            let raster = rng.uniform2() * Vec2::new(cam.width as f32, cam.height as f32);
            first_eye_vertex(scene, &mut rev[0], raster)
        }
        len if rev[len - 1].on_surface() => {
            let step = scatter(scene, rev, TransportMode::Radiance, rng)?;
            trace_eye_from(scene, &rev[len - 1], step.wi)
        }
        _ => None,
    }
}

/// The first vertex the eye vertex `eye` sees through raster position `raster` ([`trace_eye`]
/// of the camera ray from `eye`'s lens point). An orthographic camera's ray leaves the film
/// point of `raster`, which becomes `eye`'s position, and the environment it reaches straight
/// ahead is specular in the path (a delta in direction at both ends; module doc of
/// [`crate::path_space`], "Cameras").
pub fn first_eye_vertex(scene: &Scene, eye: &mut Vertex, raster: Vec2) -> Option<Vertex> {
    let cam = &scene.camera;
    let ray = cam.ray_from(raster, eye.p);
    eye.p = ray.o;
    let mut v = trace_eye(scene, &ray)?;
    v.delta |= v.is_at_infinity() && cam.is_orthographic();
    Some(v)
}

/// [`trace_eye`] leaving vertex `v` in unit direction `d`.
#[inline]
pub fn trace_eye_from(scene: &Scene, v: &Vertex, d: Vec3) -> Option<Vertex> {
    trace_eye(scene, &spawn_ray(v.p, v.ng, d))
}

/// Extends the eye sub-path `rev` until its last vertex is non-specular (E S* D), keeping at
/// most `max_vertices` vertices. False on escape, absorption or when the limit is hit first.
pub fn extend_eye_to_diffuse(scene: &Scene, rev: &mut Vec<Vertex>, max_vertices: usize, rng: &mut Rng) -> bool {
    loop {
        if let [_, .., last] = rev.as_slice() {
            if !last.on_surface() {
                return false;
            }
            if !last.delta {
                return true;
            }
        }
        if rev.len() >= max_vertices {
            return false;
        }
        match step_eye(scene, rev, rng) {
            Some(v) => rev.push(v),
            None => return false,
        }
    }
}

/// A light-to-eye path from a light prefix `light` (x₀ …) and an eye sub-path `rev` (stored
/// from the eye), joined by the edge between their last vertices, which the connection meets
/// with their non-delta lobes ([`Vertex::as_endpoint`]).
pub fn join(light: &[Vertex], rev: &[Vertex]) -> Vec<Vertex> {
    let mut path = Vec::with_capacity(light.len() + rev.len());
    path.extend_from_slice(light);
    path.extend(rev.iter().rev());
    for i in [light.len().wrapping_sub(1), light.len()] {
        if let Some(v) = path.get_mut(i) {
            *v = v.as_endpoint();
        }
    }
    path
}

/// One path-tracing sample of the whole image for the normalisation B and the chains' first
/// states: an eye path through a raster point uniform over the image, extended by BSDF
/// sampling up to `max_edges` edges; every emitter it hits and a light-sampling connection
/// at each non-specular vertex (next-event estimation) make a complete path, weighted by the
/// power heuristic between the two techniques [Veach 1997, §9.2]. `emit(path, c)` receives
/// each path with c = w f / p, so that E[Σ c] = ∫ f dμ = B (per channel).
pub fn path_tracing_sample(scene: &Scene, max_edges: usize, rng: &mut Rng, emit: &mut impl FnMut(&[Vertex], Vec3)) {
    let mut rev = vec![Vertex::eye(scene, rng)];
    // The eye walk's own factors, kept as it grows so that each path it emits costs O(1) model
    // evaluations instead of re-evaluating the whole path (O(k²) per sample). With z = rev[m−1]
    // its last vertex, a path X = (x₀, z, rev[m−2], …, eye) of k = m edges has
    //   f(X) = Le(x₀→z) G(x₀, z) f_s(z) · eye_f,   eye_f = C(rev[1]) Π_{j=1}^{m−2} f_s(rev[j]) G(rev[j+1], rev[j]),
    // and every density of its eye-side vertices is Π_{j=1}^{m−1} p_eye(rev[j]) = eye_p.
    let mut eye_f = Vec3::ZERO;
    let mut eye_p = 1.0f64;
    let mut path = Vec::with_capacity(max_edges + 2);
    while rev.len() <= max_edges {
        let Some(z) = step_eye(scene, &mut rev, rng) else {
            return;
        };
        rev.push(z);
        let m = rev.len();
        let (eye_f_before, eye_p_before) = (eye_f, eye_p);
        if m == 2 {
            let Some((_, c)) = camera_factor(scene, &rev[1], &rev[0]) else {
                return;
            };
            eye_f = Vec3::splat(c);
        } else {
            eye_f *= scattering_at(scene, &rev[m - 2], &rev[m - 3], &rev[m - 1]) * geometry(&rev[m - 1], &rev[m - 2]);
        }
        eye_p *= pdf_eye_step(scene, &rev[m - 1], &rev[m - 2], m.checked_sub(3).map(|j| &rev[j])) as f64;
        // The eye walk hits a light: the path of its first m − 1 edges, x₀ = z.
        if let Some(x0) = z.as_light(scene) {
            fill_path(&mut path, x0, &rev[..m - 1]);
            let f = if m == 2 {
                contribution(scene, &path).map_or(Vec3::ZERO, |(f, _)| f)
            } else {
                emitted(scene, &path) * geometry(&path[0], &path[1]) * scattering(scene, &path, 1) * eye_f_before
            };
            weigh(scene, &path, f, eye_p_before, false, emit);
        }
        // Next-event estimation from z: the path of m edges, x₀ = y on a light.
        if z.is_surface()
            && !z.delta
            && m <= max_edges
            && let Some(y) = sample_light_vertex(scene, rng)
            && visible(scene, &y, &z)
        {
            fill_path(&mut path, y, &rev);
            let f = emitted(scene, &path) * geometry(&path[0], &path[1]) * scattering(scene, &path, 1) * eye_f;
            weigh(scene, &path, f, eye_p, true, emit);
        }
    }
}

/// `path` ← x₀ followed by the eye sub-path `rev` reversed ([`join`] into a reused buffer).
fn fill_path(path: &mut Vec<Vertex>, x0: Vertex, rev: &[Vertex]) {
    path.clear();
    path.push(x0);
    path.extend(rev.iter().rev());
}

/// Emits a path-tracing path of contribution `f` with its MIS weight: `nee` says x₀ came from
/// light sampling (else the eye walk hit it); `eye_part` is the density of its eye-side vertices
/// x₁ … x_{k−1}, which both techniques share.
fn weigh(scene: &Scene, path: &[Vertex], f: Vec3, eye_part: f64, nee: bool, emit: &mut impl FnMut(&[Vertex], Vec3)) {
    if f == Vec3::ZERO || !f.is_finite() {
        return;
    }
    let k = path.len() - 1;
    let p_hit = eye_part * pdf_eye_side(scene, path, 0) as f64;
    let p_nee = if k >= 2 && path[1].connectible() {
        eye_part * pdf_light_side(scene, path, 0) as f64
    } else {
        0.0
    };
    let (p, other) = if nee { (p_nee, p_hit) } else { (p_hit, p_nee) };
    if p <= 0.0 || !p.is_finite() {
        return;
    }
    // The power heuristic [Veach 1997, eq. (9.13)], in f64: path densities under- and
    // overflow f32.
    let w = p * p / (p * p + other * other);
    let c = f.as_dvec3() * (w / p);
    if c.is_finite() {
        emit(path, c.as_vec3());
    }
}

/// Raster position of a path's last edge.
pub fn raster_of(scene: &Scene, path: &[Vertex]) -> Option<Vec2> {
    let k = path.len() - 1;
    camera_factor(scene, &path[k - 1], &path[k]).map(|(r, _)| r)
}
