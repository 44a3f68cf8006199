//! A structure given by its mass and stiffness matrices plus nonlinear elements.

use std::cell::RefCell;

use super::{
    Block, BlockMut, Mass, MassOperator, Matrix, MechanicalSystem, NonlinearElement, SparseMatrix,
    SparsityPattern,
};

/// Why a model is rejected.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ModelError {
    /// A matrix is not `n × n`, `n` the size of the mass matrix.
    #[error("{name} matrix is {rows}x{cols}, expected {expected}x{expected}")]
    WrongSize {
        /// Which matrix (`mass` or `stiffness`).
        name: &'static str,
        /// Its number of rows.
        rows: usize,
        /// Its number of columns.
        cols: usize,
        /// `n`, the size of the mass matrix.
        expected: usize,
    },
    /// A matrix entry is NaN or infinite.
    #[error("{name} matrix has a non-finite entry at ({row}, {col})")]
    NotFinite {
        /// Which matrix (`mass` or `stiffness`).
        name: &'static str,
        /// Row of the entry (0-based).
        row: usize,
        /// Column of the entry (0-based).
        col: usize,
    },
    /// A matrix entry is outside the range double precision holds with full accuracy: subnormal
    /// (below `f64::MIN_POSITIVE`, digits lost) or beyond `√f64::MAX ≈ 1.34e154` (its square,
    /// which the norms of modal analysis and the solvers form, overflows).
    #[error("{name} matrix entry ({row}, {col}) = {value:.3e} is {why}: rescale the model's units")]
    OutOfRange {
        /// Which matrix (`mass`, `stiffness` or `damping`).
        name: &'static str,
        /// Row of the entry (0-based).
        row: usize,
        /// Column of the entry (0-based).
        col: usize,
        /// The entry.
        value: f64,
        /// Which bound it passes ([`Matrix::out_of_range`]).
        why: &'static str,
    },
    /// A matrix differs from its transpose by more than `1e-10` of its largest entry.
    #[error("{name} matrix is not symmetric: entry ({row}, {col}) differs from ({col}, {row})")]
    NotSymmetric {
        /// Which matrix (`mass` or `stiffness`).
        name: &'static str,
        /// Row of the mismatched entry (0-based, above the diagonal: `row < col`).
        row: usize,
        /// Column of the mismatched entry (0-based).
        col: usize,
    },
    /// The mass matrix is not positive definite (a non-positive diagonal mass, or no Cholesky
    /// factor).
    #[error("mass matrix is not positive definite")]
    MassNotPositiveDefinite,
    /// A nonlinear element uses a dof the model does not have.
    #[error("nonlinear element {} uses dof {dof}, but the model has {dofs} dofs", index + 1)]
    ElementDofOutOfRange {
        /// The element's position in the list (0-based; messages count from 1).
        index: usize,
        /// The dof it uses.
        dof: usize,
        /// The model's number of dofs.
        dofs: usize,
    },
    /// A nonlinear element's parameters are unusable (for front ends that build elements from
    /// input).
    #[error("nonlinear element {} is invalid: {reason}", index + 1)]
    InvalidElement {
        /// The element's position in the list (0-based; messages count from 1).
        index: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// The mass matrix is `0 × 0`.
    #[error("model has no degrees of freedom")]
    Empty,
    /// A family parameter is out of range, or a declared cyclic symmetry does not fit the
    /// model (the text says which).
    #[error("invalid model parameter: {0}")]
    InvalidParameter(String),
}

/// Cyclic symmetry of a structure made of identical sectors, with degrees of freedom numbered
/// sector by sector (`dofs_per_sector` consecutive dofs for sector 0, then sector 1, ...).
/// Used to label linear modes `(n, d)` and to build standing-wave shapes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CyclicSymmetry {
    /// Number of sectors `N`.
    pub sectors: usize,
    /// Dofs of one sector; `sectors × dofs_per_sector` must be the model's dof count.
    pub dofs_per_sector: usize,
}

/// `M x'' + K x + Σ f_e(x) = 0` with `M` symmetric positive definite and `K` symmetric
/// (possibly singular), each dense or sparse as given.
///
/// `M` is factorised once ([`Mass`]); `K` is kept in compressed rows when sparse (or tiny),
/// and when every element gives its local tangent, `K_t(x)` is assembled on one fixed
/// pattern (`K`'s joined with the elements' dofs), so the integrator's inner loop neither
/// allocates nor multiplies by zeros.
#[derive(Debug)]
pub struct Structure {
    mass_matrix: Matrix,
    mass: Mass,
    stiffness: Matrix,
    /// `K` in the storage its products use: compressed rows when sparse or tiny.
    stiffness_operator: Matrix,
    elements: Vec<Box<dyn NonlinearElement>>,
    cyclic: Option<CyclicSymmetry>,
    /// Sectors without the symmetry (a mistuned disk's), [`MechanicalSystem::sector_layout`].
    sectors: Option<CyclicSymmetry>,
    tangent: Option<TangentAssembly>,
    /// Every dof some element touches, ascending ([`MechanicalSystem::nonlinear_dofs`]).
    nonlinear_dofs: Vec<usize>,
}

/// Up to this many dofs, a dense `K` is still kept in compressed rows (Duffing, the 2-dof
/// system: cheaper than a dense product and its set-up).
const SMALL_DENSE: usize = 8;

/// `K_t(x) = K + Σ ∂f_e/∂x` on a fixed pattern: `K`'s joined with the elements' tangent
/// positions, the constant part, and where each element's tangent entries go.
#[derive(Debug)]
struct TangentAssembly {
    pattern: SparsityPattern,
    /// `K` on the pattern (explicit zeros where only elements contribute).
    base: Vec<f64>,
    /// Per element: offset into `slots`, its number of tangent entries, and how it writes
    /// them (its dense local matrix, or values on its own sparse pattern).
    elements: Vec<(usize, usize, LocalTangent)>,
    /// Per local tangent entry of an element: its position in the values.
    slots: Vec<usize>,
    /// Per local tangent entry of an element: its position in the `p × p` block of the
    /// nonlinear dofs (column-major, [`MechanicalSystem::nonlinear_tangent`]); empty when
    /// the nonlinearity is not localised (more than [`LOCALISED_DOFS`]).
    block_slots: Vec<usize>,
    /// The elements' tangent at rest on that block.
    block_at_rest: Vec<f64>,
}

/// The most nonlinear dofs a [`Structure`] declares as localised
/// ([`MechanicalSystem::nonlinear_dofs`]). Why a bound: the block of those dofs is `p × p`,
/// and elements over a whole mesh (a von Kármán beam, a solid) touch every dof — 10⁴ dofs
/// would make it 800 MB, 10⁵ dofs 80 GB; the low-rank stage solves use at most 48 / s of
/// them anyway (`integrate::collocation`).
const LOCALISED_DOFS: usize = 256;

/// How an element gives its tangent to the assembly.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum LocalTangent {
    /// [`NonlinearElement::tangent_matrix`]: `m × m` column-major over `dofs_used` (springs).
    Dense,
    /// [`NonlinearElement::tangent_values`] on its [`NonlinearElement::tangent_pattern`]
    /// (elements that touch many dofs sparsely: the polynomial tensor).
    Sparse,
}

impl TangentAssembly {
    fn new(
        stiffness: &SparseMatrix,
        elements: &[Box<dyn NonlinearElement>],
        nonlinear_dofs: &[usize],
    ) -> Option<Self> {
        let n = stiffness.dimension();
        let zero = vec![0.0; n];
        let mut probe = Vec::new();
        // Each element's tangent positions in the order it writes its values.
        let mut locals: Vec<(Vec<(usize, usize)>, LocalTangent)> =
            Vec::with_capacity(elements.len());
        for e in elements {
            if let Some(entries) = e.tangent_pattern() {
                locals.push((entries, LocalTangent::Sparse));
                continue;
            }
            let d = e.dofs_used();
            probe.resize(d.len() * d.len(), 0.0);
            if !e.tangent_matrix(&zero, &mut probe) {
                return None;
            }
            let entries = d.iter().flat_map(|&b| d.iter().map(move |&a| (a, b)));
            locals.push((entries.collect(), LocalTangent::Dense));
        }
        let k = stiffness.pattern();
        let mut rows: Vec<Vec<usize>> = (0..n)
            .map(|i| k.col[k.row_start[i]..k.row_start[i + 1]].to_vec())
            .collect();
        for (entries, _) in &locals {
            for &(a, b) in entries {
                rows[a].push(b);
            }
        }
        let mut row_start = vec![0];
        let mut col = Vec::new();
        for r in rows.iter_mut() {
            r.sort_unstable();
            r.dedup();
            col.extend_from_slice(r);
            row_start.push(col.len());
        }
        let pattern = SparsityPattern { row_start, col };
        let mut base = vec![0.0; pattern.nonzeros()];
        for i in 0..n {
            for p in k.row_start[i]..k.row_start[i + 1] {
                let position = pattern.position(i, k.col[p]).expect("K is in the pattern");
                base[position] += stiffness.values()[p];
            }
        }
        let mut slots = Vec::new();
        let mut block_slots = Vec::new();
        let mut offsets = Vec::with_capacity(locals.len());
        let p = nonlinear_dofs.len();
        let localised = p <= LOCALISED_DOFS;
        let in_block = |dof: usize| {
            nonlinear_dofs
                .binary_search(&dof)
                .expect("an element's dof")
        };
        for (entries, kind) in &locals {
            offsets.push((slots.len(), entries.len(), *kind));
            for &(a, b) in entries {
                slots.push(pattern.position(a, b).expect("in the pattern"));
                if localised {
                    block_slots.push(in_block(b) * p + in_block(a));
                }
            }
        }
        let mut assembly = Self {
            pattern,
            base,
            elements: offsets,
            slots,
            block_slots,
            block_at_rest: Vec::new(),
        };
        if localised {
            let mut at_rest = vec![0.0; p * p];
            assembly.add_elements(elements, &zero, |entry, v| {
                at_rest[assembly.block_slots[entry]] += v
            });
            assembly.block_at_rest = at_rest;
        }
        Some(assembly)
    }

    /// Hands every element's tangent entry at `x` to `add(entry, value)`, `entry` indexing
    /// [`Self::slots`] and [`Self::block_slots`].
    fn add_elements(
        &self,
        elements: &[Box<dyn NonlinearElement>],
        x: &[f64],
        mut add: impl FnMut(usize, f64),
    ) {
        LOCAL.with_borrow_mut(|local| {
            for (e, &(offset, len, kind)) in elements.iter().zip(&self.elements) {
                local.resize(len, 0.0);
                match kind {
                    LocalTangent::Dense => {
                        e.tangent_matrix(x, local);
                    }
                    LocalTangent::Sparse => e.tangent_values(x, local),
                }
                for (entry, &v) in (offset..offset + len).zip(&*local) {
                    add(entry, v);
                }
            }
        });
    }
}

thread_local! {
    /// One element's local tangent matrix, reused across evaluations.
    static LOCAL: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
}

impl Structure {
    /// Validates and builds the model. Symmetry is checked to `1e-10` relative to the
    /// largest entry (matrices read from text files carry round-off).
    pub fn new(
        mass: impl Into<Matrix>,
        stiffness: impl Into<Matrix>,
        elements: Vec<Box<dyn NonlinearElement>>,
    ) -> Result<Self, ModelError> {
        let (mass, stiffness) = (mass.into(), stiffness.into());
        let n = mass.nrows();
        if n == 0 {
            return Err(ModelError::Empty);
        }
        for (name, m) in [("mass", &mass), ("stiffness", &stiffness)] {
            check_size(name, m, n)?;
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
        let factorised = Mass::new(&mass).map_err(|_| ModelError::MassNotPositiveDefinite)?;
        let compressed = stiffness.compressed(SMALL_DENSE);
        let mut nonlinear_dofs: Vec<usize> = elements.iter().flat_map(|e| e.dofs_used()).collect();
        nonlinear_dofs.sort_unstable();
        nonlinear_dofs.dedup();
        let tangent = compressed
            .as_ref()
            .and_then(|k| TangentAssembly::new(k, &elements, &nonlinear_dofs));
        let stiffness_operator = compressed.map_or_else(|| stiffness.clone(), Matrix::Sparse);
        Ok(Self {
            mass_matrix: mass,
            mass: factorised,
            stiffness,
            stiffness_operator,
            nonlinear_dofs,
            elements,
            cyclic: None,
            sectors: None,
            tangent,
        })
    }

    /// Declares the cyclic symmetry (sector-major dof numbering).
    pub fn with_cyclic_symmetry(mut self, cyclic: CyclicSymmetry) -> Result<Self, ModelError> {
        self.check_sectors("cyclic symmetry", cyclic)?;
        self.cyclic = Some(cyclic);
        Ok(self)
    }

    /// Declares sectors without the symmetry (sector-major numbering, sectors that differ: a
    /// mistuned disk), for what is laid out by sector ([`MechanicalSystem::sector_layout`]).
    pub fn with_sector_layout(mut self, sectors: CyclicSymmetry) -> Result<Self, ModelError> {
        self.check_sectors("sector layout", sectors)?;
        self.sectors = Some(sectors);
        Ok(self)
    }

    fn check_sectors(&self, what: &str, cyclic: CyclicSymmetry) -> Result<(), ModelError> {
        if cyclic.sectors == 0
            || cyclic.dofs_per_sector == 0
            || cyclic.sectors * cyclic.dofs_per_sector != self.dofs()
        {
            return Err(ModelError::InvalidParameter(format!(
                "{what} of {} sectors x {} dofs does not match the {} dofs of the model",
                cyclic.sectors,
                cyclic.dofs_per_sector,
                self.dofs()
            )));
        }
        Ok(())
    }

    /// The mass matrix as given.
    pub fn mass_matrix(&self) -> &Matrix {
        &self.mass_matrix
    }
    /// The stiffness matrix as given.
    pub fn stiffness(&self) -> &Matrix {
        &self.stiffness
    }
    /// The nonlinear elements, in the order given (messages number them from 1).
    pub fn elements(&self) -> &[Box<dyn NonlinearElement>] {
        &self.elements
    }

    /// `f_nl(x)`, the sum of the elements' forces.
    pub fn nonlinear_force(&self, x: &[f64], f: &mut [f64]) {
        f.fill(0.0);
        for e in &self.elements {
            e.add_force(x, f);
        }
    }
}

/// `m` must be `n × n`.
pub(super) fn check_size(name: &'static str, m: &Matrix, n: usize) -> Result<(), ModelError> {
    if m.nrows() != n || m.ncols() != n {
        return Err(ModelError::WrongSize {
            name,
            rows: m.nrows(),
            cols: m.ncols(),
            expected: n,
        });
    }
    Ok(())
}

pub(super) fn check_finite_symmetric(name: &'static str, m: &Matrix) -> Result<(), ModelError> {
    if let Some((row, col, _)) = m.entries().find(|e| !e.2.is_finite()) {
        return Err(ModelError::NotFinite { name, row, col });
    }
    if let Some((row, col, value, why)) = m.out_of_range() {
        return Err(ModelError::OutOfRange {
            name,
            row,
            col,
            value,
            why,
        });
    }
    match m.asymmetry(1e-10) {
        Some((i, j, _, _)) => Err(ModelError::NotSymmetric {
            name,
            row: i.min(j),
            col: i.max(j),
        }),
        None => Ok(()),
    }
}

impl MechanicalSystem for Structure {
    fn dofs(&self) -> usize {
        self.mass_matrix.nrows()
    }

    fn mass(&self) -> &dyn MassOperator {
        &self.mass
    }

    #[inline]
    fn internal_force(&self, x: &[f64], f: &mut [f64]) {
        let n = self.dofs();
        self.nonlinear_force(x, f);
        // A sparse (finite-element) K: each row's sum in twice the working precision. Why:
        // for a smooth field the row sums cancel terms `(ω_max/ω)²` times larger than the
        // result, and plain summation leaves that factor times ε of noise in the slow modes'
        // forces — on a 1,000-element beam the flow of a period was then reproducible to only
        // 2e-7 (energy norm) and Newton stalled there; accumulated this way, 2e-10 (300
        // elements: 5e-9 → 1.4e-11). Cost: docs/method.md §15.
        match &self.stiffness_operator {
            Matrix::Sparse(k) => k.apply_add_accurate(x, f),
            k => k.apply_add(1.0, x, n, 1, f, n),
        }
    }

    fn tangent_stiffness(&self, x: &[f64], dx: Block<'_>, mut out: BlockMut<'_>) {
        for c in 0..dx.cols {
            out.col_mut(c).fill(0.0);
        }
        for e in &self.elements {
            e.add_tangent_product(x, dx, &mut out);
        }
        self.stiffness_operator
            .apply_add(1.0, dx.data, dx.stride, dx.cols, out.data, out.stride);
    }

    fn potential_energy(&self, x: &[f64]) -> f64 {
        let kx = self.stiffness_operator.times(x);
        0.5 * crate::linalg::dot(x, &kx) + self.elements.iter().map(|e| e.potential(x)).sum::<f64>()
    }

    fn tangent_pattern(&self) -> Option<&SparsityPattern> {
        self.tangent.as_ref().map(|t| &t.pattern)
    }

    fn tangent_values(&self, x: &[f64], values: &mut [f64]) {
        let t = self.tangent.as_ref().expect("called only with a pattern");
        values.copy_from_slice(&t.base);
        t.add_elements(&self.elements, x, |entry, v| values[t.slots[entry]] += v);
    }

    /// Given with the assembled tangent only (the low-rank stage solves need its pattern),
    /// and when localised ([`LOCALISED_DOFS`]).
    fn nonlinear_dofs(&self) -> Option<&[usize]> {
        (self.tangent.is_some() && self.nonlinear_dofs.len() <= LOCALISED_DOFS)
            .then_some(self.nonlinear_dofs.as_slice())
    }

    fn nonlinear_tangent(&self, x: &[f64], out: &mut [f64]) {
        let t = self
            .tangent
            .as_ref()
            .expect("called only with nonlinear dofs");
        out.iter_mut()
            .zip(&t.block_at_rest)
            .for_each(|(o, r)| *o = -r);
        t.add_elements(&self.elements, x, |entry, v| out[t.block_slots[entry]] += v);
    }

    fn cyclic_symmetry(&self) -> Option<CyclicSymmetry> {
        self.cyclic
    }

    fn sector_layout(&self) -> Option<CyclicSymmetry> {
        self.cyclic.or(self.sectors)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ExplicitForm, PolynomialSpring};

    fn consistent_mass_model() -> Structure {
        let m = Matrix::from_fn(3, 3, |i, j| if i == j { 2.0 } else { 0.5 });
        let k = Matrix::from_fn(3, 3, |i, j| match (i as i32 - j as i32).abs() {
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
        let s = ExplicitForm::new(&s);
        let x = [0.3, -0.2, 0.5];
        let mut tangent = vec![0.0; 9];
        let eye: Vec<f64> = (0..9).map(|k| if k % 4 == 0 { 1.0 } else { 0.0 }).collect();
        s.acceleration_tangent(&x, &eye, 3, &mut tangent);
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
        assert!(disk.tangent.is_some());
        let k3 = Matrix::from_fn(3, 3, |i, j| if i == j { 2.0 } else { 0.0 });
        let opaque = Structure::new(
            Matrix::identity(3),
            k3,
            vec![
                Box::new(Opaque(PolynomialSpring::cubic(0, Some(2), 0.7))),
                Box::new(PolynomialSpring::new(1, None, 0.3, 2)),
            ],
        )
        .unwrap();
        assert!(opaque.tangent.is_none());
        let dense = consistent_mass_model();
        for s in [&disk, &dense, &opaque] {
            let s = ExplicitForm::new(s);
            let n = s.dofs();
            let k = 3;
            let x: Vec<f64> = (0..n).map(|i| (1.3 * i as f64 + 0.4).sin()).collect();
            let dx: Vec<f64> = (0..n * k).map(|i| (0.7 * i as f64).cos()).collect(); // col-major
            let mut expected = vec![0.0; n * k];
            s.acceleration_tangent(&x, &dx, k, &mut expected);
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
        ExplicitForm::new(&s).acceleration(&x, &mut a);
        let mut f = [0.0; 3];
        s.nonlinear_force(&x, &mut f);
        for i in 0..3 {
            let r: f64 = (0..3)
                .map(|j| s.mass_matrix().get(i, j) * a[j] + s.stiffness().get(i, j) * x[j])
                .sum::<f64>()
                + f[i];
            assert!(r.abs() < 1e-14, "residual {r}");
        }
    }

    #[test]
    fn rejects_bad_matrices() {
        let k = Matrix::identity(2);
        let not_spd = Matrix::from_fn(2, 2, |i, j| if i == j { 1.0 } else { 2.0 });
        assert_eq!(
            Structure::new(not_spd, k.clone(), vec![]).unwrap_err(),
            ModelError::MassNotPositiveDefinite
        );
        let negative = Matrix::from_fn(2, 2, |i, j| if i == j { -1.0 } else { 0.0 });
        assert_eq!(
            Structure::new(negative, k.clone(), vec![]).unwrap_err(),
            ModelError::MassNotPositiveDefinite
        );
        let small = Matrix::identity(3);
        assert!(matches!(
            Structure::new(small, k.clone(), vec![]),
            Err(ModelError::WrongSize { .. })
        ));
        let unsym = Matrix::from_fn(2, 2, |i, j| (i + 2 * j) as f64 + 3.0);
        assert!(matches!(
            Structure::new(k.clone(), unsym, vec![]),
            Err(ModelError::NotSymmetric { .. })
        ));
        let nan = Matrix::from_fn(2, 2, |i, j| if i == j { f64::NAN } else { 0.0 });
        assert!(matches!(
            Structure::new(k.clone(), nan, vec![]),
            Err(ModelError::NotFinite { .. })
        ));
        // Entries double precision cannot hold in full: subnormal, or with a square that
        // overflows (the scale of a model is free, but not beyond what f64 can square).
        let tiny = Matrix::from_fn(2, 2, |i, j| if i == j { 1e-310 } else { 0.0 });
        let error = Structure::new(tiny, k.clone(), vec![]).unwrap_err();
        assert_eq!(
            error.to_string(),
            "mass matrix entry (0, 0) = 1.000e-310 is subnormal (below 2.2e-308) and has lost digits in double precision: rescale the model's units"
        );
        let huge = Matrix::from_fn(2, 2, |i, j| if i == 1 && j == 1 { 2e154 } else { 0.0 });
        let error = Structure::new(k.clone(), huge, vec![]).unwrap_err();
        assert_eq!(
            error.to_string(),
            "stiffness matrix entry (1, 1) = 2.000e154 is beyond 1.3e154, where its square overflows double precision: rescale the model's units"
        );
        let largest = Matrix::from_fn(2, 2, |i, j| if i == j { 1.34e154 } else { 0.0 });
        assert!(Structure::new(largest.clone(), largest, vec![]).is_ok());
        let far =
            vec![Box::new(PolynomialSpring::cubic(5, None, 1.0)) as Box<dyn NonlinearElement>];
        assert!(matches!(
            Structure::new(k.clone(), k, far),
            Err(ModelError::ElementDofOutOfRange { dof: 5, .. })
        ));
    }

    /// The nonlinear tangent on the nonlinear dofs is the springs' own, to the last digits,
    /// where the whole tangent's entry there is 10⁸ times larger (the tip of the 1,000-element
    /// ECL beam: `K_ii ≈ 2·10¹³`, the spring's `3 c w² ≈ 3·10⁵` at 4 mm), so a difference of
    /// whole tangents would keep half of its digits; and a spring between two dofs with a
    /// linear part gives its cubic part's block.
    #[test]
    fn nonlinear_tangent_is_the_elements_change_of_tangent() {
        let beam = crate::model::CantileverBeam {
            elements: 1000,
            ..Default::default()
        }
        .build()
        .unwrap();
        let n = beam.dofs();
        let tip = n - 2;
        assert_eq!(beam.nonlinear_dofs(), Some(&[tip][..]));
        let mut x = vec![0.0; n];
        x[tip] = 4e-3;
        let mut block = [0.0];
        beam.nonlinear_tangent(&x, &mut block);
        let exact = 3.0 * 6e9 * 4e-3 * 4e-3;
        assert!(
            (block[0] - exact).abs() <= 1e-15 * exact,
            "{} vs {exact}",
            block[0]
        );
        let mut whole = vec![0.0; beam.tangent_pattern().unwrap().nonzeros()];
        let position = beam.tangent_pattern().unwrap().position(tip, tip).unwrap();
        beam.tangent_values(&x, &mut whole);
        assert!(whole[position] > 1e7 * exact);

        let k = Matrix::from_fn(3, 3, |i, j| if i == j { 2.0 } else { 0.0 });
        let springs: Vec<Box<dyn NonlinearElement>> = vec![
            Box::new(PolynomialSpring::new(2, Some(0), 0.5, 1)),
            Box::new(PolynomialSpring::cubic(2, Some(0), 0.3)),
        ];
        let model = Structure::new(Matrix::identity(3), k, springs).unwrap();
        assert_eq!(model.nonlinear_dofs(), Some(&[0, 2][..]));
        let mut block = [0.0; 4];
        model.nonlinear_tangent(&[0.25, 7.0, -0.75], &mut block);
        // f = 0.5 (x2 − x0) + 0.3 (x2 − x0)³ on x2 and its opposite on x0: the change of
        // tangent is 0.9 (x2 − x0)² [[1, −1], [−1, 1]].
        let c = 0.9 * 1.0f64.powi(2);
        for (value, expected) in block.iter().zip([c, -c, -c, c]) {
            assert!((value - expected).abs() < 1e-15, "{block:?}");
        }
    }
}
