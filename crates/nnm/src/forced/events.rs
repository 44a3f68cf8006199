//! Folds and stability changes of a forced response curve, detected between consecutive
//! points and located on the segment (docs/method.md eq. (102)).
//!
//! - A **fold** (turning point in the parameter) is where the parameter's component of the
//!   tangent changes sign; located on that component, the first trial where the cubic
//!   through the segment's ends turns, the others by regula falsi (Anderson–Björck).
//! - A **Neimark–Sacker**, **period-doubling** or **branch-point** bifurcation is where a
//!   complex pair, a real negative or a real positive multiplier leaves (or enters) the unit
//!   circle: the count of multipliers outside it changes. Located on `|μ_c| − 1`, `μ_c` the
//!   multiplier of that kind nearest the circle. A real multiplier crossing `+1` at a fold
//!   is the fold itself, not a separate event.
//! - A **phase resonance** is where the first harmonic of the response at the phase dof lags
//!   the force by a quarter period (`φ = π/2`, eq. (113)): the peak of a lightly damped
//!   single-mode resonance, on the backbone to second order in the damping. Located on
//!   `φ − π/2` with trial points that measure the motion (the phase is not known otherwise).

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
    /// The response's first harmonic lags the force by `π/2` (eq. (113)).
    PhaseResonance,
}

impl ResponseEventKind {
    /// The name in output files.
    pub fn name(self) -> &'static str {
        match self {
            ResponseEventKind::Fold => "fold",
            ResponseEventKind::NeimarkSacker => "neimark-sacker",
            ResponseEventKind::PeriodDoubling => "period-doubling",
            ResponseEventKind::BranchPoint => "branch-point",
            ResponseEventKind::PhaseResonance => "phase-resonance",
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
    /// The critical multiplier there (for a fold: the real one nearest `+1`; for a phase
    /// resonance: the largest in modulus, which says whether it is stable).
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
        ResponseEventKind::PhaseResonance => true,
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

/// Where the cubic through two points of a curve `p(s)`, with their values and slopes,
/// turns between them (eq. (102c)): `a = (s, p, dp/ds)` and `b` likewise, the slopes of
/// opposite signs. The derivative of the Hermite cubic on `[s_a, s_b]` is the quadratic
/// `q(θ) = m_a + Bθ + Cθ²` with `q(1) = m_b` and mean `(p_b − p_a)/h`: `C = 3(m_a + m_b) −
/// 6(p_b − p_a)/h`, `B = m_b − m_a − C`; its one root in `(0, 1)` (`q(0) q(1) < 0`). `None`
/// if rounding puts it outside.
fn hermite_turn(a: (f64, f64, f64), b: (f64, f64, f64)) -> Option<f64> {
    let h = b.0 - a.0;
    let (ma, mb) = (a.2, b.2);
    let c = 3.0 * (ma + mb) - 6.0 * (b.1 - a.1) / h;
    let bq = mb - ma - c;
    let inside = |theta: f64| (0.0..=1.0).contains(&theta).then_some(a.0 + theta * h);
    if c.abs() <= 1e-12 * bq.abs() {
        return inside(-ma / bq);
    }
    let discriminant = bq * bq - 4.0 * c * ma;
    if discriminant < 0.0 {
        return None;
    }
    // The roots `q/C` and `m_a/q` without cancellation.
    let q = -0.5 * (bq + bq.signum() * discriminant.sqrt());
    [q / c, ma / q]
        .into_iter()
        .find_map(|theta| inside(theta).filter(|s| s.is_finite()))
}

/// What a location is of: a zero of a function of the point that changes sign across the
/// segment, or a fold — the zero of the parameter's tangent component, whose first trial is
/// the turn of the cubic through the segment's ends ([`hermite_turn`]).
enum Located<'a> {
    Zero(&'a dyn Fn(&ResponsePoint) -> f64),
    Turn,
}

impl ResponseEvents {
    /// Locates a zero of `located` on the segment, from its ends' values: a fold's first
    /// trial by eq. (102c), every other trial by regula falsi in the arclength with the
    /// Anderson–Björck modification. Stops when `|value| ≤ accuracy` or the bracket is
    /// below four billionths of the segment. `trials`: what the trial points measure (the
    /// multipliers always; the motion too when the located value needs it).
    fn locate<P>(
        &self,
        segment: &mut Segment<'_, P>,
        located: Located<'_>,
        accuracy: f64,
        trials: Detail,
    ) -> Option<ResponsePoint>
    where
        P: ContinuationProblem<Point = ResponsePoint>,
    {
        let length = segment.length();
        let last = segment.previous().0.tangent.len() - 1;
        let value = |point: &ResponsePoint| match &located {
            Located::Zero(value) => value(point),
            Located::Turn => point.tangent[last],
        };
        let (mut a, mut fa) = (0.0, value(segment.previous().1));
        let (mut b, mut fb) = (length, value(segment.next().1));
        // The cubic's turn from each end's parameter and its slope `dp/ds = t_p/(t · t₀)`
        // (the tangents are unit and `s` is measured along the first end's, `t₀`).
        let turn = match located {
            Located::Turn => {
                let direction = &segment.previous().0.tangent;
                let end = |point: &ResponsePoint, s: f64| {
                    let along = crate::linalg::dot(&point.tangent, direction);
                    (s, point.unknowns[last], point.tangent[last] / along)
                };
                hermite_turn(end(segment.previous().1, a), end(segment.next().1, b))
            }
            Located::Zero(_) => None,
        };
        // Trials are kept off the bracket's ends by a billionth of the segment, not by a
        // fraction of the bracket: a fold 3.7e-7 from a trial, in a bracket still reaching the
        // segment's far end, took a trial 4.5e-5 away at a thousandth of the bracket. A bracket
        // of a few margins ends the location: the value's own noise is what is left to chase
        // (on the 10⁴-dof von Kármán curve the bracket closed before `accuracy` was met).
        let margin = 1e-9 * length.abs();
        let mut best: Option<ResponsePoint> = None;
        let mut side = 0i8;
        for trial in 0..MAX_TRIALS {
            if best.is_some() && b - a <= 4.0 * margin {
                break;
            }
            // A fold's first trial is the cubic's turn; later ones are regula falsi on the
            // tangent component: on a bracket that short the parameter's change along it is
            // of the order of the corrector's error in it, and the cubic follows that noise
            // (on the ECL beam's upper fold, trials then halved the component each time).
            let s = match turn.filter(|_| trial == 0) {
                Some(s) => s,
                None if fb != fa => (a * fb - b * fa) / (fb - fa),
                None => 0.5 * (a + b),
            };
            let s = if b - a > 2.0 * margin {
                s.clamp(a + margin, b - margin)
            } else {
                0.5 * (a + b)
            };
            let point = segment.point_at(s, trials, 0.1).ok()?;
            segment.add_location_steps(1);
            let f = value(&point);
            best = Some(point);
            if f.abs() <= accuracy || trial + 1 == MAX_TRIALS {
                break;
            }
            // Anderson–Björck: an end kept twice in a row has its value scaled by `1 − f/f'`
            // (`f'` the value the new trial replaces; a half if that is not positive), so
            // that the next secant reaches past the trials crowding the other end.
            let scale = |replaced: f64| {
                let m = 1.0 - f / replaced;
                if m > 0.0 { m } else { 0.5 }
            };
            if f.signum() == fa.signum() {
                if side == -1 {
                    fb *= scale(fa);
                }
                (a, fa) = (s, f);
                side = -1;
            } else {
                if side == 1 {
                    fa *= scale(fb);
                }
                (b, fb) = (s, f);
                side = 1;
            }
        }
        let point = best?;
        // The located point with its peaks, corrected to a hundredth of the tolerance: a
        // fold's parameter is where the response jumps, and the trials' tenth left it off by
        // up to 4e-9 relative (the half-period Duffing curve's upper fold against its
        // whole-period one, which a trial more had happened to tighten).
        let s = point.step;
        segment.point_at(s, Detail::Full, 0.01).ok()
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
            if let Some(point) = self.locate(segment, Located::Turn, accuracy, Detail::Light) {
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
            if let Some(point) = self.locate(
                segment,
                Located::Zero(&value),
                self.tolerance,
                Detail::Light,
            ) {
                let critical_multiplier = critical(&point, kind).map_or((f64::NAN, 0.0), |c| c.1);
                events.push(ResponseEvent {
                    kind,
                    point,
                    critical_multiplier,
                });
            }
        }
        // Phase resonance: `φ − π/2` changes sign continuously. The lag is kept in
        // `(−π/2, 3π/2]`: where it wraps, at `−π/2` (a response in phase opposition with its
        // force beyond an antiresonance), `φ − π/2` jumps from `−π` to `π` — no crossing.
        // Located to `tolerance` in the phase: near a resonance of damping ratio ζ the phase
        // moves by `~1/ζ` per relative frequency, so the frequency is placed to
        // `ζ · tolerance`.
        let quadrature = |p: &ResponsePoint| p.phase_lag - std::f64::consts::FRAC_PI_2;
        let (before, after) = (quadrature(&previous), quadrature(&next));
        if before * after < 0.0
            && (after - before).abs() < std::f64::consts::PI
            && let Some(point) = self.locate(
                segment,
                Located::Zero(&quadrature),
                self.tolerance,
                Detail::Full,
            )
        {
            let critical_multiplier = point.multipliers.first().copied().unwrap_or((0.0, 0.0));
            events.push(ResponseEvent {
                kind: ResponseEventKind::PhaseResonance,
                point,
                critical_multiplier,
            });
        }
        events.sort_by(|a, b| a.point.step.total_cmp(&b.point.step));
        events
    }
}

#[cfg(test)]
mod tests {
    use super::hermite_turn;

    /// The cubic through two points with their slopes is exact for a cubic: its turn is the
    /// root of `p'` itself — `p = s³/3 − s/4` turns at `s = 1/2`; the quadratic `p = −(s −
    /// 0.3)²` (the cubic's leading coefficient zero) at 0.3; and on a shifted, scaled bracket.
    #[test]
    fn hermite_turn_is_exact_for_cubics() {
        let cubic = |s: f64| (s * s * s / 3.0 - 0.25 * s, s * s - 0.25);
        let end = |f: &dyn Fn(f64) -> (f64, f64), s: f64| (s, f(s).0, f(s).1);
        let turn = hermite_turn(end(&cubic, 0.0), end(&cubic, 1.0)).unwrap();
        assert!((turn - 0.5).abs() < 1e-15, "{turn}");
        let quadratic = |s: f64| (-(s - 0.3) * (s - 0.3), -2.0 * (s - 0.3));
        let turn = hermite_turn(end(&quadratic, 0.0), end(&quadratic, 1.0)).unwrap();
        assert!((turn - 0.3).abs() < 1e-15, "{turn}");
        let turn = hermite_turn(end(&cubic, -0.2), end(&cubic, 0.9)).unwrap();
        assert!((turn - 0.5).abs() < 1e-14, "{turn}");
        // A descending turn (a maximum) from the other side.
        let negative = |s: f64| (-cubic(s).0, -cubic(s).1);
        let turn = hermite_turn(end(&negative, 0.1), end(&negative, 2.0)).unwrap();
        assert!((turn - 0.5).abs() < 1e-14, "{turn}");
    }
}
