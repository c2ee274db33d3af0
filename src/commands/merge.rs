//! `vitrum merge PARTS... -o OUT.exr`: combine the parts of one render (shards, checkpoints,
//! resumed parts, earlier merges) into one image by their sample counts ([`crate::parts::merge`]),
//! refusing parts of different renders and parts that leave gaps in the render's samples (unless
//! `--allow-gaps`: then the output holds, and says, only the samples the parts hold).

use crate::commands::support::{check_output_path, CliError};
use crate::output::exr::{variance_channels, ExrMetadata};
use crate::output::film::{read_part, stage_part};
use crate::output::png::stage_png;
use crate::parts::{merge, Part};
use serde_json::json;
use std::path::PathBuf;

/// Options of `vitrum merge`.
#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// The parts: EXR files written by `vitrum render` with --samples, --shard, --checkpoint or
    /// --resume (they keep the sums that merging needs), or by an earlier merge.
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// Output EXR file (a part itself: it can be merged again or resumed).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write a tone-mapped sRGB PNG preview.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Exposure of the PNG preview in stops, a finite number.
    #[arg(long, value_name = "EV", allow_hyphen_values = true, default_value_t = 0.0, value_parser = super::diff::parse_exposure)]
    pub exposure: f32,
    /// Add the per-pixel variance channels (as `vitrum render --variance`).
    #[arg(long)]
    pub variance: bool,
    /// Merge parts that leave gaps in the render's samples (shards 0, 1 and 3 of 4) instead of
    /// refusing them: the output holds the samples the parts hold (`vitrum:spp` counts them,
    /// `vitrum:samples` lists them, `vitrum:missing-samples` the rest), with a warning.
    #[arg(long)]
    pub allow_gaps: bool,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `vitrum merge`.
pub fn run(args: &MergeArgs) -> Result<(), CliError> {
    check_output_path(&args.output, "exr")?;
    if let Some(png) = &args.png {
        check_output_path(png, "png")?;
    }
    let mut parts: Vec<(String, Part)> = Vec::with_capacity(args.parts.len());
    let mut first_attributes = None;
    for path in &args.parts {
        let file = read_part(path).map_err(|e| CliError::BadInput(e.to_string()))?;
        first_attributes.get_or_insert(file.attributes);
        parts.push((path.display().to_string(), file.part));
    }
    let merged = merge(&parts, args.allow_gaps).map_err(|e| CliError::BadInput(format!("merge: {e}")))?;
    let missing = merged.info.missing();
    let attributes = first_attributes.unwrap_or_default();
    let attribute = |name: &str| attributes.get(name).cloned().unwrap_or_default();
    let film = &merged.film;
    let meta = ExrMetadata {
        version: attribute("vitrum:version"),
        integrator: attribute("vitrum:integrator"),
        spp: film.samples,
        seed: attribute("vitrum:seed").parse().unwrap_or(0),
        render_time_seconds: film.seconds,
        rays: film.rays,
        scene: attribute("vitrum:scene"),
        effects: attribute("vitrum:effects"),
    };
    let extra = match (args.variance, film.variance()) {
        (true, Some(variance)) => {
            variance_channels(&variance, &vec![film.samples as f32; variance.pixels.len()])
        }
        (true, None) => {
            eprintln!(
                "vitrum: warning: --variance: no variance from {} sample(s) per pixel; none written",
                film.samples
            );
            Vec::new()
        }
        (false, _) => Vec::new(),
    };
    let mut notes = vec![("vitrum:merged".to_string(), format!("{} parts", parts.len()))];
    if missing.count() > 0 {
        notes.push(("vitrum:missing-samples".to_string(), missing.to_string()));
    }
    let failure = |e: crate::output::OutputError| CliError::Failure(e.to_string());
    let mut staged =
        vec![stage_part(&args.output, &merged.film, &merged.info, &meta, &extra, &notes).map_err(failure)?];
    if let Some(png) = &args.png {
        staged.push(stage_png(png, &film.image(), args.exposure).map_err(failure)?);
    }
    for file in staged {
        file.commit().map_err(failure)?;
    }
    if missing.count() > 0 {
        let target = &merged.info.target;
        eprintln!(
            "vitrum: warning: --allow-gaps: the samples {missing} of {}..{} are in none of the parts; {} holds \
             {} of {} samples per pixel ({})",
            target.start,
            target.end,
            args.output.display(),
            film.samples,
            target.end - target.start,
            merged.info.samples
        );
    }
    if args.json {
        let summary = json!({
            "parts": args.parts,
            "samples": merged.info.samples.to_string(),
            "missing": missing.to_string(),
            "spp": film.samples,
            "seconds": film.seconds,
            "rays": film.rays.total(),
            "non_finite_samples": film.non_finite,
            "output": args.output,
        });
        println!("{summary}");
    } else {
        eprintln!(
            "merge: {} parts, samples {} ({} spp), {:.3} s of rendering, {} rays -> {}",
            parts.len(),
            merged.info.samples,
            film.samples,
            film.seconds,
            film.rays.total(),
            args.output.display()
        );
    }
    Ok(())
}
