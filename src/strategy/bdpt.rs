//! `kind = "bdpt"`: bidirectional path tracing with multiple importance sampling [Veach &
//! Guibas 1995; Veach 1997, ch. 10]. Every pixel sample draws an eye sub-path z₀ (the pinhole),
//! z₁ … and a light sub-path y₀ (on a light), y₁ …, and joins them in every way: for a path
//! of k edges, the technique with s light vertices and t = k + 1 − s eye vertices,
//! - s = 0: the eye sub-path hits a light;
//! - s ≥ 1, t ≥ 2: y_{s−1} and z_{t−1} connected by a shadow ray (s = 1 is next-event
//!   estimation);
//! - t = 1: y_{s−1} connected to the pinhole and splatted where it lands (light tracing).
//!
//! **Weights** [Veach 1997, eq. (10.9) and §9.2]: the power heuristic over the techniques that
//! could have made the path, w_s = p_s² / Σ_{s'} p_{s'}², with the densities of
//! [`crate::path_space`]: p_s(X) = Π_{i<s} p_L(x_i) Π_{i=s}^{k−1} p_E(x_i), in f64. A technique
//! counts when its connection edge joins two non-specular vertices (s' = 0 and the pinhole side
//! of t = 1 always can). **Decision: the eye's first vertex is taken over the whole image**
//! (p_E(x_{k−1}) = C / N for N pixels, as [`crate::path_space::pdf_eye_side`] has it): a pass
//! makes one eye sample per pixel and N light sub-paths that all splat, so for any one pixel
//! the light-tracing technique takes N samples to each eye technique's one, and N p_E is the
//! per-pixel density; the N cancels in the balance of the weights. Each technique then adds
//! w_s f(X) / (N p_s(X)) to its pixel.
//!
//! **Russian roulette** on each sub-path after `rr_depth` scattering events, with the
//! survival probability of the throughput relative to the sub-path's first (eye: the camera
//! ray's weight 1; light: the emitted flux), at most 0.95; contributions divide by the
//! survival probabilities of the vertices they use, the weights ignore them (they still sum to
//! one, so the estimator stays unbiased, as in pbrt).
//!
//! **MIS with cached sub-path factors.** The densities and f come from the path-space
//! functions the Metropolis strategies test. Each sub-path first caches what no connection
//! changes ([`LightCache`], [`EyeCache`]): every vertex's density from its own side and from
//! the other side where its two neighbours are its own, and the throughput products f_s G of
//! its prefix; a connection (or a `vcm` merge) then evaluates only the two scattering factors
//! and the geometry term of the connecting edge and the four densities next to it (pbrt-v3's
//! `MISWeight` caches the same forward and reverse densities), instead of all 2k densities and
//! k factors of its path (the earlier "MIS by recomputation", kept as [`Bdpt::mis_weight`] and
//! [`Bdpt::weighted`]: the reference a unit test holds every technique to, within 2·10⁻⁴, and
//! the route of one-edge paths). Measured
//! side by side with the build before it (perf-suite cases `cornell-box` 64 × 64 and
//! `cornell-spheres` 32 × 32 at 16 spp, two alternating runs of 5 rounds, 2 threads): `bdpt`
//! 1.10–1.13×, `vcm` 1.08–1.19× pixel samples/s (`path`, untouched, 1.01×); on `cornell-empty`
//! no gain. The rest is the technique's own cost: its rays (a shadow ray per connection) and
//! per-connection allocations.

use super::{Declared, Strategy};
use crate::bsdf::TransportMode;
use crate::error::Result;
use crate::film::Film;
use crate::geometry::spawn_ray;
use crate::params::{Params, Range};
use crate::path_space::walk::{extend_light_side, join, scatter, trace_eye, trace_from};
use crate::path_space::{
    Vertex, camera_factor, contribution, emitted, geometry, pdf_eye_side, pdf_eye_step, pdf_light_side, pdf_light_step,
    scattering, scattering_at, visible,
};
use crate::sampling::{Rng, stream};
use crate::scene::Scene;
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use std::ops::Range as Samples;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

/// Pixels per task: a fixed split, so that splats are summed in the same order on any number
/// of threads.
pub const CHUNK: usize = 256;

crate::declare_params! {
    /// Parameters of `kind = "bdpt"`.
    pub struct BdptParams {
        /// Maximum number of scattering events of a path (edges − 1), as `path`'s `max_depth`.
        max_depth: u32 = 16, range Range::int(0, 1024);
        /// Russian roulette on each sub-path starts after this many scattering events.
        rr_depth: u32 = 3, range Range::int(0, 1024);
    }
}

/// Bidirectional path tracing.
pub struct Bdpt {
    params: BdptParams,
    samples: AtomicU64,
    connections: AtomicU64,
    splats: AtomicU64,
}

impl Declared for Bdpt {
    const KIND: &'static str = "bdpt";
    const SUMMARY: &'static str = "bidirectional path tracing, every (s, t) technique, power-heuristic MIS (Veach & Guibas 1995; Veach 1997, ch. 10)";
    type Params = BdptParams;

    fn new(params: BdptParams) -> Result<Self> {
        Ok(Self {
            params,
            samples: AtomicU64::new(0),
            connections: AtomicU64::new(0),
            splats: AtomicU64::new(0),
        })
    }
}

/// A sub-path: its vertices and, per vertex, the probability that Russian roulette let the
/// walk reach it (1 before `rr_depth`).
#[derive(Clone, Default)]
pub(super) struct SubPath {
    pub(super) vertices: Vec<Vertex>,
    pub(super) survival: Vec<f64>,
}

impl SubPath {
    fn push(&mut self, v: Vertex, survival: f64) {
        self.vertices.push(v);
        self.survival.push(survival);
    }
}

/// Contributions to other pixels: (pixel index, value).
pub(super) type Splats = Vec<(u32, Vec3)>;

/// What one pixel sample adds: to its own pixel, and splats anywhere.
pub(super) struct Sample {
    pub(super) own: Vec3,
    pub(super) splats: Splats,
}

/// A technique that can make a path of k edges: a connection with s light vertices
/// (0 ≤ s ≤ k), or vertex merging at x_m (1 ≤ m ≤ k − 1, the light side reaching x_m and the
/// eye side reaching it too, joined by a density-estimation kernel: `vcm`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Technique {
    Connect(usize),
    Merge(usize),
}

impl Bdpt {
    /// Survival probability after a vertex whose throughput is `now` against `first`: 1 before
    /// `rr_depth` scattering events, else min(0.95, Y(now) / Y(first)).
    fn survival(&self, events: usize, now: Vec3, first: Vec3) -> f64 {
        if events < self.params.rr_depth as usize {
            return 1.0;
        }
        let (y, y0) = (crate::color::luminance(now), crate::color::luminance(first));
        if y0 > 0.0 {
            (y / y0).clamp(0.0, 0.95) as f64
        } else {
            0.0
        }
    }

    /// The eye sub-path through `raster`: z₀ the pinhole, then up to `max_depth + 1` surface
    /// vertices, ended by the environment where a ray leaves a scene that has one.
    /// Throughput for roulette: the product of f_s |cos| / p_ω along the walk.
    pub(super) fn eye_subpath(&self, scene: &Scene, raster: Vec2, rng: &mut Rng) -> SubPath {
        let mut sub = SubPath::default();
        sub.push(Vertex::eye(scene), 1.0);
        let Some(z1) = trace_eye(scene, &scene.camera.generate_ray(raster)) else {
            return sub;
        };
        sub.push(z1, 1.0);
        if z1.is_at_infinity() {
            return sub;
        }
        let (mut beta, mut q) = (Vec3::ONE, 1.0);
        while sub.vertices.len() < self.params.max_depth as usize + 2 {
            let n = sub.vertices.len();
            let Some(step) = scatter(scene, &mut sub.vertices, TransportMode::Radiance, rng) else {
                break;
            };
            let (v, d) = (sub.vertices[n - 1], step.wi);
            beta *= step.weight;
            let survive = self.survival(n - 1, beta, Vec3::ONE);
            if survive < 1.0 {
                if rng.uniform() as f64 >= survive {
                    break;
                }
                beta /= survive as f32;
            }
            q *= survive;
            let Some(next) = trace_eye(scene, &spawn_ray(v.p, v.ng, d)) else {
                break;
            };
            sub.push(next, q);
            if next.is_at_infinity() {
                break;
            }
        }
        sub
    }

    /// The light sub-path: y₀ on a light, then up to `max_depth` scattering vertices.
    pub(super) fn light_subpath(&self, scene: &Scene, rng: &mut Rng) -> SubPath {
        let mut sub = SubPath::default();
        let mut path = Vec::new();
        if !extend_light_side(scene, &mut path, 2, rng) {
            if let Some(&y0) = path.first() {
                sub.push(y0, 1.0);
            }
            return sub;
        }
        sub.push(path[0], 1.0);
        sub.push(path[1], 1.0);
        let (mut beta, mut q) = (Vec3::ONE, 1.0);
        while sub.vertices.len() < self.params.max_depth as usize + 1 {
            let n = sub.vertices.len();
            let Some(step) = scatter(scene, &mut sub.vertices, TransportMode::Importance, rng) else {
                break;
            };
            let (v, d) = (sub.vertices[n - 1], step.wi);
            beta *= step.weight;
            let survive = self.survival(n - 1, beta, Vec3::ONE);
            if survive < 1.0 {
                if rng.uniform() as f64 >= survive {
                    break;
                }
                beta /= survive as f32;
            }
            q *= survive;
            let Some(next) = trace_from(scene, &v, d) else { break };
            sub.push(next, q);
        }
        sub
    }

    /// w_s f(X) / (N p_s(X)) of `path` made by the technique with `s` light vertices, and the
    /// raster position of its last edge; `None` when it contributes nothing. With `eta`
    /// (η = N_VM π r², `vcm`), vertex merging competes in the weights ([`Bdpt::mis_weight`]).
    fn weighted(&self, scene: &Scene, path: &[Vertex], s: usize, eta: Option<f64>) -> Option<(Vec3, Vec2)> {
        let (f, raster) = contribution(scene, path)?;
        if f == Vec3::ZERO || !f.is_finite() {
            return None;
        }
        let (ps, sum) = self.mis_weight(scene, path, Technique::Connect(s), eta)?;
        let n = scene.camera.pixel_count() as f64;
        // w_s / (N p_s) = p_s / (N Σ p²).
        let value = f.as_dvec3() * (ps / (sum * n));
        (value.is_finite()).then(|| (value.as_vec3(), raster))
    }

    /// The density of `technique` for `path` and the sum of the squared densities of every
    /// technique that could have made it: (p, Σ p²), the power-heuristic weight being p² / Σ. The
    /// densities, in f64: p_s(X) = Π_{i<s} p_L(x_i) Π_{i=s}^{k−1} p_E(x_i) for a connection,
    /// and with `eta`, merging at x_m: p_VM,m(X) = η p_L(x_m) p_m(X) [Georgiev et al. 2012,
    /// eq. (13); Hachisuka et al. 2012], x_m sampled by both sides and accepted within
    /// the kernel's disc π r², by any of the N_VM light sub-paths of the pass. A connection
    /// counts when it joins two non-specular vertices (s' = 0 and the pinhole side of t = 1
    /// always can); merging needs a non-specular x_m. `None` for paths longer than `max_depth`
    /// or of zero density.
    pub(super) fn mis_weight(
        &self,
        scene: &Scene,
        path: &[Vertex],
        technique: Technique,
        eta: Option<f64>,
    ) -> Option<(f64, f64)> {
        let k = path.len() - 1;
        let pl: Vec<f64> = (0..k).map(|i| pdf_light_side(scene, path, i) as f64).collect();
        let pe: Vec<f64> = (0..k).map(|i| pdf_eye_side(scene, path, i) as f64).collect();
        self.mis_weight_from(path, &pl, &pe, technique, eta)
    }

    /// [`Bdpt::mis_weight`] from the path's densities p_L(x_i) (`pl`) and p_E(x_i) (`pe`),
    /// i < k, however they were obtained.
    pub(super) fn mis_weight_from(
        &self,
        path: &[Vertex],
        pl: &[f64],
        pe: &[f64],
        technique: Technique,
        eta: Option<f64>,
    ) -> Option<(f64, f64)> {
        let k = path.len() - 1;
        if k > self.params.max_depth as usize + 1 {
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
        // Technique s' joins x_{s'−1} and x_{s'}: both must be non-specular (the pinhole and a
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

    /// Every technique of one pixel sample.
    fn sample(&self, scene: &Scene, raster: Vec2, rng: &mut Rng) -> Sample {
        let eye = self.eye_subpath(scene, raster, rng);
        let light = self.light_subpath(scene, rng);
        let caches = (
            &EyeCache::new(scene, &eye.vertices),
            &LightCache::new(scene, &light.vertices),
        );
        self.connect_all(scene, &eye, &light, caches, None, rng)
    }

    /// Every connection technique (s = 0, t = 1, s ≥ 1 with t ≥ 2) between one eye and one
    /// light sub-path, weighted with merging in the weights when `eta` is given (`vcm`).
    pub(super) fn connect_all(
        &self,
        scene: &Scene,
        eye: &SubPath,
        light: &SubPath,
        cache: (&EyeCache, &LightCache),
        eta: Option<f64>,
        rng: &mut Rng,
    ) -> Sample {
        let (z, y) = (&eye.vertices, &light.vertices);
        let mut out = Sample {
            own: Vec3::ZERO,
            splats: Vec::new(),
        };
        // s = 0: the eye walk hits a light at z_{t−1}.
        for t in 2..=z.len() {
            if let Some(x0) = z[t - 1].as_light(scene) {
                let mut path = vec![x0];
                path.extend(z[..t - 1].iter().rev());
                if let Some((v, _)) = self.weighted_cached(scene, &path, (0, t), cache, eta) {
                    out.own += v / eye.survival[t - 1] as f32;
                }
            }
        }
        for s in 1..=y.len() {
            // t = 1: y_{s−1} to the pinhole, splatted.
            if y[s - 1].can_end_connection() && camera_factor(scene, &y[s - 1]).is_some() {
                let path = join(&y[..s], &z[..1]);
                self.connections.fetch_add(1, Relaxed);
                if let Some((v, r)) = self.weighted_cached(scene, &path, (s, 1), cache, eta)
                    && visible(scene, &y[s - 1], &z[0])
                {
                    let v = v / light.survival[s - 1] as f32;
                    out.splats.extend(scene.camera.splat(r, rng).map(|(p, w)| (p, v * w)));
                    self.splats.fetch_add(1, Relaxed);
                }
            }
            // t ≥ 2: y_{s−1} to z_{t−1} (a surface: not the environment that ends an eye walk).
            for t in 2..=z.len() {
                if !(y[s - 1].can_end_connection() && z[t - 1].is_surface() && z[t - 1].can_end_connection()) {
                    continue;
                }
                let path = join(&y[..s], &z[..t]);
                self.connections.fetch_add(1, Relaxed);
                if let Some((v, _)) = self.weighted_cached(scene, &path, (s, t), cache, eta)
                    && visible(scene, &y[s - 1], &z[t - 1])
                {
                    out.own += v / (light.survival[s - 1] * eye.survival[t - 1]) as f32;
                }
            }
        }
        out
    }

    /// [`Bdpt::weighted`] for the path of technique (s, t) between the sub-paths `cache` was
    /// built from, evaluating only what the connection changes: at most three scattering and
    /// geometry factors next to the connecting edge and four densities (p_L of the two eye-side
    /// vertices nearest it, p_E of the two light-side ones); the rest comes from the cache.
    /// Technique (0, 2) and (1, 1), paths of one edge, are evaluated whole.
    fn weighted_cached(
        &self,
        scene: &Scene,
        path: &[Vertex],
        (s, t): (usize, usize),
        (eye, light): (&EyeCache, &LightCache),
        eta: Option<f64>,
    ) -> Option<(Vec3, Vec2)> {
        let k = path.len() - 1;
        if k < 2 {
            return self.weighted(scene, path, s, eta);
        }
        // f(X) = Le G(x₀, x₁) Π_{i=1}^{k−1} f_s(x_i) Π_{i=1}^{k−2} G(x_i, x_{i+1}) C(x_{k−1}).
        let (f, raster) = match (s, t) {
            (0, _) => (
                emitted_first_edge(scene, path) * scattering(scene, path, 1) * eye.f[t - 1],
                Vec2::ZERO,
            ),
            (_, 1) => {
                let (raster, c) = camera_factor(scene, &path[k - 1])?;
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
        let (ps, sum) = self.mis_weight_from(path, &pl, &pe, Technique::Connect(s), eta)?;
        let n = scene.camera.pixel_count() as f64;
        let value = f.as_dvec3() * (ps / (sum * n));
        (value.is_finite()).then(|| (value.as_vec3(), raster))
    }
}

/// p_L(x_i) and p_E(x_i), i < k, of `path`, made of the first `s` vertices of the light
/// sub-path behind `light` and the eye sub-path behind `eye` (x_i = z_{k−i} for i ≥ s): from the
/// caches, except the four densities the joining edge changes (p_L of x_s, x_{s+1}; p_E of
/// x_{s−1}, x_{s−2}; with s = 0 p_L of x₀, x₁ and p_E of x₀).
pub(super) fn cached_densities(
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
pub(super) struct LightCache {
    /// p_L(y_i), from y_{i−1} and y_{i−2} (i < L).
    pl: Vec<f64>,
    /// p_E(y_i) when y_{i+1} and y_{i+2} follow it (i + 2 < L).
    pe: Vec<f64>,
    /// Le G(y₀, y₁) Π_{i=1}^{s−2} f_s(y_i) G(y_i, y_{i+1}): the light prefix of a path with s
    /// light vertices, f_s at y_{s−1} excluded (index s ≥ 2).
    f: Vec<Vec3>,
}

impl LightCache {
    pub(super) fn new(scene: &Scene, y: &[Vertex]) -> Self {
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
    pub(super) fn alpha(&self, u: usize) -> Vec3 {
        let p: f64 = self.pl[..=u].iter().product();
        if !(p > 0.0 && p.is_finite()) {
            return Vec3::ZERO;
        }
        (self.f[u + 1].as_dvec3() / p).as_vec3()
    }
}

/// What no connection changes on an eye sub-path z of T vertices (z₀ the pinhole).
pub(super) struct EyeCache {
    /// p_E(z_j), from z_{j−1} and z_{j−2} (1 ≤ j < T; index 0 unused).
    pe: Vec<f64>,
    /// p_L(z_j) when z_{j+1} and z_{j+2} precede it on the light side (j + 2 < T).
    pl: Vec<f64>,
    /// C(z₁) Π_{j=1}^{t−2} f_s(z_j) G(z_{j+1}, z_j): the eye suffix of a path with t eye
    /// vertices, f_s at z_{t−1} excluded (index t ≥ 2).
    f: Vec<Vec3>,
}

impl EyeCache {
    pub(super) fn new(scene: &Scene, z: &[Vertex]) -> Self {
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
            f[2] = camera_factor(scene, &z[1]).map_or(Vec3::ZERO, |(_, c)| Vec3::splat(c));
            for j in 3..=t {
                f[j] =
                    f[j - 1] * scattering_at(scene, &z[j - 2], &z[j - 3], &z[j - 1]) * geometry(&z[j - 1], &z[j - 2]);
            }
        }
        Self { pe, pl, f }
    }

    /// α_E(t − 1) = f / p per pixel of the sub-path up to z_{t−1} (t ≥ 2): C(z₁) Π f_s G over N
    /// (`pixels`) times the densities of z₁ … z_{t−1} (`vcm`).
    pub(super) fn alpha(&self, t: usize, pixels: f64) -> Vec3 {
        let p: f64 = self.pe[1..t].iter().product::<f64>() * pixels;
        if !(p > 0.0 && p.is_finite()) {
            return Vec3::ZERO;
        }
        (self.f[t].as_dvec3() / p).as_vec3()
    }
}

/// One sample of every pixel: `sample(p)` for pixel p gives its own value and splats
/// anywhere. Pixels run in fixed chunks of [`CHUNK`] and splats are summed in chunk order, so
/// the image is bit-identical on any number of threads.
pub(super) fn pixel_pass(scene: &Scene, film: &mut Film, sample: impl Fn(usize) -> Sample + Sync) {
    let n = scene.camera.pixel_count();
    let width = scene.camera.width as usize;
    let chunks: Vec<(Vec<Vec3>, Splats)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let (mut own, mut splats) = (Vec::with_capacity(CHUNK), Vec::new());
            for p in c * CHUNK..((c + 1) * CHUNK).min(n) {
                let s = sample(p);
                own.push(s.own);
                splats.extend(s.splats);
            }
            (own, splats)
        })
        .collect();
    let mut image: Vec<DVec3> = Vec::with_capacity(n);
    let mut all_splats = Vec::new();
    for (own, splats) in chunks {
        image.extend(own.iter().map(|v| v.as_dvec3()));
        all_splats.extend(splats);
    }
    for (p, v) in all_splats {
        image[p as usize] += v.as_dvec3();
    }
    film.rows_mut().for_each(|(y, row)| {
        for (x, acc) in row.iter_mut().enumerate() {
            acc.add(image[y * width + x].as_vec3());
        }
    });
}

impl Strategy for Bdpt {
    fn handles_point_lights(&self) -> bool {
        true
    }

    fn handles_directional_lights(&self) -> bool {
        true
    }

    fn handles_environment(&self) -> bool {
        true
    }

    fn handles_mixed_delta(&self) -> bool {
        true
    }

    fn kind(&self) -> &'static str {
        Self::KIND
    }

    fn params(&self) -> Vec<(String, String)> {
        self.params.columns()
    }

    fn render_pass(&self, scene: &Scene, seed: u64, samples: Samples<u32>, film: &mut Film) {
        let n = scene.camera.pixel_count();
        for s in samples {
            pixel_pass(scene, film, |p| {
                let mut rng = Rng::for_task(seed, [stream::BDPT, p as u64, s as u64]);
                let raster = scene.camera.sample_raster(p, rng.uniform2());
                self.sample(scene, raster, &mut rng)
            });
            self.samples.fetch_add(n as u64, Relaxed);
        }
    }

    fn counters(&self) -> Vec<(String, f64)> {
        vec![
            ("pixel_samples".into(), self.samples.load(Relaxed) as f64),
            ("connections".into(), self.connections.load(Relaxed) as f64),
            ("splats".into(), self.splats.load(Relaxed) as f64),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::load_scene;

    /// Connections evaluated from the sub-path caches carry the weight and value that
    /// evaluating their whole path gives — f(X), every technique's density, the power
    /// heuristic — for every technique (s, t) of many sample pairs: specular chains
    /// (cornell-spheres), smooth plastic (a delta lobe beside a diffuse one: cornell-plastic),
    /// an environment map on rough conductors and textures (the material preview), point, spot
    /// and directional lights (the courtyard), Veach's glossy plates.
    #[test]
    fn cached_connections_weigh_as_whole_paths() {
        for file in [
            "scenes/cornell-spheres.toml",
            "scenes/cornell-plastic.toml",
            "scenes/mitsuba/matpreview-copper.xml",
            "scenes/mitsuba/delta-lights.xml",
            "scenes/mitsuba/veach-mis.xml",
        ] {
            let scene = load_scene(std::path::Path::new(file)).unwrap();
            let bdpt = Bdpt::new(BdptParams::default()).unwrap();
            let (mut compared, mut nonzero) = (0, 0);
            for i in 0..300u64 {
                let mut rng = Rng::for_task(3, [i, 0, 0]);
                let raster = scene
                    .camera
                    .sample_raster(i as usize % scene.camera.pixel_count(), rng.uniform2());
                let eye = bdpt.eye_subpath(&scene, raster, &mut rng);
                let light = bdpt.light_subpath(&scene, &mut rng);
                let (z, y) = (&eye.vertices, &light.vertices);
                let cache = (&EyeCache::new(&scene, z), &LightCache::new(&scene, y));
                let mut paths = Vec::new();
                for t in 2..=z.len() {
                    if let Some(x0) = z[t - 1].as_light(&scene) {
                        let mut path = vec![x0];
                        path.extend(z[..t - 1].iter().rev());
                        paths.push((path, 0, t));
                    }
                }
                for s in 1..=y.len() {
                    for t in 1..=z.len() {
                        if t == 1 || (z[t - 1].is_surface() && z[t - 1].can_end_connection()) {
                            paths.push((join(&y[..s], &z[..t]), s, t));
                        }
                    }
                }
                for eta in [None, Some(0.37)] {
                    for (path, s, t) in &paths {
                        let whole = bdpt.weighted(&scene, path, *s, eta);
                        let cached = bdpt.weighted_cached(&scene, path, (*s, *t), cache, eta);
                        let close =
                            |a: Vec3, b: Vec3| (a - b).abs().max_element() <= 2e-4 * a.abs().max_element().max(1e-30);
                        match (whole, cached) {
                            (Some((a, ra)), Some((b, rb))) => {
                                assert!(
                                    close(a, b),
                                    "{file}, sample {i}, (s, t) = ({s}, {t}): whole {a:?}, cached {b:?}"
                                );
                                if *t == 1 {
                                    assert_eq!(ra, rb, "{file}: raster of a light-tracing path");
                                }
                                nonzero += usize::from(a != Vec3::ZERO);
                            }
                            (None, None) => {}
                            (a, b) => panic!("{file}, sample {i}, (s, t) = ({s}, {t}): whole {a:?}, cached {b:?}"),
                        }
                        compared += 1;
                        // Vertex merging at x_s (vcm) weighs the same path from the same densities.
                        if let (Some(_), true) = (eta, *s >= 1 && *t >= 2) {
                            let whole = bdpt.mis_weight(&scene, path, Technique::Merge(*s), eta);
                            let (pl, pe) = cached_densities(&scene, path, *s, cache);
                            let cached = bdpt.mis_weight_from(path, &pl, &pe, Technique::Merge(*s), eta);
                            let w = |m: Option<(f64, f64)>| m.map(|(p, sum)| p * p / sum);
                            match (w(whole), w(cached)) {
                                (Some(a), Some(b)) => assert!(
                                    (a - b).abs() <= 2e-4 * a,
                                    "{file}, sample {i}, merge at x_{s}: {a} vs {b}"
                                ),
                                (None, None) => {}
                                (a, b) => panic!("{file}, sample {i}, merge at x_{s}: whole {a:?}, cached {b:?}"),
                            }
                        }
                    }
                }
            }
            assert!(
                compared > 1000 && nonzero > 200,
                "{file}: {compared} compared, {nonzero} non-zero"
            );
        }
    }
}
