//! Colour parameters that may be textures: each checked (every texel a reflectance in [0, 1]),
//! image files read once per scene and entered into the content hash.

use super::mesh::read_regular_file;
use super::*;
use crate::bsdf::ColorParam;
use crate::error::Result;
use crate::scene::desc::MeshAttributeDesc;
use crate::scene::desc::{BitmapDesc, CheckerboardDesc, Color, ScalarDesc, TextureDesc, UvTransformDesc};
use crate::texture::{Bitmap, Checkerboard, Filter, MeshAttribute, Scalar, Texture, UvTransform, Wrap, decode_image};
use glam::{Vec2, Vec3};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

/// Largest image accepted as a texture, in texels (a 16k × 16k picture).
const MAX_TEXELS: u64 = 1 << 28;

/// A decoded image: width, height, linear texels.
type Decoded = (u32, u32, Arc<[Vec3]>);

/// The textures of the material being built, and every image file the scene's materials read.
pub(super) struct Textures<'a> {
    /// Directory of the scene file: relative image paths start here.
    pub(super) dir: &'a std::path::Path,
    /// The current material's textured parameters.
    pub(super) params: Vec<(ColorParam, Texture)>,
    /// Images by (path, raw), decoded once however many materials use them.
    images: BTreeMap<(PathBuf, bool), Decoded>,
    /// Bytes of every image read, in reading order, for the content hash.
    pub(super) hashed: Vec<Vec<u8>>,
    pub(super) files_read: Vec<PathBuf>,
    /// What `mesh_attribute` textures read: the shapes' attributes, each primitive's material
    /// and the shapes' first primitives and labels (set once the shapes are built).
    pub(super) meshes: Option<MeshData<'a>>,
    /// The index of the material being built.
    pub(super) material: u32,
}

/// The shapes as `mesh_attribute` textures need them ([`Textures::meshes`]).
pub(super) struct MeshData<'a> {
    pub(super) attributes: &'a BTreeMap<String, PrimValues>,
    pub(super) attrs: &'a [crate::scene::PrimAttrs],
    pub(super) shape_starts: &'a [(usize, String)],
}

impl<'a> Textures<'a> {
    pub(super) fn new(dir: &'a std::path::Path) -> Self {
        Self {
            dir,
            params: Vec::new(),
            images: BTreeMap::new(),
            hashed: Vec::new(),
            files_read: Vec::new(),
            meshes: None,
            material: 0,
        }
    }

    /// A reflectance-like colour, `param` of the model: an RGB triple with every channel in
    /// [0, 1], or a texture whose every value is. Returns the value the model is built with: the
    /// colour, or the texture's per-channel maximum (the texture itself is remembered for
    /// `param`).
    pub(super) fn unit_color(&mut self, ctx: &Ctx, field: &str, c: &Color, param: ColorParam) -> Result<Vec3> {
        let texture = match c {
            Color::Rgb(v) => return Ok(rgb(ctx.unit_rgb(field, *v)?)),
            Color::Texture(t) => match &**t {
                TextureDesc::MeshAttribute(m) => self.mesh_attribute(ctx, field, m)?,
                t => self.texture(ctx, field, t)?,
            },
        };
        let (lo, hi) = (texture.min(), texture.max());
        if lo.min_element() < 0.0 || hi.max_element() > 1.0 || !(lo.is_finite() && hi.is_finite()) {
            return Err(values_error(
                ctx,
                field,
                &texture,
                "every texture value in [0, 1] (a reflectance)",
            ));
        }
        self.params.push((param, texture));
        Ok(hi)
    }

    /// A number in [0, `max`] that may be a texture (its luminance, every texel's in range);
    /// `what` names it in the error ("a roughness").
    pub(super) fn scalar(
        &mut self,
        ctx: &Ctx,
        field: &str,
        s: &ScalarDesc,
        (max, what): (f64, &str),
    ) -> Result<Scalar> {
        // A NaN or an infinity fails the range check below.
        let scalar = match s {
            ScalarDesc::Value(v) => Scalar::Constant(*v as f32),
            ScalarDesc::Texture(t) => Scalar::Texture(self.texture(ctx, field, t)?),
        };
        let (lo, hi) = scalar.range();
        let within = |x: f32| (0.0..=max).contains(&(x as f64));
        if within(lo) && within(hi) {
            return Ok(scalar);
        }
        Err(ctx.err(
            field,
            match s {
                ScalarDesc::Value(v) => format!("expected {what} in [0, {}], got {}", num(max), num(*v)),
                ScalarDesc::Texture(_) => format!(
                    "expected every texture value in [0, {}], got luminances from {} to {}",
                    num(max),
                    num(lo as f64),
                    num(hi as f64)
                ),
            },
        ))
    }

    /// A number parameter of the model being built: a number as it is, or a texture
    /// remembered for `param` (the model holds its largest value).
    pub(super) fn number_param(
        &mut self,
        ctx: &Ctx,
        field: &str,
        s: &ScalarDesc,
        range: (f64, &str),
        param: ColorParam,
    ) -> Result<f32> {
        Ok(self.number_param_range(ctx, field, s, range, param)?.1)
    }

    /// [`Textures::number_param`] giving the least and largest values (a number's twice).
    pub(super) fn number_param_range(
        &mut self,
        ctx: &Ctx,
        field: &str,
        s: &ScalarDesc,
        range: (f64, &str),
        param: ColorParam,
    ) -> Result<(f32, f32)> {
        let scalar = self.scalar(ctx, field, s, range)?;
        let values = scalar.range();
        if let Scalar::Texture(t) = scalar {
            self.params.push((param, t));
        }
        Ok(values)
    }

    /// A normal map's colours (`normalmap`'s `normals`): one RGB triple, returned, or a
    /// texture, whose every value must be finite, driving [`ColorParam::NormalMap`] (the colour
    /// returned is then (½, ½, 1), the unmapped normal). A colour c is the normal 2c − 1 in the
    /// texture's tangent space.
    pub(super) fn normals(&mut self, ctx: &Ctx, field: &str, c: &Color) -> Result<Vec3> {
        let texture = match c {
            Color::Rgb(v) => return Ok(rgb(ctx.unit_rgb(field, *v)?)),
            Color::Texture(t) => self.texture(ctx, field, t)?,
        };
        let (lo, hi) = (texture.min(), texture.max());
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(ctx.err(field, "expected finite texture values (a normal map's colours)"));
        }
        self.params.push((ColorParam::NormalMap, texture));
        Ok(Vec3::new(0.5, 0.5, 1.0))
    }

    /// A bump map's height: a texture (its luminance; every value finite), or `None` for a
    /// number, a flat surface.
    pub(super) fn height(&mut self, ctx: &Ctx, field: &str, h: &ScalarDesc) -> Result<Option<Texture>> {
        match h {
            ScalarDesc::Value(v) if v.is_finite() => Ok(None),
            ScalarDesc::Value(v) => Err(ctx.err(field, format!("expected a finite height, got {v}"))),
            ScalarDesc::Texture(t) => {
                let texture = self.texture(ctx, field, t)?;
                if !(texture.min().is_finite() && texture.max().is_finite()) {
                    return Err(ctx.err(field, "expected finite texture values (a bump map's heights)"));
                }
                Ok(Some(texture))
            }
        }
    }

    /// A picture a light projects (a spot's `texture`): every value finite and non-negative.
    pub(super) fn picture(&mut self, ctx: &Ctx, field: &str, t: &TextureDesc) -> Result<Texture> {
        let texture = self.texture(ctx, field, t)?;
        if !(texture.min().min_element() >= 0.0 && texture.max().is_finite()) {
            return Err(values_error(
                ctx,
                field,
                &texture,
                "finite, non-negative texture values",
            ));
        }
        Ok(texture)
    }

    /// A (u, v) texture; a mesh attribute is refused here (it drives colour parameters only:
    /// [`Textures::unit_color`]).
    fn texture(&mut self, ctx: &Ctx, field: &str, t: &TextureDesc) -> Result<Texture> {
        match t {
            TextureDesc::Checkerboard(c) => checkerboard(ctx, field, c),
            TextureDesc::Bitmap(b) => self.bitmap(ctx, field, b),
            TextureDesc::MeshAttribute(m) => Err(ctx.err(
                field,
                format!(
                    "mesh attribute {:?}: a mesh attribute can drive a material's colour \
                     (reflectance) parameters only, not this one",
                    m.name
                ),
            )),
        }
    }

    /// A `mesh_attribute` texture of the material being built: every primitive of that
    /// material must carry the attribute, with 1 or 3 channels (Mitsuba evaluates a colour
    /// from either, and refuses others).
    fn mesh_attribute(&mut self, ctx: &Ctx, field: &str, m: &MeshAttributeDesc) -> Result<Texture> {
        let f = |key: &str| format!("{field}.{key}");
        let name = &m.name;
        if !(name.starts_with("vertex_") || name.starts_with("face_")) {
            return Err(ctx.err(
                &f("name"),
                format!("expected a name starting with \"vertex_\" or \"face_\", got {name:?}"),
            ));
        }
        let scale = match m.scale {
            None => 1.0,
            Some(s) if s.is_finite() && (0.0..=1e4).contains(&s) => s as f32,
            Some(s) => return Err(ctx.err(&f("scale"), format!("expected a number in [0, 1e4], got {}", num(s)))),
        };
        let meshes = self
            .meshes
            .as_ref()
            .expect("mesh attributes are read once the shapes are built");
        let refuse = |reason: String| -> Result<Texture> { Err(ctx.err(&f("name"), reason)) };
        // Per primitive of this material, its corners' colours; every other primitive zero.
        let mut corners = vec![[Vec3::ZERO; 3]; meshes.attrs.len()];
        let mut read = vec![false; meshes.attrs.len()];
        let (mut min, mut max, mut sum) = (Vec3::INFINITY, Vec3::NEG_INFINITY, glam::DVec3::ZERO);
        if let Some(v) = meshes.attributes.get(name) {
            let colour = match v.channels {
                1 => |c: [f32; 4]| Vec3::splat(c[0]),
                3 => |c: [f32; 4]| Vec3::new(c[0], c[1], c[2]),
                usize::MAX => return refuse(format!("meshes give attribute {name:?} different channel counts")),
                n => {
                    return refuse(format!(
                        "attribute {name:?} must have 1 or 3 channels to be a colour, got {n}"
                    ));
                }
            };
            for &(prim, c) in &v.corners {
                let i = prim as usize;
                if meshes.attrs[i].material == self.material {
                    corners[i] = c.map(colour);
                    read[i] = true;
                    for v in corners[i].map(|v| v * scale) {
                        (min, max, sum) = (min.min(v), max.max(v), sum + v.as_dvec3());
                    }
                }
            }
        }
        let count = read.iter().filter(|&&r| r).count();
        if let Some(i) = (0..read.len()).find(|&i| !read[i] && meshes.attrs[i].material == self.material) {
            let shape = meshes
                .shape_starts
                .iter()
                .rev()
                .find(|(start, _)| *start <= i)
                .map_or("a shape", |(_, label)| label.as_str());
            return refuse(format!(
                "{shape} uses this material but its mesh has no attribute {name:?} (PLY meshes carry \
                 them as vertex or face properties r, g, b or NAME_0, NAME_1, …)"
            ));
        }
        let (min, max) = if count == 0 {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            (min, max)
        };
        let mean = (sum / (3 * count).max(1) as f64).as_vec3();
        Ok(Texture::MeshAttribute(MeshAttribute {
            name: name.clone(),
            scale,
            per_face: name.starts_with("face_"),
            corners: Arc::from(corners),
            min,
            max,
            mean,
        }))
    }

    fn bitmap(&mut self, ctx: &Ctx, field: &str, b: &BitmapDesc) -> Result<Texture> {
        let f = |key: &str| format!("{field}.{key}");
        let filter = match b.filter.as_deref() {
            None | Some("bilinear") => Filter::Bilinear,
            Some("nearest") => Filter::Nearest,
            Some(other) => {
                return Err(ctx.err(
                    &f("filter"),
                    format!("expected \"bilinear\" or \"nearest\", got {other:?}"),
                ));
            }
        };
        let wrap = match b.wrap.as_deref() {
            None | Some("repeat") => Wrap::Repeat,
            Some("mirror") => Wrap::Mirror,
            Some("clamp") => Wrap::Clamp,
            Some(other) => {
                return Err(ctx.err(
                    &f("wrap"),
                    format!("expected \"repeat\", \"mirror\" or \"clamp\", got {other:?}"),
                ));
            }
        };
        let raw = b.raw.unwrap_or(false);
        let path = self.dir.join(&b.file);
        let image = match self.images.get(&(path.clone(), raw)) {
            Some(image) => image.clone(),
            None => {
                let shown = path.display().to_string();
                let bytes = read_regular_file(&path, "texture")
                    .map_err(|e| ctx.err(&f("file"), format!("cannot read {shown}: {e}")))?;
                let (w, h, texels) =
                    decode_image(&bytes, raw).map_err(|e| ctx.err(&f("file"), format!("{shown}: {e}")))?;
                if u64::from(w) * u64::from(h) > MAX_TEXELS {
                    return Err(ctx.err(
                        &f("file"),
                        format!("{shown}: {w} × {h} texels exceeds the limit of {MAX_TEXELS}"),
                    ));
                }
                self.hashed.push(bytes);
                self.files_read.push(path.clone());
                let image = (w, h, Arc::from(texels));
                self.images.insert((path, raw), image.clone());
                image
            }
        };
        let (width, height, mut texels) = image;
        match b.scale {
            None => {}
            Some(s) if s.is_finite() && (0.0..=1e4).contains(&s) => {
                texels = texels.iter().map(|t| *t * s as f32).collect();
            }
            Some(s) => return Err(ctx.err(&f("scale"), format!("expected a number in [0, 1e4], got {}", num(s)))),
        }
        Ok(Texture::Bitmap(Bitmap {
            width,
            height,
            texels,
            filter,
            wrap,
            to_uv: uv_transform(ctx, &f("to_uv"), b.to_uv.as_ref())?,
        }))
    }
}

/// A texture whose values are out of range: what was `expected`, and the per-channel least and
/// largest values it has.
fn values_error(ctx: &Ctx, field: &str, texture: &Texture, expected: &str) -> crate::error::Error {
    ctx.err(
        field,
        format!(
            "expected {expected}, got values from {} to {}",
            triple(texture.min().as_dvec3().to_array()),
            triple(texture.max().as_dvec3().to_array())
        ),
    )
}

fn checkerboard(ctx: &Ctx, field: &str, c: &CheckerboardDesc) -> Result<Texture> {
    let f = |key: &str| format!("{field}.{key}");
    let colour = |key: &str, v: Option<desc::Triple>, default: f64| -> Result<Vec3> {
        let v = v.unwrap_or(desc::Fixed([default; 3]));
        if v.iter().all(|x| x.is_finite()) {
            Ok(rgb(v))
        } else {
            Err(ctx.err(&f(key), format!("expected finite numbers, got {}", triple(v))))
        }
    };
    Ok(Texture::Checkerboard(Checkerboard {
        color0: colour("color0", c.color0, 0.4)?,
        color1: colour("color1", c.color1, 0.2)?,
        to_uv: uv_transform(ctx, &f("to_uv"), c.to_uv.as_ref())?,
    }))
}

fn uv_transform(ctx: &Ctx, field: &str, t: Option<&UvTransformDesc>) -> Result<UvTransform> {
    let Some(t) = t else {
        return Ok(UvTransform::default());
    };
    let finite = |key: &str, v: &[f64]| -> Result<()> {
        if v.iter().all(|x| x.is_finite() && x.abs() <= 1e7) {
            Ok(())
        } else {
            Err(ctx.err(
                &format!("{field}.{key}"),
                "expected finite numbers of magnitude at most 1e7",
            ))
        }
    };
    match (t.matrix, t.scale, t.offset) {
        (Some(m), None, None) => {
            let rows = [m[0].0, m[1].0];
            finite("matrix", &rows.concat())?;
            Ok(UvTransform {
                rows: rows.map(|r| r.map(|x| x as f32)),
            })
        }
        (Some(_), _, _) => Err(ctx.err(field, "give either a matrix or scale and offset, not both")),
        (None, scale, offset) => {
            let scale = scale.map_or([1.0; 2], |s| s.0);
            let offset = offset.map_or([0.0; 2], |o| o.0);
            finite("scale", &scale)?;
            finite("offset", &offset)?;
            Ok(UvTransform::scale_offset(
                Vec2::new(scale[0] as f32, scale[1] as f32),
                Vec2::new(offset[0] as f32, offset[1] as f32),
            ))
        }
    }
}
