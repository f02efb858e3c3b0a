//! `bench perf`: throughput of the renderer core on a scene, measured in one process.
//!
//! - paths/s: camera samples per second of `path` (all threads);
//! - rays/s: closest-hit plus shadow rays those paths traced, per second;
//! - raw closest-hit rays/s: the same closest-hit rays replayed through the BVH alone (no
//!   shading, no sampling), the ceiling the path tracer could reach.
//!
//! Ray counts come from replaying the identical samples (same seeds) with a recording tally,
//! so the timed run carries no counting overhead. [`strategies`] measures every registered
//! strategy through the strategy trait (`bench perf --strategies`).

pub mod compare;
pub mod strategies;

pub use strategies::{StrategyThroughput, measure_experiment, measure_strategies};

use crate::geometry::Ray;
use crate::sampling::Rng;
use crate::sampling::stream;
use crate::scene::Scene;
use crate::strategy::path::{PathParams, RayTally, radiance, radiance_traced};
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// Throughput figures of one measurement.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PerfReport {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub max_depth: u32,
    pub threads: usize,
    pub seconds: f64,
    pub paths_per_s: f64,
    pub closest_rays: u64,
    pub shadow_rays: u64,
    pub rays_per_s: f64,
    pub raw_closest_rays_per_s: f64,
    /// Photon paths emitted per second by photon tracing (all threads).
    pub photons_per_s: f64,
    /// Photons stored in the global map by that tracing.
    pub photons_stored: u64,
    /// k-nearest queries per second (k = 50) on that map, at surface points seen by the camera.
    pub knn_queries_per_s: f64,
    /// Jensen 1995 per-vertex pdfs built per second at those queries, as `photon_guided` builds
    /// them (k = 50 nearest on the vertex's side, 4 × 16 grid and its CDF) from the same photons.
    pub guided_pdfs_per_s: f64,
    /// Final-gather rays per second of `photon_map` (defaults, precomputed irradiance at every
    /// 4th photon, 1 spp over the image), lookups and shading included.
    pub gather_rays_per_s: f64,
    /// Metropolis steps per second with each proposal alone (NaN: UP without user paths).
    pub up_mutations_per_s: f64,
    pub bd_mutations_per_s: f64,
    pub pm_mutations_per_s: f64,
    pub cp_mutations_per_s: f64,
    pub lp_mutations_per_s: f64,
    pub ls_mutations_per_s: f64,
    pub mc_mutations_per_s: f64,
    /// Photons `mps` stores per second of its Metropolis sampling (defaults, importon
    /// normalisation, 200 000 steps).
    pub mps_photons_per_s: f64,
    /// The same with `photon_power = "paper"`: the chain and its deposits alone, without the
    /// importon density each stored photon's power is divided by (our correction).
    pub mps_paper_photons_per_s: f64,
    pub cpu: String,
    pub git_revision: String,
}

/// Counts rays, keeping closest-hit rays while `keep` is set (a bounded subset, for replay).
#[derive(Default)]
struct Recorder {
    closest: u64,
    shadow: u64,
    keep: bool,
    kept: Vec<Ray>,
}

/// Samples per pixel whose closest-hit rays are kept for the raw BVH replay.
const REPLAY_SPP: u32 = 4;

impl RayTally for Recorder {
    fn closest(&mut self, ray: &Ray) {
        self.closest += 1;
        if self.keep {
            self.kept.push(*ray);
        }
    }
    fn shadow(&mut self, _: &Ray) {
        self.shadow += 1;
    }
}

fn camera_ray(scene: &Scene, seed: u64, pixel: usize, s: u32) -> (Ray, Rng) {
    let mut rng = Rng::for_task(seed, [stream::CAMERA_PATH, pixel as u64, s as u64]);
    let raster = scene.camera.sample_raster(pixel, rng.uniform2());
    (scene.camera.generate_ray(raster), rng)
}

/// Measures `path` with `params` at `spp` samples per pixel on `scene`.
pub fn measure_path(scene: &Scene, params: &PathParams, spp: u32) -> PerfReport {
    let seed = 0;
    let pixels = scene.camera.pixel_count();
    let sum_paths = |pixel: usize| -> f32 {
        (0..spp)
            .map(|s| {
                let (ray, mut rng) = camera_ray(scene, seed, pixel, s);
                radiance(scene, params, ray, &mut rng).x
            })
            .sum()
    };
    // Warm up caches and the thread pool on a slice of the image, then time the whole image.
    let _: f32 = (0..pixels.min(4096)).into_par_iter().map(sum_paths).sum();
    let start = Instant::now();
    let checksum: f32 = (0..pixels).into_par_iter().map(sum_paths).sum();
    let seconds = start.elapsed().as_secs_f64();
    std::hint::black_box(checksum);

    // Replay the same samples, recording their rays.
    let recorded: Vec<Recorder> = (0..pixels)
        .into_par_iter()
        .map(|pixel| {
            let mut rec = Recorder::default();
            for s in 0..spp {
                rec.keep = s < REPLAY_SPP;
                let (ray, mut rng) = camera_ray(scene, seed, pixel, s);
                radiance_traced(scene, params, ray, &mut rng, &mut rec);
            }
            rec
        })
        .collect();
    let closest_rays: u64 = recorded.iter().map(|r| r.closest).sum();
    let kept: u64 = recorded.iter().map(|r| r.kept.len() as u64).sum();
    let shadow_rays: u64 = recorded.iter().map(|r| r.shadow).sum();

    let start = Instant::now();
    let hits: usize = recorded
        .par_iter()
        .map(|r| r.kept.iter().filter(|ray| scene.accel.intersect(ray).is_some()).count())
        .sum();
    let raw_s = start.elapsed().as_secs_f64();
    std::hint::black_box(hits);

    let photons = measure_photons(scene, seed);
    let gather_rays_per_s = measure_gather(scene, seed);
    let mutations = measure_mutations(scene, seed);
    PerfReport {
        gather_rays_per_s,
        up_mutations_per_s: mutations[0],
        bd_mutations_per_s: mutations[1],
        pm_mutations_per_s: mutations[2],
        cp_mutations_per_s: mutations[3],
        lp_mutations_per_s: mutations[4],
        ls_mutations_per_s: mutations[5],
        mc_mutations_per_s: mutations[6],
        mps_photons_per_s: measure_mps_photons(scene, seed, "importon"),
        mps_paper_photons_per_s: measure_mps_photons(scene, seed, "paper"),
        photons_per_s: photons.0,
        photons_stored: photons.1,
        knn_queries_per_s: photons.2,
        guided_pdfs_per_s: photons.3,
        scene: scene.name.clone(),
        width: scene.camera.width,
        height: scene.camera.height,
        spp,
        max_depth: params.max_depth,
        threads: rayon::current_num_threads(),
        seconds,
        paths_per_s: (pixels as u64 * spp as u64) as f64 / seconds,
        closest_rays,
        shadow_rays,
        rays_per_s: (closest_rays + shadow_rays) as f64 / seconds,
        raw_closest_rays_per_s: kept as f64 / raw_s,
        cpu: crate::util::cpu_model(),
        git_revision: crate::util::git_revision(),
    }
}

/// Photon paths emitted by `bench perf`'s photon-tracing measurement.
pub const PERF_PHOTONS: u64 = 200_000;

/// Photon tracing ([`PERF_PHOTONS`] paths), then k = 50 nearest queries at the first hits of
/// camera rays and Jensen grids built from their photons: (photons/s, stored, queries/s,
/// grids/s).
fn measure_photons(scene: &Scene, seed: u64) -> (f64, u64, f64, f64) {
    use crate::photon::{PhotonMap, TraceParams, trace_photons};
    use crate::strategy::photon_guided::{GridSampler, GuideMap, GuidePhoton, PhotonGuidedParams};
    let params = TraceParams {
        photons: PERF_PHOTONS,
        ..TraceParams::default()
    };
    let start = Instant::now();
    let traced = trace_photons(scene, &params, seed);
    let photons_per_s = params.photons as f64 / start.elapsed().as_secs_f64();
    let stored = traced.global.len() as u64;
    let map = PhotonMap::build(traced.global);
    let pixels = scene.camera.pixel_count();
    let queries: Vec<crate::scene::SurfaceHit> = (0..pixels)
        .step_by((pixels / 100_000).max(1))
        .filter_map(|pixel| {
            let (ray, _) = camera_ray(scene, seed + 1, pixel, 0);
            scene.intersect(&ray)
        })
        .collect();
    let start = Instant::now();
    let found: usize = queries
        .par_iter()
        .map_init(Vec::new, |buf, hit| {
            map.tree().k_nearest_into(hit.p, 50, f32::INFINITY, |_| true, buf);
            buf.len()
        })
        .sum();
    let knn_s = start.elapsed().as_secs_f64();
    std::hint::black_box(found);
    // Jensen's per-vertex pdf exactly as `photon_guided` builds it (its defaults: N = 50,
    // unbounded radius, 4 × 16 cells), from the same photons decoded once as it does.
    let guide = GuideMap::build(map.photons().iter().map(GuidePhoton::decoded).collect());
    let params = PhotonGuidedParams::default();
    let sampler = GridSampler {
        map: &guide,
        params: &params,
        records: None,
    };
    let start = Instant::now();
    let grids: usize = queries
        .par_iter()
        .map(|hit| sampler.grid_at(hit, false).cell_count())
        .sum();
    let grid_s = start.elapsed().as_secs_f64();
    std::hint::black_box(grids);
    let q = queries.len().max(1) as f64;
    (photons_per_s, stored, q / knn_s, q / grid_s)
}

/// Final-gather rays per second of `photon_map` with precomputed irradiance (every 4th
/// photon), rendering 1 spp of the whole image after preparation.
fn measure_gather(scene: &Scene, seed: u64) -> f64 {
    use crate::strategy::Strategy;
    use crate::strategy::photon_map::{PhotonMapParams, PhotonMapStrategy, Precomputed};
    let params = PhotonMapParams {
        precomputed_irradiance: Some(Precomputed::default()),
        ..PhotonMapParams::default()
    };
    let Ok(mut strategy) = PhotonMapStrategy::new(params) else {
        return f64::NAN;
    };
    if strategy.prepare(scene, seed).is_err() {
        return f64::NAN;
    }
    let mut film = crate::film::Film::new(scene.camera.width, scene.camera.height);
    let start = Instant::now();
    strategy.render_pass(scene, seed, 0..1, &mut film);
    strategy.work().gather_rays as f64 / start.elapsed().as_secs_f64()
}

/// Metropolis steps per second of each proposal alone (UP with a chain that is UP alone,
/// which validation refuses for rendering but is fine for timing), 64 chains of 5000 steps
/// from path-tracing first states; NaN where a proposal cannot run.
fn measure_mutations(scene: &Scene, seed: u64) -> [f64; crate::metropolis::PROPOSALS] {
    use crate::metropolis::proposals::Context;
    use crate::metropolis::{Chain, MetropolisParams, Proposal, ProposalMix, State, Tally, estimate_b};
    let base = MetropolisParams {
        b_samples: Some(20_000),
        ..MetropolisParams::default()
    };
    let Ok((_, starts)) = estimate_b(scene, &base, seed) else {
        return [f64::NAN; crate::metropolis::PROPOSALS];
    };
    let user_paths = crate::metropolis::prepare_user_paths(scene).unwrap_or_default();
    let starts: Vec<State> = starts.into_iter().filter_map(|p| State::new(scene, p)).collect();
    Proposal::ALL.map(|kind| {
        if kind == Proposal::Up && user_paths.is_empty() {
            return f64::NAN;
        }
        let params = MetropolisParams {
            proposals: ProposalMix::only(kind),
            ..base.clone()
        };
        const STEPS: u64 = 5000;
        let start = Instant::now();
        let accepted: u64 = starts
            .par_iter()
            .enumerate()
            .map(|(c, s)| {
                let ctx = Context::new(scene, &params, &user_paths);
                let mut chain = Chain::new(ctx, s.clone());
                let mut rng = Rng::for_task(seed, [stream::CHAIN, c as u64, 0]);
                let mut tally = Tally::default();
                for _ in 0..STEPS {
                    let step = chain.step(&mut rng, &mut tally);
                    chain.commit(step);
                }
                tally.accepted.iter().sum::<u64>()
            })
            .sum();
        std::hint::black_box(accepted);
        (starts.len() as u64 * STEPS) as f64 / start.elapsed().as_secs_f64()
    })
}

/// Photons stored per second of `mps`'s Metropolis sampling phase (defaults but
/// `photon_power`).
fn measure_mps_photons(scene: &Scene, seed: u64, photon_power: &str) -> f64 {
    use crate::strategy::Strategy;
    let mut table = toml::Table::new();
    table.insert("photon_power".into(), photon_power.into());
    let Ok(mut mps) = crate::strategy::mps::Mps::from_table(table) else {
        return f64::NAN;
    };
    let Ok(phases) = mps.prepare(scene, seed) else {
        return f64::NAN;
    };
    let seconds: f64 = phases
        .iter()
        .filter(|p| p.name == "photon_sampling")
        .map(|p| p.seconds)
        .sum();
    let stored: f64 = mps
        .counters()
        .iter()
        .filter(|(k, _)| k == "global_photons" || k == "caustic_photons")
        .map(|(_, v)| v)
        .sum();
    stored / seconds
}

/// Appends `rows` to a CSV file (header written when the file is new): `bench perf --csv`
/// collects measurements of many runs and machines in one file. A file whose header differs
/// from this version's columns (written before a column was added) is refused, not
/// misaligned.
pub fn append_csv<T: serde::Serialize>(rows: &[T], path: &std::path::Path) -> crate::Result<()> {
    use crate::error::Context;
    let exists = path.exists();
    if let (true, Some(first)) = (exists, rows.first()) {
        let mut header = csv::Writer::from_writer(Vec::new());
        header.serialize(first).context(path.display())?;
        let expected = String::from_utf8_lossy(&header.into_inner().unwrap_or_default())
            .lines()
            .next()
            .unwrap_or_default()
            .to_string();
        let existing = std::fs::read_to_string(path).context(path.display())?;
        let found = existing.lines().next().unwrap_or_default();
        if !existing.is_empty() && found != expected {
            crate::bail!(
                "{}: its columns ({found}) are not this version's ({expected}); append to a new file",
                path.display()
            );
        }
    }
    let file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .context(path.display())?;
    let mut w = csv::WriterBuilder::new().has_headers(!exists).from_writer(file);
    for row in rows {
        w.serialize(row).context(path.display())?;
    }
    w.flush().context(path.display())
}

/// One point of `bench perf --photon-scale`: photon tracing, kd-tree build and k-NN queries at
/// one global-map size N, with the scene's BVH build for scale.
#[derive(Clone, Debug, serde::Serialize)]
pub struct ScalePoint {
    pub scene: String,
    /// Triangles and spheres of the scene.
    pub primitives: usize,
    /// Seconds to build the scene's BVH (median of 3).
    pub bvh_build_s: f64,
    /// Photon paths emitted per second by the trace that produced the photons (all threads).
    pub photons_emitted_per_s: f64,
    /// Photons stored per second by that trace.
    pub photons_stored_per_s: f64,
    /// N: global-map photons in the kd-tree (the first N stored).
    pub photons: usize,
    /// Seconds to build the balanced kd-tree over N photons (median of 3, all threads).
    pub kdtree_build_s: f64,
    /// `kdtree_build_s / (N log2 N)` in nanoseconds: flat when the build is O(N log N).
    pub kdtree_build_ns_per_n_log2_n: f64,
    /// k = 50 nearest-neighbour queries (unbounded radius) per second at fixed non-delta
    /// surface points seen by the camera (where estimates are made), all threads.
    pub knn_queries_per_s: f64,
    pub queries: usize,
    pub threads: usize,
    pub cpu: String,
    pub git_revision: String,
}

/// Median of three timings of `f`, in seconds.
fn median3_s(mut f: impl FnMut()) -> f64 {
    let mut t: [f64; 3] = std::array::from_fn(|_| {
        let start = Instant::now();
        f();
        start.elapsed().as_secs_f64()
    });
    t.sort_by(f64::total_cmp);
    t[1]
}

/// `bench perf --photon-scale`: traces enough photons in `scene` to store the largest of
/// `sizes` (doubling the emitted count from 100 000 until it does), then for each N in `sizes`
/// builds the kd-tree over the first N stored photons and times k = 50 queries at the first
/// hits of `queries` camera rays that land on non-delta surfaces (the same points for every N: a balanced tree answers in
/// O(log N + k), so the rate should fall slowly with N).
pub fn measure_photon_scale(scene: &Scene, sizes: &[usize], queries: usize) -> Vec<ScalePoint> {
    use crate::photon::{KdTree, TraceParams, trace_photons};
    let seed = 0;
    let bvh_build_s = median3_s(|| {
        std::hint::black_box(crate::geometry::Accel::build(&scene.primitives));
    });
    let largest = sizes.iter().copied().max().unwrap_or(0);
    let mut emitted = 100_000u64;
    let (traced, trace_s) = loop {
        let params = TraceParams {
            photons: emitted,
            ..TraceParams::default()
        };
        let start = Instant::now();
        let traced = trace_photons(scene, &params, seed);
        let s = start.elapsed().as_secs_f64();
        if traced.global.len() >= largest || emitted >= 1 << 26 {
            break (traced, s);
        }
        emitted *= 2;
    };
    let stored = traced.global.len() + traced.caustic.len();
    let pixels = scene.camera.pixel_count();
    let points: Vec<Vec3> = (0..queries)
        .filter_map(|i| {
            let (ray, _) = camera_ray(scene, seed + 1, i % pixels, (i / pixels) as u32);
            // Only where estimates are made: delta surfaces (mirror, glass) hold no photons,
            // and an unbounded search from one sweeps a large ball.
            scene.intersect(&ray).filter(|h| !scene.bsdf(h).is_delta()).map(|h| h.p)
        })
        .collect();
    sizes
        .iter()
        .filter(|&&n| n <= traced.global.len())
        .map(|&n| {
            let photons = &traced.global[..n];
            let kdtree_build_s = median3_s(|| {
                std::hint::black_box(KdTree::build(photons.to_vec()));
            });
            let tree = KdTree::build(photons.to_vec());
            let start = Instant::now();
            let found: usize = points
                .par_iter()
                .map_init(Vec::new, |buf, &p| {
                    tree.k_nearest_into(p, 50, f32::INFINITY, |_| true, buf);
                    buf.len()
                })
                .sum();
            let knn_s = start.elapsed().as_secs_f64();
            std::hint::black_box(found);
            ScalePoint {
                scene: scene.name.clone(),
                primitives: scene.primitives.len(),
                bvh_build_s,
                photons_emitted_per_s: emitted as f64 / trace_s,
                photons_stored_per_s: stored as f64 / trace_s,
                photons: n,
                kdtree_build_s,
                kdtree_build_ns_per_n_log2_n: kdtree_build_s * 1e9 / (n as f64 * (n as f64).log2()),
                knn_queries_per_s: points.len() as f64 / knn_s,
                queries: points.len(),
                threads: rayon::current_num_threads(),
                cpu: crate::util::cpu_model(),
                git_revision: crate::util::git_revision(),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::append_csv;

    #[derive(serde::Serialize)]
    struct Old {
        a: u32,
    }

    #[derive(serde::Serialize)]
    struct New {
        a: u32,
        b: u32,
    }

    #[test]
    fn appending_with_other_columns_is_refused_and_leaves_the_file_alone() {
        let dir = std::env::temp_dir().join(format!("photon-bench-append-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("perf.csv");
        let _ = std::fs::remove_file(&path);
        append_csv(&[Old { a: 1 }], &path).unwrap();
        append_csv(&[Old { a: 2 }], &path).unwrap();
        let before = std::fs::read_to_string(&path).unwrap();
        assert_eq!(before, "a\n1\n2\n");
        let err = append_csv(&[New { a: 3, b: 4 }], &path).unwrap_err().to_string();
        assert!(
            err.contains("perf.csv") && err.contains("(a)") && err.contains("(a,b)"),
            "{err}"
        );
        assert_eq!(std::fs::read_to_string(&path).unwrap(), before);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
