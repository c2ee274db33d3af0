//! The bidirectional methods on one engine: bidirectional path tracing (`bpt`, Veach 1997),
//! progressive photon mapping (`ppm`, Hachisuka et al. 2008 with Knaus and Zwicker's radius
//! schedule), bidirectional photon mapping (`bpm`) and vertex connection and merging (`vcm`,
//! Georgiev et al. 2012). The four differ only in which strategies they use: `bpt` connects
//! camera and light sub-paths, `ppm` merges once at the first non-specular camera vertex, `bpm`
//! merges at every non-specular camera vertex and `vcm` does both.
//!
//! # One iteration is one sample index
//! Iteration `s` traces `N = min(w·h, cap)` light sub-paths ([`light_paths_per_iteration`], the
//! cap [`MergeParams::max_light_paths`], [`DEFAULT_MAX_LIGHT_PATHS`] = 2²⁰ by default) and one
//! camera sub-path per pixel. With `(seed', k)` the seed of the iteration's replica and its
//! index within it ([`Replicas::stream`]), light path `j` of iteration `s` uses the random stream
//! of (light seed, `j`, `k`), camera path `j` the camera pass's stream of pixel `j`, sample `s`:
//! the light seed is `seed'` hashed with a constant, so a light path never reuses a camera
//! sample's stream. The merge radius of iteration `s` is `r_s = r₀ · (s + 1)^{(α − 1)/2}` (Knaus
//! and Zwicker 2011), a pure function of `s`. An iteration's estimate of every pixel, camera
//! contributions plus the splats of its light paths, is one term of the film's sums, so renders
//! are progressive, time budgets, checkpoints, shards and merges work as for every method, and
//! the image does not depend on the thread count (light paths are traced in fixed chunks whose
//! vertices and splats join the store and the film in order; the photon grid is built by a
//! counting sort; camera paths are traced in fixed bands of rows).
//!
//! # Memory: a cap on the light paths, not tiles
//! Beyond the film, an iteration holds its stored light paths (their non-specular vertices, the
//! photon grid over them, the chunks' splats on their way to the film) and one band of camera
//! estimates ([`CAMERA_BAND_PIXELS`]); the light paths' splats go straight into the film's sums
//! ([`SampleSplats`]). With `N` capped, none of it grows with the resolution: peak memory about
//! 310 MB above `path`'s at the default cap on `scenes/cornell-glass.toml` (`docs/performance.md`).
//! The vertices a light path stores depend on the scene (about 2.6 there, ten or more in a closed
//! room of bright walls), so a batch of light paths stores at most [`store_budget`] vertices (3 per
//! path of the cap): an iteration whose paths store more is traced in several batches, after each
//! of which the camera paths walk again and connect and merge with that batch (emitters hit and
//! next-event estimation count in the first batch only). The estimate is the same sum, so it stays
//! unbiased, and [`Integrator::working_memory`] is an upper bound at any scene (470 MiB for the
//! merging methods at the default cap). The cap is `[render.METHOD] max_light_paths` or
//! `--max-light-paths`.
//! Above the cap, camera path `j`
//! connects to light path `j mod N` (and, for `bpt`, shares its wavelengths and time), merges
//! with the photons of the `N` paths and the splats are normalised by `N`: every `N` in the
//! formulas is the number of light paths actually traced (the kernel's `η = π r² N` of the
//! weights and of the merges' normalisation, light tracing's `1/(pixel area · N)` and its
//! weight's camera density per light path). Each camera path still pairs with one independent
//! light path and each light path's splats and photons are averaged over the `N` traced, so
//! the iteration's estimate stays unbiased; only the correlation between the pixels that share
//! a light path grows. Below the cap (up to 1024² pixels by default) `N = w·h` as in Georgiev et
//! al. Tiles were the other option: they would bound the camera side too, but a light path's
//! splats and merges reach every tile, so each tile would need its own light paths (more work per
//! pixel) or all of them (no saving).
//!
//! # The default merge radius
//! An explicit radius (`--radius`, `[render.vcm] radius`) wins. Otherwise [`initial_radius`]:
//! [`DEFAULT_RADIUS_FRACTION`] of the scene's bounding-sphere diameter up to
//! [`RADIUS_REFERENCE_PIXELS`] (256²) pixels, times `sqrt(256² / pixels)` above. A radius fixed in
//! scene units finds ever more photons per merge as `N` grows with the pixels (time per pixel ∝
//! pixels); shrinking it with the pixel footprint keeps `N·π·r²`, the photons a merge finds, and
//! so the time per pixel flat, and the kernel's blur a fixed fraction of a pixel.
//!
//! # Strategies and their weights
//! The weights follow the recursive formulation of Georgiev et al.'s technical report: every
//! sub-path vertex carries three running quantities (`d_vcm`, `d_vc`, `d_vm`) from which the
//! weight of any connection or merge is computed in constant time, with the power heuristic.
//! Camera path `j` is connected to the vertices of light path `j` only (as in classic BPT);
//! it merges with the photons of every light path of the iteration. The strategies are: a camera
//! path hitting an emitter, next-event estimation, connections to light vertices, connections of
//! light vertices to the camera (splats) and merges. A light's emission point is not connected
//! to the camera (a light seen directly is found by camera rays, with weight 1). `ppm` and `bpm`
//! count emitters hit by camera paths only along purely specular chains (the rest is merging's).
//! Russian roulette is left out of the densities the weights use: the weights still sum to one
//! over the strategies of every path (they are computed from one set of densities on both
//! sides), so the estimate stays unbiased.
//!
//! # Rough glass
//! A rough dielectric's light scattered between several facets has no density (its sample is a
//! random walk; `eval` covers single scattering only). Such a sample is treated like a specular
//! one: the weights take its reverse-to-forward density ratio as 1, and no strategy connects or
//! merges at it (connections and merges evaluate single scattering only). Every strategy
//! computes its weight from the same densities, so the weights of the strategies that can make
//! a path still sum to one and the estimate is unbiased; `ppm` follows such samples as part of
//! the specular chain before it merges.
//!
//! # Wavelengths and time
//! `bpt` draws the wavelengths and the shutter time of camera path `j` and light path `j` from a
//! stream of their own keyed by (`j`, `s`), so a connection joins sub-paths of one wavelength
//! set. The merging methods merge photons of every light path, so all paths of an iteration share
//! one wavelength set and one time, drawn from the iteration's stream: unbiased over iterations,
//! with colour noise from iteration to iteration.
//!
//! Where smooth dispersive glass parts the wavelengths, a sub-path splits as `path`'s and
//! `light`'s do, by the same decision ([`PathContext::part_wavelengths`], in the sub-path's
//! transport mode): each wavelength samples the interface at its own index with the same numbers;
//! if all three reflect they go on together, otherwise the sub-path goes on with its lead's
//! channel alone and every other wavelength becomes a branch: the sub-path's state at the split
//! (its MIS quantities, η², segments) with the branch's own direction, medium and weight (its
//! channel alone), set aside in the sub-path ([`SubPath::branches`]) and walked by the engine
//! when the walk in flight ends, replaying the sub-path's random numbers from the split (a pure
//! function of the seed, the path and the branch). A camera branch sums into its pixel; a light
//! branch's vertices join its light path's in the store, so camera vertices connect to and merge
//! with them. Every channel is then its own unbiased estimate at weight 1. The MIS weights need
//! nothing new: a specular vertex's density ratio is 1 and each channel's path is one that its
//! own wavelength samples. Rough dispersive glass still ends the secondary wavelengths and carries
//! the hero alone at weight 3 ([`PathContext::end_secondaries_at`]), and so does `mmlt`, whose
//! sample is one path, at smooth glass too ([`multiplexed`]). A full path joins two halves by what
//! each carries ([`Carries`], [`joined`]): two halves each at the hero's weight 3 count it once
//! (1/3); halves that share no channel give 0 (a branch of another wavelength); otherwise 1.
//!
//! # Thin lens
//! A camera path leaves a sampled lens point; a light vertex connects to a uniform point of the
//! lens. The camera samples a lens point with the same density (one over the lens area) and,
//! from it, a direction with the pinhole's density `1/(A·cos³θ)` (the focal plane is parallel to
//! the film), so the lens area cancels and every weight has the pinhole's form.
//!
//! # The environment
//! The environment is a light like the others: light sub-paths start on it (on the scene's
//! bounding disk, [`crate::light`]), next-event estimation samples it, and a camera sub-path
//! that leaves the scene hits it. Its densities are per solid angle, so the first segment of a
//! light sub-path from it converts no density by a squared distance ([`Mis::arrive_from_infinity`]),
//! and a camera path that escapes is weighted with the solid-angle densities of next-event
//! estimation and emission (Georgiev et al.'s technical report, SmallVCM's background light).
//! Without an environment light the background colour is no light: rays that escape see it with
//! weight 1.

use super::shadow_queue::{shadow_lanes, Shadows};
use super::splat_film::SampleSplats;
use super::{bsdf_numbers, Integrator, MergeParams, Method, RenderParams, Strategy, ROULETTE_DEPTH};
use crate::bsdf::{Scattering, ShadingFrame};
use crate::camera::Camera;
use crate::geometry::{spawn_origin, Ray, SurfaceHit};
use crate::lanes::{LaneScene, RayLanes, WIDTH};
use crate::light::SceneSphere;
use crate::lighting::crossing;
use crate::render::{camera_for, Accumulate, CameraDims, Film, Progression, RenderOptions};
use crate::sampler::{Dim, Replicas, Sampler, SamplerKind};
use crate::scene::effects::Support;
use crate::scene::{Effect, Intersection, Scene};
use crate::spectrum::{Channels, Wavelengths};
use crate::stats::RayCounts;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::ops::Range;

mod camera_paths;
mod light_paths;
mod mis;
mod multiplexed;
mod photon_grid;
mod sub_path;
use camera_paths::CameraRow;
use light_paths::{LightPaths, LightStore};
use mis::{mis, Mis};
use photon_grid::PhotonGrid;
use sub_path::{joined, Carries, SubPath};

pub(crate) use multiplexed::Multiplexed;

/// Light paths per chunk of work at most.
const CHUNK_PATHS: usize = 1 << 12;

/// The default initial merge radius as a fraction of the diameter of the scene's bounding
/// sphere, for images of at most [`RADIUS_REFERENCE_PIXELS`] pixels ([`initial_radius`]).
pub const DEFAULT_RADIUS_FRACTION: f32 = 0.0015;

/// The pixel count (256²) above which the default merge radius shrinks with the pixel
/// footprint, as `sqrt(RADIUS_REFERENCE_PIXELS / pixels)` ([`initial_radius`]).
pub const RADIUS_REFERENCE_PIXELS: u64 = 256 * 256;

pub use crate::params::DEFAULT_MAX_LIGHT_PATHS;

/// Camera paths traced between two additions to the film: their estimates wait in a buffer of
/// this many pixels at most, whatever the resolution.
const CAMERA_BAND_PIXELS: usize = 1 << 18;

/// What an iteration needs beyond the film, kept from one iteration to the next so that its
/// arrays keep their room (not allocated and faulted in again every iteration).
#[derive(Default)]
struct Workspace {
    /// The stored light paths of the batch.
    store: LightStore,
    /// The photon grid over them (merging methods only).
    grid: Option<PhotonGrid>,
    /// Batches traced so far (over all iterations).
    batches: u64,
    /// The most vertices a batch stored so far.
    peak_vertices: usize,
}

/// Hashed into the render's seed for the light sub-paths' streams.
const LIGHT_STREAM: u64 = 0x6c69_6768_745f_7061; // "light_pa"

/// Hashed into the render's seed for the streams of shared wavelengths and times.
const SHARED_STREAM: u64 = 0x7368_6172_6564_5f77; // "shared_w"

/// Which strategies a bidirectional method uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Algorithm {
    /// Bidirectional path tracing: connections only.
    Bpt,
    /// Progressive photon mapping: one merge at the first non-specular camera vertex.
    Ppm,
    /// Bidirectional photon mapping: merges at every non-specular camera vertex.
    Bpm,
    /// Vertex connection and merging: connections and merges.
    Vcm,
}

impl Algorithm {
    /// The algorithm of the method called `name` (`bpt`, `ppm`, `bpm`, `vcm`).
    pub fn from_name(name: &str) -> Option<Algorithm> {
        match Method::from_name(name)? {
            Method::Bpt => Some(Algorithm::Bpt),
            Method::Ppm => Some(Algorithm::Ppm),
            Method::Bpm => Some(Algorithm::Bpm),
            Method::Vcm => Some(Algorithm::Vcm),
            _ => None,
        }
    }

    /// The strategies the algorithm uses.
    pub fn strategies(self) -> Vec<Strategy> {
        let mut all = vec![Strategy::EmitterHit];
        if self.connects() {
            all.extend([Strategy::NextEvent, Strategy::Connection, Strategy::CameraSplat]);
        }
        if self.merges() {
            all.push(Strategy::Merge);
        }
        all
    }

    fn connects(self) -> bool {
        matches!(self, Algorithm::Bpt | Algorithm::Vcm)
    }

    fn merges(self) -> bool {
        !matches!(self, Algorithm::Bpt)
    }
}

/// A bidirectional method of the shared engine.
pub struct VertexMerging(pub Algorithm);

impl Integrator for VertexMerging {
    fn method(&self) -> Method {
        match self.0 {
            Algorithm::Bpt => Method::Bpt,
            Algorithm::Ppm => Method::Ppm,
            Algorithm::Bpm => Method::Bpm,
            Algorithm::Vcm => Method::Vcm,
        }
    }

    fn support(&self, effect: Effect) -> Support {
        match effect {
            Effect::Dispersion | Effect::MotionBlur if self.0.merges() => Support::Approximates(
                "an iteration's paths share one wavelength set and one time, so that photons can merge",
            ),
            _ => Support::Simulates,
        }
    }

    fn progression(&self) -> Progression<'_> {
        Progression::Accumulated(self)
    }

    /// The stored light paths of a batch (their vertices and the photon grid over them, at most
    /// [`store_budget`] vertices whatever the scene), the chunks of light paths on their way to
    /// the store (their vertices and splats) and the band of camera estimates: an upper bound
    /// at any scene, set by [`MergeParams::max_light_paths`], not by the pixel count.
    fn working_memory(&self, scene: &Scene, opts: &RenderOptions) -> u64 {
        let camera = camera_for(scene, opts.resolution);
        let pixels = camera.width as usize * camera.height as usize;
        let params = &opts.params.merging;
        let paths = light_paths_per_iteration(pixels, params) as u64;
        let longest = opts.params.max_depth as u64 + 1;
        let vertex = std::mem::size_of::<light_paths::LightVertex>() as u64;
        // The store and, for the merging methods, the photon grid over it.
        let grid = if self.0.merges() { PhotonGrid::BYTES_PER_PHOTON } else { 0 };
        let store =
            store_bound(paths as usize, params, longest as usize) as u64 * (vertex + grid) + paths * 4;
        // A chunk: its vertices, its path ends and its splats (16 bytes each, one per vertex and
        // one per path from each pixel of the filter's footprint, twice for the room of a
        // growing buffer).
        let chunk_paths = paths.min(CHUNK_PATHS as u64);
        let chunk_vertices = (CHUNK_VERTICES as u64 + longest).min(chunk_paths * longest);
        let footprint = (2.0 * camera.filter.radius()).ceil() as u64 + 1;
        let splats = (chunk_vertices + chunk_paths) * footprint * footprint * 16 * 2;
        let chunk = chunk_vertices * vertex + chunk_paths * 4 + splats;
        let chunks = paths.min(light_paths::CHUNKS_PER_GROUP as u64);
        // The band's estimates, and the rows being traced (their sums and the terms they wait).
        store + chunks * chunk + CAMERA_BAND_PIXELS as u64 * (12 + camera_paths::ROW_BYTES_PER_PIXEL)
    }
}

/// Stored light vertices per light path of the cap that a batch holds at most
/// ([`store_budget`]): `scenes/cornell-glass.toml` stores about 2.6 per path, so one batch holds
/// an iteration of it; scenes whose paths store more take more batches, not more memory.
const VERTICES_PER_PATH: usize = 3;

/// The most vertices a chunk of light paths stores before it stops (its last path may add up
/// to the maximum depth more).
const CHUNK_VERTICES: usize = 1 << 14;

/// The vertex budget of one batch of light paths: [`VERTICES_PER_PATH`] per light path of the
/// cap (at least of 2¹⁴ paths). An iteration whose paths store more is traced in several
/// batches; each camera path is walked again for each later batch (the same path: its random
/// numbers do not depend on the batch) and there connects and merges with that batch's light
/// paths only, so the estimate is the same sum, still unbiased.
fn store_budget(params: &MergeParams) -> usize {
    VERTICES_PER_PATH * (params.max_light_paths.max(1) as usize).max(1 << 14)
}

/// The most vertices the store of a batch holds, for `paths` light paths of at most `longest`
/// vertices each: the budget, or a chunk at its bound if that is more (a batch takes at least
/// one chunk), or all the paths at their longest if that is less.
fn store_bound(paths: usize, params: &MergeParams, longest: usize) -> usize {
    store_budget(params).max(CHUNK_VERTICES + longest).min(paths.saturating_mul(longest))
}

impl Accumulate for VertexMerging {
    fn film(&self, scene: &Scene, opts: &RenderOptions) -> Film {
        let engine = Engine::new(scene, self, opts);
        Film::of_crop(&engine.camera, 1.0, engine.dims.wavelength, opts.replicas)
    }

    /// Each sample index is one iteration: its light paths, its photon grid, its camera paths.
    fn add_samples(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        samples: Range<u32>,
        film: &mut Film,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) {
        let engine = Engine::new(scene, self, opts);
        let total = samples.len() as u64;
        let mut work = Workspace::default();
        for (k, s) in samples.enumerate() {
            engine.iteration(s, film, &mut work);
            progress(k as u64 + 1, total);
        }
    }
}

/// The initial merge radius of `scene` with `params` at the render's `resolution` (`None`: the
/// scene camera's): the explicit radius when `params` has one; else
/// [`DEFAULT_RADIUS_FRACTION`] of the diameter of the scene's bounding sphere, times
/// `min(1, sqrt(RADIUS_REFERENCE_PIXELS / pixels))`. Above 256² pixels the default radius so
/// follows the pixel footprint (halving when the image doubles in width and height): the
/// photons a merge finds, and so the time per pixel, stay flat in resolution, and the kernel's
/// blur stays a fixed fraction of a pixel.
pub fn initial_radius(scene: &Scene, params: &MergeParams, resolution: Option<(u32, u32)>) -> f32 {
    params.radius.unwrap_or_else(|| {
        let (lo, hi) = scene.bvh_stats.bounds;
        let camera = camera_for(scene, resolution);
        let pixels = (camera.width as u64 * camera.height as u64).max(1);
        let footprint = (RADIUS_REFERENCE_PIXELS as f64 / pixels as f64).sqrt().min(1.0) as f32;
        DEFAULT_RADIUS_FRACTION * (hi - lo).length() * footprint
    })
}

/// The light sub-paths of one iteration for an image of `pixels` pixels: one per pixel, at
/// most `max_light_paths`.
pub fn light_paths_per_iteration(pixels: usize, params: &MergeParams) -> usize {
    pixels.min(params.max_light_paths.max(1) as usize)
}

/// The merge radius of iteration `s` (0-based) from the initial radius `r0`.
pub fn iteration_radius(r0: f32, alpha: f32, s: u32) -> f32 {
    (r0 * ((s as f64 + 1.0).powf(0.5 * (alpha as f64 - 1.0))) as f32).max(1e-7)
}

/// The MIS constants of one iteration.
#[derive(Clone, Copy)]
struct IterationConstants {
    radius: f32,
    /// Weight of merging relative to connection, `mis(π r² N)` (0 without merging).
    mis_vm: f32,
    /// Its inverse (0 without connections).
    mis_vc: f32,
    /// `1 / (π r² N)`: the merge kernel over the number of light paths.
    vm_norm: f32,
}

/// Everything fixed during a render.
struct Engine<'a> {
    scene: &'a Scene,
    params: &'a RenderParams,
    algorithm: Algorithm,
    camera: Camera,
    dims: CameraDims,
    sampler: SamplerKind,
    seed: u64,
    /// The replicas of the iterations: iteration `s` draws from its replica's seed, at its index
    /// within the replica.
    replicas: Replicas,
    /// The number of lights: paths start on them and next-event estimation samples them, the
    /// environment included.
    lights: usize,
    /// The environment light's index, if there is one.
    environment: Option<usize>,
    /// Where light sub-paths from the environment start.
    sphere: SceneSphere,
    /// Segments a full path may have: the maximum depth (scattering vertices) plus one.
    max_segments: u32,
    /// Area of one pixel on the image plane at distance 1.
    pixel_area: f32,
    /// Light sub-paths per iteration, `N` ([`light_paths_per_iteration`]): camera path `j`
    /// connects to light path `j mod N`.
    light_paths: usize,
    radius0: f32,
    /// The one strategy rendered alone, unweighted (`None`: all, weighted).
    only: Option<Strategy>,
    /// The scene's lane form, where shadow rays are tested and camera paths walk across lanes
    /// ([`shadow_lanes`]).
    lanes: Option<LaneScene>,
    /// Whether sub-paths play Russian roulette (multiplexed MLT's sub-paths of a given length
    /// do not).
    roulette: bool,
    /// Whether sub-paths keep the hero alone at smooth dispersive refraction instead of
    /// splitting their wavelengths ([`PathContext::hero_alone`]): `mmlt`, and the estimator
    /// before splitting, kept to compare against.
    hero_alone: bool,
}

impl<'a> Engine<'a> {
    fn new(scene: &'a Scene, integrator: &VertexMerging, opts: &'a RenderOptions) -> Engine<'a> {
        let camera = camera_for(scene, opts.resolution);
        let pixels = camera.width as usize * camera.height as usize;
        let dims = CameraDims::resolve(scene, integrator, opts.spectral);
        Engine {
            light_paths: light_paths_per_iteration(pixels, &opts.params.merging),
            radius0: initial_radius(scene, &opts.params.merging, opts.resolution),
            only: opts.params.merging.only,
            lanes: shadow_lanes(scene, &opts.params),
            ..Engine::one_ray(scene, opts, integrator.0, camera, dims)
        }
    }

    /// The engine of `algorithm` for `scene` seen by `camera`, with `opts`'s depth, sampler,
    /// seed and replicas: one light path per iteration, no merging radius, shadow rays one at a
    /// time, Russian roulette on. [`Engine::new`] and `mmlt`'s engine
    /// ([`multiplexed::Multiplexed`]) set what they change.
    pub(super) fn one_ray(
        scene: &'a Scene,
        opts: &'a RenderOptions,
        algorithm: Algorithm,
        camera: Camera,
        dims: CameraDims,
    ) -> Engine<'a> {
        let pixels = camera.width as usize * camera.height as usize;
        Engine {
            scene,
            params: &opts.params,
            algorithm,
            pixel_area: camera.film_area() / pixels as f32,
            dims,
            camera,
            sampler: opts.sampler,
            seed: opts.seed,
            replicas: opts.replicas,
            lights: scene.lights.len(),
            environment: scene.environment_light(),
            sphere: scene.bounding_sphere(),
            max_segments: opts.params.max_depth.saturating_add(1),
            light_paths: 1,
            radius0: 0.0,
            only: None,
            lanes: None,
            roulette: true,
            hero_alone: false,
        }
    }

    /// How the shadow rays are tested: across lanes, or one by one.
    fn shadows(&self) -> Shadows<'_> {
        Shadows::new(self.scene, self.lanes.as_ref())
    }

    /// Whether the render includes strategy `s`.
    fn keeps(&self, s: Strategy) -> bool {
        self.only.is_none_or(|only| only == s)
    }

    /// A strategy's MIS weight, or 1 when it is rendered alone.
    fn weighted(&self, weight: f32) -> f32 {
        if self.only.is_some() {
            1.0
        } else {
            weight
        }
    }

    fn constants(&self, s: u32) -> IterationConstants {
        let radius = iteration_radius(self.radius0, self.params.merging.alpha, s);
        let eta = PI * radius * radius * self.light_paths as f32;
        let merges = self.algorithm.merges();
        IterationConstants {
            radius,
            mis_vm: if merges { mis(eta) } else { 0.0 },
            mis_vc: if self.algorithm.connects() { mis(1.0 / eta) } else { 0.0 },
            vm_norm: 1.0 / eta,
        }
    }

    /// The wavelengths and shutter time of path pair `j` of iteration `s` (shared by the whole
    /// iteration for the merging methods).
    fn channels_and_time(&self, j: usize, s: u32) -> (Channels, f32) {
        let key = if self.algorithm.merges() { u64::MAX } else { j as u64 };
        let stream = self.replicas.stream(self.seed, s, 0);
        let mut sampler = Sampler::new(self.sampler, stream.seed ^ SHARED_STREAM, key, stream.index, 0);
        let (open, close) = self.camera.shutter;
        let time = if self.dims.time { open + (close - open) * sampler.get_1d(Dim::Time) } else { open };
        let channels = if self.dims.wavelength {
            Channels::Spectral(Wavelengths::sample(sampler.get_1d(Dim::Wavelength)))
        } else {
            Channels::Rgb
        };
        (channels, time)
    }

    /// One iteration: its light paths (their splats go to the film) in batches of at most
    /// [`store_budget`] stored vertices (one batch unless the paths store more than that), and
    /// after each batch its photon grid and the camera paths ([`Engine::camera_pass`]).
    fn iteration(&self, s: u32, film: &mut Film, work: &mut Workspace) {
        let k = self.constants(s);
        // A splat is a light path's importance at its pixel over the N light paths:
        // 1 / (pixel area · N), which is 1 / (film area) when N is the pixel count.
        let scale = 1.0 / (self.pixel_area as f64 * self.light_paths as f64);
        let mut splats = SampleSplats::new(s, scale);
        let origin = self.scene.bvh_stats.bounds.0;
        let mut next = 0;
        let mut first_batch = true;
        while first_batch || next < self.light_paths {
            self.trace_light_batch(&mut next, s, &k, film, &mut splats, &mut work.store);
            let store = &work.store;
            work.batches += 1;
            work.peak_vertices = work.peak_vertices.max(store.vertices.len());
            let grid = self.algorithm.merges().then(|| {
                let grid = work.grid.get_or_insert_with(PhotonGrid::new);
                grid.build(&store.vertices, k.radius, origin);
                &*grid
            });
            let light = LightPaths { first: store.first, vertices: &store.vertices, ends: &store.ends, grid };
            self.camera_pass(s, &k, &light, first_batch, film);
            first_batch = false;
        }
        splats.finish();
    }

    /// The camera paths of the crop window's pixels with the light paths of a batch (each on
    /// its whole-film pixel's stream), in bands of rows of at most [`CAMERA_BAND_PIXELS`], each
    /// band's estimates added to the film as it is done. (Square tiles of 16² pixels, whose
    /// merges share more grid cells, measured 3–6% slower than rows on
    /// `scenes/cornell-glass.toml` at 256² and 1024².)
    fn camera_pass(
        &self,
        s: u32,
        k: &IterationConstants,
        light: &LightPaths,
        first_batch: bool,
        film: &mut Film,
    ) {
        let crop = self.camera.crop;
        let (w, x0, y0) = (self.camera.width as usize, crop.x as usize, crop.y as usize);
        let (cw, ch) = (crop.width as usize, crop.height as usize);
        let band = (CAMERA_BAND_PIXELS / cw.max(1)).max(1);
        for first in (0..ch).step_by(band) {
            let rows: Vec<(Vec<Vec3>, RayCounts, u64)> = (first..(first + band).min(ch))
                .into_par_iter()
                .map(|row| {
                    let y = y0 + row;
                    let mut out = CameraRow::new(cw, self.shadows());
                    self.camera_paths(y * w + x0, cw, s, k, light, first_batch, &mut out);
                    out.finish()
                })
                .collect();
            for (i, (values, rays, non_finite)) in rows.into_iter().enumerate() {
                film.rays += rays;
                film.non_finite += non_finite;
                let base = (first + i) * cw;
                for (x, l) in values.into_iter().enumerate() {
                    film.add(base + x, s, l.as_dvec3());
                }
            }
        }
    }

    /// The random walk of a sub-path from `ray`, shared by camera and light sub-paths: at every
    /// surface it reaches, the MIS update of the arrival, `visitor`'s strategies, then a BSDF
    /// sample, the absorption of the medium it enters and Russian roulette ([`Engine::step`]).
    /// `from_infinity`: the first segment comes from the environment (its density has no
    /// distance to convert by).
    fn walk(
        &self,
        ray: Ray,
        path: &mut SubPath,
        k: &IterationConstants,
        from_infinity: bool,
        visitor: &mut impl WalkVisitor,
    ) {
        let mut walk = Walk { ray, absorption: Vec3::ZERO, from_infinity };
        loop {
            let isect = self.scene.intersect(&walk.ray, f32::INFINITY);
            // Where the walk ends, the branches split from it (if any) walk on, one by one.
            if !self.step(&mut walk, path, k, visitor, isect) && !path.resume_branch(&mut walk) {
                break;
            }
        }
    }

    /// The walks of up to [`WIDTH`] sub-paths side by side: their closest hits found 16 at a
    /// time by `lanes` (a scene whose every primitive is tested across lanes), then
    /// `step(i, walk, path, hit)` ([`Engine::step`] with walk `i`'s visitor) for each walk
    /// still going, until none is. Each walk takes the steps of [`Engine::walk`], with the same
    /// hits to the bit ([`LaneScene::closest`] and [`Scene::record`]): where one ends, the
    /// branches split from it walk on in its lane, in the order of [`Engine::walk`].
    fn walk_lanes(
        &self,
        lanes: &LaneScene,
        walks: &mut [Walk],
        paths: &mut [SubPath],
        mut step: impl FnMut(usize, &mut Walk, &mut SubPath, Option<Intersection>) -> bool,
    ) {
        let scene = self.scene;
        let mut live = [false; WIDTH];
        live[..walks.len().min(WIDTH)].fill(true);
        while live.iter().any(|&l| l) {
            let mut rays = RayLanes::default();
            let mut tmax = [-1.0; WIDTH];
            for i in (0..walks.len()).filter(|&i| live[i]) {
                let ray = &walks[i].ray;
                for axis in 0..3 {
                    (rays.origin[axis][i], rays.dir[axis][i]) = (ray.origin[axis], ray.dir[axis]);
                }
                tmax[i] = f32::INFINITY;
            }
            let found = lanes.closest(&rays, &tmax);
            for i in 0..walks.len() {
                if live[i] {
                    let hit = (found.t[i] < f32::INFINITY)
                        .then(|| scene.record(&walks[i].ray, found.t[i], found.primitive[i], found.bary[i]));
                    live[i] =
                        step(i, &mut walks[i], &mut paths[i], hit) || paths[i].resume_branch(&mut walks[i]);
                }
            }
        }
    }

    /// One step of a sub-path's walk ([`Engine::walk`]): at `isect`, the surface its ray
    /// reaches (`None`: it leaves the scene), the MIS update of the arrival, `visitor`'s
    /// strategies, then a BSDF sample, the absorption of the medium it enters and Russian
    /// roulette, leaving the next ray in `walk`. False where the walk ends.
    fn step(
        &self,
        walk: &mut Walk,
        path: &mut SubPath,
        k: &IterationConstants,
        visitor: &mut impl WalkVisitor,
        isect: Option<Intersection>,
    ) -> bool {
        let scene = self.scene;
        let ray = walk.ray;
        let Some(isect) = isect else {
            visitor.escaped(path, ray.dir, walk.absorption != Vec3::ZERO);
            return false;
        };
        let hit = &isect.hit;
        if walk.absorption != Vec3::ZERO {
            let a = (-walk.absorption * hit.t).exp();
            path.beta *= a;
            path.throughput *= a;
        }
        let cos_in = hit.n.dot(ray.dir).abs();
        if walk.from_infinity && path.segments == 1 {
            path.mis.arrive_from_infinity(cos_in);
        } else if path.segments == 1 && path.start_offset > 0.0 {
            path.mis.arrive(hit.t + path.start_offset, cos_in);
        } else {
            path.mis.arrive(hit.t, cos_in);
        }
        if !visitor.reached(path, &ray, &isect) {
            return false;
        }
        let material = scene.material_of(isect.primitive);
        let bsdf = Scattering::at(material, hit.p, hit.uv, &path.ctx.channels);
        let hero_only = path.ctx.hero_only;
        path.beta *= path.ctx.end_secondaries_at(&material.bsdf, &bsdf);
        if path.ctx.hero_only != hero_only {
            path.carries = Carries::Hero;
        }
        let wo = -ray.dir;
        let frame = ShadingFrame::at(hit, wo);
        let at = Vertex { hit, bsdf: &bsdf, frame: &frame, wo, wo_local: frame.to_local(wo) };
        let next = visitor.visit(path, &at, isect.primitive);
        if next == Next::Stop {
            return false;
        }
        let numbers = bsdf_numbers(&bsdf, &mut path.ctx.sampler);
        let Some(smp) = bsdf.sample(at.wo_local, numbers.0, numbers.1, path.mode) else {
            return false;
        };
        // Smooth dispersive glass: the wavelengths it parts from the sub-path become branches.
        let split = if path.ctx.channels.is_spectral() {
            self.split_wavelengths(walk, path, k, &at, material, &smp, numbers)
        } else {
            Vec3::ONE
        };
        if smp.pdf <= 0.0 || smp.f == Vec3::ZERO {
            return false;
        }
        let evaluable = smp.is_evaluable();
        if next == Next::SpecularOnly && evaluable {
            return false;
        }
        let wi = frame.to_world(smp.wi);
        let shading = frame.factor(wo, wi, path.mode);
        if shading == 0.0 {
            return false;
        }
        let cos_out = smp.wi.z.abs();
        let rev = if evaluable { bsdf.pdf(smp.wi, at.wo_local) } else { 0.0 };
        path.scatter(k, cos_out, smp.pdf, rev, evaluable);
        let step = smp.f * (cos_out / smp.pdf) * split * shading;
        path.beta *= step;
        path.throughput *= step;
        if let Some(c) = crossing(&material.bsdf, ray.dir, hit.n, path.ctx.channels.hero()) {
            let medium = if smp.is_transmission { c.transmitted } else { c.incident };
            walk.absorption = path.ctx.channels.colour(medium.absorption);
        }
        if smp.is_transmission {
            path.eta_scale *= smp.eta * smp.eta;
            path.ctx.rays.refracted += 1;
        } else {
            path.ctx.rays.reflected += 1;
        }
        walk.ray = ray.spawn(spawn_origin(hit, wi), wi);
        path.segments += 1;
        if self.roulette && path.segments > ROULETTE_DEPTH + 1 {
            let rr = path.survival();
            if rr < 1.0 {
                let q = (1.0 - rr).max(0.0);
                if path.ctx.sampler.get_1d(Dim::Other) < q {
                    return false;
                }
                path.beta /= 1.0 - q;
                path.throughput /= 1.0 - q;
            }
        }
        true
    }
}

/// Where a sub-path's walk is between two surfaces: the ray it follows, the absorption of the
/// medium it is in, and whether its first segment came from the environment.
#[derive(Clone, Copy)]
struct Walk {
    ray: Ray,
    absorption: Vec3,
    from_infinity: bool,
}

/// A sub-path vertex being shaded.
struct Vertex<'a> {
    hit: &'a SurfaceHit,
    bsdf: &'a Scattering<'a>,
    frame: &'a ShadingFrame,
    /// The direction back along the sub-path, in the world and in the local frame.
    wo: Vec3,
    wo_local: Vec3,
}

/// Where a sub-path's walk may go on from a vertex.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Next {
    /// In any sampled direction.
    Any,
    /// Only along a specular (or multiply scattered) sample: photon mapping past its merge.
    SpecularOnly,
    /// Nowhere: the walk ends here.
    Stop,
}

/// What a sub-path does along its random walk ([`Engine::walk`]): camera and light sub-paths
/// share the walk and differ only here.
trait WalkVisitor {
    /// The walk left the scene along `dir`; `absorbed` when through an absorbing medium.
    fn escaped(&mut self, _path: &mut SubPath, _dir: Vec3, _absorbed: bool) {}

    /// The walk reached `isect` along `ray` (after the arrival's MIS update); false ends it
    /// there, before the surface scatters.
    fn reached(&mut self, _path: &mut SubPath, _ray: &Ray, _isect: &Intersection) -> bool {
        true
    }

    /// The strategies at vertex `at` of primitive `primitive`; returns where the walk may go on.
    fn visit(&mut self, path: &mut SubPath, at: &Vertex, primitive: u32) -> Next;
}

#[cfg(test)]
mod tests;
