//! Error metrics between a test image and a reference, with the one definition of DESIGN.md.
//!
//! With test image x and reference r, over the compared pixels and their three channels:
//! MSE = mean((x−r)²), RMSE = √MSE, relMSE = mean((x−r)² / (r² + 0.01)), MAE = mean(|x−r|) and
//! PSNR = 10·log10(peak² / MSE) dB. Sums are accumulated in f64.
//!
//! - **Non-finite pixels.** A pixel with a NaN or infinite channel is counted (per image, in
//!   [`Metrics::non_finite_test`] and [`Metrics::non_finite_reference`]) and left out of every
//!   mean: one NaN would otherwise turn every metric into NaN. Callers print the counts.
//! - **The PSNR peak** is the largest reference channel value over the compared pixels (the
//!   brightest thing the reference shows, so PSNR is relative to the image's own range, as for
//!   HDR renders there is no fixed white). When that value is not positive (a black reference),
//!   the peak is 1. It is always reported in [`Metrics::peak`].
//! - **Degenerate cases.** Identical images give MSE 0 and PSNR +∞; when no pixel is finite in both
//!   images every mean is NaN (and `pixels` is 0).

use crate::image::Image;

/// A rectangle of pixels, from the top-left corner.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crop {
    /// Left edge.
    pub x: usize,
    /// Top edge.
    pub y: usize,
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
}

/// The metrics of one comparison.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metrics {
    /// mean((x − r)²)
    pub mse: f64,
    /// √MSE
    pub rmse: f64,
    /// mean((x − r)² / (r² + 0.01))
    pub rel_mse: f64,
    /// mean(|x − r|)
    pub mae: f64,
    /// 10·log10(peak² / MSE) in dB
    pub psnr: f64,
    /// The peak used for PSNR: the largest reference channel value over the compared pixels, or 1
    /// when none is positive.
    pub peak: f64,
    /// Pixels compared (finite in both images).
    pub pixels: usize,
    /// Pixels with a NaN or infinite channel in the test image.
    pub non_finite_test: usize,
    /// Pixels with a NaN or infinite channel in the reference.
    pub non_finite_reference: usize,
}

/// Why two images cannot be compared.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum MetricsError {
    /// Different sizes.
    #[error(
        "the images differ in size: {test_width}x{test_height} against {reference_width}x{reference_height}"
    )]
    SizeMismatch {
        /// Test width.
        test_width: usize,
        /// Test height.
        test_height: usize,
        /// Reference width.
        reference_width: usize,
        /// Reference height.
        reference_height: usize,
    },
    /// A crop that does not lie inside the images.
    #[error("the crop {x},{y},{width},{height} does not fit inside the {image_width}x{image_height} image")]
    CropOutside {
        /// Left edge.
        x: usize,
        /// Top edge.
        y: usize,
        /// Width.
        width: usize,
        /// Height.
        height: usize,
        /// Image width.
        image_width: usize,
        /// Image height.
        image_height: usize,
    },
}

/// The offset added to r² in the denominator of the relative squared error (DESIGN.md).
pub const REL_EPSILON: f64 = 0.01;

/// The metrics of `test` against `reference`, over `crop` or the whole image.
pub fn compare(test: &Image, reference: &Image, crop: Option<Crop>) -> Result<Metrics, MetricsError> {
    check_sizes(test, reference)?;
    let crop = resolve_crop(test, crop)?;

    let (mut sq, mut rel, mut abs) = (0.0f64, 0.0f64, 0.0f64);
    let mut max_reference = f64::NEG_INFINITY;
    let (mut pixels, mut non_finite_test, mut non_finite_reference) = (0usize, 0usize, 0usize);
    for (x, r) in region_pairs(test, reference, crop) {
        let (x_ok, r_ok) = (x.is_finite(), r.is_finite());
        non_finite_test += usize::from(!x_ok);
        non_finite_reference += usize::from(!r_ok);
        if !(x_ok && r_ok) {
            continue;
        }
        pixels += 1;
        for c in 0..3 {
            let (xc, rc) = (f64::from(x[c]), f64::from(r[c]));
            let d = xc - rc;
            sq += d * d;
            rel += d * d / (rc * rc + REL_EPSILON);
            abs += d.abs();
            max_reference = max_reference.max(rc);
        }
    }

    let n = (3 * pixels) as f64;
    let mse = sq / n;
    let peak = if max_reference > 0.0 { max_reference } else { 1.0 };
    Ok(Metrics {
        mse,
        rmse: mse.sqrt(),
        rel_mse: rel / n,
        mae: abs / n,
        psnr: 10.0 * (peak * peak / mse).log10(),
        peak,
        pixels,
        non_finite_test,
        non_finite_reference,
    })
}

/// Per-pixel relative squared error, the mean over channels of (x − r)² / (r² + 0.01); NaN where
/// either pixel is not finite.
pub fn relative_squared_error(test: &Image, reference: &Image) -> Result<Vec<f32>, MetricsError> {
    check_sizes(test, reference)?;
    let whole = Crop { x: 0, y: 0, width: test.width, height: test.height };
    Ok(region_pairs(test, reference, whole)
        .map(|(x, r)| {
            if !(x.is_finite() && r.is_finite()) {
                return f32::NAN;
            }
            let sum: f64 = (0..3)
                .map(|c| {
                    let (xc, rc) = (f64::from(x[c]), f64::from(r[c]));
                    (xc - rc) * (xc - rc) / (rc * rc + REL_EPSILON)
                })
                .sum();
            (sum / 3.0) as f32
        })
        .collect())
}

/// The values of the rectangle `crop` of a row-major `width`-wide raster, row by row; `None` when
/// the crop does not lie inside `values` (so error maps of a crop need no indexing of their own).
pub fn crop_values(values: &[f32], width: usize, crop: Crop) -> Option<Vec<f32>> {
    let right = crop.x.checked_add(crop.width)?;
    if right > width {
        return None;
    }
    let mut out = Vec::with_capacity(crop.width.saturating_mul(crop.height));
    for row in crop.y..crop.y.checked_add(crop.height)? {
        let start = row.checked_mul(width)?.checked_add(crop.x)?;
        out.extend_from_slice(values.get(start..start + crop.width)?);
    }
    Some(out)
}

/// The number of whole rows `image` really holds (its height, unless its pixel vector is short).
fn rows_held(image: &Image) -> usize {
    image.pixels.len().checked_div(image.width).map_or(image.height, |rows| image.height.min(rows))
}

/// Equal sizes, else [`MetricsError::SizeMismatch`]. An image whose pixel vector is shorter than
/// `width × height` is reported with the height it really holds, so nothing is indexed out of bounds.
fn check_sizes(test: &Image, reference: &Image) -> Result<(), MetricsError> {
    let (test_height, reference_height) = (rows_held(test), rows_held(reference));
    if test.width != reference.width
        || test.height != reference.height
        || test_height != test.height
        || reference_height != reference.height
    {
        return Err(MetricsError::SizeMismatch {
            test_width: test.width,
            test_height,
            reference_width: reference.width,
            reference_height,
        });
    }
    Ok(())
}

/// The crop, or the whole image; [`MetricsError::CropOutside`] unless it is non-empty and inside.
fn resolve_crop(image: &Image, crop: Option<Crop>) -> Result<Crop, MetricsError> {
    let Some(c) = crop else {
        return Ok(Crop { x: 0, y: 0, width: image.width, height: image.height });
    };
    let fits = |start: usize, len: usize, size: usize| {
        len > 0 && start.checked_add(len).is_some_and(|end| end <= size)
    };
    if fits(c.x, c.width, image.width) && fits(c.y, c.height, image.height) {
        Ok(c)
    } else {
        Err(MetricsError::CropOutside {
            x: c.x,
            y: c.y,
            width: c.width,
            height: c.height,
            image_width: image.width,
            image_height: image.height,
        })
    }
}

/// The (test, reference) pixel pairs of `crop`, row by row; the sizes and crop have been checked.
fn region_pairs<'a>(
    test: &'a Image,
    reference: &'a Image,
    crop: Crop,
) -> impl Iterator<Item = (glam::Vec3, glam::Vec3)> + 'a {
    let width = test.width;
    (crop.y..crop.y + crop.height).flat_map(move |row| {
        let range = row * width + crop.x..row * width + crop.x + crop.width;
        test.pixels[range.clone()].iter().copied().zip(reference.pixels[range].iter().copied())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn figures_printed_as_json_parse_back_exactly() {
        // `--json` outputs are compared with CSV rows and with each other: every f64 must come
        // back bit for bit (serde_json's default fast parser misreads this one by an ulp).
        for x in [0.21802740356113082f64, 0.1 + 0.2, 1e-300, f64::MAX, 5e-324] {
            let text = serde_json::json!({ "rel_mse": x }).to_string();
            let back: serde_json::Value = serde_json::from_str(&text).unwrap();
            assert_eq!(back["rel_mse"].as_f64().unwrap().to_bits(), x.to_bits(), "{text}");
            assert_eq!(x.to_string().parse::<f64>().unwrap().to_bits(), x.to_bits());
        }
    }

    /// A 2×2 image from its four pixels, row by row.
    fn image(pixels: [Vec3; 4]) -> Image {
        Image { width: 2, height: 2, pixels: pixels.to_vec() }
    }

    /// Reference: row 0 = (1,1,1), (0,0,0); row 1 = (2,0,0.5), (1,1,1).
    fn reference() -> Image {
        image([Vec3::ONE, Vec3::ZERO, Vec3::new(2.0, 0.0, 0.5), Vec3::ONE])
    }

    /// Test: equal at (0,0), +0.1 red at (1,0), +0.2 green at (0,1), a NaN at (1,1).
    fn test_image() -> Image {
        image([Vec3::ONE, Vec3::new(0.1, 0.0, 0.0), Vec3::new(2.0, 0.2, 0.5), Vec3::new(f32::NAN, 0.0, 0.0)])
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-6 * b.abs().max(1e-3)
    }

    #[test]
    fn hand_computed_metrics_leave_out_the_nan_pixel() {
        let m = compare(&test_image(), &reference(), None).unwrap();
        // Three pixels compared, nine channels: squared errors 0.01 and 0.04, the rest 0.
        assert_eq!((m.pixels, m.non_finite_test, m.non_finite_reference), (3, 1, 0));
        assert!(close(m.mse, 0.05 / 9.0), "{m:?}");
        assert!(close(m.rmse, (0.05f64 / 9.0).sqrt()), "{m:?}");
        // 0.01 / (0 + 0.01) + 0.04 / (0 + 0.01) = 5.
        assert!(close(m.rel_mse, 5.0 / 9.0), "{m:?}");
        assert!(close(m.mae, 0.3 / 9.0), "{m:?}");
        // Peak = the largest reference channel among the compared pixels = 2; 4 / (0.05/9) = 720.
        assert_eq!(m.peak, 2.0);
        assert!(close(m.psnr, 10.0 * 720f64.log10()), "{m:?}");
    }

    #[test]
    fn a_crop_compares_only_its_pixels() {
        // The right column: (1,0) compared, (1,1) has the NaN.
        let crop = Crop { x: 1, y: 0, width: 1, height: 2 };
        let m = compare(&test_image(), &reference(), Some(crop)).unwrap();
        assert_eq!((m.pixels, m.non_finite_test, m.non_finite_reference), (1, 1, 0));
        assert!(close(m.mse, 0.01 / 3.0) && close(m.rel_mse, 1.0 / 3.0) && close(m.mae, 0.1 / 3.0), "{m:?}");
        // The compared reference pixel is black: the peak falls back to 1.
        assert_eq!(m.peak, 1.0);
        assert!(close(m.psnr, 10.0 * 300f64.log10()), "{m:?}");

        let crop = Crop { x: 0, y: 1, width: 1, height: 1 };
        let m = compare(&test_image(), &reference(), Some(crop)).unwrap();
        assert_eq!((m.pixels, m.non_finite_test), (1, 0));
        assert!(close(m.mse, 0.04 / 3.0));
    }

    #[test]
    fn non_finite_reference_pixels_are_counted_too() {
        let mut r = reference();
        r.pixels[0] = Vec3::new(0.0, f32::INFINITY, 0.0);
        let m = compare(&test_image(), &r, None).unwrap();
        assert_eq!((m.pixels, m.non_finite_test, m.non_finite_reference), (2, 1, 1));
        assert!(close(m.mse, 0.05 / 6.0));
    }

    #[test]
    fn identical_images_and_nothing_to_compare() {
        let m = compare(&reference(), &reference(), None).unwrap();
        assert_eq!((m.mse, m.mae, m.rel_mse), (0.0, 0.0, 0.0));
        assert_eq!(m.psnr, f64::INFINITY);
        let nan = image([Vec3::NAN; 4]);
        let m = compare(&nan, &reference(), None).unwrap();
        assert_eq!((m.pixels, m.non_finite_test), (0, 4));
        assert!(m.mse.is_nan() && m.psnr.is_nan());
    }

    #[test]
    fn sizes_and_crops_are_checked() {
        let small = Image::new(2, 1);
        assert_eq!(
            compare(&small, &reference(), None),
            Err(MetricsError::SizeMismatch {
                test_width: 2,
                test_height: 1,
                reference_width: 2,
                reference_height: 2
            })
        );
        assert!(relative_squared_error(&reference(), &small).is_err());
        // A short pixel vector is a size mismatch, not an out-of-bounds panic.
        let mut short = reference();
        short.pixels.pop();
        assert!(matches!(compare(&short, &reference(), None), Err(MetricsError::SizeMismatch { .. })));
        for (x, y, width, height) in [(1, 0, 2, 1), (0, 2, 1, 1), (0, 0, 0, 1), (usize::MAX, 0, 2, 1)] {
            let crop = Crop { x, y, width, height };
            let err = compare(&test_image(), &reference(), Some(crop)).unwrap_err();
            assert!(
                matches!(err, MetricsError::CropOutside { image_width: 2, image_height: 2, .. }),
                "{err}"
            );
        }
        let whole = Crop { x: 0, y: 0, width: 2, height: 2 };
        assert_eq!(
            compare(&test_image(), &reference(), Some(whole)),
            compare(&test_image(), &reference(), None)
        );
    }

    #[test]
    fn per_pixel_relative_error() {
        let e = relative_squared_error(&test_image(), &reference()).unwrap();
        assert_eq!(e.len(), 4);
        assert_eq!(e[0], 0.0);
        assert!((e[1] - 1.0 / 3.0).abs() < 1e-6 && (e[2] - 4.0 / 3.0).abs() < 1e-6, "{e:?}");
        assert!(e[3].is_nan());
        // Its mean over the finite pixels is relMSE.
        let m = compare(&test_image(), &reference(), None).unwrap();
        assert!(close((e[0] + e[1] + e[2]) as f64 / 3.0, m.rel_mse));
    }

    #[test]
    fn crop_values_takes_the_rectangle() {
        let v: Vec<f32> = (0..12).map(|i| i as f32).collect(); // 4 wide, 3 tall
        assert_eq!(
            crop_values(&v, 4, Crop { x: 1, y: 1, width: 2, height: 2 }),
            Some(vec![5.0, 6.0, 9.0, 10.0])
        );
        assert_eq!(crop_values(&v, 4, Crop { x: 3, y: 0, width: 2, height: 1 }), None);
        assert_eq!(crop_values(&v, 4, Crop { x: 0, y: 2, width: 1, height: 2 }), None);
    }
}
