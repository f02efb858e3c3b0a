//! Tests of light sampling: χ² of the cone sampler, irradiance estimates, local selection
//! and its pmf.

use super::*;
use crate::photon::test_scenes::SceneBuilder;
use crate::sampling::Rng;
use crate::sampling::chi2::{CHI2_ALPHA, DirectionTest, chi2_statistic, chi2_test_directions};
use crate::scene::Scene;
use crate::scene::light_selection::*;

/// The cone sampler, as next-event estimation uses it (direction from x to the sampled
/// point), draws directions with the density it reports: χ² over the sphere of directions,
/// for cones from nearly a hemisphere (x just outside the sphere) to narrow ones, around +z
/// (cone edges on cell boundaries) and around a tilted axis.
#[test]
fn sphere_cone_sampler_passes_chi2_against_its_pdf() {
    let x = Vec3::new(0.3, -0.2, 0.1);
    let radius = 0.5;
    for (k, (distance, axis)) in [
        (1.05 * radius, Vec3::Z),
        (1.5 * radius, Vec3::Z),
        (3.0 * radius, Vec3::Z),
        (1.2 * radius, Vec3::new(0.4, -0.7, 0.2).normalize()),
    ]
    .into_iter()
    .enumerate()
    {
        let center = x + distance * axis;
        let pdf = sphere_cone_pdf(center, radius, x).unwrap();
        let cos_max = (1.0 - (radius / distance).powi(2)).sqrt();
        let report = chi2_test_directions(
            |rng: &mut Rng| {
                let s = sample_sphere_cone(center, radius, x, rng.uniform2()).unwrap();
                assert!(((s.p - center).length() - radius).abs() < 1e-5 * radius, "{s:?}");
                assert!((s.n - (s.p - center) / radius).length() < 1e-5);
                let PointPdf::SolidAngle(pdf_w) = s.pdf else {
                    panic!("cone sampling reports a solid-angle pdf")
                };
                Some(((s.p - x).normalize(), pdf_w))
            },
            // A band of 1e-6 in cos θ around the cone's edge absorbs the rounding of
            // directions taken from points on the silhouette.
            |w| if w.dot(axis) >= cos_max - 1e-6 { pdf } else { 0.0 },
            DirectionTest {
                theta_bins: 40,
                seed: 20 + k as u64,
                ..DirectionTest::default()
            },
        );
        assert!(report.passes(CHI2_ALPHA), "d = {distance}, axis {axis}: {report:?}");
        assert!((report.pdf_integral - 1.0).abs() < 1e-3, "{report:?}");
    }
}

/// A point on or inside the sphere has no cone: the sampler and its pdf both decline (the
/// caller samples by area), with pbrt's margin of 1.0001 r².
#[test]
fn sphere_cone_sampler_declines_on_and_inside_the_sphere() {
    let (c, r) = (Vec3::new(1.0, 2.0, 3.0), 0.25);
    for x in [c, c + Vec3::new(0.1, 0.0, 0.0), c + Vec3::new(0.0, r, 0.0)] {
        assert!(sample_sphere_cone(c, r, x, Vec2::splat(0.3)).is_none());
        assert!(sphere_cone_pdf(c, r, x).is_none());
    }
    assert!(sphere_cone_pdf(c, r, c + Vec3::new(0.0, 1.01 * r, 0.0)).is_some());
}

/// A small, distant sphere (θmax ≈ 10⁻⁴): 1 − cos θmax keeps its precision (the naive
/// 1 − √(1 − sin²θmax) is zero in f32 here) and samples land on the visible cap.
#[test]
fn sphere_cone_sampler_keeps_precision_for_distant_spheres() {
    let (c, r, x) = (Vec3::new(0.0, 1000.0, 0.0), 0.1, Vec3::ZERO);
    let exact = {
        let s2 = (r as f64 / 1000.0).powi(2);
        1.0 - (1.0 - s2).sqrt()
    };
    let pdf = sphere_cone_pdf(c, r, x).unwrap() as f64;
    let want = 1.0 / (std::f64::consts::TAU * exact);
    assert!((pdf - want).abs() < 1e-5 * want, "{pdf} vs {want}");
    let mut rng = Rng::for_task(5, [0, 0, 0]);
    for _ in 0..1000 {
        let s = sample_sphere_cone(c, r, x, rng.uniform2()).unwrap();
        assert!(s.n.dot(x - s.p) > 0.0, "on the near side: {s:?}");
        assert!(((s.p - c).length() - r).abs() < 1e-4, "{s:?}");
    }
}

/// Irradiance from a sphere light fully above the horizon of a receiver facing its centre
/// is E = π Le sin²θmax. Both samplers estimate it without bias; the cone sampler with
/// variance several times lower (no samples wasted on the far side, no 1/cos θ').
#[test]
fn both_sphere_samplers_estimate_the_irradiance_of_a_sphere() {
    let (c, r, x) = (Vec3::new(0.2, 0.9, -0.1), 0.3, Vec3::ZERO);
    let n = c.normalize();
    let le = 2.0f64;
    let d2 = c.length_squared() as f64;
    let exact = std::f64::consts::PI * le * (r as f64).powi(2) / d2;
    let light = AreaLight {
        prim: 0,
        emission: Emission {
            le: Vec3::splat(le as f32),
            two_sided: false,
        },
        area: 4.0 * PI * r * r,
    };
    let prim = Primitive::Sphere { center: c, radius: r };
    let estimate = |cone: bool| {
        let mut rng = Rng::for_task(9, [cone as u64, 0, 0]);
        let samples = 200_000;
        let (mut s1, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..samples {
            let u = rng.uniform2();
            let s = if cone {
                sample_sphere_cone(c, r, x, u).unwrap()
            } else {
                let lp = light.sample_point(&prim, u);
                LightSample {
                    p: lp.p,
                    n: lp.n,
                    pdf: PointPdf::Area(lp.pdf_a),
                }
            };
            let to = s.p - x;
            let d2 = to.length_squared();
            let wi = to / d2.sqrt();
            // The sphere hides its own far side: a point is visible when it faces x.
            let visible = s.n.dot(-wi) > 0.0;
            let pdf_w = match s.pdf {
                PointPdf::Area(pdf_a) => pdf_a * d2 / s.n.dot(wi).abs(),
                PointPdf::SolidAngle(p) => p,
            };
            let v = if visible {
                (light.le(s.n, -wi).x * n.dot(wi).max(0.0) / pdf_w) as f64
            } else {
                0.0
            };
            s1 += v;
            s2 += v * v;
        }
        let m = s1 / samples as f64;
        let var = s2 / samples as f64 - m * m;
        (m, (var / samples as f64).sqrt(), var)
    };
    let (m_area, se_area, var_area) = estimate(false);
    let (m_cone, se_cone, var_cone) = estimate(true);
    assert!(
        (m_area - exact).abs() < 4.5 * se_area,
        "area {m_area} ± {se_area} vs {exact}"
    );
    assert!(
        (m_cone - exact).abs() < 4.5 * se_cone,
        "cone {m_cone} ± {se_cone} vs {exact}"
    );
    assert!(var_area > 4.0 * var_cone, "variance area {var_area} vs cone {var_cone}");
}

/// A scene with lights of every kind around the origin: a one-sided quad (two triangles)
/// facing −y above, a two-sided quad to the side, a one-sided and a two-sided sphere.
fn mixed_lights() -> Scene {
    let mut b = SceneBuilder::new();
    let black = b.lambertian(Vec3::ZERO);
    b.quad(
        Vec3::new(-0.5, 1.0, -0.5),
        Vec3::X,
        Vec3::Z,
        black,
        Some(Vec3::splat(3.0)),
    );
    b.quad(
        Vec3::new(1.5, -0.5, -0.3),
        Vec3::new(0.0, 0.0, 0.6),
        Vec3::new(0.0, 0.8, 0.0),
        black,
        Some(Vec3::splat(1.0)),
    );
    let sphere = |le: f32, two_sided| Emission {
        le: Vec3::splat(le),
        two_sided,
    };
    b.sphere_light(Vec3::new(-0.6, 0.3, 0.4), 0.1, black, sphere(10.0, false));
    b.sphere_light(Vec3::new(0.3, -0.7, -0.2), 0.2, black, sphere(5.0, true));
    b.build()
}

/// Unbiasedness of local selection needs a positive weight for every light that can
/// contribute at the receiver. For random receivers (reflecting or transmitting, any
/// normal) and random points on every light, whenever the point emits towards x and lies
/// on the receiver's side (either side when transmitting), the light's weight is positive;
/// and a light with weight 0 never has such a point.
#[test]
fn local_weight_is_positive_for_every_light_that_can_contribute() {
    let scene = mixed_lights();
    assert_eq!(scene.lights.len(), 6);
    let mut rng = Rng::for_task(13, [0, 0, 0]);
    let (mut zero, mut positive) = (0, 0);
    for _ in 0..4000 {
        let p = Vec3::new(
            rng.uniform() * 4.0 - 2.0,
            rng.uniform() * 3.0 - 1.5,
            rng.uniform() * 3.0 - 1.5,
        );
        let r = Receiver {
            p,
            n: sample_uniform_sphere(rng.uniform2()),
            two_sided: rng.uniform() < 0.3,
        };
        for light in &scene.lights {
            let prim = &scene.primitives[light.prim as usize];
            let w = local_weight(light, prim, &r);
            assert!(w.is_finite() && w >= 0.0, "{w}");
            if w > 0.0 {
                positive += 1;
                continue;
            }
            zero += 1;
            for _ in 0..200 {
                let lp = light.sample_point(prim, rng.uniform2());
                let wi = (lp.p - p).normalize();
                let emits = light.le(lp.n, -wi) != Vec3::ZERO;
                let cos = r.n.dot(wi);
                let side = if r.two_sided { cos != 0.0 } else { cos > 0.0 };
                assert!(!(emits && side), "weight 0 but {lp:?} lights {r:?}");
            }
        }
    }
    assert!(
        zero > 1000 && positive > 10_000,
        "both cases exercised: {zero} zero, {positive} positive"
    );
}

/// Near a light its local weight dominates; a one-sided light seen from behind gets none.
#[test]
fn local_selection_prefers_the_light_next_to_the_receiver() {
    let scene = mixed_lights();
    let sampling = LightSampling {
        selection: LightSelection::Local,
        sphere: SphereSampling::Cone,
    };
    // Just beside the small one-sided sphere (light 4), facing it.
    let r = Receiver {
        p: Vec3::new(-0.6, 0.3, 0.52),
        n: -Vec3::Z,
        two_sided: false,
    };
    let ctx = sampling.at(&scene, r.p, || r, &mut None);
    assert!(ctx.pmf(&scene, 4) > 0.9, "{}", ctx.pmf(&scene, 4));
    assert!(scene.light_selection.pmf(4) < 0.3);
    // Above the ceiling quad (lights 0 and 1 emit downwards): they get probability 0.
    let above = LightSampling {
        selection: LightSelection::Local,
        sphere: SphereSampling::Area,
    }
    .at(
        &scene,
        Vec3::new(0.0, 1.5, 0.0),
        || Receiver {
            p: Vec3::new(0.0, 1.5, 0.0),
            n: -Vec3::Y,
            two_sided: true,
        },
        &mut None,
    );
    assert_eq!(above.pmf(&scene, 0), 0.0);
    assert_eq!(above.pmf(&scene, 1), 0.0);
    let total: f32 = (0..scene.lights.len()).map(|i| above.pmf(&scene, i)).sum();
    assert!((total - 1.0).abs() < 1e-5, "{total}");
}

/// `choose` picks lights with the frequencies `pmf` reports (χ² on the counts), for power
/// and local selection at receivers where the pmfs differ.
#[test]
fn light_choice_frequencies_match_the_reported_pmf() {
    let scene = mixed_lights();
    let n_lights = scene.lights.len();
    let mut rng = Rng::for_task(17, [0, 0, 0]);
    for (k, selection) in [LightSelection::Power, LightSelection::Local, LightSelection::Local]
        .into_iter()
        .enumerate()
    {
        let r = Receiver {
            p: Vec3::new(0.1 * k as f32, 0.2, -0.3 + 0.2 * k as f32),
            n: Vec3::new(0.3, 1.0, -0.2 * k as f32).normalize(),
            two_sided: k == 2,
        };
        let mut weights = None;
        let ctx = LightSampling {
            selection,
            sphere: SphereSampling::Area,
        }
        .at(&scene, r.p, || r, &mut weights);
        let n = 100_000;
        let mut counts = vec![0.0f64; n_lights];
        for _ in 0..n {
            let (Emitter::Area(i), pmf) = ctx.choose(&scene, &weights, rng.uniform()).unwrap() else {
                panic!("no environment here");
            };
            // Bit for bit: the MIS weight recomputes the one weight it needs.
            assert_eq!(pmf, ctx.pmf(&scene, i));
            counts[i] += 1.0;
        }
        let expected: Vec<f64> = (0..n_lights).map(|i| ctx.pmf(&scene, i) as f64 * n as f64).collect();
        let chi2 = chi2_statistic(&counts, &expected, 5.0);
        assert!(
            chi2.p_value > CHI2_ALPHA,
            "{selection:?} at {r:?}: {chi2:?} {counts:?} {expected:?}"
        );
    }
}

/// The light pdf of the MIS weight ([`LightContext::pdf_w`]) is the density light sampling
/// reports for the same point: area sampling's p_A r² / |cos θ'| times the pmf, or the
/// cone's density times the pmf, for every option.
#[test]
fn mis_light_pdf_equals_the_sampling_density() {
    let scene = mixed_lights();
    let mut rng = Rng::for_task(19, [0, 0, 0]);
    for selection in [LightSelection::Power, LightSelection::Local] {
        for sphere in [SphereSampling::Area, SphereSampling::Cone] {
            let sampling = LightSampling { selection, sphere };
            let mut weights = None;
            let r = Receiver {
                p: Vec3::new(0.0, 0.1, 0.0),
                n: Vec3::Y,
                two_sided: true,
            };
            let ctx = sampling.at(&scene, r.p, || r, &mut weights);
            for _ in 0..2000 {
                let Some((Emitter::Area(i), pmf)) = ctx.choose(&scene, &weights, rng.uniform()) else {
                    continue;
                };
                let light = &scene.lights[i];
                let s = ctx.sample_point(light, &scene.primitives[light.prim as usize], rng.uniform2());
                let to = s.p - ctx.receiver.p;
                let (d2, wi) = (to.length_squared(), to.normalize());
                let cos_light = s.n.dot(wi).abs();
                let sampled = match s.pdf {
                    PointPdf::Area(pdf_a) => pmf * pdf_a * d2 / cos_light,
                    PointPdf::SolidAngle(pdf_w) => pmf * pdf_w,
                };
                let mis = ctx.pdf_w(&scene, i, d2.sqrt(), cos_light);
                assert!(
                    (sampled - mis).abs() <= 1e-4 * sampled,
                    "{selection:?} {sphere:?} light {i}: {sampled} vs {mis}"
                );
            }
        }
    }
}
