//! The forced integrators against each other: split stage systems against whole ones.

use super::*;
use crate::integrate::RADAU5;
use crate::integrate::tests::{assert_close_to_round_off, ten_element_von_karman_beam, tight};
use crate::model::{ForcedSystem, HarmonicForce, Matrix, MechanicalSystem, SparseMatrix};

/// A damped von Kármán beam (10 elements, nonlinear on every dof) driven from rest near its
/// first resonance (its middle moves 1.7 mm, a sixth of its thickness, within the period): the
/// motion integrated over a forcing period with split stage systems (the
/// recording integration, eq. (32f) with the damping blocks `h λ_j C`) equals the one with
/// the whole stage system (the integration that carries `Φ`), and so do the parameter
/// sensitivities and the recorded products — solved by refinement against the split systems
/// — against `Φ`'s columns: the same discrete flow and its derivative; the products a
/// Newton correction takes (stage solves to 1e-4) within 1e-4 of them.
#[test]
fn split_forced_stage_solves_equal_the_whole_factorisation() {
    let system = ten_element_von_karman_beam();
    let n = system.dofs();
    let n2 = 2 * n;
    // A damping that couples neighbouring dofs (a scaled graph Laplacian: symmetric, positive
    // semi-definite), so that `C`'s blocks enter every split system off the diagonal.
    let mut triplets = Vec::new();
    for i in 0..n {
        triplets.push((i, i, 0.1));
        if i + 1 < n {
            triplets.push((i, i + 1, -0.05));
            triplets.push((i + 1, i, -0.05));
        }
    }
    let damping = Matrix::Sparse(SparseMatrix::from_triplets(n, &triplets).unwrap());
    let mut shape = vec![0.0; n];
    shape[3 * 4 + 1] = 1.0; // the middle node's transverse dof
    let forced = ForcedSystem::new(&system, &damping, HarmonicForce::cosine(shape)).unwrap();
    let z0 = vec![0.0; n2];
    let drive = Drive {
        frequency: 300.0,
        amplitude: 3000.0,
    };
    let period = 2.0 * std::f64::consts::PI;
    let mut integrator = ForcedCollocation::new(&forced, &RADAU5, tight()).with_split_stages();
    let whole = integrator.flow(&z0, drive, period, true).unwrap();
    let (split, linearization) = integrator
        .flow_linearized(&z0, drive, period)
        .expect("a sparse stage system records")
        .unwrap();
    assert_close_to_round_off(&split.z, &whole.z, "motion");
    // The derivatives carry the two stage iterations' different stopping points (each at
    // its round-off floor) through a period of a stiff system: 1.5e-10 (parameter columns,
    // their stage solves refined to 1e-8 of the stage accelerations) and 1.7e-10 (products)
    // of their largest entries apart — against 1e-5 of them where the refinement leaves out
    // the damping blocks.
    let close = |x: &[f64], y: &[f64], what: &str| {
        let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (i, (a, b)) in x.iter().zip(y).enumerate() {
            assert!(
                (a - b).abs() <= 1e-9 * scale,
                "{what}, entry {i}: {a:e} split against {b:e} whole"
            );
        }
    };
    close(
        &split.sensitivity,
        &whole.sensitivity[n2 * n2..],
        "∂z/∂(Ω, a)",
    );
    // `Φ D` for three mixed directions, recorded products against the carried `Φ`.
    let k = 3;
    let directions: Vec<f64> = (0..n2 * k).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
    let mut product = vec![0.0; n2 * k];
    linearization.apply(&directions, k, &mut product);
    let carried: Vec<f64> = (0..n2 * k)
        .map(|e| {
            let (row, col) = (e % n2, e / n2);
            (0..n2)
                .map(|j| whole.sensitivity[j * n2 + row] * directions[col * n2 + j])
                .sum()
        })
        .collect();
    close(&product, &carried, "recorded products");
    // The products a Newton correction takes, each stage solve refined only to 1e-4 of its
    // largest entry: within 1e-4 of the exact ones (measured 2.9e-5, this hard start from
    // rest being far from any periodic motion's smoothness).
    let mut approximate = vec![0.0; n2 * k];
    linearization.apply_approximately(&directions, k, &mut approximate, 1e-4);
    let scale = product.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let apart = (approximate.iter().zip(&product)).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        apart <= 1e-4 * scale,
        "approximate products {apart:e} of {scale:e} apart"
    );
}

/// A step too long for the stage iteration — here eight steps a period on a von Kármán beam
/// driven hard from rest — is not an error of the curve: the integration is taken again on
/// half again as many steps a period until the stages converge (8 → 12 → 18), and that
/// count is kept as the least. The motion is then the one a fresh integrator gives on the
/// same steps, to round-off.
#[test]
fn stage_divergence_retries_on_more_steps() {
    let system = ten_element_von_karman_beam();
    let n = system.dofs();
    let damping = crate::forced::damping::Damping::Rayleigh([0.0, 1e-5])
        .matrix(&system)
        .unwrap();
    let mut shape = vec![0.0; n];
    shape[3 * 4 + 1] = 1.0;
    let forced = ForcedSystem::new(&system, &damping, HarmonicForce::cosine(shape)).unwrap();
    let drive = Drive {
        frequency: 300.0,
        amplitude: 3e3,
    };
    let period = 2.0 * std::f64::consts::PI;
    let z0 = vec![0.0; 2 * n];
    let mut retried = ForcedCollocation::new(&forced, &RADAU5, tight()).with_steps(8);
    let flow = retried.flow(&z0, drive, period, false).unwrap();
    let steps = retried.steps();
    assert!(
        steps > 2,
        "the two-step integration converged: nothing retried"
    );
    let mut fresh = ForcedCollocation::new(&forced, &RADAU5, tight()).with_steps(steps);
    let again = fresh.flow(&z0, drive, period, false).unwrap();
    assert_close_to_round_off(&flow.z, &again.z, "motion");
    assert_eq!(fresh.steps(), steps);
}
