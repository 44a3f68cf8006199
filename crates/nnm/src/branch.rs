//! Following one branch of nonlinear normal modes end to end: the shooting problem of a
//! [`Start`], continued with bifurcation detection until a limit of [`Settings::limits`],
//! each point and event handed to an [`Observer`] as soon as it is found.
//!
//! This is the loop the command line and the bindings run; a caller who wants another policy
//! drives [`crate::continuation::Continuation`] itself (see `examples/pendulum.rs`).

use std::ops::ControlFlow;

use crate::analysis::Home;
use crate::bifurcation::{BifurcationDetector, Event};
use crate::continuation::{Continuation, ContinuationError, Item, Segment, Solution};
use crate::integrate::IntegrationMethod;
use crate::model::MechanicalSystem;
use crate::settings::{Limits, Settings};
use crate::shooting::{
    BranchPoint, EvaluationProgress, PointLabel, Shooting, ShootingStats, Start,
};

mod exact;
mod hint;

pub use exact::MissedRequest;
use exact::{Found, Requested, ValueDetector};

/// Why a branch ended.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(rename_all = "kebab-case", tag = "reason", content = "detail")]
pub enum StopReason {
    /// A point's energy exceeded `limits.energy_max` (docs/method.md eq. (26)).
    EnergyMax,
    /// `|ω/ω_ref - 1|` exceeded `limits.frequency_shift_max` (docs/method.md eq. (26)).
    FrequencyShiftMax,
    /// The branch reached `limits.max_points` points (docs/method.md eq. (26)).
    MaxPoints,
    /// The observer asked to stop.
    Interrupted,
    /// The corrector failed even at the smallest step.
    StepTooSmall(String),
}

impl std::fmt::Display for StopReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StopReason::EnergyMax => write!(f, "reached energy_max"),
            StopReason::FrequencyShiftMax => write!(f, "reached frequency_shift_max"),
            StopReason::MaxPoints => write!(f, "reached max_points"),
            StopReason::Interrupted => write!(f, "interrupted"),
            StopReason::StepTooSmall(why) => {
                write!(f, "no convergence at the minimum step ({why})")
            }
        }
    }
}

/// Work counters of a branch.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct BranchStats {
    /// Converged points on the branch.
    pub points: usize,
    /// Located events.
    pub events: usize,
    /// Corrector solves spent on locating events.
    pub location_steps: usize,
    /// Newton solves of the corrector, those of event location included.
    pub newton_iterations: usize,
    /// Steps rejected and retried at half the size (corrector failure, turn angle or a
    /// suspicious correction; docs/method.md eq. (25)).
    pub rejected_steps: usize,
    /// Integrations and their work, from the shooting problem.
    pub shooting: ShootingStats,
}

/// A computed branch.
#[derive(Debug, Clone)]
pub struct Branch {
    /// Converged points in the order of the branch, the start's first: the continuation's
    /// steps, and between them the points placed on requested values (their `label` says
    /// which, their `index` is the step's before them); the last one on the limit that
    /// ended the branch, if one did.
    pub points: Vec<BranchPoint>,
    /// Located events, in the order of the branch.
    pub events: Vec<Event>,
    /// Why the continuation ended.
    pub stop: StopReason,
    /// Work counters.
    pub stats: BranchStats,
    /// Linear angular frequency of the starting mode.
    pub omega: f64,
    /// Requested values (`at_energies`, `at_frequencies`) without a point on the branch, and
    /// why (docs/method.md eq. (26b)).
    pub missed_requests: Vec<MissedRequest>,
    /// The integration method the branch ran ([`Shooting::method`]: `auto` resolved for the
    /// model; `None` for an integrator plugged into the shooting problem), which says what a
    /// reciprocity defect of its multipliers means.
    pub integrator: Option<IntegrationMethod>,
}

/// Receives a branch's results as soon as they are found, so that a caller can write them out
/// before the next one is attempted. Either method may stop the continuation by returning
/// `ControlFlow::Break`. A closure `FnMut(&BranchPoint) -> ControlFlow<()>` is an observer that
/// ignores events.
pub trait Observer {
    /// A converged point: a continuation step, or a point placed exactly on a requested
    /// value or on the limit (`label`), in the order of the branch.
    fn point(&mut self, point: &BranchPoint) -> ControlFlow<()>;
    /// A located event; it is reported before the point that follows it.
    fn event(&mut self, _event: &Event) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }
    /// One evaluation of the shooting equations (a Newton iteration or a trial point), for
    /// progress within a point; called from inside the continuation step.
    fn evaluation(&mut self, _progress: &EvaluationProgress) {}
}

impl<F: FnMut(&BranchPoint) -> ControlFlow<()>> Observer for F {
    fn point(&mut self, point: &BranchPoint) -> ControlFlow<()> {
        self(point)
    }
}

/// Follows the branch from `start`, calling `observer` with every converged point as soon as
/// it is found. Events are located all the same (see `events` in [`Settings::stability`]) and
/// returned in the [`Branch`]; [`continue_branch_observed`] also reports them as found.
pub fn continue_branch<S: MechanicalSystem + ?Sized>(
    system: &S,
    start: &Start,
    settings: &Settings,
    observer: impl FnMut(&BranchPoint) -> ControlFlow<()>,
) -> Result<Branch, ContinuationError> {
    continue_branch_observed(system, start, settings, observer)
}

/// Follows the branch from `start`, handing every converged point and located event to
/// `observer` as soon as it is found.
pub fn continue_branch_observed<S: MechanicalSystem + ?Sized>(
    system: &S,
    start: &Start,
    settings: &Settings,
    observer: impl Observer,
) -> Result<Branch, ContinuationError> {
    settings.validate_for(system.dofs())?;
    // The observer hears of evaluations from inside a continuation step and of points
    // between steps, never both at once.
    let observer = std::cell::RefCell::new(observer);
    let mut shooting = start.shooting(system, settings);
    shooting.set_progress(Box::new(|progress| {
        observer.borrow_mut().evaluation(progress);
    }));
    let half_period = shooting.half_period();
    let (u0, pin) = start.first_guess(&shooting);
    let requested = Requested::new(settings);
    let detector = ValueDetector {
        events: settings.stability.events.then_some(BifurcationDetector),
        requested: requested.clone(),
    };
    let mut points: Vec<BranchPoint> = Vec::new();
    let mut events: Vec<Event> = Vec::new();
    let mut missed: Vec<MissedRequest> = Vec::new();
    let mut hit = vec![false; requested.values.len()];
    let limits = &settings.limits;
    // Continuation, the limits and `max_points` go by the regular points; requested points
    // are inserted between them (branch/exact.rs says why).
    let mut regular: Option<BranchPoint> = None;
    let mut regular_points = 0;
    let mut beyond: Option<BranchPoint> = None;
    // Every delivered point's motion is measured (peaks, modal content) and its regime read
    // against the modes the branch calls home, from its first point (docs/method.md
    // §18) — not the trials of steps and locations, which nobody sees.
    let mut home: Option<Home> = None;
    let mut describe = |shooting: &mut Shooting<'_, S>, point: &mut BranchPoint| {
        shooting.measure(point);
        if home.is_none() {
            home = Home::from_first_point(&point.content);
        }
        point.regime = home
            .as_ref()
            .map(|h| h.classify(&point.content, point.frequency));
    };
    let mut continuation =
        Continuation::new(&mut shooting, u0, &pin, &settings.continuation, detector)?;
    let stop = loop {
        let item = match continuation.next() {
            Some(Ok(item)) => item,
            Some(Err(ContinuationError::StepTooSmall(why))) => {
                break StopReason::StepTooSmall(why.to_string());
            }
            Some(Err(ContinuationError::FirstPoint(why))) => {
                let tolerance = settings.continuation.tolerance;
                let why = hint::first_point(why, half_period, tolerance);
                return Err(ContinuationError::FirstPoint(why));
            }
            Some(Err(error)) => return Err(error),
            None => break StopReason::MaxPoints,
        };
        match item {
            Item::Event(Found::Event(event)) => {
                let flow = observer.borrow_mut().event(&event);
                events.push(event);
                if flow.is_break() {
                    break StopReason::Interrupted;
                }
            }
            Item::Event(Found::Exact { mut point, request }) => {
                // On the last segment, a requested point past the limit is not on the branch
                // (one on the limit itself is kept, and then ends it).
                if passed_limit(limits, start.omega, &point)
                    .is_some_and(|(_, g)| g > LIMIT_TOLERANCE)
                {
                    continue;
                }
                hit[request] = true;
                describe(continuation.problem_mut(), &mut point);
                let flow = observer.borrow_mut().point(&point);
                points.push(point);
                if flow.is_break() {
                    break StopReason::Interrupted;
                }
            }
            Item::Event(Found::Failed { request, why }) => {
                let (label, value) = requested.values[request];
                missed.push(MissedRequest { label, value, why });
            }
            Item::Point(mut point) => {
                // A point past a limit is replaced by the point exactly on it (below).
                if let Some((reason, _)) = passed_limit(limits, start.omega, &point)
                    && regular.is_some()
                {
                    beyond = Some(point);
                    break reason;
                }
                describe(continuation.problem_mut(), &mut point);
                let flow = observer.borrow_mut().point(&point);
                let (energy, frequency) = (point.energy, point.frequency);
                let previous = regular.as_ref();
                let cap = previous.and_then(|p| step_to_limits(limits, start.omega, p, &point));
                let spectral = previous.and_then(|p| step_to_invariant_bound(settings, p, &point));
                continuation.cap_next_step([cap, spectral].into_iter().flatten().reduce(f64::min));
                regular = Some(point.clone());
                regular_points += 1;
                points.push(point);
                if flow.is_break() {
                    break StopReason::Interrupted;
                } else if energy > limits.energy_max {
                    break StopReason::EnergyMax;
                } else if (frequency / start.omega - 1.0).abs() > limits.frequency_shift_max {
                    break StopReason::FrequencyShiftMax;
                } else if regular_points >= limits.max_points {
                    break StopReason::MaxPoints;
                }
            }
        }
    };
    let mut counters = continuation.stats();
    drop(continuation);
    if let (Some(next), Some(previous)) = (beyond, regular.as_ref()) {
        // A requested point may already lie on the limit (a request equal to it).
        let on_limit = points
            .last()
            .and_then(|p| limit_distance(limits, start.omega, &stop, p))
            .is_some_and(|g| g.abs() <= LIMIT_TOLERANCE);
        if !on_limit {
            let (exact, iterations) =
                point_on_limit(&mut shooting, settings, start.omega, previous, &next);
            counters.newton_iterations += iterations;
            let mut last = exact.unwrap_or(next);
            describe(&mut shooting, &mut last);
            // The branch stops here whatever the observer answers.
            let _ = observer.borrow_mut().point(&last);
            points.push(last);
        }
    }
    missed.extend(unreached(
        &requested,
        &hit,
        &missed,
        &points,
        settings,
        start.omega,
        &stop,
    ));
    let stats = BranchStats {
        points: points.len(),
        events: events.len(),
        location_steps: counters.location_steps,
        newton_iterations: counters.newton_iterations,
        rejected_steps: counters.rejected_steps,
        shooting: shooting.stats,
    };
    Ok(Branch {
        points,
        events,
        stop,
        stats,
        omega: start.omega,
        missed_requests: missed,
        integrator: shooting.method(),
    })
}

/// The requested values that got no point and were not already reported, each with why:
/// beyond a limit, or outside the range of energies (frequencies) the branch covered.
fn unreached(
    requested: &Requested,
    hit: &[bool],
    reported: &[MissedRequest],
    points: &[BranchPoint],
    settings: &Settings,
    omega: f64,
    stop: &StopReason,
) -> Vec<MissedRequest> {
    let range = |f: fn(&BranchPoint) -> f64| {
        points
            .iter()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            })
    };
    let (e_lo, e_hi) = range(|p| p.energy);
    let (w_lo, w_hi) = range(|p| p.frequency);
    let limits = &settings.limits;
    let shift = limits.frequency_shift_max;
    requested
        .values
        .iter()
        .enumerate()
        .filter(|&(k, &(label, value))| {
            !hit[k] && !reported.iter().any(|m| m.label == label && m.value == value)
        })
        .map(|(_, &(label, value))| {
            let why = match label {
                PointLabel::AtFrequency if (value / omega - 1.0).abs() > shift => format!(
                    "beyond frequency_shift_max = {shift} (|{value}/{omega} - 1| = {:.4})",
                    (value / omega - 1.0).abs()
                ),
                PointLabel::AtFrequency => format!(
                    "outside the frequencies the branch covers, {w_lo:.6} to {w_hi:.6} rad/s (it stopped: {stop})"
                ),
                _ if value > limits.energy_max => {
                    format!("beyond energy_max = {}", limits.energy_max)
                }
                _ => format!(
                    "outside the energies the branch covers, {e_lo:.4e} to {e_hi:.4e} (it stopped: {stop})"
                ),
            };
            MissedRequest { label, value, why }
        })
        .collect()
}

/// The limit `point` has passed, if any, with the signed distance to it `g` (negative before
/// it, positive past it): `E/E_max − 1`, or `|ω/ω_ref − 1| − frequency_shift_max`.
fn passed_limit(limits: &Limits, omega: f64, point: &BranchPoint) -> Option<(StopReason, f64)> {
    [
        (StopReason::EnergyMax, energy_distance(limits, point)),
        (
            StopReason::FrequencyShiftMax,
            frequency_distance(limits, omega, point),
        ),
    ]
    .into_iter()
    .find(|(_, g)| *g > 0.0)
}

/// How far the step after `current` may go so that it ends just past the nearest energy or
/// frequency limit, by the secant of the limit's distance over the last step (docs/method.md
/// eq. (26c)); `None` when no limit lies ahead along the branch.
///
/// Why: a step grown on a smooth branch can carry the last point far past the limit, where
/// it is computed only to be replaced by the point on the limit. That costs its own
/// corrector, and on stiff models more: at 1,000 elements the ECL beam's step from +19.95%
/// went to +28%, where the step-count estimate of the implicit integrator asked for 600 steps
/// a half period, then served the whole placement of the +20% point (200 s of the branch's
/// 300) — where the points before had taken 68.
fn step_to_limits(
    limits: &Limits,
    omega: f64,
    previous: &BranchPoint,
    current: &BranchPoint,
) -> Option<f64> {
    let distances = [
        (limits.energy_max.is_finite()).then(|| {
            (
                energy_distance(limits, previous),
                energy_distance(limits, current),
            )
        }),
        (limits.frequency_shift_max.is_finite()).then(|| {
            (
                frequency_distance(limits, omega, previous),
                frequency_distance(limits, omega, current),
            )
        }),
    ];
    distances
        .into_iter()
        .flatten()
        .filter_map(|(before, now)| {
            let rate = (now - before) / current.step;
            (now < 0.0 && rate > 0.0 && rate.is_finite()).then(|| LIMIT_REACH * (-now / rate))
        })
        .min_by(f64::total_cmp)
}

/// The step that would move the pair invariants by `invariant_step` at the rate the last
/// step moved them (docs/method.md eq. (44c)); `None` without events, without a bound, or
/// where the two analyses do not compare.
fn step_to_invariant_bound(
    settings: &Settings,
    previous: &BranchPoint,
    current: &BranchPoint,
) -> Option<f64> {
    let bound = settings.stability.invariant_step;
    if !settings.stability.events || !bound.is_finite() || current.step <= 0.0 {
        return None;
    }
    let shift = previous.floquet.invariant_shift(&current.floquet)?;
    (shift > bound * 1e-12).then(|| current.step * bound / shift)
}

/// How far past the secant's prediction of a limit (26c) aims, as a multiple of the distance
/// to it: far enough that the step usually passes the limit, so the point on it is found on a
/// short segment, not so far that the point past it is costly.
const LIMIT_REACH: f64 = 1.25;

/// The signed distance of `point` to the limit that ended the branch with `stop`, if a limit
/// did.
fn limit_distance(
    limits: &Limits,
    omega: f64,
    stop: &StopReason,
    point: &BranchPoint,
) -> Option<f64> {
    match stop {
        StopReason::EnergyMax => Some(energy_distance(limits, point)),
        StopReason::FrequencyShiftMax => Some(frequency_distance(limits, omega, point)),
        _ => None,
    }
}

fn energy_distance(limits: &Limits, point: &BranchPoint) -> f64 {
    point.energy / limits.energy_max - 1.0
}

fn frequency_distance(limits: &Limits, omega: f64, point: &BranchPoint) -> f64 {
    (point.frequency / omega - 1.0).abs() - limits.frequency_shift_max
}

/// The point exactly on the limit that `next` has passed (docs/method.md eq. (26a)): on the
/// last step's segment, the arclength `s` where the limit's distance `g(s)` vanishes, found by
/// the Illinois variant of regula falsi from the bracket `g(0) < 0 < g(L)`, each trial
/// corrected on the step's hyperplane like an event's. Returns `None` (the caller keeps
/// `next`) if a trial fails to converge, and the Newton iterations spent.
fn point_on_limit<S: MechanicalSystem + ?Sized>(
    shooting: &mut Shooting<'_, S>,
    settings: &Settings,
    omega: f64,
    previous: &BranchPoint,
    next: &BranchPoint,
) -> (Option<BranchPoint>, usize) {
    let Some((reason, _)) = passed_limit(&settings.limits, omega, next) else {
        return (None, 0);
    };
    let limits = &settings.limits;
    let g = |p: &BranchPoint| match reason {
        StopReason::EnergyMax => energy_distance(limits, p),
        _ => frequency_distance(limits, omega, p),
    };
    let solution = |p: &BranchPoint| Solution {
        index: p.index,
        u: p.unknowns.clone(),
        tangent: p.tangent.clone(),
        step: p.step,
        iterations: p.iterations,
    };
    let (a, b) = (solution(previous), solution(next));
    let mut segment = Segment::new(shooting, (&a, previous), (&b, next), &settings.continuation);
    let (g0, g1) = (g(previous), g(next));
    let mut exact = None;
    if g0 < 0.0 && g1 > 0.0 {
        let length = segment.length();
        exact = exact::locate_value(&mut segment, g, (0.0, g0), (length, g1))
            .ok()
            .map(|(s, mut p)| {
                p.index = next.index;
                p.step = s;
                p.label = Some(match reason {
                    StopReason::EnergyMax => PointLabel::EnergyMax,
                    _ => PointLabel::FrequencyShiftMax,
                });
                p
            });
    }
    let iterations = segment.newton_iterations();
    (exact, iterations)
}

/// How close the last point of a branch stopped by a limit lies to it: `|E/E_max − 1|`, or
/// `||ω/ω_ref − 1| − shift_max|`.
pub const LIMIT_TOLERANCE: f64 = 1e-10;

#[cfg(test)]
mod tests;
