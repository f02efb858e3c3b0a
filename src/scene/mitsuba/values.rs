//! Properties as Mitsuba 3 writes them: `<float>`, `<integer>`, `<boolean>`, `<string>`,
//! colours (`rgb`, `spectrum`), points and every transform form, read with the element's
//! location in errors.

use super::*;
use crate::error::Result;
use crate::scene::desc::{Fixed, Triple};
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

    /// A reflectance colour: `rgb` (one or three numbers), `float`, or a `spectrum` — one
    /// number, wavelength:value pairs, a `filename` of such pairs (`.spd`), or
    /// `type="blackbody"` — turned into RGB as Mitsuba 3's RGB variants do ([`crate::spectrum`]:
    /// D65-weighted, clamped to [0, 1] with a warning).
    pub(super) fn colour(&mut self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<Triple>> {
        self.colour_as(o, name, true)
    }

    /// An unbounded colour (emitted `radiance`, a conductor's `eta` and `k`): as
    /// [`Reader::colour`], but spectra are converted as Mitsuba converts unbounded ones (neither
    /// D65-weighted nor clamped).
    pub(super) fn unbounded_colour(&mut self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<Triple>> {
        self.colour_as(o, name, false)
    }

    fn colour_as(&mut self, o: &mut Obj<'a, 'i>, name: &str, reflectance: bool) -> Result<Option<Triple>> {
        if let Some(c) = o.children.iter().find(|c| c.attribute("name") == Some(name)) {
            return Err(self.err(
                *c,
                format!("{name}: textures are not supported; give an <rgb> or a <float>"),
            ));
        }
        let Some(p) = self.take(o, name, &["rgb", "float", "spectrum"])? else {
            return Ok(None);
        };
        if p.has_tag_name("spectrum") && (p.attribute("type").is_some() || p.attribute("filename").is_some()) {
            return self.spectrum_object(p, reflectance).map(Some);
        }
        let text = self.required(p, "value")?;
        if p.has_tag_name("spectrum") && text.contains(':') {
            let points = self.spectrum_pairs(p, "value", &text)?;
            return Ok(Some(self.spectrum_rgb(p, &points, reflectance)));
        }
        match (p.tag_name().name(), self.numbers(p, "value", &text)?.as_slice()) {
            (_, [v]) => Ok(Some(Fixed([*v; 3]))),
            ("rgb", [r, g, b]) => Ok(Some(Fixed([*r, *g, *b]))),
            _ => Err(self.err(
                p,
                format!("value: expected one number, wavelength:value pairs (for <spectrum>) or three numbers (for <rgb>), got {text:?}"),
            )),
        }
    }

    /// `<spectrum filename="…">` (pairs in a file) or `<spectrum type="blackbody">` with its
    /// `temperature` in kelvin.
    fn spectrum_object(&mut self, p: Node<'a, 'i>, reflectance: bool) -> Result<Triple> {
        if let Some(file) = self.attr(p, "filename")? {
            let path = self.resolve(&file);
            let bytes = crate::util::read_input(&path, "spectrum", crate::util::MAX_TEXT_INPUT)
                .map_err(|e| self.err(p, format!("filename: cannot read {}: {e}", path.display())))?;
            let text = String::from_utf8_lossy(&bytes);
            // One "wavelength value" pair per line; `#` starts a comment.
            let pairs: Vec<String> = text
                .lines()
                .map(|l| l.split('#').next().unwrap_or("").trim())
                .filter(|l| !l.is_empty())
                .map(|l| l.split_whitespace().collect::<Vec<_>>().join(":"))
                .collect();
            let points = self.spectrum_pairs(p, "filename", &pairs.join(", "))?;
            return Ok(self.spectrum_rgb(p, &points, reflectance));
        }
        match self.attr(p, "type")?.as_deref() {
            Some("blackbody") => {
                let mut o = self.obj(p)?;
                let Some(kelvin) = self.float(&mut o, "temperature")? else {
                    return Err(self.err(p, "expected <float name=\"temperature\"> in kelvin"));
                };
                self.finish(&o)?;
                if !(kelvin > 0.0 && kelvin <= 1e6) {
                    return Err(self.err(p, format!("temperature: expected kelvin in (0, 1e6], got {kelvin}")));
                }
                if reflectance {
                    return Err(self.err(p, "a blackbody spectrum is an emitted spectrum: give it to an emitter's radiance"));
                }
                Ok(Fixed(crate::spectrum::blackbody_to_srgb(kelvin).to_array()))
            }
            other => Err(self.err(
                p,
                format!("unsupported spectrum type {other:?} (blackbody, or wavelength:value pairs in `value` or `filename`)"),
            )),
        }
    }

    /// `λ:v, λ:v, …` with wavelengths in nm, strictly increasing, at least two, values finite.
    fn spectrum_pairs(&self, p: Node, key: &str, text: &str) -> Result<Vec<(f64, f64)>> {
        let bad = |why: &str| self.err(p, format!("{key}: {why}, got {text:?}"));
        let points = text
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(|pair| {
                let (w, v) = pair
                    .split_once(':')
                    .ok_or_else(|| bad("expected wavelength:value pairs separated by commas"))?;
                match (w.trim().parse::<f64>(), v.trim().parse::<f64>()) {
                    (Ok(w), Ok(v)) if w.is_finite() && v.is_finite() && w > 0.0 => Ok((w, v)),
                    _ => Err(bad("expected positive finite wavelengths (nm) and finite values")),
                }
            })
            .collect::<Result<Vec<_>>>()?;
        if points.len() < 2 || points.windows(2).any(|w| w[1].0 <= w[0].0) {
            return Err(bad("expected at least two pairs with strictly increasing wavelengths"));
        }
        Ok(points)
    }

    fn spectrum_rgb(&mut self, p: Node, points: &[(f64, f64)], reflectance: bool) -> Triple {
        let (rgb, clamped) = crate::spectrum::list_to_srgb(points, reflectance);
        if clamped {
            self.warn(
                p,
                "the spectrum's sRGB colour exceeds 1 and is clamped (as Mitsuba does)",
            );
        }
        Fixed(rgb.to_array())
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
