//! Log–log plots of error against time or samples (plotters), written as SVG and PNG.
//!
//! Monte Carlo error falls as a power of the effort (MSE ∝ 1/N for an unbiased estimator), so
//! convergence curves are straight lines on log–log axes and their slopes compare directly.
//!
//! Text is rendered with the vendored DejaVu Sans (`assets/DejaVuSans.ttf`, registered once as
//! the "sans-serif" family of plotters' `ab_glyph` backend), so PNG output needs no system
//! fonts and looks the same on every machine.

use crate::error::{Error, Result};
use crate::util::write_atomic;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Size of the plots written by [`log_log_plot`], in pixels (the SVG uses the same units).
pub const PLOT_SIZE_PX: (u32, u32) = (960, 640);

/// The font family every text element uses.
pub(super) const FONT: &str = "sans-serif";

/// Okabe & Ito's colour-blind-safe palette (2008, "Color Universal Design"), yellow left out
/// as it is unreadable on white, then four of ColorBrewer's "Dark2" for experiments with more
/// than seven strategies (every strategy kind at once); series cycle through it.
pub(super) const PALETTE: [RGBColor; 11] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
    RGBColor(0, 0, 0),       // black
    RGBColor(117, 112, 179), // Dark2 purple
    RGBColor(166, 118, 29),  // Dark2 brown
    RGBColor(231, 41, 138),  // Dark2 magenta
    RGBColor(102, 102, 102), // Dark2 grey
];

/// One curve of a plot.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    /// Legend entry.
    pub label: String,
    /// `(x, y)` points, drawn in the given order as a line with a marker at each point.
    pub points: Vec<(f64, f64)>,
    /// Optional confidence band `(x, lo, hi)`, drawn as a translucent area behind the line.
    pub band: Option<Vec<(f64, f64, f64)>>,
}

/// Registers the vendored font once; later calls return the first call's result.
pub(super) fn register_vendored_font() -> Result<()> {
    static REGISTERED: OnceLock<Result<()>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font(FONT, FontStyle::Normal, include_bytes!("../../assets/DejaVuSans.ttf"))
                .map_err(|_| Error::new("assets/DejaVuSans.ttf is not a valid TrueType font"))
        })
        .clone()
}

/// A value that can sit on a log axis.
fn loggable(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

/// A series reduced to what a log–log plot can draw.
struct Curve<'a> {
    label: &'a str,
    colour: RGBColor,
    points: Vec<(f64, f64)>,
    /// Closed outline of the band: lo from left to right, then hi back.
    band: Vec<(f64, f64)>,
}

/// Everything to draw, with the axis ranges.
struct Prepared<'a> {
    title: &'a str,
    x_label: &'a str,
    y_label: &'a str,
    x_range: (f64, f64),
    y_range: (f64, f64),
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

fn prepare<'a>(title: &'a str, x_label: &'a str, y_label: &'a str, series: &'a [Series]) -> Result<Prepared<'a>> {
    if series.is_empty() {
        return Err(Error::new(format!("plot \"{title}\": no series to plot")));
    }
    let curves: Vec<Curve> = series
        .iter()
        .zip(PALETTE.iter().cycle())
        .map(|(s, &colour)| {
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
                colour,
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
        x_label,
        y_label,
        x_range,
        y_range,
        curves,
    })
}

/// A tick label: plain decimals from 0.01 to 10 000, scientific notation outside.
fn tick_label(v: f64) -> String {
    if (1e-2..1e4).contains(&v.abs()) {
        // Three significant digits, trailing zeros trimmed.
        let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{v:.0e}")
    }
}

/// Draws the plot on any plotters backend.
fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &Prepared,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let (x0, x1) = plot.x_range;
    let (y0, y1) = plot.y_range;
    let mut chart = ChartBuilder::on(root)
        .caption(plot.title, (FONT, 26))
        .margin(16)
        .x_label_area_size(56)
        .y_label_area_size(80)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
    let x_ticks = |v: &f64| tick_label(*v);
    let y_ticks = |v: &f64| tick_label(*v);
    chart
        .configure_mesh()
        .x_desc(plot.x_label)
        .y_desc(plot.y_label)
        .x_label_formatter(&x_ticks)
        .y_label_formatter(&y_ticks)
        .label_style((FONT, 16))
        .axis_desc_style((FONT, 18))
        .light_line_style(RGBColor(232, 232, 232))
        .bold_line_style(RGBColor(200, 200, 200))
        .draw()?;

    // Bands first, so that every line stays visible on top of them.
    for curve in plot.curves.iter().filter(|c| c.band.len() >= 3) {
        chart.draw_series(std::iter::once(Polygon::new(
            curve.band.clone(),
            curve.colour.mix(0.18).filled(),
        )))?;
    }
    for curve in &plot.curves {
        let colour = curve.colour;
        chart
            .draw_series(LineSeries::new(curve.points.iter().copied(), colour.stroke_width(2)))?
            .label(curve.label)
            .legend(move |(x, y)| {
                EmptyElement::at((x, y))
                    + PathElement::new(vec![(-12, 0), (12, 0)], colour.stroke_width(2))
                    + Circle::new((0, 0), 4, colour.filled())
            });
        chart.draw_series(curve.points.iter().map(|&p| Circle::new(p, 4, colour.filled())))?;
    }
    draw_legend(&mut chart)?;
    root.present()
}

/// The legend every chart of the report uses: upper right, on a translucent white box.
pub(super) fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FONT, 16))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
}

/// `path` with `.ext` appended (not replacing an extension: "mse.v2" gives "mse.v2.svg").
fn with_appended_extension(path: &Path, ext: &str) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// Writes a log–log line plot of `series` to `<path_without_ext>.svg` and
/// `<path_without_ext>.png`, [`PLOT_SIZE_PX`] in size. See [`log_log_plot_sized`].
pub fn log_log_plot(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    path_without_ext: &Path,
) -> Result<()> {
    log_log_plot_sized(title, x_label, y_label, series, path_without_ext, PLOT_SIZE_PX)
}

/// Writes a log–log line plot of `series` to `<path_without_ext>.svg` and
/// `<path_without_ext>.png`, `size_px` (width, height) in size, both atomically.
///
/// Each series is one coloured line with a marker per point, plus its band if given; a legend
/// names them and a grid helps reading values. Points or band rows with a non-positive or
/// non-finite coordinate cannot sit on log axes and are left out; both axis ranges span the
/// remaining data with 5 % of the log span as margin. An empty `series`, or no drawable point
/// at all, is an error.
pub fn log_log_plot_sized(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    path_without_ext: &Path,
    size_px: (u32, u32),
) -> Result<()> {
    let plot = prepare(title, x_label, y_label, series).map_err(|e| e.context(path_without_ext.display()))?;
    write_svg_png(
        path_without_ext,
        size_px,
        |root| draw(&root, &plot).map_err(|e| e.to_string()),
        |root| draw(&root, &plot).map_err(|e| e.to_string()),
    )
}

/// Draws a figure twice, with `draw_svg` and `draw_png` (the same drawing on two backends),
/// into `<path_without_ext>.svg` and `<path_without_ext>.png`, `size_px` in size, atomically.
pub(super) fn write_svg_png(
    path_without_ext: &Path,
    size_px: (u32, u32),
    draw_svg: impl FnOnce(DrawingArea<SVGBackend, Shift>) -> std::result::Result<(), String>,
    draw_png: impl FnOnce(DrawingArea<BitMapBackend, Shift>) -> std::result::Result<(), String>,
) -> Result<()> {
    register_vendored_font()?;
    let (width, height) = size_px;

    let svg_path = with_appended_extension(path_without_ext, "svg");
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size_px).into_drawing_area();
        draw_svg(root).map_err(|e| Error::new(format!("{}: cannot draw plot: {e}", svg_path.display())))?;
    }
    write_atomic(&svg_path, svg.as_bytes())?;

    let png_path = with_appended_extension(path_without_ext, "png");
    let mut rgb = vec![0u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size_px).into_drawing_area();
        draw_png(root).map_err(|e| Error::new(format!("{}: cannot draw plot: {e}", png_path.display())))?;
    }
    let image = image::RgbImage::from_raw(width, height, rgb)
        .ok_or_else(|| Error::new(format!("{}: bitmap size mismatch", png_path.display())))?;
    let mut png = std::io::Cursor::new(Vec::new());
    image
        .write_to(&mut png, image::ImageFormat::Png)
        .map_err(|e| Error::new(format!("{}: cannot encode PNG: {e}", png_path.display())))?;
    write_atomic(&png_path, png.get_ref())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_series() -> Vec<Series> {
        vec![
            Series {
                label: "path tracing".to_string(),
                points: vec![(1.0, 0.5), (2.0, 0.25), (4.0, 0.125), (8.0, 0.0625)],
                band: Some(vec![
                    (1.0, 0.4, 0.6),
                    (2.0, 0.2, 0.3),
                    (4.0, 0.1, 0.15),
                    (8.0, 0.05, 0.075),
                ]),
            },
            Series {
                label: "photon guided".to_string(),
                // A zero and a NaN that log axes cannot show.
                points: vec![(1.0, 0.2), (2.0, 0.0), (4.0, 0.05), (f64::NAN, 1.0)],
                band: None,
            },
        ]
    }

    #[test]
    fn plot_with_two_series_writes_svg_with_labels_and_png_of_requested_size() {
        let dir = tempfile::tempdir().unwrap();
        let base = dir.path().join("mse_vs_time");
        log_log_plot_sized("MSE against time", "time [s]", "MSE", &two_series(), &base, (640, 480)).unwrap();
        let svg = std::fs::read_to_string(dir.path().join("mse_vs_time.svg")).unwrap();
        for text in ["MSE against time", "time [s]", "path tracing", "photon guided"] {
            assert!(svg.contains(text), "SVG lacks {text:?}");
        }
        let png = image::open(dir.path().join("mse_vs_time.png")).unwrap();
        assert_eq!((png.width(), png.height()), (640, 480));
        // Something besides the white background was drawn.
        assert!(png.to_rgb8().pixels().any(|p| p.0 != [255, 255, 255]));
        // Atomic writes: exactly the two files, no temporaries.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);

        log_log_plot("t", "x", "y", &two_series(), &dir.path().join("default")).unwrap();
        let png = image::open(dir.path().join("default.png")).unwrap();
        assert_eq!((png.width(), png.height()), PLOT_SIZE_PX);
    }

    #[test]
    fn plot_without_drawable_data_is_an_error_not_a_panic() {
        let dir = tempfile::tempdir().unwrap();
        let base = dir.path().join("p");
        let msg = log_log_plot("empty", "x", "y", &[], &base).unwrap_err().to_string();
        assert!(msg.contains("no series"), "{msg}");

        let non_positive = [Series {
            label: "bad".to_string(),
            points: vec![(0.0, 1.0), (1.0, -2.0), (f64::INFINITY, 3.0)],
            band: Some(vec![(1.0, 0.0, 1.0)]),
        }];
        let msg = log_log_plot("bad", "x", "y", &non_positive, &base)
            .unwrap_err()
            .to_string();
        assert!(msg.contains("positive"), "{msg}");

        let no_points = [Series {
            label: "none".to_string(),
            ..Series::default()
        }];
        assert!(log_log_plot("none", "x", "y", &no_points, &base).is_err());
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
    fn tick_labels_are_short() {
        assert_eq!(tick_label(1.0), "1");
        assert_eq!(tick_label(0.25), "0.25");
        assert_eq!(tick_label(1000.0), "1000");
        assert_eq!(tick_label(1e-5), "1e-5");
        assert_eq!(tick_label(2e6), "2e6");
    }
}
