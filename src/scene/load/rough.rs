//! The metals and microfacet materials of Mitsuba 3 (`conductor`, `rough_conductor`,
//! `rough_dielectric`, `rough_plastic`): their fields checked one by one and the models built.

use super::textures::Textures;
use super::*;
use crate::bsdf::{
    Bsdf, Coat, Coated, ColorParam, Conductor, ConductorIor, Dielectric, Microfacet, MicrofacetType, Plastic, Pplastic,
    RoughConductor, RoughDielectric, RoughPlastic, named_conductor_list,
};
use crate::error::Result;
use crate::scene::desc::{self, Roughness, Triple};
use glam::Vec3;

/// The largest roughness accepted (flatter than diffuse beyond).
const MAX_ALPHA: f64 = 10.0;

/// Mitsuba's default for rough plastic: polypropylene (1.49) in air.
pub(crate) const PLASTIC_DEFAULT_IOR: f64 = 1.49;

/// A microfacet distribution from Mitsuba's fields: `distribution`, `alpha` or both
/// `alpha_u`/`alpha_v`, `sample_visible`. Roughness textures are remembered in `textures`
/// (the model holds their largest values) where `textured`; elsewhere (rough plastic, whose
/// coating is tabulated for one roughness, as Mitsuba's) they are refused.
pub(super) fn microfacet(
    ctx: &Ctx,
    field: &str,
    r: &Roughness,
    (textures, textured): (&mut Textures, bool),
) -> Result<Microfacet> {
    let f = |key: &str| format!("{field}.{key}");
    let kind = match r.distribution.as_deref() {
        None => MicrofacetType::Beckmann,
        Some(name) => MicrofacetType::from_name(name).ok_or_else(|| {
            ctx.err(
                &f("distribution"),
                format!("expected \"beckmann\" or \"ggx\", got {name:?}"),
            )
        })?,
    };
    let default = desc::ScalarDesc::Value(0.1);
    let remap = r.remap_roughness.unwrap_or(false);
    let [alpha, alpha_u, alpha_v] = if remap {
        [
            ColorParam::AlphaRemapped,
            ColorParam::AlphaURemapped,
            ColorParam::AlphaVRemapped,
        ]
    } else {
        [ColorParam::Alpha, ColorParam::AlphaU, ColorParam::AlphaV]
    };
    let given: Vec<(ColorParam, &str, &desc::ScalarDesc)> = match (&r.alpha, &r.alpha_u, &r.alpha_v) {
        (a, None, None) => vec![(alpha, "alpha", a.as_ref().unwrap_or(&default))],
        (None, Some(u), Some(v)) => vec![(alpha_u, "alpha_u", u), (alpha_v, "alpha_v", v)],
        (Some(_), _, _) => {
            return Err(ctx.err(&f("alpha"), "give either alpha or both alpha_u and alpha_v, not both"));
        }
        (None, Some(_), None) | (None, None, Some(_)) => {
            return Err(ctx.err(field, "alpha_u and alpha_v must be given together"));
        }
    };
    let mut alphas = Vec::with_capacity(2);
    for (param, key, a) in given {
        if matches!(a, desc::ScalarDesc::Texture(_)) && !textured {
            return Err(ctx.err(
                &f(key),
                "expected a number (this model's roughness cannot be a texture)",
            ));
        }
        let value = textures.number_param(ctx, &f(key), a, (MAX_ALPHA, "a roughness"), param)?;
        // pbrt-v4's remapping, α = √r, for numbers as for textures (the model holds the
        // largest α, the texture's largest r remapped).
        alphas.push(if remap { value.sqrt() } else { value });
    }
    let (alpha_u, alpha_v) = (alphas[0], *alphas.last().unwrap());
    let height_correlated = match r.masking.as_deref() {
        None | Some("separable") => false,
        Some("height_correlated") => true,
        Some(other) => {
            return Err(ctx.err(
                &f("masking"),
                format!("expected \"separable\" or \"height_correlated\", got {other:?}"),
            ));
        }
    };
    Ok(Microfacet {
        height_correlated,
        ..Microfacet::new(kind, alpha_u, alpha_v, r.sample_visible.unwrap_or(true))
    })
}

/// The complex index of refraction: a named conductor, or `eta` and `k` (defaults 0 and 1, a
/// perfect mirror, as Mitsuba's `material = "none"`).
pub(super) fn conductor_ior(ctx: &Ctx, field: &str, c: &desc::Conductor) -> Result<ConductorIor> {
    let f = |key: &str| format!("{field}.{key}");
    let specular_reflectance = match c.specular_reflectance {
        Some(v) => rgb(ctx.unit_rgb(&f("specular_reflectance"), v)?),
        None => Vec3::ONE,
    };
    let non_negative = |key: &str, v: Triple| -> Result<Vec3> {
        if v.iter().all(|x| x.is_finite() && *x >= 0.0 && *x <= 1e4) {
            Ok(rgb(v))
        } else {
            Err(ctx.err(
                &f(key),
                format!("expected each channel finite in [0, 1e4], got {}", triple(v)),
            ))
        }
    };
    let (eta, k) = match c.material.as_deref() {
        Some(name) if name != "none" => {
            if c.eta.is_some() || c.k.is_some() {
                return Err(ctx.err(&f("material"), "give either a named material or eta and k, not both"));
            }
            let named = ConductorIor::named(name).ok_or_else(|| {
                ctx.err(
                    &f("material"),
                    format!(
                        "unknown conductor {name:?}; expected \"none\" or one of {}",
                        named_conductor_list()
                    ),
                )
            })?;
            (named.eta, named.k)
        }
        _ => (
            c.eta.map_or(Ok(Vec3::ZERO), |v| non_negative("eta", v))?,
            c.k.map_or(Ok(Vec3::ONE), |v| non_negative("k", v))?,
        ),
    };
    Ok(ConductorIor {
        eta,
        k,
        specular_reflectance,
    })
}

/// A relative index of refraction that makes a visible interface: positive, finite, ≠ 1.
fn interface_ior(ctx: &Ctx, field: &str, ior: f64) -> Result<f32> {
    if ior > 0.0 && ior <= 100.0 && ior != 1.0 {
        Ok(ior as f32)
    } else {
        Err(ctx.err(
            field,
            format!(
                "expected a relative index of refraction in (0, 100], not 1, got {}",
                num(ior)
            ),
        ))
    }
}

fn unit_or_one(ctx: &Ctx, field: &str, v: Option<Triple>) -> Result<Vec3> {
    v.map_or(Ok(Vec3::ONE), |v| Ok(rgb(ctx.unit_rgb(field, v)?)))
}

/// A smooth conductor.
pub(super) fn conductor(ctx: &Ctx, field: &str, c: &desc::Conductor) -> Result<Bsdf> {
    Ok(Bsdf::Conductor(Conductor {
        ior: conductor_ior(ctx, field, c)?,
    }))
}

pub(super) fn rough_conductor(
    ctx: &Ctx,
    field: &str,
    c: &desc::RoughConductor,
    textures: &mut Textures,
) -> Result<Bsdf> {
    Ok(Bsdf::RoughConductor(RoughConductor {
        ior: conductor_ior(ctx, field, &c.conductor())?,
        distribution: microfacet(ctx, field, &c.roughness(), (textures, true))?,
    }))
}

pub(super) fn rough_dielectric(
    ctx: &Ctx,
    field: &str,
    m: &desc::RoughDielectric,
    textures: &mut Textures,
) -> Result<Bsdf> {
    let f = |key: &str| format!("{field}.{key}");
    Ok(Bsdf::RoughDielectric(RoughDielectric {
        ior: interface_ior(ctx, &f("ior"), m.ior)?,
        distribution: microfacet(ctx, field, &m.roughness(), (textures, true))?,
        specular_reflectance: unit_or_one(ctx, &f("specular_reflectance"), m.specular_reflectance)?,
        specular_transmittance: unit_or_one(ctx, &f("specular_transmittance"), m.specular_transmittance)?,
    }))
}

pub(super) fn rough_plastic(ctx: &Ctx, field: &str, m: &desc::RoughPlastic, textures: &mut Textures) -> Result<Bsdf> {
    let f = |key: &str| format!("{field}.{key}");
    if m.masking.as_deref().is_some_and(|k| k != "separable") {
        return Err(ctx.err(
            &f("masking"),
            "expected \"separable\" (rough plastic's coating is tabulated for Mitsuba's separable masking)",
        ));
    }
    let distribution = microfacet(ctx, field, &m.roughness(), (textures, false))?;
    if !distribution.is_isotropic() {
        return Err(ctx.err(
            field,
            "rough_plastic is isotropic (as in Mitsuba): give alpha, not different alpha_u and alpha_v",
        ));
    }
    let diffuse = match &m.diffuse_reflectance {
        Some(c) => textures.unit_color(ctx, &f("diffuse_reflectance"), c, ColorParam::DiffuseReflectance)?,
        None => Vec3::splat(0.5),
    };
    Ok(Bsdf::RoughPlastic(RoughPlastic::new(
        diffuse,
        unit_or_one(ctx, &f("specular_reflectance"), m.specular_reflectance)?,
        interface_ior(ctx, &f("ior"), m.ior.unwrap_or(PLASTIC_DEFAULT_IOR))?,
        distribution,
        m.nonlinear.unwrap_or(false),
    )))
}

/// Mitsuba's `pplastic`: its sampling weight from the diffuse reflectance's mean over the
/// surface (a texture's mean texel), as Mitsuba's.
pub(super) fn pplastic(ctx: &Ctx, field: &str, m: &desc::Pplastic, textures: &mut Textures) -> Result<Bsdf> {
    let f = |key: &str| format!("{field}.{key}");
    let distribution = microfacet(ctx, field, &m.roughness(), (textures, false))?;
    let (diffuse, mean) = match &m.diffuse_reflectance {
        Some(c) => {
            let before = textures.params.len();
            let hi = textures.unit_color(ctx, &f("diffuse_reflectance"), c, ColorParam::DiffuseReflectance)?;
            let mean = match textures.params.get(before) {
                Some((_, texture)) => texture.mean(),
                None => hi,
            };
            (hi, mean)
        }
        None => (Vec3::splat(0.5), Vec3::splat(0.5)),
    };
    Ok(Bsdf::Pplastic(Pplastic::new(
        diffuse,
        unit_or_one(ctx, &f("specular_reflectance"), m.specular_reflectance)?,
        interface_ior(ctx, &f("ior"), m.ior.unwrap_or(PLASTIC_DEFAULT_IOR))?,
        distribution,
        mean.element_sum() / 3.0,
    )))
}

/// A smooth plastic: rough plastic's fields without the roughness.
pub(super) fn plastic(ctx: &Ctx, field: &str, m: &desc::Plastic, textures: &mut Textures) -> Result<Bsdf> {
    let f = |key: &str| format!("{field}.{key}");
    let diffuse = match &m.diffuse_reflectance {
        Some(c) => textures.unit_color(ctx, &f("diffuse_reflectance"), c, ColorParam::DiffuseReflectance)?,
        None => Vec3::splat(0.5),
    };
    Ok(Bsdf::Plastic(Plastic {
        diffuse_reflectance: diffuse,
        specular_reflectance: unit_or_one(ctx, &f("specular_reflectance"), m.specular_reflectance)?,
        ior: interface_ior(ctx, &f("ior"), m.ior.unwrap_or(PLASTIC_DEFAULT_IOR))?,
        nonlinear: m.nonlinear.unwrap_or(false),
    }))
}

/// A layered model: the coating (smooth unless a roughness is given), the base built by
/// `make_base` (only its colours may be textures) and the slab.
pub(super) fn coated(
    ctx: &Ctx,
    field: &str,
    m: &desc::Coated,
    textures: &mut Textures,
    make_base: impl FnOnce(&mut Textures) -> Result<Bsdf>,
) -> Result<Bsdf> {
    let f = |key: &str| format!("{field}.{key}");
    let ior = interface_ior(ctx, &f("ior"), m.ior.unwrap_or(1.5))?;
    let rough = m.alpha.is_some() || m.alpha_u.is_some() || m.alpha_v.is_some();
    let coat = if rough {
        let roughness = Roughness {
            distribution: m.distribution.clone().or(Some("ggx".into())),
            ..m.roughness()
        };
        Coat::Rough(RoughDielectric {
            ior,
            distribution: microfacet(ctx, field, &roughness, (textures, false))?,
            specular_reflectance: Vec3::ONE,
            specular_transmittance: Vec3::ONE,
        })
    } else if m.distribution.is_some() || m.sample_visible.is_some() {
        return Err(ctx.err(
            field,
            "a smooth coating takes no distribution: give alpha for a rough one",
        ));
    } else {
        Coat::Smooth(Dielectric::clear(ior))
    };
    let before = textures.params.len();
    let base = make_base(textures)?;
    if textures.params[before..].iter().any(|(param, _)| param.is_number()) {
        return Err(ctx.err(
            &f("base"),
            "expected numbers for the base's roughness (only its colours may be textures)",
        ));
    }
    let thickness = m.thickness.unwrap_or(0.01);
    if !(thickness.is_finite() && (0.0..=1e4).contains(&thickness)) {
        return Err(ctx.err(
            &f("thickness"),
            format!("expected a number in [0, 1e4], got {}", num(thickness)),
        ));
    }
    let g = m.g.unwrap_or(0.0);
    if !(g.is_finite() && g.abs() < 1.0) {
        return Err(ctx.err(&f("g"), format!("expected a number in (−1, 1), got {}", num(g))));
    }
    let max_depth = m.max_depth.unwrap_or(10);
    if !(1..=100).contains(&max_depth) {
        return Err(ctx.err(
            &f("max_depth"),
            format!("expected an integer in [1, 100], got {max_depth}"),
        ));
    }
    let samples = m.samples.unwrap_or(1);
    if !(1..=64).contains(&samples) {
        return Err(ctx.err(&f("samples"), format!("expected an integer in [1, 64], got {samples}")));
    }
    let pbrt_weights = match m.weights.as_deref() {
        None | Some("exact") => false,
        Some("pbrt") => true,
        Some(other) => return Err(ctx.err(&f("weights"), format!("expected \"exact\" or \"pbrt\", got {other:?}"))),
    };
    Ok(Bsdf::Coated(Box::new(Coated {
        coat,
        base,
        thickness: thickness as f32,
        albedo: m
            .albedo
            .map_or(Ok(Vec3::ZERO), |a| Ok(rgb(ctx.unit_rgb(&f("albedo"), a)?)))?,
        g: g as f32,
        max_depth,
        n_samples: samples,
        pbrt_weights,
    })))
}
