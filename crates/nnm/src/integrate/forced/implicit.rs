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
//! end-point order), between points and never within a Newton solve. The estimate is made on the
//! motion's slow part, as for free motions (eq. (32d)): the difference is filtered by
//! `(M + K₀/ω_c²)⁻¹M`, `ω_c` sixteen times the forcing frequency, since the quasi-static
//! response of the stiff modes converges at Radau IIA's stage order only, and its error is
//! damped out within a period (`R(∞) = 0`) instead of accumulating.
//!
//! The stage iteration is a simplified Newton iteration on the last factorised Jacobian
//! (from the step before: equal steps, slowly varying tangents), refactorised when it stops
//! contracting; an integration with sensitivities factorises the exact Jacobian at every
//! converged step, which its sensitivities need and the next step's iteration reuses. The
//! stage system is dense (`s·n` square): this integrator serves models of up to a few hundred
//! dofs.

use super::{Drive, ForcedFlow, ForcedIntegrator, check_forced_request, phase_field};
use crate::integrate::collocation::Collocation;
use crate::integrate::{IntegrationError, IntegrationStats, Tolerances};
use crate::linalg::{self, DenseLu, Mat};
use crate::model::{ForcedSystem, Matrix, MechanicalSystem, dense_mass_matrix, dense_tangent};

/// Newton iterations allowed for one step's stage equations.
const MAX_STAGE_ITERATIONS: usize = 20;
/// The stage iteration stops when the update is this small relative to the stage values.
const STAGE_TOLERANCE: f64 = 1e-13;
/// Steps a period before the first estimate, and the bounds of the estimate.
const INITIAL_STEPS: usize = 64;
const MIN_STEPS: usize = 8;
const MAX_STEPS: usize = 200_000;
/// The step count controls the error of the motion below this many harmonics of the force
/// (the low-pass filter of the module notes).
const CUTOFF_HARMONICS: f64 = 16.0;

/// Implicit collocation of a forced system with equal steps.
pub struct ForcedCollocation<'s, 'a, S: MechanicalSystem + ?Sized> {
    system: &'s ForcedSystem<'a, S>,
    method: &'static Collocation,
    /// Error tolerances of the global error estimate of [`ForcedIntegrator::adapt`].
    pub tolerances: Tolerances,
    /// Equal steps a period.
    steps: usize,
    /// `M`, `C`, column-major `n × n`.
    mass: Vec<f64>,
    damping: Vec<f64>,
    /// `Ā = A²`, row-major `s × s`.
    abar: Vec<f64>,
    /// `bᵀA`.
    bta: Vec<f64>,
    ws: Workspace,
}

/// What one step leaves for the next, and the step's scratch.
#[derive(Default)]
struct Workspace {
    /// The factorised stage Jacobian the iteration uses, and whether it is exact at the
    /// current stages (made this step at the converged stages).
    lu: Option<DenseLu>,
    /// `W`, `s × n`, of the last step (the next step's first iterate).
    w: Vec<f64>,
    x: Vec<f64>,
    v: Vec<f64>,
    residual: Vec<f64>,
    /// `K_t(X_i)`, `s` column-major `n × n` blocks.
    tangents: Vec<f64>,
    jacobian: Vec<f64>,
    force: Vec<f64>,
    values: Vec<f64>,
    rhs: Vec<f64>,
    displacement: Vec<f64>,
    /// `−(X_i − x0)/Ω` of one stage.
    moved: Vec<f64>,
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
        let column_major = |m: Mat<f64>| {
            let n = m.nrows();
            (0..n * n).map(|k| m[(k % n, k / n)]).collect()
        };
        Self {
            system,
            method,
            tolerances,
            steps: INITIAL_STEPS,
            mass: column_major(dense_mass_matrix(system.system().mass())),
            damping: column_major(Matrix::Sparse(system.damping().clone()).to_dense()),
            abar,
            bta,
            ws: Workspace::default(),
        }
    }

    /// Equal steps a period in force.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// `V_i`, `X_i` of the module notes from `W`.
    fn stage_states(&self, x0: &[f64], v0: &[f64], h: f64, omega: f64, ws: &mut Workspace) {
        let n = x0.len();
        let s = self.method.c.len();
        for i in 0..s {
            for p in 0..n {
                let (mut dv, mut dx) = (0.0, 0.0);
                for j in 0..s {
                    dv += self.method.a[i][j] * ws.w[j * n + p];
                    dx += self.abar[i * s + j] * ws.w[j * n + p];
                }
                ws.v[i * n + p] = v0[p] + h * dv;
                ws.x[i * n + p] = x0[p] + h * self.method.c[i] / omega * v0[p] + h * h / omega * dx;
            }
        }
    }

    /// Factorises the stage Jacobian (eq. (96)) at the current stage states.
    fn factorise(&self, h: f64, omega: f64, ws: &mut Workspace, stats: &mut IntegrationStats) {
        let n = self.system.dofs();
        let s = self.method.c.len();
        let size = s * n;
        ws.tangents.resize(s * n * n, 0.0);
        for i in 0..s {
            let (x, tangent) = (
                &ws.x[i * n..(i + 1) * n],
                &mut ws.tangents[i * n * n..(i + 1) * n * n],
            );
            dense_tangent(self.system.system(), x, tangent, &mut ws.values);
        }
        stats.tangent_evaluations += s;
        ws.jacobian.resize(size * size, 0.0);
        for i in 0..s {
            let tangent = &ws.tangents[i * n * n..(i + 1) * n * n];
            for j in 0..s {
                let (ca, ck) = (
                    h * self.method.a[i][j],
                    h * h / omega * self.abar[i * s + j],
                );
                let cm = if i == j { omega } else { 0.0 };
                for q in 0..n {
                    let column = &mut ws.jacobian
                        [(j * n + q) * size + i * n..(j * n + q) * size + (i + 1) * n];
                    let (m, c, k) = (
                        &self.mass[q * n..(q + 1) * n],
                        &self.damping[q * n..(q + 1) * n],
                        &tangent[q * n..(q + 1) * n],
                    );
                    for p in 0..n {
                        column[p] = cm * m[p] + ca * c[p] + ck * k[p];
                    }
                }
            }
        }
        ws.lu = Some(DenseLu::new(linalg::view(&ws.jacobian, size, size, size)));
        stats.factorisations += 1;
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
        }
        let mut previous_update = f64::INFINITY;
        let mut fresh = false;
        for _ in 0..MAX_STAGE_ITERATIONS {
            self.stage_states(x0, v0, h, omega, ws);
            if ws.lu.is_none() {
                self.factorise(h, omega, ws, stats);
                fresh = true;
            }
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
                linalg::gemm(
                    r,
                    n,
                    true,
                    linalg::view(&self.mass, n, n, n),
                    linalg::view(w, n, 1, n),
                    omega,
                );
                linalg::gemm(
                    r,
                    n,
                    true,
                    linalg::view(&self.damping, n, n, n),
                    linalg::view(v, n, 1, n),
                    1.0,
                );
                r.iter_mut().for_each(|e| *e = -*e);
            }
            stats.rhs_evaluations += s;
            ws.lu
                .as_ref()
                .expect("factorised above")
                .solve_in_place(&mut ws.residual, 1);
            let (mut update, mut size) = (0.0f64, 0.0f64);
            for (wi, d) in ws.w.iter_mut().zip(&ws.residual) {
                *wi += d;
                update = update.max(d.abs());
                size = size.max(wi.abs());
            }
            if !update.is_finite() {
                ws.w.clear();
                ws.lu = None;
                return Err(IntegrationError::NotFinite { t: tau / omega });
            }
            // Converged: the update is below the tolerance, or it stopped shrinking at a
            // small size — the round-off floor of a stiff stage system lies above
            // `STAGE_TOLERANCE` (1e-8 of the largest stage value on the 19-element ECL beam,
            // in the stiff modes' components, which the step scales down by `h²/Ω`), whether
            // the factorisation is this step's or the last one's (renewing it there doubled
            // the factorisations of the beam's forced curve and changed its folds by 4e-11).
            let floor = if fresh { 1e-6 } else { 1e-7 };
            let stalled = update > 0.25 * previous_update && update <= floor * size;
            if update <= STAGE_TOLERANCE * size || size == 0.0 || stalled {
                self.stage_states(x0, v0, h, omega, ws);
                if exact {
                    self.factorise(h, omega, ws, stats);
                }
                return Ok(());
            }
            // A stale factorisation that stops contracting is renewed at the current stages.
            if !fresh && update > 0.5 * previous_update {
                ws.lu = None;
            }
            previous_update = update;
        }
        ws.w.clear();
        ws.lu = None;
        Err(IntegrationError::InvalidInput(format!(
            "the stage equations did not converge at t = {:.6e}; tighten the tolerance or \
             choose another integrator",
            tau / omega
        )))
    }

    /// `steps` equal steps from `z0` at phase `tau0` over `span`, with the sensitivities
    /// `[Φ ∂z/∂Ω ∂z/∂a]` when asked.
    fn integrate(
        &mut self,
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
        let mut ws = std::mem::take(&mut self.ws);
        // A new integration starts its stage iteration afresh (its first iterate from the
        // field, its Jacobian at its own stages): the discrete map must not depend on the
        // integration before.
        ws.w.clear();
        ws.lu = None;
        ws.rhs.resize(s * n * cols, 0.0);
        ws.displacement.resize(n * cols, 0.0);
        let mut result = Ok(());
        for step in 0..steps {
            let tau = tau0 + step as f64 * h;
            if let Err(e) = self.stages(&z, tau, h, drive, cols > 0, &mut ws, &mut stats) {
                result = Err(e);
                break;
            }
            let (x0, v0) = z.split_at(n);
            let mut z1 = vec![0.0; n2];
            for p in 0..n {
                let (mut dv, mut dx) = (0.0, 0.0);
                for j in 0..s {
                    dv += self.method.b[j] * ws.w[j * n + p];
                    dx += self.bta[j] * ws.w[j * n + p];
                }
                z1[n + p] = v0[p] + h * dv;
                z1[p] = x0[p] + h / omega * v0[p] + h * h / omega * dx;
            }
            if cols > 0 {
                self.propagate(&mut phi, cols, &z, &z1, tau, h, omega, &mut ws);
            }
            z = z1;
            stats.steps += 1;
        }
        // The last stages are not a first iterate for an unrelated integration.
        ws.w.clear();
        ws.lu = None;
        self.ws = ws;
        result?;
        Ok(ForcedFlow {
            z,
            sensitivity: phi,
            steps: vec![h; steps],
            stats,
        })
    }

    /// Advances the sensitivities `phi` (`2n × cols`, column-major) over one step from `z`
    /// to `z1` by eq. (97), with the exact Jacobian factorised at the step's stages.
    #[allow(clippy::too_many_arguments)]
    fn propagate(
        &self,
        phi: &mut [f64],
        cols: usize,
        z: &[f64],
        z1: &[f64],
        tau: f64,
        h: f64,
        omega: f64,
        ws: &mut Workspace,
    ) {
        let n = self.system.dofs();
        let (n2, s) = (2 * n, self.method.c.len());
        let size = s * n;
        let x0 = &z[..n];
        let (omega_column, amplitude_column) = (n2, n2 + 1);
        for i in 0..s {
            // `δx0 + (h c_i/Ω) δv0` of every column.
            let ratio = h * self.method.c[i] / omega;
            for c in 0..cols {
                let column = &phi[c * n2..(c + 1) * n2];
                for p in 0..n {
                    ws.displacement[c * n + p] = column[p] + ratio * column[n + p];
                }
            }
            let block = &mut ws.rhs[i * n..];
            let tangent = &ws.tangents[i * n * n..(i + 1) * n * n];
            linalg::gemm(
                block,
                size,
                false,
                linalg::view(tangent, n, n, n),
                linalg::view(&ws.displacement, n, cols, n),
                1.0,
            );
            linalg::gemm(
                block,
                size,
                true,
                linalg::view(&self.damping, n, n, n),
                linalg::view(&phi[n..], n, cols, n2),
                1.0,
            );
            // The parameter columns: `M W_i − K_t(X_i)(X_i − x0)/Ω` and `−F(τ_i)`.
            let (w, x) = (&ws.w[i * n..(i + 1) * n], &ws.x[i * n..(i + 1) * n]);
            ws.moved.clear();
            ws.moved.extend((0..n).map(|q| -(x[q] - x0[q]) / omega));
            let moved = &ws.moved;
            let target =
                &mut ws.rhs[omega_column * size + i * n..omega_column * size + (i + 1) * n];
            linalg::gemm(
                target,
                n,
                true,
                linalg::view(&self.mass, n, n, n),
                linalg::view(w, n, 1, n),
                1.0,
            );
            linalg::gemm(
                target,
                n,
                true,
                linalg::view(tangent, n, n, n),
                linalg::view(moved, n, 1, n),
                1.0,
            );
            ws.force.fill(0.0);
            self.system
                .force()
                .add_at(tau + self.method.c[i] * h, 1.0, &mut ws.force);
            let target =
                &mut ws.rhs[amplitude_column * size + i * n..amplitude_column * size + (i + 1) * n];
            for (t, f) in target.iter_mut().zip(&ws.force) {
                *t -= f;
            }
        }
        ws.rhs.iter_mut().for_each(|e| *e = -*e);
        ws.lu
            .as_ref()
            .expect("an exact factorisation at the converged stages")
            .solve_in_place(&mut ws.rhs, cols);
        for c in 0..cols {
            let d_omega = if c == omega_column { 1.0 } else { 0.0 };
            let dw = &ws.rhs[c * size..(c + 1) * size];
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
    fn slow_difference(&self, a: &[f64], b: &[f64], filter: &DenseLu) -> f64 {
        let n2 = a.len();
        let n = n2 / 2;
        let mut d: Vec<f64> = a.iter().zip(b).map(|(a, b)| a - b).collect();
        let mut md = vec![0.0; n2];
        linalg::gemm(
            &mut md,
            n,
            false,
            linalg::view(&self.mass, n, n, n),
            linalg::view(&d, n, 2, n),
            1.0,
        );
        filter.solve_in_place(&mut md, 2);
        d.copy_from_slice(&md);
        let tol = self.tolerances;
        let sum: f64 = (0..n2)
            .map(|i| {
                let scale = tol.absolute_at(i, n2) + tol.relative * a[i].abs().max(b[i].abs());
                (d[i] / scale).powi(2)
            })
            .sum();
        (sum / n2 as f64).sqrt()
    }

    /// The low-pass filter `M + K₀/ω_c²` at the forcing frequency `omega`, factorised.
    fn low_pass(&self, omega: f64) -> DenseLu {
        let n = self.system.dofs();
        let mut stiffness = vec![0.0; n * n];
        let mut values = Vec::new();
        dense_tangent(
            self.system.system(),
            &vec![0.0; n],
            &mut stiffness,
            &mut values,
        );
        let cutoff = CUTOFF_HARMONICS * omega;
        let shifted: Vec<f64> = self
            .mass
            .iter()
            .zip(&stiffness)
            .map(|(m, k)| m + k / (cutoff * cutoff))
            .collect();
        DenseLu::new(linalg::view(&shifted, n, n, n))
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
        let period = 2.0 * std::f64::consts::PI;
        let steps = ((span / period * self.steps as f64).round() as usize).max(1);
        self.integrate(z0, 0.0, span, steps, drive, sensitivities)
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
        let filter = self.low_pass(drive.frequency);
        for _ in 0..4 {
            let steps = self.steps.max(2 * MIN_STEPS);
            let fine = self.integrate(z0, 0.0, period, steps, drive, false)?;
            let coarse = self.integrate(z0, 0.0, period, steps / 2, drive, false)?;
            let error =
                self.slow_difference(&fine.z, &coarse.z, &filter) / (2f64.powi(order) - 1.0);
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
