//! The continuation machinery on problems with exact answers, independent of shooting.

use super::*;

/// `F(x, y) = x² + y² - 1`: the unit circle, one row and two unknowns.
struct Circle {
    evaluations: usize,
    /// Fail every evaluation with `y` above this (to exercise the minimum-step stop).
    wall: f64,
}

#[derive(Debug)]
struct Failed;
impl std::fmt::Display for Failed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "outside the allowed region")
    }
}
impl std::error::Error for Failed {}

struct CircleLinearization {
    residual: [f64; 1],
    gradient: [f64; 2],
}

impl Linearization for CircleLinearization {
    fn residual(&self) -> &[f64] {
        &self.residual
    }
    fn relative_residual(&self) -> f64 {
        self.residual[0].abs()
    }
    fn solve_bordered(&self, border: &[f64], rhs: &[f64], border_rhs: f64) -> Vec<f64> {
        // [g₀ g₁; b₀ b₁] x = [r; c] by Cramer's rule.
        let [g0, g1] = self.gradient;
        let det = g0 * border[1] - g1 * border[0];
        vec![
            (rhs[0] * border[1] - g1 * border_rhs) / det,
            (g0 * border_rhs - border[0] * rhs[0]) / det,
        ]
    }
}

impl ContinuationProblem for Circle {
    type Evaluation = CircleLinearization;
    type Point = (f64, f64);
    type Error = Failed;
    fn dimension(&self) -> usize {
        2
    }
    fn evaluate(&mut self, u: &[f64]) -> Result<CircleLinearization, Failed> {
        self.evaluations += 1;
        if u[1] > self.wall {
            return Err(Failed);
        }
        Ok(CircleLinearization {
            residual: [u[0] * u[0] + u[1] * u[1] - 1.0],
            gradient: [2.0 * u[0], 2.0 * u[1]],
        })
    }
    fn point(
        &mut self,
        solution: &Solution,
        _: &CircleLinearization,
        _: Detail,
    ) -> Result<(f64, f64), Failed> {
        Ok((solution.u[0], solution.u[1]))
    }
    fn amplitude(&self, _u: &[f64]) -> f64 {
        1.0
    }
}

/// Sign changes of `x`, located by bisection on trial points of the segment.
struct CrossesYAxis;

impl EventDetector<Circle> for CrossesYAxis {
    type Event = (f64, f64);
    fn detect(&mut self, segment: &mut Segment<'_, Circle>) -> Vec<(f64, f64)> {
        let (a, b) = (segment.previous().1.0, segment.next().1.0);
        if a * b >= 0.0 {
            return Vec::new();
        }
        let (mut lo, mut hi) = (0.0, segment.length());
        let mut found = (f64::NAN, f64::NAN);
        for _ in 0..50 {
            let mid = 0.5 * (lo + hi);
            found = segment.point_at(mid, Detail::Full, 1e-2).unwrap();
            if found.0 * a > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        segment.add_location_steps(50);
        vec![found]
    }
}

fn settings() -> ContinuationSettings {
    ContinuationSettings {
        tolerance: 1e-12,
        ..ContinuationSettings::default()
    }
}

/// The continuation of the whole circle from (0.95, −0.2), counter-clockwise.
fn around_the_circle<D: EventDetector<Circle>>(
    circle: &mut Circle,
    detector: D,
) -> Continuation<'_, Circle, D> {
    Continuation::new(circle, vec![0.95, -0.2], &[1.0, 0.0], &settings(), detector).unwrap()
}

/// Every point lies on the circle, the branch keeps its direction (counter-clockwise, set by
/// the pin), goes all the way round, and each crossing of the y axis is located at
/// (0, ±1) by trial points corrected on the segment.
#[test]
fn follows_the_unit_circle_and_locates_axis_crossings() {
    let mut circle = Circle {
        evaluations: 0,
        wall: f64::INFINITY,
    };
    let mut continuation = around_the_circle(&mut circle, CrossesYAxis);
    let (mut points, mut events) = (Vec::new(), Vec::new());
    let mut angle = 0.0f64;
    while angle < 2.2 * std::f64::consts::PI {
        match continuation.next().unwrap().unwrap() {
            Item::Point((x, y)) => {
                assert!(
                    (x * x + y * y - 1.0).abs() < 1e-12,
                    "({x}, {y}) off the circle"
                );
                if let Some(&(px, py)) = points.last() {
                    let turn = f64::atan2(px * y - py * x, px * x + py * y);
                    assert!(turn > 0.0 && turn < 0.5, "turned by {turn}");
                    angle += turn;
                }
                points.push((x, y));
            }
            Item::Event(e) => events.push(e),
        }
    }
    let stats = continuation.stats();
    assert_eq!(stats.points, points.len());
    assert!(stats.location_steps >= 100);
    // The first corrector holds the pinned component (x) at its guess.
    assert_eq!(points[0].0, 0.95);
    assert!((points[0].1 + (1.0f64 - 0.95 * 0.95).sqrt()).abs() < 1e-12);
    assert_eq!(events.len(), 2, "{events:?}");
    assert!(events[0].0.abs() < 1e-10 && (events[0].1 - 1.0).abs() < 1e-10);
    assert!(events[1].0.abs() < 1e-10 && (events[1].1 + 1.0).abs() < 1e-10);
}

/// A problem that cannot be evaluated beyond a wall ends with `StepTooSmall` after halving
/// the step down to the minimum, and the iterator is then exhausted.
#[test]
fn ends_at_the_minimum_step_when_the_corrector_keeps_failing() {
    let mut circle = Circle {
        evaluations: 0,
        wall: 0.5,
    };
    let mut continuation = Continuation::new(
        &mut circle,
        vec![0.95, -0.2],
        &[1.0, 0.0],
        &settings(),
        NoEvents,
    )
    .unwrap();
    let mut last = (0.0, 0.0);
    let error = loop {
        match continuation.next().unwrap() {
            Ok(Item::Point(p)) => last = p,
            Ok(Item::Event(e)) => match e {},
            Err(e) => break e,
        }
    };
    assert!(
        matches!(error, ContinuationError::StepTooSmall(_)),
        "{error}"
    );
    assert!(continuation.next().is_none());
    assert!(last.1 <= 0.5 && last.1 > 0.5 - 1e-3, "stopped at {last:?}");
}

/// A zero first guess or a pin without any component is refused before anything is solved.
#[test]
fn refuses_a_degenerate_start() {
    let mut circle = Circle {
        evaluations: 0,
        wall: f64::INFINITY,
    };
    let zero_pin = Continuation::new(
        &mut circle,
        vec![1.0, 0.0],
        &[0.0, 3.0],
        &settings(),
        NoEvents,
    );
    assert!(matches!(zero_pin, Err(ContinuationError::FirstPoint(_))));
    assert_eq!(circle.evaluations, 0);
}

/// A cap bounds the next step only: the point after it lies within the cap of the one before
/// (as a chord of the circle), and the step after that is the step control's again, as large
/// as before the cap.
#[test]
fn a_step_cap_bounds_the_next_step_and_no_other() {
    let mut circle = Circle {
        evaluations: 0,
        wall: f64::INFINITY,
    };
    let mut continuation = around_the_circle(&mut circle, NoEvents);
    let next_point = |c: &mut Continuation<'_, Circle, NoEvents>| match c.next().unwrap().unwrap() {
        Item::Point(p) => p,
        Item::Event(e) => match e {},
    };
    let chord = |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).hypot(a.1 - b.1);
    let mut points: Vec<(f64, f64)> = (0..3).map(|_| next_point(&mut continuation)).collect();
    let uncapped = chord(points[1], points[2]);
    continuation.cap_next_step(Some(0.01));
    points.push(next_point(&mut continuation));
    points.push(next_point(&mut continuation));
    let capped = chord(points[2], points[3]);
    let after = chord(points[3], points[4]);
    // The step is measured along the tangent; the corrected point lies on the circle, a
    // chord of the same length to O(step³).
    assert!((capped / 0.01 - 1.0).abs() < 1e-4, "{capped}");
    assert!(
        uncapped > 0.05 && after >= uncapped,
        "{uncapped} then {after}"
    );
}

/// `F(x, y) = atan x`: Newton converges from `|x| < 1.39` and runs off to ever larger `|x|`
/// beyond, while the residual stays below `π/2` — the divergence a residual test misses.
struct Arctangent {
    evaluations: usize,
}

impl ContinuationProblem for Arctangent {
    type Evaluation = CircleLinearization;
    type Point = ();
    type Error = Failed;
    fn dimension(&self) -> usize {
        2
    }
    fn evaluate(&mut self, u: &[f64]) -> Result<CircleLinearization, Failed> {
        self.evaluations += 1;
        Ok(CircleLinearization {
            residual: [u[0].atan()],
            gradient: [1.0 / (1.0 + u[0] * u[0]), 0.0],
        })
    }
    fn point(&mut self, _: &Solution, _: &CircleLinearization, _: Detail) -> Result<(), Failed> {
        Ok(())
    }
    fn amplitude(&self, _u: &[f64]) -> f64 {
        1.0
    }
}

/// A diverging Newton is stopped as soon as an iterate leaves the reach, after one solve,
/// where without a reach it spends every iteration it is allowed (and ends at |x| ~ 1e84);
/// a converging Newton within the reach is not hampered by it.
#[test]
fn a_diverging_corrector_stops_at_its_reach() {
    use corrector::{CorrectorError, Limits, correct};
    let pin = [0.0, 1.0];
    let run = |x0: f64, limits: Limits| {
        let mut problem = Arctangent { evaluations: 0 };
        let start = [x0, 0.0];
        let mut solves = 0;
        let outcome = correct(&mut problem, &start, &pin, &start, limits, &mut solves);
        (outcome.map(|c| c.u[0]), problem.evaluations)
    };
    let (unbounded, evaluations) = run(2.0, Limits::unbounded(1e-12, 8));
    assert!(
        matches!(unbounded, Err(CorrectorError::NoConvergence { .. })),
        "{unbounded:?}"
    );
    assert_eq!(evaluations, 9);
    let reach = Limits {
        reach: 10.0,
        ..Limits::unbounded(1e-12, 8)
    };
    let (stopped, evaluations) = run(2.0, reach);
    // 2 → −3.54 → 13.95: the second iterate is 11.95 from the start.
    assert!(
        matches!(stopped, Err(CorrectorError::OutOfReach { distance, .. }) if distance > 10.0),
        "{stopped:?}"
    );
    assert_eq!(evaluations, 2);
    let (converged, _) = run(0.5, reach);
    assert!(converged.unwrap().abs() < 1e-12);
}
