//! What every command shares: the error type and its exit code, loading a scene, naming an
//! integrator, the worker pool, and the checks made before any work (output paths, image sizes,
//! the effects a method does not simulate).

use crate::integrators::{self, Integrator};
use crate::render::{self, RenderOptions};
use crate::scene::compile::{MAX_PIXELS, MAX_SIDE};
use crate::scene::effects::Support;
use crate::scene::{self, Scene};
use std::path::Path;

/// A failure and its exit code.
#[derive(Debug)]
pub enum CliError {
    /// Bad input from the user (exit code 2).
    BadInput(String),
    /// Anything else (exit code 1).
    Failure(String),
}

impl CliError {
    /// The process exit code.
    pub fn exit_code(&self) -> i32 {
        match self {
            CliError::BadInput(_) => 2,
            CliError::Failure(_) => 1,
        }
    }
}

/// Parses `WIDTHxHEIGHT` within the renderer's size limits.
pub fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let (w, h) =
        s.split_once(['x', 'X']).ok_or_else(|| format!("`{s}` is not WIDTHxHEIGHT, e.g. 800x800"))?;
    let parse =
        |v: &str| v.trim().parse::<u32>().map_err(|_| format!("`{v}` is not a whole number of pixels"));
    let (w, h) = (parse(w)?, parse(h)?);
    if w == 0 || h == 0 {
        return Err(format!("{w}x{h}: width and height must be at least 1"));
    }
    if w > MAX_SIDE || h > MAX_SIDE || w as u64 * h as u64 > MAX_PIXELS {
        return Err(format!("{w}x{h} is too large: at most {MAX_SIDE} per side and {MAX_PIXELS} pixels"));
    }
    Ok((w, h))
}

/// Load the given scene file, or the embedded default.
pub fn load_scene(path: Option<&Path>) -> Result<Scene, CliError> {
    match path {
        Some(p) => scene::load(p).map_err(|e| CliError::BadInput(e.to_string())),
        None => Ok(scene::load_default()),
    }
}

/// The integrator called `name`, or a bad-input error listing the known ones.
pub fn integrator_named(name: &str) -> Result<Box<dyn Integrator>, CliError> {
    integrators::create(name).ok_or_else(|| {
        CliError::BadInput(format!("unknown integrator `{name}`; known: {}", integrators::names().join(", ")))
    })
}

/// Most worker threads a render may ask for.
const MAX_THREADS: usize = 1024;

/// A worker pool with `threads` threads (all cores when `None`), refusing 0 and absurd counts.
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool, CliError> {
    match threads {
        Some(0) => return Err(CliError::BadInput("--threads 0: at least one thread".into())),
        Some(n) if n > MAX_THREADS => {
            return Err(CliError::BadInput(format!("--threads {n}: at most {MAX_THREADS}")));
        }
        _ => {}
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| CliError::Failure(format!("cannot start worker threads: {e}")))
}

/// Check that an output file can be created before spending time on a render.
pub fn check_output_path(path: &Path, extension: &str) -> Result<(), CliError> {
    if path.is_dir() {
        return Err(CliError::BadInput(format!("{}: is a folder, not a file", path.display())));
    }
    let ext = path.extension().and_then(|e| e.to_str());
    if !ext.is_some_and(|e| e.eq_ignore_ascii_case(extension)) {
        // The image output is always the linear HDR EXR; the tone-mapped preview is its own option.
        let hint = match ext {
            Some(e) if extension == "exr" && e.eq_ignore_ascii_case("png") => format!(
                " (it is written as OpenEXR, linear HDR); for a tone-mapped PNG preview give --png {}, \
                 beside -o {}",
                path.display(),
                path.with_extension("exr").display()
            ),
            _ => String::new(),
        };
        return Err(CliError::BadInput(format!(
            "{}: the output file must end in .{extension}{hint}",
            path.display()
        )));
    }
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if !parent.is_dir() {
        return Err(CliError::BadInput(format!(
            "{}: the folder {} does not exist",
            path.display(),
            parent.display()
        )));
    }
    Ok(())
}

/// Warn about (or, when `strict`, refuse) effects the integrator does not simulate; dispersion
/// counts as simulated whenever the render traces wavelengths.
pub fn check_effects(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    strict: bool,
) -> Result<(), CliError> {
    let spectral = render::CameraDims::resolve(scene, integrator, opts.spectral).wavelength;
    for u in &scene.effects.0 {
        if u.effect == crate::scene::Effect::Dispersion && spectral {
            continue;
        }
        let (verb, how) = match integrator.support(u.effect) {
            Support::Simulates => continue,
            Support::Approximates(how) => ("approximates", how),
            Support::Ignores(how) => ("ignores", how),
        };
        let message = format!("`{}` {verb} {} ({}): {how}", integrator.name(), u.effect, u.reason);
        if strict {
            return Err(CliError::BadInput(format!("{message}; refusing because of --strict")));
        }
        eprintln!("vitrum: warning: {message}");
    }
    Ok(())
}
