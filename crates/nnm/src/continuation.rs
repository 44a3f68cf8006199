//! Pseudo-arclength continuation of a branch of periodic motions (SPEC §2).
//!
//! In the unknowns `u = (q, τ)` of [`Shooting`]:
//! - **predictor** `u_pred = u_j + s_j t_j`, with `t_j` the unit tangent, the null vector of the
//!   shooting Jacobian `J`, obtained from the bordered system `[J; t_{j-1}ᵀ] t = [0; 1]` so
//!   that its orientation follows the previous one;
//! - **corrector**: Newton on `[shooting rows; t_jᵀ (u - u_pred)] = 0`, an overdetermined
//!   system (energy conservation makes one periodicity row redundant) solved by least squares;
//! - **convergence**: `‖H‖ / ‖z0‖ < eps`;
//! - **step control**: the step grows when the corrector converges in few iterations, shrinks
//!   when it needs many, and a step is retried at half size when the corrector fails or the
//!   tangent turns by more than the allowed angle.
//!
//! The first point has no predictor; its corrector keeps the projection of `q` on the starting
//! linear mode fixed, which pins the amplitude (otherwise Newton slides to the trivial
//! zero-amplitude solution, SPEC §7).

use std::ops::ControlFlow;

use crate::bifurcation::{self, Crossing, Event};
use crate::floquet::{self, DEFAULT_STABILITY_TOLERANCE, Floquet};
use crate::integrate::{DOP853, IntegrationError, Tableau};
use crate::linalg::{self, Mat};
use crate::model::{SecondOrderSystem, Structure};
use crate::modes::LinearMode;
use crate::shooting::{
    Evaluation, JacobianMethod, PhaseCondition, Shooting, ShootingSettings, ShootingStats,
};
use crate::symmetry::{Parity, invariant_class, is_odd, sample_states};

/// Continuation settings. `Default` gives the values documented on each field.
#[derive(Debug, Clone)]
pub struct Settings {
    /// Convergence tolerance `eps` on `‖H‖/‖z0‖` (default 1e-8).
    pub tolerance: f64,
    /// Stop once a point's energy exceeds this (default +∞).
    pub energy_max: f64,
    /// Stop after this many points (default 500).
    pub max_points: usize,
    /// Stop once `frequency / linear frequency - 1` exceeds this in magnitude (default +∞).
    pub frequency_shift_max: f64,
    /// First step, relative to the starting amplitude `‖q0‖` (default 0.1).
    pub initial_step: f64,
    /// Smallest step, relative to `‖q‖`, before giving up (default 1e-6).
    pub min_step: f64,
    /// Largest step, relative to `‖q‖` (default 0.25: energy grows by at most ~60% a step,
    /// which keeps a frequency-energy plot resolved).
    pub max_step: f64,
    /// Newton iterations allowed per step (default 8).
    pub max_iterations: usize,
    /// Corrector iterations the step control aims at (default 3).
    pub target_iterations: usize,
    /// Largest angle between consecutive tangents, radians (default 0.5 ≈ 29°).
    pub max_turn_angle: f64,
    /// Tolerance on `|μ| - 1` for stability (default [`DEFAULT_STABILITY_TOLERANCE`]).
    pub stability_tolerance: f64,
    pub phase: PhaseCondition,
    pub jacobian: JacobianMethod,
    pub tableau: &'static Tableau,
    /// Integrator relative tolerance as a fraction of `tolerance` (default 1e-3: the
    /// integration error must sit well below the periodicity residual we converge to).
    pub integration_factor: f64,
    /// Shoot over half a period when the system is odd (checked at sample states; default
    /// true). Every point's full-period residual is still checked.
    pub half_period: bool,
    /// Detect folds, branch points, period doublings and Krein collisions between
    /// consecutive points and locate them ([`crate::bifurcation`]; default true).
    pub events: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            tolerance: 1e-8,
            energy_max: f64::INFINITY,
            max_points: 500,
            frequency_shift_max: f64::INFINITY,
            initial_step: 0.1,
            min_step: 1e-6,
            max_step: 0.25,
            max_iterations: 8,
            target_iterations: 3,
            max_turn_angle: 0.5,
            stability_tolerance: DEFAULT_STABILITY_TOLERANCE,
            phase: PhaseCondition::ZeroVelocity,
            jacobian: JacobianMethod::Sensitivity,
            tableau: &DOP853,
            integration_factor: 1e-3,
            half_period: true,
            events: true,
        }
    }
}

/// Where a branch starts: the space of allowed initial displacements and a first guess.
#[derive(Debug, Clone)]
pub struct Start {
    /// Elastic basis `B` (`n × r`, column-major, mass-orthonormal): all elastic modes, the
    /// first `unknown_columns` spanning the subspace the branch lives in.
    pub basis: Vec<f64>,
    /// `M B`.
    pub mass_basis: Vec<f64>,
    /// How many leading columns of `basis` carry the shooting unknowns.
    pub unknown_columns: usize,
    /// The mirror-symmetry class the unknowns were restricted to, if any.
    pub symmetry: Option<Parity>,
    /// Modal amplitude at which the nonlinear forces equal the linear ones along the starting
    /// mode: the amplitude unit of the continuation (see `ShootingSettings::amplitude_scale`).
    pub amplitude_scale: f64,
    /// Reference (linear) angular frequency of the branch.
    pub omega: f64,
    /// Initial guess of `z0` (length 2n).
    pub z0: Vec<f64>,
    /// Initial guess of the period.
    pub period: f64,
    /// Whether half-period shooting may be used (when the system is odd and the settings
    /// allow it); false for a branch that breaks the half-wave symmetry.
    pub half_period: bool,
    /// State direction (length 2n) whose projection the first corrector holds fixed, and
    /// along which the branch sets off; `None`: `z0` itself (the starting mode's amplitude).
    pub pin: Option<Vec<f64>>,
    /// Phase condition required by this start, overriding the settings' (a switched branch
    /// whose motions are never at rest everywhere at once needs
    /// [`PhaseCondition::FlowOrthogonal`]).
    pub phase: Option<PhaseCondition>,
}

/// Why a branch could not be started.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ContinuationError {
    #[error("mode {0} is a rigid-body mode: it has no nonlinear normal mode")]
    RigidMode(usize),
    #[error("mode index {index} out of range (the model has {count} modes)")]
    NoSuchMode { index: usize, count: usize },
    #[error("invalid setting: {0}")]
    InvalidSetting(String),
    #[error("the first point did not converge: {0}")]
    FirstPoint(String),
}

impl Start {
    /// Starts on linear mode `index` scaled to the linear energy `energy`; when `energy` is
    /// `None`, at the amplitude where the nonlinear forces are 1e-4 of the linear ones (so
    /// the first point is nearly linear whatever the units of the model). When the structure
    /// has a verified mirror symmetry, the unknowns are restricted to the invariant class of
    /// the starting mode ([`crate::symmetry`]); [`Start::unrestricted`] undoes that.
    pub fn from_linear_mode(
        structure: &Structure,
        modes: &[LinearMode],
        index: usize,
        energy: Option<f64>,
    ) -> Result<Self, ContinuationError> {
        let mode = modes.get(index).ok_or(ContinuationError::NoSuchMode {
            index,
            count: modes.len(),
        })?;
        if mode.rigid {
            return Err(ContinuationError::RigidMode(index));
        }
        let n = structure.dofs();
        // Rigid-body modes are left out of the unknowns only when the nonlinear forces leave
        // them alone; otherwise they are kept like any other mode.
        let amplitude_scale = weakly_nonlinear_amplitude(structure, &mode.shape, 1.0);
        let decoupled = rigid_modes_decouple(structure, modes, amplitude_scale);
        let kept = |k: usize| !modes[k].rigid || !decoupled;
        // Kept modes, those of the starting mode's invariant class first.
        let class = if decoupled {
            invariant_class(structure, modes, index, amplitude_scale)
        } else {
            None
        };
        let mut order: Vec<usize> = match &class {
            Some((_, members)) => members.clone(),
            None => (0..modes.len()).filter(|&k| kept(k)).collect(),
        };
        let unknown_columns = order.len();
        let rest: Vec<usize> = (0..modes.len())
            .filter(|k| kept(*k) && !order.contains(k))
            .collect();
        order.extend(rest);
        let basis: Vec<f64> = order.iter().flat_map(|&k| modes[k].shape.clone()).collect();
        let mass_basis: Vec<f64> = basis
            .chunks(n)
            .flat_map(|shape| linalg::times(structure.mass().as_ref(), shape))
            .collect();
        let amplitude = match energy {
            Some(e) if e.is_finite() && e > 0.0 => (2.0 * e).sqrt() / mode.frequency,
            Some(e) => {
                return Err(ContinuationError::InvalidSetting(format!(
                    "start energy must be positive, got {e}"
                )));
            }
            None => weakly_nonlinear_amplitude(structure, &mode.shape, 1e-4),
        };
        let mut z0 = vec![0.0; 2 * n];
        for (z, s) in z0.iter_mut().zip(&mode.shape) {
            *z = amplitude * s;
        }
        Ok(Self {
            basis,
            mass_basis,
            unknown_columns,
            symmetry: class.map(|(parity, _)| parity),
            amplitude_scale,
            omega: mode.frequency,
            z0,
            period: 2.0 * std::f64::consts::PI / mode.frequency,
            half_period: true,
            pin: None,
            phase: None,
        })
    }
}

impl Start {
    /// The shooting problem of a branch from this start: its unknowns, scales and settings
    /// (half-period shooting only for odd systems under the zero-velocity phase condition).
    pub fn shooting<'a, S: SecondOrderSystem + ?Sized>(
        &self,
        system: &'a S,
        settings: &Settings,
    ) -> Shooting<'a, S> {
        let phase = self.phase.unwrap_or(settings.phase);
        let shooting_settings = ShootingSettings {
            phase,
            jacobian: settings.jacobian,
            tableau: settings.tableau,
            tolerance: settings.tolerance,
            integration_factor: settings.integration_factor,
            amplitude_scale: self.amplitude_scale,
            half_period: self.half_period
                && settings.half_period
                && phase == PhaseCondition::ZeroVelocity
                && is_odd(system, self.amplitude_scale),
        };
        Shooting::new(
            system,
            self.basis.clone(),
            self.mass_basis.clone(),
            self.unknown_columns,
            self.omega,
            &shooting_settings,
        )
    }

    /// The same start with the unknowns spanning every elastic mode (no symmetry restriction).
    pub fn unrestricted(mut self) -> Self {
        self.unknown_columns = self.basis.len() / (self.z0.len() / 2);
        self.symmetry = None;
        self
    }
}

/// Whether every rigid-body mode `u` decouples from the nonlinear forces:
/// `f_nl(x + c u) = f_nl(x)` and `uᵀ f_nl(x) = 0` at sample states (true of forces that depend
/// on differences of displacements, as in a free-floating structure). Only then is a rigid
/// shift periodic for every period and a rigid velocity a pure drift, so that the rigid modes
/// can be removed from the shooting unknowns and from the Floquet analysis.
fn rigid_modes_decouple(structure: &Structure, modes: &[LinearMode], amplitude: f64) -> bool {
    let n = structure.dofs();
    let samples = sample_states(n, amplitude);
    modes.iter().filter(|m| m.rigid).all(|rigid| {
        samples.iter().all(|x| {
            let shifted: Vec<f64> = x
                .iter()
                .zip(&rigid.shape)
                .map(|(a, u)| a + 0.7 * amplitude * u)
                .collect();
            let (mut f, mut g) = (vec![0.0; n], vec![0.0; n]);
            structure.nonlinear_force(x, &mut f);
            structure.nonlinear_force(&shifted, &mut g);
            let scale = f.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
            let invariant = f
                .iter()
                .zip(&g)
                .all(|(a, b)| (a - b).abs() <= 1e-10 * scale);
            let projection: f64 = linalg::dot(&f, &rigid.shape);
            let norm_u = linalg::norm(&rigid.shape);
            invariant && projection.abs() <= 1e-10 * scale * norm_u * (n as f64).sqrt()
        })
    })
}

// Negated comparisons below are deliberate: a NaN ratio or residual must count as failure.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
/// The amplitude `c` at which `‖f_nl(c φ)‖ = ratio ‖K c φ‖`, by bisection in `log c`
/// (1 when the model is linear along `φ`).
fn weakly_nonlinear_amplitude(structure: &Structure, shape: &[f64], ratio: f64) -> f64 {
    let n = shape.len();
    let k_phi = linalg::norm(&linalg::times(structure.stiffness().as_ref(), shape));
    let nonlinear_ratio = |c: f64| {
        let x: Vec<f64> = shape.iter().map(|s| c * s).collect();
        let mut f = vec![0.0; n];
        structure.nonlinear_force(&x, &mut f);
        linalg::norm(&f) / (c * k_phi)
    };
    let (mut lo, mut hi) = (-12.0f64, 12.0f64);
    if !(nonlinear_ratio(10f64.powf(hi)) > ratio) {
        return 1.0;
    }
    if nonlinear_ratio(10f64.powf(lo)) > ratio {
        return 10f64.powf(lo);
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if nonlinear_ratio(10f64.powf(mid)) > ratio {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    10f64.powf(lo)
}

/// A converged point of a branch.
#[derive(Debug, Clone, serde::Serialize)]
pub struct BranchPoint {
    pub index: usize,
    /// Total energy `E(z0)`.
    pub energy: f64,
    /// `dE/ds` along the unit tangent: changes sign at a fold.
    pub energy_slope: f64,
    /// Period `T` (s).
    pub period: f64,
    /// `2π / T` (rad/s).
    pub frequency: f64,
    /// Initial state `z0 = [x0; v0]`.
    pub z0: Vec<f64>,
    pub floquet: Floquet,
    /// `‖W H‖ / ‖W z0‖` at convergence (of the half-period problem when shooting over half a
    /// period).
    pub relative_residual: f64,
    /// The same over the full period, `‖W (z(T) - z0)‖ / ‖W z0‖`.
    pub full_period_residual: f64,
    /// Newton iterations of the accepted corrector.
    pub iterations: usize,
    /// Arclength step that led here (0 for the first point).
    pub step: f64,
    /// Unknowns `u = (q, τ)` and unit tangent there (for restarts and branch switching).
    pub unknowns: Vec<f64>,
    pub tangent: Vec<f64>,
}

/// Why a branch ended.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(rename_all = "kebab-case", tag = "reason", content = "detail")]
pub enum StopReason {
    EnergyMax,
    FrequencyShiftMax,
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
    pub points: usize,
    pub events: usize,
    /// Corrector solves spent on locating events.
    pub location_steps: usize,
    pub newton_iterations: usize,
    pub rejected_steps: usize,
    pub shooting: ShootingStats,
}

/// A computed branch.
#[derive(Debug, Clone)]
pub struct Branch {
    pub points: Vec<BranchPoint>,
    /// Located events, in the order of the branch.
    pub events: Vec<Event>,
    pub stop: StopReason,
    pub stats: BranchStats,
    /// Linear angular frequency of the starting mode.
    pub omega: f64,
}

struct Corrected {
    unknowns: Vec<f64>,
    evaluation: Evaluation,
    iterations: usize,
}

/// Newton corrector with one extra row `direction · (u - anchor) = 0`.
fn correct<S: SecondOrderSystem + ?Sized>(
    shooting: &mut Shooting<'_, S>,
    start: &[f64],
    direction: &[f64],
    anchor: &[f64],
    phase_reference: &[f64],
    settings: &Settings,
    newton_iterations: &mut usize,
) -> Result<Corrected, String> {
    let mut u = start.to_vec();
    let mut first_residual = None;
    for iteration in 0..=settings.max_iterations {
        let evaluation = shooting
            .evaluate(&u, phase_reference)
            .map_err(|e: IntegrationError| e.to_string())?;
        let residual = evaluation.relative_residual;
        if !residual.is_finite() {
            return Err("non-finite residual".into());
        }
        if residual < settings.tolerance {
            return Ok(Corrected {
                unknowns: u,
                evaluation,
                iterations: iteration,
            });
        }
        let first = *first_residual.get_or_insert(residual);
        if iteration == settings.max_iterations || residual > 1e3 * first.max(settings.tolerance) {
            return Err(format!(
                "residual {residual:.2e} after {iteration} Newton iterations"
            ));
        }
        let rows = evaluation.rows.len();
        let m = u.len();
        let mut a = Mat::<f64>::zeros(rows + 1, m);
        let mut b = vec![0.0; rows + 1];
        for i in 0..rows {
            for j in 0..m {
                a[(i, j)] = evaluation.jacobian[(i, j)];
            }
            b[i] = -evaluation.rows[i];
        }
        for j in 0..m {
            a[(rows, j)] = direction[j];
        }
        b[rows] = -direction
            .iter()
            .zip(u.iter().zip(anchor))
            .map(|(d, (x, y))| d * (x - y))
            .sum::<f64>();
        let delta = linalg::least_squares(a.as_ref(), &b);
        for (x, d) in u.iter_mut().zip(&delta) {
            *x += d;
        }
        *newton_iterations += 1;
        if u[m - 1] <= 0.0 {
            return Err("the period became non-positive".into());
        }
    }
    unreachable!("the loop returns at max_iterations")
}

/// Unit tangent at a converged point: `[J; previousᵀ] t = [0; 1]`, normalised.
fn tangent(evaluation: &Evaluation, previous: &[f64]) -> Vec<f64> {
    let rows = evaluation.rows.len();
    let m = previous.len();
    let mut a = Mat::<f64>::zeros(rows + 1, m);
    for i in 0..rows {
        for j in 0..m {
            a[(i, j)] = evaluation.jacobian[(i, j)];
        }
    }
    for j in 0..m {
        a[(rows, j)] = previous[j];
    }
    let mut b = vec![0.0; rows + 1];
    b[rows] = 1.0;
    let mut t = linalg::least_squares(a.as_ref(), &b);
    let norm = linalg::norm(&t);
    t.iter_mut().for_each(|x| *x /= norm);
    if linalg::dot(&t, previous) < 0.0 {
        t.iter_mut().for_each(|x| *x = -*x);
    }
    t
}

fn amplitude_norm(u: &[f64]) -> f64 {
    linalg::norm(&u[..u.len() - 1])
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
}

impl<F: FnMut(&BranchPoint) -> ControlFlow<()>> Observer for F {
    fn point(&mut self, point: &BranchPoint) -> ControlFlow<()> {
        self(point)
    }
}

/// Follows the branch from `start`, calling `observer` with every converged point as soon as
/// it is found. Events are located all the same (see [`Settings::events`]) and returned in
/// the [`Branch`]; [`continue_branch_observed`] also reports them as they are found.
pub fn continue_branch<S: SecondOrderSystem + ?Sized>(
    system: &S,
    start: &Start,
    settings: &Settings,
    observer: impl FnMut(&BranchPoint) -> ControlFlow<()>,
) -> Result<Branch, ContinuationError> {
    continue_branch_observed(system, start, settings, observer)
}

/// Follows the branch from `start`, handing every converged point and located event to
/// `observer` as soon as it is found.
pub fn continue_branch_observed<S: SecondOrderSystem + ?Sized>(
    system: &S,
    start: &Start,
    settings: &Settings,
    mut observer: impl Observer,
) -> Result<Branch, ContinuationError> {
    settings.validate()?;
    let mut shooting = start.shooting(system, settings);
    let mut stats = BranchStats::default();
    let mut points: Vec<BranchPoint> = Vec::new();
    let mut events: Vec<Event> = Vec::new();

    // First point: pin the projection on the starting direction.
    let u0 = shooting.unknowns_from_state(&start.z0, start.period);
    let m = u0.len();
    let q_norm = amplitude_norm(&u0);
    if q_norm == 0.0 {
        return Err(ContinuationError::FirstPoint(
            "the starting state is zero".into(),
        ));
    }
    let mut pin = match &start.pin {
        Some(direction) => shooting.unknowns_from_state(direction, 0.0),
        None => u0.clone(),
    };
    pin[m - 1] = 0.0;
    let pin_norm = linalg::norm(&pin);
    if pin_norm.is_nan() || pin_norm == 0.0 {
        return Err(ContinuationError::FirstPoint(
            "the starting direction has no component in the unknowns".into(),
        ));
    }
    pin.iter_mut().for_each(|x| *x /= pin_norm);
    let first = correct(
        &mut shooting,
        &u0,
        &pin,
        &u0,
        &start.z0,
        settings,
        &mut stats.newton_iterations,
    )
    .map_err(|why| {
        ContinuationError::FirstPoint(if shooting.half_period() {
            format!(
                "{why} (shooting over half a period; set half_period = false if the motion is not half-wave symmetric)"
            )
        } else {
            why
        })
    })?;
    let mut t = tangent(&first.evaluation, &pin);
    let point = make_point(&mut shooting, &first, &t, 0, 0.0, settings)
        .map_err(|e| ContinuationError::FirstPoint(e.to_string()))?;
    let mut u = first.unknowns;
    let mut phase_reference = point.z0.clone();
    let mut step = settings.initial_step * q_norm;

    let mut stop = record(point, &mut points, &mut observer, settings, start.omega);
    while stop.is_none() {
        let q = amplitude_norm(&u);
        step = step.clamp(settings.min_step * q, settings.max_step * q);
        let predicted: Vec<f64> = u.iter().zip(&t).map(|(x, d)| x + step * d).collect();
        let outcome = correct(
            &mut shooting,
            &predicted,
            &t,
            &predicted,
            &phase_reference,
            settings,
            &mut stats.newton_iterations,
        );
        let at_min_step = step <= settings.min_step * q * (1.0 + 1e-12);
        let corrected = match outcome {
            Ok(c) => c,
            Err(why) => {
                if at_min_step {
                    stop = Some(StopReason::StepTooSmall(why));
                    break;
                }
                stats.rejected_steps += 1;
                step *= 0.5;
                continue;
            }
        };
        // A corrector that converged slowly or far from the prediction may have landed on a
        // neighbouring branch (tangents there can be parallel, so the angle test alone misses
        // it): retry with a smaller step. On a smooth branch the correction is ~κs²/2, below
        // s/4 whenever the turn-angle test passes.
        let correction = linalg::norm(
            &corrected
                .unknowns
                .iter()
                .zip(&predicted)
                .map(|(a, b)| a - b)
                .collect::<Vec<f64>>(),
        );
        let suspicious =
            correction > 0.5 * step || corrected.iterations > 2 * settings.target_iterations.max(1);
        if suspicious && !at_min_step {
            stats.rejected_steps += 1;
            step *= 0.5;
            continue;
        }
        let t_new = tangent(&corrected.evaluation, &t);
        if linalg::dot(&t_new, &t) < settings.max_turn_angle.cos() && !at_min_step {
            stats.rejected_steps += 1;
            step *= 0.5;
            continue;
        }
        let point = match make_point(
            &mut shooting,
            &corrected,
            &t_new,
            points.len(),
            step,
            settings,
        ) {
            Ok(p) => p,
            Err(why) if at_min_step => {
                stop = Some(StopReason::StepTooSmall(why));
                break;
            }
            Err(_) => {
                stats.rejected_steps += 1;
                step *= 0.5;
                continue;
            }
        };
        let previous = points.last().expect("the first point is recorded");
        if settings.events {
            for event in locate_events(&mut shooting, previous, &point, settings, &mut stats) {
                let flow = observer.event(&event);
                events.push(event);
                if flow.is_break() {
                    stop = Some(StopReason::Interrupted);
                }
            }
            if stop.is_some() {
                break;
            }
        }
        step *= step_factor(corrected.iterations, settings.target_iterations);
        u = corrected.unknowns;
        t = t_new;
        phase_reference = point.z0.clone();
        stop = record(point, &mut points, &mut observer, settings, start.omega);
    }
    stats.points = points.len();
    stats.events = events.len();
    stats.shooting = shooting.stats;
    Ok(Branch {
        points,
        events,
        stop: stop.unwrap_or(StopReason::MaxPoints),
        stats,
        omega: start.omega,
    })
}

impl Settings {
    /// Checks every setting; `continue_branch` calls it, and front ends can call it early.
    pub fn validate(&self) -> Result<(), ContinuationError> {
        validate(self)
    }
}

fn validate(settings: &Settings) -> Result<(), ContinuationError> {
    let positive = |name: &str, v: f64| {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(ContinuationError::InvalidSetting(format!(
                "{name} must be positive and finite, got {v}"
            )))
        }
    };
    positive("tolerance", settings.tolerance)?;
    positive("initial_step", settings.initial_step)?;
    positive("min_step", settings.min_step)?;
    positive("max_step", settings.max_step)?;
    positive("max_turn_angle", settings.max_turn_angle)?;
    positive("integration_factor", settings.integration_factor)?;
    if settings.integration_factor > 1.0 {
        return Err(ContinuationError::InvalidSetting(format!(
            "integration_factor {} must not exceed 1 (the integrator must be at least as accurate as the shooting tolerance)",
            settings.integration_factor
        )));
    }
    if settings.max_turn_angle > std::f64::consts::PI {
        return Err(ContinuationError::InvalidSetting(format!(
            "max_turn_angle {} exceeds π",
            settings.max_turn_angle
        )));
    }
    if !(settings.stability_tolerance.is_finite() && settings.stability_tolerance >= 0.0) {
        return Err(ContinuationError::InvalidSetting(format!(
            "stability_tolerance must be finite and non-negative, got {}",
            settings.stability_tolerance
        )));
    }
    if settings.tolerance >= 1e-2 {
        return Err(ContinuationError::InvalidSetting(format!(
            "tolerance {} is too loose (use < 1e-2)",
            settings.tolerance
        )));
    }
    if settings.min_step > settings.max_step {
        return Err(ContinuationError::InvalidSetting(
            "min_step exceeds max_step".into(),
        ));
    }
    if settings.energy_max.is_nan() || settings.frequency_shift_max.is_nan() {
        return Err(ContinuationError::InvalidSetting(
            "stop limits must not be NaN".into(),
        ));
    }
    if settings.max_points == 0 || settings.max_iterations == 0 {
        return Err(ContinuationError::InvalidSetting(
            "max_points and max_iterations must be at least 1".into(),
        ));
    }
    Ok(())
}

/// Step growth from the corrector's effort: fewer iterations than the target → grow (up to
/// 2×), more → shrink (down to ½×).
fn step_factor(iterations: usize, target: usize) -> f64 {
    let ratio = (target.max(1) as f64) / (iterations.max(1) as f64);
    ratio.sqrt().clamp(0.5, 2.0)
}

#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn make_point<S: SecondOrderSystem + ?Sized>(
    shooting: &mut Shooting<'_, S>,
    corrected: &Corrected,
    tangent: &[f64],
    index: usize,
    step: f64,
    settings: &Settings,
) -> Result<BranchPoint, String> {
    let evaluation = &corrected.evaluation;
    let monodromy = shooting.monodromy(evaluation).map_err(|e| e.to_string())?;
    // The trivial pair spans the flow direction g(z0) and the direction along the family:
    // deflate it rather than guess it from the spectrum (SPEC §7: degenerate partners also
    // sit near +1).
    let flow_direction = shooting.modal_coordinates(&shooting.field(&evaluation.z0));
    let family_direction = shooting.modal_coordinates(&shooting.initial_state(tangent));
    let directions = [flow_direction.as_slice(), family_direction.as_slice()];
    let floquet = match shooting.unknown_block() {
        // A symmetry class: its block and the rest are analysed apart.
        Some(class) => floquet::analyse_deflated_split(
            &monodromy,
            directions,
            &class,
            settings.stability_tolerance,
        ),
        None => floquet::analyse_deflated(&monodromy, directions, settings.stability_tolerance),
    }
    .map_err(|e| e.to_string())?;
    let mut point = light_point(shooting, corrected, tangent, index, step);
    if !point.energy.is_finite() {
        return Err(format!("non-finite energy {}", point.energy));
    }
    let full_period_residual = shooting
        .full_period_residual(evaluation)
        .map_err(|e| e.to_string())?;
    if !(full_period_residual < 100.0 * settings.tolerance) {
        return Err(format!(
            "the motion is not half-wave symmetric (full-period residual {full_period_residual:.2e}); set half_period = false"
        ));
    }
    point.floquet = floquet;
    point.full_period_residual = full_period_residual;
    Ok(point)
}

/// `dE/ds` along the unit tangent `t` at unknowns `u`, by the five-point central difference
/// (exact for the quartic energy of cubic springs; `O(h⁴)` otherwise, with `h = 1e-3 ‖q‖`).
fn energy_slope<S: SecondOrderSystem + ?Sized>(
    shooting: &Shooting<'_, S>,
    u: &[f64],
    t: &[f64],
) -> f64 {
    let z = shooting.initial_state(u);
    let w = shooting.initial_state(t);
    let h = 1e-3 * amplitude_norm(u).max(f64::MIN_POSITIVE);
    let energy_at = |c: f64| {
        let shifted: Vec<f64> = z.iter().zip(&w).map(|(a, b)| a + c * h * b).collect();
        shooting.energy(&shifted)
    };
    (8.0 * (energy_at(1.0) - energy_at(-1.0)) - (energy_at(2.0) - energy_at(-2.0))) / (12.0 * h)
}

/// Relative arclength accuracy to which events are located (relative to `‖q‖`): energies
/// then come out to about twice that.
const EVENT_ARCLENGTH_TOLERANCE: f64 = 1e-8;
/// Trial points of a location are converged to this fraction of the continuation tolerance.
const EVENT_TRIAL_TOLERANCE_FACTOR: f64 = 1e-2;
/// How many times a step is halved to separate crossings that no test function brackets.
const REFINE_DEPTH: usize = 2;
/// Trials allowed to the secant location (it converges in 5–12 on a simple root).
const SECANT_TRIALS: usize = 20;
/// Relative arclength bracket to which an event without a usable test function is placed by
/// bisection (about 18 halvings of a largest step).
const EVENT_BRACKET_TOLERANCE: f64 = 1e-6;
/// Trials allowed to the bisection fallback.
const BISECTION_TRIALS: usize = 24;

/// Detects the events between two consecutive points and locates each one: every trial is a
/// point at arclength `s` from `previous`, corrected on the hyperplane
/// `t_prev · (u - u_prev - s t_prev) = 0` (the one the continuation step itself used), started
/// from the chord between the two points.
fn locate_events<S: SecondOrderSystem + ?Sized>(
    shooting: &mut Shooting<'_, S>,
    previous: &BranchPoint,
    next: &BranchPoint,
    settings: &Settings,
    stats: &mut BranchStats,
) -> Vec<Event> {
    let (u0, t0, u1) = (&previous.unknowns, &previous.tangent, &next.unknowns);
    // Arclength of `next` along the previous tangent (the step, up to round-off).
    let h: f64 = t0
        .iter()
        .zip(u1.iter().zip(u0))
        .map(|(t, (a, b))| t * (a - b))
        .sum();
    let q = amplitude_norm(u0);
    let tolerance = EVENT_ARCLENGTH_TOLERANCE * q;
    // Trial points are converged further than branch points: near a branch point the
    // corrector's Jacobian is nearly singular, and a residual at the continuation tolerance
    // leaves an error along the null direction that shifts the test function (seen as a
    // 2e-6 shift of the two-DOF branch point on the full-period problem). The integration
    // accuracy (`integration_factor × tolerance`) leaves room for this.
    let tight = Settings {
        tolerance: EVENT_TRIAL_TOLERANCE_FACTOR * settings.tolerance,
        ..settings.clone()
    };
    let mut newton = 0;
    // Solutions found so far on this step, by arclength: each trial starts from the line
    // through the two nearest, so that late trials start within the corrector's own
    // accuracy. (From the chord between the step's ends, a trial near a branch point of the
    // full-period problem can converge onto the crossing family instead.)
    let mut known: Vec<(f64, Vec<f64>)> = vec![(0.0, u0.clone()), (h, u1.clone())];
    let mut trial_point = |s: f64, with_floquet: bool| -> Result<BranchPoint, String> {
        known.sort_by(|a, b| (a.0 - s).abs().total_cmp(&(b.0 - s).abs()));
        let ((sa, ua), (sb, ub)) = (&known[0], &known[1]);
        let w = if sb != sa { (s - sa) / (sb - sa) } else { 0.0 };
        let guess: Vec<f64> = ua.iter().zip(ub).map(|(a, b)| a + w * (b - a)).collect();
        let anchor: Vec<f64> = u0.iter().zip(t0).map(|(a, t)| a + s * t).collect();
        let mut solve = |settings: &Settings| {
            correct(
                shooting,
                &guess,
                t0,
                &anchor,
                &previous.z0,
                settings,
                &mut newton,
            )
        };
        let corrected = solve(&tight).or_else(|_| solve(settings))?;
        known.push((s, corrected.unknowns.clone()));
        let t = tangent(&corrected.evaluation, t0);
        if with_floquet {
            make_point(shooting, &corrected, &t, previous.index, s, settings)
        } else {
            Ok(light_point(shooting, &corrected, &t, previous.index, s))
        }
    };
    let brackets = |crossing: Crossing, a: &BranchPoint, b: &BranchPoint| {
        let value = |p: &BranchPoint| bifurcation::test_function(crossing, p).map(|(f, _)| f);
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
        let crossings = bifurcation::detect(&a.1, &b.1);
        let unbracketed = crossings.iter().any(|&c| !brackets(c, &a.1, &b.1));
        if unbracketed && depth < REFINE_DEPTH {
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
    for ((sa, a), (sb, b), crossing) in work {
        let value = |p: &BranchPoint| bifurcation::test_function(crossing, p).map(|(f, _)| f);
        let width = sb - sa;
        let result = match (value(&a), value(&b)) {
            (Some(f0), Some(f1)) if f0 * f1 < 0.0 => {
                bifurcation::illinois(width, f0, f1, tolerance, SECANT_TRIALS, |x| {
                    let p = trial_point(sa + x, crossing.needs_floquet())?;
                    let f = value(&p).ok_or("the critical pair vanished")?;
                    Ok((f, p))
                })
            }
            // The counts changed but no test function brackets a zero even after refinement:
            // bisect on which side's pattern a trial shares. Placed, not located: a coarser
            // bracket is enough.
            _ => bifurcation::bisect(width, EVENT_BRACKET_TOLERANCE * q, BISECTION_TRIALS, |x| {
                let p = trial_point(sa + x, true)?;
                let past = bifurcation::detect(&a, &p)
                    .iter()
                    .any(|c| c.kind() == crossing.kind());
                Ok((past, p))
            }),
        };
        let located_point = match result {
            Ok(found) => {
                let summary = (
                    sa + found.arclength,
                    found.uncertainty,
                    found.trials,
                    found.converged,
                );
                if crossing.needs_floquet() {
                    Ok((found.payload, summary))
                } else {
                    // A fold's trials skip the Floquet analysis: do it once at the result.
                    trial_point(summary.0, true).map(|p| (p, summary))
                }
            }
            Err(why) => Err(why),
        };
        // A detected event whose location failed is still reported, at the end of its
        // interval, with the whole interval as its uncertainty.
        let (point, (arclength, uncertainty, trials, converged)) =
            located_point.unwrap_or_else(|_| (b.clone(), (sb, width.abs(), 0, false)));
        stats.location_steps += trials;
        located.push((crossing, arclength, uncertainty, trials, converged, point));
    }
    stats.location_steps += refinements;
    stats.newton_iterations += newton;
    let mut located: Vec<Event> = located
        .into_iter()
        .map(
            |(crossing, arclength, uncertainty, trials, converged, point)| {
                let multiplier =
                    bifurcation::test_function(crossing, &point).map_or((1.0, 0.0), |(_, m)| m);
                Event {
                    kind: crossing.kind(),
                    after: previous.index,
                    arclength,
                    arclength_uncertainty: uncertainty,
                    multiplicity: bifurcation::multiplicity(crossing, &point),
                    multiplier,
                    location_steps: trials,
                    converged,
                    state_tangent: shooting.initial_state(&point.tangent),
                    period_rate: point.tangent[point.tangent.len() - 1] * shooting.period_ref(),
                    point,
                }
            },
        )
        .collect();
    located.sort_by(|a, b| a.arclength.total_cmp(&b.arclength));
    located
}

/// A point without the Floquet analysis and the full-period check (for location trials that
/// only need `dE/ds`); [`make_point`] completes it.
fn light_point<S: SecondOrderSystem + ?Sized>(
    shooting: &Shooting<'_, S>,
    corrected: &Corrected,
    tangent: &[f64],
    index: usize,
    step: f64,
) -> BranchPoint {
    let evaluation = &corrected.evaluation;
    BranchPoint {
        index,
        energy: shooting.energy(&evaluation.z0),
        energy_slope: energy_slope(shooting, &corrected.unknowns, tangent),
        period: evaluation.period,
        frequency: 2.0 * std::f64::consts::PI / evaluation.period,
        z0: evaluation.z0.clone(),
        floquet: Floquet::empty(),
        relative_residual: evaluation.relative_residual,
        full_period_residual: f64::NAN,
        iterations: corrected.iterations,
        step,
        unknowns: corrected.unknowns.clone(),
        tangent: tangent.to_vec(),
    }
}

/// Hands the point to the observer, stores it, and says whether to stop.
fn record(
    point: BranchPoint,
    points: &mut Vec<BranchPoint>,
    observer: &mut impl Observer,
    settings: &Settings,
    omega: f64,
) -> Option<StopReason> {
    let flow = observer.point(&point);
    let energy = point.energy;
    let shift = (point.frequency / omega - 1.0).abs();
    points.push(point);
    if flow.is_break() {
        Some(StopReason::Interrupted)
    } else if energy > settings.energy_max {
        Some(StopReason::EnergyMax)
    } else if shift > settings.frequency_shift_max {
        Some(StopReason::FrequencyShiftMax)
    } else if points.len() >= settings.max_points {
        Some(StopReason::MaxPoints)
    } else {
        None
    }
}

#[cfg(test)]
mod tests;
