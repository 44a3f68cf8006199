//! Reader for real matrices in the NIST Matrix Market exchange format.
//!
//! See <https://math.nist.gov/MatrixMarket/formats.html>. Supported headers
//! (case-insensitive):
//!
//! ```text
//! %%MatrixMarket matrix coordinate real|integer general|symmetric|skew-symmetric
//! %%MatrixMarket matrix array      real|integer general|symmetric|skew-symmetric
//! ```
//!
//! * The header must be the first line. After it, comment lines (first
//!   non-blank character `%`) and blank lines are skipped anywhere.
//! * The size line is `rows cols entries` (coordinate) or `rows cols` (array).
//! * Coordinate entries are `row col value` with 1-based indices, in any
//!   order. Duplicate entries are **summed**, the finite-element assembly
//!   convention. In symmetric (skew-symmetric) files each off-diagonal entry
//!   is mirrored (mirrored negated); diagonal entries are stored once. Either
//!   triangle may be listed, but not both: a file with entries in both strict
//!   triangles is rejected, since mirroring would double them.
//! * Array entries are one value per line in column-major order. Symmetric
//!   arrays list the lower triangle column by column (diagonal included),
//!   skew-symmetric arrays the strictly lower triangle.
//! * Values must be finite. Real values also accept a Fortran `D` exponent
//!   (`1.5D+03`); integer fields require integers.
//!
//! `complex` and `pattern` fields, `hermitian` symmetry and objects other than
//! `matrix` are rejected with [`MatrixMarketError::Unsupported`].
//!
//! Storage follows the format: a coordinate file is kept as its entries (memory `O(nnz)`,
//! whatever its size) and becomes a compressed-row [`SparseMatrix`] with duplicates summed
//! ([`MarketMatrix::into_matrix`]); an array file is dense by nature and kept dense, refused
//! only when it does not fit in memory.

use std::fmt;
use std::path::{Path, PathBuf};

use nnm::model::{Matrix, SparseMatrix};

/// A matrix as a Matrix Market file gives it, in the storage its format implies.
#[derive(Debug, Clone, PartialEq)]
pub enum MarketMatrix {
    /// A coordinate file: its entries `(row, col, value)`, 0-based, in file order, each
    /// off-diagonal entry of a (skew-)symmetric file followed by its mirror; duplicates are
    /// kept (summed by [`Self::into_matrix`]). Memory `O(nnz)`.
    Coordinate {
        rows: usize,
        cols: usize,
        entries: Vec<(usize, usize, f64)>,
    },
    /// An array file: every entry, column-major (`(i, j)` at `data[j * rows + i]`).
    Array {
        rows: usize,
        cols: usize,
        data: Vec<f64>,
    },
}

impl MarketMatrix {
    /// Number of rows.
    pub fn rows(&self) -> usize {
        match self {
            MarketMatrix::Coordinate { rows, .. } | MarketMatrix::Array { rows, .. } => *rows,
        }
    }

    /// Number of columns.
    pub fn cols(&self) -> usize {
        match self {
            MarketMatrix::Coordinate { cols, .. } | MarketMatrix::Array { cols, .. } => *cols,
        }
    }

    /// Number of stored entries (mirrors of symmetric files included, duplicates counted).
    pub fn stored(&self) -> usize {
        match self {
            MarketMatrix::Coordinate { entries, .. } => entries.len(),
            MarketMatrix::Array { data, .. } => data.len(),
        }
    }

    /// The model's matrix: sparse compressed rows for a coordinate file (duplicates summed,
    /// the finite-element assembly convention; no dense copy), dense for an array file.
    /// `None` when the matrix is not square (a model's matrices are).
    pub fn into_matrix(self) -> Option<Matrix> {
        match self {
            MarketMatrix::Coordinate {
                rows,
                cols,
                entries,
            } => (rows == cols).then(|| {
                Matrix::Sparse(
                    SparseMatrix::from_triplets(rows, &entries)
                        .expect("entries were checked against the size"),
                )
            }),
            MarketMatrix::Array { rows, cols, data } => {
                (rows == cols).then(|| Matrix::from_fn(rows, rows, |i, j| data[j * rows + i]))
            }
        }
    }
}

/// The text of `matrix` as a Matrix Market `coordinate real general` file (1-based, every
/// stored entry of a sparse matrix, the non-zeros of a dense one), `comments` as `%` lines
/// after the header. Values are written in the shortest form that reads back to the same
/// `f64`, so [`read_matrix_market`] gives the matrix bit for bit (`nnm export`).
pub fn format_coordinate(matrix: &Matrix, comments: &[String]) -> String {
    use std::fmt::Write;
    let n = matrix.nrows();
    let entries: Vec<(usize, usize, f64)> = match matrix {
        Matrix::Sparse(a) => {
            let p = a.pattern();
            (0..n)
                .flat_map(|i| (p.row_start[i]..p.row_start[i + 1]).map(move |k| (i, k)))
                .map(|(i, k)| (i, p.col[k], a.values()[k]))
                .collect()
        }
        Matrix::Dense(_) => (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .map(|(i, j)| (i, j, matrix.get(i, j)))
            .filter(|&(_, _, v)| v != 0.0)
            .collect(),
    };
    let mut text = String::from("%%MatrixMarket matrix coordinate real general\n");
    for c in comments {
        let _ = writeln!(text, "% {c}");
    }
    let _ = writeln!(text, "{n} {n} {}", entries.len());
    for (i, j, v) in entries {
        let _ = writeln!(text, "{} {} {v:e}", i + 1, j + 1);
    }
    text
}

/// Why a Matrix Market file could not be read. Every message is one line;
/// parse errors name the 1-based line number.
#[derive(Debug, thiserror::Error)]
pub enum MatrixMarketError {
    #[error("cannot read {}: {}", .path.display(), io_message(.error))]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    /// A parse error in a file read by [`read_matrix_market`].
    #[error("{}: {error}", .path.display())]
    InFile {
        path: PathBuf,
        error: Box<MatrixMarketError>,
    },
    #[error("line {line}: missing `%%MatrixMarket` header (must be the first line)")]
    MissingHeader { line: usize },
    #[error(
        "line {line}: malformed header, expected `%%MatrixMarket matrix <format> <field> <symmetry>`"
    )]
    BadHeader { line: usize },
    #[error("line {line}: unsupported {kind} `{value}` (supported: {supported})")]
    Unsupported {
        line: usize,
        kind: &'static str,
        value: String,
        supported: &'static str,
    },
    #[error("line {line}: file ends before the size line")]
    MissingSize { line: usize },
    #[error("line {line}: malformed size line, expected `{expected}` as non-negative integers")]
    BadSize { line: usize, expected: &'static str },
    #[error("line {line}: {symmetry} matrix must be square, but the size is {rows}x{cols}")]
    NotSquare {
        line: usize,
        symmetry: Symmetry,
        rows: usize,
        cols: usize,
    },
    /// An array (dense) file whose size does not fit in memory.
    #[error(
        "line {line}: array matrix of size {rows}x{cols} is too large for dense storage (write it in coordinate format)"
    )]
    TooLarge {
        line: usize,
        rows: usize,
        cols: usize,
    },
    #[error("line {line}: malformed entry, expected `{expected}`")]
    BadEntry { line: usize, expected: &'static str },
    #[error("line {line}: cannot parse `{token}` as {what}")]
    BadNumber {
        line: usize,
        token: String,
        what: &'static str,
    },
    #[error("line {line}: value `{token}` is not finite")]
    NonFinite { line: usize, token: String },
    #[error(
        "line {line}: index ({row}, {col}) out of range for {rows}x{cols} matrix (indices are 1-based)"
    )]
    IndexOutOfRange {
        line: usize,
        row: usize,
        col: usize,
        rows: usize,
        cols: usize,
    },
    #[error("line {line}: file ends after {found} of the {expected} entries declared")]
    TooFewEntries {
        line: usize,
        expected: usize,
        found: usize,
    },
    #[error("line {line}: more entries than the {expected} declared")]
    TooManyEntries { line: usize, expected: usize },
    #[error("line {line}: skew-symmetric matrix has nonzero diagonal entry ({index}, {index})")]
    SkewDiagonal { line: usize, index: usize },
    #[error(
        "line {line}: {symmetry} file lists entries in both the lower and upper triangle; store only one"
    )]
    BothTriangles { line: usize, symmetry: Symmetry },
}

/// The io error's text without the trailing ` (os error N)`.
fn io_message(error: &std::io::Error) -> String {
    let text = error.to_string();
    match error.raw_os_error() {
        Some(code) => text
            .strip_suffix(&format!(" (os error {code})"))
            .unwrap_or(&text)
            .to_owned(),
        None => text,
    }
}

/// The symmetry qualifier of a Matrix Market header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Symmetry {
    General,
    Symmetric,
    SkewSymmetric,
}

impl fmt::Display for Symmetry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Symmetry::General => "general",
            Symmetry::Symmetric => "symmetric",
            Symmetry::SkewSymmetric => "skew-symmetric",
        })
    }
}

/// Reads a Matrix Market file; parse errors are wrapped in
/// [`MatrixMarketError::InFile`] so their message names the file.
pub fn read_matrix_market(path: &Path) -> Result<MarketMatrix, MatrixMarketError> {
    let text = std::fs::read_to_string(path).map_err(|error| MatrixMarketError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    parse_matrix_market(&text).map_err(|error| MatrixMarketError::InFile {
        path: path.to_path_buf(),
        error: Box::new(error),
    })
}

/// Parses the text of a Matrix Market file (format described in the module docs).
pub fn parse_matrix_market(text: &str) -> Result<MarketMatrix, MatrixMarketError> {
    use MatrixMarketError as E;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let last_line = text.lines().count().max(1);
    let (coordinate, integer, symmetry) = parse_header(text.lines().next().unwrap_or(""))?;
    let mut data = text
        .lines()
        .enumerate()
        .skip(1)
        .map(|(k, s)| (k + 1, s))
        .filter(|(_, s)| {
            let s = s.trim_start();
            !s.is_empty() && !s.starts_with('%')
        });

    // Size line.
    let (line, size) = data.next().ok_or(E::MissingSize { line: last_line })?;
    let expected = if coordinate {
        "rows cols entries"
    } else {
        "rows cols"
    };
    let numbers: Vec<usize> = size
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()
        .map_err(|_| E::BadSize { line, expected })?;
    let (rows, cols, nnz) = match (coordinate, &numbers[..]) {
        (true, &[r, c, n]) => (r, c, n),
        (false, &[r, c]) => (r, c, 0),
        _ => return Err(E::BadSize { line, expected }),
    };
    if symmetry != Symmetry::General && rows != cols {
        return Err(E::NotSquare {
            line,
            symmetry,
            rows,
            cols,
        });
    }
    let value = |token: &str, line| parse_value(token, integer, line);
    // Sign of the mirrored off-diagonal entry in symmetric storage.
    let mirror = if symmetry == Symmetry::SkewSymmetric {
        -1.0
    } else {
        1.0
    };

    let mut found = 0;
    if coordinate {
        // No capacity from the header alone (it may lie): at most one entry per 6 bytes
        // ("1 1 1\n"), two with the mirror.
        let mirrored = if symmetry == Symmetry::General { 1 } else { 2 };
        let mut entries = Vec::with_capacity(nnz.min(text.len() / 6) * mirrored);
        let (mut lower, mut upper) = (false, false);
        for (line, entry) in data {
            if found == nnz {
                return Err(E::TooManyEntries {
                    line,
                    expected: nnz,
                });
            }
            let bad = || E::BadEntry {
                line,
                expected: "row col value",
            };
            let [i, j, v] = three_tokens(entry).ok_or_else(bad)?;
            let (i, j) = (parse_index(i, line)?, parse_index(j, line)?);
            if i == 0 || j == 0 || i > rows || j > cols {
                return Err(E::IndexOutOfRange {
                    line,
                    row: i,
                    col: j,
                    rows,
                    cols,
                });
            }
            let v = value(v, line)?;
            let (i, j) = (i - 1, j - 1);
            entries.push((i, j, v));
            if symmetry != Symmetry::General {
                if i == j && symmetry == Symmetry::SkewSymmetric && v != 0.0 {
                    return Err(E::SkewDiagonal { line, index: i + 1 });
                }
                if i != j {
                    lower |= i > j;
                    upper |= i < j;
                    if lower && upper {
                        return Err(E::BothTriangles { line, symmetry });
                    }
                    entries.push((j, i, mirror * v));
                }
            }
            found += 1;
        }
        if found < nnz {
            return Err(E::TooFewEntries {
                line: last_line,
                expected: nnz,
                found,
            });
        }
        Ok(MarketMatrix::Coordinate {
            rows,
            cols,
            entries,
        })
    } else {
        // File order of the stored entries: column-major, from the first
        // stored row of each column.
        let first_row = move |j: usize| match symmetry {
            Symmetry::General => 0,
            Symmetry::Symmetric => j,
            Symmetry::SkewSymmetric => j + 1,
        };
        // Dense storage: refuse what cannot be allocated rather than abort.
        let too_large = E::TooLarge { line, rows, cols };
        let size = rows.checked_mul(cols).ok_or(too_large)?;
        let mut values = Vec::new();
        if values.try_reserve_exact(size).is_err() {
            return Err(E::TooLarge { line, rows, cols });
        }
        values.resize(size, 0.0);
        let expected = match symmetry {
            Symmetry::General => size,
            // Square here; `size` fits in memory, so `size + rows` does not overflow.
            Symmetry::Symmetric => (size + rows) / 2,
            Symmetry::SkewSymmetric => (size - rows) / 2,
        };
        let mut slots = (0..cols).flat_map(|j| (first_row(j)..rows).map(move |i| (i, j)));
        for (line, entry) in data {
            let (i, j) = slots.next().ok_or(E::TooManyEntries { line, expected })?;
            let mut tokens = entry.split_whitespace();
            let (Some(v), None) = (tokens.next(), tokens.next()) else {
                return Err(E::BadEntry {
                    line,
                    expected: "value",
                });
            };
            let v = value(v, line)?;
            values[j * rows + i] += v;
            if i != j && symmetry != Symmetry::General {
                values[i * rows + j] += mirror * v;
            }
            found += 1;
        }
        if found < expected {
            return Err(E::TooFewEntries {
                line: last_line,
                expected,
                found,
            });
        }
        Ok(MarketMatrix::Array {
            rows,
            cols,
            data: values,
        })
    }
}

/// Parses the header line into (is coordinate, is integer, symmetry).
fn parse_header(line: &str) -> Result<(bool, bool, Symmetry), MatrixMarketError> {
    use MatrixMarketError as E;
    let tokens: Vec<String> = line
        .split_whitespace()
        .map(str::to_ascii_lowercase)
        .collect();
    if tokens.first().is_none_or(|t| t != "%%matrixmarket") {
        return Err(E::MissingHeader { line: 1 });
    }
    let [_, object, format, field, symmetry] = &tokens[..] else {
        return Err(E::BadHeader { line: 1 });
    };
    let unsupported = |kind, value: &String, supported| {
        Err(E::Unsupported {
            line: 1,
            kind,
            value: value.clone(),
            supported,
        })
    };
    if object != "matrix" {
        return unsupported("object", object, "matrix");
    }
    let coordinate = match format.as_str() {
        "coordinate" => true,
        "array" => false,
        _ => return unsupported("format", format, "coordinate, array"),
    };
    let integer = match field.as_str() {
        "real" => false,
        "integer" => true,
        _ => return unsupported("field", field, "real, integer"),
    };
    let symmetry = match symmetry.as_str() {
        "general" => Symmetry::General,
        "symmetric" => Symmetry::Symmetric,
        "skew-symmetric" => Symmetry::SkewSymmetric,
        _ => return unsupported("symmetry", symmetry, "general, symmetric, skew-symmetric"),
    };
    Ok((coordinate, integer, symmetry))
}

/// Exactly three whitespace-separated tokens.
fn three_tokens(s: &str) -> Option<[&str; 3]> {
    let mut t = s.split_whitespace();
    let tokens = [t.next()?, t.next()?, t.next()?];
    t.next().is_none().then_some(tokens)
}

/// A 1-based index token (shared with the tensor term files, which index like this format).
pub(crate) fn parse_index(token: &str, line: usize) -> Result<usize, MatrixMarketError> {
    token.parse().map_err(|_| MatrixMarketError::BadNumber {
        line,
        token: token.to_owned(),
        what: "a 1-based index",
    })
}

/// A value token: integer fields exact, real ones also with a Fortran `D` exponent; never NaN
/// or infinite (shared with the tensor term files, which finite-element codes write alike).
pub(crate) fn parse_value(
    token: &str,
    integer: bool,
    line: usize,
) -> Result<f64, MatrixMarketError> {
    let bad = |what| MatrixMarketError::BadNumber {
        line,
        token: token.to_owned(),
        what,
    };
    let v = if integer {
        token.parse::<i64>().map_err(|_| bad("an integer"))? as f64
    } else {
        // Rust accepts `inf`/`nan`; those are rejected below as non-finite.
        token
            .parse::<f64>()
            .or_else(|_| token.replace(['d', 'D'], "e").parse::<f64>())
            .map_err(|_| bad("a real number"))?
    };
    if !v.is_finite() {
        return Err(MatrixMarketError::NonFinite {
            line,
            token: token.to_owned(),
        });
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use MatrixMarketError as E;

    /// `(rows, cols, row-major entries)` of a matrix (tests only: the reader never densifies
    /// a coordinate file).
    type Dense = (usize, usize, Vec<f64>);

    fn densify(m: &MarketMatrix) -> Dense {
        let (rows, cols) = (m.rows(), m.cols());
        let mut data = vec![0.0; rows * cols];
        match m {
            MarketMatrix::Coordinate { entries, .. } => {
                for &(i, j, v) in entries {
                    data[i * cols + j] += v;
                }
            }
            MarketMatrix::Array { data: d, .. } => {
                for (k, v) in d.iter().enumerate() {
                    data[(k % rows) * cols + k / rows] = *v;
                }
            }
        }
        (rows, cols, data)
    }

    fn parse(text: &str) -> Dense {
        densify(&parse_matrix_market(text).unwrap_or_else(|e| panic!("{e}")))
    }

    fn err(text: &str) -> MatrixMarketError {
        let e = parse_matrix_market(text).expect_err("parse should fail");
        let message = e.to_string();
        assert!(
            !message.contains('\n') && message.starts_with("line "),
            "{message}"
        );
        e
    }

    fn dense(rows: usize, cols: usize, data: &[f64]) -> Dense {
        (rows, cols, data.to_vec())
    }

    #[test]
    fn coordinate_general_with_comments_blank_lines_and_duplicates() {
        let m = parse(
            "%%matrixmarket MATRIX Coordinate Real General\r\n% comment\r\n\r\n2 3 4\r\n\
             1 1 1.5\r\n  % indented comment\r\n2 3 -2e1\r\n\r\n1 1 0.5\r\n1 2 3\r\n",
        );
        assert_eq!(m, dense(2, 3, &[2.0, 3.0, 0.0, 0.0, 0.0, -20.0]));
    }

    #[test]
    fn coordinate_integer_and_fortran_exponent() {
        let m = parse("%%MatrixMarket matrix coordinate integer general\n1 2 2\n1 1 -3\n1 2 +7\n");
        assert_eq!(m, dense(1, 2, &[-3.0, 7.0]));
        let m = parse("%%MatrixMarket matrix coordinate real general\n1 1 1\n1 1 1.5D+03\n");
        assert_eq!(m.2, [1500.0]);
    }

    #[test]
    fn symmetric_coordinate_equals_its_general_expansion() {
        let sym = "%%MatrixMarket matrix coordinate real symmetric\n3 3 5\n\
                   1 1 4\n2 1 -1\n2 2 4\n3 2 -1\n3 3 2\n";
        let general = "%%MatrixMarket matrix coordinate real general\n3 3 7\n\
                       1 1 4\n2 1 -1\n1 2 -1\n2 2 4\n3 2 -1\n2 3 -1\n3 3 2\n";
        assert_eq!(parse(sym), parse(general));
        assert_eq!(
            parse(sym),
            dense(3, 3, &[4.0, -1.0, 0.0, -1.0, 4.0, -1.0, 0.0, -1.0, 2.0])
        );
        // The upper triangle may be listed instead, and duplicates are summed.
        let upper = "%%MatrixMarket matrix coordinate real symmetric\n3 3 6\n\
                     1 1 4\n1 2 -1\n2 2 4\n2 3 -0.5\n2 3 -0.5\n3 3 2\n";
        assert_eq!(parse(upper), parse(general));
        // In the model's sparse storage: the same compressed rows, both triangles stored.
        let sparse = |text: &str| match parse_matrix_market(text).unwrap().into_matrix() {
            Some(Matrix::Sparse(a)) => a,
            other => panic!("{other:?}"),
        };
        let (s, g) = (sparse(sym), sparse(general));
        assert_eq!(s, g);
        assert_eq!(s.pattern().col, [0, 1, 0, 1, 2, 1, 2]);
        assert_eq!(s.values(), [4.0, -1.0, -1.0, 4.0, -1.0, -1.0, 2.0]);
        assert_eq!(sparse(upper), g);
        // An array file stays dense.
        let array = "%%MatrixMarket matrix array real symmetric\n3 3\n4\n-1\n0\n4\n-1\n2\n";
        let m = parse_matrix_market(array).unwrap().into_matrix().unwrap();
        assert!(matches!(m, Matrix::Dense(_)));
        assert_eq!(m.to_dense(), Matrix::Sparse(g).to_dense());
    }

    #[test]
    fn skew_symmetric_coordinate() {
        let m =
            parse("%%MatrixMarket matrix coordinate real skew-symmetric\n2 2 2\n2 1 3\n1 1 0\n");
        assert_eq!(m, dense(2, 2, &[0.0, -3.0, 3.0, 0.0]));
    }

    #[test]
    fn array_general_is_column_major() {
        let m = parse("%%MatrixMarket matrix array real general\n% c\n2 3\n1\n2\n3\n4\n5\n6\n");
        assert_eq!(m, dense(2, 3, &[1.0, 3.0, 5.0, 2.0, 4.0, 6.0]));
    }

    #[test]
    fn array_symmetric_lists_lower_triangle_by_columns() {
        let m = parse("%%MatrixMarket matrix array integer symmetric\n3 3\n1\n2\n3\n4\n5\n6\n");
        assert_eq!(
            m,
            dense(3, 3, &[1.0, 2.0, 3.0, 2.0, 4.0, 5.0, 3.0, 5.0, 6.0])
        );
    }

    #[test]
    fn array_skew_symmetric_lists_strict_lower_triangle() {
        let m = parse("%%MatrixMarket matrix array real skew-symmetric\n3 3\n1\n2\n3\n");
        assert_eq!(
            m,
            dense(3, 3, &[0.0, -1.0, -2.0, 1.0, 0.0, -3.0, 2.0, 3.0, 0.0])
        );
    }

    #[test]
    fn empty_matrices() {
        assert_eq!(
            parse("%%MatrixMarket matrix array real symmetric\n0 0\n"),
            dense(0, 0, &[])
        );
        assert_eq!(
            parse("%%MatrixMarket matrix coordinate real general\n2 0 0\n"),
            dense(2, 0, &[])
        );
    }

    #[test]
    fn header_errors() {
        assert!(matches!(err(""), E::MissingHeader { line: 1 }));
        assert!(matches!(
            err("% no header\n1 1 1\n1 1 1\n"),
            E::MissingHeader { line: 1 }
        ));
        assert!(matches!(
            err("%%MatrixMarket matrix coordinate real\n"),
            E::BadHeader { line: 1 }
        ));
        let unsupported = |text: &str, want: &str| match err(text) {
            E::Unsupported {
                line: 1,
                kind,
                value,
                ..
            } => assert_eq!(format!("{kind} {value}"), want),
            e => panic!("{e}"),
        };
        unsupported(
            "%%MatrixMarket vector coordinate real general\n",
            "object vector",
        );
        unsupported(
            "%%MatrixMarket matrix sparse real general\n",
            "format sparse",
        );
        unsupported(
            "%%MatrixMarket matrix coordinate complex general\n",
            "field complex",
        );
        unsupported(
            "%%MatrixMarket matrix coordinate Pattern general\n",
            "field pattern",
        );
        unsupported(
            "%%MatrixMarket matrix array real hermitian\n",
            "symmetry hermitian",
        );
        assert_eq!(
            err("%%MatrixMarket matrix coordinate complex general\n").to_string(),
            "line 1: unsupported field `complex` (supported: real, integer)"
        );
    }

    #[test]
    fn size_errors() {
        let h = "%%MatrixMarket matrix coordinate real general\n";
        assert!(matches!(
            err(&format!("{h}% only comments\n")),
            E::MissingSize { line: 2 }
        ));
        assert!(matches!(
            err(&format!("{h}2 2\n")),
            E::BadSize { line: 2, .. }
        ));
        assert!(matches!(
            err(&format!("{h}%\n2 -2 1\n")),
            E::BadSize { line: 3, .. }
        ));
        assert!(matches!(
            err("%%MatrixMarket matrix array real general\n2 2 4\n"),
            E::BadSize { line: 2, .. }
        ));
        assert!(matches!(
            err("%%MatrixMarket matrix array real symmetric\n2 3\n"),
            E::NotSquare {
                line: 2,
                rows: 2,
                cols: 3,
                ..
            }
        ));
        // A dense (array) matrix that cannot be allocated is an error, not an abort; a
        // coordinate one of the same size holds only its entries.
        let a = "%%MatrixMarket matrix array real general\n";
        for (rows, cols) in [(usize::MAX / 2, 3), (1 << 40, 1 << 20)] {
            let huge = format!("{a}{rows} {cols}\n");
            assert!(matches!(err(&huge), E::TooLarge { line: 2, .. }));
        }
        let huge = format!("{h}{} {} 1\n{} 3 1.5\n", usize::MAX / 2, 3, usize::MAX / 4);
        let m = parse_matrix_market(&huge).unwrap();
        assert_eq!(m.stored(), 1);
        assert!(m.into_matrix().is_none(), "not square");
    }

    #[test]
    fn entry_count_errors() {
        let h = "%%MatrixMarket matrix coordinate real general\n";
        assert!(matches!(
            err(&format!("{h}2 2 2\n1 1 1\n%\n")),
            E::TooFewEntries {
                line: 4,
                expected: 2,
                found: 1
            }
        ));
        assert!(matches!(
            err(&format!("{h}2 2 1\n1 1 1\n2 2 1\n")),
            E::TooManyEntries {
                line: 4,
                expected: 1
            }
        ));
        let a = "%%MatrixMarket matrix array real symmetric\n2 2\n";
        assert!(matches!(
            err(&format!("{a}1\n2\n")),
            E::TooFewEntries {
                expected: 3,
                found: 2,
                ..
            }
        ));
        assert!(matches!(
            err(&format!("{a}1\n2\n3\n4\n")),
            E::TooManyEntries {
                line: 6,
                expected: 3
            }
        ));
        assert_eq!(
            err(&format!("{h}2 2 2\n1 1 1\n")).to_string(),
            "line 3: file ends after 1 of the 2 entries declared"
        );
    }

    #[test]
    fn entry_errors() {
        let h = "%%MatrixMarket matrix coordinate real general\n2 2 1\n";
        assert!(matches!(
            err(&format!("{h}1 1\n")),
            E::BadEntry { line: 3, .. }
        ));
        assert!(matches!(
            err(&format!("{h}1 1 1 1\n")),
            E::BadEntry { line: 3, .. }
        ));
        assert!(matches!(
            err("%%MatrixMarket matrix array real general\n1 1\n1 2\n"),
            E::BadEntry { line: 3, .. }
        ));
        for (entry, row, col) in [("0 1", 0, 1), ("3 1", 3, 1), ("1 3", 1, 3)] {
            let e = err(&format!("{h}{entry} 1.0\n"));
            assert!(
                matches!(e, E::IndexOutOfRange { line: 3, rows: 2, cols: 2, row: r, col: c }
                if (r, c) == (row, col)),
                "{e}"
            );
        }
        assert_eq!(
            err(&format!("{h}3 1 1.0\n")).to_string(),
            "line 3: index (3, 1) out of range for 2x2 matrix (indices are 1-based)"
        );
        assert!(matches!(
            err(&format!("{h}-1 1 1\n")),
            E::BadNumber { line: 3, .. }
        ));
        assert!(matches!(
            err(&format!("{h}1 1 1.0x\n")),
            E::BadNumber { line: 3, .. }
        ));
        assert_eq!(
            err(&format!("{h}1 1 abc\n")).to_string(),
            "line 3: cannot parse `abc` as a real number"
        );
        let int = "%%MatrixMarket matrix coordinate integer general\n1 1 1\n1 1 1.5\n";
        assert!(matches!(
            err(int),
            E::BadNumber {
                line: 3,
                what: "an integer",
                ..
            }
        ));
        for value in ["NaN", "inf", "-Infinity", "1e400"] {
            let e = err(&format!("{h}1 1 {value}\n"));
            assert!(
                matches!(e, E::NonFinite { line: 3, ref token } if token == value),
                "{e}"
            );
        }
    }

    #[test]
    fn symmetric_storage_errors() {
        let skew = "%%MatrixMarket matrix coordinate real skew-symmetric\n2 2 1\n2 2 1\n";
        assert!(matches!(err(skew), E::SkewDiagonal { line: 3, index: 2 }));
        let both = "%%MatrixMarket matrix coordinate real symmetric\n2 2 2\n2 1 1\n1 2 1\n";
        assert!(matches!(
            err(both),
            E::BothTriangles {
                line: 4,
                symmetry: Symmetry::Symmetric
            }
        ));
    }

    /// A written matrix reads back bit for bit: sparse with an explicit zero and values that
    /// need all 17 digits, dense without its zeros.
    #[test]
    fn written_coordinate_files_read_back_exactly() {
        let values = [0.1 + 0.2, -1.0 / 3.0, 0.0, 6.02e23, -5e-300];
        let triplets: Vec<(usize, usize, f64)> = [(0, 0), (0, 2), (1, 1), (2, 0), (2, 2)]
            .iter()
            .zip(values)
            .map(|(&(i, j), v)| (i, j, v))
            .collect();
        let sparse = Matrix::Sparse(SparseMatrix::from_triplets(3, &triplets).unwrap());
        let text = format_coordinate(&sparse, &["a comment".into()]);
        assert!(
            text.starts_with("%%MatrixMarket matrix coordinate real general\n% a comment\n3 3 5\n")
        );
        let back = parse_matrix_market(&text).unwrap().into_matrix().unwrap();
        assert_eq!(back, sparse);
        let dense = Matrix::from_fn(2, 2, |i, j| if i == j { 1.5 } else { 0.0 });
        let text = format_coordinate(&dense, &[]);
        assert_eq!(
            text,
            "%%MatrixMarket matrix coordinate real general\n2 2 2\n1 1 1.5e0\n2 2 1.5e0\n"
        );
        let back = parse_matrix_market(&text).unwrap().into_matrix().unwrap();
        assert_eq!(back.to_dense(), dense.to_dense());
    }

    #[test]
    fn read_from_file_and_io_errors() {
        let dir = std::env::temp_dir().join(format!("nnm-io-mm-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("K.mtx");
        std::fs::write(
            &good,
            "%%MatrixMarket matrix array real general\n1 1\n2.5\n",
        )
        .unwrap();
        assert_eq!(
            densify(&read_matrix_market(&good).unwrap()),
            dense(1, 1, &[2.5])
        );

        let bad = dir.join("M.mtx");
        std::fs::write(&bad, "%%MatrixMarket matrix array real general\n1 1\nx\n").unwrap();
        let e = read_matrix_market(&bad).unwrap_err();
        assert!(
            matches!(&e, E::InFile { error, .. } if matches!(**error, E::BadNumber { line: 3, .. }))
        );
        assert_eq!(
            e.to_string(),
            format!(
                "{}: line 3: cannot parse `x` as a real number",
                bad.display()
            )
        );
        std::fs::remove_dir_all(&dir).unwrap();

        let e = read_matrix_market(Path::new("M.mtx")).unwrap_err();
        assert!(matches!(&e, E::Io { error, .. } if error.kind() == std::io::ErrorKind::NotFound));
        assert_eq!(
            e.to_string(),
            "cannot read M.mtx: No such file or directory"
        );
    }
}
