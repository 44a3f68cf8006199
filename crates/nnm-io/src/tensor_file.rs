//! Text files of polynomial force terms (the `tensor` element of job files,
//! docs/job-files.md "Finite-element models"; docs/method.md eq. (57)).
//!
//! One term per line: `i j k c` (quadratic, `f_i += c x_j x_k`) or `i j k l c` (cubic,
//! `f_i += c x_j x_k x_l`), indices 1-based like Matrix Market files, whitespace-separated.
//! Lines whose first non-blank character is `%` are comments; blank lines are skipped. Values
//! are read as in Matrix Market real files (a Fortran `D` exponent is accepted; NaN and
//! infinities are not).

use std::path::Path;

use crate::error::io_reason;
use crate::matrix_market::{parse_index, parse_value};

/// The terms `(i, [t_1 … t_N], c)` of a file of `N + 2` columns, 0-based, checked against a
/// model of `dofs` dofs. Errors are one line: `line L: ...` (the caller names the file).
pub fn read_terms<const N: usize>(
    path: &Path,
    dofs: usize,
) -> Result<Vec<(usize, [usize; N], f64)>, String> {
    let text =
        std::fs::read_to_string(path).map_err(|e| format!("cannot read: {}", io_reason(&e)))?;
    parse_terms(&text, dofs)
}

/// [`read_terms`] on the file's text.
pub fn parse_terms<const N: usize>(
    text: &str,
    dofs: usize,
) -> Result<Vec<(usize, [usize; N], f64)>, String> {
    let layout = if N == 2 { "i j k c" } else { "i j k l c" };
    let mut terms = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let number = k + 1;
        let trimmed = line.trim_start();
        if trimmed.is_empty() || trimmed.starts_with('%') {
            continue;
        }
        let tokens: Vec<&str> = line.split_whitespace().collect();
        if tokens.len() != N + 2 {
            return Err(format!(
                "line {number}: expected `{layout}` ({} numbers), found {}",
                N + 2,
                tokens.len()
            ));
        }
        // `i` then the N trailing indices (N ≤ 3).
        let mut index = [0; 4];
        for (slot, token) in index.iter_mut().zip(&tokens[..=N]) {
            let d = parse_index(token, number).map_err(|e| e.to_string())?;
            if d == 0 || d > dofs {
                return Err(format!(
                    "line {number}: index {d} out of range for a model of {dofs} dofs (indices are 1-based)"
                ));
            }
            *slot = d - 1;
        }
        let c = parse_value(tokens[N + 1], false, number).map_err(|e| e.to_string())?;
        let mut trailing = [0; N];
        trailing.copy_from_slice(&index[1..=N]);
        terms.push((index[0], trailing, c));
    }
    // An empty file is a mistake (a wrong or truncated file), not a request for no force.
    if terms.is_empty() {
        return Err(format!(
            "no terms: expected one `{layout}` per line (1-based indices, lines starting with % are comments)"
        ));
    }
    Ok(terms)
}

/// The text of a term file of `N + 2` columns for `terms` (0-based in, 1-based out),
/// `comments` as `%` lines first. Coefficients are written in the shortest form that reads
/// back to the same `f64`, so [`parse_terms`] gives the terms bit for bit (`nnm export`).
pub fn format_terms<const N: usize>(
    terms: &[(usize, [usize; N], f64)],
    comments: &[String],
) -> String {
    use std::fmt::Write;
    let mut text = String::new();
    for c in comments {
        let _ = writeln!(text, "% {c}");
    }
    for (i, t, c) in terms {
        let _ = write!(text, "{}", i + 1);
        for d in t {
            let _ = write!(text, " {}", d + 1);
        }
        let _ = writeln!(text, " {c:e}");
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_terms_read_back_exactly() {
        let quadratic = vec![(0, [1, 2], 0.1 + 0.2), (2, [0, 0], -7e-310)];
        let text = format_terms(&quadratic, &["f_i += c x_j x_k".into()]);
        assert_eq!(text.lines().next(), Some("% f_i += c x_j x_k"));
        assert_eq!(text.lines().nth(1), Some("1 2 3 3.0000000000000004e-1"));
        assert_eq!(parse_terms::<2>(&text, 3).unwrap(), quadratic);
        let cubic = vec![(1, [0, 1, 1], 2.5e14)];
        assert_eq!(
            parse_terms::<3>(&format_terms(&cubic, &[]), 2).unwrap(),
            cubic
        );
    }

    #[test]
    fn terms_with_comments_and_blank_lines() {
        let text = "% f_i += c x_j x_k\n\n  % indented\n1 2 3 0.5\r\n3 3 3 -2D+00\n";
        let terms = parse_terms::<2>(text, 3).unwrap();
        assert_eq!(terms, vec![(0, [1, 2], 0.5), (2, [2, 2], -2.0)]);
        let terms = parse_terms::<3>("2 1 1 1 4e-3\n", 2).unwrap();
        assert_eq!(terms, vec![(1, [0, 0, 0], 4e-3)]);
    }

    #[test]
    fn errors_name_the_line() {
        let cases: [(&str, &str); 6] = [
            ("1 2 3\n", "line 1: expected `i j k c` (4 numbers), found 3"),
            (
                "%\n1 2 3 4 5\n",
                "line 2: expected `i j k c` (4 numbers), found 5",
            ),
            (
                "\n\n1 4 1 1.0\n",
                "line 3: index 4 out of range for a model of 3 dofs",
            ),
            ("0 1 1 1.0\n", "line 1: index 0 out of range"),
            ("1 1 x 1.0\n", "line 1: cannot parse `x` as a 1-based index"),
            ("1 1 1 nan\n", "line 1: value `nan` is not finite"),
        ];
        for (text, expected) in cases {
            let e = parse_terms::<2>(text, 3).unwrap_err();
            assert!(e.starts_with(expected), "{text:?}: {e}");
            assert!(!e.contains('\n'));
        }
        for text in ["", "\n\n", "% only a comment\n  \n"] {
            let e = parse_terms::<3>(text, 3).unwrap_err();
            assert_eq!(
                e,
                "no terms: expected one `i j k l c` per line (1-based indices, lines starting with % are comments)"
            );
        }
        let e = read_terms::<3>(Path::new("/nonexistent/f3.txt"), 3).unwrap_err();
        assert_eq!(e, "cannot read: No such file or directory");
    }
}
