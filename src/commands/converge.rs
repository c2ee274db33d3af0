//! `vitrum converge`: progressive renders with error against samples and seconds.
//!
//! Every integrator renders once, progressively ([`crate::render::render_progressive`]): the image
//! grows pass by pass and at every power of two of the sample count (and at the last count) the
//! cumulative image is measured against the reference with the metrics of [`crate::metrics`],
//! together with the cumulative render seconds and rays. The reference is a file (`--reference`)
//! or a cached high-sample render ([`crate::reference::render_reference`]) by the method the
//! pilots choose for the scene ([`crate::reference::choose_by_pilot`]) or by `--reference-method`.
//!
//! # Rates and plateaus
//! Each checkpoint's MSE is split into its bias and variance parts ([`crate::metrics::split`],
//! with the render's per-pixel variance and the reference's). The error falls like variance
//! until the first checkpoint called biased ([`crate::metrics::Verdict::Biased`]);
//! from there on the error is held up by a bias floor. The relMSE slopes (against samples and
//! against seconds) are fitted over the checkpoints before that one only, and the rest is
//! reported as "plateau from N spp (bias part ≈ B ± SE)", B and SE being the last checkpoint's,
//! instead of a rate. A checkpoint without a variance estimate (one sample) counts as variance.
//! A method with no two checkpoints in the variance regime has no slope.
//!
//! Outputs in `--out` (each written atomically): `converge.csv` (one row per integrator and
//! checkpoint, rewritten after every integrator so that a stopped run keeps what it measured),
//! `relmse-spp.svg|png` and `relmse-seconds.svg|png` (log-log, the fitted slope in the legend),
//! `converge.json` (the reference, the budget, how each method's checkpoints were made and its
//! fitted slopes), `index.html` (the interactive report of [`crate::report`]: each method's last
//! checkpoint against the reference, the table and the plots) and with `--exr` the image of every checkpoint, `METHOD-Nspp.exr`.
//!
//! Progressive checkpoints are plain renders with the scene's sampler when it does not depend on
//! the sample count (Sobol', the default, and independent), and draw independent samples with the
//! stratified one (see [`crate::render`]); `--fresh` renders every checkpoint anew with the
//! scene's sampler, and then the seconds of a row are those of its own render. `ssaa` renders one fixed pattern: one row.

use super::SweepArgs;
use crate::commands::diff::read_judged;
use crate::commands::support::{load_scene, CliError};
use crate::commands::variants::{parse_methods, MethodSpec};
use crate::figure::compose::format_number;
use crate::figure::plot::{fit_slope, write_loglog, LogLogPlot, Series};
use crate::image::Image;
use crate::metrics::{self, split_csv, Metrics, MetricsError, Split};
use crate::output::exr::{stage_exr, ExrMetadata};
use crate::output::{write_atomically, OutputError};
use crate::render::{self, Budget, Growth, RenderOutput};
use crate::report::{self, Layer, Report, Section, TableRow};
use crate::scene::Scene;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use serde_json::json;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The largest sample count when neither `--spp-max` nor `--time` is given.
pub const DEFAULT_SPP_MAX: u32 = 64;
/// Samples per pixel of the cached reference (by the method [`crate::reference::choose_method`]
/// picks, or `--reference-method`) when no `--reference` is given.
pub const DEFAULT_REFERENCE_SPP: u32 = 1024;
/// The CSV header.
pub const CSV_HEADER: &str = concat!(
    "integrator,spp,seconds,rays,mse,rmse,rel_mse,mae,psnr,non_finite,std_error,est_mse,",
    "rel_mse_trimmed,psnr_peak,psnr_preview,ssim,flip,",
    "rel_mse_se,variance,reference_variance,reference_share,bias,bias_se,detection_limit,verdict"
);

/// Options of `vitrum converge`.
#[derive(clap::Args, Debug, Clone)]
pub struct ConvergeArgs {
    /// Scene file (TOML); the embedded default scene when omitted.
    pub scene: Option<PathBuf>,
    /// Integrators, comma-separated, or `all`.
    #[arg(short, long, default_value = "path,light")]
    pub integrators: String,
    /// Reference image (EXR of the render's size); default: a render by the reference method,
    /// cached.
    #[arg(long, conflicts_with_all = ["reference_spp", "cache", "reference_method"])]
    pub reference: Option<PathBuf>,
    /// Samples per pixel of the cached reference (default 1024).
    #[arg(long)]
    pub reference_spp: Option<u32>,
    /// The method that renders the reference (default: the most efficient of path, bpt and vcm
    /// fit for the scene, measured by short pilot renders).
    #[arg(long, value_name = "NAME")]
    pub reference_method: Option<String>,
    /// Folder of cached references (default `.vitrum-cache`).
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// Largest sample count (default 64); checkpoints at every power of two below it and at it.
    #[arg(long, conflicts_with = "time")]
    pub spp_max: Option<u32>,
    /// Render each integrator for this many seconds instead (checkpoints at powers of two and
    /// where the time runs out).
    #[arg(long, allow_negative_numbers = true)]
    pub time: Option<f64>,
    /// Render options shared by every integrator.
    #[command(flatten)]
    pub render: SweepArgs,
    /// Output folder.
    #[arg(long, default_value = "converge")]
    pub out: PathBuf,
    /// Also write the image of every checkpoint as `METHOD-Nspp.exr`.
    #[arg(long)]
    pub exr: bool,
    /// Render every checkpoint anew (with the scene's sampler) instead of growing one render.
    #[arg(long)]
    pub fresh: bool,
    /// No progress bars and no summary (warnings still go to stderr).
    #[arg(long)]
    pub quiet: bool,
    /// Measure these renders instead of rendering (EXR files of the scene, e.g. merged shards
    /// from a cluster): one row per file, the methods those of the files; their size is the
    /// first file's unless --resolution is given.
    #[arg(long, num_args = 1.., value_name = "EXR", conflicts_with_all = ["spp_max", "time", "fresh"])]
    pub renders: Vec<PathBuf>,
}

/// How the rows of `--renders` were made.
const PRECOMPUTED: &str = "precomputed renders read from files (--renders)";

/// Where the reference comes from.
enum ReferenceSource {
    /// Read from a file: the image with its variance and replicas (if it keeps them) and its
    /// path.
    File(Reference, PathBuf),
    /// A render by the sweep, cached.
    Cached(super::CachedReference),
}

/// Everything checked before rendering.
struct Plan {
    scene: Scene,
    /// The methods and variants, in the order of `-i` ([`super::variants`]).
    methods: Vec<MethodSpec>,
    budget: Budget,
    reference: ReferenceSource,
    width: usize,
    height: usize,
    /// The renders to measure instead of rendering (`--renders`).
    renders: Option<Vec<super::RenderFile>>,
}

/// One checkpoint of one integrator.
#[derive(Clone, Debug)]
pub struct Row {
    /// Integrator name.
    pub integrator: String,
    /// Samples per pixel.
    pub spp: u32,
    /// Render seconds (cumulative for a growing render).
    pub seconds: f64,
    /// Rays traced (cumulative for a growing render).
    pub rays: u64,
    /// Error against the reference.
    pub metrics: Metrics,
    /// The reference-free noise estimate, when the render has one.
    pub noise: Option<render::Noise>,
    /// The bias/variance split of the MSE, when the render's variance is known.
    pub split: Option<Split>,
}

impl Row {
    /// The 95% interval of the relMSE from the split, NaN bounds without one.
    pub fn rel_mse_interval(&self) -> (f64, f64) {
        self.split.map_or((f64::NAN, f64::NAN), |s| s.rel_mse_interval())
    }

    /// The row as a CSV line (no newline); absent values are empty fields.
    pub fn csv(&self) -> String {
        let m = &self.metrics;
        let opt = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
        format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            super::csv_field(&self.integrator),
            self.spp,
            self.seconds,
            self.rays,
            m.mse,
            m.rmse,
            m.rel_mse,
            m.mae,
            m.psnr,
            m.non_finite_test,
            opt(self.noise.map(|n| n.std_error)),
            opt(self.noise.map(|n| n.mse)),
            m.rel_mse_trimmed,
            m.peak,
            m.psnr_preview,
            m.ssim,
            m.flip,
            split_csv(self.split.as_ref()),
        )
    }
}

/// Check everything that can be checked before rendering.
fn plan(args: &ConvergeArgs) -> Result<Plan, CliError> {
    let bad = CliError::BadInput;
    let mut methods = parse_methods(&args.integrators)?;
    let scene = load_scene(args.scene.as_deref())?;
    let budget = match (args.spp_max, args.time) {
        (_, Some(t)) if !(t.is_finite() && t > 0.0) => {
            return Err(bad(format!("--time {t}: must be a positive number of seconds")))
        }
        (_, Some(t)) => Budget::Time(
            Duration::try_from_secs_f64(t).map_err(|_| bad(format!("--time {t}: too long to represent")))?,
        ),
        (Some(0), _) => return Err(bad("--spp-max 0: at least one sample per pixel".into())),
        (n, None) => Budget::Samples(n.unwrap_or(DEFAULT_SPP_MAX)),
    };
    let camera = render::camera_for(&scene, args.render.resolution);
    let (mut width, mut height) = (camera.crop.width as usize, camera.crop.height as usize);
    let renders = if args.renders.is_empty() {
        None
    } else {
        let size = args.render.resolution.map(|_| (width, height));
        let (renders, read_size) = super::read_renders(&args.renders, &scene, size)?;
        (width, height) = read_size;
        methods = crate::integrators::all()
            .into_iter()
            .filter(|m| renders.iter().any(|r| r.method.name() == m.name()))
            .map(MethodSpec::plain)
            .collect();
        Some(renders)
    };
    let reference = match &args.reference {
        Some(path) => {
            let judged = read_judged(path).map_err(|e| bad(format!("--reference: {e}")))?;
            let image = &judged.image;
            if (image.width, image.height) != (width, height) {
                return Err(bad(format!(
                    "--reference {}: the reference is {}x{} but the renders are {width}x{height} \
                     (give --resolution {}x{} or another reference)",
                    path.display(),
                    image.width,
                    image.height,
                    image.width,
                    image.height
                )));
            }
            ReferenceSource::File(Reference::from(judged), path.clone())
        }
        None => ReferenceSource::Cached(super::CachedReference::plan(
            &scene,
            args.reference_method.as_deref(),
            args.reference_spp.unwrap_or(DEFAULT_REFERENCE_SPP),
            args.cache.clone(),
        )?),
    };
    if args.out.exists() && !args.out.is_dir() {
        return Err(bad(format!("--out {}: is not a folder", args.out.display())));
    }
    Ok(Plan { scene, methods, budget, reference, width, height, renders })
}

/// Progress bars on stderr when it is a terminal: the whole run and the current render.
struct Bars {
    multi: Option<MultiProgress>,
    overall: ProgressBar,
}

impl Bars {
    fn new(steps: u64, quiet: bool) -> Bars {
        if quiet || !std::io::stderr().is_terminal() {
            return Bars { multi: None, overall: ProgressBar::hidden() };
        }
        let multi = MultiProgress::new();
        let overall = multi.add(ProgressBar::new(steps * 1000));
        overall.set_style(
            ProgressStyle::with_template("converge [{bar:40}] {percent:>3}%, elapsed {elapsed}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        Bars { multi: Some(multi), overall }
    }

    /// A bar for one render.
    fn render(&self, name: &str, unit: &str) -> ProgressBar {
        let Some(multi) = &self.multi else { return ProgressBar::hidden() };
        let bar = multi.add(ProgressBar::new(1));
        let template = format!("{{msg:>12}} [{{bar:40}}] {{percent:>3}}% of {unit}, ETA {{eta}}");
        bar.set_style(ProgressStyle::with_template(&template).expect("valid template").progress_chars("=> "));
        bar.set_message(name.to_string());
        bar
    }

    /// Report (done, total) of step `index` on `bar` and on the overall bar.
    fn update(&self, bar: &ProgressBar, index: u64, done: u64, total: u64) {
        bar.set_length(total.max(1));
        bar.set_position(done);
        self.overall.set_position(index * 1000 + 1000 * done / total.max(1));
    }
}

/// How one method's checkpoints were made, and its fitted slopes.
struct MethodSummary {
    /// The method's label (its name, or the variant as written).
    name: String,
    growth: Growth,
    regime: Regime,
    last: Option<Row>,
    /// The image of the last checkpoint, for the report's viewer.
    image: Option<Image>,
}

/// Where a method's error falls like variance, and where it stops at a bias floor.
#[derive(Clone, Debug, PartialEq)]
pub struct Regime {
    /// The checkpoints before the first biased one: those the slopes are fitted over.
    pub variance_rows: usize,
    /// The least-squares relMSE slope against samples over those checkpoints.
    pub slope_spp: Option<f64>,
    /// The same against seconds.
    pub slope_seconds: Option<f64>,
    /// The plateau, from the first biased checkpoint on.
    pub plateau: Option<Plateau>,
}

/// A bias floor under a method's error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plateau {
    /// Samples per pixel of the first biased checkpoint.
    pub from_spp: u32,
    /// The bias part of the MSE at the last checkpoint.
    pub bias: f64,
    /// Its standard error.
    pub bias_se: f64,
}

/// The regime of one method's checkpoints `rows` (in sample order): see the module docs.
pub fn regime(rows: &[Row]) -> Regime {
    let first_biased = rows.iter().position(|r| r.split.is_some_and(|s| s.biased()));
    let variance_rows = first_biased.unwrap_or(rows.len());
    let points = |x: fn(&Row) -> f64| -> Vec<(f64, f64)> {
        rows[..variance_rows].iter().map(|r| (x(r), r.metrics.rel_mse)).collect()
    };
    let plateau = first_biased.map(|i| {
        let last = rows.last().and_then(|r| r.split).expect("a biased row has a split");
        Plateau { from_spp: rows[i].spp, bias: last.bias, bias_se: last.bias_se }
    });
    Regime {
        variance_rows,
        slope_spp: fit_slope(&points(|r| r.spp as f64)),
        slope_seconds: fit_slope(&points(|r| r.seconds)),
        plateau,
    }
}

impl Regime {
    /// "slope −1.00 against samples, −0.98 against seconds (over 1–16 spp); plateau from 32 spp
    /// (bias part ≈ 1.2e-3 ± 4e-5)".
    fn describe(&self, rows: &[Row]) -> String {
        let slope = |s: Option<f64>| s.map_or("n/a".to_string(), |s| format!("{s:.2}"));
        let mut text = format!(
            "slope {} against samples, {} against seconds",
            slope(self.slope_spp),
            slope(self.slope_seconds)
        );
        if let Some(p) = &self.plateau {
            if self.variance_rows > 1 {
                text += &format!(" (over {}–{} spp)", rows[0].spp, rows[self.variance_rows - 1].spp);
            }
            text += &format!(
                "; plateau from {} spp (bias part ≈ {} ± {}: biased)",
                p.from_spp,
                format_number(p.bias),
                format_number(p.bias_se)
            );
        }
        text
    }

    /// The plot legend of method `name`: its slope over the variance regime and the plateau.
    fn legend(&self, name: &str, slope: Option<f64>, rows: &[Row]) -> String {
        let slope = slope.map(|s| format!("slope {}", format!("{s:.2}").replace('-', "−")));
        match (&self.plateau, slope) {
            (None, Some(s)) => format!("{name} ({s})"),
            (None, None) => name.to_string(),
            (Some(p), Some(s)) => {
                format!(
                    "{name} ({s} to {} spp, plateau from {} spp: bias)",
                    rows[self.variance_rows - 1].spp,
                    p.from_spp
                )
            }
            (Some(p), None) => format!("{name} (plateau from {} spp: bias)", p.from_spp),
        }
    }
}

/// The reference of a sweep.
type Reference = super::SweepReference;

/// Write `text` to `path` atomically.
fn write_text(path: &Path, text: &str) -> Result<(), OutputError> {
    write_atomically(path, |tmp| std::fs::write(tmp, text.as_bytes()).map_err(|e| OutputError::io(tmp, e)))
}

/// The CSV file of `rows`.
pub fn csv(rows: &[Row]) -> String {
    let mut text = String::from(CSV_HEADER);
    text.push('\n');
    for r in rows {
        text.push_str(&r.csv());
        text.push('\n');
    }
    text
}

/// The row of one checkpoint, and its EXR file with `--exr`.
fn measure(
    args: &ConvergeArgs,
    scene: &Scene,
    spec: &MethodSpec,
    seed: u64,
    reference: &Reference,
    out: &RenderOutput,
) -> Result<Row, CliError> {
    let failure = |e: MetricsError| CliError::Failure(e.to_string());
    let method = spec.integrator.as_ref();
    let metrics =
        metrics::compare(&out.image, &reference.image, None, scene.settings.exposure).map_err(failure)?;
    let fixed = matches!(method.progression(), crate::render::Progression::Fixed(_));
    let split = metrics::render_split(fixed, out, reference.estimate(), None).map_err(failure)?;
    if args.exr {
        let path = args.out.join(format!("{}-{}spp.exr", spec.file_stem(), out.spp));
        let meta = ExrMetadata {
            version: crate::VERSION.to_string(),
            integrator: method.name().to_string(),
            spp: out.spp,
            seed,
            render_time_seconds: out.seconds,
            rays: out.rays,
            scene: format!("{} ({})", scene.origin.name, scene.origin.hash),
            effects: scene.effects.names(),
        };
        stage_exr(&path, &out.image, &meta)
            .and_then(|s| s.commit())
            .map_err(|e| CliError::Failure(e.to_string()))?;
    }
    Ok(Row {
        integrator: spec.label.clone(),
        spp: out.spp,
        seconds: out.seconds,
        rays: out.rays.total(),
        metrics,
        noise: out.noise(),
        split,
    })
}

/// Render `method` (the `index`-th) progressively and measure every checkpoint against `reference`.
fn render_rows(
    args: &ConvergeArgs,
    plan: &Plan,
    bars: &Bars,
    pool: &rayon::ThreadPool,
    (index, spec): (usize, &MethodSpec),
    reference: &Reference,
) -> Result<(Growth, Vec<Row>, Option<Image>), CliError> {
    let scene = &plan.scene;
    let method = spec.integrator.as_ref();
    let cached = matches!(plan.reference, ReferenceSource::Cached(..));
    let mut opts = args.render.options(scene, method, plan.budget);
    spec.apply(&mut opts);
    crate::commands::support::check_effects(scene, method, &opts, false)?;
    let unit = match plan.budget {
        Budget::Samples(_) => "samples",
        Budget::Time(_) => "time",
    };
    let bar = bars.render(&spec.label, unit);
    let step = index as u64 + cached as u64;
    let progress = |done: u64, total: u64| bars.update(&bar, step, done, total);
    let mut error: Option<CliError> = None;
    let mut rows: Vec<Row> = Vec::new();
    let mut last: Option<Image> = None;
    let mut checkpoint = |out: &RenderOutput| {
        if error.is_none() {
            match measure(args, scene, spec, opts.seed, reference, out) {
                Ok(row) => {
                    rows.push(row);
                    last = Some(out.image.clone());
                }
                Err(e) => error = Some(e),
            }
        }
    };
    let growth = pool
        .install(|| render::render_progressive(scene, method, &opts, args.fresh, &progress, &mut checkpoint));
    bar.finish_and_clear();
    match error {
        Some(e) => Err(e),
        None => Ok((growth, rows, last)),
    }
}

/// The report section of a convergence run: the last checkpoint of every method in the viewer
/// and the table, every checkpoint in the plots.
fn report_section(
    plan: &Plan,
    summaries: &[MethodSummary],
    rows: &[Row],
    reference: &Reference,
    reference_text: &str,
) -> Section {
    let scene = &plan.scene;
    let mine = |name: &str| -> Vec<Row> { rows.iter().filter(|r| r.integrator == name).cloned().collect() };
    let budget = match plan.budget {
        Budget::Samples(n) => format!("progressive, checkpoints at powers of two up to {n} spp"),
        Budget::Time(t) => format!("progressive, {} s per method", format_number(t.as_secs_f64())),
    };
    let details = vec![
        ("scene file".to_string(), format!("{} (hash {})", scene.origin.name, scene.origin.hash)),
        ("budget".to_string(), budget),
        ("resolution".to_string(), format!("{}x{}", plan.width, plan.height)),
        ("reference".to_string(), reference_text.to_string()),
        ("viewer and table".to_string(), "each method's last checkpoint".to_string()),
    ];
    let with_image = || summaries.iter().filter_map(|s| Some((s, s.image.as_ref()?, s.last.as_ref()?)));
    Section {
        scene: Path::new(&scene.origin.name)
            .file_name()
            .map_or_else(|| scene.origin.name.clone(), |n| n.to_string_lossy().into_owned()),
        details,
        exposure: scene.settings.exposure,
        reference: Layer {
            label: "reference".into(),
            note: reference_text.to_string(),
            image: reference.image.clone(),
        },
        layers: with_image()
            .map(|(s, image, last)| Layer {
                label: s.name.to_string(),
                note: format!("{} spp, {} s", last.spp, format_number(last.seconds)),
                image: image.clone(),
            })
            .collect(),
        rows: with_image()
            .map(|(s, _, last)| {
                let stats = (f64::from(last.spp), last.seconds, last.rays);
                TableRow::new(&s.name, stats, &last.metrics, last.split.as_ref())
            })
            .collect(),
        regions: Vec::new(),
        convergence: summaries
            .iter()
            .map(|s| {
                let mine = mine(&s.name);
                report::Series {
                    method: s.name.to_string(),
                    points: mine.iter().map(|r| (f64::from(r.spp), r.seconds, r.metrics.rel_mse)).collect(),
                    intervals: mine.iter().map(Row::rel_mse_interval).collect(),
                    legend: format!("{}: {}", s.name, s.regime.describe(&mine)),
                }
            })
            .collect(),
        files: String::new(),
    }
}

/// Runs `vitrum converge`.
pub fn run(args: &ConvergeArgs) -> Result<(), CliError> {
    let plan = plan(args)?;
    let pool = args.render.pool()?;
    std::fs::create_dir_all(&args.out)
        .map_err(|e| CliError::Failure(format!("{}: cannot create the folder: {e}", args.out.display())))?;
    for w in &plan.scene.warnings {
        eprintln!("vitrum: warning: {w}");
    }
    let failure = |e: OutputError| CliError::Failure(e.to_string());
    let scene = &plan.scene;
    let cached = matches!(plan.reference, ReferenceSource::Cached(..));
    let bars = Bars::new(plan.methods.len() as u64 + cached as u64, args.quiet);

    // The reference.
    let (reference, reference_json, reference_text) = match &plan.reference {
        ReferenceSource::File(reference, path) => (
            reference.clone(),
            json!({"source": "file", "path": path, "variance": reference.variance.is_some(),
                   "replicas": reference.replicas.as_ref().map(|r| r.count())}),
            format!("reference: {} ({}x{})", path.display(), reference.image.width, reference.image.height),
        ),
        ReferenceSource::Cached(plan_ref) => {
            let bar = bars.render("reference", "rows");
            let progress = |done: u64, total: u64| bars.update(&bar, 0, done, total);
            let r = pool.install(|| plan_ref.get(scene, &args.render, &progress));
            bar.finish_and_clear();
            let r = r?;
            let json = json!({"source": r.method, "why": r.why, "spp": r.reference.spp,
                              "path": r.reference.path, "cached": r.reference.cached, "variance": true,
                              "replicas": r.reference.replicas.as_ref().map(|m| m.count())});
            let text = r.describe();
            (Reference::from(r), json, text)
        }
    };
    if !args.quiet {
        bars.overall.suspend(|| eprintln!("{reference_text}"));
    }

    let mut rows: Vec<Row> = Vec::new();
    let mut summaries = Vec::new();
    let csv_path = args.out.join("converge.csv");
    for (index, spec) in plan.methods.iter().enumerate() {
        let method = spec.integrator.as_ref();
        let (growth, method_rows, last_image) = match &plan.renders {
            Some(renders) => {
                let mut mine: Vec<&super::RenderFile> =
                    renders.iter().filter(|r| r.method.name() == method.name()).collect();
                mine.sort_by_key(|r| r.out.spp);
                let mut rows = Vec::with_capacity(mine.len());
                let last = mine.last().map(|r| r.out.image.clone());
                for r in mine {
                    let out = r.out.clone();
                    rows.push(measure(args, scene, spec, r.seed, &reference, &out)?);
                }
                (Growth::Fresh(PRECOMPUTED), rows, last)
            }
            None => render_rows(args, &plan, &bars, &pool, (index, spec), &reference)?,
        };
        summaries.push(MethodSummary {
            name: spec.label.clone(),
            growth,
            regime: regime(&method_rows),
            last: method_rows.last().cloned(),
            image: last_image,
        });
        rows.extend(method_rows);
        write_text(&csv_path, &csv(&rows)).map_err(failure)?;
    }
    bars.overall.finish_and_clear();
    // The last checkpoint of each method, the least noisy, is the one the reference must beat.
    let last: Vec<(&str, Option<&Split>)> =
        summaries.iter().map(|s| (s.name.as_str(), s.last.as_ref().and_then(|r| r.split.as_ref()))).collect();
    let reference_spp = match &plan.reference {
        ReferenceSource::Cached(r) => Some(r.spp),
        ReferenceSource::File(..) => None,
    };
    if let Some(warning) = super::reference_noise_warning(&last, reference_spp) {
        eprintln!("{warning}");
    }

    // Plots of relMSE against samples and against seconds.
    let mut plots = Vec::new();
    // A short scene name: the file stem, or "default scene".
    let name = &scene.origin.name;
    let short = match Path::new(name).file_stem() {
        Some(stem) if !name.starts_with('<') => stem.to_string_lossy().into_owned(),
        _ => "default scene".to_string(),
    };
    let title = format!("{short}: relMSE");
    type Slope = fn(&Regime) -> Option<f64>;
    for (x_name, x_label, x, slope) in [
        (
            "spp",
            "samples per pixel",
            (|r: &Row| r.spp as f64) as fn(&Row) -> f64,
            (|g: &Regime| g.slope_spp) as Slope,
        ),
        ("seconds", "render time (s)", |r: &Row| r.seconds, |g: &Regime| g.slope_seconds),
    ] {
        let series: Vec<Series> = summaries
            .iter()
            .map(|s| {
                let mine: Vec<Row> = rows.iter().filter(|r| r.integrator == s.name).cloned().collect();
                Series {
                    name: s.name.to_string(),
                    points: mine.iter().map(|r| (x(r), r.metrics.rel_mse)).collect(),
                    legend: Some(s.regime.legend(&s.name, slope(&s.regime), &mine)),
                    intervals: mine.iter().map(Row::rel_mse_interval).collect(),
                }
            })
            .collect();
        let plot = LogLogPlot {
            title: &format!("{title} against {x_label}"),
            x_label,
            y_label: "relMSE",
            series: &series,
        };
        let svg = args.out.join(format!("relmse-{x_name}.svg"));
        let png = svg.with_extension("png");
        match write_loglog(&plot, &svg, &png) {
            Ok(()) => plots.push((svg, png)),
            // A plot with no positive error (every render equals the reference) is no failure.
            Err(e @ OutputError::Format { .. }) => eprintln!("vitrum: warning: no plot: {e}"),
            Err(e) => return Err(failure(e)),
        }
    }

    let growth_json = |g: Growth| match g {
        Growth::Incremental => json!({"growth": "incremental"}),
        Growth::Fresh(why) => json!({"growth": "fresh", "note": why}),
        Growth::Fixed(why) => json!({"growth": "fixed", "note": why}),
    };
    let summary = json!({
        "scene": scene.origin.name,
        "scene_hash": scene.origin.hash,
        "width": plan.width,
        "height": plan.height,
        "seed": args.render.seed.unwrap_or(scene.settings.seed),
        "budget": match plan.budget {
            Budget::Samples(n) => json!({"spp_max": n}),
            Budget::Time(t) => json!({"seconds": t.as_secs_f64()}),
        },
        "reference": reference_json,
        "integrators": summaries.iter().map(|s| {
            let mut v = growth_json(s.growth);
            v["name"] = json!(s.name);
            v["rel_mse_slope_spp"] = json!(s.regime.slope_spp);
            v["rel_mse_slope_seconds"] = json!(s.regime.slope_seconds);
            v["slope_checkpoints"] = json!(s.regime.variance_rows);
            v["plateau"] = json!(s.regime.plateau.map(|p| json!({
                "from_spp": p.from_spp,
                "bias": p.bias,
                "bias_se": p.bias_se,
            })));
            v["checkpoints"] = json!(rows.iter().filter(|r| r.integrator == s.name).count());
            v
        }).collect::<Vec<_>>(),
        "csv": csv_path,
        "plots": plots.iter().map(|(s, p)| json!([s, p])).collect::<Vec<_>>(),
    });
    let json_path = args.out.join("converge.json");
    write_text(&json_path, &(serde_json::to_string_pretty(&summary).expect("JSON") + "\n"))
        .map_err(failure)?;
    let report = Report {
        title: format!("vitrum converge: {short}"),
        sections: vec![report_section(&plan, &summaries, &rows, &reference, &reference_text)],
        command: crate::report::command_line(),
        machine: crate::report::machine::describe(),
    };
    crate::report::write(&args.out, &report).map_err(failure)?;

    if !args.quiet {
        for s in &summaries {
            let Some(last) = &s.last else { continue };
            let how = match s.growth {
                Growth::Incremental => String::new(),
                Growth::Fresh(why) => format!(" ({why})"),
                Growth::Fixed(why) => format!(" (one fixed image: {why})"),
            };
            let mine: Vec<Row> = rows.iter().filter(|r| r.integrator == s.name).cloned().collect();
            eprintln!(
                "{:<12} {} spp in {:.3} s: relMSE {:.4e}; {}{how}",
                s.name,
                last.spp,
                last.seconds,
                last.metrics.rel_mse,
                s.regime.describe(&mine),
            );
        }
        eprintln!(
            "converge -> {}, {}, {}",
            csv_path.display(),
            json_path.display(),
            args.out.join("index.html").display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn metrics(rel_mse: f64) -> Metrics {
        Metrics {
            mse: 0.25,
            rmse: 0.5,
            rel_mse,
            rel_mse_trimmed: 0.1,
            mae: 0.4,
            psnr: 6.0,
            peak: 1.0,
            psnr_preview: 20.0,
            exposure_ev: 0.0,
            ssim: 0.5,
            flip: 0.25,
            pixels: 4,
            non_finite_test: 1,
            non_finite_reference: 0,
        }
    }

    fn row(spp: u32, rel_mse: f64, split: Option<Split>) -> Row {
        let seconds = f64::from(spp) / 10.0;
        Row {
            integrator: "light".into(),
            spp,
            seconds,
            rays: 100,
            metrics: metrics(rel_mse),
            noise: None,
            split,
        }
    }

    /// A split with bias part `bias` ± `bias_se` of an MSE `mse`.
    fn split(mse: f64, bias: f64, bias_se: f64) -> Split {
        Split {
            error: mse,
            rel_mse: mse,
            rel_mse_se: 0.0,
            variance: mse - bias,
            reference_variance: 0.0,
            bias,
            bias_se,
            dof: 7,
            errors: metrics::ErrorSource::Replicas { test: 8, reference: 0 },
            pixels: 4,
            non_finite_variance: 0,
        }
    }

    #[test]
    fn csv_rows_have_every_column_and_empty_fields_for_missing_noise() {
        let path = Row { integrator: "path".into(), spp: 8, seconds: 1.5, ..row(8, 0.125, None) };
        let text = csv(&[path]);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], CSV_HEADER);
        assert!(CSV_HEADER.ends_with(metrics::SPLIT_CSV_COLUMNS));
        assert_eq!(lines[1], "path,8,1.5,100,0.25,0.5,0.125,0.4,6,1,,,0.1,1,20,0.5,0.25,,,,,,,,unknown");
        assert_eq!(lines[1].split(',').count(), CSV_HEADER.split(',').count());
        let biased = csv(&[row(8, 0.125, Some(split(0.25, 0.2, 0.01)))]);
        let line = biased.lines().nth(1).unwrap().to_string();
        assert!(line.ends_with(&format!(",0,0,0.2,0.01,{},biased", 3.0 * 0.01)), "{biased}");
    }

    #[test]
    fn the_slope_is_fitted_before_the_first_biased_checkpoint_and_the_rest_is_a_plateau() {
        // relMSE 1/N up to 4 spp, then flat at a bias floor: slope −1 over 1..4, plateau from 8.
        let rows = [
            row(1, 1.0, None),
            row(2, 0.5, Some(split(0.5, 0.01, 0.01))),
            row(4, 0.25, Some(split(0.25, 0.02, 0.01))),
            row(8, 0.2, Some(split(0.2, 0.1, 0.004))),
            row(16, 0.2, Some(split(0.2, 0.15, 0.003))),
        ];
        let g = regime(&rows);
        assert_eq!(g.variance_rows, 3);
        assert!((g.slope_spp.unwrap() + 1.0).abs() < 1e-12, "{g:?}");
        assert_eq!(g.plateau, Some(Plateau { from_spp: 8, bias: 0.15, bias_se: 0.003 }));
        let text = g.describe(&rows);
        assert!(text.contains("slope -1.00 against samples") && text.contains("(over 1–4 spp)"), "{text}");
        assert!(text.contains("plateau from 8 spp (bias part ≈ 0.150 ± 3.00e-3: biased)"), "{text}");
        assert_eq!(
            g.legend("light", g.slope_spp, &rows),
            "light (slope −1.00 to 4 spp, plateau from 8 spp: bias)"
        );
        // Fitted over every checkpoint, the slope would read as a slow rate (about −0.6).
        let all = fit_slope(&rows.iter().map(|r| (r.spp as f64, r.metrics.rel_mse)).collect::<Vec<_>>());
        assert!(all.unwrap() > -0.7);

        // Without bias: every checkpoint, no plateau; biased from the start: no slope.
        let unbiased = regime(&rows[..3]);
        assert_eq!((unbiased.variance_rows, unbiased.plateau), (3, None));
        let biased = regime(&rows[3..]);
        assert_eq!((biased.variance_rows, biased.slope_spp), (0, None));
        assert_eq!(biased.legend("ssaa", None, &rows[3..]), "ssaa (plateau from 8 spp: bias)");
    }
}
