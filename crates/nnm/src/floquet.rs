//! Floquet multipliers and stability of a periodic motion (SPEC §2).
//!
//! The multipliers are the eigenvalues of the monodromy matrix `Φ(T)`. Every periodic orbit of
//! an autonomous conservative system has two at `+1` (the flow direction and the neighbouring
//! orbit of the family, forming a Jordan block); they carry no stability information and are
//! excluded. Because of that Jordan block they are computed only to about the square root of
//! the integration accuracy, which is why the stability tolerance below is not smaller.

use crate::linalg::{self, Complex, LinalgError, Mat};

/// Default tolerance on `|μ| - 1` for calling a motion stable. Numerical multipliers of a
/// stable orbit sit on the unit circle to ~1e-8 at the default integration accuracy (simple
/// ones) and ~1e-5 (near-double ones, e.g. a degenerate partner pair near +1); genuine
/// instabilities worth reporting grow faster than 1e-4 per period.
pub const DEFAULT_STABILITY_TOLERANCE: f64 = 1e-4;

/// Multipliers of one periodic motion.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Floquet {
    /// All multipliers `(re, im)`: the non-trivial ones by decreasing modulus, then the two
    /// trivial ones.
    pub multipliers: Vec<Complex>,
    /// Indices (into `multipliers`) of the two trivial ones (at `+1`).
    pub trivial: [usize; 2],
    /// Largest modulus among the non-trivial multipliers (1 when there are none).
    pub max_modulus: f64,
    /// `max_modulus ≤ 1 + tolerance`.
    pub stable: bool,
    /// Accuracy estimate: multipliers of a conservative system come in pairs `(μ, 1/μ)`, so
    /// the sorted moduli satisfy `ρ_k ρ_{N-1-k} = 1`; this is the largest deviation.
    pub reciprocity_defect: f64,
}

/// Multipliers and stability from a monodromy matrix, the trivial pair identified as the two
/// multipliers closest to `+1`. Prefer [`analyse_deflated`] when the flow direction and the
/// direction along the family are known: near-`+1` multipliers of a degenerate partner make
/// the "closest to +1" rule pick the wrong pair.
pub fn analyse(monodromy: &Mat<f64>, tolerance: f64) -> Result<Floquet, LinalgError> {
    let all = linalg::eigenvalues(monodromy.as_ref())?;
    let distance_to_one = |z: &Complex| (z.0 - 1.0).hypot(z.1);
    let mut order: Vec<usize> = (0..all.len()).collect();
    order.sort_by(|&a, &b| distance_to_one(&all[a]).total_cmp(&distance_to_one(&all[b])));
    let trivial: Vec<Complex> = order.iter().take(2).map(|&k| all[k]).collect();
    let rest: Vec<Complex> = order.iter().skip(2).map(|&k| all[k]).collect();
    Ok(assemble(rest, trivial, tolerance))
}

/// Multipliers with the trivial pair removed by deflation. `directions` are two vectors that
/// span the invariant subspace of the trivial pair — the flow direction `g(z0)` (`Φ g = g`)
/// and the direction along the family (`Φ w = w + c g`), in the monodromy's coordinates. With
/// `Q = [Q₁ Q₂]` orthonormal and `Q₁` spanning them, `QᵀΦQ` is block upper triangular; the
/// eigenvalues of its lower-right block are exactly the non-trivial multipliers.
pub fn analyse_deflated(
    monodromy: &Mat<f64>,
    directions: [&[f64]; 2],
    tolerance: f64,
) -> Result<Floquet, LinalgError> {
    let n = monodromy.nrows();
    // Orthonormal basis: Gram–Schmidt (twice, for round-off) of the two directions, then of
    // the unit vectors, keeping the n best-conditioned.
    let mut basis: Vec<Vec<f64>> = Vec::with_capacity(n);
    let add = |v: &[f64], basis: &mut Vec<Vec<f64>>| {
        let mut w = v.to_vec();
        for _ in 0..2 {
            for b in basis.iter() {
                let c = linalg::dot(b, &w);
                w.iter_mut().zip(b).for_each(|(x, y)| *x -= c * y);
            }
        }
        let norm = linalg::norm(&w);
        if norm > 1e-8 * linalg::norm(v).max(f64::MIN_POSITIVE) {
            w.iter_mut().for_each(|x| *x /= norm);
            basis.push(w);
            true
        } else {
            false
        }
    };
    let independent = directions.iter().filter(|d| add(d, &mut basis)).count();
    if independent < 2 {
        return analyse(monodromy, tolerance);
    }
    for k in 0..n {
        if basis.len() == n {
            break;
        }
        let mut e = vec![0.0; n];
        e[k] = 1.0;
        add(&e, &mut basis);
    }
    let q = Mat::from_fn(n, n, |i, j| basis[j][i]);
    let projected = linalg::product(
        q.transpose(),
        linalg::product(monodromy.as_ref(), q.as_ref()).as_ref(),
    );
    let block =
        |lo: usize, size: usize| Mat::from_fn(size, size, |i, j| projected[(lo + i, lo + j)]);
    let rest = linalg::eigenvalues(block(2, n - 2).as_ref())?;
    let trivial = linalg::eigenvalues(block(0, 2).as_ref())?;
    Ok(assemble(rest, trivial, tolerance))
}

fn assemble(mut rest: Vec<Complex>, trivial: Vec<Complex>, tolerance: f64) -> Floquet {
    let modulus = |z: &Complex| z.0.hypot(z.1);
    rest.sort_by(|a, b| modulus(b).total_cmp(&modulus(a)));
    let max_modulus = rest.first().map_or(1.0, modulus);
    let count = rest.len();
    let reciprocity_defect = (0..count / 2)
        .map(|k| (modulus(&rest[k]) * modulus(&rest[count - 1 - k]) - 1.0).abs())
        .fold(0.0, f64::max);
    let mut multipliers = rest;
    multipliers.extend(trivial);
    let trivial = [count, (count + 1).min(multipliers.len().saturating_sub(1))];
    Floquet {
        stable: max_modulus <= 1.0 + tolerance,
        multipliers,
        trivial,
        max_modulus,
        reciprocity_defect,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trivial_pair_is_excluded_and_instability_detected() {
        // Block diagonal: Jordan block at +1, a rotation (stable pair), a saddle (2, 1/2).
        let mut m = Mat::<f64>::zeros(6, 6);
        m[(0, 0)] = 1.0;
        m[(0, 1)] = 3.0;
        m[(1, 1)] = 1.0;
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        m[(2, 2)] = c;
        m[(2, 3)] = -s;
        m[(3, 2)] = s;
        m[(3, 3)] = c;
        m[(4, 4)] = 2.0;
        m[(5, 5)] = 0.5;
        let f = analyse(&m, DEFAULT_STABILITY_TOLERANCE).unwrap();
        assert_eq!(f.multipliers.len(), 6);
        assert!((f.max_modulus - 2.0).abs() < 1e-12);
        assert!(!f.stable);
        for k in f.trivial {
            assert!((f.multipliers[k].0 - 1.0).abs() < 1e-12);
        }
        m[(4, 4)] = c;
        m[(4, 5)] = s;
        m[(5, 4)] = -s;
        m[(5, 5)] = c;
        let f = analyse(&m, DEFAULT_STABILITY_TOLERANCE).unwrap();
        assert!(f.stable && (f.max_modulus - 1.0).abs() < 1e-12);
    }

    /// A degenerate partner pair closer to +1 than the numerically split trivial pair: the
    /// "closest to +1" rule mistakes it for the trivial pair and reports the wrong multiplier;
    /// deflation along the known directions does not.
    #[test]
    fn deflation_keeps_a_partner_pair_near_one() {
        let mut m = Mat::<f64>::zeros(4, 4);
        // Trivial Jordan block, perturbed as integration error does: eigenvalues 1 ± 1e-4.
        m[(0, 0)] = 1.0;
        m[(0, 1)] = 1.0;
        m[(1, 0)] = 1e-8;
        m[(1, 1)] = 1.0;
        // Partner pair (1 + 1e-5, 1/(1 + 1e-5)): slightly unstable.
        m[(2, 2)] = 1.0 + 1e-5;
        m[(3, 3)] = 1.0 / (1.0 + 1e-5);
        let naive = analyse(&m, 1e-6).unwrap();
        // Fooled: it reports the split trivial pair (1 + 1e-4) as the largest multiplier.
        assert!(
            (naive.max_modulus - (1.0 + 1e-4)).abs() < 1e-6,
            "{}",
            naive.max_modulus
        );
        let (e0, e1) = ([1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]);
        let f = analyse_deflated(&m, [&e0, &e1], 1e-6).unwrap();
        assert!(!f.stable);
        assert!((f.max_modulus - (1.0 + 1e-5)).abs() < 1e-12);
        assert!(f.reciprocity_defect < 1e-12);
        for k in f.trivial {
            assert!((f.multipliers[k].0 - 1.0).abs() < 2e-4);
        }
    }
}
