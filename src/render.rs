//! The camera-pass driver: every pixel's samples in parallel, deterministic at any thread count.
//!
//! A camera sample draws, in this order and only when the scene calls for the effect and the
//! integrator simulates it: the position in the pixel, a point on the lens, a time in the
//! shutter interval and a wavelength. Everything else is up to the integrator.

use crate::camera::Camera;
use crate::image::Image;
use crate::integrators::{Integrator, PathContext, RenderParams};
use crate::sampler::{Dim, Sampler, SamplerKind, DIM_PURPOSES};
use crate::scene::effects::Support;
use crate::scene::{Effect, Scene, SpectralMode};
use crate::spectrum::sample_wavelength;
use crate::stats::RayCounts;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
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
    /// When to render spectrally.
    pub spectral: SpectralMode,
    /// Sample distribution.
    pub sampler: SamplerKind,
}

impl RenderOptions {
    /// Options for `spp` samples with the scene's own settings.
    pub fn from_scene(scene: &Scene, spp: u32) -> RenderOptions {
        let s = &scene.settings;
        let integrator = crate::integrators::create(&s.integrator).expect("compile checked the name");
        RenderOptions {
            budget: Budget::Samples(spp),
            resolution: None,
            seed: s.seed,
            params: RenderParams {
                max_depth: s.max_depth.unwrap_or(integrator.default_max_depth()),
                reflectance: s.reflectance,
                ssaa: s.ssaa,
            },
            spectral: s.spectral,
            sampler: s.sampler,
        }
    }
}

/// A finished render.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// Mean radiance per pixel.
    pub image: Image,
    /// Samples per pixel actually taken (the mean, for adaptive methods).
    pub spp: u32,
    /// Wall-clock seconds of the render (excluding scene loading and output).
    pub seconds: f64,
    /// Rays traced, by kind.
    pub rays: RayCounts,
    /// Samples whose radiance was NaN or infinite (kept in the image, never hidden).
    pub non_finite_samples: u64,
    /// Whether wavelengths were traced.
    pub spectral: bool,
    /// Camera samples taken per pixel, when it varies (adaptive supersampling).
    pub samples_per_pixel: Option<Vec<f32>>,
}

/// The camera for a render, with the resolution override applied.
pub fn camera_for(scene: &Scene, resolution: Option<(u32, u32)>) -> Camera {
    match resolution {
        Some((w, h)) => scene.camera.clone().with_resolution(w, h),
        None => scene.camera.clone(),
    }
}

/// Which camera-sample dimensions a render draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CameraDims {
    /// A lens point (depth of field).
    pub lens: bool,
    /// A shutter time (motion blur).
    pub time: bool,
    /// A wavelength (spectral rendering).
    pub wavelength: bool,
}

impl CameraDims {
    /// The dimensions for `scene` rendered by `integrator`: an effect costs a dimension only
    /// when the scene calls for it and the integrator simulates it.
    pub fn resolve(scene: &Scene, integrator: &dyn Integrator, spectral: SpectralMode) -> CameraDims {
        let active = |e: Effect| scene.effects.has(e) && integrator.support(e) == Support::Simulates;
        CameraDims {
            lens: active(Effect::DepthOfField),
            time: active(Effect::MotionBlur),
            wavelength: match spectral {
                SpectralMode::Auto => active(Effect::Dispersion),
                SpectralMode::On => true,
                SpectralMode::Off => false,
            },
        }
    }
}

/// Sums of one row over a range of samples.
struct RowSums {
    sums: Vec<Vec3>,
    rays: RayCounts,
    non_finite: u64,
    requests: [u64; DIM_PURPOSES],
}

/// Everything fixed during one camera pass.
struct Pass<'a> {
    scene: &'a Scene,
    integrator: &'a dyn Integrator,
    camera: Camera,
    opts: &'a RenderOptions,
    dims: CameraDims,
}

impl Pass<'_> {
    /// One camera sample of pixel (`x`, `y`): its radiance, with its rays and sampler requests.
    fn sample(&self, x: u32, y: u32, index: u32, total: u32, row: &mut RowSums) -> Vec3 {
        let pixel = y as u64 * self.camera.width as u64 + x as u64;
        let mut sampler = Sampler::new(self.opts.sampler, self.opts.seed, pixel, index, total);
        let offset = if total == 1 { Vec2::splat(0.5) } else { sampler.get_2d(Dim::Pixel) };
        let lens = if self.dims.lens { sampler.get_2d(Dim::Lens) } else { Vec2::ZERO };
        let (open, close) = self.camera.shutter;
        let time = if self.dims.time { open + (close - open) * sampler.get_1d(Dim::Time) } else { open };
        let mut ctx = PathContext::new(sampler);
        let mut weight = Vec3::ONE;
        if self.dims.wavelength {
            let w = sample_wavelength(ctx.sampler.get_1d(Dim::Wavelength));
            ctx.lambda = Some(w.lambda);
            weight = w.weight;
        }
        let ray = self.camera.generate_ray_lens(Vec2::new(x as f32, y as f32) + offset, lens, time);
        ctx.rays.primary += 1;
        let l = weight * self.integrator.radiance(self.scene, &self.opts.params, &ray, &mut ctx);
        row.rays += ctx.rays;
        for (total, d) in row.requests.iter_mut().zip(ALL_DIMS) {
            *total += ctx.sampler.requests(d) as u64;
        }
        l
    }

    fn row(&self, y: u32, samples: std::ops::Range<u32>, total: u32) -> RowSums {
        let mut row = RowSums {
            sums: vec![Vec3::ZERO; self.camera.width as usize],
            rays: RayCounts::default(),
            non_finite: 0,
            requests: [0; DIM_PURPOSES],
        };
        for x in 0..self.camera.width {
            let mut sum = Vec3::ZERO;
            for s in samples.clone() {
                let l = self.sample(x, y, s, total, &mut row);
                if !l.is_finite() {
                    row.non_finite += 1;
                }
                sum += l;
            }
            row.sums[x as usize] = sum;
        }
        row
    }
}

const ALL_DIMS: [Dim; DIM_PURPOSES] =
    [Dim::Pixel, Dim::Lens, Dim::Time, Dim::Wavelength, Dim::Light, Dim::Bsdf, Dim::Other];

/// Counts of sampler requests per purpose over a whole render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DimensionRequests(pub [u64; DIM_PURPOSES]);

impl DimensionRequests {
    /// Requests made for `purpose`.
    pub fn get(&self, purpose: Dim) -> u64 {
        self.0[purpose as usize]
    }
}

/// Render `scene` with `integrator`; `progress` is called with (rows done, rows total) of the
/// current pass, from worker threads.
pub fn render(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> RenderOutput {
    if let Some(out) = integrator.render_image(scene, opts, progress) {
        return out;
    }
    camera_pass(scene, integrator, opts, progress).0
}

/// The shared camera pass, with the sampler requests it made per purpose.
pub fn camera_pass(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> (RenderOutput, DimensionRequests) {
    let pass = Pass {
        scene,
        integrator,
        camera: camera_for(scene, opts.resolution),
        opts,
        dims: CameraDims::resolve(scene, integrator, opts.spectral),
    };
    let (w, h) = (pass.camera.width as usize, pass.camera.height as usize);
    let start = Instant::now();
    let mut sums = vec![Vec3::ZERO; w * h];
    let mut rays = RayCounts::default();
    let mut non_finite = 0;
    let mut requests = DimensionRequests::default();
    let (passes, total): (Box<dyn Iterator<Item = std::ops::Range<u32>>>, u32) = match opts.budget {
        Budget::Samples(n) => (Box::new(std::iter::once(0..n)), n),
        // The sample count is unknown in advance: no stratification across passes.
        Budget::Time(_) => (Box::new((0..).map(|i| i..i + 1)), 0),
    };
    let mut spp = 0;
    let done = AtomicU64::new(0);
    for samples in passes {
        done.store(0, Ordering::Relaxed);
        let rows: Vec<RowSums> = (0..h as u32)
            .into_par_iter()
            .map(|y| {
                let r = pass.row(y, samples.clone(), total);
                progress(done.fetch_add(1, Ordering::Relaxed) + 1, h as u64);
                r
            })
            .collect();
        for (y, row) in rows.into_iter().enumerate() {
            for (acc, s) in sums[y * w..(y + 1) * w].iter_mut().zip(&row.sums) {
                *acc += *s;
            }
            rays += row.rays;
            non_finite += row.non_finite;
            for (a, b) in requests.0.iter_mut().zip(row.requests) {
                *a += b;
            }
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
    let out = RenderOutput {
        image,
        spp,
        seconds: start.elapsed().as_secs_f64(),
        rays,
        non_finite_samples: non_finite,
        spectral: pass.dims.wavelength,
        samples_per_pixel: None,
    };
    (out, requests)
}
