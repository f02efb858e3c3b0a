//! Parameter lists and the scene's content: shapes (with their alpha) and lights.

use super::*;

/// The 4 × 4 matrix pbrt writes as 16 numbers, column by column.
pub(super) fn column_major(v: &[f64]) -> DMat4 {
    DMat4::from_cols_slice(v)
}

pub(super) fn find<'p>(params: &'p [Param], name: &str) -> Option<&'p Param> {
    params.iter().find(|p| p.name == name)
}

/// Refuses a parameter the translation does not read (a misspelling, or a feature that would
/// change the image), naming it.
pub(super) fn check_known(d: &Directive, params: &[Param], known: &[&str]) -> Result<()> {
    match params.iter().find(|p| !known.contains(&p.name.as_str())) {
        Some(p) => Err(d.err(format!(
            "parameter \"{} {}\" is not supported here (read: {})",
            p.ty,
            p.name,
            if known.is_empty() {
                "none".to_string()
            } else {
                known.join(", ")
            }
        ))),
        None => Ok(()),
    }
}

pub(super) fn numbers(d: &Directive, p: &Param) -> Result<Vec<f64>> {
    p.values
        .iter()
        .map(|v| match v {
            Value::Num(x) => Ok(*x),
            Value::Str(_) => Err(d.err(format!("parameter \"{} {}\": expected numbers", p.ty, p.name))),
        })
        .collect()
}

pub(super) fn float_param(d: &Directive, params: &[Param], name: &str) -> Result<Option<f64>> {
    let Some(p) = find(params, name) else { return Ok(None) };
    match (p.ty.as_str(), &numbers(d, p)?[..]) {
        ("float" | "integer", [x]) => Ok(Some(*x)),
        _ => Err(d.err(format!("parameter \"{} {name}\": expected one float", p.ty))),
    }
}

pub(super) fn string_param(d: &Directive, params: &[Param], name: &str) -> Result<Option<String>> {
    let Some(p) = find(params, name) else { return Ok(None) };
    match (p.ty.as_str(), &p.values[..]) {
        ("string" | "texture", [Value::Str(s)]) => Ok(Some(s.clone())),
        _ => Err(d.err(format!("parameter \"{} {name}\": expected one string", p.ty))),
    }
}

pub(super) fn bool_param(d: &Directive, params: &[Param], name: &str) -> Result<Option<bool>> {
    let Some(p) = find(params, name) else { return Ok(None) };
    match (p.ty.as_str(), &p.values[..]) {
        ("bool", [Value::Str(s)]) if s == "true" || s == "false" => Ok(Some(s == "true")),
        _ => Err(d.err(format!("parameter \"{} {name}\": expected true or false", p.ty))),
    }
}

/// Triples of a `point3`/`normal3`/`vector3` array.
fn triples(d: &Directive, params: &[Param], name: &str) -> Result<Option<Vec<Triple>>> {
    let Some(p) = find(params, name) else { return Ok(None) };
    let v = numbers(d, p)?;
    if !matches!(
        p.ty.as_str(),
        "point3" | "point" | "normal3" | "normal" | "vector3" | "vector"
    ) || v.len() % 3 != 0
    {
        return Err(d.err(format!("parameter \"{} {name}\": expected triples of numbers", p.ty)));
    }
    Ok(Some(v.chunks(3).map(|c| Fixed([c[0], c[1], c[2]])).collect()))
}

impl Translator<'_> {
    pub(super) fn shape(&mut self, d: &Directive) -> Result<()> {
        let kind = match &d.args[..] {
            [Value::Str(s)] => s.clone(),
            _ => return Err(d.err("expected the shape type")),
        };
        let material = self.current_material();
        let emission = self.state.area_light.clone();
        let transform = Some(self.ctm_desc());
        let ro = self.state.reverse_orientation;
        let Some(material) = self.alpha_masked(d, material, emission.is_some())? else {
            self.warn(
                d,
                "alpha 0: pbrt-v4 neither shows this shape nor lets it emit (its area light masks all \
                 emission too), so it is left out",
            );
            return Ok(());
        };
        // `alpha`, read above, is a parameter of every shape.
        let params = &d.params;
        let check_known =
            |d: &Directive, params: &[Param], known: &[&str]| check_known(d, params, &[known, &["alpha"]].concat());
        let shape = match kind.as_str() {
            "trianglemesh" => {
                check_known(d, params, &["P", "indices", "N", "uv"])?;
                let positions = triples(d, params, "P")?.ok_or_else(|| d.err("expected \"point3 P\""))?;
                let mut indices: Option<Vec<i64>> = match find(params, "indices") {
                    None => None,
                    Some(p) => Some(numbers(d, p)?.iter().map(|&x| x as i64).collect()),
                };
                let normals = triples(d, params, "N")?;
                if normals.is_none() && (ro ^ self.swaps_handedness()) {
                    // Turned around by winding the other way.
                    let mut i = indices.clone().unwrap_or_else(|| (0..positions.len() as i64).collect());
                    for t in i.chunks_mut(3) {
                        if t.len() == 3 {
                            t.swap(1, 2);
                        }
                    }
                    indices = Some(i);
                }
                let uv = match find(params, "uv") {
                    None => None,
                    Some(p) => {
                        let v = numbers(d, p)?;
                        if v.len() % 2 != 0 {
                            return Err(d.err("parameter uv: expected pairs of numbers"));
                        }
                        Some(v.chunks(2).map(|c| Fixed([c[0], c[1]])).collect())
                    }
                };
                ShapeDesc::Triangles(desc::Triangles {
                    material,
                    interior: None,
                    exterior: None,
                    positions,
                    indices,
                    normals,
                    uv,
                    transform,
                    emission,
                })
            }
            "loopsubdiv" => {
                check_known(d, params, &["P", "indices", "levels"])?;
                self.loop_subdivision(d, params, material, transform, emission)?
            }
            "bilinearmesh" => {
                check_known(d, params, &["P", "indices", "uv"])?;
                self.bilinear_patches(d, params, material, transform, emission)?
            }
            "plymesh" => {
                check_known(d, params, &["filename"])?;
                let file = string_param(d, params, "filename")?.ok_or_else(|| d.err("expected \"string filename\""))?;
                ShapeDesc::Mesh(desc::Mesh {
                    material,
                    interior: None,
                    exterior: None,
                    file: self.dir.join(&file).display().to_string(),
                    face_normals: false,
                    smooth_normals: false,
                    shape_index: None,
                    // Where the winding decides the front, as for `trianglemesh`.
                    reverse_orientation: ro ^ self.swaps_handedness(),
                    transform,
                    emission,
                })
            }
            "sphere" | "disk" | "cylinder" if self.swaps_handedness() => {
                return Err(d.err("a sphere, disk or cylinder under a mirroring transform is not read"));
            }
            "sphere" => {
                check_known(d, params, &["radius", "zmin", "zmax", "phimax"])?;
                self.whole(d, &["zmin", "zmax", "phimax"])?;
                if ro {
                    return Err(d.err("a turned-around sphere (ReverseOrientation) is not read"));
                }
                ShapeDesc::Sphere(desc::Sphere {
                    material,
                    interior: None,
                    exterior: None,
                    center: Fixed(self.point(DVec3::ZERO).to_array()),
                    radius: float_param(d, params, "radius")?.unwrap_or(1.0) * self.uniform_scale(d)?,
                    transform: None,
                    emission,
                })
            }
            "disk" => {
                check_known(d, params, &["radius", "height", "innerradius", "phimax"])?;
                self.whole(d, &["innerradius", "phimax"])?;
                let r = float_param(d, params, "radius")?.unwrap_or(1.0);
                let h = float_param(d, params, "height")?.unwrap_or(0.0);
                let m = self.state.ctm
                    * DMat4::from_translation(DVec3::new(0.0, 0.0, h))
                    * DMat4::from_scale(DVec3::new(r, r, 1.0));
                ShapeDesc::Disk(desc::Disk {
                    material,
                    interior: None,
                    exterior: None,
                    flip_normals: ro,
                    transform: Some(TransformDesc::from_matrix(m)),
                    emission,
                })
            }
            "cylinder" => {
                check_known(d, params, &["radius", "zmin", "zmax", "phimax"])?;
                self.whole(d, &["phimax"])?;
                ShapeDesc::Cylinder(desc::Cylinder {
                    material,
                    interior: None,
                    exterior: None,
                    p0: Some(Fixed([0.0, 0.0, float_param(d, params, "zmin")?.unwrap_or(-1.0)])),
                    p1: Some(Fixed([0.0, 0.0, float_param(d, params, "zmax")?.unwrap_or(1.0)])),
                    radius: Some(float_param(d, params, "radius")?.unwrap_or(1.0)),
                    flip_normals: ro,
                    transform,
                    emission,
                })
            }
            other => {
                return Err(d.err(format!(
                    "unsupported shape {other:?} (trianglemesh, bilinearmesh of flat patches, plymesh, sphere, disk, cylinder)"
                )));
            }
        };
        let mut shape = shape;
        if let Some((inside, outside)) = self.shape_media() {
            shape.set_media(inside, outside);
        }
        let label = format!("{}, Shape \"{kind}\"", d.at);
        if let Some(object) = &self.defining {
            if self.state.area_light.is_some() {
                return Err(d.err("an area light inside ObjectBegin is not supported (pbrt-v4 refuses it too)"));
            }
            self.objects
                .get_mut(object)
                .expect("an open object is registered")
                .push((shape, label));
            return Ok(());
        }
        self.shapes.push(shape);
        self.labels.push(label);
        Ok(())
    }

    /// A shape's material with pbrt-v4's `alpha` (`float alpha` below 1 or `texture alpha`):
    /// our mask around the material, which tests α at every ray that meets the shape with a
    /// hash of the ray, as pbrt-v4's `GeometricPrimitive` does (user guide, "Opacity masks");
    /// the material itself where the shape is opaque. A float texture's value is its picture's
    /// luminance here, pbrt's first channel — the same for the grey pictures alpha maps are.
    /// `None` for a constant α of 0, a shape that is nothing in pbrt-v4: rays pass it, and its
    /// area light, masked by the same α (`DiffuseAreaLight::AlphaMasked`), emits nothing. An
    /// area light with any other α is refused: pbrt masks its emission point by point with a
    /// hash of the point, and our masks do not apply to emitters.
    fn alpha_masked(&mut self, d: &Directive, material: String, emits: bool) -> Result<Option<String>> {
        let Some(p) = find(&d.params, "alpha") else {
            return Ok(Some(material));
        };
        let opacity = match p.ty.as_str() {
            "float" => match float_param(d, &d.params, "alpha")? {
                Some(a) if a >= 1.0 => return Ok(Some(material)),
                Some(0.0) => return Ok(None),
                Some(a) if a > 0.0 => desc::ScalarDesc::Value(a),
                a => return Err(d.err(format!("parameter alpha: expected a number in [0, 1], got {a:?}"))),
            },
            "texture" => {
                let Some(Color::Texture(tex)) = self.colour_or_number(d, &d.params, "alpha", false, true)? else {
                    unreachable!("a texture parameter names a texture")
                };
                desc::ScalarDesc::Texture(tex)
            }
            other => return Err(d.err(format!("parameter \"{other} alpha\": expected float or texture"))),
        };
        if emits {
            return Err(
                d.err("an area light with alpha is not read (a masked emitter would emit only where rays stop)")
            );
        }
        let bsdf = self
            .materials
            .get(&material)
            .cloned()
            .expect("the current material is defined");
        // One masked material per distinct (material, α), whatever names they had.
        let key = format!("{bsdf:?} {opacity:?}");
        if let Some(name) = self.masked.get(&key) {
            return Ok(Some(name.clone()));
        }
        self.anonymous += 1;
        let name = format!("{material}-alpha-{}", self.anonymous);
        let mask = MaterialDesc::Mask(desc::Mask {
            opacity: Some(opacity),
            bsdf: Box::new(bsdf),
        });
        self.materials.insert(name.clone(), mask);
        self.masked.insert(key, name.clone());
        Ok(Some(name))
    }

    /// pbrt's `loopsubdiv`: the control mesh refined `levels` times (default 3) and moved to
    /// the limit surface, with its normals ([`super::super::loop_subdiv`]).
    fn loop_subdivision(
        &self,
        d: &Directive,
        params: &[Param],
        material: String,
        transform: Option<TransformDesc>,
        emission: Option<desc::EmissionDesc>,
    ) -> Result<ShapeDesc> {
        let positions = triples(d, params, "P")?.ok_or_else(|| d.err("expected \"point3 P\""))?;
        let indices = match find(params, "indices") {
            Some(p) => numbers(d, p)?,
            None => return Err(d.err("expected \"integer indices\"")),
        };
        if indices.len() % 3 != 0
            || indices
                .iter()
                .any(|&i| i.fract() != 0.0 || i < 0.0 || i >= positions.len() as f64)
        {
            return Err(d.err(format!(
                "indices: expected triples of integers in [0, {}), one triangle each",
                positions.len()
            )));
        }
        let levels = match find(params, "levels") {
            None => 3,
            Some(p) => match numbers(d, p)?[..] {
                [l] if l.fract() == 0.0 && (0.0..=6.0).contains(&l) => l as u32,
                _ => return Err(d.err("levels: expected one integer in [0, 6]")),
            },
        };
        let p: Vec<DVec3> = positions.iter().map(|t| DVec3::from_array(t.0)).collect();
        let tris: Vec<[u32; 3]> = indices
            .chunks(3)
            .map(|t| [t[0] as u32, t[1] as u32, t[2] as u32])
            .collect();
        let s = super::super::loop_subdiv::loop_subdivide(&p, &tris, levels)
            .map_err(|e| d.err(format!("loopsubdiv: {e}")))?;
        Ok(ShapeDesc::Triangles(desc::Triangles {
            material,
            interior: None,
            exterior: None,
            positions: s.positions.iter().map(|q| Fixed(q.to_array())).collect(),
            indices: Some(s.triangles.iter().flatten().map(|&i| i64::from(i)).collect()),
            normals: Some(s.normals.iter().map(|q| Fixed(q.to_array())).collect()),
            uv: None,
            transform,
            emission,
        }))
    }

    /// A `bilinearmesh` of flat patches as triangles: each patch (p00, p10, p01, p11) is two
    /// triangles (p00, p10, p11) and (p00, p11, p01), which keep pbrt's front side
    /// (p10 − p00) × (p01 − p00) and its (u, v) ((0, 0) … (1, 1) unless `uv` is given); a curved
    /// patch (p11 off the plane of the other three) is refused, as a bilinear surface is not
    /// rendered yet. Turned around as triangles are.
    fn bilinear_patches(
        &self,
        d: &Directive,
        params: &[Param],
        material: String,
        transform: Option<TransformDesc>,
        emission: Option<desc::EmissionDesc>,
    ) -> Result<ShapeDesc> {
        let positions = triples(d, params, "P")?.ok_or_else(|| d.err("expected \"point3 P\""))?;
        let corners: Vec<i64> = match find(params, "indices") {
            Some(p) => numbers(d, p)?.iter().map(|&x| x as i64).collect(),
            None if positions.len() == 4 => vec![0, 1, 2, 3],
            None => return Err(d.err("expected \"integer indices\" for more than 4 positions")),
        };
        if corners.is_empty()
            || !corners.len().is_multiple_of(4)
            || corners.iter().any(|&i| i < 0 || i as usize >= positions.len())
        {
            return Err(d.err("indices: expected groups of 4 vertex indices"));
        }
        let p = |i: i64| DVec3::from_array(positions[i as usize].0);
        let flip = self.state.reverse_orientation ^ self.swaps_handedness();
        let mut indices = Vec::with_capacity(corners.len() / 4 * 6);
        for (k, q) in corners.chunks(4).enumerate() {
            let [p00, p10, p01, p11] = [p(q[0]), p(q[1]), p(q[2]), p(q[3])];
            let n = (p10 - p00).cross(p01 - p00);
            let size = (p10 - p00).length().max((p01 - p00).length()).max(1e-30);
            if (p11 - p00).dot(n.normalize_or_zero()).abs() > 1e-5 * size {
                return Err(d.err(format!("bilinearmesh patch {k} is curved (its fourth corner is off the plane of the other three); curved patches are not read yet")));
            }
            let (a, b) = if flip {
                ([q[0], q[3], q[1]], [q[0], q[2], q[3]])
            } else {
                ([q[0], q[1], q[3]], [q[0], q[3], q[2]])
            };
            indices.extend(a);
            indices.extend(b);
        }
        let uv = match find(params, "uv") {
            Some(p) => {
                let v = numbers(d, p)?;
                if v.len() != 2 * positions.len() {
                    return Err(d.err("parameter uv: expected one pair per position"));
                }
                Some(v.chunks(2).map(|c| Fixed([c[0], c[1]])).collect())
            }
            // pbrt's default (u, v) of a patch are its corners' (0, 0), (1, 0), (0, 1), (1, 1),
            // which per-vertex coordinates can hold only when no vertex is shared.
            None if corners.len() == positions.len() && {
                let mut seen = corners.clone();
                seen.sort_unstable();
                seen.dedup();
                seen.len() == corners.len()
            } =>
            {
                let mut uv = vec![Fixed([0.0, 0.0]); positions.len()];
                for q in corners.chunks(4) {
                    for (i, c) in q.iter().zip([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]) {
                        uv[*i as usize] = Fixed(c);
                    }
                }
                Some(uv)
            }
            None => None,
        };
        Ok(ShapeDesc::Triangles(desc::Triangles {
            material,
            interior: None,
            exterior: None,
            positions,
            indices: Some(indices),
            normals: None,
            uv,
            transform,
            emission,
        }))
    }

    /// Refuses a partial quadric: any of `keys` away from its whole-shape default.
    fn whole(&self, d: &Directive, keys: &[&str]) -> Result<()> {
        for &k in keys {
            if let Some(v) = float_param(d, &d.params, k)? {
                let whole = match k {
                    "phimax" => v >= 360.0,
                    "innerradius" => v == 0.0,
                    "zmin" => v <= -float_param(d, &d.params, "radius")?.unwrap_or(1.0),
                    _ => v >= float_param(d, &d.params, "radius")?.unwrap_or(1.0),
                };
                if !whole {
                    return Err(d.err(format!("{k} = {v}: partial spheres, disks and cylinders are not read")));
                }
            }
        }
        Ok(())
    }

    /// The scale of a transform that keeps spheres spheres.
    fn uniform_scale(&self, d: &Directive) -> Result<f64> {
        let m = DMat3::from_mat4(self.state.ctm);
        let s = [m.x_axis.length(), m.y_axis.length(), m.z_axis.length()];
        let orthogonal = m.x_axis.dot(m.y_axis).abs() < 1e-6 * s[0] * s[1]
            && m.x_axis.dot(m.z_axis).abs() < 1e-6 * s[0] * s[2]
            && m.y_axis.dot(m.z_axis).abs() < 1e-6 * s[1] * s[2];
        if orthogonal && (s[0] - s[1]).abs() < 1e-6 * s[0] && (s[0] - s[2]).abs() < 1e-6 * s[0] {
            Ok(s[0])
        } else {
            Err(d.err("a sphere's transform must scale uniformly"))
        }
    }

    pub(super) fn light(&mut self, d: &Directive) -> Result<()> {
        let kind = match &d.args[..] {
            [Value::Str(s)] => s.clone(),
            _ => return Err(d.err("expected the light type")),
        };
        let scale = float_param(d, &d.params, "scale")?.unwrap_or(1.0);
        let point3 = |name: &str, default: DVec3| -> Result<DVec3> {
            Ok(match triples(d, &d.params, name)? {
                None => default,
                Some(v) if v.len() == 1 => DVec3::from_array(v[0].0),
                Some(_) => return Err(d.err(format!("{name}: expected one point"))),
            })
        };
        match kind.as_str() {
            "point" => {
                check_known(d, &d.params, &["I", "scale", "from"])?;
                let i = self.light_colour(d, "I")?.unwrap_or([1.0; 3]);
                self.lights.push(desc::LightDesc::Point(desc::PointLightDesc {
                    position: Fixed(self.point(point3("from", DVec3::ZERO)?).to_array()),
                    intensity: Fixed(i.map(|c| c * scale)),
                }));
            }
            "spot" => {
                check_known(
                    d,
                    &d.params,
                    &["I", "scale", "from", "to", "coneangle", "conedeltaangle"],
                )?;
                let i = self.light_colour(d, "I")?.unwrap_or([1.0; 3]);
                let (from, to) = (point3("from", DVec3::ZERO)?, point3("to", DVec3::Z)?);
                let (position, target) = (self.point(from), self.point(to));
                if (target - position).length() < 1e-12 {
                    return Err(d.err("from and to coincide"));
                }
                let cone = float_param(d, &d.params, "coneangle")?.unwrap_or(30.0);
                let delta = float_param(d, &d.params, "conedeltaangle")?.unwrap_or(5.0);
                if !(cone > 0.0 && cone <= 180.0 && (0.0..=cone).contains(&delta)) {
                    return Err(d.err(format!(
                        "coneangle {cone}, conedeltaangle {delta}: expected 0 < coneangle ≤ 180 and 0 ≤ conedeltaangle ≤ coneangle"
                    )));
                }
                // pbrt's beam is coneangle − conedeltaangle; a zero-width beam is ours as the
                // smallest positive one (the falloff reaches 1 only on the axis there).
                let beam = (cone - delta).max(1e-6 * cone);
                self.lights.push(desc::LightDesc::Spot(desc::SpotLightDesc {
                    position: Fixed(position.to_array()),
                    target: Some(Fixed(target.to_array())),
                    direction: None,
                    intensity: Fixed(i.map(|c| c * scale)),
                    cutoff_angle: Some(cone),
                    beam_width: Some(beam),
                    falloff: Some("smoothstep".into()),
                    texture: None,
                    up: None,
                }));
            }
            "distant" => {
                check_known(d, &d.params, &["L", "scale", "from", "to"])?;
                let l = self.light_colour(d, "L")?.unwrap_or([1.0; 3]);
                let (from, to) = (point3("from", DVec3::ZERO)?, point3("to", DVec3::Z)?);
                let dir = (self.point(to) - self.point(from)).normalize_or_zero();
                if dir == DVec3::ZERO {
                    return Err(d.err("from and to coincide"));
                }
                self.lights
                    .push(desc::LightDesc::Directional(desc::DirectionalLightDesc {
                        direction: Fixed(dir.to_array()),
                        irradiance: Fixed(l.map(|c| c * scale)),
                    }));
            }
            "infinite" if find(&d.params, "filename").is_some() => {
                check_known(d, &d.params, &["filename", "scale"])?;
                if self.environment.is_some() {
                    return Err(d.err("a second infinite light"));
                }
                let file = string_param(d, &d.params, "filename")?.unwrap_or_default();
                self.environment = Some(desc::EnvironmentDesc::Envmap(desc::EnvmapDesc {
                    file,
                    scale: Some(scale),
                    transform: Some(TransformDesc::from_matrix(self.state.ctm)),
                    mapping: Some("equal_area".into()),
                }));
            }
            "infinite" => {
                check_known(d, &d.params, &["L", "scale"])?;
                if self.environment.is_some() {
                    return Err(d.err("a second infinite light"));
                }
                let l = self.light_colour(d, "L")?.unwrap_or([1.0; 3]);
                self.environment = Some(desc::EnvironmentDesc::Constant(desc::ConstantEnvironment {
                    radiance: Fixed(l.map(|c| c * scale)),
                }));
            }
            other => {
                return Err(d.err(format!("unsupported light {other:?} (point, spot, distant, infinite)")));
            }
        }
        Ok(())
    }
}
