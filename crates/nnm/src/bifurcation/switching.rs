//! Branch switching: the start of the other family through a located branch point or period
//! doubling.
//!
//! At a branch point the shooting Jacobian `J` (rows × unknowns) loses rank: besides the
//! parent's tangent `t`, a second direction `φ` satisfies `J φ = 0` to first order. At a
//! period doubling the same holds for the problem posed over twice the period, where the
//! parent (traversed twice) is still a solution and the critical eigenvector of `Φ(T)` at `-1`
//! becomes a null direction of `Φ(2T) - I = Φ(T)² - I`. Either way the new family leaves along
//! `φ`: it is found as the right singular vector of `J` for the second-smallest singular value,
//! made orthogonal to `t`, and the new branch starts from `u* + ε φ` with its first corrector
//! holding the `φ` component fixed (the hyperplane `φ · (u - u*) = ε`, which the parent crosses
//! only at second order). This is the "perturbation along the null vector" variant of branch
//! switching; it needs no second derivatives.
//!
//! The new branch is posed without the parent's restrictions: every elastic mode is an
//! unknown (the new family may break the mirror symmetry), and the period is shot in full (it
//! may break the half-wave symmetry `x(t + T/2) = -x(t)`). When the configured zero-velocity
//! phase condition shows no second null direction, the new motions are never at rest
//! everywhere at once (on the two-DOF system, the family through the in-phase branch point is
//! of that kind): the switch then poses the new branch with the flow-orthogonal condition,
//! recorded in the returned [`Start::phase`].

use crate::bifurcation::{Event, EventKind};
use crate::linalg::{self, Mat};
use crate::model::MechanicalSystem;
use crate::shooting::{PhaseCondition, SettingsView, Shooting, Start};

struct Candidate<'a, S: MechanicalSystem + ?Sized> {
    start: Start,
    shooting: Shooting<'a, S>,
    u_star: Vec<f64>,
    values: Vec<f64>,
    vectors: Mat<f64>,
    null_count: usize,
}

/// Why a branch cannot be switched at an event.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SwitchError {
    /// The event (its kind named) is a fold or a Krein collision: no other family of periodic
    /// motions of the same or twice the period crosses there.
    #[error(
        "a {0} has no other branch of periodic motions to switch to (only branch points and period doublings do)"
    )]
    NotABifurcation(&'static str),
    /// The Jacobian at the event shows no null direction beside the parent's tangent
    /// (docs/method.md eq. (47)), with the flow-orthogonal phase condition tried as well.
    #[error(
        "no second null direction at this {kind} (smallest singular values {values}): the event \
         may not be located precisely enough, or the new family lies outside the unknowns"
    )]
    NoNullDirection {
        /// Name of the event's kind.
        kind: &'static str,
        /// The smallest singular values of the Jacobian, formatted for the message.
        values: String,
    },
    /// `direction` is beyond the new null directions found (only a degenerate event has more
    /// than one).
    #[error("direction {asked} asked, but the event has {available} new null direction(s) (0 to {})", available - 1)]
    NoSuchDirection {
        /// The direction asked for (0-based).
        asked: usize,
        /// How many new null directions the event has.
        available: usize,
    },
    /// The event's state does not fit the system, or the shooting problem or its SVD failed
    /// there.
    #[error("the shooting problem could not be evaluated at the event: {0}")]
    Evaluation(String),
}

/// What the switch found, beside the new start.
#[derive(Debug, Clone)]
pub struct Switch {
    /// Start of the new branch at `u* + ε φ` (docs/method.md eq. (48)), its first corrector
    /// pinned along `φ`.
    pub start: Start,
    /// The smallest singular values of the new problem's Jacobian at the event (the first two
    /// are the null directions; the gap to the third measures how clean the switch is).
    pub singular_values: Vec<f64>,
    /// How many null directions beyond the parent's tangent (1 at a simple bifurcation).
    pub null_directions: usize,
}

/// Relative size below which a singular value counts as zero. The event is located to about
/// 1e-9 in arclength and the Jacobian is accurate to ~1e-7, so null directions come out near
/// 1e-7 while genuine ones are O(1) in the scaled unknowns.
const NULL_THRESHOLD: f64 = 1e-4;

/// The start of the family that crosses `parent`'s branch at `event`. `amplitude` is the
/// offset `ε` along the new direction, relative to the event's amplitude `‖q*‖`. At a
/// degenerate event (several null directions beside the parent's tangent, e.g. where a
/// symmetry doubles the critical pair) `direction` picks one (0-based, in the order of the
/// singular values); each may lead to a different family.
pub fn switch_branch<'s, S: MechanicalSystem + ?Sized>(
    system: &S,
    parent: &Start,
    event: &Event,
    settings: impl Into<SettingsView<'s>>,
    amplitude: f64,
    direction: usize,
) -> Result<Switch, SwitchError> {
    let settings = settings.into();
    let multiple = match event.kind {
        EventKind::BranchPoint => 1.0,
        EventKind::PeriodDoubling => 2.0,
        other => return Err(SwitchError::NotABifurcation(other.name())),
    };
    let point = &event.point;
    let n2 = 2 * system.dofs();
    if point.z0.len() != n2 || event.state_tangent.len() != n2 {
        return Err(SwitchError::Evaluation(format!(
            "the event's state has length {}, the system {n2}",
            point.z0.len()
        )));
    }
    let (parent_direction, period_rate) = (&event.state_tangent, event.period_rate);

    let mut child = parent.clone().unrestricted();
    child.half_period = false;
    child.shift = None;
    child.omega = parent.omega / multiple;
    child.period = multiple * point.period;
    child.z0 = point.z0.clone();
    child.pin = None;
    // The configured phase condition first; if the new family has no null direction there,
    // its motions are never at rest everywhere at once and need the general condition.
    let attempt = |phase: PhaseCondition| -> Result<Candidate<'_, S>, SwitchError> {
        let mut child = child.clone();
        child.phase = Some(phase);
        let mut shooting = child.shooting(system, settings);
        let u_star = shooting.unknowns_from_state(&point.z0, child.period);
        let evaluation = shooting
            .evaluate_with_reference(&u_star, &point.z0)
            .map_err(|e| SwitchError::Evaluation(e.to_string()))?;
        let (values, vectors) = linalg::right_singular(evaluation.jacobian.as_ref())
            .map_err(|e| SwitchError::Evaluation(e.to_string()))?;
        let largest = values.last().copied().unwrap_or(1.0).max(f64::MIN_POSITIVE);
        let null_count = values
            .iter()
            .take_while(|v| **v <= NULL_THRESHOLD * largest)
            .count();
        Ok(Candidate {
            start: child,
            shooting,
            u_star,
            values,
            vectors,
            null_count,
        })
    };
    let configured = parent.phase.unwrap_or(settings.shooting.phase);
    let mut candidate = attempt(configured)?;
    if candidate.null_count < 2 && configured == PhaseCondition::ZeroVelocity {
        candidate = attempt(PhaseCondition::FlowOrthogonal)?;
    }
    let (child, shooting, u_star) = (candidate.start, candidate.shooting, candidate.u_star);
    let (values, vectors, null_count) = (candidate.values, candidate.vectors, candidate.null_count);
    let m = u_star.len();
    let shown: Vec<String> = values.iter().take(4).map(|v| format!("{v:.1e}")).collect();
    if null_count < 2 {
        return Err(SwitchError::NoNullDirection {
            kind: event.kind.name(),
            values: shown.join(", "),
        });
    }
    // The parent's tangent in the new unknowns, and the null direction most orthogonal to it.
    let mut tangent = shooting.unknowns_from_state(parent_direction, multiple * period_rate);
    let norm = linalg::norm(&tangent);
    tangent.iter_mut().for_each(|x| *x /= norm);
    let column = |j: usize| -> Vec<f64> { (0..m).map(|i| vectors[(i, j)]).collect() };
    let mut null: Vec<Vec<f64>> = (0..null_count).map(column).collect();
    // Gram–Schmidt with the parent tangent first: what is left spans the new directions; the
    // first of them (smallest singular value) is taken.
    let mut new_directions: Vec<Vec<f64>> = Vec::new();
    for v in null.iter_mut() {
        for _ in 0..2 {
            for d in std::iter::once(&tangent).chain(&new_directions) {
                let c = linalg::dot(d, v);
                v.iter_mut().zip(d).for_each(|(x, t)| *x -= c * t);
            }
        }
        let n = linalg::norm(v);
        if n > 0.5 {
            v.iter_mut().for_each(|x| *x /= n);
            new_directions.push(v.clone());
        }
    }
    if new_directions.is_empty() {
        return Err(SwitchError::NoNullDirection {
            kind: event.kind.name(),
            values: shown.join(", "),
        });
    }
    let available = new_directions.len();
    let phi = new_directions
        .into_iter()
        .nth(direction)
        .ok_or(SwitchError::NoSuchDirection {
            asked: direction,
            available,
        })?;
    let q_star = linalg::norm(&u_star[..m - 1]);
    let epsilon = amplitude * q_star;
    let offset = shooting.initial_state(&phi);
    let mut start = child;
    start.z0 = point
        .z0
        .iter()
        .zip(&offset)
        .map(|(z, d)| z + epsilon * d)
        .collect();
    start.period += epsilon * phi[m - 1] * shooting.period_ref();
    start.pin = Some(offset);
    Ok(Switch {
        start,
        singular_values: values.iter().take(4).copied().collect(),
        null_directions: null_count - 1,
    })
}
