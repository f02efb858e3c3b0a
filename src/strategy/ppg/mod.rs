//! `kind = "ppg"`: practical path guiding [Müller, Gross & Novák 2017] — the modern successor
//! of Jensen 1995's photon-guided pdf: path tracing whose directions are drawn from a mixture of
//! the BSDF and a learned approximation of the incident radiance, an SD-tree ([`sdtree`])
//! trained on the renderer's own paths.
//!
//! **Training** (`prepare`, timed as the phase `training`) [§4]: iteration k = 0 … n − 1
//! renders 2^k samples per pixel (doubling budgets) guided by the tree of iteration k − 1
//! (uniform directions where nothing was learned yet); every non-delta vertex records its
//! incident-radiance estimate L_i(x, ω_i) / p(ω_i) — the MIS-weighted emission and next-event
//! contributions the rest of the path gathered, divided by the throughput up to x — into the
//! D-tree of its S-tree leaf. After each iteration the S-tree splits leaves with more than
//! c √(2^k) records and each D-tree is rebuilt where a quadrant holds more than ρ of its energy
//! ([`sdtree::SdTree::end_iteration`]).
//!
//! **Rendering**: path tracing (`path`'s walk, next-event estimation and MIS) with directions
//! from the one-sample mixture p = α p_bsdf + (1 − α) p_guide [§5.1, α = ½], the guide being
//! the trained tree, frozen: every render pass reads it only, so the image is bit-identical
//! on any number of threads and for any split into passes; MIS of next-event estimation uses
//! the mixture's pdf. Delta BSDFs sample themselves.
//!
//! **Decision: Russian roulette on the albedo.** The guided weight f_s |cos| / p is small exactly
//! for the directions guiding favours (towards bright light), so roulette on the throughput
//! kills the paths guiding aimed best — as it did for Jensen 1995's guide ([`Roulette`]).
//! Measured on `cornell-empty` (64 spp, 2 seeds, α = ½, c = 1 000, 7 iterations): MSE 0.61
//! with throughput roulette, 0.36 with albedo roulette, 0.78 for `path`. The paper does not
//! specify its roulette; `roulette = "throughput"` keeps the other choice.
//!
//! **Which iterations make the image** (`combine`). `"inverse_variance"` (the default): the
//! images of the training iterations and the final render, each weighted by the inverse of its
//! estimated variance [Müller 2019, course notes; [`combine`]] — the final render's weight
//! grows as its samples accumulate, and the film's mean after n samples is the combination
//! (it receives n C(n) minus what it holds, as `sppm`'s film does). `"last"`: only the samples
//! rendered after training, as the 2017 paper keeps its final iteration. Either way the
//! training time counts in equal-time budgets as preparation.
//!
//! Randomness: training sample i of pixel p, `[PPG_TRAIN, p, i]` (i counts over all
//! iterations); rendering uses `path`'s camera streams. Training records are gathered per fixed
//! chunk of pixels and added to the tree in chunk order.

pub mod combine;
pub mod sdtree;

use super::path::{BsdfSampling, Direct, DirectionSampler, RayTally, Roulette, Walk, trace};
use super::{Declared, Phase, Strategy, pixel_sample, render_pixels};
use crate::bsdf::{Bsdf, BsdfSample, TransportMode};
use crate::error::Result;
use crate::film::Film;
use crate::geometry::{Frame, Ray};
use crate::light::LightSampling;
use crate::params::{Params, Range};
use crate::sampling::{Rng, stream};
use crate::scene::{Scene, SurfaceHit};
use combine::{Moments, weights};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use sdtree::SdTree;
use std::ops::Range as Samples;
use std::sync::Mutex;
use std::time::Instant;

/// Pixels per training task (a fixed split: records reach the tree in the same order on any
/// number of threads).
const CHUNK: usize = 1024;
/// Training chunks whose records are held at once.
const BATCH: usize = 16;

crate::declare_choice! {
    /// Which images make the result: every iteration weighted by inverse variance, or the
    /// samples after training only.
    pub enum Combine { InverseVariance = "inverse_variance", Last = "last" }
}

crate::declare_params! {
    /// Parameters of `kind = "ppg"`; the defaults are the paper's.
    pub struct PpgParams {
        /// Training iterations n: 1 + 2 + … + 2^(n−1) = 2^n − 1 samples per pixel of training.
        training_iterations: u32 = 5, range Range::int(0, 12);
        /// c, the S-tree split threshold: a leaf splits past c √(2^k) records [§3.3].
        spatial_threshold: f64 = 12_000.0, range Range::positive();
        /// ρ, the energy fraction past which a D-tree quadrant is subdivided [§3.3].
        energy_threshold: f64 = 0.01, range Range::above_to(0.0, 1.0).of("a fraction");
        /// α, the probability of sampling the BSDF instead of the guide [§5.1]. Above 0: the
        /// guide gives no density to directions nothing was recorded in, so only the BSDF's
        /// share keeps every direction the integrand reaches sampled (unbiasedness).
        bsdf_fraction: f32 = 0.5, range Range::above_to(0.0, 1.0).of("a probability");
        /// Maximum number of scattering events (as `path`).
        max_depth: u32 = 16, range Range::int(0, 1024);
        /// Russian roulette starts after this many scattering events.
        rr_depth: u32 = 3, range Range::int(0, 1024);
        /// What Russian roulette follows (as `path`); albedo, as for `photon_guided` (module doc).
        roulette: Roulette = Roulette::Albedo;
        /// Which images make the result ([`Combine`]).
        combine: Combine = Combine::InverseVariance;
    }
}

/// The final render's state between passes (`combine = "inverse_variance"`).
#[derive(Default)]
struct Final {
    seed: u64,
    moments: Moments,
    /// What the film holds per pixel.
    shown: Vec<DVec3>,
}

/// Practical path guiding.
pub struct Ppg {
    params: PpgParams,
    tree: Option<SdTree>,
    /// The training iterations' images (`combine = "inverse_variance"`).
    iterations: Vec<Moments>,
    last: Mutex<Final>,
    training_paths: u64,
    records: u64,
}

impl Declared for Ppg {
    const KIND: &'static str = "ppg";
    const SUMMARY: &'static str = "practical path guiding: an SD-tree of incident radiance learned in doubling iterations, BSDF/guide mixture (Müller, Gross & Novák 2017)";
    type Params = PpgParams;

    fn new(params: PpgParams) -> Result<Self> {
        Ok(Self {
            params,
            tree: None,
            iterations: Vec::new(),
            last: Mutex::new(Final::default()),
            training_paths: 0,
            records: 0,
        })
    }
}

/// The guided direction sampler over a frozen tree.
struct Guide<'a> {
    tree: &'a SdTree,
    alpha: f32,
}

impl DirectionSampler for Guide<'_> {
    /// The D-tree's leaf and the shading frame (to map directions), or `None` at delta BSDFs.
    type Vertex = Option<(u32, Frame)>;

    fn vertex(&self, _: &Scene, hit: &SurfaceHit, bsdf: &Bsdf, _: Vec3) -> Self::Vertex {
        (!bsdf.is_delta()).then(|| (self.tree.leaf(hit.p), hit.frame))
    }

    fn sample(&self, v: &Self::Vertex, bsdf: &Bsdf, wo: Vec3, rng: &mut Rng) -> Option<BsdfSample> {
        let Some((leaf, frame)) = v else {
            return BsdfSampling::Importance.sample(&(), bsdf, wo, rng);
        };
        let guide = &self.tree.leaves[*leaf as usize].sampling;
        let u_choice = rng.uniform();
        let (wi, drawn) = if u_choice < self.alpha {
            let (u, u_lobe) = (rng.uniform2(), rng.uniform());
            let s = bsdf.sample(wo, u, u_lobe, TransportMode::Radiance)?;
            if s.delta {
                // A delta lobe of a mixed model (smooth plastic), reached only through this
                // branch: its probability is α times the BSDF's.
                return Some(BsdfSample {
                    pdf_w: s.pdf_w * self.alpha,
                    ..s
                });
            }
            (s.wi, Some(s))
        } else {
            (frame.to_local(guide.sample(|| rng.uniform())), None)
        };
        BsdfSample::of_mixture(bsdf, wo, wi, drawn.as_ref(), self.pdf(v, bsdf, wo, wi))
    }

    fn pdf(&self, v: &Self::Vertex, bsdf: &Bsdf, wo: Vec3, wi: Vec3) -> f32 {
        let Some((leaf, frame)) = v else {
            return bsdf.pdf(wo, wi);
        };
        let guide = &self.tree.leaves[*leaf as usize].sampling;
        self.alpha * bsdf.pdf(wo, wi) + (1.0 - self.alpha) * guide.pdf(frame.to_world(wi))
    }
}

/// A vertex of a training path, collecting the radiance the rest of the path finds.
struct TrainingVertex {
    p: Vec3,
    wi: Vec3,
    pdf_w: f32,
    beta: Vec3,
    radiance: Vec3,
}

/// Records a training path's vertices and what arrives at each ([`RayTally`]'s hooks).
#[derive(Default)]
struct Recorder {
    vertices: Vec<TrainingVertex>,
}

impl RayTally for Recorder {
    fn closest(&mut self, _: &Ray) {}
    fn shadow(&mut self, _: &Ray) {}

    fn scattered(&mut self, p: Vec3, wi: Vec3, pdf_w: f32, beta: Vec3, delta: bool) {
        if !delta {
            self.vertices.push(TrainingVertex {
                p,
                wi,
                pdf_w,
                beta,
                radiance: Vec3::ZERO,
            });
        }
    }

    fn contributed(&mut self, l: Vec3) {
        for v in &mut self.vertices {
            // L_i at v: the contribution divided by the throughput up to v's sampled direction.
            let r = l / v.beta;
            if r.is_finite() {
                v.radiance += r;
            }
        }
    }
}

/// One record for the tree: leaf position, direction, L_i / p.
type Record = (Vec3, Vec3, f64);

impl Ppg {
    fn walk(&self) -> Walk {
        Walk {
            max_depth: self.params.max_depth,
            rr_depth: self.params.rr_depth,
            roulette: self.params.roulette,
            direct: Direct::Mis,
            lights: LightSampling::default(),
        }
    }

    /// Iteration k: 2^k guided samples per pixel, their records added to the building trees.
    fn train_iteration(&mut self, scene: &Scene, seed: u64, k: u32, first_sample: u64) -> u64 {
        let tree = self.tree.take().expect("a tree to train");
        let walk = self.walk();
        let spp = 1u64 << k;
        let pixels = scene.camera.pixel_count();
        let guide = Guide {
            tree: &tree,
            alpha: self.params.bsdf_fraction,
        };
        let chunk_records = |c: usize| -> (Vec<Record>, Vec<DVec3>, Vec<f64>) {
            let mut records = Vec::new();
            let (mut sums, mut squares) = (Vec::new(), Vec::new());
            let mut rec = Recorder::default();
            for p in c * CHUNK..((c + 1) * CHUNK).min(pixels) {
                let (mut sum, mut sq) = (DVec3::ZERO, 0.0);
                for i in 0..spp {
                    let mut rng = Rng::for_task(seed, [stream::PPG_TRAIN, p as u64, first_sample + i]);
                    let raster = scene.camera.sample_raster(p, rng.uniform2());
                    let ray = scene.camera.sample_ray(raster, &mut rng);
                    rec.vertices.clear();
                    let l = trace(scene, &walk, &guide, ray, &mut rng, &mut rec);
                    if l.is_finite() {
                        sum += l.as_dvec3();
                        sq += (crate::color::luminance(l) as f64).powi(2);
                    }
                    records.extend(
                        rec.vertices
                            .iter()
                            .map(|v| (v.p, v.wi, crate::color::luminance(v.radiance) as f64 / v.pdf_w as f64)),
                    );
                }
                sums.push(sum);
                squares.push(sq);
            }
            (records, sums, squares)
        };
        // Batches of chunks bound the memory the records take; within a batch, chunk order.
        let chunks = pixels.div_ceil(CHUNK);
        let mut building: Vec<sdtree::DTree> = tree.leaves.iter().map(|l| l.building.clone()).collect();
        let mut count = 0u64;
        let (mut image_sums, mut image_squares) = (Vec::with_capacity(pixels), Vec::with_capacity(pixels));
        for batch in (0..chunks).step_by(BATCH) {
            let results: Vec<(Vec<Record>, Vec<DVec3>, Vec<f64>)> = (batch..(batch + BATCH).min(chunks))
                .into_par_iter()
                .map(chunk_records)
                .collect();
            for (records, sums, squares) in results {
                for (p, wi, value) in records {
                    building[tree.leaf(p) as usize].record(wi, value);
                    count += 1;
                }
                image_sums.extend(sums);
                image_squares.extend(squares);
            }
        }
        if self.params.combine == Combine::InverseVariance {
            self.iterations.push(Moments::from_sums(image_sums, image_squares, spp));
        }
        let mut tree = tree;
        for (leaf, b) in tree.leaves.iter_mut().zip(building) {
            leaf.building = b;
        }
        tree.end_iteration(k, self.params.spatial_threshold, self.params.energy_threshold);
        self.tree = Some(tree);
        self.training_paths += spp * pixels as u64;
        self.records += count;
        spp
    }
}

impl Ppg {
    /// Inverse-variance weights of the training images and the final render so far (last).
    /// Below 2 final samples per pixel, the final render's per-sample variance is taken from the
    /// last training iteration that has one.
    fn weights(&self, last: &Moments) -> Vec<f64> {
        let mut variances: Vec<Option<f64>> = self.iterations.iter().map(Moments::variance).collect();
        let per_sample = last.variance().map(|v| v * last.n as f64).or_else(|| {
            self.iterations
                .iter()
                .rev()
                .find_map(|m| m.variance().map(|v| v * m.n as f64))
        });
        variances.push(per_sample.map(|v| v / last.n.max(1) as f64));
        weights(&variances)
    }
}

impl Strategy for Ppg {
    fn capabilities(&self) -> crate::strategy::Capabilities {
        crate::strategy::Capabilities::ALL
    }

    fn kind(&self) -> &'static str {
        Self::KIND
    }

    fn params(&self) -> Vec<(String, String)> {
        self.params.columns()
    }

    fn prepare(&mut self, scene: &Scene, seed: u64) -> Result<Vec<Phase>> {
        let start = Instant::now();
        let (lo, hi) = scene.bounds();
        self.tree = Some(SdTree::new(lo, hi));
        self.iterations.clear();
        *self.last.get_mut().unwrap() = Final::default();
        self.training_paths = 0;
        self.records = 0;
        let mut done = 0u64;
        for k in 0..self.params.training_iterations {
            done += self.train_iteration(scene, seed, k, done);
        }
        Ok(vec![Phase {
            name: "training",
            seconds: start.elapsed().as_secs_f64(),
        }])
    }

    fn render_pass(&self, scene: &Scene, seed: u64, samples: Samples<u32>, film: &mut Film) {
        let Some(tree) = &self.tree else { return };
        let walk = self.walk();
        let guide = Guide {
            tree,
            alpha: self.params.bsdf_fraction,
        };
        let radiance = |ray: &Ray, rng: &mut Rng| trace(scene, &walk, &guide, *ray, rng, &mut ());
        if self.params.combine == Combine::Last {
            render_pixels(scene, seed, samples, film, radiance);
            return;
        }
        let pixels = scene.camera.pixel_count();
        let width = scene.camera.width as usize;
        let mut state = self.last.lock().unwrap();
        if state.shown.is_empty() || state.seed != seed || state.moments.n > samples.start as u64 {
            *state = Final {
                seed,
                moments: Moments::new(pixels),
                shown: vec![DVec3::ZERO; pixels],
            };
        }
        let Final { moments, shown, .. } = &mut *state;
        for s in moments.n as u32..samples.end {
            let values: Vec<Vec3> = (0..pixels)
                .into_par_iter()
                .map(|p| pixel_sample(scene, seed, p, s, &radiance))
                .collect();
            moments.add_pass(&values);
            if s < samples.start {
                continue;
            }
            let w = self.weights(moments);
            let k = moments.n as f64;
            let (moments, iterations) = (&*moments, &self.iterations);
            film.rows_mut()
                .zip(shown.par_chunks_mut(width))
                .for_each(|((y, row), held_row)| {
                    for (x, (acc, held)) in row.iter_mut().zip(held_row).enumerate() {
                        let p = y * width + x;
                        let mut c = moments.mean(p) * w[iterations.len()];
                        for (image, wi) in iterations.iter().zip(&w) {
                            if *wi > 0.0 {
                                c += image.mean(p) * *wi;
                            }
                        }
                        // The film's mean after k samples must be C(k): give it what it lacks.
                        let value = (c * k - *held).as_vec3();
                        acc.add(value);
                        if value.is_finite() {
                            *held += value.as_dvec3();
                        }
                    }
                });
        }
    }

    fn counters(&self) -> Vec<(String, f64)> {
        let Some(tree) = &self.tree else { return Vec::new() };
        vec![
            ("training_paths".into(), self.training_paths as f64),
            ("training_records".into(), self.records as f64),
            ("stree_leaves".into(), tree.leaves.len() as f64),
            ("dtree_nodes".into(), tree.dtree_nodes() as f64),
        ]
    }
}

#[cfg(test)]
mod tests;
