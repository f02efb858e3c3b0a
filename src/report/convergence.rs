//! Convergence plots and the run summary, drawn from result rows alone (so they can be
//! redrawn from `metrics.csv`).

use super::bars::{Bar, Stack, bar_chart, stacked_bar_chart};
use super::plot::{Series, log_log_plot};
use super::rows::{BUDGET_SECONDS, BUDGET_SPP, Group, METRICS, Row, distinct, group};
use super::stats::{CONFIDENCE, Summary};
use crate::error::{Context, Result};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// Lower ends of confidence bands are clipped to this fraction of the mean on log axes.
pub const BAND_FLOOR: f64 = 0.01;

/// Per strategy, `(x, mean MSE)` points and `(x, CI low, CI high)` band rows.
type Curves<'a> = BTreeMap<&'a str, (Vec<(f64, f64)>, Vec<(f64, f64, f64)>)>;

fn add_point<'a>(curves: &mut Curves<'a>, label: &'a str, x: f64, g: &Group) {
    let mse = Summary::of(&g.values(|r| r.mse));
    let entry = curves.entry(label).or_default();
    entry.0.push((x, mse.mean));
    if let Some((lo, hi)) = mse.ci {
        // A log axis cannot show a lower bound at or below zero (frequent with two or three
        // seeds): clip it to a hundredth of the mean.
        entry.1.push((x, lo.max(mse.mean * BAND_FLOOR), hi));
    }
}

fn series(curves: Curves, suffix: &str) -> Vec<Series> {
    curves
        .into_iter()
        .map(|(label, (points, band))| Series {
            label: format!("{label}{suffix}"),
            points,
            band: (!band.is_empty()).then_some(band),
        })
        .collect()
}

/// Every plot of a run, from its rows alone. For each scene, MSE vs spp and MSE vs seconds (log-log, mean over seeds with its
/// [`CONFIDENCE`] interval as a band, its lower end clipped to [`BAND_FLOOR`] × the mean, one
/// line per strategy) as
/// `plots/<scene>_mse_vs_spp.{svg,png}` and `plots/<scene>_mse_vs_time.{svg,png}`. Equal-time
/// checkpoints join the time plot as their own lines, marked "(time budget)"; a plot without
/// any point is left out. Then the bar charts of [`write_bar_charts`].
pub fn write_plots(rows: &[Row], dir: &Path) -> Result<()> {
    let plots = dir.join("plots");
    std::fs::create_dir_all(&plots).context(plots.display())?;
    let groups = group(rows);
    for scene in distinct(rows, |r| &r.scene) {
        let (mut vs_spp, mut vs_time, mut equal_time) = (Curves::new(), Curves::new(), Curves::new());
        for g in groups.iter().filter(|g| g.scene == scene) {
            let time = super::stats::mean(&g.values(|r| r.total_s));
            if g.budget == BUDGET_SPP {
                add_point(&mut vs_spp, g.strategy, g.budget_value, g);
                add_point(&mut vs_time, g.strategy, time, g);
            } else {
                add_point(&mut equal_time, g.strategy, time, g);
            }
        }
        let title = |what: &str| format!("{scene}: MSE vs {what} (mean, {:.0} % CI)", CONFIDENCE * 100.0);
        let by_spp = series(vs_spp, "");
        if !by_spp.is_empty() {
            log_log_plot(
                &title("samples per pixel"),
                "samples per pixel",
                "MSE",
                &by_spp,
                &plots.join(format!("{scene}_mse_vs_spp")),
            )?;
        }
        let mut by_time = series(vs_time, "");
        by_time.extend(series(equal_time, " (time budget)"));
        if !by_time.is_empty() {
            log_log_plot(
                &title("time"),
                "seconds (preparation + rendering)",
                "MSE",
                &by_time,
                &plots.join(format!("{scene}_mse_vs_time")),
            )?;
        }
        write_bar_charts(scene, &groups, &plots)?;
    }
    Ok(())
}

/// The groups of `scene` at its largest checkpoint of `budget`, if it has any.
fn at_largest<'g, 'a>(scene: &str, groups: &'g [Group<'a>], budget: &str) -> Vec<&'g Group<'a>> {
    let of_budget = || groups.iter().filter(|g| g.scene == scene && g.budget == budget);
    let Some(largest) = of_budget().map(|g| g.budget_value).reduce(f64::max) else {
        return Vec::new();
    };
    of_budget().filter(|g| g.budget_value == largest).collect()
}

/// Bar charts of `scene`: mean MSE per strategy with [`CONFIDENCE`] error bars at the largest
/// time budget (`<scene>_mse_equal_time`) and at the largest spp checkpoint
/// (`<scene>_mse_equal_spp`), and the time per phase, stacked, at the largest spp checkpoint
/// (else the largest time budget) (`<scene>_timing`).
fn write_bar_charts(scene: &str, groups: &[Group], plots: &Path) -> Result<()> {
    for (budget, file, what) in [
        (BUDGET_SECONDS, "mse_equal_time", "equal time"),
        (BUDGET_SPP, "mse_equal_spp", "equal samples"),
    ] {
        let at = at_largest(scene, groups, budget);
        let Some(first) = at.first() else { continue };
        let bars: Vec<Bar> = at
            .iter()
            .map(|g| {
                let s = Summary::of(&g.values(|r| r.mse));
                Bar {
                    label: g.strategy.to_string(),
                    value: s.mean,
                    error: s.ci,
                }
            })
            .collect();
        bar_chart(
            &format!(
                "{scene}: MSE at {what}, {} (mean, {:.0} % CI)",
                first.budget_label(),
                CONFIDENCE * 100.0
            ),
            "MSE",
            &bars,
            &plots.join(format!("{scene}_{file}")),
        )?;
    }

    let mut at = at_largest(scene, groups, BUDGET_SPP);
    if at.is_empty() {
        at = at_largest(scene, groups, BUDGET_SECONDS);
    }
    let Some(first) = at.first() else { return Ok(()) };
    let mut names: Vec<String> = Vec::new();
    for g in &at {
        for r in &g.rows {
            for (name, _) in r.phases() {
                if !names.iter().any(|n| n == name) {
                    names.push(name.to_string());
                }
            }
        }
    }
    names.push("render".to_string());
    let stacks: Vec<Stack> = at
        .iter()
        .map(|g| {
            let values = names
                .iter()
                .map(|name| {
                    let per_seed: Vec<f64> = g
                        .rows
                        .iter()
                        .map(|r| {
                            if name == "render" {
                                r.render_s
                            } else {
                                r.phases().iter().filter(|(n, _)| n == name).map(|(_, s)| s).sum()
                            }
                        })
                        .collect();
                    super::stats::mean(&per_seed)
                })
                .collect();
            Stack {
                label: g.strategy.to_string(),
                values,
            }
        })
        .collect();
    stacked_bar_chart(
        &format!("{scene}: time per phase at {} (mean over seeds)", first.budget_label()),
        "seconds",
        &names,
        &stacks,
        &plots.join(format!("{scene}_timing")),
    )
}

/// A number in a table: four significant digits, scientific outside 0.01 … 10 000.
fn num(v: f64) -> String {
    if v == 0.0 || (1e-2..1e4).contains(&v.abs()) {
        format!("{v:.4}")
    } else {
        format!("{v:.3e}")
    }
}

/// `summary.md`: per scene and metric, every strategy at every checkpoint as mean, standard
/// deviation and [`CONFIDENCE`] Student-t interval over seeds, and links to the plots.
/// `gathers` adds Christensen's comparison of final-gathering variants
/// ([`super::final_gather`]) to the scenes that have one.
pub fn write_summary(
    name: &str,
    description: &str,
    rows: &[Row],
    gathers: &[super::final_gather::Comparison],
    dir: &Path,
) -> Result<()> {
    let mut md = String::new();
    let _ = writeln!(md, "# {name}\n");
    if !description.is_empty() {
        let _ = writeln!(md, "{description}\n");
    }
    if let Some(r) = rows.first() {
        let _ = writeln!(
            md,
            "Run `{}` · git `{}` · {} threads · {}\n",
            r.run_id, r.git_revision, r.threads, r.cpu
        );
    }
    let mut seeds: Vec<u64> = rows.iter().map(|r| r.seed).collect();
    seeds.sort_unstable();
    seeds.dedup();
    let seeds = seeds.len();
    let _ = writeln!(
        md,
        "Seeds per checkpoint: {seeds}. Each cell: mean ± standard deviation over seeds, then the {:.0} % \
         confidence interval of the mean (Student t with n − 1 degrees of freedom, on the log scale by the delta \
         method, so it stays above zero; none for one seed). \
         Budgets: `N spp` (equal samples) or `T s` (equal time, preparation included).\n",
        CONFIDENCE * 100.0
    );
    let groups = group(rows);
    let ratios = super::ratios::ratios(rows);
    for scene in distinct(rows, |r| &r.scene) {
        let _ = writeln!(md, "## {scene}\n");
        let _ = write!(md, "{}", super::ratios::markdown(&ratios, scene));
        for metric in METRICS {
            // A column the run's files did not record (written before `flip` existed).
            if rows
                .iter()
                .filter(|r| r.scene == scene)
                .all(|r| (metric.get)(r).is_nan())
            {
                continue;
            }
            let _ = writeln!(md, "### {}\n", metric.name);
            let _ = writeln!(
                md,
                "| strategy | budget | n | mean ± sd | {:.0} % CI |\n|---|---:|---:|---:|---:|",
                CONFIDENCE * 100.0
            );
            for g in groups.iter().filter(|g| g.scene == scene) {
                let s = Summary::of(&g.values(metric.get));
                let ci =
                    s.ci.map_or("–".to_string(), |(lo, hi)| format!("[{}, {}]", num(lo), num(hi)));
                let _ = writeln!(
                    md,
                    "| {} | {} | {} | {} ± {} | {ci} |",
                    g.strategy,
                    g.budget_label(),
                    s.n,
                    num(s.mean),
                    num(s.std_dev)
                );
            }
            let _ = writeln!(md);
        }
        let _ = write!(md, "{}", super::final_gather::markdown(gathers, scene));
        let _ = write!(md, "{}", super::photons::markdown(rows, scene, dir));
        if let Some(table) = super::counters::table(rows, scene) {
            let _ = writeln!(
                md,
                "### counters\n\nWhat each strategy counted (mean over seeds), at its largest checkpoint of each budget kind.\n"
            );
            let _ = writeln!(md, "{}", table.markdown());
        }
        let has_seconds = groups.iter().any(|g| g.scene == scene && g.budget == BUDGET_SECONDS);
        let has_spp = groups.iter().any(|g| g.scene == scene && g.budget == BUDGET_SPP);
        if has_spp {
            let _ = write!(md, "![MSE vs spp](plots/{scene}_mse_vs_spp.svg) ");
        }
        if has_spp || has_seconds {
            let _ = writeln!(md, "![MSE vs time](plots/{scene}_mse_vs_time.svg)\n");
        }
    }
    crate::util::write_atomic(&dir.join("summary.md"), md.as_bytes())
}
