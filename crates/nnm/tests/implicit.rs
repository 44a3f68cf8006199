//! The implicit Gauss–Legendre integrators against the explicit default and exact solutions,
//! through whole branches, and on stiff models where explicit integration struggles.

use std::ops::ControlFlow;

use nnm::integrate::IntegrationMethod;
use nnm::model::{duffing, two_dof};
use nnm::prelude::*;

mod common;
use common::Unassembled;

#[path = "../src/reference.rs"]
#[allow(dead_code)]
mod reference;

fn backbone<S: MechanicalSystem>(
    system: &S,
    method: IntegrationMethod,
    settings: &Settings,
) -> Branch {
    let mut settings = settings.clone();
    settings.integration.integrator = method;
    let start = Start::from_mode(system, 0).unwrap();
    continue_branch(system, &start, &settings, |_| ControlFlow::Continue(())).unwrap()
}

/// Duffing's backbone to +30% by both collocation methods: every point's period is the exact
/// elliptic one.
#[test]
fn implicit_duffing_backbone_matches_the_exact_period() {
    let system = duffing(1.0, 1.0).unwrap();
    let mut settings = Settings::default();
    settings.continuation.tolerance = 1e-10;
    settings.limits.frequency_shift_max = 0.3;
    for method in [IntegrationMethod::Gauss4, IntegrationMethod::Gauss6] {
        let branch = backbone(&system, method, &settings);
        assert_eq!(branch.stop, StopReason::FrequencyShiftMax);
        let worst = branch
            .points
            .iter()
            .map(|p| {
                let amplitude = reference::duffing_amplitude(1.0, 1.0, p.energy);
                let exact = reference::duffing_period(1.0, 1.0, amplitude);
                (p.period - exact).abs() / exact
            })
            .fold(0.0, f64::max);
        assert!(
            worst < 1e-9,
            "{method:?}: worst relative period error {worst:.2e}"
        );
        eprintln!(
            "{method:?}: {} points, worst period error {worst:.1e}",
            branch.points.len()
        );
    }
}

/// The two-DOF in-phase backbone to E = 10: implicit and explicit integration give the same
/// frequencies, point by point along the same arclength.
#[test]
fn implicit_and_explicit_agree_on_the_two_dof_backbone() {
    let system = two_dof(0.5).unwrap();
    let mut settings = Settings::default();
    settings.continuation.tolerance = 1e-10;
    settings.limits.energy_max = 10.0;
    let explicit = backbone(&system, IntegrationMethod::Dop853, &settings);
    let implicit = backbone(&system, IntegrationMethod::Gauss6, &settings);
    assert_eq!(explicit.points.len(), implicit.points.len());
    for (a, b) in explicit.points.iter().zip(&implicit.points) {
        assert!((a.frequency - b.frequency).abs() < 1e-8 * a.frequency);
        assert!((a.energy - b.energy).abs() < 1e-8 * a.energy);
        assert_eq!(a.floquet.stable, b.floquet.stable);
    }
}

/// A stiff model in its linear regime (frequencies 1 and ~1414): the implicit integrator's
/// Floquet multipliers all sit on the unit circle to 1e-6, as the exact linear monodromy's
/// do, and it needs a few dozen steps a period where the fast mode holds an explicit method
/// to thousands.
#[test]
fn stiff_model_keeps_its_multipliers_on_the_unit_circle() {
    let k = 1e6;
    let system = Structure::new(
        nnm::Mat::identity(2, 2),
        nnm::Mat::from_fn(2, 2, |i, j| if i == j { k + 1.0 } else { -k }),
        vec![Box::new(PolynomialSpring::cubic(0, None, 0.3)) as Box<dyn NonlinearElement>],
    )
    .unwrap();
    let mut settings = Settings::default();
    settings.limits.max_points = 4;
    settings.integration.integrator = IntegrationMethod::Gauss6;
    let start = Start::from_mode(&system, 0).unwrap();
    let branch =
        continue_branch(&system, &start, &settings, |_| ControlFlow::Continue(())).unwrap();
    assert_eq!(branch.points.len(), 4);
    for p in &branch.points {
        for m in &p.floquet.multipliers {
            let modulus = m.0.hypot(m.1);
            assert!((modulus - 1.0).abs() < 1e-6, "|μ| = {modulus}");
        }
        assert!(p.floquet.stable);
    }
    let s = branch.stats.shooting;
    let per_integration = s.integration.steps as f64 / s.integrations as f64;
    eprintln!(
        "stiff 2-DOF, gauss6: {} integrations, {per_integration:.0} steps each (half periods)",
        s.integrations
    );
    assert!(
        per_integration < 200.0,
        "{per_integration} steps per integration"
    );
    // For comparison (reported, not asserted: the explicit monodromy's accuracy in the fast
    // mode is docs/method.md eq. (31b)'s subject, tested in tests/monodromy.rs).
    settings.integration.integrator = IntegrationMethod::Dop853;
    let explicit =
        continue_branch(&system, &start, &settings, |_| ControlFlow::Continue(())).unwrap();
    let s = explicit.stats.shooting;
    let worst = explicit
        .points
        .iter()
        .flat_map(|p| {
            p.floquet
                .multipliers
                .iter()
                .map(|m| (m.0.hypot(m.1) - 1.0).abs())
        })
        .fold(0.0, f64::max);
    eprintln!(
        "stiff 2-DOF, dop853: {:.0} steps per integration, worst ||μ| - 1| = {worst:.1e}",
        s.integration.steps as f64 / s.integrations as f64
    );
}

/// The dense stage solve (a system without a tangent pattern) and the sparse one (a
/// `Structure`, which gives its pattern) give the same branch.
#[test]
fn dense_and_sparse_stage_solves_agree() {
    let sparse = two_dof(0.5).unwrap();
    let dense = Unassembled(two_dof(0.5).unwrap());
    assert!(sparse.tangent_pattern().is_some() && dense.tangent_pattern().is_none());
    let mut settings = Settings::default();
    settings.limits.energy_max = 5.0;
    let (a, b) = (
        backbone(&sparse, IntegrationMethod::Gauss6, &settings),
        backbone(&dense, IntegrationMethod::Gauss6, &settings),
    );
    assert_eq!(a.points.len(), b.points.len());
    for (p, q) in a.points.iter().zip(&b.points) {
        assert!((p.frequency - q.frequency).abs() < 1e-12 * p.frequency);
        assert!((p.floquet.max_modulus - q.floquet.max_modulus).abs() < 1e-9);
    }
}
