//! `kind = "mps"`: Metropolis photon sampling [Fan, Chenney & Lai 2005]. A Metropolis chain
//! over light-to-eye paths ([`crate::metropolis`], target f_eye / B_eye) decides where photons
//! go; the photon maps are then rendered by the final gather of `photon_map`.
//!
//! **Phases**: `b_eye` (path-tracing estimate of B_eye and the chains' first states, the
//! paper's t_B), `importon_trace` (with the importon normalisation), `photon_sampling` (the
//! chains), `kdtree_build` (with the sampling: the paper's t_map), then whatever the final
//! gather prepares (`irradiance_precompute`, `irradiance_cache`); rendering is the final
//! gather (t_FG).
//!
//! **Storage points** [Fan et al. 2005, §3.2]: a path L (D|S)* D S* D S* E stores a photon in
//! the global map at its second diffuse vertex counted from the eye (where final-gather rays
//! land); a path L S+ D S* E stores one in the caustic map at its first diffuse vertex from the
//! eye; other paths (L D S* E: direct light, L S* E) store nothing. "Diffuse" follows the
//! renderer at a smooth plastic: the camera path shades there whichever lobe the path took, a
//! gather ray goes on through its coating when it samples it ([`storage_point`]). The photon
//! records the incoming direction and the light sub-path's flux density f_map(X_map) =
//! Le G Π f_s G up to the storage point. Every step stores the current path with weight 1 − a and the candidate
//! with weight a (expected values, as in MLT); weights landing on the storage point and
//! incoming direction of the photon being accumulated add to it instead of making a new photon
//! (the paper's repeated paths). `merge_chains` (default true) applies the same rule across
//! chains: chains resampled onto the same first path deposit into one photon
//! ([`merge_repeated_paths`]).
//!
//! **Photon power** (per channel), N the Metropolis iterations over all chains:
//! - `photon_power = "paper"`: F = B_eye,Y · f_map(X_map) / (N · f_eye,Y(X)) [Fan et al.
//!   2005, §3.2]. Its expectation E[Σ F] is ∫ f_map dμ(X) over *whole* paths, the eye
//!   sub-path's vertices included, while a photon map must hold ∫ f_map dμ(X_map): the two
//!   differ by the measure of the eye sub-paths behind each light sub-path (area², area⁴ …),
//!   so the image depends on the unit of length (`tests/mps.rs`: ×1300 for a box 10× larger).
//! - `photon_power = "importon"` (default, our correction): F = B_eye,Y · f_map(X_map) ·
//!   q(X_eye, x_s) / (N · f_eye,Y(X) · q_s(x_s)). Here q(X_eye, x_s) = Π pdf_eye_side is the
//!   density with which the final gather's eye sub-paths (camera ray, specular bounces, first
//!   diffuse hit, one BSDF-sampled gather ray, specular bounces) produce the sampled eye
//!   sub-path and storage point, and q_s(x_s) = ∫ q dμ(X_eye) its marginal at x_s, the density
//!   of gather hits, estimated from [`Importons`] traced the same way (k-nearest density with
//!   the photons' normal test). Then q / q_s is a normalised density over the eye sub-path
//!   given X_map and E[Σ F] = ∫ f_map dμ(X_map) wherever the renderer looks, up to the density
//!   estimate; caustic photons use the density of the camera paths' first diffuse hits.
//!   The k-nearest estimate 1 / q_s = A / (k / N_imp) is unbiased when A is the area of
//!   surface inside its ball; the textbook A = π r_k² overstates it within r_k of a surface's
//!   edge, so photons there weighed too much (`rooms`, 3 M iterations: 3.1 % too bright). The
//!   default measures A with `importon_edge_probes` rays ([`surface_area_in_ball`]; 1.1 %,
//!   0.8 % with 16 M importons); `importon_edge_probes = 0` keeps π r_k². Importance also
//!   leaks through thin walls, as the paper says of importons (§3.1); `importon_in_sight`
//!   (default) counts only importons in sight of the photon ([`DensityRule`]).
//!
//! Parameters: `mutations` (N, default 200 000), `photon_power`, `importons` (1 000 000),
//! `importon_nearest` (64), `importon_edge_probes` (16), `importon_in_sight` (true), `merge_chains` (true);
//! the chain's ([`MetropolisParams`]: `proposals`, `max_depth`,
//! `b_samples`, `chains`, `pm_gamma_deg`, `lens_r1_px`, `lens_r2_fraction`, `caustic_theta1`,
//! `caustic_theta2`) and the final gather's ([`PhotonMapParams`]: `nearest`,
//! `caustic_nearest`, `max_radius`, `gather_rays`, `secondary_gather_rays`, `short_gather`,
//! `precomputed_irradiance`, `irradiance_cache`; `photons` does not apply). `max_depth`
//! bounds both the chain's paths and the gather's specular bounces.
//!
//! Files: this one (parameters, the strategy, preparation), [`photon_power`] (where a path's
//! photon is stored and the power F it gets; repeated paths merged), [`importons`] (the
//! renderer's importance estimated from importons), [`photon_sampling`] (running the chains and
//! depositing photons), `tests.rs`. The chain itself lives in [`crate::metropolis`] and the final
//! gather in [`super::photon_map`]; this folder only decides where photons go and what they carry.

mod importons;
mod photon_power;
mod photon_sampling;
#[cfg(test)]
mod tests;

pub use importons::*;
pub use photon_power::*;
use photon_sampling::*;

use super::Declared;
use super::photon_map::{PhotonMapParams, PhotonMapStrategy};
use super::{Figure, Phase, Strategy};
use crate::color::luminance;
use crate::error::Result;
use crate::film::Film;
use crate::metropolis::prepare_chains;
use crate::metropolis::proposals::Context;
use crate::metropolis::{BEstimate, MetropolisParams, Tally};
use crate::params::{Params, Range, Spec};
use crate::photon::{EstimateParams, Photon};
use crate::scene::{Scene, SurfaceHit};
use glam::Vec3;
use std::time::Instant;

crate::declare_choice! {
    /// How a stored path's photon power is computed.
    pub enum PhotonPower {
        /// F = B_Y f_map / (N f_Y) exactly as printed [Fan et al. 2005, §3.2]; its expectation
        /// carries the measure of the eye sub-paths (see the module doc).
        Paper = "paper",
        /// F = B_Y f_map q(X_eye, x_s) / (N f_Y q_s(x_s)), normalised by the renderer's own
        /// importance (see the module doc): unbiased up to the importon density estimate.
        Importon = "importon",
    }
}

/// Largest accepted `mutations` and `importons`.
const MAX_MUTATIONS: u64 = 10_000_000_000;

crate::declare_params! {
    /// Parameters of `mps` besides the chain's and the final gather's.
    pub struct MpsParams {
        /// N, Metropolis iterations over all chains.
        mutations: u64 = 200_000, range Range::int(1, MAX_MUTATIONS as i64);
        /// How a stored path's photon power is computed ([`PhotonPower`]).
        photon_power: PhotonPower = PhotonPower::Importon;
        /// Importon paths (camera ray + one gather ray) for the `importon` normalisation.
        importons: u64 = 1_000_000, range Range::int(1, MAX_MUTATIONS as i64);
        /// Importons per density estimate.
        importon_nearest: usize = 64, range Range::int(1, 10_000);
        /// Probe rays measuring the surface area inside each importon density estimate's disc
        /// ([`surface_area_in_ball`]); 0 divides by the whole disc π r² (the estimate before
        /// 2026-11-23, biased near surface edges).
        importon_edge_probes: usize = 16, range Range::int(0, 4096);
        /// Count only importons in sight of the photon ([`DensityRule::sight_lift`]): importance
        /// does not leak through thin walls.
        importon_in_sight: bool = true;
        /// Sum deposits of the same path from different chains into one photon
        /// ([`merge_repeated_paths`]).
        merge_chains: bool = true;
    }
}

/// Every parameter of `mps`: its own, the chain's and the final gather's, one table in
/// experiment files. `photons` does not apply (the photon count follows from `mutations`) and
/// `max_depth` is shared by the chain and the gather.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MpsConfig {
    pub params: MpsParams,
    pub chain: MetropolisParams,
    pub gather: PhotonMapParams,
}

impl MpsConfig {
    /// Is `key` (or the table it belongs to) a gather parameter `mps` takes? Not `photons` (the
    /// photon count follows from `mutations`) nor `max_depth` (the chain's).
    fn takes_gather_key(key: &str) -> bool {
        let top = key.split('.').next().unwrap_or_default();
        !["photons", "max_depth"].contains(&top)
    }
}

impl Params for MpsConfig {
    fn specs() -> Vec<Spec> {
        let gather = PhotonMapParams::specs()
            .into_iter()
            .filter(|s| Self::takes_gather_key(&s.name));
        MpsParams::specs()
            .into_iter()
            .chain(MetropolisParams::specs())
            .chain(gather)
            .collect()
    }

    fn check(&self, prefix: &str) -> Result<()> {
        self.params.check(prefix)?;
        self.chain.check(prefix)?;
        self.gather.check(prefix)
    }

    fn columns(&self) -> Vec<(String, String)> {
        let gather = self
            .gather
            .columns()
            .into_iter()
            .filter(|(k, _)| Self::takes_gather_key(k));
        self.params
            .columns()
            .into_iter()
            .chain(self.chain.columns())
            .chain(gather)
            .collect()
    }

    /// Splits the table by the declared keys of each part (`max_depth` goes to both the
    /// chain and the gather).
    fn from_table(mut table: toml::Table) -> Result<Self> {
        if table.contains_key("photons") {
            crate::bail!("photons: does not apply to mps (its photon count follows from `mutations`)");
        }
        let take = |table: &mut toml::Table, specs: Vec<Spec>, keep: &[&str]| {
            let mut out = toml::Table::new();
            for spec in specs.iter().filter(|s| !s.name.contains('.')) {
                if let Some(v) = table.get(&spec.name) {
                    out.insert(spec.name.clone(), v.clone());
                    if !keep.contains(&spec.name.as_str()) {
                        table.remove(&spec.name);
                    }
                }
            }
            out
        };
        let params = MpsParams::from_table(take(&mut table, MpsParams::specs(), &[]))?;
        let chain = MetropolisParams::from_table(take(&mut table, MetropolisParams::specs(), &["max_depth"]))?;
        let gather = PhotonMapParams::from_table(table)?;
        Ok(Self { params, chain, gather })
    }
}

pub struct Mps {
    pub params: MpsParams,
    pub chain: MetropolisParams,
    gather: PhotonMapStrategy,
    stats: Option<Stats>,
}

/// What `prepare` measured.
#[derive(Clone, Debug, Default)]
struct Stats {
    b: BEstimate,
    tally: Tally,
    /// Total stored power (luminance) in each map.
    global_power: f64,
    caustic_power: f64,
    /// Kish's effective sample size (Σ F)² / Σ F² of each map's photon powers (luminance): the
    /// number of equal-power photons whose total would have the same relative variance.
    /// Photon tracing stores (nearly) equal powers, so its ESS is its photon count. MPS's is
    /// lower for two reasons the counter does not separate: by design (photons land ∝ f_eye, so
    /// their power varies as 1 / importance: sparse, heavy photons where gathers rarely look)
    /// and by the chain (repeated paths pile iterations of power onto one photon).
    global_ess: f64,
    caustic_ess: f64,
    /// Photons dropped because no importon came near them (the renderer never reads them).
    unseen: usize,
}

impl Mps {
    /// The strategy from checked parameters.
    pub fn new(config: MpsConfig) -> Result<Self> {
        config.check("")?;
        Ok(Self {
            params: config.params,
            chain: config.chain,
            gather: PhotonMapStrategy::new(config.gather)?,
            stats: None,
        })
    }

    /// Parses an `mps` parameter table: its own keys, the chain's keys, the final gather's keys.
    pub fn from_table(table: toml::Table) -> Result<Self> {
        Self::new(MpsConfig::from_table(table)?)
    }
}

impl Declared for Mps {
    const KIND: &'static str = "mps";
    const SUMMARY: &'static str = "Metropolis photon sampling: photons from a Metropolis chain over light-to-eye paths, final gathering (Fan et al. 2005)";
    type Params = MpsConfig;

    fn new(config: MpsConfig) -> Result<Self> {
        Self::new(config)
    }
}

impl Strategy for Mps {
    /// Everything but opacity masks: a Metropolis photon's power divides the light side's
    /// throughput by the whole path's, and with masks that ratio would also have to undo the
    /// eye side's α and mask transmittances, which no vertex of the path records.
    fn capabilities(&self) -> crate::strategy::Capabilities {
        crate::strategy::Capabilities {
            opacity_masks: false,
            // Its proposals' acceptance needs true densities of the directions they draw.
            stochastic_bsdfs: false,
            ..crate::strategy::Capabilities::ALL
        }
    }

    fn kind(&self) -> &'static str {
        Self::KIND
    }

    fn params(&self) -> Vec<(String, String)> {
        MpsConfig {
            params: self.params.clone(),
            chain: self.chain.clone(),
            gather: self.gather.params.clone(),
        }
        .columns()
    }

    fn prepare(&mut self, scene: &Scene, seed: u64) -> Result<Vec<Phase>> {
        let start = Instant::now();
        let (b, starts, user_paths) = prepare_chains(scene, &self.chain, seed)?;
        let mut phases = vec![Phase {
            name: "b_eye",
            seconds: start.elapsed().as_secs_f64(),
        }];
        let start = Instant::now();
        let ctx = Context::new(scene, &self.chain, &user_paths);
        let importons = (self.params.photon_power == PhotonPower::Importon).then(|| {
            let estimate = EstimateParams {
                nearest: self.params.importon_nearest,
                max_radius: self.gather.max_radius(scene),
                ..EstimateParams::default()
            };
            let max_edges = self.chain.max_depth as usize + 1;
            let rule = DensityRule {
                edge_probes: self.params.importon_edge_probes,
                // ε: far above float noise, far below any wall (9e-5 m on `rooms`).
                sight_lift: self.params.importon_in_sight.then_some(2e-4 * estimate.max_radius),
            };
            Importons::trace(scene, self.params.importons, max_edges, estimate, rule, seed)
        });
        if importons.is_some() {
            phases.push(Phase {
                name: "importon_trace",
                seconds: start.elapsed().as_secs_f64(),
            });
        }
        let start = Instant::now();
        let sampled = sample_photons(&ctx, &starts, &self.params, b.b_y, importons.as_ref(), seed);
        phases.push(Phase {
            name: "photon_sampling",
            seconds: start.elapsed().as_secs_f64(),
        });
        let power = |v: &[Photon]| v.iter().map(|p| luminance(p.power()) as f64).sum::<f64>();
        self.stats = Some(Stats {
            b,
            tally: sampled.tally,
            global_power: power(&sampled.global),
            caustic_power: power(&sampled.caustic),
            global_ess: effective_sample_size(&sampled.global),
            caustic_ess: effective_sample_size(&sampled.caustic),
            unseen: sampled.unseen,
        });
        phases.extend(self.gather.build_maps(scene, sampled.global, sampled.caustic, seed));
        Ok(phases)
    }

    fn render_pass(&self, scene: &Scene, seed: u64, samples: std::ops::Range<u32>, film: &mut Film) {
        self.gather.render_maps(scene, seed, samples, film);
    }

    fn map_lookup(&self, scene: &Scene, hit: &SurfaceHit, wo: Vec3) -> Option<Vec3> {
        self.gather.lookup_maps(scene, hit, wo)
    }

    /// The photon distribution of the map the chain built [Fan et al. 2005, Fig. 2].
    fn figures(&self, scene: &Scene, _seed: u64) -> Vec<Figure> {
        let photons = self.gather.photons();
        if photons.is_empty() {
            return Vec::new();
        }
        vec![crate::photon::picture::distribution(scene, &photons)]
    }

    fn counters(&self) -> Vec<(String, f64)> {
        let Some(s) = &self.stats else { return Vec::new() };
        let mut out = vec![
            ("b_eye".to_string(), s.b.b_y),
            ("b_eye_std_error".to_string(), s.b.std_error),
            ("mutations".to_string(), self.params.mutations as f64),
            ("photons_unseen".to_string(), s.unseen as f64),
            ("global_power_y".to_string(), s.global_power),
            ("caustic_power_y".to_string(), s.caustic_power),
            ("global_ess".to_string(), s.global_ess),
            ("caustic_ess".to_string(), s.caustic_ess),
        ];
        out.extend(s.tally.counters());
        // The final gather's work and the maps' sizes (global_photons, caustic_photons, bytes).
        out.extend(Strategy::counters(&self.gather));
        out
    }
}
