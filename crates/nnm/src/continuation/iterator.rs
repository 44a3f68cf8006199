//! The continuation loop as an iterator of points and events.

use std::collections::VecDeque;

use super::corrector::{Corrected, Limits, correct};
use super::predictor::{predict, predict_curved, tangent};
use super::step::StepControl;
use super::{
    BoxError, ContinuationError, ContinuationProblem, ContinuationSettings, ContinuationStats,
    Detail, EventDetector, Solution,
};
use crate::linalg;

/// What the iterator yields: points in branch order, each event just before the point that
/// follows it.
#[derive(Debug, Clone)]
pub enum Item<P, E> {
    /// A converged, accepted point.
    Point(P),
    /// A located event, yielded just before the point that follows it.
    Event(E),
}

enum State {
    /// The first guess and the (unit) direction whose component the first corrector pins.
    NotStarted {
        u0: Vec<f64>,
        pin: Vec<f64>,
    },
    Running,
    Finished,
}

/// Pseudo-arclength continuation of `problem` (docs/method.md §5), one point per
/// [`Iterator::next`]. The iterator never ends by itself while points converge: the caller
/// stops it (limits, an interrupt, a budget). After an error it yields `None`.
pub struct Continuation<'p, P: ContinuationProblem, D: EventDetector<P>> {
    problem: &'p mut P,
    detector: D,
    settings: ContinuationSettings,
    control: Option<StepControl>,
    /// The largest arclength the next step may take (set by the caller between steps).
    cap: Option<f64>,
    /// The last accepted solution and its point.
    current: Option<(Solution, P::Point)>,
    /// The tangent of the solution accepted before `current` (for the curvature of the
    /// second-order predictor, eq. (21a)).
    previous_tangent: Option<Vec<f64>>,
    queue: VecDeque<Item<P::Point, D::Event>>,
    state: State,
    stats: ContinuationStats,
}

impl<'p, P: ContinuationProblem, D: EventDetector<P>> Continuation<'p, P, D> {
    /// Continuation from the first guess `u0`; the first corrector holds the component of `u`
    /// along `pin` (last component ignored) fixed, which pins the amplitude (otherwise Newton
    /// may slide to a trivial solution, docs/method.md eq. (23)).
    pub fn new(
        problem: &'p mut P,
        u0: Vec<f64>,
        pin: &[f64],
        settings: &ContinuationSettings,
        detector: D,
    ) -> Result<Self, ContinuationError> {
        let m = u0.len();
        if m != problem.dimension() || pin.len() != m {
            return Err(ContinuationError::FirstPoint(
                format!(
                    "the first guess has {m} unknowns, the problem {}",
                    problem.dimension()
                )
                .into(),
            ));
        }
        if problem.amplitude(&u0) == 0.0 {
            return Err(ContinuationError::FirstPoint(
                "the starting state is zero".into(),
            ));
        }
        let mut pin = pin.to_vec();
        pin[m - 1] = 0.0;
        let norm = linalg::norm(&pin);
        if norm.is_nan() || norm == 0.0 {
            return Err(ContinuationError::FirstPoint(
                "the starting direction has no component in the unknowns".into(),
            ));
        }
        pin.iter_mut().for_each(|x| *x /= norm);
        Ok(Self::from_pin(problem, u0, pin, settings, detector))
    }

    /// Continuation from the first guess `u0` whose first corrector holds the parameter-like
    /// last component of `u` fixed, and whose branch leaves it towards increasing values: a
    /// forced response starts at a given frequency or force amplitude (the response there is
    /// unique near the linear one, so nothing can slide).
    pub fn at_parameter(
        problem: &'p mut P,
        u0: Vec<f64>,
        settings: &ContinuationSettings,
        detector: D,
    ) -> Result<Self, ContinuationError> {
        let m = u0.len();
        if m != problem.dimension() {
            return Err(ContinuationError::FirstPoint(
                format!(
                    "the first guess has {m} unknowns, the problem {}",
                    problem.dimension()
                )
                .into(),
            ));
        }
        let mut pin = vec![0.0; m];
        pin[m - 1] = 1.0;
        Ok(Self::from_pin(problem, u0, pin, settings, detector))
    }

    fn from_pin(
        problem: &'p mut P,
        u0: Vec<f64>,
        pin: Vec<f64>,
        settings: &ContinuationSettings,
        detector: D,
    ) -> Self {
        Self {
            problem,
            detector,
            settings: settings.clone(),
            control: None,
            cap: None,
            current: None,
            previous_tangent: None,
            queue: VecDeque::new(),
            state: State::NotStarted { u0, pin },
            stats: ContinuationStats::default(),
        }
    }

    /// Work counters so far.
    pub fn stats(&self) -> ContinuationStats {
        self.stats
    }

    /// The problem (e.g. for its own work counters).
    pub fn problem(&self) -> &P {
        self.problem
    }

    /// The problem, to measure what a delivered point needs beyond the continuation (between
    /// steps: the continuation's own state is not touched).
    pub fn problem_mut(&mut self) -> &mut P {
        self.problem
    }

    /// Bounds the next step's arclength by `cap` (`None`: no bound), without changing what
    /// the step control has learnt: the caller shortens a step that would carry the branch
    /// far past a limit it must end on (docs/method.md eq. (26c)).
    pub fn cap_next_step(&mut self, cap: Option<f64>) {
        self.cap = cap.filter(|c| *c > 0.0 && c.is_finite());
    }

    /// The last accepted solution.
    pub fn current(&self) -> Option<&Solution> {
        self.current.as_ref().map(|(s, _)| s)
    }

    fn first_point(&mut self, u0: Vec<f64>, pin: Vec<f64>) -> Result<P::Point, ContinuationError> {
        let settings = &self.settings;
        let first = correct(
            self.problem,
            &u0,
            &pin,
            &u0,
            Limits::unbounded(settings.tolerance, settings.max_iterations),
            &mut self.stats.newton_iterations,
        )
        .map_err(|e| ContinuationError::FirstPoint(e.into()))?;
        let solution = Solution {
            index: 0,
            tangent: tangent(&first.evaluation, &pin),
            u: first.u,
            step: 0.0,
            iterations: first.iterations,
        };
        let point = self
            .problem
            .point(&solution, &first.evaluation, Detail::Full)
            .map_err(|e| ContinuationError::FirstPoint(e.into()))?;
        self.control = Some(StepControl::new(settings, self.problem.amplitude(&u0)));
        self.accept(solution, point.clone());
        Ok(point)
    }

    fn accept(&mut self, solution: Solution, point: P::Point) {
        self.problem.accept(&point);
        self.stats.points += 1;
        let replaced = self.current.replace((solution, point));
        self.previous_tangent = replaced.map(|(s, _)| s.tangent);
    }

    /// One step along the branch: retried at smaller steps until a point is accepted, or an
    /// error at the minimum step.
    fn advance(&mut self) -> Result<(), ContinuationError> {
        let mut control = self.control.take().expect("started");
        let result = self.advance_with(&mut control);
        self.control = Some(control);
        result
    }

    fn advance_with(&mut self, control: &mut StepControl) -> Result<(), ContinuationError> {
        let settings = self.settings.clone();
        let (previous, _) = self.current.as_ref().expect("started");
        let (u, t) = (previous.u.clone(), previous.tangent.clone());
        let bend = self
            .previous_tangent
            .clone()
            .filter(|_| self.problem.second_order_predictor())
            .map(|t0| (t0, previous.step));
        let index = previous.index + 1;
        let cap = self.cap.take();
        loop {
            let q = self.problem.amplitude(&u);
            let step = control.next(q);
            let at_minimum = control.at_minimum(q);
            // A cap shortens the step, not below the minimum (a failure there still ends the
            // branch), and the step control keeps its own step for the steps after.
            let step = cap.map_or(step, |cap| step.min(cap.max(control.minimum(q))));
            // The corrector starts from the curved prediction, on the hyperplane through the
            // straight one (eq. (22)): the step's arclength is measured as before.
            let anchor = predict(&u, &t, step);
            let predicted =
                predict_curved(&u, &t, bend.as_ref().map(|(t0, l)| (&t0[..], *l)), step);
            // The smallest step is the branch's last chance: its corrector may go anywhere.
            let limits = if at_minimum {
                Limits::unbounded(settings.tolerance, settings.max_iterations)
            } else {
                Limits::within_steps(settings.tolerance, settings.max_iterations, step)
            };
            let outcome = correct(
                self.problem,
                &predicted,
                &t,
                &anchor,
                limits,
                &mut self.stats.newton_iterations,
            );
            // A failure is retried at half the step, or ends the branch at the minimum step.
            let mut retry = |why: BoxError, stats: &mut ContinuationStats| {
                if at_minimum {
                    return Err(ContinuationError::StepTooSmall(why));
                }
                stats.rejected_steps += 1;
                control.reject();
                Ok(())
            };
            let corrected: Corrected<P::Evaluation> = match outcome {
                Ok(c) => c,
                Err(why) => {
                    retry(why.into(), &mut self.stats)?;
                    continue;
                }
            };
            // A corrector that converged slowly or far from the prediction may have landed on
            // a neighbouring branch (tangents there can be parallel, so the angle test alone
            // misses it): retry with a smaller step. On a smooth branch the correction is
            // ~κs²/2, below s/4 whenever the turn-angle test passes.
            let correction = linalg::distance(&corrected.u, &predicted);
            let suspicious = correction > 0.5 * step
                || corrected.iterations > 2 * settings.target_iterations.max(1);
            let t_new = tangent(&corrected.evaluation, &t);
            let turned = linalg::dot(&t_new, &t) < settings.max_turn_angle.cos();
            if (suspicious || turned) && !at_minimum {
                retry("slow or turning step".into(), &mut self.stats)?;
                continue;
            }
            let solution = Solution {
                index,
                u: corrected.u,
                tangent: t_new,
                step,
                iterations: corrected.iterations,
            };
            let point = match self
                .problem
                .point(&solution, &corrected.evaluation, Detail::Full)
            {
                Ok(p) => p,
                Err(why) => {
                    retry(why.into(), &mut self.stats)?;
                    continue;
                }
            };
            control.accept(solution.iterations);
            let (previous, previous_point) = self.current.as_ref().expect("started");
            let mut segment = Segment::new(
                self.problem,
                (previous, previous_point),
                (&solution, &point),
                &settings,
            );
            let events = self.detector.detect(&mut segment);
            self.stats.newton_iterations += segment.newton_iterations;
            self.stats.location_steps += segment.location_steps;
            self.queue.extend(events.into_iter().map(Item::Event));
            self.queue.push_back(Item::Point(point.clone()));
            self.accept(solution, point);
            return Ok(());
        }
    }
}

impl<P: ContinuationProblem, D: EventDetector<P>> Iterator for Continuation<'_, P, D> {
    type Item = Result<Item<P::Point, D::Event>, ContinuationError>;

    fn next(&mut self) -> Option<Self::Item> {
        if let Some(item) = self.queue.pop_front() {
            return Some(Ok(item));
        }
        let result = match std::mem::replace(&mut self.state, State::Running) {
            State::Finished => {
                self.state = State::Finished;
                return None;
            }
            State::NotStarted { u0, pin } => self.first_point(u0, pin).map(Item::Point),
            State::Running => self.advance().map(|()| {
                self.queue
                    .pop_front()
                    .expect("an accepted step queues its point")
            }),
        };
        if result.is_err() {
            self.state = State::Finished;
        }
        Some(result)
    }
}

/// The stretch of branch between two consecutive points, handed to an [`EventDetector`]:
/// its ends, and trial points corrected on it.
pub struct Segment<'s, P: ContinuationProblem> {
    problem: &'s mut P,
    previous: &'s Solution,
    previous_point: &'s P::Point,
    next: &'s Solution,
    next_point: &'s P::Point,
    settings: &'s ContinuationSettings,
    /// Solutions found on the segment so far, by arclength from `previous`.
    known: Vec<(f64, Vec<f64>)>,
    newton_iterations: usize,
    location_steps: usize,
}

impl<'s, P: ContinuationProblem> Segment<'s, P> {
    /// The segment between two consecutive solutions of `problem` (each with its point).
    pub fn new(
        problem: &'s mut P,
        previous: (&'s Solution, &'s P::Point),
        next: (&'s Solution, &'s P::Point),
        settings: &'s ContinuationSettings,
    ) -> Self {
        let mut segment = Segment {
            problem,
            previous: previous.0,
            previous_point: previous.1,
            next: next.0,
            next_point: next.1,
            settings,
            known: vec![(0.0, previous.0.u.clone())],
            newton_iterations: 0,
            location_steps: 0,
        };
        segment.known.push((segment.length(), next.0.u.clone()));
        segment
    }

    /// Newton iterations spent on trial points so far.
    pub fn newton_iterations(&self) -> usize {
        self.newton_iterations
    }

    /// The first end: its solution and point.
    pub fn previous(&self) -> (&Solution, &P::Point) {
        (self.previous, self.previous_point)
    }

    /// The second end.
    pub fn next(&self) -> (&Solution, &P::Point) {
        (self.next, self.next_point)
    }

    /// The arclength of the second end along the first's tangent (the step, to round-off).
    pub fn length(&self) -> f64 {
        self.previous
            .tangent
            .iter()
            .zip(self.next.u.iter().zip(&self.previous.u))
            .map(|(t, (a, b))| t * (a - b))
            .sum()
    }

    /// The step scale at the first end.
    pub fn amplitude(&self) -> f64 {
        self.problem.amplitude(&self.previous.u)
    }

    /// The problem being continued, read-only (e.g. to map a tangent to state space).
    pub fn problem(&self) -> &P {
        self.problem
    }

    /// Counts corrector solves an event location spent (reported in the statistics).
    pub fn add_location_steps(&mut self, steps: usize) {
        self.location_steps += steps;
    }

    /// The point at arclength `s` from the first end: corrected on the hyperplane
    /// `t₀ · (u - u₀ - s t₀) = 0` (the one the step itself used) to `tolerance_factor` times
    /// the continuation tolerance (falling back to the tolerance itself), starting from the
    /// line through the two nearest solutions found on the segment so far — late trials then
    /// start within the corrector's own accuracy, and cannot converge onto a crossing family.
    pub fn point_at(
        &mut self,
        s: f64,
        detail: Detail,
        tolerance_factor: f64,
    ) -> Result<P::Point, String> {
        let (u0, t0) = (&self.previous.u, &self.previous.tangent);
        self.known
            .sort_by(|a, b| (a.0 - s).abs().total_cmp(&(b.0 - s).abs()));
        let ((sa, ua), (sb, ub)) = (&self.known[0], &self.known[1]);
        let w = if sb != sa { (s - sa) / (sb - sa) } else { 0.0 };
        let guess: Vec<f64> = ua.iter().zip(ub).map(|(a, b)| a + w * (b - a)).collect();
        let anchor = predict(u0, t0, s);
        let settings = self.settings;
        // A step taken at the minimum (where its corrector may go anywhere) can end far
        // from its tangent's arclength: the reach covers the chord between the ends too.
        let length = (self.length().abs()).max(linalg::distance(&self.next.u, &self.previous.u));
        let mut solve = |tolerance: f64| {
            correct(
                self.problem,
                &guess,
                t0,
                &anchor,
                Limits::within_steps(tolerance, settings.max_iterations, length),
                &mut self.newton_iterations,
            )
        };
        let corrected = solve(tolerance_factor * settings.tolerance)
            .or_else(|_| solve(settings.tolerance))
            .map_err(|e| e.to_string())?;
        self.known.push((s, corrected.u.clone()));
        let solution = Solution {
            index: self.previous.index,
            tangent: tangent(&corrected.evaluation, t0),
            u: corrected.u,
            step: s,
            iterations: corrected.iterations,
        };
        self.problem
            .point(&solution, &corrected.evaluation, detail)
            .map_err(|e| e.to_string())
    }
}
