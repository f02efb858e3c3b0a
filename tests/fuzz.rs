//! Property-based fuzzing (proptest) of everything that reads user files: the scene loader
//! (`load_scene_bytes`), the OBJ path behind it, and the experiment parser
//! (`Experiment::parse`). Inputs are random bytes, and structured mutations of valid files:
//! a number replaced by NaN, ±∞, a huge, negative or zero value; a key dropped; a table or
//! array element duplicated; a value swapped for one of another type. The property: never a
//! panic, and every refusal is one line that starts with the file's name.
//!
//! Case counts keep this file at a few seconds in release; `PROPTEST_CASES` raises them.

use photon_bench::experiment::Experiment;
use photon_bench::scene::load::load_scene_bytes;
use proptest::prelude::*;
use proptest::sample::Index;
use std::path::{Path, PathBuf};

fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(cases),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

fn shipped(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{name}.toml"))
}

const SCENES: [&str; 3] = ["cornell-empty", "cornell-spheres", "cornell-box"];

/// A valid experiment file (its scenes need not exist: parsing does not open them).
const EXPERIMENT: &str = r#"
name = "fuzz"
description = "a valid experiment"
scenes = ["../scenes/cornell-empty.toml", "../scenes/cornell-spheres.toml"]
spp = [1, 4, 16]
seeds = 2
base_seed = 7
references = "../references"
output = "../results"

[[strategy]]
kind = "path"
label = "path-mis"
max_depth = 8
rr_depth = 3
direct = "mis"

[[strategy]]
kind = "path"
label = "uniform"
bsdf_sampling = "uniform"
"#;

/// A valid OBJ: two triangles sharing an edge, a quad, normals and texture coordinates.
const OBJ: &str = "mtllib m.mtl\no tri\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0.5 0.5 1\n\
vt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nusemtl a\nf 1/1/1 2/2/1 3/3/1\nf 2//1 4//1 3//1\n\
f -1 -2 -3 -4\ng group\ns 1\nf 1 2 5\n";

/// Where a scene or experiment error must start.
fn assert_one_line_naming(result: Result<(), String>, file: &Path) -> Result<(), TestCaseError> {
    if let Err(msg) = result {
        prop_assert!(!msg.contains('\n'), "not one line: {msg}");
        let prefix = format!("{}", file.display());
        prop_assert!(msg.starts_with(&prefix), "does not name {prefix}: {msg}");
    }
    Ok(())
}

fn load_scene(path: &Path, bytes: &[u8]) -> Result<(), String> {
    load_scene_bytes(path, bytes).map(|_| ()).map_err(|e| e.to_string())
}

fn parse_experiment(path: &Path, text: &str) -> Result<(), String> {
    Experiment::parse(path, text.to_string())
        .map(|_| ())
        .map_err(|e| e.to_string())
}

// ---------------------------------------------------------------------------------------------
// Structured mutations of TOML documents.

#[derive(Clone, Debug)]
enum Seg {
    Key(String),
    Index(usize),
}

/// Every node of a document (tables, arrays and leaves), as paths from the root.
fn nodes(v: &toml::Value, path: &mut Vec<Seg>, out: &mut Vec<Vec<Seg>>) {
    out.push(path.clone());
    match v {
        toml::Value::Table(t) => {
            for (k, x) in t {
                path.push(Seg::Key(k.clone()));
                nodes(x, path, out);
                path.pop();
            }
        }
        toml::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                path.push(Seg::Index(i));
                nodes(x, path, out);
                path.pop();
            }
        }
        _ => {}
    }
}

fn get_mut<'a>(v: &'a mut toml::Value, path: &[Seg]) -> Option<&'a mut toml::Value> {
    let mut v = v;
    for seg in path {
        v = match (v, seg) {
            (toml::Value::Table(t), Seg::Key(k)) => t.get_mut(k)?,
            (toml::Value::Array(a), Seg::Index(i)) => a.get_mut(*i)?,
            _ => return None,
        };
    }
    Some(v)
}

/// Values that break numbers: non-finite, huge, negative, zero, beyond integer ranges.
fn hostile_number(pick: u64) -> toml::Value {
    let floats = [
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        1e30,
        -1e30,
        1e300,
        -1.0,
        0.0,
        -0.0,
        5e-324,
    ];
    let ints = [0i64, -1, i64::MAX, i64::MIN, 1 << 40, 4_294_967_296];
    let n = (floats.len() + ints.len()) as u64;
    let i = (pick % n) as usize;
    if i < floats.len() {
        toml::Value::Float(floats[i])
    } else {
        toml::Value::Integer(ints[i - floats.len()])
    }
}

/// A value of another type than `v`.
fn other_type(v: &toml::Value, pick: u64) -> toml::Value {
    let options = [
        toml::Value::String("x".into()),
        toml::Value::Integer(3),
        toml::Value::Float(0.5),
        toml::Value::Boolean(true),
        toml::Value::Array(vec![]),
        toml::Value::Array(vec![toml::Value::String("a".into()); 3]),
        toml::Value::Table(toml::Table::new()),
    ];
    let choices: Vec<&toml::Value> = options.iter().filter(|o| o.type_str() != v.type_str()).collect();
    choices[(pick % choices.len() as u64) as usize].clone()
}

/// Applies mutation `op` at the node `at` (an index into the document's nodes).
fn mutate(doc: &mut toml::Value, op: u8, at: Index, pick: u64) {
    let mut all = Vec::new();
    nodes(doc, &mut Vec::new(), &mut all);
    let path = at.get(&all).clone();
    match op % 5 {
        // Replace a number (or any leaf) by a hostile number.
        0 => {
            if let Some(v) = get_mut(doc, &path) {
                *v = hostile_number(pick);
            }
        }
        // Drop the node from its parent.
        1 => {
            if let Some((last, parent)) = path.split_last()
                && let Some(p) = get_mut(doc, parent)
            {
                match (p, last) {
                    (toml::Value::Table(t), Seg::Key(k)) => {
                        t.remove(k);
                    }
                    (toml::Value::Array(a), Seg::Index(i)) => {
                        a.remove(*i);
                    }
                    _ => {}
                }
            }
        }
        // Duplicate an array element (a second [[shapes]], a repeated coordinate), or
        // copy a table under a new key.
        2 => {
            if let Some((last, parent)) = path.split_last()
                && let Some(p) = get_mut(doc, parent)
            {
                match (p, last) {
                    (toml::Value::Array(a), Seg::Index(i)) => {
                        let x = a[*i].clone();
                        a.insert(*i, x);
                    }
                    (toml::Value::Table(t), Seg::Key(k)) => {
                        let x = t[k].clone();
                        t.insert(format!("{k}_copy"), x);
                    }
                    _ => {}
                }
            }
        }
        // Swap the type.
        3 => {
            if let Some(v) = get_mut(doc, &path) {
                *v = other_type(v, pick);
            }
        }
        // Scale a number by a hostile factor.
        _ => {
            if let Some(v) = get_mut(doc, &path) {
                let f = [1e-30, 1e30, -1.0, 1e7, 1e-7][(pick % 5) as usize];
                match v {
                    toml::Value::Float(x) => *x *= f,
                    toml::Value::Integer(i) => *v = toml::Value::Float(*i as f64 * f),
                    _ => {}
                }
            }
        }
    }
}

/// The text of a document after `ops` mutations; or, for a document toml cannot write back,
/// the original text with the last mutation's value spliced in textually (still hostile).
fn mutated_text(original: &str, ops: &[(u8, Index, u64)]) -> String {
    let mut doc: toml::Value = toml::from_str(original).unwrap();
    for &(op, at, pick) in ops {
        mutate(&mut doc, op, at, pick);
    }
    toml::to_string(&doc).unwrap_or_else(|_| original.to_string())
}

/// Text-level damage the document model cannot express: a duplicated table header, a
/// truncated file, a spliced-in line.
fn damaged_text(original: &str, op: u8, at: Index, pick: u64) -> String {
    let lines: Vec<&str> = original.lines().collect();
    let i = at.index(lines.len().max(1));
    match op % 3 {
        0 => {
            // Duplicate a table header (and what follows it up to the next blank line).
            let mut out: Vec<&str> = lines.clone();
            let block: Vec<&str> = lines[i..]
                .iter()
                .take_while(|l| !l.trim().is_empty())
                .copied()
                .collect();
            out.extend(block);
            out.join("\n")
        }
        1 => original[..original.len() * (pick % 100) as usize / 100].to_string(),
        _ => {
            let junk = [
                "[",
                "]]",
                "= =",
                "x = nan",
                "\"",
                "[[shapes]]",
                "type = 3",
                "\u{0}",
                "{a=1",
            ];
            let mut out = lines.clone();
            out.insert(i, junk[(pick % junk.len() as u64) as usize]);
            out.join("\n")
        }
    }
}

fn ops() -> impl Strategy<Value = Vec<(u8, Index, u64)>> {
    prop::collection::vec((any::<u8>(), any::<Index>(), any::<u64>()), 1..4)
}

proptest! {
    #![proptest_config(config(512))]

    #[test]
    fn random_bytes_never_panic_the_scene_loader(bytes in prop::collection::vec(any::<u8>(), 0..512)) {
        let path = Path::new("fuzz/random.toml");
        assert_one_line_naming(load_scene(path, &bytes), path)?;
    }

    #[test]
    fn random_toml_like_text_never_panics_the_scene_loader(
        chars in prop::collection::vec(prop::sample::select(b"[]{}=\"'.,#-+_ \n0123456789eabcdfinxyz".to_vec()), 0..400)
    ) {
        let path = Path::new("fuzz/random.toml");
        assert_one_line_naming(load_scene(path, &chars), path)?;
    }

    #[test]
    fn mutated_shipped_scenes_never_panic(scene in 0..SCENES.len(), ops in ops()) {
        let path = shipped(SCENES[scene]);
        let original = std::fs::read_to_string(&path).unwrap();
        let text = mutated_text(&original, &ops);
        assert_one_line_naming(load_scene(&path, text.as_bytes()), &path)?;
    }

    #[test]
    fn textually_damaged_shipped_scenes_never_panic(scene in 0..SCENES.len(), op in any::<u8>(), at in any::<Index>(), pick in any::<u64>()) {
        let path = shipped(SCENES[scene]);
        let original = std::fs::read_to_string(&path).unwrap();
        let text = damaged_text(&original, op, at, pick);
        assert_one_line_naming(load_scene(&path, text.as_bytes()), &path)?;
    }

    #[test]
    fn random_bytes_never_panic_the_experiment_parser(bytes in prop::collection::vec(any::<u8>(), 0..512)) {
        let path = Path::new("experiments/fuzz.toml");
        let text = String::from_utf8_lossy(&bytes);
        assert_one_line_naming(parse_experiment(path, &text), path)?;
    }

    #[test]
    fn mutated_experiments_never_panic(ops in ops()) {
        let path = Path::new("experiments/fuzz.toml");
        prop_assert!(parse_experiment(path, EXPERIMENT).is_ok());
        let text = mutated_text(EXPERIMENT, &ops);
        assert_one_line_naming(parse_experiment(path, &text), path)?;
    }

    #[test]
    fn textually_damaged_experiments_never_panic(op in any::<u8>(), at in any::<Index>(), pick in any::<u64>()) {
        let path = Path::new("experiments/fuzz.toml");
        let text = damaged_text(EXPERIMENT, op, at, pick);
        assert_one_line_naming(parse_experiment(path, &text), path)?;
    }
}

/// An OBJ mutation: overwrite, insert or delete bytes, or replace a number.
fn mutate_obj(obj: &[u8], op: u8, at: Index, pick: u64) -> Vec<u8> {
    let mut bytes = obj.to_vec();
    let i = at.index(bytes.len());
    let interesting = b"0123456789-/ .\nfvnte#";
    match op % 5 {
        0 => bytes[i] = pick as u8,
        1 => bytes[i] = interesting[(pick % interesting.len() as u64) as usize],
        2 => {
            bytes.remove(i);
        }
        3 => {
            let words = [
                "nan",
                "inf",
                "-inf",
                "1e30",
                "-0",
                "99999999999",
                "0/0/0",
                "f 1 1 1",
                "v",
            ];
            let w = words[(pick % words.len() as u64) as usize];
            bytes.splice(i..i, w.bytes());
        }
        _ => {
            // Duplicate a line (a repeated face, a repeated vertex).
            let text = String::from_utf8_lossy(obj);
            let lines: Vec<&str> = text.lines().collect();
            let j = (pick % lines.len() as u64) as usize;
            let mut out = lines.clone();
            out.insert(j, lines[j]);
            bytes = out.join("\n").into_bytes();
        }
    }
    bytes
}

proptest! {
    #![proptest_config(config(256))]

    /// The OBJ path: the scene is fixed, the mesh file it names is mutated.
    #[test]
    fn mutated_obj_files_never_panic(muts in prop::collection::vec((any::<u8>(), any::<Index>(), any::<u64>()), 1..6)) {
        let dir = tempfile::tempdir().unwrap();
        let scene_path = dir.path().join("m.toml");
        let scene = std::fs::read_to_string(shipped("cornell-empty"))
            .unwrap()
            .replace("resolution = [80, 60]", "resolution = [8, 6]")
            + "\n[[shapes]]\ntype = \"mesh\"\nmaterial = \"white\"\nfile = \"m.obj\"\n\
               transform = { scale = 0.1, translate = [0.2, 0.1, 0.3] }\n";
        std::fs::write(dir.path().join("m.mtl"), "newmtl a\nKd 0.5 0.5\n").unwrap();
        let mut obj = OBJ.as_bytes().to_vec();
        for (op, at, pick) in muts {
            obj = mutate_obj(&obj, op, at, pick);
            if obj.is_empty() {
                break;
            }
        }
        std::fs::write(dir.path().join("m.obj"), &obj).unwrap();
        assert_one_line_naming(load_scene(&scene_path, scene.as_bytes()), &scene_path)?;
    }
}

#[test]
fn the_unmutated_inputs_are_valid() {
    for name in SCENES {
        let path = shipped(name);
        load_scene(&path, &std::fs::read(&path).unwrap()).unwrap();
    }
    parse_experiment(Path::new("experiments/fuzz.toml"), EXPERIMENT).unwrap();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("m.obj"), OBJ).unwrap();
    let scene = std::fs::read_to_string(shipped("cornell-empty")).unwrap()
        + "\n[[shapes]]\ntype = \"mesh\"\nmaterial = \"white\"\nfile = \"m.obj\"\n";
    let (_, stats) = load_scene_bytes(&dir.path().join("m.toml"), scene.as_bytes()).unwrap();
    assert_eq!(
        stats.triangles,
        12 + 5,
        "the box and light, then the OBJ: 1 + 1 + 2 (quad) + 1"
    );
}
