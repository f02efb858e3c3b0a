//! Film: per-pixel accumulation of samples in linear RGB, with non-finite samples counted and
//! excluded; the resulting [`Image`] and its EXR / PNG input and output.

use glam::{DVec3, Vec3};

/// A linear-RGB image, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Vec3>,
}

impl Image {
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![Vec3::ZERO; width as usize * height as usize],
        }
    }

    #[inline]
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * self.width + x) as usize]
    }

    /// Mean of all pixels, per channel.
    pub fn mean(&self) -> Vec3 {
        let sum: DVec3 = self.pixels.iter().map(|p| p.as_dvec3()).sum();
        (sum / self.pixels.len().max(1) as f64).as_vec3()
    }
}

/// Accumulated samples of one render.
#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Sum of finite samples per pixel (f64 so that 32 000-spp references keep full precision).
    sum: Vec<DVec3>,
    /// Number of finite samples per pixel.
    count: Vec<u32>,
    /// Samples dropped because a channel was NaN or infinite.
    pub non_finite: u64,
}

/// The accumulator of one pixel, handed to the worker that owns that pixel.
#[derive(Clone, Copy, Debug, Default)]
pub struct PixelAccumulator {
    pub sum: DVec3,
    pub count: u32,
    pub non_finite: u32,
}

impl PixelAccumulator {
    #[inline]
    pub fn add(&mut self, l: Vec3) {
        if l.is_finite() {
            self.sum += l.as_dvec3();
            self.count += 1;
        } else {
            self.non_finite += 1;
        }
    }
}

impl Film {
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self {
            width,
            height,
            sum: vec![DVec3::ZERO; n],
            count: vec![0; n],
            non_finite: 0,
        }
    }

    /// Adds per-pixel accumulators of one pass (one per pixel, in row-major order).
    pub fn add_pass(&mut self, pass: &[PixelAccumulator]) {
        assert_eq!(pass.len(), self.sum.len());
        for (i, acc) in pass.iter().enumerate() {
            self.sum[i] += acc.sum;
            self.count[i] += acc.count;
            self.non_finite += acc.non_finite as u64;
        }
    }

    /// Adds a splatted contribution (light tracing, MLT) to pixel `index`; it counts no sample.
    pub fn splat(&mut self, index: usize, l: Vec3) {
        if l.is_finite() {
            self.sum[index] += l.as_dvec3();
        } else {
            self.non_finite += 1;
        }
    }

    /// The image: the mean of the finite samples of each pixel.
    pub fn image(&self) -> Image {
        let pixels = self
            .sum
            .iter()
            .zip(&self.count)
            .map(|(s, &c)| {
                if c > 0 {
                    (*s / c as f64).as_vec3()
                } else {
                    Vec3::ZERO
                }
            })
            .collect();
        Image {
            width: self.width,
            height: self.height,
            pixels,
        }
    }

    /// The image scaled by `1/n` instead of by each pixel's sample count (for splatting
    /// estimators, whose pixels receive a varying number of contributions).
    pub fn image_scaled(&self, scale: f64) -> Image {
        let pixels = self.sum.iter().map(|s| (*s * scale).as_vec3()).collect();
        Image {
            width: self.width,
            height: self.height,
            pixels,
        }
    }
}
