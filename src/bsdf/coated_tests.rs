//! Tests of the layered models ([`Coated`]). Their `eval` and `pdf` are estimates, so the
//! χ² test of the other models does not apply; instead: the walk converges to the closed forms
//! of its limit cases, sampling and evaluation describe the same scattering (bin by bin), energy
//! is conserved without absorption, reciprocity holds in expectation, and the phase function's
//! sampler passes χ².

use super::coated::{henyey_greenstein as hg, sample_henyey_greenstein as sample_hg};
use super::tests::grey;
use super::*;
use crate::sampling::Rng;
use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_test_directions, chi2_upper_tail};
use std::f32::consts::PI;

fn rough_coat(ior: f32, alpha: f32) -> Coat {
    Coat::Rough(RoughDielectric {
        ior,
        distribution: Microfacet::new(MicrofacetType::Ggx, alpha, alpha, true),
        specular_reflectance: Vec3::ONE,
        specular_transmittance: Vec3::ONE,
    })
}

fn coated(coat: Coat, base: Bsdf, thickness: f32, albedo: f32, g: f32, max_depth: u32) -> Coated {
    Coated {
        coat,
        base,
        thickness,
        albedo: Vec3::splat(albedo),
        g,
        max_depth,
        n_samples: 1,
        pbrt_weights: false,
    }
}

fn diffuse(rho: f32) -> Bsdf {
    Bsdf::Lambertian(Lambertian {
        reflectance: Vec3::splat(rho),
    })
}

fn gold(alpha: Option<f32>) -> Bsdf {
    let ior = ConductorIor::named("Au").expect("gold is a named conductor");
    match alpha {
        None => Bsdf::Conductor(Conductor { ior }),
        Some(a) => Bsdf::RoughConductor(RoughConductor {
            ior,
            distribution: Microfacet::new(MicrofacetType::Ggx, a, a, true),
        }),
    }
}

/// Mean and standard error of `n` draws.
fn mean_and_error(n: usize, mut draw: impl FnMut(usize) -> f64) -> (f64, f64) {
    let (mut s, mut s2) = (0.0, 0.0);
    for i in 0..n {
        let x = draw(i);
        s += x;
        s2 += x * x;
    }
    let mean = s / n as f64;
    (mean, ((s2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt())
}

fn dir(theta: f32, phi: f32) -> Vec3 {
    Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
}

/// A smooth, infinitely thin, clear coating over a Lambertian base has a closed form: the
/// base's light crosses the coating twice and bounces between base and coating as a geometric
/// series, f = ρ (1 − F(θo)) (1 − F(θi)) / (π η² (1 − ρ F̄)), F̄ = 2 ∫ F_inside(μ) μ dμ the
/// coating's reflectance for diffuse light from inside (Mitsuba's `plastic` with `nonlinear`,
/// whose F̄ is a fit; here the integral). The walks' mean must converge to it pair by pair.
#[test]
fn a_thin_smooth_coating_over_a_diffuse_base_converges_to_the_geometric_series() {
    let (eta, rho) = (1.5f32, 0.7f32);
    let model = coated(Coat::Smooth(Dielectric::clear(eta)), diffuse(rho), 0.0, 0.0, 0.0, 100);
    let steps = 20_000;
    let f_bar: f64 = (0..steps)
        .map(|i| {
            let mu = (i as f64 + 0.5) / steps as f64;
            2.0 * fresnel_dielectric(mu as f32, 1.0 / eta) as f64 * mu / steps as f64
        })
        .sum();
    for (k, (wo, wi)) in [
        (dir(0.2, 0.0), dir(0.5, 2.0)),
        (dir(1.2, 1.0), dir(0.1, 4.0)),
        (dir(0.7, 0.3), dir(1.4, 0.3)),
    ]
    .into_iter()
    .enumerate()
    {
        let expected =
            rho as f64 * (1.0 - fresnel_dielectric(wo.z, eta) as f64) * (1.0 - fresnel_dielectric(wi.z, eta) as f64)
                / (std::f64::consts::PI * (eta * eta) as f64 * (1.0 - rho as f64 * f_bar));
        for mode in [TransportMode::Radiance, TransportMode::Importance] {
            let (mean, error) = mean_and_error(40_000, |i| {
                let mut rng = Rng::for_task(k as u64, [i as u64, mode as u64, 1]);
                grey(model.eval_with(wo, wi, mode, &mut rng))
            });
            assert!(
                (mean - expected).abs() < 4.0 * error + 2e-4 * expected,
                "pair {k}, {mode:?}: walks {mean} ± {error}, closed form {expected}"
            );
        }
    }
}

/// The layered models under test: smooth and rough coatings, diffuse and conductor bases,
/// clear, absorbing and scattering slabs.
fn layered_models() -> Vec<(&'static str, Coated)> {
    vec![
        (
            "rough coat, diffuse",
            coated(rough_coat(1.5, 0.3), diffuse(0.8), 0.01, 0.0, 0.0, 10),
        ),
        (
            "smooth coat, diffuse",
            coated(Coat::Smooth(Dielectric::clear(1.5)), diffuse(0.5), 0.01, 0.0, 0.0, 10),
        ),
        (
            "rough coat, smooth gold",
            coated(rough_coat(1.4, 0.2), gold(None), 0.1, 0.0, 0.0, 10),
        ),
        (
            "smooth coat, rough gold",
            coated(
                Coat::Smooth(Dielectric::clear(1.5)),
                gold(Some(0.3)),
                0.01,
                0.0,
                0.0,
                10,
            ),
        ),
        (
            "rough coat, rough gold",
            coated(rough_coat(1.5, 0.1), gold(Some(0.4)), 0.01, 0.0, 0.0, 10),
        ),
        (
            "rough coat, scattering slab",
            coated(rough_coat(1.3, 0.25), diffuse(0.3), 0.5, 0.8, 0.4, 10),
        ),
    ]
}

/// Sampling and evaluation must describe the same scattering: over each cell of the sphere, the
/// mean weight of the samples that land there equals ∫_cell f |cos θi| dω, estimated from `eval`
/// at random points of the cell — the estimate-valued analogue of the χ² test of the other
/// models (whose pdf is exact). The cells' z-scores are pooled into one χ² statistic.
#[test]
fn sampled_weights_agree_with_eval_cell_by_cell() {
    let (theta_bins, phi_bins) = (6usize, 6usize);
    let cells = theta_bins * phi_bins;
    let cell_of = |w: Vec3| -> usize {
        let t = (((1.0 - w.z) * 0.5 * theta_bins as f32) as usize).min(theta_bins - 1);
        let phi = w.y.atan2(w.x).rem_euclid(2.0 * PI);
        t * phi_bins + ((phi / (2.0 * PI) * phi_bins as f32) as usize).min(phi_bins - 1)
    };
    for (m, (name, model)) in layered_models().into_iter().enumerate() {
        let bsdf = Bsdf::Coated(Box::new(model));
        for (k, wo) in [dir(0.3, 0.5), dir(1.3, 2.0)].into_iter().enumerate() {
            let n = 200_000;
            let mut rng = Rng::for_task(m as u64, [k as u64, 7, 0]);
            let (mut sum, mut sum2) = (vec![0.0f64; cells], vec![0.0f64; cells]);
            for _ in 0..n {
                let (u, u_lobe) = (rng.uniform2(), rng.uniform());
                let Some(s) = bsdf.sample(wo, u, u_lobe, TransportMode::Radiance) else {
                    continue;
                };
                if s.delta {
                    continue;
                }
                let w = grey(s.f) * s.wi.z.abs() as f64 / s.pdf_w as f64;
                sum[cell_of(s.wi)] += w;
                sum2[cell_of(s.wi)] += w * w;
            }
            // ∫_cell f |cos| dω by uniform points of the cell (area 4π / cells each).
            let per_cell = 3000;
            let mut chi2 = 0.0;
            let mut worst = (0.0, 0);
            for c in 0..cells {
                let (t, p) = ((c / phi_bins) as f32, (c % phi_bins) as f32);
                let (by_eval, eval_error) = mean_and_error(per_cell, |_| {
                    let z = 1.0 - 2.0 * (t + rng.uniform()) / theta_bins as f32;
                    let phi = 2.0 * PI * (p + rng.uniform()) / phi_bins as f32;
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    let wi = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                    grey(bsdf.eval(wo, wi, TransportMode::Radiance)) * z.abs() as f64 * 4.0 * std::f64::consts::PI
                        / cells as f64
                });
                let by_sampling = sum[c] / n as f64;
                let sampling_error = ((sum2[c] / n as f64 - by_sampling * by_sampling).max(0.0) / n as f64).sqrt();
                let var = eval_error * eval_error + sampling_error * sampling_error;
                if var > 0.0 {
                    let z2 = (by_eval - by_sampling).powi(2) / var;
                    chi2 += z2;
                    if z2 > worst.0 {
                        worst = (z2, c);
                    }
                } else {
                    assert!(
                        by_eval == 0.0 && by_sampling == 0.0,
                        "{name}: cell {c} empty on one side only"
                    );
                }
            }
            let p = chi2_upper_tail(chi2, cells);
            assert!(
                p > CHI2_ALPHA,
                "{name}, wo = {wo}: χ² = {chi2:.1} over {cells} cells (p = {p:.2e}); worst cell {} (z² = {:.1})",
                worst.1,
                worst.0
            );
        }
    }
}

/// Without absorption (a white base under a thin clear coating, walks long enough) every bit
/// of light comes back: the mean sample weight, delta lobe included, is one. pbrt's default
/// slab (thickness 0.01) absorbs a little, and its ten events lose a little more.
#[test]
fn a_white_base_under_a_clear_thin_coating_reflects_everything() {
    let lossless = coated(Coat::Smooth(Dielectric::clear(1.5)), diffuse(1.0), 0.0, 0.0, 0.0, 100);
    let defaults = coated(Coat::Smooth(Dielectric::clear(1.5)), diffuse(1.0), 0.01, 0.0, 0.0, 10);
    for (k, wo) in [dir(0.0, 0.0), dir(0.8, 1.0), dir(1.45, 3.0)].into_iter().enumerate() {
        let albedo = |model: &Coated| {
            let bsdf = Bsdf::Coated(Box::new(model.clone()));
            let mut rng = Rng::for_task(3, [k as u64, 0, 0]);
            mean_and_error(100_000, |_| {
                let (u, u_lobe) = (rng.uniform2(), rng.uniform());
                bsdf.sample(wo, u, u_lobe, TransportMode::Radiance)
                    .map_or(0.0, |s| grey(s.f) * s.wi.z.abs() as f64 / s.pdf_w as f64)
            })
        };
        let (mean, error) = albedo(&lossless);
        assert!(
            (mean - 1.0).abs() < 4.0 * error + 1e-3,
            "wo = {wo}: albedo {mean} ± {error}"
        );
        let (lossy, error) = albedo(&defaults);
        assert!(
            lossy < 1.0 - 4.0 * error && lossy > 0.85,
            "wo = {wo}: pbrt defaults give {lossy} ± {error}"
        );
    }
}

/// A smooth coating on a smooth conductor is one mirror lobe whose coefficient is the walk's
/// expectation: the closed form against the mean of pbrt's walks.
#[test]
fn a_mirror_coating_reflects_the_mean_of_the_walks() {
    for thickness in [0.0, 0.3] {
        let model = coated(
            Coat::Smooth(Dielectric::clear(1.6)),
            gold(None),
            thickness,
            0.0,
            0.0,
            10,
        );
        assert!(model.is_mirror());
        for (k, theta) in [0.1f32, 0.9, 1.4].into_iter().enumerate() {
            let wo = dir(theta, 0.4);
            let expected = model.mirror_reflectance(wo.z);
            let mut rng = Rng::for_task(11, [k as u64, 0, 0]);
            for channel in 0..3 {
                let (mean, error) = mean_and_error(100_000, |_| {
                    let (u, u_lobe) = (rng.uniform2(), rng.uniform());
                    model.walk_for_tests(wo, u, u_lobe, &mut rng).map_or(0.0, |(w, wi)| {
                        assert!(
                            (wi - reflect_z(wo)).length() < 1e-4,
                            "a walk left off the mirror direction: {wi}"
                        );
                        w[channel] as f64
                    })
                });
                let e = expected[channel] as f64;
                assert!(
                    (mean - e).abs() < 4.0 * error + 1e-4,
                    "θ = {theta}, channel {channel}: walks {mean} ± {error}, closed form {e}"
                );
            }
        }
    }
}

/// Reciprocity in expectation: the importance BSDF at (wo, wi) is the radiance BSDF at (wi, wo).
#[test]
fn layered_models_are_reciprocal_in_expectation() {
    for (m, (name, model)) in layered_models().into_iter().enumerate() {
        for (k, (a, b)) in [(dir(0.3, 0.0), dir(1.0, 2.5)), (dir(1.2, 1.0), dir(0.6, 1.3))]
            .into_iter()
            .enumerate()
        {
            let mean = |wo: Vec3, wi: Vec3, mode: TransportMode, tag: u64| {
                mean_and_error(30_000, |i| {
                    let mut rng = Rng::for_task(m as u64, [k as u64, i as u64, tag]);
                    grey(model.eval_with(wo, wi, mode, &mut rng))
                })
            };
            let (f_ab, e_ab) = mean(a, b, TransportMode::Radiance, 1);
            let (f_ba, e_ba) = mean(b, a, TransportMode::Importance, 2);
            let error = (e_ab * e_ab + e_ba * e_ba).sqrt();
            assert!(
                (f_ab - f_ba).abs() < 4.5 * error + 1e-4 * f_ab,
                "{name}: f(a→b) {f_ab} vs f*(b→a) {f_ba} ± {error}"
            );
        }
    }
}

/// pbrt-v4's connection weights (`pbrt_weights`, [`Coated`]'s finding) are biased where the
/// coating is rough: the same tests reject them, which shows both that the option reproduces
/// pbrt's estimator and that the tests above can fail.
#[test]
fn pbrt_connection_weights_are_biased_under_a_rough_coating() {
    let exact = coated(rough_coat(1.5, 0.3), diffuse(0.8), 0.01, 0.0, 0.0, 10);
    let pbrt = Coated {
        pbrt_weights: true,
        ..exact.clone()
    };
    let (a, b) = (dir(0.3, 0.0), dir(1.0, 2.5));
    let mean = |model: &Coated, wo: Vec3, wi: Vec3, mode: TransportMode| {
        mean_and_error(60_000, |i| {
            let mut rng = Rng::for_task(5, [i as u64, mode as u64, 0]);
            grey(model.eval_with(wo, wi, mode, &mut rng))
        })
    };
    let (exact_ab, e1) = mean(&exact, a, b, TransportMode::Radiance);
    let (pbrt_ab, e2) = mean(&pbrt, a, b, TransportMode::Radiance);
    let (pbrt_ba, e3) = mean(&pbrt, b, a, TransportMode::Importance);
    let relative = |x: f64| x / exact_ab - 1.0;
    assert!(
        (pbrt_ab - pbrt_ba).abs() > 4.0 * (e2 * e2 + e3 * e3).sqrt(),
        "pbrt's weights came out reciprocal: {pbrt_ab} vs {pbrt_ba}"
    );
    assert!(
        (pbrt_ab - exact_ab).abs() > 4.0 * (e1 * e1 + e2 * e2).sqrt(),
        "pbrt's weights agree with the exact ones: {pbrt_ab} vs {exact_ab} ({:+.2} %)",
        100.0 * relative(pbrt_ab)
    );
}

#[test]
fn henyey_greenstein_sampling_passes_chi2() {
    for (k, g) in [-0.7f32, 0.0, 0.3, 0.9].into_iter().enumerate() {
        let wo = dir(0.7, 1.1);
        let report = chi2_test_directions(
            |rng: &mut Rng| Some(sample_hg(wo, g, rng.uniform2())),
            |wi| hg(wo.dot(wi), g),
            DirectionTest {
                seed: 40 + k as u64,
                ..DirectionTest::default()
            },
        );
        assert!(report.passes(CHI2_ALPHA), "g = {g}: {report:?}");
    }
}

#[test]
fn layered_models_are_classified_and_validated() {
    let smooth_diffuse = Bsdf::Coated(Box::new(coated(
        Coat::Smooth(Dielectric::clear(1.5)),
        diffuse(0.5),
        0.01,
        0.0,
        0.0,
        10,
    )));
    assert!(smooth_diffuse.mixes_delta() && smooth_diffuse.is_stochastic());
    assert_eq!(smooth_diffuse.kind(), SurfaceKind::Diffuse);
    let mirror = Bsdf::Coated(Box::new(coated(
        Coat::Smooth(Dielectric::clear(1.5)),
        gold(None),
        0.01,
        0.0,
        0.0,
        10,
    )));
    assert!(mirror.is_delta() && !mirror.is_stochastic() && !mirror.mixes_delta());
    let glossy = Bsdf::Coated(Box::new(coated(
        rough_coat(1.5, 0.2),
        gold(Some(0.2)),
        0.01,
        0.0,
        0.0,
        10,
    )));
    assert_eq!(glossy.kind(), SurfaceKind::Glossy);
    for bad in [
        coated(Coat::Smooth(Dielectric::clear(1.5)), gold(None), 0.5, 0.5, 0.0, 10),
        coated(rough_coat(1.5, 0.2), diffuse(0.5), -1.0, 0.0, 0.0, 10),
        coated(rough_coat(1.5, 0.2), diffuse(0.5), 0.1, 0.0, 1.0, 10),
        coated(rough_coat(1.5, 0.2), diffuse(0.5), 0.1, 0.0, 0.0, 0),
        coated(
            rough_coat(1.5, 0.2),
            Bsdf::Mirror(Mirror { reflectance: Vec3::ONE }),
            0.1,
            0.0,
            0.0,
            10,
        ),
    ] {
        assert!(
            Bsdf::Coated(Box::new(bad.clone())).validate().is_err(),
            "{bad:?} was accepted"
        );
    }
    // Estimates are functions of their arguments.
    let (wo, wi) = (dir(0.4, 0.2), dir(0.9, 2.0));
    assert_eq!(
        smooth_diffuse.eval(wo, wi, TransportMode::Radiance),
        smooth_diffuse.eval(wo, wi, TransportMode::Radiance)
    );
    assert_eq!(smooth_diffuse.pdf(wo, wi), smooth_diffuse.pdf(wo, wi));
}

/// The coating's samplers restricted to one lobe (the walks' steps) pass χ² against their
/// restricted densities, from outside and from inside.
#[test]
fn restricted_dielectric_samplers_pass_chi2() {
    let Coat::Rough(d) = rough_coat(1.5, 0.3) else {
        unreachable!()
    };
    for (k, lobes) in [Lobes::Reflection, Lobes::Transmission, Lobes::All]
        .into_iter()
        .enumerate()
    {
        for (j, wo) in [dir(0.4, 0.3), dir(1.3, 2.0), -dir(0.5, 1.0)].into_iter().enumerate() {
            let report = chi2_test_directions(
                |rng: &mut Rng| {
                    let (u, u_lobe) = (rng.uniform2(), rng.uniform());
                    d.sample_lobes(wo, u, u_lobe, TransportMode::Radiance, lobes)
                        .map(|s| (s.wi, s.pdf_w))
                },
                |wi| d.pdf_lobes(wo, wi, lobes),
                DirectionTest {
                    seed: 60 + (k * 3 + j) as u64,
                    ..DirectionTest::default()
                },
            );
            assert!(report.passes(CHI2_ALPHA), "{lobes:?}, wo = {wo}: {report:?}");
        }
    }
}

/// The size of pbrt's bias (docs/user-guide.md, "Layered materials"): directional albedo by
/// `eval` with pbrt's and with the corrected weights against the model's own sampling, for a
/// rough coating over a diffuse base; `--nocapture` prints the table (`cargo test --release
/// --lib measure_pbrt_weight_bias -- --nocapture`). It fails if the corrected weights stray
/// from sampling or pbrt's stop being biased.
#[test]
fn measure_pbrt_weight_bias() {
    for alpha in [0.1f32, 0.3, 0.6] {
        let exact = coated(rough_coat(1.5, alpha), diffuse(0.8), 0.01, 0.0, 0.0, 10);
        let pbrt = Coated {
            pbrt_weights: true,
            ..exact.clone()
        };
        let bsdf = Bsdf::Coated(Box::new(exact.clone()));
        for theta in [0.3f32, 1.0, 1.3] {
            let wo = dir(theta, 0.0);
            // ∫ f cos dω = π E[f] over cosine-distributed ωi.
            let by_eval = |m: &Coated| {
                let mut rng = Rng::for_task(9, [0, 0, 0]);
                mean_and_error(400_000, |i| {
                    let wi = crate::sampling::sample_cosine_hemisphere(rng.uniform2());
                    let mut walks = Rng::for_task(9, [1, i as u64, 0]);
                    grey(m.eval_with(wo, wi, TransportMode::Radiance, &mut walks)) * std::f64::consts::PI
                })
            };
            let mut rng = Rng::for_task(10, [0, 0, 0]);
            let (sampled, es) = mean_and_error(400_000, |_| {
                bsdf.sample(wo, rng.uniform2(), rng.uniform(), TransportMode::Radiance)
                    .map_or(0.0, |s| grey(s.f) * s.wi.z.abs() as f64 / s.pdf_w as f64)
            });
            let ((a, ea), (b, eb)) = (by_eval(&exact), by_eval(&pbrt));
            eprintln!(
                "α {alpha}, θo {theta}: sampled {sampled:.4} ± {es:.4}, eval {a:.4} ± {ea:.4} ({:+.2} %), pbrt's eval {b:.4} ± {eb:.4} ({:+.2} %)",
                100.0 * (a / sampled - 1.0),
                100.0 * (b / sampled - 1.0)
            );
            assert!((a - sampled).abs() < 4.0 * (ea * ea + es * es).sqrt() + 1e-3);
            assert!(b - sampled > 4.0 * (eb * eb + es * es).sqrt());
        }
    }
}
