//! Event location between two points of a branch (docs/method.md §8): the continuation
//! calls [`BifurcationDetector`] with each new segment, and the detector corrects trial points
//! on it through [`Segment::point_at`].

use super::{Crossing, Event, detect, hidden, multiplicity, test_function, unexplained};
use crate::continuation::{Detail, EventDetector, Segment};
use crate::model::MechanicalSystem;
use crate::shooting::{BranchPoint, Shooting};

/// Detects folds, branch points, period doublings and Krein collisions between consecutive
/// points of a branch of periodic motions and locates each one. Collisions undone inside a
/// step (docs/method.md eq. (44a)) are seen only on a [`Shooting`] built with events on in its
/// stability settings: only then does its Floquet analysis give the Krein signatures.
#[derive(Debug, Clone, Copy, Default)]
pub struct BifurcationDetector;

impl<S: MechanicalSystem + ?Sized> EventDetector<Shooting<'_, S>> for BifurcationDetector {
    type Event = Event;

    fn detect(&mut self, segment: &mut Segment<'_, Shooting<'_, S>>) -> Vec<Event> {
        locate_events(segment)
    }
}

/// Relative arclength accuracy to which events are located (relative to `‖q‖`): energies
/// then come out to about twice that.
const EVENT_ARCLENGTH_TOLERANCE: f64 = 1e-8;
/// Trial points of a location are converged to this fraction of the continuation tolerance.
const EVENT_TRIAL_TOLERANCE_FACTOR: f64 = 1e-2;
/// How many times a step is halved to separate crossings that no test function brackets.
const REFINE_DEPTH: usize = 2;
/// How many times a step is halved where the multipliers' pattern changes more than its
/// detected crossings explain (`unexplained`): events whose count changes cancel within one
/// step are separated by then (the (1,14) backbone's fold and Krein collision 0.0076 apart in
/// energy, on a step spanning both). Measured on the whole study: depth 3 finds 294 events in
/// 63 s, depth 5 finds 352 in 71 s (29.5 s and 278 events without this refinement, some of
/// them spurious or misplaced).
const UNEXPLAINED_DEPTH: usize = 3;
/// How many times a step is halved where pairs of opposite Krein signatures changed places
/// in it ([`hidden`]): a collision and its undoing inside the step, found once a half holds
/// the quadruplet at one of its ends.
const HIDDEN_DEPTH: usize = 4;
/// Trials allowed to the secant location (it converges in 5–12 on a simple root).
const SECANT_TRIALS: usize = 20;
/// Relative arclength bracket to which an event without a usable test function is placed by
/// bisection (about 18 halvings of a largest step).
const EVENT_BRACKET_TOLERANCE: f64 = 1e-6;
/// Trials allowed to the bisection fallback.
const BISECTION_TRIALS: usize = 24;
/// Distance, as a fraction of the step, on either side of a located event at which its test
/// function must have opposite signs (docs/method.md eq. (43a), "Verification"), and by
/// which a bracket found by bisection is widened before the test function is tried on it.
const VERIFICATION_WINDOW: f64 = 1e-3;

/// Detects the events between the ends of `segment` and locates each one; every trial is a
/// point at arclength `s` from the first end ([`Segment::point_at`]).
fn locate_events<S: MechanicalSystem + ?Sized>(
    segment: &mut Segment<'_, Shooting<'_, S>>,
) -> Vec<Event> {
    let previous = segment.previous().1.clone();
    let next = segment.next().1.clone();
    let h = segment.length();
    let q = segment.amplitude();
    let tolerance = EVENT_ARCLENGTH_TOLERANCE * q;
    // Trial points are converged further than branch points (EVENT_TRIAL_TOLERANCE_FACTOR):
    // near a branch point the corrector's Jacobian is nearly singular, and a residual at the
    // continuation tolerance leaves an error along the null direction that shifts the test
    // function (seen as a 2e-6 shift of the two-DOF branch point on the full-period
    // problem). The integration accuracy (`integration_factor × tolerance`) leaves room.
    let mut trial_point = |s: f64, with_floquet: bool| -> Result<BranchPoint, String> {
        let detail = if with_floquet {
            Detail::Full
        } else {
            Detail::Light
        };
        segment.point_at(s, detail, EVENT_TRIAL_TOLERANCE_FACTOR)
    };
    let brackets = |crossing: Crossing, a: &BranchPoint, b: &BranchPoint| {
        let value = |p: &BranchPoint| test_function(crossing, p).map(|(f, _)| f);
        matches!((value(a), value(b)), (Some(fa), Some(fb)) if fa * fb < 0.0)
    };
    // Steps in which some change has no test function bracketing it (typically several pairs
    // crossing in one step) are halved, up to REFINE_DEPTH times, so that each crossing gets
    // a sub-interval of its own.
    type End = (f64, BranchPoint);
    let mut pending: Vec<(End, End, usize)> = vec![((0.0, previous.clone()), (h, next.clone()), 0)];
    let mut work: Vec<(End, End, Crossing)> = Vec::new();
    let mut refinements = 0;
    while let Some((a, b, depth)) = pending.pop() {
        let crossings = detect(&a.1, &b.1);
        let unbracketed = crossings.iter().any(|&c| !brackets(c, &a.1, &b.1));
        let refine = (unbracketed && depth < REFINE_DEPTH)
            || (unexplained(&a.1, &b.1, &crossings) && depth < UNEXPLAINED_DEPTH)
            || (depth < HIDDEN_DEPTH && hidden(&a.1, &b.1));
        if refine {
            let mid = 0.5 * (a.0 + b.0);
            if let Ok(m) = trial_point(mid, true) {
                refinements += 1;
                pending.push(((mid, m.clone()), b, depth + 1));
                pending.push((a, (mid, m), depth + 1));
                continue;
            }
        }
        work.extend(crossings.into_iter().map(|c| (a.clone(), b.clone(), c)));
    }
    let mut located = Vec::new();
    let mut location_steps = 0;
    for ((sa, a), (sb, b), crossing) in work {
        let value = |p: &BranchPoint| test_function(crossing, p).map(|(f, _)| f);
        let width = sb - sa;
        let window = VERIFICATION_WINDOW * width;
        let mut trials = 0;
        let trial = &mut trial_point;
        let check = Check {
            origin: sa,
            width,
            window,
            tolerance,
            crossing,
        };
        let direct = match (value(&a), value(&b)) {
            (Some(f0), Some(f1)) if f0 * f1 < 0.0 => {
                check.locate(trial, (0.0, f0), (width, f1), &mut trials)
            }
            _ => None,
        };
        let result = match direct {
            Some(found) => Some(found),
            None => {
                // No verified root on the whole step: bisect on which side's pattern of
                // multipliers a trial shares, to the width of the verification window, then
                // try the test function on that bracket widened by the window; only a change
                // that is then placed without a root is bisected on, to its own tolerance.
                let past =
                    |p: &BranchPoint| detect(&a, p).iter().any(|c| c.kind() == crossing.kind());
                let coarse = bisect(
                    width,
                    window.max(EVENT_BRACKET_TOLERANCE * q),
                    BISECTION_TRIALS,
                    |x| trial(sa + x, true).map(|p| (past(&p), p)),
                );
                match coarse {
                    Err(_) => None,
                    Ok(coarse) => {
                        trials += coarse.trials;
                        let lo = (coarse.arclength - coarse.uncertainty - window).max(0.0);
                        let hi = (coarse.arclength + window).min(width);
                        let ends = check.probe(trial, lo, &mut trials).and_then(|f_lo| {
                            check.probe(trial, hi, &mut trials).map(|f_hi| (f_lo, f_hi))
                        });
                        let located = match ends {
                            Ok((Some(f_lo), Some(f_hi))) if f_lo * f_hi < 0.0 => {
                                check.locate(trial, (lo, f_lo), (hi, f_hi), &mut trials)
                            }
                            // The pattern changes there, but the test function keeps its
                            // sign across: not this kind of event (two real pairs merging
                            // off the circle while a fold's pair returns to it, say).
                            Ok((Some(_), Some(_))) => {
                                location_steps += trials;
                                continue;
                            }
                            _ => None,
                        };
                        located.or_else(|| {
                            if coarse.uncertainty <= EVENT_BRACKET_TOLERANCE * q {
                                return Some(coarse);
                            }
                            // Placed by the pattern alone: on to the bracket tolerance inside
                            // the coarse bracket (whose upper end is the change's side).
                            let start = coarse.arclength - coarse.uncertainty;
                            let fine = bisect(
                                coarse.uncertainty,
                                EVENT_BRACKET_TOLERANCE * q,
                                BISECTION_TRIALS,
                                |x| trial(sa + start + x, true).map(|p| (past(&p), p)),
                            );
                            Some(match fine {
                                Ok(fine) => {
                                    trials += fine.trials;
                                    let at = start + fine.arclength;
                                    fine.with_arclength(at)
                                }
                                Err(_) => coarse,
                            })
                        })
                    }
                }
            }
        };
        let located_point = match result {
            Some(found) => {
                let summary = (
                    sa + found.arclength,
                    found.uncertainty,
                    trials,
                    found.converged,
                );
                if crossing.needs_floquet() {
                    Ok((found.payload, summary))
                } else {
                    // A fold's trials skip the Floquet analysis: do it once at the result.
                    trial_point(summary.0, true).map(|p| (p, summary))
                }
            }
            None => Err(String::new()),
        };
        // A detected event whose location failed is still reported, at the end of its
        // interval, with the whole interval as its uncertainty.
        let (point, (arclength, uncertainty, trials, converged)) =
            located_point.unwrap_or_else(|_| (b.clone(), (sb, width.abs(), trials, false)));
        location_steps += trials;
        located.push((crossing, arclength, uncertainty, trials, converged, point));
    }
    segment.add_location_steps(location_steps + refinements);
    let mut located: Vec<Event> = located
        .into_iter()
        .map(
            |(crossing, arclength, uncertainty, trials, converged, point)| {
                let multiplier = test_function(crossing, &point).map_or((1.0, 0.0), |(_, m)| m);
                Event {
                    kind: crossing.kind(),
                    after: previous.index,
                    arclength,
                    arclength_uncertainty: uncertainty,
                    multiplicity: multiplicity(crossing, &point),
                    multiplier,
                    location_steps: trials,
                    converged,
                    state_tangent: segment.problem().initial_state(&point.tangent),
                    period_rate: point.tangent[point.tangent.len() - 1]
                        * segment.problem().period_ref(),
                    point,
                }
            },
        )
        .collect();
    located.sort_by(|a, b| a.arclength.total_cmp(&b.arclength));
    located
}

/// The zero of `f` on `[0, h]` given `f(0) = f0` and `f(h) = fh` of opposite signs, by the
/// Illinois variant of regula falsi (superlinear, and the bracket always shrinks). `f` returns
/// its value and whatever the caller wants to keep from the last trial. Stops when the bracket
/// or the last move is below `tolerance` (the second is what ends it once `f` is down to its
/// round-off, where the signs no longer shrink the bracket), or after `max_trials`.
pub(crate) fn illinois<T>(
    h: f64,
    f0: f64,
    fh: f64,
    tolerance: f64,
    max_trials: usize,
    mut f: impl FnMut(f64) -> Result<(f64, T), String>,
) -> Result<Located<T>, String> {
    let (mut a, mut fa, mut b, mut fb) = (0.0, f0, h, fh);
    let mut history = vec![(0.0, f0), (h, fh)];
    for trial in 1..=max_trials {
        let mut s = b - fb * (b - a) / (fb - fa);
        let (lo, hi) = (a.min(b), a.max(b));
        if !(s > lo && s < hi) {
            s = 0.5 * (a + b);
        }
        let (fs, payload) = f(s)?;
        history.push((s, fs));
        let moved = (s - b).abs();
        if fs * fb < 0.0 {
            (a, fa) = (b, fb);
        } else {
            fa *= 0.5;
        }
        (b, fb) = (s, fs);
        let width = (b - a).abs();
        // Where the next trial would go: a move below the tolerance ends the location here,
        // one trial early (that trial would only confirm it).
        let next = b - fb * (b - a) / (fb - fa);
        let moved = if next > a.min(b) && next < a.max(b) {
            moved.min((next - b).abs())
        } else {
            moved
        };
        if fs == 0.0 || width < tolerance || moved < tolerance || trial == max_trials {
            return Ok(Located {
                arclength: s,
                payload,
                uncertainty: if fs == 0.0 { 0.0 } else { width.min(moved) },
                trials: trial,
                // A root drives `f` to its round-off; a jump of the test function (a sign
                // change without a zero) leaves it at the size of the jump.
                // It must also have stopped on its tolerance, not on the trial limit.
                converged: fs.abs() <= 1e-3 * f0.abs().max(fh.abs())
                    && (fs == 0.0 || width < tolerance || moved < tolerance),
                history,
            });
        }
    }
    Err("no trial was made".into())
}

/// Bisection of `[0, h]` on a yes/no question whose answer is "no" at 0 and "yes" at `h`:
/// returns the first "yes" trial once the bracket is narrower than `tolerance`.
pub(crate) fn bisect<T>(
    h: f64,
    tolerance: f64,
    max_trials: usize,
    mut is_past: impl FnMut(f64) -> Result<(bool, T), String>,
) -> Result<Located<T>, String> {
    let (mut a, mut b) = (0.0, h);
    let mut best = None;
    for trial in 1..=max_trials {
        let s = 0.5 * (a + b);
        let (past, payload) = is_past(s)?;
        if past {
            b = s;
            best = Some((s, payload));
        } else {
            a = s;
        }
        if (b - a).abs() < tolerance || trial == max_trials {
            let Some((arclength, payload)) = best else {
                return Err("the change was not seen inside the step".into());
            };
            return Ok(Located {
                arclength,
                payload,
                uncertainty: (b - a).abs(),
                trials: trial,
                // Placed where the pattern of the multipliers changes (to the bracket), not
                // at a zero of a test function.
                converged: false,
                history: Vec::new(),
            });
        }
    }
    Err("no trial was made".into())
}

/// One crossing's location on a step: its test function probed and its root checked.
struct Check {
    /// Arclength of the step's first end.
    origin: f64,
    width: f64,
    window: f64,
    tolerance: f64,
    crossing: Crossing,
}

impl Check {
    /// The test function at `x` from the step's first end (`None`: not defined there).
    fn probe(
        &self,
        trial: &mut impl FnMut(f64, bool) -> Result<BranchPoint, String>,
        x: f64,
        trials: &mut usize,
    ) -> Result<Option<f64>, String> {
        *trials += 1;
        let p = trial(self.origin + x, true)?;
        Ok(test_function(self.crossing, &p).map(|(f, _)| f))
    }

    /// A root of the test function between `lo` and `hi` (values of opposite signs) by
    /// Illinois, kept only if the test function has opposite signs a window either side of
    /// it: a zero the function touches without crossing (two invariants meeting on the circle
    /// and parting again), or a zero of a function patched from different pairs across a
    /// long step, is no event.
    fn locate(
        &self,
        trial: &mut impl FnMut(f64, bool) -> Result<BranchPoint, String>,
        (lo, f_lo): (f64, f64),
        (hi, f_hi): (f64, f64),
        trials: &mut usize,
    ) -> Option<Located<BranchPoint>> {
        let crossing = self.crossing;
        let found = illinois(hi - lo, f_lo, f_hi, self.tolerance, SECANT_TRIALS, |x| {
            let p = trial(self.origin + lo + x, crossing.needs_floquet())?;
            let f = test_function(crossing, &p)
                .ok_or("the critical pair vanished")?
                .0;
            Ok((f, p))
        })
        .ok()?;
        *trials += found.trials;
        if !found.converged {
            return None;
        }
        let at = lo + found.arclength;
        // A simple root: the function crosses it linearly, so the slopes `f / (s − s*)` seen
        // from either side agree; a jump (the nearest pairs changing identity) or a zero
        // touched without crossing does not. The secant's own trials nearest the root on
        // each side serve when they are within the window (most often); else two probes.
        let root = found.arclength;
        let side = |sign: f64| {
            found
                .history
                .iter()
                .filter(|(s, _)| {
                    let d = (s - root) * sign;
                    d > 10.0 * self.tolerance && d <= self.window
                })
                .min_by(|x, y| (x.0 - root).abs().total_cmp(&(y.0 - root).abs()))
                .map(|&(s, f)| f / (s - root))
        };
        let slopes = match (side(-1.0), side(1.0)) {
            (Some(before), Some(after)) => (before, after),
            _ => {
                let before = self
                    .probe(trial, (at - self.window).max(0.0), trials)
                    .ok()??;
                let after = self
                    .probe(trial, (at + self.window).min(self.width), trials)
                    .ok()??;
                (-before / self.window, after / self.window)
            }
        };
        let ratio = slopes.1 / slopes.0;
        (ratio > 1.0 / 3.0 && ratio < 3.0).then_some(found.with_arclength(at))
    }
}

pub(crate) struct Located<T> {
    pub arclength: f64,
    pub payload: T,
    pub uncertainty: f64,
    pub trials: usize,
    pub converged: bool,
    /// The `(arclength, value)` of every evaluation (Illinois: the ends, then each trial).
    pub history: Vec<(f64, f64)>,
}

impl<T> Located<T> {
    /// The same result at arclength `s` (a location on a sub-interval, moved to the step's
    /// own origin).
    fn with_arclength(self, s: f64) -> Self {
        Self {
            arclength: s,
            ..self
        }
    }
}
