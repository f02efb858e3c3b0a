//! Convergence plots and the run summary, drawn from result rows alone (so they can be
//! redrawn from `metrics.csv`).

use super::plot::{Series, log_log_plot};
use super::rows::Row;
use crate::error::{Context, Result};
use crate::experiment::Experiment;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// Mean of a metric over seeds for each (scene, strategy, spp), in first-seen order.
struct Aggregate<'a> {
    scene: &'a str,
    strategy: &'a str,
    spp: u32,
    mse: Vec<f64>,
    total_s: Vec<f64>,
}

fn aggregate(rows: &[Row]) -> Vec<Aggregate<'_>> {
    let mut out: Vec<Aggregate> = Vec::new();
    for r in rows {
        match out
            .iter_mut()
            .find(|a| a.scene == r.scene && a.strategy == r.strategy && a.spp == r.spp)
        {
            Some(a) => {
                a.mse.push(r.mse);
                a.total_s.push(r.total_s);
            }
            None => out.push(Aggregate {
                scene: &r.scene,
                strategy: &r.strategy,
                spp: r.spp,
                mse: vec![r.mse],
                total_s: vec![r.total_s],
            }),
        }
    }
    out
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// Sample standard deviation (0 for fewer than two values).
fn std_dev(v: &[f64]) -> f64 {
    if v.len() < 2 {
        return 0.0;
    }
    let m = mean(v);
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
}

/// Scenes in first-seen order.
fn scenes(rows: &[Row]) -> Vec<&str> {
    let mut s: Vec<&str> = Vec::new();
    for r in rows {
        if !s.contains(&r.scene.as_str()) {
            s.push(&r.scene);
        }
    }
    s
}

/// For each scene, MSE vs spp and MSE vs seconds (log-log, mean over seeds, one line per
/// strategy) as `plots/<scene>_mse_vs_spp.{svg,png}` and `plots/<scene>_mse_vs_time.{svg,png}`.
pub fn write_plots(rows: &[Row], dir: &Path) -> Result<()> {
    let plots = dir.join("plots");
    std::fs::create_dir_all(&plots).context(plots.display())?;
    let agg = aggregate(rows);
    for scene in scenes(rows) {
        // Per strategy: (spp, MSE) and (seconds, MSE) points.
        let mut vs_spp: BTreeMap<&str, Vec<(f64, f64)>> = BTreeMap::new();
        let mut vs_time: BTreeMap<&str, Vec<(f64, f64)>> = BTreeMap::new();
        for a in agg.iter().filter(|a| a.scene == scene) {
            vs_spp.entry(a.strategy).or_default().push((a.spp as f64, mean(&a.mse)));
            vs_time
                .entry(a.strategy)
                .or_default()
                .push((mean(&a.total_s), mean(&a.mse)));
        }
        let series = |m: BTreeMap<&str, Vec<(f64, f64)>>| -> Vec<Series> {
            m.into_iter()
                .map(|(label, points)| Series {
                    label: label.to_string(),
                    points,
                    band: None,
                })
                .collect()
        };
        let title = |what: &str| format!("{scene}: MSE vs {what}");
        log_log_plot(
            &title("samples per pixel"),
            "samples per pixel",
            "MSE",
            &series(vs_spp),
            &plots.join(format!("{scene}_mse_vs_spp")),
        )?;
        log_log_plot(
            &title("time"),
            "seconds (preparation + rendering)",
            "MSE",
            &series(vs_time),
            &plots.join(format!("{scene}_mse_vs_time")),
        )?;
    }
    Ok(())
}

/// `summary.md`: per scene, the error and time of every strategy at every checkpoint, as mean
/// ± standard deviation over seeds, and links to the plots.
pub fn write_summary(exp: &Experiment, rows: &[Row], dir: &Path) -> Result<()> {
    let mut md = String::new();
    let first = rows.first();
    let _ = writeln!(md, "# {}\n", exp.name);
    if !exp.description.is_empty() {
        let _ = writeln!(md, "{}\n", exp.description);
    }
    if let Some(r) = first {
        let _ = writeln!(
            md,
            "Run `{}` · git `{}` · {} threads · {}\n",
            r.run_id, r.git_revision, r.threads, r.cpu
        );
    }
    let _ = writeln!(
        md,
        "Seeds: {}. Values are mean ± standard deviation over seeds.\n",
        exp.seeds.len()
    );
    let agg = aggregate(rows);
    for scene in scenes(rows) {
        let _ = writeln!(md, "## {scene}\n");
        let _ = writeln!(
            md,
            "| strategy | spp | MSE | seconds | efficiency 1/(MSE·s) |\n|---|---:|---:|---:|---:|"
        );
        for a in agg.iter().filter(|a| a.scene == scene) {
            let (m, t) = (mean(&a.mse), mean(&a.total_s));
            let _ = writeln!(
                md,
                "| {} | {} | {:.4e} ± {:.1e} | {:.3} ± {:.2} | {:.3e} |",
                a.strategy,
                a.spp,
                m,
                std_dev(&a.mse),
                t,
                std_dev(&a.total_s),
                1.0 / (m * t)
            );
        }
        let _ = writeln!(
            md,
            "\n![MSE vs spp](plots/{scene}_mse_vs_spp.svg) ![MSE vs time](plots/{scene}_mse_vs_time.svg)\n"
        );
    }
    crate::util::write_atomic(&dir.join("summary.md"), md.as_bytes())
}
