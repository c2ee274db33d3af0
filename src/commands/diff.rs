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
use crate::metrics::{self, Crop, ErrorSource, Estimate, Metrics, MetricsError, Region, Split, Verdict};
use crate::output::film::read_render;
use crate::output::OutputError;
use crate::render::{Progression, ReplicaMeans};
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
    /// Only the white pixels of this PNG of the images' size (grey level and alpha at least 128);
    /// the error map shows their bounding box.
    #[arg(long, value_name = "FILE.png", conflicts_with = "crop", value_parser = super::parse_mask)]
    pub mask: Option<super::MaskArg>,
    /// Exposure in stops of the tone-mapped preview that the preview PSNR and SSIM judge (as
    /// `render --png` would show it). Default: the exposure the test image was judged at, kept in
    /// its `vitrum:exposure` attribute (`compare`, `render`), else 0.
    #[arg(long, value_name = "EV", allow_hyphen_values = true, value_parser = parse_exposure)]
    pub exposure: Option<f32>,
    /// Print the metrics as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The attribute of a render's EXR that keeps the exposure its preview metrics were judged at.
pub const EXPOSURE_ATTRIBUTE: &str = "vitrum:exposure";

/// Parses a finite exposure in stops.
pub fn parse_exposure(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(ev) if ev.is_finite() => Ok(ev),
        _ => Err(format!("`{s}` is not a finite number of stops")),
    }
}

/// An EXR read for judging: its image, its header attributes, its replicas and the per-pixel
/// variance of its estimate when it keeps them (replica and variance channels, or the sums of a
/// render part).
pub struct Judged {
    /// The image.
    pub image: Image,
    /// Header attributes.
    pub attributes: BTreeMap<String, String>,
    /// The variance of each pixel's estimate, if the file has it.
    pub variance: Option<Image>,
    /// The means of its replicas, if the file keeps them.
    pub replicas: Option<ReplicaMeans>,
}

impl Judged {
    /// Whether the file is a render by a method of one fixed, deterministic pattern (`ssaa`),
    /// whose variance is zero.
    pub fn deterministic(&self) -> bool {
        let method = self.attributes.get("vitrum:integrator").and_then(|n| crate::integrators::create(n));
        method.is_some_and(|m| matches!(m.progression(), Progression::Fixed(_)))
    }

    /// The file as the split judges it.
    pub fn estimate(&self) -> Estimate<'_> {
        Estimate { image: &self.image, replicas: self.replicas.as_ref(), variance: self.variance.as_ref() }
    }
}

/// Reads `path` with its variance: the variance channels, else a render part's sums.
pub fn read_judged(path: &Path) -> Result<Judged, OutputError> {
    let read = read_render(path)?;
    let variance = read.variance();
    if let Some(v) = &variance {
        if (v.width, v.height) != (read.image.width, read.image.height) {
            return Err(OutputError::format(path, "the variance channels are not the size of the image"));
        }
    }
    Ok(Judged { image: read.image, attributes: read.attributes, variance, replicas: read.replicas })
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
    let (found, image) = measure(args)?;
    let text = if args.json {
        json_summary(&found, args, &image).to_string() + "\n"
    } else {
        table(&found, args, &image)
    };
    std::io::stdout()
        .lock()
        .write_all(text.as_bytes())
        .map_err(|e| CliError::Failure(format!("cannot write the metrics to stdout: {e}")))
}

/// The metrics `vitrum diff --json` prints for `args` (the error map written when asked for):
/// the entry point of a library user (the Python package).
pub fn metrics_json(args: &DiffArgs) -> Result<serde_json::Value, CliError> {
    let (found, image) = measure(args)?;
    Ok(json_summary(&found, args, &image))
}

/// Reads and measures the images of `args` (writing the error map when asked for), with notes
/// on stderr about the pixels left out; returns what was found and the test image.
fn measure(args: &DiffArgs) -> Result<(Found, Image), CliError> {
    // Refuse a bad output path before reading anything.
    if let Some(path) = &args.error_map {
        check_output_path(path, "png")?;
    }
    let test = read_image(&args.test, "test image")?;
    let reference = read_image(&args.reference, "reference image")?;
    let size = (test.image.width, test.image.height);
    let region = match &args.mask {
        Some(mask) => super::plan_regions(&[], std::slice::from_ref(mask), size)?.pop().map(|(_, r)| r),
        None => args.crop.map(|c| Region::rect(Crop { x: c.x, y: c.y, width: c.width, height: c.height })),
    };
    let crop = region.as_ref().map(|r| r.rect);
    let exposure = args.exposure.unwrap_or_else(|| {
        test.attributes
            .get(EXPOSURE_ATTRIBUTE)
            .and_then(|e| e.parse().ok())
            .filter(|e: &f32| e.is_finite())
            .unwrap_or(0.0)
    });
    let m = metrics::compare_over(&test.image, &reference.image, region.as_ref(), exposure)
        .map_err(|e| explain(&e, args))?;
    let split = if test.variance.is_some() || test.deterministic() {
        let s = metrics::split_over(test.estimate(), reference.estimate(), region.as_ref());
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
    Ok((found, test.image))
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
        MetricsError::VarianceSize { .. } | MetricsError::MaskSize { .. } => {
            format!("{error} ({test}, {reference})")
        }
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

/// The verdict on a split with the rule's numbers: "biased: …", "no bias detected: …",
/// "inconclusive: …" or "reference too noisy: …".
pub fn verdict(split: &Split) -> String {
    let share = |v: f64| format!("{:.0}%", 100.0 * v / split.error);
    let limit = format!(
        "a bias part above {} ({} of the error) would have been detected",
        format_number(split.detection_limit()),
        share(split.detection_limit())
    );
    match split.verdict() {
        Verdict::Biased => format!(
            "biased: the bias part is {:.1} standard errors above 0 and {} of the relative error (RMS relative bias {})",
            split.bias / split.bias_se,
            share(split.bias),
            format_number(split.rms_bias())
        ),
        Verdict::ReferenceTooNoisy => format!(
            "reference too noisy: its variance is {} of the relative error (more than {:.0}%); render a longer reference",
            share(split.reference_variance),
            100.0 * metrics::REFERENCE_SHARE_LIMIT
        ),
        Verdict::Inconclusive => format!(
            "inconclusive: too noisy to tell ({limit}, more than {:.0}% of it)",
            100.0 * metrics::INCONCLUSIVE_FRACTION
        ),
        Verdict::NoBiasDetected => format!(
            "no bias detected: the bias part is {:.1} standard errors ({limit})",
            split.bias / split.bias_se
        ),
    }
}

/// How the split's standard errors were found, for the table.
pub fn error_source(split: &Split) -> String {
    match split.errors {
        ErrorSource::Replicas { test, reference } => {
            let side = |n: usize, what: &str| match n {
                0 => None,
                n => Some(format!("{n} replicas of the {what}")),
            };
            let sides: Vec<String> =
                [side(test, "test"), side(reference, "reference")].into_iter().flatten().collect();
            format!("jackknife over {} ({} degrees of freedom)", sides.join(" and "), split.dof)
        }
        ErrorSource::Pixels => {
            "spread over the pixels (no replicas: right only for independent pixels)".into()
        }
    }
}

/// The metrics as a small table.
fn table(found: &Found, args: &DiffArgs, image: &Image) -> String {
    let m = &found.metrics;
    let region = match (&args.mask, args.crop) {
        (Some(mask), _) => {
            format!(
                "the {} pixels of mask {} in {}x{}",
                m.pixels,
                mask.path.display(),
                image.width,
                image.height
            )
        }
        (None, Some(c)) => {
            format!("crop {},{},{},{} of {}x{}", c.x, c.y, c.width, c.height, image.width, image.height)
        }
        (None, None) => format!("{}x{}", image.width, image.height),
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
        ("HDR-FLIP", format!("{} (mean; 67 px per degree, exposures from the reference)", fixed(m.flip))),
        ("pixels", format!("{} compared", m.pixels)),
        (
            "non-finite",
            format!("{} in the test image, {} in the reference", m.non_finite_test, m.non_finite_reference),
        ),
    ];
    match &found.split {
        Some(s) => {
            rows.push(("relMSE CI", {
                let (lo, hi) = s.rel_mse_interval();
                format!("{} .. {} (95%, {})", sci(lo), sci(hi), error_source(s))
            }));
            rows.push(("variance", format!("{} (the test's variance part of the relative error)", sci(s.variance))));
            let reference = if found.reference_variance {
                format!("{} ({:.1}% of the relative error)", sci(s.reference_variance), 100.0 * s.reference_share())
            } else {
                "0 (the reference keeps no variance: taken as exact)".to_string()
            };
            rows.push(("ref. var.", reference));
            rows.push(("bias", format!("{} (relative error − variance parts, neighbour weights)", with_se(s.bias, s.bias_se))));
            rows.push(("verdict", verdict(s)));
        }
        None => rows.push((
            "bias/var.",
            "n/a: the test image keeps no replicas or variance (render it without --no-variance, 2+ replicas)"
                .to_string(),
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
        "mask": args.mask.as_ref().map(|mask| mask.path.display().to_string()),
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
        "flip": m.flip,
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
        "error": s.error,
        "rel_mse": s.rel_mse,
        "rel_mse_se": s.rel_mse_se,
        "rel_mse_interval": [s.rel_mse_interval().0, s.rel_mse_interval().1],
        "variance": s.variance,
        "reference_variance": s.reference_variance,
        "reference_share": s.reference_share(),
        "bias": s.bias,
        "bias_se": s.bias_se,
        "detection_limit": s.detection_limit(),
        "dof": s.dof,
        "errors": error_source(s),
        "verdict": s.verdict().name(),
        "pixels": s.pixels,
        "non_finite_variance": s.non_finite_variance,
    })
}
