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
//! Newton with the exact Jacobian `∂R_i/∂W_j = Ω M δ_ij + h a_ij C + (h²/Ω) ā_ij K_t(X_i)`.
//! The sensitivities of the step follow from the same factorised Jacobian:
//! `J δW = −[δΩ M W_i + C δv0 + K_t(X_i)(δx0 + (h c_i/Ω) δv0 − δΩ (X_i − x0)/Ω) − δa F(τ_i)]`,
//! then `δv1 = δv0 + h Σ b_j δW_j`, `δx1 = δx0 + (h/Ω) δv0 + (h²/Ω) Σ (bᵀA)_j δW_j −
//! δΩ (x1 − x0)/Ω`.
//!
//! The steps are equal, `N` a period, set by [`ForcedIntegrator::adapt`] from the difference
//! of the flows with `N` and `N/2` steps (global error `≈ ‖z_N − z_{N/2}‖/(2^p − 1)`, `p` the
//! end-point order), between points and never within a Newton solve. The stage system is
//! dense (`s·n` square): this integrator serves models of up to a few hundred dofs.

use super::{Drive, ForcedFlow, ForcedIntegrator, check_forced_request, phase_field};
use crate::integrate::collocation::Collocation;
use crate::integrate::{IntegrationError, IntegrationStats, Tolerances};
use crate::linalg::{DenseLu, Mat};
use crate::model::{Block, BlockMut, ForcedSystem, MechanicalSystem, dense_mass_matrix};

/// Newton iterations allowed for one step's stage equations.
const MAX_STAGE_ITERATIONS: usize = 12;
/// The stage iteration stops when the update is this small relative to the stage values.
const STAGE_TOLERANCE: f64 = 1e-13;
/// Steps a period before the first estimate, and the bounds of the estimate.
const INITIAL_STEPS: usize = 64;
const MIN_STEPS: usize = 8;
const MAX_STEPS: usize = 200_000;

/// Implicit collocation of a forced system with equal steps.
pub struct ForcedCollocation<'s, 'a, S: MechanicalSystem + ?Sized> {
    system: &'s ForcedSystem<'a, S>,
    method: &'static Collocation,
    /// Error tolerances of the global error estimate of [`ForcedIntegrator::adapt`].
    pub tolerances: Tolerances,
    /// Equal steps a period.
    steps: usize,
    mass: Mat<f64>,
    damping: Mat<f64>,
    /// `Ā = A²`, row-major `s × s`.
    abar: Vec<f64>,
    /// `bᵀA`.
    bta: Vec<f64>,
}

/// One step's converged stages.
struct StepStages {
    /// `W`, `s × n`.
    w: Vec<f64>,
    /// `X_i`, `s × n`.
    x: Vec<f64>,
    /// The factorised stage Jacobian at the last iterate.
    jacobian: DenseLu,
    /// `K_t(X_i)`, each `n × n`.
    tangents: Vec<Mat<f64>>,
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
        let a = |i: usize, j: usize| method.a[i][j];
        let abar = (0..s * s)
            .map(|k| (0..s).map(|l| a(k / s, l) * a(l, k % s)).sum())
            .collect();
        let bta = (0..s)
            .map(|j| (0..s).map(|l| method.b[l] * a(l, j)).sum())
            .collect();
        Self {
            system,
            method,
            tolerances,
            steps: INITIAL_STEPS,
            mass: dense_mass_matrix(system.system().mass()),
            damping: crate::model::Matrix::Sparse(system.damping().clone()).to_dense(),
            abar,
            bta,
        }
    }

    /// Equal steps a period in force.
    pub fn steps(&self) -> usize {
        self.steps
    }

    fn tangent(&self, x: &[f64]) -> Mat<f64> {
        let n = x.len();
        let identity = Mat::<f64>::identity(n, n);
        let mut columns = vec![0.0; n * n];
        let unit: Vec<f64> = (0..n * n).map(|k| identity[(k % n, k / n)]).collect();
        self.system.system().tangent_stiffness(
            x,
            Block::new(&unit, n, n, n),
            BlockMut::new(&mut columns, n, n, n),
        );
        Mat::from_fn(n, n, |i, j| columns[j * n + i])
    }

    /// Solves one step's stage equations from `z` at phase `tau` with step `h`.
    fn stages(
        &self,
        z: &[f64],
        tau: f64,
        h: f64,
        drive: Drive,
        stats: &mut IntegrationStats,
    ) -> Result<StepStages, IntegrationError> {
        let n = self.system.dofs();
        let s = self.method.c.len();
        let (x0, v0) = z.split_at(n);
        let omega = drive.frequency;
        let mut start = vec![0.0; 2 * n];
        phase_field(self.system, z, tau, drive, &mut start);
        stats.rhs_evaluations += 1;
        let mut w: Vec<f64> = (0..s).flat_map(|_| start[n..].iter().copied()).collect();
        let mut x = vec![0.0; s * n];
        let mut v = vec![0.0; s * n];
        let mut residual = vec![0.0; s * n];
        let mut force = vec![0.0; n];
        let mut previous_update = f64::INFINITY;
        for _ in 0..MAX_STAGE_ITERATIONS {
            self.stage_states(x0, v0, &w, h, omega, &mut x, &mut v);
            let tangents: Vec<Mat<f64>> = (0..s)
                .map(|i| self.tangent(&x[i * n..(i + 1) * n]))
                .collect();
            stats.tangent_evaluations += s;
            for i in 0..s {
                let r = &mut residual[i * n..(i + 1) * n];
                self.system
                    .system()
                    .internal_force(&x[i * n..(i + 1) * n], r);
                force.fill(0.0);
                self.system
                    .force()
                    .add_at(tau + self.method.c[i] * h, drive.amplitude, &mut force);
                for p in 0..n {
                    let mut sum = r[p] - force[p];
                    for q in 0..n {
                        sum += omega * self.mass[(p, q)] * w[i * n + q]
                            + self.damping[(p, q)] * v[i * n + q];
                    }
                    r[p] = -sum;
                }
            }
            stats.rhs_evaluations += s;
            let jacobian = DenseLu::new(self.stage_jacobian(&tangents, h, omega).as_ref());
            stats.factorisations += 1;
            jacobian.solve_in_place(&mut residual, 1);
            let (mut update, mut size) = (0.0f64, 0.0f64);
            for (wi, d) in w.iter_mut().zip(&residual) {
                *wi += d;
                update = update.max(d.abs());
                size = size.max(wi.abs());
            }
            if !update.is_finite() {
                return Err(IntegrationError::NotFinite { t: tau / omega });
            }
            // Converged: the update is below the tolerance, or it stopped shrinking at a
            // small size — the round-off floor of a stiff stage system lies above
            // `STAGE_TOLERANCE` (1e-8 of the largest stage value on the 19-element ECL beam,
            // in the stiff modes' components, which the step scales down by `h²/Ω`).
            let stalled = update > 0.25 * previous_update && update <= 1e-6 * size;
            previous_update = update;
            if update <= STAGE_TOLERANCE * size || size == 0.0 || stalled {
                self.stage_states(x0, v0, &w, h, omega, &mut x, &mut v);
                return Ok(StepStages {
                    w,
                    x,
                    jacobian,
                    tangents,
                });
            }
        }
        Err(IntegrationError::InvalidInput(format!(
            "the stage equations did not converge at t = {:.6e}; tighten the tolerance or \
             choose another integrator",
            tau / omega
        )))
    }

    /// `V_i`, `X_i` of the module notes.
    #[allow(clippy::too_many_arguments)]
    fn stage_states(
        &self,
        x0: &[f64],
        v0: &[f64],
        w: &[f64],
        h: f64,
        omega: f64,
        x: &mut [f64],
        v: &mut [f64],
    ) {
        let n = x0.len();
        let s = self.method.c.len();
        for i in 0..s {
            let (xi, vi) = (&mut x[i * n..(i + 1) * n], &mut v[i * n..(i + 1) * n]);
            for p in 0..n {
                let (mut dv, mut dx) = (0.0, 0.0);
                for j in 0..s {
                    dv += self.method.a[i][j] * w[j * n + p];
                    dx += self.abar[i * s + j] * w[j * n + p];
                }
                vi[p] = v0[p] + h * dv;
                xi[p] = x0[p] + h * self.method.c[i] / omega * v0[p] + h * h / omega * dx;
            }
        }
    }

    fn stage_jacobian(&self, tangents: &[Mat<f64>], h: f64, omega: f64) -> Mat<f64> {
        let n = self.system.dofs();
        let s = self.method.c.len();
        Mat::from_fn(s * n, s * n, |r, c| {
            let (i, p, j, q) = (r / n, r % n, c / n, c % n);
            let mut value = h * self.method.a[i][j] * self.damping[(p, q)]
                + h * h / omega * self.abar[i * s + j] * tangents[i][(p, q)];
            if i == j {
                value += omega * self.mass[(p, q)];
            }
            value
        })
    }

    /// `steps` equal steps from `z0` at phase `tau0` over `span`, with the sensitivities
    /// `[Φ ∂z/∂Ω ∂z/∂a]` when asked.
    fn integrate(
        &self,
        z0: &[f64],
        tau0: f64,
        span: f64,
        steps: usize,
        drive: Drive,
        sensitivities: bool,
    ) -> Result<ForcedFlow, IntegrationError> {
        let n = self.system.dofs();
        let n2 = 2 * n;
        check_forced_request(z0, n2, drive)?;
        let s = self.method.c.len();
        let omega = drive.frequency;
        let h = span / steps as f64;
        let cols = if sensitivities { n2 + 2 } else { 0 };
        let mut phi = vec![0.0; n2 * cols];
        for c in 0..cols.min(n2) {
            phi[c * n2 + c] = 1.0;
        }
        let mut stats = IntegrationStats::default();
        let mut z = z0.to_vec();
        let mut rhs = vec![0.0; s * n * cols];
        let mut force = vec![0.0; n];
        for step in 0..steps {
            let tau = tau0 + step as f64 * h;
            let stages = self.stages(&z, tau, h, drive, &mut stats)?;
            let (x0, v0) = z.split_at(n);
            let mut z1 = vec![0.0; n2];
            for p in 0..n {
                let (mut dv, mut dx) = (0.0, 0.0);
                for j in 0..s {
                    dv += self.method.b[j] * stages.w[j * n + p];
                    dx += self.bta[j] * stages.w[j * n + p];
                }
                z1[n + p] = v0[p] + h * dv;
                z1[p] = x0[p] + h / omega * v0[p] + h * h / omega * dx;
            }
            if cols > 0 {
                for c in 0..cols {
                    let (dx0, dv0) = phi[c * n2..(c + 1) * n2].split_at(n);
                    let d_omega = if c == n2 { 1.0 } else { 0.0 };
                    let d_amplitude = if c == n2 + 1 { 1.0 } else { 0.0 };
                    for i in 0..s {
                        force.fill(0.0);
                        if d_amplitude != 0.0 {
                            self.system
                                .force()
                                .add_at(tau + self.method.c[i] * h, 1.0, &mut force);
                        }
                        let xi = &stages.x[i * n..(i + 1) * n];
                        let displacement: Vec<f64> = (0..n)
                            .map(|q| {
                                dx0[q] + h * self.method.c[i] / omega * dv0[q]
                                    - d_omega * (xi[q] - x0[q]) / omega
                            })
                            .collect();
                        let b = &mut rhs[c * s * n + i * n..c * s * n + (i + 1) * n];
                        for p in 0..n {
                            let mut sum = -d_amplitude * force[p];
                            for q in 0..n {
                                sum += d_omega * self.mass[(p, q)] * stages.w[i * n + q]
                                    + self.damping[(p, q)] * dv0[q]
                                    + stages.tangents[i][(p, q)] * displacement[q];
                            }
                            b[p] = -sum;
                        }
                    }
                }
                stages.jacobian.solve_in_place(&mut rhs, cols);
                for c in 0..cols {
                    let d_omega = if c == n2 { 1.0 } else { 0.0 };
                    let dw = &rhs[c * s * n..(c + 1) * s * n];
                    let column = &mut phi[c * n2..(c + 1) * n2];
                    for p in 0..n {
                        let (mut dv, mut dx) = (0.0, 0.0);
                        for j in 0..s {
                            dv += self.method.b[j] * dw[j * n + p];
                            dx += self.bta[j] * dw[j * n + p];
                        }
                        let dv0 = column[n + p];
                        column[n + p] = dv0 + h * dv;
                        column[p] += h / omega * dv0 + h * h / omega * dx
                            - d_omega * (z1[p] - x0[p]) / omega;
                    }
                }
            }
            z = z1;
            stats.steps += 1;
        }
        Ok(ForcedFlow {
            z,
            sensitivity: phi,
            steps: vec![h; steps],
            stats,
        })
    }

    /// The scaled RMS difference of two end states (the tolerances' metric).
    fn scaled_difference(&self, a: &[f64], b: &[f64]) -> f64 {
        let n2 = a.len();
        let tol = self.tolerances;
        let sum: f64 = (0..n2)
            .map(|i| {
                let scale = tol.absolute_at(i, n2) + tol.relative * a[i].abs().max(b[i].abs());
                ((a[i] - b[i]) / scale).powi(2)
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
        sensitivities: bool,
    ) -> Result<ForcedFlow, IntegrationError> {
        let period = 2.0 * std::f64::consts::PI;
        self.integrate(z0, 0.0, period, self.steps, drive, sensitivities)
    }

    /// On steps no longer than the period's equal steps.
    fn advance(
        &mut self,
        z0: &[f64],
        tau0: f64,
        span: f64,
        drive: Drive,
    ) -> Result<Vec<f64>, IntegrationError> {
        let period = 2.0 * std::f64::consts::PI;
        let steps = ((span / period * self.steps as f64).ceil() as usize).max(1);
        Ok(self.integrate(z0, tau0, span, steps, drive, false)?.z)
    }

    /// Sets the steps a period so that the estimated global error of `z(2π)` is within the
    /// tolerances (module notes): at most four estimates, each from `N` and `N/2` steps.
    fn adapt(&mut self, z0: &[f64], drive: Drive) -> Result<(), IntegrationError> {
        let period = 2.0 * std::f64::consts::PI;
        let order = self.method.order as i32;
        for _ in 0..4 {
            let steps = self.steps.max(2 * MIN_STEPS);
            let fine = self.integrate(z0, 0.0, period, steps, drive, false)?;
            let coarse = self.integrate(z0, 0.0, period, steps / 2, drive, false)?;
            let error = self.scaled_difference(&fine.z, &coarse.z) / (2f64.powi(order) - 1.0);
            // Aim at a third of the tolerance, so that the next points, a little further
            // along the curve, still meet it.
            let wanted = (steps as f64 * (3.0 * error).powf(1.0 / order as f64)).ceil() as usize;
            let wanted = wanted.clamp(MIN_STEPS, MAX_STEPS);
            if error <= 1.0 {
                // Coarsen only by a clear margin: every change alters the discrete map.
                if wanted < steps * 2 / 3 {
                    self.steps = wanted.max(2 * MIN_STEPS);
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
