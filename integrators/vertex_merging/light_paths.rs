//! The light sub-paths of an iteration: traced in fixed chunks of [`CHUNK_PATHS`] paths (the
//! unit of determinism), their non-specular vertices stored path after path ([`LightStore`]),
//! photons and connection ends both, and their connections to the camera splatted onto the
//! film as they are made.

use super::{
    mis, Engine, IterationConstants, Mis, Next, PhotonGrid, SubPath, Vertex, WalkVisitor, CHUNK_PATHS,
    LIGHT_STREAM,
};
use crate::bsdf::TransportMode;
use crate::camera::CameraConnection;
use crate::geometry::SurfaceHit;
use crate::integrators::splat_film::{CameraTarget, SampleSplats, SplatBuffer};
use crate::integrators::{pick_light, PathContext, Strategy};
use crate::light::Light;
use crate::lighting::{ShadowMode, ShadowRays};
use crate::render::Film;
use crate::sampler::{Dim, Sampler};
use crate::stats::RayCounts;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::ops::Range;

/// Chunks traced in parallel before their vertices join the store.
const CHUNKS_PER_GROUP: usize = 16;

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
    /// Whether the path has ended its secondary wavelengths.
    pub(super) hero_only: bool,
}

impl LightVertex {
    /// The surface point of the vertex.
    pub(super) fn hit(&self) -> SurfaceHit {
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

/// The stored light sub-paths of an iteration.
pub(super) struct LightStore {
    /// The vertices of every light path, path after path.
    pub vertices: Vec<LightVertex>,
    /// Per light path, the end of its vertices in `vertices`.
    pub ends: Vec<u32>,
}

/// The light sub-paths of an iteration, as the camera paths see them.
pub(super) struct LightPaths<'a> {
    /// The vertices of every light path, path after path.
    pub vertices: &'a [LightVertex],
    /// Per light path, the end of its vertices in `vertices`.
    pub ends: &'a [u32],
    /// The photon grid over `vertices` (merging methods only).
    pub grid: Option<&'a PhotonGrid>,
}

impl LightPaths<'_> {
    /// The vertices of light path `j`, from the light on.
    pub fn of(&self, j: usize) -> &[LightVertex] {
        let start = if j == 0 { 0 } else { self.ends[j - 1] as usize };
        &self.vertices[start..self.ends[j] as usize]
    }
}

impl Engine<'_> {
    /// Trace the `N` light paths of iteration `s` in fixed chunks: their splats go to `film`
    /// (through `splats`, in chunk order), their vertices are kept, path after path.
    pub(super) fn trace_light_paths(
        &self,
        s: u32,
        k: &IterationConstants,
        film: &mut Film,
        splats: &mut SampleSplats,
    ) -> LightStore {
        let n = self.light_paths;
        let starts: Vec<usize> = (0..n).step_by(CHUNK_PATHS).collect();
        let mut store = LightStore { vertices: Vec::new(), ends: Vec::with_capacity(n) };
        // A group of chunks at a time, so that the chunks' own copies of their vertices (before
        // they join the store) hold a group's worth at most.
        for group in starts.chunks(CHUNKS_PER_GROUP) {
            let chunks: Vec<LightChunk> = group
                .par_iter()
                .map(|&start| self.trace_light_chunk(start..(start + CHUNK_PATHS).min(n), s, k))
                .collect();
            for chunk in chunks {
                let base = store.vertices.len() as u32;
                store.ends.extend(chunk.ends.iter().map(|e| e + base));
                store.vertices.extend_from_slice(&chunk.vertices);
                splats.add(film, chunk.splats);
                film.rays += chunk.rays;
            }
        }
        store
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
            let weight = self.weighted(mis::camera_splat(
                &light_mis,
                k,
                camera_pdf_a / self.light_paths as f32,
                e.pdf_rev,
            ));
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
}

/// A light sub-path: its non-specular vertices are stored (for connections and merges) and
/// connected to the camera.
struct LightVisitor<'e, 'a> {
    /// The engine.
    engine: &'e Engine<'a>,
    /// The iteration's MIS constants.
    k: &'e IterationConstants,
    /// How shadow rays of the path are traced.
    shadow: ShadowRays,
    /// Where the path's vertices, splats and rays go.
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
