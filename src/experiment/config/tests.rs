//! Tests of the experiment model: normalisation, sweeps and labels, budgets, and errors that
//! name the field.

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
    assert_eq!(e.scenes[0], SceneSource::file("scenes/a.toml"));
}

#[test]
fn exposure_and_baseline_are_read_and_default_to_none() {
    let e = parse(VALID).unwrap();
    assert_eq!((e.exposure, e.baseline.as_deref()), (0.0, None));
    let text = format!("{VALID}[[strategy]]\nkind = \"path\"\nlabel = \"b\"\n")
        .replace("seeds = 2", "seeds = 2\nexposure = -1.5\nbaseline = \"b\"");
    let e = parse(&text).unwrap();
    assert_eq!((e.exposure, e.baseline.as_deref()), (-1.5, Some("b")));
}

#[test]
fn a_strategy_may_run_on_some_scenes_only() {
    let text = "scenes = [\"../scenes/a.toml\", \"../scenes/b.toml\"]\nspp = [1]\n\
        [[strategy]]\nkind = \"path\"\n\
        [[strategy]]\nkind = \"path\"\nlabel = \"only-b\"\nscenes = [\"b\"]\n";
    let e = parse(text).unwrap();
    let (all, only_b) = (&e.strategies[0], &e.strategies[1]);
    assert!(all.runs_on(&SceneSource::file("scenes/a.toml")) && all.runs_on(&SceneSource::file("scenes/b.toml")));
    assert!(
        !only_b.runs_on(&SceneSource::file("scenes/a.toml")) && only_b.runs_on(&SceneSource::file("scenes/b.toml"))
    );
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
        (
            VALID.replace("seeds = 2", "seeds = 2\nexposure = 40"),
            "exposure: expected stops in [-20, 20], got 40",
        ),
        (
            VALID.replace("seeds = 2", "seeds = 2\nbaseline = \"pth\""),
            "baseline: expected the label of one of the strategies (path), got `pth`",
        ),
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

/// `scenes` entries may be tables that set a Mitsuba scene's parameters and name it; the
/// names strategies' `scenes` refer to are those names; two entries with one name, unknown
/// keys and values that are not parameters are refused, naming the entry.
#[test]
fn scene_entries_with_parameters_and_names() {
    let text = r#"
scenes = ["../scenes/a.xml", { file = "../scenes/a.xml", params = { roughness = 0.1, albedo = [0.5, 1], on = true } }, { file = "../scenes/a.xml", params = { roughness = "0.3" }, name = "rough" }]
spp = [1]
[[strategy]]
kind = "path"
scenes = ["rough", "a-albedo-0.5-1-on-true-roughness-0.1"]
"#;
    let e = parse(text).unwrap();
    assert_eq!(e.scenes[0], SceneSource::file("scenes/a.xml"));
    let params: Vec<(&str, &str)> = e.scenes[1]
        .params
        .iter()
        .map(|(k, v)| (k.as_str(), v.as_str()))
        .collect();
    assert_eq!(params, [("albedo", "0.5, 1"), ("on", "true"), ("roughness", "0.1")]);
    let keys: Vec<String> = e.scenes.iter().map(SceneSource::key).collect();
    assert_eq!(keys, ["a", "a-albedo-0.5-1-on-true-roughness-0.1", "rough"]);
    let spec = &e.strategies[0];
    assert_eq!(
        e.scenes.iter().map(|s| spec.runs_on(s)).collect::<Vec<_>>(),
        [false, true, true]
    );

    for (scenes, expected) in [
        (
            r#"["../scenes/a.xml", { file = "../scenes/b.xml", name = "a" }]"#,
            "scenes: two scenes are named `a`",
        ),
        (
            r#"[{ file = "../scenes/a.xml", size = 2 }]"#,
            "scenes[0].size: unknown key",
        ),
        (r#"[{ params = {} }]"#, "scenes[0].file"),
        (
            r#"[{ file = "a.xml", params = { x = { y = 1 } } }]"#,
            "scenes[0].params.x",
        ),
        (r#"[{ file = "a.xml", name = "a/b" }]"#, "scenes[0].name"),
        (r#"[3]"#, "scenes[0]: expected a scene file name"),
    ] {
        let text = format!("scenes = {scenes}\nspp = [1]\n[[strategy]]\nkind = \"path\"\n");
        let err = parse(&text).unwrap_err().to_string();
        assert!(err.contains(expected), "expected `{expected}` in `{err}`");
    }
}
