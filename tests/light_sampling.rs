//! Next-event estimation with every light sampling option (`light_selection` power | local,
//! `sphere_light_sampling` area | cone) against an exact answer.
//!
//! The scene: a thin, diffusely reflecting and transmitting sheet (y = 0) under a one-sided
//! quad light and two sphere lights, with a third sphere light below it, all out of the
//! camera's view and entirely above (or below) the sheet's horizon. With one scattering event
//! (`max_depth = 1`) a camera path sees only direct light, which is known in closed form at
//! every point: L = R/π (E_quad + E_a + E_b) + T/π E_c, with E = π Le r² cos θ / d² for a
//! sphere and Lambert's formula for the quad. The MIS weight of a BSDF-sampled ray that hits a
//! light must use the density light sampling had at that vertex: the wrong pmf or the wrong
//! sphere density there breaks the agreement (see docs/path.md for the seeded bugs it caught).

use glam::{DVec3, Vec2, Vec3};
use photon_bench::light::{LightSelection, SphereSampling};
use photon_bench::sampling::Rng;
use photon_bench::scene::Scene;
use photon_bench::scene::load::load_scene_bytes;
use photon_bench::strategy::path::{Direct, PathParams, radiance};

const SCENE: &str = r#"
[camera]
eye = [0.0, 1.0, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0, 0, 1]
fov_y = 60.0
resolution = [16, 16]

[materials.paper]
type = "diffuse_transmission"
reflectance = [0.5, 0.5, 0.5]
transmittance = [0.3, 0.3, 0.3]

[materials.black]
type = "diffuse"
reflectance = [0, 0, 0]

[[shapes]]
type = "quad"
material = "paper"
center = [0.0, 0.0, 0.0]
size = [4.0, 4.0]
facing = "+y"

[[shapes]]
type = "quad"
material = "black"
center = [0.3, 2.0, -0.2]
size = [1.0, 1.0]
facing = "-y"
emission = { radiance = [3, 3, 3] }

[[shapes]]
type = "sphere"
material = "black"
center = [0.8, 0.3, 0.0]
radius = 0.1
emission = { radiance = [50, 50, 50] }

[[shapes]]
type = "sphere"
material = "black"
center = [-0.9, 0.15, 0.3]
radius = 0.05
emission = { radiance = [400, 400, 400] }

[[shapes]]
type = "sphere"
material = "black"
center = [0.2, -0.4, -0.3]
radius = 0.08
emission = { radiance = [30, 30, 30] }
"#;

const R: f64 = 0.5;
const T: f64 = 0.3;

fn scene() -> Scene {
    let (scene, _) = load_scene_bytes(std::path::Path::new("sheet.toml"), SCENE.as_bytes()).unwrap();
    assert_eq!(scene.lights.len(), 5, "two quad triangles and three spheres");
    scene
}

/// E = π Le r² |cos θ| / d² from a sphere wholly on one side of the receiver's plane.
fn sphere_irradiance(x: DVec3, n: DVec3, center: DVec3, radius: f64, le: f64) -> f64 {
    let to = center - x;
    let d2 = to.length_squared();
    std::f64::consts::PI * le * radius * radius * n.dot(to / d2.sqrt()).abs() / d2
}

/// Lambert's formula: E = Le/2 |Σ Θᵢ n · (vᵢ × vᵢ₊₁) / |vᵢ × vᵢ₊₁||, vᵢ the unit vectors to the
/// vertices of a polygon wholly above the horizon [Arvo 1995, "Applications of Irradiance
/// Tensors"].
fn polygon_irradiance(x: DVec3, n: DVec3, poly: &[DVec3], le: f64) -> f64 {
    let v: Vec<DVec3> = poly.iter().map(|p| (*p - x).normalize()).collect();
    let sum: f64 = (0..v.len())
        .map(|i| {
            let (a, b) = (v[i], v[(i + 1) % v.len()]);
            a.dot(b).clamp(-1.0, 1.0).acos() * n.dot(a.cross(b).normalize())
        })
        .sum();
    0.5 * le * sum.abs()
}

/// Exact radiance leaving the sheet upwards at `x`.
fn exact(x: Vec3) -> f64 {
    let x = x.as_dvec3();
    let n = DVec3::Y;
    let (cx, cz) = (0.3, -0.2);
    let quad = [
        DVec3::new(cx - 0.5, 2.0, cz - 0.5),
        DVec3::new(cx + 0.5, 2.0, cz - 0.5),
        DVec3::new(cx + 0.5, 2.0, cz + 0.5),
        DVec3::new(cx - 0.5, 2.0, cz + 0.5),
    ];
    let above = polygon_irradiance(x, n, &quad, 3.0)
        + sphere_irradiance(x, n, DVec3::new(0.8, 0.3, 0.0), 0.1, 50.0)
        + sphere_irradiance(x, n, DVec3::new(-0.9, 0.15, 0.3), 0.05, 400.0);
    let below = sphere_irradiance(x, n, DVec3::new(0.2, -0.4, -0.3), 0.08, 30.0);
    (R * above + T * below) / std::f64::consts::PI
}

/// Mean and standard error of (estimate − exact) over `n` camera samples, the mean exact
/// radiance, and the variance of one sample.
fn error_of(scene: &Scene, params: &PathParams, n: u64) -> (f64, f64, f64, f64) {
    let cam = &scene.camera;
    let (mut s1, mut s2, mut exact_sum, mut est2) = (0f64, 0f64, 0f64, 0f64);
    for i in 0..n {
        let mut rng = Rng::for_task(31, [i, 0, 0]);
        let raster = Vec2::new(cam.width as f32, cam.height as f32) * rng.uniform2();
        let ray = cam.generate_ray(raster);
        let hit = scene.intersect(&ray).expect("the camera sees only the sheet");
        let want = exact(hit.p);
        let got = radiance(scene, params, ray, &mut rng).x as f64;
        let d = got - want;
        s1 += d;
        s2 += d * d;
        exact_sum += want;
        est2 += got * got;
    }
    let nf = n as f64;
    let mean = s1 / nf;
    let var = s2 / nf - mean * mean;
    let mean_exact = exact_sum / nf;
    (
        mean,
        (var / nf).sqrt(),
        mean_exact,
        est2 / nf - (mean + mean_exact).powi(2),
    )
}

fn params(direct: Direct, light_selection: LightSelection, sphere_light_sampling: SphereSampling) -> PathParams {
    PathParams {
        max_depth: 1,
        direct,
        light_selection,
        sphere_light_sampling,
        ..PathParams::default()
    }
}

/// Every option, with MIS and with light sampling alone, reproduces the exact direct light
/// within 4.5 standard errors, each standard error below 1 % of the answer.
#[test]
fn direct_light_is_exact_for_every_light_sampling_option() {
    let scene = scene();
    let mut variances = Vec::new();
    for direct in [Direct::Mis, Direct::Nee] {
        for selection in [LightSelection::Power, LightSelection::Local] {
            for sphere in [SphereSampling::Area, SphereSampling::Cone] {
                let (mean, se, want, var) = error_of(&scene, &params(direct, selection, sphere), 500_000);
                let z = mean.abs() / se;
                eprintln!(
                    "{direct:?} {selection:?} {sphere:?}: error {mean:.5} ± {se:.5} of {want:.4} (z = {z:.1}), variance {var:.4}"
                );
                assert!(
                    se < 0.01 * want,
                    "{direct:?} {selection:?} {sphere:?}: imprecise, {se} of {want}"
                );
                assert!(
                    z < 4.5,
                    "{direct:?} {selection:?} {sphere:?}: biased, {mean} ± {se} of {want} (z = {z:.1})"
                );
                variances.push(((direct, selection, sphere), var));
            }
        }
    }
    // Here, next to small bright spheres, local selection with cone sampling must beat power
    // selection with area sampling clearly (with MIS: the first and the fourth entries).
    let (power_area, local_cone) = (variances[0].1, variances[3].1);
    assert!(
        power_area > 2.0 * local_cone,
        "variance power/area {power_area} vs local/cone {local_cone}"
    );
}
