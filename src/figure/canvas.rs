//! An 8-bit sRGB raster for figures: rectangles, tone-mapped renders and text set in the embedded
//! DejaVu Sans (so labels look the same on every machine, with no system fonts needed).

use crate::image::Image;
use crate::output::png::{stage_rgb8, to_srgb8};
use crate::output::{OutputError, Staged};
use ab_glyph::{Font, FontRef, PxScale, ScaleFont};
use std::path::Path;
use std::sync::OnceLock;

/// The embedded font (DejaVu Sans; licence in `assets/fonts/LICENSE-DejaVu`).
pub const FONT_BYTES: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// The parsed embedded font.
pub fn font() -> &'static FontRef<'static> {
    static FONT: OnceLock<FontRef<'static>> = OnceLock::new();
    FONT.get_or_init(|| FontRef::try_from_slice(FONT_BYTES).expect("the embedded font parses"))
}

/// An sRGB colour.
pub type Rgb = [u8; 3];

/// White.
pub const WHITE: Rgb = [255, 255, 255];
/// Black.
pub const BLACK: Rgb = [0, 0, 0];

/// A width × height raster of sRGB pixels, row by row from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Canvas {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Pixels, row-major from the top-left.
    pub pixels: Vec<Rgb>,
}

impl Canvas {
    /// A canvas filled with `background`.
    pub fn new(width: u32, height: u32, background: Rgb) -> Canvas {
        Canvas { width, height, pixels: vec![background; width as usize * height as usize] }
    }

    /// Sets one pixel; outside the canvas nothing happens.
    pub fn set(&mut self, x: i64, y: i64, color: Rgb) {
        if x >= 0 && y >= 0 && (x as u32) < self.width && (y as u32) < self.height {
            self.pixels[y as usize * self.width as usize + x as usize] = color;
        }
    }

    /// The pixel at (x, y).
    pub fn get(&self, x: u32, y: u32) -> Rgb {
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Fills the rectangle with top-left corner (x, y), clipped to the canvas.
    pub fn fill_rect(&mut self, x: i64, y: i64, w: u32, h: u32, color: Rgb) {
        for j in y..y + h as i64 {
            for i in x..x + w as i64 {
                self.set(i, j, color);
            }
        }
    }

    /// Draws the outline of a rectangle `thickness` pixels wide, inside its bounds.
    pub fn stroke_rect(&mut self, x: i64, y: i64, w: u32, h: u32, thickness: u32, color: Rgb) {
        let t = thickness.min(w).min(h);
        self.fill_rect(x, y, w, t, color);
        self.fill_rect(x, y + (h - t) as i64, w, t, color);
        self.fill_rect(x, y, t, h, color);
        self.fill_rect(x + (w - t) as i64, y, t, h, color);
    }

    /// Copies `other` with its top-left corner at (x, y), clipped to the canvas.
    pub fn blit(&mut self, x: i64, y: i64, other: &Canvas) {
        for j in 0..other.height {
            for i in 0..other.width {
                self.set(x + i as i64, y + j as i64, other.get(i, j));
            }
        }
    }

    /// A linear HDR render tone-mapped to sRGB with the exposure `exposure_ev` (stops).
    pub fn from_image(image: &Image, exposure_ev: f32) -> Canvas {
        let bytes = to_srgb8(image, exposure_ev);
        Canvas {
            width: image.width as u32,
            height: image.height as u32,
            pixels: bytes.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        }
    }

    /// This canvas scaled by an integer factor with nearest-neighbour sampling (pixel-exact zooms).
    pub fn magnified(&self, factor: u32) -> Canvas {
        let factor = factor.max(1);
        let mut out = Canvas::new(self.width * factor, self.height * factor, BLACK);
        for y in 0..out.height {
            for x in 0..out.width {
                out.pixels[(y * out.width + x) as usize] = self.get(x / factor, y / factor);
            }
        }
        out
    }

    /// The part of this canvas inside the rectangle (clipped to the canvas).
    pub fn crop(&self, x: u32, y: u32, w: u32, h: u32) -> Canvas {
        let (w, h) = (w.min(self.width.saturating_sub(x)), h.min(self.height.saturating_sub(y)));
        let mut out = Canvas::new(w, h, BLACK);
        for j in 0..h {
            for i in 0..w {
                out.pixels[(j * w + i) as usize] = self.get(x + i, y + j);
            }
        }
        out
    }

    /// Sets `text` with its top-left corner at (x, y), `size` pixels from ascent to descent,
    /// blending anti-aliased glyph coverage over the canvas. Returns the advance width in pixels.
    pub fn text(&mut self, x: f32, y: f32, size: f32, color: Rgb, text: &str) -> f32 {
        let (x0, y0) = (x.floor(), y.floor());
        for_each_text_pixel(size, text, (x - x0, y - y0), |gx, gy, coverage| {
            let (px, py) = (x0 as i64 + gx, y0 as i64 + gy);
            if px < 0 || py < 0 || px >= self.width as i64 || py >= self.height as i64 {
                return;
            }
            let under = self.get(px as u32, py as u32);
            let a = coverage.clamp(0.0, 1.0);
            let mix = |u: u8, c: u8| (u as f32 * (1.0 - a) + c as f32 * a).round() as u8;
            self.set(px, py, [mix(under[0], color[0]), mix(under[1], color[1]), mix(under[2], color[2])]);
        })
    }

    /// The advance width of `text` at `size` pixels, as [`text`](Self::text) would set it.
    pub fn text_width(size: f32, text: &str) -> f32 {
        for_each_text_pixel(size, text, (0.0, 0.0), |_, _, _| {})
    }

    /// Prepares the canvas as a PNG file at `path` (written by [`Staged::commit`]).
    pub fn stage_png(&self, path: &Path) -> Result<Staged, OutputError> {
        let bytes: Vec<u8> = self.pixels.iter().flatten().copied().collect();
        stage_rgb8(path, self.width as usize, self.height as usize, &bytes)
    }

    /// Writes the canvas as a PNG file, atomically.
    pub fn save_png(&self, path: &Path) -> Result<(), OutputError> {
        self.stage_png(path)?.commit()
    }
}

/// Lays out `text` at `size` pixels in the embedded font, with the top of its ascent at `offset`
/// (sub-pixel, from the origin), and calls `pixel(x, y, coverage)` for every pixel a glyph covers,
/// in whole pixels from the origin. Glyphs sit at their side bearings and kerning applies. Returns
/// the advance width.
pub fn for_each_text_pixel(
    size: f32,
    text: &str,
    offset: (f32, f32),
    mut pixel: impl FnMut(i64, i64, f32),
) -> f32 {
    let font = font().as_scaled(PxScale::from(size));
    let mut caret = offset.0;
    let mut previous = None;
    for c in text.chars() {
        let id = font.glyph_id(c);
        if let Some(p) = previous {
            caret += font.kern(p, id);
        }
        let glyph = id.with_scale_and_position(size, ab_glyph::point(caret, offset.1 + font.ascent()));
        caret += font.h_advance(id);
        previous = Some(id);
        let Some(outlined) = font.outline_glyph(glyph) else { continue };
        let bounds = outlined.px_bounds();
        outlined.draw(|gx, gy, coverage| {
            pixel(bounds.min.x as i64 + gx as i64, bounds.min.y as i64 + gy as i64, coverage)
        });
    }
    caret - offset.0
}

/// The height of a line of text at `size` pixels, from ascent to descent.
pub fn text_height(size: f32) -> f32 {
    let font = font().as_scaled(PxScale::from(size));
    font.ascent() - font.descent()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_drawn_inside_its_advance_and_in_the_given_colour() {
        let mut c = Canvas::new(200, 40, WHITE);
        let w = c.text(10.0, 5.0, 20.0, BLACK, "vitrum 1/N");
        assert!((w - Canvas::text_width(20.0, "vitrum 1/N")).abs() < 1e-3);
        assert!(w > 60.0 && w < 180.0, "{w}");
        let dark: Vec<(u32, u32)> = (0..40)
            .flat_map(|y| (0..200).map(move |x| (x, y)))
            .filter(|&(x, y)| c.get(x, y)[0] < 128)
            .collect();
        assert!(dark.len() > 50, "no ink");
        assert!(dark.iter().all(|&(x, y)| (9..=(11 + w as u32)).contains(&x) && (4..=30).contains(&y)));
    }

    #[test]
    fn crop_magnify_and_blit_keep_pixels() {
        let mut c = Canvas::new(4, 3, BLACK);
        c.set(1, 2, [10, 20, 30]);
        let m = c.magnified(3);
        assert_eq!((m.width, m.height), (12, 9));
        assert_eq!(m.get(4, 7), [10, 20, 30]);
        assert_eq!(c.crop(1, 1, 10, 10).get(0, 1), [10, 20, 30]);
        let mut big = Canvas::new(10, 10, WHITE);
        big.blit(5, 5, &c);
        assert_eq!(big.get(6, 7), [10, 20, 30]);
        assert_eq!(big.get(4, 4), WHITE);
    }
}
