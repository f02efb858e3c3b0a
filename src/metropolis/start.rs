//! A chain's start: B_eye estimated by path tracing over the whole image, the first state X₀ of
//! every chain resampled from those paths ∝ their luminance contribution f/p (no start-up bias
//! [Veach 1997, §11.3.1]), and the scene's user paths prepared for the UP proposal.

use super::chain::State;
use super::params::MetropolisParams;
use crate::color::luminance;
use crate::error::Result;
use crate::path_space::Vertex;
use crate::path_space::bidirectional::bidirectional_sample;
use crate::path_space::walk::{path_tracing_sample, trace};
use crate::sampling::Rng;
use crate::scene::Scene;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// A user path prepared for UP: points, cos β per segment, and for each point whether it lies
/// on a specular surface and whether the path reflects there.
#[derive(Clone, Debug)]
pub struct UserPathInfo {
    pub points: Vec<Vec3>,
    pub cos_beta: Vec<f32>,
    pub specular: Vec<bool>,
    pub reflect: Vec<bool>,
}

/// Classifies the scene's user paths (tracing each segment to find the surfaces at its points).
pub fn prepare_user_paths(scene: &Scene) -> Result<Vec<UserPathInfo>> {
    let mut out = Vec::new();
    for (j, u) in scene.user_paths.iter().enumerate() {
        let n = u.points.len();
        let mut specular = vec![false; n];
        let mut normals = vec![Vec3::ZERO; n];
        for i in 1..n {
            let d = (u.points[i] - u.points[i - 1]).normalize_or_zero();
            let hit = trace(scene, &crate::geometry::Ray::new(u.points[i - 1] + d * 1e-4, d));
            let Some(v) = hit.filter(|v| (v.p - u.points[i]).length() < 1e-2) else {
                crate::bail!(
                    "{}: user_paths[{j}]: the segment from point {} to point {i} does not reach point {i} \
                     (blocked or not on a surface)",
                    scene.source.display(),
                    i - 1
                );
            };
            specular[i] = v.delta;
            normals[i] = v.ng;
        }
        if specular[n - 1] {
            crate::bail!(
                "{}: user_paths[{j}]: the last point must lie on a diffuse surface",
                scene.source.display()
            );
        }
        let reflect = (0..n)
            .map(|i| {
                i > 0
                    && i + 1 < n
                    && (u.points[i - 1] - u.points[i]).dot(normals[i]) * (u.points[i + 1] - u.points[i]).dot(normals[i])
                        > 0.0
            })
            .collect();
        out.push(UserPathInfo {
            points: u.points.clone(),
            cos_beta: u.cone_deg.iter().map(|b| b.to_radians().cos()).collect(),
            specular,
            reflect,
        });
    }
    Ok(out)
}

/// The path-tracing estimate of B = ∫ f dμ (per channel; luminance is the paper's B_eye).
#[derive(Clone, Copy, Debug, Default)]
pub struct BEstimate {
    pub b: Vec3,
    pub b_y: f64,
    /// Standard error of `b_y`.
    pub std_error: f64,
    pub samples: u64,
}

/// One path-tracing path as resampling sees it: (sample index, ordinal within it, luminance).
#[derive(Clone, Copy, Debug)]
struct Weighted {
    sample: u64,
    ordinal: u32,
    y: f64,
}

/// Samples per parallel task; fixed so results never depend on the thread count.
const BLOCK: u64 = 1024;

/// Estimates B with `params.b_samples` path-tracing samples and resamples one first state per
/// chain ∝ luminance contribution.
pub fn estimate_b(scene: &Scene, params: &MetropolisParams, seed: u64) -> Result<(BEstimate, Vec<Vec<Vertex>>)> {
    let n = params.b_samples();
    let max_edges = params.max_depth as usize + 1;
    let blocks: Vec<(DVec3, f64, Vec<Weighted>)> = (0..n.div_ceil(BLOCK))
        .into_par_iter()
        .map(|b| {
            let mut sum = DVec3::ZERO;
            let mut sum_sq = 0.0;
            let mut weighted = Vec::new();
            for i in b * BLOCK..((b + 1) * BLOCK).min(n) {
                let mut rng = Rng::for_task(seed, [crate::sampling::stream::B_EYE, i, 0]);
                let mut total = DVec3::ZERO;
                let mut ordinal = 0u32;
                b_sample(scene, max_edges, &mut rng, &mut |_, c| {
                    total += c.as_dvec3();
                    let y = luminance(c) as f64;
                    if y > 0.0 {
                        weighted.push(Weighted { sample: i, ordinal, y });
                    }
                    ordinal += 1;
                });
                sum += total;
                let ty = luminance(total.as_vec3()) as f64;
                sum_sq += ty * ty;
            }
            (sum, sum_sq, weighted)
        })
        .collect();
    let (mut sum, mut sum_sq) = (DVec3::ZERO, 0.0);
    let mut weighted = Vec::new();
    for (s, q, w) in blocks {
        sum += s;
        sum_sq += q;
        weighted.extend(w);
    }
    let b = (sum / n as f64).as_vec3();
    let b_y = luminance(sum.as_vec3()) as f64 / n as f64;
    let var = (sum_sq / n as f64 - b_y * b_y).max(0.0);
    let estimate = BEstimate {
        b,
        b_y,
        std_error: (var / n as f64).sqrt(),
        samples: n,
    };
    if weighted.is_empty() || b_y <= 0.0 {
        crate::bail!(
            "{}: no light reaches the image in {n} path-tracing samples (B_eye = 0); raise b_samples \
             or check the lights",
            scene.source.display()
        );
    }
    let mut cdf = Vec::with_capacity(weighted.len());
    let mut acc = 0.0;
    for w in &weighted {
        acc += w.y;
        cdf.push(acc);
    }
    let starts = (0..params.chains as u64)
        .into_par_iter()
        .map(|c| {
            let mut rng = Rng::for_task(seed, [crate::sampling::stream::CHAIN_START, c, 0]);
            let u = rng.uniform_f64() * acc;
            let pick = weighted[cdf.partition_point(|&x| x <= u).min(weighted.len() - 1)];
            regenerate(scene, max_edges, seed, pick)
        })
        .collect();
    Ok((estimate, starts))
}

/// One sample of B and of the first states. **Decision**: path tracing
/// ([`path_tracing_sample`]) where it reaches every path the chains can, i.e. where every light
/// can be hit by an eye walk (area lights, the environment); with point, spot or directional
/// lights, whose caustics (a specular first bounce) no eye walk and no next-event estimate
/// reaches while the chains' bidirectional mutation does, a bidirectional sample of every
/// technique ([`bidirectional_sample`], Veach's own estimate of B). Without that, B would
/// miss those paths' share and every pixel of the chains' image would be too dark by it.
fn b_sample(scene: &Scene, max_edges: usize, rng: &mut Rng, emit: &mut impl FnMut(&[Vertex], Vec3)) {
    if scene.delta_lights.is_empty() {
        path_tracing_sample(scene, max_edges, rng, emit);
    } else {
        bidirectional_sample(scene, max_edges, rng, emit);
    }
}

/// Re-traces path-tracing sample `w.sample` and returns its `w.ordinal`-th path.
fn regenerate(scene: &Scene, max_edges: usize, seed: u64, w: Weighted) -> Vec<Vertex> {
    let mut rng = Rng::for_task(seed, [crate::sampling::stream::B_EYE, w.sample, 0]);
    let mut ordinal = 0u32;
    let mut found = Vec::new();
    b_sample(scene, max_edges, &mut rng, &mut |path, _| {
        if ordinal == w.ordinal {
            found = path.to_vec();
        }
        ordinal += 1;
    });
    found
}

/// Checks the proposal mix against the scene and estimates B_eye with the chains' first
/// states: the preparation `mlt` and `mps` share.
pub fn prepare_chains(
    scene: &Scene,
    params: &MetropolisParams,
    seed: u64,
) -> Result<(BEstimate, Vec<State>, Vec<UserPathInfo>)> {
    if params.proposals.up > 0.0 && scene.user_paths.is_empty() {
        crate::bail!(
            "proposals.up = {} but the scene {} has no [[user_paths]]: set up = 0 or add user paths",
            params.proposals.up,
            scene.source.display()
        );
    }
    let user_paths = prepare_user_paths(scene)?;
    let (b, paths) = estimate_b(scene, params, seed)?;
    let starts = paths
        .into_iter()
        .map(|p| State::new(scene, p).ok_or_else(|| crate::Error::new("a resampled first state has zero contribution")))
        .collect::<Result<Vec<_>>>()?;
    Ok((b, starts, user_paths))
}

/// Mutations of chain `c` in one block of `total` mutations over `chains` chains.
pub fn chain_share(total: u64, chains: u64, c: u64) -> u64 {
    total / chains + u64::from(c < total % chains)
}
