//! Pinhole camera.

use crate::geometry::Ray;
use crate::pixel_filter::PixelFilter;
use glam::{Vec2, Vec3};

/// A pinhole camera looking from `eye` toward `look_at`; `fov_y_deg` is the full vertical field
/// of view. Raster coordinates run from (0, 0) at the top-left corner to (width, height).
#[derive(Clone, Debug)]
pub struct Camera {
    pub eye: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    pub fov_y_deg: f32,
    pub width: u32,
    pub height: u32,
    /// The pixel reconstruction filter ([`crate::pixel_filter`]; the box by default).
    pub filter: PixelFilter,
    /// Camera basis: right, true up, forward (unit vectors).
    right: Vec3,
    true_up: Vec3,
    forward: Vec3,
    /// Half extents of the image plane at distance 1 along `forward`.
    half_w: f32,
    half_h: f32,
}

impl Camera {
    /// Builds the camera; the caller has validated that eye ≠ look_at, up is not parallel to
    /// the view direction, 0 < fov < 180 and the resolution is positive.
    pub fn new(eye: Vec3, look_at: Vec3, up: Vec3, fov_y_deg: f32, width: u32, height: u32) -> Self {
        let forward = (look_at - eye).normalize();
        let right = forward.cross(up).normalize();
        let true_up = right.cross(forward);
        let half_h = (0.5 * fov_y_deg.to_radians()).tan();
        let half_w = half_h * width as f32 / height as f32;
        Self {
            eye,
            look_at,
            up,
            fov_y_deg,
            width,
            height,
            filter: PixelFilter::Box,
            right,
            true_up,
            forward,
            half_w,
            half_h,
        }
    }

    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The same camera with pixel filter `filter`.
    pub fn with_filter(mut self, filter: PixelFilter) -> Self {
        self.filter = filter;
        self
    }

    /// The raster position of a sample of pixel `pixel` (row-major index) drawn with `u`,
    /// through the pixel filter.
    #[inline]
    pub fn sample_raster(&self, pixel: usize, u: Vec2) -> Vec2 {
        let w = self.width as usize;
        let xy = ((pixel % w) as u32, (pixel / w) as u32);
        self.filter.sample(xy, u, (self.width, self.height))
    }

    /// The pixel a contribution landing at raster position `raster` goes to and its weight:
    /// one of the pixels whose filter covers it, drawn from `rng`
    /// ([`PixelFilter::splat_one`]); the box filter's own pixel, weight 1, without a draw.
    #[inline]
    pub fn splat(&self, raster: Vec2, rng: &mut crate::sampling::Rng) -> Option<(u32, f32)> {
        let u = match self.filter {
            PixelFilter::Box => 0.0,
            PixelFilter::Separable(_) => rng.uniform(),
        };
        self.filter.splat_one(raster, (self.width, self.height), u)
    }

    /// The primary ray through raster position `raster` (pixel (x, y) covers [x, x+1) × [y, y+1)).
    #[inline]
    pub fn generate_ray(&self, raster: Vec2) -> Ray {
        let ndc_x = 2.0 * raster.x / self.width as f32 - 1.0;
        let ndc_y = 1.0 - 2.0 * raster.y / self.height as f32;
        let d = self.forward + self.right * (ndc_x * self.half_w) + self.true_up * (ndc_y * self.half_h);
        Ray::new(self.eye, d.normalize())
    }

    /// Raster position where the direction `d` from the eye crosses the image, if it does.
    pub fn raster_position(&self, d: Vec3) -> Option<Vec2> {
        let cos = d.dot(self.forward);
        if cos <= 0.0 {
            return None;
        }
        let on_plane = d / cos;
        let ndc_x = on_plane.dot(self.right) / self.half_w;
        let ndc_y = on_plane.dot(self.true_up) / self.half_h;
        let raster = Vec2::new(
            (ndc_x + 1.0) * 0.5 * self.width as f32,
            (1.0 - ndc_y) * 0.5 * self.height as f32,
        );
        (raster.x >= 0.0 && raster.y >= 0.0 && raster.x < self.width as f32 && raster.y < self.height as f32)
            .then_some(raster)
    }

    /// Jacobian du/dω of raster area per solid angle for unit direction `d` from the eye:
    /// s² / cos³θ, with s raster units per unit length on the plane at distance 1 and θ the
    /// angle between `d` and the view direction. Zero behind the camera.
    pub fn raster_per_solid_angle(&self, d: Vec3) -> f32 {
        let cos = d.dot(self.forward);
        if cos <= 0.0 {
            return 0.0;
        }
        let s = 0.5 * self.height as f32 / self.half_h;
        s * s / (cos * cos * cos)
    }

    /// Area of the image plane at distance 1 from the eye.
    pub fn image_plane_area(&self) -> f32 {
        4.0 * self.half_w * self.half_h
    }

    pub fn forward(&self) -> Vec3 {
        self.forward
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raster_position_inverts_generate_ray() {
        let cam = Camera::new(
            Vec3::new(0.0, 1.0, 4.0),
            Vec3::new(0.1, 0.9, 0.0),
            Vec3::Y,
            40.0,
            80,
            60,
        );
        for raster in [Vec2::new(0.5, 0.5), Vec2::new(40.0, 30.0), Vec2::new(79.2, 12.7)] {
            let r = cam.generate_ray(raster);
            let back = cam.raster_position(r.d).unwrap();
            assert!((back - raster).length() < 1e-3, "{raster} -> {back}");
        }
        assert!(cam.raster_position(-cam.forward()).is_none());
    }

    #[test]
    fn top_of_image_looks_up() {
        let cam = Camera::new(Vec3::ZERO, -Vec3::Z, Vec3::Y, 60.0, 100, 100);
        assert!(cam.generate_ray(Vec2::new(50.0, 0.0)).d.y > 0.0);
        assert!(cam.generate_ray(Vec2::new(100.0, 50.0)).d.x > 0.0);
    }
}
