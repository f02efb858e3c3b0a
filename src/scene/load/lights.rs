//! Point, spot, projector and directional lights: positions within the scene's limits,
//! intensities and irradiances finite and non-negative, directions non-zero, spot angles
//! ordered, a projector's field of view in (0°, 180°).

use super::textures::Textures;
use super::*;
use crate::error::Result;
use crate::light::delta::{DeltaLight, Spot};
use crate::light::projector::Projector;
use crate::scene::desc::{Color, LightDesc};

/// The largest cutoff half-angle of a spot, in degrees: beyond it the cone is the whole sphere.
const MAX_SPOT_ANGLE: f64 = 180.0;

/// Builds light `i` of the file's `[[lights]]`.
pub(super) fn delta_light(ctx: &Ctx, i: usize, l: &LightDesc, textures: &mut Textures) -> Result<DeltaLight> {
    let field = |name: &str| format!("lights[{i}].{name}");
    let power = |name: &str, v: desc::Triple| -> Result<glam::Vec3> {
        if v.iter().all(|&x| (0.0..=MAX_RADIANCE).contains(&x)) {
            Ok(rgb(v))
        } else {
            Err(ctx.err(
                &field(name),
                format!(
                    "expected each channel finite in [0, {}], got {}",
                    num(MAX_RADIANCE),
                    triple(v)
                ),
            ))
        }
    };
    let direction = |name: &str, v: desc::Triple| -> Result<glam::Vec3> {
        let d = ctx.coords(&field(name), v)?;
        if d.length() < 1e-12 {
            return Err(ctx.err(&field(name), "expected a non-zero direction, got [0, 0, 0]"));
        }
        Ok(d.normalize().as_vec3())
    };
    Ok(match l {
        LightDesc::Point(p) => DeltaLight::Point {
            position: ctx.coords(&field("position"), p.position)?.as_vec3(),
            intensity: power("intensity", p.intensity)?,
        },
        LightDesc::Directional(d) => DeltaLight::Directional {
            direction: direction("direction", d.direction)?,
            irradiance: power("irradiance", d.irradiance)?,
        },
        LightDesc::Spot(s) => {
            let position = ctx.coords(&field("position"), s.position)?;
            let axis = light_axis(ctx, i, position, s.target, s.direction)?;
            let cutoff = s.cutoff_angle.unwrap_or(20.0);
            if !(cutoff > 0.0 && cutoff <= MAX_SPOT_ANGLE) {
                return Err(ctx.err(
                    &field("cutoff_angle"),
                    format!("expected degrees in (0, {MAX_SPOT_ANGLE}], got {}", num(cutoff)),
                ));
            }
            let beam = s.beam_width.unwrap_or(0.75 * cutoff);
            if !(beam > 0.0 && beam <= cutoff) {
                return Err(ctx.err(
                    &field("beam_width"),
                    format!(
                        "expected degrees in (0, cutoff_angle = {}], got {}",
                        num(cutoff),
                        num(beam)
                    ),
                ));
            }
            let make = match s.falloff.as_deref() {
                None | Some("linear") => Spot::new,
                Some("smoothstep") => Spot::smoothstep,
                Some(other) => {
                    return Err(ctx.err(
                        &field("falloff"),
                        format!("expected \"linear\" or \"smoothstep\", got {other:?}"),
                    ));
                }
            };
            let spot = make(
                position.as_vec3(),
                axis,
                power("intensity", s.intensity)?,
                cutoff.to_radians() as f32,
                beam.to_radians() as f32,
            );
            match &s.texture {
                None => DeltaLight::Spot(spot),
                Some(t) => {
                    if cutoff >= 90.0 {
                        return Err(ctx.err(
                            &field("cutoff_angle"),
                            format!("a textured spot projects through a cone narrower than 180°: expected at most 89.9, got {}", num(cutoff)),
                        ));
                    }
                    let picture = textures.picture(ctx, &field("texture"), t)?;
                    let frame = lookat_frame(ctx, &field("up"), spot.axis, s.up)?;
                    DeltaLight::Spot(spot.with_texture(frame, picture))
                }
            }
        }
        LightDesc::Projector(p) => {
            let position = ctx.coords(&field("position"), p.position)?;
            let axis = light_axis(ctx, i, position, p.target, p.direction)?;
            let frame = lookat_frame(ctx, &field("up"), axis, p.up)?;
            let (irradiance, picture) = match &p.irradiance {
                None => (glam::Vec3::ONE, None),
                Some(Color::Rgb(c)) => (power("irradiance", *c)?, None),
                Some(Color::Texture(t)) => (glam::Vec3::ONE, Some(textures.picture(ctx, &field("irradiance"), t)?)),
            };
            let scale = p.scale.unwrap_or(1.0);
            if !(0.0..=MAX_RADIANCE).contains(&scale) {
                return Err(ctx.err(
                    &field("scale"),
                    format!("expected a number in [0, {}], got {}", num(MAX_RADIANCE), num(scale)),
                ));
            }
            let resolution = match &picture {
                Some(crate::texture::Texture::Bitmap(b)) => (b.width, b.height),
                _ => (1, 1),
            };
            let tan_half = projector_view(ctx, &field("fov"), p.fov, p.fov_axis.as_deref(), resolution)?;
            DeltaLight::Projector(Projector::new(
                position.as_vec3(),
                frame,
                tan_half,
                scale as f32,
                irradiance,
                picture,
            ))
        }
    })
}

/// A spot's or a projector's unit axis from exactly one of `target` and `direction`.
fn light_axis(
    ctx: &Ctx,
    i: usize,
    position: glam::DVec3,
    target: Option<desc::Triple>,
    direction: Option<desc::Triple>,
) -> Result<glam::Vec3> {
    let field = |name: &str| format!("lights[{i}].{name}");
    match (target, direction) {
        (Some(t), None) => {
            let t = ctx.coords(&field("target"), t)?;
            if (t - position).length() < 1e-12 {
                return Err(ctx.err(&field("target"), "expected a point other than the position"));
            }
            Ok((t - position).normalize().as_vec3())
        }
        (None, Some(d)) => {
            let d = ctx.coords(&field("direction"), d)?;
            if d.length() < 1e-12 {
                return Err(ctx.err(&field("direction"), "expected a non-zero direction, got [0, 0, 0]"));
            }
            Ok(d.normalize().as_vec3())
        }
        _ => Err(ctx.err(
            &field("target"),
            "expected exactly one of `target` (a point on the axis) and `direction`",
        )),
    }
}

/// A projector's image plane at distance 1, (t_x, t_y): `fov` degrees along `axis` of a picture
/// of `resolution` (Mitsuba's `parse_fov`: "x" by default; "smaller" and "larger" pick by the
/// aspect ratio W / H), t_y = t_x H / W.
fn projector_view(ctx: &Ctx, field: &str, fov: f64, axis: Option<&str>, (w, h): (u32, u32)) -> Result<glam::Vec2> {
    if !(fov > 0.0 && fov < 180.0) {
        return Err(ctx.err(field, format!("expected degrees in (0, 180), got {}", num(fov))));
    }
    let axis = axis.unwrap_or("x");
    let Some(half) = crate::camera::fov_half_extents(fov, axis, (w, h)) else {
        return Err(ctx.err(
            &format!("{field}_axis"),
            format!("expected \"x\", \"y\", \"diagonal\", \"smaller\" or \"larger\", got {axis:?}"),
        ));
    };
    Ok(half.as_vec2())
}

/// A pictured spot's or a projector's frame (columns x, y, axis) as Mitsuba's `lookat` makes it:
/// x = up × axis normalised, y = axis × x; `up` by default +y, or +x within 26° of vertical (the
/// Mitsuba exporter's choice).
fn lookat_frame(ctx: &Ctx, field: &str, axis: glam::Vec3, up: Option<desc::Triple>) -> Result<glam::Mat3> {
    use glam::Vec3;
    let up = match up {
        Some(u) => ctx.coords(field, u)?.as_vec3(),
        None if axis.y.abs() > 0.9 => Vec3::X,
        None => Vec3::Y,
    };
    let x = up.cross(axis);
    if x.length() <= 1e-6 * up.length() {
        return Err(ctx.err(field, "expected a direction not parallel to the light's axis"));
    }
    let x = x.normalize();
    Ok(glam::Mat3::from_cols(x, axis.cross(x), axis))
}
