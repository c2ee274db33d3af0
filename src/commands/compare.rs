//! `vitrum compare`: equal-time (or equal-sample) renders of several methods, as a figure and a table.
//!
//! Every method renders the scene with the same budget, one after the other on the same worker
//! pool: `--time T` gives each whole 1-sample passes until T seconds have passed (at least one
//! pass), `--spp N` gives each N samples per pixel (`ssaa`, deterministic and adaptive, renders
//! once whatever the budget and reports its mean samples per pixel). Each render is measured
//! against a reference, either an EXR file (`--reference`) or a cached high-sample render
//! (`--reference-spp`, cached in `--cache`) by the method right for the scene (`vcm` where a point
//! light meets a specular surface, else `path`; [`crate::reference::choose_method`]) or by
//! `--reference-method`. The output folder receives `METHOD.exr` for every
//! method, `compare.png` (the figure, laid out as [`crate::figure::compose`] documents),
//! `compare.csv` and `compare.md` (the table). Every input is checked before the first render, and
//! the files are published together once all of them are encoded.

use crate::commands::diff::{read_judged, Judged};
use crate::commands::support::{load_scene, CliError};
use crate::commands::variants::{parse_methods, MethodSpec};
use crate::commands::{parse_crop, CropArg, SweepArgs};
use crate::figure::canvas::Canvas;
use crate::figure::compose::{self, format_number, format_seconds, format_spp, Panel};
use crate::metrics::{self, Crop, Efficiency, Metrics, MetricsError, Region, Run, RunSpread, Split};
use crate::output::exr::{stage_exr_with_notes, ExrMetadata};
use crate::output::replicas::render_channels;
use crate::output::{stage, OutputError, Staged};
use crate::render::{self, Budget, Progression, RenderOutput};
use crate::report::{Layer, Report, Section, TableRow};
use crate::scene::Scene;
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::fmt::Write as _;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The attribute of a variant's render that keeps its label (`vcm[radius=0.002]`).
pub const VARIANT_ATTRIBUTE: &str = "vitrum:variant";

/// The copy of the reference in the output folder, so that the folder holds everything its
/// numbers were measured from (`vitrum diff METHOD.exr reference.exr` reproduces them).
pub const REFERENCE_FILE: &str = "reference.exr";

/// Seconds per method when neither `--time` nor `--spp` is given.
pub const DEFAULT_SECONDS: f64 = 10.0;
/// Samples per pixel of the cached reference (by the method [`crate::reference::choose_method`]
/// picks, or `--reference-method`) when no `--reference` file is given.
pub const DEFAULT_REFERENCE_SPP: u32 = 1024;

/// Options of `vitrum compare`.
#[derive(clap::Args, Debug, Clone)]
pub struct CompareArgs {
    /// Scene file (TOML); the embedded default scene when omitted.
    pub scene: Option<PathBuf>,
    /// Integrators, comma-separated, or `all`.
    #[arg(short, long, value_name = "LIST", default_value = "all")]
    pub integrators: String,
    /// Equal time: each method renders whole passes until this many seconds have passed (default 10).
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds, conflicts_with = "spp", allow_negative_numbers = true)]
    pub time: Option<f64>,
    /// Equal samples: each method takes this many samples per pixel.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..), allow_negative_numbers = true)]
    pub spp: Option<u32>,
    /// Reference image (EXR) of the same size as the renders.
    #[arg(long, value_name = "REF.exr", conflicts_with_all = ["reference_spp", "cache"])]
    pub reference: Option<PathBuf>,
    /// Samples per pixel of the reference rendered (or read from the cache) when no
    /// `--reference` is given (default 1024).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..), allow_negative_numbers = true)]
    pub reference_spp: Option<u32>,
    /// The method that renders the reference when no `--reference` is given (default: the
    /// most efficient of path, bpt and vcm fit for the scene, measured by short pilot renders).
    #[arg(long, value_name = "NAME", conflicts_with = "reference")]
    pub reference_method: Option<String>,
    /// Folder of cached references (default `.vitrum-cache`).
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
    /// Zoomed insets of this rectangle, X,Y,W,H in pixels from the top-left.
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_crop)]
    pub crop: Option<CropArg>,
    /// Also measure every method over this named rectangle (NAME=X,Y,W,H, e.g. the caustic;
    /// repeatable): `compare-regions.csv` and a table in `compare.md`, beside the whole image.
    #[arg(long = "region", value_name = "NAME=X,Y,W,H", value_parser = super::parse_region)]
    pub regions: Vec<super::RegionArg>,
    /// Also measure every method over the white pixels of this PNG, of the renders' size
    /// ([NAME=]FILE.png, named by its stem unless named; repeatable), beside the whole image and
    /// the `--region`s.
    #[arg(long = "mask", value_name = "[NAME=]FILE.png", value_parser = super::parse_mask)]
    pub masks: Vec<super::MaskArg>,
    /// At most N panels per row of `compare.png` (the reference's included), for many methods;
    /// default: all in one row.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..), allow_negative_numbers = true)]
    pub columns: Option<u32>,
    /// Exposure of the figure in stops, the same for every render (default from the scene file).
    #[arg(long, value_name = "EV", value_parser = super::diff::parse_exposure, allow_hyphen_values = true)]
    pub exposure: Option<f32>,
    /// Render options shared by every integrator.
    #[command(flatten)]
    pub render: SweepArgs,
    /// Output folder (created if missing; its parent must exist).
    #[arg(long, value_name = "DIR", default_value = "compare")]
    pub out: PathBuf,
    /// No progress bars and no summary (warnings still go to stderr).
    #[arg(long)]
    pub quiet: bool,
    /// Lay out these renders instead of rendering (EXR files of the scene, one per method, e.g.
    /// merged shards from a cluster); their size is the first file's unless --resolution is given.
    #[arg(long, num_args = 1.., value_name = "EXR", conflicts_with_all = ["time", "spp"])]
    pub renders: Vec<PathBuf>,
    /// Render every method K times, run k with seed + k, for confidence intervals of relMSE,
    /// seconds and efficiency over the runs (`compare-runs.csv` has every run; the images and
    /// the other metrics are the first run's).
    #[arg(long, value_name = "K", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=MAX_REPEAT as i64), conflicts_with = "renders")]
    pub repeat: u32,
}

/// The most runs `--repeat` accepts.
pub const MAX_REPEAT: u32 = 100;

/// Parses a positive, finite number of seconds.
pub(crate) fn parse_seconds(s: &str) -> Result<f64, String> {
    let t: f64 = s.trim().parse().map_err(|_| format!("`{s}` is not a number of seconds"))?;
    if !(t.is_finite() && t > 0.0) || Duration::try_from_secs_f64(t).is_err() {
        return Err(format!("`{s}`: must be a positive, finite number of seconds"));
    }
    Ok(t)
}

/// Where the reference comes from.
enum ReferenceSource {
    /// Read from a file: the image with its variance and replicas (when it keeps them) and a
    /// description for the title and the table.
    File(Reference, String),
    /// A render by the sweep, cached.
    Cached(super::CachedReference),
}

/// Everything `compare` will do, checked before the first render.
pub(crate) struct Plan {
    scene: Scene,
    scene_name: String,
    /// The methods and variants, in the order of `-i` ([`super::variants`]).
    methods: Vec<MethodSpec>,
    budget: Budget,
    size: (usize, usize),
    crop: Option<Crop>,
    /// Named rectangles measured beside the whole image.
    regions: Vec<(String, Region)>,
    exposure: f32,
    reference: ReferenceSource,
    out: PathBuf,
    /// The renders laid out instead of rendering (`--renders`), in the order of `methods`.
    renders: Option<Vec<super::RenderFile>>,
    /// Runs per method (`--repeat`).
    repeat: u32,
    /// The most panels per row of the figure (`--columns`).
    columns: Option<u32>,
}

/// One method's render and its errors.
struct Row {
    /// The method's label (its name, or the variant as written).
    method: String,
    /// The file name of its render, without `.exr`.
    stem: String,
    /// The integrator's own name.
    integrator: &'static str,
    /// Whether the method renders one fixed pattern (`ssaa`): its samples per pixel are then its
    /// real camera rays per pixel.
    fixed: bool,
    out: RenderOutput,
    metrics: Metrics,
    /// The bias/variance split; `None` when the render's variance is unknown.
    split: Option<Split>,
    /// The metrics and split over each of the plan's regions, in their order.
    regions: Vec<(Metrics, Option<Split>)>,
    seed: u64,
    /// Every run of `--repeat` (the first is this row's render), and their spread when there are
    /// two or more.
    runs: Vec<Run>,
    spread: Option<RunSpread>,
}

impl Row {
    /// The row of `method`'s render `out`, measured against `reference`.
    fn new(
        spec: &MethodSpec,
        out: RenderOutput,
        seed: u64,
        reference: &Reference,
        (exposure, regions): (f32, &[(String, Region)]),
    ) -> Result<Row, MetricsError> {
        let method = spec.integrator.as_ref();
        let fixed = matches!(method.progression(), Progression::Fixed(_));
        let measure = |region: Option<&Region>| -> Result<(Metrics, Option<Split>), MetricsError> {
            let metrics = metrics::compare_over(&out.image, &reference.image, region, exposure)?;
            Ok((metrics, metrics::render_split(fixed, &out, reference.estimate(), region)?))
        };
        let (metrics, split) = measure(None)?;
        let regions = regions.iter().map(|(_, r)| measure(Some(r))).collect::<Result<_, _>>()?;
        let (label, stem, integrator) = (spec.label.clone(), spec.file_stem(), method.name());
        let mut row = Row {
            method: label,
            stem,
            integrator,
            fixed,
            out,
            metrics,
            split,
            regions,
            seed,
            runs: Vec::new(),
            spread: None,
        };
        row.runs.push(Run { seed, spp: row.spp(), seconds: row.out.seconds, rel_mse: row.metrics.rel_mse });
        Ok(row)
    }

    /// Adds a further run of `--repeat`: its render `out` under `seed`, measured against
    /// `reference`.
    fn add_run(&mut self, out: &RenderOutput, seed: u64, reference: &Reference) -> Result<(), MetricsError> {
        let rel_mse = metrics::compare(&out.image, &reference.image, None, 0.0)?.rel_mse;
        let spp = spp_of(self.fixed, out);
        self.runs.push(Run { seed, spp, seconds: out.seconds, rel_mse });
        self.spread = RunSpread::of(&self.runs);
        Ok(())
    }

    /// The relMSE the tables show with its 95% interval: the mean over the runs with their
    /// interval under `--repeat`, else the render's own with the interval from its replicas.
    fn rel_mse(&self) -> (f64, Option<(f64, f64)>) {
        match (&self.spread, &self.split) {
            (Some(s), _) => (s.rel_mse.mean, Some((s.rel_mse.low, s.rel_mse.high))),
            (None, Some(split)) => (self.metrics.rel_mse, Some(split.rel_mse_interval())),
            (None, None) => (self.metrics.rel_mse, None),
        }
    }

    /// The seconds the tables show: the mean over the runs with their interval under
    /// `--repeat`, else the render's own.
    fn seconds(&self) -> (f64, Option<(f64, f64)>) {
        match &self.spread {
            Some(s) => (s.seconds.mean, Some((s.seconds.low, s.seconds.high))),
            None => (self.out.seconds, None),
        }
    }

    /// Samples per pixel: for a fixed-pattern (adaptive) method its camera rays per pixel, the
    /// real mean, else the whole samples every pixel got.
    fn spp(&self) -> f64 {
        spp_of(self.fixed, &self.out)
    }

    /// 1/(relMSE·seconds) with its interval where no bias is detected, else why not
    /// ([`metrics::efficiency`]); under `--repeat` of the runs' mean relMSE and seconds, with the
    /// interval over the runs ([`RunSpread`]), the verdict still the first run's.
    fn efficiency(&self) -> Result<Efficiency, &'static str> {
        let own = metrics::efficiency(self.split.as_ref(), self.out.seconds)?;
        Ok(match &self.spread {
            Some(s) => {
                Efficiency { value: s.efficiency.mean, low: s.efficiency.low, high: s.efficiency.high }
            }
            None => own,
        })
    }

    /// The split's verdict ([`metrics::Verdict`]), or "unknown" (no replicas to split the error
    /// with).
    fn status(&self) -> &'static str {
        self.split.as_ref().map_or("unknown", |s| s.verdict().name())
    }
}

/// Samples per pixel of the render `out`: for a fixed-pattern (adaptive) method its camera rays
/// per pixel, the real mean, else the whole samples every pixel got.
fn spp_of(fixed: bool, out: &RenderOutput) -> f64 {
    if fixed {
        let pixels = (out.image.width * out.image.height).max(1) as f64;
        out.rays.primary as f64 / pixels
    } else {
        f64::from(out.spp)
    }
}

/// The reference every method is measured against.
type Reference = super::SweepReference;

impl Plan {
    /// Checks every input; any problem is bad input (exit 2) and nothing has been rendered.
    pub(crate) fn new(args: &CompareArgs) -> Result<Plan, CliError> {
        let bad = |m: String| CliError::BadInput(m);
        let methods = parse_methods(&args.integrators)?;
        let budget = match (args.spp, args.time) {
            (Some(n), _) => Budget::Samples(n),
            (None, t) => Budget::Time(Duration::from_secs_f64(t.unwrap_or(DEFAULT_SECONDS))),
        };
        let scene = load_scene(args.scene.as_deref())?;
        let scene_name = match &args.scene {
            Some(p) => p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into()),
            None => "cornell-glass (embedded default)".into(),
        };
        let camera = render::camera_for(&scene, args.render.resolution);
        let mut size = (camera.crop.width as usize, camera.crop.height as usize);
        let renders = if args.renders.is_empty() {
            None
        } else {
            let (renders, read_size) =
                super::read_renders(&args.renders, &scene, args.render.resolution.map(|_| size))?;
            size = read_size;
            for (i, r) in renders.iter().enumerate() {
                if let Some(other) = renders[..i].iter().find(|o| o.method.name() == r.method.name()) {
                    return Err(bad(format!(
                        "--renders: {} and {} are both `{}` renders; give one per method",
                        other.path.display(),
                        r.path.display(),
                        r.method.name()
                    )));
                }
            }
            Some(renders)
        };
        let methods = match &renders {
            Some(renders) => renders
                .iter()
                .map(|r| MethodSpec::plain(crate::integrators::create(r.method.name()).expect("known")))
                .collect(),
            None => methods,
        };
        let crop = args.crop.map(|c| Crop { x: c.x, y: c.y, width: c.width, height: c.height });
        let regions = super::plan_regions(&args.regions, &args.masks, size)?;
        if let Some(c) = crop {
            if c.x + c.width > size.0 || c.y + c.height > size.1 {
                return Err(bad(format!(
                    "--crop {},{},{},{} does not fit inside the {}x{} image",
                    c.x, c.y, c.width, c.height, size.0, size.1
                )));
            }
        }
        let reference = match &args.reference {
            Some(path) => {
                let Judged { image, attributes, variance, replicas } =
                    read_judged(path).map_err(|e| bad(format!("--reference: {e}")))?;
                if (image.width, image.height) != size {
                    return Err(bad(format!(
                        "--reference {}: the reference is {}x{} but the renders are {}x{} \
                         (give --resolution {}x{} or another reference)",
                        path.display(),
                        image.width,
                        image.height,
                        size.0,
                        size.1,
                        image.width,
                        image.height
                    )));
                }
                if let Some(scene_text) = attributes.get("vitrum:scene") {
                    if !scene_text.contains(&scene.origin.hash) {
                        eprintln!(
                            "vitrum: warning: --reference {} was rendered from another scene ({scene_text})",
                            path.display()
                        );
                    }
                }
                let name = path
                    .file_name()
                    .map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into());
                let describe = match (attributes.get("vitrum:integrator"), attributes.get("vitrum:spp")) {
                    (Some(i), Some(spp)) => format!("{i}, {spp} spp ({name})"),
                    _ => name,
                };
                ReferenceSource::File(Reference { image, variance, replicas }, describe)
            }
            None => ReferenceSource::Cached(super::CachedReference::plan(
                &scene,
                args.reference_method.as_deref(),
                args.reference_spp.unwrap_or(DEFAULT_REFERENCE_SPP),
                args.cache.clone(),
            )?),
        };
        check_out_folder(&args.out)?;
        if let Some(reference) = &args.reference {
            let target = |name: &str| args.out.join(format!("{name}.exr"));
            let stems: Vec<String> = methods.iter().map(MethodSpec::file_stem).collect();
            let mut names = stems.iter().map(String::as_str).chain(["reference"]);
            if let Some(name) = names.find(|name| same_file(reference, &target(name))) {
                return Err(bad(format!(
                    "--reference {}: `{name}` would write its render over the reference; choose another --out",
                    reference.display()
                )));
            }
        }
        let exposure = args.exposure.unwrap_or(scene.settings.exposure);
        Ok(Plan {
            scene,
            scene_name,
            methods,
            budget,
            size,
            crop,
            regions,
            exposure,
            reference,
            out: args.out.clone(),
            renders,
            repeat: args.repeat,
            columns: args.columns,
        })
    }

    /// "equal time, 10 s per method" or "equal samples, 64 spp".
    fn budget_text(&self) -> String {
        if self.renders.is_some() {
            return "precomputed renders".to_string();
        }
        match self.budget {
            Budget::Samples(n) => format!("equal samples: {n} spp per method"),
            Budget::Time(t) => {
                let t = t.as_secs_f64();
                let t = if t.fract() == 0.0 { format!("{t:.0}") } else { format_number(t) };
                format!("equal time: {t} s per method")
            }
        }
    }
}

/// The output folder must be a folder, or be creatable in an existing one.
pub(crate) fn check_out_folder(out: &Path) -> Result<(), CliError> {
    if out.exists() {
        if !out.is_dir() {
            return Err(CliError::BadInput(format!("--out {}: is a file, not a folder", out.display())));
        }
        return Ok(());
    }
    let parent = out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if !parent.is_dir() {
        return Err(CliError::BadInput(format!(
            "--out {}: the folder {} does not exist",
            out.display(),
            parent.display()
        )));
    }
    Ok(())
}

/// Whether `a` and `b` name the same existing file.
fn same_file(a: &Path, b: &Path) -> bool {
    matches!((a.canonicalize(), b.canonicalize()), (Ok(a), Ok(b)) if a == b)
}

/// Progress bars on stderr, drawn only when it is a terminal: renders done, and the current render.
pub(crate) struct Bars {
    multi: MultiProgress,
    overall: ProgressBar,
}

impl Bars {
    /// Bars for `steps` renders in all, the overall bar labelled `label`.
    pub(crate) fn new(label: &str, steps: u64, quiet: bool) -> Bars {
        let target = if !quiet && std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        };
        let multi = MultiProgress::with_draw_target(target);
        let overall = multi.add(ProgressBar::new(steps));
        overall.set_style(
            ProgressStyle::with_template(&format!(
                "{label:<11} [{{bar:40}}] {{pos}}/{{len}} renders, {{elapsed}} elapsed"
            ))
            .expect("valid template")
            .progress_chars("=> "),
        );
        Bars { multi, overall }
    }

    /// A bar for one render: rows of the pass for a sample budget, seconds for a time budget.
    fn render(&self, name: &str, budget: Budget) -> ProgressBar {
        let bar = self.multi.add(ProgressBar::new(1));
        let template = match budget {
            Budget::Samples(_) => "{msg:11} [{bar:40}] {pos}/{len}, ETA {eta}",
            Budget::Time(_) => "{msg:11} [{bar:40}] {percent}% of the time",
        };
        bar.set_style(ProgressStyle::with_template(template).expect("valid template").progress_chars("=> "));
        bar.set_message(name.to_string());
        bar
    }

    /// Prints `line` above the bars.
    pub(crate) fn println(&self, line: &str) {
        self.multi.suspend(|| eprintln!("{line}"));
    }

    /// Runs `f` (which prints) with the bars hidden.
    pub(crate) fn suspend(&self, f: impl FnOnce()) {
        self.multi.suspend(f);
    }

    /// Clears the bars at the end of the run.
    pub(crate) fn finish(&self) {
        self.overall.finish_and_clear();
    }
}

/// What one scene's comparison produced: the reference and one row per method.
pub(crate) struct Outcome {
    reference: Reference,
    /// The reference's EXR file (copied into the output folder as `reference.exr`).
    reference_file: PathBuf,
    /// "path, 1024 spp (.vitrum-cache/….exr)": where the reference came from.
    reference_text: String,
    rows: Vec<Row>,
}

impl Plan {
    /// The renders this plan makes: one per method, and the reference unless it is a file.
    pub(crate) fn renders(&self) -> u64 {
        let cached = matches!(self.reference, ReferenceSource::Cached(..));
        self.methods.len() as u64 * u64::from(self.repeat) + u64::from(cached)
    }

    /// The warnings of the scene, printed before rendering.
    pub(crate) fn warnings(&self) -> &[String] {
        &self.scene.warnings
    }
}

/// Runs `vitrum compare`.
pub fn run(args: &CompareArgs) -> Result<(), CliError> {
    let plan = Plan::new(args)?;
    for w in plan.warnings() {
        eprintln!("vitrum: warning: {w}");
    }
    let pool = args.render.pool()?;
    let bars = Bars::new("compare", plan.renders(), args.quiet);
    let outcome = render_scene(&plan, args, &pool, &bars);
    bars.finish();
    let outcome = outcome?;
    let report = Report {
        title: format!("vitrum compare: {}", plan.scene_name),
        sections: vec![section(&plan, &outcome, "")],
        command: crate::report::command_line(),
        machine: crate::report::machine::describe(),
    };
    publish(&plan, &outcome, Some(&report))?;
    if !args.quiet {
        print_summary(&outcome);
        eprintln!(
            "compare: {} method(s) -> {} (index.html, compare.png, compare.csv, compare.md, METHOD.exr)",
            outcome.rows.len(),
            plan.out.display()
        );
    }
    Ok(())
}

/// One line per method: spp, seconds, errors and the bias split.
pub(crate) fn print_summary(outcome: &Outcome) {
    for row in &outcome.rows {
        eprintln!(
            "{:<11} {:>6} spp {:>8} s  relMSE {:<9} MSE {:<9} {}",
            row.method,
            format_spp(row.spp()),
            format_seconds(row.out.seconds),
            format_number(row.metrics.rel_mse),
            format_number(row.metrics.mse),
            split_text(row)
        );
        if let Some(s) = &row.spread {
            eprintln!(
                "{:<11} over {} runs: relMSE {} [{}, {}], {} s [{}, {}], efficiency {}",
                "",
                s.runs,
                format_number(s.rel_mse.mean),
                format_number(s.rel_mse.low),
                format_number(s.rel_mse.high),
                format_seconds(s.seconds.mean),
                format_seconds(s.seconds.low),
                format_seconds(s.seconds.high),
                efficiency_text(row)
            );
        }
    }
}

/// Renders (or reads) the reference and every method of `plan`, measuring each against the
/// reference; `bars` advance by one per render.
pub(crate) fn render_scene(
    plan: &Plan,
    args: &CompareArgs,
    pool: &rayon::ThreadPool,
    bars: &Bars,
) -> Result<Outcome, CliError> {
    let (reference, reference_text, reference_file) = match &plan.reference {
        ReferenceSource::File(reference, text) => {
            let path = args.reference.clone().expect("a reference file");
            (reference.clone(), text.clone(), path)
        }
        ReferenceSource::Cached(plan_ref) => {
            let spp = plan_ref.spp;
            let bar = bars.render("reference", Budget::Samples(spp));
            let progress = |done: u64, total: u64| {
                bar.set_length(total);
                bar.set_position(done);
            };
            // At the renders' size: with --renders and no --resolution, the size read from them.
            let size = (plan.size.0 as u32, plan.size.1 as u32);
            let sweep = SweepArgs { resolution: Some(size), ..args.render.clone() };
            let r = pool.install(|| plan_ref.get(&plan.scene, &sweep, &progress));
            bar.finish_and_clear();
            bars.overall.inc(1);
            let r = r?;
            if !args.quiet {
                bars.println(&r.describe());
            }
            let text = format!("{}, {} spp ({})", r.method, r.reference.spp, r.reference.path.display());
            let path = r.reference.path.clone();
            (Reference::from(r), text, path)
        }
    };

    let mut rows = Vec::new();
    for (index, spec) in plan.methods.iter().enumerate() {
        let method = spec.integrator.as_ref();
        if let Some(renders) = &plan.renders {
            let r = &renders[index];
            let failure = |e: String| CliError::Failure(format!("{}: {e}", r.path.display()));
            let out = r.out.clone();
            let row = Row::new(spec, out, r.seed, &reference, (plan.exposure, &plan.regions))
                .map_err(|e| failure(e.to_string()))?;
            rows.push(row);
            continue;
        }
        let mut opts = args.render.options(&plan.scene, method, plan.budget);
        spec.apply(&mut opts);
        crate::commands::support::check_effects(&plan.scene, method, &opts, false)?;
        let seed = opts.seed;
        let failure = |e: MetricsError| CliError::Failure(format!("{}: {e}", spec.label));
        let out = render_run(plan, spec, &opts, 0, (pool, bars));
        let mut row =
            Row::new(spec, out, seed, &reference, (plan.exposure, &plan.regions)).map_err(failure)?;
        for k in 1..plan.repeat {
            opts.seed = seed.wrapping_add(u64::from(k));
            let out = render_run(plan, spec, &opts, k, (pool, bars));
            row.add_run(&out, opts.seed, &reference).map_err(failure)?;
        }
        rows.push(row);
    }
    let spp = match &plan.reference {
        ReferenceSource::Cached(r) => Some(r.spp),
        ReferenceSource::File(..) => None,
    };
    let splits: Vec<(&str, Option<&Split>)> =
        rows.iter().map(|r| (r.method.as_str(), r.split.as_ref())).collect();
    if let Some(warning) = super::reference_noise_warning(&splits, spp) {
        bars.println(&warning);
    }
    Ok(Outcome { reference, reference_text, reference_file, rows })
}

/// Renders run `k` (from 0) of `spec` with `opts` under a bar of its own, warning of non-finite
/// samples.
fn render_run(
    plan: &Plan,
    spec: &MethodSpec,
    opts: &render::RenderOptions,
    k: u32,
    (pool, bars): (&rayon::ThreadPool, &Bars),
) -> RenderOutput {
    let name = if plan.repeat > 1 {
        format!("{} {}/{}", spec.label, k + 1, plan.repeat)
    } else {
        spec.label.clone()
    };
    let bar = bars.render(&name, plan.budget);
    let start = Instant::now();
    let progress = |done: u64, total: u64| match plan.budget {
        Budget::Samples(_) => {
            bar.set_length(total);
            bar.set_position(done);
        }
        Budget::Time(limit) => {
            bar.set_length(limit.as_millis() as u64);
            bar.set_position((start.elapsed().as_millis() as u64).min(limit.as_millis() as u64));
        }
    };
    let out = pool.install(|| render::render(&plan.scene, spec.integrator.as_ref(), opts, &progress));
    bar.finish_and_clear();
    bars.overall.inc(1);
    if out.non_finite_samples > 0 {
        bars.println(&format!(
            "vitrum: warning: {name}: {} sample(s) were NaN or infinite (seed {})",
            out.non_finite_samples, opts.seed
        ));
    }
    out
}

/// The reference description without its (possibly long) file path.
fn short_reference(text: &str) -> &str {
    text.split(" (").next().unwrap_or(text)
}

/// The static figure of `outcome`, laid out by [`compose::compose`].
fn figure(plan: &Plan, outcome: &Outcome) -> Result<Canvas, CliError> {
    let title = format!(
        "{} · {} · {}x{} · reference: {}",
        plan.scene_name,
        plan.budget_text(),
        plan.size.0,
        plan.size.1,
        short_reference(&outcome.reference_text)
    );
    let errors = outcome
        .rows
        .iter()
        .map(|row| metrics::relative_squared_error(&row.out.image, &outcome.reference.image))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| CliError::Failure(e.to_string()))?;
    let panels: Vec<Panel> = outcome
        .rows
        .iter()
        .zip(&errors)
        .map(|(row, error)| Panel {
            method: &row.method,
            image: &row.out.image,
            spp: row.spp(),
            seconds: row.out.seconds,
            rel_mse: row.metrics.rel_mse,
            rel_mse_interval: row
                .split
                .map(|s| s.rel_mse_interval())
                .filter(|(l, h)| l.is_finite() && h.is_finite()),
            error,
        })
        .collect();
    let reference = compose::ReferencePanel {
        image: &outcome.reference.image,
        description: short_reference(&outcome.reference_text),
    };
    let options = compose::FigureOptions {
        exposure_ev: plan.exposure,
        crop: plan.crop,
        reference: Some(reference),
        columns: plan.columns,
    };
    Ok(compose::compose(&title, &panels, &options))
}

/// The report section of one scene's comparison, with a table per `--region`; `files` is where
/// its EXR renders and tables are, relative to the page ("" when beside it).
pub(crate) fn section(plan: &Plan, outcome: &Outcome, files: &str) -> Section {
    let scene = &plan.scene;
    let objects: Vec<String> =
        scene.objects.iter().map(|o| format!("{} ({}, {})", o.name, o.kind, o.material)).collect();
    let effects = scene.effects.names();
    let details = vec![
        ("scene file".to_string(), format!("{} (hash {})", scene.origin.name, scene.origin.hash)),
        ("budget".to_string(), plan.budget_text()),
        ("resolution".to_string(), format!("{}x{}", plan.size.0, plan.size.1)),
        ("reference".to_string(), outcome.reference_text.clone()),
        ("effects".to_string(), if effects.is_empty() { "none".to_string() } else { effects }),
        ("objects".to_string(), objects.join("; ")),
    ];
    let layer_note = |row: &Row| {
        format!("{} spp, {} s, seed {}", format_spp(row.spp()), format_seconds(row.out.seconds), row.seed)
    };
    // A row of the page's tables: the method's budget with errors over the image or a region.
    let table_row = |r: &Row, metrics: &Metrics, split: Option<&Split>| {
        TableRow::new(&r.method, (r.spp(), r.out.seconds, r.out.rays.total()), metrics, split)
    };
    // The whole image's row: under `--repeat` with the runs' means and intervals.
    let main_row = |r: &Row| {
        let mut row = table_row(r, &r.metrics, r.split.as_ref());
        if r.spread.is_some() {
            (row.rel_mse, row.rel_mse_interval) = r.rel_mse();
            (row.seconds, row.seconds_interval) = r.seconds();
            row.efficiency = r.efficiency().ok();
        }
        row
    };
    Section {
        scene: plan.scene_name.clone(),
        details,
        exposure: plan.exposure,
        reference: Layer {
            label: "reference".into(),
            note: outcome.reference_text.clone(),
            image: outcome.reference.image.clone(),
        },
        layers: outcome
            .rows
            .iter()
            .map(|row| Layer {
                label: row.method.to_string(),
                note: layer_note(row),
                image: row.out.image.clone(),
            })
            .collect(),
        rows: outcome.rows.iter().map(main_row).collect(),
        regions: plan
            .regions
            .iter()
            .enumerate()
            .map(|(k, (name, c))| crate::report::RegionTable {
                name: name.clone(),
                rect: (c.rect.x, c.rect.y, c.rect.width, c.rect.height),
                mask: c.mask.is_some(),
                rows: outcome
                    .rows
                    .iter()
                    .map(|r| table_row(r, &r.regions[k].0, r.regions[k].1.as_ref()))
                    .collect(),
            })
            .collect(),
        convergence: Vec::new(),
        files: files.to_string(),
    }
}

/// Encodes every output of `outcome` (and the `report` page, when given), then publishes them
/// together; on failure nothing is left behind (and a folder created for them is removed again).
pub(crate) fn publish(plan: &Plan, outcome: &Outcome, report: Option<&Report>) -> Result<(), CliError> {
    let figure = figure(plan, outcome)?;
    let csv = csv_table(&outcome.rows);
    let markdown =
        markdown_table(plan, &outcome.rows, &outcome.reference_text, outcome.reference.variance.is_some());
    let out = &plan.out;
    let created = !out.exists();
    let data_created = !out.join(crate::report::data::FOLDER).exists();
    let failure = |e: OutputError| CliError::Failure(e.to_string());
    if created {
        std::fs::create_dir(out).map_err(|e| failure(OutputError::io(out, e)))?;
    }
    let result = (|| {
        let mut staged: Vec<Staged> = Vec::new();
        for row in &outcome.rows {
            let meta = ExrMetadata {
                version: crate::VERSION.to_string(),
                integrator: row.integrator.to_string(),
                spp: row.out.spp,
                seed: row.seed,
                render_time_seconds: row.out.seconds,
                rays: row.out.rays,
                scene: format!("{} ({})", plan.scene.origin.name, plan.scene.origin.hash),
                effects: plan.scene.effects.names(),
            };
            let (channels, mut notes) = render_channels(&row.out);
            notes.push((super::diff::EXPOSURE_ATTRIBUTE.to_string(), plan.exposure.to_string()));
            if row.method != row.integrator {
                notes.push((VARIANT_ATTRIBUTE.to_string(), row.method.clone()));
            }
            let path = out.join(format!("{}.exr", row.stem));
            staged.push(stage_exr_with_notes(&path, &row.out.image, &meta, &channels, &notes)?);
        }
        let copy = |tmp: &Path| {
            std::fs::copy(&outcome.reference_file, tmp)
                .map(|_| ())
                .map_err(|e| OutputError::io(&outcome.reference_file, e))
        };
        staged.push(stage(&out.join(REFERENCE_FILE), copy)?);
        staged.push(figure.stage_png(&out.join("compare.png"))?);
        staged.push(stage_text(&out.join("compare.csv"), &csv)?);
        staged.push(stage_text(&out.join("compare.md"), &markdown)?);
        if !plan.regions.is_empty() {
            staged.push(stage_text(&out.join(REGIONS_CSV), &regions_csv(&plan.regions, &outcome.rows))?);
        }
        if plan.repeat > 1 {
            staged.push(stage_text(&out.join(RUNS_CSV), &runs_csv(&outcome.rows))?);
        }
        if let Some(report) = report {
            staged.extend(crate::report::stage(out, report)?);
        }
        staged.into_iter().try_for_each(Staged::commit)
    })();
    if result.is_err() {
        // Only empty folders: the staged files removed themselves when dropped.
        if data_created {
            let _ = std::fs::remove_dir(out.join(crate::report::data::FOLDER));
        }
        if created {
            let _ = std::fs::remove_dir(out);
        }
    }
    result.map_err(failure)
}

/// Prepares a text file for publishing.
fn stage_text(path: &Path, text: &str) -> Result<Staged, OutputError> {
    stage(path, |tmp| std::fs::write(tmp, text).map_err(|e| OutputError::io(tmp, e)))
}

/// Millions of rays per second.
fn mrays_per_second(out: &RenderOutput) -> f64 {
    metrics::mrays_per_second(out.rays.total(), out.seconds)
}

/// The split for the summary line: "biased: bias part 1.2e-3 ± 4e-5 …", "no bias detected: …".
fn split_text(row: &Row) -> String {
    match &row.split {
        Some(s) => {
            let flag = if s.reference_too_noisy() && s.verdict() != metrics::Verdict::ReferenceTooNoisy {
                format!(
                    " (reference variance {:.0}% of the relative error: too noisy)",
                    100.0 * s.reference_share()
                )
            } else {
                String::new()
            };
            format!(
                "{}: bias part {} ± {}{flag}",
                s.verdict().name(),
                format_number(s.bias),
                format_number(s.bias_se)
            )
        }
        None => "bias unknown (no replicas)".to_string(),
    }
}

/// "1.23e-3 [1.1e-3, 1.4e-3]": a value with its 95% interval, or the value alone without one.
pub(crate) fn with_interval(value: f64, (low, high): (f64, f64)) -> String {
    if low.is_nan() || high.is_nan() {
        return format!("{value:.3e}");
    }
    let high = if high.is_finite() { format!("{high:.2e}") } else { "∞".into() };
    format!("{value:.3e} [{low:.2e}, {high}]")
}

/// The efficiency column: the value with its interval, or why there is none.
fn efficiency_text(row: &Row) -> String {
    match row.efficiency() {
        Ok(e) => with_interval(e.value, (e.low, e.high)),
        Err(why) => format!("— ({why})"),
    }
}

/// The CSV header: the first nine columns as before (efficiency is now 1/(relMSE·seconds)), the
/// newer ones after them, the split's last. Under `--repeat`, `seconds`, `rel_mse` and
/// `efficiency` are the means over the runs and their `_low`/`_high` the runs' 95% interval.
pub const CSV_HEADER: &str = concat!(
    "method,spp,seconds,rays,mrays_per_second,mse,rel_mse,efficiency,non_finite_pixels,",
    "rel_mse_trimmed,psnr,psnr_peak,psnr_preview,ssim,flip,",
    "rel_mse_low,rel_mse_high,efficiency_low,efficiency_high,efficiency_note,",
    "runs,seconds_low,seconds_high,",
    "rel_mse_se,variance,reference_variance,reference_share,bias,bias_se,detection_limit,verdict"
);

/// The table as CSV, one row per method (full precision; absent values are empty fields).
fn csv_table(rows: &[Row]) -> String {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for r in rows {
        let m = &r.metrics;
        let (rel_mse, interval) = r.rel_mse();
        let (low, high) = interval.unwrap_or((f64::NAN, f64::NAN));
        let (seconds, seconds_interval) = r.seconds();
        let (seconds_low, seconds_high) = seconds_interval.unwrap_or((f64::NAN, f64::NAN));
        let finite = |v: f64| if v.is_nan() { String::new() } else { v.to_string() };
        let (efficiency, e_low, e_high, note) = match r.efficiency() {
            Ok(e) => (e.value.to_string(), e.low.to_string(), e.high.to_string(), String::new()),
            Err(why) => (String::new(), String::new(), String::new(), why.to_string()),
        };
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            super::csv_field(&r.method),
            r.spp(),
            seconds,
            r.out.rays.total(),
            mrays_per_second(&r.out),
            m.mse,
            rel_mse,
            efficiency,
            m.non_finite_test,
            m.rel_mse_trimmed,
            m.psnr,
            m.peak,
            m.psnr_preview,
            m.ssim,
            m.flip,
            finite(low),
            finite(high),
            e_low,
            e_high,
            note,
            r.runs.len(),
            finite(seconds_low),
            finite(seconds_high),
            metrics::split_csv(r.split.as_ref()),
        );
    }
    s
}

/// The file of every run of `--repeat`.
pub const RUNS_CSV: &str = "compare-runs.csv";

/// The header of [`RUNS_CSV`]: one line per method and run.
pub const RUNS_CSV_HEADER: &str = "method,run,seed,spp,seconds,rel_mse";

/// Every run of every row, one line each.
fn runs_csv(rows: &[Row]) -> String {
    let mut s = format!("{RUNS_CSV_HEADER}\n");
    for r in rows {
        for (k, run) in r.runs.iter().enumerate() {
            let _ = writeln!(
                s,
                "{},{k},{},{},{},{}",
                super::csv_field(&r.method),
                run.seed,
                run.spp,
                run.seconds,
                run.rel_mse
            );
        }
    }
    s
}

/// The file of the metrics over the `--region`s.
pub const REGIONS_CSV: &str = "compare-regions.csv";

/// The header of [`REGIONS_CSV`]: the method, the region, then the metrics and the split over it.
pub const REGIONS_CSV_HEADER: &str = concat!(
    "method,region,x,y,width,height,pixels,mse,rel_mse,rel_mse_low,rel_mse_high,rel_mse_trimmed,ssim,flip,",
    "efficiency,efficiency_low,efficiency_high,",
    "rel_mse_se,variance,reference_variance,reference_share,bias,bias_se,detection_limit,verdict"
);

/// The metrics of every row over every region, one line per (method, region).
fn regions_csv(regions: &[(String, Region)], rows: &[Row]) -> String {
    let mut s = String::from(REGIONS_CSV_HEADER);
    s.push('\n');
    let finite = |v: f64| if v.is_nan() { String::new() } else { v.to_string() };
    for r in rows {
        for ((name, region), (m, split)) in regions.iter().zip(&r.regions) {
            let c = region.rect;
            let (low, high) = split.map_or((f64::NAN, f64::NAN), |s| s.rel_mse_interval());
            let (e, el, eh) = match metrics::efficiency(split.as_ref(), r.out.seconds) {
                Ok(e) => (e.value.to_string(), e.low.to_string(), e.high.to_string()),
                Err(_) => Default::default(),
            };
            let _ = writeln!(
                s,
                "{},{name},{},{},{},{},{},{},{},{},{},{},{},{},{e},{el},{eh},{}",
                super::csv_field(&r.method),
                c.x,
                c.y,
                c.width,
                c.height,
                m.pixels,
                m.mse,
                m.rel_mse,
                finite(low),
                finite(high),
                m.rel_mse_trimmed,
                m.ssim,
                m.flip,
                metrics::split_csv(split.as_ref()),
            );
        }
    }
    s
}

/// "1.23e-3 ± 4.00e-5", or "n/a".
fn value_se(split: Option<&Split>, f: fn(&Split) -> (f64, f64)) -> String {
    split.map_or("n/a".into(), |s| {
        let (v, se) = f(s);
        format!("{v:.2e} ± {se:.1e}")
    })
}

/// What the table's numbers are under `--repeat` (nothing for one run).
fn repeat_caption(repeat: u32) -> String {
    if repeat < 2 {
        return String::new();
    }
    format!(
        " Repeated runs: every method rendered {repeat} times (seeds seed … seed + {}); seconds, relMSE \
         and efficiency are the means over the runs with the 95% interval of their spread (efficiency \
         = 1/(mean relMSE · mean seconds), jackknife interval; compare-runs.csv has every run); the \
         images, the other metrics and the verdict are the first run's.",
        repeat - 1
    )
}

/// "caustic (10,20,30,40)" for a rectangle, "glass (mask in 10,20,30,40)" for a mask.
pub(crate) fn region_label(name: &str, region: &Region) -> String {
    let c = region.rect;
    let kind = if region.mask.is_some() { "mask in " } else { "" };
    format!("{name} ({kind}{},{},{},{})", c.x, c.y, c.width, c.height)
}

/// The table as Markdown with a caption stating the scene, budget, reference and definitions.
fn markdown_table(plan: &Plan, rows: &[Row], reference: &str, reference_variance: bool) -> String {
    let mut s = format!("# vitrum compare: {}\n\n", plan.scene_name);
    let _ = writeln!(
        s,
        "{} ({}); {}x{} pixels; reference: {}{}. Metrics over the whole image, defined in \
         docs/workflow.md's \"Metrics\" section: relMSE with its 95% interval and relMSE without the 0.1% \
         worst pixels; PSNR on the HDR values (peak = largest reference value, stated) and on the \
         8-bit sRGB preview at exposure {} EV (peak 1); SSIM of the preview's luma. The relative \
         error (weights 1/(r̃²+0.01), r̃ the reference's mean over each pixel's 8 neighbours) = bias \
         part + variance part + the reference's variance part (variances from the replicas), the \
         bias part ± one standard error (jackknife over the replicas). Verdicts: \"biased\" = bias \
         part > {} standard errors and above the reference's variance part; \"reference too \
         noisy\" = the reference's variance part > {:.0}% of the error; \"inconclusive\" = a bias \
         of {:.0}% of the error could hide in the noise; else \"no bias detected\". Efficiency = 1/(relMSE·seconds) with its 95% interval, given only \
         where no bias is detected. `ssaa`'s spp is its mean camera rays per pixel.{}\n",
        plan.budget_text(),
        match (&plan.renders, plan.budget) {
            (Some(_), _) => "read from files; seconds of merged parts are summed",
            (None, Budget::Time(_)) => "whole passes, at least one",
            (None, Budget::Samples(_)) => "the same samples for every method",
        },
        plan.size.0,
        plan.size.1,
        reference,
        if reference_variance { " (its variance kept)" } else { " (no variance: taken as exact)" },
        plan.exposure,
        metrics::BIAS_SIGNIFICANCE,
        100.0 * metrics::REFERENCE_SHARE_LIMIT,
        100.0 * metrics::INCONCLUSIVE_FRACTION,
        repeat_caption(plan.repeat),
    );
    s.push_str(
        "| method | spp | seconds | rays | Mrays/s | MSE | relMSE [95%] | relMSE 99.9% | PSNR HDR (peak) | \
         PSNR LDR | SSIM | HDR-FLIP | bias part | verdict | efficiency [95%] | non-finite px |\n",
    );
    s.push_str("|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|---|--:|--:|\n");
    for r in rows {
        let m = &r.metrics;
        let rel_mse = match r.rel_mse() {
            (v, Some(interval)) => with_interval(v, interval),
            (v, None) => format!("{v:.3e}"),
        };
        let seconds = match r.seconds() {
            (v, Some((low, high))) => format!("{v:.3} [{low:.3}, {high:.3}]"),
            (v, None) => format!("{v:.3}"),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {seconds} | {} | {:.2} | {:.3e} | {} | {:.3e} | {:.2} dB ({:.3}) | {:.2} dB | {:.4} | {:.4} | {} | {} | {} | {} |",
            r.method,
            format_spp(r.spp()),
            r.out.rays.total(),
            mrays_per_second(&r.out),
            m.mse,
            rel_mse,
            m.rel_mse_trimmed,
            m.psnr,
            m.peak,
            m.psnr_preview,
            m.ssim,
            m.flip,
            value_se(r.split.as_ref(), |s| (s.bias, s.bias_se)),
            r.status(),
            efficiency_text(r),
            m.non_finite_test
        );
    }
    if !plan.regions.is_empty() {
        s.push_str(
            "\n## Regions\n\nThe same metrics over each `--region` and `--mask` (compare-regions.csv has \
             every column; a mask's x, y, width and height are its bounding box).\n\n",
        );
        s.push_str("| method | region | pixels | relMSE [95%] | SSIM | HDR-FLIP | bias part | verdict |\n");
        s.push_str("|---|---|--:|--:|--:|--:|--:|---|\n");
        for r in rows {
            for ((name, region), (m, split)) in plan.regions.iter().zip(&r.regions) {
                let rel_mse = match split {
                    Some(split) => with_interval(m.rel_mse, split.rel_mse_interval()),
                    None => format!("{:.3e}", m.rel_mse),
                };
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {rel_mse} | {:.4} | {:.4} | {} | {} |",
                    r.method,
                    region_label(name, region),
                    m.pixels,
                    m.ssim,
                    m.flip,
                    value_se(split.as_ref(), |s| (s.bias, s.bias_se)),
                    split.map_or("unknown", |s| s.verdict().name()),
                );
            }
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_and_exposures_must_be_finite() {
        assert_eq!(parse_seconds("0.5"), Ok(0.5));
        for bad in ["0", "-1", "nan", "inf", "abc", "1e300"] {
            assert!(parse_seconds(bad).is_err(), "{bad}");
        }
        assert_eq!(super::super::diff::parse_exposure("-1.5"), Ok(-1.5));
        assert!(super::super::diff::parse_exposure("nan").is_err());
        assert!(super::super::diff::parse_exposure("inf").is_err());
    }

    #[test]
    fn the_split_columns_end_the_csv_header() {
        assert!(CSV_HEADER.ends_with(metrics::SPLIT_CSV_COLUMNS));
        assert_eq!(CSV_HEADER.split(',').count(), 9 + 6 + 5 + 3 + 8);
    }

    #[test]
    fn the_reference_text_loses_its_path_in_the_title() {
        assert_eq!(short_reference("path, 1024 spp (.vitrum-cache/x.exr)"), "path, 1024 spp");
        assert_eq!(short_reference("ref.exr"), "ref.exr");
    }
}
