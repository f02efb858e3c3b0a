//! What every chart of the report shares (plotters): the font, the colour-blind-safe palette,
//! per-strategy styles, the legend column beside the data, and the SVG + print-resolution PNG
//! writer.
//!
//! Every strategy keeps one colour and one marker across all charts of a run ([`Styles`]);
//! the equal-time series of a strategy shares them and differs only by a dashed line. The
//! legend sits right of the data, never over it. The SVG is [`PLOT_SIZE_PX`]; the PNG is the
//! same drawing at [`PNG_SCALE`] times the resolution (every length scaled), for print.
//!
//! Text is rendered with the vendored DejaVu Sans (`assets/DejaVuSans.ttf`, registered once as
//! the "sans-serif" family of plotters' `ab_glyph` backend), so PNG output needs no system
//! fonts and looks the same on every machine.

use crate::error::{Error, Result};
use crate::util::write_atomic;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Size of every chart in SVG units (pixels of the PNG at scale 1).
pub const PLOT_SIZE_PX: (u32, u32) = (960, 600);

/// The PNG is drawn at this multiple of [`PLOT_SIZE_PX`] with every length scaled: 1920 × 1200
/// pixels, 300 dpi at 6.4 inches, enough for a full-width figure in print.
pub const PNG_SCALE: f64 = 2.0;

/// The font family every text element uses.
pub(super) const FONT: &str = "sans-serif";

/// Okabe & Ito's colour-blind-safe palette (2008, "Color Universal Design"), yellow left out
/// as it is unreadable on white, then four of ColorBrewer's "Dark2" for experiments with more
/// than seven strategies (every strategy kind at once). Paired with [`Marker::ALL`] (7 shapes;
/// 7 and 11 are coprime), the first 77 strategies of a run get distinct colour–marker pairs.
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

/// Lengths of a drawing in SVG units, turned into backend pixels: the PNG draws the same
/// figure at [`PNG_SCALE`].
#[derive(Clone, Copy, Debug)]
pub(super) struct Scale(pub f64);

impl Scale {
    /// A length in backend pixels.
    pub fn px(self, v: impl Into<f64>) -> i32 {
        (v.into() * self.0).round() as i32
    }
    /// A font size in backend pixels.
    pub fn font(self, v: impl Into<f64>) -> f64 {
        v.into() * self.0
    }
    /// A stroke width in backend pixels (at least 1).
    pub fn stroke(self, v: impl Into<f64>) -> u32 {
        ((v.into() * self.0).round() as u32).max(1)
    }
}

/// The shape marking each point of a series.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Marker {
    #[default]
    Circle,
    Square,
    TriangleUp,
    Diamond,
    TriangleDown,
    Plus,
    Hexagon,
    /// No marker (legend samples of a line style alone).
    None,
}

impl Marker {
    /// Every marker, in the order strategies receive them.
    pub const ALL: [Marker; 7] = [
        Marker::Circle,
        Marker::Square,
        Marker::TriangleUp,
        Marker::Diamond,
        Marker::TriangleDown,
        Marker::Plus,
        Marker::Hexagon,
    ];

    /// The outline of the marker around (0, 0), `r` its half-size in backend pixels; every
    /// shape is a polygon so that all draw alike on every backend and in the legend.
    pub(super) fn outline(self, r: i32) -> Vec<(i32, i32)> {
        let regular = |n: usize, turn: f64, radius: f64| -> Vec<(i32, i32)> {
            (0..n)
                .map(|k| {
                    let a = turn + std::f64::consts::TAU * k as f64 / n as f64;
                    ((radius * a.cos()).round() as i32, (-radius * a.sin()).round() as i32)
                })
                .collect()
        };
        let rf = r as f64;
        match self {
            Marker::Circle => regular(20, 0.0, rf),
            Marker::Square => vec![(-r, -r), (r, -r), (r, r), (-r, r)],
            Marker::TriangleUp => regular(3, std::f64::consts::FRAC_PI_2, rf * 1.3),
            Marker::TriangleDown => regular(3, -std::f64::consts::FRAC_PI_2, rf * 1.3),
            Marker::Diamond => regular(4, std::f64::consts::FRAC_PI_2, rf * 1.35),
            Marker::Hexagon => regular(6, 0.0, rf * 1.15),
            Marker::None => Vec::new(),
            Marker::Plus => {
                let (a, b) = (r / 3 + 1, r + r / 4);
                vec![
                    (-a, -b),
                    (a, -b),
                    (a, -a),
                    (b, -a),
                    (b, a),
                    (a, a),
                    (a, b),
                    (-a, b),
                    (-a, a),
                    (-b, a),
                    (-b, -a),
                    (-a, -a),
                ]
            }
        }
    }
}

/// How a series' line is drawn: equal-samples series solid, equal-time series dashed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Line {
    #[default]
    Solid,
    Dashed,
}

/// The look of one series.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Style {
    pub colour: RGBColor,
    pub marker: Marker,
    pub line: Line,
}

impl Default for Style {
    fn default() -> Self {
        Style {
            colour: PALETTE[0],
            marker: Marker::Circle,
            line: Line::Solid,
        }
    }
}

/// The colour and marker of every strategy of a run, assigned in the order the strategies
/// first appear (the experiment's order), so one strategy looks the same in every plot, bar
/// chart and scene of the run.
#[derive(Clone, Debug, Default)]
pub struct Styles {
    labels: Vec<String>,
}

impl Styles {
    /// Styles for `labels` in this order (duplicates keep their first place).
    pub fn new<'a>(labels: impl IntoIterator<Item = &'a str>) -> Styles {
        let mut out = Styles::default();
        for l in labels {
            if !out.labels.iter().any(|k| k == l) {
                out.labels.push(l.to_string());
            }
        }
        out
    }

    /// The style of `label` drawn with `line`; a label unknown to the run gets the style after
    /// the known ones' (so it still differs from them).
    pub fn of(&self, label: &str, line: Line) -> Style {
        let k = self.labels.iter().position(|l| l == label).unwrap_or(self.labels.len());
        Style {
            colour: PALETTE[k % PALETTE.len()],
            marker: Marker::ALL[k % Marker::ALL.len()],
            line,
        }
    }
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

/// The house style of a chart's axes and grid: tick labels, axis titles, a faint minor grid,
/// a light major grid and thin black axes, all scaled with the drawing.
pub(super) fn house_mesh<
    'm,
    'a,
    'b,
    X: plotters::coord::ranged1d::Ranged,
    Y: plotters::coord::ranged1d::Ranged,
    DB: DrawingBackend,
>(
    mesh: &'m mut plotters::chart::MeshStyle<'a, 'b, X, Y, DB>,
    s: Scale,
) -> &'m mut plotters::chart::MeshStyle<'a, 'b, X, Y, DB> {
    mesh.label_style((FONT, s.font(15.0)))
        .axis_desc_style((FONT, s.font(17.0)))
        .light_line_style(RGBColor(243, 243, 243).stroke_width(s.stroke(1.0)))
        .bold_line_style(RGBColor(205, 205, 205).stroke_width(s.stroke(1.0)))
        .axis_style(BLACK.stroke_width(s.stroke(1.0)))
}

/// One entry of a legend.
pub(super) struct LegendEntry<'a> {
    pub label: &'a str,
    pub colour: RGBColor,
    /// Drawn as a line sample with a marker when `Some`, as a filled swatch when `None`.
    pub line: Option<(Line, Marker)>,
}

/// The width a legend of `entries` needs on `area`: the widest label plus the sample, at most
/// 40 % of the area.
pub(super) fn legend_width<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
    s: Scale,
) -> i32 {
    let font: TextStyle = (FONT, s.font(15.0)).into();
    let widest = entries
        .iter()
        .map(|e| area.estimate_text_size(e.label, &font).map_or(0, |(w, _)| w as i32))
        .max()
        .unwrap_or(0);
    if entries.is_empty() {
        return 0;
    }
    let cap = area.dim_in_pixel().0 as i32 * 2 / 5;
    (widest + s.px(64)).min(cap)
}

/// Draws `entries` top-down in `area` (beside the data, never over it).
pub(super) fn draw_legend_beside<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
    s: Scale,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let font = TextStyle::from((FONT, s.font(15.0)).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
    let row = s.px(24);
    for (k, e) in entries.iter().enumerate() {
        let y = s.px(40) + row * k as i32;
        let (x0, x1, xm) = (s.px(8), s.px(44), s.px(26));
        match e.line {
            Some((line, marker)) => {
                let style = e.colour.stroke_width(s.stroke(2.0));
                match line {
                    Line::Solid => area.draw(&PathElement::new(vec![(x0, y), (x1, y)], style))?,
                    Line::Dashed => {
                        for (a, b) in [(x0, x0 + s.px(10)), (xm - s.px(4), xm + s.px(4)), (x1 - s.px(10), x1)] {
                            area.draw(&PathElement::new(vec![(a, y), (b, y)], style))?;
                        }
                    }
                }
                if marker != Marker::None {
                    area.draw(&(EmptyElement::at((xm, y)) + Polygon::new(marker.outline(s.px(5)), e.colour.filled())))?;
                }
            }
            None => area.draw(&Rectangle::new(
                [(x0 + s.px(8), y - s.px(7)), (x1 - s.px(8), y + s.px(7))],
                e.colour.filled(),
            ))?,
        }
        area.draw(&Text::new(e.label.to_string(), (s.px(52), y), font.clone()))?;
    }
    Ok(())
}

/// The data area and the legend column of a chart.
pub(super) type Areas<DB> = (DrawingArea<DB, Shift>, DrawingArea<DB, Shift>);

/// The title on top of `root`, then the area below it split into the plot (left) and a
/// legend column (right) wide enough for `entries`.
pub(super) fn layout<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    entries: &[LegendEntry],
    s: Scale,
) -> std::result::Result<Areas<DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let body = root.margin(s.px(10), 0, 0, 0).titled(title, (FONT, s.font(22.0)))?;
    let width = legend_width(&body, entries, s);
    let (w, _) = body.dim_in_pixel();
    Ok(body.split_horizontally(w as i32 - width))
}

/// `path` with `.ext` appended (not replacing an extension: "mse.v2" gives "mse.v2.svg").
fn with_appended_extension(path: &Path, ext: &str) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// Draws a figure twice, with `draw_svg` and `draw_png` (the same drawing on two backends),
/// into `<path_without_ext>.svg` (`size`) and `<path_without_ext>.png` ([`PNG_SCALE`] ×
/// `size`), atomically.
pub(super) fn write_svg_png(
    path_without_ext: &Path,
    size: (u32, u32),
    draw_svg: impl FnOnce(DrawingArea<SVGBackend, Shift>, Scale) -> std::result::Result<(), String>,
    draw_png: impl FnOnce(DrawingArea<BitMapBackend, Shift>, Scale) -> std::result::Result<(), String>,
) -> Result<()> {
    register_vendored_font()?;

    let svg_path = with_appended_extension(path_without_ext, "svg");
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        draw_svg(root, Scale(1.0)).map_err(|e| Error::new(format!("{}: cannot draw plot: {e}", svg_path.display())))?;
    }
    write_atomic(&svg_path, svg.as_bytes())?;

    let png_path = with_appended_extension(path_without_ext, "png");
    let (width, height) = (
        (size.0 as f64 * PNG_SCALE).round() as u32,
        (size.1 as f64 * PNG_SCALE).round() as u32,
    );
    let mut rgb = vec![0u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        draw_png(root, Scale(PNG_SCALE))
            .map_err(|e| Error::new(format!("{}: cannot draw plot: {e}", png_path.display())))?;
    }
    let image = image::RgbImage::from_raw(width, height, rgb)
        .ok_or_else(|| Error::new(format!("{}: bitmap size mismatch", png_path.display())))?;
    let mut png = std::io::Cursor::new(Vec::new());
    image
        .write_to(&mut png, image::ImageFormat::Png)
        .map_err(|e| Error::new(format!("{}: cannot encode PNG: {e}", png_path.display())))?;
    write_atomic(&png_path, png.get_ref())
}
