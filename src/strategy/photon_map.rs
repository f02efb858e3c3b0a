//! `kind = "photon_map"`: photon mapping with final gathering [Jensen 1996; Christensen 1999],
//! optionally reading Christensen's precomputed irradiance at the final-gather hits.
//!
//! Preparation traces photon paths from the lights into a global map (direct, indirect and
//! caustic photons: [`CausticStorage::Both`]) and a caustic map (L S+ D), and builds both
//! kd-trees (phases `photon_trace`, `kdtree_build`; with precomputed irradiance also
//! `irradiance_precompute`).
//!
//! Rendering: one camera path per sample follows delta (mirror, glass) surfaces, sampling the
//! delta BSDF, and adds emission seen directly or through specular chains. At the first
//! non-delta hit x, L(x) = Le(x) + direct (light sampling, no MIS) + caustics (caustic-map
//! radiance estimate with the BSDF at x) + indirect (final gather). The final gather shoots G
//! rays, sampled from the BSDF at x and weighted f cos / pdf (for Lambertian surfaces that is
//! cosine-distributed rays weighted ρ); the G samples are Latin-hypercube stratified over the
//! BSDF's 2-D sample domain (every ray remains marginally distributed as the BSDF sample, so
//! the gather stays an unbiased estimate of the map's radiance). A gather ray that escapes,
//! or finds an emitter, contributes nothing (emission at y is direct light at x, already
//! counted by light sampling). A gather ray that hits a delta surface follows it (up to
//! `max_depth` bounces) to the next non-delta hit y, where the outgoing radiance is:
//! - if the path length from x to y is below `short_gather`: a *secondary gather* at y
//!   (`secondary_gather_rays` rays with map lookups at their hits, plus light sampling and the
//!   caustic estimate at y): the photon-map estimate blurs over a disc of radius ≈
//!   `max_radius`, visible as light leaks and blotches when seen from closer than a few radii
//!   (corners);
//! - otherwise the global map's radiance estimate with the BSDF at y, or, with precomputed
//!   irradiance and a Lambertian y, ρ/π times the precomputed irradiance of the nearest photon
//!   with a similar normal [Christensen 1999, §3.1].
//!
//! Estimates are taken on the side of the surface that the ray sees (photons are stored with
//! the normal of the side they arrived on); transmitting BSDFs add the estimate of the other side.
//!
//! Parameters (all optional):
//! - `photons` (200 000): photon paths *emitted* (Christensen 1999 emits 220 000 in the
//!   Cornell box).
//! - `nearest` (50): photons per global-map estimate (also for the precomputation).
//! - `caustic_nearest` (50): photons per caustic-map estimate.
//! - `max_radius` (5 % of the diagonal of the scene's bounding box): search radius bound of
//!   every estimate (and of the precomputed-irradiance lookups).
//! - `gather_rays` (64): G, final-gather rays at x.
//! - `secondary_gather_rays` (12): rays of a secondary gather; 0 disables secondary gathers.
//! - `short_gather` (2 × `max_radius`): distance below which a gather hit is shaded by a
//!   secondary gather. **Decision**: twice the estimate's radius bound — the disc a lookup
//!   averages over is then at most half the distance it is seen from. 0 disables.
//! - `max_depth` (16): delta bounces followed by camera paths and by gather rays.
//! - `precomputed_irradiance` (absent): `{ every = k, normal_dot = d }` precomputes the
//!   irradiance at every k-th photon (default 4) and looks it up for Lambertian gather hits with
//!   normal agreement n_p · n > d (default 0.9) [Christensen 1999]; absent means full density
//!   estimates at every gather hit.
//! - `irradiance_cache` (absent): `{ error = a, min_distance, max_distance, gather_rays,
//!   gradients }`
//!   caches the indirect irradiance of Lambertian surfaces seen from the camera [Ward,
//!   Rubinstein & Clear 1988] ([`crate::photon::irradiance_cache`]): a = `error` (default 0.2);
//!   each record's harmonic mean distance R is clamped to [`min_distance`, `max_distance`]
//!   (defaults 2 % and 50 % of the scene's bounding-box diagonal); a record gathers with
//!   `gather_rays` rays (default 256: records are few, and a noisy record shows as a blotch
//!   over its whole valid region); `gradients = true` (default false) stratifies each record's
//!   gather in M × N polar strata (M ≈ √(G/π), N = G/M) and stores Ward & Heckbert's 1992
//!   rotational and translational irradiance gradients, which the interpolation then uses.
//!   Absent means a final gather at every camera sample.
//! - `light_selection` (`"power"`), `sphere_light_sampling` (`"area"`): the light sampling of
//!   the direct term (at x and at secondary gathers), as for `path` ([`LightSelection`],
//!   [`SphereSampling`]).
//!
//! **Decision: a deterministic pre-pass fills the irradiance cache.** Ward fills the cache
//! lazily while rendering; filled by parallel threads in a timing-dependent order, the records
//! (and so the image) would depend on the thread count. Instead `prepare` runs an overture
//! (phase `irradiance_cache`) over the pixel centres in rounds, coarse to fine: the pixels of a
//! 16-pixel grid, then those of the 8-, 4-, 2- and 1-pixel grids not already on a coarser one,
//! each grid in three sub-rounds (odd columns, odd rows, both) so that neighbours of one round
//! are at least two grid steps apart. In a round, every pixel's camera ray (pixel centre, its
//! own random stream through delta surfaces) that reaches a Lambertian surface where the cache
//! (as it was at the round's start) has no valid record computes a record, in parallel; the new
//! records are added in pixel order and the index rebuilt. The records therefore depend on the
//! seed only. Rendering then reads the cache: at a camera path's first Lambertian hit, ρ/π times
//! the interpolated irradiance replaces the final gather; where no record is valid (a sub-pixel
//! position or a specular path the overture did not take) a full final gather is done, uncached
//! (`cache_misses`). A record's gather is the final gather's (its own `gather_rays`
//! cosine-distributed rays, secondary gathers for short ones), E = π/G Σ L_j.

use super::Declared;
use super::path::{BsdfSampling, Direct, estimate_direct, receiver};
use super::{Figure, Phase, Strategy, render_pixels};
use crate::bsdf::{Bsdf, TransportMode};
use crate::error::Result;
use crate::figure::{FigureImage, GATHER_SEES_PNG, IRRADIANCE_PNG, PRECOMPUTED_PNG};
use crate::film::{Film, Image};
use crate::geometry::{Ray, spawn_ray};
use crate::light::{LightSampling, LightSelection, SphereSampling};
use crate::params::{Params, Range};
use crate::photon::irradiance_cache::{CacheRecord, Gradients, IrradianceCache, PolarStrata, gradients};
use crate::photon::picture::{self, visible_pixels};
use crate::photon::{
    CausticStorage, EstimateParams, IrradianceMap, Photon, PhotonMap, TraceParams, precompute_irradiance, trace_photons,
};
use crate::resources;
use crate::sampling::{Rng, latin_hypercube, sample_cosine_hemisphere, stream};
use crate::scene::{Scene, SurfaceHit};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::f32::consts::{FRAC_1_PI, PI};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

crate::declare_params! {
    /// Precomputed irradiance [Christensen 1999, §2.2] (`photon_map`) or pdfs (`photon_guided`)
    /// at every k-th photon.
    pub struct Precomputed {
        /// k: every k-th photon of the global map holds a precomputed value.
        every: usize = 4, range Range::int(1, 1_000_000);
        /// A lookup uses the nearest holder whose normal n_p has n_p · n > this.
        normal_dot: f32 = 0.9, range Range::closed(-1.0, 1.0).of("a cosine");
    }
}

crate::declare_params! {
    /// Ward's irradiance cache at the camera's first Lambertian hits [Ward 1988].
    pub struct IrradianceCaching {
        /// Ward's a: records with weight w > 1/a are interpolated.
        error: f32 = 0.2, range Range::above_to(0.0, 10.0).of("Ward's a");
        /// Lower clamp of a record's harmonic mean distance R (absent: 2 % of the diagonal).
        min_distance: Option<f32> = None, range Range::positive().of("a distance");
        /// Upper clamp of R (absent: 50 % of the diagonal).
        max_distance: Option<f32> = None, range Range::positive().of("a distance");
        /// Final-gather rays of a record: records are few, and one noisy record shows as a
        /// blotch over its whole valid region.
        gather_rays: u32 = 256, range Range::int(1, 65_536);
        /// Estimate and interpolate with irradiance gradients [Ward & Heckbert 1992] (false:
        /// Ward 1988's plain weighted average).
        gradients: bool = false;
    }
    check IrradianceCaching::rules;
}

impl IrradianceCaching {
    /// min_distance ≤ max_distance.
    fn rules(&self) -> Result<()> {
        if let (Some(lo), Some(hi)) = (self.min_distance, self.max_distance)
            && lo > hi
        {
            crate::bail!("min_distance: expected at most max_distance ({hi}), got {lo}");
        }
        Ok(())
    }
}

crate::declare_params! {
    /// Parameters of `kind = "photon_map"`.
    pub struct PhotonMapParams {
        /// Photon paths emitted from the lights [Jensen 1996].
        photons: u64 = 200_000, range Range::int(1, 100_000_000);
        /// N, photons per global-map radiance estimate.
        nearest: usize = 50, range Range::int(1, 10_000);
        /// Photons per caustic-map radiance estimate.
        caustic_nearest: usize = 50, range Range::int(1, 10_000);
        /// Search radius bound of every estimate (absent: 5 % of the scene's diagonal).
        max_radius: Option<f32> = None, range Range::positive().of("a distance");
        /// Final-gather rays per camera-path hit [Christensen 1999, §2.3].
        gather_rays: u32 = 64, range Range::int(1, 65_536);
        /// Rays of a secondary gather where a gather ray lands too close (0: none).
        secondary_gather_rays: u32 = 12, range Range::int(0, 65_536);
        /// Gather rays shorter than this distance gather again instead of reading the map
        /// (absent: no secondary gathers by distance).
        short_gather: Option<f32> = None, range Range::at_least(0.0).of("a distance");
        /// Maximum scattering events of camera paths through delta surfaces and of photon paths.
        max_depth: u32 = 16, range Range::int(0, 1024);
        /// Irradiance precomputed at every k-th photon [Christensen 1999] (absent: full
        /// radiance estimates).
        precomputed_irradiance: Option<Precomputed> = None;
        /// Ward's irradiance cache at the first Lambertian hits (absent: a final gather at
        /// every hit).
        irradiance_cache: Option<IrradianceCaching> = None;
        /// How the direct term picks a light (as `path`).
        light_selection: LightSelection = LightSelection::Power;
        /// How the direct term samples sphere lights (as `path`).
        sphere_light_sampling: SphereSampling = SphereSampling::Area;
    }
}

impl PhotonMapParams {
    /// The light sampling options of the direct term.
    pub fn light_sampling(&self) -> LightSampling {
        LightSampling {
            selection: self.light_selection,
            sphere: self.sphere_light_sampling,
        }
    }
}

/// Work counted while rendering (cumulative since `prepare`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PhotonMapCounters {
    /// Final-gather rays, primary and secondary.
    pub gather_rays: u64,
    /// Secondary gathers started.
    pub secondary_gathers: u64,
    /// Global-map density estimates (full N-nearest radiance estimates).
    pub map_estimates: u64,
    /// Precomputed-irradiance lookups.
    pub irradiance_lookups: u64,
    /// Caustic-map radiance estimates.
    pub caustic_estimates: u64,
    /// Final gathers at camera-path hits (each of `gather_rays` rays), the irradiance cache's
    /// records included.
    pub final_gathers: u64,
    /// Camera-path hits shaded from the irradiance cache.
    pub cache_lookups: u64,
    /// Camera-path Lambertian hits where the cache had no valid record (full final gather).
    pub cache_misses: u64,
}

#[derive(Default)]
struct AtomicCounters([AtomicU64; 8]);

impl AtomicCounters {
    fn add(&self, c: &PhotonMapCounters) {
        let v = [
            c.gather_rays,
            c.secondary_gathers,
            c.map_estimates,
            c.irradiance_lookups,
            c.caustic_estimates,
            c.final_gathers,
            c.cache_lookups,
            c.cache_misses,
        ];
        for (a, x) in self.0.iter().zip(v) {
            if x != 0 {
                a.fetch_add(x, Ordering::Relaxed);
            }
        }
    }

    fn get(&self) -> PhotonMapCounters {
        let v = |i: usize| self.0[i].load(Ordering::Relaxed);
        PhotonMapCounters {
            gather_rays: v(0),
            secondary_gathers: v(1),
            map_estimates: v(2),
            irradiance_lookups: v(3),
            caustic_estimates: v(4),
            final_gathers: v(5),
            cache_lookups: v(6),
            cache_misses: v(7),
        }
    }

    fn reset(&self) {
        for a in &self.0 {
            a.store(0, Ordering::Relaxed);
        }
    }
}

/// What `prepare` builds.
struct Maps {
    global: PhotonMap,
    caustic: PhotonMap,
    irradiance: Option<IrradianceMap>,
    cache: Option<IrradianceCache>,
    estimate: EstimateParams,
    caustic_estimate: EstimateParams,
    short_gather: f32,
}

/// The photon-mapping strategy.
pub struct PhotonMapStrategy {
    pub params: PhotonMapParams,
    maps: Option<Maps>,
    counters: AtomicCounters,
}

/// Diagonal of the bounding box of the scene's primitives.
pub fn scene_diagonal(scene: &Scene) -> f32 {
    let (lo, hi) = scene.primitives.iter().map(|p| p.aabb_min_max()).fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(a, b), (lo, hi)| (a.min(lo), b.max(hi)),
    );
    if lo.x <= hi.x { (hi - lo).length() } else { 0.0 }
}

impl PhotonMapStrategy {
    pub fn new(params: PhotonMapParams) -> Result<Self> {
        params.check("")?;
        Ok(Self {
            params,
            maps: None,
            counters: AtomicCounters::default(),
        })
    }

    /// Work counted by the renders since the last `prepare`.
    pub fn work(&self) -> PhotonMapCounters {
        self.counters.get()
    }

    /// The search radius bound of every estimate in `scene`: `max_radius`, or 5 % of the
    /// diagonal of the scene's bounding box.
    pub fn max_radius(&self, scene: &Scene) -> f32 {
        self.params
            .max_radius
            .unwrap_or(0.05 * scene_diagonal(scene))
            .max(f32::MIN_POSITIVE)
    }

    /// The global map's photons (position, normal), for the photon distribution figure; empty
    /// before `prepare`.
    pub fn photons(&self) -> Vec<(Vec3, Vec3)> {
        self.maps.as_ref().map_or_else(Vec::new, |m| {
            m.global.photons().iter().map(|p| (p.position(), p.normal())).collect()
        })
    }

    /// Photons in the global and caustic maps (0, 0 before `prepare`).
    pub fn map_sizes(&self) -> (usize, usize) {
        self.maps.as_ref().map_or((0, 0), |m| (m.global.len(), m.caustic.len()))
    }
}

impl Declared for PhotonMapStrategy {
    const KIND: &'static str = "photon_map";
    const SUMMARY: &'static str = "photon mapping with final gathering, optional precomputed irradiance or irradiance caching (Jensen 1996; Christensen 1999; Ward 1988)";
    type Params = PhotonMapParams;

    fn new(params: PhotonMapParams) -> Result<Self> {
        Self::new(params)
    }
}

impl Strategy for PhotonMapStrategy {
    fn kind(&self) -> &'static str {
        Self::KIND
    }

    fn params(&self) -> Vec<(String, String)> {
        self.params.columns()
    }

    /// Work since `prepare` ([`PhotonMapCounters`]), then what `prepare` built: photons in the
    /// global, caustic and precomputed-irradiance maps, the bytes of one photon record, and the
    /// bytes held by all maps (records and kd-tree axes; the irradiance map's records are
    /// copies of every k-th global photon).
    fn counters(&self) -> Vec<(String, f64)> {
        let w = self.work();
        let mut out: Vec<(&str, f64)> = vec![
            ("gather_rays", w.gather_rays as f64),
            ("secondary_gathers", w.secondary_gathers as f64),
            ("map_estimates", w.map_estimates as f64),
            ("irradiance_lookups", w.irradiance_lookups as f64),
            ("caustic_estimates", w.caustic_estimates as f64),
            ("final_gathers", w.final_gathers as f64),
        ];
        if self.params.irradiance_cache.is_some() {
            let records = self.maps.as_ref().and_then(|m| m.cache.as_ref()).map_or(0, |c| c.len());
            out.extend([
                ("cache_records", records as f64),
                ("cache_lookups", w.cache_lookups as f64),
                ("cache_misses", w.cache_misses as f64),
            ]);
        }
        if let Some(m) = &self.maps {
            let irradiance = m.irradiance.as_ref();
            out.extend([
                ("global_photons", m.global.len() as f64),
                ("caustic_photons", m.caustic.len() as f64),
                ("irradiance_photons", irradiance.map_or(0, |i| i.len()) as f64),
                ("bytes_per_photon", Photon::BYTES as f64),
                (
                    "photon_map_bytes",
                    (m.global.bytes() + m.caustic.bytes() + irradiance.map_or(0, |i| i.bytes())) as f64,
                ),
            ]);
        }
        out.into_iter().map(|(n, v)| (n.to_string(), v)).collect()
    }

    fn map_lookup(&self, scene: &Scene, hit: &SurfaceHit, wo: Vec3) -> Option<Vec3> {
        self.lookup_maps(scene, hit, wo)
    }

    /// Christensen 1999, Fig. 1 (b)–(e), from this strategy's own maps (Fig. 1(a), the photon
    /// map itself, is [`Strategy::photons`]). Every image shows radiance on the renders' scale,
    /// so that one tone mapping (the renders' sRGB preview, exposure 0) serves them all:
    /// irradiance E is shown as E/π, the radiance a white Lambertian surface under E reflects
    /// (the paper's "dimmed for display"; π dims less than the paper's unstated factor but
    /// keeps the images comparable with the final render and with each other).
    /// - `IRRADIANCE_PNG` (Fig. 1b): the global map's N-nearest irradiance estimate at the first
    ///   non-delta hit of each pixel centre's camera ray (through mirrors and glass, weighted by
    ///   their reflectance), on the side the ray sees.
    /// - `PRECOMPUTED_PNG` (Fig. 1c at `every = 1`, 1d at `every = 4`): only with precomputed
    ///   irradiance: each photon holding an irradiance drawn where the camera sees it (as the
    ///   photon image draws photons), the pixel showing the mean E/π of its visible photons,
    ///   black where none is visible.
    /// - `GATHER_SEES_PNG` (Fig. 1e, the scene "as the final gathering sees it", §3.2): at the
    ///   same first hits, what a final-gather ray landing there reads ([`Renderer::lookup`]):
    ///   ρ/π · E of the nearest precomputed photon, or the global map's radiance estimate.
    ///
    /// The delta chains draw from `[stream::FIGURE, pixel, 0]`, so the images depend on the seed
    /// only, never on the thread count.
    fn figures(&self, scene: &Scene, seed: u64) -> Vec<Figure> {
        let Some(maps) = &self.maps else {
            return Vec::new();
        };
        let r = Renderer {
            scene,
            params: &self.params,
            maps,
        };
        let cam = &scene.camera;
        let (width, height) = (cam.width, cam.height);
        let hits: Vec<Option<(SurfaceHit, Vec3, Vec3)>> = (0..cam.pixel_count())
            .into_par_iter()
            .map(|pixel| {
                let mut rng = Rng::for_task(seed, [stream::FIGURE, pixel as u64, 0]);
                let (x, y) = (pixel % width as usize, pixel / width as usize);
                let ray = cam.generate_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                r.first_diffuse_hit(ray, &mut rng)
            })
            .collect();
        let at_hits = |f: &(dyn Fn(&SurfaceHit, &Bsdf, Vec3) -> Vec3 + Sync)| Image {
            width,
            height,
            pixels: hits
                .par_iter()
                .map(|h| {
                    h.as_ref()
                        .map_or(Vec3::ZERO, |(hit, beta, wo)| *beta * f(hit, scene.bsdf(hit), *wo))
                })
                .collect(),
        };
        let mut figures = vec![
            picture::distribution(scene, &self.photons()),
            Figure {
                suffix: IRRADIANCE_PNG,
                image: FigureImage::Radiance(at_hits(&|hit, _, wo| {
                    maps.global
                        .irradiance(hit.p, side_normal(hit, wo), &maps.estimate)
                        .value
                        * FRAC_1_PI
                })),
            },
        ];
        if let Some(irr) = &maps.irradiance {
            let photons: Vec<(Vec3, Vec3)> = irr.photons().iter().map(|p| (p.position(), p.normal())).collect();
            let mut sum = vec![Vec3::ZERO; cam.pixel_count()];
            let mut count = vec![0u32; cam.pixel_count()];
            for (photon, pixel) in irr.photons().iter().zip(visible_pixels(scene, &photons)) {
                if let (Some(i), Some(e)) = (pixel, photon.irradiance()) {
                    sum[i] += e * FRAC_1_PI;
                    count[i] += 1;
                }
            }
            let pixels = sum
                .iter()
                .zip(&count)
                .map(|(&s, &n)| if n > 0 { s / n as f32 } else { Vec3::ZERO })
                .collect();
            figures.push(Figure {
                suffix: PRECOMPUTED_PNG,
                image: FigureImage::Radiance(Image { width, height, pixels }),
            });
        }
        figures.push(Figure {
            suffix: GATHER_SEES_PNG,
            image: FigureImage::Radiance(at_hits(&|hit, bsdf, wo| {
                r.lookup(hit, bsdf, wo, &mut PhotonMapCounters::default())
            })),
        });
        figures
    }

    fn prepare(&mut self, scene: &Scene, seed: u64) -> Result<Vec<Phase>> {
        let p = &self.params;
        // A photon path stores about 1 / (1 − albedo) photons, plus caustic copies: budget 8.
        let bytes = resources::photon_bytes(p.photons.saturating_mul(8), Photon::BYTES as u64);
        resources::check_memory("photons (photon maps)", bytes, resources::memory_limit()?)?;
        self.counters.reset();
        let mut phases = Vec::new();
        let start = Instant::now();
        let trace = TraceParams {
            photons: p.photons,
            store_direct: true,
            caustics: CausticStorage::Both,
            ..TraceParams::default()
        };
        let traced = trace_photons(scene, &trace, seed);
        phases.push(Phase {
            name: "photon_trace",
            seconds: start.elapsed().as_secs_f64(),
        });
        phases.extend(self.build_maps(scene, traced.global, traced.caustic, seed));
        Ok(phases)
    }

    fn render_pass(&self, scene: &Scene, seed: u64, samples: std::ops::Range<u32>, film: &mut Film) {
        self.render_maps(scene, seed, samples, film);
    }
}

impl PhotonMapStrategy {
    /// Builds the kd-trees (and the precomputed irradiance, if asked for) from photon lists
    /// that any photon tracer produced — standard photon tracing here, Metropolis photon
    /// sampling in `mps` — ready for [`PhotonMapStrategy::render_maps`].
    pub fn build_maps(&mut self, scene: &Scene, global: Vec<Photon>, caustic: Vec<Photon>, seed: u64) -> Vec<Phase> {
        self.counters.reset();
        let p = &self.params;
        let diagonal = scene_diagonal(scene);
        let mut phases = Vec::new();
        let start = Instant::now();
        let global = PhotonMap::build(global);
        let caustic = PhotonMap::build(caustic);
        phases.push(Phase {
            name: "kdtree_build",
            seconds: start.elapsed().as_secs_f64(),
        });
        let max_radius = self.max_radius(scene);
        let estimate = EstimateParams {
            nearest: p.nearest,
            max_radius,
            ..EstimateParams::default()
        };
        let caustic_estimate = EstimateParams {
            nearest: p.caustic_nearest,
            ..estimate.clone()
        };
        let irradiance = p.precomputed_irradiance.as_ref().map(|pre| {
            let start = Instant::now();
            let map = precompute_irradiance(&global, pre.every, &estimate);
            phases.push(Phase {
                name: "irradiance_precompute",
                seconds: start.elapsed().as_secs_f64(),
            });
            map
        });
        let mut maps = Maps {
            global,
            caustic,
            irradiance,
            cache: None,
            estimate,
            caustic_estimate,
            short_gather: p.short_gather.unwrap_or(2.0 * max_radius),
        };
        if let Some(ic) = &p.irradiance_cache {
            let start = Instant::now();
            let r = Renderer {
                scene,
                params: p,
                maps: &maps,
            };
            let clamp = (
                ic.min_distance.unwrap_or(0.02 * diagonal),
                ic.max_distance.unwrap_or(0.5 * diagonal),
            );
            let (lo, hi) = (clamp.0.min(clamp.1), clamp.0.max(clamp.1));
            let r_clamp = (lo.max(f32::MIN_POSITIVE), hi.max(f32::MIN_POSITIVE));
            maps.cache = Some(r.fill_cache(ic, r_clamp, seed, &self.counters));
            phases.push(Phase {
                name: "irradiance_cache",
                seconds: start.elapsed().as_secs_f64(),
            });
        }
        self.maps = Some(maps);
        phases
    }

    /// Renders by final gathering from the maps of the last `prepare` / `build_maps`.
    /// What a final-gather ray reaching `hit` reads from the maps toward `wo` (no secondary
    /// gather; [`Strategy::map_lookup`]); `None` before the maps are built.
    pub fn lookup_maps(&self, scene: &Scene, hit: &SurfaceHit, wo: Vec3) -> Option<Vec3> {
        let maps = self.maps.as_ref()?;
        let r = Renderer {
            scene,
            params: &self.params,
            maps,
        };
        Some(r.lookup(hit, scene.bsdf(hit), wo, &mut PhotonMapCounters::default()))
    }

    pub fn render_maps(&self, scene: &Scene, seed: u64, samples: std::ops::Range<u32>, film: &mut Film) {
        let Some(maps) = &self.maps else { return };
        let r = Renderer {
            scene,
            params: &self.params,
            maps,
        };
        render_pixels(scene, seed, samples, film, |ray, rng| {
            let mut c = PhotonMapCounters::default();
            let l = r.radiance(*ray, rng, &mut c);
            self.counters.add(&c);
            l
        });
    }
}

struct Renderer<'a> {
    scene: &'a Scene,
    params: &'a PhotonMapParams,
    maps: &'a Maps,
}

/// Shading normal on the side of the world direction `w`.
#[inline]
fn side_normal(hit: &SurfaceHit, w: Vec3) -> Vec3 {
    if hit.ng.dot(w) >= 0.0 {
        hit.frame.n
    } else {
        -hit.frame.n
    }
}

impl Renderer<'_> {
    /// Radiance arriving along a camera ray.
    fn radiance(&self, mut ray: Ray, rng: &mut Rng, c: &mut PhotonMapCounters) -> Vec3 {
        let scene = self.scene;
        let mut l = Vec3::ZERO;
        let mut beta = Vec3::ONE;
        let mut depth = 0u32;
        while let Some(hit) = scene.intersect(&ray) {
            if let Some(light) = scene.light_of(hit.prim) {
                l += beta * light.le(hit.ng, -ray.d);
            }
            let bsdf = scene.bsdf(&hit);
            let wo = hit.frame.to_local(-ray.d);
            if !bsdf.is_delta() {
                l += beta * self.shade(&hit, bsdf, -ray.d, true, rng, c);
                break;
            }
            if depth >= self.params.max_depth {
                break;
            }
            let Some((next, weight)) = delta_bounce(&hit, bsdf, wo, rng) else {
                break;
            };
            beta *= weight;
            if beta == Vec3::ZERO {
                break;
            }
            ray = next;
            depth += 1;
        }
        l
    }

    /// Reflected radiance at a non-delta hit towards `wo_world`, without emission: light
    /// sampling + caustic map + a final gather (`primary`: G rays that may start secondary
    /// gathers; otherwise the secondary gather's rays, read from the map).
    fn shade(
        &self,
        hit: &SurfaceHit,
        bsdf: &Bsdf,
        wo_world: Vec3,
        primary: bool,
        rng: &mut Rng,
        c: &mut PhotonMapCounters,
    ) -> Vec3 {
        let scene = self.scene;
        let wo = hit.frame.to_local(wo_world);
        let sampler = BsdfSampling::Importance;
        let mut weights = None;
        let lights = self
            .params
            .light_sampling()
            .at(scene, hit.p, || receiver(hit, bsdf, wo), &mut weights);
        let light_choice = (&lights, &weights);
        let direct = estimate_direct(
            scene,
            hit,
            bsdf,
            wo,
            rng,
            Direct::Nee,
            light_choice,
            (&sampler, &()),
            &mut (),
        );
        c.caustic_estimates += u64::from(!self.maps.caustic.is_empty());
        let caustic = self.map_radiance(&self.maps.caustic, &self.maps.caustic_estimate, hit, bsdf, wo_world);
        let g = if primary {
            self.params.gather_rays
        } else {
            self.params.secondary_gather_rays
        } as usize;
        if primary && let (Some(cache), Bsdf::Lambertian(lam)) = (&self.maps.cache, bsdf) {
            // Ward's irradiance cache: ρ/π × the interpolated indirect irradiance.
            match cache.interpolate(hit.p, side_normal(hit, wo_world)) {
                Some(e) => {
                    c.cache_lookups += 1;
                    return direct + caustic + lam.reflectance * FRAC_1_PI * e;
                }
                None => c.cache_misses += 1,
            }
        }
        let mut indirect = Vec3::ZERO;
        c.final_gathers += u64::from(primary && g > 0);
        if g > 0 {
            for u in latin_hypercube(g, rng) {
                let u_lobe = rng.uniform();
                c.gather_rays += 1;
                let Some(s) = bsdf.sample(wo, u, u_lobe, TransportMode::Radiance) else {
                    continue;
                };
                if s.pdf_w <= 0.0 {
                    continue;
                }
                let wi = hit.frame.to_world(s.wi);
                if wi.dot(hit.ng) * s.wi.z <= 0.0 {
                    continue;
                }
                let weight = s.f * (s.wi.z.abs() / s.pdf_w);
                if weight == Vec3::ZERO {
                    continue;
                }
                indirect += weight * self.gather(spawn_ray(hit.p, hit.ng, wi), primary, rng, c).0;
            }
            indirect /= g as f32;
        }
        direct + caustic + indirect
    }

    /// Radiance a gather ray brings back: follows delta surfaces to the next non-delta hit y
    /// and estimates its outgoing radiance there (emission excluded); and the distance to the
    /// first surface hit (infinite when the ray escapes).
    fn gather(&self, ray: Ray, primary: bool, rng: &mut Rng, c: &mut PhotonMapCounters) -> (Vec3, f32) {
        let mut first = f32::INFINITY;
        let l = self.gather_to(ray, primary, rng, c, &mut first);
        (l, first)
    }

    fn gather_to(
        &self,
        mut ray: Ray,
        primary: bool,
        rng: &mut Rng,
        c: &mut PhotonMapCounters,
        first: &mut f32,
    ) -> Vec3 {
        let scene = self.scene;
        let mut beta = Vec3::ONE;
        let mut distance = 0.0f32;
        let mut depth = 0u32;
        loop {
            let Some(hit) = scene.intersect(&ray) else {
                return Vec3::ZERO;
            };
            if depth == 0 {
                *first = hit.t;
            }
            distance += hit.t;
            let bsdf = scene.bsdf(&hit);
            let wo_world = -ray.d;
            if !bsdf.is_delta() {
                let maps = self.maps;
                if primary && distance < maps.short_gather && self.params.secondary_gather_rays > 0 {
                    c.secondary_gathers += 1;
                    return beta * self.shade(&hit, bsdf, wo_world, false, rng, c);
                }
                return beta * self.lookup(&hit, bsdf, wo_world, c);
            }
            if depth >= self.params.max_depth {
                return Vec3::ZERO;
            }
            let wo = hit.frame.to_local(wo_world);
            let Some((next, weight)) = delta_bounce(&hit, bsdf, wo, rng) else {
                return Vec3::ZERO;
            };
            beta *= weight;
            if beta == Vec3::ZERO {
                return Vec3::ZERO;
            }
            ray = next;
            depth += 1;
        }
    }

    /// The outgoing radiance a gather ray reads at the non-delta hit `hit` towards `wo_world`
    /// (no secondary gather): with precomputed irradiance and a Lambertian surface, ρ/π times
    /// the irradiance of the nearest photon with a similar normal [Christensen 1999, §3.1];
    /// otherwise the global map's radiance estimate with the BSDF.
    fn lookup(&self, hit: &SurfaceHit, bsdf: &Bsdf, wo_world: Vec3, c: &mut PhotonMapCounters) -> Vec3 {
        let maps = self.maps;
        if let (Some(irr), Some(pre), Bsdf::Lambertian(lam)) =
            (&maps.irradiance, &self.params.precomputed_irradiance, bsdf)
        {
            c.irradiance_lookups += 1;
            let n = side_normal(hit, wo_world);
            return irr.radiance_at(hit.p, n, lam.reflectance, pre.normal_dot);
        }
        c.map_estimates += 1;
        self.map_radiance(&maps.global, &maps.estimate, hit, bsdf, wo_world)
    }

    /// The first non-delta hit of a camera ray, the throughput of the delta chain before it
    /// and the direction back along the ray; `None` when the ray escapes or the chain ends.
    fn first_diffuse_hit(&self, mut ray: Ray, rng: &mut Rng) -> Option<(SurfaceHit, Vec3, Vec3)> {
        let mut beta = Vec3::ONE;
        for _ in 0..=self.params.max_depth {
            let hit = self.scene.intersect(&ray)?;
            let bsdf = self.scene.bsdf(&hit);
            if !bsdf.is_delta() {
                return Some((hit, beta, -ray.d));
            }
            let (next, weight) = delta_bounce(&hit, bsdf, hit.frame.to_local(-ray.d), rng)?;
            beta *= weight;
            ray = next;
        }
        None
    }

    /// The irradiance cache's deterministic overture (see the module doc): rounds over pixel
    /// grids, coarse to fine; in each, the pixels whose centre's first Lambertian hit has no
    /// valid record compute one in parallel, added in pixel order.
    fn fill_cache(
        &self,
        caching: &IrradianceCaching,
        r_clamp: (f32, f32),
        seed: u64,
        counters: &AtomicCounters,
    ) -> IrradianceCache {
        let cam = &self.scene.camera;
        let (width, height) = (cam.width, cam.height);
        let mut cache = IrradianceCache::new(caching.error);
        let mut rounds: Vec<(u32, u32, u32)> = vec![(16, 0, 0)];
        for step in [8, 4, 2, 1] {
            rounds.extend([(step, step, 0), (step, 0, step), (step, step, step)]);
        }
        for (step, dx, dy) in rounds {
            // Pixels (dx + 2·step·i, dy + 2·step·j) of this round; the first round is the
            // 16-grid itself.
            let stride = if dx == 0 && dy == 0 { step } else { 2 * step };
            let pixels: Vec<(u32, u32)> = (dy..height)
                .step_by(stride as usize)
                .flat_map(|y| (dx..width).step_by(stride as usize).map(move |x| (x, y)))
                .collect();
            let found: Vec<Option<CacheRecord>> = pixels
                .par_iter()
                .map(|&(x, y)| {
                    let pixel = u64::from(y) * u64::from(width) + u64::from(x);
                    let mut rng = Rng::for_task(seed, [stream::IRRADIANCE_CACHE, pixel, 0]);
                    let mut c = PhotonMapCounters::default();
                    let ray = cam.generate_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                    let record = self.cache_record(ray, &cache, caching, r_clamp, &mut rng, &mut c);
                    counters.add(&c);
                    record
                })
                .collect();
            cache.extend(found.into_iter().flatten());
        }
        cache
    }

    /// A new cache record at the first non-delta hit of a camera ray, if that hit is
    /// Lambertian and `cache` has no valid record there.
    fn cache_record(
        &self,
        mut ray: Ray,
        cache: &IrradianceCache,
        caching: &IrradianceCaching,
        (r_min, r_max): (f32, f32),
        rng: &mut Rng,
        c: &mut PhotonMapCounters,
    ) -> Option<CacheRecord> {
        let scene = self.scene;
        for _ in 0..=self.params.max_depth {
            let hit = scene.intersect(&ray)?;
            let bsdf = scene.bsdf(&hit);
            if bsdf.is_delta() {
                ray = delta_bounce(&hit, bsdf, hit.frame.to_local(-ray.d), rng)?.0;
                continue;
            }
            let Bsdf::Lambertian(_) = bsdf else { return None };
            let n = side_normal(&hit, -ray.d);
            if cache.interpolate(hit.p, n).is_some() {
                return None;
            }
            // The final gather of `shade` with the cache's G, cosine-distributed about n:
            // E = π/G Σ L_j, and Ward's R = G / Σ 1/d_j (escaping rays count 1/d = 0).
            let g = caching.gather_rays as usize;
            let sign = if n.dot(hit.frame.n) >= 0.0 { 1.0 } else { -1.0 };
            let (mut sum, mut inverse_d) = (Vec3::ZERO, 0.0f32);
            c.final_gathers += 1;
            if caching.gradients {
                return Some(self.gradient_record(&hit, n, sign, g, (r_min, r_max), rng, c));
            }
            for u in latin_hypercube(g, rng) {
                c.gather_rays += 1;
                let w = sample_cosine_hemisphere(u);
                let wi = hit.frame.to_world(Vec3::new(w.x, w.y, sign * w.z));
                if wi.dot(hit.ng) * sign <= 0.0 {
                    continue;
                }
                let (l, d) = self.gather(spawn_ray(hit.p, hit.ng, wi), true, rng, c);
                sum += l;
                inverse_d += 1.0 / d;
            }
            let r = if inverse_d > 0.0 { g as f32 / inverse_d } else { r_max };
            return Some(CacheRecord {
                p: hit.p,
                n,
                e: sum * (PI / g as f32),
                r: r.clamp(r_min, r_max),
                gradients: None,
            });
        }
        None
    }

    /// A cache record at `hit` (normal `n` = `sign` × the shading normal) from a gather
    /// stratified in [`PolarStrata`] for about `g` rays, with Ward & Heckbert's gradients
    /// ([`crate::photon::irradiance_cache::gradients`]); E and R as in `cache_record`.
    #[allow(clippy::too_many_arguments)]
    fn gradient_record(
        &self,
        hit: &SurfaceHit,
        n: Vec3,
        sign: f32,
        g: usize,
        (r_min, r_max): (f32, f32),
        rng: &mut Rng,
        c: &mut PhotonMapCounters,
    ) -> CacheRecord {
        let strata = PolarStrata::for_rays(g);
        let (mut l, mut d, mut w) = (Vec::new(), Vec::new(), Vec::new());
        for j in 0..strata.m {
            for k in 0..strata.n {
                let local = strata.direction(j, k, rng.uniform2());
                let wi = hit.frame.to_world(Vec3::new(local.x, local.y, sign * local.z));
                let (lj, dj) = if wi.dot(hit.ng) * sign <= 0.0 {
                    (Vec3::ZERO, f32::INFINITY)
                } else {
                    c.gather_rays += 1;
                    self.gather(spawn_ray(hit.p, hit.ng, wi), true, rng, c)
                };
                l.push(lj);
                d.push(dj);
                w.push(local);
            }
        }
        let count = strata.len() as f32;
        let inverse_d: f32 = d.iter().map(|d| 1.0 / d).sum();
        let r = if inverse_d > 0.0 { count / inverse_d } else { r_max };
        let (rotational, translational) = gradients(strata, &l, &d, &w);
        // Tangent vectors map to the world through the shading frame on either side; the
        // rotational gradient ∫ L (n × ω) dω changes sign with n (x, y, −n is left-handed).
        let tangent = |v: Vec3| hit.frame.to_world(v);
        CacheRecord {
            p: hit.p,
            n,
            e: l.iter().copied().sum::<Vec3>() * (PI / count),
            r: r.clamp(r_min, r_max),
            gradients: Some(Gradients {
                rotational: rotational.map(|v| tangent(v) * sign),
                translational: translational.map(tangent),
            }),
        }
    }

    /// Radiance estimate of `map` at `hit` towards `wo_world` with the BSDF: on the side seen
    /// from `wo_world`, plus the other side for transmitting BSDFs.
    fn map_radiance(
        &self,
        map: &PhotonMap,
        params: &EstimateParams,
        hit: &SurfaceHit,
        bsdf: &Bsdf,
        wo_world: Vec3,
    ) -> Vec3 {
        if map.is_empty() {
            return Vec3::ZERO;
        }
        let wo = hit.frame.to_local(wo_world);
        let f_r = |wi: Vec3| bsdf.eval(wo, hit.frame.to_local(wi), TransportMode::Radiance);
        let n = side_normal(hit, wo_world);
        let mut l = map.radiance(hit.p, n, params, f_r).value;
        if bsdf.is_transmissive() {
            l += map.radiance(hit.p, -n, params, f_r).value;
        }
        l
    }
}

/// Samples a delta BSDF: the continued ray and the throughput weight f cos / p.
fn delta_bounce(hit: &SurfaceHit, bsdf: &Bsdf, wo: Vec3, rng: &mut Rng) -> Option<(Ray, Vec3)> {
    let (u, u_lobe) = (rng.uniform2(), rng.uniform());
    let s = bsdf.sample(wo, u, u_lobe, TransportMode::Radiance)?;
    if s.pdf_w <= 0.0 {
        return None;
    }
    let wi = hit.frame.to_world(s.wi);
    if wi.dot(hit.ng) * s.wi.z <= 0.0 {
        return None;
    }
    Some((spawn_ray(hit.p, hit.ng, wi), s.f * (s.wi.z.abs() / s.pdf_w)))
}
