//! Log-log plots of error against samples or seconds (SVG and PNG, text in the embedded font).
//!
//! Both axes span whole decades around the data, ticks at powers of ten (plain numbers when every
//! tick lies between 0.01 and 1000, else 10ⁿ). Each series is a line with point markers in a
//! colour-blind-safe palette (Okabe–Ito), and the legend gives its name with the least-squares
//! slope of log y against log x: Monte Carlo error falls with slope −0.5 for RMSE and −1 for MSE.
//! Points that cannot be shown on log axes (not positive or not finite) are left out of the
//! drawing and of the fit. A series may give each point's 95% confidence interval, drawn as a
//! vertical error bar with caps (a lower bound at or below zero reaches the bottom of the axis).

use super::canvas::{for_each_text_pixel, text_height, FONT_BYTES};
use crate::output::{stage, OutputError};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};
use plotters::style::FontStyle;
use plotters_backend::{BackendColor, BackendCoord, BackendTextStyle, DrawingErrorKind};
use std::path::Path;
use std::sync::OnceLock;

/// One line of a plot.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend name (the fitted slope is appended).
    pub name: String,
    /// (x, y) points, both positive.
    pub points: Vec<(f64, f64)>,
    /// The whole legend text instead of the name and the slope fitted to every point (for a
    /// slope fitted to some of them, such as `converge`'s variance regime).
    pub legend: Option<String>,
    /// The 95% interval (low, high) of each point's y, in the points' order; empty when the
    /// series has none, NaN bounds for a point without one.
    pub intervals: Vec<(f64, f64)>,
}

/// A log-log plot.
#[derive(Clone, Debug)]
pub struct LogLogPlot<'a> {
    /// Title above the plot.
    pub title: &'a str,
    /// X axis label with its unit.
    pub x_label: &'a str,
    /// Y axis label with its unit.
    pub y_label: &'a str,
    /// The lines.
    pub series: &'a [Series],
}

/// The size of the plot in pixels (the PNG) or user units (the SVG): readable at thesis size.
pub const PLOT_SIZE: (u32, u32) = (800, 600);

/// The font family name the embedded font is registered under for plotters.
const FAMILY: &str = "sans-serif";

/// Line colours: the Okabe–Ito palette without its yellow (too pale on white).
const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
];

/// Whether a point can be drawn on log-log axes.
fn usable(&(x, y): &(f64, f64)) -> bool {
    x.is_finite() && y.is_finite() && x > 0.0 && y > 0.0
}

/// The least-squares slope of log y against log x, `None` with fewer than two usable points.
pub fn fit_slope(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> = points.iter().filter(|p| usable(p)).map(|&(x, y)| (x.ln(), y.ln())).collect();
    if logs.len() < 2 {
        return None;
    }
    let n = logs.len() as f64;
    let (mx, my) = logs.iter().fold((0.0, 0.0), |(a, b), &(x, y)| (a + x / n, b + y / n));
    let (sxy, sxx) =
        logs.iter().fold((0.0, 0.0), |(a, b), &(x, y)| (a + (x - mx) * (y - my), b + (x - mx) * (x - mx)));
    // All x equal: no slope.
    (sxx > 0.0).then(|| sxy / sxx).filter(|s| s.is_finite())
}

/// The legend text of a series: its name and fitted slope, e.g. "path (slope −0.98)".
pub fn legend_label(series: &Series) -> String {
    if let Some(legend) = &series.legend {
        return legend.clone();
    }
    match fit_slope(&series.points) {
        Some(slope) => format!("{} (slope {})", series.name, format!("{slope:.2}").replace('-', "−")),
        None => series.name.clone(),
    }
}

/// Where the legend covers no data: upper right when the series fall (errors against samples),
/// upper left when they rise (cost against scene size), judged by their mean fitted slope.
pub fn legend_position(plot: &LogLogPlot) -> SeriesLabelPosition {
    let slopes: Vec<f64> = plot.series.iter().filter_map(|s| fit_slope(&s.points)).collect();
    if !slopes.is_empty() && slopes.iter().sum::<f64>() > 0.0 {
        SeriesLabelPosition::UpperLeft
    } else {
        SeriesLabelPosition::UpperRight
    }
}

/// Writes the plot as an SVG and a PNG file, atomically.
pub fn write_loglog(plot: &LogLogPlot, svg: &Path, png: &Path) -> Result<(), OutputError> {
    register_font().map_err(|m| OutputError::format(svg, m))?;
    let (x_range, y_range) = decade_ranges(plot).ok_or_else(|| {
        OutputError::format(svg, "nothing to plot: no point has a positive, finite x and y")
    })?;
    let (w, h) = PLOT_SIZE;

    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, PLOT_SIZE).into_drawing_area();
        draw(&root, plot, x_range, y_range).map_err(|m| OutputError::format(svg, m))?;
    }
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    {
        let root = GlyphPlacing(BitMapBackend::with_buffer(&mut rgb, PLOT_SIZE)).into_drawing_area();
        draw(&root, plot, x_range, y_range).map_err(|m| OutputError::format(png, m))?;
    }

    // Stage both before publishing either, so a failure leaves neither file half-written.
    let staged_svg =
        stage(svg, |tmp| std::fs::write(tmp, text.as_bytes()).map_err(|e| OutputError::io(svg, e)))?;
    let staged_png = crate::output::png::stage_rgb8(png, w as usize, h as usize, &rgb)?;
    staged_svg.commit()?;
    staged_png.commit()
}

/// Registers the embedded font as plotters' "sans-serif" once per process.
fn register_font() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font(FAMILY, FontStyle::Normal, FONT_BYTES)
                .map_err(|_| "the embedded font cannot be registered for plotting".to_string())
        })
        .clone()
}

/// Exponents of ten `(lo, hi)`, `lo < hi`, of the whole decades around the x and the y values of
/// the usable points; `None` when there is none.
#[allow(clippy::type_complexity)]
fn decade_ranges(plot: &LogLogPlot) -> Option<((i32, i32), (i32, i32))> {
    let bounds = |s: &'_ Series| {
        s.points
            .iter()
            .zip(&s.intervals)
            .flat_map(|(&(x, _), &(lo, hi))| [(x, lo), (x, hi)])
            .collect::<Vec<_>>()
    };
    let points: Vec<(f64, f64)> = plot
        .series
        .iter()
        .flat_map(|s| s.points.iter().copied().chain(bounds(s).into_iter().filter(|&(_, y)| y < f64::MAX)))
        .filter(usable)
        .collect();
    let decades = |values: &mut dyn Iterator<Item = f64>| -> Option<(i32, i32)> {
        let (min, max) = values.fold(None, |acc: Option<(f64, f64)>, v| {
            Some(acc.map_or((v, v), |(a, b)| (a.min(v), b.max(v))))
        })?;
        // The tolerance keeps an exact power of ten on its own decade despite rounding in log10.
        let lo = (min.log10() + 1e-9).floor().clamp(-300.0, 300.0) as i32;
        let hi = ((max.log10() - 1e-9).ceil().clamp(-300.0, 300.0) as i32).max(lo + 1);
        Some((lo, hi))
    };
    Some((decades(&mut points.iter().map(|p| p.0))?, decades(&mut points.iter().map(|p| p.1))?))
}

/// The tick label of `value`: plain numbers on an axis whose decades all lie within 10⁻²..10³,
/// else 10ⁿ; empty for the minor ticks between powers of ten.
fn tick_label(value: f64, plain: bool) -> String {
    let exponent = value.log10().round();
    if (value.log10() - exponent).abs() > 1e-6 {
        return String::new();
    }
    let k = exponent as i32;
    match (plain, k) {
        (true, k) if k < 0 => format!("{value:.*}", (-k) as usize),
        (true, _) => format!("{value:.0}"),
        (false, _) => super::colormap::power_of_ten_label(k),
    }
}

/// Draws the plot on `root` with the given decade ranges.
fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &LogLogPlot,
    (x_lo, x_hi): (i32, i32),
    (y_lo, y_hi): (i32, i32),
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| format!("cannot draw the plot: {e}");
    root.fill(&WHITE).map_err(err)?;
    // A hair wider than the decades, so rounding cannot drop the end ticks.
    let range = |lo: i32, hi: i32| 10f64.powi(lo) * (1.0 - 1e-9)..10f64.powi(hi) * (1.0 + 1e-9);
    let mut chart = ChartBuilder::on(root)
        .caption(plot.title, (FAMILY, 30))
        .margin(20)
        .x_label_area_size(60)
        .y_label_area_size(90)
        .build_cartesian_2d(range(x_lo, x_hi).log_scale(), range(y_lo, y_hi).log_scale())
        .map_err(err)?;

    let plain = |lo: i32, hi: i32| lo >= -2 && hi <= 3;
    let (x_plain, y_plain) = (plain(x_lo, x_hi), plain(y_lo, y_hi));
    let x_format = move |v: &f64| tick_label(*v, x_plain);
    let y_format = move |v: &f64| tick_label(*v, y_plain);
    chart
        .configure_mesh()
        .x_desc(plot.x_label)
        .y_desc(plot.y_label)
        .x_labels(12)
        .y_labels(12)
        .x_label_formatter(&x_format)
        .y_label_formatter(&y_format)
        .label_style((FAMILY, 18))
        .axis_desc_style((FAMILY, 22))
        .light_line_style(TRANSPARENT)
        .bold_line_style(RGBColor(225, 225, 225))
        .draw()
        .map_err(err)?;

    for (i, series) in plot.series.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let style = colour.stroke_width(2);
        let points: Vec<(f64, f64)> = series.points.iter().copied().filter(usable).collect();
        chart
            .draw_series(LineSeries::new(points.iter().copied(), style))
            .map_err(err)?
            .label(legend_label(series))
            .legend(move |(x, y)| {
                EmptyElement::at((x, y))
                    + PathElement::new(vec![(0, 0), (24, 0)], style)
                    + Circle::new((12, 0), 4, colour.filled())
            });
        chart.draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled()))).map_err(err)?;
        let bottom = 10f64.powi(y_lo);
        let bars = series.points.iter().zip(&series.intervals).filter_map(|(&(x, y), &(lo, hi))| {
            let drawable = usable(&(x, y)) && lo.is_finite() && hi.is_finite() && hi > 0.0;
            drawable.then(|| error_bar(x, lo.max(bottom), hi))
        });
        let style = colour.stroke_width(1);
        chart.draw_series(bars.flatten().map(|line| PathElement::new(line, style))).map_err(err)?;
    }
    if !plot.series.is_empty() {
        chart
            .configure_series_labels()
            .position(legend_position(plot))
            .margin(12)
            .legend_area_size(34)
            .label_font((FAMILY, 18))
            .background_style(WHITE.mix(0.9))
            .border_style(RGBColor(160, 160, 160))
            .draw()
            .map_err(err)?;
    }
    root.present().map_err(err)
}

/// The three lines of a vertical error bar at `x` from `low` to `high`: the bar and its caps, each
/// cap 3% of x to either side (the same width anywhere on a log axis).
fn error_bar(x: f64, low: f64, high: f64) -> [Vec<(f64, f64)>; 3] {
    let cap = |y: f64| vec![(x / 1.03, y), (x * 1.03, y)];
    [vec![(x, low), (x, high)], cap(low), cap(high)]
}

/// A bitmap backend that sets text itself: plotters' own ab_glyph text drawing places each glyph
/// at the pen position without its side bearing (so "pixel" reads "pi xel"); this one places
/// glyphs as [`Canvas::text`](super::canvas::Canvas::text) does. Everything else is delegated.
struct GlyphPlacing<'a>(BitMapBackend<'a>);

impl<'a> DrawingBackend for GlyphPlacing<'a> {
    type ErrorType = <BitMapBackend<'a> as DrawingBackend>::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.0.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.ensure_prepared()
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.present()
    }

    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_pixel(point, color)
    }

    fn draw_line<S: plotters_backend::BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_line(from, to, style)
    }

    fn draw_rect<S: plotters_backend::BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: plotters_backend::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_path(path, style)
    }

    fn draw_circle<S: plotters_backend::BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: plotters_backend::BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.0.fill_polygon(vert, style)
    }

    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> Result<(u32, u32), DrawingErrorKind<Self::ErrorType>> {
        let size = style.size() as f32;
        let width = for_each_text_pixel(size, text, (0.0, 0.0), |_, _, _| {});
        Ok((width.ceil() as u32, text_height(size).ceil() as u32))
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let size = style.size() as f32;
        let (width, height) = (for_each_text_pixel(size, text, (0.0, 0.0), |_, _, _| {}), text_height(size));
        let dx = match style.anchor().h_pos {
            HPos::Left => 0.0,
            HPos::Right => -width,
            HPos::Center => -width / 2.0,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0.0,
            VPos::Center => -height / 2.0,
            VPos::Bottom => -height,
        };
        let transform = style.transform();
        let (w, h) = self.get_size();
        let mut result = Ok(());
        for_each_text_pixel(size, text, (dx, dy), |x, y, coverage| {
            let (x, y) = transform.transform(x as i32, y as i32);
            let (x, y) = (pos.0 + x, pos.1 + y);
            if result.is_ok() && x >= 0 && y >= 0 && (x as u32) < w && (y as u32) < h {
                let alpha = color.alpha * f64::from(coverage.clamp(0.0, 1.0));
                result = self.0.draw_pixel((x, y), BackendColor { alpha, rgb: color.rgb });
            }
        });
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slope_of_a_power_law_is_exact() {
        let points: Vec<(f64, f64)> = (0..8).map(|i| 2f64.powi(i)).map(|x| (x, 3.0 * x.powf(-0.5))).collect();
        assert!((fit_slope(&points).unwrap() + 0.5).abs() < 1e-12);
        let points: Vec<(f64, f64)> =
            (1..6).map(|i| (i as f64 * 0.1, 7.0 * (i as f64 * 0.1).powi(2))).collect();
        assert!((fit_slope(&points).unwrap() - 2.0).abs() < 1e-12);
    }

    #[test]
    fn slope_skips_unusable_points() {
        let mut points = vec![(1.0, 1.0), (10.0, 0.1), (100.0, 0.01)];
        points.extend([(0.0, 5.0), (-1.0, 2.0), (1000.0, 0.0), (f64::NAN, 1.0), (5.0, f64::INFINITY)]);
        assert!((fit_slope(&points).unwrap() + 1.0).abs() < 1e-12);
        assert_eq!(fit_slope(&[(1.0, 1.0)]), None);
        assert_eq!(fit_slope(&[(1.0, 1.0), (0.0, 3.0)]), None);
        assert_eq!(fit_slope(&[(2.0, 1.0), (2.0, 3.0)]), None);
        assert_eq!(fit_slope(&[]), None);
    }

    #[test]
    fn the_legend_sits_where_the_curves_are_not() {
        let series = |points: Vec<(f64, f64)>| {
            [Series { name: "s".into(), points, legend: None, intervals: Vec::new() }]
        };
        let plot = |series| LogLogPlot { title: "t", x_label: "x", y_label: "y", series };
        let falling = series(vec![(1.0, 1.0), (10.0, 0.1), (100.0, 0.01)]);
        let rising = series(vec![(1.0, 0.1), (10.0, 0.2), (100.0, 0.4)]);
        assert!(matches!(legend_position(&plot(&falling)), SeriesLabelPosition::UpperRight));
        assert!(matches!(legend_position(&plot(&rising)), SeriesLabelPosition::UpperLeft));
    }

    #[test]
    fn legend_names_carry_the_slope() {
        let s = Series {
            name: "path".into(),
            points: vec![(1.0, 1.0), (100.0, 0.1)],
            legend: None,
            intervals: Vec::new(),
        };
        assert_eq!(legend_label(&s), "path (slope −0.50)");
        let lone =
            Series { name: "light".into(), points: vec![(1.0, 1.0)], legend: None, intervals: Vec::new() };
        assert_eq!(legend_label(&lone), "light");
        let given = Series { legend: Some("light (plateau)".into()), ..s };
        assert_eq!(legend_label(&given), "light (plateau)");
    }

    #[test]
    fn tick_labels() {
        assert_eq!(tick_label(100.0, true), "100");
        assert_eq!(tick_label(0.01, true), "0.01");
        assert_eq!(tick_label(1e-5, false), "10⁻⁵");
        assert_eq!(tick_label(3.0, true), "");
    }

    fn sample_plot_series() -> Vec<Series> {
        let spp = [1.0, 4.0, 16.0, 64.0, 256.0];
        vec![
            Series {
                name: "path".into(),
                points: spp.iter().map(|&n| (n, 0.3 / n)).collect(),
                legend: None,
                intervals: Vec::new(),
            },
            Series {
                name: "light".into(),
                points: spp.iter().map(|&n| (n, 0.9 * f64::powf(n, -0.9))).collect(),
                legend: None,
                intervals: spp
                    .iter()
                    .map(|&n| (0.5 * f64::powf(n, -0.9), 1.5 * f64::powf(n, -0.9)))
                    .collect(),
            },
        ]
    }

    #[test]
    fn error_bars_widen_the_axes_to_show_them_and_a_bound_at_zero_is_left_to_the_axis() {
        let series = |intervals: Vec<(f64, f64)>| {
            vec![Series { name: "s".into(), points: vec![(1.0, 1.0), (10.0, 0.5)], legend: None, intervals }]
        };
        let plot = |s: &[Series]| {
            decade_ranges(&LogLogPlot { title: "", x_label: "", y_label: "", series: s }).unwrap()
        };
        assert_eq!(plot(&series(Vec::new())).1, (-1, 0));
        assert_eq!(plot(&series(vec![(0.5, 20.0), (0.0, 0.6)])).1, (-1, 2), "the upper bound 20 is shown");
        assert_eq!(plot(&series(vec![(0.005, 2.0), (f64::NAN, f64::NAN)])).1, (-3, 1));
        assert_eq!(error_bar(10.0, 1.0, 2.0)[0], vec![(10.0, 1.0), (10.0, 2.0)]);
    }

    #[test]
    fn writes_a_valid_svg_and_png() {
        let dir = tempfile::tempdir().unwrap();
        let (svg, png) = (dir.path().join("plot.svg"), dir.path().join("plot.png"));
        let series = sample_plot_series();
        let plot = LogLogPlot {
            title: "Error against samples",
            x_label: "samples per pixel",
            y_label: "MSE",
            series: &series,
        };
        write_loglog(&plot, &svg, &png).unwrap();

        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(text.starts_with("<svg"), "{}", &text[..text.len().min(80)]);
        assert!(text.trim_end().ends_with("</svg>"));
        for needle in
            ["Error against samples", "samples per pixel", "MSE", "path (slope −1.00)", "light (slope −0.90)"]
        {
            assert!(text.contains(needle), "the SVG lacks `{needle}`");
        }

        let decoded = ::image::open(&png).unwrap().to_rgb8();
        assert_eq!(decoded.dimensions(), PLOT_SIZE);
        // A white page with dark text and the first series' blue on it.
        assert_eq!(decoded.get_pixel(2, 2).0, [255, 255, 255]);
        assert!(decoded.pixels().any(|p| p.0 == [0, 114, 178]));
        assert!(decoded.pixels().filter(|p| p.0.iter().all(|&c| c < 60)).count() > 500);

        let mut names: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into())
            .collect();
        names.sort();
        assert_eq!(names, ["plot.png", "plot.svg"]);
    }

    #[test]
    fn nothing_to_plot_is_an_error_and_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let (svg, png) = (dir.path().join("plot.svg"), dir.path().join("plot.png"));
        let series = [Series {
            name: "zero".into(),
            points: vec![(1.0, 0.0), (0.0, 1.0)],
            legend: None,
            intervals: Vec::new(),
        }];
        let plot = LogLogPlot { title: "t", x_label: "x", y_label: "y", series: &series };
        let err = write_loglog(&plot, &svg, &png).unwrap_err();
        assert!(err.to_string().contains("plot.svg"), "{err}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        // A missing folder is an error naming the file, and nothing is left either.
        let missing = dir.path().join("no-such").join("p.svg");
        assert!(write_loglog(&LogLogPlot { series: &sample_plot_series(), ..plot }, &missing, &png).is_err());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
