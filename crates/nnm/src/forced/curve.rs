//! One forced response curve end to end: the integrator chosen, the linear first point, the
//! continuation over the sweep with events, the limits that end it, and an observer that sees
//! every point and event as it comes (docs/method.md §19).

use std::ops::ControlFlow;

use crate::continuation::corrector::Limits;
use crate::continuation::{Continuation, ContinuationError, ContinuationSettings, Item};
use crate::integrate::forced::{ForcedCollocation, ForcedIntegrator, ForcedRungeKutta};
use crate::integrate::{
    DOP853, DOPRI5, GAUSS4, GAUSS6, IntegrationMethod, IntegrationSettings, RADAU5, RADAU9,
    Tolerances,
};
use crate::linalg;
use crate::model::{ForcedSystem, MechanicalSystem};
use crate::shooting::Formulation;

use super::events::{ResponseEvent, ResponseEvents};
use super::linear::LinearOperators;
use super::problem::{ForcedShooting, ForcedStats, ResponsePoint, Scales, Sweep};

/// Settings of a forced response curve.
///
/// Serialized flat (the continuation and integration groups' keys beside `events`,
/// `max_points`, `samples`). Deserializing a partial table fills a missing continuation key
/// from [`ContinuationSettings::default`], not from this type's defaults (serde's `flatten`):
/// front ends merge what the user gave over the serialized [`ResponseSettings::default`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct ResponseSettings {
    /// The continuation; steps are absolute in the scaled unknowns (forced/problem.rs), so
    /// the defaults differ from a branch's: first step 0.02, largest 0.1, so that a curve of
    /// a few scaled units gets some fifty points (the turning-angle limit refines peaks and
    /// folds).
    #[serde(flatten)]
    pub continuation: ContinuationSettings,
    /// The integration method and its accuracy.
    #[serde(flatten)]
    pub integration: IntegrationSettings,
    /// Detect and locate folds and bifurcations (default true).
    pub events: bool,
    /// Largest number of points (default 2000).
    pub max_points: usize,
    /// Shoot over half the forcing period when the response is half-wave symmetric — the
    /// internal force odd, or a parity of the model under which the force is odd (default
    /// true; docs/method.md eq. (99b)): halves every integration; the multipliers are the half
    /// map's squared, the full-period symmetry-breaking ones included.
    pub half_period: bool,
    /// Samples of a period for the peaks and the first harmonic (default 32: the first
    /// harmonic is exact for motions without harmonics above the 30th, and each peak is
    /// refined between samples, docs/method.md eq. (87)).
    pub samples: usize,
    /// Dense Jacobian and monodromy, or matrix-free Newton–Krylov with Arnoldi multipliers
    /// (docs/method.md eq. (102a)); default: matrix-free above [`MATRIX_FREE_DOFS`] dofs when
    /// the implicit integrator solves sparse stage systems, dense otherwise.
    pub formulation: Formulation,
}

/// Above this many dofs, [`Formulation::Auto`] shoots forced responses matrix-free. Why here:
/// the dense formulation integrates `2n + 2` sensitivity directions a point, the matrix-free
/// one replays the recorded steps for ~50 products a point whatever `n` (about the rank of the
/// lightly damped modes). Measured by `nnm run`, default settings, the ECL cantilever's first
/// resonance through its two folds (Rayleigh β = 1e-5), dense against matrix-free: 10 dofs
/// 0.31 against 0.36 s, 20 dofs 0.60 against 0.53 s, 38 dofs 1.27 against 0.81 s (the same
/// folds to 2e-10); the 20-element von Kármán beam (57 dofs) 2.65 against 2.60 s.
pub const MATRIX_FREE_DOFS: usize = 16;

impl Default for ResponseSettings {
    fn default() -> Self {
        Self {
            continuation: ContinuationSettings {
                initial_step: 0.02,
                max_step: 0.1,
                ..ContinuationSettings::default()
            },
            integration: IntegrationSettings::default(),
            events: true,
            max_points: 2000,
            half_period: true,
            samples: 32,
            formulation: Formulation::Auto,
        }
    }
}

/// Why a curve ended.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ResponseStop {
    /// The parameter reached the end of the sweep.
    End,
    /// The curve turned back out of the start of the sweep.
    Start,
    /// The point budget ran out.
    MaxPoints,
    /// The observer stopped it (an interrupt).
    Stopped,
    /// The continuation failed (the message says why); the points so far are kept.
    Failed(String),
    /// The curve came back onto itself at this earlier point: it runs round a closed loop,
    /// which the curve from the start of the sweep cannot be (it leaves the linear regime at
    /// both ends), so a step jumped onto an isolated loop of responses.
    Closed(usize),
}

/// What a curve's observer is shown.
pub type ResponseItem = Item<ResponsePoint, ResponseEvent>;

/// A computed curve.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ResponseCurve {
    /// The points in order.
    pub points: Vec<ResponsePoint>,
    /// The located events in order.
    pub events: Vec<ResponseEvent>,
    /// Why it ended.
    pub stop: ResponseStop,
    /// The integration method used.
    pub integrator: &'static str,
    /// The dofs whose peaks the points hold.
    pub output_dofs: Vec<usize>,
    /// The dof of the first harmonic's amplitude and phase.
    pub phase_dof: usize,
    /// Whether it was shot over half the forcing period.
    pub half_period: bool,
    /// Work counters.
    pub stats: ForcedStats,
    /// The continuation's counters.
    pub continuation: crate::continuation::ContinuationStats,
}

/// Why a curve could not start.
#[derive(Debug, thiserror::Error)]
pub enum ResponseError {
    /// The sweep or a setting is out of range (the text says which).
    #[error("{0}")]
    Invalid(String),
    /// The first point did not converge.
    #[error(transparent)]
    Continuation(#[from] ContinuationError),
}

/// Arclength, in steps of the last point, the curve must have run since an earlier point
/// before coming back to it counts as closing (nearer ones are its neighbours).
const CLOSING_ARCLENGTH_IN_STEPS: f64 = 10.0;

/// The index of an earlier point of `path` its last point has come back to (`at` gives a
/// point's unknowns, unit tangent and the step that led there): within the last step of it, moving the same way (tangents
/// within 25°), after at least [`CLOSING_ARCLENGTH_IN_STEPS`] steps of arclength. A curve in
/// `2n + 1` dimensions does not pass that close to itself unless it retraces a loop (a
/// mistuned disk's curve once circled between 2.130 and 2.136 rad/s until its 2,000 points
/// ran out; docs/method.md §19).
pub(super) fn closes<P>(path: &[P], at: impl Fn(&P) -> (&[f64], &[f64], f64)) -> Option<usize> {
    let (last, before) = path.split_last()?;
    let (u, t, step) = at(last);
    let mut arclength = step;
    for (j, earlier) in before.iter().enumerate().rev() {
        let (earlier_u, earlier_t, earlier_step) = at(earlier);
        // The parameter first: one coordinate rules out most points without the distance.
        if arclength > CLOSING_ARCLENGTH_IN_STEPS * step
            && (earlier_u.last()? - u.last()?).abs() < step
            && linalg::distance(earlier_u, u) < step
            && linalg::dot(earlier_t, t) > 0.9
        {
            return Some(j);
        }
        arclength += earlier_step;
    }
    None
}

/// The integrator for `method` (resolved from `auto` at `frequency`): explicit DOP853 for
/// non-stiff models, implicit Radau IIA of order 9 for stiff ones — not Gauss–Legendre,
/// whose `|R(−∞)| = 1` would carry an overdamped stiff mode's multiplier at `−1` instead of
/// `0`. Why order 9 and not 5: a forced curve's steps are set to a hundredth of the
/// tolerance (the response near a lightly damped resonance amplifies the map's error), and
/// there order 5 needed 32–183 steps a period on the ECL beam's curve where order 9 needs
/// 8–19, for 1.7 times the work a step (docs/performance.md).
fn integrator<'s, 'a, S: MechanicalSystem + ?Sized>(
    system: &'s ForcedSystem<'a, S>,
    method: IntegrationMethod,
    frequency: f64,
    tolerances: Tolerances,
) -> (IntegrationMethod, Box<dyn ForcedIntegrator + 's>) {
    let method = match method.resolve(system.system(), frequency) {
        IntegrationMethod::Gauss6 | IntegrationMethod::Radau5 if method.is_auto() => {
            IntegrationMethod::Radau9
        }
        other => other,
    };
    let integrator: Box<dyn ForcedIntegrator + 's> = match method {
        IntegrationMethod::Dop853 | IntegrationMethod::Auto => {
            Box::new(ForcedRungeKutta::new(system, &DOP853, tolerances))
        }
        IntegrationMethod::Dopri5 => Box::new(ForcedRungeKutta::new(system, &DOPRI5, tolerances)),
        IntegrationMethod::Gauss4 => Box::new(ForcedCollocation::new(system, &GAUSS4, tolerances)),
        IntegrationMethod::Gauss6 => Box::new(ForcedCollocation::new(system, &GAUSS6, tolerances)),
        IntegrationMethod::Radau5 => Box::new(ForcedCollocation::new(system, &RADAU5, tolerances)),
        IntegrationMethod::Radau9 => Box::new(ForcedCollocation::new(system, &RADAU9, tolerances)),
    };
    (method, integrator)
}

/// Checks a sweep before anything is computed ([`forced_response`] calls it; front ends call
/// it early, to refuse a job before any curve runs).
// Negated comparisons deliberate: NaN must fail.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub fn check_sweep(sweep: &Sweep) -> Result<(), ResponseError> {
    let invalid = |s: String| Err(ResponseError::Invalid(s));
    let number = crate::number::Number;
    match *sweep {
        Sweep::Frequency {
            from,
            to,
            amplitude,
        } => {
            if !(from > 0.0 && from.is_finite()) {
                return invalid(format!(
                    "frequency_start must be positive, got {}",
                    number(from)
                ));
            }
            if !(to > from && to.is_finite()) {
                return invalid(format!(
                    "frequency_end must exceed frequency_start ({}), got {}",
                    number(from),
                    number(to)
                ));
            }
            if !(amplitude != 0.0 && amplitude.is_finite()) {
                return invalid(format!(
                    "the force amplitude must be non-zero, got {}",
                    number(amplitude)
                ));
            }
        }
        Sweep::Amplitude {
            from,
            to,
            frequency,
        } => {
            if !(frequency > 0.0 && frequency.is_finite()) {
                return invalid(format!(
                    "frequency must be positive, got {}",
                    number(frequency)
                ));
            }
            if !(from > 0.0 && from.is_finite()) {
                return invalid(format!(
                    "the starting amplitude must be positive, got {}",
                    number(from)
                ));
            }
            if !(to > from && to.is_finite()) {
                return invalid(format!(
                    "amplitude_max must exceed the starting amplitude ({}), got {}",
                    number(from),
                    number(to)
                ));
            }
        }
    }
    Ok(())
}

/// The lowest forcing frequency a curve may reach, as a fraction of the model's lowest
/// natural frequency: a period of a thousand of the model's longest. The first point of a
/// damped Duffing oscillator's curve (ζ = 0.01) converged down to `3e-4 ω₁` and its stage
/// equations did not at `1e-4 ω₁`; the command line's two-dof property model's, to `1e-5 ω₁`;
/// at `Ω = 1e-300` rad/s a step of 1e299 s made the stage system singular — after the job's
/// branches had been written. So far below the resonances the motion is the static
/// deflection a linear solve gives.
pub const LOWEST_FREQUENCY_RATIO: f64 = 1e-3;

/// Checks a sweep against the model it drives, before anything is computed: its frequencies
/// at least [`LOWEST_FREQUENCY_RATIO`] of `lowest_natural_frequency` (rad/s; the smallest
/// positive one of the model).
pub fn check_sweep_resolvable(
    sweep: &Sweep,
    lowest_natural_frequency: f64,
) -> Result<(), ResponseError> {
    let floor = LOWEST_FREQUENCY_RATIO * lowest_natural_frequency;
    let number = crate::number::Number;
    let (key, frequency) = match *sweep {
        Sweep::Frequency { from, to, .. } => ("frequency_start", from.min(to)),
        Sweep::Amplitude { frequency, .. } => ("frequency", frequency),
    };
    if frequency < floor {
        return Err(ResponseError::Invalid(format!(
            "{key} {} rad/s is below {} of the model's lowest natural frequency ({} rad/s): a forcing period the integrators cannot resolve",
            number(frequency),
            number(LOWEST_FREQUENCY_RATIO),
            number(lowest_natural_frequency)
        )));
    }
    Ok(())
}

/// The scales of the unknowns: the largest linear response over the sweep (on a grid of
/// frequencies refined at its peak, or at the largest amplitude) as the Euclidean norm of its
/// displacement amplitude, its velocity at the sweep's frequency, and the sweep's width.
///
/// The norm, not the largest entry: the arclength runs over every dof, and a disk whose sixty
/// dofs all move would otherwise see a curve √60 times longer than the plot of one blade shows
/// (210 points instead of about forty on the (1,5) engine-order curve). The amplitude over
/// both phases (`‖X‖`, eq. (98)), not the displacement at `t = 0`: at a lightly damped
/// resonance the response is in quadrature with the force, and its in-phase part peaks a
/// half-power width away at half the amplitude. The peak refined between the grid's
/// frequencies: a resonance narrower than the grid's spacing (the ECL beam's, `Q ≈ 700`:
/// half-power width 0.22 rad/s, grid 0.30 rad/s) would otherwise be seen at a fraction of its
/// height. On the ECL beam's curve the two together doubled the scale (2.7e-3 was the
/// in-phase part on the grid), and the curve took 82 points instead of 100 (eq. (99)).
fn scales(linear: &LinearOperators, sweep: &Sweep) -> Scales {
    let amplitude = |omega: f64, force: f64| {
        let z = linear.response(omega, force);
        let (x0, v0) = z.split_at(z.len() / 2);
        linalg::norm(x0).hypot(linalg::norm(v0) / omega)
    };
    let (displacement, frequency) = match *sweep {
        Sweep::Frequency {
            from,
            to,
            amplitude: force,
        } => {
            const GRID: usize = 200;
            let spacing = (to - from) / GRID as f64;
            let (best, peak) = (0..=GRID)
                .map(|k| from + spacing * k as f64)
                .map(|omega| (omega, amplitude(omega, force)))
                .fold((from, 0.0f64), |a, b| if b.1 > a.1 { b } else { a });
            let refined = golden_section_maximum(
                |omega| amplitude(omega, force),
                ((best - spacing).max(from), (best + spacing).min(to)),
                REFINEMENTS,
            );
            (peak.max(refined), 0.5 * (from + to))
        }
        Sweep::Amplitude { to, frequency, .. } => (amplitude(frequency, to), frequency),
    };
    let displacement = if displacement > 0.0 && displacement.is_finite() {
        displacement
    } else {
        1.0
    };
    let (from, to) = sweep.range();
    Scales {
        displacement,
        velocity: displacement * frequency,
        parameter: to - from,
    }
}

/// Golden-section steps refining the linear response's peak between the scales' grid
/// frequencies: each shrinks the bracket by 0.618, so 40 resolve a peak 1e-8 of the grid's
/// spacing wide.
const REFINEMENTS: usize = 40;

/// The largest value of `f` found by golden-section search for a maximum in `[a, b]` (a local
/// one where `f` is not unimodal there).
fn golden_section_maximum(f: impl Fn(f64) -> f64, (mut a, mut b): (f64, f64), steps: usize) -> f64 {
    let ratio = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - ratio * (b - a), a + ratio * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..steps {
        if fc > fd {
            (b, d, fd) = (d, c, fc);
            c = b - ratio * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + ratio * (b - a);
            fd = f(d);
        }
    }
    // NaN (a singular undamped resonance) is no maximum: `max` passes over it.
    fc.max(fd)
}

/// Computes the forced response of `system` over `sweep`: the periodic responses from the
/// linear one at the start of the sweep to its end, through folds, with their stability and
/// events. `output_dofs`: the dofs whose peaks each point records (empty: the forced dofs);
/// `observer` sees each point and event as it comes and may stop the curve.
pub fn forced_response<S: MechanicalSystem + ?Sized>(
    system: &ForcedSystem<'_, S>,
    sweep: Sweep,
    output_dofs: &[usize],
    settings: &ResponseSettings,
    mut observer: impl FnMut(&ResponseItem) -> ControlFlow<()>,
) -> Result<ResponseCurve, ResponseError> {
    check_sweep(&sweep)?;
    let n = system.dofs();
    if let Some(&d) = output_dofs.iter().find(|&&d| d >= n) {
        return Err(ResponseError::Invalid(format!(
            "output dof {d} is out of range (the model has {n} dofs)"
        )));
    }
    let force = system.force();
    let forced: Vec<usize> = (0..n)
        .filter(|&i| force.cosine[i] != 0.0 || force.sine[i] != 0.0)
        .collect();
    let output_dofs = if output_dofs.is_empty() {
        forced.clone()
    } else {
        output_dofs.to_vec()
    };
    let phase_dof = forced[0];
    let linear = LinearOperators::new(system);
    let scales = scales(&linear, &sweep);
    let (from, _) = sweep.range();
    let drive = sweep.drive(from);
    let tolerances = |relative: f64| Tolerances {
        relative,
        absolute: relative * scales.displacement,
        velocity_scale: drive.frequency,
    };
    let (method, mut integrator) = integrator(
        system,
        settings.integration.integrator,
        drive.frequency,
        tolerances(1.0),
    );
    // The collocation methods' global error estimate is held to a hundredth of the
    // tolerance, not a tenth as on free motions: a fold's frequency moves by the residual's
    // error divided by the curve's small slope there (measured on the Duffing curve: a
    // tenth left the fold 1.7e-8 off, a hundredth 1e-9).
    let relative = if method.is_collocation() {
        0.01 * settings.continuation.tolerance
    } else {
        method.relative_tolerance(
            settings.continuation.tolerance,
            settings.integration.integration_factor,
        )
    };
    integrator.set_tolerances(tolerances(relative));
    let problem = ForcedShooting::new(
        system,
        integrator,
        sweep,
        scales,
        output_dofs.clone(),
        phase_dof,
        settings.samples.max(8),
        settings.continuation.tolerance,
    );
    let half_wave = settings
        .half_period
        .then(|| crate::symmetry::half_wave_signs(system, scales.displacement))
        .flatten();
    let matrix_free = match settings.formulation {
        Formulation::MatrixFree => true,
        Formulation::Dense => false,
        Formulation::Auto => system.dofs() > MATRIX_FREE_DOFS,
    };
    let mut problem = problem
        .with_half_period(half_wave)
        .with_matrix_free(matrix_free);
    let z0 = linear.response(drive.frequency, drive.amplitude);
    problem
        .adapt(&z0, from)
        .map_err(|e| ContinuationError::FirstPoint(e.into()))?;
    let u0 = problem.unknowns(&z0, from);
    problem.hold_rigid_offsets(&linear.rigid_modes(), &u0);
    let detector = settings.events.then_some(ResponseEvents {
        tolerance: settings.continuation.tolerance,
    });
    let mut continuation =
        Continuation::at_parameter(&mut problem, u0, &settings.continuation, detector)?;
    let (mut points, mut events) = (Vec::new(), Vec::new());
    let (start, end) = sweep.range();
    let width = end - start;
    let mut landing_iterations = 0;
    let stop = loop {
        let item = match continuation.next() {
            Some(Ok(item)) => item,
            Some(Err(ContinuationError::FirstPoint(e))) => {
                return Err(ContinuationError::FirstPoint(e).into());
            }
            Some(Err(e)) => break ResponseStop::Failed(e.to_string()),
            None => break ResponseStop::Failed("the continuation ended".into()),
        };
        let parameter = |point: &ResponsePoint| match sweep {
            Sweep::Frequency { .. } => point.frequency,
            Sweep::Amplitude { .. } => point.force_amplitude,
        };
        // A point past the end of the sweep is moved onto it before anyone sees it.
        let item = match item {
            Item::Point(mut point) => {
                if let Some(previous) = points.last()
                    && parameter(&point) > end
                {
                    land_on_end(
                        continuation.problem_mut(),
                        previous,
                        &mut point,
                        end,
                        settings,
                        &mut landing_iterations,
                    );
                }
                Item::Point(point)
            }
            event => event,
        };
        let flow = observer(&item);
        let point = match item {
            Item::Event(event) => {
                events.push(event);
                if flow.is_break() {
                    break ResponseStop::Stopped;
                }
                continue;
            }
            Item::Point(point) => point,
        };
        let p = parameter(&point);
        let tangent = *point.tangent.last().expect("a tangent");
        let z0 = point.z0.clone();
        points.push(point);
        if flow.is_break() {
            break ResponseStop::Stopped;
        }
        if p >= end - 1e-9 * width {
            break ResponseStop::End;
        }
        if p < start - 1e-9 * width {
            break ResponseStop::Start;
        }
        if points.len() >= settings.max_points {
            break ResponseStop::MaxPoints;
        }
        if let Some(earlier) = closes(&points, |p| (&p.unknowns, &p.tangent, p.step)) {
            break ResponseStop::Closed(earlier);
        }
        // Land on the end of the sweep rather than past it (docs/method.md eq. (26c)).
        let cap = (tangent > 0.0).then(|| (end - p) / width / tangent * 1.0000001);
        continuation.cap_next_step(cap);
        if let Err(e) = continuation.problem_mut().adapt(&z0, p) {
            break ResponseStop::Failed(e.to_string());
        }
    };
    let mut continuation_stats = continuation.stats();
    continuation_stats.newton_iterations += landing_iterations;
    drop(continuation);
    Ok(ResponseCurve {
        points,
        events,
        stop,
        integrator: method.name(),
        output_dofs,
        phase_dof,
        half_period: problem.half_period(),
        stats: problem.work(),
        continuation: continuation_stats,
    })
}

/// Replaces a point past the end of the sweep by the point at the end itself: corrected at
/// the fixed parameter from the chord between it and the point before (the cap on the last
/// step lands near the end; the corrector's move along the curve's curvature leaves it a
/// little past). Left as it is if the correction fails.
fn land_on_end<S: MechanicalSystem + ?Sized>(
    problem: &mut ForcedShooting<'_, '_, S>,
    before: &ResponsePoint,
    last: &mut ResponsePoint,
    end: f64,
    settings: &ResponseSettings,
    iterations: &mut usize,
) {
    let m = last.unknowns.len();
    let target = end / problem.scales().parameter;
    let (a, b) = (before.unknowns[m - 1], last.unknowns[m - 1]);
    if b <= target || a >= target {
        return;
    }
    let w = (target - a) / (b - a);
    let mut guess: Vec<f64> = before
        .unknowns
        .iter()
        .zip(&last.unknowns)
        .map(|(x, y)| x + w * (y - x))
        .collect();
    guess[m - 1] = target;
    let mut pin = vec![0.0; m];
    pin[m - 1] = 1.0;
    let Ok(corrected) = crate::continuation::corrector::correct(
        problem,
        &guess,
        &pin,
        &guess,
        Limits::within_steps(
            settings.continuation.tolerance,
            settings.continuation.max_iterations,
            last.step
                .max(linalg::distance(&before.unknowns, &last.unknowns)),
        ),
        iterations,
    ) else {
        return;
    };
    let solution = crate::continuation::Solution {
        index: last.index,
        tangent: crate::continuation::predictor::tangent(&corrected.evaluation, &last.tangent),
        step: last.step,
        u: corrected.u,
        iterations: corrected.iterations,
    };
    use crate::continuation::ContinuationProblem;
    if let Ok(point) = problem.point(
        &solution,
        &corrected.evaluation,
        crate::continuation::Detail::Full,
    ) {
        *last = point;
    }
}
