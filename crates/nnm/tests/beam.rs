//! The ECL cantilever beam (stiff: 38 dofs, highest frequency ~4000× the first) by the
//! implicit integrators, against each other and against the explicit default.

use std::ops::ControlFlow;

use nnm::integrate::IntegrationMethod;
use nnm::model::CantileverBeam;
use nnm::prelude::*;
use nnm::shooting::Formulation;

/// The first `points` points of the first NNM of the ECL beam with `elements` elements, by
/// `method`, events off, in the automatic formulation.
fn branch(elements: usize, method: IntegrationMethod, points: usize) -> Branch {
    branch_in(elements, method, points, Formulation::Auto)
}

fn branch_in(
    elements: usize,
    method: IntegrationMethod,
    points: usize,
    formulation: Formulation,
) -> Branch {
    let beam = CantileverBeam {
        elements,
        ..CantileverBeam::default()
    }
    .build()
    .unwrap();
    let start = Start::from_mode(&beam, 0).unwrap();
    let mut settings = Settings::default();
    settings.limits.max_points = points;
    settings.stability.events = false;
    settings.integration.integrator = method;
    settings.shooting.formulation = formulation;
    continue_branch(&beam, &start, &settings, |_| ControlFlow::Continue(())).unwrap()
}

/// The same in the dense formulation, whatever the integrator (the points of two
/// formulations are not the same points: their unknowns, and so their arclengths, differ).
fn first_points(method: IntegrationMethod, points: usize) -> Vec<(f64, f64)> {
    branch_in(19, method, points, Formulation::Dense)
        .points
        .iter()
        .map(|p| (p.energy, p.frequency))
        .collect()
}

fn assert_same(a: &[(f64, f64)], b: &[(f64, f64)], tolerance: f64) {
    assert_eq!(a.len(), b.len());
    for (p, q) in a.iter().zip(b) {
        assert!(
            (p.0 - q.0).abs() < tolerance * q.0,
            "energy {} vs {}",
            p.0,
            q.0
        );
        assert!(
            (p.1 - q.1).abs() < tolerance * q.1,
            "frequency {} vs {}",
            p.1,
            q.1
        );
    }
}

/// Orders 4 and 6, with their own step counts, give the same first points (measured: 4e-12),
/// and so does the damping Radau IIA collocation.
#[test]
fn gauss4_gauss6_and_radau5_agree_on_the_beam() {
    let gauss6 = first_points(IntegrationMethod::Gauss6, 3);
    assert_same(&gauss6, &first_points(IntegrationMethod::Gauss4, 3), 1e-10);
    assert_same(&gauss6, &first_points(IntegrationMethod::Radau5, 3), 1e-10);
}

/// A 100-element beam (200 dofs, `ω_max/ω_1 ≈ 10⁵`): under Auto (Radau9 at this size) its
/// first points converge, are stable, and their frequencies sit on the linear one (within
/// the small amplitude's hardening). Gauss6 did not converge on the first point from 70
/// elements on (aliased unresolved modes, `integrate::SYMPLECTIC_DOFS`).
#[test]
fn fine_beam_branch_starts_under_auto() {
    let branch = branch(100, IntegrationMethod::Auto, 3);
    assert_eq!(branch.points.len(), 3);
    let linear = 2.0 * std::f64::consts::PI * 23.6615;
    for p in &branch.points {
        assert!(p.floquet.stable, "point {} unstable", p.index);
        assert!((p.frequency / linear - 1.0).abs() < 1e-3, "{}", p.frequency);
        assert!(p.relative_residual < Settings::default().continuation.tolerance);
    }
}

/// Against the explicit default (measured: 3e-13 in frequency; 40 s for dop853 against 1 s
/// for gauss6, so not in the default run: `cargo test --release -p nnm --test beam --
/// --ignored`).
#[test]
#[ignore = "40 s: the explicit integrator on a stiff model"]
fn gauss6_and_dop853_agree_on_the_beam() {
    assert_same(
        &first_points(IntegrationMethod::Gauss6, 3),
        &first_points(IntegrationMethod::Dop853, 3),
        1e-10,
    );
}

/// A finer beam (50 elements, 100 dofs, `ω_max/ω_1 ≈ 3·10⁴`) in its linear regime: the
/// monodromy of the symplectic discrete flow has every multiplier on the unit circle and in
/// reciprocal pairs. Measured: `|μ| − 1 ≤ 1e-10`; before the energy scaling of the monodromy
/// (docs/method.md eq. (33a)) round-off gave `|μ| = 1.0001` and points flagged unstable.
#[test]
fn stiff_beam_multipliers_stay_on_the_unit_circle() {
    // The symplectic scheme (Auto takes Radau9 at this size, whose dissipation moves the
    // multipliers inside the circle by design).
    let branch = branch(50, IntegrationMethod::Gauss6, 3);
    for p in &branch.points {
        let f = &p.floquet;
        assert_eq!(f.pairs.len(), 99, "one trivial and 99 non-trivial pairs");
        assert!(f.stable && f.unstable_pairs == 0);
        assert!(f.max_modulus - 1.0 < 1e-8, "max |μ| = {}", f.max_modulus);
        assert!(
            f.reciprocity_defect < 1e-8,
            "defect {}",
            f.reciprocity_defect
        );
        for pair in &f.pairs {
            let m = pair.multiplier;
            let modulus = m.0.hypot(m.1);
            assert!((modulus - 1.0).abs() < 1e-8, "|μ| = {modulus}");
        }
    }
}
