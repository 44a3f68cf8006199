use super::*;
use crate::model::duffing;
use crate::model::{Block, MechanicalSystem};
use crate::reference::{duffing_amplitude, duffing_period};

fn identity(n2: usize) -> Vec<f64> {
    (0..n2 * n2)
        .map(|k| if k % (n2 + 1) == 0 { 1.0 } else { 0.0 })
        .collect()
}

/// Linear oscillator: the flow and its monodromy are known in closed form.
#[test]
fn harmonic_oscillator_flow_and_sensitivity_are_exact() {
    let w = 1.7;
    let system = duffing(w, 0.0).unwrap();
    let t = 2.3;
    for tableau in [&DOPRI5, &DOP853] {
        let mut integrator = RungeKutta::new(
            &system,
            tableau,
            Tolerances {
                relative: 1e-12,
                absolute: 1e-12,
                velocity_scale: 1.0,
            },
        );
        let eye = identity(2);
        let flow = integrator
            .flow(
                &[0.4, -0.3],
                t,
                Some(Block::new(&eye, 2, 2, 2)),
                Steps::Adaptive { first_step: None },
            )
            .unwrap();
        let (c, s) = ((w * t).cos(), (w * t).sin());
        let exact = [0.4 * c - 0.3 * s / w, -0.4 * w * s - 0.3 * c];
        let phi = [c, -w * s, s / w, c]; // column-major
        for i in 0..2 {
            assert!((flow.z[i] - exact[i]).abs() < 1e-10, "{}", tableau.name);
        }
        for k in 0..4 {
            assert!(
                (flow.sensitivity[k] - phi[k]).abs() < 1e-10,
                "{}",
                tableau.name
            );
        }
    }
}

/// Convergence order on a nonlinear problem with an exact reference: Duffing released from
/// rest returns to its initial state after the exact elliptic period. Halving a fixed step
/// must divide the error by about 2^p.
#[test]
fn observed_order_matches_tableau_order() {
    let (w0, alpha, amp) = (1.0, 1.0, 1.0);
    let system = duffing(w0, alpha).unwrap();
    let period = duffing_period(w0, alpha, amp);
    for (tableau, steps) in [(&DOPRI5, 200usize), (&DOP853, 40)] {
        let mut integrator = RungeKutta::new(
            &system,
            tableau,
            Tolerances {
                relative: 1e-10,
                absolute: 1e-10,
                velocity_scale: 1.0,
            },
        );
        let mut errors = vec![];
        for n in [steps, 2 * steps] {
            let h = vec![period / n as f64; n];
            let flow = integrator
                .flow(&[amp, 0.0], period, None, Steps::Replay(&h))
                .unwrap();
            errors.push(((flow.z[0] - amp).powi(2) + flow.z[1].powi(2)).sqrt());
        }
        let observed = (errors[0] / errors[1]).log2();
        let p = tableau.order as f64;
        assert!(
            (observed - p).abs() < 0.6,
            "{}: observed order {observed:.2}, errors {errors:?}",
            tableau.name
        );
    }
}

/// Accuracy follows the tolerance: at relative tolerance 1e-12 DOP853 returns to the start
/// after the exact period within ~1e-10 (global error is a modest multiple of the local one).
#[test]
fn adaptive_accuracy_follows_tolerance() {
    let (w0, alpha) = (1.0, 0.5);
    let system = duffing(w0, alpha).unwrap();
    let amp = duffing_amplitude(w0, alpha, 3.0);
    let period = duffing_period(w0, alpha, amp);
    for tol in [1e-8, 1e-10, 1e-12] {
        let mut integrator = RungeKutta::new(
            &system,
            &DOP853,
            Tolerances {
                relative: tol,
                absolute: tol * amp,
                velocity_scale: 1.0,
            },
        );
        let flow = integrator
            .flow(
                &[amp, 0.0],
                period,
                None,
                Steps::Adaptive { first_step: None },
            )
            .unwrap();
        let err = ((flow.z[0] - amp).powi(2) + flow.z[1].powi(2)).sqrt() / amp;
        assert!(
            err < 100.0 * tol,
            "tol {tol}: relative return error {err:.2e}"
        );
        assert!(flow.stats.steps > 5);
    }
}

/// The propagated sensitivities are the derivative of the discrete flow: central differences
/// of the flow with the same (replayed) steps agree to ~1e-8.
#[test]
fn sensitivity_matches_finite_differences_of_the_same_discrete_map() {
    let system = crate::model::two_dof(0.5).unwrap();
    let z0 = [0.8, 0.5, 0.1, -0.2];
    let mut integrator = RungeKutta::new(
        &system,
        &DOP853,
        Tolerances {
            relative: 1e-9,
            absolute: 1e-9,
            velocity_scale: 1.0,
        },
    );
    let eye = identity(4);
    let base = integrator
        .flow(
            &z0,
            5.0,
            Some(Block::new(&eye, 4, 4, 4)),
            Steps::Adaptive { first_step: None },
        )
        .unwrap();
    let h = 1e-6;
    for c in 0..4 {
        let (mut zp, mut zm) = (z0, z0);
        zp[c] += h;
        zm[c] -= h;
        let fp = integrator
            .flow(&zp, 5.0, None, Steps::Replay(&base.steps))
            .unwrap();
        let fm = integrator
            .flow(&zm, 5.0, None, Steps::Replay(&base.steps))
            .unwrap();
        for r in 0..4 {
            let fd = (fp.z[r] - fm.z[r]) / (2.0 * h);
            let exact = base.sensitivity[c * 4 + r];
            assert!(
                (fd - exact).abs() < 1e-8 * (1.0 + exact.abs()),
                "column {c} row {r}: fd {fd} vs {exact}"
            );
        }
    }
}

#[test]
fn rejects_bad_requests() {
    let system = duffing(1.0, 1.0).unwrap();
    let mut integrator = RungeKutta::new(
        &system,
        &DOP853,
        Tolerances {
            relative: 1e-8,
            absolute: 1e-8,
            velocity_scale: 1.0,
        },
    );
    let adaptive = Steps::Adaptive { first_step: None };
    assert!(matches!(
        integrator.flow(&[1.0], 1.0, None, adaptive),
        Err(IntegrationError::InvalidInput(_))
    ));
    assert!(matches!(
        integrator.flow(&[1.0, 0.0], -1.0, None, adaptive),
        Err(IntegrationError::InvalidInput(_))
    ));
    assert!(matches!(
        integrator.flow(&[f64::NAN, 0.0], 1.0, None, adaptive),
        Err(IntegrationError::NotFinite { .. })
    ));
    // A blow-up (softening spring beyond its well) is reported, not panicked on.
    let softening = duffing(1.0, -1.0).unwrap();
    let mut integrator = RungeKutta::new(&softening, &DOP853, integrator.tolerances);
    integrator.max_steps = 10_000;
    assert!(integrator.flow(&[3.0, 0.0], 50.0, None, adaptive).is_err());
}

// ------------------------------------------------------------------------------------------
// Gauss–Legendre collocation
// ------------------------------------------------------------------------------------------

/// The clamped 10-element von Kármán beam (27 dofs, nonlinear on every one): the integrators'
/// tests of split stage systems.
pub(super) fn ten_element_von_karman_beam() -> crate::model::Structure {
    von_karman_beam(10)
}

/// The default von Kármán beam (clamped, 1 m × 10 cm × 1 cm, aluminium) of `elements` elements.
pub(super) fn von_karman_beam(elements: usize) -> crate::model::Structure {
    crate::model::VonKarmanBeam {
        elements,
        ..Default::default()
    }
    .build()
    .unwrap()
}

/// A clamped von Kármán beam of `elements` elements (unit length) at rest, bent to its
/// thickness (1 cm) in the clamped shape and stretched: the interior nodes carry
/// `(u, w, θ)` with `w = a sin²(π ξ)`, `θ = w'`, `u = 1e-5 sin 2πξ`.
pub(super) fn bent_clamped_state(elements: usize) -> Vec<f64> {
    let a = 0.01;
    let mut z0 = vec![0.0; 6 * (elements - 1)];
    for node in 1..elements {
        let phase = std::f64::consts::PI * node as f64 / elements as f64;
        z0[3 * (node - 1)] = 1e-5 * (2.0 * phase).sin();
        z0[3 * (node - 1) + 1] = a * phase.sin().powi(2);
        z0[3 * (node - 1) + 2] = a * std::f64::consts::PI * (2.0 * phase).sin();
    }
    z0
}

pub(super) fn tight() -> Tolerances {
    Tolerances {
        relative: 1e-12,
        absolute: 1e-12,
        velocity_scale: 1.0,
    }
}

/// The linear oscillator's flow and monodromy by both collocation methods, with their
/// self-chosen steps, against the closed form.
#[test]
fn gauss_harmonic_oscillator_flow_and_sensitivity_are_exact() {
    let w = 1.7;
    let system = duffing(w, 0.0).unwrap();
    let t = 2.3;
    for method in [&GAUSS4, &GAUSS6] {
        let mut integrator = GaussLegendre::new(&system, method, tight());
        let eye = identity(2);
        let flow = integrator
            .flow(
                &[0.4, -0.3],
                t,
                Some(Block::new(&eye, 2, 2, 2)),
                Steps::Adaptive { first_step: None },
            )
            .unwrap();
        let (c, s) = ((w * t).cos(), (w * t).sin());
        let exact = [0.4 * c - 0.3 * s / w, -0.4 * w * s - 0.3 * c];
        let phi = [c, -w * s, s / w, c];
        for (a, b) in flow.z.iter().zip(&exact) {
            assert!((a - b).abs() < 1e-10, "{}: {a} vs {b}", method.name);
        }
        for (a, b) in flow.sensitivity.iter().zip(&phi) {
            assert!((a - b).abs() < 1e-10, "{}: {a} vs {b}", method.name);
        }
    }
}

/// Halving a fixed step divides the error of Duffing's closed orbit by about `2^(2s)`.
#[test]
fn gauss_observed_order_matches_2s() {
    let (w0, alpha, amp) = (1.0, 1.0, 1.0);
    let system = duffing(w0, alpha).unwrap();
    let period = duffing_period(w0, alpha, amp);
    for (method, steps) in [(&GAUSS4, 40usize), (&GAUSS6, 16)] {
        let mut integrator = GaussLegendre::new(&system, method, tight());
        let error = |n: usize, integrator: &mut GaussLegendre<'_, _>| {
            let h = vec![period / n as f64; n];
            let flow = integrator
                .flow(&[amp, 0.0], period, None, Steps::Replay(&h))
                .unwrap();
            (flow.z[0] - amp).hypot(flow.z[1])
        };
        let (e1, e2) = (
            error(steps, &mut integrator),
            error(2 * steps, &mut integrator),
        );
        let observed = (e1 / e2).log2();
        assert!(
            (observed - method.order as f64).abs() < 0.5,
            "{}: observed order {observed:.2} ({e1:.2e} → {e2:.2e})",
            method.name
        );
    }
}

/// The sensitivities are the derivative of the discrete map: central differences of the
/// same steps agree.
#[test]
fn gauss_sensitivity_matches_finite_differences_of_the_same_discrete_map() {
    let system = crate::model::two_dof(0.5).unwrap();
    let mut integrator = GaussLegendre::new(&system, &GAUSS6, tight());
    let z0 = [1.2, -0.4, 0.3, 0.5];
    let eye = identity(4);
    let base = integrator
        .flow(
            &z0,
            5.0,
            Some(Block::new(&eye, 4, 4, 4)),
            Steps::Adaptive { first_step: None },
        )
        .unwrap();
    let delta = 1e-6;
    for c in 0..4 {
        let (mut zp, mut zm) = (z0, z0);
        zp[c] += delta;
        zm[c] -= delta;
        let p = integrator
            .flow(&zp, 5.0, None, Steps::Replay(&base.steps))
            .unwrap();
        let m = integrator
            .flow(&zm, 5.0, None, Steps::Replay(&base.steps))
            .unwrap();
        for r in 0..4 {
            let fd = (p.z[r] - m.z[r]) / (2.0 * delta);
            let sens = base.sensitivity[c * 4 + r];
            assert!(
                (fd - sens).abs() < 1e-7 * (1.0 + sens.abs()),
                "({r},{c}): {fd} vs {sens}"
            );
        }
    }
}

/// Symplectic even where the step resolves nothing: on a stiff linear chain (frequencies 1
/// and ~1414, steps of ~0.1 so `ωh ≈ 140` for the fast mode) the discrete monodromy satisfies
/// `Φᵀ Ω Φ = Ω` (unit mass), so no mode is damped or amplified — the explicit schemes either
/// need thousands of steps here or damp the fast mode.
#[test]
fn gauss_monodromy_is_symplectic_on_a_stiff_model() {
    let k = 1e6;
    let stiffness = crate::Mat::from_fn(2, 2, |i, j| if i == j { k + 1.0 } else { -k });
    let system = crate::model::Structure::new(
        crate::Mat::identity(2, 2),
        stiffness,
        vec![Box::new(crate::model::PolynomialSpring::cubic(
            0, None, 0.3,
        ))],
    )
    .unwrap();
    let mut integrator = GaussLegendre::new(&system, &GAUSS6, tight());
    let eye = identity(4);
    let steps = vec![2.0 * std::f64::consts::PI / 64.0; 64];
    let flow = integrator
        .flow(
            &[0.5, 0.5, 0.0, 0.0],
            2.0 * std::f64::consts::PI,
            Some(Block::new(&eye, 4, 4, 4)),
            Steps::Replay(&steps),
        )
        .unwrap();
    let phi = |r: usize, c: usize| flow.sensitivity[c * 4 + r];
    // Entries reach ω ≈ 1414: round-off is relative to ‖Φ‖².
    let scale = flow.sensitivity.iter().fold(0.0f64, |m, v| m.max(v * v));
    // Ω = [[0, I], [-I, 0]]; (Φᵀ Ω Φ)_ab = Σ_i Φ_ia Φ_(i+2)b - Φ_(i+2)a Φ_ib.
    for a in 0..4 {
        for b in 0..4 {
            let value: f64 = (0..2)
                .map(|i| phi(i, a) * phi(i + 2, b) - phi(i + 2, a) * phi(i, b))
                .sum();
            let expected = match (a, b) {
                (0, 2) | (1, 3) => 1.0,
                (2, 0) | (3, 1) => -1.0,
                _ => 0.0,
            };
            assert!(
                (value - expected).abs() < 1e-12 * scale,
                "({a},{b}): {value}"
            );
        }
    }
}

/// `Auto` picks the implicit methods for the stiff beam (highest frequency ~4000× the first):
/// Gauss6 at 38 dofs, Radau9 at 100; the explicit one for the bladed disk (≤ 14×) and Duffing.
#[test]
fn auto_resolves_by_stiffness() {
    let beam = crate::model::CantileverBeam::default().build().unwrap();
    let disk = crate::model::BladedDisk::default().build().unwrap();
    let duffing = duffing(1.0, 1.0).unwrap();
    let beam_omega = 2.0 * std::f64::consts::PI * 23.6615;
    assert_eq!(
        IntegrationMethod::Auto.resolve(&beam, beam_omega),
        IntegrationMethod::Gauss6
    );
    // The same beam refined past `SYMPLECTIC_DOFS`: the damping collocation.
    let fine = crate::model::CantileverBeam {
        elements: 50,
        ..crate::model::CantileverBeam::default()
    }
    .build()
    .unwrap();
    assert_eq!(
        IntegrationMethod::Auto.resolve(&fine, beam_omega),
        IntegrationMethod::Radau9
    );
    assert_eq!(
        IntegrationMethod::Auto.resolve(&disk, 0.18),
        IntegrationMethod::Dop853
    );
    assert_eq!(
        IntegrationMethod::Auto.resolve(&duffing, 1.0),
        IntegrationMethod::Dop853
    );
    assert_eq!(
        IntegrationMethod::Dopri5.resolve(&beam, beam_omega),
        IntegrationMethod::Dopri5
    );
}

/// The recorded linearisation is the sensitivity integrated with the motion: on a sparse
/// finite-element beam (Radau5) and on the dense two-dof system (Gauss6), `Φ D` applied after
/// the integration equals the columns propagated with it, and the motion is the same.
#[test]
fn recorded_linearization_equals_the_integrated_sensitivities() {
    let beam = crate::model::CantileverBeam {
        elements: 6,
        ..Default::default()
    }
    .build()
    .unwrap();
    let two_dof = crate::model::two_dof(0.5).unwrap();
    let cases: [(&dyn MechanicalSystem, &'static Collocation); 3] =
        [(&beam, &GAUSS6), (&two_dof, &RADAU5), (&beam, &RADAU5)];
    for (system, method) in cases {
        let n2 = 2 * system.dofs();
        let mut integrator = GaussLegendre::new(system, method, tight());
        let z0: Vec<f64> = (0..n2).map(|i| 1e-5 * (1.0 + (i % 5) as f64)).collect();
        let k = 3;
        let directions: Vec<f64> = (0..n2 * k).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
        let with = integrator
            .flow(
                &z0,
                0.02,
                Some(Block::new(&directions, n2, k, n2)),
                Steps::Replay(&[0.02 / 40.0; 40]),
            )
            .unwrap();
        let (flow, linearization) = integrator
            .flow_linearized(&z0, 0.02, Steps::Replay(&with.steps))
            .unwrap();
        assert_eq!(flow.z, with.z);
        assert_eq!(linearization.dimension(), n2);
        let mut product = vec![0.0; n2 * k];
        linearization.apply(&directions, k, &mut product);
        let scale = with.sensitivity.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (a, b) in product.iter().zip(&with.sensitivity) {
            assert!((a - b).abs() <= 1e-13 * scale, "{a} vs {b}");
        }
    }
}

/// Sampling in one pass (the collocation methods keep their stage factorisation from step to
/// step) gives the states of integrating each division on its own, on the same steps, on a
/// stiff beam (Gauss6, Radau5).
#[test]
fn sampled_flow_equals_the_divisions_integrated_one_by_one() {
    let beam = crate::model::CantileverBeam {
        elements: 6,
        ..Default::default()
    }
    .build()
    .unwrap();
    let n2 = 2 * beam.dofs();
    let z0: Vec<f64> = (0..n2).map(|i| 1e-5 * (1.0 + (i % 5) as f64)).collect();
    let (duration, samples) = (0.02, 8);
    let division = [duration / samples as f64 / 5.0; 5];
    let mut integrators: Vec<Box<dyn Integrator + '_>> = vec![
        Box::new(GaussLegendre::new(&beam, &GAUSS6, tight())),
        Box::new(GaussLegendre::new(&beam, &RADAU5, tight())),
    ];
    for integrator in &mut integrators {
        let (flow, states) = integrator
            .flow_sampled(&z0, duration, samples, Steps::Replay(&division))
            .unwrap();
        let (one_by_one, reference) = sampled_by_divisions(
            integrator.as_mut(),
            &z0,
            duration,
            samples,
            Steps::Replay(&division),
        )
        .unwrap();
        assert_eq!(states.len(), samples);
        assert_eq!(flow.steps, one_by_one.steps);
        assert_eq!(flow.z, *states.last().unwrap());
        for (a, b) in states.iter().zip(&reference) {
            let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (x, y) in a.iter().zip(b) {
                // The same discrete map; only the stage Newton's stopping point differs.
                assert!((x - y).abs() <= 1e-10 * scale, "{x} vs {y}");
            }
        }
    }
}

/// Asserts that `x` equals `y` to 1e-10 of `y`'s largest entry: two exact stage solvers
/// (whole, low-rank, split) differ by the stage systems' round-off.
pub(super) fn assert_close_to_round_off(x: &[f64], y: &[f64], what: &str) {
    let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let error = x
        .iter()
        .zip(y)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(
        x.iter().chain(y).all(|v| v.is_finite()) && error <= 1e-10 * scale,
        "{what} off by {error:e} of {scale:e}"
    );
}

/// A system with its nonlinear dofs withheld: the stage systems are then factorised whole
/// every step, as for a nonlinearity spread over the mesh.
struct Spread<'a>(&'a dyn MechanicalSystem);

impl MechanicalSystem for Spread<'_> {
    fn dofs(&self) -> usize {
        self.0.dofs()
    }
    fn mass(&self) -> &dyn crate::model::MassOperator {
        self.0.mass()
    }
    fn internal_force(&self, x: &[f64], f: &mut [f64]) {
        self.0.internal_force(x, f)
    }
    fn tangent_stiffness(&self, x: &[f64], dx: Block<'_>, out: crate::model::BlockMut<'_>) {
        self.0.tangent_stiffness(x, dx, out)
    }
    fn potential_energy(&self, x: &[f64]) -> f64 {
        self.0.potential_energy(x)
    }
    fn tangent_pattern(&self) -> Option<&crate::model::SparsityPattern> {
        self.0.tangent_pattern()
    }
    fn tangent_values(&self, x: &[f64], values: &mut [f64]) {
        self.0.tangent_values(x, values)
    }
}

/// The low-rank stage solves (eq. (32e)) are the stage Jacobian's: on the 19-element ECL beam
/// (a cubic spring at the tip, `p = 1`) and a 10-element beam with cubic springs on three
/// dofs, at an amplitude where the springs carry a large share of the force, the motion, its
/// sensitivities (Gauss6) and the recorded linearisation's products (Radau5) agree with those
/// of the whole stage system factorised every step.
#[test]
fn low_rank_stage_solves_equal_the_whole_factorisation() {
    use crate::model::{CantileverBeam, NonlinearElement, PolynomialSpring, Structure};
    let ecl = CantileverBeam::default().build().unwrap();
    let coarse = CantileverBeam {
        elements: 10,
        ..Default::default()
    }
    .build()
    .unwrap();
    let springs: Vec<Box<dyn NonlinearElement>> = vec![
        Box::new(PolynomialSpring::cubic(18, None, 6e9)),
        Box::new(PolynomialSpring::cubic(10, Some(12), 3e9)),
    ];
    let three = Structure::new(
        coarse.mass_matrix().clone(),
        coarse.stiffness().clone(),
        springs,
    )
    .unwrap();
    for system in [&ecl, &three] {
        let n2 = 2 * system.dofs();
        // From rest in the static shape of a tip load (w = δ ξ²(3L − ξ)/(2L³)), 4 mm at the
        // tip: past the ECL beam's +20% point, the spring stiffer than the beam.
        let (nodes, length, tip) = (system.dofs() / 2, 0.7, 4e-3);
        let mut z0 = vec![0.0; n2];
        for k in 1..=nodes {
            let xi = length * k as f64 / nodes as f64;
            z0[2 * k - 2] = tip * xi * xi * (3.0 * length - xi) / (2.0 * length.powi(3));
            z0[2 * k - 1] = tip * (6.0 * length * xi - 3.0 * xi * xi) / (2.0 * length.powi(3));
        }
        let k = 4;
        let directions: Vec<f64> = (0..n2 * k).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
        let steps = [0.04 / 64.0; 64];
        for method in [&GAUSS6, &RADAU5] {
            let mut low_rank = GaussLegendre::new(system, method, tight());
            assert!(low_rank.solves_low_rank());
            let spread = Spread(system);
            let mut whole = GaussLegendre::new(&spread, method, tight());
            assert!(!whole.solves_low_rank());
            let block = Block::new(&directions, n2, k, n2);
            let a = low_rank.flow(&z0, 0.04, Some(block), Steps::Replay(&steps));
            let b = whole.flow(&z0, 0.04, Some(block), Steps::Replay(&steps));
            let (a, b) = (a.unwrap(), b.unwrap());
            // Both are exact to the stage systems' round-off, whose condition grows like
            // (ω_max h)²: measured differences 3e-13 to 1e-11 of the largest entry.
            let close = |x: &[f64], y: &[f64], what: &str| {
                assert_close_to_round_off(x, y, &format!("{}: {what}", method.name))
            };
            close(&a.z, &b.z, "motion");
            close(&a.sensitivity, &b.sensitivity, "sensitivities");
            let (_, linearization) = low_rank
                .flow_linearized(&z0, 0.04, Steps::Replay(&steps))
                .unwrap();
            let mut product = vec![0.0; n2 * k];
            linearization.apply(&directions, k, &mut product);
            close(&product, &b.sensitivity, "recorded products");
        }
    }
}

/// The split stage systems (eq. (32f)) against the whole one. On a 10-element von Kármán
/// beam — nonlinear on every dof, so its stage systems are split when no sensitivities are
/// carried — bent to its thickness in its first mode's static shape and stretched axially, the
/// motion integrated with split stages (no sensitivities) equals the one integrated with the
/// whole stage system (sensitivities carried), and the products of the recorded linearisation,
/// solved by refinement against the split systems, equal the sensitivities: same steps, Gauss6
/// and Radau5.
#[test]
fn split_stage_solves_equal_the_whole_factorisation() {
    let system = ten_element_von_karman_beam();
    let n2 = 2 * system.dofs();
    let z0 = bent_clamped_state(10);
    let k = 3;
    let directions: Vec<f64> = (0..n2 * k).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
    let steps = [0.01 / 48.0; 48];
    for method in [&GAUSS6, &RADAU5] {
        let mut integrator = GaussLegendre::new(&system, method, tight()).with_split_stages();
        let whole = integrator
            .flow(
                &z0,
                0.01,
                Some(Block::new(&directions, n2, k, n2)),
                Steps::Replay(&steps),
            )
            .unwrap();
        let (split, linearization) = integrator
            .flow_linearized(&z0, 0.01, Steps::Replay(&steps))
            .unwrap();
        let close = |x: &[f64], y: &[f64], what: &str| {
            assert_close_to_round_off(x, y, &format!("{}: {what}", method.name))
        };
        close(&split.z, &whole.z, "motion");
        let mut product = vec![0.0; n2 * k];
        linearization.apply(&directions, k, &mut product);
        close(&product, &whole.sensitivity, "recorded products");
        // One direction at a time (the matrix-free products) too.
        let mut single = vec![0.0; n2];
        linearization.apply(&directions[n2..2 * n2], 1, &mut single);
        close(&single, &whole.sensitivity[n2..2 * n2], "a single product");
    }
}

/// Refined split solves stop at the round-off floor of their residual (eq. (32g)) and lose
/// nothing by it: on a 300-element von Kármán beam (897 dofs) bent to a tenth of its
/// thickness, over half its first period in 10 Radau9 steps (what the forced curves take),
/// the recorded products of the bent shape and of its mirror image equal the sensitivities
/// integrated with the whole stage system to 3e-8 (measured: 1.0e-8 and 9.1e-9; refined for
/// all 30 sweeps: 8.8e-9 — the two factorisations' round-off, which grows like `n³`–`n⁴`:
/// 4.5e-10 at 100 elements, 8e-7 at 1,000). Stopped at corrections of 1e-4 of the end state
/// instead, they miss by 1.5e-5.
#[test]
fn split_solves_refined_to_their_floor_equal_the_whole_factorisation() {
    let elements = 300;
    let system = von_karman_beam(elements);
    let n2 = 2 * system.dofs();
    let z0: Vec<f64> = bent_clamped_state(elements)
        .iter()
        .map(|v| 0.1 * v)
        .collect();
    let mut directions = z0.clone();
    directions.extend(z0.iter().rev());
    let k = 2;
    let span = 0.0095;
    let steps = [span / 10.0; 10];
    let mut integrator = GaussLegendre::new(&system, &RADAU9, tight()).with_split_stages();
    let whole = integrator
        .flow(
            &z0,
            span,
            Some(Block::new(&directions, n2, k, n2)),
            Steps::Replay(&steps),
        )
        .unwrap();
    let (_, linearization) = integrator
        .flow_linearized(&z0, span, Steps::Replay(&steps))
        .unwrap();
    for col in 0..k {
        let mut product = vec![0.0; n2];
        linearization.apply(&directions[col * n2..(col + 1) * n2], 1, &mut product);
        let expected = &whole.sensitivity[col * n2..(col + 1) * n2];
        let scale = expected.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let error = (product.iter().zip(expected)).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(
            error <= 3e-8 * scale,
            "direction {col} off by {error:e} of {scale:e}"
        );
    }
}

/// Above `PARALLEL_DOFS` the split systems are solved, and the refinement's stage residuals
/// formed, on the threads of the pool: the motion and the recorded products of a
/// 3,336-element von Kármán beam (10,005 dofs) are the same to the last bit on one thread and
/// on two.
#[test]
fn split_stage_solves_are_the_same_on_one_thread_and_on_two() {
    let elements = 3336;
    let system = von_karman_beam(elements);
    let n2 = 2 * system.dofs();
    assert!(n2 / 2 >= super::collocation::SPLIT_DOFS);
    let z0 = bent_clamped_state(elements);
    let directions: Vec<f64> = (0..n2).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
    let steps = [1e-4; 3];
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut integrator = GaussLegendre::new(&system, &RADAU5, tight()).with_split_stages();
            let (flow, linearization) = integrator
                .flow_linearized(&z0, 3e-4, Steps::Replay(&steps))
                .unwrap();
            let mut product = vec![0.0; n2];
            linearization.apply(&directions, 1, &mut product);
            (flow.z, product)
        })
    };
    let (one, two) = (run(1), run(2));
    assert!(one.0.iter().all(|v| v.is_finite()));
    assert_eq!(one.0, two.0, "motion");
    assert_eq!(one.1, two.1, "recorded products");
}
