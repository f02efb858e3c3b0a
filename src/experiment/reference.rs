//! Reference images: long path-traced renders, stored as `references/<scene>.exr` with a JSON
//! sidecar saying exactly how they were made. Experiments refuse a reference whose scene hash
//! differs from the scene's, and say how to regenerate it.

use crate::error::{Context, Error, Result};
use crate::film::{Film, Image, read_exr, write_exr};
use crate::scene::Scene;
use crate::strategy::Strategy;
use crate::strategy::path::{Path as PathStrategy, PathParams};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How a reference was made (the `.json` sidecar).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ReferenceInfo {
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
    /// The command that reproduces this reference.
    pub command: String,
}

/// A loaded reference.
pub struct Reference {
    pub image: Image,
    pub info: ReferenceInfo,
    /// Content hash of the EXR file.
    pub hash: String,
}

pub fn exr_path(dir: &Path, scene_name: &str) -> PathBuf {
    dir.join(format!("{scene_name}.exr"))
}

fn sidecar_path(exr: &Path) -> PathBuf {
    exr.with_extension("json")
}

/// Loads the reference of `scene` from `dir`, checking that it was made from this scene.
pub fn load(dir: &Path, scene: &Scene) -> Result<Reference> {
    let exr = exr_path(dir, &scene.name);
    let remake = format!("bench reference {}", scene.source.display());
    if !exr.exists() {
        return Err(Error::new(format!(
            "{}: reference missing for scene `{}`; make it with `{remake} --spp <N>`",
            exr.display(),
            scene.name
        )));
    }
    let side = sidecar_path(&exr);
    let text =
        std::fs::read_to_string(&side).context(format!("{}: cannot read the reference's sidecar", side.display()))?;
    let info: ReferenceInfo = serde_json::from_str(&text).context(side.display())?;
    if info.scene_hash != scene.content_hash {
        return Err(Error::new(format!(
            "{}: made from a different version of {} (scene hash {} ≠ {}); regenerate it with `{}`",
            exr.display(),
            scene.source.display(),
            info.scene_hash,
            scene.content_hash,
            info.command
        )));
    }
    let image = read_exr(&exr)?;
    if (image.width, image.height) != (scene.camera.width, scene.camera.height) {
        return Err(Error::new(format!(
            "{}: {}×{} pixels but the scene renders {}×{}; regenerate it with `{}`",
            exr.display(),
            image.width,
            image.height,
            scene.camera.width,
            scene.camera.height,
            info.command
        )));
    }
    let hash = crate::util::content_hash(&[&std::fs::read(&exr).context(exr.display())?]);
    Ok(Reference { image, info, hash })
}

/// Renders a reference with `path` and writes the EXR, a PNG preview and the sidecar into
/// `dir`. `on_pass` is called after each pass with the samples done so far.
pub fn make(
    scene: &Scene,
    dir: &Path,
    spp: u32,
    seed: u64,
    params: PathParams,
    mut on_pass: impl FnMut(u32),
) -> Result<PathBuf> {
    let strategy = PathStrategy::new(params);
    let mut film = Film::new(scene.camera.width, scene.camera.height);
    let start = Instant::now();
    let pass = 16u32;
    let mut done = 0;
    while done < spp {
        let next = (done + pass).min(spp);
        strategy.render_pass(scene, seed, done..next, &mut film);
        done = next;
        on_pass(done);
    }
    let seconds = start.elapsed().as_secs_f64();
    let image = film.image();
    let exr = exr_path(dir, &scene.name);
    // Every parameter, defaults included, so the command stays right if defaults change.
    let param_args: String = strategy
        .params()
        .iter()
        .map(|(k, v)| format!(" --{} {v}", k.replace('_', "-")))
        .collect();
    let info = ReferenceInfo {
        scene: scene.name.clone(),
        scene_file: scene.source.display().to_string(),
        scene_hash: scene.content_hash.clone(),
        strategy: strategy.kind().to_string(),
        params: strategy.params().into_iter().map(|(k, v)| (k.to_string(), v)).collect(),
        spp,
        seed,
        seconds,
        threads: rayon::current_num_threads(),
        cpu: crate::util::cpu_model(),
        git_revision: crate::util::git_revision(),
        width: image.width,
        height: image.height,
        non_finite: film.non_finite(),
        command: format!(
            "bench reference {} --spp {spp} --seed {seed}{param_args}",
            scene.source.display()
        ),
    };
    write_exr(&image, &exr)?;
    crate::film::write_png(&image, &exr.with_extension("png"), 0.0)?;
    let json = serde_json::to_string_pretty(&info).map_err(|e| Error::new(e.to_string()))?;
    crate::util::write_atomic(&sidecar_path(&exr), json.as_bytes())?;
    Ok(exr)
}
