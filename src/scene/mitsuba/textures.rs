//! `<texture>` elements (`checkerboard`, `bitmap`, `mesh_attribute`) and texture-valued colour parameters, named
//! (`<ref id>`) or nested.

use super::*;
use crate::scene::desc::{BitmapDesc, CheckerboardDesc, Color, Fixed, MeshAttributeDesc, TextureDesc, UvTransformDesc};
use glam::DMat4;

impl<'a, 'i> Reader<'a, 'i> {
    /// A colour that may be a texture: a nested `<texture name>`, a `<ref name id>` to a
    /// top-level texture, or an `<rgb>`/`<float>`/`<spectrum>` (as [`Reader::colour`]).
    pub(super) fn texture_colour(&mut self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<Color>> {
        let Some(i) = o.children.iter().position(|c| c.attribute("name") == Some(name)) else {
            return Ok(self.colour(o, name)?.map(Color::Rgb));
        };
        let c = o.children.remove(i);
        if o.props.contains_key(name) {
            return Err(self.err(c, format!("{name} is given twice")));
        }
        let texture = match c.tag_name().name() {
            "texture" => self.texture(c)?,
            "ref" => {
                let id = self.required(c, "id")?;
                self.texture_ids
                    .get(&id)
                    .cloned()
                    .ok_or_else(|| self.err(c, format!("no top-level <texture id=\"{id}\"> to refer to")))?
            }
            other => return Err(self.err(c, format!("{name}: expected a <texture> or a <ref>, got <{other}>"))),
        };
        Ok(Some(Color::Texture(Box::new(texture))))
    }

    /// A `<texture>` element.
    pub(super) fn texture(&mut self, n: Node<'a, 'i>) -> Result<TextureDesc> {
        let kind = self.required(n, "type")?;
        let mut o = self.obj(n)?;
        let to_uv = self.transform(&mut o, "to_uv")?.map(|(_, m)| uv_step(m));
        let t = match kind.as_str() {
            "checkerboard" => TextureDesc::Checkerboard(CheckerboardDesc {
                color0: self.colour(&mut o, "color0")?,
                color1: self.colour(&mut o, "color1")?,
                to_uv,
            }),
            "bitmap" => {
                let Some((p, file)) = self.string(&mut o, "filename")? else {
                    return Err(self.err(n, "expected <string name=\"filename\">"));
                };
                let path = self.resolve(&file);
                if !path.is_file() {
                    return Err(self.err(p, format!("filename: cannot read {}: no such file", path.display())));
                }
                let filter = self.string(&mut o, "filter_type")?.map(|(_, v)| v);
                let wrap = self.string(&mut o, "wrap_mode")?.map(|(_, v)| v);
                // Storage precision and the lookup acceleration do not change the values.
                let _ = self.string(&mut o, "format")?;
                let _ = self.boolean(&mut o, "accel")?;
                TextureDesc::Bitmap(BitmapDesc {
                    file: self.loader_path(p, &file, &path)?,
                    filter,
                    wrap,
                    raw: self.boolean(&mut o, "raw")?,
                    scale: None,
                    to_uv,
                })
            }
            "mesh_attribute" => {
                let Some((_, name)) = self.string(&mut o, "name")? else {
                    return Err(self.err(n, "expected <string name=\"name\"> (the mesh attribute)"));
                };
                TextureDesc::MeshAttribute(MeshAttributeDesc {
                    name,
                    scale: self.float(&mut o, "scale")?,
                })
            }
            other => {
                return Err(self.err(
                    n,
                    format!("unsupported texture {other:?} (checkerboard, bitmap, mesh_attribute)"),
                ));
            }
        };
        if let Some(&c) = o.children.first() {
            return Err(self.err(c, "unexpected element in a texture (nested textures are not supported)"));
        }
        self.finish(&o)?;
        Ok(t)
    }
}

/// A `to_uv` transform as Mitsuba reads a 4 × 4 matrix for a 2D map (`Transform::extract`):
/// the upper-left 2 × 2 block and the first two entries of the last column.
fn uv_step(m: DMat4) -> UvTransformDesc {
    let r = |i: usize| {
        let row = m.row(i);
        Fixed([row.x, row.y, row.w])
    };
    UvTransformDesc {
        matrix: Some(Fixed([r(0), r(1)])),
        ..UvTransformDesc::default()
    }
}
