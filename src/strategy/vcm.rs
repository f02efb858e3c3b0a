//! `kind = "vcm"`: vertex connection and merging [Georgiev, Křivánek, Davidovič & Slusallek
//! 2012; Hachisuka, Pantaleoni & Jensen 2012, unified path sampling]: bidirectional path
//! tracing whose techniques also include *merging* — a light sub-path vertex y_u found within
//! radius r of an eye sub-path vertex z_{t−1} joins the two as photon mapping does — all
//! weighted by one power heuristic.
//!
//! **A pass** (one sample per pixel, the `spp` unit) [Georgiev et al. 2012, §5]:
//! 1. N = (pixel count) light sub-paths are traced (`[VCM_LIGHT, s, j]`), as `bdpt` draws them;
//!    every non-specular vertex y_u (u ≥ 1) goes into a kd-tree with its photon flux
//!    α_L(u) = Le G Π f_s G / Π p_L (the light sub-path's f / p, divided by its roulette
//!    survival).
//! 2. Pixel j traces an eye sub-path (`[VCM_EYE, j, s]`) and is paired with light sub-path j
//!    for every connection technique of `bdpt` (s = 0, t = 1 splats, s ≥ 1 with t ≥ 2).
//! 3. At each non-specular eye vertex z_{t−1} (t ≥ 2) every stored y_u within r merges:
//!    α_E(t−1) f_s(y_{u−1} → z_{t−1} → z_{t−2}) α_L(u) / η with η = N π r², the photon
//!    density estimate with a disc kernel [Georgiev et al. 2012, eq. (10)].
//!
//! **Weights** [Georgiev et al. 2012, eqs. (12)–(13)]: over the connections s and the merges
//! at every non-specular interior vertex x_m of the path, p_VM,m = η p_L(x_m) p_m (x_m
//! sampled from both sides, accepted within the disc). **Decision: MIS by recomputation**, as in
//! `bdpt` ([`super::bdpt`]): the merged path is X = (y_0 … y_{u−1}, z_{t−1} … z_0), the light
//! prefix joined to the eye vertex it merged with, and its densities are recomputed from the
//! path-space functions; the weights of every technique of a path still sum to one.
//!
//! **Radius** [Georgiev et al. 2012, §5.1]: r_i = r₁ i^((α−1)/2) in pass i = 1, 2, …, with
//! r₁ = `radius_factor` × the radius of the scene's bounding sphere (SmallVCM's defaults 0.003
//! and α = 0.75). Each pass is an estimate at its own radius; the film averages them, so the
//! bias vanishes as passes grow (consistent) and any split into passes gives the same image.
//!
//! **Participating media** (modes `vcm` and `bpt`): the sub-paths walk through media as
//! `bdpt`'s do, each with its own hero channel, and a merge's estimate is the product of the two
//! sub-paths' spectral estimates as a connection's is ([`crate::path_space::bidirectional`],
//! "Media"). **Decision: merging happens at
//! surface vertices only**; vertices in media are connected, never merged (a volume would need
//! its own kernel — photon points or beams in 3-D, Křivánek et al. 2014's unified points, beams
//! and paths — not the disc of a surface), and the weights count merging only where it can
//! happen ([`crate::path_space::bidirectional::mis_weight_from`]), so they still sum to one. The
//! `ppm` mode refuses media: its eye path stops at the first non-specular vertex, which in a
//! medium could not merge.
//!
//! **Modes** (`mode`), as in the paper's comparisons: `"vcm"` both; `"bpt"` connections only —
//! `bdpt` with VCM's sample streams, the same estimator; `"ppm"` merging only, as SmallVCM's
//! PPM mode: the eye path stops at its first non-specular vertex and merges there, emitters
//! count when seen directly or through specular bounces, no weights.

use super::bdpt::{Bdpt, BdptParams, Sample, pixel_pass};
use super::{Declared, Strategy};
use crate::error::Result;
use crate::film::Film;
use crate::params::{Params, Range};
use crate::path_space::bidirectional::{EyeCache, LightCache, SubPath, Technique, cached_densities, mis_weight_from};
use crate::path_space::{emitted, scattering};
use crate::photon::{KdPoint, KdTree};
use crate::sampling::{Rng, stream};
use crate::scene::Scene;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::ops::Range as Samples;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

/// Pixels (and light sub-paths) per task: a fixed split, so that sums never depend on the
/// number of threads.
const CHUNK: usize = 256;

crate::declare_choice! {
    /// Which techniques run: connections and merging, connections only (BPT) or merging only
    /// (PPM).
    pub enum VcmMode { Vcm = "vcm", Bpt = "bpt", Ppm = "ppm" }
}

crate::declare_params! {
    /// Parameters of `kind = "vcm"`.
    pub struct VcmParams {
        /// Which techniques run ([`VcmMode`]).
        mode: VcmMode = VcmMode::Vcm;
        /// r₁ as a fraction of the radius of the scene's bounding sphere (SmallVCM: 0.003).
        radius_factor: f64 = 0.003, range Range::above_to(0.0, 1.0).of("a fraction");
        /// α of the radius reduction r_i = r₁ i^((α−1)/2) (SmallVCM: 0.75; 1 keeps r fixed).
        alpha: f64 = 0.75, range Range::above_to(0.0, 1.0).of("a fraction");
        /// Maximum number of scattering events of a path, as `path`'s `max_depth`.
        max_depth: u32 = 16, range Range::int(0, 1024);
        /// Russian roulette on each sub-path starts after this many scattering events.
        rr_depth: u32 = 3, range Range::int(0, 1024);
    }
}

/// A light sub-path vertex stored for merging.
#[derive(Clone, Copy, Debug)]
struct LightPoint {
    p: Vec3,
    /// α_L(u), divided by the roulette survival of the sub-path up to y_u and by the opacity
    /// of a masked surface there.
    alpha: Vec3,
    path: u32,
    /// u: the vertex index in its sub-path (≥ 1).
    vertex: u32,
}

impl KdPoint for LightPoint {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}

/// Vertex connection and merging.
pub struct Vcm {
    params: VcmParams,
    /// The sub-path sampler and the weights, shared with `bdpt`.
    bdpt: Bdpt,
    /// Radius of the scene's bounding sphere (set by `prepare`).
    scene_radius: f64,
    pixel_samples: AtomicU64,
    light_vertices: AtomicU64,
    merges: AtomicU64,
}

impl Declared for Vcm {
    const KIND: &'static str = "vcm";
    const SUMMARY: &'static str = "vertex connection and merging: BDPT and photon merging under one power heuristic (Georgiev et al. 2012; Hachisuka et al. 2012)";
    type Params = VcmParams;

    fn new(params: VcmParams) -> Result<Self> {
        let bdpt = <Bdpt as Declared>::new(BdptParams {
            max_depth: params.max_depth,
            rr_depth: params.rr_depth,
        })?;
        Ok(Self {
            params,
            bdpt,
            scene_radius: 1.0,
            pixel_samples: AtomicU64::new(0),
            light_vertices: AtomicU64::new(0),
            merges: AtomicU64::new(0),
        })
    }
}

/// Radius of a sphere around the bounding box of every primitive.
fn bounding_radius(scene: &Scene) -> f64 {
    let (lo, hi) = scene.bounds();
    let r = 0.5 * (hi - lo).length() as f64;
    if r.is_finite() && r > 0.0 { r } else { 1.0 }
}

/// One pass's light side: a sub-path per pixel, their caches and the kd-tree of their merging
/// vertices.
struct LightPass {
    paths: Vec<SubPath>,
    caches: Vec<LightCache>,
    points: KdTree<LightPoint>,
}

impl Vcm {
    /// r_i of pass `s` (0-based: i = s + 1).
    fn radius(&self, s: u32) -> f64 {
        let r1 = self.params.radius_factor * self.scene_radius;
        r1 * ((s + 1) as f64).powf(0.5 * (self.params.alpha - 1.0))
    }

    /// The light sub-paths of pass `s`, their caches (connections and photon fluxes α_L read
    /// them) and the kd-tree of their merging vertices.
    fn light_pass(&self, scene: &Scene, seed: u64, s: u32, merging: bool) -> LightPass {
        let n = scene.camera.pixel_count();
        let chunks: Vec<(Vec<SubPath>, Vec<LightCache>, Vec<LightPoint>)> = (0..n.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let (mut paths, mut caches, mut points) = (Vec::new(), Vec::new(), Vec::new());
                for j in c * CHUNK..((c + 1) * CHUNK).min(n) {
                    let mut rng = Rng::for_task(seed, [stream::VCM_LIGHT, s as u64, j as u64]);
                    let sub = self.bdpt.light_subpath(scene, &mut rng);
                    let cache = LightCache::new(scene, &sub.vertices);
                    if merging {
                        for (u, y_u) in sub.vertices.iter().enumerate().skip(1) {
                            if !(y_u.is_surface() && y_u.can_end_connection()) {
                                continue;
                            }
                            // Divided by the opacity too: y_u stands for all the light that
                            // arrives there, also what a mask lets through (as a photon does,
                            // `crate::photon::PhotonHit::power`).
                            let alpha = cache.alpha(u) / (sub.survival[u] as f32 * y_u.opacity(scene));
                            if alpha != Vec3::ZERO && alpha.is_finite() {
                                points.push(LightPoint {
                                    p: y_u.p,
                                    alpha,
                                    path: j as u32,
                                    vertex: u as u32,
                                });
                            }
                        }
                    }
                    caches.push(cache);
                    paths.push(sub);
                }
                (paths, caches, points)
            })
            .collect();
        let (mut paths, mut caches) = (Vec::with_capacity(n), Vec::with_capacity(n));
        let mut points = Vec::new();
        for (p, c, q) in chunks {
            paths.extend(p);
            caches.extend(c);
            points.extend(q);
        }
        self.light_vertices.fetch_add(points.len() as u64, Relaxed);
        LightPass {
            paths,
            caches,
            points: KdTree::build(points),
        }
    }

    /// What merging at eye vertex z_{t−1} adds (weighted unless `weights` is false).
    fn merge_at(
        &self,
        scene: &Scene,
        eye: &SubPath,
        t: usize,
        alpha_e: Vec3,
        (pass, r, eta): (&LightPass, f64, f64),
        weights: Option<&EyeCache>,
    ) -> DVec3 {
        let (lights, points) = (&pass.paths, &pass.points);
        let z = &eye.vertices;
        let media = !eye.media.is_empty();
        // The merge meets z_{t−1} with its non-delta lobe, whichever the eye walk took there.
        let x = z[t - 1].as_endpoint();
        let items = points.items();
        let mut sum = DVec3::ZERO;
        let mut found = 0u64;
        points.for_each_within(x.p, r as f32, |index, _| {
            let lp = &items[index as usize];
            let y = &lights[lp.path as usize].vertices;
            let u = lp.vertex as usize;
            // Same side of the surface: the photon arrived where the eye vertex looks from.
            if y[u].ng.dot(x.ng) <= 0.0 {
                return;
            }
            let f = scattering(scene, &[y[u - 1], x, z[t - 2]], 1);
            if f == Vec3::ZERO {
                return;
            }
            let w = if let Some(eye) = weights {
                let mut path = y[..u].to_vec();
                path.push(x);
                path.extend(z[..t - 1].iter().rev());
                let (pl, pe) = cached_densities(scene, &path, u, (eye, &pass.caches[lp.path as usize]));
                match mis_weight_from(&path, &pl, &pe, Technique::Merge(u), Some(eta), self.bdpt.max_edges()) {
                    Some((p, sum_sq)) => p * p / sum_sq,
                    None => return,
                }
            } else {
                1.0
            };
            found += 1;
            let mut value = alpha_e * f * lp.alpha;
            if media {
                value = eye
                    .flights(t - 1)
                    .estimate(lights[lp.path as usize].flights(u).estimate(value));
            }
            sum += value.as_dvec3() * (w / eta);
        });
        self.merges.fetch_add(found, Relaxed);
        sum
    }

    /// One pixel sample: `bdpt`'s connections with light sub-path `j` and merging (by mode).
    fn pixel(&self, scene: &Scene, eye: &SubPath, j: usize, merge: (&LightPass, f64, f64), rng: &mut Rng) -> Sample {
        let z = &eye.vertices;
        let eta = merge.2;
        match self.params.mode {
            VcmMode::Bpt => {
                let caches = (&EyeCache::new(scene, z), &merge.0.caches[j]);
                self.bdpt.connect_all(scene, eye, &merge.0.paths[j], caches, None, rng)
            }
            VcmMode::Vcm => {
                let eye_cache = EyeCache::new(scene, z);
                let caches = (&eye_cache, &merge.0.caches[j]);
                let mut sample = self
                    .bdpt
                    .connect_all(scene, eye, &merge.0.paths[j], caches, Some(eta), rng);
                let mut own = sample.own.as_dvec3();
                for t in 2..=z.len() {
                    if !(z[t - 1].is_surface() && z[t - 1].can_end_connection()) {
                        continue;
                    }
                    let alpha_e = eye_cache.alpha(t, scene.camera.pixel_count() as f64) / eye.survival[t - 1] as f32;
                    own += self.merge_at(scene, eye, t, alpha_e, merge, Some(&eye_cache));
                }
                sample.own = own.as_vec3();
                sample
            }
            VcmMode::Ppm => {
                let eye_cache = EyeCache::new(scene, z);
                let mut own = DVec3::ZERO;
                for t in 2..=z.len() {
                    let alpha_e = eye_cache.alpha(t, scene.camera.pixel_count() as f64) / eye.survival[t - 1] as f32;
                    if let Some(x0) = z[t - 1].as_light(scene) {
                        own += (alpha_e * emitted(scene, &[x0, z[t - 2]])).as_dvec3();
                    }
                    // Merging takes the non-delta part of z_{t−1}; where the walk went on
                    // through a delta lobe (a smooth plastic's coating), the part it carries is
                    // still to be collected further on.
                    if z[t - 1].is_surface() && z[t - 1].can_end_connection() {
                        own += self.merge_at(scene, eye, t, alpha_e, merge, None);
                        if !z[t - 1].delta {
                            break;
                        }
                    }
                }
                Sample {
                    own: own.as_vec3(),
                    splats: Vec::new(),
                }
            }
        }
    }
}

impl Strategy for Vcm {
    fn capabilities(&self) -> crate::strategy::Capabilities {
        crate::strategy::Capabilities {
            media: self.params.mode != VcmMode::Ppm,
            ..crate::strategy::Capabilities::ALL
        }
    }

    fn kind(&self) -> &'static str {
        Self::KIND
    }

    fn params(&self) -> Vec<(String, String)> {
        self.params.columns()
    }

    fn prepare(&mut self, scene: &Scene, _: u64) -> Result<Vec<super::Phase>> {
        self.scene_radius = bounding_radius(scene);
        Ok(Vec::new())
    }

    fn render_pass(&self, scene: &Scene, seed: u64, samples: Samples<u32>, film: &mut Film) {
        let n = scene.camera.pixel_count();
        let merging = self.params.mode != VcmMode::Bpt;
        for s in samples {
            let r = self.radius(s);
            let eta = std::f64::consts::PI * r * r * n as f64;
            let pass = self.light_pass(scene, seed, s, merging);
            let merge = (&pass, r, eta);
            pixel_pass(scene, film, |p| {
                let mut rng = Rng::for_task(seed, [stream::VCM_EYE, p as u64, s as u64]);
                let raster = scene.camera.sample_raster(p, rng.uniform2());
                let eye = self.bdpt.eye_subpath(scene, raster, &mut rng);
                self.pixel(scene, &eye, p, merge, &mut rng)
            });
            self.pixel_samples.fetch_add(n as u64, Relaxed);
        }
    }

    fn counters(&self) -> Vec<(String, f64)> {
        let mut out = vec![
            ("pixel_samples".into(), self.pixel_samples.load(Relaxed) as f64),
            ("light_vertices".into(), self.light_vertices.load(Relaxed) as f64),
            ("merges".into(), self.merges.load(Relaxed) as f64),
        ];
        out.extend(
            self.bdpt
                .counters()
                .into_iter()
                .filter(|(name, _)| name != "pixel_samples"),
        );
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path_space::{Vertex, camera_factor, geometry, light_throughput, pdf_eye_side, pdf_light_side};
    use crate::photon::test_scenes::emitting_box;

    /// α_E(t−1) of eye sub-path `z` (z₀ the eye vertex) from the whole path, the reference for
    /// [`EyeCache::alpha`]: its f / p per pixel up to z_{t−1}, C(z₁) Π f_s G / (N Π p_E).
    fn eye_alpha(scene: &Scene, z: &[Vertex], t: usize) -> Vec3 {
        let rev: Vec<Vertex> = z[..t].iter().rev().copied().collect();
        let k = t - 1;
        let Some((_, c)) = camera_factor(scene, &rev[k - 1], &rev[k]) else {
            return Vec3::ZERO;
        };
        let mut f = Vec3::splat(c);
        for i in 1..k {
            f *= scattering(scene, &rev, i) * geometry(&rev[i - 1], &rev[i]);
        }
        let n = scene.camera.pixel_count() as f64;
        let p: f64 = (0..k).map(|i| pdf_eye_side(scene, &rev, i) as f64).product::<f64>() * n;
        if !(p > 0.0 && p.is_finite()) {
            return Vec3::ZERO;
        }
        (f.as_dvec3() / p).as_vec3()
    }

    /// α_L(u) of light sub-path `y` (u ≥ 1) from the whole path, the reference for
    /// [`LightCache::alpha`]: its f / p up to y_u in area measure, the photon's flux.
    fn light_alpha(scene: &Scene, y: &[Vertex], u: usize) -> Vec3 {
        let prefix = &y[..=u];
        let p: f64 = (0..=u).map(|i| pdf_light_side(scene, prefix, i) as f64).product();
        if !(p > 0.0 && p.is_finite()) {
            return Vec3::ZERO;
        }
        (light_throughput(scene, prefix, u).as_dvec3() / p).as_vec3()
    }

    /// Photon flux α_L and eye weight α_E from the sub-path caches equal their whole-path
    /// evaluation, on specular chains (cornell-spheres) and under an environment map.
    #[test]
    fn cached_alphas_equal_whole_path_alphas() {
        use crate::path_space::bidirectional::{EyeCache, LightCache};
        for file in ["scenes/cornell-spheres.toml", "scenes/mitsuba/matpreview-copper.xml"] {
            let scene = crate::scene::load_scene(std::path::Path::new(file)).unwrap();
            let vcm = <Vcm as Declared>::new(VcmParams::default()).unwrap();
            let pixels = scene.camera.pixel_count() as f64;
            let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() <= 1e-4 * a.abs().max_element().max(1e-30);
            let mut compared = 0;
            for i in 0..300u64 {
                let mut rng = Rng::for_task(4, [i, 0, 0]);
                let raster = scene.camera.sample_raster(i as usize, rng.uniform2());
                let z = vcm.bdpt.eye_subpath(&scene, raster, &mut rng).vertices;
                let y = vcm.bdpt.light_subpath(&scene, &mut rng).vertices;
                let (eye, light) = (EyeCache::new(&scene, &z), LightCache::new(&scene, &y));
                for u in 1..y.len() {
                    let (a, b) = (light_alpha(&scene, &y, u), light.alpha(u));
                    assert!(close(a, b), "{file}, sample {i}, α_L({u}): {a:?} vs {b:?}");
                    compared += usize::from(a != Vec3::ZERO);
                }
                for t in 2..=z.len() {
                    let (a, b) = (eye_alpha(&scene, &z, t), eye.alpha(t, pixels));
                    assert!(close(a, b), "{file}, sample {i}, α_E({t}): {a:?} vs {b:?}");
                    compared += usize::from(a != Vec3::ZERO);
                }
            }
            assert!(compared > 500, "{file}: {compared} non-zero alphas compared");
        }
    }

    /// Mean luminance over 6 seeds of 12 passes, and its standard error.
    fn furnace_mean(scene: &Scene, params: &str) -> (f64, f64) {
        let means: Vec<f64> = (0..6)
            .map(|seed| {
                let mut s = crate::strategy::build("vcm", toml::from_str(params).unwrap()).unwrap();
                s.prepare(scene, seed).unwrap();
                let mut film = Film::new(scene.camera.width, scene.camera.height);
                s.render_pass(scene, seed, 0..12, &mut film);
                crate::color::luminance(film.image().mean()) as f64
            })
            .collect();
        let n = means.len() as f64;
        let mean = means.iter().sum::<f64>() / n;
        let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, (var / n).sqrt())
    }

    /// In the emitting furnace (radiance Le / (1 − ρ) everywhere) every mode reaches the exact
    /// value within 5 standard errors, the standard error below 1.5 %: merging alone checks
    /// the photon flux α_L, the eye weight α_E and the kernel 1 / (N π r²); `vcm` checks that
    /// the weights of connections and merges sum to one.
    #[test]
    fn every_mode_converges_in_the_emitting_furnace() {
        let scene = emitting_box(0.5, false);
        let exact = 2.0;
        for params in ["mode = \"ppm\"\nradius_factor = 0.02", "", "mode = \"bpt\""] {
            let (mean, se) = furnace_mean(&scene, params);
            let z = (mean - exact) / se;
            assert!(se < 0.015 * exact, "[{params}]: standard error {se}");
            assert!(z.abs() < 5.0, "[{params}]: {mean} vs {exact} (z = {z:.2})");
        }
    }

    #[test]
    fn the_radius_shrinks_as_the_paper_says() {
        let mut v =
            <Vcm as Declared>::new(VcmParams::from_table(toml::from_str("alpha = 0.5").unwrap()).unwrap()).unwrap();
        v.scene_radius = 2.0;
        let r1 = 0.003 * 2.0;
        assert!((v.radius(0) - r1).abs() < 1e-12);
        // r_i = r₁ i^((α−1)/2): i = 16, α = ½ → r₁ / 2.
        assert!((v.radius(15) - r1 / 2.0).abs() < 1e-12);
    }

    #[test]
    fn hostile_parameters_are_refused() {
        for text in [
            "mode = \"sppm\"",
            "radius_factor = 0.0",
            "alpha = 1.5",
            "alpha = -0.1",
            "max_depth = -1",
        ] {
            assert!(
                crate::strategy::build("vcm", toml::from_str(text).unwrap()).is_err(),
                "`{text}`"
            );
        }
    }
}
