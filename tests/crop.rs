//! Film crop windows (TOML `camera.crop`, Mitsuba's `crop_offset_x/y`, `crop_width/height`): a
//! cropped render is the full film's render inside the window — same projection, same pixel
//! values in expectation — for an eye-path and a light-tracing strategy; Mitsuba's attributes
//! are imported and exported; windows off the film are refused naming the field.

mod agreement;

use agreement::{assert_refused, load_text as load, render_image};
use photon_bench::film::Image;

const ROOM: &str = r#"[camera]
eye = [0, 1, 3.4]
look_at = [0, 1, 0]
fov_y = 40
resolution = [24, 18]
{crop}

[materials.white]
type = "diffuse"
reflectance = [0.7, 0.7, 0.7]
[materials.red]
type = "diffuse"
reflectance = [0.7, 0.2, 0.1]

[[shapes]]
type = "box"
material = "white"
min = [-1, 0, -1]
max = [1, 2, 4]
[[shapes]]
type = "sphere"
material = "red"
center = [0.3, 0.4, -0.2]
radius = 0.4
[[shapes]]
type = "quad"
material = "white"
center = [0, 1.99, 0]
size = [0.6, 0.6]
facing = "-y"
emission = { radiance = [6, 6, 6] }
"#;

/// Per 3 × 3 block of the window, the cropped render's mean and the full render's agree within
/// 4 standard errors (over 4 seeds each), for `path` and for `light`, whose splats must land in
/// the window's own pixels.
#[test]
fn a_cropped_render_is_the_full_render_inside_the_window() {
    let dir = tempfile::tempdir().unwrap();
    let full = load(dir.path(), "full.toml", &ROOM.replace("{crop}", "")).unwrap();
    let crop = load(
        dir.path(),
        "crop.toml",
        &ROOM.replace("{crop}", "crop = { offset = [9, 3], size = [12, 9] }"),
    )
    .unwrap();
    assert_eq!((crop.camera.width, crop.camera.height), (12, 9));
    for (kind, spp) in [("path", 256), ("light", 256)] {
        let seeds = 4u64;
        let block = |img: &Image, x0: u32, y0: u32, bx: u32, by: u32| -> f64 {
            let mut sum = 0.0;
            for y in 0..3 {
                for x in 0..3 {
                    sum += f64::from(img.get(x0 + 3 * bx + x, y0 + 3 * by + y).element_sum());
                }
            }
            sum / 9.0
        };
        let stats = |images: &[Image], x0: u32, y0: u32, bx: u32, by: u32| {
            let v: Vec<f64> = images.iter().map(|i| block(i, x0, y0, bx, by)).collect();
            let m = v.iter().sum::<f64>() / v.len() as f64;
            let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
            (m, var / v.len() as f64)
        };
        let fulls: Vec<Image> = (0..seeds)
            .map(|s| render_image(&full, kind, "max_depth = 4", spp, s))
            .collect();
        let crops: Vec<Image> = (0..seeds)
            .map(|s| render_image(&crop, kind, "max_depth = 4", spp, 100 + s))
            .collect();
        let lit = (0..3)
            .flat_map(|by| (0..4).map(move |bx| (bx, by)))
            .filter(|&(bx, by)| stats(&fulls, 9, 3, bx, by).0 > 0.05);
        assert!(lit.count() >= 10, "{kind}: the window sees the lit room");
        for by in 0..3 {
            for bx in 0..4 {
                let (a, va) = stats(&crops, 0, 0, bx, by);
                let (b, vb) = stats(&fulls, 9, 3, bx, by);
                let z = (a - b) / (va + vb).sqrt().max(1e-9);
                assert!(
                    z.abs() < 4.0,
                    "{kind}, block ({bx}, {by}): crop {a} vs full {b} (z = {z:.2})"
                );
            }
        }
    }
}

#[test]
fn crop_windows_off_the_film_are_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    for (crop, expect) in [
        (
            "crop = { offset = [20, 0], size = [5, 5] }",
            &["camera.crop", "24 × 18", "[20, 0]"][..],
        ),
        ("crop = { size = [0, 5] }", &["camera.crop.size", "positive"][..]),
        ("crop = { offset = [1, 1] }", &["size"][..]),
    ] {
        let err = load(dir.path(), "bad.toml", &ROOM.replace("{crop}", crop))
            .err()
            .unwrap()
            .to_string();
        assert_refused(&err, expect);
    }
}

/// Mitsuba's crop attributes set the window (the field of view stays the full film's, as
/// Mitsuba's), a window off the film is refused, and the export writes them back.
#[test]
fn mitsuba_crop_windows_are_imported_and_exported() {
    let dir = tempfile::tempdir().unwrap();
    let xml = |film: &str| {
        format!(
            r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="45"/>
    <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/>{film}</film>
  </sensor>
  <shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
</scene>"#
        )
    };
    let full = load(dir.path(), "full.xml", &xml("")).unwrap();
    let crop = load(
        dir.path(),
        "crop.xml",
        &xml(r#"<integer name="crop_offset_x" value="10"/><integer name="crop_offset_y" value="4"/><integer name="crop_width" value="20"/><integer name="crop_height" value="30"/>"#),
    )
    .unwrap();
    assert_eq!((crop.camera.width, crop.camera.height), (20, 30));
    assert_eq!((crop.camera.film, crop.camera.crop_offset), ((64, 48), (10, 4)));
    let d = full.camera.generate_ray(glam::Vec2::new(15.5, 9.5)).d;
    let c = crop.camera.generate_ray(glam::Vec2::new(5.5, 5.5)).d;
    assert!((d - c).length() < 1e-6, "{d} vs {c}");
    // Only a width: the window runs from the offset's default (0) over that width.
    let narrow = load(
        dir.path(),
        "narrow.xml",
        &xml(r#"<integer name="crop_width" value="16"/>"#),
    )
    .unwrap();
    assert_eq!(
        (narrow.camera.width, narrow.camera.height, narrow.camera.crop_offset),
        (16, 48, (0, 0))
    );
    let err = load(
        dir.path(),
        "off.xml",
        &xml(r#"<integer name="crop_offset_x" value="60"/><integer name="crop_width" value="8"/>"#),
    )
    .err()
    .unwrap()
    .to_string();
    assert_refused(&err, &["crop", "64 × 48"]);
    let out = dir.path().join("export.xml");
    photon_bench::scene::export::export_file(&dir.path().join("crop.xml"), &out).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains(r#"name="crop_offset_x" value="10""#) && text.contains(r#"name="crop_height" value="30""#),
        "{text}"
    );
}
