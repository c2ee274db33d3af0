//! The bidirectional methods on one engine: bidirectional path tracing (`bpt`, Veach 1997),
//! progressive photon mapping (`ppm`, Hachisuka et al. 2008 with Knaus and Zwicker's radius
//! schedule), bidirectional photon mapping (`bpm`) and vertex connection and merging (`vcm`,
//! Georgiev et al. 2012). The four differ only in which strategies they use: `bpt` connects
//! camera and light sub-paths, `ppm` merges once at the first non-specular camera vertex, `bpm`
//! merges at every non-specular camera vertex and `vcm` does both.
//!
//! # One iteration is one sample index
//! Iteration `s` traces `N = w·h` light sub-paths and one camera sub-path per pixel. With `(seed',
//! k)` the seed of the iteration's replica and its index within it ([`Replicas::stream`]), light
//! path `j` of iteration `s` uses the random stream of (light seed, `j`, `k`), camera path `j` the
//! camera pass's stream of pixel `j`, sample `s`: the light seed is `seed'` hashed with a
//! constant, so a light path never reuses a camera sample's stream. The merge radius of
//! iteration `s` is `r_s = r₀ · (s + 1)^{(α − 1)/2}` (Knaus and Zwicker 2011), a pure function of
//! `s`. An iteration's estimate of every pixel, camera contributions plus the splats of its
//! light paths, is one term of the film's sums, so renders are progressive, time budgets,
//! checkpoints, shards and merges work as for every method, and the image does not depend on
//! the thread count (light paths are traced in fixed chunks whose vertices and splats are
//! concatenated in order; the photon grid is built by a counting sort).
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
//! with colour noise from iteration to iteration. A sub-path that ends its secondary wavelengths
//! (dispersive refraction) carries the hero alone; a full path both of whose halves did so counts
//! the factor 3 once.
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

use super::splat_film::{CameraTarget, SampleSplats, SplatBuffer};
use super::{
    pick_light, sample_bsdf, Integrator, MergeParams, PathContext, RenderParams, Strategy, DEFAULT_PATH_DEPTH,
};
use crate::bsdf::{Scattering, ShadingFrame, TransportMode};
use crate::camera::{Camera, CameraConnection};
use crate::geometry::{spawn_origin, Ray, SurfaceHit};
use crate::light::{Light, SceneSphere};
use crate::lighting::{crossing, transmittance, ShadowMode, ShadowRays};
use crate::render::{
    camera_for, render_accumulated, Accumulate, CameraDims, Film, Progression, RenderOptions, RenderOutput,
};
use crate::sampler::{Dim, Replicas, Sampler, SamplerKind};
use crate::scene::effects::Support;
use crate::scene::{Effect, Intersection, Scene};
use crate::spectrum::{Channels, Wavelengths};
use crate::stats::RayCounts;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::f32::consts::PI;
use std::ops::Range;

mod mis;
use mis::{mis, Mis};

/// Light paths per chunk of work (the unit of determinism).
const CHUNK_PATHS: usize = 1 << 12;

/// Bounces after which Russian roulette may end a sub-path.
const ROULETTE_DEPTH: u32 = 3;

/// The default initial merge radius as a fraction of the diameter of the scene's bounding sphere.
pub const DEFAULT_RADIUS_FRACTION: f32 = 0.0015;

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
        match name {
            "bpt" => Some(Algorithm::Bpt),
            "ppm" => Some(Algorithm::Ppm),
            "bpm" => Some(Algorithm::Bpm),
            "vcm" => Some(Algorithm::Vcm),
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
    fn name(&self) -> &'static str {
        match self.0 {
            Algorithm::Bpt => "bpt",
            Algorithm::Ppm => "ppm",
            Algorithm::Bpm => "bpm",
            Algorithm::Vcm => "vcm",
        }
    }

    fn description(&self) -> &'static str {
        match self.0 {
            Algorithm::Bpt => {
                "bidirectional path tracing: camera and light sub-paths connected, MIS over every strategy"
            }
            Algorithm::Ppm => {
                "progressive photon mapping: specular camera chains merge photons once; radius shrinks"
            }
            Algorithm::Bpm => "bidirectional photon mapping: merges at every non-specular camera vertex, MIS",
            Algorithm::Vcm => {
                "vertex connection and merging: bpt plus merging, MIS over both; every light path"
            }
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

    fn default_max_depth(&self) -> u32 {
        DEFAULT_PATH_DEPTH
    }

    /// Unused: the engine renders in [`Integrator::render_image`], which always returns `Some`.
    fn radiance(&self, _: &Scene, _: &RenderParams, _: &Ray, _: &mut PathContext) -> Vec3 {
        Vec3::ZERO
    }

    fn render_image(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Option<RenderOutput> {
        Some(render_accumulated(scene, self, opts, progress))
    }

    fn progression(&self) -> Progression<'_> {
        Progression::Own(self)
    }
}

impl Accumulate for VertexMerging {
    fn film(&self, scene: &Scene, opts: &RenderOptions) -> Film {
        let engine = Engine::new(scene, self, opts);
        let (w, h) = (engine.camera.crop.width as usize, engine.camera.crop.height as usize);
        Film::new(w, h, 1.0, engine.dims.wavelength, opts.replicas)
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
        for (k, s) in samples.enumerate() {
            engine.iteration(s, film);
            progress(k as u64 + 1, total);
        }
    }
}

/// The initial merge radius of `scene` with `params`.
pub fn initial_radius(scene: &Scene, params: &MergeParams) -> f32 {
    params.radius.unwrap_or_else(|| {
        let (lo, hi) = scene.bvh_stats.bounds;
        DEFAULT_RADIUS_FRACTION * (hi - lo).length()
    })
}

/// The merge radius of iteration `s` (0-based) from the initial radius `r0`.
pub fn iteration_radius(r0: f32, alpha: f32, s: u32) -> f32 {
    (r0 * ((s as f64 + 1.0).powf(0.5 * (alpha as f64 - 1.0))) as f32).max(1e-7)
}

/// A light sub-path vertex on a non-delta surface: a photon and a connection end.
#[derive(Clone, Copy, Debug)]
struct LightVertex {
    p: Vec3,
    n: Vec3,
    /// Texture coordinates of the surface here.
    uv: Vec2,
    /// The shading normal.
    ns: Vec3,
    p_error: f32,
    /// Unit direction towards the previous vertex of the light path (where the light came from).
    wo: Vec3,
    /// Path weight from the light to this vertex (emission included).
    beta: Vec3,
    /// The light sub-path's MIS quantities here.
    mis: Mis,
    /// Segments from the light to this vertex.
    segments: u32,
    primitive: u32,
    hero_only: bool,
}

impl LightVertex {
    fn hit(&self) -> SurfaceHit {
        SurfaceHit { t: 0.0, p: self.p, n: self.n, shading_n: self.ns, uv: self.uv, p_error: self.p_error }
    }
}

/// What one chunk of light paths made.
#[derive(Default)]
struct LightChunk {
    vertices: Vec<LightVertex>,
    /// Per path of the chunk, the end of its vertices in `vertices`.
    ends: Vec<u32>,
    splats: SplatBuffer,
    rays: RayCounts,
}

/// The photons of one iteration in a hashed uniform grid of cells twice the radius wide.
struct PhotonGrid {
    origin: Vec3,
    inv_cell: f32,
    mask: u64,
    /// Per bucket, the start of its photons in `indices` (one more entry at the end).
    starts: Vec<u32>,
    indices: Vec<u32>,
}

impl PhotonGrid {
    fn cell_of(&self, p: Vec3) -> [i64; 3] {
        let c = ((p - self.origin) * self.inv_cell).floor();
        [c.x as i64, c.y as i64, c.z as i64]
    }

    fn bucket(&self, c: [i64; 3]) -> usize {
        let h = (c[0] as u64).wrapping_mul(73_856_093)
            ^ (c[1] as u64).wrapping_mul(19_349_663)
            ^ (c[2] as u64).wrapping_mul(83_492_791);
        (h & self.mask) as usize
    }

    /// A grid over `vertices` for merges of radius `radius` (deterministic: a counting sort).
    fn build(vertices: &[LightVertex], radius: f32, origin: Vec3) -> PhotonGrid {
        let buckets = vertices.len().max(1).next_power_of_two();
        let mut grid = PhotonGrid {
            origin,
            inv_cell: 1.0 / (2.0 * radius),
            mask: buckets as u64 - 1,
            starts: vec![0; buckets + 1],
            indices: vec![0; vertices.len()],
        };
        let keys: Vec<usize> = vertices.iter().map(|v| grid.bucket(grid.cell_of(v.p))).collect();
        for &k in &keys {
            grid.starts[k + 1] += 1;
        }
        for b in 0..buckets {
            grid.starts[b + 1] += grid.starts[b];
        }
        let mut fill = grid.starts.clone();
        for (i, &k) in keys.iter().enumerate() {
            grid.indices[fill[k] as usize] = i as u32;
            fill[k] += 1;
        }
        grid
    }

    /// Call `visit` with the index of every photon within `radius` of `p`, each once.
    fn query(&self, vertices: &[LightVertex], p: Vec3, radius: f32, mut visit: impl FnMut(usize)) {
        let lo = self.cell_of(p - Vec3::splat(radius));
        let hi = self.cell_of(p + Vec3::splat(radius));
        let mut seen = [usize::MAX; 8];
        let mut count = 0;
        let r2 = radius * radius;
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    let b = self.bucket([x, y, z]);
                    if seen[..count].contains(&b) {
                        continue;
                    }
                    if count < seen.len() {
                        seen[count] = b;
                        count += 1;
                    }
                    for &i in &self.indices[self.starts[b] as usize..self.starts[b + 1] as usize] {
                        if (vertices[i as usize].p - p).length_squared() <= r2 {
                            visit(i as usize);
                        }
                    }
                }
            }
        }
    }
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

/// The running state of a sub-path.
struct SubPath {
    ctx: PathContext,
    /// Camera paths gather radiance, light paths carry importance.
    mode: TransportMode,
    /// The path's weight: its value over its density, the light's emitted power included.
    beta: Vec3,
    /// `beta` without the light's emission and the spectral factors: the roulette's measure of
    /// a light path.
    throughput: Vec3,
    /// The product of η² over the refractions so far: the radiance scaling a camera path's
    /// roulette leaves out (pbrt-v4's `etaScale`).
    eta_scale: f32,
    mis: Mis,
    segments: u32,
    specular_path: bool,
    /// The distance from the sub-path's true start to its first ray's origin: a camera ray
    /// clipped by the near plane starts that far from the lens point, which the first
    /// segment's density conversion must count (0 otherwise).
    start_offset: f32,
}

impl SubPath {
    /// A sub-path of weight `beta` and MIS state `mis` at its first segment.
    fn new(ctx: PathContext, mode: TransportMode, beta: Vec3, mis: Mis) -> SubPath {
        SubPath {
            ctx,
            mode,
            beta,
            throughput: Vec3::ONE,
            eta_scale: 1.0,
            mis,
            segments: 1,
            specular_path: true,
            start_offset: 0.0,
        }
    }

    /// The MIS update on scattering into `wi` with forward density `pdf` and reverse density
    /// `rev` (both ignored for specular and multiply scattered samples).
    fn scatter(&mut self, k: &IterationConstants, cos_out: f32, pdf: f32, rev: f32, evaluable: bool) {
        self.mis.scatter(k, cos_out, pdf, rev, evaluable);
        self.specular_path &= !evaluable;
    }

    /// The probability Russian roulette keeps the path with (before clamping to 1): a camera
    /// path's weight without the radiance scaling of refraction, a light path's throughput.
    fn survival(&self) -> f32 {
        match self.mode {
            TransportMode::Radiance => (self.beta * self.eta_scale).max_element(),
            TransportMode::Importance => self.throughput.max_element(),
        }
    }
}

/// The factor of a full path joined from two halves: 1/3 when both ended their secondary
/// wavelengths (each half carries the hero's factor 3, the path only once).
#[inline]
fn joined(a: bool, b: bool) -> f32 {
    if a && b {
        1.0 / 3.0
    } else {
        1.0
    }
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
    paths: usize,
    radius0: f32,
    /// The one strategy rendered alone, unweighted (`None`: all, weighted).
    only: Option<Strategy>,
}

impl<'a> Engine<'a> {
    fn new(scene: &'a Scene, integrator: &VertexMerging, opts: &'a RenderOptions) -> Engine<'a> {
        let camera = camera_for(scene, opts.resolution);
        let paths = camera.width as usize * camera.height as usize;
        Engine {
            scene,
            params: &opts.params,
            algorithm: integrator.0,
            pixel_area: camera.film_area() / paths as f32,
            dims: CameraDims::resolve(scene, integrator, opts.spectral),
            camera,
            sampler: opts.sampler,
            seed: opts.seed,
            replicas: opts.replicas,
            lights: scene.lights.len(),
            environment: scene.environment_light(),
            sphere: scene.bounding_sphere(),
            max_segments: opts.params.max_depth.saturating_add(1),
            paths,
            radius0: initial_radius(scene, &opts.params.merging),
            only: opts.params.merging.only,
        }
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
        let eta = PI * radius * radius * self.paths as f32;
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

    /// One iteration: light paths, photon grid, camera paths, then one term of every pixel.
    fn iteration(&self, s: u32, film: &mut Film) {
        let k = self.constants(s);
        let starts: Vec<usize> = (0..self.paths).step_by(CHUNK_PATHS).collect();
        let chunks: Vec<LightChunk> = starts
            .par_iter()
            .map(|&start| self.trace_light_chunk(start..(start + CHUNK_PATHS).min(self.paths), s, &k))
            .collect();
        let mut vertices = Vec::with_capacity(chunks.iter().map(|c| c.vertices.len()).sum());
        let mut ends = Vec::with_capacity(self.paths);
        let crop = self.camera.crop;
        let mut splats = SampleSplats::new(crop.pixels(), s);
        for chunk in chunks {
            let base = vertices.len() as u32;
            ends.extend(chunk.ends.iter().map(|e| e + base));
            vertices.extend_from_slice(&chunk.vertices);
            splats.add(film, chunk.splats);
            film.rays += chunk.rays;
        }
        let grid = self
            .algorithm
            .merges()
            .then(|| PhotonGrid::build(&vertices, k.radius, self.scene.bvh_stats.bounds.0));
        let light = LightPaths { vertices: &vertices, ends: &ends, grid: grid.as_ref() };
        // The camera paths of the crop window's pixels, each on its whole-film pixel's stream.
        let (w, x0, y0) = (self.camera.width as usize, crop.x as usize, crop.y as usize);
        let rows: Vec<(Vec<Vec3>, RayCounts, u64)> = (y0..y0 + crop.height as usize)
            .into_par_iter()
            .map(|y| {
                let mut rays = RayCounts::default();
                let mut non_finite = 0;
                let row = (x0..x0 + crop.width as usize)
                    .map(|x| {
                        let l = self.camera_path(y * w + x, s, &k, &light, &mut rays);
                        if !l.is_finite() {
                            non_finite += 1;
                        }
                        l
                    })
                    .collect();
                (row, rays, non_finite)
            })
            .collect();
        let mut camera = Vec::with_capacity(crop.pixels());
        for (row, rays, non_finite) in rows {
            film.rays += rays;
            film.non_finite += non_finite;
            camera.extend(row);
        }
        splats.finish(film, Some(&camera), 1.0 / self.camera.film_area() as f64);
    }

    /// The random stream of light path `j` of iteration `s`.
    fn light_sampler(&self, j: usize, s: u32) -> Sampler {
        let stream = self.replicas.stream(self.seed, s, 0);
        Sampler::new(self.sampler, stream.seed ^ LIGHT_STREAM, j as u64, stream.index, 0)
    }

    fn trace_light_chunk(&self, paths: Range<usize>, s: u32, k: &IterationConstants) -> LightChunk {
        let mut out = LightChunk::default();
        for j in paths {
            if self.lights > 0 {
                self.trace_light_path(j, s, k, &mut out);
            }
            out.ends.push(out.vertices.len() as u32);
        }
        out
    }

    /// Trace light path `j`: store its vertices and splat their connections to the camera.
    fn trace_light_path(&self, j: usize, s: u32, k: &IterationConstants, out: &mut LightChunk) {
        let (channels, time) = self.channels_and_time(j, s);
        let mut ctx = PathContext::new(self.light_sampler(j, s));
        ctx.channels = channels;
        let n = self.lights;
        let light = &self.scene.lights[pick_light(n, &mut ctx.sampler)];
        let side = ctx.sampler.get_1d(Dim::Light);
        let u_point = ctx.sampler.get_2d(Dim::Light);
        let u_dir = ctx.sampler.get_2d(Dim::Light);
        let Some(e) = light.emit(1.0 / n as f32, side, u_point, u_dir, &self.sphere) else { return };
        let mis = Mis::light(k, e.pdf_emit, e.pdf_direct, e.cos_light, e.delta);
        let mut path = SubPath::new(ctx, TransportMode::Importance, channels.colour(e.beta), mis);
        let shadow = ShadowRays { mode: ShadowMode::Opaque, channels, time };
        if let (Some(Strategy::CameraSplat), Some((origin, inv_pdf))) = (self.only, e.origin) {
            self.splat_emission_point(light, &origin, inv_pdf, &mut path, shadow, out);
        }
        let mut ray = e.ray;
        ray.time = time;
        path.ctx.rays.primary += 1;
        self.walk(ray, &mut path, k, e.infinite, &mut LightVisitor { engine: self, k, shadow, out });
        out.rays += path.ctx.rays;
    }

    /// The random walk of a sub-path from `ray`, shared by camera and light sub-paths: at every
    /// surface it reaches, the MIS update of the arrival, `visitor`'s strategies, then a BSDF
    /// sample, the absorption of the medium it enters and Russian roulette. `from_infinity`: the
    /// first segment comes from the environment (its density has no distance to convert by).
    fn walk(
        &self,
        mut ray: Ray,
        path: &mut SubPath,
        k: &IterationConstants,
        from_infinity: bool,
        visitor: &mut impl WalkVisitor,
    ) {
        let scene = self.scene;
        let mut absorption = Vec3::ZERO;
        loop {
            let Some(isect) = scene.intersect(&ray, f32::INFINITY) else {
                visitor.escaped(path, ray.dir, absorption != Vec3::ZERO);
                break;
            };
            let hit = &isect.hit;
            if absorption != Vec3::ZERO {
                let a = (-absorption * hit.t).exp();
                path.beta *= a;
                path.throughput *= a;
            }
            let cos_in = hit.n.dot(ray.dir).abs();
            if from_infinity && path.segments == 1 {
                path.mis.arrive_from_infinity(cos_in);
            } else if path.segments == 1 && path.start_offset > 0.0 {
                path.mis.arrive(hit.t + path.start_offset, cos_in);
            } else {
                path.mis.arrive(hit.t, cos_in);
            }
            if !visitor.reached(path, &ray, &isect) {
                break;
            }
            let material = scene.material_of(isect.primitive);
            let bsdf = Scattering::at(material, hit.p, hit.uv, &path.ctx.channels);
            path.beta *= path.ctx.end_secondaries_at(&material.bsdf, &bsdf);
            let wo = -ray.dir;
            let frame = ShadingFrame::at(hit, wo);
            let at = Vertex { hit, bsdf: &bsdf, frame: &frame, wo, wo_local: frame.to_local(wo) };
            let next = visitor.visit(path, &at, isect.primitive);
            if next == Next::Stop {
                break;
            }
            let Some(smp) = sample_bsdf(&bsdf, at.wo_local, path.mode, &mut path.ctx.sampler) else {
                break;
            };
            if smp.pdf <= 0.0 || smp.f == Vec3::ZERO {
                break;
            }
            let evaluable = smp.is_evaluable();
            if next == Next::SpecularOnly && evaluable {
                break;
            }
            let wi = frame.to_world(smp.wi);
            let shading = frame.factor(wo, wi, path.mode);
            if shading == 0.0 {
                break;
            }
            let cos_out = smp.wi.z.abs();
            let rev = if evaluable { bsdf.pdf(smp.wi, at.wo_local) } else { 0.0 };
            path.scatter(k, cos_out, smp.pdf, rev, evaluable);
            let step = smp.f
                * (cos_out / smp.pdf)
                * path.ctx.secondaries_after(&material.bsdf, &smp, at.wo_local)
                * shading;
            path.beta *= step;
            path.throughput *= step;
            if let Some(c) = crossing(&material.bsdf, ray.dir, hit.n, path.ctx.channels.hero()) {
                let medium = if smp.is_transmission { c.transmitted } else { c.incident };
                absorption = path.ctx.channels.colour(medium.absorption);
            }
            if smp.is_transmission {
                path.eta_scale *= smp.eta * smp.eta;
                path.ctx.rays.refracted += 1;
            } else {
                path.ctx.rays.reflected += 1;
            }
            ray = ray.spawn(spawn_origin(hit, wi), wi);
            path.segments += 1;
            if path.segments > ROULETTE_DEPTH + 1 {
                let rr = path.survival();
                if rr < 1.0 {
                    let q = (1.0 - rr).max(0.0);
                    if path.ctx.sampler.get_1d(Dim::Other) < q {
                        break;
                    }
                    path.beta /= 1.0 - q;
                    path.throughput /= 1.0 - q;
                }
            }
        }
    }

    /// Splat the emission point `origin` of an area light seen directly (`inv_pdf`: one over
    /// its density): only when light tracing's strategy is rendered alone, which is then all of
    /// light tracing; otherwise camera paths find an emitter they see, with weight 1.
    fn splat_emission_point(
        &self,
        light: &Light,
        origin: &SurfaceHit,
        inv_pdf: f32,
        path: &mut SubPath,
        shadow: ShadowRays,
        out: &mut LightChunk,
    ) {
        self.splat(origin, path, shadow, out, |ctx, c| {
            let le = light.emitted(origin, -c.dir) * (c.dir.dot(origin.n).abs() * inv_pdf);
            ctx.channels.colour(le)
        });
    }

    /// Splat the connection of light vertex `at` to the camera (light tracing's strategy).
    fn connect_to_camera(
        &self,
        at: &Vertex,
        path: &mut SubPath,
        k: &IterationConstants,
        shadow: ShadowRays,
        out: &mut LightChunk,
    ) {
        let (beta, light_mis) = (path.beta, path.mis);
        self.splat(at.hit, path, shadow, out, |_, c| {
            let wc_local = at.frame.to_local(-c.dir);
            let e = at.bsdf.evaluate(at.wo_local, wc_local, TransportMode::Importance);
            if e.f == Vec3::ZERO {
                return Vec3::ZERO;
            }
            let cos_v = wc_local.z.abs();
            // Density of this point per unit area as the camera samples it (one sample per pixel).
            let camera_pdf_a = cos_v / (self.pixel_area * c.dist2 * c.cos * c.cos * c.cos);
            let weight =
                self.weighted(mis::camera_splat(&light_mis, k, camera_pdf_a / self.paths as f32, e.pdf_rev));
            beta * e.f * (weight * cos_v * at.frame.factor(at.wo, -c.dir, TransportMode::Importance))
        });
    }

    /// Connect the light-path point `hit` to the camera and splat `value(context, connection)`
    /// ([`CameraTarget::splat`]).
    fn splat(
        &self,
        hit: &SurfaceHit,
        path: &mut SubPath,
        shadow: ShadowRays,
        out: &mut LightChunk,
        value: impl FnOnce(&PathContext, &CameraConnection) -> Vec3,
    ) {
        let target = CameraTarget { scene: self.scene, camera: &self.camera, lens: self.dims.lens };
        target.splat(hit, &mut path.ctx, shadow, &mut out.splats, value);
    }

    /// The radiance camera path `j` of iteration `s` gathers by its own strategies.
    fn camera_path(
        &self,
        j: usize,
        s: u32,
        k: &IterationConstants,
        light: &LightPaths,
        rays: &mut RayCounts,
    ) -> Vec3 {
        let cam = &self.camera;
        let (channels, time) = self.channels_and_time(j, s);
        let stream = self.replicas.stream(self.seed, s, 0);
        let mut ctx = PathContext::new(Sampler::of_stream(self.sampler, stream, j as u64));
        ctx.channels = channels;
        let (x, y) = ((j % cam.width as usize) as u32, (j / cam.width as usize) as u32);
        let film = cam.film_point(x, y, ctx.sampler.get_2d(Dim::Pixel));
        let lens = if self.dims.lens { ctx.sampler.get_2d(Dim::Lens) } else { Vec2::ZERO };
        let ray = cam.generate_ray_lens(film, lens, time);
        ctx.rays.primary += 1;
        let cos = ray.dir.dot(cam.forward);
        let camera_pdf_w = 1.0 / (self.pixel_area * cos * cos * cos);
        let mis = Mis::camera(self.paths as f32, camera_pdf_w);
        let mut path = SubPath::new(ctx, TransportMode::Radiance, Vec3::ONE, mis);
        path.start_offset = cam.near_clip / cos;
        let mut visitor = CameraVisitor {
            engine: self,
            j,
            k,
            light,
            shadow: ShadowRays { mode: ShadowMode::Opaque, channels, time },
            pick: 1.0 / self.lights.max(1) as f32,
            only_merges: self.algorithm.merges() && !self.algorithm.connects(),
            radiance: Vec3::ZERO,
        };
        self.walk(ray, &mut path, k, false, &mut visitor);
        *rays += path.ctx.rays;
        path.ctx.channels.to_rgb(visitor.radiance)
    }

    /// Next-event estimation at a camera vertex, weighted against every other strategy.
    fn next_event(
        &self,
        at: &Vertex,
        path: &mut SubPath,
        k: &IterationConstants,
        shadow: ShadowRays,
        pick: f32,
    ) -> Vec3 {
        let index = pick_light(self.lights, &mut path.ctx.sampler);
        let u = path.ctx.sampler.get_2d(Dim::Light);
        let light = &self.scene.lights[index];
        let Some(ls) = light.sample_li(at.hit.p, u) else { return Vec3::ZERO };
        let wi_local = at.frame.to_local(ls.wi);
        if at.frame.factor(at.wo, ls.wi, TransportMode::Radiance) == 0.0 {
            return Vec3::ZERO;
        }
        let e = at.bsdf.evaluate(at.wo_local, wi_local, TransportMode::Radiance);
        if e.f == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let cos_to_light = wi_local.z.abs();
        let (direct_w, emit_w, cos_at_light) =
            if let Some((direct, emit)) = light.delta_pdfs(&self.sphere, ls.distance) {
                (direct, emit, 1.0)
            } else if !ls.distance.is_finite() {
                let (emit, direct) = light.environment_pdfs(&self.sphere, ls.wi);
                (direct, emit, 1.0)
            } else {
                let cos_at_light = ls.normal.dot(-ls.wi).abs();
                if cos_at_light <= 0.0 {
                    // A grazing sample (a point of an emitter's own plane): its geometry term is 0.
                    return Vec3::ZERO;
                }
                (ls.pdf, light.emission_pdfs(at.hit.p, ls.position, ls.normal, -ls.wi).0, cos_at_light)
            };
        // A delta light cannot be hit by BSDF sampling.
        let dir_pdf = if ls.delta { 0.0 } else { e.pdf };
        let emit_ratio = emit_w * cos_to_light / (direct_w * cos_at_light);
        let weight =
            self.weighted(mis::next_event(&path.mis, k, dir_pdf, e.pdf_rev, pick * direct_w, emit_ratio));
        let target = if ls.distance.is_finite() {
            ls.position
        } else {
            at.hit.p + ls.wi * self.scene.far_distance(at.hit.p)
        };
        let visible =
            transmittance(self.scene, at.hit, target, Some(index as u32), shadow, &mut path.ctx.rays);
        if visible == Vec3::ZERO {
            return Vec3::ZERO;
        }
        e.f * path.ctx.channels.colour(ls.radiance) * visible * (weight * cos_to_light / (pick * ls.pdf))
    }

    /// The connection of a camera vertex to light vertex `v`, weighted.
    fn connect(
        &self,
        at: &Vertex,
        path: &mut SubPath,
        v: &LightVertex,
        k: &IterationConstants,
        shadow: ShadowRays,
    ) -> Vec3 {
        let d = v.p - at.hit.p;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0 && dist2.is_finite()) {
            return Vec3::ZERO;
        }
        let dir = d / dist2.sqrt();
        let wi_local = at.frame.to_local(dir);
        if at.frame.factor(at.wo, dir, TransportMode::Radiance) == 0.0 {
            return Vec3::ZERO;
        }
        let camera = at.bsdf.evaluate(at.wo_local, wi_local, TransportMode::Radiance);
        if camera.f == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let material = self.scene.material_of(v.primitive);
        let light_bsdf = Scattering::at(material, v.p, v.uv, &path.ctx.channels);
        let light_frame = ShadingFrame::at(&v.hit(), v.wo);
        let light_wo = light_frame.to_local(v.wo);
        let light_wi = light_frame.to_local(-dir);
        let light = light_bsdf.evaluate(light_wo, light_wi, TransportMode::Importance);
        if light.f == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let (cos_camera, cos_light) = (wi_local.z.abs(), light_wi.z.abs());
        let camera_dir_a = camera.pdf * cos_light / dist2;
        let light_dir_a = light.pdf * cos_camera / dist2;
        let weight = self.weighted(mis::connection(
            &path.mis,
            &v.mis,
            k,
            camera_dir_a,
            light_dir_a,
            camera.pdf_rev,
            light.pdf_rev,
        ));
        let target = spawn_origin(&v.hit(), -dir);
        let visible = transmittance(self.scene, at.hit, target, None, shadow, &mut path.ctx.rays);
        if visible == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let g = cos_camera * cos_light / dist2 * light_frame.factor(v.wo, -dir, TransportMode::Importance);
        camera.f * light.f * v.beta * visible * (weight * g * joined(path.ctx.hero_only, v.hero_only))
    }

    /// The merges of a camera vertex with the photons around it, weighted.
    fn merge(
        &self,
        at: &Vertex,
        path: &SubPath,
        k: &IterationConstants,
        vertices: &[LightVertex],
        grid: &PhotonGrid,
    ) -> Vec3 {
        let mut sum = Vec3::ZERO;
        let ppm = self.algorithm == Algorithm::Ppm;
        grid.query(vertices, at.hit.p, k.radius, |i| {
            let v = &vertices[i];
            if v.segments + path.segments > self.max_segments {
                return;
            }
            if at.frame.factor(at.wo, v.wo, TransportMode::Radiance) == 0.0 {
                return;
            }
            let wi_local = at.frame.to_local(v.wo);
            // Unweighted merges (`ppm`, a strategy alone) need the value only.
            let (f, weight) = if ppm || self.only.is_some() {
                (at.bsdf.eval(at.wo_local, wi_local, TransportMode::Radiance), 1.0)
            } else {
                let e = at.bsdf.evaluate(at.wo_local, wi_local, TransportMode::Radiance);
                (e.f, mis::merge(&path.mis, &v.mis, k, e.pdf, e.pdf_rev))
            };
            if f == Vec3::ZERO {
                return;
            }
            sum += f * v.beta * (weight * joined(path.ctx.hero_only, v.hero_only));
        });
        sum * k.vm_norm
    }
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

/// A light sub-path: its non-specular vertices are stored (for connections and merges) and
/// connected to the camera.
struct LightVisitor<'e, 'a> {
    engine: &'e Engine<'a>,
    k: &'e IterationConstants,
    shadow: ShadowRays,
    out: &'e mut LightChunk,
}

impl WalkVisitor for LightVisitor<'_, '_> {
    fn visit(&mut self, path: &mut SubPath, at: &Vertex, primitive: u32) -> Next {
        let e = self.engine;
        if !at.bsdf.is_delta() {
            self.out.vertices.push(LightVertex {
                p: at.hit.p,
                n: at.hit.n,
                uv: at.hit.uv,
                ns: at.hit.shading_n,
                p_error: at.hit.p_error,
                wo: at.wo,
                beta: path.beta,
                mis: path.mis,
                segments: path.segments,
                primitive,
                hero_only: path.ctx.hero_only,
            });
            if e.algorithm.connects() && e.keeps(Strategy::CameraSplat) && path.segments < e.max_segments {
                e.connect_to_camera(at, path, self.k, self.shadow, self.out);
            }
        }
        // A light sub-path leaves at least one segment of the full path to the camera.
        if path.segments + 2 > e.max_segments {
            Next::Stop
        } else {
            Next::Any
        }
    }
}

/// A camera sub-path: emitters it hits, next-event estimation, connections to the vertices of
/// its light sub-path and merges with the iteration's photons, summed in `radiance`.
struct CameraVisitor<'e, 'a> {
    engine: &'e Engine<'a>,
    j: usize,
    k: &'e IterationConstants,
    light: &'e LightPaths<'e>,
    shadow: ShadowRays,
    /// The probability of picking a given light.
    pick: f32,
    /// Whether the method merges without connecting (`ppm`, `bpm`).
    only_merges: bool,
    radiance: Vec3,
}

impl CameraVisitor<'_, '_> {
    /// The weight of emission found by the camera path itself; `densities` gives the
    /// emitter's (emission, direct) densities of the arrival.
    fn emitter_weight(&self, path: &SubPath, densities: impl FnOnce() -> (f32, f32)) -> f32 {
        if path.segments == 1 || self.engine.only.is_some() {
            1.0
        } else if self.only_merges {
            // Merging's paths: only a specular chain reaches an emitter by itself.
            if path.specular_path {
                1.0
            } else {
                0.0
            }
        } else {
            let (emit, direct) = densities();
            mis::emitter_hit(&path.mis, self.pick * direct, self.pick * emit)
        }
    }
}

impl WalkVisitor for CameraVisitor<'_, '_> {
    fn escaped(&mut self, path: &mut SubPath, dir: Vec3, absorbed: bool) {
        let e = self.engine;
        if absorbed || !e.keeps(Strategy::EmitterHit) {
            return;
        }
        // Without an environment light the background is no light: it is seen with weight 1.
        let weight = match e.environment {
            None => 1.0,
            Some(i) => self.emitter_weight(path, || e.scene.lights[i].environment_pdfs(&e.sphere, dir)),
        };
        self.radiance += path.beta * path.ctx.channels.colour(e.scene.background(dir)) * weight;
    }

    fn reached(&mut self, path: &mut SubPath, ray: &Ray, isect: &Intersection) -> bool {
        let e = self.engine;
        if let Some(index) = e.scene.light_of(isect.primitive) {
            let emitter = &e.scene.lights[index as usize];
            let (hit, wo) = (&isect.hit, -ray.dir);
            let le = emitter.emitted(hit, wo);
            if le != Vec3::ZERO && e.keeps(Strategy::EmitterHit) {
                let weight =
                    self.emitter_weight(path, || emitter.emission_pdfs(ray.origin, hit.p, hit.n, wo));
                self.radiance += path.beta * path.ctx.channels.colour(le) * weight;
            }
        }
        path.segments < e.max_segments
    }

    fn visit(&mut self, path: &mut SubPath, at: &Vertex, _: u32) -> Next {
        let (e, k, light, j) = (self.engine, self.k, self.light, self.j);
        if at.bsdf.is_delta() {
            return Next::Any;
        }
        if e.algorithm.connects() {
            if e.lights > 0 && e.keeps(Strategy::NextEvent) {
                self.radiance += path.beta * e.next_event(at, path, k, self.shadow, self.pick);
            }
            let range = if j == 0 { 0 } else { light.ends[j - 1] as usize }..light.ends[j] as usize;
            let connections = if e.keeps(Strategy::Connection) { &light.vertices[range] } else { &[] };
            for v in connections {
                if v.segments + path.segments + 1 > e.max_segments {
                    break;
                }
                self.radiance += path.beta * e.connect(at, path, v, k, self.shadow);
            }
        }
        let Some(grid) = light.grid else { return Next::Any };
        if e.keeps(Strategy::Merge) {
            self.radiance += path.beta * e.merge(at, path, k, light.vertices, grid);
        }
        // Photon mapping merges once: only the specular chain (multiply scattered samples of
        // rough glass included) goes on past a merge.
        if e.algorithm == Algorithm::Ppm {
            Next::SpecularOnly
        } else {
            Next::Any
        }
    }
}

/// The light sub-paths of an iteration.
struct LightPaths<'a> {
    vertices: &'a [LightVertex],
    ends: &'a [u32],
    grid: Option<&'a PhotonGrid>,
}
