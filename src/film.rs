//! Film: per-pixel accumulation of samples in linear RGB, with non-finite samples counted and
//! excluded; the resulting [`Image`] and its EXR / PNG input and output.

use crate::color::srgb8;
use crate::error::{Context, Error, Result};
use crate::util::{write_atomic, write_atomic_with};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::path::Path;

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
///
/// Each pixel's samples are added one by one in sample order, whether they arrive in one pass
/// or several, so a render split into passes is bit-identical to one pass.
#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pixels: Vec<PixelAccumulator>,
    /// Non-finite splats (splats belong to no pixel sample).
    non_finite_splats: u64,
}

/// The accumulator of one pixel.
#[derive(Clone, Copy, Debug, Default)]
pub struct PixelAccumulator {
    /// Sum of finite samples (f64 so that 32 000-spp references keep full precision).
    pub sum: DVec3,
    /// Number of finite samples.
    pub count: u32,
    /// Samples dropped because a channel was NaN or infinite.
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
            pixels: vec![PixelAccumulator::default(); n],
            non_finite_splats: 0,
        }
    }

    /// Rows of pixel accumulators, for parallel rendering (row index, pixels of the row).
    pub fn rows_mut(&mut self) -> impl IndexedParallelIterator<Item = (usize, &mut [PixelAccumulator])> {
        self.pixels.par_chunks_mut(self.width as usize).enumerate()
    }

    /// Adds a splatted contribution (light tracing, MLT) to pixel `index`; it counts no sample.
    pub fn splat(&mut self, index: usize, l: Vec3) {
        if l.is_finite() {
            self.pixels[index].sum += l.as_dvec3();
        } else {
            self.non_finite_splats += 1;
        }
    }

    /// The pixel accumulators, row by row.
    pub fn accumulators(&self) -> &[PixelAccumulator] {
        &self.pixels
    }

    /// Adds the samples and splats of `other` (a film of the same size holding other samples
    /// of the same render) to this one.
    pub fn absorb(&mut self, other: &Film) {
        assert_eq!(
            (self.width, self.height),
            (other.width, other.height),
            "films of one render"
        );
        for (p, q) in self.pixels.iter_mut().zip(&other.pixels) {
            p.sum += q.sum;
            p.count += q.count;
            p.non_finite += q.non_finite;
        }
        self.non_finite_splats += other.non_finite_splats;
    }

    /// Samples (and splats) dropped because they were NaN or infinite.
    pub fn non_finite(&self) -> u64 {
        self.non_finite_splats + self.pixels.iter().map(|p| p.non_finite as u64).sum::<u64>()
    }

    /// The image: the mean of the finite samples of each pixel.
    pub fn image(&self) -> Image {
        let pixels = self
            .pixels
            .iter()
            .map(|p| {
                if p.count > 0 {
                    (p.sum / p.count as f64).as_vec3()
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

    /// The pixel sums scaled by `scale` instead of divided by each pixel's sample count (for
    /// splatting estimators, whose pixels receive a varying number of contributions).
    pub fn image_scaled(&self, scale: f64) -> Image {
        let pixels = self.pixels.iter().map(|p| (p.sum * scale).as_vec3()).collect();
        Image {
            width: self.width,
            height: self.height,
            pixels,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Image input and output.

/// Checks that `image.pixels` holds `width · height` pixels.
pub(crate) fn check_pixel_count(image: &Image, what: impl std::fmt::Display) -> Result<()> {
    let expected = image.width as usize * image.height as usize;
    if image.pixels.len() != expected {
        return Err(Error::new(format!(
            "{what}: a {}x{} image must hold {expected} pixels, not {}",
            image.width,
            image.height,
            image.pixels.len()
        )));
    }
    Ok(())
}

/// Writes `image` as an OpenEXR file of 32-bit float R, G, B channels, ZIP-compressed in blocks
/// of 16 scanlines (`Encoding::SMALL_LOSSLESS`: lossless, and much smaller than the default RLE
/// on noisy renders, which matters for committed references). The file is written atomically.
pub fn write_exr(image: &Image, path: &Path) -> Result<()> {
    use exr::prelude::{Encoding, Layer, LayerAttributes, SpecificChannels, Vec2, WritableImage};
    check_pixel_count(image, path.display())?;
    let width = image.width as usize;
    let layer = Layer::new(
        (width, image.height as usize),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        SpecificChannels::rgb(|pos: Vec2<usize>| {
            let p = image.pixels[pos.y() * width + pos.x()];
            (p.x, p.y, p.z)
        }),
    );
    let exr_image = exr::prelude::Image::from_layer(layer);
    write_atomic_with(path, |tmp| {
        exr_image
            .write()
            .to_file(tmp)
            .context(format_args!("{}: cannot write EXR", path.display()))
    })
}

/// Reads the first RGB(A) layer of an OpenEXR file as f32 linear RGB (alpha is ignored).
/// A missing, unreadable or corrupt file is a one-line error naming the path.
pub fn read_exr(path: &Path) -> Result<Image> {
    crate::util::check_input(path, "EXR image", crate::util::MAX_IMAGE_INPUT)?;
    let read = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |resolution, _| {
            (
                resolution.width(),
                vec![Vec3::ZERO; resolution.width() * resolution.height()],
            )
        },
        |(width, pixels), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            pixels[pos.y() * *width + pos.x()] = Vec3::new(r, g, b);
        },
    )
    .context(format_args!("{}: cannot read EXR", path.display()))?;
    let size = read.layer_data.size;
    let (_, pixels) = read.layer_data.channel_data.pixels;
    let (Ok(width), Ok(height)) = (u32::try_from(size.width()), u32::try_from(size.height())) else {
        return Err(Error::new(format!(
            "{}: EXR of {}x{} pixels is too large",
            path.display(),
            size.width(),
            size.height()
        )));
    };
    Ok(Image { width, height, pixels })
}

/// Encodes an 8-bit RGB buffer as PNG and writes it atomically.
pub fn write_rgb8_png(rgb: &image::RgbImage, path: &Path) -> Result<()> {
    let mut bytes = std::io::Cursor::new(Vec::new());
    rgb.write_to(&mut bytes, image::ImageFormat::Png)
        .context(format_args!("{}: cannot encode PNG", path.display()))?;
    write_atomic(path, bytes.get_ref())
}

/// Writes an 8-bit sRGB PNG preview of a linear-RGB image: each channel is scaled by
/// `2^exposure_stops` (0 leaves the image as is, +1 doubles it), clamped to `[0, 1]` and
/// encoded with the sRGB transfer function ([`crate::color::srgb_encode`]). The file is written atomically.
pub fn write_png(image: &Image, path: &Path, exposure_stops: f32) -> Result<()> {
    check_pixel_count(image, path.display())?;
    let scale = exposure_stops.exp2();
    let rgb = image::RgbImage::from_fn(image.width, image.height, |x, y| {
        let p = image.get(x, y) * scale;
        image::Rgb([srgb8(p.x), srgb8(p.y), srgb8(p.z)])
    });
    write_rgb8_png(&rgb, path)
}

/// Places `images` side by side, left to right and top-aligned, with `gap_px` black columns
/// between neighbours; shorter images are padded with black below. The strip is as tall as
/// the tallest image; an empty slice gives a 0x0 image.
pub fn image_strip(images: &[&Image], gap_px: u32) -> Image {
    let height = images.iter().map(|im| im.height).max().unwrap_or(0);
    let width = images.iter().map(|im| im.width).sum::<u32>() + gap_px * images.len().saturating_sub(1) as u32;
    let mut strip = Image::new(width, height);
    let mut x0 = 0usize;
    for im in images {
        for y in 0..im.height as usize {
            let src = &im.pixels[y * im.width as usize..(y + 1) * im.width as usize];
            let dst = y * width as usize + x0;
            strip.pixels[dst..dst + src.len()].copy_from_slice(src);
        }
        x0 += (im.width + gap_px) as usize;
    }
    strip
}

/// Rows of images stacked vertically, `gap_px` black pixels between rows and columns (each row
/// an [`image_strip`]): e.g. strategies as rows and checkpoints as columns.
pub fn image_grid(rows: &[Vec<&Image>], gap_px: u32) -> Image {
    let strips: Vec<Image> = rows.iter().map(|r| image_strip(r, gap_px)).collect();
    let width = strips.iter().map(|s| s.width).max().unwrap_or(0);
    let height = strips.iter().map(|s| s.height).sum::<u32>() + gap_px * strips.len().saturating_sub(1) as u32;
    let mut grid = Image::new(width, height);
    let mut y0 = 0usize;
    for s in &strips {
        for y in 0..s.height as usize {
            let src = &s.pixels[y * s.width as usize..(y + 1) * s.width as usize];
            let dst = (y0 + y) * width as usize;
            grid.pixels[dst..dst + src.len()].copy_from_slice(src);
        }
        y0 += (s.height + gap_px) as usize;
    }
    grid
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_grid_places_rows_below_each_other() {
        let a = image(1, 1, &[[1.0, 0.0, 0.0]]);
        let b = image(1, 1, &[[0.0, 1.0, 0.0]]);
        let c = image(1, 1, &[[0.0, 0.0, 1.0]]);
        let g = image_grid(&[vec![&a, &b], vec![&c]], 1);
        assert_eq!((g.width, g.height), (3, 3));
        let at = |x: usize, y: usize| g.pixels[y * 3 + x].to_array();
        assert_eq!(at(0, 0), [1.0, 0.0, 0.0]);
        assert_eq!(at(2, 0), [0.0, 1.0, 0.0]);
        assert_eq!(at(0, 2), [0.0, 0.0, 1.0]);
        assert_eq!(
            [at(1, 0), at(0, 1), at(2, 2)],
            [[0.0; 3]; 3],
            "gaps and the short row stay black"
        );
    }

    fn image(width: u32, height: u32, pixels: &[[f32; 3]]) -> Image {
        Image {
            width,
            height,
            pixels: pixels.iter().map(|&p| Vec3::from(p)).collect(),
        }
    }

    fn bits(image: &Image) -> Vec<[u32; 3]> {
        image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
    }

    #[test]
    fn exr_round_trip_is_bit_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ref.exr");
        let original = image(
            3,
            2,
            &[
                [0.0, -0.0, 1.0],
                [0.1, 0.2, 0.3],
                [1e-40, f32::MIN_POSITIVE, f32::MAX],
                [-1.5, 12345.678, f32::INFINITY],
                [std::f32::consts::PI, 1.0 / 3.0, 7e-8],
                [65504.0, 65505.0, 1e30],
            ],
        );
        write_exr(&original, &path).unwrap();
        let back = read_exr(&path).unwrap();
        assert_eq!((back.width, back.height), (3, 2));
        assert_eq!(bits(&back), bits(&original));
        // Atomic write: only the final file is left.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn exr_is_written_with_zip_compression() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        write_exr(&Image::new(4, 3), &path).unwrap();
        let meta = exr::meta::MetaData::read_from_file(&path, false).unwrap();
        assert_eq!(meta.headers[0].compression, exr::compression::Compression::ZIP16);
    }

    #[test]
    fn reading_corrupt_or_missing_exr_is_an_error_naming_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let corrupt = dir.path().join("corrupt.exr");
        std::fs::write(&corrupt, b"this is not an OpenEXR file").unwrap();
        let msg = read_exr(&corrupt).unwrap_err().message().to_string();
        assert!(msg.contains(&corrupt.display().to_string()), "{msg}");
        assert!(!msg.contains('\n'));

        // A valid header followed by truncated pixel data.
        let truncated = dir.path().join("truncated.exr");
        write_exr(&Image::new(64, 64), &truncated).unwrap();
        let bytes = std::fs::read(&truncated).unwrap();
        std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
        let msg = read_exr(&truncated).unwrap_err().message().to_string();
        assert!(msg.contains(&truncated.display().to_string()), "{msg}");

        let missing = dir.path().join("missing.exr");
        let msg = read_exr(&missing).unwrap_err().message().to_string();
        assert!(msg.contains(&missing.display().to_string()), "{msg}");
    }

    #[test]
    fn png_decodes_to_expected_srgb_values() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("preview.png");
        // 18 % grey encodes to 118, 0.5 to 188, 0.001 (linear segment) to 3; out of range
        // and NaN clamp.
        let im = image(
            3,
            2,
            &[
                [0.0, 1.0, 0.5],
                [0.18, 0.001, 2.0],
                [-1.0, f32::NAN, f32::INFINITY],
                [0.25, 0.09, 0.5],
                [0.0; 3],
                [1.0; 3],
            ],
        );
        write_png(&im, &path, 0.0).unwrap();
        let png = image::open(&path).unwrap().to_rgb8();
        assert_eq!(png.dimensions(), (3, 2));
        assert_eq!(png.get_pixel(0, 0).0, [0, 255, 188]);
        assert_eq!(png.get_pixel(1, 0).0, [118, 3, 255]);
        assert_eq!(png.get_pixel(2, 0).0, [0, 0, 255]);

        // +1 stop doubles: 0.25 -> 0.5, 0.09 -> 0.18.
        write_png(&im, &path, 1.0).unwrap();
        let png = image::open(&path).unwrap().to_rgb8();
        assert_eq!(png.get_pixel(0, 1).0, [188, 118, 255]);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn image_strip_places_images_side_by_side_with_black_gaps() {
        let a = image(2, 1, &[[1.0; 3], [2.0; 3]]);
        let b = image(1, 2, &[[3.0; 3], [4.0; 3]]);
        let strip = image_strip(&[&a, &b], 1);
        assert_eq!((strip.width, strip.height), (4, 2));
        let row = |y| (0..4).map(|x| strip.get(x, y).x).collect::<Vec<_>>();
        assert_eq!(row(0), [1.0, 2.0, 0.0, 3.0]);
        assert_eq!(row(1), [0.0, 0.0, 0.0, 4.0]);
        assert_eq!(image_strip(&[], 5), Image::new(0, 0));
    }
}
