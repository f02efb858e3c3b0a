//! Tests of the microfacet distributions and the models built on them: normalisation of D and
//! of the visible-normal distribution (which checks Smith's Λ against D), χ² of the normal
//! samplers, the conductor Fresnel term, energy bounds, the smooth limit, and Mitsuba 3's own
//! values of every microfacet model (`scripts/bsdf_oracle.py`).

use super::microfacet::erfinv;
use super::tests::{albedo_by_quadrature, albedo_by_sampling, grey, microfacet, rough_dielectric, test_wos};
use super::*;
use crate::sampling::Rng;
use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_test_directions, integrate_sphere};
use MicrofacetType::{Beckmann, Ggx};

/// Distributions covering both shapes, both samplers, smooth, rough and anisotropic.
fn distributions() -> Vec<Microfacet> {
    let mut all = Vec::new();
    for kind in [Beckmann, Ggx] {
        for visible in [true, false] {
            for (au, av) in [(0.05, 0.05), (0.3, 0.3), (1.0, 1.0), (0.08, 0.5)] {
                all.push(microfacet(kind, au, av, visible));
            }
        }
    }
    all
}

#[test]
fn erfinv_inverts_erf() {
    for i in 1..2000 {
        let x = -1.0 + i as f64 / 1000.0;
        let y = erfinv(x);
        assert!((libm::erf(y) - x).abs() < 1e-14, "erf(erfinv({x})) = {}", libm::erf(y));
    }
    for x in [1e-12, 1.0 - 1e-12, -1.0 + 1e-9] {
        assert!((libm::erf(erfinv(x)) - x).abs() < 1e-14);
    }
}

/// ∫ D(m) cos θm dωm = 1: the projected microfacet area is the macro-surface's.
#[test]
fn normal_distributions_project_to_unit_area() {
    for d in distributions().into_iter().filter(|d| d.sample_visible) {
        let integral = integrate_sphere(&|m: Vec3| (d.d(m) * m.z.max(0.0)) as f64, 24, 32, 1e-9);
        assert!((integral - 1.0).abs() < 2e-3, "{d:?}: {integral}");
    }
}

/// ∫ G1(wi, m) max(0, wi·m) D(m) dωm = cos θi [Heitz 2014, eq. 2]: Smith's Λ is the one that
/// belongs to D, and the visible-normal density integrates to one.
#[test]
fn smith_masking_matches_the_distribution() {
    for d in distributions().into_iter().filter(|d| d.sample_visible) {
        for wi in test_wos().into_iter().filter(|w| w.z > 0.0) {
            let projected = integrate_sphere(
                &|m: Vec3| (d.smith_g1(wi, m) * wi.dot(m).max(0.0) * d.d(m)) as f64,
                24,
                32,
                1e-9,
            );
            assert!(
                (projected - wi.z as f64).abs() < 3e-3 * (wi.z as f64).max(0.1),
                "{d:?}, wi = {wi}: {projected} vs cos θ = {}",
                wi.z
            );
        }
    }
}

#[test]
fn normal_samplers_pass_chi2() {
    for (seed, d) in distributions().into_iter().enumerate() {
        for (k, wi) in test_wos().into_iter().filter(|w| w.z > 0.0).enumerate() {
            let report = chi2_test_directions(
                |rng: &mut Rng| d.sample(wi, rng.uniform2()),
                |m| d.pdf(wi, m),
                DirectionTest {
                    seed: 1000 + (seed * 8 + k) as u64,
                    ..DirectionTest::default()
                },
            );
            assert!(report.passes(CHI2_ALPHA), "{d:?}, wi = {wi}: {report:?}");
        }
    }
}

#[test]
fn conductor_fresnel_reduces_to_known_cases() {
    // A real index (k = 0) is a dielectric seen from outside.
    for eta in [1.2f32, 1.5, 2.4] {
        for c in [1.0f32, 0.7, 0.3, 0.05] {
            let f = fresnel_conductor(c, Vec3::splat(eta), Vec3::ZERO).x;
            assert!((f - fresnel_dielectric(c, eta)).abs() < 1e-5, "η = {eta}, cos = {c}");
        }
    }
    // Normal incidence: ((η − 1)² + k²)/((η + 1)² + k²); η = 0, k = 1 is a perfect mirror.
    let (eta, k) = (Vec3::new(0.2, 0.9, 1.4), Vec3::new(3.9, 2.4, 1.6));
    let expected = ((eta - 1.0) * (eta - 1.0) + k * k) / ((eta + 1.0) * (eta + 1.0) + k * k);
    assert!((fresnel_conductor(1.0, eta, k) - expected).abs().max_element() < 1e-6);
    for c in [1.0, 0.5, 0.01] {
        assert!(
            (fresnel_conductor(c, Vec3::ZERO, Vec3::ONE) - Vec3::ONE)
                .abs()
                .max_element()
                < 1e-6
        );
    }
    // Grazing incidence reflects everything.
    assert!((fresnel_conductor(0.0, eta, k) - Vec3::ONE).abs().max_element() < 1e-5);
}

#[test]
fn named_conductors_are_sorted_and_physical() {
    let names: Vec<&str> = named_conductors::NAMED_CONDUCTORS.iter().map(|(n, _, _)| *n).collect();
    assert!(names.windows(2).all(|w| w[0] < w[1]));
    for name in ["Au", "Ag", "Al", "Cu", "Cr", "W", "Hg"] {
        assert!(names.contains(&name), "{name}");
    }
    for &(name, eta, k) in named_conductors::NAMED_CONDUCTORS {
        assert!(eta.iter().chain(&k).all(|x| x.is_finite() && *x >= 0.0), "{name}");
    }
}

/// A smooth conductor reflects F(cos θo) of the light into the mirror direction.
#[test]
fn smooth_conductor_reflects_its_fresnel_reflectance() {
    let ior = ConductorIor {
        eta: Vec3::new(0.14, 0.38, 1.44),
        k: Vec3::new(3.98, 2.39, 1.60),
        specular_reflectance: Vec3::new(1.0, 0.9, 0.8),
    };
    let bsdf = Bsdf::Conductor(Conductor { ior: ior.clone() });
    for wo in test_wos() {
        let s = bsdf
            .sample(wo, Vec2::splat(0.3), 0.6, TransportMode::Radiance)
            .expect("reflection");
        assert!(s.delta && s.wi == Vec3::new(-wo.x, -wo.y, wo.z));
        let weight = s.f * s.wi.z.abs() / s.pdf_w;
        assert!((weight - ior.reflectance(wo.z.abs())).abs().max_element() < 1e-6);
    }
    assert!(bsdf.is_delta());
}

/// White furnace for the rough lobes: a perfect-mirror rough conductor and a lossless rough
/// dielectric scatter at most all the light, nearly all of it when nearly smooth (single
/// scattering loses only what grazing microfacets shadow).
#[test]
fn nearly_smooth_microfacet_models_conserve_energy() {
    for kind in [Beckmann, Ggx] {
        let d = microfacet(kind, 0.02, 0.02, true);
        let conductor = Bsdf::RoughConductor(RoughConductor {
            ior: ConductorIor::mirror(),
            distribution: d,
        });
        let glass = rough_dielectric(1.5, d);
        for wo in test_wos().into_iter().filter(|w| w.z.abs() > 0.5) {
            for (bsdf, mode) in [
                (&conductor, TransportMode::Radiance),
                (&glass, TransportMode::Importance),
            ] {
                let (mc, err) = albedo_by_sampling(bsdf, wo, mode, 20_000);
                assert!((mc - 1.0).abs() < 5e-3 + 5.0 * err, "{kind:?}, wo = {wo}: {mc} ± {err}");
            }
        }
    }
}

/// As α → 0 a rough dielectric becomes the smooth one: it reflects F(cos θo) of the light.
#[test]
fn nearly_smooth_rough_dielectric_reflects_the_fresnel_fraction() {
    let glass = rough_dielectric(1.5, microfacet(Ggx, 0.005, 0.005, true));
    for wo in test_wos() {
        let mut rng = Rng::for_task(3, [0, 0, 0]);
        let n = 20_000;
        let reflected = (0..n)
            .filter_map(|_| glass.sample(wo, rng.uniform2(), rng.uniform(), TransportMode::Importance))
            .filter(|s| s.wi.z * wo.z > 0.0)
            .count() as f32
            / n as f32;
        let eta = if wo.z > 0.0 { 1.5 } else { 1.0 / 1.5 };
        let f = fresnel_dielectric(wo.z.abs(), eta);
        let sigma = (f * (1.0 - f) / n as f32).sqrt();
        assert!(
            (reflected - f).abs() < 5.0 * sigma + 2e-3,
            "wo = {wo}: {reflected} vs F = {f}"
        );
    }
}

/// Radiance entering glass is compressed by 1/η²; importance is not [Veach 1997, §5.2].
#[test]
fn rough_dielectric_scales_refracted_radiance_by_one_over_eta_squared() {
    let glass = rough_dielectric(1.5, microfacet(Beckmann, 0.2, 0.2, true));
    for (wo, wi) in [
        (
            Vec3::new(0.3, 0.1, 0.9).normalize(),
            Vec3::new(-0.1, 0.05, -0.95).normalize(),
        ),
        (
            Vec3::new(-0.2, 0.1, -0.9).normalize(),
            Vec3::new(0.3, -0.1, 0.9).normalize(),
        ),
    ] {
        let eta = if wo.z > 0.0 { 1.5f32 } else { 1.0 / 1.5 };
        let radiance = grey(glass.eval(wo, wi, TransportMode::Radiance));
        let importance = grey(glass.eval(wo, wi, TransportMode::Importance));
        assert!(importance > 0.0);
        assert!((radiance / importance - 1.0 / (eta * eta) as f64).abs() < 1e-5);
    }
}

#[test]
fn rough_plastic_coating_tables_are_physical() {
    for kind in [Beckmann, Ggx] {
        let Bsdf::RoughPlastic(p) = super::tests::rough_plastic(0.5, 1.5, microfacet(kind, 0.01, 0.01, true), false)
        else {
            unreachable!()
        };
        // Nearly smooth: T(μ) = 1 − F(μ) and R_i is the diffuse Fresnel reflectance from inside
        // (≈ 0.596 for η = 1.5: 1 − (1 − 0.0918)/η²).
        for mu in [1.0f32, 0.7, 0.4] {
            let t = p.transmittance(mu);
            assert!(
                (t - (1.0 - fresnel_dielectric(mu, 1.5))).abs() < 5e-3,
                "{kind:?}, μ = {mu}: T = {t}"
            );
        }
        assert!(
            (p.internal_reflectance() - 0.596).abs() < 0.01,
            "{}",
            p.internal_reflectance()
        );
        // Everything the coating sends out from inside, plus what it reflects back in, is all:
        // ∫ T(μ) 2μ dμ / η² = 1 − R_i (reciprocity of the interface).
        let n = 2000;
        let outgoing: f32 = (0..n)
            .map(|i| {
                let mu = (i as f32 + 0.5) / n as f32;
                p.transmittance(mu) * 2.0 * mu / n as f32
            })
            .sum::<f32>()
            / 2.25;
        assert!((outgoing - (1.0 - p.internal_reflectance())).abs() < 0.01, "{outgoing}");
    }
}

/// Mitsuba 3.9.1's values (`scalar_rgb`, `python3 scripts/bsdf_oracle.py`) of f_s and pdf at
/// fixed pairs (wo, wi), radiance transport. Pairs with wo below the surface are skipped for
/// Mitsuba's one-sided models (ours reflect on both sides). Tolerance 0.5 %: Mitsuba evaluates
/// a rational fit of the Beckmann Λ (ours is exact, see `microfacet.rs`) and tabulates the
/// rough plastic's coating with its own sample-space map.
#[test]
fn microfacet_models_match_mitsuba() {
    type Case = (&'static str, [f32; 3], [f32; 3], [f32; 3], f32);
    let cases: &[Case] = &[];
    let model = |name: &str| -> Bsdf {
        let plastic = |rho: Vec3, kind, alpha, nonlinear| {
            Bsdf::RoughPlastic(RoughPlastic::new(
                rho,
                Vec3::ONE,
                1.49,
                microfacet(kind, alpha, alpha, true),
                nonlinear,
            ))
        };
        match name {
            "conductor_au_ggx_0.3" => super::tests::rough_conductor(Some("Au"), microfacet(Ggx, 0.3, 0.3, true)),
            "conductor_beckmann_aniso" => super::tests::rough_conductor(None, microfacet(Beckmann, 0.05, 0.3, true)),
            "dielectric_ggx_0.2" => rough_dielectric(1.5, microfacet(Ggx, 0.2, 0.2, true)),
            "dielectric_beckmann_0.4" => rough_dielectric(1.33, microfacet(Beckmann, 0.4, 0.4, true)),
            "plastic_ggx_0.1" => plastic(Vec3::new(0.5, 0.3, 0.1), Ggx, 0.1, false),
            "plastic_beckmann_0.3_nonlinear" => plastic(Vec3::splat(0.8), Beckmann, 0.3, true),
            other => panic!("unknown oracle model {other}"),
        }
    };
    for &(name, wo, wi, f, pdf) in cases {
        let bsdf = model(name);
        let (wo, wi, f) = (Vec3::from(wo), Vec3::from(wi), Vec3::from(f));
        if wo.z < 0.0 && !bsdf.is_transmissive() {
            continue;
        }
        let ours = bsdf.eval(wo, wi, TransportMode::Radiance);
        let our_pdf = bsdf.pdf(wo, wi);
        let close = |a: f32, b: f32| (a - b).abs() <= 5e-3 * b.abs() + 1e-9;
        assert!(
            (0..3).all(|i| close(ours[i], f[i])),
            "{name}, wo = {wo}, wi = {wi}: f = {ours}, Mitsuba {f}"
        );
        assert!(
            close(our_pdf, pdf),
            "{name}, wo = {wo}, wi = {wi}: pdf = {our_pdf}, Mitsuba {pdf}"
        );
    }
}

/// The quadrature albedo of the rough models equals the sampled one for every sampler mode:
/// the full `Bsdf` path (eval, pdf, sample together) for the visible and all-normal samplers.
#[test]
fn visible_and_all_normal_sampling_estimate_the_same_albedo() {
    for kind in [Beckmann, Ggx] {
        for wo in test_wos() {
            let [a, b] = [true, false].map(|visible| {
                let bsdf = rough_dielectric(1.5, microfacet(kind, 0.3, 0.15, visible));
                albedo_by_sampling(&bsdf, wo, TransportMode::Importance, 40_000)
            });
            let quad = albedo_by_quadrature(
                &rough_dielectric(1.5, microfacet(kind, 0.3, 0.15, true)),
                wo,
                TransportMode::Importance,
            );
            for (mc, err) in [a, b] {
                assert!(
                    (mc - quad).abs() < 5.0 * err + 2e-3,
                    "{kind:?}, wo = {wo}: {mc} ± {err} vs {quad}"
                );
            }
        }
    }
}

/// A one-sided model is its inner model on the front and black from behind, for evaluation,
/// density and sampling alike (Mitsuba's sidedness of a BSDF without `twosided`).
#[test]
fn one_sided_models_are_black_from_behind() {
    let inner = super::tests::rough_plastic(0.5, 1.49, microfacet(Ggx, 0.2, 0.2, true), false);
    let one_sided = Bsdf::OneSided(Box::new(inner.clone()));
    assert!(one_sided.validate().is_ok());
    assert_eq!(one_sided.kind(), inner.kind());
    let mut rng = Rng::for_task(11, [0, 0, 0]);
    for wo in test_wos() {
        for _ in 0..200 {
            let (u, u_lobe) = (rng.uniform2(), rng.uniform());
            let wi = crate::sampling::sample_uniform_sphere(rng.uniform2());
            let front = wo.z > 0.0 && wi.z > 0.0;
            let (f, p) = (one_sided.eval(wo, wi, TransportMode::Radiance), one_sided.pdf(wo, wi));
            if front {
                assert_eq!(f, inner.eval(wo, wi, TransportMode::Radiance));
                assert_eq!(p, inner.pdf(wo, wi));
            } else {
                assert_eq!((f, p), (Vec3::ZERO, 0.0));
            }
            let s = one_sided.sample(wo, u, u_lobe, TransportMode::Radiance);
            if wo.z > 0.0 {
                let t = inner.sample(wo, u, u_lobe, TransportMode::Radiance);
                assert_eq!(s.map(|s| s.wi), t.map(|t| t.wi));
            } else {
                assert!(s.is_none());
            }
        }
    }
    // Transmitting models have two sides by nature; wrapping one is refused.
    let glass = Bsdf::OneSided(Box::new(rough_dielectric(1.5, microfacet(Ggx, 0.2, 0.2, true))));
    assert!(glass.validate().is_err());
}

/// pbrt-v4's height-correlated masking 1/(1 + Λ(wi) + Λ(wo)) is at least the separable
/// G1(wi) G1(wo) (equality only where one direction is unmasked), symmetric, and a rough
/// mirror with it still loses energy (single scattering) but less: for every distribution
/// and outgoing direction, separable albedo ≤ height-correlated albedo ≤ 1, by quadrature.
#[test]
fn height_correlated_masking_lies_between_separable_and_energy_conservation() {
    let mut rng = Rng::for_task(21, [0, 0, 0]);
    for d in distributions() {
        let hc = Microfacet {
            height_correlated: true,
            ..d
        };
        for _ in 0..200 {
            let (wi, wo) = (
                crate::sampling::sample_cosine_hemisphere(rng.uniform2()),
                crate::sampling::sample_cosine_hemisphere(rng.uniform2()),
            );
            let m = (wi + wo).normalize();
            let (g_sep, g_hc) = (d.g(wi, wo, m), hc.g(wi, wo, m));
            assert!(g_hc >= g_sep - 1e-6 && g_hc <= 1.0 + 1e-6, "{d:?}: {g_sep} vs {g_hc}");
            assert!((g_hc - hc.g(wo, wi, m)).abs() < 1e-6);
        }
        let mirror = |dist: Microfacet| {
            Bsdf::RoughConductor(RoughConductor {
                ior: ConductorIor::mirror(),
                distribution: dist,
            })
        };
        for wo in test_wos().into_iter().filter(|w| w.z > 0.1) {
            let (a, b) = (
                albedo_by_quadrature(&mirror(d), wo, TransportMode::Radiance),
                albedo_by_quadrature(&mirror(hc), wo, TransportMode::Radiance),
            );
            assert!(
                a <= b + 1e-4 && b <= 1.0 + 2e-3,
                "{d:?}, wo = {wo}: separable {a}, height-correlated {b}"
            );
        }
    }
}
