//! The light sub-paths of an iteration: traced in chunks of at most [`CHUNK_PATHS`] paths and
//! [`CHUNK_VERTICES`] stored vertices, in batches of at most [`store_budget`] stored vertices
//! ([`LightStore`]: their non-specular vertices path after path, photons and connection ends both),
//! their connections to the camera splatted onto the film as they are made. Each path has its own
//! random stream and the chunks join the store in path order, so the result does not depend on
//! the chunks or the thread count.

use super::{
    mis, store_bound, store_budget, Carries, Engine, IterationConstants, Mis, Next, PhotonGrid, SubPath,
    Vertex, WalkVisitor, CHUNK_PATHS, CHUNK_VERTICES, LIGHT_STREAM, VERTICES_PER_PATH,
};
use crate::bsdf::TransportMode;
use crate::camera::CameraConnection;
use crate::geometry::SurfaceHit;
use crate::integrators::splat_film::{CameraTarget, SampleSplats, SplatBuffer};
use crate::integrators::{pick_light, PathContext, Strategy};
use crate::light::{Emission, Light};
use crate::render::Film;
use crate::sampler::{Dim, Sampler};
use crate::stats::RayCounts;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::ops::Range;

/// Chunks traced in parallel before their vertices join the store.
pub(super) const CHUNKS_PER_GROUP: usize = 16;

/// A light sub-path vertex on a non-delta surface: a photon and a connection end.
#[derive(Clone, Copy, Debug)]
pub(super) struct LightVertex {
    /// The surface point.
    pub(super) p: Vec3,
    /// The geometric normal.
    pub(super) n: Vec3,
    /// Texture coordinates of the surface here.
    pub(super) uv: Vec2,
    /// The shading normal.
    pub(super) ns: Vec3,
    /// The bound on the point's rounding error (for spawning rays).
    pub(super) p_error: f32,
    /// Unit direction towards the previous vertex of the light path (where the light came from).
    pub(super) wo: Vec3,
    /// Path weight from the light to this vertex (emission included).
    pub(super) beta: Vec3,
    /// The light sub-path's MIS quantities here.
    pub(super) mis: Mis,
    /// Segments from the light to this vertex.
    pub(super) segments: u32,
    /// The primitive hit (its material).
    pub(super) primitive: u32,
    /// What the light sub-path's channels carry here (a branch of a split: its one channel).
    pub(super) carries: Carries,
}

impl LightVertex {
    /// The vertex of the light sub-path `path` at `at` on primitive `primitive`.
    pub(super) fn at(at: &Vertex, path: &SubPath, primitive: u32) -> LightVertex {
        LightVertex {
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
            carries: path.carries,
        }
    }

    /// The surface point of the vertex.
    pub(super) fn hit(&self) -> SurfaceHit {
        SurfaceHit { t: 0.0, p: self.p, n: self.n, shading_n: self.ns, uv: self.uv, p_error: self.p_error }
    }
}

/// What one chunk of light paths made (kept between rounds for the room of its arrays).
#[derive(Default)]
pub(super) struct LightChunk {
    vertices: Vec<LightVertex>,
    /// Per path of the chunk, the end of its vertices in `vertices`.
    ends: Vec<u32>,
    splats: SplatBuffer,
    rays: RayCounts,
}

/// The stored light sub-paths of one batch of an iteration: at most
/// [`store_budget`] vertices, however many the scene's paths store.
#[derive(Default)]
pub(super) struct LightStore {
    /// The index of the batch's first light path in the iteration.
    pub first: usize,
    /// The vertices of the batch's light paths, path after path.
    pub vertices: Vec<LightVertex>,
    /// Per light path of the batch, the end of its vertices in `vertices`.
    pub ends: Vec<u32>,
    /// The chunks of the round being traced.
    chunks: Vec<LightChunk>,
}

/// The light sub-paths of a batch, as the camera paths see them.
pub(super) struct LightPaths<'a> {
    /// The index of the batch's first light path in the iteration.
    pub first: usize,
    /// The vertices of the batch's light paths, path after path.
    pub vertices: &'a [LightVertex],
    /// Per light path of the batch, the end of its vertices in `vertices`.
    pub ends: &'a [u32],
    /// The photon grid over `vertices` (merging methods only).
    pub grid: Option<&'a PhotonGrid>,
}

impl LightStore {
    /// The bytes its arrays and its chunks' arrays hold (their room, not only what they use).
    #[cfg(test)]
    pub fn bytes_held(&self) -> u64 {
        let vertex = std::mem::size_of::<LightVertex>();
        let chunks: usize = self
            .chunks
            .iter()
            .map(|c| c.vertices.capacity() * vertex + c.ends.capacity() * 4 + c.splats.bytes_held())
            .sum();
        (self.vertices.capacity() * vertex + self.ends.capacity() * 4 + chunks) as u64
    }
}

impl LightPaths<'_> {
    /// The vertices of light path `j` of the iteration, from the light on, then those of the
    /// branches split from it at smooth dispersive glass, each from its split on; `None` when
    /// the path is not in this batch.
    pub fn of(&self, j: usize) -> Option<&[LightVertex]> {
        let i = j.checked_sub(self.first).filter(|&i| i < self.ends.len())?;
        let start = if i == 0 { 0 } else { self.ends[i - 1] as usize };
        Some(&self.vertices[start..self.ends[i] as usize])
    }
}

impl Engine<'_> {
    /// Trace the next batch of the `N` light paths of iteration `s`, from path `*next` on, into
    /// `store`: in rounds of [`CHUNKS_PER_GROUP`] chunks traced in parallel, joined in order,
    /// until the store would exceed [`store_budget`] vertices or every path is traced.
    /// Their splats go to `film` (through `splats`, in path order), their vertices stay, path
    /// after path; `*next` moves past the paths stored. A chunk stops once it holds
    /// [`CHUNK_VERTICES`] vertices (the chunks after it in its round are traced again in the
    /// next round), and a round's chunks hold as many paths as fit that many vertices at the
    /// batch's mean so far, so the chunks on their way to the store stay bounded too. Paths are
    /// traced from their own streams and joined in order, so neither the chunks nor the thread
    /// count change a bit of the result.
    pub(super) fn trace_light_batch(
        &self,
        next: &mut usize,
        s: u32,
        k: &IterationConstants,
        film: &mut Film,
        splats: &mut SampleSplats,
        store: &mut LightStore,
    ) {
        let n = self.light_paths;
        let budget = store_budget(&self.params.merging);
        store.first = *next;
        store.vertices.clear();
        store.ends.clear();
        let bound = store_bound(n, &self.params.merging, self.max_segments as usize);
        store.ends.reserve_exact(n);
        while *next < n {
            // Paths per chunk: the chunk's vertices at 1.5 times the mean per path so far
            // (VERTICES_PER_PATH before any), within CHUNK_VERTICES.
            let mean = if store.ends.is_empty() {
                VERTICES_PER_PATH as f64
            } else {
                store.vertices.len() as f64 / store.ends.len() as f64
            };
            let size = ((CHUNK_VERTICES as f64 / (1.5 * mean.max(1.0))) as usize).clamp(1, CHUNK_PATHS);
            let starts: Vec<usize> =
                (0..CHUNKS_PER_GROUP).map(|i| *next + i * size).take_while(|&a| a < n).collect();
            if store.chunks.len() < starts.len() {
                store.chunks.resize_with(starts.len(), LightChunk::default);
            }
            let mut chunks = std::mem::take(&mut store.chunks);
            chunks[..starts.len()]
                .par_iter_mut()
                .zip(&starts)
                .for_each(|(chunk, &a)| self.trace_light_chunk(chunk, a..(a + size).min(n), s, k));
            for (chunk, &a) in chunks.iter_mut().zip(&starts) {
                if !store.ends.is_empty() && store.vertices.len() + chunk.vertices.len() > budget {
                    // The batch is full: this chunk and the rest start the next batch.
                    store.chunks = chunks;
                    return;
                }
                let base = store.vertices.len() as u32;
                store.ends.extend(chunk.ends.iter().map(|e| e + base));
                grow_within(&mut store.vertices, chunk.vertices.len(), bound);
                store.vertices.extend_from_slice(&chunk.vertices);
                splats.add(film, &mut chunk.splats);
                film.rays += chunk.rays;
                *next = a + chunk.ends.len();
                if *next < (a + size).min(n) {
                    // The chunk stopped at its vertex bound: the next round starts where it did.
                    break;
                }
            }
            store.chunks = chunks;
        }
    }

    /// The random stream of light path `j` of iteration `s`.
    fn light_sampler(&self, j: usize, s: u32) -> Sampler {
        let stream = self.replicas.stream(self.seed, s, 0);
        Sampler::new(self.sampler, stream.seed ^ LIGHT_STREAM, j as u64, stream.index, 0)
    }

    /// Trace the light paths `paths` of iteration `s` into `out` (emptied first), until they
    /// are traced or `out` holds [`CHUNK_VERTICES`] vertices or more.
    fn trace_light_chunk(&self, out: &mut LightChunk, paths: Range<usize>, s: u32, k: &IterationConstants) {
        out.vertices.clear();
        out.vertices.reserve_exact(CHUNK_VERTICES + self.max_segments as usize);
        out.ends.clear();
        out.splats.clear();
        out.rays = RayCounts::default();
        for j in paths {
            if out.vertices.len() >= CHUNK_VERTICES {
                break;
            }
            if self.lights > 0 {
                self.trace_light_path(j, s, k, out);
            }
            out.ends.push(out.vertices.len() as u32);
        }
        out.splats.settle(&self.shadows(), true);
    }

    /// Trace light path `j`: store its vertices and splat their connections to the camera.
    fn trace_light_path(&self, j: usize, s: u32, k: &IterationConstants, out: &mut LightChunk) {
        let (channels, time) = self.channels_and_time(j, s);
        let mut ctx = PathContext::new(self.light_sampler(j, s));
        ctx.channels = channels;
        ctx.hero_alone = self.hero_alone;
        let Some((light, e, mut path)) = self.light_subpath(ctx, k) else { return };
        if let (Some(Strategy::CameraSplat), Some((origin, inv_pdf))) = (self.only, e.origin) {
            self.splat_emission_point(light, &origin, inv_pdf, &mut path, time, out);
        }
        let mut ray = e.ray;
        ray.time = time;
        path.ctx.rays.primary += 1;
        self.walk(ray, &mut path, k, e.infinite, &mut LightVisitor { engine: self, k, time, out });
        out.rays += path.ctx.rays;
    }

    /// A light sub-path drawing its numbers from `ctx` (its channels set): the light picked,
    /// its emission (the first ray, without the time) and the path's state; `None` where the
    /// light emits nothing there.
    pub(super) fn light_subpath(
        &self,
        mut ctx: PathContext,
        k: &IterationConstants,
    ) -> Option<(&Light, Emission, SubPath)> {
        let n = self.lights;
        let light = &self.scene.lights[pick_light(n, &mut ctx.sampler)];
        let side = ctx.sampler.get_1d(Dim::Light);
        let u_point = ctx.sampler.get_2d(Dim::Light);
        let u_dir = ctx.sampler.get_2d(Dim::Light);
        let e = light.emit(1.0 / n as f32, side, u_point, u_dir, &self.sphere)?;
        let mis = Mis::light(k, e.pdf_emit, e.pdf_direct, e.cos_light, e.delta);
        let beta = ctx.channels.colour(e.beta);
        Some((light, e, SubPath::new(ctx, TransportMode::Importance, beta, mis)))
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
        time: f32,
        out: &mut LightChunk,
    ) {
        self.splat(origin, path, time, out, |ctx, c| {
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
        time: f32,
        out: &mut LightChunk,
    ) {
        let (beta, light_mis) = (path.beta, path.mis);
        self.splat(at.hit, path, time, out, |_, c| self.camera_splat_value(at, beta, &light_mis, k, c));
    }

    /// The value light tracing's strategy gives the connection `c` of the light vertex `at`
    /// (path weight `beta`, MIS state `light_mis`) to the camera, weighted, before the
    /// pinhole's importance ([`CameraTarget::splat`]).
    pub(super) fn camera_splat_value(
        &self,
        at: &Vertex,
        beta: Vec3,
        light_mis: &Mis,
        k: &IterationConstants,
        c: &CameraConnection,
    ) -> Vec3 {
        let wc_local = at.frame.to_local(-c.dir);
        let e = at.bsdf.evaluate(at.wo_local, wc_local, TransportMode::Importance);
        if e.f == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let cos_v = wc_local.z.abs();
        // Density of this point per unit area as the camera samples it (one sample per pixel).
        let camera_pdf_a = cos_v / (self.pixel_area * c.dist2 * c.cos * c.cos * c.cos);
        let weight =
            self.weighted(mis::camera_splat(light_mis, k, camera_pdf_a / self.light_paths as f32, e.pdf_rev));
        beta * e.f * (weight * cos_v * at.frame.factor(at.wo, -c.dir, TransportMode::Importance))
    }

    /// Connect the light-path point `hit` to the camera at time `time` and splat
    /// `value(context, connection)` ([`CameraTarget::splat`]).
    fn splat(
        &self,
        hit: &SurfaceHit,
        path: &mut SubPath,
        time: f32,
        out: &mut LightChunk,
        value: impl FnOnce(&PathContext, &CameraConnection) -> Vec3,
    ) {
        let target = CameraTarget { camera: &self.camera, lens: self.dims.lens, shadows: self.shadows() };
        target.splat(hit, &mut path.ctx, time, &mut out.splats, value);
    }
}

/// Make room in `v` for `extra` more elements: by doubling, as a `Vec` grows, but never past
/// `bound` elements (unless it must hold more), so that the room stays within the memory
/// estimate. Growing as needed, rather than reserving the bound at once, keeps small renders'
/// stores small (and in memory the allocator reuses, not fresh pages).
fn grow_within<T>(v: &mut Vec<T>, extra: usize, bound: usize) {
    let need = v.len() + extra;
    if need > v.capacity() {
        let room = need.max(2 * v.capacity()).min(bound.max(need));
        v.reserve_exact(room - v.len());
    }
}

/// A light sub-path: its non-specular vertices are stored (for connections and merges) and
/// connected to the camera.
struct LightVisitor<'e, 'a> {
    /// The engine.
    engine: &'e Engine<'a>,
    /// The iteration's MIS constants.
    k: &'e IterationConstants,
    /// The path's time (its shadow rays').
    time: f32,
    /// Where the path's vertices, splats and rays go.
    out: &'e mut LightChunk,
}

impl WalkVisitor for LightVisitor<'_, '_> {
    fn visit(&mut self, path: &mut SubPath, at: &Vertex, primitive: u32) -> Next {
        let e = self.engine;
        if !at.bsdf.is_delta() {
            self.out.vertices.push(LightVertex::at(at, path, primitive));
            if e.algorithm.connects() && e.keeps(Strategy::CameraSplat) && path.segments < e.max_segments {
                e.connect_to_camera(at, path, self.k, self.time, self.out);
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
