//! `<bsdf>` elements mapped to our materials, named IORs included; `twosided` unwrapped.

use super::*;
use crate::error::Result;
use crate::scene::desc::{self, Color, Fixed, MaterialDesc, Roughness};
use roxmltree::Node;

/// What a normal or bump map cannot wrap: a mask (it goes around the map) or another map.
const SURFACE_WRAPPERS: &[&str] = &["mask", "normalmap", "bumpmap"];
const SURFACE_WRAPPERS_HINT: &str = " (a mask goes outside)";

impl<'a, 'i> Reader<'a, 'i> {
    /// A BSDF element as one of our materials.
    pub(super) fn bsdf(&mut self, n: Node<'a, 'i>) -> Result<MaterialDesc> {
        let kind = self.required(n, "type")?;
        if kind == "mask" {
            return self.mask(n, Self::bsdf);
        }
        if kind == "normalmap" {
            return self.normal_map(n, Self::bsdf);
        }
        if kind == "bumpmap" {
            return self.bump_map(n, Self::bsdf);
        }
        if kind == "blendbsdf" {
            // Each model keeps its own sidedness (a blended dielectric stays two-sided).
            return self.blend(n, Self::bsdf);
        }
        if kind == "null" {
            // Rays pass it unchanged: a medium's boundary (our `null` material).
            let o = self.obj(n)?;
            if let Some(&c) = o.children.first() {
                return Err(self.err(c, "unexpected element in a null BSDF"));
            }
            self.finish(&o)?;
            return Ok(MaterialDesc::Null(desc::Null {}));
        }
        if kind == "twosided" {
            let o = self.obj(n)?;
            self.finish(&o)?;
            let inner: Vec<Node> = o.children.iter().copied().filter(|c| c.has_tag_name("bsdf")).collect();
            if let Some(&c) = o.children.iter().find(|c| !c.has_tag_name("bsdf")) {
                return Err(self.err(c, "unexpected element in a twosided BSDF"));
            }
            let [inner] = inner[..] else {
                return Err(self.err(
                    n,
                    "expected exactly one nested <bsdf> (a different back side is not supported)",
                ));
            };
            // Opacity is the same from both sides: twosided(mask(b)) is mask(twosided(b)).
            match self.required(inner, "type")?.as_str() {
                "mask" => return self.mask(inner, Self::one_bsdf),
                "blendbsdf" => return self.blend(inner, Self::one_bsdf),
                _ => {}
            }
            let m = self.one_bsdf(inner)?;
            match &m {
                MaterialDesc::Dielectric(_) | MaterialDesc::ThinDielectric(_) | MaterialDesc::RoughDielectric(_) => {
                    return Err(self.err(inner, "a dielectric cannot be two-sided (Mitsuba refuses it too)"));
                }
                MaterialDesc::PrincipledThin(_) => {
                    return Err(self.err(
                        inner,
                        "a principledthin transmits, so it cannot be two-sided (Mitsuba refuses it too)",
                    ));
                }
                MaterialDesc::Principled(p) if p.spec_trans.is_some() => {
                    return Err(self.err(
                        inner,
                        "a principled BSDF with spec_trans transmits, so it cannot be two-sided (Mitsuba refuses it too)",
                    ));
                }
                _ => {}
            }
            return Ok(m);
        }
        let m = self.one_bsdf(n)?;
        // Without `twosided`, Mitsuba's reflecting BSDFs are black from behind: so is ours.
        // Dielectrics and the thin principled sheet have two sides by nature; the principled
        // model has its own back side.
        Ok(match m {
            MaterialDesc::Dielectric(_)
            | MaterialDesc::ThinDielectric(_)
            | MaterialDesc::RoughDielectric(_)
            | MaterialDesc::PrincipledThin(_) => m,
            MaterialDesc::Principled(p) => MaterialDesc::Principled(desc::Principled { two_sided: None, ..p }),
            m => MaterialDesc::OneSided(desc::OneSided { bsdf: Box::new(m) }),
        })
    }

    pub(super) fn one_bsdf(&mut self, n: Node<'a, 'i>) -> Result<MaterialDesc> {
        let kind = self.required(n, "type")?;
        if kind == "blendbsdf" {
            return self.blend(n, Self::one_bsdf);
        }
        if kind == "normalmap" {
            return self.normal_map(n, Self::one_bsdf);
        }
        if kind == "bumpmap" {
            return self.bump_map(n, Self::one_bsdf);
        }
        let mut o = self.obj(n)?;
        let m = match kind.as_str() {
            "diffuse" => MaterialDesc::Diffuse(desc::Diffuse {
                reflectance: self
                    .texture_colour(&mut o, "reflectance")?
                    .unwrap_or(Color::Rgb(Fixed([0.5; 3]))),
            }),
            "conductor" | "roughconductor" => {
                let c = self.conductor(&mut o)?;
                if kind == "roughconductor" {
                    let r = self.roughness(&mut o)?;
                    MaterialDesc::RoughConductor(desc::RoughConductor {
                        material: c.material,
                        eta: c.eta,
                        k: c.k,
                        specular_reflectance: c.specular_reflectance,
                        distribution: r.distribution,
                        alpha: r.alpha,
                        alpha_u: r.alpha_u,
                        alpha_v: r.alpha_v,
                        sample_visible: r.sample_visible,
                        masking: None,
                        remap_roughness: None,
                    })
                } else if c.material.is_none() && c.eta.is_none() && c.k.is_none() {
                    // Mitsuba's default conductor is a perfect mirror: ours, exactly.
                    MaterialDesc::Mirror(desc::Mirror {
                        reflectance: c.specular_reflectance.unwrap_or(Fixed([1.0; 3])),
                    })
                } else {
                    MaterialDesc::Conductor(c)
                }
            }
            "roughdielectric" => {
                let int_ior = self.ior(&mut o, "int_ior", 1.5046)?;
                let ext_ior = self.ior(&mut o, "ext_ior", 1.000277)?;
                let r = self.roughness(&mut o)?;
                MaterialDesc::RoughDielectric(desc::RoughDielectric {
                    ior: int_ior / ext_ior,
                    specular_reflectance: self.colour(&mut o, "specular_reflectance")?,
                    specular_transmittance: self.colour(&mut o, "specular_transmittance")?,
                    distribution: r.distribution,
                    alpha: r.alpha,
                    alpha_u: r.alpha_u,
                    alpha_v: r.alpha_v,
                    sample_visible: r.sample_visible,
                    masking: None,
                    remap_roughness: None,
                })
            }
            "roughplastic" => {
                let ior = self.plastic_ior(&mut o)?;
                let r = self.roughness(&mut o)?;
                MaterialDesc::RoughPlastic(desc::RoughPlastic {
                    diffuse_reflectance: self.texture_colour(&mut o, "diffuse_reflectance")?,
                    specular_reflectance: self.colour(&mut o, "specular_reflectance")?,
                    ior: Some(ior),
                    nonlinear: self.boolean(&mut o, "nonlinear")?,
                    distribution: r.distribution,
                    alpha: r.alpha,
                    alpha_u: r.alpha_u,
                    alpha_v: r.alpha_v,
                    sample_visible: r.sample_visible,
                    masking: None,
                    remap_roughness: None,
                })
            }
            "pplastic" => {
                let ior = self.plastic_ior(&mut o)?;
                let r = self.roughness(&mut o)?;
                MaterialDesc::Pplastic(desc::Pplastic {
                    diffuse_reflectance: self.texture_colour(&mut o, "diffuse_reflectance")?,
                    specular_reflectance: self.colour(&mut o, "specular_reflectance")?,
                    ior: Some(ior),
                    distribution: r.distribution,
                    alpha: r.alpha,
                    alpha_u: r.alpha_u,
                    alpha_v: r.alpha_v,
                    sample_visible: r.sample_visible,
                    masking: None,
                    remap_roughness: None,
                })
            }
            "plastic" => {
                let ior = self.plastic_ior(&mut o)?;
                MaterialDesc::Plastic(desc::Plastic {
                    diffuse_reflectance: self.texture_colour(&mut o, "diffuse_reflectance")?,
                    specular_reflectance: self.colour(&mut o, "specular_reflectance")?,
                    ior: Some(ior),
                    nonlinear: self.boolean(&mut o, "nonlinear")?,
                })
            }
            "dielectric" => {
                let int_ior = self.ior(&mut o, "int_ior", 1.5046)?;
                let ext_ior = self.ior(&mut o, "ext_ior", 1.000277)?;
                for key in ["specular_reflectance", "specular_transmittance"] {
                    if let Some(c) = self.colour(&mut o, key)?
                        && c.0 != [1.0; 3]
                    {
                        return Err(self.err(n, format!("{key}: only 1 (clear glass) is supported, got {:?}", c.0)));
                    }
                }
                MaterialDesc::Dielectric(desc::Dielectric { ior: int_ior / ext_ior })
            }
            "polarizer" => {
                // Mitsuba's unpolarized variants (scalar_rgb) read a linear polarizer as a
                // straight pass-through that absorbs half the light: a thin sheet of index 1
                // (no reflection) filtering by ½ transmittance. Its angle only turns a
                // polarization state, which an RGB renderer does not carry.
                if let Some(i) = o.children.iter().position(|c| c.attribute("name") == Some("theta")) {
                    o.children.remove(i);
                } else {
                    self.unbounded_colour(&mut o, "theta")?;
                }
                self.boolean(&mut o, "polarizing")?;
                let t = self.colour(&mut o, "transmittance")?.unwrap_or(Fixed([1.0; 3]));
                self.warn(
                    n,
                    "a polarizer is read as Mitsuba's RGB variants read it: a neutral filter of ½ transmittance (polarization is not tracked)",
                );
                MaterialDesc::ThinDielectric(desc::ThinDielectric {
                    ior: 1.0,
                    reflectance: Fixed([1.0; 3]),
                    transmittance: Fixed(t.0.map(|c| 0.5 * c)),
                })
            }
            "thindielectric" => {
                let int_ior = self.ior(&mut o, "int_ior", 1.5046)?;
                let ext_ior = self.ior(&mut o, "ext_ior", 1.000277)?;
                MaterialDesc::ThinDielectric(desc::ThinDielectric {
                    ior: int_ior / ext_ior,
                    reflectance: self.colour(&mut o, "specular_reflectance")?.unwrap_or(Fixed([1.0; 3])),
                    transmittance: self
                        .colour(&mut o, "specular_transmittance")?
                        .unwrap_or(Fixed([1.0; 3])),
                })
            }
            "principled" => MaterialDesc::Principled(self.principled(&mut o)?),
            "principledthin" => MaterialDesc::PrincipledThin(self.principled_thin(&mut o)?),
            other => {
                return Err(self.err(
                    n,
                    format!(
                        "unsupported BSDF {other:?} (diffuse, conductor, roughconductor, dielectric, \
                         roughdielectric, thindielectric, plastic, roughplastic, pplastic, principled, principledthin, polarizer, twosided, mask, blendbsdf, normalmap, bumpmap)"
                    ),
                ));
            }
        };
        if let Some(&c) = o.children.first() {
            return Err(self.err(c, "unexpected element in a BSDF"));
        }
        self.finish(&o)?;
        Ok(m)
    }

    /// A `blendbsdf`: its `weight` (a number, a colour's luminance or a texture's, default 0.5)
    /// and its two nested BSDFs, read by `nested`.
    fn blend(
        &mut self,
        n: Node<'a, 'i>,
        nested: fn(&mut Self, Node<'a, 'i>) -> Result<MaterialDesc>,
    ) -> Result<MaterialDesc> {
        let mut o = self.obj(n)?;
        let weight = self.scalar_texture(&mut o, "weight")?;
        let inner = self.nested_bsdfs(&o, "blendbsdf")?;
        let [a, b] = inner[..] else {
            return Err(self.err(n, "expected exactly two nested <bsdf> in a blendbsdf"));
        };
        Ok(MaterialDesc::Blend(desc::Blend {
            weight,
            bsdfs: vec![nested(self, a)?, nested(self, b)?],
        }))
    }

    /// A `principled` BSDF's properties, read as the model inside `twosided` (the caller makes a
    /// bare one one-sided, [`Reader::bsdf`]).
    fn principled(&mut self, o: &mut Obj<'a, 'i>) -> Result<desc::Principled> {
        Ok(desc::Principled {
            base_color: self.texture_colour(o, "base_color")?,
            roughness: self.scalar_texture(o, "roughness")?,
            anisotropic: self.scalar_texture(o, "anisotropic")?,
            metallic: self.scalar_texture(o, "metallic")?,
            spec_trans: self.scalar_texture(o, "spec_trans")?.filter(|s| !is_zero(s)),
            spec_tint: self.scalar_texture(o, "spec_tint")?,
            sheen: self.scalar_texture(o, "sheen")?,
            sheen_tint: self.scalar_texture(o, "sheen_tint")?,
            flatness: self.scalar_texture(o, "flatness")?,
            clearcoat: self.scalar_texture(o, "clearcoat")?,
            clearcoat_gloss: self.scalar_texture(o, "clearcoat_gloss")?,
            specular: self.float(o, "specular")?,
            eta: self.float(o, "eta")?,
            diffuse_reflectance_sampling_rate: self.float(o, "diffuse_reflectance_sampling_rate")?,
            main_specular_sampling_rate: self.float(o, "main_specular_sampling_rate")?,
            clearcoat_sampling_rate: self.float(o, "clearcoat_sampling_rate")?,
            two_sided: Some(true),
        })
    }

    /// A `principledthin` BSDF's properties; its `eta` must be a number.
    fn principled_thin(&mut self, o: &mut Obj<'a, 'i>) -> Result<desc::PrincipledThin> {
        let eta = match self.scalar_texture(o, "eta")? {
            None => None,
            Some(desc::ScalarDesc::Value(v)) => Some(v),
            Some(desc::ScalarDesc::Texture(_)) => {
                return Err(self.err(
                    o.node,
                    "eta: a textured index of refraction is not supported (give a <float>)",
                ));
            }
        };
        Ok(desc::PrincipledThin {
            base_color: self.texture_colour(o, "base_color")?,
            roughness: self.scalar_texture(o, "roughness")?,
            anisotropic: self.scalar_texture(o, "anisotropic")?,
            spec_trans: self.scalar_texture(o, "spec_trans")?,
            diff_trans: self.scalar_texture(o, "diff_trans")?,
            spec_tint: self.scalar_texture(o, "spec_tint")?,
            sheen: self.scalar_texture(o, "sheen")?,
            sheen_tint: self.scalar_texture(o, "sheen_tint")?,
            flatness: self.scalar_texture(o, "flatness")?,
            eta,
            specular_reflectance_sampling_rate: self.float(o, "specular_reflectance_sampling_rate")?,
            specular_transmittance_sampling_rate: self.float(o, "specular_transmittance_sampling_rate")?,
            diffuse_reflectance_sampling_rate: self.float(o, "diffuse_reflectance_sampling_rate")?,
            diffuse_transmittance_sampling_rate: self.float(o, "diffuse_transmittance_sampling_rate")?,
        })
    }

    /// A number that may be a texture: a `<float>`, a colour's luminance, or a texture.
    fn scalar_texture(&mut self, o: &mut Obj<'a, 'i>, name: &str) -> Result<Option<desc::ScalarDesc>> {
        Ok(match self.texture_colour(o, name)? {
            None => None,
            // A grey value (a <float>) as it is; a colour's luminance, as Mitsuba's eval_1.
            Some(Color::Rgb(c)) if c.0[0] == c.0[1] && c.0[1] == c.0[2] => Some(desc::ScalarDesc::Value(c.0[0])),
            Some(Color::Rgb(c)) => Some(desc::ScalarDesc::Value(crate::color::luminance(
                glam::DVec3::from_array(c.0).as_vec3(),
            ) as f64)),
            Some(Color::Texture(t)) => Some(desc::ScalarDesc::Texture(t)),
        })
    }

    /// The nested `<bsdf>` elements of a wrapper BSDF (`kind`), once its properties are taken;
    /// anything else nested is an error.
    fn nested_bsdfs(&self, o: &Obj<'a, 'i>, kind: &str) -> Result<Vec<Node<'a, 'i>>> {
        self.finish(o)?;
        if let Some(&c) = o.children.iter().find(|c| !c.has_tag_name("bsdf")) {
            return Err(self.err(c, format!("unexpected element in a {kind} BSDF")));
        }
        Ok(o.children.clone())
    }

    /// The one nested `<bsdf>` of a wrapper BSDF (`kind`), once its properties are taken; a
    /// nested BSDF of a type in `refused` is an error (`hint` says where it goes instead).
    fn one_nested_bsdf(
        &self,
        n: Node<'a, 'i>,
        o: &Obj<'a, 'i>,
        kind: &str,
        (refused, hint): (&[&str], &str),
    ) -> Result<Node<'a, 'i>> {
        let inner = self.nested_bsdfs(o, kind)?;
        let [inner] = inner[..] else {
            return Err(self.err(n, format!("expected exactly one nested <bsdf> in a {kind}")));
        };
        let inner_kind = self.required(inner, "type")?;
        if refused.contains(&inner_kind.as_str()) {
            return Err(self.err(inner, format!("a {inner_kind} inside a {kind} is not supported{hint}")));
        }
        Ok(inner)
    }

    /// A `mask`: its `opacity` (a number, a colour's luminance or a texture's, default 0.5) and
    /// its one nested BSDF, read by `nested` (sidedness as Mitsuba's, or two-sided).
    fn mask(
        &mut self,
        n: Node<'a, 'i>,
        nested: fn(&mut Self, Node<'a, 'i>) -> Result<MaterialDesc>,
    ) -> Result<MaterialDesc> {
        let mut o = self.obj(n)?;
        let opacity = self.scalar_texture(&mut o, "opacity")?;
        let inner = self.one_nested_bsdf(n, &o, "mask", (&["mask"], ""))?;
        Ok(MaterialDesc::Mask(desc::Mask {
            opacity,
            bsdf: Box::new(nested(self, inner)?),
        }))
    }

    /// A `normalmap`: its `normalmap` texture and its one nested BSDF, read by `nested`
    /// (sidedness as Mitsuba's, or two-sided).
    fn normal_map(
        &mut self,
        n: Node<'a, 'i>,
        nested: fn(&mut Self, Node<'a, 'i>) -> Result<MaterialDesc>,
    ) -> Result<MaterialDesc> {
        let mut o = self.obj(n)?;
        let Some(normals) = self.texture_colour(&mut o, "normalmap")? else {
            return Err(self.err(n, "expected a <texture name=\"normalmap\">"));
        };
        let inner = self.one_nested_bsdf(n, &o, "normalmap", (SURFACE_WRAPPERS, SURFACE_WRAPPERS_HINT))?;
        Ok(MaterialDesc::NormalMap(desc::NormalMap {
            normals,
            bsdf: Box::new(nested(self, inner)?),
        }))
    }

    /// A `bumpmap`: its `scale`, its one nested texture (any name: the height, read as a
    /// number) and its one nested BSDF, read by `nested` (sidedness as Mitsuba's, or two-sided).
    fn bump_map(
        &mut self,
        n: Node<'a, 'i>,
        nested: fn(&mut Self, Node<'a, 'i>) -> Result<MaterialDesc>,
    ) -> Result<MaterialDesc> {
        let mut o = self.obj(n)?;
        let scale = self.float(&mut o, "scale")?;
        let textures: Vec<Node> = o
            .children
            .iter()
            .copied()
            .filter(|c| c.has_tag_name("texture") || (c.has_tag_name("ref") && c.attribute("name") != Some("bsdf")))
            .collect();
        let [texture] = textures[..] else {
            return Err(self.err(n, "expected exactly one nested <texture> (the height) in a bumpmap"));
        };
        let name = texture.attribute("name").unwrap_or("height").to_string();
        let height = match self.scalar_texture(&mut o, &name)? {
            Some(h) => h,
            None => desc::ScalarDesc::Texture(Box::new(self.texture(texture)?)),
        };
        o.children.retain(|c| *c != texture);
        let inner = self.one_nested_bsdf(n, &o, "bumpmap", (SURFACE_WRAPPERS, SURFACE_WRAPPERS_HINT))?;
        Ok(MaterialDesc::BumpMap(desc::BumpMap {
            height,
            scale,
            bsdf: Box::new(nested(self, inner)?),
        }))
    }

    /// A conductor's `material` (a name; "none" is the default mirror), `eta` and `k` (unbounded
    /// colours, as Mitsuba reads them) and `specular_reflectance`.
    fn conductor(&mut self, o: &mut Obj<'a, 'i>) -> Result<desc::Conductor> {
        let material = match self.string(o, "material")? {
            Some((_, m)) if m == "none" => None,
            Some((p, m)) => {
                if crate::bsdf::ConductorIor::named(&m).is_none() {
                    return Err(self.err(
                        p,
                        format!(
                            "value: unknown conductor {m:?}; expected \"none\" or one of {}",
                            crate::bsdf::named_conductor_list()
                        ),
                    ));
                }
                Some(m)
            }
            None => None,
        };
        Ok(desc::Conductor {
            material,
            eta: self.unbounded_colour(o, "eta")?,
            k: self.unbounded_colour(o, "k")?,
            specular_reflectance: self.colour(o, "specular_reflectance")?,
        })
    }

    /// The relative index int_ior / ext_ior of the plastics' interface (defaults: polypropylene
    /// in air, Mitsuba's).
    fn plastic_ior(&mut self, o: &mut Obj<'a, 'i>) -> Result<f64> {
        Ok(self.ior(o, "int_ior", 1.49)? / self.ior(o, "ext_ior", 1.000277)?)
    }

    /// A microfacet distribution's properties, left for the scene loader to check.
    fn roughness(&mut self, o: &mut Obj<'a, 'i>) -> Result<Roughness> {
        Ok(Roughness {
            distribution: self.string(o, "distribution")?.map(|(_, d)| d),
            alpha: self.scalar_texture(o, "alpha")?,
            alpha_u: self.scalar_texture(o, "alpha_u")?,
            alpha_v: self.scalar_texture(o, "alpha_v")?,
            sample_visible: self.boolean(o, "sample_visible")?,
            masking: None,
            remap_roughness: None,
        })
    }

    pub(super) fn ior(&self, o: &mut Obj<'a, 'i>, key: &str, default: f64) -> Result<f64> {
        let Some(p) = self.take(o, key, &["float", "string"])? else {
            return Ok(default);
        };
        let text = self.required(p, "value")?;
        let v = match NAMED_IOR.iter().find(|(name, _)| *name == text) {
            Some(&(_, v)) => v,
            None => self.number(p, "value")?,
        };
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(p, format!("value: expected a positive index of refraction, got {v}")))
        }
    }
}

/// A weight given as the number 0: Mitsuba's `get_flag` reads it as absent (no transmission
/// lobe, so `twosided` accepts the model).
fn is_zero(s: &desc::ScalarDesc) -> bool {
    matches!(s, desc::ScalarDesc::Value(v) if *v == 0.0)
}
