//! The memory a render needs, estimated before anything is allocated, against the memory the
//! machine has: a render that cannot fit is refused with the estimate (exit code 2) instead of
//! failing part way through an allocation.
//!
//! The estimate is the render's own allocations (the scene is loaded already, so what it holds
//! is no longer available and is not counted again):
//! - the film: per pixel of the crop window, the f64 RGB sum and one per replica (24·(1 + R)
//!   bytes);
//! - the outputs: the image (12 bytes a pixel) and, with the variance (two or more replicas
//!   holding samples), the variance image, the replicas' means and their f32 channels, twice
//!   (channels and encoded file);
//! - the method's working memory beyond the film ([`crate::integrators::Integrator::working_memory`]):
//!   the stored light sub-paths of the bidirectional methods, bounded by their cap whatever the
//!   resolution; nothing that grows with the pixel count for the other methods.
//!
//! The memory available is `MemAvailable` of `/proc/meminfo`, and, when the process runs in a
//! cgroup (v2) with a `memory.max`, that limit less the cgroup's `memory.current`, whichever is
//! less. The variable [`AVAILABLE_OVERRIDE`] replaces both (for tests). Where neither can be
//! read (not Linux), no render is refused.

use crate::integrators::Integrator;
use crate::render::{camera_for, Budget, RenderOptions};
use crate::scene::Scene;
use std::fmt;

/// The environment variable that, when set to a number of bytes, is taken as the memory
/// available instead of what the system reports (for tests of the refusal).
pub const AVAILABLE_OVERRIDE: &str = "VITRUM_AVAILABLE_MEMORY";

/// What a render will allocate, by part, in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryEstimate {
    /// The film's sums.
    pub film: u64,
    /// The output images and channels.
    pub outputs: u64,
    /// The method's working memory beyond the film.
    pub method: u64,
}

impl MemoryEstimate {
    /// The estimate of a render of `scene` by `integrator` with `opts`.
    pub fn of(scene: &Scene, integrator: &dyn Integrator, opts: &RenderOptions) -> MemoryEstimate {
        let pixels = camera_for(scene, opts.resolution).crop.pixels() as u64;
        let r = opts.replicas.count() as u64;
        let variance = r >= 2 && !matches!(opts.budget, Budget::Samples(n) if n < 2);
        let film = pixels * 24 * (1 + r);
        // Image; with the variance: variance image, R means, then (R·3 + 4) f32 channels, twice.
        let per_pixel = if variance { 12 + 12 + 12 * r + 2 * 4 * (3 * r + 4) } else { 12 };
        MemoryEstimate { film, outputs: pixels * per_pixel, method: integrator.working_memory(scene, opts) }
    }

    /// All parts together.
    pub fn total(&self) -> u64 {
        self.film + self.outputs + self.method
    }
}

impl fmt::Display for MemoryEstimate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "about {} (film {}, outputs {}, method {})",
            mib(self.total()),
            mib(self.film),
            mib(self.outputs),
            mib(self.method)
        )
    }
}

/// `bytes` in MiB (rounded up), for messages.
pub fn mib(bytes: u64) -> String {
    format!("{} MiB", bytes.div_ceil(1 << 20))
}

/// The memory available to this process in bytes and where the figure comes from; `None`
/// where the system tells nothing; an error for an [`AVAILABLE_OVERRIDE`] that is not a number.
pub fn available() -> Result<Option<(u64, &'static str)>, String> {
    if let Ok(text) = std::env::var(AVAILABLE_OVERRIDE) {
        return text
            .trim()
            .parse::<u64>()
            .map(|b| Some((b, AVAILABLE_OVERRIDE)))
            .map_err(|_| format!("{AVAILABLE_OVERRIDE}: `{text}` is not a number of bytes"));
    }
    let system = std::fs::read_to_string("/proc/meminfo").ok().and_then(|m| mem_available(&m));
    let cgroup = cgroup_room();
    Ok(match (system, cgroup) {
        (Some(s), Some(c)) if c < s => Some((c, "the cgroup's memory.max less memory.current")),
        (Some(s), _) => Some((s, "MemAvailable in /proc/meminfo")),
        (None, Some(c)) => Some((c, "the cgroup's memory.max less memory.current")),
        (None, None) => None,
    })
}

/// `MemAvailable` of the text of `/proc/meminfo`, in bytes.
fn mem_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// The room left under this process's cgroup (v2) memory limit, `None` without a limit.
fn cgroup_room() -> Option<u64> {
    let own = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let path = own.lines().find_map(|l| l.strip_prefix("0::"))?.trim();
    let dir = std::path::Path::new("/sys/fs/cgroup").join(path.trim_start_matches('/'));
    let max: u64 = std::fs::read_to_string(dir.join("memory.max")).ok()?.trim().parse().ok()?;
    let current: u64 = std::fs::read_to_string(dir.join("memory.current"))
        .ok()
        .and_then(|c| c.trim().parse().ok())
        .unwrap_or(0);
    Some(max.saturating_sub(current))
}

/// Refuse a render whose estimate exceeds the memory available: the message gives both.
pub fn check(scene: &Scene, integrator: &dyn Integrator, opts: &RenderOptions) -> Result<(), String> {
    let need = MemoryEstimate::of(scene, integrator, opts);
    match available()? {
        Some((have, from)) if need.total() > have => Err(format!(
            "the render needs {need}, more than the {} available ({from}); lower --resolution or --replicas",
            mib(have)
        )),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mem_available_is_read_in_bytes() {
        let meminfo = "MemTotal:       16303424 kB\nMemFree:         1000 kB\nMemAvailable:    8000000 kB\n";
        assert_eq!(mem_available(meminfo), Some(8_000_000 * 1024));
        assert_eq!(mem_available("MemTotal: 5 kB\n"), None);
    }
}
