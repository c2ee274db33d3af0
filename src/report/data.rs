//! The report's image data: linear RGB as half floats in base64, inside a `<script>` file.

use crate::image::Image;
use base64::Engine as _;
use half::f16;

/// The folder of the data files, beside the page.
pub const FOLDER: &str = "data";

/// The key of image `label` of section `section`: `s0-path`, `s1-reference`, … Labels are
/// method names or "reference"; any other character becomes `_`, so a key is a safe file name.
pub fn key(section: usize, label: &str) -> String {
    let label: String =
        label.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect();
    format!("s{section}-{label}")
}

/// The data file of `key`, relative to the page.
pub fn file_name(key: &str) -> String {
    format!("{FOLDER}/{key}.js")
}

/// A channel value as a half float: rounded to nearest, finite values beyond half's range
/// saturated to ±65504 (so a firefly stays a bright finite pixel), NaN and ±∞ kept.
pub fn to_half(x: f32) -> f16 {
    if x.is_finite() {
        f16::from_f32(x.clamp(-f16::MAX.to_f32(), f16::MAX.to_f32()))
    } else {
        f16::from_f32(x)
    }
}

/// The image's channels as little-endian half floats, row-major from the top row, R, G, B.
pub fn half_bytes(image: &Image) -> Vec<u8> {
    image.pixels.iter().flat_map(|p| p.to_array()).flat_map(|c| to_half(c).to_le_bytes()).collect()
}

/// The script that hands the image to the viewer: `vitrumReport.image("KEY", "BASE64");`.
pub fn script(key: &str, image: &Image) -> String {
    let encoded = base64::engine::general_purpose::STANDARD.encode(half_bytes(image));
    format!("vitrumReport.image(\"{key}\", \"{encoded}\");\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn halves_round_saturate_and_keep_nan() {
        assert_eq!(to_half(1.0).to_f32(), 1.0);
        assert_eq!(to_half(1e6).to_f32(), 65504.0);
        assert_eq!(to_half(-1e6).to_f32(), -65504.0);
        assert!(to_half(f32::NAN).is_nan());
        assert_eq!(to_half(f32::INFINITY).to_f32(), f32::INFINITY);
        // Rounded to nearest: 1 + 2^-11 is halfway between 1 and 1 + 2^-10 and rounds to even.
        assert_eq!(to_half(1.0 + 2f32.powi(-11)).to_f32(), 1.0);
        assert_eq!(to_half(1.0 + 3.0 * 2f32.powi(-11)).to_f32(), 1.0 + 2.0 * 2f32.powi(-10));
    }

    #[test]
    fn the_data_is_six_bytes_per_pixel_in_row_order() {
        let mut image = Image::new(2, 1);
        image.pixels[0] = Vec3::new(1.0, 2.0, 0.5);
        image.pixels[1] = Vec3::new(0.0, -2.0, 65504.0);
        let bytes = half_bytes(&image);
        assert_eq!(bytes.len(), 12);
        assert_eq!(&bytes[..6], &[0x00, 0x3c, 0x00, 0x40, 0x00, 0x38]);
        assert_eq!(&bytes[6..], &[0x00, 0x00, 0x00, 0xc0, 0xff, 0x7b]);
        let text = script("s0-path", &image);
        assert_eq!(text, "vitrumReport.image(\"s0-path\", \"ADwAQAA4AAAAwP97\");\n");
    }

    #[test]
    fn keys_are_safe_file_names() {
        assert_eq!(key(0, "path"), "s0-path");
        assert_eq!(key(3, "../x y"), "s3-___x_y");
        assert_eq!(file_name("s1-reference"), "data/s1-reference.js");
    }
}
