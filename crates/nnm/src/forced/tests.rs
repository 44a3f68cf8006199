//! Forced responses against exact solutions: the linear response `(K − Ω²M + iΩC)⁻¹F` at
//! every point of a curve, and the monodromy against an independent integration of the
//! variational equations.

use std::ops::ControlFlow;

use super::*;
use crate::integrate::IntegrationMethod;
use crate::model::{ForcedSystem, HarmonicForce, Matrix, Structure};

/// Two masses, springs to ground and between them, with Rayleigh damping: a linear model
/// whose response is known in closed form (a complex 2×2 solve, written out here).
fn two_masses(cubic: f64) -> Structure {
    crate::model::two_dof(cubic).unwrap()
}

/// `x = Re(X e^{iΩt})`, `X = (K − Ω²M + iΩC)⁻¹ F` for a 2-dof model with unit masses and
/// `F = f_c e_0`, by Cramer's rule in complex arithmetic.
fn exact_two_dof(k: [[f64; 2]; 2], c: [[f64; 2]; 2], f: f64, omega: f64) -> [(f64, f64); 2] {
    let entry = |i: usize, j: usize| {
        let mass = if i == j { 1.0 } else { 0.0 };
        (k[i][j] - omega * omega * mass, omega * c[i][j])
    };
    let mul = |a: (f64, f64), b: (f64, f64)| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
    let div = |a: (f64, f64), b: (f64, f64)| {
        let d = b.0 * b.0 + b.1 * b.1;
        ((a.0 * b.0 + a.1 * b.1) / d, (a.1 * b.0 - a.0 * b.1) / d)
    };
    let (a, b, cc, d) = (entry(0, 0), entry(0, 1), entry(1, 0), entry(1, 1));
    let det = {
        let (p, q) = (mul(a, d), mul(b, cc));
        (p.0 - q.0, p.1 - q.1)
    };
    let rhs = (f, 0.0);
    [div(mul(d, rhs), det), div(mul((-cc.0, -cc.1), rhs), det)]
}

fn linear_curve(method: IntegrationMethod) {
    let structure = two_masses(0.0);
    let damping = Matrix::from_rows(&[vec![0.03, -0.01], vec![-0.01, 0.03]]).unwrap();
    let force = HarmonicForce::cosine(vec![1.0, 0.0]);
    let system = ForcedSystem::new(&structure, &damping, force).unwrap();
    let mut settings = ResponseSettings::default();
    settings.integration.integrator = method;
    settings.continuation.tolerance = 1e-12;
    let sweep = Sweep::Frequency {
        from: 0.5,
        to: 2.0,
        amplitude: 0.01,
    };
    let curve = forced_response(&system, sweep, &[0, 1], &settings, |_| {
        ControlFlow::Continue(())
    })
    .unwrap();
    assert_eq!(curve.stop, ResponseStop::End, "{:?}", curve.stop);
    assert!(curve.points.len() > 20, "{} points", curve.points.len());
    let k = [[2.0, -1.0], [-1.0, 2.0]];
    let c = [[0.03, -0.01], [-0.01, 0.03]];
    let mut worst = 0.0f64;
    for point in &curve.points {
        let omega = point.frequency;
        let x = exact_two_dof(k, c, 0.01, omega);
        let exact_z = [x[0].0, x[1].0, -omega * x[0].1, -omega * x[1].1];
        let size = exact_z.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (a, b) in point.z0.iter().zip(exact_z) {
            worst = worst.max((a - b).abs() / size);
        }
        for (d, peak) in point.peaks.iter().enumerate() {
            let exact = x[d].0.hypot(x[d].1);
            assert!(
                (peak - exact).abs() < 1e-9 * exact,
                "peak {peak} vs {exact} at {omega}"
            );
        }
        assert!(point.stable, "a damped linear response is stable");
        // The multipliers of a linear model are e^{λT} of its damped eigenvalues: all inside.
        assert!(point.max_floquet_modulus < 1.0);
    }
    assert!(
        worst < 1e-10,
        "largest relative error {worst:e} ({})",
        curve.integrator
    );
    // No fold or bifurcation; phase resonances (eq. (113)) where the exact response of the
    // forced dof is in quadrature with the force, `X₀ = −i|X₀|`, to the location's accuracy.
    assert!(!curve.events.is_empty());
    for event in &curve.events {
        assert_eq!(event.kind, ResponseEventKind::PhaseResonance);
        let x = exact_two_dof(k, c, 0.01, event.point.frequency)[0];
        assert!(
            x.0.abs() < 1e-7 * x.1.abs() && x.1 < 0.0,
            "{x:?} at {}",
            event.point.frequency
        );
    }
    // The curve passes both resonances (ω = 1 and √3) and lands on the end of the sweep.
    let last = curve.points.last().unwrap().frequency;
    assert!((last - 2.0).abs() < 1e-6, "last point at {last}");
}

#[test]
fn linear_response_equals_the_complex_solve_explicit() {
    linear_curve(IntegrationMethod::Dop853);
}

#[test]
fn linear_response_equals_the_complex_solve_implicit() {
    linear_curve(IntegrationMethod::Radau5);
    linear_curve(IntegrationMethod::Radau9);
}

#[test]
fn bad_sweeps_and_damping_are_refused_before_anything_is_computed() {
    let structure = two_masses(0.5);
    let force = HarmonicForce::cosine(vec![1.0, 0.0]);
    let indefinite = Matrix::from_rows(&[vec![0.01, 0.05], vec![0.05, 0.01]]).unwrap();
    let error = ForcedSystem::new(&structure, &indefinite, force.clone()).unwrap_err();
    assert!(
        error
            .to_string()
            .contains("not positive semi-definite (eigenvalue -0.04"),
        "{error}"
    );
    let zero = HarmonicForce::cosine(vec![0.0, 0.0]);
    let c = Matrix::from_rows(&[vec![0.0, 0.0], vec![0.0, 0.0]]).unwrap();
    assert!(
        ForcedSystem::new(&structure, &c, zero)
            .unwrap_err()
            .to_string()
            .contains("the force is zero")
    );
    let system = ForcedSystem::new(&structure, &c, force).unwrap();
    let settings = ResponseSettings::default();
    for (sweep, message) in [
        (
            Sweep::Frequency {
                from: 2.0,
                to: 1.0,
                amplitude: 1.0,
            },
            "frequency_end must exceed",
        ),
        (
            Sweep::Frequency {
                from: 0.0,
                to: 1.0,
                amplitude: 1.0,
            },
            "frequency_start must be positive",
        ),
        (
            Sweep::Frequency {
                from: 1.0,
                to: 2.0,
                amplitude: 0.0,
            },
            "non-zero",
        ),
    ] {
        let error = forced_response(
            &system,
            sweep,
            &[],
            &settings,
            |_| ControlFlow::Continue(()),
        )
        .unwrap_err();
        assert!(error.to_string().contains(message), "{error}");
    }
}

/// The first prefix of a path whose last point [`curve::closes`] finds back on the path, and
/// the earlier point it names (`None` when no prefix closes).
fn first_closing(points: &[(Vec<f64>, Vec<f64>)], step: f64) -> Option<(usize, usize)> {
    (1..=points.len())
        .find_map(|k| curve::closes(&points[..k], |(u, t)| (u, t, step)).map(|j| (k - 1, j)))
}

/// A circle walked in steps of 0.1 rad closes as soon as the second lap passes its start
/// (point 62, at 6.2 rad, 0.083 from point 0: within its step); a helix rising 0.05 a radian, 0.31 a lap
/// above its first, never does, nor does a hairpin that comes back beside itself (0.05
/// apart, within a step) running the other way.
#[test]
fn a_curve_that_retraces_a_loop_is_found_closed_and_no_other() {
    let h = 0.1;
    let circle: Vec<_> = (0..100)
        .map(|k| {
            let a = k as f64 * h;
            (vec![a.cos(), a.sin(), 0.0], vec![-a.sin(), a.cos(), 0.0])
        })
        .collect();
    assert_eq!(first_closing(&circle, h), Some((62, 0)));
    let helix: Vec<_> = (0..200)
        .map(|k| {
            let a = k as f64 * h;
            let norm = (1.0f64 + 0.05 * 0.05).sqrt();
            (
                vec![a.cos(), a.sin(), 0.05 * a],
                vec![-a.sin() / norm, a.cos() / norm, 0.05 / norm],
            )
        })
        .collect();
    assert_eq!(first_closing(&helix, h), None);
    let out = (0..30).map(|k| (vec![k as f64 * h, 0.0, 0.0], vec![1.0, 0.0, 0.0]));
    let back = (0..30).map(|k| (vec![(29 - k) as f64 * h, 0.05, 0.0], vec![-1.0, 0.0, 0.0]));
    let hairpin: Vec<_> = out.chain(back).collect();
    assert_eq!(first_closing(&hairpin, h), None);
}
