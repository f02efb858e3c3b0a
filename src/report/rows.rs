//! Result rows: one per (scene × strategy × seed × spp checkpoint), carrying everything that
//! produced the numbers, written as a tidy CSV.

use crate::error::{Context, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One checkpoint of one run. Column order is the CSV's.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Row {
    pub experiment: String,
    pub run_id: String,
    pub scene: String,
    pub scene_hash: String,
    pub reference_hash: String,
    pub reference_spp: u32,
    /// The strategy's label in the experiment (defaults to its kind).
    pub strategy: String,
    pub kind: String,
    /// Every parameter as `key=value`, `;`-separated, defaults included.
    pub params: String,
    pub seed: u64,
    /// The kind of budget this checkpoint belongs to: [`BUDGET_SPP`] or [`BUDGET_SECONDS`].
    pub budget: String,
    /// The budget: samples per pixel, or seconds of preparation + rendering.
    pub budget_value: f64,
    /// Samples per pixel rendered at this checkpoint.
    pub spp: u32,
    pub width: u32,
    pub height: u32,
    pub threads: usize,
    pub git_revision: String,
    pub cpu: String,
    /// Preparation time (all phases), seconds.
    pub prep_s: f64,
    /// Rendering time up to this checkpoint, seconds.
    pub render_s: f64,
    /// prep_s + render_s.
    pub total_s: f64,
    /// Preparation phases as `name=seconds`, `;`-separated.
    pub phases: String,
    /// Samples dropped because they were NaN or infinite.
    pub non_finite: u64,
    pub mse: f64,
    pub rmse: f64,
    pub rel_mse: f64,
    pub mse_trimmed: f64,
    pub rel_mse_trimmed: f64,
    pub rms_rel_lum: f64,
    pub rms_rel_lum_excluded: u64,
    /// 1 / (MSE · total_s).
    pub efficiency: f64,
    pub mean_r: f64,
    pub mean_g: f64,
    pub mean_b: f64,
    /// EXR image of this checkpoint, relative to the run directory.
    pub image: String,
    /// What the strategy counted ([`crate::strategy::Strategy::counters`]) as `name=value`,
    /// `;`-separated; empty when it counts nothing. Absent from files written before it
    /// existed (they read as empty).
    #[serde(default)]
    pub counters: String,
    /// Mean LDR-FLIP error of the tone-mapped image against the reference
    /// ([`crate::metrics::flip`]). The last column; files written before it existed read as
    /// NaN, and reports leave a metric out where it is NaN on every row.
    #[serde(default = "not_recorded")]
    pub flip: f64,
    /// MSE of the tone-mapped 8-bit images ([`crate::metrics::mse_ldr`]). The last column;
    /// NaN in files written before it existed, like `flip`.
    #[serde(default = "not_recorded")]
    pub mse_ldr: f64,
    /// The reference's own noise: the MSE it adds to every measured `mse` in expectation
    /// (E[MSE(I, R)] = MSE(I, truth) + this, for an image independent of the reference), from
    /// the reference's two independent halves ([`crate::experiment::reference::ReferenceNoise`]).
    /// Subtract it to estimate the error against the converged image. The last column; NaN for
    /// references made before it was recorded, and in older files.
    #[serde(default = "not_recorded")]
    pub reference_mse: f64,
}

fn not_recorded() -> f64 {
    f64::NAN
}

/// `budget` of a checkpoint of an equal-samples render (`spp = [...]`).
pub const BUDGET_SPP: &str = "spp";
/// `budget` of a checkpoint of an equal-time render (`seconds = [...]`).
pub const BUDGET_SECONDS: &str = "seconds";

/// A number reported per row, with how to read it.
pub struct Metric {
    pub name: &'static str,
    /// An image error (lower is better), compared by `bench compare`.
    pub error: bool,
    pub get: fn(&Row) -> f64,
}

/// Every metric the reports summarise over seeds, errors first.
pub const METRICS: &[Metric] = &[
    Metric {
        name: "mse",
        error: true,
        get: |r| r.mse,
    },
    Metric {
        name: "rmse",
        error: true,
        get: |r| r.rmse,
    },
    Metric {
        name: "rel_mse",
        error: true,
        get: |r| r.rel_mse,
    },
    Metric {
        name: "mse_trimmed",
        error: true,
        get: |r| r.mse_trimmed,
    },
    Metric {
        name: "rel_mse_trimmed",
        error: true,
        get: |r| r.rel_mse_trimmed,
    },
    Metric {
        name: "rms_rel_lum",
        error: true,
        get: |r| r.rms_rel_lum,
    },
    Metric {
        name: "flip",
        error: true,
        get: |r| r.flip,
    },
    Metric {
        name: "mse_ldr",
        error: true,
        get: |r| r.mse_ldr,
    },
    Metric {
        name: "spp",
        error: false,
        get: |r| r.spp as f64,
    },
    Metric {
        name: "total_s",
        error: false,
        get: |r| r.total_s,
    },
    Metric {
        name: "efficiency",
        error: false,
        get: |r| r.efficiency,
    },
];

/// The rows of one checkpoint over seeds: same scene, strategy, parameters and budget.
pub struct Group<'a> {
    pub scene: &'a str,
    pub strategy: &'a str,
    pub params: &'a str,
    pub budget: &'a str,
    pub budget_value: f64,
    pub rows: Vec<&'a Row>,
}

impl Group<'_> {
    /// One metric over the group's seeds.
    pub fn values(&self, get: fn(&Row) -> f64) -> Vec<f64> {
        self.rows.iter().map(|r| get(r)).collect()
    }

    /// The budget as people write it: `64 spp` or `0.5 s`.
    pub fn budget_label(&self) -> String {
        budget_label(self.budget, self.budget_value)
    }
}

/// `64 spp` or `0.5 s`.
pub fn budget_label(budget: &str, value: f64) -> String {
    if budget == BUDGET_SECONDS {
        format!("{value} s")
    } else {
        format!("{value} spp")
    }
}

/// Counters as the `counters` column writes them: `name=value;…`, values as plain numbers
/// (Rust's shortest round-trip form, so they read back bit for bit).
pub fn format_counters(counters: &[(String, f64)]) -> String {
    counters
        .iter()
        .map(|(name, value)| format!("{name}={value}"))
        .collect::<Vec<_>>()
        .join(";")
}

/// The `counters` column of a row as (name, value) pairs, in their order; malformed entries
/// (not `name=number`) are skipped.
pub fn parse_counters(text: &str) -> Vec<(&str, f64)> {
    text.split(';')
        .filter_map(|entry| {
            let (name, value) = entry.split_once('=')?;
            Some((name.trim(), value.trim().parse().ok()?))
        })
        .filter(|(name, _)| !name.is_empty())
        .collect()
}

/// One counter of a row, if it recorded it.
pub fn counter(row: &Row, name: &str) -> Option<f64> {
    parse_counters(&row.counters)
        .into_iter()
        .find(|(n, _)| *n == name)
        .map(|(_, v)| v)
}

impl Row {
    /// The preparation phases: `name=seconds;…` parsed (unreadable entries skipped).
    pub fn phases(&self) -> Vec<(&str, f64)> {
        unpack(&self.phases)
            .filter_map(|(name, s)| s.parse().ok().map(|s| (name, s)))
            .collect()
    }
}

/// Rows grouped by checkpoint, in first-seen order.
pub fn group(rows: &[Row]) -> Vec<Group<'_>> {
    let mut out: Vec<Group> = Vec::new();
    for r in rows {
        let same = |g: &&mut Group| {
            g.scene == r.scene
                && g.strategy == r.strategy
                && g.params == r.params
                && g.budget == r.budget
                && g.budget_value.to_bits() == r.budget_value.to_bits()
        };
        match out.iter_mut().find(|g| same(g)) {
            Some(g) => g.rows.push(r),
            None => out.push(Group {
                scene: &r.scene,
                strategy: &r.strategy,
                params: &r.params,
                budget: &r.budget,
                budget_value: r.budget_value,
                rows: vec![r],
            }),
        }
    }
    out
}

/// Distinct values of a column in first-seen order.
pub fn distinct<'a>(rows: &'a [Row], column: impl Fn(&'a Row) -> &'a str) -> Vec<&'a str> {
    let mut out: Vec<&str> = Vec::new();
    for r in rows {
        let v = column(r);
        if !out.contains(&v) {
            out.push(v);
        }
    }
    out
}

/// Writes rows as CSV with a header, atomically.
pub fn write_csv(rows: &[Row], path: &Path) -> Result<()> {
    crate::util::write_atomic_with(path, |tmp| {
        let mut w = csv::Writer::from_path(tmp).context(tmp.display())?;
        for r in rows {
            w.serialize(r).context(path.display())?;
        }
        w.flush().context(path.display())
    })
}

/// The `key=value` entries of a packed column (`params`, `phases`, `counters`): split at `;`,
/// then at each entry's first `=` (values such as `[4, 16]` hold neither separator).
pub fn unpack(packed: &str) -> impl Iterator<Item = (&str, &str)> {
    packed
        .split(';')
        .filter(|e| !e.is_empty())
        .map(|e| e.split_once('=').unwrap_or((e, "")))
}

/// The columns of `metrics_long.csv` that say which row an entry belongs to.
const LONG_ID_COLUMNS: [&str; 6] = ["run_id", "scene", "strategy", "seed", "budget", "budget_value"];

/// Writes the packed columns of `rows` in long (tidy) form, atomically: one line per entry of
/// `params`, `phases` and `counters`, with the columns that identify its row, then `field`
/// (which packed column), `key` and `value` (as written in the packed column). pandas reads it
/// without string splitting: `pd.read_csv("metrics_long.csv").pivot_table(…)`.
pub fn write_long_csv(rows: &[Row], path: &Path) -> Result<()> {
    crate::util::write_atomic_with(path, |tmp| {
        let mut w = csv::Writer::from_path(tmp).context(tmp.display())?;
        let header = LONG_ID_COLUMNS.iter().chain(&["field", "key", "value"]);
        w.write_record(header).context(path.display())?;
        for r in rows {
            let seed = r.seed.to_string();
            let budget_value = r.budget_value.to_string();
            for (field, packed) in [("params", &r.params), ("phases", &r.phases), ("counters", &r.counters)] {
                for (key, value) in unpack(packed) {
                    w.write_record([
                        r.run_id.as_str(),
                        &r.scene,
                        &r.strategy,
                        &seed,
                        &r.budget,
                        &budget_value,
                        field,
                        key,
                        value,
                    ])
                    .context(path.display())?;
                }
            }
        }
        w.flush().context(path.display())
    })
}

/// Reads rows written by [`write_csv`].
pub fn read_csv(path: &Path) -> Result<Vec<Row>> {
    crate::util::check_input(path, "metrics CSV", crate::util::MAX_CSV_INPUT)?;
    let mut r = csv::Reader::from_path(path).context(path.display())?;
    r.deserialize().map(|row| row.context(path.display())).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_long_csv_holds_every_packed_entry_once_and_nothing_else() {
        let row = |strategy: &str, seed: u64, params: &str, phases: &str, counters: &str| Row {
            run_id: "r".into(),
            scene: "s".into(),
            strategy: strategy.into(),
            seed,
            budget: BUDGET_SPP.into(),
            budget_value: 4.0,
            params: params.into(),
            phases: phases.into(),
            counters: counters.into(),
            ..Row::default()
        };
        let rows = [
            row(
                "mps",
                0,
                "grid=[4, 16];mutation.proposals=up;b_samples=none;gather_rays=16",
                "photon_map=0.25;b_eye=1.5",
                "rays=1e6;photons=20000",
            ),
            row("path", 1, "max_depth=16", "", ""),
        ];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("metrics_long.csv");
        write_long_csv(&rows, &path).unwrap();
        let mut reader = csv::Reader::from_path(&path).unwrap();
        assert_eq!(
            reader.headers().unwrap().iter().collect::<Vec<_>>(),
            [
                "run_id",
                "scene",
                "strategy",
                "seed",
                "budget",
                "budget_value",
                "field",
                "key",
                "value"
            ]
        );
        let lines: Vec<Vec<String>> = reader
            .records()
            .map(|r| r.unwrap().iter().map(String::from).collect())
            .collect();
        let mut expected = Vec::new();
        for r in &rows {
            for (field, packed) in [("params", &r.params), ("phases", &r.phases), ("counters", &r.counters)] {
                for entry in packed.split(';').filter(|e| !e.is_empty()) {
                    let (k, v) = entry.split_once('=').unwrap();
                    expected.push(vec![
                        "r".to_string(),
                        "s".into(),
                        r.strategy.clone(),
                        r.seed.to_string(),
                        "spp".into(),
                        "4".into(),
                        field.into(),
                        k.into(),
                        v.into(),
                    ]);
                }
            }
        }
        assert_eq!(lines, expected);
        assert!(lines.iter().any(|l| l[7] == "grid" && l[8] == "[4, 16]"));
        assert!(lines.iter().any(|l| l[7] == "mutation.proposals" && l[8] == "up"));
    }

    #[test]
    fn files_written_before_the_flip_column_load_and_compare_without_it() {
        // A file as written before the two optional columns existed: the committed baseline
        // with `flip` and `mse_ldr` dropped.
        let baseline = Path::new(env!("CARGO_MANIFEST_DIR")).join("results/baseline/metrics.csv");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("old.csv");
        {
            let mut reader = csv::Reader::from_path(&baseline).unwrap();
            let header = reader.headers().unwrap().clone();
            let keep: Vec<usize> = (0..header.len())
                .filter(|&i| !matches!(&header[i], "flip" | "mse_ldr"))
                .collect();
            assert_eq!(keep.len() + 2, header.len(), "the baseline has both optional columns");
            let mut writer = csv::Writer::from_path(&path).unwrap();
            writer.write_record(keep.iter().map(|&i| &header[i])).unwrap();
            for record in reader.records() {
                let record = record.unwrap();
                writer.write_record(keep.iter().map(|&i| &record[i])).unwrap();
            }
            writer.flush().unwrap();
        }
        let old = read_csv(&path).unwrap();
        assert!(
            !old.is_empty()
                && old
                    .iter()
                    .all(|r| r.flip.is_nan() && r.mse_ldr.is_nan() && r.counters.is_empty())
        );
        let new: Vec<Row> = old
            .iter()
            .map(|r| Row {
                flip: 0.25,
                ..r.clone()
            })
            .collect();
        let metrics_of = |c: &crate::report::compare::Comparison| {
            let mut m: Vec<&str> = c.lines.iter().map(|l| l.metric).collect();
            m.dedup();
            m
        };
        let mixed = crate::report::compare::compare(&old, &new).unwrap();
        assert!(!metrics_of(&mixed).contains(&"flip") && metrics_of(&mixed).contains(&"mse"));
        assert!(metrics_of(&crate::report::compare::compare(&new, &new).unwrap()).contains(&"flip"));
        // Written and read again, the column is there.
        write_csv(&new, &dir.path().join("m.csv")).unwrap();
        assert_eq!(read_csv(&dir.path().join("m.csv")).unwrap()[0].flip, 0.25);
    }

    #[test]
    fn counters_round_trip_bit_for_bit() {
        let c = vec![
            ("gather_rays".to_string(), 8_912_896.0),
            ("bytes_per_photon".to_string(), 24.0),
            ("ratio".to_string(), 0.1 + 0.2),
        ];
        let text = format_counters(&c);
        assert_eq!(
            text,
            "gather_rays=8912896;bytes_per_photon=24;ratio=0.30000000000000004"
        );
        let back = parse_counters(&text);
        assert_eq!(back.len(), 3);
        for ((n, v), (m, w)) in c.iter().zip(&back) {
            assert_eq!(n, m);
            assert_eq!(v.to_bits(), w.to_bits());
        }
        assert!(parse_counters("").is_empty());
        assert_eq!(parse_counters("a=1;junk;b=x;=3;c=2"), vec![("a", 1.0), ("c", 2.0)]);
    }
}
