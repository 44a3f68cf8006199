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

/// The Euler predictor `u + s t`: the point on the step's hyperplane (eq. (21)).
pub fn predict(u: &[f64], tangent: &[f64], step: f64) -> Vec<f64> {
    u.iter().zip(tangent).map(|(x, d)| x + step * d).collect()
}

/// The second-order predictor `u + s t + (s²/2) κ`, `κ = (t − t_prev)/s_prev` the branch's
/// curvature vector estimated from the last two tangents and the step between them
/// (eq. (21a)): the corrector starts an order of the step closer to the branch than from
/// [`predict`] (error `O(s³)` instead of `O(s²)`), and the step control, which aims at a number
/// of iterations, lets the steps grow accordingly. `previous`: the tangent before `tangent`
/// and the step from it; without one (the first step), the Euler predictor.
pub fn predict_curved(
    u: &[f64],
    tangent: &[f64],
    previous: Option<(&[f64], f64)>,
    step: f64,
) -> Vec<f64> {
    let Some((before, length)) = previous.filter(|(_, length)| *length > 0.0) else {
        return predict(u, tangent, step);
    };
    let bend = 0.5 * step * step / length;
    u.iter()
        .zip(tangent.iter().zip(before))
        .map(|(x, (t, t0))| x + step * t + bend * (t - t0))
        .collect()
}
