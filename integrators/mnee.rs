//! Path tracing with manifold next-event estimation (`mnee`): [`Path`]'s estimator with one
//! more strategy at every non-delta vertex, a light reached through a chain of smooth glass
//! interfaces solved by Newton's method ([`crate::manifold`]): the caustics of point and small
//! lights through glass that `path` misses or finds only by rare BSDF samples. The strategy is
//! written once in [`PathState::advance`](crate::render::PathState) for both of `path`'s
//! engines and switched on by the render's [`ManifoldParams`](crate::params::ManifoldParams)
//! (`[render.mnee]`): chains found by it and those BSDF sampling finds of the same class
//! partition the paths. Everything else is `path`'s.

use super::Path;
use super::{CameraEstimator, EngineChoice, Integrator, Method, PathContext, Progression, RenderParams};
use crate::geometry::Ray;
use crate::render::RenderOptions;
use crate::scene::effects::Support;
use crate::scene::{Effect, Scene};
use glam::Vec3;

/// Path tracing with manifold next-event estimation through glass.
pub struct Mnee;

impl Integrator for Mnee {
    fn method(&self) -> Method {
        Method::Mnee
    }

    fn support(&self, effect: Effect) -> Support {
        Path.support(effect)
    }

    fn progression(&self) -> Progression<'_> {
        Progression::Camera(self)
    }
}

impl CameraEstimator for Mnee {
    fn radiance(
        &self,
        scene: &Scene,
        params: &RenderParams,
        camera_ray: &Ray,
        ctx: &mut PathContext,
    ) -> Vec3 {
        debug_assert!(params.manifold.is_some(), "mnee renders with its manifold settings");
        Path.radiance(scene, params, camera_ray, ctx)
    }

    fn engine(&self, scene: &Scene, opts: &RenderOptions) -> EngineChoice {
        Path.engine(scene, opts)
    }
}
