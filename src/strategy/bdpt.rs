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
//! **Participating media**: in a scene with media both sub-paths walk through them (free
//! flights, vertices at collisions in media, a hero channel per sub-path) and every connection
//! carries the transmittance of its edge; the MIS weights use pbrt-v3's pseudo-densities, which
//! leave out the free flights' probabilities ([`crate::path_space::bidirectional`], "Media").
//!
//! **Russian roulette** on each sub-path after `rr_depth` scattering events, with the
//! survival probability of the throughput relative to the sub-path's first (eye: the camera
//! ray's weight 1; light: the emitted flux), at most 0.95; contributions divide by the
//! survival probabilities of the vertices they use, the weights ignore them (they still sum to
//! one, so the estimator stays unbiased, as in pbrt).
//!
//! **MIS with cached sub-path factors** ([`crate::path_space::bidirectional`], shared with
//! `vcm` and with the Metropolis strategies' estimate of B in scenes with point, spot or
//! directional lights). The densities and f come from the path-space functions the Metropolis
//! strategies test. Each sub-path first caches what no connection changes ([`LightCache`],
//! [`EyeCache`]): every vertex's density from its own side and from
//! the other side where its two neighbours are its own, and the throughput products f_s G of
//! its prefix; a connection (or a `vcm` merge) then evaluates only the two scattering factors
//! and the geometry term of the connecting edge and the four densities next to it (pbrt-v3's
//! `MISWeight` caches the same forward and reverse densities), instead of all 2k densities and
//! k factors of its path (the earlier "MIS by recomputation", kept as
//! [`bidirectional::mis_weight`] and [`bidirectional::weighted_whole`]: the reference a unit
//! test holds every technique to, within 2·10⁻⁴, and the route of one-edge paths). Measured
//! side by side with the build before it (perf-suite cases `cornell-box` 64 × 64 and
//! `cornell-spheres` 32 × 32 at 16 spp, two alternating runs of 5 rounds, 2 threads): `bdpt`
//! 1.10–1.13×, `vcm` 1.08–1.19× pixel samples/s (`path`, untouched, 1.01×); on `cornell-empty`
//! no gain. The rest is the technique's own cost: its rays (a shadow ray per connection) and
//! per-connection allocations.

use super::{Declared, Strategy};
use crate::error::Result;
use crate::film::Film;
use crate::params::{Params, Range};
use crate::path_space::bidirectional::{self, EyeCache, LightCache, Roulette, SubPath};
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

/// Contributions to other pixels: (pixel index, value).
pub(super) type Splats = Vec<(u32, Vec3)>;

/// What one pixel sample adds: to its own pixel, and splats anywhere.
pub(super) struct Sample {
    pub(super) own: Vec3,
    pub(super) splats: Splats,
}

impl Bdpt {
    /// The eye sub-path through `raster` ([`bidirectional::eye_subpath`]; through media in a
    /// scene with media, [`bidirectional::eye_subpath_in_media`]).
    pub(super) fn eye_subpath(&self, scene: &Scene, raster: Vec2, rng: &mut Rng) -> SubPath {
        match scene.media.is_empty() {
            true => bidirectional::eye_subpath(scene, raster, self.roulette(), rng),
            false => bidirectional::eye_subpath_in_media(scene, raster, self.roulette(), rng),
        }
    }

    /// The light sub-path ([`bidirectional::light_subpath`]; through media in a scene with
    /// media, [`bidirectional::light_subpath_in_media`]).
    pub(super) fn light_subpath(&self, scene: &Scene, rng: &mut Rng) -> SubPath {
        match scene.media.is_empty() {
            true => bidirectional::light_subpath(scene, self.roulette(), rng),
            false => bidirectional::light_subpath_in_media(scene, self.roulette(), rng),
        }
    }

    fn roulette(&self) -> Roulette {
        Roulette {
            max_depth: self.params.max_depth as usize,
            rr_depth: self.params.rr_depth as usize,
        }
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

    /// Every connection technique between one eye and one light sub-path
    /// ([`bidirectional::connect_all`]), weighted with merging in the weights when `eta` is
    /// given (`vcm`): what lands on the pixel of the eye sub-path, and the splats of t = 1.
    pub(super) fn connect_all(
        &self,
        scene: &Scene,
        eye: &SubPath,
        light: &SubPath,
        caches: (&EyeCache, &LightCache),
        eta: Option<f64>,
        rng: &mut Rng,
    ) -> Sample {
        let mut out = Sample {
            own: Vec3::ZERO,
            splats: Vec::new(),
        };
        let n = scene.camera.pixel_count() as f32;
        let tried = bidirectional::connect_all(
            scene,
            (eye, light),
            caches,
            eta,
            self.max_edges(),
            rng,
            &mut |c, rng| {
                let v = c.value / n;
                match c.raster {
                    Some(r) => {
                        out.splats.extend(scene.camera.splat(r, rng).map(|(p, w)| (p, v * w)));
                        self.splats.fetch_add(1, Relaxed);
                    }
                    None => out.own += v,
                }
            },
        );
        self.connections.fetch_add(tried, Relaxed);
        out
    }

    /// Largest number of edges of a path: `max_depth` + 1.
    pub(super) fn max_edges(&self) -> usize {
        self.params.max_depth as usize + 1
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
    fn capabilities(&self) -> crate::strategy::Capabilities {
        crate::strategy::Capabilities {
            media: true,
            ..crate::strategy::Capabilities::ALL
        }
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
    use crate::path_space::VertexKind;
    use crate::path_space::bidirectional::{Technique, mis_weight_from};
    use crate::path_space::walk::join;
    use crate::scene::load_scene;

    /// Connections evaluated from the sub-path caches carry the weight and value that
    /// evaluating their whole path gives — f(X), every technique's density, the power
    /// heuristic — for every technique (s, t) of many sample pairs: specular chains
    /// (cornell-spheres), smooth plastic (a delta lobe beside a diffuse one: cornell-plastic),
    /// an environment map on rough conductors and textures (the material preview), point, spot
    /// and directional lights (the courtyard), Veach's glossy plates, and vertices in media
    /// (homogeneous fog and milk behind glass, heterogeneous smoke).
    #[test]
    fn cached_connections_weigh_as_whole_paths() {
        for file in [
            "scenes/cornell-spheres.toml",
            "scenes/cornell-plastic.toml",
            "scenes/mitsuba/matpreview-copper.xml",
            "scenes/mitsuba/delta-lights.xml",
            "scenes/mitsuba/veach-mis.xml",
            "scenes/mitsuba/fog.xml",
            "scenes/mitsuba/smoke.xml",
        ] {
            let scene = load_scene(std::path::Path::new(file)).unwrap();
            let bdpt = Bdpt::new(BdptParams::default()).unwrap();
            let (mut compared, mut nonzero, mut in_media) = (0, 0, 0);
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
                        if t == 1 || (z[t - 1].scatters() && z[t - 1].can_end_connection()) {
                            paths.push((join(&y[..s], &z[..t]), s, t));
                        }
                    }
                }
                for eta in [None, Some(0.37)] {
                    for (path, s, t) in &paths {
                        let max_edges = bdpt.max_edges();
                        let whole = bidirectional::weighted_whole(&scene, path, *s, eta, max_edges);
                        let cached = bidirectional::weighted_cached(&scene, path, (*s, *t), cache, eta, max_edges);
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
                                in_media += usize::from(path.iter().any(|v| matches!(v.kind, VertexKind::Medium(_))));
                            }
                            (None, None) => {}
                            (a, b) => panic!("{file}, sample {i}, (s, t) = ({s}, {t}): whole {a:?}, cached {b:?}"),
                        }
                        compared += 1;
                        // Vertex merging at x_s (vcm) weighs the same path from the same densities.
                        if let (Some(_), true) = (eta, *s >= 1 && *t >= 2) {
                            let whole =
                                bidirectional::mis_weight(&scene, path, Technique::Merge(*s), eta, bdpt.max_edges());
                            let (pl, pe) = bidirectional::cached_densities(&scene, path, *s, cache);
                            let cached = mis_weight_from(path, &pl, &pe, Technique::Merge(*s), eta, bdpt.max_edges());
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
            assert!(
                scene.media.is_empty() || in_media > 30,
                "{file}: {in_media} non-zero paths with a vertex in a medium"
            );
        }
    }
}
