//! An explicit embedded Runge–Kutta pair for the forced motion in the force's phase
//! (docs/method.md eqs. (91)–(93)), with the sensitivities advanced by the same stages.
//!
//! The state and its sensitivities `Ψ = ∂z/∂(z0, Ω, a)` are stepped together: stage `i`
//! evaluates `G(Y_i, τ_i)` and its linearisation along `Ψ_i`,
//!
//! ```text
//!     L_i = (1/Ω) [δV; M⁻¹(−C δV − K_t(X_i) δX)] − [Ω column] G(Y_i, τ_i)/Ω
//!           + [a column] (1/Ω) [0; M⁻¹ F(τ_i)],
//! ```
//!
//! so `Ψ(2π)` is the exact derivative of the discrete map for the accepted steps. The step
//! is accepted when both the motion's and the sensitivities' embedded error estimates pass
//! (eq. (31b)): controlled on the motion alone, the steps of a lightly forced orbit grow to
//! the stability edge of the stiffest mode and its multiplier comes out wrong.

use super::{Drive, ForcedFlow, ForcedIntegrator, check_forced_request, phase_field};
use crate::integrate::kernels::{Terms, linear_combination};
use crate::integrate::tableau::{ErrorEstimate, Tableau};
use crate::integrate::{IntegrationError, IntegrationStats, Tolerances};
use crate::linalg;
use crate::model::{ExplicitForm, ForcedSystem, MechanicalSystem};

/// Floor of the sensitivities' relative tolerance in the step control: the multipliers'
/// accuracy needs no more (the free-motion integrator's choice, integrate/runge_kutta.rs).
const VARIATIONAL_TOLERANCE: f64 = 1e-9;
const SAFETY: f64 = 0.9;
const MAX_GROWTH: f64 = 6.0;
const MAX_SHRINK: f64 = 0.2;

/// The explicit forced integrator of `system` by an embedded pair (DOP853 by default).
///
/// The sensitivities are stored interleaved (the directions of one state index contiguous,
/// `Ψ[i·k + c]`), as the free-motion integrator stores them: the tangent and the damping,
/// assembled as `−M⁻¹K_t` and `−M⁻¹C` in compressed rows when the mass is diagonal, then
/// combine whole contiguous rows, and the stage combinations are single fused passes
/// (integrate/kernels.rs).
pub struct ForcedRungeKutta<'s, 'a, S: MechanicalSystem + ?Sized> {
    system: &'s ForcedSystem<'a, S>,
    form: ExplicitForm<'a, S>,
    /// `−M⁻¹C` in compressed rows (`row_start`, `col`, values) with a diagonal mass.
    damping_rate: Option<(Vec<usize>, Vec<usize>, Vec<f64>)>,
    tableau: &'static Tableau,
    /// Local error tolerances of the step control.
    pub tolerances: Tolerances,
    /// Accepted steps allowed per integration.
    pub max_steps: usize,
    /// The first step of the last integration, to start the next one with.
    first_step: Option<f64>,
    ws: Workspace,
}

#[derive(Default)]
struct Workspace {
    /// `K_i`, `stages × 2n`.
    motion: Vec<f64>,
    /// `L_i`, `stages × 2n·k`, interleaved.
    sensitivity: Vec<f64>,
    y: Vec<f64>,
    psi: Vec<f64>,
    /// `A_v Ψ_v` of a stage (`n·k`).
    damped: Vec<f64>,
    /// `M⁻¹F(τ)` (`n`).
    force: Vec<f64>,
    /// Per direction, the largest displacement and velocity sensitivity (`2k`).
    size: Vec<f64>,
    /// The error combinations.
    err_a: Vec<f64>,
    err_b: Vec<f64>,
    /// Column-major copies for the unassembled fallback.
    columns_in: Vec<f64>,
    columns_out: Vec<f64>,
}

impl<'s, 'a, S: MechanicalSystem + ?Sized> ForcedRungeKutta<'s, 'a, S> {
    /// An integrator of `system` by `tableau` at `tolerances`.
    pub fn new(
        system: &'s ForcedSystem<'a, S>,
        tableau: &'static Tableau,
        tolerances: Tolerances,
    ) -> Self {
        let damping_rate = system.system().mass().diagonal().map(|d| {
            let c = system.damping();
            let p = c.pattern();
            let values = p
                .row_start
                .windows(2)
                .enumerate()
                .flat_map(|(i, b)| (b[0]..b[1]).map(move |k| (i, k)))
                .map(|(i, k)| -c.values()[k] / d[i])
                .collect();
            (p.row_start.clone(), p.col.clone(), values)
        });
        Self {
            system,
            form: ExplicitForm::new(system.system()),
            damping_rate,
            tableau,
            tolerances,
            max_steps: 1_000_000,
            first_step: None,
            ws: Workspace::default(),
        }
    }

    /// `out = −M⁻¹C dv` for interleaved `n × k` blocks.
    fn damping_product(&self, dv: &[f64], k: usize, out: &mut [f64], ws: &mut Workspace) {
        if let Some((row_start, col, values)) = &self.damping_rate {
            linalg::sparse_times_interleaved(row_start, col, values, dv, k, out);
            return;
        }
        let n = self.system.dofs();
        let (a, b) = (&mut ws.columns_in, &mut ws.columns_out);
        a.resize(n * k, 0.0);
        b.clear();
        b.resize(n * k, 0.0);
        for i in 0..n {
            for c in 0..k {
                a[c * n + i] = dv[i * k + c];
            }
        }
        self.system.damping().apply_add(1.0, a, n, k, b, n);
        self.system.system().mass().solve_in_place(b, k);
        for i in 0..n {
            for c in 0..k {
                out[i * k + c] = -b[c * n + i];
            }
        }
    }

    /// `L = ∂G/∂(z0, Ω, a)` along the stage sensitivities `psi` (interleaved `2n × k`, the
    /// columns `cols − 2` and `cols − 1` those of `Ω` and `a`), given the stage's `G`.
    #[allow(clippy::too_many_arguments)]
    fn sensitivity_field(
        &self,
        y: &[f64],
        field: &[f64],
        tau: f64,
        drive: Drive,
        psi: &[f64],
        k: usize,
        cols: usize,
        out: &mut [f64],
        ws: &mut Workspace,
    ) {
        let n = self.system.dofs();
        let scale = 1.0 / drive.frequency;
        let (psi_x, psi_v) = psi.split_at(n * k);
        let (top, bottom) = out.split_at_mut(n * k);
        for (t, v) in top.iter_mut().zip(psi_v) {
            *t = scale * v;
        }
        self.form
            .acceleration_tangent_interleaved(&y[..n], psi_x, k, bottom);
        let mut damped = std::mem::take(&mut ws.damped);
        damped.resize(n * k, 0.0);
        self.damping_product(psi_v, k, &mut damped, ws);
        for (b, d) in bottom.iter_mut().zip(&damped) {
            *b = scale * (*b + d);
        }
        ws.damped = damped;
        // The parameter columns: `∂G/∂a = (1/Ω)[0; M⁻¹F(τ)]`, `∂G/∂Ω = −G/Ω`.
        ws.force.clear();
        ws.force.resize(n, 0.0);
        self.system.force().add_at(tau, 1.0, &mut ws.force);
        self.system.system().mass().solve_in_place(&mut ws.force, 1);
        let (omega_column, amplitude_column) = (cols - 2, cols - 1);
        for i in 0..n {
            out[(n + i) * k + amplitude_column] += scale * ws.force[i];
        }
        for (i, g) in field.iter().enumerate() {
            out[i * k + omega_column] -= scale * g;
        }
    }

    /// Integrates from `z0` at phase `tau0` over `span` (in `τ`), with the sensitivities
    /// along `[I 0 0]` and the two parameters when `sensitivities`.
    fn integrate(
        &mut self,
        z0: &[f64],
        tau0: f64,
        span: f64,
        drive: Drive,
        sensitivities: bool,
    ) -> Result<ForcedFlow, IntegrationError> {
        let n = self.system.dofs();
        let n2 = 2 * n;
        check_forced_request(z0, n2, drive)?;
        let tab = self.tableau;
        let stages = tab.c.len();
        let cols = if sensitivities { n2 + 2 } else { 0 };
        // Directions padded to a multiple of four for the kernels' four-lane groups (zero
        // directions stay zero).
        let k = if cols < 4 {
            cols
        } else {
            cols.next_multiple_of(4)
        };
        let len = n2 * k;
        let mut phi = vec![0.0; len];
        for c in 0..cols.min(n2) {
            phi[c * k + c] = 1.0;
        }
        let mut ws = std::mem::take(&mut self.ws);
        ws.motion.resize(stages * n2, 0.0);
        ws.sensitivity.resize(stages * len, 0.0);
        ws.y.resize(n2, 0.0);
        ws.psi.resize(len, 0.0);
        let mut z = z0.to_vec();
        let (mut z_new, mut phi_new) = (vec![0.0; n2], vec![0.0; len]);
        let mut stats = IntegrationStats::default();
        let mut steps = Vec::new();
        let mut tau = 0.0;
        // The last integration's first step, unless it was far shorter than this span (a
        // short advance to a peak would otherwise start a whole period underflowing).
        let mut h = self
            .first_step
            .filter(|h| *h > 1e-10 * span && *h < span)
            .unwrap_or(span / 100.0);
        let mut last_rejected = false;
        let result = loop {
            if steps.len() >= self.max_steps {
                break Err(IntegrationError::TooManySteps {
                    max_steps: self.max_steps,
                    t: tau / drive.frequency,
                });
            }
            if h < 1e-14 * span {
                break Err(IntegrationError::StepSizeUnderflow {
                    t: tau / drive.frequency,
                });
            }
            let last = tau + 1.01 * h >= span;
            if last {
                h = span - tau;
            }
            for i in 0..stages {
                let stage_tau = tau0 + tau + tab.c[i] * h;
                {
                    let mut terms = Terms::new();
                    for (j, &a) in tab.a[i].iter().enumerate() {
                        if a != 0.0 {
                            terms.push(h * a, &ws.motion[j * n2..(j + 1) * n2]);
                        }
                    }
                    linear_combination(&mut ws.y, Some(&z), terms.as_slice());
                }
                phase_field(
                    self.system,
                    &ws.y,
                    stage_tau,
                    drive,
                    &mut ws.motion[i * n2..(i + 1) * n2],
                );
                stats.rhs_evaluations += 1;
                if cols > 0 {
                    {
                        let mut terms = Terms::new();
                        for (j, &a) in tab.a[i].iter().enumerate() {
                            if a != 0.0 {
                                terms.push(h * a, &ws.sensitivity[j * len..(j + 1) * len]);
                            }
                        }
                        linear_combination(&mut ws.psi, Some(&phi), terms.as_slice());
                    }
                    let mut l = std::mem::take(&mut ws.sensitivity);
                    let y = std::mem::take(&mut ws.y);
                    let psi = std::mem::take(&mut ws.psi);
                    let motion = std::mem::take(&mut ws.motion);
                    self.sensitivity_field(
                        &y,
                        &motion[i * n2..(i + 1) * n2],
                        stage_tau,
                        drive,
                        &psi,
                        k,
                        cols,
                        &mut l[i * len..(i + 1) * len],
                        &mut ws,
                    );
                    (ws.sensitivity, ws.y, ws.psi, ws.motion) = (l, y, psi, motion);
                    stats.tangent_evaluations += 1;
                }
            }
            combine(tab.b, h, &z, &ws.motion, &mut z_new);
            if cols > 0 {
                combine(tab.b, h, &phi, &ws.sensitivity, &mut phi_new);
            }
            let tol = self.tolerances;
            let motion_error =
                error_norm(tab, h, &ws.motion, n2, &mut ws.err_a, &mut ws.err_b, |i| {
                    tol.absolute_at(i, n2) + tol.relative * z[i].abs().max(z_new[i].abs())
                });
            let sensitivity_error = if cols > 0 {
                // Per direction, the largest displacement and velocity sensitivity set the
                // scale of that direction's halves.
                let relative = tol.relative.max(VARIATIONAL_TOLERANCE);
                let size = &mut ws.size;
                size.clear();
                size.resize(2 * k, 0.0);
                for i in 0..n2 {
                    let half = usize::from(i >= n);
                    for c in 0..k {
                        let s = &mut size[2 * c + half];
                        *s = s.max(phi_new[i * k + c].abs()).max(phi[i * k + c].abs());
                    }
                }
                error_norm(
                    tab,
                    h,
                    &ws.sensitivity,
                    len,
                    &mut ws.err_a,
                    &mut ws.err_b,
                    |e| {
                        let (i, c) = (e / k, e % k);
                        relative * size[2 * c + usize::from(i >= n)] + f64::MIN_POSITIVE
                    },
                )
            } else {
                0.0
            };
            // A non-finite state or estimate rejects the step at the largest shrink; if it
            // persists the step underflows and the integration reports it.
            let error = motion_error.max(sensitivity_error);
            let error = if error.is_finite() {
                error
            } else {
                f64::INFINITY
            };
            let factor = if error == 0.0 {
                MAX_GROWTH
            } else {
                (SAFETY * error.powf(-tab.controller_exponent)).clamp(MAX_SHRINK, MAX_GROWTH)
            };
            if error <= 1.0 {
                if steps.is_empty() {
                    self.first_step = Some(h);
                }
                steps.push(h);
                stats.steps += 1;
                tau += h;
                std::mem::swap(&mut z, &mut z_new);
                std::mem::swap(&mut phi, &mut phi_new);
                if last {
                    break Ok(());
                }
                h *= if last_rejected {
                    factor.min(1.0)
                } else {
                    factor
                };
                last_rejected = false;
            } else {
                stats.rejected_steps += 1;
                if sensitivity_error > 1.0 && motion_error <= 1.0 {
                    stats.variational_rejections += 1;
                }
                h *= factor.min(1.0);
                last_rejected = true;
            }
        };
        self.ws = ws;
        result?;
        // Column-major `2n × cols` for the caller.
        let mut sensitivity = vec![0.0; n2 * cols];
        for c in 0..cols {
            for i in 0..n2 {
                sensitivity[c * n2 + i] = phi[i * k + c];
            }
        }
        Ok(ForcedFlow {
            z,
            sensitivity,
            steps,
            stats,
        })
    }
}

/// `out = start + h Σ_j b_j k_j` in one fused pass.
fn combine(b: &[f64], h: f64, start: &[f64], stages: &[f64], out: &mut [f64]) {
    let len = start.len();
    let mut terms = Terms::new();
    for (j, &w) in b.iter().enumerate() {
        if w != 0.0 {
            terms.push(h * w, &stages[j * len..(j + 1) * len]);
        }
    }
    linear_combination(out, Some(start), terms.as_slice());
}

/// The scaled RMS norm of the embedded error estimate (DOP853's blend of its 5th- and
/// 3rd-order estimates, or a plain embedded difference), as integrate/runge_kutta.rs.
fn error_norm(
    tab: &Tableau,
    h: f64,
    stages: &[f64],
    len: usize,
    err_a: &mut Vec<f64>,
    err_b: &mut Vec<f64>,
    scale: impl Fn(usize) -> f64,
) -> f64 {
    let stage = |j: usize| &stages[j * len..(j + 1) * len];
    let sum = |weights: &mut dyn Iterator<Item = (usize, f64)>, out: &mut Vec<f64>| {
        out.clear();
        out.resize(len, 0.0);
        let mut terms = Terms::new();
        for (j, w) in weights {
            if w != 0.0 {
                terms.push(w, stage(j));
            }
        }
        linear_combination(out, None, terms.as_slice());
    };
    match &tab.error {
        ErrorEstimate::Embedded(weights) => {
            sum(&mut weights.iter().copied().enumerate(), err_a);
            let s: f64 = err_a
                .iter()
                .enumerate()
                .map(|(i, e)| (h * e / scale(i)).powi(2))
                .sum();
            (s / len as f64).sqrt()
        }
        ErrorEstimate::Dop853 { fifth, third } => {
            sum(&mut fifth.iter().copied().enumerate(), err_a);
            sum(
                &mut tab
                    .b
                    .iter()
                    .copied()
                    .enumerate()
                    .chain(third.iter().map(|&(j, w)| (j, -w))),
                err_b,
            );
            let (mut a, mut b) = (0.0, 0.0);
            for i in 0..len {
                let s = scale(i);
                a += (err_a[i] / s).powi(2);
                b += (err_b[i] / s).powi(2);
            }
            let denominator = if a + 0.01 * b > 0.0 {
                a + 0.01 * b
            } else {
                1.0
            };
            h.abs() * a * (1.0 / (len as f64 * denominator)).sqrt()
        }
    }
}

impl<S: MechanicalSystem + ?Sized> ForcedIntegrator for ForcedRungeKutta<'_, '_, S> {
    fn flow(
        &mut self,
        z0: &[f64],
        drive: Drive,
        span: f64,
        sensitivities: bool,
    ) -> Result<ForcedFlow, IntegrationError> {
        self.integrate(z0, 0.0, span, drive, sensitivities)
    }

    fn advance(
        &mut self,
        z0: &[f64],
        tau0: f64,
        span: f64,
        drive: Drive,
    ) -> Result<Vec<f64>, IntegrationError> {
        Ok(self.integrate(z0, tau0, span, drive, false)?.z)
    }

    fn tolerances(&self) -> Tolerances {
        self.tolerances
    }

    fn set_tolerances(&mut self, tolerances: Tolerances) {
        self.tolerances = tolerances;
    }

    fn name(&self) -> &'static str {
        self.tableau.name
    }
}
