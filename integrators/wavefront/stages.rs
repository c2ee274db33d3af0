//! Every stage of the wavefront engine across lanes: chunks of 16 paths ([`PathChunk`]: the
//! path state of `path` with one lane per path, [`PathState`]`<Vec3x>`, and each path's own
//! context) go through one round per bounce:
//! 1. closest hits and their records across lanes ([`LaneScene::closest`],
//!    [`LaneScene::records`]; with moving objects each lane's ray through the BVH at its time);
//! 2. the vertex across lanes: [`PathState::advance`], the very function the scalar engine
//!    runs, here over the lanes' numbers with [`LaneWorld`] as its world: the hits'
//!    materials and the lights read from fixed-size tables ([`Table`], whose reads vectorise as
//!    gathers), each lane drawing its random numbers from its own stream at its own dimension;
//! 3. the shadow rays across lanes ([`LaneScene::occluded`]), and the light gathered where
//!    nothing blocks it;
//!
//! a path that ends writes its estimate and context back, and after each round the paths that
//! go on are compacted into full chunks. The camera rays are the camera pass's.
//!
//! What the tables do not hold (a material, a light or an emitter without a lane form, an
//! environment, wavelengths, more materials than the tables take, the hit records of shapes
//! the lane kernels do not record, another sampler's draws) the world asks of the scalar world
//! (`OneRay`) lane by lane, for the lanes that need it: the
//! same functions the scalar engine calls, so nothing is written twice, and the rest of the
//! vertex stays across lanes. [`LaneStages::lane_by_lane`] says what a scene sends that way.
//! Each lane computes what the scalar engine computes, operation for operation: images are the
//! scalar engine's, bit for bit (`tests/wavefront.rs`).

// Lane loops index several arrays by the lane, as the kernels they vectorise into do.
#![allow(clippy::needless_range_loop)]

use super::super::path::{PathState, Step};
use super::super::{PathContext, RenderParams};
use super::{Occupancy, StageOccupancy};
use crate::bsdf::RoughDielectric;
use crate::geometry::Ray;
use crate::lanes::{dispatch, F32x, Isa, LaneHits, LaneScene, Mask, RayLanes, SurfaceX, Vec3x, WIDTH};
use crate::light::Light;
use crate::lighting::ShadowRay;
use crate::material::Bsdf;
use crate::render::CameraRays;
use crate::sampler::{Dim, SamplerKind, DIM_PURPOSES};
use crate::scene::{Intersection, Scene};
use crate::stats::RayCounts;
use crate::texture::Texture;
use glam::Vec3;
use world::lanes_of;
pub(crate) use world::{LaneCtx, LaneShadow, LaneWorld, Models};

mod world;

/// An idle lane's slot.
const NONE: u32 = u32::MAX;

/// Entries of a [`Table`]: the most materials and lights the tables take.
const ENTRIES: usize = LaneScene::MAX_PRIMITIVES;

/// One number per material (or light), read per lane at the lane's index; the index is taken
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

    /// Where the entry at each lane's index is set (not 0).
    #[inline(always)]
    fn set_at(&self, index: &[u32; WIDTH]) -> Mask {
        self.at(index).ne(F32x::ZERO)
    }
}

/// A vector per material (or light): three [`Table`]s.
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

/// What the stages read of a hit's material, per material: a diffuse albedo as a 3-D checker (a
/// constant colour being a checker of two equal colours), or smooth glass with its relative index
/// and the absorption on each side.
#[derive(Clone, Debug)]
struct Materials {
    glass: Table,
    color1: Table3,
    color2: Table3,
    cell: Table,
    eta: Table,
    inside: Table3,
    outside: Table3,
}

/// What the stages read of a hit's primitive, per primitive: its material, the light it emits
/// as ([`NONE`] for none), whether its vertices are the scalar world's (a material the tables
/// do not hold), and whether its emission is (an emitter the tables do not hold).
#[derive(Clone, Debug, Default)]
struct Primitives {
    material: Vec<u32>,
    light: Vec<u32>,
    scalar: Vec<bool>,
    emitter_scalar: Vec<bool>,
}

/// The lights, per light: quads and points in tables, any other light sampled lane by lane.
#[derive(Clone, Debug)]
struct Lights {
    count: usize,
    /// 1 for a light sampled lane by lane by the scalar world (every light beyond the tables).
    scalar: Table,
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
    /// The scene's primitives for the lane kernels, or why it has none (its objects move: each
    /// lane's ray is then traced through the BVH on its own, at its time).
    lanes: Result<LaneScene, String>,
    /// Whether the tables hold the scene's materials (else every vertex that finds a surface is
    /// shaded lane by lane).
    tables: bool,
    /// Whether the lane kernels make the hits' records (a few analytic shapes, whose shading
    /// normal is the geometric one), else the scalar engine's `Scene::record` lane by lane.
    lane_records: bool,
    materials: Materials,
    primitives: Primitives,
    lights: Lights,
    /// The background, where an escaping ray sees it in RGB (no environment light, no
    /// wavelengths); `None` where each lane asks the scalar world.
    background: Option<Vec3>,
    /// Whether the sampler is Sobol' (each lane's stream kept across lanes), else each lane
    /// draws from its own sampler.
    sobol: bool,
    /// Whether the paths' channels are wavelengths: the shading kernel is chosen by it once
    /// per batch, so RGB paths run without the wavelengths' work.
    spectral: bool,
    /// What goes lane by lane through the scalar world, in words.
    lane_by_lane: Vec<String>,
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

    /// Lane `k` of an [`EMPTY`](Self::EMPTY) context (nothing counted yet) takes up the stream
    /// of `ctx` (where the stream is `sobol`; other streams stay in the path's context).
    fn start(&mut self, k: usize, ctx: &PathContext, sobol: bool) {
        if let Some(state) = ctx.sampler.sobol_state().filter(|_| sobol) {
            (self.key[k], self.reversed[k], self.dimension[k]) =
                (state.pixel_key, state.reversed_sample, state.dimension);
        }
    }

    /// Gives lane `k`'s numbers drawn (from a `sobol` stream) and rays traced back to its
    /// path's context `ctx`.
    fn finish(&self, k: usize, ctx: &mut PathContext, sobol: bool) {
        if sobol {
            let mut requests = [0; DIM_PURPOSES];
            requests[Dim::Light as usize..].copy_from_slice(&self.requests.map(|r| r[k]));
            ctx.sampler.resume(self.dimension[k], &requests);
        }
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
/// hits' records; and the lanes shaded by the scalar world, with their full records.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneHit {
    live: Mask,
    found: Mask,
    hits: LaneHits,
    records: SurfaceX,
    /// The shading normal (the geometric one but on a smooth mesh).
    shading_n: Vec3x,
    /// The material of each lane's primitive, and the light it emits as ([`NONE`] for none):
    /// the tables' indices.
    material: [u32; WIDTH],
    light: [u32; WIDTH],
    /// Lanes whose vertex the scalar world shades.
    scalar: Mask,
    /// Lanes whose emission it gives (those, and emitters the tables do not hold).
    scalar_emission: Mask,
    /// The hits as the scalar engine records them, in those lanes and wherever the lane kernels
    /// make no records (stale in the other lanes, never read there).
    isect: [Option<Intersection>; WIDTH],
}

impl LaneHit {
    /// No hits yet.
    const EMPTY: LaneHit = LaneHit {
        live: Mask::NONE,
        found: Mask::NONE,
        hits: LaneHits { t: [f32::INFINITY; WIDTH], primitive: [0; WIDTH], bary: [None; WIDTH] },
        records: SurfaceX { p: Vec3x::ZERO, n: Vec3x::ZERO, p_error: F32x::ZERO },
        shading_n: Vec3x::ZERO,
        material: [0; WIDTH],
        light: [NONE; WIDTH],
        scalar: Mask::NONE,
        scalar_emission: Mask::NONE,
        isect: [None; WIDTH],
    };
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
            chain: self.chain.0[k],
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
        self.chain.0[k] = path.chain;
    }
}

impl LaneStages {
    /// The stages for `scene` with the lane kernels `lanes` (or why it has none), rendered with
    /// `sampler`, spectrally where `spectral`: what has a lane form goes into the tables, the
    /// rest is noted as going lane by lane ([`LaneStages::lane_by_lane`]).
    pub fn new(
        scene: &Scene,
        lanes: Result<LaneScene, String>,
        sampler: SamplerKind,
        spectral: bool,
    ) -> LaneStages {
        let mut lane_by_lane = Vec::new();
        let sobol = sampler == SamplerKind::Sobol;
        if !sobol {
            lane_by_lane.push(format!("the {} sampler's draws", sampler.name()));
        }
        let tables = if spectral {
            Err("wavelengths are traced (dispersion)".to_string())
        } else if scene.materials.len() > ENTRIES {
            Err(format!("{} materials (the tables take {ENTRIES})", scene.materials.len()))
        } else {
            Ok(())
        };
        let lane_records = match &lanes {
            Ok(l) => l.tables(),
            Err(why) => Err(why.clone()),
        };
        if let Err(why) = &tables {
            lane_by_lane.push(format!("every vertex: {why}"));
        } else if let Err(why) = &lane_records {
            lane_by_lane.push(format!("the hit records: {why}"));
        }
        let mut lights = Lights {
            count: scene.lights.len(),
            scalar: Table::ZERO,
            point: Table::ZERO,
            corner: Table3::ZERO,
            u: Table3::ZERO,
            v: Table3::ZERO,
            normal: Table3::ZERO,
            radiance: Table3::ZERO,
            area_pdf: Table::ZERO,
        };
        if spectral {
            // The tables hold RGB.
            lights.scalar = Table([1.0; ENTRIES]);
        } else if scene.lights.len() > ENTRIES {
            lights.scalar = Table([1.0; ENTRIES]);
            lane_by_lane.push(format!(
                "the light samples: {} lights (the tables take {ENTRIES})",
                scene.lights.len()
            ));
        }
        let mut other_lights = Vec::new();
        for (i, light) in scene.lights.iter().enumerate().take(ENTRIES) {
            match *light {
                Light::Quad { corner, u, v, normal, radiance } => {
                    lights.corner.set(i, corner);
                    lights.u.set(i, u);
                    lights.v.set(i, v);
                    lights.normal.set(i, normal);
                    lights.radiance.set(i, radiance);
                    lights.area_pdf.0[i] = 1.0 / u.cross(v).length();
                }
                Light::Point { position, intensity } => {
                    lights.point.0[i] = 1.0;
                    lights.corner.set(i, position);
                    lights.radiance.set(i, intensity);
                }
                _ if spectral => {}
                _ => {
                    lights.scalar.0[i] = 1.0;
                    other_lights.push(light.kind_name());
                }
            }
        }
        if !other_lights.is_empty() {
            other_lights.dedup();
            lane_by_lane.push(format!("the samples of {} lights", other_lights.join(", ")));
        }
        let mut materials = Materials {
            glass: Table::ZERO,
            color1: Table3::ZERO,
            color2: Table3::ZERO,
            cell: Table([1.0; ENTRIES]),
            eta: Table([1.0; ENTRIES]),
            inside: Table3::ZERO,
            outside: Table3::ZERO,
        };
        let mut primitives = Primitives::default();
        let (mut other_materials, mut other_emitters) = (Vec::new(), Vec::new());
        if tables.is_ok() {
            let mut material_scalar = vec![false; scene.materials.len()];
            for (i, m) in scene.materials.iter().enumerate() {
                let in_tables = match &m.bsdf {
                    Bsdf::Diffuse { one_sided: false, albedo: Texture::Constant(c) } => {
                        materials.color1.set(i, *c);
                        materials.color2.set(i, *c);
                        Ok(())
                    }
                    Bsdf::Diffuse { one_sided: false, albedo: Texture::Checker { color1, color2, size } } => {
                        materials.color1.set(i, *color1);
                        materials.color2.set(i, *color2);
                        materials.cell.0[i] = *size;
                        Ok(())
                    }
                    Bsdf::Dielectric { inside, outside, roughness, distribution }
                        if !m.bsdf.is_dispersive() =>
                    {
                        let eta = inside.ior_at(None) / outside.ior_at(None);
                        if RoughDielectric::new(eta, distribution.with_alpha(roughness * roughness))
                            .is_specular()
                        {
                            materials.glass.0[i] = 1.0;
                            materials.eta.0[i] = eta;
                            materials.inside.set(i, inside.absorption);
                            materials.outside.set(i, outside.absorption);
                            Ok(())
                        } else {
                            Err("rough glass")
                        }
                    }
                    Bsdf::Diffuse { one_sided: true, .. } => Err("one-sided diffuse"),
                    Bsdf::Diffuse { .. } => Err("an image texture"),
                    Bsdf::Mirror { .. } => Err("a mirror"),
                    Bsdf::Conductor(_) => Err("a conductor"),
                    Bsdf::ThinDielectric { .. } => Err("a thin dielectric"),
                    Bsdf::Plastic { .. } => Err("a plastic"),
                    Bsdf::RoughPlastic { .. } => Err("a rough plastic"),
                    Bsdf::Dielectric { .. } => Err("dispersive glass"),
                };
                if let Err(kind) = in_tables {
                    material_scalar[i] = true;
                    if scene.primitives.iter().any(|p| p.material as usize == i) {
                        other_materials.push(format!("`{}` ({kind})", m.name));
                    }
                }
            }
            for prim in &scene.primitives {
                let emitter = prim.light.map(|l| l as usize);
                let emits_from_table =
                    emitter.is_some_and(|l| l < ENTRIES && matches!(scene.lights[l], Light::Quad { .. }));
                let other_emitter = emitter.is_some() && !emits_from_table;
                if other_emitter {
                    other_emitters.push(format!("`{}`", scene.materials[prim.material as usize].name));
                }
                primitives.material.push(prim.material);
                primitives.light.push(prim.light.unwrap_or(NONE));
                primitives.scalar.push(material_scalar[prim.material as usize]);
                primitives.emitter_scalar.push(other_emitter);
            }
        }
        if !other_emitters.is_empty() {
            other_emitters.sort();
            other_emitters.dedup();
            lane_by_lane.push(format!(
                "the emission of {} (emitters without a lane form)",
                other_emitters.join(", ")
            ));
        }
        if !other_materials.is_empty() {
            other_materials.sort();
            other_materials.dedup();
            lane_by_lane.push(format!("the vertices on {}", other_materials.join(", ")));
        }
        let background =
            (scene.environment_light().is_none() && !spectral).then_some(scene.settings.background);
        if background.is_none() && tables.is_ok() {
            lane_by_lane.push("the environment seen by escaping rays".to_string());
        }
        LaneStages {
            lanes,
            tables: tables.is_ok(),
            lane_records: tables.is_ok() && lane_records.is_ok(),
            materials,
            primitives,
            lights,
            background,
            sobol,
            spectral,
            lane_by_lane,
        }
    }

    /// The instruction set the stages run with.
    pub fn isa(&self) -> Isa {
        self.lanes.as_ref().map_or(Isa::detect(), |l| l.isa())
    }

    /// Whether the tables hold the scene's materials (else every vertex that finds a surface is
    /// shaded lane by lane).
    pub fn has_tables(&self) -> bool {
        self.tables
    }

    /// What the scalar world computes lane by lane, in words (empty where every part of every
    /// vertex has a lane form).
    pub fn lane_by_lane(&self) -> &[String] {
        &self.lane_by_lane
    }

    /// The radiance of every camera ray of `rays`, each with its sample's context (its random
    /// stream, channels and counters, which it leaves as the scalar engine would), as
    /// [`crate::integrators::Path`]'s `radiance` gives it one at a time.
    pub fn radiance(
        &self,
        scene: &Scene,
        params: &RenderParams,
        rays: &[CameraRays],
        ctxs: &mut [PathContext],
        occupancy: &mut StageOccupancy,
    ) -> Vec<Vec3> {
        let n = ctxs.len();
        let models: Models = Default::default();
        let world = LaneWorld { stages: self, scene, models: &models };
        let mut hit = LaneHit::EMPTY;
        SCRATCH.with_borrow_mut(|scratch| {
            let chunks = &mut scratch.chunks;
            chunks.clear();
            for (c, (rays, ctxs)) in rays.iter().zip(ctxs.chunks(WIDTH)).enumerate() {
                let path = PathState {
                    origin: Vec3x::from_lanes(&rays.rays.origin),
                    dir: Vec3x::from_lanes(&rays.rays.dir),
                    time: F32x(rays.time),
                    ..PathState::fresh()
                };
                let mut chunk = PathChunk { path, ctx: LaneContext::EMPTY, slot: [NONE; WIDTH] };
                for (k, ctx) in ctxs.iter().enumerate() {
                    chunk.ctx.start(k, ctx, self.sobol);
                    chunk.slot[k] = (c * WIDTH + k) as u32;
                }
                chunks.push(chunk);
            }
            let mut estimates = vec![Vec3::ZERO; n];
            // The mode, once for the batch.
            let round = if self.spectral { LaneWorld::round::<true> } else { LaneWorld::round::<false> };
            while !chunks.is_empty() {
                for chunk in chunks.iter_mut() {
                    let ended = round(&world, params, chunk, ctxs, &mut hit, occupancy);
                    for k in 0..WIDTH {
                        if ended.0[k] {
                            let slot = chunk.slot[k] as usize;
                            estimates[slot] = chunk.path.l.lane(k);
                            chunk.ctx.finish(k, &mut ctxs[slot], self.sobol);
                            chunk.slot[k] = NONE;
                        }
                    }
                }
                compact(chunks);
            }
            estimates
        })
    }
}

impl LaneWorld<'_, '_> {
    /// One bounce of the 16 paths of `chunk` (their contexts in `ctxs` at their slots), their
    /// hits found into `hit`: the lanes whose path ends. `SPECTRAL`: the stages' mode
    /// ([`LaneStages::spectral`]), fixed for the render.
    fn round<const SPECTRAL: bool>(
        &self,
        params: &RenderParams,
        chunk: &mut PathChunk,
        ctxs: &mut [PathContext],
        hit: &mut LaneHit,
        occupancy: &mut StageOccupancy,
    ) -> Mask {
        let live = Mask(std::array::from_fn(|k| chunk.slot[k] != NONE));
        self.closest_hits(&chunk.path, live, hit, &mut occupancy.closest);
        let mut ctx = LaneCtx { lanes: &mut chunk.ctx, paths: ctxs, slot: chunk.slot };
        let shade = if SPECTRAL { shade_spectral } else { shade_rgb };
        let step = shade(self.stages.isa(), self, params, &mut chunk.path, hit, &mut ctx);
        let visible = self.shadow_rays(&step.light.shadow, &mut occupancy.shadow);
        chunk.path.resolve(&step.light, visible);
        live & !step.goes_on
    }

    /// The closest hits of the `live` lanes' rays, with their records, into `hit` (the full
    /// records only where the scalar world shades a lane: the others keep stale ones, never read).
    fn closest_hits(
        &self,
        path: &PathState<Vec3x>,
        live: Mask,
        hit: &mut LaneHit,
        occupancy: &mut Occupancy,
    ) {
        let (stages, scene) = (self.stages, self.scene);
        let rays = RayLanes { origin: path.origin.to_lanes(), dir: path.dir.to_lanes() };
        let ray = |k: usize| Ray { origin: path.origin.lane(k), dir: path.dir.lane(k), time: path.time.0[k] };
        occupancy.add(live.count());
        let isect = &mut hit.isect;
        // Through the BVH, 16 rays at once pay for coherent camera rays only; the bounces'
        // (about 7 octants in 16 lanes) go one by one, the scalar traversal with its record
        // (docs/performance.md, "The engines").
        let packet = match &stages.lanes {
            Ok(lanes) => !lanes.traverses_bvh() || !(live & !path.depth.eq(F32x::ZERO)).any(),
            Err(_) => false,
        };
        let hits = match &stages.lanes {
            Ok(lanes) if packet => {
                let tmax = F32x::select(live, F32x::splat(f32::INFINITY), F32x::splat(-1.0));
                lanes.closest(&rays, &tmax.0)
            }
            _ => {
                // Each ray through the BVH on its own, at its time.
                let mut hits =
                    LaneHits { t: [f32::INFINITY; WIDTH], primitive: [0; WIDTH], bary: [None; WIDTH] };
                for k in lanes_of(live) {
                    isect[k] = scene.intersect(&ray(k), f32::INFINITY);
                    if let Some(i) = &isect[k] {
                        (hits.t[k], hits.primitive[k]) = (i.hit.t, i.primitive);
                    }
                }
                hits
            }
        };
        let found = live & F32x(hits.t).lt(F32x::splat(f32::INFINITY));
        let (mut scalar, mut scalar_emission) = (found, found);
        if stages.tables {
            let prims = &stages.primitives;
            for k in lanes_of(found) {
                let i = hits.primitive[k] as usize;
                (hit.material[k], hit.light[k], scalar.0[k]) =
                    (prims.material[i], prims.light[i], prims.scalar[i]);
                scalar_emission.0[k] = prims.scalar[i] || prims.emitter_scalar[i];
            }
        }
        let mut records = match &stages.lanes {
            Ok(lanes) if stages.lane_records => lanes.records(&rays, &hits),
            _ => SurfaceX { p: Vec3x::ZERO, n: Vec3x::ZERO, p_error: F32x::ZERO },
        };
        let mut shading_n = records.n;
        // The records the lane kernels do not make (or the scalar world reads in full).
        let recorded = if stages.lane_records { scalar_emission } else { found };
        for k in lanes_of(recorded) {
            if packet {
                isect[k] = Some(scene.record(&ray(k), hits.t[k], hits.primitive[k], hits.bary[k]));
            }
            let i = isect[k].expect("a lane that found a surface has its record");
            records.p.set_lane(k, i.hit.p);
            records.n.set_lane(k, i.hit.n);
            records.p_error.0[k] = i.hit.p_error;
            shading_n.set_lane(k, i.hit.shading_n);
        }
        (hit.live, hit.found, hit.hits, hit.records, hit.shading_n) = (live, found, hits, records, shading_n);
        (hit.scalar, hit.scalar_emission) = (scalar, scalar_emission);
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
        let Ok(lanes) = &self.stages.lanes else {
            // Moving objects: each ray through the BVH at its time.
            let mut visible = Mask::ALL;
            for k in lanes_of(shadow.shadowed) {
                let mut ray = Ray::new(segment.origin.lane(k), segment.dir.lane(k));
                ray.time = shadow.time.0[k];
                let query = ShadowRay {
                    ray,
                    tmax: segment.tmax.0[k],
                    remaining: segment.remaining.0[k],
                    target: shadow.target.lane(k),
                    light: Some(shadow.light[k]),
                };
                visible.0[k] = !query.blocked(self.scene);
            }
            return visible;
        };
        let rays = RayLanes { origin: segment.origin.to_lanes(), dir: segment.dir.to_lanes() };
        let tmax = F32x::select(shadow.shadowed, segment.tmax, F32x::splat(-1.0));
        let blocked = lanes.occluded(&rays, &tmax.0, &shadow.light, &shadow.reach.0);
        !Mask(blocked)
    }
}

/// The vertex of every lane of `path` ([`PathState::advance`] in the world of the lanes), the
/// paths' channels wavelengths where `SPECTRAL`.
#[inline(always)]
fn shade_kernel<'a, 's, const SPECTRAL: bool>(
    world: &LaneWorld<'a, 's>,
    params: &RenderParams,
    path: &mut PathState<Vec3x>,
    hit: &LaneHit,
    ctx: &mut LaneCtx<'a>,
) -> Step<Vec3x, LaneShadow> {
    path.advance::<SPECTRAL, _>(world, params, hit, ctx)
}

dispatch! {
    /// [`shade_kernel`] of RGB paths compiled for `isa`.
    fn shade_rgb<'a, 's>(world: &LaneWorld<'a, 's>, params: &RenderParams, path: &mut PathState<Vec3x>, hit: &LaneHit, ctx: &mut LaneCtx<'a>) -> Step<Vec3x, LaneShadow> => shade_kernel::<false>
}

dispatch! {
    /// [`shade_kernel`] of spectral paths compiled for `isa`.
    fn shade_spectral<'a, 's>(world: &LaneWorld<'a, 's>, params: &RenderParams, path: &mut PathState<Vec3x>, hit: &LaneHit, ctx: &mut LaneCtx<'a>) -> Step<Vec3x, LaneShadow> => shade_kernel::<true>
}
/// Packs the live paths of `chunks` into full chunks at the front (the last one padded with idle
/// lanes) and drops the rest: each hole of a front chunk takes a live path from the last chunk
/// (an empty chunk trades places with the last one whole), so a round moves at most as many
/// paths as it ended, and a full chunk is not touched. Which lane a path occupies changes
/// nothing it computes: each lane's arithmetic is its own.
fn compact(chunks: &mut Vec<PathChunk>) {
    let live = |c: &PathChunk, k: usize| c.slot[k] != NONE;
    let mut back = chunks.len();
    let mut front = 0;
    loop {
        while back > 0 && !(0..WIDTH).any(|k| live(&chunks[back - 1], k)) {
            back -= 1;
        }
        while front + 1 < back && (0..WIDTH).all(|k| live(&chunks[front], k)) {
            front += 1;
        }
        if front + 1 >= back {
            break;
        }
        if !(0..WIDTH).any(|k| live(&chunks[front], k)) {
            chunks.swap(front, back - 1);
            continue;
        }
        let (head, tail) = chunks.split_at_mut(back - 1);
        let (to, from) = (&mut head[front], &mut tail[0]);
        let (to_slots, from_slots) = (to.slot, from.slot);
        let mut sources = (0..WIDTH).rev().filter(|&k| from_slots[k] != NONE);
        for hole in (0..WIDTH).filter(|&k| to_slots[k] == NONE) {
            let Some(k) = sources.next() else { break };
            to.path.set_lane(hole, &from.path.lane(k));
            to.ctx.set_lane(hole, &from.ctx.lane(k));
            (to.slot[hole], from.slot[k]) = (from.slot[k], NONE);
        }
    }
    chunks.truncate(back);
}

/// Buffers a thread reuses from one batch of paths to the next (fresh ones cost page faults).
#[derive(Default)]
struct Scratch {
    chunks: Vec<PathChunk>,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}
