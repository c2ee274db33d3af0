//! Image files: linear HDR EXR with render metadata, and tone-mapped sRGB PNG previews.
//!
//! Every writer goes through [`write_atomically`], so a reader (a viewer, a running sweep) never
//! sees a half-written file and a failed write never destroys an existing one.

pub mod exr;
pub mod png;

use crate::image::Image;
use std::fs;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

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

/// Removes the temporary file when dropped, unless it has been renamed into place.
struct TempFile {
    path: PathBuf,
    keep: bool,
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if !self.keep {
            // It may never have been created; there is nothing useful to do on failure.
            let _ = fs::remove_file(&self.path);
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
    /// Publish the file under its final name (an atomic rename).
    pub fn commit(mut self) -> Result<(), OutputError> {
        fs::rename(&self.tmp.path, &self.target).map_err(|e| OutputError::io(&self.target, e))?;
        self.tmp.keep = true;
        Ok(())
    }
}

/// Write `path`'s contents to a temporary file with `write(tmp_path)` and make them durable,
/// without publishing them yet; dropping the result removes the temporary file.
pub fn stage(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), OutputError>,
) -> Result<Staged, OutputError> {
    let Some(file_name) = path.file_name() else {
        let e = io::Error::new(io::ErrorKind::InvalidInput, "the output path has no file name");
        return Err(OutputError::io(path, e));
    };
    let counter = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
    let tmp_name = format!(".{}.tmp-{}-{counter}", file_name.to_string_lossy(), std::process::id());
    // The guard also cleans up if `write` panics.
    let tmp = TempFile { path: path.with_file_name(tmp_name), keep: false };
    write(&tmp.path)?;
    // Make the contents durable before a rename publishes them, so a crash cannot leave an
    // empty or partial file under the final name.
    let sync = fs::OpenOptions::new().write(true).open(&tmp.path).and_then(|f| f.sync_all());
    sync.map_err(|e| OutputError::io(&tmp.path, e))?;
    Ok(Staged { tmp, target: path.to_path_buf() })
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
    fn pixel_count_mismatch_is_rejected() {
        let mut image = Image::new(3, 2);
        image.pixels.pop();
        let err = check_pixel_count(Path::new("x.exr"), &image).unwrap_err();
        assert!(err.to_string().contains("x.exr"), "{err}");
    }
}
