//! A localised nonlinearity's stage system as a low-rank update of its linear part
//! (docs/method.md eq. (32e)): the linear part factorised once per step size, each step's
//! nonlinear blocks applied by Woodbury's identity.

use std::sync::Arc;

use super::split::{SplitLu, SplitStages};
use crate::linalg::{DenseLu, Mat, SparseLu};
use crate::model::MechanicalSystem;

/// Most nonlinear unknowns `s p` (stages × nonlinear dofs) for which the stage system is
/// solved as a low-rank update of its linear part. A bound, not a measured crossover: the
/// update costs a dense `s p × s p` factorisation a step and `s p` sparse solves an
/// integration, against one sparse factorisation a step without it; measured only at
/// `s p = 3` (one spring), where the ECL beam's branch took 42% (19 elements) to 59% (1,000
/// elements) less time.
pub(super) const LOW_RANK_MAX: usize = 48;

/// A localised nonlinearity (eq. (32e)): `K_t(X_i) = K_t(0) + P D_i Pᵀ` with `P` the
/// nonlinear dofs' columns of the identity, so `J = J_lin + U D Vᵀ`, `J_lin` the stage
/// Jacobian of `K_t(0)`, `U = I_s ⊗ P`, `D = diag(D_i)`, `Vᵀ = h² Ā ⊗ Pᵀ`.
pub(super) struct LowRank {
    /// The nonlinear dofs `P`.
    pub(super) dofs: Vec<usize>,
    /// `K_t(0)` on the tangent's pattern.
    pub(super) rest: Vec<f64>,
    /// The linear part's stage system split into systems of the model's size (eq. (32f),
    /// exact here: every stage has the tangent `K_t(0)`); `None` if the method's `A` has no
    /// eigenbasis to split by.
    pub(super) split: Option<SplitStages>,
}

/// The linear part of the stage system at one step size, factorised, with what the low-rank
/// update needs of it: `Z = J_lin⁻¹ U` (`s n × s p`) and `Vᵀ Z` (`s p × s p`). One per step
/// size, shared by every step (and every recorded step) of an integration.
pub(in crate::integrate) struct LinearStages {
    pub(super) h: f64,
    pub(super) lu: LinearLu,
    pub(super) z: Vec<f64>,
    pub(super) vtz: Vec<f64>,
    /// `h² Ā`, row-major `s × s`.
    pub(super) hh_abar: Vec<f64>,
    pub(super) dofs: Vec<usize>,
    pub(super) n: usize,
}

/// The linear part's factorisation: split exactly (eq. (32f)), or whole when the method's
/// `A` has no eigenbasis to split by.
pub(super) enum LinearLu {
    Split(SplitLu),
    Whole(SparseLu),
}

impl LinearLu {
    /// `J_lin⁻¹ B` in place for `cols` columns.
    pub(super) fn solve_in_place(&self, b: &mut [f64], cols: usize) {
        match self {
            LinearLu::Split(split) => split.solve_in_place(b, cols),
            LinearLu::Whole(lu) => lu.solve_in_place(b, cols),
        }
    }
}

impl LinearStages {
    /// `Vᵀ x` for `cols` columns of `x` (`s n` each): entry `(i, a)` is
    /// `h² Σ_j Ā_ij x_j[P_a]`; column-major `s p × cols`.
    pub(super) fn project(&self, x: &[f64], cols: usize) -> Vec<f64> {
        let (n, p) = (self.n, self.dofs.len());
        let s = self.hh_abar.len().isqrt();
        let (m, sp) = (s * n, s * p);
        let mut out = vec![0.0; sp * cols];
        for col in 0..cols {
            let x = &x[col * m..(col + 1) * m];
            for i in 0..s {
                for (a, &dof) in self.dofs.iter().enumerate() {
                    out[col * sp + i * p + a] = (0..s)
                        .map(|j| self.hh_abar[i * s + j] * x[j * n + dof])
                        .sum();
                }
            }
        }
        out
    }
}

/// The stage Jacobian of one step as a low-rank update of [`LinearStages`]: the blocks `D_i`
/// (`p × p` each, row-major, stage after stage) and `S = I + D Vᵀ Z` factorised.
#[derive(Clone)]
pub(in crate::integrate) struct UpdatedStages {
    linear: Arc<LinearStages>,
    d: Vec<f64>,
    s_lu: Option<DenseLu>,
}

impl UpdatedStages {
    /// `J⁻¹ B` by Woodbury's identity: `y = J_lin⁻¹ b`, then `y −= Z S⁻¹ D Vᵀ y`.
    pub(super) fn solve_in_place(&self, b: &mut [f64], cols: usize) {
        let linear = &self.linear;
        linear.lu.solve_in_place(b, cols);
        let Some(s_lu) = &self.s_lu else { return };
        let p = linear.dofs.len();
        let sp = self.d.len() / p;
        let s = sp / p;
        let m = b.len() / cols.max(1);
        let projected = linear.project(b, cols);
        let mut t = vec![0.0; sp * cols];
        for col in 0..cols {
            for i in 0..s {
                for a in 0..p {
                    let row = &self.d[(i * p + a) * p..(i * p + a + 1) * p];
                    let x = &projected[col * sp + i * p..col * sp + (i + 1) * p];
                    t[col * sp + i * p + a] = row.iter().zip(x).map(|(d, x)| d * x).sum();
                }
            }
        }
        s_lu.solve_in_place(&mut t, cols);
        for col in 0..cols {
            let y = &mut b[col * m..(col + 1) * m];
            for (c, &tc) in t[col * sp..(col + 1) * sp].iter().enumerate() {
                if tc != 0.0 {
                    let z = &linear.z[c * m..(c + 1) * m];
                    y.iter_mut().zip(z).for_each(|(y, z)| *y -= z * tc);
                }
            }
        }
    }
}

impl LowRank {
    /// The update of `linear` to the stage states `X_i` (`s × n`): `D_i` is the system's
    /// nonlinear tangent there.
    pub(super) fn update<S: MechanicalSystem + ?Sized>(
        &self,
        system: &S,
        linear: Arc<LinearStages>,
        states: &[f64],
    ) -> Option<UpdatedStages> {
        let p = self.dofs.len();
        let n = system.dofs();
        let s = states.len() / n;
        let sp = s * p;
        // `d` holds each D_i row-major; the system writes it column-major.
        let mut d = vec![0.0; sp * p];
        let mut block = vec![0.0; p * p];
        for i in 0..s {
            system.nonlinear_tangent(&states[i * n..(i + 1) * n], &mut block);
            for a in 0..p {
                for c in 0..p {
                    d[(i * p + a) * p + c] = block[c * p + a];
                }
            }
        }
        if d.iter().any(|v| !v.is_finite()) {
            return None;
        }
        if d.iter().all(|&v| v == 0.0) {
            return Some(UpdatedStages {
                linear,
                d,
                s_lu: None,
            });
        }
        // S = I + D Vᵀ Z: row (i, a) of D Vᵀ Z is Σ_c D_i[a][c] (VᵀZ)[(i, c), ·].
        let matrix = Mat::<f64>::from_fn(sp, sp, |row, col| {
            let (i, a) = (row / p, row % p);
            let coupled: f64 = (0..p)
                .map(|c| d[(i * p + a) * p + c] * linear.vtz[col * sp + i * p + c])
                .sum();
            coupled + if row == col { 1.0 } else { 0.0 }
        });
        Some(UpdatedStages {
            linear,
            d,
            s_lu: Some(DenseLu::new(matrix.as_ref())),
        })
    }
}
