//! The damping matrix `C` from the forms users give it (docs/method.md eq. (90a)):
//! proportional (Rayleigh) `C = αM + βK`, modal ratios `C = M Φ diag(2ζ_k ω_k) Φᵀ M` over the
//! lowest modes, or the matrix itself. `K` is the tangent at rest `K_t(0)`.

use crate::model::{Matrix, MechanicalSystem, SparseMatrix, mass_entries};
use crate::modes::linear_modes;

/// How a user gives the damping.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Damping {
    /// `C = αM + βK`: `[α, β]`.
    Rayleigh([f64; 2]),
    /// Damping ratios `ζ_k` of the lowest elastic modes, in order.
    Modal(Vec<f64>),
    /// `C` itself.
    #[serde(skip)]
    Matrix(Matrix),
}

/// Why a damping cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct DampingError(pub String);

impl Damping {
    /// `C` for `system` (sparse on `M`'s and `K`'s patterns for Rayleigh damping; dense for
    /// modal damping, which couples every dof the modes touch). Rejects negative or
    /// non-finite coefficients and more ratios than the model has elastic modes; the matrix
    /// itself is checked by [`crate::model::ForcedSystem::new`].
    pub fn matrix<S: MechanicalSystem + ?Sized>(&self, system: &S) -> Result<Matrix, DampingError> {
        let n = system.dofs();
        let check = |name: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(DampingError(format!(
                    "damping {name} must be non-negative and finite, got {}",
                    crate::number::Number(v)
                )))
            }
        };
        match self {
            Damping::Matrix(c) => Ok(c.clone()),
            Damping::Rayleigh([alpha, beta]) => {
                check("rayleigh α", *alpha)?;
                check("rayleigh β", *beta)?;
                let mut triplets: Vec<(usize, usize, f64)> = Vec::new();
                let mass = mass_entries(system.mass());
                let p = mass.pattern();
                for i in 0..n {
                    for k in p.row_start[i]..p.row_start[i + 1] {
                        triplets.push((i, p.col[k], alpha * mass.values()[k]));
                    }
                }
                stiffness_entries(system, |i, j, k| triplets.push((i, j, beta * k)));
                Ok(Matrix::Sparse(
                    SparseMatrix::from_triplets(n, &triplets).map_err(DampingError)?,
                ))
            }
            Damping::Modal(ratios) => {
                for (k, &z) in ratios.iter().enumerate() {
                    check(&format!("modal ratio {}", k + 1), z)?;
                }
                let modes = linear_modes(system).map_err(|e| DampingError(e.to_string()))?;
                let elastic: Vec<_> = modes.iter().filter(|m| !m.rigid).collect();
                if ratios.len() > elastic.len() {
                    return Err(DampingError(format!(
                        "{} modal damping ratios given, the model has {} elastic modes",
                        ratios.len(),
                        elastic.len()
                    )));
                }
                let mut c = vec![0.0; n * n];
                let mut mode_mass = vec![0.0; n];
                for (mode, &zeta) in elastic.iter().zip(ratios) {
                    system.mass().apply(&mode.shape, 1, &mut mode_mass);
                    let weight = 2.0 * zeta * mode.frequency;
                    for j in 0..n {
                        for i in 0..n {
                            c[j * n + i] += weight * mode_mass[i] * mode_mass[j];
                        }
                    }
                }
                Ok(Matrix::from_fn(n, n, |i, j| {
                    0.5 * (c[j * n + i] + c[i * n + j])
                }))
            }
        }
    }
}

/// Calls `add(i, j, K_ij)` for the entries of `K = K_t(0)`: on the system's tangent pattern
/// when it has one, else by products with the unit vectors.
fn stiffness_entries<S: MechanicalSystem + ?Sized>(
    system: &S,
    mut add: impl FnMut(usize, usize, f64),
) {
    let n = system.dofs();
    let zero = vec![0.0; n];
    if let Some(pattern) = system.tangent_pattern() {
        let mut values = vec![0.0; pattern.nonzeros()];
        system.tangent_values(&zero, &mut values);
        for (i, bounds) in pattern.row_start.windows(2).enumerate() {
            for (&j, &k) in pattern.col[bounds[0]..bounds[1]]
                .iter()
                .zip(&values[bounds[0]..bounds[1]])
            {
                add(i, j, k);
            }
        }
        return;
    }
    let mut unit = vec![0.0; n];
    let mut column = vec![0.0; n];
    for j in 0..n {
        unit[j] = 1.0;
        system.tangent_stiffness(
            &zero,
            crate::model::Block::new(&unit, n, 1, n),
            crate::model::BlockMut::new(&mut column, n, 1, n),
        );
        unit[j] = 0.0;
        for (i, &k) in column.iter().enumerate() {
            if k != 0.0 {
                add(i, j, k);
            }
        }
    }
}
