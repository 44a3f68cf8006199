//! Explicit embedded Runge–Kutta integration of the motion with its sensitivities
//! (docs/method.md eqs. (27)–(31)).
//!
//! The state `z = [x; v]` obeys `z' = g(z) = [v; a(x)]`. A block of sensitivities
//! `Φ = ∂z/∂(directions)` obeys the variational equations `Φ' = J(z(t)) Φ` with
//! `J = [0 I; A(x) 0]`, `A = -M⁻¹(K + ∂f_nl/∂x)`. Both are advanced by the *same* embedded
//! Runge–Kutta steps, with the variational stages evaluated at the motion's own stage states:
//! `Φ(T)` is then the exact derivative of the discrete flow map for that step sequence
//! ("internal differentiation"), so the shooting Jacobian and residual agree to round-off and
//! Newton converges quadratically even at tight tolerances (docs/method.md §13).
//!
//! Step sizes are controlled on the motion **and on the variational equations**
//! (docs/method.md eq. (31b)): the sensitivity pass runs once the motion's error passes, and
//! its own embedded error, per direction, must pass too. Controlled on the motion alone, a
//! linear-regime orbit of a slow mode lets the steps grow until the fast modes of `Φ` sit at
//! the edge of the method's stability region: on a chain of 50 masses a multiplier of modulus
//! 3.18 instead of 1, of 0.012 on two DOF with ω = 1 and 20. A step the
//! sensitivities reject costs their pass once; the next step is sized by the stricter of the
//! two estimates, so such rejections are rare after the first steps.
//!
//! **Sensitivity pass.** `Φ` is stored interleaved (the `k` directions of a state
//! index contiguous), so the sparse tangent combines whole contiguous rows. The upper half of
//! `J Φ` is `Φ_v`, so the stages need only `Φ_x` and `A Φ_x`: with `K_j = A(x_j) Φ_{x,j}`,
//! `Φ_{x,i} = Φ_x + h σ_i Φ_v + h² Σ_l ā_il K_l` (`σ = A·1`, `ā = A²`) and the step ends with
//! `Φ_x += h Σb Φ_v + h² Σ_l (bᵀA)_l K_l`, `Φ_v += h Σ_j b_j K_j` — the same discrete map
//! (identical in exact arithmetic) on half the data, each combination one fused pass.
//! Directions are padded to a multiple of four (zero directions stay zero) for the four-lane
//! AVX2 kernels of `linalg`. Not done: integrating the directions in blocks of 32 so that a
//! block's stages stay in L2 (slower: the per-call set-up outweighs the cache gain).
//!
//! **Choice of scheme (measured).** On the Duffing backbone `x'' + x + x³ = 0` to +50%
//! frequency (`nnm run` with `integrator = "dop853"` vs `"dopri5"`, same shooting tolerance),
//! both reach the same accuracy against the exact period (7e-10 at tolerance 1e-8, 9e-12 at
//! 1e-10), but DOPRI5 needs 3.8× (1e-8) to 5.7× (1e-10) more vector-field evaluations — and
//! as many more variational evaluations, which dominate for many DOFs. DOP853 is the default.

use super::kernels::{MAX_TERMS, Terms, linear_combination};
use super::tableau::{ErrorEstimate, Tableau};
use super::{Flow, IntegrationError, IntegrationStats, Integrator, Steps, Tolerances};
use crate::model::{Block, ExplicitForm, MechanicalSystem};

/// An explicit embedded Runge–Kutta integrator for `z' = g(z)` (the [`ExplicitForm`] of a
/// system) and its variational equations. Holds its workspace, so repeated integrations
/// (every Newton iteration) do not allocate beyond the returned [`Flow`].
#[derive(Debug)]
pub struct RungeKutta<'a, S: MechanicalSystem + ?Sized> {
    form: ExplicitForm<'a, S>,
    tableau: &'static Tableau,
    nystrom: Nystrom,
    /// Local error tolerances of the step control (docs/method.md eq. (31)).
    pub tolerances: Tolerances,
    /// Accepted steps allowed per integration before giving up (default 1 000 000).
    pub max_steps: usize,
    ws: Workspace,
}

#[derive(Debug, Default)]
struct Workspace {
    /// Stage derivatives of the motion, `stages × 2n`.
    k_z: Vec<f64>,
    /// Stage states of the motion (kept for the sensitivity pass), `stages × 2n`.
    z_stages: Vec<f64>,
    /// Stage accelerations of the sensitivities `A(x_i) Φ_{x,i}`, `stages × n·k`, interleaved.
    k_v: Vec<f64>,
    /// The displacement sensitivities of the current stage, `n·k`, interleaved.
    x_stage: Vec<f64>,
    z_new: Vec<f64>,
    /// The two error combinations of the stages (`2n` each).
    err_a: Vec<f64>,
    err_b: Vec<f64>,
    /// Error combinations of the sensitivity stages (`n·k`, interleaved).
    phi_err: Vec<f64>,
    /// Per direction, the largest displacement then velocity sensitivity (`2k`).
    phi_size: Vec<f64>,
}

/// Floor of the sensitivities' relative tolerance in their error control (eq. (31b)). The
/// multipliers need `| |μ| − 1 |` well below the stability tolerance (1e-4; the target is 1e-6)
/// and Newton needs no accuracy from `Φ` at all (it is the exact derivative of the discrete
/// map, whatever the steps). Measured on the bladed disk's (0,1) backbone, 60 points: the
/// motion's own 1e-11 took 44 s against 19 s without the control; 1e-9 takes 26 s (324k steps
/// against 527k) with the same largest reciprocity defect (2.4e-6, from 0.44 without), and
/// the chains' monodromy stays within 2e-7 of the exact one.
const VARIATIONAL_TOLERANCE: f64 = 1e-9;

const SAFETY: f64 = 0.9;
const MAX_GROWTH: f64 = 6.0;
const MAX_SHRINK: f64 = 0.2;

impl<'a, S: MechanicalSystem + ?Sized> RungeKutta<'a, S> {
    /// An integrator of `system` by `tableau` with `tolerances`, and the default step budget.
    pub fn new(system: &'a S, tableau: &'static Tableau, tolerances: Tolerances) -> Self {
        Self {
            form: ExplicitForm::new(system),
            tableau,
            nystrom: Nystrom::new(tableau),
            tolerances,
            max_steps: 1_000_000,
            ws: Workspace::default(),
        }
    }

    /// The Butcher tableau in use.
    pub fn tableau(&self) -> &'static Tableau {
        self.tableau
    }

    /// Integrates `z' = g(z)` from `z0` over `duration`, and, when `sensitivity` is given
    /// (`2n × k` initial block `Φ(0)`), the variational equations on the same steps.
    fn integrate(
        &mut self,
        z0: &[f64],
        duration: f64,
        sensitivity: Option<Block<'_>>,
        steps: Steps<'_>,
    ) -> Result<Flow, IntegrationError> {
        let n2 = 2 * self.form.dofs();
        super::check_request(z0, n2, duration, sensitivity)?;
        let stages = self.tableau.c.len();
        let columns = sensitivity.map_or(0, |b| b.cols);
        // Row stride of the interleaved Φ: padded with zero directions (which stay zero) to a
        // multiple of four, so that the kernels' four-lane groups leave no scalar remainder;
        // not below four (one or two directions of a tiny system would do 2-4x the work).
        let stride = if columns < 4 {
            columns
        } else {
            columns.next_multiple_of(4)
        };
        let mut phi = vec![0.0; n2 * stride];
        if let Some(b) = sensitivity {
            // Interleaved (state index-major) during the integration (module notes).
            for c in 0..columns {
                for (i, &v) in b.col(c).iter().enumerate() {
                    phi[i * stride + c] = v;
                }
            }
        }
        let ws = &mut self.ws;
        ws.k_z.resize(stages * n2, 0.0);
        ws.z_stages.resize(stages * n2, 0.0);
        ws.k_v.resize(stages * n2 / 2 * stride, 0.0);
        ws.x_stage.resize(n2 / 2 * stride, 0.0);
        ws.z_new.resize(n2, 0.0);

        let mut stats = IntegrationStats::default();
        let mut z = z0.to_vec();
        let mut accepted = Vec::new();
        let mut t = 0.0;

        // First stage of the first step.
        self.form.field(&z, &mut ws.k_z[..n2]);
        stats.rhs_evaluations += 1;
        let mut first_stage_ready = true;
        let mut first_phi_ready = false;

        let (mut h, replay) = match steps {
            Steps::Replay(list) => (list.first().copied().unwrap_or(duration), Some(list)),
            Steps::Adaptive {
                first_step: Some(h),
            } if h > 0.0 => (h, None),
            Steps::Adaptive { .. } => {
                let h = self.initial_step(&z, duration, &mut stats);
                (h, None)
            }
        };
        let mut last_rejected = false;
        let mut step_index = 0usize;
        loop {
            let last = if let Some(list) = replay {
                if step_index >= list.len() {
                    break;
                }
                h = list[step_index];
                step_index + 1 == list.len()
            } else {
                if accepted.len() >= self.max_steps {
                    return Err(IntegrationError::TooManySteps {
                        max_steps: self.max_steps,
                        t,
                    });
                }
                if h < 1e-14 * duration {
                    return Err(IntegrationError::StepSizeUnderflow { t });
                }
                if t + 1.01 * h >= duration {
                    h = duration - t;
                    true
                } else {
                    false
                }
            };

            // Motion stages.
            let tab = self.tableau;
            let ws = &mut self.ws;
            for i in 0..stages {
                if i == 0 && first_stage_ready {
                    ws.z_stages[..n2].copy_from_slice(&z);
                    continue;
                }
                let (done, rest) = ws.k_z.split_at_mut(i * n2);
                let zs = &mut ws.z_stages[i * n2..(i + 1) * n2];
                let mut terms = Terms::new();
                for (j, &a) in tab.a[i].iter().enumerate() {
                    if a != 0.0 {
                        terms.push(h * a, &done[j * n2..(j + 1) * n2]);
                    }
                }
                linear_combination(zs, Some(&z), terms.as_slice());
                self.form.field(zs, &mut rest[..n2]);
                stats.rhs_evaluations += 1;
            }
            let mut terms = Terms::new();
            for (j, &b) in tab.b.iter().enumerate() {
                if b != 0.0 {
                    terms.push(h * b, &ws.k_z[j * n2..(j + 1) * n2]);
                }
            }
            linear_combination(&mut ws.z_new, Some(&z), terms.as_slice());
            let finite = ws.z_new.iter().all(|v| v.is_finite());

            // Step-size control (adaptive mode only): the size of the next step, or a retry.
            let next = if replay.is_none() {
                let err = if finite {
                    error_norm(tab, &self.tolerances, h, &z, ws)
                } else {
                    f64::INFINITY
                };
                let factor = step_factor(err, tab.controller_exponent);
                if err > 1.0 {
                    stats.rejected_steps += 1;
                    h *= factor.min(1.0);
                    last_rejected = true;
                    // The first stage (at z) stays valid.
                    first_stage_ready = true;
                    continue;
                }
                // After a rejection, do not grow at once (Hairer's safeguard against ping-pong).
                let grow = if last_rejected {
                    factor.min(1.0)
                } else {
                    factor
                };
                last_rejected = false;
                h * grow
            } else {
                if !finite {
                    return Err(IntegrationError::NotFinite { t });
                }
                step_index += 1;
                h
            };
            let control = replay.is_none() && columns > 0;
            let next = match self.finish_step(
                h,
                (stride, columns),
                n2,
                &mut phi,
                first_phi_ready,
                control,
                &mut stats,
            ) {
                Ok(None) => next,
                Ok(Some(factor)) => next.min(h * factor),
                Err(factor) => {
                    stats.rejected_steps += 1;
                    stats.variational_rejections += 1;
                    h *= factor.min(1.0);
                    last_rejected = true;
                    // Both first stages (at z, and of Φ, untouched) stay valid.
                    first_stage_ready = true;
                    first_phi_ready = true;
                    continue;
                }
            };
            t += h;
            accepted.push(h);
            h = next;
            let ws = &mut self.ws;
            z.copy_from_slice(&ws.z_new);
            stats.steps += 1;
            // Next step's first stage: reuse the last stage when it sits at the new point.
            if tab.fsal {
                let (head, tail) = ws.k_z.split_at_mut((stages - 1) * n2);
                head[..n2].copy_from_slice(&tail[..n2]);
                if columns > 0 {
                    let m = n2 / 2 * stride;
                    let (head, tail) = ws.k_v.split_at_mut((stages - 1) * m);
                    head[..m].copy_from_slice(&tail[..m]);
                }
                first_phi_ready = columns > 0;
            } else {
                self.form.field(&z, &mut ws.k_z[..n2]);
                stats.rhs_evaluations += 1;
                first_phi_ready = false;
            }
            first_stage_ready = true;
            if last {
                break;
            }
        }
        if replay.is_none() && (t - duration).abs() > 1e-12 * duration {
            return Err(IntegrationError::InvalidInput(format!(
                "integration stopped at t = {} before T = {}",
                crate::number::Number(t),
                crate::number::Number(duration)
            )));
        }
        let mut sensitivity = vec![0.0; n2 * columns];
        for (i, row) in phi.chunks_exact(stride.max(1)).enumerate().take(n2) {
            for (c, &v) in row[..columns].iter().enumerate() {
                sensitivity[c * n2 + i] = v;
            }
        }
        Ok(Flow {
            z,
            sensitivity,
            columns,
            steps: accepted,
            stats,
        })
    }

    /// The sensitivity pass of a step the motion accepted (interleaved `Φ`, module notes):
    /// the stages `K_i = A(x_i) Φ_{x,i}` at the stored motion stages (into `ws.k_v`), then —
    /// unless the sensitivities' own error (eq. (31b)) rejects the step, `Some(factor)`
    /// returned with `Φ` untouched — the update of `Φ_x`, `Φ_v`. `control` says whether to
    /// check that error; accepted, it returns `None` or the factor it proposes for the next
    /// step. `stride`: the padded number of directions (row length of the interleaved blocks).
    #[allow(clippy::too_many_arguments)]
    fn finish_step(
        &mut self,
        h: f64,
        (stride, columns): (usize, usize),
        n2: usize,
        phi: &mut [f64],
        first_phi_ready: bool,
        control: bool,
        stats: &mut IntegrationStats,
    ) -> Result<Option<f64>, f64> {
        if stride == 0 {
            return Ok(None);
        }
        let (tab, ny) = (self.tableau, &self.nystrom);
        let ws = &mut self.ws;
        let n = n2 / 2;
        let m = n * stride;
        let (phi_x, phi_v) = phi.split_at(m);
        let h2 = h * h;
        for i in 0..tab.c.len() {
            if i == 0 && first_phi_ready {
                continue;
            }
            let (done, rest) = ws.k_v.split_at_mut(i * m);
            let x_stage: &[f64] = if i == 0 {
                phi_x
            } else {
                let mut terms = Terms::new();
                terms.push(h * ny.sigma[i], phi_v);
                for (l, &a) in ny.abar[i].iter().enumerate() {
                    if a != 0.0 {
                        terms.push(h2 * a, &done[l * m..(l + 1) * m]);
                    }
                }
                linear_combination(&mut ws.x_stage, Some(phi_x), terms.as_slice());
                &ws.x_stage
            };
            let x = &ws.z_stages[i * n2..i * n2 + n];
            self.form
                .acceleration_tangent_interleaved(x, x_stage, stride, &mut rest[..m]);
            stats.tangent_evaluations += 1;
        }
        let proposal = if control {
            let err = variational_error(
                ny,
                self.tolerances.relative.max(VARIATIONAL_TOLERANCE),
                h,
                (n, stride, columns),
                phi,
                &ws.k_v,
                (&mut ws.phi_err, &mut ws.phi_size),
            );
            let factor = step_factor(err, tab.controller_exponent);
            if err > 1.0 {
                return Err(factor);
            }
            Some(factor)
        } else {
            None
        };
        let (phi_x, phi_v) = phi.split_at_mut(m);
        let mut terms = Terms::new();
        terms.push(h * ny.b_sum, phi_v);
        for (l, &a) in ny.bbar.iter().enumerate() {
            if a != 0.0 {
                terms.push(h2 * a, &ws.k_v[l * m..(l + 1) * m]);
            }
        }
        linear_combination(phi_x, None, terms.as_slice());
        let mut terms = Terms::new();
        for (j, &b) in tab.b.iter().enumerate() {
            if b != 0.0 {
                terms.push(h * b, &ws.k_v[j * m..(j + 1) * m]);
            }
        }
        linear_combination(phi_v, None, terms.as_slice());
        Ok(proposal)
    }

    /// Hairer's starting-step heuristic (Solving ODEs I, §II.4): a step whose Euler error
    /// estimate matches the tolerance, capped by 100× a step based on `|z|/|g(z)|`.
    fn initial_step(&mut self, z: &[f64], duration: f64, stats: &mut IntegrationStats) -> f64 {
        let n2 = z.len();
        let tol = &self.tolerances;
        let sk: Vec<f64> = z
            .iter()
            .enumerate()
            .map(|(i, v)| tol.absolute_at(i, n2) + tol.relative * v.abs())
            .collect();
        let rms = |w: &dyn Fn(usize) -> f64| -> f64 {
            ((0..n2).map(|i| (w(i) / sk[i]).powi(2)).sum::<f64>() / n2 as f64).sqrt()
        };
        let f0 = self.ws.k_z[..n2].to_vec();
        let d0 = rms(&|i| z[i]);
        let d1 = rms(&|i| f0[i]);
        let h0 = if d0 < 1e-10 || d1 < 1e-10 {
            1e-6 * duration
        } else {
            0.01 * d0 / d1
        };
        let z1: Vec<f64> = (0..n2).map(|i| z[i] + h0 * f0[i]).collect();
        let mut f1 = vec![0.0; n2];
        self.form.field(&z1, &mut f1);
        stats.rhs_evaluations += 1;
        let d2 = rms(&|i| f1[i] - f0[i]) / h0;
        let order = self.tableau.order as f64;
        let h1 = if d1.max(d2) <= 1e-15 {
            (h0 * 1e-3).max(1e-6 * duration)
        } else {
            (0.01 / d1.max(d2)).powf(1.0 / (order + 1.0))
        };
        (100.0 * h0).min(h1).min(duration)
    }
}

impl<S: MechanicalSystem + ?Sized> Integrator for RungeKutta<'_, S> {
    fn flow(
        &mut self,
        z0: &[f64],
        duration: f64,
        sensitivity: Option<Block<'_>>,
        steps: Steps<'_>,
    ) -> Result<Flow, IntegrationError> {
        self.integrate(z0, duration, sensitivity, steps)
    }

    fn field(&self, z: &[f64], out: &mut [f64]) {
        self.form.field(z, out);
    }

    fn energy(&self, z: &[f64]) -> f64 {
        self.form.energy(z)
    }

    fn tolerances(&self) -> Tolerances {
        self.tolerances
    }

    fn set_tolerances(&mut self, tolerances: Tolerances) {
        self.tolerances = tolerances;
    }
}

/// The coefficients of the sensitivity stages in displacement form (module notes): the row
/// sums `σ = A·1`, `ā = A²` (strictly lower), `Σb` and `bᵀA`, and the error estimates'
/// stage weights `w` with their `wᵀA` (eq. (31b)), computed once per tableau.
#[derive(Debug)]
struct Nystrom {
    sigma: Vec<f64>,
    abar: Vec<Vec<f64>>,
    b_sum: f64,
    bbar: Vec<f64>,
    /// The embedded estimate (DOP853: its 5th-order one), `(w, wᵀA)`.
    error: (Vec<f64>, Vec<f64>),
    /// DOP853's 3rd-order estimate, `(w, wᵀA)`.
    error_third: Option<(Vec<f64>, Vec<f64>)>,
}

impl Nystrom {
    fn new(tab: &Tableau) -> Self {
        assert!(tab.c.len() < MAX_TERMS, "tableau has too many stages");
        // (row · A)_l = Σ_j row_j a_jl, summed in j order for every row alike: with a last
        // row equal to b (FSAL) the last stage then sits exactly at the new Φ_x.
        let times_a = |row: &[f64]| -> Vec<f64> {
            (0..row.len())
                .map(|l| {
                    (l + 1..row.len())
                        .map(|j| row[j] * tab.a[j][l])
                        .fold(0.0, |s, t| s + t)
                })
                .collect()
        };
        let with_a = |w: Vec<f64>| {
            let wa = times_a(&w);
            (w, wa)
        };
        let (error, error_third) = match &tab.error {
            ErrorEstimate::Embedded(e) => (with_a(e.to_vec()), None),
            ErrorEstimate::Dop853 { fifth, third } => {
                let mut w = tab.b.to_vec();
                for &(j, t) in third.iter() {
                    w[j] -= t;
                }
                (with_a(fifth.to_vec()), Some(with_a(w)))
            }
        };
        Self {
            sigma: tab.a.iter().map(|row| row.iter().sum()).collect(),
            abar: tab.a.iter().map(|row| times_a(row)).collect(),
            b_sum: tab.b.iter().sum(),
            bbar: times_a(tab.b),
            error,
            error_third,
        }
    }
}

/// The step-size factor an error norm proposes (eq. (31)), within `[MAX_SHRINK, MAX_GROWTH]`.
fn step_factor(err: f64, exponent: f64) -> f64 {
    if err.is_finite() && err > 0.0 {
        (SAFETY / err.powf(exponent)).clamp(MAX_SHRINK, MAX_GROWTH)
    } else if err == 0.0 {
        MAX_GROWTH
    } else {
        MAX_SHRINK
    }
}

/// Scaled local error of the sensitivities over a step just taken (docs/method.md eq. (31b)),
/// from their stage accelerations `K_j` (`k_v`): with error weights `w` (embedded minus
/// propagated solution), the velocity part's error is `h Σ_j w_j K_j` and the displacement
/// part's `h² Σ_l (wᵀA)_l K_l` (its `h Σ w_j Φ_v` term vanishes: `Σ w_j = 0`). Each direction
/// is measured against its own size, `relative × max_i |Φ_x,ic|` for displacements and
/// likewise for velocities (directions of very different sizes are each held to the same
/// relative accuracy), in Hairer's root-mean-square norm, with DOP853's blend of its 5th- and
/// 3rd-order estimates as for the motion. `phi` is `Φ` at the start of the step;
/// `(n, stride, columns)` its shape; `scratch` two work buffers of the integrator's (no
/// allocation per step).
#[allow(clippy::too_many_arguments)]
fn variational_error(
    ny: &Nystrom,
    relative: f64,
    h: f64,
    (n, stride, columns): (usize, usize, usize),
    phi: &[f64],
    k_v: &[f64],
    (scratch, sizes): (&mut Vec<f64>, &mut Vec<f64>),
) -> f64 {
    let m = n * stride;
    // Per direction: the largest displacement and velocity sensitivity, the scales.
    sizes.clear();
    sizes.resize(2 * columns, 0.0);
    let (size_x, size_v) = sizes.split_at_mut(columns);
    for (half, size) in [(&phi[..m], &mut *size_x), (&phi[m..2 * m], &mut *size_v)] {
        for row in half.chunks_exact(stride) {
            for (s, &v) in size.iter_mut().zip(&row[..columns]) {
                *s = s.max(v.abs());
            }
        }
    }
    let scale = |size: f64| relative * if size > 0.0 { size } else { 1.0 };
    // Σ_{i,c} (error/scale)² of one estimate: stage weights `w` and `wa = wᵀa`.
    let mut squared = |(w, wa): &(Vec<f64>, Vec<f64>)| -> f64 {
        let mut total = 0.0;
        for (weights, factor, size) in [(wa, h * h, &*size_x), (w, h, &*size_v)] {
            let mut terms = Terms::new();
            for (j, &wj) in weights.iter().enumerate() {
                if wj != 0.0 {
                    terms.push(factor * wj, &k_v[j * m..(j + 1) * m]);
                }
            }
            scratch.resize(m, 0.0);
            scratch.fill(0.0);
            linear_combination(scratch, None, terms.as_slice());
            for row in scratch.chunks_exact(stride) {
                for (c, &e) in row[..columns].iter().enumerate() {
                    total += (e / scale(size[c])).powi(2);
                }
            }
        }
        total
    };
    let count = (2 * n * columns) as f64;
    match &ny.error_third {
        None => (squared(&ny.error) / count).sqrt(),
        Some(third) => {
            // DOP853's blend (as in `error_norm`, with the factors of h inside the sums).
            let (e5, e3) = (squared(&ny.error), squared(third));
            let denominator = if e5 + 0.01 * e3 > 0.0 {
                e5 + 0.01 * e3
            } else {
                1.0
            };
            e5 * (1.0 / (count * denominator)).sqrt()
        }
    }
}

/// Scaled local error of a step (Hairer's norm), including DOP853's blended estimate. The
/// error combinations of the stages are formed first, as whole vectors (fused kernel).
fn error_norm(tab: &Tableau, tol: &Tolerances, h: f64, z: &[f64], ws: &mut Workspace) -> f64 {
    let n2 = z.len();
    let (k, z_new) = (&ws.k_z, &ws.z_new);
    let scale = |i: usize| tol.absolute_at(i, n2) + tol.relative * z[i].abs().max(z_new[i].abs());
    let stage = |j: usize| &k[j * n2..(j + 1) * n2];
    ws.err_a.resize(n2, 0.0);
    ws.err_b.resize(n2, 0.0);
    // Σ_j w_j k_j (non-zero weights only) into `err_a`.
    let weights = match &tab.error {
        ErrorEstimate::Embedded(e) => e,
        ErrorEstimate::Dop853 { fifth, .. } => fifth,
    };
    let mut terms = Terms::new();
    for (j, &w) in weights.iter().enumerate() {
        if w != 0.0 {
            terms.push(w, stage(j));
        }
    }
    ws.err_a.fill(0.0);
    linear_combination(&mut ws.err_a, None, terms.as_slice());
    match &tab.error {
        ErrorEstimate::Embedded(_) => {
            let sum: f64 = (0..n2).map(|i| (h * ws.err_a[i] / scale(i)).powi(2)).sum();
            (sum / n2 as f64).sqrt()
        }
        ErrorEstimate::Dop853 { third, .. } => {
            // The 3rd-order error: the propagated solution's weights minus the 3rd-order ones.
            let mut terms = Terms::new();
            for (j, &b) in tab.b.iter().enumerate() {
                if b != 0.0 {
                    terms.push(b, stage(j));
                }
            }
            for &(j, w) in third {
                terms.push(-w, stage(j));
            }
            ws.err_b.fill(0.0);
            linear_combination(&mut ws.err_b, None, terms.as_slice());
            let (mut e5, mut e3) = (0.0, 0.0);
            for i in 0..n2 {
                let sk = scale(i);
                e5 += (ws.err_a[i] / sk).powi(2);
                e3 += (ws.err_b[i] / sk).powi(2);
            }
            let denominator = if e5 + 0.01 * e3 > 0.0 {
                e5 + 0.01 * e3
            } else {
                1.0
            };
            h.abs() * e5 * (1.0 / (n2 as f64 * denominator)).sqrt()
        }
    }
}
