//! `kind = "ppm"` and `kind = "sppm"`: progressive photon mapping [Hachisuka, Ogaki & Jensen
//! 2008] and stochastic progressive photon mapping [Hachisuka & Jensen 2009], the consistent
//! successors of photon mapping with final gathering: the photon density estimate's radius
//! shrinks as photons accumulate, so bias and variance both vanish.
//!
//! **The estimator.** Each *estimate slot* i (a fixed hit point in `ppm`, a pixel in `sppm`)
//! keeps a radius R_i, an accumulated photon count N_i and the accumulated flux τ_i. A pass
//! traces N_e photon paths; at the slot's visible point x (with eye throughput β) the photons
//! p within R_i deposit Φ_i = β Σ_p f_s(x, ω, ω_p) ΔΦ_p, and M_i of them are counted
//! ([`photons::gather`]). Then [Hachisuka et al. 2008, eqs. (8)–(12); Hachisuka & Jensen
//! 2009, eqs. (4)–(6)]
//!   N_i ← N_i + α M_i,   R_i ← R_i √((N_i + α M_i) / (N_i + M_i)),
//!   τ_i ← (τ_i + Φ_i) R_i'² / R_i²,
//! and after k passes the slot's radiance is L_i = D_i / k + τ_i / (k π R_i²), where D_i sums
//! each pass's direct light ([`eye`]) and every ΔΦ already carries the 1/N_e of its pass.
//!
//! **`ppm`: fixed hit points.** The eye pass runs once: `eye_samples` jittered camera paths
//! per pixel, each a slot; the pixel is their mean. What a pixel converges to is therefore the
//! radiance at those fixed points, not the pixel integral — PPM's known limit with
//! antialiasing, depth of field and glossy paths [Hachisuka & Jensen 2009, §1], kept as the
//! paper has it. Direct light defaults to photons (`direct = "photons"`, the paper computes all
//! illumination at hit points from photons).
//!
//! **`sppm`: new visible points every pass.** Each pass traces one new camera path per pixel
//! (stochastic in the pixel, the lens and every glossy bounce); the pixel is one slot whose
//! statistics are shared by its successive visible points [Hachisuka & Jensen 2009, §3.2],
//! so it converges to the pixel integral. Direct light defaults to next-event estimation at
//! the eye vertices (`direct = "nee"`, as pbrt-v3's SPPM), photons counting from their
//! second hit.
//!
//! **Decision: what a sample is.** One sample (the `spp` unit of experiments) is one pass: an
//! eye pass (for `sppm`) and `photons_per_pass` photon paths. The estimate after k passes is not
//! a mean of independent samples, so the film receives, at pass k, the value
//! k L(k) − (what it holds already): its mean is exactly the k-pass estimate. Experiments see
//! the progressive error curve the methods are known for. The strategy keeps the slot
//! statistics between passes and replays passes from 0 when a film starts over (equal time
//! after equal samples), so any split into passes gives the bit-identical image.
//!
//! **Decision: the initial radius.** `initial_radius = 0` (the default) takes Hachisuka's rule
//! from the authors' `smallppm`: twice the mean extent of the bounding box of the first pass's
//! visible points over the mean image side, R₀ ≈ two pixel footprints.
//!
//! **Determinism.** Eye path of pixel p in pass s: `[PPM_EYE, p, s]` (`ppm`: hit point j of
//! pixel p, `[PPM_EYE, p, j]`); direct light of slot i in pass s: `[PPM_DIRECT, i, s]`; photon
//! path j of pass s: `[PPM_PHOTON, j, s]`. Photons are traced in fixed blocks and gathered per
//! slot in kd-tree order.

pub mod eye;
pub mod photons;

use super::{Declared, Phase, Strategy};
use crate::camera::Camera;
use crate::error::Result;
use crate::film::Film;
use crate::params::{Params, Range};
use crate::sampling::{Rng, stream};
use crate::scene::Scene;
use eye::{EyePath, sample_direct, trace_eye};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::ops::Range as Samples;
use std::sync::Mutex;

crate::declare_choice! {
    /// What light a visible point receives straight from the emitters: `"nee"` samples a light
    /// at every non-delta eye vertex and counts photons from their second hit; `"photons"`
    /// counts every photon, the direct ones included.
    pub enum DirectLight { Nee = "nee", Photons = "photons" }
}

crate::declare_params! {
    /// Parameters of `kind = "ppm"` [Hachisuka, Ogaki & Jensen 2008].
    pub struct PpmParams {
        /// N_e, photon paths traced per pass.
        photons_per_pass: u64 = 100_000, range Range::int(1, 100_000_000);
        /// α, the fraction of new photons a radius reduction keeps [eq. (8)]; the paper: 0.7.
        alpha: f64 = 0.7, range Range::above_to(0.0, 1.0).of("a fraction");
        /// R₀ in scene units; 0 derives it from the image (module doc).
        initial_radius: f64 = 0.0, range Range::at_least(0.0).of("a distance");
        /// Hit points per pixel, fixed for the whole render (jittered in the pixel).
        eye_samples: u32 = 1, range Range::int(1, 256);
        /// Where direct light comes from ([`DirectLight`]).
        direct: DirectLight = DirectLight::Photons;
        /// Maximum number of scattering events of eye paths and of photon paths.
        max_depth: u32 = 16, range Range::int(0, 1024);
    }
}

crate::declare_params! {
    /// Parameters of `kind = "sppm"` [Hachisuka & Jensen 2009].
    pub struct SppmParams {
        /// N_e, photon paths traced per pass.
        photons_per_pass: u64 = 100_000, range Range::int(1, 100_000_000);
        /// α, the fraction of new photons a radius reduction keeps [eq. (4)]; the paper: 0.7.
        alpha: f64 = 0.7, range Range::above_to(0.0, 1.0).of("a fraction");
        /// R₀ in scene units; 0 derives it from the image (module doc).
        initial_radius: f64 = 0.0, range Range::at_least(0.0).of("a distance");
        /// Where direct light comes from ([`DirectLight`]).
        direct: DirectLight = DirectLight::Nee;
        /// Maximum number of scattering events of eye paths and of photon paths.
        max_depth: u32 = 16, range Range::int(0, 1024);
    }
}

/// What distinguishes the two methods: where the hit points come from.
#[derive(Clone, Copy, Debug, PartialEq)]
enum HitPoints {
    /// `ppm`: this many per pixel, traced once.
    Fixed(u32),
    /// `sppm`: one per pixel, new every pass.
    Stochastic,
}

/// The settings both methods share.
#[derive(Clone, Copy, Debug)]
struct Settings {
    hit_points: HitPoints,
    photons_per_pass: u64,
    alpha: f64,
    initial_radius: f64,
    direct: DirectLight,
    max_depth: u32,
}

/// The statistics of one estimate slot (module doc).
#[derive(Clone, Copy, Debug, Default)]
struct Slot {
    /// R_i².
    r2: f64,
    /// N_i.
    n: f64,
    /// τ_i.
    tau: DVec3,
    /// D_i: the direct light of every pass so far.
    direct: DVec3,
}

impl Slot {
    /// Folds in one pass's Φ_i and M_i [Hachisuka & Jensen 2009, eqs. (4)–(6)].
    fn update(&mut self, phi: DVec3, m: u32, alpha: f64) {
        if m == 0 {
            return;
        }
        let m = m as f64;
        let n_new = self.n + alpha * m;
        let shrink = n_new / (self.n + m);
        self.tau = (self.tau + phi) * shrink;
        self.r2 *= shrink;
        self.n = n_new;
    }

    /// L_i after `k` passes.
    fn radiance(&self, k: f64) -> DVec3 {
        self.direct / k + self.tau / (k * std::f64::consts::PI * self.r2)
    }
}

/// Everything that lives from one pass to the next.
#[derive(Default)]
struct Progress {
    seed: u64,
    /// Passes done.
    passes: u32,
    slots: Vec<Slot>,
    /// `ppm`'s eye paths, one per slot.
    fixed: Vec<EyePath>,
    /// What the film holds per pixel (the sum of what it was given).
    shown: Vec<DVec3>,
}

/// Work counted since `prepare`.
#[derive(Clone, Copy, Debug, Default)]
struct Tally {
    passes: u64,
    photon_paths: u64,
    photons_stored: u64,
    photon_rays: u64,
    visible_points: u64,
    photons_gathered: u64,
}

/// The engine behind `ppm` and `sppm`.
struct Progressive {
    settings: Settings,
    progress: Mutex<Progress>,
    tally: Mutex<Tally>,
}

impl Progressive {
    fn new(settings: Settings) -> Self {
        Self {
            settings,
            progress: Mutex::new(Progress::default()),
            tally: Mutex::new(Tally::default()),
        }
    }

    fn slots_per_pixel(&self) -> usize {
        match self.settings.hit_points {
            HitPoints::Fixed(n) => n as usize,
            HitPoints::Stochastic => 1,
        }
    }

    /// The eye path of sample `index` of pixel `pixel`.
    fn eye_path(&self, camera: &Camera, scene: &Scene, seed: u64, pixel: usize, index: u64) -> EyePath {
        let mut rng = Rng::for_task(seed, [stream::PPM_EYE, pixel as u64, index]);
        let raster = camera.sample_raster(pixel, rng.uniform2());
        let ray = camera.sample_ray(raster, &mut rng);
        trace_eye(scene, ray, self.settings.max_depth, self.settings.direct, &mut rng)
    }

    /// Starts over for `seed`: no pass done, `ppm`'s hit points traced.
    fn restart(&self, scene: &Scene, seed: u64, progress: &mut Progress) {
        let pixels = scene.camera.pixel_count();
        let per_pixel = self.slots_per_pixel();
        let fixed = match self.settings.hit_points {
            HitPoints::Fixed(n) => (0..pixels * per_pixel)
                .into_par_iter()
                .map(|i| self.eye_path(&scene.camera, scene, seed, i / n as usize, (i % n as usize) as u64))
                .collect(),
            HitPoints::Stochastic => Vec::new(),
        };
        *progress = Progress {
            seed,
            passes: 0,
            slots: vec![Slot::default(); pixels * per_pixel],
            fixed,
            shown: vec![DVec3::ZERO; pixels],
        };
    }

    /// R₀²: the parameter, or Hachisuka's rule over the first pass's visible points.
    fn initial_r2(&self, scene: &Scene, paths: &[&EyePath]) -> f64 {
        if self.settings.initial_radius > 0.0 {
            return self.settings.initial_radius * self.settings.initial_radius;
        }
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for v in paths.iter().filter_map(|p| p.visible.as_ref()) {
            lo = lo.min(v.hit.p);
            hi = hi.max(v.hit.p);
        }
        let extent = if lo.x <= hi.x {
            ((hi - lo).element_sum() / 3.0) as f64
        } else {
            1.0
        };
        let cam = &scene.camera;
        let r0 = 2.0 * extent / ((cam.width + cam.height) as f64 / 2.0);
        if r0 > 0.0 { r0 * r0 } else { 1.0 }
    }

    /// Runs pass `s` (module doc) and, when `film` is given, shows its estimate there.
    fn pass(&self, scene: &Scene, seed: u64, s: u32, progress: &mut Progress, film: Option<&mut Film>) {
        let pixels = scene.camera.pixel_count();
        let per_pixel = self.slots_per_pixel();
        let fresh: Vec<EyePath> = match self.settings.hit_points {
            HitPoints::Stochastic => (0..pixels)
                .into_par_iter()
                .map(|p| self.eye_path(&scene.camera, scene, seed, p, s as u64))
                .collect(),
            HitPoints::Fixed(_) => Vec::new(),
        };
        let paths: Vec<&EyePath> = if fresh.is_empty() {
            progress.fixed.iter().collect()
        } else {
            fresh.iter().collect()
        };
        if s == 0 {
            let r2 = self.initial_r2(scene, &paths);
            progress.slots.iter_mut().for_each(|slot| slot.r2 = r2);
        }
        let min_bounces = match self.settings.direct {
            DirectLight::Nee => 1,
            DirectLight::Photons => 0,
        };
        let pass = photons::photon_pass(
            scene,
            seed,
            s as u64,
            self.settings.photons_per_pass,
            self.settings.max_depth,
            min_bounces,
        );
        let alpha = self.settings.alpha;
        let gathered: u64 = progress
            .slots
            .par_iter_mut()
            .zip(paths.par_iter())
            .enumerate()
            .map(|(i, (slot, path))| {
                let mut rng = Rng::for_task(seed, [stream::PPM_DIRECT, i as u64, s as u64]);
                slot.direct += (path.emitted + sample_direct(scene, path, &mut rng)).as_dvec3();
                let Some(vp) = &path.visible else { return 0 };
                let (phi, m) = photons::gather(scene, &pass.photons, vp, slot.r2.sqrt() as f32);
                slot.update(phi, m, alpha);
                m as u64
            })
            .sum();
        progress.passes = s + 1;
        let mut tally = self.tally.lock().unwrap();
        tally.passes += 1;
        tally.photon_paths += self.settings.photons_per_pass;
        tally.photons_stored += pass.photons.len() as u64;
        tally.photon_rays += pass.rays;
        tally.visible_points += paths.iter().filter(|p| p.visible.is_some()).count() as u64;
        tally.photons_gathered += gathered;
        drop(tally);
        let Some(film) = film else { return };
        let k = (s + 1) as f64;
        let width = scene.camera.width as usize;
        let (slots, shown) = (&progress.slots, &mut progress.shown);
        film.rows_mut()
            .zip(shown.par_chunks_mut(width))
            .for_each(|((y, row), shown_row)| {
                for (x, (acc, held)) in row.iter_mut().zip(shown_row).enumerate() {
                    let pixel = y * width + x;
                    let group = &slots[pixel * per_pixel..(pixel + 1) * per_pixel];
                    let l = group.iter().map(|slot| slot.radiance(k)).sum::<DVec3>() / per_pixel as f64;
                    // The film's mean after k samples must be L(k): give it what it lacks.
                    let value = (l * k - *held).as_vec3();
                    acc.add(value);
                    if value.is_finite() {
                        *held += value.as_dvec3();
                    }
                }
            });
    }

    fn render(&self, scene: &Scene, seed: u64, samples: Samples<u32>, film: &mut Film) {
        let mut progress = self.progress.lock().unwrap();
        if progress.slots.is_empty() || progress.seed != seed || progress.passes > samples.start {
            self.restart(scene, seed, &mut progress);
        }
        let mut film = Some(film);
        for s in progress.passes..samples.end {
            let shown = if s >= samples.start { film.as_deref_mut() } else { None };
            self.pass(scene, seed, s, &mut progress, shown);
        }
    }

    fn counters(&self) -> Vec<(String, f64)> {
        let t = *self.tally.lock().unwrap();
        vec![
            ("passes".into(), t.passes as f64),
            ("photon_paths".into(), t.photon_paths as f64),
            ("photons_stored".into(), t.photons_stored as f64),
            ("photon_rays".into(), t.photon_rays as f64),
            ("visible_points".into(), t.visible_points as f64),
            ("photons_gathered".into(), t.photons_gathered as f64),
        ]
    }

    fn reset(&mut self) -> Vec<Phase> {
        *self.progress.get_mut().unwrap() = Progress::default();
        *self.tally.get_mut().unwrap() = Tally::default();
        Vec::new()
    }
}

/// Progressive photon mapping [Hachisuka, Ogaki & Jensen 2008].
pub struct Ppm {
    params: PpmParams,
    engine: Progressive,
}

impl Declared for Ppm {
    const KIND: &'static str = "ppm";
    const SUMMARY: &'static str =
        "progressive photon mapping: fixed hit points, shrinking radii (Hachisuka, Ogaki & Jensen 2008)";
    type Params = PpmParams;

    fn new(params: PpmParams) -> Result<Self> {
        let settings = Settings {
            hit_points: HitPoints::Fixed(params.eye_samples),
            photons_per_pass: params.photons_per_pass,
            alpha: params.alpha,
            initial_radius: params.initial_radius,
            direct: params.direct,
            max_depth: params.max_depth,
        };
        Ok(Self {
            params,
            engine: Progressive::new(settings),
        })
    }
}

/// Stochastic progressive photon mapping [Hachisuka & Jensen 2009].
pub struct Sppm {
    params: SppmParams,
    engine: Progressive,
}

impl Declared for Sppm {
    const KIND: &'static str = "sppm";
    const SUMMARY: &'static str = "stochastic progressive photon mapping: new visible points every pass, shared statistics (Hachisuka & Jensen 2009)";
    type Params = SppmParams;

    fn new(params: SppmParams) -> Result<Self> {
        let settings = Settings {
            hit_points: HitPoints::Stochastic,
            photons_per_pass: params.photons_per_pass,
            alpha: params.alpha,
            initial_radius: params.initial_radius,
            direct: params.direct,
            max_depth: params.max_depth,
        };
        Ok(Self {
            params,
            engine: Progressive::new(settings),
        })
    }
}

/// The [`Strategy`] of a wrapper around [`Progressive`].
macro_rules! progressive_strategy {
    ($t:ty) => {
        impl Strategy for $t {
            fn kind(&self) -> &'static str {
                Self::KIND
            }

            fn capabilities(&self) -> crate::strategy::Capabilities {
                crate::strategy::Capabilities::ALL
            }

            fn params(&self) -> Vec<(String, String)> {
                self.params.columns()
            }

            fn prepare(&mut self, _: &Scene, _: u64) -> Result<Vec<Phase>> {
                Ok(self.engine.reset())
            }

            fn render_pass(&self, scene: &Scene, seed: u64, samples: Samples<u32>, film: &mut Film) {
                self.engine.render(scene, seed, samples, film);
            }

            fn counters(&self) -> Vec<(String, f64)> {
                self.engine.counters()
            }
        }
    };
}

progressive_strategy!(Ppm);
progressive_strategy!(Sppm);

#[cfg(test)]
mod tests;
