//! The shooting problem for periodic motions (docs/method.md §2–4):
//!
//! `H(z0, T) = z(T; z0) - z0 = 0` (eq. (6)) plus a phase condition (eqs. (7)–(8)), with the
//! Jacobian `∂H/∂z0 = Φ(T) - I`, `∂H/∂T = g(z(T))` (eq. (13)) from the variational equations
//! (or, as the paper's baseline, from finite differences). [`Shooting`] implements
//! [`crate::continuation::ContinuationProblem`], so a branch of periodic motions is continued like any other
//! family; its points are [`BranchPoint`]s, with Floquet stability.
//!
//! **Unknowns.** Initial states are restricted to the leading `r_u` columns `B_u` of an
//! *elastic basis* `B` (`n × r`, mass-orthonormal linear modes without the rigid-body ones):
//! `x0 = B_u a` and, for the general phase condition, `v0 = ω_ref B_u b`. This removes the
//! rigid-body degeneracy exactly (a rigid shift is periodic for every `T`, a rigid velocity
//! drifts; docs/method.md §13) and gives modal scaling; `B_u` may be a smaller invariant subspace (see
//! [`crate::symmetry`]), while Floquet multipliers always use the whole of `B`.
//! The period enters as `τ = T / T_ref`. The unknown vector is `u = (a[, b], τ)`.
//!
//! **Equations.** The residual is taken in modal coordinates, each mode's velocity divided by
//! its own frequency (eq. (17)), so that a mode's displacement and velocity mismatches weigh
//! alike whatever its frequency and the time unit; the convergence test (eq. (19)) is applied
//! in the same metric: `‖W H‖ / ‖W z0‖ < eps`.

mod matrix_free;
mod monodromy;
mod motion;
mod point;
mod settings;
mod shift;
mod start;

pub use matrix_free::MatrixFreeJacobian;
pub use motion::{CONTENT_HARMONICS, MOTION_SAMPLES, Motion};
pub use point::{BranchPoint, PointLabel};
pub use settings::{OutputSettings, SettingsView, ShootingSettings, StartSettings};
pub use shift::{ShiftSymmetry, Travel};
pub use start::{Start, StartError};

use crate::continuation::Linearization;
use crate::floquet::{DenseFloquet, FloquetSolver};
use crate::integrate::{
    Flow, IntegrationError, IntegrationMethod, IntegrationStats, Integrator, Steps, Tolerances,
};
use crate::linalg::{self, Mat};
use crate::model::{Block, BlockMut, MechanicalSystem};

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

/// How the Newton corrections and the monodromy are computed (docs/method.md §15).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Formulation {
    /// Matrix-free when the modal basis is incomplete (a large model's lowest modes only), or
    /// when the model is stiff enough for the damping collocation (Radau IIA, chosen
    /// automatically above 64 dofs) and holds its tangent sparse — unless the motion is a
    /// travelling wave (shot over a sector shift, dense only); dense otherwise. Measured on
    /// the ECL beam to +20% (`nnm bench --stiff`): matrix-free 3.1 s against 4.9 s at 100
    /// dofs, 7.2 s against 15.0 s at 200; 28 s against 109 s at 400 dofs (docs/method.md
    /// §15).
    #[default]
    Auto,
    /// Unknowns in the elastic modal basis, the Jacobian and monodromy as dense matrices from
    /// sensitivities along every unknown direction (docs/method.md §2–7).
    Dense,
    /// Unknowns the whole weighted initial state, Newton corrections by GMRES and multipliers
    /// by Arnoldi on monodromy–vector products: O(n · steps) memory, no modal basis beyond the
    /// starting mode.
    MatrixFree,
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
    /// `‖W H‖ / ‖W z0‖`, the convergence measure (eq. (19)) in the weighted metric.
    pub relative_residual: f64,
    /// Weighted residual rows `[W H; h]`.
    pub rows: Vec<f64>,
    /// Their Jacobian with respect to the unknowns `u` (`rows × (m+1)`).
    pub jacobian: Mat<f64>,
    /// `Φ(T) S`, the flow derivative along the unknown state directions (`2n × m`).
    pub flow_derivative: Vec<f64>,
    /// Accepted step sizes (replayed by finite differences).
    pub steps: Vec<f64>,
    /// The Jacobian as an operator (matrix-free formulation; `jacobian` is then empty).
    pub operator: Option<std::sync::Arc<MatrixFreeJacobian>>,
}

impl Linearization for Evaluation {
    fn residual(&self) -> &[f64] {
        &self.rows
    }

    fn relative_residual(&self) -> f64 {
        self.relative_residual
    }

    /// Dense Householder QR of the bordered Jacobian (the Moore–Penrose solution of the
    /// consistent overdetermined system).
    fn solve_bordered(&self, border: &[f64], rhs: &[f64], border_rhs: f64) -> Vec<f64> {
        if let Some(operator) = &self.operator {
            return operator.solve(border, rhs, border_rhs);
        }
        crate::continuation::solve_bordered_dense(&self.jacobian, border, rhs, border_rhs)
    }
}

/// Why the shooting problem could not be evaluated, or a solution is not a valid point.
#[derive(Debug, thiserror::Error)]
pub enum ShootingError {
    /// The time integration failed.
    #[error(transparent)]
    Integration(#[from] IntegrationError),
    /// The unknowns give a period that is not positive and finite (the value held).
    #[error("non-positive period {}", crate::number::Number(*.0))]
    NonPositivePeriod(f64),
    /// The converged point's energy is NaN or infinite.
    #[error("non-finite energy {0}")]
    NonFiniteEnergy(f64),
    /// The full-period residual (held) exceeds 100× the tolerance: a half-period solution that
    /// is not periodic after all (docs/method.md §2).
    #[error(
        "the motion is not half-wave symmetric (full-period residual {0:.2e}); set half_period = false"
    )]
    NotHalfWaveSymmetric(f64),
    /// The eigenvalues of the monodromy could not be computed.
    #[error("Floquet analysis failed: {0}")]
    Floquet(#[from] linalg::LinalgError),
    /// The formulation cannot shoot this model (the text says why and what to change).
    #[error("{0}")]
    Unsupported(String),
}

/// Work counters of the shooting problem.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct ShootingStats {
    /// Evaluations of the shooting equations (Newton iterations and trial points).
    pub evaluations: usize,
    /// Integrations of the motion (with or without sensitivities).
    pub integrations: usize,
    /// Their work, summed (finite-difference runs included).
    pub integration: IntegrationStats,
    /// Monodromy–vector products of the matrix-free formulation (GMRES and Arnoldi).
    pub krylov_products: usize,
}

/// The shooting problem of one branch.
pub struct Shooting<'a, S: MechanicalSystem + ?Sized> {
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
    /// `z(T/q) = P z0` shot instead of `z(T) = z0`, if any (docs/method.md §17).
    shift: Option<ShiftSymmetry>,
    period_ref: f64,
    /// State directions of the unknowns, `2n × m`.
    state_basis: Vec<f64>,
    integrator: Box<dyn Integrator + 'a>,
    /// The method `integrator` runs, resolved from `auto`; `None` once
    /// [`Self::with_integrator`] plugged in another.
    method: Option<IntegrationMethod>,
    floquet: Box<dyn FloquetSolver>,
    first_step: Option<f64>,
    /// `z_ref` of the flow-orthogonal phase condition: the last accepted point's `z0`.
    phase_reference: Vec<f64>,
    /// `ω_c = √(b_cᵀ K_t(0) b_c)` of each basis column: the scaling that makes the linear
    /// monodromy orthogonal in modal coordinates (docs/method.md eq. (33a)).
    modal_frequencies: Vec<f64>,
    /// The convergence tolerance (the full-period check of half-period points uses it).
    tolerance: f64,
    stability_tolerance: f64,
    /// Whether the Floquet analysis gives the pairs on the circle their Krein signatures
    /// (docs/method.md eq. (37a)): the events' detection needs them, a stability verdict not,
    /// and the eigenvectors cost ~15% of a small model's point.
    krein_signatures: bool,
    /// Work counters so far.
    pub stats: ShootingStats,
    /// Called after every evaluation (a Newton iteration, or a trial point of an event's
    /// location), for progress within a long point.
    progress: Option<ProgressHook<'a>>,
    /// The weighted coordinates of the matrix-free formulation; `None`: dense.
    matrix_free: Option<matrix_free::MatrixFree>,
    /// Why this problem cannot be evaluated, if it cannot (reported by the first evaluation).
    unsupported: Option<String>,
    /// The linear mode (index in the model's list) of each column of `basis`.
    basis_modes: Vec<usize>,
    /// The dofs whose peak displacements every point records.
    output_dofs: Vec<usize>,
    /// The damping and force whose resonance force every point reports, if asked.
    energy_balance: Option<std::sync::Arc<crate::analysis::EnergyBalance>>,
    /// The integrator takes equal steps whose number it sets from a global error estimate
    /// (the collocation methods): the motion of a converged point is then sampled on the
    /// shooting's own step, not re-estimated for every sample (10× the cost on the beams).
    equal_steps: bool,
}

/// A progress hook: called with every evaluation.
pub type ProgressHook<'a> = Box<dyn FnMut(&EvaluationProgress) + 'a>;

/// One shooting evaluation, as reported to a progress hook ([`Shooting::set_progress`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvaluationProgress {
    /// Evaluations of this shooting problem so far (this one included).
    pub evaluations: usize,
    /// The evaluation's relative residual (eq. (19)).
    pub relative_residual: f64,
    /// Its period `T`.
    pub period: f64,
}

/// `ω_c = √(b_cᵀ K_t(0) b_c)` for the `r` columns of the mass-orthonormal basis `B` (the
/// natural frequencies when they are modes); rigid or non-positive columns get `ω_ref`.
fn modal_frequencies<S: MechanicalSystem + ?Sized>(
    system: &S,
    basis: &[f64],
    r: usize,
    omega_ref: f64,
) -> Vec<f64> {
    let n = system.dofs();
    let mut kb = vec![0.0; n * r];
    system.tangent_stiffness(
        &vec![0.0; n],
        Block::new(basis, n, r, n),
        BlockMut::new(&mut kb, n, r, n),
    );
    (0..r)
        .map(|c| {
            let w2 = linalg::dot(&basis[c * n..(c + 1) * n], &kb[c * n..(c + 1) * n]);
            if w2 > 0.0 { w2.sqrt() } else { omega_ref }
        })
        .collect()
}

impl<S: MechanicalSystem + ?Sized> std::fmt::Debug for Shooting<'_, S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Shooting")
            .field("dofs", &self.n)
            .field("modes", &self.r)
            .field("unknown_modes", &self.r_u)
            .field("phase", &self.phase)
            .field("shift", &self.shift)
            .finish()
    }
}

/// What a branch's start fixes of its shooting problem, beside the settings.
#[derive(Debug, Clone)]
pub struct ShootingSetup {
    /// Elastic basis `B` (`n × r` column-major, mass-orthonormal), the first
    /// `unknown_columns` spanning the unknowns.
    pub basis: Vec<f64>,
    /// `M B`, for projections onto modal coordinates (`q = (MB)ᵀ x`).
    pub mass_basis: Vec<f64>,
    /// How many leading columns of `basis` span the unknowns (`r_u`: fewer than `r` when
    /// restricted to a symmetry class).
    pub unknown_columns: usize,
    /// Frequency scale of the branch.
    pub omega_ref: f64,
    /// Phase condition of the branch (docs/method.md eqs. (7)–(8)).
    pub phase: PhaseCondition,
    /// Amplitude unit of the unknowns: `x0 = B_u (amplitude_scale · a)`. Chosen where the
    /// nonlinearity becomes strong, it makes `a` and `τ` both O(1) in the nonlinear regime,
    /// so the arclength does not depend on the model's length unit.
    pub amplitude_scale: f64,
    /// Shoot over `T/q` on `z(T/q) = P z0` (docs/method.md §17): `z(T/2) = -z0` for odd
    /// systems' half-wave-symmetric motions, a sector shift for travelling waves.
    pub shift: Option<ShiftSymmetry>,
    /// The first phase reference (the start's state).
    pub phase_reference: Vec<f64>,
    /// Whether `basis` holds every elastic mode (the dense formulation needs them all).
    pub complete_basis: bool,
    /// The linear mode (index in the model's list) of each column of `basis`.
    pub basis_modes: Vec<usize>,
    /// The dofs whose peak displacements every point records ([`Start::output_dofs`]).
    pub output_dofs: Vec<usize>,
}

impl<'a, S: MechanicalSystem + ?Sized> Shooting<'a, S> {
    /// The problem of one branch, integrated by the settings' method
    /// ([`IntegrationMethod::resolve`] for `auto`; [`Self::with_integrator`] plugs another
    /// in). `settings`: a `&Settings`, or the groups it reads borrowed in a [`SettingsView`].
    pub fn new<'s>(
        system: &'a S,
        setup: ShootingSetup,
        settings: impl Into<SettingsView<'s>>,
    ) -> Self {
        let settings = settings.into();
        let ShootingSetup {
            basis,
            mass_basis,
            unknown_columns,
            omega_ref,
            phase,
            amplitude_scale,
            shift,
            phase_reference,
            complete_basis,
            basis_modes,
            output_dofs,
        } = setup;
        let n = system.dofs();
        let r = basis.len() / n;
        let r_u = unknown_columns.min(r);
        let m = match phase {
            PhaseCondition::ZeroVelocity => r_u,
            PhaseCondition::FlowOrthogonal => 2 * r_u,
        };
        let a = amplitude_scale;
        let mut state_basis = vec![0.0; 2 * n * m];
        for c in 0..r_u {
            let b = &basis[c * n..(c + 1) * n];
            for (s, b) in state_basis[c * 2 * n..c * 2 * n + n].iter_mut().zip(b) {
                *s = a * b;
            }
            if phase == PhaseCondition::FlowOrthogonal {
                let col = &mut state_basis[(r_u + c) * 2 * n + n..(r_u + c + 1) * 2 * n];
                for (s, b) in col.iter_mut().zip(b) {
                    *s = a * omega_ref * b;
                }
            }
        }
        let tolerance = settings.continuation.tolerance;
        let method = settings.integration.integrator.resolve(system, omega_ref);
        let (matrix_free, unsupported) = match settings.shooting.formulation {
            Formulation::MatrixFree => (true, None),
            Formulation::Auto => (
                !complete_basis
                    || (method.damps_unresolved_modes()
                        && system.tangent_pattern().is_some()
                        && shift.as_ref().is_none_or(|s| s.diagonal(0).is_some())),
                None,
            ),
            Formulation::Dense if !complete_basis => (
                false,
                Some(format!(
                    "the dense formulation needs every linear mode, but only the lowest {r} of {n} were computed; set formulation = \"matrix-free\""
                )),
            ),
            Formulation::Dense => (false, None),
        };
        // Matrix-free shooting replays a collocation method's linearised steps; a model that
        // only needs it for its size (not stiff: a disk of thousands of sectors) gets the
        // symplectic one, which neither damps nor amplifies any mode (docs/method.md §15).
        let method =
            if matrix_free && settings.integration.integrator.is_auto() && !method.is_collocation()
            {
                IntegrationMethod::Gauss6
            } else {
                method
            };
        let (matrix_free, unsupported) = if matrix_free {
            match matrix_free::MatrixFree::new(
                system,
                amplitude_scale * omega_ref,
                &phase_reference,
                omega_ref,
            ) {
                Ok(free) => (Some(free), unsupported),
                Err(why) => (None, Some(why)),
            }
        } else {
            (None, unsupported)
        };
        let (phase, state_basis) = if matrix_free.is_some() {
            // The whole state is unknown: the time shift is fixed by the flow-orthogonal
            // condition.
            (PhaseCondition::FlowOrthogonal, Vec::new())
        } else {
            (phase, state_basis)
        };
        let relative =
            method.relative_tolerance(tolerance, settings.integration.integration_factor);
        let tolerances = Tolerances {
            relative,
            absolute: relative,
            velocity_scale: omega_ref,
        };
        let integrator = method.integrator(system, tolerances);
        let modal_frequencies = modal_frequencies(system, &basis, r, omega_ref);
        Self {
            system,
            n,
            basis,
            mass_basis,
            r,
            r_u,
            phase,
            jacobian_method: settings.shooting.jacobian,
            omega_ref,
            amplitude_scale: a,
            shift,
            period_ref: 2.0 * std::f64::consts::PI / omega_ref,
            state_basis,
            integrator,
            method: Some(method),
            floquet: Box::new(DenseFloquet),
            first_step: None,
            phase_reference,
            modal_frequencies,
            tolerance,
            stability_tolerance: settings.stability.stability_tolerance,
            krein_signatures: settings.stability.events,
            stats: ShootingStats::default(),
            progress: None,
            matrix_free,
            unsupported,
            basis_modes,
            output_dofs,
            energy_balance: settings.output.energy_balance.clone(),
            equal_steps: method.is_collocation(),
        }
    }

    /// Whether the problem is shot matrix-free ([`Formulation`]).
    pub fn is_matrix_free(&self) -> bool {
        self.matrix_free.is_some()
    }

    /// Calls `hook` after every evaluation: a long point (a large model's Newton iterations
    /// take seconds each) can show its progress.
    pub fn set_progress(&mut self, hook: ProgressHook<'a>) {
        self.progress = Some(hook);
    }

    /// Replaces the integrator (e.g. an implicit one for a stiff model). Its tolerances are
    /// set from the problem's.
    pub fn with_integrator(mut self, mut integrator: Box<dyn Integrator + 'a>) -> Self {
        integrator.set_tolerances(self.integrator.tolerances());
        self.integrator = integrator;
        self.method = None;
        self
    }

    /// The integration method in use: the settings' `integrator`, resolved from `auto` for
    /// this model and formulation; `None` for an integrator plugged in by
    /// [`Self::with_integrator`].
    pub fn method(&self) -> Option<IntegrationMethod> {
        self.method
    }

    /// Replaces the Floquet solver (the dense full-spectrum one by default).
    pub fn with_floquet_solver(mut self, solver: Box<dyn FloquetSolver>) -> Self {
        self.floquet = solver;
        self
    }

    /// The system being shot.
    pub fn system(&self) -> &'a S {
        self.system
    }

    /// Number of unknowns `m + 1`.
    pub fn unknowns(&self) -> usize {
        if self.matrix_free.is_some() {
            return 2 * self.n + 1;
        }
        self.state_basis.len() / (2 * self.n) + 1
    }

    /// The phase condition in use (a start may override the settings').
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
        if let Some(free) = &self.matrix_free {
            return free.state(&u[..n2]);
        }
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
        if let Some(free) = &self.matrix_free {
            let mut u = free.unknowns(z0);
            u.push(period / self.period_ref);
            return u;
        }
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
        self.integrator.energy(z0)
    }

    fn integrate(
        &mut self,
        z0: &[f64],
        period: f64,
        directions: Option<Block<'_>>,
        steps: Steps<'_>,
    ) -> Result<Flow, IntegrationError> {
        self.scale_tolerances(z0);
        let flow = self.integrator.flow(z0, period, directions, steps)?;
        self.count_integration(&flow);
        Ok(flow)
    }

    fn count_integration(&mut self, flow: &Flow) {
        self.stats.integrations += 1;
        self.stats.integration += flow.stats;
    }

    /// `T = τ T_ref` (`NonPositivePeriod` unless positive and finite) and the horizon shot
    /// (`T`, or `T/q` with a [`ShiftSymmetry`]).
    fn horizon(&self, tau: f64) -> Result<(f64, f64), ShootingError> {
        let period = tau * self.period_ref;
        if !(period.is_finite() && period > 0.0) {
            return Err(ShootingError::NonPositivePeriod(period));
        }
        let divisions = self.shift.as_ref().map_or(1, |s| s.divisions);
        Ok((period, period / divisions as f64))
    }

    /// The target of the shooting equations for a state: `z0`, or `P z0` with a shift
    /// (`H = z(horizon) − P z0`, eq. (80)).
    fn shifted(&self, z: &[f64]) -> Vec<f64> {
        match &self.shift {
            Some(shift) => shift.apply(z),
            None => z.to_vec(),
        }
    }

    /// Sets the integrator's absolute tolerance from the motion's displacement scale
    /// (velocities weighted by 1/ω_ref, see `Tolerances`).
    fn scale_tolerances(&mut self, z0: &[f64]) {
        let n = self.n;
        let scale = z0.iter().enumerate().fold(0.0f64, |m, (i, v)| {
            m.max(if i < n {
                v.abs()
            } else {
                v.abs() / self.omega_ref
            })
        });
        let mut tolerances = self.integrator.tolerances();
        tolerances.absolute = tolerances.relative * scale.max(f64::MIN_POSITIVE);
        self.integrator.set_tolerances(tolerances);
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

    /// Evaluates the shooting equations and their Jacobian at `u`, with `phase_reference`
    /// the `z_ref` of [`PhaseCondition::FlowOrthogonal`] (ignored otherwise).
    pub fn evaluate_with_reference(
        &mut self,
        u: &[f64],
        phase_reference: &[f64],
    ) -> Result<Evaluation, ShootingError> {
        if let Some(why) = &self.unsupported {
            return Err(ShootingError::Unsupported(why.clone()));
        }
        if self.matrix_free.is_some() {
            return self.evaluate_matrix_free(u, phase_reference);
        }
        let n2 = 2 * self.n;
        let m = u.len() - 1;
        let (period, horizon) = self.horizon(u[m])?;
        let z0 = self.initial_state(u);
        let directions = std::mem::take(&mut self.state_basis);
        let result = self.flow_with_derivative(&z0, horizon, &directions, None);
        self.state_basis = directions;
        let (flow, derivative) = result?;

        // H = z(T) - z0, or z(T/q) - P z0 with a shift, weighted mode by mode (eq. (17)).
        let target = self.shifted(&z0);
        let h: Vec<f64> = (0..n2).map(|i| flow.z[i] - target[i]).collect();
        let mut rows = self.weighted_modal(&h);
        let r2 = rows.len();
        let relative_residual =
            linalg::norm(&rows) / linalg::norm(&self.weighted_modal(&z0)).max(f64::MIN_POSITIVE);
        let phase_rows = usize::from(self.phase == PhaseCondition::FlowOrthogonal);
        let mut jacobian = Mat::<f64>::zeros(r2 + phase_rows, m + 1);
        let mut column = vec![0.0; n2];
        for c in 0..m {
            let s = self.shifted(&self.state_basis[c * n2..(c + 1) * n2]);
            for i in 0..n2 {
                column[i] = derivative[c * n2 + i] - s[i];
            }
            for (i, v) in self.weighted_modal(&column).into_iter().enumerate() {
                jacobian[(i, c)] = v;
            }
        }
        // ∂H/∂τ = (horizon/τ) g(z(horizon)): T_ref g(z(T)), or T_ref/q g(z(T/q)).
        let mut g_end = vec![0.0; n2];
        self.integrator.field(&flow.z, &mut g_end);
        g_end.iter_mut().for_each(|g| *g *= horizon / u[m]);
        for (i, v) in self.weighted_modal(&g_end).into_iter().enumerate() {
            jacobian[(i, m)] = v;
        }
        if phase_rows == 1 {
            let mut g_ref = vec![0.0; n2];
            self.integrator.field(phase_reference, &mut g_ref);
            let norm = linalg::norm(&g_ref).max(f64::MIN_POSITIVE);
            g_ref.iter_mut().for_each(|g| *g /= norm);
            let offset: Vec<f64> = (0..n2).map(|i| z0[i] - phase_reference[i]).collect();
            rows.push(linalg::dot(&g_ref, &offset));
            for c in 0..m {
                let s = &self.state_basis[c * n2..(c + 1) * n2];
                jacobian[(r2, c)] = linalg::dot(&g_ref, s);
            }
        }
        self.finish_evaluation(relative_residual, period);
        Ok(Evaluation {
            z0,
            z_end: flow.z,
            period,
            relative_residual,
            rows,
            jacobian,
            flow_derivative: derivative,
            steps: flow.steps,
            operator: None,
        })
    }

    /// Counts an evaluation and reports it to the progress hook.
    fn finish_evaluation(&mut self, relative_residual: f64, period: f64) {
        self.stats.evaluations += 1;
        if let Some(hook) = self.progress.as_mut() {
            hook(&EvaluationProgress {
                evaluations: self.stats.evaluations,
                relative_residual,
                period,
            });
        }
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
