use super::*;
use crate::photon::test_scenes::emitting_box;

fn table(text: &str) -> toml::Table {
    toml::from_str(text).unwrap()
}

fn render_mean(scene: &Scene, kind: &str, params: &str, seed: u64, passes: u32) -> Vec3 {
    let mut s = crate::strategy::build(kind, table(params)).unwrap();
    s.prepare(scene, seed).unwrap();
    let mut film = Film::new(scene.camera.width, scene.camera.height);
    s.render_pass(scene, seed, 0..passes, &mut film);
    film.image().mean()
}

/// Both methods, with direct light from light sampling and from photons, converge to
/// Le / (1 − ρ) in the emitting furnace: the mean over 6 seeds is within 5 standard errors of
/// the exact value, and the standard error is below 1 %, so the test is sharp enough to see a
/// missing π or an unscaled τ (which overshoots by the radius reduction, 2× after 12 passes).
#[test]
fn the_emitting_furnace_converges_to_le_over_one_minus_rho() {
    let rho = 0.5f32;
    let exact = 1.0 / (1.0 - rho as f64);
    for (kind, params, mirror) in [
        ("sppm", "photons_per_pass = 20000", false),
        ("sppm", "photons_per_pass = 20000\ndirect = \"photons\"", true),
        ("ppm", "photons_per_pass = 20000\neye_samples = 2", false),
        ("ppm", "photons_per_pass = 20000\ndirect = \"nee\"", true),
    ] {
        let scene = emitting_box(rho, mirror);
        let means: Vec<f64> = (0..6)
            .map(|seed| crate::color::luminance(render_mean(&scene, kind, params, seed, 12)) as f64)
            .collect();
        let n = means.len() as f64;
        let mean = means.iter().sum::<f64>() / n;
        let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let se = (var / n).sqrt();
        let z = (mean - exact) / se;
        assert!(se < 0.01 * exact, "{kind} [{params}]: standard error {se}");
        assert!(
            z.abs() < 5.0,
            "{kind} [{params}]: {mean} vs {exact} (z = {z:.2}, means {means:?})"
        );
    }
}

/// The radius reduction of one slot: α M of the M new photons are kept, and the radius and the
/// flux shrink by (N + α M) / (N + M), so that under a uniform photon density (M ∝ R²) the
/// estimate τ / (k π R²) keeps its expected value while R → 0.
#[test]
fn a_uniform_density_keeps_its_estimate_while_the_radius_shrinks() {
    // λ photons per unit area per pass, each depositing 1: Φ = M = λ π R² (fractions allowed
    // here through the expected-value form of the update).
    let lambda = 1.0e5f64;
    let alpha = 0.7;
    let mut slot = Slot {
        r2: 0.01,
        ..Slot::default()
    };
    let r2_start = slot.r2;
    for k in 1..=200u32 {
        let m = (lambda * std::f64::consts::PI * slot.r2).round() as u32;
        slot.update(DVec3::splat(m as f64), m, alpha);
        let estimate = slot.radiance(k as f64).x;
        assert!((estimate / lambda - 1.0).abs() < 0.05, "pass {k}: {estimate}");
    }
    // R² falls like k^−(1−α) (Hachisuka et al. 2008, §4): 200^−0.3 ≈ 0.2.
    assert!(
        slot.r2 < 0.2 * r2_start,
        "the radius must shrink: {} → {}",
        r2_start,
        slot.r2
    );
    let untouched = {
        let mut s = slot;
        s.update(DVec3::splat(5.0), 0, alpha);
        s
    };
    assert_eq!((untouched.r2, untouched.n, untouched.tau), (slot.r2, slot.n, slot.tau));
}

/// The film's mean after each pass is the estimate of that many passes: the values handed to
/// the film telescope, whatever the split into passes.
#[test]
fn the_film_mean_after_k_passes_is_the_k_pass_estimate() {
    let scene = emitting_box(0.5, false);
    let strategy = <Sppm as Declared>::new(SppmParams::from_table(table("photons_per_pass = 2000")).unwrap()).unwrap();
    let mut film = Film::new(16, 16);
    for k in 1..=5u32 {
        strategy.render_pass(&scene, 3, k - 1..k, &mut film);
        let progress = strategy.engine.progress.lock().unwrap();
        let image = film.image();
        for (pixel, slot) in progress.slots.iter().enumerate() {
            let want = slot.radiance(k as f64);
            let got = image.pixels[pixel].as_dvec3();
            assert!(
                ((got - want).abs() / want).max_element() < 1e-6,
                "pass {k}, pixel {pixel}"
            );
        }
        assert!(film.accumulators().iter().all(|a| a.count == k));
    }
}

#[test]
fn hostile_parameters_are_refused() {
    for (kind, text) in [
        ("sppm", "alpha = 0.0"),
        ("sppm", "alpha = 1.5"),
        ("ppm", "photons_per_pass = 0"),
        ("ppm", "eye_samples = 0"),
        ("sppm", "initial_radius = -1.0"),
        ("sppm", "eye_samples = 2"),
        ("ppm", "direct = \"mis\""),
    ] {
        let err = crate::strategy::build(kind, table(text)).err();
        assert!(err.is_some(), "{kind}: `{text}` must be refused");
    }
}

/// The eye pass at a smooth plastic (module doc of [`eye`]): over many eye paths through one
/// point of a plastic sphere, the visible points made there carry, in expectation, the
/// throughput that arrived (β / (1 − P_δ) with probability 1 − P_δ), and the paths that went on
/// through the coating carry its reflectance F(θ) k_s to the Lambertian wall they reach next.
/// Both means must lie within 4 standard errors; dropping the 1 / (1 − P_δ) or stopping at the
/// plastic fails the first or the second.
#[test]
fn a_smooth_plastic_splits_eye_paths_between_its_base_and_its_coating() {
    use crate::bsdf::{Bsdf, Plastic, fresnel_dielectric};
    use crate::geometry::Ray;
    use crate::photon::test_scenes::SceneBuilder;
    let mut b = SceneBuilder::new();
    let wall = b.lambertian(Vec3::splat(0.5));
    b.closed_box(wall, Vec3::ONE);
    let ks = 0.8;
    let plastic = b.material(Bsdf::Plastic(Plastic {
        diffuse_reflectance: Vec3::new(0.2, 0.4, 0.6),
        specular_reflectance: Vec3::splat(ks),
        ior: 1.5,
        nonlinear: false,
    }));
    b.sphere(Vec3::splat(0.5), 0.2, plastic);
    let scene = b.build();
    // A ray from inside the box to a point of the sphere 50° off its normal there.
    let hit_dir = Vec3::new(50f32.to_radians().sin(), 0.0, -50f32.to_radians().cos());
    let target = Vec3::splat(0.5) + 0.2 * hit_dir;
    let origin = Vec3::new(0.5, 0.5, 0.05);
    let ray = Ray::new(origin, (target - origin).normalize());
    let first = scene.intersect(&ray).unwrap();
    assert_eq!(first.material, plastic);
    let mu = first.frame.to_local(-ray.d).z.abs();
    let n = 200_000;
    let (mut base, mut coat) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for i in 0..n {
        let mut rng = Rng::for_task(7, [0, i as u64, 0]);
        let path = trace_eye(&scene, ray, 4, DirectLight::Photons, &mut rng);
        let v = path.visible.map(|v| (v.hit.material, v.beta.x as f64));
        base.push(match v {
            Some((m, beta)) if m == plastic => beta,
            _ => 0.0,
        });
        coat.push(match v {
            Some((m, beta)) if m == wall => beta,
            _ => 0.0,
        });
    }
    let mean_se = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
        (m, (var / v.len() as f64).sqrt())
    };
    let (m, se) = mean_se(&base);
    assert!((m - 1.0).abs() < 4.0 * se, "base: {m} ± {se}, expected 1");
    let expected = f64::from(fresnel_dielectric(mu, 1.5) * ks);
    let (m, se) = mean_se(&coat);
    assert!(se < 0.05 * expected, "coating too noisy to judge: {m} ± {se}");
    assert!(
        (m - expected).abs() < 4.0 * se,
        "coating: {m} ± {se}, expected F k_s = {expected}"
    );
}
