//! `vitrum export`: the scene for another renderer (Mitsuba 3 XML).

use crate::commands::support::{check_output_path, load_scene, parse_resolution, CliError};
use crate::scene::compile::MAX_DEPTH;
use std::path::{Path, PathBuf};

/// Options of `vitrum export`.
#[derive(clap::Args, Debug)]
pub struct ExportArgs {
    /// Scene file (TOML); the embedded default scene when omitted.
    pub scene: Option<PathBuf>,
    /// Target format: `mitsuba` (Mitsuba 3 XML; see docs/mitsuba-export.md).
    #[arg(long, value_parser = ["mitsuba"], default_value = "mitsuba")]
    pub format: String,
    /// Output file (.xml); mesh files go to a folder beside it, `<name>-meshes/`, image files
    /// (textures, the environment map) to `<name>-textures/`.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples per pixel, written as the XML default `spp` (default from the scene file).
    #[arg(long, allow_negative_numbers = true)]
    pub spp: Option<u32>,
    /// vitrum's maximum depth in bounces (default from the scene file); Mitsuba's max_depth is N + 1.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=MAX_DEPTH as i64))]
    pub max_depth: Option<u32>,
    /// Mitsuba integrator: `path` (`volpath` when glass absorbs) or `ptracer` (light tracing).
    #[arg(short, long, value_parser = ["path", "ptracer"], default_value = "path")]
    pub integrator: String,
    /// Image size, e.g. 400x300 (default from the scene file).
    #[arg(long, value_parser = parse_resolution)]
    pub resolution: Option<(u32, u32)>,
    /// No summary line and no notes on stderr.
    #[arg(long)]
    pub quiet: bool,
}

/// Runs `vitrum export`.
pub fn run(args: &ExportArgs) -> Result<(), CliError> {
    use crate::export::mitsuba::{self, MitsubaIntegrator};
    let scene = load_scene(args.scene.as_deref())?;
    check_output_path(&args.output, "xml")?;
    if args.spp == Some(0) {
        return Err(CliError::BadInput("--spp 0: at least one sample per pixel".into()));
    }
    let stem = args.output.file_stem().map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    let mut opts = mitsuba::Options::from_scene(&scene, &stem);
    opts.spp = args.spp.unwrap_or(opts.spp);
    opts.max_depth = args.max_depth.unwrap_or(opts.max_depth);
    opts.resolution = args.resolution.unwrap_or(opts.resolution);
    opts.integrator = MitsubaIntegrator::from_name(&args.integrator).ok_or_else(|| {
        CliError::BadInput(format!("--integrator {}: not one of path, ptracer", args.integrator))
    })?;
    let out = mitsuba::export(&scene, &opts);

    // Stage every file first and publish the XML last: a failure never leaves an XML file that
    // refers to missing meshes or images.
    let failure = |e: crate::output::OutputError| CliError::Failure(e.to_string());
    let folder = args.output.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let mut staged = Vec::new();
    for mesh in out.meshes.iter().chain(&out.textures) {
        let path = folder.join(&mesh.path);
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| {
                CliError::Failure(format!("{}: cannot create the folder: {e}", dir.display()))
            })?;
        }
        let write = |tmp: &Path| {
            std::fs::write(tmp, &mesh.contents).map_err(|e| crate::output::OutputError::io(tmp, e))
        };
        staged.push(crate::output::stage(&path, write).map_err(failure)?);
    }
    let xml = |tmp: &Path| {
        std::fs::write(tmp, out.xml.as_bytes()).map_err(|e| crate::output::OutputError::io(tmp, e))
    };
    staged.push(crate::output::stage(&args.output, xml).map_err(failure)?);
    for file in staged {
        file.commit().map_err(failure)?;
    }
    if !args.quiet {
        for n in &out.notes {
            eprintln!("vitrum: note: {n}");
        }
        let meshes = match out.meshes.len() {
            0 => String::new(),
            n => format!(" and {n} mesh file(s) in {}", folder.join(&opts.mesh_folder).display()),
        };
        let images = match out.textures.len() {
            0 => String::new(),
            n => format!(" and {n} image file(s) in {}", folder.join(&opts.texture_folder).display()),
        };
        eprintln!("export: Mitsuba 3 scene -> {}{meshes}{images}", args.output.display());
    }
    Ok(())
}
