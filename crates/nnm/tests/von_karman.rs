//! The von Kármán beam end to end: the first NNM's backbone hardens as the immovable-ends
//! theory predicts (the axial dofs condensed statically), through shooting, continuation and
//! the implicit integrator on the assembled sparse tangent.

use std::ops::ControlFlow;

use nnm::model::VonKarmanBeam;
use nnm::prelude::*;
use nnm::shooting::Formulation;

/// Solves the small dense system `a x = b` by Gaussian elimination with partial pivoting.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for k in 0..n {
        let p = (k..n)
            .max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))
            .unwrap();
        a.swap(k, p);
        b.swap(k, p);
        for i in k + 1..n {
            let f = a[i][k] / a[k][k];
            let (top, bottom) = a.split_at_mut(i);
            for (r, p) in bottom[0][k..].iter_mut().zip(&top[k][k..]) {
                *r -= f * p;
            }
            b[i] -= f * b[k];
        }
    }
    let mut x = vec![0.0; n];
    for k in (0..n).rev() {
        let s: f64 = (k + 1..n).map(|j| a[k][j] * x[j]).sum();
        x[k] = (b[k] - s) / a[k][k];
    }
    x
}

/// With the axial dofs at their static equilibrium (`∂V/∂u = 0`), the potential along the
/// first mode `w = q φ` is exactly `½ ω₁² q² + ¼ α q⁴`: `V` is quadratic in `u` with the
/// linear term `g(q) = f_u(0, q φ)` quadratic in `q`, so the minimum over `u` subtracts
/// `½ gᵀ K_uu⁻¹ g`, quartic. Backbone of the Duffing equation `q'' + ω₁² q + α q³ = 0`, to
/// first order in the energy: `ω/ω₁ − 1 = 3 α E / (4 ω₁⁴)`. The first point of the branch
/// (shift ~1e-4) must agree to 0.5% (axial inertia, neglected by the condensation, enters
/// as `(2ω₁/ω_axial)² ≈ 2e-3`; measured −0.2%), and the branch must harden.
///
/// Four elements (9 dofs), three points: 0.4 s. (Eight elements: ~1800 Gauss6 steps a half
/// period, the axial vibrations the quadratic coupling drives reaching 405 ω₁.)
#[test]
fn first_backbone_hardens_as_the_condensed_duffing_predicts() {
    let beam = VonKarmanBeam {
        elements: 4,
        ..Default::default()
    };
    let s = beam.build().unwrap();
    let n = s.dofs();
    let modes = linear_modes(&s).unwrap();
    let (omega, phi) = (modes[0].frequency, &modes[0].shape);
    assert!(
        phi.iter().step_by(3).all(|u| u.abs() < 1e-12),
        "a bending mode"
    );

    let axial: Vec<usize> = (0..n).step_by(3).collect();
    let mut f = vec![0.0; n];
    s.internal_force(phi, &mut f);
    let g: Vec<f64> = axial.iter().map(|&i| f[i]).collect();
    let k_uu: Vec<Vec<f64>> = axial
        .iter()
        .map(|&i| axial.iter().map(|&j| s.stiffness().get(i, j)).collect())
        .collect();
    let u = solve(k_uu, g.clone());
    let condensed =
        s.potential_energy(phi) - 0.5 * g.iter().zip(&u).map(|(a, b)| a * b).sum::<f64>();
    let alpha = 4.0 * (condensed - 0.5 * omega * omega);
    assert!(alpha > 0.0, "hardening: α = {alpha}");

    // Started where the predicted shift is 1e-3 (the default start, where the membrane
    // forces' work on the mode is 1e-4 of the linear ones', eq. (16a), is at a shift of
    // ~3e-5).
    let energy = 1e-3 * 4.0 * omega.powi(4) / (3.0 * alpha);
    let start = Start::from_linear_mode(&s, &modes, 0, Some(energy)).unwrap();
    let mut settings = Settings::default();
    settings.limits.max_points = 3;
    settings.stability.events = false;
    let branch = continue_branch(&s, &start, &settings, |_| ControlFlow::Continue(())).unwrap();
    let points = &branch.points;
    assert_eq!(points.len(), 3);
    let first = &points[0];
    let predicted = 3.0 * alpha * first.energy / (4.0 * omega.powi(4));
    let shift = first.frequency / omega - 1.0;
    assert!(
        (shift / predicted - 1.0).abs() < 5e-3,
        "shift {shift:e} vs {predicted:e} at E = {:e}",
        first.energy
    );
    for w in points.windows(2) {
        assert!(w[1].energy > w[0].energy && w[1].frequency > w[0].frequency);
    }
}

/// The default start (docs/method.md eq. (16a)): the membrane force, quadratic in the
/// transverse displacement, is 1e-4 of the linear one where the frequency has moved by 1e-12;
/// the start is where its work on the mode is 1e-4 of the linear force's, so the first point's
/// frequency has moved measurably and the motion is still weakly nonlinear (a shift of a few
/// 1e-5: the uncondensed cubic's `3/8 · 1e-4`, less what the axial dofs take).
#[test]
fn default_start_is_where_the_frequency_has_just_moved() {
    let s = VonKarmanBeam {
        elements: 4,
        ..Default::default()
    }
    .build()
    .unwrap();
    let modes = linear_modes(&s).unwrap();
    let start = Start::from_linear_mode(&s, &modes, 0, None).unwrap();
    let mut settings = Settings::default();
    settings.limits.max_points = 1;
    settings.stability.events = false;
    let branch = continue_branch(&s, &start, &settings, |_| ControlFlow::Continue(())).unwrap();
    let shift = branch.points[0].frequency / modes[0].frequency - 1.0;
    assert!((1e-5..1e-4).contains(&shift), "first shift {shift:e}");
}

/// A fine von Kármán mesh gets its lowest modes although its full spectrum cannot be refined
/// to the residual check: 300 elements (897 dofs, below the size where only the lowest modes
/// are computed) failed with "modal analysis did not converge" (worst residual 3.6e-3, the
/// axial end of the spectrum); the lowest modes by shift-invert are all shooting needs. The
/// first one is the clamped–clamped Euler–Bernoulli beam's, `ω₁ = (β₁/L)² √(EI/ρA)` with
/// `β₁ L = 4.730040744862704` (Hermite elements converge like `h⁴`: far below 1e-8 at 300).
#[test]
fn a_fine_mesh_gets_its_lowest_modes_when_the_full_spectrum_fails_its_check() {
    let definition = VonKarmanBeam {
        elements: 300,
        ..VonKarmanBeam::default()
    };
    let beam = definition.build().unwrap();
    let modes = nnm::modes::linear_modes(&beam).expect("the lowest modes");
    let (e, rho) = (definition.youngs_modulus, definition.density);
    let (b, t, l) = (definition.width, definition.thickness, definition.length);
    let (area, inertia) = (b * t, b * t.powi(3) / 12.0);
    let theory = (4.730040744862704 / l).powi(2) * (e * inertia / (rho * area)).sqrt();
    let first = modes[0].frequency;
    assert!(
        (first / theory - 1.0).abs() < 1e-8,
        "{first} against {theory}"
    );
}

/// Parity half-period shooting (docs/method.md eq. (9b)) against full-period shooting. The
/// von Kármán beam is not odd — its membrane force is even in the transverse displacement —
/// but flipping the transverse dofs and keeping the axial ones is a symmetry, and the first
/// bending mode's motion is odd in it: `z(T/2) = S z0`. The parity must be found from the
/// model (the transverse dofs flipped, the axial ones kept), and the backbone shot over half
/// the period must equal the one shot over the whole period at the same energies, in the
/// dense formulation and the matrix-free one (whose Floquet products are `S Φ(T/2)`).
#[test]
fn parity_half_period_shooting_equals_full_period_shooting() {
    let beam = VonKarmanBeam {
        elements: 6,
        ..Default::default()
    };
    let s = beam.build().unwrap();
    let modes = linear_modes(&s).unwrap();
    let start = Start::from_linear_mode(&s, &modes, 0, Some(1e-4)).unwrap();
    let energies = [0.3, 0.9];
    let run = |half_period: bool, formulation: Formulation| {
        let mut settings = Settings::default();
        settings.shooting.half_period = half_period;
        settings.shooting.formulation = formulation;
        settings.stability.events = false;
        settings.limits.frequency_shift_max = 0.05;
        settings.requests.at_energies = energies.to_vec();
        let shooting = start.shooting(&s, &settings);
        assert_eq!(shooting.half_period(), half_period);
        if half_period {
            let signs = &shooting.shift().expect("a parity").dof_signs;
            for (i, sign) in signs.iter().enumerate() {
                // Dofs u, w, θ per free node: the axial one kept, the transverse ones flipped.
                let expected = if i % 3 == 0 { 1.0 } else { -1.0 };
                assert_eq!(*sign, expected, "dof {i}");
            }
        }
        let branch = continue_branch(&s, &start, &settings, |_| ControlFlow::Continue(())).unwrap();
        energies
            .iter()
            .map(|&e| {
                let point = branch
                    .points
                    .iter()
                    .find(|p| (p.energy / e - 1.0).abs() < 1e-9)
                    .unwrap_or_else(|| panic!("no point at E = {e}"));
                assert!(point.floquet.stable, "E = {e}");
                (point.frequency, point.floquet.max_modulus)
            })
            .collect::<Vec<_>>()
    };
    for formulation in [Formulation::Dense, Formulation::MatrixFree] {
        let half = run(true, formulation);
        let full = run(false, formulation);
        for ((fh, mh), (ff, mf)) in half.iter().zip(&full) {
            assert!(
                (fh / ff - 1.0).abs() < 1e-9,
                "{formulation:?}: frequency {fh} (half) vs {ff} (full)"
            );
            assert!((mh - mf).abs() < 1e-6, "{formulation:?}: |μ| {mh} vs {mf}");
        }
        // The backbone hardens between the two energies.
        assert!(half[1].0 > half[0].0);
    }
}
