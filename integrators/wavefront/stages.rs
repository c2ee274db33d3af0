//! Every stage of the wavefront engine across lanes, for the scenes whose effects it covers
//! ([`LaneStages::new`] says which): chunks of 16 paths in structure-of-arrays form go through
//! one round per bounce:
//! 1. closest hits across lanes ([`LaneScene::closest`]), then each hit's record;
//! 2. the round's random numbers: four Sobol' requests per lane across lanes ([`sobol_pairs`]),
//!    each lane at its own dimensions (a diffuse vertex draws light, BSDF and roulette numbers,
//!    glass a lobe choice, BSDF and roulette numbers);
//! 3. shading before the trigonometry, across lanes: emission and its MIS weight, the quad
//!    light's sample with its MIS weight and shadow ray, the glass's Fresnel choice and
//!    refraction, the diffuse sample's polar coordinates on the disk;
//! 4. the cosine and sine of the diffuse samples, one lane at a time (the scalar engine's libm
//!    calls, so that every bit agrees);
//! 5. shading after it, across lanes: the scattered direction, throughput, media, the next
//!    ray's origin, Russian roulette;
//! 6. the shadow rays across lanes ([`LaneScene::occluded`]);
//!
//! then the radiance each path gathered is added to its sample's estimate, and the paths that go
//! on are compacted into full chunks. Each lane computes what [`PathState::advance`] computes,
//! operation for operation (the same scalar functions, inlined into loops that the compiler
//! vectorises, with selects for branches): images are the scalar engine's, bit for bit.
//!
//! [`PathState::advance`]: crate::integrators::path

use super::super::{PathContext, RenderParams};
use super::{Occupancy, StageOccupancy};
use crate::bsdf::{RoughDielectric, TrowbridgeReitz};
use crate::geometry::Ray;
use crate::lanes::shading::{
    area_to_solid_angle, checker, concentric_polar, lambert_eval, lambert_pdf, lambert_sample,
    power_heuristic, shadow_toward, spawn_origin, specular_sample, FrameX, SampleX, ShadowX,
};
use crate::lanes::{dispatch, sobol_pairs, F32x, Isa, LaneScene, Lanes, Mask, RayLanes, Vec3x, WIDTH};
use crate::light::Light;
use crate::lighting::ShadowRay;
use crate::material::Bsdf;
use crate::sampler::{Dim, SamplerKind, DIM_PURPOSES};
use crate::scene::{Effect, Scene};
use crate::stats::RayCounts;
use crate::texture::Texture;
use glam::Vec3;

/// Bounces after which Russian roulette may end a path (as the scalar engine).
const ROULETTE_DEPTH: u32 = 3;

/// An idle lane's slot, and a primitive that is no light.
const NONE: u32 = u32::MAX;

/// Three lanes of components: a vector per lane.
type Vec3Lanes = [Lanes; 3];

/// Lane `k` of `v`.
#[inline(always)]
fn get(v: &Vec3Lanes, k: usize) -> Vec3 {
    Vec3::new(v[0][k], v[1][k], v[2][k])
}

/// Sets lane `k` of `v` to `x`.
#[inline(always)]
fn set(v: &mut Vec3Lanes, k: usize, x: Vec3) {
    v[0][k] = x.x;
    v[1][k] = x.y;
    v[2][k] = x.z;
}

/// The surfaces the stages know, as tables indexed by material (gathered per lane, so that no
/// lane branches on an enum): a diffuse surface's albedo is a 3-D checker (a constant colour is
/// a checker of two equal colours), glass is smooth with a relative index and the absorption of
/// its two sides.
#[derive(Clone, Debug, Default)]
struct Surfaces {
    glass: Vec<bool>,
    color1: Vec<Vec3>,
    color2: Vec<Vec3>,
    cell: Vec<f32>,
    eta: Vec<f32>,
    inside: Vec<Vec3>,
    outside: Vec<Vec3>,
}

/// The quad lights, as tables indexed by light.
#[derive(Clone, Debug, Default)]
struct QuadLights {
    corner: Vec<Vec3>,
    u: Vec<Vec3>,
    v: Vec<Vec3>,
    normal: Vec<Vec3>,
    radiance: Vec<Vec3>,
    /// 1/area, computed as [`Light::pdf_li`] computes it.
    area_pdf: Vec<f32>,
}

/// Every stage across lanes for one scene.
#[derive(Clone, Debug)]
pub struct LaneStages {
    lanes: LaneScene,
    surfaces: Surfaces,
    lights: QuadLights,
    /// Per primitive, its material.
    material: Vec<u32>,
    /// Per primitive, the light it emits for, or [`NONE`].
    light: Vec<u32>,
    background: Vec3,
}

/// 16 camera paths in structure-of-arrays form: what [`PathState`] holds, per lane, with the
/// sample stream's state and the slot of the sample's estimate.
///
/// [`PathState`]: crate::integrators::path
#[derive(Clone, Copy, Debug)]
struct PathChunk {
    origin: Vec3Lanes,
    dir: Vec3Lanes,
    beta: Vec3Lanes,
    absorption: Vec3Lanes,
    eta_scale: Lanes,
    bsdf_pdf: Lanes,
    skip_mis: [bool; WIDTH],
    depth: [u32; WIDTH],
    key: [u64; WIDTH],
    reversed: [u32; WIDTH],
    dimension: [u32; WIDTH],
    /// The sample whose estimate the lane's path adds to; [`NONE`] for an idle lane.
    slot: [u32; WIDTH],
}

impl PathChunk {
    const IDLE: PathChunk = PathChunk {
        origin: [[0.0; WIDTH]; 3],
        dir: [[0.0; WIDTH]; 3],
        beta: [[0.0; WIDTH]; 3],
        absorption: [[0.0; WIDTH]; 3],
        eta_scale: [0.0; WIDTH],
        bsdf_pdf: [0.0; WIDTH],
        skip_mis: [false; WIDTH],
        depth: [0; WIDTH],
        key: [0; WIDTH],
        reversed: [0; WIDTH],
        dimension: [0; WIDTH],
        slot: [NONE; WIDTH],
    };

    /// Copies lane `k` of `from` into lane `j`.
    #[inline]
    fn copy_lane(&mut self, j: usize, from: &PathChunk, k: usize) {
        for axis in 0..3 {
            self.origin[axis][j] = from.origin[axis][k];
            self.dir[axis][j] = from.dir[axis][k];
            self.beta[axis][j] = from.beta[axis][k];
            self.absorption[axis][j] = from.absorption[axis][k];
        }
        self.eta_scale[j] = from.eta_scale[k];
        self.bsdf_pdf[j] = from.bsdf_pdf[k];
        self.skip_mis[j] = from.skip_mis[k];
        self.depth[j] = from.depth[k];
        self.key[j] = from.key[k];
        self.reversed[j] = from.reversed[k];
        self.dimension[j] = from.dimension[k];
        self.slot[j] = from.slot[k];
    }
}

/// What a path's sample tallies besides its radiance: rays, and the dimensions and requests it
/// drew from its stream (written back into its context at the end).
#[derive(Clone, Copy, Debug, Default)]
struct Tally {
    rays: RayCounts,
    dimensions: u32,
    requests: [u32; DIM_PURPOSES],
}

/// The hits of a chunk's rays.
#[derive(Clone, Copy, Debug)]
struct HitLanes {
    hit: [bool; WIDTH],
    t: Lanes,
    p: Vec3Lanes,
    n: Vec3Lanes,
    p_error: Lanes,
    surface: [u32; WIDTH],
    light: [u32; WIDTH],
}

/// What a round does at each lane's vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Vertex {
    /// No path (an idle lane) or an escaped ray.
    Miss,
    /// A hit at the maximum depth: its emission, nothing more.
    Last,
    /// A diffuse surface.
    Diffuse,
    /// Smooth glass.
    Glass,
}

/// The round's random numbers per lane (see the module documentation).
#[derive(Clone, Copy, Debug)]
struct Draws {
    /// The light choice (with several lights).
    pick: Lanes,
    /// The light point (diffuse), or the lobe choice in `.0` (glass).
    first: [Lanes; 2],
    /// The BSDF sample's pair.
    bsdf: [Lanes; 2],
    /// Russian roulette.
    roulette: Lanes,
}

/// What a lane's vertex reads from the scene's tables (gathered one lane at a time, so that the
/// shading loops read only lanes): its surface, the emitter it hit and the light it samples.
#[derive(Clone, Copy, Debug)]
struct Gathered {
    color1: Vec3Lanes,
    color2: Vec3Lanes,
    cell: Lanes,
    /// The glass's relative index.
    eta: Lanes,
    /// Absorption inside and outside the glass.
    inside: Vec3Lanes,
    outside: Vec3Lanes,
    /// Radiance of the quad light hit (zero for other surfaces) and its area density.
    emit_radiance: Vec3Lanes,
    emit_area_pdf: Lanes,
    /// The light next-event estimation samples: its index, quad and radiance.
    light: [u32; WIDTH],
    corner: Vec3Lanes,
    edge_u: Vec3Lanes,
    edge_v: Vec3Lanes,
    normal: Vec3Lanes,
    radiance: Vec3Lanes,
    area_pdf: Lanes,
}

/// Shading before the trigonometry, per lane: what stage 5 and the estimates need.
#[derive(Clone, Copy, Debug)]
struct Shaded {
    /// Radiance this vertex adds before next-event estimation (emission, or the background).
    emitted: Vec3x,
    frame: FrameX,
    wo_local: Vec3x,
    /// Diffuse albedo.
    albedo: Vec3x,
    /// The diffuse sample's point on the disk: at its centre, else the polar coordinates.
    centre: Mask,
    radius: F32x,
    theta: F32x,
    /// The glass sample, where `glass_ok`.
    glass_ok: Mask,
    glass: SampleX,
    /// Next-event estimation: a pending light (`pending`: its shadow ray counted), whether its
    /// shadow ray can be blocked (`shadowed`), the ray, and the light's value f·Le·w/pdf and
    /// the throughput at the vertex.
    pending: Mask,
    shadowed: Mask,
    shadow: ShadowX,
    target: Vec3x,
    nee_beta: Vec3x,
    nee_value: Vec3x,
}

/// The round's end per lane.
#[derive(Clone, Copy, Debug)]
struct Scattered {
    goes_on: [bool; WIDTH],
    reflected: [bool; WIDTH],
    refracted: [bool; WIDTH],
    /// Dimensions drawn and requests per purpose (light, BSDF, other).
    dimensions: [u32; WIDTH],
    light_requests: [u32; WIDTH],
    bsdf_requests: [u32; WIDTH],
    other_requests: [u32; WIDTH],
}

impl LaneStages {
    /// The stages for `scene` rendered with `sampler` in RGB without depth of field, or why
    /// they cannot run it (an effect whose stage is not across lanes yet).
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
        if scene.effects.has(Effect::DepthOfField) {
            return Err("the camera has a lens (depth of field)".into());
        }
        let mut lights = QuadLights::default();
        for light in &scene.lights {
            let Light::Quad { corner, u, v, normal, radiance } = *light else {
                return Err("a light is not a quad (quad lights have a lane form)".into());
            };
            lights.corner.push(corner);
            lights.u.push(u);
            lights.v.push(v);
            lights.normal.push(normal);
            lights.radiance.push(radiance);
            lights.area_pdf.push(1.0 / u.cross(v).length());
        }
        if lights.corner.is_empty() {
            return Err("the scene has no light".into());
        }
        let mut surfaces = Surfaces::default();
        for m in &scene.materials {
            let (glass, colors, cell, model, inside, outside) = match &m.bsdf {
                Bsdf::Diffuse(Texture::Constant(c)) => (false, (*c, *c), 1.0, None, Vec3::ZERO, Vec3::ZERO),
                Bsdf::Diffuse(Texture::Checker { color1, color2, size }) => {
                    (false, (*color1, *color2), *size, None, Vec3::ZERO, Vec3::ZERO)
                }
                Bsdf::Dielectric { inside, outside, roughness }
                    if m.bsdf.is_specular() && !m.bsdf.is_dispersive() =>
                {
                    let eta = inside.ior_at(None) / outside.ior_at(None);
                    let model = RoughDielectric::new(eta, TrowbridgeReitz::from_roughness(*roughness));
                    (true, (Vec3::ZERO, Vec3::ZERO), 1.0, Some(model), inside.absorption, outside.absorption)
                }
                Bsdf::Diffuse(_) => return Err(format!("material `{}` reads an image texture", m.name)),
                Bsdf::Mirror { .. } => return Err(format!("material `{}` is a mirror", m.name)),
                Bsdf::Dielectric { .. } => {
                    return Err(format!("material `{}` is rough or dispersive glass", m.name))
                }
            };
            if model.is_some_and(|g| !g.is_specular()) {
                return Err(format!("material `{}` is rough glass", m.name));
            }
            surfaces.glass.push(glass);
            surfaces.color1.push(colors.0);
            surfaces.color2.push(colors.1);
            surfaces.cell.push(cell);
            surfaces.eta.push(model.map_or(1.0, |g| g.eta));
            surfaces.inside.push(inside);
            surfaces.outside.push(outside);
        }
        Ok(LaneStages {
            material: scene.primitives.iter().map(|p| p.material).collect(),
            light: scene.primitives.iter().map(|p| p.light.unwrap_or(NONE)).collect(),
            lanes,
            surfaces,
            lights,
            background: scene.settings.background,
        })
    }

    /// The instruction set the stages run with.
    pub fn isa(&self) -> Isa {
        self.lanes.isa()
    }

    /// The radiance of every camera ray of `rays` (each with its sample's context), as the
    /// scalar engine gives it.
    pub fn radiance(
        &self,
        scene: &Scene,
        params: &RenderParams,
        rays: &[Ray],
        ctxs: &mut [PathContext],
        occupancy: &mut StageOccupancy,
    ) -> Vec<Vec3> {
        let n = rays.len();
        let mut chunks: Vec<PathChunk> = Vec::with_capacity(n.div_ceil(WIDTH));
        for (i, (ray, ctx)) in rays.iter().zip(ctxs.iter()).enumerate() {
            let k = i % WIDTH;
            if k == 0 {
                chunks.push(PathChunk::IDLE);
            }
            let c = chunks.last_mut().expect("pushed above");
            let stream = ctx.sampler.sobol_state().expect("LaneStages::new checked the sampler");
            set(&mut c.origin, k, ray.origin);
            set(&mut c.dir, k, ray.dir);
            set(&mut c.beta, k, Vec3::ONE);
            set(&mut c.absorption, k, Vec3::ZERO);
            (c.eta_scale[k], c.bsdf_pdf[k], c.skip_mis[k], c.depth[k]) = (1.0, 0.0, true, 0);
            (c.key[k], c.reversed[k], c.dimension[k]) =
                (stream.pixel_key, stream.reversed_sample, stream.dimension);
            c.slot[k] = i as u32;
        }
        let mut estimates = vec![Vec3::ZERO; n];
        let mut tallies = vec![Tally::default(); n];
        let mut next = Vec::with_capacity(chunks.len());
        while !chunks.is_empty() {
            for chunk in &mut chunks {
                self.round(scene, params, chunk, &mut estimates, &mut tallies, occupancy);
            }
            compact(&chunks, &mut next);
            std::mem::swap(&mut chunks, &mut next);
        }
        for (ctx, tally) in ctxs.iter_mut().zip(&tallies) {
            ctx.rays += tally.rays;
            ctx.sampler.skip(tally.dimensions, &tally.requests);
        }
        estimates
    }

    /// One bounce of the 16 paths of `chunk`.
    fn round(
        &self,
        scene: &Scene,
        params: &RenderParams,
        chunk: &mut PathChunk,
        estimates: &mut [Vec3],
        tallies: &mut [Tally],
        occupancy: &mut StageOccupancy,
    ) {
        let isa = self.isa();
        // Stage 1: closest hits and their records.
        let live: [bool; WIDTH] = std::array::from_fn(|k| chunk.slot[k] != NONE);
        let tmax: Lanes = std::array::from_fn(|k| if live[k] { f32::INFINITY } else { -1.0 });
        let rays = RayLanes { origin: chunk.origin, dir: chunk.dir };
        let found = self.lanes.closest(&rays, &tmax);
        occupancy.closest.add(live.iter().filter(|&&l| l).count());
        let records = self.lanes.records(&rays, &found);
        let mut hits = HitLanes {
            hit: std::array::from_fn(|k| live[k] && found.t[k] < f32::INFINITY),
            t: found.t,
            p: records.p.to_lanes(),
            n: records.n.to_lanes(),
            p_error: records.p_error.0,
            surface: [0; WIDTH],
            light: [NONE; WIDTH],
        };
        for k in 0..WIDTH {
            if hits.hit[k] {
                let primitive = found.primitive[k] as usize;
                hits.surface[k] = self.material[primitive];
                hits.light[k] = self.light[primitive];
            }
        }
        // Absorption along the segment (libm's exp, one lane at a time, where a medium absorbs).
        for k in 0..WIDTH {
            let absorption = get(&chunk.absorption, k);
            if hits.hit[k] && absorption != Vec3::ZERO {
                let beta = get(&chunk.beta, k) * (-absorption * hits.t[k]).exp();
                set(&mut chunk.beta, k, beta);
            }
        }
        let vertex: [Vertex; WIDTH] = std::array::from_fn(|k| {
            if !hits.hit[k] {
                Vertex::Miss
            } else if chunk.depth[k] >= params.max_depth {
                Vertex::Last
            } else if self.surfaces.glass[hits.surface[k] as usize] {
                Vertex::Glass
            } else {
                Vertex::Diffuse
            }
        });
        // Stage 2: the round's random numbers, and what each lane reads from the tables.
        let draws = self.draws(isa, chunk, &vertex);
        let gathered = self.gather(&hits, &vertex, &draws);
        // Stage 3: shading before the trigonometry.
        let shaded = shade_before_trigonometry(isa, self, chunk, &hits, &vertex, &draws, &gathered);
        // Stage 4: the diffuse samples' cosines and sines, one lane at a time.
        let mut trig = [[0.0; WIDTH]; 2];
        for k in 0..WIDTH {
            if vertex[k] == Vertex::Diffuse && !shaded.centre.0[k] {
                let theta = shaded.theta.0[k];
                (trig[0][k], trig[1][k]) = (theta.cos(), theta.sin());
            }
        }
        // Stage 5: shading after it.
        let scattered = scatter(isa, self, chunk, &hits, &vertex, &draws, &gathered, &shaded, &trig);
        // Stage 6: the shadow rays.
        let visible = self.shadow_rays(scene, &shaded, &gathered, &mut occupancy.shadow);
        // The radiance gathered, in the scalar engine's order: emission, then the light.
        for k in 0..WIDTH {
            let slot = chunk.slot[k];
            if slot == NONE {
                continue;
            }
            let estimate = &mut estimates[slot as usize];
            *estimate += shaded.emitted.lane(k);
            if shaded.pending.0[k] {
                *estimate +=
                    shaded.nee_beta.lane(k) * if visible[k] { shaded.nee_value.lane(k) } else { Vec3::ZERO };
            }
            let tally = &mut tallies[slot as usize];
            tally.rays.shadow += shaded.pending.0[k] as u64;
            tally.rays.reflected += scattered.reflected[k] as u64;
            tally.rays.refracted += scattered.refracted[k] as u64;
            tally.dimensions += scattered.dimensions[k];
            tally.requests[Dim::Light as usize] += scattered.light_requests[k];
            tally.requests[Dim::Bsdf as usize] += scattered.bsdf_requests[k];
            tally.requests[Dim::Other as usize] += scattered.other_requests[k];
            if !scattered.goes_on[k] {
                chunk.slot[k] = NONE;
            }
        }
    }

    /// Stage 2: per lane, the Sobol' numbers its vertex may draw, at the dimensions the scalar
    /// engine draws them (whether it does depends on what the vertex finds; see [`Draws`]).
    fn draws(&self, isa: Isa, chunk: &PathChunk, vertex: &[Vertex; WIDTH]) -> Draws {
        let picks = (self.lights.corner.len() > 1) as u32;
        let at = |offset: &dyn Fn(usize) -> u32| -> [u32; WIDTH] {
            std::array::from_fn(|k| chunk.dimension[k].wrapping_add(offset(k)))
        };
        let diffuse = |k: usize| vertex[k] == Vertex::Diffuse;
        let pair = |dims: [u32; WIDTH]| sobol_pairs(isa, &chunk.key, &chunk.reversed, &dims);
        let (first_x, first_y) = pair(at(&|k| if diffuse(k) { picks } else { 0 }));
        let (bsdf_x, bsdf_y) = pair(at(&|k| if diffuse(k) { picks + 2 } else { 1 }));
        let (roulette, _) = pair(at(&|k| if diffuse(k) { picks + 4 } else { 3 }));
        let pick = if picks > 0 { pair(at(&|_| 0)).0 } else { [0.0; WIDTH] };
        Draws { pick, first: [first_x, first_y], bsdf: [bsdf_x, bsdf_y], roulette }
    }

    /// Per lane, what its vertex reads from the tables: its surface's colours, cell size and
    /// glass model, the quad light it hit and the light it samples.
    fn gather(&self, hits: &HitLanes, vertex: &[Vertex; WIDTH], draws: &Draws) -> Gathered {
        let (surfaces, q) = (&self.surfaces, &self.lights);
        let count = q.corner.len();
        let mut g = Gathered {
            color1: [[0.0; WIDTH]; 3],
            color2: [[0.0; WIDTH]; 3],
            cell: [1.0; WIDTH],
            eta: [1.0; WIDTH],
            inside: [[0.0; WIDTH]; 3],
            outside: [[0.0; WIDTH]; 3],
            emit_radiance: [[0.0; WIDTH]; 3],
            emit_area_pdf: [0.0; WIDTH],
            light: [0; WIDTH],
            corner: [[0.0; WIDTH]; 3],
            edge_u: [[0.0; WIDTH]; 3],
            edge_v: [[0.0; WIDTH]; 3],
            normal: [[0.0; WIDTH]; 3],
            radiance: [[0.0; WIDTH]; 3],
            area_pdf: [0.0; WIDTH],
        };
        for k in 0..WIDTH {
            if vertex[k] == Vertex::Miss {
                continue;
            }
            let s = hits.surface[k] as usize;
            set(&mut g.color1, k, surfaces.color1[s]);
            set(&mut g.color2, k, surfaces.color2[s]);
            g.cell[k] = surfaces.cell[s];
            g.eta[k] = surfaces.eta[s];
            set(&mut g.inside, k, surfaces.inside[s]);
            set(&mut g.outside, k, surfaces.outside[s]);
            if hits.light[k] != NONE {
                let l = hits.light[k] as usize;
                set(&mut g.emit_radiance, k, q.radiance[l]);
                g.emit_area_pdf[k] = q.area_pdf[l];
            }
            // pick_light: one light draws no number.
            let l = if count == 1 { 0 } else { ((draws.pick[k] * count as f32) as usize).min(count - 1) };
            g.light[k] = l as u32;
            set(&mut g.corner, k, q.corner[l]);
            set(&mut g.edge_u, k, q.u[l]);
            set(&mut g.edge_v, k, q.v[l]);
            set(&mut g.normal, k, q.normal[l]);
            set(&mut g.radiance, k, q.radiance[l]);
            g.area_pdf[k] = q.area_pdf[l];
        }
        g
    }

    /// Stage 6: whether each lane's pending light is visible (true where its shadow ray cannot
    /// be blocked).
    fn shadow_rays(
        &self,
        scene: &Scene,
        shaded: &Shaded,
        gathered: &Gathered,
        occupancy: &mut Occupancy,
    ) -> [bool; WIDTH] {
        let queries: [Option<ShadowRay>; WIDTH] = std::array::from_fn(|k| {
            shaded.shadowed.0[k].then(|| ShadowRay {
                ray: Ray { origin: shaded.shadow.origin.lane(k), dir: shaded.shadow.dir.lane(k), time: 0.0 },
                tmax: shaded.shadow.tmax.0[k],
                remaining: shaded.shadow.remaining.0[k],
                target: shaded.target.lane(k),
                light: Some(gathered.light[k]),
            })
        });
        let used = queries.iter().flatten().count();
        if used == 0 {
            return [true; WIDTH];
        }
        occupancy.add(used);
        let rays = RayLanes { origin: shaded.shadow.origin.to_lanes(), dir: shaded.shadow.dir.to_lanes() };
        let tmax = F32x::select(shaded.shadowed, shaded.shadow.tmax, F32x::splat(-1.0)).0;
        let blocked = self.lanes.occluded(&rays, &tmax, |k, primitive, t| {
            queries[k].as_ref().is_some_and(|s| s.blocks(scene, primitive, t))
        });
        std::array::from_fn(|k| !blocked[k])
    }
}

/// The live paths of `chunks`, in order, packed into full chunks (the last one padded with idle
/// lanes) in `into`.
fn compact(chunks: &[PathChunk], into: &mut Vec<PathChunk>) {
    into.clear();
    let mut j = WIDTH;
    for c in chunks {
        for k in 0..WIDTH {
            if c.slot[k] == NONE {
                continue;
            }
            if j == WIDTH {
                into.push(PathChunk::IDLE);
                j = 0;
            }
            into.last_mut().expect("pushed above").copy_lane(j, c, k);
            j += 1;
        }
    }
}

/// Stage 3 across lanes: the vertex's emission (or the background for an escaped ray), its
/// frame, next-event estimation of its quad light, the glass sample, and the diffuse sample's
/// polar coordinates. Every lane computes everything and keeps what its vertex uses.
#[inline(always)]
fn shade_before_kernel(
    stages: &LaneStages,
    chunk: &PathChunk,
    hits: &HitLanes,
    vertex: &[Vertex; WIDTH],
    draws: &Draws,
    g: &Gathered,
) -> Shaded {
    let light_pick = 1.0 / stages.lights.corner.len().max(1) as f32;
    let zero = Vec3x::splat(Vec3::ZERO);
    let is = |kind: Vertex| Mask(std::array::from_fn(|k| vertex[k] == kind));
    let (miss, diffuse, glass) = (is(Vertex::Miss), is(Vertex::Diffuse), is(Vertex::Glass));
    let live = Mask(std::array::from_fn(|k| chunk.slot[k] != NONE));
    let beta = Vec3x::from_lanes(&chunk.beta);
    let (origin, dir) = (Vec3x::from_lanes(&chunk.origin), Vec3x::from_lanes(&chunk.dir));
    let (p, n, p_error) = (Vec3x::from_lanes(&hits.p), Vec3x::from_lanes(&hits.n), F32x(hits.p_error));
    let wo = -dir;
    // An escaped ray outside any medium sees the background (no environment light).
    let outside = live & Vec3x::from_lanes(&chunk.absorption).is_zero();
    let escaped = Vec3x::select(outside, beta * Vec3x::splat(stages.background), zero);
    // Emission reached by BSDF sampling (or seen directly), weighted against NEE.
    let le = Vec3x::select(n.dot(wo).gt(F32x::splat(0.0)), Vec3x::from_lanes(&g.emit_radiance), zero);
    let pdf_li = area_to_solid_angle(F32x(g.emit_area_pdf), origin, p, n);
    let skip_mis = Mask(chunk.skip_mis);
    let w =
        F32x::select(skip_mis, F32x::splat(1.0), power_heuristic(F32x(chunk.bsdf_pdf), light_pick * pdf_li));
    let emission = Vec3x::select(!le.is_zero(), beta * le * w, zero);
    let frame = FrameX::from_normal(n);
    let wo_local = frame.to_local(wo);
    // Smooth glass: RoughDielectric::sample.
    let (glass_ok, glass_sample) = specular_sample(F32x(g.eta), wo_local, F32x(draws.first[0]));
    // A diffuse vertex: the albedo, then next-event estimation (Light::sample_li of a quad).
    let albedo = checker(p, F32x(g.cell), Vec3x::from_lanes(&g.color1), Vec3x::from_lanes(&g.color2));
    let (ux, uy) = (F32x(draws.first[0]), F32x(draws.first[1]));
    let y =
        Vec3x::from_lanes(&g.corner) + ux * Vec3x::from_lanes(&g.edge_u) + uy * Vec3x::from_lanes(&g.edge_v);
    let ny = Vec3x::from_lanes(&g.normal);
    let d = y - p;
    let distance = d.length();
    let wi = d / distance;
    let radiance = Vec3x::select(ny.dot(-wi).gt(F32x::splat(0.0)), Vec3x::from_lanes(&g.radiance), zero);
    let pdf = area_to_solid_angle(F32x(g.area_pdf), p, y, ny);
    let sampled =
        distance.gt(F32x::splat(0.0)) & !radiance.is_zero() & pdf.gt(F32x::splat(0.0)) & pdf.is_finite();
    let wi_local = frame.to_local(wi);
    let f = lambert_eval(albedo, wo_local, wi_local) * (wi_local.z.abs() * 1.0);
    let pending = diffuse & sampled & !f.is_zero();
    let shadow = shadow_toward(p, n, p_error, y);
    let pdf = light_pick * pdf;
    let w = power_heuristic(pdf, lambert_pdf(wo_local, wi_local));
    // The diffuse BSDF sample's point on the disk, up to its trigonometry.
    let (centre, radius, theta) = concentric_polar(F32x(draws.bsdf[0]), F32x(draws.bsdf[1]));
    Shaded {
        emitted: Vec3x::select(miss, escaped, emission),
        frame,
        wo_local,
        albedo,
        centre,
        radius,
        theta,
        glass_ok: glass & glass_ok,
        glass: glass_sample,
        pending,
        shadowed: pending & !shadow.remaining.le(F32x::splat(0.0)),
        shadow,
        target: y,
        nee_beta: beta,
        nee_value: f * radiance * (w / pdf),
    }
}

dispatch! {
    /// Stage 3 compiled for `isa` (see [`shade_before_kernel`]).
    fn shade_before_trigonometry(stages: &LaneStages, chunk: &PathChunk, hits: &HitLanes, vertex: &[Vertex; WIDTH], draws: &Draws, g: &Gathered) -> Shaded => shade_before_kernel
}

/// Stage 5 across lanes: the BSDF sample from the disk point (diffuse) or the glass sample, the
/// throughput, the medium, the next ray and Russian roulette, written into `chunk` where the
/// path scatters.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn scatter_kernel(
    stages: &LaneStages,
    chunk: &mut PathChunk,
    hits: &HitLanes,
    vertex: &[Vertex; WIDTH],
    draws: &Draws,
    g: &Gathered,
    shaded: &Shaded,
    trig: &[Lanes; 2],
) -> Scattered {
    let picks = (stages.lights.corner.len() > 1) as u32;
    let zero = F32x::splat(0.0);
    let is = |kind: Vertex| Mask(std::array::from_fn(|k| vertex[k] == kind));
    let (diffuse, glass) = (is(Vertex::Diffuse), is(Vertex::Glass));
    let (dx, dy) = (shaded.radius * F32x(trig[0]), shaded.radius * F32x(trig[1]));
    let (dx, dy) = (F32x::select(shaded.centre, zero, dx), F32x::select(shaded.centre, zero, dy));
    let (diffuse_ok, diffuse_sample) = lambert_sample(shaded.albedo, shaded.wo_local, dx, dy);
    let pick = |a: SampleX, b: SampleX| SampleX {
        wi: Vec3x::select(diffuse, a.wi, b.wi),
        f: Vec3x::select(diffuse, a.f, b.f),
        pdf: F32x::select(diffuse, a.pdf, b.pdf),
        transmits: (diffuse & a.transmits) | (!diffuse & b.transmits),
        eta: F32x::select(diffuse, a.eta, b.eta),
    };
    let s = pick(diffuse_sample, shaded.glass);
    let sampled = (diffuse & diffuse_ok) | shaded.glass_ok;
    let scatters = sampled & !(s.pdf.le(zero) | s.f.is_zero());
    let wi = shaded.frame.to_world(s.wi);
    let beta = Vec3x::from_lanes(&chunk.beta) * (s.f * (s.wi.z.abs() / s.pdf));
    let (dir, n) = (Vec3x::from_lanes(&chunk.dir), Vec3x::from_lanes(&hits.n));
    // lighting::crossing: the medium a reflected ray stays in or a refracted one enters.
    let (inside, outside) = (Vec3x::from_lanes(&g.inside), Vec3x::from_lanes(&g.outside));
    let enters = dir.dot(n).lt(zero);
    let incident = Vec3x::select(enters, outside, inside);
    let transmitted = Vec3x::select(enters, inside, outside);
    let medium = Vec3x::select(s.transmits, transmitted, incident);
    let eta_scale = F32x(chunk.eta_scale);
    let eta_scale = F32x::select(s.transmits, eta_scale * (s.eta * s.eta), eta_scale);
    let wo = -dir;
    let reflected = (wi.dot(n) * wo.dot(n)).gt(zero);
    let origin = spawn_origin(Vec3x::from_lanes(&hits.p), n, F32x(hits.p_error), wi);
    let next_dir = wi + Vec3x::splat(Vec3::ZERO);
    let depth: [u32; WIDTH] = std::array::from_fn(|k| chunk.depth[k] + 1);
    // Russian roulette.
    let rr = (beta * eta_scale).max_element();
    let deep = Mask(std::array::from_fn(|k| depth[k] > ROULETTE_DEPTH));
    let plays = deep & rr.lt(F32x::splat(1.0));
    let q = (1.0 - rr).max(zero);
    let dies = plays & F32x(draws.roulette).lt(q);
    let beta = Vec3x::select(plays, beta / (1.0 - q), beta);
    // The new state where the path scatters.
    let keep = |new: Vec3x, old: &mut Vec3Lanes| {
        *old = Vec3x::select(scatters, new, Vec3x::from_lanes(old)).to_lanes()
    };
    keep(beta, &mut chunk.beta);
    keep(Vec3x::select(glass, medium, Vec3x::from_lanes(&chunk.absorption)), &mut chunk.absorption);
    keep(origin, &mut chunk.origin);
    keep(next_dir, &mut chunk.dir);
    chunk.eta_scale = F32x::select(scatters, eta_scale, F32x(chunk.eta_scale)).0;
    chunk.bsdf_pdf = F32x::select(scatters, s.pdf, F32x(chunk.bsdf_pdf)).0;
    let mut out = Scattered {
        goes_on: (scatters & !dies).0,
        reflected: (scatters & reflected).0,
        refracted: (scatters & !reflected).0,
        dimensions: [0; WIDTH],
        light_requests: [0; WIDTH],
        bsdf_requests: [0; WIDTH],
        other_requests: [0; WIDTH],
    };
    for k in 0..WIDTH {
        let (diffuse, glass, scatters) = (diffuse.0[k], glass.0[k], scatters.0[k]);
        // The numbers drawn: light choice and point then the BSDF pair (diffuse), or the lobe
        // choice and the pair (glass); a roulette number where it played.
        let rolled = (scatters & plays.0[k]) as u32;
        let drawn = if diffuse {
            picks + 4
        } else if glass {
            3
        } else {
            0
        };
        out.dimensions[k] = drawn + rolled;
        out.light_requests[k] = if diffuse { picks + 1 } else { 0 };
        out.bsdf_requests[k] = if diffuse {
            1
        } else if glass {
            2
        } else {
            0
        };
        out.other_requests[k] = rolled;
        chunk.dimension[k] += out.dimensions[k];
        if scatters {
            // Delta samples are not evaluable: no MIS on what they hit.
            chunk.skip_mis[k] = glass;
            chunk.depth[k] = depth[k];
        }
    }
    out
}

dispatch! {
    /// Stage 5 compiled for `isa` (see [`scatter_kernel`]).
    fn scatter(stages: &LaneStages, chunk: &mut PathChunk, hits: &HitLanes, vertex: &[Vertex; WIDTH], draws: &Draws, g: &Gathered, shaded: &Shaded, trig: &[Lanes; 2]) -> Scattered => scatter_kernel
}
