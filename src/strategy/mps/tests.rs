//! Tests of Metropolis photon sampling's parts: merging, effective sample size, the area
//! probes and the importon density.

use super::*;
use crate::photon::PhotonMap;
use crate::photon::test_scenes::SceneBuilder;
use crate::sampling::Rng;
use glam::DVec3;

fn deposit(p: Vec3, from: Vec3, power: f64) -> Deposit {
    Deposit {
        map: Map::Global,
        p,
        from,
        wi: (from - p).normalize(),
        n: Vec3::Y,
        flags: 0,
        unit: Vec3::ONE,
        power: DVec3::splat(power),
    }
}

/// Two chains depositing the same path make one photon with both powers; the same point
/// reached from elsewhere, or stored in the other map, stays a photon of its own; power is
/// conserved, and the merge goes by the path, not by where its deposits sit in the list.
#[test]
fn repeated_paths_across_chains_merge_into_one_photon() {
    let (a, b, up) = (Vec3::ZERO, Vec3::X, Vec3::Y);
    let mut caustic = deposit(a, up, 8.0);
    caustic.map = Map::Caustic;
    let chains = vec![
        deposit(a, up, 1.0),
        deposit(b, up, 2.0),
        deposit(a, up + Vec3::X, 4.0),
        caustic,
        deposit(a, up, 16.0),
    ];
    let merged = merge_repeated_paths(chains.clone());
    assert_eq!(merged.len(), 4);
    let total: f64 = merged.iter().map(|d| d.power.x).sum();
    assert_eq!(total, 31.0);
    let same = merged
        .iter()
        .find(|d| d.map == Map::Global && d.p == a && d.from == up)
        .unwrap();
    assert_eq!(same.power.x, 17.0);
    let reversed = merge_repeated_paths(chains.into_iter().rev().collect());
    let key = |v: &[Deposit]| v.iter().map(|d| (d.p, d.from, d.power.x)).collect::<Vec<_>>();
    let mut k1 = key(&merged);
    let mut k2 = key(&reversed);
    let cmp = |x: &(Vec3, Vec3, f64), y: &(Vec3, Vec3, f64)| x.2.total_cmp(&y.2);
    k1.sort_by(cmp);
    k2.sort_by(cmp);
    assert_eq!(k1, k2);
}

fn photons(powers: &[f32]) -> Vec<Photon> {
    powers
        .iter()
        .map(|&w| Photon::new(Vec3::ZERO, Vec3::splat(w), Vec3::Y, Vec3::Y, 0))
        .collect()
}

#[test]
fn effective_sample_size_counts_equal_photons_and_discounts_heavy_ones() {
    assert!((effective_sample_size(&photons(&[0.5; 100])) - 100.0).abs() < 0.5);
    // One photon holding as much power as 99 light ones: (2)² / (1 + 99 / 99²) ≈ 3.96.
    let mut heavy = vec![1.0 / 99.0; 99];
    heavy.push(1.0);
    let ess = effective_sample_size(&photons(&heavy));
    assert!((ess - 3.96).abs() < 0.05, "ESS {ess}");
    assert_eq!(effective_sample_size(&[]), 0.0);
}

/// A diffuse unit square [0, 1] × {0} × [0, 1] facing +y (a light far above it), and, when
/// given, a diffuse sphere of radius `sphere` at (3, 0, 0).
fn square_scene(sphere: Option<f32>) -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.lambertian(Vec3::splat(0.5));
    b.quad(Vec3::ZERO, Vec3::Z, Vec3::X, m, None);
    b.quad(Vec3::new(0.0, 10.0, 0.0), Vec3::X, Vec3::Z, m, Some(Vec3::ONE));
    if let Some(radius) = sphere {
        b.sphere(Vec3::new(3.0, 0.0, 0.0), radius, m);
    }
    b.build()
}

/// Mean and standard error of `n` draws.
fn mean_and_error(n: usize, mut draw: impl FnMut(usize) -> f64) -> (f64, f64) {
    let xs: Vec<f64> = (0..n).map(&mut draw).collect();
    let mean = xs.iter().sum::<f64>() / n as f64;
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    (mean, (var / n as f64).sqrt())
}

#[test]
fn surface_area_in_ball_is_exact_in_expectation_at_edges_corners_and_on_a_sphere() {
    let scene = square_scene(Some(0.5));
    let (r, pi) = (0.2f32, std::f64::consts::PI);
    let disc = pi * (r as f64).powi(2);
    // The part of the disc of radius r within distance d of its centre's side of a chord.
    let cut = |d: f64| {
        let r = r as f64;
        disc - (r * r * (d / r).acos() - d * (r * r - d * d).sqrt())
    };
    // A sphere's area within 3-D distance r of a point on it is π r² (Archimedes); the disc
    // projected onto the tangent plane is smaller (0.84 π r² at r = 0.8 R at the probe's
    // depth), so this checks the 1 / (n_y · n) Jacobian.
    let top = Vec3::new(3.0, 0.5, 0.0);
    let r_sphere = 0.4f32;
    let cases = [
        ("inside", Vec3::new(0.5, 0.0, 0.5), Vec3::Y, r, disc),
        ("edge", Vec3::new(0.5, 0.0, 0.0), Vec3::Y, r, disc / 2.0),
        ("near edge", Vec3::new(0.5, 0.0, 0.1), Vec3::Y, r, cut(0.1)),
        ("corner", Vec3::ZERO, Vec3::Y, r, disc / 4.0),
        ("sphere", top, Vec3::Y, r_sphere, pi * (r_sphere as f64).powi(2)),
    ];
    // In sight or not makes no difference here: nothing stands on these surfaces.
    for sight_lift in [None, Some(1e-5)] {
        let rule = DensityRule {
            edge_probes: 16,
            sight_lift,
        };
        for (i, (name, p, n, r, expected)) in cases.into_iter().enumerate() {
            let mut rng = Rng::for_task(1, [i as u64, 0, 0]);
            let (mean, err) = mean_and_error(4000, |_| surface_area_in_ball(&scene, p, n, r, 0.5, &rule, &mut rng));
            let z = (mean - expected) / err.max(1e-12);
            assert!(
                z.abs() < 4.0 || (mean / expected - 1.0).abs() < 1e-5,
                "{name} ({sight_lift:?}): mean {mean:.6} ± {err:.2e}, expected {expected:.6} (z = {z:.1})"
            );
        }
    }
}

/// Global-map importons at `positions` on the floor y = 0 (arriving from above), one per
/// path, with 16-nearest estimates under `rule`.
fn floor_importons(positions: impl Iterator<Item = (f32, f32)>, rule: DensityRule) -> Importons {
    let global: Vec<Photon> = positions
        .map(|(x, z)| Photon::new(Vec3::new(x, 0.0, z), Vec3::ONE, Vec3::Y, Vec3::Y, 0))
        .collect();
    Importons {
        caustic: PhotonMap::build(Vec::new()),
        paths: global.len() as u64,
        global: PhotonMap::build(global),
        estimate: EstimateParams {
            nearest: 16,
            ..EstimateParams::default()
        },
        rule,
    }
}

/// Uniform importons on the unit square, `paths` of them (density q_s = 1 per path and
/// unit area).
fn square_importons(paths: u64, edge_probes: usize, rng: &mut Rng) -> Importons {
    let positions: Vec<(f32, f32)> = (0..paths).map(|_| rng.uniform2().into()).collect();
    let rule = DensityRule {
        edge_probes,
        sight_lift: None,
    };
    floor_importons(positions.into_iter(), rule)
}

#[test]
fn inverse_importon_density_is_unbiased_at_edges_and_corners_only_with_edge_probes() {
    let scene = square_scene(None);
    let points = [
        ("inside", Vec3::new(0.5, 0.0, 0.5)),
        ("edge", Vec3::new(0.5, 0.0, 0.0)),
        ("corner", Vec3::ZERO),
    ];
    let (runs, paths) = (1500, 2000);
    for probes in [0, 16] {
        for (i, (name, p)) in points.into_iter().enumerate() {
            let mut rng = Rng::for_task(2, [probes as u64, i as u64, 0]);
            let (mean, err) = mean_and_error(runs, |_| {
                let imp = square_importons(paths, probes, &mut rng);
                imp.inverse_density(&scene, Map::Global, p, Vec3::Y, &mut rng).unwrap()
            });
            // With `paths` uniform points E[A / k] = 1 / q_s · paths / (paths + 1).
            let expected = paths as f64 / (paths + 1) as f64;
            let z = (mean - expected) / err;
            if probes > 0 || name == "inside" {
                assert!(
                    z.abs() < 4.0,
                    "{probes} probes, {name}: mean {mean:.4} ± {err:.4}, z = {z:.1}"
                );
            } else {
                // π r² at an edge overstates the area twofold, at a corner fourfold.
                let bias = if name == "edge" { 2.0 } else { 4.0 };
                assert!(
                    (mean / bias - 1.0).abs() < 0.1,
                    "{name} without probes: mean {mean:.3}, expected ≈ {bias}"
                );
            }
        }
    }
}

/// A floor [0, 2] × {0} × [0, 1] facing +y split by a thin wall (two quads, at x = 1 and
/// x = 1.01, 0.5 high) standing on it, a light far above.
fn walled_floor_scene() -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.lambertian(Vec3::splat(0.5));
    b.quad(Vec3::ZERO, Vec3::Z, Vec3::X * 2.0, m, None);
    b.quad(Vec3::X, Vec3::Y * 0.5, Vec3::Z, m, None);
    b.quad(Vec3::new(1.01, 0.0, 0.0), Vec3::Z, Vec3::Y * 0.5, m, None);
    b.quad(Vec3::new(0.0, 10.0, 0.0), Vec3::X, Vec3::Z, m, Some(Vec3::ONE));
    b.build()
}

#[test]
fn importon_density_in_sight_does_not_leak_through_a_thin_wall() {
    // Importons 10× denser behind the wall than in front of it; a photon 2 cm in front of
    // the wall, whose 16-nearest disc (r ≈ 0.05) reaches behind it.
    let scene = walled_floor_scene();
    let (front, behind) = (1000u64, 10_000u64);
    let paths = front + behind;
    let p = Vec3::new(0.98, 0.0, 0.5);
    let draw = |rule: DensityRule, rng: &mut Rng| {
        let positions: Vec<(f32, f32)> = (0..paths)
            .map(|i| {
                let u = rng.uniform2();
                (if i < front { u.x } else { 1.01 + 0.99 * u.x }, u.y)
            })
            .collect();
        let imp = floor_importons(positions.into_iter(), rule);
        imp.inverse_density(&scene, Map::Global, p, Vec3::Y, rng).unwrap()
    };
    // In front of the wall q_s = front / paths per unit area.
    let expected = paths as f64 / front as f64 * front as f64 / (front + 1) as f64;
    for sight_lift in [Some(1e-5), None] {
        let rule = DensityRule {
            edge_probes: 16,
            sight_lift,
        };
        let mut rng = Rng::for_task(3, [sight_lift.is_some() as u64, 0, 0]);
        let (mean, err) = mean_and_error(1000, |_| draw(rule, &mut rng));
        let z = (mean - expected) / err;
        if sight_lift.is_some() {
            assert!(
                z.abs() < 4.0,
                "in sight: mean {mean:.3} ± {err:.3}, expected {expected:.3}, z = {z:.1}"
            );
        } else {
            // Counting the dense importons behind the wall makes the photon far too light.
            assert!(
                mean < 0.7 * expected,
                "through the wall: mean {mean:.3}, expected {expected:.3}"
            );
        }
    }
}
