//! Textures: colours that vary over a surface with its (u, v) coordinates, as Mitsuba 3 defines
//! them: `checkerboard` and `bitmap` (PNG, JPEG, BMP or OpenEXR), each with an affine `to_uv` map.
//!
//! What lives here: the textures' data and their evaluation at a (u, v) point, and decoding of
//! image files into linear RGB. What does not: where (u, v) comes from (the scene's primitives,
//! [`crate::scene::Scene::uv`]), which material parameter a texture drives
//! ([`crate::scene::Material`]), or reading files (the loader hands over the bytes).
//!
//! Conventions follow Mitsuba 3.9 so that the same scene renders the same image:
//! - `to_uv` maps the surface's (u, v) before the lookup: (u', v') = M (u, v) + t (a 4 × 4
//!   matrix in a Mitsuba file contributes its upper-left 2 × 2 block and the first two entries
//!   of its last column, as Mitsuba's `Transform::extract`).
//! - Bitmap texel (x, y) covers [x, x + 1)/W × [y, y + 1)/H in (u', v'), with row y = 0 the
//!   first row of the file (the top of the picture); the OBJ reader flips v as Mitsuba does, so
//!   that the usual bottom-up v lands on the right row (PLY and `.serialized` coordinates are
//!   used as they are, as Mitsuba 3.9.1 does).
//! - Bilinear filtering interpolates the four texels around u'·W − ½, v'·H − ½; `nearest` takes
//!   the texel under (u', v'). Wrap modes `repeat`, `mirror` and `clamp` act on texel indices.
//! - 8- and 16-bit PNG, JPEG and BMP files hold sRGB-encoded values; they are decoded to linear RGB
//!   per texel when loaded (before filtering) unless `raw`; OpenEXR files are linear already.
//!   Alpha is ignored; a grey image gives grey colours.
//! - The checkerboard picks `color0` where the fractional parts of u' and v' are on the same
//!   side of ½, `color1` elsewhere (Mitsuba's `eval`); for a number parameter ([`Scalar`]: an
//!   opacity, a blend weight, a roughness) it swaps the two, as Mitsuba 3.9.1's `eval_1` does
//!   (the pattern moved by one cell; followed so that the same scene renders the same image).
//! - `mesh_attribute` reads a value the mesh carries ([`MeshAttribute`]): per vertex,
//!   interpolated with the point's barycentrics b₀ a₀ + b₁ a₁ + b₂ a₂ (b₀ = 1 − b₁ − b₂, in the
//!   triangle's vertex order), or per face, constant; then × `scale`. A one-channel attribute
//!   gives grey colours. Checked on Mitsuba 3.9.1's `eval` at a ray's hit on a one-triangle mesh.

use glam::{Vec2, Vec3};
use std::sync::Arc;

/// An affine map of texture coordinates, (u', v') = M (u, v) + t.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    /// Rows of the 2 × 3 matrix [M | t].
    pub rows: [[f32; 3]; 2],
}

impl Default for UvTransform {
    fn default() -> Self {
        Self {
            rows: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        }
    }
}

impl UvTransform {
    /// Scaling by (su, sv), then offsetting by (ou, ov).
    pub fn scale_offset(scale: Vec2, offset: Vec2) -> Self {
        Self {
            rows: [[scale.x, 0.0, offset.x], [0.0, scale.y, offset.y]],
        }
    }

    #[inline]
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        let [a, b] = self.rows;
        Vec2::new(a[0] * uv.x + a[1] * uv.y + a[2], b[0] * uv.x + b[1] * uv.y + b[2])
    }
}

/// A texture; cheap to clone (a bitmap's texels are shared).
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    Checkerboard(Checkerboard),
    Bitmap(Bitmap),
    MeshAttribute(MeshAttribute),
}

/// Where a texture is read: the surface's (u, v); and the primitive and the barycentrics
/// (b₁, b₂) of the point in it, for textures of the mesh's own data ([`MeshAttribute`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TexPoint {
    pub uv: Vec2,
    pub prim: u32,
    pub bary: Vec2,
}

/// Mitsuba 3's `mesh_attribute` (module doc): a mesh's per-vertex or per-face values.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshAttribute {
    /// The attribute's name (`vertex_color`, `face_color`, …).
    pub name: String,
    pub scale: f32,
    pub per_face: bool,
    /// Per primitive of the scene, the values at its three corners (a face attribute's value
    /// three times; zero for primitives of other materials, which never read it).
    pub corners: Arc<[[Vec3; 3]]>,
    /// Per-channel least and largest values and the mean over the corners of the primitives
    /// that read it, × `scale` (vertex values stay within them between corners).
    pub min: Vec3,
    pub max: Vec3,
    pub mean: Vec3,
}

impl MeshAttribute {
    #[inline]
    pub fn eval(&self, at: &TexPoint) -> Vec3 {
        let [a, b, c] = self.corners[at.prim as usize];
        let value = if self.per_face {
            a
        } else {
            (1.0 - at.bary.x - at.bary.y) * a + at.bary.x * b + at.bary.y * c
        };
        value * self.scale
    }
}

/// Two colours in a unit checker pattern of (u', v').
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Checkerboard {
    pub color0: Vec3,
    pub color1: Vec3,
    pub to_uv: UvTransform,
}

/// How a bitmap is read between texel centres.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    Bilinear,
    Nearest,
}

/// How texel indices outside the image are brought back in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Repeat,
    Mirror,
    Clamp,
}

/// An image of linear RGB texels.
#[derive(Clone, Debug, PartialEq)]
pub struct Bitmap {
    pub width: u32,
    pub height: u32,
    /// Row-major, row 0 first in the file (the top of the picture).
    pub texels: Arc<[Vec3]>,
    pub filter: Filter,
    pub wrap: Wrap,
    pub to_uv: UvTransform,
}

impl Texture {
    /// The colour at a surface point.
    #[inline]
    pub fn eval_at(&self, at: &TexPoint) -> Vec3 {
        match self {
            Texture::MeshAttribute(m) => m.eval(at),
            _ => self.eval(at.uv),
        }
    }

    /// The colour at surface coordinates `uv`; a mesh attribute, which (u, v) alone does not
    /// locate, gives its mean (the loader lets mesh attributes drive a model's parameters only,
    /// which are read with [`Texture::eval_at`]).
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        match self {
            Texture::Checkerboard(c) => c.eval(uv),
            Texture::Bitmap(b) => b.eval(uv),
            Texture::MeshAttribute(m) => m.mean,
        }
    }

    /// The number a number parameter reads at a surface point (Mitsuba's `eval_1`): the
    /// luminance of the colour, a checkerboard's colours swapped (module doc).
    #[inline]
    pub fn eval_number_at(&self, at: &TexPoint) -> f32 {
        match self {
            Texture::MeshAttribute(m) => crate::color::luminance(m.eval(at)),
            _ => self.eval_number(at.uv),
        }
    }

    /// [`Texture::eval_number_at`] at surface coordinates `uv` (a mesh attribute: its mean's).
    #[inline]
    pub fn eval_number(&self, uv: Vec2) -> f32 {
        crate::color::luminance(match self {
            Texture::Checkerboard(c) => c.eval_swapped(uv),
            Texture::Bitmap(b) => b.eval(uv),
            Texture::MeshAttribute(m) => m.mean,
        })
    }

    /// The gradient (∂/∂u, ∂/∂v) of [`Texture::eval_number`] at `uv` (Mitsuba's `eval_1_grad`,
    /// what a bump map reads): a bilinear bitmap's exact derivative within its cell; zero for a
    /// nearest-texel bitmap and a checkerboard, which are flat between their steps.
    pub fn gradient_number(&self, uv: Vec2) -> Vec2 {
        match self {
            Texture::Checkerboard(_) | Texture::MeshAttribute(_) => Vec2::ZERO,
            Texture::Bitmap(b) => b.gradient_number(uv),
        }
    }

    /// The largest value of each channel anywhere on the texture.
    pub fn max(&self) -> Vec3 {
        match self {
            Texture::Checkerboard(c) => c.color0.max(c.color1),
            Texture::Bitmap(b) => b.texels.iter().fold(Vec3::ZERO, |m, &t| m.max(t)),
            Texture::MeshAttribute(m) => m.max,
        }
    }

    /// The smallest value of each channel anywhere on the texture.
    pub fn min(&self) -> Vec3 {
        match self {
            Texture::Checkerboard(c) => c.color0.min(c.color1),
            Texture::Bitmap(b) => b.texels.iter().fold(Vec3::INFINITY, |m, &t| m.min(t)),
            Texture::MeshAttribute(m) => m.min,
        }
    }

    /// The mean colour over the unit square of (u', v').
    pub fn mean(&self) -> Vec3 {
        match self {
            Texture::Checkerboard(c) => 0.5 * (c.color0 + c.color1),
            Texture::Bitmap(b) => {
                let sum: glam::DVec3 = b.texels.iter().map(|t| t.as_dvec3()).sum();
                (sum / b.texels.len().max(1) as f64).as_vec3()
            }
            Texture::MeshAttribute(m) => m.mean,
        }
    }
}

/// A number that may vary over a surface: Mitsuba's float parameters that take a texture (the
/// opacity of a `mask`). A colour texture gives its luminance, as Mitsuba's `eval_1` does
/// (a grey image its grey value).
#[derive(Clone, Debug, PartialEq)]
pub enum Scalar {
    Constant(f32),
    Texture(Texture),
}

impl Scalar {
    /// The value at surface coordinates `uv`.
    #[inline]
    pub fn at(&self, uv: Vec2) -> f32 {
        match self {
            Scalar::Constant(v) => *v,
            Scalar::Texture(t) => t.eval_number(uv),
        }
    }

    /// The smallest and largest values anywhere (a texture's per-texel luminance; bilinear
    /// filtering stays within them).
    pub fn range(&self) -> (f32, f32) {
        match self {
            Scalar::Constant(v) => (*v, *v),
            Scalar::Texture(Texture::Checkerboard(c)) => {
                let (a, b) = (crate::color::luminance(c.color0), crate::color::luminance(c.color1));
                (a.min(b), a.max(b))
            }
            Scalar::Texture(Texture::MeshAttribute(m)) => {
                let (a, b) = (crate::color::luminance(m.min), crate::color::luminance(m.max));
                (a.min(b), a.max(b))
            }
            Scalar::Texture(Texture::Bitmap(b)) => {
                b.texels
                    .iter()
                    .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &t| {
                        let l = crate::color::luminance(t);
                        (lo.min(l), hi.max(l))
                    })
            }
        }
    }
}

impl Checkerboard {
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        if self.same_side(uv) { self.color0 } else { self.color1 }
    }

    /// The colour Mitsuba's `eval_1` reads for a number parameter: the other one.
    #[inline]
    pub fn eval_swapped(&self, uv: Vec2) -> Vec3 {
        if self.same_side(uv) { self.color1 } else { self.color0 }
    }

    /// Whether the fractional parts of u' and v' lie on the same side of ½.
    #[inline]
    fn same_side(&self, uv: Vec2) -> bool {
        let uv = self.to_uv.apply(uv);
        let upper = |x: f32| x - x.floor() > 0.5;
        upper(uv.x) == upper(uv.y)
    }
}

impl Bitmap {
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        let uv = self.to_uv.apply(uv);
        let (w, h) = (self.width as f32, self.height as f32);
        match self.filter {
            Filter::Nearest => self.texel((uv.x * w).floor(), (uv.y * h).floor()),
            Filter::Bilinear => {
                let (x, y) = (uv.x * w - 0.5, uv.y * h - 0.5);
                let (x0, y0) = (x.floor(), y.floor());
                let (fx, fy) = (x - x0, y - y0);
                let row = |y: f32| self.texel(x0, y).lerp(self.texel(x0 + 1.0, y), fx);
                row(y0).lerp(row(y0 + 1.0), fy)
            }
        }
    }

    /// [`Texture::gradient_number`]: the bilinear interpolation's derivative in texel units,
    /// scaled by the resolution and taken back through the affine `to_uv` (its transpose).
    fn gradient_number(&self, uv: Vec2) -> Vec2 {
        if self.filter == Filter::Nearest {
            return Vec2::ZERO;
        }
        let st = self.to_uv.apply(uv);
        let (w, h) = (self.width as f32, self.height as f32);
        let (x, y) = (st.x * w - 0.5, st.y * h - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let l = |dx: f32, dy: f32| crate::color::luminance(self.texel(x0 + dx, y0 + dy));
        let (l00, l10, l01, l11) = (l(0.0, 0.0), l(1.0, 0.0), l(0.0, 1.0), l(1.0, 1.0));
        let d_st = Vec2::new(
            w * ((1.0 - fy) * (l10 - l00) + fy * (l11 - l01)),
            h * ((1.0 - fx) * (l01 - l00) + fx * (l11 - l10)),
        );
        let [a, b] = self.to_uv.rows;
        Vec2::new(a[0] * d_st.x + b[0] * d_st.y, a[1] * d_st.x + b[1] * d_st.y)
    }

    /// The texel at integer coordinates (given as floats, possibly outside the image or not
    /// finite), after wrapping.
    #[inline]
    pub(crate) fn texel(&self, x: f32, y: f32) -> Vec3 {
        let x = wrap_index(x, self.width, self.wrap);
        let y = wrap_index(y, self.height, self.wrap);
        self.texels[y * self.width as usize + x]
    }
}

/// Brings integer coordinate `i` into 0..n by the wrap mode. Non-finite coordinates (a NaN uv
/// from a degenerate parameterization) land on texel 0 rather than anywhere undefined.
#[inline]
pub(crate) fn wrap_index(i: f32, n: u32, wrap: Wrap) -> usize {
    let n_f = n as f32;
    if !i.is_finite() {
        return 0;
    }
    let i = match wrap {
        Wrap::Repeat => i.rem_euclid(n_f),
        Wrap::Clamp => i.clamp(0.0, n_f - 1.0),
        Wrap::Mirror => {
            let m = i.rem_euclid(2.0 * n_f);
            if m >= n_f { 2.0 * n_f - 1.0 - m } else { m }
        }
    };
    // rem_euclid of a huge f32 can round up to n itself.
    (i as usize).min(n as usize - 1)
}

/// The sRGB transfer function's inverse (IEC 61966-2-1), as Mitsuba's `srgb_to_linear`.
#[inline]
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Decodes an image file's bytes into linear RGB texels: PNG, JPEG and BMP (sRGB-encoded unless
/// `raw`, as Mitsuba reads 8-bit images) by their signature, OpenEXR (linear). Returns width, height and the texels, or a
/// message saying what is wrong with the file.
pub fn decode_image(bytes: &[u8], raw: bool) -> Result<(u32, u32, Vec<Vec3>), String> {
    if bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        return decode_exr(bytes);
    }
    let format = image::guess_format(bytes).map_err(|_| "not a PNG, JPEG, BMP or OpenEXR image".to_string())?;
    if !matches!(
        format,
        image::ImageFormat::Png | image::ImageFormat::Jpeg | image::ImageFormat::Bmp
    ) {
        return Err(format!("a {format:?} image; expected PNG, JPEG, BMP or OpenEXR"));
    }
    let img = image::load_from_memory_with_format(bytes, format).map_err(|e| format!("cannot decode: {e}"))?;
    let (width, height) = (img.width(), img.height());
    if width == 0 || height == 0 {
        return Err("the image is empty".to_string());
    }
    // 16 bits keep the precision of deep PNGs; both are normalised to [0, 1] first.
    let rgb = img.to_rgb32f();
    let decode = |v: f32| if raw { v } else { srgb_to_linear(v) };
    let texels = rgb
        .pixels()
        .map(|p| Vec3::new(decode(p[0]), decode(p[1]), decode(p[2])))
        .collect();
    Ok((width, height, texels))
}

fn decode_exr(bytes: &[u8]) -> Result<(u32, u32, Vec<Vec3>), String> {
    use exr::prelude::{ReadChannels, ReadLayers};
    let read = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |resolution, _| {
                (
                    resolution.width(),
                    vec![Vec3::ZERO; resolution.width() * resolution.height()],
                )
            },
            |(width, pixels): &mut (usize, Vec<Vec3>), pos, (r, g, b, _a): (f32, f32, f32, exr::prelude::f16)| {
                pixels[pos.y() * *width + pos.x()] = Vec3::new(r, g, b);
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|e| format!("cannot read OpenEXR: {e}"))?;
    let size = read.layer_data.size;
    let (Ok(width), Ok(height)) = (u32::try_from(size.width()), u32::try_from(size.height())) else {
        return Err("the image is too large".to_string());
    };
    if width == 0 || height == 0 {
        return Err("the image is empty".to_string());
    }
    Ok((width, height, read.layer_data.channel_data.pixels.1))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bitmap(width: u32, height: u32, texels: Vec<Vec3>, filter: Filter, wrap: Wrap) -> Bitmap {
        Bitmap {
            width,
            height,
            texels: texels.into(),
            filter,
            wrap,
            to_uv: UvTransform::default(),
        }
    }

    /// Mitsuba's checkerboard at `to_uv` scale 8 (the matpreview floor): colour 0 on the
    /// diagonal cells, colour 1 off it, cell size 1/16.
    #[test]
    fn checkerboard_alternates_cells_as_mitsuba() {
        let c = Checkerboard {
            color0: Vec3::splat(0.2),
            color1: Vec3::splat(0.4),
            to_uv: UvTransform::scale_offset(Vec2::splat(8.0), Vec2::ZERO),
        };
        let cell = |i: f32, j: f32| c.eval(Vec2::new((i + 0.5) / 16.0, (j + 0.5) / 16.0)).x;
        for i in 0..16 {
            for j in 0..16 {
                let same = (i % 2) == (j % 2);
                assert_eq!(cell(i as f32, j as f32), if same { 0.2 } else { 0.4 }, "cell {i},{j}");
            }
        }
        // Negative coordinates continue the pattern (floor, not truncation).
        assert_eq!(c.eval(Vec2::new(-0.5 / 16.0, 0.5 / 16.0)).x, 0.4);
    }

    /// At texel centres bilinear filtering returns the texel; halfway between two it returns
    /// their mean; and it is linear in between.
    #[test]
    fn the_bilinear_gradient_is_the_derivative_of_the_number_read() {
        let texels: Vec<Vec3> = [0.1f32, 0.7, 0.3, 0.2, 0.9, 0.5, 0.4, 0.8, 0.0]
            .iter()
            .map(|&g| Vec3::splat(g))
            .collect();
        let mut bitmap = Bitmap {
            width: 3,
            height: 3,
            texels: texels.into(),
            filter: Filter::Bilinear,
            wrap: Wrap::Repeat,
            to_uv: UvTransform {
                rows: [[2.0, 0.5, 0.1], [-0.3, 1.5, 0.2]],
            },
        };
        let t = Texture::Bitmap(bitmap.clone());
        // Along any line a bilinear function is quadratic within a cell, where central
        // differences are exact: compare at points whose differences stay in one cell.
        let h = 1e-3f32;
        let mut compared = 0;
        for k in 0..200 {
            let uv = Vec2::new((k as f32 * 0.137).fract(), (k as f32 * 0.291 + 0.05).fract());
            let in_cell = [Vec2::new(h, 0.0), Vec2::new(0.0, h)].iter().all(|d| {
                let cell = |uv: Vec2| {
                    let st = bitmap.to_uv.apply(uv) * 3.0 - Vec2::splat(0.5);
                    st.floor()
                };
                cell(uv + *d) == cell(uv - *d)
            });
            if !in_cell {
                continue;
            }
            compared += 1;
            let g = t.gradient_number(uv);
            let num = Vec2::new(
                t.eval_number(uv + Vec2::new(h, 0.0)) - t.eval_number(uv - Vec2::new(h, 0.0)),
                t.eval_number(uv + Vec2::new(0.0, h)) - t.eval_number(uv - Vec2::new(0.0, h)),
            ) / (2.0 * h);
            assert!((g - num).length() < 2e-3 * g.length().max(1.0), "{uv}: {g} vs {num}");
        }
        assert!(compared > 150, "{compared}");
        bitmap.filter = Filter::Nearest;
        assert_eq!(Texture::Bitmap(bitmap).gradient_number(Vec2::new(0.3, 0.4)), Vec2::ZERO);
    }

    #[test]
    fn bilinear_filter_interpolates_between_texel_centres() {
        let t = [Vec3::ZERO, Vec3::ONE, Vec3::splat(2.0), Vec3::splat(3.0)];
        let b = bitmap(2, 2, t.to_vec(), Filter::Bilinear, Wrap::Clamp);
        assert_eq!(b.eval(Vec2::new(0.25, 0.25)), t[0]);
        assert_eq!(b.eval(Vec2::new(0.75, 0.25)), t[1]);
        assert_eq!(b.eval(Vec2::new(0.25, 0.75)), t[2]);
        assert_eq!(b.eval(Vec2::new(0.5, 0.25)), Vec3::splat(0.5));
        assert_eq!(b.eval(Vec2::new(0.5, 0.5)), Vec3::splat(1.5));
        // Clamped at the border: beyond the outer texel centres the value stays.
        assert_eq!(b.eval(Vec2::new(0.0, 0.0)), t[0]);
        let n = bitmap(2, 2, t.to_vec(), Filter::Nearest, Wrap::Clamp);
        assert_eq!(n.eval(Vec2::new(0.49, 0.51)), t[2]);
    }

    #[test]
    fn wrap_modes_fold_indices_as_mitsuba() {
        let fold = |wrap| (-1..6).map(|i| wrap_index(i as f32, 3, wrap)).collect::<Vec<_>>();
        assert_eq!(fold(Wrap::Repeat), [2, 0, 1, 2, 0, 1, 2]);
        assert_eq!(fold(Wrap::Clamp), [0, 0, 1, 2, 2, 2, 2]);
        assert_eq!(fold(Wrap::Mirror), [0, 0, 1, 2, 2, 1, 0]);
        assert_eq!(wrap_index(f32::NAN, 3, Wrap::Repeat), 0);
        assert!(wrap_index(1e30, 3, Wrap::Repeat) < 3 && wrap_index(-1e30, 3, Wrap::Mirror) < 3);
    }

    /// A PNG's 8-bit values are sRGB: 128 decodes to 0.2158, 255 to 1, 0 to 0; `raw` keeps them.
    #[test]
    fn png_values_are_decoded_from_srgb_unless_raw() {
        let img = image::RgbImage::from_raw(2, 1, vec![128, 0, 255, 64, 64, 64]).unwrap();
        let mut png = std::io::Cursor::new(Vec::new());
        img.write_to(&mut png, image::ImageFormat::Png).unwrap();
        let (w, h, t) = decode_image(png.get_ref(), false).unwrap();
        assert_eq!((w, h), (2, 1));
        assert!((t[0].x - 0.215_861).abs() < 1e-5 && t[0].y == 0.0 && (t[0].z - 1.0).abs() < 1e-6);
        let (_, _, raw) = decode_image(png.get_ref(), true).unwrap();
        assert!((raw[0].x - 128.0 / 255.0).abs() < 1e-6);
        assert!(decode_image(b"not an image", false).is_err());
    }

    #[test]
    fn exr_texels_are_read_linear() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.exr");
        let image = crate::film::Image {
            width: 2,
            height: 1,
            pixels: vec![Vec3::new(0.5, 2.0, 0.0), Vec3::new(0.25, 0.0, 1.0)],
        };
        crate::film::write_exr(&image, &path).unwrap();
        let (w, h, t) = decode_image(&std::fs::read(&path).unwrap(), false).unwrap();
        assert_eq!((w, h, t), (2, 1, image.pixels));
    }
}
