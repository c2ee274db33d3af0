//! The scene's obvhs CwBvh traversed for [`WIDTH`] rays at once: the closest hits and the
//! occlusion of [`LaneScene`](super::LaneScene)s too large (or with shapes, such as mesh
//! triangles, too many) for testing every primitive.
//!
//! **Packet traversal.** A packet of lanes walks the tree depth first; at each node, one
//! kernel tests the node's eight child boxes against all 16 rays (obvhs's slab test,
//! `CwBvhNode::intersect_ray`, operation for operation: the same products, sums, minima and
//! maxima, so each lane enters exactly the children obvhs's one-ray test enters), and a child is
//! visited by the lanes that enter it. A leaf's primitives are tested, one after another, by the
//! lanes that entered the leaf. A triangle met by at least [`TRIANGLE_LANES_FROM`] lanes is
//! tested against them all at once by [`Triangle::hits`], the watertight test written once over
//! [`crate::lanes::Vector`]: the function the scalar engine runs for one ray, so each lane's
//! distance and barycentrics are the scalar engine's to the bit. Fewer lanes, and every other
//! shape, run the scalar engine's own test lane by lane ([`Shape::hit_sheared`], the ray's shear
//! computed once per lane).
//!
//! **The scalar engine's order, lane by lane.** [`crate::scene::Scene::intersect`] visits a
//! node's children in an order given by the ray's octant (the signs of its direction), prunes
//! children against the closest hit found so far, and breaks ties between equal distances by
//! compile rank. Which children are pruned depends on the order when a box's computed entry
//! distance and a primitive's computed hit distance differ in the last bits, so the closest hits
//! traverse one packet per octant among the batch's rays, in that octant's child order: each
//! lane then meets its nodes and primitives in the very order, and with the very limits, of its
//! one-ray traversal, and ends with the same primitive, distance and barycentrics, ties
//! included. Occlusion prunes against the fixed segment length only, so its answer does not
//! depend on the order: one packet takes every lane, and a lane leaves it at its first blocker.
//!
//! **Measured** (`cargo bench --bench lanes`, smooth-glass's 968 triangles, AVX-512; numbers and
//! the engine choice they led to in `docs/architecture.md`, "Meshes across lanes"): one 16-ray
//! traversal against 16 one-ray traversals, camera rays 1.4–1.6×, uniform bounce rays (about 7
//! octants among 16 rays) 0.47× with the box test always across the 16 lanes, 0.63× with it lane
//! by lane below [`DENSE_FROM`] lanes, 0.74× with the hit bits walked as words, 0.65–0.87× with a
//! lone ray of its octant traversing alone ([`ONE_BY_ONE_UP_TO`]); shadow rays 1.1–1.45×. Single
//! runs on a shared machine (their spread is wide); the two thresholds were set by those steps,
//! not tuned further. The triangle test across lanes changes little (camera rays' medians 1.55×
//! without it, 1.62–1.63× from 8 or 4 lanes on, within the noise; callgrind's instruction count
//! of a render (AVX2) the same within 0.1% from 4 or 8 lanes on, 0.6% more from 2): a mesh's
//! triangle tests are about a tenth of its traversal's instructions, its node tests the rest.

// Lane loops index several arrays by the lane, as the kernels they vectorise into do.
#![allow(clippy::needless_range_loop)]

use super::scene::LaneHits;
use super::{dispatch, F32x, Isa, Lanes, Mask, RayLanes, Vec3x, WIDTH};
use crate::geometry::{Ray, Shape, ShearedRay, Triangle};
use crate::scene::Scene;
use obvhs::cwbvh::node::CwBvhNode;
use std::cell::OnceCell;

/// obvhs's nearest box distance a CwBvh node accepts (its `EPSILON`, not exported;
/// `src/scene/traversal.rs` checks it against obvhs).
const NODE_TMIN: f32 = 1e-4;

/// No primitive, or no light.
const NONE: u32 = u32::MAX;

/// A set of lanes, one bit each.
type LaneMask = u16;

/// What a BVH traversal across lanes reads of a static scene: its CwBvh and its primitives'
/// shapes and lights, in BVH order.
#[derive(Clone, Debug)]
pub(super) struct SceneBvh {
    nodes: Vec<CwBvhNode>,
    /// Per primitive (BVH order), its compile rank: which of two equal distances wins.
    rank: Vec<u32>,
    shapes: Vec<Shape>,
    /// Per primitive, the light it emits for, or [`NONE`].
    light_of: Vec<u32>,
    /// BVH = world coordinates × this power of two (so the mapping is exact).
    inv_scale: f32,
}

/// [`WIDTH`] rays in BVH coordinates, as `obvhs::ray::Ray::new` and `Scene::bvh_ray` make them,
/// with what the node test reads of them.
struct BvhRays {
    origin: [Lanes; 3],
    /// obvhs's `safe_inverse` of the direction's components.
    inv: [Lanes; 3],
    /// Whether the direction runs backwards along each axis (the far plane comes first).
    negative: [[bool; WIDTH]; 3],
    /// obvhs's `oct_inv4` of each lane's direction: the order it visits children in.
    oct: [u32; WIDTH],
}

impl BvhRays {
    #[inline(always)]
    fn new(rays: &RayLanes, inv_scale: f32) -> BvhRays {
        let mut out = BvhRays {
            origin: rays.origin,
            inv: [[0.0; WIDTH]; 3],
            negative: [[false; WIDTH]; 3],
            oct: [0; WIDTH],
        };
        for a in 0..3 {
            for k in 0..WIDTH {
                // `Vec3A::from(dir) + Vec3A::ZERO`: −0 becomes +0.
                let d = rays.dir[a][k] + 0.0;
                out.origin[a][k] = rays.origin[a][k] * inv_scale;
                out.inv[a][k] = if d.abs() <= f32::EPSILON { d.signum() / f32::EPSILON } else { 1.0 / d };
                out.negative[a][k] = d < 0.0;
            }
        }
        for k in 0..WIDTH {
            let bit = |a: usize, v: u32| if out.negative[a][k] { 0 } else { v };
            out.oct[k] = bit(0, 0x0404_0404) | bit(1, 0x0202_0202) | bit(2, 0x0101_0101);
        }
        out
    }
}

/// A node's eight child boxes in its grid (obvhs's quantised corners as floats), and which slots
/// hold a child.
struct Children {
    lo: [[f32; 8]; 3],
    hi: [[f32; 8]; 3],
    used: [bool; 8],
}

impl Children {
    #[inline(always)]
    fn of(node: &CwBvhNode) -> Children {
        let f = |q: &[u8; 8]| q.map(f32::from);
        Children {
            lo: [f(&node.child_min_x), f(&node.child_min_y), f(&node.child_min_z)],
            hi: [f(&node.child_max_x), f(&node.child_max_y), f(&node.child_max_z)],
            // An empty slot: obvhs gives it no bits.
            used: node.child_meta.map(|m| m != 0),
        }
    }
}

/// Whether the ray with the grid `scale` and `offset` (per axis) and the direction signs
/// `negative` enters the box `lo`..`hi` within (`NODE_TMIN`, `limit`): obvhs's
/// `CwBvhNode::intersect_ray_basic` for one child.
#[inline(always)]
fn slab(
    lo: [f32; 3],
    hi: [f32; 3],
    scale: [f32; 3],
    offset: [f32; 3],
    negative: [bool; 3],
    limit: f32,
) -> bool {
    let mut near = [0.0; 3];
    let mut far = [0.0; 3];
    for a in 0..3 {
        let (n, f) = if negative[a] { (hi[a], lo[a]) } else { (lo[a], hi[a]) };
        near[a] = n * scale[a] + offset[a];
        far[a] = f * scale[a] + offset[a];
    }
    // No NaN can arise (finite inverses and offsets), so the order of max and min is free.
    let tmin = near[0].max(near[1]).max(near[2]).max(NODE_TMIN);
    let tmax = far[0].min(far[1]).min(far[2]).min(limit);
    tmin <= tmax
}

/// Per child slot of `node`, the lanes of `group` whose ray enters the child's box within
/// (`NODE_TMIN`, `limit[k]`), lane by lane obvhs's test. Two loop orders for one test: across
/// the 16 lanes child by child where many lanes take part, across the 8 children lane by lane
/// where few do ([`DENSE_FROM`]).
#[inline(always)]
fn enter(node: &CwBvhNode, rays: &BvhRays, group: LaneMask, limit: &Lanes) -> [LaneMask; 8] {
    let extent = node.compute_extent().to_array();
    let p = node.p.to_array();
    let boxes = Children::of(node);
    let mut out = [0; 8];
    if group.count_ones() >= DENSE_FROM {
        let mut scale = [[0.0; WIDTH]; 3];
        let mut offset = [[0.0; WIDTH]; 3];
        for a in 0..3 {
            for k in 0..WIDTH {
                scale[a][k] = extent[a] * rays.inv[a][k];
                offset[a][k] = (p[a] - rays.origin[a][k]) * rays.inv[a][k];
            }
        }
        for c in 0..8 {
            if !boxes.used[c] {
                continue;
            }
            let lo = [boxes.lo[0][c], boxes.lo[1][c], boxes.lo[2][c]];
            let hi = [boxes.hi[0][c], boxes.hi[1][c], boxes.hi[2][c]];
            let mut entered = [false; WIDTH];
            for k in 0..WIDTH {
                let scale = [scale[0][k], scale[1][k], scale[2][k]];
                let offset = [offset[0][k], offset[1][k], offset[2][k]];
                let negative = [rays.negative[0][k], rays.negative[1][k], rays.negative[2][k]];
                entered[k] = slab(lo, hi, scale, offset, negative, limit[k]);
            }
            let mut mask = 0;
            for k in 0..WIDTH {
                mask |= (entered[k] as LaneMask) << k;
            }
            out[c] = mask & group;
        }
    } else {
        each_lane(group, |k| {
            let scale: [f32; 3] = std::array::from_fn(|a| extent[a] * rays.inv[a][k]);
            let offset: [f32; 3] = std::array::from_fn(|a| (p[a] - rays.origin[a][k]) * rays.inv[a][k]);
            let negative = [rays.negative[0][k], rays.negative[1][k], rays.negative[2][k]];
            let mut entered = [false; 8];
            for c in 0..8 {
                let lo = [boxes.lo[0][c], boxes.lo[1][c], boxes.lo[2][c]];
                let hi = [boxes.hi[0][c], boxes.hi[1][c], boxes.hi[2][c]];
                entered[c] = slab(lo, hi, scale, offset, negative, limit[k]) & boxes.used[c];
            }
            for c in 0..8 {
                out[c] |= (entered[c] as LaneMask) << k;
            }
        });
    }
    out
}

/// The most rays of one octant that traverse one by one ([`traverse_one`]) rather than as a
/// packet (see the module documentation).
const ONE_BY_ONE_UP_TO: u32 = 1;

/// The fewest lanes at a node for which its children are tested across the 16 lanes (fewer are
/// tested lane by lane, the eight children at once; see the module documentation).
const DENSE_FROM: u32 = 6;

/// A depth-first traversal of `nodes` by the lanes `lanes`, children visited in the order of the
/// octant `oct` (obvhs's `traverse!` order: a node's primitives, then its children, the highest
/// hit bit first). `visit(primitive, lanes, limit)` tests a primitive for the lanes that reached
/// it, may lower their `limit` (BVH units), and returns the lanes that are done. `stack` is
/// scratch space.
#[inline(always)]
fn traverse(
    nodes: &[CwBvhNode],
    rays: &BvhRays,
    lanes: LaneMask,
    oct: u32,
    limit: &mut Lanes,
    stack: &mut Vec<(u32, LaneMask)>,
    mut visit: impl FnMut(u32, LaneMask, &mut Lanes) -> LaneMask,
) {
    if nodes.is_empty() || lanes == 0 {
        return;
    }
    let mut alive = lanes;
    stack.clear();
    stack.push((0, lanes));
    while let Some((index, group)) = stack.pop() {
        let group = group & alive;
        if group == 0 {
            continue;
        }
        let node = &nodes[index as usize];
        let entered = enter(node, rays, group, limit);
        // Per bit of obvhs's hit mask (primitives in the low 24, inner children in the top 8),
        // the lanes that set it; `hit` has the bits some lane set.
        let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct);
        let mut at = [0 as LaneMask; 32];
        let mut hit = 0u32;
        for slot in 0..8 {
            let lanes = entered[slot];
            if lanes == 0 {
                continue;
            }
            let mut bits =
                (((child_bits8 >> (8 * slot)) & 0xff) << ((bit_index8 >> (8 * slot)) & 0xff)) as u32;
            hit |= bits;
            while bits != 0 {
                at[bits.trailing_zeros() as usize] |= lanes;
                bits &= bits - 1;
            }
        }
        // Primitives, highest bit first.
        let mut primitives = hit & 0x00ff_ffff;
        while primitives != 0 {
            let bit = 31 - primitives.leading_zeros();
            primitives &= !(1 << bit);
            let lanes = at[bit as usize] & alive;
            if lanes != 0 {
                alive &= !visit(node.primitive_base_idx + bit, lanes, limit);
            }
        }
        // Children, pushed lowest first so that the highest bit is visited next.
        let mut children = hit >> 24;
        while children != 0 {
            let bit = children.trailing_zeros();
            children &= children - 1;
            let slot = bit ^ (oct & 0xff);
            let child = node.child_base_idx + (node.imask as u32 & ((1 << slot) - 1)).count_ones();
            stack.push((child, at[24 + bit as usize]));
        }
    }
}

/// [`traverse`] for the one lane `k`: obvhs's hit mask kept as one word, with no lane sets to
/// carry (for packets of one or two rays, where a lane set costs more than it shares).
#[inline(always)]
fn traverse_one(
    nodes: &[CwBvhNode],
    rays: &BvhRays,
    k: usize,
    limit: &mut f32,
    stack: &mut Vec<(u32, LaneMask)>,
    mut visit: impl FnMut(u32, &mut f32),
) {
    if nodes.is_empty() {
        return;
    }
    let oct = rays.oct[k];
    let negative = [rays.negative[0][k], rays.negative[1][k], rays.negative[2][k]];
    stack.clear();
    stack.push((0, 1));
    while let Some((index, _)) = stack.pop() {
        let node = &nodes[index as usize];
        let extent = node.compute_extent().to_array();
        let p = node.p.to_array();
        let boxes = Children::of(node);
        let scale: [f32; 3] = std::array::from_fn(|a| extent[a] * rays.inv[a][k]);
        let offset: [f32; 3] = std::array::from_fn(|a| (p[a] - rays.origin[a][k]) * rays.inv[a][k]);
        let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct);
        let mut hit = 0u32;
        for c in 0..8 {
            let lo = [boxes.lo[0][c], boxes.lo[1][c], boxes.lo[2][c]];
            let hi = [boxes.hi[0][c], boxes.hi[1][c], boxes.hi[2][c]];
            let entered = slab(lo, hi, scale, offset, negative, *limit) & boxes.used[c];
            let bits = (((child_bits8 >> (8 * c)) & 0xff) << ((bit_index8 >> (8 * c)) & 0xff)) as u32;
            hit |= if entered { bits } else { 0 };
        }
        let mut primitives = hit & 0x00ff_ffff;
        while primitives != 0 {
            let bit = 31 - primitives.leading_zeros();
            primitives &= !(1 << bit);
            visit(node.primitive_base_idx + bit, limit);
        }
        let mut children = hit >> 24;
        while children != 0 {
            let bit = children.trailing_zeros();
            children &= children - 1;
            let slot = bit ^ (oct & 0xff);
            stack.push((node.child_base_idx + (node.imask as u32 & ((1 << slot) - 1)).count_ones(), 1));
        }
    }
}

/// Lane `k` of `rays` as a ray (at time 0: the scene is static).
#[inline(always)]
fn lane_ray(rays: &RayLanes, k: usize) -> Ray {
    let axis = |v: &[Lanes; 3]| glam::Vec3::new(v[0][k], v[1][k], v[2][k]);
    Ray { origin: axis(&rays.origin), dir: axis(&rays.dir), time: 0.0 }
}

/// The lanes of `lanes`, lowest first.
#[inline(always)]
fn each_lane(mut lanes: LaneMask, mut f: impl FnMut(usize)) {
    while lanes != 0 {
        f(lanes.trailing_zeros() as usize);
        lanes &= lanes - 1;
    }
}

/// The fewest lanes for which a leaf's triangle is tested across the 16 lanes at once (fewer are
/// tested lane by lane, by the same function for one ray; see the module documentation).
const TRIANGLE_LANES_FROM: u32 = 4;

/// The lanes of a lane set as a [`Mask`].
#[inline(always)]
fn mask_of(lanes: LaneMask) -> Mask {
    Mask(std::array::from_fn(|k| lanes & (1 << k) != 0))
}

/// The lanes of a [`Mask`] as a lane set.
#[inline(always)]
fn lanes_of(mask: Mask) -> LaneMask {
    let mut lanes = 0;
    for k in 0..WIDTH {
        lanes |= (mask.0[k] as LaneMask) << k;
    }
    lanes
}

/// A batch's rays in world coordinates, for the primitives' tests: each lane's ray, and the
/// triangle test's constants lane by lane and across lanes (each made when first needed).
struct WorldRays<'a> {
    rays: &'a RayLanes,
    ray: [Ray; WIDTH],
    sheared: [OnceCell<Option<ShearedRay>>; WIDTH],
    /// The constants across lanes, and where they are valid.
    lanes: OnceCell<(Mask, ShearedRay<Vec3x>)>,
}

impl WorldRays<'_> {
    #[inline(always)]
    fn new(rays: &RayLanes) -> WorldRays<'_> {
        WorldRays {
            rays,
            ray: std::array::from_fn(|k| lane_ray(rays, k)),
            sheared: Default::default(),
            lanes: OnceCell::new(),
        }
    }

    /// The triangle `p` against the rays of `lanes` within (0, `below`), across the lanes:
    /// the lanes it hits, their distances and barycentrics.
    #[inline(always)]
    fn triangle(
        &self,
        isa: Isa,
        p: [glam::Vec3; 3],
        lanes: LaneMask,
        below: &Lanes,
    ) -> Option<LaneTriangleHits> {
        let (valid, sheared) = self.lanes.get_or_init(|| {
            ShearedRay::of(Vec3x::from_lanes(&self.rays.origin), Vec3x::from_lanes(&self.rays.dir))
        });
        triangle_hits(isa, p, sheared, mask_of(lanes) & *valid, below)
    }
}

/// A triangle's hits across lanes: the lanes, their distances and barycentrics.
type LaneTriangleHits = (LaneMask, F32x, [F32x; 3]);

/// [`Triangle::hits`] of one triangle against the lanes of `rays` that are `active`.
#[inline(always)]
fn triangle_kernel(
    p: [glam::Vec3; 3],
    rays: &ShearedRay<Vec3x>,
    active: Mask,
    below: &Lanes,
) -> Option<LaneTriangleHits> {
    let p = [Vec3x::splat(p[0]), Vec3x::splat(p[1]), Vec3x::splat(p[2])];
    let (hit, t, bary) = Triangle::hits(&p, rays, active, F32x::ZERO, F32x(*below))?;
    Some((lanes_of(hit), t, bary))
}

dispatch! {
    /// [`triangle_kernel`] compiled for `isa`: a call of its own, so that the traversal's
    /// lane-by-lane path does not carry the kernel's registers.
    fn triangle_hits(p: [glam::Vec3; 3], rays: &ShearedRay<Vec3x>, active: Mask, below: &Lanes) -> Option<LaneTriangleHits> => triangle_kernel
}

/// A batch's closest hits so far, as `Scene::closest` keeps them lane by lane.
struct Closest<'a> {
    bvh: &'a SceneBvh,
    world: WorldRays<'a>,
    tmax: &'a Lanes,
    hits: LaneHits,
}

impl Closest<'_> {
    /// Lane `k`'s limit for the next primitive: up to and including the best distance so far
    /// (to see ties).
    #[inline(always)]
    fn below(&self, k: usize) -> f32 {
        if self.hits.primitive[k] != NONE {
            self.hits.t[k].next_up()
        } else {
            self.tmax[k]
        }
    }

    /// Lane `k` meets primitive `id` at `t` with `bary`: ties go to the lower compile rank.
    #[inline(always)]
    fn take(&mut self, id: u32, k: usize, t: f32, bary: Option<[f32; 3]>, limit: &mut f32) {
        let hits = &mut self.hits;
        let found = hits.primitive[k] != NONE;
        if found && t == hits.t[k] && self.bvh.rank[id as usize] > self.bvh.rank[hits.primitive[k] as usize] {
            return;
        }
        (hits.t[k], hits.primitive[k], hits.bary[k]) = (t, id, bary);
        *limit = limit.min(t * self.bvh.inv_scale);
    }

    /// Primitive `id` for lane `k` alone, by the scalar test.
    #[inline(always)]
    fn test(&mut self, id: u32, k: usize, limit: &mut f32) {
        let shape = &self.bvh.shapes[id as usize];
        let world = &self.world;
        if let Some((t, bary)) = shape.hit_sheared(&world.ray[k], &world.sheared[k], 0.0, self.below(k)) {
            self.take(id, k, t, bary, limit);
        }
    }

    /// Primitive `id` for the lanes `lanes`: a triangle across the lanes where there are
    /// enough of them, else lane by lane.
    #[inline(always)]
    fn visit(&mut self, isa: Isa, id: u32, lanes: LaneMask, limit: &mut Lanes) {
        match &self.bvh.shapes[id as usize] {
            Shape::Triangle(tri) if lanes.count_ones() >= TRIANGLE_LANES_FROM => {
                let below: Lanes = std::array::from_fn(|k| self.below(k));
                if let Some((hit, t, bary)) = self.world.triangle(isa, tri.vertices(), lanes, &below) {
                    each_lane(hit, |k| {
                        let bary = Some([bary[0].0[k], bary[1].0[k], bary[2].0[k]]);
                        self.take(id, k, t.0[k], bary, &mut limit[k])
                    });
                }
            }
            _ => each_lane(lanes, |k| self.test(id, k, &mut limit[k])),
        }
    }
}

/// The closest hits of a batch through the BVH: one packet per octant (see the module
/// documentation).
#[inline(always)]
fn closest_kernel(bvh: &SceneBvh, rays: &RayLanes, tmax: &Lanes, isa: Isa) -> LaneHits {
    let packet = BvhRays::new(rays, bvh.inv_scale);
    let hits = LaneHits { t: [f32::INFINITY; WIDTH], primitive: [NONE; WIDTH], bary: [None; WIDTH] };
    let mut closest = Closest { bvh, world: WorldRays::new(rays), tmax, hits };
    let mut limit: Lanes = std::array::from_fn(|k| tmax[k] * bvh.inv_scale);
    let mut remaining: LaneMask = 0;
    for k in 0..WIDTH {
        remaining |= ((tmax[k] > 0.0) as LaneMask) << k;
    }
    let mut stack = Vec::with_capacity(64);
    while remaining != 0 {
        let oct = packet.oct[remaining.trailing_zeros() as usize];
        let mut group = 0;
        each_lane(remaining, |k| group |= ((packet.oct[k] == oct) as LaneMask) << k);
        remaining &= !group;
        if group.count_ones() <= ONE_BY_ONE_UP_TO {
            each_lane(group, |k| {
                traverse_one(&bvh.nodes, &packet, k, &mut limit[k], &mut stack, |id, limit| {
                    closest.test(id, k, limit)
                })
            });
        } else {
            traverse(&bvh.nodes, &packet, group, oct, &mut limit, &mut stack, |id, lanes, limit| {
                closest.visit(isa, id, lanes, limit);
                0
            });
        }
    }
    closest.hits
}

dispatch! {
    /// [`closest_kernel`] compiled for `isa` (given again as its last argument: the set its
    /// triangle kernel runs with).
    fn closest_hits(bvh: &SceneBvh, rays: &RayLanes, tmax: &Lanes, triangles: Isa) -> LaneHits => closest_kernel
}

/// Whether a blocker meets each lane's shadow ray (see [`super::LaneScene::occluded`]): one
/// packet for every lane.
#[inline(always)]
fn any_hit_kernel(
    bvh: &SceneBvh,
    rays: &RayLanes,
    tmax: &Lanes,
    light: &[u32; WIDTH],
    reach: &Lanes,
    isa: Isa,
) -> [bool; WIDTH] {
    let packet = BvhRays::new(rays, bvh.inv_scale);
    let mut limit: Lanes = std::array::from_fn(|k| tmax[k] * bvh.inv_scale);
    let mut lanes: LaneMask = 0;
    for k in 0..WIDTH {
        lanes |= ((tmax[k] > 0.0) as LaneMask) << k;
    }
    let world = WorldRays::new(rays);
    let mut blocked = [false; WIDTH];
    let oct = if lanes == 0 { 0 } else { packet.oct[lanes.trailing_zeros() as usize] };
    let mut stack = Vec::with_capacity(64);
    traverse(&bvh.nodes, &packet, lanes, oct, &mut limit, &mut stack, |id, lanes, _| {
        let (shape, emits) = (&bvh.shapes[id as usize], bvh.light_of[id as usize]);
        let mut done = 0;
        // `ShadowRay::blocks`: a hit on the light aimed at, from its reach on, passes.
        let mut block = |k: usize, t: f32| {
            let passes = emits != NONE && emits == light[k] && t >= reach[k];
            if !passes {
                blocked[k] = true;
                done |= 1 << k;
            }
        };
        match shape {
            Shape::Triangle(tri) if lanes.count_ones() >= TRIANGLE_LANES_FROM => {
                if let Some((hit, t, _)) = world.triangle(isa, tri.vertices(), lanes, tmax) {
                    each_lane(hit, |k| block(k, t.0[k]));
                }
            }
            _ => each_lane(lanes, |k| {
                if let Some(t) = shape.intersect_sheared(&world.ray[k], &world.sheared[k], 0.0, tmax[k]) {
                    block(k, t);
                }
            }),
        }
        done
    });
    blocked
}

dispatch! {
    /// [`any_hit_kernel`] compiled for `isa` (given again as its last argument).
    fn any_hits(bvh: &SceneBvh, rays: &RayLanes, tmax: &Lanes, light: &[u32; WIDTH], reach: &Lanes, triangles: Isa) -> [bool; WIDTH] => any_hit_kernel
}

impl SceneBvh {
    /// The BVH and the primitives of `scene` (which must not move).
    pub(super) fn new(scene: &Scene) -> SceneBvh {
        let bvh = scene.bvh();
        SceneBvh {
            nodes: bvh.nodes.clone(),
            rank: bvh.primitive_indices.clone(),
            shapes: scene.primitives.iter().map(|p| p.shape.clone()).collect(),
            light_of: scene.primitives.iter().map(|p| p.light.unwrap_or(NONE)).collect(),
            inv_scale: 1.0 / scene.bvh_scale(),
        }
    }

    /// [`super::LaneScene::closest`] through the BVH.
    pub(super) fn closest(&self, isa: Isa, rays: &RayLanes, tmax: &Lanes) -> LaneHits {
        closest_hits(isa, self, rays, tmax, isa)
    }

    /// [`super::LaneScene::occluded`] through the BVH.
    pub(super) fn occluded(
        &self,
        isa: Isa,
        rays: &RayLanes,
        tmax: &Lanes,
        light: &[u32; WIDTH],
        reach: &Lanes,
    ) -> [bool; WIDTH] {
        any_hits(isa, self, rays, tmax, light, reach, isa)
    }
}
