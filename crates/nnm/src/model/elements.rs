//! The catalogue of nonlinear elements.

use super::{Block, BlockMut, FixedDofs, NonlinearElement};

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

    fn dofs_used(&self) -> Vec<usize> {
        std::iter::once(self.i).chain(self.j).collect()
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
