//! `vitrum render`: the options, the render itself (plain, in parts, progressive with
//! checkpoints), its outputs and its summary line.

use crate::commands::parts;
use crate::commands::support::{
    check_effects, check_output_path, integrator_named, load_scene, parse_resolution, thread_pool, CliError,
};
use crate::integrators::{self, Integrator, RenderParams};
use crate::interrupt;
use crate::output::exr::{stage_exr_with_notes, variance_channels, ExrMetadata};
use crate::output::png::stage_png;
use crate::output::replicas::render_channels;
use crate::output::Staged;
use crate::render::{self, Budget, RenderOptions, RenderOutput};
use crate::sampler::{Replicas, SamplerKind};
use crate::scene::compile::MAX_DEPTH;
use crate::scene::{Scene, SpectralMode};
use serde_json::json;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Options of `vitrum render`.
#[derive(clap::Args, Debug, Clone)]
pub struct RenderArgs {
    /// Scene file (TOML); the embedded default scene when omitted.
    pub scene: Option<PathBuf>,
    /// Integrator name (see `vitrum integrators`); default from the scene file.
    #[arg(short, long)]
    pub integrator: Option<String>,
    /// Samples per pixel.
    #[arg(long, conflicts_with = "time", allow_negative_numbers = true)]
    pub spp: Option<u32>,
    /// Render whole passes until this many seconds have passed.
    #[arg(long, allow_negative_numbers = true)]
    pub time: Option<f64>,
    /// Image size, e.g. 400x300.
    #[arg(long, value_parser = parse_resolution)]
    pub resolution: Option<(u32, u32)>,
    /// Seed of the random streams.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Worker threads (default: all cores).
    #[arg(long, allow_negative_numbers = true)]
    pub threads: Option<usize>,
    /// Maximum recursion depth.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=MAX_DEPTH as i64))]
    pub max_depth: Option<u32>,
    /// Constant dielectric reflectance instead of exact Fresnel (the thesis used 0.06).
    #[arg(long, allow_negative_numbers = true)]
    pub reflectance: Option<f32>,
    /// Output EXR file (default `render.exr`; with --resume, the file resumed).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Also write a tone-mapped sRGB PNG preview.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Exposure of the PNG preview in stops, a finite number (default from the scene file).
    #[arg(long, value_name = "EV", allow_hyphen_values = true, value_parser = super::diff::parse_exposure)]
    pub exposure: Option<f32>,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    /// No progress bar, no summary line (warnings still go to stderr).
    #[arg(long)]
    pub quiet: bool,
    /// Refuse to render when the integrator cannot simulate an effect the scene calls for.
    #[arg(long)]
    pub strict: bool,
    /// Trace wavelengths: auto (when the scene disperses and the method simulates it), on, off.
    #[arg(long, value_parser = ["auto", "on", "off"])]
    pub spectral: Option<String>,
    /// Sample distribution: sobol (Owen-scrambled, progressive), stratified or independent.
    #[arg(long, value_parser = ["sobol", "stratified", "independent"])]
    pub sampler: Option<String>,
    /// ppm, bpm, vcm: initial merge radius in scene units (default from the scene file, else
    /// 0.0015 of the diameter of the scene's bounding sphere, times sqrt(256²/pixels) over 256²
    /// pixels).
    #[arg(long, allow_negative_numbers = true)]
    pub radius: Option<f32>,
    /// ppm, bpm, vcm: Knaus–Zwicker α in (0, 1]: the radius of iteration i is
    /// radius·(i + 1)^((α − 1)/2) (default from the scene file, else 0.75).
    #[arg(long, allow_negative_numbers = true)]
    pub radius_alpha: Option<f32>,
    /// bpt, ppm, bpm, vcm: the most light sub-paths an iteration traces, at least 1 (default from
    /// the scene file, else 2²⁰): an iteration traces min(pixels, this) and camera paths share
    /// them above it, which bounds the memory of the stored light paths whatever the resolution.
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub max_light_paths: Option<String>,
    /// bpt, ppm, bpm, vcm: render one strategy alone, unweighted (emitter, nee, connect, splat,
    /// merge): its own estimate of the paths it can make (`splat` is light tracing's).
    #[arg(long, value_parser = ["emitter", "nee", "connect", "splat", "merge"])]
    pub strategy: Option<String>,
    /// ssaa: adaptive corner subdivision or a regular grid.
    #[arg(long, value_parser = ["adaptive", "grid"])]
    pub ssaa_mode: Option<String>,
    /// ssaa: samples per side of the regular grid.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub ssaa_grid: Option<u32>,
    /// ssaa: maximum subdivision level of the adaptive mode (each level splits 3×3).
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=6))]
    pub ssaa_levels: Option<u32>,
    /// ssaa: contrast threshold that triggers subdivision.
    #[arg(long)]
    pub ssaa_threshold: Option<f32>,
    /// Write the number of camera samples per pixel as a grey-scale PNG (white = the most).
    #[arg(long)]
    pub density_map: Option<PathBuf>,
    /// Also write the render so far to the output every this many seconds (0: after every
    /// sample pass), with the sums that `--resume` continues from. Render time (and a --time
    /// budget) counts the sample passes, not the writes.
    #[arg(long, allow_negative_numbers = true)]
    pub checkpoint: Option<f64>,
    /// Continue the render part in this EXR file (a checkpoint, an interrupted or a finished
    /// part) to its target samples or time budget, to a larger --spp, or for --time more
    /// seconds; its settings are the defaults, and the output defaults to it. The result equals
    /// an uninterrupted render bit for bit.
    #[arg(long, conflicts_with_all = ["samples", "shard"])]
    pub resume: Option<PathBuf>,
    /// Render only the sample indices A..B of the render (of --spp samples; default B), keeping
    /// the sums in the output for `vitrum merge`.
    #[arg(long, conflicts_with_all = ["shard", "time"], value_parser = crate::parts::parse_sample_range)]
    pub samples: Option<std::ops::Range<u32>>,
    /// Render shard I of N (0-based) of the --spp samples: the sample indices spp·I/N to
    /// spp·(I+1)/N, keeping the sums in the output for `vitrum merge`.
    #[arg(long, conflicts_with = "time", value_parser = crate::parts::Shard::parse)]
    pub shard: Option<crate::parts::Shard>,
    /// Engine of `path`: auto (the wavefront engine where it supports the scene, else one ray at
    /// a time), wavefront (always; scenes without a lane form traverse the BVH one ray per
    /// lane), scalar (one ray at a time: the reference implementation; for `light` and the
    /// bidirectional methods too, which otherwise trace rays 16 at a time where they can).
    #[arg(long, value_parser = ["auto", "wavefront", "scalar"])]
    pub engine: Option<String>,
    /// Require the variance channels: refuse a render that cannot have them (a fixed pattern,
    /// 1 sample per pixel). Every render with two or more replicas keeps them anyway, with the
    /// replicas' means: `variance.R`, `variance.G`, `variance.B` (the variance of each pixel's
    /// estimate), `samples`, and `replica.K.R/G/B`.
    #[arg(long, conflicts_with = "no_variance")]
    pub variance: bool,
    /// Leave the variance and replica channels out of the EXR (a file of R, G, B only, which
    /// `vitrum diff` can judge only without standard errors).
    #[arg(long)]
    pub no_variance: bool,
    /// Independent randomisations the samples are split into (1 to 64, default 8): sample index
    /// `s` belongs to replica `s mod R`; the spread of the replicas' means gives each pixel's
    /// variance and the standard errors of every metric. 1 renders one randomisation (no variance).
    #[arg(long, value_name = "R", value_parser = parse_replicas)]
    pub replicas: Option<Replicas>,
}

/// Parses a replica count, 1 to [`Replicas::MAX`].
pub fn parse_replicas(s: &str) -> Result<Replicas, String> {
    s.parse::<u32>()
        .ok()
        .and_then(Replicas::new)
        .ok_or_else(|| format!("{s:?}: the replica count must be a whole number from 1 to {}", Replicas::MAX))
}

/// Parses `--max-light-paths` for the method `method`: a whole number of at least 1, for the
/// bidirectional methods only.
fn parse_max_light_paths(text: &str, method: &str) -> Result<u32, CliError> {
    if !crate::scene::desc::BIDIRECTIONAL_METHODS.contains(&method) {
        return Err(CliError::BadInput(format!(
            "--max-light-paths {text}: `{method}` traces no light sub-paths per iteration (bpt, ppm, bpm and vcm do)"
        )));
    }
    match text.trim().parse::<u32>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(CliError::BadInput(format!(
            "--max-light-paths {text}: must be a whole number of light sub-paths per iteration, from 1 to {}",
            u32::MAX
        ))),
    }
}

/// Options of a render after applying command-line overrides to the scene's defaults.
pub fn render_options(
    scene: &Scene,
    integrator: &dyn Integrator,
    args: &RenderArgs,
) -> Result<RenderOptions, CliError> {
    let s = &scene.settings;
    let budget = match (args.spp, args.time) {
        (_, Some(t)) if !(t.is_finite() && t > 0.0) => {
            return Err(CliError::BadInput(format!("--time {t}: must be a positive number of seconds")))
        }
        (_, Some(t)) => Budget::Time(
            Duration::try_from_secs_f64(t)
                .map_err(|_| CliError::BadInput(format!("--time {t}: too long to represent")))?,
        ),
        (Some(0), _) => return Err(CliError::BadInput("--spp 0: at least one sample per pixel".into())),
        (Some(n), _) => Budget::Samples(n),
        (None, None) => Budget::Samples(s.spp),
    };
    let reflectance = match args.reflectance {
        Some(r) if !(0.0..=1.0).contains(&r) => {
            return Err(CliError::BadInput(format!("--reflectance {r}: must be in [0, 1]")))
        }
        Some(r) => Some(r),
        None => s.reflectance,
    };
    let mut ssaa = s.ssaa;
    if let Some(mode) = &args.ssaa_mode {
        ssaa.adaptive = mode == "adaptive";
    }
    ssaa.grid = args.ssaa_grid.unwrap_or(ssaa.grid);
    ssaa.levels = args.ssaa_levels.unwrap_or(ssaa.levels);
    if let Some(t) = args.ssaa_threshold {
        if !(t.is_finite() && t >= 0.0) {
            return Err(CliError::BadInput(format!("--ssaa-threshold {t}: must be 0 or greater")));
        }
        ssaa.threshold = t;
    }
    let mut params = RenderParams { reflectance, ssaa, ..s.params(integrator, args.max_depth) };
    if let Some(name) = &args.engine {
        params.engine = crate::params::EngineOption::from_name(name).expect("clap checks the name");
    }
    if let Some(r) = args.radius {
        if !(r.is_finite() && r > 0.0) {
            return Err(CliError::BadInput(format!(
                "--radius {r}: must be a positive distance in scene units"
            )));
        }
        params.merging.radius = Some(r);
    }
    if let Some(a) = args.radius_alpha {
        if !(a > 0.0 && a <= 1.0) {
            return Err(CliError::BadInput(format!("--radius-alpha {a}: must be in (0, 1]")));
        }
        params.merging.alpha = a;
    }
    if let Some(text) = &args.max_light_paths {
        params.merging.max_light_paths = parse_max_light_paths(text, integrator.name())?;
    }
    if let Some(name) = &args.strategy {
        let strategy = integrators::Strategy::from_name(name).expect("clap checks the name");
        let Some(algorithm) = integrators::Algorithm::from_name(integrator.name()) else {
            return Err(CliError::BadInput(format!(
                "--strategy {name}: `{}` has no strategies to choose from (bpt, ppm, bpm and vcm have)",
                integrator.name()
            )));
        };
        let allowed = algorithm.strategies();
        if !allowed.contains(&strategy) {
            let names: Vec<&str> = allowed.iter().map(|s| s.name()).collect();
            return Err(CliError::BadInput(format!(
                "--strategy {name}: `{}` uses only {}",
                integrator.name(),
                names.join(", ")
            )));
        }
        params.merging.only = Some(strategy);
    }
    let opts = RenderOptions {
        budget,
        resolution: args.resolution,
        seed: args.seed.unwrap_or(s.seed),
        params,
        spectral: args.spectral.as_deref().and_then(SpectralMode::from_name).unwrap_or(s.spectral),
        sampler: args.sampler.as_deref().and_then(SamplerKind::from_name).unwrap_or(s.sampler),
        planned_spp: None,
        replicas: args.replicas.unwrap_or_default(),
    };
    let wavefront_asked = opts.params.engine == crate::params::EngineOption::Wavefront;
    if wavefront_asked && integrator.engine(scene, &opts).wavefront.is_none() {
        return Err(CliError::BadInput(format!(
            "--engine wavefront: `{}` has no wavefront engine (only `path` has one)",
            integrator.name()
        )));
    }
    Ok(opts)
}

/// Runs `vitrum render`.
pub fn run(args: &RenderArgs) -> Result<(), CliError> {
    // A resumed part's settings are the defaults of every option.
    let resumed = args.resume.as_deref().map(parts::read_resumed).transpose()?;
    // Resuming a finished part into itself (a cluster job restarted after it finished) has
    // nothing to do, once its settings are checked.
    let finished =
        resumed.as_ref().is_some_and(|f| parts::finished(f) && args.spp.is_none() && args.time.is_none());
    let args = &match &resumed {
        Some(file) => parts::resume_defaults(args, file)?,
        None => args.clone(),
    };
    let output = args.output.clone().unwrap_or_else(|| PathBuf::from("render.exr"));
    let scene = load_scene(args.scene.as_deref())?;
    for w in &scene.warnings {
        eprintln!("vitrum: warning: {w}");
    }
    let (integrator, mut opts) = prepare(&scene, args, |_| {
        check_output_path(&output, "exr")?;
        for png in [&args.png, &args.density_map].into_iter().flatten() {
            check_output_path(png, "png")?;
        }
        Ok(())
    })?;
    // A render part (a shard, a resumed or checkpointed render) keeps its sums in the output.
    let mut part = parts::plan(args, &scene, integrator.as_ref(), &mut opts, resumed)?;
    if let (true, Some(p), Some(resumed)) = (finished, &part, &args.resume) {
        if same_file(resumed, &output) {
            let done = &p.info.samples;
            eprintln!(
                "vitrum: {} already holds all its samples {done}: nothing to render (give a larger --spp or --time to continue)",
                resumed.display()
            );
            return Ok(());
        }
    }
    let pool = worker_pool(&scene, integrator.as_ref(), &opts, args.threads)?;

    let bar = (!args.quiet && std::io::stderr().is_terminal()).then(|| {
        let bar = indicatif::ProgressBar::new(1);
        // indicatif's own {eta} follows a short moving window of the rate: ours is exact for a
        // time budget and the steady rate since the start for a sample budget (see `eta`).
        let budget = opts.budget;
        let eta_key = move |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
            let left = eta(budget, state.pos(), state.len().unwrap_or(0), state.elapsed());
            let _ = w.write_str(&left.map_or_else(|| "?".to_string(), format_eta));
        };
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} {msg} [{bar:40}] {percent:>3}%, ETA {eta_left}",
            )
            .expect("valid template")
            .with_key("eta_left", eta_key)
            .progress_chars("=> "),
        );
        bar.set_message(integrator.name());
        // Redraw between progress reports, so that a time budget's ETA counts down.
        bar.enable_steady_tick(Duration::from_millis(250));
        bar
    });
    let progress = |done: u64, total: u64| {
        if let Some(b) = &bar {
            b.set_length(total);
            b.set_position(done);
        }
    };
    // From here on the first Ctrl-C stops the render at its next pass boundary and the samples
    // done are written; a second one aborts without writing (before, Ctrl-C simply ends the
    // process: there is nothing to save).
    if let Err(e) = interrupt::install_handler() {
        eprintln!("vitrum: warning: cannot catch Ctrl-C ({e}): an interrupted render would be lost");
    }
    let out = match &mut part {
        Some(part) => {
            let meta = |film: &render::Film| {
                exr_metadata(&scene, integrator.name(), opts.seed, (film.samples, film.seconds, film.rays))
            };
            let mut checkpoints = parts::Checkpoints::new(&output, args.checkpoint, part, &meta);
            pool.install(|| {
                parts::render(&scene, integrator.as_ref(), &opts, part, &progress, &mut checkpoints)
            })
        }
        None => pool.install(|| render::render(&scene, integrator.as_ref(), &opts, &progress)),
    };
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let mut rendered = Rendered::new(&scene, integrator, opts, out, args);
    if let (Some(p), Some(_)) = (&part, &rendered.interrupted) {
        // A part: which of its sample indices are done (`vitrum render --resume` continues).
        rendered.interrupted = Some(format!(
            "SIGINT after the samples {} of {}..{}",
            p.info.samples, p.info.target.start, p.info.target.end
        ));
    }
    let out = &rendered.out;

    // Encode every output first and publish them together: a failure leaves none behind.
    let failure = |e: crate::output::OutputError| CliError::Failure(e.to_string());
    if args.variance && out.variance.is_none() {
        eprintln!(
            "vitrum: warning: --variance: no variance after {} sample(s) per pixel; none written",
            out.spp
        );
    }
    let exr = match &part {
        // A part keeps its replicas' sums in its film layer.
        Some(part) => {
            let extra = match (&out.variance, args.variance && !args.no_variance) {
                (Some(variance), true) => {
                    variance_channels(variance, &vec![out.spp as f32; variance.pixels.len()])
                }
                _ => Vec::new(),
            };
            let meta = rendered.metadata(&scene);
            crate::output::film::stage_part(&output, &part.film, &part.info, &meta, &extra, &rendered.notes())
        }
        None => rendered.stage_exr(&scene, &output),
    };
    let mut staged = vec![exr.map_err(failure)?];
    if let Some(png) = &args.png {
        staged.push(stage_png(png, &out.image, rendered.exposure).map_err(failure)?);
    }
    if let Some(path) = &args.density_map {
        staged.push(stage_density_map(path, out).map_err(failure)?);
    }
    for file in staged {
        file.commit().map_err(failure)?;
    }
    if out.non_finite_samples > 0 {
        eprintln!("vitrum: warning: {} sample(s) were NaN or infinite", out.non_finite_samples);
    }
    if let Some(what) = &rendered.interrupted {
        eprintln!("vitrum: warning: interrupted: {what}; written to {}", output.display());
    }
    report(args, &output, &scene, &rendered);
    Ok(())
}

/// The integrator and the options of a render of `scene` with `args` (the scene's defaults
/// with the arguments applied), checked as every render is before it starts: the caller's
/// `outputs` check (given the options; `vitrum render` checks its output paths there), then the
/// effects the method does not simulate (a warning on stderr, or refused with `--strict`) and
/// `--variance`.
pub fn prepare(
    scene: &Scene,
    args: &RenderArgs,
    outputs: impl FnOnce(&RenderOptions) -> Result<(), CliError>,
) -> Result<(Box<dyn Integrator>, RenderOptions), CliError> {
    let integrator = integrator_named(args.integrator.as_deref().unwrap_or(&scene.settings.integrator))?;
    let opts = render_options(scene, integrator.as_ref(), args)?;
    outputs(&opts)?;
    check_effects(scene, integrator.as_ref(), &opts, args.strict)?;
    if args.variance {
        if let render::Progression::Fixed(image) = integrator.progression() {
            return Err(CliError::BadInput(format!(
                "--variance: `{}` renders a fixed sample pattern ({}); it has no sample variance",
                integrator.name(),
                image.why()
            )));
        }
        if opts.budget == Budget::Samples(1) {
            return Err(CliError::BadInput("--variance needs at least 2 samples per pixel (--spp 2)".into()));
        }
        if opts.replicas.count() < 2 {
            return Err(CliError::BadInput("--variance needs at least 2 replicas (--replicas 2)".into()));
        }
    }
    Ok((integrator, opts))
}

/// The worker pool of a render of `threads` threads (all cores when `None`), once the render
/// is known to fit in the machine's memory (checked before anything of it is allocated).
pub fn worker_pool(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    threads: Option<usize>,
) -> Result<rayon::ThreadPool, CliError> {
    crate::memory::check(scene, integrator, opts).map_err(CliError::BadInput)?;
    thread_pool(threads)
}

/// Renders `scene` with `args` in memory, as `vitrum render` does without its outputs: the
/// entry point of a library user (the Python package). `progress` receives (work done, total).
/// A stop requested through [`crate::interrupt::request_stop`] ends the render at its next
/// pass boundary with the samples done ([`Rendered::interrupted`]). The options that make
/// a render part (`--resume`, `--samples`, `--shard`, `--checkpoint`) write files and are
/// refused here; the output options (`-o`, `--png`, `--density-map`, `--json`, `--quiet`) are
/// ignored: the caller writes the EXR with [`Rendered::stage_exr`].
pub fn render_in_memory(
    scene: &Scene,
    args: &RenderArgs,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Rendered, CliError> {
    let part_option = [
        (args.resume.is_some(), "--resume"),
        (args.samples.is_some(), "--samples"),
        (args.shard.is_some(), "--shard"),
        (args.checkpoint.is_some(), "--checkpoint"),
    ];
    if let Some((_, option)) = part_option.iter().find(|(given, _)| *given) {
        return Err(CliError::BadInput(format!(
            "{option}: a render part is written to a file as it renders; use `vitrum render` for it"
        )));
    }
    let (integrator, opts) = prepare(scene, args, |_| Ok(()))?;
    let pool = worker_pool(scene, integrator.as_ref(), &opts, args.threads)?;
    let out = pool.install(|| render::render(scene, integrator.as_ref(), &opts, progress));
    Ok(Rendered::new(scene, integrator, opts, out, args))
}

/// A finished (or interrupted) render and how it was made: what `vitrum render` writes
/// ([`Rendered::stage_exr`]) and prints ([`Rendered::summary`]).
pub struct Rendered {
    /// The method that rendered.
    pub integrator: Box<dyn Integrator>,
    /// The options it rendered with.
    pub options: RenderOptions,
    /// The image, its variance, its replicas and its statistics.
    pub out: RenderOutput,
    /// What a stop request interrupted (the `vitrum:interrupted` attribute), `None` when the
    /// render ran to its budget.
    pub interrupted: Option<String>,
    /// The exposure of the preview in stops (`--exposure`, else the scene's).
    pub exposure: f32,
    /// Whether the EXR leaves out the variance and replica channels (`--no-variance`).
    pub no_variance: bool,
}

impl Rendered {
    /// The render `out` of `scene` by `integrator` with `options` and the arguments `args`;
    /// interrupted when a stop has been requested ([`crate::interrupt::stop_requested`]).
    pub fn new(
        scene: &Scene,
        integrator: Box<dyn Integrator>,
        options: RenderOptions,
        out: RenderOutput,
        args: &RenderArgs,
    ) -> Rendered {
        let interrupted =
            interrupt::stop_requested().then(|| interruption(integrator.as_ref(), &options, &out));
        let exposure = args.exposure.unwrap_or(scene.settings.exposure);
        Rendered { integrator, options, out, interrupted, exposure, no_variance: args.no_variance }
    }

    /// The EXR header metadata of the render of `scene`.
    pub fn metadata(&self, scene: &Scene) -> ExrMetadata {
        let out = &self.out;
        exr_metadata(scene, self.integrator.name(), self.options.seed, (out.spp, out.seconds, out.rays))
    }

    /// The notes of the EXR header: what interrupted the render, and the preview's exposure.
    pub fn notes(&self) -> Vec<(String, String)> {
        let interrupted =
            self.interrupted.iter().map(|what| ("vitrum:interrupted".to_string(), what.clone()));
        interrupted
            .chain([(super::diff::EXPOSURE_ATTRIBUTE.to_string(), self.exposure.to_string())])
            .collect()
    }

    /// The EXR file of the render of `scene` (image, variance and replica channels unless
    /// `--no-variance`, metadata) encoded into a temporary file beside `path`, to be published
    /// with [`crate::output::Staged::commit`].
    pub fn stage_exr(
        &self,
        scene: &Scene,
        path: &Path,
    ) -> Result<crate::output::Staged, crate::output::OutputError> {
        let (extra, mut notes) = match self.no_variance {
            true => (Vec::new(), Vec::new()),
            false => render_channels(&self.out),
        };
        notes.extend(self.notes());
        stage_exr_with_notes(path, &self.out.image, &self.metadata(scene), &extra, &notes)
    }

    /// The summary `vitrum render --json` prints, of the render of `scene` written to
    /// `output` (and the preview `png`).
    pub fn summary(&self, scene: &Scene, output: Option<&Path>, png: Option<&Path>) -> serde_json::Value {
        let (out, opts, integrator) = (&self.out, &self.options, self.integrator.name());
        let engine = self.integrator.engine(scene, opts);
        let (depth, merging) = depth_and_merging(scene, integrator, opts);
        json!({
            "integrator": integrator,
            "scene": scene.origin.name,
            "scene_hash": scene.origin.hash,
            "width": out.image.width,
            "height": out.image.height,
            "spp": out.spp,
            "seed": opts.seed,
            // The depth the render used (`null` for `raycast`, which has none).
            "max_depth": depth,
            // The initial merge radius and its α (`null` for the methods that do not merge).
            "merging": merging.map(|(radius, alpha)| json!({"radius": radius, "alpha": alpha})),
            // The one strategy rendered alone (`--strategy`), or `null`.
            "strategy": opts.params.merging.only.map(|s| s.name()),
            // The engine that traced the paths (`wavefront` or `scalar`), how, and why.
            "engine": {"name": engine.name(), "description": engine.describe(), "reason": engine.reason},
            "seconds": out.seconds,
            "rays": {
                "primary": out.rays.primary,
                "reflected": out.rays.reflected,
                "refracted": out.rays.refracted,
                "shadow": out.rays.shadow,
                "total": out.rays.total(),
            },
            "mrays_per_second": mrays_per_second(out),
            "rays_per_pixel": out.rays.total() as f64 / (out.image.width * out.image.height).max(1) as f64,
            "non_finite_samples": out.non_finite_samples,
            "spectral": out.spectral,
            "samples_per_pixel": out.samples_per_pixel.as_ref().map(|c| {
                let n = c.len().max(1) as f32;
                json!({"mean": c.iter().sum::<f32>() / n, "min": c.iter().copied().fold(f32::INFINITY, f32::min),
                       "max": c.iter().copied().fold(0.0f32, f32::max)})
            }),
            "effects": scene.effects.names(),
            // The reference-free noise estimate (see `render`'s module documentation).
            "noise": out.noise().map(|n| json!({
                "std_error": n.std_error,
                "mse": n.mse,
                "non_finite_pixels": n.non_finite,
                "basis": noise_basis(opts, out),
            })),
            "output": output,
            "png": png,
            // Whether Ctrl-C stopped the render (`spp` is then the samples done), and the
            // sample count asked for.
            "interrupted": self.interrupted.is_some(),
            "requested_spp": match opts.budget {
                Budget::Samples(n) => Some(n),
                Budget::Time(_) => None,
            },
        })
    }
}

/// The depth a render by `integrator` used (`None` for a method without one) and its initial
/// merge radius and α (`None` for the methods that do not merge).
fn depth_and_merging(
    scene: &Scene,
    integrator: &str,
    opts: &RenderOptions,
) -> (Option<u32>, Option<(f32, f32)>) {
    let depth = crate::scene::desc::has_max_depth(integrator).then_some(opts.params.max_depth);
    let merging = crate::scene::desc::MERGING_METHODS.contains(&integrator).then(|| {
        (integrators::initial_radius(scene, &opts.params.merging, opts.resolution), opts.params.merging.alpha)
    });
    (depth, merging)
}

/// Millions of rays per second of a render.
fn mrays_per_second(out: &RenderOutput) -> f64 {
    out.rays.total() as f64 / out.seconds.max(1e-9) / 1e6
}

/// The time a render has left after `elapsed`, having done `done` of `total` work units: for a
/// time budget exactly the budget less the time elapsed; for a sample budget the time left at
/// the steady rate since the start, elapsed · (total − done) / done (`None` before any work).
/// The rate of a render is steady after its first pass (the same work per sample), so from
/// the first tenth on the estimate is close; a short moving window, as indicatif's own, follows
/// every stall of a pass and of the machine.
pub fn eta(budget: Budget, done: u64, total: u64, elapsed: Duration) -> Option<Duration> {
    match budget {
        Budget::Time(limit) => Some(limit.saturating_sub(elapsed)),
        Budget::Samples(_) if done == 0 || total == 0 => None,
        Budget::Samples(_) => {
            let left = total.saturating_sub(done) as f64 / done as f64;
            Duration::try_from_secs_f64(elapsed.as_secs_f64() * left).ok()
        }
    }
}

/// A time left as `1h 02m 03s`, `2m 05s` or `12s`.
pub fn format_eta(left: Duration) -> String {
    let s = left.as_secs_f64().ceil() as u64;
    match (s / 3600, s / 60 % 60, s % 60) {
        (0, 0, sec) => format!("{sec}s"),
        (0, min, sec) => format!("{min}m {sec:02}s"),
        (h, min, sec) => format!("{h}h {min:02}m {sec:02}s"),
    }
}

/// Whether `a` and `b` name the same file (or the same path, when they do not exist).
fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

/// The EXR header metadata of a render of `scene` by `integrator` with `seed` that took
/// (samples per pixel, seconds, rays).
fn exr_metadata(
    scene: &Scene,
    integrator: &str,
    seed: u64,
    (spp, seconds, rays): (u32, f64, crate::stats::RayCounts),
) -> ExrMetadata {
    ExrMetadata {
        version: crate::VERSION.to_string(),
        integrator: integrator.to_string(),
        spp,
        seed,
        render_time_seconds: seconds,
        rays,
        scene: format!("{} ({})", scene.origin.name, scene.origin.hash),
        effects: scene.effects.names(),
    }
}

/// What an interrupted render did, for the warning and the `vitrum:interrupted` attribute.
fn interruption(integrator: &dyn Integrator, opts: &RenderOptions, out: &RenderOutput) -> String {
    if let render::Progression::Fixed(_) = integrator.progression() {
        return format!("SIGINT; `{}` renders one fixed pattern and finished it", integrator.name());
    }
    match opts.budget {
        Budget::Samples(n) => format!("SIGINT after {} of {n} samples per pixel", out.spp),
        Budget::Time(t) => {
            format!(
                "SIGINT after {} samples per pixel, {:.3} s of a {} s budget",
                out.spp,
                out.seconds,
                t.as_secs_f64()
            )
        }
    }
}

/// The camera samples per pixel as grey levels, white for the most-sampled pixel.
fn stage_density_map(path: &Path, out: &RenderOutput) -> Result<Staged, crate::output::OutputError> {
    let (w, h) = (out.image.width, out.image.height);
    let counts = out.samples_per_pixel.clone().unwrap_or_else(|| vec![out.spp as f32; w * h]);
    let max = counts.iter().copied().fold(0.0f32, f32::max).max(1e-9);
    let levels: Vec<f32> = counts.iter().map(|&c| c / max).collect();
    crate::output::png::stage_grey_png(path, w, h, &levels)
}

/// Print the one-line summary (or the JSON object).
fn report(args: &RenderArgs, output: &Path, scene: &Scene, rendered: &Rendered) {
    let (out, opts, integrator) = (&rendered.out, &rendered.options, rendered.integrator.name());
    if args.json {
        println!("{}", rendered.summary(scene, Some(output), args.png.as_deref()));
    } else if !args.quiet {
        let engine = rendered.integrator.engine(scene, opts);
        let (depth, merging) = depth_and_merging(scene, integrator, opts);
        eprintln!(
            "{integrator}: {}x{} at {} spp{}{}{}{} in {:.3} s, {} rays ({:.1} per pixel: primary {}, reflected {}, refracted {}, shadow {}), {:.2} Mrays/s, {} -> {}\n  engine: {}",
            out.image.width,
            out.image.height,
            out.spp,
            depth.map_or(String::new(), |d| format!(", max depth {d}")),
            merging.map_or(String::new(), |(r, a)| format!(", radius {r:.3e} (alpha {a})")),
            opts.params.merging.only.map_or(String::new(), |s| format!(", strategy {} alone (unweighted)", s.name())),
            if out.spectral { " (spectral)" } else { "" },
            out.seconds,
            out.rays.total(),
            out.rays.total() as f64 / (out.image.width * out.image.height).max(1) as f64,
            out.rays.primary,
            out.rays.reflected,
            out.rays.refracted,
            out.rays.shadow,
            mrays_per_second(out),
            match out.noise() {
                Some(n) => format!("std error {:.3e}", n.std_error),
                None => "std error n/a".to_string(),
            },
            output.display(),
            engine.describe()
        );
    }
}

/// What the noise estimate of a render rests on, for the JSON summary.
fn noise_basis(opts: &RenderOptions, out: &RenderOutput) -> String {
    match &out.replicas {
        Some(r) => format!(
            "spread of {} independent replicas' means ({} samples per pixel, {} sampler): the variance of the \
             estimator used, stratification included",
            r.count(),
            out.spp,
            opts.sampler.name()
        ),
        None => "no estimate: fewer than two replicas hold samples".to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_time_budget_has_exactly_its_rest_left() {
        let budget = Budget::Time(Duration::from_secs(60));
        for (elapsed, left) in [(0.0, 60.0), (12.5, 47.5), (59.9, 0.1), (61.0, 0.0)] {
            let eta = eta(budget, 1, 2, Duration::from_secs_f64(elapsed)).unwrap();
            assert!((eta.as_secs_f64() - left).abs() < 1e-9, "{elapsed}: {eta:?}");
        }
    }

    #[test]
    fn a_sample_budget_is_within_a_fifth_after_its_first_tenth() {
        // A render of 1000 passes whose times vary by ±40% around 10 ms (a pseudo-random
        // sequence), with a slow first pass (warm-up, 5×): after 10% of the work the
        // steady-rate estimate is within 20% of the time really left.
        let times: Vec<f64> = (0..1000u64)
            .map(|i| {
                let u = (i.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 11) as f64 / (1u64 << 53) as f64;
                let t = 0.010 * (0.6 + 0.8 * u);
                if i == 0 {
                    5.0 * t
                } else {
                    t
                }
            })
            .collect();
        let total_time: f64 = times.iter().sum();
        let mut elapsed = 0.0;
        let mut worst = 0.0f64;
        for (i, t) in times.iter().enumerate() {
            elapsed += t;
            let done = i as u64 + 1;
            if done < 100 || done == 1000 {
                continue;
            }
            let estimate = eta(Budget::Samples(1000), done, 1000, Duration::from_secs_f64(elapsed)).unwrap();
            let truth = total_time - elapsed;
            worst = worst.max((estimate.as_secs_f64() - truth).abs() / truth);
        }
        assert!(worst < 0.2, "worst relative error {worst}");
        assert_eq!(eta(Budget::Samples(8), 0, 8000, Duration::from_secs(1)), None, "no rate yet");
        assert_eq!(eta(Budget::Samples(8), 8000, 8000, Duration::from_secs(3)), Some(Duration::ZERO));
        // A steady rate is estimated exactly.
        let steady = eta(Budget::Samples(8), 2000, 8000, Duration::from_secs(5)).unwrap();
        assert!((steady.as_secs_f64() - 15.0).abs() < 1e-9);
    }

    #[test]
    fn times_left_read_as_hours_minutes_and_seconds() {
        assert_eq!(format_eta(Duration::from_secs_f64(11.2)), "12s");
        assert_eq!(format_eta(Duration::from_secs(125)), "2m 05s");
        assert_eq!(format_eta(Duration::from_secs(3723)), "1h 02m 03s");
        assert_eq!(format_eta(Duration::ZERO), "0s");
    }
}
