//! A structure given by its mass and stiffness matrices plus nonlinear elements.

use std::cell::RefCell;

use super::{Block, BlockMut, NonlinearElement, SecondOrderSystem};
use crate::linalg::{self, Mat, Operator};

/// Why a model is rejected.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ModelError {
    #[error("{name} matrix is {rows}x{cols}, expected {expected}x{expected}")]
    WrongSize {
        name: &'static str,
        rows: usize,
        cols: usize,
        expected: usize,
    },
    #[error("{name} matrix has a non-finite entry at ({row}, {col})")]
    NotFinite {
        name: &'static str,
        row: usize,
        col: usize,
    },
    #[error("{name} matrix is not symmetric: entry ({row}, {col}) differs from ({col}, {row})")]
    NotSymmetric {
        name: &'static str,
        row: usize,
        col: usize,
    },
    #[error("mass matrix is not positive definite")]
    MassNotPositiveDefinite,
    #[error("nonlinear element {} uses dof {dof}, but the model has {dofs} dofs", index + 1)]
    ElementDofOutOfRange {
        index: usize,
        dof: usize,
        dofs: usize,
    },
    #[error("nonlinear element {} is invalid: {reason}", index + 1)]
    InvalidElement { index: usize, reason: String },
    #[error("model has no degrees of freedom")]
    Empty,
    #[error("invalid model parameter: {0}")]
    InvalidParameter(String),
}

/// Cyclic symmetry of a structure made of identical sectors, with degrees of freedom numbered
/// sector by sector (`dofs_per_sector` consecutive dofs for sector 0, then sector 1, ...).
/// Used to label linear modes `(n, d)` and to build standing-wave shapes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CyclicSymmetry {
    pub sectors: usize,
    pub dofs_per_sector: usize,
}

/// `M x'' + K x + Σ f_e(x) = 0` with dense `M` (symmetric positive definite) and `K`
/// (symmetric, possibly singular).
///
/// `M⁻¹K` is precomputed and stored as compressed rows when sparse (lumped-mass models), and
/// `M⁻¹` as a diagonal when `M` is diagonal, so the integrator's inner loop neither allocates
/// nor multiplies by zeros.
#[derive(Debug)]
pub struct Structure {
    mass: Mat<f64>,
    stiffness: Mat<f64>,
    elements: Vec<Box<dyn NonlinearElement>>,
    cyclic: Option<CyclicSymmetry>,
    mass_inverse_stiffness: Operator,
    mass_inverse: MassInverse,
    /// The tangent `-M⁻¹(K + ∂f_nl/∂x)` as one sparse operator refreshed per evaluation, when
    /// `M` is diagonal, `M⁻¹K` sparse and every element gives its tangent matrix.
    assembled: Option<AssembledTangent>,
}

/// Up to this many dofs, a dense `M⁻¹K` (with a diagonal `M`) is still assembled into the
/// compressed-row tangent.
const SMALL_DENSE: usize = 8;

/// Compressed rows of `-M⁻¹(K + ∂f_nl/∂x)`: the pattern of `M⁻¹K` joined with the elements'
/// dofs, the constant part, and where each element's local tangent entries go.
#[derive(Debug)]
struct AssembledTangent {
    row_start: Vec<usize>,
    col: Vec<usize>,
    /// `-M⁻¹K` on the pattern (explicit zeros where only elements contribute).
    base: Vec<f64>,
    /// Per element: offset into `slots` and its number of dofs `m`.
    elements: Vec<(usize, usize)>,
    /// Per local entry `(a, b)` (column-major): its position in the values and `-1/M_aa`.
    slots: Vec<(usize, f64)>,
}

impl AssembledTangent {
    fn new(
        minv_k: &Mat<f64>,
        inverse_diagonal: &[f64],
        elements: &[Box<dyn NonlinearElement>],
    ) -> Option<Self> {
        let n = minv_k.nrows();
        let zero = vec![0.0; n];
        let mut probe = Vec::new();
        let mut dofs = Vec::with_capacity(elements.len());
        for e in elements {
            let d = e.dofs_used();
            probe.resize(d.len() * d.len(), 0.0);
            if !e.tangent_matrix(&zero, &mut probe) {
                return None;
            }
            dofs.push(d);
        }
        let mut rows: Vec<Vec<usize>> = (0..n)
            .map(|i| (0..n).filter(|&j| minv_k[(i, j)] != 0.0).collect())
            .collect();
        for d in &dofs {
            for &a in d {
                rows[a].extend_from_slice(d);
            }
        }
        let mut row_start = vec![0];
        let (mut col, mut base) = (Vec::new(), Vec::new());
        for (i, r) in rows.iter_mut().enumerate() {
            r.sort_unstable();
            r.dedup();
            base.extend(r.iter().map(|&j| -minv_k[(i, j)]));
            col.extend_from_slice(r);
            row_start.push(col.len());
        }
        let mut slots = Vec::new();
        let mut offsets = Vec::with_capacity(dofs.len());
        for d in &dofs {
            offsets.push((slots.len(), d.len()));
            for &b in d {
                for &a in d {
                    let row = &col[row_start[a]..row_start[a + 1]];
                    let position = row_start[a] + row.binary_search(&b).expect("in the pattern");
                    slots.push((position, -inverse_diagonal[a]));
                }
            }
        }
        Some(Self {
            row_start,
            col,
            base,
            elements: offsets,
            slots,
        })
    }
}

#[derive(Debug)]
enum MassInverse {
    Diagonal(Vec<f64>),
    Dense(Mat<f64>),
}

thread_local! {
    /// Scratch for the dense-mass path only (consistent-mass models): `M⁻¹` must be applied
    /// to the nonlinear forces after they are summed.
    static SCRATCH: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
    /// The assembled tangent's values and one element's local tangent matrix.
    static ASSEMBLY: RefCell<(Vec<f64>, Vec<f64>)> = const { RefCell::new((Vec::new(), Vec::new())) };
}

impl Structure {
    /// Validates and builds the model. Symmetry is checked to `1e-10` relative to the
    /// largest entry (matrices read from text files carry round-off).
    pub fn new(
        mass: Mat<f64>,
        stiffness: Mat<f64>,
        elements: Vec<Box<dyn NonlinearElement>>,
    ) -> Result<Self, ModelError> {
        let n = mass.nrows();
        if n == 0 {
            return Err(ModelError::Empty);
        }
        for (name, m) in [("mass", &mass), ("stiffness", &stiffness)] {
            if m.nrows() != n || m.ncols() != n {
                return Err(ModelError::WrongSize {
                    name,
                    rows: m.nrows(),
                    cols: m.ncols(),
                    expected: n,
                });
            }
            check_finite_symmetric(name, m)?;
        }
        for (index, e) in elements.iter().enumerate() {
            if let Some(&dof) = e.dofs_used().iter().find(|&&d| d >= n) {
                return Err(ModelError::ElementDofOutOfRange {
                    index,
                    dof,
                    dofs: n,
                });
            }
        }
        let is_diagonal = (0..n).all(|i| (0..n).all(|j| i == j || mass[(i, j)] == 0.0));
        let (mass_inverse, minv_k) = if is_diagonal {
            if (0..n).any(|i| mass[(i, i)] <= 0.0) {
                return Err(ModelError::MassNotPositiveDefinite);
            }
            let d: Vec<f64> = (0..n).map(|i| 1.0 / mass[(i, i)]).collect();
            let minv_k = Mat::from_fn(n, n, |i, j| d[i] * stiffness[(i, j)]);
            (MassInverse::Diagonal(d), minv_k)
        } else {
            let l = linalg::cholesky_lower(mass.as_ref())
                .map_err(|_| ModelError::MassNotPositiveDefinite)?;
            let mut inv = Mat::<f64>::identity(n, n);
            linalg::solve_lower_in_place(l.as_ref(), &mut inv);
            linalg::solve_lower_transpose_in_place(l.as_ref(), &mut inv);
            let minv_k = linalg::product(inv.as_ref(), stiffness.as_ref());
            (MassInverse::Dense(inv), minv_k)
        };
        let mass_inverse_stiffness = Operator::new(&minv_k);
        // Sparse, or so small that compressed rows beat a dense product and its set-up
        // (Duffing, the 2-dof system).
        let assembled = match (&mass_inverse, &mass_inverse_stiffness) {
            (MassInverse::Diagonal(d), Operator::Sparse { .. }) => {
                AssembledTangent::new(&minv_k, d, &elements)
            }
            (MassInverse::Diagonal(d), Operator::Dense(_)) if n <= SMALL_DENSE => {
                AssembledTangent::new(&minv_k, d, &elements)
            }
            _ => None,
        };
        Ok(Self {
            mass,
            stiffness,
            elements,
            cyclic: None,
            mass_inverse_stiffness,
            mass_inverse,
            assembled,
        })
    }

    /// Declares the cyclic symmetry (sector-major dof numbering).
    pub fn with_cyclic_symmetry(mut self, cyclic: CyclicSymmetry) -> Result<Self, ModelError> {
        if cyclic.sectors == 0
            || cyclic.dofs_per_sector == 0
            || cyclic.sectors * cyclic.dofs_per_sector != self.dofs()
        {
            return Err(ModelError::InvalidParameter(format!(
                "cyclic symmetry of {} sectors x {} dofs does not match the {} dofs of the model",
                cyclic.sectors,
                cyclic.dofs_per_sector,
                self.dofs()
            )));
        }
        self.cyclic = Some(cyclic);
        Ok(self)
    }

    pub fn mass(&self) -> &Mat<f64> {
        &self.mass
    }
    pub fn stiffness(&self) -> &Mat<f64> {
        &self.stiffness
    }
    pub fn elements(&self) -> &[Box<dyn NonlinearElement>] {
        &self.elements
    }
    pub fn cyclic_symmetry(&self) -> Option<CyclicSymmetry> {
        self.cyclic
    }

    /// `f_nl(x)`, the sum of the elements' forces.
    pub fn nonlinear_force(&self, x: &[f64], f: &mut [f64]) {
        f.fill(0.0);
        for e in &self.elements {
            e.add_force(x, f);
        }
    }
}

fn check_finite_symmetric(name: &'static str, m: &Mat<f64>) -> Result<(), ModelError> {
    let n = m.nrows();
    let mut scale: f64 = 0.0;
    for j in 0..n {
        for i in 0..n {
            let v = m[(i, j)];
            if !v.is_finite() {
                return Err(ModelError::NotFinite {
                    name,
                    row: i,
                    col: j,
                });
            }
            scale = scale.max(v.abs());
        }
    }
    for j in 0..n {
        for i in 0..j {
            if (m[(i, j)] - m[(j, i)]).abs() > 1e-10 * scale {
                return Err(ModelError::NotSymmetric {
                    name,
                    row: i,
                    col: j,
                });
            }
        }
    }
    Ok(())
}

impl SecondOrderSystem for Structure {
    fn dofs(&self) -> usize {
        self.mass.nrows()
    }

    fn acceleration(&self, x: &[f64], a: &mut [f64]) {
        let n = self.dofs();
        // a = -M⁻¹ f_nl(x) - (M⁻¹K) x
        match &self.mass_inverse {
            MassInverse::Diagonal(d) => {
                self.nonlinear_force(x, a);
                for (ai, di) in a.iter_mut().zip(d) {
                    *ai *= -di;
                }
            }
            MassInverse::Dense(inv) => SCRATCH.with_borrow_mut(|f| {
                f.resize(n, 0.0);
                self.nonlinear_force(x, f);
                linalg::gemm(a, n, false, inv.as_ref(), linalg::view(f, n, 1, n), -1.0);
            }),
        }
        self.mass_inverse_stiffness.apply_add(-1.0, x, n, 1, a, n);
    }

    fn acceleration_tangent(&self, x: &[f64], dx: Block<'_>, mut out: BlockMut<'_>) {
        let n = self.dofs();
        let cols = dx.cols;
        // out = -M⁻¹ (K_t,nl dx) - (M⁻¹K) dx
        match &self.mass_inverse {
            MassInverse::Diagonal(d) => {
                for c in 0..cols {
                    out.col_mut(c).fill(0.0);
                }
                for e in &self.elements {
                    e.add_tangent_product(x, dx, &mut out);
                }
                for c in 0..cols {
                    for (o, di) in out.col_mut(c).iter_mut().zip(d) {
                        *o *= -di;
                    }
                }
            }
            MassInverse::Dense(inv) => SCRATCH.with_borrow_mut(|s| {
                s.clear();
                s.resize(n * cols, 0.0);
                let mut tangent = BlockMut::new(s, n, cols, n);
                for e in &self.elements {
                    e.add_tangent_product(x, dx, &mut tangent);
                }
                linalg::gemm(
                    out.data,
                    out.stride,
                    false,
                    inv.as_ref(),
                    linalg::view(s, n, cols, n),
                    -1.0,
                );
            }),
        }
        self.mass_inverse_stiffness
            .apply_add(-1.0, dx.data, dx.stride, cols, out.data, out.stride);
    }

    fn acceleration_tangent_interleaved(&self, x: &[f64], dx: &[f64], k: usize, out: &mut [f64]) {
        let Some(t) = &self.assembled else {
            return super::tangent_through_columns(self, x, dx, k, out);
        };
        ASSEMBLY.with_borrow_mut(|(values, local)| {
            values.clear();
            values.extend_from_slice(&t.base);
            for (e, &(offset, m)) in self.elements.iter().zip(&t.elements) {
                local.resize(m * m, 0.0);
                e.tangent_matrix(x, local);
                for (&(position, factor), &v) in t.slots[offset..offset + m * m].iter().zip(&*local)
                {
                    values[position] += factor * v;
                }
            }
            linalg::sparse_times_interleaved(&t.row_start, &t.col, values, dx, k, out);
        });
    }

    fn energy(&self, x: &[f64], v: &[f64]) -> f64 {
        let n = self.dofs();
        let mut quadratic = 0.0;
        for j in 0..n {
            for i in 0..n {
                quadratic += v[i] * self.mass[(i, j)] * v[j] + x[i] * self.stiffness[(i, j)] * x[j];
            }
        }
        0.5 * quadratic + self.elements.iter().map(|e| e.potential(x)).sum::<f64>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::PolynomialSpring;

    fn consistent_mass_model() -> Structure {
        let m = Mat::from_fn(3, 3, |i, j| if i == j { 2.0 } else { 0.5 });
        let k = Mat::from_fn(3, 3, |i, j| match (i as i32 - j as i32).abs() {
            0 => 2.0,
            1 => -1.0,
            _ => 0.0,
        });
        let elements: Vec<Box<dyn NonlinearElement>> = vec![
            Box::new(PolynomialSpring::cubic(0, None, 0.7)),
            Box::new(PolynomialSpring::new(1, Some(2), 0.3, 2)),
        ];
        Structure::new(m, k, elements).unwrap()
    }

    /// The acceleration tangent is the derivative of the acceleration (central differences),
    /// for the dense-mass path; the diagonal path is exercised by every family test.
    #[test]
    fn tangent_is_derivative_of_acceleration() {
        let s = consistent_mass_model();
        let x = [0.3, -0.2, 0.5];
        let mut tangent = vec![0.0; 9];
        let eye: Vec<f64> = (0..9).map(|k| if k % 4 == 0 { 1.0 } else { 0.0 }).collect();
        s.acceleration_tangent(
            &x,
            Block::new(&eye, 3, 3, 3),
            BlockMut::new(&mut tangent, 3, 3, 3),
        );
        let h = 1e-6;
        for c in 0..3 {
            let (mut xp, mut xm) = (x, x);
            xp[c] += h;
            xm[c] -= h;
            let (mut ap, mut am) = ([0.0; 3], [0.0; 3]);
            s.acceleration(&xp, &mut ap);
            s.acceleration(&xm, &mut am);
            for r in 0..3 {
                let fd = (ap[r] - am[r]) / (2.0 * h);
                assert!((fd - tangent[c * 3 + r]).abs() < 1e-8);
            }
        }
    }

    /// The interleaved tangent (assembled sparse operator for the bladed disk, transposition
    /// fallback for the dense mass and for an element without a tangent matrix) equals the
    /// column-major one.
    #[test]
    fn interleaved_tangent_matches_column_major() {
        #[derive(Debug)]
        struct Opaque(PolynomialSpring);
        impl NonlinearElement for Opaque {
            fn add_force(&self, x: &[f64], f: &mut [f64]) {
                self.0.add_force(x, f)
            }
            fn add_tangent_product(&self, x: &[f64], dx: Block<'_>, out: &mut BlockMut<'_>) {
                self.0.add_tangent_product(x, dx, out)
            }
            fn potential(&self, x: &[f64]) -> f64 {
                self.0.potential(x)
            }
            fn dofs_used(&self) -> Vec<usize> {
                self.0.dofs_used()
            }
        }
        // 12 sectors: sparse enough for compressed rows (≤ 4 non-zeros in rows of 24).
        let disk = crate::model::BladedDisk {
            sectors: 12,
            ..Default::default()
        }
        .build()
        .unwrap();
        assert!(disk.assembled.is_some());
        let k3 = Mat::from_fn(3, 3, |i, j| if i == j { 2.0 } else { 0.0 });
        let opaque = Structure::new(
            Mat::<f64>::identity(3, 3),
            k3,
            vec![
                Box::new(Opaque(PolynomialSpring::cubic(0, Some(2), 0.7))),
                Box::new(PolynomialSpring::new(1, None, 0.3, 2)),
            ],
        )
        .unwrap();
        assert!(opaque.assembled.is_none());
        let dense = consistent_mass_model();
        let systems: [&dyn SecondOrderSystem; 3] = [&disk, &dense, &opaque];
        for s in systems {
            let n = s.dofs();
            let k = 3;
            let x: Vec<f64> = (0..n).map(|i| (1.3 * i as f64 + 0.4).sin()).collect();
            let dx: Vec<f64> = (0..n * k).map(|i| (0.7 * i as f64).cos()).collect(); // col-major
            let mut expected = vec![0.0; n * k];
            s.acceleration_tangent(
                &x,
                Block::new(&dx, n, k, n),
                BlockMut::new(&mut expected, n, k, n),
            );
            let interleaved: Vec<f64> = (0..n * k).map(|p| dx[(p % k) * n + p / k]).collect();
            let mut out = vec![f64::NAN; n * k];
            s.acceleration_tangent_interleaved(&x, &interleaved, k, &mut out);
            for i in 0..n {
                for c in 0..k {
                    let (a, b) = (out[i * k + c], expected[c * n + i]);
                    assert!((a - b).abs() < 1e-14 * (1.0 + b.abs()), "{a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn acceleration_solves_the_equation_of_motion() {
        let s = consistent_mass_model();
        let x = [0.3, -0.2, 0.5];
        let mut a = [0.0; 3];
        s.acceleration(&x, &mut a);
        let mut f = [0.0; 3];
        s.nonlinear_force(&x, &mut f);
        for i in 0..3 {
            let r: f64 = (0..3)
                .map(|j| s.mass()[(i, j)] * a[j] + s.stiffness()[(i, j)] * x[j])
                .sum::<f64>()
                + f[i];
            assert!(r.abs() < 1e-14, "residual {r}");
        }
    }

    #[test]
    fn rejects_bad_matrices() {
        let k = Mat::<f64>::identity(2, 2);
        let not_spd = Mat::from_fn(2, 2, |i, j| if i == j { 1.0 } else { 2.0 });
        assert_eq!(
            Structure::new(not_spd, k.clone(), vec![]).unwrap_err(),
            ModelError::MassNotPositiveDefinite
        );
        let negative = Mat::from_fn(2, 2, |i, j| if i == j { -1.0 } else { 0.0 });
        assert_eq!(
            Structure::new(negative, k.clone(), vec![]).unwrap_err(),
            ModelError::MassNotPositiveDefinite
        );
        let small = Mat::<f64>::identity(3, 3);
        assert!(matches!(
            Structure::new(small, k.clone(), vec![]),
            Err(ModelError::WrongSize { .. })
        ));
        let unsym = Mat::from_fn(2, 2, |i, j| (i + 2 * j) as f64 + 3.0);
        assert!(matches!(
            Structure::new(k.clone(), unsym, vec![]),
            Err(ModelError::NotSymmetric { .. })
        ));
        let nan = Mat::from_fn(2, 2, |i, j| if i == j { f64::NAN } else { 0.0 });
        assert!(matches!(
            Structure::new(k.clone(), nan, vec![]),
            Err(ModelError::NotFinite { .. })
        ));
        let far =
            vec![Box::new(PolynomialSpring::cubic(5, None, 1.0)) as Box<dyn NonlinearElement>];
        assert!(matches!(
            Structure::new(k.clone(), k, far),
            Err(ModelError::ElementDofOutOfRange { dof: 5, .. })
        ));
    }
}
