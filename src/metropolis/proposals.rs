//! The six proposals of Metropolis photon sampling [Fan et al. 2005, §4.1]: BD, CP, LP and LS
//! from Veach's MLT [Veach 1997, §11.4], PM and UP from the paper; and a seventh, Veach's
//! multi-chain perturbation MC [Veach 1997, §11.4.4], off unless a mix asks for it. Each
//! returns a candidate path Y with the ratio of transition densities T(X|Y) / T(Y|X) (both in
//! the area-product measure of the vertices the proposal changes, with dropped deltas as in
//! [`crate::path_space`]), or `None` when it cannot propose (a rejection).
//!
//! One file on purpose: the proposals share their helpers (sub-path regeneration, the
//! perturbation samplers and their densities) and are read side by side when checking that
//! every T(X|Y) / T(Y|X) matches its sampler; their tests live in `tests/metropolis.rs`.

use super::{MetropolisParams, UserPathInfo};
use crate::bsdf::TransportMode;
use crate::geometry::Frame;
use crate::path_space::walk::{
    extend_eye_side, extend_eye_to_diffuse, extend_light_side, first_eye_vertex, join, raster_of, scatter,
    trace_eye_from, trace_from,
};
use crate::path_space::{
    Vertex, camera_factor, direction, eye_toward, first_diffuse_from_eye, pdf_eye_side, pdf_light_side,
    solid_angle_to_area, visible,
};
use crate::sampling::{Rng, sample_uniform_cone};
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use std::f32::consts::TAU;

/// A proposed path and T(X|Y) / T(Y|X).
pub struct Candidate {
    pub path: Vec<Vertex>,
    pub t_ratio: f64,
}

/// What the proposals share: the scene, the parameters, the user paths.
#[derive(Clone, Copy)]
pub struct Context<'a> {
    pub scene: &'a Scene,
    pub params: &'a MetropolisParams,
    pub user_paths: &'a [UserPathInfo],
    /// Largest number of edges of a path (max_depth + 1).
    pub max_edges: usize,
}

impl<'a> Context<'a> {
    /// The context of chains with `params` on `scene`: paths of at most `max_depth` + 1 edges.
    pub fn new(scene: &'a Scene, params: &'a MetropolisParams, user_paths: &'a [UserPathInfo]) -> Self {
        Self {
            scene,
            params,
            user_paths,
            max_edges: params.max_depth as usize + 1,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Bidirectional mutation (BD) [Veach 1997, §11.4.2].

/// 2^{−j}, exactly (the value `0.5f64.powi(j)` has, without its libgcc loop: these weights are
/// summed over every edge count in every BD density).
#[inline]
fn half_to_the(j: usize) -> f64 {
    if j > 1022 {
        0.5f64.powi(j.min(i32::MAX as usize) as i32)
    } else {
        f64::from_bits((1023 - j as u64) << 52)
    }
}

/// Probability of deleting `kd` edges from a path of `k` edges: ∝ 1/4, 1/2, 2^{−kd} for kd = 1,
/// 2, ≥ 3 (Veach's choice: mostly short changes, but any length up to the whole path).
fn p_delete_edges(kd: usize, k: usize) -> f64 {
    let w = |j: usize| match j {
        1 => 0.25,
        2 => 0.5,
        _ => half_to_the(j),
    };
    // Deleting x₀ counts its virtual edge from "before the light": up to k + 1 edges, the
    // whole path but the eye.
    if kd == 0 || kd > k + 1 {
        return 0.0;
    }
    w(kd) / (1..=k + 1).map(w).sum::<f64>()
}

/// May BD delete the edges between x_l and x_m (l = −1: x₀ too)? The kept ends must be
/// non-specular, so that the regenerated vertices differ from the old ones almost surely and
/// the deleted range is determined by X and Y alone. Keeping x₀ on the eye side (m = 0) makes
/// it an interior vertex of the new path: only a point on an area light can be one.
fn deletion_allowed(path: &[Vertex], l: isize, m: usize) -> bool {
    (l < 0 || path[l as usize].connectible()) && path[m].connectible() && (m > 0 || path[0].on_surface())
}

/// Number of positions l where `kd` edges may be deleted from `path`.
fn deletion_positions(path: &[Vertex], kd: usize) -> usize {
    let k = path.len() - 1;
    (-1..=(k as isize - kd as isize))
        .filter(|&l| deletion_allowed(path, l, (l + kd as isize) as usize))
        .count()
}

/// Edges of a path of `k` edges that survive deleting `kd` after `l` (with l = −1, one of the
/// `kd` is x₀'s virtual edge).
fn kept_edges(k: usize, kd: usize, l: isize) -> usize {
    k + usize::from(l < 0) - kd
}

/// Largest edge count a deletion after `l` may add, keeping the path within `max_edges`.
fn max_added_edges(kept: usize, l: isize, max_edges: usize) -> usize {
    (max_edges + usize::from(l < 0)).saturating_sub(kept)
}

/// Probability of adding `ka` edges after a deletion after `l` (ka ≥ 2 when x₀ is deleted):
/// ∝ 2^{−|ka − kd|} (length changes are rare, as in Veach's P_a).
fn p_add_edges(ka: usize, kd: usize, l: isize, kept: usize, max_edges: usize) -> f64 {
    let lo = if l < 0 { 2 } else { 1 };
    let hi = max_added_edges(kept, l, max_edges);
    if ka < lo || ka > hi {
        return 0.0;
    }
    let w = |j: usize| half_to_the(j.abs_diff(kd));
    w(ka) / (lo..=hi).map(w).sum::<f64>()
}

/// Density with which BD applied to `from` produces `to`, where both share the prefix
/// x₀ … x_l and the last `tail` vertices (the eye side x_m … x_k). Sums over the ways of
/// splitting the new vertices between the light side and the eye side [Veach 1997, eq. (11.8)].
pub fn bd_density(ctx: &Context, from: &[Vertex], to: &[Vertex], l: isize, tail: usize) -> f64 {
    let scene = ctx.scene;
    let k_from = from.len() - 1;
    let m_from = from.len() - tail;
    let m_to = to.len() - tail;
    let kd = (m_from as isize - l) as usize;
    let ka = (m_to as isize - l) as usize;
    if !deletion_allowed(from, l, m_from) {
        return 0.0;
    }
    let positions = deletion_positions(from, kd);
    let p_del = p_delete_edges(kd, k_from) / positions as f64;
    let p_add = p_add_edges(ka, kd, l, kept_edges(k_from, kd, l), ctx.max_edges);
    if p_del == 0.0 || p_add == 0.0 {
        return 0.0;
    }
    let n = ka - 1;
    let first = (l + 1) as usize;
    // light[s] = density of the first s new vertices from the light side; eye[t] likewise.
    let mut light = vec![1.0f64; n + 1];
    for s in 1..=n {
        light[s] = light[s - 1] * pdf_light_side(scene, to, first + s - 1) as f64;
    }
    let mut eye = vec![1.0f64; n + 1];
    for t in 1..=n {
        eye[t] = eye[t - 1] * pdf_eye_side(scene, to, m_to - t) as f64;
    }
    let mut sum = 0.0;
    for s in 0..=n {
        // The connection joins to[first + s − 1] and to[first + s]; with nothing on the light
        // side (l = −1, s = 0) the eye walk itself found x₀ on a light.
        let joined = (first + s == 0) || (to[first + s - 1].connectible() && to[first + s].connectible());
        if joined {
            sum += light[s] * eye[n - s];
        }
    }
    p_del * p_add * sum / (n + 1) as f64
}

/// BD: deletes a sub-path and regenerates it from both ends, joined by a connection.
pub fn bidirectional(ctx: &Context, x: &[Vertex], rng: &mut Rng) -> Option<(Vec<Vertex>, isize, usize)> {
    let k = x.len() - 1;
    // Deleted edge count kd, then a position among the allowed ones.
    let mut u = rng.uniform_f64();
    let mut kd = k + 1;
    for j in 1..=k + 1 {
        let p = p_delete_edges(j, k);
        if u < p {
            kd = j;
            break;
        }
        u -= p;
    }
    let allowed: Vec<isize> = (-1..=(k as isize - kd as isize))
        .filter(|&l| deletion_allowed(x, l, (l + kd as isize) as usize))
        .collect();
    if allowed.is_empty() {
        return None;
    }
    let l = allowed[rng.below(allowed.len() as u32) as usize];
    let m = (l + kd as isize) as usize;
    // Added edge count ka.
    let lo = if l < 0 { 2 } else { 1 };
    let kept = kept_edges(k, kd, l);
    let hi = max_added_edges(kept, l, ctx.max_edges);
    if hi < lo {
        return None;
    }
    let mut u = rng.uniform_f64();
    let mut ka = hi;
    for j in lo..=hi {
        let p = p_add_edges(j, kd, l, kept, ctx.max_edges);
        if u < p {
            ka = j;
            break;
        }
        u -= p;
    }
    let n = ka - 1;
    let s = rng.below((n + 1) as u32) as usize;
    let mut light: Vec<Vertex> = x[..(l + 1) as usize].to_vec();
    if !extend_light_side(ctx.scene, &mut light, s, rng) {
        return None;
    }
    let mut rev: Vec<Vertex> = x[m..].iter().rev().copied().collect();
    if m == k {
        // Regenerating from the eye draws a new lens point (thin lens; density 1 both ways in
        // the lens's probability measure, module doc of `path_space`, "Cameras"): the move that
        // lets BD-only mixes explore the lens.
        rev[0] = Vertex::eye(ctx.scene, rng);
    }
    if !extend_eye_side(ctx.scene, &mut rev, n - s, rng) {
        return None;
    }
    if light.is_empty() {
        // The eye walk must have found a light: its last vertex becomes x₀ (the only way to
        // reach paths L S+ E, such as a light seen in a mirror).
        let x0 = rev.pop()?.as_light(ctx.scene)?;
        rev.push(x0);
        return Some((rev.into_iter().rev().collect(), l, k + 1 - m));
    }
    if let [eye] = rev.as_mut_slice() {
        // t = 1: an orthographic camera's eye vertex is the film point behind the light end.
        *eye = eye_toward(ctx.scene, light.last()?, eye);
    }
    let (a, b) = (light.last()?, rev.last()?);
    // An eye walk that left the scene ends at x₀ on the environment, never at a connection.
    if !a.connectible() || !b.connectible() || b.is_at_infinity() || !visible(ctx.scene, a, b) {
        return None;
    }
    Some((join(&light, &rev), l, k + 1 - m))
}

// ---------------------------------------------------------------------------------------------
// User-path proposal (UP) [Fan et al. 2005, §5].

/// Density with which UP produces `path`'s vertices 1 … d−1 from its x₀ and its eye sub-path
/// x_d … x_k: (1/N_UP) Σ_j C(u_j) Π_i p_i [Fan et al. 2005, eq. (6)], each p_i the cone density
/// (uniform in solid angle, **decision** of NOTES.md) times |cos| / r², or |cos| / r² alone
/// where user path j follows a specular bounce.
pub fn up_density(ctx: &Context, path: &[Vertex], d: usize) -> f64 {
    if ctx.user_paths.is_empty() {
        return 0.0;
    }
    let sum: f64 = ctx.user_paths.iter().map(|u| up_density_one(ctx, u, path, d)).sum();
    sum / ctx.user_paths.len() as f64
}

fn up_density_one(ctx: &Context, u: &UserPathInfo, path: &[Vertex], d: usize) -> f64 {
    let segments = u.points.len() - 1;
    if d != segments + 1 || path[0].is_at_infinity() {
        return 0.0;
    }
    let mut density = 1.0f64;
    for i in 0..segments {
        let (y, next) = (&path[i], &path[i + 1]);
        let last = i + 1 == segments;
        if next.delta != (!last && u.specular[i + 1]) {
            return 0.0;
        }
        if i > 0 && u.specular[i] {
            let Some(w) = user_specular_direction(ctx.scene, u, i, &path[i - 1], y) else {
                return 0.0;
            };
            if w.dot(direction(y, next).0) < 1.0 - 1e-4 {
                return 0.0;
            }
        } else if in_cone(u, i, y, next) {
            density *= cone_pdf(u.cos_beta[i]) as f64;
        } else {
            return 0.0;
        }
        density *= solid_angle_to_area(y, next) as f64;
    }
    density
}

/// Does the segment from `y` to `next` lie in user path `u`'s cone i, around the direction from
/// `y` to the user point i + 1? The sampler and the density both ask this of the vertices, so
/// that they agree on the support: a ray leaves `y` from an offset origin, and a direction drawn
/// within rounding of the cone's edge can join the two vertices just outside it (9 of the
/// 600 000 candidates of `tests/metropolis.rs`'s UP density test did, each with T_UP = 0).
fn in_cone(u: &UserPathInfo, i: usize, y: &Vertex, next: &Vertex) -> bool {
    let axis = (u.points[i + 1] - y.p).normalize_or_zero();
    axis != Vec3::ZERO && axis.dot(direction(y, next).0) >= u.cos_beta[i]
}

#[inline]
fn cone_pdf(cos_max: f32) -> f32 {
    1.0 / (TAU * (1.0 - cos_max))
}

/// The bounce user path `u` takes at its specular point i, applied at vertex `y` reached from
/// `from`: reflection or refraction as the user path does there.
fn user_specular_direction(scene: &Scene, u: &UserPathInfo, i: usize, from: &Vertex, y: &Vertex) -> Option<Vec3> {
    if !y.delta {
        return None;
    }
    let wo = y.frame.to_local(direction(y, from).0);
    let wi = specular_direction(&y.bsdf(scene), wo, u.reflect[i])?;
    Some(y.frame.to_world(wi))
}

/// The delta lobe of `bsdf` from local `wo` that reflects (`reflect`) or transmits.
pub fn specular_direction(bsdf: &crate::bsdf::Bsdf, wo: Vec3, reflect: bool) -> Option<Vec3> {
    let u_lobe = if reflect { 0.0 } else { 1.0 - f32::EPSILON };
    let s = bsdf.sample(wo, Vec2::ZERO, u_lobe, TransportMode::Radiance)?;
    (s.delta && s.pdf_w > 0.0 && (s.wi.z * wo.z > 0.0) == reflect).then_some(s.wi)
}

/// Does the path turn back at vertex i (reflection) rather than pass through (transmission)?
fn reflects_at(path: &[Vertex], i: usize) -> bool {
    let v = &path[i];
    let a = v.frame.to_local(direction(v, &path[i - 1]).0);
    let b = v.frame.to_local(direction(v, &path[i + 1]).0);
    a.z * b.z > 0.0
}

/// UP: keeps x₀ and the eye sub-path E S* D, replaces the vertices between by a perturbed copy
/// of a user path chosen uniformly (cones aimed from each new vertex at the next user point;
/// specular user points followed as bounces), joined to x_d by a connection. Not from light
/// arriving from infinitely far away, which has no point to aim a cone from.
pub fn user_path(ctx: &Context, x: &[Vertex], rng: &mut Rng) -> Option<(Vec<Vertex>, usize)> {
    if x[0].is_at_infinity() {
        return None;
    }
    let d = first_diffuse_from_eye(x)?;
    let u = &ctx.user_paths[rng.below(ctx.user_paths.len() as u32) as usize];
    let segments = u.points.len() - 1;
    if segments + (x.len() - d) > ctx.max_edges {
        return None;
    }
    let mut light = vec![x[0]];
    for i in 0..segments {
        let y = light[i];
        let bounce = i > 0 && u.specular[i];
        let dir = if bounce {
            user_specular_direction(ctx.scene, u, i, &light[i - 1], &y)?
        } else {
            let axis = (u.points[i + 1] - y.p).normalize_or_zero();
            if axis == Vec3::ZERO {
                return None;
            }
            Frame::from_normal(axis).to_world(sample_uniform_cone(rng.uniform2(), u.cos_beta[i]))
        };
        let next = trace_from(ctx.scene, &y, dir)?;
        if !bounce && !in_cone(u, i, &y, &next) {
            return None;
        }
        let last = i + 1 == segments;
        if next.delta != (!last && u.specular[i + 1]) {
            return None;
        }
        light.push(next);
    }
    let xd = &x[d];
    if !visible(ctx.scene, light.last()?, xd) {
        return None;
    }
    let mut y = light;
    y.extend_from_slice(&x[d..]);
    Some((y, x.len() - d))
}

// ---------------------------------------------------------------------------------------------
// Lens sub-path mutation (LS) [Veach 1997, §11.4.4; Fan et al. 2005, §4.1].

/// Density of the eye sub-path x_d … x_{k−1} as LS samples it.
fn ls_density(scene: &Scene, path: &[Vertex], d: usize) -> f64 {
    (d..path.len() - 1)
        .map(|i| pdf_eye_side(scene, path, i) as f64)
        .product()
}

/// LS: replaces the eye sub-path E S* D by a new one through a raster point uniform over the
/// image (**decision**: uniform rather than Veach's stratified points, so that T is exact and
/// independent of the chain's history), connected to x_{d−1}.
pub fn lens_subpath(ctx: &Context, x: &[Vertex], rng: &mut Rng) -> Option<Candidate> {
    let scene = ctx.scene;
    let d = first_diffuse_from_eye(x)?;
    if !x[d - 1].connectible() || took_a_mixed_delta_lobe(&x[d + 1..x.len() - 1]) {
        return None;
    }
    // A new lens point too (thin lens; density 1 both ways, as BD's).
    let mut rev = vec![Vertex::eye(scene, rng)];
    if !extend_eye_to_diffuse(scene, &mut rev, ctx.max_edges + 1 - d, rng) {
        return None;
    }
    if !visible(scene, &x[d - 1], rev.last()?) {
        return None;
    }
    let y = join(&x[..d], &rev);
    let t_fwd = ls_density(scene, &y, d);
    let t_rev = ls_density(scene, x, d);
    ratio(y, t_rev, t_fwd)
}

/// A re-traced vertex that stands for `old` in a perturbation that keeps the path's specular
/// pattern: on a model with both kinds of lobe (smooth plastic) it takes the lobe `old` took,
/// as a dielectric keeps reflecting or refracting.
fn keep_lobe(mut v: Vertex, old: &Vertex) -> Vertex {
    if v.mixed {
        v.delta = old.delta;
    }
    v
}

/// Did the path take the delta lobe of a model with both kinds (smooth plastic) at any of
/// `vertices`? LS and PM trace their specular chains until the first vertex that is not purely
/// specular, so they cannot make such a chain, nor may they leave one (the reverse move).
fn took_a_mixed_delta_lobe(vertices: &[Vertex]) -> bool {
    vertices.iter().any(|v| v.mixed && v.delta)
}

fn ratio(path: Vec<Vertex>, t_rev: f64, t_fwd: f64) -> Option<Candidate> {
    (t_fwd > 0.0 && t_fwd.is_finite() && t_rev.is_finite()).then(|| Candidate {
        path,
        t_ratio: t_rev / t_fwd,
    })
}

// ---------------------------------------------------------------------------------------------
// Lens perturbation (LP) [Veach 1997, §11.4.3].

/// Density of the perturbed eye sub-path per unit raster area: C(x_{k−1}) times |cos| / r² for
/// each vertex reached through a specular bounce (the lobe is kept, probability 1). Public for
/// the tests that check it against LP's own candidates.
pub fn lp_density(scene: &Scene, path: &[Vertex], d: usize) -> f64 {
    let k = path.len() - 1;
    let c = camera_factor(scene, &path[k - 1], &path[k]).map_or(0.0, |(_, c)| c as f64);
    (d..k - 1).fold(c, |acc, i| acc * solid_angle_to_area(&path[i + 1], &path[i]) as f64)
}

/// Re-traces the first surface the eye sees, y_{k−1}, through image point `u2` from the kept
/// lens point (an orthographic camera: from `u2`'s film point, which becomes y_k), keeping the
/// lobe x_{k−1} took (LP and MC). `None` when the ray leaves the scene.
fn retrace_through(scene: &Scene, y: &mut [Vertex], x: &[Vertex], u2: Vec2) -> Option<()> {
    let k = y.len() - 1;
    let v = first_eye_vertex(scene, &mut y[k], u2).filter(Vertex::is_surface)?;
    y[k - 1] = keep_lobe(v, &x[k - 1]);
    Some(())
}

/// Offset of a perturbation: radius r ∈ [r1, r2] with density ∝ 1/r, angle uniform.
fn perturbation(rng: &mut Rng, r1: f32, r2: f32) -> (f32, f32) {
    let r = r1 * (r2 / r1).powf(rng.uniform());
    (r, TAU * rng.uniform())
}

/// The image point of `x` moved by an offset of length r ∈ [r1, r2] with density ∝ 1/r and a
/// uniform angle [Veach 1997, §11.4.3] (LP and MC); `None` when it leaves the image.
fn perturbed_image_point(ctx: &Context, x: &[Vertex], rng: &mut Rng) -> Option<Vec2> {
    let cam = &ctx.scene.camera;
    let u = raster_of(ctx.scene, x)?;
    let r2 = (ctx.params.lens_r2_fraction * cam.pixel_count() as f32 / std::f32::consts::PI).sqrt();
    let (r, phi) = perturbation(rng, ctx.params.lens_r1_px.min(r2), r2);
    let u2 = u + r * Vec2::new(phi.cos(), phi.sin());
    let inside = u2.x >= 0.0 && u2.y >= 0.0 && u2.x < cam.width as f32 && u2.y < cam.height as f32;
    inside.then_some(u2)
}

/// LP: moves the image point of a path (L|D) D S* E by an offset with density ∝ 1/r on
/// [r1, r2] (symmetric), re-traces the eye sub-path through the same specular bounces and
/// reconnects x_d to x_{d−1}.
pub fn lens_perturbation(ctx: &Context, x: &[Vertex], rng: &mut Rng) -> Option<Candidate> {
    let scene = ctx.scene;
    let k = x.len() - 1;
    let d = first_diffuse_from_eye(x)?;
    if !x[d - 1].connectible() {
        return None;
    }
    let u2 = perturbed_image_point(ctx, x, rng)?;
    let mut y = x.to_vec();
    retrace_through(scene, &mut y, x, u2)?;
    for i in (d..k - 1).rev() {
        if !y[i + 1].delta {
            return None;
        }
        let v = y[i + 1];
        let wo = v.frame.to_local(direction(&v, &y[i + 2]).0);
        let wi = specular_direction(&v.bsdf(scene), wo, reflects_at(x, i + 1))?;
        y[i] = keep_lobe(trace_from(scene, &v, v.frame.to_world(wi))?, &x[i]);
    }
    if y[d].delta || !visible(scene, &y[d - 1], &y[d]) {
        return None;
    }
    let t_fwd = lp_density(scene, &y, d);
    let t_rev = lp_density(scene, x, d);
    ratio(y, t_rev, t_fwd)
}

// ---------------------------------------------------------------------------------------------
// Caustic perturbation (CP) [Veach 1997, §11.4.3].

/// Density of the vertices x_{j+1} … x_{k−1} per unit solid angle at x_j. Public for the tests
/// that check it against CP's own candidates.
pub fn cp_density(path: &[Vertex], j: usize) -> f64 {
    let k = path.len() - 1;
    (j + 1..k).fold(1.0, |acc, i| acc * solid_angle_to_area(&path[i - 1], &path[i]) as f64)
}

/// CP: for a path ending (L|D) S* D E, perturbs the direction leaving x_j by an angle with
/// density ∝ 1/θ on [θ1, θ2] (symmetric), re-traces through the same specular bounces to a
/// non-specular x_{k−1} and connects it to the eye.
pub fn caustic_perturbation(ctx: &Context, x: &[Vertex], rng: &mut Rng) -> Option<Candidate> {
    let scene = ctx.scene;
    let k = x.len() - 1;
    if k < 2 || x[k - 1].delta {
        return None;
    }
    let j = (0..k - 1).rev().find(|&i| !x[i].delta)?;
    // From light arriving from infinitely far away there is no point to turn a direction at
    // (the reverse move is impossible too: CP keeps x₀ … x_j).
    if x[j].is_at_infinity() {
        return None;
    }
    let axis = direction(&x[j], &x[j + 1]).0;
    let p = &ctx.params;
    let (theta, phi) = perturbation(rng, p.caustic_theta1, p.caustic_theta2);
    let local = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
    let mut dir = Frame::from_normal(axis).to_world(local);
    let mut y = x.to_vec();
    for i in j + 1..k {
        y[i] = keep_lobe(trace_from(scene, &y[i - 1], dir)?, &x[i]);
        if i + 1 < k {
            if !y[i].delta {
                return None;
            }
            let v = y[i];
            let wo = v.frame.to_local(direction(&v, &y[i - 1]).0);
            let wi = specular_direction(&v.bsdf(scene), wo, reflects_at(x, i))?;
            dir = v.frame.to_world(wi);
        }
    }
    y[k] = eye_toward(scene, &y[k - 1], &x[k]);
    if y[k - 1].delta || camera_factor(scene, &y[k - 1], &y[k]).is_none() || !visible(scene, &y[k - 1], &y[k]) {
        return None;
    }
    ratio(y.clone(), cp_density(x, j), cp_density(&y, j))
}

// ---------------------------------------------------------------------------------------------
// Photon-map proposal (PM) [Fan et al. 2005, §4.3].

/// Density of the vertices x_e … x_{d−1} per unit solid angle at x_d, PM sampling them.
fn pm_density(scene: &Scene, path: &[Vertex], e: usize, d: usize) -> f64 {
    let first = solid_angle_to_area(&path[d], &path[d - 1]) as f64;
    (e..d - 1).fold(first, |acc, i| acc * pdf_eye_side(scene, path, i) as f64)
}

/// PM: keeps x_d (the diffuse vertex nearest the eye) and its eye sub-path, perturbs the
/// direction x_d → x_{d−1} uniformly within a cone of half-angle γ (symmetric, so its density
/// cancels), traces it through any specular bounces (sampled) to the next diffuse hit and
/// connects that to the old path's x_{e−1}, replacing the D S* D segment.
pub fn photon_map(ctx: &Context, x: &[Vertex], rng: &mut Rng) -> Option<Candidate> {
    let scene = ctx.scene;
    let d = first_diffuse_from_eye(x)?;
    let e = (1..d).rev().find(|&i| !x[i].delta)?;
    if !x[e - 1].connectible() || took_a_mixed_delta_lobe(&x[e + 1..d]) {
        return None;
    }
    let axis = direction(&x[d], &x[d - 1]).0;
    let cos_gamma = ctx.params.pm_gamma_deg.to_radians().cos();
    let dir = Frame::from_normal(axis).to_world(sample_uniform_cone(rng.uniform2(), cos_gamma));
    // rev: from x_d toward the light.
    let mut rev = vec![x[d + 1], x[d]];
    let mut next = trace_from(scene, &x[d], dir)?;
    let budget = ctx.max_edges + 2 - (e + (x.len() - d));
    loop {
        rev.push(next);
        if !next.delta {
            break;
        }
        if rev.len() > budget {
            return None;
        }
        let w = scatter(scene, &mut rev, TransportMode::Radiance, rng)?.wi;
        next = trace_from(scene, &rev[rev.len() - 1], w)?;
    }
    if !visible(scene, &x[e - 1], rev.last()?) {
        return None;
    }
    let mut y: Vec<Vertex> = x[..e].to_vec();
    y.extend(rev[2..].iter().rev());
    let d_y = y.len();
    y.extend_from_slice(&x[d..]);
    let t_fwd = pm_density(scene, &y, e, d_y);
    let t_rev = pm_density(scene, x, e, d);
    ratio(y, t_rev, t_fwd)
}

// ---------------------------------------------------------------------------------------------
// Multi-chain perturbation (MC) [Veach 1997, §11.4.4].

/// Density of the vertices x_c … x_{k−1} that MC re-traces, per unit raster area of the image
/// point and per unit solid angle of each turned direction: C(x_{k−1}) Π_{i=c}^{k−2}
/// |cos θ_{x_i}| / |x_{i+1} − x_i|², each x_i reached from x_{i+1} by a kept specular bounce
/// (its delta dropped, lobe probability 1) or by a turned direction. The same product as
/// [`lp_density`]; the offset and angle densities are left out because they are symmetric.
/// Public for the test that checks it against MC's own candidates.
pub fn mc_density(scene: &Scene, path: &[Vertex], c: usize) -> f64 {
    lp_density(scene, path, c)
}

/// MC, the multi-chain perturbation [Veach 1997, §11.4.4], for paths whose eye sub-path
/// E S* D is followed by a specular vertex: … S+ D S* E.
///
/// **Why.** On the Box scene (mirror right wall) a chain finds paths L S D S E (light → mirror
/// wall → floor or back wall → mirror wall → eye) and stays there: LP, LS and PM must reconnect
/// x_d to x_{d−1} and CP must connect x_{k−1} to the eye, and here both are specular, so only BD's
/// regeneration of (nearly) the whole path can leave, after thousands of steps that store one
/// photon with a huge accumulated power. MC moves such a path a little, as LP and CP move theirs.
///
/// **Sampling.** (1) The image point moves by an offset of radius r ∈ [r1, r2] with density
/// ∝ 1/r and a uniform angle, as LP's (`lens_r1_px`, `lens_r2_fraction`), and the new camera ray
/// is traced through the same specular bounces (each reflecting or refracting as X does) to the
/// first non-specular y_d. (2) At each non-specular y_j whose neighbour x_{j−1} toward the light
/// is specular, the old direction x_j → x_{j−1} of X is turned by an angle θ ∈ [θ1, θ2] with
/// density ∝ 1/θ and a uniform azimuth, as CP's (`caustic_theta1`, `caustic_theta2`), and the
/// ray is traced through the next specular chain. **Decision**: θ drawn afresh, not tied to the
/// angle of the previous perturbation (one reading of Veach's text): a tied θ leaves the
/// candidates on a set of lower dimension than the re-traced vertices, with no density in the
/// area measure. (3) It stops at the first non-specular y_j whose x_{j−1} is non-specular too,
/// connected to the unchanged x_{j−1} (shadow ray), or where a chain ends at the light: then the
/// hit on the light is the new y₀. Every re-traced vertex must be specular exactly where X's is,
/// so that the reverse move retraces the same chains.
///
/// **Densities.** The offset density p(u′|u) = 1 / (2π r² ln(r2/r1)) per unit raster area
/// [Veach 1997, §11.4.3] and the angle density p(ω′|ω) = 1 / (2π sin θ · θ ln(θ2/θ1)) per unit
/// solid angle depend only on |u′ − u| and on the angle between ω and ω′, the same for the move
/// X → Y and its reverse: they cancel in T(X|Y) / T(Y|X), as for LP and CP [Veach 1997,
/// §11.4.3]. What remains is the conversion of each re-traced vertex to the area measure, with
/// dropped deltas ([`crate::path_space`]): T(Y|X) = p(u′|u) C(y_{k−1}) Π p(ω′|ω) ·
/// Π_{i=c}^{k−2} |cos θ_{y_i}| / |y_{i+1} − y_i|² ([`mc_density`]), c the lowest re-traced index
/// (j of the connection, or 0).
pub fn multi_chain_perturbation(ctx: &Context, x: &[Vertex], rng: &mut Rng) -> Option<Candidate> {
    let scene = ctx.scene;
    let k = x.len() - 1;
    let d = first_diffuse_from_eye(x)?;
    if x[d - 1].connectible() {
        // (L|D) D S* E: LP's paths, no further chain.
        return None;
    }
    let u2 = perturbed_image_point(ctx, x, rng)?;
    let (theta1, theta2) = (ctx.params.caustic_theta1, ctx.params.caustic_theta2);
    let mut y = x.to_vec();
    retrace_through(scene, &mut y, x, u2)?;
    // y[i] is re-traced; walk toward the light until a connection or the light.
    let mut i = k - 1;
    let c = loop {
        let v = y[i];
        if v.delta != x[i].delta {
            return None;
        }
        let dir = if v.delta {
            let wo = v.frame.to_local(direction(&v, &y[i + 1]).0);
            let wi = specular_direction(&v.bsdf(scene), wo, reflects_at(x, i))?;
            v.frame.to_world(wi)
        } else if x[i - 1].connectible() {
            if !visible(scene, &x[i - 1], &v) {
                return None;
            }
            break i;
        } else {
            let axis = direction(&x[i], &x[i - 1]).0;
            let (theta, phi) = perturbation(rng, theta1, theta2);
            let local = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            Frame::from_normal(axis).to_world(local)
        };
        // A chain may end on the environment: x₀ is then where the ray leaves the scene.
        let next = trace_eye_from(scene, &v, dir)?;
        i -= 1;
        if i == 0 {
            // The reverse move re-traces to X's x₀: impossible from a point, spot or
            // directional light, which no ray hits (without this check such paths would move
            // to whatever light the ray finds, and never back).
            if !x[0].is_hittable_light() {
                return None;
            }
            y[0] = next.as_light(scene)?;
            break 0;
        }
        if !next.is_surface() {
            return None;
        }
        y[i] = keep_lobe(next, &x[i]);
    };
    let t_fwd = mc_density(scene, &y, c);
    let t_rev = mc_density(scene, x, c);
    ratio(y, t_rev, t_fwd)
}

#[cfg(test)]
mod tests {
    #[test]
    fn half_to_the_is_powi_exactly() {
        for j in (0..1100usize).chain([5000, usize::MAX]) {
            assert_eq!(
                super::half_to_the(j),
                0.5f64.powi(j.min(i32::MAX as usize) as i32),
                "j = {j}"
            );
        }
    }
}
