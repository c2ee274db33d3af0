//! The camera pass: the camera-sample dimensions a render draws ([`CameraDims`]) and one pass of
//! sample indices over every pixel, rows in parallel.

use super::*;
use crate::camera::Camera;
use crate::geometry::Ray;
use crate::sampler::{Dim, Replicas, Sampler, DIM_PURPOSES};
use crate::scene::effects::Support;
use crate::scene::{Effect, Scene, SpectralMode};
use crate::spectrum::{Channels, Wavelengths};
use crate::stats::RayCounts;
use glam::{DVec3, Vec2, Vec3};
use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};

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

/// Counters of one row over a range of samples.
pub(super) struct RowStats {
    pub(super) rays: RayCounts,
    pub(super) non_finite: u64,
    pub(super) requests: [u64; DIM_PURPOSES],
}

impl RowStats {
    /// Adds the estimate `l` of sample index `s` to its pixel's sums (`sum`, and `replica_sums`
    /// of its replicas), counting it if it is not finite.
    #[inline]
    fn add(&mut self, l: Vec3, s: u32, replicas: Replicas, sum: &mut DVec3, replica_sums: &mut [DVec3]) {
        if !l.is_finite() {
            self.non_finite += 1;
        }
        let l = l.as_dvec3();
        *sum += l;
        replica_sums[replicas.of(s) as usize] += l;
    }
}

/// Everything fixed during camera passes.
pub(super) struct Pass<'a> {
    pub(super) scene: &'a Scene,
    /// The method's radiance per camera ray.
    pub(super) estimator: &'a dyn CameraEstimator,
    pub(super) camera: Camera,
    pub(super) opts: RenderOptions,
    pub(super) dims: CameraDims,
    /// The engine that traces the camera paths.
    pub(super) engine: EngineChoice,
}

/// The most camera paths the wavefront engine advances together (whole pixels' samples; at least
/// one pixel's): enough that batches of 16 stay full as paths end, few enough that their states
/// stay in the cache.
pub const WAVEFRONT_BATCH: usize = 1024;

impl<'a> Pass<'a> {
    /// The camera passes of `integrator`, whose radiance per camera ray is `estimator`, over
    /// `scene` with `opts`.
    pub(super) fn new(
        scene: &'a Scene,
        integrator: &dyn Integrator,
        estimator: &'a dyn CameraEstimator,
        opts: &RenderOptions,
    ) -> Pass<'a> {
        Pass {
            scene,
            estimator,
            camera: camera_for(scene, opts.resolution),
            opts: opts.clone(),
            dims: CameraDims::resolve(scene, integrator, opts.spectral),
            engine: estimator.engine(scene, opts),
        }
    }

    /// An empty film of the size of the camera's crop window.
    pub(super) fn film(&self) -> Film {
        let (w, h) = (self.camera.crop.width as usize, self.camera.crop.height as usize);
        Film::new(w, h, 1.0, self.dims.wavelength, self.opts.replicas)
    }

    /// The camera ray of sample `index` (of `total`) of the film's pixel (`x`, `y`), with the
    /// context of its path: the sample's stream after the camera's dimensions, its channels and
    /// counters. A single sample per pixel goes through the pixel's centre; more are placed by
    /// the pixel filter ([`Camera::film_point`]).
    pub(super) fn start(&self, x: u32, y: u32, index: u32, total: u32) -> (Ray, PathContext) {
        let pixel = y as u64 * self.camera.width as u64 + x as u64;
        let stream = self.opts.replicas.stream(self.opts.seed, index, total);
        let mut sampler = Sampler::of_stream(self.opts.sampler, stream, pixel);
        let film = if total == 1 {
            Vec2::new(x as f32, y as f32) + Vec2::splat(0.5)
        } else {
            self.camera.film_point(x, y, sampler.get_2d(Dim::Pixel))
        };
        let lens = if self.dims.lens { sampler.get_2d(Dim::Lens) } else { Vec2::ZERO };
        let (open, close) = self.camera.shutter;
        let time = if self.dims.time { open + (close - open) * sampler.get_1d(Dim::Time) } else { open };
        let mut ctx = PathContext::new(sampler);
        if self.dims.wavelength {
            ctx.channels = Channels::Spectral(Wavelengths::sample(ctx.sampler.get_1d(Dim::Wavelength)));
        }
        let ray = self.camera.generate_ray_lens(film, lens, time);
        ctx.rays.primary += 1;
        (ray, ctx)
    }

    /// The RGB estimate of a sample whose path (context `ctx`) gathered `radiance`, its rays and
    /// sampler requests counted in `row`.
    pub(super) fn finish(&self, ctx: &PathContext, radiance: Vec3, row: &mut RowStats) -> Vec3 {
        row.rays += ctx.rays;
        for (total, d) in row.requests.iter_mut().zip(ALL_DIMS) {
            *total += ctx.sampler.requests(d) as u64;
        }
        ctx.channels.to_rgb(radiance)
    }

    /// One camera sample of pixel (`x`, `y`) by the one-ray engine: its radiance, with its rays
    /// and sampler requests.
    pub(super) fn sample(&self, x: u32, y: u32, index: u32, total: u32, row: &mut RowStats) -> Vec3 {
        let (ray, mut ctx) = self.start(x, y, index, total);
        let radiance = self.estimator.radiance(self.scene, &self.opts.params, &ray, &mut ctx);
        self.finish(&ctx, radiance, row)
    }

    /// Continues the sums of the film's row `y` (`sums`: per pixel of the crop window, the sum
    /// and the replicas' sums) with the samples `samples` (of `total`) by the batch engine:
    /// its paths go in batches of at most [`WAVEFRONT_BATCH`] whole pixels' samples, whose
    /// estimates are added pixel by pixel in sample order, as the one-ray loop adds them.
    fn wavefront_row(
        &self,
        engine: &dyn BatchEngine,
        y: u32,
        (sum, replica_sums): (&mut [DVec3], &mut [DVec3]),
        samples: Range<u32>,
        total: u32,
        row: &mut RowStats,
    ) {
        let replicas = self.opts.replicas;
        let r = replicas.count() as usize;
        let width = sum.len();
        let per_pixel = samples.len().max(1);
        let pixels_per_batch = (WAVEFRONT_BATCH / per_pixel).max(1);
        let batch = pixels_per_batch.min(width) * per_pixel;
        let (mut rays, mut ctxs) = (Vec::with_capacity(batch), Vec::with_capacity(batch));
        let x0 = self.camera.crop.x;
        for first in (0..width).step_by(pixels_per_batch) {
            let xs = x0 + first as u32..x0 + (first + pixels_per_batch).min(width) as u32;
            rays.clear();
            ctxs.clear();
            for x in xs.clone() {
                for s in samples.clone() {
                    let (ray, ctx) = self.start(x, y, s, total);
                    rays.push(ray);
                    ctxs.push(ctx);
                }
            }
            let radiance = engine.estimate_rays(self.scene, &self.opts.params, &rays, &mut ctxs);
            let estimates: Vec<Vec3> =
                ctxs.iter().zip(radiance).map(|(ctx, l)| self.finish(ctx, l, row)).collect();
            let first = (xs.start - x0) as usize;
            let pixels = sum[first..].iter_mut().zip(replica_sums[first * r..].chunks_mut(r));
            for ((sum, replica_sums), pixel) in pixels.zip(estimates.chunks(samples.len())) {
                for (&l, s) in pixel.iter().zip(samples.clone()) {
                    row.add(l, s, replicas, sum, replica_sums);
                }
            }
        }
    }

    /// Continue the sums of the film's row `y` (`sum` per pixel of the crop window,
    /// `replica_sums` per pixel and replica) with the samples `samples` (of `total`, 0 when
    /// unknown).
    pub(super) fn row(
        &self,
        y: u32,
        samples: Range<u32>,
        total: u32,
        sum: &mut [DVec3],
        replica_sums: &mut [DVec3],
    ) -> RowStats {
        let mut row = RowStats { rays: RayCounts::default(), non_finite: 0, requests: [0; DIM_PURPOSES] };
        if let Some(engine) = &self.engine.wavefront {
            self.wavefront_row(engine.as_ref(), y, (sum, replica_sums), samples, total, &mut row);
            return row;
        }
        let replicas = self.opts.replicas;
        let r = replicas.count() as usize;
        let x0 = self.camera.crop.x;
        for (x, (sum, replica_sums)) in sum.iter_mut().zip(replica_sums.chunks_mut(r)).enumerate() {
            for s in samples.clone() {
                let l = self.sample(x0 + x as u32, y, s, total, &mut row);
                row.add(l, s, replicas, sum, replica_sums);
            }
        }
        row
    }

    /// Add the samples `samples` (of `total` planned, 0 when unknown) to every pixel of `film`
    /// (the camera's crop window).
    pub(super) fn add(
        &self,
        film: &mut Film,
        samples: Range<u32>,
        total: u32,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) {
        let (w, h) = (film.width, film.height as u64);
        let r = film.replicas.count() as usize;
        let done = AtomicU64::new(0);
        let y0 = self.camera.crop.y;
        let rows: Vec<RowStats> = film
            .sum
            .par_chunks_mut(w)
            .zip(film.replica_sums.par_chunks_mut(w * r))
            .enumerate()
            .map(|(y, (sum, replica_sums))| {
                let r = self.row(y0 + y as u32, samples.clone(), total, sum, replica_sums);
                progress(done.fetch_add(1, Ordering::Relaxed) + 1, h);
                r
            })
            .collect();
        for row in rows {
            film.rays += row.rays;
            film.non_finite += row.non_finite;
            for (a, b) in film.requests.0.iter_mut().zip(row.requests) {
                *a += b;
            }
        }
    }
}

pub(super) const ALL_DIMS: [Dim; DIM_PURPOSES] =
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
