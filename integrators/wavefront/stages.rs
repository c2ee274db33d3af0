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

use super::super::path::power_heuristic;
use super::super::{PathContext, RenderParams};
use super::{Occupancy, StageOccupancy};
use crate::bsdf::{BsdfSample, Frame, Lambert, RoughDielectric, TransportMode, TrowbridgeReitz};
use crate::camera::concentric_polar;
use crate::geometry::{spawn_origin, Ray, SurfaceHit};
use crate::lanes::{dispatch, sobol_pairs, Isa, LaneScene, Lanes, RayLanes, WIDTH};
use crate::light::{area_to_solid_angle, Light};
use crate::lighting::ShadowRay;
use crate::material::Bsdf;
use crate::sampler::{Dim, SamplerKind, DIM_PURPOSES};
use crate::scene::{Effect, Scene};
use crate::stats::RayCounts;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

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
    model: Vec<RoughDielectric>,
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

/// Shading before the trigonometry, per lane: what stage 5 and the estimates need.
#[derive(Clone, Copy, Debug)]
struct Shaded {
    /// Radiance this vertex adds before next-event estimation (emission, or the background).
    emitted: Vec3Lanes,
    /// Whether the vertex samples its BSDF.
    scatters: [bool; WIDTH],
    frame: [Vec3Lanes; 3],
    wo_local: Vec3Lanes,
    /// Diffuse albedo.
    albedo: Vec3Lanes,
    /// The diffuse sample's point on the disk: at its centre, else the polar coordinates.
    centre: [bool; WIDTH],
    radius: Lanes,
    theta: Lanes,
    /// The glass sample (valid where `glass_ok`).
    glass_ok: [bool; WIDTH],
    glass_wi: Vec3Lanes,
    glass_f: Lanes,
    glass_pdf: Lanes,
    glass_transmits: [bool; WIDTH],
    glass_eta: Lanes,
    /// Next-event estimation: a pending light (`pending`), its shadow ray (`shadow`, where it can
    /// be blocked), and its value f·Le·w/pdf times the throughput at the vertex.
    pending: [bool; WIDTH],
    shadow: [Option<ShadowRay>; WIDTH],
    nee_beta: Vec3Lanes,
    nee_value: Vec3Lanes,
    /// Rays counted (shadow) by the stage.
    shadow_rays: [u32; WIDTH],
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
            surfaces
                .model
                .push(model.unwrap_or(RoughDielectric::new(1.0, TrowbridgeReitz::from_roughness(0.0))));
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
        let found = self.lanes.closest(&RayLanes { origin: chunk.origin, dir: chunk.dir }, &tmax);
        occupancy.closest.add(live.iter().filter(|&&l| l).count());
        let mut hits = HitLanes {
            hit: [false; WIDTH],
            t: [0.0; WIDTH],
            p: [[0.0; WIDTH]; 3],
            n: [[0.0; WIDTH]; 3],
            p_error: [0.0; WIDTH],
            surface: [0; WIDTH],
            light: [NONE; WIDTH],
        };
        for k in 0..WIDTH {
            if live[k] && found.t[k] < f32::INFINITY {
                let ray = Ray { origin: get(&chunk.origin, k), dir: get(&chunk.dir, k), time: 0.0 };
                let primitive = found.primitive[k];
                let h = scene.record(&ray, found.t[k], primitive, None).hit;
                hits.hit[k] = true;
                hits.t[k] = h.t;
                set(&mut hits.p, k, h.p);
                set(&mut hits.n, k, h.n);
                hits.p_error[k] = h.p_error;
                hits.surface[k] = self.material[primitive as usize];
                hits.light[k] = self.light[primitive as usize];
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
        // Stage 2: the round's random numbers.
        let draws = self.draws(isa, chunk, &vertex);
        // Stage 3: shading before the trigonometry.
        let shaded = shade_before_trigonometry(isa, self, chunk, &hits, &vertex, &draws);
        // Stage 4: the diffuse samples' cosines and sines, one lane at a time.
        let mut trig = [[0.0; WIDTH]; 2];
        for k in 0..WIDTH {
            if vertex[k] == Vertex::Diffuse && !shaded.centre[k] {
                (trig[0][k], trig[1][k]) = (shaded.theta[k].cos(), shaded.theta[k].sin());
            }
        }
        // Stage 5: shading after it.
        let scattered = scatter(isa, self, chunk, &hits, &vertex, &draws, &shaded, &trig);
        // Stage 6: the shadow rays.
        let visible = self.shadow_rays(scene, &shaded, &mut occupancy.shadow);
        // The radiance gathered, in the scalar engine's order: emission, then the light.
        for k in 0..WIDTH {
            let slot = chunk.slot[k];
            if slot == NONE {
                continue;
            }
            let estimate = &mut estimates[slot as usize];
            *estimate += get(&shaded.emitted, k);
            if shaded.pending[k] {
                *estimate += get(&shaded.nee_beta, k)
                    * if visible[k] { get(&shaded.nee_value, k) } else { Vec3::ZERO };
            }
            let tally = &mut tallies[slot as usize];
            tally.rays.shadow += shaded.shadow_rays[k] as u64;
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

    /// Stage 6: whether each lane's pending light is visible (true where it has no shadow ray).
    fn shadow_rays(&self, scene: &Scene, shaded: &Shaded, occupancy: &mut Occupancy) -> [bool; WIDTH] {
        let mut rays = RayLanes::default();
        let mut tmax = [-1.0; WIDTH];
        let mut used = 0;
        for k in 0..WIDTH {
            if let Some(s) = &shaded.shadow[k] {
                for axis in 0..3 {
                    rays.origin[axis][k] = s.ray.origin[axis];
                    rays.dir[axis][k] = s.ray.dir[axis];
                }
                tmax[k] = s.tmax;
                used += 1;
            }
        }
        if used == 0 {
            return [true; WIDTH];
        }
        occupancy.add(used);
        let blocked = self.lanes.occluded(&rays, &tmax, |k, primitive, t| {
            shaded.shadow[k].as_ref().is_some_and(|s| s.blocks(scene, primitive, t))
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

/// Stage 3, per lane: the vertex's emission (or the background for an escaped ray), its
/// frame, next-event estimation of a quad light, the glass sample, and the diffuse sample's
/// polar coordinates.
#[inline(always)]
fn shade_before_kernel(
    stages: &LaneStages,
    chunk: &PathChunk,
    hits: &HitLanes,
    vertex: &[Vertex; WIDTH],
    draws: &Draws,
) -> Shaded {
    let light_count = stages.lights.corner.len();
    let light_pick = 1.0 / light_count.max(1) as f32;
    let mut out = Shaded {
        emitted: [[0.0; WIDTH]; 3],
        scatters: [false; WIDTH],
        frame: [[[0.0; WIDTH]; 3]; 3],
        wo_local: [[0.0; WIDTH]; 3],
        albedo: [[0.0; WIDTH]; 3],
        centre: [false; WIDTH],
        radius: [0.0; WIDTH],
        theta: [0.0; WIDTH],
        glass_ok: [false; WIDTH],
        glass_wi: [[0.0; WIDTH]; 3],
        glass_f: [0.0; WIDTH],
        glass_pdf: [0.0; WIDTH],
        glass_transmits: [false; WIDTH],
        glass_eta: [1.0; WIDTH],
        pending: [false; WIDTH],
        shadow: [None; WIDTH],
        nee_beta: [[0.0; WIDTH]; 3],
        nee_value: [[0.0; WIDTH]; 3],
        shadow_rays: [0; WIDTH],
    };
    for k in 0..WIDTH {
        let beta = get(&chunk.beta, k);
        let (origin, dir) = (get(&chunk.origin, k), get(&chunk.dir, k));
        if vertex[k] == Vertex::Miss {
            // An escaped ray outside any medium sees the background (no environment light).
            if chunk.slot[k] != NONE && get(&chunk.absorption, k) == Vec3::ZERO {
                set(&mut out.emitted, k, beta * stages.background);
            }
            continue;
        }
        let (p, n) = (get(&hits.p, k), get(&hits.n, k));
        let wo = -dir;
        // Emission reached by BSDF sampling (or seen directly), weighted against NEE.
        let light = hits.light[k];
        if light != NONE {
            let l = light as usize;
            let le = if n.dot(wo) > 0.0 { stages.lights.radiance[l] } else { Vec3::ZERO };
            if le != Vec3::ZERO {
                let w = if chunk.skip_mis[k] {
                    1.0
                } else {
                    let pdf_li = area_to_solid_angle(stages.lights.area_pdf[l], origin, p, n);
                    power_heuristic(chunk.bsdf_pdf[k], light_pick * pdf_li)
                };
                set(&mut out.emitted, k, beta * le * w);
            }
        }
        if vertex[k] == Vertex::Last {
            continue;
        }
        out.scatters[k] = true;
        let frame = Frame::from_normal(n);
        let wo_local = frame.to_local(wo);
        set(&mut out.frame[0], k, frame.s);
        set(&mut out.frame[1], k, frame.t);
        set(&mut out.frame[2], k, frame.n);
        set(&mut out.wo_local, k, wo_local);
        let s = hits.surface[k] as usize;
        if vertex[k] == Vertex::Glass {
            // RoughDielectric::sample of a smooth interface.
            let sample = if wo_local.z == 0.0 {
                None
            } else {
                stages.surfaces.model[s].sample_specular(wo_local, draws.first[0][k], TransportMode::Radiance)
            };
            if let Some(g) = sample {
                out.glass_ok[k] = true;
                set(&mut out.glass_wi, k, g.wi);
                out.glass_f[k] = g.f.x;
                out.glass_pdf[k] = g.pdf;
                out.glass_transmits[k] = g.is_transmission;
                out.glass_eta[k] = g.eta;
            }
            continue;
        }
        // A diffuse vertex: the albedo (Texture::eval of a checker), then next-event estimation.
        let size = stages.surfaces.cell[s];
        let cell = ((p / size) + Vec3::splat(1e-4)).floor();
        let parity = (cell.x as i64 + cell.y as i64 + cell.z as i64).rem_euclid(2);
        let albedo = if parity == 0 { stages.surfaces.color1[s] } else { stages.surfaces.color2[s] };
        set(&mut out.albedo, k, albedo);
        let index = if light_count == 1 {
            0
        } else {
            ((draws.pick[k] * light_count as f32) as usize).min(light_count - 1)
        };
        let u = Vec2::new(draws.first[0][k], draws.first[1][k]);
        let q = &stages.lights;
        // Light::sample_li of a quad.
        let (y, ny) = (q.corner[index] + u.x * q.u[index] + u.y * q.v[index], q.normal[index]);
        let d = y - p;
        let distance = d.length();
        if distance > 0.0 {
            let wi = d / distance;
            let radiance = if ny.dot(-wi) > 0.0 { q.radiance[index] } else { Vec3::ZERO };
            let pdf = area_to_solid_angle(q.area_pdf[index], p, y, ny);
            if radiance != Vec3::ZERO && pdf > 0.0 && pdf.is_finite() {
                let wi_local = frame.to_local(wi);
                let lambert = Lambert { albedo };
                let f = lambert.eval(wo_local, wi_local) * (wi_local.z.abs() * 1.0);
                if f != Vec3::ZERO {
                    let hit = SurfaceHit {
                        t: hits.t[k],
                        p,
                        n,
                        shading_n: n,
                        uv: Vec2::ZERO,
                        p_error: hits.p_error[k],
                    };
                    let mut rays = RayCounts::default();
                    out.shadow[k] = ShadowRay::new(&hit, y, Some(index as u32), 0.0, &mut rays);
                    out.shadow_rays[k] = rays.shadow as u32;
                    let pdf = light_pick * pdf;
                    let w = power_heuristic(pdf, lambert.pdf(wo_local, wi_local));
                    out.pending[k] = true;
                    set(&mut out.nee_beta, k, beta);
                    set(&mut out.nee_value, k, f * radiance * (w / pdf));
                }
            }
        }
        let (centre, radius, theta) = concentric_polar(Vec2::new(draws.bsdf[0][k], draws.bsdf[1][k]));
        (out.centre[k], out.radius[k], out.theta[k]) = (centre, radius, theta);
    }
    out
}

dispatch! {
    /// Stage 3 compiled for `isa` (see [`shade_before_kernel`]).
    fn shade_before_trigonometry(stages: &LaneStages, chunk: &PathChunk, hits: &HitLanes, vertex: &[Vertex; WIDTH], draws: &Draws) -> Shaded => shade_before_kernel
}

/// Stage 5, per lane: the BSDF sample from the disk point (diffuse) or the glass sample, the
/// throughput, the medium, the next ray and Russian roulette; updates `chunk` in place.
#[inline(always)]
fn scatter_kernel(
    stages: &LaneStages,
    chunk: &mut PathChunk,
    hits: &HitLanes,
    vertex: &[Vertex; WIDTH],
    draws: &Draws,
    shaded: &Shaded,
    trig: &[Lanes; 2],
) -> Scattered {
    let picks = (stages.lights.corner.len() > 1) as u32;
    let mut out = Scattered {
        goes_on: [false; WIDTH],
        reflected: [false; WIDTH],
        refracted: [false; WIDTH],
        dimensions: [0; WIDTH],
        light_requests: [0; WIDTH],
        bsdf_requests: [0; WIDTH],
        other_requests: [0; WIDTH],
    };
    for k in 0..WIDTH {
        if !shaded.scatters[k] {
            continue;
        }
        let diffuse = vertex[k] == Vertex::Diffuse;
        // The numbers drawn before the BSDF sample: light choice and point, or lobe and pair.
        if diffuse {
            (out.dimensions[k], out.light_requests[k], out.bsdf_requests[k]) = (picks + 4, picks + 1, 1);
        } else {
            (out.dimensions[k], out.bsdf_requests[k]) = (3, 2);
        }
        let wo_local = get(&shaded.wo_local, k);
        let sample: Option<BsdfSample> = if diffuse {
            let d = if shaded.centre[k] {
                Vec2::ZERO
            } else {
                shaded.radius[k] * Vec2::new(trig[0][k], trig[1][k])
            };
            Lambert { albedo: get(&shaded.albedo, k) }.sample_above(wo_local, d)
        } else if shaded.glass_ok[k] {
            Some(BsdfSample {
                wi: get(&shaded.glass_wi, k),
                f: Vec3::splat(shaded.glass_f[k]),
                pdf: shaded.glass_pdf[k],
                is_specular: true,
                is_multiple: false,
                is_transmission: shaded.glass_transmits[k],
                eta: shaded.glass_eta[k],
            })
        } else {
            None
        };
        let Some(s) = sample else { continue };
        if s.pdf <= 0.0 || s.f == Vec3::ZERO {
            continue;
        }
        let frame =
            Frame { s: get(&shaded.frame[0], k), t: get(&shaded.frame[1], k), n: get(&shaded.frame[2], k) };
        let wi = frame.to_world(s.wi);
        let mut beta = get(&chunk.beta, k) * (s.f * (s.wi.z.abs() / s.pdf));
        chunk.skip_mis[k] = !s.is_evaluable();
        chunk.bsdf_pdf[k] = s.pdf;
        let (dir, n) = (get(&chunk.dir, k), get(&hits.n, k));
        if !diffuse {
            // lighting::crossing: the medium a reflected ray stays in or a refracted one enters.
            let m = hits.surface[k] as usize;
            let (incident, transmitted) = if dir.dot(n) < 0.0 {
                (stages.surfaces.outside[m], stages.surfaces.inside[m])
            } else {
                (stages.surfaces.inside[m], stages.surfaces.outside[m])
            };
            set(&mut chunk.absorption, k, if s.is_transmission { transmitted } else { incident });
        }
        if s.is_transmission {
            chunk.eta_scale[k] *= s.eta * s.eta;
        }
        let wo = -dir;
        if wi.dot(n) * wo.dot(n) > 0.0 {
            out.reflected[k] = true;
        } else {
            out.refracted[k] = true;
        }
        let hit = SurfaceHit {
            t: hits.t[k],
            p: get(&hits.p, k),
            n,
            shading_n: n,
            uv: Vec2::ZERO,
            p_error: hits.p_error[k],
        };
        set(&mut chunk.origin, k, spawn_origin(&hit, wi));
        set(&mut chunk.dir, k, wi + Vec3::ZERO);
        chunk.depth[k] += 1;
        out.goes_on[k] = true;
        if chunk.depth[k] > ROULETTE_DEPTH {
            let rr = (beta * chunk.eta_scale[k]).max_element();
            if rr < 1.0 {
                let q = (1.0 - rr).max(0.0);
                out.dimensions[k] += 1;
                out.other_requests[k] = 1;
                if draws.roulette[k] < q {
                    out.goes_on[k] = false;
                } else {
                    beta /= 1.0 - q;
                }
            }
        }
        set(&mut chunk.beta, k, beta);
    }
    for k in 0..WIDTH {
        chunk.dimension[k] += out.dimensions[k];
    }
    out
}

dispatch! {
    /// Stage 5 compiled for `isa` (see [`scatter_kernel`]).
    fn scatter(stages: &LaneStages, chunk: &mut PathChunk, hits: &HitLanes, vertex: &[Vertex; WIDTH], draws: &Draws, shaded: &Shaded, trig: &[Lanes; 2]) -> Scattered => scatter_kernel
}
