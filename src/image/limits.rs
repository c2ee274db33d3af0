//! The one size limit on every image vitrum reads (textures, environment maps, masks, and the
//! EXR files of `diff`, `merge`, `--resume`, `--reference` and `--renders`), checked against
//! the size a file declares in its header, before any pixel is allocated; and the PNG and JPEG
//! reader that applies it.

use std::io::Cursor;
use std::path::Path;

/// Most pixels (width × height, per EXR layer) of an image vitrum reads: 2²⁷ = 134 217 728, a
/// 16384 × 8192 map, the largest size HDR environment maps are commonly published at.
///
/// vitrum keeps an image as linear f32 RGB, 12 bytes a pixel: 1.5 GiB at the limit. Decoding
/// holds more for a moment (the decoder's samples, up to 16 bytes a pixel for RGBA f32, beside
/// the RGB copy: 3.5 GiB), and an environment map adds its sampling distribution (one f64 per
/// texel, 1 GiB), so an image at the limit loads in about 4 GiB besides the file's own bytes.
/// Twice the largest render ([`crate::scene::compile::MAX_PIXELS`]): vitrum reads back every
/// image it writes.
pub const MAX_IMAGE_PIXELS: u64 = 1 << 27;

/// The widest pixel a PNG or JPEG decoder hands over (RGBA, 4 bytes a channel), in bytes: the
/// decoders' allocation budget is this per pixel at the limit.
const WIDEST_DECODED_PIXEL: u64 = 16;

// vitrum reads back every image it writes.
const _: () = assert!(MAX_IMAGE_PIXELS >= crate::scene::compile::MAX_PIXELS, "renders must read back");

/// An image whose header declares more than [`MAX_IMAGE_PIXELS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "the image declares {width}x{height} pixels, over vitrum's limit of {MAX_IMAGE_PIXELS} pixels per image"
)]
pub struct ImageTooLarge {
    /// The declared width in pixels.
    pub width: u64,
    /// The declared height in pixels.
    pub height: u64,
}

/// Whether an image of `width` × `height` pixels is within [`MAX_IMAGE_PIXELS`].
pub fn check_image_size(width: u64, height: u64) -> Result<(), ImageTooLarge> {
    match width.checked_mul(height) {
        Some(pixels) if pixels <= MAX_IMAGE_PIXELS => Ok(()),
        _ => Err(ImageTooLarge { width, height }),
    }
}

/// Why a PNG or JPEG file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum RasterError {
    /// The file could not be read.
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// Its header declares more pixels than vitrum reads.
    #[error("{0}")]
    TooLarge(#[from] ImageTooLarge),
    /// The decoder refused it (not PNG or JPEG, damaged, cut short).
    #[error("{0}")]
    Decode(#[from] ::image::ImageError),
}

/// The decoders' limits, from [`MAX_IMAGE_PIXELS`]: no side longer than the limit, no more
/// allocated than its widest pixels take.
fn decoder_limits() -> ::image::Limits {
    let mut limits = ::image::Limits::default();
    let side = u32::try_from(MAX_IMAGE_PIXELS).unwrap_or(u32::MAX);
    limits.max_image_width = Some(side);
    limits.max_image_height = Some(side);
    limits.max_alloc = Some(MAX_IMAGE_PIXELS * WIDEST_DECODED_PIXEL);
    limits
}

/// A reader of the image file contents `bytes`, its format told by its first bytes, under
/// [`decoder_limits`].
fn limited_reader(bytes: &[u8]) -> Result<::image::ImageReader<Cursor<&[u8]>>, RasterError> {
    let mut reader = ::image::ImageReader::new(Cursor::new(bytes)).with_guessed_format()?;
    reader.limits(decoder_limits());
    Ok(reader)
}

/// The image of PNG or JPEG file contents `bytes`: its header's size checked against
/// [`MAX_IMAGE_PIXELS`] first, then decoded under the same limit.
pub fn decode_raster(bytes: &[u8]) -> Result<::image::DynamicImage, RasterError> {
    let (width, height) = limited_reader(bytes)?.into_dimensions()?;
    check_image_size(width.into(), height.into())?;
    Ok(limited_reader(bytes)?.decode()?)
}

/// The image of the PNG or JPEG file `path`, as [`decode_raster`] reads it.
pub fn read_raster(path: &Path) -> Result<::image::DynamicImage, RasterError> {
    decode_raster(&std::fs::read(path)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An 8×8 JPEG whose frame header (SOF0) declares `width` × `height` pixels.
    fn jpeg_declaring(width: u16, height: u16) -> Vec<u8> {
        let mut bytes = Vec::new();
        ::image::RgbImage::new(8, 8)
            .write_to(&mut Cursor::new(&mut bytes), ::image::ImageFormat::Jpeg)
            .unwrap();
        let sof = bytes.windows(2).position(|w| w == [0xFF, 0xC0]).expect("a baseline frame header");
        // The marker (2 bytes), the segment length (2), the sample precision (1), height, width.
        bytes[sof + 5..sof + 7].copy_from_slice(&height.to_be_bytes());
        bytes[sof + 7..sof + 9].copy_from_slice(&width.to_be_bytes());
        bytes
    }

    #[test]
    fn the_limit_is_the_pixel_count() {
        assert_eq!(check_image_size(16384, 8192), Ok(()));
        assert_eq!(check_image_size(MAX_IMAGE_PIXELS, 1), Ok(()));
        assert!(check_image_size(16384, 8193).is_err());
        assert!(check_image_size(24000, 12000).is_err());
        assert!(check_image_size(u64::MAX, 2).is_err(), "no overflow");
        let message = check_image_size(24000, 12000).unwrap_err().to_string();
        assert!(message.contains("24000x12000") && message.contains("134217728"), "{message}");
    }

    /// PNG files declaring too many pixels: `tests/textures.rs` and `tests/diff.rs`.
    #[test]
    fn a_jpeg_declaring_too_many_pixels_is_refused_before_decoding() {
        match decode_raster(&jpeg_declaring(65_000, 65_000)) {
            Err(RasterError::TooLarge(e)) => assert_eq!((e.width, e.height), (65_000, 65_000)),
            other => panic!("{other:?}"),
        }
        assert_eq!(decode_raster(&jpeg_declaring(8, 8)).unwrap().height(), 8);
    }
}
