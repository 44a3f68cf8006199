//! Exit codes: a command that wrote its results but did not finish what was asked ends with its
//! own code, told apart from a failure (1).

/// Exit code of a run whose every branch ran, but one stopped before its limit (no
/// convergence at the minimum step): its results are written, yet a script must not take them
/// for the branch asked for. (2 is clap's code for a command-line usage error.)
pub const EXIT_STOPPED_EARLY: u8 = 3;

/// A command that wrote its results but did not finish what was asked; told apart from a
/// failure (exit code 1) by its own exit code.
#[derive(Debug)]
pub enum Unfinished {
    /// A branch stopped before its limit ([`EXIT_STOPPED_EARLY`]).
    StoppedEarly(String),
    /// Ctrl-C or SIGTERM (exit code 128 + the signal's number: [`crate::interrupt::exit_code`]).
    Interrupted(String),
}

impl std::fmt::Display for Unfinished {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Unfinished::StoppedEarly(m) | Unfinished::Interrupted(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for Unfinished {}

/// The process's exit code for a command that returned `error`.
pub fn exit_code(error: &anyhow::Error) -> u8 {
    match error.downcast_ref::<Unfinished>() {
        Some(Unfinished::StoppedEarly(_)) => EXIT_STOPPED_EARLY,
        Some(Unfinished::Interrupted(_)) => crate::interrupt::exit_code(),
        None => 1,
    }
}
