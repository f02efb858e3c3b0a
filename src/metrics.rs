//! Error metrics of a rendered image against a converged reference: images in, numbers out.
//!
//! This module never sees a scene, only two [`Image`]s of equal size. All sums run in `f64`.
//!
//! Definitions (`I` the image, `R` the reference, `N` pixels, `c` one of the 3 channels):
//! - **MSE** = `1/(3N) Σ_p Σ_c (I − R)²`.
//! - **RMSE** = `√MSE`.
//! - **relMSE** = `1/(3N) Σ_p Σ_c (I − R)² / (R² + ε)` with [`REL_MSE_EPSILON`]. The
//!   denominator is the *squared* reference, so relMSE is dimensionless; leaving it unsquared
//!   (a bug once shipped in Tungsten's relMSE, tungsten issue #57) gives a number that scales
//!   with the brightness of the scene.
//! - **trimmed** MSE / relMSE: the same means after dropping the [`trimmed_pixel_count`]
//!   pixels with the largest per-pixel error (fireflies).
//! - **RMS relative luminance error** of Fan, Chenney & Lai 2005, "Metropolis Photon Sampling":
//!   `√(mean_p ((Y(I) − Y(R)) / Y(R))²)` with Rec. 709 luminance `Y`, over the pixels whose
//!   reference luminance is not (close to) zero.
//! - **FLIP** (Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating Images"):
//!   the mean of NVIDIA's LDR-FLIP error map (0 identical … 1 most different), through the
//!   `nv-flip` crate (NVIDIA's C++ implementation), at its default 67 pixels per degree (a
//!   0.7 m wide 4K monitor seen from 0.7 m). **Decision: tone mapping.** LDR-FLIP compares
//!   display images, so both images are mapped exactly as the sRGB previews next to each EXR
//!   are ([`crate::film::write_png`] at exposure 0): linear values clamped to [0, 1], the sRGB
//!   transfer function, rounded to 8 bits. FLIP therefore judges the picture a reader sees;
//!   errors above 1 (a saturated light) are invisible to it, which the other metrics cover.
//! - **MSE of the display images** (`mse_ldr`): the MSE of the same 8-bit sRGB images FLIP
//!   sees, in units of full scale (0 … 1). Jensen 1995 reports MSE between computed images and
//!   a reference without saying whether they were the 8-bit images of its figures; this is that
//!   reading. A saturated region (a light, a hot spot seen directly) has no error here, so when
//!   such pixels dominate the MSE of the radiance the two tell different stories (docs/reproductions/jensen1995.md).
//! - **efficiency** = `1 / (MSE · time)` (Veach 1997, §2.5 "efficiency of an estimator"; Pharr,
//!   Jakob & Humphreys, PBRT 4th ed., §2.1.4), higher is better.

use crate::color::viridis;
use crate::error::{Error, Result};
use crate::film::{Image, check_pixel_count, write_rgb8_png};
use glam::DVec3;
use std::path::Path;

/// The ε of relMSE, `(I − R)² / (R² + ε)`: keeps black reference pixels finite. With ε = 1e-3
/// an error of 1 on a black pixel contributes 1000, so black pixels still weigh heavily.
pub const REL_MSE_EPSILON: f64 = 1e-3;

/// Fraction of pixels dropped by the trimmed metrics: the brightest 0.1 % of per-pixel errors.
pub const TRIM_FRACTION: f64 = 1e-3;

/// Rec. 709 / sRGB luminance weights of linear R, G, B (ITU-R BT.709, item 3.2).
pub const REC709_LUMINANCE: DVec3 = DVec3::new(0.2126, 0.7152, 0.0722);

/// A pixel enters the RMS relative luminance error only where its reference luminance is at
/// least this fraction of the mean reference luminance (and positive); the others would divide
/// by (nearly) zero.
pub const LUMINANCE_EXCLUSION_FRACTION: f64 = 1e-4;

/// Error of one image against a reference. Definitions in the [module documentation](self).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metrics {
    /// Mean squared error over pixels and channels: `mean_{p,c} (I − R)²`.
    pub mse: f64,
    /// Root mean squared error: `√mse`.
    pub rmse: f64,
    /// Relative MSE: `mean_{p,c} (I − R)² / (R² + ε)`, ε = [`REL_MSE_EPSILON`].
    pub rel_mse: f64,
    /// MSE over the pixels left after dropping the [`trimmed_pixel_count`] pixels with the
    /// largest per-pixel squared error `mean_c (I − R)²`.
    pub mse_trimmed: f64,
    /// relMSE over the pixels left after dropping the [`trimmed_pixel_count`] pixels with the
    /// largest per-pixel relative squared error `mean_c (I − R)² / (R² + ε)`. The dropped pixels
    /// are chosen for this metric on its own, so they may differ from those of `mse_trimmed`.
    pub rel_mse_trimmed: f64,
    /// RMS relative luminance error (Fan et al. 2005): `√(mean_p ((Y(I) − Y(R)) / Y(R))²)` over
    /// the pixels not excluded; NaN when every pixel is excluded (a black reference).
    pub rms_rel_lum: f64,
    /// Pixels left out of `rms_rel_lum` because `Y(R) ≤ 0` or
    /// `Y(R) < LUMINANCE_EXCLUSION_FRACTION · mean_p Y(R)`.
    pub rms_rel_lum_excluded: u64,
    /// Mean LDR-FLIP error of the tone-mapped images, in [0, 1] ([`flip`]).
    pub flip: f64,
    /// MSE of the tone-mapped 8-bit images, in full-scale units ([`mse_ldr`]).
    pub mse_ldr: f64,
}

/// Number of pixels the trimmed metrics drop out of `n_pixels`: exactly
/// `floor(TRIM_FRACTION · n_pixels)`, so nothing below 1000 pixels.
pub fn trimmed_pixel_count(n_pixels: usize) -> usize {
    // Integer arithmetic: floor(n / 1000) without the rounding of a float product.
    n_pixels / (1.0 / TRIM_FRACTION).round() as usize
}

/// Rec. 709 luminance of a linear-RGB colour.
#[inline]
pub fn luminance(rgb: DVec3) -> f64 {
    rgb.dot(REC709_LUMINANCE)
}

/// Compares `image` with `reference`; the two must have the same size and at least one pixel.
///
/// Non-finite pixel values propagate into the means (the film already drops non-finite
/// samples, so a NaN here means a broken image and should show).
pub fn compare(image: &Image, reference: &Image) -> Result<Metrics> {
    if (image.width, image.height) != (reference.width, reference.height) {
        return Err(Error::new(format!(
            "cannot compare a {}x{} image with a {}x{} reference: sizes differ",
            image.width, image.height, reference.width, reference.height
        )));
    }
    let n = image.pixels.len();
    if n != reference.pixels.len() || n != image.width as usize * image.height as usize {
        return Err(Error::new(format!(
            "cannot compare images: a {}x{} image holds {} pixels and its reference {}",
            image.width,
            image.height,
            n,
            reference.pixels.len()
        )));
    }
    if n == 0 {
        return Err(Error::new("cannot compare empty (0-pixel) images"));
    }

    // Per-pixel errors, each the mean over the pixel's 3 channels.
    let mut sq_err = Vec::with_capacity(n);
    let mut rel_sq_err = Vec::with_capacity(n);
    for (i, r) in image.pixels.iter().zip(&reference.pixels) {
        let (i, r) = (i.as_dvec3(), r.as_dvec3());
        let d2 = (i - r) * (i - r);
        sq_err.push(d2.element_sum() / 3.0);
        rel_sq_err.push((d2 / (r * r + REL_MSE_EPSILON)).element_sum() / 3.0);
    }
    let mse = mean(&sq_err);
    let rel_mse = mean(&rel_sq_err);
    let n_trim = trimmed_pixel_count(n);
    let mse_trimmed = trimmed_mean(&mut sq_err, n_trim);
    let rel_mse_trimmed = trimmed_mean(&mut rel_sq_err, n_trim);
    let (rms_rel_lum, rms_rel_lum_excluded) = rms_relative_luminance_error(image, reference);

    Ok(Metrics {
        mse,
        rmse: mse.sqrt(),
        rel_mse,
        mse_trimmed,
        rel_mse_trimmed,
        rms_rel_lum,
        rms_rel_lum_excluded,
        flip: flip(image, reference),
        mse_ldr: mse_ldr(image, reference),
    })
}

/// An image as its sRGB preview shows it: clamped to [0, 1], sRGB-encoded, 8 bits per channel.
fn ldr(im: &Image) -> Vec<u8> {
    im.pixels
        .iter()
        .flat_map(|p| p.to_array())
        .map(crate::color::srgb8)
        .collect()
}

/// MSE of the display images (module documentation): mean over pixels and channels of
/// ((a − b) / 255)² for the 8-bit sRGB values a, b.
pub fn mse_ldr(image: &Image, reference: &Image) -> f64 {
    let (a, b) = (ldr(image), ldr(reference));
    let sum: f64 = a
        .iter()
        .zip(&b)
        .map(|(&x, &y)| ((x as f64 - y as f64) / 255.0).powi(2))
        .sum();
    sum / a.len().max(1) as f64
}

/// Mean LDR-FLIP error of `image` against `reference` (same size, checked by the caller),
/// both tone-mapped as the sRGB previews are (module documentation).
pub fn flip(image: &Image, reference: &Image) -> f64 {
    let (w, h) = (image.width, image.height);
    let map = nv_flip::flip(
        nv_flip::FlipImageRgb8::with_data(w, h, &ldr(reference)),
        nv_flip::FlipImageRgb8::with_data(w, h, &ldr(image)),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    f64::from(nv_flip::FlipPool::from_image(&map).mean())
}

/// Efficiency of an estimator, `1 / (MSE · time)` (Veach 1997, §2.5): halving either the error
/// or the time doubles it. Infinite when the MSE or the time is zero.
pub fn efficiency(mse: f64, seconds: f64) -> f64 {
    1.0 / (mse * seconds)
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

/// Mean of `values` without its `n_drop` largest entries. Deterministic: a selection by
/// `f64::total_cmp` (NaN sorts above +∞ and is dropped first), then a sum over the kept part.
fn trimmed_mean(values: &mut [f64], n_drop: usize) -> f64 {
    let n_keep = values.len() - n_drop;
    if n_drop > 0 {
        // Afterwards values[..n_keep] hold the n_keep smallest entries.
        values.select_nth_unstable_by(n_keep, f64::total_cmp);
    }
    mean(&values[..n_keep])
}

/// RMS relative luminance error and the number of pixels excluded from it.
fn rms_relative_luminance_error(image: &Image, reference: &Image) -> (f64, u64) {
    let y_ref: Vec<f64> = reference.pixels.iter().map(|r| luminance(r.as_dvec3())).collect();
    let threshold = LUMINANCE_EXCLUSION_FRACTION * mean(&y_ref);
    let mut sum = 0.0;
    let mut included = 0u64;
    for (i, &y_r) in image.pixels.iter().zip(&y_ref) {
        if y_r > 0.0 && y_r >= threshold {
            let rel = (luminance(i.as_dvec3()) - y_r) / y_r;
            sum += rel * rel;
            included += 1;
        }
    }
    let excluded = y_ref.len() as u64 - included;
    let rms = if included > 0 {
        (sum / included as f64).sqrt()
    } else {
        f64::NAN
    };
    (rms, excluded)
}

// Per-pixel relative error and its false-colour map (written beside every render).

/// Per-pixel relative errors below this value get the bottom colour of the error map.
pub const ERROR_MAP_MIN: f64 = 1e-3;
/// Per-pixel relative errors above this value get the top colour of the error map.
pub const ERROR_MAP_MAX: f64 = 10.0;
/// Colour of pixels whose error is NaN (not part of the colormap).
pub const ERROR_MAP_NAN_RGB: [u8; 3] = [255, 0, 0];

/// Per-pixel relative error `e = √(mean_c (I − R)² / (R² + ε))`, ε =
/// [`REL_MSE_EPSILON`]: the square root of the pixel's relMSE term, so
/// `e ≈ |I − R| / R` (0.1 means 10 % off).
pub fn relative_error_per_pixel(image: &Image, reference: &Image) -> Result<Vec<f64>> {
    if (image.width, image.height) != (reference.width, reference.height) {
        return Err(Error::new(format!(
            "cannot map the error of a {}x{} image against a {}x{} reference: sizes differ",
            image.width, image.height, reference.width, reference.height
        )));
    }
    check_pixel_count(image, "error map image")?;
    check_pixel_count(reference, "error map reference")?;
    let eps = REL_MSE_EPSILON;
    Ok(image
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(i, r)| {
            let (i, r) = (i.as_dvec3(), r.as_dvec3());
            (((i - r) * (i - r) / (r * r + eps)).element_sum() / 3.0).sqrt()
        })
        .collect())
}

/// Colour of one relative error on the logarithmic error-map scale: `log10 e` from
/// `log10 ERROR_MAP_MIN` (−3, bottom of viridis, dark purple) to `log10 ERROR_MAP_MAX`
/// (+1, top, yellow), one decade per quarter of the colormap; zero and smaller errors clamp to
/// the bottom, larger and infinite ones to the top; NaN is [`ERROR_MAP_NAN_RGB`].
pub fn error_map_colour(e: f64) -> [u8; 3] {
    if e.is_nan() {
        return ERROR_MAP_NAN_RGB;
    }
    let (lo, hi) = (ERROR_MAP_MIN.log10(), ERROR_MAP_MAX.log10());
    // log10(0) = -inf clamps to 0 below.
    viridis((e.log10() - lo) / (hi - lo))
}

/// Writes a false-colour PNG of the per-pixel relative error of `image` against `reference`
/// ([`relative_error_per_pixel`]), on the logarithmic viridis scale of [`error_map_colour`]:
/// dark purple ≤ 0.1 %, blue-green ≈ 10 %, yellow ≥ 1000 %. The file is written atomically.
pub fn write_error_png(image: &Image, reference: &Image, path: &Path) -> Result<()> {
    let errors = relative_error_per_pixel(image, reference)?;
    let width = image.width as usize;
    let rgb = image::RgbImage::from_fn(image.width, image.height, |x, y| {
        image::Rgb(error_map_colour(errors[y as usize * width + x as usize]))
    });
    write_rgb8_png(&rgb, path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn image(width: u32, height: u32, pixels: &[[f32; 3]]) -> Image {
        Image {
            width,
            height,
            pixels: pixels.iter().map(|&p| Vec3::from(p)).collect(),
        }
    }

    /// A 48 × 32 test pattern: a gradient with a bright square and a dark stripe.
    fn pattern() -> Image {
        let px: Vec<[f32; 3]> = (0..48 * 32)
            .map(|i| {
                let (x, y) = ((i % 48) as f32, (i / 48) as f32);
                let v = if (10.0..20.0).contains(&x) && (8.0..18.0).contains(&y) {
                    0.9
                } else {
                    0.05 + x / 96.0
                };
                let v = if (26.0..28.0).contains(&y) { 0.01 } else { v };
                [v, 0.6 * v, 0.3 + 0.2 * (y / 32.0)]
            })
            .collect();
        image(48, 32, &px)
    }

    fn noisy(base: &Image, amplitude: f32, seed: u64) -> Image {
        let mut rng = crate::sampling::Rng::for_task(seed, [0, 0, 0]);
        Image {
            pixels: base
                .pixels
                .iter()
                .map(|p| (*p * (1.0 + amplitude * (2.0 * rng.uniform() - 1.0))).max(Vec3::ZERO))
                .collect(),
            ..base.clone()
        }
    }

    #[test]
    fn flip_is_zero_for_identical_images_and_grows_with_the_noise() {
        let r = pattern();
        assert_eq!(flip(&r, &r), 0.0);
        let errors: Vec<f64> = [0.02, 0.1, 0.3, 0.8]
            .iter()
            .map(|&a| flip(&noisy(&r, a, 7), &r))
            .collect();
        assert!(
            errors.windows(2).all(|w| 0.0 < w[0] && w[0] < w[1] && w[1] <= 1.0),
            "{errors:?}"
        );
        // It is part of every comparison.
        assert_eq!(compare(&noisy(&r, 0.3, 7), &r).unwrap().flip, errors[2]);
    }

    #[test]
    fn mse_ldr_compares_the_display_images() {
        // Both saturate: no error on the display, however different the radiance.
        assert_eq!(mse_ldr(&image(1, 1, &[[5.0; 3]]), &image(1, 1, &[[50.0; 3]])), 0.0);
        // Black against white: full scale in every channel.
        assert_eq!(mse_ldr(&image(1, 1, &[[0.0; 3]]), &image(1, 1, &[[1.0; 3]])), 1.0);
        // 0.5 linear is sRGB 188/255; against black, one channel of three.
        let e = mse_ldr(&image(1, 1, &[[0.5, 0.0, 0.0]]), &image(1, 1, &[[0.0; 3]]));
        assert!((e - (188.0f64 / 255.0).powi(2) / 3.0).abs() < 1e-12, "{e}");
    }

    #[test]
    fn flip_sees_the_tone_mapped_images() {
        // Above 1 the previews saturate: a brighter light that stays above 1 looks the same.
        let bright = image(8, 8, &[[2.0, 3.0, 4.0]; 64]);
        let brighter = image(8, 8, &[[5.0, 6.0, 7.0]; 64]);
        assert_eq!(flip(&brighter, &bright), 0.0);
        // Black against white differs most: no edges, so the colour error alone (Andersson et
        // al. 2020, eq. 4 with ΔE_f = 0), and it is large.
        let black = image(8, 8, &[[0.0; 3]; 64]);
        let white = image(8, 8, &[[1.0; 3]; 64]);
        let e = flip(&black, &white);
        assert!(e > 0.5 && e <= 1.0, "{e}");
        // A single pixel works (the filters are wider than the image).
        assert!(flip(&image(1, 1, &[[0.2; 3]]), &image(1, 1, &[[0.3; 3]])) > 0.0);
    }

    fn grey(width: u32, height: u32, values: &[f32]) -> Image {
        Image {
            width,
            height,
            pixels: values.iter().map(|&v| Vec3::splat(v)).collect(),
        }
    }

    fn assert_close(actual: f64, expected: f64) {
        assert!(
            (actual - expected).abs() <= 1e-12 * expected.abs().max(1.0),
            "{actual} != {expected}"
        );
    }

    #[test]
    fn mse_and_rmse_average_over_pixels_and_channels() {
        // Differences (1, 0, -2) and (0, 0, 1): squares sum to 6 over 6 values.
        let r = image(2, 1, &[[1.0, 2.0, 3.0], [0.0, 0.0, 0.0]]);
        let i = image(2, 1, &[[2.0, 2.0, 1.0], [0.0, 0.0, 1.0]]);
        let m = compare(&i, &r).unwrap();
        assert_close(m.mse, 1.0);
        assert_close(m.rmse, 1.0);
        // Fewer than 1000 pixels: nothing trimmed.
        assert_close(m.mse_trimmed, m.mse);
        assert_close(m.rel_mse_trimmed, m.rel_mse);
    }

    #[test]
    fn rel_mse_divides_by_squared_reference_plus_epsilon() {
        let r = image(2, 1, &[[1.0, 2.0, 3.0], [0.0, 0.0, 0.0]]);
        let i = image(2, 1, &[[2.0, 2.0, 1.0], [0.0, 0.0, 1.0]]);
        let m = compare(&i, &r).unwrap();
        // 1/(1+ε) + 0 + 4/(9+ε) + 0 + 0 + 1/(0+ε), over 6 values.
        let expected = (1.0 / 1.001 + 4.0 / 9.001 + 1.0 / 0.001) / 6.0;
        assert_close(m.rel_mse, expected);

        // Reference 2, image 3: 1/(4+ε), not the unsquared 1/(2+ε) of tungsten#57.
        let m = compare(&grey(1, 1, &[3.0]), &grey(1, 1, &[2.0])).unwrap();
        assert_close(m.rel_mse, 1.0 / 4.001);
    }

    #[test]
    fn rel_mse_epsilon_keeps_black_reference_finite() {
        let m = compare(&grey(1, 1, &[0.5]), &grey(1, 1, &[0.0])).unwrap();
        assert_close(m.rel_mse, 0.25 / REL_MSE_EPSILON);
        let m = compare(&grey(1, 1, &[0.0]), &grey(1, 1, &[0.0])).unwrap();
        assert_eq!(m.rel_mse, 0.0);
    }

    #[test]
    fn trimmed_count_is_floor_of_a_thousandth() {
        assert_eq!(trimmed_pixel_count(0), 0);
        assert_eq!(trimmed_pixel_count(999), 0);
        assert_eq!(trimmed_pixel_count(1000), 1);
        assert_eq!(trimmed_pixel_count(2999), 2);
        assert_eq!(trimmed_pixel_count(1920 * 1080), 2073);
    }

    #[test]
    fn trimmed_mse_drops_the_firefly() {
        // 1000 pixels off by 0.1 in every channel, one of them a firefly off by 100.
        let r = grey(1000, 1, &[1.0; 1000]);
        let mut values = vec![1.1f32; 1000];
        values[417] = 101.0;
        let i = grey(1000, 1, &values);
        let m = compare(&i, &r).unwrap();
        let d = 1.1f32 as f64 - 1.0;
        let d2 = d * d;
        assert_close(m.mse, (999.0 * d2 + 1e4) / 1000.0);
        assert_close(m.mse_trimmed, d2);
        assert_close(m.rel_mse_trimmed, d2 / (1.0 + REL_MSE_EPSILON));

        // With 999 pixels floor(0.999) = 0: the firefly stays.
        let m = compare(&grey(999, 1, &values[..999]), &grey(999, 1, &[1.0; 999])).unwrap();
        assert_close(m.mse_trimmed, m.mse);
    }

    #[test]
    fn trimmed_mse_drops_exactly_the_brightest_count() {
        // 2000 pixels: floor(2) are dropped out of 3 fireflies; the smallest one stays.
        let r = grey(2000, 1, &[0.0; 2000]);
        let mut values = vec![1.0f32; 2000];
        values[5] = 30.0;
        values[1000] = 10.0;
        values[1999] = 20.0;
        let m = compare(&grey(2000, 1, &values), &r).unwrap();
        assert_close(m.mse_trimmed, (1997.0 + 100.0) / 1998.0);
        assert_close(m.mse, (1997.0 + 100.0 + 400.0 + 900.0) / 2000.0);
    }

    #[test]
    fn rms_relative_luminance_excludes_black_reference_pixels() {
        // Y(R) = 1, 2, 0; relative errors 0.5 and -0.5; the black pixel is excluded.
        let r = grey(3, 1, &[1.0, 2.0, 0.0]);
        let i = grey(3, 1, &[1.5, 1.0, 5.0]);
        let m = compare(&i, &r).unwrap();
        assert_close(m.rms_rel_lum, 0.5);
        assert_eq!(m.rms_rel_lum_excluded, 1);
    }

    #[test]
    fn rms_relative_luminance_uses_rec709_weights() {
        // Y(R) = 0.2126, Y(I) = 0.2126 + 0.7152.
        let r = image(1, 1, &[[1.0, 0.0, 0.0]]);
        let i = image(1, 1, &[[1.0, 1.0, 0.0]]);
        let m = compare(&i, &r).unwrap();
        let expected = 0.7152f64 / 0.2126;
        assert!((m.rms_rel_lum - expected).abs() < 1e-6 * expected);
        assert_eq!(m.rms_rel_lum_excluded, 0);
    }

    #[test]
    fn rms_relative_luminance_threshold_is_relative_to_mean() {
        // Mean Y(R) = (1 + 1 + 3e-5 + 2e-4) / 4 ≈ 0.5; threshold ≈ 5e-5: 3e-5 out, 2e-4 in.
        let r = grey(4, 1, &[1.0, 1.0, 3e-5, 2e-4]);
        let i = grey(4, 1, &[1.0, 1.0, 1.0, 4e-4]);
        let m = compare(&i, &r).unwrap();
        assert_eq!(m.rms_rel_lum_excluded, 1);
        // Only the 2e-4 pixel has an error: relative error 1 over 3 included pixels.
        assert!((m.rms_rel_lum - (1.0f64 / 3.0).sqrt()).abs() < 1e-6);

        // An all-black reference excludes everything.
        let m = compare(&grey(2, 1, &[1.0, 0.0]), &grey(2, 1, &[0.0, 0.0])).unwrap();
        assert_eq!(m.rms_rel_lum_excluded, 2);
        assert!(m.rms_rel_lum.is_nan());
    }

    #[test]
    fn identical_images_have_zero_error() {
        let r = image(2, 2, &[[0.1, 0.2, 0.3], [1.0, 0.0, 4.0], [0.0; 3], [7.0, 7.0, 7.0]]);
        let m = compare(&r, &r).unwrap();
        assert_eq!(m.mse, 0.0);
        assert_eq!(m.rel_mse, 0.0);
        assert_eq!(m.mse_trimmed, 0.0);
        assert_eq!(m.rel_mse_trimmed, 0.0);
        assert_eq!(m.rms_rel_lum, 0.0);
        assert_eq!(m.rms_rel_lum_excluded, 1);
    }

    #[test]
    fn size_mismatch_is_a_one_line_error_naming_both_sizes() {
        let e = compare(&Image::new(2, 1), &Image::new(1, 2)).unwrap_err();
        let msg = e.message();
        assert!(msg.contains("2x1") && msg.contains("1x2"), "{msg}");
        assert!(!msg.contains('\n'));
        assert!(compare(&Image::new(0, 0), &Image::new(0, 0)).is_err());
    }

    #[test]
    fn efficiency_is_inverse_of_error_times_time() {
        assert_close(efficiency(0.5, 4.0), 0.5);
        assert_close(efficiency(0.01, 10.0), 10.0);
    }

    #[test]
    fn error_map_scale_is_logarithmic_from_a_thousandth_to_ten() {
        assert_eq!(error_map_colour(0.0), viridis(0.0));
        assert_eq!(error_map_colour(ERROR_MAP_MIN), viridis(0.0));
        // One decade is a quarter of the colormap: 10 % is its middle.
        assert_eq!(error_map_colour(0.1), viridis(0.5));
        assert_eq!(error_map_colour(0.01), viridis(0.25));
        assert_eq!(error_map_colour(ERROR_MAP_MAX), viridis(1.0));
        assert_eq!(error_map_colour(f64::INFINITY), viridis(1.0));
        assert_eq!(error_map_colour(f64::NAN), ERROR_MAP_NAN_RGB);
    }

    #[test]
    fn error_png_colours_exact_firefly_and_nan_pixels() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("error.png");
        let reference = image(3, 1, &[[1.0; 3], [1.0; 3], [1.0; 3]]);
        let im = image(3, 1, &[[1.0; 3], [1000.0; 3], [f32::NAN; 3]]);
        write_error_png(&im, &reference, &path).unwrap();
        let png = image::open(&path).unwrap().to_rgb8();
        assert_eq!(png.dimensions(), (3, 1));
        assert_eq!(png.get_pixel(0, 0).0, viridis(0.0));
        assert_eq!(png.get_pixel(1, 0).0, viridis(1.0));
        assert_eq!(png.get_pixel(2, 0).0, ERROR_MAP_NAN_RGB);

        let e = relative_error_per_pixel(&image(1, 1, &[[1.1, 1.1, 1.1]]), &image(1, 1, &[[1.0; 3]])).unwrap();
        assert!((e[0] - 0.1 / 1.001f64.sqrt()).abs() < 1e-6);
        assert!(write_error_png(&Image::new(2, 1), &Image::new(1, 2), &path).is_err());
    }
}
