//! The rendering methods, one per file, behind one trait, and the registry of their names.

mod raycast;
mod whitted;

pub use raycast::RayCast;
pub use whitted::Whitted;

use crate::geometry::Ray;
use crate::sampler::Sampler;
use crate::scene::effects::Support;
use crate::scene::{Effect, Scene};
use crate::stats::RayCounts;
use glam::Vec3;

/// Per-render parameters an integrator reads (scene settings after command-line overrides).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderParams {
    /// Maximum recursion depth.
    pub max_depth: u32,
    /// Constant dielectric reflectance instead of exact Fresnel.
    pub reflectance: Option<f32>,
}

/// A rendering method that estimates the radiance arriving along camera rays.
pub trait Integrator: Send + Sync {
    /// Registry name (`raycast`, `whitted`, …).
    fn name(&self) -> &'static str;
    /// One line for `vitrum integrators`.
    fn description(&self) -> &'static str;
    /// What the method does with an effect the scene calls for.
    fn support(&self, effect: Effect) -> Support;
    /// Radiance arriving at the camera along `ray`.
    fn radiance(
        &self,
        scene: &Scene,
        params: &RenderParams,
        ray: &Ray,
        sampler: &mut Sampler,
        rays: &mut RayCounts,
    ) -> Vec3;
}

/// Every integrator, in the order `vitrum integrators` lists them.
pub fn all() -> Vec<Box<dyn Integrator>> {
    vec![Box::new(RayCast), Box::new(Whitted)]
}

/// The integrator registered under `name`.
pub fn create(name: &str) -> Option<Box<dyn Integrator>> {
    all().into_iter().find(|i| i.name() == name)
}

/// The registered names.
pub fn names() -> Vec<&'static str> {
    all().iter().map(|i| i.name()).collect()
}
