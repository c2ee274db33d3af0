//! The camera pass: the camera-sample dimensions a render draws ([`CameraDims`]) and one pass of
//! sample indices over every pixel, rows in parallel.

use super::*;
use crate::camera::Camera;
use crate::lanes::{self, Isa, Lanes, RayLanes, WIDTH};
use crate::sampler::{Dim, Replicas, SampleStream, Sampler, DIM_PURPOSES};
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
    /// The instruction set of the camera's lane kernels.
    pub(super) isa: Isa,
}

/// The most camera samples the camera pass starts together (whole pixels' samples; at least one
/// pixel's), which the wavefront engine advances together: enough that batches of 16 stay full as
/// paths end, few enough that their states stay in the cache.
pub const CAMERA_BATCH: usize = 1024;

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
            isa: Isa::detect(),
        }
    }

    /// An empty film of the size of the camera's crop window.
    pub(super) fn film(&self) -> Film {
        Film::of_crop(&self.camera, 1.0, self.dims.wavelength, self.opts.replicas)
    }

    /// The camera rays of the samples `samples` (of `total`) of every pixel of `xs` in row `y`,
    /// pixel by pixel in sample order, into `rays` ([`WIDTH`] to an element), with the contexts
    /// of their paths into `ctxs` (each sample's stream after the camera's dimensions, its
    /// channels and counters); both are cleared first, so that sample `i` is lane `i % WIDTH`
    /// of `rays[i / WIDTH]`. The
    /// camera's dimensions are drawn in one order for every engine: the pixel (the filter places
    /// the sample, [`Camera::film_point`]; a single sample per pixel goes through the pixel's
    /// centre and draws none), the lens, the time, the wavelength. Their numbers are drawn and
    /// their rays made [`WIDTH`] at a time (the sampler's [`lanes::sobol_pairs`], the camera's
    /// [`lanes::camera_rays`], each lane the one-ray function's bits).
    fn start_batch(
        &self,
        (xs, y): (Range<u32>, u32),
        samples: Range<u32>,
        total: u32,
        rays: &mut Vec<CameraRays>,
        ctxs: &mut Vec<PathContext>,
    ) {
        let (opts, camera) = (&self.opts, &self.camera);
        let streams: Vec<SampleStream> =
            samples.clone().map(|s| opts.replicas.stream(opts.seed, s, total)).collect();
        rays.clear();
        ctxs.clear();
        for x in xs.clone() {
            let pixel = y as u64 * camera.width as u64 + x as u64;
            ctxs.extend(
                streams
                    .iter()
                    .map(|&stream| PathContext::new(Sampler::of_stream(opts.sampler, stream, pixel))),
            );
        }
        let per_pixel = samples.len();
        let isa = self.isa;
        for (c, group) in ctxs.chunks_mut(WIDTH).enumerate() {
            let pixel = |k: usize| xs.start + ((c * WIDTH + k) / per_pixel) as u32;
            let active: [bool; WIDTH] = std::array::from_fn(|k| k < group.len());
            let film: [Lanes; 2] = if total == 1 {
                let centre = |k: usize, at: u32| if active[k] { at as f32 + 0.5 } else { 0.0 };
                [std::array::from_fn(|k| centre(k, pixel(k))), [y as f32 + 0.5; WIDTH]]
            } else {
                let u = draw_2d(isa, group, Dim::Pixel);
                let mut film = [[0.0; WIDTH]; 2];
                for k in 0..group.len() {
                    let p = camera.film_point(pixel(k), y, Vec2::new(u[0][k], u[1][k]));
                    (film[0][k], film[1][k]) = (p.x, p.y);
                }
                film
            };
            let lens = if self.dims.lens { draw_2d(isa, group, Dim::Lens) } else { [[0.0; WIDTH]; 2] };
            let (open, close) = camera.shutter;
            let time = if self.dims.time {
                draw_1d(isa, group, Dim::Time).map(|u| open + (close - open) * u)
            } else {
                [open; WIDTH]
            };
            if self.dims.wavelength {
                for ctx in group.iter_mut() {
                    ctx.channels =
                        Channels::Spectral(Wavelengths::sample(ctx.sampler.get_1d(Dim::Wavelength)));
                }
            }
            let (origin, dir) = lanes::camera_rays(isa, camera, &film, &lens);
            rays.push(CameraRays { rays: RayLanes { origin, dir }, time });
            for ctx in group.iter_mut() {
                ctx.rays.primary += 1;
            }
        }
    }

    /// The RGB estimate of a sample whose path (context `ctx`) gathered `radiance`, its rays and
    /// sampler requests counted in `row`.
    pub(super) fn finish(&self, ctx: &PathContext, radiance: Vec3, row: &mut RowStats) -> Vec3 {
        row.rays += ctx.rays;
        for (total, d) in row.requests.iter_mut().zip(ALL_DIMS) {
            *total += ctx.sampler.requests(d) as u64;
        }
        ctx.rgb(radiance)
    }

    /// Continue the sums of the film's row `y` (`sum` per pixel of the crop window,
    /// `replica_sums` per pixel and replica) with the samples `samples` (of `total`, 0 when
    /// unknown). The camera rays go in batches of at most [`CAMERA_BATCH`] whole pixels' samples
    /// ([`Pass::start_batch`]) to the engine: the batch engine traces them together, the one-ray
    /// engine one after the other; their estimates are added pixel by pixel in sample order.
    pub(super) fn row(
        &self,
        y: u32,
        samples: Range<u32>,
        total: u32,
        sum: &mut [DVec3],
        replica_sums: &mut [DVec3],
    ) -> RowStats {
        let mut row = RowStats { rays: RayCounts::default(), non_finite: 0, requests: [0; DIM_PURPOSES] };
        if samples.is_empty() {
            return row;
        }
        let replicas = self.opts.replicas;
        let r = replicas.count() as usize;
        let width = sum.len();
        let pixels_per_batch = (CAMERA_BATCH / samples.len()).max(1);
        let batch = pixels_per_batch.min(width) * samples.len();
        let (mut rays, mut ctxs) = (Vec::with_capacity(batch.div_ceil(WIDTH)), Vec::with_capacity(batch));
        let mut estimates = Vec::with_capacity(batch);
        let x0 = self.camera.crop.x;
        for first in (0..width).step_by(pixels_per_batch) {
            let xs = x0 + first as u32..x0 + (first + pixels_per_batch).min(width) as u32;
            estimates.clear();
            self.start_batch((xs, y), samples.clone(), total, &mut rays, &mut ctxs);
            match &self.engine.wavefront {
                Some(engine) => {
                    let radiance = engine.estimate_rays(self.scene, &self.opts.params, &rays, &mut ctxs);
                    estimates.extend(ctxs.iter().zip(radiance).map(|(ctx, l)| self.finish(ctx, l, &mut row)));
                }
                None => estimates.extend(ctxs.iter_mut().enumerate().map(|(i, ctx)| {
                    let ray = rays[i / WIDTH].ray(i % WIDTH);
                    let l = self.estimator.radiance(self.scene, &self.opts.params, &ray, ctx);
                    self.finish(ctx, l, &mut row)
                })),
            }
            let pixels = sum[first..].iter_mut().zip(replica_sums[first * r..].chunks_mut(r));
            for ((sum, replica_sums), pixel) in pixels.zip(estimates.chunks(samples.len())) {
                for (&l, s) in pixel.iter().zip(samples.clone()) {
                    row.add(l, s, replicas, sum, replica_sums);
                }
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

/// The next two-dimensional request for `purpose` of each stream of `ctxs` (at most [`WIDTH`],
/// the other lanes 0): what each stream's [`Sampler::get_2d`] gives, across lanes for Sobol'
/// streams ([`lanes::sobol_pairs`]), one stream at a time for the other kinds.
fn draw_2d(isa: Isa, ctxs: &mut [PathContext], purpose: Dim) -> [Lanes; 2] {
    let mut u = [[0.0; WIDTH]; 2];
    match sobol_lanes(ctxs) {
        Some((keys, reversed, dims)) => {
            (u[0], u[1]) = lanes::sobol_pairs(isa, &keys, &reversed, &dims);
            resume(ctxs, &dims, 2, purpose);
        }
        None => {
            for (k, ctx) in ctxs.iter_mut().enumerate() {
                let v = ctx.sampler.get_2d(purpose);
                (u[0][k], u[1][k]) = (v.x, v.y);
            }
        }
    }
    u
}

/// [`draw_2d`] for a one-dimensional request ([`Sampler::get_1d`], [`lanes::sobol_firsts`]).
fn draw_1d(isa: Isa, ctxs: &mut [PathContext], purpose: Dim) -> Lanes {
    match sobol_lanes(ctxs) {
        Some((keys, reversed, dims)) => {
            let u = lanes::sobol_firsts(isa, &keys, &reversed, &dims);
            resume(ctxs, &dims, 1, purpose);
            u
        }
        None => {
            let mut u = [0.0; WIDTH];
            for (k, ctx) in ctxs.iter_mut().enumerate() {
                u[k] = ctx.sampler.get_1d(purpose);
            }
            u
        }
    }
}

/// The Sobol' states of the streams of `ctxs` per lane (pixel keys, reversed sample indices,
/// next dimensions), `None` when they are of another kind.
fn sobol_lanes(ctxs: &[PathContext]) -> Option<([u64; WIDTH], [u32; WIDTH], [u32; WIDTH])> {
    let (mut keys, mut reversed, mut dims) = ([0; WIDTH], [0; WIDTH], [0; WIDTH]);
    for (k, ctx) in ctxs.iter().enumerate() {
        let state = ctx.sampler.sobol_state()?;
        (keys[k], reversed[k], dims[k]) = (state.pixel_key, state.reversed_sample, state.dimension);
    }
    Some((keys, reversed, dims))
}

/// Moves each stream of `ctxs` past the `width` dimensions drawn for it across lanes at `dims`,
/// one request for `purpose`.
fn resume(ctxs: &mut [PathContext], dims: &[u32; WIDTH], width: u32, purpose: Dim) {
    let mut requests = [0; DIM_PURPOSES];
    requests[purpose as usize] = 1;
    for (ctx, d) in ctxs.iter_mut().zip(dims) {
        ctx.sampler.resume(d + width, &requests);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Ray;
    use crate::pixel_filter::{FilterKind, PixelFilter};
    use crate::sampler::SamplerKind;

    /// Every camera ray of a batch is the one-ray camera's ([`Camera::generate_ray_lens`]) from
    /// the sample's own stream drawn one request at a time (the pixel placed by the filter, the
    /// lens, the time), and leaves the stream after those requests: for every sampler kind, with
    /// a thin lens, a shutter, a near clip plane and a Gaussian filter, in batches that end
    /// mid-chunk.
    #[test]
    fn batched_camera_rays_are_the_one_ray_cameras() {
        let scene = crate::scene::load_default();
        let path = crate::integrators::create("path").unwrap();
        for kind in [SamplerKind::Sobol, SamplerKind::Stratified, SamplerKind::Independent] {
            for (samples, total) in [(0..5, 5), (3..7, 9), (0..1, 1), (2..4, 0)] {
                let mut opts = RenderOptions::from_scene(&scene, total.max(1));
                opts.resolution = Some((11, 7));
                opts.sampler = kind;
                let mut pass = Pass::new(&scene, path.as_ref(), path.camera().unwrap(), &opts);
                pass.camera = pass
                    .camera
                    .clone()
                    .with_lens(0.2, 2.5)
                    .with_shutter(0.25, 0.75)
                    .with_near_clip(0.3)
                    .with_filter(PixelFilter::new(FilterKind::Gaussian { stddev: 0.5 }));
                pass.dims = CameraDims { lens: true, time: true, wavelength: false };
                let (mut rays, mut ctxs) = (Vec::new(), Vec::new());
                let (xs, y) = (2..9, 4);
                pass.start_batch((xs.clone(), y), samples.clone(), total, &mut rays, &mut ctxs);
                assert_eq!(ctxs.len(), xs.len() * samples.len());
                assert_eq!(rays.len(), ctxs.len().div_ceil(WIDTH));
                let one_by_one = xs.flat_map(|x| samples.clone().map(move |s| (x, s)));
                for (i, (x, s)) in one_by_one.enumerate() {
                    let stream = opts.replicas.stream(opts.seed, s, total);
                    let mut sampler = Sampler::of_stream(kind, stream, (y * pass.camera.width + x) as u64);
                    let film = if total == 1 {
                        Vec2::new(x as f32 + 0.5, y as f32 + 0.5)
                    } else {
                        pass.camera.film_point(x, y, sampler.get_2d(Dim::Pixel))
                    };
                    let lens = sampler.get_2d(Dim::Lens);
                    let time = 0.25 + 0.5 * sampler.get_1d(Dim::Time);
                    let want = pass.camera.generate_ray_lens(film, lens, time);
                    let got = rays[i / WIDTH].ray(i % WIDTH);
                    let bits =
                        |r: &Ray| (r.origin.to_array().map(f32::to_bits), r.dir.to_array().map(f32::to_bits));
                    assert_eq!(bits(&got), bits(&want), "{kind:?}, pixel ({x}, {y}), sample {s} of {total}");
                    assert_eq!(got.time.to_bits(), want.time.to_bits());
                    let ctx = &mut ctxs[i];
                    assert_eq!(ctx.rays.primary, 1);
                    for d in ALL_DIMS {
                        assert_eq!(ctx.sampler.requests(d), sampler.requests(d), "{d:?}");
                    }
                    assert_eq!(
                        ctx.sampler.get_1d(Dim::Other).to_bits(),
                        sampler.get_1d(Dim::Other).to_bits()
                    );
                }
            }
        }
    }
}
