//! Multiplexed Metropolis light transport (Hachisuka et al. 2014; pbrt-v4's `MLTIntegrator`)
//! over the bidirectional engine's strategies.
//!
//! # The method
//! The state space has one part per path depth `d` (scattering vertices, 0 to the maximum
//! depth): in part `d` a primary sample vector makes one path of depth `d` by one of the
//! engine's strategies (s, t) with `s + t = d + 2` (camera sub-path of `t` vertices, light
//! sub-path of `s`), chosen uniformly by one of its numbers, and its contribution is that
//! strategy's `bpt` MIS-weighted contribution times the number of strategies
//! ([`Multiplexed`]: the engine's own sub-paths, connections and weights, one strategy at a
//! time, without Russian roulette). Strategies with `t = 1` (light tracing's) land on the film
//! point their light vertex projects to, the others on the camera sample's. The chains move
//! between strategies by small steps of the strategy's number, so a path that one strategy
//! finds poorly is carried to the strategy that finds it well: Metropolis over the strategies,
//! MIS within each path.
//!
//! A chain never changes depth. The driver ([`super::metropolis`], shared with `pssmlt`)
//! bootstraps every depth with `bootstrap / (max_depth + 1)` vectors (rounded up), normalises by
//! `b̂ = (max_depth + 1) · mean(F)` (pbrt-v4's) and starts each chain from a bootstrap vector
//! chosen ∝ its importance, so the depths get chains in proportion to their share of `b̂`. Large
//! steps (`large_step`, default 0.3), small steps (`sigma`, default 0.01), expected-value splats,
//! rounds of 4096 mutations, one sample index = one independent run of as many mutations as the
//! crop window has pixels: exactly `pssmlt`'s, with `[render.mmlt]` settings.
//!
//! # Start-up bias and the normalisation's error
//! None and variance: as for `pssmlt` ([`super::metropolis`]), chains started by resampling the
//! bootstrap make every run unbiased from its first mutation, the normalisation's error
//! included, which is variance that the replicas measure with the rest.
//! `tests/mmlt.rs` measures the image mean of `cornell-glass` (32², depth 16) against `bpt`'s:
//! +0.45% ± 0.77% at 1 mutation per pixel (64 independent runs, 0.58 standard errors) and
//! −0.54% ± 0.51% at 16 (16 replicas of 16 runs, −1.07 standard errors).
//! Each depth is bootstrapped by `bootstrap / (max_depth + 1)` vectors only (241 at the
//! defaults), so `b̂` and the share of chains a depth gets vary from run to run. Where a run's
//! image mean is `b̂` times a constant (the glass slab of `tests/mmlt.rs`, lit only through
//! the emitter-hit strategy, one of four at its depth), its run-to-run deviation is that of
//! `b̂`: measured 13% per run (0.00876·√256 / 1.066), as the binomial count of the ≈ 60 of 241
//! depth-2 vectors that pick the one working strategy predicts (11%).
//!
//! # What it cannot do
//! - **Paths deeper than its maximum depth** (default 16, [`crate::methods::DEFAULT_MMLT_DEPTH`]):
//!   every depth costs its bootstrap and has no roulette to end it, so the default is lower than
//!   the other methods' 256; the light of deeper paths is missing.
//! - **What `bpt` cannot do**: a caustic of a point light seen through smooth glass (a
//!   specular–diffuse–specular path with a point light) has no strategy; neither has a light
//!   seen directly through glass by a light sub-path (emission points are not connected to
//!   the camera). Chains also cannot cross depths: a depth whose bootstrap finds no light is
//!   reached by no chain of that run.
//! - **Correlated noise**: within a run the mutations are correlated, so the image shows
//!   blotches at low `--spp`; per-pixel variance from the replicas stays valid.
//! - `--sampler` has no effect: primary samples are uniform numbers of the chains. The merging
//!   settings (`radius`, `max_light_paths`) do not apply: there is no merging and one light
//!   sub-path per sample.
//!
//! # Determinism, `--spp`, shards
//! As `pssmlt`: the numbers of every bootstrap vector and chain are a pure function of (seed,
//! sample index, vector or chain), splats join the film in (sample index, chain) order, the image
//! is bit-identical at any thread count; `--spp` is mutations per pixel; time budgets,
//! checkpoints, resume, shards (whole runs) and `merge` work as for `light`.

use super::metropolis::{film_region, Contribution, Metropolis, Target};
use super::vertex_merging::Multiplexed;
use super::{Algorithm, Integrator, Method, VertexMerging};
use crate::camera::Camera;
use crate::render::{camera_for, Accumulate, CameraDims, Film, Progression, RenderOptions};
use crate::sampler::primary::{with_primary, PrimarySamples};
use crate::scene::effects::Support;
use crate::scene::{Effect, Scene};
use crate::stats::RayCounts;
use glam::Vec2;
use std::ops::Range;

/// Multiplexed Metropolis light transport over the bidirectional engine's strategies.
pub struct Mmlt;

impl Integrator for Mmlt {
    fn method(&self) -> Method {
        Method::Mmlt
    }

    /// `bpt`'s: its strategies make every sample.
    fn support(&self, effect: Effect) -> Support {
        VertexMerging(Algorithm::Bpt).support(effect)
    }

    fn progression(&self) -> Progression<'_> {
        Progression::Accumulated(self)
    }

    /// The chains in flight and the bootstraps ([`Metropolis::working_memory`]).
    fn working_memory(&self, scene: &Scene, opts: &RenderOptions) -> u64 {
        Run::new(scene, self, opts).metropolis(opts).working_memory()
    }
}

impl Accumulate for Mmlt {
    /// A film whose pixel estimate is the mean over sample indices of each run's splats.
    fn film(&self, scene: &Scene, opts: &RenderOptions) -> Film {
        let camera = camera_for(scene, opts.resolution);
        let dims = CameraDims::resolve(scene, self, opts.spectral);
        Film::of_crop(&camera, 1.0, dims.wavelength, opts.replicas)
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
        Run::new(scene, self, opts).metropolis(opts).add(samples, film, progress);
    }
}

/// Everything fixed during a render: the engine's strategies over the film region.
struct Run<'a> {
    engine: Multiplexed<'a>,
    camera: Camera,
    /// Corner and size (pixel units) of the film region the camera samples cover.
    origin: Vec2,
    size: Vec2,
    /// The depths: 0 to the maximum depth.
    depths: u32,
}

impl<'a> Run<'a> {
    fn new(scene: &'a Scene, integrator: &Mmlt, opts: &'a RenderOptions) -> Run<'a> {
        let camera = camera_for(scene, opts.resolution);
        let (origin, size) = film_region(&camera);
        let dims = CameraDims::resolve(scene, integrator, opts.spectral);
        let region = size.x as f64 * size.y as f64;
        Run {
            engine: Multiplexed::new(scene, opts, camera.clone(), dims, region),
            camera,
            origin,
            size,
            depths: opts.params.max_depth.saturating_add(1),
        }
    }

    /// The Metropolis runs over this target.
    fn metropolis(&self, opts: &RenderOptions) -> Metropolis<'_, Self> {
        Metropolis::new(self, &self.camera, opts.params.metropolis, opts, self.size)
    }
}

impl Target for Run<'_> {
    /// One per path depth.
    fn strata(&self) -> u32 {
        self.depths
    }

    /// The sample of depth `stratum` at `state`'s current numbers.
    fn evaluate(&self, state: &mut PrimarySamples, stratum: u32, rays: &mut RayCounts) -> Contribution {
        let sample = with_primary(state, || self.engine.sample(stratum, self.origin, self.size));
        *rays += sample.rays;
        Contribution::new(sample.film, sample.l)
    }
}
