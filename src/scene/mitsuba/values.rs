//! Properties as Mitsuba 3 writes them: `<float>`, `<integer>`, `<boolean>`, `<string>`,
//! colours (`rgb`, `spectrum`), points and every transform form, read with the element's
//! location in errors.

use super::*;
use crate::error::Result;
use crate::scene::desc::{Fixed, TransformDesc, TransformStep, Triple};
use glam::{DMat3, DMat4, DVec3, DVec4};
use roxmltree::Node;
use std::collections::BTreeMap;

impl<'a, 'i> Reader<'a, 'i> {
    /// Splits an object's children into properties (by name) and nested objects.
    pub(super) fn obj(&self, node: Node<'a, 'i>) -> Result<Obj<'a, 'i>> {
        let mut props = BTreeMap::new();
        let mut children = Vec::new();
        for c in node.children() {
            if c.is_text() && !c.text().unwrap_or("").trim().is_empty() {
                return Err(self.err(node, format!("unexpected text {:?}", c.text().unwrap_or("").trim())));
            }
            if !c.is_element() {
                continue;
            }
            if PROPERTY_TAGS.contains(&c.tag_name().name()) {
                let name = self.required(c, "name")?;
                if props.insert(name.clone(), c).is_some() {
                    return Err(self.err(c, format!("property {name:?} is given twice")));
                }
            } else {
                children.push(c);
            }
        }
        Ok(Obj { node, props, children })
    }

    /// Refuses any property the caller did not read: nothing is silently ignored.
    pub(super) fn finish(&self, o: &Obj) -> Result<()> {
        match o.props.values().next() {
            None => Ok(()),
            Some(&p) => Err(self.err(
                p,
                format!(
                    "unsupported property of <{} type=\"{}\"> (photon-bench does not read it)",
                    o.node.tag_name().name(),
                    o.node.attribute("type").unwrap_or("")
                ),
            )),
        }
    }

    pub(super) fn take(&self, o: &mut Obj<'a, 'i>, name: &str, tags: &[&str]) -> Result<Option<Node<'a, 'i>>> {
        match o.props.remove(name) {
            None => Ok(None),
            Some(p) if tags.contains(&p.tag_name().name()) => Ok(Some(p)),
            Some(p) => Err(self.err(p, format!("expected {name:?} as one of <{}>", tags.join(">, <")))),
        }
    }

    pub(super) fn float(&self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<f64>> {
        self.take(o, name, &["float", "integer"])?
            .map(|p| self.number(p, "value"))
            .transpose()
    }

    pub(super) fn integer(&self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<i64>> {
        let Some(p) = self.take(o, name, &["integer"])? else {
            return Ok(None);
        };
        let text = self.required(p, "value")?;
        text.trim()
            .parse::<i64>()
            .map(Some)
            .map_err(|_| self.err(p, format!("value: expected an integer, got {text:?}")))
    }

    pub(super) fn boolean(&self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<bool>> {
        let Some(p) = self.take(o, name, &["boolean"])? else {
            return Ok(None);
        };
        match self.required(p, "value")?.as_str() {
            "true" => Ok(Some(true)),
            "false" => Ok(Some(false)),
            other => Err(self.err(p, format!("value: expected true or false, got {other:?}"))),
        }
    }

    pub(super) fn string(&self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<(Node<'a, 'i>, String)>> {
        self.take(o, name, &["string"])?
            .map(|p| Ok((p, self.required(p, "value")?)))
            .transpose()
    }

    /// A colour: `rgb` (one or three numbers), `float`, or a `spectrum` holding one number.
    pub(super) fn colour(&self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<Triple>> {
        if let Some(c) = o.children.iter().find(|c| c.attribute("name") == Some(name)) {
            return Err(self.err(
                *c,
                format!("{name}: textures are not supported; give an <rgb> or a <float>"),
            ));
        }
        let Some(p) = self.take(o, name, &["rgb", "float", "spectrum"])? else {
            return Ok(None);
        };
        let text = self.required(p, "value")?;
        if text.contains(':') {
            return Err(self.err(
                p,
                "value: wavelength:value spectra are not supported (photon-bench renders RGB); \
                 give one number or an <rgb>",
            ));
        }
        match (p.tag_name().name(), self.numbers(p, "value", &text)?.as_slice()) {
            (_, [v]) => Ok(Some(Fixed([*v; 3]))),
            ("rgb", [r, g, b]) => Ok(Some(Fixed([*r, *g, *b]))),
            _ => Err(self.err(
                p,
                format!("value: expected one number or (for <rgb>) three, got {text:?}"),
            )),
        }
    }

    pub(super) fn point(&self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<DVec3>> {
        let Some(p) = self.take(o, name, &["point", "vector"])? else {
            return Ok(None);
        };
        if p.attribute("value").is_some() {
            return self.triple_attr(p, "value").map(Some);
        }
        Ok(Some(DVec3::new(
            self.coord(p, "x", 0.0)?,
            self.coord(p, "y", 0.0)?,
            self.coord(p, "z", 0.0)?,
        )))
    }

    /// A `<transform name>` as a 4 × 4 matrix acting on column vectors.
    pub(super) fn transform(&self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<(Node<'a, 'i>, DMat4)>> {
        let Some(t) = self.take(o, name, &["transform"])? else {
            return Ok(None);
        };
        let mut m = DMat4::IDENTITY;
        for op in t.children().filter(Node::is_element) {
            let step = match op.tag_name().name() {
                "translate" => {
                    let v = if op.attribute("value").is_some() {
                        self.triple_attr(op, "value")?
                    } else {
                        self.coords(op, 0.0)?
                    };
                    DMat4::from_translation(v)
                }
                "scale" => {
                    let v = if let Some(text) = self.attr(op, "value")? {
                        match self.numbers(op, "value", &text)?.as_slice() {
                            [s] => DVec3::splat(*s),
                            [x, y, z] => DVec3::new(*x, *y, *z),
                            _ => {
                                return Err(self.err(op, format!("value: expected one or three numbers, got {text:?}")));
                            }
                        }
                    } else {
                        self.coords(op, 1.0)?
                    };
                    DMat4::from_scale(v)
                }
                "rotate" => {
                    let axis = if op.attribute("value").is_some() {
                        self.triple_attr(op, "value")?
                    } else {
                        self.coords(op, 0.0)?
                    };
                    let angle = self.number(op, "angle")?;
                    let Some(axis) = axis.try_normalize() else {
                        return Err(self.err(op, "expected a non-zero rotation axis"));
                    };
                    DMat4::from_axis_angle(axis, angle.to_radians())
                }
                "matrix" => {
                    let text = self.required(op, "value")?;
                    match self.numbers(op, "value", &text)?.as_slice() {
                        v if v.len() == 16 => DMat4::from_cols_array(&[
                            v[0], v[4], v[8], v[12], v[1], v[5], v[9], v[13], v[2], v[6], v[10], v[14], v[3], v[7],
                            v[11], v[15],
                        ]),
                        v if v.len() == 9 => DMat4::from_mat3(DMat3::from_cols_array(&[
                            v[0], v[3], v[6], v[1], v[4], v[7], v[2], v[5], v[8],
                        ])),
                        v => {
                            return Err(self.err(op, format!("value: expected 16 or 9 numbers, got {}", v.len())));
                        }
                    }
                }
                "lookat" => {
                    let origin = self.triple_attr(op, "origin")?;
                    let target = self.triple_attr(op, "target")?;
                    let up = self.triple_attr(op, "up")?;
                    let Some(dir) = (target - origin).try_normalize() else {
                        return Err(self.err(op, "target must differ from origin"));
                    };
                    let Some(left) = up.cross(dir).try_normalize() else {
                        return Err(self.err(op, "up must be non-zero and not parallel to target - origin"));
                    };
                    let new_up = dir.cross(left);
                    DMat4::from_cols(
                        left.extend(0.0),
                        new_up.extend(0.0),
                        dir.extend(0.0),
                        origin.extend(1.0),
                    )
                }
                other => {
                    return Err(self.err(
                        op,
                        format!("unsupported transform operation <{other}> (translate, rotate, scale, matrix, lookat)"),
                    ));
                }
            };
            m = step * m;
        }
        if !m.to_cols_array().iter().all(|x| x.is_finite()) {
            return Err(self.err(t, "the composed transform is not finite"));
        }
        if m.row(3) != DVec4::new(0.0, 0.0, 0.0, 1.0) {
            return Err(self.err(t, "the last row must be 0 0 0 1 (affine transforms only)"));
        }
        Ok(Some((t, m)))
    }
}

/// A 4 × 4 affine matrix as one `matrix` step of our transform format (row-major).
pub(super) fn matrix_step(m: DMat4) -> TransformDesc {
    let row = |i: usize| Fixed(m.row(i).to_array());
    TransformDesc(vec![TransformStep {
        matrix: Some(Fixed([row(0), row(1), row(2), row(3)])),
        ..TransformStep::default()
    }])
}
