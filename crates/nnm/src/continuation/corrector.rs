//! The Newton corrector on the bordered system (docs/method.md eqs. (22)–(23)): the problem's rows
//! plus one row `dᵀ (u - anchor) = 0`, solved in least squares (energy conservation makes one
//! periodicity row of the shooting problem redundant).

use super::{ContinuationProblem, Linearization};
use crate::linalg;

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
    /// An iterate left the ball the solution must lie in around the start: Newton is
    /// diverging, and its next iterates (at ever larger amplitudes and farther parameters)
    /// only cost integrations.
    #[error("Newton iterate {distance:.2e} from its start, beyond its reach {reach:.2e}")]
    OutOfReach {
        /// Distance of the iterate from the start.
        distance: f64,
        /// The largest distance allowed.
        reach: f64,
    },
}

/// What ends a corrector: the tolerance it must meet, its iterations, and how far from the
/// start its iterates may go.
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    /// The relative residual to reach.
    pub tolerance: f64,
    /// Newton iterations allowed (chord solves: [`CHORDS_PER_ITERATION`] times as many).
    pub max_iterations: usize,
    /// The largest distance of an iterate from the start (`f64::INFINITY`: unbounded).
    pub reach: f64,
}

/// Arclength steps an iterate may stray from the prediction (docs/method.md eq. (22a)): four
/// times the correction a step may end on (a converged correction beyond half the step is
/// refused, eq. (25)), room for a chord's overshoot, while a diverging Newton is stopped
/// before its iterates' motions grow costly.
pub const REACH_IN_STEPS: f64 = 2.0;

impl Limits {
    /// `tolerance` and `max_iterations`, iterates within [`REACH_IN_STEPS`] steps of
    /// arclength `step` from the start.
    pub fn within_steps(tolerance: f64, max_iterations: usize, step: f64) -> Self {
        Self {
            tolerance,
            max_iterations,
            reach: REACH_IN_STEPS * step.abs(),
        }
    }

    /// `tolerance` and `max_iterations`, any distance.
    pub fn unbounded(tolerance: f64, max_iterations: usize) -> Self {
        Self {
            tolerance,
            max_iterations,
            reach: f64::INFINITY,
        }
    }
}

/// Chord solves a corrector allows per Newton iteration it allows: a chord that cuts the
/// residual only fourfold a step (the forced response's threshold for asking an exact one)
/// needs twenty steps from 1e-4 to 1e-16, against eight Newton iterations' allowance (a
/// landing on the end of a sweep at tolerance 1e-12 ran out at eight).
pub const CHORDS_PER_ITERATION: usize = 4;

/// Newton from `start` on `F(u) = 0`, `direction · (u - anchor) = 0`, until the problem's
/// relative residual is below `limits.tolerance`; at most `limits.max_iterations`
/// iterations, and it gives up early when the residual grows a thousandfold or an iterate
/// goes farther than `limits.reach` from `start` (a relative residual can stay bounded while
/// Newton runs off to huge amplitudes: the bladed disk's forced curve once spent 200 s
/// integrating one such iterate). `newton_iterations` counts the solves.
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
    limits: Limits,
    newton_iterations: &mut usize,
) -> Result<Corrected<P::Evaluation>, CorrectorError<P::Error>> {
    let Limits {
        tolerance,
        max_iterations,
        reach,
    } = limits;
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
        let distance = linalg::distance(&u, start);
        if distance > reach {
            return Err(CorrectorError::OutOfReach { distance, reach });
        }
    }
}
