//! `vitrum render` in parts, on [`crate::parts`]: shards (`--samples A..B`, `--shard I/N`),
//! checkpoints (`--checkpoint SECONDS`) and resume (`--resume FILE`). Each writes its output
//! with the film layer of [`crate::output::film`], which `--resume` continues and
//! `vitrum merge` combines.

use crate::cli::{CliError, RenderArgs};
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

/// Whether resuming `file` with `args` has nothing to do: the part holds all its target samples
/// and neither a larger `--spp` nor `--time` asks for more (a job restarted after it finished).
pub fn nothing_to_resume(args: &RenderArgs, file: &PartFile) -> bool {
    let part = &file.part;
    let done = part
        .info
        .samples
        .as_range()
        .is_some_and(|r| r.start == part.info.target.start && r.end >= part.info.target.end);
    done && args.spp.is_none() && args.time.is_none()
}

/// `args` with every render setting it leaves open taken from the resumed part `file` (the
/// scene file it was rendered from, the integrator, seed, resolution, sampler, maximum depth,
/// spectral mode and reflectance), and the output defaulting to the resumed file.
pub fn resume_defaults(args: &RenderArgs, file: &PartFile) -> Result<RenderArgs, CliError> {
    let path = args.resume.clone().expect("called for --resume");
    let id = &file.part.info.identity;
    let bad = |field: &str| {
        CliError::BadInput(format!("--resume {}: its vitrum:settings have no valid {field}", path.display()))
    };
    let field = |name: &str| id.get(name).ok_or_else(|| bad(name));
    let mut a = args.clone();
    if a.scene.is_none() {
        let scene = file.attributes.get("vitrum:scene").ok_or_else(|| bad("vitrum:scene"))?;
        let name = scene.rsplit_once(" (").map_or(scene.as_str(), |(name, _)| name);
        if name != DEFAULT_SCENE_NAME {
            a.scene = Some(PathBuf::from(name));
        }
    }
    a.integrator.get_or_insert(field("integrator")?.to_string());
    if a.seed.is_none() {
        a.seed = Some(field("seed")?.parse().map_err(|_| bad("seed"))?);
    }
    if a.resolution.is_none() {
        a.resolution =
            Some(crate::cli::parse_resolution(field("resolution")?).map_err(|_| bad("resolution"))?);
    }
    a.sampler.get_or_insert(field("sampler")?.to_string());
    if a.max_depth.is_none() {
        a.max_depth = Some(field("max-depth")?.parse().map_err(|_| bad("max-depth"))?);
    }
    a.spectral.get_or_insert(field("spectral")?.to_string());
    if a.reflectance.is_none() {
        a.reflectance = match field("reflectance")? {
            "fresnel" => None,
            r => Some(r.parse().map_err(|_| bad("reflectance"))?),
        };
    }
    a.output.get_or_insert(path);
    Ok(a)
}

/// The render part that `args` ask for, with `opts` set to render it (the budget up to the
/// part's last sample index, the sampler's plan), or `None` for a plain render: a shard, a
/// resumed part (checked to be a part of the render these options describe) or a checkpointed
/// render.
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
    if let Progression::Fixed(why) | Progression::Fresh(why) = integrator.progression() {
        return bad(format!("{option}: `{}` cannot be rendered in parts: {why}", integrator.name()));
    }
    // The sample indices asked for, and the sample count they are drawn as samples of.
    let (target, planned) = match (&resumed, args.samples.clone(), args.shard, opts.budget) {
        (Some(file), ..) => resumed_target(args, file, opts.budget)?,
        (None, Some(r), _, Budget::Samples(n)) => {
            let planned = if args.spp.is_some() { n } else { r.end };
            if r.end > planned {
                return bad(format!(
                    "--samples {}..{}: beyond the --spp {planned} samples of the render",
                    r.start, r.end
                ));
            }
            (r, planned)
        }
        (None, None, Some(shard), Budget::Samples(n)) => {
            let r = shard.range(n);
            if r.is_empty() {
                return bad(format!(
                    "--shard {}/{}: empty, the render has only {n} samples per pixel (use at most {n} shards)",
                    shard.index, shard.count
                ));
            }
            (r, n)
        }
        (None, None, None, Budget::Samples(n)) => (0..n, n),
        // A time budget: its samples are open-ended and drawn without a plan.
        (None, _, _, Budget::Time(_)) => (0..0, 0),
    };
    if let Budget::Samples(_) = opts.budget {
        opts.budget = Budget::Samples(target.end);
    }
    opts.planned_spp = (planned > 0).then_some(planned);
    let fresh = render::part_film(scene, integrator, opts, target.start).map_err(|why| {
        CliError::BadInput(format!("{option}: `{}` cannot be rendered in parts: {why}", integrator.name()))
    })?;
    let identity = Identity::new(scene, integrator.name(), opts, (fresh.width, fresh.height), fresh.spectral);
    let film = match resumed {
        Some(file) => {
            if let Some((field, was, now)) = file.part.info.identity.difference(&identity) {
                let path = args.resume.as_deref().expect("resuming").display();
                return bad(format!(
                    "--resume {path}: it was rendered with {field} {was}; these options give {now}"
                ));
            }
            if (file.part.film.width, file.part.film.height, file.part.film.norm)
                != (fresh.width, fresh.height, fresh.norm)
            {
                let path = args.resume.as_deref().expect("resuming").display();
                return bad(format!("--resume {path}: its film does not match this render's"));
            }
            file.part.film
        }
        None => fresh,
    };
    let samples = SampleSet::of(film.sample_range());
    Ok(Some(Part { film, info: PartInfo { identity, samples, target, planned } }))
}

/// The target and plan of resuming `file` under `budget`: the rest of its target, up to a
/// larger `--spp`, or `--time` more seconds; checked against the options' identity.
fn resumed_target(args: &RenderArgs, file: &PartFile, budget: Budget) -> Result<(Range<u32>, u32), CliError> {
    let path = args.resume.as_deref().expect("resuming").display();
    let part = &file.part;
    let bad = |message: String| Err(CliError::BadInput(format!("--resume {path}: {message}")));
    let Some(done) =
        part.info.samples.as_range().filter(|r| r.is_empty() || r.start == part.info.target.start)
    else {
        return bad(format!(
            "it holds the samples {}, not one range from {}: only a single part can be resumed",
            part.info.samples, part.info.target.start
        ));
    };
    match (budget, args.spp) {
        (Budget::Time(_), _) => Ok((part.info.target.start..done.end, 0)),
        (Budget::Samples(n), Some(_)) => {
            if n <= done.end {
                return bad(format!(
                    "it already holds the samples {}; --spp {n} asks for no more",
                    part.info.samples
                ));
            }
            if part.info.plan_matters() && n != part.info.planned {
                return bad(format!(
                    "its samples were drawn from a {}-sample plan ({} sampler), which cannot grow: resume with \
                     --spp {} or render anew",
                    part.info.planned,
                    part.info.identity.get("sampler").unwrap_or("?"),
                    part.info.planned
                ));
            }
            Ok((part.info.target.start..n, part.info.planned.max(n)))
        }
        (Budget::Samples(_), None) => Ok((part.info.target.clone(), part.info.planned)),
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
