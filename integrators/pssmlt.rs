//! Primary-sample-space Metropolis light transport (Kelemen et al. 2002; pbrt-v4's `MLTSampler`
//! with a path tracer as the path generator) over `path`'s estimator.
//!
//! # The method
//! A camera sample of `path` is a function of the uniform numbers it draws: the first two place
//! the film point anywhere on the image (not in a given pixel), the next ones the lens point,
//! the time and the wavelength where the scene calls for them, the rest are `path`'s own
//! ([`Path`]'s [`CameraEstimator::radiance`], unchanged). Write `u` for that vector, `L(u)` for
//! the sample's RGB radiance and `F(u) = Y(|L(u)|)` for its luminance (of the absolute values, so
//! that no non-zero contribution has zero importance). Markov chains over `u`
//! ([`PrimarySamples`]) visit states with density ∝ F, so the samples gather where the image is
//! bright in the path tracer's own terms, e.g. in caustics that `path` finds only by rare BSDF
//! samples. A proposal is a *large step* (every number fresh) with probability `large_step`
//! (default 0.3, pbrt-v4's), else a *small step* (each number moved by a normal offset of
//! deviation `sigma`, default 0.01 as in pbrt-v4, wrapped around [0, 1)). It is accepted with
//! probability `a = min(1, F(proposal)/F(current))`; both the proposal and the current state
//! splat, weighted `a` and `1 − a` (the expected values of Kelemen et al. and pbrt), so rejected
//! proposals still count.
//!
//! # Normalisation
//! Pixel `j` is `I_j = A ∫ L(u) k_j(p(u)) du` with `A` the area (in pixels) of the film region the
//! film points cover and `k_j` the pixel's normalised filter (the box by default): the camera
//! pass's box-filtered mean, as `light`'s splats estimate it. With `b = ∫ F du`, a chain whose
//! states `u_i` have density `F/b` estimates it as `(b·A/N) Σ_i L(u_i) k_j / F(u_i)`. `b` is
//! estimated from `bootstrap` independent uniform samples `u_1 … u_n` (their mean importance
//! `b̂`, as pbrt-v4 does), and every chain starts from one of them chosen with probability
//! `F_i / Σ F` (sampling–importance resampling).
//!
//! **The run is unbiased, start-up included.** Given the bootstrap, a chain's first state
//! contributes `b̂ · Σ_i (F_i/ΣF) · g(u_i) = (1/n) Σ_i F_i g(u_i)` in expectation (`g = L k_j / F`),
//! and after `k` mutations `(1/n) Σ_i F_i (Pᵏg)(u_i)`, `P` the Metropolis kernel; over the uniform
//! `u_i` that is `∫ F Pᵏg du = b ∫ π Pᵏg = b ∫ π g = I_j` (`π = F/b` is stationary for `P`). So no
//! burn-in is needed and the correlation of `b̂` with the chains' starts biases nothing; the
//! normalisation's error is variance, which the replicas measure with the rest
//! (`tests/pssmlt.rs` measures the image mean against `path` at 1 and at 16 mutations per pixel).
//! A run whose bootstrap finds no light (`b̂ = 0`) adds zero, its unbiased estimate given the
//! bootstrap (every `L(u_i)` is zero too).
//!
//! The film region is the crop window widened by the filter's radius (clamped to the film), so
//! a crop window costs only its own pixels and every film point can land in a crop pixel.
//!
//! # Sample indices: `--spp`, replicas, shards and time budgets
//! **One sample index is one whole, independent Metropolis run** of `N` mutations, `N` the
//! pixel count of the crop window: its own bootstrap of `bootstrap` samples, its own `b`, and
//! `chains` chains (default 64) of `N/chains` mutations each, started from its own bootstrap.
//! So `--spp` is the number of mutations per pixel, every sample index adds one unbiased estimate
//! of the whole image to the film ([`Film::add`]), the replicas' means are
//! independent (the variance the film reports is honest, the normalisation's error included),
//! and progressive renders, checkpoints, resume, time budgets, shards and `merge` work exactly
//! as for `light`: a shard owns whole sample indices, hence whole chains with their own
//! normalisation, and merging adds films of independent runs.
//!
//! # What it cannot do (beyond `path`)
//! - **Light `path` cannot find.** The chains explore `path`'s own samples: a caustic of a point
//!   light seen through or cast by smooth glass (no next-event estimation through glass, no BSDF
//!   sample hits a point) stays black, as in `path`. What Metropolis adds is effort where `path`'s
//!   samples are rare but possible (small area lights seen through glass).
//! - **Rare light at small `bootstrap`.** A run explores from its bootstrap samples and by large
//!   steps; light that none of them finds is reached only by large steps, so a run of few
//!   mutations may miss it. The estimate stays unbiased, but such runs make the variance large.
//! - **Correlated noise.** Within a run the mutations are correlated: the image shows blotches
//!   at low `--spp`, not per-pixel noise; per-pixel variance from the replicas stays valid.
//! - `--sampler` has no effect: primary samples are uniform numbers of the chains.
//!
//! # Determinism
//! The random numbers of bootstrap sample `i` and chain `c` of sample index `s` are a pure
//! function of (seed of `s`'s replica, `s`'s index within it, `i` or `c`) ([`Replicas::stream`],
//! [`PrimarySamples`]). Bootstraps and chains run in parallel, the chains in rounds of
//! [`SEGMENT`] mutations (so the splat buffers' memory does not grow with the resolution), and
//! each round's splats are added to the film in (sample index, chain) order, so the image is
//! bit-identical at any thread count.

use super::path::Path;
use super::splat_film::{film_splats, SampleSplats, SplatBuffer};
use super::{CameraEstimator, Integrator, Method, PathContext};
use crate::camera::Camera;
use crate::metrics::LUMA;
use crate::params::{MetropolisParams, RenderParams};
use crate::render::{camera_for, Accumulate, CameraDims, Film, Progression, RenderOptions};
use crate::sampler::primary::{with_primary, PrimarySamples};
use crate::sampler::{pixel_key, Dim, Replicas, Sampler};
use crate::scene::effects::Support;
use crate::scene::{Effect, Scene};
use crate::spectrum::{Channels, Wavelengths};
use crate::stats::RayCounts;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};

/// Primary-sample-space Metropolis light transport over `path`.
pub struct Pssmlt;

impl Integrator for Pssmlt {
    fn method(&self) -> Method {
        Method::Pssmlt
    }

    /// `path`'s: its estimator draws every sample.
    fn support(&self, effect: Effect) -> Support {
        Path.support(effect)
    }

    fn progression(&self) -> Progression<'_> {
        Progression::Accumulated(self)
    }

    fn working_memory(&self, scene: &Scene, opts: &RenderOptions) -> u64 {
        let run = Run::new(scene, self, opts);
        // The chains in flight: each a segment's splats (two per mutation, a pixel index and an
        // RGB value each, 16 bytes with padding, over the filter's footprint) and its vector;
        // and the bootstraps' importances. None of it grows with the resolution.
        let footprint = (2.0 * run.camera.filter.radius()).ceil().max(1.0) as u64;
        let chains = run.group() as u64 * run.settings.chains as u64;
        let bootstrap = run.group() as u64 * run.settings.bootstrap as u64 * 16;
        chains * (SEGMENT * 2 * 16 * footprint * footprint + 4096) + bootstrap
    }
}

impl Accumulate for Pssmlt {
    /// A film whose pixel estimate is the mean over sample indices of each run's splats.
    fn film(&self, scene: &Scene, opts: &RenderOptions) -> Film {
        let run = Run::new(scene, self, opts);
        Film::of_crop(&run.camera, 1.0, run.dims.wavelength, opts.replicas)
    }

    /// Sample index `s` is one Metropolis run of as many mutations as the crop window has
    /// pixels (see the module documentation).
    fn add_samples(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        samples: Range<u32>,
        film: &mut Film,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) {
        Run::new(scene, self, opts).add(samples, film, progress);
    }
}

/// One evaluation of the path tracer at a primary sample vector.
#[derive(Clone, Copy, Debug)]
struct Contribution {
    /// The film point (pixel units).
    film: Vec2,
    /// The RGB radiance.
    l: Vec3,
    /// The importance `Y(|L|)`; 0 for a non-finite radiance.
    f: f32,
}

/// Mutations a chain makes per round: the unit of the splat buffers, which bounds their memory
/// whatever the resolution.
const SEGMENT: u64 = 4096;

/// The splats of one segment of a chain, in the order it made them.
struct ChainSplats {
    splats: SplatBuffer,
    rays: RayCounts,
    non_finite: u64,
}

/// A chain between rounds: its primary sample vector, its current state and what is left.
struct Chain {
    /// The sample index whose run it belongs to.
    sample: u32,
    /// The run's normalisation.
    b: f64,
    state: PrimarySamples,
    current: Contribution,
    /// Mutations still to make.
    remaining: u64,
}

/// Everything fixed during a render.
struct Run<'a> {
    scene: &'a Scene,
    params: &'a RenderParams,
    settings: MetropolisParams,
    camera: Camera,
    dims: CameraDims,
    seed: u64,
    replicas: Replicas,
    /// Corner and size (pixel units) of the film region the film points cover.
    origin: Vec2,
    size: Vec2,
    /// Mutations per sample index: the pixels of the crop window.
    mutations: u64,
}

impl<'a> Run<'a> {
    fn new(scene: &'a Scene, integrator: &Pssmlt, opts: &'a RenderOptions) -> Run<'a> {
        let camera = camera_for(scene, opts.resolution);
        let (crop, r) = (camera.crop, camera.filter.radius());
        // Film points that reach a crop pixel: the window widened by the filter's reach beyond
        // a pixel's own square (none for the box), clamped to the film.
        let reach = (r - 0.5).max(0.0);
        let lo = Vec2::new(crop.x as f32 - reach, crop.y as f32 - reach).max(Vec2::ZERO);
        let hi = Vec2::new((crop.x + crop.width) as f32 + reach, (crop.y + crop.height) as f32 + reach)
            .min(Vec2::new(camera.width as f32, camera.height as f32));
        Run {
            scene,
            params: &opts.params,
            settings: opts.params.metropolis,
            dims: CameraDims::resolve(scene, integrator, opts.spectral),
            mutations: crop.pixels() as u64,
            camera,
            seed: opts.seed,
            replicas: opts.replicas,
            origin: lo,
            size: hi - lo,
        }
    }

    /// Sample indices run together: enough chains to keep every thread busy.
    fn group(&self) -> usize {
        (4 * rayon::current_num_threads()).div_ceil(self.settings.chains as usize).max(1)
    }

    /// The key of the numbers of sample index `s`'s bootstrap sample `i` (`chain` false) or
    /// chain `i` (`chain` true): a pure function of (seed, s, i).
    fn key(&self, s: u32, chain: bool, i: u32) -> u64 {
        let stream = self.replicas.stream(self.seed, s, 0);
        pixel_key(pixel_key(stream.seed, stream.index as u64), 2 * i as u64 + chain as u64)
    }

    /// A chain's numbers keyed `start` for its first state and `chain` for its mutations.
    fn state(&self, start: u64, chain: u64) -> PrimarySamples {
        let m = &self.settings;
        PrimarySamples::new(start, chain, m.sigma as f64, m.large_step as f64)
    }

    /// Run the sample indices `samples` and add their splats to `film`. A few sample indices
    /// run at a time ([`Run::group`]); their chains advance in rounds of [`SEGMENT`] mutations,
    /// all in parallel, and each round's splats join the film in (sample index, chain) order.
    fn add(&self, samples: Range<u32>, film: &mut Film, progress: &(dyn Fn(u64, u64) + Sync)) {
        let total = samples.len() as u64 * self.mutations;
        let done = AtomicU64::new(0);
        // Each chain's splats carry b/F; a run's N mutations cover the region of area A.
        let scale = self.size.x as f64 * self.size.y as f64 / self.mutations as f64;
        let all: Vec<u32> = samples.collect();
        for group in all.chunks(self.group()) {
            let started: Vec<(RayCounts, Vec<Chain>)> = group
                .par_iter()
                .map(|&s| {
                    let (b, cumulative, mut rays) = self.bootstrap(s);
                    let chains = (0..self.settings.chains)
                        .filter_map(|c| self.start_chain(s, c, b, &cumulative, &mut rays))
                        .collect();
                    (rays, chains)
                })
                .collect();
            let mut chains = Vec::new();
            for (rays, c) in started {
                film.rays += rays;
                chains.extend(c);
            }
            while chains.iter().any(|c| c.remaining > 0) {
                let round: Vec<ChainSplats> = chains
                    .par_iter_mut()
                    .map(|chain| {
                        let n = chain.remaining.min(SEGMENT);
                        let out = self.advance(chain, n);
                        progress(done.fetch_add(n, Ordering::Relaxed) + n, total);
                        out
                    })
                    .collect();
                for (chain, mut out) in chains.iter().zip(round) {
                    SampleSplats::new(chain.sample, scale).add(film, &mut out.splats);
                    film.rays += out.rays;
                    film.non_finite += out.non_finite;
                }
            }
        }
    }

    /// Sample index `s`'s bootstrap: the normalisation `b` (the mean importance of its uniform
    /// samples), the cumulative importance of its samples (where chains start) and its rays.
    fn bootstrap(&self, s: u32) -> (f64, Vec<f64>, RayCounts) {
        let n = self.settings.bootstrap;
        let evaluated: Vec<(f32, RayCounts)> = (0..n)
            .into_par_iter()
            .map(|i| {
                let mut rays = RayCounts::default();
                let f = self.evaluate(&mut self.state(self.key(s, false, i), 0), &mut rays).f;
                (f, rays)
            })
            .collect();
        let mut cumulative = Vec::with_capacity(n as usize);
        let (mut sum, mut rays) = (0.0f64, RayCounts::default());
        for (f, r) in evaluated {
            sum += f as f64;
            cumulative.push(sum);
            rays += r;
        }
        (sum / n as f64, cumulative, rays)
    }

    /// Chain `c` of sample index `s` with normalisation `b`, started from a bootstrap sample
    /// chosen ∝ its importance (`cumulative`), to make `N/chains` mutations; `None` when the run
    /// found no light (or the chain has no mutation).
    fn start_chain(&self, s: u32, c: u32, b: f64, cumulative: &[f64], rays: &mut RayCounts) -> Option<Chain> {
        let chains = self.settings.chains as u64;
        let n = (c as u64 + 1) * self.mutations / chains - c as u64 * self.mutations / chains;
        let total = cumulative.last().copied().unwrap_or(0.0);
        if !(b > 0.0 && total > 0.0) || n == 0 {
            return None;
        }
        let key = self.key(s, true, c);
        let u = Sampler::independent(key, 0, 0).get_1d(Dim::Other) as f64 * total;
        let start = cumulative.partition_point(|&w| w <= u).min(cumulative.len() - 1) as u32;
        let mut state = self.state(self.key(s, false, start), key);
        let current = self.evaluate(&mut state, rays);
        debug_assert!(current.f > 0.0, "a chain starts from a sample with light");
        Some(Chain { sample: s, b, state, current, remaining: n })
    }

    /// The next `n` mutations of `chain`: their splats, weighted by the acceptance probability
    /// (the proposal's) and its complement (the current state's).
    fn advance(&self, chain: &mut Chain, n: u64) -> ChainSplats {
        let mut out = ChainSplats {
            splats: SplatBuffer::with_capacity(2 * n as usize),
            rays: RayCounts::default(),
            non_finite: 0,
        };
        let b = chain.b;
        for _ in 0..n {
            let state = &mut chain.state;
            state.start_iteration();
            let proposed = self.evaluate(state, &mut out.rays);
            if !proposed.l.is_finite() {
                out.non_finite += 1;
            }
            let a = (proposed.f / chain.current.f).min(1.0);
            if a > 0.0 {
                self.splat(&proposed, a as f64 * b, &mut out.splats);
            }
            if a < 1.0 {
                self.splat(&chain.current, (1.0 - a) as f64 * b, &mut out.splats);
            }
            if state.accept_draw() < a as f64 {
                state.accept();
                chain.current = proposed;
            } else {
                state.reject();
            }
        }
        chain.remaining -= n;
        out
    }

    /// Splat `weight · L / F` of `sample` into the pixels its film point reaches.
    fn splat(&self, sample: &Contribution, weight: f64, out: &mut SplatBuffer) {
        let value = sample.l * (weight / sample.f as f64) as f32;
        film_splats(&self.camera, sample.film, value, |pixel, v| out.add_visible(pixel, v));
    }

    /// The camera sample of `state`'s current numbers and `path`'s radiance along it, its rays
    /// counted in `rays`. The camera's numbers are drawn in the camera pass's order: the film
    /// point, the lens, the time, the wavelength.
    fn evaluate(&self, state: &mut PrimarySamples, rays: &mut RayCounts) -> Contribution {
        let (camera, dims) = (&self.camera, self.dims);
        let (film, l, traced) = with_primary(state, || {
            let mut ctx = PathContext::new(Sampler::primary());
            let film = self.origin + ctx.sampler.get_2d(Dim::Pixel) * self.size;
            let lens = if dims.lens { ctx.sampler.get_2d(Dim::Lens) } else { Vec2::ZERO };
            let (open, close) = camera.shutter;
            let time = if dims.time { open + (close - open) * ctx.sampler.get_1d(Dim::Time) } else { open };
            if dims.wavelength {
                ctx.channels = Channels::Spectral(Wavelengths::sample(ctx.sampler.get_1d(Dim::Wavelength)));
            }
            let ray = camera.generate_ray_lens(film, lens, time);
            ctx.rays.primary += 1;
            let l = Path.radiance(self.scene, self.params, &ray, &mut ctx);
            // In RGB, with what the camera ray itself saw (an emitter, the background): in
            // spectral mode `path` leaves that in the context ([`PathContext::rgb`]).
            (film, ctx.rgb(l), ctx.rays)
        });
        *rays += traced;
        let f = if l.is_finite() {
            (LUMA[0] * l.x.abs() as f64 + LUMA[1] * l.y.abs() as f64 + LUMA[2] * l.z.abs() as f64) as f32
        } else {
            0.0
        };
        Contribution { film, l, f }
    }
}
