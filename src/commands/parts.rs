//! `vitrum render` in parts, on [`crate::parts`]: shards (`--samples A..B`, `--shard I/N`),
//! checkpoints (`--checkpoint SECONDS`) and resume (`--resume FILE`). Each writes its output
//! with the film layer of [`crate::output::film`], which `--resume` continues and
//! `vitrum merge` combines.

use crate::commands::render::RenderArgs;
use crate::commands::support::CliError;
use crate::integrators::Integrator;
use crate::output::exr::ExrMetadata;
use crate::output::film::{read_part, stage_part, PartFile};
use crate::parts::{Identity, Part, PartInfo, SampleSet};
use crate::render::{self, Budget, Film, Progression, RenderOptions, RenderOutput};
use crate::scene::compile::DEFAULT_SCENE_NAME;
use crate::scene::Scene;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Read the part that `--resume` names; a file that is not one is bad input.
pub fn read_resumed(path: &Path) -> Result<PartFile, CliError> {
    read_part(path).map_err(|e| CliError::BadInput(format!("--resume: {e}")))
}

/// Whether the resumed part `file` is finished: it holds all its target samples, or a time
/// budget's render time is spent.
pub fn finished(file: &PartFile) -> bool {
    let (film, info) = (&file.part.film, &file.part.info);
    match info.time_budget {
        Some(t) => film.seconds >= t,
        None => {
            info.samples.as_range().is_some_and(|r| r.start == info.target.start && r.end >= info.target.end)
        }
    }
}

/// `args` with every render setting it leaves open taken from the resumed part `file` (the
/// scene file it was rendered from, the integrator, seed, resolution, sampler, maximum depth,
/// merge radius and its α, whether it traced wavelengths and the reflectance), and the output defaulting to the
/// resumed file.
pub fn resume_defaults(args: &RenderArgs, file: &PartFile) -> Result<RenderArgs, CliError> {
    let path = args.resume.clone().expect("called for --resume");
    let id = &file.part.info.identity;
    let bad = |field: &str| {
        CliError::BadInput(format!("--resume {}: its vitrum:settings have no valid {field}", path.display()))
    };
    let field = |name: &str| id.get(name).ok_or_else(|| bad(name));
    let mut a = args.clone();
    if a.scene.is_none() && file.part.info.scene_file != DEFAULT_SCENE_NAME {
        a.scene = Some(PathBuf::from(&file.part.info.scene_file));
    }
    a.integrator.get_or_insert(field("integrator")?.to_string());
    if a.seed.is_none() {
        a.seed = Some(field("seed")?.parse().map_err(|_| bad("seed"))?);
    }
    if a.resolution.is_none() {
        a.resolution = Some(
            crate::commands::support::parse_resolution(field("resolution")?)
                .map_err(|_| bad("resolution"))?,
        );
    }
    a.sampler.get_or_insert(field("sampler")?.to_string());
    if a.max_depth.is_none() {
        a.max_depth = Some(field("max-depth")?.parse().map_err(|_| bad("max-depth"))?);
    }
    if a.radius.is_none() {
        a.radius = id.get("radius").map(|r| r.parse().map_err(|_| bad("radius"))).transpose()?;
    }
    if a.radius_alpha.is_none() {
        a.radius_alpha =
            id.get("radius-alpha").map(|r| r.parse().map_err(|_| bad("radius-alpha"))).transpose()?;
    }
    if a.max_light_paths.is_none() {
        a.max_light_paths = id.get("max-light-paths").map(str::to_string);
    }
    if a.strategy.is_none() {
        a.strategy = id.get("strategy").map(str::to_string);
    }
    let wavelengths = if field("wavelengths")? == "yes" { "on" } else { "off" };
    a.spectral.get_or_insert(wavelengths.to_string());
    if a.reflectance.is_none() {
        a.reflectance = match field("reflectance")? {
            "fresnel" => None,
            r => Some(r.parse().map_err(|_| bad("reflectance"))?),
        };
    }
    a.output.get_or_insert(path);
    Ok(a)
}

/// The scene file as a part records it: its absolute path (so that `--resume` finds it from
/// any folder), or the name of the embedded default scene.
fn scene_file(args: &RenderArgs) -> String {
    match &args.scene {
        Some(p) => std::fs::canonicalize(p).unwrap_or_else(|_| p.clone()).display().to_string(),
        None => DEFAULT_SCENE_NAME.to_string(),
    }
}

/// What a part is asked to render: its sample indices, the sample count they are drawn as
/// samples of, and for a time budget its render seconds in all.
struct Target {
    samples: Range<u32>,
    planned: u32,
    time_budget: Option<f64>,
}

/// The render part that `args` ask for, with `opts` set to render it (the budget up to the
/// part's last sample index or the time left, the sampler's plan), or `None` for a plain
/// render: a shard, a resumed part (checked to be a part of the render these options describe)
/// or a checkpointed render.
pub fn plan(
    args: &RenderArgs,
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &mut RenderOptions,
    resumed: Option<PartFile>,
) -> Result<Option<Part>, CliError> {
    let option = match (&resumed, &args.samples, &args.shard, args.checkpoint) {
        (Some(_), ..) => "--resume",
        (_, Some(_), ..) => "--samples",
        (_, _, Some(_), _) => "--shard",
        (.., Some(_)) => "--checkpoint",
        _ => return Ok(None),
    };
    let bad = |message: String| Err(CliError::BadInput(message));
    if let Some(t) = args.checkpoint {
        if !(t.is_finite() && t >= 0.0) {
            return bad(format!(
                "--checkpoint {t}: seconds between checkpoints, 0 or more (0: after every pass)"
            ));
        }
    }
    if let Progression::Fixed(image) = integrator.progression() {
        let why = image.why();
        return bad(format!("{option}: `{}` cannot be rendered in parts: {why}", integrator.name()));
    }
    let target = match (&resumed, args.samples.clone(), args.shard, opts.budget) {
        (Some(file), ..) => resumed_target(args, file, opts)?,
        (None, Some(r), _, Budget::Samples(n)) => {
            let planned = if args.spp.is_some() { n } else { r.end };
            if r.end > planned {
                return bad(format!(
                    "--samples {}..{}: beyond the --spp {planned} samples of the render",
                    r.start, r.end
                ));
            }
            Target { samples: r, planned, time_budget: None }
        }
        (None, None, Some(shard), Budget::Samples(n)) => {
            let r = shard.range(n);
            if r.is_empty() {
                return bad(format!(
                    "--shard {}/{}: empty, the render has only {n} samples per pixel (use at most {n} shards)",
                    shard.index, shard.count
                ));
            }
            Target { samples: r, planned: n, time_budget: None }
        }
        (None, None, None, Budget::Samples(n)) => Target { samples: 0..n, planned: n, time_budget: None },
        // A time budget: its samples are open-ended and drawn without a plan.
        (None, _, _, Budget::Time(t)) => {
            Target { samples: 0..0, planned: 0, time_budget: Some(t.as_secs_f64()) }
        }
    };
    if let Budget::Samples(_) = opts.budget {
        opts.budget = Budget::Samples(target.samples.end);
    }
    opts.planned_spp = (target.planned > 0).then_some(target.planned);
    let fresh = render::part_film(scene, integrator, opts, target.samples.start).map_err(|why| {
        CliError::BadInput(format!("{option}: `{}` cannot be rendered in parts: {why}", integrator.name()))
    })?;
    let identity = Identity::new(scene, integrator.name(), opts, (fresh.width, fresh.height), fresh.spectral);
    let film = match resumed {
        Some(file) => {
            let path = args.resume.as_deref().expect("resuming").display();
            if let Some((field, was, now)) = file.part.info.identity.difference(&identity) {
                return bad(format!(
                    "--resume {path}: it was rendered with {field} {was}; these options give {now}"
                ));
            }
            if (file.part.film.width, file.part.film.height, file.part.film.norm)
                != (fresh.width, fresh.height, fresh.norm)
            {
                return bad(format!("--resume {path}: its film does not match this render's"));
            }
            file.part.film
        }
        None => fresh,
    };
    let info = PartInfo {
        identity,
        samples: SampleSet::of(film.sample_range()),
        target: target.samples,
        planned: target.planned,
        time_budget: target.time_budget,
        scene_file: scene_file(args),
    };
    Ok(Some(Part { film, info }))
}

/// The target of resuming `file`, setting `opts.budget`: the rest of its target samples or of
/// its time budget, up to a larger `--spp`, or `--time` more seconds.
fn resumed_target(args: &RenderArgs, file: &PartFile, opts: &mut RenderOptions) -> Result<Target, CliError> {
    let path = args.resume.as_deref().expect("resuming").display();
    let (film, info) = (&file.part.film, &file.part.info);
    let bad = |message: String| Err(CliError::BadInput(format!("--resume {path}: {message}")));
    let Some(done) = info.samples.as_range().filter(|r| r.is_empty() || r.start == info.target.start) else {
        return bad(format!(
            "it holds the samples {}, not one range from {}: only a single part can be resumed",
            info.samples, info.target.start
        ));
    };
    let so_far = info.target.start..done.end;
    match (opts.budget, args.spp, args.time) {
        (Budget::Time(t), ..) => {
            let total = film.seconds + t.as_secs_f64();
            Ok(Target { samples: so_far, planned: 0, time_budget: Some(total) })
        }
        (Budget::Samples(n), Some(_), _) => {
            if n <= done.end {
                return bad(format!(
                    "it already holds the samples {}; --spp {n} asks for no more",
                    info.samples
                ));
            }
            if info.target.end < info.planned {
                return bad(format!(
                    "it is the shard {}..{} of a {}-sample render: a larger --spp would take the samples of \
                     other shards; render more shards instead",
                    info.target.start, info.target.end, info.planned
                ));
            }
            if info.plan_matters() && n != info.planned {
                return bad(format!(
                    "its samples were drawn from a {}-sample plan ({} sampler), which cannot grow: resume with \
                     --spp {} or render anew",
                    info.planned,
                    info.identity.get("sampler").unwrap_or("?"),
                    info.planned
                ));
            }
            Ok(Target { samples: info.target.start..n, planned: info.planned.max(n), time_budget: None })
        }
        // The rest of a time budget (nothing when it is spent).
        (Budget::Samples(_), None, None) if info.time_budget.is_some() => {
            let left = info.time_budget.unwrap_or(0.0) - film.seconds;
            opts.budget = match Duration::try_from_secs_f64(left) {
                Ok(left) if left > Duration::ZERO => Budget::Time(left),
                _ => Budget::Samples(done.end),
            };
            Ok(Target { samples: so_far, planned: 0, time_budget: info.time_budget })
        }
        (Budget::Samples(_), None, _) => {
            Ok(Target { samples: info.target.clone(), planned: info.planned, time_budget: None })
        }
    }
}

/// Writes checkpoints of a render part at pass boundaries, every `every` seconds or more.
pub struct Checkpoints<'a> {
    path: &'a Path,
    every: Option<Duration>,
    last: Instant,
    meta: &'a (dyn Fn(&Film) -> ExrMetadata + Sync),
    info: PartInfo,
}

impl<'a> Checkpoints<'a> {
    /// Checkpoints of `part` to `path` every `seconds` (none without), with the header `meta`.
    pub fn new(
        path: &'a Path,
        seconds: Option<f64>,
        part: &Part,
        meta: &'a (dyn Fn(&Film) -> ExrMetadata + Sync),
    ) -> Checkpoints<'a> {
        let every = seconds.map(Duration::from_secs_f64);
        Checkpoints { path, every, last: Instant::now(), meta, info: part.info.clone() }
    }

    /// After a sample pass: write the checkpoint when one is due (atomically; a failure to
    /// write is a warning, the render goes on).
    fn after_pass(&mut self, film: &Film) {
        let Some(every) = self.every else { return };
        if self.last.elapsed() < every {
            return;
        }
        let info = &mut self.info;
        info.samples = SampleSet::of(film.sample_range());
        info.target.end = info.target.end.max(film.next_sample());
        let note = format!("{} of the samples {}..{}", info.samples, info.target.start, info.target.end);
        let notes = [("vitrum:checkpoint".to_string(), note)];
        let staged = stage_part(self.path, film, info, &(self.meta)(film), &[], &notes);
        if let Err(e) = staged.and_then(|s| s.commit()) {
            eprintln!("vitrum: warning: checkpoint not written: {e}");
        }
        self.last = Instant::now();
    }
}

/// Render `part` under `opts` (from [`plan`]), writing `checkpoints`; the part then holds the
/// samples done (all of its target unless a stop was requested).
pub fn render(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    part: &mut Part,
    progress: &(dyn Fn(u64, u64) + Sync),
    checkpoints: &mut Checkpoints<'_>,
) -> RenderOutput {
    render::render_part(scene, integrator, opts, &mut part.film, progress, &mut |film| {
        checkpoints.after_pass(film)
    })
    .expect("plan refuses methods that cannot render in parts");
    part.info.samples = SampleSet::of(part.film.sample_range());
    part.info.target.end = part.info.target.end.max(part.film.next_sample());
    part.film.output()
}
