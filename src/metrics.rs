//! Error metrics between a test image and a reference, with the one definition of docs/workflow.md's
//! "Metrics" section, and the split of the MSE into its bias and its variance.
//!
//! With test image x and reference r, over the compared pixels and their three channels:
//! MSE = mean((x−r)²), RMSE = √MSE, relMSE = mean((x−r)² / (r² + 0.01)), MAE = mean(|x−r|) and
//! PSNR = 10·log10(peak² / MSE) dB. Sums are accumulated in f64.
//!
//! - **Non-finite pixels.** A pixel with a NaN or infinite channel is counted (per image, in
//!   [`Metrics::non_finite_test`] and [`Metrics::non_finite_reference`]) and left out of every
//!   mean: one NaN would otherwise turn every metric into NaN. Callers print the counts.
//! - **The HDR PSNR peak** is the largest reference channel value over the compared pixels (the
//!   brightest thing the reference shows, so PSNR is relative to the image's own range, as for
//!   HDR renders there is no fixed white). When that value is not positive (a black reference),
//!   the peak is 1. It is always reported in [`Metrics::peak`]. On a scene with a point light's
//!   hot spot that peak is far above everything else, and the HDR PSNR flatters noisy images:
//!   read it with [`Metrics::psnr_preview`].
//! - **Trimmed relMSE** ([`Metrics::rel_mse_trimmed`]), as in the denoising and path-guiding
//!   literature ("relMSE excluding the 0.1% highest pixel errors", e.g. Rousselle et al. 2012,
//!   Vogels et al. 2018, Müller et al. 2017): each compared pixel's relative squared error is the
//!   mean over its three channels of (x−r)²/(r²+0.01); the ⌊n/1000⌋ largest of the n values are
//!   dropped ([`TRIMMED_FRACTION`]; below 1000 pixels none is) and the rest averaged. A handful of
//!   fireflies can make the full relMSE; they cannot make the trimmed one.
//! - **Preview PSNR** ([`Metrics::psnr_preview`]): PSNR with peak 1 on the 8-bit PNG preview of
//!   both images as `vitrum render --png` writes it ([`crate::output::png::to_srgb8`]: exposure,
//!   clamp to [0, 1], the sRGB curve, 8 bits), each code divided by 255. It measures what a
//!   reader sees on the page; the 8-bit codes cap it near 59 dB for images that differ at all.
//! - **SSIM** ([`Metrics::ssim`], the perceptual metric): Wang, Bovik, Sheikh and Simoncelli
//!   (2004), on the luma Y′ = 0.2126 R′ + 0.7152 G′ + 0.0722 B′ of the same preview values
//!   (dynamic range L = 1), with their 11×11 Gaussian window of σ = 1.5 (weights normalised to
//!   sum 1), C1 = (0.01 L)², C2 = (0.03 L)² and biased (weighted) variances, averaged over every
//!   window position that lies wholly inside the compared region (no padding, as in the
//!   authors' `ssim_index.m`); windows touching a non-finite pixel are left out. NaN when the
//!   region is smaller than 11×11. SSIM is kept beside HDR-FLIP: exactly specified and
//!   testable by hand.
//! - **HDR-FLIP** ([`Metrics::flip`], the perceptual metric of the rendering literature;
//!   Andersson et al. 2020, 2021): the mean of [`crate::flip::hdr_flip`]'s per-pixel error with
//!   the reference implementation's defaults (67 pixels per degree, ACES tone mapping, the
//!   exposure range from the reference), over the compared pixels; checked against NVIDIA's
//!   `flip-evaluator` in `tests/flip.rs`. NaN for a reference with no positive luminance.
//! - **Degenerate cases.** Identical images give MSE 0 and PSNR +∞; when no pixel is finite in both
//!   images every mean is NaN (and `pixels` is 0).
//!
//! # Bias and variance
//! [`split`] divides a render's relMSE into the part its noise explains and its bias, with
//! standard errors from its replicas and a verdict ([`split`]'s module documentation).
//!
//! # Repeated runs
//! [`RunSpread`] gives relMSE, seconds and efficiency with intervals over K runs of one method
//! under K seeds (`vitrum compare --repeat K`; [`repeats`]'s module documentation).

mod repeats;
mod split;

pub use repeats::*;
pub use split::*;

use crate::image::Image;
use crate::output::png::to_srgb8;

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

/// The pixels a metric covers: a rectangle and, within it, only the pixels a mask selects when
/// there is one (`--mask`). A mask's rectangle is the bounding box of its selected pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct Region {
    /// The rectangle (a mask's bounding box).
    pub rect: Crop,
    /// Which pixels of the whole image count, row by row (`width·height` flags); `None` for every
    /// pixel of the rectangle.
    pub mask: Option<std::sync::Arc<[bool]>>,
}

impl Region {
    /// The whole of a rectangle.
    pub fn rect(rect: Crop) -> Region {
        Region { rect, mask: None }
    }

    /// The pixels `selected` (row by row) of a `width`-wide image; `None` when none is.
    pub fn masked(width: usize, selected: Vec<bool>) -> Option<Region> {
        let chosen = || selected.iter().enumerate().filter(|(_, &s)| s).map(|(i, _)| (i % width, i / width));
        let (x0, x1) = (chosen().map(|p| p.0).min()?, chosen().map(|p| p.0).max()?);
        let (y0, y1) = (chosen().map(|p| p.1).min()?, chosen().map(|p| p.1).max()?);
        let rect = Crop { x: x0, y: y0, width: x1 - x0 + 1, height: y1 - y0 + 1 };
        Some(Region { rect, mask: Some(selected.into()) })
    }

    /// How many pixels the region covers.
    pub fn pixel_count(&self) -> usize {
        match &self.mask {
            Some(mask) => mask.iter().filter(|&&m| m).count(),
            None => self.rect.width * self.rect.height,
        }
    }

    /// Whether pixel `i` of the whole image counts (for a pixel of the rectangle).
    fn selects(&self, i: usize) -> bool {
        self.mask.as_ref().is_none_or(|m| m[i])
    }

    /// The indices of the region's pixels in a `width`-wide raster, row by row.
    fn indices(&self, width: usize) -> impl Iterator<Item = usize> + '_ {
        region_indices(width, self.rect).filter(|&i| self.selects(i))
    }
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
    /// relMSE without the ⌊n/1000⌋ pixels of largest relative squared error (module docs).
    pub rel_mse_trimmed: f64,
    /// mean(|x − r|)
    pub mae: f64,
    /// 10·log10(peak² / MSE) in dB, on the linear HDR values
    pub psnr: f64,
    /// The peak used for PSNR: the largest reference channel value over the compared pixels, or 1
    /// when none is positive.
    pub peak: f64,
    /// PSNR in dB with peak 1 on the 8-bit tone-mapped preview (module docs).
    pub psnr_preview: f64,
    /// The exposure in stops of the preview that `psnr_preview` and `ssim` judge.
    pub exposure_ev: f32,
    /// SSIM of the preview's luma (module docs); NaN below 11×11 pixels.
    pub ssim: f64,
    /// Mean HDR-FLIP of the compared pixels (module docs; [`crate::flip`] with its default
    /// options); NaN where it is undefined (a reference without a positive luminance).
    pub flip: f64,
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
    /// A mask whose size is not the images'.
    #[error("the mask has {mask} pixels, the {image_width}x{image_height} image {}", image_width * image_height)]
    MaskSize {
        /// The mask's pixel count.
        mask: usize,
        /// Image width.
        image_width: usize,
        /// Image height.
        image_height: usize,
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
    /// A per-pixel variance of another size than its image.
    #[error("the {which} variance is {width}x{height}, not the size of its image")]
    VarianceSize {
        /// "test" or "reference".
        which: &'static str,
        /// Its width.
        width: usize,
        /// Its height.
        height: usize,
    },
}

/// The offset added to r² in the denominator of the relative squared error (docs/workflow.md, "Metrics").
pub const REL_EPSILON: f64 = 0.01;

/// The fraction of pixels, those of largest error, that the trimmed relMSE leaves out: 0.1%.
pub const TRIMMED_FRACTION: f64 = 0.001;

/// Weights of the luma the SSIM judges (ITU-R BT.709, the sRGB primaries), on encoded values.
pub const LUMA: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Side of the SSIM window, in pixels.
pub const SSIM_WINDOW: usize = 11;

/// Standard deviation of the SSIM window's Gaussian, in pixels.
pub const SSIM_SIGMA: f64 = 1.5;

/// SSIM's C1 = (K1·L)² with K1 = 0.01 and dynamic range L = 1.
pub const SSIM_C1: f64 = 0.01 * 0.01;

/// SSIM's C2 = (K2·L)² with K2 = 0.03 and L = 1.
pub const SSIM_C2: f64 = 0.03 * 0.03;

/// The metrics of `test` against `reference`, over `crop` or the whole image; the preview
/// metrics judge both images exposed by `exposure_ev` stops.
pub fn compare(
    test: &Image,
    reference: &Image,
    crop: Option<Crop>,
    exposure_ev: f32,
) -> Result<Metrics, MetricsError> {
    compare_over(test, reference, crop.map(Region::rect).as_ref(), exposure_ev)
}

/// The metrics of `test` against `reference` over `region` (or the whole image), as [`compare`];
/// SSIM takes the windows of the region's rectangle whose pixels all count.
pub fn compare_over(
    test: &Image,
    reference: &Image,
    region: Option<&Region>,
    exposure_ev: f32,
) -> Result<Metrics, MetricsError> {
    check_sizes(test, reference)?;
    let region = resolve_region(test, region)?;
    let crop = region.rect;

    let (mut sq, mut abs) = (0.0f64, 0.0f64);
    let mut rel_per_pixel: Vec<f64> = Vec::with_capacity(crop.width * crop.height);
    let mut max_reference = f64::NEG_INFINITY;
    let (mut pixels, mut non_finite_test, mut non_finite_reference) = (0usize, 0usize, 0usize);
    for (x, r) in region.indices(test.width).map(|i| (test.pixels[i], reference.pixels[i])) {
        let (x_ok, r_ok) = (x.is_finite(), r.is_finite());
        non_finite_test += usize::from(!x_ok);
        non_finite_reference += usize::from(!r_ok);
        if !(x_ok && r_ok) {
            continue;
        }
        pixels += 1;
        let mut rel = 0.0;
        for c in 0..3 {
            let (xc, rc) = (f64::from(x[c]), f64::from(r[c]));
            let d = xc - rc;
            sq += d * d;
            rel += d * d / (rc * rc + REL_EPSILON);
            abs += d.abs();
            max_reference = max_reference.max(rc);
        }
        rel_per_pixel.push(rel / 3.0);
    }

    let n = (3 * pixels) as f64;
    let mse = sq / n;
    let peak = if max_reference > 0.0 { max_reference } else { 1.0 };
    let rel_mse = rel_per_pixel.iter().sum::<f64>() / pixels as f64;
    let (preview_test, preview_reference) = (preview(test, exposure_ev), preview(reference, exposure_ev));
    let preview_mse = preview_squared_error(test, reference, &preview_test, &preview_reference, &region);
    Ok(Metrics {
        mse,
        rmse: mse.sqrt(),
        rel_mse,
        rel_mse_trimmed: trimmed_mean(rel_per_pixel),
        mae: abs / n,
        psnr: 10.0 * (peak * peak / mse).log10(),
        peak,
        psnr_preview: -10.0 * preview_mse.log10(),
        exposure_ev,
        ssim: ssim_of_previews(test, reference, &preview_test, &preview_reference, &region),
        flip: flip_mean(test, reference, &region),
        pixels,
        non_finite_test,
        non_finite_reference,
    })
}

/// The mean HDR-FLIP of `test` against `reference` over the pixels of `crop` finite in both (the
/// error map is computed on the whole images, whose surroundings the filters see); NaN when
/// HDR-FLIP is undefined for the reference or no pixel is finite.
fn flip_mean(test: &Image, reference: &Image, region: &Region) -> f64 {
    let Ok(result) = crate::flip::hdr_flip(test, reference, &crate::flip::FlipOptions::default()) else {
        return f64::NAN;
    };
    let finite = |i: &usize| test.pixels[*i].is_finite() && reference.pixels[*i].is_finite();
    result.mean_over(region.indices(test.width).filter(finite)).unwrap_or(f64::NAN)
}

/// The mean of `values` without their ⌊n·[`TRIMMED_FRACTION`]⌋ largest; NaN when empty.
pub fn trimmed_mean(mut values: Vec<f64>) -> f64 {
    let drop = (values.len() as f64 * TRIMMED_FRACTION).floor() as usize;
    let keep = values.len() - drop;
    if drop > 0 {
        values.select_nth_unstable_by(keep, f64::total_cmp);
    }
    values[..keep].iter().sum::<f64>() / keep as f64
}

/// The preview's channel values in [0, 1]: the 8-bit codes of [`to_srgb8`] over 255.
fn preview(image: &Image, exposure_ev: f32) -> Vec<f64> {
    to_srgb8(image, exposure_ev).into_iter().map(|c| f64::from(c) / 255.0).collect()
}

/// The mean squared difference of the previews over the pixels of `crop` finite in both images.
fn preview_squared_error(test: &Image, reference: &Image, pt: &[f64], pr: &[f64], region: &Region) -> f64 {
    let (mut sum, mut count) = (0.0, 0usize);
    for i in region.indices(test.width) {
        if test.pixels[i].is_finite() && reference.pixels[i].is_finite() {
            sum += (0..3).map(|c| (pt[3 * i + c] - pr[3 * i + c]).powi(2)).sum::<f64>();
            count += 3;
        }
    }
    sum / count as f64
}

/// The SSIM of the previews' luma over `crop`; windows touching a pixel not finite in either
/// image are left out.
fn ssim_of_previews(test: &Image, reference: &Image, pt: &[f64], pr: &[f64], region: &Region) -> f64 {
    let luma = |p: &[f64], i: usize| (0..3).map(|c| LUMA[c] * p[3 * i + c]).sum::<f64>();
    let crop = region.rect;
    let (mut x, mut y, mut valid) = (Vec::new(), Vec::new(), Vec::new());
    for i in region_indices(test.width, crop) {
        x.push(luma(pt, i));
        y.push(luma(pr, i));
        valid.push(region.selects(i) && test.pixels[i].is_finite() && reference.pixels[i].is_finite());
    }
    ssim(&x, &y, &valid, crop.width, crop.height)
}

/// The normalised 1-D weights of the SSIM window: exp(−k²/(2σ²)) for k = −5..=5, over their sum.
pub fn ssim_weights() -> [f64; SSIM_WINDOW] {
    let half = (SSIM_WINDOW / 2) as f64;
    let mut w = [0.0; SSIM_WINDOW];
    for (i, w) in w.iter_mut().enumerate() {
        let k = i as f64 - half;
        *w = (-k * k / (2.0 * SSIM_SIGMA * SSIM_SIGMA)).exp();
    }
    let sum: f64 = w.iter().sum();
    w.map(|v| v / sum)
}

/// SSIM of the `width`×`height` planes `x` and `y` (row-major, values in [0, 1]): the mean over
/// the window positions wholly inside the planes of which every pixel is `valid`; NaN when there
/// is none. See the module documentation for the constants.
pub fn ssim(x: &[f64], y: &[f64], valid: &[bool], width: usize, height: usize) -> f64 {
    if width < SSIM_WINDOW || height < SSIM_WINDOW {
        return f64::NAN;
    }
    let g = ssim_weights();
    let (ow, oh) = (width - SSIM_WINDOW + 1, height - SSIM_WINDOW + 1);
    // Separable filtering, 'valid' positions only: rows first, then columns.
    let filter = |plane: &dyn Fn(usize) -> f64, weights: &[f64; SSIM_WINDOW]| -> Vec<f64> {
        let mut rows = vec![0.0; ow * height];
        for r in 0..height {
            for c in 0..ow {
                rows[r * ow + c] = (0..SSIM_WINDOW).map(|k| weights[k] * plane(r * width + c + k)).sum();
            }
        }
        let mut out = vec![0.0; ow * oh];
        for r in 0..oh {
            for c in 0..ow {
                out[r * ow + c] = (0..SSIM_WINDOW).map(|k| weights[k] * rows[(r + k) * ow + c]).sum();
            }
        }
        out
    };
    let value = |p: &[f64], i: usize| if valid[i] { p[i] } else { 0.0 };
    let mu_x = filter(&|i| value(x, i), &g);
    let mu_y = filter(&|i| value(y, i), &g);
    let xx = filter(&|i| value(x, i).powi(2), &g);
    let yy = filter(&|i| value(y, i).powi(2), &g);
    let xy = filter(&|i| value(x, i) * value(y, i), &g);
    let invalid = filter(&|i| f64::from(u8::from(!valid[i])), &[1.0; SSIM_WINDOW]);
    let (mut sum, mut windows) = (0.0, 0usize);
    for i in 0..ow * oh {
        if invalid[i] > 0.0 {
            continue;
        }
        let (mx, my) = (mu_x[i], mu_y[i]);
        let (vx, vy, cxy) = (xx[i] - mx * mx, yy[i] - my * my, xy[i] - mx * my);
        sum += (2.0 * mx * my + SSIM_C1) * (2.0 * cxy + SSIM_C2)
            / ((mx * mx + my * my + SSIM_C1) * (vx + vy + SSIM_C2));
        windows += 1;
    }
    sum / windows as f64
}

/// The mean of `values` and its standard error, sd/√n (NaN for the error below two values).
fn mean_and_se(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let ss: f64 = values.iter().map(|v| (v - mean).powi(2)).sum();
    (mean, (ss / (n - 1.0)).sqrt() / n.sqrt())
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

/// The region, or the whole image: [`MetricsError::CropOutside`] unless its rectangle is
/// non-empty and inside, [`MetricsError::MaskSize`] unless its mask covers the image.
fn resolve_region(image: &Image, region: Option<&Region>) -> Result<Region, MetricsError> {
    let Some(region) = region else {
        return Ok(Region::rect(resolve_crop(image, None)?));
    };
    resolve_crop(image, Some(region.rect))?;
    if let Some(mask) = &region.mask {
        if mask.len() != image.width * image.height {
            return Err(MetricsError::MaskSize {
                mask: mask.len(),
                image_width: image.width,
                image_height: image.height,
            });
        }
    }
    Ok(region.clone())
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

/// The indices of the pixels of `crop` in a `width`-wide raster, row by row.
fn region_indices(width: usize, crop: Crop) -> impl Iterator<Item = usize> {
    (crop.y..crop.y + crop.height)
        .flat_map(move |row| row * width + crop.x..row * width + crop.x + crop.width)
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

/// Millions of rays per second.
pub fn mrays_per_second(rays: u64, seconds: f64) -> f64 {
    rays as f64 / seconds.max(1e-9) / 1e6
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
        let m = compare(&test_image(), &reference(), None, 0.0).unwrap();
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
        let m = compare(&test_image(), &reference(), Some(crop), 0.0).unwrap();
        assert_eq!((m.pixels, m.non_finite_test, m.non_finite_reference), (1, 1, 0));
        assert!(close(m.mse, 0.01 / 3.0) && close(m.rel_mse, 1.0 / 3.0) && close(m.mae, 0.1 / 3.0), "{m:?}");
        // The compared reference pixel is black: the peak falls back to 1.
        assert_eq!(m.peak, 1.0);
        assert!(close(m.psnr, 10.0 * 300f64.log10()), "{m:?}");

        let crop = Crop { x: 0, y: 1, width: 1, height: 1 };
        let m = compare(&test_image(), &reference(), Some(crop), 0.0).unwrap();
        assert_eq!((m.pixels, m.non_finite_test), (1, 0));
        assert!(close(m.mse, 0.04 / 3.0));
    }

    #[test]
    fn non_finite_reference_pixels_are_counted_too() {
        let mut r = reference();
        r.pixels[0] = Vec3::new(0.0, f32::INFINITY, 0.0);
        let m = compare(&test_image(), &r, None, 0.0).unwrap();
        assert_eq!((m.pixels, m.non_finite_test, m.non_finite_reference), (2, 1, 1));
        assert!(close(m.mse, 0.05 / 6.0));
    }

    #[test]
    fn identical_images_and_nothing_to_compare() {
        let m = compare(&reference(), &reference(), None, 0.0).unwrap();
        assert_eq!((m.mse, m.mae, m.rel_mse), (0.0, 0.0, 0.0));
        assert_eq!(m.psnr, f64::INFINITY);
        let nan = image([Vec3::NAN; 4]);
        let m = compare(&nan, &reference(), None, 0.0).unwrap();
        assert_eq!((m.pixels, m.non_finite_test), (0, 4));
        assert!(m.mse.is_nan() && m.psnr.is_nan());
    }

    #[test]
    fn sizes_and_crops_are_checked() {
        let small = Image::new(2, 1);
        assert_eq!(
            compare(&small, &reference(), None, 0.0),
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
        assert!(matches!(compare(&short, &reference(), None, 0.0), Err(MetricsError::SizeMismatch { .. })));
        for (x, y, width, height) in [(1, 0, 2, 1), (0, 2, 1, 1), (0, 0, 0, 1), (usize::MAX, 0, 2, 1)] {
            let crop = Crop { x, y, width, height };
            let err = compare(&test_image(), &reference(), Some(crop), 0.0).unwrap_err();
            assert!(
                matches!(err, MetricsError::CropOutside { image_width: 2, image_height: 2, .. }),
                "{err}"
            );
        }
        let whole = Crop { x: 0, y: 0, width: 2, height: 2 };
        // (Debug text: the SSIM of a 2×2 image is NaN, which is not equal to itself.)
        assert_eq!(
            format!("{:?}", compare(&test_image(), &reference(), Some(whole), 0.0)),
            format!("{:?}", compare(&test_image(), &reference(), None, 0.0))
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
        let m = compare(&test_image(), &reference(), None, 0.0).unwrap();
        assert!(close((e[0] + e[1] + e[2]) as f64 / 3.0, m.rel_mse));
    }

    #[test]
    fn a_mask_region_is_its_pixels_in_their_bounding_box() {
        // 4 wide: pixels (1,0) and (2,2) selected.
        let mut selected = vec![false; 12];
        selected[1] = true;
        selected[10] = true;
        let region = Region::masked(4, selected).unwrap();
        assert_eq!(region.rect, Crop { x: 1, y: 0, width: 2, height: 3 });
        assert_eq!(region.pixel_count(), 2);
        assert_eq!(region.indices(4).collect::<Vec<_>>(), [1, 10]);
        assert_eq!(Region::masked(4, vec![false; 12]), None);
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

    /// A `w`×`h` grey image of linear value `v`.
    fn grey(w: usize, h: usize, v: f32) -> Image {
        Image { width: w, height: h, pixels: vec![Vec3::splat(v); w * h] }
    }

    #[test]
    fn trimmed_rel_mse_drops_the_worst_tenth_of_a_percent() {
        // 1000 pixels (40×25): reference 1, test 1.1 (relative squared error d²/1.01 each, d the
        // f32 difference) but one firefly of 101 (10⁴/1.01). ⌊1000/1000⌋ = 1 pixel dropped: the
        // firefly.
        let one = grey(40, 25, 1.0);
        let mut test = grey(40, 25, 1.1);
        test.pixels[617] = Vec3::splat(101.0);
        let d = f64::from(1.1f32 - 1.0);
        let (e, firefly) = (d * d / 1.01, 1e4 / 1.01);
        let m = compare(&test, &one, None, 0.0).unwrap();
        assert!(close(m.rel_mse, (999.0 * e + firefly) / 1000.0), "{m:?}");
        assert!(close(m.rel_mse_trimmed, e), "{m:?}");
        assert!(m.rel_mse > 9.0 && m.rel_mse_trimmed < 0.011, "{m:?}");
        // 2000 pixels with three fireflies: two dropped, one kept.
        let one = grey(50, 40, 1.0);
        let mut test = grey(50, 40, 1.1);
        for i in [3, 999, 1500] {
            test.pixels[i] = Vec3::splat(101.0);
        }
        let m = compare(&test, &one, None, 0.0).unwrap();
        assert!(close(m.rel_mse_trimmed, (1997.0 * e + firefly) / 1998.0), "{m:?}");
        // Under 1000 pixels nothing is dropped.
        let m = compare(&test_image(), &reference(), None, 0.0).unwrap();
        assert_eq!(m.rel_mse_trimmed, m.rel_mse);
        assert!(trimmed_mean(Vec::new()).is_nan());
    }

    #[test]
    fn preview_psnr_has_peak_one_on_the_8_bit_preview() {
        // Black against white: preview values 0 and 1, MSE 1, 0 dB.
        let m = compare(&grey(2, 2, 0.0), &grey(2, 2, 1.0), None, 0.0).unwrap();
        assert!(close(m.psnr_preview, 0.0) || m.psnr_preview.abs() < 1e-12, "{m:?}");
        // Linear 0.5 is the sRGB code round(255·(1.055·0.5^(1/2.4) − 0.055)) = 188.
        let m = compare(&grey(2, 2, 0.5), &grey(2, 2, 1.0), None, 0.0).unwrap();
        let d = (255.0 - 188.0) / 255.0f64;
        assert!(close(m.psnr_preview, -10.0 * (d * d).log10()), "{m:?}");
        // One stop of exposure takes 0.5 to white: identical previews.
        let m = compare(&grey(2, 2, 0.5), &grey(2, 2, 1.0), None, 1.0).unwrap();
        assert_eq!((m.psnr_preview, m.exposure_ev), (f64::INFINITY, 1.0));
        // The HDR PSNR of the same images keeps its own peak (1).
        assert!(close(m.psnr, -10.0 * 0.25f64.log10()), "{m:?}");
        // The NaN pixel is left out of the preview too: only (1,0) and (0,1) differ.
        let m = compare(&test_image(), &reference(), None, 0.0).unwrap();
        let (red, green) = (f64::from(to_srgb8(&grey(1, 1, 0.1), 0.0)[0]) / 255.0, 0.0);
        let green_ref = 0.0f64;
        let green_test = f64::from(to_srgb8(&grey(1, 1, 0.2), 0.0)[0]) / 255.0;
        let mse = (red * red + (green_test - green_ref).powi(2) + green) / 9.0;
        assert!(close(m.psnr_preview, -10.0 * mse.log10()), "{m:?}");
    }

    #[test]
    fn ssim_of_constant_planes_and_a_checkerboard_by_hand() {
        // Black against white, one 11×11 window: σ = 0, so SSIM = C1 / (1 + C1).
        let m = compare(&grey(11, 11, 0.0), &grey(11, 11, 1.0), None, 0.0).unwrap();
        assert!(close(m.ssim, SSIM_C1 / (1.0 + SSIM_C1)), "{m:?}");
        assert_eq!(compare(&grey(11, 11, 0.5), &grey(11, 11, 0.5), None, 0.0).unwrap().ssim, 1.0);
        // Below one window: undefined.
        assert!(compare(&grey(10, 20, 0.0), &grey(10, 20, 1.0), None, 0.0).unwrap().ssim.is_nan());

        // Planes: x = a + d·(−1)^(i+j) (a checkerboard), y = a. With g the 1-D weights and
        // q = (Σ_k g_k (−1)^k)² over k = −5..=5, the window centred on an even square has
        // μx = a + d·q, σx² = d²(1 − q²), σy = σxy = 0: SSIM = (2μx·a + C1)/(μx² + a² + C1)
        // · C2/(σx² + C2). On a 12×11 plane the second window is centred on an odd square (−q).
        let g: Vec<f64> = (-5i32..=5).map(|k| (-(k * k) as f64 / (2.0 * 1.5 * 1.5)).exp()).collect();
        let total: f64 = g.iter().sum();
        let alternating: f64 =
            (-5i32..=5).zip(&g).map(|(k, w)| w / total * f64::from((-1i32).pow(k.unsigned_abs()))).sum();
        let q = alternating * alternating;
        let (a, d) = (0.5, 0.2);
        let by_hand = |sign: f64| {
            let mx = a + sign * d * q;
            let vx = d * d * (1.0 - q * q);
            (2.0 * mx * a + SSIM_C1) / (mx * mx + a * a + SSIM_C1) * SSIM_C2 / (vx + SSIM_C2)
        };
        let plane = |w: usize, h: usize| -> Vec<f64> {
            (0..w * h).map(|i| a + d * if (i % w + i / w).is_multiple_of(2) { 1.0 } else { -1.0 }).collect()
        };
        let (x, y) = (plane(11, 11), vec![a; 121]);
        let s = ssim(&x, &y, &[true; 121], 11, 11);
        // The centre (5,5) is an even square.
        assert!((s - by_hand(1.0)).abs() < 1e-12, "{s} against {}", by_hand(1.0));
        let (x, y) = (plane(12, 11), vec![a; 132]);
        let s = ssim(&x, &y, &[true; 132], 12, 11);
        let expected = (by_hand(1.0) + by_hand(-1.0)) / 2.0;
        assert!((s - expected).abs() < 1e-12, "{s} against {expected}");
        // A window touching an invalid pixel is left out: only the first window of 12×11 counts.
        let mut valid = [true; 132];
        valid[11] = false;
        assert!((ssim(&x, &y, &valid, 12, 11) - by_hand(1.0)).abs() < 1e-12);
        assert!(ssim(&x, &y, &[false; 132], 12, 11).is_nan());
    }
}
