//! Christensen 1999's comparison, from the rows and images of a run: every `photon_map`
//! variant that accelerates the final gather (precomputed irradiance, irradiance caching)
//! against the variant with direct photon-map lookups and otherwise equal parameters, at every
//! equal-samples checkpoint of every seed: photons, bytes per photon, phase timings,
//! final-gather time and speed-up, the precomputation as a percentage of the time it saved,
//! gather rays and density estimates, and the MSE between the two images beside each one's MSE
//! to the reference [Christensen 1999, §4: 5.8× faster final gathering, precomputation < 2 %
//! of the time saved, images indistinguishable].
//!
//! Written as `final_gather.csv` and as a table in `summary.md` and `index.html`. Every number
//! comes from the rows (`render_s` is the final-gather time: rendering is final gathering plus
//! a few camera rays, light samples and caustic lookups) and the checkpoint images.

use super::rows::{BUDGET_SPP, Row, counter};
use crate::error::{Context, Result};
use crate::film::read_exr;
use serde::Serialize;
use std::path::Path;

/// Parameters that select how gather hits are shaded (everything else must match for a
/// variant to be compared with a direct-lookup run).
fn is_acceleration(key: &str) -> bool {
    key.starts_with("precomputed_") || key.starts_with("irradiance_cache")
}

/// Preparation phases that only an accelerated variant runs.
const PRECOMPUTE_PHASES: &[&str] = &["irradiance_precompute", "irradiance_cache"];

/// The parameters without the acceleration keys, and whether every acceleration key is off.
fn split_params(params: &str) -> (String, bool) {
    let mut kept = Vec::new();
    let mut direct = true;
    for entry in params.split(';') {
        let (key, value) = entry.split_once('=').unwrap_or((entry, ""));
        if is_acceleration(key) {
            direct &= value == "none";
        } else {
            kept.push(entry);
        }
    }
    (kept.join(";"), direct)
}

/// One accelerated variant against direct lookups: one scene, seed and spp checkpoint.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Comparison {
    pub scene: String,
    pub seed: u64,
    pub spp: u32,
    /// The accelerated variant's label and the direct-lookup variant's.
    pub variant: String,
    pub direct: String,
    pub global_photons: f64,
    pub caustic_photons: f64,
    pub bytes_per_photon: f64,
    /// Bytes of every map (records and kd-tree axes), direct-lookup run and variant.
    pub map_bytes_direct: f64,
    pub map_bytes_variant: f64,
    pub photon_trace_s: f64,
    pub kdtree_build_s: f64,
    /// The variant's own preparation (irradiance precomputation or cache filling), seconds.
    pub precompute_s: f64,
    /// Final-gather (rendering) time of each, seconds.
    pub gather_s_direct: f64,
    pub gather_s_variant: f64,
    /// gather_s_direct / gather_s_variant.
    pub speedup: f64,
    /// precompute_s / (gather_s_direct − gather_s_variant) × 100 (NaN if nothing was saved).
    pub precompute_pct_of_saved: f64,
    pub gather_rays_direct: f64,
    pub gather_rays_variant: f64,
    /// Photon-map density estimates: at gather hits (`map_estimates`) plus, for the variant,
    /// those of the precomputation (`irradiance_photons`).
    pub estimates_direct: f64,
    pub estimates_variant: f64,
    /// Precomputed-irradiance lookups of the variant.
    pub irradiance_lookups: f64,
    /// Final gathers of each (camera-path gathers, with the cache's records included).
    pub final_gathers_direct: f64,
    pub final_gathers_variant: f64,
    /// MSE between the two images, and each one's MSE to the reference.
    pub mse_between: f64,
    pub mse_direct: f64,
    pub mse_variant: f64,
}

/// Every comparison a run's rows allow, in row order; images are read from `dir`.
pub fn comparisons(rows: &[Row], dir: &Path) -> Result<Vec<Comparison>> {
    let photon_map = |r: &&Row| r.kind == "photon_map" && r.budget == BUDGET_SPP;
    let mut out = Vec::new();
    for v in rows.iter().filter(photon_map) {
        let (key, direct) = split_params(&v.params);
        if direct {
            continue;
        }
        let Some(d) = rows.iter().filter(photon_map).find(|d| {
            let (other, direct) = split_params(&d.params);
            direct
                && other == key
                && d.scene == v.scene
                && d.seed == v.seed
                && d.budget_value.to_bits() == v.budget_value.to_bits()
        }) else {
            continue;
        };
        let read = |r: &Row| read_exr(&dir.join(&r.image)).map_err(|e| e.context(dir.join(&r.image).display()));
        let between = crate::metrics::compare(&read(v)?, &read(d)?).context(&v.image)?.mse;
        let c = |r: &Row, name: &str| counter(r, name).unwrap_or(f64::NAN);
        let phase = |r: &Row, names: &[&str]| -> f64 {
            r.phases()
                .iter()
                .filter(|(n, _)| names.contains(n))
                .map(|(_, s)| s)
                .sum()
        };
        let precompute_s = phase(v, PRECOMPUTE_PHASES);
        let saved_s = d.render_s - v.render_s;
        out.push(Comparison {
            scene: v.scene.clone(),
            seed: v.seed,
            spp: v.spp,
            variant: v.strategy.clone(),
            direct: d.strategy.clone(),
            global_photons: c(v, "global_photons"),
            caustic_photons: c(v, "caustic_photons"),
            bytes_per_photon: c(v, "bytes_per_photon"),
            map_bytes_direct: c(d, "photon_map_bytes"),
            map_bytes_variant: c(v, "photon_map_bytes"),
            photon_trace_s: phase(v, &["photon_trace"]),
            kdtree_build_s: phase(v, &["kdtree_build"]),
            precompute_s,
            gather_s_direct: d.render_s,
            gather_s_variant: v.render_s,
            speedup: d.render_s / v.render_s,
            precompute_pct_of_saved: if saved_s > 0.0 {
                100.0 * precompute_s / saved_s
            } else {
                f64::NAN
            },
            gather_rays_direct: c(d, "gather_rays"),
            gather_rays_variant: c(v, "gather_rays"),
            estimates_direct: c(d, "map_estimates"),
            estimates_variant: c(v, "map_estimates") + counter(v, "irradiance_photons").unwrap_or(0.0),
            irradiance_lookups: c(v, "irradiance_lookups"),
            final_gathers_direct: c(d, "final_gathers"),
            final_gathers_variant: c(v, "final_gathers"),
            mse_between: between,
            mse_direct: d.mse,
            mse_variant: v.mse,
        });
    }
    Ok(out)
}

/// Writes `final_gather.csv` into `dir` (nothing when there is no comparison).
pub fn write_csv(comparisons: &[Comparison], dir: &Path) -> Result<()> {
    if comparisons.is_empty() {
        return Ok(());
    }
    let path = dir.join("final_gather.csv");
    crate::util::write_atomic_with(&path, |tmp| {
        let mut w = csv::Writer::from_path(tmp).context(tmp.display())?;
        for c in comparisons {
            w.serialize(c).context(path.display())?;
        }
        w.flush().context(path.display())
    })
}

/// Mean over seeds of one field, for the comparisons of one (scene, variant, spp).
fn mean(of: &[&Comparison], get: fn(&Comparison) -> f64) -> f64 {
    super::stats::mean(&of.iter().map(|c| get(c)).collect::<Vec<_>>())
}

/// A number for the tables: four significant digits, scientific when small or large.
fn num(v: f64) -> String {
    if v.is_nan() {
        "–".into()
    } else if v == 0.0 || (1e-2..1e5).contains(&v.abs()) {
        format!("{v:.4}")
    } else {
        format!("{v:.3e}")
    }
}

/// Comparisons grouped by (scene, variant, spp), in first-seen order.
fn grouped(comparisons: &[Comparison]) -> Vec<Vec<&Comparison>> {
    let mut out: Vec<Vec<&Comparison>> = Vec::new();
    for c in comparisons {
        let same = |g: &&mut Vec<&Comparison>| g[0].scene == c.scene && g[0].variant == c.variant && g[0].spp == c.spp;
        match out.iter_mut().find(same) {
            Some(g) => g.push(c),
            None => out.push(vec![c]),
        }
    }
    out
}

/// The comparison tables of one scene as (header, rows of cells); empty when there is none.
/// Means over seeds.
pub fn tables(comparisons: &[Comparison], scene: &str) -> Vec<(Vec<&'static str>, Vec<Vec<String>>)> {
    let groups: Vec<Vec<&Comparison>> = grouped(comparisons)
        .into_iter()
        .filter(|g| g[0].scene == scene)
        .collect();
    if groups.is_empty() {
        return Vec::new();
    }
    let lead = |g: &[&Comparison]| {
        vec![
            g[0].variant.clone(),
            g[0].direct.clone(),
            g[0].spp.to_string(),
            g.len().to_string(),
        ]
    };
    let int = |v: f64| if v.is_nan() { "–".into() } else { format!("{v:.0}") };
    let timing = groups
        .iter()
        .map(|g| {
            let mut cells = lead(g);
            cells.extend([
                format!(
                    "{} + {}",
                    int(mean(g, |c| c.global_photons)),
                    int(mean(g, |c| c.caustic_photons))
                ),
                int(mean(g, |c| c.bytes_per_photon)),
                format!(
                    "{} / {}",
                    num(mean(g, |c| c.map_bytes_direct) / 1e6),
                    num(mean(g, |c| c.map_bytes_variant) / 1e6)
                ),
                num(mean(g, |c| c.photon_trace_s)),
                num(mean(g, |c| c.kdtree_build_s)),
                num(mean(g, |c| c.precompute_s)),
                format!(
                    "{} / {}",
                    num(mean(g, |c| c.gather_s_direct)),
                    num(mean(g, |c| c.gather_s_variant))
                ),
                format!(
                    "{:.2}×",
                    mean(g, |c| c.gather_s_direct) / mean(g, |c| c.gather_s_variant)
                ),
                num(mean(g, |c| c.precompute_pct_of_saved)),
            ]);
            cells
        })
        .collect();
    let work = groups
        .iter()
        .map(|g| {
            let mut cells = lead(g);
            cells.extend([
                format!(
                    "{} / {}",
                    int(mean(g, |c| c.gather_rays_direct)),
                    int(mean(g, |c| c.gather_rays_variant))
                ),
                format!(
                    "{} / {}",
                    int(mean(g, |c| c.final_gathers_direct)),
                    int(mean(g, |c| c.final_gathers_variant))
                ),
                format!(
                    "{} / {}",
                    int(mean(g, |c| c.estimates_direct)),
                    int(mean(g, |c| c.estimates_variant))
                ),
                int(mean(g, |c| c.irradiance_lookups)),
                num(mean(g, |c| c.mse_between)),
                num(mean(g, |c| c.mse_direct)),
                num(mean(g, |c| c.mse_variant)),
                num(mean(g, |c| c.mse_between) / mean(g, |c| c.mse_direct.min(c.mse_variant))),
            ]);
            cells
        })
        .collect();
    vec![
        (
            vec![
                "variant",
                "vs",
                "spp",
                "n",
                "photons (global + caustic)",
                "bytes / photon",
                "maps MB (direct / variant)",
                "photon trace s",
                "kd-tree s",
                "precompute s",
                "final gather s (direct / variant)",
                "speed-up",
                "precompute % of time saved",
            ],
            timing,
        ),
        (
            vec![
                "variant",
                "vs",
                "spp",
                "n",
                "gather rays (direct / variant)",
                "final gathers (direct / variant)",
                "density estimates (direct / variant)",
                "irradiance lookups",
                "MSE between images",
                "MSE direct → ref",
                "MSE variant → ref",
                "between / min to ref",
            ],
            work,
        ),
    ]
}

/// The comparison of one scene as markdown, or an empty string.
pub fn markdown(comparisons: &[Comparison], scene: &str) -> String {
    let mut md = String::new();
    let tables = tables(comparisons, scene);
    if tables.is_empty() {
        return md;
    }
    md += "### final gathering: accelerated vs direct lookups\n\n\
           Christensen 1999's comparison (mean over seeds; `final_gather.csv` has every seed). \
           Final-gather time is the rendering time; the speed-up is its ratio; the precomputation \
           (irradiance precompute or cache filling) as a percentage of the rendering time it saved; \
           density estimates include the precomputation's.\n\n";
    for (header, rows) in tables {
        md += &format!("| {} |\n|{}\n", header.join(" | "), "---|".repeat(header.len()));
        for r in rows {
            md += &format!("| {} |\n", r.join(" | "));
        }
        md += "\n";
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn acceleration_keys_are_split_off() {
        let direct = "photons=100;gather_rays=64;precomputed_every=none;precomputed_normal_dot=none";
        let pre = "photons=100;gather_rays=64;precomputed_every=4;precomputed_normal_dot=0.9";
        assert_eq!(split_params(direct), ("photons=100;gather_rays=64".to_string(), true));
        assert_eq!(split_params(pre), ("photons=100;gather_rays=64".to_string(), false));
        let cached = "photons=100;precomputed_every=none;irradiance_cache_error=0.2";
        assert_eq!(split_params(cached), ("photons=100".to_string(), false));
        assert!(split_params("photons=100;irradiance_cache_error=none").1);
    }

    #[test]
    fn numbers_read_well() {
        assert_eq!(num(f64::NAN), "–");
        assert_eq!(num(5.8), "5.8000");
        assert_eq!(num(1.1e-7), "1.100e-7");
    }
}
