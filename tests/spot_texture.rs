//! A spot's projected picture (TOML `texture` and `up` on a `[[lights]]` spot, Mitsuba's `spot`
//! with a `texture`): the light on a floor against the closed form, every strategy rendering a
//! room lit by a pictured spot as `path` does, the Mitsuba export, bad input refused.

mod agreement;

use agreement::{
    assert_light_starting_strategies_agree, assert_refused, floor_point, floor_under, load_text as load,
    render_image as render, room_under, write_png,
};
use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

/// A spot 1.5 above the floor pointing down, its picture `quadrants.png` (frame x = up × axis
/// = +x, y = axis × x = +z).
const SPOT: &str = "type = \"spot\"\nposition = [0, 1.5, 0]\ndirection = [0, -1, 0]\nup = [0, 0, 1]\n\
    intensity = [6, 6, 6]\ncutoff_angle = 30\nbeam_width = 29.5\n\
    texture = { type = \"bitmap\", file = \"quadrants.png\", filter = \"nearest\", raw = true }";

/// The four texels of `quadrants.png` (8-bit, read raw): column c, row r at [r][c]; u > ½ is
/// column 1, v > ½ row 1 (the file's second row).
const TEXELS: [[[u8; 3]; 2]; 2] = [[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [255, 255, 102]]];

/// Writes `quadrants.png` into `dir`.
fn write_picture(dir: &std::path::Path) {
    write_png(&dir.join("quadrants.png"), &TEXELS);
}

/// Under the pictured spot a diffuse floor reflects ρ/π · I T(u, v) cos θ / r², T the
/// texel of the quadrant the direction falls in (pixels whose footprint straddles a quadrant's
/// border or the beam's edge are left out). A picture read in another frame (turned, swapped
/// or mirrored) puts the texels in other quadrants.
#[test]
fn a_floor_shows_the_spots_picture_in_its_frame() {
    let dir = tempfile::tempdir().unwrap();
    write_picture(dir.path());
    let scene = load(dir.path(), "floor.toml", &floor_under(SPOT)).unwrap();
    let img = render(&scene, "path", "max_depth = 1", 256, 1);
    let tan = 30f32.to_radians().tan();
    let mut checked = 0;
    for y in 0..scene.camera.height {
        for x in 0..scene.camera.width {
            let p = floor_point(&scene, x, y);
            let d = p - Vec3::new(0.0, 1.5, 0.0);
            let (lx, ly, lz) = (d.x, d.z, -d.y);
            let near = |a: f32| a.abs() / lz < 0.12;
            let edge = ((lx * lx + ly * ly).sqrt() / lz / tan - 1.0).abs() < 0.15;
            if near(lx) || near(ly) || edge {
                continue;
            }
            let inside = (lx * lx + ly * ly).sqrt() / lz < 29.5f32.to_radians().tan();
            let texel = TEXELS[usize::from(ly > 0.0)][usize::from(lx > 0.0)];
            let t = if inside {
                Vec3::from_array(texel.map(|c| f32::from(c) / 255.0))
            } else {
                Vec3::ZERO
            };
            let r2 = d.length_squared();
            let want = 0.5 * FRAC_1_PI * 6.0 * t * (lz / r2.sqrt()) / r2;
            let got = img.get(x, y);
            assert!(
                (got - want).abs().max_element() <= 0.01 * want.max_element() + 1e-6,
                "pixel ({x}, {y}) at ({lx}, {ly}): {got} vs {want}"
            );
            checked += 1;
        }
    }
    assert!(checked > 100, "{checked}");
}

/// A room lit by the pictured spot: the unbiased strategies that start paths on lights agree
/// with `path` (photon emission and light sub-paths weigh the picture in).
#[test]
fn strategies_agree_under_a_pictured_spot() {
    let dir = tempfile::tempdir().unwrap();
    write_picture(dir.path());
    let room = room_under(SPOT);
    let scene = load(dir.path(), "room.toml", &room).unwrap();
    assert_light_starting_strategies_agree(&scene);
}

/// The exporter writes the picture and the frame's up; bad pictures and frames are refused in
/// one line naming the field.
#[test]
fn pictured_spots_are_exported_and_bad_ones_refused() {
    let dir = tempfile::tempdir().unwrap();
    write_picture(dir.path());
    let toml = dir.path().join("floor.toml");
    std::fs::write(&toml, floor_under(SPOT)).unwrap();
    let out = dir.path().join("floor.xml");
    photon_bench::scene::export::export_file(&toml, &out).unwrap();
    let xml = std::fs::read_to_string(&out).unwrap();
    assert!(
        xml.contains(r#"up="0 0 1""#) || xml.contains(r#"up="0, 0, 1""#),
        "{xml}"
    );
    assert!(xml.contains(r#"<texture type="bitmap" name="texture">"#), "{xml}");
    // The export loads back as the same light.
    let back = load(dir.path(), "floor.xml", &xml).unwrap();
    let orig = load(dir.path(), "floor2.toml", &floor_under(SPOT)).unwrap();
    assert_eq!(back.delta_lights.len(), 1);
    for w in [
        Vec3::new(0.2, -1.0, 0.1),
        Vec3::new(-0.3, -1.0, 0.2),
        Vec3::new(0.1, -1.0, -0.25),
    ] {
        let w = w.normalize();
        let (a, b) = (back.delta_lights[0].intensity(w), orig.delta_lights[0].intensity(w));
        assert!((a - b).abs().max_element() < 1e-4 * b.max_element(), "{w}: {a} vs {b}");
    }
    let refused = |light: &str| match load(dir.path(), "bad.toml", &floor_under(light)) {
        Ok(_) => panic!("loaded: {light}"),
        Err(e) => e.to_string(),
    };
    assert_refused(
        &refused(&SPOT.replace(
            "{ type = \"bitmap\", file = \"quadrants.png\", filter = \"nearest\", raw = true }",
            "{ type = \"checkerboard\", color0 = [1, 1, 1], color1 = [-1, 0, 0] }",
        )),
        &["lights[0].texture", "non-negative"],
    );
    assert_refused(
        &refused(&SPOT.replace("up = [0, 0, 1]", "up = [0, 2, 0]")),
        &["lights[0].up", "parallel"],
    );
    assert_refused(
        &refused(&SPOT.replace(
            "cutoff_angle = 30\nbeam_width = 29.5",
            "cutoff_angle = 120\nbeam_width = 20",
        )),
        &["lights[0].cutoff_angle", "89.9"],
    );
}
