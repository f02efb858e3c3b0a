//! `<bsdf>` elements mapped to our materials, named IORs included; `twosided` unwrapped.

use super::*;
use crate::error::Result;
use crate::scene::desc::{self, Fixed, MaterialDesc};
use roxmltree::Node;

impl<'a, 'i> Reader<'a, 'i> {
    /// A BSDF element as one of our materials.
    pub(super) fn bsdf(&mut self, n: Node<'a, 'i>) -> Result<MaterialDesc> {
        let kind = self.required(n, "type")?;
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
            let m = self.one_bsdf(inner)?;
            if matches!(m, MaterialDesc::Dielectric(_) | MaterialDesc::ThinDielectric(_)) {
                return Err(self.err(inner, "a dielectric cannot be two-sided (Mitsuba refuses it too)"));
            }
            return Ok(m);
        }
        let m = self.one_bsdf(n)?;
        if !matches!(m, MaterialDesc::Dielectric(_) | MaterialDesc::ThinDielectric(_)) {
            self.warn(
                n,
                "one-sided in Mitsuba 3 (black from behind), two-sided in photon-bench; wrap it in \
                 <bsdf type=\"twosided\"> for equal renders",
            );
        }
        Ok(m)
    }

    pub(super) fn one_bsdf(&mut self, n: Node<'a, 'i>) -> Result<MaterialDesc> {
        let kind = self.required(n, "type")?;
        let mut o = self.obj(n)?;
        let m = match kind.as_str() {
            "diffuse" => MaterialDesc::Diffuse(desc::Diffuse {
                reflectance: self.colour(&mut o, "reflectance")?.unwrap_or(Fixed([0.5; 3])),
            }),
            "conductor" | "roughconductor" => {
                if let Some((p, material)) = self.string(&mut o, "material")?
                    && material != "none"
                {
                    return Err(self.err(
                        p,
                        format!(
                            "material {material:?}: named metals need a Fresnel conductor, which photon-bench \
                             does not have; use material=\"none\" with a specular_reflectance"
                        ),
                    ));
                }
                for key in ["eta", "k"] {
                    if let Some(&p) = o.props.get(key) {
                        return Err(self.err(
                            p,
                            "complex indices of refraction are not supported (material=\"none\" only)",
                        ));
                    }
                }
                let reflectance = self.colour(&mut o, "specular_reflectance")?.unwrap_or(Fixed([1.0; 3]));
                if kind == "conductor" {
                    MaterialDesc::Mirror(desc::Mirror { reflectance })
                } else {
                    if let Some((p, d)) = self.string(&mut o, "distribution")?
                        && !(d == "beckmann" || d == "ggx")
                    {
                        return Err(self.err(p, format!("distribution: expected beckmann or ggx, got {d:?}")));
                    }
                    self.boolean(&mut o, "sample_visible")?;
                    let alpha = self.float(&mut o, "alpha")?;
                    let au = self.float(&mut o, "alpha_u")?;
                    let av = self.float(&mut o, "alpha_v")?;
                    let (ax, ay) = match (alpha, au, av) {
                        (a, None, None) => (a.unwrap_or(0.1), a.unwrap_or(0.1)),
                        (None, Some(u), Some(v)) => (u, v),
                        _ => return Err(self.err(n, "expected either alpha or both alpha_u and alpha_v")),
                    };
                    self.warn(
                        n,
                        "approximated by photon-bench's Ward model (alpha as its roughness, no Fresnel term); \
                         renders will differ from Mitsuba's microfacet conductor",
                    );
                    MaterialDesc::Ward(desc::Ward {
                        diffuse: Fixed([0.0; 3]),
                        specular: reflectance,
                        alpha_x: ax,
                        alpha_y: ay,
                    })
                }
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
            other => {
                return Err(self.err(
                    n,
                    format!("unsupported BSDF {other:?} (diffuse, conductor, roughconductor, dielectric, thindielectric, twosided)"),
                ));
            }
        };
        if let Some(&c) = o.children.first() {
            return Err(self.err(c, "unexpected element in a BSDF"));
        }
        self.finish(&o)?;
        Ok(m)
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
