//! Krylov methods on linear operators given only by their products (docs/method.md §15):
//! GMRES for the Newton corrections of matrix-free shooting, and Arnoldi for the Floquet
//! multipliers of largest modulus. Both grow one orthonormal basis of
//! `span{b, A b, A² b, …}` ([`Arnoldi`]): one piece serves the solver and the eigenvalues.
//!
//! No restarts: the operators met here (the monodromy of a model whose unresolved modes the
//! integrator damps, minus the identity) are the identity plus an operator of small numerical
//! rank, and the Krylov space exhausts that rank in a few dozen products.

use crate::linalg::{self, Mat};

/// An inner product `⟨a, b⟩ = aᵀ G b` given by the products `G a` of a symmetric positive
/// definite `G` (written into the second argument).
pub type Metric = std::sync::Arc<dyn Fn(&[f64], &mut [f64]) + Send + Sync>;

/// `‖w‖` in `metric`'s inner product (Euclidean when `None`), with `G w` (empty without a
/// metric).
pub fn norm_with(metric: Option<&Metric>, w: &[f64]) -> (f64, Vec<f64>) {
    match metric {
        None => (linalg::norm(w), Vec::new()),
        Some(metric) => {
            let mut gw = vec![0.0; w.len()];
            metric(w, &mut gw);
            (linalg::dot(w, &gw).max(0.0).sqrt(), gw)
        }
    }
}

/// An orthonormal basis `V` grown by applying `A` to its vectors in turn, and the projected
/// matrix `H` with `A V_k = V H` (to the directions dropped as negligible): Arnoldi's process,
/// optionally seeded with several vectors (then `H` is block Hessenberg). Seeding lets the
/// Floquet analysis hold the trivial directions exactly in the basis.
///
/// Orthonormal in the Euclidean inner product, or in a [`Metric`]'s: then GMRES minimises
/// the residual in that norm — what matrix-free shooting needs when its coordinates weigh
/// the state unevenly (docs/method.md eq. (76a)).
#[derive(Clone)]
pub struct Arnoldi {
    /// Basis vectors, each of the operator's dimension.
    pub basis: Vec<Vec<f64>>,
    /// `G v` for every basis vector `v` (empty without a metric).
    metric_basis: Vec<Vec<f64>>,
    metric: Option<Metric>,
    /// Columns of `H`: column `j` holds `⟨vᵢ, A v_j⟩` for the vectors there were at step `j`,
    /// and the norm of the new direction (0 when none was added).
    columns: Vec<Vec<f64>>,
    /// Whether every basis vector has been processed and `A V` lies in `span V`.
    pub invariant: bool,
}

impl std::fmt::Debug for Arnoldi {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Arnoldi")
            .field("vectors", &self.basis.len())
            .field("steps", &self.columns.len())
            .field("metric", &self.metric.is_some())
            .field("invariant", &self.invariant)
            .finish()
    }
}

impl Arnoldi {
    /// A basis started at `b / ‖b‖`; `None` if `b` is zero or not finite.
    pub fn new(b: &[f64]) -> Option<Self> {
        Self::with_metric(b, None)
    }

    /// A basis started at `b / ‖b‖_G`, orthonormal in `metric`'s inner product (Euclidean
    /// when `None`); `None` if `b` is zero or not finite.
    pub fn with_metric(b: &[f64], metric: Option<Metric>) -> Option<Self> {
        let mut arnoldi = Self {
            basis: Vec::new(),
            metric_basis: Vec::new(),
            metric,
            columns: Vec::new(),
            invariant: false,
        };
        let (norm, gb) = arnoldi.norm(b);
        if !(norm > 0.0 && norm.is_finite()) {
            return None;
        }
        arnoldi.push(b, norm, gb);
        Some(arnoldi)
    }

    /// A basis seeded with `vectors`, orthonormalised in order (one that depends on the
    /// previous ones to `1e-12` of its norm is skipped), in `metric`'s inner product
    /// (Euclidean when `None`); `None` if none is usable.
    pub fn seeded(vectors: &[&[f64]], metric: Option<Metric>) -> Option<Self> {
        let mut arnoldi = Self::with_metric(vectors.first()?, metric)?;
        for v in &vectors[1..] {
            let mut w = v.to_vec();
            let size = arnoldi.norm(&w).0;
            arnoldi.orthogonalise(&mut w);
            let (norm, gw) = arnoldi.norm(&w);
            if norm > 1e-12 * size {
                arnoldi.push(&w, norm, gw);
            }
        }
        Some(arnoldi)
    }

    /// `‖w‖` in the basis' inner product, with `G w` (empty without a metric).
    fn norm(&self, w: &[f64]) -> (f64, Vec<f64>) {
        norm_with(self.metric.as_ref(), w)
    }

    /// Appends `w / norm` to the basis (`gw = G w`, when there is a metric).
    fn push(&mut self, w: &[f64], norm: f64, gw: Vec<f64>) {
        self.basis.push(w.iter().map(|v| v / norm).collect());
        if self.metric.is_some() {
            self.metric_basis
                .push(gw.iter().map(|v| v / norm).collect());
        }
    }

    /// `⟨vᵢ, w⟩`.
    fn inner(&self, i: usize, w: &[f64]) -> f64 {
        match self.metric {
            None => linalg::dot(&self.basis[i], w),
            Some(_) => linalg::dot(&self.metric_basis[i], w),
        }
    }

    /// Removes from `w` its components along the basis, by modified Gram–Schmidt twice (the
    /// second pass restores orthogonality lost to cancellation, which the eigenvalues of `H`
    /// are sensitive to); returns the coefficients.
    fn orthogonalise(&self, w: &mut [f64]) -> Vec<f64> {
        let mut h = vec![0.0; self.basis.len()];
        for _ in 0..2 {
            for (i, v) in self.basis.iter().enumerate() {
                let c = self.inner(i, w);
                h[i] += c;
                w.iter_mut().zip(v).for_each(|(w, v)| *w -= c * v);
            }
        }
        h
    }

    /// The columns of `H`: column `j` holds `⟨vᵢ, A v_j⟩` for the basis vectors there were at
    /// step `j`, then the norm of the direction added (0 when none was): `A v_j` is their
    /// combination of the basis vectors.
    pub fn columns(&self) -> &[Vec<f64>] {
        &self.columns
    }

    /// Steps taken (columns of `H`).
    pub fn steps(&self) -> usize {
        self.columns.len()
    }

    /// One step: `w = A v_k` for the next unprocessed basis vector `v_k`, orthogonalised
    /// against the basis. Returns the norm of what is left, and adds it as a new vector unless
    /// it is below `breakdown` times the norm of `A v_k` or below `floor` (then `A v_k` lies
    /// in the span, to that accuracy); the space is invariant when every vector has been
    /// processed.
    pub fn step(
        &mut self,
        apply: &mut impl FnMut(&[f64], &mut [f64]),
        breakdown: f64,
        floor: f64,
    ) -> f64 {
        let next = &self.basis[self.columns.len()];
        let mut w = vec![0.0; next.len()];
        apply(next, &mut w);
        let size = self.norm(&w).0;
        let mut h = self.orthogonalise(&mut w);
        let (norm, gw) = self.norm(&w);
        let added = norm > breakdown * size && norm > floor && norm.is_finite();
        h.push(if added { norm } else { 0.0 });
        self.columns.push(h);
        if added {
            self.push(&w, norm, gw);
        }
        self.invariant = self.columns.len() == self.basis.len();
        if added { norm } else { 0.0 }
    }

    /// The square (block) Hessenberg matrix `H_k = V_kᵀ A V_k` (`k × k`, `k` = steps): its
    /// eigenvalues are the Ritz values.
    pub fn hessenberg(&self) -> Mat<f64> {
        let k = self.steps();
        Mat::from_fn(k, k, |i, j| self.columns[j].get(i).copied().unwrap_or(0.0))
    }

    /// The Ritz values of modulus at least `floor`, once each has converged: its residual
    /// `‖A V y − θ V y‖ = h_(k+1,k) |y_k|` (`y` the unit eigenvector of `H_k`; Saad, *Numerical
    /// Methods for Large Eigenvalue Problems*, §6.2) at most `tolerance`. `None` while one of
    /// them has not, or when the process was seeded with several vectors (its residual is
    /// then a block). An invariant space has converged every Ritz value.
    pub fn converged_ritz_values(
        &self,
        floor: f64,
        tolerance: f64,
    ) -> Option<Vec<linalg::Complex>> {
        let k = self.steps();
        if k == 0 || self.basis.len() > k + 1 {
            return None;
        }
        let next = self.columns[k - 1].get(k).copied().unwrap_or(0.0);
        let eigen = self.hessenberg().eigen().ok()?;
        let (vectors, values) = (eigen.U(), eigen.S());
        let mut converged = Vec::new();
        for j in 0..k {
            let theta = values.column_vector()[j];
            if theta.norm() < floor {
                continue;
            }
            let size = (0..k)
                .map(|i| vectors[(i, j)].norm_sqr())
                .sum::<f64>()
                .sqrt();
            let residual = next * vectors[(k - 1, j)].norm() / size;
            if !(residual <= tolerance) {
                return None;
            }
            converged.push((theta.re, theta.im));
        }
        Some(converged)
    }

    /// Coordinates of `x` in the first `k` basis vectors, `⟨v_i, x⟩`.
    pub fn coordinates(&self, x: &[f64]) -> Vec<f64> {
        (0..self.steps()).map(|i| self.inner(i, x)).collect()
    }
}

/// The outcome of [`gmres`].
#[derive(Debug, Clone)]
pub struct GmresSolution {
    /// The approximate solution.
    pub x: Vec<f64>,
    /// Operator products made.
    pub iterations: usize,
    /// `‖b − A x‖ / ‖b‖` (from the least-squares problem, exact in exact arithmetic).
    pub relative_residual: f64,
}

/// GMRES (Saad & Schultz) for `A x = b` from `x = 0`, until `‖b − A x‖ ≤ relative ‖b‖`, or
/// `≤ absolute`, or `max_iterations` products (`(relative, absolute) = tolerances`): each
/// step minimises the residual over the Krylov space, by Givens rotations of the Hessenberg
/// columns as they come.
pub fn gmres(
    mut apply: impl FnMut(&[f64], &mut [f64]),
    b: &[f64],
    (relative, absolute): (f64, f64),
    max_iterations: usize,
    metric: Option<Metric>,
) -> GmresSolution {
    let Some(mut arnoldi) = Arnoldi::with_metric(b, metric) else {
        return GmresSolution {
            x: vec![0.0; b.len()],
            iterations: 0,
            relative_residual: 0.0,
        };
    };
    let beta = arnoldi.norm(b).0;
    let tolerance = relative.max(absolute / beta);
    // The rotated Hessenberg R, the rotations, and the rotated right-hand side β e₁.
    let mut r: Vec<Vec<f64>> = Vec::new();
    let mut rotations: Vec<(f64, f64)> = Vec::new();
    let mut g = vec![beta];
    let mut residual = 1.0;
    while arnoldi.steps() < max_iterations && residual > tolerance {
        arnoldi.step(&mut apply, 1e-14, 0.0);
        let mut h = arnoldi.columns.last().expect("a step was taken").clone();
        let k = h.len() - 1;
        for (i, &(c, s)) in rotations.iter().enumerate() {
            let (a, b) = (h[i], h[i + 1]);
            h[i] = c * a + s * b;
            h[i + 1] = -s * a + c * b;
        }
        let (a, b) = (h[k - 1], h[k]);
        let rho = a.hypot(b);
        let (c, s) = if rho > 0.0 {
            (a / rho, b / rho)
        } else {
            (1.0, 0.0)
        };
        h[k - 1] = rho;
        h[k] = 0.0;
        rotations.push((c, s));
        g.push(-s * g[k - 1]);
        g[k - 1] *= c;
        h.truncate(k);
        r.push(h);
        residual = g[k].abs() / beta;
        if arnoldi.invariant {
            break;
        }
    }
    // Back substitution R y = g, then x = V y.
    let k = r.len();
    let mut y = vec![0.0; k];
    for i in (0..k).rev() {
        let sum: f64 = (i + 1..k).map(|j| r[j][i] * y[j]).sum();
        y[i] = if r[i][i] != 0.0 {
            (g[i] - sum) / r[i][i]
        } else {
            0.0
        };
    }
    let mut x = vec![0.0; b.len()];
    for (v, yi) in arnoldi.basis.iter().zip(&y) {
        x.iter_mut().zip(v).for_each(|(x, v)| *x += yi * v);
    }
    GmresSolution {
        x,
        iterations: k,
        relative_residual: residual,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A non-symmetric test operator: `I + low-rank` plus a tridiagonal coupling, applied
    /// densely.
    fn operator(n: usize) -> Mat<f64> {
        Mat::from_fn(n, n, |i, j| {
            let low_rank = ((i + 1) as f64).sin() * ((2 * j + 1) as f64).cos();
            let band = match i as i64 - j as i64 {
                0 => 2.0,
                1 => -0.5,
                -1 => 0.3,
                _ => 0.0,
            };
            band + low_rank
        })
    }

    fn apply(a: &Mat<f64>) -> impl FnMut(&[f64], &mut [f64]) + '_ {
        move |x, out| {
            for (i, o) in out.iter_mut().enumerate() {
                *o = (0..x.len()).map(|j| a[(i, j)] * x[j]).sum();
            }
        }
    }

    /// GMRES solves a non-symmetric system to its tolerance; the dense solve agrees.
    #[test]
    fn gmres_solves_a_nonsymmetric_system() {
        let n = 40;
        let a = operator(n);
        let b: Vec<f64> = (0..n).map(|i| 1.0 + (i % 3) as f64).collect();
        let solution = gmres(apply(&a), &b, (1e-12, 0.0), n, None);
        assert!(solution.relative_residual <= 1e-12);
        let exact = linalg::least_squares(a.as_ref(), &b);
        for (x, e) in solution.x.iter().zip(&exact) {
            assert!((x - e).abs() < 1e-9 * (1.0 + e.abs()), "{x} vs {e}");
        }
        // Its own residual estimate is the true one.
        let mut ax = vec![0.0; n];
        apply(&a)(&solution.x, &mut ax);
        let true_residual =
            linalg::norm(&ax.iter().zip(&b).map(|(p, q)| p - q).collect::<Vec<_>>())
                / linalg::norm(&b);
        assert!(true_residual < 1e-11, "{true_residual}");
    }

    /// On `I + rank r`, GMRES converges in at most `r + 1` products (the minimal polynomial
    /// has degree `r + 1`): the property matrix-free shooting relies on.
    #[test]
    fn gmres_converges_in_rank_plus_one_on_identity_plus_low_rank() {
        let (n, rank) = (200, 6);
        let u: Vec<Vec<f64>> = (0..rank)
            .map(|k| (0..n).map(|i| ((i * (k + 3)) as f64 * 0.1).sin()).collect())
            .collect();
        let w: Vec<Vec<f64>> = (0..rank)
            .map(|k| {
                (0..n)
                    .map(|i| ((i + k) as f64 * 0.37).cos() / n as f64)
                    .collect()
            })
            .collect();
        let product = |x: &[f64], out: &mut [f64]| {
            out.copy_from_slice(x);
            for (u, w) in u.iter().zip(&w) {
                let c = linalg::dot(w, x);
                out.iter_mut().zip(u).for_each(|(o, u)| *o += c * u);
            }
        };
        let b: Vec<f64> = (0..n).map(|i| (i as f64).sqrt()).collect();
        let solution = gmres(product, &b, (1e-12, 0.0), n, None);
        assert!(solution.iterations <= rank + 1, "{}", solution.iterations);
        assert!(solution.relative_residual <= 1e-12);
    }

    /// The Ritz values of a full Arnoldi run are the eigenvalues; the basis is orthonormal.
    #[test]
    fn arnoldi_ritz_values_are_the_eigenvalues_when_complete() {
        let n = 12;
        let a = operator(n);
        let start: Vec<f64> = (0..n).map(|i| 1.0 / (1.0 + i as f64)).collect();
        let mut arnoldi = Arnoldi::new(&start).unwrap();
        let mut product = apply(&a);
        while arnoldi.steps() < n && !arnoldi.invariant {
            arnoldi.step(&mut product, 1e-12, 0.0);
        }
        let mut ritz = linalg::eigenvalues(arnoldi.hessenberg().as_ref()).unwrap();
        let mut exact = linalg::eigenvalues(a.as_ref()).unwrap();
        let key = |z: &linalg::Complex| (z.0 * 1e6).round() * 1e7 + z.1;
        ritz.sort_by(|p, q| key(p).total_cmp(&key(q)));
        exact.sort_by(|p, q| key(p).total_cmp(&key(q)));
        for (r, e) in ritz.iter().zip(&exact) {
            assert!((r.0 - e.0).hypot(r.1 - e.1) < 1e-9, "{r:?} vs {e:?}");
        }
        for (i, v) in arnoldi.basis.iter().enumerate() {
            for (j, w) in arnoldi.basis.iter().enumerate() {
                let expected = if i == j { 1.0 } else { 0.0 };
                assert!((linalg::dot(v, w) - expected).abs() < 1e-12);
            }
        }
    }

    /// A damped shot map's spectrum: a rotated pair `0.9 e^{±0.3i}`, `0.5` and `−0.3`, and a
    /// tail of 60 eigenvalues falling from 0.05 to 1e-9 (coupled by a non-normal similarity).
    /// The Ritz values above 0.1 converge, to the exact ones within 1e-9, long before the
    /// space is invariant; those below are not given.
    #[test]
    fn ritz_values_above_a_floor_converge_before_invariance() {
        let n = 64;
        let mut d = Mat::<f64>::zeros(n, n);
        let (r, t) = (0.9f64, 0.3f64);
        d[(0, 0)] = r * t.cos();
        d[(0, 1)] = -r * t.sin();
        d[(1, 0)] = r * t.sin();
        d[(1, 1)] = r * t.cos();
        d[(2, 2)] = 0.5;
        d[(3, 3)] = -0.3;
        for k in 4..n {
            d[(k, k)] = 0.05 * (1e-9f64 / 0.05).powf((k - 4) as f64 / (n - 5) as f64);
        }
        // A = S D S⁻¹ with S = I + 0.1 (upper shift): non-normal, the same spectrum.
        let s = Mat::<f64>::from_fn(n, n, |i, j| match j.wrapping_sub(i) {
            0 => 1.0,
            1 => 0.1,
            _ => 0.0,
        });
        let s_inverse = Mat::<f64>::from_fn(n, n, |i, j| {
            if j >= i {
                (-0.1f64).powi((j - i) as i32)
            } else {
                0.0
            }
        });
        let a = linalg::product(
            linalg::product(s.as_ref(), d.as_ref()).as_ref(),
            s_inverse.as_ref(),
        );
        let start: Vec<f64> = (0..n).map(|i| ((i as f64) * 0.618 + 0.5).sin()).collect();
        let mut arnoldi = Arnoldi::new(&start).unwrap();
        let mut product = apply(&a);
        let converged = loop {
            arnoldi.step(&mut product, 1e-14, 1e-10);
            if let Some(values) = arnoldi.converged_ritz_values(0.1, 1e-10) {
                if values.len() == 4 || arnoldi.invariant {
                    break values;
                }
            }
            assert!(arnoldi.steps() < n, "never converged");
        };
        assert!(
            !arnoldi.invariant && arnoldi.steps() < 40,
            "{} steps",
            arnoldi.steps()
        );
        let exact = [
            (r * t.cos(), r * t.sin()),
            (r * t.cos(), -r * t.sin()),
            (0.5, 0.0),
            (-0.3, 0.0),
        ];
        assert_eq!(converged.len(), 4, "{converged:?}");
        for e in exact {
            let nearest = converged
                .iter()
                .map(|c| (c.0 - e.0).hypot(c.1 - e.1))
                .fold(f64::INFINITY, f64::min);
            assert!(nearest < 1e-9, "{e:?} in {converged:?}");
        }
    }
}
