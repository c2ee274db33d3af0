//! Adaptive supersampling against the regular grid of the same maximum density.

use vitrum::image::Image;
use vitrum::integrators::{create, SsaaParams};
use vitrum::render::{render, RenderOptions, RenderOutput};
use vitrum::scene::load_default;

const SIDE: u32 = 64;

fn ssaa(ssaa: SsaaParams) -> RenderOutput {
    let scene = load_default();
    let mut opts = RenderOptions { resolution: Some((SIDE, SIDE)), ..RenderOptions::from_scene(&scene, 1) };
    opts.params.ssaa = ssaa;
    render(&scene, create("ssaa").unwrap().as_ref(), &opts, &|_, _| {})
}

fn mse(a: &Image, b: &Image) -> f64 {
    let n = (a.pixels.len() * 3) as f64;
    a.pixels.iter().zip(&b.pixels).map(|(x, y)| (*x - *y).length_squared() as f64).sum::<f64>() / n
}

#[test]
fn adaptive_uses_fewer_rays_than_the_grid_of_equal_density_at_comparable_error() {
    let reference = ssaa(SsaaParams { adaptive: false, grid: 16, ..SsaaParams::default() });
    // The default: the thesis's single 3×3 subdivision, samples 1/3 pixel apart like a 3×3 grid.
    let adaptive = ssaa(SsaaParams::default());
    let params = SsaaParams::default();
    assert!(params.adaptive && params.levels == 1);
    let grid = ssaa(SsaaParams { adaptive: false, grid: 3, ..SsaaParams::default() });
    let (e_grid, e_adaptive) = (mse(&grid.image, &reference.image), mse(&adaptive.image, &reference.image));
    println!(
        "grid 3x3: {} primary rays, MSE {e_grid:.3e}; adaptive: {} primary rays, MSE {e_adaptive:.3e}",
        grid.rays.primary, adaptive.rays.primary
    );
    assert!(adaptive.rays.primary < grid.rays.primary);
    assert!(adaptive.rays.total() < grid.rays.total());
    assert!(e_adaptive <= 1.25 * e_grid, "{e_adaptive} vs {e_grid}");
    // The per-pixel counts add up to the primary rays (pixel corners are shared by four pixels).
    let counts = adaptive.samples_per_pixel.unwrap();
    let corners = ((SIDE + 1) * (SIDE + 1)) as f32;
    let own: f32 = counts.iter().map(|c| c - 1.0).sum();
    assert!((own + corners - adaptive.rays.primary as f32).abs() < 0.5);
    // Some pixels were subdivided (12 new points each), most were not.
    assert!(counts.iter().all(|&c| c == 1.0 || c == 13.0));
    let split = counts.iter().filter(|&&c| c == 13.0).count();
    assert!(split > 0 && split < counts.len() / 2, "{split} of {} pixels split", counts.len());
}

#[test]
fn a_contrast_threshold_of_zero_splits_every_pixel_with_any_variation() {
    let all = ssaa(SsaaParams { threshold: 0.0, ..SsaaParams::default() });
    let some = ssaa(SsaaParams::default());
    let split = |o: &RenderOutput| o.samples_per_pixel.as_ref().unwrap().iter().filter(|&&c| c > 1.0).count();
    assert!(split(&all) > split(&some));
    assert!(all.rays.primary > some.rays.primary);
}
