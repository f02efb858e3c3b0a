//! `index.html`: one page that shows a run. On top, the interactive comparison viewer
//! ([`super::page`]); then per scene the convergence plots and bar charts (inline SVG), the
//! table of the largest checkpoints, and, folded, the counters, Christensen's final-gathering
//! tables, photon figures, strips and every image. Built from the result rows and the files of
//! the run directory alone; the script and data are inline, every link is relative and nothing
//! external is loaded, so the page opens offline, straight from disk.

use super::rows::{BUDGET_SECONDS, BUDGET_SPP, Group, Row, distinct, group};
use super::stats::{CONFIDENCE, Summary};
use crate::error::Result;
use std::fmt::Write as _;
use std::path::Path;

/// The image strip of `scene` at a checkpoint, relative to the run directory: every strategy
/// of the first seed side by side, in the experiment's order, then the reference.
pub fn strip_path(scene: &str, budget: &str, value: f64) -> String {
    if budget == BUDGET_SECONDS {
        format!("images/{scene}_strip_t{value}s.png")
    } else {
        format!("images/{scene}_strip_spp{value}.png")
    }
}

/// The equal-spp progression of `scene`, relative to the run directory: one row per strategy
/// (the experiment's order, then the reference alone), one column per spp checkpoint, first
/// seed — Jensen 1995's Fig. 4 is two of its rows.
pub fn progression_path(scene: &str) -> String {
    format!("images/{scene}_progression_spp.png")
}

/// Escapes text for HTML.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

const STYLE: &str = "body{font-family:sans-serif;margin:1em auto;max-width:1420px;padding:0 1em;color:#111}\
h1{margin:0.2em 0}h2{border-bottom:1px solid #ccc;margin-top:1.6em}\
img{max-width:100%}figure{display:inline-block;margin:0.4em;vertical-align:top}\
figcaption{font-size:85%;max-width:480px;word-wrap:break-word}\
.px img{image-rendering:pixelated;width:240px}.strip img{image-rendering:pixelated;min-width:720px}\
.plots{display:grid;grid-template-columns:repeat(auto-fill,minmax(460px,1fr));gap:0.6em}.plots svg{width:100%;height:auto}\
table{border-collapse:collapse;font-size:90%}td,th{border:1px solid #ccc;padding:0.2em 0.6em}\
td{text-align:right}td:first-child{text-align:left}details{margin:0.6em 0}summary{cursor:pointer;font-weight:bold}\
#viewer{background:#f6f6f6;border:1px solid #ddd;padding:0.6em;border-radius:4px}\
#viewer .controls{display:flex;flex-wrap:wrap;gap:0.8em;align-items:center;margin-bottom:0.4em}\
#viewer button{font:inherit;font-size:85%;border:1px solid #bbb;background:#fff;padding:0.15em 0.5em;cursor:pointer;border-radius:3px}\
#viewer button.on{background:#0072b2;color:#fff;border-color:#0072b2}#viewer button.on kbd{color:#111}\
#viewer .stage{display:flex;gap:0.6em;align-items:flex-start}\
#images{display:flex;flex-direction:column;gap:0.2em;min-width:170px;max-height:360px;overflow-y:auto}\
#images button{text-align:left}#viewer figure{margin:0}#viewer canvas{background:#222;display:block;cursor:crosshair}\
#metrics{min-width:230px}#metrics caption{font-weight:bold;text-align:left}#metrics th{text-align:left;font-weight:normal;color:#444}\
#metrics td{text-align:left;max-width:240px;word-break:break-all}.ci{color:#666}\
.scale{display:block;position:relative;width:256px;height:2.2em}.scale canvas{width:256px;height:10px;background:none}\
#colour-bar-labels span{position:absolute;top:12px;transform:translateX(-50%);font-size:80%}\
#pixel{font-family:monospace;font-size:85%;min-height:1.2em;margin:0.3em 0}.keys{font-size:85%;color:#444;margin:0}\
kbd{border:1px solid #bbb;border-radius:3px;padding:0 0.25em;font-size:85%;background:#fff}";

/// The SVG of a chart, ready to sit inline in HTML (no XML prolog, no namespace URL, which
/// inline SVG does not need), or `None` when the run did not draw it.
fn inline_svg(dir: &Path, rel: &str) -> Option<String> {
    let text = std::fs::read_to_string(dir.join(rel)).ok()?;
    let start = text.find("<svg")?;
    Some(text[start..].replacen(" xmlns=\"http://www.w3.org/2000/svg\"", "", 1))
}

/// Writes `index.html` into the run directory `dir`. Files that a run did not write (a plot
/// without data, a strip without images) are left out of the page.
/// `gathers`: Christensen's comparison of final-gathering variants, shown per scene.
/// `exposure`: the viewer's initial exposure in stops (the experiment's `exposure`).
pub fn write_index(rows: &[Row], gathers: &[super::final_gather::Comparison], dir: &Path, exposure: f64) -> Result<()> {
    let mut h = String::new();
    let first = rows.first();
    let name = first.map_or("run", |r| r.experiment.as_str());
    let _ = write!(
        h,
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width\"><title>{}</title><style>{STYLE}</style></head><body>\n<h1>{}</h1>\n",
        esc(name),
        esc(name)
    );
    if let Some(r) = first {
        let _ = writeln!(
            h,
            "<p>Run <code>{}</code> · git <code>{}</code> · {} threads · {}</p>",
            esc(&r.run_id),
            esc(&r.git_revision),
            r.threads,
            esc(&r.cpu)
        );
    }
    let _ = writeln!(
        h,
        "<p><a href=\"metrics.csv\">metrics.csv</a> · <a href=\"metrics_long.csv\">metrics_long.csv</a> · <a href=\"summary.md\">summary.md</a> · \
         <a href=\"experiment.toml\">experiment.toml</a></p>"
    );
    h.push_str(&super::page::viewer(rows, dir, exposure)?);
    let exists = |rel: &str| dir.join(rel).exists();
    let figure = |h: &mut String, class: &str, src: &str, caption: &str| {
        if exists(src) {
            let _ = writeln!(
                h,
                "<figure class=\"{class}\"><a href=\"{0}\"><img src=\"{0}\" alt=\"{1}\"></a><figcaption>{1}</figcaption></figure>",
                esc(src),
                esc(caption)
            );
        }
    };
    let groups = group(rows);
    for scene in distinct(rows, |r| &r.scene) {
        let _ = writeln!(h, "<h2>{}</h2>", esc(scene));
        let _ = writeln!(h, "<h3>Convergence and bars</h3>\n<div class=\"plots\">");
        let mut charts: Vec<String> = super::convergence::PLOTTED_METRICS
            .iter()
            .flat_map(|m| ["vs_spp", "vs_time"].map(|what| format!("{m}_{what}")))
            .collect();
        charts.extend(["mse_equal_time", "mse_equal_spp", "timing"].map(String::from));
        for chart in charts {
            if let Some(svg) = inline_svg(dir, &format!("plots/{scene}_{chart}.svg")) {
                let _ = writeln!(h, "<div>{svg}</div>");
            }
        }
        let _ = writeln!(h, "</div><p>Every chart as SVG and print PNG: <code>plots/</code>.</p>");

        // The largest checkpoint of each budget kind.
        let largest: Vec<Vec<&Group>> = [BUDGET_SPP, BUDGET_SECONDS]
            .iter()
            .filter_map(|&budget| {
                let of = || groups.iter().filter(|g| g.scene == scene && g.budget == budget);
                let top = of().map(|g| g.budget_value).reduce(f64::max)?;
                Some(of().filter(|g| g.budget_value == top).collect())
            })
            .collect();
        let _ = writeln!(
            h,
            "<h3>Largest checkpoints</h3>\n<table><tr><th>strategy</th><th>budget</th><th>n</th><th>MSE</th>\
             <th>{:.0} % CI</th><th>relMSE</th><th>FLIP</th><th>spp</th><th>seconds</th></tr>",
            CONFIDENCE * 100.0
        );
        for g in largest.iter().flatten() {
            let mse = Summary::of(&g.values(|r| r.mse));
            let ci = mse.ci.map_or("–".into(), |(lo, hi)| format!("[{lo:.3e}, {hi:.3e}]"));
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.4e}</td><td>{ci}</td><td>{:.4e}</td><td>{:.4}</td><td>{:.0}</td><td>{:.3}</td></tr>",
                esc(g.strategy),
                esc(&g.budget_label()),
                mse.n,
                mse.mean,
                super::stats::mean(&g.values(|r| r.rel_mse)),
                super::stats::mean(&g.values(|r| r.flip)),
                super::stats::mean(&g.values(|r| r.spp as f64)),
                super::stats::mean(&g.values(|r| r.total_s)),
            );
        }
        let _ = writeln!(h, "</table>");

        let tables = super::final_gather::tables(gathers, scene);
        if !tables.is_empty() {
            let _ = writeln!(
                h,
                "<h3>Final gathering: accelerated vs direct lookups</h3>\n<p>Christensen 1999's comparison, mean over seeds (every seed: <a href=\"final_gather.csv\">final_gather.csv</a>).</p>"
            );
        }
        for (header, lines) in tables {
            let _ = write!(h, "<table><tr>");
            for name in header {
                let _ = write!(h, "<th>{}</th>", esc(name));
            }
            let _ = writeln!(h, "</tr>");
            for line in lines {
                let cells: String = line.iter().map(|c| format!("<td>{}</td>", esc(c))).collect();
                let _ = writeln!(h, "<tr>{cells}</tr>");
            }
            let _ = writeln!(h, "</table><br>");
        }

        if let Some(table) = super::counters::table(rows, scene) {
            let _ = write!(
                h,
                "<h3>Counters</h3>\n<p>What each strategy counted (mean over seeds), at its largest checkpoint of each budget kind.</p>\n<table><tr><th>strategy</th><th>budget</th><th>n</th>"
            );
            for name in &table.names {
                let _ = write!(h, "<th>{}</th>", esc(name));
            }
            let _ = writeln!(h, "</tr>");
            for l in &table.lines {
                let _ = write!(
                    h,
                    "<tr><td>{}</td><td>{}</td><td>{}</td>",
                    esc(&l.strategy),
                    esc(&l.budget),
                    l.seeds
                );
                for v in &l.values {
                    let _ = write!(h, "<td>{}</td>", v.map_or("–".into(), super::counters::show));
                }
                let _ = writeln!(h, "</tr>");
            }
            let _ = writeln!(h, "</table>");
        }

        let figures = super::photons::figure_links(rows, scene, dir);
        if !figures.is_empty() {
            let _ = writeln!(
                h,
                "<h3>Photon-map figures</h3>\n<p>Christensen 1999, Fig. 1; radiance and E/π shown like the renders.</p>"
            );
        }
        for (rel, caption) in &figures {
            figure(&mut h, "px", rel, caption);
        }
        let _ = writeln!(
            h,
            "<details><summary>Image strips and every image of the largest checkpoints</summary>"
        );
        for at in &largest {
            let Some(g) = at.first() else { continue };
            let labels: Vec<&str> = at.iter().map(|g| g.strategy).collect();
            figure(
                &mut h,
                "strip",
                &strip_path(scene, g.budget, g.budget_value),
                &format!(
                    "{}, first seed, left to right: {}, reference",
                    g.budget_label(),
                    labels.join(", ")
                ),
            );
        }
        let spp_strategies = distinct(rows, |r| &r.strategy)
            .into_iter()
            .filter(|s| {
                groups
                    .iter()
                    .any(|g| g.scene == scene && g.strategy == *s && g.budget == BUDGET_SPP)
            })
            .collect::<Vec<_>>();
        figure(
            &mut h,
            "strip",
            &progression_path(scene),
            &format!(
                "equal spp, first seed: one row per strategy ({}), then the reference; one column per spp checkpoint",
                spp_strategies.join(", ")
            ),
        );
        let _ = writeln!(h, "<br>");
        for g in largest.iter().flatten() {
            let Some(r) = g.rows.first() else { continue };
            let png = Path::new(&r.image).with_extension("png").display().to_string();
            let error = png.replace(".png", "_error.png");
            let what = format!("{} · {} · seed {}", g.strategy, g.budget_label(), r.seed);
            figure(&mut h, "px", &png, &what);
            figure(
                &mut h,
                "px",
                &error,
                &format!("{what} · relative error (log viridis, 0.1 % … 1000 %)"),
            );
        }
        let _ = writeln!(h, "</details>");
    }
    let _ = writeln!(h, "</body></html>");
    crate::util::write_atomic(&dir.join("index.html"), h.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escaping_and_strip_names() {
        assert_eq!(esc("a<b>&\"c\""), "a&lt;b&gt;&amp;&quot;c&quot;");
        assert_eq!(strip_path("box", "spp", 64.0), "images/box_strip_spp64.png");
        assert_eq!(strip_path("box", "seconds", 0.5), "images/box_strip_t0.5s.png");
    }
}
