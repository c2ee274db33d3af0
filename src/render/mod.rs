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
//! image), `light` and the bidirectional methods. `ssaa` renders one fixed pattern whatever the
//! sample count ([`Progression::Fixed`]): a progressive render of it is that one image.
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
//! The sample indices of a render split into independent replicas ([`crate::sampler::Replicas`]:
//! index `s` in replica `s mod R`, each replica's streams from a seed of its own); the film keeps
//! each replica's sums beside the total. The variance of a pixel's estimate (its squared standard
//! error) is the spread of its replicas' means ([`ReplicaMeans::variance`]): unbiased for the
//! estimator actually used, the gain of Sobol' or stratified sampling within a replica included.
//! With fewer than two replicas holding samples there is no estimate.

use crate::camera::Camera;
use crate::image::Image;
use crate::methods::Method;
use crate::params::RenderParams;
use crate::sampler::{Replicas, SamplerKind};
use crate::scene::{Scene, SpectralMode};
use crate::stats::RayCounts;
use rayon::prelude::*;
use std::ops::Range;
use std::time::Duration;

mod camera_pass;
mod contract;
mod drivers;
mod film;
mod path_state;
mod progressive;
mod replicas;

pub use camera_pass::*;
pub use contract::*;
pub use drivers::*;
pub use film::*;
pub(crate) use path_state::{Branch, PathState, PendingBranches};
pub use progressive::*;
pub use replicas::*;

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
    /// How the sample indices split into independent randomisations, whose spread gives the
    /// variance ([`Replicas`]).
    pub replicas: Replicas,
}

impl RenderOptions {
    /// Options for `spp` samples with the scene's own settings for its own integrator
    /// (`[render] integrator`; for another method, use [`for_method`](Self::for_method)).
    pub fn from_scene(scene: &Scene, spp: u32) -> RenderOptions {
        let method = Method::from_name(&scene.settings.integrator).expect("compile checked the name");
        RenderOptions::of(scene, method, spp)
    }

    /// Options for `spp` samples of `integrator` with the scene's settings for that method
    /// (its `[render.METHOD]` table, else the method's own defaults, such as its full depth).
    pub fn for_method(scene: &Scene, integrator: &dyn Integrator, spp: u32) -> RenderOptions {
        RenderOptions::of(scene, integrator.method(), spp)
    }

    /// Options for `spp` samples of `method` with the scene's settings for it.
    fn of(scene: &Scene, method: Method, spp: u32) -> RenderOptions {
        let s = &scene.settings;
        RenderOptions {
            budget: Budget::Samples(spp),
            resolution: None,
            seed: s.seed,
            params: s.params_of(method, None),
            spectral: s.spectral,
            sampler: s.sampler,
            planned_spp: None,
            replicas: Replicas::DEFAULT,
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
    /// it cannot be estimated (fewer than two replicas with samples, or a deterministic sample
    /// pattern).
    pub variance: Option<Image>,
    /// The means of the render's replicas, whose spread gave `variance`; `None` as for it.
    pub replicas: Option<ReplicaMeans>,
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

/// The camera for a render, with the resolution override applied.
pub fn camera_for(scene: &Scene, resolution: Option<(u32, u32)>) -> Camera {
    match resolution {
        Some((w, h)) => scene.camera.clone().with_resolution(w, h),
        None => scene.camera.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec3, Vec3};

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
        for pixel in 0..film.sum.len() {
            for s in samples.clone() {
                film.add(pixel, s, DVec3::splat(value(pixel, s)));
            }
        }
    }

    #[test]
    fn passes_give_the_bits_of_one_range_and_a_stop_lands_between_passes() {
        let mut whole = Film::new(3, 2, 1.0, false, Replicas::DEFAULT);
        add_values(&mut whole, 0..40);
        let mut passes = Vec::new();
        let mut film = Film::new(3, 2, 1.0, false, Replicas::DEFAULT);
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
        assert_eq!(
            (film.sum.clone(), film.replica_sums.clone()),
            (whole.sum.clone(), whole.replica_sums.clone())
        );
        assert_eq!(passes.first(), Some(&(0..1)), "the first pass is one sample");
        assert!(passes.windows(2).all(|w| w[0].end == w[1].start) && passes.last().unwrap().end == 40);

        // A stop requested during the third pass: that pass finishes, nothing more is added.
        let calls = std::cell::Cell::new(0);
        let mut film = Film::new(3, 2, 1.0, false, Replicas::DEFAULT);
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
        let mut expected = Film::new(3, 2, 1.0, false, Replicas::DEFAULT);
        add_values(&mut expected, 0..film.samples);
        expected.samples = film.samples;
        assert_eq!(film.sum, expected.sum);
        assert_eq!(film.image().pixels, expected.image().pixels);

        // A stop requested before the render: one pass all the same; time budgets stop too.
        for budget in [Budget::Samples(40), Budget::Time(Duration::from_secs(3600))] {
            let mut film = Film::new(3, 2, 1.0, false, Replicas::DEFAULT);
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
        let mut whole = Film::new(3, 2, 1.0, false, Replicas::DEFAULT);
        add_values(&mut whole, 5..30);
        // Sample indices 5..30 of a 40-sample plan, stopped after a few passes, then resumed.
        let calls = std::cell::Cell::new(0);
        let (mut film, mut seen) = (Film::new(3, 2, 1.0, false, Replicas::DEFAULT), Vec::new());
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
        assert_eq!((film.sum.clone(), film.replica_sums.clone()), (whole.sum, whole.replica_sums));
        assert_eq!(seen.first(), Some(&(5..6)), "after every pass, from the first index");
        assert_eq!(seen.last(), Some(&(5..30)));
    }

    #[test]
    fn progress_covers_the_whole_render() {
        let seen = std::sync::Mutex::new(Vec::new());
        let mut film = Film::new(1, 1, 1.0, false, Replicas::DEFAULT);
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
        let pass = Pass::new(&scene, path.as_ref(), path.camera().unwrap(), &opts);
        let (mut once, mut split) = (pass.film(), pass.film());
        pass.add(&mut once, 0..6, 6, &|_, _| {});
        for range in [0..1, 1..3, 3..6] {
            pass.add(&mut split, range, 6, &|_, _| {});
        }
        assert_eq!(once.sum, split.sum);
        assert_eq!(once.replica_sums, split.replica_sums);
        assert_eq!(once.replica_samples, split.replica_samples);
        assert_eq!(once.rays, split.rays);
        assert!(once.sum.iter().any(|s| s.max_element() > 0.0), "a black image would pass trivially");
    }

    /// A 2×1 film with the per-sample values `a` (pixel 0) and `b` (pixel 1).
    fn film(a: &[f64], b: &[f64], norm: f64) -> Film {
        let mut film = Film::new(2, 1, norm, false, Replicas::DEFAULT);
        for (pixel, values) in [a, b].into_iter().enumerate() {
            for (s, &v) in values.iter().enumerate() {
                film.add(pixel, s as u32, DVec3::splat(v));
            }
        }
        film.advance(a.len() as u32);
        film
    }

    #[test]
    fn the_variance_is_that_of_the_mean() {
        // Samples 1, 2, 3, one per replica: replica means 1, 2, 3, variance of the mean
        // Σ(m − 2)² / (3·2) = 1/3.
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
        f.replica_sums[Replicas::DEFAULT.count() as usize].x = f64::NAN;
        let v = f.variance().unwrap();
        assert!(v.pixels[1].x.is_nan(), "a NaN stays NaN, it is not clamped to 0");
        let noise = f.output().noise().unwrap();
        assert_eq!(noise.non_finite, 1);
        assert!((noise.mse - 1.0 / 3.0).abs() < 1e-7, "{noise:?}");
        assert!(film(&[1.0], &[1.0], 1.0).output().noise().is_none());
    }
}
