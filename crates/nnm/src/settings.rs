//! The settings of a branch, gathered: each group is defined, with its defaults, beside the
//! layer that reads it ([`ContinuationSettings`] in `continuation`, [`ShootingSettings`],
//! [`StartSettings`] and [`OutputSettings`] in `shooting`, [`IntegrationSettings`] in
//! `integrate`, [`StabilitySettings`] in `floquet`); the branch's own limits and requests are
//! here, since only the branch above reads them. [`Settings`] nests them all and validates
//! them in one place, and the group types are re-exported so that `nnm::settings::X` names
//! every one.
//!
//! Job files write them flat (`tolerance = 1e-8`, `max_step = 0.25`, ...): every group is
//! flattened for serde, and [`Settings::KEYS`] lists the accepted keys so a front end can
//! refuse a misspelt one.

use serde::{Deserialize, Serialize};

use crate::number::Number;

pub use crate::continuation::{ContinuationSettings, MIN_TOLERANCE, SettingsError};
pub use crate::floquet::StabilitySettings;
pub use crate::integrate::IntegrationSettings;
pub use crate::shooting::{OutputSettings, SettingsView, ShootingSettings, StartSettings};

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

impl Default for Limits {
    fn default() -> Self {
        Self {
            energy_max: f64::INFINITY,
            frequency_shift_max: f64::INFINITY,
            max_points: 500,
        }
    }
}

impl<'s> From<&'s Settings> for SettingsView<'s> {
    fn from(settings: &'s Settings) -> Self {
        Self {
            shooting: &settings.shooting,
            start: &settings.start,
            output: &settings.output,
            integration: &settings.integration,
            continuation: &settings.continuation,
            stability: &settings.stability,
        }
    }
}

/// The least integrator tolerance `integration_factor × tolerance` a job may ask for: two
/// decades below double precision's round-off (the smallest shooting tolerance, 1e-14, at
/// the default factor 1e-3 asks for 1e-17).
pub const MIN_INTEGRATION_TOLERANCE: f64 = 1e-18;

/// Checks a relative `tolerance`: positive, finite, from [`MIN_TOLERANCE`] (what double
/// precision can meet) to below 1e-2 (looser is no result). [`Settings::validate`] holds the
/// continuation's `tolerance` to it, and front ends hold any other relative tolerance a user
/// gives (a sampled motion's) to the same range, with the same messages.
// Negated comparisons are deliberate: NaN must fail them.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub fn check_tolerance(tolerance: f64) -> Result<(), SettingsError> {
    if !(tolerance.is_finite() && tolerance > 0.0) {
        return Err(SettingsError(format!(
            "tolerance must be positive and finite, got {}",
            Number(tolerance)
        )));
    }
    if tolerance >= 1e-2 {
        return Err(SettingsError(format!(
            "tolerance {} is too loose (use < 1e-2)",
            Number(tolerance)
        )));
    }
    if tolerance < MIN_TOLERANCE {
        return Err(SettingsError(format!(
            "tolerance {tolerance:e} is below {MIN_TOLERANCE:e}, which double precision cannot meet: the periodicity residual of an integrated orbit carries round-off of ~1e-15 of the state"
        )));
    }
    Ok(())
}

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
        "invariant_step",
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
        if let Some(balance) = &self.output.energy_balance
            && balance.dofs() != dofs
        {
            return Err(SettingsError(format!(
                "resonance_force: the energy balance has {} dofs, the model {dofs}",
                balance.dofs()
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
                fail(format!(
                    "{name} must be positive and finite, got {}",
                    Number(v)
                ))
            }
        };
        let c = &self.continuation;
        check_tolerance(c.tolerance)?;
        positive("initial_step", c.initial_step)?;
        positive("min_step", c.min_step)?;
        positive("max_step", c.max_step)?;
        positive("max_turn_angle", c.max_turn_angle)?;
        positive("integration_factor", self.integration.integration_factor)?;
        if self.integration.integration_factor > 1.0 {
            return fail(format!(
                "integration_factor {} must not exceed 1 (the integrator must be at least as accurate as the shooting tolerance)",
                Number(self.integration.integration_factor)
            ));
        }
        let method = self.integration.integrator;
        if self.shooting.formulation == crate::shooting::Formulation::MatrixFree
            && !method.is_auto()
            && !method.is_collocation()
        {
            return fail(format!(
                "formulation = \"matrix-free\" needs an implicit collocation integrator (gauss4, gauss6, radau5, radau9), not {}",
                method.name()
            ));
        }
        // Far below round-off no integrator can meet its tolerance: the first point would
        // fail after files are written, where the job can be refused before.
        let integration = self.integration.integration_factor * c.tolerance;
        if integration < MIN_INTEGRATION_TOLERANCE {
            return fail(format!(
                "integration_factor {} × tolerance {} = {integration:e} is below {MIN_INTEGRATION_TOLERANCE:e}, which double precision cannot meet",
                Number(self.integration.integration_factor),
                Number(c.tolerance)
            ));
        }
        if c.max_turn_angle > std::f64::consts::PI {
            return fail(format!(
                "max_turn_angle {} exceeds π",
                Number(c.max_turn_angle)
            ));
        }
        let s = self.stability.stability_tolerance;
        if !(s.is_finite() && s >= 0.0) {
            return fail(format!(
                "stability_tolerance must be finite and non-negative, got {}",
                Number(s)
            ));
        }
        let bound = self.stability.invariant_step;
        if !(bound > 0.0) {
            return fail(format!(
                "invariant_step must be positive, got {}",
                Number(bound)
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
                return fail(format!("{name} must be positive, got {}", Number(v)));
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
                return fail(format!(
                    "{name} must hold positive, finite {what}, got {}",
                    Number(*v)
                ));
            }
        }
        if self.limits.max_points == 0 || c.max_iterations == 0 {
            return fail("max_points and max_iterations must be at least 1".into());
        }
        // The step control aims at this many corrector iterations a step: none is no aim.
        if c.target_iterations == 0 {
            return fail("target_iterations must be at least 1".into());
        }
        // A dof listed twice would give two `peak_x<d>` columns of one name.
        let dofs = &self.output.output_dofs;
        let repeated = (1..dofs.len()).find(|&k| dofs[..k].contains(&dofs[k]));
        if let Some(d) = repeated.map(|k| dofs[k]) {
            return fail(format!("output_dofs: dof {d} is listed twice"));
        }
        if let Some(e) = self.start.energy_start
            && !(e.is_finite() && e > 0.0)
        {
            return fail(format!(
                "energy_start must be positive and finite, got {}",
                Number(e)
            ));
        }
        // The branch starts near energy_start and rises: starting at or past the limit would
        // spend a Newton solve on a point the limit then discards.
        if let Some(e) = self.start.energy_start
            && e >= l.energy_max
        {
            return fail(format!(
                "energy_start {} must be below energy_max {} (the branch starts there and rises towards it)",
                Number(e),
                Number(l.energy_max)
            ));
        }
        Ok(())
    }
}
