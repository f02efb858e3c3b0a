//! `bench compare`: a candidate run against a baseline run, checkpoint by checkpoint, from
//! their `metrics.csv` files alone.
//!
//! Checkpoints match on scene, strategy label, parameters, budget kind and budget value. For
//! every error metric, Welch's unequal-variance t-test over seeds asks whether the candidate's
//! mean error is larger than the baseline's: a one-sided p below [`ALPHA`] is a regression
//! (below [`ALPHA`] the other way round, an improvement). With one seed on either side there is
//! no variance to test against, and a ratio of means above `1 + `[`REL_THRESHOLD`] is a
//! regression instead. Times are shown for information only: they compare only between runs on
//! the same machine, and never fail a comparison.

use super::rows::{METRICS, Row, group};
use super::stats::{mean, welch};
use crate::error::{Error, Result};
use std::fmt::Write as _;

/// Significance level of the one-sided Welch test.
pub const ALPHA: f64 = 0.01;
/// Relative change of the mean treated as significant when a side has a single seed.
pub const REL_THRESHOLD: f64 = 0.10;

/// What one comparison says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// No significant difference.
    Same,
    /// Candidate error significantly lower.
    Better,
    /// Candidate error significantly higher: a regression.
    Worse,
    /// Not tested (times, or a metric that is not finite).
    Info,
}

impl Verdict {
    fn as_str(self) -> &'static str {
        match self {
            Verdict::Same => "same",
            Verdict::Better => "better",
            Verdict::Worse => "REGRESSION",
            Verdict::Info => "info",
        }
    }
}

/// One metric at one matched checkpoint.
#[derive(Clone, Debug)]
pub struct Line {
    pub checkpoint: String,
    pub metric: &'static str,
    pub baseline_mean: f64,
    pub candidate_mean: f64,
    /// candidate / baseline.
    pub ratio: f64,
    /// One-sided Welch p of "candidate larger"; `None` when not tested by Welch.
    pub p_greater: Option<f64>,
    pub verdict: Verdict,
}

/// Every comparison of two runs.
#[derive(Clone, Debug)]
pub struct Comparison {
    pub lines: Vec<Line>,
    /// Checkpoints found in only one of the runs.
    pub only_baseline: usize,
    pub only_candidate: usize,
}

impl Comparison {
    pub fn regressions(&self) -> usize {
        self.lines.iter().filter(|l| l.verdict == Verdict::Worse).count()
    }
}

fn judge(base: &[f64], cand: &[f64]) -> (Option<f64>, Verdict) {
    let (mb, mc) = (mean(base), mean(cand));
    if !mb.is_finite() || !mc.is_finite() {
        return (None, Verdict::Info);
    }
    match welch(base, cand) {
        Some(w) => {
            let verdict = if w.p_greater < ALPHA {
                Verdict::Worse
            } else if 1.0 - w.p_greater < ALPHA {
                Verdict::Better
            } else {
                Verdict::Same
            };
            (Some(w.p_greater), verdict)
        }
        None => {
            let verdict = if mc > mb * (1.0 + REL_THRESHOLD) {
                Verdict::Worse
            } else if mc * (1.0 + REL_THRESHOLD) < mb {
                Verdict::Better
            } else {
                Verdict::Same
            };
            (None, verdict)
        }
    }
}

/// Compares `candidate` with `baseline`; an error when no checkpoint matches.
pub fn compare(baseline: &[Row], candidate: &[Row]) -> Result<Comparison> {
    let (base, cand) = (group(baseline), group(candidate));
    let key = |g: &super::rows::Group| {
        (
            g.scene.to_string(),
            g.strategy.to_string(),
            g.params.to_string(),
            g.budget.to_string(),
            g.budget_value.to_bits(),
        )
    };
    let mut lines = Vec::new();
    let mut matched = 0;
    for b in &base {
        let Some(c) = cand.iter().find(|c| key(c) == key(b)) else {
            continue;
        };
        matched += 1;
        let checkpoint = format!("{} · {} · {}", b.scene, b.strategy, b.budget_label());
        for metric in METRICS
            .iter()
            .filter(|m| m.error)
            .chain(METRICS.iter().filter(|m| m.name == "total_s"))
        {
            let (bv, cv) = (b.values(metric.get), c.values(metric.get));
            // A column one of the runs did not record (a file older than `flip` or `mse_ldr`).
            if bv.iter().chain(&cv).any(|v| v.is_nan()) && ["flip", "mse_ldr"].contains(&metric.name) {
                continue;
            }
            let (p_greater, verdict) = if metric.error {
                judge(&bv, &cv)
            } else {
                (None, Verdict::Info)
            };
            let (baseline_mean, candidate_mean) = (mean(&bv), mean(&cv));
            lines.push(Line {
                checkpoint: checkpoint.clone(),
                metric: metric.name,
                baseline_mean,
                candidate_mean,
                ratio: candidate_mean / baseline_mean,
                p_greater,
                verdict,
            });
        }
    }
    if matched == 0 {
        return Err(Error::new(
            "no checkpoint of the candidate matches one of the baseline (same scene, strategy, parameters and budget)",
        ));
    }
    Ok(Comparison {
        lines,
        only_baseline: base.len() - matched,
        only_candidate: cand.len() - matched,
    })
}

/// The comparison as a plain-text table, one line per metric and checkpoint.
pub fn table(c: &Comparison) -> String {
    let width = c.lines.iter().map(|l| l.checkpoint.chars().count()).max().unwrap_or(10);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<width$}  {:<16} {:>12} {:>12} {:>8} {:>9}  verdict",
        "checkpoint", "metric", "baseline", "candidate", "ratio", "p"
    );
    for l in &c.lines {
        let p = l.p_greater.map_or("-".to_string(), |p| format!("{p:.4}"));
        let _ = writeln!(
            out,
            "{:<width$}  {:<16} {:>12.4e} {:>12.4e} {:>8.4} {:>9}  {}",
            l.checkpoint,
            l.metric,
            l.baseline_mean,
            l.candidate_mean,
            l.ratio,
            p,
            l.verdict.as_str()
        );
    }
    let _ = writeln!(
        out,
        "{} regression(s) (one-sided Welch t-test over seeds, alpha {ALPHA}; {:.0} % change with one seed); \
         checkpoints only in baseline: {}, only in candidate: {}",
        c.regressions(),
        REL_THRESHOLD * 100.0,
        c.only_baseline,
        c.only_candidate
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn judge_flags_only_significant_increases() {
        let base = [1.0, 1.1, 0.9];
        assert_eq!(judge(&base, &base).1, Verdict::Same);
        assert_eq!(judge(&base, &[2.0, 2.1, 1.9]).1, Verdict::Worse);
        assert_eq!(judge(&base, &[0.5, 0.55, 0.45]).1, Verdict::Better);
        assert_eq!(judge(&base, &[1.05, 1.2, 0.95]).1, Verdict::Same);
        // One seed: a relative threshold.
        assert_eq!(judge(&[1.0], &[1.05]).1, Verdict::Same);
        assert_eq!(judge(&[1.0], &[1.2]).1, Verdict::Worse);
        assert_eq!(judge(&[1.0], &[0.8]).1, Verdict::Better);
        assert_eq!(judge(&[f64::NAN], &[1.0]).1, Verdict::Info);
    }
}
