//! Photon tracing [Jensen 1996; Christensen 1999, §1.1]: photons leave the lights, scatter by
//! the BSDFs in importance mode, end by Russian roulette, and are stored at diffuse surfaces.
//!
//! **Emission.** A light is chosen ∝ its power (luminance, `Scene::light_selection`), a point
//! uniformly on it, a direction cosine-distributed about its normal (a two-sided light picks
//! either side with probability ½). The photon then carries
//! ΔΦ = Le cos θ / (p_light · p_A · p_ω · N) = Φ_light / (p_light · N)
//! per channel (with p_A = 1/A, p_ω = cos θ / π per side, Φ_light = π A Le per side): every
//! emitted photon of a light starts with the same power, and the expected sum of the initial
//! powers is exactly the total emitted power Φ.
//!
//! Every emitter competes in the same selection ∝ power (`Scene::light_selection`: area
//! lights, then delta lights, then the environment). A scene's environment (light from
//! infinitely far away) sends its photons from a disc of the scene's bounding radius R facing a
//! direction ω drawn from the environment's importance sampling, placed at distance R from the
//! scene's centre toward ω, and travelling along −ω [the construction of pbrt-v3's
//! `InfiniteAreaLight::Sample_Le`]; a photon carries ΔΦ = L(ω) π R² / (p_env · p(ω) · N):
//! parallel light through the disc, which covers the whole scene as seen from ω. Point, spot
//! and directional lights emit as [`crate::light::delta`] says, ΔΦ = (their sample's power) /
//! (p_light · N).
//!
//! **Scattering.** At each hit the BSDF is sampled with [`TransportMode::Importance`]; the
//! photon power is multiplied by the weight w = f_s |cos θi| / p_ω (times Veach's adjoint
//! correction for shading normals, [Veach 1997, eq. (5.19)]).
//!
//! **Russian roulette** [Jensen 1996; Arvo & Kirk 1990] at every bounce: the photon survives
//! with probability q = min(1, max channel of w), and a survivor carries ΔΦ · w / q. For a
//! sampled weight w ≤ 1 (every BSDF here when importance-sampled) the survivor's largest
//! channel therefore keeps exactly the power it had: grey surfaces never change a photon's
//! power, coloured ones only drain the weaker channels. E[ΔΦ'] = q · ΔΦ w / q = ΔΦ w, so the
//! roulette is unbiased per channel.
//!
//! **Storage** (the path grammar of Heckbert 1990, as in Jensen 1996): at every hit on a
//! [`SurfaceKind::Diffuse`] surface (any diffuse component) the photon is recorded with the
//! power it arrived with, the direction it came from and the surface normal on its side.
//! - Bounce count 0 (straight from the light, "direct"): stored only with
//!   [`TraceParams::store_direct`]. Jensen 1995 stores indirect photons only (direct light is
//!   computed by light sampling and must not enter the guiding pdf).
//! - Paths L S+ D (one or more scatterings, all on delta lobes: mirrors, glass) are caustic
//!   photons; where they go is [`CausticStorage`].
//! - Glossy surfaces ([`SurfaceKind::Glossy`]) store nothing: a density estimate blurs a
//!   glossy lobe beyond use, so renderers ray trace glossy reflection [Jensen 1996]. The photon
//!   scatters on.
//! - Specular surfaces store nothing (a photon on a mirror has zero density-estimate value).
//!
//! **Determinism.** Photon path i draws from `Rng::for_task(seed, [PHOTON_PATH, i, 0])` and
//! paths are traced in fixed blocks whose results are concatenated in index order, so the maps
//! are bit-identical for any number of threads.

use super::record::{Photon, flags};
use crate::bsdf::{SurfaceKind, TransportMode};
use crate::error::{Error, Result};
use crate::geometry::{Frame, Ray, spawn_ray};
use crate::light::parallel_ray_origin;
use crate::sampling::stream;
use crate::sampling::{Rng, sample_cosine_hemisphere};
use crate::scene::Scene;
use crate::scene::light_selection::Emitter;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use serde::Deserialize;
use std::f32::consts::PI;

/// Where caustic (L S+ D) photons are stored.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum CausticStorage {
    /// No caustic map: caustic photons go to the global map like any other.
    None,
    /// Caustic photons go to the caustic map *and* the global map. The default: the global map
    /// then holds all of L{S|D}*D, so a radiance estimate at a final-gather hit sees all the
    /// light arriving there, caustics included [Jensen 1996; Christensen 1999, §1.1: caustic
    /// photons are stored "in addition"].
    #[default]
    Both,
    /// Caustic photons go to the caustic map only; the global map holds the paths with at least
    /// one diffuse bounce before the storing one (or none, for direct photons).
    Separate,
}

/// Photon tracing parameters.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct TraceParams {
    /// Photon paths emitted from the lights (default 200 000; Christensen 1999 emits 220 000
    /// in the Cornell box). The number *stored* depends on the scene.
    pub photons: u64,
    /// Maximum number of scattering events per path (default 64). A safety net only: Russian
    /// roulette ends paths after about 1 / (1 − albedo) bounces; the cap drops the power that
    /// survives 64 bounces (0.73⁶⁴ ≈ 2 · 10⁻⁹ of it in a white Cornell box).
    pub max_depth: u32,
    /// Store photons on their first hit (bounce count 0; default true). False gives the
    /// indirect-only map of Jensen 1995.
    pub store_direct: bool,
    /// Where caustic photons go (default [`CausticStorage::Both`]).
    pub caustics: CausticStorage,
}

impl Default for TraceParams {
    fn default() -> Self {
        Self {
            photons: 200_000,
            max_depth: 64,
            store_direct: true,
            caustics: CausticStorage::Both,
        }
    }
}

impl TraceParams {
    /// Checks the parameters: at least one photon, at most 2³² − 1 (photon indices fit in u32
    /// stream coordinates and kd-tree indices).
    pub fn validate(&self) -> Result<()> {
        if self.photons == 0 || self.photons > u32::MAX as u64 {
            return Err(Error::new(format!(
                "photons must lie in 1..=4294967295, got {}",
                self.photons
            )));
        }
        Ok(())
    }
}

/// The result of photon tracing: unsorted photon lists, ready for [`super::PhotonMap::build`].
#[derive(Clone, Debug)]
pub struct TracedPhotons {
    /// Photons of the global map, in path order (path 0's photons first, in bounce order).
    pub global: Vec<Photon>,
    /// Photons of the caustic map (empty with [`CausticStorage::None`]).
    pub caustic: Vec<Photon>,
    /// Photon paths emitted (N in ΔΦ = Φ / (p_light N)).
    pub emitted: u64,
    /// Total power emitted by the scene's lights, Φ, per channel: what the emitted photons
    /// carry in expectation.
    pub total_power: Vec3,
    /// Sum of the initial powers of the emitted photons (f64 accumulation): equals
    /// `total_power` in expectation, exactly when there is one light.
    pub emitted_power: Vec3,
    /// Rays traced (closest-hit queries).
    pub rays: u64,
}

/// Photon paths traced per parallel task; fixed so the order of results never depends on the
/// thread count.
const BLOCK: u64 = 1024;

/// Traces `params.photons` photon paths from the lights of `scene` (see the module doc).
/// Returns empty maps when `params.photons` is 0.
pub fn trace_photons(scene: &Scene, params: &TraceParams, seed: u64) -> TracedPhotons {
    let n = params.photons;
    let blocks = n.div_ceil(BLOCK);
    let results: Vec<Block> = (0..blocks)
        .into_par_iter()
        .map(|b| {
            let mut out = Block::default();
            for i in b * BLOCK..((b + 1) * BLOCK).min(n) {
                trace_path(scene, params, seed, i, &mut out);
            }
            out
        })
        .collect();
    let mut traced = TracedPhotons {
        global: Vec::with_capacity(results.iter().map(|b| b.global.len()).sum()),
        caustic: Vec::with_capacity(results.iter().map(|b| b.caustic.len()).sum()),
        emitted: n,
        total_power: scene.total_power(),
        emitted_power: Vec3::ZERO,
        rays: 0,
    };
    let mut emitted_power = DVec3::ZERO;
    for b in results {
        traced.global.extend_from_slice(&b.global);
        traced.caustic.extend_from_slice(&b.caustic);
        traced.rays += b.rays;
        for c in 0..3 {
            emitted_power[c] += b.emitted_power[c];
        }
    }
    traced.emitted_power = Vec3::new(
        emitted_power[0] as f32,
        emitted_power[1] as f32,
        emitted_power[2] as f32,
    );
    traced
}

#[derive(Default)]
struct Block {
    global: Vec<Photon>,
    caustic: Vec<Photon>,
    emitted_power: DVec3,
    rays: u64,
}

/// Traces photon path `index` and appends what it stores to `out`.
fn trace_path(scene: &Scene, params: &TraceParams, seed: u64, index: u64, out: &mut Block) {
    let mut rng = Rng::for_task(seed, [stream::PHOTON_PATH, index, 0]);
    let traced = trace_photon_path(scene, params.max_depth, params.photons, &mut rng, |hit| {
        if hit.bounces == 0 && !params.store_direct {
            return;
        }
        let caustic = hit.caustic();
        let f = (if hit.bounces > 0 { flags::INDIRECT } else { 0 }) | (if caustic { flags::CAUSTIC } else { 0 });
        let photon = Photon::new(hit.p, hit.power, hit.wi, hit.n, f);
        match (caustic, params.caustics) {
            (true, CausticStorage::Both) => {
                out.caustic.push(photon);
                out.global.push(photon);
            }
            (true, CausticStorage::Separate) => out.caustic.push(photon),
            _ => out.global.push(photon),
        }
    });
    out.emitted_power += traced.emitted_power.as_dvec3();
    out.rays += traced.rays;
}

/// Where a photon path meets a surface with a diffuse component ([`SurfaceKind::Diffuse`]):
/// the candidates for storage (module doc).
#[derive(Clone, Copy, Debug)]
pub struct PhotonHit {
    pub p: Vec3,
    /// Power on arrival, ΔΦ (full precision), divided by the surface's opacity α where it is
    /// masked: the ray found the surface with probability α, and a density estimate needs all
    /// the light that arrives there, also the light a mask lets through
    /// ([`crate::scene::Scene::passes_through`]).
    pub power: Vec3,
    /// Unit direction towards where the photon came from.
    pub wi: Vec3,
    /// The shading normal turned to the side the photon arrived on.
    pub n: Vec3,
    /// Scattering events before this hit (0: straight from the light).
    pub bounces: u32,
    /// Every scattering event before this hit was on a delta lobe.
    pub specular_only: bool,
}

impl PhotonHit {
    /// A caustic photon: L S+ D.
    #[inline]
    pub fn caustic(&self) -> bool {
        self.bounces > 0 && self.specular_only
    }
}

/// What one traced photon path cost and carried.
#[derive(Clone, Copy, Debug, Default)]
pub struct TracedPath {
    /// The photon's initial power, Φ_light / (p_light N).
    pub emitted_power: Vec3,
    /// Rays traced (closest-hit queries).
    pub rays: u64,
}

/// A photon from the environment (module doc): its ray, entering the scene's bounding sphere
/// from a disc facing the sampled direction, and its power; `None` for a direction of zero
/// density or radiance.
fn environment_photon(scene: &Scene, p_env: f32, emitted: u64, rng: &mut Rng) -> Option<(Ray, Vec3)> {
    let env = scene.environment.as_ref()?;
    let s = env.sample(rng.uniform2())?;
    let sphere = scene.bounding_sphere();
    let radius = sphere.1;
    let origin = parallel_ray_origin(s.wi, sphere, rng.uniform2());
    let power = s.le * (PI * radius * radius / (p_env * s.pdf_w * emitted as f32));
    (power.is_finite() && power.max_element() > 0.0).then(|| (Ray::new(origin, -s.wi), power))
}

/// A photon from delta light `i` picked with probability `pmf` (module doc); `None` where the
/// sample carries nothing.
fn delta_photon(scene: &Scene, i: usize, pmf: f32, emitted: u64, rng: &mut Rng) -> Option<(Ray, Vec3)> {
    let e = scene.delta_lights[i].emit(rng.uniform2(), scene.bounding_sphere())?;
    let power = e.power / (pmf * emitted as f32);
    power.is_finite().then(|| (Ray::new(e.origin, e.dir), power))
}

/// A photon from area light `i` picked with probability `pmf`: a uniform point, a
/// cosine-distributed direction about the side it leaves from; `Err` with the photon's power
/// when the sampled direction is degenerate (the photon still counts as emitted).
fn area_photon(scene: &Scene, i: usize, pmf: f32, emitted: u64, rng: &mut Rng) -> Result<(Ray, Vec3), Vec3> {
    let light = &scene.lights[i];
    let lp = light.sample_point(&scene.primitives[light.prim as usize], rng.uniform2());
    let mut n = lp.n;
    let u_side = rng.uniform();
    if light.emission.two_sided && u_side < 0.5 {
        n = -n;
    }
    let local = sample_cosine_hemisphere(rng.uniform2());
    let dir = Frame::from_normal(n).to_world(local);
    let power = light.power() / (pmf * emitted as f32);
    if local.z <= 0.0 || !power.is_finite() {
        return Err(power);
    }
    Ok((spawn_ray(lp.p, lp.n, dir), power))
}

/// Traces one photon path with the random numbers of `rng` — emission, scattering in
/// importance mode and Russian roulette as in the module doc — as one of `emitted` photon
/// paths (the N of ΔΦ = Φ_light / (p_light N)), and calls `store` at every hit on a surface
/// with a diffuse component, whatever its bounce count: callers decide what to keep. At most
/// `max_depth` scattering events.
pub fn trace_photon_path(
    scene: &Scene,
    max_depth: u32,
    emitted: u64,
    rng: &mut Rng,
    mut store: impl FnMut(&PhotonHit),
) -> TracedPath {
    let mut out = TracedPath::default();
    // Emission: an emitter ∝ power, then as the module doc says for its kind.
    let (i, pmf, _) = scene.light_selection.sample(rng.uniform());
    let emission = match scene.emitter(i) {
        Emitter::Area(i) => area_photon(scene, i, pmf, emitted, rng),
        Emitter::Delta(i) => delta_photon(scene, i, pmf, emitted, rng).ok_or(Vec3::ZERO),
        Emitter::Environment => environment_photon(scene, pmf, emitted, rng).ok_or(Vec3::ZERO),
    };
    let (mut ray, mut power) = match emission {
        Ok(e) => e,
        Err(power) => {
            out.emitted_power = power;
            return out;
        }
    };
    out.emitted_power = power;

    // Scattering events so far, and whether all of them were on delta lobes (L S* so far).
    let mut bounces = 0u32;
    let mut specular_only = true;
    loop {
        out.rays += 1;
        let Some(hit) = scene.intersect(&ray) else { break };
        let bsdf = scene.bsdf(&hit);
        let wi_world = -ray.d;

        if bsdf.kind() == SurfaceKind::Diffuse {
            let n_side = if hit.ng.dot(wi_world) >= 0.0 {
                hit.frame.n
            } else {
                -hit.frame.n
            };
            store(&PhotonHit {
                p: hit.p,
                power: power / scene.opacity(&hit),
                wi: wi_world,
                n: n_side,
                bounces,
                specular_only,
            });
        }
        if bounces >= max_depth {
            break;
        }

        // Scatter: sample the adjoint BSDF.
        let wo = hit.frame.to_local(wi_world);
        let (u, u_lobe) = (rng.uniform2(), rng.uniform());
        let Some(s) = bsdf.sample(wo, u, u_lobe, TransportMode::Importance) else {
            break;
        };
        let wi_next = hit.frame.to_world(s.wi);
        // Directions on the wrong side of the geometric surface (shading-normal artefacts)
        // are not valid transport.
        if wi_next.dot(hit.ng) * s.wi.z <= 0.0 || s.pdf_w <= 0.0 {
            break;
        }
        let mut w = s.f * (s.wi.z.abs() / s.pdf_w);
        if hit.frame.n != hit.ng {
            // Adjoint BSDF with shading normals [Veach 1997, eq. (5.19)]:
            // |wo·ns| |wi·ng| / (|wo·ng| |wi·ns|).
            let num = wo.z.abs() * wi_next.dot(hit.ng).abs();
            let den = wi_world.dot(hit.ng).abs() * s.wi.z.abs();
            if den == 0.0 {
                break;
            }
            w *= num / den;
        }

        // Russian roulette on the scattering weight (module doc).
        let q = w.max_element().min(1.0);
        if q.is_nan() || q <= 0.0 || (q < 1.0 && rng.uniform() >= q) {
            break;
        }
        power *= w / q;
        specular_only &= s.delta;
        bounces += 1;
        ray = spawn_ray(hit.p, hit.ng, wi_next);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{Bsdf, Phong};
    use crate::photon::record::Rgbe;
    use crate::photon::test_scenes::SceneBuilder;
    use crate::scene::load_scene;
    use std::path::Path;

    fn cornell_spheres() -> Scene {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-spheres.toml");
        load_scene(&path).expect("shipped scene loads")
    }

    fn furnace(albedo: Vec3) -> Scene {
        let mut b = SceneBuilder::new();
        let m = b.lambertian(albedo);
        b.closed_box(m, Vec3::new(3.0, 2.0, 1.0));
        b.build()
    }

    fn stored_power(photons: &[Photon]) -> [f64; 3] {
        let mut sum = [0f64; 3];
        for p in photons {
            let c = p.power();
            for (s, v) in sum.iter_mut().zip(c.to_array()) {
                *s += v as f64;
            }
        }
        sum
    }

    /// Power conservation with Russian roulette: in a closed box whose walls all have albedo
    /// ρ, a photon of power ΔΦ stores ΔΦ ρ^k at its k-th hit (k = 0, 1, …) in expectation, so
    /// the global map holds Φ Σ_{k=k0}^{D} ρ^k per channel (k0 = 0 with direct photons, 1
    /// without; D = max_depth). Grey ρ keeps every photon's power constant, and the number
    /// of hits K of a path is geometric: Var K = ρ / (1 − ρ)², so the total's relative σ is
    /// √(ρ / N) (stored direct) — the tolerance is 5σ plus the RGBE rounding (≤ 1/256).
    #[test]
    fn grey_furnace_stores_the_geometric_series_of_the_emitted_power() {
        let rho = 0.6f32;
        let scene = furnace(Vec3::splat(rho));
        let phi = scene.total_power();
        let n = 100_000u64;
        for (store_direct, max_depth) in [(true, 64u32), (false, 64), (true, 2), (false, 3)] {
            let params = TraceParams {
                photons: n,
                max_depth,
                store_direct,
                caustics: CausticStorage::Both,
            };
            let traced = trace_photons(&scene, &params, 1);
            assert!(traced.caustic.is_empty());
            assert!(((traced.emitted_power - phi).abs() / phi).max_element() < 1e-5);
            assert_eq!(traced.total_power, phi);
            let k0 = if store_direct { 0 } else { 1 };
            let series: f64 = (k0..=max_depth).map(|k| (rho as f64).powi(k as i32)).sum();
            let sigma = ((rho as f64) / n as f64).sqrt() / if store_direct { 1.0 } else { rho as f64 };
            let got = stored_power(&traced.global);
            for c in 0..3 {
                let want = phi[c] as f64 * series;
                let rel = (got[c] / want - 1.0).abs();
                assert!(
                    rel < 5.0 * sigma + 1.0 / 256.0,
                    "direct {store_direct}, depth {max_depth}, channel {c}: {} vs {want} ({rel})",
                    got[c]
                );
            }
            assert_eq!(traced.global.iter().all(|p| p.is_indirect()), !store_direct);
        }
    }

    /// The same with coloured walls, where the roulette keeps the largest channel and drains
    /// the others: each channel must still get Φ_c / (1 − ρ_c). Tolerance: 5 times a bound on
    /// σ (a path's channel total is at most ΔΦ_c K with K geometric in ρ_max:
    /// σ_c / mean_c ≤ √(1 + ρ_max) (1 − ρ_c) / ((1 − ρ_max) √N)), plus the RGBE bound
    /// Σ_k ΔΦ_max ρ_max^k / 256 relative to the channel's expectation.
    #[test]
    fn coloured_furnace_conserves_power_in_every_channel() {
        let rho = Vec3::new(0.8, 0.5, 0.2);
        let scene = furnace(rho);
        let phi = scene.total_power();
        let n = 200_000u64;
        let traced = trace_photons(
            &scene,
            &TraceParams {
                photons: n,
                ..TraceParams::default()
            },
            2,
        );
        let got = stored_power(&traced.global);
        let rho_max = 0.8f64;
        for c in 0..3 {
            let rho_c = rho[c] as f64;
            let want = phi[c] as f64 / (1.0 - rho_c);
            let sigma = (1.0 + rho_max).sqrt() * (1.0 - rho_c) / ((1.0 - rho_max) * (n as f64).sqrt());
            let rgbe = phi.max_element() as f64 / (1.0 - rho_max) / 256.0 / want;
            let rel = (got[c] / want - 1.0).abs();
            assert!(rel < 5.0 * sigma + rgbe, "channel {c}: {} vs {want} ({rel})", got[c]);
        }
        // The largest channel never changes: every photon's red power is Φ_r / N (to RGBE).
        let red = Rgbe::encode(phi / n as f32).decode().x;
        assert!(
            traced
                .global
                .iter()
                .all(|p| (p.power().x / red - 1.0).abs() < 1.0 / 128.0)
        );
    }

    #[test]
    fn tracing_is_bit_identical_for_any_thread_count() {
        let scene = cornell_spheres();
        let params = TraceParams {
            photons: 30_000,
            ..TraceParams::default()
        };
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| trace_photons(&scene, &params, 9))
        };
        let (a, b) = (run(1), run(2));
        assert!(!a.global.is_empty() && !a.caustic.is_empty());
        assert_eq!(a.global, b.global);
        assert_eq!(a.caustic, b.caustic);
        assert_eq!((a.rays, a.emitted_power), (b.rays, b.emitted_power));
        assert_ne!(a.global, trace_photons(&scene, &params, 10).global, "the seed matters");
    }

    /// Caustic photons (L S+ D: the glass sphere's caustic) carry both flags; the three storage
    /// modes trace the same paths and only route the caustic photons differently.
    #[test]
    fn caustic_storage_modes_route_the_same_photons() {
        let scene = cornell_spheres();
        let trace = |caustics| {
            let params = TraceParams {
                photons: 30_000,
                caustics,
                ..TraceParams::default()
            };
            trace_photons(&scene, &params, 4)
        };
        let (none, both, separate) = (
            trace(CausticStorage::None),
            trace(CausticStorage::Both),
            trace(CausticStorage::Separate),
        );
        assert!(none.caustic.is_empty());
        assert_eq!(none.global, both.global);
        assert_eq!(both.caustic, separate.caustic);
        assert!(both.caustic.len() > 100, "{} caustic photons", both.caustic.len());
        assert!(both.caustic.iter().all(|p| p.is_caustic() && p.is_indirect()));
        let global_caustics: Vec<Photon> = both.global.iter().copied().filter(Photon::is_caustic).collect();
        assert_eq!(global_caustics, both.caustic);
        assert!(!separate.global.iter().any(Photon::is_caustic));
        assert_eq!(separate.global.len() + separate.caustic.len(), both.global.len());
        // Caustics land under the glass sphere (centre (0.17, 0.1, 0.17)) far more densely
        // than elsewhere on the floor: most floor caustic photons are within 0.15 of it.
        let floor: Vec<&Photon> = both.caustic.iter().filter(|p| p.position[1] < 1e-3).collect();
        let under = floor
            .iter()
            .filter(|p| (p.position[0] - 0.17).hypot(p.position[2] - 0.17) < 0.15)
            .count();
        assert!(under * 2 > floor.len(), "{under} of {}", floor.len());
    }

    #[test]
    fn glossy_and_specular_surfaces_store_nothing() {
        let mut b = SceneBuilder::new();
        let white = b.lambertian(Vec3::splat(0.5));
        let glossy = b.material(Bsdf::Phong(Phong {
            diffuse: Vec3::ZERO,
            specular: Vec3::splat(0.9),
            exponent: 20.0,
        }));
        let mirror = b.material(Bsdf::Mirror(crate::bsdf::Mirror { reflectance: Vec3::ONE }));
        b.closed_box(white, Vec3::ONE);
        b.sphere(Vec3::new(0.3, 0.2, 0.5), 0.15, glossy);
        b.sphere(Vec3::new(0.7, 0.2, 0.5), 0.15, mirror);
        let scene = b.build();
        let traced = trace_photons(
            &scene,
            &TraceParams {
                photons: 20_000,
                ..TraceParams::default()
            },
            3,
        );
        for p in &traced.global {
            for c in [Vec3::new(0.3, 0.2, 0.5), Vec3::new(0.7, 0.2, 0.5)] {
                assert!((p.position() - c).length() > 0.15 + 1e-3, "photon stored on a sphere");
            }
        }
        assert!(traced.global.len() > 20_000);
    }

    #[test]
    fn validate_rejects_zero_and_oversized_photon_counts() {
        assert!(TraceParams::default().validate().is_ok());
        for photons in [0u64, 1 << 40] {
            let p = TraceParams {
                photons,
                ..TraceParams::default()
            };
            assert!(p.validate().is_err());
        }
    }

    #[test]
    fn params_parse_and_reject_unknown_keys() {
        let p: TraceParams = toml::from_str("photons = 10\ncaustics = \"separate\"").unwrap();
        assert_eq!(p.photons, 10);
        assert_eq!(p.caustics, CausticStorage::Separate);
        assert_eq!(p.max_depth, TraceParams::default().max_depth);
        assert!(toml::from_str::<TraceParams>("photon = 10").is_err());
    }
}
