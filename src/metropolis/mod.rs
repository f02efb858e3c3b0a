//! A Metropolis–Hastings chain over light-to-eye paths with target density p_eye = f_eye / B_eye
//! [Fan et al. 2005, §3–4; Veach 1997, ch. 11], shared by `kind = "mlt"` (paths splat into the
//! image) and `kind = "mps"` (paths store photons).
//!
//! - **B_eye** is estimated by path tracing over the whole image ([`estimate_b`]), with its
//!   standard error.
//! - **X₀** of every chain is resampled from those path-tracing paths ∝ their luminance
//!   contribution f/p (no start-up bias [Veach 1997, §11.3.1]).
//! - Each **step** picks a proposal with its fixed probability and accepts with
//!   a = min(1, f_eye,Y(Y) T(X|Y) / (f_eye,Y(X) T(Y|X))); T is that of the chosen proposal,
//!   except UP and BD, which are combined: T = (P_UP T_UP + P_BD T_BD) / (P_UP + P_BD)
//!   [Fan et al. 2005, eq. (7)].

pub mod proposals;

use crate::error::{Error, Result};
use crate::path_space::walk::{path_tracing_sample, trace};
use crate::path_space::{Vertex, contribution, direction, first_diffuse_from_eye};
use crate::sampling::Rng;
use crate::scene::{Scene, luminance};
use glam::{DVec3, Vec2, Vec3};
use proposals::{Candidate, Context};
use rayon::prelude::*;
use serde::Deserialize;

/// Proposal probabilities P_type, Σ = 1 [Fan et al. 2005, eq. (5)]. In an experiment file a
/// `proposals` table lists the non-zero ones (missing keys are 0); without the table the
/// default mix applies.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ProposalMix {
    #[serde(default)]
    pub up: f64,
    #[serde(default)]
    pub bd: f64,
    #[serde(default)]
    pub pm: f64,
    #[serde(default)]
    pub cp: f64,
    #[serde(default)]
    pub lp: f64,
    #[serde(default)]
    pub ls: f64,
    /// The multi-chain perturbation (not in Fan et al. 2005; [Veach 1997, §11.4.4]): 0 unless
    /// an experiment asks for it.
    #[serde(default)]
    pub mc: f64,
}

impl Default for ProposalMix {
    /// The paper's Lantern mix (no user paths): BD 0.4, PM 0.2, LP 0.2, LS 0.2.
    fn default() -> Self {
        Self {
            up: 0.0,
            bd: 0.4,
            pm: 0.2,
            cp: 0.0,
            lp: 0.2,
            ls: 0.2,
            mc: 0.0,
        }
    }
}

/// Number of proposal types.
pub const PROPOSALS: usize = 7;

/// The proposal types, in the order of [`ProposalMix`] and of the counters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Proposal {
    Up,
    Bd,
    Pm,
    Cp,
    Lp,
    Ls,
    Mc,
}

impl Proposal {
    pub const ALL: [Proposal; PROPOSALS] = [
        Proposal::Up,
        Proposal::Bd,
        Proposal::Pm,
        Proposal::Cp,
        Proposal::Lp,
        Proposal::Ls,
        Proposal::Mc,
    ];

    pub fn name(self) -> &'static str {
        ["up", "bd", "pm", "cp", "lp", "ls", "mc"][self as usize]
    }
}

impl ProposalMix {
    /// One proposal alone (for timing and tests: a chain of LP alone, say, is not ergodic, and
    /// UP alone is refused by validation).
    pub fn only(p: Proposal) -> Self {
        let mut values = [0.0; PROPOSALS];
        values[p as usize] = 1.0;
        let [up, bd, pm, cp, lp, ls, mc] = values;
        Self {
            up,
            bd,
            pm,
            cp,
            lp,
            ls,
            mc,
        }
    }

    pub fn get(&self, p: Proposal) -> f64 {
        [self.up, self.bd, self.pm, self.cp, self.lp, self.ls, self.mc][p as usize]
    }

    fn validate(&self) -> Result<()> {
        for p in Proposal::ALL {
            let v = self.get(p);
            if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                crate::bail!("proposals.{}: expected a probability in [0, 1], got {v}", p.name());
            }
        }
        let sum: f64 = Proposal::ALL.iter().map(|&p| self.get(p)).sum();
        if (sum - 1.0).abs() > 1e-6 {
            crate::bail!(
                "proposals: the probabilities up, bd, pm, cp, lp, ls, mc must sum to 1, got {sum} \
                 (up {}, bd {}, pm {}, cp {}, lp {}, ls {}, mc {})",
                self.up,
                self.bd,
                self.pm,
                self.cp,
                self.lp,
                self.ls,
                self.mc
            );
        }
        if self.up > 0.0 && self.bd == 0.0 {
            crate::bail!(
                "proposals: up > 0 needs bd > 0 (UP is combined with BD, which gives every path a \
                 way back [Fan et al. 2005, eq. (7)])"
            );
        }
        Ok(())
    }

    fn choose(&self, u: f64) -> Proposal {
        let mut acc = 0.0;
        for p in Proposal::ALL {
            acc += self.get(p);
            if u < acc {
                return p;
            }
        }
        *Proposal::ALL
            .iter()
            .rev()
            .find(|&&p| self.get(p) > 0.0)
            .unwrap_or(&Proposal::Bd)
    }
}

/// Chain parameters shared by `mlt` and `mps`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct MetropolisParams {
    pub proposals: ProposalMix,
    /// Maximum scattering events of a path (edges − 1), as `path`'s `max_depth`.
    pub max_depth: u32,
    /// Path-tracing samples (whole-image eye paths) for B_eye and the chains' first states;
    /// absent: [`B_SAMPLES_PER_CHAIN`] per chain ([`Self::b_samples`]).
    pub b_samples: Option<u64>,
    /// Independent chains (fixed, so results do not depend on the thread count). **Decision:
    /// many short chains (default 8192).** Every chain starts from a path resampled ∝ f/p, so a
    /// short chain has no start-up bias, and it caps how many iterations a chain stuck in a
    /// state its proposals cannot leave (L S D S E in `box`) piles onto one photon or pixel:
    /// 64 → 8192 chains took MPS on box from rms_rel_lum 0.44 to 0.19 and MLT from 5.8 to 0.90
    /// (README, "Reproducing Fan et al. 2005").
    pub chains: u32,
    /// PM cone half-angle γ in degrees (paper: 30).
    pub pm_gamma_deg: f32,
    /// LP offsets: r ∈ [r1, r2] with density ∝ 1/r; r1 in pixels, r2 the radius of a disc
    /// covering this fraction of the image [Veach 1997, §11.4.3: 0.1 pixel and 10 %].
    pub lens_r1_px: f32,
    pub lens_r2_fraction: f32,
    /// CP angles θ ∈ [θ1, θ2] radians with density ∝ 1/θ [Veach 1997: 0.0001, 0.1].
    pub caustic_theta1: f32,
    pub caustic_theta2: f32,
}

impl Default for MetropolisParams {
    fn default() -> Self {
        Self {
            proposals: ProposalMix::default(),
            max_depth: 16,
            b_samples: None,
            chains: 8192,
            pm_gamma_deg: 30.0,
            lens_r1_px: 0.1,
            lens_r2_fraction: 0.1,
            caustic_theta1: 1e-4,
            caustic_theta2: 0.1,
        }
    }
}

/// Default path-tracing samples per chain for B_eye and the first states. **Decision** (beyond
/// the paper, which runs one chain): the pool grows with the chains. A chain's first state is
/// resampled from the pool ∝ f/p, which is unbiased with the pool's B_eye in expectation, but
/// a pool with few samples per chain starts many chains on the same heavy paths and misses the
/// rare ones: short chains then crowd their photons around those starts, and the k-nearest
/// estimate reads crowds as density. Measured with `bench map-error` on `lantern` (8 seeds,
/// 8192 chains, 500 000 mutations), the interior mean ratio went 1.068 ± 0.014 with 12 samples
/// per chain (the earlier fixed 100 000), 1.015 ± 0.014 with 100, photon mapping's k / (k − 1)
/// (README, "Reproducing Fan et al. 2005", item 10).
pub const B_SAMPLES_PER_CHAIN: u64 = 100;

impl MetropolisParams {
    /// Path-tracing samples for B_eye: `b_samples`, or [`B_SAMPLES_PER_CHAIN`] per chain.
    pub fn b_samples(&self) -> u64 {
        self.b_samples.unwrap_or(B_SAMPLES_PER_CHAIN * u64::from(self.chains))
    }

    pub fn validate(&self) -> Result<()> {
        self.proposals.validate()?;
        let bad = |what: &str, got: String| Err(Error::new(format!("{what}, got {got}")));
        if self.max_depth == 0 || self.max_depth > 64 {
            return bad(
                "max_depth: expected 1..=64 scattering events",
                self.max_depth.to_string(),
            );
        }
        if let Some(n) = self.b_samples
            && (n == 0 || n > 1_000_000_000)
        {
            return bad("b_samples: expected 1..=1000000000", n.to_string());
        }
        if self.chains == 0 || self.chains > 65_536 {
            return bad("chains: expected 1..=65536", self.chains.to_string());
        }
        if !(self.pm_gamma_deg > 0.0 && self.pm_gamma_deg <= 90.0) {
            return bad(
                "pm_gamma_deg: expected an angle in (0, 90]",
                self.pm_gamma_deg.to_string(),
            );
        }
        if !(self.lens_r1_px > 0.0 && self.lens_r1_px.is_finite()) {
            return bad("lens_r1_px: expected a positive radius", self.lens_r1_px.to_string());
        }
        if !(self.lens_r2_fraction > 0.0 && self.lens_r2_fraction <= 1.0) {
            return bad(
                "lens_r2_fraction: expected a fraction in (0, 1]",
                self.lens_r2_fraction.to_string(),
            );
        }
        if !(self.caustic_theta1 > 0.0 && self.caustic_theta1 < self.caustic_theta2 && self.caustic_theta2 <= 1.0) {
            return bad(
                "caustic_theta1, caustic_theta2: expected 0 < θ1 < θ2 ≤ 1 radian",
                format!("{}, {}", self.caustic_theta1, self.caustic_theta2),
            );
        }
        Ok(())
    }

    /// The parameters as result-row pairs.
    pub fn describe(&self) -> Vec<(&'static str, String)> {
        let p = &self.proposals;
        let mut proposals = format!(
            "up={} bd={} pm={} cp={} lp={} ls={}",
            p.up, p.bd, p.pm, p.cp, p.lp, p.ls
        );
        // Only when used, so that the rows of every mix without it read as before.
        if p.mc > 0.0 {
            proposals += &format!(" mc={}", p.mc);
        }
        vec![
            ("proposals", proposals),
            ("max_depth", self.max_depth.to_string()),
            ("b_samples", self.b_samples().to_string()),
            ("chains", self.chains.to_string()),
            ("pm_gamma_deg", self.pm_gamma_deg.to_string()),
            ("lens_r1_px", self.lens_r1_px.to_string()),
            ("lens_r2_fraction", self.lens_r2_fraction.to_string()),
            ("caustic_theta1", self.caustic_theta1.to_string()),
            ("caustic_theta2", self.caustic_theta2.to_string()),
        ]
    }
}

/// A user path prepared for UP: points, cos β per segment, and for each point whether it lies
/// on a specular surface and whether the path reflects there.
#[derive(Clone, Debug)]
pub struct UserPathInfo {
    pub points: Vec<Vec3>,
    pub cos_beta: Vec<f32>,
    pub specular: Vec<bool>,
    pub reflect: Vec<bool>,
}

/// Classifies the scene's user paths (tracing each segment to find the surfaces at its points).
pub fn prepare_user_paths(scene: &Scene) -> Result<Vec<UserPathInfo>> {
    let mut out = Vec::new();
    for (j, u) in scene.user_paths.iter().enumerate() {
        let n = u.points.len();
        let mut specular = vec![false; n];
        let mut normals = vec![Vec3::ZERO; n];
        for i in 1..n {
            let d = (u.points[i] - u.points[i - 1]).normalize_or_zero();
            let hit = trace(scene, &crate::geometry::Ray::new(u.points[i - 1] + d * 1e-4, d));
            let Some(v) = hit.filter(|v| (v.p - u.points[i]).length() < 1e-2) else {
                crate::bail!(
                    "{}: user_paths[{j}]: the segment from point {} to point {i} does not reach point {i} \
                     (blocked or not on a surface)",
                    scene.source.display(),
                    i - 1
                );
            };
            specular[i] = v.delta;
            normals[i] = v.ng;
        }
        if specular[n - 1] {
            crate::bail!(
                "{}: user_paths[{j}]: the last point must lie on a diffuse surface",
                scene.source.display()
            );
        }
        let reflect = (0..n)
            .map(|i| {
                i > 0
                    && i + 1 < n
                    && (u.points[i - 1] - u.points[i]).dot(normals[i]) * (u.points[i + 1] - u.points[i]).dot(normals[i])
                        > 0.0
            })
            .collect();
        out.push(UserPathInfo {
            points: u.points.clone(),
            cos_beta: u.cone_deg.iter().map(|b| b.to_radians().cos()).collect(),
            specular,
            reflect,
        });
    }
    Ok(out)
}

/// The path-tracing estimate of B = ∫ f dμ (per channel; luminance is the paper's B_eye).
#[derive(Clone, Copy, Debug, Default)]
pub struct BEstimate {
    pub b: Vec3,
    pub b_y: f64,
    /// Standard error of `b_y`.
    pub std_error: f64,
    pub samples: u64,
}

/// One path-tracing path as resampling sees it: (sample index, ordinal within it, luminance).
#[derive(Clone, Copy, Debug)]
struct Weighted {
    sample: u64,
    ordinal: u32,
    y: f64,
}

/// Samples per parallel task; fixed so results never depend on the thread count.
const BLOCK: u64 = 1024;

/// Estimates B with `params.b_samples` path-tracing samples and resamples one first state per
/// chain ∝ luminance contribution.
pub fn estimate_b(scene: &Scene, params: &MetropolisParams, seed: u64) -> Result<(BEstimate, Vec<Vec<Vertex>>)> {
    let n = params.b_samples();
    let max_edges = params.max_depth as usize + 1;
    let blocks: Vec<(DVec3, f64, Vec<Weighted>)> = (0..n.div_ceil(BLOCK))
        .into_par_iter()
        .map(|b| {
            let mut sum = DVec3::ZERO;
            let mut sum_sq = 0.0;
            let mut weighted = Vec::new();
            for i in b * BLOCK..((b + 1) * BLOCK).min(n) {
                let mut rng = Rng::for_task(seed, [crate::strategy::stream::B_EYE, i, 0]);
                let mut total = DVec3::ZERO;
                let mut ordinal = 0u32;
                path_tracing_sample(scene, max_edges, &mut rng, &mut |_, c| {
                    total += c.as_dvec3();
                    let y = luminance(c) as f64;
                    if y > 0.0 {
                        weighted.push(Weighted { sample: i, ordinal, y });
                    }
                    ordinal += 1;
                });
                sum += total;
                let ty = luminance(total.as_vec3()) as f64;
                sum_sq += ty * ty;
            }
            (sum, sum_sq, weighted)
        })
        .collect();
    let (mut sum, mut sum_sq) = (DVec3::ZERO, 0.0);
    let mut weighted = Vec::new();
    for (s, q, w) in blocks {
        sum += s;
        sum_sq += q;
        weighted.extend(w);
    }
    let b = (sum / n as f64).as_vec3();
    let b_y = luminance(sum.as_vec3()) as f64 / n as f64;
    let var = (sum_sq / n as f64 - b_y * b_y).max(0.0);
    let estimate = BEstimate {
        b,
        b_y,
        std_error: (var / n as f64).sqrt(),
        samples: n,
    };
    if weighted.is_empty() || b_y <= 0.0 {
        crate::bail!(
            "{}: no light reaches the image in {n} path-tracing samples (B_eye = 0); raise b_samples \
             or check the lights",
            scene.source.display()
        );
    }
    let mut cdf = Vec::with_capacity(weighted.len());
    let mut acc = 0.0;
    for w in &weighted {
        acc += w.y;
        cdf.push(acc);
    }
    let starts = (0..params.chains as u64)
        .into_par_iter()
        .map(|c| {
            let mut rng = Rng::for_task(seed, [crate::strategy::stream::CHAIN_START, c, 0]);
            let u = rng.uniform_f64() * acc;
            let pick = weighted[cdf.partition_point(|&x| x <= u).min(weighted.len() - 1)];
            regenerate(scene, max_edges, seed, pick)
        })
        .collect();
    Ok((estimate, starts))
}

/// Re-traces path-tracing sample `w.sample` and returns its `w.ordinal`-th path.
fn regenerate(scene: &Scene, max_edges: usize, seed: u64, w: Weighted) -> Vec<Vertex> {
    let mut rng = Rng::for_task(seed, [crate::strategy::stream::B_EYE, w.sample, 0]);
    let mut ordinal = 0u32;
    let mut found = Vec::new();
    path_tracing_sample(scene, max_edges, &mut rng, &mut |path, _| {
        if ordinal == w.ordinal {
            found = path.to_vec();
        }
        ordinal += 1;
    });
    found
}

/// A path with its contribution.
#[derive(Clone, Debug)]
pub struct State {
    pub path: Vec<Vertex>,
    pub f: Vec3,
    /// f_eye,Y: the luminance of f, the chain's scalar target.
    pub f_y: f32,
    pub raster: Vec2,
}

impl State {
    pub fn new(scene: &Scene, path: Vec<Vertex>) -> Option<Self> {
        let (f, raster) = contribution(scene, &path)?;
        let f_y = luminance(f);
        (f_y > 0.0 && f_y.is_finite()).then_some(Self { path, f, f_y, raster })
    }
}

/// Per-proposal tallies.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tally {
    pub proposed: [u64; PROPOSALS],
    pub accepted: [u64; PROPOSALS],
    /// Proposals that produced no path, or one with zero contribution.
    pub zero: [u64; PROPOSALS],
}

impl Tally {
    pub fn merge(&mut self, o: &Tally) {
        for i in 0..PROPOSALS {
            self.proposed[i] += o.proposed[i];
            self.accepted[i] += o.accepted[i];
            self.zero[i] += o.zero[i];
        }
    }

    /// Named counters for result rows.
    pub fn counters(&self) -> Vec<(String, f64)> {
        let mut out = Vec::new();
        for p in Proposal::ALL {
            let i = p as usize;
            if self.proposed[i] == 0 {
                continue;
            }
            out.push((format!("{}_proposed", p.name()), self.proposed[i] as f64));
            out.push((format!("{}_accepted", p.name()), self.accepted[i] as f64));
            out.push((format!("{}_zero", p.name()), self.zero[i] as f64));
        }
        // Sums only (result rows difference counters between checkpoints): the acceptance
        // rate is accepted / proposed.
        out
    }
}

/// The outcome of one step: the candidate (if any), its acceptance probability a, and the
/// decision (drawn with probability a). The chain has not moved yet: callers record the
/// current state with weight 1 − a and the candidate with weight a (expected values
/// [Veach 1997, §11.3.3]), then [`Chain::commit`].
pub struct Step {
    pub candidate: Option<State>,
    pub a: f32,
    pub accept: bool,
}

/// One Metropolis–Hastings chain.
pub struct Chain<'a> {
    pub ctx: Context<'a>,
    pub current: State,
}

impl<'a> Chain<'a> {
    pub fn new(ctx: Context<'a>, current: State) -> Self {
        Self { ctx, current }
    }

    /// Proposes and computes a.
    pub fn step(&self, rng: &mut Rng, tally: &mut Tally) -> Step {
        let mix = &self.ctx.params.proposals;
        let kind = mix.choose(rng.uniform_f64());
        tally.proposed[kind as usize] += 1;
        let candidate = self.propose(kind, rng);
        let Some((state, t_ratio)) = candidate.and_then(|c| State::new(self.ctx.scene, c.path).map(|s| (s, c.t_ratio)))
        else {
            tally.zero[kind as usize] += 1;
            return Step {
                candidate: None,
                a: 0.0,
                accept: false,
            };
        };
        let r = state.f_y as f64 / self.current.f_y as f64 * t_ratio;
        let a = if r.is_finite() { r.min(1.0) as f32 } else { 0.0 };
        let accept = rng.uniform() < a;
        tally.accepted[kind as usize] += u64::from(accept);
        Step {
            candidate: Some(state),
            a,
            accept,
        }
    }

    /// Moves to the candidate if the step accepted it.
    pub fn commit(&mut self, step: Step) {
        if step.accept
            && let Some(c) = step.candidate
        {
            self.current = c;
        }
    }

    fn propose(&self, kind: Proposal, rng: &mut Rng) -> Option<Candidate> {
        let ctx = &self.ctx;
        let x = &self.current.path;
        match kind {
            Proposal::Up | Proposal::Bd => self.up_bd(kind, rng),
            Proposal::Pm => proposals::photon_map(ctx, x, rng),
            Proposal::Cp => proposals::caustic_perturbation(ctx, x, rng),
            Proposal::Lp => proposals::lens_perturbation(ctx, x, rng),
            Proposal::Ls => proposals::lens_subpath(ctx, x, rng),
            Proposal::Mc => proposals::multi_chain_perturbation(ctx, x, rng),
        }
    }

    /// UP or BD, with the combined transition density of both [Fan et al. 2005, eq. (7)].
    fn up_bd(&self, kind: Proposal, rng: &mut Rng) -> Option<Candidate> {
        let ctx = &self.ctx;
        let x = &self.current.path;
        let (y, l, tail) = match kind {
            Proposal::Up => {
                let (y, tail) = proposals::user_path(ctx, x, rng)?;
                (y, 0, tail)
            }
            _ => proposals::bidirectional(ctx, x, rng)?,
        };
        let (p_up, p_bd) = (ctx.params.proposals.up, ctx.params.proposals.bd);
        let mut t_fwd = p_bd * proposals::bd_density(ctx, x, &y, l, tail);
        let mut t_rev = p_bd * proposals::bd_density(ctx, &y, x, l, tail);
        if p_up > 0.0 && l == 0 {
            // UP keeps x₀ and exactly the eye sub-path E S* D.
            if first_diffuse_from_eye(x) == Some(x.len() - tail) {
                t_fwd += p_up * proposals::up_density(ctx, &y, y.len() - tail);
            }
            if first_diffuse_from_eye(&y) == Some(y.len() - tail) {
                t_rev += p_up * proposals::up_density(ctx, x, x.len() - tail);
            }
        }
        (t_fwd > 0.0 && t_fwd.is_finite() && t_rev.is_finite()).then(|| Candidate {
            path: y,
            t_ratio: t_rev / t_fwd,
        })
    }
}

/// The incoming direction at vertex i of a path (toward x_{i−1}).
pub fn incoming(path: &[Vertex], i: usize) -> Vec3 {
    direction(&path[i], &path[i - 1]).0
}
