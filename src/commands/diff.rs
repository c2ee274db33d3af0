//! `vitrum diff`: error metrics of a test image against a reference (DESIGN.md's definitions).

use crate::cli::CliError;
use std::path::PathBuf;

/// Options of `vitrum diff`.
#[derive(clap::Args, Debug, Clone)]
pub struct DiffArgs {
    /// The image to judge (EXR).
    pub test: PathBuf,
    /// The reference image (EXR).
    pub reference: PathBuf,
    /// Write a false-colour map of the relative squared error, with a colour bar.
    #[arg(long)]
    pub error_map: Option<PathBuf>,
    /// Only this rectangle, X,Y,W,H in pixels from the top-left.
    #[arg(long, value_parser = super::parse_crop)]
    pub crop: Option<super::CropArg>,
    /// Print the metrics as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `vitrum diff`.
pub fn run(_args: &DiffArgs) -> Result<(), CliError> {
    Err(CliError::Failure("diff: under construction".into()))
}
