//! Post-processing of computed NNMs: motions over a period, their harmonic content, how much a
//! shape has changed, and how energy is distributed over the sectors of a cyclic structure;
//! the peak displacements and the regime (backbone, internal-resonance tongue, other family)
//! measured at every point of a branch; and the force whose resonance peak a point's motion is
//! (energy balance).

mod energy_balance;
mod interpolate;
mod peak;
mod regime;

pub use energy_balance::{EnergyBalance, ResonanceForce};
pub use interpolate::{Reached, first_reached, value_at, value_in};
pub use peak::{local_peak, peak_candidates};
pub use regime::{
    HOME_SHARE, Home, ModalComponent, NEAR_DEGENERATE, REPORTED_SHARE, RESONANCE_WINDOW, Regime,
    RegimeKind, TONGUE_SHARE, modal_content, regime_changes,
};

use std::f64::consts::PI;

use crate::integrate::{
    DOP853, IntegrationError, IntegrationMethod, Integrator, RungeKutta, Steps, Tolerances,
};
use crate::linalg;
use crate::model::{MechanicalSystem, Structure};

/// The motion over one period, sampled at `t_k = k T / samples`, `k = 0..=samples` (the last
/// sample closes the orbit), to relative `tolerance`. A non-stiff system is integrated by
/// DOP853, each segment adaptively, so sampling does not cost accuracy; a stiff one
/// ([`IntegrationMethod::resolve`]: a finite-element beam or solid, whose explicit steps the
/// highest frequency would hold to nanoseconds) by the collocation method a branch of it
/// uses, on equal steps: as many as an integration of the whole period chooses, rounded up
/// to a multiple of `samples`.
pub fn sample_motion<S: MechanicalSystem + ?Sized>(
    system: &S,
    z0: &[f64],
    period: f64,
    samples: usize,
    tolerance: f64,
) -> Result<Vec<Vec<f64>>, IntegrationError> {
    let scale = z0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let tolerances = Tolerances {
        relative: tolerance,
        absolute: tolerance * scale.max(f64::MIN_POSITIVE),
        velocity_scale: 1.0,
    };
    let samples = samples.max(1);
    let method = IntegrationMethod::Auto.resolve(system, 2.0 * PI / period);
    if method.is_collocation() {
        let mut integrator = method.integrator(system, tolerances);
        let whole = integrator.flow(z0, period, None, Steps::Adaptive { first_step: None })?;
        let per_sample = whole.steps.len().div_ceil(samples).max(1);
        let division = vec![period / (samples * per_sample) as f64; per_sample];
        let (_, sampled) =
            integrator.flow_sampled(z0, period, samples, Steps::Replay(&division))?;
        let mut states = Vec::with_capacity(samples + 1);
        states.push(z0.to_vec());
        states.extend(sampled);
        return Ok(states);
    }
    let mut integrator = RungeKutta::new(system, &DOP853, tolerances);
    let dt = period / samples as f64;
    let mut states = Vec::with_capacity(samples + 1);
    states.push(z0.to_vec());
    let mut first_step = None;
    for _ in 0..samples {
        let flow = integrator.flow(
            states.last().expect("non-empty"),
            dt,
            None,
            Steps::Adaptive { first_step },
        )?;
        first_step = flow.steps.first().copied();
        states.push(flow.z);
    }
    Ok(states)
}

/// Amplitudes of the harmonics `1..=count` of the displacements over one period, from
/// `samples + 1` states as returned by [`sample_motion`] (the closing one is not used):
/// `A_k = ‖(2/N) Σ_j x(t_j) e^{-2πi k j/N}‖₂` over the dofs — for `x = a cos(kωt)` it is `‖a‖`.
pub fn harmonic_amplitudes(states: &[Vec<f64>], dofs: usize, count: usize) -> Vec<f64> {
    let n = states.len().saturating_sub(1).max(1);
    (1..=count)
        .map(|k| {
            let mut sum = 0.0;
            for dof in 0..dofs {
                let (mut re, mut im) = (0.0, 0.0);
                for (j, z) in states[..n].iter().enumerate() {
                    let phase = 2.0 * PI * (k * j) as f64 / n as f64;
                    re += z[dof] * phase.cos();
                    im -= z[dof] * phase.sin();
                }
                sum += (re * re + im * im) * (2.0 / n as f64).powi(2);
            }
            sum.sqrt()
        })
        .collect()
}

/// Angle in `[0, π/2]` between two displacement shapes in the mass metric, ignoring sign and
/// scale: 0 for the same shape. Measures how far an NNM has moved from its linear mode
/// (similar NNMs keep their shape, nonsimilar ones do not).
pub fn shape_angle(mass: &dyn crate::model::MassOperator, a: &[f64], b: &[f64]) -> f64 {
    let inner = |u: &[f64], v: &[f64]| {
        let mut mv = vec![0.0; v.len()];
        mass.apply(v, 1, &mut mv);
        linalg::dot(u, &mv)
    };
    let (ab, aa, bb) = (inner(a, b), inner(a, a), inner(b, b));
    if aa == 0.0 || bb == 0.0 {
        return 0.0;
    }
    (ab.abs() / (aa * bb).sqrt()).min(1.0).acos()
}

/// Energy held by each sector of a cyclic structure in state `(x, v)`: each dof `r` carries
/// `½ v_r (M v)_r + ½ x_r (K x)_r`, each nonlinear element its potential (assigned to the
/// sector of its first dof). The sectors' energies add up to the total energy exactly.
/// `None` for structures without cyclic symmetry.
pub fn sector_energies(structure: &Structure, x: &[f64], v: &[f64]) -> Option<Vec<f64>> {
    let cyclic = structure.cyclic_symmetry()?;
    let n = x.len();
    let (mv, kx) = (
        structure.mass_matrix().times(v),
        structure.stiffness().times(x),
    );
    let mut energies = vec![0.0; cyclic.sectors];
    for r in 0..n {
        energies[r / cyclic.dofs_per_sector] += 0.5 * (v[r] * mv[r] + x[r] * kx[r]);
    }
    for e in structure.elements() {
        if let Some(&first) = e.dofs_used().first() {
            energies[first / cyclic.dofs_per_sector] += e.potential(x);
        }
    }
    Some(energies)
}

/// Share of the total held by the `count` largest entries: `count/N` when spread evenly, 1
/// when concentrated in `count` sectors.
pub fn top_share(energies: &[f64], count: usize) -> f64 {
    let total: f64 = energies.iter().sum();
    let mut sorted = energies.to_vec();
    sorted.sort_by(|a, b| b.total_cmp(a));
    sorted.iter().take(count).sum::<f64>() / total
}

/// Participation number `(Σ e)² / Σ e²`: the number of sectors that effectively share the
/// energy (N when even, 1 when all in one).
pub fn participation(energies: &[f64]) -> f64 {
    let total: f64 = energies.iter().sum();
    let squares: f64 = energies.iter().map(|e| e * e).sum();
    total * total / squares
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{BladedDisk, duffing};
    use crate::reference::duffing_period;

    #[test]
    fn harmonics_of_a_linear_oscillation() {
        // x'' + 4x = 0 from (0.3, 0): x = 0.3 cos 2t, a pure fundamental over T = π.
        let s = duffing(2.0, 0.0).unwrap();
        let states = sample_motion(&s, &[0.3, 0.0], PI, 64, 1e-12).unwrap();
        assert_eq!(states.len(), 65);
        assert!((states[64][0] - 0.3).abs() < 1e-10);
        let h = harmonic_amplitudes(&states, 1, 3);
        assert!((h[0] - 0.3).abs() < 1e-10 && h[1] < 1e-10 && h[2] < 1e-10);
    }

    #[test]
    fn duffing_third_harmonic_matches_elliptic_expansion() {
        // x = A cn(ωt|m): the cn Fourier series gives a3/a1 = q (1 + q)... to leading order
        // a3/a1 ≈ q with the nome q = exp(-π K'/K); check the ratio to 2% at m ≈ 0.25.
        let (w0, alpha, amp) = (1.0, 1.0, 1.0);
        let period = duffing_period(w0, alpha, amp);
        let s = duffing(w0, alpha).unwrap();
        let states = sample_motion(&s, &[amp, 0.0], period, 128, 1e-12).unwrap();
        let h = harmonic_amplitudes(&states, 1, 3);
        let m = alpha * amp * amp / (2.0 * (w0 * w0 + alpha * amp * amp));
        let (k, kp) = (
            crate::reference::elliptic_k(m),
            crate::reference::elliptic_k(1.0 - m),
        );
        let q = (-PI * kp / k).exp();
        // cn Fourier coefficients ∝ q^{j+1/2}/(1+q^{2j+1}): a3/a1 = q (1+q)/(1+q³).
        let expected = q * (1.0 + q) / (1.0 + q.powi(3));
        assert!(h[1] < 1e-9, "even harmonic {}", h[1]);
        assert!(
            ((h[2] / h[0]) / expected - 1.0).abs() < 1e-6,
            "{} vs {expected}",
            h[2] / h[0]
        );
    }

    #[test]
    fn sector_energies_add_up_and_measure_localization() {
        let s = BladedDisk::default().build().unwrap();
        let n = s.dofs();
        let mut x = vec![0.0; n];
        x[1] = 0.5; // one blade displaced
        x[0] = -0.1;
        let v = vec![0.0; n];
        let e = sector_energies(&s, &x, &v).unwrap();
        let total = s.energy(&x, &v);
        assert!((e.iter().sum::<f64>() - total).abs() < 1e-14);
        assert!(top_share(&e, 3) > 0.99);
        let uniform = vec![1.0; 30];
        assert!((top_share(&uniform, 3) - 0.1).abs() < 1e-15);
        assert!((participation(&uniform) - 30.0).abs() < 1e-12);
    }

    #[test]
    fn shape_angle_ignores_scale_and_sign() {
        let m = crate::model::Mass::identity(2);
        assert!(shape_angle(&m, &[1.0, 1.0], &[-2.0, -2.0]) < 1e-7);
        assert!((shape_angle(&m, &[1.0, 0.0], &[0.0, 3.0]) - PI / 2.0).abs() < 1e-15);
    }
}
