//! What `nnm run`, `nnm study` and `nnm example cantilever-beam` share: a branch from its job
//! entry to its files. [`request`] resolves each branch's starting mode (or its parent's event),
//! [`pool`] computes the branches on worker threads, [`branch`] follows one branch, writing it
//! point by point through the observer of [`writing`], [`outcome`] is what each branch came to,
//! and [`summary`] prints them. The commands build on this; nothing here knows of a command.

mod branch;
mod outcome;
mod pool;
mod request;
mod summary;
mod writing;

pub use branch::compute_branch;
pub use outcome::{NotStarted, Outcome, failures};
pub use pool::compute_all;
pub use request::{make_start, resolve};
pub use summary::print_summary;
