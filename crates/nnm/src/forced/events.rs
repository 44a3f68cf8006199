//! Folds and stability changes of a forced response curve, detected between consecutive
//! points and located on the segment (docs/method.md eq. (102)).
//!
//! - A **fold** (turning point in the parameter) is where the parameter's component of the
//!   tangent changes sign; located by the Illinois variant of regula falsi on that component.
//! - A **Neimark–Sacker**, **period-doubling** or **branch-point** bifurcation is where a
//!   complex pair, a real negative or a real positive multiplier leaves (or enters) the unit
//!   circle: the count of multipliers outside it changes. Located on `|μ_c| − 1`, `μ_c` the
//!   multiplier of that kind nearest the circle. A real multiplier crossing `+1` at a fold
//!   is the fold itself, not a separate event.

use crate::continuation::{ContinuationProblem, Detail, EventDetector, Segment};
use crate::linalg::Complex;
use crate::model::MechanicalSystem;

use super::problem::{ForcedShooting, ResponsePoint};

/// What happens at an event.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ResponseEventKind {
    /// A turning point in the continued parameter: the response jumps there in a sweep.
    Fold,
    /// A complex pair of multipliers crosses the unit circle: a quasi-periodic response
    /// branches off.
    NeimarkSacker,
    /// A multiplier crosses `−1`: a response at twice the period branches off.
    PeriodDoubling,
    /// A multiplier crosses `+1` away from a fold: another branch of periodic responses
    /// crosses this one (a symmetry-breaking branch point).
    BranchPoint,
}

impl ResponseEventKind {
    /// The name in output files.
    pub fn name(self) -> &'static str {
        match self {
            ResponseEventKind::Fold => "fold",
            ResponseEventKind::NeimarkSacker => "neimark-sacker",
            ResponseEventKind::PeriodDoubling => "period-doubling",
            ResponseEventKind::BranchPoint => "branch-point",
        }
    }
}

/// A located event.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ResponseEvent {
    /// Its kind.
    pub kind: ResponseEventKind,
    /// The point where it was located (peaks included).
    pub point: ResponsePoint,
    /// The critical multiplier there (for a fold: the real one nearest `+1`).
    pub critical_multiplier: Complex,
}

/// The event detector of forced responses.
#[derive(Debug, Clone, Copy)]
pub struct ResponseEvents {
    /// Relative accuracy of the location, in the parameter (folds) or in `|μ| − 1`.
    pub tolerance: f64,
}

/// Largest number of trial points one event's location may take.
const MAX_TRIALS: usize = 40;

/// Which multipliers a bifurcation kind concerns.
fn of_kind(kind: ResponseEventKind, m: Complex) -> bool {
    let complex = m.1.abs() > 1e-7 * m.0.hypot(m.1);
    match kind {
        ResponseEventKind::NeimarkSacker => complex,
        ResponseEventKind::PeriodDoubling => !complex && m.0 < 0.0,
        ResponseEventKind::BranchPoint | ResponseEventKind::Fold => !complex && m.0 > 0.0,
    }
}

/// `|μ| − 1` of the multiplier of `kind` nearest the unit circle, if any.
fn critical(point: &ResponsePoint, kind: ResponseEventKind) -> Option<(f64, Complex)> {
    point
        .multipliers
        .iter()
        .filter(|m| of_kind(kind, **m))
        .map(|m| (m.0.hypot(m.1) - 1.0, *m))
        .min_by(|a, b| a.0.abs().total_cmp(&b.0.abs()))
}

fn unstable_of_kind(point: &ResponsePoint, kind: ResponseEventKind) -> usize {
    point
        .multipliers
        .iter()
        .filter(|m| of_kind(kind, **m) && m.0.hypot(m.1) > 1.0)
        .count()
}

impl ResponseEvents {
    /// Locates a zero of `value(point)` on the segment by Illinois regula falsi in the
    /// arclength, from its ends' values; stops when `|value| ≤ accuracy` or the bracket is
    /// below `1e-12` of the segment.
    fn locate<P>(
        &self,
        segment: &mut Segment<'_, P>,
        value: impl Fn(&ResponsePoint) -> f64,
        accuracy: f64,
    ) -> Option<ResponsePoint>
    where
        P: ContinuationProblem<Point = ResponsePoint>,
    {
        let length = segment.length();
        let (mut a, mut fa) = (0.0, value(segment.previous().1));
        let (mut b, mut fb) = (length, value(segment.next().1));
        let mut best: Option<ResponsePoint> = None;
        let mut side = 0i8;
        for trial in 0..MAX_TRIALS {
            let s = if fb != fa {
                (a * fb - b * fa) / (fb - fa)
            } else {
                0.5 * (a + b)
            };
            let s = s.clamp(a + 1e-3 * (b - a), b - 1e-3 * (b - a));
            let point = segment.point_at(s, Detail::Light, 0.1).ok()?;
            segment.add_location_steps(1);
            let f = value(&point);
            best = Some(point);
            if f.abs() <= accuracy
                || (b - a).abs() <= 1e-12 * length.abs()
                || trial + 1 == MAX_TRIALS
            {
                break;
            }
            if f.signum() == fa.signum() {
                (a, fa) = (s, f);
                if side == -1 {
                    fb *= 0.5;
                }
                side = -1;
            } else {
                (b, fb) = (s, f);
                if side == 1 {
                    fa *= 0.5;
                }
                side = 1;
            }
        }
        let point = best?;
        // The located point with its peaks.
        let s = point.step;
        segment.point_at(s, Detail::Full, 0.1).ok()
    }
}

impl<S: MechanicalSystem + ?Sized> EventDetector<ForcedShooting<'_, '_, S>> for ResponseEvents {
    type Event = ResponseEvent;

    fn detect(
        &mut self,
        segment: &mut Segment<'_, ForcedShooting<'_, '_, S>>,
    ) -> Vec<ResponseEvent> {
        let mut events = Vec::new();
        let (previous, next) = (segment.previous().1.clone(), segment.next().1.clone());
        let last = previous.tangent.len() - 1;
        let fold = previous.tangent[last].signum() != next.tangent[last].signum();
        if fold {
            // Near the fold the parameter is `p_f + ½κ(s − s_f)²` and the tangent's component
            // `κ(s − s_f)`: a component of `1e-3√tolerance` leaves the point `1e-3√tol/κ`
            // along the curve from the fold — the peak there off by as much, relative, as its
            // slope — and `p` off by `5e-7·tolerance/κ` (scaled units, κ of order one on a
            // resolved curve).
            let accuracy = 1e-3 * self.tolerance.sqrt();
            if let Some(point) = self.locate(segment, |p| p.tangent[last], accuracy) {
                let critical_multiplier =
                    critical(&point, ResponseEventKind::Fold).map_or((1.0, 0.0), |c| c.1);
                events.push(ResponseEvent {
                    kind: ResponseEventKind::Fold,
                    point,
                    critical_multiplier,
                });
            }
        }
        for kind in [
            ResponseEventKind::NeimarkSacker,
            ResponseEventKind::PeriodDoubling,
            ResponseEventKind::BranchPoint,
        ] {
            if kind == ResponseEventKind::BranchPoint && fold {
                continue;
            }
            if unstable_of_kind(&previous, kind) == unstable_of_kind(&next, kind) {
                continue;
            }
            let value = |p: &ResponsePoint| critical(p, kind).map_or(f64::NAN, |c| c.0);
            // Both ends must bracket the crossing (a NaN — no multiplier of the kind — never
            // does).
            let bracketed = value(&previous) * value(&next) < 0.0;
            if !bracketed {
                continue;
            }
            if let Some(point) = self.locate(segment, value, self.tolerance) {
                let critical_multiplier = critical(&point, kind).map_or((f64::NAN, 0.0), |c| c.1);
                events.push(ResponseEvent {
                    kind,
                    point,
                    critical_multiplier,
                });
            }
        }
        events.sort_by(|a, b| a.point.step.total_cmp(&b.point.step));
        events
    }
}
