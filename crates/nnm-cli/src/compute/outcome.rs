//! What a branch came to: computed, failed, or skipped after Ctrl-C.

use anyhow::Result;
use nnm::{Branch, Start};
use nnm_io::output::BranchInfo;

/// One branch of a command, done.
pub struct Outcome {
    pub info: BranchInfo,
    /// The branch, or why it failed ([`NotStarted`] after Ctrl-C).
    pub result: Result<Branch>,
    /// Wall time of its computation (0 for a branch not started).
    pub seconds: f64,
    /// The start the branch was computed from (what a switched branch builds on).
    pub start: Option<Start>,
}

/// A branch skipped because Ctrl-C came before it started.
#[derive(Debug)]
pub struct NotStarted;

impl std::fmt::Display for NotStarted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("not started (interrupted)")
    }
}

impl std::error::Error for NotStarted {}

/// `"<branch>: <error>"` for every branch that failed (not those skipped after Ctrl-C).
pub fn failures(outcomes: &[Outcome]) -> Vec<String> {
    outcomes
        .iter()
        .filter_map(|o| {
            let e = o.result.as_ref().err()?;
            (!e.is::<NotStarted>()).then(|| format!("{}: {e:#}", o.info.name))
        })
        .collect()
}
