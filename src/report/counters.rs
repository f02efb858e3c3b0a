//! The table of strategy counters (the `counters` column): per scene, every strategy at its
//! largest equal-samples checkpoint and its largest time budget, each counter's mean over
//! seeds. Shared by `summary.md` and `index.html`.

use super::rows::{BUDGET_SECONDS, BUDGET_SPP, Group, Row, group, parse_counters};

/// Counters of one scene: the counter names (in first-seen order) and one line per strategy
/// and budget kind.
pub struct CounterTable {
    pub names: Vec<String>,
    pub lines: Vec<CounterLine>,
}

/// One strategy at one checkpoint: each counter's mean over the seeds that recorded it.
pub struct CounterLine {
    pub strategy: String,
    pub budget: String,
    pub seeds: usize,
    pub values: Vec<Option<f64>>,
}

/// The counter table of `scene`, or `None` when no row of it recorded a counter.
pub fn table(rows: &[Row], scene: &str) -> Option<CounterTable> {
    let groups = group(rows);
    let mut names: Vec<String> = Vec::new();
    for r in rows.iter().filter(|r| r.scene == scene) {
        for (name, _) in parse_counters(&r.counters) {
            if !names.iter().any(|n| n == name) {
                names.push(name.to_string());
            }
        }
    }
    if names.is_empty() {
        return None;
    }
    let mut lines = Vec::new();
    for budget in [BUDGET_SPP, BUDGET_SECONDS] {
        let of_scene: Vec<&Group> = groups
            .iter()
            .filter(|g| g.scene == scene && g.budget == budget)
            .collect();
        for g in &of_scene {
            // Each strategy (and parameter set) once: at its largest checkpoint of this kind.
            let largest = of_scene
                .iter()
                .filter(|o| o.strategy == g.strategy && o.params == g.params)
                .all(|o| o.budget_value <= g.budget_value);
            if !largest || g.rows.iter().all(|r| r.counters.is_empty()) {
                continue;
            }
            let values = names
                .iter()
                .map(|name| {
                    let found: Vec<f64> = g
                        .rows
                        .iter()
                        .filter_map(|r| parse_counters(&r.counters).into_iter().find(|(n, _)| n == name))
                        .map(|(_, v)| v)
                        .collect();
                    (!found.is_empty()).then(|| super::stats::mean(&found))
                })
                .collect();
            lines.push(CounterLine {
                strategy: g.strategy.to_string(),
                budget: g.budget_label(),
                seeds: g.rows.len(),
                values,
            });
        }
    }
    Some(CounterTable { names, lines })
}

/// A counter as a table shows it: integers in full, other values to four significant digits.
pub fn show(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{v:.0}")
    } else if v != 0.0 && !(1e-2..1e6).contains(&v.abs()) {
        format!("{v:.3e}")
    } else {
        format!("{v:.4}")
    }
}

impl CounterTable {
    /// The table as markdown.
    pub fn markdown(&self) -> String {
        let mut md = format!("| strategy | budget | n | {} |\n", self.names.join(" | "));
        md += &format!("|---|---:|---:|{}\n", "---:|".repeat(self.names.len()));
        for l in &self.lines {
            let cells: Vec<String> = l.values.iter().map(|v| v.map_or("–".into(), show)).collect();
            md += &format!(
                "| {} | {} | {} | {} |\n",
                l.strategy,
                l.budget,
                l.seeds,
                cells.join(" | ")
            );
        }
        md
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::rows::read_csv;

    #[test]
    fn integers_print_in_full() {
        assert_eq!(show(8_912_896.0), "8912896");
        assert_eq!(show(24.0), "24");
        assert_eq!(show(0.5), "0.5000");
        assert_eq!(show(1.5e-5), "1.500e-5");
    }

    #[test]
    fn old_files_have_no_counter_table() {
        let rows = read_csv(std::path::Path::new("results/baseline/metrics.csv")).unwrap();
        assert!(rows.iter().all(|r| r.counters.is_empty()));
        assert!(table(&rows, "ci-tiny").is_none());
    }

    #[test]
    fn table_shows_the_mean_over_seeds_at_the_largest_checkpoint() {
        let mut rows = read_csv(std::path::Path::new("results/baseline/metrics.csv")).unwrap();
        let first = rows[0].strategy.clone();
        for r in rows.iter_mut().filter(|r| r.strategy == first) {
            r.counters = format!("rays={};photons=7", r.spp as u64 * 100 + r.seed);
        }
        let t = table(&rows, "ci-tiny").unwrap();
        assert_eq!(t.names, ["rays", "photons"]);
        assert_eq!(t.lines.len(), 1, "one line: the strategy with counters, at 16 spp");
        let l = &t.lines[0];
        assert_eq!(
            (l.strategy.as_str(), l.budget.as_str(), l.seeds),
            (first.as_str(), "16 spp", 3)
        );
        assert_eq!(l.values, [Some(1601.0), Some(7.0)], "mean of 1600, 1601, 1602");
        let md = t.markdown();
        assert!(md.contains("| rays | photons |"), "{md}");
        assert!(md.contains("| 16 spp | 3 | 1601 | 7 |"), "{md}");
    }
}
