//! Implicit collocation (Radau IIA, Gauss–Legendre) of the forced motion in the force's
//! phase, with the sensitivities of the discrete flow (docs/method.md eqs. (95)–(97)).
//!
//! The stage unknowns are the phase-rates of the velocity `W_j = dv/dτ` at the nodes; with
//! `Ā = A²` the stage states are
//!
//! ```text
//!     V_i = v0 + h Σ_j a_ij W_j,   X_i = x0 + (h c_i/Ω) v0 + (h²/Ω) Σ_j ā_ij W_j,
//! ```
//!
//! and the stage equations `R_i = Ω M W_i + C V_i + f_int(X_i) − a F(τ_i) = 0` are solved by
//! Newton with the exact Jacobian `∂R_i/∂W_j = Ω M δ_ij + h a_ij C + (h²/Ω) ā_ij K_t(X_i)`,
//! i.e. `Ω` times the free motion's stage Jacobian with the time step `h/Ω` and the damping
//! term `(h/Ω) a_ij C` (eq. (96)): the same sparse stage system, factorised whole or, for a
//! localised nonlinearity, as a low-rank update of its linear part (eq. (32e)), serves both.
//! The sensitivities of the step follow from the same factorised Jacobian:
//! `J δW = −[δΩ M W_i + C δv0 + K_t(X_i)(δx0 + (h c_i/Ω) δv0 − δΩ (X_i − x0)/Ω) − δa F(τ_i)]`,
//! then `δv1 = δv0 + h Σ b_j δW_j`, `δx1 = δx0 + (h/Ω) δv0 + (h²/Ω) Σ (bᵀA)_j δW_j −
//! δΩ (x1 − x0)/Ω`.
//!
//! The steps are equal, `N` a period, set by [`ForcedIntegrator::adapt`] from the difference
//! of the flows over the shot span with `N` and `N/2` steps a period (global error
//! `≈ ‖z_N − z_{N/2}‖/(2^p − 1)`, `p` the end-point order), between points and never within a
//! Newton solve. The estimate is made on the
//! motion's slow part, as for free motions (eq. (32d)): the difference is filtered by
//! `(M + K₀/ω_c²)⁻¹M`, `ω_c` sixteen times the forcing frequency, since the quasi-static
//! response of the stiff modes converges at Radau IIA's stage order only, and its error is
//! damped out within a period (`R(∞) = 0`) instead of accumulating.
//!
//! The stage iteration is a simplified Newton iteration on the last factorised Jacobian
//! (from the step before: equal steps, slowly varying tangents), refactorised when it stops
//! contracting; an integration with sensitivities factorises the exact Jacobian at every
//! converged step, which its sensitivities need and the next step's iteration reuses. A model
//! that gives its tangent on a pattern has a sparse stage system (no `n × n` array is formed);
//! one that does not, a dense one.

use std::sync::Arc;

use super::{Drive, ForcedFlow, ForcedIntegrator, RecordedFlow, check_forced_request, phase_field};
use crate::integrate::collocation::{
    Collocation, CollocationLinearization, LinearStages, RecordedStep, SPLIT_DOFS, Scratch,
    SparseStages, SplitStages, StageLu, StageMethod, StageTangents, StepImage, VariationalBuffers,
    low_pass, variational_step,
};
use crate::integrate::{IntegrationError, IntegrationStats, LinearizedFlow, Tolerances};
use crate::linalg::{DenseLu, Mat};
use crate::model::{ForcedSystem, Matrix, MechanicalSystem, SparseMatrix, dense_tangent};

/// Newton iterations allowed for one step's stage equations.
const MAX_STAGE_ITERATIONS: usize = 20;
/// The stage iteration stops when the update is this small relative to the stage values.
const STAGE_TOLERANCE: f64 = 1e-13;
/// A stalled stage iteration has met its round-off floor when its update is below these
/// fractions of the stage values: on a fresh factorisation (the floor then recorded), and
/// at least, on a stale one (see the convergence test of the stage iteration).
const FRESH_FLOOR: f64 = 1e-4;
const STALE_FLOOR: f64 = 1e-7;
/// The accuracy a recorded step's split stage solve (eq. (32f)) takes the parameter columns
/// `∂z/∂Ω`, `∂z/∂a` to, relative to the state the step ends in (eqs. (97), (32g)). Why not to
/// round-off: the columns only enter the Jacobian's last column, whose error moves a Newton
/// correction, the tangent and a fold's test function by as much — and a fold's frequency
/// only by its square (the curve turns there). The corrections' own products are taken to
/// 1e-4 (eq. (102a)). (Whole and low-rank stage factorisations solve exactly in one pass.)
const PARAMETER_COLUMN_ACCURACY: f64 = 1e-8;
/// Steps a period before the first estimate, and the bounds of the estimate.
const INITIAL_STEPS: usize = 64;
const MIN_STEPS: usize = 8;
const MAX_STEPS: usize = 200_000;
/// Integrations taken again on more steps after the stage equations diverged, before that is
/// an error: 1.5⁶ ≈ 11 times the steps.
const STAGE_RETRIES: usize = 6;

/// The steps a period to take again on after the stage equations diverged on `steps`: half
/// again as many (at least one more, at most [`MAX_STEPS`]).
fn half_again(steps: usize) -> usize {
    (steps + steps / 2).max(steps + 1).min(MAX_STEPS)
}
/// The step count controls the error of the motion below this many harmonics of the force
/// (the low-pass filter of the module notes).
const CUTOFF_HARMONICS: f64 = 16.0;
/// An estimate of the step count serves the points after it while the frequency stays within
/// this fraction of the one it was made at and the state's size within this factor, for at
/// most [`REUSE`] points: the error of a fixed step count moves with the motion, slowly.
const REUSE_FREQUENCY: f64 = 0.02;
const REUSE_SIZE: f64 = 1.25;
const REUSE: usize = 8;

/// What an integration carries besides the motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Sensitivities {
    None,
    /// `[Φ ∂z/∂Ω ∂z/∂a]`.
    Full,
    /// `[∂z/∂Ω ∂z/∂a]`, and every step recorded for products with `Φ` (eq. (72)).
    Recorded,
}

/// Implicit collocation of a forced system with equal steps.
pub struct ForcedCollocation<'s, 'a, S: MechanicalSystem + ?Sized> {
    system: &'s ForcedSystem<'a, S>,
    method: &'static Collocation,
    /// Error tolerances of the global error estimate of [`ForcedIntegrator::adapt`].
    pub tolerances: Tolerances,
    /// Equal steps a period.
    steps: usize,
    /// At least this many steps a period, once fewer failed the stage iteration
    /// ([`Self::integrate_on_period_steps`]).
    least_steps: usize,
    /// Where the step count was last estimated (frequency, RMS size of the state) and how
    /// many points it has served since.
    estimate: Option<(f64, f64, usize)>,
    /// The last integration with sensitivities from phase 0: its start, drive, span, step
    /// count and end state. [`ForcedIntegrator::adapt`], called at the point just converged,
    /// takes its fine flow from here instead of integrating it again (the same discrete map:
    /// the stage iteration converges to the same stages, to its tolerance, whatever it
    /// carries besides).
    last_flow: Option<LastFlow>,
    /// `M`'s entries.
    mass: SparseMatrix,
    /// The stage system's structure.
    stages: Stages,
    /// `A` and `Ā = A²`.
    coefficients: StageMethod,
    /// `bᵀA`.
    bta: Vec<f64>,
    /// `E_ij = ℓ_j(1 + c_i)`, the Lagrange basis of the nodes at the next step's nodes
    /// (row-major `s × s`): the last step's stage values extrapolated.
    extrapolation: Vec<f64>,
    ws: Workspace,
}

/// See [`ForcedCollocation::last_flow`].
struct LastFlow {
    z0: Vec<f64>,
    drive: Drive,
    span: f64,
    steps: usize,
    z: Vec<f64>,
}

/// How the stage system is assembled and factorised.
enum Stages {
    /// On the union of `M`'s, `C`'s and `K_t`'s patterns (shared with free collocation);
    /// above [`SPLIT_DOFS`] dofs with a nonlinearity everywhere, also split into systems of
    /// the model's size (eq. (32f)) for the integrations that carry no `Φ` columns: the
    /// stage iteration's matrix, and the recorded steps' refined exact solves.
    Sparse {
        stages: SparseStages,
        split: Option<SplitStages>,
    },
    /// Dense, for systems that give no tangent pattern: `M` and `C` column-major `n × n`.
    Dense { mass: Vec<f64>, damping: Vec<f64> },
}

/// What one step leaves for the next, and the step's scratch.
#[derive(Default)]
struct Workspace {
    /// The factorised stage Jacobian the iteration uses, divided by `Ω` (eq. (96)), and the
    /// tangents it was made from.
    lu: Option<StageLu>,
    tangents: Option<StageTangents>,
    /// The linear part of a low-rank stage system at the current step (eq. (32e)).
    linear: Option<Arc<LinearStages>>,
    /// `W`, `s × n`, of the last step (extrapolated, the next step's first iterate).
    w: Vec<f64>,
    extrapolated: Vec<f64>,
    x: Vec<f64>,
    v: Vec<f64>,
    residual: Vec<f64>,
    force: Vec<f64>,
    /// A dense tangent's pattern values or identity block.
    values: Vec<f64>,
    rhs: Vec<f64>,
    /// `δx0 + (h c_i/Ω) δv0` of one parameter column.
    displacement: Vec<f64>,
    /// `−(X_i − x0)/Ω` of one stage, and its product with the tangent.
    moved: Vec<f64>,
    product: Vec<f64>,
    /// `C δv0` of the parameter columns (`n × 2`).
    damped: Vec<f64>,
    /// The parameter columns' split stage solves' (eq. (32f)).
    solve: Scratch,
    /// The relative update at which freshly factorised stage systems of this integration
    /// stalled: their round-off floor (0 until one has).
    floor: f64,
    /// Whether this integration's stage systems are split (eq. (32f)).
    split: bool,
}

impl<'s, 'a, S: MechanicalSystem + ?Sized> ForcedCollocation<'s, 'a, S> {
    /// The integrator of `system` by `method`, with [`INITIAL_STEPS`] steps a period until
    /// [`ForcedIntegrator::adapt`] sets them.
    pub fn new(
        system: &'s ForcedSystem<'a, S>,
        method: &'static Collocation,
        tolerances: Tolerances,
    ) -> Self {
        let s = method.c.len();
        let coefficients = StageMethod::new(method);
        let bta = (0..s)
            .map(|j| (0..s).map(|l| method.b[l] * method.a[l][j]).sum())
            .collect();
        let c = method.c;
        let extrapolation = (0..s * s)
            .map(|k| {
                let (i, j) = (k / s, k % s);
                (0..s)
                    .filter(|&l| l != j)
                    .map(|l| (1.0 + c[i] - c[l]) / (c[j] - c[l]))
                    .product()
            })
            .collect();
        let mass = crate::model::mass_entries(system.system().mass());
        let column_major = |m: Mat<f64>| {
            let n = m.nrows();
            (0..n * n).map(|k| m[(k % n, k / n)]).collect()
        };
        let inner = system.system();
        let damped = (&mass, Some(system.damping()));
        let stages = match inner.tangent_pattern().and_then(|pattern| {
            SparseStages::new(pattern, &mass, Some(system.damping()), s)
                .map(|stages| stages.with_low_rank(inner, damped, &coefficients))
                .map(|stages| (pattern, stages))
        }) {
            Some((pattern, stages)) => {
                let split = (system.dofs() > SPLIT_DOFS && !stages.is_low_rank())
                    .then(|| SparseStages::split(pattern, damped, &coefficients))
                    .flatten();
                Stages::Sparse { stages, split }
            }
            None => Stages::Dense {
                mass: column_major(Matrix::Sparse(mass.clone()).to_dense()),
                damping: column_major(Matrix::Sparse(system.damping().clone()).to_dense()),
            },
        };
        Self {
            system,
            method,
            tolerances,
            steps: INITIAL_STEPS,
            least_steps: MIN_STEPS,
            estimate: None,
            last_flow: None,
            mass,
            stages,
            coefficients,
            bta,
            extrapolation,
            ws: Workspace::default(),
        }
    }

    /// Splits the stage systems whatever the model's size (tests of eq. (32f) on small ones).
    #[cfg(test)]
    pub(super) fn with_split_stages(mut self) -> Self {
        let pattern = (self.system.system().tangent_pattern()).expect("a sparse model");
        let damped = (&self.mass, Some(self.system.damping()));
        let Stages::Sparse { stages, split } = &mut self.stages else {
            panic!("a sparse model");
        };
        assert!(!stages.is_low_rank(), "a nonlinearity everywhere");
        *split = SparseStages::split(pattern, damped, &self.coefficients);
        assert!(split.is_some(), "Radau IIA's A is diagonalisable");
        self
    }

    /// Sets the steps a period (tests of the step count's own checks).
    #[cfg(test)]
    pub(super) fn with_steps(mut self, steps: usize) -> Self {
        self.steps = steps;
        self
    }

    /// Equal steps a period in force.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// `V_i`, `X_i` of the module notes from `W`.
    fn stage_states(&self, x0: &[f64], v0: &[f64], h: f64, omega: f64, ws: &mut Workspace) {
        let n = x0.len();
        let s = self.method.c.len();
        let (a, abar) = (&self.coefficients.a, &self.coefficients.abar);
        for i in 0..s {
            for p in 0..n {
                let (mut dv, mut dx) = (0.0, 0.0);
                for j in 0..s {
                    dv += a[i][j] * ws.w[j * n + p];
                    dx += abar[i][j] * ws.w[j * n + p];
                }
                ws.v[i * n + p] = v0[p] + h * dv;
                ws.x[i * n + p] = x0[p] + h * self.method.c[i] / omega * v0[p] + h * h / omega * dx;
            }
        }
    }

    /// Factorises the stage Jacobian (eq. (96)) divided by `Ω`, `M δ_ij + (h/Ω) a_ij C +
    /// (h/Ω)² ā_ij K_t(X_i)`, at the current stage states.
    fn factorise(
        &self,
        h: f64,
        omega: f64,
        ws: &mut Workspace,
        stats: &mut IntegrationStats,
    ) -> Result<(), IntegrationError> {
        let n = self.system.dofs();
        let s = self.method.c.len();
        let step = h / omega;
        let system = self.system.system();
        stats.tangent_evaluations += s;
        stats.factorisations += 1;
        let factorised = match &self.stages {
            Stages::Sparse {
                stages,
                split: Some(split),
            } if ws.split => stages.factorise_split(split, system, &ws.x, step),
            Stages::Sparse { stages, .. } => {
                stages.factorise(system, &ws.x, step, &self.coefficients, &mut ws.linear)
            }
            Stages::Dense { mass, damping } => {
                let mut tangents = vec![0.0; s * n * n];
                for (x, tangent) in ws.x.chunks(n).zip(tangents.chunks_mut(n * n)) {
                    dense_tangent(system, x, tangent, &mut ws.values);
                }
                let (a, abar) = (&self.coefficients.a, &self.coefficients.abar);
                let jacobian = Mat::<f64>::from_fn(s * n, s * n, |row, col| {
                    let (i, p, j, q) = (row / n, row % n, col / n, col % n);
                    let m = if i == j { mass[q * n + p] } else { 0.0 };
                    m + step * a[i][j] * damping[q * n + p]
                        + step * step * abar[i][j] * tangents[i * n * n + q * n + p]
                });
                let lu = DenseLu::new(jacobian.as_ref());
                Some((StageLu::Dense(lu), StageTangents::Dense(tangents)))
            }
        };
        let (lu, tangents) = factorised.ok_or_else(|| {
            IntegrationError::InvalidInput(format!(
                "the implicit stage system is singular (step {step:.3e} s)"
            ))
        })?;
        ws.lu = Some(lu);
        ws.tangents = Some(tangents);
        Ok(())
    }

    /// Solves one step's stage equations from `z` at phase `tau` with step `h`; with
    /// `exact`, leaves the Jacobian at the converged stages factorised in `ws.lu`.
    #[allow(clippy::too_many_arguments)]
    fn stages(
        &self,
        z: &[f64],
        tau: f64,
        h: f64,
        drive: Drive,
        exact: bool,
        ws: &mut Workspace,
        stats: &mut IntegrationStats,
    ) -> Result<(), IntegrationError> {
        let n = self.system.dofs();
        let s = self.method.c.len();
        let (x0, v0) = z.split_at(n);
        let omega = drive.frequency;
        ws.x.resize(s * n, 0.0);
        ws.v.resize(s * n, 0.0);
        ws.residual.resize(s * n, 0.0);
        ws.force.resize(n, 0.0);
        if ws.w.len() != s * n {
            let mut start = vec![0.0; 2 * n];
            phase_field(self.system, z, tau, drive, &mut start);
            stats.rhs_evaluations += 1;
            ws.w = (0..s).flat_map(|_| start[n..].iter().copied()).collect();
        } else {
            // The last step's collocation polynomial of `W`, extrapolated to this step's
            // nodes: an error of order `h^s` to start from instead of order `h`, a Newton
            // iteration or two less a step.
            ws.extrapolated.clear();
            ws.extrapolated.resize(s * n, 0.0);
            for i in 0..s {
                for j in 0..s {
                    let e = self.extrapolation[i * s + j];
                    let (target, source) = (
                        &mut ws.extrapolated[i * n..(i + 1) * n],
                        &ws.w[j * n..(j + 1) * n],
                    );
                    target.iter_mut().zip(source).for_each(|(t, w)| *t += e * w);
                }
            }
            std::mem::swap(&mut ws.w, &mut ws.extrapolated);
        }
        let mut previous_update = f64::INFINITY;
        let mut fresh = false;
        for _ in 0..MAX_STAGE_ITERATIONS {
            self.stage_states(x0, v0, h, omega, ws);
            if ws.lu.is_none() {
                self.factorise(h, omega, ws, stats)?;
                fresh = true;
            }
            // `−R_i/Ω`: the Jacobian is factorised divided by `Ω`.
            for i in 0..s {
                let r = &mut ws.residual[i * n..(i + 1) * n];
                self.system
                    .system()
                    .internal_force(&ws.x[i * n..(i + 1) * n], r);
                ws.force.fill(0.0);
                self.system.force().add_at(
                    tau + self.method.c[i] * h,
                    drive.amplitude,
                    &mut ws.force,
                );
                for (rp, fp) in r.iter_mut().zip(&ws.force) {
                    *rp -= fp;
                }
                let (w, v) = (&ws.w[i * n..(i + 1) * n], &ws.v[i * n..(i + 1) * n]);
                self.mass.apply_add(omega, w, n, 1, r, n);
                self.system.add_damping_force(v, r);
                r.iter_mut().for_each(|e| *e /= -omega);
            }
            stats.rhs_evaluations += s;
            ws.lu
                .as_ref()
                .expect("factorised above")
                .solve_in_place(&mut ws.residual, 1);
            let (mut update, mut size, mut finite) = (0.0f64, 0.0f64, true);
            for (wi, d) in ws.w.iter_mut().zip(&ws.residual) {
                *wi += d;
                update = update.max(d.abs());
                size = size.max(wi.abs());
                // `max` passes over a NaN: it is looked for entry by entry.
                finite &= d.is_finite();
            }
            // A diverging iteration overflows: the step is too long for it.
            if !(finite && update.is_finite()) {
                ws.w.clear();
                ws.lu = None;
                return Err(IntegrationError::StagesDiverged { t: tau / omega });
            }
            // Converged: the update is below the tolerance, or it stopped shrinking at the
            // round-off floor of the stage system, which lies above `STAGE_TOLERANCE` in the
            // stiff modes' components the step scales down by `h²/Ω` (1e-8 of the largest
            // stage value on the 19-element ECL beam, 2e-6 on the 1,000-element one: its
            // condition grows like `(ω_max h/Ω)²`). A freshly factorised system that stalls
            // near convergence has met that floor, and records it; a stale one that stalls
            // below twice it (or 1e-7) has reached it too (renewing it there doubled the
            // factorisations of the beam's forced curve and changed its folds by 4e-11).
            let stalled = update > 0.25 * previous_update;
            let at_floor = if fresh {
                stalled && update <= FRESH_FLOOR * size
            } else {
                stalled && update <= (2.0 * ws.floor).max(STALE_FLOOR) * size
            };
            if fresh && at_floor {
                ws.floor = ws.floor.max(update / size);
            }
            if update <= STAGE_TOLERANCE * size || size == 0.0 || at_floor {
                self.stage_states(x0, v0, h, omega, ws);
                if exact {
                    self.factorise(h, omega, ws, stats)?;
                }
                return Ok(());
            }
            // A factorisation that stops contracting is renewed at the current stages: a
            // stale one, or one made this step at a first iterate too far from the stages
            // (a long step of a stiff model from the field: the von Kármán beam's membrane
            // at 32 steps a period diverged from it). The renewed one's first update is not
            // measured against the old one's.
            if update > 0.5 * previous_update {
                ws.lu = None;
                previous_update = f64::INFINITY;
            } else {
                previous_update = update;
            }
        }
        ws.w.clear();
        ws.lu = None;
        Err(IntegrationError::StagesDiverged { t: tau / omega })
    }

    /// [`Self::integrate`] over `span` on the steps a period [`Self::steps`] holds (rounded
    /// up when `round_up`, to the nearest count otherwise). When a step's stage equations do
    /// not converge, half again as many steps a period are taken, and kept as the least for
    /// the rest of the curve. Why: the error estimate sets the steps by accuracy alone, and a
    /// step it allows can still be too long for the stage iteration — the 10⁴-dof von
    /// Kármán beam's upper branch at 8 steps a period by Radau9, just past its fold.
    fn integrate_on_period_steps(
        &mut self,
        z0: &[f64],
        (tau0, span, round_up): (f64, f64, bool),
        drive: Drive,
        sensitivities: Sensitivities,
    ) -> Result<(ForcedFlow, Option<Vec<RecordedStep>>), IntegrationError> {
        let period = 2.0 * std::f64::consts::PI;
        self.with_stage_retries(|this| {
            let steps = span / period * this.steps as f64;
            let steps = (if round_up {
                steps.ceil()
            } else {
                steps.round()
            } as usize)
                .max(1);
            this.integrate(z0, tau0, span, steps, drive, sensitivities, None)
        })
    }

    /// `attempt` on the steps a period [`Self::steps`] holds, retried on half again as many
    /// (kept as the least for the rest of the curve) while a step's stage equations do not
    /// converge ([`Self::integrate_on_period_steps`] says why).
    fn with_stage_retries<T>(
        &mut self,
        mut attempt: impl FnMut(&mut Self) -> Result<T, IntegrationError>,
    ) -> Result<T, IntegrationError> {
        for retry in 0.. {
            match attempt(self) {
                Err(IntegrationError::StagesDiverged { .. })
                    if retry < STAGE_RETRIES && self.steps < MAX_STEPS =>
                {
                    self.steps = half_again(self.steps);
                    self.least_steps = self.steps;
                }
                result => return result,
            }
        }
        unreachable!("the loop returns")
    }

    /// `steps` equal steps from `z0` at phase `tau0` over `span`, with the sensitivities
    /// `sensitivities` asks for; with `kept = (every, states)`, the state before every
    /// `every`-th step pushed onto `states` (the start first).
    #[allow(clippy::too_many_arguments)]
    fn integrate(
        &mut self,
        z0: &[f64],
        tau0: f64,
        span: f64,
        steps: usize,
        drive: Drive,
        sensitivities: Sensitivities,
        mut kept: Option<(usize, &mut Vec<Vec<f64>>)>,
    ) -> Result<(ForcedFlow, Option<Vec<RecordedStep>>), IntegrationError> {
        let n = self.system.dofs();
        let n2 = 2 * n;
        check_forced_request(z0, n2, drive)?;
        let s = self.method.c.len();
        let omega = drive.frequency;
        let h = span / steps as f64;
        // `Φ`'s columns (the identity at the start), then `∂z/∂Ω` and `∂z/∂a` (zero).
        let directions = match sensitivities {
            Sensitivities::Full => n2,
            _ => 0,
        };
        let parameters = if sensitivities == Sensitivities::None {
            0
        } else {
            2
        };
        let mut phi = vec![0.0; n2 * (directions + parameters)];
        for c in 0..directions {
            phi[c * n2 + c] = 1.0;
        }
        let mut record = (sensitivities == Sensitivities::Recorded).then(Vec::new);
        let mut stats = IntegrationStats::default();
        let mut z = z0.to_vec();
        let mut ws = std::mem::take(&mut self.ws);
        // A new integration starts its stage iteration afresh (its first iterate from the
        // field, its Jacobian at its own stages): the discrete map must not depend on the
        // integration before.
        ws.w.clear();
        ws.lu = None;
        ws.floor = 0.0;
        ws.split = directions == 0;
        let mut buffers = VariationalBuffers::default();
        let mut result = Ok(());
        // The next state: every entry written each step, the buffer swapped with `z`.
        let mut z1 = vec![0.0; n2];
        for step in 0..steps {
            if let Some((every, states)) = &mut kept
                && step % *every == 0
            {
                states.push(z.clone());
            }
            let tau = tau0 + step as f64 * h;
            let exact = parameters > 0;
            if let Err(e) = self.stages(&z, tau, h, drive, exact, &mut ws, &mut stats) {
                result = Err(e);
                break;
            }
            let (x0, v0) = z.split_at(n);
            for p in 0..n {
                let (mut dv, mut dx) = (0.0, 0.0);
                for j in 0..s {
                    dv += self.method.b[j] * ws.w[j * n + p];
                    dx += self.bta[j] * ws.w[j * n + p];
                }
                z1[n + p] = v0[p] + h * dv;
                z1[p] = x0[p] + h / omega * v0[p] + h * h / omega * dx;
            }
            if exact {
                let (state, parameter) = phi.split_at_mut(n2 * directions);
                self.propagate_parameters(parameter, &z, &z1, tau, h, omega, &mut ws);
                let lu = ws.lu.as_ref().expect("an exact factorisation");
                let tangents = ws.tangents.take().expect("its tangents");
                if directions > 0 {
                    // In time, the direction columns follow the free motion's variational
                    // step with the step `h/Ω` and the damping (eq. (97)).
                    variational_step(
                        self.method,
                        &self.bta,
                        h / omega,
                        (lu, &tangents, 0.0),
                        Some(self.system.damping()),
                        state,
                        directions,
                        &mut buffers,
                    );
                }
                if let Some(record) = &mut record {
                    record.push(RecordedStep {
                        h: h / omega,
                        lu: lu.clone(),
                        tangents,
                    });
                }
            }
            std::mem::swap(&mut z, &mut z1);
            stats.steps += 1;
        }
        // The last stages are not a first iterate for an unrelated integration.
        ws.w.clear();
        ws.lu = None;
        self.ws = ws;
        result?;
        if tau0 == 0.0 && sensitivities != Sensitivities::None {
            self.last_flow = Some(LastFlow {
                z0: z0.to_vec(),
                drive,
                span,
                steps,
                z: z.clone(),
            });
        }
        let flow = ForcedFlow {
            z,
            sensitivity: phi,
            steps: vec![h; steps],
            stats,
        };
        Ok((flow, record))
    }

    /// Advances the parameter sensitivities `[∂z/∂Ω ∂z/∂a]` (`2n × 2`, column-major) over
    /// one step from `z` to `z1` by eq. (97), with the exact Jacobian factorised at the
    /// step's stages.
    #[allow(clippy::too_many_arguments)]
    fn propagate_parameters(
        &self,
        phi: &mut [f64],
        z: &[f64],
        z1: &[f64],
        tau: f64,
        h: f64,
        omega: f64,
        ws: &mut Workspace,
    ) {
        const COLUMNS: usize = 2;
        let n = self.system.dofs();
        let (n2, s) = (2 * n, self.method.c.len());
        let size = s * n;
        let x0 = &z[..n];
        let Workspace {
            lu,
            tangents,
            w,
            x,
            force,
            rhs,
            displacement,
            moved,
            product,
            damped,
            solve,
            ..
        } = ws;
        let tangents = tangents
            .as_ref()
            .expect("the tangents of an exact factorisation at the converged stages");
        rhs.resize(size * COLUMNS, 0.0);
        displacement.resize(n, 0.0);
        product.resize(n, 0.0);
        // `C δv0` of both columns: the same in every stage's equations.
        damped.clear();
        damped.resize(n * COLUMNS, 0.0);
        self.system
            .damping()
            .apply_add(1.0, &phi[n..], n2, COLUMNS, damped, n);
        for i in 0..s {
            let ratio = h * self.method.c[i] / omega;
            for c in 0..COLUMNS {
                // `K_t(X_i)(δx0 + (h c_i/Ω) δv0) + C δv0`.
                let column = &phi[c * n2..(c + 1) * n2];
                for p in 0..n {
                    displacement[p] = column[p] + ratio * column[n + p];
                }
                let block = &mut rhs[c * size + i * n..c * size + (i + 1) * n];
                tangents.apply(i, displacement, block);
                block
                    .iter_mut()
                    .zip(&damped[c * n..(c + 1) * n])
                    .for_each(|(r, d)| *r += d);
            }
            // The parameters' own terms: `M W_i − K_t(X_i)(X_i − x0)/Ω` and `−F(τ_i)`.
            let (w, x) = (&w[i * n..(i + 1) * n], &x[i * n..(i + 1) * n]);
            moved.clear();
            moved.extend((0..n).map(|q| -(x[q] - x0[q]) / omega));
            tangents.apply(i, moved, product);
            let target = &mut rhs[i * n..(i + 1) * n];
            self.mass.apply_add(1.0, w, n, 1, target, n);
            target
                .iter_mut()
                .zip(product.iter())
                .for_each(|(t, p)| *t += p);
            force.fill(0.0);
            self.system
                .force()
                .add_at(tau + self.method.c[i] * h, 1.0, force);
            let target = &mut rhs[size + i * n..size + (i + 1) * n];
            for (t, f) in target.iter_mut().zip(force.iter()) {
                *t -= f;
            }
        }
        rhs.iter_mut().for_each(|e| *e /= -omega);
        let image = StepImage {
            displacement: &self.bta,
            velocity: self.method.b,
            scales: (h * h / omega, h),
            start: phi,
        };
        lu.as_ref()
            .expect("an exact factorisation at the converged stages")
            .solve_exact(
                rhs,
                COLUMNS,
                tangents,
                (PARAMETER_COLUMN_ACCURACY, &image),
                solve,
            );
        for c in 0..COLUMNS {
            let d_omega = if c == 0 { 1.0 } else { 0.0 };
            let dw = &rhs[c * size..(c + 1) * size];
            let column = &mut phi[c * n2..(c + 1) * n2];
            for p in 0..n {
                let (mut dv, mut dx) = (0.0, 0.0);
                for j in 0..s {
                    dv += self.method.b[j] * dw[j * n + p];
                    dx += self.bta[j] * dw[j * n + p];
                }
                let dv0 = column[n + p];
                column[n + p] = dv0 + h * dv;
                column[p] +=
                    h / omega * dv0 + h * h / omega * dx - d_omega * (z1[p] - x0[p]) / omega;
            }
        }
    }

    /// The scaled RMS size of the slow part of `a − b` (module notes): each half filtered
    /// by `(M + K₀/ω_c²)⁻¹M`, in the tolerances' metric.
    fn slow_difference(&self, a: &[f64], b: &[f64], filter: &StageLu) -> f64 {
        let n2 = a.len();
        let n = n2 / 2;
        let d: Vec<f64> = a.iter().zip(b).map(|(a, b)| a - b).collect();
        let mut md = vec![0.0; n2];
        self.mass.apply_add(1.0, &d, n, 2, &mut md, n);
        filter.solve_in_place(&mut md, 2);
        let tol = self.tolerances;
        let sum: f64 = (0..n2)
            .map(|i| {
                let scale = tol.absolute_at(i, n2) + tol.relative * a[i].abs().max(b[i].abs());
                (md[i] / scale).powi(2)
            })
            .sum();
        (sum / n2 as f64).sqrt()
    }
}

impl<S: MechanicalSystem + ?Sized> ForcedIntegrator for ForcedCollocation<'_, '_, S> {
    fn flow(
        &mut self,
        z0: &[f64],
        drive: Drive,
        span: f64,
        sensitivities: bool,
    ) -> Result<ForcedFlow, IntegrationError> {
        let wanted = if sensitivities {
            Sensitivities::Full
        } else {
            Sensitivities::None
        };
        let horizon = (0.0, span, false);
        Ok(self
            .integrate_on_period_steps(z0, horizon, drive, wanted)?
            .0)
    }

    /// Records the steps when the stage system is sparse (a dense one serves small models,
    /// whose monodromy is formed whole).
    fn flow_linearized(
        &mut self,
        z0: &[f64],
        drive: Drive,
        span: f64,
    ) -> Option<Result<RecordedFlow, IntegrationError>> {
        if !matches!(self.stages, Stages::Sparse { .. }) {
            return None;
        }
        let recorded = Sensitivities::Recorded;
        Some(
            self.integrate_on_period_steps(z0, (0.0, span, false), drive, recorded)
                .map(|(flow, record)| {
                    let linearization = CollocationLinearization {
                        method: self.method,
                        bbar: self.bta.clone(),
                        dofs: self.system.dofs(),
                        steps: record.expect("recorded"),
                        damping: Some(Arc::new(self.system.damping().clone())),
                    };
                    (flow, Arc::new(linearization) as Arc<dyn LinearizedFlow>)
                }),
        )
    }

    /// On steps no longer than the period's equal steps.
    fn advance(
        &mut self,
        z0: &[f64],
        tau0: f64,
        span: f64,
        drive: Drive,
    ) -> Result<Vec<f64>, IntegrationError> {
        let horizon = (tau0, span, true);
        let (flow, _) = self.integrate_on_period_steps(z0, horizon, drive, Sensitivities::None)?;
        Ok(flow.z)
    }

    /// In one integration on the period's equal steps, as many to a piece as
    /// [`ForcedIntegrator::advance`] takes: the same discrete motion as piece by piece, but the
    /// stage iteration carries its first iterate and its factorisation from piece to piece
    /// instead of starting each afresh from the field (on the ECL beam's curve, where a piece
    /// is one step, the samples cost half as much).
    fn sample_states(
        &mut self,
        z0: &[f64],
        drive: Drive,
        count: usize,
        pieces: usize,
    ) -> Result<Vec<Vec<f64>>, IntegrationError> {
        let piece = 2.0 * std::f64::consts::PI / count as f64;
        self.with_stage_retries(|this| {
            let every = this.steps.div_ceil(count).max(1);
            let mut states = Vec::with_capacity(pieces);
            let span = piece * pieces as f64;
            let none = Sensitivities::None;
            let kept = Some((every, &mut states));
            this.integrate(z0, 0.0, span, every * pieces, drive, none, kept)?;
            Ok(states)
        })
    }

    /// Sets the steps a period so that the estimated global error of `z(span)` is within the
    /// tolerances (module notes): at most four estimates, each from `N` and `N/2` steps over
    /// the span (`N` the steps a period scaled to it, as the shooting integrates). The fine
    /// flow of the first estimate is the converged point's own when it was the last
    /// integrated ([`Self::last_flow`]). An estimate is reused for the points near the one it
    /// was made at (see [`REUSE`]).
    ///
    /// Why over the span and from the point's flow: half-period shooting (eq. (99b)) needs
    /// its half period accurate, and the estimates over whole periods, both flows integrated,
    /// cost as much as the shooting's own integrations (the ECL beam's curve: 44 estimates, 66
    /// whole periods beside 221 half ones).
    fn adapt(&mut self, z0: &[f64], drive: Drive, span: f64) -> Result<(), IntegrationError> {
        let size = (z0.iter().map(|v| v * v).sum::<f64>() / z0.len().max(1) as f64).sqrt();
        if let Some((frequency, estimated_size, served)) = &mut self.estimate {
            let near = (drive.frequency / *frequency - 1.0).abs() <= REUSE_FREQUENCY
                && size <= REUSE_SIZE * *estimated_size
                && *estimated_size <= REUSE_SIZE * size;
            if near && *served < REUSE {
                *served += 1;
                return Ok(());
            }
        }
        self.estimate = Some((drive.frequency, size, 0));
        let period = 2.0 * std::f64::consts::PI;
        let order = self.method.order as i32;
        let filter = low_pass(
            self.system.system(),
            &self.mass,
            CUTOFF_HARMONICS * drive.frequency,
        )?;
        let last = self.last_flow.take();
        for _ in 0..4 {
            let steps = self.steps.max(2 * MIN_STEPS);
            // The counts the shooting integrates the span on (eq. (99b)), and half as many.
            let fine_steps = ((span / period * steps as f64).round() as usize).max(2);
            let coarse_steps = fine_steps / 2;
            let none = Sensitivities::None;
            let fine = match &last {
                Some(l)
                    if l.z0 == z0
                        && l.drive == drive
                        && l.span == span
                        && l.steps == fine_steps =>
                {
                    Ok(l.z.clone())
                }
                _ => self
                    .integrate(z0, 0.0, span, fine_steps, drive, none, None)
                    .map(|(flow, _)| flow.z),
            };
            let pair = fine.and_then(|fine| {
                Ok((
                    fine,
                    self.integrate(z0, 0.0, span, coarse_steps, drive, none, None)?
                        .0
                        .z,
                ))
            });
            let (fine, coarse) = match pair {
                // Steps too long for the stage iteration are too long for the estimate too.
                Err(IntegrationError::StagesDiverged { .. }) if steps < MAX_STEPS => {
                    self.steps = half_again(steps);
                    continue;
                }
                pair => pair?,
            };
            let ratio = fine_steps as f64 / coarse_steps as f64;
            let error = self.slow_difference(&fine, &coarse, &filter) / (ratio.powi(order) - 1.0);
            // Aim at a third of the tolerance, so that the next points, a little further
            // along the curve, still meet it.
            let wanted = (steps as f64 * (3.0 * error).powf(1.0 / order as f64)).ceil() as usize;
            let wanted = wanted.clamp(MIN_STEPS, MAX_STEPS);
            if error <= 1.0 {
                // Coarsen only by a clear margin: every change alters the discrete map.
                if wanted < steps * 2 / 3 {
                    self.steps = wanted.max(2 * MIN_STEPS).max(self.least_steps);
                }
                return Ok(());
            }
            self.steps = wanted.max(steps + steps / 4);
        }
        Ok(())
    }

    fn tolerances(&self) -> Tolerances {
        self.tolerances
    }

    fn set_tolerances(&mut self, tolerances: Tolerances) {
        self.tolerances = tolerances;
    }

    fn name(&self) -> &'static str {
        self.method.name
    }
}
