//! `<shape>` elements (meshes, rectangles, cubes, spheres, disks, cylinders, curves) and
//! their `area` emitters.

use super::*;
use crate::error::Result;
use crate::scene::desc::{self, Fixed, MaterialDesc, ShapeDesc};
use crate::scene::load::cylinder_frame;
use glam::{DMat3, DMat4, DVec3};
use roxmltree::Node;

/// The shape types read.
const SHAPES: [&str; 10] = [
    "obj",
    "ply",
    "serialized",
    "rectangle",
    "cube",
    "sphere",
    "disk",
    "cylinder",
    "linearcurve",
    "bsplinecurve",
];

/// The refusal of shape type `kind`.
fn unsupported_shape(kind: &str) -> String {
    format!(
        "unsupported shape {kind:?} ({}, and shapegroup with instance)",
        SHAPES.join(", ")
    )
}

/// A `shapegroup`'s shapes, each with the label of its element, kept for `instance`s to copy.
pub(super) type ShapeGroup = Vec<(ShapeDesc, String)>;

impl<'a, 'i> Reader<'a, 'i> {
    /// A shape element; `key` names what the shape brings without a name of its own (an inline
    /// BSDF `key`, inline media `key-interior` and `key-exterior`).
    pub(super) fn shape(&mut self, n: Node<'a, 'i>, key: &str) -> Result<ShapeDesc> {
        let kind = self.required(n, "type")?;
        // Before its children, which a type we do not read may hold in forms refused as elements.
        if !SHAPES.contains(&kind.as_str()) {
            return Err(self.err(n, unsupported_shape(&kind)));
        }
        let mut o = self.obj(n)?;
        let to_world = self.transform(&mut o, "to_world")?.map(|(_, m)| m);
        let transform = to_world.map(desc::TransformDesc::from_matrix);
        let flip_normals = self.boolean(&mut o, "flip_normals")?.unwrap_or(false);
        if flip_normals && !matches!(kind.as_str(), "disk" | "cylinder") {
            return Err(self.err(n, "flip_normals=\"true\" is supported on disks and cylinders only"));
        }
        let mut material = None;
        let mut emission = None;
        let (mut interior, mut exterior) = (None, None);
        for c in o.children.clone() {
            match (c.tag_name().name(), c.attribute("name")) {
                ("ref" | "medium", Some(side @ ("interior" | "exterior"))) => {
                    let slot = if side == "interior" {
                        &mut interior
                    } else {
                        &mut exterior
                    };
                    if slot.is_some() {
                        return Err(self.err(c, format!("a second {side} medium for this shape")));
                    }
                    *slot = Some(self.medium_child(c, format!("{key}-{side}"))?);
                }
                ("medium", _) => {
                    return Err(self.err(c, "a medium in a shape needs name=\"interior\" or name=\"exterior\""));
                }
                _ => {}
            }
        }
        for c in o.children.clone() {
            if c.attribute("name").is_some_and(|s| s == "interior" || s == "exterior") {
                continue;
            }
            match c.tag_name().name() {
                "ref" if c.attribute("id").is_some_and(|id| self.emitter_ids.contains_key(id)) => {
                    if emission.is_some() {
                        return Err(self.err(c, "a second emitter for this shape"));
                    }
                    emission = c.attribute("id").and_then(|id| self.emitter_ids.get(id)).cloned();
                }
                "bsdf" | "ref" if material.is_some() => {
                    return Err(self.err(c, "a second BSDF for this shape"));
                }
                "bsdf" => {
                    let m = self.bsdf(c)?;
                    let name = match self.attr(c, "id")? {
                        Some(id) => id,
                        None => key.to_string(),
                    };
                    if self.materials.contains_key(&name) {
                        return Err(self.err(c, format!("id {name:?} is used twice")));
                    }
                    self.materials.insert(name.clone(), m);
                    material = Some(name);
                }
                "ref" => {
                    let id = self.required(c, "id")?;
                    let Some(name) = self.bsdf_ids.get(&id) else {
                        return Err(self.err(
                            c,
                            format!("no top-level <bsdf id=\"{id}\"> or area <emitter id=\"{id}\"> to refer to"),
                        ));
                    };
                    material = Some(name.clone());
                }
                "emitter" => {
                    if emission.is_some() {
                        return Err(self.err(c, "a second emitter for this shape"));
                    }
                    emission = Some(self.area(c)?);
                }
                other => {
                    return Err(self.err(
                        c,
                        format!("unsupported element <{other}> in a shape (bsdf, ref, emitter, medium)"),
                    ));
                }
            }
        }
        let material = match material {
            Some(m) => m,
            None => {
                // Mitsuba gives a shape without a BSDF a one-sided diffuse: black on an emitter
                // (it only emits), 0.5 elsewhere.
                let (name, albedo) = if emission.is_some() {
                    ("mitsuba-default-emitter", 0.0)
                } else {
                    ("mitsuba-default", 0.5)
                };
                self.materials
                    .entry(name.to_string())
                    .or_insert(MaterialDesc::OneSided(desc::OneSided {
                        bsdf: Box::new(MaterialDesc::Diffuse(desc::Diffuse {
                            reflectance: Fixed([albedo; 3]).into(),
                        })),
                    }));
                if emission.is_none() {
                    self.warn(n, "no BSDF: Mitsuba's default, a one-sided diffuse 0.5");
                }
                name.to_string()
            }
        };
        let shape = match kind.as_str() {
            "rectangle" => ShapeDesc::Quad(desc::Quad {
                material,
                interior: None,
                exterior: None,
                corner: Some(Fixed([-1.0, -1.0, 0.0])),
                edge_u: Some(Fixed([2.0, 0.0, 0.0])),
                edge_v: Some(Fixed([0.0, 2.0, 0.0])),
                center: None,
                size: None,
                facing: None,
                subdivide: None,
                transform,
                emission,
            }),
            "cube" => ShapeDesc::Box(desc::Cuboid {
                material,
                interior: None,
                exterior: None,
                min: Some(Fixed([-1.0; 3])),
                max: Some(Fixed([1.0; 3])),
                center: None,
                size: None,
                subdivide: None,
                transform,
                emission,
            }),
            "sphere" => ShapeDesc::Sphere(desc::Sphere {
                material,
                interior: None,
                exterior: None,
                center: Fixed(self.point(&mut o, "center")?.unwrap_or(DVec3::ZERO).to_array()),
                radius: self.float(&mut o, "radius")?.unwrap_or(1.0),
                transform,
                emission,
            }),
            "disk" => ShapeDesc::Disk(desc::Disk {
                material,
                interior: None,
                exterior: None,
                flip_normals,
                transform,
                emission,
            }),
            "cylinder" => {
                let (p0, p1, radius) = self.cylinder_axis(n, &mut o, to_world, emission.is_some())?;
                ShapeDesc::Cylinder(desc::Cylinder {
                    material,
                    interior: None,
                    exterior: None,
                    p0: Some(Fixed(p0.to_array())),
                    p1: Some(Fixed(p1.to_array())),
                    radius: Some(radius),
                    flip_normals,
                    transform,
                    emission,
                })
            }
            "linearcurve" | "bsplinecurve" => {
                if emission.is_some() {
                    return Err(self.err(n, format!("a {kind} cannot be an area light here")));
                }
                let Some((p, file)) = self.string(&mut o, "filename")? else {
                    return Err(self.err(n, "expected <string name=\"filename\">"));
                };
                let path = self.resolve(&file);
                if !path.is_file() {
                    return Err(self.err(p, format!("filename: cannot read {}: no such file", path.display())));
                }
                let curves = desc::Curves {
                    material,
                    interior: None,
                    exterior: None,
                    file: self.loader_path(p, &file, &path)?,
                    transform,
                };
                if kind == "linearcurve" {
                    ShapeDesc::LinearCurve(curves)
                } else {
                    ShapeDesc::BsplineCurve(curves)
                }
            }
            "obj" | "ply" | "serialized" => {
                let Some((p, file)) = self.string(&mut o, "filename")? else {
                    return Err(self.err(n, "expected <string name=\"filename\">"));
                };
                let face_normals = self.boolean(&mut o, "face_normals")?.unwrap_or(false);
                let shape_index =
                    match (kind.as_str(), self.integer(&mut o, "shape_index")?) {
                        (_, None) => None,
                        ("serialized", Some(i)) => Some(u32::try_from(i).map_err(|_| {
                            self.err(n, format!("shape_index: expected a non-negative integer, got {i}"))
                        })?),
                        (_, Some(_)) => return Err(self.err(n, "shape_index is a property of serialized shapes")),
                    };
                let path = self.resolve(&file);
                if !path.is_file() {
                    return Err(self.err(p, format!("filename: cannot read {}: no such file", path.display())));
                }
                let expected = format!(".{kind}");
                if !file.to_ascii_lowercase().ends_with(&expected) {
                    return Err(self.err(p, format!("filename: a {kind} shape needs a file ending in {expected}")));
                }
                let file = self.loader_path(p, &file, &path)?;
                // A file without normals is shaded smooth, as Mitsuba recomputes them, unless
                // the scene asks for face normals.
                ShapeDesc::Mesh(desc::Mesh {
                    material,
                    interior: None,
                    exterior: None,
                    file,
                    face_normals,
                    smooth_normals: !face_normals,
                    shape_index,
                    reverse_orientation: false,
                    transform,
                    emission,
                })
            }
            other => return Err(self.err(n, unsupported_shape(other))),
        };
        self.finish(&o)?;
        let mut shape = shape;
        shape.set_media(interior, exterior);
        Ok(shape)
    }

    /// `<shape type="shapegroup" id>`: shapes drawn only where an `instance` places them. As
    /// Mitsuba 3's `ShapeGroup` does, a group may not hold an emitter, a group or an instance.
    pub(super) fn shapegroup(&mut self, n: Node<'a, 'i>) -> Result<()> {
        let Some(id) = self.attr(n, "id")? else {
            return Err(self.err(n, "a top-level shapegroup needs an `id` for instances to <ref> it"));
        };
        let group = self.group_shapes(n, &id)?;
        if self.shapegroups.insert(id.clone(), group).is_some() {
            return Err(self.err(n, format!("id {id:?} is used twice")));
        }
        Ok(())
    }

    fn group_shapes(&mut self, n: Node<'a, 'i>, id: &str) -> Result<ShapeGroup> {
        let o = self.obj(n)?;
        self.finish(&o)?;
        let mut group = ShapeGroup::new();
        for c in o.children {
            if !c.has_tag_name("shape") {
                return Err(self.err(
                    c,
                    format!(
                        "unsupported element <{}> in a shapegroup (shapes only)",
                        c.tag_name().name()
                    ),
                ));
            }
            if matches!(self.required(c, "type")?.as_str(), "shapegroup" | "instance") {
                return Err(self.err(c, "nested instancing is not supported (Mitsuba 3 refuses it too)"));
            }
            let shape = self.shape(c, &format!("{id}-shape{}", group.len()))?;
            if shape.common().2.is_some() {
                return Err(self.err(
                    c,
                    "an emitter in a shapegroup: emitters are not instanced (Mitsuba 3 refuses them too)",
                ));
            }
            group.push((shape, self.label(c)));
        }
        Ok(group)
    }

    /// `<shape type="instance">`: a copy of every shape of its group (a `<ref>` to a shapegroup
    /// read before it), `to_world` applied after each shape's own transform, as Mitsuba 3's
    /// `Instance` does. Instances are flattened into the scene: exact,
    /// without Mitsuba's memory savings. A mirroring `to_world` is refused: Mitsuba then turns
    /// the instanced normals by the inverse transpose and flags the frame as flipped, where our
    /// flattened meshes would take their normals from the mirrored winding.
    pub(super) fn instance(
        &mut self,
        n: Node<'a, 'i>,
        shapes: &mut Vec<ShapeDesc>,
        labels: &mut Vec<String>,
    ) -> Result<()> {
        let mut o = self.obj(n)?;
        let to_world = self.transform(&mut o, "to_world")?;
        self.finish(&o)?;
        let [c] = o.children[..] else {
            return Err(self.err(
                n,
                "an instance holds exactly one shapegroup (a <ref id> to one, or the <shape type=\"shapegroup\"> itself)",
            ));
        };
        let group = match (c.tag_name().name(), c.attribute("type")) {
            ("ref", _) => {
                let id = self.required(c, "id")?;
                match self.shapegroups.get(&id) {
                    Some(g) => g.clone(),
                    None => {
                        return Err(self.err(
                            c,
                            format!("no <shape type=\"shapegroup\" id=\"{id}\"> before this instance"),
                        ));
                    }
                }
            }
            ("shape", Some("shapegroup")) => {
                return Err(self.err(
                    c,
                    "a shapegroup written inside an instance (Mitsuba 3 does not load it either): write it at the top \
                     level with an `id` and <ref> it",
                ));
            }
            _ => return Err(self.err(c, "an instance holds a <ref> to a shapegroup only (Mitsuba 3's rule)")),
        };
        if let Some((p, m)) = to_world
            && m.determinant() < 0.0
        {
            return Err(self.err(
                p,
                "to_world mirrors (negative determinant): an instance under a mirroring transform is not read yet",
            ));
        }
        let here = self.label(n);
        for (mut shape, label) in group {
            if let Some((_, m)) = to_world {
                let t = shape
                    .transform_mut()
                    .get_or_insert_with(|| desc::TransformDesc(Vec::new()));
                t.0.extend(desc::TransformDesc::from_matrix(m).0);
            }
            shapes.push(shape);
            labels.push(format!("{here}, instance of {label}"));
        }
        Ok(())
    }

    /// A cylinder's `p0`, `p1` (defaults (0, 0, 0) and (0, 0, 1)) and `radius` (default 1), as
    /// Mitsuba 3's `cylinder.cpp` reads them; a radius that is not positive and an axis of zero
    /// length (where Mitsuba divides by zero) are refused. When the tube `emits`, a `to_world`
    /// that makes it elliptic or shears it is warned about: Mitsuba (which warns too)
    /// intersects that surface but takes its area, so its light sampling, as a round tube's,
    /// which makes its image of the light wrong; our triangles are the surface itself.
    fn cylinder_axis(
        &mut self,
        n: Node<'a, 'i>,
        o: &mut Obj<'a, 'i>,
        to_world: Option<DMat4>,
        emits: bool,
    ) -> Result<(DVec3, DVec3, f64)> {
        let node = |o: &Obj<'a, 'i>, name: &str| o.props.get(name).copied().unwrap_or(n);
        let (p0_node, p1_node, radius_node) = (node(o, "p0"), node(o, "p1"), node(o, "radius"));
        let p0 = self.point(o, "p0")?.unwrap_or(DVec3::ZERO);
        let p1 = self.point(o, "p1")?.unwrap_or(DVec3::Z);
        let radius = self.float(o, "radius")?.unwrap_or(1.0);
        if radius <= 0.0 {
            return Err(self.err(radius_node, format!("radius: expected a positive number, got {radius}")));
        }
        if p0 == p1 {
            // Named by the one written (p1 unless only p0 is).
            let (at, key, other) = if p1_node == n {
                (p0_node, "p0", "p1")
            } else {
                (p1_node, "p1", "p0")
            };
            return Err(self.err(
                at,
                format!(
                    "{key}: expected a point other than {other} (the axis would have zero length), got {p1} for both"
                ),
            ));
        }
        let linear = to_world.map_or(DMat3::IDENTITY, DMat3::from_mat4) * cylinder_frame(p0, p1, radius).matrix3;
        if emits && !is_round_tube(linear) {
            self.warn(
                n,
                "to_world makes the emitting tube elliptic or sheared: Mitsuba 3 samples its light as a round \
                 tube's, so Mitsuba's image of it will differ from ours",
            );
        }
        Ok((p0, p1, radius))
    }

    /// A file as the loader will read it: relative to the scene file's directory, so a file
    /// found elsewhere (a `<path>` directory, an included file's directory) is named by its
    /// absolute path.
    pub(super) fn loader_path(&self, p: Node, file: &str, path: &std::path::Path) -> Result<String> {
        if self.including.len() == 1 && path == self.dir.join(file) {
            return Ok(file.to_string());
        }
        Ok(std::fs::canonicalize(path)
            .map_err(|e| self.err(p, format!("filename: cannot resolve {}: {e}", path.display())))?
            .display()
            .to_string())
    }
}

/// Whether the unit tube under `linear` is a round tube about a perpendicular axis (equal,
/// orthogonal x and y columns, both orthogonal to z), the case where Mitsuba's area is right.
fn is_round_tube(linear: DMat3) -> bool {
    let (x, y, z) = (linear.x_axis, linear.y_axis, linear.z_axis);
    let tol = 1e-5 * x.length().max(y.length()).max(z.length()).powi(2);
    (x.length_squared() - y.length_squared()).abs() <= tol
        && x.dot(y).abs() <= tol
        && x.dot(z).abs() <= tol
        && y.dot(z).abs() <= tol
}
