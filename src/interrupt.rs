//! Ctrl-C (SIGINT) during a render: never lose the work done.
//!
//! A process-wide "stop requested" flag ([`stop_requested`]) that the render drivers check
//! between sample passes ([`crate::render`]): a stop lands between two passes, so the image
//! always holds a whole number of samples per pixel. Nothing sets the flag unless
//! [`install_handler`] has been called (`vitrum render` does, just before it starts rendering);
//! other commands keep the default SIGINT behaviour.
//!
//! With the handler installed:
//! - the **first** Ctrl-C requests the stop: the samples in flight (the current pass) are
//!   finished, `vitrum render` writes what it has (EXR with `vitrum:spp` = the samples done,
//!   and the PNG if asked for) and exits with [`EXIT_INTERRUPTED`] (130, as shells report a
//!   SIGINT);
//! - a **second** Ctrl-C aborts at once ([`abort`]): the temporary files of outputs being
//!   written are removed, nothing is published, and the process exits with 130.
//!
//! The process exits with a status rather than dying of the signal (the standard library cannot
//! re-raise it with the default action): a shell script that should stop on Ctrl-C checks for 130.

use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::OnceLock;

/// The exit code of an interrupted command (128 + SIGINT, what shells report).
pub const EXIT_INTERRUPTED: i32 = 130;

/// Whether a stop has been requested.
static STOP: AtomicBool = AtomicBool::new(false);

/// Ctrl-C presses received by the handler.
static SIGNALS: AtomicU32 = AtomicU32::new(0);

/// Whether running renders should stop at their next pass boundary.
pub fn stop_requested() -> bool {
    STOP.load(Ordering::Relaxed)
}

/// Ask running renders to stop at their next pass boundary (what the first Ctrl-C does).
pub fn request_stop() {
    STOP.store(true, Ordering::Relaxed);
}

/// Forget a stop request (for library users that render again after an interrupt).
pub fn reset() {
    STOP.store(false, Ordering::Relaxed);
    SIGNALS.store(0, Ordering::Relaxed);
}

/// Install the Ctrl-C handler (once per process; later calls return the first result).
pub fn install_handler() -> Result<(), String> {
    static INSTALLED: OnceLock<Result<(), String>> = OnceLock::new();
    INSTALLED.get_or_init(|| ctrlc::set_handler(on_signal).map_err(|e| e.to_string())).clone()
}

/// Runs on the handler's own thread (not in signal context) for every Ctrl-C.
fn on_signal() {
    if SIGNALS.fetch_add(1, Ordering::SeqCst) == 0 {
        request_stop();
        eprintln!(
            "\nvitrum: interrupted: finishing the samples in flight, then writing what is done \
             (Ctrl-C again to abort without writing)"
        );
    } else {
        abort();
    }
}

/// Abort now: remove the temporary files of outputs being written (none can be published or
/// created after this), and exit with [`EXIT_INTERRUPTED`].
pub fn abort() -> ! {
    crate::output::abandon_staged();
    eprintln!("\nvitrum: aborted: nothing written");
    std::process::exit(EXIT_INTERRUPTED)
}
