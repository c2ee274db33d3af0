//! Every stage of the wavefront engine across lanes, for the scenes whose effects it covers
//! ([`LaneStages::new`] says which): chunks of 16 paths ([`PathChunk`]: the path state of
//! `path` with one lane per path, [`PathState`]`<Vec3x>`, and each path's own context) go
//! through one round per bounce:
//! 1. closest hits and their records across lanes ([`LaneScene::closest`],
//!    [`LaneScene::records`]);
//! 2. the vertex across lanes: [`PathState::advance`], the very function the scalar engine
//!    runs, here over the lanes' numbers with [`LaneStages`] as its world: the primitives'
//!    materials and the lights read from fixed-size tables ([`Table`], whose reads vectorise as
//!    gathers), each lane drawing its random numbers from its own stream at its own dimension;
//! 3. the shadow rays across lanes ([`LaneScene::occluded`]), and the light gathered where
//!    nothing blocks it;
//!
//! a path that ends writes its estimate and context back, and after each round the paths that
//! go on are compacted into full chunks. The camera rays are the camera pass's. Each lane
//! computes what the scalar engine computes, operation for operation: images are the scalar
//! engine's, bit for bit (`tests/wavefront.rs`).

// Lane loops index several arrays by the lane, as the kernels they vectorise into do.
#![allow(clippy::needless_range_loop)]

use super::super::path::{no_sample, LightDraw, PathState, PathWorld, Step, VertexBsdf, VertexFrame};
use super::super::{light_index, PathContext, RenderParams};
use super::{Occupancy, StageOccupancy};
use crate::bsdf::rough_dielectric::smooth_dielectric_sample;
use crate::bsdf::{BsdfSample, Frame, Lambert, RoughDielectric, TransportMode};
use crate::camera::concentric_disk_point;
use crate::geometry::Ray;
use crate::lanes::{
    dispatch, sobol_firsts, sobol_pairs, F32x, Isa, LaneHits, LaneScene, Mask, RayLanes, SurfaceX, Vec3x,
    WIDTH,
};
use crate::light::Light;
use crate::light::{area_to_solid_angle, front_area_sample, point_light_sample, quad_point, LightSampleOf};
use crate::lighting::ShadowSegment;
use crate::material::Bsdf;
use crate::sampler::{Dim, SamplerKind, DIM_PURPOSES};
use crate::scene::Scene;
use crate::stats::RayCounts;
use crate::texture::checker;
use crate::texture::Texture;
use glam::Vec3;

/// An idle lane's slot.
const NONE: u32 = u32::MAX;

/// Entries of a [`Table`]: the most primitives a [`LaneScene`] takes, and the most lights.
const ENTRIES: usize = LaneScene::MAX_PRIMITIVES;

/// One number per primitive (or light), read per lane at the lane's index; the index is taken
/// modulo the table's size (a power of two), so a read has no bounds check and the reads of 16
/// lanes vectorise as one gather.
#[derive(Clone, Copy, Debug)]
struct Table([f32; ENTRIES]);

impl Table {
    const ZERO: Table = Table([0.0; ENTRIES]);

    #[inline(always)]
    fn at(&self, index: &[u32; WIDTH]) -> F32x {
        F32x(std::array::from_fn(|k| self.0[index[k] as usize % ENTRIES]))
    }
}

/// A vector per primitive (or light): three [`Table`]s.
#[derive(Clone, Copy, Debug)]
struct Table3([Table; 3]);

impl Table3 {
    const ZERO: Table3 = Table3([Table::ZERO; 3]);

    #[inline(always)]
    fn at(&self, index: &[u32; WIDTH]) -> Vec3x {
        Vec3x::new(self.0[0].at(index), self.0[1].at(index), self.0[2].at(index))
    }

    fn get(&self, i: usize) -> Vec3 {
        Vec3::new(self.0[0].0[i], self.0[1].0[i], self.0[2].0[i])
    }

    fn set(&mut self, i: usize, v: Vec3) {
        (self.0[0].0[i], self.0[1].0[i], self.0[2].0[i]) = (v.x, v.y, v.z);
    }
}

/// What the stages read of a hit's primitive: its material (a diffuse albedo as a 3-D checker,
/// a constant colour being a checker of two equal colours; smooth glass with its relative index
/// and the absorption on each side) and, for a quad light, its emission.
#[derive(Clone, Debug)]
struct Primitives {
    glass: Table,
    color1: Table3,
    color2: Table3,
    cell: Table,
    eta: Table,
    inside: Table3,
    outside: Table3,
    /// Radiance of a quad light (zero for other primitives) and its area density.
    emit_radiance: Table3,
    emit_area_pdf: Table,
}

/// The lights (quads and points), per light.
#[derive(Clone, Debug)]
struct Lights {
    count: usize,
    /// 1 for a point light, 0 for a quad.
    point: Table,
    /// A quad's corner, a point light's position.
    corner: Table3,
    u: Table3,
    v: Table3,
    normal: Table3,
    /// A quad's radiance, a point light's intensity.
    radiance: Table3,
    /// 1/area, as [`Light::pdf_li`] computes it.
    area_pdf: Table,
}

/// Every stage across lanes for one scene.
#[derive(Clone, Debug)]
pub struct LaneStages {
    lanes: LaneScene,
    primitives: Primitives,
    lights: Lights,
    background: Vec3,
}

/// 16 camera paths: the path state with one lane per path, their streams and counters, and
/// the slot of the sample whose estimate each is ([`NONE`] for an idle lane).
#[derive(Clone, Copy, Debug)]
struct PathChunk {
    path: PathState<Vec3x>,
    ctx: LaneContext,
    slot: [u32; WIDTH],
}

/// The purposes a path vertex draws numbers for: [`Dim::Light`], [`Dim::Bsdf`] and
/// [`Dim::Other`], the last three.
const VERTEX_PURPOSES: usize = DIM_PURPOSES - Dim::Light as usize;

/// The random streams and counters of 16 paths, lane by lane: each lane's Sobol' stream (its
/// pixel key, bit-reversed sample index and next dimension: [`crate::sampler::SobolState`]),
/// and the requests and rays it has added since its path entered the lanes, given back to the
/// path's own context ([`PathContext`]) when it ends.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneContext {
    key: [u64; WIDTH],
    reversed: [u32; WIDTH],
    dimension: [u32; WIDTH],
    /// Requests for a light, a BSDF sample and anything else (the purposes a vertex draws for).
    requests: [[u32; WIDTH]; VERTEX_PURPOSES],
    /// Shadow, reflected and refracted rays.
    rays: [[u32; WIDTH]; 3],
}

/// One lane of a [`LaneContext`], for moving a path between lanes.
#[derive(Clone, Copy, Debug)]
struct ContextLane {
    stream: (u64, u32, u32),
    requests: [u32; VERTEX_PURPOSES],
    rays: [u32; 3],
}

impl LaneContext {
    const EMPTY: LaneContext = LaneContext {
        key: [0; WIDTH],
        reversed: [0; WIDTH],
        dimension: [0; WIDTH],
        requests: [[0; WIDTH]; VERTEX_PURPOSES],
        rays: [[0; WIDTH]; 3],
    };

    /// Lane `k` takes up the stream of `ctx` (a Sobol' stream), with nothing counted yet.
    fn start(&mut self, k: usize, ctx: &PathContext) {
        let state = ctx.sampler.sobol_state().expect("the lane stages take Sobol' streams only");
        (self.key[k], self.reversed[k], self.dimension[k]) =
            (state.pixel_key, state.reversed_sample, state.dimension);
        for r in &mut self.requests {
            r[k] = 0;
        }
        for r in &mut self.rays {
            r[k] = 0;
        }
    }

    /// Gives lane `k`'s numbers drawn and rays traced back to its path's context `ctx`.
    fn finish(&self, k: usize, ctx: &mut PathContext) {
        let mut requests = [0; DIM_PURPOSES];
        requests[Dim::Light as usize..].copy_from_slice(&self.requests.map(|r| r[k]));
        ctx.sampler.resume(self.dimension[k], &requests);
        let [shadow, reflected, refracted] = self.rays.map(|r| r[k] as u64);
        ctx.rays += RayCounts { primary: 0, reflected, refracted, shadow };
    }

    /// Lane `k`'s stream and counts.
    #[inline]
    fn lane(&self, k: usize) -> ContextLane {
        ContextLane {
            stream: (self.key[k], self.reversed[k], self.dimension[k]),
            requests: self.requests.map(|r| r[k]),
            rays: self.rays.map(|r| r[k]),
        }
    }

    /// Puts `lane` into lane `j`.
    #[inline]
    fn set_lane(&mut self, j: usize, lane: &ContextLane) {
        (self.key[j], self.reversed[j], self.dimension[j]) = lane.stream;
        for (to, from) in self.requests.iter_mut().zip(lane.requests) {
            to[j] = from;
        }
        for (to, from) in self.rays.iter_mut().zip(lane.rays) {
            to[j] = from;
        }
    }

    /// Counts a request for `purpose` of `dimensions` numbers in the `active` lanes.
    #[inline(always)]
    fn advance(&mut self, purpose: Dim, active: Mask, dimensions: u32) {
        debug_assert!(
            purpose as usize >= Dim::Light as usize,
            "a vertex draws for a light, a BSDF or roulette"
        );
        for k in 0..WIDTH {
            self.dimension[k] += dimensions * active.0[k] as u32;
            self.requests[purpose as usize - Dim::Light as usize][k] += active.0[k] as u32;
        }
    }
}

/// What the closest-hit stage found for a chunk: which lanes carry a path, their hits and the
/// hits' records.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneHit {
    live: Mask,
    found: Mask,
    hits: LaneHits,
    records: SurfaceX,
}

/// The scattering at 16 vertices: two-sided diffuse with its albedo, or smooth glass with its
/// relative index.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneBsdf {
    glass: Mask,
    lambert: Lambert<Vec3x>,
    eta: F32x,
}

/// A chunk's shadow rays: where one can be blocked, and the segments.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneShadow {
    shadowed: Mask,
    segment: ShadowSegment<Vec3x>,
    /// The light each lane's ray aims at.
    light: [u32; WIDTH],
}

impl PathState<Vec3x> {
    /// Lane `k`'s path.
    #[inline]
    fn lane(&self, k: usize) -> PathState {
        PathState {
            origin: self.origin.lane(k),
            dir: self.dir.lane(k),
            time: self.time.0[k],
            l: self.l.lane(k),
            beta: self.beta.lane(k),
            eta_scale: self.eta_scale.0[k],
            skip_mis: self.skip_mis.0[k],
            bsdf_pdf: self.bsdf_pdf.0[k],
            absorption: self.absorption.lane(k),
            depth: self.depth.0[k],
        }
    }

    /// Puts `path` into lane `k`.
    #[inline]
    fn set_lane(&mut self, k: usize, path: &PathState) {
        self.origin.set_lane(k, path.origin);
        self.dir.set_lane(k, path.dir);
        self.time.0[k] = path.time;
        self.l.set_lane(k, path.l);
        self.beta.set_lane(k, path.beta);
        self.eta_scale.0[k] = path.eta_scale;
        self.skip_mis.0[k] = path.skip_mis;
        self.bsdf_pdf.0[k] = path.bsdf_pdf;
        self.absorption.set_lane(k, path.absorption);
        self.depth.0[k] = path.depth;
    }
}

impl LaneStages {
    /// The stages for `scene` rendered with the Sobol' `sampler` in RGB (`spectral` false) with
    /// quad and point lights, or
    /// why they cannot run it (an effect whose data has no lane tables yet).
    pub fn new(
        scene: &Scene,
        lanes: LaneScene,
        sampler: SamplerKind,
        spectral: bool,
    ) -> Result<LaneStages, String> {
        if sampler != SamplerKind::Sobol {
            return Err(format!("the {} sampler has no lane form (the Sobol' sampler has)", sampler.name()));
        }
        if spectral {
            return Err("wavelengths are traced (dispersion)".into());
        }
        if scene.lights.is_empty() || scene.lights.len() > ENTRIES {
            return Err(format!("{} lights (the lanes take 1 to {ENTRIES})", scene.lights.len()));
        }
        let mut lights = Lights {
            count: scene.lights.len(),
            point: Table::ZERO,
            corner: Table3::ZERO,
            u: Table3::ZERO,
            v: Table3::ZERO,
            normal: Table3::ZERO,
            radiance: Table3::ZERO,
            area_pdf: Table::ZERO,
        };
        for (i, light) in scene.lights.iter().enumerate() {
            let (corner, u, v, normal, radiance) = match *light {
                Light::Quad { corner, u, v, normal, radiance } => (corner, u, v, normal, radiance),
                Light::Point { position, intensity } => {
                    lights.point.0[i] = 1.0;
                    lights.corner.set(i, position);
                    lights.radiance.set(i, intensity);
                    continue;
                }
                _ => {
                    return Err(
                        "a light is a sphere, a spot, a directional light, an emissive object or the environment (quads and points have a lane form)"
                            .into(),
                    )
                }
            };
            lights.corner.set(i, corner);
            lights.u.set(i, u);
            lights.v.set(i, v);
            lights.normal.set(i, normal);
            lights.radiance.set(i, radiance);
            lights.area_pdf.0[i] = 1.0 / u.cross(v).length();
        }
        let mut primitives = Primitives {
            glass: Table::ZERO,
            color1: Table3::ZERO,
            color2: Table3::ZERO,
            cell: Table([1.0; ENTRIES]),
            eta: Table([1.0; ENTRIES]),
            inside: Table3::ZERO,
            outside: Table3::ZERO,
            emit_radiance: Table3::ZERO,
            emit_area_pdf: Table::ZERO,
        };
        for (i, prim) in scene.primitives.iter().enumerate() {
            let m = &scene.materials[prim.material as usize];
            match &m.bsdf {
                Bsdf::Diffuse { one_sided: true, .. } => {
                    return Err(format!("material `{}` is a one-sided diffuse", m.name))
                }
                Bsdf::Diffuse { albedo: Texture::Constant(c), .. } => {
                    primitives.color1.set(i, *c);
                    primitives.color2.set(i, *c);
                }
                Bsdf::Diffuse { albedo: Texture::Checker { color1, color2, size }, .. } => {
                    primitives.color1.set(i, *color1);
                    primitives.color2.set(i, *color2);
                    primitives.cell.0[i] = *size;
                }
                Bsdf::Dielectric { inside, outside, roughness, distribution } if !m.bsdf.is_dispersive() => {
                    let eta = inside.ior_at(None) / outside.ior_at(None);
                    if !RoughDielectric::new(eta, distribution.with_alpha(roughness * roughness))
                        .is_specular()
                    {
                        return Err(format!("material `{}` is rough glass", m.name));
                    }
                    primitives.glass.0[i] = 1.0;
                    primitives.eta.0[i] = eta;
                    primitives.inside.set(i, inside.absorption);
                    primitives.outside.set(i, outside.absorption);
                }
                Bsdf::Diffuse { .. } => return Err(format!("material `{}` reads an image texture", m.name)),
                Bsdf::Mirror { .. } => return Err(format!("material `{}` is a mirror", m.name)),
                Bsdf::Conductor(_) => return Err(format!("material `{}` is a conductor", m.name)),
                Bsdf::ThinDielectric { .. } => {
                    return Err(format!("material `{}` is a thin dielectric", m.name))
                }
                Bsdf::Plastic { .. } => return Err(format!("material `{}` is a plastic", m.name)),
                Bsdf::RoughPlastic { .. } => return Err(format!("material `{}` is a rough plastic", m.name)),
                Bsdf::Dielectric { .. } => return Err(format!("material `{}` is dispersive glass", m.name)),
            }
            if let Some(l) = prim.light {
                primitives.emit_radiance.set(i, lights.radiance.get(l as usize));
                primitives.emit_area_pdf.0[i] = lights.area_pdf.0[l as usize];
            }
        }
        Ok(LaneStages { lanes, primitives, lights, background: scene.settings.background })
    }

    /// The instruction set the stages run with.
    pub fn isa(&self) -> Isa {
        self.lanes.isa()
    }

    /// The radiance of every camera ray of `rays`, each with its sample's context (its random
    /// stream, channels and counters, which it leaves as the scalar engine would), as
    /// [`crate::integrators::Path`]'s `radiance` gives it one at a time.
    pub fn radiance(
        &self,
        params: &RenderParams,
        rays: &[Ray],
        ctxs: &mut [PathContext],
        occupancy: &mut StageOccupancy,
    ) -> Vec<Vec3> {
        let n = rays.len();
        SCRATCH.with_borrow_mut(|scratch| {
            let chunks = &mut scratch.chunks;
            chunks.clear();
            for (c, (rays, ctxs)) in rays.chunks(WIDTH).zip(ctxs.chunks(WIDTH)).enumerate() {
                let mut chunk =
                    PathChunk { path: PathState::fresh(), ctx: LaneContext::EMPTY, slot: [NONE; WIDTH] };
                for (k, (ray, ctx)) in rays.iter().zip(ctxs).enumerate() {
                    chunk.path.set_lane(k, &PathState::new(*ray));
                    chunk.ctx.start(k, ctx);
                    chunk.slot[k] = (c * WIDTH + k) as u32;
                }
                chunks.push(chunk);
            }
            let mut estimates = vec![Vec3::ZERO; n];
            while !chunks.is_empty() {
                for chunk in chunks.iter_mut() {
                    let ended = self.round(params, chunk, occupancy);
                    for k in 0..WIDTH {
                        if ended.0[k] {
                            let slot = chunk.slot[k] as usize;
                            estimates[slot] = chunk.path.l.lane(k);
                            chunk.ctx.finish(k, &mut ctxs[slot]);
                            chunk.slot[k] = NONE;
                        }
                    }
                }
                compact(chunks);
            }
            estimates
        })
    }

    /// One bounce of the 16 paths of `chunk`: the lanes whose path ends.
    fn round(&self, params: &RenderParams, chunk: &mut PathChunk, occupancy: &mut StageOccupancy) -> Mask {
        let live = Mask(std::array::from_fn(|k| chunk.slot[k] != NONE));
        let rays = RayLanes { origin: chunk.path.origin.to_lanes(), dir: chunk.path.dir.to_lanes() };
        let tmax = F32x::select(live, F32x::splat(f32::INFINITY), F32x::splat(-1.0));
        let hits = self.lanes.closest(&rays, &tmax.0);
        occupancy.closest.add(live.count());
        let records = self.lanes.records(&rays, &hits);
        let found = live & F32x(hits.t).lt(F32x::splat(f32::INFINITY));
        let hit = LaneHit { live, found, hits, records };
        let step = shade(self.isa(), self, params, chunk, &hit);
        let visible = self.shadow_rays(&step.light.shadow, &mut occupancy.shadow);
        chunk.path.resolve(&step.light, visible);
        live & !step.goes_on
    }

    /// The shadow rays: whether each lane's pending light is visible (true where its shadow ray
    /// cannot be blocked).
    fn shadow_rays(&self, shadow: &LaneShadow, occupancy: &mut Occupancy) -> Mask {
        let used = shadow.shadowed.count();
        if used == 0 {
            return Mask::ALL;
        }
        occupancy.add(used);
        let segment = &shadow.segment;
        let rays = RayLanes { origin: segment.origin.to_lanes(), dir: segment.dir.to_lanes() };
        let tmax = F32x::select(shadow.shadowed, segment.tmax, F32x::splat(-1.0));
        let reach = segment.remaining * (1.0 - 1e-3);
        let blocked = self.lanes.occluded(&rays, &tmax.0, &shadow.light, &reach.0);
        !Mask(blocked)
    }
}

/// The vertex of every lane of `chunk` ([`PathState::advance`] with the stages as its world).
#[inline(always)]
fn shade_kernel(
    stages: &LaneStages,
    params: &RenderParams,
    chunk: &mut PathChunk,
    hit: &LaneHit,
) -> Step<Vec3x, LaneShadow> {
    chunk.path.advance(stages, params, hit, &mut chunk.ctx)
}

dispatch! {
    /// [`shade_kernel`] compiled for `isa`.
    fn shade(stages: &LaneStages, params: &RenderParams, chunk: &mut PathChunk, hit: &LaneHit) -> Step<Vec3x, LaneShadow> => shade_kernel
}

/// Packs the live paths of `chunks`, in order, into full chunks at the front (the last one
/// padded with idle lanes) and drops the rest. Paths only move towards the front, so this
/// works in place; a full chunk that stays where it is is not touched.
fn compact(chunks: &mut Vec<PathChunk>) {
    let (mut to_chunk, mut to_lane) = (0, 0);
    for from in 0..chunks.len() {
        if to_lane == 0 && chunks[from].slot.iter().all(|&s| s != NONE) {
            if to_chunk != from {
                chunks[to_chunk] = chunks[from];
            }
            to_chunk += 1;
            continue;
        }
        for k in 0..WIDTH {
            if chunks[from].slot[k] == NONE {
                continue;
            }
            let (path, ctx, slot) =
                (chunks[from].path.lane(k), chunks[from].ctx.lane(k), chunks[from].slot[k]);
            let to = &mut chunks[to_chunk];
            to.path.set_lane(to_lane, &path);
            to.ctx.set_lane(to_lane, &ctx);
            to.slot[to_lane] = slot;
            to_lane += 1;
            if to_lane == WIDTH {
                (to_chunk, to_lane) = (to_chunk + 1, 0);
            }
        }
    }
    if to_lane > 0 {
        chunks[to_chunk].slot[to_lane..].fill(NONE);
        to_chunk += 1;
    }
    chunks.truncate(to_chunk);
}

/// Buffers a thread reuses from one batch of paths to the next (fresh ones cost page faults).
#[derive(Default)]
struct Scratch {
    chunks: Vec<PathChunk>,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

impl PathWorld for LaneStages {
    type R = F32x;
    type V = Vec3x;
    type Hit = LaneHit;
    type Bsdf = LaneBsdf;
    type Frame = Frame<Vec3x>;
    type Light = [u32; WIDTH];
    type Shadow = LaneShadow;
    type Context = LaneContext;

    #[inline(always)]
    fn light_count(&self) -> usize {
        self.lights.count
    }

    #[inline(always)]
    fn live(&self, hit: &LaneHit) -> Mask {
        hit.live
    }

    #[inline(always)]
    fn found(&self, hit: &LaneHit) -> Mask {
        hit.found
    }

    #[inline(always)]
    fn surface(&self, hit: &LaneHit) -> (F32x, Vec3x, Vec3x, F32x) {
        (F32x(hit.hits.t), hit.records.p, hit.records.n, hit.records.p_error)
    }

    #[inline(always)]
    fn escaped(&self, _: Vec3x, _: Mask, _: F32x, _: F32x, _: Mask, _: &Self::Context) -> Vec3x {
        // No environment light (the stages take none): the plain background.
        Vec3x::splat(self.background)
    }

    #[inline(always)]
    fn emission(
        &self,
        hit: &LaneHit,
        origin: Vec3x,
        wo: Vec3x,
        _: Mask,
        _: &Self::Context,
    ) -> (Mask, Vec3x, F32x) {
        let primitive = &hit.hits.primitive;
        let (p, n) = (hit.records.p, hit.records.n);
        // Light::emitted of a quad: on its front.
        let le = Vec3x::select(
            n.dot(wo).gt(F32x::splat(0.0)),
            self.primitives.emit_radiance.at(primitive),
            Vec3x::ZERO,
        );
        let emits = !le.is_zero();
        let pdf_li = if emits.any() {
            area_to_solid_angle(self.primitives.emit_area_pdf.at(primitive), origin, p, n)
        } else {
            F32x::ZERO
        };
        (emits, le, pdf_li)
    }

    #[inline(always)]
    fn bsdf(&self, hit: &LaneHit, active: Mask, _: &mut Self::Context) -> (LaneBsdf, Vec3x) {
        let (prims, primitive) = (&self.primitives, &hit.hits.primitive);
        let glass = active & prims.glass.at(primitive).ne(F32x::splat(0.0));
        let albedo = if (active & !glass).any() {
            checker(
                hit.records.p,
                prims.cell.at(primitive),
                prims.color1.at(primitive),
                prims.color2.at(primitive),
            )
        } else {
            Vec3x::ZERO
        };
        let eta = if glass.any() { prims.eta.at(primitive) } else { F32x::ONE };
        // Two-sided diffuse (the stages take no one-sided surface).
        (LaneBsdf { glass, lambert: Lambert { albedo, one_sided: Mask::NONE }, eta }, Vec3x::ONE)
    }

    #[inline(always)]
    fn frame(&self, hit: &LaneHit, _: Vec3x) -> Frame<Vec3x> {
        // Analytic shapes: the shading normal is the geometric one.
        Frame::from_normal(hit.records.n)
    }

    #[inline(always)]
    fn draw_1d(&self, ctx: &mut LaneContext, purpose: Dim, active: Mask) -> F32x {
        if !active.any() {
            return F32x::ZERO;
        }
        let x = sobol_firsts(self.isa(), &ctx.key, &ctx.reversed, &ctx.dimension);
        ctx.advance(purpose, active, 1);
        F32x::select(active, F32x(x), F32x::ZERO)
    }

    #[inline(always)]
    fn draw_2d(&self, ctx: &mut LaneContext, purpose: Dim, active: Mask) -> (F32x, F32x) {
        if !active.any() {
            return (F32x::ZERO, F32x::ZERO);
        }
        let (x, y) = sobol_pairs(self.isa(), &ctx.key, &ctx.reversed, &ctx.dimension);
        ctx.advance(purpose, active, 2);
        (F32x::select(active, F32x(x), F32x::ZERO), F32x::select(active, F32x(y), F32x::ZERO))
    }

    #[inline(always)]
    fn light_at(&self, u: F32x) -> [u32; WIDTH] {
        std::array::from_fn(|k| light_index(u.0[k], self.lights.count) as u32)
    }

    #[inline(always)]
    fn sample_light(
        &self,
        hit: &LaneHit,
        l: [u32; WIDTH],
        (ux, uy): (F32x, F32x),
        active: Mask,
        _: &Self::Context,
    ) -> LightDraw<Vec3x> {
        let (lights, zero) = (&self.lights, F32x::ZERO);
        let p = hit.records.p;
        // One light is the same in every lane: no gathers.
        let one = lights.count == 1;
        let vector = |t: &Table3| if one { Vec3x::splat(t.get(0)) } else { t.at(&l) };
        let point = if one { Mask::splat(lights.point.0[0] != 0.0) } else { lights.point.at(&l).ne(zero) };
        // Light::sample_li of a quad (a point on it) or of a point light, where some lane has one.
        let (corner, emitted) = (vector(&lights.corner), vector(&lights.radiance));
        let quads = active & !point;
        let at_point = if (active & point).any() {
            point_light_sample(p, corner, emitted)
        } else {
            LightSampleOf::none()
        };
        if !quads.any() {
            return LightDraw { sample: at_point, delta: point, target: corner };
        }
        let y = quad_point(corner, vector(&lights.u), vector(&lights.v), ux, uy);
        let area_pdf = if one { F32x::splat(lights.area_pdf.0[0]) } else { lights.area_pdf.at(&l) };
        let on_quad = front_area_sample(p, y, vector(&lights.normal), emitted, area_pdf);
        let sample = LightSampleOf::select(point, &at_point, &on_quad);
        LightDraw { sample, delta: point, target: Vec3x::select(point, corner, y) }
    }

    #[inline(always)]
    fn no_shadow(&self) -> LaneShadow {
        let zero = F32x::ZERO;
        LaneShadow {
            shadowed: Mask::NONE,
            segment: ShadowSegment { origin: Vec3x::ZERO, dir: Vec3x::ZERO, tmax: zero, remaining: zero },
            light: [NONE; WIDTH],
        }
    }

    #[inline(always)]
    fn shadow(
        &self,
        hit: &LaneHit,
        target: Vec3x,
        light: [u32; WIDTH],
        _: F32x,
        active: Mask,
        ctx: &mut Self::Context,
    ) -> LaneShadow {
        let r = &hit.records;
        let segment = ShadowSegment::toward(r.p, r.n, r.p_error, target);
        for k in 0..WIDTH {
            ctx.rays[0][k] += active.0[k] as u32;
        }
        LaneShadow { shadowed: active & !segment.remaining.le(F32x::ZERO), segment, light }
    }

    #[inline(always)]
    fn secondaries_after(
        &self,
        _: &LaneHit,
        _: &BsdfSample<Vec3x>,
        _: Vec3x,
        _: Mask,
        _: &mut Self::Context,
    ) -> Vec3x {
        Vec3x::ONE
    }

    #[inline(always)]
    fn medium_after(
        &self,
        hit: &LaneHit,
        dir: Vec3x,
        transmitted: Mask,
        active: Mask,
        _: &Self::Context,
    ) -> (Mask, Vec3x) {
        let (prims, primitive) = (&self.primitives, &hit.hits.primitive);
        let glass = active & prims.glass.at(primitive).ne(F32x::splat(0.0));
        if !glass.any() {
            return (glass, Vec3x::ZERO);
        }
        // lighting::crossing: the medium a reflected ray stays in or a refracted one enters.
        let (inside, outside) = (prims.inside.at(primitive), prims.outside.at(primitive));
        let enters = dir.dot(hit.records.n).lt(F32x::ZERO);
        let incident = Vec3x::select(enters, outside, inside);
        let entered = Vec3x::select(enters, inside, outside);
        (glass, Vec3x::select(transmitted, entered, incident))
    }

    #[inline(always)]
    fn count_scattered(ctx: &mut Self::Context, reflected: Mask, active: Mask) {
        for k in 0..WIDTH {
            ctx.rays[1][k] += (active.0[k] & reflected.0[k]) as u32;
            ctx.rays[2][k] += (active.0[k] & !reflected.0[k]) as u32;
        }
    }
}

impl VertexBsdf<Vec3x> for LaneBsdf {
    #[inline(always)]
    fn is_delta(&self) -> Mask {
        self.glass
    }

    #[inline(always)]
    fn chooses_lobe(&self) -> Mask {
        self.glass
    }

    #[inline(always)]
    fn eval(&self, wo: Vec3x, wi: Vec3x) -> Vec3x {
        self.lambert.eval(wo, wi)
    }

    #[inline(always)]
    fn pdf(&self, wo: Vec3x, wi: Vec3x) -> F32x {
        self.lambert.pdf(wo, wi)
    }

    #[inline(always)]
    fn sample(&self, wo: Vec3x, uc: F32x, (ux, uy): (F32x, F32x), active: Mask) -> (Mask, BsdfSample<Vec3x>) {
        let (glass, diffuse) = (active & self.glass, active & !self.glass);
        let (mut ok, mut s) = (Mask::NONE, no_sample());
        if glass.any() {
            // Smooth glass: RoughDielectric::sample.
            let (glass_ok, g) = smooth_dielectric_sample(self.eta, wo, uc, TransportMode::Radiance);
            (ok, s) = (glass & glass_ok, g);
        }
        if diffuse.any() {
            // Lambert::sample.
            let (dx, dy) = concentric_disk_point(ux, uy, diffuse);
            let (diffuse_ok, d) = self.lambert.disk_sample(wo, dx, dy);
            ok = ok | (diffuse & diffuse_ok);
            s = BsdfSample::select(diffuse, &d, &s);
        }
        (ok, s)
    }
}

impl VertexFrame<Vec3x> for Frame<Vec3x> {
    #[inline(always)]
    fn to_local(&self, v: Vec3x) -> Vec3x {
        Frame::to_local(self, v)
    }

    #[inline(always)]
    fn to_world(&self, v: Vec3x) -> Vec3x {
        Frame::to_world(self, v)
    }

    #[inline(always)]
    fn factor(&self, _: Vec3x, _: Vec3x) -> F32x {
        // Analytic shapes: no shading normal, so the factor is exactly 1.
        F32x::ONE
    }
}
