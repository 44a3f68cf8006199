//! Starting a branch from a user's state and period (`Start::from_state`) instead of a linear
//! mode, checked against exact Duffing periods.

use std::ops::ControlFlow;

use nnm::model::{duffing, two_dof};
use nnm::prelude::*;

#[path = "../src/reference.rs"]
#[allow(dead_code)]
mod reference;

fn follow<S: MechanicalSystem>(system: &S, start: &Start, points: usize) -> Branch {
    let mut settings = Settings::default();
    settings.continuation.tolerance = 1e-10;
    settings.limits.max_points = points;
    continue_branch(system, start, &settings, |_| ControlFlow::Continue(())).unwrap()
}

/// From rest at amplitude 1.5 with a rough period guess (the linear one), the first point
/// converges onto the Duffing orbit through that state: its period is the exact elliptic one
/// for the amplitude it converged to, and so are the points that follow.
#[test]
fn duffing_from_a_state_at_rest() {
    let system = duffing(1.0, 1.0).unwrap();
    let start = Start::from_state(&system, &[1.5, 0.0], 2.0 * std::f64::consts::PI).unwrap();
    let branch = follow(&system, &start, 6);
    assert_eq!(branch.points.len(), 6);
    assert!(
        (branch.points[0].z0[0] - 1.5).abs() < 1e-9,
        "the pin holds the amplitude"
    );
    for p in &branch.points {
        let exact = reference::duffing_period(1.0, 1.0, p.z0[0].abs());
        assert!(
            (p.period - exact).abs() < 1e-9 * exact,
            "{} vs {exact}",
            p.period
        );
    }
}

/// A state that is not at rest (here the Duffing orbit of amplitude 1 seen a quarter period
/// later, through x = 0) needs the flow-orthogonal phase condition, which the start chooses;
/// the energy of the converged orbit is the state's, and its period the exact one.
#[test]
fn duffing_from_a_moving_state_uses_the_flow_orthogonal_phase() {
    let system = duffing(1.0, 1.0).unwrap();
    // E = ½ v² at x = 0 equals ½ A² + ¼ A⁴ with A = 1.
    let v = (2.0f64 * 0.75).sqrt();
    let start = Start::from_state(&system, &[0.0, v], 6.0).unwrap();
    assert_eq!(start.phase, Some(PhaseCondition::FlowOrthogonal));
    let branch = follow(&system, &start, 3);
    let first = &branch.points[0];
    let amplitude = reference::duffing_amplitude(1.0, 1.0, first.energy);
    let exact = reference::duffing_period(1.0, 1.0, amplitude);
    assert!((first.period - exact).abs() < 1e-9 * exact);
    assert!(
        (first.energy - 0.75).abs() < 1e-6,
        "energy {}",
        first.energy
    );
}

/// A wrong-sized state or a non-positive period is refused with a one-line error.
#[test]
fn from_state_refuses_bad_input() {
    let system = two_dof(0.5).unwrap();
    for (state, period) in [(vec![1.0, 0.0], 6.0), (vec![1.0, 0.0, 0.0, 0.0], -1.0)] {
        let error = Start::from_state(&system, &state, period)
            .unwrap_err()
            .to_string();
        assert!(
            !error.contains('\n') && error.starts_with("invalid start"),
            "{error}"
        );
    }
}

/// A model above the dense modal limit gets only its lowest modes, which do not span the
/// state space: its branch is shot matrix-free (docs/method.md §14), and the dense formulation,
/// asked for explicitly, is refused with an error saying so at the first evaluation — rather
/// than solving a residual projected on 20 modes as if it were the whole one.
#[test]
fn large_model_is_shot_matrix_free_and_dense_is_refused_without_a_complete_basis() {
    use nnm::continuation::ContinuationProblem;
    use nnm::shooting::Formulation;
    let beam = nnm::model::CantileverBeam {
        elements: 1100,
        ..nnm::model::CantileverBeam::default()
    }
    .build()
    .unwrap();
    let start = Start::from_mode(&beam, 0).unwrap();
    assert!(!start.complete_basis);
    let settings = nnm::Settings::default();
    assert!(start.shooting(&beam, &settings).is_matrix_free());
    let mut dense = settings.clone();
    dense.shooting.formulation = Formulation::Dense;
    let mut shooting = start.shooting(&beam, &dense);
    assert!(!shooting.is_matrix_free());
    let (u0, _) = start.first_guess(&shooting);
    let error = shooting.evaluate(&u0).unwrap_err().to_string();
    assert!(
        error.contains("every linear mode") && error.contains("matrix-free"),
        "{error}"
    );
}
