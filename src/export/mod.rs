//! Writing a compiled scene for other renderers, so that the same scene can be rendered
//! independently (`vitrum export`).
//!
//! Exporters work on the compiled [`Scene`](crate::scene::Scene), not on the scene file: composite
//! bodies are already expanded into analytic surfaces with the right interface on each side, and
//! every default has been applied.

pub mod mitsuba;

use std::path::PathBuf;

/// A file an export writes besides its main file (a mesh, for example).
#[derive(Clone, Debug, PartialEq)]
pub struct ExtraFile {
    /// Path relative to the folder of the main file (as the main file refers to it).
    pub path: PathBuf,
    /// The file's bytes.
    pub contents: Vec<u8>,
}
