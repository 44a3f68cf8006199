//! A damped structure driven by a harmonic force, `M x'' + C x' + f_int(x) = a (F_c cos Ωt +
//! F_s sin Ωt)` (docs/method.md eq. (90)).
//!
//! Damping and forcing wrap a [`MechanicalSystem`] instead of extending it: the conservative
//! trait, and everything built on it (NNM branches, Floquet pairs, energies), stays as it is,
//! and any system — a built-in family, an imported finite-element model, a user's own — can be
//! driven. The forced integrators (`integrate::forced`) and the forced-response problem
//! (`crate::forced`) read this wrapper only.

use super::{Matrix, structure::check_finite_symmetric, structure::check_size};
use super::{MechanicalSystem, ModelError, SparseMatrix};
use crate::linalg;

/// The spatial shape of a harmonic force: `F(τ) = F_c cos τ + F_s sin τ`, `τ = Ωt`, scaled by
/// the force amplitude `a` of the continuation.
#[derive(Debug, Clone, PartialEq)]
pub struct HarmonicForce {
    /// `F_c` (length `n`).
    pub cosine: Vec<f64>,
    /// `F_s` (length `n`).
    pub sine: Vec<f64>,
}

impl HarmonicForce {
    /// A force in phase with `cos Ωt`.
    pub fn cosine(shape: Vec<f64>) -> Self {
        let n = shape.len();
        Self {
            cosine: shape,
            sine: vec![0.0; n],
        }
    }

    /// Adds `amplitude · F(τ)` to `out`.
    #[inline]
    pub fn add_at(&self, tau: f64, amplitude: f64, out: &mut [f64]) {
        let (s, c) = tau.sin_cos();
        let (c, s) = (amplitude * c, amplitude * s);
        for ((o, fc), fs) in out.iter_mut().zip(&self.cosine).zip(&self.sine) {
            *o += c * fc + s * fs;
        }
    }

    /// The complex amplitude `F_c − i F_s` of `F(τ) = Re[(F_c − i F_s) e^{iτ}]`.
    pub fn complex_amplitude(&self) -> (Vec<f64>, Vec<f64>) {
        (self.cosine.clone(), self.sine.iter().map(|s| -s).collect())
    }

    /// The largest entry of `F_c` and `F_s` in modulus.
    pub fn largest(&self) -> f64 {
        self.cosine
            .iter()
            .chain(&self.sine)
            .fold(0.0f64, |m, v| m.max(v.abs()))
    }
}

/// A [`MechanicalSystem`] with viscous damping `C` and a harmonic force shape.
pub struct ForcedSystem<'a, S: MechanicalSystem + ?Sized> {
    system: &'a S,
    damping: SparseMatrix,
    force: HarmonicForce,
}

impl<S: MechanicalSystem + ?Sized> std::fmt::Debug for ForcedSystem<'_, S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ForcedSystem")
            .field("dofs", &self.system.dofs())
            .field("damping_nonzeros", &self.damping.pattern().nonzeros())
            .field("force", &self.force)
            .finish()
    }
}

impl<'a, S: MechanicalSystem + ?Sized> ForcedSystem<'a, S> {
    /// `system` with damping `C` (symmetric, positive semi-definite, `n × n`) and the force
    /// shape `force`. Rejects a wrongly sized, non-finite, non-symmetric or indefinite `C`
    /// (naming the entry or the eigenvalue), and a force of the wrong length, non-finite or
    /// zero.
    pub fn new(system: &'a S, damping: &Matrix, force: HarmonicForce) -> Result<Self, ModelError> {
        let n = system.dofs();
        check_size("damping", damping, n)?;
        check_finite_symmetric("damping", damping)?;
        check_semi_definite(damping)?;
        for (name, shape) in [("cosine", &force.cosine), ("sine", &force.sine)] {
            if shape.len() != n {
                return Err(ModelError::InvalidParameter(format!(
                    "the force's {name} part has {} entries, the model {n} dofs",
                    shape.len()
                )));
            }
            if let Some(i) = shape.iter().position(|v| !v.is_finite()) {
                return Err(ModelError::InvalidParameter(format!(
                    "the force's {name} part has a non-finite entry at dof {i}"
                )));
            }
        }
        if force.largest() == 0.0 {
            return Err(ModelError::InvalidParameter("the force is zero".into()));
        }
        let damping = damping
            .compressed(usize::MAX)
            .expect("every matrix compresses when tiny means any size");
        Ok(Self {
            system,
            damping,
            force,
        })
    }

    /// The conservative system driven.
    pub fn system(&self) -> &'a S {
        self.system
    }

    /// Number of dofs `n`.
    pub fn dofs(&self) -> usize {
        self.system.dofs()
    }

    /// `C`, in compressed rows.
    pub fn damping(&self) -> &SparseMatrix {
        &self.damping
    }

    /// The force shape.
    pub fn force(&self) -> &HarmonicForce {
        &self.force
    }

    /// `r = a F(τ) − C v − f_int(x)`: `M x''` at the state `(x, v)` and phase `τ`.
    #[inline]
    pub fn inertia_force(&self, tau: f64, amplitude: f64, x: &[f64], v: &[f64], r: &mut [f64]) {
        self.system.internal_force(x, r);
        self.add_damping_force(v, r);
        r.iter_mut().for_each(|e| *e = -*e);
        self.force.add_at(tau, amplitude, r);
    }

    /// `r += C v`, a row whose terms cancel summed in twice the working precision (docs/method.md
    /// eq. (76c)), as the internal force's `K x` is. Why: Rayleigh damping `αM + βK` cancels
    /// like `K` on a smooth velocity field, and summed plainly its round-off, though `β ω²`
    /// times smaller than `K x`'s, set the floor of the shooting residual — on the 10⁴-dof von
    /// Kármán beam 4e-9–1e-8 (relative), which the default tolerance of 1e-8 could not get
    /// under; accurate, 6e-12–8e-11.
    #[inline]
    pub fn add_damping_force(&self, v: &[f64], r: &mut [f64]) {
        self.damping.apply_add_accurate(v, r);
    }
}

/// Above this many dofs a damping matrix's semi-definiteness is checked by a sparse Cholesky
/// factorisation of `C + εI` instead of its dense eigenvalues (`O(n³)` and `O(n²)` memory).
const DENSE_CHECK_DOFS: usize = 1500;

/// `C` must be positive semi-definite: viscous damping dissipates. Dense: its smallest
/// eigenvalue must not fall below `−1e-10` of the largest in modulus (the message gives it).
/// Large: `C + 1e-10·max|C_ii| I` must have a Cholesky factor.
fn check_semi_definite(c: &Matrix) -> Result<(), ModelError> {
    let n = c.nrows();
    let largest = c.entries().fold(0.0f64, |m, e| m.max(e.2.abs()));
    if largest == 0.0 {
        return Ok(());
    }
    let indefinite = |detail: String| {
        Err(ModelError::InvalidParameter(format!(
            "the damping matrix is not positive semi-definite ({detail})"
        )))
    };
    if n <= DENSE_CHECK_DOFS {
        let dense = c.to_dense();
        let (values, _) = linalg::symmetric_eigen(dense.as_ref())
            .map_err(|e| ModelError::InvalidParameter(format!("damping matrix: {e}")))?;
        let scale = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let smallest = values.iter().copied().fold(f64::INFINITY, f64::min);
        if smallest < -1e-10 * scale {
            return indefinite(format!("eigenvalue {}", crate::number::Number(smallest)));
        }
        return Ok(());
    }
    let diagonal = (0..n).fold(0.0f64, |m, i| m.max(c.get(i, i).abs()));
    let shift = 1e-10 * diagonal.max(largest);
    let mut triplets: Vec<(usize, usize, f64)> = c.entries().collect();
    triplets.extend((0..n).map(|i| (i, i, shift)));
    let shifted =
        SparseMatrix::from_triplets(n, &triplets).map_err(ModelError::InvalidParameter)?;
    let p = shifted.pattern();
    match linalg::SparseCholesky::new(n, &p.row_start, &p.col, shifted.values()) {
        Some(_) => Ok(()),
        None => indefinite("no Cholesky factor of C + 1e-10·max|C| I".into()),
    }
}
