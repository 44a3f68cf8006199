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
    /// All multipliers `(re, im)`, sorted by decreasing modulus.
    pub multipliers: Vec<Complex>,
    /// Indices (into `multipliers`) of the two trivial ones, those closest to `+1`.
    pub trivial: [usize; 2],
    /// Largest modulus among the non-trivial multipliers (1 when there are none).
    pub max_modulus: f64,
    /// `max_modulus ≤ 1 + tolerance`.
    pub stable: bool,
}

/// Multipliers and stability from a monodromy matrix.
pub fn analyse(monodromy: &Mat<f64>, tolerance: f64) -> Result<Floquet, LinalgError> {
    let mut multipliers = linalg::eigenvalues(monodromy.as_ref())?;
    let modulus = |z: &Complex| z.0.hypot(z.1);
    multipliers.sort_by(|a, b| modulus(b).total_cmp(&modulus(a)));
    let distance_to_one = |k: usize| {
        let (re, im) = multipliers[k];
        (re - 1.0).hypot(im)
    };
    let mut order: Vec<usize> = (0..multipliers.len()).collect();
    order.sort_by(|&a, &b| distance_to_one(a).total_cmp(&distance_to_one(b)));
    let trivial = [order[0], order.get(1).copied().unwrap_or(order[0])];
    let max_modulus = (0..multipliers.len())
        .filter(|k| !trivial.contains(k))
        .map(|k| modulus(&multipliers[k]))
        .reduce(f64::max)
        .unwrap_or(1.0);
    Ok(Floquet {
        stable: max_modulus <= 1.0 + tolerance,
        multipliers,
        trivial,
        max_modulus,
    })
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
}
