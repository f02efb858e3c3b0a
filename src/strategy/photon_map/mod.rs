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
//!
//! Files: this one (parameters, the strategy, building the maps), [`final_gather`] (camera
//! paths, the direct term, gather rays and what they read), [`irradiance_cache`] (Ward's cache),
//! [`figures`] (Christensen's Fig. 1), [`counters`]. Photon tracing, kd-trees, estimates and the
//! precomputed irradiance are shared machinery and live in [`crate::photon`], not here.

mod counters;
mod figures;
mod final_gather;
mod irradiance_cache;

use counters::AtomicCounters;
pub use counters::PhotonMapCounters;
use final_gather::{Renderer, bsdf_bounce, side_normal};

use super::Declared;
use super::{Figure, Phase, Strategy, render_pixels};
use crate::error::Result;
use crate::film::Film;
use crate::light::{LightSampling, LightSelection, SphereSampling};
use crate::params::{Params, Range};
use crate::photon::irradiance_cache::IrradianceCache;
use crate::photon::{
    CausticStorage, EstimateParams, IrradianceMap, Photon, PhotonMap, TraceParams, precompute_irradiance, trace_photons,
};
use crate::resources;
use crate::scene::{Scene, SurfaceHit};
use glam::Vec3;
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
    fn capabilities(&self) -> crate::strategy::Capabilities {
        crate::strategy::Capabilities::ALL
    }

    fn figures(&self, scene: &Scene, seed: u64) -> Vec<Figure> {
        self.draw_figures(scene, seed)
    }

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
        Some(r.lookup(hit, &scene.bsdf(hit), wo, &mut PhotonMapCounters::default()))
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
