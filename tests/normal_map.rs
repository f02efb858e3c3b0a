//! Normal and bump maps (TOML `type = "normal_map"` / `"bump_map"`, Mitsuba's `normalmap` /
//! `bumpmap`): the model a map gives against its closed forms, every strategy rendering a
//! mapped room as `path` does, Mitsuba's elements read (textures raw, wrapped or wrapping), bad
//! input refused in one line.

mod agreement;

use agreement::{
    assert_agrees, assert_refused, floor_under, image_mean, load_text as load, mitsuba_scene, render_image as render,
};
use glam::{Vec2, Vec3};
use photon_bench::bsdf::{Bsdf, TransportMode};
use photon_bench::scene::Scene;
use std::f32::consts::FRAC_1_PI;

/// A grey floor (ρ = 0.5) seen from above under a sun shining straight down (E = 2), its
/// material `grey` wrapped in a normal map of colours `normals` (a TOML value).
fn floor_in_sun(normals: Option<&str>) -> String {
    let floor = floor_under("type = \"directional\"\ndirection = [0, -1, 0]\nirradiance = [2, 2, 2]");
    match normals {
        None => floor,
        Some(c) => floor.replace(
            "type = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]",
            &format!(
                "type = \"normal_map\"\nnormals = {c}\nbsdf = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}"
            ),
        ),
    }
}

/// Under light falling along the surface normal n, a diffuse floor reflects ρ/π · E (n′ · n)
/// with n′ its mapped normal (the shadowing G₁ of a light along n is 1), and a map colour c
/// tilts n′ away from n by the angle whose cosine is (2c − 1)_z / |2c − 1| whatever the
/// tangent's direction: c = (0.8, 0.5, 0.9) gives 2c − 1 = (0.6, 0, 0.8), so 0.8 ρ/π E
/// everywhere; c = (0.5, 0.5, 1), the flat normal, gives the unmapped floor's ρ/π E; a map
/// tilting the normal below the horizon (c_z < ½, here (0.5, 0.5, 0.2), n′ = −n) sees the sun
/// from behind: black, as Mitsuba's one-sided models. Next-event estimation toward a
/// directional light has no variance at a point.
#[test]
fn a_normal_map_shades_a_floor_as_its_tilted_normal() {
    let dir = tempfile::tempdir().unwrap();
    let flat = FRAC_1_PI * 0.5 * 2.0;
    for (normals, want) in [
        (None, flat),
        (Some("[0.5, 0.5, 1.0]"), flat),
        (Some("[0.8, 0.5, 0.9]"), 0.8 * flat),
        (Some("[0.5, 0.8, 0.9]"), 0.8 * flat),
        (Some("[0.2, 0.5, 0.9]"), 0.8 * flat),
    ] {
        let scene = load(dir.path(), "floor.toml", &floor_in_sun(normals)).unwrap();
        let img = render(&scene, "path", "max_depth = 1", 16, 1);
        for p in &img.pixels {
            assert!(
                (*p - Vec3::splat(want)).abs().max_element() < 1e-5 * want,
                "{normals:?}: {p} vs {want}"
            );
        }
    }
    // A one-sided floor whose mapped normal points below the surface is black in the sun.
    let one_sided = floor_in_sun(Some("[0.5, 0.5, 0.2]")).replace(
        "bsdf = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }",
        "bsdf = { type = \"one_sided\", bsdf = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] } }",
    );
    let scene = load(dir.path(), "floor.toml", &one_sided).unwrap();
    let img = render(&scene, "path", "max_depth = 1", 4, 1);
    assert!(
        img.pixels.iter().all(|p| *p == Vec3::ZERO),
        "lit from behind its mapped normal"
    );
}

/// A sun 45° off the normal: the light direction l is shadowed by Smith's GGX G₁ with
/// α² = tan²θ′ / 8 (θ′ the map's tilt, 37° here: α² = 0.0703, G₁(45°) = 0.98302) [Chiang et al.
/// 2019], as Mitsuba 3.9's `normalmap`. Two maps tilting the normal by ±0.6 along the tangent
/// give ρ/π E (l · n′) G₁ each, whatever direction the tangent has, and together
/// ρ/π E · 2 · 0.8 (l · n) G₁.
#[test]
fn an_oblique_sun_is_shadowed_by_the_maps_tilt() {
    let dir = tempfile::tempdir().unwrap();
    let sun = |normals: &str| {
        floor_in_sun(Some(normals)).replace("direction = [0, -1, 0]", "direction = [0.7071068, -0.7071068, 0]")
    };
    let mean = |normals: &str| {
        let scene = load(dir.path(), "floor.toml", &sun(normals)).unwrap();
        let img = render(&scene, "path", "max_depth = 1", 4, 1);
        let (first, rest) = img.pixels.split_first().unwrap();
        assert!(
            rest.iter().all(|p| (*p - *first).abs().max_element() < 1e-5),
            "{normals}: uniform floor"
        );
        first.x
    };
    let g1 = 2.0 / (1.0 + (1.0 + 0.36 / (8.0 * 0.64) * 1.0f32).sqrt());
    let want = FRAC_1_PI * 0.5 * 2.0 * 0.8 * std::f32::consts::FRAC_1_SQRT_2 * g1;
    let got = 0.5 * (mean("[0.8, 0.5, 0.9]") + mean("[0.2, 0.5, 0.9]"));
    assert!((got / want - 1.0).abs() < 1e-5, "{got} vs {want} (G₁ = {g1})");
}

/// The model a map gives, read at a hit: the hit keeps its shading frame, whose tangent is ∂p/∂u,
/// and a diffuse model's f |cos θ| toward l is ρ/π (l · n′) G₁(l) with n′ the map's vector in
/// that frame, normalised.
#[test]
fn the_mapped_model_reflects_about_the_maps_vector_in_the_surface_frame() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(dir.path(), "floor.toml", &floor_in_sun(Some("[0.9, 0.3, 0.8]"))).unwrap();
    let ray = scene.camera.generate_ray(Vec2::new(5.5, 9.5));
    let hit = scene.intersect(&ray).expect("the floor");
    assert!(
        (hit.frame.n - Vec3::Y).length() < 1e-6,
        "the hit keeps its frame: {}",
        hit.frame.n
    );
    let bsdf = scene.bsdf(&hit);
    let Bsdf::NormalMapped(mapped) = &*bsdf else {
        panic!("a normal-mapped model: {bsdf:?}")
    };
    let m = Vec3::new(0.8, -0.4, 0.6).normalize();
    assert!((mapped.normal - m).length() < 1e-6, "{}", mapped.normal);
    let wo = hit.frame.to_local(-ray.d);
    for k in 0..64 {
        let (a, z) = (k as f32 * 2.4, (k as f32 + 0.5) / 64.0);
        let r = (1.0 - z * z).sqrt();
        let wi = Vec3::new(r * a.cos(), r * a.sin(), z);
        let want = 0.5 * FRAC_1_PI * wi.dot(m).max(0.0) * mapped.shadowing(z);
        let got = bsdf.eval(wo, wi, TransportMode::Radiance).x * z;
        assert!((got - want).abs() < 1e-5, "wi = {wi}: {got} vs {want}");
    }
}

/// A room whose floor carries a bump map and whose back wall a normal map (the same 4 × 4 PNG
/// of tilted tiles, read raw: as heights, its luminance) under an area light.
fn mapped_room(png: &str) -> String {
    format!(
        r#"[camera]
eye = [0, 1, 2.8]
look_at = [0, 0.6, 0]
fov_y = 55
resolution = [12, 9]

[materials.white]
type = "diffuse"
reflectance = [0.7, 0.7, 0.7]
[materials.tiles]
type = "bump_map"
height = {{ type = "bitmap", file = "{png}", raw = true }}
scale = 0.05
bsdf = {{ type = "diffuse", reflectance = [0.6, 0.5, 0.4] }}
[materials.glossy_tiles]
type = "normal_map"
normals = {{ type = "bitmap", file = "{png}", raw = true }}
bsdf = {{ type = "rough_conductor", material = "Cu", alpha = 0.3 }}

[[shapes]]
type = "box"
material = "white"
min = [-1, 0, -1]
max = [1, 2, 3]
[[shapes]]
type = "quad"
material = "tiles"
center = [0, 0.001, 0.5]
size = [2, 3]
facing = "+y"
[[shapes]]
type = "quad"
material = "glossy_tiles"
center = [0, 1, -0.999]
size = [2, 2]
facing = "+z"
[[shapes]]
type = "quad"
material = "white"
center = [0, 1.99, 0.5]
size = [0.6, 0.6]
facing = "-y"
emission = {{ radiance = [6, 6, 6] }}
"#
    )
}

/// Writes a 4 × 4 map of normals tilted up to 40° in every direction.
fn write_tiles(dir: &std::path::Path) -> String {
    let mut img = image::RgbImage::new(4, 4);
    for (x, y, px) in img.enumerate_pixels_mut() {
        let (a, t) = (x as f32 * 1.7 + y as f32 * 0.9, (x + y) as f32 * 0.1);
        let v = Vec3::new(t * a.cos(), t * a.sin(), 1.0).normalize();
        let c = (v + Vec3::ONE) * 0.5 * 255.0;
        *px = image::Rgb([c.x.round() as u8, c.y.round() as u8, c.z.round() as u8]);
    }
    img.save(dir.join("tiles.png")).unwrap();
    "tiles.png".into()
}

/// Every strategy sees the mapped model (the material's model at the hit or at a path vertex,
/// the bump map's normal made from the vertex's primitive), so unbiased ones agree with `path` within 4 standard errors over 6 seeds, `vcm`
/// within 5 %, and `photon_map` keeps the ratio to `path` it has without the map.
#[test]
fn strategies_render_a_normal_mapped_room_as_path_does() {
    let dir = tempfile::tempdir().unwrap();
    let png = write_tiles(dir.path());
    let scene: Scene = load(dir.path(), "room.toml", &mapped_room(&png)).unwrap();
    let path = image_mean(&scene, "path", "max_depth = 6", 256);
    // The map changes the image: the unmapped room differs by many standard errors.
    let plain = mapped_room(&png)
        .replace("type = \"bump_map\"\nheight = { type = \"bitmap\", file = \"tiles.png\", raw = true }\nscale = 0.05\nbsdf = { type = \"diffuse\", reflectance = [0.6, 0.5, 0.4] }", "type = \"diffuse\"\nreflectance = [0.6, 0.5, 0.4]")
        .replace("type = \"normal_map\"\nnormals = { type = \"bitmap\", file = \"tiles.png\", raw = true }\nbsdf = { type = \"rough_conductor\", material = \"Cu\", alpha = 0.3 }", "type = \"rough_conductor\"\nmaterial = \"Cu\"\nalpha = 0.3");
    assert!(!plain.contains("normal_map") && !plain.contains("bump_map"));
    let unmapped = image_mean(
        &load(dir.path(), "plain.toml", &plain).unwrap(),
        "path",
        "max_depth = 6",
        256,
    );
    let z = (unmapped.0 - path.0) / (unmapped.1.powi(2) + path.1.powi(2)).sqrt();
    assert!(z.abs() > 8.0, "the map must matter: z = {z:.1}");
    for (kind, params, spp) in [
        ("bdpt", "max_depth = 6", 16),
        ("light", "max_depth = 6", 32),
        ("photon_guided", "max_depth = 6", 64),
        ("mlt", "max_depth = 6\nchains = 512", 4),
    ] {
        assert_agrees(kind, image_mean(&scene, kind, params, spp), path);
    }
    let (m, _) = image_mean(&scene, "vcm", "max_depth = 6", 16);
    assert!((m / path.0 - 1.0).abs() < 0.05, "vcm: {m} vs path {}", path.0);
    // The final gather's density estimation is 8 % brighter than `path` in this small room with
    // or without the map; the map must not change that ratio.
    let gathered = image_mean(&scene, "photon_map", "max_depth = 6", 4).0 / path.0;
    let plain_scene = load(dir.path(), "plain.toml", &plain).unwrap();
    let plain_gathered = image_mean(&plain_scene, "photon_map", "max_depth = 6", 4).0 / unmapped.0;
    assert!(
        (gathered / plain_gathered - 1.0).abs() < 0.02,
        "photon_map / path: {gathered} mapped, {plain_gathered} unmapped"
    );
}

/// A Mitsuba rectangle (side 2: ∂p/∂u = 2 x̂, ∂p/∂v = ±2 ŷ) under a bump map of a 2-texel ramp
/// (heights 0 and 1, bilinear and repeated: slopes ∂h/∂u = ±2 everywhere) scaled by ½, lit by a
/// sun along its normal. The displaced ∂p/∂u is (2, 0, ±1), ∂p/∂v (0, ±2, 0): the normal is
/// (∓2, 0, 4) / √20 wherever the slope's sign, so the floor reflects ρ/π E · 4 / √20.
#[test]
fn a_bump_map_tilts_the_normal_by_the_heights_slope() {
    let dir = tempfile::tempdir().unwrap();
    image::GrayImage::from_raw(2, 1, vec![0, 255])
        .unwrap()
        .save(dir.path().join("ramp.png"))
        .unwrap();
    let scene = |scale: &str| {
        format!(
            r#"<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="20"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
    <emitter type="directional"><vector name="direction" x="0" y="0" z="-1"/><rgb name="irradiance" value="2"/></emitter>
    <shape type="rectangle"><bsdf type="bumpmap"><float name="scale" value="{scale}"/>
        <texture type="bitmap" name="ramp"><string name="filename" value="ramp.png"/><boolean name="raw" value="true"/></texture>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></bsdf></shape>
</scene>"#
        )
    };
    for (scale, cos) in [("0.5", 4.0 / 20.0f32.sqrt()), ("0", 1.0)] {
        let scene = load(dir.path(), "bump.xml", &scene(scale)).unwrap();
        let img = render(&scene, "path", "max_depth = 1", 16, 1);
        let want = FRAC_1_PI * 0.5 * 2.0 * cos;
        for p in &img.pixels {
            assert!(
                (*p - Vec3::splat(want)).abs().max_element() < 1e-5,
                "scale {scale}: {p} vs {want}"
            );
        }
    }
}

/// Mitsuba's `normalmap` and `bumpmap` around a BSDF (as its documentation scenes write them),
/// inside `twosided` and inside a `mask`: read with the nested model's sidedness (one-sided bare,
/// mirrored below the surface in `twosided`); exported and read back, the same model.
#[test]
fn mitsuba_maps_are_read_and_exported() {
    let dir = tempfile::tempdir().unwrap();
    let png = write_tiles(dir.path());
    let texture = |name: &str| {
        format!(
            r#"<texture name="{name}" type="bitmap"><boolean name="raw" value="true"/><string name="filename" value="{png}"/></texture>"#
        )
    };
    for (map, bumped) in [
        (
            format!(
                r#"<bsdf type="normalmap">{}<bsdf type="diffuse"/></bsdf>"#,
                texture("normalmap")
            ),
            false,
        ),
        (
            format!(
                r#"<bsdf type="bumpmap"><float name="scale" value="0.1"/>{}<bsdf type="diffuse"/></bsdf>"#,
                texture("h")
            ),
            true,
        ),
    ] {
        for (bsdf, one_sided) in [
            (map.clone(), true),
            (format!(r#"<bsdf type="twosided">{map}</bsdf>"#), false),
            (
                format!(r#"<bsdf type="mask"><float name="opacity" value="0.5"/>{map}</bsdf>"#),
                true,
            ),
        ] {
            let xml = mitsuba_scene(&format!(r#"<shape type="rectangle">{bsdf}</shape>"#));
            let path = dir.path().join("scene.xml");
            std::fs::write(&path, &xml).unwrap();
            let scene = photon_bench::scene::load::load_scene_with_stats(&path)
                .unwrap_or_else(|e| panic!("{bsdf}: {e}"))
                .0;
            let m = scene
                .materials
                .iter()
                .find(|m| matches!(m.bsdf, Bsdf::NormalMapped(_)))
                .expect(&bsdf);
            let Bsdf::NormalMapped(b) = &m.bsdf else { unreachable!() };
            assert_eq!(matches!(b.nested, Bsdf::OneSided(_)), one_sided, "{bsdf}");
            assert_eq!(m.bump.is_some(), bumped, "{bsdf}");
            let out = dir.path().join("back.xml");
            photon_bench::scene::export::export_file(&path, &out).unwrap();
            let back = photon_bench::scene::load::load_scene_with_stats(&out).unwrap().0;
            assert!(
                back.materials
                    .iter()
                    .any(|x| x.bsdf == m.bsdf && x.bump.is_some() == bumped),
                "{bsdf}: exported as {}",
                std::fs::read_to_string(&out).unwrap()
            );
        }
    }
}

#[test]
fn bad_normal_maps_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let toml =
        |material: &str| floor_in_sun(None).replace("type = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]", material);
    for (material, expect) in [
        (
            "type = \"normal_map\"\nnormals = [0.5, 0.5, 1]\nbsdf = { type = \"mask\", opacity = 0.5, bsdf = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] } }",
            &["materials.grey.bsdf", "a mask goes around them"][..],
        ),
        (
            "type = \"normal_map\"\nnormals = [0.5, 2, 1]\nbsdf = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }",
            &["materials.grey.normals"][..],
        ),
        (
            "type = \"blend\"\nweight = 0.5\nbsdfs = [{ type = \"normal_map\", normals = [0.5, 0.5, 1], bsdf = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] } }, { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }]",
            &["materials.grey.bsdfs[0]", "normal map"][..],
        ),
        (
            "type = \"normal_map\"\nnormals = { type = \"bitmap\", file = \"missing.png\", raw = true }\nbsdf = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }",
            &["materials.grey.normals.file", "missing.png"][..],
        ),
        (
            "type = \"bump_map\"\nheight = { type = \"bitmap\", file = \"missing.png\", raw = true }\nbsdf = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }",
            &["materials.grey.height.file", "missing.png"][..],
        ),
        (
            "type = \"bump_map\"\nheight = 0.5\nscale = nan\nbsdf = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }",
            &["materials.grey.scale", "finite"][..],
        ),
        (
            "type = \"bump_map\"\nheight = 0.5\nbsdf = { type = \"normal_map\", normals = [0.5, 0.5, 1], bsdf = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] } }",
            &["materials.grey.bsdf", "bump map"][..],
        ),
    ] {
        let Err(err) = load(dir.path(), "floor.toml", &toml(material)) else {
            panic!("{material}: accepted")
        };
        let err = err.to_string();
        assert_refused(&err, expect);
    }
    for (bsdf, expect) in [
        (r#"<bsdf type="normalmap"><bsdf type="diffuse"/></bsdf>"#, "normalmap"),
        (r#"<bsdf type="bumpmap"><bsdf type="diffuse"/></bsdf>"#, "bumpmap"),
    ] {
        let xml = mitsuba_scene(&format!(r#"<shape type="rectangle">{bsdf}</shape>"#));
        let Err(err) = load(dir.path(), "scene.xml", &xml) else {
            panic!("{bsdf} without its texture: accepted")
        };
        let err = err.to_string();
        assert_refused(&err, &[expect]);
    }
}
