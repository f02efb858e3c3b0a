//! The experiment file (`experiments/*.toml`): which scenes, which strategies with which
//! parameters, at which sample counts and seeds.
//!
//! ```toml
//! name = "cornell"                 # results go to <output>/<name>/<run-id>/ (default: file stem)
//! description = "…"                # optional, copied into the summary
//! scenes = ["../scenes/cornell-empty.toml"]   # relative to this file; or a table
//!                                  # { file = "…", params = { … }, name = "…" } (Mitsuba parameters)
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
//!
//! Files: this one (the experiment file model and its validation), [`strategies`]
//! (`[[strategy]]` tables: kinds, labels, budgets, sweeps), `tests.rs`. What a strategy's keys
//! mean is declared by the strategy ([`crate::params`]), not here.

mod strategies;
#[cfg(test)]
mod tests;

pub use strategies::*;

use crate::error::{Error, Result};
use crate::scene::load::SceneSource;
use crate::strategy::Registry;
use crate::util::join_clean;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Largest accepted samples per pixel (a typo guard; references use `bench reference`).
pub const MAX_SPP: u32 = 1 << 20;
/// Largest accepted time budget, seconds.
pub const MAX_SECONDS: f64 = 86_400.0;
/// Largest accepted exposure, stops either way (2²⁰ ≈ 10⁶ already turns any render white or
/// black).
pub const MAX_EXPOSURE: f32 = 20.0;
/// Largest accepted number of seeds.
pub const MAX_SEEDS: u32 = 1000;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ExperimentFile {
    name: Option<String>,
    description: Option<String>,
    scenes: Vec<toml::Value>,
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
    #[serde(default)]
    exposure: f32,
    baseline: Option<String>,
    #[serde(rename = "strategy")]
    strategies: Vec<toml::Table>,
}

fn one() -> u32 {
    1
}

/// A validated experiment.
#[derive(Debug, Clone)]
pub struct Experiment {
    pub file: PathBuf,
    /// The experiment file's bytes, copied into every run directory.
    pub text: String,
    pub name: String,
    pub description: String,
    /// The scenes, each a file with (for Mitsuba XML scenes) its parameters and a name.
    pub scenes: Vec<SceneSource>,
    /// Equal-samples checkpoints, ascending and unique (may be empty).
    pub spp: Vec<u32>,
    /// Equal-time checkpoints in seconds of preparation + rendering, ascending and unique (may
    /// be empty, but not together with `spp`).
    pub seconds: Vec<f64>,
    pub seeds: Vec<u64>,
    pub references: PathBuf,
    pub output: PathBuf,
    /// Exposure of the previews, strips and the viewer's first view, in stops (`2^exposure`
    /// times the linear image before clamping and sRGB); 0 shows the image as is. Metrics
    /// never depend on it.
    pub exposure: f32,
    /// The strategy label the ratio tables compare every other strategy with; the first
    /// strategy when absent.
    pub baseline: Option<String>,
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
        let text = crate::util::read_input_to_string(file, "experiment file", crate::util::MAX_TEXT_INPUT)?;
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
        let scene_files: Vec<SceneSource> = raw
            .scenes
            .iter()
            .enumerate()
            .map(|(i, v)| scene_source(dir, v).map_err(|e| at(format!("scenes[{i}]{e}"))))
            .collect::<Result<_>>()?;
        let stems: Vec<String> = scene_files.iter().map(SceneSource::key).collect();
        if let Some(k) = stems
            .iter()
            .enumerate()
            .find_map(|(i, k)| stems[..i].contains(k).then_some(k))
        {
            return Err(at(format!(
                "scenes: two scenes are named `{k}`; give one of them its own `name`"
            )));
        }
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
        if !(raw.exposure.is_finite() && raw.exposure.abs() <= MAX_EXPOSURE) {
            return Err(at(format!(
                "exposure: expected stops in [-{MAX_EXPOSURE}, {MAX_EXPOSURE}], got {}",
                raw.exposure
            )));
        }
        if let Some(b) = &raw.baseline
            && !strategies.iter().any(|s| &s.label == b)
        {
            let labels: Vec<&str> = strategies.iter().map(|s| s.label.as_str()).collect();
            return Err(at(format!(
                "baseline: expected the label of one of the strategies ({}), got `{b}`",
                labels.join(", ")
            )));
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
            exposure: raw.exposure,
            baseline: raw.baseline,
            strategies,
        })
    }
}

/// See [`StrategySpec::file_stem`].
pub fn file_stem(label: &str) -> String {
    crate::util::file_stem(label)
}

/// One entry of `scenes`: a file name (relative to the experiment file), or a table
/// `{ file = "…", params = { name = value, … }, name = "…" }` setting a Mitsuba scene's
/// parameters (numbers, booleans, strings, or lists of numbers written as Mitsuba writes
/// them: `"1, 0, 0"`) and naming the result. Errors start with the field path after
/// `scenes[i]`.
fn scene_source(dir: &Path, value: &toml::Value) -> std::result::Result<SceneSource, String> {
    let expected = "expected a scene file name or a table { file = \"…\", params = { … }, name = \"…\" }";
    match value {
        toml::Value::String(file) => Ok(SceneSource::file(join_clean(dir, file))),
        toml::Value::Table(t) => {
            if let Some(k) = t.keys().find(|k| !["file", "params", "name"].contains(&k.as_str())) {
                return Err(format!(".{k}: unknown key; {expected}"));
            }
            let file = t
                .get("file")
                .and_then(toml::Value::as_str)
                .ok_or_else(|| format!(".file: {expected}"))?;
            let name = match t.get("name") {
                None => None,
                Some(toml::Value::String(n)) if !n.is_empty() && crate::util::file_stem(n) == *n => Some(n.clone()),
                Some(n) => return Err(format!(".name: expected letters, digits, '-', '_' or '.', got {n}")),
            };
            let params = match t.get("params") {
                None => Vec::new(),
                Some(toml::Value::Table(p)) => p
                    .iter()
                    .map(|(k, v)| {
                        param_text(v).map(|v| (k.clone(), v)).ok_or_else(|| {
                            format!(".params.{k}: expected a number, boolean, string or list of numbers, got {v}")
                        })
                    })
                    .collect::<std::result::Result<_, _>>()?,
                Some(v) => return Err(format!(".params: expected a table of parameters, got {v}")),
            };
            Ok(SceneSource {
                file: join_clean(dir, file),
                params,
                name,
            })
        }
        v => Err(format!(": {expected}, got {v}")),
    }
}

/// A parameter value as the text `$name` stands for.
fn param_text(v: &toml::Value) -> Option<String> {
    match v {
        toml::Value::String(s) => Some(s.clone()),
        toml::Value::Integer(i) => Some(i.to_string()),
        toml::Value::Float(f) if f.is_finite() => Some(f.to_string()),
        toml::Value::Boolean(b) => Some(b.to_string()),
        toml::Value::Array(a) => a
            .iter()
            .map(|x| match x {
                toml::Value::Integer(i) => Some(i.to_string()),
                toml::Value::Float(f) if f.is_finite() => Some(f.to_string()),
                _ => None,
            })
            .collect::<Option<Vec<_>>>()
            .map(|v| v.join(", ")),
        _ => None,
    }
}

/// The name a scene file is known by in `scenes = [...]` of a strategy: its file stem.
pub fn scene_stem(file: &Path) -> String {
    file.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
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
