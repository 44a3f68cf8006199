//! The catalogue of nonlinear elements.

use super::{Block, BlockMut, FixedDofs, NonlinearElement, PolynomialTerms};

/// A polynomial spring `f = c (x_i - x_j)^p` acting on dof `i`, with the opposite force on
/// dof `j` (or tied to ground when `j` is `None`). `p = 3` is the cubic spring of the paper;
/// any `p ≥ 2` works (even `p` gives an asymmetric, softening-on-one-side law).
///
/// Potential `V = c d^{p+1} / (p+1)` with `d = x_i - x_j`; tangent `k_t = p c d^{p-1}`.
#[derive(Debug, Clone, PartialEq)]
pub struct PolynomialSpring {
    /// Dof the force acts on (0-based).
    pub i: usize,
    /// Dof at the other end, which takes the opposite force; `None`: tied to ground.
    pub j: Option<usize>,
    /// `c` in `f = c (x_i - x_j)^p`.
    pub coefficient: f64,
    /// `p` (3 for the paper's cubic spring).
    pub exponent: u32,
}

impl PolynomialSpring {
    /// The spring `f = c (x_i - x_j)^p` between dofs `i` and `j` (ground when `None`;
    /// docs/method.md eq. (5)).
    pub fn new(i: usize, j: Option<usize>, coefficient: f64, exponent: u32) -> Self {
        Self {
            i,
            j,
            coefficient,
            exponent,
        }
    }

    /// The paper's cubic spring.
    pub fn cubic(i: usize, j: Option<usize>, coefficient: f64) -> Self {
        Self::new(i, j, coefficient, 3)
    }

    /// The same spring on the model with `fixed`'s dofs held at zero and removed
    /// (docs/method.md eq. (61)), in the reduced numbering; `None` when both ends are fixed
    /// (it never stretches). A spring with one fixed end ties the other to ground: with `x_i`
    /// fixed, `f_j = −c (−x_j)ᵖ = (−1)^(p+1) c x_jᵖ`.
    pub fn reduced(&self, fixed: &FixedDofs) -> Option<Self> {
        let i = fixed.reduced_index(self.i);
        let j = self.j.map(|j| fixed.reduced_index(j));
        let (i, j, coefficient) = match (i, j) {
            (Some(i), None | Some(None)) => (i, None, self.coefficient),
            (Some(i), Some(Some(j))) => (i, Some(j), self.coefficient),
            (None, Some(Some(j))) => {
                let sign = if self.exponent % 2 == 1 { 1.0 } else { -1.0 };
                (j, None, sign * self.coefficient)
            }
            (None, None | Some(None)) => return None,
        };
        Some(Self::new(i, j, coefficient, self.exponent))
    }

    fn stretch(&self, x: &[f64]) -> f64 {
        x[self.i] - self.j.map_or(0.0, |j| x[j])
    }

    /// `c (x_i − x_j)^N` expanded into monomials (eq. (5)): one product per choice of a
    /// term of each of the `N` factors `(x_i − x_j)`, `(i, +1)` or `(j, −1)`, its coefficient
    /// `c` times the signs chosen. The same monomial comes several times (`x_i² x_j` three
    /// times for `N = 3`); [`PolynomialTerms::summed`] adds them up.
    fn expanded<const N: usize>(&self) -> Vec<([usize; N], f64)> {
        let ends: Vec<(usize, f64)> = std::iter::once((self.i, 1.0))
            .chain(self.j.map(|j| (j, -1.0)))
            .collect();
        let choices = ends.len().pow(N as u32);
        (0..choices)
            .map(|mut choice| {
                let mut t = [0; N];
                let mut c = self.coefficient;
                for slot in t.iter_mut() {
                    let (dof, sign) = ends[choice % ends.len()];
                    choice /= ends.len();
                    *slot = dof;
                    c *= sign;
                }
                (t, c)
            })
            .collect()
    }
}

/// `d^p`, bitwise equal to `d.powi(p)` (the same product by squaring), with the small
/// exponents of the force (3) and tangent (2) inlined instead of a libcall
/// (`__powidf2` on a run-time exponent was ~2% of a tongue's instructions).
#[inline]
fn power(d: f64, p: i32) -> f64 {
    match p {
        0 => 1.0,
        1 => d,
        2 => d * d,
        3 => d * (d * d),
        _ => d.powi(p),
    }
}

impl NonlinearElement for PolynomialSpring {
    fn add_force(&self, x: &[f64], f: &mut [f64]) {
        let force = self.coefficient * power(self.stretch(x), self.exponent as i32);
        f[self.i] += force;
        if let Some(j) = self.j {
            f[j] -= force;
        }
    }

    fn add_tangent_product(&self, x: &[f64], dx: Block<'_>, out: &mut BlockMut<'_>) {
        let p = self.exponent as i32;
        let kt = self.coefficient * p as f64 * power(self.stretch(x), p - 1);
        for c in 0..dx.cols {
            let col = dx.col(c);
            let d = col[self.i] - self.j.map_or(0.0, |j| col[j]);
            let o = out.col_mut(c);
            o[self.i] += kt * d;
            if let Some(j) = self.j {
                o[j] -= kt * d;
            }
        }
    }

    fn tangent_matrix(&self, x: &[f64], out: &mut [f64]) -> bool {
        let p = self.exponent as i32;
        let kt = self.coefficient * p as f64 * power(self.stretch(x), p - 1);
        match self.j {
            None => out[0] = kt,
            Some(_) => out[..4].copy_from_slice(&[kt, -kt, -kt, kt]),
        }
        true
    }

    fn potential(&self, x: &[f64]) -> f64 {
        let p = self.exponent as i32;
        self.coefficient * power(self.stretch(x), p + 1) / (p + 1) as f64
    }

    /// The force `c dᵖ` on `i` and `−c dᵖ` on `j` as terms, for `p = 2` (quadratic) and `p = 3`
    /// (cubic); other exponents are not of the degrees a tensor holds.
    fn polynomial_terms(&self) -> Option<PolynomialTerms> {
        fn rows<const N: usize>(
            s: &PolynomialSpring,
            monomials: Vec<([usize; N], f64)>,
        ) -> Vec<(usize, [usize; N], f64)> {
            let rows: Vec<(usize, f64)> = std::iter::once((s.i, 1.0))
                .chain(s.j.map(|j| (j, -1.0)))
                .collect();
            rows.iter()
                .flat_map(|&(i, sign)| monomials.iter().map(move |&(t, c)| (i, t, sign * c)))
                .collect()
        }
        let terms = match self.exponent {
            2 => PolynomialTerms {
                quadratic: rows(self, self.expanded::<2>()),
                cubic: Vec::new(),
            },
            3 => PolynomialTerms {
                quadratic: Vec::new(),
                cubic: rows(self, self.expanded::<3>()),
            },
            _ => return None,
        };
        Some(terms.summed())
    }

    fn dofs_used(&self) -> Vec<usize> {
        std::iter::once(self.i).chain(self.j).collect()
    }
}

/// Adds an element's local vector to the global one: local entry `a` to `global[dofs[a]]`,
/// nothing where the local dof is clamped (`None`). The finite elements' force assembly.
pub(super) fn add_local(dofs: &[Option<usize>], local: &[f64], global: &mut [f64]) {
    for (d, v) in dofs.iter().zip(local) {
        if let Some(i) = *d {
            global[i] += v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Force is the gradient of the potential and the tangent the gradient of the force,
    /// checked by central differences for every supported exponent.
    #[test]
    fn power_is_powi() {
        for d in [0.3, -1.7, 2.0f64.sqrt(), 1e-5, -3.3e4] {
            for p in 0..8 {
                // black_box: a constant-folded powi would use the host's pow instead.
                let (db, pb) = (std::hint::black_box(d), std::hint::black_box(p));
                assert_eq!(power(d, p).to_bits(), db.powi(pb).to_bits(), "{d}^{p}");
            }
        }
    }

    /// The expanded terms give the spring's own force, read back as a tensor (which also checks
    /// that they are a gradient, eq. (59)), for both ends free and to ground, at states where
    /// the stretch has either sign; a quintic spring has no such terms.
    #[test]
    fn polynomial_terms_give_the_force() {
        for (p, j) in [(2, Some(2)), (3, Some(0)), (2, None), (3, None)] {
            let e = PolynomialSpring::new(1, j, -1.7, p);
            let terms = e.polynomial_terms().expect("degree 2 or 3");
            let expected = if j.is_some() { 2 * (p as usize + 1) } else { 1 };
            let count = terms.quadratic.len() + terms.cubic.len();
            assert_eq!(count, expected, "one term per monomial and row, p = {p}");
            let tensor = terms.into_tensor(3).expect("a gradient");
            for x in [[0.3, -1.1, 0.8], [-2.0, 0.25, 0.5], [1.0, 1.0, -1.0]] {
                let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
                e.add_force(&x, &mut a);
                tensor.add_force(&x, &mut b);
                // Round-off of the expanded sum: a few ulps of its largest monomial.
                let reach = x[1].abs() + j.map_or(0.0, |j| x[j].abs());
                let scale = 1.7 * reach.powi(p as i32);
                for (a, b) in a.iter().zip(&b) {
                    assert!((a - b).abs() <= 1e-14 * scale, "p={p}: {a} vs {b}");
                }
            }
        }
        assert!(
            PolynomialSpring::new(0, Some(1), 1.0, 5)
                .polynomial_terms()
                .is_none()
        );
    }

    #[test]
    fn force_and_tangent_are_derivatives() {
        let x = [0.7, -0.4, 0.2];
        for p in [2, 3, 5] {
            let e = PolynomialSpring::new(0, Some(1), 1.3, p);
            let h = 1e-6;
            let mut f = [0.0; 3];
            e.add_force(&x, &mut f);
            for k in 0..3 {
                let (mut xp, mut xm) = (x, x);
                xp[k] += h;
                xm[k] -= h;
                let dv = (e.potential(&xp) - e.potential(&xm)) / (2.0 * h);
                assert!((dv - f[k]).abs() < 1e-8, "p={p} dof {k}: {dv} vs {}", f[k]);
                let (mut fp, mut fm) = ([0.0; 3], [0.0; 3]);
                e.add_force(&xp, &mut fp);
                e.add_force(&xm, &mut fm);
                let mut dir = [0.0; 3];
                dir[k] = 1.0;
                let mut out = [0.0; 3];
                e.add_tangent_product(
                    &x,
                    Block::new(&dir, 3, 1, 3),
                    &mut BlockMut::new(&mut out, 3, 1, 3),
                );
                for r in 0..3 {
                    let fd = (fp[r] - fm[r]) / (2.0 * h);
                    assert!((fd - out[r]).abs() < 1e-7, "p={p}: {fd} vs {}", out[r]);
                }
                // The local tangent matrix on dofs (0, 1) is the same derivative.
                let mut local = [0.0; 4];
                assert!(e.tangent_matrix(&x, &mut local));
                for (a, &row) in e.dofs_used().iter().enumerate() {
                    let entry = e
                        .dofs_used()
                        .iter()
                        .position(|&d| d == k)
                        .map_or(0.0, |b| local[b * 2 + a]);
                    assert_eq!(entry, out[row], "p={p}");
                }
            }
        }
    }
}
