//! Participating media as Mitsuba 3 `<medium type="homogeneous">` elements, and the references
//! shapes and the sensor make to them.

use super::{Files, escape, matrix, nums};
use crate::error::Result;
use crate::scene::desc::{GridDesc, MediumDesc, PhaseDesc, SceneDesc};
use std::fmt::Write;

/// Every medium of `desc` as a top-level element (before the sensor and the shapes that refer
/// to it); a grid's file keeps its place ([`Files::written`]) and its transform.
pub(super) fn media_xml(desc: &SceneDesc, files: &Files, file: &str) -> Result<String> {
    let mut x = String::new();
    for (name, medium) in &desc.media {
        let (albedo, albedo_grid, phase, sample_emitters) = match medium {
            MediumDesc::Homogeneous(m) => (m.albedo, &m.albedo_grid, m.phase, m.sample_emitters),
            MediumDesc::Heterogeneous(m) => (m.albedo, &m.albedo_grid, m.phase, m.sample_emitters),
        };
        match medium {
            MediumDesc::Homogeneous(m) => {
                let _ = writeln!(x, "    <medium type=\"homogeneous\" id=\"{}\">", escape(name));
                // Mitsuba reads an <rgb> σ_t as a reflectance (each channel at most 1): a grey
                // one is written as a float, a coloured one divided by its largest channel,
                // which moves into `scale`.
                let sigma_t = m.sigma_t.map_or([1.0; 3], |s| s.0);
                let largest = sigma_t.iter().copied().fold(0.0, f64::max);
                let scale = m.scale.unwrap_or(1.0);
                if sigma_t.iter().all(|&s| s == sigma_t[0]) || largest == 0.0 {
                    let _ = writeln!(x, "        <float name=\"sigma_t\" value=\"{}\"/>", sigma_t[0]);
                    let _ = writeln!(x, "        <float name=\"scale\" value=\"{scale}\"/>");
                } else {
                    let _ = writeln!(
                        x,
                        "        <rgb name=\"sigma_t\" value=\"{}\"/>",
                        nums(&sigma_t.map(|s| s / largest))
                    );
                    let _ = writeln!(x, "        <float name=\"scale\" value=\"{}\"/>", scale * largest);
                }
            }
            MediumDesc::Heterogeneous(m) => {
                let _ = writeln!(x, "    <medium type=\"heterogeneous\" id=\"{}\">", escape(name));
                x.push_str(&grid_xml("sigma_t", &m.sigma_t_grid, files, file, name)?);
                let _ = writeln!(
                    x,
                    "        <float name=\"scale\" value=\"{}\"/>",
                    m.scale.unwrap_or(1.0)
                );
            }
        }
        match albedo_grid {
            Some(g) => x.push_str(&grid_xml("albedo", g, files, file, name)?),
            None => {
                let _ = writeln!(
                    x,
                    "        <rgb name=\"albedo\" value=\"{}\"/>",
                    nums(&albedo.map_or([0.75; 3], |a| a.0))
                );
            }
        }
        let _ = writeln!(
            x,
            "        <boolean name=\"sample_emitters\" value=\"{}\"/>",
            sample_emitters.unwrap_or(true)
        );
        match phase {
            None | Some(PhaseDesc::Isotropic(_)) => {
                let _ = writeln!(x, "        <phase type=\"isotropic\"/>");
            }
            Some(PhaseDesc::Hg(hg)) => {
                let _ = writeln!(
                    x,
                    "        <phase type=\"hg\">\n            <float name=\"g\" value=\"{}\"/>\n        </phase>",
                    hg.g
                );
            }
        }
        let _ = writeln!(x, "    </medium>");
    }
    Ok(x)
}

/// `<ref name="interior|exterior|medium" id>` lines for the media a shape or the sensor names.
pub(super) fn medium_refs(refs: &[(&str, Option<&str>)], indent: &str) -> String {
    let mut x = String::new();
    for (side, name) in refs {
        if let Some(name) = name {
            let _ = writeln!(x, "{indent}<ref name=\"{side}\" id=\"{}\"/>", escape(name));
        }
    }
    x
}

/// A grid as Mitsuba's `<volume type="gridvolume" name>`, its file where the scene names it.
fn grid_xml(param: &str, g: &GridDesc, files: &Files, file: &str, medium: &str) -> Result<String> {
    let mut x = String::new();
    let _ = writeln!(x, "        <volume name=\"{param}\" type=\"gridvolume\">");
    let written = files.written(&g.file).display().to_string();
    let _ = writeln!(
        x,
        "            <string name=\"filename\" value=\"{}\"/>",
        escape(&written)
    );
    let filter = g.filter.as_deref().unwrap_or("trilinear");
    let _ = writeln!(
        x,
        "            <string name=\"filter_type\" value=\"{}\"/>",
        escape(filter)
    );
    let wrap = g.wrap.as_deref().unwrap_or("clamp");
    let _ = writeln!(x, "            <string name=\"wrap_mode\" value=\"{}\"/>", escape(wrap));
    let bbox = g.use_grid_bbox.unwrap_or(false);
    let _ = writeln!(x, "            <boolean name=\"use_grid_bbox\" value=\"{bbox}\"/>");
    if let Some(t) = &g.to_world {
        let field = format!("media.{medium}.{param}_grid.to_world");
        x.push_str(&matrix(crate::scene::load::shape_transform(file, &field, Some(t))?));
    }
    let _ = writeln!(x, "        </volume>");
    Ok(x)
}
