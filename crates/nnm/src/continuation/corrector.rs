//! The Newton corrector on the bordered system (docs/method.md eqs. (22)–(23)): the problem's rows
//! plus one row `dᵀ (u - anchor) = 0`, solved in least squares (energy conservation makes one
//! periodicity row of the shooting problem redundant).

use super::{ContinuationProblem, Linearization};

/// A converged corrector.
#[derive(Debug)]
pub struct Corrected<E> {
    /// The converged unknowns.
    pub u: Vec<f64>,
    /// The problem's linearisation at `u`, reused for the tangent and the point.
    pub evaluation: E,
    /// Newton solves it took (0 when `start` already met the tolerance).
    pub iterations: usize,
}

/// Why the corrector failed.
#[derive(Debug, thiserror::Error)]
pub enum CorrectorError<E: std::error::Error> {
    /// The problem could not be evaluated (e.g. the time integration failed).
    #[error(transparent)]
    Problem(E),
    /// The relative residual became NaN or infinite.
    #[error("non-finite residual")]
    NotFinite,
    /// The residual did not fall below the tolerance within `max_iterations`, or grew a
    /// thousandfold.
    #[error("residual {residual:.2e} after {iterations} Newton iterations")]
    NoConvergence {
        /// Relative residual at the last iterate.
        residual: f64,
        /// Newton solves made.
        iterations: usize,
    },
}

/// Chord solves a corrector allows per Newton iteration it allows: a chord that cuts the
/// residual only fourfold a step (the forced response's threshold for asking an exact one)
/// needs twenty steps from 1e-4 to 1e-16, against eight Newton iterations' allowance (a
/// landing on the end of a sweep at tolerance 1e-12 ran out at eight).
pub const CHORDS_PER_ITERATION: usize = 4;

/// Newton from `start` on `F(u) = 0`, `direction · (u - anchor) = 0`, until the problem's
/// relative residual is below `tolerance`; at most `max_iterations` iterations, and it gives
/// up early when the residual grows a thousandfold. `newton_iterations` counts the solves.
///
/// A problem may linearise some iterates by a chord (a neighbour's Jacobian,
/// [`Linearization::is_exact`] false): those solves are cheap, and they are not counted as
/// iterations — neither against `max_iterations` (their own allowance is
/// [`CHORDS_PER_ITERATION`] times as many) nor in [`Corrected::iterations`], which the step
/// control reads as the work a point took.
pub fn correct<P: ContinuationProblem>(
    problem: &mut P,
    start: &[f64],
    direction: &[f64],
    anchor: &[f64],
    tolerance: f64,
    max_iterations: usize,
    newton_iterations: &mut usize,
) -> Result<Corrected<P::Evaluation>, CorrectorError<P::Error>> {
    let mut u = start.to_vec();
    let mut first_residual = None;
    let (mut exact, mut chords) = (0usize, 0usize);
    loop {
        let evaluation = problem.evaluate(&u).map_err(CorrectorError::Problem)?;
        let residual = evaluation.relative_residual();
        if !residual.is_finite() {
            return Err(CorrectorError::NotFinite);
        }
        if residual < tolerance {
            return Ok(Corrected {
                u,
                evaluation,
                iterations: exact,
            });
        }
        let first = *first_residual.get_or_insert(residual);
        let spent = if evaluation.is_exact() {
            exact >= max_iterations
        } else {
            chords >= CHORDS_PER_ITERATION * max_iterations
        };
        if spent || residual > 1e3 * first.max(tolerance) {
            return Err(CorrectorError::NoConvergence {
                residual,
                iterations: exact + chords,
            });
        }
        if evaluation.is_exact() {
            exact += 1;
        } else {
            chords += 1;
        }
        let rhs: Vec<f64> = evaluation.residual().iter().map(|r| -r).collect();
        let offset: f64 = direction
            .iter()
            .zip(u.iter().zip(anchor))
            .map(|(d, (x, y))| d * (x - y))
            .sum();
        let delta = evaluation.solve_bordered(direction, &rhs, -offset);
        for (x, d) in u.iter_mut().zip(&delta) {
            *x += d;
        }
        *newton_iterations += 1;
    }
}
