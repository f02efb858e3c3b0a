//! Combining the images of the training iterations with the final render, each weighted by
//! the inverse of its estimated variance [Müller 2019, "Practical Path Guiding in Production",
//! §"Inverse-variance-based sample weighting"], instead of discarding the training samples.
//!
//! **The variance of an image** is the mean over pixels of the variance of each pixel's mean,
//! estimated from the per-pixel sample variance of luminance. An iteration with one sample per
//! pixel has no such estimate and gets weight 0 (iteration 0). The weights come from the same
//! samples they weight, which makes the combination very slightly biased, as in Müller's.

use glam::{DVec3, Vec3};

/// Per-pixel moments of one image's samples.
#[derive(Clone, Debug, Default)]
pub struct Moments {
    sum: Vec<DVec3>,
    /// Σ of squared luminance.
    sq: Vec<f64>,
    /// Samples per pixel.
    pub n: u64,
}

impl Moments {
    pub fn new(pixels: usize) -> Self {
        Self {
            sum: vec![DVec3::ZERO; pixels],
            sq: vec![0.0; pixels],
            n: 0,
        }
    }

    /// Adds one sample per pixel (non-finite samples count as zero, as the film drops them).
    pub fn add_pass(&mut self, values: &[Vec3]) {
        for ((s, q), v) in self.sum.iter_mut().zip(&mut self.sq).zip(values) {
            let v = if v.is_finite() { v.as_dvec3() } else { DVec3::ZERO };
            *s += v;
            *q += luminance(v).powi(2);
        }
        self.n += 1;
    }

    /// An image from each pixel's sum of `n` samples and their sum of squared luminance (a
    /// training iteration).
    pub fn from_sums(sum: Vec<DVec3>, sq: Vec<f64>, n: u64) -> Self {
        Self { sum, sq, n }
    }

    /// Pixel `p`'s mean.
    #[inline]
    pub fn mean(&self, p: usize) -> DVec3 {
        self.sum[p] / self.n.max(1) as f64
    }

    /// The image's variance (module doc); `None` below 2 samples per pixel.
    pub fn variance(&self) -> Option<f64> {
        if self.n < 2 {
            return None;
        }
        let n = self.n as f64;
        let total: f64 = self
            .sum
            .iter()
            .zip(&self.sq)
            .map(|(s, q)| {
                let m = luminance(*s) / n;
                ((q / n - m * m) * n / (n - 1.0)).max(0.0) / n
            })
            .sum();
        Some(total / self.sum.len().max(1) as f64)
    }
}

#[inline]
fn luminance(c: DVec3) -> f64 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Inverse-variance weights of images with variances `variances` (`None`: weight 0). A zero
/// variance (a black image) is taken as the smallest positive one, so weights stay finite;
/// when no image has a variance, the last one gets all the weight.
pub fn weights(variances: &[Option<f64>]) -> Vec<f64> {
    let floor = variances
        .iter()
        .flatten()
        .copied()
        .filter(|v| *v > 0.0)
        .fold(f64::INFINITY, f64::min);
    let mut w: Vec<f64> = variances
        .iter()
        .map(|v| match v {
            Some(v) if *v > 0.0 => 1.0 / v,
            Some(_) if floor.is_finite() => 1.0 / floor,
            Some(_) => 1.0,
            None => 0.0,
        })
        .collect();
    let total: f64 = w.iter().sum();
    if total > 0.0 {
        w.iter_mut().for_each(|x| *x /= total);
    } else if let Some(last) = w.last_mut() {
        *last = 1.0;
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_are_inverse_variances_normalised() {
        let w = weights(&[None, Some(4.0), Some(1.0)]);
        assert_eq!(w[0], 0.0);
        assert!((w[1] - 0.2).abs() < 1e-12 && (w[2] - 0.8).abs() < 1e-12);
        assert_eq!(weights(&[None, None]), vec![0.0, 1.0]);
        let w = weights(&[Some(0.0), Some(2.0)]);
        assert!((w[0] - 0.5).abs() < 1e-12);
    }

    /// The image variance estimate is unbiased: for samples 0 or 2 with probability ½ (luminance
    /// variance 1 per sample for white), an image of 4 samples per pixel has variance ¼.
    #[test]
    fn the_variance_of_an_image_is_that_of_its_pixel_means() {
        let mut rng = crate::sampling::Rng::for_task(5, [0, 0, 0]);
        let pixels = 20_000;
        let mut m = Moments::new(pixels);
        for _ in 0..4 {
            let values: Vec<Vec3> = (0..pixels)
                .map(|_| {
                    if rng.uniform() < 0.5 {
                        Vec3::ZERO
                    } else {
                        Vec3::splat(2.0)
                    }
                })
                .collect();
            m.add_pass(&values);
        }
        let v = m.variance().unwrap();
        assert!((v - 0.25).abs() < 0.01, "{v}");
        assert!(Moments::new(3).variance().is_none());
    }
}
