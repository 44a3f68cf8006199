//! Job files (TOML, docs/job-files.md): the model, and the branches and forced responses to
//! compute.
//!
//! ```toml
//! [model]
//! family = "bladed-disk"          # or "duffing", "two-dof"; omit for a general model
//! sectors = 30
//!
//! [settings]                      # optional defaults for every branch
//! tolerance = 1e-8
//!
//! [[branch]]
//! name = "mode-1-5"
//! mode = "1,5"                    # label "n,d", or 0-based index into the ascending modes
//! energy_max = 10.0
//!
//! [[branch]]                      # switch onto the family through an event of a branch above
//! name = "switched"
//! start = { branch = "mode-1-5", event = 0 }   # row `index` of mode-1-5.events.csv
//! energy_max = 10.0
//! ```
//!
//! A general model (no `family`) takes `mass` and `stiffness` (rows, or Matrix Market files),
//! `fixed_dofs` (0-based, like springs' `dofs`; removed from the model, docs/method.md
//! eq. (61)) and `[[model.nonlinear]]` elements: `cubic`/`polynomial` springs and `tensor`
//! terms from files (1-based, like Matrix Market; eq. (57)).
//!
//! Unknown keys are errors (a typo must not silently fall back to a default), and every error
//! is one line naming the file and, where it can, the line and column.
//!
//! The module's files, one concern each: `schema` (the TOML's serde structs), `load`
//! (reading, overrides, the order of the checks), `model` (a family or a general model),
//! `families` (the built-in families, one enum over their parameter structs), `elements`
//! (nonlinear elements), `matrices` (matrix rows and files), `branch` (a branch's mode and its
//! settings merged over `[settings]`), `response` (damping, and a forced response's force,
//! curves and settings).

use std::path::PathBuf;

use nnm::Settings;
use nnm::model::{ModelError, Structure};
use nnm::modes::StandingWave;
use nnm::shooting::Travel;

use crate::matrix_market::MatrixMarketError;

mod branch;
mod elements;
mod families;
mod load;
mod matrices;
mod model;
mod response;
mod schema;

pub use branch::{
    BranchBody, RESONANCE_FORCE, SWITCH_AMPLITUDE, branch_body, branch_mode, phase_name,
    resolve_mode,
};
pub use elements::{Element, spring};
pub use families::{Family, family_defaults, family_names, family_parameter_names};
pub use load::{MAX_BRANCH_NAME, load_job, load_job_with, parse_job};
pub use model::{BuiltModel, general_model, model_from_table};
pub use response::{
    AMPLITUDE_START_RATIO, ForceForm, RESPONSE_KEYS, RESPONSE_SETTINGS_KEYS, ResponseBody,
    ResponseJob, damping_matrix, energy_balance, force_shape, given_damping_matrix, response_body,
    response_settings,
};
pub use schema::{DampingSpec, EventStart};

/// Why a job file was rejected.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    #[error("cannot read {path}: {reason}")]
    Read { path: PathBuf, reason: String },
    #[error("{path}:{line}:{column}: {message}")]
    Syntax {
        path: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    // The model's own message says what is wrong ("invalid model parameter: …", "mass matrix
    // is not positive definite"); a second "invalid model:" only stuttered.
    #[error("{path}: {error}")]
    Model { path: PathBuf, error: ModelError },
    // Transparent: with `{0}` and `#[from]` (a source), error chains printed the message twice.
    #[error(transparent)]
    Matrix(#[from] MatrixMarketError),
}

/// A parsed job: the model and the branches asked for.
#[derive(Debug)]
pub struct Job {
    pub structure: Structure,
    /// The model family (`"bladed-disk"`, `"duffing"`, `"two-dof"`, `"cantilever-beam"`,
    /// `"von-karman-beam"`, or `"general"`).
    pub family: String,
    pub branches: Vec<BranchJob>,
    /// The `[settings]` section alone (what a branch gets when it sets nothing itself).
    pub default_settings: Settings,
    /// `C` of `[model] damping`, after `fixed_dofs`, checked symmetric positive semi-definite.
    pub damping: Option<nnm::model::Matrix>,
    /// `[model] damping` as written (what `damping` was built from).
    pub damping_spec: Option<DampingSpec>,
    /// `[model] fixed_dofs`: the numbering a force's `dofs` and a damping `matrix` are given
    /// in (the full one) against the model's.
    pub fixed_dofs: Option<nnm::model::FixedDofs>,
    /// The forced responses (`[[response]]`), in the order of the file.
    pub responses: Vec<ResponseJob>,
    /// Where the model's dofs sit in space (beams and solids), for ParaView output.
    pub layout: Option<nnm::model::Layout>,
}

/// One branch to compute.
#[derive(Debug, Clone)]
pub struct BranchJob {
    pub name: String,
    /// Mode label `"n,d"` or index, as written (empty for a branch started from an event).
    pub mode: String,
    /// Start from an event of an earlier branch instead of a linear mode.
    pub from_event: Option<EventStart>,
    pub pattern: Option<StandingWave>,
    /// `pattern = "travelling"` (or `"travelling-backward"`): the travelling wave of the pair.
    pub travel: Option<Travel>,
    /// Every setting of the branch: the `[settings]` section overridden key by key by the
    /// branch's own (the start energy and symmetry restriction are in `settings.start`).
    pub settings: Settings,
}

#[cfg(test)]
mod tests;
