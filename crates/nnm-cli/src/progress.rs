//! `--quiet`: errors only. Commands that print progress from deep inside (the study's
//! sections) ask here instead of carrying the flag through every call; one command runs per
//! process, so the switch is set once, at its start.

use std::sync::atomic::{AtomicBool, Ordering};

static QUIET: AtomicBool = AtomicBool::new(false);

/// Whether a progress line went to stderr ([`line`]).
static SAID: AtomicBool = AtomicBool::new(false);

/// Silences [`say!`] for the rest of the process.
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// Whether `--quiet` was given.
pub fn quiet() -> bool {
    QUIET.load(Ordering::Relaxed)
}

/// A progress line on stderr (whatever `--quiet` says: the caller decides), remembered for
/// [`separate`]. Formatted first and written by one call: `eprintln!` writes a line piece by
/// piece (stderr is unbuffered), and the interrupt handler's line could land inside it.
pub fn line(text: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let whole = format!("{text}\n");
    let _ = std::io::stderr().lock().write_all(whole.as_bytes());
    SAID.store(true, Ordering::Relaxed);
}

/// Whether a progress line came before: the interrupt handler's line is set off from them by
/// a blank line, and has none before it otherwise. An atomic load: async-signal-safe.
pub fn said() -> bool {
    SAID.load(Ordering::Relaxed)
}

/// A blank line on stderr between the progress lines and what follows them (the summary,
/// the `error:` line) — none when no line came before, so that stderr never starts with a
/// blank line (a run whose only branch failed before its first point says just its error).
pub fn separate() {
    if SAID.load(Ordering::Relaxed) {
        eprintln!();
    }
}

/// [`line`] unless `--quiet`.
macro_rules! say {
    ($($arg:tt)*) => {
        if !$crate::progress::quiet() {
            $crate::progress::line(format_args!($($arg)*));
        }
    };
}
pub(crate) use say;
