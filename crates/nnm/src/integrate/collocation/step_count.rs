//! How many equal steps a collocation integration takes over its horizon (docs/method.md
//! eq. (32d)): a Richardson estimate of the global error, `N` against `2N` steps, measured on
//! the motion's slow part, and reused while the horizon stays within 20% of the one it was
//! chosen for.

use super::stages::{SparseStages, StageLu};
use super::{GaussLegendre, StepCache};
use crate::integrate::{IntegrationError, IntegrationStats};
use crate::linalg::{self, DenseLu, Mat};
use crate::model::{MechanicalSystem, SparseMatrix, dense_tangent};

/// The first step count tried when nothing is known yet; the count chosen is at least twice
/// this. Why not fewer: with `N` steps over a half period, the stiff modes that the stages do
/// not resolve rotate by nearly `π` a step, i.e. at nearly the `N`-th harmonic of the motion;
/// with `N` = 16 imposed, they met the motion's 15th harmonic on the ECL beam and the branch
/// left for a spurious, aliased one (the trap NLvib's Newmark shooting falls into). At 32 the
/// motion's content there is negligible.
const FIRST_STEPS: usize = 16;
/// Adaptive calls served by one error estimate before it is made again.
const REUSE: usize = 64;
/// The step count controls the error of the motion's components below this many cycles over
/// the horizon (16 harmonics of a half-period shot); faster ones are filtered out of the
/// estimate (eq. (32d)).
const CUTOFF_CYCLES: f64 = 8.0;

/// The low-pass filter of the step-count estimate: `M + K₀/ω_c²` factorised, `K₀` the
/// tangent at rest (docs/method.md eq. (32d)). Applied to `M d`, it passes a displacement
/// `d`'s components in the linear modes with `ω_k ≪ ω_c` and attenuates those above by
/// `(ω_c/ω_k)²`. Free and forced collocation both estimate their step counts through it.
pub(in crate::integrate) fn low_pass<S: MechanicalSystem + ?Sized>(
    system: &S,
    mass: &SparseMatrix,
    cutoff: f64,
) -> Result<StageLu, IntegrationError> {
    let n = system.dofs();
    let alpha = 1.0 / (cutoff * cutoff);
    let rest = vec![0.0; n];
    let singular = || {
        IntegrationError::InvalidInput(
            "M + K/ω² is singular: the stiffness at rest is not positive semi-definite".into(),
        )
    };
    if let Some(pattern) = system.tangent_pattern() {
        let single = SparseStages::new(pattern, mass, None, 1).ok_or_else(singular)?;
        let mut tangent = vec![0.0; pattern.nonzeros()];
        system.tangent_values(&rest, &mut tangent);
        let values = single.values(|_, _| alpha, &[tangent]);
        return Ok(StageLu::Sparse(
            single.lu.factorise(&values).ok_or_else(singular)?,
        ));
    }
    let mut tangent = vec![0.0; n * n];
    dense_tangent(system, &rest, &mut tangent, &mut Vec::new());
    let mut shifted = Mat::<f64>::from_fn(n, n, |r, c| alpha * tangent[c * n + r]);
    let pattern = mass.pattern();
    for r in 0..n {
        for p in pattern.row_start[r]..pattern.row_start[r + 1] {
            shifted[(r, pattern.col[p])] += mass.values()[p];
        }
    }
    Ok(StageLu::Dense(DenseLu::new(shifted.as_ref())))
}

impl<S: MechanicalSystem + ?Sized> GaussLegendre<'_, S> {
    /// `√(yᵀ M y)` with `(M + K₀/ω_c²) y = M x`, `x` the displacements of `z`: the mass norm
    /// of the displacements' slow part (eq. (32d)). The step count is chosen on this norm of
    /// the error, taken at the middle and at the end of the horizon (a phase error hides in
    /// the velocities at a turning point but shows in the displacements a quarter period
    /// away).
    ///
    /// Why filtered: the stiff end of a finite-element spectrum is not resolvable at an
    /// affordable step, and need not be: the A-stable, symplectic stages carry it with a
    /// bounded phase error. But a state on a computed orbit holds it at small amplitude, and
    /// the `N`- and `2N`-step runs rotate it by different phases, so an unfiltered difference
    /// measures that content instead of the error, and does not fall with `N` until `ω_max h`
    /// is small. On the ECL beam the unfiltered estimate asked for ~200 steps a half period;
    /// filtered, it takes ~32, and the backbone agrees with a 512-step one to 1e-10 in
    /// frequency. (Velocities are left out for the same reason: weighed in, the estimate asked
    /// for thousands of steps a period.)
    fn filtered_norm(&self, z: &[f64], filter: &StageLu) -> f64 {
        let x = &z[..z.len() / 2];
        let mass = self.form.system().mass();
        let mut y = vec![0.0; x.len()];
        mass.apply(x, 1, &mut y);
        filter.solve_in_place(&mut y, 1);
        let mut my = vec![0.0; x.len()];
        mass.apply(&y, 1, &mut my);
        linalg::dot(&y, &my).max(0.0).sqrt()
    }

    /// Integrates `steps` (even) equal steps of `duration / steps` without sensitivities: the
    /// states at the middle and at the end of the horizon.
    fn run(
        &self,
        z0: &[f64],
        duration: f64,
        steps: usize,
        stats: &mut IntegrationStats,
    ) -> Result<(Vec<f64>, Vec<f64>), IntegrationError> {
        let mut z = z0.to_vec();
        let mut middle = Vec::new();
        let sizes = vec![duration / steps as f64; steps];
        let mut cache = StepCache {
            split: true,
            ..StepCache::default()
        };
        self.march(
            &mut z,
            &sizes,
            (&mut [], 0),
            &mut cache,
            stats,
            |k, state| {
                if 2 * (k + 1) == steps {
                    middle = state.to_vec();
                }
            },
        )?;
        Ok((middle, z))
    }

    /// The number of equal steps over `duration` whose global error meets the tolerances:
    /// `N` and `2N` steps compared (Richardson, order `2s`), `N` grown until the estimate of
    /// the `2N` run's error is below one; then `2N`.
    pub(super) fn choose_steps(
        &mut self,
        z0: &[f64],
        duration: f64,
        hint: Option<f64>,
        stats: &mut IntegrationStats,
    ) -> Result<usize, IntegrationError> {
        if let Some((h, horizon, uses)) = self.chosen
            && uses < REUSE
            && (duration / horizon - 1.0).abs() < 0.2
        {
            self.chosen = Some((h, horizon, uses + 1));
            return Ok((duration / h).ceil().max(1.0) as usize);
        }
        let even = |s: usize| s.max(2).next_multiple_of(2);
        let mut steps = even(
            hint.map(|h| (duration / h / 2.0).ceil() as usize)
                .unwrap_or(FIRST_STEPS),
        );
        let p = self.method.order as f64;
        // The motion's slow part: components below `CUTOFF_CYCLES` cycles over the horizon.
        let filter = low_pass(
            self.form.system(),
            &self.mass,
            2.0 * std::f64::consts::PI * CUTOFF_CYCLES / duration,
        )?;
        let mut trials: Vec<(usize, f64)> = Vec::new();
        loop {
            if 2 * steps > self.max_steps {
                return Err(IntegrationError::TooManySteps {
                    max_steps: self.max_steps,
                    t: 0.0,
                });
            }
            let coarse = self.run(z0, duration, steps, stats)?;
            let fine = self.run(z0, duration, 2 * steps, stats)?;
            let relative = |a: &[f64], b: &[f64]| {
                let d: Vec<f64> = a.iter().zip(b).map(|(a, b)| a - b).collect();
                let norm = |z: &[f64]| self.filtered_norm(z, &filter);
                let scale = norm(z0).max(norm(b));
                if scale > 0.0 { norm(&d) / scale } else { 0.0 }
            };
            let error = relative(&coarse.0, &fine.0).max(relative(&coarse.1, &fine.1))
                / (2f64.powf(p) - 1.0)
                / self.tolerances.relative;
            // The estimate's floor: once the steps have grown at least fourfold over two
            // trials, an error of order `p` has fallen a thousandfold; if it fell less than
            // tenfold, what is left is not the truncation error the step count controls —
            // the stage systems' round-off (their condition grows like (ω_max h)²), or the
            // unresolved stiff modes the N- and 2N-step runs treat differently — and more
            // steps do not reduce it. Measured on the 1,000-element ECL beam (ω_max/ω₁ ≈
            // 10⁷): estimates 5.6, 23, 5.4, 13, 2.6 times the tolerance at 16 to 646 steps;
            // on the 10⁴-dof von Kármán beam at +4.6%: 7.5, 3.1, 2.4 at 76, 182, 364 steps.
            // The fewest steps whose estimate is within twice the lowest are taken (the
            // lowest estimate's own count would take the von Kármán beam four to five times the
            // steps and recorded stage factorisations); Newton's own residual still decides
            // convergence.
            trials.push((steps, error));
            let floor = match trials[..] {
                [.., (s0, e0), _, (s2, e2)] if s2 >= 4 * s0 && e2 > 0.1 * e0 => {
                    let lowest = trials.iter().map(|t| t.1).fold(f64::INFINITY, f64::min);
                    trials
                        .iter()
                        .filter(|t| t.1 <= 2.0 * lowest)
                        .map(|t| t.0)
                        .min()
                }
                _ => None,
            };
            if let Some(trial) = (error <= 1.0).then_some(steps).or(floor) {
                let chosen = 2 * trial;
                self.chosen = Some((duration / chosen as f64, duration, 0));
                return Ok(chosen);
            }
            // Error ∝ N^-p: aim at a tenth of the tolerance, growing at least twofold.
            let factor = (10.0 * error).powf(1.0 / p).clamp(2.0, 16.0);
            steps = even((steps as f64 * factor).ceil() as usize);
        }
    }
}
