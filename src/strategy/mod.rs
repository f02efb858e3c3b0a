//! Light-transport strategies behind one small trait. Each strategy lives in its own file,
//! whose name matches its `kind` in experiment files and its label in results.
//!
//! A strategy first *prepares* (photon tracing, kd-tree build, Markov chains …: timed phase by
//! phase, apart from rendering), then renders *passes*: a pass adds the samples with indices
//! `samples` to every pixel. Because every sample draws from its own stream, seeded by
//! (seed, pixel, sample index) and the film adds each pixel's samples in order, rendering
//! 0..64 at once or as 0..16, 16..64 gives the bit-identical image, on any number of threads.
//!
//! What lives here: the [`Strategy`] trait, [`render_pixels`], the [`registry`] of kinds and
//! one module per strategy (a file, or a folder when the method has several parts). What does not:
//! machinery two strategies share (photon maps in [`crate::photon`], the chain in
//! [`crate::metropolis`], path space in [`crate::path_space`]), and anything about experiments,
//! files or reports: a strategy fills a film and returns counters, phases and figures.

pub mod bdpt;
pub mod light;
pub mod mlt;
pub mod mps;
pub mod path;
pub mod photon_guided;
pub mod photon_map;
pub mod ppg;
pub mod ppm;
pub mod registry;
pub mod vcm;

pub use crate::figure::Figure;
pub use path::Path;
pub use registry::{Declared, Registration, Registry};

use crate::error::Result;
use crate::film::Film;
use crate::geometry::Ray;
use crate::sampling::{Rng, stream};
use crate::scene::{Scene, SurfaceHit};
use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;

/// Wall-clock time of one named preparation phase.
#[derive(Clone, Debug, PartialEq)]
pub struct Phase {
    pub name: &'static str,
    pub seconds: f64,
}

/// What a strategy renders beyond area lights, pinhole cameras and the models every strategy
/// takes; a scene holding anything it does not is refused in one line ([`check_scene`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Capabilities {
    /// Light from infinitely far away (a scene's `environment`: Mitsuba's `constant` and
    /// `envmap`).
    pub environment: bool,
    /// Point and spot lights (positional `delta_lights`), which only next-event estimation or
    /// paths starting on them can reach.
    pub point_lights: bool,
    /// Directional light (parallel light from infinitely far away).
    pub directional_lights: bool,
    /// Thin-lens and orthographic cameras (Mitsuba's `thinlens` and `orthographic` sensors):
    /// eye paths from [`crate::camera::Camera::sample_ray`] or, in path space, the camera
    /// vertex of [`crate::path_space`] ("Cameras"); a strategy that makes camera rays any other
    /// way would render a lens as a pinhole.
    pub lens_camera: bool,
    /// Models with a delta lobe beside a non-delta one (Mitsuba's smooth `plastic`): the
    /// strategy treats each sample's `delta` flag rather than the surface's class.
    pub mixed_delta: bool,
    /// Opacity masks (Mitsuba's `mask`), which rays pass with probability 1 − α
    /// ([`crate::scene::Scene::passes_through`]): the strategy's estimates stay unbiased when
    /// every surface vertex is kept with its α by the ray that found it, and a density estimate
    /// divides a stored photon's power by α there.
    pub opacity_masks: bool,
    /// Models whose value and density are estimates (pbrt-v4's layered `coateddiffuse` and
    /// `coatedconductor`, [`crate::bsdf::Bsdf::is_stochastic`]): the strategy stays unbiased
    /// when a sampled direction's density is only known approximately, as it is for MIS and
    /// plain BSDF sampling, and not for Metropolis proposals.
    pub stochastic_bsdfs: bool,
    /// Participating media ([`crate::medium`]): `path`, `light` and `bdpt` render them (their
    /// volumetric walks: [`crate::strategy::path::media`], and [`crate::path_space::media`] for
    /// the light tracer and the bidirectional sub-paths); not part of [`Capabilities::ALL`], so
    /// that a strategy claims them only by name.
    pub media: bool,
}

impl Capabilities {
    pub const NONE: Self = Self {
        environment: false,
        point_lights: false,
        directional_lights: false,
        lens_camera: false,
        mixed_delta: false,
        opacity_masks: false,
        stochastic_bsdfs: false,
        media: false,
    };
    /// Every feature of surfaces, lights and cameras (participating media are claimed by name).
    pub const ALL: Self = Self {
        environment: true,
        point_lights: true,
        directional_lights: true,
        lens_camera: true,
        mixed_delta: true,
        opacity_masks: true,
        stochastic_bsdfs: true,
        media: false,
    };
}

/// A light-transport algorithm under test.
pub trait Strategy: Send + Sync {
    /// The `kind` of the strategy, as in experiment files.
    fn kind(&self) -> &'static str;

    /// Every parameter with its value, in a fixed order (recorded with every result row).
    fn params(&self) -> Vec<(String, String)>;

    /// What the strategy renders beyond area lights, pinhole cameras and the models every
    /// strategy takes ([`Capabilities`]); none by default, so that a new strategy is refused
    /// every scene holding such a feature ([`check_scene`]) until it says it renders it.
    fn capabilities(&self) -> Capabilities {
        Capabilities::NONE
    }

    fn handles_environment(&self) -> bool {
        self.capabilities().environment
    }

    fn handles_point_lights(&self) -> bool {
        self.capabilities().point_lights
    }

    fn handles_directional_lights(&self) -> bool {
        self.capabilities().directional_lights
    }

    fn handles_lens_camera(&self) -> bool {
        self.capabilities().lens_camera
    }

    fn handles_mixed_delta(&self) -> bool {
        self.capabilities().mixed_delta
    }

    fn handles_opacity_masks(&self) -> bool {
        self.capabilities().opacity_masks
    }

    fn handles_stochastic_bsdfs(&self) -> bool {
        self.capabilities().stochastic_bsdfs
    }

    fn handles_media(&self) -> bool {
        self.capabilities().media
    }

    /// Work done once per scene and seed before any sample is taken.
    fn prepare(&mut self, scene: &Scene, seed: u64) -> Result<Vec<Phase>> {
        let _ = (scene, seed);
        Ok(Vec::new())
    }

    /// Adds samples `samples` of every pixel to `film`.
    fn render_pass(&self, scene: &Scene, seed: u64, samples: Range<u32>, film: &mut Film);

    /// Named quantities the strategy counted or estimated since `prepare` (gather rays, photons
    /// stored, proposals accepted, B_eye …), in a fixed order; recorded with every result row.
    /// Each must either accumulate since `prepare` or stay constant while rendering (rows take
    /// differences between checkpoints): report a ratio as its numerator and denominator.
    fn counters(&self) -> Vec<(String, f64)> {
        Vec::new()
    }

    /// What a final-gather ray reaching the non-delta surface point `hit` reads from the
    /// strategy's photon maps as the radiance leaving it toward `wo` (world, unit): the
    /// lookup `bench map-error` measures ([`crate::experiment::map_error`]). `None` for
    /// strategies without a photon map, or before `prepare`.
    fn map_lookup(&self, scene: &Scene, hit: &SurfaceHit, wo: Vec3) -> Option<Vec3> {
        let _ = (scene, hit, wo);
        None
    }

    /// Diagnostic images of what `prepare` built (the photon distribution of Fan et al. 2005,
    /// Fig. 2; Christensen 1999, Fig. 1: irradiance at the image points, precomputed
    /// irradiance, what the final gather sees; [`crate::figure`]); written beside the renders
    /// as `<cell><suffix>`. Empty by default.
    fn figures(&self, scene: &Scene, seed: u64) -> Vec<Figure> {
        let _ = (scene, seed);
        Vec::new()
    }
}

/// Refuses a scene the strategy cannot render faithfully, with one line naming both.
pub fn check_scene(strategy: &dyn Strategy, scene: &Scene) -> Result<()> {
    let able = |can: fn(&dyn Strategy) -> bool| -> Vec<&'static str> {
        kinds()
            .into_iter()
            .filter(|k| build(k, toml::Table::new()).is_ok_and(|s| can(&*s)))
            .collect()
    };
    if let Some(m) = scene.materials.iter().find(|m| m.bsdf.mixes_delta())
        && !strategy.handles_mixed_delta()
    {
        crate::bail!(
            "{}: strategy `{}` does not render material {:?} (a delta lobe beside smooth ones: a smooth \
             plastic or coating) yet; strategies that do: {}",
            scene.source.display(),
            strategy.kind(),
            m.name,
            able(|s| s.handles_mixed_delta()).join(", ")
        );
    }
    if !matches!(scene.camera.lens, crate::camera::Lens::Pinhole) && !strategy.handles_lens_camera() {
        crate::bail!(
            "{}: strategy `{}` does not render a {} camera (the scene's sensor) yet; strategies that do: {}",
            scene.source.display(),
            strategy.kind(),
            match scene.camera.lens {
                crate::camera::Lens::Orthographic { .. } => "orthographic",
                _ => "thin-lens",
            },
            able(|s| s.handles_lens_camera()).join(", ")
        );
    }
    if let Some(m) = scene.materials.iter().find(|m| m.opacity.is_some())
        && !strategy.handles_opacity_masks()
    {
        crate::bail!(
            "{}: strategy `{}` does not render material {:?} (an opacity mask) yet; strategies that do: {}",
            scene.source.display(),
            strategy.kind(),
            m.name,
            able(|s| s.handles_opacity_masks()).join(", ")
        );
    }
    if let Some(m) = scene.materials.iter().find(|m| m.bsdf.is_stochastic())
        && !strategy.handles_stochastic_bsdfs()
    {
        crate::bail!(
            "{}: strategy `{}` does not render material {:?} (a layered model evaluated by random walks, \
             whose sampling density is only estimated) yet; strategies that do: {}",
            scene.source.display(),
            strategy.kind(),
            m.name,
            able(|s| s.handles_stochastic_bsdfs()).join(", ")
        );
    }
    if let Some(m) = scene.media.first()
        && !strategy.handles_media()
    {
        let able = able(|s| s.handles_media());
        // A kind whose defaults render media refuses them only with some parameters (`vcm`'s
        // `ppm` mode).
        let these = if able.contains(&strategy.kind()) {
            " with these parameters"
        } else {
            ""
        };
        crate::bail!(
            "{}: strategy `{}`{these} does not render participating media (the scene's medium {:?}) yet; \
             strategies that do: {}",
            scene.source.display(),
            strategy.kind(),
            m.name,
            able.join(", ")
        );
    }
    if scene.environment.is_some() && !strategy.handles_environment() {
        let able = able(|s| s.handles_environment());
        crate::bail!(
            "{}: strategy `{}` does not render environment light (the scene's `constant` or `envmap` \
             emitter) yet; strategies that do: {}",
            scene.source.display(),
            strategy.kind(),
            able.join(", ")
        );
    }
    let refuse = |what: &str, can: fn(&dyn Strategy) -> bool| -> Result<()> {
        crate::bail!(
            "{}: strategy `{}` with these parameters does not render {what} (reached only by light \
             sampling or by paths that start on it) yet; strategies that do: {}",
            scene.source.display(),
            strategy.kind(),
            able(can).join(", ")
        )
    };
    if scene.delta_lights.iter().any(|l| l.is_positional()) && !strategy.handles_point_lights() {
        refuse("point, spot or projector lights", |s| s.handles_point_lights())?;
    }
    if scene.delta_lights.iter().any(|l| !l.is_positional()) && !strategy.handles_directional_lights() {
        refuse("directional light", |s| s.handles_directional_lights())?;
    }
    Ok(())
}

/// Renders `samples` of every pixel with a per-pixel estimator `radiance(ray, rng)`, in parallel
/// over rows. Each (pixel, sample) draws from its own stream, so the result is independent of
/// the thread count and of how the sample range is split into passes.
pub fn render_pixels<F>(scene: &Scene, seed: u64, samples: Range<u32>, film: &mut Film, radiance: F)
where
    F: Fn(&Ray, &mut Rng) -> Vec3 + Sync,
{
    let width = scene.camera.width as usize;
    film.rows_mut().for_each(|(y, row)| {
        for (x, acc) in row.iter_mut().enumerate() {
            for s in samples.clone() {
                acc.add(pixel_sample(scene, seed, y * width + x, s, &radiance));
            }
        }
    });
}

/// Sample `s` of pixel `pixel` as [`render_pixels`] takes it: a camera ray through a jittered
/// point of the pixel, with the stream `[CAMERA_PATH, pixel, s]`.
#[inline]
pub fn pixel_sample<F>(scene: &Scene, seed: u64, pixel: usize, s: u32, radiance: &F) -> Vec3
where
    F: Fn(&Ray, &mut Rng) -> Vec3,
{
    let cam = &scene.camera;
    let mut rng = Rng::for_task(seed, [stream::CAMERA_PATH, pixel as u64, s as u64]);
    let raster = cam.sample_raster(pixel, rng.uniform2());
    let ray = cam.sample_ray(raster, &mut rng);
    radiance(&ray, &mut rng)
}

/// Builds a strategy of the crate from its kind and parameter table (without `kind` and
/// `label`): [`Registry::builtin`]'s [`Registry::build`].
pub fn build(kind: &str, params: toml::Table) -> Result<Box<dyn Strategy>> {
    Registry::builtin().build(kind, params)
}

/// Every strategy kind of the crate, in the order `bench list` shows them.
pub fn kinds() -> Vec<&'static str> {
    Registry::builtin().kinds()
}
