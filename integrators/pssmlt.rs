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
//! function of (seed of `s`'s replica, `s`'s index within it, `i` or `c`) (`Replicas::stream`,
//! [`PrimarySamples`]). Bootstraps and chains run in parallel, the chains in rounds of
//! [`SEGMENT`](super::metropolis::SEGMENT) mutations (so the splat buffers' memory does not grow with the resolution), and
//! each round's splats are added to the film in (sample index, chain) order, so the image is
//! bit-identical at any thread count.
//!
//! The driver (bootstrap, chains, splats, rounds) is [`super::metropolis`], shared with `mmlt`;
//! this module is its target: `path`'s camera sample at a primary sample vector, one stratum.

use super::metropolis::{film_region, Contribution, Metropolis, Target};
use super::path::Path;
use super::{CameraEstimator, Integrator, Method, PathContext};
use crate::camera::Camera;
use crate::params::RenderParams;
use crate::render::{camera_for, Accumulate, CameraDims, Film, Progression, RenderOptions};
use crate::sampler::primary::{with_primary, PrimarySamples};
use crate::sampler::{Dim, Sampler};
use crate::scene::effects::Support;
use crate::scene::{Effect, Scene};
use crate::spectrum::{Channels, Wavelengths};
use crate::stats::RayCounts;
use glam::Vec2;
use std::ops::Range;

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

    /// The chains in flight and the bootstraps ([`Metropolis::working_memory`]).
    fn working_memory(&self, scene: &Scene, opts: &RenderOptions) -> u64 {
        let run = Run::new(scene, self, opts);
        run.metropolis(opts).working_memory()
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
        let run = Run::new(scene, self, opts);
        run.metropolis(opts).add(samples, film, progress);
    }
}

/// Everything fixed during a render: `path`'s camera samples over the film region.
struct Run<'a> {
    scene: &'a Scene,
    params: &'a RenderParams,
    camera: Camera,
    dims: CameraDims,
    /// Corner and size (pixel units) of the film region the film points cover.
    origin: Vec2,
    size: Vec2,
}

impl<'a> Run<'a> {
    fn new(scene: &'a Scene, integrator: &Pssmlt, opts: &'a RenderOptions) -> Run<'a> {
        let camera = camera_for(scene, opts.resolution);
        let (origin, size) = film_region(&camera);
        Run {
            scene,
            params: &opts.params,
            dims: CameraDims::resolve(scene, integrator, opts.spectral),
            camera,
            origin,
            size,
        }
    }

    /// The Metropolis runs over this target.
    fn metropolis(&self, opts: &RenderOptions) -> Metropolis<'_, Self> {
        Metropolis::new(self, &self.camera, opts.params.metropolis, opts, self.size)
    }
}

impl Target for Run<'_> {
    /// One: `path`'s samples.
    fn strata(&self) -> u32 {
        1
    }

    /// The camera sample of `state`'s current numbers and `path`'s radiance along it, its rays
    /// counted in `rays`. The camera's numbers are drawn in the camera pass's order: the film
    /// point, the lens, the time, the wavelength.
    fn evaluate(&self, state: &mut PrimarySamples, _stratum: u32, rays: &mut RayCounts) -> Contribution {
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
        Contribution::new(film, l)
    }
}
