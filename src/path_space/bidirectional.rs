//! Bidirectional estimators over path space [Veach 1997, ch. 10]: the techniques that make a
//! path from a light sub-path and an eye sub-path, their power-heuristic weights, and what each
//! sub-path can cache so that a connection costs O(1) model evaluations. `bdpt` and `vcm` render
//! with it (module doc of [`crate::strategy::bdpt`], "MIS with cached sub-path factors");
//! [`bidirectional_sample`] estimates B with it for the Metropolis strategies. Sub-paths are
//! drawn with the densities of [`crate::path_space`] and Russian roulette; every technique's
//! value divides by the survival probabilities of the vertices it uses, the weights ignore
//! them (they still sum to one, so the estimators stay unbiased, as in pbrt).
//!
//! **Media** ([`crate::medium`]; `bdpt`, `vcm`). In a scene with media both sub-paths are drawn
//! by the walks of [`super::media`] ([`eye_subpath_in_media`], [`light_subpath_in_media`]): free
//! flights on every segment, vertices at collisions in media ([`super::VertexKind::Medium`], f_s
//! the phase function), `null` boundaries passed. Each vertex keeps the medium its walk reached
//! it in and the flights up to it ([`InMedium`]); a technique's value is its geometric w f / p
//! times the transmittance of its connecting edge, traced from the eye side
//! ([`super::media::transmittance_between`]), and the flights of both sub-paths. **Each sub-path
//! draws its own hero channel**: its density is then the mixture (1/3) Σ_c p_c over the channels
//! (the balance heuristic of [`crate::medium`]), and since the two heroes are independent, the
//! joined path's density is the product of the two mixtures — its estimate is the product of the
//! sub-paths' spectral estimates ([`super::media::Flights::estimate`] of each), unbiased. (One
//! hero shared by both sub-paths would need the mean over channels of the *products* of their
//! ratios instead; `vcm` merges an eye sub-path with every light sub-path of its pass, so a
//! shared hero would be one per pass, whose colour noise the whole image would share — measured:
//! a white furnace read (0.88, 0.96, 1.16) at 64 spp. The products' mean with independent heroes
//! is biased: +4.6 % in the test's coloured fog.)
//! **Decision: the MIS weights use pseudo-densities** — at each vertex the density of the
//! direction that led to it (BSDF, phase function, emission, camera) as an area density, without
//! the probability of the free flight that placed it there (σ_t T at a collision, T for a
//! surface reached through a medium) — as pbrt-v3's volumetric `BDPTIntegrator` does. The
//! flights' probabilities depend on the hero channel and, in heterogeneous media, are not known
//! in closed form; leaving them out keeps each technique's weight a function of the path alone,
//! so the weights still sum to one over the techniques and every technique stays unbiased. What
//! is lost is optimality where the flights matter: in dense media the weights misjudge how
//! likely each side was to reach a vertex.

use super::media::{Flights, MediaWalk, emission_ray, transmittance_between};
use super::walk::{extend_light_side, first_eye_vertex, join, sample_light_vertex, scatter, trace_eye, trace_from};
use super::{
    Vertex, VertexKind, camera_factor, contribution, direction, emitted, eye_toward, geometry, pdf_eye_side,
    pdf_eye_step, pdf_light_side, pdf_light_step, scattering, scattering_at, visible,
};
use crate::bsdf::TransportMode;
use crate::geometry::spawn_ray;
use crate::sampling::Rng;
use crate::scene::Scene;
use glam::{Vec2, Vec3};

/// A technique that can make a path of k edges: a connection with s light vertices
/// (0 ≤ s ≤ k), or vertex merging at x_m (1 ≤ m ≤ k − 1, the light side reaching x_m and the
/// eye side reaching it too, joined by a density-estimation kernel: `vcm`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Technique {
    Connect(usize),
    Merge(usize),
}

/// The density of `technique` for `path` and the sum of the squared densities of every
/// technique that could have made it, (p, Σ p²) — the power-heuristic weight being p² / Σ —
/// from the path's densities p_L(x_i) (`pl`) and p_E(x_i) (`pe`), i < k, however they were
/// obtained. The densities, in f64: p_s(X) = Π_{i<s} p_L(x_i) Π_{i=s}^{k−1} p_E(x_i) for a
/// connection, and with `eta`, merging at x_m: p_VM,m(X) = η p_L(x_m) p_m(X) [Georgiev et al.
/// 2012, eq. (13); Hachisuka et al. 2012], x_m sampled by both sides and accepted within
/// the kernel's disc π r², by any of the N_VM light sub-paths of the pass. A connection
/// counts when it joins two non-specular vertices (s' = 0 and the eye side of t = 1
/// always can); merging needs a non-specular x_m. `None` for paths of more than `max_edges`
/// edges or of zero density.
pub fn mis_weight_from(
    path: &[Vertex],
    pl: &[f64],
    pe: &[f64],
    technique: Technique,
    eta: Option<f64>,
    max_edges: usize,
) -> Option<(f64, f64)> {
    let k = path.len() - 1;
    if k > max_edges {
        return None;
    }
    // Prefix products of p_L and suffix products of p_E: every p_s in O(1) after O(k).
    let mut light_prefix = Vec::with_capacity(k + 1);
    light_prefix.push(1.0);
    for &d in pl {
        light_prefix.push(light_prefix[light_prefix.len() - 1] * d);
    }
    let mut eye_suffix = vec![1.0; k + 1];
    for i in (0..k).rev() {
        eye_suffix[i] = pe[i] * eye_suffix[i + 1];
    }
    let p = |s: usize| -> f64 { light_prefix[s] * eye_suffix[s] };
    // Technique s' joins x_{s'−1} and x_{s'}: both must be non-specular (the eye vertex and a
    // hit of the eye walk on a light always may).
    // The eye walk cannot hit a point, spot or directional light (s' = 0 needs x₀ on an
    // area light or the environment).
    let valid = |s: usize| {
        if s == 0 {
            path[0].is_hittable_light()
        } else {
            path[s - 1].connectible() && (s == k || path[s].connectible())
        }
    };
    let p_merge = |m: usize, eta: f64| eta * pl[m] * p(m);
    let can_merge = |m: usize| m >= 1 && m < k && path[m].is_surface() && path[m].connectible();
    let pt = match technique {
        Technique::Connect(s) => p(s),
        Technique::Merge(m) => p_merge(m, eta?),
    };
    if !(pt > 0.0 && pt.is_finite()) {
        return None;
    }
    let mut sum: f64 = (0..=k).filter(|&s| valid(s)).map(|s| p(s).powi(2)).sum();
    if let Some(eta) = eta {
        sum += (1..k)
            .filter(|&m| can_merge(m))
            .map(|m| p_merge(m, eta).powi(2))
            .sum::<f64>();
    }
    Some((pt, sum))
}

/// (p, Σ p²) of [`mis_weight_from`] with every density evaluated on the whole path (O(k)
/// model evaluations): the reference the caches are held to, and the route of one-edge paths.
pub fn mis_weight(
    scene: &Scene,
    path: &[Vertex],
    technique: Technique,
    eta: Option<f64>,
    max_edges: usize,
) -> Option<(f64, f64)> {
    let k = path.len() - 1;
    let pl: Vec<f64> = (0..k).map(|i| pdf_light_side(scene, path, i) as f64).collect();
    let pe: Vec<f64> = (0..k).map(|i| pdf_eye_side(scene, path, i) as f64).collect();
    mis_weight_from(path, &pl, &pe, technique, eta, max_edges)
}

/// w_s f(X) / p_s(X) of `path` made by the technique with `s` light vertices (with `eta`,
/// merging in the weights), and the raster position of its last edge, evaluated whole; `None`
/// when it contributes nothing.
pub fn weighted_whole(
    scene: &Scene,
    path: &[Vertex],
    s: usize,
    eta: Option<f64>,
    max_edges: usize,
) -> Option<(Vec3, Vec2)> {
    let (f, raster) = contribution(scene, path)?;
    if f == Vec3::ZERO || !f.is_finite() {
        return None;
    }
    let (ps, sum) = mis_weight(scene, path, Technique::Connect(s), eta, max_edges)?;
    // w_s / p_s = p_s / Σ p².
    let value = f.as_dvec3() * (ps / sum);
    (value.is_finite()).then(|| (value.as_vec3(), raster))
}

/// w_s f(X) / p_s(X) of the path of technique (s, t) between the sub-paths the caches were
/// built from (with `eta`, merging in the weights), and the raster position of its last
/// edge (t = 1); `None` when it contributes nothing. Evaluates only what the connection
/// changes: at most three scattering and geometry factors next to the connecting edge and
/// four densities (p_L of the two eye-side vertices nearest it, p_E of the two light-side
/// ones); the rest comes from the caches. Paths of one edge (techniques (0, 2) and (1, 1)) are
/// evaluated whole.
pub fn weighted_cached(
    scene: &Scene,
    path: &[Vertex],
    (s, t): (usize, usize),
    (eye, light): (&EyeCache, &LightCache),
    eta: Option<f64>,
    max_edges: usize,
) -> Option<(Vec3, Vec2)> {
    let k = path.len() - 1;
    if k < 2 {
        return weighted_whole(scene, path, s, eta, max_edges);
    }
    // f(X) = Le G(x₀, x₁) Π_{i=1}^{k−1} f_s(x_i) Π_{i=1}^{k−2} G(x_i, x_{i+1}) C(x_{k−1}).
    let (f, raster) = match (s, t) {
        (0, _) => (
            emitted_first_edge(scene, path) * scattering(scene, path, 1) * eye.f[t - 1],
            Vec2::ZERO,
        ),
        (_, 1) => {
            let (raster, c) = camera_factor(scene, &path[k - 1], &path[k])?;
            (light.f[s] * scattering(scene, path, s - 1) * c, raster)
        }
        (1, _) => (
            emitted_first_edge(scene, path) * scattering(scene, path, 1) * eye.f[t],
            Vec2::ZERO,
        ),
        _ => {
            let connection =
                scattering(scene, path, s - 1) * geometry(&path[s - 1], &path[s]) * scattering(scene, path, s);
            (light.f[s] * connection * eye.f[t], Vec2::ZERO)
        }
    };
    if f == Vec3::ZERO || !f.is_finite() {
        return None;
    }
    let (pl, pe) = cached_densities(scene, path, s, (eye, light));
    let (ps, sum) = mis_weight_from(path, &pl, &pe, Technique::Connect(s), eta, max_edges)?;
    let value = f.as_dvec3() * (ps / sum);
    (value.is_finite()).then(|| (value.as_vec3(), raster))
}

/// p_L(x_i) and p_E(x_i), i < k, of `path`, made of the first `s` vertices of the light
/// sub-path behind `light` and the eye sub-path behind `eye` (x_i = z_{k−i} for i ≥ s): from the
/// caches, except the four densities the joining edge changes (p_L of x_s, x_{s+1}; p_E of
/// x_{s−1}, x_{s−2}; with s = 0 p_L of x₀, x₁ and p_E of x₀).
pub fn cached_densities(
    scene: &Scene,
    path: &[Vertex],
    s: usize,
    (eye, light): (&EyeCache, &LightCache),
) -> (Vec<f64>, Vec<f64>) {
    let k = path.len() - 1;
    let pl = (0..k)
        .map(|i| match i {
            _ if i < s => light.pl[i],
            _ if i <= s + 1 => pdf_light_side(scene, path, i) as f64,
            _ => eye.pl[k - i],
        })
        .collect();
    let pe = (0..k)
        .map(|i| match i {
            _ if i + 2 < s => light.pe[i],
            _ if i < s || (s == 0 && i == 0) => pdf_eye_side(scene, path, i) as f64,
            _ => eye.pe[k - i],
        })
        .collect();
    (pl, pe)
}

/// Le(x₀ → x₁) G(x₀, x₁) of a path.
fn emitted_first_edge(scene: &Scene, path: &[Vertex]) -> Vec3 {
    emitted(scene, path) * geometry(&path[0], &path[1])
}

/// What no connection changes on a light sub-path y of L vertices, computed once (module doc,
/// "MIS with cached sub-path factors").
pub struct LightCache {
    /// p_L(y_i), from y_{i−1} and y_{i−2} (i < L).
    pl: Vec<f64>,
    /// p_E(y_i) when y_{i+1} and y_{i+2} follow it (i + 2 < L).
    pe: Vec<f64>,
    /// Le G(y₀, y₁) Π_{i=1}^{s−2} f_s(y_i) G(y_i, y_{i+1}): the light prefix of a path with s
    /// light vertices, f_s at y_{s−1} excluded (index s ≥ 2).
    f: Vec<Vec3>,
}

impl LightCache {
    pub fn new(scene: &Scene, y: &[Vertex]) -> Self {
        let l = y.len();
        let pl = (0..l).map(|i| pdf_light_side(scene, y, i) as f64).collect();
        let pe = (0..l.saturating_sub(2))
            .map(|i| pdf_eye_step(scene, &y[i], &y[i + 1], Some(&y[i + 2])) as f64)
            .collect();
        let mut f = vec![Vec3::ZERO; l.max(2) + 1];
        if l >= 2 {
            f[2] = emitted_first_edge(scene, y);
            for s in 3..=l {
                f[s] =
                    f[s - 1] * scattering_at(scene, &y[s - 2], &y[s - 1], &y[s - 3]) * geometry(&y[s - 2], &y[s - 1]);
            }
        }
        Self { pl, pe, f }
    }

    /// α_L(u) = f / p of the sub-path up to y_u (u ≥ 1) in area measure: a photon's flux (`vcm`).
    pub fn alpha(&self, u: usize) -> Vec3 {
        let p: f64 = self.pl[..=u].iter().product();
        if !(p > 0.0 && p.is_finite()) {
            return Vec3::ZERO;
        }
        (self.f[u + 1].as_dvec3() / p).as_vec3()
    }
}

/// What no connection changes on an eye sub-path z of T vertices (z₀ the eye vertex).
pub struct EyeCache {
    /// p_E(z_j), from z_{j−1} and z_{j−2} (1 ≤ j < T; index 0 unused).
    pe: Vec<f64>,
    /// p_L(z_j) when z_{j+1} and z_{j+2} precede it on the light side (j + 2 < T).
    pl: Vec<f64>,
    /// C(z₁) Π_{j=1}^{t−2} f_s(z_j) G(z_{j+1}, z_j): the eye suffix of a path with t eye
    /// vertices, f_s at z_{t−1} excluded (index t ≥ 2).
    f: Vec<Vec3>,
}

impl EyeCache {
    pub fn new(scene: &Scene, z: &[Vertex]) -> Self {
        let t = z.len();
        let pe = (0..t)
            .map(|j| match j {
                0 => 0.0,
                _ => pdf_eye_step(scene, &z[j], &z[j - 1], j.checked_sub(2).map(|i| &z[i])) as f64,
            })
            .collect();
        let pl = (0..t.saturating_sub(2))
            .map(|j| pdf_light_step(scene, &z[j], &z[j + 1], &z[j + 2]) as f64)
            .collect();
        let mut f = vec![Vec3::ZERO; t.max(2) + 1];
        if t >= 2 {
            f[2] = camera_factor(scene, &z[1], &z[0]).map_or(Vec3::ZERO, |(_, c)| Vec3::splat(c));
            for j in 3..=t {
                f[j] =
                    f[j - 1] * scattering_at(scene, &z[j - 2], &z[j - 3], &z[j - 1]) * geometry(&z[j - 1], &z[j - 2]);
            }
        }
        Self { pe, pl, f }
    }

    /// α_E(t − 1) = f / p per pixel of the sub-path up to z_{t−1} (t ≥ 2): C(z₁) Π f_s G over N
    /// (`pixels`) times the densities of z₁ … z_{t−1} (`vcm`).
    pub fn alpha(&self, t: usize, pixels: f64) -> Vec3 {
        let p: f64 = self.pe[1..t].iter().product::<f64>() * pixels;
        if !(p > 0.0 && p.is_finite()) {
            return Vec3::ZERO;
        }
        (self.f[t].as_dvec3() / p).as_vec3()
    }
}

/// How long sub-paths grow: at most `max_depth` scattering events of a path, Russian roulette
/// after `rr_depth` events of a sub-path.
#[derive(Clone, Copy, Debug)]
pub struct Roulette {
    pub max_depth: usize,
    pub rr_depth: usize,
}

impl Roulette {
    /// Survival probability after a vertex whose throughput is `now` against `first`: 1 before
    /// `rr_depth` scattering events, else min(0.95, Y(now) / Y(first)).
    fn survival(&self, events: usize, now: Vec3, first: Vec3) -> f64 {
        if events < self.rr_depth {
            return 1.0;
        }
        let (y, y0) = (crate::color::luminance(now), crate::color::luminance(first));
        if y0 > 0.0 {
            (y / y0).clamp(0.0, 0.95) as f64
        } else {
            0.0
        }
    }

    /// Grows `sub` by BSDF sampling in `mode` until it holds `max_vertices`, the roulette ends
    /// it, or a ray leaves the scene (an eye walk, in `Radiance` mode, then ends on the
    /// environment if the scene has one).
    fn grow(&self, scene: &Scene, sub: &mut SubPath, max_vertices: usize, mode: TransportMode, rng: &mut Rng) {
        let (mut beta, mut q) = (Vec3::ONE, 1.0);
        while sub.vertices.len() < max_vertices {
            let n = sub.vertices.len();
            let Some(step) = scatter(scene, &mut sub.vertices, mode, rng) else {
                break;
            };
            let v = sub.vertices[n - 1];
            beta *= step.weight;
            let survive = self.survival(n - 1, beta, Vec3::ONE);
            if survive < 1.0 {
                if rng.uniform() as f64 >= survive {
                    break;
                }
                beta /= survive as f32;
            }
            q *= survive;
            let next = match mode {
                TransportMode::Radiance => trace_eye(scene, &spawn_ray(v.p, v.ng, step.wi)),
                TransportMode::Importance => trace_from(scene, &v, step.wi),
            };
            let Some(next) = next else { break };
            sub.push(next, q);
            if next.is_at_infinity() {
                break;
            }
        }
    }
}

/// A sub-path: its vertices and, per vertex, the probability that Russian roulette let the
/// walk reach it (1 before `rr_depth`), and in a scene with media where its walk was
/// ([`InMedium`]; empty otherwise).
#[derive(Clone, Default)]
pub struct SubPath {
    pub vertices: Vec<Vertex>,
    pub survival: Vec<f64>,
    pub media: Vec<InMedium>,
}

/// Where a walk through media reached a vertex: the medium it arrived in (the one a ray leaving
/// the vertex on the side it came from travels in) and the flights from the sub-path's start.
#[derive(Clone, Copy, Debug)]
pub struct InMedium {
    pub medium: Option<u32>,
    pub flights: Flights,
}

impl SubPath {
    fn push(&mut self, v: Vertex, survival: f64) {
        self.vertices.push(v);
        self.survival.push(survival);
    }

    fn push_in(&mut self, v: Vertex, survival: f64, walk: &MediaWalk) {
        self.push(v, survival);
        self.media.push(InMedium {
            medium: walk.medium,
            flights: walk.flights,
        });
    }

    /// The flights up to vertex `i` (none in a scene without media).
    #[inline]
    pub fn flights(&self, i: usize) -> Flights {
        self.media.get(i).map_or(Flights::ONE, |m| m.flights)
    }
}

/// [`eye_subpath`] through media, its flights drawn with a hero channel of its own (module doc,
/// "Media").
pub fn eye_subpath_in_media(scene: &Scene, raster: Vec2, roulette: Roulette, rng: &mut Rng) -> SubPath {
    let hero = MediaWalk::draw_hero(rng);
    let mut sub = SubPath::default();
    let mut z0 = Vertex::eye(scene, rng);
    let cam = &scene.camera;
    let ray = cam.ray_from(raster, z0.p);
    z0.p = ray.o;
    let mut walk = MediaWalk::new(hero, scene.camera_medium);
    sub.push_in(z0, 1.0, &walk);
    let Some(mut z1) = walk.next_vertex(scene, ray, true, rng) else {
        return sub;
    };
    z1.delta |= z1.is_at_infinity() && cam.is_orthographic();
    sub.push_in(z1, 1.0, &walk);
    if !z1.is_at_infinity() {
        roulette.grow_in_media(
            scene,
            &mut sub,
            roulette.max_depth + 2,
            TransportMode::Radiance,
            walk,
            rng,
        );
    }
    sub
}

/// [`light_subpath`] through media, its flights drawn with a hero channel of its own.
pub fn light_subpath_in_media(scene: &Scene, roulette: Roulette, rng: &mut Rng) -> SubPath {
    let hero = MediaWalk::draw_hero(rng);
    let mut sub = SubPath::default();
    let Some(x0) = sample_light_vertex(scene, rng) else {
        return sub;
    };
    sub.push_in(x0, 1.0, &MediaWalk::new(hero, None));
    let Some((ray, mut walk)) = emission_ray(scene, &x0, hero, rng) else {
        return sub;
    };
    if let Some(x1) = walk.next_vertex(scene, ray, false, rng) {
        sub.push_in(x1, 1.0, &walk);
        roulette.grow_in_media(
            scene,
            &mut sub,
            roulette.max_depth + 1,
            TransportMode::Importance,
            walk,
            rng,
        );
    }
    sub
}

/// The eye sub-path through `raster`: z₀ on the camera (a lens point drawn uniformly for a
/// thin lens), then up to `max_depth + 1` surface vertices, ended by the environment where a
/// ray leaves a scene that has one. Throughput for roulette: the product of f_s |cos| / p_ω
/// along the walk.
pub fn eye_subpath(scene: &Scene, raster: Vec2, roulette: Roulette, rng: &mut Rng) -> SubPath {
    let mut sub = SubPath::default();
    let mut z0 = Vertex::eye(scene, rng);
    let z1 = first_eye_vertex(scene, &mut z0, raster);
    sub.push(z0, 1.0);
    let Some(z1) = z1 else {
        return sub;
    };
    sub.push(z1, 1.0);
    if !z1.is_at_infinity() {
        roulette.grow(scene, &mut sub, roulette.max_depth + 2, TransportMode::Radiance, rng);
    }
    sub
}

/// The light sub-path: y₀ on a light, then up to `max_depth` scattering vertices.
pub fn light_subpath(scene: &Scene, roulette: Roulette, rng: &mut Rng) -> SubPath {
    let mut sub = SubPath::default();
    let mut path = Vec::new();
    let whole = extend_light_side(scene, &mut path, 2, rng);
    for &v in &path {
        sub.push(v, 1.0);
    }
    if whole {
        roulette.grow(scene, &mut sub, roulette.max_depth + 1, TransportMode::Importance, rng);
    }
    sub
}

impl Roulette {
    /// [`Roulette::grow`] through media: the next direction from the BSDF at a surface, from
    /// the phase function in a medium (whose sample weighs 1), the next vertex by `walk`'s free
    /// flights; the roulette weighs the sub-path's estimate, flights included.
    fn grow_in_media(
        &self,
        scene: &Scene,
        sub: &mut SubPath,
        max_vertices: usize,
        mode: TransportMode,
        mut walk: MediaWalk,
        rng: &mut Rng,
    ) {
        let (mut beta, mut q) = (Vec3::ONE, 1.0);
        while sub.vertices.len() < max_vertices {
            let n = sub.vertices.len();
            let v = sub.vertices[n - 1];
            let d = match v.kind {
                VertexKind::Medium(m) => {
                    let travel = direction(&sub.vertices[n - 2], &v).0;
                    scene.media[m as usize].phase.sample(travel, rng.uniform2()).0
                }
                _ => {
                    let Some(step) = scatter(scene, &mut sub.vertices, mode, rng) else {
                        break;
                    };
                    beta *= step.weight;
                    step.wi
                }
            };
            let survive = self.survival(n - 1, walk.flights.estimate(beta), Vec3::ONE);
            if survive < 1.0 {
                if rng.uniform() as f64 >= survive {
                    break;
                }
                beta /= survive as f32;
            }
            q *= survive;
            let ray = walk.leave(scene, &v, d);
            let Some(next) = walk.next_vertex(scene, ray, mode == TransportMode::Radiance, rng) else {
                break;
            };
            sub.push_in(next, q, &walk);
            if next.is_at_infinity() {
                break;
            }
        }
    }
}

/// One path a connection made ([`connect_all`]).
pub struct Connection<'a> {
    pub path: &'a [Vertex],
    /// Light vertices s and eye vertices t of the technique.
    pub s: usize,
    pub t: usize,
    /// w f(X) / p(X) over the survival probabilities of the vertices it uses (p with the eye's
    /// first vertex over the whole image: a pixel's share is this over N).
    pub value: Vec3,
    /// Where t = 1 lands on the image (the path is splatted there); `None` for the eye's pixel.
    pub raster: Option<Vec2>,
}

/// Every connection technique between one eye and one light sub-path — s = 0 (the eye walk hits
/// a light), t = 1 (y_{s−1} to the eye), s ≥ 1 with t ≥ 2 (y_{s−1} to z_{t−1}) — each of
/// at most `max_edges` edges, weighted with merging in the weights when `eta` is given (`vcm`);
/// `visit` receives those that contribute, with `rng` (which, in a scene with media, also
/// estimates the connections' transmittance). Returns the number of connections tried (shadow
/// rays cast or skipped by an earlier test).
pub fn connect_all(
    scene: &Scene,
    (eye, light): (&SubPath, &SubPath),
    caches: (&EyeCache, &LightCache),
    eta: Option<f64>,
    max_edges: usize,
    rng: &mut Rng,
    visit: &mut impl FnMut(Connection, &mut Rng),
) -> u64 {
    let (z, y) = (&eye.vertices, &light.vertices);
    let weigh = |path: &[Vertex], s: usize, t: usize| weighted_cached(scene, path, (s, t), caches, eta, max_edges);
    let media = !eye.media.is_empty();
    // What reaches z (eye-side vertex `t` − 1, or the eye `z0` of t = 1) from y_{s−1} along
    // the connecting edge, and the estimate of a value with the flights of both sub-paths.
    let through = |zt: &Vertex, t: usize, s: usize, rng: &mut Rng| {
        if media {
            let arrived_in = eye.media[t - 1].medium;
            transmittance_between(scene, zt, arrived_in, &y[s - 1], rng)
        } else {
            if visible(scene, &y[s - 1], zt) {
                Vec3::ONE
            } else {
                Vec3::ZERO
            }
        }
    };
    let estimate = |v: Vec3, s: usize, t: usize| {
        if media {
            let v = if s == 0 { v } else { light.flights(s - 1).estimate(v) };
            eye.flights(t - 1).estimate(v)
        } else {
            v
        }
    };
    let mut tried = 0;
    // s = 0: the eye walk hits a light at z_{t−1}.
    let mut path = Vec::with_capacity(z.len() + y.len());
    for t in 2..=z.len() {
        if let Some(x0) = z[t - 1].as_light(scene) {
            path.clear();
            path.push(x0);
            path.extend(z[..t - 1].iter().rev());
            if let Some((v, _)) = weigh(&path, 0, t) {
                let value = estimate(v / eye.survival[t - 1] as f32, 0, t);
                visit(
                    Connection {
                        path: &path,
                        s: 0,
                        t,
                        value,
                        raster: None,
                    },
                    rng,
                );
            }
        }
    }
    for s in 1..=y.len() {
        if !y[s - 1].can_end_connection() {
            continue;
        }
        // t = 1: y_{s−1} to the eye (the eye walk's lens point, the film point behind y_{s−1}
        // for an orthographic camera), splatted.
        let z0 = eye_toward(scene, &y[s - 1], &z[0]);
        if camera_factor(scene, &y[s - 1], &z0).is_some() {
            let path = join(&y[..s], &[z0]);
            tried += 1;
            if let Some((v, r)) = weigh(&path, s, 1) {
                let tr = through(&z0, 1, s, rng);
                if tr != Vec3::ZERO {
                    let value = estimate(v * tr / light.survival[s - 1] as f32, s, 1);
                    visit(
                        Connection {
                            path: &path,
                            s,
                            t: 1,
                            value,
                            raster: Some(r),
                        },
                        rng,
                    );
                }
            }
        }
        // t ≥ 2: y_{s−1} to z_{t−1} (a surface or a point in a medium: not the environment that
        // ends an eye walk).
        for t in 2..=z.len() {
            if !(z[t - 1].scatters() && z[t - 1].can_end_connection()) {
                continue;
            }
            let path = join(&y[..s], &z[..t]);
            tried += 1;
            if let Some((v, _)) = weigh(&path, s, t) {
                let tr = through(&z[t - 1], t, s, rng);
                if tr != Vec3::ZERO {
                    let value = estimate(v * tr / (light.survival[s - 1] * eye.survival[t - 1]) as f32, s, t);
                    visit(
                        Connection {
                            path: &path,
                            s,
                            t,
                            value,
                            raster: None,
                        },
                        rng,
                    );
                }
            }
        }
    }
    tried
}

/// One bidirectional sample of the whole image for the normalisation B and the chains' first
/// states, where [`crate::path_space::walk::path_tracing_sample`] cannot reach every path the
/// chains can: an eye sub-path through a raster point uniform over the image and a light
/// sub-path, each of up to `max_edges` edges (roulette after 3 scattering events, as `bdpt`),
/// joined in every way by [`connect_all`] with the power heuristic over all techniques [Veach
/// 1997, §10.2–10.3; Veach's own estimate of B, §11.3.1]. `emit(path, c)` receives each path
/// with c = w f / p, so that E[Σ c] = ∫ f dμ = B. Paths from a point, spot or directional light
/// whose first bounce is specular (the light's caustics) need it: no eye walk hits such a
/// light and next-event estimation cannot end on a specular vertex, while the chains'
/// bidirectional mutation makes them.
pub fn bidirectional_sample(scene: &Scene, max_edges: usize, rng: &mut Rng, emit: &mut impl FnMut(&[Vertex], Vec3)) {
    let cam = &scene.camera;
    let raster = rng.uniform2() * Vec2::new(cam.width as f32, cam.height as f32);
    let roulette = Roulette {
        max_depth: max_edges - 1,
        rr_depth: 3,
    };
    let eye = eye_subpath(scene, raster, roulette, rng);
    let light = light_subpath(scene, roulette, rng);
    let caches = (
        &EyeCache::new(scene, &eye.vertices),
        &LightCache::new(scene, &light.vertices),
    );
    connect_all(scene, (&eye, &light), caches, None, max_edges, rng, &mut |c, _| {
        emit(c.path, c.value)
    });
}
