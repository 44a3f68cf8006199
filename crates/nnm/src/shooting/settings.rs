//! The settings groups shooting reads: its own ([`ShootingSettings`]), where a branch starts
//! ([`StartSettings`]) and what a point measures ([`OutputSettings`]); [`SettingsView`]
//! borrows them, with the groups of the layers below, from a [`crate::Settings`], which
//! gathers every group above this layer.

use serde::{Deserialize, Serialize};

use super::{Formulation, JacobianMethod, PhaseCondition};
use crate::continuation::ContinuationSettings;
use crate::floquet::StabilitySettings;
use crate::integrate::IntegrationSettings;

/// How a branch starts from a linear mode.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct StartSettings {
    /// Linear energy of the first guess; `None`: where the nonlinear forces are 1e-4 of the
    /// linear ones along the mode, or their work on the mode when the forces alone leave it
    /// linear (docs/method.md eq. (16)).
    pub energy_start: Option<f64>,
    /// On cyclic models with a verified mirror symmetry, keep the unknowns in the starting
    /// mode's symmetry class (default true).
    pub symmetry: bool,
}

/// The shooting problem (docs/method.md §2–4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ShootingSettings {
    /// How the time shift is removed: zero velocity (default, docs/method.md eq. (7)) or
    /// flow-orthogonal (eq. (8)).
    pub phase: PhaseCondition,
    /// Jacobian from the variational equations (default, docs/method.md eqs. (11)–(13)) or from
    /// finite differences (eq. (32)).
    pub jacobian: JacobianMethod,
    /// Shoot over half a period when the system is odd (checked at sample states; default
    /// true). Every point's full-period residual is still checked.
    pub half_period: bool,
    /// Dense Jacobian and monodromy, or matrix-free Newton–Krylov (docs/method.md §15);
    /// default: chosen by size ([`Formulation::Auto`]).
    pub formulation: Formulation,
}

/// What is measured of every point's motion (docs/method.md §18).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct OutputSettings {
    /// Dofs (0-based, in the model's numbering after `fixed_dofs`) whose peak displacement
    /// over the period is measured at every point; empty (default): the dof where the
    /// starting mode's amplitude is largest.
    pub output_dofs: Vec<usize>,
    /// The damping and force shape whose resonance force every point reports (energy
    /// balance, docs/method.md §21); `None`: none. Built from the model by the front end
    /// (`[settings] resonance_force` and `[model] damping`), so no job-file key of its own.
    #[serde(skip)]
    pub energy_balance: Option<std::sync::Arc<crate::analysis::EnergyBalance>>,
}

impl Default for StartSettings {
    fn default() -> Self {
        Self {
            energy_start: None,
            symmetry: true,
        }
    }
}

impl Default for ShootingSettings {
    fn default() -> Self {
        Self {
            phase: PhaseCondition::ZeroVelocity,
            jacobian: JacobianMethod::Sensitivity,
            half_period: true,
            formulation: Formulation::Auto,
        }
    }
}

/// The settings groups a branch's start and shooting problem read, borrowed. `&Settings`
/// converts into it, so callers pass `&settings`; shooting itself names no
/// [`crate::Settings`], which sits above it and gathers these groups with the branch's own.
#[derive(Debug, Clone, Copy)]
pub struct SettingsView<'s> {
    /// Phase condition, Jacobian, half-period shooting, formulation.
    pub shooting: &'s ShootingSettings,
    /// First-guess energy and symmetry restriction.
    pub start: &'s StartSettings,
    /// The dofs every point measures.
    pub output: &'s OutputSettings,
    /// The integration method and its tolerance factor.
    pub integration: &'s IntegrationSettings,
    /// The corrector tolerance, which sets the integration tolerance.
    pub continuation: &'s ContinuationSettings,
    /// The tolerance of a point's stability verdict.
    pub stability: &'s StabilitySettings,
}
