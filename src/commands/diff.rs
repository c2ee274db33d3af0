//! `vitrum diff`: error metrics of a test image against a reference (as [`crate::metrics`]
//! defines them).
//!
//! Prints MSE, RMSE, relMSE and the trimmed relMSE, MAE, the HDR PSNR (with its peak), the PSNR
//! of the tone-mapped preview (peak 1, at `--exposure`) and SSIM (see [`crate::metrics`]), the
//! pixels compared and the pixels left out because they are not finite, as a table or as one
//! JSON object. When the test image keeps its per-pixel variance (`render --variance`, a render
//! part) or is deterministic (`ssaa`), the MSE is split into its variance and bias parts with
//! their standard errors ([`crate::metrics::split`]; the reference's variance channels, if any,
//! are taken into account) and the test is called biased or not. `--error-map` writes the
//! per-pixel relative squared error in false colour ([`crate::figure::colormap::error_map`]),
//! and the pixels above its scale are counted. Unreadable images, different sizes and a crop
//! outside the images are bad input (exit 2); nothing is written then.

use crate::commands::support::{check_output_path, CliError};
use crate::figure::colormap::{above_scale, error_map, log_range, power_of_ten_label};
use crate::figure::compose::format_number;
use crate::image::Image;
use crate::metrics::{self, Crop, Metrics, MetricsError, Split};
use crate::output::exr::read_variance;
use crate::output::film::read_render;
use crate::output::OutputError;
use crate::render::Progression;
use serde_json::json;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Options of `vitrum diff`.
#[derive(clap::Args, Debug, Clone)]
pub struct DiffArgs {
    /// The image to judge (EXR).
    pub test: PathBuf,
    /// The reference image (EXR).
    pub reference: PathBuf,
    /// Write a false-colour map of the relative squared error, with a colour bar.
    #[arg(long)]
    pub error_map: Option<PathBuf>,
    /// Only this rectangle, X,Y,W,H in pixels from the top-left.
    #[arg(long, value_parser = super::parse_crop)]
    pub crop: Option<super::CropArg>,
    /// Exposure in stops of the tone-mapped preview that the preview PSNR and SSIM judge (as
    /// `render --png` would show it; default 0).
    #[arg(long, value_name = "EV", default_value_t = 0.0, allow_hyphen_values = true, value_parser = parse_exposure)]
    pub exposure: f32,
    /// Print the metrics as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Parses a finite exposure in stops.
pub fn parse_exposure(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(ev) if ev.is_finite() => Ok(ev),
        _ => Err(format!("`{s}` is not a finite number of stops")),
    }
}

/// An EXR read for judging: its image, its header attributes and the per-pixel variance of its
/// estimate when it keeps one (variance channels, or the sums of a render part).
pub struct Judged {
    /// The image.
    pub image: Image,
    /// Header attributes.
    pub attributes: BTreeMap<String, String>,
    /// The variance of each pixel's estimate, if the file has it.
    pub variance: Option<Image>,
}

impl Judged {
    /// Whether the file is a render by a method of one fixed, deterministic pattern (`ssaa`),
    /// whose variance is zero.
    pub fn deterministic(&self) -> bool {
        let method = self.attributes.get("vitrum:integrator").and_then(|n| crate::integrators::create(n));
        method.is_some_and(|m| matches!(m.progression(), Progression::Fixed(_)))
    }
}

/// Reads `path` with its variance: the variance channels, else a render part's sums.
pub fn read_judged(path: &Path) -> Result<Judged, OutputError> {
    let read = read_render(path)?;
    let variance = match read.part {
        Some(part) => part.film.output().variance,
        None => read_variance(path)?,
    };
    if let Some(v) = &variance {
        if (v.width, v.height) != (read.image.width, read.image.height) {
            return Err(OutputError::format(path, "the variance channels are not the size of the image"));
        }
    }
    Ok(Judged { image: read.image, attributes: read.attributes, variance })
}

/// The label of the error map's colour bar.
const ERROR_MAP_LABEL: &str = "relative squared error (x−r)²/(r²+0.01)";

/// What `diff` found.
struct Found {
    metrics: Metrics,
    /// The bias/variance split, when the test image's variance is known.
    split: Option<Split>,
    /// Whether the reference's variance was taken into account.
    reference_variance: bool,
    /// The error map's scale (decades) and the pixels above it, with `--error-map`.
    map: Option<((i32, i32), usize)>,
}

/// Runs `vitrum diff`.
pub fn run(args: &DiffArgs) -> Result<(), CliError> {
    // Refuse a bad output path before reading anything.
    if let Some(path) = &args.error_map {
        check_output_path(path, "png")?;
    }
    let test = read_image(&args.test, "test image")?;
    let reference = read_image(&args.reference, "reference image")?;
    let crop = args.crop.map(|c| Crop { x: c.x, y: c.y, width: c.width, height: c.height });
    let m = metrics::compare(&test.image, &reference.image, crop, args.exposure)
        .map_err(|e| explain(&e, args))?;
    let split = if test.variance.is_some() || test.deterministic() {
        let s = metrics::split(
            &test.image,
            test.variance.as_ref(),
            &reference.image,
            reference.variance.as_ref(),
            crop,
        );
        Some(s.map_err(|e| explain(&e, args))?)
    } else {
        None
    };

    let map = match &args.error_map {
        Some(path) => Some(write_error_map(&test.image, &reference.image, crop, path, args)?),
        None => None,
    };

    for (count, path) in [(m.non_finite_test, &args.test), (m.non_finite_reference, &args.reference)] {
        if count > 0 {
            let (s, verb) = if count == 1 { ("", "is") } else { ("s", "are") };
            eprintln!(
                "vitrum: note: {count} pixel{s} of {} {verb} not finite (NaN or infinite), left out of the \
                 metrics",
                path.display()
            );
        }
    }
    if m.pixels == 0 {
        eprintln!("vitrum: note: no pixel is finite in both images; every metric is undefined");
    }

    let found = Found { metrics: m, split, reference_variance: reference.variance.is_some(), map };
    let text = if args.json {
        json_summary(&found, args, &test.image).to_string() + "\n"
    } else {
        table(&found, args, &test.image)
    };
    std::io::stdout()
        .lock()
        .write_all(text.as_bytes())
        .map_err(|e| CliError::Failure(format!("cannot write the metrics to stdout: {e}")))
}

/// Reads an EXR with its variance; any failure (missing, not an EXR, truncated) is bad input
/// naming the file.
fn read_image(path: &Path, role: &str) -> Result<Judged, CliError> {
    read_judged(path).map_err(|e| CliError::BadInput(format!("cannot read the {role}: {e}")))
}

/// A metrics error as bad input naming both files and the crop.
fn explain(error: &MetricsError, args: &DiffArgs) -> CliError {
    let (test, reference) = (args.test.display(), args.reference.display());
    CliError::BadInput(match *error {
        MetricsError::SizeMismatch { test_width, test_height, reference_width, reference_height } => format!(
            "the images differ in size: the test image {test} is {test_width}x{test_height}, the reference \
             {reference} is {reference_width}x{reference_height}"
        ),
        MetricsError::CropOutside { x, y, width, height, image_width, image_height } => format!(
            "--crop {x},{y},{width},{height} does not fit inside the {image_width}x{image_height} images \
             ({test}, {reference})"
        ),
        MetricsError::VarianceSize { .. } => format!("{error} ({test}, {reference})"),
    })
}

/// Writes the error map of `crop` (or the whole image) to `path`, atomically; returns its scale
/// and the number of pixels above it.
fn write_error_map(
    test: &Image,
    reference: &Image,
    crop: Option<Crop>,
    path: &Path,
    args: &DiffArgs,
) -> Result<((i32, i32), usize), CliError> {
    let errors = metrics::relative_squared_error(test, reference).map_err(|e| explain(&e, args))?;
    let region = crop.unwrap_or(Crop { x: 0, y: 0, width: test.width, height: test.height });
    let values = metrics::crop_values(&errors, test.width, region).ok_or_else(|| {
        explain(
            &MetricsError::CropOutside {
                x: region.x,
                y: region.y,
                width: region.width,
                height: region.height,
                image_width: test.width,
                image_height: test.height,
            },
            args,
        )
    })?;
    error_map(&values, region.width, region.height, ERROR_MAP_LABEL)
        .save_png(path)
        .map_err(|e| CliError::Failure(format!("cannot write the error map: {e}")))?;
    let decades = log_range(&values);
    Ok((decades, above_scale(&values, decades)))
}

/// A float for the table: scientific notation, or "n/a" when undefined.
fn sci(v: f64) -> String {
    if v.is_nan() {
        "n/a".into()
    } else {
        format!("{v:.4e}")
    }
}

/// A PSNR for the table: "n/a", "inf dB (identical images)" or "12.34 dB".
fn psnr_text(psnr: f64) -> String {
    if psnr.is_nan() {
        "n/a".to_string()
    } else if psnr == f64::INFINITY {
        "inf dB (identical images)".to_string()
    } else {
        format!("{psnr:.2} dB")
    }
}

/// "1.2e-3 ± 4.0e-5".
fn with_se(value: f64, se: f64) -> String {
    format!("{} ± {}", sci(value), sci(se))
}

/// The verdict on a split: "biased: …" or "not biased: …", with the rule's numbers.
pub fn verdict(split: &Split) -> String {
    let share = 100.0 * split.bias / split.mse;
    if split.biased() {
        format!(
            "biased: the bias part is {:.1} standard errors and {share:.0}% of the MSE (RMS bias {})",
            split.bias / split.bias_se,
            format_number(split.rms_bias())
        )
    } else if split.variance_overestimated() {
        format!(
            "unresolved: the bias part is {:.1} standard errors below 0, so the test's variance \
             estimate is conservative (Sobol' or stratified samples) and could hide a bias",
            -split.bias / split.bias_se
        )
    } else {
        format!(
            "not biased: the error is variance (bias part {share:.0}% of the MSE; biased means > {} \
             standard errors and > {:.0}% of the MSE)",
            metrics::BIAS_SIGNIFICANCE,
            100.0 * metrics::BIAS_FRACTION
        )
    }
}

/// The metrics as a small table.
fn table(found: &Found, args: &DiffArgs, image: &Image) -> String {
    let m = &found.metrics;
    let region = match args.crop {
        Some(c) => {
            format!("crop {},{},{},{} of {}x{}", c.x, c.y, c.width, c.height, image.width, image.height)
        }
        None => format!("{}x{}", image.width, image.height),
    };
    let mut out = format!("{} against {} ({region})\n", args.test.display(), args.reference.display());
    let mut rows = vec![
        ("MSE", sci(m.mse)),
        ("RMSE", sci(m.rmse)),
        ("relMSE", sci(m.rel_mse)),
        ("relMSE 99.9%", format!("{} (without the 0.1% worst pixels)", sci(m.rel_mse_trimmed))),
        ("MAE", sci(m.mae)),
        (
            "PSNR HDR",
            format!(
                "{} (peak {} = largest reference value, or 1 if none is positive)",
                psnr_text(m.psnr),
                sci(m.peak)
            ),
        ),
        (
            "PSNR LDR",
            format!(
                "{} (peak 1, on the 8-bit sRGB preview at exposure {} EV)",
                psnr_text(m.psnr_preview),
                m.exposure_ev
            ),
        ),
        ("SSIM", format!("{} (luma of the same preview, 11x11 Gaussian window)", fixed(m.ssim))),
        ("pixels", format!("{} compared", m.pixels)),
        (
            "non-finite",
            format!("{} in the test image, {} in the reference", m.non_finite_test, m.non_finite_reference),
        ),
    ];
    match &found.split {
        Some(s) => {
            rows.push((
                "variance",
                format!("{} (mean variance of the test's estimate)", with_se(s.variance, s.variance_se)),
            ));
            let reference = if found.reference_variance {
                with_se(s.reference_variance, s.reference_variance_se)
            } else {
                "0 (the reference keeps no variance: taken as exact)".to_string()
            };
            rows.push(("ref. var.", reference));
            rows.push(("bias", format!("{} (MSE − variance parts)", with_se(s.bias, s.bias_se))));
            rows.push(("verdict", verdict(s)));
        }
        None => rows.push((
            "bias/var.",
            "n/a: the test image keeps no variance (render it with --variance)".to_string(),
        )),
    }
    for (name, value) in rows {
        out += &format!("  {name:<13} {value}\n");
    }
    if let (Some(path), Some(((lo, hi), above))) = (&args.error_map, found.map) {
        out += &format!(
            "  {:<13} {} (scale {}..{}; {above} px above it, drawn red)\n",
            "error map",
            path.display(),
            power_of_ten_label(lo),
            power_of_ten_label(hi)
        );
    }
    out
}

/// A value in [0, 1] with four decimals, or "n/a".
fn fixed(v: f64) -> String {
    if v.is_nan() {
        "n/a".into()
    } else {
        format!("{v:.4}")
    }
}

/// The metrics as one JSON object (undefined or infinite values are `null`).
fn json_summary(found: &Found, args: &DiffArgs, image: &Image) -> serde_json::Value {
    let m = &found.metrics;
    json!({
        "test": args.test.display().to_string(),
        "reference": args.reference.display().to_string(),
        "width": image.width,
        "height": image.height,
        "crop": args.crop.map(|c| json!({"x": c.x, "y": c.y, "width": c.width, "height": c.height})),
        "mse": m.mse,
        "rmse": m.rmse,
        "rel_mse": m.rel_mse,
        "rel_mse_trimmed": m.rel_mse_trimmed,
        "mae": m.mae,
        "psnr": m.psnr,
        "peak": m.peak,
        "psnr_preview": m.psnr_preview,
        "exposure": m.exposure_ev,
        "ssim": m.ssim,
        "pixels": m.pixels,
        "non_finite_test": m.non_finite_test,
        "non_finite_reference": m.non_finite_reference,
        "split": found.split.map(|s| split_json(&s)),
        "error_map": args.error_map.as_ref().map(|p| p.display().to_string()),
        "error_map_above_scale": found.map.map(|(_, above)| above),
    })
}

/// A split as a JSON object: the parts, their standard errors and the verdict.
pub fn split_json(s: &Split) -> serde_json::Value {
    json!({
        "variance": s.variance,
        "variance_se": s.variance_se,
        "reference_variance": s.reference_variance,
        "reference_variance_se": s.reference_variance_se,
        "bias": s.bias,
        "bias_se": s.bias_se,
        "biased": s.biased(),
        "status": s.status(),
        "pixels": s.pixels,
        "non_finite_variance": s.non_finite_variance,
    })
}
