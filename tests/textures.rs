//! Textures and texture coordinates: each shape's (u, v) as Mitsuba 3 defines it, checkerboard
//! and bitmap textures driving a material's colour where the ray lands, the files' bytes in the
//! scene hash, and bad textures refused with one line naming the field.

use glam::{Vec2, Vec3};
use photon_bench::bsdf::Bsdf;
use photon_bench::geometry::Ray;
use photon_bench::scene::Scene;
use photon_bench::scene::load::load_scene_with_stats;
use photon_bench::texture::srgb_to_linear;
use std::path::Path;

const LIGHT: &str = r#"<shape type="sphere"><point name="center" x="0" y="30" z="0"/><float name="radius" value="0.5"/>
        <emitter type="area"><rgb name="radiance" value="4"/></emitter></shape>"#;

fn scene_xml(body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 9" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
    {LIGHT}
    {body}
</scene>"#
    )
}

fn load_in(dir: &Path, body: &str) -> photon_bench::error::Result<Scene> {
    let path = dir.join("s.xml");
    std::fs::write(&path, scene_xml(body)).unwrap();
    load_scene_with_stats(&path).map(|(s, _)| s)
}

/// The (u, v) and the reflectance where a ray from `o` along `d` lands.
fn probe(scene: &Scene, o: Vec3, d: Vec3) -> (Vec2, Vec3) {
    let hit = scene
        .intersect(&Ray::new(o, d.normalize()))
        .expect("the probe ray hits");
    let reflectance = match &*scene.bsdf(&hit) {
        Bsdf::Lambertian(l) => l.reflectance,
        Bsdf::OneSided(b) => match &**b {
            Bsdf::Lambertian(l) => l.reflectance,
            other => panic!("not diffuse: {other:?}"),
        },
        other => panic!("not diffuse: {other:?}"),
    };
    (scene.uv(&hit), reflectance)
}

fn close(a: Vec2, b: Vec2) -> bool {
    (a - b).abs().max_element() < 2e-4
}

/// Rays shot at Mitsuba 3.9.1's own `cube`, `rectangle` and (rotated) `sphere` gave these
/// (u, v) (`si.uv` of `scene.ray_intersect` in `scalar_rgb`); ours must give the same, face by
/// face, including the orientation of each cube face.
#[test]
fn shape_parameterizations_are_mitsubas() {
    let dir = tempfile::tempdir().unwrap();
    let cube = load_in(dir.path(), r#"<shape type="cube"/>"#).unwrap();
    // (origin, direction, Mitsuba's uv)
    let cube_probes = [
        ([3.0, 0.5, 0.25], [-1.0, 0.0, 0.0], [0.75, 0.375]),
        ([3.0, -0.5, 0.75], [-1.0, 0.0, 0.0], [0.25, 0.125]),
        ([-3.0, 0.5, 0.25], [1.0, 0.0, 0.0], [0.75, 0.625]),
        ([-3.0, -0.5, 0.75], [1.0, 0.0, 0.0], [0.25, 0.875]),
        ([0.5, 3.0, 0.25], [0.0, -1.0, 0.0], [0.25, 0.375]),
        ([-0.5, 3.0, 0.75], [0.0, -1.0, 0.0], [0.75, 0.125]),
        ([0.5, -3.0, 0.25], [0.0, 1.0, 0.0], [0.625, 0.75]),
        ([-0.5, -3.0, 0.75], [0.0, 1.0, 0.0], [0.875, 0.25]),
        ([0.5, 0.25, 3.0], [0.0, 0.0, -1.0], [0.625, 0.75]),
        ([-0.5, 0.75, 3.0], [0.0, 0.0, -1.0], [0.875, 0.25]),
        ([0.5, 0.25, -3.0], [0.0, 0.0, 1.0], [0.375, 0.75]),
        ([-0.5, 0.75, -3.0], [0.0, 0.0, 1.0], [0.125, 0.25]),
    ];
    for (o, d, uv) in cube_probes {
        let (got, _) = probe(&cube, Vec3::from(o), Vec3::from(d));
        assert!(close(got, Vec2::from(uv)), "cube from {o:?}: {got} vs Mitsuba's {uv:?}");
    }
    let rect = load_in(dir.path(), r#"<shape type="rectangle"/>"#).unwrap();
    let (got, _) = probe(&rect, Vec3::new(0.5, -0.25, 2.0), -Vec3::Z);
    assert!(close(got, Vec2::new(0.75, 0.375)), "rectangle: {got}");
    let sphere = load_in(dir.path(), r#"<shape type="sphere"/>"#).unwrap();
    let (got, _) = probe(&sphere, Vec3::new(2.0, 0.3, 0.4), -Vec3::X);
    assert!(close(got, Vec2::new(0.0531, 0.369)), "sphere: {got}");
    let (got, _) = probe(&sphere, Vec3::new(0.3, -2.0, 0.4), Vec3::Y);
    assert!(close(got, Vec2::new(0.8031, 0.369)), "sphere, φ past π: {got}");
    let turned = load_in(
        dir.path(),
        r#"<shape type="sphere"><transform name="to_world"><rotate x="1" angle="90"/></transform></shape>"#,
    )
    .unwrap();
    let (got, _) = probe(&turned, Vec3::new(2.0, 0.3, 0.4), -Vec3::X);
    assert!(close(got, Vec2::new(0.0689, 0.597)), "rotated sphere: {got}");
    let (got, _) = probe(&turned, Vec3::new(0.3, 2.0, 0.4), -Vec3::Y);
    assert!(close(got, Vec2::new(0.1476, 0.8333)), "rotated sphere: {got}");
}

/// A checkerboard named at the top level and referred to, with Mitsuba's `to_uv` (scale, then
/// translate): each cell of the rectangle gets colour 0 or 1 by Mitsuba's rule.
#[test]
fn a_checkerboard_colours_the_cells_mitsuba_colours() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load_in(
        dir.path(),
        r#"<texture type="checkerboard" id="checks">
            <rgb name="color0" value="0.1, 0.2, 0.3"/><rgb name="color1" value="0.9, 0.8, 0.7"/>
            <transform name="to_uv"><scale x="2" y="2"/><translate x="0.5"/></transform></texture>
        <bsdf type="diffuse" id="floor"><ref name="reflectance" id="checks"/></bsdf>
        <shape type="rectangle"><ref id="floor"/></shape>"#,
    )
    .unwrap();
    let (c0, c1) = (Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.9, 0.8, 0.7));
    for (x, y) in [(-0.9f32, -0.9f32), (-0.4, -0.9), (0.1, 0.3), (0.7, 0.7), (-0.3, 0.6)] {
        let (uv, r) = probe(&scene, Vec3::new(x, y, 1.0), -Vec3::Z);
        let t = Vec2::new(2.0 * uv.x + 0.5, 2.0 * uv.y);
        let upper = |a: f32| a - a.floor() > 0.5;
        let expected = if upper(t.x) == upper(t.y) { c0 } else { c1 };
        assert!(
            (r - expected).abs().max_element() < 1e-6,
            "at ({x}, {y}), uv {uv}: {r} vs {expected}"
        );
    }
}

fn png(path: &Path, w: u32, h: u32, rgb: &[u8]) {
    image::RgbImage::from_raw(w, h, rgb.to_vec())
        .unwrap()
        .save(path)
        .unwrap();
}

/// A 2 × 2 PNG read with `nearest`: each quadrant of the rectangle gets its texel, decoded
/// from sRGB, with row 0 of the file at v = 0 (Mitsuba's rectangle has v = 0 at local y = −1);
/// on an OBJ whose `vt` put v = 0 at the bottom, Mitsuba flips v, and so do we.
#[test]
fn bitmaps_are_read_in_mitsubas_orientation_and_decoded_from_srgb() {
    let dir = tempfile::tempdir().unwrap();
    png(
        &dir.path().join("quad.png"),
        2,
        2,
        &[255, 0, 0, 0, 255, 0, 0, 0, 255, 128, 128, 128],
    );
    let texture = r#"<texture type="bitmap" name="reflectance"><string name="filename" value="quad.png"/>
        <string name="filter_type" value="nearest"/></texture>"#;
    let scene = load_in(
        dir.path(),
        &format!(
            r#"<shape type="rectangle"><bsdf type="twosided"><bsdf type="diffuse">{texture}</bsdf></bsdf></shape>"#
        ),
    )
    .unwrap();
    let grey = srgb_to_linear(128.0 / 255.0);
    let at = |x: f32, y: f32| probe(&scene, Vec3::new(x, y, 1.0), -Vec3::Z).1;
    assert_eq!(at(-0.5, -0.5), Vec3::X, "row 0, column 0 at u, v < ½");
    assert_eq!(at(0.5, -0.5), Vec3::Y);
    assert_eq!(at(-0.5, 0.5), Vec3::Z);
    assert!((at(0.5, 0.5) - Vec3::splat(grey)).abs().max_element() < 1e-6);

    // The same unit square as an OBJ with its own vt: (0, 0) bottom left as OBJ files mean it.
    let obj = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
    std::fs::write(dir.path().join("square.obj"), obj).unwrap();
    let scene = load_in(
        dir.path(),
        &format!(
            r#"<shape type="obj"><string name="filename" value="square.obj"/>
                <bsdf type="diffuse">{texture}</bsdf></shape>"#
        ),
    )
    .unwrap();
    let at = |x: f32, y: f32| probe(&scene, Vec3::new(x, y, 1.0), -Vec3::Z);
    let (uv, r) = at(-0.5, 0.5);
    assert!(close(uv, Vec2::new(0.25, 0.25)), "top left of the picture: {uv}");
    assert_eq!(r, Vec3::X, "the file's first texel at the top left, as an OBJ means it");
    assert_eq!(at(0.5, -0.5).1, Vec3::splat(grey));
}

/// PLY texture coordinates under any of their usual names, as they are (Mitsuba 3.9.1 gave
/// (u, v) = (0.05, 0.05) at the corner of a PLY square whose file says so).
#[test]
fn ply_texture_coordinates_are_read() {
    let dir = tempfile::tempdir().unwrap();
    for (u, v) in [("u", "v"), ("s", "t"), ("texture_u", "texture_v")] {
        let ply = format!(
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
             property float {u}\nproperty float {v}\nelement face 1\nproperty list uchar int vertex_indices\n\
             end_header\n-1 -1 0 0 0\n1 -1 0 1 0\n-1 1 0 0 1\n3 0 1 2\n"
        );
        std::fs::write(dir.path().join("tri.ply"), ply).unwrap();
        let scene = load_in(
            dir.path(),
            r#"<shape type="ply"><string name="filename" value="tri.ply"/></shape>"#,
        )
        .unwrap();
        let hit = scene
            .intersect(&Ray::new(Vec3::new(-0.5, -0.5, 1.0), -Vec3::Z))
            .unwrap();
        let uv = scene.uv(&hit);
        assert!(close(uv, Vec2::new(0.25, 0.25)), "{u}/{v}: {uv}");
    }
}

/// A material whose texture is one colour everywhere renders bit for bit as the material with
/// that colour, in every strategy: evaluating a texture changes nothing else on any path.
#[test]
fn a_uniform_texture_renders_as_its_colour() {
    use photon_bench::film::Film;
    use photon_bench::strategy;
    let dir = tempfile::tempdir().unwrap();
    // A closed room (photon strategies need light to bounce), its walls and a plastic sphere
    // coloured by `reflectance`.
    let load = |reflectance: &str| {
        let text = format!(
            r#"<scene version="3.0.0">
            <sensor type="perspective"><float name="fov" value="60"/>
                <transform name="to_world"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
                <film type="hdrfilm"><integer name="width" value="6"/><integer name="height" value="6"/></film></sensor>
            <shape type="sphere"><point name="center" x="0" y="3" z="0"/><float name="radius" value="0.5"/>
                <emitter type="area"><rgb name="radiance" value="4"/></emitter></shape>
            <shape type="cube"><transform name="to_world"><scale value="4"/></transform>
                <bsdf type="twosided"><bsdf type="diffuse">{reflectance}</bsdf></bsdf></shape>
            <shape type="sphere"><point name="center" x="0" y="-2" z="0"/><float name="radius" value="1"/>
                <bsdf type="roughplastic">{}</bsdf></shape>
        </scene>"#,
            reflectance.replace("\"reflectance\"", "\"diffuse_reflectance\"")
        );
        let path = dir.path().join("room.xml");
        std::fs::write(&path, text).unwrap();
        load_scene_with_stats(&path).unwrap().0
    };
    let flat = load(r#"<rgb name="reflectance" value="0.3, 0.5, 0.7"/>"#);
    let textured = load(
        r#"<texture type="checkerboard" name="reflectance"><rgb name="color0" value="0.3, 0.5, 0.7"/>
            <rgb name="color1" value="0.3, 0.5, 0.7"/></texture>"#,
    );
    assert!(textured.materials.iter().any(|m| !m.textures.is_empty()));
    for kind in strategy::kinds() {
        let render = |scene: &Scene| {
            let mut s = strategy::build(kind, toml::Table::new()).unwrap();
            s.prepare(scene, 7).unwrap();
            let mut film = Film::new(scene.camera.width, scene.camera.height);
            s.render_pass(scene, 7, 0..2, &mut film);
            film.image().pixels
        };
        assert_eq!(render(&flat), render(&textured), "{kind}");
    }
}

/// The image's bytes are part of the scene's content hash; bad textures are refused with the
/// field and what was expected.
#[test]
fn texture_files_are_hashed_and_bad_textures_refused() {
    let dir = tempfile::tempdir().unwrap();
    let body = r#"<shape type="rectangle"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">
        <string name="filename" value="t.png"/></texture></bsdf></shape>"#;
    png(&dir.path().join("t.png"), 1, 1, &[10, 20, 30]);
    let a = load_in(dir.path(), body).unwrap().content_hash;
    png(&dir.path().join("t.png"), 1, 1, &[10, 20, 31]);
    let b = load_in(dir.path(), body).unwrap().content_hash;
    assert_ne!(a, b, "changing one texel changes the scene's hash");

    let refused = |body: &str, expect: &[&str]| {
        let err = load_in(dir.path(), body).err().expect("refused").to_string();
        assert_eq!(err.lines().count(), 1, "{err}");
        for e in expect {
            assert!(err.contains(e), "{err:?} lacks {e:?}");
        }
    };
    refused(&body.replace("t.png", "missing.png"), &["filename", "missing.png"]);
    std::fs::write(dir.path().join("junk.png"), b"not a picture").unwrap();
    refused(
        &body.replace("t.png", "junk.png"),
        &["reflectance.file", "junk.png", "PNG"],
    );
    refused(
        &body.replace("</texture>", r#"<string name="filter_type" value="cubic"/></texture>"#),
        &["reflectance.filter", "\"bilinear\" or \"nearest\""],
    );
    refused(
        r#"<shape type="rectangle"><bsdf type="diffuse"><texture type="checkerboard" name="reflectance">
            <rgb name="color0" value="1.5"/></texture></bsdf></shape>"#,
        &["reflectance", "[0, 1]"],
    );
    refused(
        r#"<shape type="rectangle"><bsdf type="diffuse"><ref name="reflectance" id="nowhere"/></bsdf></shape>"#,
        &["no top-level <texture id=\"nowhere\">"],
    );
    refused(
        r#"<shape type="rectangle"><bsdf type="diffuse"><texture type="voronoi" name="reflectance"/></bsdf></shape>"#,
        &["unsupported texture \"voronoi\""],
    );
}

/// For an anisotropic model the shading frame's first axis is ∂p/∂u, as Mitsuba's, so that the
/// model is oriented as there: along the rectangle's x, along a sphere's longitude about its own
/// z, and along the direction in which a mesh's texture coordinate u grows.
#[test]
fn shading_tangents_follow_the_texture_parameterization() {
    let dir = tempfile::tempdir().unwrap();
    let frame_s = |scene: &Scene, o: Vec3, d: Vec3| scene.intersect(&Ray::new(o, d)).unwrap().frame.s;
    let aniso =
        r#"<bsdf type="roughconductor"><float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.3"/></bsdf>"#;
    let rect = load_in(
        dir.path(),
        &format!(r#"<shape type="rectangle"><transform name="to_world"><rotate z="1" angle="30"/></transform>{aniso}</shape>"#),
    )
    .unwrap();
    let s = frame_s(&rect, Vec3::new(0.1, 0.2, 2.0), -Vec3::Z);
    let expected = Vec3::new(30f32.to_radians().cos(), 30f32.to_radians().sin(), 0.0);
    assert!((s - expected).length() < 1e-5, "rectangle: {s}");

    let sphere = load_in(
        dir.path(),
        &format!(
            r#"<shape type="sphere"><transform name="to_world"><rotate x="1" angle="90"/></transform>{aniso}</shape>"#
        ),
    )
    .unwrap();
    // Local z is world −y after the turn: at the point (1, 0, 0) longitude grows along the
    // turned local y, i.e. world +z.
    let s = frame_s(&sphere, Vec3::new(3.0, 0.0, 0.0), -Vec3::X);
    assert!((s - Vec3::Z).length() < 1e-4, "sphere: {s}");

    // A square whose u grows along world y.
    let obj = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 0 1\nvt 1 1\nvt 1 0\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
    std::fs::write(dir.path().join("turned.obj"), obj).unwrap();
    let mesh = load_in(
        dir.path(),
        &format!(r#"<shape type="obj"><string name="filename" value="turned.obj"/>{aniso}</shape>"#),
    )
    .unwrap();
    for (x, y) in [(0.5f32, -0.5f32), (-0.5, 0.5)] {
        let s = frame_s(&mesh, Vec3::new(x, y, 2.0), -Vec3::Z);
        assert!((s - Vec3::Y).length() < 1e-5, "mesh at ({x}, {y}): {s}");
    }
}

/// Number parameters read a texture's luminance, a checkerboard's colours swapped as Mitsuba
/// 3.9.1's `eval_1` swaps them: a rough conductor's `alpha_u` and `alpha_v` from two opposite
/// checkerboards (Mitsuba's textured carbon) give each cell α_u = the *other* colour of its
/// checkerboard, and the model is oriented by the tangent; a rough plastic's roughness
/// cannot be a texture (one line).
#[test]
fn textured_roughness_reads_mitsubas_eval_1() {
    use photon_bench::bsdf::Bsdf;
    let dir = tempfile::tempdir().unwrap();
    let checks = |name: &str, c0: f32, c1: f32| {
        format!(
            r#"<texture name="{name}" type="checkerboard"><transform name="to_uv"><scale x="2" y="2"/></transform>
            <float name="color0" value="{c0}"/><float name="color1" value="{c1}"/></texture>"#
        )
    };
    let body = format!(
        r#"<shape type="rectangle"><bsdf type="twosided"><bsdf type="roughconductor">{}{}</bsdf></bsdf></shape>"#,
        checks("alpha_u", 0.05, 0.3),
        checks("alpha_v", 0.3, 0.05)
    );
    let scene = load_in(dir.path(), &body).unwrap();
    assert!(scene.materials.iter().any(|m| m.is_anisotropic()));
    for (x, y) in [(-0.9f32, -0.9f32), (-0.4, -0.9), (0.1, 0.3), (0.7, -0.2)] {
        let hit = scene.intersect(&Ray::new(Vec3::new(x, y, 1.0), -Vec3::Z)).unwrap();
        let Bsdf::RoughConductor(b) = &*scene.bsdf(&hit) else {
            panic!("not a rough conductor")
        };
        let uv = scene.uv(&hit);
        let upper = |a: f32| a - a.floor() > 0.5;
        let same = upper(2.0 * uv.x) == upper(2.0 * uv.y);
        // eval would give color0 where `same`; eval_1 gives color1 there.
        let (au, av) = if same { (0.3, 0.05) } else { (0.05, 0.3) };
        assert_eq!(
            (b.distribution.alpha_u, b.distribution.alpha_v),
            (au, av),
            "at ({x}, {y})"
        );
        assert!(
            (hit.frame.to_world(Vec3::X) - Vec3::X).length() < 1e-5,
            "tangent along x"
        );
    }
    let err = load_in(
        dir.path(),
        &format!(
            r#"<shape type="rectangle"><bsdf type="roughplastic">{}</bsdf></shape>"#,
            checks("alpha", 0.1, 0.2)
        ),
    )
    .err()
    .unwrap()
    .to_string();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("alpha") && err.contains("cannot be a texture"), "{err}");
}
