//! Light from infinitely far away (`[environment]`, Mitsuba's `constant` and `envmap`): the
//! furnace under a constant sky, next-event estimation, BSDF sampling and MIS agreeing under
//! an environment map, strategies that do not render it refusing the scene, bad input refused.

mod agreement;

use agreement::{assert_agrees, assert_refused, image_mean, load_text, region_mean, render_image};
use glam::Vec3;
use photon_bench::film::{Image, write_exr};
use photon_bench::scene::Scene;
use photon_bench::scene::load::load_scene_with_stats;
use photon_bench::strategy::{self, Strategy};
use std::path::Path;

fn scene_toml(environment: &str) -> String {
    format!(
        r#"[camera]
eye = [0, 0, 4]
look_at = [0, 0, 0]
fov_y = 40
resolution = [16, 16]

[materials.grey]
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]

[[shapes]]
type = "sphere"
material = "grey"
center = [0, 0, 0]
radius = 1

{environment}
"#
    )
}

/// A convex diffuse sphere of albedo ρ under a constant sky L sees the sky over its whole
/// hemisphere and nothing else: it reflects exactly ρ L everywhere, and the sky behind it is L.
/// BSDF sampling gives it in every sample (cosine sampling of a Lambertian toward a constant
/// sky has weight ρ L), next-event estimation and MIS in the mean: per sample, NEE's estimate
/// 4ρ cos θ (half the uniform directions lie below the horizon) has a standard deviation of
/// 1.3 ρ L, so 16 pixels × 4096 samples pin the mean to ±0.5 % (1 σ).
#[test]
fn a_diffuse_sphere_under_a_constant_sky_reflects_albedo_times_sky() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load_text(
        dir.path(),
        "env.toml",
        &scene_toml("[environment]\ntype = \"constant\"\nradiance = [1, 2, 3]"),
    )
    .unwrap();
    for direct in ["mis", "nee", "bsdf"] {
        let img = render_image(
            &scene,
            "path",
            &format!("direct = \"{direct}\"\nmax_depth = 4"),
            4096,
            3,
        );
        let corner = img.get(0, 0);
        assert_eq!(corner, Vec3::new(1.0, 2.0, 3.0), "{direct}: the sky seen directly");
        // The central 4 × 4 pixels see the sphere's front.
        let mut sum = Vec3::ZERO;
        for y in 6..10 {
            for x in 6..10 {
                sum += img.get(x, y);
            }
        }
        let mean = sum / 16.0;
        let expected = Vec3::new(0.5, 1.0, 1.5);
        let rel = ((mean - expected) / expected).abs().max_element();
        let tolerance = if direct == "bsdf" { 1e-4 } else { 0.02 };
        assert!(rel < tolerance, "{direct}: {mean} vs {expected}");
    }
}

/// The strategies built on path space (the environment as a vertex at infinity) reproduce the
/// closed form of the test above, each technique family on its own: `light` sees the sky only
/// by connecting environment samples to the pinhole, `bdpt` weighs that against the eye walk
/// leaving the scene, `vcm` adds merging. Per region (the sphere's centre, ρ L; a corner, L)
/// the mean over 6 seeds must lie within 4 standard errors (plus 1 % for `vcm`'s consistent
/// merging), and the standard error must be small enough for that to mean something.
#[test]
fn path_space_strategies_under_a_constant_sky_reproduce_albedo_times_sky() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load_text(
        dir.path(),
        "env.toml",
        &scene_toml("[environment]\ntype = \"constant\"\nradiance = [1, 2, 3]"),
    )
    .unwrap();
    let centre: Vec<(u32, u32)> = (6..10).flat_map(|y| (6..10).map(move |x| (x, y))).collect();
    let corners: Vec<(u32, u32)> = (0..2).flat_map(|y| [(0, y), (1, y), (14, y), (15, y)]).collect();
    // `light` reaches a sky pixel only where one of its N = 256 environment samples per pass
    // lands (~2 per corner pixel per 64 passes): its sky needs many passes for 6 seeds to
    // estimate their own spread.
    for (kind, spp, slack) in [("light", 1024, 0.0), ("bdpt", 64, 0.0), ("vcm", 64, 0.01)] {
        let images: Vec<Image> = (0..6)
            .map(|seed| render_image(&scene, kind, "max_depth = 4", spp, seed))
            .collect();
        for (region, pixels, expected) in [("sphere", &centre, 0.5 * 6.0), ("sky", &corners, 6.0)] {
            let (m, se) = region_mean(&images, pixels);
            assert!(se < 0.03 * expected, "{kind} {region}: too noisy to judge ({m} ± {se})");
            assert!(
                (m - expected).abs() < 4.0 * se + slack * expected,
                "{kind} {region}: {m} ± {se}, expected {expected}"
            );
        }
    }
}

/// A small lat-long map with a bright sun and a dim sky.
fn write_sky(path: &Path) {
    let (w, h) = (32u32, 16u32);
    let mut pixels = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let sky = Vec3::new(0.2, 0.3, 0.5) * (1.0 - y as f32 / h as f32);
            let sun = if (x, y) == (7, 4) {
                Vec3::splat(300.0)
            } else {
                Vec3::ZERO
            };
            pixels.push(sky + sun);
        }
    }
    write_exr(
        &Image {
            width: w,
            height: h,
            pixels,
        },
        path,
    )
    .unwrap();
}

/// Under an environment map with a sun, the three ways of finding its light are three
/// estimators of the same image: their means agree within their statistical error.
#[test]
fn nee_bsdf_sampling_and_mis_agree_under_an_environment_map() {
    let dir = tempfile::tempdir().unwrap();
    write_sky(&dir.path().join("sky.exr"));
    let env =
        "[environment]\ntype = \"envmap\"\nfile = \"sky.exr\"\nscale = 2\ntransform = { rotate_y = 30, rotate_x = 10 }";
    let scene = load_text(dir.path(), "env.toml", &scene_toml(env)).unwrap();
    let estimate = |direct: &str| {
        let means: Vec<f64> = (0..8)
            .map(|seed| {
                let img = render_image(
                    &scene,
                    "path",
                    &format!("direct = \"{direct}\"\nmax_depth = 3"),
                    16,
                    seed,
                );
                img.pixels.iter().map(|p| f64::from(p.x + p.y + p.z)).sum::<f64>() / img.pixels.len() as f64
            })
            .collect();
        let m = means.iter().sum::<f64>() / means.len() as f64;
        let var = means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (means.len() - 1) as f64;
        (m, (var / means.len() as f64).sqrt())
    };
    let (mis, nee, bsdf) = (estimate("mis"), estimate("nee"), estimate("bsdf"));
    for (name, (m, se)) in [("nee", nee), ("bsdf", bsdf)] {
        let z = (m - mis.0) / (se * se + mis.1 * mis.1).sqrt();
        assert!(
            z.abs() < 4.0,
            "{name}: {m} ± {se} vs mis {} ± {} (z = {z:.2})",
            mis.0,
            mis.1
        );
    }
    assert!(
        mis.1 < bsdf.1,
        "MIS is less noisy than BSDF sampling under a sun: {mis:?} vs {bsdf:?}"
    );
}

/// Every strategy renders environment light now (the Metropolis ones since 2026-11-26): each
/// accepts the scene.
#[test]
fn every_strategy_takes_environment_light() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load_text(
        dir.path(),
        "env.toml",
        &scene_toml("[environment]\ntype = \"constant\"\nradiance = [1, 1, 1]"),
    )
    .unwrap();
    for kind in strategy::kinds() {
        let s: Box<dyn Strategy> = strategy::build(kind, toml::Table::new()).unwrap();
        let r = strategy::check_scene(&*s, &scene);
        assert!(r.is_ok(), "{kind}: {r:?}");
    }
}

#[test]
fn bad_environments_are_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    write_sky(&dir.path().join("sky.exr"));
    write_exr(
        &Image {
            width: 4,
            height: 2,
            pixels: vec![Vec3::ZERO; 8],
        },
        &dir.path().join("black.exr"),
    )
    .unwrap();
    let refused = |env: &str, expect: &[&str]| {
        let err = load_text(dir.path(), "env.toml", &scene_toml(env))
            .err()
            .expect("refused")
            .to_string();
        assert_refused(&err, expect);
    };
    refused(
        "[environment]\ntype = \"constant\"\nradiance = [1, -1, 1]",
        &["environment.radiance", "[0, "],
    );
    refused(
        "[environment]\ntype = \"envmap\"\nfile = \"nowhere.exr\"",
        &["environment.file", "nowhere.exr"],
    );
    refused(
        "[environment]\ntype = \"envmap\"\nfile = \"black.exr\"",
        &["environment.file", "black"],
    );
    refused(
        "[environment]\ntype = \"envmap\"\nfile = \"sky.exr\"\nscale = -2",
        &["environment.scale"],
    );
    refused(
        "[environment]\ntype = \"envmap\"\nfile = \"sky.exr\"\ntransform = { scale = [1, 2, 1] }",
        &["environment.transform", "rotation"],
    );
    refused("[environment]\ntype = \"sun\"", &["environment", "sun"]);
    refused(
        "[environment]\ntype = \"constant\"\nradiance = [1, 1, 1]\nshine = 2",
        &["shine"],
    );
}

/// Mitsuba's `constant` and `envmap` emitters become the scene's environment, with the map's
/// frame and scale; an environment alone lights a scene; a second one is refused.
#[test]
fn mitsuba_environment_emitters_are_imported() {
    let dir = tempfile::tempdir().unwrap();
    write_sky(&dir.path().join("sky.exr"));
    let xml = |emitters: &str| {
        format!(
            r#"<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
    <shape type="sphere"><bsdf type="diffuse"/></shape>
    {emitters}
</scene>"#
        )
    };
    let load_xml = |text: &str| {
        let path = dir.path().join("s.xml");
        std::fs::write(&path, text).unwrap();
        load_scene_with_stats(&path).map(|(s, _)| s)
    };
    let constant = load_xml(&xml(
        r#"<emitter type="constant"><rgb name="radiance" value="0.5, 1, 2"/></emitter>"#,
    ))
    .unwrap();
    let env = constant.environment.as_ref().expect("an environment");
    assert_eq!(env.le(Vec3::Y), Vec3::new(0.5, 1.0, 2.0));
    assert!(constant.lights.is_empty() && constant.environment_power_share() == 1.0);

    let map = load_xml(&xml(
        r#"<emitter type="envmap"><string name="filename" value="sky.exr"/><float name="scale" value="3"/>
            <transform name="to_world"><rotate y="1" angle="90"/></transform></emitter>"#,
    ))
    .unwrap();
    let env = map.environment.as_ref().unwrap();
    // The map's −z (u = 0) turned by 90° about +y looks down −x in the world.
    let unturned = load_xml(&xml(
        r#"<emitter type="envmap"><string name="filename" value="sky.exr"/></emitter>"#,
    ))
    .unwrap();
    let base = unturned.environment.as_ref().unwrap();
    let d = Vec3::new(0.3, 0.5, -0.8).normalize();
    let turned = glam::Mat3::from_rotation_y(90f32.to_radians()) * d;
    assert!((env.le(turned) - 3.0 * base.le(d)).abs().max_element() < 1e-3 * base.le(d).max_element().max(1.0));

    let err = load_xml(&xml(
        r#"<emitter type="constant"/><emitter type="envmap"><string name="filename" value="sky.exr"/></emitter>"#,
    ))
    .err()
    .unwrap()
    .to_string();
    assert!(err.contains("second environment"), "{err}");
}

/// Photons from the environment: a disc of the scene's size facing each sampled direction.
/// Under a constant sky L a square of area A receives π L A on each side, so the photons'
/// first hits on it must carry 2π L A in total (in expectation; here within 1 %, 6 σ), for a
/// constant sky and for a map (whose flux onto the square we integrate by quadrature).
#[test]
fn environment_photons_carry_the_flux_the_sky_sends_onto_a_surface() {
    use photon_bench::photon::trace::trace_photon_path;
    use photon_bench::sampling::Rng;
    let dir = tempfile::tempdir().unwrap();
    let text = |env: &str| {
        format!(
            r#"[camera]
eye = [0, 3, 0.1]
look_at = [0, 0, 0]
fov_y = 40
resolution = [4, 4]
[materials.grey]
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
[[shapes]]
type = "quad"
material = "grey"
center = [0, 0, 0]
size = [2, 2]
facing = "+y"
{env}"#
        )
    };
    let scene = load_text(
        dir.path(),
        "env.toml",
        &text("[environment]\ntype = \"constant\"\nradiance = [1, 2, 3]"),
    )
    .unwrap();
    let n = 400_000u64;
    let flux = |scene: &Scene| {
        let mut sum = glam::DVec3::ZERO;
        for i in 0..n {
            let mut rng = Rng::for_task(11, [i, 0, 0]);
            trace_photon_path(scene, 0, n, &mut rng, |hit| {
                if hit.bounces == 0 {
                    sum += hit.power.as_dvec3();
                }
            });
        }
        sum
    };
    let got = flux(&scene);
    let expected = 2.0 * std::f64::consts::PI * 4.0 * glam::DVec3::new(1.0, 2.0, 3.0);
    let rel = ((got - expected) / expected).abs().max_element();
    assert!(rel < 0.01, "constant sky: {got} vs {expected}");

    write_sky(&dir.path().join("sky.exr"));
    let scene = load_text(
        dir.path(),
        "env.toml",
        &text("[environment]\ntype = \"envmap\"\nfile = \"sky.exr\""),
    )
    .unwrap();
    let env = scene.environment.as_ref().unwrap();
    // Flux onto both sides of the square: A ∫ L(ω) |cos θ| dω, by a fine (θ, φ) grid.
    let (nt, np) = (400usize, 800usize);
    let mut expected = glam::DVec3::ZERO;
    for i in 0..nt {
        let theta = (i as f64 + 0.5) / nt as f64 * std::f64::consts::PI;
        for j in 0..np {
            let phi = (j as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
            let w = glam::DVec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            let d_omega = theta.sin() * (std::f64::consts::PI / nt as f64) * (std::f64::consts::TAU / np as f64);
            expected += env.le(w.as_vec3()).as_dvec3() * (w.y.abs() * d_omega * 4.0);
        }
    }
    let got = flux(&scene);
    let rel = ((got - expected) / expected).abs().max_element();
    assert!(rel < 0.02, "map: {got} vs {expected}");
}

/// Every strategy that renders environment light agrees with `path` on a sphere on a floor
/// under a sky with a sun: the unbiased `photon_guided` and `ppg` within 4 standard errors of
/// the image mean, the consistent photon-density estimators within 5 %.
#[test]
fn strategies_that_render_the_environment_agree_with_path() {
    let dir = tempfile::tempdir().unwrap();
    write_sky(&dir.path().join("sky.exr"));
    let text = r#"[camera]
eye = [0, 1.5, 4]
look_at = [0, 0.3, 0]
fov_y = 45
resolution = [12, 9]
[materials.grey]
type = "diffuse"
reflectance = [0.6, 0.6, 0.6]
[[shapes]]
type = "quad"
material = "grey"
center = [0, 0, 0]
size = [6, 6]
facing = "+y"
[[shapes]]
type = "sphere"
material = "grey"
center = [0, 0.6, 0]
radius = 0.6
[environment]
type = "envmap"
file = "sky.exr"
"#;
    let scene = load_text(dir.path(), "env.toml", text).unwrap();
    let path = image_mean(&scene, "path", "max_depth = 4", 256);
    for (kind, params, spp) in [
        ("photon_guided", "max_depth = 4", 64),
        ("ppg", "max_depth = 4", 64),
        ("bdpt", "max_depth = 4", 64),
        ("light", "max_depth = 4", 64),
        ("vcm", "max_depth = 4\nmode = \"bpt\"", 64),
        ("mlt", "max_depth = 4", 4),
    ] {
        assert_agrees(kind, image_mean(&scene, kind, params, spp), path);
    }
    for (kind, params, spp) in [
        ("photon_map", "max_depth = 4", 4),
        ("ppm", "max_depth = 4", 64),
        ("sppm", "max_depth = 4", 64),
        ("vcm", "max_depth = 4", 64),
    ] {
        let (m, _) = image_mean(&scene, kind, params, spp);
        assert!((m / path.0 - 1.0).abs() < 0.05, "{kind}: {m} vs path {}", path.0);
    }
}
