//! Photon-map figures written beside a cell's renders.
//!
//! - Photon distribution images [Fan et al. 2005, Fig. 2; Christensen 1999, Fig. 1a]: where a
//!   strategy's global-map photons lie, as the camera sees them. Each photon in front of the
//!   camera and visible from the eye counts in the pixel it projects to; counts are shown on a
//!   log scale (viridis, black for no photon), so standard photon mapping's photons spread over
//!   everything the lights reach while Metropolis photon sampling's gather where the final
//!   gather looks.
//! - Christensen 1999, Fig. 1 (b)–(e), drawn by the strategy itself
//!   ([`crate::strategy::Strategy::figures`]) and written as sRGB previews like the renders.
//!
//! [`FIGURES`] lists every suffix with its caption; `summary.md` and `index.html` link the
//! files a run wrote ([`figure_links`]).

use super::rows::Row;
use crate::color::viridis;
use crate::error::Result;
use crate::film::write_rgb8_png;
use crate::geometry::spawn_shadow_ray;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use std::path::Path;

/// Suffix of a cell's photon distribution image (Fig. 1a).
pub const PHOTONS_PNG: &str = "_photons.png";
/// Suffix of the irradiance estimated at the image points (Fig. 1b).
pub const IRRADIANCE_PNG: &str = "_fig1b_irradiance.png";
/// Suffix of the precomputed irradiance at the photons (Fig. 1c, 1d).
pub const PRECOMPUTED_PNG: &str = "_fig1cd_precomputed.png";
/// Suffix of the radiance the final gather reads (Fig. 1e).
pub const GATHER_SEES_PNG: &str = "_fig1e_gather_sees.png";

/// Every figure a cell may write, with its caption, in the paper's order.
pub const FIGURES: [(&str, &str); 4] = [
    (
        PHOTONS_PNG,
        "(a) global photon map: visible photons per pixel, log scale (viridis)",
    ),
    (
        IRRADIANCE_PNG,
        "(b) irradiance estimated from the global map at each pixel's first diffuse hit, shown as E/π",
    ),
    (
        PRECOMPUTED_PNG,
        "(c, d) precomputed irradiance at the photons that hold it, as the camera sees them, shown as E/π",
    ),
    (
        GATHER_SEES_PNG,
        "(e) what final-gather rays read at each pixel's first diffuse hit (ρ/π · E, or the map's radiance estimate)",
    ),
];

/// The figures of `scene`'s cells that exist in the run directory `dir`: (path relative to
/// `dir`, caption naming the strategy and seed), cell by cell in row order, each cell's in
/// [`FIGURES`] order.
pub fn figure_links(rows: &[Row], scene: &str, dir: &Path) -> Vec<(String, String)> {
    let mut cells: Vec<(String, &str, u64)> = Vec::new();
    for r in rows.iter().filter(|r| r.scene == scene) {
        // `images/<cell>_spp<N>.exr` or `images/<cell>_t<T>s.exr`: the cell is all before the last `_`.
        let image = Path::new(&r.image);
        let Some(stem) = image.file_stem().map(|s| s.to_string_lossy().into_owned()) else {
            continue;
        };
        let cell = stem.rsplit_once('_').map_or(stem.as_str(), |(a, _)| a);
        let prefix = image.with_file_name(cell).display().to_string();
        if !cells.iter().any(|(p, _, _)| *p == prefix) {
            cells.push((prefix, &r.strategy, r.seed));
        }
    }
    let mut links = Vec::new();
    for (prefix, strategy, seed) in cells {
        for (suffix, caption) in FIGURES {
            let rel = format!("{prefix}{suffix}");
            if dir.join(&rel).is_file() {
                links.push((rel, format!("{strategy} · seed {seed} · {caption}")));
            }
        }
    }
    links
}

/// The `summary.md` section of [`figure_links`] (empty when there is none).
pub fn markdown(rows: &[Row], scene: &str, dir: &Path) -> String {
    let links = figure_links(rows, scene, dir);
    if links.is_empty() {
        return String::new();
    }
    let mut md = String::from(
        "### photon-map figures\n\nChristensen 1999, Fig. 1, for each photon-map cell. Radiance and E/π are \
         shown like the renders (linear, clamped to 1, sRGB); photon counts on a log scale.\n\n",
    );
    for (rel, caption) in links {
        md.push_str(&format!("- [{caption}]({rel})\n"));
    }
    md.push('\n');
    md
}

/// The pixel each photon (position, normal) projects to, if it lies in front of the camera and
/// the eye sees it.
pub fn visible_pixels(scene: &Scene, photons: &[(Vec3, Vec3)]) -> Vec<Option<usize>> {
    let cam = &scene.camera;
    photons
        .par_iter()
        .map(|&(p, n)| {
            let d = p - cam.eye;
            let raster = cam.raster_position(d.normalize_or_zero())?;
            let (ray, dist) = spawn_shadow_ray(cam.eye, cam.forward(), p, n);
            (dist > 0.0 && scene.unoccluded(&ray)).then(|| raster.y as usize * cam.width as usize + raster.x as usize)
        })
        .collect()
}

/// Visible photons per pixel.
pub fn photon_counts(scene: &Scene, photons: &[(Vec3, Vec3)]) -> Vec<u32> {
    let mut counts = vec![0u32; scene.camera.pixel_count()];
    for i in visible_pixels(scene, photons).into_iter().flatten() {
        counts[i] += 1;
    }
    counts
}

/// Writes the photon distribution image of `photons` (position, normal) in `scene` to `path`
/// (PNG, atomically); returns how many photons the camera sees.
pub fn write_photon_image(scene: &Scene, photons: &[(Vec3, Vec3)], path: &Path) -> Result<u64> {
    let counts = photon_counts(scene, photons);
    let max = counts.iter().copied().max().unwrap_or(0).max(1) as f64;
    let (w, h) = (scene.camera.width, scene.camera.height);
    let rgb = image::RgbImage::from_fn(w, h, |x, y| {
        let c = counts[(y * w + x) as usize];
        if c == 0 {
            image::Rgb([0, 0, 0])
        } else {
            image::Rgb(viridis((1.0 + c as f64).ln() / (1.0 + max).ln()))
        }
    });
    write_rgb8_png(rgb, path)?;
    Ok(counts.iter().map(|&c| c as u64).sum())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn photons_behind_a_wall_or_the_camera_are_not_counted() {
        let scene = crate::scene::load_scene(Path::new("scenes/cornell-empty.toml")).unwrap();
        let eye = scene.camera.eye;
        let f = scene.camera.forward();
        // On the back wall straight ahead (visible), behind the camera, and outside the box
        // behind the back wall (occluded).
        let back = Vec3::new(0.278, 0.2744, 0.5592);
        let photons = [(back, -Vec3::Z), (eye - f, Vec3::Z), (back + Vec3::Z * 0.5, -Vec3::Z)];
        let counts = photon_counts(&scene, &photons);
        assert_eq!(counts.iter().sum::<u32>(), 1);
    }
}
