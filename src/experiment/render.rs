//! `bench render`: one image of a scene by any strategy, with the provenance a result row
//! carries. What a researcher reaches for to look at one strategy on one scene, and what the
//! Mitsuba cross-checks use to test any unbiased strategy (not only `path`) pixel by pixel
//! against Mitsuba 3 (`scripts/crosscheck_mitsuba.py --strategy`).

use crate::error::{Error, Result};
use crate::film::{Film, write_exr};
use crate::scene::Scene;
use crate::strategy::{self, Strategy};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How an image was made (the `.json` beside the EXR).
#[derive(Clone, Debug, Serialize)]
pub struct RenderInfo {
    pub scene: String,
    pub scene_file: String,
    pub scene_hash: String,
    pub strategy: String,
    pub params: Vec<(String, String)>,
    pub spp: u32,
    pub seed: u64,
    pub seconds: f64,
    pub threads: usize,
    pub cpu: String,
    pub git_revision: String,
    pub width: u32,
    pub height: u32,
    pub non_finite: u64,
}

/// The strategy parameters of `--set NAME=VALUE` as the table an experiment's `[[strategy]]`
/// would hold: VALUE is read as a TOML value (`8`, `0.5`, `true`, `"bpt"`, `[1, 2]`), and as a
/// string when it is not one (`mode=bpt`).
pub fn params_from_args(args: &[String]) -> Result<toml::Table> {
    let mut table = toml::Table::new();
    for arg in args {
        let (name, value) = arg
            .split_once('=')
            .map(|(k, v)| (k.trim(), v.trim()))
            .filter(|(k, _)| !k.is_empty())
            .ok_or_else(|| Error::new(format!("--set: expected NAME=VALUE, got {arg:?}")))?;
        let value = toml::from_str::<toml::Table>(&format!("v = {value}"))
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| toml::Value::String(value.to_string()));
        if table.insert(name.to_string(), value).is_some() {
            return Err(Error::new(format!("--set: parameter `{name}` given twice")));
        }
    }
    Ok(table)
}

/// Builds strategy `kind` with `params`, checks that it renders `scene`, prepares it for `seed`:
/// every refusal happens here, before anything is rendered or written.
pub fn prepare(scene: &Scene, kind: &str, params: toml::Table, seed: u64) -> Result<Box<dyn Strategy>> {
    let mut s = strategy::build(kind, params)?;
    strategy::check_scene(&*s, scene)?;
    s.prepare(scene, seed)?;
    Ok(s)
}

/// Renders `spp` samples of every pixel with `strategy` (prepared for `seed`) and writes the
/// EXR to `out`, an sRGB preview (`.png`) and its provenance (`.json`) beside it, each
/// atomically. `on_pass` is called
/// after each pass with the samples done so far.
pub fn render(
    scene: &Scene,
    strategy: &dyn Strategy,
    spp: u32,
    seed: u64,
    out: &Path,
    mut on_pass: impl FnMut(u32),
) -> Result<PathBuf> {
    let mut film = Film::new(scene.camera.width, scene.camera.height);
    let start = Instant::now();
    let pass = spp.clamp(1, 16);
    let mut done = 0;
    while done < spp {
        let next = (done + pass).min(spp);
        strategy.render_pass(scene, seed, done..next, &mut film);
        done = next;
        on_pass(done);
    }
    let seconds = start.elapsed().as_secs_f64();
    let image = film.image();
    let info = RenderInfo {
        scene: scene.name.clone(),
        scene_file: scene.source.display().to_string(),
        scene_hash: scene.content_hash.clone(),
        strategy: strategy.kind().to_string(),
        params: strategy.params(),
        spp,
        seed,
        seconds,
        threads: rayon::current_num_threads(),
        cpu: crate::util::cpu_model(),
        git_revision: crate::util::git_revision(),
        width: image.width,
        height: image.height,
        non_finite: film.non_finite(),
    };
    let json = serde_json::to_string_pretty(&info).map_err(|e| Error::new(e.to_string()))?;
    write_exr(&image, out)?;
    crate::film::write_png(&image, &out.with_extension("png"), 0.0)?;
    crate::util::write_atomic(&out.with_extension("json"), json.as_bytes())?;
    Ok(out.to_path_buf())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_arguments_read_as_toml_values_or_strings() {
        let t = params_from_args(&[
            "max_depth=8".into(),
            "mode=bpt".into(),
            "alpha = 0.5".into(),
            "x=\"y\"".into(),
        ])
        .unwrap();
        assert_eq!(t["max_depth"], toml::Value::Integer(8));
        assert_eq!(t["mode"], toml::Value::String("bpt".into()));
        assert_eq!(t["alpha"], toml::Value::Float(0.5));
        assert_eq!(t["x"], toml::Value::String("y".into()));
        for bad in ["max_depth", "=3"] {
            let e = params_from_args(&[bad.into()]).unwrap_err().to_string();
            assert!(e.starts_with("--set: expected NAME=VALUE"), "{e}");
        }
        let e = params_from_args(&["a=1".into(), "a=2".into()]).unwrap_err().to_string();
        assert!(e.contains("`a` given twice"), "{e}");
    }
}
