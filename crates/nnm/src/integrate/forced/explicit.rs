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
use crate::integrate::tableau::{ErrorEstimate, Tableau};
use crate::integrate::{IntegrationError, IntegrationStats, Tolerances};
use crate::model::{Block, BlockMut, ForcedSystem, MechanicalSystem};

/// Floor of the sensitivities' relative tolerance in the step control: the multipliers'
/// accuracy needs no more (the free-motion integrator's choice, integrate/runge_kutta.rs).
const VARIATIONAL_TOLERANCE: f64 = 1e-9;
const SAFETY: f64 = 0.9;
const MAX_GROWTH: f64 = 6.0;
const MAX_SHRINK: f64 = 0.2;

/// The explicit forced integrator of `system` by an embedded pair (DOP853 by default).
pub struct ForcedRungeKutta<'s, 'a, S: MechanicalSystem + ?Sized> {
    system: &'s ForcedSystem<'a, S>,
    tableau: &'static Tableau,
    /// Local error tolerances of the step control.
    pub tolerances: Tolerances,
    /// Accepted steps allowed per integration.
    pub max_steps: usize,
    /// The first step of the last integration, to start the next one with.
    first_step: Option<f64>,
}

/// Stage data of one step.
struct Stages {
    /// `K_i`, `stages × 2n`.
    motion: Vec<f64>,
    /// `L_i`, `stages × 2n·cols`.
    sensitivity: Vec<f64>,
}

impl<'s, 'a, S: MechanicalSystem + ?Sized> ForcedRungeKutta<'s, 'a, S> {
    /// An integrator of `system` by `tableau` at `tolerances`.
    pub fn new(
        system: &'s ForcedSystem<'a, S>,
        tableau: &'static Tableau,
        tolerances: Tolerances,
    ) -> Self {
        Self {
            system,
            tableau,
            tolerances,
            max_steps: 1_000_000,
            first_step: None,
        }
    }

    /// `L = ∂G/∂(z0, Ω, a)` along the stage sensitivities `psi` (`2n × cols`, the last two
    /// columns `Ω` and `a` when `parameters`), given the stage's `G` (`field`).
    #[allow(clippy::too_many_arguments)]
    fn sensitivity_field(
        &self,
        y: &[f64],
        field: &[f64],
        tau: f64,
        drive: Drive,
        psi: &[f64],
        cols: usize,
        parameters: bool,
        out: &mut [f64],
        scratch: &mut Vec<f64>,
    ) {
        let n = self.system.dofs();
        let n2 = 2 * n;
        scratch.resize(n * cols, 0.0);
        let system = self.system.system();
        system.tangent_stiffness(
            &y[..n],
            Block::new(psi, n, cols, n2),
            BlockMut::new(scratch, n, cols, n),
        );
        self.system
            .damping()
            .apply_add(1.0, &psi[n..], n2, cols, scratch, n);
        scratch.iter_mut().for_each(|v| *v = -*v);
        if parameters {
            let a_column = &mut scratch[(cols - 1) * n..cols * n];
            self.system.force().add_at(tau, 1.0, a_column);
        }
        system.mass().solve_in_place(scratch, cols);
        let scale = 1.0 / drive.frequency;
        for c in 0..cols {
            let (column, velocity) = (
                &mut out[c * n2..(c + 1) * n2],
                &psi[c * n2 + n..(c + 1) * n2],
            );
            for i in 0..n {
                column[i] = scale * velocity[i];
                column[n + i] = scale * scratch[c * n + i];
            }
        }
        if parameters {
            let omega_column = &mut out[(cols - 2) * n2..(cols - 1) * n2];
            for (o, g) in omega_column.iter_mut().zip(field) {
                *o -= scale * g;
            }
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
        let len = n2 * cols;
        let mut phi = vec![0.0; len];
        for c in 0..cols.min(n2) {
            phi[c * n2 + c] = 1.0;
        }
        let mut st = Stages {
            motion: vec![0.0; stages * n2],
            sensitivity: vec![0.0; stages * len],
        };
        let mut y = vec![0.0; n2];
        let mut psi = vec![0.0; len];
        let mut scratch = Vec::new();
        let mut z = z0.to_vec();
        let (mut z_new, mut phi_new) = (vec![0.0; n2], vec![0.0; len]);
        let mut stats = IntegrationStats::default();
        let mut steps = Vec::new();
        let mut tau = 0.0;
        let mut h = self
            .first_step
            .filter(|h| *h > 0.0 && *h < span)
            .unwrap_or(span / 100.0);
        let mut last_rejected = false;
        loop {
            if steps.len() >= self.max_steps {
                return Err(IntegrationError::TooManySteps {
                    max_steps: self.max_steps,
                    t: tau / drive.frequency,
                });
            }
            if h < 1e-14 * span {
                return Err(IntegrationError::StepSizeUnderflow {
                    t: tau / drive.frequency,
                });
            }
            let last = tau + 1.01 * h >= span;
            if last {
                h = span - tau;
            }
            for i in 0..stages {
                let stage_tau = tau0 + tau + tab.c[i] * h;
                y.copy_from_slice(&z);
                psi.copy_from_slice(&phi);
                for (j, &a) in tab.a[i].iter().enumerate() {
                    if a != 0.0 {
                        let k = &st.motion[j * n2..(j + 1) * n2];
                        y.iter_mut().zip(k).for_each(|(y, k)| *y += h * a * k);
                        let l = &st.sensitivity[j * len..(j + 1) * len];
                        psi.iter_mut().zip(l).for_each(|(p, l)| *p += h * a * l);
                    }
                }
                let k = &mut st.motion[i * n2..(i + 1) * n2];
                phase_field(self.system, &y, stage_tau, drive, k);
                stats.rhs_evaluations += 1;
                if cols > 0 {
                    let l = &mut st.sensitivity[i * len..(i + 1) * len];
                    self.sensitivity_field(
                        &y,
                        k,
                        stage_tau,
                        drive,
                        &psi,
                        cols,
                        true,
                        l,
                        &mut scratch,
                    );
                    stats.tangent_evaluations += 1;
                }
            }
            combine(tab.b, h, &z, &st.motion, &mut z_new);
            combine(tab.b, h, &phi, &st.sensitivity, &mut phi_new);
            let tol = self.tolerances;
            let motion_error = error_norm(tab, h, &st.motion, n2, |i| {
                tol.absolute_at(i, n2) + tol.relative * z[i].abs().max(z_new[i].abs())
            });
            let sensitivity_error = if cols > 0 {
                let relative = tol.relative.max(VARIATIONAL_TOLERANCE);
                let mut size = vec![0.0f64; 2 * cols];
                for c in 0..cols {
                    for i in 0..n2 {
                        let s = &mut size[2 * c + usize::from(i >= n)];
                        *s = s.max(phi_new[c * n2 + i].abs()).max(phi[c * n2 + i].abs());
                    }
                }
                error_norm(tab, h, &st.sensitivity, len, |k| {
                    let (c, i) = (k / n2, k % n2);
                    relative * size[2 * c + usize::from(i >= n)] + f64::MIN_POSITIVE
                })
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
                    break;
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
        }
        Ok(ForcedFlow {
            z,
            sensitivity: phi,
            steps,
            stats,
        })
    }
}

/// `out = start + h Σ_j b_j k_j`.
fn combine(b: &[f64], h: f64, start: &[f64], stages: &[f64], out: &mut [f64]) {
    let len = start.len();
    out.copy_from_slice(start);
    for (j, &w) in b.iter().enumerate() {
        if w != 0.0 {
            let k = &stages[j * len..(j + 1) * len];
            out.iter_mut().zip(k).for_each(|(o, k)| *o += h * w * k);
        }
    }
}

/// The scaled RMS norm of the embedded error estimate (DOP853's blend of its 5th- and
/// 3rd-order estimates, or a plain embedded difference), as integrate/runge_kutta.rs.
fn error_norm(
    tab: &Tableau,
    h: f64,
    stages: &[f64],
    len: usize,
    scale: impl Fn(usize) -> f64,
) -> f64 {
    let stage = |j: usize| &stages[j * len..(j + 1) * len];
    let sum = |weights: &mut dyn Iterator<Item = (usize, f64)>| {
        let mut e = vec![0.0; len];
        for (j, w) in weights {
            e.iter_mut().zip(stage(j)).for_each(|(e, k)| *e += w * k);
        }
        e
    };
    match &tab.error {
        ErrorEstimate::Embedded(weights) => {
            let e = sum(&mut weights.iter().copied().enumerate());
            let s: f64 = e
                .iter()
                .enumerate()
                .map(|(i, e)| (h * e / scale(i)).powi(2))
                .sum();
            (s / len as f64).sqrt()
        }
        ErrorEstimate::Dop853 { fifth, third } => {
            let e5 = sum(&mut fifth.iter().copied().enumerate());
            let e3 = sum(&mut tab
                .b
                .iter()
                .copied()
                .enumerate()
                .chain(third.iter().map(|&(j, w)| (j, -w))));
            let (mut a, mut b) = (0.0, 0.0);
            for i in 0..len {
                let s = scale(i);
                a += (e5[i] / s).powi(2);
                b += (e3[i] / s).powi(2);
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
        sensitivities: bool,
    ) -> Result<ForcedFlow, IntegrationError> {
        self.integrate(z0, 0.0, 2.0 * std::f64::consts::PI, drive, sensitivities)
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
