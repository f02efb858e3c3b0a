//! Photon distribution images [Fan et al. 2005, Fig. 2]: where a strategy's global-map photons
//! lie, as the camera sees them. Each photon in front of the camera and visible from the eye
//! counts in the pixel it projects to; counts are shown on a log scale (viridis, black for no
//! photon), so standard photon mapping's photons spread over everything the lights reach
//! while Metropolis photon sampling's gather where the final gather looks.

use crate::error::Result;
use crate::film::{viridis, write_rgb8_png};
use crate::geometry::spawn_shadow_ray;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use std::path::Path;

/// Visible photons per pixel.
pub fn photon_counts(scene: &Scene, photons: &[(Vec3, Vec3)]) -> Vec<u32> {
    let cam = &scene.camera;
    let pixels: Vec<Option<usize>> = photons
        .par_iter()
        .map(|&(p, n)| {
            let d = p - cam.eye;
            let raster = cam.raster_position(d.normalize_or_zero())?;
            let (ray, dist) = spawn_shadow_ray(cam.eye, cam.forward(), p, n);
            (dist > 0.0 && scene.unoccluded(&ray)).then(|| raster.y as usize * cam.width as usize + raster.x as usize)
        })
        .collect();
    let mut counts = vec![0u32; cam.pixel_count()];
    for i in pixels.into_iter().flatten() {
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
