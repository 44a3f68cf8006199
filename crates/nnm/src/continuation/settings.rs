//! The settings the continuation reads (docs/method.md §5), and the error a setting out of
//! its range makes. [`crate::settings::Settings`] gathers this group with the others and
//! validates them all.

use serde::{Deserialize, Serialize};

/// Pseudo-arclength continuation (docs/method.md §5).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ContinuationSettings {
    /// Convergence tolerance `ε` of the corrector on the problem's relative residual
    /// (eq. (19); default 1e-8; from [`MIN_TOLERANCE`] to 1e-2).
    pub tolerance: f64,
    /// First step, relative to the starting amplitude (default 0.1).
    pub initial_step: f64,
    /// Smallest step, relative to the amplitude, before giving up (default 1e-6).
    pub min_step: f64,
    /// Largest step, relative to the amplitude (default 0.25: the energy grows by at most
    /// ~60% a step, which keeps a frequency–energy plot resolved).
    pub max_step: f64,
    /// Newton iterations allowed per step (default 8).
    pub max_iterations: usize,
    /// Corrector iterations the step control aims at (default 3).
    pub target_iterations: usize,
    /// Largest angle between consecutive tangents, radians (default 0.5 ≈ 29°).
    pub max_turn_angle: f64,
}

impl Default for ContinuationSettings {
    fn default() -> Self {
        Self {
            tolerance: 1e-8,
            initial_step: 0.1,
            min_step: 1e-6,
            max_step: 0.25,
            max_iterations: 8,
            target_iterations: 3,
            max_turn_angle: 0.5,
        }
    }
}

/// The smallest `tolerance` accepted: the relative residual of a period integrated in double
/// precision does not fall much below 1e-15 (round-off of the state and of every step), so a
/// smaller tolerance cannot be met and would only end in a failed first point.
pub const MIN_TOLERANCE: f64 = 1e-14;

/// A setting out of its range. Defined with the continuation because its error
/// ([`super::ContinuationError::Settings`]) carries it: a branch refuses its settings before
/// it starts.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("invalid setting: {0}")]
pub struct SettingsError(pub String);
