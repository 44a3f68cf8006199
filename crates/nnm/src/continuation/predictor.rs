//! The tangent of the branch and the predictor along it (docs/method.md eqs. (20)–(21)).

use super::Linearization;
use crate::linalg;

/// The unit tangent at a converged point: `[J; t_prevᵀ] t = [0; 1]`, normalised and
/// oriented like `previous` (so the branch is followed in one direction, through folds too).
pub fn tangent(linearization: &impl Linearization, previous: &[f64]) -> Vec<f64> {
    let rhs = vec![0.0; linearization.residual().len()];
    let mut t = linearization.solve_bordered(previous, &rhs, 1.0);
    let norm = linalg::norm(&t);
    t.iter_mut().for_each(|x| *x /= norm);
    if linalg::dot(&t, previous) < 0.0 {
        t.iter_mut().for_each(|x| *x = -*x);
    }
    t
}

/// The Euler predictor `u + s t`.
pub fn predict(u: &[f64], tangent: &[f64], step: f64) -> Vec<f64> {
    u.iter().zip(tangent).map(|(x, d)| x + step * d).collect()
}
