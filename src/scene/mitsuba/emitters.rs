//! `<emitter>` elements: `area` emitters (inside shapes or referenced by them), the
//! environment (`constant`, `envmap`) and the delta lights (`point`, `spot`, `projector`,
//! `directional`).

use super::*;
use crate::error::Result;
use crate::scene::desc::{self, Fixed};
use glam::{DMat3, DMat4, DVec3};
use roxmltree::Node;

impl<'a, 'i> Reader<'a, 'i> {
    /// A top-level `constant` or `envmap` emitter.
    pub(super) fn environment(&mut self, n: Node<'a, 'i>) -> Result<desc::EnvironmentDesc> {
        let kind = self.required(n, "type")?;
        let mut o = self.obj(n)?;
        let env = if kind == "constant" {
            let radiance = self.unbounded_colour(&mut o, "radiance")?.unwrap_or(Fixed([1.0; 3]));
            desc::EnvironmentDesc::Constant(desc::ConstantEnvironment { radiance })
        } else {
            let Some((p, file)) = self.string(&mut o, "filename")? else {
                return Err(self.err(n, "expected <string name=\"filename\">"));
            };
            let path = self.resolve(&file);
            if !path.is_file() {
                return Err(self.err(p, format!("filename: cannot read {}: no such file", path.display())));
            }
            if self.boolean(&mut o, "mis_compensation")? == Some(true) {
                return Err(self.err(n, "mis_compensation=\"true\" is not supported"));
            }
            desc::EnvironmentDesc::Envmap(desc::EnvmapDesc {
                file: self.loader_path(p, &file, &path)?,
                scale: self.float(&mut o, "scale")?,
                transform: self
                    .transform(&mut o, "to_world")?
                    .map(|(_, m)| desc::TransformDesc::from_matrix(m)),
                mapping: None,
            })
        };
        if let Some(&c) = o.children.first() {
            return Err(self.err(c, "unexpected element in an emitter"));
        }
        self.finish(&o)?;
        Ok(env)
    }

    pub(super) fn area(&mut self, n: Node<'a, 'i>) -> Result<desc::EmissionDesc> {
        let kind = self.required(n, "type")?;
        if kind != "area" {
            return Err(self.err(n, format!("unsupported emitter {kind:?} in a shape (area)")));
        }
        let mut o = self.obj(n)?;
        let Some(radiance) = self.unbounded_colour(&mut o, "radiance")? else {
            return Err(self.err(n, "expected a radiance (<rgb name=\"radiance\" value=\"r, g, b\"/>)"));
        };
        if !radiance.iter().all(|&c| c >= 0.0) {
            return Err(self.err(n, format!("radiance: expected each channel >= 0, got {:?}", radiance.0)));
        }
        if let Some(&c) = o.children.first() {
            return Err(self.err(c, "unexpected element in an emitter"));
        }
        self.finish(&o)?;
        Ok(desc::EmissionDesc {
            radiance,
            two_sided: false,
        })
    }

    /// A top-level `point`, `spot`, `projector` or `directional` emitter, with Mitsuba's
    /// defaults (intensity and irradiance 1, cutoff 20°, beam ¾ of the cutoff). Its `to_world`
    /// gives a point, a spot or a projector its position (the translation) and the others their
    /// direction (the image of +z) — and a projector or a pictured spot the picture's up (the
    /// image of +y); a spot's or a projector's must keep angles (rotation, translation, uniform
    /// scale), since a sheared cone is not a spot.
    pub(super) fn delta_light(&mut self, n: Node<'a, 'i>) -> Result<desc::LightDesc> {
        let kind = self.required(n, "type")?;
        let mut o = self.obj(n)?;
        let to_world = self.transform(&mut o, "to_world")?;
        let given = |name: &str, v: Option<DVec3>, to_world: &Option<(Node, DMat4)>| -> Result<()> {
            if let (Some(_), Some((t, _))) = (v, to_world) {
                return Err(self.err(*t, format!("give either `{name}` or `to_world`, not both (as Mitsuba)")));
            }
            Ok(())
        };
        let matrix = to_world.as_ref().map_or(DMat4::IDENTITY, |(_, m)| *m);
        let translation = matrix.w_axis.truncate();
        let axis = matrix.transform_vector3(DVec3::Z);
        let light = match kind.as_str() {
            "point" => {
                let position = self.point(&mut o, "position")?;
                given("position", position, &to_world)?;
                desc::LightDesc::Point(desc::PointLightDesc {
                    position: Fixed(position.unwrap_or(translation).to_array()),
                    intensity: self.unbounded_colour(&mut o, "intensity")?.unwrap_or(Fixed([1.0; 3])),
                })
            }
            "spot" => {
                let linear = DMat3::from_mat4(matrix);
                self.angle_keeping(n, &to_world, linear, "a spot's")?;
                let mut intensity = self.unbounded_colour(&mut o, "intensity")?.unwrap_or(Fixed([1.0; 3]));
                // The projected picture's frame is to_world's: its y axis is the picture's up.
                let texture = match self.texture_colour(&mut o, "texture")? {
                    None => None,
                    Some(desc::Color::Rgb(c)) => {
                        intensity = Fixed(std::array::from_fn(|k| intensity[k] * c[k]));
                        None
                    }
                    Some(desc::Color::Texture(t)) => {
                        if linear.determinant() < 0.0 {
                            let at = to_world.as_ref().map_or(n, |(t, _)| *t);
                            return Err(self.err(at, "a textured spot's to_world must not mirror"));
                        }
                        Some(t)
                    }
                };
                desc::LightDesc::Spot(desc::SpotLightDesc {
                    position: Fixed(translation.to_array()),
                    target: None,
                    direction: Some(Fixed(axis.to_array())),
                    intensity,
                    cutoff_angle: self.float(&mut o, "cutoff_angle")?,
                    beam_width: self.float(&mut o, "beam_width")?,
                    falloff: None,
                    up: texture
                        .is_some()
                        .then(|| Fixed(matrix.transform_vector3(DVec3::Y).to_array())),
                    texture,
                })
            }
            "projector" => {
                let linear = DMat3::from_mat4(matrix);
                let uniform_scale = self.angle_keeping(n, &to_world, linear, "a projector's")?;
                if linear.determinant() < 0.0 {
                    let at = to_world.as_ref().map_or(n, |(t, _)| *t);
                    return Err(self.err(at, "a projector's to_world must not mirror"));
                }
                if o.props.contains_key("focal_length") {
                    return Err(self.err(n, "focal_length is not supported; give <float name=\"fov\">"));
                }
                let Some(fov) = self.float(&mut o, "fov")? else {
                    return Err(self.err(n, "expected <float name=\"fov\"> (focal_length is not supported)"));
                };
                let irradiance = if o.children.iter().any(|c| c.attribute("name") == Some("irradiance")) {
                    self.texture_colour(&mut o, "irradiance")?
                } else {
                    self.unbounded_colour(&mut o, "irradiance")?.map(desc::Color::Rgb)
                };
                // Mitsuba divides by the local z² and multiplies by the length of to_world's
                // image of +z: a uniform scale s multiplies the intensity by s.
                let scale = self.float(&mut o, "scale")?.unwrap_or(1.0) * uniform_scale;
                desc::LightDesc::Projector(desc::ProjectorLightDesc {
                    position: Fixed(translation.to_array()),
                    target: None,
                    direction: Some(Fixed(axis.to_array())),
                    up: Some(Fixed(matrix.transform_vector3(DVec3::Y).to_array())),
                    fov,
                    fov_axis: self.string(&mut o, "fov_axis")?.map(|(_, a)| a),
                    irradiance,
                    scale: Some(scale),
                })
            }
            _ => {
                let direction = self.point(&mut o, "direction")?;
                given("direction", direction, &to_world)?;
                desc::LightDesc::Directional(desc::DirectionalLightDesc {
                    direction: Fixed(direction.unwrap_or(axis).to_array()),
                    irradiance: self.unbounded_colour(&mut o, "irradiance")?.unwrap_or(Fixed([1.0; 3])),
                })
            }
        };
        if let Some(&c) = o.children.first() {
            return Err(self.err(c, "unexpected element in an emitter"));
        }
        self.finish(&o)?;
        Ok(light)
    }

    /// Checks that `linear` (the linear part of `to_world`) keeps angles — a rotation and a
    /// uniform scale, possibly mirrored — since a sheared cone or frustum is not the light's;
    /// returns the scale.
    fn angle_keeping(
        &self,
        n: Node<'a, 'i>,
        to_world: &Option<(Node<'a, 'i>, DMat4)>,
        linear: DMat3,
        whose: &str,
    ) -> Result<f64> {
        let gram = linear.transpose() * linear;
        let s2 = gram.x_axis.x;
        if s2 <= 0.0
            || (gram - DMat3::IDENTITY * s2)
                .to_cols_array()
                .iter()
                .any(|x| x.abs() > 1e-4 * s2)
        {
            let at = to_world.as_ref().map_or(n, |(t, _)| *t);
            return Err(self.err(
                at,
                format!("{whose} to_world must be a rotation, a translation and a uniform scale"),
            ));
        }
        Ok(s2.sqrt())
    }
}
