//! The registry of strategy kinds: the one place where a strategy is named. A strategy is one
//! file that implements [`Strategy`] and [`Declared`], plus one line in [`Registry::builtin`];
//! its parameters are declared once ([`crate::params`]), and parsing, validation, the `params`
//! column, `bench list` and `docs/strategies.md` all read that declaration. Code outside the
//! crate (a test, a research fork) registers its own strategies with [`Registry::register`]
//! and loads experiments with [`crate::experiment::Experiment::load_with`]
//! (`docs/adding-a-strategy.md`).

use super::Strategy;
use crate::error::{Error, Result};
use crate::params::{Params, Spec};
use std::fmt;

/// A strategy whose parameters are one declared table.
pub trait Declared: Strategy + Sized + 'static {
    /// `kind` in experiment files; also the strategy's file name and its label in results.
    const KIND: &'static str;
    /// One line for `bench list` and the docs: the method and its paper.
    const SUMMARY: &'static str;
    /// The declared parameters ([`crate::declare_params!`]).
    type Params: Params;
    /// The strategy, from parameters whose declared ranges have been checked; it may refuse
    /// combinations the declaration cannot express.
    fn new(params: Self::Params) -> Result<Self>;
}

/// How the harness knows a strategy kind.
#[derive(Clone, Copy)]
pub struct Registration {
    pub kind: &'static str,
    pub summary: &'static str,
    /// Every parameter with its type, default, range and doc.
    pub specs: fn() -> Vec<Spec>,
    /// Builds the strategy from an experiment file's table (without `kind` and `label`).
    pub build: fn(toml::Table) -> Result<Box<dyn Strategy>>,
}

impl Registration {
    /// The registration of a declared strategy.
    pub fn of<S: Declared>() -> Self {
        Self {
            kind: S::KIND,
            summary: S::SUMMARY,
            specs: S::Params::specs,
            build: build_declared::<S>,
        }
    }
}

fn build_declared<S: Declared>(table: toml::Table) -> Result<Box<dyn Strategy>> {
    Ok(Box::new(S::new(S::Params::from_table(table)?)?))
}

impl fmt::Debug for Registration {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Registration({})", self.kind)
    }
}

/// The strategy kinds an experiment may name, in the order `bench list` shows them.
#[derive(Clone, Debug)]
pub struct Registry {
    entries: Vec<Registration>,
}

impl Registry {
    /// Every strategy of the crate.
    pub fn builtin() -> Self {
        use super::{
            bdpt::Bdpt,
            light::LightTracing,
            mlt::Mlt,
            mps::Mps,
            path::Path,
            photon_guided::PhotonGuided,
            photon_map::PhotonMapStrategy,
            ppg::Ppg,
            ppm::{Ppm, Sppm},
            vcm::Vcm,
        };
        Self {
            entries: vec![
                Registration::of::<Path>(),
                Registration::of::<PhotonGuided>(),
                Registration::of::<PhotonMapStrategy>(),
                Registration::of::<Mlt>(),
                Registration::of::<Mps>(),
                Registration::of::<LightTracing>(),
                Registration::of::<Bdpt>(),
                Registration::of::<Ppm>(),
                Registration::of::<Sppm>(),
                Registration::of::<Vcm>(),
                Registration::of::<Ppg>(),
            ],
        }
    }

    /// Adds a strategy kind; an error if the kind is taken.
    pub fn register(&mut self, registration: Registration) -> Result<()> {
        if self.entries.iter().any(|r| r.kind == registration.kind) {
            crate::bail!("strategy kind `{}` is registered twice", registration.kind);
        }
        self.entries.push(registration);
        Ok(())
    }

    /// The registration of `kind`, or an error listing the known kinds.
    pub fn get(&self, kind: &str) -> Result<&Registration> {
        self.entries.iter().find(|r| r.kind == kind).ok_or_else(|| {
            Error::new(format!(
                "unknown strategy kind `{kind}`; expected one of: {}",
                self.kinds().join(", ")
            ))
        })
    }

    /// Builds strategy `kind` from its parameter table.
    pub fn build(&self, kind: &str, params: toml::Table) -> Result<Box<dyn Strategy>> {
        (self.get(kind)?.build)(params)
    }

    /// Every kind, in registration order.
    pub fn kinds(&self) -> Vec<&'static str> {
        self.entries.iter().map(|r| r.kind).collect()
    }

    /// Every registration, in order.
    pub fn iter(&self) -> impl Iterator<Item = &Registration> {
        self.entries.iter()
    }
}

impl Registration {
    /// The strategy as `bench list` prints it: a `[[strategy]]` table with every default, as
    /// TOML that an experiment file can take unchanged. Parameters absent by default are
    /// commented out, with the value their table takes when given.
    pub fn toml_listing(&self) -> String {
        let specs = (self.specs)();
        let mut out = format!("# {}\n[[strategy]]\nkind = \"{}\"\n", self.summary, self.kind);
        for spec in specs.iter().filter(|s| !s.name.contains('.')) {
            let (line, absent) = match &spec.default {
                Some(v) => (format!("{} = {v}", spec.name), false),
                None => (format!("# {} = {}", spec.name, example(spec, &specs)), true),
            };
            let mut note = spec.range.clone().map_or(String::new(), |r| format!("{r}. "));
            if absent {
                note += "Absent by default. ";
            }
            out += &format!("{line:<40} # {note}{}\n", spec.summary());
        }
        out
    }

    /// The strategy's section of the parameter reference (`docs/strategies.md`).
    pub fn markdown(&self) -> String {
        let mut out = format!("## `{}`\n\n{}.\n\n", self.kind, self.summary);
        out += "| key | type | default | range | meaning |\n|---|---|---|---|---|\n";
        for spec in (self.specs)() {
            let cell = |s: &str| s.replace('|', "\\|").replace('\n', " ").trim().to_string();
            out += &format!(
                "| `{}` | {} | {} | {} | {} |\n",
                spec.name,
                cell(&spec.kind),
                spec.default
                    .as_deref()
                    .map_or("absent".to_string(), |d| format!("`{}`", cell(d))),
                spec.range.as_deref().map_or(String::new(), cell),
                cell(&spec.text()),
            );
        }
        out
    }
}

/// A value for a parameter that is absent by default: a table of its keys' defaults, or a
/// placeholder of its type.
fn example(spec: &Spec, specs: &[Spec]) -> String {
    let prefix = format!("{}.", spec.name);
    let keys: Vec<String> = specs
        .iter()
        .filter(|s| s.name.starts_with(&prefix) && !s.name[prefix.len()..].contains('.'))
        .filter_map(|s| Some(format!("{} = {}", &s.name[prefix.len()..], s.default.as_ref()?)))
        .collect();
    if spec.kind == "table" {
        return format!("{{ {} }}", keys.join(", "));
    }
    match spec.kind.as_str() {
        "integer" => "1".to_string(),
        "float" => "1.0".to_string(),
        "boolean" => "true".to_string(),
        other => other.split(" | ").next().unwrap_or("\"\"").to_string(),
    }
}

/// The parameter reference of every strategy in `registry` (`bench list --markdown`, committed
/// as `docs/strategies.md`).
pub fn reference_markdown(registry: &Registry) -> String {
    let mut out = String::from(
        "# Strategies and their parameters\n\nGenerated from the parameter declarations by \
         `cargo run --release -- list --markdown > docs/strategies.md` (a test fails while this \
         file is stale). Every key is optional; `bench list` prints the same as TOML.\n\n",
    );
    out += &capabilities_markdown(registry);
    for r in registry.iter() {
        out += &r.markdown();
        out.push('\n');
    }
    out
}

/// What each strategy renders beyond area lights and the models every strategy takes, with
/// its default parameters (the answers of [`Strategy::capabilities`]).
fn capabilities_markdown(registry: &Registry) -> String {
    let mut out = String::from(
        "## What each strategy renders

With default parameters; a strategy refuses a scene holding \
         anything it does not render, with one line naming it and the strategies that do \
         (`strategy::check_scene`, before anything runs).

\
         | strategy | environment light | point and spot lights | directional light | smooth plastic | thin lens, orthographic | opacity masks | layered (coated) models | participating media |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    let mark = |yes: bool| if yes { "yes" } else { "no" };
    for r in registry.iter() {
        let Ok(s) = (r.build)(toml::Table::new()) else { continue };
        out += &format!(
            "| `{}` | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.kind,
            mark(s.handles_environment()),
            mark(s.handles_point_lights()),
            mark(s.handles_directional_lights()),
            mark(s.handles_mixed_delta()),
            mark(s.handles_lens_camera()),
            mark(s.handles_opacity_masks()),
            mark(s.handles_stochastic_bsdfs()),
            mark(s.handles_media()),
        );
    }
    out.push('\n');
    out
}
