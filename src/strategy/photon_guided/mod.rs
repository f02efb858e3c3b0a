//! `kind = "photon_guided"`: Jensen 1995, "Importance Driven Path Tracing using the Photon
//! Map". Path tracing (as `path`: NEE + MIS, Russian roulette) whose diffuse vertices sample
//! the next direction from a pdf built from the N photons nearest to the vertex
//! ([`crate::sampling::photon_grid`]: inverse cosine warp, m × n grid of reflected flux,
//! ε for empty cells, weight s of eq. (11)). No direction gets zero probability, so the
//! estimator is unbiased (tested against `path`).
//!
//! Parameters: [`PhotonGuidedParams`] (declared once; `bench list photon_guided` prints them
//! with defaults and ranges); the defaults reproduce the paper. What they mean, and the
//! decisions behind them:
//! - `photons`: Np, photons *stored* in the map. Only indirect photons (reflected at
//!   least once) are stored: direct light is computed by light sampling and must not enter the
//!   pdf [§3]. Photon paths are emitted until Np are stored (the path order is fixed by the
//!   seed, so the map is deterministic); the map keeps the first Np.
//! - `nearest`: N, photons per pdf.
//! - `grid`: θ-intervals × φ-intervals.
//! - `epsilon` and `empty_cells`: the paper gives empty cells "a small
//!   fraction of the overall energy". **Decision**: `"each"` gives ε · Φ_total to every empty
//!   cell (the default); `"shared"` splits ε · Φ_total among all empty cells (the reading of
//!   the project digest, `NOTES.md`). With N = 50 photons most of the 64 cells are empty, and
//!   "shared" gives them together 1 % of the probability though they often carry far more of
//!   the light: measured on `cornell-empty` at 64 spp (one seed), MSE path 0.81, guided
//!   "each" 0.58, guided "shared" 4.1 (fireflies). "each" reproduces the paper's gain.
//! - `max_radius`: the photons are searched within this distance (scene units); the paper
//!   uses the N nearest without bound.
//! - `bsdf_mixture`: probability of sampling the BSDF instead of the
//!   grid at a guided vertex (one-sample MIS / defensive mixture, pdf = α p_bsdf + (1 − α)
//!   p_grid). 0 is the paper's method.
//! - `roulette`: Russian roulette on the vertex's albedo, not on the path
//!   throughput (`path`'s default). **Decision**: the paper does not say how paths end; it
//!   cites Arvo & Kirk's roulette, which survives with the surface reflectance. Throughput
//!   roulette multiplies the guiding weight s of eq. (11) into the survival probability: s is
//!   smallest for the directions that carry the most light, so those paths die most often.
//!   Measured on `cornell-empty` walls (`tests/guided_unbiased.rs`): guiding cuts the variance
//!   3.4x with albedo roulette and 1.2x with throughput roulette. `"throughput"` stays
//!   selectable; `experiments/jensen95.toml` gives the standard method albedo roulette too, so
//!   the two differ only in the direction pdf.
//! - `glossy`: also guide glossy vertices (Phong, Ward) with the grid
//!   of the *product* f_r(ωo, ω_p) ΔΦ_p — the paper's ΔΦ_r = f_r · ΔΦ_i of §4 with f_r no
//!   longer constant. Cells stay cosine-warped and uniform inside, so a lobe narrower than a
//!   cell is sampled no better than the cell; ε keeps every direction possible.
//! - `precomputed_pdfs`: `{ every = k, normal_dot = d }` builds
//!   Jensen's pdf once at every k-th photon of the map (default 4), in the frame of that
//!   photon's surface normal, and a Lambertian vertex then uses the pdf of the nearest such
//!   photon whose normal has n_p · n > d (default 0.9) instead of building its own — the
//!   precomputation Christensen 1999 applies to irradiance, applied to the guiding pdf. The
//!   paper's 20 % overhead per sample assumed a ray cost far more than a k-nearest search; here
//!   one pdf costs ~40 rays, and the lookup replaces it by a nearest-neighbour query. The pdf is
//!   then that of a point up to a few photon spacings away, rotated into the vertex's own
//!   tangent frame (its tangent follows the record's), so every direction above the vertex
//!   keeps a non-zero pdf (ε) and the estimator stays unbiased; where no record passes the
//!   normal test within `max_radius`, the vertex builds its own pdf. Absent (the default) is the
//!   paper's method.
//! - `max_depth`, `rr_depth`, `direct`, `light_selection`, `sphere_light_sampling`: as for
//!   `path` (light sampling is the same next-event estimation; its MIS weight uses the guided
//!   pdf as the other strategy).
//!
//! Which vertices are guided: Lambertian surfaces (the paper's "diffuse surfaces"; "The photon
//! map has only been incorporated in the importance sampling algorithm for ideal diffuse
//! reflection", §5), and glossy ones with `glossy = true`; specular and transmitting surfaces
//! keep BSDF sampling. Photons count when they arrived
//! from the vertex's side (incoming direction in the hemisphere of the normal facing `wo`) on a
//! surface facing the same way (stored normal · n > 0), so light on the other side of a thin
//! wall never steers the pdf.
//!
//! Files: this one (parameters, the strategy, tracing the indirect photon map), [`sampler`]
//! (Jensen's pdf at a vertex and the precomputed pdfs), `tests.rs`. The grid itself
//! ([`crate::sampling::photon_grid`]) and the path tracer it plugs into ([`super::path`]) live
//! elsewhere.

mod guide_map;
mod sampler;
#[cfg(test)]
mod tests;

pub use guide_map::GuideMap;
pub use sampler::*;

use super::Declared;
use super::path::{Direct, Roulette, Walk, trace};
use super::photon_map::Precomputed;
use super::{Phase, Strategy, render_pixels};
use crate::color::luminance;
use crate::error::{Error, Result};
use crate::film::Film;
use crate::light::{LightSampling, LightSelection, SphereSampling};
use crate::params::{Params, Range};
use crate::photon::{CausticStorage, FacingTree, KdPoint, Photon, TraceParams, trace_photons};
use crate::resources;
use crate::sampling::photon_grid::{EmptyCells, QuantizedGrids};
use crate::scene::Scene;
use glam::Vec3;
use std::time::Instant;

crate::declare_params! {
    /// Parameters of `kind = "photon_guided"`; the defaults reproduce Jensen 1995.
    pub struct PhotonGuidedParams {
        /// Np, photons *stored* in the map (indirect only: reflected at least once) [§3].
        photons: u64 = 60_000, range Range::int(1, 100_000_000);
        /// N, photons per pdf.
        nearest: usize = 50, range Range::int(1, 10_000);
        /// θ-intervals × φ-intervals of the grid over the cosine-warped hemisphere.
        grid: [usize; 2] = [4, 16], range Range::int(1, 1024);
        /// ε, the fraction of the total energy given to empty cells (see `empty_cells`).
        epsilon: f32 = 0.01, range Range::closed(0.0, 1.0).of("a share");
        /// Whether each empty cell or all of them together receive ε · Φ_total (module doc).
        empty_cells: EmptyCells = EmptyCells::Each;
        /// Photons are searched within this distance (scene units); the paper: unbounded.
        max_radius: f32 = f32::INFINITY, range Range::above_to(0.0, f64::INFINITY).of("a distance");
        /// α, probability of sampling the BSDF instead of the grid (beyond the paper; 0 is
        /// the paper's method).
        bsdf_mixture: f32 = 0.0, range Range::closed(0.0, 1.0).of("a probability");
        /// Also guide glossy vertices with the grid of f_r · ΔΦ (beyond the paper).
        glossy: bool = false;
        /// Jensen's pdf precomputed at every k-th photon, looked up per vertex (beyond the
        /// paper; absent: the paper's method).
        precomputed_pdfs: Option<Precomputed> = None;
        /// Maximum number of scattering events (as `path`).
        max_depth: u32 = 16, range Range::int(0, 1024);
        /// Russian roulette starts after this many scattering events.
        rr_depth: u32 = 3, range Range::int(0, 1024);
        /// What Russian roulette follows; albedo, as 1995-era path tracers (module doc).
        roulette: Roulette = Roulette::Albedo;
        /// How emitted light is gathered (as `path`).
        direct: Direct = Direct::Mis;
        /// How next-event estimation picks a light (as `path`).
        light_selection: LightSelection = LightSelection::Power;
        /// How next-event estimation samples sphere lights (as `path`).
        sphere_light_sampling: SphereSampling = SphereSampling::Area;
    }
}

/// A photon as guiding reads it: the compact record decoded once at preparation (direction,
/// normal and flux luminance), so the k-nearest filter and the grid do no decoding per query.
#[derive(Clone, Copy, Debug)]
pub struct GuidePhoton {
    pub position: Vec3,
    /// Unit direction the photon came from (away from the surface).
    pub direction: Vec3,
    /// Unit surface normal on the side the photon arrived.
    pub normal: Vec3,
    /// Luminance of the photon power ΔΦ.
    pub flux: f32,
}

impl GuidePhoton {
    /// The photon decoded once: position, direction, normal and flux luminance.
    pub fn decoded(p: &Photon) -> Self {
        Self {
            position: p.position(),
            direction: p.direction(),
            normal: p.normal(),
            flux: luminance(p.power()),
        }
    }
}

impl KdPoint for GuidePhoton {
    fn position(&self) -> Vec3 {
        self.position
    }
}

/// Where Jensen's pdf was precomputed at a photon (`precomputed_pdfs`): the key a vertex
/// looks up. The pdf itself is grid `id` of [`PdfRecords::grids`], in the frame
/// `Frame::from_normal_tangent(normal, tangent)`.
#[derive(Clone, Copy, Debug)]
pub struct PdfRecord {
    pub position: Vec3,
    /// Unit normal of the side the photon arrived on.
    pub normal: Vec3,
    /// First axis of the grid's frame: `Frame::from_normal(normal).s`, which lookups rebuild
    /// from the normal the search returns rather than read the record.
    pub tangent: Vec3,
    pub id: u32,
}

/// The precomputed pdfs: their keys in a kd-tree of their own (the per-vertex nearest-record
/// search tests positions and normals eight at a time from the tree's own arrays, then reads
/// the key for the frame) and, indexed by the key's `id`, the grids stored compactly (one or
/// two cache lines per vertex).
#[derive(Clone, Debug)]
pub struct PdfRecords {
    pub tree: FacingTree<PdfRecord>,
    pub grids: QuantizedGrids,
}

impl KdPoint for PdfRecord {
    fn position(&self) -> Vec3 {
        self.position
    }
}

/// The photon-guided strategy; [`Strategy::prepare`] traces the indirect photon map.
pub struct PhotonGuided {
    pub params: PhotonGuidedParams,
    map: Option<GuideMap>,
    records: Option<PdfRecords>,
}

impl PhotonGuided {
    pub fn new(params: PhotonGuidedParams) -> Result<Self> {
        params.check("")?;
        Ok(Self {
            params,
            map: None,
            records: None,
        })
    }

    /// The light sampling options of next-event estimation.
    pub fn light_sampling(&self) -> LightSampling {
        LightSampling {
            selection: self.params.light_selection,
            sphere: self.params.sphere_light_sampling,
        }
    }

    /// The photons built by `prepare`, if any, in their kd-tree.
    pub fn map(&self) -> Option<&GuideMap> {
        self.map.as_ref()
    }
}

/// Traces photon paths until `stored` indirect photons are stored and keeps the first
/// `stored` (in path order). Returns the photons and the number of paths emitted.
fn trace_indirect(scene: &Scene, stored: u64, seed: u64) -> Result<GuideMap> {
    let mut params = TraceParams {
        photons: stored,
        store_direct: false,
        caustics: CausticStorage::None,
        ..TraceParams::default()
    };
    loop {
        let traced = trace_photons(scene, &params, seed);
        let got = traced.global.len() as u64;
        if got >= stored {
            let photons = traced.global[..stored as usize].iter().map(GuidePhoton::decoded);
            return Ok(GuideMap::build(photons.collect()));
        }
        // Emit enough more paths, with 10 % to spare; the first paths are the same ones again.
        let next = if got == 0 {
            params.photons * 8
        } else {
            (params.photons as f64 * stored as f64 / got as f64 * 1.1) as u64 + 1
        };
        if next > 64 * stored.max(1_000_000) {
            return Err(Error::new(format!(
                "photons: {} emitted paths stored only {got} indirect photons; the scene returns too little light for {stored}",
                params.photons
            )));
        }
        params.photons = next;
    }
}

impl Declared for PhotonGuided {
    const KIND: &'static str = "photon_guided";
    const SUMMARY: &'static str = "path tracing guided at diffuse vertices by a photon-built pdf (Jensen 1995)";
    type Params = PhotonGuidedParams;

    fn new(params: PhotonGuidedParams) -> Result<Self> {
        Self::new(params)
    }
}

impl Strategy for PhotonGuided {
    fn capabilities(&self) -> crate::strategy::Capabilities {
        crate::strategy::Capabilities {
            point_lights: self.params.direct != Direct::Bsdf,
            directional_lights: self.params.direct != Direct::Bsdf,
            ..crate::strategy::Capabilities::ALL
        }
    }

    fn kind(&self) -> &'static str {
        Self::KIND
    }

    fn params(&self) -> Vec<(String, String)> {
        self.params.columns()
    }

    fn prepare(&mut self, scene: &Scene, seed: u64) -> Result<Vec<Phase>> {
        let bytes = resources::photon_bytes(self.params.photons, Photon::BYTES as u64);
        resources::check_memory("photons (photon map)", bytes, resources::memory_limit()?)?;
        let start = Instant::now();
        let map = trace_indirect(scene, self.params.photons, seed)?;
        let mut phases = vec![Phase {
            name: "photon_map",
            seconds: start.elapsed().as_secs_f64(),
        }];
        self.records = self.params.precomputed_pdfs.as_ref().map(|pre| {
            let start = Instant::now();
            let records = precompute_pdfs(&map, &self.params, pre.every);
            phases.push(Phase {
                name: "pdf_precompute",
                seconds: start.elapsed().as_secs_f64(),
            });
            records
        });
        self.map = Some(map);
        Ok(phases)
    }

    fn render_pass(&self, scene: &Scene, seed: u64, samples: std::ops::Range<u32>, film: &mut Film) {
        let Some(map) = &self.map else { return };
        let p = &self.params;
        let walk = Walk {
            max_depth: p.max_depth,
            rr_depth: p.rr_depth,
            roulette: p.roulette,
            direct: p.direct,
            lights: self.light_sampling(),
        };
        let sampler = GridSampler {
            map,
            params: p,
            records: self.records.as_ref(),
        };
        render_pixels(scene, seed, samples, film, |ray, rng| {
            trace(scene, &walk, &sampler, *ray, rng, &mut ())
        });
    }
}
