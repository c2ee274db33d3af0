//! Supersampled antialiasing over Whitted radiance, on a regular grid or adaptively.
//!
//! The regular grid's points (the centres of n×n equal cells of [0, 1)²) go through the pixel
//! filter's inverse distribution like any camera sample ([`crate::camera::Camera::film_point`]):
//! a midpoint quadrature of the filter-weighted pixel (the box: the pixel's square). The adaptive
//! mode subdivides the pixel's square and so always estimates the box, whatever the filter.
//!
//! Adaptive mode follows the thesis (§ antialiasing): trace the four corners of a pixel; where
//! their colours differ by more than a contrast threshold, split the square into 3×3 sub-squares
//! (a 4×4 lattice of corner points, 12 of them new) and repeat on every sub-square, up to a
//! maximum level. A square that is not split takes the mean of its corners. Pixel corners are
//! traced once for the whole image and shared by the four pixels that meet there; points on a
//! pixel's edges below the top level are traced by each pixel that needs them.
//!
//! Contrast is Mitchell's per channel, (max − min) / (max + min), over the square's corners.
//! The default is the thesis's single subdivision (at most 16 rays per pixel) with threshold
//! 0.1. Deeper levels save more rays but, since an unsplit square is estimated from its corners
//! alone, lose accuracy faster than a regular grid of the same spacing (docs/methods.md, the `ssaa` row).

use super::whitted::{deterministic_support, trace, Sampling, Segment};
use super::{FixedImage, Integrator, Method, PathContext, RenderParams};
use crate::camera::Camera;
use crate::image::Image;
use crate::render::{camera_for, Progression, RenderOptions, RenderOutput};
use crate::sampler::Sampler;
use crate::scene::effects::Support;
use crate::scene::{Effect, Scene};
use crate::stats::RayCounts;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::time::Instant;

/// How many sub-squares per side one subdivision makes.
const SPLIT: usize = 3;

/// Supersampled Whitted ray tracing.
pub struct Ssaa;

impl Integrator for Ssaa {
    fn method(&self) -> Method {
        Method::Ssaa
    }

    fn support(&self, effect: Effect) -> Support {
        match effect {
            Effect::Dispersion => Support::Approximates(
                "refracts at the nominal index n_d: its fixed sample pattern has no wavelength to sample (--spectral is ignored)",
            ),
            _ => deterministic_support(effect),
        }
    }

    fn progression(&self) -> Progression<'_> {
        Progression::Fixed(self)
    }
}

impl FixedImage for Ssaa {
    fn why(&self) -> &'static str {
        "its sample pattern is set by --ssaa-mode/--ssaa-grid/--ssaa-levels, not by a sample count"
    }

    fn render(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> RenderOutput {
        let start = Instant::now();
        let camera = camera_for(scene, opts.resolution);
        let tracer = Tracer { scene, params: &opts.params, camera: &camera };
        // The crop window's pixels, at their places on the whole film.
        let (w, h) = (camera.crop.width as usize, camera.crop.height as usize);
        let (x0, y0) = (camera.crop.x as usize, camera.crop.y as usize);
        let done = std::sync::atomic::AtomicU64::new(0);
        let tick = || progress(done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1, h as u64);
        let ssaa = opts.params.ssaa;
        let mut rays = RayCounts::default();
        let rows: Vec<(Vec<Vec3>, Vec<f32>, RayCounts)> = if ssaa.adaptive {
            // Pixel corners, traced once: (w+1) × (h+1).
            let corners: Vec<(Vec<Vec3>, RayCounts)> = (0..=h)
                .into_par_iter()
                .map(|y| {
                    let mut rays = RayCounts::default();
                    let row = (0..=w)
                        .map(|x| tracer.at(Vec2::new((x0 + x) as f32, (y0 + y) as f32), &mut rays))
                        .collect();
                    (row, rays)
                })
                .collect();
            for (_, r) in &corners {
                rays += *r;
            }
            (0..h)
                .into_par_iter()
                .map(|y| {
                    let mut rays = RayCounts::default();
                    let mut counts = Vec::with_capacity(w);
                    let row = (0..w)
                        .map(|x| {
                            let c = [
                                corners[y].0[x],
                                corners[y].0[x + 1],
                                corners[y + 1].0[x],
                                corners[y + 1].0[x + 1],
                            ];
                            let mut traced = 0;
                            let origin = Vec2::new((x0 + x) as f32, (y0 + y) as f32);
                            let v = tracer.adaptive(
                                origin,
                                1.0,
                                c,
                                ssaa.levels,
                                ssaa.threshold,
                                &mut rays,
                                &mut traced,
                            );
                            // the four shared corners count a quarter each
                            counts.push(traced as f32 + 1.0);
                            v
                        })
                        .collect();
                    tick();
                    (row, counts, rays)
                })
                .collect()
        } else {
            let n = ssaa.grid as usize;
            (0..h)
                .into_par_iter()
                .map(|y| {
                    let mut rays = RayCounts::default();
                    let row = (0..w)
                        .map(|x| {
                            let mut sum = Vec3::ZERO;
                            for j in 0..n {
                                for i in 0..n {
                                    let offset =
                                        Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                                    let film = camera.film_point((x0 + x) as u32, (y0 + y) as u32, offset);
                                    sum += tracer.at(film, &mut rays);
                                }
                            }
                            sum / (n * n) as f32
                        })
                        .collect();
                    tick();
                    (row, vec![(n * n) as f32; w], rays)
                })
                .collect()
        };
        let mut pixels = Vec::with_capacity(w * h);
        let mut counts = Vec::with_capacity(w * h);
        for (row, c, r) in rows {
            pixels.extend(row);
            counts.extend(c);
            rays += r;
        }
        let non_finite = pixels.iter().filter(|p| !p.is_finite()).count() as u64;
        let spp = (counts.iter().sum::<f32>() / counts.len().max(1) as f32).round().max(1.0) as u32;
        RenderOutput {
            image: Image { width: w, height: h, pixels },
            spp,
            seconds: start.elapsed().as_secs_f64(),
            rays,
            non_finite_samples: non_finite,
            spectral: false,
            samples_per_pixel: Some(counts),
            // A fixed pattern (grid or contrast-driven subdivision): no sample variance.
            variance: None,
            replicas: None,
        }
    }
}

/// Whitted radiance at film positions.
struct Tracer<'a> {
    scene: &'a Scene,
    params: &'a RenderParams,
    camera: &'a Camera,
}

impl Tracer<'_> {
    /// Radiance through film position `film` (pixel units).
    fn at(&self, film: Vec2, rays: &mut RayCounts) -> Vec3 {
        // Whitted draws no random numbers; the stream exists only to satisfy the interface.
        let mut ctx = PathContext::new(Sampler::independent(0, 0, 0));
        let ray = self.camera.clip(self.camera.generate_ray(film));
        ctx.rays.primary += 1;
        let l = trace(self.scene, self.params, &ray, Segment::camera(), Sampling::Fixed, &mut ctx);
        *rays += ctx.rays;
        l
    }

    /// Mean radiance over the square at `origin` with side `size` whose corners (top-left,
    /// top-right, bottom-left, bottom-right) are `c`, subdividing up to `levels` more times.
    #[allow(clippy::too_many_arguments)]
    fn adaptive(
        &self,
        origin: Vec2,
        size: f32,
        c: [Vec3; 4],
        levels: u32,
        threshold: f32,
        rays: &mut RayCounts,
        traced: &mut u32,
    ) -> Vec3 {
        if levels == 0 || contrast(&c) <= threshold {
            return (c[0] + c[1] + c[2] + c[3]) * 0.25;
        }
        // The (SPLIT+1)² lattice of the square; its four corners are known.
        const N: usize = SPLIT + 1;
        let mut lattice = [[Vec3::ZERO; N]; N];
        for (j, row) in lattice.iter_mut().enumerate() {
            for (i, value) in row.iter_mut().enumerate() {
                *value = match (i, j) {
                    (0, 0) => c[0],
                    (SPLIT, 0) => c[1],
                    (0, SPLIT) => c[2],
                    (SPLIT, SPLIT) => c[3],
                    _ => {
                        *traced += 1;
                        let p = origin + Vec2::new(i as f32, j as f32) * (size / SPLIT as f32);
                        self.at(p, rays)
                    }
                };
            }
        }
        let sub = size / SPLIT as f32;
        let mut sum = Vec3::ZERO;
        for j in 0..SPLIT {
            for i in 0..SPLIT {
                let corners = [lattice[j][i], lattice[j][i + 1], lattice[j + 1][i], lattice[j + 1][i + 1]];
                let o = origin + Vec2::new(i as f32, j as f32) * sub;
                sum += self.adaptive(o, sub, corners, levels - 1, threshold, rays, traced);
            }
        }
        sum / (SPLIT * SPLIT) as f32
    }
}

/// Mitchell's contrast of the corners: the largest over channels of (max − min) / (max + min).
fn contrast(c: &[Vec3; 4]) -> f32 {
    let max = c[0].max(c[1]).max(c[2].max(c[3]));
    let min = c[0].min(c[1]).min(c[2].min(c[3]));
    ((max - min) / (max + min + Vec3::splat(1e-3))).max_element()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contrast_is_zero_for_equal_corners_and_one_for_black_against_white() {
        assert_eq!(contrast(&[Vec3::splat(0.5); 4]), 0.0);
        let c = contrast(&[Vec3::ZERO, Vec3::ONE, Vec3::ONE, Vec3::ONE]);
        assert!(c > 0.99 && c <= 1.0);
    }
}
