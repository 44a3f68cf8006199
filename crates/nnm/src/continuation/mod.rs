//! Pseudo-arclength continuation of a one-parameter family of solutions of `F(u) = 0`,
//! `F: ℝ^{N+1} → ℝ^{rows}` (docs/method.md §5), apart from any particular problem.
//!
//! - [`ContinuationProblem`] is what a problem provides: evaluation of its residual and a
//!   linearisation that solves bordered systems, and the conversion of a converged solution
//!   into the point type its users want. Shooting for periodic orbits is one implementation
//!   ([`crate::shooting::Shooting`]).
//! - [`Continuation`] is an iterator of points: the caller drives the loop (stop, inspect,
//!   write). Its pieces are separate: the predictor and tangent ([`predictor`]), the Newton
//!   corrector ([`corrector`]) and the step control ([`step`]).
//! - [`EventDetector`] plugs event detection and location in: it is called with every new
//!   [`Segment`] between two points and may correct trial points on it.

pub mod corrector;
mod iterator;
pub mod predictor;
mod settings;
pub mod step;

pub use iterator::{Continuation, Item, Segment};
pub use settings::{ContinuationSettings, MIN_TOLERANCE, SettingsError};

/// A linearisation of `F` at one `u`: the residual and the solution of bordered systems
/// `[J; bᵀ] x = [r; c]` (eqs. (20)–(23)): by dense least squares, or by GMRES on a square
/// augmented system in the matrix-free formulation (docs/method.md eq. (74)).
pub trait Linearization {
    /// The residual rows `F(u)` (possibly more rows than `N`: consistent overdetermined
    /// systems are solved in least squares).
    fn residual(&self) -> &[f64];
    /// The problem's convergence measure (relative residual, eq. (19)).
    fn relative_residual(&self) -> f64;
    /// Least-squares solution `x` of `J x = rhs`, `borderᵀ x = border_rhs`.
    fn solve_bordered(&self, border: &[f64], rhs: &[f64], border_rhs: f64) -> Vec<f64>;
    /// Whether the linearisation is the Jacobian at `u` itself (default), or a chord — a
    /// neighbour's Jacobian with `u`'s residual, cheap to make, converging linearly. The
    /// corrector does not count chord solves as iterations ([`corrector::correct`]); a
    /// problem must return an exact linearisation where the residual meets the tolerance
    /// (the converged point's tangent reads it).
    fn is_exact(&self) -> bool {
        true
    }
}

/// The bordered system `[J; bᵀ] x = [r; c]` by dense Householder QR in least squares (the
/// Moore–Penrose solution of a consistent overdetermined system, eqs. (20)–(23)): what a
/// problem with a dense Jacobian answers [`Linearization::solve_bordered`] with.
pub fn solve_bordered_dense(
    jacobian: &crate::Mat<f64>,
    border: &[f64],
    rhs: &[f64],
    border_rhs: f64,
) -> Vec<f64> {
    let (rows, m) = (jacobian.nrows(), jacobian.ncols());
    let a = crate::Mat::from_fn(rows + 1, m, |i, j| {
        if i < rows {
            jacobian[(i, j)]
        } else {
            border[j]
        }
    });
    let mut b = rhs.to_vec();
    b.push(border_rhs);
    crate::linalg::least_squares(a.as_ref(), &b)
}

/// A problem continued in `u ∈ ℝ^{N+1}`.
pub trait ContinuationProblem {
    /// One evaluation at `u`: residual, convergence measure and bordered solves.
    type Evaluation: Linearization;
    /// What a converged point carries for the caller.
    type Point: Clone;
    /// Why an evaluation failed or a solution makes no acceptable point: the continuation
    /// retries with a smaller step.
    type Error: std::error::Error + Send + Sync + 'static;

    /// `N + 1`, the number of unknowns.
    fn dimension(&self) -> usize;

    /// Evaluates `F` and its linearisation at `u`.
    fn evaluate(&mut self, u: &[f64]) -> Result<Self::Evaluation, Self::Error>;

    /// Makes the point of a converged solution. `detail`: whether the analyses a point
    /// carries (e.g. stability) are wanted, or only what event location needs.
    fn point(
        &mut self,
        solution: &Solution,
        evaluation: &Self::Evaluation,
        detail: Detail,
    ) -> Result<Self::Point, Self::Error>;

    /// Called when a point is accepted on the branch (e.g. to move a phase reference).
    fn accept(&mut self, _point: &Self::Point) {}

    /// The size against which steps are measured (relative steps). Default: the norm of `u`
    /// without its last component (the parameter-like one).
    fn amplitude(&self, u: &[f64]) -> f64 {
        crate::linalg::norm(&u[..u.len() - 1])
    }

    /// Whether steps start from the second-order predictor (eq. (21a)) instead of the Euler
    /// one. Default false: on free families it moved the 2-DOF branch point's location by more
    /// than 1e-6 between two steps and lost the period-doubling switch of the bifurcation
    /// tests (crates/nnm/tests/bifurcations.rs), where branches cross and the curvature of
    /// the last two tangents says nothing of the next stretch.
    fn second_order_predictor(&self) -> bool {
        false
    }
}

/// A converged solution on the branch.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// Index of the point on the branch (for a trial point between two points, the first's).
    pub index: usize,
    /// The converged unknowns `u ∈ ℝ^{N+1}`.
    pub u: Vec<f64>,
    /// The unit tangent there, oriented along the branch.
    pub tangent: Vec<f64>,
    /// The arclength step that led here (0 for the first point).
    pub step: f64,
    /// Newton iterations of the corrector.
    pub iterations: usize,
}

/// How much a point needs to carry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Detail {
    /// Everything a branch point carries (stability included).
    Full,
    /// Only what is cheap (for location trials of test functions that need no stability).
    Light,
}

/// Detects events between consecutive points and locates them.
pub trait EventDetector<P: ContinuationProblem> {
    /// What a located event is reported as (yielded as `Item::Event`).
    type Event;
    /// The events between the ends of `segment`, located, in the order of the branch.
    fn detect(&mut self, segment: &mut Segment<'_, P>) -> Vec<Self::Event>;
}

/// No event detection.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoEvents;

impl<P: ContinuationProblem> EventDetector<P> for NoEvents {
    type Event = std::convert::Infallible;
    fn detect(&mut self, _segment: &mut Segment<'_, P>) -> Vec<Self::Event> {
        Vec::new()
    }
}

/// Detection switched on or off at run time.
impl<P: ContinuationProblem, D: EventDetector<P>> EventDetector<P> for Option<D> {
    type Event = D::Event;
    fn detect(&mut self, segment: &mut Segment<'_, P>) -> Vec<Self::Event> {
        match self {
            Some(detector) => detector.detect(segment),
            None => Vec::new(),
        }
    }
}

/// Why continuation could not go on.
#[derive(Debug, thiserror::Error)]
pub enum ContinuationError {
    /// A setting is out of range (`Settings::validate`).
    #[error(transparent)]
    Settings(#[from] SettingsError),
    /// The first point could not be computed: a bad first guess or pin, or its corrector
    /// (docs/method.md eq. (23)) or the problem failed; holds the cause (shown in the message,
    /// so not also chained as a `source`, which would print it twice).
    #[error("the first point did not converge: {0}")]
    FirstPoint(BoxError),
    /// A step failed even at the minimum step size (docs/method.md eq. (24)); holds the last
    /// failure.
    #[error("no convergence at the minimum step ({0})")]
    StepTooSmall(BoxError),
}

/// A boxed cause: the problem's own error type, or a corrector failure wrapping it.
pub type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// Work counters of a continuation.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct ContinuationStats {
    /// Accepted points.
    pub points: usize,
    /// Newton solves, those of event location included.
    pub newton_iterations: usize,
    /// Steps rejected and retried at half the size.
    pub rejected_steps: usize,
    /// Corrector solves spent on locating events.
    pub location_steps: usize,
}

#[cfg(test)]
mod tests;
