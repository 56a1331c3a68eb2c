//! Line charts of trajectories and results: several series, solid/dashed/dotted styles, optional
//! logarithmic axes, legend and axis labels, rendered to SVG or PNG with `plotters`.
//!
//! Text uses the vendored DejaVu Sans font (`assets/DejaVuSans.ttf`, Bitstream Vera licence in
//! `assets/DejaVuSans-LICENSE.txt`), registered under the family name `sans-serif`, so no system
//! fonts are needed.
//!
//! ```no_run
//! use dirac_output::{LineChart, LineStyle, Series};
//! let chart = LineChart::new("Convergence")
//!     .x_label("steps per period")
//!     .y_label("error")
//!     .log_log()
//!     .with_series(Series::new("ours", vec![(20.0, 0.2), (40.0, 0.05)]))
//!     .with_series(Series::new("paper", vec![(20.0, 0.23), (40.0, 0.056)]).style(LineStyle::Dotted));
//! chart.save_svg("convergence.svg")?;
//! chart.save_png("convergence.png")?;
//! # Ok::<(), dirac_output::PlotError>(())
//! ```

use std::ops::Range;
use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;
use plotters::style::FontStyle;
use thiserror::Error;

/// Family name the vendored font is registered under.
pub const FONT_FAMILY: &str = "sans-serif";

static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// Failure to build or render a chart.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum PlotError {
    /// The vendored font could not be registered.
    #[error("the vendored DejaVu Sans font could not be registered")]
    Font,
    /// The chart has no series with a drawable point.
    #[error("chart `{0}` has no finite data to draw (log axes also drop non-positive values)")]
    NoData(String),
    /// The plotting backend failed (I/O, encoding, drawing).
    #[error("rendering `{path}` failed: {message}")]
    Backend {
        /// Output file.
        path: String,
        /// The backend's message.
        message: String,
    },
}

fn ensure_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, FONT).is_ok()
    });
    if ok { Ok(()) } else { Err(PlotError::Font) }
}

/// How a series' line is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LineStyle {
    /// Continuous line.
    #[default]
    Solid,
    /// Long dashes.
    Dashed,
    /// Dots.
    Dotted,
}

/// One line: a label, points `(x, y)`, a style and an optional colour.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    label: String,
    points: Vec<(f64, f64)>,
    style: LineStyle,
    color: Option<(u8, u8, u8)>,
    width: u32,
    markers: bool,
}

impl Series {
    /// A solid series in the next palette colour.
    #[must_use]
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            label: label.into(),
            points,
            style: LineStyle::Solid,
            color: None,
            width: 2,
            markers: false,
        }
    }

    /// Sets the line style.
    #[must_use]
    pub fn style(mut self, style: LineStyle) -> Self {
        self.style = style;
        self
    }

    /// Sets the colour (RGB).
    #[must_use]
    pub fn color(mut self, r: u8, g: u8, b: u8) -> Self {
        self.color = Some((r, g, b));
        self
    }

    /// Sets the stroke width in pixels.
    #[must_use]
    pub fn width(mut self, width: u32) -> Self {
        self.width = width.max(1);
        self
    }

    /// Also draws a hollow circle at every point.
    #[must_use]
    pub fn markers(mut self, on: bool) -> Self {
        self.markers = on;
        self
    }

    /// The label.
    #[must_use]
    pub fn label(&self) -> &str {
        &self.label
    }

    /// The points.
    #[must_use]
    pub fn points(&self) -> &[(f64, f64)] {
        &self.points
    }
}

/// Tableau-10 palette.
const PALETTE: [(u8, u8, u8); 10] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
];

/// Where the legend goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LegendPosition {
    /// Upper right corner (default).
    #[default]
    UpperRight,
    /// Upper left corner.
    UpperLeft,
    /// Lower left corner.
    LowerLeft,
    /// Lower right corner.
    LowerRight,
}

/// A line chart with a title, axis labels, optional log axes and a legend.
#[derive(Debug, Clone, PartialEq)]
pub struct LineChart {
    title: String,
    x_label: String,
    y_label: String,
    log_x: bool,
    log_y: bool,
    size: (u32, u32),
    legend: LegendPosition,
    x_ticks: Option<Vec<f64>>,
    x_range: Option<(f64, f64)>,
    y_range: Option<(f64, f64)>,
    series: Vec<Series>,
}

impl LineChart {
    /// An empty 900×600 chart.
    #[must_use]
    pub fn new(title: impl Into<String>) -> Self {
        Self {
            title: title.into(),
            x_label: String::new(),
            y_label: String::new(),
            log_x: false,
            log_y: false,
            size: (900, 600),
            legend: LegendPosition::UpperRight,
            x_ticks: None,
            x_range: None,
            y_range: None,
            series: Vec::new(),
        }
    }

    /// Sets the x-axis label.
    #[must_use]
    pub fn x_label(mut self, label: impl Into<String>) -> Self {
        self.x_label = label.into();
        self
    }

    /// Sets the y-axis label.
    #[must_use]
    pub fn y_label(mut self, label: impl Into<String>) -> Self {
        self.y_label = label.into();
        self
    }

    /// Logarithmic x axis.
    #[must_use]
    pub fn log_x(mut self, on: bool) -> Self {
        self.log_x = on;
        self
    }

    /// Logarithmic y axis.
    #[must_use]
    pub fn log_y(mut self, on: bool) -> Self {
        self.log_y = on;
        self
    }

    /// Both axes logarithmic.
    #[must_use]
    pub fn log_log(self) -> Self {
        self.log_x(true).log_y(true)
    }

    /// Image size in pixels.
    #[must_use]
    pub fn size(mut self, width: u32, height: u32) -> Self {
        self.size = (width.max(100), height.max(100));
        self
    }

    /// Legend position.
    #[must_use]
    pub fn legend(mut self, position: LegendPosition) -> Self {
        self.legend = position;
        self
    }

    /// Explicit x-axis tick positions on a logarithmic x axis (useful when it spans less than a
    /// decade or two, where the default ticks sit at powers of ten only). Ignored on a linear axis.
    #[must_use]
    pub fn x_ticks(mut self, ticks: Vec<f64>) -> Self {
        self.x_ticks = Some(ticks);
        self
    }

    /// Fixes the x-axis range instead of fitting the data (points outside are clipped).
    #[must_use]
    pub fn x_range(mut self, lo: f64, hi: f64) -> Self {
        self.x_range = Some((lo, hi));
        self
    }

    /// Fixes the y-axis range instead of fitting the data (e.g. to leave room for the legend).
    #[must_use]
    pub fn y_range(mut self, lo: f64, hi: f64) -> Self {
        self.y_range = Some((lo, hi));
        self
    }

    /// Adds a series (builder form).
    #[must_use]
    pub fn with_series(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }

    /// Adds a series.
    pub fn push(&mut self, series: Series) {
        self.series.push(series);
    }

    /// The title.
    #[must_use]
    pub fn title(&self) -> &str {
        &self.title
    }

    /// Renders to an SVG file.
    pub fn save_svg(&self, path: impl AsRef<Path>) -> Result<(), PlotError> {
        let path = path.as_ref();
        let root = SVGBackend::new(path, self.size).into_drawing_area();
        self.render(root, path)
    }

    /// Renders to an SVG string.
    pub fn to_svg_string(&self) -> Result<String, PlotError> {
        let mut out = String::new();
        {
            let root = SVGBackend::with_string(&mut out, self.size).into_drawing_area();
            self.render(root, Path::new("<string>"))?;
        }
        Ok(out)
    }

    /// Renders to a PNG file.
    pub fn save_png(&self, path: impl AsRef<Path>) -> Result<(), PlotError> {
        let path = path.as_ref();
        let root = BitMapBackend::new(path, self.size).into_drawing_area();
        self.render(root, path)
    }

    /// Points of a series that can be drawn on the chart's axes.
    fn drawable<'a>(&self, s: &'a Series) -> impl Iterator<Item = (f64, f64)> + Clone + 'a {
        let (lx, ly) = (self.log_x, self.log_y);
        s.points.iter().copied().filter(move |&(x, y)| {
            x.is_finite() && y.is_finite() && (!lx || x > 0.0) && (!ly || y > 0.0)
        })
    }

    fn ranges(&self) -> Option<(Range<f64>, Range<f64>)> {
        let mut xr = (f64::INFINITY, f64::NEG_INFINITY);
        let mut yr = (f64::INFINITY, f64::NEG_INFINITY);
        for s in &self.series {
            for (x, y) in self.drawable(s) {
                xr = (xr.0.min(x), xr.1.max(x));
                yr = (yr.0.min(y), yr.1.max(y));
            }
        }
        if !(xr.0 <= xr.1 && yr.0 <= yr.1) {
            return None;
        }
        if let Some(t) = &self.x_ticks {
            for &x in t
                .iter()
                .filter(|x| x.is_finite() && (!self.log_x || **x > 0.0))
            {
                xr = (xr.0.min(x), xr.1.max(x));
            }
        }
        let fixed = |r: Option<(f64, f64)>, log: bool| {
            r.filter(|(lo, hi)| lo < hi && lo.is_finite() && hi.is_finite() && (!log || *lo > 0.0))
                .map(|(lo, hi)| lo..hi)
        };
        Some((
            fixed(self.x_range, self.log_x).unwrap_or_else(|| pad(xr, self.log_x, 0.0)),
            fixed(self.y_range, self.log_y).unwrap_or_else(|| pad(yr, self.log_y, 0.05)),
        ))
    }

    fn render<DB: DrawingBackend>(
        &self,
        root: DrawingArea<DB, plotters::coord::Shift>,
        path: &Path,
    ) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        ensure_font()?;
        let fail = |e: &dyn std::fmt::Display| PlotError::Backend {
            path: path.display().to_string(),
            message: e.to_string(),
        };
        let (xr, yr) = self
            .ranges()
            .ok_or_else(|| PlotError::NoData(self.title.clone()))?;
        let spans = (xr.end - xr.start, yr.end - yr.start);
        root.fill(&WHITE).map_err(|e| fail(&e))?;
        match (self.log_x, self.log_y, self.x_ticks.clone()) {
            (false, false, _) => self.draw(&root, xr, yr, spans),
            (true, false, None) => self.draw(&root, xr.log_scale(), yr, spans),
            (false, true, _) => self.draw(&root, xr, yr.log_scale(), spans),
            (true, true, None) => self.draw(&root, xr.log_scale(), yr.log_scale(), spans),
            (true, false, Some(t)) => {
                self.draw(&root, xr.log_scale().with_key_points(t), yr, spans)
            }
            (true, true, Some(t)) => self.draw(
                &root,
                xr.log_scale().with_key_points(t),
                yr.log_scale(),
                spans,
            ),
        }
        .map_err(|e| fail(&e))?;
        root.present().map_err(|e| fail(&e))
    }

    fn draw<DB: DrawingBackend, X, Y>(
        &self,
        root: &DrawingArea<DB, plotters::coord::Shift>,
        x: X,
        y: Y,
        (x_span, y_span): (f64, f64),
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>>
    where
        X: AsRangedCoord<Value = f64>,
        Y: AsRangedCoord<Value = f64>,
        X::CoordDescType: ValueFormatter<f64>,
        Y::CoordDescType: ValueFormatter<f64>,
    {
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FONT_FAMILY, 22))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(75)
            .build_cartesian_2d(x, y)?;
        // Ticks within round-off of zero (a linear axis crossing 0) print as "0".
        let (lx, ly) = (self.log_x, self.log_y);
        let x_tick = move |v: &f64| {
            format_tick(if !lx && v.abs() < 1e-9 * x_span {
                0.0
            } else {
                *v
            })
        };
        let y_tick = move |v: &f64| {
            format_tick(if !ly && v.abs() < 1e-9 * y_span {
                0.0
            } else {
                *v
            })
        };
        chart
            .configure_mesh()
            .x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .label_style((FONT_FAMILY, 14))
            .axis_desc_style((FONT_FAMILY, 16))
            .x_label_formatter(&x_tick)
            .y_label_formatter(&y_tick)
            .light_line_style(RGBColor(235, 235, 235))
            .bold_line_style(RGBColor(210, 210, 210))
            .draw()?;
        for (i, s) in self.series.iter().enumerate() {
            let (r, g, b) = s.color.unwrap_or(PALETTE[i % PALETTE.len()]);
            let color = RGBColor(r, g, b);
            let stroke = color.stroke_width(s.width);
            let points = self.drawable(s);
            if s.markers {
                chart.draw_series(
                    self.drawable(s)
                        .map(|p| Circle::new(p, 4, color.stroke_width(s.width.max(1)))),
                )?;
            }
            let anno = match s.style {
                LineStyle::Solid => chart.draw_series(LineSeries::new(points, stroke))?,
                LineStyle::Dashed => {
                    chart.draw_series(DashedLineSeries::new(points, 10, 6, stroke))?
                }
                LineStyle::Dotted => chart.draw_series(DashedLineSeries::new(
                    points,
                    s.width.max(2),
                    s.width.max(2) + 4,
                    stroke,
                ))?,
            };
            if !s.label.is_empty() {
                let style = s.style;
                anno.label(s.label.as_str()).legend(move |(px, py)| {
                    // One dash as long as the sample line draws it solid.
                    let (dash, gap) = match style {
                        LineStyle::Solid => (24, 4),
                        LineStyle::Dashed => (8, 4),
                        LineStyle::Dotted => (2, 4),
                    };
                    plotters::element::DashedPathElement::new(
                        vec![(px, py), (px + 24, py)],
                        dash,
                        gap,
                        stroke,
                    )
                });
            }
        }
        if self.series.iter().any(|s| !s.label.is_empty()) {
            let position = match self.legend {
                LegendPosition::UpperRight => SeriesLabelPosition::UpperRight,
                LegendPosition::UpperLeft => SeriesLabelPosition::UpperLeft,
                LegendPosition::LowerLeft => SeriesLabelPosition::LowerLeft,
                LegendPosition::LowerRight => SeriesLabelPosition::LowerRight,
            };
            chart
                .configure_series_labels()
                .position(position)
                .label_font((FONT_FAMILY, 14))
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK.mix(0.4))
                .draw()?;
        }
        Ok(())
    }
}

/// Pads a data range: a relative margin on linear axes, a factor on log axes; a degenerate range
/// is widened so that it has a positive length.
fn pad((lo, hi): (f64, f64), log: bool, frac: f64) -> Range<f64> {
    if log {
        let (lo, hi) = if hi > lo {
            (lo, hi)
        } else {
            (lo / 2.0, hi * 2.0)
        };
        let f = (hi / lo).powf(frac);
        lo / f..hi * f
    } else {
        let span = hi - lo;
        if span > 0.0 {
            lo - frac * span..hi + frac * span
        } else {
            let d = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
            lo - d..hi + d
        }
    }
}

/// Short tick labels: plain for moderate magnitudes, scientific otherwise.
fn format_tick(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if (1e-3..1e4).contains(&a) {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    } else {
        let s = format!("{v:.1e}");
        s.replace(".0e", "e")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> LineChart {
        LineChart::new("Test chart title")
            .x_label("steps per period")
            .y_label("error")
            .log_log()
            .with_series(Series::new(
                "second order",
                vec![(20.0, 0.2), (40.0, 0.05), (80.0, 0.0125)],
            ))
            .with_series(
                Series::new(
                    "fourth order",
                    vec![(20.0, 1e-4), (40.0, 6.25e-6), (80.0, 0.0)],
                )
                .style(LineStyle::Dotted),
            )
            .with_series(
                Series::new("dashed", vec![(20.0, 1e-2), (80.0, 1e-3)])
                    .style(LineStyle::Dashed)
                    .markers(true),
            )
    }

    #[test]
    fn renders_svg_and_png() {
        let dir = std::env::temp_dir().join(format!("dirac-plot-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (svg, png) = (dir.join("chart.svg"), dir.join("chart.png"));
        let chart = sample();
        chart.save_svg(&svg).unwrap();
        chart.save_png(&png).unwrap();
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(!text.is_empty());
        assert!(text.contains("Test chart title"), "title missing from SVG");
        assert!(text.contains("fourth order"), "legend missing from SVG");
        let bytes = std::fs::read(&png).unwrap();
        assert!(bytes.len() > 1000);
        assert_eq!(&bytes[1..4], b"PNG");
        let linear =
            LineChart::new("linear").with_series(Series::new("", vec![(0.0, -1.0), (1.0, 1.0)]));
        assert!(linear.to_svg_string().unwrap().contains("linear"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn empty_chart_is_an_error() {
        let chart = LineChart::new("empty")
            .log_log()
            .with_series(Series::new("zero", vec![(0.0, 0.0)]));
        assert_eq!(
            chart.to_svg_string(),
            Err(PlotError::NoData("empty".into()))
        );
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(format_tick(20.0), "20");
        assert_eq!(format_tick(0.25), "0.25");
        assert_eq!(format_tick(1e-6), "1e-6");
        assert_eq!(format_tick(0.0), "0");
    }
}
