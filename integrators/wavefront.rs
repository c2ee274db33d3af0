//! The wavefront engine of `path`: many camera paths advanced together, stage by stage, instead
//! of one path from the camera to its end.
//!
//! Where the scene's effects allow ([`LaneStages::new`] says which), every stage runs across 16
//! lanes (`wavefront/stages.rs`), camera rays included. Elsewhere a batch of paths (a row's
//! camera samples of one pass) is kept as a list of live paths, and each round runs three
//! stages over the whole list:
//! 1. **closest hits**: the rays of 16 live paths at a time across lanes, against every
//!    primitive or through the BVH ([`LaneScene::closest`]), or through the BVH one ray per lane
//!    where the scene has no lane form (moving objects; `--engine wavefront` only: `auto` runs
//!    the scalar engine there);
//! 2. **shading**: per path, [`PathState::advance`], the very step the scalar engine takes
//!    (emission and its MIS weight, next-event estimation, the BSDF sample, Russian roulette),
//!    which leaves the shadow ray of its light sample pending;
//! 3. **shadow rays**: the pending ones, 16 at a time ([`LaneScene::occluded`]), whose light
//!    then counts where nothing blocks it;
//!
//! and the paths that go on are compacted into the next round's list (so the batches of 16 stay
//! full: [`Occupancy`]). Either way every path draws the same random numbers in the same order
//! as the scalar engine and adds the same terms in the same order, and the lane kernels return
//! the scalar functions' values to the bit: the two engines render the same bits
//! (`tests/wavefront.rs`, every shipped scene). A path's estimate depends on its own sample
//! stream alone, so images are bit-identical at any thread count.

mod stages;

use super::path::{OneRay, PathState, PendingLight};
use super::{BatchEngine, EngineChoice, PathContext, RenderParams};
use crate::geometry::Ray;
use crate::lanes::{Isa, LaneScene, Lanes, RayLanes, WIDTH};
use crate::lighting::ShadowRay;
use crate::params::EngineOption;
use crate::render::RenderOptions;
use crate::scene::{Intersection, Scene};
use glam::Vec3;
use stages::LaneStages;

/// A light sample of one path waiting for its shadow ray.
type Pending = PendingLight<Vec3, Option<ShadowRay>>;

/// The wavefront engine for one scene, with its statistics.
#[derive(Debug)]
pub struct Wavefront {
    /// The scene's primitives for the lane kernels, or why it has none (the BVH is traversed one
    /// ray per lane).
    lanes: Result<LaneScene, String>,
    /// Every stage across lanes, or why not (each path is shaded by [`PathState::advance`], one
    /// lane at a time).
    stages: Result<LaneStages, String>,
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
    /// The engine for `scene` rendered with `opts`: hits across lanes where the scene has a lane
    /// form, else through the BVH one ray per lane; every stage across lanes where its effects
    /// allow.
    pub fn new(scene: &Scene, opts: &RenderOptions) -> Wavefront {
        let lanes = LaneScene::new(scene, Isa::detect());
        let stages = match &lanes {
            Ok(l) => l.tables().and_then(|()| {
                let spectral = opts.spectral.resolve(&scene.effects);
                LaneStages::new(scene, l.clone(), opts.sampler, spectral)
            }),
            Err(why) => Err(why.clone()),
        };
        Wavefront { lanes, stages, occupancy: Default::default() }
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
        match (&self.lanes, &self.stages) {
            (Ok(l), Ok(_)) => format!("every stage across 16 lanes, {}", l.isa().name()),
            (Ok(l), Err(why)) => format!(
                "hits and shadow rays across 16 lanes ({}, {}), shading one path at a time: {why}",
                l.isa().name(),
                l.method()
            ),
            (Err(_), _) => "the BVH one ray per lane, shading one path at a time".to_string(),
        }
    }

    /// The radiance of every camera ray of `rays`, each with its sample's context (its random
    /// stream, channels and counters), as [`super::Path`]'s `radiance` gives it one at a time:
    /// hits and shadow rays across lanes, shading path by path.
    pub fn radiance(
        &self,
        scene: &Scene,
        params: &RenderParams,
        rays: &[Ray],
        ctxs: &mut [PathContext],
        occupancy: &mut StageOccupancy,
    ) -> Vec<Vec3> {
        if let Ok(stages) = &self.stages {
            return stages.radiance(params, rays, ctxs, occupancy);
        }
        let mut paths: Vec<PathState> = rays.iter().map(|&r| PathState::new(r)).collect();
        self.trace(scene, params, &mut paths, ctxs, occupancy);
        paths.iter().map(|p| p.l).collect()
    }

    /// Advance every path of `paths` (with its context in `ctxs`) to its end.
    fn trace(
        &self,
        scene: &Scene,
        params: &RenderParams,
        paths: &mut [PathState],
        ctxs: &mut [PathContext],
        occupancy: &mut StageOccupancy,
    ) {
        let n = paths.len();
        let mut live: Vec<u32> = (0..n as u32).collect();
        let mut next: Vec<u32> = Vec::with_capacity(n);
        let mut hits: Vec<Option<Intersection>> = Vec::with_capacity(n);
        let mut pending: Vec<(u32, Pending)> = Vec::with_capacity(n);
        let world = OneRay { scene };
        while !live.is_empty() {
            self.closest_hits(scene, paths, &live, &mut hits, &mut occupancy.closest);
            pending.clear();
            next.clear();
            for (&i, isect) in live.iter().zip(&hits) {
                let (path, ctx) = (&mut paths[i as usize], &mut ctxs[i as usize]);
                let step = path.advance(&world, params, isect, ctx);
                match step.light {
                    light if light.pending && light.shadow.is_some() => pending.push((i, light)),
                    light if light.pending => path.resolve(&light, true),
                    _ => {}
                }
                if step.goes_on {
                    next.push(i);
                }
            }
            self.shadow_rays(scene, paths, &pending, &mut occupancy.shadow);
            std::mem::swap(&mut live, &mut next);
        }
    }

    /// Stage 1: the closest hit of every live path's ray, into `hits` (in the order of `live`).
    fn closest_hits(
        &self,
        scene: &Scene,
        paths: &[PathState],
        live: &[u32],
        hits: &mut Vec<Option<Intersection>>,
        occupancy: &mut Occupancy,
    ) {
        hits.clear();
        let Ok(lanes) = &self.lanes else {
            hits.extend(live.iter().map(|&i| scene.intersect(&paths[i as usize].ray(), f32::INFINITY)));
            return;
        };
        for batch in live.chunks(WIDTH) {
            let (rays, tmax) = gather(batch.iter().map(|&i| (paths[i as usize].ray(), f32::INFINITY)));
            let found = lanes.closest(&rays, &tmax);
            occupancy.add(batch.len());
            hits.extend(batch.iter().enumerate().map(|(k, &i)| {
                let t = found.t[k];
                let ray = paths[i as usize].ray();
                t.is_finite().then(|| scene.record(&ray, t, found.primitive[k], found.bary[k]))
            }));
        }
    }

    /// Stage 3: the pending shadow rays; each path's light counts where nothing blocks it.
    fn shadow_rays(
        &self,
        scene: &Scene,
        paths: &mut [PathState],
        pending: &[(u32, Pending)],
        occupancy: &mut Occupancy,
    ) {
        let shadow = |light: &Pending| light.shadow.expect("only pending lights with a shadow ray");
        let Ok(lanes) = &self.lanes else {
            for (i, light) in pending {
                paths[*i as usize].resolve(light, !shadow(light).blocked(scene));
            }
            return;
        };
        for batch in pending.chunks(WIDTH) {
            let queries: [Option<ShadowRay>; WIDTH] =
                std::array::from_fn(|k| batch.get(k).map(|(_, l)| shadow(l)));
            let (rays, tmax) = gather(queries.iter().flatten().map(|q| (q.ray, q.tmax)));
            let light = queries.map(|q| q.and_then(|q| q.light()).unwrap_or(u32::MAX));
            let reach = queries.map(|q| q.map_or(0.0, |q| q.reach(scene)));
            let blocked = lanes.occluded(&rays, &tmax, &light, &reach);
            occupancy.add(batch.len());
            for (k, (i, light)) in batch.iter().enumerate() {
                paths[*i as usize].resolve(light, !blocked[k]);
            }
        }
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
        rays: &[Ray],
        ctxs: &mut [PathContext],
    ) -> Vec<Vec3> {
        let mut occupancy = StageOccupancy::default();
        let radiance = self.radiance(scene, params, rays, ctxs, &mut occupancy);
        self.tally(&occupancy);
        radiance
    }
}

/// Up to [`WIDTH`] rays with their limits as lanes; missing lanes are idle (limit −1).
fn gather(batch: impl Iterator<Item = (Ray, f32)>) -> (RayLanes, Lanes) {
    let mut rays = RayLanes::default();
    let mut tmax = [-1.0; WIDTH];
    for (k, (ray, limit)) in batch.take(WIDTH).enumerate() {
        for axis in 0..3 {
            rays.origin[axis][k] = ray.origin[axis];
            rays.dir[axis][k] = ray.dir[axis];
        }
        tmax[k] = limit;
    }
    (rays, tmax)
}

/// Which engine `path` runs on `scene` under `opts.params.engine`, and why.
pub(super) fn choose(scene: &Scene, opts: &RenderOptions) -> EngineChoice {
    if opts.params.engine == EngineOption::Scalar {
        return EngineChoice::scalar("--engine scalar: one ray at a time, the reference implementation");
    }
    let engine = Wavefront::new(scene, opts);
    match (opts.params.engine, &engine.lanes, &engine.stages) {
        // Hits through the BVH across lanes but shading path by path: measured slower than the
        // scalar engine (docs/architecture.md, "Meshes across lanes").
        (EngineOption::Auto, Ok(l), Err(why)) if l.traverses_bvh() => EngineChoice::scalar(format!(
            "{} primitives: the wavefront engine would traverse the BVH across lanes but shade one path at \
             a time ({why}), measured at 0.85–0.98× the scalar engine's speed",
            scene.primitives.len()
        )),
        (_, Ok(l), _) => {
            let why = format!("{} primitives, {}", scene.primitives.len(), l.method());
            EngineChoice::wavefront(engine, why)
        }
        (EngineOption::Wavefront, Err(_), _) => {
            EngineChoice::wavefront(engine, "--engine wavefront asks for it whatever the scene")
        }
        (_, Err(why), _) => EngineChoice::scalar(format!(
            "{why}; the wavefront engine would traverse the BVH one ray per lane, no faster than one ray at a time"
        )),
    }
}
