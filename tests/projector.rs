//! A projector (TOML `type = "projector"` in `[[lights]]`, Mitsuba's `projector` emitter): the
//! light on a floor against the closed form, every strategy rendering a room lit by it as
//! `path` does, Mitsuba's element read and written, bad input refused.

mod agreement;

use agreement::{
    assert_light_starting_strategies_agree, assert_refused, floor_point, floor_under, load_text as load,
    render_image as render, room_under, write_png,
};
use glam::Vec3;

/// A projector 1.5 above the floor looking down, the picture's up +z (frame x = up × axis =
/// +x, the picture's left; y = +z), a 30° view along the picture's height.
const PROJECTOR: &str = "type = \"projector\"\nposition = [0, 1.5, 0]\ndirection = [0, -1, 0]\nup = [0, 0, 1]\n\
    fov = 30\nfov_axis = \"y\"\nscale = 2\n\
    irradiance = { type = \"bitmap\", file = \"strip.png\", filter = \"nearest\", raw = true }";

/// `strip.png` (8-bit, read raw): 4 columns × 2 rows, [row][column], row 0 the top.
const TEXELS: [[[u8; 3]; 4]; 2] = [
    [[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]],
    [[51, 51, 51], [255, 128, 0], [0, 128, 255], [102, 0, 204]],
];

fn write_picture(dir: &std::path::Path) {
    write_png(&dir.join("strip.png"), &TEXELS);
}

/// A floor facing the projector at distance h receives π s E / h² wherever the picture
/// reaches, so a diffuse floor shows ρ s E / h², the picture's texel under the pixel
/// (u = ½ − ½ (l_x / l_z) / t_x, v = ½ − ½ (l_y / l_z) / t_y; t_y = tan 15°, t_x = 2 t_y for
/// this 4 × 2 picture). Pixels whose footprint straddles a texel's border are left out. A
/// mirrored, turned or stretched picture puts other texels under the pixels.
#[test]
fn a_floor_shows_the_projected_picture_upright_and_evenly_lit() {
    let dir = tempfile::tempdir().unwrap();
    write_picture(dir.path());
    let scene = load(
        dir.path(),
        "floor.toml",
        &floor_under(PROJECTOR).replace("[24, 24]", "[48, 48]"),
    )
    .unwrap();
    let img = render(&scene, "path", "max_depth = 1", 64, 1);
    let ty = 15f32.to_radians().tan();
    let tx = 2.0 * ty;
    let (mut checked, mut dark) = (0, 0);
    for y in 0..scene.camera.height {
        for x in 0..scene.camera.width {
            let d = floor_point(&scene, x, y) - Vec3::new(0.0, 1.5, 0.0);
            let (lx, ly, lz) = (d.x, d.z, -d.y);
            let (u, v) = (0.5 - 0.5 * lx / lz / tx, 0.5 - 0.5 * ly / lz / ty);
            // A pixel spans 2.18 / 48 on the floor: a margin of one pixel in (u, v).
            let (mu, mv) = (0.05 / (2.0 * 1.5 * tx), 0.05 / (2.0 * 1.5 * ty));
            let (cu, cv) = (u * 4.0, v * 2.0);
            let straddles = |c: f32, m: f32, n: f32| (c - c.round()).abs() < m * n;
            if straddles(cu, mu, 4.0) || straddles(cv, mv, 2.0) {
                continue;
            }
            let want = if (0.0..1.0).contains(&u) && (0.0..1.0).contains(&v) {
                let t = TEXELS[cv as usize][cu as usize];
                0.5 * 2.0 * Vec3::from_array(t.map(|c| f32::from(c) / 255.0)) / (1.5 * 1.5)
            } else {
                dark += 1;
                Vec3::ZERO
            };
            let got = img.get(x, y);
            assert!(
                (got - want).abs().max_element() <= 1e-3 * want.max_element() + 1e-6,
                "pixel ({x}, {y}) at (u, v) = ({u}, {v}): {got} vs {want}"
            );
            checked += 1;
        }
    }
    assert!(checked > 1000 && dark > 200, "{checked} checked, {dark} dark");
}

/// A room lit by the projector: the unbiased strategies that start paths on lights agree with
/// `path` (photons and light sub-paths leave where the picture is bright, with its density).
#[test]
fn strategies_agree_under_a_projector() {
    let dir = tempfile::tempdir().unwrap();
    write_picture(dir.path());
    let projector = PROJECTOR.replace("filter = \"nearest\", ", "");
    let room = room_under(&projector);
    let scene = load(dir.path(), "room.toml", &room).unwrap();
    assert_light_starting_strategies_agree(&scene);
}

/// Mitsuba's element: the exporter writes the frame, the view and the picture, and the file
/// loads back as the same light; Mitsuba's uniform scale in `to_world` multiplies the
/// intensity (it divides by the local z² and multiplies by the image of +z's length); shear,
/// mirroring and a focal length are refused.
#[test]
fn projectors_are_read_and_written_as_mitsuba_does() {
    let dir = tempfile::tempdir().unwrap();
    write_picture(dir.path());
    let toml = dir.path().join("floor.toml");
    std::fs::write(&toml, floor_under(PROJECTOR)).unwrap();
    let out = dir.path().join("floor.xml");
    photon_bench::scene::export::export_file(&toml, &out).unwrap();
    let xml = std::fs::read_to_string(&out).unwrap();
    for part in [
        r#"<emitter type="projector">"#,
        r#"<texture type="bitmap" name="irradiance">"#,
        r#"name="fov_axis" value="y""#,
    ] {
        assert!(xml.contains(part), "{part} not in {xml}");
    }
    let orig = load(dir.path(), "floor2.toml", &floor_under(PROJECTOR)).unwrap();
    let back = load(dir.path(), "floor.xml", &xml).unwrap();
    let probes = [
        Vec3::new(0.2, -1.0, 0.1),
        Vec3::new(-0.4, -1.0, 0.2),
        Vec3::new(0.1, -1.0, -0.25),
        Vec3::new(0.5, -1.0, 0.0),
    ];
    for w in probes {
        let w = w.normalize();
        let (a, b) = (back.delta_lights[0].intensity(w), orig.delta_lights[0].intensity(w));
        assert!((a - b).abs().max_element() <= 1e-4 * b.max_element(), "{w}: {a} vs {b}");
    }

    let mitsuba = |to_world: &str| {
        format!(
            r#"<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 3, 0" target="0, 0, 0" up="0, 0, -1"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
    <emitter type="projector">
        <float name="fov" value="30"/>
        <rgb name="irradiance" value="1, 2, 3"/>
        <transform name="to_world">{to_world}</transform>
    </emitter>
    <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/></transform></shape>
</scene>"#
        )
    };
    let lookat = r#"<lookat origin="0, 1.5, 0" target="0, 0, 0" up="0, 0, 1"/>"#;
    let plain = load(dir.path(), "plain.xml", &mitsuba(lookat)).unwrap();
    let scaled = load(
        dir.path(),
        "scaled.xml",
        &mitsuba(&format!(r#"<scale value="2"/>{lookat}"#)),
    )
    .unwrap();
    let w = Vec3::new(0.1, -1.0, 0.05).normalize();
    let (a, b) = (plain.delta_lights[0].intensity(w), scaled.delta_lights[0].intensity(w));
    assert!(
        a.max_element() > 0.0 && (b - 2.0 * a).abs().max_element() <= 1e-5 * b.max_element(),
        "{a} {b}"
    );
    let refused = |name: &str, text: &str| match load(dir.path(), name, text) {
        Ok(_) => panic!("loaded: {text}"),
        Err(e) => e.to_string(),
    };
    assert_refused(
        &refused("shear.xml", &mitsuba(&format!(r#"<scale value="2, 1, 1"/>{lookat}"#))),
        &["shear.xml", "uniform scale"],
    );
    assert_refused(
        &refused("mirror.xml", &mitsuba(&format!(r#"<scale value="-1, 1, 1"/>{lookat}"#))),
        &["mirror.xml", "mirror"],
    );
    assert_refused(
        &refused(
            "focal.xml",
            &mitsuba(lookat).replace(
                r#"<float name="fov" value="30"/>"#,
                r#"<string name="focal_length" value="35mm"/>"#,
            ),
        ),
        &["focal.xml", "focal_length"],
    );
}

/// Bad TOML input: one line naming the field and what is expected.
#[test]
fn bad_projectors_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    write_picture(dir.path());
    let refused = |light: &str| match load(dir.path(), "bad.toml", &floor_under(light)) {
        Ok(_) => panic!("loaded: {light}"),
        Err(e) => e.to_string(),
    };
    for (from, to, expect) in [
        ("fov = 30", "fov = 180", &["lights[0].fov", "(0, 180)"][..]),
        ("fov_axis = \"y\"", "fov_axis = \"z\"", &["lights[0].fov_axis", "\"z\""]),
        ("up = [0, 0, 1]", "up = [0, 3, 0]", &["lights[0].up", "parallel"]),
        ("scale = 2", "scale = -1", &["lights[0].scale", "-1"]),
        (
            "{ type = \"bitmap\", file = \"strip.png\", filter = \"nearest\", raw = true }",
            "{ type = \"checkerboard\", color0 = [1, 1, 1], color1 = [0, -1, 0] }",
            &["lights[0].irradiance", "non-negative"],
        ),
        (
            "{ type = \"bitmap\", file = \"strip.png\", filter = \"nearest\", raw = true }",
            "{ type = \"bitmap\", file = \"missing.png\" }",
            &["lights[0].irradiance", "missing.png"],
        ),
    ] {
        assert!(PROJECTOR.contains(from), "{from}");
        assert_refused(&refused(&PROJECTOR.replace(from, to)), expect);
    }
}
