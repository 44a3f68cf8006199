//! The settings of a branch, nested by the layer that uses them, with their defaults and
//! validation in one place.
//!
//! Job files write them flat (`tolerance = 1e-8`, `max_step = 0.25`, ...): every group is
//! flattened for serde, and [`Settings::KEYS`] lists the accepted keys so a front end can
//! refuse a misspelt one.

use serde::{Deserialize, Serialize};

use crate::integrate::IntegrationMethod;

/// All settings of a branch.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct Settings {
    /// Where the branch stops (docs/method.md eq. (26)).
    #[serde(flatten)]
    pub limits: Limits,
    /// Points placed exactly at given energies and frequencies (docs/method.md eq. (26b)).
    #[serde(flatten)]
    pub requests: Requests,
    /// Corrector tolerance and step control (docs/method.md §5).
    #[serde(flatten)]
    pub continuation: ContinuationSettings,
    /// First-guess energy and symmetry restriction of a start from a linear mode.
    #[serde(flatten)]
    pub start: StartSettings,
    /// Phase condition, Jacobian and half-period shooting (docs/method.md §2–4).
    #[serde(flatten)]
    pub shooting: ShootingSettings,
    /// Integration scheme, and its accuracy relative to the continuation tolerance.
    #[serde(flatten)]
    pub integration: IntegrationSettings,
    /// Stability tolerance and event detection (docs/method.md §7–8).
    #[serde(flatten)]
    pub stability: StabilitySettings,
    /// What is measured of every point's motion beyond the shooting unknowns (docs/method.md
    /// §18).
    #[serde(flatten)]
    pub output: OutputSettings,
}

/// Where a branch stops.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Limits {
    /// Stop once a point's energy exceeds this (positive; default +∞).
    pub energy_max: f64,
    /// Stop once `|frequency / linear frequency - 1|` exceeds this (positive; default +∞).
    pub frequency_shift_max: f64,
    /// Stop after this many continuation steps (default 500; points placed on requested
    /// values come in addition).
    pub max_points: usize,
}

/// Points a branch must contain exactly: wherever the branch crosses one of these values
/// between two of its points, the point on the value is located (to `|x/x* − 1| ≤`
/// [`crate::branch::LIMIT_TOLERANCE`]) and inserted, labelled, between them (docs/method.md
/// eq. (26b)). Values the branch never reaches are reported in
/// [`crate::Branch::missed_requests`].
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct Requests {
    /// Total energies (positive; default none).
    pub at_energies: Vec<f64>,
    /// Angular frequencies `2π/T`, rad/s (positive; default none).
    pub at_frequencies: Vec<f64>,
}

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

/// How a branch starts from a linear mode.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct StartSettings {
    /// Linear energy of the first guess; `None`: where the nonlinear forces are 1e-4 of the
    /// linear ones along the mode.
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
    pub phase: crate::shooting::PhaseCondition,
    /// Jacobian from the variational equations (default, docs/method.md eqs. (11)–(13)) or from
    /// finite differences (eq. (32)).
    pub jacobian: crate::shooting::JacobianMethod,
    /// Shoot over half a period when the system is odd (checked at sample states; default
    /// true). Every point's full-period residual is still checked.
    pub half_period: bool,
    /// Dense Jacobian and monodromy, or matrix-free Newton–Krylov (docs/method.md §15);
    /// default: chosen by size ([`crate::shooting::Formulation::Auto`]).
    pub formulation: crate::shooting::Formulation,
}

/// Time integration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct IntegrationSettings {
    /// Runge–Kutta pair of the time integration (default DOP853).
    pub integrator: IntegrationMethod,
    /// Integrator relative tolerance as a fraction of the continuation tolerance (default
    /// 1e-3: the integration error must sit well below the residual Newton converges to).
    pub integration_factor: f64,
}

/// What is measured of every point's motion (docs/method.md §18).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct OutputSettings {
    /// Dofs (0-based, in the model's numbering after `fixed_dofs`) whose peak displacement
    /// over the period is measured at every point; empty (default): the dof where the
    /// starting mode's amplitude is largest.
    pub output_dofs: Vec<usize>,
}

/// Floquet stability and bifurcation events.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct StabilitySettings {
    /// Tolerance on `|μ| - 1` for calling a point stable (default
    /// [`crate::floquet::DEFAULT_STABILITY_TOLERANCE`]).
    pub stability_tolerance: f64,
    /// Detect folds, branch points, period doublings and Krein collisions between points and
    /// locate them (default true).
    pub events: bool,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            energy_max: f64::INFINITY,
            frequency_shift_max: f64::INFINITY,
            max_points: 500,
        }
    }
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
            phase: crate::shooting::PhaseCondition::ZeroVelocity,
            jacobian: crate::shooting::JacobianMethod::Sensitivity,
            half_period: true,
            formulation: crate::shooting::Formulation::Auto,
        }
    }
}

impl Default for IntegrationSettings {
    fn default() -> Self {
        Self {
            integrator: IntegrationMethod::Auto,
            integration_factor: 1e-3,
        }
    }
}

impl Default for StabilitySettings {
    fn default() -> Self {
        Self {
            stability_tolerance: crate::floquet::DEFAULT_STABILITY_TOLERANCE,
            events: true,
        }
    }
}

/// The smallest `tolerance` accepted: the relative residual of a period integrated in double
/// precision does not fall much below 1e-15 (round-off of the state and of every step), so a
/// smaller tolerance cannot be met and would only end in a failed first point.
pub const MIN_TOLERANCE: f64 = 1e-14;

/// A setting out of its range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("invalid setting: {0}")]
pub struct SettingsError(pub String);

impl Settings {
    /// The keys of the flat (job-file) form, every group's fields.
    pub const KEYS: &'static [&'static str] = &[
        "energy_max",
        "frequency_shift_max",
        "max_points",
        "at_energies",
        "at_frequencies",
        "tolerance",
        "initial_step",
        "min_step",
        "max_step",
        "max_iterations",
        "target_iterations",
        "max_turn_angle",
        "energy_start",
        "symmetry",
        "phase",
        "jacobian",
        "half_period",
        "formulation",
        "integrator",
        "integration_factor",
        "stability_tolerance",
        "events",
        "output_dofs",
    ];

    /// [`Self::validate`], and the settings that name dofs against a model of `dofs` dofs.
    pub fn validate_for(&self, dofs: usize) -> Result<(), SettingsError> {
        self.validate()?;
        if let Some(&d) = self.output.output_dofs.iter().find(|&&d| d >= dofs) {
            return Err(SettingsError(format!(
                "output_dofs: dof {d} does not exist (the model has {dofs} dofs, numbered from 0)"
            )));
        }
        Ok(())
    }

    /// Checks every setting; continuation calls it, and front ends can call it early.
    // Negated comparisons are deliberate: NaN must fail them.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    pub fn validate(&self) -> Result<(), SettingsError> {
        let fail = |m: String| Err(SettingsError(m));
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                fail(format!("{name} must be positive and finite, got {v}"))
            }
        };
        let c = &self.continuation;
        positive("tolerance", c.tolerance)?;
        positive("initial_step", c.initial_step)?;
        positive("min_step", c.min_step)?;
        positive("max_step", c.max_step)?;
        positive("max_turn_angle", c.max_turn_angle)?;
        positive("integration_factor", self.integration.integration_factor)?;
        if self.integration.integration_factor > 1.0 {
            return fail(format!(
                "integration_factor {} must not exceed 1 (the integrator must be at least as accurate as the shooting tolerance)",
                self.integration.integration_factor
            ));
        }
        if c.max_turn_angle > std::f64::consts::PI {
            return fail(format!("max_turn_angle {} exceeds π", c.max_turn_angle));
        }
        let s = self.stability.stability_tolerance;
        if !(s.is_finite() && s >= 0.0) {
            return fail(format!(
                "stability_tolerance must be finite and non-negative, got {s}"
            ));
        }
        if c.tolerance >= 1e-2 {
            return fail(format!(
                "tolerance {} is too loose (use < 1e-2)",
                c.tolerance
            ));
        }
        if c.tolerance < MIN_TOLERANCE {
            return fail(format!(
                "tolerance {:e} is below {MIN_TOLERANCE:e}, which double precision cannot meet: the periodicity residual of an integrated orbit carries round-off of ~1e-15 of the state",
                c.tolerance
            ));
        }
        if c.min_step > c.max_step {
            return fail("min_step exceeds max_step".into());
        }
        // A limit at or below zero would stop the branch at its first point, which already
        // lies above it: a sign slip, not a request for one point (`max_points = 1` is that).
        let l = &self.limits;
        for (name, v) in [
            ("energy_max", l.energy_max),
            ("frequency_shift_max", l.frequency_shift_max),
        ] {
            if !(v > 0.0) {
                return fail(format!("{name} must be positive, got {v}"));
            }
        }
        for (name, values, what) in [
            ("at_energies", &self.requests.at_energies, "energies"),
            (
                "at_frequencies",
                &self.requests.at_frequencies,
                "frequencies (rad/s)",
            ),
        ] {
            if let Some(v) = values.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
                return fail(format!("{name} must hold positive, finite {what}, got {v}"));
            }
        }
        if self.limits.max_points == 0 || c.max_iterations == 0 {
            return fail("max_points and max_iterations must be at least 1".into());
        }
        if let Some(e) = self.start.energy_start
            && !(e.is_finite() && e > 0.0)
        {
            return fail(format!("energy_start must be positive and finite, got {e}"));
        }
        // The branch starts near energy_start and rises: starting at or past the limit would
        // spend a Newton solve on a point the limit then discards.
        if let Some(e) = self.start.energy_start
            && e >= l.energy_max
        {
            return fail(format!(
                "energy_start {e} must be below energy_max {} (the branch starts there and rises towards it)",
                l.energy_max
            ));
        }
        Ok(())
    }
}
