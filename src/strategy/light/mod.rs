//! `kind = "light"`: light tracing — particle tracing from the lights with every non-specular
//! vertex connected to the camera and splatted where it lands on the image [Veach 1997,
//! §10.2, the s ≥ 1, t = 1 techniques; Arvo & Kirk 1990]. It is the estimator that sees
//! caustics on diffuse surfaces directly, and the `t = 1` half of bidirectional path tracing.
//!
//! **Estimator.** A light sub-path x₀ … x_i is drawn with the area densities of
//! [`crate::path_space::pdf_light_side`] (a light ∝ power, a point uniform on it, cosine
//! emission, then BSDF sampling in importance mode). Its ratio
//! A_i = Le(x₀→x₁) G(x₀,x₁) Π_{j=1}^{i−1} f_s(x_j) G(x_j,x_{j+1}) / Π_{j=0}^{i} p(x_j) is kept
//! incrementally; joining x_i to the eye x_e (the pinhole, a point drawn uniformly on a thin
//! lens, the film point behind x_i for an orthographic camera: [`crate::path_space`],
//! "Cameras") gives the path X = (x₀ … x_i, x_e) with f(X) / p(X) = A_i f_s(x_{i−1}→x_i→x_e)
//! C(x_i) [Veach 1997, eq. (10.8) with t = 1], where C = du/dA is the camera factor of
//! [`crate::path_space::camera_factor`] (pixel area 1), and x₀ seen directly gives
//! Le(x₀→x_e) C(x₀) / p(x₀). With N light paths, pixel j's value is (1/N) Σ of the f/p that
//! land in it.
//!
//! **Decision: what a sample is.** One sample per pixel is N = (pixel count) light paths, so
//! that `spp` costs about what it costs `path`; each sample's splats form one image, added to
//! every pixel as one sample (like `mlt`). Paths run in fixed chunks of [`CHUNK`] with their own
//! streams `[LIGHT_PATH, sample, path]`, summed in chunk order: bit-identical on any number of
//! threads and however the samples are split into passes.
//!
//! **What it cannot see.** A path whose last scattering vertex before the eye is specular
//! (E S … : a mirror or glass seen directly, a smooth plastic's coating) has no connection to
//! the eye, so light tracing leaves it out (of a plastic it sees the base); scenes with
//! directly visible specular surfaces render darker there (as in every light tracer; `bdpt`
//! covers them with its other techniques). Nor does the environment seen straight through an
//! orthographic camera (a delta in direction at both ends of the edge): it stays black.
//!
//! **Participating media** ([`crate::medium`]): scenes with media take the volumetric walk of
//! [`media`], whose vertices may lie inside media and whose joins to the eye carry the
//! transmittance of the media they cross.
//!
//! Russian roulette after `rr_depth` scattering events continues with q = min(0.95, Y(A_i) /
//! Y(A_1)), the luminance of the throughput relative to what left the light.

mod media;

use super::{Declared, Strategy};
use crate::error::Result;
use crate::film::Film;
use crate::params::{Params, Range};
use crate::path_space::{
    Vertex, camera_factor, emitted, eye_toward, geometry, pdf_light_side, scattering, visible,
    walk::{extend_light_side, sample_light_vertex},
};
use crate::sampling::{Rng, stream};
use crate::scene::Scene;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::ops::Range as Samples;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

/// Light paths per task: a fixed split, so that the sum over paths is the same on any number
/// of threads.
pub const CHUNK: usize = 256;

crate::declare_params! {
    /// Parameters of `kind = "light"`.
    pub struct LightParams {
        /// Maximum number of scattering events of a path (light sub-path vertices after x₀), as
        /// `path`'s `max_depth`; 0 shows only emitters seen directly.
        max_depth: u32 = 16, range Range::int(0, 1024);
        /// Russian roulette starts after this many scattering events.
        rr_depth: u32 = 3, range Range::int(0, 1024);
    }
}

/// The light tracer.
pub struct LightTracing {
    params: LightParams,
    light_paths: AtomicU64,
    connections: AtomicU64,
    splats: AtomicU64,
}

impl Declared for LightTracing {
    const KIND: &'static str = "light";
    const SUMMARY: &'static str = "light tracing: particles from the lights connected to the pinhole and splatted (Veach 1997, §10.2; Arvo & Kirk 1990)";
    type Params = LightParams;

    fn new(params: LightParams) -> Result<Self> {
        Ok(Self {
            params,
            light_paths: AtomicU64::new(0),
            connections: AtomicU64::new(0),
            splats: AtomicU64::new(0),
        })
    }
}

/// One splat: pixel index and f/p.
type Splat = (u32, Vec3);

impl LightTracing {
    /// Splats f/p of joining the light sub-path `sub` (x₀ … x_i, with ratio `a` = A_i for
    /// i ≥ 1) to the pinhole into `out`, on a pixel whose filter covers where it lands;
    /// nothing when it misses the image, is blocked, or its last vertex is specular.
    fn connect(&self, scene: &Scene, sub: &[Vertex], a: Vec3, rng: &mut Rng, out: &mut Vec<Splat>) {
        self.join(scene, (sub, a), rng, out, |x, eye, _| {
            if visible(scene, x, eye) { Vec3::ONE } else { Vec3::ZERO }
        });
    }

    /// [`LightTracing::connect`] with what reaches the eye along the join, `through(x, eye)`
    /// (1 or 0 for visibility, the transmittance through media), asked only for a join that
    /// carries something.
    fn join(
        &self,
        scene: &Scene,
        (sub, a): (&[Vertex], Vec3),
        rng: &mut Rng,
        out: &mut Vec<Splat>,
        through: impl FnOnce(&Vertex, &Vertex, &mut Rng) -> Vec3,
    ) {
        let Some(x) = sub.last() else { return };
        if !x.connectible() {
            return;
        }
        let eye = eye_toward(scene, x, &Vertex::eye(scene, rng));
        let Some((raster, c)) = camera_factor(scene, x, &eye) else {
            return;
        };
        self.connections.fetch_add(1, Relaxed);
        let value = if sub.len() == 1 {
            emitted(scene, &[*x, eye]) * c / pdf_light_side(scene, sub, 0)
        } else {
            let i = sub.len() - 1;
            a * scattering(scene, &[sub[i - 1], *x, eye], 1) * c
        };
        if value == Vec3::ZERO || !value.is_finite() {
            return;
        }
        let tr = through(x, &eye, rng);
        if tr == Vec3::ZERO {
            return;
        }
        self.splats.fetch_add(1, Relaxed);
        out.extend(scene.camera.splat(raster, rng).map(|(p, w)| (p, value * tr * w)));
    }

    /// Traces one light path and pushes its splats.
    fn trace(&self, scene: &Scene, rng: &mut Rng, out: &mut Vec<Splat>) {
        if !scene.media.is_empty() {
            return self.trace_through_media(scene, rng, out);
        }
        let max_depth = self.params.max_depth as usize;
        let mut sub = Vec::with_capacity(max_depth + 1);
        let Some(x0) = sample_light_vertex(scene, rng) else {
            return;
        };
        sub.push(x0);
        self.connect(scene, &sub, Vec3::ZERO, rng, out);
        let mut a = Vec3::ZERO;
        let mut a1_lum = 0.0;
        for i in 1..=max_depth {
            if !extend_light_side(scene, &mut sub, 1, rng) {
                return;
            }
            let Some(next) = next_ratio(scene, &sub, a) else {
                return;
            };
            a = next;
            if i == 1 {
                a1_lum = crate::color::luminance(a);
            }
            self.connect(scene, &sub, a, rng, out);
            if i >= self.params.rr_depth as usize {
                let Some(q) = survival(crate::color::luminance(a), a1_lum, rng) else {
                    return;
                };
                a /= q;
            }
        }
    }
}

/// A_i of the light sub-path `sub` (x₀ … x_i, i ≥ 1) from `a` = A_{i−1}: the new edge's geometry
/// over the new vertex's density (for i = 1, Le G over the densities of x₀ and x₁); `None` when
/// it is zero, not finite or has no density.
fn next_ratio(scene: &Scene, sub: &[Vertex], a: Vec3) -> Option<Vec3> {
    let i = sub.len() - 1;
    let p = pdf_light_side(scene, sub, i);
    let a = if i == 1 {
        emitted(scene, sub) * geometry(&sub[0], &sub[1]) / (pdf_light_side(scene, sub, 0) * p)
    } else {
        a * scattering(scene, sub, i - 1) * geometry(&sub[i - 1], &sub[i]) / p
    };
    (a.is_finite() && p > 0.0 && a != Vec3::ZERO).then_some(a)
}

/// Russian roulette (module doc): the survival probability q = min(0.95, `lum` / `lum_1`), the
/// luminance of the throughput relative to the first vertex's; `None` when the path ends.
fn survival(lum: f32, lum_1: f32, rng: &mut Rng) -> Option<f32> {
    let q = (lum / lum_1).clamp(0.0, 0.95);
    (!(q.is_nan() || q <= 0.0) && rng.uniform() < q).then_some(q)
}

impl Strategy for LightTracing {
    fn capabilities(&self) -> crate::strategy::Capabilities {
        crate::strategy::Capabilities {
            media: true,
            ..crate::strategy::Capabilities::ALL
        }
    }

    fn kind(&self) -> &'static str {
        Self::KIND
    }

    fn params(&self) -> Vec<(String, String)> {
        self.params.columns()
    }

    fn render_pass(&self, scene: &Scene, seed: u64, samples: Samples<u32>, film: &mut Film) {
        let n = scene.camera.pixel_count();
        for s in samples {
            let chunks: Vec<Vec<Splat>> = (0..n.div_ceil(CHUNK))
                .into_par_iter()
                .map(|c| {
                    let mut out = Vec::new();
                    for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                        let mut rng = Rng::for_task(seed, [stream::LIGHT_PATH, s as u64, i as u64]);
                        self.trace(scene, &mut rng, &mut out);
                    }
                    out
                })
                .collect();
            self.light_paths.fetch_add(n as u64, Relaxed);
            let mut image = vec![DVec3::ZERO; n];
            for (p, v) in chunks.into_iter().flatten() {
                image[p as usize] += v.as_dvec3();
            }
            let width = scene.camera.width as usize;
            film.rows_mut().for_each(|(y, row)| {
                for (x, acc) in row.iter_mut().enumerate() {
                    acc.add((image[y * width + x] / n as f64).as_vec3());
                }
            });
        }
    }

    fn counters(&self) -> Vec<(String, f64)> {
        vec![
            ("light_paths".into(), self.light_paths.load(Relaxed) as f64),
            ("eye_connections".into(), self.connections.load(Relaxed) as f64),
            ("splats".into(), self.splats.load(Relaxed) as f64),
        ]
    }
}
