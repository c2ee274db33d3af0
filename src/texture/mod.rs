//! Textures: how a colour of a material varies over a surface — one colour, a checkerboard in
//! space, or an image addressed by the surface's texture coordinates.

mod image_map;

pub use image_map::{srgb_to_linear, ColorSpace, Filter, ImageMap, Wrap};

use crate::lanes::{Real, Vector};
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// An image placed on a surface: texture coordinates `uv` read the image at `uv · scale + offset`.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageTexture {
    /// The texels (shared by every texture that reads the same file).
    pub map: Arc<ImageMap>,
    /// Repetitions of the image per unit of uv, along u and v.
    pub scale: Vec2,
    /// Shift of the image in units of the image, added after `scale`.
    pub offset: Vec2,
    /// What lookups outside the image read.
    pub wrap: Wrap,
    /// How texels are combined.
    pub filter: Filter,
}

impl ImageTexture {
    /// The colour at texture coordinates `uv`. Never inlined: it keeps [`Texture::eval`] small
    /// enough to inline into the BSDF set-up of every hit, which untextured scenes must not pay
    /// for (measured: 2.4% more instructions for `path` on `soft-shadows` when it was inlined).
    #[inline(never)]
    pub fn lookup(&self, uv: Vec2) -> Vec3 {
        self.map.lookup(uv * self.scale + self.offset, self.wrap, self.filter)
    }
}

/// How a colour varies over a surface.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    /// One colour everywhere.
    Constant(Vec3),
    /// A 3-D checkerboard with cells of side `size` (the thesis's floor).
    Checker {
        /// Colour of the cells whose index sum is even.
        color1: Vec3,
        /// Colour of the other cells.
        color2: Vec3,
        /// Cell edge length in scene units.
        size: f32,
    },
    /// An image addressed by the surface's texture coordinates.
    Image(ImageTexture),
}

/// A 3-D checker of cell size `size` at `p`, for one point or across lanes: `color1` where the
/// cell's indices sum to an even number, `color2` elsewhere.
#[inline(always)]
pub fn checker<V: Vector>(p: V, size: V::Real, color1: V, color2: V) -> V {
    // A tiny bias keeps points on cell boundaries (walls, floors at integer multiples of
    // `size`) from flickering between cells.
    let cell = (p / size + V::splat(Vec3::splat(1e-4))).floor();
    V::select(V::Real::even_sum(cell.x(), cell.y(), cell.z()), color1, color2)
}

impl Texture {
    /// The colour at world point `p` with surface texture coordinates `uv`.
    #[inline]
    pub fn eval(&self, p: Vec3, uv: Vec2) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Checker { color1, color2, size } => checker(p, *size, *color1, *color2),
            Texture::Image(image) => image.lookup(uv),
        }
    }

    /// The colour when it is the same everywhere, else `None`.
    pub fn constant(&self) -> Option<Vec3> {
        match self {
            Texture::Constant(c) => Some(*c),
            _ => None,
        }
    }

    /// The largest value any channel takes anywhere (bounds the Phong highlight weight and
    /// tells whether a texture is black).
    pub fn max_value(&self) -> f32 {
        match self {
            Texture::Constant(c) => c.max_element(),
            Texture::Checker { color1, color2, .. } => color1.max_element().max(color2.max_element()),
            Texture::Image(image) => image.map.texels.iter().fold(0.0f32, |m, t| m.max(t.max_element())),
        }
    }

    /// The mean colour: a checker's two colours equally, an image's texels equally (the mean over
    /// the surface where its uv is uniform over the area, as on a quad).
    pub fn mean(&self) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Checker { color1, color2, .. } => 0.5 * (*color1 + *color2),
            Texture::Image(image) => {
                let texels = &image.map.texels;
                texels.iter().sum::<Vec3>() / texels.len().max(1) as f32
            }
        }
    }

    /// Whether the colour depends on where on the surface it is read.
    pub fn varies(&self) -> bool {
        !matches!(self, Texture::Constant(_))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checker_alternates_and_is_stable_on_cell_boundaries() {
        let t = Texture::Checker { color1: Vec3::ONE, color2: Vec3::ZERO, size: 0.5 };
        let uv = Vec2::ZERO;
        assert_eq!(t.eval(Vec3::new(0.25, 0.0, 0.25), uv), Vec3::ONE);
        assert_eq!(t.eval(Vec3::new(0.75, 0.0, 0.25), uv), Vec3::ZERO);
        assert_eq!(t.eval(Vec3::new(-0.25, 0.0, 0.25), uv), Vec3::ZERO);
        // a floor at y = 0 (a cell boundary) and one a hair below it read the same cell
        assert_eq!(t.eval(Vec3::new(0.25, 0.0, 0.25), uv), t.eval(Vec3::new(0.25, -1e-6, 0.25), uv));
    }

    #[test]
    fn image_texture_scale_and_offset() {
        let map = Arc::new(ImageMap {
            width: 2,
            height: 1,
            texels: vec![Vec3::X, Vec3::Y],
            file: "t".into(),
            colorspace: ColorSpace::Linear,
        });
        let t = ImageTexture {
            map,
            scale: Vec2::new(2.0, 1.0),
            offset: Vec2::new(0.5, 0.0),
            wrap: Wrap::Repeat,
            filter: Filter::Nearest,
        };
        // u = 0.1 → s = 0.7: the right texel; u = 0.3 → s = 1.1 ≡ 0.1: the left one.
        assert_eq!(t.lookup(Vec2::new(0.1, 0.5)), Vec3::Y);
        assert_eq!(t.lookup(Vec2::new(0.3, 0.5)), Vec3::X);
        let texture = Texture::Image(t);
        assert_eq!(texture.eval(Vec3::splat(9.0), Vec2::new(0.3, 0.5)), Vec3::X);
        assert_eq!(texture.max_value(), 1.0);
        assert_eq!(texture.mean(), Vec3::new(0.5, 0.5, 0.0));
        assert!(texture.varies() && texture.constant().is_none());
    }
}
