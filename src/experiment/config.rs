//! The experiment file (`experiments/*.toml`): which scenes, which strategies with which
//! parameters, at which sample counts and seeds.
//!
//! ```toml
//! name = "cornell"                 # results go to <output>/<name>/<run-id>/ (default: file stem)
//! description = "…"                # optional, copied into the summary
//! scenes = ["../scenes/cornell-empty.toml"]   # relative to this file
//! spp = [1, 4, 16, 64]             # checkpoints: one CSV row per strategy × scene × seed × spp
//! seeds = 2                        # independent runs, seeds base_seed … base_seed + seeds − 1
//! base_seed = 0                    # optional
//! references = "../references"     # optional: where <scene name>.exr references live
//! output = "../results"            # optional
//!
//! [[strategy]]
//! kind = "path"                    # see `bench list` for kinds, parameters and defaults
//! label = "path-mis"               # optional, defaults to the kind; unique per experiment
//! max_depth = 8                    # any parameter of the kind; unknown keys are errors
//! ```

use crate::error::{Error, Result};
use crate::strategy::{self, Strategy};
use crate::util::join_clean;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Largest accepted samples per pixel (a typo guard; references use `bench reference`).
pub const MAX_SPP: u32 = 1 << 20;
/// Largest accepted number of seeds.
pub const MAX_SEEDS: u32 = 1000;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ExperimentFile {
    name: Option<String>,
    description: Option<String>,
    scenes: Vec<String>,
    spp: Vec<u32>,
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

/// One strategy entry of an experiment.
#[derive(Debug, Clone)]
pub struct StrategySpec {
    pub label: String,
    pub kind: String,
    /// The parameter table as written (without `kind` and `label`).
    pub params: toml::Table,
}

impl StrategySpec {
    /// A fresh strategy object for one run.
    pub fn instantiate(&self) -> Result<Box<dyn Strategy>> {
        strategy::build(&self.kind, self.params.clone())
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
    /// Checkpoints, ascending and unique.
    pub spp: Vec<u32>,
    pub seeds: Vec<u64>,
    pub references: PathBuf,
    pub output: PathBuf,
    pub strategies: Vec<StrategySpec>,
}

impl Experiment {
    pub fn load(file: &Path) -> Result<Experiment> {
        let text = std::fs::read_to_string(file)
            .map_err(|e| Error::new(format!("{}: cannot read experiment file: {e}", file.display())))?;
        Self::parse(file, text)
    }

    /// Parses and validates experiment text; `file` locates relative paths and names errors.
    pub fn parse(file: &Path, text: String) -> Result<Experiment> {
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
        if raw.spp.is_empty() {
            return Err(at("spp: expected a non-empty list of sample counts".into()));
        }
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
        let mut strategies = Vec::new();
        for (i, table) in raw.strategies.into_iter().enumerate() {
            let spec = strategy_spec(table).map_err(|e| at(format!("strategy[{i}]{e}")))?;
            if strategies.iter().any(|s: &StrategySpec| s.label == spec.label) {
                return Err(at(format!(
                    "strategy[{i}].label: `{}` is used twice; give each strategy a unique label",
                    spec.label
                )));
            }
            strategies.push(spec);
        }
        Ok(Experiment {
            file: file.to_path_buf(),
            text,
            name,
            description: raw.description.unwrap_or_default(),
            scenes: raw.scenes.iter().map(|s| join_clean(dir, s)).collect(),
            spp,
            seeds,
            references: join_clean(dir, raw.references.as_deref().unwrap_or("../references")),
            output: join_clean(dir, raw.output.as_deref().unwrap_or("../results")),
            strategies,
        })
    }
}

/// Splits `kind` and `label` off a strategy table and checks the parameters by building the
/// strategy once. Errors start with the field path after `strategy[i]`.
fn strategy_spec(mut table: toml::Table) -> Result<StrategySpec, String> {
    let kind = match table.remove("kind") {
        Some(toml::Value::String(k)) => k,
        Some(other) => return Err(format!(".kind: expected a string, got {other}")),
        None => {
            return Err(format!(
                ".kind: missing; expected one of: {}",
                strategy::KINDS.join(", ")
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
    let spec = StrategySpec {
        label,
        kind,
        params: table,
    };
    spec.instantiate()
        .map_err(|e| format!(" ({}): {}", spec.kind, e.message()))?;
    Ok(spec)
}

/// A one-line description of a TOML error with its line and column.
pub fn describe_toml_error(e: &toml::de::Error, text: &str) -> String {
    let msg = e.message().trim().to_string();
    match e.span() {
        Some(span) => {
            let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
            let col = span.start - text[..span.start.min(text.len())].rfind('\n').map_or(0, |p| p + 1) + 1;
            format!("line {line}, column {col}: {msg}")
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
                "spp: expected a non-empty list",
            ),
            (VALID.replace("seeds = 2", "seeds = 0"), "seeds: expected a count"),
            (VALID.replace("seeds = 2", "seedz = 2"), "unknown field `seedz`"),
            (VALID.replace("max_depth = 3", "max_depth = -3"), "strategy[0] (path)"),
            (VALID.replace("spp = [4, 1, 4]", "spp = [4 1]"), "line 2, column"),
            (format!("{VALID}[[strategy]]\nkind = \"path\"\n"), "used twice"),
        ];
        for (text, expected) in cases {
            let err = parse(&text).unwrap_err().to_string();
            assert!(err.starts_with("experiments/x.toml: "), "{err}");
            assert!(err.contains(expected), "expected `{expected}` in `{err}`");
            assert!(!err.contains('\n'), "one line: {err}");
        }
    }
}
