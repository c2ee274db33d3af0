//! `vitrum import`: a Mitsuba XML scene written as vitrum's TOML, to be edited in vitrum's own
//! format. Every difference from the Mitsuba scene is a comment at the top of the file (and a
//! warning on stderr); rendering the TOML gives the same image bits as rendering the XML.

use crate::commands::support::{check_output_path, CliError};
use crate::scene::mitsuba;
use std::path::{Path, PathBuf};

/// Options of `vitrum import`.
#[derive(clap::Args, Debug)]
pub struct ImportArgs {
    /// The Mitsuba scene (XML, version 0.5 to 3.x).
    pub scene: PathBuf,
    /// The TOML file to write; the files the scene names (meshes, images) are referred to from
    /// there.
    #[arg(short, long)]
    pub output: PathBuf,
    /// No warnings on stderr (they stay in the file's comments).
    #[arg(long)]
    pub quiet: bool,
}

/// Runs `vitrum import`.
pub fn run(args: &ImportArgs) -> Result<(), CliError> {
    check_output_path(&args.output, "toml")?;
    let dir = args.output.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let imported = mitsuba::import(&args.scene, mitsuba::lenient(), Some(dir))
        .map_err(|e| CliError::BadInput(e.to_string()))?;
    let write = |tmp: &Path| {
        std::fs::write(tmp, imported.toml.as_bytes()).map_err(|e| crate::output::OutputError::io(tmp, e))
    };
    crate::output::write_atomically(&args.output, write).map_err(|e| CliError::Failure(e.to_string()))?;
    if !args.quiet {
        for w in &imported.warnings {
            eprintln!("vitrum: warning: {w}");
        }
        eprintln!("import: {} -> {}", args.scene.display(), args.output.display());
    }
    Ok(())
}
