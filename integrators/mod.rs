//! The rendering methods, one per file, behind one trait, and the registry of their names.

mod distributed;
mod light;
mod path;
mod raycast;
mod ssaa;
mod whitted;

pub use distributed::Distributed;
pub use light::LightTracer;
pub use path::{Path, DEFAULT_PATH_DEPTH};
pub use raycast::RayCast;
pub use ssaa::{Ssaa, SsaaParams};
pub use whitted::Whitted;

use crate::geometry::Ray;
use crate::render::{Progression, RenderOptions, RenderOutput};
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
    /// Settings of `ssaa`.
    pub ssaa: SsaaParams,
}

impl RenderParams {
    /// Parameters with the given depth and the defaults otherwise (exact Fresnel, default ssaa).
    pub fn with_depth(max_depth: u32) -> RenderParams {
        RenderParams { max_depth, reflectance: None, ssaa: SsaaParams::default() }
    }
}

/// The state of one camera sample while its path is traced.
#[derive(Clone, Debug)]
pub struct PathContext {
    /// The sample's random stream.
    pub sampler: Sampler,
    /// Rays traced so far, by kind.
    pub rays: RayCounts,
    /// The sample's wavelength in nm when rendering spectrally.
    pub lambda: Option<f32>,
}

impl PathContext {
    /// A context for the given stream, in RGB mode.
    pub fn new(sampler: Sampler) -> PathContext {
        PathContext { sampler, rays: RayCounts::default(), lambda: None }
    }
}

/// A rendering method.
pub trait Integrator: Send + Sync {
    /// Registry name (`raycast`, `whitted`, …).
    fn name(&self) -> &'static str;
    /// One line for `vitrum integrators`.
    fn description(&self) -> &'static str;
    /// What the method does with an effect the scene calls for.
    fn support(&self, effect: Effect) -> Support;
    /// The maximum depth when neither the scene nor the command line sets one.
    fn default_max_depth(&self) -> u32 {
        5
    }
    /// Radiance arriving at the camera along `ray`.
    fn radiance(&self, scene: &Scene, params: &RenderParams, ray: &Ray, ctx: &mut PathContext) -> Vec3;
    /// Methods with their own image loop (adaptive supersampling, light tracing) render here;
    /// `None` means the shared camera pass estimates every pixel with [`Integrator::radiance`].
    fn render_image(
        &self,
        _scene: &Scene,
        _opts: &RenderOptions,
        _progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Option<RenderOutput> {
        None
    }
    /// How the method's image grows with the sample count (progressive rendering, per-pixel
    /// variance); the default is the shared camera pass.
    fn progression(&self) -> Progression<'_> {
        Progression::CameraPass
    }
}

/// Every integrator, in the order `vitrum integrators` lists them.
pub fn all() -> Vec<Box<dyn Integrator>> {
    vec![
        Box::new(RayCast),
        Box::new(Whitted),
        Box::new(Ssaa),
        Box::new(Distributed),
        Box::new(Path),
        Box::new(LightTracer),
    ]
}

/// The integrator registered under `name`.
pub fn create(name: &str) -> Option<Box<dyn Integrator>> {
    all().into_iter().find(|i| i.name() == name)
}

/// The registered names.
pub fn names() -> Vec<&'static str> {
    all().iter().map(|i| i.name()).collect()
}
