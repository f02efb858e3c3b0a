//! The interactive comparison viewer of `index.html`: per scene, flip between the strategies'
//! images and the reference with the keyboard, zoom and pan the image and its error map in
//! step, change the exposure, and read the metrics of the image shown beside it.
//!
//! **Decision: what is embedded.** The page is one offline file (inline script and data, no
//! network), so the images travel inside it: per scene and budget kind, the first seed's image
//! of every strategy at the largest checkpoint, and the reference. Pixels are IEEE half floats
//! (`half`), each image divided by a power of two that puts its brightest value near 2¹⁴:
//! 0.05 % precision over 28 stops, far below what the error view resolves, at 8 bytes per pixel
//! in base64 (a 1280 × 720 image adds 7.4 MB). The script (`page.js`) tone-maps exactly as the
//! PNG previews are made and computes the error view as [`crate::metrics`]'s per-pixel relative
//! error on its log viridis scale, so the page shows what the run's files hold.
//!
//! The reference is the run's own copy (`references/<scene>.exr` and its sidecar in the run
//! directory); a scene without it gets no viewer.

use super::rows::{BUDGET_SECONDS, BUDGET_SPP, Group, Row, distinct, group};
use super::stats::Summary;
use crate::error::Result;
use crate::film::{Image, read_exr};
use serde_json::{Value, json};
use std::path::Path;

/// The script of the viewer.
const SCRIPT: &str = include_str!("page.js");

/// The viewer's markup; `page.js` fills it.
const MARKUP: &str = r#"<section id="viewer">
<div class="controls"><span id="scenes"></span><span id="budgets"></span>
<label>exposure <input id="exposure" type="range" min="-16" max="16" step="0.5"> <output id="exposure-value"></output></label>
<button id="fit" title="f">fit</button></div>
<div class="stage"><nav id="images"></nav>
<figure><canvas id="view-image" width="440" height="330"></canvas><figcaption>image</figcaption></figure>
<figure><canvas id="view-error" width="440" height="330"></canvas><figcaption>relative error against the reference
<span class="scale"><canvas id="colour-bar" width="256" height="10"></canvas><span id="colour-bar-labels"></span></span></figcaption></figure>
<table id="metrics"></table></div>
<p id="pixel"></p>
<p class="keys"><kbd>1</kbd>…<kbd>9</kbd> image, <kbd>r</kbd> reference, <kbd>←</kbd> <kbd>→</kbd> previous / next image,
<kbd>↑</kbd> <kbd>↓</kbd> scene, <kbd>b</kbd> budget, <kbd>+</kbd> <kbd>-</kbd> exposure (<kbd>0</kbd> resets), wheel zoom,
drag pan, <kbd>f</kbd> fit. Error: √(mean over channels of (I − R)² / (R² + 10⁻³)), log scale.</p>
<div id="status" hidden></div>
</section>"#;

/// Standard base64 (RFC 4648, with padding).
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// The image as little-endian half floats (RGB interleaved) and the power of two they are to
/// be multiplied by: the brightest finite value is stored near 2¹⁴, below half's 65 504.
pub fn encode_half(image: &Image) -> (Vec<u8>, f64) {
    let max = image
        .pixels
        .iter()
        .flat_map(|p| p.to_array())
        .filter(|v| v.is_finite())
        .fold(0.0f32, |m, v| m.max(v.abs()));
    let scale = if max > 0.0 {
        2f64.powi(max.log2().ceil() as i32 - 14)
    } else {
        1.0
    };
    let bytes = image
        .pixels
        .iter()
        .flat_map(|p| p.to_array())
        .flat_map(|v| half::f16::from_f64(v as f64 / scale).to_le_bytes())
        .collect();
    (bytes, scale)
}

fn embedded(image: &Image, label: &str, metrics: Vec<Value>) -> Value {
    let (bytes, scale) = encode_half(image);
    json!({ "label": label, "scale": scale, "data": base64(&bytes), "metrics": metrics })
}

/// One line of the metrics table: name, value, optional confidence interval.
fn line(name: &str, value: Value, ci: Option<(f64, f64)>) -> Value {
    json!([name, value, ci.map(|(lo, hi)| [lo, hi])])
}

/// The metrics shown beside a strategy's image: its own row, then the mean over seeds.
fn row_metrics(r: &Row, g: &Group) -> Vec<Value> {
    let mut out = vec![
        line("strategy", json!(r.strategy), None),
        line("budget", json!(g.budget_label()), None),
        line("seed", json!(r.seed), None),
        line("spp", json!(r.spp), None),
        line("seconds", json!(r.total_s), None),
    ];
    for (name, get) in [
        ("MSE", (|r: &Row| r.mse) as fn(&Row) -> f64),
        ("relMSE", |r: &Row| r.rel_mse),
        ("FLIP", |r: &Row| r.flip),
    ] {
        out.push(line(&format!("{name}, this seed"), json!(get(r)), None));
        let s = Summary::of(&g.values(get));
        out.push(line(&format!("{name}, mean of {}", s.n), json!(s.mean), s.ci));
    }
    out.push(line("params", json!(r.params), None));
    out.push(line("file", json!(r.image), None));
    out
}

/// The reference's lines, from its sidecar.
fn reference_metrics(sidecar: &Value, file: &str) -> Vec<Value> {
    let mut out: Vec<Value> = ["strategy", "spp", "seed", "seconds", "command"]
        .iter()
        .filter_map(|k| sidecar.get(k).map(|v| line(k, v.clone(), None)))
        .collect();
    out.push(line("file", json!(file), None));
    out
}

/// The data of one scene's viewer, or `None` when the run directory holds no reference copy.
fn scene_data(scene: &str, rows: &[Row], dir: &Path) -> Result<Option<Value>> {
    let exr = dir.join("references").join(format!("{scene}.exr"));
    if !exr.is_file() {
        return Ok(None);
    }
    let reference = read_exr(&exr)?;
    let sidecar: Value = std::fs::read_to_string(exr.with_extension("json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or(Value::Null);
    let groups = group(rows);
    let mut budgets = Vec::new();
    for budget in [BUDGET_SPP, BUDGET_SECONDS] {
        let of = || groups.iter().filter(|g| g.scene == scene && g.budget == budget);
        let Some(top) = of().map(|g| g.budget_value).reduce(f64::max) else {
            continue;
        };
        let mut images = Vec::new();
        for g in of().filter(|g| g.budget_value == top) {
            let Some(r) = g.rows.iter().min_by_key(|r| r.seed) else {
                continue;
            };
            let image = read_exr(&dir.join(&r.image))?;
            images.push(embedded(&image, g.strategy, row_metrics(r, g)));
        }
        budgets.push(json!({ "name": super::rows::budget_label(budget, top), "images": images }));
    }
    let spp = sidecar.get("spp").and_then(Value::as_u64);
    let label = spp.map_or("reference".to_string(), |n| format!("reference ({n} spp)"));
    Ok(Some(json!({
        "name": scene,
        "width": reference.width,
        "height": reference.height,
        "budgets": budgets,
        "reference": embedded(&reference, &label, reference_metrics(&sidecar, &format!("references/{scene}.exr"))),
    })))
}

/// The viewer section of `index.html` (markup, data and script) for every scene of `rows`
/// whose reference the run directory holds; empty when none does. `exposure`: the initial
/// exposure in stops (the experiment's, as its previews).
pub fn viewer(rows: &[Row], dir: &Path, exposure: f64) -> Result<String> {
    let mut scenes = Vec::new();
    for scene in distinct(rows, |r| &r.scene) {
        if let Some(data) = scene_data(scene, rows, dir)? {
            scenes.push(data);
        }
    }
    if scenes.is_empty() {
        return Ok(String::new());
    }
    let data = json!({
        "exposure": exposure,
        "viridis": crate::color::VIRIDIS_STOPS,
        "error_min": crate::metrics::ERROR_MAP_MIN,
        "error_max": crate::metrics::ERROR_MAP_MAX,
        "error_nan_rgb": crate::metrics::ERROR_MAP_NAN_RGB,
        "rel_mse_epsilon": crate::metrics::REL_MSE_EPSILON,
        "scenes": scenes,
    });
    // `</` cannot close the script element early once escaped.
    let data = data.to_string().replace("</", "<\\/");
    Ok(format!(
        "{MARKUP}\n<script type=\"application/json\" id=\"viewer-data\">{data}</script>\n<script>{SCRIPT}</script>\n"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn base64_matches_rfc_4648_test_vectors() {
        for (plain, encoded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(plain.as_bytes()), encoded);
        }
        assert_eq!(base64(&[0xfb, 0xff]), "+/8=");
    }

    #[test]
    fn half_encoding_keeps_every_value_to_its_precision_over_a_wide_range() {
        for brightest in [1e-6f32, 0.7, 3.0e4, 2.0e7] {
            let pixels: Vec<Vec3> = (0..64)
                .map(|k| {
                    let v = brightest * 0.5f32.powi(k % 24);
                    Vec3::new(v, 0.3 * v, 0.0)
                })
                .collect();
            let image = Image {
                width: 8,
                height: 8,
                pixels,
            };
            let (bytes, scale) = encode_half(&image);
            assert_eq!(bytes.len(), 64 * 3 * 2);
            assert_eq!(scale.log2().fract(), 0.0, "a power of two: {scale}");
            for (k, p) in image.pixels.iter().enumerate() {
                for c in 0..3 {
                    let i = 2 * (3 * k + c);
                    let decoded = half::f16::from_le_bytes([bytes[i], bytes[i + 1]]).to_f64() * scale;
                    let v = p[c] as f64;
                    assert!(
                        (decoded - v).abs() <= v.abs() * 2f64.powi(-11),
                        "brightest {brightest}: {v} came back as {decoded}"
                    );
                }
            }
        }
    }
}
