//! The experiment file (`experiments/*.toml`): which scenes, which strategies with which
//! parameters, at which sample counts and seeds.
//!
//! ```toml
//! name = "cornell"                 # results go to <output>/<name>/<run-id>/ (default: file stem)
//! description = "…"                # optional, copied into the summary
//! scenes = ["../scenes/cornell-empty.toml"]   # relative to this file
//! spp = [1, 4, 16, 64]             # equal samples: one CSV row per strategy × scene × seed × spp
//! seconds = [0.5, 2]               # equal time (preparation included); spp, seconds or both
//! seeds = 2                        # independent runs, seeds base_seed … base_seed + seeds − 1
//! base_seed = 0                    # optional
//! references = "../references"     # optional: where <scene name>.exr references live
//! output = "../results"            # optional
//!
//! [[strategy]]
//! kind = "path"                    # see `bench list` for kinds, parameters and defaults
//! label = "path-mis"               # optional, defaults to the kind; unique per experiment
//! max_depth = [2, 4, 8]            # any parameter of the kind; unknown keys are errors
//! ```
//!
//! ## Sweeps
//!
//! A parameter written as a list is swept: each `[[strategy]]` expands into the cartesian
//! product of its list-valued parameters, taken in alphabetical order of their names, the last
//! varying fastest. Every combination is built once while parsing, so a misspelled key or a bad
//! value in any combination is refused. An expanded strategy is labelled
//! `<label>[key=value,…]` with its swept values, e.g. `path[max_depth=4]`; a strategy without
//! list-valued parameters keeps its plain label.
//!
//! ## A strategy's own scenes
//!
//! `scenes = ["rooms", "lantern"]` in a `[[strategy]]` table runs it on those of the
//! experiment's scenes only (named by file stem), e.g. a proposal mix tuned per scene as in
//! Fan et al. 2005's Table 1. Never swept.
//!
//! ## A strategy's own budgets
//!
//! A `[[strategy]]` table may restrict itself to some of the experiment's checkpoints with its
//! own `spp = [...]` and `seconds = [...]` (subsets of the experiment's lists; `[]` for none of
//! that kind), e.g. a slow strategy rendered at the small spp checkpoints and the time budgets
//! only. These two keys are budgets, never swept, and no strategy has parameters of those names.
//!
//! A parameter declared as an array (`photon_guided`'s `grid`) takes a list of numbers as its
//! single value: `grid = [4, 16]` (or `grid = [[4, 16]]`); `grid = [[4, 16], [8, 8]]` sweeps
//! over two values. A list whose elements are all lists is always a sweep over those lists.

use crate::error::{Error, Result};
use crate::strategy::{Registration, Registry, Strategy};
use crate::util::join_clean;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Largest accepted samples per pixel (a typo guard; references use `bench reference`).
pub const MAX_SPP: u32 = 1 << 20;
/// Largest accepted time budget, seconds.
pub const MAX_SECONDS: f64 = 86_400.0;
/// Largest accepted number of seeds.
pub const MAX_SEEDS: u32 = 1000;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ExperimentFile {
    name: Option<String>,
    description: Option<String>,
    scenes: Vec<String>,
    #[serde(default)]
    spp: Vec<u32>,
    #[serde(default)]
    seconds: Vec<f64>,
    #[serde(default = "one")]
    seeds: u32,
    #[serde(default)]
    base_seed: u64,
    references: Option<String>,
    output: Option<String>,
    #[serde(rename = "strategy")]
    strategies: Vec<toml::Table>,
}

fn one() -> u32 {
    1
}

/// One strategy of an experiment: one combination of a `[[strategy]]` table's swept values.
#[derive(Debug, Clone)]
pub struct StrategySpec {
    /// The registered kind this table names: how to build it and its declared parameters.
    pub registration: Registration,
    /// Unique label: the table's `label` (default: the kind), plus `[key=value,…]` of the
    /// swept parameters when there are any.
    pub label: String,
    pub kind: String,
    /// The parameter table of this combination (without `kind` and `label`).
    pub params: toml::Table,
    /// The swept parameters of this combination with their values, by name.
    pub swept: Vec<(String, String)>,
    /// This strategy's equal-samples checkpoints: the experiment's `spp`, or the subset its
    /// table names (`spp = [1, 4]`; `[]` for none).
    pub spp: Vec<u32>,
    /// This strategy's time budgets: the experiment's `seconds`, or the subset its table names.
    pub seconds: Vec<f64>,
    /// The scenes (file stems) this strategy runs on: all of the experiment's when empty, or
    /// the subset its table names (`scenes = ["rooms"]`).
    pub scenes: Vec<String>,
}

impl StrategySpec {
    /// Does this strategy run on the scene loaded from `scene_file`?
    pub fn runs_on(&self, scene_file: &Path) -> bool {
        self.scenes.is_empty() || self.scenes.iter().any(|s| *s == scene_stem(scene_file))
    }

    /// A fresh strategy object for one run.
    pub fn instantiate(&self) -> Result<Box<dyn Strategy>> {
        (self.registration.build)(self.params.clone())
    }
}

/// A validated experiment.
#[derive(Debug, Clone)]
pub struct Experiment {
    pub file: PathBuf,
    /// The experiment file's bytes, copied into every run directory.
    pub text: String,
    pub name: String,
    pub description: String,
    pub scenes: Vec<PathBuf>,
    /// Equal-samples checkpoints, ascending and unique (may be empty).
    pub spp: Vec<u32>,
    /// Equal-time checkpoints in seconds of preparation + rendering, ascending and unique (may
    /// be empty, but not together with `spp`).
    pub seconds: Vec<f64>,
    pub seeds: Vec<u64>,
    pub references: PathBuf,
    pub output: PathBuf,
    pub strategies: Vec<StrategySpec>,
}

impl Experiment {
    /// Loads an experiment whose strategies are the crate's ([`Registry::builtin`]).
    pub fn load(file: &Path) -> Result<Experiment> {
        Self::load_with(file, &Registry::builtin())
    }

    /// Loads an experiment whose strategies are those of `registry` (the crate's and any
    /// registered from outside: `docs/adding-a-strategy.md`).
    pub fn load_with(file: &Path, registry: &Registry) -> Result<Experiment> {
        let text = std::fs::read_to_string(file)
            .map_err(|e| Error::new(format!("{}: cannot read experiment file: {e}", file.display())))?;
        Self::parse_with(file, text, registry)
    }

    /// Parses and validates experiment text with the crate's strategies.
    pub fn parse(file: &Path, text: String) -> Result<Experiment> {
        Self::parse_with(file, text, &Registry::builtin())
    }

    /// Parses and validates experiment text; `file` locates relative paths and names errors.
    pub fn parse_with(file: &Path, text: String, registry: &Registry) -> Result<Experiment> {
        let at = |msg: String| Error::new(format!("{}: {msg}", file.display()));
        let raw: ExperimentFile = toml::from_str(&text).map_err(|e| at(describe_toml_error(&e, &text)))?;
        let dir = file.parent().unwrap_or(Path::new("."));
        let name = match raw.name {
            Some(n) => n,
            None => file
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "experiment".into()),
        };
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_') {
            return Err(at(format!("name: expected letters, digits, '-' or '_', got {name:?}")));
        }
        if raw.scenes.is_empty() {
            return Err(at("scenes: expected at least one scene file".into()));
        }
        if raw.spp.is_empty() && raw.seconds.is_empty() {
            return Err(at(
                "spp, seconds: expected a non-empty list of sample counts (spp) or time budgets (seconds)".into(),
            ));
        }
        if let Some(bad) = raw.seconds.iter().find(|&&s| !(s > 0.0 && s <= MAX_SECONDS)) {
            return Err(at(format!(
                "seconds: expected time budgets in (0, {MAX_SECONDS}], got {bad}"
            )));
        }
        let mut seconds = raw.seconds.clone();
        seconds.sort_by(f64::total_cmp);
        seconds.dedup();
        if let Some(bad) = raw.spp.iter().find(|&&s| s == 0 || s > MAX_SPP) {
            return Err(at(format!("spp: expected sample counts in 1..={MAX_SPP}, got {bad}")));
        }
        let mut spp = raw.spp.clone();
        spp.sort_unstable();
        spp.dedup();
        if raw.seeds == 0 || raw.seeds > MAX_SEEDS {
            return Err(at(format!(
                "seeds: expected a count in 1..={MAX_SEEDS}, got {}",
                raw.seeds
            )));
        }
        let seeds = (0..raw.seeds as u64).map(|i| raw.base_seed.wrapping_add(i)).collect();
        if raw.strategies.is_empty() {
            return Err(at("strategy: expected at least one [[strategy]] table".into()));
        }
        let scene_files: Vec<PathBuf> = raw.scenes.iter().map(|s| join_clean(dir, s)).collect();
        let stems: Vec<String> = scene_files.iter().map(|f| scene_stem(f)).collect();
        let mut strategies: Vec<StrategySpec> = Vec::new();
        for (i, mut table) in raw.strategies.into_iter().enumerate() {
            let (own_spp, own_seconds) =
                strategy_budgets(&mut table, &spp, &seconds).map_err(|e| at(format!("strategy[{i}]{e}")))?;
            let own_scenes = strategy_scenes(&mut table, &stems).map_err(|e| at(format!("strategy[{i}]{e}")))?;
            for mut spec in strategy_specs(table, registry).map_err(|e| at(format!("strategy[{i}]{e}")))? {
                spec.spp = own_spp.clone();
                spec.seconds = own_seconds.clone();
                spec.scenes = own_scenes.clone();
                let clash = strategies
                    .iter()
                    .find(|s| s.label == spec.label || s.file_stem() == spec.file_stem());
                if let Some(other) = clash {
                    return Err(at(format!(
                        "strategy[{i}].label: `{}` is used twice (or names the same files as `{}`); give each strategy a unique label",
                        spec.label, other.label
                    )));
                }
                strategies.push(spec);
            }
        }
        Ok(Experiment {
            file: file.to_path_buf(),
            text,
            name,
            description: raw.description.unwrap_or_default(),
            scenes: scene_files,
            spp,
            seconds,
            seeds,
            references: join_clean(dir, raw.references.as_deref().unwrap_or("../references")),
            output: join_clean(dir, raw.output.as_deref().unwrap_or("../results")),
            strategies,
        })
    }
}

impl StrategySpec {
    /// The label as used in file names: `[`, `=`, `,` and other characters outside letters,
    /// digits, `-`, `_` and `.` become `-` (`path[max_depth=4]` → `path-max_depth-4`).
    pub fn file_stem(&self) -> String {
        file_stem(&self.label)
    }
}

/// See [`StrategySpec::file_stem`].
pub fn file_stem(label: &str) -> String {
    let mapped: String = label
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '-'
            }
        })
        .collect();
    let mut out = String::with_capacity(mapped.len());
    for c in mapped.chars() {
        if !(c == '-' && out.ends_with('-')) {
            out.push(c);
        }
    }
    out.trim_end_matches('-').to_string()
}

/// The name a scene file is known by in `scenes = [...]` of a strategy: its file stem.
pub fn scene_stem(file: &Path) -> String {
    file.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Takes a strategy table's own `scenes` (file stems of some of the experiment's scenes) out
/// of it; empty means every scene.
fn strategy_scenes(table: &mut toml::Table, stems: &[String]) -> Result<Vec<String>, String> {
    let Some(value) = table.remove("scenes") else {
        return Ok(Vec::new());
    };
    let expected = || format!(".scenes: expected a non-empty list of scene names among {stems:?}, got {value}");
    let list = value.as_array().filter(|a| !a.is_empty()).ok_or_else(expected)?;
    list.iter()
        .map(|v| {
            let name = v.as_str().ok_or_else(expected)?;
            if stems.iter().any(|s| s == name) {
                Ok(name.to_string())
            } else {
                Err(format!(
                    ".scenes: `{name}` is not one of the experiment's scenes {stems:?}"
                ))
            }
        })
        .collect()
}

/// Takes a strategy table's own budgets (`spp`, `seconds`) out of it: each, when given, must
/// be a subset of the experiment's list (so that strategies meet at common checkpoints) and
/// replaces it for this strategy; together they must leave at least one checkpoint. Errors
/// start with the field path after `strategy[i]`.
fn strategy_budgets(table: &mut toml::Table, spp: &[u32], seconds: &[f64]) -> Result<(Vec<u32>, Vec<f64>), String> {
    fn subset<T: Copy + PartialEq + std::fmt::Debug>(
        key: &str,
        value: Option<toml::Value>,
        all: &[T],
        read: impl Fn(&toml::Value) -> Option<T>,
    ) -> Result<Vec<T>, String> {
        let Some(value) = value else {
            return Ok(all.to_vec());
        };
        let expected = || format!(".{key}: expected a list of the experiment's {key} {all:?}, got {value}");
        let toml::Value::Array(items) = &value else {
            return Err(expected());
        };
        let mut own = Vec::new();
        for item in items {
            let v = read(item).ok_or_else(expected)?;
            if !all.contains(&v) {
                return Err(format!(
                    ".{key}: {item} is not among the experiment's {key} {all:?}; a strategy's own budgets pick from those"
                ));
            }
            own.push(v);
        }
        // The experiment's order (ascending), without repeats.
        Ok(all.iter().copied().filter(|v| own.contains(v)).collect())
    }
    let own_spp = subset("spp", table.remove("spp"), spp, |v| {
        v.as_integer().and_then(|i| u32::try_from(i).ok())
    })?;
    let own_seconds = subset("seconds", table.remove("seconds"), seconds, |v| {
        v.as_float().or_else(|| v.as_integer().map(|i| i as f64))
    })?;
    if own_spp.is_empty() && own_seconds.is_empty() {
        return Err(": spp, seconds: the strategy's own budgets leave no checkpoint".into());
    }
    Ok((own_spp, own_seconds))
}

/// Largest number of combinations one `[[strategy]]` table may expand into.
pub const MAX_SWEEP: usize = 10_000;

/// A value as shown in a label: strings without quotes, everything else as TOML writes it.
fn label_value(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// The values a parameter sweeps over, or `None` when it holds a single value: a list sweeps
/// over its elements (a list of lists over its inner lists). A parameter declared as an array
/// (`grid = [4, 16]`) holds a list of scalars as its single value; a list of lists sweeps.
fn sweep_values(v: &toml::Value, array_typed: bool) -> Option<&Vec<toml::Value>> {
    match v {
        toml::Value::Array(items) if array_typed && !items.iter().all(|i| i.is_array()) => None,
        toml::Value::Array(items) => Some(items),
        _ => None,
    }
}

/// Splits `kind` and `label` off a strategy table, expands its list-valued parameters into
/// their cartesian product and checks every combination by building it. Errors start with the
/// field path after `strategy[i]`.
fn strategy_specs(table: toml::Table, registry: &Registry) -> Result<Vec<StrategySpec>, String> {
    let base = strategy_spec(table, registry)?;
    let specs = (base.registration.specs)();
    let swept: Vec<(String, Vec<toml::Value>)> = base
        .params
        .iter()
        .filter_map(|(k, v)| {
            let array_typed = specs.iter().any(|s| s.name == *k && s.kind.starts_with('['));
            sweep_values(v, array_typed).map(|items| (k.clone(), items.clone()))
        })
        .collect();
    if let Some((key, _)) = swept.iter().find(|(_, items)| items.is_empty()) {
        return Err(format!(
            ".{key}: an empty list sweeps over nothing; give at least one value"
        ));
    }
    let count = swept
        .iter()
        .try_fold(1usize, |n, (_, items)| n.checked_mul(items.len()));
    if count.is_none_or(|n| n > MAX_SWEEP) {
        return Err(format!(": the sweep has more than {MAX_SWEEP} combinations"));
    }
    let mut specs = Vec::new();
    for combination in 0..count.unwrap_or(1) {
        // Mixed radix, the last parameter varying fastest.
        let mut rest = combination;
        let mut choice = vec![0; swept.len()];
        for (slot, (_, items)) in choice.iter_mut().zip(&swept).rev() {
            *slot = rest % items.len();
            rest /= items.len();
        }
        let mut spec = StrategySpec {
            swept: Vec::new(),
            ..base.clone()
        };
        for ((key, items), &i) in swept.iter().zip(&choice) {
            spec.params.insert(key.clone(), items[i].clone());
            spec.swept.push((key.clone(), label_value(&items[i])));
        }
        if !spec.swept.is_empty() {
            let values: Vec<String> = spec.swept.iter().map(|(k, v)| format!("{k}={v}")).collect();
            spec.label = format!("{}[{}]", base.label, values.join(","));
        }
        spec.instantiate().map_err(|e| {
            let at = if spec.swept.is_empty() {
                String::new()
            } else {
                format!(" {}", spec.label)
            };
            format!(" ({}){at}: {}", spec.kind, e.message())
        })?;
        specs.push(spec);
    }
    Ok(specs)
}

/// Splits `kind` and `label` off a strategy table. Errors start with the field path after
/// `strategy[i]`.
fn strategy_spec(mut table: toml::Table, registry: &Registry) -> Result<StrategySpec, String> {
    let kind = match table.remove("kind") {
        Some(toml::Value::String(k)) => k,
        Some(other) => return Err(format!(".kind: expected a string, got {other}")),
        None => {
            return Err(format!(
                ".kind: missing; expected one of: {}",
                registry.kinds().join(", ")
            ));
        }
    };
    let label = match table.remove("label") {
        Some(toml::Value::String(l))
            if !l.is_empty() && l.chars().all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c)) =>
        {
            l
        }
        Some(other) => {
            return Err(format!(
                ".label: expected a non-empty string of letters, digits, '-', '_' or '.', got {other}"
            ));
        }
        None => kind.clone(),
    };
    let registration = *registry.get(&kind).map_err(|e| format!(" ({kind}): {}", e.message()))?;
    Ok(StrategySpec {
        registration,
        label,
        kind,
        params: table,
        swept: Vec::new(),
        spp: Vec::new(),
        seconds: Vec::new(),
        scenes: Vec::new(),
    })
}

/// A one-line description of a TOML error with its line and column.
pub fn describe_toml_error(e: &toml::de::Error, text: &str) -> String {
    let msg = e.message().trim().to_string();
    match e.span() {
        Some(span) => {
            let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
            let line_start = text[..span.start.min(text.len())].rfind('\n').map_or(0, |p| p + 1);
            let col = span.start - line_start + 1;
            // Name the key of a `key = value` line, so that type and range errors say which field.
            let line_text = text[line_start..].lines().next().unwrap_or("");
            let key = line_text.split_once('=').map(|(k, _)| k.trim()).filter(|k| {
                !k.is_empty()
                    && k.chars()
                        .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.')
            });
            match key {
                Some(key) if !msg.contains(&format!("`{key}`")) => format!("line {line}, column {col}: {key}: {msg}"),
                _ => format!("line {line}, column {col}: {msg}"),
            }
        }
        None => msg,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Experiment> {
        Experiment::parse(Path::new("experiments/x.toml"), text.to_string())
    }

    const VALID: &str =
        "scenes = [\"../scenes/a.toml\"]\nspp = [4, 1, 4]\nseeds = 2\n[[strategy]]\nkind = \"path\"\nmax_depth = 3\n";

    #[test]
    fn valid_file_is_normalised() {
        let e = parse(VALID).unwrap();
        assert_eq!(e.name, "x");
        assert_eq!(e.spp, vec![1, 4]);
        assert_eq!(e.seeds, vec![0, 1]);
        assert_eq!(e.strategies[0].label, "path");
        assert_eq!(e.scenes[0], Path::new("scenes/a.toml"));
    }

    #[test]
    fn a_strategy_may_run_on_some_scenes_only() {
        let text = "scenes = [\"../scenes/a.toml\", \"../scenes/b.toml\"]\nspp = [1]\n\
            [[strategy]]\nkind = \"path\"\n\
            [[strategy]]\nkind = \"path\"\nlabel = \"only-b\"\nscenes = [\"b\"]\n";
        let e = parse(text).unwrap();
        let (all, only_b) = (&e.strategies[0], &e.strategies[1]);
        assert!(all.runs_on(Path::new("scenes/a.toml")) && all.runs_on(Path::new("scenes/b.toml")));
        assert!(!only_b.runs_on(Path::new("scenes/a.toml")) && only_b.runs_on(Path::new("scenes/b.toml")));
        assert!(
            !only_b.params.contains_key("scenes"),
            "scenes is not a strategy parameter"
        );
        for (bad, expect) in [
            ("scenes = [\"c\"]", "`c` is not one of the experiment's scenes"),
            ("scenes = []", "expected a non-empty list of scene names"),
            ("scenes = \"b\"", "expected a non-empty list of scene names"),
        ] {
            let text = format!(
                "scenes = [\"../scenes/a.toml\", \"../scenes/b.toml\"]\nspp = [1]\n[[strategy]]\nkind = \"path\"\n{bad}\n"
            );
            let err = parse(&text).unwrap_err().to_string();
            assert!(
                err.contains("strategy[0].scenes") && err.contains(expect),
                "{bad}: {err}"
            );
        }
    }

    #[test]
    fn a_strategy_may_take_a_subset_of_the_budgets() {
        let text = "scenes = [\"../scenes/a.toml\"]\nspp = [1, 4, 16]\nseconds = [1, 3]\n\
            [[strategy]]\nkind = \"path\"\n\
            [[strategy]]\nkind = \"path\"\nlabel = \"slow\"\nspp = [4, 1]\nseconds = [3]\nmax_depth = [2, 3]\n\
            [[strategy]]\nkind = \"path\"\nlabel = \"timed\"\nspp = []\n";
        let e = parse(text).unwrap();
        assert_eq!(e.strategies.len(), 4, "spp and seconds are budgets, never swept");
        let by = |label: &str| e.strategies.iter().find(|s| s.label == label).unwrap();
        assert_eq!(
            (by("path").spp.as_slice(), by("path").seconds.as_slice()),
            (&[1, 4, 16][..], &[1.0, 3.0][..])
        );
        for label in ["slow[max_depth=2]", "slow[max_depth=3]"] {
            assert_eq!(
                (by(label).spp.as_slice(), by(label).seconds.as_slice()),
                (&[1, 4][..], &[3.0][..])
            );
            assert!(!by(label).params.contains_key("spp") && !by(label).params.contains_key("seconds"));
        }
        assert_eq!((by("timed").spp.len(), by("timed").seconds.len()), (0, 2));
        for (own, message) in [
            (
                "spp = [2]",
                "strategy[1].spp: 2 is not among the experiment's spp [1, 4, 16]",
            ),
            ("seconds = [0.5]", "strategy[1].seconds: 0.5 is not among"),
            ("spp = 4", "strategy[1].spp: expected a list"),
            ("spp = [\"4\"]", "strategy[1].spp: expected a list"),
            (
                "spp = []\nseconds = []",
                "strategy[1]: spp, seconds: the strategy's own budgets leave no checkpoint",
            ),
        ] {
            let text = format!(
                "scenes = [\"../scenes/a.toml\"]\nspp = [1, 4, 16]\nseconds = [1, 3]\n[[strategy]]\nkind = \"path\"\n[[strategy]]\nkind = \"path\"\nlabel = \"x\"\n{own}\n"
            );
            let err = parse(&text).unwrap_err().to_string();
            assert!(err.contains(message), "{own}: {err}");
        }
    }

    #[test]
    fn budgets_may_be_samples_time_or_both() {
        let e = parse(&VALID.replace("spp = [4, 1, 4]", "seconds = [2, 0.5, 2]")).unwrap();
        assert!(e.spp.is_empty());
        assert_eq!(e.seconds, [0.5, 2.0]);
        let e = parse(&VALID.replace("spp = [4, 1, 4]", "spp = [8]\nseconds = [1.5]")).unwrap();
        assert_eq!((e.spp.as_slice(), e.seconds.as_slice()), (&[8][..], &[1.5][..]));
    }

    #[test]
    fn list_valued_parameters_expand_into_their_cartesian_product() {
        let text = VALID.replace(
            "max_depth = 3",
            "max_depth = [2, 4]\ndirect = [\"mis\", \"nee\", \"bsdf\"]",
        );
        let e = parse(&text).unwrap();
        let labels: Vec<&str> = e.strategies.iter().map(|s| s.label.as_str()).collect();
        assert_eq!(
            labels,
            [
                "path[direct=mis,max_depth=2]",
                "path[direct=mis,max_depth=4]",
                "path[direct=nee,max_depth=2]",
                "path[direct=nee,max_depth=4]",
                "path[direct=bsdf,max_depth=2]",
                "path[direct=bsdf,max_depth=4]",
            ]
        );
        let s = &e.strategies[3];
        assert_eq!(s.params["max_depth"], toml::Value::Integer(4));
        assert_eq!(s.params["direct"], toml::Value::String("nee".into()));
        assert_eq!(
            s.swept,
            [("direct".into(), "nee".into()), ("max_depth".into(), "4".into())]
        );
        assert_eq!(s.file_stem(), "path-direct-nee-max_depth-4");
        let built = s.instantiate().unwrap().params();
        assert!(built.contains(&("max_depth".to_string(), "4".to_string())), "{built:?}");

        // A label prefixes the swept values; unswept strategies keep their label.
        let text = format!("{VALID}[[strategy]]\nkind = \"path\"\nlabel = \"uni\"\nrr_depth = [1]\n");
        let e = parse(&text).unwrap();
        assert_eq!(e.strategies[0].label, "path");
        assert_eq!(e.strategies[1].label, "uni[rr_depth=1]");
    }

    #[test]
    fn a_list_of_lists_sweeps_over_list_values() {
        let table: toml::Table = toml::from_str("kind = \"x\"\ngrid = [[4, 16], [8, 8]]\nn = 1").unwrap();
        // `x` is no kind, so check the expansion before validation through sweep_values.
        let items = sweep_values(&table["grid"], true).unwrap();
        assert_eq!(items.len(), 2);
        assert_eq!(label_value(&items[0]), "[4, 16]");
        assert!(sweep_values(&table["n"], false).is_none());
        // A parameter declared as an array takes a list of scalars as one value.
        let single: toml::Table = toml::from_str("grid = [4, 16]").unwrap();
        assert!(sweep_values(&single["grid"], true).is_none());
        assert_eq!(sweep_values(&single["grid"], false).map(Vec::len), Some(2));
        let text = format!("{VALID}[[strategy]]\nkind = \"photon_guided\"\ngrid = [4, 16]\n");
        let e = parse(&text).unwrap();
        assert_eq!(e.strategies.len(), 2);
        assert!(e.strategies[1].swept.is_empty());
        assert_eq!(file_stem("g[grid=[4, 16]]"), "g-grid-4-16");
    }

    #[test]
    fn bad_files_name_the_field() {
        let cases = [
            (
                VALID.replace("max_depth", "max_dpeth"),
                "strategy[0] (path): unknown field `max_dpeth`",
            ),
            (VALID.replace("\"path\"", "\"pth\""), "unknown strategy kind `pth`"),
            (
                VALID.replace("spp = [4, 1, 4]", "spp = [0]"),
                "spp: expected sample counts",
            ),
            (
                VALID.replace("spp = [4, 1, 4]", "spp = []"),
                "spp, seconds: expected a non-empty list",
            ),
            (
                VALID.replace("spp = [4, 1, 4]", "seconds = [0.0]"),
                "seconds: expected time budgets",
            ),
            (VALID.replace("seeds = 2", "seeds = 0"), "seeds: expected a count"),
            (VALID.replace("seeds = 2", "seedz = 2"), "unknown field `seedz`"),
            (VALID.replace("max_depth = 3", "max_depth = -3"), "strategy[0] (path)"),
            (VALID.replace("spp = [4, 1, 4]", "spp = [4 1]"), "line 2, column"),
            (format!("{VALID}[[strategy]]\nkind = \"path\"\n"), "used twice"),
            (
                VALID.replace("max_depth = 3", "max_depth = [3, -1]"),
                "strategy[0] (path) path[max_depth=-1]",
            ),
            (
                VALID.replace("max_depth = 3", "max_depth = []"),
                "strategy[0].max_depth: an empty list",
            ),
            (
                VALID.replace("max_depth = 3", "max_dpeth = [3, 4]"),
                "unknown field `max_dpeth`",
            ),
            (
                format!("{VALID}[[strategy]]\nkind = \"path\"\nlabel = \"path-max_depth-3\"\n")
                    .replace("max_depth = 3", "max_depth = [3]"),
                "used twice",
            ),
        ];
        for (text, expected) in cases {
            let err = parse(&text).unwrap_err().to_string();
            assert!(err.starts_with("experiments/x.toml: "), "{err}");
            assert!(err.contains(expected), "expected `{expected}` in `{err}`");
            assert!(!err.contains('\n'), "one line: {err}");
        }
    }
}
