//! Error metrics between a test image and a reference, with the one definition of DESIGN.md.

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
    /// The peak used for PSNR.
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

/// The metrics of `test` against `reference`, over `crop` or the whole image.
pub fn compare(_test: &Image, _reference: &Image, _crop: Option<Crop>) -> Result<Metrics, MetricsError> {
    unimplemented!("under construction")
}

/// Per-pixel relative squared error, the mean over channels of (x − r)² / (r² + 0.01); NaN where
/// either pixel is not finite.
pub fn relative_squared_error(_test: &Image, _reference: &Image) -> Result<Vec<f32>, MetricsError> {
    unimplemented!("under construction")
}
