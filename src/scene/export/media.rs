//! Participating media as Mitsuba 3 `<medium type="homogeneous">` elements, and the references
//! shapes and the sensor make to them.

use super::{Files, escape, matrix, nums};
use crate::error::Result;
use crate::scene::desc::{MediumDesc, PhaseDesc, SceneDesc};
use std::fmt::Write;

/// Every medium of `desc` as a top-level element (before the sensor and the shapes that refer
/// to it); a grid's file keeps its place ([`Files::written`]) and its transform.
pub(super) fn media_xml(desc: &SceneDesc, files: &Files, file: &str) -> Result<String> {
    let mut x = String::new();
    for (name, MediumDesc::Homogeneous(m)) in &desc.media {
        let _ = writeln!(x, "    <medium type=\"homogeneous\" id=\"{}\">", escape(name));
        // Mitsuba reads an <rgb> σ_t as a reflectance (each channel at most 1): a grey one is
        // written as a float, a coloured one divided by its largest channel, which moves into
        // `scale`.
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
        match &m.albedo_grid {
            Some(g) => {
                let _ = writeln!(x, "        <volume name=\"albedo\" type=\"gridvolume\">");
                let _ = writeln!(
                    x,
                    "            <string name=\"filename\" value=\"{}\"/>",
                    escape(&files.written(&g.file).display().to_string())
                );
                let filter = g.filter.as_deref().unwrap_or("trilinear");
                let _ = writeln!(
                    x,
                    "            <string name=\"filter_type\" value=\"{}\"/>",
                    escape(filter)
                );
                let _ = writeln!(
                    x,
                    "            <string name=\"wrap_mode\" value=\"{}\"/>",
                    escape(g.wrap.as_deref().unwrap_or("clamp"))
                );
                let _ = writeln!(
                    x,
                    "            <boolean name=\"use_grid_bbox\" value=\"{}\"/>",
                    g.use_grid_bbox.unwrap_or(false)
                );
                if let Some(t) = &g.to_world {
                    let xf = crate::scene::load::shape_transform(
                        file,
                        &format!("media.{name}.albedo_grid.to_world"),
                        Some(t),
                    )?;
                    x.push_str(&matrix(xf));
                }
                let _ = writeln!(x, "        </volume>");
            }
            None => {
                let _ = writeln!(
                    x,
                    "        <rgb name=\"albedo\" value=\"{}\"/>",
                    nums(&m.albedo.map_or([0.75; 3], |a| a.0))
                );
            }
        }
        let _ = writeln!(
            x,
            "        <boolean name=\"sample_emitters\" value=\"{}\"/>",
            m.sample_emitters.unwrap_or(true)
        );
        match m.phase {
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
