//! The Metropolis chain samples f_eye: for BD alone and for each other proposal mixed with BD,
//! the chain's image (expected-value splats, as `mlt` renders) matches path tracing block by
//! block within a statistical tolerance. A wrong transition density T(X|Y) / T(Y|X) biases
//! the paths that proposal produces (a missing whole-path deletion in BD, found by this test,
//! left the light's reflection in the mirror sphere 35 % too dark).
//!
//! Tolerance: each chain's estimate is independent of the others (own stream, own resampled
//! first state), so the spread over the 64 chains gives the standard error of their mean; the
//! path-traced blocks' error comes from 8 independent renders, and B_eye's relative standard
//! error applies to every block alike. |z| < 4.5 for each of the 16 blocks.

use glam::Vec3;
use photon_bench::camera::Camera;
use photon_bench::film::Film;
use photon_bench::metropolis::proposals::Context;
use photon_bench::metropolis::{Chain, MetropolisParams, ProposalMix, State, Tally, estimate_b, prepare_user_paths};
use photon_bench::sampling::Rng;
use photon_bench::sampling::chi2::chi2_upper_tail;
use photon_bench::scene::{Scene, UserPath, load_scene, luminance};
use photon_bench::strategy;

const W: u32 = 24;
const H: u32 = 24;
const BLOCKS: usize = 4;

/// cornell-spheres (mirror and glass spheres: caustics, specular chains) at 24 × 24, with one
/// user path from the light to the floor.
fn scene() -> Scene {
    let mut scene = load_scene(std::path::Path::new("scenes/cornell-spheres.toml")).unwrap();
    let c = &scene.camera;
    scene.camera = Camera::new(c.eye, c.look_at, c.up, c.fov_y_deg, W, H);
    scene.user_paths.push(UserPath {
        points: vec![Vec3::new(0.278, 0.5478, 0.2795), Vec3::new(0.2, 0.0, 0.3)],
        cone_deg: vec![10.0],
    });
    scene
}

fn block_of(x: usize, y: usize) -> usize {
    (y * BLOCKS / H as usize) * BLOCKS + x * BLOCKS / W as usize
}

/// Block means of path tracing, from 8 independent 96-spp renders.
fn path_blocks(scene: &Scene) -> Vec<(f64, f64)> {
    let path = strategy::build("path", toml::Table::new()).unwrap();
    let runs: Vec<[f64; BLOCKS * BLOCKS]> = (0..8)
        .map(|seed| {
            let mut film = Film::new(W, H);
            path.render_pass(scene, 1000 + seed, 0..96, &mut film);
            let img = film.image();
            let mut blocks = [0.0; BLOCKS * BLOCKS];
            for y in 0..H as usize {
                for x in 0..W as usize {
                    blocks[block_of(x, y)] += luminance(img.pixels[y * W as usize + x]) as f64;
                }
            }
            let per_block = (W * H) as f64 / (BLOCKS * BLOCKS) as f64;
            blocks.map(|b| b / per_block)
        })
        .collect();
    mean_se_n(&runs)
}

/// Path functionals h(X) whose integrals ∫ h f_Y dμ the chain must reproduce: the path
/// length (1 … ≥ 6 edges) split by whether a specular vertex occurs, and the length of the
/// edge x_{k−2} x_{k−1} in four bins (the vertex most proposals move).
const FEATURES: usize = 12 + 4;

fn features(path: &[photon_bench::path_space::Vertex]) -> [usize; 2] {
    let k = path.len() - 1;
    let specular = path.iter().any(|v| v.delta) as usize;
    let by_length = (k.min(6) - 1) * 2 + specular;
    let edge = if k >= 2 {
        (path[k - 1].p - path[k - 2].p).length()
    } else {
        0.0
    };
    let by_edge = 12 + ((edge / 0.15) as usize).min(3);
    [by_length, by_edge]
}

/// Block estimates, feature estimates (mean, standard error), B's relative standard error and
/// the proposal tallies.
type ChainEstimates = (Vec<(f64, f64)>, Vec<(f64, f64)>, f64, Tally);

/// The chain's estimates, one per chain: block mean luminances and ∫ h f_Y dμ of each
/// feature. Each chain starts from its own state resampled ∝ f / p, so each chain's estimate
/// is unbiased and independent of the others whatever its mixing (a wrong T still biases it;
/// reachability has its own test); the first `burn_in` steps are discarded all the same.
fn chain_estimates(scene: &Scene, proposals: ProposalMix, mutations_per_chain: u64) -> ChainEstimates {
    let params = MetropolisParams {
        proposals,
        b_samples: 200_000,
        chains: 48,
        ..MetropolisParams::default()
    };
    let (b, starts) = estimate_b(scene, &params, 11).unwrap();
    let user_paths = prepare_user_paths(scene).unwrap();
    let per_block = (W * H) as f64 / (BLOCKS * BLOCKS) as f64;
    let burn_in = mutations_per_chain / 8;
    let runs: Vec<([f64; BLOCKS * BLOCKS], [f64; FEATURES], Tally)> = (0..params.chains as u64)
        .map(|c| {
            let ctx = Context::new(scene, &params, &user_paths);
            let mut chain = Chain::new(ctx, State::new(scene, starts[c as usize].clone()).unwrap());
            let mut rng = Rng::for_task(11, [99, c, 0]);
            let mut tally = Tally::default();
            let mut blocks = [0.0; BLOCKS * BLOCKS];
            let mut feats = [0.0; FEATURES];
            let block = |s: &State| block_of(s.raster.x as usize, s.raster.y as usize);
            for i in 0..burn_in + mutations_per_chain {
                let step = chain.step(&mut rng, &mut tally);
                if i >= burn_in {
                    let mut add = |s: &State, w: f64| {
                        blocks[block(s)] += w;
                        for f in features(&s.path) {
                            feats[f] += w;
                        }
                    };
                    add(&chain.current, (1.0 - step.a) as f64);
                    if let Some(cand) = &step.candidate {
                        add(cand, step.a as f64);
                    }
                }
                chain.commit(step);
            }
            // Pixel values are (B / M) Σ splats (pixel area 1): block mean = that / pixels.
            let scale = b.b_y / mutations_per_chain as f64;
            (blocks.map(|s| scale * s / per_block), feats.map(|s| scale * s), tally)
        })
        .collect();
    let mut tally = Tally::default();
    for r in &runs {
        tally.merge(&r.2);
    }
    let blocks: Vec<_> = runs.iter().map(|r| r.0).collect();
    let feats: Vec<_> = runs.iter().map(|r| r.1).collect();
    (mean_se_n(&blocks), mean_se_n(&feats), b.std_error / b.b_y, tally)
}

/// Mean and standard error of each entry over `runs` independent estimates.
fn mean_se_n<const N: usize>(runs: &[[f64; N]]) -> Vec<(f64, f64)> {
    let n = runs.len() as f64;
    (0..N)
        .map(|i| {
            let mean = runs.iter().map(|r| r[i]).sum::<f64>() / n;
            let var = runs.iter().map(|r| (r[i] - mean).powi(2)).sum::<f64>() / (n - 1.0);
            (mean, (var / n).sqrt())
        })
        .collect()
}

/// ∫ h f_Y dμ of each feature by path tracing in path space (the MIS samples of B_eye),
/// with standard errors from 32 batches.
fn path_features(scene: &Scene) -> Vec<(f64, f64)> {
    let batches: Vec<[f64; FEATURES]> = (0..32u64)
        .map(|batch| {
            let n = 16_000u64;
            let mut sum = [0.0; FEATURES];
            for i in 0..n {
                let mut rng = Rng::for_task(5, [batch, i, 0]);
                photon_bench::path_space::walk::path_tracing_sample(scene, 17, &mut rng, &mut |p, c| {
                    for f in features(p) {
                        sum[f] += luminance(c) as f64;
                    }
                });
            }
            sum.map(|s| s / n as f64)
        })
        .collect();
    mean_se_n(&batches)
}

/// z-scores of the chain's estimates against the reference; panics at |z| ≥ 5.
fn z_scores(
    name: &str,
    what: &str,
    chain: &[(f64, f64)],
    reference: &[(f64, f64)],
    b_rel: f64,
    tally: &Tally,
) -> Vec<f64> {
    let mut zs = Vec::new();
    for (i, ((m, se_m), (r, se_r))) in chain.iter().zip(reference).enumerate() {
        let se = (se_m * se_m + se_r * se_r + (m * b_rel).powi(2)).sqrt();
        if se == 0.0 {
            assert_eq!(m, r, "{name}: {what} {i}");
            continue;
        }
        let z = (m - r) / se;
        if std::env::var("MLT_TEST_VERBOSE").is_ok() {
            eprintln!("{name} {what} {i}: {m:.4} ± {se_m:.4} vs {r:.4} ± {se_r:.4}: z {z:.2}");
        }
        zs.push(z);
        assert!(
            z.abs() < 5.0,
            "{name}: {what} {i}: chain {m:.4} ± {se_m:.4}, path tracing {r:.4} ± {se_r:.4}, z = {z:.2} ({:?})",
            tally.counters()
        );
    }
    zs
}

/// Each estimate within |z| < 5, and jointly Σ z² below the 10⁻⁴ upper quantile of χ² with
/// one degree of freedom per estimate: a small bias spread over many estimates (a wrong
/// Jacobian in one proposal) fails the joint test before any single z gets large.
fn check(name: &str, proposals: ProposalMix) {
    let scene = scene();
    let (blocks, feats, b_rel, tally) = chain_estimates(&scene, proposals, 40_000);
    let mut zs = z_scores(name, "block", &blocks, &path_blocks(&scene), b_rel, &tally);
    zs.extend(z_scores(name, "feature", &feats, &path_features(&scene), b_rel, &tally));
    let chi2: f64 = zs.iter().map(|z| z * z).sum();
    let p = chi2_upper_tail(chi2, zs.len());
    eprintln!(
        "{name}: Σz² = {chi2:.1} over {} estimates (p = {p:.2e}); {:?}",
        zs.len(),
        tally.counters()
    );
    assert!(
        p > 1e-4,
        "{name}: Σz² = {chi2:.1} over {} estimates, p = {p:.2e}",
        zs.len()
    );
}

fn mix(f: impl FnOnce(&mut ProposalMix)) -> ProposalMix {
    let mut m = ProposalMix {
        up: 0.0,
        bd: 0.5,
        pm: 0.0,
        cp: 0.0,
        lp: 0.0,
        ls: 0.0,
    };
    f(&mut m);
    m
}

#[test]
fn bd_alone_samples_f_eye() {
    check("bd", mix(|m| m.bd = 1.0));
}

#[test]
fn ls_with_bd_samples_f_eye() {
    check("ls+bd", mix(|m| m.ls = 0.5));
}

#[test]
fn lp_with_bd_samples_f_eye() {
    check("lp+bd", mix(|m| m.lp = 0.5));
}

#[test]
fn cp_with_bd_samples_f_eye() {
    check("cp+bd", mix(|m| m.cp = 0.5));
}

#[test]
fn pm_with_bd_samples_f_eye() {
    check("pm+bd", mix(|m| m.pm = 0.5));
}

#[test]
fn up_with_bd_samples_f_eye() {
    check("up+bd", mix(|m| m.up = 0.5));
}

#[test]
fn up_without_user_paths_is_refused_with_a_clear_error() {
    let scene = load_scene(std::path::Path::new("scenes/cornell-spheres.toml")).unwrap();
    let table: toml::Table = toml::from_str("proposals = { up = 0.5, bd = 0.5 }").unwrap();
    for kind in ["mlt", "mps"] {
        let mut s = strategy::build(kind, table.clone()).unwrap();
        let err = s.prepare(&scene, 1).unwrap_err().to_string();
        assert!(err.contains("user_paths") && err.contains("up = 0.5"), "{kind}: {err}");
    }
}

#[test]
fn proposal_probabilities_are_validated() {
    for (text, expect) in [
        ("proposals = { bd = 0.5, ls = 0.4 }", "sum to 1"),
        ("proposals = { bd = 1.5, ls = -0.5 }", "proposals.bd"),
        ("proposals = { up = 1.0 }", "needs bd > 0"),
        ("proposals = { bd = 1.0, xx = 0.0 }", "xx"),
    ] {
        let table: toml::Table = toml::from_str(text).unwrap();
        for kind in ["mlt", "mps"] {
            let err = strategy::build(kind, table.clone())
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default();
            assert!(err.contains(expect), "{kind} {text}: got `{err}`");
        }
    }
}

/// Ergodicity where it is hardest: a path L S E (the light seen in the mirror sphere) has no
/// non-specular interior vertex, so BD reaches it only by deleting the whole path and
/// regenerating it from the eye until the walk finds the light. Chains started on a
/// diffuse path L D E must propose such paths (about 1 in 10⁵ steps here).
#[test]
fn bd_reaches_the_light_seen_in_a_mirror_from_a_diffuse_path() {
    let scene = scene();
    let params = MetropolisParams {
        proposals: mix(|m| m.bd = 1.0),
        b_samples: 50_000,
        chains: 64,
        ..MetropolisParams::default()
    };
    let (_, starts) = estimate_b(&scene, &params, 3).unwrap();
    let diffuse = starts
        .iter()
        .find(|p| p.len() == 3 && p.iter().all(|v| !v.delta))
        .expect("a resampled L D E path");
    let user_paths = prepare_user_paths(&scene).unwrap();
    let mut tally = Tally::default();
    let mut proposed = 0u64;
    for c in 0..16u64 {
        let ctx = Context::new(&scene, &params, &user_paths);
        let mut chain = Chain::new(ctx, State::new(&scene, diffuse.clone()).unwrap());
        let mut rng = Rng::for_task(3, [98, c, 0]);
        for _ in 0..150_000 {
            let step = chain.step(&mut rng, &mut tally);
            if let Some(p) = step.candidate.as_ref().map(|s| &s.path) {
                proposed += u64::from(p.len() == 3 && p[1].delta);
            }
            chain.commit(step);
        }
    }
    assert!(
        proposed > 0,
        "BD never proposed L S E in 2.4 M steps ({:?})",
        tally.counters()
    );
    eprintln!("L S E proposed {proposed} times");
}

/// An open box (1 m, no front wall) with a ceiling light: from the light every floor point is
/// visible, and the camera in front sees part of the floor.
const OPEN_BOX: &str = r#"
[camera]
eye = [0.5, 0.5, -1.2]
look_at = [0.5, 0.4, 0.5]
up = [0, 1, 0]
fov_y = 40
resolution = [32, 24]

[materials.white]
type = "diffuse"
reflectance = [0.7, 0.7, 0.7]

[[shapes]]
type = "quad"
material = "white"
center = [0.5, 0.0, 0.5]
size = [1.0, 1.0]
facing = "+y"

[[shapes]]
type = "quad"
material = "white"
center = [0.5, 1.0, 0.5]
size = [1.0, 1.0]
facing = "-y"

[[shapes]]
type = "quad"
material = "white"
center = [0.5, 0.5, 1.0]
size = [1.0, 1.0]
facing = "-z"

[[shapes]]
type = "quad"
material = "white"
center = [0.2, 0.999, 0.5]
size = [0.2, 0.2]
facing = "-y"
emission = { radiance = [10, 10, 10], two_sided = false }
"#;

fn open_box() -> Scene {
    let file = std::path::Path::new("open-box.toml");
    photon_bench::scene::load::load_scene_bytes(file, OPEN_BOX.as_bytes())
        .unwrap()
        .0
}

/// E over proposals Y ~ T(·|X) of g(Y) / T(Y|X) is ∫ g dμ over where T > 0: with g the
/// indicator "the one new vertex lies on the floor", the floor area the proposal can reach.
/// This checks a proposal's reported T against the distribution of its own candidates.
fn integrate_over_floor(samples: &[f64], area: f64, what: &str) {
    let n = samples.len() as f64;
    let mean = samples.iter().sum::<f64>() / n;
    let var = samples.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let se = (var / n).sqrt();
    let z = (mean - area) / se;
    eprintln!("{what}: E[g/T] = {mean:.4} ± {se:.4}, reachable floor area {area:.4}, z = {z:.2}");
    assert!(
        z.abs() < 4.5,
        "{what}: E[g/T] = {mean:.4} ± {se:.4}, expected {area:.4} (z = {z:.2})"
    );
}

#[test]
fn bd_and_ls_transition_densities_match_their_own_candidates() {
    use photon_bench::metropolis::proposals::{bidirectional, lens_subpath};
    use photon_bench::path_space::walk::trace_from;
    use photon_bench::path_space::{Vertex, pdf_eye_side};
    let scene = open_box();
    let params = MetropolisParams::default();
    let ctx = Context::new(&scene, &params, &[]);
    // X = L D E: light centre, a point on the back wall, the eye.
    let x0 = Vertex::light(&scene, 0, Vec3::new(0.2, 0.999, 0.5), -Vec3::Y);
    let x1 = trace_from(&scene, &x0, (Vec3::new(0.6, 0.5, 1.0) - x0.p).normalize()).unwrap();
    let x = vec![x0, x1, Vertex::eye(&scene)];
    let on_floor = |v: &Vertex| v.p.y.abs() < 1e-4;
    let n = 200_000;
    let mut rng = Rng::for_task(1, [0, 0, 0]);

    // BD: deleting x1 alone and adding one vertex, from the light (any floor point) or from
    // the eye; the whole floor is reachable from the light.
    let bd: Vec<f64> = (0..n)
        .map(|_| match bidirectional(&ctx, &x, &mut rng) {
            Some((y, 0, 1)) if y.len() == 3 && on_floor(&y[1]) => {
                1.0 / photon_bench::metropolis::proposals::bd_density(&ctx, &x, &y, 0, 1)
            }
            _ => 0.0,
        })
        .collect();
    integrate_over_floor(&bd, 1.0, "BD");

    // LS: a new eye sub-path through a uniform raster point; reachable: the floor in view.
    let cam = &scene.camera;
    let in_view = (0..400_000)
        .filter(|i| {
            let mut r = Rng::for_task(2, [*i, 0, 0]);
            let u = r.uniform2();
            let p = Vec3::new(u.x, 0.0, u.y);
            cam.raster_position((p - cam.eye).normalize()).is_some()
        })
        .count() as f64
        / 400_000.0;
    let ls: Vec<f64> = (0..n)
        .map(|_| match lens_subpath(&ctx, &x, &mut rng) {
            Some(c) if c.path.len() == 3 && on_floor(&c.path[1]) => 1.0 / pdf_eye_side(&scene, &c.path, 1) as f64,
            _ => 0.0,
        })
        .collect();
    integrate_over_floor(&ls, in_view, "LS");
}

/// PM's density against its own candidates: from X = L D D E in the open box, PM turns the
/// direction x₂ → x₁ (back wall to floor) within a 30° cone; E[1{y on the floor} / T] is the
/// floor area inside that cone (every such point sees the light).
#[test]
fn pm_transition_density_matches_its_own_candidates() {
    use photon_bench::metropolis::proposals::photon_map;
    use photon_bench::path_space::walk::trace_from;
    use photon_bench::path_space::{Vertex, solid_angle_to_area};
    let scene = open_box();
    let params = MetropolisParams::default();
    let ctx = Context::new(&scene, &params, &[]);
    let x0 = Vertex::light(&scene, 0, Vec3::new(0.2, 0.999, 0.5), -Vec3::Y);
    let x1 = trace_from(&scene, &x0, (Vec3::new(0.5, 0.0, 0.6) - x0.p).normalize()).unwrap();
    let x2 = trace_from(&scene, &x1, (Vec3::new(0.5, 0.3, 1.0) - x1.p).normalize()).unwrap();
    let x = vec![x0, x1, x2, Vertex::eye(&scene)];
    let cos_gamma = params.pm_gamma_deg.to_radians().cos();
    let cone_pdf = 1.0 / (std::f64::consts::TAU * (1.0 - cos_gamma as f64));
    let axis = (x1.p - x2.p).normalize();
    let mut rng = Rng::for_task(3, [0, 0, 0]);
    let samples: Vec<f64> = (0..200_000)
        .map(|_| match photon_map(&ctx, &x, &mut rng) {
            Some(c) if c.path.len() == 4 && c.path[1].p.y.abs() < 1e-4 => {
                1.0 / (cone_pdf * solid_angle_to_area(&c.path[2], &c.path[1]) as f64)
            }
            _ => 0.0,
        })
        .collect();
    let inside = (0..400_000u64)
        .filter(|&i| {
            let u = Rng::for_task(4, [i, 0, 0]).uniform2();
            let p = Vec3::new(u.x, 0.0, u.y);
            (p - x2.p).normalize().dot(axis) >= cos_gamma
        })
        .count() as f64
        / 400_000.0;
    integrate_over_floor(&samples, inside, "PM");
}
