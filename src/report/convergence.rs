//! Convergence plots and the run summary, drawn from result rows alone (so they can be
//! redrawn from `metrics.csv`).

use super::bars::{Bar, Stack, bar_chart, stacked_bar_chart};
use super::chart::{Line, Styles};
use super::plot::{LogLogPlot, Series, log_log_plot};
use super::rows::{BUDGET_SECONDS, BUDGET_SPP, Group, METRICS, Metric, Row, distinct, group};
use super::stats::{CONFIDENCE, Summary};
use crate::error::{Context, Error, Result};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// Lower ends of confidence bands are clipped to this fraction of the mean on log axes.
pub const BAND_FLOOR: f64 = 0.01;

/// The metrics a run plots unless `bench plot --metric` names others: the MSE, the relative
/// MSE (insensitive to the image's brightness) and FLIP (what a viewer sees).
pub const PLOTTED_METRICS: [&str; 3] = ["mse", "rel_mse", "flip"];

/// The metric called `name` ([`METRICS`]), or an error listing the known names.
pub fn metric_named(name: &str) -> Result<&'static Metric> {
    METRICS.iter().find(|m| m.name == name).ok_or_else(|| {
        let known: Vec<&str> = METRICS.iter().map(|m| m.name).collect();
        Error::new(format!(
            "--metric: unknown metric `{name}`; expected one of {}",
            known.join(", ")
        ))
    })
}

/// How a metric is written on an axis and in a title.
fn axis_name(metric: &str) -> &str {
    match metric {
        "mse" => "MSE",
        "rmse" => "RMSE",
        "rel_mse" => "relMSE",
        "mse_trimmed" => "MSE (trimmed)",
        "rel_mse_trimmed" => "relMSE (trimmed)",
        "rms_rel_lum" => "RMS relative luminance error",
        "flip" => "FLIP",
        "mse_ldr" => "MSE (tone-mapped, 8 bit)",
        other => other,
    }
}

/// Per strategy (in the run's order), `(x, mean)` points and `(x, CI low, CI high)` band rows.
type Curves<'a> = BTreeMap<usize, (&'a str, Vec<(f64, f64)>, Vec<(f64, f64, f64)>)>;

fn add_point<'a>(curves: &mut Curves<'a>, order: usize, label: &'a str, x: f64, values: &[f64]) {
    let m = Summary::of(values);
    let entry = curves.entry(order).or_insert_with(|| (label, Vec::new(), Vec::new()));
    entry.1.push((x, m.mean));
    if let Some((lo, hi)) = m.ci {
        // Log-scale intervals stay above zero; the floor only guards a degenerate spread.
        entry.2.push((x, lo.max(m.mean * BAND_FLOOR), hi));
    }
}

fn series(curves: Curves, styles: &Styles, line: Line) -> Vec<Series> {
    curves
        .into_values()
        .map(|(label, points, band)| Series {
            label: label.to_string(),
            style: styles.of(label, line),
            points,
            band: (!band.is_empty()).then_some(band),
        })
        .collect()
}

/// The distinct budget values of `scene`'s checkpoints of `budget`.
fn checkpoints(groups: &[Group], scene: &str, budget: &str) -> Vec<f64> {
    let mut v: Vec<f64> = groups
        .iter()
        .filter(|g| g.scene == scene && g.budget == budget)
        .map(|g| g.budget_value)
        .collect();
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

/// Every plot of a run, from its rows alone, for the [`PLOTTED_METRICS`]. See
/// [`write_plots_of`].
pub fn write_plots(rows: &[Row], dir: &Path) -> Result<()> {
    let metrics: Vec<&Metric> = PLOTTED_METRICS.iter().map(|m| metric_named(m)).collect::<Result<_>>()?;
    write_plots_of(rows, dir, &metrics)
}

/// Every plot of a run for `metrics`, from its rows alone. Per scene and metric: the metric
/// against spp and against seconds (log–log; mean over seeds with its [`CONFIDENCE`] interval
/// as a band; one line per strategy; x ticks at the checkpoints) as
/// `plots/<scene>_<metric>_vs_spp.{svg,png}` and `plots/<scene>_<metric>_vs_time.{svg,png}`,
/// and the bar charts at the largest checkpoints (`<scene>_<metric>_equal_time`,
/// `<scene>_<metric>_equal_spp`); then the time per phase (`<scene>_timing`). Equal-time
/// checkpoints join the time plot dashed, in their strategy's colour and marker; its legend
/// names each strategy once and then the two line styles. A metric a scene's rows did not record (NaN), or a plot without any point,
/// is left out. One strategy has one style in every plot of the run ([`Styles`]).
pub fn write_plots_of(rows: &[Row], dir: &Path, metrics: &[&Metric]) -> Result<()> {
    let plots = dir.join("plots");
    std::fs::create_dir_all(&plots).context(plots.display())?;
    let groups = group(rows);
    let strategies = distinct(rows, |r| &r.strategy);
    let styles = Styles::new(strategies.iter().copied());
    let order = |label: &str| strategies.iter().position(|s| *s == label).unwrap_or(usize::MAX);
    for scene in distinct(rows, |r| &r.scene) {
        let spp_ticks = checkpoints(&groups, scene, BUDGET_SPP);
        let time_ticks = checkpoints(&groups, scene, BUDGET_SECONDS);
        for metric in metrics {
            let recorded = |g: &&Group| g.scene == scene && g.values(metric.get).iter().any(|v| !v.is_nan());
            if !groups.iter().any(|g| recorded(&g)) {
                continue;
            }
            let (mut vs_spp, mut vs_time, mut equal_time) = (Curves::new(), Curves::new(), Curves::new());
            for g in groups.iter().filter(recorded) {
                let values = g.values(metric.get);
                let time = super::stats::mean(&g.values(|r| r.total_s));
                let k = order(g.strategy);
                if g.budget == BUDGET_SPP {
                    add_point(&mut vs_spp, k, g.strategy, g.budget_value, &values);
                    add_point(&mut vs_time, k, g.strategy, time, &values);
                } else {
                    add_point(&mut equal_time, k, g.strategy, time, &values);
                }
            }
            let name = axis_name(metric.name);
            let title = |what: &str| format!("{scene}: {name} vs {what} (mean, {:.0} % CI)", CONFIDENCE * 100.0);
            let by_spp = series(vs_spp, &styles, Line::Solid);
            if !by_spp.is_empty() {
                log_log_plot(
                    &LogLogPlot {
                        title: &title("samples per pixel"),
                        x_label: "samples per pixel",
                        y_label: name,
                        series: &by_spp,
                        x_ticks: spp_ticks.clone(),
                        line_meaning: None,
                    },
                    &plots.join(format!("{scene}_{}_vs_spp", metric.name)),
                )?;
            }
            let mut by_time = series(vs_time, &styles, Line::Solid);
            by_time.extend(series(equal_time, &styles, Line::Dashed));
            if !by_time.is_empty() {
                log_log_plot(
                    &LogLogPlot {
                        title: &title("time"),
                        x_label: "seconds (preparation + rendering)",
                        y_label: name,
                        series: &by_time,
                        x_ticks: time_ticks.clone(),
                        line_meaning: Some(["equal samples", "equal time"]),
                    },
                    &plots.join(format!("{scene}_{}_vs_time", metric.name)),
                )?;
            }
            write_metric_bars(scene, &groups, metric, &styles, &plots)?;
        }
        write_timing(scene, &groups, &plots)?;
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

/// Bar charts of `metric` on `scene`: mean per strategy with [`CONFIDENCE`] error bars at the
/// largest time budget (`<scene>_<metric>_equal_time`) and at the largest spp checkpoint
/// (`<scene>_<metric>_equal_spp`), in the strategies' colours.
fn write_metric_bars(scene: &str, groups: &[Group], metric: &Metric, styles: &Styles, plots: &Path) -> Result<()> {
    let name = axis_name(metric.name);
    for (budget, file, what) in [
        (BUDGET_SECONDS, "equal_time", "equal time"),
        (BUDGET_SPP, "equal_spp", "equal samples"),
    ] {
        let at = at_largest(scene, groups, budget);
        let Some(first) = at.first() else { continue };
        let bars: Vec<Bar> = at
            .iter()
            .map(|g| {
                let s = Summary::of(&g.values(metric.get));
                Bar {
                    label: g.strategy.to_string(),
                    colour: styles.of(g.strategy, Line::Solid).colour,
                    value: s.mean,
                    error: s.ci,
                }
            })
            .collect();
        bar_chart(
            &format!(
                "{scene}: {name} at {what}, {} (mean, {:.0} % CI)",
                first.budget_label(),
                CONFIDENCE * 100.0
            ),
            name,
            &bars,
            &plots.join(format!("{scene}_{}_{file}", metric.name)),
        )?;
    }
    Ok(())
}

/// The time per phase of `scene`'s strategies, stacked, at the largest spp checkpoint (else
/// the largest time budget) (`<scene>_timing`).
fn write_timing(scene: &str, groups: &[Group], plots: &Path) -> Result<()> {
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
/// ([`super::final_gather`]) to the scenes that have one; `baseline` is the strategy the ratio
/// tables compare with ([`super::ratios`]).
pub fn write_summary(
    name: &str,
    description: &str,
    rows: &[Row],
    baseline: Option<&str>,
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
    let ratios = super::ratios::ratios(rows, baseline);
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
