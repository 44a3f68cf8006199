//! Shooting for the periodic response to a harmonic force: `H(z0, p) = z(2π; z0, p) − z0 = 0`
//! over the fixed forcing period, continued in `p` = the frequency `Ω` or the force amplitude
//! `a` (docs/method.md eqs. (99)–(101)).
//!
//! The corrector iterates by chords (eq. (99a)): an iterate's residual comes from the motion
//! alone and is linearised by the last exact Jacobian (a converged neighbour's, one step
//! back), and only an iterate whose residual is below the tolerance — or whose chord step
//! did not cut it fourfold — integrates the sensitivities. A point then costs about one integration
//! with `2n + 2` directions instead of one per Newton iteration.
//!
//! The unknowns are scaled so that a whole curve spans a few units: displacements by the
//! largest linear response over the sweep, velocities by that times the sweep's frequency,
//! and the parameter by the sweep's width. The arclength steps are then absolute (the
//! problem's [`ContinuationProblem::amplitude`] is 1): a resonance peak and the flanks of the
//! curve are resolved alike on the plot a user looks at, whatever the units of the model.

use std::sync::Arc;

use super::matrix_free::{ForcedOperator, Subspace};
use crate::continuation::{ContinuationProblem, Detail, Linearization, Solution};
use crate::integrate::IntegrationError;
use crate::integrate::LinearizedFlow;
use crate::integrate::forced::{Drive, ForcedFlow, ForcedIntegrator, sample, sample_half_wave};
use crate::linalg::{self, Complex, Mat};
use crate::model::{ForcedSystem, MechanicalSystem};

/// Matrix-free analyses resolve the Floquet multipliers of at least this modulus (and all of
/// them when none is): the ones that can cross the unit circle between two points.
const MULTIPLIER_FLOOR: f64 = 0.1;

/// What a curve is continued in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sweep {
    /// The forcing frequency `Ω` from `from` to `to` (rad/s) at force amplitude `amplitude`.
    Frequency {
        /// `Ω` where the curve starts.
        from: f64,
        /// `Ω` where it ends.
        to: f64,
        /// The factor `a` on the force shape.
        amplitude: f64,
    },
    /// The force amplitude `a` from `from` to `to` at the fixed frequency `frequency`.
    Amplitude {
        /// `a` where the curve starts.
        from: f64,
        /// `a` where it ends.
        to: f64,
        /// `Ω` (rad/s).
        frequency: f64,
    },
}

impl Sweep {
    /// The drive at parameter value `p`.
    pub fn drive(&self, p: f64) -> Drive {
        match *self {
            Sweep::Frequency { amplitude, .. } => Drive {
                frequency: p,
                amplitude,
            },
            Sweep::Amplitude { frequency, .. } => Drive {
                frequency,
                amplitude: p,
            },
        }
    }

    /// Where the parameter starts and ends.
    pub fn range(&self) -> (f64, f64) {
        match *self {
            Sweep::Frequency { from, to, .. } | Sweep::Amplitude { from, to, .. } => (from, to),
        }
    }
}

/// One evaluation of the forced shooting equations.
#[derive(Debug, Clone)]
pub struct ForcedEvaluation {
    /// `z0`, unscaled.
    pub z0: Vec<f64>,
    /// The drive it was integrated at.
    pub drive: Drive,
    /// The scaled residual `D (z(2π) − z0)`, then the rigid-body offset rows.
    pub rows: Vec<f64>,
    /// `‖D H‖ / ‖D z0‖` (eq. (19)).
    pub relative_residual: f64,
    /// `∂(D H)/∂u` and the offset rows, `(2n + r) × (2n + 1)`.
    pub jacobian: Mat<f64>,
    /// The derivative `P Φ(span)` of the shot map (the monodromy `Φ(2π)` over a whole
    /// period; over half of one, its square root `S Φ(π)`), unscaled (empty on a chord
    /// evaluation).
    pub monodromy: Mat<f64>,
    /// The Jacobian as products (matrix-free shooting, eq. (102a)), in place of `jacobian`
    /// and `monodromy` (then empty).
    pub operator: Option<Arc<ForcedOperator>>,
    /// Whether `jacobian` is the Jacobian at `z0` (else a chord: the last exact one).
    pub exact: bool,
    /// Integration steps of the period.
    pub steps: usize,
}

impl Linearization for ForcedEvaluation {
    fn residual(&self) -> &[f64] {
        &self.rows
    }

    fn relative_residual(&self) -> f64 {
        self.relative_residual
    }

    fn is_exact(&self) -> bool {
        self.exact
    }

    /// The bordered system `[J; bᵀ]` in least squares by QR (square without rigid-body
    /// modes; with them, consistent and overdetermined by one row a mode).
    fn solve_bordered(&self, border: &[f64], rhs: &[f64], border_rhs: f64) -> Vec<f64> {
        match &self.operator {
            Some(operator) => operator.solve_bordered(border, rhs, border_rhs),
            None => {
                crate::continuation::solve_bordered_dense(&self.jacobian, border, rhs, border_rhs)
            }
        }
    }
}

/// A converged point of a forced response curve.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ResponsePoint {
    /// Index along the curve (an event's point carries the index of the point before it).
    pub index: usize,
    /// `Ω` (rad/s).
    pub frequency: f64,
    /// The force amplitude `a`.
    pub force_amplitude: f64,
    /// `z(0) = [x; v]` of the periodic response (the force's phase is 0 at `t = 0`).
    pub z0: Vec<f64>,
    /// `max_t |x_d(t)|` over the period, for each output dof (empty on light trial points).
    pub peaks: Vec<f64>,
    /// First-harmonic amplitude `√(a₁² + b₁²)` of the phase dof (`x ≈ A cos(Ωt − φ)`).
    pub harmonic_amplitude: f64,
    /// Phase lag `φ` of that first harmonic behind `cos Ωt`, radians in `(−π/2, 3π/2]`.
    pub phase_lag: f64,
    /// Floquet multipliers, by decreasing modulus.
    pub multipliers: Vec<Complex>,
    /// The largest `|μ|`.
    pub max_floquet_modulus: f64,
    /// Every `|μ| < 1`.
    pub stable: bool,
    /// The converged relative residual.
    pub relative_residual: f64,
    /// Newton iterations of the corrector.
    pub iterations: usize,
    /// The arclength step that led here.
    pub step: f64,
    /// Integration steps of one period.
    pub integration_steps: usize,
    /// The scaled unknowns `u`.
    pub unknowns: Vec<f64>,
    /// The unit tangent at `u`, oriented along the curve.
    pub tangent: Vec<f64>,
}

impl ResponsePoint {
    /// The number of multipliers outside the unit circle.
    pub fn unstable_multipliers(&self) -> usize {
        self.multipliers
            .iter()
            .filter(|m| m.0.hypot(m.1) > 1.0)
            .count()
    }
}

/// Why a forced evaluation failed or a converged solution makes no point.
#[derive(Debug, thiserror::Error)]
pub enum ForcedError {
    /// The time integration failed.
    #[error(transparent)]
    Integration(#[from] IntegrationError),
    /// The parameter left the values the model can be driven at (`Ω ≤ 0`).
    #[error("the forcing frequency must stay positive, got {}", crate::number::Number(*.0))]
    NonPositiveFrequency(f64),
    /// The eigenvalues of the monodromy could not be computed.
    #[error("Floquet analysis failed: {0}")]
    Floquet(#[from] linalg::LinalgError),
}

/// Work counters of the forced shooting problem.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct ForcedStats {
    /// Evaluations of the shooting equations.
    pub evaluations: usize,
    /// Integrations (with or without sensitivities).
    pub integrations: usize,
    /// Their work, summed.
    pub integration: crate::integrate::IntegrationStats,
    /// Products with the recorded monodromy (matrix-free shooting: GMRES and Arnoldi).
    pub krylov_products: usize,
}

/// The scales of the unknowns (module notes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scales {
    /// Displacements.
    pub displacement: f64,
    /// Velocities.
    pub velocity: f64,
    /// The parameter.
    pub parameter: f64,
}

/// The forced shooting problem of one curve.
pub struct ForcedShooting<'s, 'a, S: MechanicalSystem + ?Sized> {
    system: &'s ForcedSystem<'a, S>,
    integrator: Box<dyn ForcedIntegrator + 's>,
    sweep: Sweep,
    scales: Scales,
    output_dofs: Vec<usize>,
    phase_dof: usize,
    samples: usize,
    /// Rows `wᵀ u_x = c` that hold the rigid-body offsets of the first point (docs/method.md
    /// eq. (100a)): `w = Mφ` of each rigid-body mode `φ`, in scaled coordinates.
    rigid_pins: Vec<(Vec<f64>, f64)>,
    /// Multipliers at +1 that the rigid-body modes bring (one or two a mode).
    neutral_multipliers: usize,
    /// Shoot over half the period, `S z(π) = z0` (eq. (99b)).
    half_period: bool,
    /// `P`, the state map after the horizon, per state coordinate (`2n`): `+1` over a whole
    /// period; over half of one the signs `S` (the velocities' those of their displacements):
    /// `−1` everywhere for an odd system, a parity's (flip the transverse dofs, keep the
    /// in-plane ones) for a von Kármán model.
    flip: Vec<f64>,
    /// The continuation's tolerance: below it, an evaluation is made exact.
    tolerance: f64,
    /// Newton corrections by GMRES and multipliers by Arnoldi on the recorded flow (eq.
    /// (102a)), when the integrator records it.
    matrix_free: bool,
    /// The last exact Jacobian (dense, or its operator), the chord of the corrector
    /// iterations (eq. (99a)).
    chord: Option<(Mat<f64>, Option<Arc<ForcedOperator>>)>,
    /// Products with the recorded monodromy so far, shared with the operators.
    products: Arc<std::sync::atomic::AtomicUsize>,
    /// The last iterate's relative residual (`None` before the first): a chord step that
    /// does not cut it fourfold gets an exact evaluation.
    chord_residual: Option<f64>,
    /// The shot map's Krylov space from the last Floquet analysis, which preconditions the
    /// matrix-free solves after it (eq. (102b)).
    subspace: Option<Arc<Subspace>>,
    /// Work counters so far.
    pub stats: ForcedStats,
}

impl<'s, 'a, S: MechanicalSystem + ?Sized> ForcedShooting<'s, 'a, S> {
    /// The problem of `sweep` integrated by `integrator`; points record the peaks of
    /// `output_dofs` and the first harmonic of `phase_dof`, from `samples` samples a period;
    /// `tolerance` is the continuation's (below it an evaluation is made exact).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        system: &'s ForcedSystem<'a, S>,
        integrator: Box<dyn ForcedIntegrator + 's>,
        sweep: Sweep,
        scales: Scales,
        output_dofs: Vec<usize>,
        phase_dof: usize,
        samples: usize,
        tolerance: f64,
    ) -> Self {
        Self {
            system,
            integrator,
            sweep,
            scales,
            output_dofs,
            phase_dof,
            samples,
            rigid_pins: Vec::new(),
            neutral_multipliers: 0,
            half_period: false,
            flip: vec![1.0; 2 * system.dofs()],
            tolerance,
            matrix_free: false,
            products: Arc::default(),
            chord: None,
            chord_residual: None,
            subspace: None,
            stats: ForcedStats::default(),
        }
    }

    /// Holds the offset along each rigid-body mode (`rigid_modes`, displacement shapes with
    /// `Kφ = 0`) at its value in `u0`. A free structure's periodic responses form a family
    /// of rigid offsets: the periodicity equations leave that direction free (a zero row and
    /// a zero column of `Φ − I` pair up), and the corrector needs one more equation for each.
    pub fn hold_rigid_offsets(&mut self, rigid_modes: &[Vec<f64>], u0: &[f64]) {
        let n = self.system.dofs();
        let mass = self.system.system().mass();
        let damping = self.system.damping();
        let damping_scale = damping.values().iter().fold(0.0f64, |m, v| m.max(v.abs()));
        self.neutral_multipliers = rigid_modes
            .iter()
            .map(|shape| {
                let mut c_shape = vec![0.0; n];
                damping.apply_add(1.0, shape, n, 1, &mut c_shape, n);
                let undamped =
                    linalg::norm(&c_shape) <= 1e-10 * damping_scale * linalg::norm(shape);
                1 + usize::from(undamped)
            })
            .sum();
        self.rigid_pins = rigid_modes
            .iter()
            .map(|shape| {
                let mut w = vec![0.0; n];
                mass.apply(shape, 1, &mut w);
                w.iter_mut().for_each(|v| *v *= self.scales.displacement);
                let norm = linalg::norm(&w);
                w.iter_mut().for_each(|v| *v /= norm);
                let value = linalg::dot(&w, &u0[..n]);
                (w, value)
            })
            .collect();
    }

    /// Shoots over half the forcing period, `S z(π; z0) = z0` (eq. (99b)), `signs` the
    /// diagonal of `S` on the displacements: valid when `S` is a symmetry of the system
    /// (`f_int(S x) = S f_int(x)`, `S M = M S`, `S C = C S`) under which the force is odd,
    /// `S F = −F` (as `F(τ + π) = −F(τ)`), and the response is half-wave symmetric; halves
    /// every integration. `None`: whole periods.
    pub fn with_half_period(mut self, signs: Option<Vec<f64>>) -> Self {
        let n = self.system.dofs();
        if let Some(signs) = &signs {
            assert_eq!(signs.len(), n, "one sign a displacement");
        }
        self.half_period = signs.is_some();
        // On the state: the velocities take their displacements' signs.
        self.flip = match signs {
            Some(s) => s.iter().chain(&s).copied().collect(),
            None => vec![1.0; 2 * n],
        };
        self
    }

    /// Solves the corrections by GMRES and takes the multipliers by Arnoldi on the recorded
    /// flow (eq. (102a)) when the integrator records it and no rigid-body offset is held
    /// (those rows make the system non-square); dense otherwise.
    pub fn with_matrix_free(mut self, matrix_free: bool) -> Self {
        self.matrix_free = matrix_free;
        self
    }

    /// Whether the corrections are matrix-free (see [`Self::with_matrix_free`]).
    pub fn matrix_free(&self) -> bool {
        self.matrix_free && self.rigid_pins.is_empty()
    }

    /// The work so far, the matrix-free products included.
    pub fn work(&self) -> ForcedStats {
        ForcedStats {
            krylov_products: self.products.load(std::sync::atomic::Ordering::Relaxed),
            ..self.stats
        }
    }

    /// Whether it shoots over half the period.
    pub fn half_period(&self) -> bool {
        self.half_period
    }

    /// The sweep.
    pub fn sweep(&self) -> Sweep {
        self.sweep
    }

    /// The scales of the unknowns.
    pub fn scales(&self) -> Scales {
        self.scales
    }

    /// The integrator's name.
    pub fn integrator_name(&self) -> &'static str {
        self.integrator.name()
    }

    fn scale_of(&self, i: usize) -> f64 {
        if i < self.system.dofs() {
            self.scales.displacement
        } else {
            self.scales.velocity
        }
    }

    /// The scaled unknowns of the state `z0` at parameter `p`.
    pub fn unknowns(&self, z0: &[f64], p: f64) -> Vec<f64> {
        z0.iter()
            .enumerate()
            .map(|(i, z)| z / self.scale_of(i))
            .chain(std::iter::once(p / self.scales.parameter))
            .collect()
    }

    /// The state and parameter of scaled unknowns `u`.
    pub fn state(&self, u: &[f64]) -> (Vec<f64>, f64) {
        let n2 = u.len() - 1;
        let z0 = (0..n2).map(|i| u[i] * self.scale_of(i)).collect();
        (z0, u[n2] * self.scales.parameter)
    }

    /// Prepares the integrator for the motion from `z0` at parameter `p` (the step count of
    /// an equal-step method, between points).
    pub fn adapt(&mut self, z0: &[f64], p: f64) -> Result<(), ForcedError> {
        let span = self.span();
        self.integrator.adapt(z0, self.sweep.drive(p), span)?;
        Ok(())
    }

    /// Peaks of the output dofs and the phase dof's first harmonic, from samples of the
    /// motion refined at the peaks (analysis/peak.rs, docs/method.md eq. (87)).
    fn motion_summary(
        &mut self,
        z0: &[f64],
        drive: Drive,
    ) -> Result<(Vec<f64>, f64, f64), ForcedError> {
        let n = self.system.dofs();
        let count = self.samples;
        // A half-wave symmetric motion's second half is the first's image `S z`: not
        // integrated.
        let states = if self.half_period && count % 2 == 0 {
            sample_half_wave(self.integrator.as_mut(), z0, drive, count, &self.flip)?
        } else {
            sample(self.integrator.as_mut(), z0, drive, count)?
        };
        self.stats.integrations += 1;
        let dt = 2.0 * std::f64::consts::PI / (count as f64 * drive.frequency);
        let mut peaks = Vec::with_capacity(self.output_dofs.len());
        for &d in &self.output_dofs {
            let x: Vec<f64> = states.iter().map(|z| z[d]).collect();
            let v: Vec<f64> = states.iter().map(|z| z[n + d]).collect();
            let mut peak = x.iter().fold(0.0f64, |m, a| m.max(a.abs()));
            for (j, delay) in crate::analysis::peak_candidates(&x, &v, dt) {
                let tau = j as f64 * 2.0 * std::f64::consts::PI / count as f64;
                // A peak on a sample (a response in exact quadrature peaks at T/4, sample
                // N/4) leaves a delay of round-off: integrating that would hand the next
                // integration a first step of ~1e-17 of the period, which underflows.
                let z = if delay > 1e-12 * dt {
                    self.integrator
                        .advance(&states[j], tau, delay * drive.frequency, drive)?
                } else {
                    states[j].clone()
                };
                let mut rate = vec![0.0; 2 * n];
                crate::integrate::forced::phase_field(
                    self.system,
                    &z,
                    tau + delay * drive.frequency,
                    drive,
                    &mut rate,
                );
                let acceleration = rate[n + d] * drive.frequency;
                peak = peak.max(crate::analysis::local_peak(z[d], z[n + d], acceleration));
            }
            peaks.push(peak);
        }
        let (mut a1, mut b1) = (0.0, 0.0);
        for (k, z) in states.iter().enumerate() {
            let tau = k as f64 * 2.0 * std::f64::consts::PI / count as f64;
            a1 += z[self.phase_dof] * tau.cos();
            b1 += z[self.phase_dof] * tau.sin();
        }
        let (a1, b1) = (2.0 * a1 / count as f64, 2.0 * b1 / count as f64);
        let mut lag = b1.atan2(a1);
        if lag <= -std::f64::consts::FRAC_PI_2 {
            lag += 2.0 * std::f64::consts::PI;
        }
        Ok((peaks, a1.hypot(b1), lag))
    }
}

impl<S: MechanicalSystem + ?Sized> ForcedShooting<'_, '_, S> {
    /// The horizon shot: the forcing period, or half of it (eq. (99b)).
    fn span(&self) -> f64 {
        if self.half_period {
            std::f64::consts::PI
        } else {
            2.0 * std::f64::consts::PI
        }
    }

    /// `D (P z(span) − z0)` and the rigid-body offset rows.
    fn residual_rows(&self, u: &[f64], z0: &[f64], end: &[f64]) -> Vec<f64> {
        let n = self.system.dofs();
        let flip = &self.flip;
        (0..2 * n)
            .map(|i| (flip[i] * end[i] - z0[i]) / self.scale_of(i))
            .chain(
                self.rigid_pins
                    .iter()
                    .map(|(w, value)| linalg::dot(w, &u[..n]) - value),
            )
            .collect()
    }

    /// The residual rows of `flow` from `z0` at `u` and their relative size, the integration
    /// counted (and the evaluation, when `exact`: one with sensitivities).
    fn residual_of(
        &mut self,
        u: &[f64],
        z0: &[f64],
        flow: &ForcedFlow,
        exact: bool,
    ) -> (Vec<f64>, f64) {
        self.stats.evaluations += usize::from(exact);
        self.stats.integrations += 1;
        self.stats.integration += flow.stats;
        let rows = self.residual_rows(u, z0, &flow.z);
        let relative_residual = self.relative(u, &rows);
        (rows, relative_residual)
    }

    /// `‖rows‖ / ‖D z0‖` (eq. (19)).
    fn relative(&self, u: &[f64], rows: &[f64]) -> f64 {
        let n2 = 2 * self.system.dofs();
        linalg::norm(rows) / linalg::norm(&u[..n2]).max(f64::MIN_POSITIVE)
    }

    /// The evaluation with the sensitivities: the exact Jacobian and the monodromy, kept as
    /// the chord of the next corrector iterations.
    fn exact_evaluation(&mut self, u: &[f64]) -> Result<ForcedEvaluation, ForcedError> {
        let n2 = 2 * self.system.dofs();
        let n = n2 / 2;
        let (z0, p) = self.state(u);
        let drive = self.sweep.drive(p);
        // The last chord is replaced below: released first, so that two recorded flows (or
        // two dense Jacobians) are not held at once — on the 1,000-element von Kármán beam a
        // recorded flow is ~0.4 GB.
        self.chord = None;
        if self.matrix_free() {
            let span = self.span();
            if let Some(linearized) = self.integrator.flow_linearized(&z0, drive, span) {
                let (flow, linearization) = linearized?;
                return Ok(self.matrix_free_evaluation(u, z0, drive, flow, linearization));
            }
        }
        let flow = self.integrator.flow(&z0, drive, self.span(), true)?;
        let (rows, relative_residual) = self.residual_of(u, &z0, &flow, true);
        let flip = &self.flip;
        let phi = |i: usize, j: usize| flip[i] * flow.sensitivity[j * n2 + i];
        let parameter_column = match self.sweep {
            Sweep::Frequency { .. } => n2,
            Sweep::Amplitude { .. } => n2 + 1,
        };
        let jacobian = Mat::from_fn(rows.len(), n2 + 1, |i, j| {
            if i >= n2 {
                let w = &self.rigid_pins[i - n2].0;
                if j < n { w[j] } else { 0.0 }
            } else if j == n2 {
                phi(i, parameter_column) * self.scales.parameter / self.scale_of(i)
            } else {
                let identity = if i == j { 1.0 } else { 0.0 };
                (phi(i, j) - identity) * self.scale_of(j) / self.scale_of(i)
            }
        });
        self.chord = Some((jacobian.clone(), None));
        self.chord_residual = Some(relative_residual);
        Ok(ForcedEvaluation {
            z0,
            drive,
            rows,
            relative_residual,
            jacobian,
            monodromy: Mat::from_fn(n2, n2, phi),
            operator: None,
            exact: true,
            steps: flow.steps.len(),
        })
    }

    /// The exact evaluation of matrix-free shooting: the residual and the parameter's
    /// column from an integration that records its linearised flow, the Jacobian as its
    /// products (eq. (102a)).
    fn matrix_free_evaluation(
        &mut self,
        u: &[f64],
        z0: Vec<f64>,
        drive: Drive,
        flow: ForcedFlow,
        linearization: Arc<dyn LinearizedFlow>,
    ) -> ForcedEvaluation {
        let n2 = 2 * self.system.dofs();
        let (rows, relative_residual) = self.residual_of(u, &z0, &flow, true);
        let flip = &self.flip;
        // `flow.sensitivity` holds `[∂z/∂Ω ∂z/∂a]`.
        let parameter = match self.sweep {
            Sweep::Frequency { .. } => 0,
            Sweep::Amplitude { .. } => 1,
        };
        let scales: Vec<f64> = (0..n2).map(|i| self.scale_of(i)).collect();
        let parameter_column = (0..n2)
            .map(|i| {
                flip[i] * flow.sensitivity[parameter * n2 + i] * self.scales.parameter / scales[i]
            })
            .collect();
        let size = linalg::norm(&u[..n2]);
        let operator = Arc::new(
            ForcedOperator::new(
                linearization,
                flip.clone(),
                scales,
                parameter_column,
                self.tolerance,
                size,
                self.products.clone(),
            )
            .preconditioned_by(self.subspace.clone()),
        );
        self.chord = Some((Mat::zeros(0, 0), Some(operator.clone())));
        self.chord_residual = Some(relative_residual);
        ForcedEvaluation {
            z0,
            drive,
            rows,
            relative_residual,
            jacobian: Mat::zeros(0, 0),
            monodromy: Mat::zeros(0, 0),
            operator: Some(operator),
            exact: true,
            steps: flow.steps.len(),
        }
    }
}

impl<S: MechanicalSystem + ?Sized> ContinuationProblem for ForcedShooting<'_, '_, S> {
    type Evaluation = ForcedEvaluation;
    type Point = ResponsePoint;
    type Error = ForcedError;

    fn dimension(&self) -> usize {
        2 * self.system.dofs() + 1
    }

    /// A chord step where it can (module notes, eq. (99a)): the residual from the motion
    /// alone, linearised by the last exact Jacobian, until the residual is below the
    /// tolerance or a chord step fails to halve it; there the evaluation is made exact — the
    /// converged point's tangent, multipliers and events read it.
    // Negated comparison deliberate: a NaN frequency must fail.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    fn evaluate(&mut self, u: &[f64]) -> Result<ForcedEvaluation, ForcedError> {
        let (z0, p) = self.state(u);
        let drive = self.sweep.drive(p);
        if !(drive.frequency > 0.0) {
            return Err(ForcedError::NonPositiveFrequency(drive.frequency));
        }
        // Matrix-free, the exact Jacobian costs an integration that records its steps, about
        // what a chord's motion costs: Newton's iterations then beat the chord's.
        let Some(chord) = self.chord.clone().filter(|_| !self.matrix_free()) else {
            return self.exact_evaluation(u);
        };
        let flow = self.integrator.flow(&z0, drive, self.span(), false)?;
        let (rows, relative_residual) = self.residual_of(u, &z0, &flow, false);
        // A chord step must cut the residual fourfold, or the iterate gets the exact
        // Jacobian; the first iterate of a new solve (after a converged point) always chords.
        let stalled = self.chord_residual.is_some_and(|previous| {
            previous >= self.tolerance && relative_residual > 0.25 * previous
        });
        if relative_residual < self.tolerance || stalled {
            return self.exact_evaluation(u);
        }
        self.chord_residual = Some(relative_residual);
        let (jacobian, operator) = chord;
        Ok(ForcedEvaluation {
            z0,
            drive,
            rows,
            relative_residual,
            jacobian,
            monodromy: Mat::zeros(0, 0),
            operator,
            exact: false,
            steps: flow.steps.len(),
        })
    }

    /// The multipliers always (event location needs them), the peaks and first harmonic
    /// with [`Detail::Full`].
    fn point(
        &mut self,
        solution: &Solution,
        evaluation: &ForcedEvaluation,
        detail: Detail,
    ) -> Result<ResponsePoint, ForcedError> {
        let mut multipliers = match &evaluation.operator {
            Some(operator) => {
                // Multipliers below a tenth in modulus take part in no crossing of the unit
                // circle; over half a period the shot map's eigenvalues are their roots.
                let floor = if self.half_period {
                    MULTIPLIER_FLOOR.sqrt()
                } else {
                    MULTIPLIER_FLOOR
                };
                let (multipliers, subspace) = operator.shot_map_eigenvalues(floor)?;
                self.subspace = subspace.map(Arc::new);
                multipliers
            }
            None => linalg::eigenvalues(evaluation.monodromy.as_ref())?,
        };
        if self.half_period {
            // The monodromy is the half map's derivative squared (eq. (99b)).
            multipliers = multipliers
                .iter()
                .map(|&(re, im)| (re * re - im * im, 2.0 * re * im))
                .collect();
        }
        // The rigid-body modes' multipliers sit at +1 (an offset, and a momentum when the
        // damping leaves the mode free): neutral directions the offset rows hold, not a
        // stability property. Left out, as the trivial pair of a free motion is.
        let distance = |m: &Complex| (m.0 - 1.0).hypot(m.1);
        multipliers.sort_by(|a, b| distance(a).total_cmp(&distance(b)));
        multipliers.drain(..self.neutral_multipliers.min(multipliers.len()));
        let modulus = |m: &Complex| m.0.hypot(m.1);
        multipliers.sort_by(|a, b| modulus(b).total_cmp(&modulus(a)));
        let max_floquet_modulus = multipliers.first().map_or(0.0, modulus);
        let (peaks, harmonic_amplitude, phase_lag) = match detail {
            Detail::Full => self.motion_summary(&evaluation.z0, evaluation.drive)?,
            Detail::Light => (Vec::new(), f64::NAN, f64::NAN),
        };
        Ok(ResponsePoint {
            index: solution.index,
            frequency: evaluation.drive.frequency,
            force_amplitude: evaluation.drive.amplitude,
            z0: evaluation.z0.clone(),
            peaks,
            harmonic_amplitude,
            phase_lag,
            stable: max_floquet_modulus < 1.0,
            max_floquet_modulus,
            multipliers,
            relative_residual: evaluation.relative_residual,
            iterations: solution.iterations,
            step: solution.step,
            integration_steps: evaluation.steps,
            unknowns: solution.u.clone(),
            tangent: solution.tangent.clone(),
        })
    }

    /// Steps are absolute in the scaled unknowns (module notes).
    fn amplitude(&self, _u: &[f64]) -> f64 {
        1.0
    }

    /// A forced curve is smooth between its folds, and the second-order predictor lets its
    /// steps grow: the ECL beam's resonance curve took 52 points instead of 82, 0.38 against
    /// 0.60 s (docs/performance.md).
    fn second_order_predictor(&self) -> bool {
        true
    }
}
