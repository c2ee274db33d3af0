//! Shadow rays asked now and answered later, [`WIDTH`] at a time: the visibility tests of the
//! methods that trace one sub-path at a time (the bidirectional engine's next-event estimation
//! and connections, and the camera splats of its light paths and of `light`).
//!
//! A contribution that needs a clear line of sight waits in a [`ShadowQueue`] with its shadow
//! ray ([`ShadowQueue::ray`], [`ShadowQueue::add`]); once [`WIDTH`] rays wait, they are set up
//! across lanes ([`ShadowSegment`]) and tested at once ([`LaneScene::occluded`]), and the
//! contributions are handed back in the order they were added, each with its ray's answer
//! ([`ShadowQueue::answer`]). Both are the one-ray [`ShadowRay::new`] and
//! [`ShadowRay::blocked`] lane by lane to the bit, and the caller adds the contributions up in
//! the order it made them, so the image is the one the rays tested one by one give. A scene
//! without a lane form (moving objects), or a render with `--engine scalar`, tests each ray on
//! its own ([`shadow_lanes`]; so do scenes whose lane form traverses the BVH, where it measured
//! slower), at once: its contribution waits only behind others that wait.
//!
//! Only opaque shadow rays (pure visibility, [`crate::lighting::ShadowMode::Opaque`]) wait here:
//! they are the only kind these methods trace.

use crate::geometry::SurfaceHit;
use crate::lanes::{dispatch, F32x, Isa, LaneScene, RayLanes, Vec3x, WIDTH};
use crate::lighting::{shadow_reach, ShadowRay, ShadowSegment};
use crate::params::{EngineOption, RenderParams};
use crate::scene::Scene;
use crate::stats::RayCounts;
use glam::{Vec2, Vec3};

/// How the shadow rays of a render are tested: across lanes where the scene has a lane form,
/// else one by one.
#[derive(Clone, Copy)]
pub(crate) struct Shadows<'a> {
    scene: &'a Scene,
    lanes: Option<&'a LaneScene>,
}

/// The lane form of `scene` that the rays of a render with `params` are tested through, 16 at
/// a time: `None` (one ray at a time) under `--engine scalar`, where the scene has none (its
/// objects move), and where its form traverses the BVH (meshes, polygons, ellipsoids, more
/// than 64 primitives). Through the BVH the 16 rays of these methods (connections from one
/// camera vertex to scattered light vertices, splats towards the camera, bounces) share few
/// nodes: `vcm` on `scenes/smooth-glass.toml` measured 6% slower with them (400², one thread,
/// AVX-512; `docs/performance.md`).
pub(crate) fn shadow_lanes(scene: &Scene, params: &RenderParams) -> Option<LaneScene> {
    if params.engine == EngineOption::Scalar {
        return None;
    }
    LaneScene::new(scene, Isa::detect()).ok().filter(|lanes| !lanes.traverses_bvh())
}

impl<'a> Shadows<'a> {
    /// Tests in `scene`, [`WIDTH`] rays at once through `lanes` (the scene's lane form), or one
    /// by one where it is `None`.
    pub fn new(scene: &'a Scene, lanes: Option<&'a LaneScene>) -> Shadows<'a> {
        Shadows { scene, lanes }
    }

    /// Appends to `out` whether each ray of `queries` (at most [`WIDTH`]) reaches its target.
    fn test(&self, queries: &[Query], out: &mut Vec<bool>) {
        debug_assert!(queries.len() <= WIDTH);
        let Some(lanes) = self.lanes else {
            out.extend(queries.iter().map(|q| q.visible(self.scene)));
            return;
        };
        // Idle lanes repeat the first query (finite numbers) and test nothing.
        let mut from = Segments {
            p: Vec3x::splat(queries[0].p),
            n: Vec3x::splat(queries[0].n),
            p_error: F32x::splat(queries[0].p_error),
            target: Vec3x::splat(queries[0].target),
        };
        let mut light = [NO_LIGHT; WIDTH];
        for (k, q) in queries.iter().enumerate() {
            from.p.set_lane(k, q.p);
            from.n.set_lane(k, q.n);
            from.p_error.0[k] = q.p_error;
            from.target.set_lane(k, q.target);
            light[k] = q.light;
        }
        let segment = segments(lanes.isa(), &from);
        let mut tmax = [-1.0; WIDTH];
        let mut reach = [0.0; WIDTH];
        let mut blockable = [false; WIDTH];
        for (k, q) in queries.iter().enumerate() {
            let remaining = segment.remaining.0[k];
            // `ShadowRay::can_be_blocked`: a NaN distance is blockable.
            blockable[k] = remaining > 0.0 || remaining.is_nan();
            tmax[k] = if blockable[k] { segment.tmax.0[k] } else { -1.0 };
            reach[k] = shadow_reach(self.scene, q.light(), q.target, remaining);
        }
        let rays = RayLanes { origin: segment.origin.to_lanes(), dir: segment.dir.to_lanes() };
        let blocked = lanes.occluded(&rays, &tmax, &light, &reach);
        out.extend((0..queries.len()).map(|k| !blockable[k] || !blocked[k]));
    }
}

/// The starts and targets of a batch of shadow rays, across lanes.
struct Segments {
    p: Vec3x,
    n: Vec3x,
    p_error: F32x,
    target: Vec3x,
}

/// The segments of a batch of shadow rays ([`ShadowSegment::toward`] across lanes).
#[inline(always)]
fn segments_kernel(from: &Segments) -> ShadowSegment<Vec3x> {
    ShadowSegment::toward(from.p, from.n, from.p_error, from.target)
}

dispatch! {
    /// [`segments_kernel`] compiled for `isa`.
    fn segments(from: &Segments) -> ShadowSegment<Vec3x> => segments_kernel
}

/// No light aimed at ([`LaneScene::occluded`]'s light of a lane that aims at none).
const NO_LIGHT: u32 = u32::MAX;

/// A shadow ray waiting: from a surface point (its geometric normal and error bound) to a
/// target, aimed at a light or none, at a time.
#[derive(Clone, Copy, Debug)]
struct Query {
    p: Vec3,
    n: Vec3,
    p_error: f32,
    target: Vec3,
    /// The light aimed at, or [`NO_LIGHT`].
    light: u32,
    time: f32,
}

impl Query {
    /// The light aimed at, if any.
    fn light(&self) -> Option<u32> {
        (self.light != NO_LIGHT).then_some(self.light)
    }

    /// Whether the ray reaches its target, tested on its own: [`ShadowRay::new`] and
    /// [`ShadowRay::blocked`], as [`crate::lighting::transmittance`] tests an opaque ray.
    fn visible(&self, scene: &Scene) -> bool {
        let from = SurfaceHit {
            t: 0.0,
            p: self.p,
            n: self.n,
            shading_n: self.n,
            uv: Vec2::ZERO,
            p_error: self.p_error,
        };
        let shadow = ShadowRay::toward(&from, self.target, self.light(), self.time);
        !shadow.can_be_blocked() || !shadow.blocked(scene)
    }
}

/// Which shadow ray a waiting contribution depends on ([`ShadowQueue::ray`]), or the answer
/// where it is known.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Ticket(u32);

impl Ticket {
    /// A contribution that needs no shadow ray, or whose ray reaches its target: it counts.
    pub const CLEAR: Ticket = Ticket(u32::MAX);

    /// A contribution whose ray is blocked.
    pub const BLOCKED: Ticket = Ticket(u32::MAX - 1);

    /// Whether the contribution counts, where that is known already.
    pub fn known(self) -> Option<bool> {
        match self {
            Ticket::CLEAR => Some(true),
            Ticket::BLOCKED => Some(false),
            _ => None,
        }
    }
}

/// Contributions `T` waiting, in order, for the shadow rays they depend on.
#[derive(Debug)]
pub(crate) struct ShadowQueue<T> {
    /// The rays not yet tested, in the order they were asked.
    queries: Vec<Query>,
    /// The contributions not yet handed back, in order, each with its ray's index in `queries`
    /// (or [`Ticket::CLEAR`]).
    items: Vec<(T, Ticket)>,
    /// The answers of the rays being tested.
    visible: Vec<bool>,
}

impl<T> Default for ShadowQueue<T> {
    fn default() -> Self {
        ShadowQueue { queries: Vec::new(), items: Vec::new(), visible: Vec::new() }
    }
}

impl<T: Copy> ShadowQueue<T> {
    /// Asks for the opaque shadow ray from the surface point `from` to `target` (on light
    /// `light`, which does not block where the ray reaches it) at time `time`; counts one
    /// shadow ray in `rays`, as [`ShadowRay::new`] does. Where `shadows` tests one ray at a
    /// time, it is tested now and the ticket holds the answer ([`Ticket::known`]).
    pub fn ray(
        &mut self,
        shadows: &Shadows,
        from: &SurfaceHit,
        target: Vec3,
        light: Option<u32>,
        time: f32,
        rays: &mut RayCounts,
    ) -> Ticket {
        rays.shadow += 1;
        let query = Query {
            p: from.p,
            n: from.n,
            p_error: from.p_error,
            target,
            light: light.unwrap_or(NO_LIGHT),
            time,
        };
        if shadows.lanes.is_none() {
            return if query.visible(shadows.scene) { Ticket::CLEAR } else { Ticket::BLOCKED };
        }
        self.queries.push(query);
        Ticket(self.queries.len() as u32 - 1)
    }

    /// Adds `item`, which counts where the ray of `ticket` reaches its target.
    pub fn add(&mut self, item: T, ticket: Ticket) {
        self.items.push((item, ticket));
    }

    /// Whether [`WIDTH`] rays or more wait: time to [`answer`](Self::answer) them.
    pub fn full(&self) -> bool {
        self.queries.len() >= WIDTH
    }

    /// Whether nothing waits.
    pub fn is_empty(&self) -> bool {
        self.queries.is_empty() && self.items.is_empty()
    }

    /// Whether contributions wait (a contribution whose answer is known can be taken at once
    /// only where none is ahead of it).
    pub fn has_items(&self) -> bool {
        !self.items.is_empty()
    }

    /// Tests the waiting rays (all of them with `all`, else as many whole batches of [`WIDTH`]
    /// as wait) and hands the contributions that no untested ray holds back to `take`, in the
    /// order they were added, each with whether its ray reaches its target (its known answer
    /// for a [`Ticket::known`] one).
    pub fn answer(&mut self, shadows: &Shadows, all: bool, mut take: impl FnMut(T, bool)) {
        let tested = if all { self.queries.len() } else { self.queries.len() / WIDTH * WIDTH };
        self.visible.clear();
        for batch in self.queries[..tested].chunks(WIDTH) {
            shadows.test(batch, &mut self.visible);
        }
        let untested = |t: Ticket| t.known().is_none() && t.0 as usize >= tested;
        let done = self.items.iter().position(|&(_, t)| untested(t)).unwrap_or(self.items.len());
        for &(item, ticket) in &self.items[..done] {
            take(item, ticket.known().unwrap_or_else(|| self.visible[ticket.0 as usize]));
        }
        self.items.drain(..done);
        self.queries.drain(..tested);
        for (_, ticket) in &mut self.items {
            if ticket.known().is_none() {
                ticket.0 -= tested as u32;
            }
        }
    }
}
