//! Tests shared by every reflectance model: χ² of each sampler against its pdf, energy and
//! albedo by the sampler and by quadrature, reciprocity, sidedness, and the delta models'
//! exact directions and weights.

use super::*;
use crate::sampling::Rng;
use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_test_directions, integrate_sphere};

/// Outgoing directions: normal, oblique, grazing, and below the surface (two-sided models).
pub(super) fn test_wos() -> [Vec3; 4] {
    [
        Vec3::Z,
        Vec3::new(0.5, -0.3, 0.812_404).normalize(),
        Vec3::new(-0.6, 0.797_496, 0.06).normalize(),
        Vec3::new(0.2, 0.5, -0.842_615).normalize(),
    ]
}

fn phong(kd: f32, ks: f32, exponent: f32) -> Bsdf {
    Bsdf::Phong(Phong {
        diffuse: Vec3::splat(kd),
        specular: Vec3::splat(ks),
        exponent,
    })
}

fn ward(kd: f32, ks: f32, alpha_x: f32, alpha_y: f32) -> Bsdf {
    Bsdf::Ward(Ward {
        diffuse: Vec3::splat(kd),
        specular: Vec3::splat(ks),
        alpha_x,
        alpha_y,
    })
}

pub(super) fn lambertian(rho: f32) -> Bsdf {
    Bsdf::Lambertian(Lambertian {
        reflectance: Vec3::splat(rho),
    })
}

fn diffuse_transmission(r: f32, t: f32) -> Bsdf {
    Bsdf::DiffuseTransmission(DiffuseTransmission {
        reflectance: Vec3::splat(r),
        transmittance: Vec3::splat(t),
    })
}

pub(super) fn microfacet(kind: MicrofacetType, alpha_u: f32, alpha_v: f32, visible: bool) -> Microfacet {
    Microfacet::new(kind, alpha_u, alpha_v, visible)
}

/// A rough conductor; `metal` names one of Mitsuba's measured conductors, `None` a perfect mirror.
pub(super) fn rough_conductor(metal: Option<&str>, distribution: Microfacet) -> Bsdf {
    let ior = metal.map_or_else(ConductorIor::mirror, |name| {
        ConductorIor::named(name).expect("a named conductor")
    });
    Bsdf::RoughConductor(RoughConductor { ior, distribution })
}

pub(super) fn rough_dielectric(ior: f32, distribution: Microfacet) -> Bsdf {
    Bsdf::RoughDielectric(RoughDielectric {
        ior,
        distribution,
        specular_reflectance: Vec3::ONE,
        specular_transmittance: Vec3::ONE,
    })
}

pub(super) fn rough_plastic(rho: f32, ior: f32, distribution: Microfacet, nonlinear: bool) -> Bsdf {
    Bsdf::RoughPlastic(RoughPlastic::new(
        Vec3::splat(rho),
        Vec3::ONE,
        ior,
        distribution,
        nonlinear,
    ))
}

/// Every non-delta model with parameter sets that cover broad, sharp and anisotropic lobes.
pub(super) fn non_delta_models() -> Vec<(&'static str, Bsdf)> {
    use MicrofacetType::{Beckmann, Ggx};
    vec![
        ("lambertian", lambertian(0.8)),
        ("diffuse_transmission", diffuse_transmission(0.3, 0.6)),
        ("phong n=1", phong(0.0, 0.9, 1.0)),
        ("phong n=10", phong(0.0, 0.9, 10.0)),
        ("phong n=200", phong(0.0, 0.9, 200.0)),
        ("phong kd+ks n=30", phong(0.4, 0.5, 30.0)),
        ("ward a=0.05", ward(0.0, 0.9, 0.05, 0.05)),
        ("ward a=0.2", ward(0.0, 0.9, 0.2, 0.2)),
        ("ward a=0.5", ward(0.0, 0.9, 0.5, 0.5)),
        ("ward aniso 0.05x0.3", ward(0.0, 0.9, 0.05, 0.3)),
        ("ward aniso 0.4x0.1 kd", ward(0.3, 0.6, 0.4, 0.1)),
        (
            "roughconductor beckmann 0.1",
            rough_conductor(None, microfacet(Beckmann, 0.1, 0.1, true)),
        ),
        (
            "roughconductor ggx 0.3 Au",
            rough_conductor(Some("Au"), microfacet(Ggx, 0.3, 0.3, true)),
        ),
        (
            "roughconductor ggx aniso 0.05x0.4",
            rough_conductor(None, microfacet(Ggx, 0.05, 0.4, true)),
        ),
        (
            "roughconductor beckmann aniso 0.5x0.1",
            rough_conductor(None, microfacet(Beckmann, 0.5, 0.1, true)),
        ),
        (
            "roughconductor beckmann 0.2 all normals",
            rough_conductor(None, microfacet(Beckmann, 0.2, 0.2, false)),
        ),
        (
            "roughconductor ggx aniso all normals",
            rough_conductor(None, microfacet(Ggx, 0.3, 0.08, false)),
        ),
        (
            "roughdielectric ggx 0.2",
            rough_dielectric(1.5, microfacet(Ggx, 0.2, 0.2, true)),
        ),
        (
            "roughdielectric beckmann 0.1",
            rough_dielectric(1.5, microfacet(Beckmann, 0.1, 0.1, true)),
        ),
        (
            "roughdielectric beckmann 0.6 water",
            rough_dielectric(1.33, microfacet(Beckmann, 0.6, 0.6, true)),
        ),
        (
            "roughdielectric ggx aniso all normals",
            rough_dielectric(1.5, microfacet(Ggx, 0.4, 0.1, false)),
        ),
        (
            "roughplastic ggx 0.1",
            rough_plastic(0.5, 1.49, microfacet(Ggx, 0.1, 0.1, true), false),
        ),
        (
            "roughplastic beckmann 0.3 nonlinear",
            rough_plastic(0.8, 1.49, microfacet(Beckmann, 0.3, 0.3, true), true),
        ),
        (
            "blend 0.3 lambertian + roughconductor ggx 0.2",
            blend(
                0.3,
                lambertian(0.8),
                rough_conductor(None, microfacet(Ggx, 0.2, 0.2, true)),
            ),
        ),
        (
            "pplastic beckmann 0.1",
            pplastic(0.5, 1.0, microfacet(Beckmann, 0.1, 0.1, true)),
        ),
        (
            "pplastic ggx aniso 0.05x0.3 all normals",
            pplastic(0.3, 0.8, microfacet(Ggx, 0.05, 0.3, false)),
        ),
        (
            "normal map 37° lambertian",
            normal_mapped(lambertian(0.8), Vec3::new(0.8, 0.5, 0.9)),
        ),
        (
            "normal map 76° one-sided roughplastic",
            normal_mapped(
                Bsdf::OneSided(Box::new(rough_plastic(
                    0.5,
                    1.49,
                    microfacet(Ggx, 0.2, 0.2, true),
                    false,
                ))),
                Vec3::new(0.9, 0.5, 0.6),
            ),
        ),
        (
            "normal map 40° roughconductor aniso",
            normal_mapped(
                rough_conductor(None, microfacet(Ggx, 0.05, 0.4, true)),
                Vec3::new(0.7, 0.35, 0.8),
            ),
        ),
        (
            "blend 0.6 roughdielectric + diffuse_transmission",
            blend(
                0.6,
                rough_dielectric(1.5, microfacet(Beckmann, 0.3, 0.3, true)),
                diffuse_transmission(0.2, 0.5),
            ),
        ),
    ]
}

/// Mitsuba's `pplastic` of diffuse ρ, specular k_s and η = 1.49, its sampling weight from ρ.
pub(super) fn pplastic(rho: f32, ks: f32, distribution: Microfacet) -> Bsdf {
    Bsdf::Pplastic(Pplastic::new(
        Vec3::splat(rho),
        Vec3::splat(ks),
        1.49,
        distribution,
        rho,
    ))
}

/// `nested` under a normal map of colour `c`.
pub(super) fn normal_mapped(nested: Bsdf, c: Vec3) -> Bsdf {
    Bsdf::NormalMapped(Box::new(NormalMapped::new(nested, c)))
}

/// (1 − w) `a` + w `b`.
pub(super) fn blend(w: f32, a: Bsdf, b: Bsdf) -> Bsdf {
    Bsdf::Blend(Box::new(super::Blend {
        weight: w,
        bsdfs: [a, b],
    }))
}

/// One scalar channel of a spectrum (all test spectra are grey).
pub(super) fn grey(c: Vec3) -> f64 {
    c.x as f64
}

#[test]
fn every_non_delta_sampler_passes_chi2() {
    for (seed, (name, bsdf)) in non_delta_models().into_iter().enumerate() {
        for (k, wo) in test_wos().into_iter().enumerate() {
            assert_sampler_follows_pdf(name, &bsdf, wo, (seed * 16 + k) as u64);
        }
    }
}

/// χ² of the model's sampler from `wo` against its `pdf` (radiance transport), at
/// [`CHI2_ALPHA`].
pub(super) fn assert_sampler_follows_pdf(name: &str, bsdf: &Bsdf, wo: Vec3, seed: u64) {
    let report = chi2_test_directions(
        |rng: &mut Rng| {
            let (u, u_lobe) = (rng.uniform2(), rng.uniform());
            bsdf.sample(wo, u, u_lobe, TransportMode::Radiance)
                .map(|s| (s.wi, s.pdf_w))
        },
        |wi| bsdf.pdf(wo, wi),
        DirectionTest {
            seed,
            ..DirectionTest::default()
        },
    );
    assert!(report.passes(CHI2_ALPHA), "{name}, wo = {wo}: {report:?}");
}

#[test]
fn chi2_rejects_a_sampler_tested_against_a_slightly_wrong_pdf() {
    // Phong n = 10 sampled, n = 12 claimed: the helper must notice.
    let (sampled, claimed) = (phong(0.0, 0.9, 10.0), phong(0.0, 0.9, 12.0));
    let wo = test_wos()[1];
    let report = chi2_test_directions(
        |rng: &mut Rng| {
            let (u, u_lobe) = (rng.uniform2(), rng.uniform());
            sampled
                .sample(wo, u, u_lobe, TransportMode::Radiance)
                .map(|s| (s.wi, claimed.pdf(wo, s.wi)))
        },
        |wi| claimed.pdf(wo, wi),
        DirectionTest::default(),
    );
    assert!(report.chi2.p_value < CHI2_ALPHA, "{report:?}");
    assert!(!report.passes(CHI2_ALPHA));
}

#[test]
fn chi2_helper_flags_a_reported_pdf_that_disagrees_with_the_pdf_function() {
    let bsdf = ward(0.0, 0.9, 0.2, 0.2);
    let wo = test_wos()[1];
    let report = chi2_test_directions(
        |rng: &mut Rng| {
            let (u, u_lobe) = (rng.uniform2(), rng.uniform());
            bsdf.sample(wo, u, u_lobe, TransportMode::Radiance)
                .map(|s| (s.wi, s.pdf_w * 1.01))
        },
        |wi| bsdf.pdf(wo, wi),
        DirectionTest {
            n_samples: 1_000,
            ..DirectionTest::default()
        },
    );
    assert!(report.pdf_mismatches > 0);
    assert!(!report.passes(CHI2_ALPHA));
}

/// Directional albedo ∫ f |cos θi| dωi by the model's own sampler: (mean, standard error).
pub(super) fn albedo_by_sampling(bsdf: &Bsdf, wo: Vec3, mode: TransportMode, n: usize) -> (f64, f64) {
    let mut rng = Rng::for_task(99, [0, 0, 0]);
    let (mut sum, mut sum2) = (0.0, 0.0);
    for _ in 0..n {
        let (u, u_lobe) = (rng.uniform2(), rng.uniform());
        let w = bsdf
            .sample(wo, u, u_lobe, mode)
            .map_or(0.0, |s| grey(s.f) * s.wi.z.abs() as f64 / s.pdf_w as f64);
        sum += w;
        sum2 += w * w;
    }
    let mean = sum / n as f64;
    let var = (sum2 / n as f64 - mean * mean).max(0.0);
    (mean, (var / n as f64).sqrt())
}

/// Directional albedo by brute-force quadrature of f |cos θi| over the sphere.
pub(super) fn albedo_by_quadrature(bsdf: &Bsdf, wo: Vec3, mode: TransportMode) -> f64 {
    let integrand = |wi: Vec3| grey(bsdf.eval(wo, wi, mode)) * wi.z.abs() as f64;
    integrate_sphere(&integrand, 10, 20, 1e-7)
}

/// The transport mode in which a model's albedo is at most one.
pub(super) fn energy_mode(bsdf: &Bsdf) -> TransportMode {
    if bsdf.is_transmissive() {
        TransportMode::Importance
    } else {
        TransportMode::Radiance
    }
}

#[test]
fn albedo_by_sampler_matches_quadrature_and_is_at_most_one() {
    for (name, bsdf) in non_delta_models() {
        // Refraction scales radiance by 1/η², which can exceed 1; importance is conserved.
        let mode = energy_mode(&bsdf);
        for wo in test_wos() {
            let (mc, std_err) = albedo_by_sampling(&bsdf, wo, mode, 40_000);
            let quad = albedo_by_quadrature(&bsdf, wo, mode);
            assert!(quad <= 1.0 + 1e-3, "{name}, wo = {wo}: albedo {quad}");
            assert!(mc <= 1.0 + 1e-3 + 5.0 * std_err, "{name}, wo = {wo}: albedo {mc}");
            assert!(
                (mc - quad).abs() <= 5.0 * std_err + 2e-3,
                "{name}, wo = {wo}: sampled {mc} ± {std_err}, quadrature {quad}"
            );
        }
    }
}

#[test]
fn lambertian_albedo_equals_reflectance() {
    for wo in test_wos() {
        let (mc, std_err) = albedo_by_sampling(&lambertian(0.7), wo, TransportMode::Radiance, 1000);
        assert!((mc - 0.7).abs() < 1e-5 && std_err < 1e-6, "{mc} ± {std_err}");
        let quad = albedo_by_quadrature(&lambertian(0.7), wo, TransportMode::Radiance);
        assert!((quad - 0.7).abs() < 1e-4, "{quad}");
    }
}

#[test]
fn diffuse_transmission_albedo_equals_reflectance_plus_transmittance() {
    let bsdf = diffuse_transmission(0.25, 0.5);
    for wo in test_wos() {
        let quad = albedo_by_quadrature(&bsdf, wo, TransportMode::Radiance);
        assert!((quad - 0.75).abs() < 1e-4, "{quad}");
        let (mc, std_err) = albedo_by_sampling(&bsdf, wo, TransportMode::Radiance, 1000);
        assert!((mc - 0.75).abs() < 1e-5 && std_err < 1e-6, "{mc} ± {std_err}");
    }
}

#[test]
fn phong_specular_albedo_is_ks_at_normal_incidence_and_less_elsewhere() {
    for n in [1.0, 10.0, 200.0] {
        let bsdf = phong(0.0, 0.8, n);
        let quad = albedo_by_quadrature(&bsdf, Vec3::Z, TransportMode::Radiance);
        assert!((quad - 0.8).abs() < 1e-3, "n = {n}: {quad}");
        for wo in test_wos().into_iter().skip(1) {
            assert!(albedo_by_quadrature(&bsdf, wo, TransportMode::Radiance) < 0.8 + 1e-4);
        }
    }
}

#[test]
fn ward_specular_albedo_is_bounded_by_rho_s_even_at_grazing_angles() {
    for (ax, ay) in [(0.05, 0.05), (0.3, 0.3), (0.5, 0.5), (0.1, 0.5)] {
        let bsdf = ward(0.0, 1.0, ax, ay);
        for z in [1.0f32, 0.5, 0.1, 0.02] {
            let wo = Vec3::new((1.0 - z * z).sqrt(), 0.0, z);
            let quad = albedo_by_quadrature(&bsdf, wo, TransportMode::Radiance);
            assert!(quad <= 1.0 + 1e-3, "α = ({ax}, {ay}), cos θo = {z}: {quad}");
        }
    }
}

/// Deterministic pseudo-random unit directions.
pub(super) fn random_directions(seed: u64, n: usize) -> Vec<Vec3> {
    let mut rng = Rng::for_task(seed, [1, 2, 3]);
    (0..n)
        .map(|_| crate::sampling::sample_uniform_sphere(rng.uniform2()))
        .collect()
}

/// Reciprocity, in the form that holds for refraction too: the BSDF for importance at (wo, wi)
/// is the BSDF for radiance at (wi, wo) [Veach 1997, eq. 5.21]; for the other models the mode
/// does not matter and this is plain symmetry.
#[test]
fn non_delta_models_are_reciprocal() {
    let dirs = random_directions(5, 400);
    for (name, bsdf) in non_delta_models() {
        for pair in dirs.chunks_exact(2) {
            assert_reciprocal(name, &bsdf, pair[0], pair[1]);
        }
    }
}

/// f for importance at (wo, wi) equals f for radiance at (wi, wo), to 10⁻⁴ relative.
pub(super) fn assert_reciprocal(name: &str, bsdf: &Bsdf, wo: Vec3, wi: Vec3) {
    let a = bsdf.eval(wo, wi, TransportMode::Importance);
    let b = bsdf.eval(wi, wo, TransportMode::Radiance);
    assert!(
        (a - b).abs().max_element() <= 1e-4 * a.abs().max_element().max(1.0),
        "{name}: f({wo}, {wi}) = {a} but f({wi}, {wo}) = {b}"
    );
}

#[test]
fn reflection_models_are_zero_on_the_wrong_side() {
    let reflection_only = [
        lambertian(0.8),
        phong(0.4, 0.5, 10.0),
        phong(0.0, 0.9, 1.0),
        ward(0.3, 0.6, 0.2, 0.4),
        rough_conductor(Some("Cu"), microfacet(MicrofacetType::Ggx, 0.3, 0.3, true)),
        rough_plastic(0.5, 1.49, microfacet(MicrofacetType::Beckmann, 0.2, 0.2, true), false),
    ];
    let dirs = random_directions(6, 200);
    for bsdf in &reflection_only {
        for pair in dirs.chunks_exact(2) {
            let (wo, mut wi) = (pair[0], pair[1]);
            if wo.z * wi.z > 0.0 {
                wi.z = -wi.z;
            }
            assert_eq!(bsdf.eval(wo, wi, TransportMode::Radiance), Vec3::ZERO);
            assert_eq!(bsdf.pdf(wo, wi), 0.0);
        }
    }
}

#[test]
fn diffuse_transmission_transmits_to_the_other_side() {
    let bsdf = diffuse_transmission(0.2, 0.7);
    let wo = test_wos()[1];
    let wi = Vec3::new(0.1, 0.2, -0.974_679_4);
    let f = bsdf.eval(wo, wi, TransportMode::Radiance);
    assert!((f - Vec3::splat(0.7 * std::f32::consts::FRAC_1_PI)).abs().max_element() < 1e-7);
    let f = bsdf.eval(wo, wi.with_z(-wi.z), TransportMode::Radiance);
    assert!((f - Vec3::splat(0.2 * std::f32::consts::FRAC_1_PI)).abs().max_element() < 1e-7);
}

#[test]
fn sampled_values_match_eval() {
    let mut rng = Rng::for_task(8, [0, 0, 0]);
    for (name, bsdf) in non_delta_models() {
        for wo in test_wos() {
            for _ in 0..200 {
                let (u, u_lobe) = (rng.uniform2(), rng.uniform());
                if let Some(s) = bsdf.sample(wo, u, u_lobe, TransportMode::Radiance) {
                    assert!(!s.delta);
                    let f = bsdf.eval(wo, s.wi, TransportMode::Radiance);
                    assert!((s.f - f).abs().max_element() <= 1e-5 * f.max_element(), "{name}");
                }
            }
        }
    }
}

#[test]
fn mirror_reflects_exactly_with_weight_r() {
    let r = Vec3::new(0.9, 0.5, 0.2);
    let bsdf = Bsdf::Mirror(Mirror { reflectance: r });
    for wo in test_wos() {
        let s = bsdf
            .sample(wo, Vec2::new(0.3, 0.7), 0.4, TransportMode::Radiance)
            .expect("a mirror always reflects");
        assert!(s.delta);
        assert_eq!(s.wi, Vec3::new(-wo.x, -wo.y, wo.z));
        assert_eq!(s.pdf_w, 1.0);
        assert!((s.f * s.wi.z.abs() / s.pdf_w - r).abs().max_element() < 1e-6);
        assert_eq!(bsdf.eval(wo, s.wi, TransportMode::Radiance), Vec3::ZERO);
        assert_eq!(bsdf.pdf(wo, s.wi), 0.0);
    }
    assert!(bsdf.is_delta());
}

#[test]
fn fresnel_matches_known_values() {
    // Normal incidence: ((η − 1)/(η + 1))², the same from both sides.
    assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
    assert!((fresnel_dielectric(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
    // Grazing incidence reflects everything; a matched index nothing.
    assert!((fresnel_dielectric(0.0, 1.5) - 1.0).abs() < 1e-6);
    assert!(fresnel_dielectric(0.3, 1.0) < 1e-12);
    // Brewster's angle tan θB = η: r_p = 0, F = r_s²/2.
    let theta_b = 1.5f32.atan();
    let (cos_i, cos_t) = (theta_b.cos(), theta_b.sin());
    let r_s = (cos_i - 1.5 * cos_t) / (cos_i + 1.5 * cos_t);
    assert!((fresnel_dielectric(cos_i, 1.5) - 0.5 * r_s * r_s).abs() < 1e-6);
    // Total internal reflection beyond the critical angle sin θc = 1/1.5.
    let cos_c = (1.0f32 - 1.0 / 2.25).sqrt();
    assert_eq!(fresnel_dielectric(cos_c - 1e-3, 1.0 / 1.5), 1.0);
    assert!(fresnel_dielectric(cos_c + 1e-3, 1.0 / 1.5) < 1.0);
}

#[test]
fn dielectric_refraction_obeys_snell_and_fresnel_symmetry() {
    let glass = Dielectric::clear(1.5);
    let bsdf = Bsdf::Dielectric(glass.clone());
    for wo in test_wos().into_iter().chain(random_directions(7, 50)) {
        let eta = glass.eta_toward(wo);
        let f_r = fresnel_dielectric(wo.z.abs(), eta);
        if f_r >= 1.0 {
            continue;
        }
        let u_refract = f_r + 0.5 * (1.0 - f_r);
        let s = bsdf
            .sample(wo, Vec2::ZERO, u_refract, TransportMode::Importance)
            .expect("refraction");
        let wi = s.wi;
        assert!(s.delta && wo.z * wi.z < 0.0);
        assert!((wi.length() - 1.0).abs() < 1e-5);
        // Snell: η_o sin θo = η_t sin θi, and wi lies in the plane of wo and n, opposite.
        let (sin_o, sin_i) = (wo.truncate().length(), wi.truncate().length());
        assert!((sin_o - eta * sin_i).abs() < 1e-5, "{sin_o} vs {eta} · {sin_i}");
        assert!(wo.truncate().dot(wi.truncate()) <= 1e-6);
        assert!(wo.truncate().perp_dot(wi.truncate()).abs() < 1e-5);
        // The reverse path refracts back to wo, with the same Fresnel transmittance.
        let back = refract(wi, 1.0 / eta).expect("reverse refraction");
        assert!((back - wo).abs().max_element() < 1e-5);
        let f_back = fresnel_dielectric(wi.z.abs(), 1.0 / eta);
        assert!((f_back - f_r).abs() < 1e-5, "F {f_r} vs reverse {f_back}");
        assert_eq!(bsdf.eval(wo, wi, TransportMode::Radiance), Vec3::ZERO);
        assert_eq!(bsdf.pdf(wo, wi), 0.0);
    }
}

#[test]
fn dielectric_reflect_and_refract_weights_sum_to_one_in_importance_mode() {
    let glass = Dielectric::clear(1.5);
    let bsdf = Bsdf::Dielectric(glass.clone());
    let weight = |s: &BsdfSample| s.f * s.wi.z.abs() / s.pdf_w;
    for wo in test_wos().into_iter().chain(random_directions(9, 50)) {
        let eta = glass.eta_toward(wo);
        let f_r = fresnel_dielectric(wo.z.abs(), eta);
        let mut total = Vec3::ZERO;
        if f_r > 0.0 {
            let s = bsdf
                .sample(wo, Vec2::ZERO, 0.5 * f_r, TransportMode::Importance)
                .expect("reflection");
            assert_eq!(s.wi, Vec3::new(-wo.x, -wo.y, wo.z));
            assert!((s.pdf_w - f_r).abs() < 1e-7);
            total += s.pdf_w * weight(&s);
        }
        if f_r < 1.0 {
            let u = f_r + 0.5 * (1.0 - f_r);
            let s = bsdf
                .sample(wo, Vec2::ZERO, u, TransportMode::Importance)
                .expect("refraction");
            assert!((s.pdf_w - (1.0 - f_r)).abs() < 1e-6);
            total += s.pdf_w * weight(&s);
            // Radiance is scaled by 1/η² on the way into the medium the path enters.
            let r = bsdf
                .sample(wo, Vec2::ZERO, u, TransportMode::Radiance)
                .expect("refraction");
            let ratio = weight(&r) / weight(&s);
            assert!((ratio - Vec3::splat(1.0 / (eta * eta))).abs().max_element() < 1e-5);
        }
        assert!((total - Vec3::ONE).abs().max_element() < 1e-5, "F + (1 − F) = {total}");
    }
}

#[test]
fn dielectric_radiance_weights_of_a_path_and_its_reverse_multiply_to_one() {
    // Radiance crossing into glass and back out again keeps L/η² invariant [Veach 1997, §5.2].
    let bsdf = Bsdf::Dielectric(Dielectric::clear(1.5));
    let weight = |s: &BsdfSample| s.f * s.wi.z.abs() / s.pdf_w;
    let wo = test_wos()[1];
    let there = bsdf
        .sample(wo, Vec2::ZERO, 0.999, TransportMode::Radiance)
        .expect("refraction");
    let back = bsdf
        .sample(there.wi, Vec2::ZERO, 0.999, TransportMode::Radiance)
        .expect("refraction");
    assert!((back.wi - wo).abs().max_element() < 1e-5);
    let product = weight(&there) * weight(&back);
    assert!((product - Vec3::ONE).abs().max_element() < 1e-5, "{product}");
}

#[test]
fn dielectric_totally_reflects_beyond_the_critical_angle() {
    let bsdf = Bsdf::Dielectric(Dielectric::clear(1.5));
    // Inside the glass, 60° from the normal, beyond θc ≈ 41.8°.
    let wo = Vec3::new(0.866_025_4, 0.0, -0.5);
    for u_lobe in [0.0, 0.5, 0.999_999] {
        let s = bsdf
            .sample(wo, Vec2::ZERO, u_lobe, TransportMode::Radiance)
            .expect("reflection");
        assert_eq!(s.wi, Vec3::new(-wo.x, -wo.y, wo.z));
        assert_eq!(s.pdf_w, 1.0);
        assert!((s.f * s.wi.z.abs() - Vec3::ONE).abs().max_element() < 1e-6);
    }
}

#[test]
fn dielectric_tint_filters_refraction_only() {
    let tint = Vec3::new(1.0, 0.5, 0.25);
    let bsdf = Bsdf::Dielectric(Dielectric { ior: 1.33, tint });
    let wo = test_wos()[1];
    let weight = |s: BsdfSample| s.f * s.wi.z.abs() / s.pdf_w;
    let r = bsdf.sample(wo, Vec2::ZERO, 0.0, TransportMode::Importance);
    let t = bsdf.sample(wo, Vec2::ZERO, 0.999, TransportMode::Importance);
    assert!((weight(r.expect("reflection")) - Vec3::ONE).abs().max_element() < 1e-6);
    assert!((weight(t.expect("refraction")) - tint).abs().max_element() < 1e-6);
}

#[test]
fn surfaces_are_classified_for_the_path_grammar() {
    use SurfaceKind::*;
    let cases = [
        (lambertian(0.5), Diffuse),
        (diffuse_transmission(0.2, 0.5), Diffuse),
        (phong(0.3, 0.5, 10.0), Diffuse),
        (phong(0.0, 0.5, 10.0), Glossy),
        (ward(0.3, 0.5, 0.1, 0.1), Diffuse),
        (ward(0.0, 0.5, 0.1, 0.1), Glossy),
        (Bsdf::Mirror(Mirror { reflectance: Vec3::ONE }), Specular),
        (Bsdf::Dielectric(Dielectric::clear(1.5)), Specular),
        (
            Bsdf::Conductor(Conductor {
                ior: ConductorIor::mirror(),
            }),
            Specular,
        ),
        (
            rough_conductor(None, Microfacet::new(MicrofacetType::Ggx, 0.1, 0.1, true)),
            Glossy,
        ),
        (
            rough_dielectric(1.5, Microfacet::new(MicrofacetType::Ggx, 0.1, 0.1, true)),
            Glossy,
        ),
        (
            rough_plastic(0.5, 1.5, Microfacet::new(MicrofacetType::Ggx, 0.1, 0.1, true), false),
            Diffuse,
        ),
        (
            rough_plastic(0.0, 1.5, Microfacet::new(MicrofacetType::Ggx, 0.1, 0.1, true), false),
            Glossy,
        ),
    ];
    for (bsdf, kind) in cases {
        assert_eq!(bsdf.kind(), kind, "{bsdf:?}");
        assert_eq!(bsdf.is_delta(), kind == Specular);
    }
}

#[test]
fn albedo_bounds_reflectance_plus_transmittance() {
    assert_eq!(diffuse_transmission(0.2, 0.5).albedo(), Vec3::splat(0.7));
    assert_eq!(phong(0.25, 0.5, 10.0).albedo(), Vec3::splat(0.75));
    assert_eq!(ward(0.25, 0.5, 0.1, 0.1).albedo(), Vec3::splat(0.75));
    assert_eq!(lambertian(0.4).albedo(), Vec3::splat(0.4));
    assert_eq!(Bsdf::Dielectric(Dielectric::clear(1.5)).albedo(), Vec3::ONE);
    // The bound holds: every model's sampled albedo stays below it.
    for (name, bsdf) in non_delta_models() {
        for wo in test_wos() {
            let (mc, std_err) = albedo_by_sampling(&bsdf, wo, energy_mode(&bsdf), 5_000);
            assert!(mc <= grey(bsdf.albedo()) + 5.0 * std_err + 1e-3, "{name}: {mc}");
        }
    }
}

#[test]
fn validate_rejects_unphysical_parameters() {
    for (name, bsdf) in non_delta_models() {
        assert!(bsdf.validate().is_ok(), "{name}");
    }
    assert!(Bsdf::Dielectric(Dielectric::clear(1.5)).validate().is_ok());
    let bad = [
        phong(0.6, 0.5, 10.0),
        phong(0.2, 0.5, -1.0),
        phong(0.2, 0.5, f32::NAN),
        ward(0.6, 0.5, 0.1, 0.1),
        ward(0.2, 0.5, 0.0, 0.1),
        ward(0.2, 0.5, 0.1, f32::INFINITY),
        diffuse_transmission(0.6, 0.5),
        lambertian(1.2),
        lambertian(-0.1),
        Bsdf::Dielectric(Dielectric::clear(0.0)),
        Bsdf::Dielectric(Dielectric::clear(f32::NAN)),
        Bsdf::Dielectric(Dielectric {
            ior: 1.5,
            tint: Vec3::splat(1.5),
        }),
    ];
    for bsdf in bad {
        assert!(bsdf.validate().is_err(), "{bsdf:?}");
    }
    let message = phong(0.6, 0.5, 10.0).validate().unwrap_err();
    assert!(message.message().contains("diffuse + specular"), "{message}");
}

#[test]
fn samplers_reject_grazing_wo_and_black_models() {
    for (_, bsdf) in non_delta_models() {
        let wo = Vec3::X;
        assert!(
            bsdf.sample(wo, Vec2::splat(0.5), 0.5, TransportMode::Radiance)
                .is_none()
        );
    }
    assert!(
        phong(0.0, 0.0, 10.0)
            .sample(Vec3::Z, Vec2::splat(0.5), 0.5, TransportMode::Radiance)
            .is_none()
    );
    assert_eq!(phong(0.0, 0.0, 10.0).pdf(Vec3::Z, Vec3::Z), 0.0);
}

#[test]
fn ward_alpha_x_widens_the_lobe_along_the_tangent() {
    let bsdf = ward(0.0, 0.9, 0.4, 0.1);
    let tilt = 0.3f32;
    let along_x = Vec3::new(tilt.sin(), 0.0, tilt.cos());
    let along_y = Vec3::new(0.0, tilt.sin(), tilt.cos());
    let f = |wi| grey(bsdf.eval(Vec3::Z, wi, TransportMode::Radiance));
    assert!(f(along_x) > 5.0 * f(along_y), "{} vs {}", f(along_x), f(along_y));
    assert!(bsdf.pdf(Vec3::Z, along_x) > 5.0 * bsdf.pdf(Vec3::Z, along_y));
}

/// Without its specular lobe a `pplastic` is ρ/π attenuated by both refractions: at normal
/// incidence and exit (1 − F₀)², F₀ = ((η − 1)/(η + 1))²; at 60° the Fresnel reflectance of
/// that angle enters instead.
#[test]
fn pplastic_diffuse_lobe_is_attenuated_by_both_refractions() {
    let b = Pplastic::new(
        Vec3::splat(0.6),
        Vec3::ZERO,
        1.5,
        microfacet(MicrofacetType::Ggx, 0.2, 0.2, true),
        0.6,
    );
    let f0 = (0.5f32 / 2.5).powi(2);
    let f = b.eval(Vec3::Z, Vec3::Z).x;
    assert!(
        (f - 0.6 * std::f32::consts::FRAC_1_PI * (1.0 - f0).powi(2)).abs() < 1e-6,
        "{f}"
    );
    let w60 = Vec3::new(0.75f32.sqrt(), 0.0, 0.5);
    let f = b.eval(Vec3::Z, w60).x;
    let want = 0.6 * std::f32::consts::FRAC_1_PI * (1.0 - f0) * (1.0 - fresnel_dielectric(0.5, 1.5));
    assert!((f - want).abs() < 1e-6, "{f} vs {want}");
    assert_eq!(b.specular_probability, 0.0);
}
