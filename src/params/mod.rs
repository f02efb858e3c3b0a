//! Declared parameters. A strategy's parameters are declared once, with
//! [`declare_params!`](crate::declare_params): name, type, default, admissible range and doc,
//! field by field. Everything else is derived from that declaration:
//! - parsing: serde, with unknown keys refused and an error that names the offending key
//!   ([`Params::from_table`]);
//! - validation: every declared range is checked, with a one-line message
//!   `key: expected <range>, got <value>` ([`Params::check`]);
//! - the `params` column of result rows ([`Params::columns`]);
//! - `bench list` and the parameter reference in `docs/strategies.md` ([`Spec`]), whose
//!   defaults are printed as TOML that parses back.
//!
//! Enumerations are declared with [`declare_choice!`](crate::declare_choice), so that their
//! spellings in experiment files, in result rows and in the docs are one list. This module
//! sits below every layer that has parameters (photon tracing, the Metropolis chain,
//! strategies); it knows nothing about any of them.

use crate::error::{Error, Result};
use std::fmt;

/// Re-exported for the macros, so that a crate declaring parameters needs no serde of its own.
pub use serde;

/// The admissible values of a number (or of every element of an array of numbers). NaN is
/// never admissible.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    lo: f64,
    hi: f64,
    lo_open: bool,
    hi_open: bool,
    integer: bool,
    /// What the number is, shown before the range: "a cosine" → "expected a cosine in [-1, 1]".
    what: &'static str,
}

impl Range {
    /// The integers `lo..=hi`.
    pub const fn int(lo: i64, hi: i64) -> Self {
        Self::new(lo as f64, hi as f64, false, false, true)
    }

    /// The closed interval [lo, hi].
    pub const fn closed(lo: f64, hi: f64) -> Self {
        Self::new(lo, hi, false, false, false)
    }

    /// The interval (lo, hi]: `lo` excluded.
    pub const fn above_to(lo: f64, hi: f64) -> Self {
        Self::new(lo, hi, true, false, false)
    }

    /// The open interval (lo, hi).
    pub const fn open(lo: f64, hi: f64) -> Self {
        Self::new(lo, hi, true, true, false)
    }

    /// [lo, inf): `lo` or more, finite.
    pub const fn at_least(lo: f64) -> Self {
        Self::new(lo, f64::INFINITY, false, true, false)
    }

    /// Positive and finite: (0, inf).
    pub const fn positive() -> Self {
        Self::open(0.0, f64::INFINITY)
    }

    /// Names what the number is: `Range::closed(-1.0, 1.0).of("a cosine")`.
    pub const fn of(mut self, what: &'static str) -> Self {
        self.what = what;
        self
    }

    const fn new(lo: f64, hi: f64, lo_open: bool, hi_open: bool, integer: bool) -> Self {
        Self {
            lo,
            hi,
            lo_open,
            hi_open,
            integer,
            what: "",
        }
    }

    /// Is `v` admissible?
    pub fn contains(&self, v: f64) -> bool {
        let above = if self.lo_open { v > self.lo } else { v >= self.lo };
        let below = if self.hi_open { v < self.hi } else { v <= self.hi };
        above && below
    }

    /// `Ok` when `v` is admissible, else the one-line error naming `name`.
    pub fn check(&self, name: &str, v: f64, shown: impl fmt::Display) -> Result<()> {
        if self.contains(v) {
            Ok(())
        } else {
            Err(Error::new(format!("{name}: expected {self}, got {shown}")))
        }
    }
}

impl fmt::Display for Range {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if !self.what.is_empty() {
            write!(f, "{} in ", self.what)?;
        }
        if self.integer {
            return write!(f, "{}..={}", self.lo, self.hi);
        }
        let (open, close) = (
            if self.lo_open { '(' } else { '[' },
            if self.hi_open { ')' } else { ']' },
        );
        write!(f, "{open}{}, {}{close}", self.lo, self.hi)
    }
}

/// One declared parameter, as `bench list` and the docs show it.
#[derive(Clone, Debug, PartialEq)]
pub struct Spec {
    /// The key; a key of a nested table is `table.key`.
    pub name: String,
    /// The TOML type: `integer`, `float`, `boolean`, `table`, a choice `"a" | "b"`, …
    pub kind: String,
    /// The default as TOML source; `None` when the parameter is absent by default.
    pub default: Option<String>,
    /// The admissible values, when the type alone does not say.
    pub range: Option<String>,
    /// The doc comment of the declaration.
    pub doc: &'static str,
}

impl Spec {
    /// The whole doc on one line, rustdoc links as plain code.
    pub fn text(&self) -> String {
        let doc = self.doc.split_whitespace().collect::<Vec<_>>().join(" ");
        doc.replace("[`", "`").replace("`]", "`")
    }

    /// The first sentence of the doc on one line, rustdoc links as plain code: what
    /// `bench list` prints.
    pub fn summary(&self) -> String {
        let doc = self.text();
        let abbreviation = |head: &str| {
            ["al.", "e.g.", "i.e.", "cf.", "eq.", "Fig.", "vs."]
                .iter()
                .any(|a| head.ends_with(a))
        };
        let end = doc
            .match_indices(". ")
            .map(|(i, _)| i + 1)
            .find(|&i| !abbreviation(&doc[..i]))
            .unwrap_or(doc.len());
        doc[..end].to_string()
    }
}

/// A value a parameter can hold: numbers, booleans, arrays, options, choices and nested
/// parameter tables.
pub trait Value: Sized {
    /// The TOML type, as the docs show it.
    fn kind() -> String;
    /// Checks the value against the declared range (numbers) or its own declarations (tables).
    fn check_value(&self, name: &str, range: Option<&Range>) -> Result<()>;
    /// The value as TOML source; `None` for an absent optional value.
    fn toml(&self) -> Option<String>;
    /// The value in the `params` column: TOML, but strings without quotes.
    fn text(&self) -> String {
        self.toml().unwrap_or_else(|| "none".to_string())
    }
    /// The `params` column entries of this value under `name` (tables: one per key).
    fn push_columns(&self, name: &str, out: &mut Vec<(String, String)>) {
        out.push((name.to_string(), self.text()));
    }
    /// The declarations inside a table value, their names prefixed with `name.`.
    fn nested(name: &str) -> Vec<Spec> {
        let _ = name;
        Vec::new()
    }
}

macro_rules! integer_value {
    ($($t:ty),*) => {$(
        impl Value for $t {
            fn kind() -> String {
                "integer".to_string()
            }
            fn check_value(&self, name: &str, range: Option<&Range>) -> Result<()> {
                range.map_or(Ok(()), |r| r.check(name, *self as f64, self))
            }
            fn toml(&self) -> Option<String> {
                Some(self.to_string())
            }
        }
    )*};
}
integer_value!(u32, u64, usize, i64);

macro_rules! float_value {
    ($($t:ty),*) => {$(
        impl Value for $t {
            fn kind() -> String {
                "float".to_string()
            }
            fn check_value(&self, name: &str, range: Option<&Range>) -> Result<()> {
                match range {
                    Some(r) => r.check(name, *self as f64, self),
                    None if self.is_nan() => Err(Error::new(format!("{name}: expected a number, got NaN"))),
                    None => Ok(()),
                }
            }
            /// TOML source that parses back as a float: `1.0`, not `1`.
            fn toml(&self) -> Option<String> {
                if self.is_nan() {
                    return Some("nan".to_string());
                }
                let s = self.to_string();
                let float_like = s.contains(['.', 'e', 'i']);
                Some(if float_like { s } else { format!("{s}.0") })
            }
            /// As Rust prints it (`1`, `0.01`, `inf`): the column rows have always recorded.
            fn text(&self) -> String {
                self.to_string()
            }
        }
    )*};
}
float_value!(f32, f64);

impl Value for bool {
    fn kind() -> String {
        "boolean".to_string()
    }
    fn check_value(&self, _: &str, _: Option<&Range>) -> Result<()> {
        Ok(())
    }
    fn toml(&self) -> Option<String> {
        Some(self.to_string())
    }
}

impl<T: Value, const N: usize> Value for [T; N] {
    fn kind() -> String {
        format!("[{}; {N}]", T::kind())
    }
    fn check_value(&self, name: &str, range: Option<&Range>) -> Result<()> {
        self.iter().try_for_each(|v| v.check_value(name, range))
    }
    fn toml(&self) -> Option<String> {
        let items: Vec<String> = self.iter().map(|v| v.toml().unwrap_or_default()).collect();
        Some(format!("[{}]", items.join(", ")))
    }
}

impl<T: Value> Value for Option<T> {
    fn kind() -> String {
        T::kind()
    }
    fn check_value(&self, name: &str, range: Option<&Range>) -> Result<()> {
        self.as_ref().map_or(Ok(()), |v| v.check_value(name, range))
    }
    fn toml(&self) -> Option<String> {
        self.as_ref().and_then(T::toml)
    }
    fn text(&self) -> String {
        self.as_ref().map_or_else(|| "none".to_string(), T::text)
    }
    fn push_columns(&self, name: &str, out: &mut Vec<(String, String)>) {
        match self {
            Some(v) => v.push_columns(name, out),
            None => out.push((name.to_string(), "none".to_string())),
        }
    }
    fn nested(name: &str) -> Vec<Spec> {
        T::nested(name)
    }
}

/// The declaration of one field: its spec followed by those of the table it holds, if any.
pub fn field_specs<T: Value>(name: &str, doc: &'static str, default: &T, range: Option<Range>) -> Vec<Spec> {
    let mut specs = vec![Spec {
        name: name.to_string(),
        kind: T::kind(),
        default: default.toml(),
        range: range.map(|r| r.to_string()),
        doc,
    }];
    specs.extend(T::nested(name));
    specs
}

/// `prefix.name`, or `name` at the top level.
pub fn key(prefix: &str, name: &str) -> String {
    if prefix.is_empty() {
        name.to_string()
    } else {
        format!("{prefix}.{name}")
    }
}

/// A declared parameter table ([`declare_params!`](crate::declare_params) implements it; a
/// strategy whose table joins several declared tables implements it by hand from theirs).
pub trait Params: Default {
    /// Every parameter, in declaration order, nested tables' keys after their table.
    fn specs() -> Vec<Spec>;
    /// Checks every declared range and the table's own rules; keys in messages are prefixed
    /// with `prefix.` (empty at the top level).
    fn check(&self, prefix: &str) -> Result<()>;
    /// The `params` column: every parameter with its value, in declaration order.
    fn columns(&self) -> Vec<(String, String)>;

    /// Parses and checks an experiment file's table: unknown keys, wrong types and values out
    /// of range are one-line errors naming the key.
    fn from_table(table: toml::Table) -> Result<Self>;
}

/// Deserialises a parameter table; an error names the offending key when one alone fails
/// (every parameter table has defaults, so a single key is a valid table on its own).
pub fn deserialize<T: serde::de::DeserializeOwned>(params: toml::Table) -> Result<T> {
    <T as serde::Deserialize>::deserialize(toml::Value::Table(params.clone())).map_err(|e| {
        let culprit = params.iter().find(|(key, value)| {
            let alone: toml::Table = [((*key).clone(), (*value).clone())].into_iter().collect();
            <T as serde::Deserialize>::deserialize(toml::Value::Table(alone)).is_err()
        });
        match culprit {
            Some((key, _)) if !e.message().contains(&format!("`{key}`")) => {
                Error::new(format!("{key}: {}", e.message()))
            }
            _ => Error::new(e.message().to_string()),
        }
    })
}

/// Declares a parameter table: the struct (serde, unknown keys refused, every field defaulted),
/// its [`Default`], and [`Params`] and [`Value`] from one list of fields:
///
/// ```ignore
/// declare_params! {
///     /// Parameters of `kind = "path"`.
///     pub struct PathParams {
///         /// Maximum number of scattering events.
///         max_depth: u32 = 16, range Range::int(0, 1024);
///         /// What Russian roulette's survival probability follows.
///         roulette: Roulette = Roulette::Throughput;
///     }
///     check Self::rules;   // optional: rules that tie several fields together
/// }
/// ```
#[macro_export]
macro_rules! declare_params {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            $(
                $(#[doc = $doc:literal])*
                $field:ident : $ty:ty = $default:expr $(, range $range:expr)? ;
            )*
        }
        $(check $rules:path;)?
    ) => {
        $(#[$meta])*
        #[derive(Clone, Debug, PartialEq, $crate::params::serde::Deserialize)]
        #[serde(deny_unknown_fields, default)]
        $vis struct $name {
            $( $(#[doc = $doc])* pub $field: $ty, )*
        }

        impl Default for $name {
            fn default() -> Self {
                Self { $( $field: $default, )* }
            }
        }

        impl $crate::params::Params for $name {
            fn specs() -> Vec<$crate::params::Spec> {
                let defaults = Self::default();
                let mut specs = Vec::new();
                $(
                    specs.extend($crate::params::field_specs(
                        stringify!($field),
                        concat!($($doc, "\n",)*),
                        &defaults.$field,
                        $crate::declare_params!(@range $($range)?),
                    ));
                )*
                specs
            }

            fn check(&self, prefix: &str) -> $crate::error::Result<()> {
                $(
                    $crate::params::Value::check_value(
                        &self.$field,
                        &$crate::params::key(prefix, stringify!($field)),
                        $crate::declare_params!(@range $($range)?).as_ref(),
                    )?;
                )*
                $( $rules(self).map_err(|e| $crate::error::Error::new(format!("{}{}", if prefix.is_empty() { String::new() } else { format!("{prefix}.") }, e.message())))?; )?
                Ok(())
            }

            fn from_table(table: toml::Table) -> $crate::error::Result<Self> {
                let params: Self = $crate::params::deserialize(table)?;
                $crate::params::Params::check(&params, "")?;
                Ok(params)
            }

            fn columns(&self) -> Vec<(String, String)> {
                let mut out = Vec::new();
                $( $crate::params::Value::push_columns(&self.$field, stringify!($field), &mut out); )*
                out
            }
        }

        impl $crate::params::Value for $name {
            fn kind() -> String {
                "table".to_string()
            }
            fn check_value(&self, name: &str, _: Option<&$crate::params::Range>) -> $crate::error::Result<()> {
                <Self as $crate::params::Params>::check(self, name)
            }
            fn toml(&self) -> Option<String> {
                let mut items = Vec::new();
                $(
                    if let Some(v) = $crate::params::Value::toml(&self.$field) {
                        items.push(format!("{} = {v}", stringify!($field)));
                    }
                )*
                Some(format!("{{ {} }}", items.join(", ")))
            }
            fn push_columns(&self, name: &str, out: &mut Vec<(String, String)>) {
                for (key, value) in <Self as $crate::params::Params>::columns(self) {
                    out.push(($crate::params::key(name, &key), value));
                }
            }
            fn nested(name: &str) -> Vec<$crate::params::Spec> {
                <Self as $crate::params::Params>::specs()
                    .into_iter()
                    .map(|mut s| {
                        s.name = $crate::params::key(name, &s.name);
                        s
                    })
                    .collect()
            }
        }
    };
    (@range) => { None::<$crate::params::Range> };
    (@range $range:expr) => { Some($range) };
}

/// Declares a choice between named options (an enum whose TOML spelling is each variant's
/// string), with [`Value`]: `bench list` shows `"mis" | "nee" | "bsdf"`, rows show `mis`.
///
/// ```ignore
/// declare_choice! {
///     /// How light from emitters is gathered at each vertex.
///     pub enum Direct { Mis = "mis", Nee = "nee", Bsdf = "bsdf" }
/// }
/// ```
#[macro_export]
macro_rules! declare_choice {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident {
            $( $(#[$vmeta:meta])* $variant:ident = $spelling:literal ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, $crate::params::serde::Deserialize)]
        $vis enum $name {
            $( $(#[$vmeta])* #[serde(rename = $spelling)] $variant, )*
        }

        impl $name {
            /// The spelling in experiment files and result rows.
            pub fn name(self) -> &'static str {
                match self {
                    $( Self::$variant => $spelling, )*
                }
            }
        }

        impl $crate::params::Value for $name {
            fn kind() -> String {
                [$( concat!("\"", $spelling, "\"") ),*].join(" | ")
            }
            fn check_value(&self, _: &str, _: Option<&$crate::params::Range>) -> $crate::error::Result<()> {
                Ok(())
            }
            fn toml(&self) -> Option<String> {
                Some(format!("\"{}\"", self.name()))
            }
            fn text(&self) -> String {
                self.name().to_string()
            }
        }
    };
}

#[cfg(test)]
mod tests;
