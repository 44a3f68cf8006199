//! The tangents `K_t(X_i)` a stage Jacobian was built from, and their products with blocks of
//! directions: the right-hand sides of the variational step (docs/method.md eq. (32c)) and the
//! residuals of the split systems' refined solves (eq. (32f)) both come from here.

use std::sync::Arc;

use crate::linalg;
use crate::model::SparsityPattern;

/// The tangents `K_t(X_i)` the stage Jacobian was built from: dense `n × n` each, or values on
/// the system's pattern.
pub(in crate::integrate) enum StageTangents {
    Dense(Vec<f64>),
    Sparse(Arc<SparsityPattern>, Vec<Vec<f64>>),
}

impl StageTangents {
    /// `K_t(X_i) D` for a block `D` of `k` directions stored direction-fastest (`D[r k + c]`),
    /// each entry handed to `out(row, column, value)`. On the sparse path one sweep over the
    /// tangent's rows serves every direction with contiguous, vectorisable updates: on a
    /// 100-element beam, where this product over the `n` sensitivity directions is the largest
    /// cost of a step, it was 18% of the branch applied direction by direction.
    pub(in crate::integrate) fn apply_block(
        &self,
        i: usize,
        d: &[f64],
        k: usize,
        row: &mut Vec<f64>,
        mut out: impl FnMut(usize, usize, f64),
    ) {
        let n = d.len() / k.max(1);
        match self {
            StageTangents::Sparse(pattern, values) => {
                row.resize(k, 0.0);
                for r in 0..n {
                    row.fill(0.0);
                    let span = pattern.row_start[r]..pattern.row_start[r + 1];
                    for (&c, &v) in pattern.col[span.clone()].iter().zip(&values[i][span]) {
                        for (acc, x) in row.iter_mut().zip(&d[c * k..(c + 1) * k]) {
                            *acc += v * x;
                        }
                    }
                    for (col, &value) in row.iter().enumerate() {
                        out(r, col, value);
                    }
                }
            }
            StageTangents::Dense(_) => {
                let mut column = vec![0.0; n];
                let mut result = vec![0.0; n];
                for col in 0..k {
                    for r in 0..n {
                        column[r] = d[r * k + col];
                    }
                    self.apply(i, &column, &mut result);
                    for (r, &value) in result.iter().enumerate() {
                        out(r, col, value);
                    }
                }
            }
        }
    }

    /// `out = K_t(X_i) d` in plain sums: for the residuals of refined stage solves
    /// ([`super::split::SplitLu::solve_exact`]), whose floor need be no lower than the
    /// backward error of a factorisation of the whole stage system. (Summed accurately, as
    /// [`Self::apply`] does, these products were a third of a 1,000-element von Kármán
    /// branch.)
    pub(super) fn apply_plain(&self, i: usize, d: &[f64], out: &mut [f64]) {
        match self {
            StageTangents::Sparse(pattern, values) => {
                for (r, o) in out.iter_mut().enumerate() {
                    let span = pattern.row_start[r]..pattern.row_start[r + 1];
                    *o = pattern.col[span.clone()]
                        .iter()
                        .zip(&values[i][span])
                        .map(|(&c, v)| v * d[c])
                        .sum();
                }
            }
            StageTangents::Dense(_) => self.apply(i, d, out),
        }
    }

    /// `out = K_t(X_i) d`.
    pub(in crate::integrate) fn apply(&self, i: usize, d: &[f64], out: &mut [f64]) {
        let n = d.len();
        match self {
            StageTangents::Dense(all) => {
                let k = &all[i * n * n..(i + 1) * n * n];
                for (r, o) in out.iter_mut().enumerate() {
                    *o = (0..n).map(|c| k[c * n + r] * d[c]).sum();
                }
            }
            StageTangents::Sparse(pattern, values) => {
                // Rows that cancel summed in twice the precision, as the internal force's
                // are (eq. (76c)): the monodromy–vector products then carry the slow modes'
                // part of a smooth direction without the rows' cancellation noise.
                for (r, o) in out.iter_mut().enumerate() {
                    let span = pattern.row_start[r]..pattern.row_start[r + 1];
                    *o = linalg::sparse_row_dot(
                        0.0,
                        &pattern.col[span.clone()],
                        &values[i][span],
                        d,
                    );
                }
            }
        }
    }
}
