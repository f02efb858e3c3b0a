//! Pixel filters (`camera.filter`, Mitsuba's `rfilter`): eye samples drawn by the filter and
//! splats spread by it estimate the same pixels (light tracing and bidirectional path tracing
//! agree with `path` block by block under a Gaussian and a tent), rendering stays bit-identical
//! across thread counts, and Mitsuba's rfilters are imported with their defaults or refused.

use photon_bench::film::{Film, Image};
use photon_bench::pixel_filter::{FilterKind, PixelFilter};
use photon_bench::scene::Scene;
use photon_bench::scene::load::{load_scene_bytes, load_scene_with_stats};
use photon_bench::strategy;
use std::path::Path;

/// The Cornell box (diffuse only: light tracing sees all of it) at 16 × 16 with `filter`.
fn scene_with(filter: &str) -> Scene {
    let file = Path::new("scenes/cornell-box.toml");
    let text = std::fs::read_to_string(file).unwrap().replace(
        "resolution = [256, 256]",
        &format!("resolution = [16, 16]\nfilter = {filter}"),
    );
    let (scene, _) = load_scene_bytes(file, text.as_bytes()).unwrap();
    assert_eq!(scene.camera.width, 16, "the resolution replacement must apply");
    scene
}

fn render(scene: &Scene, kind: &str, params: &str, seed: u64, spp: u32, threads: usize) -> Image {
    let mut s = strategy::build(kind, toml::from_str(params).unwrap()).unwrap();
    s.prepare(scene, seed).unwrap();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| {
        let mut film = Film::new(scene.camera.width, scene.camera.height);
        s.render_pass(scene, seed, 0..spp, &mut film);
        film.image()
    })
}

/// Means and standard errors over `seeds` renders of the 16 blocks of 4 × 4 pixels (r + g + b).
fn block_means(scene: &Scene, kind: &str, spp: u32, seeds: u64) -> Vec<(f64, f64)> {
    let per_seed: Vec<Vec<f64>> = (0..seeds)
        .map(|seed| {
            let img = render(scene, kind, "max_depth = 6", seed, spp, 2);
            let mut blocks = vec![0.0f64; 16];
            for y in 0..16 {
                for x in 0..16 {
                    let p = img.get(x, y);
                    blocks[(y / 4 * 4 + x / 4) as usize] += f64::from(p.x + p.y + p.z) / 16.0;
                }
            }
            blocks
        })
        .collect();
    (0..16)
        .map(|b| {
            let v: Vec<f64> = per_seed.iter().map(|s| s[b]).collect();
            let m = v.iter().sum::<f64>() / v.len() as f64;
            let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
            (m, (var / v.len() as f64).sqrt())
        })
        .collect()
}

/// Light tracing splats every contribution over the pixels whose filter covers it; `path`
/// draws each pixel's samples from that same filter. Both estimate the same filtered image, so
/// their 4 × 4-pixel block means agree within 4.5 standard errors (16 blocks), under a Gaussian
/// of σ = 0.8 pixel (radius 3.2: blocks exchange light across their edges) and a tent; `bdpt`
/// (whose t = 1 technique splats) agrees too. A splat left in its own pixel would darken the
/// blocks next to the bright ceiling light and brighten its own.
#[test]
fn splatting_and_eye_sampling_estimate_the_same_filtered_pixels() {
    for filter in [
        "{ type = \"gaussian\", stddev = 0.8 }",
        "{ type = \"tent\", radius = 1.5 }",
    ] {
        let scene = scene_with(filter);
        let path = block_means(&scene, "path", 64, 8);
        for (kind, spp) in [("light", 16), ("bdpt", 8)] {
            let other = block_means(&scene, kind, spp, 8);
            for (b, ((m0, s0), (m, s))) in path.iter().zip(&other).enumerate() {
                let z = (m - m0) / (s0 * s0 + s * s).sqrt();
                assert!(
                    z.abs() < 4.5,
                    "{filter}, {kind}, block {b}: {m} ± {s} vs path {m0} ± {s0} (z = {z:.2})"
                );
            }
        }
    }
}

/// The filter draws and splats in a fixed order: images are bit-identical on 1 and 3 threads.
#[test]
fn filtered_images_are_bit_identical_across_thread_counts() {
    let scene = scene_with("{ type = \"gaussian\" }");
    for kind in ["path", "light", "bdpt", "vcm", "mlt"] {
        let bits =
            |img: &Image| -> Vec<u32> { img.pixels.iter().flat_map(|p| p.to_array()).map(f32::to_bits).collect() };
        let (one, three) = (render(&scene, kind, "", 3, 2, 1), render(&scene, kind, "", 3, 2, 3));
        assert_eq!(bits(&one), bits(&three), "{kind}");
    }
}

fn load_xml(dir: &Path, film: &str) -> photon_bench::error::Result<Scene> {
    let text = format!(
        r#"<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        {film}</sensor>
    <shape type="sphere"><bsdf type="diffuse"/></shape>
    <emitter type="constant"/>
</scene>"#
    );
    let path = dir.join("s.xml");
    std::fs::write(&path, text).unwrap();
    load_scene_with_stats(&path).map(|(s, _)| s)
}

/// Mitsuba's film filters with its defaults: no rfilter (or no film) is its Gaussian of σ = ½,
/// `tent` has radius 1; filters with negative lobes are refused with one line; TOML checks
/// the parameters.
#[test]
fn filters_are_imported_as_mitsuba_defines_them() {
    let dir = tempfile::tempdir().unwrap();
    let filter = |film: &str| load_xml(dir.path(), film).unwrap().camera.filter;
    let gaussian = PixelFilter::separable(FilterKind::Gaussian { stddev: 0.5 });
    assert_eq!(filter(""), gaussian);
    assert_eq!(filter(r#"<film type="hdrfilm"/>"#), gaussian);
    assert_eq!(
        filter(r#"<film type="hdrfilm"><rfilter type="box"/></film>"#),
        PixelFilter::Box
    );
    assert_eq!(
        filter(r#"<film type="hdrfilm"><rfilter type="tent"/></film>"#),
        PixelFilter::separable(FilterKind::Tent { radius: 1.0 })
    );
    assert_eq!(
        filter(r#"<film type="hdrfilm"><rfilter type="gaussian"><float name="stddev" value="0.25"/></rfilter></film>"#),
        PixelFilter::separable(FilterKind::Gaussian { stddev: 0.25 })
    );
    let e = load_xml(dir.path(), r#"<film type="hdrfilm"><rfilter type="lanczos"/></film>"#)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.lines().count() == 1 && e.contains("lanczos") && e.contains("negative lobes"),
        "{e}"
    );

    let toml = |filter: &str| {
        let file = Path::new("scenes/cornell-box.toml");
        let text =
            std::fs::read_to_string(file)
                .unwrap()
                .replacen("[camera]", &format!("[camera]\nfilter = {filter}"), 1);
        load_scene_bytes(file, text.as_bytes()).map(|(s, _)| s)
    };
    assert_eq!(
        toml("{ type = \"tent\", radius = 2 }").unwrap().camera.filter,
        PixelFilter::separable(FilterKind::Tent { radius: 2.0 })
    );
    for (bad, field) in [
        ("{ type = \"gaussian\", stddev = 0 }", "camera.filter.stddev"),
        ("{ type = \"tent\", radius = 100 }", "camera.filter.radius"),
        ("{ type = \"mitchell\" }", "mitchell"),
    ] {
        let e = toml(bad).err().unwrap().to_string();
        assert!(e.lines().count() == 1 && e.contains(field), "{bad}: {e}");
    }
    // The filter is part of what a reference was made with.
    assert_ne!(
        toml("{ type = \"gaussian\" }").unwrap().content_hash,
        toml("{ type = \"box\" }").unwrap().content_hash
    );
}
