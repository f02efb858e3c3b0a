//! Helpers the feature tests share (`tests/environment.rs`, `tests/plastic.rs`,
//! `tests/delta_lights.rs`, `tests/crop.rs`, `tests/lens.rs`, …): loading a scene written by
//! the test, rendering one image, comparing strategies by their image means, and checking that
//! bad input is refused with one line.

use photon_bench::film::{Film, Image};
use photon_bench::scene::Scene;
use photon_bench::scene::load::load_scene_with_stats;
use photon_bench::strategy;
use std::path::Path;

#[allow(dead_code)]
/// Writes scene `text` to `dir/name` (the extension says TOML or Mitsuba XML) and loads it.
pub fn load_text(dir: &Path, name: &str, text: &str) -> photon_bench::error::Result<Scene> {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    load_scene_with_stats(&path).map(|(s, _)| s)
}

#[allow(dead_code)]
/// One image of `scene` by strategy `kind` with TOML `params`: `spp` samples per pixel under
/// `seed`; the strategy must accept the scene.
pub fn render_image(scene: &Scene, kind: &str, params: &str, spp: u32, seed: u64) -> Image {
    let mut s = strategy::build(kind, toml::from_str(params).unwrap()).unwrap();
    strategy::check_scene(&*s, scene).unwrap();
    s.prepare(scene, seed).unwrap();
    let mut film = Film::new(scene.camera.width, scene.camera.height);
    s.render_pass(scene, seed, 0..spp, &mut film);
    film.image()
}

#[allow(dead_code)] // not every test binary that includes this module compares means
/// Mean (over 6 seeds) of the image-mean of r + g + b that strategy `kind` with `params`
/// renders at `spp`, and its standard error; the strategy must accept the scene.
pub fn image_mean(scene: &Scene, kind: &str, params: &str, spp: u32) -> (f64, f64) {
    let v: Vec<f64> = (0..6u64)
        .map(|seed| {
            let img = render_image(scene, kind, params, spp, seed);
            img.pixels.iter().map(|p| f64::from(p.x + p.y + p.z)).sum::<f64>() / img.pixels.len() as f64
        })
        .collect();
    let m = v.iter().sum::<f64>() / v.len() as f64;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
    (m, (var / v.len() as f64).sqrt())
}

#[allow(dead_code)]
/// Asserts that an unbiased strategy's mean agrees with the baseline's within 4 standard errors.
pub fn assert_agrees(kind: &str, (m, se): (f64, f64), (m0, se0): (f64, f64)) {
    let z = (m - m0) / (se * se + se0 * se0).sqrt();
    assert!(z.abs() < 4.0, "{kind}: {m} ± {se} vs path {m0} ± {se0} (z = {z:.2})");
}

#[allow(dead_code)]
/// Asserts that `bdpt`, `light`, `photon_guided` and `mlt` (defaults, 64 spp) agree with `path`
/// on `scene`: the unbiased strategies that start paths on lights or mutate them.
pub fn assert_light_starting_strategies_agree(scene: &Scene) {
    let base = image_mean(scene, "path", "", 64);
    for kind in ["bdpt", "light", "photon_guided", "mlt"] {
        assert_agrees(kind, image_mean(scene, kind, "", 64), base);
    }
}

/// Asserts that `err` is one line holding every text of `expect` (a field name, the value).
#[allow(dead_code)] // not every test binary that includes this module refuses input
pub fn assert_refused(err: &str, expect: &[&str]) {
    assert_eq!(err.lines().count(), 1, "{err}");
    for e in expect {
        assert!(err.contains(e), "{err:?} lacks {e:?}");
    }
}

#[allow(dead_code)]
/// Over `images` (one per seed), the mean of r + g + b over `pixels`, averaged, and its
/// standard error.
pub fn region_mean(images: &[Image], pixels: &[(u32, u32)]) -> (f64, f64) {
    let per_image: Vec<f64> = images
        .iter()
        .map(|img| {
            let sum: f64 = pixels
                .iter()
                .map(|&(x, y)| f64::from(img.get(x, y).element_sum()))
                .sum();
            sum / pixels.len() as f64
        })
        .collect();
    let n = per_image.len() as f64;
    let m = per_image.iter().sum::<f64>() / n;
    let var = per_image.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

#[allow(dead_code)]
/// The pixels of `scene`'s image in blocks of 3 × 3, row by row (the unit the block-by-block
/// comparisons judge).
pub fn blocks(scene: &Scene) -> Vec<Vec<(u32, u32)>> {
    let (w, h) = (scene.camera.width, scene.camera.height);
    (0..h)
        .step_by(3)
        .flat_map(|by| {
            (0..w)
                .step_by(3)
                .map(move |bx| (by..by + 3).flat_map(|y| (bx..bx + 3).map(move |x| (x, y))).collect())
        })
        .collect()
}

#[allow(dead_code)]
/// Per block of [`blocks`], the mean of r + g + b over 6 seeds of `kind` with `params` at `spp`
/// and its standard error.
pub fn block_means(scene: &Scene, kind: &str, params: &str, spp: u32) -> Vec<(f64, f64)> {
    let images: Vec<Image> = (0..6)
        .map(|seed| render_image(scene, kind, params, spp, seed))
        .collect();
    blocks(scene).iter().map(|b| region_mean(&images, b)).collect()
}

#[allow(dead_code)]
/// Whether the primary ray through any point of an 8 × 8 grid over any pixel of `block` meets
/// `what` (its first hit, `None` where it leaves the scene).
pub fn block_sees(
    scene: &Scene,
    block: &[(u32, u32)],
    what: impl Fn(Option<photon_bench::scene::SurfaceHit>) -> bool,
) -> bool {
    let grid = |i: u32| (i as f32 + 0.5) / 8.0;
    block.iter().any(|&(x, y)| {
        (0..64).any(|j| {
            let raster = glam::Vec2::new(x as f32 + grid(j % 8), y as f32 + grid(j / 8));
            what(scene.intersect(&scene.camera.generate_ray(raster)))
        })
    })
}

#[allow(dead_code)]
/// Judges `kind` at `spp` against `reference` (its [`block_means`]) block by block: within 4
/// standard errors plus `slack` × the reference, wherever that tolerance is under 10 % of the
/// block's value and `skip` does not exclude the block; at least 6 blocks must be judged.
pub fn judge_blocks(
    scene: &Scene,
    reference: &[(f64, f64)],
    (kind, params, spp, slack): (&str, &str, u32, f64),
    skip: impl Fn(&[(u32, u32)]) -> bool,
) {
    let blocks = blocks(scene);
    let mut judged = 0;
    for (b, ((m, se), (m0, se0))) in block_means(scene, kind, params, spp)
        .into_iter()
        .zip(reference.iter().copied())
        .enumerate()
    {
        // Blocks that are exact in every strategy (a constant sky) are judged to 10⁻⁵.
        let tol = 4.0 * (se * se + se0 * se0).sqrt() + (slack + 1e-5) * m0;
        if tol > 0.1 * m0 || skip(&blocks[b]) {
            continue;
        }
        judged += 1;
        assert!(
            (m - m0).abs() < tol,
            "{kind}, block {b}: {m} ± {se} vs reference {m0} ± {se0}"
        );
    }
    assert!(judged >= 6, "{kind}: only {judged} of {} blocks judged", blocks.len());
}

#[allow(dead_code)]
/// Asserts that `kind` renders `scene` bit-identically on 1 and on 3 threads (2 spp, `seed`).
pub fn assert_bit_identical_across_threads(scene: &Scene, kind: &str, seed: u64) {
    let bits = |threads: usize| -> Vec<u32> {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let img = pool.install(|| render_image(scene, kind, "", 2, seed));
        img.pixels.iter().flat_map(|p| p.to_array()).map(f32::to_bits).collect()
    };
    assert_eq!(bits(1), bits(3), "{kind}");
}

#[allow(dead_code)]
/// A small Mitsuba 3 scene around `body`: an 8 × 8 camera looking down −z from z = 9 and a
/// sphere light high above.
pub fn mitsuba_scene(body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 9" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
    <shape type="sphere"><point name="center" x="0" y="30" z="0"/><float name="radius" value="0.5"/>
        <emitter type="area"><rgb name="radiance" value="4"/></emitter></shape>
    {body}
</scene>"#
    )
}

/// A grey floor (ρ = 0.5, material `grey`) seen from straight above, 24 × 24 pixels, lit by
/// `light` alone (a `[[lights]]` table's body).
#[allow(dead_code)]
pub fn floor_under(light: &str) -> String {
    format!(
        r#"[camera]
eye = [0, 3, 0]
look_at = [0, 0, 0]
up = [0, 0, -1]
fov_y = 40
resolution = [24, 24]

[materials.grey]
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]

[[shapes]]
type = "quad"
material = "grey"
center = [0, 0, 0]
size = [6, 6]
facing = "+y"

[[lights]]
{light}
"#
    )
}

#[allow(dead_code)]
/// Writes an 8-bit RGB PNG of `rows` (row 0 the top) to `path`.
pub fn write_png<const W: usize>(path: &Path, rows: &[[[u8; 3]; W]]) {
    let mut img = image::RgbImage::new(W as u32, rows.len() as u32);
    for (r, row) in rows.iter().enumerate() {
        for (c, t) in row.iter().enumerate() {
            img.put_pixel(c as u32, r as u32, image::Rgb(*t));
        }
    }
    img.save(path).unwrap();
}

#[allow(dead_code)]
/// The point of the floor y = 0 that the centre of pixel (x, y) sees.
pub fn floor_point(scene: &Scene, x: u32, y: u32) -> glam::Vec3 {
    let ray = scene
        .camera
        .generate_ray(glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
    ray.o + ray.d * (-ray.o.y / ray.d.y)
}

#[allow(dead_code)]
/// [`floor_under`] at 12 × 12 pixels with a grey ball on the floor: a room whose light reaches
/// the camera by several bounces, for comparing strategies.
pub fn room_under(light: &str) -> String {
    floor_under(light).replace("resolution = [24, 24]", "resolution = [12, 12]")
        + "\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"grey\"\ncenter = [0.3, 0.3, 0.2]\nradius = 0.3\n"
}
