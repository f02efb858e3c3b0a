//! Point, spot and directional lights (`[[lights]]`, Mitsuba's `point`, `spot`, `directional`):
//! the radiance of a diffuse floor under each against its closed form, photons carrying the
//! power each emits, the strategies that render them agreeing with `path` (glossy vertices
//! included), the others refusing the scene, Mitsuba's emitters imported with their defaults,
//! bad input refused naming the field.

mod agreement;

use agreement::{assert_agrees, assert_refused, floor_under, image_mean, load_text as load, render_image as render};
use glam::{Vec2, Vec3};
use photon_bench::light::delta::DeltaLight;
use photon_bench::scene::Scene;
use photon_bench::strategy::{self, Strategy};
use std::f32::consts::FRAC_1_PI;

/// The floor point each pixel centre sees.
fn floor_point(scene: &Scene, x: u32, y: u32) -> Vec3 {
    let ray = scene.camera.generate_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
    ray.o + ray.d * (-ray.o.y / ray.d.y)
}

/// The expected value at a floor point and the tolerance there (`None`: not checked).
type Expected = dyn Fn(Vec3) -> Option<(f32, f32)>;

/// A diffuse floor under a point light reflects ρ/π · I cos θ / r² and a spot ρ/π · I f(θ)
/// cos θ / r², with Mitsuba's linear falloff f; directional light ρ/π · E cos θ everywhere.
/// With nothing else in the scene there is no indirect light, next-event estimation toward one
/// delta light has no variance at a point, and the pixel mean differs from the pixel-centre
/// value only by the footprint's curvature (< 0.2 % here) and the jitter's noise — except
/// where a spot's falloff has a kink inside the pixel, which is left out.
#[test]
fn a_diffuse_floor_reflects_what_each_delta_light_sends_it() {
    let dir = tempfile::tempdir().unwrap();
    let (rho, i0, h) = (0.5f32, 6.0f32, 1.5f32);
    let (cutoff, beam) = (30f32.to_radians(), 18f32.to_radians());
    let cases: [(&str, Box<Expected>); 3] = [
        (
            "type = \"point\"\nposition = [0.2, 1.5, -0.1]\nintensity = [6, 3, 1.5]",
            Box::new(move |p: Vec3| {
                let d = Vec3::new(0.2, h, -0.1) - p;
                let cos = d.y / d.length();
                Some((rho * FRAC_1_PI * i0 * cos / d.length_squared(), 0.005))
            }),
        ),
        (
            "type = \"spot\"\nposition = [0, 1.5, 0]\ntarget = [0.3, 0, 0]\nintensity = [6, 3, 1.5]\n\
             cutoff_angle = 30\nbeam_width = 18",
            Box::new(move |p: Vec3| {
                let d = p - Vec3::new(0.0, h, 0.0);
                let axis = Vec3::new(0.3, -h, 0.0).normalize();
                let theta = axis.dot(d.normalize()).clamp(-1.0, 1.0).acos();
                // The pixel footprint spans about 0.06 rad of θ here: skip pixels at the kinks.
                if (theta - cutoff).abs() < 0.07 || (theta - beam).abs() < 0.07 {
                    return None;
                }
                // In the ramp the value changes by up to ±30 % across a pixel, so the jittered
                // pixel samples have a standard deviation of about 0.3 / √(3 · 4096) = 0.3 %.
                let (falloff, tolerance) = if theta >= cutoff {
                    (0.0, 0.005)
                } else if theta <= beam {
                    (1.0, 0.005)
                } else {
                    ((cutoff - theta) / (cutoff - beam), 0.02)
                };
                let cos = -d.y / d.length();
                Some((rho * FRAC_1_PI * i0 * falloff * cos / d.length_squared(), tolerance))
            }),
        ),
        (
            "type = \"directional\"\ndirection = [0.5, -1, 0.25]\nirradiance = [6, 3, 1.5]",
            Box::new(move |_| Some((rho * FRAC_1_PI * i0 / Vec3::new(0.5, -1.0, 0.25).length(), 1e-5))),
        ),
    ];
    for (light, expected) in cases {
        let scene = load(dir.path(), "floor.toml", &floor_under(light)).unwrap();
        for selection in ["power", "local", "uniform"] {
            let img = render(
                &scene,
                "path",
                &format!("max_depth = 3\nlight_selection = \"{selection}\""),
                4096,
                1,
            );
            let mut checked = 0;
            for y in 0..scene.camera.height {
                for x in 0..scene.camera.width {
                    let Some((want, tolerance)) = expected(floor_point(&scene, x, y)) else {
                        continue;
                    };
                    let got = img.get(x, y);
                    // The colour ratios of the light carry through.
                    let want = Vec3::new(want, want / 2.0, want / 4.0);
                    let err = ((got - want).abs() / want.max_element().max(1e-3)).max_element();
                    assert!(
                        err < tolerance,
                        "{light} ({selection}), pixel ({x}, {y}): {got} vs {want}"
                    );
                    checked += 1;
                }
            }
            assert!(checked > 300, "{light}: only {checked} pixels checked");
        }
    }
}

/// Photons from a delta light carry its power: the first hits of the photons on a floor that
/// takes all of a downward spot's light (and of a directional light's, whose photons come from
/// a disc of the scene's size) sum to what the light sends onto it — the spot's whole power
/// 2π I (1 − (sin θc − sin θb)/(θc − θb)), and E A cos θ from the sun.
#[test]
fn delta_light_photons_carry_the_power_they_deliver() {
    use photon_bench::photon::trace::trace_photon_path;
    use photon_bench::sampling::Rng;
    let dir = tempfile::tempdir().unwrap();
    let flux = |scene: &Scene| {
        let n = 200_000u64;
        let mut sum = glam::DVec3::ZERO;
        for i in 0..n {
            let mut rng = Rng::for_task(5, [i, 0, 0]);
            trace_photon_path(scene, 0, n, &mut rng, |hit| {
                if hit.bounces == 0 {
                    sum += hit.power.as_dvec3();
                }
            });
        }
        sum.x
    };
    let spot = load(
        dir.path(),
        "spot.toml",
        &floor_under(
            "type = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = [6, 3, 1.5]\n\
             cutoff_angle = 40\nbeam_width = 10",
        ),
    )
    .unwrap();
    let (c, b) = (40f64.to_radians(), 10f64.to_radians());
    let expected = std::f64::consts::TAU * 6.0 * (1.0 - (c.sin() - b.sin()) / (c - b));
    let got = flux(&spot);
    assert!((got / expected - 1.0).abs() < 0.01, "spot: {got} vs {expected}");

    let sun = load(
        dir.path(),
        "sun.toml",
        &floor_under("type = \"directional\"\ndirection = [0.6, -0.8, 0]\nirradiance = [6, 3, 1.5]"),
    )
    .unwrap();
    let expected = 6.0 * 36.0 * 0.8;
    let got = flux(&sun);
    assert!((got / expected - 1.0).abs() < 0.01, "sun: {got} vs {expected}");
}

/// A closed room lit by a point light and a spot only, with a rough metal sphere (glossy
/// vertices, where gather rays and photon-mapping eye paths must sample the delta lights they
/// cannot hit): the unbiased strategies (light sub-paths from the point and the spot included:
/// `light`, `bdpt`) agree with `path` within 4 standard errors of the image mean; `photon_map`
/// and `vcm` within 5 %; `ppm` and `sppm`, whose radius bias after 16 passes is
/// still −5 % here (−3.4 % after 128), within 8 %. The depth is 64 for all: the photon-mapping
/// strategies add the eye path's bounces to the photons', so at a depth of 8 they would carry
/// light `path` cuts off (6 % of this white room's).
#[test]
fn strategies_that_render_delta_lights_agree_with_path() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(dir.path(), "room.toml", ROOM).unwrap();
    let path = image_mean(&scene, "path", "max_depth = 64", 256);
    for (kind, params, spp) in [
        ("path", "max_depth = 64\nlight_selection = \"local\"", 256),
        ("path", "max_depth = 64\nlight_selection = \"uniform\"", 256),
        ("photon_guided", "max_depth = 64", 64),
        ("ppg", "max_depth = 64", 64),
        ("bdpt", "max_depth = 64", 16),
        ("light", "max_depth = 64", 16),
        ("mlt", "max_depth = 64\nchains = 1024", 4),
    ] {
        assert_agrees(kind, image_mean(&scene, kind, params, spp), path);
    }
    for (kind, params, spp, tolerance) in [
        ("photon_map", "max_depth = 64", 4, 0.05),
        ("vcm", "max_depth = 64", 16, 0.05),
        ("ppm", "max_depth = 64\ndirect = \"photons\"", 16, 0.08),
        ("sppm", "max_depth = 64", 16, 0.08),
    ] {
        let (m, _) = image_mean(&scene, kind, params, spp);
        assert!((m / path.0 - 1.0).abs() < tolerance, "{kind}: {m} vs path {}", path.0);
    }
}

/// Directional light in path space (x₀ a direction, x₁ through the disc around the scene, the
/// eye side never reaching x₀): under a sun a diffuse floor that fills the image has the one
/// value ρ/π · E cos θ, which `light` (particles from the disc), `bdpt` and `vcm` reproduce
/// within 4 standard errors over 6 seeds (plus 1 % for `vcm`'s merging); then, with a rough
/// gold sphere casting a shadow and reflecting the sun onto the floor, they agree with `path`.
#[test]
fn path_space_strategies_render_directional_light() {
    let dir = tempfile::tempdir().unwrap();
    let direction = Vec3::new(0.5, -1.0, 0.25);
    let sun = "type = \"directional\"\ndirection = [0.5, -1, 0.25]\nirradiance = [6, 3, 1.5]";
    let floor = load(dir.path(), "floor.toml", &floor_under(sun)).unwrap();
    let expected = f64::from(0.5 * FRAC_1_PI * 10.5 / direction.length());
    for (kind, spp, slack) in [("light", 64, 0.0), ("bdpt", 4, 0.0), ("vcm", 4, 0.01)] {
        let (m, se) = image_mean(&floor, kind, "max_depth = 3", spp);
        assert!(se < 0.01 * expected, "{kind}: too noisy to judge ({m} ± {se})");
        assert!(
            (m - expected).abs() < 4.0 * se + slack * expected,
            "{kind}: {m} ± {se}, expected {expected}"
        );
    }
    let with_sphere = floor_under(sun).replace(
        "[[lights]]",
        "[materials.gold]\ntype = \"rough_conductor\"\nmaterial = \"Au\"\nalpha = 0.2\n\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"gold\"\ncenter = [0.3, 0.5, 0]\nradius = 0.5\n\n[[lights]]",
    );
    let scene = load(dir.path(), "sphere.toml", &with_sphere).unwrap();
    let path = image_mean(&scene, "path", "max_depth = 8", 256);
    for (kind, spp) in [("light", 16), ("bdpt", 16)] {
        assert_agrees(kind, image_mean(&scene, kind, "max_depth = 8", spp), path);
    }
    let (m, _) = image_mean(&scene, "vcm", "max_depth = 8", 16);
    assert!((m / path.0 - 1.0).abs() < 0.05, "vcm: {m} vs path {}", path.0);
}

const ROOM: &str = r#"[camera]
eye = [0, 0.9, 2.6]
look_at = [0, 0.5, 0]
fov_y = 55
resolution = [12, 9]

[materials.white]
type = "diffuse"
reflectance = [0.7, 0.7, 0.7]
[materials.metal]
type = "rough_conductor"
material = "Au"
alpha = 0.2

[[shapes]]
type = "box"
material = "white"
min = [-1, 0, -1]
max = [1, 2, 3]
[[shapes]]
type = "sphere"
material = "metal"
center = [0.2, 0.4, 0]
radius = 0.4

[[lights]]
type = "point"
position = [-0.5, 1.6, 0.5]
intensity = [2, 2, 2]
[[lights]]
type = "spot"
position = [0.6, 1.8, 1.5]
target = [0.2, 0.4, 0]
intensity = [6, 5, 4]
cutoff_angle = 25
"#;

/// Each strategy either renders a scene's point and spot lights (`ROOM`) and directional light
/// (a floor under the sun) or refuses the scene with one line naming itself and the light.
#[test]
fn strategies_that_cannot_reach_delta_lights_refuse_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let room = load(dir.path(), "room.toml", ROOM).unwrap();
    let sun = load(
        dir.path(),
        "sun.toml",
        &floor_under("type = \"directional\"\ndirection = [0, -1, 0]\nirradiance = [1, 1, 1]"),
    )
    .unwrap();
    let eye_paths = ["path", "ppg", "photon_guided", "photon_map", "ppm", "sppm"];
    for (scene, able, what) in [
        (
            &room,
            [&eye_paths[..], &["light", "bdpt", "vcm", "mlt", "mps"]].concat(),
            "point, spot or projector",
        ),
        (
            &sun,
            [&eye_paths[..], &["light", "bdpt", "vcm", "mlt", "mps"]].concat(),
            "directional",
        ),
    ] {
        for kind in strategy::kinds() {
            let s: Box<dyn Strategy> = strategy::build(kind, toml::Table::new()).unwrap();
            match strategy::check_scene(&*s, scene) {
                Ok(()) => assert!(able.contains(&kind), "{kind} accepted {what} lights it does not render"),
                Err(e) => {
                    let e = e.to_string();
                    assert!(!able.contains(&kind), "{kind}: {e}");
                    assert!(
                        e.lines().count() == 1 && e.contains(&format!("`{kind}`")) && e.contains(what),
                        "{e}"
                    );
                }
            }
        }
    }
    // A path tracer that finds light only by hitting it cannot see a point light.
    let bsdf_only = strategy::build("path", toml::from_str("direct = \"bsdf\"").unwrap()).unwrap();
    let e = strategy::check_scene(&*bsdf_only, &room).unwrap_err().to_string();
    assert!(e.contains("`path`") && e.contains("point, spot or projector"), "{e}");
}

#[test]
fn bad_delta_lights_are_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let refused = |light: &str, expect: &[&str]| {
        let err = load(dir.path(), "bad.toml", &floor_under(light))
            .err()
            .expect("refused")
            .to_string();
        assert_refused(&err, expect);
    };
    refused(
        "type = \"point\"\nposition = [0, 1, 0]\nintensity = [1, -1, 1]",
        &["lights[0].intensity", "[0, "],
    );
    refused(
        "type = \"point\"\nposition = [0, nan, 0]\nintensity = [1, 1, 1]",
        &["lights[0].position"],
    );
    refused(
        "type = \"directional\"\ndirection = [0, 0, 0]\nirradiance = [1, 1, 1]",
        &["lights[0].direction", "non-zero"],
    );
    refused(
        "type = \"spot\"\nposition = [0, 1, 0]\nintensity = [1, 1, 1]",
        &["lights[0].target", "exactly one"],
    );
    refused(
        "type = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = [1, 1, 1]\ncutoff_angle = 10\nbeam_width = 20",
        &["lights[0].beam_width", "cutoff_angle = 10"],
    );
    refused(
        "type = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = [1, 1, 1]\ncutoff_angle = 0",
        &["lights[0].cutoff_angle"],
    );
    refused("type = \"area\"\nposition = [0, 1, 0]", &["lights", "area"]);
    refused(
        "type = \"point\"\nposition = [0, 1, 0]\nintensity = [1, 1, 1]\ncolour = 2",
        &["colour"],
    );
}

/// Mitsuba's `point`, `spot` and `directional` emitters, by `position`/`direction` or by
/// `to_world`, with Mitsuba's defaults (intensity 1, cutoff 20°, beam ¾ of it); a delta light
/// alone lights a scene; contradictory or unsupported settings are refused with one line.
#[test]
fn mitsuba_delta_emitters_are_imported() {
    let dir = tempfile::tempdir().unwrap();
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
    let load_xml = |emitters: &str| load(dir.path(), "s.xml", &xml(emitters));
    let scene = load_xml(
        r#"<emitter type="point"><point name="position" x="1" y="2" z="3"/><rgb name="intensity" value="4, 5, 6"/></emitter>
        <emitter type="point"><transform name="to_world"><translate x="-1"/></transform></emitter>
        <emitter type="spot"><transform name="to_world"><lookat origin="0, 3, 0" target="0, 0, 0" up="1, 0, 0"/></transform>
            <float name="cutoff_angle" value="40"/></emitter>
        <emitter type="directional"><vector name="direction" value="0, -2, 0"/><rgb name="irradiance" value="2, 2, 2"/></emitter>
        <emitter type="directional"><transform name="to_world"><rotate x="1" angle="90"/></transform></emitter>"#,
    )
    .unwrap();
    assert!(scene.lights.is_empty());
    let d = &scene.delta_lights;
    assert_eq!(d.len(), 5);
    assert_eq!(
        d[0],
        DeltaLight::Point {
            position: Vec3::new(1.0, 2.0, 3.0),
            intensity: Vec3::new(4.0, 5.0, 6.0)
        }
    );
    assert_eq!(
        d[1],
        DeltaLight::Point {
            position: Vec3::new(-1.0, 0.0, 0.0),
            intensity: Vec3::ONE
        }
    );
    let DeltaLight::Spot(spot) = &d[2] else {
        panic!("{:?}", d[2])
    };
    assert_eq!(spot.position, Vec3::new(0.0, 3.0, 0.0));
    assert!((spot.axis - Vec3::NEG_Y).length() < 1e-6);
    // Default beam: ¾ of the 40° cutoff; full intensity inside 30°, none beyond 40°.
    let dir_at = |deg: f32| Vec3::new(deg.to_radians().sin(), -deg.to_radians().cos(), 0.0);
    assert_eq!(spot.falloff(dir_at(29.0)), 1.0);
    assert!((spot.falloff(dir_at(35.0)) - 0.5).abs() < 1e-3);
    assert_eq!(spot.falloff(dir_at(41.0)), 0.0);
    assert_eq!(
        d[3],
        DeltaLight::Directional {
            direction: Vec3::NEG_Y,
            irradiance: Vec3::splat(2.0)
        }
    );
    // +z turned 90° about +x points down −y.
    let DeltaLight::Directional { direction, irradiance } = d[4] else {
        panic!()
    };
    assert!((direction - Vec3::NEG_Y).length() < 1e-6 && irradiance == Vec3::ONE);

    let refused = |emitter: &str, expect: &str| {
        let e = load_xml(emitter).err().expect("refused").to_string();
        assert!(e.lines().count() == 1 && e.contains(expect), "{e}");
    };
    refused(
        r#"<emitter type="point"><point name="position" value="0, 1, 0"/><transform name="to_world"><translate x="1"/></transform></emitter>"#,
        "either `position` or `to_world`",
    );
    refused(
        r#"<emitter type="spot"><transform name="to_world"><scale x="2"/></transform></emitter>"#,
        "uniform scale",
    );
    // A projected picture is read (tests/spot_texture.rs), but not through a mirroring frame.
    refused(
        r#"<emitter type="spot"><transform name="to_world"><scale x="-1"/></transform><texture type="checkerboard" name="texture"/></emitter>"#,
        "must not mirror",
    );
    refused(r#"<emitter type="directionalarea"/>"#, "unsupported emitter");
}

/// Light that reaches the floor only off a rough metal reflector (an occluder hides the point
/// light from the floor), seen on the floor and in the reflector itself: every path is
/// L G D E or L G E. Gather rays (`photon_map`) and photon-mapping eye paths with photon direct
/// light (`ppm`) reach the light only by sampling it at the glossy vertex, so without that
/// the image is the floor's photons alone; with it each agrees with `path`.
#[test]
fn light_reflected_by_a_glossy_surface_is_found_by_every_strategy() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(dir.path(), "reflector.toml", REFLECTOR).unwrap();
    let path = image_mean(&scene, "path", "max_depth = 8", 256);
    for (kind, params, spp) in [
        ("photon_guided", "max_depth = 8", 64),
        ("ppg", "max_depth = 8", 64),
        ("bdpt", "max_depth = 8", 16),
        ("light", "max_depth = 8", 16),
    ] {
        assert_agrees(kind, image_mean(&scene, kind, params, spp), path);
    }
    for (kind, params, spp) in [
        ("photon_map", "max_depth = 8", 4),
        ("ppm", "max_depth = 8\ndirect = \"photons\"", 16),
        ("sppm", "max_depth = 8", 16),
    ] {
        let (m, _) = image_mean(&scene, kind, params, spp);
        assert!((m / path.0 - 1.0).abs() < 0.05, "{kind}: {m} vs path {}", path.0);
    }
}

const REFLECTOR: &str = r#"[camera]
eye = [0, 0.5, 3.5]
look_at = [0, 0.6, 0]
fov_y = 50
resolution = [12, 9]

[materials.white]
type = "diffuse"
reflectance = [0.6, 0.6, 0.6]
[materials.black]
type = "diffuse"
reflectance = [0, 0, 0]
[materials.metal]
type = "rough_conductor"
material = "Al"
alpha = 0.15

[[shapes]]
type = "quad"
material = "white"
center = [0, 0, 0]
size = [4, 4]
facing = "+y"
[[shapes]]
type = "quad"
material = "black"
center = [0, 0.8, 0]
size = [1, 1]
facing = "-y"
[[shapes]]
type = "quad"
material = "metal"
center = [0, 1.5, 0]
size = [3, 3]
facing = "-y"

[[lights]]
type = "point"
position = [0, 1, 0]
intensity = [5, 5, 5]
"#;
