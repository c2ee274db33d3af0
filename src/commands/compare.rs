//! `vitrum compare`: equal-time (or equal-sample) renders of several methods, as a figure and a table.

use crate::cli::CliError;
use std::path::PathBuf;

/// Options of `vitrum compare`.
#[derive(clap::Args, Debug, Clone)]
pub struct CompareArgs {
    /// Scene file (TOML); the embedded default scene when omitted.
    pub scene: Option<PathBuf>,
    /// Integrators, comma-separated, or `all`.
    #[arg(short, long, default_value = "all")]
    pub integrators: String,
    /// Render options shared by every integrator.
    #[command(flatten)]
    pub render: super::SweepArgs,
    /// Output folder.
    #[arg(long, default_value = "compare")]
    pub out: PathBuf,
}

/// Runs `vitrum compare`.
pub fn run(_args: &CompareArgs) -> Result<(), CliError> {
    Err(CliError::Failure("compare: under construction".into()))
}
