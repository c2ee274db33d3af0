//! 8-bit sRGB PNG previews of linear HDR images.

use super::{check_pixel_count, stage_bytes, OutputError, Staged};
use crate::image::Image;
use std::path::Path;

/// The preview colour of a pixel with a NaN channel: magenta, so it stands out.
const NAN_RGB8: [u8; 3] = [255, 0, 255];

/// The sRGB OETF (IEC 61966-2-1) on \[0, 1\]: linear light to the encoded value; callers clamp first.
pub fn linear_to_srgb(x: f32) -> f32 {
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// A linear channel value (already exposed) as an 8-bit sRGB code: clamp, encode, round.
fn srgb8(x: f32) -> u8 {
    // `clamp` keeps NaN; callers map NaN pixels to magenta before this.
    (linear_to_srgb(x.clamp(0.0, 1.0)) * 255.0).round() as u8
}

/// The RGB8 bytes (row-major, top row first) of the preview: pixel * 2^exposure_ev, clamp, sRGB OETF, NaN → magenta.
pub fn to_srgb8(image: &Image, exposure_ev: f32) -> Vec<u8> {
    let scale = exposure_ev.exp2();
    image
        .pixels
        .iter()
        .flat_map(|p| if p.is_nan() { NAN_RGB8 } else { (*p * scale).to_array().map(srgb8) })
        .collect()
}

/// sRGB 8-bit preview: pixel * 2^exposure_ev, then clamp to \[0, 1\], then the sRGB OETF, rounded. NaN pixels become magenta (255,0,255) so they are visible.
pub fn write_png(path: &Path, image: &Image, exposure_ev: f32) -> Result<(), OutputError> {
    stage_png(path, image, exposure_ev)?.commit()
}

/// Encode the preview into a temporary file beside `path`, to be published with
/// [`Staged::commit`].
pub fn stage_png(path: &Path, image: &Image, exposure_ev: f32) -> Result<Staged, OutputError> {
    check_pixel_count(path, image)?;
    stage_rgb8(path, image.width, image.height, &to_srgb8(image, exposure_ev))
}

/// The preview of [`stage_png`] encoded as PNG bytes in memory (a notebook's display of a render).
pub fn preview_png(image: &Image, exposure_ev: f32) -> Result<Vec<u8>, String> {
    encode_rgb8(image.width, image.height, &to_srgb8(image, exposure_ev))
}

/// Grey levels `values` in [0, 1] (clamped), staged linearly as 8-bit RGB: for data such as
/// sample-density maps, not for radiance.
pub fn stage_grey_png(
    path: &Path,
    width: usize,
    height: usize,
    values: &[f32],
) -> Result<Staged, OutputError> {
    if values.len() != width * height {
        return Err(OutputError::format(path, "value count does not match the image size"));
    }
    let bytes: Vec<u8> = values.iter().flat_map(|v| [(v.clamp(0.0, 1.0) * 255.0).round() as u8; 3]).collect();
    stage_rgb8(path, width, height, &bytes)
}

/// Stage packed RGB8 bytes as a PNG file.
pub fn stage_rgb8(path: &Path, width: usize, height: usize, bytes: &[u8]) -> Result<Staged, OutputError> {
    // Encoded in memory, then staged (see `stage_bytes`).
    let png = encode_rgb8(width, height, bytes).map_err(|e| OutputError::format(path, e))?;
    stage_bytes(path, &png)
}

/// Packed RGB8 bytes (row-major, top row first) encoded as PNG.
pub fn encode_rgb8(width: usize, height: usize, bytes: &[u8]) -> Result<Vec<u8>, String> {
    let too_big = || "image too large for PNG".to_string();
    let width = u32::try_from(width).map_err(|_| too_big())?;
    let height = u32::try_from(height).map_err(|_| too_big())?;
    if bytes.len() as u64 != width as u64 * height as u64 * 3 {
        return Err("byte count does not match the image size".into());
    }
    let mut png = Vec::new();
    ::image::ImageEncoder::write_image(
        ::image::codecs::png::PngEncoder::new(&mut png),
        bytes,
        width,
        height,
        ::image::ExtendedColorType::Rgb8,
    )
    .map_err(|e| format!("cannot encode PNG: {e}"))?;
    Ok(png)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::tests::dir_entries;
    use glam::Vec3;

    fn grey(width: usize, height: usize, values: &[f32]) -> Image {
        Image { width, height, pixels: values.iter().map(|&v| Vec3::splat(v)).collect() }
    }

    #[test]
    fn oetf_matches_the_srgb_definition() {
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert!((linear_to_srgb(1.0) - 1.0).abs() < 1e-6);
        assert!((linear_to_srgb(0.5) - 0.735_356_7).abs() < 1e-6);
        assert!((linear_to_srgb(0.001) - 0.012_92).abs() < 1e-7); // linear segment
                                                                  // continuous at the breakpoint
        assert!((linear_to_srgb(0.003_130_8) - linear_to_srgb(0.003_130_9)).abs() < 1e-5);
    }

    #[test]
    fn known_srgb_codes() {
        let image = grey(6, 1, &[0.0, 1.0, 0.5, 0.18, -3.0, 7.0]);
        let codes: Vec<u8> = to_srgb8(&image, 0.0).chunks(3).map(|c| c[0]).collect();
        // 18% grey encodes to 0.4614 = 117.6/255.
        assert_eq!(codes, [0, 255, 188, 118, 0, 255]);
        assert!(to_srgb8(&image, 0.0).chunks(3).all(|c| c[0] == c[1] && c[1] == c[2]));
    }

    #[test]
    fn exposure_scales_before_the_curve() {
        let half = grey(1, 1, &[0.5]);
        let quarter = grey(1, 1, &[0.25]);
        assert_eq!(to_srgb8(&quarter, 1.0), to_srgb8(&half, 0.0));
        assert_eq!(to_srgb8(&half, -1.0), to_srgb8(&quarter, 0.0));
        assert_eq!(to_srgb8(&grey(1, 1, &[0.6]), 1.0), [255, 255, 255]); // doubled, then clamped
    }

    #[test]
    fn nan_is_magenta_and_infinities_clamp() {
        let mut image = Image::new(3, 1);
        image.pixels[0] = Vec3::new(0.5, f32::NAN, 0.0);
        image.pixels[1] = Vec3::new(f32::INFINITY, f32::NEG_INFINITY, 1.0);
        image.pixels[2] = Vec3::new(1.0, 0.0, 0.0);
        assert_eq!(to_srgb8(&image, 0.0), [255, 0, 255, 255, 0, 255, 255, 0, 0]);
    }

    #[test]
    fn writes_a_decodable_png_of_the_right_size() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("preview.png");
        let mut image = Image::new(7, 5);
        for (i, p) in image.pixels.iter_mut().enumerate() {
            *p = Vec3::new(i as f32 / 34.0, 0.5, 0.0);
        }
        image.pixels[8] = Vec3::NAN;
        write_png(&path, &image, 0.0).unwrap();
        assert_eq!(dir_entries(dir.path()), ["preview.png"]);

        let decoded = ::image::open(&path).unwrap().to_rgb8();
        assert_eq!(decoded.dimensions(), (7, 5));
        assert_eq!(decoded.as_raw(), &to_srgb8(&image, 0.0));
        assert_eq!(decoded.get_pixel(1, 1).0, [255, 0, 255]); // pixel 8 = row 1, column 1
        assert_eq!(decoded.get_pixel(0, 0).0, [0, 188, 0]);
    }

    #[test]
    fn failed_write_names_the_path_and_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("preview.png");
        let mut image = Image::new(2, 2);
        image.pixels.pop();
        let err = write_png(&path, &image, 0.0).unwrap_err();
        assert!(err.to_string().contains("preview.png"), "{err}");
        assert!(dir_entries(dir.path()).is_empty());
    }
}
