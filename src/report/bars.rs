//! Bar charts (plotters), written as SVG and PNG like [`super::plot`]: a bar per strategy with
//! confidence-interval error bars, and stacked bars of the time spent per phase.
//!
//! Bars lie horizontally, one strategy per row, so that long labels (`path[max_depth=2]`)
//! read without rotation or overlap. A value axis whose bars span a decade or more is
//! logarithmic, as error values of different methods routinely differ by orders of magnitude.

use super::chart::{FONT, LegendEntry, PLOT_SIZE_PX, Scale, draw_legend_beside, house_mesh, layout, write_svg_png};
use super::plot::{log_ticks, tick_label};
use crate::error::{Error, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// Paul Tol's colour-blind-safe "light" scheme, for the phases of stacked bars: phases are not
/// strategies, so they must not borrow the strategies' colours.
const PHASE_PALETTE: [RGBColor; 8] = [
    RGBColor(119, 170, 221),
    RGBColor(238, 136, 102),
    RGBColor(238, 221, 136),
    RGBColor(255, 170, 187),
    RGBColor(153, 221, 255),
    RGBColor(68, 187, 153),
    RGBColor(187, 204, 51),
    RGBColor(170, 170, 0),
];

/// One bar: its label, colour, height and optional error bar `(low, high)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Bar {
    pub label: String,
    pub colour: RGBColor,
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
    value_label: &'a str,
    labels: Vec<&'a str>,
    /// Per bar, per segment: the value (≥ 0, non-finite drawn as 0).
    segments: Vec<Vec<f64>>,
    /// Per segment (stacked) or per bar (plain): its colour.
    colours: Vec<RGBColor>,
    /// Legend entries (stacked charts: the segment names).
    legend: Vec<(String, RGBColor)>,
    errors: Vec<Option<(f64, f64)>>,
    axis: Axis,
    /// Colours are per segment (stacked bars), not per bar.
    stacked: bool,
}

/// The value axis.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Axis {
    Linear { max: f64 },
    Log { min: f64, max: f64 },
}

fn finite_or_zero(v: f64) -> f64 {
    if v.is_finite() { v.max(0.0) } else { 0.0 }
}

/// A log axis when the positive values span a decade or more (and none is zero); else a linear
/// axis from zero. Margins: 8 % above the top; a third of a decade below the bottom on log axes.
fn axis_for(values: impl Iterator<Item = f64> + Clone) -> Axis {
    let positive = values.clone().filter(|v| v.is_finite() && *v > 0.0);
    let (lo, hi) = positive.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
    let has_zero = values.into_iter().any(|v| !(v.is_finite() && v > 0.0));
    if hi <= 0.0 {
        return Axis::Linear { max: 1.0 };
    }
    if !has_zero && hi / lo >= 10.0 {
        Axis::Log {
            min: lo / 10f64.powf(1.0 / 3.0),
            max: hi * 1.5,
        }
    } else {
        Axis::Linear { max: hi * 1.08 }
    }
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    c: &Chart,
    s: Scale,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let entries: Vec<LegendEntry> = c
        .legend
        .iter()
        .map(|(label, colour)| LegendEntry {
            label,
            colour: *colour,
            line: None,
        })
        .collect();
    let (data, legend) = layout(root, c.title, &entries, s)?;
    let font: TextStyle = (FONT, s.font(15.0)).into();
    let label_width = c
        .labels
        .iter()
        .map(|l| data.estimate_text_size(l, &font).map_or(0, |(w, _)| w as i32))
        .max()
        .unwrap_or(0);
    let n = c.labels.len() as i32;
    let builder = || {
        let mut b = ChartBuilder::on(&data);
        b.margin(s.px(12))
            .x_label_area_size(s.px(52))
            .y_label_area_size(label_width + s.px(16));
        b
    };
    // Bars top-down in the given order: row i sits at segment n − 1 − i.
    let row = |i: usize| n - 1 - i as i32;
    let labels = c.labels.clone();
    let y_format = move |v: &SegmentValue<i32>| match v {
        SegmentValue::CenterOf(k) => labels
            .get((n - 1 - k) as usize)
            .map_or(String::new(), |s| s.to_string()),
        _ => String::new(),
    };
    let rows = (0..(n - 1).max(0)).into_segmented();
    macro_rules! bars_on {
        ($chart:expr, $base:expr) => {{
            let mut chart = $chart;
            let x_format = |v: &f64| tick_label(*v);
            house_mesh(&mut chart.configure_mesh(), s)
                .disable_y_mesh()
                .x_max_light_lines(1)
                .y_labels(c.labels.len())
                .y_label_formatter(&y_format)
                .x_label_formatter(&x_format)
                .x_desc(c.value_label)
                .draw()?;
            let stacked = c.stacked;
            for (i, values) in c.segments.iter().enumerate() {
                let mut base: f64 = $base;
                for (k, v) in values.iter().enumerate() {
                    let top = if stacked {
                        base + finite_or_zero(*v)
                    } else {
                        finite_or_zero(*v).max($base)
                    };
                    let colour = if stacked { c.colours[k] } else { c.colours[i] };
                    let mut r = Rectangle::new(
                        [
                            (base, SegmentValue::Exact(row(i))),
                            (top, SegmentValue::Exact(row(i) + 1)),
                        ],
                        colour.filled(),
                    );
                    r.set_margin(s.px(6) as u32, s.px(6) as u32, 0, 0);
                    chart.draw_series(std::iter::once(r))?;
                    base = top;
                }
            }
            // Error bars: a horizontal line from low to high with caps, on a white halo so
            // that they stay visible over dark bars.
            for style in [WHITE.stroke_width(s.stroke(4.5)), BLACK.stroke_width(s.stroke(1.5))] {
                for (i, e) in c.errors.iter().enumerate() {
                    let Some((lo, hi)) = *e else { continue };
                    let (lo, hi) = (finite_or_zero(lo).max($base), hi);
                    if !hi.is_finite() {
                        continue;
                    }
                    let y = || SegmentValue::CenterOf(row(i));
                    chart.draw_series(std::iter::once(PathElement::new(vec![(lo, y()), (hi, y())], style)))?;
                    for x in [lo, hi] {
                        chart.draw_series(std::iter::once(
                            EmptyElement::at((x, y())) + PathElement::new(vec![(0, -s.px(7)), (0, s.px(7))], style),
                        ))?;
                    }
                }
            }
        }};
    }
    match c.axis {
        Axis::Linear { max } => bars_on!(builder().build_cartesian_2d(0f64..max, rows)?, 0.0),
        Axis::Log { min, max } => bars_on!(
            builder().build_cartesian_2d((min..max).log_scale().with_key_points(log_ticks(min, max)), rows)?,
            min
        ),
    }
    draw_legend_beside(&legend, &entries, s)?;
    root.present()
}

fn write(chart: &Chart, path_without_ext: &Path) -> Result<()> {
    if chart.labels.is_empty() {
        return Err(Error::new(format!("{}: no bars to draw", path_without_ext.display())));
    }
    // Taller when there are many bars, so that rows stay readable.
    let size = (PLOT_SIZE_PX.0, PLOT_SIZE_PX.1.max(140 + 34 * chart.labels.len() as u32));
    write_svg_png(
        path_without_ext,
        size,
        |root, s| draw(&root, chart, s).map_err(|e| e.to_string()),
        |root, s| draw(&root, chart, s).map_err(|e| e.to_string()),
    )
}

/// A bar chart of `bars` with their error bars, on a log axis when they span a decade or
/// more, written to `<path_without_ext>.{svg,png}`.
pub fn bar_chart(title: &str, value_label: &str, bars: &[Bar], path_without_ext: &Path) -> Result<()> {
    let values = bars
        .iter()
        .flat_map(|b| [Some(b.value), b.error.map(|e| e.1), b.error.map(|e| e.0)])
        .flatten();
    let chart = Chart {
        title,
        value_label,
        labels: bars.iter().map(|b| b.label.as_str()).collect(),
        segments: bars.iter().map(|b| vec![b.value]).collect(),
        colours: bars.iter().map(|b| b.colour).collect(),
        legend: Vec::new(),
        errors: bars.iter().map(|b| b.error).collect(),
        axis: axis_for(values.collect::<Vec<_>>().into_iter()),
        stacked: false,
    };
    write(&chart, path_without_ext)
}

/// Stacked bars on a linear axis (segments add up): one bar per stack, its segments named by
/// `segment_names` from the left, with a legend, written to `<path_without_ext>.{svg,png}`.
pub fn stacked_bar_chart(
    title: &str,
    value_label: &str,
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
    let colours: Vec<RGBColor> = (0..segment_names.len())
        .map(|k| PHASE_PALETTE[k % PHASE_PALETTE.len()])
        .collect();
    let totals: Vec<f64> = stacks
        .iter()
        .map(|s| s.values.iter().copied().map(finite_or_zero).sum())
        .collect();
    let max = totals.iter().copied().fold(0.0, f64::max);
    let chart = Chart {
        title,
        value_label,
        labels: stacks.iter().map(|s| s.label.as_str()).collect(),
        segments: stacks.iter().map(|s| s.values.clone()).collect(),
        legend: segment_names.iter().cloned().zip(colours.iter().copied()).collect(),
        colours,
        errors: vec![None; stacks.len()],
        axis: Axis::Linear {
            max: if max > 0.0 { max * 1.08 } else { 1.0 },
        },
        stacked: true,
    };
    write(&chart, path_without_ext)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bar(label: &str, value: f64, error: Option<(f64, f64)>) -> Bar {
        Bar {
            label: label.into(),
            colour: RGBColor(0, 114, 178),
            value,
            error,
        }
    }

    #[test]
    fn bar_charts_write_svg_and_png_with_labels() {
        let dir = tempfile::tempdir().unwrap();
        let bars = [
            bar("path", 0.02, Some((0.015, 0.025))),
            bar("path[max_depth=2]", 0.05, None),
        ];
        bar_chart("MSE at 1 s", "MSE", &bars, &dir.path().join("bars")).unwrap();
        let svg = std::fs::read_to_string(dir.path().join("bars.svg")).unwrap();
        assert!(svg.contains("path[max_depth=2]") && svg.contains("MSE at 1 s"));
        assert!(dir.path().join("bars.png").exists());

        let names = vec!["photons".to_string(), "render".to_string()];
        let stacks = [
            Stack {
                label: "photon_map".into(),
                values: vec![0.5, 1.5],
            },
            Stack {
                label: "path".into(),
                values: vec![0.0, 0.7],
            },
        ];
        stacked_bar_chart("time", "seconds", &names, &stacks, &dir.path().join("t")).unwrap();
        // One segment only (no strategy has a preparation phase).
        let render = ["render".to_string()];
        let single = [Stack {
            label: "path".into(),
            values: vec![0.7],
        }];
        stacked_bar_chart("time", "seconds", &render, &single, &dir.path().join("r")).unwrap();
        let svg = std::fs::read_to_string(dir.path().join("t.svg")).unwrap();
        assert!(svg.contains("photons") && svg.contains("render"));
        let bad = [Stack {
            label: "x".into(),
            values: vec![1.0],
        }];
        assert!(stacked_bar_chart("t", "s", &names, &bad, &dir.path().join("u")).is_err());
        assert!(bar_chart("t", "s", &[], &dir.path().join("v")).is_err());
    }

    #[test]
    fn values_spanning_decades_get_a_log_axis_with_decade_ticks() {
        assert_eq!(axis_for([0.02, 0.05].into_iter()), Axis::Linear { max: 0.05 * 1.08 });
        let Axis::Log { min, max } = axis_for([2e-4, 0.3, 0.01].into_iter()) else {
            panic!("three decades on a linear axis")
        };
        assert!(min < 2e-4 && min > 5e-5 && max > 0.3, "{min} {max}");
        // A zero cannot sit on a log axis: linear from zero.
        assert!(matches!(axis_for([0.0, 1e-3, 1.0].into_iter()), Axis::Linear { .. }));

        let dir = tempfile::tempdir().unwrap();
        let bars = [bar("mps", 2e-4, Some((1e-4, 3e-4))), bar("path", 0.3, None)];
        bar_chart("MSE", "MSE", &bars, &dir.path().join("log")).unwrap();
        let svg = std::fs::read_to_string(dir.path().join("log.svg")).unwrap();
        for tick in ["1e-3", "0.01", "0.1"] {
            assert!(svg.contains(&format!(">\n{tick}\n</text>")), "no decade tick {tick}");
        }
    }
}
