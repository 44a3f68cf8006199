//! The thin facade over `faer` (pinned; its minor releases break APIs).
//!
//! Every decomposition the crate uses goes through here, so a faer upgrade touches one file.
//! faer runs sequentially (`Par::Seq`): at the sizes of a shooting Jacobian (tens to a few
//! hundred unknowns) its 2-thread mode was measured slower;
//! parallelism belongs at the outer level (independent branches).

pub use faer::Mat;
use faer::linalg::matmul::matmul;
use faer::linalg::solvers::SolveLstsq;
use faer::{Accum, MatRef, Par, Side};

/// A complex number `(re, im)`, as returned for Floquet multipliers.
pub type Complex = (f64, f64);

/// Why a factorization failed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LinalgError {
    /// Cholesky failed: the matrix is not symmetric positive definite.
    #[error("matrix is not symmetric positive definite")]
    NotPositiveDefinite,
    /// An eigenvalue or singular-value iteration did not converge.
    #[error("eigenvalue iteration did not converge")]
    NoConvergence,
    /// The matrix has NaN or infinite entries.
    #[error("the matrix has non-finite entries")]
    NonFinite,
}

/// Borrowed column-major view of a contiguous slice: `rows × cols`, column stride `stride`.
pub fn view(data: &[f64], rows: usize, cols: usize, stride: usize) -> MatRef<'_, f64> {
    MatRef::from_column_major_slice_with_stride(data, rows, cols, stride)
}

/// `dst (+)= alpha * a * b` for dense blocks stored column-major in slices.
pub fn gemm(
    dst: &mut [f64],
    dst_stride: usize,
    accumulate: bool,
    a: MatRef<'_, f64>,
    b: MatRef<'_, f64>,
    alpha: f64,
) {
    let dst = faer::MatMut::from_column_major_slice_with_stride_mut(
        dst,
        a.nrows(),
        b.ncols(),
        dst_stride,
    );
    let beta = if accumulate {
        Accum::Add
    } else {
        Accum::Replace
    };
    matmul(dst, beta, a, b, alpha, Par::Seq);
}

/// Dense product `a * b` into a new matrix.
pub fn product(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> Mat<f64> {
    let mut out = Mat::zeros(a.nrows(), b.ncols());
    matmul(out.as_mut(), Accum::Replace, a, b, 1.0, Par::Seq);
    out
}

/// Lower Cholesky factor `L` with `A = L Lᵀ`.
pub fn cholesky_lower(a: MatRef<'_, f64>) -> Result<Mat<f64>, LinalgError> {
    let llt = a
        .llt(Side::Lower)
        .map_err(|_| LinalgError::NotPositiveDefinite)?;
    Ok(llt.L().to_owned())
}

/// Solves `L X = B` in place for lower-triangular `L`.
pub fn solve_lower_in_place(l: MatRef<'_, f64>, b: &mut Mat<f64>) {
    faer::linalg::triangular_solve::solve_lower_triangular_in_place(l, b.as_mut(), Par::Seq);
}

/// Solves `Lᵀ X = B` in place for lower-triangular `L`.
pub fn solve_lower_transpose_in_place(l: MatRef<'_, f64>, b: &mut Mat<f64>) {
    faer::linalg::triangular_solve::solve_upper_triangular_in_place(
        l.transpose(),
        b.as_mut(),
        Par::Seq,
    );
}

/// Solves `L Lᵀ X = B` in place for `cols` contiguous column-major columns of `b`.
pub fn cholesky_solve_in_place(l: MatRef<'_, f64>, b: &mut [f64], cols: usize) {
    let n = l.nrows();
    let rhs = faer::MatMut::from_column_major_slice_mut(&mut b[..n * cols], n, cols);
    faer::linalg::triangular_solve::solve_lower_triangular_in_place(l, rhs, Par::Seq);
    let rhs = faer::MatMut::from_column_major_slice_mut(&mut b[..n * cols], n, cols);
    faer::linalg::triangular_solve::solve_upper_triangular_in_place(l.transpose(), rhs, Par::Seq);
}

/// A dense LU factorisation with partial pivoting (the implicit integrators' stage systems).
#[derive(Clone)]
pub struct DenseLu(faer::linalg::solvers::PartialPivLu<f64>);

impl DenseLu {
    /// Factorises the square matrix `a`.
    pub fn new(a: MatRef<'_, f64>) -> Self {
        Self(a.partial_piv_lu())
    }

    /// Solves `A X = B` in place for `cols` contiguous column-major columns of `b`.
    pub fn solve_in_place(&self, b: &mut [f64], cols: usize) {
        use faer::linalg::solvers::Solve;
        let n = b.len() / cols.max(1);
        let rhs = faer::MatMut::from_column_major_slice_mut(b, n, cols);
        self.0.solve_in_place(rhs);
    }
}

/// A square sparse matrix's structure in compressed columns (rows sorted within a column),
/// with its symbolic LU factorisation made once: each numeric factorisation with new values on
/// the same structure then skips the ordering and the symbolic analysis.
///
/// faer's lower-level interface is used so the supernodal factorisation can be chosen: the
/// implicit integrator's stage systems are made of `s × s` dense blocks per entry of `K_t`,
/// which group into supernodes (see [`SparseLuPattern::new`] for the figures).
pub struct SparseLuPattern {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    symbolic: std::sync::Arc<faer::sparse::linalg::lu::SymbolicLu<usize>>,
}

/// Largest sparse LU factorised supernodally ([`SparseLuPattern::new`]).
pub const SUPERNODAL_UP_TO: usize = 1000;

/// A numeric sparse LU factorisation on a [`SparseLuPattern`], real or complex (the
/// transformed stage systems of the collocation integrators, docs/method.md eq. (32f)).
#[derive(Clone)]
pub struct SparseLu<T = f64> {
    symbolic: std::sync::Arc<faer::sparse::linalg::lu::SymbolicLu<usize>>,
    numeric: faer::sparse::linalg::lu::NumericLu<usize, T>,
}

/// A work buffer of `req` bytes for faer's stack-based routines.
fn scratch(req: faer::dyn_stack::StackReq) -> faer::dyn_stack::MemBuffer {
    faer::dyn_stack::MemBuffer::new(req)
}

impl SparseLuPattern {
    /// The structure of an `n × n` matrix; `None` if the symbolic analysis fails.
    ///
    /// Supernodal factorisation up to [`SUPERNODAL_UP_TO`] rows; above, faer's own choice by
    /// the fill's flop ratio, which takes simplicial on every beam (measured up to the
    /// 10⁴-dof von Kármán beam's 29,988 rows) and supernodal on a solid's three-dimensional
    /// fill: the 513-dof hex27 box's first 4 points (1,309 factorisations of 1,539 rows)
    /// 120 s and 1.89 GB simplicial, 49 s and 1.18 GB supernodal. Measured on the ECL beam's Radau5
    /// and Gauss6 stage systems (`3n` rows), whole branches or their first points: 19 elements
    /// (114 rows) 0.53 s supernodal against 0.72 s simplicial; 100 elements (600) 6.58 s
    /// against 6.75 s; 200 elements (1,200) 2.97 against 2.76 s; 400 (2,400) 6.83 against
    /// 6.15 s; 1,000 (6,000) 9.81 against 7.21 s — small supernodes do not pay for their
    /// dense kernels on a beam's thin fill.
    pub fn new(n: usize, col_ptr: Vec<usize>, row_idx: Vec<usize>) -> Option<Self> {
        Self::analyse(n, col_ptr, row_idx, n <= SUPERNODAL_UP_TO)
    }

    /// As [`Self::new`] without forcing small ones supernodal: for matrices of a model's
    /// own pattern (the split stage systems, eq. (32f)), whose thin fill on beams forms no
    /// supernodes worth their dense kernels (faer's choice by flop ratio). Measured on the ECL beam's forced curve with its stage
    /// systems' linear part split: 100 elements (200 rows) 11.9 s simplicial against 18.0 s
    /// supernodal; 19 elements (38 rows) 4.08 against 4.85 s.
    pub fn chosen_by_fill(n: usize, col_ptr: Vec<usize>, row_idx: Vec<usize>) -> Option<Self> {
        Self::analyse(n, col_ptr, row_idx, false)
    }

    fn analyse(
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        supernodal: bool,
    ) -> Option<Self> {
        use faer::sparse::linalg::{SupernodalThreshold, lu};
        let structure =
            faer::sparse::SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let threshold = if supernodal {
            SupernodalThreshold::FORCE_SUPERNODAL
        } else {
            SupernodalThreshold::AUTO
        };
        let params = lu::LuSymbolicParams {
            supernodal_flop_ratio_threshold: threshold,
            ..Default::default()
        };
        let symbolic = lu::factorize_symbolic_lu(structure, params).ok()?;
        Some(Self {
            n,
            col_ptr,
            row_idx,
            symbolic: std::sync::Arc::new(symbolic),
        })
    }

    /// Factorises the matrix with these values (in the pattern's order); `None` if singular.
    pub fn factorise<T: faer::traits::ComplexField>(&self, values: &[T]) -> Option<SparseLu<T>> {
        let structure = faer::sparse::SymbolicSparseColMatRef::new_checked(
            self.n,
            self.n,
            &self.col_ptr,
            None,
            &self.row_idx,
        );
        let matrix = faer::sparse::SparseColMatRef::new(structure, values);
        let mut numeric = faer::sparse::linalg::lu::NumericLu::new();
        let params = Default::default();
        let mut buffer = scratch(
            self.symbolic
                .factorize_numeric_lu_scratch::<T>(faer::Par::Seq, params),
        );
        self.symbolic
            .factorize_numeric_lu(
                &mut numeric,
                matrix,
                faer::Par::Seq,
                faer::dyn_stack::MemStack::new(&mut buffer),
                params,
            )
            .ok()?;
        Some(SparseLu {
            symbolic: self.symbolic.clone(),
            numeric,
        })
    }
}

impl<T: faer::traits::ComplexField> SparseLu<T> {
    /// Solves `A X = B` in place for `cols` contiguous column-major columns of `b` (none: a
    /// model without nonlinear dofs has no low-rank columns to solve for).
    pub fn solve_in_place(&self, b: &mut [T], cols: usize) {
        if cols == 0 {
            return;
        }
        let n = b.len() / cols;
        let rhs = faer::MatMut::from_column_major_slice_mut(b, n, cols);
        let mut buffer = scratch(
            self.symbolic
                .solve_in_place_scratch::<T>(cols, faer::Par::Seq),
        );
        // `numeric` is the output of `factorize_numeric_lu` on this `symbolic` (the pairing
        // `new_unchecked` requires).
        let lu = faer::sparse::linalg::lu::LuRef::new_unchecked(&self.symbolic, &self.numeric);
        lu.solve_in_place_with_conj(
            faer::Conj::No,
            rhs,
            faer::Par::Seq,
            faer::dyn_stack::MemStack::new(&mut buffer),
        );
    }
}

/// A sparse Cholesky factorisation `A = L Lᵀ` of a symmetric positive definite matrix (the
/// mass of a finite-element model): O(nnz(L)) memory, no dense copy.
pub struct SparseCholesky(faer::sparse::linalg::solvers::Llt<usize, f64>);

impl std::fmt::Debug for SparseCholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SparseCholesky")
    }
}

impl SparseCholesky {
    /// Factorises the `n × n` symmetric matrix given in compressed rows (both triangles or
    /// either; the lower one — the upper one of the rows — is read); `None` if it is not
    /// positive definite.
    pub fn new(n: usize, row_start: &[usize], col: &[usize], values: &[f64]) -> Option<Self> {
        use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
        // Compressed rows of a symmetric matrix are its compressed columns: read as columns,
        // the entries with row index >= column form the lower triangle.
        let structure =
            faer::sparse::SymbolicSparseColMatRef::new_checked(n, n, row_start, None, col);
        let symbolic = SymbolicLlt::try_new(structure, Side::Lower).ok()?;
        let matrix = faer::sparse::SparseColMatRef::new(structure, values);
        Llt::try_new_with_symbolic(symbolic, matrix, Side::Lower)
            .ok()
            .map(Self)
    }

    /// Solves `A X = B` in place for `cols` contiguous column-major columns of `b`.
    pub fn solve_in_place(&self, b: &mut [f64], cols: usize) {
        use faer::linalg::solvers::Solve;
        let n = b.len() / cols.max(1);
        let rhs = faer::MatMut::from_column_major_slice_mut(b, n, cols);
        self.0.solve_in_place(rhs);
    }
}

/// Row sums cancelling more than this factor (`Σ|terms| / |sum|`) are redone in twice the
/// precision by [`sparse_row_dot`]. Below it a plain sum is exact to `ε` times this, 2e-8 of
/// the row: measured on the ECL beam, plain sums of rows cancelling ~10¹⁰-fold (100
/// elements) left 1.4e-10 of round-off in a period's flow, so rows below 10⁸ leave ~1e-12.
/// The 19-element beam's rows (~10⁷) stay plain: summing them twice cost 7% of its branch.
pub const CANCELLATION: f64 = 1e8;

/// `init + Σ_k values_k x[columns_k]`, a sparse row applied to `x`: summed plainly, and
/// again in twice the working precision ([`accurate_sum`] of [`exact_product`]s, Dot2, `init`
/// included) when the row's own terms cancel more than [`CANCELLATION`]-fold — what
/// finite-element rows do on smooth fields, by `(ω_max/ω)²` (docs/method.md §15, eq. (76c)).
/// `init` takes no part in that test: added to a residual (a stage residual's damping
/// force), whose terms cancel by construction, every row would be judged cancelling — 21% of
/// the rows of the 19-element ECL beam's forced curve went through the second pass for
/// nothing, ~8% of its time. The plain pass costs one absolute value more per term; a
/// 19-element beam never needs the second, a 1,000-element one nearly always.
#[inline]
pub fn sparse_row_dot(init: f64, columns: &[usize], values: &[f64], x: &[f64]) -> f64 {
    // The plain pass in two interleaved partial sums: a finite-element row's few terms
    // are then two dependency chains, not one — on the ECL beam's forced curve (rows of
    // ≤ 6 terms) this pass took 17% of the time with one chain, latency-bound.
    let (mut sums, mut sizes) = ([0.0f64; 2], [0.0f64; 2]);
    let (pairs, values_paired) = (columns.chunks_exact(2), values.chunks_exact(2));
    let (last_column, last_value) = (pairs.remainder(), values_paired.remainder());
    for (c, v) in pairs.zip(values_paired) {
        for k in 0..2 {
            let term = v[k] * x[c[k]];
            sums[k] += term;
            sizes[k] += term.abs();
        }
    }
    if let (Some(&c), Some(&v)) = (last_column.first(), last_value.first()) {
        let term = v * x[c];
        sums[0] += term;
        sizes[0] += term.abs();
    }
    let (sum, size) = (sums[0] + sums[1], sizes[0] + sizes[1]);
    if size <= CANCELLATION * sum.abs() {
        return init + sum;
    }
    accurate_row_dot(init, columns, values, x)
}

/// The second pass of [`sparse_row_dot`]: out of line, so that the plain pass's loop stays
/// small where it is inlined.
#[cold]
#[inline(never)]
fn accurate_row_dot(init: f64, columns: &[usize], values: &[f64], x: &[f64]) -> f64 {
    let row = columns.iter().zip(values).map(|(&c, &v)| (v, x[c]));
    with_fused_multiply_add(|| accurate_sum(init, row.map(|(v, x)| exact_product(v, x))))
}

/// `init + Σ terms`: summed plainly, and again in twice the working precision from the same
/// terms given exactly (`head + tail`, [`accurate_sum`], `init` included) when they cancel
/// more than `cancellation`-fold among themselves (`Σ|terms| / |Σ terms|`; docs/method.md
/// eqs. (57a), (76c)) — `init` takes no part in the test, as in [`sparse_row_dot`]: a sum
/// added to another force that it balances (a tensor's cubic rows to its quadratic ones, on
/// a von Kármán beam whose membrane force is their small difference) would otherwise be
/// redone whatever its own terms do, for no gain over `init`'s own rounding. The plain pass
/// costs one absolute value more per term; the plain sum is left with up to `ε` times
/// `cancellation` of round-off per term.
#[inline(always)]
pub fn cancelling_sum<E: Iterator<Item = (f64, f64)>>(
    init: f64,
    terms: impl Iterator<Item = f64>,
    exact_terms: impl FnOnce() -> E,
    cancellation: f64,
) -> f64 {
    let (mut sum, mut size) = (0.0f64, 0.0f64);
    for term in terms {
        sum += term;
        size += term.abs();
    }
    if size <= cancellation * sum.abs() {
        return init + sum;
    }
    with_fused_multiply_add(|| accurate_sum(init, exact_terms()))
}

/// `work()` compiled with the fused multiply-add where the CPU has it: the error-free
/// product ([`exact_product`]) is one instruction with FMA, a call into libm without it
/// (x86-64's baseline lacks FMA) — the same correctly rounded result either way, 3% off the
/// first points of the 1,000-element beam (7.00 → 6.62–6.90 s), where the libm call alone
/// took 2.8% of a profile (3.7% at 10⁴ dofs). `work` must be inlined into it (the
/// accumulations below are `#[inline(always)]`).
#[inline(always)]
pub fn with_fused_multiply_add<R>(work: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "fma")]
        fn with_fma<R>(work: impl FnOnce() -> R) -> R {
            work()
        }
        if std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the CPU supports FMA (checked just above).
            return unsafe { with_fma(work) };
        }
    }
    work()
}

/// `(p, e)` with `p = fl(a b)` and `a b = p + e` exactly (an error-free product by `mul_add`).
#[inline(always)]
pub fn exact_product(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

/// `init + Σ (head_k + tail_k)` accumulated in twice the working precision (Ogita, Rump &
/// Oishi's Sum2 with each term given to twice the precision as `head + tail`, `|tail| ≤ u
/// |head|`: error-free sums of the heads, the tails and the sums' errors added plainly), as
/// if computed in quadruple precision and rounded once. With the terms of
/// [`exact_product`] it is their Dot2, about five times a plain sum's work.
#[inline(always)]
pub fn accurate_sum(init: f64, terms: impl Iterator<Item = (f64, f64)>) -> f64 {
    let (mut sum, mut error) = (init, 0.0f64);
    for (head, tail) in terms {
        let (total, lost) = exact_sum(sum, head);
        error += lost + tail;
        sum = total;
    }
    sum + error
}

/// `(s, e)` with `s = fl(a + b)` and `a + b = s + e` exactly (Knuth's two-sum).
#[inline(always)]
pub fn exact_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let back = s - a;
    (s, (a - (s - back)) + (b - back))
}

/// Eigenvalues (ascending) and orthonormal eigenvectors of a symmetric matrix.
pub fn symmetric_eigen(a: MatRef<'_, f64>) -> Result<(Vec<f64>, Mat<f64>), LinalgError> {
    let evd = a
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| LinalgError::NoConvergence)?;
    let values = evd.S().column_vector().iter().copied().collect();
    Ok((values, evd.U().to_owned()))
}

/// `NonFinite` if an entry of `a` is not finite (the eigensolvers would not converge).
fn finite(a: MatRef<'_, f64>) -> Result<(), LinalgError> {
    match (0..a.ncols()).all(|j| (0..a.nrows()).all(|i| a[(i, j)].is_finite())) {
        true => Ok(()),
        false => Err(LinalgError::NonFinite),
    }
}

/// Eigenvalues of a general real matrix.
pub fn eigenvalues(a: MatRef<'_, f64>) -> Result<Vec<Complex>, LinalgError> {
    finite(a)?;
    let values = a.eigenvalues().map_err(|_| LinalgError::NoConvergence)?;
    Ok(values.iter().map(|z| (z.re, z.im)).collect())
}

/// Eigenvalues of a general real matrix and their eigenvectors (column `k` of the returned
/// `n × m` list of columns, each `n` complex entries).
pub fn eigenpairs(a: MatRef<'_, f64>) -> Result<(Vec<Complex>, Vec<Vec<Complex>>), LinalgError> {
    finite(a)?;
    let eigen = a.eigen().map_err(|_| LinalgError::NoConvergence)?;
    let values = eigen
        .S()
        .column_vector()
        .iter()
        .map(|z| (z.re, z.im))
        .collect();
    let u = eigen.U();
    let vectors = (0..u.ncols())
        .map(|k| {
            (0..u.nrows())
                .map(|i| (u[(i, k)].re, u[(i, k)].im))
                .collect()
        })
        .collect();
    Ok((values, vectors))
}

/// Least-squares solution of `A x = b` (A with full column rank) by Householder QR.
///
/// This is the Moore–Penrose solution of the overdetermined corrector systems (docs/method.md §5),
/// whose extra rows (energy conservation makes one periodicity equation redundant) are
/// consistent at a solution.
pub fn least_squares(a: MatRef<'_, f64>, b: &[f64]) -> Vec<f64> {
    let rhs = view(b, b.len(), 1, b.len());
    let x = a.qr().solve_lstsq(rhs);
    (0..a.ncols()).map(|i| x[(i, 0)]).collect()
}

/// Singular values in ascending order and the matching right singular vectors (the columns
/// of the returned matrix): the null directions of a rank-deficient Jacobian come first.
pub fn right_singular(a: MatRef<'_, f64>) -> Result<(Vec<f64>, Mat<f64>), LinalgError> {
    let svd = a.thin_svd().map_err(|_| LinalgError::NoConvergence)?;
    let values: Vec<f64> = svd.S().column_vector().iter().copied().collect();
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&x, &y| values[x].total_cmp(&values[y]));
    let v = svd.V();
    let vectors = Mat::from_fn(v.nrows(), order.len(), |i, j| v[(i, order[j])]);
    Ok((order.iter().map(|&k| values[k]).collect(), vectors))
}

/// Euclidean norm.
pub fn norm(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// Euclidean distance `‖a − b‖`.
pub fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// Dot product.
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The non-zeros of `a` in compressed rows: `(row_start, col, value)`.
pub fn compressed_rows(a: &Mat<f64>) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
    let mut row_start = Vec::with_capacity(a.nrows() + 1);
    let (mut col, mut value) = (Vec::new(), Vec::new());
    row_start.push(0);
    for i in 0..a.nrows() {
        for j in 0..a.ncols() {
            if a[(i, j)] != 0.0 {
                col.push(j);
                value.push(a[(i, j)]);
            }
        }
        row_start.push(col.len());
    }
    (row_start, col, value)
}

/// Defines a hot kernel twice: as written (portable: SSE2 on x86-64) and compiled with AVX2,
/// chosen at run time by CPU detection (cached by std). The body sees a `const WIDE: bool`,
/// true in the AVX2 build, to pass on to [`combine`]. The arithmetic is the same — no FMA
/// contraction — so results are bitwise identical on either path; only the vector width
/// changes. Lifetimes in the signature must be elided.
macro_rules! multiversion {
    ($(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $body:block) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) {
            #[inline(always)]
            fn kernel<const WIDE: bool>($($arg: $ty),*) $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2")]
                fn avx2($($arg: $ty),*) {
                    kernel::<true>($($arg),*)
                }
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU supports AVX2 (checked just above).
                    return unsafe { avx2($($arg),*) };
                }
            }
            kernel::<false>($($arg),*)
        }
    };
}
pub(crate) use multiversion;

multiversion! {
    /// `out = A x` for interleaved `n × k` blocks (row `i`'s `k` directions contiguous at
    /// `[i * k..(i + 1) * k]`) and `A` in compressed rows (`row_start`, `col`, `value`): each
    /// row of the result combines whole contiguous rows of `x`, up to four at a time, so the
    /// inner loop runs over the `k` directions without gathers. Never allocates.
    pub fn sparse_times_interleaved(
        row_start: &[usize],
        col: &[usize],
        value: &[f64],
        x: &[f64],
        k: usize,
        out: &mut [f64],
    ) {
        if k == 0 {
            return;
        }
        let row = |j: usize| &x[j * k..(j + 1) * k];
        for (o, bounds) in out.chunks_exact_mut(k).zip(row_start.windows(2)) {
            let (cols, vals) = (&col[bounds[0]..bounds[1]], &value[bounds[0]..bounds[1]]);
            if cols.is_empty() {
                o.fill(0.0);
                continue;
            }
            let mut first = true;
            for (c, v) in cols.chunks(4).zip(vals.chunks(4)) {
                match (c, first) {
                    (&[a], true) => combine::<WIDE, false, 1>(o, [v[0]], [row(a)]),
                    (&[a], false) => combine::<WIDE, true, 1>(o, [v[0]], [row(a)]),
                    (&[a, b], true) => {
                        combine::<WIDE, false, 2>(o, [v[0], v[1]], [row(a), row(b)])
                    }
                    (&[a, b], false) => {
                        combine::<WIDE, true, 2>(o, [v[0], v[1]], [row(a), row(b)])
                    }
                    (&[a, b, d], true) => combine::<WIDE, false, 3>(
                        o,
                        [v[0], v[1], v[2]],
                        [row(a), row(b), row(d)],
                    ),
                    (&[a, b, d], false) => combine::<WIDE, true, 3>(
                        o,
                        [v[0], v[1], v[2]],
                        [row(a), row(b), row(d)],
                    ),
                    (&[a, b, d, e], true) => combine::<WIDE, false, 4>(
                        o,
                        [v[0], v[1], v[2], v[3]],
                        [row(a), row(b), row(d), row(e)],
                    ),
                    (&[a, b, d, e], false) => combine::<WIDE, true, 4>(
                        o,
                        [v[0], v[1], v[2], v[3]],
                        [row(a), row(b), row(d), row(e)],
                    ),
                    _ => unreachable!("chunks of one to four"),
                }
                first = false;
            }
        }
    }
}

/// `o = (ADD ? o : 0) + Σ_m v[m] x[m]` elementwise, `M` rows in one pass over `o`, summed
/// as `((v0 x0 + v1 x1) + v2 x2) + ...` on every path. `WIDE` (only inside the AVX2 build of
/// [`multiversion!`]) takes explicit four-lane AVX2 registers: left to the auto-vectoriser,
/// these short rows (tens of directions) spent more in loop set-up and scalar remainders
/// than in arithmetic.
#[inline(always)]
pub(crate) fn combine<const WIDE: bool, const ADD: bool, const M: usize>(
    o: &mut [f64],
    v: [f64; M],
    x: [&[f64]; M],
) {
    let len = o.len();
    let x = x.map(|xm| &xm[..len]);
    let mut done = 0;
    #[cfg(target_arch = "x86_64")]
    if WIDE {
        // SAFETY: WIDE is true only in the AVX2 build, entered after detection.
        unsafe { combine_avx2::<ADD, M>(o, v, x) };
        done = len / 4 * 4;
    }
    for i in done..len {
        let mut s = v[0] * x[0][i];
        for m in 1..M {
            s += v[m] * x[m][i];
        }
        o[i] = if ADD { o[i] + s } else { s };
    }
}

/// The four-lane groups of [`combine`] (the remainder, `len % 4`, is left to it). Every
/// `x[m]` must have `o.len()` entries.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn combine_avx2<const ADD: bool, const M: usize>(o: &mut [f64], v: [f64; M], x: [&[f64]; M]) {
    use std::arch::x86_64::{
        _mm256_add_pd, _mm256_loadu_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_storeu_pd,
    };
    let len = o.len();
    assert!(x.iter().all(|xm| xm.len() == len));
    let v = v.map(|c| _mm256_set1_pd(c));
    let out = o.as_mut_ptr();
    for g in 0..len / 4 {
        let i = 4 * g;
        // SAFETY: i + 4 <= len, the length of `o` and of every `x[m]` (asserted above).
        unsafe {
            let mut s = _mm256_mul_pd(v[0], _mm256_loadu_pd(x[0].as_ptr().add(i)));
            for m in 1..M {
                let t = _mm256_mul_pd(v[m], _mm256_loadu_pd(x[m].as_ptr().add(i)));
                s = _mm256_add_pd(s, t);
            }
            if ADD {
                s = _mm256_add_pd(_mm256_loadu_pd(out.add(i)), s);
            }
            _mm256_storeu_pd(out.add(i), s);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    /// Rows with zero to seven non-zeros (every grouping of the kernel) against a dense sum.
    #[test]
    fn sparse_times_interleaved_matches_dense() {
        let n = 8;
        let k = 5;
        let a = Mat::from_fn(n, n, |i, j| {
            if j < i {
                (1.0 + i as f64 * 0.3 - j as f64).sin()
            } else {
                0.0
            }
        });
        let (row_start, col, value) = compressed_rows(&a);
        let x: Vec<f64> = (0..n * k).map(|p| (0.37 * p as f64).cos()).collect();
        let mut out = vec![f64::NAN; n * k];
        sparse_times_interleaved(&row_start, &col, &value, &x, k, &mut out);
        for i in 0..n {
            for c in 0..k {
                let expected: f64 = (0..n).map(|j| a[(i, j)] * x[j * k + c]).sum();
                assert!((out[i * k + c] - expected).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn least_squares_solves_consistent_overdetermined_system() {
        // Three equations, two unknowns, consistent: x = (1, -2).
        let a = Mat::from_fn(3, 2, |i, j| [[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]][i][j]);
        let x = least_squares(a.as_ref(), &[1.0, -2.0, -1.0]);
        assert!((x[0] - 1.0).abs() < 1e-14 && (x[1] + 2.0).abs() < 1e-14);
    }
}
