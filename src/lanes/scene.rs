//! A scene's primitives for the lane kernels: the closest hit and the occlusion of [`WIDTH`]
//! rays, found one of two ways, chosen by measurement when the lane scene is made:
//!
//! - **every primitive tested across the 16 lanes** (no hierarchy), for static scenes of at most
//!   [`LaneScene::TEST_EVERY_UP_TO`] quads, spheres, outward cylinders and disks. On the shipped
//!   analytic scenes (9–10 primitives, one CwBvh node) the BVH's one-ray closest hit takes
//!   1.2–1.9× the time per ray of this (`cargo bench --bench lanes`), and rendering `path` with
//!   the BVH traversed across lanes instead ([`super::bvh`]) runs at 0.57× (soft-shadows), 0.68×
//!   (cornell-glass), 0.89× (frosted-glass, 12 primitives) and 0.91× (dispersion, 16) of this
//!   form's speed (`scripts/perf/ab_speed.py`, 200², 8 spp, 4 rounds, AVX-512). Between 16 and 64
//!   primitives no shipped scene measures the crossing; the limit is the stage tables' 64.
//! - **the scene's CwBvh traversed by the 16 rays** ([`super::bvh`]) for any other static scene:
//!   meshes (with vertex normals or not), polygons, ellipsoids, inward cylinders, any number of
//!   primitives. Each lane gets the scalar traversal's primitive, distance and triangle
//!   barycentrics ([`LaneHits::bary`]), so [`Scene::record`] makes the same hit record.
//!
//! Scenes whose objects move have no lane form (their shapes are tested where they are at each
//! ray's time).

// Lane loops index several arrays by the lane, as the kernels they vectorise into do.
#![allow(clippy::needless_range_loop)]

use super::bvh::SceneBvh;
use super::shapes::{cylinder_kernel, disk_kernel, quad_kernel, sphere_kernel};
use super::wide::{F32x, Mask, Vec3x};
use super::{dispatch, Isa, Lanes, RayLanes, WIDTH};
use crate::geometry::{gamma, Shape};
use crate::scene::Scene;
use glam::Vec3;
use std::sync::Arc;

/// One primitive of a kind: its shape, its index into [`Scene::primitives`] and its compile
/// rank (which wins a tie).
#[derive(Clone, Copy, Debug)]
struct Entry<S> {
    shape: S,
    primitive: u32,
    rank: u32,
}

/// A scene's primitives grouped by kind, for testing every one of them across lanes.
#[derive(Clone, Debug)]
pub struct LaneScene {
    quads: Vec<Entry<crate::geometry::Quad>>,
    spheres: Vec<Entry<crate::geometry::Sphere>>,
    cylinders: Vec<Entry<crate::geometry::Cylinder>>,
    disks: Vec<Entry<crate::geometry::Disk>>,
    /// Per primitive, what its hit record needs.
    records: Vec<RecordShape>,
    /// Per primitive (modulo [`LaneScene::MAX_PRIMITIVES`]), the light it emits for, or
    /// [`NONE`].
    light_of: [u32; LaneScene::MAX_PRIMITIVES],
    /// The BVH traversed across lanes, where the scene is not tested primitive by primitive
    /// (shared: the engine and its stages hold copies of the lane scene).
    bvh: Option<Arc<SceneBvh>>,
    /// Why the lane stages' per-primitive tables cannot take the scene, if they cannot.
    tables: Result<(), String>,
    isa: Isa,
}

/// How a primitive's hit record is made: the shape's kind and its numbers (see
/// [`LaneScene::records`]).
#[derive(Clone, Copy, Debug, Default)]
struct RecordShape {
    kind: RecordKind,
    /// A quad's corner, a disk's, sphere's centre, a cylinder's base.
    reference: Vec3,
    /// A plane's normal, a sphere's axis (its normal's fallback), a cylinder's axis.
    axis: Vec3,
    /// A cylinder's normal's fallback.
    fallback: Vec3,
    radius: f32,
}

/// The kinds of hit record.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum RecordKind {
    /// Quads and disks: the point projected onto the plane.
    #[default]
    Plane,
    /// The point reprojected onto the sphere.
    Sphere,
    /// The radial component reprojected onto the wall.
    Cylinder,
}

/// The hit records of a batch (lanes that hit): what [`Scene::record`] gives without texture
/// coordinates.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceX {
    /// The point.
    pub p: Vec3x,
    /// The geometric (and shading) normal.
    pub n: Vec3x,
    /// The point's error bound.
    pub p_error: F32x,
}

/// The closest hits of a batch: per lane the distance (+∞ for a miss) and the primitive.
#[derive(Clone, Copy, Debug)]
pub struct LaneHits {
    /// Hit distances; +∞ where the ray meets nothing.
    pub t: Lanes,
    /// The primitive hit (an index into [`Scene::primitives`]); meaningless for a miss.
    pub primitive: [u32; WIDTH],
    /// A triangle's barycentrics at the hit, as its test found them (`None` for other shapes
    /// and misses): what [`Scene::record`] takes to make the triangle's hit record.
    pub bary: [Option<[f32; 3]>; WIDTH],
}

impl LaneScene {
    /// The most primitives the lane stages' per-primitive tables take
    /// (`integrators/wavefront/stages.rs`; [`LaneScene::tables`] says whether a scene fits).
    pub const MAX_PRIMITIVES: usize = 64;

    /// The most primitives tested one by one across lanes (beyond, and for any shape but quads,
    /// spheres, outward cylinders and disks, the BVH is traversed across lanes; see the module
    /// documentation for the measurements).
    pub const TEST_EVERY_UP_TO: usize = 64;

    /// The lane form of `scene`, with kernels for `isa`: every primitive tested across lanes
    /// (a few quads, spheres, cylinders and disks) or the BVH traversed across lanes (any other
    /// static scene); `Err` says why the scene cannot have one (its objects move).
    pub fn new(scene: &Scene, isa: Isa) -> Result<LaneScene, String> {
        if scene.has_motion() {
            return Err(
                "objects move (motion blur): their shapes are tested where they are at each ray's time, \
                        through the BVH"
                    .into(),
            );
        }
        let count = scene.primitives.len();
        let mut lanes = LaneScene {
            quads: vec![],
            spheres: vec![],
            cylinders: vec![],
            disks: vec![],
            records: vec![],
            light_of: [NONE; Self::MAX_PRIMITIVES],
            bvh: None,
            tables: Ok(()),
            isa,
        };
        // Why some primitive has no kernel of its own and no lane hit record, if one has none.
        let mut analytic = Ok(());
        for (i, prim) in scene.primitives.iter().enumerate() {
            let (primitive, rank) = (i as u32, scene.compile_rank(i as u32));
            if i < Self::MAX_PRIMITIVES {
                lanes.light_of[i] = prim.light.unwrap_or(NONE);
            }
            let plane = |reference, axis| RecordShape {
                kind: RecordKind::Plane,
                reference,
                axis,
                ..Default::default()
            };
            match &prim.shape {
                Shape::Quad(q) => {
                    lanes.quads.push(Entry { shape: **q, primitive, rank });
                    lanes.records.push(plane(q.corner, q.normal));
                }
                Shape::Sphere(s) => {
                    lanes.spheres.push(Entry { shape: **s, primitive, rank });
                    let (reference, axis, radius) = (s.center, s.axis, s.radius);
                    lanes.records.push(RecordShape {
                        kind: RecordKind::Sphere,
                        reference,
                        axis,
                        fallback: axis,
                        radius,
                    });
                }
                Shape::Cylinder(c) if c.inward() => {
                    analytic = analytic.and(Err("a cylinder faces inwards (flip_normals)".to_string()));
                    lanes.records.push(RecordShape::default());
                }
                Shape::Cylinder(c) => {
                    lanes.cylinders.push(Entry { shape: **c, primitive, rank });
                    let (reference, axis, fallback, radius) = (c.base, c.w, c.u, c.radius);
                    lanes.records.push(RecordShape {
                        kind: RecordKind::Cylinder,
                        reference,
                        axis,
                        fallback,
                        radius,
                    });
                }
                Shape::Disk(d) => {
                    lanes.disks.push(Entry { shape: **d, primitive, rank });
                    lanes.records.push(plane(d.center, d.normal));
                }
                Shape::Triangle(_) => {
                    let why = "triangle primitives (tested across lanes in the BVH traversal)";
                    analytic = analytic.and(Err(why.to_string()));
                    lanes.records.push(RecordShape::default());
                }
                other => {
                    analytic = analytic.and(Err(format!(
                        "{} primitives have no lane kernel (each lane runs the scalar test)",
                        other.kind()
                    )));
                    lanes.records.push(RecordShape::default());
                }
            }
        }
        lanes.tables = if count > Self::MAX_PRIMITIVES {
            Err(format!("{count} primitives (the lane stages' tables take up to {})", Self::MAX_PRIMITIVES))
        } else {
            analytic.clone().map_err(|why| format!("{why}, which have no lane hit record"))
        };
        if analytic.is_err() || count > Self::TEST_EVERY_UP_TO {
            lanes.bvh = Some(Arc::new(SceneBvh::new(scene)));
            (lanes.quads, lanes.spheres, lanes.cylinders, lanes.disks) = (vec![], vec![], vec![], vec![]);
        }
        Ok(lanes)
    }

    /// Whether the lane stages' per-primitive tables and hit records ([`LaneScene::records`])
    /// take the scene: at most [`LaneScene::MAX_PRIMITIVES`] quads, spheres, outward cylinders
    /// and disks; `Err` says why not.
    pub fn tables(&self) -> Result<(), String> {
        self.tables.clone()
    }

    /// Whether the hits are found through the BVH (else every primitive is tested).
    pub fn traverses_bvh(&self) -> bool {
        self.bvh.is_some()
    }

    /// How the hits are found, in words: every primitive tested, or the BVH traversed.
    pub fn method(&self) -> &'static str {
        match self.bvh {
            None => "every primitive tested against 16 rays at once",
            Some(_) => "the BVH traversed by 16 rays at once",
        }
    }

    /// The instruction set the kernels run with.
    pub fn isa(&self) -> Isa {
        self.isa
    }

    /// The closest hit of every lane's ray within (0, `tmax[k]`): what [`Scene::intersect`]
    /// finds, with ties going to the primitive compiled first as there. A lane with a `tmax` of
    /// 0 or below is idle (it never hits).
    pub fn closest(&self, rays: &RayLanes, tmax: &Lanes) -> LaneHits {
        if let Some(bvh) = &self.bvh {
            return bvh.closest(self.isa, rays, tmax);
        }
        closest_hits(self.isa, self, rays, tmax)
    }

    /// Whether each lane's ray meets, within (0, `tmax[k]`), a primitive that blocks it: any
    /// primitive but those of the light `light[k]` met at a distance of `reach[k]` or more (the
    /// light a shadow ray aims at, [`crate::lighting::ShadowRay::reach`]); what
    /// [`Scene::occluded`] finds with [`crate::lighting::ShadowRay::blocks`]. A lane with a
    /// `tmax` of 0 or below is idle.
    pub fn occluded(
        &self,
        rays: &RayLanes,
        tmax: &Lanes,
        light: &[u32; WIDTH],
        reach: &Lanes,
    ) -> [bool; WIDTH] {
        if let Some(bvh) = &self.bvh {
            return bvh.occluded(self.isa, rays, tmax, light, reach);
        }
        any_hits(self.isa, self, rays, tmax, light, reach)
    }
}

/// Keeps, per lane, the hit `t` of `primitive` (compile rank `rank`) where it is closer than the
/// best so far or as close and compiled first; `limit` becomes the float above the best
/// distance, so that the next primitives' ties are seen (as `Scene::closest`).
#[inline(always)]
fn keep_closest(
    best: &mut LaneHits,
    best_rank: &mut [u32; WIDTH],
    limit: &mut Lanes,
    t: &Lanes,
    primitive: u32,
    rank: u32,
) {
    // Selects, no branches: the loop vectorises.
    for k in 0..WIDTH {
        let wins = (t[k] < f32::INFINITY)
            & ((best.primitive[k] == NONE) | (t[k] < best.t[k]) | (rank < best_rank[k]));
        best.t[k] = if wins { t[k] } else { best.t[k] };
        best.primitive[k] = if wins { primitive } else { best.primitive[k] };
        best_rank[k] = if wins { rank } else { best_rank[k] };
        // The next float above a positive distance is its bit pattern plus one.
        limit[k] = if wins { f32::from_bits(t[k].to_bits() + 1) } else { limit[k] };
    }
}

/// Every primitive's kernel in turn, in one function (so that the rays stay in registers):
/// `visit(state, t, primitive, rank)` sees each primitive's hit distances below
/// `limit(state)`.
#[inline(always)]
fn each_primitive<S>(
    scene: &LaneScene,
    rays: &RayLanes,
    state: &mut S,
    limit: impl Fn(&S) -> Lanes,
    visit: impl Fn(&mut S, &Lanes, u32, u32),
) {
    for e in &scene.quads {
        let t = quad_kernel(&e.shape, rays, 0.0, &limit(state));
        visit(state, &t, e.primitive, e.rank);
    }
    for e in &scene.spheres {
        let t = sphere_kernel(&e.shape, rays, 0.0, &limit(state));
        visit(state, &t, e.primitive, e.rank);
    }
    for e in &scene.cylinders {
        let t = cylinder_kernel(&e.shape, rays, 0.0, &limit(state));
        visit(state, &t, e.primitive, e.rank);
    }
    for e in &scene.disks {
        let t = disk_kernel(&e.shape, rays, 0.0, &limit(state));
        visit(state, &t, e.primitive, e.rank);
    }
}

/// The closest hit of every lane among all primitives.
#[inline(always)]
fn closest_kernel(scene: &LaneScene, rays: &RayLanes, tmax: &Lanes) -> LaneHits {
    let best = LaneHits { t: [f32::INFINITY; WIDTH], primitive: [NONE; WIDTH], bary: [None; WIDTH] };
    let mut state = (best, [u32::MAX; WIDTH], *tmax);
    each_primitive(
        scene,
        rays,
        &mut state,
        #[inline(always)]
        |(_, _, limit)| *limit,
        #[inline(always)]
        |(best, rank, limit), t, primitive, r| keep_closest(best, rank, limit, t, primitive, r),
    );
    state.0
}

dispatch! {
    /// [`closest_kernel`] compiled for `isa`.
    fn closest_hits(scene: &LaneScene, rays: &RayLanes, tmax: &Lanes) -> LaneHits => closest_kernel
}

/// Marks, per lane, a hit `t` of `primitive` that blocks (see [`LaneScene::occluded`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn keep_blockers(
    scene: &LaneScene,
    blocked: &mut [bool; WIDTH],
    t: &Lanes,
    primitive: u32,
    light: &[u32; WIDTH],
    reach: &Lanes,
) {
    let emits = scene.light_of[primitive as usize % LaneScene::MAX_PRIMITIVES];
    for k in 0..WIDTH {
        let passes = (emits == light[k]) & (emits != NONE) & (t[k] >= reach[k]);
        blocked[k] |= (t[k] < f32::INFINITY) & !passes;
    }
}

/// Whether a primitive blocks each lane's shadow ray.
#[inline(always)]
fn any_hit_kernel(
    scene: &LaneScene,
    rays: &RayLanes,
    tmax: &Lanes,
    light: &[u32; WIDTH],
    reach: &Lanes,
) -> [bool; WIDTH] {
    let mut blocked = [false; WIDTH];
    each_primitive(
        scene,
        rays,
        &mut blocked,
        #[inline(always)]
        |_| *tmax,
        #[inline(always)]
        |blocked, t, primitive, _| keep_blockers(scene, blocked, t, primitive, light, reach),
    );
    blocked
}

dispatch! {
    /// [`any_hit_kernel`] compiled for `isa`.
    fn any_hits(scene: &LaneScene, rays: &RayLanes, tmax: &Lanes, light: &[u32; WIDTH], reach: &Lanes) -> [bool; WIDTH] => any_hit_kernel
}

impl LaneScene {
    /// The hit records of `hits` (lanes with a finite distance; the others' are meaningless):
    /// [`Scene::record`]'s point, normal and error bound to the bit, without texture
    /// coordinates (the lane stages read none). Only for lanes that hit a quad, a sphere, an
    /// outward cylinder or a disk: a scene that [`LaneScene::tables`] accepts has no others.
    pub fn records(&self, rays: &RayLanes, hits: &LaneHits) -> SurfaceX {
        let zero = Vec3x::splat(Vec3::ZERO);
        let mut table = RecordLanes {
            sphere: Mask::splat(false),
            cylinder: Mask::splat(false),
            reference: zero,
            axis: zero,
            fallback: zero,
            radius: F32x::splat(0.0),
        };
        let set = |v: &mut Vec3x, k: usize, x: Vec3| {
            (v.x.0[k], v.y.0[k], v.z.0[k]) = (x.x, x.y, x.z);
        };
        for k in 0..WIDTH {
            if hits.t[k] < f32::INFINITY {
                let s = &self.records[hits.primitive[k] as usize];
                table.sphere.0[k] = s.kind == RecordKind::Sphere;
                table.cylinder.0[k] = s.kind == RecordKind::Cylinder;
                set(&mut table.reference, k, s.reference);
                set(&mut table.axis, k, s.axis);
                set(&mut table.fallback, k, s.fallback);
                table.radius.0[k] = s.radius;
            }
        }
        surfaces(self.isa, rays, &hits.t, &table)
    }
}

/// The record numbers of a batch's primitives, as lanes.
#[derive(Clone, Copy, Debug)]
struct RecordLanes {
    sphere: Mask,
    cylinder: Mask,
    reference: Vec3x,
    axis: Vec3x,
    fallback: Vec3x,
    radius: F32x,
}

/// [`crate::geometry::unit_or`] across lanes.
#[inline(always)]
fn unit_or(v: Vec3x, fallback: Vec3x) -> Vec3x {
    let largest = v.abs().max_element();
    let scaled = v / largest;
    let rcp = 1.0 / scaled.length();
    let keep =
        largest.gt(F32x::splat(0.0)) & largest.is_finite() & rcp.is_finite() & rcp.gt(F32x::splat(0.0));
    Vec3x::select(keep, scaled * rcp, fallback)
}

/// [`crate::geometry::point_error`] across lanes.
#[inline(always)]
fn point_error(p: Vec3x, local: F32x, ulps: i32) -> F32x {
    gamma(ulps) * local + gamma(2) * p.abs().max_element()
}

/// The records of every kind present in the batch, each lane keeping its own kind's: the quad's
/// and disk's `plane_point` and `planar_surface`, the sphere's and the cylinder's `surface_uv`.
#[inline(always)]
fn surfaces_kernel(rays: &RayLanes, t: &Lanes, s: &RecordLanes) -> SurfaceX {
    let (origin, dir, t) = (Vec3x::from_lanes(&rays.origin), Vec3x::from_lanes(&rays.dir), F32x(*t));
    let q = (origin - s.reference) + t * dir;
    // A plane: q projected onto it.
    let in_plane = q - q.dot(s.axis) * s.axis;
    let plane_p = s.reference + in_plane;
    let mut out = SurfaceX { p: plane_p, n: s.axis, p_error: point_error(plane_p, in_plane.length(), 6) };
    // A sphere and a cylinder, where some lane hit one.
    if s.sphere.any() {
        let n = unit_or(q, s.fallback);
        let p = s.reference + n * s.radius;
        out.p = Vec3x::select(s.sphere, p, out.p);
        out.n = Vec3x::select(s.sphere, n, out.n);
        out.p_error = F32x::select(s.sphere, point_error(p, s.radius, 6), out.p_error);
    }
    if s.cylinder.any() {
        let z = q.dot(s.axis);
        let n = unit_or(q - z * s.axis, s.fallback);
        let p = s.reference + (z * s.axis + s.radius * n);
        out.p = Vec3x::select(s.cylinder, p, out.p);
        out.n = Vec3x::select(s.cylinder, n, out.n);
        out.p_error = F32x::select(s.cylinder, point_error(p, s.radius + z.abs(), 8), out.p_error);
    }
    out
}

dispatch! {
    /// [`surfaces_kernel`] compiled for `isa`.
    fn surfaces(rays: &RayLanes, t: &Lanes, s: &RecordLanes) -> SurfaceX => surfaces_kernel
}

/// The primitive of a lane that has hit nothing yet.
const NONE: u32 = u32::MAX;
