//! One Metropolis–Hastings chain: its state, one step (propose, accept with a, commit) and the
//! per-proposal tallies.

use super::params::{PROPOSALS, Proposal};
use super::proposals::{self, Candidate, Context};
use crate::color::luminance;
use crate::path_space::{Vertex, contribution, direction, first_diffuse_from_eye};
use crate::sampling::Rng;
use crate::scene::Scene;
use glam::{Vec2, Vec3};

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
