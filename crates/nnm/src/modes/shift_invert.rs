//! Accurate lowest modes of stiff models (docs/method.md §10, eqs. (67)–(71)): shift-invert
//! subspace iteration in correction form, with every residual `K v − θ M v` evaluated in
//! double-double arithmetic and a Rayleigh–Ritz step solved by Jacobi rotations.
//!
//! Why each piece: a dense eigen-solver on `L⁻¹ K L⁻ᵀ` has eigenvalue errors of
//! `ε λ_max`, so the low modes of a model whose spectrum spans 10⁸ or more lose most of their
//! digits (and a stiff penalty spring pushes an elastic `ω²` below any threshold relative to
//! `λ_max`). Here the factorisation of `F = K + τ M` (`τ` a tiny positive shift, so rigid-body
//! modes do not make `F` singular) is applied to the residual, not to `M v`: the step
//! `V ← V − F⁻¹ R` is inverse iteration (eq. (68)) whose double-precision solve only has to be
//! accurate relative to the small correction, while `R` itself is exact to `O(ε²)` (eq. (69)).
//! The iteration therefore converges to the eigenpairs of the matrices *as given*, to a
//! residual of 1e-10 of `‖K v‖` checked on every returned mode, however large the spread.
//! Memory: the sparse factor plus `O(n p)` for a block of `p` vectors.

use super::{LinearMode, ModesError};
use crate::linalg::{self, SparseLuPattern};
use crate::model::{MassOperator, MechanicalSystem};

/// Unit round-off of `f64`, `u = 2⁻⁵³`.
pub(super) const UNIT_ROUNDOFF: f64 = f64::EPSILON / 2.0;

/// A mode is rigid when `‖K v‖ ≤ RIGID_ROUNDING · u ‖|K| |v|‖` (eq. (70)): `K v` vanishes to the
/// rounding of its entries (assembly sums a few rounded terms per entry).
pub const RIGID_ROUNDING: f64 = 16.0;

/// An elastic mode must have `‖K v‖ ≥ ELASTIC_ROUNDING · u ‖|K| |v|‖` (eq. (70)); in between,
/// the rounding of the stiffness entries could move `ω²` by more than 1% of itself in the
/// worst case, and the model is refused. (The bound is pessimistic for assembled meshes: on a
/// 1,000-element cantilever, `ρ ≈ 1.4e3` bounds the first `ω²` to 7e-4 while the measured
/// effect of rounding is 7e-10; a 2,000-element one, `ρ = 145`, still passes.)
pub const ELASTIC_ROUNDING: f64 = 100.0;

/// Residual every returned elastic mode satisfies, `‖K v − ω² M v‖ ≤ tol ‖K v‖` (eq. (69)) —
/// or, when that is below what a vector stored in double can reach, the rounding floor
/// [`RESIDUAL_ROUNDING`]` · u ‖|K| |v|‖`.
pub const RESIDUAL_TOLERANCE: f64 = 1e-10;

/// The rounding floor of eq. (69), in units of `u`: storing the exact eigenvector in double
/// perturbs each entry by `u |v_i|`, hence row `i` of `K v − θ M v` by up to
/// `u (|K| |v| + |θ| |M| |v|)_i`. Where `‖|K| |v|‖ / ‖K v‖` exceeds ~1e6 (the low modes of a
/// beam of 100 elements and more, of a bladed disk of thousands of sectors) no double vector
/// reaches `tol ‖K v‖`; such a mode is accepted when its backward error is within this many
/// round-offs — the iteration settles at 0.3–0.8 of one (measured on beams and disks).
pub const RESIDUAL_ROUNDING: f64 = 2.0;

/// Correction steps made after every wanted mode passes the check (see [`iterate`]).
const POLISH_STEPS: usize = 2;

/// A symmetric `n × n` matrix in compressed rows (both triangles).
#[derive(Debug, Clone)]
pub(super) struct Csr {
    pub n: usize,
    pub row_start: Vec<usize>,
    pub col: Vec<usize>,
    pub value: Vec<f64>,
}

impl Csr {
    /// The non-zeros of a dense column-major `n × n` matrix (the dense path's operators).
    pub fn from_dense(a: &linalg::Mat<f64>) -> Self {
        let (row_start, col, value) = linalg::compressed_rows(a);
        Self {
            n: a.nrows(),
            row_start,
            col,
            value,
        }
    }

    fn diagonal(d: &[f64]) -> Self {
        Self {
            n: d.len(),
            row_start: (0..=d.len()).collect(),
            col: (0..d.len()).collect(),
            value: d.to_vec(),
        }
    }

    fn entry_diagonal(&self) -> Vec<f64> {
        (0..self.n)
            .map(|i| {
                (self.row_start[i]..self.row_start[i + 1])
                    .find(|&k| self.col[k] == i)
                    .map_or(0.0, |k| self.value[k])
            })
            .collect()
    }

    /// `A v` in double-double: `(hi, lo)` per row with `hi + lo` equal to the exact product to
    /// `O(ε²)` relative to `|A| |v|` (eq. (69)).
    fn times_dd(&self, v: &[f64], hi: &mut [f64], lo: &mut [f64]) {
        for i in 0..self.n {
            let (mut s, mut e) = (0.0, 0.0);
            for k in self.row_start[i]..self.row_start[i + 1] {
                let (p, pe) = linalg::exact_product(self.value[k], v[self.col[k]]);
                let (t, te) = linalg::exact_sum(s, p);
                s = t;
                e += te + pe;
            }
            let h = s + e;
            hi[i] = h;
            lo[i] = e - (h - s);
        }
    }

    /// `A v` in double.
    fn times(&self, v: &[f64], out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = (self.row_start[i]..self.row_start[i + 1])
                .map(|k| self.value[k] * v[self.col[k]])
                .sum();
        }
    }

    /// `|A| |v|`, row by row.
    fn abs_times(&self, v: &[f64]) -> Vec<f64> {
        (0..self.n)
            .map(|i| {
                (self.row_start[i]..self.row_start[i + 1])
                    .map(|k| (self.value[k] * v[self.col[k]]).abs())
                    .sum::<f64>()
            })
            .collect()
    }

    /// `‖|A| |v|‖`: the scale of the rounding of `A v`.
    fn abs_times_norm(&self, v: &[f64]) -> f64 {
        (0..self.n)
            .map(|i| {
                (self.row_start[i]..self.row_start[i + 1])
                    .map(|k| (self.value[k] * v[self.col[k]]).abs())
                    .sum::<f64>()
                    .powi(2)
            })
            .sum::<f64>()
            .sqrt()
    }
}

/// `K` and `M` of a system's linearisation at rest, held sparse.
#[derive(Debug, Clone)]
pub(super) struct Operators {
    pub k: Csr,
    pub m: Csr,
    /// `S = diag(K)^(-1/2)` (the mass diagonal where `K_ii = 0`): the equilibration weights of
    /// the backward error (eq. (69)).
    pub weight: Vec<f64>,
}

impl Operators {
    /// From the system's sparse tangent at `x = 0` and its sparse or diagonal mass, without
    /// any `n × n` array; `None` when the system gives neither.
    pub fn sparse<S: MechanicalSystem + ?Sized>(system: &S) -> Option<Self> {
        let n = system.dofs();
        let pattern = system.tangent_pattern()?;
        let mut value = vec![0.0; pattern.nonzeros()];
        system.tangent_values(&vec![0.0; n], &mut value);
        let k = Csr {
            n,
            row_start: pattern.row_start.clone(),
            col: pattern.col.clone(),
            value,
        };
        let mass = system.mass();
        let m = if let Some(d) = mass.diagonal() {
            Csr::diagonal(d)
        } else if let Some(s) = mass.sparse() {
            Csr {
                n,
                row_start: s.pattern().row_start.clone(),
                col: s.pattern().col.clone(),
                value: s.values().to_vec(),
            }
        } else {
            return None;
        };
        Some(Self::new(k, m))
    }

    /// `K`, `M` and the equilibration weights.
    pub fn new(k: Csr, m: Csr) -> Self {
        let (kd, md) = (k.entry_diagonal(), m.entry_diagonal());
        let weight = kd
            .iter()
            .zip(&md)
            .map(|(&k, &m)| {
                let d = if k.abs() > 0.0 { k.abs() } else { m.abs() };
                if d > 0.0 && d.is_finite() {
                    1.0 / d.sqrt()
                } else {
                    1.0
                }
            })
            .collect();
        Self { k, m, weight }
    }

    fn n(&self) -> usize {
        self.k.n
    }

    /// `F = K + τ M` on the union of the two patterns, factorised by sparse LU; `None` if
    /// singular or not finite.
    fn factorise(&self, tau: f64) -> Option<linalg::SparseLu> {
        let n = self.n();
        let mut row_start = vec![0];
        let (mut col, mut value) = (Vec::new(), Vec::new());
        for i in 0..n {
            let mut row: Vec<(usize, f64)> = (self.k.row_start[i]..self.k.row_start[i + 1])
                .map(|p| (self.k.col[p], self.k.value[p]))
                .chain(
                    (self.m.row_start[i]..self.m.row_start[i + 1])
                        .map(|p| (self.m.col[p], tau * self.m.value[p])),
                )
                .collect();
            row.sort_by_key(|e| e.0);
            for (j, v) in row {
                if col.len() > row_start[i] && col.last() == Some(&j) {
                    *value.last_mut().expect("an entry") += v;
                } else {
                    col.push(j);
                    value.push(v);
                }
            }
            row_start.push(col.len());
        }
        // Symmetric: the compressed rows are the compressed columns of the transpose, i.e. of
        // the matrix itself (up to the round-off asymmetry of the input, harmless for LU).
        let pattern = SparseLuPattern::new(n, row_start, col)?;
        let lu = pattern.factorise(&value)?;
        let mut probe = vec![1.0; n];
        lu.solve_in_place(&mut probe, 1);
        probe.iter().all(|x| x.is_finite()).then_some(lu)
    }

    /// The shift `τ` of eq. (67): a hundred round-offs of the largest `K_ii / M_ii` (an
    /// upper estimate of the spectrum's scale), so `K + τ M` is safely non-singular with
    /// rigid-body modes while every mode that can be told from rigid (eq. (70)) lies above it.
    fn shift(&self) -> f64 {
        let (kd, md) = (self.k.entry_diagonal(), self.m.entry_diagonal());
        let scale = kd
            .iter()
            .zip(&md)
            .filter(|(_, m)| **m > 0.0)
            .map(|(k, m)| k.abs() / m)
            .fold(0.0f64, f64::max);
        let scale = if scale > 0.0 && scale.is_finite() {
            scale
        } else {
            1.0
        };
        ELASTIC_ROUNDING * UNIT_ROUNDOFF * scale
    }
}

/// `2^e` for `-1022 ≤ e ≤ 1023`, exactly.
fn pow2(e: i32) -> f64 {
    debug_assert!((-1022..=1023).contains(&e));
    f64::from_bits(((e + 1023) as u64) << 52)
}

/// The even power-of-two exponent nearest `max` (0 for zero or non-finite), within the range
/// whose powers and inverse powers are normal numbers.
fn even_exponent(max: f64) -> i32 {
    if !(max > 0.0 && max.is_finite()) {
        return 0;
    }
    let e = max.log2().round() as i32;
    (e - e.rem_euclid(2)).clamp(-1022, 1022)
}

/// Exact power-of-two scales of `K` and `M`: the analysis runs on `K_s = 2^-k K` and
/// `M_s = 2^-m M`, whose largest entries are near 1, and its modes are mapped back
/// (`ω = 2^((k-m)/2) ω_s`, `v = 2^(-m/2) v_s`, both exact). Why: the checks of eqs. (69)–(70)
/// form norms of `K v` and `vᵀ K v`; with `K` of order 1e154 or a mass of order 1e-300 their
/// squares overflow (or underflow), which read every elastic mode as rigid. Every check is a
/// ratio, so on the scaled pencil it decides as on a model of ordinary units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Scale {
    k: i32,
    m: i32,
}

impl Scale {
    /// From the largest magnitudes of `K`'s and `M`'s entries.
    pub fn new(max_k: f64, max_m: f64) -> Self {
        Self {
            k: even_exponent(max_k),
            m: even_exponent(max_m),
        }
    }

    /// The scale of the operators' own entries.
    pub fn of(ops: &Operators) -> Self {
        let max = |a: &Csr| a.value.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        Self::new(max(&ops.k), max(&ops.m))
    }

    /// The factors `(2^-k, 2^-m)` that scale `K` and `M`.
    pub fn factors(&self) -> (f64, f64) {
        (pow2(-self.k), pow2(-self.m))
    }

    /// The scaled operators (weights recomputed).
    pub fn operators(&self, ops: Operators) -> Operators {
        let (mut k, mut m) = (ops.k, ops.m);
        let (sk, sm) = self.factors();
        k.value.iter_mut().for_each(|v| *v *= sk);
        m.value.iter_mut().for_each(|v| *v *= sm);
        Operators::new(k, m)
    }

    /// A mass-normalised shape of the model as given, as one of the scaled pencil.
    pub fn scale_shape(&self, v: &mut [f64]) {
        let s = pow2(self.m / 2);
        v.iter_mut().for_each(|x| *x *= s);
    }

    /// Modes of the scaled pencil (or its error) as those of the model as given.
    pub fn unscale(
        &self,
        modes: Result<Vec<LinearMode>, ModesError>,
    ) -> Result<Vec<LinearMode>, ModesError> {
        let (frequency, shape) = (pow2((self.k - self.m) / 2), pow2(-self.m / 2));
        let omega_squared = |x: f64| x * frequency * frequency;
        match modes {
            Ok(mut modes) => {
                for mode in &mut modes {
                    mode.frequency *= frequency;
                    mode.shape.iter_mut().for_each(|x| *x *= shape);
                }
                Ok(modes)
            }
            Err(ModesError::NegativeStiffness(theta)) => {
                Err(ModesError::NegativeStiffness(omega_squared(theta)))
            }
            Err(ModesError::IllConditioned {
                mode,
                omega_squared: theta,
                rounding_units,
            }) => Err(ModesError::IllConditioned {
                mode,
                omega_squared: omega_squared(theta),
                rounding_units,
            }),
            Err(e) => Err(e),
        }
    }
}

/// What the residual check says of one vector (eqs. (69), (70)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Check {
    /// Rayleigh quotient `θ = vᵀ K v / vᵀ M v`, from the double-double product.
    pub theta: f64,
    /// `‖K v − θ M v‖ / ‖K v‖`.
    pub residual: f64,
    /// `ρ = ‖K v‖ / (u ‖|K| |v|‖)`: how many round-offs `K v` is away from zero.
    pub rounding_units: f64,
    /// Backward error `‖S r‖ / ‖S (|K| |v| + |θ| |M| |v|)‖` in units of `u`, `S = diag(K)^(-1/2)`
    /// (eq. (69)): the residual against the rounding of a double vector, each dof weighted as
    /// in the equilibrated problem `S K S` so that dofs of different units (displacements and
    /// rotations) count alike.
    pub backward: f64,
}

impl Check {
    /// Rigid: `K v` vanishes to the rounding of its entries (eq. (70)).
    pub fn rigid(&self) -> bool {
        self.rounding_units <= RIGID_ROUNDING
    }
    /// Converged: rigid, or elastic with the residual below the tolerance or at the rounding
    /// floor of a double vector (eq. (69)).
    pub fn converged(&self) -> bool {
        self.rigid() || self.residual <= RESIDUAL_TOLERANCE || self.backward <= RESIDUAL_ROUNDING
    }
}

/// The residual `r = K v − θ M v` (double-double, rounded) and the check of eq. (69)–(70).
pub(super) fn check(ops: &Operators, v: &[f64], r: &mut [f64]) -> Check {
    let n = ops.n();
    let (mut kh, mut kl, mut mh, mut ml) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    ops.k.times_dd(v, &mut kh, &mut kl);
    ops.m.times_dd(v, &mut mh, &mut ml);
    let vkv = linalg::dot(v, &kh) + linalg::dot(v, &kl);
    let vmv = linalg::dot(v, &mh) + linalg::dot(v, &ml);
    let theta = vkv / vmv;
    for i in 0..n {
        let (p, pe) = linalg::exact_product(theta, mh[i]);
        let (s, se) = linalg::exact_sum(kh[i], -p);
        r[i] = s + (se + kl[i] - pe - theta * ml[i]);
    }
    let kv = linalg::norm(&kh);
    let scale = ops.k.abs_times_norm(v);
    let (ka, ma) = (ops.k.abs_times(v), ops.m.abs_times(v));
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..n {
        let w = ops.weight[i];
        num += (w * r[i]).powi(2);
        den += (w * (ka[i] + theta.abs() * ma[i])).powi(2);
    }
    let backward = if num == 0.0 {
        0.0
    } else if den > 0.0 {
        (num / den).sqrt() / UNIT_ROUNDOFF
    } else {
        f64::INFINITY
    };
    Check {
        backward,
        theta,
        residual: if kv > 0.0 { linalg::norm(r) / kv } else { 0.0 },
        rounding_units: if scale > 0.0 {
            kv / (UNIT_ROUNDOFF * scale)
        } else {
            0.0
        },
    }
}

/// A deterministic pseudo-random vector (xorshift), for starting blocks and for replacing a
/// column that orthogonalisation annihilated.
fn random_vector(n: usize, seed: u64) -> Vec<f64> {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect()
}

/// M-orthonormalises the `p` columns of `v` (column-major, `n × p`) by classical Gram–Schmidt
/// twice; a column that vanishes is replaced by a random one.
fn m_orthonormalise(ops: &Operators, v: &mut [f64], p: usize) {
    let n = ops.n();
    let mut mv = vec![0.0; n * p];
    let mut seed = 1u64;
    let mut j = 0;
    while j < p {
        let norm_before = {
            let col = &v[j * n..(j + 1) * n];
            let mut m = vec![0.0; n];
            ops.m.times(col, &mut m);
            linalg::dot(col, &m).max(0.0).sqrt()
        };
        for _ in 0..2 {
            let coeffs: Vec<f64> = (0..j)
                .map(|i| linalg::dot(&mv[i * n..(i + 1) * n], &v[j * n..(j + 1) * n]))
                .collect();
            let (done, rest) = v.split_at_mut(j * n);
            for (i, c) in coeffs.iter().enumerate() {
                for (x, b) in rest[..n].iter_mut().zip(&done[i * n..(i + 1) * n]) {
                    *x -= c * b;
                }
            }
        }
        let (done, rest) = mv.split_at_mut(j * n);
        let _ = done;
        ops.m.times(&v[j * n..(j + 1) * n], &mut rest[..n]);
        let norm = linalg::dot(&v[j * n..(j + 1) * n], &rest[..n])
            .max(0.0)
            .sqrt();
        if !(norm > 1e-10 * norm_before && norm.is_finite()) {
            seed += 1;
            v[j * n..(j + 1) * n].copy_from_slice(&random_vector(n, 1000 + seed));
            if seed > 50 {
                // Cannot happen with p ≤ n; leave the column as it is rather than loop.
                j += 1;
            }
            continue;
        }
        v[j * n..(j + 1) * n].iter_mut().for_each(|x| *x /= norm);
        rest[..n].iter_mut().for_each(|x| *x /= norm);
        j += 1;
    }
}

/// Eigenvalues (ascending) and orthonormal eigenvectors (column-major) of a symmetric `p × p`
/// matrix by cyclic Jacobi rotations: small eigenvalues of a graded, nearly diagonal matrix —
/// the projected stiffness once the block has converged — keep their relative accuracy, which a
/// tridiagonalising solver (errors of `ε ‖A‖`) would not (eq. (68)).
fn jacobi_eigen(a: &mut [f64], p: usize) -> (Vec<f64>, Vec<f64>) {
    let mut q = vec![0.0; p * p];
    for i in 0..p {
        q[i * p + i] = 1.0;
    }
    for _sweep in 0..60 {
        let mut rotated = false;
        for c in 1..p {
            for r in 0..c {
                let (arr, acc, arc) = (a[r * p + r], a[c * p + c], a[c * p + r]);
                if arc == 0.0 || arc.abs() <= 1e-18 * (arr.abs() * acc.abs()).sqrt() {
                    continue;
                }
                rotated = true;
                let zeta = (acc - arr) / (2.0 * arc);
                let t = zeta.signum() / (zeta.abs() + (1.0 + zeta * zeta).sqrt());
                let t = if zeta == 0.0 { 1.0 } else { t };
                let cs = 1.0 / (1.0 + t * t).sqrt();
                let sn = t * cs;
                for k in 0..p {
                    let (akr, akc) = (a[r * p + k], a[c * p + k]);
                    a[r * p + k] = cs * akr - sn * akc;
                    a[c * p + k] = sn * akr + cs * akc;
                }
                for k in 0..p {
                    let (ark, ack) = (a[k * p + r], a[k * p + c]);
                    a[k * p + r] = cs * ark - sn * ack;
                    a[k * p + c] = sn * ark + cs * ack;
                }
                for k in 0..p {
                    let (qkr, qkc) = (q[r * p + k], q[c * p + k]);
                    q[r * p + k] = cs * qkr - sn * qkc;
                    q[c * p + k] = sn * qkr + cs * qkc;
                }
            }
        }
        if !rotated {
            break;
        }
    }
    let mut order: Vec<usize> = (0..p).collect();
    order.sort_by(|&x, &y| a[x * p + x].total_cmp(&a[y * p + y]));
    let values = order.iter().map(|&k| a[k * p + k]).collect();
    let vectors = order
        .iter()
        .flat_map(|&k| q[k * p..(k + 1) * p].to_vec())
        .collect();
    (values, vectors)
}

/// Rayleigh–Ritz on the M-orthonormal block `v`: `v ← v Q`, returns the Ritz values.
fn rayleigh_ritz(ops: &Operators, v: &mut Vec<f64>, p: usize) -> Vec<f64> {
    let n = ops.n();
    let mut kv = vec![0.0; n * p];
    let mut lo = vec![0.0; n];
    for j in 0..p {
        ops.k
            .times_dd(&v[j * n..(j + 1) * n], &mut kv[j * n..(j + 1) * n], &mut lo);
    }
    let mut a = vec![0.0; p * p];
    for c in 0..p {
        for r in 0..=c {
            let x = 0.5
                * (linalg::dot(&v[r * n..(r + 1) * n], &kv[c * n..(c + 1) * n])
                    + linalg::dot(&v[c * n..(c + 1) * n], &kv[r * n..(r + 1) * n]));
            a[c * p + r] = x;
            a[r * p + c] = x;
        }
    }
    let (values, q) = jacobi_eigen(&mut a, p);
    let mut rotated = vec![0.0; n * p];
    for c in 0..p {
        let out = &mut rotated[c * n..(c + 1) * n];
        for r in 0..p {
            let w = q[c * p + r];
            if w != 0.0 {
                for (o, x) in out.iter_mut().zip(&v[r * n..(r + 1) * n]) {
                    *o += w * x;
                }
            }
        }
    }
    *v = rotated;
    values
}

/// Converged block: Ritz vectors (column-major `n × p`, M-orthonormal) and their checks.
pub(super) struct Block {
    pub vectors: Vec<f64>,
    pub checks: Vec<Check>,
}

/// Shift-invert subspace iteration in correction form (eqs. (67)–(69)) with `F = K − σ M`
/// from the `p` starting columns `v`, until the lowest `want` Ritz pairs pass the check — and
/// the next one too if it continues a cluster (a degenerate pair is never cut in half).
pub(super) fn iterate(
    ops: &Operators,
    mut v: Vec<f64>,
    p: usize,
    want: usize,
    max_iterations: usize,
    sigma: f64,
) -> Result<Block, ModesError> {
    let n = ops.n();
    let factor = ops.factorise(-sigma).ok_or(ModesError::Singular)?;
    let mut r = vec![0.0; n * p];
    m_orthonormalise(ops, &mut v, p);
    let mut worst = f64::INFINITY;
    let mut polish = 0;
    for _ in 0..max_iterations {
        rayleigh_ritz(ops, &mut v, p);
        let checks: Vec<Check> = (0..p)
            .map(|j| check(ops, &v[j * n..(j + 1) * n], &mut r[j * n..(j + 1) * n]))
            .collect();
        let mut needed = want.min(p);
        while needed < p
            && needed > 0
            && (checks[needed].theta - checks[needed - 1].theta).abs()
                <= 1e-6 * checks[needed].theta.abs()
        {
            needed += 1;
        }
        worst = checks[..needed]
            .iter()
            .filter(|c| !c.rigid())
            .map(|c| c.residual)
            .fold(0.0, f64::max);
        if checks[..needed].iter().all(Check::converged) {
            // Two more steps past the test: a residual at the rounding floor still allows an
            // `ω²` error of `‖r‖²_(M⁻¹)/gap`, which they remove (the two paths of
            // `linear_modes` then agree on a 500-element beam to 1e-15 instead of 1e-12).
            polish += 1;
            if polish > POLISH_STEPS {
                return Ok(Block { vectors: v, checks });
            }
        } else {
            polish = 0;
        }
        // V ← V − F⁻¹ R (eq. (68)); R is exact to O(ε²), so the solve's round-off only scales
        // with the correction.
        factor.solve_in_place(&mut r, p);
        for (x, d) in v.iter_mut().zip(&r) {
            *x -= d;
        }
        if v.iter().any(|x| !x.is_finite()) {
            return Err(ModesError::Singular);
        }
        m_orthonormalise(ops, &mut v, p);
    }
    Err(ModesError::NotConverged {
        iterations: max_iterations,
        residual: worst,
    })
}

/// The `count` lowest modes from a random block (the sparse path of [`super::lowest_modes`]).
pub(super) fn lowest(ops: &Operators, count: usize) -> Result<Vec<(Check, Vec<f64>)>, ModesError> {
    let n = ops.n();
    let count = count.min(n);
    if count == 0 {
        return Ok(Vec::new());
    }
    let p = n.min((2 * count).max(count + 8));
    let v: Vec<f64> = (0..p)
        .flat_map(|j| random_vector(n, j as u64 + 1))
        .collect();
    // First step from the random block: V = F⁻¹ M V0, done by the iteration's correction with
    // the random block itself (its residual is as good a start as any).
    let block = iterate(ops, v, p, count, 500, -ops.shift())?;
    let mut take = count;
    while take < p
        && (block.checks[take].theta - block.checks[take - 1].theta).abs()
            <= 1e-6 * block.checks[take].theta.abs()
        && block.checks[take].converged()
    {
        take += 1;
    }
    Ok((0..take)
        .map(|j| (block.checks[j], block.vectors[j * n..(j + 1) * n].to_vec()))
        .collect())
}

/// Turns checked pairs into modes: rigid ones get `ω = 0`; a clearly negative `ω²` or one that
/// round-off cannot tell from zero (eq. (70)) is an error.
pub(super) fn to_modes(pairs: Vec<(Check, Vec<f64>)>) -> Result<Vec<LinearMode>, ModesError> {
    let mut modes = Vec::with_capacity(pairs.len());
    for (index, (c, shape)) in pairs.into_iter().enumerate() {
        let rigid = c.rigid();
        if !rigid && c.theta < 0.0 {
            return Err(ModesError::NegativeStiffness(c.theta));
        }
        if !rigid && c.rounding_units < ELASTIC_ROUNDING {
            return Err(ModesError::IllConditioned {
                mode: index,
                omega_squared: c.theta,
                rounding_units: c.rounding_units,
            });
        }
        modes.push(LinearMode {
            frequency: if rigid { 0.0 } else { c.theta.sqrt() },
            shape,
            rigid,
            cyclic: None,
        });
    }
    // Rigid modes first, then ascending frequency (the Ritz order, up to rigid round-off).
    modes.sort_by(|a, b| a.frequency.total_cmp(&b.frequency));
    Ok(modes)
}

/// Checks every dense mode (eqs. (69), (70)) and refines each cluster of failing ones (equal
/// `ω²` to 1e-6, so degenerate pairs stay together) by [`iterate`] with its own shift: `−τ`
/// for the modes near zero (rigid ones included), else below the cluster by a tenth of the
/// smaller gap to its neighbours (eq. (68): inverse iteration then damps every other mode by
/// 1/9 or better per step).
/// Returns the checked pairs in ascending order.
pub(super) fn refine_dense(
    ops: &Operators,
    shapes: &[f64],
    count: usize,
) -> Result<Vec<(Check, Vec<f64>)>, ModesError> {
    let n = ops.n();
    let tau = ops.shift();
    let mut r = vec![0.0; n];
    let mut pairs: Vec<(Check, Vec<f64>)> = (0..count)
        .map(|j| {
            let v = shapes[j * n..(j + 1) * n].to_vec();
            (check(ops, &v, &mut r), v)
        })
        .collect();
    let doubtful = |c: &Check| {
        !c.converged() || (!c.rigid() && c.rounding_units < ELASTIC_ROUNDING) || c.theta < 0.0
    };
    let same = |a: f64, b: f64| (a - b).abs() <= 1e-6 * a.abs().max(b.abs());
    let mut a = 0;
    while a < count {
        // The cluster starting at `a`: the modes near zero together, else equal ω².
        let low = |c: &Check| c.theta <= tau;
        let mut b = a + 1;
        while b < count
            && ((low(&pairs[a].0) && low(&pairs[b].0))
                || same(pairs[b].0.theta, pairs[b - 1].0.theta))
        {
            b += 1;
        }
        if !pairs[a..b].iter().any(|(c, _)| doubtful(c)) {
            a = b;
            continue;
        }
        let sigma = if a == 0 || low(&pairs[a].0) {
            -tau
        } else {
            let below = pairs[a].0.theta - pairs[a - 1].0.theta.max(-tau);
            let above = pairs
                .get(b)
                .map_or(below, |(c, _)| c.theta - pairs[b - 1].0.theta);
            pairs[a].0.theta - 0.1 * below.min(above)
        };
        let p = b - a;
        let v: Vec<f64> = shapes[a * n..b * n].to_vec();
        let block = iterate(ops, v, p, p, 100, sigma)?;
        // A shift placed on the wrong side of a neighbour (dense estimates off by more than
        // the gap) would converge to that neighbour again: refuse rather than duplicate it.
        if a > 0 {
            let mut m_prev = vec![0.0; n];
            ops.m.times(&pairs[a - 1].1, &mut m_prev);
            for j in 0..p {
                let overlap = linalg::dot(&block.vectors[j * n..(j + 1) * n], &m_prev);
                if overlap.abs() > 1e-6 {
                    return Err(ModesError::NotConverged {
                        iterations: 100,
                        residual: block.checks[j].residual,
                    });
                }
            }
        }
        for (j, c) in block.checks.iter().enumerate() {
            pairs[a + j] = (*c, block.vectors[j * n..(j + 1) * n].to_vec());
        }
        a = b;
    }
    pairs.sort_by(|x, y| x.0.theta.total_cmp(&y.0.theta));
    Ok(pairs)
}

/// `‖v‖_M` through the system's own mass operator (the cyclic labels' normalisation).
pub(super) fn mass_norm(mass: &dyn MassOperator, v: &[f64]) -> f64 {
    let mut mv = vec![0.0; v.len()];
    mass.apply(v, 1, &mut mv);
    linalg::dot(v, &mv).max(0.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jacobi_keeps_relative_accuracy_of_graded_matrices() {
        // diag(1e-12, 1, 1e6) with couplings far below each entry's scale.
        let p = 3;
        let mut a = vec![1e-12, 1e-20, 0.0, 1e-20, 1.0, 1e-8, 0.0, 1e-8, 1e6];
        let (values, q) = jacobi_eigen(&mut a, p);
        assert!((values[0] - 1e-12).abs() < 1e-26, "{values:?}");
        assert!((values[2] - 1e6).abs() < 1e-8);
        // Orthonormal vectors.
        for i in 0..p {
            for j in 0..p {
                let d = linalg::dot(&q[i * p..(i + 1) * p], &q[j * p..(j + 1) * p]);
                assert!((d - if i == j { 1.0 } else { 0.0 }).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn double_double_product_is_exact_where_double_cancels() {
        // (1e16 + 2) x0 − 1e16 x1 with x = (1, 1): 2 exactly, though every term is 1e16.
        let a = Csr {
            n: 1,
            row_start: vec![0, 2],
            col: vec![0, 1],
            value: vec![1e16 + 2.0, -1e16],
        };
        let (mut hi, mut lo) = ([0.0], [0.0]);
        a.times_dd(&[1.0 + f64::EPSILON, 1.0], &mut hi, &mut lo);
        // Exact: (1e16 + 2)(1 + ε) − 1e16 = 2 + (1e16 + 2) ε.
        let exact = 2.0 + (1e16 + 2.0) * f64::EPSILON;
        assert!(
            (hi[0] + lo[0] - exact).abs() < 1e-15 * exact,
            "{} {}",
            hi[0],
            lo[0]
        );
    }
}
