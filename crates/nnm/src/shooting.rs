//! The shooting problem for periodic motions (SPEC §2):
//!
//! `H(z0, T) = z(T; z0) - z0 = 0` plus a phase condition, with the Jacobian
//! `∂H/∂z0 = Φ(T) - I`, `∂H/∂T = g(z(T))` from the variational equations (or, as the paper's
//! baseline, from finite differences).
//!
//! **Unknowns.** Initial states are restricted to the leading `r_u` columns `B_u` of an
//! *elastic basis* `B` (`n × r`, mass-orthonormal linear modes without the rigid-body ones):
//! `x0 = B_u a` and, for the general phase condition, `v0 = ω_ref B_u b`. This removes the
//! rigid-body degeneracy exactly (a rigid shift is periodic for every `T`, a rigid velocity
//! drifts; SPEC §7) and gives modal scaling; `B_u` may be a smaller invariant subspace (see
//! [`crate::symmetry`]), while Floquet multipliers always use the whole of `B`.
//! The period enters as `τ = T / T_ref`. The unknown vector is `u = (a[, b], τ)`.
//!
//! **Equations.** Residual rows are weighted `W = diag(I, I/ω_ref)` so that displacement and
//! velocity mismatches weigh alike, and the convergence test of SPEC §2 is applied in the same
//! metric: `‖W H‖ / ‖W z0‖ < eps`. With `ω_ref = 1` this is exactly `‖H‖ / ‖z0‖`; in general
//! it makes the test independent of the time unit (the unweighted one effectively ignores
//! velocity mismatches when `ω ≪ 1` and over-weights them when `ω ≫ 1`).

use crate::integrate::{
    Flow, IntegrationError, IntegrationStats, Integrator, Steps, Tableau, evaluate_field as field,
};
use crate::linalg::{self, Mat};
use crate::model::{Block, SecondOrderSystem};

/// How the time-shift freedom of an autonomous periodic orbit is removed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PhaseCondition {
    /// All initial velocities zero (the paper's choice for synchronous NNMs): the unknowns
    /// are `(a, τ)` only, and the orbit starts at a turning point of every dof.
    ZeroVelocity,
    /// `g(z_ref)ᵀ (z0 - z_ref) = 0` with `z_ref` the previous solution: valid for any
    /// periodic motion, including ones that never stop everywhere at once.
    FlowOrthogonal,
}

/// How the Jacobian (and monodromy) is obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum JacobianMethod {
    /// Variational equations integrated with the motion, on the same steps.
    Sensitivity,
    /// One extra integration per unknown, with the base run's steps replayed so that the
    /// difference quotient differentiates one smooth discrete map.
    FiniteDifference,
}

/// One evaluation of the shooting equations.
#[derive(Debug, Clone)]
pub struct Evaluation {
    /// `z0` (length 2n).
    pub z0: Vec<f64>,
    /// `z(T)`, or `z(T/2)` when shooting over half a period.
    pub z_end: Vec<f64>,
    /// `T`.
    pub period: f64,
    /// `‖W H‖ / ‖W z0‖`, the convergence measure of SPEC §2 in the weighted metric.
    pub relative_residual: f64,
    /// Weighted residual rows `[W H; h]`.
    pub rows: Vec<f64>,
    /// Their Jacobian with respect to the unknowns `u` (`rows × (m+1)`).
    pub jacobian: Mat<f64>,
    /// `Φ(T) S`, the flow derivative along the unknown state directions (`2n × m`).
    pub flow_derivative: Vec<f64>,
    /// Accepted step sizes (replayed by finite differences).
    pub steps: Vec<f64>,
}

/// Work counters of the shooting problem.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct ShootingStats {
    /// Integrations of the motion (with or without sensitivities).
    pub integrations: usize,
    pub integration: IntegrationStats,
}

/// The shooting problem of one branch.
#[derive(Debug)]
pub struct Shooting<'a, S: SecondOrderSystem + ?Sized> {
    system: &'a S,
    n: usize,
    /// Elastic basis `B`, `n × r` column-major; its first `r_u` columns span the unknowns.
    basis: Vec<f64>,
    /// `M B`, for projections onto modal coordinates (`q = (MB)ᵀ x`).
    mass_basis: Vec<f64>,
    r: usize,
    r_u: usize,
    phase: PhaseCondition,
    jacobian_method: JacobianMethod,
    omega_ref: f64,
    amplitude_scale: f64,
    half_period: bool,
    period_ref: f64,
    /// State directions of the unknowns, `2n × m`.
    state_basis: Vec<f64>,
    integrator: Integrator,
    first_step: Option<f64>,
    pub stats: ShootingStats,
}

/// Settings of the shooting problem.
#[derive(Debug, Clone)]
pub struct ShootingSettings {
    pub phase: PhaseCondition,
    pub jacobian: JacobianMethod,
    pub tableau: &'static Tableau,
    /// The shooting tolerance `eps` (SPEC §2).
    pub tolerance: f64,
    /// Integrator relative tolerance = `integration_factor × tolerance`.
    pub integration_factor: f64,
    /// Amplitude unit of the unknowns: `x0 = B_u (amplitude_scale · a)`. Chosen where the
    /// nonlinearity becomes strong, it makes `a` and `τ` both O(1) in the nonlinear regime,
    /// so the arclength does not depend on the model's length unit.
    pub amplitude_scale: f64,
    /// Shoot over half a period on `z(T/2) = -z0` (valid for odd systems, `g(-z) = -g(z)`,
    /// and half-wave-symmetric motions): half the integration, and `Φ(T) = Φ(T/2)²`.
    pub half_period: bool,
}

impl<'a, S: SecondOrderSystem + ?Sized> Shooting<'a, S> {
    /// `basis`: `n × r` column-major, mass-orthonormal, the first `unknown_columns` spanning
    /// the unknowns; `mass_basis = M B`; `omega_ref`: frequency scale of the branch.
    pub fn new(
        system: &'a S,
        basis: Vec<f64>,
        mass_basis: Vec<f64>,
        unknown_columns: usize,
        omega_ref: f64,
        settings: &ShootingSettings,
    ) -> Self {
        let n = system.dofs();
        let r = basis.len() / n;
        let r_u = unknown_columns.min(r);
        let m = match settings.phase {
            PhaseCondition::ZeroVelocity => r_u,
            PhaseCondition::FlowOrthogonal => 2 * r_u,
        };
        let a = settings.amplitude_scale;
        let mut state_basis = vec![0.0; 2 * n * m];
        for c in 0..r_u {
            let b = &basis[c * n..(c + 1) * n];
            for (s, b) in state_basis[c * 2 * n..c * 2 * n + n].iter_mut().zip(b) {
                *s = a * b;
            }
            if settings.phase == PhaseCondition::FlowOrthogonal {
                let col = &mut state_basis[(r_u + c) * 2 * n + n..(r_u + c + 1) * 2 * n];
                for (s, b) in col.iter_mut().zip(b) {
                    *s = a * omega_ref * b;
                }
            }
        }
        let tolerances = crate::integrate::Tolerances {
            relative: settings.integration_factor * settings.tolerance,
            absolute: settings.integration_factor * settings.tolerance,
            velocity_scale: omega_ref,
        };
        Self {
            system,
            n,
            basis,
            mass_basis,
            r,
            r_u,
            phase: settings.phase,
            jacobian_method: settings.jacobian,
            omega_ref,
            amplitude_scale: a,
            half_period: settings.half_period,
            period_ref: 2.0 * std::f64::consts::PI / omega_ref,
            state_basis,
            integrator: Integrator::new(settings.tableau, tolerances),
            first_step: None,
            stats: ShootingStats::default(),
        }
    }

    pub fn system(&self) -> &'a S {
        self.system
    }

    /// Number of unknowns `m + 1`.
    pub fn unknowns(&self) -> usize {
        self.state_basis.len() / (2 * self.n) + 1
    }

    pub fn phase(&self) -> PhaseCondition {
        self.phase
    }

    /// The reference period `T_ref` (the unknown `τ` is `T / T_ref`).
    pub fn period_ref(&self) -> f64 {
        self.period_ref
    }

    /// `z0 = S q` for unknowns `u = (q, τ)`.
    pub fn initial_state(&self, u: &[f64]) -> Vec<f64> {
        let n2 = 2 * self.n;
        let mut z0 = vec![0.0; n2];
        for (c, &q) in u[..u.len() - 1].iter().enumerate() {
            for (z, s) in z0.iter_mut().zip(&self.state_basis[c * n2..(c + 1) * n2]) {
                *z += q * s;
            }
        }
        z0
    }

    /// Unknowns `u` whose state is the projection of `z0` on the unknown directions.
    pub fn unknowns_from_state(&self, z0: &[f64], period: f64) -> Vec<f64> {
        let (n, r_u) = (self.n, self.r_u);
        let project = |x: &[f64]| -> Vec<f64> {
            (0..r_u)
                .map(|c| linalg::dot(&self.mass_basis[c * n..(c + 1) * n], x))
                .collect()
        };
        let a = self.amplitude_scale;
        let mut u: Vec<f64> = project(&z0[..n]).iter().map(|x| x / a).collect();
        if self.phase == PhaseCondition::FlowOrthogonal {
            u.extend(project(&z0[n..]).iter().map(|v| v / (a * self.omega_ref)));
        }
        u.push(period / self.period_ref);
        u
    }

    /// Total energy of the motion starting at `z0`.
    pub fn energy(&self, z0: &[f64]) -> f64 {
        self.system.energy(&z0[..self.n], &z0[self.n..])
    }

    fn integrate(
        &mut self,
        z0: &[f64],
        period: f64,
        directions: Option<Block<'_>>,
        steps: Steps<'_>,
    ) -> Result<Flow, IntegrationError> {
        // Absolute tolerance from the motion's displacement scale (velocities weighted by
        // 1/ω_ref, see `Tolerances`).
        let n = self.n;
        let scale = z0.iter().enumerate().fold(0.0f64, |m, (i, v)| {
            m.max(if i < n {
                v.abs()
            } else {
                v.abs() / self.omega_ref
            })
        });
        self.integrator.tolerances.absolute =
            self.integrator.tolerances.relative * scale.max(f64::MIN_POSITIVE);
        let flow = self
            .integrator
            .flow(self.system, z0, period, directions, steps)?;
        self.stats.integrations += 1;
        self.stats.integration += flow.stats;
        Ok(flow)
    }

    /// `z(T)` and `Φ(T) D` for a block of directions `D` (`2n × k`), by the configured method.
    fn flow_with_derivative(
        &mut self,
        z0: &[f64],
        period: f64,
        directions: &[f64],
        replay: Option<&[f64]>,
    ) -> Result<(Flow, Vec<f64>), IntegrationError> {
        let n2 = 2 * self.n;
        let k = directions.len() / n2;
        let first_step = match replay {
            Some(steps) => Steps::Replay(steps),
            None => Steps::Adaptive {
                first_step: self.first_step,
            },
        };
        match self.jacobian_method {
            JacobianMethod::Sensitivity => {
                let mut flow = self.integrate(
                    z0,
                    period,
                    Some(Block::new(directions, n2, k, n2)),
                    first_step,
                )?;
                self.first_step = flow.steps.first().copied();
                let derivative = std::mem::take(&mut flow.sensitivity);
                Ok((flow, derivative))
            }
            JacobianMethod::FiniteDifference => {
                let flow = self.integrate(z0, period, None, first_step)?;
                self.first_step = flow.steps.first().copied();
                let mut derivative = vec![0.0; n2 * k];
                let z_scale = weighted_norm(z0, self.n, self.omega_ref).max(f64::MIN_POSITIVE);
                for c in 0..k {
                    let d = &directions[c * n2..(c + 1) * n2];
                    // Forward difference with δ‖Wd‖ ≈ √ε_mach ‖W z0‖: balances truncation against
                    // round-off in the (smooth, same-steps) discrete flow map.
                    let d_scale = weighted_norm(d, self.n, self.omega_ref);
                    let delta = 1e-8 * z_scale / d_scale.max(f64::MIN_POSITIVE);
                    let zp: Vec<f64> = z0.iter().zip(d).map(|(z, d)| z + delta * d).collect();
                    let perturbed =
                        self.integrate(&zp, period, None, Steps::Replay(&flow.steps))?;
                    for (i, out) in derivative[c * n2..(c + 1) * n2].iter_mut().enumerate() {
                        *out = (perturbed.z[i] - flow.z[i]) / delta;
                    }
                }
                Ok((flow, derivative))
            }
        }
    }

    /// Evaluates the shooting equations and their Jacobian at `u`. `phase_reference` is the
    /// `z_ref` of [`PhaseCondition::FlowOrthogonal`] (ignored otherwise).
    pub fn evaluate(
        &mut self,
        u: &[f64],
        phase_reference: &[f64],
    ) -> Result<Evaluation, IntegrationError> {
        let (n, n2) = (self.n, 2 * self.n);
        let m = u.len() - 1;
        let period = u[m] * self.period_ref;
        if !(period.is_finite() && period > 0.0) {
            return Err(IntegrationError::InvalidInput(format!(
                "non-positive period {period}"
            )));
        }
        let z0 = self.initial_state(u);
        let directions = std::mem::take(&mut self.state_basis);
        let (horizon, sign) = if self.half_period {
            (0.5 * period, 1.0)
        } else {
            (period, -1.0)
        };
        let result = self.flow_with_derivative(&z0, horizon, &directions, None);
        self.state_basis = directions;
        let (flow, derivative) = result?;

        let weight = |i: usize| if i < n { 1.0 } else { 1.0 / self.omega_ref };
        // H = z(T) - z0, or z(T/2) + z0 over half a period.
        let mut rows: Vec<f64> = (0..n2)
            .map(|i| weight(i) * (flow.z[i] + sign * z0[i]))
            .collect();
        let weighted_z0: Vec<f64> = (0..n2).map(|i| weight(i) * z0[i]).collect();
        let relative_residual =
            linalg::norm(&rows) / linalg::norm(&weighted_z0).max(f64::MIN_POSITIVE);
        let phase_rows = usize::from(self.phase == PhaseCondition::FlowOrthogonal);
        let mut jacobian = Mat::<f64>::zeros(n2 + phase_rows, m + 1);
        for c in 0..m {
            let s = &self.state_basis[c * n2..(c + 1) * n2];
            for i in 0..n2 {
                jacobian[(i, c)] = weight(i) * (derivative[c * n2 + i] + sign * s[i]);
            }
        }
        // ∂H/∂τ = (horizon/τ) g(z(horizon)): T_ref g(z(T)), or T_ref/2 g(z(T/2)).
        let mut g_end = vec![0.0; n2];
        field(self.system, &flow.z, &mut g_end);
        for i in 0..n2 {
            jacobian[(i, m)] = weight(i) * (horizon / u[m]) * g_end[i];
        }
        if phase_rows == 1 {
            let mut g_ref = vec![0.0; n2];
            field(self.system, phase_reference, &mut g_ref);
            let norm = linalg::norm(&g_ref).max(f64::MIN_POSITIVE);
            g_ref.iter_mut().for_each(|g| *g /= norm);
            let offset: Vec<f64> = (0..n2).map(|i| z0[i] - phase_reference[i]).collect();
            rows.push(linalg::dot(&g_ref, &offset));
            for c in 0..m {
                let s = &self.state_basis[c * n2..(c + 1) * n2];
                jacobian[(n2, c)] = linalg::dot(&g_ref, s);
            }
        }
        Ok(Evaluation {
            z0,
            z_end: flow.z,
            period,
            relative_residual,
            rows,
            jacobian,
            flow_derivative: derivative,
            steps: flow.steps,
        })
    }

    /// The monodromy matrix restricted to the elastic state space, in modal coordinates
    /// (`2r × 2r`): `L Φ(T) E` with `E = diag(B, B)`, `L = diag((MB)ᵀ, (MB)ᵀ)`. Rigid-body
    /// motions decouple exactly (their block is `[[1, T], [0, 1]]`), so its eigenvalues are the
    /// Floquet multipliers of the elastic motion. The columns of `Φ E` that the evaluation
    /// already propagated (the unknown directions) are reused; the rest are integrated in one
    /// pass on a fresh step sequence.
    pub fn monodromy(&mut self, evaluation: &Evaluation) -> Result<Mat<f64>, IntegrationError> {
        let (n, n2, r, r_u) = (self.n, 2 * self.n, self.r, self.r_u);
        let (phase, omega_ref, a) = (self.phase, self.omega_ref, self.amplitude_scale);
        // Column c of E: displacement mode c (c < r) or velocity mode c - r; the evaluation
        // propagated them scaled by `a` (and `ω_ref` for velocities).
        let known = move |c: usize| -> Option<(usize, f64)> {
            match phase {
                _ if c < r_u => Some((c, 1.0 / a)),
                PhaseCondition::FlowOrthogonal if c >= r && c < r + r_u => {
                    Some((r_u + c - r, 1.0 / (a * omega_ref)))
                }
                _ => None,
            }
        };
        let missing: Vec<usize> = (0..2 * r).filter(|&c| known(c).is_none()).collect();
        let mut directions = vec![0.0; n2 * missing.len()];
        for (k, &c) in missing.iter().enumerate() {
            let (mode, offset) = if c < r { (c, 0) } else { (c - r, n) };
            directions[k * n2 + offset..k * n2 + offset + n]
                .copy_from_slice(&self.basis[mode * n..(mode + 1) * n]);
        }
        // Same steps as the evaluation: every column then differentiates one discrete map.
        let integrated = if missing.is_empty() {
            Vec::new()
        } else {
            self.flow_with_derivative(
                &evaluation.z0,
                evaluation.period,
                &directions,
                Some(&evaluation.steps),
            )?
            .1
        };
        let mut reduced = Mat::<f64>::zeros(2 * r, 2 * r);
        let mut next_missing = 0;
        for c in 0..2 * r {
            let column: Vec<f64> = match known(c) {
                Some((k, scale)) => evaluation.flow_derivative[k * n2..(k + 1) * n2]
                    .iter()
                    .map(|v| v * scale)
                    .collect(),
                None => {
                    next_missing += 1;
                    integrated[(next_missing - 1) * n2..next_missing * n2].to_vec()
                }
            };
            for k in 0..r {
                let mb = &self.mass_basis[k * n..(k + 1) * n];
                reduced[(k, c)] = linalg::dot(mb, &column[..n]);
                reduced[(r + k, c)] = linalg::dot(mb, &column[n..]);
            }
        }
        if self.half_period {
            // Odd system and z(T/2) = -z0: the second half-period map equals the first.
            reduced = linalg::product(reduced.as_ref(), reduced.as_ref());
        }
        Ok(reduced)
    }

    /// The periodicity residual over the full period, `‖W(z(T) - z0)‖ / ‖W z0‖`: for a
    /// half-period evaluation, the second half is integrated (without sensitivities) to check
    /// that the motion really is half-wave symmetric.
    pub fn full_period_residual(
        &mut self,
        evaluation: &Evaluation,
    ) -> Result<f64, IntegrationError> {
        if !self.half_period {
            return Ok(evaluation.relative_residual);
        }
        let half = 0.5 * evaluation.period;
        let flow = self.integrate(
            &evaluation.z_end,
            half,
            None,
            Steps::Adaptive {
                first_step: self.first_step,
            },
        )?;
        let n = self.n;
        let weight = |i: usize| if i < n { 1.0 } else { 1.0 / self.omega_ref };
        let mismatch: Vec<f64> = (0..2 * n)
            .map(|i| weight(i) * (flow.z[i] - evaluation.z0[i]))
            .collect();
        let scale: Vec<f64> = (0..2 * n).map(|i| weight(i) * evaluation.z0[i]).collect();
        Ok(linalg::norm(&mismatch) / linalg::norm(&scale).max(f64::MIN_POSITIVE))
    }

    /// Coordinates of a state in the modal basis of [`Shooting::monodromy`]:
    /// `((MB)ᵀ x, (MB)ᵀ v)`.
    pub fn modal_coordinates(&self, z: &[f64]) -> Vec<f64> {
        let (n, r) = (self.n, self.r);
        let project = |x: &[f64]| -> Vec<f64> {
            (0..r)
                .map(|c| linalg::dot(&self.mass_basis[c * n..(c + 1) * n], x))
                .collect()
        };
        let mut q = project(&z[..n]);
        q.extend(project(&z[n..]));
        q
    }

    /// The vector field `g(z)`.
    pub fn field(&self, z: &[f64]) -> Vec<f64> {
        let mut g = vec![0.0; z.len()];
        field(self.system, z, &mut g);
        g
    }

    /// Coordinates of [`Shooting::monodromy`] spanned by the unknowns' modes (displacements
    /// and velocities), when they are fewer than all: on a model whose mirror symmetry
    /// restricted the unknowns to one class, the monodromy leaves this block and its
    /// complement invariant.
    pub fn unknown_block(&self) -> Option<Vec<usize>> {
        (self.r_u < self.r).then(|| (0..self.r_u).chain(self.r..self.r + self.r_u).collect())
    }

    /// Whether the problem is shot over half a period.
    pub fn half_period(&self) -> bool {
        self.half_period
    }
}

/// `‖W z‖` with `W = diag(I, I/ω)`: displacements and velocities on one scale.
fn weighted_norm(z: &[f64], n: usize, omega: f64) -> f64 {
    z.iter()
        .enumerate()
        .map(|(i, v)| if i < n { v * v } else { (v / omega).powi(2) })
        .sum::<f64>()
        .sqrt()
}
