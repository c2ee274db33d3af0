//! `vitrum diff`: error metrics of a test image against a reference (DESIGN.md's definitions).
//!
//! Prints MSE, RMSE, relMSE, MAE and PSNR (with its peak, see [`crate::metrics`]), the pixels
//! compared and the pixels left out because they are not finite, as a table or as one JSON
//! object. `--error-map` writes the per-pixel relative squared error in false colour
//! ([`crate::figure::colormap::error_map`]). Unreadable images, different sizes and a crop
//! outside the images are bad input (exit 2); nothing is written then.

use crate::cli::{check_output_path, CliError};
use crate::figure::colormap::error_map;
use crate::image::Image;
use crate::metrics::{self, Crop, Metrics, MetricsError};
use crate::output::exr::read_exr;
use serde_json::json;
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
    /// Print the metrics as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// The label of the error map's colour bar.
const ERROR_MAP_LABEL: &str = "relative squared error (x−r)²/(r²+0.01)";

/// Runs `vitrum diff`.
pub fn run(args: &DiffArgs) -> Result<(), CliError> {
    // Refuse a bad output path before reading anything.
    if let Some(path) = &args.error_map {
        check_output_path(path, "png")?;
    }
    let test = read_image(&args.test, "test image")?;
    let reference = read_image(&args.reference, "reference image")?;
    let crop = args.crop.map(|c| Crop { x: c.x, y: c.y, width: c.width, height: c.height });
    let m = metrics::compare(&test, &reference, crop).map_err(|e| explain(&e, args))?;

    if let Some(path) = &args.error_map {
        write_error_map(&test, &reference, crop, path, args)?;
    }

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

    let text =
        if args.json { json_summary(&m, args, &test).to_string() + "\n" } else { table(&m, args, &test) };
    std::io::stdout()
        .lock()
        .write_all(text.as_bytes())
        .map_err(|e| CliError::Failure(format!("cannot write the metrics to stdout: {e}")))
}

/// Reads an EXR; any failure (missing, not an EXR, truncated) is bad input naming the file.
fn read_image(path: &Path, role: &str) -> Result<Image, CliError> {
    match read_exr(path) {
        Ok((image, _)) => Ok(image),
        Err(e) => Err(CliError::BadInput(format!("cannot read the {role}: {e}"))),
    }
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
    })
}

/// Writes the error map of `crop` (or the whole image) to `path`, atomically.
fn write_error_map(
    test: &Image,
    reference: &Image,
    crop: Option<Crop>,
    path: &Path,
    args: &DiffArgs,
) -> Result<(), CliError> {
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
        .map_err(|e| CliError::Failure(format!("cannot write the error map: {e}")))
}

/// A float for the table: scientific notation, or "n/a" when undefined.
fn sci(v: f64) -> String {
    if v.is_nan() {
        "n/a".into()
    } else {
        format!("{v:.4e}")
    }
}

/// The metrics as a small table.
fn table(m: &Metrics, args: &DiffArgs, image: &Image) -> String {
    let region = match args.crop {
        Some(c) => {
            format!("crop {},{},{},{} of {}x{}", c.x, c.y, c.width, c.height, image.width, image.height)
        }
        None => format!("{}x{}", image.width, image.height),
    };
    let psnr = if m.psnr.is_nan() {
        "n/a".to_string()
    } else if m.psnr == f64::INFINITY {
        "inf dB (identical images)".to_string()
    } else {
        format!("{:.2} dB", m.psnr)
    };
    let mut out = format!("{} against {} ({region})\n", args.test.display(), args.reference.display());
    let rows = [
        ("MSE", sci(m.mse)),
        ("RMSE", sci(m.rmse)),
        ("relMSE", sci(m.rel_mse)),
        ("MAE", sci(m.mae)),
        (
            "PSNR",
            format!("{psnr} (peak {} = largest reference value, or 1 if none is positive)", sci(m.peak)),
        ),
        ("pixels", format!("{} compared", m.pixels)),
        (
            "non-finite",
            format!("{} in the test image, {} in the reference", m.non_finite_test, m.non_finite_reference),
        ),
    ];
    for (name, value) in rows {
        out += &format!("  {name:<11} {value}\n");
    }
    if let Some(path) = &args.error_map {
        out += &format!("  {:<11} {}\n", "error map", path.display());
    }
    out
}

/// The metrics as one JSON object (undefined or infinite values are `null`).
fn json_summary(m: &Metrics, args: &DiffArgs, image: &Image) -> serde_json::Value {
    json!({
        "test": args.test.display().to_string(),
        "reference": args.reference.display().to_string(),
        "width": image.width,
        "height": image.height,
        "crop": args.crop.map(|c| json!({"x": c.x, "y": c.y, "width": c.width, "height": c.height})),
        "mse": m.mse,
        "rmse": m.rmse,
        "rel_mse": m.rel_mse,
        "mae": m.mae,
        "psnr": m.psnr,
        "peak": m.peak,
        "pixels": m.pixels,
        "non_finite_test": m.non_finite_test,
        "non_finite_reference": m.non_finite_reference,
        "error_map": args.error_map.as_ref().map(|p| p.display().to_string()),
    })
}
