//! Ward's irradiance cache [Ward 1988; Ward & Heckbert 1992] at the camera's first Lambertian
//! hits: records from full final gathers, filled in a fixed order before rendering so that the
//! image does not depend on the thread count, and interpolated with or without gradients.

use super::*;
use crate::bsdf::Bsdf;
use crate::geometry::{Ray, spawn_ray};
use crate::photon::irradiance_cache::{CacheRecord, Gradients, IrradianceCache, PolarStrata, gradients};
use crate::sampling::{Rng, latin_hypercube, sample_cosine_hemisphere, stream};
use crate::scene::SurfaceHit;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::f32::consts::PI;

impl Renderer<'_> {
    /// The irradiance cache's deterministic overture (see the module doc): rounds over pixel
    /// grids, coarse to fine; in each, the pixels whose centre's first Lambertian hit has no
    /// valid record compute one in parallel, added in pixel order.
    pub(super) fn fill_cache(
        &self,
        caching: &IrradianceCaching,
        r_clamp: (f32, f32),
        seed: u64,
        counters: &AtomicCounters,
    ) -> IrradianceCache {
        let cam = &self.scene.camera;
        let (width, height) = (cam.width, cam.height);
        let mut cache = IrradianceCache::new(caching.error);
        let mut rounds: Vec<(u32, u32, u32)> = vec![(16, 0, 0)];
        for step in [8, 4, 2, 1] {
            rounds.extend([(step, step, 0), (step, 0, step), (step, step, step)]);
        }
        for (step, dx, dy) in rounds {
            // Pixels (dx + 2·step·i, dy + 2·step·j) of this round; the first round is the
            // 16-grid itself.
            let stride = if dx == 0 && dy == 0 { step } else { 2 * step };
            let pixels: Vec<(u32, u32)> = (dy..height)
                .step_by(stride as usize)
                .flat_map(|y| (dx..width).step_by(stride as usize).map(move |x| (x, y)))
                .collect();
            let found: Vec<Option<CacheRecord>> = pixels
                .par_iter()
                .map(|&(x, y)| {
                    let pixel = u64::from(y) * u64::from(width) + u64::from(x);
                    let mut rng = Rng::for_task(seed, [stream::IRRADIANCE_CACHE, pixel, 0]);
                    let mut c = PhotonMapCounters::default();
                    let ray = cam.generate_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                    let record = self.cache_record(ray, &cache, caching, r_clamp, &mut rng, &mut c);
                    counters.add(&c);
                    record
                })
                .collect();
            cache.extend(found.into_iter().flatten());
        }
        cache
    }

    /// A new cache record at the first non-delta hit of a camera ray, if that hit is
    /// Lambertian and `cache` has no valid record there.
    pub(super) fn cache_record(
        &self,
        mut ray: Ray,
        cache: &IrradianceCache,
        caching: &IrradianceCaching,
        (r_min, r_max): (f32, f32),
        rng: &mut Rng,
        c: &mut PhotonMapCounters,
    ) -> Option<CacheRecord> {
        let scene = self.scene;
        for _ in 0..=self.params.max_depth {
            let hit = scene.intersect(&ray)?;
            let bsdf = scene.bsdf(&hit);
            if bsdf.is_delta() {
                ray = bsdf_bounce(&hit, &bsdf, hit.frame.to_local(-ray.d), rng)?.0;
                continue;
            }
            let Some(Bsdf::Lambertian(_)) = bsdf.seen_from(hit.frame.to_local(-ray.d)) else {
                return None;
            };
            let n = side_normal(&hit, -ray.d);
            if cache.interpolate(hit.p, n).is_some() {
                return None;
            }
            // The final gather of `shade` with the cache's G, cosine-distributed about n:
            // E = π/G Σ L_j, and Ward's R = G / Σ 1/d_j (escaping rays count 1/d = 0).
            let g = caching.gather_rays as usize;
            let sign = if n.dot(hit.frame.n) >= 0.0 { 1.0 } else { -1.0 };
            let (mut sum, mut inverse_d) = (Vec3::ZERO, 0.0f32);
            c.final_gathers += 1;
            if caching.gradients {
                return Some(self.gradient_record(&hit, n, sign, g, (r_min, r_max), rng, c));
            }
            for u in latin_hypercube(g, rng) {
                c.gather_rays += 1;
                let w = sample_cosine_hemisphere(u);
                let wi = hit.frame.to_world(Vec3::new(w.x, w.y, sign * w.z));
                if wi.dot(hit.ng) * sign <= 0.0 {
                    continue;
                }
                let (l, d) = self.gather(spawn_ray(hit.p, hit.ng, wi), true, rng, c);
                sum += l;
                inverse_d += 1.0 / d;
            }
            let r = if inverse_d > 0.0 { g as f32 / inverse_d } else { r_max };
            return Some(CacheRecord {
                p: hit.p,
                n,
                e: sum * (PI / g as f32),
                r: r.clamp(r_min, r_max),
                gradients: None,
            });
        }
        None
    }

    /// A cache record at `hit` (normal `n` = `sign` × the shading normal) from a gather
    /// stratified in [`PolarStrata`] for about `g` rays, with Ward & Heckbert's gradients
    /// ([`crate::photon::irradiance_cache::gradients`]); E and R as in `cache_record`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn gradient_record(
        &self,
        hit: &SurfaceHit,
        n: Vec3,
        sign: f32,
        g: usize,
        (r_min, r_max): (f32, f32),
        rng: &mut Rng,
        c: &mut PhotonMapCounters,
    ) -> CacheRecord {
        let strata = PolarStrata::for_rays(g);
        let (mut l, mut d, mut w) = (Vec::new(), Vec::new(), Vec::new());
        for j in 0..strata.m {
            for k in 0..strata.n {
                let local = strata.direction(j, k, rng.uniform2());
                let wi = hit.frame.to_world(Vec3::new(local.x, local.y, sign * local.z));
                let (lj, dj) = if wi.dot(hit.ng) * sign <= 0.0 {
                    (Vec3::ZERO, f32::INFINITY)
                } else {
                    c.gather_rays += 1;
                    self.gather(spawn_ray(hit.p, hit.ng, wi), true, rng, c)
                };
                l.push(lj);
                d.push(dj);
                w.push(local);
            }
        }
        let count = strata.len() as f32;
        let inverse_d: f32 = d.iter().map(|d| 1.0 / d).sum();
        let r = if inverse_d > 0.0 { count / inverse_d } else { r_max };
        let (rotational, translational) = gradients(strata, &l, &d, &w);
        // Tangent vectors map to the world through the shading frame on either side; the
        // rotational gradient ∫ L (n × ω) dω changes sign with n (x, y, −n is left-handed).
        let tangent = |v: Vec3| hit.frame.to_world(v);
        CacheRecord {
            p: hit.p,
            n,
            e: l.iter().copied().sum::<Vec3>() * (PI / count),
            r: r.clamp(r_min, r_max),
            gradients: Some(Gradients {
                rotational: rotational.map(|v| tangent(v) * sign),
                translational: translational.map(tangent),
            }),
        }
    }
}
