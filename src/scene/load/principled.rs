//! Mitsuba 3's principled materials (`principled`, `principled_thin`): their fields checked one
//! by one, Mitsuba's defaults and adjustments applied, and the models built.

use super::textures::Textures;
use super::*;
use crate::bsdf::{Bsdf, ColorParam, DisneyParams, Principled, PrincipledParam, PrincipledThin};
use crate::scene::desc::{Color, Fixed, ScalarDesc};

/// The largest sampling rate accepted (a lobe drawn 10⁴ times as often as its weight says).
const MAX_SAMPLING_RATE: f64 = 1e4;

/// The weights both models read, with their defaults: a number in [0, `max`] or a texture
/// remembered for its parameter.
struct Weights<'c, 't> {
    ctx: &'c Ctx,
    field: &'c str,
    textures: &'c mut Textures<'t>,
}

impl Weights<'_, '_> {
    /// A weight in [0, `max`] (default `default`); a texture is remembered for `param` and the
    /// model holds its largest value, as every textured parameter does
    /// ([`crate::scene::Material::bsdf`]).
    fn number(
        &mut self,
        key: &str,
        s: Option<&ScalarDesc>,
        default: f64,
        max: f64,
        param: PrincipledParam,
    ) -> Result<f32> {
        Ok(self.number_range(key, s, (default, max), param)?.1)
    }

    /// A weight that takes the diffuse lobe away (metallic, spec_trans): the model holds a
    /// texture's least value, so that its class is the one of its most diffuse point.
    fn number_least(&mut self, key: &str, s: Option<&ScalarDesc>, param: PrincipledParam) -> Result<f32> {
        Ok(self.number_range(key, s, (0.0, 1.0), param)?.0)
    }

    /// The least and largest values of a weight, its texture remembered for `param`.
    fn number_range(
        &mut self,
        key: &str,
        s: Option<&ScalarDesc>,
        (default, max): (f64, f64),
        param: PrincipledParam,
    ) -> Result<(f32, f32)> {
        let default = ScalarDesc::Value(default);
        let what = if max == 1.0 {
            "a weight"
        } else {
            "a weight of Burley's range"
        };
        self.textures.number_param_range(
            self.ctx,
            &format!("{}.{key}", self.field),
            s.unwrap_or(&default),
            (max, what),
            ColorParam::Principled(param),
        )
    }

    fn base_color(&mut self, c: Option<&Color>) -> Result<glam::Vec3> {
        let default = Color::Rgb(Fixed([0.5; 3]));
        self.textures.unit_color(
            self.ctx,
            &format!("{}.base_color", self.field),
            c.unwrap_or(&default),
            ColorParam::Principled(PrincipledParam::BaseColor),
        )
    }

    /// The parameters both models share: the base colour, then roughness, anisotropic,
    /// spec_trans, spec_tint, sheen, sheen_tint and flatness, in that order.
    fn shared(&mut self, base_color: Option<&Color>, w: [&Option<ScalarDesc>; 7]) -> Result<DisneyParams> {
        use PrincipledParam::*;
        let [
            roughness,
            anisotropic,
            spec_trans,
            spec_tint,
            sheen,
            sheen_tint,
            flatness,
        ] = w.map(Option::as_ref);
        Ok(DisneyParams {
            base_color: self.base_color(base_color)?,
            roughness: self.number("roughness", roughness, 0.5, 1.0, Roughness)?,
            anisotropic: self.number("anisotropic", anisotropic, 0.0, 1.0, Anisotropic)?,
            spec_trans: self.number_least("spec_trans", spec_trans, SpecTrans)?,
            spec_tint: self.number("spec_tint", spec_tint, 0.0, 1.0, SpecTint)?,
            sheen: self.number("sheen", sheen, 0.0, 1.0, Sheen)?,
            sheen_tint: self.number("sheen_tint", sheen_tint, 0.0, 1.0, SheenTint)?,
            flatness: self.number("flatness", flatness, 0.0, 1.0, Flatness)?,
        })
    }

    /// A sampling rate: finite, in [0, 10⁴], default 1.
    fn rate(&self, key: &str, r: Option<f64>) -> Result<f32> {
        match r {
            None => Ok(1.0),
            Some(r) if (0.0..=MAX_SAMPLING_RATE).contains(&r) => Ok(r as f32),
            Some(r) => Err(self.ctx.err(
                &format!("{}.{key}", self.field),
                format!(
                    "expected a sampling rate in [0, {}], got {}",
                    num(MAX_SAMPLING_RATE),
                    num(r)
                ),
            )),
        }
    }

    /// A relative index of refraction in (0, 100].
    fn eta(&self, key: &str, eta: f64) -> Result<f32> {
        if eta > 0.0 && eta <= 100.0 {
            Ok(eta as f32)
        } else {
            Err(self.ctx.err(
                &format!("{}.{key}", self.field),
                format!("expected a relative index of refraction in (0, 100], got {}", num(eta)),
            ))
        }
    }

    /// Rates that cannot all be zero (nothing would be sampled).
    fn some_rate_positive(&self, rates: &[f32]) -> Result<()> {
        if rates.iter().any(|r| *r > 0.0) {
            Ok(())
        } else {
            Err(self.ctx.err(self.field, "expected some sampling rate above 0"))
        }
    }
}

/// Whether a weight is given as a texture or a positive number: Mitsuba's `get_flag`, which
/// decides where it nudges η and `specular` off values that make transmission implausible.
fn given(s: Option<&ScalarDesc>) -> bool {
    match s {
        Some(ScalarDesc::Value(v)) => *v != 0.0,
        Some(ScalarDesc::Texture(_)) => true,
        None => false,
    }
}

/// Mitsuba's `principled`: η from `eta`, or from `specular` (default 0.5), never both; with
/// transmission, η = 1 becomes 1.001 and specular = 0 becomes 10⁻³, as Mitsuba does.
pub(super) fn principled(ctx: &Ctx, field: &str, m: &desc::Principled, textures: &mut Textures) -> Result<Bsdf> {
    use PrincipledParam::*;
    let mut w = Weights { ctx, field, textures };
    let transmits = given(m.spec_trans.as_ref());
    let eta = match (m.eta, m.specular) {
        (Some(_), Some(_)) => {
            return Err(ctx.err(
                field,
                "give either eta or specular, not both (Mitsuba refuses both too)",
            ));
        }
        (Some(eta), None) => {
            let eta = w.eta("eta", eta)?;
            if transmits && eta == 1.0 { 1.001 } else { eta }
        }
        (None, specular) => {
            let specular = specular.unwrap_or(0.5);
            if !(0.0..=1.0).contains(&specular) {
                return Err(ctx.err(
                    &format!("{field}.specular"),
                    format!("expected a number in [0, 1], got {}", num(specular)),
                ));
            }
            let specular = if transmits && specular == 0.0 {
                1e-3
            } else {
                specular as f32
            };
            Principled::eta_of_specular(specular)
        }
    };
    let two_sided = m.two_sided.unwrap_or(false);
    if two_sided && transmits {
        return Err(ctx.err(
            &format!("{field}.two_sided"),
            "a principled material with spec_trans cannot be two-sided (Mitsuba's twosided refuses transmission too)",
        ));
    }
    let rates = [
        w.rate("diffuse_reflectance_sampling_rate", m.diffuse_reflectance_sampling_rate)?,
        w.rate("main_specular_sampling_rate", m.main_specular_sampling_rate)?,
        w.rate("clearcoat_sampling_rate", m.clearcoat_sampling_rate)?,
    ];
    w.some_rate_positive(&rates)?;
    let shared = w.shared(
        m.base_color.as_ref(),
        [
            &m.roughness,
            &m.anisotropic,
            &m.spec_trans,
            &m.spec_tint,
            &m.sheen,
            &m.sheen_tint,
            &m.flatness,
        ],
    )?;
    Ok(Bsdf::Principled(Principled {
        shared,
        metallic: w.number_least("metallic", m.metallic.as_ref(), Metallic)?,
        eta,
        clearcoat: w.number("clearcoat", m.clearcoat.as_ref(), 0.0, 1.0, Clearcoat)?,
        clearcoat_gloss: w.number("clearcoat_gloss", m.clearcoat_gloss.as_ref(), 0.0, 1.0, ClearcoatGloss)?,
        rates,
        two_sided,
    }))
}

/// Mitsuba's `principledthin`.
pub(super) fn principled_thin(
    ctx: &Ctx,
    field: &str,
    m: &desc::PrincipledThin,
    textures: &mut Textures,
) -> Result<Bsdf> {
    let mut w = Weights { ctx, field, textures };
    let rates = [
        w.rate(
            "specular_reflectance_sampling_rate",
            m.specular_reflectance_sampling_rate,
        )?,
        w.rate(
            "specular_transmittance_sampling_rate",
            m.specular_transmittance_sampling_rate,
        )?,
        w.rate("diffuse_reflectance_sampling_rate", m.diffuse_reflectance_sampling_rate)?,
        w.rate(
            "diffuse_transmittance_sampling_rate",
            m.diffuse_transmittance_sampling_rate,
        )?,
    ];
    w.some_rate_positive(&rates)?;
    let shared = w.shared(
        m.base_color.as_ref(),
        [
            &m.roughness,
            &m.anisotropic,
            &m.spec_trans,
            &m.spec_tint,
            &m.sheen,
            &m.sheen_tint,
            &m.flatness,
        ],
    )?;
    Ok(Bsdf::PrincipledThin(PrincipledThin {
        shared,
        diff_trans: w.number(
            "diff_trans",
            m.diff_trans.as_ref(),
            0.0,
            2.0,
            PrincipledParam::DiffTrans,
        )?,
        eta: w.eta("eta", m.eta.unwrap_or(1.5))?,
        rates,
    }))
}
