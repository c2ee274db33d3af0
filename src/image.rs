//! A linear HDR RGB image in memory, and the size limit on every image file vitrum reads
//! ([`limits`]).

pub mod limits;

use glam::Vec3;

/// Linear, scene-referred RGB pixels in row-major order, pixel (0,0) at the top left.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width * height` pixels, row by row from the top.
    pub pixels: Vec<Vec3>,
}

impl Image {
    /// A black image.
    pub fn new(width: usize, height: usize) -> Image {
        Image { width, height, pixels: vec![Vec3::ZERO; width * height] }
    }

    /// The pixel at column `x`, row `y`.
    pub fn get(&self, x: usize, y: usize) -> Vec3 {
        self.pixels[y * self.width + x]
    }

    /// How many pixels have a NaN or infinite channel.
    pub fn non_finite_count(&self) -> usize {
        self.pixels.iter().filter(|p| !p.is_finite()).count()
    }
}
