//! pbrt-v4's materials as ours: `diffuse`, `diffusetransmission`, `conductor`, `dielectric`,
//! `thindielectric`, `mix`, `coateddiffuse` and `coatedconductor` (the mappings are in
//! docs/user-guide.md, "pbrt-v4 scenes").

use super::content::{bool_param, check_known, find, float_param, numbers, string_param};
use super::textures::image_uv;
use super::*;

impl Translator<'_> {
    /// One material of pbrt-v4 as ours, with its `normalmap` if it has one.
    ///
    /// pbrt-v4's normal map (`NormalMap` in its materials.h): an image read linearly, filtered
    /// bilinearly with repeat at (u, 1 − v), whose colour c is the normal 2c − 1 in the frame
    /// of the shading ∂p/∂u and normal — our `normal_map` around the material, its picture read
    /// `raw` with the v flip every pbrt image takes here. pbrt-v4 reads no normal map on `mix`
    /// and `interface`: one there is ignored with a warning, as pbrt ignores it.
    pub(super) fn material(&mut self, d: &Directive, kind: &str, params: &[Param]) -> Result<MaterialDesc> {
        let normal_map = string_param(d, params, "normalmap")?.filter(|f| !f.is_empty());
        let rest: Vec<Param> = params.iter().filter(|p| p.name != "normalmap").cloned().collect();
        let model = self.material_model(d, kind, &rest)?;
        let Some(file) = normal_map else {
            return Ok(model);
        };
        if matches!(kind, "mix" | "interface") {
            self.warn(
                d,
                &format!("normalmap on a {kind} material is ignored, as pbrt-v4 ignores it"),
            );
            return Ok(model);
        }
        let normals = TextureDesc::Bitmap(desc::BitmapDesc {
            file: self.dir.join(&file).display().to_string(),
            filter: None,
            wrap: None,
            raw: Some(true),
            scale: None,
            to_uv: Some(image_uv([1.0, 1.0], [0.0, 0.0])),
        });
        Ok(MaterialDesc::NormalMap(desc::NormalMap {
            normals: Color::Texture(Box::new(normals)),
            bsdf: Box::new(model),
        }))
    }

    /// One material model of pbrt-v4 as ours (module doc for the mappings).
    fn material_model(&mut self, d: &Directive, kind: &str, params: &[Param]) -> Result<MaterialDesc> {
        Ok(match kind {
            // A medium boundary that does not scatter: our `null`.
            "interface" => {
                check_known(d, params, &[])?;
                MaterialDesc::Null(desc::Null {})
            }
            "diffuse" => {
                check_known(d, params, &["reflectance"])?;
                MaterialDesc::Diffuse(desc::Diffuse {
                    reflectance: self
                        .colour(d, params, "reflectance", true)?
                        .unwrap_or(Color::Rgb(Fixed([0.5; 3]))),
                })
            }
            "diffusetransmission" => {
                check_known(d, params, &["reflectance", "transmittance", "scale"])?;
                let s = float_param(d, params, "scale")?.unwrap_or(1.0);
                let rgb = |name: &str| -> Result<Triple> {
                    match self.colour(d, params, name, true)? {
                        None => Ok(Fixed([0.25 * s; 3])),
                        Some(Color::Rgb(c)) => Ok(Fixed(c.0.map(|x| x * s))),
                        Some(Color::Texture(_)) => Err(d.err(format!("{name}: a texture is not read here"))),
                    }
                };
                MaterialDesc::DiffuseTransmission(desc::DiffuseTransmission {
                    reflectance: rgb("reflectance")?,
                    transmittance: rgb("transmittance")?,
                })
            }
            "conductor" => {
                check_known(
                    d,
                    params,
                    &[
                        "eta",
                        "k",
                        "reflectance",
                        "roughness",
                        "uroughness",
                        "vroughness",
                        "remaproughness",
                    ],
                )?;
                let (material, eta, k) = self.conductor_ior(d, params, "")?;
                conductor_desc((material, eta, k), self.alphas(d, params)?)
            }
            "dielectric" | "thindielectric" => {
                check_known(
                    d,
                    params,
                    &["eta", "roughness", "uroughness", "vroughness", "remaproughness"],
                )?;
                let eta = self.coat_eta(d, params, "eta")?;
                let alphas = self.alphas(d, params)?;
                if kind == "thindielectric" {
                    MaterialDesc::ThinDielectric(desc::ThinDielectric {
                        ior: eta,
                        reflectance: Fixed([1.0; 3]),
                        transmittance: Fixed([1.0; 3]),
                    })
                } else if alphas.smooth() {
                    MaterialDesc::Dielectric(desc::Dielectric { ior: eta })
                } else {
                    MaterialDesc::RoughDielectric(desc::RoughDielectric {
                        ior: eta,
                        specular_reflectance: None,
                        specular_transmittance: None,
                        distribution: Some("ggx".into()),
                        alpha: None,
                        alpha_u: Some(alphas.u),
                        alpha_v: Some(alphas.v),
                        sample_visible: Some(true),
                        masking: Some("height_correlated".into()),
                        remap_roughness: alphas.remap,
                    })
                }
            }
            "mix" => {
                check_known(d, params, &["materials", "amount"])?;
                let Some(p) = find(params, "materials") else {
                    return Err(d.err("expected \"string materials\" [\"a\" \"b\"]"));
                };
                let [Value::Str(a), Value::Str(b)] = &p.values[..] else {
                    return Err(d.err("parameter materials: expected two material names"));
                };
                let named = |n: &str| {
                    self.materials
                        .get(&format!("named:{n}"))
                        .cloned()
                        .ok_or_else(|| d.err(format!("materials: no material named {n:?}")))
                };
                MaterialDesc::Blend(desc::Blend {
                    weight: Some(desc::ScalarDesc::Value(
                        float_param(d, params, "amount")?.unwrap_or(0.5),
                    )),
                    bsdfs: vec![named(a)?, named(b)?],
                })
            }
            "coateddiffuse" => {
                const KNOWN: &[&str] = &[
                    "reflectance",
                    "roughness",
                    "uroughness",
                    "vroughness",
                    "remaproughness",
                    "thickness",
                    "eta",
                    "maxdepth",
                    "nsamples",
                    "g",
                    "albedo",
                ];
                check_known(d, params, KNOWN)?;
                let base = MaterialDesc::Diffuse(desc::Diffuse {
                    reflectance: self
                        .colour(d, params, "reflectance", true)?
                        .unwrap_or(Color::Rgb(Fixed([0.5; 3]))),
                });
                self.coated(d, params, base, "")?
            }
            "coatedconductor" => {
                const KNOWN: &[&str] = &[
                    "interface.roughness",
                    "interface.uroughness",
                    "interface.vroughness",
                    "interface.eta",
                    "conductor.eta",
                    "conductor.k",
                    "conductor.roughness",
                    "conductor.uroughness",
                    "conductor.vroughness",
                    "reflectance",
                    "remaproughness",
                    "thickness",
                    "maxdepth",
                    "nsamples",
                    "g",
                    "albedo",
                ];
                check_known(d, params, KNOWN)?;
                let coat_eta = self.coat_eta(d, params, "interface.eta")?;
                // pbrt-v4 divides the conductor's η and k by the coating's (the conductor
                // sits under it).
                let (material, eta, k) = self.conductor_ior(d, params, "conductor.")?;
                let (eta, k) = match material {
                    Some(m) => {
                        let ior = crate::bsdf::ConductorIor::named(&m).expect("a named metal was checked");
                        (ior.eta.as_dvec3().to_array(), ior.k.as_dvec3().to_array())
                    }
                    None => (eta.expect("η without a name").0, k.expect("k without a name").0),
                };
                let (eta, k) = (Fixed(eta.map(|x| x / coat_eta)), Fixed(k.map(|x| x / coat_eta)));
                let alphas = GgxAlphas::numbers(self.roughness(d, params, "conductor.")?);
                let base = conductor_desc((None, Some(eta), Some(k)), alphas);
                self.coated(d, params, base, "interface.")?
            }
            other => {
                return Err(d.err(format!(
                    "unsupported material {other:?} (diffuse, coateddiffuse, coatedconductor, conductor, \
                     dielectric, thindielectric, diffusetransmission, mix)"
                )));
            }
        })
    }

    /// A conductor's index: a named metal (`metal-X-eta` and `metal-X-k`, both the same X), η
    /// and k as `rgb`, `spectrum` pairs or `.spd` files (converted as Mitsuba converts
    /// unbounded spectra), or pbrt-v4's `reflectance` r (η = 1, k = 2√r / √(1 − r), r ≤
    /// 0.9999: the index whose normal-incidence Fresnel reflectance is r). Default: copper.
    fn conductor_ior(
        &mut self,
        d: &Directive,
        params: &[Param],
        prefix: &str,
    ) -> Result<(Option<String>, Option<Triple>, Option<Triple>)> {
        let (eta_name, k_name) = (format!("{prefix}eta"), format!("{prefix}k"));
        if let Some(r) = self.colour(d, params, "reflectance", true)? {
            if find(params, &eta_name).is_some() || find(params, &k_name).is_some() {
                return Err(d.err("give reflectance or eta and k, not both"));
            }
            let Color::Rgb(r) = r else {
                return Err(d.err("reflectance: a texture is not read for a conductor"));
            };
            let k = r.0.map(|r| {
                let r = r.clamp(0.0, 0.9999);
                2.0 * r.sqrt() / (1.0 - r).sqrt()
            });
            return Ok((None, Some(Fixed([1.0; 3])), Some(Fixed(k))));
        }
        let metal = |p: Option<&Param>, suffix: &str| -> Option<String> {
            match p.map(|p| &p.values[..]) {
                None => Some("Cu".into()),
                Some([Value::Str(s)]) => s
                    .strip_prefix("metal-")
                    .and_then(|m| m.strip_suffix(suffix))
                    .map(str::to_string),
                _ => None,
            }
        };
        let (pe, pk) = (find(params, &eta_name), find(params, &k_name));
        if let (Some(a), Some(b)) = (metal(pe, "-eta"), metal(pk, "-k"))
            && a == b
        {
            if crate::bsdf::ConductorIor::named(&a).is_none() {
                return Err(d.err(format!(
                    "metal {a:?}: expected one of {}",
                    crate::bsdf::named_conductor_list()
                )));
            }
            return Ok((Some(a), None, None));
        }
        let mut part = |p: Option<&Param>, suffix: &str| -> Result<Triple> {
            let named = metal(p, suffix).and_then(|m| crate::bsdf::ConductorIor::named(&m));
            match (named, p) {
                (Some(ior), _) => {
                    let v = if suffix == "-eta" { ior.eta } else { ior.k };
                    Ok(Fixed(v.as_dvec3().to_array()))
                }
                (None, Some(p)) => self.unbounded(d, p),
                (None, None) => unreachable!("an absent parameter is copper"),
            }
        };
        Ok((None, Some(part(pe, "-eta")?), Some(part(pk, "-k")?)))
    }

    /// An unbounded spectrum (η, k) as RGB: `rgb`, `spectrum` pairs, or a `spectrum` file of
    /// pairs (pbrt's `.spd`, relative to the scene; its bytes join the scene's hash).
    fn unbounded(&mut self, d: &Directive, p: &Param) -> Result<Triple> {
        let pairs: Vec<f64> = match (p.ty.as_str(), &p.values[..]) {
            ("rgb", _) => {
                let v = numbers(d, p)?;
                let [r, g, b] = v[..] else {
                    return Err(d.err(format!("parameter \"rgb {}\": expected 3 numbers", p.name)));
                };
                return Ok(Fixed([r, g, b]));
            }
            ("spectrum", [Value::Str(file)]) => {
                let path = self.dir.join(file);
                let bytes = crate::util::read_input(&path, "spectrum file", crate::util::MAX_TEXT_INPUT)
                    .map_err(|e| d.err(format!("parameter \"spectrum {}\": {file}: {e} (named spectra other than metal-X-eta/-k are not known)", p.name)))?;
                let text = String::from_utf8_lossy(&bytes).to_string();
                self.files_read.push((path, bytes));
                let mut v = Vec::new();
                for line in text.lines() {
                    for w in line.split('#').next().unwrap_or("").split_whitespace() {
                        v.push(
                            w.parse::<f64>()
                                .map_err(|_| d.err(format!("{file}: {w:?} is not a number")))?,
                        );
                    }
                }
                v
            }
            ("spectrum", _) => numbers(d, p)?,
            (ty, _) => return Err(d.err(format!("parameter \"{ty} {}\": expected rgb or spectrum", p.name))),
        };
        if pairs.len() < 4 || !pairs.len().is_multiple_of(2) || pairs.iter().any(|x| !x.is_finite()) {
            return Err(d.err(format!("parameter {}: expected wavelength–value pairs", p.name)));
        }
        let points: Vec<(f64, f64)> = pairs.chunks(2).map(|c| (c[0], c[1])).collect();
        Ok(Fixed(crate::spectrum::list_to_srgb(&points, false).0.to_array()))
    }

    /// (α_u, α_v) from `roughness` or `uroughness`/`vroughness` (default 0), remapped by
    /// `remaproughness` (default true): α = √roughness.
    /// A coated model over `base`: the coating's η and roughness (`prefix` names them, as
    /// pbrt-v4's `coatedconductor` does) and the slab's parameters, pbrt's defaults where absent.
    fn coated(&self, d: &Directive, params: &[Param], base: MaterialDesc, prefix: &str) -> Result<MaterialDesc> {
        let (au, av) = self.roughness(d, params, prefix)?;
        let rough = au.max(av) >= 1e-3;
        let int = |name: &str| -> Result<Option<u32>> {
            match find(params, name) {
                None => Ok(None),
                Some(p) => match &numbers(d, p)?[..] {
                    [x] if x.fract() == 0.0 && (0.0..=1e6).contains(x) => Ok(Some(*x as u32)),
                    _ => Err(d.err(format!("parameter {name}: expected one non-negative integer"))),
                },
            }
        };
        // Ranges checked here so that the message names the file's line.
        let g = float_param(d, params, "g")?;
        if let Some(g) = g
            && (g.is_nan() || g.abs() >= 1.0)
        {
            return Err(d.err(format!("g: expected a number in (−1, 1), got {g}")));
        }
        let (max_depth, samples) = (int("maxdepth")?, int("nsamples")?);
        if max_depth.is_some_and(|n| !(1..=100).contains(&n)) {
            return Err(d.err("maxdepth: expected an integer in [1, 100] (written as max_depth in TOML)"));
        }
        if samples.is_some_and(|n| !(1..=64).contains(&n)) {
            return Err(d.err("nsamples: expected an integer in [1, 64]"));
        }
        let thickness = float_param(d, params, "thickness")?.unwrap_or(0.01);
        if !(0.0..=1e4).contains(&thickness) {
            return Err(d.err(format!("thickness: expected a number in [0, 1e4], got {thickness}")));
        }
        let albedo = match self.colour(d, params, "albedo", true)? {
            None => None,
            Some(Color::Rgb(c)) => Some(c),
            Some(Color::Texture(_)) => return Err(d.err("albedo: a texture is not read for a coating's slab")),
        };
        Ok(MaterialDesc::Coated(desc::Coated {
            base: Box::new(base),
            ior: Some(self.coat_eta(d, params, &format!("{prefix}eta"))?),
            thickness: Some(thickness),
            albedo,
            g,
            max_depth,
            samples,
            weights: None,
            distribution: rough.then(|| "ggx".into()),
            alpha: None,
            alpha_u: rough.then_some(desc::ScalarDesc::Value(au)),
            alpha_v: rough.then_some(desc::ScalarDesc::Value(av)),
            sample_visible: rough.then_some(true),
            masking: rough.then(|| "height_correlated".into()),
            remap_roughness: None,
        }))
    }

    /// A dielectric's (or a coating's) index of refraction: a `float` (default 1.5); pbrt's
    /// spectrally varying η is refused (it would split the interface by wavelength).
    fn coat_eta(&self, d: &Directive, params: &[Param], name: &str) -> Result<f64> {
        match find(params, name) {
            None => Ok(1.5),
            Some(p) if p.ty == "float" => Ok(float_param(d, params, name)?.unwrap_or(1.5)),
            Some(p) => Err(d.err(format!("parameter \"{} {name}\": expected a float", p.ty))),
        }
    }

    /// A conductor's or dielectric's α_u, α_v: numbers already remapped ([`Self::roughness`]),
    /// or, when `roughness`, `uroughness` or `vroughness` is a float texture, the values as given
    /// (numbers or textures, default 0) with pbrt's `remaproughness` (default true: α = √r at
    /// each hit, after the texture is read, as pbrt-v4's materials do).
    fn alphas(&self, d: &Directive, params: &[Param]) -> Result<GgxAlphas> {
        let is_texture = |name: &str| find(params, name).is_some_and(|p| p.ty == "texture");
        if !["roughness", "uroughness", "vroughness"].into_iter().any(is_texture) {
            return Ok(GgxAlphas::numbers(self.roughness(d, params, "")?));
        }
        let value = |name: &str, default: desc::ScalarDesc| -> Result<desc::ScalarDesc> {
            if is_texture(name) {
                let Some(Color::Texture(t)) = self.colour_or_number(d, params, name, false, true)? else {
                    unreachable!("a texture parameter names a texture")
                };
                return Ok(desc::ScalarDesc::Texture(t));
            }
            match float_param(d, params, name)? {
                None => Ok(default),
                Some(x) if x >= 0.0 => Ok(desc::ScalarDesc::Value(x)),
                Some(x) => Err(d.err(format!("{name}: expected a number ≥ 0, got {x}"))),
            }
        };
        let r = value("roughness", desc::ScalarDesc::Value(0.0))?;
        Ok(GgxAlphas {
            u: value("uroughness", r.clone())?,
            v: value("vroughness", r)?,
            remap: Some(bool_param(d, params, "remaproughness")?.unwrap_or(true)),
        })
    }

    /// `prefix` names a layer of a coated model (`interface.`, `conductor.`).
    fn roughness(&self, d: &Directive, params: &[Param], prefix: &str) -> Result<(f64, f64)> {
        for name in ["roughness", "uroughness", "vroughness"].map(|n| format!("{prefix}{n}")) {
            if find(params, &name).is_some_and(|p| p.ty == "texture") {
                return Err(d.err(format!(
                    "parameter \"texture {name}\": a textured roughness is read for conductor and dielectric only"
                )));
            }
        }
        let r = float_param(d, params, &format!("{prefix}roughness"))?.unwrap_or(0.0);
        let u = float_param(d, params, &format!("{prefix}uroughness"))?.unwrap_or(r);
        let v = float_param(d, params, &format!("{prefix}vroughness"))?.unwrap_or(r);
        if u < 0.0 || v < 0.0 {
            return Err(d.err(format!("{prefix}roughness: expected numbers ≥ 0")));
        }
        Ok(if bool_param(d, params, "remaproughness")?.unwrap_or(true) {
            (u.sqrt(), v.sqrt())
        } else {
            (u, v)
        })
    }
}

/// A conductor's or dielectric's roughness ([`Translator::alphas`]).
struct GgxAlphas {
    u: desc::ScalarDesc,
    v: desc::ScalarDesc,
    /// `Some` for textured roughness: the values are pbrt's r, remapped at each hit or not.
    remap: Option<bool>,
}

impl GgxAlphas {
    /// α_u and α_v as numbers (already remapped).
    fn numbers((u, v): (f64, f64)) -> Self {
        Self {
            u: desc::ScalarDesc::Value(u),
            v: desc::ScalarDesc::Value(v),
            remap: None,
        }
    }

    /// pbrt's `EffectivelySmooth`: both α below 10⁻³ (a textured roughness is rough).
    fn smooth(&self) -> bool {
        match (&self.u, &self.v) {
            (desc::ScalarDesc::Value(u), desc::ScalarDesc::Value(v)) if self.remap.is_none() => u.max(*v) < 1e-3,
            _ => false,
        }
    }
}

/// A smooth conductor below α 10⁻³ (pbrt's `EffectivelySmooth`), a GGX rough conductor with
/// visible-normal sampling above.
fn conductor_desc(
    (material, eta, k): (Option<String>, Option<Triple>, Option<Triple>),
    alphas: GgxAlphas,
) -> MaterialDesc {
    if alphas.smooth() {
        return MaterialDesc::Conductor(desc::Conductor {
            material,
            eta,
            k,
            specular_reflectance: None,
        });
    }
    MaterialDesc::RoughConductor(desc::RoughConductor {
        material,
        eta,
        k,
        specular_reflectance: None,
        distribution: Some("ggx".into()),
        alpha: None,
        alpha_u: Some(alphas.u),
        alpha_v: Some(alphas.v),
        sample_visible: Some(true),
        masking: Some("height_correlated".into()),
        remap_roughness: alphas.remap,
    })
}
