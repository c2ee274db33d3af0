//! The Metropolis driver shared by `pssmlt` and `mmlt`: bootstrap, normalisation, chains started
//! by sampling–importance resampling, mutations with expected-value splats in rounds, sample
//! indices as whole independent runs. A method supplies only its [`Target`]: the image
//! contribution of a primary sample vector in one of its strata of the state space (`pssmlt`:
//! one, `path`'s samples; `mmlt`: one per path depth).
//!
//! # One sample index, one run
//! Sample index `s` is one Metropolis run of `N` mutations, `N` the pixel count of the crop
//! window. Its bootstrap evaluates `n` independent uniform vectors, vector `i` in stratum
//! `i mod K` (`K` the target's strata; `n` is `bootstrap` rounded up to a multiple of `K`, so
//! every stratum gets `n/K`). Its normalisation is `b̂ = K · mean(F_i)`: the state space is the
//! union of the strata, whose uniform density gives each stratum the probability `1/K`, so `b̂`
//! estimates `b = Σ_k ∫ F_k du` without bias. Each of its `chains` chains starts from a
//! bootstrap vector chosen ∝ `F_i` (so a stratum gets chains in proportion to its share of
//! `b̂`, pbrt-v4's way of distributing chains over depths) and stays in that vector's stratum,
//! making `N/chains` mutations (a large step with probability `large_step`, else a small step
//! of deviation `sigma`; [`PrimarySamples`]). Every mutation splats the proposal with weight
//! `a` and the current state with `1 − a` (`a` the acceptance probability), each `b̂ · L/F`
//! times `A/N` (`A` the film region's area in pixels: the target's contributions are per unit
//! of the region's uniform measure).
//!
//! The run is unbiased, start-up included: given the bootstrap, a chain's state after `k`
//! mutations contributes `(K/n) Σ_i F_i (Pᵏg)(u_i)` in expectation (`g = L k_j / F`, `P` the
//! Metropolis kernel, which leaves `π = F/b` invariant on each stratum), whose expectation over
//! the uniform `u_i` is `Σ_k ∫ F_k Pᵏg = b ∫ π g = I_j`. So no burn-in is needed, and the
//! normalisation's error is variance that the replicas measure with the rest. A run whose
//! bootstrap finds no light adds zero (its unbiased estimate given the bootstrap).
//!
//! # Determinism
//! The numbers of bootstrap vector `i` and chain `c` of sample index `s` are a pure function of
//! (seed of `s`'s replica, `s`'s index within it, `i` or `c`) ([`Replicas::stream`]). Bootstraps
//! and chains run in parallel, the chains in rounds of [`SEGMENT`] mutations, and each round's
//! splats join the film in (sample index, chain) order: the image is bit-identical at any
//! thread count, and shards, resume and merge work as for `light`.

use super::splat_film::{film_splats, SampleSplats, SplatBuffer};
use crate::camera::Camera;
use crate::metrics::LUMA;
use crate::params::MetropolisParams;
use crate::render::{Film, RenderOptions};
use crate::sampler::primary::PrimarySamples;
use crate::sampler::{pixel_key, Dim, Replicas, Sampler};
use crate::stats::RayCounts;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};

/// What a Metropolis method explores: the contribution of a primary sample vector.
pub(super) trait Target: Sync {
    /// The strata of the state space (at least 1): a chain stays in the stratum it starts in.
    fn strata(&self) -> u32;

    /// The contribution of `state`'s current numbers in stratum `stratum`, its rays counted in
    /// `rays`.
    fn evaluate(&self, state: &mut PrimarySamples, stratum: u32, rays: &mut RayCounts) -> Contribution;
}

/// One evaluation of a target at a primary sample vector.
#[derive(Clone, Copy, Debug)]
pub(super) struct Contribution {
    /// The film point (pixel units).
    pub film: Vec2,
    /// The RGB value, per unit of the film region's uniform measure (a camera sample's
    /// radiance).
    pub l: Vec3,
    /// The importance `Y(|L|)`; 0 for a non-finite value.
    pub f: f32,
}

impl Contribution {
    /// The value `l` landing on the film point `film`, its importance the luminance of its
    /// absolute values (so that no non-zero contribution has zero importance).
    pub fn new(film: Vec2, l: Vec3) -> Contribution {
        let f = if l.is_finite() {
            (LUMA[0] * l.x.abs() as f64 + LUMA[1] * l.y.abs() as f64 + LUMA[2] * l.z.abs() as f64) as f32
        } else {
            0.0
        };
        Contribution { film, l, f }
    }
}

/// Mutations a chain makes per round: the unit of the splat buffers, which bounds their memory
/// whatever the resolution.
pub(super) const SEGMENT: u64 = 4096;

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
    /// Its stratum.
    stratum: u32,
    /// The run's normalisation.
    b: f64,
    state: PrimarySamples,
    current: Contribution,
    /// Mutations still to make.
    remaining: u64,
}

/// The film region whose points a camera sample of `camera` covers: corner and size (pixel
/// units). The crop window widened by the filter's reach beyond a pixel's own square (none for
/// the box), clamped to the film, so that a crop window costs only its own pixels and every
/// film point can land in a crop pixel.
pub(super) fn film_region(camera: &Camera) -> (Vec2, Vec2) {
    let (crop, r) = (camera.crop, camera.filter.radius());
    let reach = (r - 0.5).max(0.0);
    let lo = Vec2::new(crop.x as f32 - reach, crop.y as f32 - reach).max(Vec2::ZERO);
    let hi = Vec2::new((crop.x + crop.width) as f32 + reach, (crop.y + crop.height) as f32 + reach)
        .min(Vec2::new(camera.width as f32, camera.height as f32));
    (lo, hi - lo)
}

/// The Metropolis runs of a render: the target, where it splats and the settings.
pub(super) struct Metropolis<'a, T: Target> {
    /// What the chains explore.
    pub target: &'a T,
    /// The camera whose crop window the splats land in.
    pub camera: &'a Camera,
    /// The chains' settings.
    pub settings: MetropolisParams,
    /// The render's seed and replicas.
    pub seed: u64,
    /// The replicas the sample indices belong to.
    pub replicas: Replicas,
    /// Area (pixels) of the film region the target's film points cover uniformly.
    pub area: f64,
    /// Mutations per sample index: the pixels of the crop window.
    pub mutations: u64,
}

impl<'a, T: Target> Metropolis<'a, T> {
    /// The runs of `target` for a render with `opts` on `camera`, whose film points cover the
    /// region of size `size` (pixels).
    pub fn new(
        target: &'a T,
        camera: &'a Camera,
        settings: MetropolisParams,
        opts: &RenderOptions,
        size: Vec2,
    ) -> Self {
        Metropolis {
            target,
            camera,
            settings,
            seed: opts.seed,
            replicas: opts.replicas,
            area: size.x as f64 * size.y as f64,
            mutations: camera.crop.pixels() as u64,
        }
    }

    /// Sample indices run together: enough chains to keep every thread busy.
    fn group(&self) -> usize {
        (4 * rayon::current_num_threads()).div_ceil(self.settings.chains as usize).max(1)
    }

    /// Bootstrap vectors per sample index: `bootstrap` rounded up to a multiple of the strata.
    fn bootstraps(&self) -> u32 {
        let k = self.target.strata().max(1);
        self.settings.bootstrap.div_ceil(k).saturating_mul(k)
    }

    /// The chains in flight and the bootstraps' importances, in bytes: each chain a segment's
    /// splats (two per mutation, a pixel index and an RGB value each, 16 bytes with padding,
    /// over the filter's footprint) and its vector. None of it grows with the resolution.
    pub fn working_memory(&self) -> u64 {
        let footprint = (2.0 * self.camera.filter.radius()).ceil().max(1.0) as u64;
        let chains = self.group() as u64 * self.settings.chains as u64;
        let bootstrap = self.group() as u64 * self.bootstraps() as u64 * 16;
        chains * (SEGMENT * 2 * 16 * footprint * footprint + 4096) + bootstrap
    }

    /// The key of the numbers of sample index `s`'s bootstrap vector `i` (`chain` false) or
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
    /// run at a time ([`Metropolis::group`]); their chains advance in rounds of [`SEGMENT`]
    /// mutations, all in parallel, and each round's splats join the film in (sample index,
    /// chain) order.
    pub fn add(&self, samples: Range<u32>, film: &mut Film, progress: &(dyn Fn(u64, u64) + Sync)) {
        let total = samples.len() as u64 * self.mutations;
        let done = AtomicU64::new(0);
        // Each chain's splats carry b/F; a run's N mutations cover the region of area A.
        let scale = self.area / self.mutations as f64;
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

    /// Sample index `s`'s bootstrap: the normalisation `b` (the strata's count times the mean
    /// importance of its uniform vectors), the cumulative importance of its vectors (where
    /// chains start) and its rays.
    fn bootstrap(&self, s: u32) -> (f64, Vec<f64>, RayCounts) {
        let n = self.bootstraps();
        let strata = self.target.strata().max(1);
        let evaluated: Vec<(f32, RayCounts)> = (0..n)
            .into_par_iter()
            .map(|i| {
                let mut rays = RayCounts::default();
                let mut state = self.state(self.key(s, false, i), 0);
                let f = self.target.evaluate(&mut state, i % strata, &mut rays).f;
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
        (sum * strata as f64 / n as f64, cumulative, rays)
    }

    /// Chain `c` of sample index `s` with normalisation `b`, started from a bootstrap vector
    /// chosen ∝ its importance (`cumulative`), in that vector's stratum, to make `N/chains`
    /// mutations; `None` when the run found no light (or the chain has no mutation).
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
        let stratum = start % self.target.strata().max(1);
        let mut state = self.state(self.key(s, false, start), key);
        let current = self.target.evaluate(&mut state, stratum, rays);
        debug_assert!(current.f > 0.0, "a chain starts from a sample with light");
        Some(Chain { sample: s, stratum, b, state, current, remaining: n })
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
            let proposed = self.target.evaluate(state, chain.stratum, &mut out.rays);
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
        film_splats(self.camera, sample.film, value, |pixel, v| out.add_visible(pixel, v));
    }
}
