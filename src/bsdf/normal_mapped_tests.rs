//! Tests of [`NormalMapped`] beyond the shared ones (which take three mapped models through χ²
//! in radiance transport, reciprocity, albedo and sampled values): χ² and sampled values in
//! importance transport, Mitsuba 3.9's rules in closed form (the normal the eye sees, G₁), a
//! density wherever there is a value in both modes, and delta models under a map.

use super::tests::{lambertian, microfacet, normal_mapped, random_directions, rough_dielectric, test_wos};
use super::*;
use crate::sampling::Rng;
use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_test_directions};
use std::f32::consts::FRAC_1_PI;

/// Mapped models of every kind: reflecting (two-sided and one-sided), transmitting, glossy.
fn mapped_models() -> Vec<(&'static str, Bsdf)> {
    use MicrofacetType::Ggx;
    vec![
        (
            "lambertian 37°",
            normal_mapped(lambertian(0.8), Vec3::new(0.8, 0.5, 0.9)),
        ),
        (
            "lambertian 76°",
            normal_mapped(lambertian(0.8), Vec3::new(0.9, 0.5, 0.6)),
        ),
        (
            "one-sided lambertian 40°",
            normal_mapped(Bsdf::OneSided(Box::new(lambertian(0.8))), Vec3::new(0.7, 0.35, 0.8)),
        ),
        (
            "roughdielectric 30°",
            normal_mapped(
                rough_dielectric(1.5, microfacet(Ggx, 0.3, 0.3, true)),
                Vec3::new(0.3, 0.6, 0.9),
            ),
        ),
        (
            "diffuse transmission 40°",
            normal_mapped(
                Bsdf::DiffuseTransmission(DiffuseTransmission {
                    reflectance: Vec3::splat(0.3),
                    transmittance: Vec3::splat(0.6),
                }),
                Vec3::new(0.7, 0.35, 0.8),
            ),
        ),
    ]
}

const MODES: [TransportMode; 2] = [TransportMode::Radiance, TransportMode::Importance];

#[test]
fn mapped_samplers_pass_chi2_in_both_modes() {
    for (seed, (name, bsdf)) in mapped_models().into_iter().enumerate() {
        for mode in MODES {
            for (k, wo) in test_wos().into_iter().enumerate() {
                let report = chi2_test_directions(
                    |rng: &mut Rng| {
                        let (u, u_lobe) = (rng.uniform2(), rng.uniform());
                        bsdf.sample(wo, u, u_lobe, mode).map(|s| (s.wi, s.pdf_w))
                    },
                    |wi| bsdf.pdf(wo, wi),
                    DirectionTest {
                        seed: (seed * 16 + k) as u64 + 500,
                        ..DirectionTest::default()
                    },
                );
                assert!(report.passes(CHI2_ALPHA), "{name}, {mode:?}, wo = {wo}: {report:?}");
            }
        }
    }
}

/// Sampling covers every direction with a value, in both modes: in importance transport the eye
/// is the direction sampled, and it may see either normal.
#[test]
fn mapped_models_have_a_density_wherever_they_have_a_value() {
    let dirs = random_directions(21, 20_000);
    for (name, bsdf) in mapped_models() {
        for mode in MODES {
            let mut seen = 0;
            for pair in dirs.chunks_exact(2) {
                let (wo, wi) = (pair[0], pair[1]);
                if bsdf.eval(wo, wi, mode).max_element() > 0.0 {
                    seen += 1;
                    assert!(
                        bsdf.pdf(wo, wi) > 0.0,
                        "{name}, {mode:?}: f({wo}, {wi}) > 0 with no density"
                    );
                }
            }
            assert!(seen > 1000, "{name}, {mode:?}: {seen} pairs with a value");
        }
    }
}

#[test]
fn mapped_samples_carry_eval_and_pdf_in_both_modes() {
    let mut rng = Rng::for_task(23, [0, 0, 0]);
    for (name, bsdf) in mapped_models() {
        for mode in MODES {
            for wo in test_wos() {
                for _ in 0..300 {
                    let Some(s) = bsdf.sample(wo, rng.uniform2(), rng.uniform(), mode) else {
                        continue;
                    };
                    let f = bsdf.eval(wo, s.wi, mode);
                    assert!(
                        (s.f - f).abs().max_element() <= 1e-5 * f.max_element().max(1e-3),
                        "{name}"
                    );
                    assert!((s.pdf_w / bsdf.pdf(wo, s.wi) - 1.0).abs() < 1e-5, "{name}");
                }
            }
        }
    }
}

/// G₁ in closed form: a 76° tilt clamps α² to 1, where G₁(60°) = 2 / (1 + √(1 + 3)) = 2/3
/// (Mitsuba 3.9.1 gives 0.666 67 there); a flat map shadows nothing.
#[test]
fn shadowing_is_smiths_ggx_with_the_tilts_roughness() {
    let steep = NormalMapped::new(lambertian(0.5), Vec3::new(0.9, 0.5, 0.6));
    assert!(
        (steep.shadowing(0.5) - 2.0 / 3.0).abs() < 1e-6,
        "{}",
        steep.shadowing(0.5)
    );
    assert_eq!(steep.shadowing(0.0), 0.0);
    assert_eq!(steep.shadowing(1.0), 1.0);
    let flat = NormalMapped::new(lambertian(0.5), Vec3::new(0.5, 0.5, 1.0));
    for c in [0.01, 0.3, 0.9] {
        assert_eq!(flat.shadowing(c), 1.0);
    }
    // 37°: α² = (1 − 0.64) / (8 · 0.64).
    let tilt = NormalMapped::new(lambertian(0.5), Vec3::new(0.8, 0.5, 0.9));
    let want = 2.0 / (1.0 + (1.0 + 0.36 / 5.12 * 3.0f32).sqrt());
    assert!((tilt.shadowing(0.5) - want).abs() < 1e-6);
}

/// A Lambertian model under a map reflects ρ/π (l · n′) G₁(l) with n′ the map's normal m where
/// the eye sees m's front, and m with its tangential part reversed where it does not (Mitsuba
/// 3.9's rule: a grazing eye on a steep map is not black).
#[test]
fn the_eye_sees_the_maps_normal_or_its_mirror_image() {
    let c = Vec3::new(0.7, 0.35, 0.8);
    let b = NormalMapped::new(lambertian(0.5), c);
    let m = (2.0 * c - Vec3::ONE).normalize();
    let dirs = random_directions(22, 4000);
    let (mut direct, mut reversed) = (0, 0);
    for pair in dirs.chunks_exact(2) {
        let (eye, light) = (pair[0].with_z(pair[0].z.abs()), pair[1]);
        let n = if eye.dot(m) < 0.0 {
            reversed += 1;
            reflect_z(m)
        } else {
            direct += 1;
            m
        };
        let want = if light.z > 0.0 && light.dot(n) > 0.0 {
            0.5 * FRAC_1_PI * light.dot(n) * b.shadowing(light.z) / light.z
        } else {
            0.0
        };
        for mode in MODES {
            let (wo, wi) = if mode == TransportMode::Radiance {
                (eye, light)
            } else {
                (light, eye)
            };
            let got = b.eval(wo, wi, mode).x;
            assert!((got - want).abs() <= 1e-5 * want.max(1.0), "{mode:?}: {got} vs {want}");
        }
    }
    assert!(direct > 200 && reversed > 200, "{direct} / {reversed}");
}

/// Below the surface a two-sided model sees the map mirrored (Mitsuba's twosided flips both
/// directions), a one-sided one is black.
#[test]
fn back_sides_are_mirrored_or_black() {
    let c = Vec3::new(0.7, 0.35, 0.8);
    let two = NormalMapped::new(lambertian(0.5), c);
    let one = NormalMapped::new(Bsdf::OneSided(Box::new(lambertian(0.5))), c);
    let flip = |w: Vec3| w.with_z(-w.z);
    for pair in random_directions(24, 400).chunks_exact(2) {
        let (wo, wi) = (pair[0].with_z(-pair[0].z.abs()), pair[1].with_z(-pair[1].z.abs()));
        for mode in MODES {
            assert_eq!(two.eval(wo, wi, mode), two.eval(flip(wo), flip(wi), mode));
            assert_eq!(one.eval(wo, wi, mode), Vec3::ZERO);
        }
        assert_eq!(two.pdf(wo, wi), two.pdf(flip(wo), flip(wi)));
        assert_eq!(one.pdf(wo, wi), 0.0);
    }
}

/// A mirror under a map: in radiance transport it reflects about the normal the eye (`wo`) sees,
/// and a sample drawn around the other normal carries nothing; the coefficient and probability
/// of each sample are the ones `delta_lobe` reports, and a lobe's coefficient for importance is
/// its coefficient for radiance with the directions swapped.
#[test]
fn a_mapped_mirror_reflects_about_the_normal_the_eye_sees() {
    let c = Vec3::new(0.7, 0.35, 0.8);
    let mirror = normal_mapped(
        Bsdf::Mirror(Mirror {
            reflectance: Vec3::splat(0.9),
        }),
        c,
    );
    let Bsdf::NormalMapped(b) = &mirror else { unreachable!() };
    let mut rng = Rng::for_task(25, [0, 0, 0]);
    let mut valid = [0usize; 2];
    for wo in random_directions(26, 400) {
        let wo = wo.with_z(wo.z.abs());
        for mode in MODES {
            let u_lobe = rng.uniform();
            let Some(s) = mirror.sample(wo, rng.uniform2(), u_lobe, mode) else {
                continue;
            };
            assert!(s.delta);
            valid[(u_lobe >= OWN_FRAME_SHARE) as usize] += 1;
            let (f, p) = mirror.delta_lobe(wo, s.wi, mode).expect("the sampled lobe");
            assert!((f - s.f).abs().max_element() < 1e-5 * f.max_element() && (p - s.pdf_w).abs() < 1e-6);
            let (f_adj, _) = mirror.delta_lobe(s.wi, wo, mode.adjoint()).expect("the adjoint lobe");
            assert!(
                (f_adj - f).abs().max_element() < 1e-4 * f.max_element(),
                "{f_adj} vs {f}"
            );
            if mode == TransportMode::Radiance {
                let n = if wo.dot(b.normal) < 0.0 {
                    reflect_z(b.normal)
                } else {
                    b.normal
                };
                let want = 2.0 * wo.dot(n) * n - wo;
                assert!((s.wi - want).length() < 1e-5, "{} vs {want}", s.wi);
                assert!(u_lobe < OWN_FRAME_SHARE, "radiance keeps the eye's own frame");
            }
        }
    }
    assert!(valid[0] > 300, "{valid:?}");
}
