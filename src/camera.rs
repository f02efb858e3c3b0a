//! The camera: a pinhole, a thin lens or an orthographic projection (Mitsuba's `perspective`,
//! `thinlens` and `orthographic` sensors, [`Lens`]), with an optional crop window (Mitsuba's
//! `hdrfilm` crop): the projection is the full film's, the image the window's.

use crate::geometry::Ray;
use crate::pixel_filter::PixelFilter;
use crate::sampling::{Rng, sample_concentric_disk};
use glam::{Vec2, Vec3};

/// How rays leave the camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lens {
    /// Every ray through the eye point (Mitsuba's `perspective`).
    Pinhole,
    /// A thin lens of radius `aperture_radius` at the eye, in focus at `focus_distance` along
    /// the view direction (Mitsuba's `thinlens`): the ray through raster point r leaves a point
    /// uniform on the lens disc toward where the pinhole ray through r meets the plane of focus.
    Thin { aperture_radius: f32, focus_distance: f32 },
    /// Parallel rays along the view direction from a rectangle of half extents `half_w` ×
    /// `half_h` (scene units) centred on the eye (Mitsuba's `orthographic`).
    Orthographic { half_w: f32, half_h: f32 },
}

/// A pinhole camera looking from `eye` toward `look_at`; `fov_y_deg` is the full vertical field
/// of view of the full film. Raster coordinates run from (0, 0) at the top-left corner of the
/// image to (width, height); the image is the crop window of the film when there is one.
#[derive(Clone, Debug)]
pub struct Camera {
    pub eye: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    pub fov_y_deg: f32,
    /// The image's size in pixels: the crop window's, or the film's without one.
    pub width: u32,
    pub height: u32,
    /// The full film's size, which the field of view spans.
    pub film: (u32, u32),
    /// The crop window's top-left pixel on the film ((0, 0) without a crop).
    pub crop_offset: (u32, u32),
    /// The pixel reconstruction filter ([`crate::pixel_filter`]; the box by default).
    pub filter: PixelFilter,
    /// Pinhole (default), thin lens or orthographic.
    pub lens: Lens,
    /// The image mirrored left–right: raster x grows along up × view instead of view × up
    /// (pbrt's left-handed camera space, [`Camera::mirrored`]).
    pub flip_x: bool,
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
            film: (width, height),
            crop_offset: (0, 0),
            filter: PixelFilter::Box,
            lens: Lens::Pinhole,
            flip_x: false,
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

    /// The same camera with lens `lens` (the caller has checked its parameters are positive).
    /// The same camera with its image mirrored left–right, as pbrt's cameras see: pbrt's
    /// `LookAt` makes camera-space x = up × view and maps it to raster x, the mirror image of
    /// a right-handed camera's (Mitsuba's importer of pbrt scenes scales x by −1 likewise).
    /// Every projection reads the `right` axis, so all of them mirror together.
    pub fn mirrored(mut self) -> Self {
        self.flip_x = !self.flip_x;
        self.right = -self.right;
        self
    }

    pub fn with_lens(mut self, lens: Lens) -> Self {
        self.lens = lens;
        self
    }

    /// The same camera rendering only the film's pixels [x, x + w) × [y, y + h), `offset` =
    /// (x, y) and `size` = (w, h), which the caller has checked lie on the film.
    pub fn with_crop(mut self, offset: (u32, u32), size: (u32, u32)) -> Self {
        debug_assert!(offset.0 + size.0 <= self.film.0 && offset.1 + size.1 <= self.film.1);
        self.crop_offset = offset;
        (self.width, self.height) = size;
        self
    }

    /// The same view at 1/`factor` of the resolution (crop window and pixel filter kept).
    pub fn downscaled(&self, factor: u32) -> Self {
        let f = factor.max(1);
        let shrink = |v: u32| (v / f).max(1);
        let film = (shrink(self.film.0), shrink(self.film.1));
        let mut c = Camera::new(self.eye, self.look_at, self.up, self.fov_y_deg, film.0, film.1)
            .with_filter(self.filter.clone())
            .with_lens(self.lens);
        let offset = (
            (self.crop_offset.0 / f).min(film.0 - 1),
            (self.crop_offset.1 / f).min(film.1 - 1),
        );
        let size = (
            shrink(self.width).min(film.0 - offset.0),
            shrink(self.height).min(film.1 - offset.1),
        );
        if (offset, size) != ((0, 0), film) {
            c = c.with_crop(offset, size);
        }
        if self.flip_x {
            c = c.mirrored();
        }
        c
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
    pub fn splat(&self, raster: Vec2, rng: &mut Rng) -> Option<(u32, f32)> {
        let u = match self.filter {
            PixelFilter::Box => 0.0,
            PixelFilter::Separable(_) => rng.uniform(),
        };
        self.filter.splat_one(raster, (self.width, self.height), u)
    }

    /// The primary ray through raster position `raster` (pixel (x, y) covers [x, x+1) × [y, y+1)),
    /// drawing the point on a thin lens from `rng` (nothing is drawn for a pinhole or an
    /// orthographic camera).
    #[inline]
    pub fn sample_ray(&self, raster: Vec2, rng: &mut Rng) -> Ray {
        match self.lens {
            Lens::Thin { .. } => self.lens_ray(raster, rng.uniform2()),
            _ => self.generate_ray(raster),
        }
    }

    /// The ray through raster position `raster` from the lens point `u_lens` ∈ [0, 1)² (mapped
    /// to the disc concentrically, as Mitsuba does); the pinhole and orthographic cameras do
    /// not read it.
    #[inline]
    pub fn lens_ray(&self, raster: Vec2, u_lens: Vec2) -> Ray {
        self.ray_from(raster, self.lens_point(u_lens))
    }

    /// Whether rays leave parallel to the view from a film rectangle (a delta in direction:
    /// path space's camera vertex is then the film point behind the vertex it sees).
    #[inline]
    pub fn is_orthographic(&self) -> bool {
        matches!(self.lens, Lens::Orthographic { .. })
    }

    /// The point on the lens disc of a thin lens for `u` ∈ [0, 1)² (mapped concentrically, as
    /// [`Camera::lens_ray`] maps it); the eye point for the other cameras.
    #[inline]
    pub fn lens_point(&self, u: Vec2) -> Vec3 {
        match self.lens {
            Lens::Thin { aperture_radius, .. } => {
                let on_lens = sample_concentric_disk(u) * aperture_radius;
                self.eye + self.right * on_lens.x + self.true_up * on_lens.y
            }
            _ => self.eye,
        }
    }

    /// The ray through raster position `raster` that leaves lens point `p` (a point of the
    /// thin lens's disc, [`Camera::lens_point`]); the pinhole's ray from the eye and the
    /// orthographic camera's ray from the film point of `raster` do not read `p`.
    #[inline]
    pub fn ray_from(&self, raster: Vec2, p: Vec3) -> Ray {
        match self.lens {
            Lens::Thin { focus_distance, .. } => {
                let offset = p - self.eye;
                let focus = self.pinhole_direction(raster) * focus_distance;
                Ray::new(p, (focus - offset).normalize())
            }
            _ => self.generate_ray(raster),
        }
    }

    /// The raster position where a ray leaving lens point `p` in direction `d` lands: through
    /// the point where it crosses the plane of focus for a thin lens, [`Camera::raster_position`]
    /// of `d` for a pinhole (an orthographic camera has no such map: [`Camera::film_point`]).
    pub fn raster_from(&self, p: Vec3, d: Vec3) -> Option<Vec2> {
        let Lens::Thin { focus_distance, .. } = self.lens else {
            return self.raster_position(d);
        };
        let cos = d.dot(self.forward);
        if cos <= 0.0 {
            return None;
        }
        let on_focus = (p - self.eye) + d * (focus_distance / cos);
        self.raster_on_plane(on_focus / focus_distance)
    }

    /// The point of an orthographic camera's film rectangle behind world point `x` (x seen along
    /// the view) and its raster position; `None` when `x` lies behind the film plane or outside
    /// the image.
    pub fn film_point(&self, x: Vec3) -> Option<(Vec3, Vec2)> {
        let rel = x - self.eye;
        let depth = rel.dot(self.forward);
        if depth <= 0.0 {
            return None;
        }
        let o = x - self.forward * depth;
        Some((o, self.film_raster(o)?))
    }

    /// The raster position of the point `o` of an orthographic camera's film rectangle; `None`
    /// outside the image.
    pub fn film_raster(&self, o: Vec3) -> Option<Vec2> {
        let Lens::Orthographic { half_w, half_h } = self.lens else {
            return None;
        };
        let rel = o - self.eye;
        let on_plane = Vec2::new(rel.dot(self.right) / half_w, rel.dot(self.true_up) / half_h);
        self.raster_of_ndc(on_plane.x, on_plane.y)
    }

    /// Raster area per unit area of an orthographic camera's film rectangle: du/dA_film, the
    /// density with which a raster point uniform over the film lands on the rectangle, times the
    /// film's pixel count (zero for the other cameras).
    pub fn raster_per_film_area(&self) -> f32 {
        match self.lens {
            Lens::Orthographic { half_w, half_h } => {
                (self.film.0 as f32 / (2.0 * half_w)) * (self.film.1 as f32 / (2.0 * half_h))
            }
            _ => 0.0,
        }
    }

    /// The ray through raster position `raster` (pixel (x, y) covers [x, x+1) × [y, y+1)) from
    /// the eye point (the lens centre for a thin lens: cache placement, figures), or parallel
    /// to the view for an orthographic camera.
    #[inline]
    pub fn generate_ray(&self, raster: Vec2) -> Ray {
        if let Lens::Orthographic { half_w, half_h } = self.lens {
            let (ndc_x, ndc_y) = self.ndc(raster);
            let o = self.eye + self.right * (ndc_x * half_w) + self.true_up * (ndc_y * half_h);
            return Ray::new(o, self.forward);
        }
        Ray::new(self.eye, self.pinhole_direction(raster).normalize())
    }

    /// The unnormalised direction from the eye through raster position `raster`, with forward
    /// component 1.
    #[inline]
    fn pinhole_direction(&self, raster: Vec2) -> Vec3 {
        let (ndc_x, ndc_y) = self.ndc(raster);
        self.forward + self.right * (ndc_x * self.half_w) + self.true_up * (ndc_y * self.half_h)
    }

    /// Normalised device coordinates in [−1, 1]² (y up) of raster position `raster` on the film.
    #[inline]
    fn ndc(&self, raster: Vec2) -> (f32, f32) {
        let (x, y) = (
            raster.x + self.crop_offset.0 as f32,
            raster.y + self.crop_offset.1 as f32,
        );
        (2.0 * x / self.film.0 as f32 - 1.0, 1.0 - 2.0 * y / self.film.1 as f32)
    }

    /// Raster position where the direction `d` from the eye crosses the image, if it does.
    pub fn raster_position(&self, d: Vec3) -> Option<Vec2> {
        let cos = d.dot(self.forward);
        if cos <= 0.0 {
            return None;
        }
        self.raster_on_plane(d / cos)
    }

    /// Raster position of the point `on_plane` (relative to the eye) of the plane at distance 1
    /// along the view, if it lies on the image.
    #[inline]
    fn raster_on_plane(&self, on_plane: Vec3) -> Option<Vec2> {
        self.raster_of_ndc(
            on_plane.dot(self.right) / self.half_w,
            on_plane.dot(self.true_up) / self.half_h,
        )
    }

    /// Raster position of normalised device coordinates (the inverse of [`Camera::ndc`]), if it
    /// lies on the image.
    #[inline]
    fn raster_of_ndc(&self, ndc_x: f32, ndc_y: f32) -> Option<Vec2> {
        let raster = Vec2::new(
            (ndc_x + 1.0) * 0.5 * self.film.0 as f32 - self.crop_offset.0 as f32,
            (1.0 - ndc_y) * 0.5 * self.film.1 as f32 - self.crop_offset.1 as f32,
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
        let s = 0.5 * self.film.1 as f32 / self.half_h;
        s * s / (cos * cos * cos)
    }

    pub fn forward(&self) -> Vec3 {
        self.forward
    }
}

/// The half-extents (t_x, t_y) of the image plane at distance 1 of a `width` × `height` view
/// whose field of view is `fov_deg` degrees along `axis`, as Mitsuba's `parse_fov` reads
/// `fov_axis` ("x", "y", "diagonal", or "smaller"/"larger" of the two sides); `None` for any
/// other axis. Shared by the perspective sensor and the projector emitter.
pub fn fov_half_extents(fov_deg: f64, axis: &str, (width, height): (u32, u32)) -> Option<glam::DVec2> {
    let (w, h) = (f64::from(width), f64::from(height));
    let t = (0.5 * fov_deg.to_radians()).tan();
    let tan_y = match axis {
        "x" => t * h / w,
        "y" => t,
        "diagonal" => t * h / (w * w + h * h).sqrt(),
        "smaller" | "larger" if (width < height) == (axis == "smaller") => t * h / w,
        "smaller" | "larger" => t,
        _ => return None,
    };
    Some(glam::DVec2::new(tan_y * w / h, tan_y))
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

    /// A crop window renders exactly the film's pixels it covers: the same rays, the same raster
    /// Jacobian, raster positions shifted by the offset and `None` outside the window.
    #[test]
    fn a_crop_window_is_the_same_projection_shifted() {
        let full = Camera::new(Vec3::new(0.0, 1.0, 4.0), Vec3::ZERO, Vec3::Y, 40.0, 80, 60);
        let crop = full.clone().with_crop((30, 10), (20, 25));
        assert_eq!((crop.width, crop.height, crop.pixel_count()), (20, 25, 500));
        for raster in [Vec2::new(0.5, 0.5), Vec2::new(19.9, 24.2), Vec2::new(7.3, 11.0)] {
            let shifted = raster + Vec2::new(30.0, 10.0);
            let (a, b) = (crop.generate_ray(raster), full.generate_ray(shifted));
            assert!((a.d - b.d).length() < 1e-6);
            let back = crop.raster_position(a.d).unwrap();
            assert!((back - raster).length() < 1e-3, "{raster} -> {back}");
            assert_eq!(crop.raster_per_solid_angle(a.d), full.raster_per_solid_angle(b.d));
        }
        // Film pixels outside the window are not on the image.
        assert!(crop.raster_position(full.generate_ray(Vec2::new(5.0, 5.0)).d).is_none());
        let half = crop.downscaled(2);
        assert_eq!(
            (half.film, half.crop_offset, half.width, half.height),
            ((40, 30), (15, 5), 10, 12)
        );
    }

    #[test]
    fn top_of_image_looks_up() {
        let cam = Camera::new(Vec3::ZERO, -Vec3::Z, Vec3::Y, 60.0, 100, 100);
        assert!(cam.generate_ray(Vec2::new(50.0, 0.0)).d.y > 0.0);
        assert!(cam.generate_ray(Vec2::new(100.0, 50.0)).d.x > 0.0);
    }
}
