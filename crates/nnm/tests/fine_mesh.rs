//! Finite-element meshes fine enough for double precision to run out (docs/method.md §15,
//! eqs. (76a)–(76c)): the ECL beam at 300 and 1,000 Hermite elements, whose stiffness rows
//! cancel 10¹⁰–10¹⁴-fold on a smooth field.

use std::ops::ControlFlow;

use nnm::integrate::{IntegrationMethod, Steps, Tolerances};
use nnm::model::{CantileverBeam, MechanicalSystem, Structure};
use nnm::modes::lowest_modes;
use nnm::prelude::*;
use nnm::shooting::Formulation;

fn beam(elements: usize) -> Structure {
    CantileverBeam {
        elements,
        ..CantileverBeam::default()
    }
    .build()
    .unwrap()
}

/// `√(xᵀ f_int(x) + vᵀ M v)`: the energy norm of a state (of a displacement difference at
/// the small amplitudes used here, where the force is linear).
fn energy_norm(system: &Structure, z: &[f64]) -> f64 {
    let n = system.dofs();
    let mut f = vec![0.0; n];
    system.internal_force(&z[..n], &mut f);
    let mut mv = vec![0.0; n];
    system.mass().apply(&z[n..], 1, &mut mv);
    let work: f64 = z[..n].iter().zip(&f).map(|(a, b)| a * b).sum();
    let kinetic: f64 = z[n..].iter().zip(&mv).map(|(a, b)| a * b).sum();
    (work.abs() + kinetic).sqrt()
}

/// The flow over half a period of the first mode is reproducible: a state perturbed by
/// 1e-14 of itself lands where the recorded linearisation says, to 1e-10 of the orbit in the
/// energy norm. What is left is round-off; with plain row sums of `K x` it was 5e-9 on this
/// 300-element beam (2.2e-7 at 1,000 elements) and Newton could not converge below it;
/// summed in twice the precision where rows cancel (eq. (76c)), 1.4e-11.
#[test]
fn a_fine_mesh_flow_is_reproducible_to_round_off() {
    let system = beam(300);
    let n = system.dofs();
    let mode = &lowest_modes(&system, 1).unwrap()[0];
    let amplitude = 1e-4;
    let mut z0 = vec![0.0; 2 * n];
    for (z, s) in z0.iter_mut().zip(&mode.shape) {
        *z = amplitude * s;
    }
    let tolerances = Tolerances {
        relative: 1e-10,
        absolute: 1e-10 * amplitude,
        velocity_scale: mode.frequency,
    };
    let mut integrator = IntegrationMethod::Radau5.integrator(&system, tolerances);
    let half = std::f64::consts::PI / mode.frequency;
    let (flow, linearization) = integrator
        .flow_linearized(&z0, half, Steps::Adaptive { first_step: None })
        .unwrap();
    let perturbation: Vec<f64> = (0..2 * n)
        .map(|i| 1e-14 * amplitude * (0.7 * i as f64).sin() * mode.shape[i % n].abs())
        .collect();
    let perturbed: Vec<f64> = z0.iter().zip(&perturbation).map(|(a, b)| a + b).collect();
    let moved = integrator
        .flow(&perturbed, half, None, Steps::Replay(&flow.steps))
        .unwrap();
    let mut predicted = vec![0.0; 2 * n];
    linearization.apply(&perturbation, 1, &mut predicted);
    let mismatch: Vec<f64> = (0..2 * n)
        .map(|i| moved.z[i] - flow.z[i] - predicted[i])
        .collect();
    let noise = energy_norm(&system, &mismatch) / energy_norm(&system, &z0);
    eprintln!(
        "300 elements, {} steps: round-off of the flow {noise:.2e}",
        flow.steps.len()
    );
    assert!(noise < 1e-10, "{noise:.2e}");
}

/// The 1,000-element beam (2,000 dofs: the lowest modes by shift-invert, matrix-free shooting
/// chosen automatically) converges along its first NNM — Newton diverged on the first point
/// before eqs. (76a)–(76c) — and its points agree with an independent computation: the
/// 100-element model shot with the dense formulation, interpolated at the same energies
/// (the two meshes' first frequencies differ by ~1e-9, Hermite elements converging like
/// `h⁴`).
#[test]
fn a_thousand_element_beam_converges_and_agrees_with_a_coarser_mesh() {
    let fine = beam(1000);
    let start = Start::from_mode(&fine, 0).unwrap();
    let mut settings = Settings::default();
    settings.limits.max_points = 6;
    settings.stability.events = false;
    let branch = continue_branch(&fine, &start, &settings, |_| ControlFlow::Continue(())).unwrap();
    assert_eq!(branch.points.len(), 6);
    let last_energy = branch.points.last().unwrap().energy;

    let coarse = beam(100);
    let mut settings = Settings::default();
    settings.limits.energy_max = 1.5 * last_energy;
    settings.stability.events = false;
    settings.shooting.formulation = Formulation::Dense;
    let start = Start::from_mode(&coarse, 0).unwrap();
    let reference =
        continue_branch(&coarse, &start, &settings, |_| ControlFlow::Continue(())).unwrap();
    let curve: Vec<(f64, f64)> = reference
        .points
        .iter()
        .map(|p| (p.energy, p.frequency))
        .collect();
    // ω(E) is linear in E to O(E²) this close to the linear limit: linear interpolation.
    let interpolated = |e: f64| {
        let k = curve
            .windows(2)
            .position(|w| w[0].0 <= e && e <= w[1].0)
            .expect("the reference covers the energies");
        let ((e0, w0), (e1, w1)) = (curve[k], curve[k + 1]);
        w0 + (w1 - w0) * (e - e0) / (e1 - e0)
    };
    let shift = branch.points.last().unwrap().frequency / branch.points[0].frequency - 1.0;
    let mut worst = 0.0f64;
    for p in branch.points.iter().filter(|p| p.energy >= curve[0].0) {
        worst = worst.max((p.frequency / interpolated(p.energy) - 1.0).abs());
    }
    eprintln!(
        "1,000 elements: {} points to {:.2e} (shift {shift:.1e}); against 100 elements: {worst:.1e}",
        branch.points.len(),
        last_energy
    );
    assert!(shift > 0.0, "the frequency rises along the branch");
    assert!(worst < 1e-7, "{worst:.1e}");

    // Stability: so close to the linear limit the largest non-trivial multiplier (the second
    // mode's, inside the unit circle by Radau IIA's damping, ~1 − 1e-5) moves continuously
    // with the energy, and every point is stable. With the Floquet Arnoldi orthonormal in the
    // Jacobi coordinates' Euclidean product it scattered by up to 1e-3 from point to point,
    // and the fifth point was reported unstable (|μ| = 1.00065).
    let moduli: Vec<f64> = branch
        .points
        .iter()
        .map(|p| p.floquet.max_modulus)
        .collect();
    let scatter = moduli
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0, f64::max);
    eprintln!("largest non-trivial |μ| along the branch: {moduli:?}");
    assert!(branch.points.iter().all(|p| p.floquet.stable), "{moduli:?}");
    assert!(scatter < 1e-6, "{moduli:?}");
}
