//! Bar charts (plotters), written as SVG and PNG like [`super::plot`]: a bar per strategy with
//! confidence-interval error bars, and stacked bars of the time spent per phase.

use super::plot::{FONT, PALETTE, PLOT_SIZE_PX, draw_legend, write_svg_png};
use crate::error::{Error, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// One bar: its label, height and optional error bar `(low, high)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Bar {
    pub label: String,
    pub value: f64,
    pub error: Option<(f64, f64)>,
}

/// One bar made of stacked segments, one value per segment name of the chart.
#[derive(Clone, Debug, PartialEq)]
pub struct Stack {
    pub label: String,
    pub values: Vec<f64>,
}

/// What to draw: bars, each a stack of segments (one segment for a plain bar).
struct Chart<'a> {
    title: &'a str,
    y_label: &'a str,
    labels: Vec<&'a str>,
    /// Per bar, per segment: the value (≥ 0, non-finite drawn as 0).
    segments: Vec<Vec<f64>>,
    segment_names: &'a [String],
    errors: Vec<Option<(f64, f64)>>,
    y_max: f64,
}

fn finite_or_zero(v: f64) -> f64 {
    if v.is_finite() { v.max(0.0) } else { 0.0 }
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    c: &Chart,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let n = c.labels.len() as i32;
    let mut chart = ChartBuilder::on(root)
        .caption(c.title, (FONT, 26))
        .margin(16)
        .x_label_area_size(64)
        .y_label_area_size(90)
        // A segmented range a..b has b − a + 1 segments.
        .build_cartesian_2d((0..(n - 1).max(0)).into_segmented(), 0f64..c.y_max)?;
    let labels = c.labels.clone();
    let x_format = move |v: &SegmentValue<i32>| match v {
        SegmentValue::CenterOf(i) => labels.get(*i as usize).map_or(String::new(), |s| s.to_string()),
        _ => String::new(),
    };
    let y_format = |v: &f64| format!("{v:.3e}");
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(c.labels.len())
        .x_label_formatter(&x_format)
        .y_label_formatter(&y_format)
        .y_desc(c.y_label)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 18))
        .light_line_style(RGBColor(232, 232, 232))
        .bold_line_style(RGBColor(200, 200, 200))
        .draw()?;

    let stacked = c.segment_names.len() > 1;
    for (k, name) in c.segment_names.iter().enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        let rects = c.segments.iter().enumerate().map(|(i, values)| {
            let base: f64 = values[..k].iter().copied().map(finite_or_zero).sum();
            let top = base + finite_or_zero(values[k]);
            let mut r = Rectangle::new(
                [
                    (SegmentValue::Exact(i as i32), base),
                    (SegmentValue::Exact(i as i32 + 1), top),
                ],
                colour.filled(),
            );
            r.set_margin(0, 0, 12, 12);
            r
        });
        let drawn = chart.draw_series(rects)?;
        if stacked {
            drawn
                .label(name.as_str())
                .legend(move |(x, y)| Rectangle::new([(x - 8, y - 6), (x + 8, y + 6)], colour.filled()));
        }
    }
    // Error bars: a vertical line from low to high with caps.
    let style = BLACK.stroke_width(2);
    for (i, e) in c.errors.iter().enumerate() {
        if let Some((lo, hi)) = e {
            let (lo, hi) = (finite_or_zero(*lo), hi.min(c.y_max));
            let x = || SegmentValue::CenterOf(i as i32);
            chart.draw_series(std::iter::once(PathElement::new(vec![(x(), lo), (x(), hi)], style)))?;
            for y in [lo, hi] {
                chart.draw_series(std::iter::once(
                    EmptyElement::at((x(), y)) + PathElement::new(vec![(-8, 0), (8, 0)], style),
                ))?;
            }
        }
    }
    if stacked {
        draw_legend(&mut chart)?;
    }
    root.present()
}

fn write(chart: &Chart, path_without_ext: &Path) -> Result<()> {
    if chart.labels.is_empty() {
        return Err(Error::new(format!("{}: no bars to draw", path_without_ext.display())));
    }
    write_svg_png(
        path_without_ext,
        PLOT_SIZE_PX,
        |root| draw(&root, chart).map_err(|e| e.to_string()),
        |root| draw(&root, chart).map_err(|e| e.to_string()),
    )
}

/// The top of the y axis: the largest bar or error bar plus 8 %, at least a tiny positive value.
fn y_max(values: impl Iterator<Item = f64>) -> f64 {
    let top = values.filter(|v| v.is_finite()).fold(0.0f64, f64::max);
    if top > 0.0 { top * 1.08 } else { 1.0 }
}

/// A bar chart of `bars` (linear y axis from zero) with their error bars, written to
/// `<path_without_ext>.{svg,png}`.
pub fn bar_chart(title: &str, y_label: &str, bars: &[Bar], path_without_ext: &Path) -> Result<()> {
    let names = [String::new()];
    let chart = Chart {
        title,
        y_label,
        labels: bars.iter().map(|b| b.label.as_str()).collect(),
        segments: bars.iter().map(|b| vec![b.value]).collect(),
        segment_names: &names,
        errors: bars.iter().map(|b| b.error).collect(),
        y_max: y_max(
            bars.iter()
                .flat_map(|b| [Some(b.value), b.error.map(|e| e.1)])
                .flatten(),
        ),
    };
    write(&chart, path_without_ext)
}

/// Stacked bars: one bar per stack, its segments named by `segment_names` from the bottom up
/// (with a legend), written to `<path_without_ext>.{svg,png}`.
pub fn stacked_bar_chart(
    title: &str,
    y_label: &str,
    segment_names: &[String],
    stacks: &[Stack],
    path_without_ext: &Path,
) -> Result<()> {
    if let Some(s) = stacks.iter().find(|s| s.values.len() != segment_names.len()) {
        return Err(Error::new(format!(
            "{}: bar `{}` has {} segments, expected {}",
            path_without_ext.display(),
            s.label,
            s.values.len(),
            segment_names.len()
        )));
    }
    let chart = Chart {
        title,
        y_label,
        labels: stacks.iter().map(|s| s.label.as_str()).collect(),
        segments: stacks.iter().map(|s| s.values.clone()).collect(),
        segment_names,
        errors: vec![None; stacks.len()],
        y_max: y_max(
            stacks
                .iter()
                .map(|s| s.values.iter().copied().map(finite_or_zero).sum()),
        ),
    };
    write(&chart, path_without_ext)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bar_charts_write_svg_and_png_with_labels() {
        let dir = tempfile::tempdir().unwrap();
        let bars = [
            Bar {
                label: "path".into(),
                value: 0.02,
                error: Some((0.015, 0.025)),
            },
            Bar {
                label: "path[max_depth=2]".into(),
                value: 0.05,
                error: None,
            },
        ];
        bar_chart("MSE at 1 s", "MSE", &bars, &dir.path().join("bars")).unwrap();
        let svg = std::fs::read_to_string(dir.path().join("bars.svg")).unwrap();
        assert!(svg.contains("path[max_depth=2]") && svg.contains("MSE at 1 s"));
        assert!(dir.path().join("bars.png").exists());

        let names = vec!["photons".to_string(), "render".to_string()];
        let stacks = [Stack {
            label: "photon_map".into(),
            values: vec![0.5, 1.5],
        }];
        stacked_bar_chart("time", "seconds", &names, &stacks, &dir.path().join("t")).unwrap();
        let svg = std::fs::read_to_string(dir.path().join("t.svg")).unwrap();
        assert!(svg.contains("photons") && svg.contains("render"));
        let bad = [Stack {
            label: "x".into(),
            values: vec![1.0],
        }];
        assert!(stacked_bar_chart("t", "s", &names, &bad, &dir.path().join("u")).is_err());
        assert!(bar_chart("t", "s", &[], &dir.path().join("v")).is_err());
    }
}
