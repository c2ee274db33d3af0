//! The native half of the `vitrum` Python package (`vitrum._vitrum`): thin bindings over the
//! library's own entry points, so that Python and the command line share one path.
//!
//! - Scenes load through [`vitrum::commands::support::load_scene`] (a file) or
//!   [`vitrum::scene::load_str`] (the TOML text a dict becomes), as `vitrum render` loads them.
//! - Render options are parsed by the command line's clap definition ([`vitrum::cli::Cli`]) from
//!   the argument vector the Python wrapper builds, and rendered by
//!   [`vitrum::commands::render::render_in_memory`], which `vitrum render` uses too.
//! - `diff` and `compare` run the commands' own code ([`vitrum::commands::diff::metrics_json`],
//!   [`vitrum::commands::compare::run`]).
//!
//! Every call that renders releases the GIL and runs on a worker thread while the calling thread
//! polls Python's signal handlers every 50 ms: a Ctrl-C (KeyboardInterrupt) requests the stop of
//! [`vitrum::interrupt`], the render ends at its next pass boundary with the samples done, and the
//! signal's exception is handed back to the wrapper (which re-raises it). No process-wide signal
//! handler is installed.

use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray3};
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::Duration;
use vitrum::cli::{Cli, CliError, Command};
use vitrum::commands::render::Rendered;
use vitrum::image::Image;
use vitrum::interrupt;

pyo3::create_exception!(
    _vitrum,
    VitrumError,
    PyException,
    "A failure of vitrum (what the command line reports with exit code 1)."
);
pyo3::create_exception!(
    _vitrum,
    InputError,
    VitrumError,
    "Bad input: an option, a scene or an image file (what the command line reports with exit code 2)."
);
pyo3::create_exception!(
    _vitrum,
    SceneError,
    InputError,
    "A scene that cannot be read or compiled; the message names file:line:column and the field."
);

/// How often the calling thread looks at Python's signal handlers during a render.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// The Python exception of a command-line error, with the command line's message.
fn py_error(error: CliError) -> PyErr {
    match error {
        CliError::BadInput(m) => InputError::new_err(m),
        CliError::Failure(m) => VitrumError::new_err(m),
    }
}

/// Parses `vitrum ARGS…` with the command line's own definition; a clap error is bad input
/// with clap's message.
fn parse(args: Vec<String>) -> PyResult<Command> {
    let argv = std::iter::once("vitrum".to_string()).chain(args);
    match <Cli as clap::Parser>::try_parse_from(argv) {
        Ok(cli) => {
            vitrum::scene::mitsuba::set_lenient(cli.lenient);
            vitrum::scene::mitsuba::set_two_sided(cli.two_sided);
            Ok(cli.command)
        }
        Err(e) => Err(InputError::new_err(e.render().to_string().trim_end().to_string())),
    }
}

/// Runs `work` on a worker thread with the GIL released, polling Python's signal handlers every
/// [`SIGNAL_POLL`]: the first exception they raise (KeyboardInterrupt on Ctrl-C) requests the
/// stop of every running render ([`interrupt::request_stop`]) and is returned beside the
/// result once the work has stopped. A panic of the work is a [`VitrumError`].
fn interruptible<T: Send + 'static>(
    py: Python<'_>,
    work: impl FnOnce() -> T + Send + 'static,
) -> PyResult<(T, Option<PyErr>)> {
    interrupt::reset();
    let (done, finished) = mpsc::channel::<()>();
    // A receiver is not `Sync`: the closures the GIL is released for borrow it through a lock.
    let finished = std::sync::Mutex::new(finished);
    let worker = std::thread::spawn(move || {
        let result = work();
        let _ = done.send(());
        result
    });
    let mut signal = None;
    loop {
        let wait = || finished.lock().map_or(Ok(()), |f| f.recv_timeout(SIGNAL_POLL));
        match py.detach(wait) {
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            _ => break,
        }
        if signal.is_none() {
            if let Err(e) = py.check_signals() {
                interrupt::request_stop();
                signal = Some(e);
            }
        }
    }
    let result = py.detach(|| worker.join());
    interrupt::reset();
    match result {
        Ok(value) => Ok((value, signal)),
        Err(_) => Err(VitrumError::new_err("internal error: the render panicked (please report it)")),
    }
}

/// An image as a float32 numpy array of shape (height, width, 3), linear.
fn to_numpy<'py>(py: Python<'py>, image: &Image) -> Bound<'py, PyArray3<f32>> {
    let data: Vec<f32> = image.pixels.iter().flat_map(|p| p.to_array()).collect();
    Array3::from_shape_vec((image.height, image.width, 3), data)
        .expect("width × height × 3 values")
        .into_pyarray(py)
}

/// A compiled scene, ready to render.
#[pyclass(frozen, module = "vitrum._vitrum")]
struct Scene {
    scene: Arc<vitrum::scene::Scene>,
}

#[pymethods]
impl Scene {
    /// The scene's name: its file path, or the name given to a scene built from a dict.
    #[getter]
    fn name(&self) -> String {
        self.scene.origin.name.clone()
    }

    /// The 64-bit hash of the scene text (and of the files it reads), in hex.
    #[getter]
    fn hash(&self) -> String {
        self.scene.origin.hash.clone()
    }

    /// The warnings found while compiling the scene.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.scene.warnings.clone()
    }

    /// The camera's resolution (width, height).
    #[getter]
    fn resolution(&self) -> (usize, usize) {
        let camera = &self.scene.camera;
        (camera.width as usize, camera.height as usize)
    }

    /// The default method of the scene file.
    #[getter]
    fn method(&self) -> String {
        self.scene.settings.integrator.clone()
    }

    /// Renders with the options `args` of `vitrum render` (without the scene); returns the
    /// render and the exception of a signal that stopped it (KeyboardInterrupt), if any.
    fn render(&self, py: Python<'_>, args: Vec<String>) -> PyResult<(Render, Option<PyErr>)> {
        let args = std::iter::once("render".to_string()).chain(args).collect();
        let Command::Render(args) = parse(args)? else { unreachable!("the first argument is `render`") };
        if let Some(scene) = &args.scene {
            let scene = scene.display();
            return Err(InputError::new_err(format!(
                "{scene}: the scene is the one rendered, not an argument"
            )));
        }
        let scene = Arc::clone(&self.scene);
        let (rendered, signal) =
            interruptible(py, move || vitrum::commands::render::render_in_memory(&scene, &args, &|_, _| {}))?;
        let rendered = rendered.map_err(py_error)?;
        Ok((Render { scene: Arc::clone(&self.scene), rendered }, signal))
    }
}

/// A render held in memory.
#[pyclass(frozen, module = "vitrum._vitrum")]
struct Render {
    scene: Arc<vitrum::scene::Scene>,
    rendered: Rendered,
}

#[pymethods]
impl Render {
    /// The image: float32 numpy array (height, width, 3), linear radiance.
    fn image<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f32>> {
        to_numpy(py, &self.rendered.out.image)
    }

    /// The variance of each pixel's estimate (its squared standard error), as the image, or
    /// `None` when it cannot be estimated (one replica, a fixed sample pattern).
    fn variance<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray3<f32>>> {
        self.rendered.out.variance.as_ref().map(|v| to_numpy(py, v))
    }

    /// The summary of `vitrum render --json` as JSON text, with `output` as its output file.
    #[pyo3(signature = (output=None))]
    fn summary(&self, output: Option<PathBuf>) -> String {
        self.rendered.summary(&self.scene, output.as_deref(), None).to_string()
    }

    /// What a stop interrupted (the EXR's `vitrum:interrupted`), or `None`.
    #[getter]
    fn interrupted(&self) -> Option<String> {
        self.rendered.interrupted.clone()
    }

    /// The exposure of the preview, in stops.
    #[getter]
    fn exposure(&self) -> f32 {
        self.rendered.exposure
    }

    /// Writes the EXR `vitrum render` writes (image, variance and replica channels, metadata).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        vitrum::commands::support::check_output_path(&path, "exr").map_err(py_error)?;
        py.detach(|| self.rendered.stage_exr(&self.scene, &path).and_then(|staged| staged.commit()))
            .map_err(|e| VitrumError::new_err(e.to_string()))
    }

    /// The tone-mapped preview `vitrum render --png` writes, as PNG bytes, at `exposure` stops
    /// (default: the render's).
    #[pyo3(signature = (exposure=None))]
    fn png<'py>(&self, py: Python<'py>, exposure: Option<f32>) -> PyResult<Bound<'py, PyBytes>> {
        let exposure = exposure.unwrap_or(self.rendered.exposure);
        let bytes = vitrum::output::png::preview_png(&self.rendered.out.image, exposure)
            .map_err(VitrumError::new_err)?;
        Ok(PyBytes::new(py, &bytes))
    }
}

/// Loads a scene file (vitrum TOML or Mitsuba XML), as `vitrum render FILE` does.
#[pyfunction]
fn load_file(py: Python<'_>, path: PathBuf) -> PyResult<Scene> {
    let scene = py.detach(|| vitrum::commands::support::load_scene(Some(&path)));
    let scene = scene.map_err(|e| match e {
        CliError::BadInput(m) => SceneError::new_err(m),
        other => py_error(other),
    })?;
    Ok(Scene { scene: Arc::new(scene) })
}

/// Compiles scene TOML `text` named `name` in messages, with relative file paths resolved
/// against the folder `dir`.
#[pyfunction]
fn load_text(py: Python<'_>, text: String, name: String, dir: PathBuf) -> PyResult<Scene> {
    let scene = py.detach(|| vitrum::scene::load_str(&text, &name, Some(&dir)));
    Ok(Scene { scene: Arc::new(scene.map_err(|e| SceneError::new_err(e.to_string()))?) })
}

/// The scene TOML of a scene given as JSON text (a dict's `json.dumps`): tables stay tables,
/// lists of tables become arrays of tables. JSON `null` has no TOML form and is refused.
#[pyfunction]
fn toml_of_json(json: &str) -> PyResult<String> {
    let value: serde_json::Value =
        serde_json::from_str(json).map_err(|e| SceneError::new_err(format!("the scene dict: {e}")))?;
    if let Some(path) = find_null(&value, String::new()) {
        return Err(SceneError::new_err(format!(
            "the scene dict: {path} is None, which a scene file cannot hold (leave the key out for its default)"
        )));
    }
    toml::to_string(&value)
        .map_err(|e| SceneError::new_err(format!("the scene dict cannot be written as TOML: {e}")))
}

/// The path (`render.spp`, `objects[2].radius`) of the first `null` in `value`, if any.
fn find_null(value: &serde_json::Value, path: String) -> Option<String> {
    match value {
        serde_json::Value::Null => Some(if path.is_empty() { "the whole scene".into() } else { path }),
        serde_json::Value::Array(items) => {
            items.iter().enumerate().find_map(|(i, item)| find_null(item, format!("{path}[{i}]")))
        }
        serde_json::Value::Object(map) => map.iter().find_map(|(key, item)| {
            find_null(item, if path.is_empty() { key.clone() } else { format!("{path}.{key}") })
        }),
        _ => None,
    }
}

/// The metrics of `vitrum diff ARGS… --json`, as JSON text.
#[pyfunction]
fn diff(py: Python<'_>, args: Vec<String>) -> PyResult<String> {
    let args = ["diff".to_string()].into_iter().chain(args).chain(["--json".to_string()]).collect();
    let Command::Diff(args) = parse(args)? else { unreachable!("the first argument is `diff`") };
    let json = py.detach(|| vitrum::commands::diff::metrics_json(&args)).map_err(py_error)?;
    Ok(json.to_string())
}

/// Runs `vitrum compare ARGS…` (its files go to its `--out` folder); returns the exception of
/// a signal that stopped it, if any (the renders then stop at their next pass boundary and
/// the comparison is of the samples done).
#[pyfunction]
fn compare(py: Python<'_>, args: Vec<String>) -> PyResult<Option<PyErr>> {
    let args = std::iter::once("compare".to_string()).chain(args).collect();
    let Command::Compare(args) = parse(args)? else { unreachable!("the first argument is `compare`") };
    let (result, signal) = interruptible(py, move || vitrum::commands::compare::run(&args))?;
    match (result, signal) {
        (_, Some(signal)) => Ok(Some(signal)),
        (result, None) => result.map(|()| None).map_err(py_error),
    }
}

/// An EXR file's RGB image and header attributes.
type ExrImage<'py> = (Bound<'py, PyArray3<f32>>, std::collections::BTreeMap<String, String>);

/// Reads an EXR file: its RGB image as float32 numpy (height, width, 3) and its header
/// attributes.
#[pyfunction]
fn read_exr<'py>(py: Python<'py>, path: PathBuf) -> PyResult<ExrImage<'py>> {
    let read = py.detach(|| vitrum::output::exr::read_exr(Path::new(&path)));
    let (image, attributes) = read.map_err(|e| InputError::new_err(e.to_string()))?;
    Ok((to_numpy(py, &image), attributes))
}

/// The methods: (name, description) of `vitrum integrators`.
#[pyfunction]
fn methods() -> Vec<(&'static str, &'static str)> {
    vitrum::methods::METHODS.iter().map(|m| (m.name, m.description)).collect()
}

/// The native module.
#[pymodule]
fn _vitrum(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("VitrumError", py.get_type::<VitrumError>())?;
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("SceneError", py.get_type::<SceneError>())?;
    m.add("VERSION", vitrum::VERSION)?;
    m.add_class::<Scene>()?;
    m.add_class::<Render>()?;
    m.add_function(wrap_pyfunction!(load_file, m)?)?;
    m.add_function(wrap_pyfunction!(load_text, m)?)?;
    m.add_function(wrap_pyfunction!(toml_of_json, m)?)?;
    m.add_function(wrap_pyfunction!(diff, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr, m)?)?;
    m.add_function(wrap_pyfunction!(methods, m)?)?;
    Ok(())
}
