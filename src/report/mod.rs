//! The interactive HTML report: one self-contained folder that opens offline from `file://`.
//!
//! `vitrum compare`, `vitrum converge` and `vitrum report` describe what they measured as a
//! [`Report`] (one [`Section`] per scene: its images, its table, its tables over `--region`s,
//! its convergence curves) and [`stage`] turns it into files, published together with the
//! command's other outputs:
//!
//! - `index.html`: the page. Every text from a scene or the command line is HTML-escaped
//!   ([`page::escape`]); the section's numbers travel as JSON in a
//!   `<script type="application/json">` element, escaped so that no `</script>` can end it.
//! - `report.js`, `report.css`: the viewer (no external script, font or request).
//! - `data/S-NAME.js`: one file per image, the linear RGB values as IEEE half floats
//!   (little-endian, row-major, top row first, 6 bytes per pixel) in base64, which a
//!   `<script>` element loads: a `file://` page may not `fetch()` its neighbours. An 800×800
//!   image takes 5.1 MB (4/3 of its 3.84 MB of halves). Finite values beyond half's range are
//!   stored as ±65504; NaN stays NaN.
//!
//! The browser tone-maps the data itself, as the PNG previews do (`crate::output::png`):
//! `v·2^EV` clamped to \[0, 1\], then the sRGB curve (or `v^(1/γ)`), rounded to 8 bits; NaN is
//! magenta. Error maps are the per-pixel relative squared error of
//! [`crate::metrics::relative_squared_error`], in viridis on a log scale shared by the section's
//! methods ([`crate::figure::colormap::log_range`] of them all). Files depend only on the report's
//! content, so the same renders give the same bytes.

pub mod data;
pub mod machine;
pub mod page;

use crate::image::Image;
use crate::metrics::{Efficiency, Metrics, Split, Verdict};
use crate::output::{stage_bytes, OutputError, Staged};
use std::path::Path;

/// The page's file name.
pub const PAGE: &str = "index.html";
/// The names of the report's own files and folder beside the page, which no scene folder may take.
pub const RESERVED_NAMES: [&str; 4] = [PAGE, "report.js", "report.css", data::FOLDER];

/// The viewer's script, written beside the page.
const SCRIPT: &str = include_str!("assets/report.js");
/// The page's style sheet.
const STYLE: &str = include_str!("assets/report.css");

/// A whole report: a title, one section per scene, and what made it.
#[derive(Clone, Debug)]
pub struct Report {
    /// The page title (escaped when written).
    pub title: String,
    /// One section per scene.
    pub sections: Vec<Section>,
    /// The command line that made the report, shown in the footer.
    pub command: String,
    /// The machine it ran on ([`machine::describe`]), shown in the footer.
    pub machine: String,
}

/// One scene's viewer, table and convergence plot.
#[derive(Clone, Debug)]
pub struct Section {
    /// The scene's display name (its file name).
    pub scene: String,
    /// Labelled facts shown above the viewer: budget, resolution, reference, objects, ….
    pub details: Vec<(String, String)>,
    /// The exposure the viewer starts at, in stops.
    pub exposure: f32,
    /// The reference every layer is measured against.
    pub reference: Layer,
    /// The methods' renders, in the table's order.
    pub layers: Vec<Layer>,
    /// The table: one row per method.
    pub rows: Vec<TableRow>,
    /// The same metrics over each `--region`, a table each, in the order given; empty without.
    pub regions: Vec<RegionTable>,
    /// Error against samples and seconds, one series per method; empty when there is none.
    pub convergence: Vec<Series>,
    /// Where the section's files (EXR, CSV) are, relative to the page; empty if beside it.
    pub files: String,
}

/// One image of a viewer.
#[derive(Clone, Debug)]
pub struct Layer {
    /// The tab's label: the method's name, or "reference".
    pub label: String,
    /// A short description under the tab (e.g. "64 spp, 1.2 s").
    pub note: String,
    /// The linear RGB image.
    pub image: Image,
}

/// One method's row of the table.
#[derive(Clone, Debug, PartialEq)]
pub struct TableRow {
    /// The method.
    pub method: String,
    /// Samples per pixel (a mean for adaptive methods).
    pub spp: f64,
    /// Render seconds (the mean over the runs under `compare --repeat`).
    pub seconds: f64,
    /// The seconds' 95% interval over the runs, under `compare --repeat`.
    pub seconds_interval: Option<(f64, f64)>,
    /// Rays traced.
    pub rays: u64,
    /// Millions of rays per second.
    pub mrays_per_second: f64,
    /// Mean squared error against the reference.
    pub mse: f64,
    /// Relative MSE against the reference.
    pub rel_mse: f64,
    /// Its 95% confidence interval, when the render has replicas.
    pub rel_mse_interval: Option<(f64, f64)>,
    /// The relMSE without the 0.1% worst pixels.
    pub rel_mse_trimmed: f64,
    /// PSNR on the HDR values, dB.
    pub psnr: f64,
    /// SSIM of the preview's luma.
    pub ssim: f64,
    /// Mean HDR-FLIP.
    pub flip: f64,
    /// The bias part of the relative error and its standard error, when the render's bias was judged.
    pub bias: Option<(f64, f64)>,
    /// 1/(relMSE·seconds) with its interval, where no bias is detected
    /// ([`crate::metrics::efficiency`]).
    pub efficiency: Option<Efficiency>,
    /// The bias verdict ([`crate::metrics::Verdict`], or "unknown"), with a note on a reference
    /// too noisy to judge it.
    pub status: String,
}

impl TableRow {
    /// The row of `method`'s render of `spp` samples per pixel in `seconds` with `rays` rays,
    /// whose errors are `metrics` and its split `split`.
    pub fn new(
        method: &str,
        (spp, seconds, rays): (f64, f64, u64),
        metrics: &Metrics,
        split: Option<&Split>,
    ) -> TableRow {
        TableRow {
            method: method.to_string(),
            spp,
            seconds,
            seconds_interval: None,
            rays,
            mrays_per_second: crate::metrics::mrays_per_second(rays, seconds),
            mse: metrics.mse,
            rel_mse: metrics.rel_mse,
            rel_mse_interval: split
                .map(Split::rel_mse_interval)
                .filter(|(lo, hi)| lo.is_finite() && hi.is_finite()),
            rel_mse_trimmed: metrics.rel_mse_trimmed,
            psnr: metrics.psnr,
            ssim: metrics.ssim,
            flip: metrics.flip,
            bias: split.map(|s| (s.bias, s.bias_se)),
            efficiency: crate::metrics::efficiency(split, seconds).ok(),
            status: TableRow::status_of(split),
        }
    }

    /// The verdict of `split` as the table shows it, with the reference's share of the error where
    /// it is too large.
    pub fn status_of(split: Option<&Split>) -> String {
        match split {
            None => "unknown".to_string(),
            Some(s) if s.reference_too_noisy() && s.verdict() != Verdict::ReferenceTooNoisy => format!(
                "{} (reference too noisy: {:.0}% of the error)",
                s.verdict().name(),
                100.0 * s.reference_share()
            ),
            Some(s) => s.verdict().name().to_string(),
        }
    }
}

/// The methods' metrics over one named rectangle of the image (`--region NAME=X,Y,W,H`).
#[derive(Clone, Debug, PartialEq)]
pub struct RegionTable {
    /// The region's name.
    pub name: String,
    /// The rectangle: left, top, width and height in pixels from the image's top-left corner
    /// (a mask's bounding box).
    pub rect: (usize, usize, usize, usize),
    /// Whether only a mask's pixels inside the rectangle count (`--mask`).
    pub mask: bool,
    /// One row per method, in the main table's order, every metric over the rectangle only.
    pub rows: Vec<TableRow>,
}

/// One method's convergence: relMSE at each checkpoint.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// The method.
    pub method: String,
    /// (samples per pixel, seconds, relMSE) of each checkpoint, in order.
    pub points: Vec<(f64, f64, f64)>,
    /// The 95% interval (low, high) of each point's relMSE, in the points' order (NaN bounds
    /// where a point has none), drawn as error bars.
    pub intervals: Vec<(f64, f64)>,
    /// The legend text (fitted slope, plateau).
    pub legend: String,
}

/// The command line of this process as the footer shows it: arguments that are not valid UTF-8
/// written lossily (never a panic), those with spaces or quotes in single quotes.
pub fn command_line() -> String {
    std::env::args_os().map(|a| quote_argument(&a.to_string_lossy())).collect::<Vec<_>>().join(" ")
}

/// `arg` as a shell would need it: as it is when it is plain, else in single quotes.
fn quote_argument(arg: &str) -> String {
    let plain = !arg.is_empty() && arg.chars().all(|c| c.is_alphanumeric() || "-_./=:,+@%".contains(c));
    if plain {
        arg.to_string()
    } else {
        format!("'{}'", arg.replace('\'', "'\\''"))
    }
}

/// Encodes the report's files for the folder `dir` (created, with its `data` subfolder, if
/// missing), to be published with the command's other outputs by [`Staged::commit`].
pub fn stage(dir: &Path, report: &Report) -> Result<Vec<Staged>, OutputError> {
    let data_dir = dir.join(data::FOLDER);
    std::fs::create_dir_all(&data_dir).map_err(|e| OutputError::io(&data_dir, e))?;
    let mut staged = vec![
        stage_bytes(&dir.join(RESERVED_NAMES[1]), SCRIPT.as_bytes())?,
        stage_bytes(&dir.join(RESERVED_NAMES[2]), STYLE.as_bytes())?,
    ];
    for (s, section) in report.sections.iter().enumerate() {
        for layer in std::iter::once(&section.reference).chain(&section.layers) {
            let key = data::key(s, &layer.label);
            let text = data::script(&key, &layer.image);
            staged.push(stage_bytes(&dir.join(data::file_name(&key)), text.as_bytes())?);
        }
    }
    // The page last: a commit that fails part-way never leaves a page without its files.
    staged.push(stage_bytes(&dir.join(PAGE), page::html(report).as_bytes())?);
    Ok(staged)
}

/// Writes the report into `dir` (see [`stage`]); for a report that is the only output.
pub fn write(dir: &Path, report: &Report) -> Result<(), OutputError> {
    stage(dir, report)?.into_iter().try_for_each(Staged::commit)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arguments_are_quoted_where_a_shell_would_need_it() {
        assert_eq!(quote_argument("scenes/a-b_c.toml"), "scenes/a-b_c.toml");
        assert_eq!(quote_argument("--time=0.5"), "--time=0.5");
        assert_eq!(quote_argument("my scene.toml"), "'my scene.toml'");
        assert_eq!(quote_argument("it's"), "'it'\\''s'");
        assert_eq!(quote_argument(""), "''");
        assert!(!command_line().is_empty());
    }
}
