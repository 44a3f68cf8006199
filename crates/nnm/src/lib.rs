//! # nnm — nonlinear normal modes
//!
//! Computes branches of periodic motions (nonlinear normal modes, NNMs) of conservative
//! structures `M x'' + K x + f_nl(x) = 0` by shooting with sensitivity analysis and
//! pseudo-arclength continuation, with Floquet stability and bifurcations. The equations the
//! code implements are numbered in `docs/method.md`; the layers and where to plug in are in
//! `docs/architecture.md`.
//!
//! The crate is the numerical core and does no file or terminal I/O. Its layers:
//! - [`model`]: the mechanical model — the [`MechanicalSystem`] trait any structure
//!   implements, and [`Structure`] (mass and stiffness matrices plus nonlinear elements);
//! - [`modes`]: linear modal analysis (the starting points of NNM branches);
//! - [`integrate`]: time integration of the motion with its variational equations, behind
//!   the [`integrate::Integrator`] trait;
//! - [`shooting`]: the periodicity problem `H(z0, T) = z(T; z0) - z0 = 0`, its Jacobian and
//!   monodromy, and where a branch [`Start`]s;
//! - [`continuation`]: pseudo-arclength continuation of any [`ContinuationProblem`], as an
//!   iterator of points;
//! - [`floquet`]: multipliers and stability;
//! - [`bifurcation`]: folds, branch points, period doublings and Krein collisions located
//!   between points (an event detector the continuation calls), and branch switching;
//! - [`branch`]: one NNM branch end to end, with limits and an observer;
//! - [`settings`]: the settings of a branch, each group defined beside the layer that reads
//!   it and gathered here, validated;
//! - [`symmetry`], [`analysis`]: mirror symmetry of cyclic structures; harmonics, shape change
//!   and localization of computed NNMs.
//!
//! ```
//! use nnm::prelude::*;
//!
//! // x'' + x + x³ = 0, followed from its linear mode to +10% frequency.
//! let duffing = nnm::model::duffing(1.0, 1.0).unwrap();
//! let start = Start::from_mode(&duffing, 0).unwrap();
//! let mut settings = Settings::default();
//! settings.limits.frequency_shift_max = 0.1;
//! let branch = continue_branch(&duffing, &start, &settings, |_| std::ops::ControlFlow::Continue(())).unwrap();
//! // The branch ends on its limit: the last point is at +10% to 1e-10.
//! assert!((branch.points.last().unwrap().frequency - 1.1).abs() < 1e-9);
//! ```

#![warn(missing_docs)]

pub mod analysis;
pub mod bifurcation;
pub mod branch;
pub mod continuation;
pub mod floquet;
pub mod forced;
pub mod integrate;
pub mod krylov;
pub(crate) mod linalg;
pub mod model;
pub mod modes;
pub mod number;
#[cfg(test)]
mod reference;
pub mod settings;
pub mod shooting;
pub mod symmetry;

/// A complex number `(re, im)`, as Floquet multipliers are returned.
pub use linalg::Complex;
pub use linalg::LinalgError;
/// The dense matrix type of the public API (monodromy matrices, dense model input): faer's.
pub use linalg::Mat;

pub use branch::{
    Branch, BranchStats, Observer, StopReason, continue_branch, continue_branch_observed,
};
pub use continuation::{Continuation, ContinuationError, ContinuationProblem, Item};
pub use model::{MechanicalSystem, Structure};
pub use settings::Settings;
pub use shooting::{BranchPoint, Shooting, Start};

/// What most users need: `use nnm::prelude::*;`.
pub mod prelude {
    pub use crate::bifurcation::{Event, EventKind, switch_branch};
    pub use crate::branch::{
        Branch, Observer, StopReason, continue_branch, continue_branch_observed,
    };
    pub use crate::continuation::{Continuation, ContinuationProblem, Item};
    pub use crate::model::{
        Block, BlockMut, Mass, MassOperator, Matrix, MechanicalSystem, NonlinearElement,
        PolynomialSpring, SparseMatrix, SparsityPattern, Structure,
    };
    pub use crate::modes::{LinearMode, find_mode, linear_modes};
    pub use crate::settings::Settings;
    pub use crate::shooting::{BranchPoint, PhaseCondition, Shooting, Start};
}
