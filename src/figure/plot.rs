//! Log-log plots of error against samples or seconds (SVG and PNG, text in the embedded font).

use crate::output::OutputError;
use std::path::Path;

/// One line of a plot.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend name (the fitted slope is appended).
    pub name: String,
    /// (x, y) points, both positive.
    pub points: Vec<(f64, f64)>,
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

/// The least-squares slope of log y against log x, `None` with fewer than two usable points.
pub fn fit_slope(_points: &[(f64, f64)]) -> Option<f64> {
    unimplemented!("under construction")
}

/// Writes the plot as an SVG and a PNG file, atomically.
pub fn write_loglog(_plot: &LogLogPlot, _svg: &Path, _png: &Path) -> Result<(), OutputError> {
    unimplemented!("under construction")
}
