//! Thin-lens and orthographic cameras (TOML `camera.lens`, Mitsuba's `thinlens` and
//! `orthographic` sensors): an orthographic image of an emitter holds its area over a pixel's,
//! a thin lens focused on an emitter renders it as the pinhole does, every strategy renders
//! both as `path` does, Mitsuba's sensors are imported and exported, bad lenses are refused
//! naming the field.

mod agreement;

use agreement::{assert_refused, block_means, block_sees, judge_blocks, load_text as load, render_image};
use photon_bench::camera::Lens;
use photon_bench::scene::load::load_scene_with_stats;

/// A 1 × 1.5 emitting quad facing the camera 3 units away, in front of a grey wall.
fn scene(lens: &str) -> String {
    format!(
        r#"[camera]
eye = [0, 0, 3]
look_at = [0, 0, 0]
fov_y = 50
resolution = [40, 30]
{lens}

[materials.grey]
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
[materials.black]
type = "diffuse"
reflectance = [0, 0, 0]

[[shapes]]
type = "quad"
material = "black"
center = [0.2, -0.1, 0]
size = [1, 1.5]
facing = "+z"
emission = {{ radiance = [2, 3, 4] }}
[[shapes]]
type = "quad"
material = "grey"
center = [0, 0, -1]
size = [20, 20]
facing = "+z"
"#
    )
}

/// Parallel projection keeps sizes: with direct light only (the wall is unlit), the image's sum
/// is Le times the quad's area over a pixel's (4 × 3 units over 40 × 30 pixels: 0.01), wherever
/// the quad sits in the view — exact up to the edge pixels' jitter.
#[test]
fn an_orthographic_image_of_an_emitter_holds_its_area() {
    let dir = tempfile::tempdir().unwrap();
    let s = load(
        dir.path(),
        "o.toml",
        &scene("lens = { type = \"orthographic\", height = 3 }"),
    )
    .unwrap();
    assert_eq!(
        s.camera.lens,
        Lens::Orthographic {
            half_w: 2.0,
            half_h: 1.5
        }
    );
    let img = render_image(&s, "path", "max_depth = 0", 256, 1);
    let sum: f64 = img.pixels.iter().map(|p| f64::from(p.x)).sum();
    let expected = 2.0 * 1.5 / 0.01;
    assert!((sum / expected - 1.0).abs() < 0.003, "{sum} vs {expected}");
}

/// Every ray a thin lens sends through one raster point crosses the plane of focus at the
/// pinhole ray's point there, so an emitter in that plane renders as through the pinhole: the
/// same raster positions (drawn first from each pixel's stream) give the same hits.
#[test]
fn a_thin_lens_focused_on_an_emitter_renders_it_as_the_pinhole() {
    let dir = tempfile::tempdir().unwrap();
    let pinhole = load(dir.path(), "p.toml", &scene("")).unwrap();
    let thin = load(
        dir.path(),
        "t.toml",
        &scene("lens = { type = \"thin\", aperture_radius = 0.2, focus_distance = 3 }"),
    )
    .unwrap();
    let raster = glam::Vec2::new(13.3, 21.7);
    let focus = pinhole.camera.generate_ray(raster);
    let at_focus = focus.o + focus.d * (3.0 / focus.d.dot(glam::Vec3::NEG_Z));
    for u in [
        glam::Vec2::new(0.1, 0.9),
        glam::Vec2::new(0.7, 0.3),
        glam::Vec2::new(0.99, 0.5),
    ] {
        let r = thin.camera.lens_ray(raster, u);
        assert!((r.o - pinhole.camera.eye).length() > 1e-3 && (r.o - pinhole.camera.eye).length() <= 0.2 + 1e-5);
        let p = r.o + r.d * ((r.o.z - 0.0) / -r.d.z);
        assert!((p - at_focus).length() < 1e-4, "{p} vs {at_focus}");
    }
    let (a, b) = (
        render_image(&pinhole, "path", "max_depth = 0", 16, 3),
        render_image(&thin, "path", "max_depth = 0", 16, 3),
    );
    let differ = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(p, q)| (**p - **q).abs().max_element() > 1e-3)
        .count();
    assert!(differ <= 4, "{differ} pixels differ");
    // Out of focus the emitter blurs: its edge pixels change.
    let blurred = load(
        dir.path(),
        "b.toml",
        &scene("lens = { type = \"thin\", aperture_radius = 0.2, focus_distance = 1 }"),
    )
    .unwrap();
    let c = render_image(&blurred, "path", "max_depth = 0", 16, 3);
    let differ = a
        .pixels
        .iter()
        .zip(&c.pixels)
        .filter(|(p, q)| (**p - **q).abs().max_element() > 0.1)
        .count();
    assert!(differ > 40, "only {differ} pixels blurred");
}

/// An outdoor scene for every strategy: a ground, a diffuse and a rough gold sphere, an area
/// light above and a constant sky, which an orthographic camera sees straight ahead above the
/// horizon (a path that is a delta in direction at both ends, `path_space`'s module doc).
fn outdoor(lens: &str) -> String {
    format!(
        r#"[camera]
eye = [0, 1.2, 3]
look_at = [0, 0.5, 0]
fov_y = 50
resolution = [12, 9]
{lens}

[environment]
type = "constant"
radiance = [0.3, 0.35, 0.45]

[materials.ground]
type = "diffuse"
reflectance = [0.6, 0.6, 0.55]
[materials.red]
type = "diffuse"
reflectance = [0.7, 0.2, 0.15]
[materials.gold]
type = "rough_conductor"
distribution = "ggx"
material = "Au"
alpha = 0.25

[[shapes]]
type = "quad"
material = "ground"
center = [0, 0, 0]
size = [6, 9]
facing = "+y"
[[shapes]]
type = "sphere"
material = "red"
center = [-0.5, 0.4, 0.3]
radius = 0.4
[[shapes]]
type = "sphere"
material = "gold"
center = [0.6, 0.35, -0.3]
radius = 0.35
[[shapes]]
type = "quad"
material = "ground"
center = [0, 2.5, 0]
size = [1, 1]
facing = "-y"
emission = {{ radiance = [6, 6, 6] }}
"#
    )
}

const THIN: &str = "lens = { type = \"thin\", aperture_radius = 0.15, focus_distance = 3 }";
const ORTHOGRAPHIC: &str = "lens = { type = \"orthographic\", height = 2.4 }";

/// The strategies built on path space render a thin lens and an orthographic camera as `path`
/// does (its eye rays are the cameras' definition): block by block (3 × 3 pixels, 6 seeds)
/// within 4 standard errors (plus 1 % for `vcm`'s merging) wherever a block is precise enough
/// to tell, and `mps`'s image (photon maps read by a final gather: biased, consistent) within
/// 3 % of `path`'s. The lens point is a vertex of its own, drawn uniformly (module doc of
/// `path_space`, "Cameras"): a light path connects to one and lands where the ray through it
/// crosses the plane of focus, the Metropolis chain moves it with BD and LS. Through the
/// orthographic camera a connection meets the film point behind its vertex, and the sky seen
/// straight ahead is made by the eye walk alone: `light`, which has no eye walk, leaves those
/// pixels black (its module doc) and is judged on the other blocks.
#[test]
fn path_space_strategies_render_lenses_as_path() {
    let dir = tempfile::tempdir().unwrap();
    for lens in [THIN, ORTHOGRAPHIC] {
        let scene = load(dir.path(), "outdoor.toml", &outdoor(lens)).unwrap();
        let params = "max_depth = 6";
        let reference = block_means(&scene, "path", params, 512);
        let sees_the_sky = |block: &[(u32, u32)]| block_sees(&scene, block, |hit| hit.is_none());
        for (kind, spp, slack) in [
            ("bdpt", 64, 0.0),
            ("light", 1024, 0.0),
            ("vcm", 64, 0.01),
            ("mlt", 4096, 0.0),
        ] {
            judge_blocks(&scene, &reference, (kind, params, spp, slack), |block| {
                kind == "light" && scene.camera.is_orthographic() && sees_the_sky(block)
            });
        }
        let mean = |v: &[(f64, f64)]| v.iter().map(|b| b.0).sum::<f64>() / v.len() as f64;
        let (photons, path) = (mean(&block_means(&scene, "mps", params, 16)), mean(&reference));
        assert!(
            (photons / path - 1.0).abs() < 0.03,
            "{lens}: mps {photons} vs path {path}"
        );
    }
}

#[test]
fn bad_lenses_are_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    for (lens, expect) in [
        (
            "lens = { type = \"thin\", aperture_radius = -1, focus_distance = 3 }",
            &["camera.lens.aperture_radius"][..],
        ),
        (
            "lens = { type = \"thin\", aperture_radius = 0.1, focus_distance = 0 }",
            &["camera.lens.focus_distance"][..],
        ),
        (
            "lens = { type = \"orthographic\", height = 0 }",
            &["camera.lens.height"][..],
        ),
        ("lens = { type = \"fisheye\" }", &["fisheye"][..]),
    ] {
        let err = load(dir.path(), "bad.toml", &scene(lens)).err().unwrap().to_string();
        assert_refused(&err, expect);
    }
    let no_fov = scene("").replace("fov_y = 50\n", "");
    assert_refused(
        &load(dir.path(), "nofov.toml", &no_fov).err().unwrap().to_string(),
        &["camera.fov_y", "missing"],
    );
    // An orthographic camera needs no field of view.
    let ortho = scene("lens = { type = \"orthographic\", height = 3, width = 5 }").replace("fov_y = 50\n", "");
    let s = load(dir.path(), "ortho.toml", &ortho).unwrap();
    assert_eq!(
        s.camera.lens,
        Lens::Orthographic {
            half_w: 2.5,
            half_h: 1.5
        }
    );
}

/// Mitsuba's `thinlens` (`aperture_radius`, `focus_distance` with Mitsuba's default 10⁴) and
/// `orthographic` (extent from `to_world`'s scale: camera space [−1, 1] × [−1/aspect,
/// 1/aspect]) come in as these lenses, and go out again.
#[test]
fn mitsuba_lens_sensors_are_imported_and_exported() {
    let dir = tempfile::tempdir().unwrap();
    let xml = |sensor: &str| {
        format!(
            r#"<scene version="3.0.0">
  {sensor}
  <shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
</scene>"#
        )
    };
    let film = r#"<film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="20"/></film>"#;
    let thin = load(
        dir.path(),
        "thin.xml",
        &xml(&format!(
            r#"<sensor type="thinlens"><float name="fov" value="40"/><float name="aperture_radius" value="0.25"/><float name="focus_distance" value="6"/><transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>{film}</sensor>"#
        )),
    )
    .unwrap();
    assert_eq!(
        thin.camera.lens,
        Lens::Thin {
            aperture_radius: 0.25,
            focus_distance: 6.0
        }
    );
    let far = load(
        dir.path(),
        "far.xml",
        &xml(&format!(
            r#"<sensor type="thinlens"><float name="fov" value="40"/><float name="aperture_radius" value="0.25"/>{film}</sensor>"#
        )),
    )
    .unwrap();
    assert_eq!(
        far.camera.lens,
        Lens::Thin {
            aperture_radius: 0.25,
            focus_distance: 1e4
        }
    );
    let ortho = load(
        dir.path(),
        "ortho.xml",
        &xml(&format!(
            r#"<sensor type="orthographic"><transform name="to_world"><scale x="3" y="3"/><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>{film}</sensor>"#
        )),
    )
    .unwrap();
    // Aspect 2: x spans ±3, y ±3 / 2.
    assert_eq!(
        ortho.camera.lens,
        Lens::Orthographic {
            half_w: 3.0,
            half_h: 1.5
        }
    );
    let err = load(
        dir.path(),
        "bad.xml",
        &xml(&format!(
            r#"<sensor type="thinlens"><float name="fov" value="40"/>{film}</sensor>"#
        )),
    )
    .err()
    .unwrap()
    .to_string();
    assert_refused(&err, &["aperture_radius"]);
    for (name, scene) in [("thin.xml", &thin), ("ortho.xml", &ortho)] {
        let out = dir.path().join(format!("export-{name}"));
        photon_bench::scene::export::export_file(&dir.path().join(name), &out).unwrap();
        let back = load_scene_with_stats(&out).unwrap().0;
        assert_eq!(back.camera.lens, scene.camera.lens, "{name}");
        let r = glam::Vec2::new(7.5, 3.25);
        let (a, b) = (back.camera.generate_ray(r), scene.camera.generate_ray(r));
        assert!((a.o - b.o).length() < 1e-4 && (a.d - b.d).length() < 1e-5, "{name}");
    }
}
