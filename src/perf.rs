//! `bench perf`: throughput of the renderer core on a scene, measured in one process.
//!
//! - paths/s: camera samples per second of `path` (all threads);
//! - rays/s: closest-hit plus shadow rays those paths traced, per second;
//! - raw closest-hit rays/s: the same closest-hit rays replayed through the BVH alone (no
//!   shading, no sampling), the ceiling the path tracer could reach.
//!
//! Ray counts come from replaying the identical samples (same seeds) with a recording tally,
//! so the timed run carries no counting overhead.

use crate::geometry::Ray;
use crate::sampling::Rng;
use crate::scene::Scene;
use crate::strategy::path::{PathParams, RayTally, radiance, radiance_traced};
use crate::strategy::stream;
use glam::Vec2;
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
    let w = scene.camera.width as usize;
    let mut rng = Rng::for_task(seed, [stream::CAMERA_PATH, pixel as u64, s as u64]);
    let raster = Vec2::new((pixel % w) as f32, (pixel / w) as f32) + rng.uniform2();
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

    PerfReport {
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

/// Appends `report` to a CSV file (header written when the file is new).
pub fn append_csv(report: &PerfReport, path: &std::path::Path) -> crate::Result<()> {
    use crate::error::Context;
    let exists = path.exists();
    let file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .context(path.display())?;
    let mut w = csv::WriterBuilder::new().has_headers(!exists).from_writer(file);
    w.serialize(report).context(path.display())?;
    w.flush().context(path.display())
}
