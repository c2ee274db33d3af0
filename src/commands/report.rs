//! `vitrum report`: every scene × method at equal time (or samples), in one interactive page.
//!
//! Each scene is compared as `vitrum compare` compares it (the same budget for every method, the
//! same reference choice, [`crate::reference::choose_method`], cached), one scene after the
//! other under one progress bar over the whole run. Every input of every scene is checked before
//! the first render. `--out DIR` receives `index.html` (with `report.js`, `report.css` and
//! `data/`, see [`crate::report`]) and one folder per scene, named after its file, holding what
//! `compare` writes (`METHOD.exr`, `compare.png`, `compare.csv`, `compare.md`).

use crate::commands::compare::{self, Bars, CompareArgs, Plan};
use crate::commands::support::CliError;
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

/// The `compare` options of one scene of the report.
fn compare_args(args: &ReportArgs, scene: &Path, out: PathBuf) -> CompareArgs {
    CompareArgs {
        scene: Some(scene.to_path_buf()),
        integrators: args.integrators.clone(),
        time: args.time,
        spp: args.spp,
        reference: None,
        reference_spp: args.reference_spp,
        reference_method: args.reference_method.clone(),
        cache: args.cache.clone(),
        crop: args.crop,
        regions: args.regions.clone(),
        masks: Vec::new(),
        columns: None,
        exposure: args.exposure,
        render: args.render.clone(),
        out,
        quiet: args.quiet,
        renders: Vec::new(),
        repeat: 1,
    }
}

/// Runs `vitrum report`.
pub fn run(args: &ReportArgs) -> Result<(), CliError> {
    compare::check_out_folder(&args.out)?;
    let names = folder_names(&args.scenes);
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
        .map(|(scene, name)| {
            let scene_args = compare_args(args, scene, args.out.join(name));
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
