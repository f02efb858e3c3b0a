//! Running the chains: each chain's mutations in fixed blocks from its own stream, every
//! accepted or rejected state deposited at its storage point with expected-value weights
//! [Veach 1997, §11.3.3], deposits merged and stored as photons.

use super::*;
use crate::metropolis::chain_share;
use crate::metropolis::proposals::Context;
use crate::metropolis::{Chain, State, Tally};
use crate::photon::Photon;
use crate::sampling::Rng;
use crate::scene::Scene;
use rayon::prelude::*;

/// Photons of all chains, in chain order.
#[derive(Default)]
pub(super) struct Sampled {
    pub(super) global: Vec<Photon>,
    pub(super) caustic: Vec<Photon>,
    pub(super) tally: Tally,
    pub(super) unseen: usize,
}

/// Runs the chains for `mutations` iterations in total and stores their photons.
pub(super) fn sample_photons(
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
pub(super) fn store(out: &mut Sampled, d: Deposit, importons: Option<&Importons>, scene: &Scene, probe_rng: &mut Rng) {
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
