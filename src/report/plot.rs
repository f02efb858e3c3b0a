//! Log–log plots of error against time or samples (plotters), written as SVG and PNG, styled
//! to go into a paper unchanged.
//!
//! Monte Carlo error falls as a power of the effort (MSE ∝ 1/N for an unbiased estimator), so
//! convergence curves are straight lines on log–log axes and their slopes compare directly.
//!
//! Lines are drawn on a white halo so that crossing curves stay readable; the look every
//! chart shares (styles per strategy, legend beside the data, SVG and print PNG) is
//! [`super::chart`]'s.

use super::chart::{
    LegendEntry, Line, Marker, PLOT_SIZE_PX, Scale, Style, draw_legend_beside, house_mesh, layout, write_svg_png,
};
use crate::error::{Error, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// One curve of a plot.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    /// Legend entry.
    pub label: String,
    pub style: Style,
    /// `(x, y)` points, drawn in the given order as a line with a marker at each point.
    pub points: Vec<(f64, f64)>,
    /// Optional confidence band `(x, lo, hi)`, drawn as a translucent area behind the line.
    pub band: Option<Vec<(f64, f64, f64)>>,
}

/// A log–log plot to draw.
#[derive(Clone, Debug, Default)]
pub struct LogLogPlot<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub series: &'a [Series],
    /// Ticks of the x axis, e.g. the spp checkpoints; decades (with 2 and 5 when the axis
    /// spans little) when empty, and added where the given ticks leave much of the axis bare.
    pub x_ticks: Vec<f64>,
    /// What a solid and a dashed line mean (e.g. equal samples, equal time). When given, the
    /// legend names each label once, in its colour and marker, then the two line styles in
    /// grey; when not, it names every series with its own line.
    pub line_meaning: Option<[&'a str; 2]>,
}

/// A value that can sit on a log axis.
fn loggable(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

/// A series reduced to what a log–log plot can draw.
struct Curve<'a> {
    label: &'a str,
    style: Style,
    points: Vec<(f64, f64)>,
    /// Closed outline of the band: lo from left to right, then hi back.
    band: Vec<(f64, f64)>,
}

/// Everything to draw, with the axis ranges and ticks.
struct Prepared<'a> {
    title: &'a str,
    line_meaning: Option<[&'a str; 2]>,
    x_label: &'a str,
    y_label: &'a str,
    x_range: (f64, f64),
    y_range: (f64, f64),
    x_ticks: Vec<f64>,
    y_ticks: Vec<f64>,
    curves: Vec<Curve<'a>>,
}

/// `[min, max]` of `values` widened by 5 % of its log span on each side (half a decade when
/// all values are equal); `None` when there are none.
fn log_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if lo > hi {
        return None;
    }
    let span_decades = (hi / lo).log10();
    let pad_decades = if span_decades > 0.0 { 0.05 * span_decades } else { 0.5 };
    let factor = 10f64.powf(pad_decades);
    Some((lo / factor, hi * factor))
}

/// `m · 10^k` for every decade k meeting `[lo, hi]` and every `m` of `mantissas`, inside it.
fn decade_multiples(lo: f64, hi: f64, mantissas: &[f64]) -> Vec<f64> {
    let (k0, k1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    (k0..=k1)
        .flat_map(|k| mantissas.iter().map(move |m| m * 10f64.powi(k)))
        .filter(|v| (lo..=hi).contains(v))
        .collect()
}

/// Labelled ticks of a log axis over `[lo, hi]`: the decades, or 1-2-5 steps when fewer than
/// three decades fall inside, every other decade when more than ten do.
pub(super) fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let decades = decade_multiples(lo, hi, &[1.0]);
    match decades.len() {
        0..=2 => {
            let steps = decade_multiples(lo, hi, &[1.0, 2.0, 5.0]);
            if steps.len() >= 2 {
                steps
            } else {
                decade_multiples(lo, hi, &[1.0, 1.5, 2.0, 3.0, 5.0, 7.0])
            }
        }
        3..=10 => decades,
        _ => decades.into_iter().step_by(2).collect(),
    }
}

/// The unlabelled minor grid of a log axis: 1 … 9 × each decade.
fn log_minor_grid(lo: f64, hi: f64) -> Vec<f64> {
    decade_multiples(lo, hi, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
}

/// The given ticks inside `[lo, hi]`, thinned to every other one while more than 12 remain
/// (so labels never overlap). Where they cover less than half of the axis' log span, the
/// [`log_ticks`] farther than a sixth of a decade from every given tick join them; alone when
/// none is given or none falls inside.
fn ticks_within(given: &[f64], (lo, hi): (f64, f64)) -> Vec<f64> {
    let mut inside: Vec<f64> = given.iter().copied().filter(|v| (lo..=hi).contains(v)).collect();
    inside.sort_by(f64::total_cmp);
    inside.dedup();
    while inside.len() > 12 {
        inside = inside.into_iter().step_by(2).collect();
    }
    let (Some(&first), Some(&last)) = (inside.first(), inside.last()) else {
        return log_ticks(lo, hi);
    };
    if (last / first).log10() >= 0.5 * (hi / lo).log10() {
        return inside;
    }
    let far = |v: f64| inside.iter().all(|t| (v / t).log10().abs() > 1.0 / 6.0);
    let mut merged: Vec<f64> = log_ticks(lo, hi).into_iter().filter(|&v| far(v)).collect();
    merged.extend(&inside);
    merged.sort_by(f64::total_cmp);
    merged
}

fn prepare<'a>(plot: &'a LogLogPlot<'a>) -> Result<Prepared<'a>> {
    let title = plot.title;
    if plot.series.is_empty() {
        return Err(Error::new(format!("plot \"{title}\": no series to plot")));
    }
    let curves: Vec<Curve> = plot
        .series
        .iter()
        .map(|s| {
            let points = s
                .points
                .iter()
                .copied()
                .filter(|&(x, y)| loggable(x) && loggable(y))
                .collect();
            let band_rows: Vec<_> = s
                .band
                .iter()
                .flatten()
                .copied()
                .filter(|&(x, lo, hi)| loggable(x) && loggable(lo) && loggable(hi))
                .collect();
            let band = band_rows
                .iter()
                .map(|&(x, lo, _)| (x, lo))
                .chain(band_rows.iter().rev().map(|&(x, _, hi)| (x, hi)))
                .collect();
            Curve {
                label: &s.label,
                style: s.style,
                points,
                band,
            }
        })
        .collect();
    let all = || curves.iter().flat_map(|c| c.points.iter().chain(&c.band));
    let (Some(x_range), Some(y_range)) = (log_range(all().map(|p| p.0)), log_range(all().map(|p| p.1))) else {
        return Err(Error::new(format!(
            "plot \"{title}\": no point with positive, finite x and y to draw on log axes"
        )));
    };
    Ok(Prepared {
        title,
        line_meaning: plot.line_meaning,
        x_label: plot.x_label,
        y_label: plot.y_label,
        x_range,
        y_range,
        x_ticks: ticks_within(&plot.x_ticks, x_range),
        y_ticks: log_ticks(y_range.0, y_range.1),
        curves,
    })
}

/// A tick label: plain decimals from 0.01 to 10 000, scientific notation outside.
pub(super) fn tick_label(v: f64) -> String {
    if v == 0.0 {
        "0".to_string()
    } else if (1e-2..1e4).contains(&v.abs()) {
        // Three significant digits, trailing zeros trimmed.
        let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        let s = format!("{v:.1e}");
        // "2.0e6" reads "2e6"; "2.5e6" stays.
        s.replacen(".0e", "e", 1)
    }
}

/// The legend of a plot: every series, or, with [`LogLogPlot::line_meaning`], every label once
/// and then what the line styles mean (only when both occur).
fn legend_entries<'a>(plot: &'a Prepared) -> Vec<LegendEntry<'a>> {
    let Some(meaning) = plot.line_meaning else {
        return plot
            .curves
            .iter()
            .map(|c| LegendEntry {
                label: c.label,
                colour: c.style.colour,
                line: Some((c.style.line, c.style.marker)),
            })
            .collect();
    };
    let mut entries: Vec<LegendEntry> = Vec::new();
    for c in &plot.curves {
        if !entries.iter().any(|e| e.label == c.label) {
            entries.push(LegendEntry {
                label: c.label,
                colour: c.style.colour,
                line: Some((Line::Solid, c.style.marker)),
            });
        }
    }
    let has = |line: Line| plot.curves.iter().any(|c| c.style.line == line && !c.points.is_empty());
    if has(Line::Solid) && has(Line::Dashed) {
        for (line, label) in [(Line::Solid, meaning[0]), (Line::Dashed, meaning[1])] {
            entries.push(LegendEntry {
                label,
                colour: RGBColor(110, 110, 110),
                line: Some((line, Marker::None)),
            });
        }
    }
    entries
}

/// Draws the plot on any plotters backend.
fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &Prepared,
    s: Scale,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let entries = legend_entries(plot);
    let (data, legend) = layout(root, plot.title, &entries, s)?;
    let (x0, x1) = plot.x_range;
    let (y0, y1) = plot.y_range;
    let mut chart = ChartBuilder::on(&data)
        .margin(s.px(12))
        .x_label_area_size(s.px(52))
        .y_label_area_size(s.px(76))
        .build_cartesian_2d(
            (x0..x1)
                .log_scale()
                .with_key_points(plot.x_ticks.clone())
                .with_light_points(log_minor_grid(x0, x1)),
            (y0..y1)
                .log_scale()
                .with_key_points(plot.y_ticks.clone())
                .with_light_points(log_minor_grid(y0, y1)),
        )?;
    let x_ticks = |v: &f64| tick_label(*v);
    let y_ticks = |v: &f64| tick_label(*v);
    house_mesh(&mut chart.configure_mesh(), s)
        .x_desc(plot.x_label)
        .y_desc(plot.y_label)
        .x_label_formatter(&x_ticks)
        .y_label_formatter(&y_ticks)
        .draw()?;

    // Bands first, so that every line stays visible on top of them.
    for curve in plot.curves.iter().filter(|c| c.band.len() >= 3) {
        chart.draw_series(std::iter::once(Polygon::new(
            curve.band.clone(),
            curve.style.colour.mix(0.15).filled(),
        )))?;
    }
    // A white halo under each line keeps crossing curves apart.
    for curve in &plot.curves {
        let points = || curve.points.iter().copied();
        chart.draw_series(LineSeries::new(points(), WHITE.stroke_width(s.stroke(5.0))))?;
        let style = curve.style.colour.stroke_width(s.stroke(2.0));
        match curve.style.line {
            Line::Solid => chart.draw_series(LineSeries::new(points(), style))?,
            Line::Dashed => chart.draw_series(DashedLineSeries::new(points(), s.px(9), s.px(5), style))?,
        };
    }
    for curve in &plot.curves {
        let outline = curve.style.marker.outline(s.px(4));
        let colour = curve.style.colour;
        chart.draw_series(
            curve
                .points
                .iter()
                .map(|&p| EmptyElement::at(p) + Polygon::new(outline.clone(), colour.filled())),
        )?;
    }
    draw_legend_beside(&legend, &entries, s)?;
    root.present()
}

/// Writes `plot` to `<path_without_ext>.svg` ([`PLOT_SIZE_PX`]) and `<path_without_ext>.png`
/// ([`PNG_SCALE`] times that), both atomically.
///
/// Each series is one line (solid or dashed) with a marker per point, plus its band if given;
/// the legend beside the data names them, and a grid helps reading values. Points or band
/// rows with a non-positive or non-finite coordinate cannot sit on log axes and are left out;
/// both axis ranges span the remaining data with 5 % of the log span as margin. An empty
/// `series`, or no drawable point at all, is an error.
pub fn log_log_plot(plot: &LogLogPlot, path_without_ext: &Path) -> Result<()> {
    let prepared = prepare(plot).map_err(|e| e.context(path_without_ext.display()))?;
    write_svg_png(
        path_without_ext,
        PLOT_SIZE_PX,
        |root, s| draw(&root, &prepared, s).map_err(|e| e.to_string()),
        |root, s| draw(&root, &prepared, s).map_err(|e| e.to_string()),
    )
}

#[cfg(test)]
mod tests {
    use super::super::chart::{PALETTE, PNG_SCALE, Styles};
    use super::*;

    fn two_series(styles: &Styles) -> Vec<Series> {
        vec![
            Series {
                label: "path tracing".to_string(),
                style: styles.of("path tracing", Line::Solid),
                points: vec![(1.0, 0.5), (2.0, 0.25), (4.0, 0.125), (16.0, 0.03)],
                band: Some(vec![
                    (1.0, 0.4, 0.6),
                    (2.0, 0.2, 0.3),
                    (4.0, 0.1, 0.15),
                    (16.0, 0.02, 0.04),
                ]),
            },
            Series {
                label: "photon guided".to_string(),
                style: styles.of("photon guided", Line::Dashed),
                // A zero and a NaN that log axes cannot show; a point in the top right
                // corner, where a legend inside the data would cover it.
                points: vec![(1.0, 0.2), (2.0, 0.0), (4.0, 0.05), (f64::NAN, 1.0), (16.0, 0.6)],
                band: None,
            },
        ]
    }

    fn plot<'a>(series: &'a [Series], x_ticks: Vec<f64>) -> LogLogPlot<'a> {
        LogLogPlot {
            title: "MSE against spp",
            x_label: "samples per pixel",
            y_label: "MSE",
            series,
            x_ticks,
            line_meaning: Some(["equal samples", "equal time"]),
        }
    }

    /// The x coordinates of an SVG attribute list like `points="1,2 3,4"`.
    fn xs_of_points(svg: &str) -> Vec<f64> {
        svg.split("points=\"")
            .skip(1)
            .flat_map(|rest| {
                let list = &rest[..rest.find('"').unwrap()];
                list.split_whitespace()
                    .filter_map(|p| p.split(',').next()?.parse::<f64>().ok())
                    .collect::<Vec<_>>()
            })
            .collect()
    }

    /// The x coordinate of the `<text>` element holding `label`.
    fn text_x(svg: &str, label: &str) -> f64 {
        let end = svg
            .find(&format!(">\n{label}\n</text>"))
            .unwrap_or_else(|| panic!("no text {label:?}"));
        let start = svg[..end].rfind("<text").unwrap();
        let attr = &svg[start..end];
        let x = &attr[attr.find(" x=\"").unwrap() + 4..];
        x[..x.find('"').unwrap()].parse().unwrap()
    }

    #[test]
    fn plot_writes_svg_and_print_resolution_png_with_the_legend_beside_the_data() {
        let dir = tempfile::tempdir().unwrap();
        let base = dir.path().join("mse_vs_spp");
        let styles = Styles::new(["path tracing", "photon guided"]);
        let series = two_series(&styles);
        log_log_plot(&plot(&series, vec![1.0, 2.0, 4.0, 8.0, 16.0]), &base).unwrap();
        let svg = std::fs::read_to_string(dir.path().join("mse_vs_spp.svg")).unwrap();
        for text in [
            "MSE against spp",
            "samples per pixel",
            "path tracing",
            "photon guided",
            "equal time",
        ] {
            assert!(svg.contains(text), "SVG lacks {text:?}");
        }
        // Every checkpoint is a labelled tick.
        for tick in ["1", "2", "4", "8", "16"] {
            assert!(svg.contains(&format!(">\n{tick}\n</text>")), "no tick {tick}");
        }
        // The legend starts right of every drawn data point and band (polylines and polygons
        // of the data; the legend's own samples sit left of its labels).
        let legend_x = text_x(&svg, "path tracing").min(text_x(&svg, "photon guided"));
        let data_right = xs_of_points(&svg)
            .into_iter()
            .filter(|&x| x < legend_x - 60.0)
            .fold(0.0, f64::max);
        assert!(data_right > PLOT_SIZE_PX.0 as f64 * 0.4, "data ends at {data_right}");
        assert!(
            xs_of_points(&svg).iter().all(|&x| x < legend_x),
            "something is drawn over the legend column"
        );

        let png = image::open(dir.path().join("mse_vs_spp.png")).unwrap();
        let expected = (
            (PLOT_SIZE_PX.0 as f64 * PNG_SCALE) as u32,
            (PLOT_SIZE_PX.1 as f64 * PNG_SCALE) as u32,
        );
        assert_eq!((png.width(), png.height()), expected);
        // Both strategies' colours are drawn.
        let rgb = png.to_rgb8();
        for s in &series {
            let RGBColor(r, g, b) = s.style.colour;
            assert!(rgb.pixels().any(|p| p.0 == [r, g, b]), "{} not drawn", s.label);
        }
        // Atomic writes: exactly the two files, no temporaries.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    }

    #[test]
    fn a_strategy_keeps_its_style_whatever_else_a_plot_shows() {
        let styles = Styles::new(["path", "photon_map", "mps", "path", "mlt"]);
        let mps = styles.of("mps", Line::Solid);
        // The same colour and marker as an equal-time series, only the line differs.
        let mps_time = styles.of("mps", Line::Dashed);
        assert_eq!((mps.colour, mps.marker), (mps_time.colour, mps_time.marker));
        assert_ne!(mps.line, mps_time.line);
        // Duplicates keep their first place: mlt is the fourth strategy.
        assert_eq!(styles.of("mlt", Line::Solid).colour, PALETTE[3]);
        // Distinct colour–marker pairs for many strategies.
        let labels: Vec<String> = (0..77).map(|k| format!("s{k}")).collect();
        let many = Styles::new(labels.iter().map(String::as_str));
        let mut pairs: Vec<_> = labels
            .iter()
            .map(|l| {
                let s = many.of(l, Line::Solid);
                (s.colour, s.marker as u8)
            })
            .map(|(RGBColor(r, g, b), m)| (r, g, b, m))
            .collect();
        pairs.sort_unstable();
        pairs.dedup();
        assert_eq!(pairs.len(), 77);
        // A label the run does not know still differs from the known ones.
        assert_ne!(
            styles.of("other", Line::Solid).colour,
            styles.of("path", Line::Solid).colour
        );
    }

    #[test]
    fn plot_without_drawable_data_is_an_error_not_a_panic() {
        let dir = tempfile::tempdir().unwrap();
        let base = dir.path().join("p");
        let msg = log_log_plot(&plot(&[], vec![]), &base).unwrap_err().to_string();
        assert!(msg.contains("no series"), "{msg}");

        let non_positive = [Series {
            label: "bad".to_string(),
            points: vec![(0.0, 1.0), (1.0, -2.0), (f64::INFINITY, 3.0)],
            band: Some(vec![(1.0, 0.0, 1.0)]),
            ..Series::default()
        }];
        let msg = log_log_plot(&plot(&non_positive, vec![]), &base)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("positive"), "{msg}");

        let no_points = [Series {
            label: "none".to_string(),
            ..Series::default()
        }];
        assert!(log_log_plot(&plot(&no_points, vec![]), &base).is_err());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn axis_range_spans_positive_data_with_a_margin() {
        let (lo, hi) = log_range([0.0f64, 1.0, 100.0].into_iter().filter(|&v| loggable(v))).unwrap();
        assert!(lo < 1.0 && lo > 0.5, "{lo}");
        assert!(hi > 100.0 && hi < 200.0, "{hi}");
        // A single value still gives a non-empty range.
        let (lo, hi) = log_range(std::iter::once(3.0)).unwrap();
        assert!(lo < 3.0 && hi > 3.0);
        assert!(log_range(std::iter::empty()).is_none());
    }

    #[test]
    fn ticks_are_decades_or_the_given_checkpoints_and_never_crowd() {
        assert_eq!(log_ticks(0.5, 2000.0), vec![1.0, 10.0, 100.0, 1000.0]);
        // Little more than a decade: 1-2-5 steps.
        assert_eq!(log_ticks(0.15, 3.0), vec![0.2, 0.5, 1.0, 2.0]);
        // Twenty decades: every other one.
        assert!(log_ticks(1e-10, 1e10).len() <= 11);
        // Within one 1-2-5 step there are still at least two ticks.
        assert_eq!(log_ticks(1.1, 1.9), vec![1.5]);
        assert!(log_ticks(1.05, 4.0).len() >= 2);
        // Checkpoints inside the range, sorted, thinned when too many.
        assert_eq!(ticks_within(&[16.0, 1.0, 4.0, 1e6], (0.5, 20.0)), vec![1.0, 4.0, 16.0]);
        let doubling: Vec<f64> = (0..20).map(|k| 2f64.powi(k)).collect();
        let thinned = ticks_within(&doubling, (0.5, 1e6));
        assert!(thinned.len() <= 12 && thinned[0] == 1.0, "{thinned:?}");
        assert_eq!(ticks_within(&[], (0.5, 2000.0)), log_ticks(0.5, 2000.0));
        // Time budgets at the right end of a long time axis: decades join them, except where
        // they would crowd a budget.
        assert_eq!(ticks_within(&[0.5, 1.0], (0.004, 3.0)), vec![0.01, 0.1, 0.5, 1.0]);
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick_label(0.0), "0");
        assert_eq!(tick_label(1.0), "1");
        assert_eq!(tick_label(0.25), "0.25");
        assert_eq!(tick_label(1000.0), "1000");
        assert_eq!(tick_label(1e-5), "1e-5");
        assert_eq!(tick_label(2e6), "2e6");
        assert_eq!(tick_label(2.5e-3), "2.5e-3");
    }
}
