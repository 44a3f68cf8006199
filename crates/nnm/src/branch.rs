//! Following one branch of nonlinear normal modes end to end: the shooting problem of a
//! [`Start`], continued with bifurcation detection until a limit of [`Settings::limits`],
//! each point and event handed to an [`Observer`] as soon as it is found.
//!
//! This is the loop the command line and the bindings run; a caller who wants another policy
//! drives [`crate::continuation::Continuation`] itself (see `examples/pendulum.rs`).

use std::ops::ControlFlow;

use crate::bifurcation::{BifurcationDetector, Event};
use crate::continuation::{Continuation, ContinuationError, Item};
use crate::model::MechanicalSystem;
use crate::settings::Settings;
use crate::shooting::{BranchPoint, EvaluationProgress, ShootingStats, Start};

/// A first point that failed on a half-period problem: the likely cause, a motion that is
/// not half-wave symmetric, is named beside the failure it wraps.
#[derive(Debug, thiserror::Error)]
#[error(
    "{0} (shooting over half a period; set half_period = false if the motion is not half-wave symmetric)"
)]
struct HalfPeriodHint(crate::continuation::BoxError);

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
    /// Converged points in the order of the branch, the start's first.
    pub points: Vec<BranchPoint>,
    /// Located events, in the order of the branch.
    pub events: Vec<Event>,
    /// Why the continuation ended.
    pub stop: StopReason,
    /// Work counters.
    pub stats: BranchStats,
    /// Linear angular frequency of the starting mode.
    pub omega: f64,
}

/// Receives a branch's results as soon as they are found, so that a caller can write them out
/// before the next one is attempted. Either method may stop the continuation by returning
/// `ControlFlow::Break`. A closure `FnMut(&BranchPoint) -> ControlFlow<()>` is an observer that
/// ignores events.
pub trait Observer {
    /// A converged point.
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
    settings.validate()?;
    // The observer hears of evaluations from inside a continuation step and of points
    // between steps, never both at once.
    let observer = std::cell::RefCell::new(observer);
    let mut shooting = start.shooting(system, settings);
    shooting.set_progress(Box::new(|progress| {
        observer.borrow_mut().evaluation(progress);
    }));
    let half_period = shooting.half_period();
    let (u0, pin) = start.first_guess(&shooting);
    let detector = settings.stability.events.then_some(BifurcationDetector);
    let mut points: Vec<BranchPoint> = Vec::new();
    let mut events: Vec<Event> = Vec::new();
    let limits = &settings.limits;
    let mut continuation =
        Continuation::new(&mut shooting, u0, &pin, &settings.continuation, detector)?;
    let stop = loop {
        let item = match continuation.next() {
            Some(Ok(item)) => item,
            Some(Err(ContinuationError::StepTooSmall(why))) => {
                break StopReason::StepTooSmall(why.to_string());
            }
            Some(Err(ContinuationError::FirstPoint(why))) if half_period => {
                return Err(ContinuationError::FirstPoint(Box::new(HalfPeriodHint(why))));
            }
            Some(Err(error)) => return Err(error),
            None => break StopReason::MaxPoints,
        };
        match item {
            Item::Event(event) => {
                let flow = observer.borrow_mut().event(&event);
                events.push(event);
                if flow.is_break() {
                    break StopReason::Interrupted;
                }
            }
            Item::Point(point) => {
                let flow = observer.borrow_mut().point(&point);
                let (energy, frequency) = (point.energy, point.frequency);
                points.push(point);
                if flow.is_break() {
                    break StopReason::Interrupted;
                } else if energy > limits.energy_max {
                    break StopReason::EnergyMax;
                } else if (frequency / start.omega - 1.0).abs() > limits.frequency_shift_max {
                    break StopReason::FrequencyShiftMax;
                } else if points.len() >= limits.max_points {
                    break StopReason::MaxPoints;
                }
            }
        }
    };
    let counters = continuation.stats();
    drop(continuation);
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
    })
}

#[cfg(test)]
mod tests;
