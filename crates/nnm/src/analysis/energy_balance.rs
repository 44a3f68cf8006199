//! Resonance peaks from a backbone by energy balance (docs/method.md §21, eqs. (110)–(112)).
//!
//! A periodic solution of the damped, forced system `M x'' + C x' + f_int(x) = a p(t)` that is
//! also an NNM motion must put into the structure, over one period, the energy damping takes
//! out: `∫ ẋᵀ C ẋ dt = a ∫ ẋᵀ p dt` (eq. (110)). For a force of the model's harmonic shape at
//! the NNM's own frequency, `p(t) = F_c cos(ωt + φ) + F_s sin(ωt + φ)`, only the first harmonic
//! of the velocity does work, and the phase `φ` that does the most gives the smallest force
//! amplitude whose resonance peak is that motion (eq. (111)). One sampled period of a branch
//! point — the one its peaks are measured on — is all it takes: no forced computation.

use crate::linalg;
use crate::model::{HarmonicForce, Matrix};

/// The damping and force shape a backbone's resonance peaks are predicted for.
#[derive(Debug, Clone, PartialEq)]
pub struct EnergyBalance {
    /// `C`, the model's damping.
    damping: Matrix,
    /// `F_c`, `F_s`: the force shape at unit amplitude.
    force: HarmonicForce,
}

/// The force of one backbone point's resonance peak.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ResonanceForce {
    /// `a`: the force amplitude whose resonance peak is the point's motion (eq. (111c)); `+∞`
    /// when the force's shape does no work on the motion's first harmonic (it drives a node
    /// of the mode, or another engine order), `0` without damping.
    pub amplitude: f64,
    /// `φ` (rad, in `(−π, π]`): the force `a (F_c cos(ωt + φ) + F_s sin(ωt + φ))` with `t`
    /// counted from the point's initial state `z0` (eq. (111b)); NaN where `amplitude` is `+∞`.
    pub phase: f64,
    /// `∫ ẋᵀ C ẋ dt` over one period: the energy damping takes out (eq. (110)).
    pub dissipated: f64,
}

impl EnergyBalance {
    /// The energy balance of `damping` against `force`; both of the model's size (`C` square,
    /// `F_c` and `F_s` of the same length), the force not zero.
    pub fn new(damping: Matrix, force: HarmonicForce) -> Result<Self, String> {
        let n = force.cosine.len();
        if damping.nrows() != n || damping.ncols() != n || force.sine.len() != n {
            return Err(format!(
                "the damping is {}x{} and the force has {} entries: they must match",
                damping.nrows(),
                damping.ncols(),
                n
            ));
        }
        if force.largest() == 0.0 {
            return Err("the resonance force's shape is zero".into());
        }
        Ok(Self { damping, force })
    }

    /// The model's dofs.
    pub fn dofs(&self) -> usize {
        self.force.cosine.len()
    }

    /// The force shape (unit amplitude): whether a forced curve's force is this one.
    pub fn force(&self) -> &HarmonicForce {
        &self.force
    }

    /// The resonance force of a motion of angular frequency `omega` sampled at `N` equally
    /// spaced instants of one period, `states[k] = [x; v](kT/N)`, `k = 0..N` (the period's end
    /// not repeated). The trapezoidal rule on a periodic integrand is exact for the harmonics
    /// the samples resolve: the dissipation of eq. (110) up to harmonic `N/2 − 1` of the
    /// velocity, its first harmonic's coefficients (eq. (111a)) up to harmonic `N − 2`.
    pub fn resonance(&self, states: &[Vec<f64>], omega: f64) -> ResonanceForce {
        let n = self.dofs();
        let count = states.len().max(1) as f64;
        let period = 2.0 * std::f64::consts::PI / omega;
        let mut power = 0.0;
        let (mut in_phase, mut quadrature) = (vec![0.0; n], vec![0.0; n]);
        for (k, z) in states.iter().enumerate() {
            let v = &z[n..2 * n];
            power += linalg::dot(v, &self.damping.times(v));
            let (s, c) = (2.0 * std::f64::consts::PI * k as f64 / count).sin_cos();
            for i in 0..n {
                in_phase[i] += 2.0 / count * c * v[i];
                quadrature[i] += 2.0 / count * s * v[i];
            }
        }
        let dissipated = period * power / count;
        // Eq. (111a): the work of a unit force over a period is (T/2)(P cos φ + Q sin φ).
        let p =
            linalg::dot(&self.force.cosine, &in_phase) + linalg::dot(&self.force.sine, &quadrature);
        let q =
            linalg::dot(&self.force.sine, &in_phase) - linalg::dot(&self.force.cosine, &quadrature);
        let work = 0.5 * period * p.hypot(q);
        if work == 0.0 {
            return ResonanceForce {
                amplitude: if dissipated == 0.0 {
                    0.0
                } else {
                    f64::INFINITY
                },
                phase: f64::NAN,
                dissipated,
            };
        }
        // `atan2` gives −π for a negative zero `Q`: the same phase as π, kept in (−π, π].
        let phase = q.atan2(p);
        ResonanceForce {
            amplitude: dissipated / work,
            phase: if phase <= -std::f64::consts::PI {
                std::f64::consts::PI
            } else {
                phase
            },
            dissipated,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `x = X cos(ωt + θ)` on one dof with `C = c`: the dissipation is `π c ω X²`, the force
    /// `c ω X` (the linear oscillator's resonance, `X = a/(cω)`), and the force leads the
    /// displacement by a quarter period: `φ = θ + π/2`, i.e. in phase with the velocity.
    #[test]
    fn a_harmonic_motion_needs_the_linear_resonance_force_in_phase_with_its_velocity() {
        let (c, omega, amplitude, theta) = (0.03, 2.5, 0.4, 0.7);
        let balance = EnergyBalance::new(
            Matrix::from_fn(1, 1, |_, _| c),
            HarmonicForce::cosine(vec![1.0]),
        )
        .unwrap();
        let samples = 16;
        let states: Vec<Vec<f64>> = (0..samples)
            .map(|k| {
                let t = k as f64 / samples as f64 * 2.0 * std::f64::consts::PI / omega;
                let angle = omega * t + theta;
                vec![amplitude * angle.cos(), -amplitude * omega * angle.sin()]
            })
            .collect();
        let r = balance.resonance(&states, omega);
        let pi = std::f64::consts::PI;
        assert!((r.dissipated / (pi * c * omega * amplitude * amplitude) - 1.0).abs() < 1e-14);
        assert!(
            (r.amplitude / (c * omega * amplitude) - 1.0).abs() < 1e-14,
            "{r:?}"
        );
        assert!((r.phase - (theta + pi / 2.0)).abs() < 1e-14, "{r:?}");
    }

    /// A third harmonic in the motion dissipates energy but does no work against a force at
    /// the fundamental: the force grows by the dissipation's share, `1 + 9ε²`.
    #[test]
    fn higher_harmonics_dissipate_but_do_no_work() {
        let (omega, eps) = (1.0, 0.1);
        let balance = EnergyBalance::new(
            Matrix::from_fn(1, 1, |_, _| 1.0),
            HarmonicForce::cosine(vec![1.0]),
        )
        .unwrap();
        let samples = 32;
        let states: Vec<Vec<f64>> = (0..samples)
            .map(|k| {
                let t = k as f64 / samples as f64 * 2.0 * std::f64::consts::PI;
                vec![
                    t.cos() + eps * (3.0 * t).cos(),
                    -t.sin() - 3.0 * eps * (3.0 * t).sin(),
                ]
            })
            .collect();
        let r = balance.resonance(&states, omega);
        assert!(
            (r.amplitude - (1.0 + 9.0 * eps * eps)).abs() < 1e-14,
            "{r:?}"
        );
    }

    /// A force on a node of the motion does no work: no finite force reaches that peak.
    #[test]
    fn a_force_on_a_node_cannot_drive_the_motion() {
        let balance = EnergyBalance::new(
            Matrix::from_fn(2, 2, |i, j| if i == j { 0.1 } else { 0.0 }),
            HarmonicForce::cosine(vec![0.0, 1.0]),
        )
        .unwrap();
        let states: Vec<Vec<f64>> = (0..8)
            .map(|k| {
                let t = k as f64 / 8.0 * 2.0 * std::f64::consts::PI;
                vec![t.cos(), 0.0, -t.sin(), 0.0]
            })
            .collect();
        let r = balance.resonance(&states, 1.0);
        assert!(r.amplitude.is_infinite() && r.phase.is_nan() && r.dissipated > 0.0);
        let zero = EnergyBalance::new(
            Matrix::from_fn(2, 2, |_, _| 0.0),
            HarmonicForce::cosine(vec![0.0, 0.0]),
        );
        assert!(zero.is_err());
    }
}
