//! `bench compare --perf`: speed of a candidate perf run against a baseline perf run (both
//! CSV files of `bench perf --experiment … --csv`), case by case, with verdicts that respect
//! the run-to-run noise each run measured.
//!
//! Each case is measured as `repeats` independent prepare + render runs; its spread is
//! (highest − lowest) / median. A case is **slower** when the candidate's speed falls below the
//! baseline's by more than the two spreads together (and at least [`FLOOR`]), **faster** when
//! it rises above it by as much, and **same** otherwise: a single timing never decides.
//!
//! Runs on different machines (CPU model or thread count differ) are compared after dividing
//! by the machine factor, the ratio of the two runs' [`calibration`] rows, and the calibration's
//! own spreads join the tolerance; the raw ratio is printed beside it. Runs on one machine are
//! compared raw. Side-by-side runs of two builds on one machine remain the sharper test.

use super::strategies::{CALIBRATION, StrategyThroughput};
use crate::error::{Context, Result};
use std::path::Path;

/// The smallest relative change ever called a slowdown or a speed-up.
pub const FLOOR: f64 = 0.08;

/// Preparation medians below this many seconds are timer noise and not judged.
const MIN_PREPARE_S: f64 = 0.02;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    Slower,
    Same,
    Faster,
}

/// One measure of one case in both runs.
#[derive(Clone, Debug)]
pub struct PerfChange {
    pub scene: String,
    pub label: String,
    /// `render` (pixel samples per second) or `prepare` (seconds, compared as 1 / seconds).
    pub measure: &'static str,
    pub baseline: f64,
    pub candidate: f64,
    /// Candidate speed / baseline speed (> 1: faster), divided by the machine factor.
    pub speed_ratio: f64,
    /// The same before that division.
    pub raw_ratio: f64,
    /// The relative change the verdict needed: spreads of both runs (and of the calibration
    /// across machines), at least [`FLOOR`].
    pub tolerance: f64,
    pub verdict: Verdict,
}

#[derive(Clone, Debug)]
pub struct PerfComparison {
    /// Candidate calibration / baseline calibration (1 on one machine).
    pub machine_factor: f64,
    pub same_machine: bool,
    pub changes: Vec<PerfChange>,
    /// Cases present in only one of the runs (scene / label).
    pub unmatched: Vec<String>,
}

impl PerfComparison {
    pub fn slowdowns(&self) -> usize {
        self.changes.iter().filter(|c| c.verdict == Verdict::Slower).count()
    }
}

/// Reads a CSV written by `bench perf --experiment … --csv`.
pub fn read_csv(path: &Path) -> Result<Vec<StrategyThroughput>> {
    let mut reader = csv::Reader::from_path(path).context(path.display())?;
    let rows: Vec<StrategyThroughput> = reader
        .deserialize()
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| {
            crate::error::Error::new(format!("{}: {e}; expected a `bench perf --csv` file", path.display()))
        })?;
    if rows.is_empty() {
        crate::bail!("{}: no rows; expected a `bench perf --csv` file", path.display());
    }
    Ok(rows)
}

/// Relative spread of a median and its range.
fn spread(median: f64, lo: f64, hi: f64) -> f64 {
    if median > 0.0 {
        (hi - lo).abs() / median
    } else {
        f64::INFINITY
    }
}

fn key(r: &StrategyThroughput) -> (&str, &str, u32, u32, u32) {
    (&r.scene, &r.label, r.samples, r.width, r.height)
}

/// Each case's latest row.
fn latest(rows: &[StrategyThroughput]) -> Vec<&StrategyThroughput> {
    let mut m: Vec<&StrategyThroughput> = Vec::new();
    for r in rows {
        match m.iter_mut().find(|x| key(x) == key(r)) {
            Some(x) => *x = r,
            None => m.push(r),
        }
    }
    m
}

fn find_calibration<'a>(rows: &[&'a StrategyThroughput]) -> Option<&'a StrategyThroughput> {
    rows.iter().find(|r| r.label == CALIBRATION).copied()
}

/// The case-by-case comparison; the latest row of a case counts when a file holds several.
pub fn compare(baseline: &[StrategyThroughput], candidate: &[StrategyThroughput]) -> Result<PerfComparison> {
    let (base, cand) = (latest(baseline), latest(candidate));
    let machine = |r: &StrategyThroughput| (r.cpu.clone(), r.threads);
    let same_machine = base.first().map(|r| machine(r)) == cand.first().map(|r| machine(r));
    let (machine_factor, machine_spread) = if same_machine {
        (1.0, 0.0)
    } else {
        let (Some(b), Some(c)) = (find_calibration(&base), find_calibration(&cand)) else {
            crate::bail!(
                "the runs come from different machines and one has no {CALIBRATION} row; measure both with `bench perf --experiment`"
            );
        };
        (
            c.pixel_samples_per_s / b.pixel_samples_per_s,
            spread(
                b.pixel_samples_per_s,
                b.pixel_samples_per_s_min,
                b.pixel_samples_per_s_max,
            ) + spread(
                c.pixel_samples_per_s,
                c.pixel_samples_per_s_min,
                c.pixel_samples_per_s_max,
            ),
        )
    };
    let mut changes = Vec::new();
    let mut unmatched = Vec::new();
    for b in base.iter().filter(|r| r.label != CALIBRATION) {
        let Some(c) = cand.iter().find(|c| key(c) == key(b)) else {
            unmatched.push(format!("{} / {} (baseline only)", b.scene, b.label));
            continue;
        };
        let judge = |measure, base: (f64, f64, f64), cand: (f64, f64, f64), speed: fn(f64) -> f64| {
            let raw_ratio = speed(cand.0) / speed(base.0);
            let speed_ratio = raw_ratio / machine_factor;
            let tolerance =
                (spread(base.0, base.1, base.2) + spread(cand.0, cand.1, cand.2) + machine_spread).max(FLOOR);
            let verdict = if speed_ratio < 1.0 - tolerance {
                Verdict::Slower
            } else if speed_ratio > 1.0 + tolerance {
                Verdict::Faster
            } else {
                Verdict::Same
            };
            PerfChange {
                scene: b.scene.clone(),
                label: b.label.clone(),
                measure,
                baseline: base.0,
                candidate: cand.0,
                speed_ratio,
                raw_ratio,
                tolerance,
                verdict,
            }
        };
        changes.push(judge(
            "render",
            (
                b.pixel_samples_per_s,
                b.pixel_samples_per_s_min,
                b.pixel_samples_per_s_max,
            ),
            (
                c.pixel_samples_per_s,
                c.pixel_samples_per_s_min,
                c.pixel_samples_per_s_max,
            ),
            |x| x,
        ));
        if b.prepare_s.max(c.prepare_s) >= MIN_PREPARE_S {
            changes.push(judge(
                "prepare",
                (b.prepare_s, b.prepare_s_min, b.prepare_s_max),
                (c.prepare_s, c.prepare_s_min, c.prepare_s_max),
                |s| 1.0 / s,
            ));
        }
    }
    for c in cand.iter().filter(|r| r.label != CALIBRATION) {
        if !base.iter().any(|b| key(b) == key(c)) {
            unmatched.push(format!("{} / {} (candidate only)", c.scene, c.label));
        }
    }
    if changes.is_empty() {
        crate::bail!("the two perf runs share no case (scene, resolution, label, samples)");
    }
    Ok(PerfComparison {
        machine_factor,
        same_machine,
        changes,
        unmatched,
    })
}

/// The comparison as a plain-text table.
pub fn table(c: &PerfComparison) -> String {
    let mut out = String::new();
    if c.same_machine {
        out.push_str("same machine and thread count: raw ratios\n");
    } else {
        out.push_str(&format!(
            "different machines: ratios divided by the machine factor {:.3} (calibration)\n",
            c.machine_factor
        ));
    }
    out.push_str(&format!(
        "{:<18} {:<28} {:<8} {:>14} {:>14} {:>7} {:>7} {:>6}  verdict\n",
        "scene", "strategy", "measure", "baseline", "candidate", "speed", "raw", "tol"
    ));
    for ch in &c.changes {
        let unit = |v: f64| {
            if ch.measure == "render" {
                format!("{v:.0}/s")
            } else {
                format!("{v:.3} s")
            }
        };
        out.push_str(&format!(
            "{:<18} {:<28} {:<8} {:>14} {:>14} {:>7.3} {:>7.3} {:>5.1}%  {}\n",
            ch.scene,
            ch.label,
            ch.measure,
            unit(ch.baseline),
            unit(ch.candidate),
            ch.speed_ratio,
            ch.raw_ratio,
            100.0 * ch.tolerance,
            match ch.verdict {
                Verdict::Slower => "SLOWER",
                Verdict::Same => "same",
                Verdict::Faster => "faster",
            }
        ));
    }
    for u in &c.unmatched {
        out.push_str(&format!("not compared: {u}\n"));
    }
    out.push_str(&format!(
        "{} slower, {} faster, {} within noise\n",
        c.slowdowns(),
        c.changes.iter().filter(|x| x.verdict == Verdict::Faster).count(),
        c.changes.iter().filter(|x| x.verdict == Verdict::Same).count()
    ));
    out
}

#[cfg(test)]
mod tests {
    use super::super::strategies::{calibration_rate, calibration_row};
    use super::*;

    fn row(label: &str, rate: f64, spread: f64, cpu: &str) -> StrategyThroughput {
        let mut r = calibration_like(label, cpu);
        r.pixel_samples_per_s = rate;
        r.pixel_samples_per_s_min = rate * (1.0 - spread / 2.0);
        r.pixel_samples_per_s_max = rate * (1.0 + spread / 2.0);
        r
    }

    fn calibration_like(label: &str, cpu: &str) -> StrategyThroughput {
        StrategyThroughput {
            scene: "box".into(),
            width: 8,
            height: 8,
            label: label.into(),
            strategy: "path".into(),
            params: "{}".into(),
            threads: 2,
            prepare_s: 0.0,
            prepare_s_min: 0.0,
            prepare_s_max: 0.0,
            samples: 1,
            repeats: 5,
            pixel_samples_per_s: 1.0,
            pixel_samples_per_s_min: 1.0,
            pixel_samples_per_s_max: 1.0,
            counters_per_s: String::new(),
            cpu: cpu.into(),
            git_revision: "x".into(),
        }
    }

    #[test]
    fn a_slowdown_beyond_the_measured_spread_is_flagged_and_one_within_it_is_not() {
        let base = [row("a", 100.0, 0.04, "cpu"), row("b", 100.0, 0.04, "cpu")];
        // a: 20 % slower against spreads of 4 % + 4 %; b: 6 % slower, inside 4 % + 4 %.
        let cand = [row("a", 80.0, 0.04, "cpu"), row("b", 94.0, 0.04, "cpu")];
        let c = compare(&base, &cand).unwrap();
        let verdicts: Vec<_> = c.changes.iter().map(|x| (x.label.as_str(), x.verdict)).collect();
        assert_eq!(verdicts, [("a", Verdict::Slower), ("b", Verdict::Same)]);
        assert_eq!(c.slowdowns(), 1);
        // A noisy baseline (spread 30 %) makes the same 20 % drop undecidable.
        let noisy = [row("a", 100.0, 0.30, "cpu")];
        assert_eq!(compare(&noisy, &cand).unwrap().changes[0].verdict, Verdict::Same);
        let faster = [row("a", 130.0, 0.04, "cpu")];
        assert_eq!(compare(&base, &faster).unwrap().changes[0].verdict, Verdict::Faster);
    }

    #[test]
    fn other_machines_are_compared_through_the_calibration() {
        let mut base = vec![row("a", 100.0, 0.02, "old"), row(CALIBRATION, 1000.0, 0.02, "old")];
        // Twice as fast a machine, the strategy only 1.5× faster: a slowdown of 25 %.
        let cand = vec![row("a", 150.0, 0.02, "new"), row(CALIBRATION, 2000.0, 0.02, "new")];
        let c = compare(&base, &cand).unwrap();
        assert!(!c.same_machine);
        assert!((c.machine_factor - 2.0).abs() < 1e-12);
        assert!((c.changes[0].speed_ratio - 0.75).abs() < 1e-12);
        assert_eq!(c.changes[0].verdict, Verdict::Slower);
        base.pop();
        assert!(compare(&base, &cand).is_err(), "no calibration on another machine");
    }

    #[test]
    fn prepare_times_are_judged_as_speeds_and_tiny_ones_not_at_all() {
        let mut b = row("a", 100.0, 0.02, "cpu");
        (b.prepare_s, b.prepare_s_min, b.prepare_s_max) = (1.0, 0.99, 1.01);
        let mut c = b.clone();
        (c.prepare_s, c.prepare_s_min, c.prepare_s_max) = (2.0, 1.98, 2.02);
        let cmp = compare(std::slice::from_ref(&b), &[c]).unwrap();
        let prep = cmp.changes.iter().find(|x| x.measure == "prepare").unwrap();
        assert!((prep.speed_ratio - 0.5).abs() < 1e-12);
        assert_eq!(prep.verdict, Verdict::Slower);
        let tiny = row("a", 100.0, 0.02, "cpu");
        let cmp = compare(std::slice::from_ref(&tiny), std::slice::from_ref(&tiny)).unwrap();
        assert!(cmp.changes.iter().all(|x| x.measure == "render"));
    }

    #[test]
    fn the_calibration_is_a_positive_rate_with_a_range() {
        let c = calibration_row((0..3).map(|_| calibration_rate()).collect());
        assert!(c.pixel_samples_per_s_min > 0.0);
        assert!(
            c.pixel_samples_per_s_min <= c.pixel_samples_per_s && c.pixel_samples_per_s <= c.pixel_samples_per_s_max
        );
    }
}
