//! Christensen 1999, Fig. 1, drawn from the maps `prepare` built: the photon distribution,
//! irradiance at the image points, precomputed irradiance, and what the final gather sees.

use super::*;
use crate::bsdf::Bsdf;
use crate::figure::{FigureImage, GATHER_SEES_PNG, IRRADIANCE_PNG, PRECOMPUTED_PNG};
use crate::film::Image;
use crate::photon::picture::{self, visible_pixels};
use crate::sampling::{Rng, stream};
use crate::scene::{Scene, SurfaceHit};
use crate::strategy::Figure;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::f32::consts::FRAC_1_PI;

impl PhotonMapStrategy {
    /// Christensen 1999, Fig. 1 (b)–(e), from this strategy's own maps (Fig. 1(a), the photon
    /// map itself, is [`crate::photon::picture::distribution`]). Every image shows radiance on the renders' scale,
    /// so that one tone mapping (the renders' sRGB preview, exposure 0) serves them all:
    /// irradiance E is shown as E/π, the radiance a white Lambertian surface under E reflects
    /// (the paper's "dimmed for display"; π dims less than the paper's unstated factor but
    /// keeps the images comparable with the final render and with each other).
    /// - `IRRADIANCE_PNG` (Fig. 1b): the global map's N-nearest irradiance estimate at the first
    ///   non-delta hit of each pixel centre's camera ray (through mirrors and glass, weighted by
    ///   their reflectance), on the side the ray sees.
    /// - `PRECOMPUTED_PNG` (Fig. 1c at `every = 1`, 1d at `every = 4`): only with precomputed
    ///   irradiance: each photon holding an irradiance drawn where the camera sees it (as the
    ///   photon image draws photons), the pixel showing the mean E/π of its visible photons,
    ///   black where none is visible.
    /// - `GATHER_SEES_PNG` (Fig. 1e, the scene "as the final gathering sees it", §3.2): at the
    ///   same first hits, what a final-gather ray landing there reads ([`Renderer::lookup`]):
    ///   ρ/π · E of the nearest precomputed photon, or the global map's radiance estimate.
    ///
    /// The delta chains draw from `[stream::FIGURE, pixel, 0]`, so the images depend on the seed
    /// only, never on the thread count.
    pub(super) fn draw_figures(&self, scene: &Scene, seed: u64) -> Vec<Figure> {
        let Some(maps) = &self.maps else {
            return Vec::new();
        };
        let r = Renderer {
            scene,
            params: &self.params,
            maps,
        };
        let cam = &scene.camera;
        let (width, height) = (cam.width, cam.height);
        let hits: Vec<Option<(SurfaceHit, Vec3, Vec3)>> = (0..cam.pixel_count())
            .into_par_iter()
            .map(|pixel| {
                let mut rng = Rng::for_task(seed, [stream::FIGURE, pixel as u64, 0]);
                let (x, y) = (pixel % width as usize, pixel / width as usize);
                let ray = cam.generate_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                r.first_diffuse_hit(ray, &mut rng)
            })
            .collect();
        let at_hits = |f: &(dyn Fn(&SurfaceHit, &Bsdf, Vec3) -> Vec3 + Sync)| Image {
            width,
            height,
            pixels: hits
                .par_iter()
                .map(|h| {
                    h.as_ref()
                        .map_or(Vec3::ZERO, |(hit, beta, wo)| *beta * f(hit, &scene.bsdf(hit), *wo))
                })
                .collect(),
        };
        let mut figures = vec![
            picture::distribution(scene, &self.photons()),
            Figure {
                suffix: IRRADIANCE_PNG,
                image: FigureImage::Radiance(at_hits(&|hit, _, wo| {
                    maps.global
                        .irradiance(hit.p, side_normal(hit, wo), &maps.estimate)
                        .value
                        * FRAC_1_PI
                })),
            },
        ];
        if let Some(irr) = &maps.irradiance {
            let photons: Vec<(Vec3, Vec3)> = irr.photons().iter().map(|p| (p.position(), p.normal())).collect();
            let mut sum = vec![Vec3::ZERO; cam.pixel_count()];
            let mut count = vec![0u32; cam.pixel_count()];
            for (photon, pixel) in irr.photons().iter().zip(visible_pixels(scene, &photons)) {
                if let (Some(i), Some(e)) = (pixel, photon.irradiance()) {
                    sum[i] += e * FRAC_1_PI;
                    count[i] += 1;
                }
            }
            let pixels = sum
                .iter()
                .zip(&count)
                .map(|(&s, &n)| if n > 0 { s / n as f32 } else { Vec3::ZERO })
                .collect();
            figures.push(Figure {
                suffix: PRECOMPUTED_PNG,
                image: FigureImage::Radiance(Image { width, height, pixels }),
            });
        }
        figures.push(Figure {
            suffix: GATHER_SEES_PNG,
            image: FigureImage::Radiance(at_hits(&|hit, bsdf, wo| {
                r.lookup(hit, bsdf, wo, &mut PhotonMapCounters::default())
            })),
        });
        figures
    }
}
