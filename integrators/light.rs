//! Light tracing (particle tracing; Veach 1997 §10.2, pbrt's light path integrator): paths start
//! on the lights and every vertex that can be seen from the camera is splatted into the film.
//!
//! # The method
//! A path starts on a light chosen uniformly among the scene's lights (probability 1/N): a point
//! light emits uniformly over the sphere, an area light (quad, sphere, emissive surface) from a
//! point uniform over its area in a cosine-distributed direction about the emitting normal (a
//! two-sided emissive surface picks its side with probability ½), the environment in a uniform
//! direction from a point of the scene's bounding disk facing it ([`crate::light`]). The path
//! then scatters by sampling the BSDF in [`TransportMode::Importance`], absorbs by Beer–Lambert
//! inside media, and ends by Russian roulette after three bounces or at `--max-depth` scattering
//! vertices (the same bound as `path`: both include paths with up to `max_depth` scattering
//! vertices between the light and the camera).
//!
//! The emission point of an area light (that is how lights are seen directly) and every
//! non-specular surface vertex are connected to the camera by a straight, opaque visibility ray
//! and splat into the pixel they project to. Emission is never counted where a light path hits an
//! emitter; only camera connections make the image.
//!
//! # Importance and pixel-area normalisation
//! The camera pass estimates, for pixel j, the mean radiance over the pixel's area on the image
//! plane at distance 1 (a box filter): `I_j = (1/A_pix) ∫_pixel L(x_film) dA_film`, with
//! `A = (2·tan(fov/2))²·aspect` the area of that plane and `A_pix = A/(w·h)`. A film point whose
//! ray makes the angle θ with the view axis is at distance 1/cos θ and the plane is tilted by θ
//! against the ray, so `dA_film = dω / cos³θ`; and the solid angle of a surface element at
//! distance d seen at cosine `cos_v` from its normal is `dω = |cos_v| dA / d²`. Hence
//!
//! `I_j = (1/A_pix) ∫_{x ↦ j} L(x → camera) · |cos_v| / (d² · cos³θ) dA(x)`.
//!
//! This is the pinhole importance `W_e = 1/(A·cos⁴θ)` (pbrt) times the cosine `cos θ` the
//! camera's geometry term contributes. With β the weight of a light path arriving at vertex x
//! (the particle-tracing identity `E[Σ β h(x, ω_in)] = ∫∫ L_in(x, ω_in) |cos_in| h dω dA`), one
//! vertex contributes `β · f(ω_in → ω_cam) · |cos_v| / (d² cos³θ)` and the emission point of an
//! area light `L_e(x → camera) · |cos_v| / (p_light · p_area · d² cos³θ)`. Averaged over the
//! `N = spp·w·h` light paths and divided by `A_pix`, every splat is scaled by
//! `w·h / (N·A) = 1 / (spp·A)`: "spp" means the same number of paths (rays from the camera or
//! from the lights) as for the camera methods, and the pixel value estimates the same quantity
//! as the camera pass's box-filtered mean. `tests/light_tracing.rs` checks this against `path`.
//!
//! A thin lens is the same measurement averaged over the lens: a point on the lens disk is
//! sampled uniformly, the vertex is connected to it, and the splat lands where the camera pass's
//! ray from that lens point through the focal plane comes from. With θ the angle between the
//! connection and the view axis, `dω = cos³θ dA_film` still holds for rays from one lens point
//! (the focal plane is parallel to the film), the lens area cancels against the density of the
//! lens sample, and the contribution has the pinhole's form.
//!
//! # Russian roulette
//! The roulette uses the path's throughput since emission (the product of `f·|cos|/pdf`, without
//! the emitted power). In importance mode the BTDF of refraction carries no `1/η'²` (the flux of a
//! beam is conserved across an interface, only its radiance changes), so the throughput through
//! lossless glass stays 1 and light inside glass is not killed early: no `η²` correction is
//! needed, unlike the radiance throughput of `path`.
//!
//! # Dispersion
//! In spectral mode a path carries three wavelengths (`crate::spectrum`). Where smooth dispersive
//! glass parts them, the path splits as `path`'s does, by the same decision
//! ([`PathContext::part_wavelengths`], in importance mode): each wavelength samples the interface
//! at its own index with the same numbers; if all three reflect they go on together, otherwise
//! the path goes on with its lead wavelength's channel alone and every other wavelength becomes
//! a branch ([`LightWalk`], its channel's throughput, ray and medium), set aside and run when the
//! walk in flight ends, replaying its random numbers from the split. Each channel is then its own
//! unbiased estimate, with weight 1. At rough dispersive glass the wavelengths go on together,
//! weighted by MIS over their densities, and light that the microsurface scattered several times
//! splits the same way (`crate::integrators::wavelengths`, the decisions `path` takes, here in
//! importance mode); the connection to the camera there evaluates each wavelength's BSDF.
//!
//! # What light tracing cannot see
//! - **Specular surfaces seen directly.** A smooth mirror or smooth glass scatters only into delta
//!   directions, so a vertex on it can never be connected to the camera (the chance that a
//!   sampled direction hits the pinhole, or a given lens point, is zero), and the straight
//!   visibility ray of a diffuse vertex behind it is blocked by it. Smooth mirrors and smooth
//!   glass seen directly from the camera, with everything seen in or through them (reflections,
//!   the view through a window), render **black**: an L(S)*S-E path has no vertex to splat. What
//!   specular surfaces do to light elsewhere (caustics on diffuse surfaces, including those of
//!   point lights, which `path` cannot find) is rendered, because the diffuse receiver connects.
//!   Rough mirrors and rough glass do connect, but the nearly specular ones are very noisy.
//! - **The environment and the background seen directly.** Paths start on the environment and
//!   light the scene, but a camera ray that leaves the scene meets no vertex to splat: the
//!   environment and the background colour, seen directly or through specular surfaces, render
//!   black.
//! - **Point lights** are not visible either (as for every method).
//!
//! # Determinism
//! The random stream of a path is a pure function of (seed, path index). Path `j` of sample index
//! `s` draws from the seed of the replica of `s` ([`Replicas::stream`]), as path `k = i·w·h + j`
//! of that replica, with `i` the index of `s` within it: the sampler of "pixel" `k`
//! (independent sampler), of group `k / 16`, sample `k mod 16` (the stratified sampler: every
//! group of 16 consecutive paths is stratified in each dimension), or of group `k / 65536`,
//! sample `k mod 65536` (Sobol': consecutive paths are one scrambled sequence). So the replicas
//! share no sequence and are independent.
//! Paths are traced in fixed chunks of [`CHUNK_PATHS`]; each chunk appends its splats to its own
//! buffer, and the buffers are merged into an f64 film in chunk order, so the image is
//! bit-identical at any thread count. Chunks are traced in batches of a few per thread and each
//! batch is merged while the next one is traced, so memory stays bounded.
//!
//! # Sample indices: progressive rendering and variance
//! Sample index `s` is the `w·h` paths `s·w·h .. (s+1)·w·h` (chunks never straddle two), and the
//! film is summed in path order whatever the ranges asked for, so rendering the sample indices
//! `0..a` and then `a..b` gives the bits of `0..b` at once ([`crate::render::Accumulate`]). The
//! splats of one sample index form one image, an unbiased estimate on its own; the spread of
//! the replicas' means gives each pixel's variance ([`crate::render`]).
//! A render adds them in passes of whole sample indices ([`render_accumulated`]), so a Ctrl-C
//! lands between sample indices: the image of the `k` indices done is, bit for bit, a plain
//! `k`-sample render.

use super::shadow_queue::{shadow_lanes, Shadows};
use super::splat_film::{CameraTarget, SampleSplats, SplatBuffer};
use super::{bsdf_numbers, pick_light, Integrator, Method, PathContext, RenderParams, ROULETTE_DEPTH};
use crate::bsdf::{Scattering, ShadingFrame, TransportMode};
use crate::camera::Camera;
use crate::geometry::{spawn_origin, Ray, SurfaceHit};
use crate::lanes::LaneScene;
use crate::light::SceneSphere;
use crate::lighting::crossing;
use crate::render::{
    camera_for, Accumulate, Branch, CameraDims, Film, PendingBranches, Progression, RenderOptions,
};
use crate::sampler::{Dim, Replicas, Sampler, SamplerKind};
use crate::scene::effects::Support;
use crate::scene::{Effect, Scene};
use crate::spectrum::{Channels, Wavelengths, HERO_WAVELENGTHS};
use crate::stats::RayCounts;
use glam::Vec3;
use rand::SeedableRng;
use rand_pcg::Pcg32;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};

/// Light paths per chunk of work (the unit of determinism: splats are merged chunk by chunk).
pub const CHUNK_PATHS: u64 = 1 << 12;

/// Consecutive paths stratified together by the stratified sampler.
const STRATUM_PATHS: u64 = 16;

/// Consecutive paths that share one Sobol' sequence (one "pixel" of the sampler).
const SOBOL_PATHS: u64 = 1 << 16;

/// Chunks traced per batch, per worker thread: enough to keep every thread busy until the end
/// of a batch, few enough to bound the splat buffers alive at once (a chunk's buffer holds about
/// 16 bytes per path vertex seen by the camera: typically well under a megabyte).
const CHUNKS_PER_THREAD: usize = 8;

/// Light tracing: paths from the lights, every non-specular vertex splatted into the film.
pub struct LightTracer;

impl Integrator for LightTracer {
    fn method(&self) -> Method {
        Method::Light
    }

    fn support(&self, effect: Effect) -> Support {
        // Dispersion (three wavelengths per path, see `crate::spectrum`), absorption, motion blur (one time per path), depth
        // of field (connections to a sampled lens point), area lights, glossy surfaces, textures
        // and meshes are simulated. Specular surfaces seen directly are not an effect of the
        // list; the module documentation and the description state that they render black.
        match effect {
            Effect::Environment => Support::Approximates(
                "paths start on the environment and it lights the scene, but seen directly it renders black",
            ),
            _ => Support::Simulates,
        }
    }

    fn progression(&self) -> Progression<'_> {
        Progression::Accumulated(self)
    }
}

impl Accumulate for LightTracer {
    /// A film whose pixel estimate is the splat sum over `spp · A` (see the module documentation).
    fn film(&self, scene: &Scene, opts: &RenderOptions) -> Film {
        let tracer = Tracer::new(scene, self, opts);
        Film::of_crop(&tracer.camera, tracer.camera.film_area() as f64, tracer.dims.wavelength, opts.replicas)
    }

    /// Sample index `s` is the `w·h` light paths `s·w·h .. (s+1)·w·h`; their splats are one
    /// term of every pixel's sum and sum of squares.
    fn add_samples(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        samples: Range<u32>,
        film: &mut Film,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) {
        Tracer::new(scene, self, opts).trace_samples(samples, film, progress);
    }
}

/// The splats of one chunk of paths, in the order the paths made them (before the film's
/// common 1/(spp·A) scale).
#[derive(Default)]
struct ChunkSplats {
    splats: SplatBuffer,
    rays: RayCounts,
    /// Whether the chunk holds the last paths of its sample index.
    ends_sample: bool,
}

/// A light path between two surfaces (or a branch of one, waiting to run).
#[derive(Clone, Copy, Debug)]
struct LightWalk {
    /// The ray it follows next.
    ray: Ray,
    /// The emitted power over its density, in the path's channels, with the factors of the
    /// secondary wavelengths' ending.
    beta0: Vec3,
    /// The product of f·|cos|/pdf and absorption since emission (what Russian roulette looks at).
    throughput: Vec3,
    /// The absorption coefficient of the medium it travels in.
    absorption: Vec3,
    /// Scattering vertices so far.
    depth: u32,
}

/// Everything fixed during a light-tracing render.
struct Tracer<'a> {
    scene: &'a Scene,
    params: &'a RenderParams,
    camera: Camera,
    dims: CameraDims,
    sampler: SamplerKind,
    seed: u64,
    /// The replicas of the sample indices.
    replicas: Replicas,
    /// The paths of one sample index: the pixel count.
    paths_per_sample: u64,
    /// The number of lights paths can start on (all of them).
    lights: usize,
    /// Where paths from the environment start.
    sphere: SceneSphere,
    /// The scene's lane form for the shadow rays, if they are tested across lanes.
    lanes: Option<LaneScene>,
    /// Whether paths keep the hero alone at smooth dispersive refraction instead of splitting
    /// the wavelengths (the estimator before splitting, kept to compare against).
    hero_alone: bool,
}

/// Merge chunk buffers into the film in their order; `batch` sends the splats to the film's
/// sums of the current sample index, and moves on to the next when its last chunk is merged.
fn merge(film: &mut Film, batch: &mut SampleSplats, chunks: Vec<ChunkSplats>) {
    for mut chunk in chunks {
        batch.add(film, &mut chunk.splats);
        film.rays += chunk.rays;
        if chunk.ends_sample {
            batch.finish();
        }
    }
}

impl<'a> Tracer<'a> {
    fn new(scene: &'a Scene, integrator: &LightTracer, opts: &'a RenderOptions) -> Tracer<'a> {
        let camera = camera_for(scene, opts.resolution);
        Tracer {
            scene,
            params: &opts.params,
            paths_per_sample: camera.width as u64 * camera.height as u64,
            camera,
            dims: CameraDims::resolve(scene, integrator, opts.spectral),
            sampler: opts.sampler,
            seed: opts.seed,
            replicas: opts.replicas,
            lights: scene.lights.len(),
            sphere: scene.bounding_sphere(),
            lanes: shadow_lanes(scene, &opts.params),
            hero_alone: false,
        }
    }

    /// How the shadow rays towards the camera are tested.
    fn shadows(&self) -> Shadows<'_> {
        Shadows::new(self.scene, self.lanes.as_ref())
    }
}

impl Tracer<'_> {
    /// Trace the paths of the sample indices `samples` in fixed chunks (never straddling two
    /// sample indices), merging the chunks' splats into `film` in order.
    fn trace_samples(&self, samples: Range<u32>, film: &mut Film, progress: &(dyn Fn(u64, u64) + Sync)) {
        let pixels = self.camera.width as u64 * self.camera.height as u64;
        let mut chunks: Vec<(Range<u64>, bool)> = Vec::new();
        let first = samples.start;
        for s in samples {
            let (start, end) = (s as u64 * pixels, (s as u64 + 1) * pixels);
            for c in (start..end).step_by(CHUNK_PATHS as usize) {
                let stop = (c + CHUNK_PATHS).min(end);
                chunks.push((c..stop, stop == end));
            }
        }
        let total = chunks.len() as u64;
        let done = AtomicU64::new(0);
        let batch_size = CHUNKS_PER_THREAD * rayon::current_num_threads().max(1);
        let mut batch = SampleSplats::new(first, 1.0);
        let mut pending: Option<Vec<ChunkSplats>> = None;
        for group in chunks.chunks(batch_size) {
            // Trace this batch while the previous one is merged (in chunk order).
            let (traced, ()) = rayon::join(
                || {
                    group
                        .par_iter()
                        .map(|(range, ends_sample)| {
                            let mut c = self.trace_chunk(range.clone());
                            c.ends_sample = *ends_sample;
                            progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
                            c
                        })
                        .collect::<Vec<_>>()
                },
                || {
                    if let Some(p) = pending.take() {
                        merge(film, &mut batch, p);
                    }
                },
            );
            pending = Some(traced);
        }
        if let Some(p) = pending {
            merge(film, &mut batch, p);
        }
    }

    fn trace_chunk(&self, paths: Range<u64>) -> ChunkSplats {
        let mut out = ChunkSplats {
            splats: SplatBuffer::with_capacity(2 * (paths.end - paths.start) as usize),
            ..Default::default()
        };
        if self.lights == 0 {
            return out;
        }
        for index in paths {
            self.trace_path(index, &mut out);
        }
        out.splats.settle(&self.shadows(), true);
        out
    }

    /// The random stream of path `index` (path `index mod w·h` of sample index `index div w·h`):
    /// a pure function of (seed, index), drawn from the seed of its sample index's replica.
    fn path_sampler(&self, index: u64) -> Sampler {
        let per_sample = self.paths_per_sample;
        let stream = self.replicas.stream(self.seed, (index / per_sample) as u32, 0);
        let (seed, index) = (stream.seed, stream.index as u64 * per_sample + index % per_sample);
        match self.sampler {
            SamplerKind::Independent => Sampler::new(self.sampler, seed, index, 0, 1),
            SamplerKind::Stratified => Sampler::new(
                self.sampler,
                seed,
                index / STRATUM_PATHS,
                (index % STRATUM_PATHS) as u32,
                STRATUM_PATHS as u32,
            ),
            SamplerKind::Sobol => {
                Sampler::new(self.sampler, seed, index / SOBOL_PATHS, (index % SOBOL_PATHS) as u32, 0)
            }
        }
    }

    /// Trace light path `index`, appending its splats to `out`.
    fn trace_path(&self, index: u64, out: &mut ChunkSplats) {
        let scene = self.scene;
        let mut ctx =
            PathContext { hero_alone: self.hero_alone, ..PathContext::new(self.path_sampler(index)) };
        let (open, close) = self.camera.shutter;
        let time = if self.dims.time { open + (close - open) * ctx.sampler.get_1d(Dim::Time) } else { open };
        if self.dims.wavelength {
            ctx.channels = Channels::Spectral(Wavelengths::sample(ctx.sampler.get_1d(Dim::Wavelength)));
        }
        // The same dimensions for every light, so that stratification lines up across paths.
        let n = self.lights;
        let light = &scene.lights[pick_light(n, &mut ctx.sampler)];
        let side = ctx.sampler.get_1d(Dim::Light);
        let u_point = ctx.sampler.get_2d(Dim::Light);
        let u_dir = ctx.sampler.get_2d(Dim::Light);
        let Some(emission) = light.emit(1.0 / n as f32, side, u_point, u_dir, &self.sphere) else { return };

        // Vertex 0: the emission point of an area light, seen directly.
        if let Some((origin, inv_pdf)) = emission.origin {
            let channels = ctx.channels;
            self.connect(&origin, &mut ctx, time, out, |wc| {
                channels.colour(light.emitted(&origin, wc)) * (wc.dot(origin.n).abs() * inv_pdf)
            });
        }

        let mut ray = emission.ray;
        ray.time = time;
        ctx.rays.primary += 1;
        // Light is assumed to leave its light in a clear medium.
        let mut walk = LightWalk {
            ray,
            beta0: ctx.channels.colour(emission.beta),
            throughput: Vec3::ONE,
            absorption: Vec3::ZERO,
            depth: 0,
        };
        // The branches smooth dispersive glass splits the path into, run one after the other.
        let mut branches = PendingBranches::<LightWalk>::default();
        loop {
            self.walk(&mut walk, time, &mut ctx, &mut branches, out);
            let Some(branch) = branches.resume(&mut ctx.channels) else { break };
            ctx.sampler.replay_from(branch.replay);
            walk = branch.state;
        }
        out.rays += ctx.rays;
    }

    /// The random walk of a light path (or of one of its branches) from `walk` until it ends,
    /// splatting its vertices; the wavelengths smooth dispersive glass parts from it are set
    /// aside in `branches`.
    fn walk(
        &self,
        walk: &mut LightWalk,
        time: f32,
        ctx: &mut PathContext,
        branches: &mut PendingBranches<LightWalk>,
        out: &mut ChunkSplats,
    ) {
        let scene = self.scene;
        let mode = TransportMode::Importance;
        while walk.depth < self.params.max_depth {
            let ray = walk.ray;
            let Some(isect) = scene.intersect(&ray, f32::INFINITY) else { break };
            let hit = isect.hit;
            if walk.absorption != Vec3::ZERO {
                walk.throughput *= (-walk.absorption * hit.t).exp();
            }
            walk.depth += 1;
            let material = scene.material_of(isect.primitive);
            let bsdf = Scattering::at(material, hit.p, hit.uv, &ctx.channels);
            // Rough dispersive glass: the wavelengths go on together, weighted by MIS over their
            // densities (`crate::integrators::wavelengths`); the estimator kept to compare against
            // ends the secondaries there instead.
            let mixed = ctx.mixes_wavelengths(material, &hit);
            if !mixed {
                walk.beta0 *= ctx.end_secondaries_at(&material.bsdf, &bsdf);
            }
            // Importance mode: `wo` leads back towards the light, `wi` on towards the camera.
            let wo = -ray.dir;
            let frame = ShadingFrame::at(&hit, wo);
            let wo_local = frame.to_local(wo);
            if !bsdf.is_delta() {
                let beta = walk.beta0 * walk.throughput;
                // Rough glass: its multiply scattered light by a one-walk estimate, seeded here so
                // that the sampler's dimensions do not depend on whether the camera is visible.
                let mut rough = bsdf.has_multiple_scattering().then(|| {
                    let (a, b) = (ctx.sampler.get_1d(Dim::Other), ctx.sampler.get_1d(Dim::Other));
                    Pcg32::seed_from_u64(u64::from(a.to_bits()) << 32 | u64::from(b.to_bits()))
                });
                // Where the wavelengths mix, each channel's value is its own wavelength's.
                let models: Option<[Scattering; HERO_WAVELENGTHS]> =
                    mixed.then(|| std::array::from_fn(|i| ctx.model_at(material, &hit, i)));
                self.connect(&hit, ctx, time, out, |wc| {
                    let wc_local = frame.to_local(wc);
                    let f = match (&models, rough.as_mut()) {
                        (Some(models), rough) => Vec3::from_array(std::array::from_fn(|i| {
                            let single = models[i].eval(wo_local, wc_local, mode).x;
                            // The same walk's numbers at every wavelength.
                            let multiple = rough.as_ref().map_or(0.0, |rng| {
                                models[i].eval_multiple(wo_local, wc_local, mode, &mut (*rng).clone()).x
                            });
                            single + multiple
                        })),
                        (None, Some(rng)) => {
                            bsdf.eval(wo_local, wc_local, mode)
                                + bsdf.eval_multiple(wo_local, wc_local, mode, rng)
                        }
                        (None, None) => bsdf.eval(wo_local, wc_local, mode),
                    };
                    beta * f * (wc_local.z.abs() * frame.factor(wo, wc, mode))
                });
            }
            if walk.depth >= self.params.max_depth {
                break;
            }
            let numbers = bsdf_numbers(&bsdf, &mut ctx.sampler);
            let sampled = if mixed {
                ctx.sample_wavelengths(material, &hit, wo_local, numbers.0, numbers.1.into(), mode)
            } else {
                bsdf.sample(wo_local, numbers.0, numbers.1, mode)
            };
            let Some(s) = sampled else { break };
            // The absorption of the medium a ray in `channels` enters, where it crosses one.
            let medium_after = |transmitted: bool, channels: &Channels| {
                crossing(&material.bsdf, ray.dir, hit.n, channels.hero()).map(|c| {
                    let medium = if transmitted { c.transmitted } else { c.incident };
                    channels.colour(medium.absorption)
                })
            };
            // Dispersive glass: the wavelengths it parts become branches, replaying this path's
            // numbers from here on, set aside even where the lead cannot go on.
            let mut factor = Vec3::ONE;
            if ctx.channels.is_spectral() && s.pdf > 0.0 {
                let (u, replay) = (numbers.1.into(), ctx.sampler.dimension());
                let (f, parted) = if mixed && !s.is_evaluable() {
                    ctx.part_multiple(material, &hit, &frame, wo, &s, wo_local, (numbers.0, u), mode)
                } else {
                    ctx.part_wavelengths(material, &hit, &frame, wo, &s, wo_local, numbers, mode)
                };
                for p in parted.into_iter().flatten() {
                    let absorption = medium_after(p.sample.is_transmission, &p.channels);
                    let state = LightWalk {
                        ray: ray.spawn(spawn_origin(&hit, p.wi), p.wi),
                        throughput: walk.throughput * p.weight,
                        absorption: absorption.unwrap_or(walk.absorption),
                        ..*walk
                    };
                    branches.push(Branch { channel: p.channel, state, replay });
                }
                factor = f;
            }
            if s.pdf <= 0.0 || s.f == Vec3::ZERO {
                break;
            }
            let wi = frame.to_world(s.wi);
            let shading = frame.factor(wo, wi, mode);
            if shading == 0.0 {
                break;
            }
            let step = s.f * (s.wi.z.abs() / s.pdf) * shading * factor;
            walk.throughput *= step;
            if let Some(absorption) = medium_after(s.is_transmission, &ctx.channels) {
                walk.absorption = absorption;
            }
            if s.is_transmission {
                ctx.rays.refracted += 1;
            } else {
                ctx.rays.reflected += 1;
            }
            walk.ray = ray.spawn(spawn_origin(&hit, wi), wi);
            if walk.depth > ROULETTE_DEPTH {
                // No η² correction: the importance-mode throughput is a ratio of fluxes.
                let rr = walk.throughput.max_element();
                if rr < 1.0 {
                    let q = (1.0 - rr).max(0.0);
                    if ctx.sampler.get_1d(Dim::Other) < q {
                        break;
                    }
                    walk.throughput /= 1.0 - q;
                }
            }
        }
    }

    /// Connect the vertex `hit` to the camera at time `time`: `value(wc)` is the vertex's
    /// weight towards the unit direction `wc` to the camera (β·f·|cos|, or L_e·|cos|/pdf for an
    /// emission point); when the camera sees the vertex, its splat goes to the pixel it
    /// projects to.
    fn connect(
        &self,
        hit: &SurfaceHit,
        ctx: &mut PathContext,
        time: f32,
        out: &mut ChunkSplats,
        value: impl FnOnce(Vec3) -> Vec3,
    ) {
        let target = CameraTarget { camera: &self.camera, lens: self.dims.lens, shadows: self.shadows() };
        target.splat(hit, ctx, time, &mut out.splats, |_, c| value(-c.dir));
    }
}

#[cfg(test)]
mod tests;
