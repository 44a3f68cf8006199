//! Integration of a damped, harmonically forced structure over one forcing period, with the
//! derivatives of the end state with respect to the initial state, the forcing frequency and
//! the force amplitude (docs/method.md eqs. (91)–(94)).
//!
//! The forced motion is integrated in the phase `τ = Ωt ∈ [0, 2π]` of the force, not in time:
//!
//! ```text
//!     dz/dτ = G(z, τ; Ω, a) = (1/Ω) [v; M⁻¹(a F(τ) − C v − f_int(x))],   z = [x; v],
//! ```
//!
//! so the period is fixed and `Ω` enters the field only through the factor `1/Ω`: the
//! derivative with respect to `Ω` is a parameter sensitivity (`∂G/∂Ω = −G/Ω`) integrated
//! with the others, exact for the discrete flow, and needs no derivative of the period.
//! The velocity stays `dx/dt`, so states, outputs and the linear starting point are in the
//! user's units.
//!
//! Two schemes, as for free motions: [`ForcedRungeKutta`] (explicit embedded pair, adaptive
//! steps) for non-stiff models, and [`ForcedCollocation`] (implicit Radau IIA or Gauss,
//! equal steps set from a global error estimate) for stiff finite-element models. Both
//! differentiate their own discrete flow ("internal differentiation", eq. (29)), so the
//! shooting Jacobian is exactly the Jacobian of the residual Newton solves.

mod explicit;
mod implicit;

pub use explicit::ForcedRungeKutta;
pub use implicit::ForcedCollocation;

use std::sync::Arc;

use super::{IntegrationError, IntegrationStats, LinearizedFlow, Tolerances};

/// The forcing's parameters at which a flow is integrated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drive {
    /// `Ω` (rad/s).
    pub frequency: f64,
    /// `a`, the factor on the force shape.
    pub amplitude: f64,
}

/// The flow over one forcing period (or half of it): `z(span)` and, when asked,
/// `∂z(span)/∂(z0, Ω, a)`.
#[derive(Debug, Clone)]
pub struct ForcedFlow {
    /// `z(2π)`, the state after one forcing period.
    pub z: Vec<f64>,
    /// `[Φ  ∂z/∂Ω  ∂z/∂a]`, `2n × (2n + 2)` column-major (`Φ = ∂z(2π)/∂z0`, the monodromy);
    /// empty without sensitivities.
    pub sensitivity: Vec<f64>,
    /// Accepted step sizes in `τ`.
    pub steps: Vec<f64>,
    /// Work counters.
    pub stats: IntegrationStats,
}

/// A flow with its parameter sensitivities and its recorded linearisation
/// ([`ForcedIntegrator::flow_linearized`]).
pub type RecordedFlow = (ForcedFlow, Arc<dyn LinearizedFlow>);

/// Integrates a forced system over its forcing period, with sensitivities on request.
pub trait ForcedIntegrator {
    /// `z(span)` from `z(0) = z0` at `drive` — `span` the forcing period `2π`, or half of it
    /// for a half-wave symmetric response; with `sensitivities`, also
    /// [`ForcedFlow::sensitivity`] at `span`.
    fn flow(
        &mut self,
        z0: &[f64],
        drive: Drive,
        span: f64,
        sensitivities: bool,
    ) -> Result<ForcedFlow, IntegrationError>;

    /// `z(span)` with the parameter sensitivities only, `[∂z/∂Ω ∂z/∂a]` (`2n × 2`, in
    /// [`ForcedFlow::sensitivity`]), and the integration's linearised discrete flow, whose
    /// products `Φ d` replay the recorded steps (matrix-free shooting, docs/method.md eqs.
    /// (72), (102a)); `None` when the integrator does not record.
    fn flow_linearized(
        &mut self,
        _z0: &[f64],
        _drive: Drive,
        _span: f64,
    ) -> Option<Result<RecordedFlow, IntegrationError>> {
        None
    }

    /// The states at `τ_k = 2πk/count`, `k = 0..pieces`, from `z(0) = z0` at `drive` (the
    /// samples of [`sample`]): by default piece by piece with [`Self::advance`].
    fn sample_states(
        &mut self,
        z0: &[f64],
        drive: Drive,
        count: usize,
        pieces: usize,
    ) -> Result<Vec<Vec<f64>>, IntegrationError> {
        let span = 2.0 * std::f64::consts::PI / count as f64;
        let mut z = z0.to_vec();
        let mut out = Vec::with_capacity(count);
        for k in 0..pieces {
            let next = self.advance(&z, k as f64 * span, span, drive)?;
            out.push(std::mem::replace(&mut z, next));
        }
        Ok(out)
    }

    /// `z(tau0 + span)` from `z(tau0) = z0` at `drive`, without sensitivities (samples of a
    /// converged motion, and the instants of its peaks).
    fn advance(
        &mut self,
        z0: &[f64],
        tau0: f64,
        span: f64,
        drive: Drive,
    ) -> Result<Vec<f64>, IntegrationError>;

    /// Prepares the integration of the motion from `z0` at `drive` over `span` (the shot
    /// horizon) to a global accuracy of `tolerance` relative to the state: a method with
    /// equal steps sets their number here (adaptive methods have nothing to do). Called before
    /// the first point and after each accepted one, never within a Newton solve (the discrete
    /// map must not change there).
    fn adapt(&mut self, _z0: &[f64], _drive: Drive, _span: f64) -> Result<(), IntegrationError> {
        Ok(())
    }

    /// The local error tolerances in force.
    fn tolerances(&self) -> Tolerances;

    /// Sets the local error tolerances.
    fn set_tolerances(&mut self, tolerances: Tolerances);

    /// The scheme's name (`dop853`, `radau5`, …).
    fn name(&self) -> &'static str;
}

/// `G(z, τ)` of the module notes: writes `dz/dτ` into `out` (`2n`).
pub fn phase_field<S: crate::model::MechanicalSystem + ?Sized>(
    system: &crate::model::ForcedSystem<'_, S>,
    z: &[f64],
    tau: f64,
    drive: Drive,
    out: &mut [f64],
) {
    let n = system.dofs();
    let (x, v) = z.split_at(n);
    let (top, bottom) = out.split_at_mut(n);
    system.inertia_force(tau, drive.amplitude, x, v, bottom);
    system.system().mass().solve_in_place(bottom, 1);
    let scale = 1.0 / drive.frequency;
    for (t, vi) in top.iter_mut().zip(v) {
        *t = scale * vi;
    }
    bottom.iter_mut().for_each(|b| *b *= scale);
}

/// The states at `τ_k = 2πk/count`, `k = 0..count` (the start included, the end not).
pub fn sample(
    integrator: &mut dyn ForcedIntegrator,
    z0: &[f64],
    drive: Drive,
    count: usize,
) -> Result<Vec<Vec<f64>>, IntegrationError> {
    let count = count.max(1);
    integrator.sample_states(z0, drive, count, count)
}

/// [`sample`] of a half-wave symmetric motion, `z(τ + π) = S z(τ)` (eq. (99b); `signs` the
/// diagonal of `S`, `2n`): the first half of the period integrated, the second its image.
/// `count` must be even.
pub fn sample_half_wave(
    integrator: &mut dyn ForcedIntegrator,
    z0: &[f64],
    drive: Drive,
    count: usize,
    signs: &[f64],
) -> Result<Vec<Vec<f64>>, IntegrationError> {
    assert!(count % 2 == 0, "an even sample count");
    let mut out = integrator.sample_states(z0, drive, count, count / 2)?;
    let mirrored: Vec<Vec<f64>> = (out.iter())
        .map(|z| z.iter().zip(signs).map(|(v, s)| s * v).collect())
        .collect();
    out.extend(mirrored);
    Ok(out)
}

/// Checks every forced integration makes of a request: a state of `2n` finite entries and a
/// positive, finite frequency and finite amplitude.
// Negated comparison deliberate: NaN must fail.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub(crate) fn check_forced_request(
    z0: &[f64],
    n2: usize,
    drive: Drive,
) -> Result<(), IntegrationError> {
    if z0.len() != n2 {
        return Err(IntegrationError::InvalidInput(format!(
            "state has length {}, expected {n2}",
            z0.len()
        )));
    }
    if !(drive.frequency.is_finite() && drive.frequency > 0.0 && drive.amplitude.is_finite()) {
        return Err(IntegrationError::InvalidInput(format!(
            "the forcing frequency must be positive and the amplitude finite, got {} and {}",
            crate::number::Number(drive.frequency),
            crate::number::Number(drive.amplitude)
        )));
    }
    if z0.iter().any(|v| !v.is_finite()) {
        return Err(IntegrationError::NotFinite { t: 0.0 });
    }
    Ok(())
}

#[cfg(test)]
mod tests;
