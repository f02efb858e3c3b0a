//! Tests of the declarations: defaults print as TOML that parses back, specs list nested keys,
//! ranges refuse with one-line messages, columns flatten tables.

use super::*;

crate::declare_choice! {
    /// A test choice.
    pub enum Colour { Red = "red", Green = "green" }
}

crate::declare_params! {
    /// A nested test table.
    pub struct Inner {
        /// How often.
        every: usize = 4, range Range::int(1, 100);
        /// A cosine.
        dot: f32 = 0.9, range Range::closed(-1.0, 1.0).of("a cosine");
    }
}

fn ordered(p: &Outer) -> Result<()> {
    if p.lo > p.hi {
        crate::bail!("lo: expected at most hi ({}), got {}", p.hi, p.lo);
    }
    Ok(())
}

crate::declare_params! {
    /// A test table.
    pub struct Outer {
        /// Count. Second sentence.
        count: u64 = 10, range Range::int(1, 1000);
        /// Low end.
        lo: f32 = 1.0, range Range::positive();
        /// High end.
        hi: f32 = 2.0;
        /// A colour.
        colour: Colour = Colour::Red;
        /// A grid.
        grid: [usize; 2] = [4, 16], range Range::int(1, 1024);
        /// Optional table.
        inner: Option<Inner> = None;
        /// Optional number.
        radius: Option<f32> = None, range Range::positive();
    }
    check ordered;
}

fn table(text: &str) -> toml::Table {
    toml::from_str(text).unwrap()
}

#[test]
fn defaults_print_as_toml_that_parses_back_to_the_defaults() {
    let mut text = String::new();
    for spec in Outer::specs().iter().filter(|s| !s.name.contains('.')) {
        if let Some(d) = &spec.default {
            text += &format!("{} = {d}\n", spec.name);
        }
    }
    assert_eq!(Outer::from_table(table(&text)).unwrap(), Outer::default());
    let inner = Inner::default();
    let printed = Value::toml(&inner).unwrap();
    let parsed = Inner::from_table(table(&format!("t = {printed}"))["t"].as_table().unwrap().clone());
    assert_eq!(parsed.unwrap(), inner);
}

#[test]
fn specs_list_every_key_with_nested_tables_prefixed() {
    let names: Vec<String> = Outer::specs().into_iter().map(|s| s.name).collect();
    assert_eq!(
        names,
        [
            "count",
            "lo",
            "hi",
            "colour",
            "grid",
            "inner",
            "inner.every",
            "inner.dot",
            "radius"
        ]
    );
    let specs = Outer::specs();
    assert_eq!(specs[0].summary(), "Count.");
    let spec = |doc| Spec {
        doc,
        ..specs[0].clone()
    };
    assert_eq!(
        spec("See [`Foo`] (Fan et al. 2005).\n Second. Third.").summary(),
        "See `Foo` (Fan et al. 2005)."
    );
    assert_eq!(specs[0].range.as_deref(), Some("1..=1000"));
    assert_eq!(specs[3].kind, "\"red\" | \"green\"");
    assert_eq!(specs[5].default, None);
    assert_eq!(specs[7].range.as_deref(), Some("a cosine in [-1, 1]"));
}

#[test]
fn out_of_range_values_are_refused_naming_the_key() {
    let err = |text: &str| Outer::from_table(table(text)).unwrap_err().message().to_string();
    assert_eq!(err("count = 0"), "count: expected 1..=1000, got 0");
    assert_eq!(err("lo = 0.0\nhi = 3.0"), "lo: expected (0, inf), got 0");
    assert_eq!(err("lo = nan"), "lo: expected (0, inf), got NaN");
    assert_eq!(err("grid = [4, 0]"), "grid: expected 1..=1024, got 0");
    assert_eq!(err("radius = -1.0"), "radius: expected (0, inf), got -1");
    assert_eq!(
        err("inner = { dot = 2.0 }"),
        "inner.dot: expected a cosine in [-1, 1], got 2"
    );
    assert_eq!(err("lo = 3.0"), "lo: expected at most hi (2), got 3");
    assert!(err("colour = \"blue\"").contains("unknown variant `blue`"));
    assert!(err("cuont = 3").contains("unknown field `cuont`"));
    assert!(err("count = \"ten\"").starts_with("count: "));
}

#[test]
fn columns_flatten_tables_and_show_absent_values_as_none() {
    let p = Outer::from_table(table("inner = { every = 2 }\ncolour = \"green\"")).unwrap();
    let cols: Vec<String> = p.columns().into_iter().map(|(k, v)| format!("{k}={v}")).collect();
    assert_eq!(
        cols,
        [
            "count=10",
            "lo=1",
            "hi=2",
            "colour=green",
            "grid=[4, 16]",
            "inner.every=2",
            "inner.dot=0.9",
            "radius=none"
        ]
    );
}

#[test]
fn floats_print_as_toml_floats() {
    for v in [1.0f32, 0.01, 1e-10, 3e12, f32::INFINITY, f32::NEG_INFINITY, f32::NAN] {
        let text = format!("x = {}", Value::toml(&v).unwrap());
        let parsed: toml::Table = toml::from_str(&text).unwrap_or_else(|e| panic!("{text}: {e}"));
        let back = parsed["x"].as_float().unwrap_or_else(|| panic!("{text} is no float")) as f32;
        assert!(back == v || (back.is_nan() && v.is_nan()), "{text}");
    }
}
