//! The third stage, meaning: numbers in range, colours, energies, the camera and the
//! materials (BSDFs built and checked), each error one line naming the field.

use super::principled;
use super::rough;
use super::textures::Textures;
use super::*;
use crate::bsdf::{
    Blend, Bsdf, ColorParam, Dielectric, DiffuseTransmission, Lambertian, Mirror, NormalMapped, Phong, ThinDielectric,
    Ward,
};
use crate::camera::{Camera, Lens};
use crate::error::Result;
use crate::pixel_filter::{FilterKind, MAX_RADIUS, PixelFilter};
use crate::resources::{check_memory, film_bytes, memory_limit};
use crate::scene::desc::{self, MaterialDesc, Triple};
use crate::scene::{Bump, Material};
use glam::{DVec3, Vec3};
use std::collections::BTreeMap;

/// A number as a reader would write it: exponents for very large or small magnitudes.
pub(super) fn num(v: f64) -> String {
    let a = v.abs();
    if v.is_finite() && a != 0.0 && !(1e-4..1e7).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// A computed number (a distance, a determinant) to 4 significant digits.
pub(super) fn approx(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        return "0".to_string();
    }
    if !v.is_finite() || !(1e-4..1e7).contains(&a) {
        return format!("{v:.3e}");
    }
    let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

pub(super) fn triple(v: impl Into<Triple>) -> String {
    let v = v.into();
    format!("[{}, {}, {}]", num(v[0]), num(v[1]), num(v[2]))
}

pub(super) fn dvec(v: Triple) -> DVec3 {
    DVec3::from_array(v.0)
}

pub(super) fn rgb(v: Triple) -> Vec3 {
    dvec(v).as_vec3()
}

pub(super) fn is_coord(v: f64) -> bool {
    v.is_finite() && v.abs() <= MAX_COORD
}

impl Ctx {
    /// A point or vector: finite, every coordinate within ±[`MAX_COORD`].
    pub(super) fn coords(&self, field: &str, v: Triple) -> Result<DVec3> {
        if v.iter().all(|&c| is_coord(c)) {
            Ok(dvec(v))
        } else {
            Err(self.err(
                field,
                format!(
                    "expected finite coordinates of magnitude at most {}, got {}",
                    num(MAX_COORD),
                    triple(v)
                ),
            ))
        }
    }

    /// A length such as a radius: positive, finite, at most [`MAX_COORD`].
    pub(super) fn positive(&self, field: &str, v: f64) -> Result<f64> {
        if v > 0.0 && is_coord(v) {
            Ok(v)
        } else {
            Err(self.err(field, format!("expected a positive finite number, got {}", num(v))))
        }
    }

    /// Positive sizes per axis.
    pub(super) fn sizes<const N: usize>(&self, field: &str, v: [f64; N]) -> Result<[f64; N]> {
        if v.iter().all(|&c| c > 0.0 && is_coord(c)) {
            Ok(v)
        } else {
            let list: Vec<String> = v.iter().map(|&c| num(c)).collect();
            Err(self.err(
                field,
                format!("expected positive finite sizes, got [{}]", list.join(", ")),
            ))
        }
    }

    /// A reflectance-like colour: every channel in [0, 1].
    pub(super) fn unit_rgb(&self, field: &str, v: Triple) -> Result<Triple> {
        if v.iter().all(|c| (0.0..=1.0).contains(c)) {
            Ok(v)
        } else {
            Err(self.err(field, format!("expected each channel in [0, 1], got {}", triple(v))))
        }
    }

    /// Two colours whose sum must not exceed 1 per channel (energy conservation).
    pub(super) fn energy(&self, field: &str, what: &str, a: Triple, b: Triple) -> Result<()> {
        if (0..3).all(|i| a[i] + b[i] <= 1.0 + 1e-6) {
            Ok(())
        } else {
            let sum = [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
            Err(self.err(
                field,
                format!(
                    "{what} must not exceed 1 in any channel (energy conservation), got {}",
                    triple(sum)
                ),
            ))
        }
    }
}

pub(super) fn camera(ctx: &Ctx, c: &desc::CameraDesc) -> Result<Camera> {
    let [w, h] = c.resolution.0;
    if !(1..=MAX_RESOLUTION_SIDE).contains(&w) || !(1..=MAX_RESOLUTION_SIDE).contains(&h) {
        return Err(ctx.err(
            "camera.resolution",
            format!("expected width and height in 1..={MAX_RESOLUTION_SIDE}, got [{w}, {h}]"),
        ));
    }
    if w as u64 * h as u64 > MAX_PIXELS {
        return Err(ctx.err(
            "camera.resolution",
            format!("{w} × {h} pixels exceeds the limit of {} Mpixel", MAX_PIXELS >> 20),
        ));
    }
    // Before any film is allocated: a film this machine cannot hold is refused here, not
    // killed by the kernel halfway through a run.
    let film = format!("a {w} × {h} film");
    check_memory(&film, film_bytes(w, h), memory_limit()?).map_err(|e| ctx.err("camera.resolution", e))?;
    let orthographic = matches!(c.lens, Some(desc::LensDesc::Orthographic(_)));
    let fov_y = match c.fov_y {
        Some(f) if f > 0.0 && f < 180.0 => f,
        // Unused by an orthographic lens; any valid value keeps the camera's basis well defined.
        None if orthographic => 90.0,
        Some(f) => {
            return Err(ctx.err("camera.fov_y", format!("expected degrees in (0, 180), got {}", num(f))));
        }
        None => return Err(ctx.err("camera.fov_y", "missing; expected degrees in (0, 180)")),
    };
    let eye = ctx.coords("camera.eye", c.eye)?;
    let look_at = ctx.coords("camera.look_at", c.look_at)?;
    let up = ctx.coords("camera.up", c.up)?;
    let dir = look_at - eye;
    // Closer than f32 can resolve at these coordinates counts as equal.
    let scale = eye.abs().max_element().max(look_at.abs().max_element());
    if dir.length() <= 1e-6 * scale || dir.length() == 0.0 {
        return Err(ctx.err(
            "camera.look_at",
            format!("must differ from camera.eye, both are {}", triple(c.eye)),
        ));
    }
    let sin = dir.normalize().cross(up.normalize_or_zero()).length();
    if sin.is_nan() || sin <= 1e-3 {
        return Err(ctx.err(
            "camera.up",
            format!(
                "must be non-zero and not parallel to the view direction (look_at - eye), got {}",
                triple(c.up)
            ),
        ));
    }
    let mut camera = Camera::new(eye.as_vec3(), look_at.as_vec3(), up.as_vec3(), fov_y as f32, w, h)
        .with_filter(pixel_filter(ctx, c.filter)?)
        .with_lens(lens(ctx, c.lens, w as f64 / h as f64)?);
    if c.flip_x {
        camera = camera.mirrored();
    }
    let Some(crop) = c.crop else {
        return Ok(camera);
    };
    let [x, y] = crop.offset.map_or([0, 0], |o| o.0);
    let [cw, ch] = crop.size.0;
    if cw == 0 || ch == 0 {
        return Err(ctx.err(
            "camera.crop.size",
            format!("expected a positive width and height, got [{cw}, {ch}]"),
        ));
    }
    if u64::from(x) + u64::from(cw) > u64::from(w) || u64::from(y) + u64::from(ch) > u64::from(h) {
        return Err(ctx.err(
            "camera.crop",
            format!(
                "expected a window inside the {w} × {h} film (offset + size ≤ resolution), got offset [{x}, {y}], size [{cw}, {ch}]"
            ),
        ));
    }
    Ok(camera.with_crop((x, y), (cw, ch)))
}

/// The camera's lens; `aspect` is the film's width over its height.
fn lens(ctx: &Ctx, l: Option<desc::LensDesc>, aspect: f64) -> Result<Lens> {
    let positive = |field: &str, v: f64| -> Result<f32> {
        if v > 0.0 && v.is_finite() && (v as f32).is_normal() {
            Ok(v as f32)
        } else {
            Err(ctx.err(field, format!("expected a positive length, got {}", num(v))))
        }
    };
    Ok(match l {
        None | Some(desc::LensDesc::Pinhole(_)) => Lens::Pinhole,
        Some(desc::LensDesc::Thin(t)) => Lens::Thin {
            aperture_radius: positive("camera.lens.aperture_radius", t.aperture_radius)?,
            focus_distance: positive("camera.lens.focus_distance", t.focus_distance)?,
        },
        Some(desc::LensDesc::Orthographic(o)) => {
            let height = positive("camera.lens.height", o.height)?;
            let width = match o.width {
                Some(w) => positive("camera.lens.width", w)?,
                None => height * aspect as f32,
            };
            Lens::Orthographic {
                half_w: 0.5 * width,
                half_h: 0.5 * height,
            }
        }
    })
}

/// The camera's pixel filter: a tent's radius in (0, 16], a Gaussian's σ in (0, 4] pixels.
fn pixel_filter(ctx: &Ctx, f: Option<desc::FilterDesc>) -> Result<PixelFilter> {
    let within = |field: &str, v: f64, max: f64| -> Result<f32> {
        if v > 0.0 && v <= max {
            Ok(v as f32)
        } else {
            Err(ctx.err(field, format!("expected pixels in (0, {max}], got {}", num(v))))
        }
    };
    Ok(match f {
        None | Some(desc::FilterDesc::Box(_)) => PixelFilter::Box,
        Some(desc::FilterDesc::Tent(t)) => PixelFilter::separable(FilterKind::Tent {
            radius: within("camera.filter.radius", t.radius.unwrap_or(1.0), MAX_RADIUS as f64)?,
        }),
        Some(desc::FilterDesc::Gaussian(g)) => PixelFilter::separable(FilterKind::Gaussian {
            stddev: within("camera.filter.stddev", g.stddev.unwrap_or(0.5), MAX_RADIUS as f64 / 4.0)?,
        }),
    })
}

/// Validates every material and builds them in name order; returns the name → index map.
/// Image files for textures are read through `textures`, which keeps their bytes for the hash.
pub(super) fn materials(
    ctx: &Ctx,
    descs: &BTreeMap<String, MaterialDesc>,
    textures: &mut Textures,
) -> Result<(Vec<Material>, BTreeMap<String, u32>)> {
    let mut out = Vec::with_capacity(descs.len());
    let mut index = BTreeMap::new();
    for (name, d) in descs {
        let field = format!("materials.{}", key_string(name));
        validate_material(ctx, &field, d)?;
        index.insert(name.clone(), out.len() as u32);
        textures.material = out.len() as u32;
        // A mask is a property of the surface, not of the model: outermost (validation refuses
        // it anywhere else).
        let (d, field, opacity) = match d {
            // Every ray passes a null surface: a mask of opacity 0 (its model is never asked).
            MaterialDesc::Null(_) => (d, field, Some(crate::texture::Scalar::Constant(0.0))),
            MaterialDesc::Mask(m) => {
                let opacity = m.opacity.clone().unwrap_or(desc::ScalarDesc::Value(0.5));
                (
                    &*m.bsdf,
                    format!("{field}.bsdf"),
                    Some(textures.scalar(ctx, &format!("{field}.opacity"), &opacity, (1.0, "an opacity"))?),
                )
            }
            d => (d, field, None),
        };
        let bump = match d {
            MaterialDesc::BumpMap(m) => textures
                .height(ctx, &format!("{field}.height"), &m.height)?
                .map(|height| Bump {
                    height,
                    scale: m.scale.unwrap_or(1.0) as f32,
                }),
            _ => None,
        };
        let bsdf = make_bsdf(ctx, &field, d, textures)?;
        out.push(Material {
            name: name.clone(),
            bsdf,
            textures: std::mem::take(&mut textures.params),
            opacity,
            bump,
        });
    }
    Ok((out, index))
}

/// Why a `null` material is refused inside another: it is a surface property (rays pass it),
/// not a reflectance model.
const NULL_NESTED: &str =
    "expected a material other than null (a null surface only marks a medium's boundary: use it alone)";

pub(super) fn validate_material(ctx: &Ctx, field: &str, d: &MaterialDesc) -> Result<()> {
    let f = |key: &str| format!("{field}.{key}");
    let ior = |ior: f64| {
        if ior > 0.0 && (ior as f32).is_finite() {
            Ok(())
        } else {
            Err(ctx.err(
                &f("ior"),
                format!("expected a positive finite number, got {}", num(ior)),
            ))
        }
    };
    match d {
        // Checked while built, textures included (`make_bsdf`).
        MaterialDesc::Diffuse(_) | MaterialDesc::Null(_) => {}
        MaterialDesc::Mirror(m) => {
            ctx.unit_rgb(&f("reflectance"), m.reflectance)?;
        }
        MaterialDesc::Dielectric(m) => ior(m.ior)?,
        MaterialDesc::ThinDielectric(m) => {
            ior(m.ior)?;
            ctx.unit_rgb(&f("reflectance"), m.reflectance)?;
            ctx.unit_rgb(&f("transmittance"), m.transmittance)?;
        }
        MaterialDesc::Phong(m) => {
            ctx.unit_rgb(&f("diffuse"), m.diffuse)?;
            ctx.unit_rgb(&f("specular"), m.specular)?;
            ctx.energy(field, "diffuse + specular", m.diffuse, m.specular)?;
            if !(0.0..=MAX_PHONG_EXPONENT).contains(&m.exponent) {
                return Err(ctx.err(
                    &f("exponent"),
                    format!(
                        "expected a number in [0, {}], got {}",
                        num(MAX_PHONG_EXPONENT),
                        num(m.exponent)
                    ),
                ));
            }
        }
        MaterialDesc::Ward(m) => {
            ctx.unit_rgb(&f("diffuse"), m.diffuse)?;
            ctx.unit_rgb(&f("specular"), m.specular)?;
            ctx.energy(field, "diffuse + specular", m.diffuse, m.specular)?;
            for (key, a) in [("alpha_x", m.alpha_x), ("alpha_y", m.alpha_y)] {
                if !(a > 0.0 && a <= 1.0) {
                    return Err(ctx.err(&f(key), format!("expected a roughness in (0, 1], got {}", num(a))));
                }
            }
        }
        MaterialDesc::DiffuseTransmission(m) => {
            ctx.unit_rgb(&f("reflectance"), m.reflectance)?;
            ctx.unit_rgb(&f("transmittance"), m.transmittance)?;
            ctx.energy(field, "reflectance + transmittance", m.reflectance, m.transmittance)?;
        }
        // Checked field by field while they are built (`super::rough`).
        MaterialDesc::Conductor(_)
        | MaterialDesc::RoughConductor(_)
        | MaterialDesc::RoughDielectric(_)
        | MaterialDesc::RoughPlastic(_)
        | MaterialDesc::Pplastic(_)
        | MaterialDesc::Plastic(_)
        | MaterialDesc::Principled(_)
        | MaterialDesc::PrincipledThin(_) => {}
        MaterialDesc::OneSided(m) => {
            if matches!(
                *m.bsdf,
                MaterialDesc::Dielectric(_)
                    | MaterialDesc::ThinDielectric(_)
                    | MaterialDesc::RoughDielectric(_)
                    | MaterialDesc::DiffuseTransmission(_)
                    | MaterialDesc::Principled(_)
                    | MaterialDesc::PrincipledThin(_)
                    | MaterialDesc::OneSided(_)
                    | MaterialDesc::Mask(_)
                    | MaterialDesc::NormalMap(_)
                    | MaterialDesc::BumpMap(_)
                    | MaterialDesc::Null(_)
            ) {
                return Err(ctx.err(
                    &f("bsdf"),
                    "expected a reflecting material (a dielectric, a sheet or diffuse transmission has two sides by nature; a principled material has its own `two_sided`)",
                ));
            }
            validate_material(ctx, &f("bsdf"), &m.bsdf)?;
        }
        MaterialDesc::Blend(m) => {
            if m.bsdfs.len() != 2 {
                return Err(ctx.err(
                    &f("bsdfs"),
                    format!("expected exactly 2 materials, got {}", m.bsdfs.len()),
                ));
            }
            for (i, b) in m.bsdfs.iter().enumerate() {
                let field = format!("{field}.bsdfs[{i}]");
                if matches!(
                    b,
                    MaterialDesc::Mask(_) | MaterialDesc::NormalMap(_) | MaterialDesc::BumpMap(_)
                ) {
                    return Err(ctx.err(
                        &field,
                        "expected a material that is not a mask, a normal map or a bump map (they go around the blend)",
                    ));
                }
                if matches!(b, MaterialDesc::Null(_)) {
                    return Err(ctx.err(&field, NULL_NESTED));
                }
                validate_material(ctx, &field, b)?;
            }
        }
        MaterialDesc::Coated(m) => {
            if !matches!(
                *m.base,
                MaterialDesc::Diffuse(_) | MaterialDesc::Conductor(_) | MaterialDesc::RoughConductor(_)
            ) {
                return Err(ctx.err(&f("base"), "expected a diffuse, conductor or rough_conductor material"));
            }
            validate_material(ctx, &f("base"), &m.base)?;
        }
        MaterialDesc::Mask(m) => {
            if matches!(*m.bsdf, MaterialDesc::Mask(_)) {
                return Err(ctx.err(&f("bsdf"), "expected a material that is not itself a mask"));
            }
            if matches!(*m.bsdf, MaterialDesc::Null(_)) {
                return Err(ctx.err(&f("bsdf"), NULL_NESTED));
            }
            validate_material(ctx, &f("bsdf"), &m.bsdf)?;
        }
        MaterialDesc::NormalMap(desc::NormalMap { bsdf, .. }) | MaterialDesc::BumpMap(desc::BumpMap { bsdf, .. }) => {
            if matches!(
                **bsdf,
                MaterialDesc::Mask(_) | MaterialDesc::NormalMap(_) | MaterialDesc::BumpMap(_)
            ) {
                return Err(ctx.err(
                    &f("bsdf"),
                    "expected a material that is not a mask, a normal map or a bump map (a mask goes around them)",
                ));
            }
            if matches!(**bsdf, MaterialDesc::Null(_)) {
                return Err(ctx.err(&f("bsdf"), NULL_NESTED));
            }
            if let MaterialDesc::BumpMap(b) = d
                && !b.scale.unwrap_or(1.0).is_finite()
            {
                return Err(ctx.err(&f("scale"), "expected a finite number"));
            }
            validate_material(ctx, &f("bsdf"), bsdf)?;
        }
    }
    Ok(())
}

/// A blend of two materials; only its weight may be a texture (a colour texture inside would
/// have no parameter of the blend to drive).
fn blend(ctx: &Ctx, field: &str, m: &desc::Blend, textures: &mut Textures) -> Result<Bsdf> {
    let before = textures.params.len();
    let mut bsdfs = Vec::with_capacity(2);
    for (i, b) in m.bsdfs.iter().enumerate() {
        let field = format!("{field}.bsdfs[{i}]");
        bsdfs.push(make_bsdf(ctx, &field, b, textures)?);
        if textures.params.len() != before {
            return Err(ctx.err(
                &field,
                "expected a material without textures (only the blend's weight may be one)",
            ));
        }
    }
    let weight = m.weight.clone().unwrap_or(desc::ScalarDesc::Value(0.5));
    let weight = textures.number_param(
        ctx,
        &format!("{field}.weight"),
        &weight,
        (1.0, "a weight"),
        ColorParam::Weight,
    )?;
    let [b0, b1]: [Bsdf; 2] = bsdfs.try_into().expect("validated: two materials");
    Ok(Bsdf::Blend(Box::new(Blend {
        weight,
        bsdfs: [b0, b1],
    })))
}

/// Turns a validated material description into its reflectance model: the one place that
/// knows both the file's material types and the [`Bsdf`] variants.
pub(super) fn make_bsdf(ctx: &Ctx, field: &str, d: &MaterialDesc, textures: &mut Textures) -> Result<Bsdf> {
    let bsdf = match d {
        MaterialDesc::Diffuse(m) => Bsdf::Lambertian(Lambertian {
            reflectance: textures.unit_color(
                ctx,
                &format!("{field}.reflectance"),
                &m.reflectance,
                ColorParam::Reflectance,
            )?,
        }),
        MaterialDesc::Mirror(m) => Bsdf::Mirror(Mirror {
            reflectance: rgb(m.reflectance),
        }),
        MaterialDesc::Dielectric(m) => Bsdf::Dielectric(Dielectric::clear(m.ior as f32)),
        MaterialDesc::ThinDielectric(m) => Bsdf::ThinDielectric(ThinDielectric {
            ior: m.ior as f32,
            reflectance: rgb(m.reflectance),
            transmittance: rgb(m.transmittance),
        }),
        MaterialDesc::Phong(m) => Bsdf::Phong(Phong {
            diffuse: rgb(m.diffuse),
            specular: rgb(m.specular),
            exponent: m.exponent as f32,
        }),
        MaterialDesc::Ward(m) => Bsdf::Ward(Ward {
            diffuse: rgb(m.diffuse),
            specular: rgb(m.specular),
            alpha_x: m.alpha_x as f32,
            alpha_y: m.alpha_y as f32,
        }),
        MaterialDesc::DiffuseTransmission(m) => Bsdf::DiffuseTransmission(DiffuseTransmission {
            reflectance: rgb(m.reflectance),
            transmittance: rgb(m.transmittance),
        }),
        MaterialDesc::Conductor(m) => rough::conductor(ctx, field, m)?,
        MaterialDesc::RoughConductor(m) => rough::rough_conductor(ctx, field, m, textures)?,
        MaterialDesc::RoughDielectric(m) => rough::rough_dielectric(ctx, field, m, textures)?,
        MaterialDesc::RoughPlastic(m) => rough::rough_plastic(ctx, field, m, textures)?,
        MaterialDesc::Pplastic(m) => rough::pplastic(ctx, field, m, textures)?,
        MaterialDesc::Plastic(m) => rough::plastic(ctx, field, m, textures)?,
        MaterialDesc::Principled(m) => principled::principled(ctx, field, m, textures)?,
        MaterialDesc::PrincipledThin(m) => principled::principled_thin(ctx, field, m, textures)?,
        MaterialDesc::OneSided(m) => {
            Bsdf::OneSided(Box::new(make_bsdf(ctx, &format!("{field}.bsdf"), &m.bsdf, textures)?))
        }
        // `materials` takes the opacity off the outermost material; validation refuses a mask
        // anywhere else.
        MaterialDesc::Mask(m) => make_bsdf(ctx, &format!("{field}.bsdf"), &m.bsdf, textures)?,
        // Never evaluated: every ray passes the surface (`materials` gives it opacity 0).
        MaterialDesc::Null(_) => Bsdf::Lambertian(Lambertian {
            reflectance: glam::Vec3::ZERO,
        }),
        MaterialDesc::NormalMap(m) => {
            let c = textures.normals(ctx, &format!("{field}.normals"), &m.normals)?;
            let nested = make_bsdf(ctx, &format!("{field}.bsdf"), &m.bsdf, textures)?;
            Bsdf::NormalMapped(Box::new(NormalMapped::new(nested, c)))
        }
        // `materials` takes the height off; the normal is set at every hit (`Scene::bsdf_of`).
        MaterialDesc::BumpMap(m) => {
            let nested = make_bsdf(ctx, &format!("{field}.bsdf"), &m.bsdf, textures)?;
            Bsdf::NormalMapped(Box::new(NormalMapped::flat(nested)))
        }
        MaterialDesc::Blend(m) => blend(ctx, field, m, textures)?,
        MaterialDesc::Coated(m) => rough::coated(ctx, field, m, textures, |textures| {
            make_bsdf(ctx, &format!("{field}.base"), &m.base, textures)
        })?,
    };
    // The description was validated field by field; this is the models' own check, kept as a
    // second line of defence (f64 → f32 rounding could tip a sum over 1).
    bsdf.validate()
        .map_err(|e| e.context(format!("{}: {field}", ctx.file)))?;
    Ok(bsdf)
}
