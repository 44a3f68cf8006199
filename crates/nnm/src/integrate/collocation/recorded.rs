//! The variational step of a collocation method (docs/method.md eq. (32c)) and the recorded
//! linearisation built on it (eq. (72)): what a step keeps so that `Φ D` can be applied to any
//! block `D` after the motion is integrated.

use std::sync::Arc;

use super::split::{Scratch, StepImage};
use super::stages::StageLu;
use super::tableaux::Collocation;
use super::tangents::StageTangents;
use crate::integrate::LinearizedFlow;
use crate::model::SparseMatrix;

/// The work buffers of [`variational_step`]: `s n × k`, `n × k`, `k` and `n × k`.
#[derive(Default)]
pub(in crate::integrate) struct VariationalBuffers {
    rhs: Vec<f64>,
    directions: Vec<f64>,
    row: Vec<f64>,
    damped: Vec<f64>,
    /// A split stage solve's (eq. (32f)).
    solve: Scratch,
}

/// One step of the variational equations (eq. (32c)) for `k` directions `phi` (`2n × k`,
/// column-major, in place): `J dW = -[K_t(X_i)(Φ_x + h c_i Φ_v) + C Φ_v]_i` with the exact
/// stage Jacobian `J` at the converged stages (factorised in `lu`) and the tangents it was
/// built from, then `Φ_x += h Φ_v + h² Σ b̄_j dW_j`, `Φ_v += h Σ b_j dW_j`. The damping `C`
/// is a forced motion's (eq. (97), in time rather than phase); free motions have none.
/// `accuracy`: the relative accuracy the stage solves are taken to (0: round-off,
/// [`StageLu::solve_exact`]).
#[allow(clippy::too_many_arguments)]
pub(in crate::integrate) fn variational_step(
    method: &Collocation,
    bbar: &[f64],
    h: f64,
    (lu, tangents, accuracy): (&StageLu, &StageTangents, f64),
    damping: Option<&SparseMatrix>,
    phi: &mut [f64],
    k: usize,
    buffers: &mut VariationalBuffers,
) {
    let s = method.c.len();
    let n = phi.len() / (2 * k);
    let (m, n2) = (s * n, 2 * n);
    // Every entry of both is written below: resized, not cleared.
    let VariationalBuffers {
        rhs,
        directions,
        row,
        damped,
        solve,
    } = buffers;
    rhs.resize(m * k, 0.0);
    directions.resize(n * k, 0.0);
    if let Some(damping) = damping {
        // `C Φ_v`: the same in every stage's equations.
        damped.clear();
        damped.resize(n * k, 0.0);
        damping.apply_add(1.0, &phi[n..], n2, k, damped, n);
    }
    for i in 0..s {
        let hc = h * method.c[i];
        // Φ_x + h c_i Φ_v for every column, stored direction-fastest.
        for col in 0..k {
            let (px, pv) = phi[col * n2..(col + 1) * n2].split_at(n);
            for r in 0..n {
                directions[r * k + col] = px[r] + hc * pv[r];
            }
        }
        if k == 1 {
            // One direction (a matrix-free product): the plain product, without the block
            // sweep's per-entry callback — a fifth of a product's time on a 100-element beam.
            let out = &mut rhs[i * n..(i + 1) * n];
            tangents.apply(i, directions, out);
            out.iter_mut().for_each(|v| *v = -*v);
        } else {
            tangents.apply_block(i, directions, k, row, |r, col, value| {
                rhs[col * m + i * n + r] = -value;
            });
        }
        if damping.is_some() {
            for col in 0..k {
                rhs[col * m + i * n..col * m + (i + 1) * n]
                    .iter_mut()
                    .zip(&damped[col * n..(col + 1) * n])
                    .for_each(|(r, d)| *r -= d);
            }
        }
    }
    let image = StepImage {
        displacement: bbar,
        velocity: method.b,
        scales: (h * h, h),
        start: phi,
    };
    lu.solve_exact(rhs, k, tangents, (accuracy, &image), solve);
    for col in 0..k {
        let dw = &rhs[col * m..(col + 1) * m];
        let (px, pv) = phi[col * n2..(col + 1) * n2].split_at_mut(n);
        for r in 0..n {
            let bbar: f64 = (0..s).map(|j| bbar[j] * dw[j * n + r]).sum();
            let b: f64 = (0..s).map(|j| method.b[j] * dw[j * n + r]).sum();
            px[r] += h * pv[r] + h * h * bbar;
            pv[r] += h * b;
        }
    }
}

/// What a step keeps for later products with the monodromy: its size, its factorised stage
/// Jacobian and the tangents `K_t(X_i)` it was built from.
pub(in crate::integrate) struct RecordedStep {
    pub(in crate::integrate) h: f64,
    pub(in crate::integrate) lu: StageLu,
    pub(in crate::integrate) tangents: StageTangents,
}

/// The linearised discrete flow of one collocation integration (docs/method.md eq. (72)):
/// `Φ D` for any block `D` by [`variational_step`] over the recorded steps — the same
/// arithmetic as sensitivities integrated with the motion — without integrating the motion
/// again or factorising anything. Memory: per step one sparse LU of the `s n × s n` stage
/// system and `s` tangents, O(n · steps) for a banded model.
pub struct CollocationLinearization {
    pub(in crate::integrate) method: &'static Collocation,
    pub(in crate::integrate) bbar: Vec<f64>,
    pub(in crate::integrate) dofs: usize,
    pub(in crate::integrate) steps: Vec<RecordedStep>,
    /// A forced motion's damping `C` (eq. (97)); `None` for free motions.
    pub(in crate::integrate) damping: Option<Arc<SparseMatrix>>,
}

impl LinearizedFlow for CollocationLinearization {
    fn dimension(&self) -> usize {
        2 * self.dofs
    }

    fn apply(&self, directions: &[f64], columns: usize, out: &mut [f64]) {
        self.replay(directions, columns, out, 0.0);
    }

    fn apply_approximately(
        &self,
        directions: &[f64],
        columns: usize,
        out: &mut [f64],
        accuracy: f64,
    ) {
        self.replay(directions, columns, out, accuracy);
    }
}

impl CollocationLinearization {
    /// The variational steps over the recorded ones, their stage solves to `accuracy`.
    fn replay(&self, directions: &[f64], columns: usize, out: &mut [f64], accuracy: f64) {
        out.copy_from_slice(directions);
        if columns == 0 {
            return;
        }
        let mut buffers = VariationalBuffers::default();
        for step in &self.steps {
            variational_step(
                self.method,
                &self.bbar,
                step.h,
                (&step.lu, &step.tangents, accuracy),
                self.damping.as_deref(),
                out,
                columns,
                &mut buffers,
            );
        }
    }
}
