//! Every stage of the wavefront engine across lanes, for the scenes whose effects it covers
//! ([`LaneStages::new`] says which): chunks of 16 paths in structure-of-arrays form
//! ([`PathChunk`]) go through one round per bounce:
//! 0. the camera rays across lanes (the pixels' Sobol' offsets, a pinhole);
//! 1. closest hits and their records across lanes ([`LaneScene::closest`],
//!    [`LaneScene::records`]);
//! 2. the round's random numbers across lanes ([`sobol_pairs`], [`sobol_firsts`]), each lane at
//!    its own dimensions: a diffuse vertex draws (a light choice,) a light point, a BSDF pair
//!    and a roulette number, glass a lobe choice, a BSDF pair and a roulette number, as the
//!    scalar engine draws them;
//! 3. shading before the trigonometry, across lanes: emission and its MIS weight, the quad or
//!    point light's sample with its MIS weight and shadow ray, the glass's Fresnel choice and
//!    refraction, the diffuse sample's polar coordinates on the disk;
//! 4. the cosine and sine of the diffuse samples, one lane at a time (the scalar engine's libm
//!    calls, so that every bit agrees);
//! 5. shading after it, across lanes: the scattered direction, throughput, media, the next
//!    ray's origin, Russian roulette;
//! 6. the shadow rays across lanes ([`LaneScene::occluded`]), and the radiance gathered;
//!
//! a path that ends writes its estimate and counters out, and after each round the paths that
//! go on are compacted into full chunks. Each lane computes what the scalar engine's
//! `PathState::advance` computes, operation for operation (its functions written once over
//! [`crate::lanes::Real`] and [`crate::lanes::Vector`], the one source for one ray and for
//! lanes): images are the scalar engine's, bit for bit. Per-primitive and per-light numbers are read from fixed-size tables
//! ([`Table`]), so that the reads vectorise as gathers.

// Lane loops index several arrays by the lane, as the kernels they vectorise into do.
#![allow(clippy::needless_range_loop)]

use super::super::path::power_heuristic;
use super::super::RenderParams;
use super::{Occupancy, SampleBatch, StageOccupancy};
use crate::bsdf::rough_dielectric::smooth_dielectric_sample;
use crate::bsdf::{BsdfSample, Frame, Lambert, RoughDielectric, TransportMode};
use crate::camera::concentric_polar;
use crate::geometry::offset_origin;
use crate::lanes::{
    dispatch, sobol_firsts, sobol_pairs, F32x, Isa, LaneHits, LaneScene, Lanes, Mask, RayLanes, SurfaceX,
    Vec3x, WIDTH,
};
use crate::light::area_to_solid_angle;
use crate::light::Light;
use crate::lighting::ShadowSegment;
use crate::material::Bsdf;
use crate::sampler::{pixel_key, Dim, SamplerKind, DIM_PURPOSES};
use crate::scene::{Effect, Scene};
use crate::stats::RayCounts;
use crate::texture::checker;
use crate::texture::Texture;
use glam::Vec3;

/// Bounces after which Russian roulette may end a path (as the scalar engine).
const ROULETTE_DEPTH: u32 = 3;

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

/// 16 camera paths in structure-of-arrays form: what the scalar engine's path state holds, per
/// lane, with the sample stream's state, the radiance and counters so far, and the slot of the
/// sample's estimate.
#[derive(Clone, Copy, Debug)]
struct PathChunk {
    origin: Vec3x,
    dir: Vec3x,
    beta: Vec3x,
    absorption: Vec3x,
    radiance: Vec3x,
    eta_scale: F32x,
    bsdf_pdf: F32x,
    skip_mis: Mask,
    depth: [u32; WIDTH],
    key: [u64; WIDTH],
    reversed: [u32; WIDTH],
    dimension: [u32; WIDTH],
    /// Requests per purpose so far (light, BSDF, other); rays by kind (shadow, reflected,
    /// refracted).
    requests: [[u32; WIDTH]; 3],
    rays: [[u32; WIDTH]; 3],
    /// The sample whose estimate the lane's path is; [`NONE`] for an idle lane.
    slot: [u32; WIDTH],
}

impl PathChunk {
    const IDLE: PathChunk = PathChunk {
        origin: Vec3x::ZERO,
        dir: Vec3x::ZERO,
        beta: Vec3x::ZERO,
        absorption: Vec3x::ZERO,
        radiance: Vec3x::ZERO,
        eta_scale: F32x::ZERO,
        bsdf_pdf: F32x::ZERO,
        skip_mis: Mask::NONE,
        depth: [0; WIDTH],
        key: [0; WIDTH],
        reversed: [0; WIDTH],
        dimension: [0; WIDTH],
        requests: [[0; WIDTH]; 3],
        rays: [[0; WIDTH]; 3],
        slot: [NONE; WIDTH],
    };

    /// Paths about to start: unit throughput, no medium, no MIS on what the camera sees.
    const FRESH: PathChunk =
        PathChunk { beta: Vec3x::ONE, eta_scale: F32x::ONE, skip_mis: Mask::ALL, ..PathChunk::IDLE };

    /// Lane `k`'s path.
    #[inline]
    fn lane(&self, k: usize) -> PathLane {
        PathLane {
            vectors: [&self.origin, &self.dir, &self.beta, &self.absorption, &self.radiance]
                .map(|v| v.lane(k)),
            eta_scale: self.eta_scale.0[k],
            bsdf_pdf: self.bsdf_pdf.0[k],
            skip_mis: self.skip_mis.0[k],
            key: self.key[k],
            counts: [
                self.depth[k],
                self.reversed[k],
                self.dimension[k],
                self.requests[0][k],
                self.requests[1][k],
                self.requests[2][k],
                self.rays[0][k],
                self.rays[1][k],
                self.rays[2][k],
                self.slot[k],
            ],
        }
    }

    /// Puts `path` into lane `j`.
    #[inline]
    fn set_lane(&mut self, j: usize, path: &PathLane) {
        let [origin, dir, beta, absorption, radiance] = path.vectors;
        self.origin.set_lane(j, origin);
        self.dir.set_lane(j, dir);
        self.beta.set_lane(j, beta);
        self.absorption.set_lane(j, absorption);
        self.radiance.set_lane(j, radiance);
        self.eta_scale.0[j] = path.eta_scale;
        self.bsdf_pdf.0[j] = path.bsdf_pdf;
        self.skip_mis.0[j] = path.skip_mis;
        self.key[j] = path.key;
        [
            self.depth[j],
            self.reversed[j],
            self.dimension[j],
            self.requests[0][j],
            self.requests[1][j],
            self.requests[2][j],
            self.rays[0][j],
            self.rays[1][j],
            self.rays[2][j],
            self.slot[j],
        ] = path.counts;
    }
}

/// One lane of a [`PathChunk`], for moving a path between lanes.
#[derive(Clone, Copy, Debug)]
struct PathLane {
    /// Origin, direction, throughput, absorption, radiance.
    vectors: [Vec3; 5],
    eta_scale: f32,
    bsdf_pdf: f32,
    skip_mis: bool,
    key: u64,
    /// Depth, reversed sample, dimension, requests (3), rays (3), slot.
    counts: [u32; 10],
}

/// What a path's sample tallies besides its radiance: rays, and the requests it made of its
/// stream.
#[derive(Clone, Copy, Debug, Default)]
struct Tally {
    rays: RayCounts,
    requests: [u32; DIM_PURPOSES],
}

/// What each lane's vertex is.
#[derive(Clone, Copy, Debug)]
struct Vertices {
    /// A path's ray hit something.
    hit: Mask,
    /// The hit is on diffuse surface below the maximum depth.
    diffuse: Mask,
    /// The hit is on glass below the maximum depth.
    glass: Mask,
}

/// The round's random numbers per lane (see the module documentation).
#[derive(Clone, Copy, Debug)]
struct Draws {
    /// The light point (diffuse), or the lobe choice in `.0` (glass).
    first: (F32x, F32x),
    /// The BSDF sample's pair.
    bsdf: (F32x, F32x),
    /// Russian roulette.
    roulette: F32x,
    /// The light each diffuse lane samples.
    light: [u32; WIDTH],
}

/// Shading before the trigonometry, per lane: what stage 5 and the estimates need.
#[derive(Clone, Copy, Debug)]
struct Shaded {
    /// Radiance this vertex adds before next-event estimation (emission, or the background).
    emitted: Vec3x,
    frame: Frame<Vec3x>,
    wo_local: Vec3x,
    /// Diffuse albedo.
    albedo: Vec3x,
    /// The diffuse sample's point on the disk: at its centre, else the polar coordinates.
    centre: Mask,
    radius: F32x,
    theta: F32x,
    /// The glass sample, where `glass_ok`.
    glass_ok: Mask,
    glass: BsdfSample<Vec3x>,
    /// The glass's media (absorption) inside and outside.
    inside: Vec3x,
    outside: Vec3x,
    /// Next-event estimation: a pending light (`pending`: its shadow ray counted), whether its
    /// shadow ray can be blocked (`shadowed`), the ray, and the light's value
    /// f·Le·w/pdf.
    pending: Mask,
    shadowed: Mask,
    shadow: ShadowSegment<Vec3x>,
    nee_value: Vec3x,
}

impl LaneStages {
    /// The stages for `scene` rendered with `sampler` in RGB (`spectral` false) without depth of
    /// field, with quad and point lights, or why they cannot run it (an effect whose stage is
    /// not across lanes yet).
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

    /// The estimates of `batch`'s samples, as the camera pass's scalar samples give them (a
    /// pinhole `camera`, the Sobol' streams of `seed`), with the camera rays made across lanes
    /// too; their rays and sampler requests are added to `counters`.
    pub fn camera_samples(
        &self,
        params: &RenderParams,
        camera: &crate::camera::Camera,
        seed: u64,
        batch: &SampleBatch,
        counters: (&mut RayCounts, &mut [u64; DIM_PURPOSES]),
        occupancy: &mut StageOccupancy,
    ) -> Vec<Vec3> {
        let SampleBatch { y, xs, samples, total, replicas } = batch.clone();
        let isa = self.isa();
        let per_pixel = samples.len();
        let n = xs.len() * per_pixel;
        // A single sample per pixel goes through the pixel's centre and draws nothing.
        let offset = total != 1;
        let start = |chunks: &mut Vec<PathChunk>| {
            for (p, x) in xs.clone().enumerate() {
                let pixel = y as u64 * camera.width as u64 + x as u64;
                for (j, s) in samples.clone().enumerate() {
                    let i = p * per_pixel + j;
                    let c = lane_of(chunks, i);
                    let k = i % WIDTH;
                    let stream = replicas.stream(seed, s, total);
                    let key = pixel_key(stream.seed, pixel);
                    (c.key[k], c.reversed[k], c.dimension[k]) =
                        (key, stream.index.reverse_bits(), 2 * offset as u32);
                    // The film position's integer part, for now.
                    (c.origin.x.0[k], c.origin.y.0[k]) = (x as f32, y as f32);
                }
            }
            for c in chunks.iter_mut() {
                let (ox, oy) = if offset {
                    let (ox, oy) = sobol_pairs(isa, &c.key, &c.reversed, &[0; WIDTH]);
                    (F32x(ox), F32x(oy))
                } else {
                    (F32x::splat(0.5), F32x::splat(0.5))
                };
                let (fx, fy) = if offset && !camera.filter.is_box() {
                    // The pixel filter's film point, lane by lane (the scalar camera's function).
                    let (mut fx, mut fy) = (F32x::splat(0.0), F32x::splat(0.0));
                    for k in 0..WIDTH {
                        let (x, y) = (c.origin.x.0[k] as u32, c.origin.y.0[k] as u32);
                        let p = camera.film_point(x, y, glam::Vec2::new(ox.0[k], oy.0[k]));
                        (fx.0[k], fy.0[k]) = (p.x, p.y);
                    }
                    (fx, fy)
                } else {
                    (c.origin.x + ox, c.origin.y + oy)
                };
                c.dir = pinhole(isa, camera, &fx, &fy);
                c.origin = Vec3x::splat(camera.position);
            }
        };
        let (estimates, tallies) = self.trace(params, n, start, occupancy);
        let (rays, requests) = counters;
        for tally in tallies {
            *rays += tally.rays;
            for (total, n) in requests.iter_mut().zip(tally.requests) {
                *total += n as u64;
            }
        }
        rays.primary += n as u64;
        requests[Dim::Pixel as usize] += if offset { n as u64 } else { 0 };
        estimates
    }

    /// Traces `n` paths, which `start` sets going (their rays and streams, in the chunks it is
    /// given with every lane's path state fresh and its slot set), to their ends: their
    /// estimates and tallies, in slot order.
    fn trace(
        &self,
        params: &RenderParams,
        n: usize,
        start: impl FnOnce(&mut Vec<PathChunk>),
        occupancy: &mut StageOccupancy,
    ) -> (Vec<Vec3>, Vec<Tally>) {
        SCRATCH.with_borrow_mut(|scratch| {
            let chunks = &mut scratch.chunks;
            chunks.clear();
            chunks.resize(n.div_ceil(WIDTH), PathChunk::FRESH);
            for (i, slot) in (0..chunks.len() * WIDTH).zip(0u32..) {
                chunks[i / WIDTH].slot[i % WIDTH] = if i < n { slot } else { NONE };
            }
            start(chunks);
            let mut estimates = vec![Vec3::ZERO; n];
            let mut tallies = vec![Tally::default(); n];
            while !chunks.is_empty() {
                for chunk in chunks.iter_mut() {
                    self.round(params, chunk, occupancy);
                    finish_ended(chunk, &mut estimates, &mut tallies);
                }
                compact(chunks);
            }
            (estimates, tallies)
        })
    }

    /// One bounce of the 16 paths of `chunk`; the lanes whose path ends get the slot
    /// [`NONE`] after their estimates are written (by [`finish_ended`]).
    fn round(&self, params: &RenderParams, chunk: &mut PathChunk, occupancy: &mut StageOccupancy) {
        let isa = self.isa();
        // Stage 1: closest hits and their records.
        let live = Mask(std::array::from_fn(|k| chunk.slot[k] != NONE));
        let rays = RayLanes { origin: chunk.origin.to_lanes(), dir: chunk.dir.to_lanes() };
        let tmax = F32x::select(live, F32x::splat(f32::INFINITY), F32x::splat(-1.0));
        let found = self.lanes.closest(&rays, &tmax.0);
        occupancy.closest.add(live.count());
        let records = self.lanes.records(&rays, &found);
        let hit = live & F32x(found.t).lt(F32x::splat(f32::INFINITY));
        let scatters = hit & Mask(std::array::from_fn(|k| chunk.depth[k] < params.max_depth));
        let glass = scatters & self.primitives.glass.at(&found.primitive).ne(F32x::splat(0.0));
        let vertices = Vertices { hit, diffuse: scatters & !glass, glass };
        // Absorption along the segment (libm's exp, one lane at a time, where a medium absorbs).
        let absorbs = hit & !chunk.absorption.is_zero();
        if absorbs.any() {
            for k in 0..WIDTH {
                if absorbs.0[k] {
                    let beta = chunk.beta.lane(k) * (-chunk.absorption.lane(k) * found.t[k]).exp();
                    chunk.beta.set_lane(k, beta);
                }
            }
        }
        // Stage 2: the round's random numbers.
        let draws = self.draws(isa, chunk, &vertices);
        // Stage 3: shading before the trigonometry.
        let shaded = shade_before_trigonometry(isa, self, chunk, &found, &records, &vertices, &draws);
        // Stage 4: the diffuse samples' cosines and sines, one lane at a time.
        let mut trig = [[0.0; WIDTH]; 2];
        for k in 0..WIDTH {
            if vertices.diffuse.0[k] && !shaded.centre.0[k] {
                let theta = shaded.theta.0[k];
                (trig[0][k], trig[1][k]) = (theta.cos(), theta.sin());
            }
        }
        // Stage 5: shading after it.
        let beta = chunk.beta;
        let goes_on = scatter(isa, self, chunk, &records, &vertices, &draws, &shaded, &trig);
        // Stage 6: the shadow rays, then the radiance gathered, in the scalar engine's order:
        // emission (or the background), then the light.
        let visible = self.shadow_rays(&shaded, &draws, &mut occupancy.shadow);
        let light = Vec3x::select(visible, shaded.nee_value, Vec3x::ZERO);
        let radiance = chunk.radiance + shaded.emitted;
        chunk.radiance = Vec3x::select(shaded.pending, radiance + beta * light, radiance);
        for k in 0..WIDTH {
            chunk.rays[0][k] += shaded.pending.0[k] as u32;
            if !goes_on.0[k] {
                chunk.depth[k] = u32::MAX;
            }
        }
    }

    /// Stage 2: per lane, the Sobol' numbers its vertex may draw, at the dimensions the scalar
    /// engine draws them (whether it does depends on what the vertex finds; see [`Draws`]), and
    /// the light a diffuse vertex samples.
    fn draws(&self, isa: Isa, chunk: &PathChunk, v: &Vertices) -> Draws {
        let count = self.lights.count;
        let picks = (count > 1) as u32;
        let at = |diffuse: u32, glass: u32| -> [u32; WIDTH] {
            std::array::from_fn(|k| {
                chunk.dimension[k].wrapping_add(if v.diffuse.0[k] { diffuse } else { glass })
            })
        };
        let (keys, reversed) = (&chunk.key, &chunk.reversed);
        // Glass reads only the first number of its pair and none of its BSDF pair (a smooth
        // interface needs none): a chunk without diffuse vertices draws those alone.
        let (first, bsdf) = if v.diffuse.any() {
            (
                sobol_pairs(isa, keys, reversed, &at(picks, 0)),
                sobol_pairs(isa, keys, reversed, &at(picks + 2, 1)),
            )
        } else if v.glass.any() {
            ((sobol_firsts(isa, keys, reversed, &at(picks, 0)), [0.0; WIDTH]), ([0.0; WIDTH], [0.0; WIDTH]))
        } else {
            (([0.0; WIDTH], [0.0; WIDTH]), ([0.0; WIDTH], [0.0; WIDTH]))
        };
        // Roulette plays from the fourth bounce on: earlier rounds draw no roulette number.
        let scatters = v.diffuse | v.glass;
        let deep = (0..WIDTH).any(|k| scatters.0[k] && chunk.depth[k] >= ROULETTE_DEPTH);
        let roulette = if deep { sobol_firsts(isa, keys, reversed, &at(picks + 4, 3)) } else { [1.0; WIDTH] };
        let pick = if picks > 0 && v.diffuse.any() {
            sobol_firsts(isa, keys, reversed, &chunk.dimension)
        } else {
            [0.0; WIDTH]
        };
        // pick_light: one light draws no number.
        let light = std::array::from_fn(|k| {
            if count == 1 {
                0
            } else {
                ((pick[k] * count as f32) as usize).min(count - 1) as u32
            }
        });
        Draws {
            first: (F32x(first.0), F32x(first.1)),
            bsdf: (F32x(bsdf.0), F32x(bsdf.1)),
            roulette: F32x(roulette),
            light,
        }
    }

    /// Stage 6: whether each lane's pending light is visible (true where its shadow ray cannot
    /// be blocked).
    fn shadow_rays(&self, shaded: &Shaded, draws: &Draws, occupancy: &mut Occupancy) -> Mask {
        let used = shaded.shadowed.count();
        if used == 0 {
            return Mask::ALL;
        }
        occupancy.add(used);
        let rays = RayLanes { origin: shaded.shadow.origin.to_lanes(), dir: shaded.shadow.dir.to_lanes() };
        let tmax = F32x::select(shaded.shadowed, shaded.shadow.tmax, F32x::splat(-1.0));
        let reach = shaded.shadow.remaining * (1.0 - 1e-3);
        let blocked = self.lanes.occluded(&rays, &tmax.0, &draws.light, &reach.0);
        !Mask(blocked)
    }
}

/// The chunk of path `i` (lane `i % WIDTH`).
#[inline]
fn lane_of(chunks: &mut [PathChunk], i: usize) -> &mut PathChunk {
    &mut chunks[i / WIDTH]
}

/// Writes out the estimate and counters of every lane of `chunk` whose path ended this round
/// (marked by a depth of `u32::MAX`) and makes the lane idle.
fn finish_ended(chunk: &mut PathChunk, estimates: &mut [Vec3], tallies: &mut [Tally]) {
    for k in 0..WIDTH {
        let slot = chunk.slot[k];
        if slot == NONE || chunk.depth[k] != u32::MAX {
            continue;
        }
        estimates[slot as usize] = chunk.radiance.lane(k);
        let mut requests = [0; DIM_PURPOSES];
        for (purpose, i) in [(Dim::Light, 0), (Dim::Bsdf, 1), (Dim::Other, 2)] {
            requests[purpose as usize] = chunk.requests[i][k];
        }
        let [shadow, reflected, refracted] = chunk.rays.map(|r| r[k] as u64);
        tallies[slot as usize] =
            Tally { rays: RayCounts { primary: 0, reflected, refracted, shadow }, requests };
        chunk.slot[k] = NONE;
    }
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
            let path = chunks[from].lane(k);
            chunks[to_chunk].set_lane(to_lane, &path);
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

/// Stage 3 across lanes: the vertex's emission (or the background for an escaped ray), its
/// frame, next-event estimation of its quad light, the glass sample, and the diffuse sample's
/// polar coordinates. Every lane computes everything and keeps what its vertex uses.
#[inline(always)]
fn shade_before_kernel(
    stages: &LaneStages,
    chunk: &PathChunk,
    found: &LaneHits,
    records: &SurfaceX,
    v: &Vertices,
    draws: &Draws,
) -> Shaded {
    let (prims, lights) = (&stages.primitives, &stages.lights);
    let primitive = &found.primitive;
    let light_pick = 1.0 / lights.count.max(1) as f32;
    let zero = F32x::splat(0.0);
    let live = Mask(std::array::from_fn(|k| chunk.slot[k] != NONE));
    let (beta, origin, wo) = (chunk.beta, chunk.origin, -chunk.dir);
    let (p, n) = (records.p, records.n);
    // An escaped ray outside any medium sees the background (no environment light).
    let escaped =
        Vec3x::select(live & chunk.absorption.is_zero(), beta * Vec3x::splat(stages.background), Vec3x::ZERO);
    // Emission reached by BSDF sampling (or seen directly), weighted against NEE. Each part
    // below runs only where some lane of the chunk needs it (the others' results are unused).
    let le = Vec3x::select(n.dot(wo).gt(zero), prims.emit_radiance.at(primitive), Vec3x::ZERO);
    let emits = !le.is_zero();
    let emission = if emits.any() {
        let pdf_li = area_to_solid_angle(prims.emit_area_pdf.at(primitive), origin, p, n);
        let mis = power_heuristic(chunk.bsdf_pdf, light_pick * pdf_li);
        let w = F32x::select(chunk.skip_mis, F32x::splat(1.0), mis);
        Vec3x::select(emits, beta * le * w, Vec3x::ZERO)
    } else {
        Vec3x::ZERO
    };
    let frame = Frame::from_normal(n);
    let wo_local = frame.to_local(wo);
    let mut shaded = Shaded {
        emitted: Vec3x::select(v.hit, emission, escaped),
        frame,
        wo_local,
        albedo: Vec3x::ZERO,
        centre: Mask::NONE,
        radius: zero,
        theta: zero,
        glass_ok: Mask::NONE,
        glass: BsdfSample {
            wi: Vec3x::ZERO,
            f: Vec3x::ZERO,
            pdf: zero,
            is_specular: Mask::ALL,
            is_multiple: Mask::NONE,
            is_transmission: Mask::NONE,
            eta: F32x::ONE,
        },
        inside: Vec3x::ZERO,
        outside: Vec3x::ZERO,
        pending: Mask::NONE,
        shadowed: Mask::NONE,
        shadow: ShadowSegment { origin: Vec3x::ZERO, dir: Vec3x::ZERO, tmax: zero, remaining: zero },
        nee_value: Vec3x::ZERO,
    };
    if v.glass.any() {
        // Smooth glass: RoughDielectric::sample.
        let (glass_ok, glass) = smooth_dielectric_sample(
            prims.eta.at(primitive),
            wo_local,
            draws.first.0,
            TransportMode::Radiance,
        );
        (shaded.glass_ok, shaded.glass) = (v.glass & glass_ok, glass);
        (shaded.inside, shaded.outside) = (prims.inside.at(primitive), prims.outside.at(primitive));
    }
    if !v.diffuse.any() {
        return shaded;
    }
    // A diffuse vertex: the albedo, then next-event estimation (Light::sample_li of a quad).
    let albedo = checker(p, prims.cell.at(primitive), prims.color1.at(primitive), prims.color2.at(primitive));
    let l = &draws.light;
    // One light is the same in every lane: no gathers.
    let one = lights.count == 1;
    let vector = |t: &Table3| if one { Vec3x::splat(t.get(0)) } else { t.at(l) };
    let (ux, uy) = draws.first;
    let point = if one { Mask::splat(lights.point.0[0] != 0.0) } else { lights.point.at(l).ne(zero) };
    // Light::sample_li of a quad (a point on it) or of a point light.
    let corner = vector(&lights.corner);
    let y = Vec3x::select(point, corner, corner + ux * vector(&lights.u) + uy * vector(&lights.v));
    let ny = vector(&lights.normal);
    let d = y - p;
    let distance = d.length();
    let wi = d / distance;
    let emitted = vector(&lights.radiance);
    let quad_radiance = Vec3x::select(ny.dot(-wi).gt(zero), emitted, Vec3x::ZERO);
    let radiance = Vec3x::select(point, emitted / (distance * distance), quad_radiance);
    let area_pdf = if one { F32x::splat(lights.area_pdf.0[0]) } else { lights.area_pdf.at(l) };
    let pdf = F32x::select(point, F32x::ONE, area_to_solid_angle(area_pdf, p, y, ny));
    let quad_sampled = !radiance.is_zero() & pdf.gt(zero) & pdf.is_finite();
    let sampled = distance.gt(zero) & (point | quad_sampled);
    let wi_local = frame.to_local(wi);
    // Two-sided diffuse (the lane stages take no one-sided surface).
    let lambert = Lambert { albedo, one_sided: Mask::NONE };
    let f = lambert.eval(wo_local, wi_local) * (wi_local.z.abs() * 1.0);
    let pending = v.diffuse & sampled & !f.is_zero();
    let shadow = ShadowSegment::toward(p, n, records.p_error, y);
    let pdf = light_pick * pdf;
    // A point light is a delta: no MIS.
    let w_light = F32x::select(point, F32x::ONE, power_heuristic(pdf, lambert.pdf(wo_local, wi_local)));
    // The diffuse BSDF sample's point on the disk, up to its trigonometry.
    let (centre, radius, theta) = concentric_polar(draws.bsdf.0, draws.bsdf.1);
    Shaded {
        albedo,
        centre,
        radius,
        theta,
        pending,
        shadowed: pending & !shadow.remaining.le(zero),
        shadow,
        nee_value: f * radiance * (w_light / pdf),
        ..shaded
    }
}

/// The pinhole camera's ray directions through the film positions (`fx`, `fy`).
#[inline(always)]
fn pinhole_kernel(camera: &crate::camera::Camera, fx: &F32x, fy: &F32x) -> Vec3x {
    // Ray::new clears −0 components.
    camera.pinhole_direction::<Vec3x>(*fx, *fy) + Vec3x::ZERO
}

dispatch! {
    /// [`pinhole_kernel`] compiled for `isa`.
    fn pinhole(camera: &crate::camera::Camera, fx: &F32x, fy: &F32x) -> Vec3x => pinhole_kernel
}

dispatch! {
    /// Stage 3 compiled for `isa` (see [`shade_before_kernel`]).
    fn shade_before_trigonometry(stages: &LaneStages, chunk: &PathChunk, found: &LaneHits, records: &SurfaceX, v: &Vertices, draws: &Draws) -> Shaded => shade_before_kernel
}

/// Stage 5 across lanes: the BSDF sample from the disk point (diffuse) or the glass sample, the
/// throughput, the medium, the next ray and Russian roulette, written into `chunk` where the
/// path scatters; with the numbers drawn and the rays counted. Returns the lanes whose path
/// goes on.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn scatter_kernel(
    stages: &LaneStages,
    chunk: &mut PathChunk,
    records: &SurfaceX,
    v: &Vertices,
    draws: &Draws,
    shaded: &Shaded,
    trig: &[Lanes; 2],
) -> Mask {
    let picks = (stages.lights.count > 1) as u32;
    let zero = F32x::splat(0.0);
    let (dx, dy) = (shaded.radius * F32x(trig[0]), shaded.radius * F32x(trig[1]));
    let (dx, dy) = (F32x::select(shaded.centre, zero, dx), F32x::select(shaded.centre, zero, dy));
    let lambert = Lambert { albedo: shaded.albedo, one_sided: Mask::NONE };
    let (diffuse_ok, diffuse) = lambert.disk_sample(shaded.wo_local, dx, dy);
    let d = v.diffuse;
    let s = BsdfSample {
        wi: Vec3x::select(d, diffuse.wi, shaded.glass.wi),
        f: Vec3x::select(d, diffuse.f, shaded.glass.f),
        pdf: F32x::select(d, diffuse.pdf, shaded.glass.pdf),
        is_specular: !d,
        is_multiple: Mask::NONE,
        is_transmission: !d & shaded.glass.is_transmission,
        eta: F32x::select(d, diffuse.eta, shaded.glass.eta),
    };
    let sampled = (d & diffuse_ok) | shaded.glass_ok;
    let scatters = sampled & !(s.pdf.le(zero) | s.f.is_zero());
    let wi = shaded.frame.to_world(s.wi);
    let beta = chunk.beta * (s.f * (s.wi.z.abs() / s.pdf));
    let (dir, n) = (chunk.dir, records.n);
    // lighting::crossing: the medium a reflected ray stays in or a refracted one enters.
    let enters = dir.dot(n).lt(zero);
    let incident = Vec3x::select(enters, shaded.outside, shaded.inside);
    let transmitted = Vec3x::select(enters, shaded.inside, shaded.outside);
    let medium = Vec3x::select(s.is_transmission, transmitted, incident);
    let eta_scale = F32x::select(s.is_transmission, chunk.eta_scale * (s.eta * s.eta), chunk.eta_scale);
    let wo = -dir;
    let reflected = (wi.dot(n) * wo.dot(n)).gt(zero);
    let origin = offset_origin(records.p, n, records.p_error, wi);
    let depth: [u32; WIDTH] = std::array::from_fn(|k| chunk.depth[k] + 1);
    // Russian roulette.
    let rr = (beta * eta_scale).max_element();
    let plays = Mask(std::array::from_fn(|k| depth[k] > ROULETTE_DEPTH)) & rr.lt(F32x::splat(1.0));
    let q = (1.0 - rr).max(zero);
    let dies = plays & draws.roulette.lt(q);
    let beta = Vec3x::select(plays, beta / (1.0 - q), beta);
    // The new state where the path scatters.
    chunk.beta = Vec3x::select(scatters, beta, chunk.beta);
    chunk.absorption = Vec3x::select(scatters & v.glass, medium, chunk.absorption);
    chunk.origin = Vec3x::select(scatters, origin, chunk.origin);
    chunk.dir = Vec3x::select(scatters, wi + Vec3x::ZERO, chunk.dir);
    chunk.eta_scale = F32x::select(scatters, eta_scale, chunk.eta_scale);
    chunk.bsdf_pdf = F32x::select(scatters, s.pdf, chunk.bsdf_pdf);
    // Delta samples are not evaluable: no MIS on what they hit.
    chunk.skip_mis = (scatters & v.glass) | (!scatters & chunk.skip_mis);
    for k in 0..WIDTH {
        let (diffuse, glass, scatters) = (v.diffuse.0[k], v.glass.0[k], scatters.0[k]);
        // The numbers drawn: light choice and point then the BSDF pair (diffuse), or the lobe
        // choice and the pair (glass); a roulette number where it played.
        let rolled = (scatters & plays.0[k]) as u32;
        let drawn = (if diffuse {
            picks + 4
        } else if glass {
            3
        } else {
            0
        }) + rolled;
        chunk.dimension[k] += drawn;
        chunk.requests[0][k] += if diffuse { picks + 1 } else { 0 };
        chunk.requests[1][k] += if diffuse {
            1
        } else if glass {
            2
        } else {
            0
        };
        chunk.requests[2][k] += rolled;
        chunk.rays[1][k] += (scatters & reflected.0[k]) as u32;
        chunk.rays[2][k] += (scatters & !reflected.0[k]) as u32;
        if scatters {
            chunk.depth[k] = depth[k];
        }
    }
    scatters & !dies
}

dispatch! {
    /// Stage 5 compiled for `isa` (see [`scatter_kernel`]).
    fn scatter(stages: &LaneStages, chunk: &mut PathChunk, records: &SurfaceX, v: &Vertices, draws: &Draws, shaded: &Shaded, trig: &[Lanes; 2]) -> Mask => scatter_kernel
}
