//! The monodromy of a converged point in modal coordinates, and the full-period check of
//! half-period points (docs/method.md §7 and eq. (10)).

use super::{Evaluation, PhaseCondition, ShiftSymmetry, Shooting, ShootingError};
use crate::integrate::Steps;
use crate::linalg::{self, Mat};
use crate::model::MechanicalSystem;

impl<S: MechanicalSystem + ?Sized> Shooting<'_, S> {
    /// The monodromy matrix restricted to the elastic state space, in modal coordinates
    /// (`2r × 2r`): `L Φ(T) E` with `E = diag(B, B)`, `L = diag((MB)ᵀ, (MB)ᵀ)`. Rigid-body
    /// motions decouple exactly (their block is `[[1, T], [0, 1]]`), so its eigenvalues are the
    /// Floquet multipliers of the elastic motion. The columns of `Φ E` that the evaluation
    /// already propagated (the unknown directions) are reused; the rest are integrated in one
    /// pass on a fresh step sequence.
    pub fn monodromy(&mut self, evaluation: &Evaluation) -> Result<Mat<f64>, ShootingError> {
        let (n, n2, r, r_u) = (self.n, 2 * self.n, self.r, self.r_u);
        let (phase, omega_ref, a) = (self.phase, self.omega_ref, self.amplitude_scale);
        // Column c of E: displacement mode c (c < r) or velocity mode c - r; the evaluation
        // propagated them scaled by `a` (and `ω_ref` for velocities).
        let known = move |c: usize| -> Option<(usize, f64)> {
            match phase {
                _ if c < r_u => Some((c, 1.0 / a)),
                PhaseCondition::FlowOrthogonal if c >= r && c < r + r_u => {
                    Some((r_u + c - r, 1.0 / (a * omega_ref)))
                }
                _ => None,
            }
        };
        let missing: Vec<usize> = (0..2 * r).filter(|&c| known(c).is_none()).collect();
        let mut directions = vec![0.0; n2 * missing.len()];
        for (k, &c) in missing.iter().enumerate() {
            let (mode, offset) = if c < r { (c, 0) } else { (c - r, n) };
            directions[k * n2 + offset..k * n2 + offset + n]
                .copy_from_slice(&self.basis[mode * n..(mode + 1) * n]);
        }
        // Same steps as the evaluation: every column then differentiates one discrete map.
        let integrated = if missing.is_empty() {
            Vec::new()
        } else {
            self.flow_with_derivative(
                &evaluation.z0,
                evaluation.period,
                &directions,
                Some(&evaluation.steps),
            )?
            .1
        };
        let mut reduced = Mat::<f64>::zeros(2 * r, 2 * r);
        let mut next_missing = 0;
        for c in 0..2 * r {
            let column: Vec<f64> = match known(c) {
                Some((k, scale)) => evaluation.flow_derivative[k * n2..(k + 1) * n2]
                    .iter()
                    .map(|v| v * scale)
                    .collect(),
                None => {
                    next_missing += 1;
                    integrated[(next_missing - 1) * n2..next_missing * n2].to_vec()
                }
            };
            // With a shift, the column of P⁻¹ Φ(T/q): the derivative of z0 ↦ P⁻¹ z(T/q; z0),
            // whose q-th power is Φ(T) (eq. (82)).
            let column = match &self.shift {
                Some(shift) => shift.apply_inverse(&column),
                None => column,
            };
            for k in 0..r {
                let mb = &self.mass_basis[k * n..(k + 1) * n];
                reduced[(k, c)] = linalg::dot(mb, &column[..n]);
                reduced[(r + k, c)] = linalg::dot(mb, &column[n..]);
            }
        }
        if let Some(shift) = &self.shift {
            let map = reduced.clone();
            for _ in 1..shift.divisions {
                reduced = linalg::product(map.as_ref(), reduced.as_ref());
            }
        }
        Ok(reduced)
    }

    /// The periodicity residual over the full period, `‖W(z(T) - z0)‖ / ‖W z0‖`: for an
    /// evaluation over `T/q` (a [`super::ShiftSymmetry`]), the rest of the period is
    /// integrated (without sensitivities) to check that the motion really has the symmetry.
    pub fn full_period_residual(&mut self, evaluation: &Evaluation) -> Result<f64, ShootingError> {
        let Some(divisions) = self.shift.as_ref().map(|s| s.divisions) else {
            return Ok(evaluation.relative_residual);
        };
        let rest = evaluation.period * (divisions - 1) as f64 / divisions as f64;
        let flow = self.integrate(
            &evaluation.z_end,
            rest,
            None,
            Steps::Adaptive {
                first_step: self.first_step,
            },
        )?;
        // In the metric of the convergence test (eq. (19)).
        let mismatch: Vec<f64> = flow
            .z
            .iter()
            .zip(&evaluation.z0)
            .map(|(a, b)| a - b)
            .collect();
        Ok(self.residual_norm(&mismatch)
            / self.residual_norm(&evaluation.z0).max(f64::MIN_POSITIVE))
    }

    /// The norm the convergence test measures a state in: of [`Self::weighted_modal`], or in
    /// the matrix-free formulation that of `W z` in its metric (docs/method.md eqs. (73),
    /// (76a)).
    fn residual_norm(&self, z: &[f64]) -> f64 {
        match &self.matrix_free {
            Some(free) => free.norm(&free.weigh(z)),
            None => linalg::norm(&self.weighted_modal(z)),
        }
    }

    /// Coordinates of a state in the modal basis of [`Shooting::monodromy`]:
    /// `((MB)ᵀ x, (MB)ᵀ v)`.
    pub fn modal_coordinates(&self, z: &[f64]) -> Vec<f64> {
        let (n, r) = (self.n, self.r);
        let project = |x: &[f64]| -> Vec<f64> {
            (0..r)
                .map(|c| linalg::dot(&self.mass_basis[c * n..(c + 1) * n], x))
                .collect()
        };
        let mut q = project(&z[..n]);
        q.extend(project(&z[n..]));
        q
    }

    /// The similarity `Φ ← D Φ D⁻¹`, `D = diag(ω_1..ω_r, 1..1)`, applied to the modal
    /// monodromy and the trivial directions (`d ← D d`) before its eigenvalues are taken
    /// (docs/method.md eq. (33a)). In the coordinates `(ω_c q_c, q̇_c)` the linear flow of
    /// every mode is a rotation, so the scaled monodromy is orthogonal in the linear limit and
    /// near-orthogonal along the branch: its eigenvalues are perfectly conditioned. Unscaled,
    /// a mode's block `[[cos, sin/ω], [−ω sin, cos]]` is non-normal by `ω²`, and on a stiff
    /// model (the 50-element beam: `ω_max/ω_1 ≈ 3·10⁴`) round-off put multipliers at
    /// `|μ| = 1.0001` and flagged points of the linear regime unstable.
    pub fn energy_scaling(&self, monodromy: &mut Mat<f64>, directions: [&mut Vec<f64>; 2]) {
        let r = self.r;
        let scale = |i: usize| {
            if i < r {
                self.modal_frequencies[i]
            } else {
                1.0
            }
        };
        for j in 0..2 * r {
            let inverse = 1.0 / scale(j);
            for i in 0..2 * r {
                monodromy[(i, j)] *= scale(i) * inverse;
            }
        }
        for d in directions {
            for (i, v) in d.iter_mut().enumerate() {
                *v *= scale(i);
            }
        }
    }

    /// `W_m L₂ z = [q; q̇ / ω]` mode by mode: the modal coordinates of a state with each mode's
    /// velocity divided by its own frequency (docs/method.md eq. (17)), so that a mode's
    /// displacement and velocity mismatches count alike whatever its frequency. With one
    /// `1/ω_ref` for all velocities instead, a stiff mode's velocity counted `ω_k/ω_ref` times
    /// its displacement: on a 70-element beam (`ω_max/ω_1 ≈ 5·10⁴`) the round-off content of
    /// the stiff modes in the first guess alone made a relative residual of 0.4, the
    /// Jacobian's condition 10¹¹, and Newton failed on the first point.
    pub fn weighted_modal(&self, z: &[f64]) -> Vec<f64> {
        let mut q = self.modal_coordinates(z);
        let r = self.r;
        for (c, v) in q[r..].iter_mut().enumerate() {
            *v /= self.modal_frequencies[c];
        }
        q
    }

    /// The vector field `g(z)`.
    pub fn field(&self, z: &[f64]) -> Vec<f64> {
        let mut g = vec![0.0; z.len()];
        self.integrator.field(z, &mut g);
        g
    }

    /// Coordinates of [`Shooting::monodromy`] spanned by the unknowns' modes (displacements
    /// and velocities), when they are fewer than all: on a model whose mirror symmetry
    /// restricted the unknowns to one class, the monodromy leaves this block and its
    /// complement invariant.
    pub fn unknown_block(&self) -> Option<Vec<usize>> {
        (self.r_u < self.r).then(|| (0..self.r_u).chain(self.r..self.r + self.r_u).collect())
    }

    /// Whether the problem is shot over half a period (`z(T/2) = −z0`, or `S z0` with a
    /// parity `S`).
    pub fn half_period(&self) -> bool {
        self.shift
            .as_ref()
            .is_some_and(|shift| shift.diagonal(0).is_some())
    }

    /// The spatio-temporal symmetry shot with, if any.
    pub fn shift(&self) -> Option<&ShiftSymmetry> {
        self.shift.as_ref()
    }
}
