//! A general model's `mass` and `stiffness`: rows in the job file, or Matrix Market files
//! checked before they are stored.

use std::path::Path;

use nnm::model::Matrix;

use super::JobError;
use super::schema::MatrixSpec;
use crate::matrix_market::{MarketMatrix, read_matrix_market};

/// Reads `mass` (`expected` = `None`) or `stiffness` (`Some(n)`, the mass's size). A file's
/// matrix is checked before it is stored: square, of the expected size, symmetric, finite and
/// in range ([`Matrix::out_of_range`]) (errors name the file and the entry, 1-based as in the
/// file); a coordinate file stays sparse (`O(nnz)`, no size limit).
pub(super) fn load_matrix(
    spec: &MatrixSpec,
    name: &'static str,
    expected: Option<usize>,
    base: &Path,
    path: &Path,
) -> Result<Matrix, JobError> {
    match spec {
        MatrixSpec::Rows(rows) => {
            let n = rows.len();
            if let Some((i, row)) = rows.iter().enumerate().find(|(_, r)| r.len() != n) {
                return Err(JobError::Invalid {
                    path: path.to_owned(),
                    message: format!(
                        "{name} matrix row {} has {} entries, expected {n} (a square matrix)",
                        i + 1,
                        row.len()
                    ),
                });
            }
            Ok(Matrix::from_fn(n, n, |i, j| rows[i][j]))
        }
        MatrixSpec::File { file } => {
            let file = base.join(file);
            let m = read_matrix_market(&file)?;
            check_file_matrix(name, expected, &file, m)
        }
    }
}

/// Relative tolerance of the symmetry check of matrix files, on the largest entry: values
/// written to full precision carry round-off of ~1e-16, so anything above 1e-12 is a
/// modelling or export error, not noise.
const FILE_SYMMETRY_TOLERANCE: f64 = 1e-12;

fn check_file_matrix(
    name: &'static str,
    expected: Option<usize>,
    file: &Path,
    m: MarketMatrix,
) -> Result<Matrix, JobError> {
    let invalid = |message: String| JobError::Invalid {
        path: file.to_owned(),
        message: format!("{name} matrix {message}"),
    };
    let (rows, cols) = (m.rows(), m.cols());
    if rows != cols {
        return Err(invalid(format!("is {rows}x{cols}, not square")));
    }
    if let Some(n) = expected
        && n != rows
    {
        return Err(invalid(format!(
            "is {rows}x{rows}, expected {n}x{n} (the size of the mass matrix)"
        )));
    }
    // A positive definite mass has every diagonal entry: a size beyond the stored entries is
    // refused before any O(n) storage is made for it (the stiffness's size must then match).
    if expected.is_none() && m.stored() < rows {
        return Err(invalid(format!(
            "is {rows}x{rows} but stores {} entries: it cannot be positive definite (every diagonal entry must be positive)",
            m.stored()
        )));
    }
    let m = m.into_matrix().expect("square");
    // Duplicates summed in a coordinate file may overflow.
    if let Matrix::Sparse(a) = &m {
        let p = a.pattern();
        if let Some(k) = a.values().iter().position(|v| !v.is_finite()) {
            let row = p.row_start.partition_point(|&s| s <= k);
            return Err(invalid(format!(
                "entry ({row}, {}) is not finite after summing duplicates",
                p.col[k] + 1
            )));
        }
    }
    if let Some((i, j, value, why)) = m.out_of_range() {
        return Err(invalid(format!(
            "entry ({}, {}) = {value:.3e} is {why}: rescale the model's units",
            i + 1,
            j + 1
        )));
    }
    if let Some((i, j, a, b)) = m.asymmetry(FILE_SYMMETRY_TOLERANCE) {
        return Err(invalid(format!(
            "is not symmetric: entry ({}, {}) = {a:e} but ({}, {}) = {b:e} (1-based; tolerance {FILE_SYMMETRY_TOLERANCE:e} of the largest entry)",
            i + 1,
            j + 1,
            j + 1,
            i + 1
        )));
    }
    Ok(m)
}
