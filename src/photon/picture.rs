//! Photons as the camera sees them: each photon in front of the camera and visible from the
//! eye counts in the pixel it projects to [Fan et al. 2005, Fig. 2; Christensen 1999, Fig. 1a].

use crate::color::viridis;
use crate::figure::{Figure, FigureImage, PHOTONS_PNG};
use crate::geometry::spawn_shadow_ray;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;

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

/// The photon distribution figure of `photons` (position, normal) in `scene`: visible photons
/// per pixel on a log scale (viridis, black for none).
pub fn distribution(scene: &Scene, photons: &[(Vec3, Vec3)]) -> Figure {
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
    Figure {
        suffix: PHOTONS_PNG,
        image: FigureImage::Display(rgb),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn photons_behind_a_wall_or_the_camera_are_not_counted() {
        let scene = crate::scene::load_scene(std::path::Path::new("scenes/cornell-empty.toml")).unwrap();
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
