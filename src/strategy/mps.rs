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
//! eye; other paths (L D S* E: direct light, L S* E) store nothing. The photon records the
//! incoming direction and the light sub-path's flux density f_map(X_map) = Le G Π f_s G up to
//! the storage point. Every step stores the current path with weight 1 − a and the candidate
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

use super::Declared;
use super::photon_map::{PhotonMapParams, PhotonMapStrategy};
use super::{Figure, Phase, Strategy};
use crate::bsdf::SurfaceKind;
use crate::bsdf::TransportMode;
use crate::color::luminance;
use crate::error::Result;
use crate::film::Film;
use crate::geometry::{Frame, Ray};
use crate::metropolis::proposals::Context;
use crate::metropolis::{BEstimate, Chain, MetropolisParams, State, Tally, incoming};
use crate::metropolis::{chain_share, prepare_chains};
use crate::params::{Params, Range, Spec};
use crate::path_space::walk::{extend_eye_to_diffuse, sample_direction, trace_from};
use crate::path_space::{Vertex, direction, first_diffuse_from_eye, light_throughput, pdf_eye_side};
use crate::photon::{EstimateParams, Photon, PhotonMap, flags};
use crate::sampling::{Rng, latin_hypercube, sample_concentric_disk};
use crate::scene::{Scene, SurfaceHit};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
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
    /// Gather keys that `mps` does not take or takes from the chain.
    const NOT_GATHER: [&'static str; 2] = ["photons", "max_depth"];
}

impl Params for MpsConfig {
    fn specs() -> Vec<Spec> {
        let gather = PhotonMapParams::specs().into_iter().filter(|s| {
            let top = s.name.split('.').next().unwrap_or_default();
            !Self::NOT_GATHER.contains(&top)
        });
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
        let gather = self.gather.columns().into_iter().filter(|(k, _)| {
            let top = k.split('.').next().unwrap_or_default();
            !Self::NOT_GATHER.contains(&top)
        });
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

/// Kish's effective sample size (Σ w)² / Σ w² of the photons' luminance powers (0 for none).
pub fn effective_sample_size(photons: &[Photon]) -> f64 {
    let (sum, sum_sq) = photons.iter().fold((0.0, 0.0), |(s, q), p| {
        let w = luminance(p.power()) as f64;
        (s + w, q + w * w)
    });
    if sum_sq > 0.0 { sum * sum / sum_sq } else { 0.0 }
}

/// Which map a path stores into, at which vertex, with which flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Map {
    Global,
    Caustic,
}

/// The storage point of a path (see the module doc), if it has one.
pub fn storage_point(scene: &Scene, path: &[Vertex]) -> Option<(Map, usize, u8)> {
    let diffuse = |v: &Vertex| !v.delta && v.bsdf(scene).kind() == SurfaceKind::Diffuse;
    let d = first_diffuse_from_eye(path)?;
    if !diffuse(&path[d]) {
        return None;
    }
    let s = (0..d).rev().find(|&i| !path[i].delta)?;
    if s >= 1 {
        if !diffuse(&path[s]) {
            return None;
        }
        let mut f = 0;
        if s >= 2 {
            f |= flags::INDIRECT;
            if path[1..s].iter().all(|v| v.delta) {
                f |= flags::CAUSTIC;
            }
        }
        Some((Map::Global, s, f))
    } else if d >= 2 {
        Some((Map::Caustic, d, flags::CAUSTIC | flags::INDIRECT))
    } else {
        None
    }
}

/// A photon being accumulated: where, from where, and its power so far.
#[derive(Clone, Copy, Debug)]
struct Deposit {
    map: Map,
    p: Vec3,
    from: Vec3,
    wi: Vec3,
    n: Vec3,
    flags: u8,
    /// F of one whole visit (weight 1).
    unit: Vec3,
    power: DVec3,
}

impl Deposit {
    /// The deposit of `state`: per unit weight B_Y f_map / (N f_Y), times q(X_eye, x_s) with
    /// the importon normalisation (whose 1 / q_s(x_s) is applied when the photon is emitted);
    /// `None` when the path stores nothing.
    fn of(scene: &Scene, state: &State, b_y: f64, n: u64, power: PhotonPower) -> Option<Self> {
        let path = &state.path;
        let (map, s, flags) = storage_point(scene, path)?;
        let f_map = light_throughput(scene, path, s);
        let q_eye = match power {
            PhotonPower::Paper => 1.0,
            PhotonPower::Importon => (s..path.len() - 1)
                .map(|i| pdf_eye_side(scene, path, i) as f64)
                .product(),
        };
        let unit = (f_map.as_dvec3() * (b_y * q_eye / (n as f64 * state.f_y as f64))).as_vec3();
        if !unit.is_finite() || unit == Vec3::ZERO {
            return None;
        }
        let v = &path[s];
        let wi = incoming(path, s);
        let n = if v.ng.dot(wi) >= 0.0 { v.ng } else { -v.ng };
        Some(Self {
            map,
            p: v.p,
            from: path[s - 1].p,
            wi,
            n,
            flags,
            unit,
            power: DVec3::ZERO,
        })
    }

    fn same_photon(&self, o: &Deposit) -> bool {
        self.map == o.map && self.p == o.p && self.from == o.from
    }

    fn add(&mut self, weight: f32) {
        self.power += self.unit.as_dvec3() * weight as f64;
    }
}

/// Photons of all chains, in chain order.
#[derive(Default)]
struct Sampled {
    global: Vec<Photon>,
    caustic: Vec<Photon>,
    tally: Tally,
    unseen: usize,
}

/// The renderer's importance, as densities of importons: where camera paths first meet a
/// diffuse surface (caustic map lookups) and where their first gather ray lands (global map
/// lookups).
pub struct Importons {
    caustic: PhotonMap,
    global: PhotonMap,
    estimate: EstimateParams,
    paths: u64,
    rule: DensityRule,
}

/// How [`Importons`] turn the importons near a point into 1 / q_s (see
/// [`Importons::inverse_density`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DensityRule {
    /// Probe rays measuring the surface area inside the estimate's disc (0: the whole disc
    /// π r²): [`surface_area_in_ball`].
    pub edge_probes: usize,
    /// `Some(ε)`: count only importons, and area, in sight of the point, so that importance
    /// does not leak through a thin wall. `None`: count everything in the ball, as a photon
    /// estimate does. In sight: the segment between the two points, each lifted along its
    /// normal by ε + d / 4 (d their distance), is free. The d / 4 carries the segment over
    /// the surface itself where it curves (on a sphere of radius R a chord of length d sinks
    /// d² / 8R below its ends, less than d / 4 for d < 2R) and over anything lower than that;
    /// a wall stops it.
    pub sight_lift: Option<f32>,
}

impl DensityRule {
    fn in_sight(&self, scene: &Scene, p: Vec3, n: Vec3, q: Vec3, n_q: Vec3) -> bool {
        let Some(eps) = self.sight_lift else { return true };
        let lift = eps + 0.25 * p.distance(q);
        let (a, b) = (p + n * lift, q + n_q * lift);
        let len = a.distance(b);
        len <= lift
            || scene.unoccluded(&Ray {
                o: a,
                d: (b - a) / len,
                t_max: len,
            })
    }
}

impl Importons {
    /// Traces `paths` importon paths: a camera ray through a raster point uniform over the
    /// image, specular bounces (lobes sampled) to the first diffuse hit x_d, one BSDF-sampled
    /// gather ray from it, specular bounces to the next diffuse hit — exactly how the final
    /// gather generates the eye sub-paths that read each map.
    pub fn trace(
        scene: &Scene,
        paths: u64,
        max_edges: usize,
        estimate: EstimateParams,
        rule: DensityRule,
        seed: u64,
    ) -> Self {
        const BLOCK: u64 = 4096;
        let blocks: Vec<(Vec<Photon>, Vec<Photon>)> = (0..paths.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let (mut caustic, mut global) = (Vec::new(), Vec::new());
                for i in b * BLOCK..((b + 1) * BLOCK).min(paths) {
                    let mut rng = Rng::for_task(seed, [crate::sampling::stream::IMPORTON, i, 0]);
                    let mut rev = vec![Vertex::eye(scene)];
                    if !extend_eye_to_diffuse(scene, &mut rev, max_edges, &mut rng) {
                        continue;
                    }
                    let Some(ip) = importon(scene, &rev) else { continue };
                    caustic.push(ip);
                    let (xd, from) = (rev[rev.len() - 1], rev[rev.len() - 2]);
                    let Some(hit) = sample_direction(scene, &xd, &from, TransportMode::Radiance, &mut rng)
                        .and_then(|w| trace_from(scene, &xd, w))
                    else {
                        continue;
                    };
                    rev.push(hit);
                    if extend_eye_to_diffuse(scene, &mut rev, 2 * max_edges, &mut rng)
                        && let Some(ip) = importon(scene, &rev)
                    {
                        global.push(ip);
                    }
                }
                (caustic, global)
            })
            .collect();
        let (mut caustic, mut global) = (Vec::new(), Vec::new());
        for (c, g) in blocks {
            caustic.extend(c);
            global.extend(g);
        }
        Self {
            caustic: PhotonMap::build(caustic),
            global: PhotonMap::build(global),
            estimate,
            paths,
            rule,
        }
    }

    /// 1 / q_s(p): the reciprocal of the density (per unit area) with which the renderer's eye
    /// sub-paths reach `p` on the side of `n`, for lookups in `map`; `None` where no importon
    /// came near (the renderer never looks there).
    ///
    /// The estimate is A / (k / paths), k the importons within the k-nearest radius r (or all
    /// within `max_radius` when fewer) and A the area of surface inside that ball on which they
    /// could lie. Given r, k − 1 importons fall uniformly in A, so with A exact E[A / k] = 1 / q_s
    /// (λ A(r_k) is Gamma(k) distributed for importons of local density λ). A = π r² is exact
    /// only inside a flat surface; within r of an edge or a corner the disc reaches past the
    /// surface and π r² overstates A, so 1 / q_s comes out too large there (`rooms`: +3 %
    /// luminance). With `edge_probes` > 0, A is measured instead: [`surface_area_in_ball`].
    ///
    /// Importance leaks through walls as photon power does [Fan et al. 2005, §3.1]: the ball
    /// around a point of the floor beside a thin wall holds importons from the floor behind it,
    /// where the gather may look far more (or less) often. With a `sight_lift` the count and
    /// the area both keep only what is in sight of `p`, so the estimate stays on its side.
    fn inverse_density(&self, scene: &Scene, map: Map, p: Vec3, n: Vec3, rng: &mut Rng) -> Option<f64> {
        let m = match map {
            Map::Global => &self.global,
            Map::Caustic => &self.caustic,
        };
        if m.is_empty() {
            return None;
        }
        let rule = &self.rule;
        let est = m.irradiance_where(p, n, &self.estimate, |imp| {
            rule.in_sight(scene, p, n, imp.position(), imp.normal())
        });
        if est.photons == 0 || est.radius <= 0.0 {
            return None;
        }
        let r = est.radius;
        let area = if rule.edge_probes == 0 {
            std::f64::consts::PI * (r as f64).powi(2)
        } else {
            surface_area_in_ball(scene, p, n, r, self.estimate.normal_dot, rule, rng)
        };
        (area > 0.0).then(|| area * self.paths as f64 / est.photons as f64)
    }
}

/// An unbiased estimate of the area of the surfaces inside the ball of radius `r` around `p`
/// that a density estimate on the side of `n` reads: diffuse surfaces whose normal, turned to
/// face the probe, passes the importons' normal test (n_y · n ≥ `normal_dot`). `rule.edge_probes` points
/// uniform (Latin-hypercube stratified) on the tangent disc of radius r each cast a ray along
/// −n from height r above it, over 2r; a first hit y inside the ball on such a surface counts
/// 1 / (n_y · n), the Jacobian from the disc's projected area to the surface's. Exact in
/// expectation for any surface seen from above as a height field over the disc: a flat
/// surface's open edges and corners, walls standing on it (nothing under them is seen),
/// curved surfaces. With the rule's `sight_lift` a hit also has to be in sight of `p` (the
/// floor behind a thin wall does not count). What it cannot know is where a surface is seen
/// from above yet never reached by importons (the floor under a wall box without a bottom
/// face).
pub fn surface_area_in_ball(
    scene: &Scene,
    p: Vec3,
    n: Vec3,
    r: f32,
    normal_dot: f32,
    rule: &DensityRule,
    rng: &mut Rng,
) -> f64 {
    let probes = rule.edge_probes;
    let frame = Frame::from_normal(n);
    let mut sum = 0.0f64;
    for u in latin_hypercube(probes, rng) {
        let d = sample_concentric_disk(u) * r;
        let ray = Ray {
            o: p + frame.s * d.x + frame.t * d.y + n * r,
            d: -n,
            t_max: 2.0 * r,
        };
        let Some(hit) = scene.intersect(&ray) else { continue };
        let n_y = if hit.ng.dot(n) >= 0.0 { hit.ng } else { -hit.ng };
        let cos = n_y.dot(n);
        if cos >= normal_dot.max(1e-3)
            && hit.p.distance_squared(p) <= r * r
            && scene.bsdf(&hit).kind() == SurfaceKind::Diffuse
            && rule.in_sight(scene, p, n, hit.p, n_y)
        {
            sum += 1.0 / cos as f64;
        }
    }
    std::f64::consts::PI * (r as f64).powi(2) * sum / probes as f64
}

/// An importon at the last vertex of an eye sub-path, if it is diffuse: unit "power", the
/// direction it came from and the normal on that side.
fn importon(scene: &Scene, rev: &[Vertex]) -> Option<Photon> {
    let v = rev[rev.len() - 1];
    if v.delta || v.bsdf(scene).kind() != SurfaceKind::Diffuse {
        return None;
    }
    let wi = direction(&v, &rev[rev.len() - 2]).0;
    let n = if v.ng.dot(wi) >= 0.0 { v.ng } else { -v.ng };
    Some(Photon::new(v.p, Vec3::ONE, wi, n, 0))
}

/// Runs the chains for `mutations` iterations in total and stores their photons.
fn sample_photons(
    ctx: &Context,
    starts: &[State],
    params: &MpsParams,
    b_y: f64,
    importons: Option<&Importons>,
    seed: u64,
) -> Sampled {
    let chains = starts.len() as u64;
    let mutations = params.mutations;
    let power = params.photon_power;
    let results: Vec<(Sampled, Option<Deposit>)> = starts
        .par_iter()
        .enumerate()
        .map(|(c, start)| {
            let ctx = *ctx;
            let scene = ctx.scene;
            let mut chain = Chain::new(ctx, start.clone());
            let mut rng = Rng::for_task(seed, [crate::sampling::stream::CHAIN, c as u64, 0]);
            let mut probe_rng = Rng::for_task(seed, [crate::sampling::stream::IMPORTON_PROBE, c as u64, 0]);
            let mut out = Sampled::default();
            let mut emit = |d: Deposit| store(&mut out, d, importons, scene, &mut probe_rng);
            let deposit = |s: &State| Deposit::of(scene, s, b_y, mutations, power);
            let mut current = deposit(&chain.current);
            // The photon of the first state, held back to merge with other chains' (below)
            // while `current` is still it.
            let mut first: Option<Deposit> = None;
            let mut at_first = params.merge_chains && current.is_some();
            let mut tally = Tally::default();
            for _ in 0..chain_share(mutations, chains, c as u64) {
                let step = chain.step(&mut rng, &mut tally);
                if let Some(cur) = &mut current {
                    cur.add(1.0 - step.a);
                }
                let cand = match (&step.candidate, step.a > 0.0) {
                    (Some(s), true) => deposit(s),
                    _ => None,
                };
                if step.accept {
                    match (current.take(), cand) {
                        (Some(mut old), Some(new)) if old.same_photon(&new) => {
                            old.unit = new.unit;
                            old.add(step.a);
                            current = Some(old);
                        }
                        (old, new) => {
                            if let Some(old) = old {
                                if std::mem::take(&mut at_first) {
                                    first = Some(old);
                                } else {
                                    emit(old);
                                }
                            }
                            current = new.map(|mut d| {
                                d.add(step.a);
                                d
                            });
                        }
                    }
                } else if let Some(mut new) = cand {
                    match &mut current {
                        Some(cur) if cur.same_photon(&new) => cur.power += new.unit.as_dvec3() * step.a as f64,
                        _ => {
                            new.add(step.a);
                            emit(new);
                        }
                    }
                }
                chain.commit(step);
            }
            if let Some(cur) = current {
                if at_first {
                    first = Some(cur);
                } else {
                    emit(cur);
                }
            }
            out.tally = tally;
            (out, first)
        })
        .collect();
    let mut all = Sampled::default();
    let mut firsts = Vec::new();
    for (r, first) in results {
        all.global.extend(r.global);
        all.caustic.extend(r.caustic);
        all.tally.merge(&r.tally);
        all.unseen += r.unseen;
        firsts.extend(first);
    }
    // Continuous paths repeat across chains only where chains start on the same resampled path.
    let mut probe_rng = Rng::for_task(seed, [crate::sampling::stream::IMPORTON_PROBE, chains, 1]);
    for d in merge_repeated_paths(firsts) {
        store(&mut all, d, importons, ctx.scene, &mut probe_rng);
    }
    all
}

/// Turns a finished deposit into a photon of its map, normalised by the importon density
/// (dropped, and counted, where no importon came near it).
fn store(out: &mut Sampled, d: Deposit, importons: Option<&Importons>, scene: &Scene, probe_rng: &mut Rng) {
    let mut power = d.power;
    if let Some(imp) = importons {
        let Some(inv_q) = imp.inverse_density(scene, d.map, d.p, d.n, probe_rng) else {
            out.unseen += 1;
            return;
        };
        power *= inv_q;
    }
    let photon = Photon::new(d.p, power.as_vec3(), d.wi, d.n, d.flags);
    match d.map {
        Map::Global => out.global.push(photon),
        Map::Caustic => out.caustic.push(photon),
    }
}

/// One photon per repeated path across chains: deposits with the same storage point and the
/// same previous vertex (the paper's "repeated paths", §3.2) are summed, in chain order. Chains
/// resampled from the same B_eye path start on the same storage point; as separate photons
/// they would stack at one position and shrink the k-nearest radius around it. Applied to the
/// chains' first photons, the only ones that can repeat across chains (every later path is a
/// continuous random perturbation of its own chain's).
fn merge_repeated_paths(mut deposits: Vec<Deposit>) -> Vec<Deposit> {
    let key = |d: &Deposit| {
        let b = |v: Vec3| v.to_array().map(f32::to_bits);
        (d.map as u8, b(d.p), b(d.from))
    };
    // Stable: equal keys stay in chain order, so sums do not depend on the thread count.
    deposits.sort_by_key(key);
    let mut out: Vec<Deposit> = Vec::with_capacity(deposits.len());
    for d in deposits {
        match out.last_mut() {
            Some(last) if last.same_photon(&d) => last.power += d.power,
            _ => out.push(d),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::test_scenes::SceneBuilder;

    fn deposit(p: Vec3, from: Vec3, power: f64) -> Deposit {
        Deposit {
            map: Map::Global,
            p,
            from,
            wi: (from - p).normalize(),
            n: Vec3::Y,
            flags: 0,
            unit: Vec3::ONE,
            power: DVec3::splat(power),
        }
    }

    /// Two chains depositing the same path make one photon with both powers; the same point
    /// reached from elsewhere, or stored in the other map, stays a photon of its own; power is
    /// conserved, and the merge goes by the path, not by where its deposits sit in the list.
    #[test]
    fn repeated_paths_across_chains_merge_into_one_photon() {
        let (a, b, up) = (Vec3::ZERO, Vec3::X, Vec3::Y);
        let mut caustic = deposit(a, up, 8.0);
        caustic.map = Map::Caustic;
        let chains = vec![
            deposit(a, up, 1.0),
            deposit(b, up, 2.0),
            deposit(a, up + Vec3::X, 4.0),
            caustic,
            deposit(a, up, 16.0),
        ];
        let merged = merge_repeated_paths(chains.clone());
        assert_eq!(merged.len(), 4);
        let total: f64 = merged.iter().map(|d| d.power.x).sum();
        assert_eq!(total, 31.0);
        let same = merged
            .iter()
            .find(|d| d.map == Map::Global && d.p == a && d.from == up)
            .unwrap();
        assert_eq!(same.power.x, 17.0);
        let reversed = merge_repeated_paths(chains.into_iter().rev().collect());
        let key = |v: &[Deposit]| v.iter().map(|d| (d.p, d.from, d.power.x)).collect::<Vec<_>>();
        let mut k1 = key(&merged);
        let mut k2 = key(&reversed);
        let cmp = |x: &(Vec3, Vec3, f64), y: &(Vec3, Vec3, f64)| x.2.total_cmp(&y.2);
        k1.sort_by(cmp);
        k2.sort_by(cmp);
        assert_eq!(k1, k2);
    }

    fn photons(powers: &[f32]) -> Vec<Photon> {
        powers
            .iter()
            .map(|&w| Photon::new(Vec3::ZERO, Vec3::splat(w), Vec3::Y, Vec3::Y, 0))
            .collect()
    }

    #[test]
    fn effective_sample_size_counts_equal_photons_and_discounts_heavy_ones() {
        assert!((effective_sample_size(&photons(&[0.5; 100])) - 100.0).abs() < 0.5);
        // One photon holding as much power as 99 light ones: (2)² / (1 + 99 / 99²) ≈ 3.96.
        let mut heavy = vec![1.0 / 99.0; 99];
        heavy.push(1.0);
        let ess = effective_sample_size(&photons(&heavy));
        assert!((ess - 3.96).abs() < 0.05, "ESS {ess}");
        assert_eq!(effective_sample_size(&[]), 0.0);
    }

    /// A diffuse unit square [0, 1] × {0} × [0, 1] facing +y (a light far above it), and, when
    /// given, a diffuse sphere of radius `sphere` at (3, 0, 0).
    fn square_scene(sphere: Option<f32>) -> Scene {
        let mut b = SceneBuilder::new();
        let m = b.lambertian(Vec3::splat(0.5));
        b.quad(Vec3::ZERO, Vec3::Z, Vec3::X, m, None);
        b.quad(Vec3::new(0.0, 10.0, 0.0), Vec3::X, Vec3::Z, m, Some(Vec3::ONE));
        if let Some(radius) = sphere {
            b.sphere(Vec3::new(3.0, 0.0, 0.0), radius, m);
        }
        b.build()
    }

    /// Mean and standard error of `n` draws.
    fn mean_and_error(n: usize, mut draw: impl FnMut(usize) -> f64) -> (f64, f64) {
        let xs: Vec<f64> = (0..n).map(&mut draw).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        (mean, (var / n as f64).sqrt())
    }

    #[test]
    fn surface_area_in_ball_is_exact_in_expectation_at_edges_corners_and_on_a_sphere() {
        let scene = square_scene(Some(0.5));
        let (r, pi) = (0.2f32, std::f64::consts::PI);
        let disc = pi * (r as f64).powi(2);
        // The part of the disc of radius r within distance d of its centre's side of a chord.
        let cut = |d: f64| {
            let r = r as f64;
            disc - (r * r * (d / r).acos() - d * (r * r - d * d).sqrt())
        };
        // A sphere's area within 3-D distance r of a point on it is π r² (Archimedes); the disc
        // projected onto the tangent plane is smaller (0.84 π r² at r = 0.8 R at the probe's
        // depth), so this checks the 1 / (n_y · n) Jacobian.
        let top = Vec3::new(3.0, 0.5, 0.0);
        let r_sphere = 0.4f32;
        let cases = [
            ("inside", Vec3::new(0.5, 0.0, 0.5), Vec3::Y, r, disc),
            ("edge", Vec3::new(0.5, 0.0, 0.0), Vec3::Y, r, disc / 2.0),
            ("near edge", Vec3::new(0.5, 0.0, 0.1), Vec3::Y, r, cut(0.1)),
            ("corner", Vec3::ZERO, Vec3::Y, r, disc / 4.0),
            ("sphere", top, Vec3::Y, r_sphere, pi * (r_sphere as f64).powi(2)),
        ];
        // In sight or not makes no difference here: nothing stands on these surfaces.
        for sight_lift in [None, Some(1e-5)] {
            let rule = DensityRule {
                edge_probes: 16,
                sight_lift,
            };
            for (i, (name, p, n, r, expected)) in cases.into_iter().enumerate() {
                let mut rng = Rng::for_task(1, [i as u64, 0, 0]);
                let (mean, err) = mean_and_error(4000, |_| surface_area_in_ball(&scene, p, n, r, 0.5, &rule, &mut rng));
                let z = (mean - expected) / err.max(1e-12);
                assert!(
                    z.abs() < 4.0 || (mean / expected - 1.0).abs() < 1e-5,
                    "{name} ({sight_lift:?}): mean {mean:.6} ± {err:.2e}, expected {expected:.6} (z = {z:.1})"
                );
            }
        }
    }

    /// Global-map importons at `positions` on the floor y = 0 (arriving from above), one per
    /// path, with 16-nearest estimates under `rule`.
    fn floor_importons(positions: impl Iterator<Item = (f32, f32)>, rule: DensityRule) -> Importons {
        let global: Vec<Photon> = positions
            .map(|(x, z)| Photon::new(Vec3::new(x, 0.0, z), Vec3::ONE, Vec3::Y, Vec3::Y, 0))
            .collect();
        Importons {
            caustic: PhotonMap::build(Vec::new()),
            paths: global.len() as u64,
            global: PhotonMap::build(global),
            estimate: EstimateParams {
                nearest: 16,
                ..EstimateParams::default()
            },
            rule,
        }
    }

    /// Uniform importons on the unit square, `paths` of them (density q_s = 1 per path and
    /// unit area).
    fn square_importons(paths: u64, edge_probes: usize, rng: &mut Rng) -> Importons {
        let positions: Vec<(f32, f32)> = (0..paths).map(|_| rng.uniform2().into()).collect();
        let rule = DensityRule {
            edge_probes,
            sight_lift: None,
        };
        floor_importons(positions.into_iter(), rule)
    }

    #[test]
    fn inverse_importon_density_is_unbiased_at_edges_and_corners_only_with_edge_probes() {
        let scene = square_scene(None);
        let points = [
            ("inside", Vec3::new(0.5, 0.0, 0.5)),
            ("edge", Vec3::new(0.5, 0.0, 0.0)),
            ("corner", Vec3::ZERO),
        ];
        let (runs, paths) = (1500, 2000);
        for probes in [0, 16] {
            for (i, (name, p)) in points.into_iter().enumerate() {
                let mut rng = Rng::for_task(2, [probes as u64, i as u64, 0]);
                let (mean, err) = mean_and_error(runs, |_| {
                    let imp = square_importons(paths, probes, &mut rng);
                    imp.inverse_density(&scene, Map::Global, p, Vec3::Y, &mut rng).unwrap()
                });
                // With `paths` uniform points E[A / k] = 1 / q_s · paths / (paths + 1).
                let expected = paths as f64 / (paths + 1) as f64;
                let z = (mean - expected) / err;
                if probes > 0 || name == "inside" {
                    assert!(
                        z.abs() < 4.0,
                        "{probes} probes, {name}: mean {mean:.4} ± {err:.4}, z = {z:.1}"
                    );
                } else {
                    // π r² at an edge overstates the area twofold, at a corner fourfold.
                    let bias = if name == "edge" { 2.0 } else { 4.0 };
                    assert!(
                        (mean / bias - 1.0).abs() < 0.1,
                        "{name} without probes: mean {mean:.3}, expected ≈ {bias}"
                    );
                }
            }
        }
    }

    /// A floor [0, 2] × {0} × [0, 1] facing +y split by a thin wall (two quads, at x = 1 and
    /// x = 1.01, 0.5 high) standing on it, a light far above.
    fn walled_floor_scene() -> Scene {
        let mut b = SceneBuilder::new();
        let m = b.lambertian(Vec3::splat(0.5));
        b.quad(Vec3::ZERO, Vec3::Z, Vec3::X * 2.0, m, None);
        b.quad(Vec3::X, Vec3::Y * 0.5, Vec3::Z, m, None);
        b.quad(Vec3::new(1.01, 0.0, 0.0), Vec3::Z, Vec3::Y * 0.5, m, None);
        b.quad(Vec3::new(0.0, 10.0, 0.0), Vec3::X, Vec3::Z, m, Some(Vec3::ONE));
        b.build()
    }

    #[test]
    fn importon_density_in_sight_does_not_leak_through_a_thin_wall() {
        // Importons 10× denser behind the wall than in front of it; a photon 2 cm in front of
        // the wall, whose 16-nearest disc (r ≈ 0.05) reaches behind it.
        let scene = walled_floor_scene();
        let (front, behind) = (1000u64, 10_000u64);
        let paths = front + behind;
        let p = Vec3::new(0.98, 0.0, 0.5);
        let draw = |rule: DensityRule, rng: &mut Rng| {
            let positions: Vec<(f32, f32)> = (0..paths)
                .map(|i| {
                    let u = rng.uniform2();
                    (if i < front { u.x } else { 1.01 + 0.99 * u.x }, u.y)
                })
                .collect();
            let imp = floor_importons(positions.into_iter(), rule);
            imp.inverse_density(&scene, Map::Global, p, Vec3::Y, rng).unwrap()
        };
        // In front of the wall q_s = front / paths per unit area.
        let expected = paths as f64 / front as f64 * front as f64 / (front + 1) as f64;
        for sight_lift in [Some(1e-5), None] {
            let rule = DensityRule {
                edge_probes: 16,
                sight_lift,
            };
            let mut rng = Rng::for_task(3, [sight_lift.is_some() as u64, 0, 0]);
            let (mean, err) = mean_and_error(1000, |_| draw(rule, &mut rng));
            let z = (mean - expected) / err;
            if sight_lift.is_some() {
                assert!(
                    z.abs() < 4.0,
                    "in sight: mean {mean:.3} ± {err:.3}, expected {expected:.3}, z = {z:.1}"
                );
            } else {
                // Counting the dense importons behind the wall makes the photon far too light.
                assert!(
                    mean < 0.7 * expected,
                    "through the wall: mean {mean:.3}, expected {expected:.3}"
                );
            }
        }
    }
}
