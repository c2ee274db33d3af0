//! The `dispersion` scene, rendered by `distributed`, shows the hues of the lamp seen through the
//! dense-flint prism separated in order, blue on the side the prism's geometry predicts; rendered
//! in RGB the separation vanishes.
//!
//! Geometry (see the header of `scenes/dispersion.toml`): the lamp lies towards +x of the prism
//! (behind the slot in the right wall), and the camera rays that reach it enter the prism's
//! front-left face and are bent by ~70° towards +x, the side of the prism's base. The deviation
//! grows with the index, and the index of dense flint is larger for blue than for red. For a
//! camera ray of a short wavelength to end up on the lamp, it must therefore start out turned
//! further from the lamp, towards −x: the blue image of the lamp lies to the LEFT of the red one,
//! green in between.

use std::path::Path;
use vitrum::image::Image;
use vitrum::integrators;
use vitrum::render::{render, RenderOptions};
use vitrum::scene::{self, Scene, SpectralMode};

/// Render size: the prism's near face covers about a fifth of the image width.
const SIZE: u32 = 100;
const SPP: u32 = 64;

/// A pixel belongs to the lamp's image when one of its channels exceeds this radiance; the room
/// (lit by the ceiling light) stays below ~2, the lamp seen through the prism far above.
const LAMP: f32 = 8.0;

fn dispersion_scene() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/dispersion.toml");
    scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

fn render_with(scene: &Scene, spectral: SpectralMode) -> (Image, bool) {
    let distributed = integrators::create("distributed").unwrap();
    let opts =
        RenderOptions { resolution: Some((SIZE, SIZE)), spectral, ..RenderOptions::from_scene(scene, SPP) };
    let out = render(scene, distributed.as_ref(), &opts, &|_, _| {});
    assert_eq!(out.non_finite_samples, 0);
    (out.image, out.spectral)
}

/// What the test measures on one image.
#[derive(Debug)]
struct Spectrum {
    /// Pixels of the lamp's image.
    pixels: usize,
    /// Leftmost and rightmost column of the lamp's image.
    columns: (usize, usize),
    /// Centroids (pixel columns) of the red, green and blue channels over the lamp's image, each
    /// weighted by that channel's (positive) radiance.
    centroid: [f64; 3],
}

impl Spectrum {
    fn measure(image: &Image) -> Spectrum {
        let mut sums = [0f64; 3];
        let mut moments = [0f64; 3];
        let mut pixels = 0;
        let mut columns = (usize::MAX, 0);
        for y in 0..image.height {
            for x in 0..image.width {
                let p = image.get(x, y);
                if p.max_element() < LAMP {
                    continue;
                }
                pixels += 1;
                columns = (columns.0.min(x), columns.1.max(x));
                for (c, value) in p.to_array().into_iter().enumerate() {
                    // Single-wavelength samples carry negative channels (monochromatic light is
                    // outside the sRGB gamut); count only the positive light of each channel.
                    let w = value.max(0.0) as f64;
                    sums[c] += w;
                    moments[c] += w * (x as f64 + 0.5);
                }
            }
        }
        assert!(pixels > 0, "the lamp is not visible through the prism");
        let centroid = [0, 1, 2].map(|c| moments[c] / sums[c]);
        Spectrum { pixels, columns, centroid }
    }

    /// Blue centroid minus red centroid, in pixels (negative: blue to the left).
    fn blue_minus_red(&self) -> f64 {
        self.centroid[2] - self.centroid[0]
    }
}

#[test]
fn the_prism_separates_the_hues_in_order_and_rgb_mode_does_not() {
    let scene = dispersion_scene();
    assert!(scene.effects.names().contains("dispersion"));

    let (spectral_image, spectral) = render_with(&scene, SpectralMode::Auto);
    assert!(spectral, "auto mode must trace wavelengths in a dispersive scene");
    let on = Spectrum::measure(&spectral_image);

    let (rgb_image, spectral) = render_with(&scene, SpectralMode::Off);
    assert!(!spectral);
    let off = Spectrum::measure(&rgb_image);
    eprintln!("spectral: {on:?}\nrgb:      {off:?}");

    // The lamp's image lies on the prism's near face, left of the image centre (the prism's
    // centre is the image centre; its front-left face is its left half).
    let centre = SIZE as usize / 2;
    assert!(on.columns.1 <= centre, "{on:?}");

    // Spectral: in order from left to right, blue, green, red, and well apart. At 100 pixels the
    // band is ~20 columns wide; its red and blue halves lie several columns apart.
    let [r, g, b] = on.centroid;
    assert!(b < g && g < r, "hues out of order (expected blue < green < red): {on:?}");
    assert!(on.blue_minus_red() < -4.0, "blue and red barely separated: {on:?}");

    // RGB: the lamp is one white line; its channels coincide, so there is no separation...
    assert!(off.blue_minus_red().abs() < 0.25, "RGB render separates hues: {off:?}");
    // ...and the line is much narrower than the spectrum.
    let width = |s: &Spectrum| s.columns.1 - s.columns.0 + 1;
    assert!(width(&off) * 2 < width(&on), "spectral {on:?}, RGB {off:?}");
    assert!(off.pixels * 2 < on.pixels, "spectral {on:?}, RGB {off:?}");
}
