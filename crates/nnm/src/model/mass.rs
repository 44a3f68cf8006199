//! The mass matrix as an operator: applied to vectors, and solved with a factorisation made
//! once (docs/method.md eq. (3): the explicit form needs `M⁻¹`, never formed).

use super::{Matrix, SparseMatrix};
use crate::linalg::{self, Mat, SparseCholesky};

/// `M`'s entries as a sparse matrix, whatever form the operator holds them in: its sparse
/// entries, its diagonal, or (a mass given only by products) its `n` products with the
/// identity. What the implicit integrator assembles its stage systems from, and the metric of
/// matrix-free shooting.
pub fn mass_entries(mass: &dyn MassOperator) -> SparseMatrix {
    let n = mass.dimension();
    if let Some(sparse) = mass.sparse() {
        return sparse.clone();
    }
    if let Some(diagonal) = mass.diagonal() {
        let entries: Vec<_> = diagonal
            .iter()
            .enumerate()
            .map(|(i, &m)| (i, i, m))
            .collect();
        return SparseMatrix::from_triplets(n, &entries).expect("diagonal entries are in range");
    }
    SparseMatrix::from_dense(&dense_mass_matrix(mass))
}

/// `M` as a dense matrix, from the operator's `n` products with the identity.
pub fn dense_mass_matrix(mass: &dyn MassOperator) -> Mat<f64> {
    let n = mass.dimension();
    let eye: Vec<f64> = (0..n * n)
        .map(|k| if k % (n + 1) == 0 { 1.0 } else { 0.0 })
        .collect();
    let mut m = vec![0.0; n * n];
    mass.apply(&eye, n, &mut m);
    Mat::from_fn(n, n, |i, j| m[j * n + i])
}

/// What the integrators need of the mass matrix `M` (symmetric positive definite).
///
/// Implement it for a mass held in your own storage; [`Mass`] covers diagonal (lumped) and
/// dense (consistent) masses.
pub trait MassOperator: Send + Sync {
    /// Dimension `n`.
    fn dimension(&self) -> usize;
    /// `out = M v` for `cols` column-major columns of length `n` (contiguous).
    fn apply(&self, v: &[f64], cols: usize, out: &mut [f64]);
    /// `b ← M⁻¹ b` for `cols` column-major columns of length `n` (contiguous), with the
    /// factorisation made when the operator was built.
    fn solve_in_place(&self, b: &mut [f64], cols: usize);
    /// The diagonal of a diagonal (lumped) mass: integrators then scale rows instead of
    /// solving, and fold the scaling into an assembled tangent.
    fn diagonal(&self) -> Option<&[f64]> {
        None
    }
    /// The entries of `M`, when it is held sparse: an implicit integrator assembles its stage
    /// matrices on `M`'s pattern instead of a dense `n × n` copy.
    fn sparse(&self) -> Option<&SparseMatrix> {
        None
    }
}

/// A factorised mass matrix.
#[derive(Debug, Clone)]
pub enum Mass {
    /// `M = diag(m)`; `inverse = 1/m`.
    Diagonal {
        /// The masses `m_i`.
        diagonal: Vec<f64>,
        /// `1/m_i`: a solve is a scaling.
        inverse: Vec<f64>,
    },
    /// Sparse `M` (a finite-element consistent mass) with its sparse Cholesky factor:
    /// memory O(nnz), no dense copy.
    Sparse {
        /// `M` itself, for products and for assembling stage matrices.
        matrix: SparseMatrix,
        /// The sparse Cholesky factor, for solves.
        factor: std::sync::Arc<SparseCholesky>,
    },
    /// Dense `M` with its Cholesky factor `M = L Lᵀ`.
    Dense {
        /// `M` itself, for products.
        matrix: Mat<f64>,
        /// The lower Cholesky factor `L`, for solves.
        factor: Mat<f64>,
    },
}

/// Why a mass matrix cannot be factorised.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("mass matrix is not positive definite")]
pub struct MassNotPositiveDefinite;

impl Mass {
    /// Factorises `M`: a diagonal matrix (in either storage) stays a diagonal; a sparse one is
    /// factorised by sparse Cholesky, a dense one by dense Cholesky.
    pub fn new(matrix: &Matrix) -> Result<Self, MassNotPositiveDefinite> {
        let n = matrix.nrows();
        if matrix.is_diagonal() {
            let diagonal: Vec<f64> = (0..n).map(|i| matrix.get(i, i)).collect();
            // `!(m > 0)` also rejects NaN.
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            if diagonal.iter().any(|&m| !(m > 0.0)) {
                return Err(MassNotPositiveDefinite);
            }
            let inverse = diagonal.iter().map(|m| 1.0 / m).collect();
            return Ok(Mass::Diagonal { diagonal, inverse });
        }
        if let Matrix::Sparse(sparse) = matrix {
            let pattern = sparse.pattern();
            let factor = SparseCholesky::new(n, &pattern.row_start, &pattern.col, sparse.values())
                .ok_or(MassNotPositiveDefinite)?;
            return Ok(Mass::Sparse {
                matrix: sparse.clone(),
                factor: std::sync::Arc::new(factor),
            });
        }
        let dense = matrix.to_dense();
        let factor = linalg::cholesky_lower(dense.as_ref()).map_err(|_| MassNotPositiveDefinite)?;
        Ok(Mass::Dense {
            matrix: dense,
            factor,
        })
    }

    /// The identity mass of `n` dofs.
    pub fn identity(n: usize) -> Self {
        Mass::Diagonal {
            diagonal: vec![1.0; n],
            inverse: vec![1.0; n],
        }
    }
}

impl MassOperator for Mass {
    fn dimension(&self) -> usize {
        match self {
            Mass::Diagonal { diagonal, .. } => diagonal.len(),
            Mass::Sparse { matrix, .. } => matrix.dimension(),
            Mass::Dense { matrix, .. } => matrix.nrows(),
        }
    }

    fn apply(&self, v: &[f64], cols: usize, out: &mut [f64]) {
        let n = self.dimension();
        match self {
            Mass::Diagonal { diagonal, .. } => {
                for (o, x) in out[..n * cols].chunks_mut(n).zip(v.chunks(n)) {
                    for ((o, x), m) in o.iter_mut().zip(x).zip(diagonal) {
                        *o = m * x;
                    }
                }
            }
            Mass::Sparse { matrix, .. } => {
                out[..n * cols].fill(0.0);
                matrix.apply_add(1.0, v, n, cols, out, n);
            }
            Mass::Dense { matrix, .. } => linalg::gemm(
                out,
                n,
                false,
                matrix.as_ref(),
                linalg::view(v, n, cols, n),
                1.0,
            ),
        }
    }

    fn solve_in_place(&self, b: &mut [f64], cols: usize) {
        let n = self.dimension();
        match self {
            Mass::Diagonal { inverse, .. } => {
                for column in b[..n * cols].chunks_mut(n) {
                    for (x, d) in column.iter_mut().zip(inverse) {
                        *x *= d;
                    }
                }
            }
            Mass::Sparse { factor, .. } => factor.solve_in_place(&mut b[..n * cols], cols),
            Mass::Dense { factor, .. } => linalg::cholesky_solve_in_place(factor.as_ref(), b, cols),
        }
    }

    fn diagonal(&self) -> Option<&[f64]> {
        match self {
            Mass::Diagonal { diagonal, .. } => Some(diagonal),
            Mass::Sparse { .. } | Mass::Dense { .. } => None,
        }
    }

    fn sparse(&self) -> Option<&SparseMatrix> {
        match self {
            Mass::Sparse { matrix, .. } => Some(matrix),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tridiagonal consistent-mass-like matrix held sparse: factorised by sparse Cholesky,
    /// whose solve inverts the product and agrees with the dense factorisation.
    #[test]
    fn sparse_mass_is_factorised_sparse_and_agrees_with_dense() {
        let n = 6;
        let mut triplets = Vec::new();
        for i in 0..n {
            triplets.push((i, i, 4.0));
            if i + 1 < n {
                triplets.push((i, i + 1, 1.0));
                triplets.push((i + 1, i, 1.0));
            }
        }
        let sparse = Matrix::Sparse(SparseMatrix::from_triplets(n, &triplets).unwrap());
        let mass = Mass::new(&sparse).unwrap();
        assert!(matches!(mass, Mass::Sparse { .. }));
        assert!(mass.sparse().is_some());
        let dense = Mass::new(&Matrix::Dense(sparse.to_dense())).unwrap();
        let v: Vec<f64> = (0..2 * n).map(|k| (k as f64 * 0.7).sin()).collect();
        let (mut a, mut b) = (vec![0.0; 2 * n], vec![0.0; 2 * n]);
        mass.apply(&v, 2, &mut a);
        dense.apply(&v, 2, &mut b);
        assert!(a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-14));
        mass.solve_in_place(&mut a, 2);
        assert!(a.iter().zip(&v).all(|(x, y)| (x - y).abs() < 1e-14));
        // Indefinite: the (0, 1) coupling made larger than the diagonal.
        let indefinite =
            SparseMatrix::from_triplets(2, &[(0, 0, 1.0), (1, 1, 1.0), (0, 1, 2.0), (1, 0, 2.0)]);
        assert!(Mass::new(&Matrix::Sparse(indefinite.unwrap())).is_err());
    }

    #[test]
    fn dense_solve_inverts_apply() {
        let m = Matrix::from_fn(3, 3, |i, j| if i == j { 2.0 } else { 0.5 });
        let mass = Mass::new(&m).unwrap();
        let v = [0.3, -1.0, 2.5, 1.0, 0.0, -0.7];
        let mut mv = vec![0.0; 6];
        mass.apply(&v, 2, &mut mv);
        mass.solve_in_place(&mut mv, 2);
        for (a, b) in mv.iter().zip(&v) {
            assert!((a - b).abs() < 1e-14);
        }
        assert!(
            Mass::new(&Matrix::from_fn(2, 2, |i, j| if i == j {
                1.0
            } else {
                2.0
            }))
            .is_err()
        );
        assert!(
            Mass::new(&Matrix::from_fn(2, 2, |i, j| if i == j {
                -1.0
            } else {
                0.0
            }))
            .is_err()
        );
    }
}
