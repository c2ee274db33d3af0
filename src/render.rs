//! The camera-pass driver: every pixel's samples in parallel, deterministic at any thread count.

use crate::camera::Camera;
use crate::image::Image;
use crate::integrators::{Integrator, RenderParams};
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::stats::RayCounts;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// How long to render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// A fixed number of samples per pixel.
    Samples(u32),
    /// Whole 1-sample passes until this much time has passed (at least one pass).
    Time(Duration),
}

/// Everything a render needs besides the scene and the integrator.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Samples or time.
    pub budget: Budget,
    /// Image size override.
    pub resolution: Option<(u32, u32)>,
    /// Seed of the random streams.
    pub seed: u64,
    /// Integrator parameters.
    pub params: RenderParams,
}

/// A finished render.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// Mean radiance per pixel.
    pub image: Image,
    /// Samples per pixel actually taken.
    pub spp: u32,
    /// Wall-clock seconds of the render (excluding scene loading and output).
    pub seconds: f64,
    /// Rays traced, by kind.
    pub rays: RayCounts,
    /// Samples whose radiance was NaN or infinite (kept in the image, never hidden).
    pub non_finite_samples: u64,
}

/// The camera for a render, with the resolution override applied.
pub fn camera_for(scene: &Scene, resolution: Option<(u32, u32)>) -> Camera {
    let c = &scene.camera;
    match resolution {
        Some((w, h)) => Camera::new(c.position, c.position + c.forward, c.up, c.fov_degrees, w, h)
            .expect("a valid camera stays valid at another resolution"),
        None => c.clone(),
    }
}

/// Film position of sample `index` in pixel (`x`, `y`): the pixel centre for a single
/// sample, uniform random positions otherwise.
fn film_position(x: u32, y: u32, index: u32, total: u32, sampler: &mut Sampler) -> Vec2 {
    let offset = if total == 1 && index == 0 { Vec2::splat(0.5) } else { sampler.next_2d() };
    Vec2::new(x as f32, y as f32) + offset
}

/// Sums of one row over a range of samples.
struct RowSums {
    sums: Vec<Vec3>,
    rays: RayCounts,
    non_finite: u64,
}

fn render_row(
    scene: &Scene,
    integrator: &dyn Integrator,
    camera: &Camera,
    opts: &RenderOptions,
    y: u32,
    samples: std::ops::Range<u32>,
    total: u32,
) -> RowSums {
    let mut row =
        RowSums { sums: vec![Vec3::ZERO; camera.width as usize], rays: RayCounts::default(), non_finite: 0 };
    for x in 0..camera.width {
        let pixel = y as u64 * camera.width as u64 + x as u64;
        let mut sum = Vec3::ZERO;
        for s in samples.clone() {
            let mut sampler = Sampler::new(opts.seed, pixel, s as u64);
            let ray = camera.generate_ray(film_position(x, y, s, total, &mut sampler));
            row.rays.primary += 1;
            let l = integrator.radiance(scene, &opts.params, &ray, &mut sampler, &mut row.rays);
            if !l.is_finite() {
                row.non_finite += 1;
            }
            sum += l;
        }
        row.sums[x as usize] = sum;
    }
    row
}

/// Render `scene` with `integrator`; `progress` is called with (rows done, rows total) of the
/// current pass, from worker threads.
pub fn render(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> RenderOutput {
    let camera = camera_for(scene, opts.resolution);
    let (w, h) = (camera.width as usize, camera.height as usize);
    let start = Instant::now();
    let mut sums = vec![Vec3::ZERO; w * h];
    let mut rays = RayCounts::default();
    let mut non_finite = 0;
    let passes: Box<dyn Iterator<Item = std::ops::Range<u32>>> = match opts.budget {
        Budget::Samples(n) => Box::new(std::iter::once(0..n)),
        Budget::Time(_) => Box::new((0..).map(|i| i..i + 1)),
    };
    let total = match opts.budget {
        Budget::Samples(n) => n,
        Budget::Time(_) => u32::MAX,
    };
    let mut spp = 0;
    let done = std::sync::atomic::AtomicU64::new(0);
    for samples in passes {
        done.store(0, std::sync::atomic::Ordering::Relaxed);
        let rows: Vec<RowSums> = (0..h as u32)
            .into_par_iter()
            .map(|y| {
                let r = render_row(scene, integrator, &camera, opts, y, samples.clone(), total);
                let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                progress(n, h as u64);
                r
            })
            .collect();
        for (y, row) in rows.into_iter().enumerate() {
            for (acc, s) in sums[y * w..(y + 1) * w].iter_mut().zip(&row.sums) {
                *acc += *s;
            }
            rays += row.rays;
            non_finite += row.non_finite;
        }
        spp = samples.end;
        if let Budget::Time(limit) = opts.budget {
            if start.elapsed() >= limit {
                break;
            }
        }
    }
    let inv = 1.0 / spp as f32;
    let image = Image { width: w, height: h, pixels: sums.into_iter().map(|s| s * inv).collect() };
    RenderOutput { image, spp, seconds: start.elapsed().as_secs_f64(), rays, non_finite_samples: non_finite }
}
