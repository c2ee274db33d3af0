//! Image files: linear HDR EXR with render metadata, and tone-mapped sRGB PNG previews.
//!
//! Every writer goes through [`stage`] (or [`write_atomically`]): the file is written to a
//! temporary name beside its target, flushed to disk and renamed into place, so a reader (a
//! viewer, a running sweep) never sees a half-written file, a failed write never destroys an
//! existing one, and a process killed at any moment (even by SIGKILL) leaves either the old
//! file, the new one, or none, never a truncated one. What a kill can leave is the temporary
//! file `.{name}.tmp-{pid}-{n}`; the next write of the same output removes it (see [`stage`]).

pub mod exr;
pub mod film;
pub mod png;
pub mod replicas;

use crate::image::Image;
use std::fs;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard};

/// Why an image file could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The file system refused (missing file, no permission, disk full, ...).
    #[error("{}: {source}", path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The underlying error.
        source: io::Error,
    },
    /// The EXR library could not encode or decode the file (for example, it is not an EXR file).
    #[error("{}: EXR library error: {message}", path.display())]
    Exr {
        /// The file concerned.
        path: PathBuf,
        /// What the EXR library reported.
        message: String,
    },
    /// The file or image does not have the expected content (for example, not an RGB EXR).
    #[error("{}: {message}", path.display())]
    Format {
        /// The file concerned.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
}

impl OutputError {
    /// An [`OutputError::Io`] for `path`.
    pub fn io(path: &Path, source: io::Error) -> OutputError {
        OutputError::Io { path: path.to_path_buf(), source }
    }

    /// An [`OutputError::Format`] for `path`.
    pub fn format(path: &Path, message: impl Into<String>) -> OutputError {
        OutputError::Format { path: path.to_path_buf(), message: message.into() }
    }
}

/// Distinguishes temporary files of concurrent writes within one process.
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// The temporary files of this process's staged outputs, and whether the process is aborting.
#[derive(Debug, Default)]
struct Registry {
    live: Vec<PathBuf>,
    aborting: bool,
}

impl Registry {
    /// Remove every registered temporary file and refuse new ones and publications from now on.
    fn abandon(&mut self) {
        self.aborting = true;
        for path in self.live.drain(..) {
            let _ = fs::remove_file(path);
        }
    }

    fn forget(&mut self, path: &Path) {
        self.live.retain(|p| p != path);
    }
}

static REGISTRY: Mutex<Registry> = Mutex::new(Registry { live: Vec::new(), aborting: false });

/// The registry, even if a thread panicked while holding it (its data stays consistent).
fn registry() -> MutexGuard<'static, Registry> {
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner())
}

/// Remove the temporary files of every output being staged, and make every later [`stage`] and
/// [`Staged::commit`] fail: for an abort (the second Ctrl-C, [`crate::interrupt::abort`]), which
/// exits the process next. Creating, publishing and removing temporary files all happen under
/// one lock, so after this returns nothing is published and no temporary file is created (but a
/// [`stage`] writer that reopens its file by name may recreate it; [`stage_bytes`] cannot).
pub fn abandon_staged() {
    registry().abandon();
}

/// The error of a write attempted after [`abandon_staged`].
fn aborting_error(path: &Path) -> OutputError {
    OutputError::io(path, io::Error::new(io::ErrorKind::Interrupted, "aborted: not written"))
}

/// Removes the temporary file when dropped, unless it has been renamed into place.
struct TempFile {
    path: PathBuf,
    keep: bool,
}

impl TempFile {
    /// Create the (empty) temporary file for `target` and register it, so that an abort
    /// removes it; returns it open for writing.
    fn create(target: &Path) -> Result<(TempFile, fs::File), OutputError> {
        let Some(file_name) = target.file_name() else {
            let e = io::Error::new(io::ErrorKind::InvalidInput, "the output path has no file name");
            return Err(OutputError::io(target, e));
        };
        remove_stale_temp_files(target);
        let counter = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp_name = format!(".{}.tmp-{}-{counter}", file_name.to_string_lossy(), std::process::id());
        let path = target.with_file_name(tmp_name);
        let mut registry = registry();
        if registry.aborting {
            return Err(aborting_error(target));
        }
        // The name holds this process's id: a file by that name is ours or a stale one of a
        // dead process that had the same id, so truncating it is right.
        let file = fs::OpenOptions::new()
            .write(true)
            .create(true)
            .truncate(true)
            .open(&path)
            // Named by the target: the temporary name means nothing to the user.
            .map_err(|e| OutputError::io(target, e))?;
        registry.live.push(path.clone());
        Ok((TempFile { path, keep: false }, file))
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if !self.keep {
            let mut registry = registry();
            // After an abort it is already gone; there is nothing useful to do on failure.
            let _ = fs::remove_file(&self.path);
            registry.forget(&self.path);
        }
    }
}

/// Write a file atomically: call `write(tmp_path)` to write a temporary file in the same directory as `path`
/// (name like `.{file_name}.tmp-{pid}-{counter}`), then rename it over `path`; on error remove the temp file, leave `path` untouched.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), OutputError>,
) -> Result<(), OutputError> {
    stage(path, write)?.commit()
}

/// A complete output written to a temporary file beside its target, not yet published: commit
/// several staged files together so that a failure in one leaves none of them behind.
pub struct Staged {
    tmp: TempFile,
    target: PathBuf,
}

impl Staged {
    /// Publish the file under its final name (an atomic rename), and make the rename durable.
    pub fn commit(mut self) -> Result<(), OutputError> {
        {
            let mut registry = registry();
            if registry.aborting {
                return Err(aborting_error(&self.target));
            }
            fs::rename(&self.tmp.path, &self.target).map_err(|e| OutputError::io(&self.target, e))?;
            self.tmp.keep = true;
            registry.forget(&self.tmp.path);
        }
        // Best effort: the directory entry survives a power loss (the file is complete either way).
        #[cfg(unix)]
        if let Ok(dir) = fs::File::open(parent_dir(&self.target)) {
            let _ = dir.sync_all();
        }
        Ok(())
    }
}

/// The folder of `path` (`.` for a bare file name).
fn parent_dir(path: &Path) -> &Path {
    path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."))
}

/// Write `path`'s contents to a temporary file with `write(tmp_path)` and make them durable,
/// without publishing them yet; dropping the result removes the temporary file.
///
/// A process killed outright (SIGKILL, power loss) can leave its temporary file
/// `.{file_name}.tmp-{pid}-{counter}` beside `path`, never a partial `path`. Staging `path` again
/// removes such leftovers of processes that no longer run ([`remove_stale_temp_files`]).
///
/// `write` opens the temporary file by its name; an abort ([`abandon_staged`]) that removes the
/// file while `write` runs cannot stop `write` from creating it anew. Outputs of a render that
/// can be aborted are therefore encoded in memory and staged with [`stage_bytes`].
pub fn stage(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), OutputError>,
) -> Result<Staged, OutputError> {
    // The guard also cleans up if `write` fails or panics.
    let (tmp, file) = TempFile::create(path)?;
    drop(file);
    write(&tmp.path)?;
    // Make the contents durable before a rename publishes them, so a crash cannot leave an
    // empty or partial file under the final name.
    let sync = fs::OpenOptions::new().write(true).open(&tmp.path).and_then(|f| f.sync_all());
    sync.map_err(|e| OutputError::io(&tmp.path, e))?;
    Ok(Staged { tmp, target: path.to_path_buf() })
}

/// Stage the encoded file `bytes` as `path` (see [`stage`]): written through the handle that
/// created the temporary file, so an abort that removes it leaves nothing behind, and the
/// temporary file exists only while the bytes are written and flushed.
pub fn stage_bytes(path: &Path, bytes: &[u8]) -> Result<Staged, OutputError> {
    use std::io::Write;
    let (tmp, mut file) = TempFile::create(path)?;
    file.write_all(bytes).and_then(|()| file.sync_all()).map_err(|e| OutputError::io(path, e))?;
    Ok(Staged { tmp, target: path.to_path_buf() })
}

/// The process id in the name of a temporary file of `file_name`
/// (`.{file_name}.tmp-{pid}-{counter}`), if `name` is one.
fn temp_file_pid(name: &str, file_name: &str) -> Option<u32> {
    let rest = name.strip_prefix('.')?.strip_prefix(file_name)?.strip_prefix(".tmp-")?;
    let (pid, counter) = rest.split_once('-')?;
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    (digits(pid) && digits(counter)).then(|| pid.parse().ok()).flatten()
}

/// Whether process `pid` runs, when that can be known (Linux with `/proc` mounted).
fn process_running(pid: u32) -> Option<bool> {
    let proc = Path::new("/proc");
    (cfg!(target_os = "linux") && proc.join("self").exists()).then(|| proc.join(pid.to_string()).exists())
}

/// Remove the temporary files that killed processes left beside `path` (see [`stage`]): those
/// of process ids that no longer run (Linux: as seen in `/proc`, so only writers in this
/// machine's process namespace count as running). Elsewhere nothing is removed. Best effort.
pub fn remove_stale_temp_files(path: &Path) {
    let Some(file_name) = path.file_name().and_then(|n| n.to_str()) else { return };
    let Ok(entries) = fs::read_dir(parent_dir(path)) else { return };
    let own = std::process::id();
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name.to_str().and_then(|n| temp_file_pid(n, file_name)) else { continue };
        if pid != own && process_running(pid) == Some(false) {
            let _ = fs::remove_file(entry.path());
        }
    }
}

/// Check that `image.pixels` holds exactly `width * height` pixels before encoding it to `path`.
fn check_pixel_count(path: &Path, image: &Image) -> Result<(), OutputError> {
    let expected = image.width.checked_mul(image.height);
    if expected != Some(image.pixels.len()) {
        return Err(OutputError::format(
            path,
            format!("image is {}x{} but has {} pixels", image.width, image.height, image.pixels.len()),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Names of all files in `dir`.
    pub(crate) fn dir_entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn atomic_write_success_leaves_only_target() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.txt");
        let mut seen_tmp = None;
        write_atomically(&target, |tmp| {
            seen_tmp = Some(tmp.to_path_buf());
            fs::write(tmp, b"new").map_err(|e| OutputError::io(tmp, e))
        })
        .unwrap();
        let tmp = seen_tmp.unwrap();
        assert_eq!(tmp.parent(), Some(dir.path()));
        let tmp_name = tmp.file_name().unwrap().to_string_lossy().into_owned();
        assert!(tmp_name.starts_with(&format!(".out.txt.tmp-{}-", std::process::id())), "{tmp_name}");
        assert_eq!(fs::read(&target).unwrap(), b"new");
        assert_eq!(dir_entries(dir.path()), ["out.txt"]);
    }

    #[test]
    fn atomic_write_replaces_existing_target() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.txt");
        fs::write(&target, b"old").unwrap();
        write_atomically(&target, |tmp| fs::write(tmp, b"new").map_err(|e| OutputError::io(tmp, e))).unwrap();
        assert_eq!(fs::read(&target).unwrap(), b"new");
        assert_eq!(dir_entries(dir.path()), ["out.txt"]);
    }

    #[test]
    fn atomic_write_failure_keeps_existing_target_and_removes_temp() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.txt");
        fs::write(&target, b"old").unwrap();
        let result = write_atomically(&target, |tmp| {
            fs::write(tmp, b"partial").unwrap();
            Err(OutputError::format(tmp, "simulated failure"))
        });
        assert!(matches!(result, Err(OutputError::Format { .. })));
        assert_eq!(fs::read(&target).unwrap(), b"old");
        assert_eq!(dir_entries(dir.path()), ["out.txt"]);
    }

    #[test]
    fn atomic_write_failure_without_target_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.txt");
        let result = write_atomically(&target, |tmp| {
            fs::write(tmp, b"partial").unwrap();
            Err(OutputError::format(tmp, "simulated failure"))
        });
        assert!(result.is_err());
        assert!(dir_entries(dir.path()).is_empty());
    }

    #[test]
    fn atomic_write_into_missing_directory_is_io_error_with_path() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("no-such-dir").join("out.txt");
        let err = write_atomically(&target, |tmp| fs::write(tmp, b"x").map_err(|e| OutputError::io(tmp, e)))
            .unwrap_err();
        assert!(matches!(err, OutputError::Io { .. }));
        assert!(err.to_string().contains("no-such-dir"), "{err}");
    }

    #[test]
    fn temp_file_names_are_recognised_exactly() {
        assert_eq!(temp_file_pid(".out.exr.tmp-123-0", "out.exr"), Some(123));
        assert_eq!(temp_file_pid(".out.exr.tmp-7-42", "out.exr"), Some(7));
        for other in
            [".out.exr.tmp-123", ".out.exr.tmp-x-0", ".out.exr.tmp--0", "out.exr.tmp-1-0", ".o.exr.tmp-1-0"]
        {
            assert_eq!(temp_file_pid(other, "out.exr"), None, "{other}");
        }
    }

    #[test]
    fn staging_removes_only_the_temp_files_of_dead_processes() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.exr");
        // No process has an id this large (Linux caps them at 2^22).
        let dead = ".out.exr.tmp-999999999-0";
        let own = format!(".out.exr.tmp-{}-999999", std::process::id());
        let keep =
            [own.as_str(), ".other.exr.tmp-999999999-0", ".out.exr.tmp-x-0", "out.exr.tmp-999999999-0"];
        for name in keep.iter().chain([&dead]) {
            fs::write(dir.path().join(name), b"partial").unwrap();
        }
        write_atomically(&target, |tmp| fs::write(tmp, b"new").map_err(|e| OutputError::io(tmp, e))).unwrap();
        let mut expected: Vec<String> = keep.iter().map(|s| s.to_string()).collect();
        if process_running(1).is_none() {
            // Without /proc nothing can be known to be stale: nothing is removed.
            expected.push(dead.to_string());
        }
        expected.push("out.exr".to_string());
        expected.sort();
        assert_eq!(dir_entries(dir.path()), expected);
    }

    #[test]
    fn an_abandoned_registry_removes_its_files_and_refuses_more() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join(".x.tmp-1-0");
        fs::write(&file, b"partial").unwrap();
        let mut registry = Registry { live: vec![file.clone()], aborting: false };
        registry.abandon();
        assert!(registry.aborting && registry.live.is_empty());
        assert!(!file.exists());
    }

    #[test]
    fn pixel_count_mismatch_is_rejected() {
        let mut image = Image::new(3, 2);
        image.pixels.pop();
        let err = check_pixel_count(Path::new("x.exr"), &image).unwrap_err();
        assert!(err.to_string().contains("x.exr"), "{err}");
    }
}
