//! Ctrl-C (SIGINT) and SIGTERM as a request to stop, not a kill: the branches in progress stop
//! at their next point or event (everything computed is already on disk), branches not yet
//! started are skipped, and the command still writes its summary, frequency–energy plot and
//! report for what was finished, then exits with 128 + the signal's number ([`exit_code`]: 130
//! for Ctrl-C, 143 for SIGTERM).
//!
//! A second signal (or SIGHUP, the terminal gone: nothing can be printed any more) quits at
//! once — yet not in the middle of a write of the branch files: a write in progress
//! ([`writing`]) is finished first, so the files hold every point and event written, whole. The
//! output folder's lock ([`hold_lock`]) is removed, then the process ends by the signal itself
//! (as shells expect of a process that did not finish). A third signal quits even while a write
//! is stuck.

use std::ffi::c_char;
use std::path::Path;
use std::sync::atomic::{AtomicI32, AtomicPtr, AtomicUsize, Ordering};

/// The first stopping signal received (0: none).
static SIGNAL: AtomicI32 = AtomicI32::new(0);
/// Signals received so far.
static RECEIVED: AtomicUsize = AtomicUsize::new(0);
/// The signal that asked to quit at once (0: none).
static QUIT: AtomicI32 = AtomicI32::new(0);
/// Writes of branch files in progress.
static WRITING: AtomicUsize = AtomicUsize::new(0);
/// The output folder's lock file, removed when quitting at once (null: none held). The string
/// is leaked, never freed, so that the handler can read it at any time.
static LOCK: AtomicPtr<c_char> = AtomicPtr::new(std::ptr::null_mut());

/// Whether Ctrl-C or SIGTERM came.
pub fn requested() -> bool {
    SIGNAL.load(Ordering::SeqCst) != 0
}

/// The exit code of a run stopped by a signal: 128 + its number, as shells report a process
/// ended by it (130 for Ctrl-C, 143 for SIGTERM; 130 when none came).
pub fn exit_code() -> u8 {
    match SIGNAL.load(Ordering::SeqCst) {
        0 => 130,
        signal => u8::try_from(128 + signal).unwrap_or(130),
    }
}

/// The lines printed on the first Ctrl-C or SIGTERM, from the handler (so only `write(2)`,
/// which is async-signal-safe, not Rust's buffered, locking `eprintln!`). The leading newline
/// only after progress lines (a blank line between them), or where a terminal echoed `^C`
/// ([`newline_first`]): stderr never starts with a blank line.
const MESSAGE: &[u8] = b"\ninterrupted: finishing the points in progress and writing what is done (Ctrl-C again to quit at once)\n";
const TERMINATED: &[u8] = b"\nterminated (SIGTERM): finishing the points in progress and writing what is done (a second signal quits at once)\n";

#[cfg(unix)]
extern "C" fn on_signal(signal: libc::c_int) {
    let first = RECEIVED.fetch_add(1, Ordering::SeqCst) == 0;
    if signal != libc::SIGHUP && first {
        SIGNAL.store(signal, Ordering::SeqCst);
        let message = if signal == libc::SIGTERM {
            TERMINATED
        } else {
            MESSAGE
        };
        let message = if newline_first(signal) {
            message
        } else {
            &message[1..]
        };
        // SAFETY: write(2) is async-signal-safe; the buffer is static. Its result is ignored:
        // nothing can be done about a closed stderr here.
        unsafe {
            libc::write(2, message.as_ptr().cast(), message.len());
        }
        return;
    }
    QUIT.store(signal, Ordering::SeqCst);
    // A write in progress quits when it is done ([`writing`]); a third signal does not wait.
    if WRITING.load(Ordering::SeqCst) == 0 || RECEIVED.load(Ordering::SeqCst) > 2 {
        quit(signal);
    }
}

/// Whether stderr was a terminal when the handlers were installed.
static TERMINAL: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether the first signal's line starts on a new line: after a progress line, or after the
/// `^C` a terminal echoes for Ctrl-C (not for a `kill`, which echoes nothing, nor into a file
/// or pipe). Atomic loads only: async-signal-safe.
#[cfg(unix)]
fn newline_first(signal: libc::c_int) -> bool {
    crate::progress::said() || (signal == libc::SIGINT && TERMINAL.load(Ordering::SeqCst))
}

/// Removes the lock and ends the process by `signal` (its default action), only
/// async-signal-safe calls.
#[cfg(unix)]
fn quit(signal: libc::c_int) -> ! {
    // SAFETY: unlink, signal, pthread_sigmask, raise and _exit are async-signal-safe; the lock
    // path is a leaked, NUL-terminated string that is never freed.
    unsafe {
        let lock = LOCK.load(Ordering::SeqCst);
        if !lock.is_null() {
            libc::unlink(lock);
        }
        libc::signal(signal, libc::SIG_DFL);
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        libc::sigaddset(&mut set, signal);
        libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
        libc::raise(signal);
        libc::_exit(128 + signal)
    }
}

/// Runs `write` (a write of branch files) so that a signal asking to quit at once waits for it
/// to end, and quits right after it; a write asked for once quitting was decided is not begun.
pub fn writing<T>(write: impl FnOnce() -> T) -> T {
    WRITING.fetch_add(1, Ordering::SeqCst);
    if QUIT.load(Ordering::SeqCst) != 0 {
        done_writing();
        // Another write is ending and will quit.
        loop {
            std::thread::park();
        }
    }
    let result = write();
    done_writing();
    result
}

/// Ends a write; the last one quits if a signal asked to meanwhile.
fn done_writing() {
    let left = WRITING.fetch_sub(1, Ordering::SeqCst) - 1;
    #[cfg(unix)]
    {
        let signal = QUIT.load(Ordering::SeqCst);
        if left == 0 && signal != 0 {
            quit(signal);
        }
    }
    #[cfg(not(unix))]
    let _ = left;
}

/// Records `path` as the lock to remove if a signal quits the process at once.
pub fn hold_lock(path: &Path) {
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        if let Ok(path) = std::ffi::CString::new(path.as_os_str().as_bytes()) {
            LOCK.store(path.into_raw(), Ordering::SeqCst);
        }
    }
    #[cfg(not(unix))]
    let _ = path;
}

/// The lock is removed by its holder: nothing to remove when quitting.
pub fn release_lock() {
    // The string stays leaked: the handler may be reading it.
    LOCK.store(std::ptr::null_mut(), Ordering::SeqCst);
}

/// Installs the handlers (unix; elsewhere the signals keep their default action): SIGINT and
/// SIGTERM, and SIGHUP unless it is ignored (`nohup`).
pub fn install() {
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any other thread exists; the handler only
    // uses atomics and async-signal-safe calls.
    unsafe {
        TERMINAL.store(libc::isatty(2) == 1, Ordering::SeqCst);
        let mut action: libc::sigaction = std::mem::zeroed();
        action.sa_sigaction = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
        action.sa_flags = libc::SA_RESTART;
        // The other signals wait while the handler runs: it sees them one at a time.
        libc::sigemptyset(&mut action.sa_mask);
        for signal in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
            libc::sigaddset(&mut action.sa_mask, signal);
        }
        libc::sigaction(libc::SIGINT, &action, std::ptr::null_mut());
        libc::sigaction(libc::SIGTERM, &action, std::ptr::null_mut());
        let mut hangup: libc::sigaction = std::mem::zeroed();
        libc::sigaction(libc::SIGHUP, std::ptr::null(), &mut hangup);
        if hangup.sa_sigaction != libc::SIG_IGN {
            libc::sigaction(libc::SIGHUP, &action, std::ptr::null_mut());
        }
    }
}
