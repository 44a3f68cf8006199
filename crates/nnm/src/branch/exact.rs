//! Points placed exactly on given values: the requested energies and frequencies of
//! [`crate::settings::Requests`] (docs/method.md eq. (26b)) and the limit that ends a branch
//! (eq. (26a)).
//!
//! **Why inside the detector, beside the events.** A requested point is located on the
//! segment between two regular points, on the hyperplanes the step itself used (eq. (42)),
//! exactly like an event, and is *inserted* between them in the output. Continuation and
//! event detection stay on the regular points: the step control never sees the inserted
//! point (so the branch is the same with or without requests), and events are detected and
//! located first, on the untouched segment, so an inserted point can neither create nor hide
//! one — a crossing between the inserted point and a regular one is still a crossing between
//! the two regular points, where it is looked for.

use crate::bifurcation::{BifurcationDetector, Event};
use crate::continuation::{ContinuationProblem, Detail, EventDetector, Segment};
use crate::model::MechanicalSystem;
use crate::settings::Settings;
use crate::shooting::{BranchPoint, PointLabel, Shooting};

use super::LIMIT_TOLERANCE;

/// Trial points of a value location are converged to this fraction of the continuation
/// tolerance (as the limit's always were).
const TRIAL_TOLERANCE_FACTOR: f64 = 0.1;
/// Trials allowed to the Illinois iteration on a value (it converges in 4–8 on a smooth
/// branch).
const VALUE_TRIALS: usize = 40;

/// A requested value that has no point on the branch, and why.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MissedRequest {
    /// `at_energy` or `at_frequency`.
    pub label: PointLabel,
    /// The value asked for (J, or rad/s).
    pub value: f64,
    /// Why there is no point on it, in words.
    pub why: String,
}

impl std::fmt::Display for MissedRequest {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let key = match self.label {
            PointLabel::AtFrequency => "at_frequencies",
            _ => "at_energies",
        };
        write!(f, "{key} value {} has no point: {}", self.value, self.why)
    }
}

/// The requested values, each with its kind: what [`ValueDetector`] looks for.
#[derive(Debug, Clone)]
pub(crate) struct Requested {
    pub values: Vec<(PointLabel, f64)>,
}

impl Requested {
    pub fn new(settings: &Settings) -> Self {
        let r = &settings.requests;
        let values = (r.at_energies.iter().map(|&v| (PointLabel::AtEnergy, v)))
            .chain(
                r.at_frequencies
                    .iter()
                    .map(|&v| (PointLabel::AtFrequency, v)),
            )
            .collect();
        Self { values }
    }
}

/// The signed relative distance of `point` to the value `value` of kind `label`.
pub(crate) fn distance(label: PointLabel, value: f64, point: &BranchPoint) -> f64 {
    match label {
        PointLabel::AtFrequency => point.frequency / value - 1.0,
        _ => point.energy / value - 1.0,
    }
}

/// What the branch's detector hands back from a segment, in the order of the branch.
pub(crate) enum Found {
    /// A located bifurcation event.
    Event(Event),
    /// The point exactly on requested value number `request`.
    Exact { point: BranchPoint, request: usize },
    /// A crossing of requested value number `request` whose point could not be computed.
    Failed { request: usize, why: String },
}

/// Events (if detected at all) and requested values, on each new segment.
pub(crate) struct ValueDetector {
    pub events: Option<BifurcationDetector>,
    pub requested: Requested,
}

impl<S: MechanicalSystem + ?Sized> EventDetector<Shooting<'_, S>> for ValueDetector {
    type Event = Found;

    fn detect(&mut self, segment: &mut Segment<'_, Shooting<'_, S>>) -> Vec<Found> {
        // Events first, on the segment exactly as without requests.
        let events = self.events.detect(segment);
        if self.requested.values.is_empty() {
            return events.into_iter().map(Found::Event).collect();
        }
        let mut found: Vec<(f64, Found)> = events
            .into_iter()
            .map(|e| (e.arclength, Found::Event(e)))
            .collect();
        let (a, b) = (segment.previous().1.clone(), segment.next().1.clone());
        let length = segment.length();
        for (request, &(label, value)) in self.requested.values.iter().enumerate() {
            let (ga, gb) = (distance(label, value, &a), distance(label, value, &b));
            // A sign change (false for NaN).
            let crosses = ga * gb < 0.0;
            if !crosses {
                continue;
            }
            let g = |p: &BranchPoint| distance(label, value, p);
            match locate_value(segment, g, (0.0, ga), (length, gb)) {
                Ok((s, mut point)) => {
                    point.label = Some(label);
                    found.push((s, Found::Exact { point, request }));
                }
                Err(why) => found.push((
                    length,
                    Found::Failed {
                        request,
                        why: format!(
                            "its crossing after point {} could not be located ({why})",
                            a.index
                        ),
                    },
                )),
            }
        }
        found.sort_by(|x, y| x.0.total_cmp(&y.0));
        found.into_iter().map(|(_, f)| f).collect()
    }
}

/// The point of `segment` where `g` vanishes, from a bracket `(s0, g0)`, `(s1, g1)` with
/// `g0 g1 < 0`: the Illinois variant of regula falsi on the arclength (docs/method.md eq.
/// (26a)), each trial corrected on the step's hyperplane (eq. (42)) without its Floquet
/// analysis, until `|g| ≤` [`LIMIT_TOLERANCE`]; the point there is then made with everything
/// a branch point carries (stability included). Returns its arclength and the point.
pub(crate) fn locate_value<P: ContinuationProblem<Point = BranchPoint>>(
    segment: &mut Segment<'_, P>,
    g: impl Fn(&BranchPoint) -> f64,
    (mut s0, mut g0): (f64, f64),
    (mut s1, mut g1): (f64, f64),
) -> Result<(f64, BranchPoint), String> {
    let mut last_side = 0;
    for _ in 0..VALUE_TRIALS {
        let s = (s0 * g1 - s1 * g0) / (g1 - g0);
        let trial = segment.point_at(s, Detail::Light, TRIAL_TOLERANCE_FACTOR)?;
        let gs = g(&trial);
        if gs.abs() <= LIMIT_TOLERANCE {
            // The same hyperplane and a start already converged there: no new Newton step.
            let point = segment.point_at(s, Detail::Full, TRIAL_TOLERANCE_FACTOR)?;
            return Ok((s, point));
        }
        // Illinois: halve the stale end's value when the same end is kept twice.
        if gs * g0 > 0.0 {
            (s0, g0) = (s, gs);
            if last_side == -1 {
                g1 *= 0.5;
            }
            last_side = -1;
        } else {
            (s1, g1) = (s, gs);
            if last_side == 1 {
                g0 *= 0.5;
            }
            last_side = 1;
        }
    }
    Err(format!(
        "|g| still above {LIMIT_TOLERANCE:e} after {VALUE_TRIALS} trials"
    ))
}
