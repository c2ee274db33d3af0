//! The contract between the render drivers and the rendering methods: what a method
//! ([`Integrator`]) tells the drivers, and the one way it estimates its image
//! ([`Progression`]). The drivers in this module depend on it alone; the methods
//! (`integrators/`) implement it, and may use the drivers' pieces ([`Film`],
//! [`render_accumulated`], [`camera_for`]). `render` never imports `integrators`
//! (`tests/module_layers.rs`).

use super::*;
use crate::geometry::Ray;
use crate::lanes::{Lanes, RayLanes};
use crate::methods::{Method, MethodInfo};
use crate::params::RenderParams;
use crate::sampler::Sampler;
use crate::scene::effects::Support;
use crate::scene::{Effect, RenderSettings, Scene};
use crate::spectrum::Channels;
use glam::Vec3;
use std::sync::Arc;

/// A rendering method.
pub trait Integrator: Send + Sync {
    /// Which method of the table ([`crate::methods::METHODS`]) this is: its name, description
    /// and default depth.
    fn method(&self) -> Method;
    /// What the method does with an effect the scene calls for.
    fn support(&self, effect: Effect) -> Support;
    /// How the method estimates its image, and so how the image grows with the sample count.
    fn progression(&self) -> Progression<'_>;
    /// The bytes the method allocates for a render of `scene` with `opts` beyond the film and
    /// the outputs ([`crate::memory::MemoryEstimate`]); none by default.
    fn working_memory(&self, _scene: &Scene, _opts: &RenderOptions) -> u64 {
        0
    }
    /// Its row of the table of methods.
    fn info(&self) -> &'static MethodInfo {
        self.method().info()
    }
    /// Registry name (`raycast`, `whitted`, …), from the table.
    fn name(&self) -> &'static str {
        self.info().name
    }
    /// One line for `vitrum integrators`, from the table.
    fn description(&self) -> &'static str {
        self.info().description
    }
    /// The maximum depth when neither the scene nor the command line sets one, from the table.
    fn default_max_depth(&self) -> u32 {
        self.info().default_max_depth
    }
}

/// How a method estimates its image: the one hook the drivers call, whose variants also say how
/// the image grows with the sample count (progressive rendering, checkpoints, render parts).
#[derive(Clone, Copy)]
pub enum Progression<'a> {
    /// Radiance per camera ray: the shared camera pass ([`camera_pass`]) draws the camera
    /// samples and adds their estimates, sample index by sample index.
    Camera(&'a dyn CameraEstimator),
    /// Whole-image sample indices (light paths, iterations) that the method adds to a film
    /// itself ([`render_accumulated`]).
    Accumulated(&'a dyn Accumulate),
    /// One image whatever the sample count (a fixed sample pattern): every render is that image.
    Fixed(&'a dyn FixedImage),
}

impl std::fmt::Debug for Progression<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Progression::Camera(_) => write!(f, "Camera"),
            Progression::Accumulated(_) => write!(f, "Accumulated"),
            Progression::Fixed(image) => write!(f, "Fixed({:?})", image.why()),
        }
    }
}

/// The phrase of the one-ray engine for methods without another.
const ONE_RAY: &str = "one ray at a time: only `path` has a wavefront engine";

/// A method that estimates the radiance arriving along each camera ray.
pub trait CameraEstimator: Sync {
    /// Radiance arriving at the camera along `ray`, with the sample's context `ctx`, in the
    /// context's channels: its RGB estimate is [`PathContext::rgb`] of it (in spectral mode a
    /// method may leave part of it in the context, in RGB: [`PathContext::seen_rgb`]).
    fn radiance(&self, scene: &Scene, params: &RenderParams, ray: &Ray, ctx: &mut PathContext) -> Vec3;
    /// Which engine traces `scene` under `opts` ([`RenderParams::engine`]), and why; the
    /// default is one ray at a time.
    fn engine(&self, _scene: &Scene, _opts: &RenderOptions) -> EngineChoice {
        EngineChoice::scalar(ONE_RAY)
    }
}

/// A method with its own image loop that still builds its image sample index by sample index
/// (light tracing, the bidirectional methods), so that it can render progressively and estimate
/// its variance.
pub trait Accumulate: Sync {
    /// An empty film for rendering `scene` with `opts`.
    fn film(&self, scene: &Scene, opts: &RenderOptions) -> Film;
    /// Add the sample indices `samples` (from [`Film::next_sample`] on) to `film`, each sample index
    /// adding one term to every pixel's sum and sum of squares; the caller then advances
    /// `film.samples` and its time. `progress` gets (work done, work total) of this call.
    fn add_samples(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        samples: Range<u32>,
        film: &mut Film,
        progress: &(dyn Fn(u64, u64) + Sync),
    );
}

/// A method that renders one fixed image whatever the sample count.
pub trait FixedImage: Sync {
    /// Why its image does not grow with the sample count.
    fn why(&self) -> &'static str;
    /// Render the image of `scene` with `opts` (whose sample budget it ignores); `progress` gets
    /// (work done, work total).
    fn render(
        &self,
        scene: &Scene,
        opts: &RenderOptions,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> RenderOutput;
}

/// What every method is asked through its [`Progression`].
impl dyn Integrator + '_ {
    /// The camera estimator of a method that estimates radiance per camera ray.
    pub fn camera(&self) -> Option<&dyn CameraEstimator> {
        match self.progression() {
            Progression::Camera(camera) => Some(camera),
            _ => None,
        }
    }

    /// Radiance arriving at the camera along `ray` ([`CameraEstimator::radiance`]).
    ///
    /// # Panics
    /// For a method that does not estimate per camera ray ([`Integrator::progression`] is not
    /// [`Progression::Camera`]): a mistake of the caller, not of any input.
    pub fn radiance(&self, scene: &Scene, params: &RenderParams, ray: &Ray, ctx: &mut PathContext) -> Vec3 {
        let Some(camera) = self.camera() else {
            panic!("`{}` estimates whole images, not the radiance of a camera ray", self.name())
        };
        camera.radiance(scene, params, ray, ctx)
    }

    /// Which engine traces `scene` under `opts`, and why: the camera estimator's choice, one ray
    /// at a time for the other methods.
    pub fn engine(&self, scene: &Scene, opts: &RenderOptions) -> EngineChoice {
        match self.camera() {
            Some(camera) => camera.engine(scene, opts),
            None => EngineChoice::scalar(ONE_RAY),
        }
    }
}

/// The state of one camera sample while its path is traced.
///
/// Its fields are laid out in this order (`repr(C)`) so that the branches a spectral path
/// sets aside come last: a context is made for every camera sample without writing them, and
/// an RGB render, which never reads them, pays nothing for them.
#[derive(Clone, Debug)]
#[repr(C)]
pub struct PathContext {
    /// The sample's random stream.
    pub sampler: Sampler,
    /// Rays traced so far, by kind.
    pub rays: RayCounts,
    /// What the channels of the sample's radiance hold: RGB, or its wavelengths.
    pub channels: Channels,
    /// Whether the path has ended its secondary wavelengths (at a dispersive interface), or
    /// carries one wavelength alone (a branch of a split there, or the lead that goes on).
    pub hero_only: bool,
    /// Whether the methods that split keep the hero alone at dispersive glass: at smooth
    /// refraction instead of splitting the wavelengths, and (`path`) at rough glass instead of
    /// MIS over them (the estimator before both, kept to compare against; and `mmlt`'s, whose
    /// sample is one path).
    pub(crate) hero_alone: bool,
    /// In spectral mode, what the camera ray itself sees (an emitter, the background), in RGB:
    /// added to the RGB estimate of the channels ([`PathContext::rgb`]).
    pub seen_rgb: Vec3,
    /// The branches of a `path` split at dispersive glass that wait for the one in
    /// flight to end (one wavelength each). Last: see above.
    pub(crate) pending: super::PendingBranches,
}

impl PathContext {
    /// A context for the given stream, in RGB mode.
    pub fn new(sampler: Sampler) -> PathContext {
        PathContext {
            sampler,
            rays: RayCounts::default(),
            channels: Channels::Rgb,
            hero_only: false,
            pending: Default::default(),
            hero_alone: false,
            seen_rgb: Vec3::ZERO,
        }
    }

    /// The RGB estimate of a sample whose channels hold `radiance`: its channels in RGB, plus
    /// what the camera ray saw in RGB ([`seen_rgb`](Self::seen_rgb)).
    #[inline]
    pub fn rgb(&self, radiance: Vec3) -> Vec3 {
        match &self.channels {
            // Nothing is set aside in RGB mode.
            Channels::Rgb => radiance,
            Channels::Spectral(w) => w.to_rgb(radiance) + self.seen_rgb,
        }
    }
}

/// [`WIDTH`](crate::lanes::WIDTH) camera rays in structure-of-arrays form, as the camera pass
/// makes them ([`crate::lanes::camera_rays`]): their origins and directions per axis, and their
/// times.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraRays {
    /// Origins and unit directions.
    pub rays: RayLanes,
    /// Shutter times.
    pub time: Lanes,
}

impl CameraRays {
    /// Lane `k`'s ray.
    #[inline]
    pub fn ray(&self, k: usize) -> Ray {
        let (o, d) = (&self.rays.origin, &self.rays.dir);
        Ray {
            origin: Vec3::new(o[0][k], o[1][k], o[2][k]),
            dir: Vec3::new(d[0][k], d[1][k], d[2][k]),
            time: self.time[k],
        }
    }
}

/// An engine that traces many camera samples together (the wavefront engine of `path`), with
/// the same bits as the method's [`CameraEstimator::radiance`] one sample at a time. Its
/// statistics are its own: the drivers and the [`Film`] know nothing of them.
pub trait BatchEngine: Send + Sync + std::fmt::Debug {
    /// How it traces, in one phrase.
    fn describe(&self) -> String;
    /// The radiance of every camera sample of `ctxs` (its context), as
    /// [`CameraEstimator::radiance`] gives it one at a time; sample `i`'s camera ray is lane
    /// `i % WIDTH` of `rays[i / WIDTH]`.
    fn estimate_rays(
        &self,
        scene: &Scene,
        params: &RenderParams,
        rays: &[CameraRays],
        ctxs: &mut [PathContext],
    ) -> Vec<Vec3>;
}

/// Which engine runs a method on a scene, and why (for `vitrum info` and the render summary).
#[derive(Clone, Debug)]
pub struct EngineChoice {
    /// The engine that traces camera samples in batches, when it runs; `None`: one ray at a time.
    pub wavefront: Option<Arc<dyn BatchEngine>>,
    /// Why this engine runs.
    pub reason: String,
}

impl EngineChoice {
    /// The one-ray engine, for `reason`.
    pub fn scalar(reason: impl Into<String>) -> EngineChoice {
        EngineChoice { wavefront: None, reason: reason.into() }
    }

    /// The batch engine `engine`, for `reason`.
    pub fn wavefront(engine: impl BatchEngine + 'static, reason: impl Into<String>) -> EngineChoice {
        EngineChoice::shared(Arc::new(engine), reason)
    }

    /// The batch engine `engine`, which the caller may also hold (to read its statistics after
    /// a render), for `reason`.
    pub fn shared(engine: Arc<dyn BatchEngine>, reason: impl Into<String>) -> EngineChoice {
        EngineChoice { wavefront: Some(engine), reason: reason.into() }
    }

    /// `wavefront` or `scalar`.
    pub fn name(&self) -> &'static str {
        if self.wavefront.is_some() {
            "wavefront"
        } else {
            "scalar"
        }
    }

    /// The engine, how it finds hits and why it runs, in one phrase.
    pub fn describe(&self) -> String {
        match &self.wavefront {
            Some(w) => format!("wavefront ({}): {}", w.describe(), self.reason),
            None => format!("scalar: {}", self.reason),
        }
    }
}

/// How a scene's settings meet a method: its depth and its parameters.
impl RenderSettings {
    /// The maximum depth of a render by `integrator`: `cli` (the command line's `--max-depth`),
    /// else the scene's `[render.METHOD] max_depth`, else the method's own default.
    pub fn max_depth(&self, integrator: &dyn Integrator, cli: Option<u32>) -> u32 {
        self.max_depth_of(integrator.method(), cli)
    }

    /// The parameters of a render by `integrator` with the scene's settings, the depth as
    /// [`RenderSettings::max_depth`] gives it.
    pub fn params(&self, integrator: &dyn Integrator, cli_depth: Option<u32>) -> RenderParams {
        self.params_of(integrator.method(), cli_depth)
    }
}
