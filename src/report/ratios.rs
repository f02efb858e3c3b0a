//! Ratios to a baseline strategy (the experiment's `baseline`, else its first): the form in which papers state their headline ("at 500 spp,
//! standard importance sampling has more than 3× the MSE"; "the photon map adds 20 % render
//! time" — Jensen 1995, §5). For every scene, every strategy is set against the baseline
//! (called "first" below) on that scene at the largest checkpoint of each budget kind that both reach:
//! the error ratios first / this (MSE, MSE of the display images, FLIP; > 1: this strategy is
//! better) and the time ratio this / first
//! (preparation included; at equal spp, 1 + the time overhead per sample).
//!
//! Confidence intervals: the seeds of two strategies are independent runs, so each ratio of
//! means r = m₁/m₂ gets the delta-method interval on the log scale,
//! exp(ln r ± t · √(s₁²/(n₁m₁²) + s₂²/(n₂m₂²))), with t the Student quantile for the
//! Welch–Satterthwaite degrees of freedom of those two variance terms. It needs two seeds or
//! more on both sides.

use super::rows::{BUDGET_SECONDS, BUDGET_SPP, Group, Row, budget_label, distinct, group};
use super::stats::{CONFIDENCE, mean, std_dev, t_quantile};
use crate::error::Result;
use std::fmt::Write as _;
use std::path::Path;

/// A ratio of two means with its confidence interval (`None` with fewer than two seeds).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RatioCi {
    pub ratio: f64,
    pub ci: Option<(f64, f64)>,
}

/// `mean(numerator) / mean(denominator)` with the log-scale delta-method interval.
pub fn ratio_of_means(numerator: &[f64], denominator: &[f64]) -> RatioCi {
    let (m1, m2) = (mean(numerator), mean(denominator));
    let ratio = m1 / m2;
    let (n1, n2) = (numerator.len() as f64, denominator.len() as f64);
    if n1 < 2.0 || n2 < 2.0 || !(m1 > 0.0 && m2 > 0.0) {
        return RatioCi { ratio, ci: None };
    }
    let v1 = std_dev(numerator).powi(2) / (n1 * m1 * m1);
    let v2 = std_dev(denominator).powi(2) / (n2 * m2 * m2);
    let se2 = v1 + v2;
    if se2 == 0.0 {
        return RatioCi {
            ratio,
            ci: Some((ratio, ratio)),
        };
    }
    let df = se2 * se2 / (v1 * v1 / (n1 - 1.0) + v2 * v2 / (n2 - 1.0));
    let half = t_quantile(0.5 + CONFIDENCE / 2.0, df) * se2.sqrt();
    RatioCi {
        ratio,
        ci: Some((ratio * (-half).exp(), ratio * half.exp())),
    }
}

/// One strategy against the first at one checkpoint.
#[derive(Clone, Debug, PartialEq)]
pub struct Ratio {
    pub scene: String,
    pub baseline: String,
    pub strategy: String,
    pub budget: String,
    pub budget_value: f64,
    pub seeds: (usize, usize),
    /// MSE of the first / MSE of this strategy.
    pub mse: RatioCi,
    /// FLIP of the first / FLIP of this strategy (`None` for runs without the column).
    pub flip: Option<RatioCi>,
    /// MSE of the display images, first / this (`None` for runs without the column).
    pub mse_ldr: Option<RatioCi>,
    /// Total time (preparation + rendering) of this strategy / of the first.
    pub time: RatioCi,
}

/// The ratios of every scene's strategies to `baseline` where the scene has it, else to its
/// first strategy (module doc).
pub fn ratios(rows: &[Row], baseline: Option<&str>) -> Vec<Ratio> {
    let groups = group(rows);
    let mut out = Vec::new();
    for scene in distinct(rows, |r| &r.scene) {
        let in_scene: Vec<&Group> = groups.iter().filter(|g| g.scene == scene).collect();
        let chosen = baseline.and_then(|b| in_scene.iter().find(|g| g.strategy == b));
        let Some(first) = chosen.or(in_scene.first()).map(|g| g.strategy) else {
            continue;
        };
        for budget in [BUDGET_SPP, BUDGET_SECONDS] {
            let at = |strategy: &str| -> Vec<&Group> {
                in_scene
                    .iter()
                    .copied()
                    .filter(|g| g.strategy == strategy && g.budget == budget)
                    .collect()
            };
            let baseline = at(first);
            for strategy in distinct(rows, |r| &r.strategy).into_iter().filter(|&s| s != first) {
                let candidate = at(strategy);
                let largest_shared = candidate
                    .iter()
                    .filter(|c| baseline.iter().any(|b| b.budget_value == c.budget_value))
                    .max_by(|a, b| a.budget_value.total_cmp(&b.budget_value));
                let Some(c) = largest_shared else { continue };
                let b = baseline
                    .iter()
                    .find(|b| b.budget_value == c.budget_value)
                    .expect("shared");
                let optional = |get: fn(&Row) -> f64| {
                    let known = b.rows.iter().chain(&c.rows).all(|r| !get(r).is_nan());
                    known.then(|| ratio_of_means(&b.values(get), &c.values(get)))
                };
                out.push(Ratio {
                    scene: scene.to_string(),
                    baseline: first.to_string(),
                    strategy: strategy.to_string(),
                    budget: budget.to_string(),
                    budget_value: c.budget_value,
                    seeds: (b.rows.len(), c.rows.len()),
                    mse: ratio_of_means(&b.values(|r| r.mse), &c.values(|r| r.mse)),
                    flip: optional(|r| r.flip),
                    mse_ldr: optional(|r| r.mse_ldr),
                    time: ratio_of_means(&c.values(|r| r.total_s), &b.values(|r| r.total_s)),
                });
            }
        }
    }
    out
}

fn cell(r: &RatioCi) -> String {
    match r.ci {
        Some((lo, hi)) => format!("{:.3} [{lo:.3}, {hi:.3}]", r.ratio),
        None => format!("{:.3}", r.ratio),
    }
}

/// The ratios of `scene` as a markdown section (empty when there are none).
pub fn markdown(ratios: &[Ratio], scene: &str) -> String {
    let mine: Vec<&Ratio> = ratios.iter().filter(|r| r.scene == scene).collect();
    let Some(first) = mine.first() else {
        return String::new();
    };
    let mut md = String::new();
    let _ = writeln!(
        md,
        "### ratios to `{}`\n\nAt the largest checkpoint both reach: error of `{}` / error of the strategy (> 1: the \
         strategy is better) and time of the strategy / time of `{}` (preparation included), with {:.0} % \
         confidence intervals (log-scale delta method, Welch degrees of freedom).\n",
        first.baseline,
        first.baseline,
        first.baseline,
        CONFIDENCE * 100.0
    );
    let _ = writeln!(
        md,
        "| strategy | budget | seeds | MSE ratio | display MSE ratio | FLIP ratio | time ratio |\n|---|---:|---:|---:|---:|---:|---:|"
    );
    for r in mine {
        let _ = writeln!(
            md,
            "| {} | {} | {}/{} | {} | {} | {} | {} |",
            r.strategy,
            budget_label(&r.budget, r.budget_value),
            r.seeds.0,
            r.seeds.1,
            cell(&r.mse),
            r.mse_ldr.as_ref().map_or("–".to_string(), cell),
            r.flip.as_ref().map_or("–".to_string(), cell),
            cell(&r.time)
        );
    }
    let _ = writeln!(md);
    md
}

/// `ratios.csv`: one row per ratio, intervals as lo/hi columns (empty without one).
pub fn write_csv(ratios: &[Ratio], dir: &Path) -> Result<()> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let header = [
        "scene",
        "baseline",
        "strategy",
        "budget",
        "budget_value",
        "seeds_baseline",
        "seeds",
        "mse_ratio",
        "mse_ratio_lo",
        "mse_ratio_hi",
        "mse_ldr_ratio",
        "mse_ldr_ratio_lo",
        "mse_ldr_ratio_hi",
        "flip_ratio",
        "flip_ratio_lo",
        "flip_ratio_hi",
        "time_ratio",
        "time_ratio_lo",
        "time_ratio_hi",
    ];
    let io = |e: csv::Error| crate::error::Error::new(format!("ratios.csv: {e}"));
    w.write_record(header).map_err(io)?;
    let cols = |r: Option<&RatioCi>| -> [String; 3] {
        match r {
            None => Default::default(),
            Some(r) => {
                let (lo, hi) =
                    r.ci.map_or((String::new(), String::new()), |(l, h)| (l.to_string(), h.to_string()));
                [r.ratio.to_string(), lo, hi]
            }
        }
    };
    for r in ratios {
        let mut rec = vec![
            r.scene.clone(),
            r.baseline.clone(),
            r.strategy.clone(),
            r.budget.clone(),
            r.budget_value.to_string(),
            r.seeds.0.to_string(),
            r.seeds.1.to_string(),
        ];
        rec.extend(cols(Some(&r.mse)));
        rec.extend(cols(r.mse_ldr.as_ref()));
        rec.extend(cols(r.flip.as_ref()));
        rec.extend(cols(Some(&r.time)));
        w.write_record(&rec).map_err(io)?;
    }
    let bytes = w
        .into_inner()
        .map_err(|e| crate::error::Error::new(format!("ratios.csv: {e}")))?;
    crate::util::write_atomic(&dir.join("ratios.csv"), &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratio_of_means_and_its_interval() {
        // Equal relative spreads on both sides: se² = 2 · (s/m)² / n.
        let a = [2.0, 4.0, 6.0];
        let b = [1.0, 2.0, 3.0];
        let r = ratio_of_means(&a, &b);
        assert_eq!(r.ratio, 2.0);
        let (lo, hi) = r.ci.unwrap();
        // ln-scale half width: t(0.975, df = 4) · √(2 · 0.25 / 3) = 2.776445 · 0.408248.
        let half = 2.776445f64 * (2.0f64 * 0.25 / 3.0).sqrt();
        assert!(
            (lo - 2.0 * (-half).exp()).abs() < 1e-5 && (hi - 2.0 * half.exp()).abs() < 1e-5,
            "{lo} {hi}"
        );
        // Symmetric on the log scale, so r/lo = hi/r.
        assert!((2.0 / lo - hi / 2.0).abs() < 1e-9);
        assert_eq!(ratio_of_means(&[3.0], &[1.5]), RatioCi { ratio: 2.0, ci: None });
        assert_eq!(ratio_of_means(&[3.0, 3.0], &[1.5, 1.5]).ci, Some((2.0, 2.0)));
    }

    #[test]
    fn every_strategy_against_the_first_at_the_largest_shared_checkpoint() {
        let row = |strategy: &str, seed: u64, spp: f64, mse: f64, total_s: f64| Row {
            scene: "s".into(),
            strategy: strategy.into(),
            seed,
            budget: BUDGET_SPP.into(),
            budget_value: spp,
            mse,
            total_s,
            flip: f64::NAN,
            mse_ldr: f64::NAN,
            ..Row::default()
        };
        let mut rows = Vec::new();
        for seed in 0..2 {
            for spp in [1.0, 10.0, 100.0] {
                rows.push(row("standard", seed, spp, 1.0 / spp, spp));
            }
            // The guided method stops at 10 spp: the ratio is taken there.
            for spp in [1.0, 10.0] {
                rows.push(row("guided", seed, spp, 0.25 / spp, 1.2 * spp + seed as f64 * 0.1));
            }
        }
        let r = ratios(&rows, None);
        assert_eq!(r.len(), 1);
        assert_eq!(
            (r[0].baseline.as_str(), r[0].strategy.as_str(), r[0].budget_value),
            ("standard", "guided", 10.0)
        );
        assert!((r[0].mse.ratio - 4.0).abs() < 1e-12);
        assert!((r[0].time.ratio - 12.05 / 10.0).abs() < 1e-12);
        assert!(r[0].flip.is_none());
        let md = markdown(&r, "s");
        assert!(
            md.contains("| guided | 10 spp | 2/2 | 4.000 [4.000, 4.000] | – |"),
            "{md}"
        );

        // A chosen baseline turns the ratios around; one the scene lacks falls back to the first.
        let r = ratios(&rows, Some("guided"));
        assert_eq!((r[0].baseline.as_str(), r[0].strategy.as_str()), ("guided", "standard"));
        assert!((r[0].mse.ratio - 0.25).abs() < 1e-12);
        assert_eq!(ratios(&rows, Some("absent"))[0].baseline, "standard");
    }
}
