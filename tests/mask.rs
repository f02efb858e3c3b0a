//! Opacity masks (TOML `type = "mask"`, Mitsuba's `mask`): light passes a masked surface with
//! probability 1 − α, in camera rays, shadow rays and photon paths alike; every strategy that
//! takes masks renders them as `path` does, and photon maps read the light a mask lets through.

mod agreement;

use agreement::{
    assert_agrees, assert_refused, block_means, image_mean, judge_blocks, load_text as load, render_image,
};
use photon_bench::scene::Scene;
use photon_bench::strategy::{self, Strategy};

/// An emitter of radiance 1 filling the view, behind sheets of black (nested reflectance 0)
/// masks of opacity `alphas`, nearest first.
fn sheets(alphas: &[f64]) -> String {
    let mut s = String::from(
        r#"[camera]
eye = [0, 0, 3]
look_at = [0, 0, 0]
fov_y = 30
resolution = [8, 6]

[materials.black]
type = "diffuse"
reflectance = [0, 0, 0]

[[shapes]]
type = "quad"
material = "black"
center = [0, 0, -1]
size = [20, 20]
facing = "+z"
emission = { radiance = [1, 1, 1] }
"#,
    );
    for (i, a) in alphas.iter().enumerate() {
        s += &format!(
            "[materials.sheet{i}]\ntype = \"mask\"\nopacity = {a}\nbsdf = {{ type = \"diffuse\", reflectance = [0, 0, 0] }}\n\
             [[shapes]]\ntype = \"quad\"\nmaterial = \"sheet{i}\"\ncenter = [0, 0, {}]\nsize = [20, 20]\nfacing = \"+z\"\n",
            1.0 - 0.5 * i as f64
        );
    }
    s
}

/// Camera rays pass a mask with probability 1 − α and a stack of masks with the product: the
/// image of an emitter of radiance 1 behind black masks reads Π (1 − α_i), within 4 standard
/// errors of its 0/1 draws, for `path` and for `bdpt` (whose eye walk and light connections
/// both cross the masks).
#[test]
fn camera_rays_pass_a_mask_with_probability_one_minus_alpha() {
    let dir = tempfile::tempdir().unwrap();
    for alphas in [&[0.3][..], &[0.8], &[0.5, 0.6]] {
        let scene = load(dir.path(), "sheets.toml", &sheets(alphas)).unwrap();
        let expected: f64 = alphas.iter().map(|a| 1.0 - a).product();
        for kind in ["path", "bdpt"] {
            let img = render_image(&scene, kind, "max_depth = 4", 256, 7);
            let n = img.pixels.len() as f64 * 256.0;
            let mean = img.pixels.iter().map(|p| f64::from(p.x)).sum::<f64>() / img.pixels.len() as f64;
            let se = (expected * (1.0 - expected) / n).sqrt();
            assert!(
                (mean - expected).abs() < 4.0 * se + 1e-6,
                "{kind}, α = {alphas:?}: {mean} vs {expected} ± {se}"
            );
        }
    }
}

/// A grey floor lit by a point light 2 above it, seen from beside the light, with (or without)
/// a black mask of opacity α between the two and the floor.
fn floor_under(alpha: Option<f64>) -> String {
    let mut s = String::from(
        r#"[camera]
eye = [0.3, 2, 0]
look_at = [0, 0, 0]
up = [0, 0, -1]
fov_y = 40
resolution = [9, 9]

[materials.grey]
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]

[[lights]]
type = "point"
position = [0, 2, 0]
intensity = [3, 3, 3]

[[shapes]]
type = "quad"
material = "grey"
center = [0, 0, 0]
size = [4, 4]
facing = "+y"
"#,
    );
    if let Some(a) = alpha {
        s += &format!(
            "[materials.mask]\ntype = \"mask\"\nopacity = {a}\nbsdf = {{ type = \"diffuse\", reflectance = [0, 0, 0] }}\n\
             [[shapes]]\ntype = \"quad\"\nmaterial = \"mask\"\ncenter = [0, 1, 0]\nsize = [20, 20]\nfacing = \"+y\"\n"
        );
    }
    s
}

/// Shadow rays carry the transmittance: a point light (reached only by next-event estimation
/// and light paths) lights the floor through a black mask, which the camera also looks through,
/// so the masked image is (1 − α)² times the open one — for `path`, `light`, `bdpt` and
/// `photon_map`, each against its own open image within 4 standard errors.
#[test]
fn shadow_rays_carry_one_minus_alpha() {
    let dir = tempfile::tempdir().unwrap();
    let alpha = 0.4;
    let open = load(dir.path(), "open.toml", &floor_under(None)).unwrap();
    let masked = load(dir.path(), "masked.toml", &floor_under(Some(alpha))).unwrap();
    for (kind, spp) in [("path", 64), ("light", 64), ("bdpt", 32), ("photon_map", 2)] {
        let (m0, se0) = image_mean(&open, kind, "max_depth = 3", spp);
        let (m, se) = image_mean(&masked, kind, "max_depth = 3", spp);
        let k = (1.0 - alpha) * (1.0 - alpha);
        assert_agrees(kind, (m, se), (m0 * k, se0 * k));
    }
}

/// A closed room lit from the ceiling, with a standing two-sided green leaf whose opacity is a
/// checkerboard of 0.25 and 1 (four cells), and a point light beside it.
const ROOM: &str = r#"[camera]
eye = [0, 1, 2.9]
look_at = [0, 0.8, 0]
fov_y = 50
resolution = [12, 9]

[materials.white]
type = "diffuse"
reflectance = [0.7, 0.7, 0.7]
[materials.leaf]
type = "mask"
opacity = { type = "checkerboard", color0 = [0.25, 0.25, 0.25], color1 = [1, 1, 1], to_uv = { scale = [1, 1] } }
bsdf = { type = "diffuse", reflectance = [0.2, 0.6, 0.15] }

[[lights]]
type = "point"
position = [0.5, 1.2, 0.8]
intensity = [0.6, 0.6, 0.6]

[[shapes]]
type = "box"
material = "white"
min = [-1.2, 0, -1]
max = [1.2, 2, 3]
[[shapes]]
type = "quad"
material = "leaf"
center = [0, 0.8, 0]
size = [1.2, 1.2]
facing = "+z"
[[shapes]]
type = "quad"
material = "white"
center = [0, 1.99, -0.3]
size = [0.7, 0.7]
facing = "-y"
emission = { radiance = [6, 6, 6] }
"#;

fn room() -> Scene {
    let dir = tempfile::tempdir().unwrap();
    load(dir.path(), "room.toml", ROOM).unwrap()
}

/// Every shipped strategy but `mps` takes masks; `mps` refuses them in one line naming the
/// material and the strategies that do.
#[test]
fn every_strategy_but_mps_takes_masks() {
    let scene = room();
    for kind in strategy::kinds() {
        let s: Box<dyn Strategy> = strategy::build(kind, toml::Table::new()).unwrap();
        let r = strategy::check_scene(&*s, &scene);
        if kind == "mps" {
            assert_refused(
                &r.unwrap_err().to_string(),
                &["mps", "\"leaf\"", "opacity mask", "path"],
            );
        } else {
            assert!(r.is_ok(), "{kind}: {r:?}");
        }
    }
}

/// The leaf room, every strategy that does not estimate densities against `path`: the
/// path-space strategies block by block (3 × 3 pixels, within 4 standard errors, plus 1 % for
/// `vcm`'s merging, where a block is precise enough to tell), the guided path tracers by their
/// image means (4 standard errors). The photon maps are judged on `SHEET`, below.
#[test]
fn unbiased_strategies_render_a_mask_as_path() {
    let scene = room();
    let params = "max_depth = 10";
    let reference = block_means(&scene, "path", params, 256);
    for (kind, spp, slack) in [
        ("bdpt", 32, 0.0),
        ("light", 128, 0.0),
        ("vcm", 32, 0.01),
        ("mlt", 2048, 0.0),
    ] {
        judge_blocks(&scene, &reference, (kind, params, spp, slack), |_| false);
    }
    let path = image_mean(&scene, "path", params, 256);
    for kind in ["photon_guided", "ppg"] {
        assert_agrees(kind, image_mean(&scene, kind, params, 32), path);
    }
}

/// A white masked sheet (α = 1/4) lit by a spot light straight above it, over a void, and a
/// white wall behind it outside the spot's cone: the camera sees the sheet lit directly and
/// the wall lit only by the sheet.
const SHEET: &str = r#"[materials.white]
type = "diffuse"
reflectance = [0.8, 0.8, 0.8]
[materials.sheet]
type = "mask"
opacity = 0.25
bsdf = { type = "diffuse", reflectance = [0.8, 0.8, 0.8] }

[[lights]]
type = "spot"
position = [0, 1, 0]
direction = [0, -1, 0]
intensity = [4, 4, 4]
cutoff_angle = 35

[[shapes]]
type = "quad"
material = "sheet"
center = [0, 0, 0]
size = [1.4, 1.4]
facing = "+y"
[[shapes]]
type = "quad"
material = "white"
center = [0, 0.5, -1]
size = [4, 3]
facing = "+z"
"#;

/// Density estimates read all the light that arrives at a masked surface: a photon found there
/// (with probability α) stands for the light the mask lets through too, so its power is
/// divided by α (and so is a light vertex `vcm` merges with). On `SHEET`, `ppm` and `vcm`'s
/// `ppm` mode (which estimate the sheet's direct light from photons) seen from above, and
/// `photon_map` looking at the wall only (whose gather rays read the sheet's map), agree with
/// `path` within 4 standard errors plus 5 % (kernel blur at a few passes); without the division
/// they read 39 %, 39 % and 25 % of `path` (measured). `sppm`, whose direct light is next-event
/// estimation and whose photons count from their second hit, is checked as well.
#[test]
fn photon_maps_read_the_light_a_mask_lets_through() {
    let dir = tempfile::tempdir().unwrap();
    let above = "[camera]\neye = [0, 1.6, 2.2]\nlook_at = [0, 0.3, -0.4]\nfov_y = 45\nresolution = [12, 9]\n";
    let wall = "[camera]\neye = [0, 1.2, 1.5]\nlook_at = [0, 1.2, -1]\nfov_y = 40\nresolution = [12, 9]\n";
    for (camera, kind, spp, params) in [
        (above, "ppm", 16, ""),
        (above, "sppm", 16, ""),
        (above, "vcm", 64, "mode = \"ppm\"\nradius_factor = 0.03"),
        (wall, "photon_map", 2, "photons = 400000"),
    ] {
        let scene = load(dir.path(), "sheet.toml", &format!("{camera}{SHEET}")).unwrap();
        let (m0, se0) = image_mean(&scene, "path", "max_depth = 4", 256);
        let (m, se) = image_mean(&scene, kind, &format!("max_depth = 4\n{params}"), spp);
        assert!(
            (m - m0).abs() < 4.0 * (se * se + se0 * se0).sqrt() + 0.05 * m0,
            "{kind}: {m} ± {se} vs path {m0} ± {se0}"
        );
    }
}

/// Same seed, same image with masks (the pass-through choice is a hash of the ray, not a
/// random stream): every strategy that takes masks, prepared and rendered on 1 and on 3
/// threads, gives bit-identical images of the leaf room.
#[test]
fn masked_images_are_bit_identical_for_any_thread_count() {
    let scene = room();
    for kind in strategy::kinds().into_iter().filter(|&k| k != "mps") {
        agreement::assert_bit_identical_across_threads(&scene, kind, 5);
    }
}

/// Mitsuba's `mask` is read with its opacity (a number, a colour's luminance, a texture) and
/// its nested BSDF, also inside `twosided` (the same mask, two-sided) and around it; it
/// survives the export to Mitsuba XML; a mask on an emitter, an opacity outside [0, 1] and a
/// mask in a mask are refused in one line naming the place.
#[test]
fn mitsuba_masks_are_read_exported_and_checked() {
    use photon_bench::bsdf::Bsdf;
    use photon_bench::texture::Scalar;
    let dir = tempfile::tempdir().unwrap();
    let diffuse = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.5, 0.1"/></bsdf>"#;
    let rect = |bsdf: &str| format!(r#"<shape type="rectangle">{bsdf}</shape>"#);
    for (bsdf, alpha, one_sided) in [
        (
            format!(r#"<bsdf type="mask"><float name="opacity" value="0.3"/>{diffuse}</bsdf>"#),
            0.3,
            true,
        ),
        (format!(r#"<bsdf type="mask">{diffuse}</bsdf>"#), 0.5, true),
        (
            format!(
                r#"<bsdf type="mask"><rgb name="opacity" value="0.2, 0.4, 0.9"/><bsdf type="twosided">{diffuse}</bsdf></bsdf>"#
            ),
            0.2126 * 0.2 + 0.7152 * 0.4 + 0.0722 * 0.9,
            false,
        ),
        (
            format!(
                r#"<bsdf type="twosided"><bsdf type="mask"><float name="opacity" value="0.7"/>{diffuse}</bsdf></bsdf>"#
            ),
            0.7,
            false,
        ),
    ] {
        let path = dir.path().join("m.xml");
        std::fs::write(&path, agreement::mitsuba_scene(&rect(&bsdf))).unwrap();
        let scene = photon_bench::scene::load::load_scene_with_stats(&path).unwrap().0;
        let m = scene
            .materials
            .iter()
            .find(|m| m.opacity.is_some())
            .expect("a masked material");
        match m.opacity {
            Some(Scalar::Constant(a)) => assert!((a - alpha as f32).abs() < 1e-6, "{bsdf}: {a}"),
            ref o => panic!("{bsdf}: {o:?}"),
        }
        assert_eq!(matches!(m.bsdf, Bsdf::OneSided(_)), one_sided, "{bsdf}: {:?}", m.bsdf);
        // Exported and read back: the same opacity and model.
        let out = dir.path().join("back.xml");
        photon_bench::scene::export::export_file(&path, &out).unwrap();
        let back = photon_bench::scene::load::load_scene_with_stats(&out).unwrap().0;
        let b = back
            .materials
            .iter()
            .find(|m| m.opacity.is_some())
            .expect("exported mask");
        assert_eq!((&b.opacity, &b.bsdf), (&m.opacity, &m.bsdf), "{bsdf}");
    }
    // A texture's luminance.
    let checker = r#"<bsdf type="mask"><texture name="opacity" type="checkerboard"><rgb name="color0" value="1"/><rgb name="color1" value="0.25"/></texture><bsdf type="diffuse"/></bsdf>"#;
    let path = dir.path().join("t.xml");
    std::fs::write(&path, agreement::mitsuba_scene(&rect(checker))).unwrap();
    let scene = photon_bench::scene::load::load_scene_with_stats(&path).unwrap().0;
    let m = scene.materials.iter().find(|m| m.opacity.is_some()).unwrap();
    assert_eq!(m.opacity.as_ref().unwrap().range(), (0.25, 1.0));
    for (body, expect) in [
        (
            r#"<shape type="rectangle"><bsdf type="mask"><bsdf type="diffuse"/></bsdf><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#.to_string(),
            &["an emitter cannot be masked"][..],
        ),
        (
            rect(r#"<bsdf type="mask"><float name="opacity" value="1.5"/><bsdf type="diffuse"/></bsdf>"#),
            &["opacity", "[0, 1]", "1.5"],
        ),
        (
            rect(r#"<bsdf type="mask"><bsdf type="mask"><bsdf type="diffuse"/></bsdf></bsdf>"#),
            &["mask inside a mask"],
        ),
        (rect(r#"<bsdf type="mask"></bsdf>"#), &["exactly one nested <bsdf>"]),
    ] {
        let path = dir.path().join("bad.xml");
        std::fs::write(&path, agreement::mitsuba_scene(&body)).unwrap();
        let err = photon_bench::scene::load::load_scene_with_stats(&path).err().expect(&body).to_string();
        assert_refused(&err, expect);
    }
    // TOML: the field is named.
    let bad = ROOM.replace("opacity = { type = \"checkerboard\"", "opacity = 2\n#");
    let err = load(dir.path(), "bad.toml", &bad).err().unwrap().to_string();
    assert_refused(&err, &["materials.leaf.opacity", "[0, 1]"]);
}
