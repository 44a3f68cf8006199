//! Shooting over a fraction of the period with a spatio-temporal symmetry of the motion
//! (docs/method.md §17, eqs. (80)–(83)).
//!
//! A motion with `z(t + T/q) = P z(t)` for a signed permutation `P` of the dofs that the
//! equations of motion commute with is determined by one `q`-th of its period: the shooting
//! equations become `z(T/q) − P z0 = 0`, the integration is `q` times shorter, and the
//! monodromy is `Φ(T) = (P⁻¹ Φ(T/q))^q`. Three cases are built here:
//! - an odd system's half-wave-symmetric motions, `z(T/2) = −z0` (`q = 2`, `P = −I`);
//! - a system with a parity `S` (a sign per dof, `f(S x) = S f(x)`, `S M = M S`) and a
//!   motion odd in the flipped dofs: `z(T/2) = S z0` (`q = 2`, `P = S`, eq. (9b)) — a von
//!   Kármán beam's transverse dofs flip while its axial ones, driven at twice the frequency,
//!   repeat;
//! - a travelling wave of a cyclic structure, whose pattern turns by `g = gcd(d, N)` sectors'
//!   worth of phase every `T/q`, `q = N/g`: `z(T/q) = R^s z0`, `R` the sector shift.

use crate::model::CyclicSymmetry;

/// `z(T/q) = P z0`, with `P` a signed permutation applied to displacements and velocities
/// alike: `(P x)_i = sign · x_{source_i}`.
#[derive(Debug, Clone, PartialEq)]
pub struct ShiftSymmetry {
    /// `q`: the motion is shot over `T/q`.
    pub divisions: usize,
    /// `source_i` of `(P x)_i = sign · x_{source_i}`; empty for the identity.
    pub source: Vec<usize>,
    /// `±1`.
    pub sign: f64,
    /// A sign per dof multiplying `sign` (a parity, [`ShiftSymmetry::parity`]); empty: all `+1`.
    pub dof_signs: Vec<f64>,
}

/// Which way a travelling wave's pattern turns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Travel {
    /// `x(t) ≈ a (φ_cos cos ωt + φ_sin sin ωt)`: from the cos pattern towards the sin one.
    #[serde(rename = "travelling")]
    Forward,
    /// `x(t) ≈ a (φ_cos cos ωt − φ_sin sin ωt)`.
    #[serde(rename = "travelling-backward")]
    Backward,
}

impl Travel {
    /// `+1` forward, `−1` backward: the sign of the sin member's velocity at `t = 0`.
    pub fn sign(self) -> f64 {
        match self {
            Travel::Forward => 1.0,
            Travel::Backward => -1.0,
        }
    }

    /// The name used in job files and outputs (`travelling`, `travelling-backward`).
    pub fn name(self) -> &'static str {
        match self {
            Travel::Forward => "travelling",
            Travel::Backward => "travelling-backward",
        }
    }
}

impl ShiftSymmetry {
    /// `z(T/2) = −z0`: the half-wave symmetry of an odd system's motions.
    pub fn half_wave() -> Self {
        Self {
            divisions: 2,
            source: Vec::new(),
            sign: -1.0,
            dof_signs: Vec::new(),
        }
    }

    /// `z(T/2) = S z0` for a parity `S = diag(dof_signs)` (eq. (9b)).
    pub fn parity(dof_signs: Vec<f64>) -> Self {
        Self {
            divisions: 2,
            source: Vec::new(),
            sign: 1.0,
            dof_signs,
        }
    }

    /// Whether this is [`ShiftSymmetry::half_wave`].
    pub fn is_half_wave(&self) -> bool {
        self.divisions == 2
            && self.source.is_empty()
            && self.sign < 0.0
            && self.dof_signs.is_empty()
    }

    /// `P`'s diagonal over a state `[x; v]` of `2n` entries when `P` is a diagonal involution
    /// (the half-wave symmetry or a parity); `None` for a sector shift.
    pub fn diagonal(&self, n: usize) -> Option<Vec<f64>> {
        (self.divisions == 2 && self.source.is_empty())
            .then(|| (0..2 * n).map(|i| self.sign_of(i % n)).collect())
    }

    /// The sign `P` gives dof `j`.
    fn sign_of(&self, j: usize) -> f64 {
        self.sign * self.dof_signs.get(j).copied().unwrap_or(1.0)
    }

    /// The travelling wave with `d` nodal diameters of a structure of `N` sectors (sector-major
    /// dofs): with `g = gcd(d, N)`, the pattern `cos(ωt ∓ 2π d k / N)` at `t + T/q`, `q = N/g`,
    /// is the pattern at `t` moved by `s` sectors, `d s ≡ ∓g (mod N)` (eq. (81)). Which `s` the
    /// standing waves' sign conventions make the forward one is decided by `matches`, given
    /// the sector shift `s` to test: the caller checks it against the linear travelling wave.
    /// `None` when no shift works (`d = 0` or `N/2`: no travelling wave; or no `s` with
    /// `P^q = I`).
    pub fn travelling_wave(
        cyclic: CyclicSymmetry,
        diameters: usize,
        mut matches: impl FnMut(&ShiftSymmetry) -> bool,
    ) -> Option<Self> {
        let (sectors, p) = (cyclic.sectors, cyclic.dofs_per_sector);
        if diameters == 0 || 2 * diameters >= sectors {
            return None;
        }
        let g = gcd(diameters, sectors);
        let divisions = sectors / g;
        // P^q must be the identity for Φ(T) = (P⁻¹ Φ(T/q))^q: s q ≡ 0 (mod N), i.e. g | s
        // (there is such an s for N = 30 and every d; not for, e.g., N = 8, d = 2).
        (1..sectors)
            .filter(|s| (diameters * s) % sectors == g || (diameters * s) % sectors == sectors - g)
            .filter(|s| (s * divisions) % sectors == 0)
            .map(|s| Self {
                divisions,
                // (P x) in sector k is x in sector k + s.
                source: (0..sectors * p)
                    .map(|i| ((i / p + s) % sectors) * p + i % p)
                    .collect(),
                sign: 1.0,
                dof_signs: Vec::new(),
            })
            .find(|shift| matches(shift))
    }

    /// `P z` for a state `z = [x; v]` (length `2n`).
    pub fn apply(&self, z: &[f64]) -> Vec<f64> {
        let n = z.len() / 2;
        (0..z.len())
            .map(|i| {
                let (half, j) = (i / n, i % n);
                let from = self.source.get(j).copied().unwrap_or(j);
                self.sign_of(from) * z[half * n + from]
            })
            .collect()
    }

    /// `P⁻¹ z`.
    pub fn apply_inverse(&self, z: &[f64]) -> Vec<f64> {
        let n = z.len() / 2;
        let mut out = vec![0.0; z.len()];
        for (i, value) in z.iter().enumerate() {
            let (half, j) = (i / n, i % n);
            let from = self.source.get(j).copied().unwrap_or(j);
            out[half * n + from] = self.sign_of(from) * value;
        }
        out
    }
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sector_shift_and_its_inverse() {
        let cyclic = CyclicSymmetry {
            sectors: 5,
            dofs_per_sector: 2,
        };
        let shift = ShiftSymmetry::travelling_wave(cyclic, 2, |_| true).unwrap();
        // d = 2, N = 5: g = 1, q = 5, 2 s ≡ ±1 (mod 5): s = 2 (4 ≡ −1) or 3 (6 ≡ 1).
        assert_eq!(shift.divisions, 5);
        let z: Vec<f64> = (0..20).map(|i| i as f64).collect();
        let pz = shift.apply(&z);
        // Sector 0 of P x is sector s of x, dof by dof, in both halves.
        let s = shift.source[0] / 2;
        assert!(s == 2 || s == 3);
        assert_eq!(pz[0], z[2 * s]);
        assert_eq!(pz[10 + 1], z[10 + 2 * s + 1]);
        assert_eq!(shift.apply_inverse(&pz), z);
        // q applications of P: the identity when s q ≡ 0 (mod N).
        let mut w = z.clone();
        for _ in 0..shift.divisions {
            w = shift.apply(&w);
        }
        assert_eq!(w, z);
        // No travelling wave for d = 0.
        assert!(ShiftSymmetry::travelling_wave(cyclic, 0, |_| true).is_none());
    }

    #[test]
    fn half_wave_is_minus_the_identity() {
        let shift = ShiftSymmetry::half_wave();
        assert!(shift.is_half_wave());
        assert_eq!(shift.apply(&[1.0, -2.0]), vec![-1.0, 2.0]);
        assert_eq!(shift.apply_inverse(&[1.0, -2.0]), vec![-1.0, 2.0]);
        assert_eq!(shift.diagonal(1), Some(vec![-1.0, -1.0]));
    }

    #[test]
    fn parity_flips_its_dofs_in_both_halves_and_is_its_own_inverse() {
        let shift = ShiftSymmetry::parity(vec![-1.0, 1.0, -1.0]);
        assert!(!shift.is_half_wave());
        let z = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let pz = shift.apply(&z);
        assert_eq!(pz, vec![-1.0, 2.0, -3.0, -4.0, 5.0, -6.0]);
        assert_eq!(shift.apply_inverse(&pz), z.to_vec());
        assert_eq!(shift.apply(&pz), z.to_vec());
        assert_eq!(
            shift.diagonal(3),
            Some(vec![-1.0, 1.0, -1.0, -1.0, 1.0, -1.0])
        );
    }
}
