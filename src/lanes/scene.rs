//! A scene's primitives for the lane kernels: the closest hit and the occlusion of [`WIDTH`]
//! rays, each primitive tested against all of them at once.
//!
//! Every primitive is tested (no hierarchy): measured on the shipped analytic scenes (9–10
//! primitives, one CwBvh node), the BVH's one-ray closest hit takes 1.7–1.9× the time per ray
//! of testing every primitive across 16 lanes (`cargo bench --bench lanes`). That holds for
//! few primitives only, so a [`LaneScene`] takes static scenes of at most
//! [`LaneScene::MAX_PRIMITIVES`] analytic ones (quads, spheres, cylinders, disks); anything else
//! is traversed through the BVH one ray per lane.

use super::{cylinder_hits, disk_hits, quad_hits, sphere_hits, Isa, Lanes, RayLanes, WIDTH};
use crate::geometry::Shape;
use crate::scene::Scene;

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
    isa: Isa,
}

/// The closest hits of a batch: per lane the distance (+∞ for a miss) and the primitive.
#[derive(Clone, Copy, Debug)]
pub struct LaneHits {
    /// Hit distances; +∞ where the ray meets nothing.
    pub t: Lanes,
    /// The primitive hit (an index into [`Scene::primitives`]); meaningless for a miss.
    pub primitive: [u32; WIDTH],
}

impl LaneScene {
    /// The most primitives a lane scene takes: beyond this many, testing every one costs more
    /// than traversing the BVH (see the module documentation).
    pub const MAX_PRIMITIVES: usize = 64;

    /// The lane form of `scene`, with kernels for `isa`; `Err` says why the scene cannot have
    /// one (it moves, has too many primitives, or has polygons or mesh triangles).
    pub fn new(scene: &Scene, isa: Isa) -> Result<LaneScene, String> {
        if scene.has_motion() {
            return Err(
                "objects move (motion blur): their shapes are tested where they are at each ray's time, \
                        through the BVH"
                    .into(),
            );
        }
        let count = scene.primitives.len();
        if count > Self::MAX_PRIMITIVES {
            return Err(format!(
                "{count} primitives: testing every one across lanes pays only up to {}",
                Self::MAX_PRIMITIVES
            ));
        }
        let mut lanes = LaneScene { quads: vec![], spheres: vec![], cylinders: vec![], disks: vec![], isa };
        for (i, prim) in scene.primitives.iter().enumerate() {
            let (primitive, rank) = (i as u32, scene.compile_rank(i as u32));
            match &prim.shape {
                Shape::Quad(q) => lanes.quads.push(Entry { shape: **q, primitive, rank }),
                Shape::Sphere(s) => lanes.spheres.push(Entry { shape: **s, primitive, rank }),
                Shape::Cylinder(c) => lanes.cylinders.push(Entry { shape: **c, primitive, rank }),
                Shape::Disk(d) => lanes.disks.push(Entry { shape: **d, primitive, rank }),
                other => {
                    return Err(format!(
                        "{} primitives have no lane kernel yet (quads, spheres, cylinders and disks have)",
                        other.kind()
                    ))
                }
            }
        }
        Ok(lanes)
    }

    /// The instruction set the kernels run with.
    pub fn isa(&self) -> Isa {
        self.isa
    }

    /// Every primitive in turn, as `visit(hits, primitive, rank)`, where `hits(limit)` runs its
    /// kernel: per lane its hit distance in (0, `limit[k]`), +∞ for none. The closest and the
    /// any-hit queries differ only in the limits they pass and what they keep.
    #[inline]
    fn each_primitive(&self, rays: &RayLanes, mut visit: impl FnMut(&dyn Fn(&Lanes) -> Lanes, u32, u32)) {
        let isa = self.isa;
        for e in &self.quads {
            visit(&|limit| quad_hits(isa, &e.shape, rays, 0.0, limit), e.primitive, e.rank);
        }
        for e in &self.spheres {
            visit(&|limit| sphere_hits(isa, &e.shape, rays, 0.0, limit), e.primitive, e.rank);
        }
        for e in &self.cylinders {
            visit(&|limit| cylinder_hits(isa, &e.shape, rays, 0.0, limit), e.primitive, e.rank);
        }
        for e in &self.disks {
            visit(&|limit| disk_hits(isa, &e.shape, rays, 0.0, limit), e.primitive, e.rank);
        }
    }

    /// The closest hit of every lane's ray within (0, `tmax[k]`): what [`Scene::intersect`]
    /// finds, with ties going to the primitive compiled first as there. A lane with a `tmax` of
    /// 0 or below is idle (it never hits).
    pub fn closest(&self, rays: &RayLanes, tmax: &Lanes) -> LaneHits {
        let mut best = LaneHits { t: [f32::INFINITY; WIDTH], primitive: [NONE; WIDTH] };
        let mut best_rank = [u32::MAX; WIDTH];
        let mut limit = *tmax;
        self.each_primitive(rays, |hits, primitive, rank| {
            let t = hits(&limit);
            // Selects, no branches: the loop vectorises.
            for k in 0..WIDTH {
                let wins = (t[k] < f32::INFINITY)
                    & ((best.primitive[k] == NONE) | (t[k] < best.t[k]) | (rank < best_rank[k]));
                best.t[k] = if wins { t[k] } else { best.t[k] };
                best.primitive[k] = if wins { primitive } else { best.primitive[k] };
                best_rank[k] = if wins { rank } else { best_rank[k] };
                // Up to and including the best distance so far, to see ties (as `Scene::closest`):
                // the next float above a positive distance is its bit pattern plus one.
                limit[k] = if wins { f32::from_bits(t[k].to_bits() + 1) } else { limit[k] };
            }
        });
        best
    }

    /// Whether each lane's ray meets, within (0, `tmax[k]`), a primitive that
    /// `blocks(lane, primitive, t)` counts as a blocker (as [`Scene::occluded`]). A lane with a
    /// `tmax` of 0 or below is idle.
    pub fn occluded(
        &self,
        rays: &RayLanes,
        tmax: &Lanes,
        blocks: impl Fn(usize, u32, f32) -> bool,
    ) -> [bool; WIDTH] {
        let mut blocked = [false; WIDTH];
        self.each_primitive(rays, |hits, primitive, _| {
            let t = hits(tmax);
            for k in 0..WIDTH {
                if t[k].is_finite() && !blocked[k] && blocks(k, primitive, t[k]) {
                    blocked[k] = true;
                }
            }
        });
        blocked
    }
}

/// The primitive of a lane that has hit nothing yet.
const NONE: u32 = u32::MAX;
