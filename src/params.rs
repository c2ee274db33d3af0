//! The parameters every method reads, after the scene's settings and the command line's
//! overrides: the depth, the Fresnel override, and the settings of `ssaa` and of the
//! bidirectional engine. They live apart from the integrators so that the scene, which fills
//! them, does not depend on the integrators.

/// Per-render parameters an integrator reads (scene settings after command-line overrides).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderParams {
    /// Maximum recursion depth.
    pub max_depth: u32,
    /// Constant dielectric reflectance instead of exact Fresnel.
    pub reflectance: Option<f32>,
    /// Settings of `ssaa`.
    pub ssaa: SsaaParams,
    /// Settings of the methods that merge photons (`ppm`, `bpm`, `vcm`).
    pub merging: MergeParams,
    /// Settings of the Metropolis methods (`pssmlt`).
    pub metropolis: MetropolisParams,
    /// Manifold next-event estimation (`mnee`): on with these settings, off (`None`) for every
    /// other method.
    pub manifold: Option<ManifoldParams>,
    /// Which engine traces a method that has more than one (`path`: wavefront or scalar;
    /// `Scalar` also makes `light` and the bidirectional methods trace one ray at a time).
    pub engine: EngineOption,
}

/// The engine asked for (`--engine`): a method with a wavefront engine (`path`) runs it where it
/// supports every effect of the scene, and its one-ray engine (the reference) elsewhere.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EngineOption {
    /// The wavefront engine where it supports the scene, else the scalar one.
    #[default]
    Auto,
    /// The wavefront engine; a scene it does not support is an error.
    Wavefront,
    /// One ray at a time: the reference implementation.
    Scalar,
}

impl EngineOption {
    /// Every option with its command-line name.
    pub const NAMES: [(&'static str, EngineOption); 3] = [
        ("auto", EngineOption::Auto),
        ("wavefront", EngineOption::Wavefront),
        ("scalar", EngineOption::Scalar),
    ];

    /// The option called `name`.
    pub fn from_name(name: &str) -> Option<EngineOption> {
        EngineOption::NAMES.iter().find(|(n, _)| *n == name).map(|&(_, e)| e)
    }
}

impl RenderParams {
    /// Parameters with the given depth and the defaults otherwise (exact Fresnel, default ssaa
    /// and merging).
    pub fn with_depth(max_depth: u32) -> RenderParams {
        RenderParams {
            max_depth,
            reflectance: None,
            ssaa: SsaaParams::default(),
            merging: MergeParams::default(),
            metropolis: MetropolisParams::default(),
            manifold: None,
            engine: EngineOption::Auto,
        }
    }
}

/// Settings of the supersampling integrator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SsaaParams {
    /// Adaptive subdivision (true) or a regular grid (false).
    pub adaptive: bool,
    /// Samples per side of the regular grid.
    pub grid: u32,
    /// Maximum subdivision level (level L spaces samples 3^-L pixels apart).
    pub levels: u32,
    /// Contrast above which a square is split.
    pub threshold: f32,
}

impl Default for SsaaParams {
    fn default() -> Self {
        SsaaParams { adaptive: true, grid: 4, levels: 1, threshold: 0.1 }
    }
}

/// A strategy of the engine, for rendering one alone (`--strategy`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// A camera path reaching an emitter (or escaping to the background).
    EmitterHit,
    /// Next-event estimation at a camera vertex.
    NextEvent,
    /// A camera vertex connected to a light vertex.
    Connection,
    /// A light vertex connected to the camera (light tracing's strategy).
    CameraSplat,
    /// A camera vertex merged with the photons around it.
    Merge,
}

impl Strategy {
    /// Every strategy with its command-line name.
    pub const NAMES: [(&'static str, Strategy); 5] = [
        ("emitter", Strategy::EmitterHit),
        ("nee", Strategy::NextEvent),
        ("connect", Strategy::Connection),
        ("splat", Strategy::CameraSplat),
        ("merge", Strategy::Merge),
    ];

    /// The strategy called `name`.
    pub fn from_name(name: &str) -> Option<Strategy> {
        Strategy::NAMES.iter().find(|(n, _)| *n == name).map(|&(_, s)| s)
    }

    /// The command-line name.
    pub fn name(self) -> &'static str {
        Strategy::NAMES.iter().find(|(_, s)| *s == self).map(|&(n, _)| n).expect("every strategy is named")
    }
}

/// The most light sub-paths an iteration of the bidirectional engine traces by default (2²⁰, the
/// pixels of a 1024² image): beyond that, camera paths share light paths
/// ([`MergeParams::max_light_paths`]).
pub const DEFAULT_MAX_LIGHT_PATHS: u32 = 1 << 20;

/// Settings of the merging methods, and of the engine's research view of one strategy alone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MergeParams {
    /// Initial merge radius (scene units); `None`: the default rule of
    /// [`crate::integrators::initial_radius`] (0.0015 of the diameter of the scene's bounding
    /// sphere up to 256² pixels, shrinking with the pixel footprint above).
    pub radius: Option<f32>,
    /// Knaus–Zwicker α in (0, 1]: the radius shrinks as `(s + 1)^{(α − 1)/2}`.
    pub alpha: f32,
    /// Render only this strategy, unweighted (weight 1): its own estimate of the paths it can
    /// make (for `CameraSplat`, light tracing). `None`: every strategy of the method, weighted.
    pub only: Option<Strategy>,
    /// The most light sub-paths an iteration traces (at least 1): an iteration traces
    /// `N = min(pixels, max_light_paths)` and camera path `j` connects to light path `j mod N`
    /// ([`DEFAULT_MAX_LIGHT_PATHS`] by default, which bounds the memory of the
    /// stored light paths whatever the resolution).
    pub max_light_paths: u32,
}

impl Default for MergeParams {
    fn default() -> MergeParams {
        MergeParams { radius: None, alpha: 0.75, only: None, max_light_paths: DEFAULT_MAX_LIGHT_PATHS }
    }
}

/// Settings of primary-sample-space Metropolis light transport (`pssmlt`), per sample index: one
/// sample index is one Metropolis run of as many mutations as the image has pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MetropolisParams {
    /// Probability in (0, 1] that a proposal is a large step (every primary sample fresh):
    /// pbrt-v4's default 0.3. Large steps keep the chains ergodic and find new paths; small
    /// steps explore around a found one.
    pub large_step: f32,
    /// Standard deviation of a small step's normal offset of each primary sample (> 0, at most
    /// 1): pbrt-v4's default 0.01.
    pub sigma: f32,
    /// Bootstrap samples per sample index (at least 1): their mean contribution is the
    /// normalisation, and the chains start from them.
    pub bootstrap: u32,
    /// Markov chains per sample index (at least 1), each of `pixels / chains` mutations.
    pub chains: u32,
}

impl MetropolisParams {
    /// The default probability of a large step.
    pub const DEFAULT_LARGE_STEP: f32 = 0.3;
    /// The default deviation of a small step.
    pub const DEFAULT_SIGMA: f32 = 0.01;
    /// The default number of bootstrap samples per sample index: 4096 evaluations cost 2.6% of
    /// a 400² run (160,000 mutations) and estimate the normalisation of a scene whose
    /// importance varies by a factor of 10 (relative deviation) to within about 16% per run;
    /// the replicas average that error with the rest.
    pub const DEFAULT_BOOTSTRAP: u32 = 4096;
    /// The default number of chains per sample index: 64 keeps 64 threads busy on one run, and
    /// leaves chains of 2,500 mutations at 400², long enough for small steps to explore.
    pub const DEFAULT_CHAINS: u32 = 64;
}

impl Default for MetropolisParams {
    fn default() -> MetropolisParams {
        MetropolisParams {
            large_step: MetropolisParams::DEFAULT_LARGE_STEP,
            sigma: MetropolisParams::DEFAULT_SIGMA,
            bootstrap: MetropolisParams::DEFAULT_BOOTSTRAP,
            chains: MetropolisParams::DEFAULT_CHAINS,
        }
    }
}

/// How manifold next-event estimation seeds its chains ([`crate::manifold`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Seeding {
    /// Manifold next-event estimation (Hanika et al. 2015), the default: the straight line to
    /// the light, refractions only, one solve: cheap and noiseless, biased where several chains
    /// exist or a chain reflects.
    #[default]
    Straight,
    /// Specular manifold sampling (Zeltner et al. 2020): random seeds, and the reciprocal of
    /// the chance to find a chain estimated by Bernoulli trials: unbiased in principle up to
    /// `max_trials`, but measured biased low in one test (see [`crate::manifold`]).
    Sms,
}

impl Seeding {
    /// Every seeding with its name in scene files and variants.
    pub const NAMES: [(&'static str, Seeding); 2] = [("straight", Seeding::Straight), ("sms", Seeding::Sms)];

    /// The seeding called `name`.
    pub fn from_name(name: &str) -> Option<Seeding> {
        Seeding::NAMES.iter().find(|(n, _)| *n == name).map(|&(_, s)| s)
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        Seeding::NAMES.iter().find(|(_, s)| *s == self).map_or("straight", |(n, _)| n)
    }
}

/// Settings of manifold next-event estimation (`mnee`, `[render.mnee]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ManifoldParams {
    /// How chains are seeded.
    pub seeding: Seeding,
    /// The most smooth dielectric interfaces a chain crosses or reflects at (1 to 16).
    pub max_chain: u32,
    /// The most seeds (the first included) an SMS estimate of `1/p` draws; a count that reaches
    /// it is cut there (at least 1; 1 makes SMS the biased estimate of one found chain).
    pub max_trials: u32,
}

impl ManifoldParams {
    /// The default longest chain: a glass of water seen from the side (glass, water, glass,
    /// air and back) with room to spare.
    pub const DEFAULT_MAX_CHAIN: u32 = 8;
    /// The default cap on SMS's trials.
    pub const DEFAULT_MAX_TRIALS: u32 = 256;
}

impl Default for ManifoldParams {
    fn default() -> ManifoldParams {
        ManifoldParams {
            seeding: Seeding::default(),
            max_chain: ManifoldParams::DEFAULT_MAX_CHAIN,
            max_trials: ManifoldParams::DEFAULT_MAX_TRIALS,
        }
    }
}
