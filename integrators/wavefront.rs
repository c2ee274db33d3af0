//! The wavefront engine of `path`: many camera paths advanced together, stage by stage, instead
//! of one path from the camera to its end.
//!
//! Every stage runs across 16 lanes (`wavefront/stages.rs`): the closest hits of 16 paths'
//! rays (every primitive tested, or the BVH traversed, against 16 rays at once), the vertex
//! ([`PathState::advance`], the very step the scalar engine takes, over the lanes' numbers) and
//! the shadow rays of its light samples; after each round the paths that go on are compacted
//! into full chunks (so the batches of 16 stay full: [`Occupancy`]). What a scene holds without
//! a lane form (a material, a light, an environment, wavelengths, moving objects) the vertex
//! asks of the scalar engine's world lane by lane, for the lanes that meet it
//! ([`Wavefront::describe`] says what). Either way every path draws the same random numbers in
//! the same order as the scalar engine and adds the same terms in the same order: the two
//! engines render the same bits (`tests/wavefront.rs`, every shipped scene). A path's estimate
//! depends on its own sample stream alone, so images are bit-identical at any thread count.

mod stages;

use super::{BatchEngine, EngineChoice, PathContext, RenderParams};
use crate::lanes::{Isa, LaneScene, WIDTH};
use crate::params::EngineOption;
use crate::render::CameraRays;
use crate::render::RenderOptions;
use crate::scene::Scene;
use glam::Vec3;
use stages::LaneStages;

/// The wavefront engine for one scene, with its statistics.
#[derive(Debug)]
pub struct Wavefront {
    /// Every stage across lanes.
    stages: LaneStages,
    /// The scene's primitives for the lane kernels, or why it has none (its objects move).
    lanes: Result<LaneScene, String>,
    /// How full the lane stages were over every batch the engine traced as a [`BatchEngine`].
    occupancy: std::sync::Mutex<StageOccupancy>,
}

/// How full a stage's batches were: lanes that carried a ray, of the lanes issued.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Occupancy {
    /// Lanes that carried a ray.
    pub used: u64,
    /// Lanes issued (16 per batch).
    pub issued: u64,
}

impl Occupancy {
    /// The fraction of lanes used (1 for a stage that never ran).
    pub fn fraction(&self) -> f64 {
        if self.issued == 0 {
            1.0
        } else {
            self.used as f64 / self.issued as f64
        }
    }

    /// Adds `other`'s lanes.
    pub fn merge(&mut self, other: &Occupancy) {
        self.used += other.used;
        self.issued += other.issued;
    }

    fn add(&mut self, used: usize) {
        self.used += used as u64;
        self.issued += WIDTH as u64;
    }
}

/// The occupancy of the two lane stages over a trace.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StageOccupancy {
    /// Closest hits.
    pub closest: Occupancy,
    /// Shadow rays.
    pub shadow: Occupancy,
}

impl StageOccupancy {
    /// Adds `other`'s lanes, stage by stage.
    pub fn merge(&mut self, other: &StageOccupancy) {
        self.closest.merge(&other.closest);
        self.shadow.merge(&other.shadow);
    }
}

impl Wavefront {
    /// The engine for `scene` rendered with `opts`: every stage across lanes, what has no lane
    /// form lane by lane.
    pub fn new(scene: &Scene, opts: &RenderOptions) -> Wavefront {
        let lanes = LaneScene::new(scene, Isa::detect());
        let spectral = opts.spectral.resolve(&scene.effects);
        let stages = LaneStages::new(scene, lanes.clone(), opts.sampler, spectral);
        Wavefront { stages, lanes, occupancy: Default::default() }
    }

    /// How full the lane stages were over every batch traced so far as a [`BatchEngine`] (the
    /// camera pass's batches).
    pub fn occupancy(&self) -> StageOccupancy {
        *self.occupancy.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Adds `occupancy` to the engine's statistics.
    fn tally(&self, occupancy: &StageOccupancy) {
        self.occupancy.lock().unwrap_or_else(|e| e.into_inner()).merge(occupancy);
    }

    /// What runs across lanes, in words.
    pub fn describe(&self) -> String {
        let (isa, hits) = (self.stages.isa().name(), self.hit_method());
        let lane_by_lane = self.stages.lane_by_lane();
        if lane_by_lane.is_empty() {
            format!("every stage across lanes ({isa}); hits: {hits}")
        } else {
            format!(
                "every stage across lanes ({isa}); hits: {hits}; lane by lane through the scalar engine's world: {}",
                lane_by_lane.join("; ")
            )
        }
    }

    /// How the closest hits are found, in words.
    fn hit_method(&self) -> String {
        match &self.lanes {
            Ok(l) if l.traverses_bvh() => {
                "the BVH traversed by 16 camera rays at once, bounces one by one".to_string()
            }
            Ok(l) => l.method().to_string(),
            Err(why) => format!("each ray through the BVH on its own ({why})"),
        }
    }

    /// The radiance of every camera sample of `ctxs` (its random stream, channels and counters),
    /// whose rays are `rays` ([`BatchEngine::estimate_rays`]), as [`super::Path`]'s `radiance`
    /// gives it one at a time.
    pub fn radiance(
        &self,
        scene: &Scene,
        params: &RenderParams,
        rays: &[CameraRays],
        ctxs: &mut [PathContext],
        occupancy: &mut StageOccupancy,
    ) -> Vec<Vec3> {
        self.stages.radiance(scene, params, rays, ctxs, occupancy)
    }
}

/// The engine as the camera pass drives it: [`Wavefront::radiance`], its lane occupancy added
/// to the engine's statistics.
impl BatchEngine for Wavefront {
    fn describe(&self) -> String {
        Wavefront::describe(self)
    }

    fn estimate_rays(
        &self,
        scene: &Scene,
        params: &RenderParams,
        rays: &[CameraRays],
        ctxs: &mut [PathContext],
    ) -> Vec<Vec3> {
        let mut occupancy = StageOccupancy::default();
        let radiance = self.radiance(scene, params, rays, ctxs, &mut occupancy);
        self.tally(&occupancy);
        radiance
    }
}

/// The most primitives for which `--engine auto` runs the wavefront engine. Measured on the
/// grey diffuse terrains of `benches/cost_growth.rs` under a point light (callgrind, AVX2
/// kernels, `vitrum render terrain.toml -i path --engine E --resolution 128x128 --spp 8
/// --threads 1`, less loading and the EXR), the wavefront engine's instructions over the scalar
/// engine's: 0.96 at 968 triangles, 1.02 at 10,082, 1.07 at 29,768, 1.19 at 100,352: the
/// bounces' one-ray traversal from the lanes, and the triangles' hit records lane by lane, cost
/// more than the lane stages save once the traversal dominates.
const LARGE_SCENE: usize = 4096;

/// Which engine `path` runs on `scene` under `opts.params.engine`, and why.
pub(super) fn choose(scene: &Scene, opts: &RenderOptions) -> EngineChoice {
    if opts.params.engine == EngineOption::Scalar {
        return EngineChoice::scalar("--engine scalar: one ray at a time, the reference implementation");
    }
    let engine = Wavefront::new(scene, opts);
    if opts.params.engine == EngineOption::Wavefront {
        return EngineChoice::wavefront(engine, "--engine wavefront asks for it whatever the scene");
    }
    let lane_by_lane = engine.stages.lane_by_lane().join("; ");
    let primitives = scene.primitives.len();
    if primitives > LARGE_SCENE {
        return EngineChoice::scalar(format!(
            "{primitives} primitives: through a BVH of more than {LARGE_SCENE} the wavefront engine \
             measured slower than one ray at a time"
        ));
    }
    let hits = engine.hit_method();
    if lane_by_lane.is_empty() {
        return EngineChoice::wavefront(
            engine,
            format!("{primitives} primitives, {hits}, every vertex across lanes"),
        );
    }
    // The tables hold the materials: ahead of the scalar engine on every shipped scene measured
    // (1.02 to 1.94 times fewer instructions, docs/performance.md, "`path`: the engines, scene
    // by scene"), even where some vertices or the hit records go lane by lane.
    if engine.stages.has_tables() {
        return EngineChoice::wavefront(
            engine,
            format!("{primitives} primitives, {hits}; lane by lane: {lane_by_lane}"),
        );
    }
    // Every vertex lane by lane (wavelengths, too many materials): no faster than one ray at a
    // time (measured there too).
    EngineChoice::scalar(format!(
        "{primitives} primitives: the wavefront engine would shade every vertex lane by lane ({lane_by_lane}), \
         measured no faster than one ray at a time"
    ))
}
