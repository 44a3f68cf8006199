//! Ctrl-C (SIGINT) as a request to stop, not a kill: the branches in progress stop at their
//! next point or event (everything computed is already on disk), branches not yet started
//! are skipped, and the command still writes its summary, frequency–energy plot and report for
//! what was finished, then exits with [`crate::exit::EXIT_INTERRUPTED`]. A second Ctrl-C ends the
//! process at once (the handler is reset to the default action when the first is delivered),
//! for a point that would take too long to finish.

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Whether Ctrl-C was pressed.
pub fn requested() -> bool {
    REQUESTED.load(Ordering::Relaxed)
}

/// The line printed on the first Ctrl-C, from the handler (so only `write(2)`, which is
/// async-signal-safe, not Rust's buffered, locking `eprintln!`).
const MESSAGE: &[u8] = b"\ninterrupted: finishing the points in progress and writing what is done (Ctrl-C again to quit at once)\n";

#[cfg(unix)]
extern "C" fn on_sigint(_: libc::c_int) {
    REQUESTED.store(true, Ordering::Relaxed);
    // SAFETY: write(2) is async-signal-safe; the buffer is static. Its result is ignored:
    // nothing can be done about a closed stderr here.
    unsafe {
        libc::write(2, MESSAGE.as_ptr().cast(), MESSAGE.len());
    }
}

/// Installs the handler (unix; elsewhere Ctrl-C keeps its default action).
pub fn install() {
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any other thread exists; the handler only
    // stores to an atomic and calls write(2). SA_RESETHAND restores the default action once
    // the first SIGINT is delivered, so a second one ends the process.
    unsafe {
        let mut action: libc::sigaction = std::mem::zeroed();
        action.sa_sigaction = on_sigint as extern "C" fn(libc::c_int) as libc::sighandler_t;
        action.sa_flags = libc::SA_RESETHAND | libc::SA_RESTART;
        libc::sigemptyset(&mut action.sa_mask);
        libc::sigaction(libc::SIGINT, &action, std::ptr::null_mut());
    }
}
