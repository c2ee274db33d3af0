//! Images as texel grids: loading PNG, JPEG and OpenEXR files into linear RGB, and filtered
//! lookups by texture coordinates.

use crate::image::limits::{decode_raster, RasterError};
use glam::{Vec2, Vec3};
use std::path::Path;

/// How the 8- or 16-bit values of an image file encode colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ColorSpace {
    /// The sRGB transfer curve (decoded to linear on load): the default for PNG and JPEG.
    Srgb,
    /// Values are linear already: the default for OpenEXR.
    Linear,
}

impl ColorSpace {
    /// The name scene files use: `srgb` or `linear`.
    pub fn name(self) -> &'static str {
        match self {
            ColorSpace::Srgb => "srgb",
            ColorSpace::Linear => "linear",
        }
    }
}

/// What a lookup outside [0, 1)² reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    /// The image tiles the plane.
    Repeat,
    /// The border texels extend outwards.
    Clamp,
}

/// How texels are combined at a lookup.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    /// The texel the point falls in.
    Nearest,
    /// Bilinear interpolation between the four texel centres around the point.
    Bilinear,
}

/// The sRGB electro-optical transfer function: an encoded value in [0, 1] to linear.
#[inline]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// An image's linear RGB texels, loaded once per scene however many textures and lights read
/// it (shared as an `Arc`; not `Clone`, so that a decoded image is never copied).
#[derive(PartialEq)]
pub struct ImageMap {
    /// Width in texels.
    pub width: usize,
    /// Height in texels.
    pub height: usize,
    /// `width * height` linear RGB texels, row by row from the top of the image.
    pub texels: Vec<Vec3>,
    /// The file the texels came from, for messages and `vitrum info`.
    pub file: String,
    /// How the file's values were decoded.
    pub colorspace: ColorSpace,
}

impl std::fmt::Debug for ImageMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ImageMap({}, {}x{})", self.file, self.width, self.height)
    }
}

/// Whether `bytes` begin with OpenEXR's magic number.
fn is_exr(bytes: &[u8]) -> bool {
    bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01])
}

/// Rows of a decoded PNG or JPEG converted to texels at a time.
const STRIP_ROWS: u32 = 64;

/// The RGB values of a decoded PNG or JPEG `image` as f32 texels (alpha dropped), converted a
/// strip of [`STRIP_ROWS`] rows at a time: the decoded image and its texels are the only
/// full-size buffers, never a whole converted copy between them.
fn raster_texels(image: &image::DynamicImage) -> Vec<Vec3> {
    let (width, height) = (image.width(), image.height());
    let mut texels = Vec::with_capacity(width as usize * height as usize);
    for top in (0..height).step_by(STRIP_ROWS as usize) {
        let strip = image.crop_imm(0, top, width, STRIP_ROWS.min(height - top)).into_rgb32f();
        texels.extend(strip.pixels().map(|p| Vec3::from_array(p.0)));
    }
    texels
}

impl ImageMap {
    /// The texels of an image file's contents `bytes` (PNG, JPEG or OpenEXR, told apart by their
    /// first bytes), read from `path` (named in errors). `colorspace` overrides the default
    /// (sRGB for PNG and JPEG, linear for EXR). The alpha channel is ignored. A file declaring
    /// more than [`MAX_IMAGE_PIXELS`](crate::image::limits::MAX_IMAGE_PIXELS) is refused before
    /// its pixels are decoded.
    pub fn decode(path: &Path, bytes: &[u8], colorspace: Option<ColorSpace>) -> Result<ImageMap, String> {
        let file = path.display().to_string();
        if bytes.is_empty() {
            return Err(format!("{file}: the image file is empty"));
        }
        let (width, height, mut texels, default_space) = if is_exr(bytes) {
            let image = crate::output::exr::decode_exr_rgb(path, bytes).map_err(|e| e.to_string())?;
            (image.width, image.height, image.pixels, ColorSpace::Linear)
        } else {
            let image = decode_raster(bytes).map_err(|e| match e {
                RasterError::TooLarge(e) => format!("{file}: {e}"),
                e => format!(
                    "{file}: cannot decode the image ({e}); PNG, JPEG and OpenEXR files are supported"
                ),
            })?;
            (image.width() as usize, image.height() as usize, raster_texels(&image), ColorSpace::Srgb)
        };
        if width == 0 || height == 0 {
            return Err(format!("{file}: the image has no texels ({width}x{height})"));
        }
        if let Some(bad) = texels.iter().position(|t| !t.is_finite() || t.min_element() < 0.0) {
            return Err(format!(
                "{file}: texel ({}, {}) is {} (texels must be finite and not negative)",
                bad % width,
                bad / width,
                texels[bad]
            ));
        }
        let colorspace = colorspace.unwrap_or(default_space);
        if colorspace == ColorSpace::Srgb {
            for t in &mut texels {
                *t = Vec3::new(srgb_to_linear(t.x), srgb_to_linear(t.y), srgb_to_linear(t.z));
            }
        }
        Ok(ImageMap { width, height, texels, file, colorspace })
    }

    /// The texel in column `x` and row `y` counted from the top (both in range).
    #[inline]
    pub fn texel(&self, x: usize, y: usize) -> Vec3 {
        self.texels[y * self.width + x]
    }

    /// The colour at texture coordinates `st`: s across the image from its left edge, t up from
    /// its bottom edge (the OBJ and OpenGL convention), one unit per image.
    pub fn lookup(&self, st: Vec2, wrap: Wrap, filter: Filter) -> Vec3 {
        // Non-finite coordinates (never made by the shapes) read as the image's corner.
        let st = if st.is_finite() { st } else { Vec2::ZERO };
        // Continuous texel coordinates: x to the right, y down from the top row.
        let x = st.x * self.width as f32;
        let y = (1.0 - st.y) * self.height as f32;
        match filter {
            Filter::Nearest => {
                let (i, j) =
                    (wrap_index(x.floor(), self.width, wrap), wrap_index(y.floor(), self.height, wrap));
                self.texel(i, j)
            }
            Filter::Bilinear => {
                // Texel centres sit at half-integers.
                let (x, y) = (x - 0.5, y - 0.5);
                let (x0, y0) = (x.floor(), y.floor());
                let (fx, fy) = (x - x0, y - y0);
                let (i0, i1) = wrap_pair(x0, self.width, wrap);
                let (j0, j1) = wrap_pair(y0, self.height, wrap);
                let top = self.texel(i0, j0) * (1.0 - fx) + self.texel(i1, j0) * fx;
                let bottom = self.texel(i0, j1) * (1.0 - fx) + self.texel(i1, j1) * fx;
                top * (1.0 - fy) + bottom * fy
            }
        }
    }
}

/// The integer-valued texel coordinate `i` as an integer, saturated far outside any image
/// (non-finite coordinates, which the shapes never make, become 0).
#[inline]
fn texel_coordinate(i: f32) -> i64 {
    if i.is_finite() {
        i.clamp(-1e15, 1e15) as i64
    } else {
        0
    }
}

/// The indices in `0..n` of the texel at the integer-valued coordinate `i` and of its right (or
/// lower) neighbour under `wrap`: one integer remainder for both.
#[inline]
fn wrap_pair(i: f32, n: usize, wrap: Wrap) -> (usize, usize) {
    let (i, n) = (texel_coordinate(i), n as i64);
    match wrap {
        Wrap::Repeat => {
            let a = i.rem_euclid(n);
            (a as usize, if a + 1 == n { 0 } else { a as usize + 1 })
        }
        Wrap::Clamp => (i.clamp(0, n - 1) as usize, (i + 1).clamp(0, n - 1) as usize),
    }
}

/// The index in `0..n` of the integer-valued texel coordinate `i` under `wrap`.
#[inline]
fn wrap_index(i: f32, n: usize, wrap: Wrap) -> usize {
    let (i, n) = (texel_coordinate(i), n as i64);
    match wrap {
        Wrap::Repeat => i.rem_euclid(n) as usize,
        Wrap::Clamp => i.clamp(0, n - 1) as usize,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2×2 image: top row red, green; bottom row blue, white (linear).
    fn two_by_two() -> ImageMap {
        ImageMap {
            width: 2,
            height: 2,
            texels: vec![Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE],
            file: "test".into(),
            colorspace: ColorSpace::Linear,
        }
    }

    #[test]
    fn texel_centres_read_their_texel_exactly() {
        let m = two_by_two();
        for filter in [Filter::Nearest, Filter::Bilinear] {
            // Centres: s = 0.25 / 0.75, t = 0.75 (top row) / 0.25 (bottom row).
            assert_eq!(m.lookup(Vec2::new(0.25, 0.75), Wrap::Clamp, filter), Vec3::X);
            assert_eq!(m.lookup(Vec2::new(0.75, 0.75), Wrap::Clamp, filter), Vec3::Y);
            assert_eq!(m.lookup(Vec2::new(0.25, 0.25), Wrap::Clamp, filter), Vec3::Z);
            assert_eq!(m.lookup(Vec2::new(0.75, 0.25), Wrap::Repeat, filter), Vec3::ONE);
        }
    }

    #[test]
    fn bilinear_weights_between_centres_and_at_borders() {
        let m = two_by_two();
        // Halfway between the two top centres: the mean of red and green.
        assert_eq!(m.lookup(Vec2::new(0.5, 0.75), Wrap::Clamp, Filter::Bilinear), Vec3::new(0.5, 0.5, 0.0));
        // A quarter of the way from red's centre to green's: weights 3/4, 1/4.
        assert_eq!(
            m.lookup(Vec2::new(0.375, 0.75), Wrap::Clamp, Filter::Bilinear),
            Vec3::new(0.75, 0.25, 0.0)
        );
        // The centre of the image: the mean of all four.
        assert_eq!(m.lookup(Vec2::new(0.5, 0.5), Wrap::Clamp, Filter::Bilinear), Vec3::new(0.5, 0.5, 0.5));
        // The left border (s = 0) on the top row's centre line: clamp reads red alone; repeat
        // averages red with green, the texel across the seam.
        assert_eq!(m.lookup(Vec2::new(0.0, 0.75), Wrap::Clamp, Filter::Bilinear), Vec3::X);
        assert_eq!(m.lookup(Vec2::new(0.0, 0.75), Wrap::Repeat, Filter::Bilinear), Vec3::new(0.5, 0.5, 0.0));
        // The top border (t = 1) on the left column's centre line: clamp reads red; repeat
        // averages red with blue, the bottom row.
        assert_eq!(m.lookup(Vec2::new(0.25, 1.0), Wrap::Clamp, Filter::Bilinear), Vec3::X);
        assert_eq!(m.lookup(Vec2::new(0.25, 1.0), Wrap::Repeat, Filter::Bilinear), Vec3::new(0.5, 0.0, 0.5));
    }

    #[test]
    fn wrap_modes_outside_the_unit_square() {
        let m = two_by_two();
        // Repeat: s = 1.25 is s = 0.25; s = -0.25 is s = 0.75; t = -0.75 is t = 0.25 (bottom row).
        assert_eq!(m.lookup(Vec2::new(1.25, 0.75), Wrap::Repeat, Filter::Nearest), Vec3::X);
        assert_eq!(m.lookup(Vec2::new(-0.25, 0.75), Wrap::Repeat, Filter::Nearest), Vec3::Y);
        assert_eq!(m.lookup(Vec2::new(0.25, -0.75), Wrap::Repeat, Filter::Nearest), Vec3::Z);
        // Clamp: far outside reads the border texel.
        assert_eq!(m.lookup(Vec2::new(7.0, 0.75), Wrap::Clamp, Filter::Nearest), Vec3::Y);
        assert_eq!(m.lookup(Vec2::new(-7.0, -7.0), Wrap::Clamp, Filter::Bilinear), Vec3::Z);
        assert!(m.lookup(Vec2::new(f32::NAN, 0.5), Wrap::Repeat, Filter::Bilinear).is_finite());
    }

    #[test]
    fn srgb_decoding_formula() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert_eq!(srgb_to_linear(1.0), 1.0);
        // The linear segment and its end.
        assert_eq!(srgb_to_linear(0.04), 0.04 / 12.92);
        // 0.5 encodes 0.21404 (IEC 61966-2-1).
        assert!((srgb_to_linear(0.5) - 0.214_041_14).abs() < 1e-6);
        // The two segments meet (continuity at 0.04045 to within 1e-7).
        let below = 0.04045f32 / 12.92;
        let above = ((0.04045f32 + 0.055) / 1.055).powf(2.4);
        assert!((below - above).abs() < 1e-7);
    }

    fn png_bytes(width: u32, height: u32, pixels: &[[u8; 3]]) -> Vec<u8> {
        let mut img = image::RgbImage::new(width, height);
        for (p, v) in img.pixels_mut().zip(pixels) {
            p.0 = *v;
        }
        let mut bytes = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).unwrap();
        bytes
    }

    #[test]
    fn png_texels_are_decoded_from_srgb_unless_linear() {
        let bytes = png_bytes(2, 1, &[[255, 0, 128], [0, 255, 0]]);
        let m = ImageMap::decode(Path::new("a.png"), &bytes, None).unwrap();
        assert_eq!((m.width, m.height), (2, 1));
        assert_eq!(m.texel(0, 0), Vec3::new(1.0, 0.0, srgb_to_linear(128.0 / 255.0)));
        let linear = ImageMap::decode(Path::new("a.png"), &bytes, Some(ColorSpace::Linear)).unwrap();
        assert_eq!(linear.texel(0, 0), Vec3::new(1.0, 0.0, 128.0 / 255.0));
        assert_eq!(linear.texel(1, 0), Vec3::Y);
    }

    #[test]
    fn strips_convert_as_the_whole_image_does() {
        // 16-bit RGBA over more rows than a strip (and not a multiple of it): alpha dropped,
        // every value kept to f32 as one conversion of the whole image gives it.
        let (w, h) = (3u32, 2 * STRIP_ROWS + 5);
        let image = image::DynamicImage::ImageRgba16(image::ImageBuffer::from_fn(w, h, |x, y| {
            image::Rgba([(x * 1000 + y) as u16, (y * 97) as u16, 65535 - y as u16, 7])
        }));
        let whole: Vec<Vec3> = image.to_rgb32f().pixels().map(|p| Vec3::from_array(p.0)).collect();
        assert_eq!(raster_texels(&image), whole);
    }

    #[test]
    fn jpeg_files_decode_from_srgb() {
        // A flat grey JPEG: lossy, but a uniform block survives to within a unit of 8 bits.
        let mut img = image::RgbImage::new(8, 8);
        img.pixels_mut().for_each(|p| p.0 = [128, 128, 128]);
        let mut bytes = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Jpeg).unwrap();
        let m = ImageMap::decode(Path::new("a.jpg"), &bytes, None).unwrap();
        assert_eq!((m.width, m.height, m.colorspace), (8, 8, ColorSpace::Srgb));
        let expected = srgb_to_linear(128.0 / 255.0);
        for t in &m.texels {
            assert!((t.x - expected).abs() < 0.005 && (t.y - expected).abs() < 0.005, "{t} vs {expected}");
        }
    }

    #[test]
    fn exr_texels_are_exact_and_linear() {
        let dir = std::env::temp_dir().join(format!("vitrum-texture-exr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.exr");
        let mut image = crate::image::Image::new(3, 2);
        let values = [0.1f32, 2.5, 1e-3, 100.0, 0.0, 7.25];
        for (i, p) in image.pixels.iter_mut().enumerate() {
            *p = Vec3::new(values[i], values[(i + 1) % 6], values[(i + 2) % 6]);
        }
        crate::output::exr::write_exr(&path, &image, &Default::default()).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let m = ImageMap::decode(&path, &bytes, None).unwrap();
        assert_eq!(m.texels, image.pixels);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn bad_files_are_errors_naming_the_file() {
        let p = Path::new("textures/bad.png");
        let e = ImageMap::decode(p, &[], None).unwrap_err();
        assert!(e.contains("textures/bad.png") && e.contains("empty"), "{e}");
        let e = ImageMap::decode(p, b"not an image at all", None).unwrap_err();
        assert!(e.contains("textures/bad.png") && e.contains("PNG, JPEG and OpenEXR"), "{e}");
        // A PNG cut short.
        let bytes = png_bytes(4, 4, &[[1, 2, 3]; 16]);
        let e = ImageMap::decode(p, &bytes[..bytes.len() / 2], None).unwrap_err();
        assert!(e.contains("textures/bad.png"), "{e}");
        // A GIF (a format this build does not decode).
        let e = ImageMap::decode(p, b"GIF89a\x01\x00\x01\x00\x00\x00\x00", None).unwrap_err();
        assert!(e.contains("PNG, JPEG and OpenEXR"), "{e}");
    }
}
