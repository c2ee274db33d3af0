//! `vitrum report`: every scene × method at equal time (or samples), in one interactive page.
//!
//! Each scene is compared as `vitrum compare` compares it (the same budget for every method, the
//! same reference choice, [`crate::reference::choose_method`], cached), one scene after the
//! other under one progress bar over the whole run. Every input of every scene is checked before
//! the first render. `--out DIR` receives `index.html` (with `report.js`, `report.css` and
//! `data/`, see [`crate::report`]) and one folder per scene, named after its file, holding what
//! `compare` writes (`METHOD.exr`, `reference.exr`, `compare.png`, `compare.csv`, `compare.md`,
//! `compare-regions.csv` with `--region`).
//!
//! A scene is named on the command line by that folder's name ([`folder_names`]):
//! `--reference SCENE=REF.exr` gives it a reference file instead of the cached render (a bare
//! `REF.exr` when the report has one scene), and `--renders DIR` lays out `DIR/SCENE/METHOD.exr`
//! instead of rendering, so a previous report's folder (or merged cluster renders laid out the
//! same way) is reported again.

use crate::commands::compare::{self, Bars, CompareArgs, Plan};
use crate::commands::support::CliError;
use crate::commands::variants::{parse_methods, MethodSpec};
use crate::commands::SweepArgs;
use crate::report::Report;
use std::path::{Path, PathBuf};

/// Options of `vitrum report`.
#[derive(clap::Args, Debug, Clone)]
pub struct ReportArgs {
    /// Scene files (TOML), one section each.
    #[arg(required = true, value_name = "SCENE")]
    pub scenes: Vec<PathBuf>,
    /// Integrators, comma-separated, or `all`.
    #[arg(short, long, value_name = "LIST", default_value = "all")]
    pub integrators: String,
    /// Equal time: each method renders whole passes until this many seconds have passed (default 10).
    #[arg(long, value_name = "SECONDS", value_parser = compare::parse_seconds, conflicts_with = "spp", allow_negative_numbers = true)]
    pub time: Option<f64>,
    /// Equal samples: each method takes this many samples per pixel.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..), allow_negative_numbers = true)]
    pub spp: Option<u32>,
    /// A scene's reference file instead of its cached render: SCENE=REF.exr, SCENE the scene's
    /// folder in the report (its file's stem); REF.exr alone when the report has one scene.
    /// Repeatable, once per scene; a scene without one gets the cached reference.
    #[arg(long = "reference", value_name = "[SCENE=]REF.exr", value_parser = parse_reference)]
    pub references: Vec<ReferenceArg>,
    /// Samples per pixel of each scene's reference (default 1024), rendered or read from the cache.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..), allow_negative_numbers = true)]
    pub reference_spp: Option<u32>,
    /// The method of every reference (default: chosen per scene, as `compare` does).
    #[arg(long, value_name = "NAME")]
    pub reference_method: Option<String>,
    /// Folder of cached references (default `.vitrum-cache`).
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
    /// Zoomed insets of this rectangle in every scene's figure, X,Y,W,H in pixels.
    #[arg(long, value_name = "X,Y,W,H", value_parser = super::parse_crop)]
    pub crop: Option<super::CropArg>,
    /// Also measure every method over this named rectangle of every scene (NAME=X,Y,W,H;
    /// repeatable), as `compare --region` does.
    #[arg(long = "region", value_name = "NAME=X,Y,W,H", value_parser = super::parse_region)]
    pub regions: Vec<super::RegionArg>,
    /// Also measure every method over the white pixels of this PNG in every scene
    /// ([NAME=]FILE.png; repeatable), as `compare --mask` does (every scene at the mask's size).
    #[arg(long = "mask", value_name = "[NAME=]FILE.png", value_parser = super::parse_mask)]
    pub masks: Vec<super::MaskArg>,
    /// Render every method K times per scene for intervals over seeds, as `compare --repeat`.
    #[arg(long, value_name = "K", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=compare::MAX_REPEAT as i64), conflicts_with = "renders")]
    pub repeat: u32,
    /// At most N panels per row of every scene's `compare.png`.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..), allow_negative_numbers = true)]
    pub columns: Option<u32>,
    /// Exposure the viewers start at, in stops (default: each scene's own).
    #[arg(long, value_name = "EV", value_parser = super::diff::parse_exposure, allow_hyphen_values = true)]
    pub exposure: Option<f32>,
    /// Render options shared by every integrator and scene.
    #[command(flatten)]
    pub render: SweepArgs,
    /// Output folder (created if missing; its parent must exist).
    #[arg(long, value_name = "DIR", default_value = "report")]
    pub out: PathBuf,
    /// No progress bar and no summary (warnings still go to stderr).
    #[arg(long)]
    pub quiet: bool,
    /// Lay out renders instead of rendering: DIR/SCENE/METHOD.exr for every scene (SCENE its
    /// folder in the report) and every method of -i (with `all`, each method's file that is
    /// there), as a previous report's --out holds them.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["time", "spp"])]
    pub renders: Option<PathBuf>,
}

/// A `--reference` of `report`: a reference file, for the scene named or the only scene.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ReferenceArg {
    /// The scene's folder name (`SCENE=`); `None` for the report's only scene.
    pub scene: Option<String>,
    /// The reference EXR.
    pub path: PathBuf,
}

/// Parses `SCENE=REF.exr` or `REF.exr`; text before the first `=` is a scene's name unless it
/// holds a path separator (so `./a=b.exr` is a file whose name has a `=`).
pub fn parse_reference(s: &str) -> Result<ReferenceArg, String> {
    let named = s.split_once('=').filter(|(scene, _)| !scene.is_empty() && !scene.contains(['/', '\\']));
    let (scene, path) = match named {
        Some((scene, path)) => (Some(scene.to_string()), path),
        None => (None, s),
    };
    if path.is_empty() {
        return Err(format!(
            "`{s}` names no file: write SCENE=REF.exr, or REF.exr for a report of one scene"
        ));
    }
    Ok(ReferenceArg { scene, path: PathBuf::from(path) })
}

/// The files one scene of the report is measured from, instead of the cache and renders.
#[derive(Clone, Debug, Default, PartialEq)]
struct SceneFiles {
    /// Its `--reference` file, if it was given one.
    reference: Option<PathBuf>,
    /// Its `--renders`, one per method; empty when it is rendered.
    renders: Vec<PathBuf>,
    /// The size of its first render, which its cached reference takes when no `--resolution`
    /// is given (the renders' own size, as the renders were made at).
    size: Option<(u32, u32)>,
}

/// The folder names of `scenes` inside the report: each file's stem (characters other than
/// letters, digits, `-`, `_` and `.` as `_`; `scene-` before a stem that is empty, starts with a
/// dot or is one of the report's own names), made unique by `-2`, `-3`, ….
fn folder_names(scenes: &[PathBuf]) -> Vec<String> {
    let mut names: Vec<String> = Vec::with_capacity(scenes.len());
    for scene in scenes {
        let stem = scene.file_stem().map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        let stem: String =
            stem.chars().map(|c| if c.is_alphanumeric() || "-_.".contains(c) { c } else { '_' }).collect();
        let reserved = crate::report::RESERVED_NAMES.iter().any(|r| r.eq_ignore_ascii_case(&stem));
        let stem =
            if stem.is_empty() || stem.starts_with('.') || reserved { format!("scene-{stem}") } else { stem };
        let mut name = stem.clone();
        let mut n = 2;
        while names.contains(&name) {
            name = format!("{stem}-{n}");
            n += 1;
        }
        names.push(name);
    }
    names
}

/// Each scene's `--reference` and `--renders` files, in the order of `names` (the scenes' folder
/// names); bad input when one names no scene of the report or a file is missing.
fn scene_files(args: &ReportArgs, names: &[String]) -> Result<Vec<SceneFiles>, CliError> {
    let references = scene_references(&args.references, names)?;
    let renders = match &args.renders {
        Some(dir) => scene_renders(dir, args, names)?,
        None => vec![Vec::new(); names.len()],
    };
    references
        .into_iter()
        .zip(renders)
        .map(|(reference, renders)| {
            let size = match renders.first() {
                Some(first) if args.render.resolution.is_none() => Some(render_size(first)?),
                _ => None,
            };
            Ok(SceneFiles { reference, renders, size })
        })
        .collect()
}

/// The width and height of the EXR render at `path`, read from its header alone.
fn render_size(path: &Path) -> Result<(u32, u32), CliError> {
    let bad = |what: String| CliError::BadInput(format!("--renders {}: {what}", path.display()));
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| bad(e.to_string()))?;
    let size =
        meta.headers.first().map(|h| h.layer_size).ok_or_else(|| bad("an EXR without layers".into()))?;
    let side = |n: usize| u32::try_from(n).map_err(|_| bad(format!("{}x{} pixels", size.0, size.1)));
    Ok((side(size.0)?, side(size.1)?))
}

/// Each scene's `--reference` file, in the order of `names` (`None`: the cached reference).
fn scene_references(references: &[ReferenceArg], names: &[String]) -> Result<Vec<Option<PathBuf>>, CliError> {
    let bad = |m: String| CliError::BadInput(m);
    let mut chosen: Vec<Option<PathBuf>> = vec![None; names.len()];
    for r in references {
        let index = match &r.scene {
            Some(scene) => names.iter().position(|n| n == scene).ok_or_else(|| {
                bad(format!(
                    "--reference {scene}={}: the report has no scene `{scene}` (its scenes: {}; a file \
                     whose name holds `=` is written ./NAME)",
                    r.path.display(),
                    names.join(", ")
                ))
            })?,
            None if names.len() == 1 => 0,
            None => {
                return Err(bad(format!(
                    "--reference {}: the report has {} scenes; name the one it is for as \
                     SCENE=REF.exr, SCENE one of {}",
                    r.path.display(),
                    names.len(),
                    names.join(", ")
                )))
            }
        };
        if chosen[index].replace(r.path.clone()).is_some() {
            return Err(bad(format!("--reference: the scene `{}` is given two references", names[index])));
        }
    }
    Ok(chosen)
}

/// Each scene's renders under `dir`, in the order of `names`: `dir/NAME/STEM.exr` for every
/// method of `-i`, each required unless `-i` is `all` (then those that are there, at least one).
fn scene_renders(dir: &Path, args: &ReportArgs, names: &[String]) -> Result<Vec<Vec<PathBuf>>, CliError> {
    let bad = |what: String| CliError::BadInput(format!("--renders {}: {what}", dir.display()));
    if !dir.is_dir() {
        return Err(bad("not a folder".into()));
    }
    if matches!((dir.canonicalize(), args.out.canonicalize()), (Ok(d), Ok(o)) if d == o) {
        return Err(bad(
            "is the --out folder, whose renders the report would replace; choose another --out".into()
        ));
    }
    let methods = parse_methods(&args.integrators)?;
    let every = args.integrators.trim() == "all";
    let in_folder = |name: &String, scene: &PathBuf| -> Result<Vec<PathBuf>, String> {
        let folder = dir.join(name);
        if !folder.is_dir() {
            return Err(format!("no folder `{name}` for the scene {}", scene.display()));
        }
        let files =
            folder_renders(&folder, &methods, every).map_err(|stem| format!("no {name}/{stem}.exr"))?;
        if files.is_empty() {
            return Err(format!("{name}/ holds no render of a method of -i (METHOD.exr)"));
        }
        Ok(files)
    };
    names.iter().zip(&args.scenes).map(|(name, scene)| in_folder(name, scene).map_err(bad)).collect()
}

/// The files `folder/STEM.exr` of `methods` that are there, in their order; the first missing
/// file's STEM when `every` is false (each method named by `-i` must have its file).
fn folder_renders(folder: &Path, methods: &[MethodSpec], every: bool) -> Result<Vec<PathBuf>, String> {
    let mut files = Vec::new();
    for stem in methods.iter().map(MethodSpec::file_stem) {
        let file = folder.join(format!("{stem}.exr"));
        if file.is_file() {
            files.push(file);
        } else if !every {
            return Err(stem);
        }
    }
    Ok(files)
}

/// The `compare` options of one scene of the report, measured from `files` where given.
fn compare_args(args: &ReportArgs, scene: &Path, files: SceneFiles, out: PathBuf) -> CompareArgs {
    CompareArgs {
        scene: Some(scene.to_path_buf()),
        integrators: args.integrators.clone(),
        time: args.time,
        spp: args.spp,
        reference: files.reference,
        reference_spp: args.reference_spp,
        reference_method: args.reference_method.clone(),
        cache: args.cache.clone(),
        crop: args.crop,
        regions: args.regions.clone(),
        masks: args.masks.clone(),
        columns: args.columns,
        exposure: args.exposure,
        render: SweepArgs { resolution: args.render.resolution.or(files.size), ..args.render.clone() },
        out,
        quiet: args.quiet,
        renders: files.renders,
        repeat: args.repeat,
    }
}

/// Runs `vitrum report`.
pub fn run(args: &ReportArgs) -> Result<(), CliError> {
    compare::check_out_folder(&args.out)?;
    let names = folder_names(&args.scenes);
    let files = scene_files(args, &names)?;
    // The scene folders' parent must exist for their plans; a folder made here is removed again
    // when a plan fails, so bad input leaves nothing behind.
    let created = !args.out.exists();
    if created {
        std::fs::create_dir(&args.out).map_err(|e| {
            CliError::Failure(format!("--out {}: cannot create the folder: {e}", args.out.display()))
        })?;
    }
    let plans: Result<Vec<(CompareArgs, Plan)>, CliError> = args
        .scenes
        .iter()
        .zip(&names)
        .zip(files)
        .map(|((scene, name), files)| {
            let scene_args = compare_args(args, scene, files, args.out.join(name));
            Plan::new(&scene_args).map(|plan| (scene_args, plan))
        })
        .collect();
    let result = plans.and_then(|plans| render_all(args, &names, &plans));
    if result.is_err() && created {
        // Removes only what is empty: published scene folders stay.
        let _ = std::fs::remove_dir(&args.out);
    }
    result
}

/// Renders every planned scene, publishing each scene's folder as it is done; the sections of
/// the page.
fn render_sections(
    args: &ReportArgs,
    names: &[String],
    plans: &[(CompareArgs, Plan)],
    pool: &rayon::ThreadPool,
    bars: &Bars,
) -> Result<Vec<crate::report::Section>, CliError> {
    let mut sections = Vec::with_capacity(plans.len());
    for ((scene_args, plan), name) in plans.iter().zip(names) {
        let outcome = compare::render_scene(plan, scene_args, pool, bars)?;
        compare::publish(plan, &outcome, None)?;
        if !args.quiet {
            bars.suspend(|| {
                eprintln!("{name}:");
                compare::print_summary(&outcome);
            });
        }
        sections.push(compare::section(plan, &outcome, name));
    }
    Ok(sections)
}

/// Renders every planned scene (each scene's folder published as it is done), then the page.
fn render_all(args: &ReportArgs, names: &[String], plans: &[(CompareArgs, Plan)]) -> Result<(), CliError> {
    for (_, plan) in plans {
        for w in plan.warnings() {
            eprintln!("vitrum: warning: {w}");
        }
    }
    let pool = args.render.pool()?;
    let bars = Bars::new("report", plans.iter().map(|(_, p)| p.renders()).sum(), args.quiet);
    let sections = render_sections(args, names, plans, &pool, &bars);
    bars.finish();
    let sections = sections?;
    let scenes =
        if sections.len() == 1 { "1 scene".to_string() } else { format!("{} scenes", sections.len()) };
    let report = Report {
        title: format!("vitrum report: {scenes}"),
        sections,
        command: crate::report::command_line(),
        machine: crate::report::machine::describe(),
    };
    crate::report::write(&args.out, &report).map_err(|e| CliError::Failure(e.to_string()))?;
    if !args.quiet {
        eprintln!("report: {} -> {}", scenes, args.out.join("index.html").display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn references_name_their_scene_unless_the_text_before_the_equals_sign_is_a_path() {
        let named = |scene: Option<&str>, path: &str| ReferenceArg {
            scene: scene.map(String::from),
            path: path.into(),
        };
        assert_eq!(parse_reference("box=ref.exr"), Ok(named(Some("box"), "ref.exr")));
        assert_eq!(parse_reference("box=a=b.exr"), Ok(named(Some("box"), "a=b.exr")));
        assert_eq!(parse_reference("ref.exr"), Ok(named(None, "ref.exr")));
        assert_eq!(parse_reference("./a=b.exr"), Ok(named(None, "./a=b.exr")));
        assert!(parse_reference("box=").is_err());
        assert!(parse_reference("").is_err());
    }

    #[test]
    fn each_scene_gets_at_most_one_reference_and_a_bare_one_only_alone() {
        let names = |n: &[&str]| n.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let refs = |texts: &[&str]| texts.iter().map(|t| parse_reference(t).unwrap()).collect::<Vec<_>>();
        assert_eq!(
            scene_references(&refs(&["b=r.exr"]), &names(&["a", "b"])).unwrap(),
            [None, Some(PathBuf::from("r.exr"))]
        );
        assert_eq!(
            scene_references(&refs(&["r.exr"]), &names(&["a"])).unwrap(),
            [Some(PathBuf::from("r.exr"))]
        );
        for (texts, scenes) in [
            (&["c=r.exr"][..], &["a", "b"][..]),
            (&["r.exr"], &["a", "b"]),
            (&["a=r.exr", "a=s.exr"], &["a", "b"]),
            (&["r.exr", "a=s.exr"], &["a"]),
        ] {
            let result = scene_references(&refs(texts), &names(scenes));
            assert!(
                matches!(result, Err(CliError::BadInput(ref m)) if m.starts_with("--reference")),
                "{texts:?}"
            );
        }
    }

    #[test]
    fn scene_folders_are_unique_and_safe() {
        let scenes: Vec<PathBuf> =
            ["a/box.toml", "b/box.toml", "c/box.toml", "x y.toml"].iter().map(PathBuf::from).collect();
        assert_eq!(folder_names(&scenes), ["box", "box-2", "box-3", "x_y"]);
        // The report's own names and names that would leave the folder are never taken.
        let scenes: Vec<PathBuf> =
            ["data.toml", "report.js.toml", "...toml", "index.html.toml", ".toml", "Data.toml"]
                .iter()
                .map(PathBuf::from)
                .collect();
        assert_eq!(
            folder_names(&scenes),
            ["scene-data", "scene-report.js", "scene-..", "scene-index.html", "scene-.toml", "scene-Data"]
        );
    }
}
