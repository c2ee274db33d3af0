//! The render drivers: the camera pass (every pixel's samples in parallel), the [`Film`] that
//! sums sample indices, progressive rendering ([`Progressive`]) and the per-pixel variance, all
//! deterministic at any thread count.
//!
//! A camera sample draws, in this order and only when the scene calls for the effect and the
//! integrator simulates it: the position in the pixel, a point on the lens, a time in the
//! shutter interval and a wavelength. Everything else is up to the integrator.
//!
//! # Films and progressive rendering
//! A [`Film`] holds per pixel the f64 sums of the per-sample estimates and of their squares. The
//! camera pass continues every pixel's sums sample index by sample index, in index order, and
//! light tracing adds its `w·h` paths per sample index in path order; so adding the sample
//! ranges `0..a` and then `a..b` gives the very bits of adding `0..b` at once. A progressive
//! render reports the image after N samples without re-rendering anything, and that image *is*
//! the plain N-sample render:
//! - The Sobol' sampler (the default) and the independent one do not depend on the sample count,
//!   so a checkpoint at N ≥ 2 samples equals, bit for bit, a plain N-sample render with the same
//!   sampler; a plain 1-sample render traces the pixel centres, a progressive first pass a
//!   sampled point in them. The stratified sampler needs the count in advance: its progressive
//!   passes (like the passes of a time budget) draw independent samples, and equal plain renders
//!   with `--sampler independent`.
//! - Light tracing's path streams do not depend on the count: its checkpoints equal plain renders
//!   with any sampler.
//!
//! Which methods grow ([`Integrator::progression`]): the camera-pass methods (`raycast`,
//! `whitted`, `distributed`, `path`; the deterministic ones converge to their own antialiased
//! image) and `light`. `ssaa` renders one fixed pattern whatever the sample count
//! ([`Progression::Fixed`]): a progressive render of it is that one image.
//!
//! # Passes and interrupts
//! A render spends its budget in sample passes: a sample budget of n in passes
//! of adaptive size (doubling while a pass takes under about an eighth of a second), each still
//! drawing sample s of n (so stratification is kept), a time budget in 1-sample passes. Because
//! the film sums every pixel's samples in index order whatever the ranges, the passes change no
//! bit of the image. Between passes the drivers check [`crate::interrupt::stop_requested`]:
//! after a stop (the first Ctrl-C of `vitrum render`) the render returns the whole passes done,
//! at least one, so `spp` is the whole number of samples every pixel got. That image equals,
//! bit for bit:
//! - for light tracing, a plain render with that many samples (any sampler);
//! - for the camera pass with the Sobol' or the independent sampler, a plain render with that
//!   many samples and the same sampler (for 2 samples or more, as above), time budgets included
//!   (with the stratified sampler a time budget draws independent samples);
//! - for the camera pass with the stratified sampler, the first `spp` sample indices of the
//!   planned n-sample pattern: an unbiased estimate (each pixel's strata are assigned to sample
//!   indices by a random permutation), but not what a plain `spp`-sample stratified render draws.
//!
//! `ssaa` renders its one fixed pattern to the end. [`Progressive`] renders are driven by their
//! caller and ignore the flag.
//!
//! # Variance
//! The variance of a pixel's estimate (its squared standard error) is s²/n, with s² the unbiased
//! variance of its n per-sample estimates: the camera samples of the pixel, or for light tracing
//! the n images made by one sample index's `w·h` paths each (batches, independent of each other
//! up to the 16-path strata of the stratified sampler, and the sequences of the Sobol' one, that
//! span batches). With the Sobol' or stratified camera sampler the samples of a pixel are not
//! independent and s²/n overestimates the error (the gain of stratification is not seen): a
//! conservative estimate. With fewer than two samples there is no estimate.

use crate::camera::Camera;
use crate::image::Image;
use crate::integrators::{Integrator, PathContext, RenderParams};
use crate::sampler::{Dim, Sampler, SamplerKind, DIM_PURPOSES};
use crate::scene::effects::Support;
use crate::scene::{Effect, Scene, SpectralMode};
use crate::spectrum::{Channels, Wavelengths};
use crate::stats::RayCounts;
use glam::{DVec3, Vec2, Vec3};
use rayon::prelude::*;
use std::ops::Range;
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
    /// The sample count the sampler plans for when this render is one part of a larger one (a
    /// shard, a resumed range): sample `s` is drawn as sample `s` of this many. `None`: the
    /// budget's own count.
    pub planned_spp: Option<u32>,
}

impl RenderOptions {
    /// Options for `spp` samples with the scene's own settings for its own integrator
    /// (`[render] integrator`; for another method, use [`for_method`](Self::for_method)).
    pub fn from_scene(scene: &Scene, spp: u32) -> RenderOptions {
        let integrator =
            crate::integrators::create(&scene.settings.integrator).expect("compile checked the name");
        RenderOptions::for_method(scene, integrator.as_ref(), spp)
    }

    /// Options for `spp` samples of `integrator` with the scene's settings for that method
    /// (its `[render.METHOD]` table, else the method's own defaults, such as its full depth).
    pub fn for_method(scene: &Scene, integrator: &dyn Integrator, spp: u32) -> RenderOptions {
        let s = &scene.settings;
        RenderOptions {
            budget: Budget::Samples(spp),
            resolution: None,
            seed: s.seed,
            params: s.params(integrator, None),
            spectral: s.spectral,
            sampler: s.sampler,
            planned_spp: None,
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
    /// Variance of each pixel's estimate per channel (its squared standard error); `None` when
    /// it cannot be estimated (fewer than two samples, or a deterministic sample pattern).
    pub variance: Option<Image>,
}

/// A noise estimate of a render that needs no reference, from its per-pixel variance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Noise {
    /// Mean over pixels and channels of the standard error of the pixel estimate.
    pub std_error: f64,
    /// Mean over pixels and channels of the variance of the estimate: the expected MSE against
    /// the converged image (of an unbiased method).
    pub mse: f64,
    /// Pixels whose variance is NaN or infinite, left out of both means.
    pub non_finite: usize,
}

impl RenderOutput {
    /// The reference-free noise estimate, when the render has a per-pixel variance.
    pub fn noise(&self) -> Option<Noise> {
        let variance = self.variance.as_ref()?;
        let (mut se, mut mse, mut count, mut non_finite) = (0.0f64, 0.0f64, 0usize, 0usize);
        for v in &variance.pixels {
            if !v.is_finite() {
                non_finite += 1;
                continue;
            }
            let v = v.as_dvec3();
            se += v.x.sqrt() + v.y.sqrt() + v.z.sqrt();
            mse += v.element_sum();
            count += 3;
        }
        let n = count.max(1) as f64;
        Some(Noise { std_error: se / n, mse: mse / n, non_finite })
    }
}

/// The running sums of a render: what a progressive render carries from pass to pass.
#[derive(Clone, Debug)]
pub struct Film {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Per pixel, the sum over sample indices of the per-sample estimates (before `norm`).
    pub sum: Vec<DVec3>,
    /// Per pixel, the sum of their squares.
    pub sum_sq: Vec<DVec3>,
    /// The first sample index of the film (0 but for a part of a larger render: a shard).
    pub first: u32,
    /// Sample indices added so far, `first..first + samples` (the driver advances it after
    /// each addition).
    pub samples: u32,
    /// A pixel's estimate is `sum / (samples · norm)`: 1 for the camera pass, the film area for
    /// light tracing.
    pub norm: f64,
    /// Rays traced, by kind.
    pub rays: RayCounts,
    /// Samples (or light paths' splats) that were NaN or infinite.
    pub non_finite: u64,
    /// Sampler requests per purpose (camera pass only).
    pub requests: DimensionRequests,
    /// Whether wavelengths are traced.
    pub spectral: bool,
    /// Seconds spent adding samples.
    pub seconds: f64,
}

/// `x` clamped below at 0 per channel, NaN kept (a NaN must never turn into a clean 0).
fn non_negative(v: DVec3) -> DVec3 {
    let f = |x: f64| if x < 0.0 { 0.0 } else { x };
    DVec3::new(f(v.x), f(v.y), f(v.z))
}

impl Film {
    /// An empty film of `width × height` pixels.
    pub fn new(width: usize, height: usize, norm: f64, spectral: bool) -> Film {
        Film {
            width,
            height,
            sum: vec![DVec3::ZERO; width * height],
            sum_sq: vec![DVec3::ZERO; width * height],
            first: 0,
            samples: 0,
            norm,
            rays: RayCounts::default(),
            non_finite: 0,
            requests: DimensionRequests::default(),
            spectral,
            seconds: 0.0,
        }
    }

    /// The sample index the next addition starts at.
    pub fn next_sample(&self) -> u32 {
        self.first + self.samples
    }

    /// The sample indices added so far.
    pub fn sample_range(&self) -> Range<u32> {
        self.first..self.next_sample()
    }

    /// The mean per pixel (black before the first sample).
    pub fn image(&self) -> Image {
        let scale = 1.0 / (self.samples.max(1) as f64 * self.norm);
        let pixels = self.sum.iter().map(|s| (*s * scale).as_vec3()).collect();
        Image { width: self.width, height: self.height, pixels }
    }

    /// The variance of each pixel's mean, s²/n; `None` below two samples.
    pub fn variance(&self) -> Option<Image> {
        if self.samples < 2 {
            return None;
        }
        let n = self.samples as f64;
        let scale = 1.0 / (self.norm * self.norm * n * (n - 1.0));
        let pixels = self
            .sum
            .iter()
            .zip(&self.sum_sq)
            .map(|(s, q)| (non_negative(*q - *s * *s / n) * scale).as_vec3())
            .collect();
        Some(Image { width: self.width, height: self.height, pixels })
    }

    /// The render so far.
    pub fn output(&self) -> RenderOutput {
        RenderOutput {
            image: self.image(),
            spp: self.samples,
            seconds: self.seconds,
            rays: self.rays,
            non_finite_samples: self.non_finite,
            spectral: self.spectral,
            samples_per_pixel: None,
            variance: self.variance(),
        }
    }
}

/// A method with its own image loop that still builds its image sample index by sample index
/// (light tracing), so that it can render progressively and estimate its variance.
pub trait Accumulate: Sync {
    /// An empty film for rendering `scene` with `opts`.
    fn film(&self, scene: &Scene, opts: &RenderOptions) -> Film;
    /// Add the sample indices `samples` (from [`Film::next_sample`] on) to `film`, each sample index
    /// adding one term to every pixel's sum and sum of squares; the caller then advances
    /// `film.samples` and its time. `progress` gets (work done, work total) of this call.
    fn add_samples(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        samples: Range<u32>,
        film: &mut Film,
        progress: &(dyn Fn(u64, u64) + Sync),
    );
}

/// How a method's image grows with the sample count (see the module documentation).
#[derive(Clone, Copy)]
pub enum Progression<'a> {
    /// The shared camera pass adds samples of [`Integrator::radiance`].
    CameraPass,
    /// The method adds sample indices itself.
    Own(&'a dyn Accumulate),
    /// The method cannot grow an image: every checkpoint is rendered anew; the text says why.
    Fresh(&'static str),
    /// The method renders one image whatever the sample count; the text says why.
    Fixed(&'static str),
}

impl std::fmt::Debug for Progression<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Progression::CameraPass => write!(f, "CameraPass"),
            Progression::Own(_) => write!(f, "Own"),
            Progression::Fresh(why) => write!(f, "Fresh({why:?})"),
            Progression::Fixed(why) => write!(f, "Fixed({why:?})"),
        }
    }
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

/// Counters of one row over a range of samples.
struct RowStats {
    rays: RayCounts,
    non_finite: u64,
    requests: [u64; DIM_PURPOSES],
}

/// Everything fixed during camera passes.
struct Pass<'a> {
    scene: &'a Scene,
    integrator: &'a dyn Integrator,
    camera: Camera,
    opts: RenderOptions,
    dims: CameraDims,
}

impl<'a> Pass<'a> {
    fn new(scene: &'a Scene, integrator: &'a dyn Integrator, opts: &RenderOptions) -> Pass<'a> {
        Pass {
            scene,
            integrator,
            camera: camera_for(scene, opts.resolution),
            opts: opts.clone(),
            dims: CameraDims::resolve(scene, integrator, opts.spectral),
        }
    }

    /// An empty film of the camera's size.
    fn film(&self) -> Film {
        Film::new(self.camera.width as usize, self.camera.height as usize, 1.0, self.dims.wavelength)
    }

    /// One camera sample of pixel (`x`, `y`): its radiance, with its rays and sampler requests.
    fn sample(&self, x: u32, y: u32, index: u32, total: u32, row: &mut RowStats) -> Vec3 {
        let pixel = y as u64 * self.camera.width as u64 + x as u64;
        let mut sampler = Sampler::new(self.opts.sampler, self.opts.seed, pixel, index, total);
        let offset = if total == 1 { Vec2::splat(0.5) } else { sampler.get_2d(Dim::Pixel) };
        let lens = if self.dims.lens { sampler.get_2d(Dim::Lens) } else { Vec2::ZERO };
        let (open, close) = self.camera.shutter;
        let time = if self.dims.time { open + (close - open) * sampler.get_1d(Dim::Time) } else { open };
        let mut ctx = PathContext::new(sampler);
        if self.dims.wavelength {
            ctx.channels = Channels::Spectral(Wavelengths::sample(ctx.sampler.get_1d(Dim::Wavelength)));
        }
        let ray = self.camera.generate_ray_lens(Vec2::new(x as f32, y as f32) + offset, lens, time);
        ctx.rays.primary += 1;
        let radiance = self.integrator.radiance(self.scene, &self.opts.params, &ray, &mut ctx);
        let l = ctx.channels.to_rgb(radiance);
        row.rays += ctx.rays;
        for (total, d) in row.requests.iter_mut().zip(ALL_DIMS) {
            *total += ctx.sampler.requests(d) as u64;
        }
        l
    }

    /// Continue the sums of row `y` with the samples `samples` (of `total`, 0 when unknown).
    fn row(
        &self,
        y: u32,
        samples: Range<u32>,
        total: u32,
        sum: &mut [DVec3],
        sum_sq: &mut [DVec3],
    ) -> RowStats {
        let mut row = RowStats { rays: RayCounts::default(), non_finite: 0, requests: [0; DIM_PURPOSES] };
        for (x, (sum, sum_sq)) in sum.iter_mut().zip(sum_sq.iter_mut()).enumerate() {
            for s in samples.clone() {
                let l = self.sample(x as u32, y, s, total, &mut row);
                if !l.is_finite() {
                    row.non_finite += 1;
                }
                let l = l.as_dvec3();
                *sum += l;
                *sum_sq += l * l;
            }
        }
        row
    }

    /// Add the samples `samples` (of `total` planned, 0 when unknown) to every pixel of `film`.
    fn add(&self, film: &mut Film, samples: Range<u32>, total: u32, progress: &(dyn Fn(u64, u64) + Sync)) {
        let (w, h) = (film.width, film.height as u64);
        let done = AtomicU64::new(0);
        let rows: Vec<RowStats> = film
            .sum
            .par_chunks_mut(w)
            .zip(film.sum_sq.par_chunks_mut(w))
            .enumerate()
            .map(|(y, (sum, sum_sq))| {
                let r = self.row(y as u32, samples.clone(), total, sum, sum_sq);
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

/// Seconds a sample pass should take: long enough that the pass overhead (a parallel loop's
/// start and tail) is negligible, short enough that a stop request is honoured promptly.
const PASS_SECONDS: f64 = 0.25;

/// The sample count of the pass after one of `size` samples that took `took`: doubled while
/// passes are short, halved (down to one) when they are long.
fn next_pass_size(size: u32, took: Duration) -> u32 {
    let t = took.as_secs_f64();
    if t < PASS_SECONDS / 2.0 {
        size.saturating_mul(2)
    } else if t > 2.0 * PASS_SECONDS {
        (size / 2).max(1)
    } else {
        size
    }
}

/// How a sample range is added to a film: `add(film, samples, total, progress)` adds the sample
/// indices `samples` of `total` planned (0 when the count is not known in advance), reporting
/// (work done, work total) of this call to `progress`.
type AddSamples<'f> = dyn FnMut(&mut Film, Range<u32>, u32, &(dyn Fn(u64, u64) + Sync)) + 'f;

/// Spend `budget` on `film` in sample passes, checking `stop()` between passes: after a stop
/// the film holds the whole passes done (at least one), a whole number of samples per pixel.
/// `after_pass` sees the film after every pass (checkpoints). `progress` gets (done, total) of
/// the whole render: thousandths of a sample per pixel for a sample budget, milliseconds for a
/// time budget.
///
/// A sample budget of `n` adds the sample indices from the film's next one up to `n`, in passes
/// of adaptive size (see [`next_pass_size`]), each with `total` = `planned` (or `n`). Films sum
/// every pixel's samples in index order whatever the ranges asked for, so the passes change no
/// bit of the result, and the timing that sizes them cannot either. A time budget adds 1-sample
/// passes until the film's seconds have grown by the limit. Only the passes count as render
/// time, not what `after_pass` does.
fn run_budget(
    film: &mut Film,
    budget: Budget,
    planned: Option<u32>,
    stop: &dyn Fn() -> bool,
    progress: &(dyn Fn(u64, u64) + Sync),
    add: &mut AddSamples<'_>,
    after_pass: &mut dyn FnMut(&Film),
) {
    let mut rendered = 0.0f64;
    match budget {
        Budget::Samples(n) => {
            let (first, total) = (film.next_sample().min(n), planned.unwrap_or(n));
            let span = (n - first) as u64 * 1000;
            let mut size = 1u32;
            while film.next_sample() < n {
                let from = film.next_sample();
                let to = from + size.min(n - from);
                let pass_start = Instant::now();
                // Thousandths of a sample per pixel over the whole render.
                let pass_progress = |done: u64, of: u64| {
                    let within = (to - from) as u128 * 1000 * done as u128 / of.max(1) as u128;
                    progress(((from - first) as u64 * 1000 + within as u64).min(span), span)
                };
                add(film, from..to, total, &pass_progress);
                film.samples += to - from;
                let took = pass_start.elapsed();
                film.seconds += took.as_secs_f64();
                after_pass(film);
                if stop() {
                    break;
                }
                size = next_pass_size(size, took);
            }
        }
        // The sample count is unknown in advance: no stratification across passes.
        Budget::Time(limit) => {
            let total = (limit.as_millis() as u64).max(1);
            let limit = limit.as_secs_f64();
            loop {
                let (s, pass_start) = (film.next_sample(), Instant::now());
                let timed = |_: u64, _: u64| {
                    let ms = ((rendered + pass_start.elapsed().as_secs_f64()) * 1000.0) as u64;
                    progress(ms.min(total), total)
                };
                add(film, s..s + 1, 0, &timed);
                film.samples += 1;
                let took = pass_start.elapsed().as_secs_f64();
                (rendered, film.seconds) = (rendered + took, film.seconds + took);
                after_pass(film);
                if rendered >= limit || stop() || film.next_sample() == u32::MAX {
                    break;
                }
            }
        }
    }
}

/// Spend `pass`'s budget on `film` with the shared camera pass, stopping on a stop request.
fn run_camera_pass(
    pass: &Pass<'_>,
    film: &mut Film,
    progress: &(dyn Fn(u64, u64) + Sync),
    after_pass: &mut dyn FnMut(&Film),
) {
    let opts = &pass.opts;
    let add = &mut |film: &mut Film, samples, total, p: &(dyn Fn(u64, u64) + Sync)| {
        pass.add(film, samples, total, p)
    };
    let stop = &crate::interrupt::stop_requested;
    run_budget(film, opts.budget, opts.planned_spp, stop, progress, add, after_pass);
}

/// Spend `opts.budget` on `film` with a method that adds sample indices itself, stopping on a
/// stop request.
fn run_accumulated(
    scene: &Scene,
    method: &dyn Accumulate,
    opts: &RenderOptions,
    film: &mut Film,
    progress: &(dyn Fn(u64, u64) + Sync),
    after_pass: &mut dyn FnMut(&Film),
) {
    let add = &mut |film: &mut Film, samples, _, p: &(dyn Fn(u64, u64) + Sync)| {
        method.add_samples(scene, opts, samples, film, p)
    };
    let stop = &crate::interrupt::stop_requested;
    run_budget(film, opts.budget, opts.planned_spp, stop, progress, add, after_pass);
}

/// Render `scene` with `integrator`; `progress` is called with (work done, work total) of the
/// whole render, from worker threads. After a stop request ([`crate::interrupt`]) the render
/// ends at its next pass boundary and returns the samples done (`spp` counts them); methods with
/// one fixed pattern (`ssaa`) finish.
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

/// The shared camera pass, with the sampler requests it made per purpose; it stops early, at a
/// whole number of samples per pixel, when a stop is requested ([`crate::interrupt`]).
pub fn camera_pass(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> (RenderOutput, DimensionRequests) {
    let pass = Pass::new(scene, integrator, opts);
    let mut film = pass.film();
    run_camera_pass(&pass, &mut film, progress, &mut |_| {});
    (film.output(), film.requests)
}

/// Render `opts.budget` with a method that adds sample indices itself (for its
/// [`Integrator::render_image`]): in passes of whole sample indices until the samples are done,
/// the time is up or a stop is requested ([`crate::interrupt`]).
pub fn render_accumulated(
    scene: &Scene,
    method: &dyn Accumulate,
    opts: &RenderOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> RenderOutput {
    let mut film = method.film(scene, opts);
    run_accumulated(scene, method, opts, &mut film, progress, &mut |_| {});
    film.output()
}

/// An empty film for a render of `scene` by `integrator` whose sample indices start at `first`
/// (a shard of a larger render, see [`render_part`]); `Err` with the reason for a method that
/// cannot grow an image by sample indices (`ssaa`'s one fixed pattern).
pub fn part_film(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    first: u32,
) -> Result<Film, &'static str> {
    let mut film = match integrator.progression() {
        Progression::CameraPass => Pass::new(scene, integrator, opts).film(),
        Progression::Own(method) => method.film(scene, opts),
        Progression::Fresh(why) | Progression::Fixed(why) => return Err(why),
    };
    film.first = first;
    Ok(film)
}

/// Continue `film` (new from [`part_film`], or read back from a checkpoint) under
/// `opts.budget`: a sample budget of `n` adds the sample indices from [`Film::next_sample`] up
/// to `n` (sample `s` drawn as sample `s` of `opts.planned_spp`, or of `n`), a time budget adds
/// 1-sample passes for that long. `after_pass` sees the film after every pass (to write
/// checkpoints); a stop request ([`crate::interrupt`]) ends the render at a pass boundary. The
/// sums are continued in index order, so a film rendered `a..k`, written, read back and
/// continued `k..b` holds the bits of one render of `a..b`. `Err` as for [`part_film`].
pub fn render_part(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    film: &mut Film,
    progress: &(dyn Fn(u64, u64) + Sync),
    after_pass: &mut dyn FnMut(&Film),
) -> Result<(), &'static str> {
    match integrator.progression() {
        Progression::CameraPass => {
            run_camera_pass(&Pass::new(scene, integrator, opts), film, progress, after_pass)
        }
        Progression::Own(method) => run_accumulated(scene, method, opts, film, progress, after_pass),
        Progression::Fresh(why) | Progression::Fixed(why) => return Err(why),
    }
    Ok(())
}

/// How the checkpoints of a progressive render are made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Growth {
    /// One render grows: the checkpoint at N samples is its first N sample indices.
    Incremental,
    /// Every checkpoint is a fresh N-sample render; the text says why.
    Fresh(&'static str),
    /// The method renders one image whatever the sample count: a single checkpoint.
    Fixed(&'static str),
}

/// Where a growing render's samples come from.
enum Source<'a> {
    Camera(Pass<'a>),
    Own(&'a dyn Accumulate),
    /// Whole renders (fresh or fixed).
    Renders,
}

/// A render that grows by sample ranges and can report the cumulative image at any count.
pub struct Progressive<'a> {
    scene: &'a Scene,
    integrator: &'a dyn Integrator,
    opts: RenderOptions,
    growth: Growth,
    source: Source<'a>,
    /// The running sums (incremental growth).
    film: Option<Film>,
    /// The latest whole render (fresh or fixed growth).
    last: Option<RenderOutput>,
    /// Seconds spent rendering, over all passes or renders.
    spent: f64,
}

impl<'a> Progressive<'a> {
    /// A progressive render of `scene` by `integrator` with `opts` (whose budget is ignored: the
    /// caller chooses the sample counts); incremental when the method can grow an image.
    pub fn new(scene: &'a Scene, integrator: &'a dyn Integrator, opts: &RenderOptions) -> Progressive<'a> {
        let (growth, source) = match integrator.progression() {
            Progression::CameraPass => {
                (Growth::Incremental, Source::Camera(Pass::new(scene, integrator, opts)))
            }
            Progression::Own(method) => (Growth::Incremental, Source::Own(method)),
            Progression::Fresh(why) => (Growth::Fresh(why), Source::Renders),
            Progression::Fixed(why) => (Growth::Fixed(why), Source::Renders),
        };
        let film = match &source {
            Source::Camera(pass) => Some(pass.film()),
            Source::Own(method) => Some(method.film(scene, opts)),
            Source::Renders => None,
        };
        Progressive { scene, integrator, opts: opts.clone(), growth, source, film, last: None, spent: 0.0 }
    }

    /// A progressive render whose every checkpoint is a fresh render with the options' own
    /// sampler, for methods that could also grow.
    pub fn fresh(scene: &'a Scene, integrator: &'a dyn Integrator, opts: &RenderOptions) -> Progressive<'a> {
        let mut p = Progressive::new(scene, integrator, opts);
        if p.growth == Growth::Incremental {
            p.growth = Growth::Fresh("each checkpoint is a new render with the scene's sampler, as asked");
            p.source = Source::Renders;
            p.film = None;
        }
        p
    }

    /// How checkpoints are made.
    pub fn growth(&self) -> Growth {
        self.growth
    }

    /// Samples per pixel of the current image (0 before the first advance).
    pub fn spp(&self) -> u32 {
        match (&self.film, &self.last) {
            (Some(film), _) => film.samples,
            (None, Some(out)) => out.spp,
            (None, None) => 0,
        }
    }

    /// Seconds spent rendering so far, over every pass or fresh render.
    pub fn seconds_spent(&self) -> f64 {
        self.spent
    }

    /// Grow the image to `spp` samples per pixel (a fresh `spp`-sample render when the method
    /// cannot grow; nothing after the first render of a fixed method). `progress` gets
    /// (work done, work total) of this step, from worker threads.
    pub fn advance_to(&mut self, spp: u32, progress: &(dyn Fn(u64, u64) + Sync)) {
        let start = Instant::now();
        match (&self.source, self.film.as_mut()) {
            (Source::Camera(pass), Some(film)) if spp > film.samples => {
                pass.add(film, film.samples..spp, 0, progress);
            }
            (Source::Own(method), Some(film)) if spp > film.samples => {
                method.add_samples(self.scene, &self.opts, film.samples..spp, film, progress);
            }
            (Source::Renders, _) => {
                if matches!(self.growth, Growth::Fixed(_)) && self.last.is_some() {
                    return;
                }
                let opts = RenderOptions { budget: Budget::Samples(spp), ..self.opts.clone() };
                let out = render(self.scene, self.integrator, &opts, progress);
                self.spent += out.seconds;
                self.last = Some(out);
                return;
            }
            _ => return,
        }
        let seconds = start.elapsed().as_secs_f64();
        let film = self.film.as_mut().expect("incremental renders have a film");
        film.samples = film.samples.max(spp);
        film.seconds += seconds;
        self.spent += seconds;
    }

    /// The current image: the cumulative render (its seconds are the time spent on all its
    /// passes), or the latest fresh render; `None` before the first advance.
    pub fn output(&self) -> Option<RenderOutput> {
        match (&self.film, &self.last) {
            (Some(film), _) if film.samples > 0 => Some(film.output()),
            (None, Some(out)) => Some(out.clone()),
            _ => None,
        }
    }
}

/// The checkpoints of a progressive render up to `max` samples: every power of two below it,
/// then `max` itself.
pub fn power_of_two_checkpoints(max: u32) -> Vec<u32> {
    let mut out: Vec<u32> = (0..32).map(|k| 1u32 << k).take_while(|&n| n < max).collect();
    if max > 0 {
        out.push(max);
    }
    out
}

/// Render progressively under `opts.budget` and call `checkpoint` with the cumulative render at
/// every power of two: up to `Budget::Samples(max)` (and at `max`), or until the render time
/// reaches `Budget::Time` (and where it stops, growing by 1-sample passes). With `fresh`, every
/// checkpoint is rendered anew ([`Progressive::fresh`]). A fixed method has one checkpoint.
/// `progress` gets (done, total) in thousandths of a sample per pixel (sample budgets) or in
/// milliseconds (time budgets). Returns how the checkpoints were made.
pub fn render_progressive(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    fresh: bool,
    progress: &(dyn Fn(u64, u64) + Sync),
    checkpoint: &mut dyn FnMut(&RenderOutput),
) -> Growth {
    let mut p = if fresh {
        Progressive::fresh(scene, integrator, opts)
    } else {
        Progressive::new(scene, integrator, opts)
    };
    let growth = p.growth();
    // Progress of a step from `from` to `to` work units out of `total`.
    let step = |from: u64, to: u64, total: u64| {
        move |done: u64, of: u64| progress((from + (to - from) * done / of.max(1)).min(total), total)
    };
    match opts.budget {
        Budget::Samples(max) => {
            let targets = match growth {
                Growth::Fixed(_) => vec![max],
                _ => power_of_two_checkpoints(max),
            };
            // Work in thousandths of a sample: what each step renders.
            let cost = |prev: u32, t: u32| match growth {
                Growth::Incremental => (t - prev) as u64 * 1000,
                _ => t as u64 * 1000,
            };
            let (mut total, mut prev) = (0u64, 0u32);
            for &t in &targets {
                total += cost(prev, t);
                prev = t;
            }
            let (mut done, mut prev) = (0u64, 0u32);
            for &target in &targets {
                let next = done + cost(prev, target);
                p.advance_to(target, &step(done, next, total));
                checkpoint(&p.output().expect("rendered"));
                (done, prev) = (next, target);
            }
        }
        Budget::Time(limit) => {
            let total = limit.as_millis().max(1) as u64;
            let mut spp = 0u32;
            loop {
                spp = match growth {
                    Growth::Incremental => spp + 1,
                    Growth::Fresh(_) => (spp * 2).max(1),
                    Growth::Fixed(_) => 1,
                };
                // Progress in milliseconds of render time.
                let (before, start) = ((p.seconds_spent() * 1000.0) as u64, Instant::now());
                let timed = |_: u64, _: u64| {
                    progress((before + start.elapsed().as_millis() as u64).min(total), total)
                };
                p.advance_to(spp, &timed);
                let out_of_time =
                    p.seconds_spent() >= limit.as_secs_f64() || matches!(growth, Growth::Fixed(_));
                if spp.is_power_of_two() || out_of_time {
                    checkpoint(&p.output().expect("rendered"));
                }
                progress(((p.seconds_spent() * 1000.0) as u64).min(total), total);
                if out_of_time || spp == u32::MAX {
                    break;
                }
            }
        }
    }
    growth
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkpoints_are_powers_of_two_then_the_maximum() {
        assert_eq!(power_of_two_checkpoints(0), Vec::<u32>::new());
        assert_eq!(power_of_two_checkpoints(1), [1]);
        assert_eq!(power_of_two_checkpoints(8), [1, 2, 4, 8]);
        assert_eq!(power_of_two_checkpoints(11), [1, 2, 4, 8, 11]);
        assert_eq!(power_of_two_checkpoints(u32::MAX).len(), 33);
    }

    /// A per-sample value that does not sum exactly in f64 in any order but index order.
    fn value(pixel: usize, s: u32) -> f64 {
        ((pixel as f64 + 1.0) * 0.1 + s as f64 * 0.37).sin() * 1e3 + 1e-7 * s as f64
    }

    /// Adds `value` for the samples `samples` to every pixel of `film`, in index order.
    fn add_values(film: &mut Film, samples: Range<u32>) {
        for (pixel, (sum, sq)) in film.sum.iter_mut().zip(film.sum_sq.iter_mut()).enumerate() {
            for s in samples.clone() {
                let v = DVec3::splat(value(pixel, s));
                *sum += v;
                *sq += v * v;
            }
        }
    }

    #[test]
    fn passes_give_the_bits_of_one_range_and_a_stop_lands_between_passes() {
        let mut whole = Film::new(3, 2, 1.0, false);
        add_values(&mut whole, 0..40);
        let mut passes = Vec::new();
        let mut film = Film::new(3, 2, 1.0, false);
        run_budget(
            &mut film,
            Budget::Samples(40),
            None,
            &|| false,
            &|_, _| {},
            &mut |f, samples, total, _| {
                assert_eq!(total, 40, "every pass draws from the planned pattern");
                passes.push(samples.clone());
                add_values(f, samples);
            },
            &mut |_| {},
        );
        assert_eq!(film.samples, 40);
        assert_eq!((film.sum.clone(), film.sum_sq.clone()), (whole.sum.clone(), whole.sum_sq.clone()));
        assert_eq!(passes.first(), Some(&(0..1)), "the first pass is one sample");
        assert!(passes.windows(2).all(|w| w[0].end == w[1].start) && passes.last().unwrap().end == 40);

        // A stop requested during the third pass: that pass finishes, nothing more is added.
        let calls = std::cell::Cell::new(0);
        let mut film = Film::new(3, 2, 1.0, false);
        let stop = || calls.get() >= 3;
        let mut ends = Vec::new();
        run_budget(
            &mut film,
            Budget::Samples(40),
            None,
            &stop,
            &|_, _| {},
            &mut |f, samples, _, _| {
                calls.set(calls.get() + 1);
                ends.push(samples.end);
                add_values(f, samples);
            },
            &mut |_| {},
        );
        assert_eq!(film.samples, *ends.last().unwrap());
        assert_eq!(ends.len(), 3);
        let mut expected = Film::new(3, 2, 1.0, false);
        add_values(&mut expected, 0..film.samples);
        expected.samples = film.samples;
        assert_eq!(film.sum, expected.sum);
        assert_eq!(film.image().pixels, expected.image().pixels);

        // A stop requested before the render: one pass all the same; time budgets stop too.
        for budget in [Budget::Samples(40), Budget::Time(Duration::from_secs(3600))] {
            let mut film = Film::new(3, 2, 1.0, false);
            run_budget(
                &mut film,
                budget,
                None,
                &|| true,
                &|_, _| {},
                &mut |f, samples, _, _| add_values(f, samples),
                &mut |_| {},
            );
            assert_eq!(film.samples, 1, "{budget:?}");
        }
    }

    #[test]
    fn a_part_adds_its_own_range_from_the_planned_pattern_and_resumes_bit_for_bit() {
        let mut whole = Film::new(3, 2, 1.0, false);
        add_values(&mut whole, 5..30);
        // Sample indices 5..30 of a 40-sample plan, stopped after a few passes, then resumed.
        let calls = std::cell::Cell::new(0);
        let (mut film, mut seen) = (Film::new(3, 2, 1.0, false), Vec::new());
        film.first = 5;
        let mut add = |f: &mut Film, samples: Range<u32>, total: u32, _: &(dyn Fn(u64, u64) + Sync)| {
            assert_eq!(total, 40, "drawn as samples of the plan");
            calls.set(calls.get() + 1);
            add_values(f, samples)
        };
        let mut after = |f: &Film| seen.push(f.sample_range());
        run_budget(
            &mut film,
            Budget::Samples(30),
            Some(40),
            &|| calls.get() >= 2,
            &|_, _| {},
            &mut add,
            &mut after,
        );
        assert!(film.next_sample() < 30 && film.first == 5, "{:?}", film.sample_range());
        run_budget(&mut film, Budget::Samples(30), Some(40), &|| false, &|_, _| {}, &mut add, &mut after);
        assert_eq!(film.sample_range(), 5..30);
        assert_eq!((film.sum.clone(), film.sum_sq.clone()), (whole.sum, whole.sum_sq));
        assert_eq!(seen.first(), Some(&(5..6)), "after every pass, from the first index");
        assert_eq!(seen.last(), Some(&(5..30)));
    }

    #[test]
    fn progress_covers_the_whole_render() {
        let seen = std::sync::Mutex::new(Vec::new());
        let mut film = Film::new(1, 1, 1.0, false);
        let progress = |done: u64, total: u64| seen.lock().unwrap().push((done, total));
        run_budget(
            &mut film,
            Budget::Samples(10),
            None,
            &|| false,
            &progress,
            &mut |f, samples, _, p| {
                p(1, 2);
                p(2, 2);
                add_values(f, samples);
            },
            &mut |_| {},
        );
        let seen = seen.into_inner().unwrap();
        assert!(seen.iter().all(|&(_, total)| total == 10_000), "{seen:?}");
        assert!(seen.windows(2).all(|w| w[0].0 <= w[1].0), "{seen:?}");
        assert_eq!(seen.last(), Some(&(10_000, 10_000)));
    }

    #[test]
    fn pass_sizes_double_while_short_and_halve_when_long() {
        let ms = Duration::from_millis;
        assert_eq!(next_pass_size(4, ms(1)), 8);
        assert_eq!(next_pass_size(4, ms(200)), 4);
        assert_eq!(next_pass_size(4, ms(2000)), 2);
        assert_eq!(next_pass_size(1, ms(2000)), 1);
        assert_eq!(next_pass_size(u32::MAX, ms(1)), u32::MAX);
    }

    #[test]
    fn camera_passes_split_anywhere_give_the_same_bits() {
        let scene = crate::scene::load_default();
        let path = crate::integrators::create("path").unwrap();
        let mut opts = RenderOptions::from_scene(&scene, 6);
        opts.resolution = Some((12, 8));
        let pass = Pass::new(&scene, path.as_ref(), &opts);
        let (mut once, mut split) = (pass.film(), pass.film());
        pass.add(&mut once, 0..6, 6, &|_, _| {});
        for range in [0..1, 1..3, 3..6] {
            pass.add(&mut split, range, 6, &|_, _| {});
        }
        assert_eq!(once.sum, split.sum);
        assert_eq!(once.sum_sq, split.sum_sq);
        assert_eq!(once.rays, split.rays);
        assert!(once.sum.iter().any(|s| s.max_element() > 0.0), "a black image would pass trivially");
    }

    /// A 2×1 film with the per-sample values `a` (pixel 0) and `b` (pixel 1).
    fn film(a: &[f64], b: &[f64], norm: f64) -> Film {
        let mut film = Film::new(2, 1, norm, false);
        for (pixel, values) in [a, b].into_iter().enumerate() {
            for &v in values {
                film.sum[pixel] += DVec3::splat(v);
                film.sum_sq[pixel] += DVec3::splat(v * v);
            }
        }
        film.samples = a.len() as u32;
        film
    }

    #[test]
    fn the_variance_is_that_of_the_mean() {
        // Samples 1, 2, 3: mean 2, sample variance 1, variance of the mean 1/3.
        let f = film(&[1.0, 2.0, 3.0], &[5.0, 5.0, 5.0], 1.0);
        assert_eq!(f.image().pixels, [Vec3::splat(2.0), Vec3::splat(5.0)]);
        let v = f.variance().unwrap();
        assert!((v.pixels[0] - Vec3::splat(1.0 / 3.0)).abs().max_element() < 1e-7, "{v:?}");
        assert_eq!(v.pixels[1], Vec3::ZERO, "a constant pixel has no variance");
        // The norm scales the estimate and its standard error alike (light tracing's film area).
        let g = film(&[1.0, 2.0, 3.0], &[5.0, 5.0, 5.0], 2.0);
        assert_eq!(g.image().pixels[0], Vec3::splat(1.0));
        assert!((g.variance().unwrap().pixels[0] - Vec3::splat(1.0 / 12.0)).abs().max_element() < 1e-7);
        // One sample: no estimate.
        assert!(film(&[1.0], &[2.0], 1.0).variance().is_none());
    }

    #[test]
    fn the_noise_estimate_averages_pixels_and_counts_non_finite_ones() {
        let mut f = film(&[1.0, 2.0, 3.0], &[5.0, 5.0, 5.0], 1.0);
        let noise = f.output().noise().unwrap();
        assert!((noise.mse - 1.0 / 6.0).abs() < 1e-7, "{noise:?}");
        assert!((noise.std_error - (1.0f64 / 3.0).sqrt() / 2.0).abs() < 1e-7, "{noise:?}");
        assert_eq!(noise.non_finite, 0);
        f.sum_sq[1].x = f64::NAN;
        let v = f.variance().unwrap();
        assert!(v.pixels[1].x.is_nan(), "a NaN stays NaN, it is not clamped to 0");
        let noise = f.output().noise().unwrap();
        assert_eq!(noise.non_finite, 1);
        assert!((noise.mse - 1.0 / 3.0).abs() < 1e-7, "{noise:?}");
        assert!(film(&[1.0], &[1.0], 1.0).output().noise().is_none());
    }
}
