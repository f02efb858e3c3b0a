//! The "adding a strategy" guide (`docs/adding-a-strategy.md`), followed from outside the crate:
//! a tiny strategy declared and registered here runs an experiment end to end, its parameters
//! parsed, checked and recorded from its one declaration. If the guide's steps stop working,
//! this test stops compiling or fails.

use glam::Vec3;
use photon_bench::error::Result;
use photon_bench::experiment::{self, Experiment};
use photon_bench::film::Film;
use photon_bench::params::{Params, Range};
use photon_bench::report::rows::read_csv;
use photon_bench::scene::Scene;
use photon_bench::strategy::{Declared, Registration, Registry, Strategy, render_pixels};
use std::process::Command;

photon_bench::declare_params! {
    /// Parameters of `kind = "eye_light"`.
    pub struct EyeLightParams {
        /// Radiance of the light at the eye: a hit returns albedo · |cos θ| · this.
        intensity: f32 = 1.0, range Range::closed(0.0, 1000.0).of("a radiance");
        /// Add the radiance of emitters seen directly.
        show_emitters: bool = true;
    }
}

/// A light at the eye: the first hit's albedo times the cosine to the ray (the "headlight"
/// shading of scene viewers). Not light transport, but enough to show every step.
pub struct EyeLight {
    params: EyeLightParams,
}

impl Declared for EyeLight {
    const KIND: &'static str = "eye_light";
    const SUMMARY: &'static str = "albedo times cosine at the first hit, lit from the eye (a scene viewer's headlight)";
    type Params = EyeLightParams;

    fn new(params: EyeLightParams) -> Result<Self> {
        Ok(Self { params })
    }
}

impl Strategy for EyeLight {
    fn kind(&self) -> &'static str {
        Self::KIND
    }

    fn params(&self) -> Vec<(String, String)> {
        self.params.columns()
    }

    fn render_pass(&self, scene: &Scene, seed: u64, samples: std::ops::Range<u32>, film: &mut Film) {
        let p = &self.params;
        render_pixels(scene, seed, samples, film, |ray, _rng| {
            let Some(hit) = scene.intersect(ray) else {
                return Vec3::ZERO;
            };
            let cos = hit.ng.dot(ray.d).abs();
            let emitted = match scene.light_of(hit.prim) {
                Some(light) if p.show_emitters => light.le(hit.ng, -ray.d),
                _ => Vec3::ZERO,
            };
            scene.bsdf(&hit).albedo() * cos * p.intensity + emitted
        });
    }
}

const EXPERIMENT: &str = r#"
scenes = ["../scenes/tiny.toml"]
spp = [1, 2]
[[strategy]]
kind = "eye_light"
intensity = 2.0
[[strategy]]
kind = "path"
"#;

mod common;

fn project() -> tempfile::TempDir {
    let dir = common::tiny_project(EXPERIMENT);
    let root = dir.path();
    let o = Command::new(env!("CARGO_BIN_EXE_bench"))
        .current_dir(root)
        .args(["reference", "scenes/tiny.toml", "--spp", "4"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    dir
}

fn registry() -> Registry {
    let mut registry = Registry::builtin();
    registry.register(Registration::of::<EyeLight>()).unwrap();
    registry
}

#[test]
fn a_strategy_registered_outside_the_crate_runs_an_experiment() {
    let dir = project();
    let file = dir.path().join("experiments/tiny.toml");

    // Without the registration the kind is unknown, and the message lists the known ones.
    let err = Experiment::load(&file).unwrap_err().message().to_string();
    assert!(err.contains("unknown strategy kind `eye_light`"), "{err}");

    let exp = Experiment::load_with(&file, &registry()).unwrap();
    let outcome = experiment::run(&exp, false).unwrap();
    let rows = read_csv(&outcome.dir.join("metrics.csv")).unwrap();
    let ours: Vec<_> = rows.iter().filter(|r| r.kind == "eye_light").collect();
    assert_eq!(ours.len(), 2, "one row per spp checkpoint");
    // The params column comes from the declaration: every key, defaults included.
    assert!(
        ours.iter().all(|r| r.params == "intensity=2;show_emitters=true"),
        "{}",
        ours[0].params
    );
    assert!(ours.iter().all(|r| r.mse.is_finite() && r.mean_g > 0.0));
    for r in &ours {
        assert!(outcome.dir.join(&r.image).is_file(), "{}", r.image);
    }
}

#[test]
fn a_registered_strategy_gets_its_declared_checks_and_docs() {
    let mut registry = registry();
    let build = |text: &str| registry.build("eye_light", toml::from_str(text).unwrap());
    assert!(build("").is_ok());
    let err = |text: &str| build(text).err().unwrap().message().to_string();
    assert_eq!(
        err("intensity = -1.0"),
        "intensity: expected a radiance in [0, 1000], got -1"
    );
    assert!(err("intensty = 1.0").contains("unknown field `intensty`"));
    assert!(err("show_emitters = 1").starts_with("show_emitters: "));
    assert!(
        registry.register(Registration::of::<EyeLight>()).is_err(),
        "a kind registers once"
    );

    let eye = registry.get("eye_light").unwrap();
    let specs = (eye.specs)();
    assert_eq!(specs.len(), 2);
    assert_eq!(specs[0].name, "intensity");
    assert_eq!(specs[0].default.as_deref(), Some("1.0"));
    assert_eq!(specs[0].range.as_deref(), Some("a radiance in [0, 1000]"));
    assert!(registry.kinds().contains(&"eye_light") && registry.kinds().contains(&"path"));
    assert!(!Registry::builtin().kinds().contains(&"eye_light"));
}

/// `bench list` prints each strategy as a `[[strategy]]` table an experiment file takes
/// unchanged: it parses, and builds the strategy with its defaults; every parameter that is
/// absent by default is printed commented out with a value that builds too.
#[test]
fn every_listed_default_parses_back_and_builds() {
    let registry = Registry::builtin();
    for r in registry.iter() {
        let listing = r.toml_listing();
        let strategy = |text: &str| -> toml::Table {
            let doc: toml::Table = toml::from_str(text).unwrap_or_else(|e| panic!("{}: {e}\n{text}", r.kind));
            let mut table = doc["strategy"].as_array().unwrap()[0].as_table().unwrap().clone();
            assert_eq!(table.remove("kind").unwrap().as_str(), Some(r.kind));
            table
        };
        let built = registry.build(r.kind, strategy(&listing)).unwrap();
        let defaults = registry.build(r.kind, toml::Table::new()).unwrap();
        assert_eq!(
            built.params(),
            defaults.params(),
            "{}: listed defaults are the defaults",
            r.kind
        );
        for line in listing.lines().filter(|l| l.starts_with("# ") && l.contains(" = ")) {
            let uncommented = listing.replacen(line, &line[2..], 1);
            let table = strategy(&uncommented);
            if let Err(e) = registry.build(r.kind, table) {
                panic!("{}: `{}` does not build: {}", r.kind, &line[2..], e.message());
            }
        }
    }
}

#[test]
fn the_parameter_reference_in_the_docs_is_current() {
    let generated = photon_bench::strategy::registry::reference_markdown(&Registry::builtin());
    let committed = std::fs::read_to_string("docs/strategies.md").unwrap_or_default();
    assert!(
        committed == generated,
        "docs/strategies.md is stale: cargo run --release -- list --markdown > docs/strategies.md"
    );
}
