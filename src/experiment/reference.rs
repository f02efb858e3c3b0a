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
    /// The reference's own noise; absent from references made before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<ReferenceNoise>,
}

/// The reference's own noise, estimated from two independent halves of its samples.
///
/// A reference R is the mean of the samples of two films A and B (alternate passes, `n_A` and
/// `n_B` samples in a pixel). For independent, unbiased halves, `(A − B)² · n_A n_B / (n_A +
/// n_B)²` is an unbiased estimate of Var(R) in that pixel, and any image I independent of R
/// has E[(I − R)²] = E[(I − truth)²] + Var(R): every measured MSE carries `mse` on top of the
/// true error, and every relMSE about `rel_mse`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ReferenceNoise {
    /// Mean over pixels and channels of the estimated Var(R).
    pub mse: f64,
    /// Mean over pixels and channels of Var(R) / (R² + ε), ε = [`crate::metrics::REL_MSE_EPSILON`].
    pub rel_mse: f64,
}

impl ReferenceNoise {
    /// The noise of the mean of two independent films' samples (module doc of the type).
    pub fn of_halves(a: &Film, b: &Film) -> Option<ReferenceNoise> {
        let (mut mse, mut rel_mse, mut n) = (0.0, 0.0, 0usize);
        for (pa, pb) in a.accumulators().iter().zip(b.accumulators()) {
            if pa.count == 0 || pb.count == 0 {
                continue;
            }
            let (na, nb) = (pa.count as f64, pb.count as f64);
            let (ma, mb) = (pa.sum / na, pb.sum / nb);
            let r = (pa.sum + pb.sum) / (na + nb);
            let var = (ma - mb) * (ma - mb) * (na * nb / ((na + nb) * (na + nb)));
            mse += var.element_sum();
            rel_mse += (var / (r * r + crate::metrics::REL_MSE_EPSILON)).element_sum();
            n += 3;
        }
        (n > 0).then(|| ReferenceNoise {
            mse: mse / n as f64,
            rel_mse: rel_mse / n as f64,
        })
    }
}

/// A loaded reference.
pub struct Reference {
    pub image: Image,
    pub info: ReferenceInfo,
    /// Content hash of the EXR file.
    pub hash: String,
}

impl Reference {
    /// The MSE the reference's own noise adds to every measured MSE ([`ReferenceNoise`]); NaN
    /// when the reference does not record it.
    pub fn noise_mse(&self) -> f64 {
        self.info.noise.as_ref().map_or(f64::NAN, |n| n.mse)
    }
}

/// Above this share of a measured MSE, the reference's own noise is reported: the error is
/// then in good part the reference's.
pub const NOISE_WARNING_SHARE: f64 = 0.1;

/// One line per scene and strategy whose smallest mean MSE over its checkpoints is less than
/// 1 / [`NOISE_WARNING_SHARE`] times the reference's own noise.
pub fn noise_warnings(rows: &[crate::report::rows::Row]) -> Vec<String> {
    use crate::report::rows::{distinct, group};
    let groups = group(rows);
    let mut out = Vec::new();
    for scene in distinct(rows, |r| &r.scene) {
        for strategy in distinct(rows, |r| &r.strategy) {
            let of = || groups.iter().filter(|g| g.scene == scene && g.strategy == strategy);
            let mean_mse = |g: &&crate::report::rows::Group| crate::report::stats::mean(&g.values(|r| r.mse));
            // The most converged checkpoint: where the reference's noise weighs most.
            let Some(g) = of().min_by(|a, b| mean_mse(a).total_cmp(&mean_mse(b))) else {
                continue;
            };
            let noise = crate::report::stats::mean(&g.values(|r| r.reference_mse));
            let mse = crate::report::stats::mean(&g.values(|r| r.mse));
            if noise.is_finite() && mse > 0.0 && noise > NOISE_WARNING_SHARE * mse {
                let spp = g.rows.first().map_or(0, |r| r.reference_spp);
                out.push(format!(
                    "{scene}: the reference's own noise ({spp} spp) adds an expected MSE of {noise:.3e}, {:.0} % of {strategy}'s {mse:.3e} at {}; the column reference_mse holds it (subtract it for the error against the converged image), or render a longer reference",
                    100.0 * noise / mse,
                    g.budget_label()
                ));
            }
        }
    }
    out
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
    // The command writes where this experiment reads (`--out`), from the same directory.
    let out = format!("--out {}", dir.display());
    if !exr.exists() && std::fs::symlink_metadata(&exr).is_err() {
        return Err(Error::new(format!(
            "{}: reference missing for scene `{}`; make it with `bench reference {}{} --spp <N> {out}`",
            exr.display(),
            scene.name,
            scene.source.display(),
            scene_param_args(&scene.params)
        )));
    }
    let side = sidecar_path(&exr);
    let text = crate::util::read_input_to_string(&side, "reference's sidecar", crate::util::MAX_TEXT_INPUT)?;
    let info: ReferenceInfo = serde_json::from_str(&text).context(side.display())?;
    if info.scene_hash != scene.content_hash {
        return Err(Error::new(format!(
            "{}: made from a different version of {} (scene hash {} ≠ {}); regenerate it with `{} {out} --force`",
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
            "{}: {}×{} pixels but the scene renders {}×{}; regenerate it with `{} {out} --force`",
            exr.display(),
            image.width,
            image.height,
            scene.camera.width,
            scene.camera.height,
            info.command
        )));
    }
    let hash = crate::util::content_hash(&[&crate::util::read_input(
        &exr,
        "reference EXR",
        crate::util::MAX_IMAGE_INPUT,
    )?]);
    Ok(Reference { image, info, hash })
}

/// ` --param k=v` for each Mitsuba scene parameter: what `bench reference` needs to load the
/// same scene.
fn scene_param_args(params: &[(String, String)]) -> String {
    params.iter().map(|(k, v)| format!(" --param {k}={v}")).collect()
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
    // Alternate passes go to two films, the two independent halves that measure the
    // reference's own noise ([`ReferenceNoise`]); the reference is the mean of all samples.
    let mut halves = [
        Film::new(scene.camera.width, scene.camera.height),
        Film::new(scene.camera.width, scene.camera.height),
    ];
    let start = Instant::now();
    let pass = (spp / 2).clamp(1, 16);
    let (mut done, mut k) = (0, 0);
    while done < spp {
        let next = (done + pass).min(spp);
        strategy.render_pass(scene, seed, done..next, &mut halves[k % 2]);
        done = next;
        k += 1;
        on_pass(done);
    }
    let seconds = start.elapsed().as_secs_f64();
    let noise = ReferenceNoise::of_halves(&halves[0], &halves[1]);
    let [mut film, second] = halves;
    film.absorb(&second);
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
        noise,
        command: format!(
            "bench reference {}{} --spp {spp} --seed {seed}{param_args}",
            scene.source.display(),
            scene_param_args(&scene.params)
        ),
    };
    write_exr(&image, &exr)?;
    crate::film::write_png(&image, &exr.with_extension("png"), 0.0)?;
    let json = serde_json::to_string_pretty(&info).map_err(|e| Error::new(e.to_string()))?;
    crate::util::write_atomic(&sidecar_path(&exr), json.as_bytes())?;
    Ok(exr)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::rows::{BUDGET_SPP, Row};

    /// The noise a reference records from its halves predicts how far two independent
    /// references of the same scene lie apart: E[MSE(R₁, R₂)] = Var(R₁) + Var(R₂) = 2 · noise.
    #[test]
    fn recorded_noise_predicts_the_distance_between_two_independent_references() {
        let scene =
            crate::scene::load_scene(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/ci-tiny.toml"))).unwrap();
        let spp = 32;
        let (mut predicted, mut measured) = (0.0, 0.0);
        for pair in 0..PAIRS {
            let refs: Vec<Reference> = (0..2)
                .map(|k| {
                    let dir = tempfile::tempdir().unwrap();
                    make(
                        &scene,
                        dir.path(),
                        spp,
                        1000 + 2 * pair + k,
                        PathParams::default(),
                        |_| {},
                    )
                    .unwrap();
                    load(dir.path(), &scene).unwrap()
                })
                .collect();
            let noise = |r: &Reference| r.info.noise.clone().expect("a new reference records its noise");
            predicted += noise(&refs[0]).mse + noise(&refs[1]).mse;
            measured += crate::metrics::compare(&refs[0].image, &refs[1].image).unwrap().mse;
        }
        assert!(
            (measured / predicted - 1.0).abs() < 0.25,
            "MSE between references {measured:.4e}, predicted from their halves {predicted:.4e}"
        );
    }
    const PAIRS: u64 = 24;

    #[test]
    fn halves_of_identical_samples_have_no_noise_and_empty_films_none() {
        let mut a = Film::new(2, 1);
        use rayon::prelude::*;
        a.rows_mut().for_each(|(_, row)| {
            for p in row {
                p.add(glam::Vec3::splat(0.5));
                p.add(glam::Vec3::splat(0.5));
            }
        });
        let b = a.clone();
        assert_eq!(ReferenceNoise::of_halves(&a, &b).unwrap().mse, 0.0);
        assert!(ReferenceNoise::of_halves(&a, &Film::new(2, 1)).is_none());
        let mut merged = a.clone();
        merged.absorb(&b);
        assert_eq!(merged.accumulators()[0].count, 4);
        assert_eq!(merged.image().pixels[0], glam::Vec3::splat(0.5));
    }

    #[test]
    fn noise_is_reported_where_it_is_a_sizable_share_of_a_measured_error() {
        let row = |strategy: &str, spp: f64, mse: f64| Row {
            scene: "s".into(),
            strategy: strategy.into(),
            budget: BUDGET_SPP.into(),
            budget_value: spp,
            reference_spp: 1024,
            mse,
            reference_mse: 0.002,
            ..Row::default()
        };
        // `fast` gets down to 0.01 (the noise is 20 % of it), `slow` only to 0.1 (2 %).
        let rows = [row("fast", 1.0, 0.1), row("fast", 16.0, 0.01), row("slow", 16.0, 0.1)];
        let warnings = noise_warnings(&rows);
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        assert!(warnings[0].contains("fast") && warnings[0].contains("20 %") && warnings[0].contains("16 spp"));
        // References without the record warn about nothing.
        let old: Vec<Row> = rows
            .iter()
            .map(|r| Row {
                reference_mse: f64::NAN,
                ..r.clone()
            })
            .collect();
        assert!(noise_warnings(&old).is_empty());
    }
}
