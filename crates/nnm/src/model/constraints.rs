//! Dofs held at zero (clamped supports), removed from a model exported without its boundary
//! conditions (docs/method.md eq. (61)).

use super::{Matrix, ModelError};

/// Which dofs of an `n`-dof model are fixed (`x = 0`), and the numbering of the others.
///
/// The reduced model keeps the free dofs in ascending order: reduced dof `r` is full dof
/// [`Self::free_dofs`]`[r]`. Matrices lose the fixed rows and columns; a force term that
/// contains a fixed dof's displacement vanishes, and the force on a fixed dof is the support's
/// reaction, not part of the reduced model (eq. (61)).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FixedDofs {
    /// Full dof → its reduced index, `None` when fixed.
    reduced: Vec<Option<usize>>,
    /// Reduced index → full dof.
    free: Vec<usize>,
}

impl FixedDofs {
    /// Fixes `fixed` (0-based, any order) of a model of `dofs` dofs. A dof out of range or
    /// listed twice is an error, and so is fixing every dof.
    pub fn new(dofs: usize, fixed: &[usize]) -> Result<Self, ModelError> {
        let mut reduced = vec![Some(0); dofs];
        for &d in fixed {
            match reduced.get_mut(d) {
                None => {
                    return Err(ModelError::InvalidParameter(format!(
                        "fixed dof {d} is outside the {dofs} dofs of the model"
                    )));
                }
                Some(None) => {
                    return Err(ModelError::InvalidParameter(format!(
                        "fixed dof {d} is listed twice"
                    )));
                }
                Some(slot) => *slot = None,
            }
        }
        let mut free = Vec::with_capacity(dofs - fixed.len());
        for (d, slot) in reduced.iter_mut().enumerate() {
            if slot.is_some() {
                *slot = Some(free.len());
                free.push(d);
            }
        }
        if free.is_empty() {
            return Err(ModelError::Empty);
        }
        Ok(Self { reduced, free })
    }

    /// Number of dofs of the full model.
    pub fn full_dofs(&self) -> usize {
        self.reduced.len()
    }

    /// The free dofs in ascending order: reduced dof `r` is full dof `free_dofs()[r]`.
    pub fn free_dofs(&self) -> &[usize] {
        &self.free
    }

    /// The reduced index of full dof `dof`, `None` when it is fixed (or out of range).
    pub fn reduced_index(&self, dof: usize) -> Option<usize> {
        self.reduced.get(dof).copied().flatten()
    }

    /// The matrix without the fixed rows and columns, in its own storage (a sparse matrix
    /// stays sparse, `O(nnz)`). It must be `n × n`, `n` the full model's size.
    pub fn reduce_matrix(&self, name: &'static str, m: &Matrix) -> Result<Matrix, ModelError> {
        super::structure::check_size(name, m, self.full_dofs())?;
        Ok(m.principal_submatrix(&self.free, &self.reduced))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{NonlinearElement, PolynomialSpring, PolynomialTensor, SparseMatrix};

    type Element = Box<dyn NonlinearElement>;

    /// `x = P y`: the full state with the fixed dofs at zero.
    fn expand(fixed: &FixedDofs, y: &[f64]) -> Vec<f64> {
        let mut x = vec![0.0; fixed.full_dofs()];
        for (&d, &v) in fixed.free_dofs().iter().zip(y) {
            x[d] = v;
        }
        x
    }

    /// The reduced element's force is `Pᵀ f(P y)` (eq. (61)) for springs with either, both or
    /// no end fixed (even and odd exponents) and for a tensor with terms on fixed dofs.
    #[test]
    fn reduced_forces_are_the_restricted_forces() {
        let fixed = FixedDofs::new(5, &[3, 0]).unwrap();
        assert_eq!(fixed.free_dofs(), &[1, 2, 4]);
        assert_eq!(fixed.reduced_index(4), Some(2));
        assert_eq!(fixed.reduced_index(3), None);
        let tensor = PolynomialTensor::new(
            5,
            // x0 x1 x2 + x1² x4 (quadratic), x1 x3³ + x2² x4² (cubic), as gradients.
            vec![
                (0, 1, 2, 1.0),
                (1, 0, 2, 1.0),
                (2, 1, 0, 1.0),
                (1, 1, 4, 2.0),
                (4, 1, 1, 1.0),
            ],
            vec![
                (1, 3, 3, 3, 1.0),
                (3, 1, 3, 3, 3.0),
                (2, 2, 4, 4, 2.0),
                (4, 2, 2, 4, 2.0),
            ],
        )
        .unwrap();
        let reduced_tensor = tensor.reduced(&fixed);
        assert_eq!(reduced_tensor.terms(), (2, 2));
        let mut elements: Vec<(Element, Option<Element>)> =
            vec![(Box::new(tensor), Some(Box::new(reduced_tensor)))];
        for (i, j) in [
            (0, Some(1)),
            (1, Some(0)),
            (2, Some(4)),
            (0, Some(3)),
            (3, None),
            (4, None),
        ] {
            for p in [2, 3] {
                let spring = PolynomialSpring::new(i, j, 0.7, p);
                let reduced = spring.reduced(&fixed);
                assert_eq!(reduced.is_none(), i == 0 && j == Some(3) || i == 3);
                elements.push((Box::new(spring), reduced.map(|s| Box::new(s) as Element)));
            }
        }
        let y = [0.3, -0.8, 1.3];
        let x = expand(&fixed, &y);
        for (full, reduced) in &elements {
            let mut f = vec![0.0; 5];
            full.add_force(&x, &mut f);
            let mut g = vec![0.0; 3];
            if let Some(r) = reduced {
                r.add_force(&y, &mut g);
                assert!((r.potential(&y) - full.potential(&x)).abs() < 1e-15);
            }
            for (r, &d) in fixed.free_dofs().iter().enumerate() {
                assert!((g[r] - f[d]).abs() < 1e-15, "{full:?}: {g:?} vs {f:?}");
            }
        }
    }

    /// A sparse matrix loses the fixed rows and columns without a dense copy and equals the
    /// dense selection; a dense one stays dense.
    #[test]
    fn reduced_matrices_drop_rows_and_columns() {
        let n = 5;
        let dense = Matrix::from_fn(n, n, |i, j| {
            (1 + i * n + j) as f64 * if (i + j) % 3 == 0 { 1.0 } else { 0.0 }
        });
        let triplets: Vec<_> = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .map(|(i, j)| (i, j, dense.get(i, j)))
            .filter(|t| t.2 != 0.0)
            .collect();
        let sparse = Matrix::Sparse(SparseMatrix::from_triplets(n, &triplets).unwrap());
        let fixed = FixedDofs::new(n, &[1, 4]).unwrap();
        let (a, b) = (
            fixed.reduce_matrix("mass", &dense).unwrap(),
            fixed.reduce_matrix("mass", &sparse).unwrap(),
        );
        assert!(matches!(a, Matrix::Dense(_)) && matches!(b, Matrix::Sparse(_)));
        for (r, &i) in fixed.free_dofs().iter().enumerate() {
            for (c, &j) in fixed.free_dofs().iter().enumerate() {
                assert_eq!(a.get(r, c), dense.get(i, j));
                assert_eq!(b.get(r, c), dense.get(i, j));
            }
        }
        assert!(matches!(
            fixed.reduce_matrix("stiffness", &Matrix::identity(4)),
            Err(ModelError::WrongSize { expected: 5, .. })
        ));
    }

    #[test]
    fn bad_fixed_dofs_are_refused() {
        assert!(
            FixedDofs::new(3, &[3])
                .unwrap_err()
                .to_string()
                .contains("fixed dof 3 is outside")
        );
        assert!(
            FixedDofs::new(3, &[1, 1])
                .unwrap_err()
                .to_string()
                .contains("listed twice")
        );
        assert_eq!(FixedDofs::new(2, &[1, 0]).unwrap_err(), ModelError::Empty);
        assert_eq!(FixedDofs::new(2, &[]).unwrap().free_dofs(), &[0, 1]);
    }
}
