//! What a converged point's motion looks like over its period, measured with the branch's own
//! integrator (an explicit pair would crawl through a stiff model's period): the peak
//! displacements of the output dofs and the modal harmonic content (docs/method.md §18), and
//! the force of the motion's resonance peak by energy balance when asked (§21).

use super::{Shooting, ShootingError};
use crate::analysis::{
    ModalComponent, REPORTED_SHARE, ResonanceForce, local_peak, modal_content, peak_candidates,
};
use crate::integrate::Steps;
use crate::linalg;
use crate::model::MechanicalSystem;

/// Samples a period is cut into. Harmonic `k` of the samples also holds harmonics `N ± k`:
/// at 32, the fixed–free chain's motion on its 7:1 family (harmonics 7, 21, 35, ... of the
/// branch's fundamental) put 4e-5 of spurious share on its 7th harmonic; at 64 the shares
/// agree with 2,000 samples to 1e-6 (tests/regimes.rs).
pub const MOTION_SAMPLES: usize = 64;

/// Harmonics of the modal content: up to 10:1 internal resonances (the chain's 7:1 and 9:1
/// families, the bladed disk's 3:1 tongue).
pub const CONTENT_HARMONICS: usize = 10;

/// Components kept with a point, at most.
const KEPT_COMPONENTS: usize = 8;

/// The measured motion of one point.
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    /// `max_t |x_d(t)|` of each output dof, in the order of the settings' `output_dofs`.
    pub peak_displacements: Vec<f64>,
    /// The largest (mode, harmonic) components, by decreasing share (eq. (84)).
    pub content: Vec<ModalComponent>,
    /// The force whose resonance peak the motion is (eq. (111)), if the settings ask.
    pub resonance: Option<ResonanceForce>,
}

impl<S: MechanicalSystem + ?Sized> Shooting<'_, S> {
    /// Measures a delivered point's motion ([`Self::motion`]) into its `peak_displacements`
    /// and `content`; a measurement that fails (the integration of a converged orbit does not
    /// in practice) leaves them empty rather than losing the point.
    pub fn measure(&mut self, point: &mut super::BranchPoint) {
        if let Ok(motion) = self.motion(&point.z0, point.period) {
            point.peak_displacements = motion.peak_displacements;
            point.content = motion.content;
            point.resonance = motion.resonance;
        }
    }

    /// Integrates one period from `z0` in [`MOTION_SAMPLES`] segments and measures the peak
    /// displacements of the output dofs (eq. (87)), the modal harmonic content (eq. (84)) and
    /// the resonance force (eq. (111)) from the same samples.
    pub fn motion(&mut self, z0: &[f64], period: f64) -> Result<Motion, ShootingError> {
        let n = self.n;
        let h = period / MOTION_SAMPLES as f64;
        // A motion with `z(t + T/q) = P z(t)` is integrated over `T/q` only when the samples
        // fall on that grid (the half-wave symmetry: half the cost); the rest are shifted.
        let shift = self
            .shift
            .clone()
            .filter(|s| MOTION_SAMPLES % s.divisions == 0);
        let integrated = shift
            .as_ref()
            .map_or(MOTION_SAMPLES, |s| MOTION_SAMPLES / s.divisions);
        // An equal-step integrator takes the shooting's own step (at most) over each stretch;
        // an adaptive one chooses, starting from its last step.
        let shooting_step = self.first_step.filter(|_| self.equal_steps);
        let grid = |duration: f64| -> Option<Vec<f64>> {
            let step = shooting_step?;
            let count = (duration / step).ceil().max(1.0) as usize;
            Some(vec![duration / count as f64; count])
        };
        let segment = grid(h);
        let steps = match &segment {
            Some(grid) => Steps::Replay(grid),
            None => Steps::Adaptive { first_step: None },
        };
        // Samples 1 to `integrated − 1` in one integration; the rest by the shift.
        let mut states = Vec::with_capacity(MOTION_SAMPLES);
        states.push(z0.to_vec());
        let mut first_step = None;
        if integrated > 1 {
            self.scale_tolerances(z0);
            let divisions = integrated - 1;
            let (flow, sampled) =
                self.integrator
                    .flow_sampled(z0, h * divisions as f64, divisions, steps)?;
            self.count_integration(&flow);
            first_step = flow.steps.last().copied();
            states.extend(sampled);
        }
        if let Some(shift) = &shift {
            for j in integrated..MOTION_SAMPLES {
                let shifted = shift.apply(&states[j - integrated]);
                states.push(shifted);
            }
        }
        let mut field = vec![0.0; 2 * n];
        let mut peak_displacements = Vec::with_capacity(self.output_dofs.len());
        for d in self.output_dofs.clone() {
            let x: Vec<f64> = states.iter().map(|z| z[d]).collect();
            let v: Vec<f64> = states.iter().map(|z| z[n + d]).collect();
            let mut peak = x.iter().fold(0.0f64, |m, a| m.max(a.abs()));
            for (j, tau) in peak_candidates(&x, &v, h) {
                let at = if tau > 1e-12 * h {
                    let partial = grid(tau);
                    let steps = match &partial {
                        Some(grid) => Steps::Replay(grid),
                        None => Steps::Adaptive { first_step },
                    };
                    self.integrate(&states[j], tau, None, steps)?.z
                } else {
                    states[j].clone()
                };
                self.integrator.field(&at, &mut field);
                peak = peak.max(local_peak(at[d], at[n + d], field[n + d]));
            }
            peak_displacements.push(peak);
        }
        let displacements: Vec<Vec<f64>> = states.iter().map(|z| z[..n].to_vec()).collect();
        let mass_basis = &self.mass_basis;
        let content = modal_content(
            &displacements,
            |x, c| linalg::dot(&mass_basis[c * n..(c + 1) * n], x),
            &self.basis_modes,
            &self.modal_frequencies,
            2.0 * std::f64::consts::PI / period,
            CONTENT_HARMONICS,
        )
        .into_iter()
        .filter(|c| c.share >= REPORTED_SHARE)
        .take(KEPT_COMPONENTS)
        .collect();
        let resonance = self
            .energy_balance
            .as_ref()
            .map(|balance| balance.resonance(&states, 2.0 * std::f64::consts::PI / period));
        Ok(Motion {
            peak_displacements,
            content,
            resonance,
        })
    }
}
