//! Tests that drive system programs for real (headless Chromium, a Slurm cluster with munge, GNU
//! parallel) check for them first. On a machine without them such a test prints one line saying
//! what it did not run and how to install what it needs, and passes without running; with the
//! environment variable [`REQUIRE`] set (`.ci/run` sets it after installing them) a missing
//! program fails the test instead, so CI cannot skip them silently.

use std::io::Write;
use std::path::{Path, PathBuf};

/// The environment variable that makes a missing system program a test failure.
pub const REQUIRE: &str = "VITRUM_REQUIRE_SYSTEM_TESTS";

/// The running test's name (the test harness names each test's thread after it).
fn test_name() -> String {
    std::thread::current().name().unwrap_or("a test").to_owned()
}

/// Whether the running test may run: `missing` lists what this machine lacks (empty: nothing), `install` says
/// how to get it. With something missing, prints the skip line on the terminal (past the test
/// harness's capture, so a plain `cargo test` shows it) and returns false, or panics with the same
/// line when [`REQUIRE`] is set.
pub fn may_run(missing: &[String], install: &str) -> bool {
    if missing.is_empty() {
        return true;
    }
    let line = format!("not run: {}: needs {} (install: {install})", test_name(), missing.join(", "));
    if std::env::var_os(REQUIRE).is_some_and(|v| !v.is_empty() && v != "0") {
        panic!("{line}; {REQUIRE} is set, so a missing program is a failure");
    }
    // std::io::stderr() is not captured by the test harness (only the print macros are).
    let _ = writeln!(std::io::stderr().lock(), "{line}");
    false
}

/// The file `program` names: itself when it contains a `/`, else its first match on the `PATH`.
pub fn find_program(program: &str) -> Option<PathBuf> {
    if program.contains('/') {
        return Path::new(program).is_file().then(|| PathBuf::from(program));
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path).map(|dir| dir.join(program)).find(|p| p.is_file())
}

/// The programs of `programs` that are not on the `PATH`.
pub fn missing_programs(programs: &[&str]) -> Vec<String> {
    programs.iter().filter(|p| find_program(p).is_none()).map(|p| p.to_string()).collect()
}

/// Whether the test process runs as root.
pub fn is_root() -> bool {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let uid = status.lines().find_map(|l| l.strip_prefix("Uid:")).and_then(|l| l.split_whitespace().next());
    uid == Some("0")
}

/// Whether a browser test may run: headless Chromium (see `browser::Browser::launch`) is there.
pub fn may_run_browser() -> bool {
    let missing: Vec<String> = super::browser::find_chromium()
        .err()
        .map(|e| format!("Chromium ({})", e.trim_start_matches("no Chromium: ")))
        .into_iter()
        .collect();
    may_run(&missing, "apt-get install chromium, or set CHROMIUM to a Chromium binary")
}
