//! pbrt-v4's layered models (TOML `type = "coated"`, pbrt's `coateddiffuse` and
//! `coatedconductor`): a coating over a diffuse or conductor base, evaluated by random walks.
//! Every strategy that renders them renders them as `path` does (their densities are only
//! estimated, so the Metropolis strategies refuse them in one line); pbrt's parameters map to
//! ours; images are bit-identical on any number of threads.

mod agreement;

use agreement::{assert_agrees, assert_refused, block_means, image_mean, judge_blocks, load_text as load};
use photon_bench::bsdf::{Bsdf, Coat};
use photon_bench::scene::Scene;

/// A coated ball and a coated gold block on a grey floor, under a constant sky and a small
/// area light.
fn scene(ball: &str, block: &str) -> String {
    format!(
        r#"[camera]
eye = [0, 0.9, 2.6]
look_at = [0, 0.45, 0]
fov_y = 40
resolution = [12, 9]

[environment]
type = "constant"
radiance = [0.4, 0.45, 0.5]

[materials.floor]
type = "diffuse"
reflectance = [0.3, 0.3, 0.3]
[materials.ball]
{ball}
[materials.block]
{block}
[materials.lamp]
type = "diffuse"
reflectance = [0, 0, 0]

[[shapes]]
type = "quad"
material = "floor"
center = [0, 0, 0]
size = [8, 8]
facing = "+y"
[[shapes]]
type = "sphere"
material = "ball"
center = [-0.3, 0.4, 0]
radius = 0.4
[[shapes]]
type = "box"
material = "block"
center = [0.55, 0.25, -0.2]
size = [0.5, 0.5, 0.5]
[[shapes]]
type = "quad"
material = "lamp"
center = [0.8, 2, 0.8]
size = [0.5, 0.5]
facing = "-y"
emission = {{ radiance = [10, 10, 10] }}
"#
    )
}

/// A smooth coating over a checkered diffuse base (a delta lobe beside the walks) and a rough
/// coating over rough gold with a scattering slab.
const SMOOTH_DIFFUSE: &str = r#"type = "coated"
thickness = 0.05
base = { type = "diffuse", reflectance = { type = "checkerboard", color0 = [0.7, 0.2, 0.1], color1 = [0.1, 0.3, 0.6], to_uv = { scale = [4, 2] } } }"#;
const ROUGH_GOLD: &str = r#"type = "coated"
alpha = 0.2
albedo = [0.6, 0.6, 0.6]
g = 0.3
thickness = 0.3
base = { type = "rough_conductor", material = "Au", distribution = "ggx", alpha = 0.3 }"#;

fn coated_scene() -> Scene {
    let dir = tempfile::tempdir().unwrap();
    load(dir.path(), "coated.toml", &scene(SMOOTH_DIFFUSE, ROUGH_GOLD)).unwrap()
}

/// `bdpt` and `vcm` agree with `path` block by block (4 standard errors; 1 % more for `vcm`'s
/// merging), `light`, `photon_guided` and `ppg` by the image mean (4 standard errors),
/// `photon_map` within 5 % of it (final gathers on photon maps: biased, consistent).
#[test]
fn every_strategy_that_takes_layered_models_renders_them_as_path() {
    let scene = coated_scene();
    let params = "max_depth = 8";
    let reference = block_means(&scene, "path", params, 512);
    for (kind, spp, slack) in [("bdpt", 64, 0.0), ("vcm", 64, 0.01)] {
        judge_blocks(&scene, &reference, (kind, params, spp, slack), |_| false);
    }
    let path = image_mean(&scene, "path", params, 512);
    for (kind, spp, extra) in [
        ("photon_guided", 64, ""),
        ("ppg", 64, "combine = \"last\""),
        ("light", 256, ""),
    ] {
        assert_agrees(kind, image_mean(&scene, kind, &format!("{params}\n{extra}"), spp), path);
    }
    let (m, _) = image_mean(&scene, "photon_map", params, 4);
    assert!((m / path.0 - 1.0).abs() < 0.05, "photon_map: {m} vs path {}", path.0);
}

/// Metropolis proposals need the true density of the directions they draw, which a layered
/// model only estimates: `mlt` and `mps` refuse the scene, naming the material and the
/// strategies that take it.
#[test]
fn metropolis_strategies_refuse_layered_models() {
    let scene = coated_scene();
    for kind in ["mlt", "mps"] {
        let s = photon_bench::strategy::build(kind, toml::Table::new()).unwrap();
        let err = photon_bench::strategy::check_scene(&*s, &scene)
            .unwrap_err()
            .to_string();
        assert_refused(&err, &[kind, "\"ball\"", "random walks", "path", "bdpt"]);
    }
}

#[test]
fn layered_images_are_bit_identical_for_any_thread_count() {
    let scene = coated_scene();
    for kind in ["path", "bdpt", "photon_map"] {
        agreement::assert_bit_identical_across_threads(&scene, kind, 3);
    }
}

/// pbrt-v4's `coateddiffuse` and `coatedconductor` with pbrt's defaults and names: roughness
/// remapped (α = √r), the conductor's η and k divided by the coating's η, smooth layers where
/// the roughness is 0; bad values and a texture in a slab refused in one line.
#[test]
fn pbrt_coated_materials_map_to_ours() {
    let dir = tempfile::tempdir().unwrap();
    let load_pbrt = |material: &str| {
        let text = format!(
            "LookAt 0 1 4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 50\n\
             Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 6\nWorldBegin\n\
             LightSource \"point\" \"rgb I\" [1 1 1] \"point3 from\" [0 2 0]\n{material}\nShape \"sphere\" \"float radius\" 0.3\n"
        );
        load(dir.path(), "c.pbrt", &text)
    };
    let last = |s: &Scene| s.materials[s.attrs.last().unwrap().material as usize].bsdf.clone();
    let Bsdf::Coated(c) = last(&load_pbrt("Material \"coateddiffuse\"").unwrap()) else {
        panic!()
    };
    assert!(matches!(&c.coat, Coat::Smooth(d) if d.ior == 1.5));
    assert!(matches!(&c.base, Bsdf::Lambertian(l) if l.reflectance == glam::Vec3::splat(0.5)));
    assert_eq!((c.thickness, c.max_depth, c.n_samples, c.g), (0.01, 10, 1, 0.0));
    let Bsdf::Coated(c) = last(
        &load_pbrt(
            "Material \"coateddiffuse\" \"float roughness\" 0.04 \"rgb reflectance\" [0.4 0.2 0.2] \
             \"float eta\" 1.3 \"integer maxdepth\" 20 \"rgb albedo\" [0.5 0.5 0.5] \"float g\" -0.2",
        )
        .unwrap(),
    ) else {
        panic!()
    };
    let Coat::Rough(d) = &c.coat else {
        panic!("{:?}", c.coat)
    };
    assert!((d.distribution.alpha_u - 0.2).abs() < 1e-6 && (d.ior - 1.3).abs() < 1e-6);
    assert!(d.distribution.height_correlated, "pbrt-v4's masking");
    assert_eq!((c.max_depth, c.albedo.x, c.g), (20, 0.5, -0.2));
    let Bsdf::Coated(c) = last(
        &load_pbrt(
            "Material \"coatedconductor\" \"float interface.eta\" 1.6 \"float conductor.roughness\" 0.09 \
             \"spectrum conductor.eta\" \"metal-Au-eta\" \"spectrum conductor.k\" \"metal-Au-k\"",
        )
        .unwrap(),
    ) else {
        panic!()
    };
    let gold = photon_bench::bsdf::ConductorIor::named("Au").unwrap();
    let Bsdf::RoughConductor(base) = &c.base else {
        panic!("{:?}", c.base)
    };
    assert!((base.ior.eta * 1.6 - gold.eta).length() < 1e-5 && (base.ior.k * 1.6 - gold.k).length() < 1e-5);
    assert!((base.distribution.alpha_u - 0.3).abs() < 1e-6);
    assert!(matches!(c.coat, Coat::Smooth(_)));
    for (material, expect) in [
        (
            "Material \"coateddiffuse\" \"float g\" 1",
            &["line 6", "g", "(−1, 1)"][..],
        ),
        (
            "Material \"coateddiffuse\" \"integer maxdepth\" 0",
            &["line 6", "maxdepth", "[1, 100]"],
        ),
        (
            "Material \"coatedconductor\" \"float conductor.rughness\" 0.1",
            &["line 6", "conductor.rughness"],
        ),
        (
            "Texture \"t\" \"spectrum\" \"checkerboard\"\nMaterial \"coateddiffuse\" \"texture albedo\" \"t\"",
            &["line 7", "albedo", "texture"],
        ),
    ] {
        let err = load_pbrt(material).err().expect(material).to_string();
        assert_refused(&err, expect);
    }
}

/// The TOML model refuses what it cannot build, naming the field.
#[test]
fn bad_coated_materials_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (block, expect) in [
        (
            "type = \"coated\"\nbase = { type = \"dielectric\", ior = 1.5 }",
            &["materials.block.base", "diffuse, conductor or rough_conductor"][..],
        ),
        (
            "type = \"coated\"\nweights = \"fast\"\nbase = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }",
            &["materials.block.weights", "\"exact\" or \"pbrt\""],
        ),
        (
            "type = \"coated\"\nalbedo = [0.5, 0.5, 0.5]\nbase = { type = \"conductor\", material = \"Au\" }",
            &["materials.block", "scattering slab"],
        ),
        (
            "type = \"coated\"\nbase = { type = \"rough_conductor\", alpha = { type = \"checkerboard\" } }",
            &["materials.block.base", "roughness"],
        ),
    ] {
        let err = load(dir.path(), "bad.toml", &scene(SMOOTH_DIFFUSE, block))
            .err()
            .expect(block)
            .to_string();
        assert_refused(&err, expect);
    }
}
