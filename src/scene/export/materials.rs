//! Materials as Mitsuba 3 BSDFs (and the textures their parameters hold), for
//! [`super::to_xml`].

use super::*;

/// One material as a top-level `<bsdf id>`: reflecting models wrapped in `twosided` (ours reflect
/// on both sides) unless `one_sided` (Mitsuba's own sidedness: the BSDF bare), dielectrics as
/// they are.
pub(super) fn material_xml(
    m: &MaterialDesc,
    one_sided: bool,
    id: &str,
    field: &str,
    file: &str,
    files: &Files,
    warnings: &mut Vec<String>,
) -> Result<String> {
    let err = |field: &str, msg: &str| Error::new(format!("{file}: {field}: {msg}"));
    // The nested element itself, carrying the id.
    let bare = |inner: String| inner.replacen(">", &format!(" id=\"{id}\">"), 1);
    let twosided = |inner: String| {
        if one_sided {
            bare(inner)
        } else {
            format!("    <bsdf type=\"twosided\" id=\"{id}\">\n{inner}    </bsdf>\n")
        }
    };
    let bsdf = match m {
        MaterialDesc::Diffuse(d) => twosided(format!(
            "        <bsdf type=\"diffuse\">\n{}        </bsdf>\n",
            files.color("reflectance", &d.reflectance, INNER)?
        )),
        MaterialDesc::Mirror(d) => twosided(format!(
            "        <bsdf type=\"conductor\">\n            <string name=\"material\" value=\"none\"/>\n            \
             <rgb name=\"specular_reflectance\" value=\"{}\"/>\n        </bsdf>\n",
            nums(&d.reflectance.0)
        )),
        MaterialDesc::Dielectric(d) => format!(
            "    <bsdf type=\"dielectric\" id=\"{id}\">\n        <float name=\"int_ior\" value=\"{}\"/>\n        \
             <float name=\"ext_ior\" value=\"1\"/>\n    </bsdf>\n",
            d.ior
        ),
        MaterialDesc::ThinDielectric(d) => format!(
            "    <bsdf type=\"thindielectric\" id=\"{id}\">\n        <float name=\"int_ior\" value=\"{}\"/>\n        \
             <float name=\"ext_ior\" value=\"1\"/>\n        \
             <rgb name=\"specular_reflectance\" value=\"{}\"/>\n        \
             <rgb name=\"specular_transmittance\" value=\"{}\"/>\n    </bsdf>\n",
            d.ior,
            nums(&d.reflectance.0),
            nums(&d.transmittance.0)
        ),
        MaterialDesc::Ward(w) if w.diffuse.0 == [0.0; 3] => {
            warnings.push(format!(
                "{file}: {field}: ward written as Mitsuba's roughconductor (Beckmann, same alpha): \
                 similar, not equal lobes"
            ));
            twosided(format!(
                "        <bsdf type=\"roughconductor\">\n            <string name=\"material\" value=\"none\"/>\n            \
                 <string name=\"distribution\" value=\"beckmann\"/>\n            \
                 <float name=\"alpha_u\" value=\"{}\"/>\n            <float name=\"alpha_v\" value=\"{}\"/>\n            \
                 <rgb name=\"specular_reflectance\" value=\"{}\"/>\n        </bsdf>\n",
                w.alpha_x,
                w.alpha_y,
                nums(&w.specular.0)
            ))
        }
        MaterialDesc::Ward(_) => {
            return Err(err(field, "a ward with a diffuse part has no Mitsuba 3 equivalent"));
        }
        MaterialDesc::Conductor(c) => twosided(format!(
            "        <bsdf type=\"conductor\">\n{}        </bsdf>\n",
            conductor_props(c, INNER)
        )),
        MaterialDesc::RoughConductor(c) => twosided(format!(
            "        <bsdf type=\"roughconductor\">\n{}{}        </bsdf>\n",
            conductor_props(&c.conductor(), INNER),
            roughness_props(&c.roughness(), INNER, files).map_err(|e| e.context(format!("{file}: {field}")))?
        )),
        MaterialDesc::RoughDielectric(d) => format!(
            "    <bsdf type=\"roughdielectric\" id=\"{id}\">\n        <float name=\"int_ior\" value=\"{}\"/>\n        \
             <float name=\"ext_ior\" value=\"1\"/>\n{}{}{}    </bsdf>\n",
            d.ior,
            optional_rgb("specular_reflectance", d.specular_reflectance, OUTER),
            optional_rgb("specular_transmittance", d.specular_transmittance, OUTER),
            roughness_props(&d.roughness(), OUTER, files).map_err(|e| e.context(format!("{file}: {field}")))?
        ),
        MaterialDesc::RoughPlastic(p) => twosided(plastic_xml(
            "roughplastic",
            (
                p.ior,
                p.diffuse_reflectance.as_ref(),
                p.specular_reflectance,
                p.nonlinear,
            ),
            &roughness_props(&p.roughness(), INNER, files).map_err(|e| e.context(format!("{file}: {field}")))?,
            files,
        )?),
        MaterialDesc::Pplastic(p) => twosided(format!(
            "        <bsdf type=\"pplastic\">\n{INNER}<float name=\"int_ior\" value=\"{}\"/>\n{INNER}\
             <float name=\"ext_ior\" value=\"1\"/>\n{}{}{}        </bsdf>\n",
            p.ior.unwrap_or(crate::scene::load::PLASTIC_DEFAULT_IOR),
            match &p.diffuse_reflectance {
                Some(c) => files.color("diffuse_reflectance", c, INNER)?,
                None => String::new(),
            },
            optional_rgb("specular_reflectance", p.specular_reflectance, INNER),
            roughness_props(&p.roughness(), INNER, files).map_err(|e| e.context(format!("{file}: {field}")))?
        )),
        MaterialDesc::Plastic(p) => twosided(plastic_xml(
            "plastic",
            (
                p.ior,
                p.diffuse_reflectance.as_ref(),
                p.specular_reflectance,
                p.nonlinear,
            ),
            "",
            files,
        )?),
        // Its own sidedness: bare (Mitsuba's), or in `twosided` when two-sided.
        MaterialDesc::Principled(p) => {
            let weights = [
                ("roughness", &p.roughness),
                ("anisotropic", &p.anisotropic),
                ("metallic", &p.metallic),
                ("spec_trans", &p.spec_trans),
                ("spec_tint", &p.spec_tint),
                ("sheen", &p.sheen),
                ("sheen_tint", &p.sheen_tint),
                ("flatness", &p.flatness),
                ("clearcoat", &p.clearcoat),
                ("clearcoat_gloss", &p.clearcoat_gloss),
            ];
            let numbers = [
                ("specular", p.specular),
                ("eta", p.eta),
                ("diffuse_reflectance_sampling_rate", p.diffuse_reflectance_sampling_rate),
                ("main_specular_sampling_rate", p.main_specular_sampling_rate),
                ("clearcoat_sampling_rate", p.clearcoat_sampling_rate),
            ];
            let inner = principled_xml("principled", p.base_color.as_ref(), &weights, &numbers, files)?;
            if p.two_sided.unwrap_or(false) && !one_sided {
                format!("    <bsdf type=\"twosided\" id=\"{id}\">\n{inner}    </bsdf>\n")
            } else {
                bare(inner)
            }
        }
        MaterialDesc::PrincipledThin(p) => {
            let weights = [
                ("roughness", &p.roughness),
                ("anisotropic", &p.anisotropic),
                ("spec_trans", &p.spec_trans),
                ("diff_trans", &p.diff_trans),
                ("spec_tint", &p.spec_tint),
                ("sheen", &p.sheen),
                ("sheen_tint", &p.sheen_tint),
                ("flatness", &p.flatness),
            ];
            let numbers = [
                ("eta", p.eta),
                (
                    "specular_reflectance_sampling_rate",
                    p.specular_reflectance_sampling_rate,
                ),
                (
                    "specular_transmittance_sampling_rate",
                    p.specular_transmittance_sampling_rate,
                ),
                ("diffuse_reflectance_sampling_rate", p.diffuse_reflectance_sampling_rate),
                (
                    "diffuse_transmittance_sampling_rate",
                    p.diffuse_transmittance_sampling_rate,
                ),
            ];
            bare(principled_xml(
                "principledthin",
                p.base_color.as_ref(),
                &weights,
                &numbers,
                files,
            )?)
        }
        MaterialDesc::OneSided(o) => material_xml(&o.bsdf, true, id, field, file, files, warnings)?,
        MaterialDesc::Mask(m) => {
            // The nested material as it would stand alone, its id moved to the mask.
            let inner = material_xml(&m.bsdf, one_sided, id, field, file, files, warnings)?;
            let inner = indented(&inner.replacen(&format!(" id=\"{id}\""), "", 1));
            let opacity = scalar_xml("opacity", m.opacity.as_ref(), files)?;
            format!("    <bsdf type=\"mask\" id=\"{id}\">\n{opacity}{inner}    </bsdf>\n")
        }
        MaterialDesc::NormalMap(m) => {
            let normals = files.color("normalmap", &m.normals, OUTER)?;
            let nested = |one_sided| material_xml(&m.bsdf, one_sided, id, field, file, files, &mut *warnings);
            surface_map_xml("normalmap", &normals, &m.bsdf, one_sided, id, nested)?
        }
        // A constant height is a flat surface: the nested material alone (Mitsuba's bumpmap
        // takes only a texture).
        MaterialDesc::BumpMap(m) if matches!(m.height, desc::ScalarDesc::Value(_)) => {
            material_xml(&m.bsdf, one_sided, id, field, file, files, warnings)?
        }
        MaterialDesc::BumpMap(m) => {
            let height = scalar_xml("height", Some(&m.height), files)?;
            let props = format!(
                "{OUTER}<float name=\"scale\" value=\"{}\"/>\n{height}",
                m.scale.unwrap_or(1.0)
            );
            let nested = |one_sided| material_xml(&m.bsdf, one_sided, id, field, file, files, &mut *warnings);
            surface_map_xml("bumpmap", &props, &m.bsdf, one_sided, id, nested)?
        }
        MaterialDesc::Blend(b) => {
            // Each model as it would stand alone (its own sidedness), without an id.
            let mut parts = String::new();
            for (i, m) in b.bsdfs.iter().enumerate() {
                let part = material_xml(
                    m,
                    one_sided,
                    "part",
                    &format!("{field}.bsdfs[{i}]"),
                    file,
                    files,
                    warnings,
                )?;
                parts += &indented(&part.replacen(" id=\"part\"", "", 1));
            }
            format!(
                "    <bsdf type=\"blendbsdf\" id=\"{id}\">\n{}{parts}    </bsdf>\n",
                scalar_xml("weight", b.weight.as_ref(), files)?
            )
        }
        MaterialDesc::Null(_) => format!("    <bsdf type=\"null\" id=\"{id}\"/>\n"),
        MaterialDesc::Phong(_) => return Err(err(field, "phong has no Mitsuba 3 equivalent")),
        MaterialDesc::Coated(_) => {
            return Err(err(
                field,
                "coated (pbrt-v4's layered models) has no Mitsuba 3 equivalent",
            ));
        }
        MaterialDesc::DiffuseTransmission(_) => {
            return Err(err(field, "diffuse_transmission has no Mitsuba 3 equivalent"));
        }
    };
    Ok(bsdf)
}

/// A number parameter that may be a texture (absent: Mitsuba's default 0.5, written out).
pub(super) fn scalar_xml(name: &str, v: Option<&desc::ScalarDesc>, files: &Files) -> Result<String> {
    scalar_xml_at(name, Some(v.unwrap_or(&desc::ScalarDesc::Value(0.5))), files, OUTER)
}

/// A principled BSDF (`kind`) at the nested indentation: its base colour, the weights given
/// (numbers or textures) and the plain numbers given; Mitsuba's defaults are ours.
fn principled_xml(
    kind: &str,
    base_color: Option<&Color>,
    weights: &[(&str, &Option<desc::ScalarDesc>)],
    numbers: &[(&str, Option<f64>)],
    files: &Files,
) -> Result<String> {
    let mut props = match base_color {
        Some(c) => files.color("base_color", c, INNER)?,
        None => String::new(),
    };
    for (name, w) in weights {
        props += &scalar_xml_at(name, w.as_ref(), files, INNER)?;
    }
    for (name, x) in numbers {
        if let Some(x) = x {
            props += &format!("{INNER}<float name=\"{name}\" value=\"{x}\"/>\n");
        }
    }
    Ok(format!("        <bsdf type=\"{kind}\">\n{props}        </bsdf>\n"))
}

/// A number parameter (or its texture) at `indent`; nothing when absent.
fn scalar_xml_at(name: &str, v: Option<&desc::ScalarDesc>, files: &Files, indent: &str) -> Result<String> {
    match v {
        None => Ok(String::new()),
        Some(desc::ScalarDesc::Value(v)) => Ok(format!("{indent}<float name=\"{name}\" value=\"{v}\"/>\n")),
        Some(desc::ScalarDesc::Texture(t)) => files.color(name, &Color::Texture(t.clone()), indent),
    }
}

/// A `normalmap` or `bumpmap` (`kind`, its properties `props`) around `bsdf`, written by
/// `nested(one_sided)`. Ours mirror the map below the surface for a two-sided reflecting
/// material, which is Mitsuba's `twosided(kind(bare material))` (a `twosided` inside the map
/// would flip the directions after the map has chosen its normal); other materials keep their
/// sidedness inside the map.
fn surface_map_xml(
    kind: &str,
    props: &str,
    bsdf: &MaterialDesc,
    one_sided: bool,
    id: &str,
    nested: impl FnOnce(bool) -> Result<String>,
) -> Result<String> {
    let transmits = matches!(
        bsdf,
        MaterialDesc::Dielectric(_)
            | MaterialDesc::ThinDielectric(_)
            | MaterialDesc::RoughDielectric(_)
            | MaterialDesc::DiffuseTransmission(_)
    );
    // The principled models have their own sides: a two-sided one goes bare inside the
    // mirrored map, a one-sided one and the thin sheet keep theirs inside a plain map.
    let own_sides = match bsdf {
        MaterialDesc::Principled(p) => !p.two_sided.unwrap_or(false),
        b => matches!(b, MaterialDesc::PrincipledThin(_) | MaterialDesc::OneSided(_)),
    };
    let mirrored = !one_sided && !transmits && !own_sides;
    let id_attr = format!(" id=\"{id}\"");
    let inner = indented(&nested(one_sided || mirrored)?.replacen(&id_attr, "", 1));
    let map = format!("    <bsdf type=\"{kind}\"{id_attr}>\n{props}{inner}    </bsdf>\n");
    Ok(if mirrored {
        let map = indented(&map.replacen(&id_attr, "", 1));
        format!("    <bsdf type=\"twosided\"{id_attr}>\n{map}    </bsdf>\n")
    } else {
        map
    })
}

/// A top-level element's lines moved in by one level, to nest it.
fn indented(xml: &str) -> String {
    xml.lines().map(|l| format!("    {l}\n")).collect()
}

/// A `plastic` or `roughplastic` BSDF (nested in `twosided`): the coating's index, the colours,
/// `nonlinear`, then `extra` (the roughness).
fn plastic_xml(
    kind: &str,
    (ior, diffuse, specular, nonlinear): (Option<f64>, Option<&Color>, Option<Triple>, Option<bool>),
    extra: &str,
    files: &Files,
) -> Result<String> {
    Ok(format!(
        "        <bsdf type=\"{kind}\">\n{INNER}<float name=\"int_ior\" value=\"{}\"/>\n{INNER}\
         <float name=\"ext_ior\" value=\"1\"/>\n{}{}{INNER}<boolean name=\"nonlinear\" value=\"{}\"/>\n{extra}        </bsdf>\n",
        ior.unwrap_or(crate::scene::load::PLASTIC_DEFAULT_IOR),
        files.color(
            "diffuse_reflectance",
            diffuse.unwrap_or(&Color::Rgb(Fixed([0.5; 3]))),
            INNER
        )?,
        optional_rgb("specular_reflectance", specular, INNER),
        nonlinear.unwrap_or(false),
    ))
}

/// Indentation of the properties of a top-level BSDF and of one nested in `twosided`.
const OUTER: &str = "        ";
const INNER: &str = "            ";

/// `<rgb>` for a colour that was given, nothing for one left at its default.
fn optional_rgb(name: &str, v: Option<Triple>, indent: &str) -> String {
    v.map_or(String::new(), |v| {
        format!("{indent}<rgb name=\"{name}\" value=\"{}\"/>\n", nums(&v.0))
    })
}

/// A conductor's index: its named material, or η and k as RGB (Mitsuba's defaults 0 and 1).
fn conductor_props(c: &desc::Conductor, indent: &str) -> String {
    let mut x = match c.material.as_deref() {
        Some(name) if name != "none" => format!("{indent}<string name=\"material\" value=\"{}\"/>\n", escape(name)),
        _ => format!(
            "{indent}<rgb name=\"eta\" value=\"{}\"/>\n{indent}<rgb name=\"k\" value=\"{}\"/>\n",
            nums(&c.eta.unwrap_or(Fixed([0.0; 3])).0),
            nums(&c.k.unwrap_or(Fixed([1.0; 3])).0)
        ),
    };
    x.push_str(&optional_rgb("specular_reflectance", c.specular_reflectance, indent));
    x
}

/// A microfacet distribution with every default written out.
fn roughness_props(r: &Roughness, indent: &str, files: &Files) -> Result<String> {
    if r.masking.as_deref().is_some_and(|k| k != "separable") {
        return Err(Error::new(
            "masking = \"height_correlated\" (pbrt-v4's) has no Mitsuba 3 equivalent: its microfacet models are separable",
        ));
    }
    if r.remap_roughness == Some(true) {
        return Err(Error::new(
            "remap_roughness (pbrt-v4's α = √roughness) has no Mitsuba 3 equivalent: give alpha itself",
        ));
    }
    let mut x = format!(
        "{indent}<string name=\"distribution\" value=\"{}\"/>\n",
        escape(r.distribution.as_deref().unwrap_or("beckmann"))
    );
    match (&r.alpha_u, &r.alpha_v) {
        (Some(u), Some(v)) => {
            x += &scalar_xml_at("alpha_u", Some(u), files, indent)?;
            x += &scalar_xml_at("alpha_v", Some(v), files, indent)?;
        }
        _ => {
            x += &scalar_xml_at(
                "alpha",
                Some(r.alpha.as_ref().unwrap_or(&desc::ScalarDesc::Value(0.1))),
                files,
                indent,
            )?
        }
    }
    let _ = writeln!(
        x,
        "{indent}<boolean name=\"sample_visible\" value=\"{}\"/>",
        r.sample_visible.unwrap_or(true)
    );
    Ok(x)
}
