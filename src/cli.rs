//! The `vitrum` command line: the clap definition of every command and the dispatch to
//! [`crate::commands`], where each command lives (`render`, `info`, `integrators`, `export`,
//! `diff`, `converge`, `compare`, `report`, `merge`).
//!
//! Exit codes: 0 success; 2 bad input (options, scene file, image file) with a message naming
//! the problem; 1 any other failure; 130 a render interrupted by Ctrl-C (see
//! [`crate::interrupt`]): the first Ctrl-C writes the samples done, a second one aborts
//! without writing anything.

use crate::commands::export::ExportArgs;
use crate::commands::info::InfoArgs;
use crate::commands::render::RenderArgs;
pub use crate::commands::support::CliError;
use crate::interrupt;
use clap::{Parser, Subcommand};

/// vitrum: render scenes with transparent objects by every classic method.
#[derive(Parser, Debug)]
#[command(name = "vitrum", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
    /// Read Mitsuba XML scenes leniently: a plugin or parameter vitrum lacks is dropped or
    /// approximated with a warning instead of refused (any command that reads a scene).
    #[arg(long, global = true)]
    pub lenient: bool,
    /// Read every one-sided Mitsuba `diffuse` (one not inside a `twosided`) as two-sided, with a
    /// warning: the reading other renderers give such scenes (any command that reads a scene).
    #[arg(long, global = true)]
    pub two_sided: bool,
}

/// The subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a scene (the embedded default scene when none is given) to an EXR file.
    Render(Box<RenderArgs>),
    /// Describe a scene in words (`--json`: the same as data): render settings, objects, materials
    /// and their textures, lights, BVH statistics, effects, and warnings such as coincident surfaces.
    Info(InfoArgs),
    /// List the integrators.
    Integrators,
    /// Write the scene for another renderer (Mitsuba 3 XML), to render the same scene there.
    Export(ExportArgs),
    /// Write a Mitsuba XML scene as vitrum's TOML, with comments for what is not exact.
    Import(crate::commands::import::ImportArgs),
    /// Error metrics of an EXR image against a reference, and an optional false-colour error map.
    Diff(crate::commands::diff::DiffArgs),
    /// Render progressively and record error against samples and seconds at every power of two.
    Converge(Box<crate::commands::converge::ConvergeArgs>),
    /// Render with several methods at equal time (or samples): a figure and a table.
    Compare(Box<crate::commands::compare::CompareArgs>),
    /// Render every scene × method at equal time (or samples) into one interactive HTML page.
    Report(Box<crate::commands::report::ReportArgs>),
    /// Combine render parts (shards, checkpoints) of one render into one image.
    Merge(crate::commands::merge::MergeArgs),
}

/// Run the command line; returns the process exit code.
pub fn main() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() { 2 } else { 0 };
        }
    };
    crate::scene::mitsuba::set_lenient(cli.lenient);
    crate::scene::mitsuba::set_two_sided(cli.two_sided);
    let result = match cli.command {
        Command::Render(args) => crate::commands::render::run(&args),
        Command::Info(args) => crate::commands::info::run(&args),
        Command::Export(args) => crate::commands::export::run(&args),
        Command::Import(args) => crate::commands::import::run(&args),
        Command::Diff(args) => crate::commands::diff::run(&args),
        Command::Converge(args) => crate::commands::converge::run(&args),
        Command::Compare(args) => crate::commands::compare::run(&args),
        Command::Report(args) => crate::commands::report::run(&args),
        Command::Merge(args) => crate::commands::merge::run(&args),
        Command::Integrators => {
            for m in crate::methods::METHODS {
                println!("{:<12} {}", m.name, m.description);
            }
            Ok(())
        }
    };
    match result {
        // Only `render` catches Ctrl-C: it has written the samples done.
        Ok(()) if interrupt::stop_requested() => interrupt::EXIT_INTERRUPTED,
        Ok(()) => 0,
        Err(e) => {
            let (CliError::BadInput(m) | CliError::Failure(m)) = &e;
            eprintln!("vitrum: error: {m}");
            e.exit_code()
        }
    }
}
