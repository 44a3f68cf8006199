//! Forced, damped periodic responses: frequency response curves and force–amplitude curves
//! of `M x'' + C x' + f_int(x) = a (F_c cos Ωt + F_s sin Ωt)` by shooting over the fixed
//! forcing period and pseudo-arclength continuation through folds, with Floquet stability and
//! located events (docs/method.md §19).
//!
//! - [`forced_response`] computes one curve of a [`ForcedSystem`](crate::model::ForcedSystem)
//!   over a [`Sweep`] (in frequency, or in force amplitude at a fixed frequency);
//! - [`ForcedShooting`] is the continuation problem (a [`crate::ContinuationProblem`]), for
//!   callers that drive the continuation themselves;
//! - [`damping`] builds `C` from the forms users give it (Rayleigh, modal ratios, a matrix),
//!   [`Force`] the force shape (dofs, a vector, an engine order).

mod curve;
pub mod damping;
mod events;
mod force;
mod linear;
mod matrix_free;
mod problem;

pub use curve::{
    LOWEST_FREQUENCY_RATIO, MATRIX_FREE_DOFS, ResponseCurve, ResponseError, ResponseItem,
    ResponseSettings, ResponseStop, check_sweep, check_sweep_resolvable, forced_response,
};
pub use events::{ResponseEvent, ResponseEventKind, ResponseEvents};
pub use force::{Force, ForceError};
pub use matrix_free::ForcedOperator;
pub use problem::{
    ForcedError, ForcedEvaluation, ForcedShooting, ForcedStats, ResponsePoint, Scales, Sweep,
};

#[cfg(test)]
mod tests;
