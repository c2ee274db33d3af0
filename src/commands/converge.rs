//! `vitrum converge`: progressive renders with error against samples and seconds.

use crate::cli::CliError;
use std::path::PathBuf;

/// Options of `vitrum converge`.
#[derive(clap::Args, Debug, Clone)]
pub struct ConvergeArgs {
    /// Scene file (TOML); the embedded default scene when omitted.
    pub scene: Option<PathBuf>,
    /// Integrators, comma-separated, or `all`.
    #[arg(short, long, default_value = "path,light")]
    pub integrators: String,
    /// Render options shared by every integrator.
    #[command(flatten)]
    pub render: super::SweepArgs,
    /// Output folder.
    #[arg(long, default_value = "converge")]
    pub out: PathBuf,
}

/// Runs `vitrum converge`.
pub fn run(_args: &ConvergeArgs) -> Result<(), CliError> {
    Err(CliError::Failure("converge: under construction".into()))
}
