//! Colours and textures of pbrt-v4 as ours: colour and number parameters (`rgb`, spectra,
//! texture names), lights' colours, and the `Texture` directive.

use super::content::{check_known, find, float_param, numbers, string_param};
use super::*;

/// The (u, v) map of a pbrt image texture with pbrt's `uscale`, `vscale`, `udelta`, `vdelta`:
/// (s_u u + d_u, s_v v + d_v), then v flipped, since pbrt's image puts v = 0 at the bottom row
/// and ours at the top.
pub(super) fn image_uv([su, sv]: [f64; 2], [du, dv]: [f64; 2]) -> desc::UvTransformDesc {
    desc::UvTransformDesc {
        scale: None,
        offset: None,
        matrix: Some(Fixed([Fixed([su, 0.0, du]), Fixed([0.0, -sv, 1.0 - dv])])),
    }
}

impl Translator<'_> {
    /// A colour parameter: `rgb`, `spectrum` (wavelength–value pairs), or a `texture` name
    /// (when `textures` allows); reflectances (`reflectance = true`) as Mitsuba converts them.
    pub(super) fn colour(
        &self,
        d: &Directive,
        params: &[Param],
        name: &str,
        reflectance: bool,
    ) -> Result<Option<Color>> {
        self.colour_or_number(d, params, name, reflectance, false)
    }

    /// [`Translator::colour`], or with `float` a number parameter, whose `texture` names a
    /// float texture: pbrt keeps float and spectrum textures apart, under names of their own.
    pub(super) fn colour_or_number(
        &self,
        d: &Directive,
        params: &[Param],
        name: &str,
        reflectance: bool,
        float: bool,
    ) -> Result<Option<Color>> {
        let Some(p) = find(params, name) else { return Ok(None) };
        match p.ty.as_str() {
            "rgb" => match &numbers(d, p)?[..] {
                [r, g, b] => Ok(Some(Color::Rgb(Fixed([*r, *g, *b])))),
                _ => Err(d.err(format!("parameter \"rgb {name}\": expected 3 numbers"))),
            },
            "float" => Ok(float_param(d, params, name)?.map(|x| Color::Rgb(Fixed([x; 3])))),
            "spectrum" => {
                let v = numbers(d, p).map_err(|_| {
                    d.err(format!(
                        "parameter \"spectrum {name}\": named spectra are read for conductors only; give wavelength–value pairs or rgb"
                    ))
                })?;
                if v.len() < 4 || v.len() % 2 != 0 {
                    return Err(d.err(format!(
                        "parameter \"spectrum {name}\": expected wavelength–value pairs"
                    )));
                }
                let pairs: Vec<(f64, f64)> = v.chunks(2).map(|c| (c[0], c[1])).collect();
                let (rgb, _) = crate::spectrum::list_to_srgb(&pairs, reflectance);
                Ok(Some(Color::Rgb(Fixed(rgb.to_array()))))
            }
            "texture" => {
                let t = string_param(d, params, name)?.unwrap_or_default();
                let (textures, kind) = if float {
                    (&self.float_textures, "float")
                } else {
                    (&self.textures, "spectrum")
                };
                let tex = textures
                    .get(&t)
                    .ok_or_else(|| d.err(format!("parameter \"texture {name}\": no {kind} texture named {t:?}")))?;
                Ok(Some(Color::Texture(Box::new(tex.clone()))))
            }
            other => Err(d.err(format!(
                "parameter \"{other} {name}\": expected rgb, spectrum or texture"
            ))),
        }
    }

    /// A light's colour `L`/`I`: `rgb`, a `spectrum` list, or `blackbody` at luminance 1.
    pub(super) fn light_colour(&self, d: &Directive, name: &str) -> Result<Option<[f64; 3]>> {
        let Some(p) = find(&d.params, name) else {
            return Ok(None);
        };
        if p.ty == "blackbody" {
            let [t] = numbers(d, p)?[..] else {
                return Err(d.err(format!("parameter \"blackbody {name}\": expected one temperature")));
            };
            let rgb = crate::spectrum::blackbody_to_srgb(t);
            let y = crate::color::luminance(rgb.as_vec3()) as f64;
            return Ok(Some((rgb / y).to_array()));
        }
        match self.colour(d, &d.params, name, false)? {
            Some(Color::Rgb(c)) => Ok(Some(c.0)),
            Some(Color::Texture(_)) => Err(d.err(format!("parameter {name}: a light's colour cannot be a texture"))),
            None => Ok(None),
        }
    }

    /// `Texture "name" "spectrum"|"float" "checkerboard"|"imagemap" …`.
    pub(super) fn texture(&mut self, d: &Directive) -> Result<()> {
        let [Value::Str(name), Value::Str(ty), Value::Str(class)] = &d.args[..] else {
            return Err(d.err("expected a name, a type (spectrum, float) and a class"));
        };
        let float = match ty.as_str() {
            "float" => true,
            "spectrum" => false,
            other => return Err(d.err(format!("texture type {other:?}: expected float or spectrum"))),
        };
        let scale = |key: &str| float_param(d, &d.params, key).map(|v| v.unwrap_or(1.0));
        let to_uv = desc::UvTransformDesc {
            scale: Some(Fixed([scale("uscale")?, scale("vscale")?])),
            offset: Some(Fixed([
                float_param(d, &d.params, "udelta")?.unwrap_or(0.0),
                float_param(d, &d.params, "vdelta")?.unwrap_or(0.0),
            ])),
            matrix: None,
        };
        let t = match class.as_str() {
            "checkerboard" => {
                check_known(
                    d,
                    &d.params,
                    &["tex1", "tex2", "uscale", "vscale", "udelta", "vdelta", "dimension"],
                )?;
                if float_param(d, &d.params, "dimension")?.is_some_and(|x| x != 2.0) {
                    return Err(d.err("only the 2D checkerboard is read"));
                }
                let rgb = |key: &str, default: f64| -> Result<Triple> {
                    match self.colour(d, &d.params, key, true)? {
                        None => Ok(Fixed([default; 3])),
                        Some(Color::Rgb(c)) => Ok(c),
                        Some(Color::Texture(_)) => Err(d.err(format!("{key}: a nested texture is not read"))),
                    }
                };
                // pbrt's checkerboard has tex1 where ⌊u⌋ + ⌊v⌋ is even, in cells of 1; ours
                // has color0 where both fractional parts of u′, v′ lie on one side of ½, in
                // cells of ½: halve the scale.
                // Our number parameters read a checkerboard's colours swapped (Mitsuba's
                // `eval_1`, src/texture.rs): a float one is kept swapped, so that it reads tex1
                // where pbrt does.
                let (tex1, tex2) = (rgb("tex1", 1.0)?, rgb("tex2", 0.0)?);
                let (color0, color1) = if float { (tex2, tex1) } else { (tex1, tex2) };
                TextureDesc::Checkerboard(desc::CheckerboardDesc {
                    color0: Some(color0),
                    color1: Some(color1),
                    to_uv: Some(desc::UvTransformDesc {
                        scale: to_uv.scale.map(|s| Fixed(s.0.map(|x| 0.5 * x))),
                        offset: to_uv.offset.map(|o| Fixed(o.0.map(|x| 0.5 * x))),
                        matrix: None,
                    }),
                })
            }
            "imagemap" => {
                check_known(
                    d,
                    &d.params,
                    &[
                        "filename", "uscale", "vscale", "udelta", "vdelta", "filter", "wrap", "encoding", "scale",
                    ],
                )?;
                let file =
                    string_param(d, &d.params, "filename")?.ok_or_else(|| d.err("expected \"string filename\""))?;
                let raw = match string_param(d, &d.params, "encoding")?.as_deref() {
                    None | Some("sRGB") => None,
                    Some("linear") => Some(true),
                    Some(e) => return Err(d.err(format!("encoding {e:?}: expected sRGB or linear"))),
                };
                let wrap = match string_param(d, &d.params, "wrap")?.as_deref() {
                    None | Some("repeat") => None,
                    Some("clamp") => Some("clamp".to_string()),
                    Some(w) => return Err(d.err(format!("wrap {w:?}: expected repeat or clamp"))),
                };
                let filter = match string_param(d, &d.params, "filter")?.as_deref() {
                    None | Some("bilinear") => None,
                    Some("point") => Some("nearest".to_string()),
                    Some(x) => return Err(d.err(format!("filter {x:?}: expected bilinear or point"))),
                };
                TextureDesc::Bitmap(desc::BitmapDesc {
                    file: self.dir.join(&file).display().to_string(),
                    filter,
                    wrap,
                    raw,
                    scale: float_param(d, &d.params, "scale")?,
                    to_uv: Some(image_uv(
                        [scale("uscale")?, scale("vscale")?],
                        [
                            float_param(d, &d.params, "udelta")?.unwrap_or(0.0),
                            float_param(d, &d.params, "vdelta")?.unwrap_or(0.0),
                        ],
                    )),
                })
            }
            "constant" => {
                check_known(d, &d.params, &["value"])?;
                // One value everywhere: a checkerboard of two equal colours.
                let v = match self.colour_or_number(d, &d.params, "value", true, float)? {
                    None => Fixed([1.0; 3]),
                    Some(Color::Rgb(c)) => c,
                    Some(Color::Texture(_)) => return Err(d.err("value: expected a number or a colour")),
                };
                TextureDesc::Checkerboard(desc::CheckerboardDesc {
                    color0: Some(v),
                    color1: Some(v),
                    to_uv: None,
                })
            }
            "scale" => {
                check_known(d, &d.params, &["tex", "scale"])?;
                let s = match find(&d.params, "scale") {
                    None => 1.0,
                    Some(p) if p.ty == "float" => float_param(d, &d.params, "scale")?.unwrap_or(1.0),
                    Some(_) => return Err(d.err("scale: a texture is not read here; give a float")),
                };
                // tex times s: a named texture's values scaled, or a uniform one.
                match self.colour_or_number(d, &d.params, "tex", true, float)? {
                    Some(Color::Texture(t)) => match *t {
                        TextureDesc::Checkerboard(mut c) => {
                            for colour in [&mut c.color0, &mut c.color1] {
                                *colour = colour.map(|v| Fixed(v.0.map(|x| x * s)));
                            }
                            TextureDesc::Checkerboard(c)
                        }
                        TextureDesc::Bitmap(mut b) => {
                            b.scale = Some(b.scale.unwrap_or(1.0) * s);
                            TextureDesc::Bitmap(b)
                        }
                        TextureDesc::MeshAttribute(mut m) => {
                            m.scale = Some(m.scale.unwrap_or(1.0) * s);
                            TextureDesc::MeshAttribute(m)
                        }
                    },
                    value => {
                        let c = match value {
                            Some(Color::Rgb(c)) => c,
                            _ => Fixed([1.0; 3]),
                        };
                        let v = Some(Fixed(c.0.map(|x| x * s)));
                        TextureDesc::Checkerboard(desc::CheckerboardDesc {
                            color0: v,
                            color1: v,
                            to_uv: None,
                        })
                    }
                }
            }
            other => {
                return Err(d.err(format!(
                    "unsupported texture {other:?} (checkerboard, constant, imagemap, scale)"
                )));
            }
        };
        if float {
            self.float_textures.insert(name.clone(), t);
        } else {
            self.textures.insert(name.clone(), t);
        }
        Ok(())
    }
}
