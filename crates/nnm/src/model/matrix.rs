//! Square matrices as models come with them: dense (small hand-written models) or sparse
//! (finite-element exports, Matrix Market), kept in the storage they were given so that no
//! dense `n × n` copy is made of a sparse model.

use crate::linalg::{self, Mat};

/// A real square matrix, dense or in compressed rows.
#[derive(Debug, Clone, PartialEq)]
pub enum Matrix {
    /// Dense storage (small hand-written models).
    Dense(Mat<f64>),
    /// Compressed sparse rows (finite-element exports, Matrix Market).
    Sparse(SparseMatrix),
}

/// Compressed sparse rows of an `n × n` matrix (column indices sorted within a row, no
/// duplicates).
#[derive(Debug, Clone, PartialEq)]
pub struct SparseMatrix {
    n: usize,
    pattern: SparsityPattern,
    values: Vec<f64>,
}

/// The positions of the non-zeros of a sparse `n × n` matrix in compressed rows: row `i`
/// holds columns `col[row_start[i]..row_start[i + 1]]`, sorted.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct SparsityPattern {
    /// Row `i`'s entries are stored at `row_start[i]..row_start[i + 1]` (length `n + 1`).
    pub row_start: Vec<usize>,
    /// Column of each stored entry, sorted within a row.
    pub col: Vec<usize>,
}

impl SparsityPattern {
    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.row_start.len().saturating_sub(1)
    }
    /// Number of stored entries.
    pub fn nonzeros(&self) -> usize {
        self.col.len()
    }
    /// Where entry `(i, j)` is stored, if it is in the pattern.
    pub fn position(&self, i: usize, j: usize) -> Option<usize> {
        let (a, b) = (self.row_start[i], self.row_start[i + 1]);
        self.col[a..b].binary_search(&j).ok().map(|k| a + k)
    }
}

impl SparseMatrix {
    /// `out[i] += (A x)_i` for one column, a row whose terms cancel redone in twice the
    /// working precision ([`linalg::sparse_row_dot`]).
    pub(crate) fn apply_add_accurate(&self, x: &[f64], out: &mut [f64]) {
        let p = &self.pattern;
        for (o, bounds) in out.iter_mut().zip(p.row_start.windows(2)) {
            let span = bounds[0]..bounds[1];
            *o = linalg::sparse_row_dot(*o, &p.col[span.clone()], &self.values[span], x);
        }
    }

    /// Builds an `n × n` matrix from `(row, column, value)` triplets (0-based); duplicates are
    /// summed, as finite-element assembly expects. Entries out of range are an error.
    pub fn from_triplets(n: usize, triplets: &[(usize, usize, f64)]) -> Result<Self, String> {
        if let Some(&(i, j, _)) = triplets.iter().find(|(i, j, _)| *i >= n || *j >= n) {
            return Err(format!("entry ({i}, {j}) is outside the {n}x{n} matrix"));
        }
        let mut sorted: Vec<(usize, usize, f64)> = triplets.to_vec();
        sorted.sort_by_key(|&(i, j, _)| (i, j));
        let mut row_start = vec![0; n + 1];
        let (mut col, mut values): (Vec<usize>, Vec<f64>) = (Vec::new(), Vec::new());
        let mut last: Option<(usize, usize)> = None;
        for (i, j, v) in sorted {
            if last == Some((i, j)) {
                *values.last_mut().expect("a previous entry") += v;
                continue;
            }
            col.push(j);
            values.push(v);
            row_start[i + 1] = col.len();
            last = Some((i, j));
        }
        for i in 0..n {
            row_start[i + 1] = row_start[i + 1].max(row_start[i]);
        }
        Ok(Self {
            n,
            pattern: SparsityPattern { row_start, col },
            values,
        })
    }

    /// The non-zeros of a dense matrix.
    pub(crate) fn from_dense(a: &Mat<f64>) -> Self {
        let (row_start, col, values) = linalg::compressed_rows(a);
        Self {
            n: a.nrows(),
            pattern: SparsityPattern { row_start, col },
            values,
        }
    }

    /// Size `n` of the `n × n` matrix.
    pub fn dimension(&self) -> usize {
        self.n
    }
    /// Where the stored entries are.
    pub fn pattern(&self) -> &SparsityPattern {
        &self.pattern
    }
    /// The stored entries, in the order of the pattern's `col`.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// `out += alpha * A x` for `cols` column-major columns with the given strides.
    pub(crate) fn apply_add(
        &self,
        alpha: f64,
        x: &[f64],
        x_stride: usize,
        cols: usize,
        out: &mut [f64],
        out_stride: usize,
    ) {
        let p = &self.pattern;
        for c in 0..cols {
            let xc = &x[c * x_stride..c * x_stride + self.n];
            let oc = &mut out[c * out_stride..c * out_stride + self.n];
            for (o, bounds) in oc.iter_mut().zip(p.row_start.windows(2)) {
                let (cols_i, vals_i) = (
                    &p.col[bounds[0]..bounds[1]],
                    &self.values[bounds[0]..bounds[1]],
                );
                let s: f64 = cols_i.iter().zip(vals_i).map(|(&j, &v)| v * xc[j]).sum();
                *o += alpha * s;
            }
        }
    }
}

impl From<Mat<f64>> for Matrix {
    fn from(a: Mat<f64>) -> Self {
        Matrix::Dense(a)
    }
}

impl From<SparseMatrix> for Matrix {
    fn from(a: SparseMatrix) -> Self {
        Matrix::Sparse(a)
    }
}

/// The largest entry magnitude a matrix may hold, `√f64::MAX`.
const LARGEST_ENTRY: f64 = 1.340_780_792_994_259_6e154;

impl Matrix {
    /// A dense matrix from a function of `(row, column)`.
    pub fn from_fn(rows: usize, cols: usize, f: impl FnMut(usize, usize) -> f64) -> Self {
        Matrix::Dense(Mat::from_fn(rows, cols, f))
    }

    /// The `n × n` identity (dense).
    pub fn identity(n: usize) -> Self {
        Matrix::Dense(Mat::identity(n, n))
    }

    /// A dense matrix from its rows; ragged rows are an error.
    pub fn from_rows(rows: &[Vec<f64>]) -> Result<Self, String> {
        let n = rows.len();
        let cols = rows.first().map_or(0, Vec::len);
        if let Some((i, r)) = rows.iter().enumerate().find(|(_, r)| r.len() != cols) {
            return Err(format!(
                "row {} has {} entries, row 1 has {cols}",
                i + 1,
                r.len()
            ));
        }
        Ok(Matrix::from_fn(n, cols, |i, j| rows[i][j]))
    }

    /// Number of rows.
    pub fn nrows(&self) -> usize {
        match self {
            Matrix::Dense(a) => a.nrows(),
            Matrix::Sparse(a) => a.n,
        }
    }
    /// Number of columns (a model's matrices must be square; `Structure::new` checks).
    pub fn ncols(&self) -> usize {
        match self {
            Matrix::Dense(a) => a.ncols(),
            Matrix::Sparse(a) => a.n,
        }
    }

    /// Entry `(i, j)` (a binary search in a sparse row).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        match self {
            Matrix::Dense(a) => a[(i, j)],
            Matrix::Sparse(a) => a.pattern.position(i, j).map_or(0.0, |k| a.values[k]),
        }
    }

    /// `A v`.
    pub fn times(&self, v: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.nrows()];
        self.apply_add(1.0, v, v.len(), 1, &mut out, self.nrows());
        out
    }

    /// `out[:, c] += alpha * A x[:, c]` for `cols` column-major columns.
    pub(crate) fn apply_add(
        &self,
        alpha: f64,
        x: &[f64],
        x_stride: usize,
        cols: usize,
        out: &mut [f64],
        out_stride: usize,
    ) {
        match self {
            Matrix::Dense(a) => linalg::gemm(
                out,
                out_stride,
                true,
                a.as_ref(),
                linalg::view(x, a.ncols(), cols, x_stride),
                alpha,
            ),
            Matrix::Sparse(a) => a.apply_add(alpha, x, x_stride, cols, out, out_stride),
        }
    }

    /// Whether every off-diagonal entry is zero.
    pub fn is_diagonal(&self) -> bool {
        match self {
            Matrix::Dense(a) => {
                (0..a.nrows()).all(|i| (0..a.ncols()).all(|j| i == j || a[(i, j)] == 0.0))
            }
            Matrix::Sparse(a) => (0..a.n).all(|i| {
                let r = a.pattern.row_start[i]..a.pattern.row_start[i + 1];
                a.pattern.col[r.clone()]
                    .iter()
                    .zip(&a.values[r])
                    .all(|(&j, &v)| j == i || v == 0.0)
            }),
        }
    }

    /// The stored entries `(i, j, value)` (every entry of a dense matrix, zeros included).
    pub(crate) fn entries(&self) -> Box<dyn Iterator<Item = (usize, usize, f64)> + '_> {
        match self {
            Matrix::Dense(a) => Box::new(
                (0..a.ncols()).flat_map(move |j| (0..a.nrows()).map(move |i| (i, j, a[(i, j)]))),
            ),
            Matrix::Sparse(a) => Box::new((0..a.n).flat_map(move |i| {
                (a.pattern.row_start[i]..a.pattern.row_start[i + 1])
                    .map(move |k| (i, a.pattern.col[k], a.values[k]))
            })),
        }
    }

    /// A dense copy (small models only: modal analysis of the whole spectrum).
    pub fn to_dense(&self) -> Mat<f64> {
        match self {
            Matrix::Dense(a) => a.clone(),
            Matrix::Sparse(a) => {
                let mut d = Mat::zeros(a.n, a.n);
                for (i, j, v) in self.entries() {
                    d[(i, j)] += v;
                }
                d
            }
        }
    }

    /// The first entry `(i, j, a_ij, why)`, in storage order, that double precision does not
    /// hold with full accuracy, if any: a subnormal one (below `f64::MIN_POSITIVE`; zeros are
    /// fine) or one beyond `√f64::MAX ≈ 1.34e154`, whose square — formed by the norms of modal
    /// analysis and the solvers — overflows. `why` says which, for a message.
    pub fn out_of_range(&self) -> Option<(usize, usize, f64, &'static str)> {
        self.entries().find_map(|(i, j, v)| {
            if v.abs() > LARGEST_ENTRY {
                Some((
                    i,
                    j,
                    v,
                    "beyond 1.3e154, where its square overflows double precision",
                ))
            } else if v != 0.0 && v.abs() < f64::MIN_POSITIVE {
                Some((
                    i,
                    j,
                    v,
                    "subnormal (below 2.2e-308) and has lost digits in double precision",
                ))
            } else {
                None
            }
        })
    }

    /// The first entry `(i, j, a_ij, a_ji)`, in storage order, where `A` and `Aᵀ` differ by
    /// more than `relative` times the largest `|entry|` (a missing mirror counts as zero), if
    /// any. `O(nnz log)` for a sparse matrix (a binary search per mirror). NaN entries are not
    /// reported here (check finiteness first).
    pub fn asymmetry(&self, relative: f64) -> Option<(usize, usize, f64, f64)> {
        let scale = self.entries().fold(0.0_f64, |s, (_, _, v)| s.max(v.abs()));
        self.entries().find_map(|(i, j, v)| {
            let w = self.get(j, i);
            ((v - w).abs() > relative * scale).then_some((i, j, v, w))
        })
    }

    /// The rows and columns `free` (ascending; `index[d]` is the position of `d` in `free`,
    /// `None` for a dropped dof), in the same storage: `O(nnz)` for a sparse matrix.
    pub(crate) fn principal_submatrix(&self, free: &[usize], index: &[Option<usize>]) -> Matrix {
        match self {
            Matrix::Dense(a) => Matrix::Dense(Mat::from_fn(free.len(), free.len(), |r, c| {
                a[(free[r], free[c])]
            })),
            Matrix::Sparse(a) => {
                let p = &a.pattern;
                let mut row_start = Vec::with_capacity(free.len() + 1);
                row_start.push(0);
                let (mut col, mut values) = (Vec::new(), Vec::new());
                for &i in free {
                    for k in p.row_start[i]..p.row_start[i + 1] {
                        // `index` is increasing on the free dofs: columns stay sorted.
                        if let Some(j) = index[p.col[k]] {
                            col.push(j);
                            values.push(a.values[k]);
                        }
                    }
                    row_start.push(col.len());
                }
                Matrix::Sparse(SparseMatrix {
                    n: free.len(),
                    pattern: SparsityPattern { row_start, col },
                    values,
                })
            }
        }
    }

    /// Compressed rows of the non-zeros: the matrix itself when sparse; a dense matrix is
    /// compressed when at most a quarter of its entries are non-zero or when it is tiny
    /// (`n ≤ small`), where compressed rows beat a dense product and its set-up.
    pub(crate) fn compressed(&self, small: usize) -> Option<SparseMatrix> {
        match self {
            Matrix::Sparse(a) => Some(a.clone()),
            Matrix::Dense(a) => {
                let n = a.nrows();
                let nonzeros = self.entries().filter(|e| e.2 != 0.0).count();
                (n <= small || nonzeros * 4 <= n * n).then(|| SparseMatrix::from_dense(a))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows whose own terms cancel: plain summation loses the small ones entirely, the
    /// accurate product gets the exact results (representable here, so exactly equal), the
    /// value already in `out` included; that value takes no part in the test of cancellation.
    #[test]
    fn accurate_product_keeps_what_cancellation_loses() {
        let big = 1e16;
        // Row 0: 1e16 + 1 − 1e16 + 0.75; in plain arithmetic `1e16 + 1` rounds to `1e16`.
        let a = SparseMatrix::from_triplets(
            4,
            &[
                (0, 0, big),
                (0, 1, 1.0),
                (0, 2, -big),
                (0, 3, 0.75),
                (1, 1, 2.0),
            ],
        )
        .unwrap();
        let x = [1.0, 1.0, 1.0, 1.0];
        let mut plain = [0.5, 0.0, 0.0, 0.0];
        a.apply_add(1.0, &x, 4, 1, &mut plain, 4);
        let mut accurate = [0.5, 0.0, 0.0, 0.0];
        a.apply_add_accurate(&x, &mut accurate);
        assert_eq!(accurate, [2.25, 2.0, 0.0, 0.0]);
        assert_ne!(
            plain[0], accurate[0],
            "plain summation should lose the small terms here"
        );
        // A product error with the value in `out` cancelling the row: no term of the row
        // cancels another, so the plain sum stands — `out` is a residual's other terms, whose
        // own rounding the second pass could not undo.
        let b = SparseMatrix::from_triplets(1, &[(0, 0, 0.1)]).unwrap();
        let mut out = [-0.30000000000000004];
        b.apply_add_accurate(&[3.0], &mut out);
        assert_eq!(out[0], 0.0);
        // The same row with a second, cancelling term: the second pass keeps 0.1·3's exact
        // rounding error.
        let c = SparseMatrix::from_triplets(3, &[(0, 0, 0.1), (0, 1, -1e9), (0, 2, 1e9)]).unwrap();
        let mut out = [-0.30000000000000004, 0.0, 0.0];
        c.apply_add_accurate(&[3.0, 1.0, 1.0], &mut out);
        let exact_error = 0.1f64.mul_add(3.0, -0.30000000000000004);
        assert_eq!(out[0], exact_error);
        assert!(out[0] != 0.0);
    }

    #[test]
    fn triplets_sum_duplicates_and_match_dense_product() {
        let t = [
            (0, 0, 2.0),
            (1, 0, -1.0),
            (0, 1, -1.0),
            (1, 1, 1.0),
            (1, 1, 1.0),
        ];
        let s = Matrix::Sparse(SparseMatrix::from_triplets(3, &t).unwrap());
        let d = Matrix::from_fn(3, 3, |i, j| match (i, j) {
            (0, 0) | (1, 1) => 2.0,
            (0, 1) | (1, 0) => -1.0,
            _ => 0.0,
        });
        let v = [0.3, -1.1, 2.0];
        assert_eq!(s.times(&v), d.times(&v));
        assert_eq!(s.get(1, 1), 2.0);
        assert_eq!(s.get(2, 2), 0.0);
        assert!(SparseMatrix::from_triplets(2, &[(2, 0, 1.0)]).is_err());
    }
}
