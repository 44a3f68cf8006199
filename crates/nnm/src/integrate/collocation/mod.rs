//! Implicit collocation (Gauss–Legendre, Radau IIA) with exact sensitivities, for stiff models
//! (docs/method.md eqs. (32a)–(32g): the same internal differentiation as the explicit pairs).
//!
//! **Why this method.** A finite-element model's highest frequency is thousands of times the
//! NNM's, and an explicit method's stability then dictates thousands of steps a period although
//! the motion is smooth. Gauss–Legendre collocation with `s` stages is A-stable (any step is
//! stable), of order `2s`, and symplectic: it neither damps nor amplifies the unresolved high
//! modes (`|R(iωh)| = 1` for every `ωh`), so Floquet multipliers stay on the unit circle
//! instead of being pulled inside it, as a damping scheme (Newmark with numerical dissipation,
//! BDF) would do. Radau IIA ([`RADAU5`]) damps them instead, for meshes fine enough that their
//! aliased phases resonate with the motion (docs/method.md §6).
//!
//! **Stage equations in second-order form.** With stage accelerations `W_i` (no `M⁻¹`
//! needed): `X_i = x + h c_i v + h² Σ_j Ā_ij W_j` (`Ā = A²`), `M W_i + f_int(X_i) = 0`, and the
//! step `x₁ = x + h v + h² Σ_j b̄_j W_j` (`b̄ = bᵀA`), `v₁ = v + h Σ_j b_j W_j`. Newton on `W`
//! uses the exact block Jacobian `M δ_ij + h² Ā_ij K_t(X_i)`, iterated to round-off.
//!
//! **Sensitivities.** Differentiating the converged stage equations along a direction
//! `(dx, dv)` gives `J dW = -[K_t(X_i)(dx + h c_i dv)]_i` with the *same* Jacobian `J` —
//! solved with the factorisation of the last Newton iteration, so `Φ` is the derivative of
//! the discrete flow that shooting's Newton solves (to the stage convergence, ~1e-13).
//!
//! **Steps.** Equal steps over the horizon; their number follows from a Richardson estimate
//! of the global error (`N` against `2N` steps, order `2s`; displacements in the mass norm at
//! the middle and the end of the horizon, relative to the motion's) against the integration
//! tolerance, and is reused while the horizon stays within 20% of the one it was chosen for.
//!
//! **Stage solves.** When the system gives its tangent on a fixed pattern (a `Structure`
//! does), the `(s n) × (s n)` stage Jacobian is assembled on the union of `M`'s and `K_t`'s
//! patterns in every block and factorised by sparse LU, its symbolic analysis made once;
//! otherwise it is dense. When the nonlinearity lives on a few dofs
//! ([`MechanicalSystem::nonlinear_dofs`]), the stage Jacobian is a low-rank update of its
//! linear part, factorised once per step size (eq. (32e)). When it is everywhere and the model
//! is large ([`SPLIT_DOFS`]), integrations without sensitivities split the stage system into
//! systems of the model's size and refine the recorded solves to round-off (eq. (32f)): a
//! fraction of the memory of the whole factorisations a matrix-free integration records.
//!
//! **Files.** `tableaux.rs`: the methods' coefficients; `stages.rs`: the stage system, its
//! pattern and factorisations (whole sparse or dense); `low_rank.rs`: the low-rank update of
//! its linear part; `split.rs`: the split systems and the refined exact solves; `tangents.rs`:
//! the stage tangents and their products, used by the variational step and by the refined
//! solves; `recorded.rs`: the variational step and the recorded linearisation;
//! `step_count.rs`: the step count; here: the integrator, its Newton iteration on the stages
//! and its [`Integrator`] implementation.

mod low_rank;
mod recorded;
mod split;
mod stages;
mod step_count;
mod tableaux;
mod tangents;

pub use recorded::CollocationLinearization;
pub(in crate::integrate) use recorded::{RecordedStep, VariationalBuffers, variational_step};
pub use split::SPLIT_DOFS;
pub use tableaux::{Collocation, GAUSS4, GAUSS6, RADAU5, RADAU9};

use std::sync::Arc;

use crate::integrate::{
    Flow, IntegrationError, IntegrationStats, Integrator, LinearizedFlow, Steps, Tolerances,
};
use crate::model::{Block, ExplicitForm, MechanicalSystem, SparseMatrix};
pub(in crate::integrate) use low_rank::LinearStages;
pub(in crate::integrate) use split::{Scratch, SplitStages, StepImage};
pub(in crate::integrate) use stages::{SparseStages, StageLu};
pub(in crate::integrate) use step_count::low_pass;
pub(in crate::integrate) use tableaux::StageMethod;
pub(in crate::integrate) use tangents::StageTangents;

/// Newton iterations allowed per step (times four, counting refactorisations) before the
/// step is declared failed.
const MAX_NEWTON: usize = 12;

/// Gauss–Legendre collocation of a [`MechanicalSystem`] with its sensitivities.
pub struct GaussLegendre<'a, S: MechanicalSystem + ?Sized> {
    form: ExplicitForm<'a, S>,
    method: &'static Collocation,
    /// `A` and `Ā = A²` by rows.
    coefficients: StageMethod,
    bbar: Vec<f64>,
    tolerances: Tolerances,
    /// The step size of the last estimate, the horizon it was made for, and how often it has
    /// been reused.
    chosen: Option<(f64, f64, usize)>,
    /// Most steps an integration may take.
    pub max_steps: usize,
    /// `M`'s entries (sparse: no dense `n × n` copy), and the identity block the dense
    /// tangents are built from (dense path only).
    mass: SparseMatrix,
    identity: Vec<f64>,
    /// The sparse stage system, when the system gives its tangent on a pattern.
    sparse: Option<SparseStages>,
    /// The stage system split into systems of the model's size (eq. (32f)), when it is
    /// sparse and its nonlinearity is not localised: used by integrations that carry no
    /// sensitivity block (matrix-free shooting records them, eq. (72)).
    split: Option<SplitStages>,
}

/// What one integration keeps from step to step: the last factorised stage Jacobian with its
/// step size (the next step's Newton starts from it), and the buffers of the variational
/// step — `s n × k` and `n × k`, about 1.3 MB a step on a 100-element beam: allocated afresh
/// every step, they made nine times the page faults.
#[derive(Default)]
struct StepCache {
    lu: Option<(StageLu, f64)>,
    /// Whether the stage systems are split (eq. (32f)) in this integration.
    split: bool,
    /// The linear part of the stage system at the current step size (low-rank path).
    linear: Option<Arc<LinearStages>>,
    buffers: VariationalBuffers,
    /// Every step's stage factorisation, when the integration records its linearisation.
    record: Option<Vec<RecordedStep>>,
    /// The relative size of the Newton update at which the last freshly factorised stage
    /// system stalled: the round-off floor of the stage iteration (0 until one has).
    floor: f64,
}

impl<S: MechanicalSystem + ?Sized> std::fmt::Debug for GaussLegendre<'_, S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GaussLegendre")
            .field("method", &self.method.name)
            .field("tolerances", &self.tolerances)
            .finish()
    }
}

impl<'a, S: MechanicalSystem + ?Sized> GaussLegendre<'a, S> {
    /// The method for `system` with the given tolerances.
    pub fn new(system: &'a S, method: &'static Collocation, tolerances: Tolerances) -> Self {
        let s = method.c.len();
        let a = |i: usize, j: usize| method.a[i][j];
        let coefficients = StageMethod::new(method);
        let bbar = (0..s)
            .map(|j| (0..s).map(|l| method.b[l] * a(l, j)).sum())
            .collect();
        let n = system.dofs();
        let mass = crate::model::mass_entries(system.mass());
        let sparse = system.tangent_pattern().and_then(|pattern| {
            SparseStages::new(pattern, &mass, None, method.c.len())
                .map(|stages| stages.with_low_rank(system, (&mass, None), &coefficients))
        });
        let split = if n > SPLIT_DOFS {
            Self::split_stages(system, sparse.as_ref(), &mass, &coefficients)
        } else {
            None
        };
        // The identity block the dense tangents are built from: the dense path only.
        let identity = if sparse.is_some() {
            Vec::new()
        } else {
            (0..n * n)
                .map(|k| if k % (n + 1) == 0 { 1.0 } else { 0.0 })
                .collect()
        };
        Self {
            form: ExplicitForm::new(system),
            method,
            coefficients,
            bbar,
            tolerances,
            chosen: None,
            max_steps: 1_000_000,
            mass,
            identity,
            sparse,
            split,
        }
    }

    /// The stage states `X_i = x + h c_i v + h² Σ_j Ā_ij W_j` (eq. (32a)), `s × n`.
    fn stage_states(&self, x: &[f64], v: &[f64], w: &[f64], h: f64) -> Vec<f64> {
        let (n, s) = (x.len(), self.method.c.len());
        let mut states = vec![0.0; s * n];
        for i in 0..s {
            for r in 0..n {
                states[i * n + r] = x[r]
                    + h * self.method.c[i] * v[r]
                    + h * h
                        * (0..s)
                            .map(|j| self.coefficients.abar[i][j] * w[j * n + r])
                            .sum::<f64>();
            }
        }
        states
    }

    /// One step of size `h` from `z` (in place), with the sensitivities `phi` (`2n × k`
    /// column-major) carried along.
    ///
    /// Newton on the stage accelerations reuses the factorisation of the previous step (kept
    /// in `cache.lu` with its step size) and refactors only when it converges slowly; with
    /// sensitivities, the exact Jacobian at the converged stages is factorised once, used for
    /// the variational step (eq. (32c)), and kept for the next step's Newton.
    /// Factorises the stage Jacobian at the stage states of accelerations `w` (step `h` from
    /// `(x, v)`) into `cache.lu`, counting the tangents and the factorisation.
    fn refactorise(
        &self,
        x: &[f64],
        v: &[f64],
        w: &[f64],
        h: f64,
        cache: &mut StepCache,
        stats: &mut IntegrationStats,
    ) -> Result<(), IntegrationError> {
        let (lu, _) = self.stage_jacobian(
            &self.stage_states(x, v, w, h),
            h,
            &mut cache.linear,
            cache.split,
        )?;
        stats.tangent_evaluations += self.method.c.len();
        stats.factorisations += 1;
        cache.lu = Some((lu, h));
        Ok(())
    }

    fn step(
        &self,
        z: &mut [f64],
        h: f64,
        phi: &mut [f64],
        k: usize,
        cache: &mut StepCache,
        stats: &mut IntegrationStats,
    ) -> Result<(), IntegrationError> {
        let system = self.form.system();
        let n = z.len() / 2;
        let s = self.method.c.len();
        let m = s * n;
        let (x, v) = z.split_at(n);
        // First guess: no stage acceleration, the stages on the start's tangent line. Not
        // the start's own acceleration `a(x)` in every stage: where the step does not resolve
        // the stiffest modes, the error those carry in `x` (round-off, or the eigensolver's
        // residual) is amplified in `a(x)` by `ω_max²` and in the stage states by
        // `(ω_max h)²`, and on a solid mesh the first Newton iterate's stages then strain
        // elements by several percent, where the St. Venant–Kirchhoff tangent is far from the
        // one the iterate needs: Newton diverged, or stalled at 10% and the step went on to
        // a non-finite state. Measured on the default hex27 box (513 dofs) to +5%: 63 points
        // with 29 rejected steps in 527 s before, 24 points with none in 199 s now; a Gmsh
        // tet10 mesh of the same box (13,626 dofs) could not start its branch before. (Nor
        // the last step's collocation polynomial extrapolated: its unresolved stiff
        // components, amplified by the extrapolation, move the step-count estimate — three
        // times the steps an integration on the von Kármán example.)
        let mut w = vec![0.0; m];
        if cache.lu.as_ref().is_none_or(|(_, size)| *size != h) {
            self.refactorise(x, v, &w, h, cache, stats)?;
        }
        let mut fresh = false;
        let mut previous = f64::INFINITY;
        let mut residual = vec![0.0; m];
        let mut mw = vec![0.0; m];
        let mut iterations = 0;
        loop {
            let states = self.stage_states(x, v, &w, h);
            // M W_i for every stage in one product of the mass operator.
            system.mass().apply(&w, s, &mut mw);
            for i in 0..s {
                let ri = &mut residual[i * n..(i + 1) * n];
                system.internal_force(&states[i * n..(i + 1) * n], ri);
                ri.iter_mut()
                    .zip(&mw[i * n..(i + 1) * n])
                    .for_each(|(r, a)| *r += a);
            }
            stats.rhs_evaluations += s;
            let mut delta: Vec<f64> = residual.iter().map(|r| -r).collect();
            cache
                .lu
                .as_ref()
                .expect("factorised")
                .0
                .solve_in_place(&mut delta, 1);
            if delta.iter().any(|d| !d.is_finite()) {
                return Err(IntegrationError::NotFinite { t: f64::NAN });
            }
            w.iter_mut().zip(&delta).for_each(|(a, d)| *a += d);
            iterations += 1;
            let size = delta.iter().fold(0.0f64, |a, d| a.max(d.abs()));
            let scale = w.iter().fold(f64::MIN_POSITIVE, |a, d| a.max(d.abs()));
            if size <= 1e-14 * scale {
                break;
            }
            if iterations >= 2 && size >= 0.5 * previous {
                // Slow: with a stale matrix, refactor at the current stages; with a fresh
                // one, this is the round-off floor of the stage system (its condition grows
                // like (ω_max h)², in unresolved stiff components of W whose effect on the
                // state is h²-small) — ~1e-10 of W's largest entry on the ECL beam, where
                // the test above asks for 1e-14. A stale matrix that stalls no higher than
                // twice the floor the last fresh one met has reached it too: refactoring
                // there buys nothing but 0.7 factorisations and 3 iterations a step.
                if fresh {
                    cache.floor = size / scale;
                    break;
                }
                if size <= 2.0 * cache.floor * scale {
                    break;
                }
                self.refactorise(x, v, &w, h, cache, stats)?;
                fresh = true;
                previous = f64::INFINITY;
                continue;
            }
            if iterations >= 4 * MAX_NEWTON {
                return Err(IntegrationError::InvalidInput(format!(
                    "implicit stages did not converge in {iterations} Newton iterations (step {h:.3e})"
                )));
            }
            previous = size;
        }
        if k > 0 || cache.record.is_some() {
            // The exact J at the converged stages: the variational step's matrix, kept for
            // the next step's Newton, and recorded for later products with Φ.
            let (lu, tangents) = self.stage_jacobian(
                &self.stage_states(x, v, &w, h),
                h,
                &mut cache.linear,
                cache.split,
            )?;
            stats.tangent_evaluations += s;
            stats.factorisations += 1;
            if k > 0 {
                variational_step(
                    self.method,
                    &self.bbar,
                    h,
                    (&lu, &tangents, 0.0),
                    None,
                    phi,
                    k,
                    &mut cache.buffers,
                );
            }
            if let Some(record) = &mut cache.record {
                // A copy, not a shared pointer: faer's factors carry the spare capacity of
                // their growth, and the copy holds only the entries (shared, they kept that
                // capacity: more memory, no time saved).
                record.push(RecordedStep {
                    h,
                    lu: lu.clone(),
                    tangents,
                });
            }
            cache.lu = Some((lu, h));
        }
        let (x1, v1) = z.split_at_mut(n);
        for r in 0..n {
            let bbar: f64 = (0..s).map(|j| self.bbar[j] * w[j * n + r]).sum();
            let b: f64 = (0..s).map(|j| self.method.b[j] * w[j * n + r]).sum();
            x1[r] += h * v1[r] + h * h * bbar;
            v1[r] += h * b;
        }
        if z.iter().any(|v| !v.is_finite()) {
            return Err(IntegrationError::NotFinite { t: f64::NAN });
        }
        Ok(())
    }
}

impl<S: MechanicalSystem + ?Sized> GaussLegendre<'_, S> {
    /// [`Integrator::flow`]; with `record`, also each step's stage factorisation, for
    /// [`CollocationLinearization`].
    fn integrate(
        &mut self,
        z0: &[f64],
        duration: f64,
        sensitivity: Option<Block<'_>>,
        steps: Steps<'_>,
        record: bool,
    ) -> Result<(Flow, Vec<RecordedStep>), IntegrationError> {
        let n2 = 2 * self.form.dofs();
        crate::integrate::check_request(z0, n2, duration, sensitivity)?;
        let mut stats = IntegrationStats::default();
        let sizes: Vec<f64> = match steps {
            Steps::Replay(list) => list.to_vec(),
            Steps::Adaptive { first_step } => {
                let count = self.choose_steps(z0, duration, first_step, &mut stats)?;
                vec![duration / count as f64; count]
            }
        };
        let k = sensitivity.map_or(0, |b| b.cols);
        let mut phi = vec![0.0; n2 * k];
        if let Some(b) = sensitivity {
            for c in 0..k {
                phi[c * n2..(c + 1) * n2].copy_from_slice(b.col(c));
            }
        }
        let mut z = z0.to_vec();
        let mut cache = StepCache {
            record: record.then(Vec::new),
            split: k == 0,
            ..StepCache::default()
        };
        self.march(
            &mut z,
            &sizes,
            (&mut phi, k),
            &mut cache,
            &mut stats,
            |_, _| {},
        )?;
        let flow = Flow {
            z,
            sensitivity: phi,
            columns: k,
            steps: sizes,
            stats,
        };
        Ok((flow, cache.record.unwrap_or_default()))
    }

    /// Takes the steps `sizes` from `z` (in place) with the sensitivities `phi` (`2n × k`),
    /// one stage factorisation carried from step to step in `cache`; `after(k, z)` sees the
    /// state after step `k`. A non-finite state is reported at the time its step started.
    fn march(
        &self,
        z: &mut [f64],
        sizes: &[f64],
        (phi, k): (&mut [f64], usize),
        cache: &mut StepCache,
        stats: &mut IntegrationStats,
        mut after: impl FnMut(usize, &[f64]),
    ) -> Result<(), IntegrationError> {
        let mut t = 0.0;
        for (index, &h) in sizes.iter().enumerate() {
            self.step(z, h, phi, k, cache, stats).map_err(|e| match e {
                IntegrationError::NotFinite { .. } => IntegrationError::NotFinite { t },
                other => other,
            })?;
            stats.steps += 1;
            t += h;
            after(index, z);
        }
        Ok(())
    }
}

impl<S: MechanicalSystem + ?Sized> Integrator for GaussLegendre<'_, S> {
    fn flow(
        &mut self,
        z0: &[f64],
        duration: f64,
        sensitivity: Option<Block<'_>>,
        steps: Steps<'_>,
    ) -> Result<Flow, IntegrationError> {
        Ok(self.integrate(z0, duration, sensitivity, steps, false)?.0)
    }

    fn flow_linearized(
        &mut self,
        z0: &[f64],
        duration: f64,
        steps: Steps<'_>,
    ) -> Result<(Flow, Arc<dyn LinearizedFlow>), IntegrationError> {
        let (flow, record) = self.integrate(z0, duration, None, steps, true)?;
        let linearization = CollocationLinearization {
            method: self.method,
            bbar: self.bbar.clone(),
            dofs: self.form.dofs(),
            steps: record,
            damping: None,
        };
        Ok((flow, Arc::new(linearization)))
    }

    /// With replayed steps, one pass keeping the stage factorisation from step to step (a
    /// division at a time, each would start with a new one: on the ECL beam, sampling a period
    /// would cost 14% of the branch).
    fn flow_sampled(
        &mut self,
        z0: &[f64],
        duration: f64,
        samples: usize,
        steps: Steps<'_>,
    ) -> Result<(Flow, Vec<Vec<f64>>), IntegrationError> {
        let Steps::Replay(division) = steps else {
            return crate::integrate::sampled_by_divisions(self, z0, duration, samples, steps);
        };
        let n2 = 2 * self.form.dofs();
        crate::integrate::check_request(z0, n2, duration, None)?;
        let mut stats = IntegrationStats::default();
        let mut z = z0.to_vec();
        let sizes = division.repeat(samples);
        let per_sample = division.len().max(1);
        let mut states = Vec::with_capacity(samples);
        self.march(
            &mut z,
            &sizes,
            (&mut [], 0),
            &mut StepCache {
                split: true,
                ..StepCache::default()
            },
            &mut stats,
            |index, state| {
                if (index + 1) % per_sample == 0 {
                    states.push(state.to_vec());
                }
            },
        )?;
        let flow = Flow {
            z,
            sensitivity: Vec::new(),
            columns: 0,
            steps: sizes,
            stats,
        };
        Ok((flow, states))
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
