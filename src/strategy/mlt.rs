//! `kind = "mlt"`: Metropolis light transport [Veach 1997, ch. 11] with the proposals of
//! Metropolis photon sampling: the chain of [`crate::metropolis`], whose paths splat straight
//! into the image (the paper's Fig. 3). It is the most direct check that the chain samples
//! f_eye: its image must converge to the path-traced one.
//!
//! One *sample* (the `spp` unit of experiments) is W × H mutations in total, spread over a
//! fixed number of chains. Sample s of chain c draws from the stream `[CHAIN, c, s]`, and
//! chains resume from where the previous pass stopped, so any split into passes gives the
//! bit-identical image on any number of threads. Pixel j of sample s receives
//! (B / M) Σ_mutations (1 − a) h_j(X) f(X)/f_Y(X) + a h_j(Y) f(Y)/f_Y(Y) (expected-value
//! splatting [Veach 1997, §11.3.3], M = W × H, B the path-traced B_eye), and the film averages
//! the samples.
//!
//! Parameters: those of [`MetropolisParams`] (proposal mix, `max_depth`, `b_samples`,
//! `chains`, perturbation sizes); the scene's user paths feed UP.

use super::{Declared, Phase, Strategy};
use crate::error::Result;
use crate::film::Film;
use crate::metropolis::proposals::Context;
use crate::metropolis::{BEstimate, Chain, MetropolisParams, State, Tally, UserPathInfo, chain_share, prepare_chains};
use crate::params::Params;
use crate::sampling::Rng;
use crate::scene::Scene;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::ops::Range;
use std::sync::Mutex;
use std::time::Instant;

/// What `prepare` computes.
struct Prepared {
    b: BEstimate,
    starts: Vec<State>,
    user_paths: Vec<UserPathInfo>,
}

/// Contributions (pixel index, value) one chain adds in one sample.
type Splats = Vec<(u32, Vec3)>;

/// Chain states between passes.
#[derive(Default)]
struct Progress {
    seed: u64,
    next_sample: u32,
    states: Vec<State>,
    tally: Tally,
}

pub struct Mlt {
    pub params: MetropolisParams,
    prepared: Option<Prepared>,
    progress: Mutex<Progress>,
}

impl Mlt {
    pub fn new(params: MetropolisParams) -> Result<Self> {
        params.check("")?;
        Ok(Self {
            params,
            prepared: None,
            progress: Mutex::new(Progress::default()),
        })
    }
}

impl Declared for Mlt {
    const KIND: &'static str = "mlt";
    const SUMMARY: &'static str =
        "Metropolis light transport with the MPS proposals, splatting paths (Veach 1997; Fan et al. 2005)";
    type Params = MetropolisParams;

    fn new(params: MetropolisParams) -> Result<Self> {
        Self::new(params)
    }
}

impl Strategy for Mlt {
    fn capabilities(&self) -> crate::strategy::Capabilities {
        crate::strategy::Capabilities {
            // The acceptance of a bidirectional proposal needs the true density of each
            // regenerated direction, which layered models only estimate.
            stochastic_bsdfs: false,
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
        let start = Instant::now();
        let (b, starts, user_paths) = prepare_chains(scene, &self.params, seed)?;
        *self.progress.lock().unwrap() = Progress::default();
        self.prepared = Some(Prepared { b, starts, user_paths });
        Ok(vec![Phase {
            name: "b_eye",
            seconds: start.elapsed().as_secs_f64(),
        }])
    }

    fn render_pass(&self, scene: &Scene, seed: u64, samples: Range<u32>, film: &mut Film) {
        let Some(prep) = &self.prepared else { return };
        let mut progress = self.progress.lock().unwrap();
        if progress.states.is_empty() || progress.seed != seed || progress.next_sample > samples.start {
            // Replays count as work done: the tally runs on since `prepare`.
            let tally = progress.tally;
            *progress = Progress {
                seed,
                next_sample: 0,
                states: prep.starts.clone(),
                tally,
            };
        }
        let pixels = scene.camera.pixel_count();
        let ctx = || Context::new(scene, &self.params, &prep.user_paths);
        while progress.next_sample < samples.end {
            let s = progress.next_sample;
            let splat = s >= samples.start;
            let chains = progress.states.len() as u64;
            let results: Vec<(State, Splats, Tally)> = progress
                .states
                .par_iter()
                .enumerate()
                .map(|(c, state)| {
                    let mut chain = Chain::new(ctx(), state.clone());
                    let mut rng = Rng::for_task(seed, [crate::sampling::stream::CHAIN, c as u64, s as u64]);
                    let mut tally = Tally::default();
                    let mut splats = Vec::new();
                    let splat_at = |st: &State, value: Vec3, rng: &mut Rng, splats: &mut Splats| {
                        splats.extend(scene.camera.splat(st.raster, rng).map(|(p, w)| (p, value * w)));
                    };
                    for _ in 0..chain_share(pixels as u64, chains, c as u64) {
                        let step = chain.step(&mut rng, &mut tally);
                        if splat {
                            let cur = &chain.current;
                            splat_at(cur, cur.f / cur.f_y * (1.0 - step.a), &mut rng, &mut splats);
                            if let Some(cand) = &step.candidate
                                && step.a > 0.0
                            {
                                splat_at(cand, cand.f / cand.f_y * step.a, &mut rng, &mut splats);
                            }
                        }
                        chain.commit(step);
                    }
                    (chain.current, splats, tally)
                })
                .collect();
            let mut image = vec![DVec3::ZERO; pixels];
            for (c, (state, splats, tally)) in results.into_iter().enumerate() {
                progress.states[c] = state;
                progress.tally.merge(&tally);
                for (p, v) in splats {
                    image[p as usize] += v.as_dvec3();
                }
            }
            if splat {
                let scale = prep.b.b_y / pixels as f64;
                let width = scene.camera.width as usize;
                film.rows_mut().for_each(|(y, row)| {
                    for (x, acc) in row.iter_mut().enumerate() {
                        acc.add((image[y * width + x] * scale).as_vec3());
                    }
                });
            }
            progress.next_sample += 1;
        }
    }

    fn counters(&self) -> Vec<(String, f64)> {
        let Some(prep) = &self.prepared else { return Vec::new() };
        let mut out = vec![
            ("b_eye".to_string(), prep.b.b_y),
            ("b_eye_std_error".to_string(), prep.b.std_error),
        ];
        out.extend(self.progress.lock().unwrap().tally.counters());
        out
    }
}
