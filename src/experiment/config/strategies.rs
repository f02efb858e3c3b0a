//! `[[strategy]]` tables: the registered kind they name, their label, their own budgets and
//! scenes, and the expansion of list-valued parameters into sweeps, every combination checked
//! by building it.

use super::*;
use crate::error::Result;
use crate::strategy::{Registration, Registry, Strategy};

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
    /// Does this strategy run on the experiment's scene `scene`?
    pub fn runs_on(&self, scene: &crate::scene::load::SceneSource) -> bool {
        self.scenes.is_empty() || self.scenes.iter().any(|s| *s == scene.key())
    }

    /// A fresh strategy object for one run.
    pub fn instantiate(&self) -> Result<Box<dyn Strategy>> {
        (self.registration.build)(self.params.clone())
    }
}
impl StrategySpec {
    /// The label as used in file names: `[`, `=`, `,` and other characters outside letters,
    /// digits, `-`, `_` and `.` become `-` (`path[max_depth=4]` → `path-max_depth-4`).
    pub fn file_stem(&self) -> String {
        file_stem(&self.label)
    }
}
/// Takes a strategy table's own `scenes` (file stems of some of the experiment's scenes) out
/// of it; empty means every scene.
pub(super) fn strategy_scenes(table: &mut toml::Table, stems: &[String]) -> Result<Vec<String>, String> {
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
pub(super) fn strategy_budgets(
    table: &mut toml::Table,
    spp: &[u32],
    seconds: &[f64],
) -> Result<(Vec<u32>, Vec<f64>), String> {
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
pub(super) fn label_value(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// The values a parameter sweeps over, or `None` when it holds a single value: a list sweeps
/// over its elements (a list of lists over its inner lists). A parameter declared as an array
/// (`grid = [4, 16]`) holds a list of scalars as its single value; a list of lists sweeps.
pub(super) fn sweep_values(v: &toml::Value, array_typed: bool) -> Option<&Vec<toml::Value>> {
    match v {
        toml::Value::Array(items) if array_typed && !items.iter().all(|i| i.is_array()) => None,
        toml::Value::Array(items) => Some(items),
        _ => None,
    }
}

/// Splits `kind` and `label` off a strategy table, expands its list-valued parameters into
/// their cartesian product and checks every combination by building it. Errors start with the
/// field path after `strategy[i]`.
pub(super) fn strategy_specs(table: toml::Table, registry: &Registry) -> Result<Vec<StrategySpec>, String> {
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
pub(super) fn strategy_spec(mut table: toml::Table, registry: &Registry) -> Result<StrategySpec, String> {
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
