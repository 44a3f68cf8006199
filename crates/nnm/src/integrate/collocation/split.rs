//! The stage system of a collocation step split into `s` systems of the model's size
//! (docs/method.md eq. (32f)): exactly for a stage system whose stages share one tangent (the
//! linear part of a localised nonlinearity's, eq. (32e)), and as the preconditioner of exact
//! solves for large sparse models whose nonlinearity is everywhere.
//!
//! **Why.** The exact stage Jacobian `J = I⊗M + h (A⊗C) + h² diag(K_t(X_i)) (Ā⊗I)` (`C` a
//! forced motion's damping, eq. (96); none for free motions) is `s n × s n`; its sparse LU
//! with partial pivoting fills like a band of `2 s` times the model's: on the 10⁴-dof von
//! Kármán beam one factorisation took 26.7 ms and 21 MB, and a matrix-free integration
//! records one a step. With one tangent `K̄` for every stage, the matrix
//! `P = I⊗M + h A⊗C + h² Ā⊗K̄` is block-diagonalised by the eigenvectors of `A = T Λ T⁻¹`,
//! which are those of `Ā = A² = T Λ² T⁻¹` (Butcher 1976; Hairer & Wanner, *Solving ODEs II*,
//! §IV.8): `P = (T⊗I) diag(M + h λ_j C + h² λ_j² K̄) (T⁻¹⊗I)` — one real system per real
//! eigenvalue and one complex system per conjugate pair, each of the model's size and
//! pattern: 1.7 + 1.6 ms on the same beam, 1.8 MB for the real factors (the complex ones hold
//! twice the values on the same indices).
//!
//! **Exactness is kept.** Where the stages share their tangent, `P = J`. Elsewhere `P` serves
//! the stage Newton iteration as an approximate Jacobian (its fixed point is the same: the
//! converged stages are those of the exact method), and the variational solves `J dW = b` —
//! which must be exact, so that the monodromy is the derivative of the discrete flow that
//! shooting's Newton solves — are iterated with `P` as preconditioner until the corrections
//! no longer move the step's end state (eq. (32g)): `dW ← dW + P⁻¹ (b − J dW)`, with `J`'s
//! action from the stage tangents themselves.
//! `P⁻¹ J − I = P⁻¹ h² diag(K_t(X_i) − K̄) (Ā⊗I)` is the change of the tangent within one
//! step relative to the stage matrix, small wherever the step resolves the motion.

use std::sync::Arc;

use faer::c64;
use rayon::prelude::*;

use super::tableaux::StageMethod;
use super::tangents::StageTangents;
use crate::linalg::{Mat, SparseLu, SparseLuPattern};
use crate::model::SparseMatrix;

/// Models of more dofs than this split their stage systems (eq. (32f)) in the integrations
/// that carry no sensitivity block. Why not all: refining every recorded solve to round-off
/// costs more than the whole factorisation saves — on the von Kármán beam, matrix-free, split
/// takes half (3,000 dofs) to 40% (10⁴ dofs) of the memory and 1.65 to 1.45 times the time.
/// Above 10⁴ dofs the whole factorisations a matrix-free integration records grow past what a
/// workstation holds (~16 GB at 10⁵ dofs, ~6.5 GB split).
pub const SPLIT_DOFS: usize = 10_000;

/// Models of at least this many dofs solve their split systems (and form the stage residuals
/// of the refinement) side by side on the threads of the current pool; the results are the
/// same to the last bit. Measured on 2 cores: the 10⁴-dof von Kármán forced curve (refined
/// solves, then ~7 sweeps each) 20 min 47 s → 17 min 2 s with it; the 2,000-dof ECL beam's curve
/// (its linear part split exactly, one pass a solve) 41.5 → 41.9 s on 125% CPU: nothing
/// gained there, so the threshold is where the stage systems are split for their size.
const PARALLEL_DOFS: usize = SPLIT_DOFS;

/// Most refinement sweeps of an exact stage solve ([`SplitLu::solve_exact`]); a step whose
/// tangent changes so much that they do not suffice has a step far too long for its error
/// estimate anyway.
const MAX_REFINEMENTS: usize = 30;

/// A refinement whose correction (eq. (32g)) falls less than half in a sweep has reached the
/// round-off floor of its residual when the correction is below `FLOOR`, or below
/// `HIGH_FLOOR` after two such sweeps in a row; above, the iteration is taken as slow rather
/// than done. On the 10⁴-dof von Kármán beam the floors lie at 3e-8–3e-6 of the end state,
/// a few up to 5e-5; a second correction barely below the first happens on the way down too
/// (5.8e-4, then 5.8e-4, then 1e-5).
const FLOOR: f64 = 1e-6;
const HIGH_FLOOR: f64 = 1e-4;

/// The eigen-decomposition `A = T Λ T⁻¹` of a collocation method's `A` (so `Ā = A² =
/// T Λ² T⁻¹`), one entry per real eigenvalue and one per conjugate pair (the one with
/// `Im λ > 0`).
#[derive(Debug)]
pub(super) struct StageEigen {
    s: usize,
    /// `(λ, column of T, row of T⁻¹)`, real.
    real: Vec<(f64, Vec<f64>, Vec<f64>)>,
    /// `(λ, column of T, row of T⁻¹)`, `Im λ > 0`; its conjugate partner is implied.
    complex: Vec<(c64, Vec<c64>, Vec<c64>)>,
}

impl StageEigen {
    /// The decomposition of `a` (`s × s`); `None` if it is not diagonalisable in a
    /// well-conditioned basis (no collocation method of this crate is such).
    pub(super) fn new(a: &[Vec<f64>]) -> Option<Self> {
        let s = a.len();
        let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let a = Mat::<f64>::from_fn(s, s, |i, j| a[i][j]);
        let eigen = a.eigen().ok()?;
        let (u, values) = (eigen.U(), eigen.S());
        let t = Mat::<c64>::from_fn(s, s, |i, j| u[(i, j)]);
        let identity = Mat::<c64>::from_fn(s, s, |i, j| {
            if i == j {
                c64::new(1.0, 0.0)
            } else {
                c64::new(0.0, 0.0)
            }
        });
        let inverse = {
            use faer::linalg::solvers::Solve;
            t.partial_piv_lu().solve(&identity)
        };
        let mut real = Vec::new();
        let mut complex = Vec::new();
        for j in 0..s {
            let lambda = values.column_vector()[j];
            let column: Vec<c64> = (0..s).map(|i| t[(i, j)]).collect();
            let row: Vec<c64> = (0..s).map(|i| inverse[(j, i)]).collect();
            if lambda.im.abs() <= 1e-12 * scale {
                // A real eigenvector up to a phase, which the row of T⁻¹ carries inversely.
                let largest = column
                    .iter()
                    .copied()
                    .max_by(|a, b| a.norm().total_cmp(&b.norm()))?;
                let phase = largest / largest.norm();
                real.push((
                    lambda.re,
                    column.iter().map(|c| (c / phase).re).collect(),
                    row.iter().map(|r| (r * phase).re).collect(),
                ));
            } else if lambda.im > 0.0 {
                complex.push((lambda, column, row));
            }
        }
        (real.len() + 2 * complex.len() == s).then_some(Self { s, real, complex })
    }
}

/// The single-stage pattern the split systems are factorised on, with the decomposition of
/// `A`.
pub(in crate::integrate) struct SplitStages {
    eigen: Arc<StageEigen>,
    lu: SparseLuPattern,
    /// The single-stage pattern's entries (`M`'s, `C`'s and `K_t`'s union) in
    /// compressed-column order: their `M` and `C` values and their positions in `K_t`'s.
    entries: Vec<(f64, f64, Option<usize>)>,
    mass: Arc<SparseMatrix>,
    /// A forced motion's damping `C`; `None` for free motions.
    damping: Option<Arc<SparseMatrix>>,
    /// `A` and `Ā`, row-major.
    a: Vec<f64>,
    abar: Vec<f64>,
}

impl SplitStages {
    /// On the pattern `lu` with `entries` of one stage, for the method of coefficients
    /// `method`.
    pub(super) fn new(
        eigen: StageEigen,
        lu: SparseLuPattern,
        entries: Vec<(f64, f64, Option<usize>)>,
        (mass, damping): (&SparseMatrix, Option<&SparseMatrix>),
        method: &StageMethod,
    ) -> Self {
        Self {
            eigen: Arc::new(eigen),
            lu,
            entries,
            mass: Arc::new(mass.clone()),
            damping: damping.map(|c| Arc::new(c.clone())),
            a: method.a.iter().flatten().copied().collect(),
            abar: method.abar.iter().flatten().copied().collect(),
        }
    }

    /// The values of `M + h λ C + h² λ² K̄` on the pattern (`λ` real or complex).
    fn system_values<T: SplitScalar>(
        &self,
        lambda: T,
        h: f64,
        mean: &impl Fn(usize) -> f64,
    ) -> Vec<T> {
        let hl = lambda * h;
        let hhll = hl * hl;
        self.entries
            .iter()
            .map(|&(mass, damping, slot)| {
                T::from(mass) + hl * damping + slot.map_or(T::default(), |p| hhll * mean(p))
            })
            .collect()
    }

    /// `P` for step `h` with the stage tangents `tangents` (on the system's pattern): `K̄` is
    /// their mean (with one tangent for every stage, `P = J`). `None` if a split system is
    /// singular.
    pub(super) fn factorise(&self, h: f64, tangents: &[Vec<f64>]) -> Option<SplitLu> {
        let s = tangents.len();
        let mean = |p: usize| tangents.iter().map(|t| t[p]).sum::<f64>() / s as f64;
        let real = (self.eigen.real.iter())
            .map(|&(lambda, ..)| self.lu.factorise(&self.system_values(lambda, h, &mean)))
            .collect::<Option<Vec<_>>>()?;
        let complex = (self.eigen.complex.iter())
            .map(|&(lambda, ..)| self.lu.factorise(&self.system_values(lambda, h, &mean)))
            .collect::<Option<Vec<_>>>()?;
        Some(SplitLu {
            eigen: self.eigen.clone(),
            real,
            complex,
            mass: self.mass.clone(),
            damping: self.damping.clone(),
            h_a: self.a.iter().map(|a| h * a).collect(),
            hh_abar: self.abar.iter().map(|a| h * h * a).collect(),
        })
    }
}

/// The scalars of the split systems: `f64` for a real eigenvalue of `A`, `c64` for a pair.
trait SplitScalar:
    faer::traits::ComplexField
    + Copy
    + Default
    + From<f64>
    + std::ops::Mul<Output = Self>
    + std::ops::Add<Output = Self>
    + std::ops::Mul<f64, Output = Self>
    + std::ops::AddAssign
{
    fn real_part(self) -> f64;
}

impl SplitScalar for f64 {
    fn real_part(self) -> f64 {
        self
    }
}

impl SplitScalar for c64 {
    fn real_part(self) -> f64 {
        self.re
    }
}

/// One split system's share of `P⁻¹ b` added to `out` (`cols` columns of `s n`): `u = Σ_i
/// T⁻¹_ji b_i`, `(M + h λ_j C + h² λ_j² K̄) y = u`, `out_i += weight · Re(T_ij y)`.
fn split_solve<T: SplitScalar>(
    lu: &SparseLu<T>,
    (t, tinv): (&[T], &[T]),
    b: &[f64],
    out: &mut [f64],
    (n, cols): (usize, usize),
    weight: f64,
) {
    let m = b.len() / cols.max(1);
    let mut u = vec![T::default(); n * cols];
    for col in 0..cols {
        let uc = &mut u[col * n..(col + 1) * n];
        for (i, &w) in tinv.iter().enumerate() {
            let bi = &b[col * m + i * n..col * m + (i + 1) * n];
            uc.iter_mut().zip(bi).for_each(|(u, &b)| *u += w * b);
        }
    }
    lu.solve_in_place(&mut u, cols);
    for col in 0..cols {
        let uc = &u[col * n..(col + 1) * n];
        for (i, &w) in t.iter().enumerate() {
            let oi = &mut out[col * m + i * n..col * m + (i + 1) * n];
            oi.iter_mut()
                .zip(uc)
                .for_each(|(o, &u)| *o += weight * (w * u).real_part());
        }
    }
}

/// The buffers an exact solve's refinement sweeps reuse: one share of `P⁻¹ b` per split
/// system, and the `Σ_j Ā_ij x_j`-type combination and tangent product of each stage block;
/// and, across the solves of an integration or a replay (one a step), the right-hand side
/// kept and the residual — at 10⁴ dofs ~2.4 MB a solve if allocated afresh.
#[derive(Default)]
pub(in crate::integrate) struct Scratch {
    shares: Vec<Vec<f64>>,
    stages: Vec<(Vec<f64>, Vec<f64>)>,
    rhs: Vec<f64>,
    residual: Vec<f64>,
}

/// `P` of one step, factorised ([`SplitStages::factorise`]).
#[derive(Clone)]
pub(in crate::integrate) struct SplitLu {
    eigen: Arc<StageEigen>,
    real: Vec<SparseLu<f64>>,
    complex: Vec<SparseLu<c64>>,
    mass: Arc<SparseMatrix>,
    damping: Option<Arc<SparseMatrix>>,
    /// `h A` and `h² Ā`, row-major.
    h_a: Vec<f64>,
    hh_abar: Vec<f64>,
}

impl SplitLu {
    /// `P⁻¹ B` in place for `cols` columns of `s n` (stage-major): `(T⁻¹⊗I) b`, each split
    /// system solved, `(T⊗I)` back.
    pub(super) fn solve_in_place(&self, b: &mut [f64], cols: usize) {
        self.solve_with(b, cols, &mut Scratch::default());
    }

    /// [`Self::solve_in_place`] with the buffers of `scratch` (an exact solve's sweeps reuse
    /// them: allocated afresh, the 10⁴-dof beam's ~2.5 MB a sweep were page faults).
    fn solve_with(&self, b: &mut [f64], cols: usize, scratch: &mut Scratch) {
        let s = self.eigen.s;
        let m = b.len() / cols.max(1);
        let n = m / s;
        // One system's share of `P⁻¹ b` added to `out`: `k` counts the real systems, then the
        // pairs. A conjugate pair's partner contributes the conjugate: together, twice the
        // real part.
        let share = |k: usize, out: &mut [f64]| match self.real.get(k) {
            Some(lu) => {
                let (_, t, tinv) = &self.eigen.real[k];
                split_solve(lu, (t, tinv), b, out, (n, cols), 1.0);
            }
            None => {
                let k = k - self.real.len();
                let (_, t, tinv) = &self.eigen.complex[k];
                split_solve(&self.complex[k], (t, tinv), b, out, (n, cols), 2.0);
            }
        };
        let systems = self.real.len() + self.complex.len();
        let zeroed = |own: &mut Vec<f64>| {
            own.clear();
            own.resize(b.len(), 0.0);
        };
        let shares = &mut scratch.shares;
        if n < PARALLEL_DOFS {
            // One buffer the shares are added into in turn.
            shares.resize_with(1, Vec::new);
            let out = &mut shares[0];
            zeroed(out);
            (0..systems).for_each(|k| share(k, out));
            b.copy_from_slice(out);
            return;
        }
        // The systems are independent: solved side by side, each into its own buffer, and
        // added in the systems' order — the same sum, to the last bit, as one buffer gives
        // (each system adds one term to an entry) and on any number of threads.
        shares.resize_with(systems, Vec::new);
        shares.par_iter_mut().enumerate().for_each(|(k, own)| {
            zeroed(own);
            share(k, own);
        });
        for (i, bi) in b.iter_mut().enumerate() {
            *bi = shares.iter().fold(0.0, |sum, own| sum + own[i]);
        }
    }

    /// `J X` for `cols` columns (`s n` each): `(J x)_i = M x_i + C Σ_j h A_ij x_j +
    /// K_t(X_i) Σ_j h² Ā_ij x_j`.
    fn apply_exact(
        &self,
        x: &[f64],
        cols: usize,
        tangents: &StageTangents,
        out: &mut [f64],
        scratch: &mut Scratch,
    ) {
        let s = self.eigen.s;
        let m = x.len() / cols.max(1);
        let n = m / s;
        let pattern = self.mass.pattern();
        let values = self.mass.values();
        let combine = |weights: &[f64], xc: &[f64], i: usize, mixed: &mut [f64]| {
            mixed.fill(0.0);
            for j in 0..s {
                let a = weights[i * s + j];
                mixed
                    .iter_mut()
                    .zip(&xc[j * n..(j + 1) * n])
                    .for_each(|(y, x)| *y += a * x);
            }
        };
        // Stage `i` of column `col`: its own tangent, independent of the other stages'.
        let stage = |block: usize, oi: &mut [f64], (mixed, product): &mut (Vec<f64>, Vec<f64>)| {
            let (col, i) = (block / s, block % s);
            let xc = &x[col * m..(col + 1) * m];
            combine(&self.hh_abar, xc, i, mixed);
            tangents.apply_plain(i, mixed, product);
            if let Some(damping) = &self.damping {
                combine(&self.h_a, xc, i, mixed);
                damping.apply_add(1.0, mixed, n, 1, product, n);
            }
            let xi = &xc[i * n..(i + 1) * n];
            for (r, o) in oi.iter_mut().enumerate() {
                let span = pattern.row_start[r]..pattern.row_start[r + 1];
                let mass: f64 = pattern.col[span.clone()]
                    .iter()
                    .zip(&values[span])
                    .map(|(&c, v)| v * xi[c])
                    .sum();
                *o = mass + product[r];
            }
        };
        let out = &mut out[..cols * m];
        let buffers = &mut scratch.stages;
        buffers.resize_with(cols * s, || (vec![0.0; n], vec![0.0; n]));
        if n < PARALLEL_DOFS {
            (out.chunks_mut(n).zip(buffers.iter_mut()).enumerate())
                .for_each(|(b, (oi, buffer))| stage(b, oi, buffer));
        } else {
            (out.par_chunks_mut(n)
                .zip(buffers.par_iter_mut())
                .enumerate())
            .for_each(|(b, (oi, buffer))| stage(b, oi, buffer));
        }
    }

    /// `J⁻¹ B` to round-off, in place: `x = P⁻¹ b`, then `x += P⁻¹ (b − J x)` while the
    /// corrections still move the state the step ends in (`image`). It stops when a correction
    /// moves that state by less than its last bit, or the next one, extrapolated at the last
    /// rate, would; with `accuracy > 0`, as soon as a correction moves it by less than that
    /// fraction; and at the floor of the residual's round-off: corrections that fell less
    /// than half ([`FLOOR`]). Returns the sweeps made.
    ///
    /// Why the state and not the stage accelerations: these are largest in the unresolved
    /// stiff components, which move the state by `h²` times as little, and there the residual
    /// `b − J x` has a round-off floor (`K_t`'s largest entries times the stages' size): on the
    /// 10⁴-dof von Kármán beam (Radau9) the stage corrections fell to 2e-6–1e-5 of `x` in two
    /// or three sweeps and then wandered there, so that a test on them took 11.5 sweeps an exact
    /// solve (30, the most, for a third of them) and 18 for the parameter columns' 1e-8 —
    /// sweeps that no longer changed the products. Refinement diverges only where the tangent
    /// changes within one step by as much as the stage matrix itself, far beyond the steps an
    /// error estimate chooses.
    pub(super) fn solve_exact(
        &self,
        b: &mut [f64],
        cols: usize,
        tangents: &StageTangents,
        (accuracy, image): (f64, &StepImage),
        scratch: &mut Scratch,
    ) -> usize {
        let mut rhs = std::mem::take(&mut scratch.rhs);
        let mut residual = std::mem::take(&mut scratch.residual);
        rhs.clear();
        rhs.extend_from_slice(b);
        residual.resize(b.len(), 0.0);
        let sweeps = self.refine(
            b,
            cols,
            tangents,
            (accuracy, image),
            (&rhs, &mut residual),
            scratch,
        );
        (scratch.rhs, scratch.residual) = (rhs, residual);
        sweeps
    }

    /// The sweeps of [`Self::solve_exact`], `rhs` the right-hand side and `residual` a buffer
    /// of its size.
    fn refine(
        &self,
        b: &mut [f64],
        cols: usize,
        tangents: &StageTangents,
        (accuracy, image): (f64, &StepImage),
        (rhs, residual): (&[f64], &mut [f64]),
        scratch: &mut Scratch,
    ) -> usize {
        self.solve_with(b, cols, scratch);
        let mut previous: Option<f64> = None;
        let mut stalled = false;
        for sweep in 1..=MAX_REFINEMENTS {
            self.apply_exact(b, cols, tangents, residual, scratch);
            residual.iter_mut().zip(rhs).for_each(|(r, b)| *r = b - *r);
            self.solve_with(residual, cols, scratch);
            b.iter_mut().zip(residual.iter()).for_each(|(x, d)| *x += d);
            let relative = image.relative_change(b, residual, cols);
            if relative <= accuracy.max(f64::EPSILON) {
                return sweep;
            }
            if let Some(previous) = previous {
                let rate = relative / previous;
                if relative * rate <= f64::EPSILON {
                    return sweep;
                }
                let was_stalled = stalled;
                stalled = rate > 0.5;
                if stalled && (relative <= FLOOR || (was_stalled && relative <= HIGH_FLOOR)) {
                    return sweep;
                }
            }
            previous = Some(relative);
        }
        MAX_REFINEMENTS
    }
}

/// How a step's stage solution `dW` moves the state the step ends in (eq. (32c)):
/// `x₁ = x₀ + h v₀ + Σ_j dx_j dW_j`, `v₁ = v₀ + Σ_j dv_j dW_j` for each column of `start`
/// (`[x₀, v₀]`, `2n` a column), with `(dx_j, dv_j) = (scales.0 displacement_j, scales.1
/// velocity_j)` — what exact stage solves are judged by. Borrowed weights and their scales
/// (`h²`, `h`): built every step of every replay, it allocates nothing.
pub(in crate::integrate) struct StepImage<'a> {
    /// The weights of the stages in the displacement (`b̄_j`) and in the velocity (`b_j`),
    /// and the factors on each (`h²`, `h` for free motions).
    pub(in crate::integrate) displacement: &'a [f64],
    pub(in crate::integrate) velocity: &'a [f64],
    pub(in crate::integrate) scales: (f64, f64),
    /// The state every column starts the step from.
    pub(in crate::integrate) start: &'a [f64],
}

impl StepImage<'_> {
    /// How far `correction` (of the stage solution `dw`) moves the end state, relative to its
    /// size: the largest displacement change over the largest displacement, and the same of
    /// the velocities, in any column (each part's size at least its increment's, so that a
    /// column starting from rest is judged by what the step adds).
    fn relative_change(&self, dw: &[f64], correction: &[f64], cols: usize) -> f64 {
        let s = self.velocity.len();
        let m = dw.len() / cols.max(1);
        let (n, n2) = (m / s, self.start.len() / cols.max(1));
        let mut worst = 0.0f64;
        for col in 0..cols {
            let (dw, correction) = (
                &dw[col * m..(col + 1) * m],
                &correction[col * m..(col + 1) * m],
            );
            let start = &self.start[col * n2..(col + 1) * n2];
            let parts = [
                (0, self.displacement, self.scales.0),
                (1, self.velocity, self.scales.1),
            ];
            for (part, weights, scale) in parts {
                let (mut size, mut change) = (0.0f64, 0.0f64);
                for r in 0..n {
                    let combine = |w: &[f64]| -> f64 {
                        scale * (0..s).map(|j| weights[j] * w[j * n + r]).sum::<f64>()
                    };
                    size = size.max(start[part * n + r].abs()).max(combine(dw).abs());
                    change = change.max(combine(correction).abs());
                }
                if change > 0.0 {
                    worst = worst.max(change / size.max(f64::MIN_POSITIVE));
                }
            }
        }
        worst
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::{GAUSS4, GAUSS6, RADAU5, RADAU9};

    /// `T Λ T⁻¹` gives back `A`, and `T Λ² T⁻¹` gives back `Ā = A²`, for every collocation
    /// method, from the real eigenvalues and the conjugate pairs kept (Gauss4 has one pair,
    /// Gauss6 and Radau5 one real and one pair, Radau9 one real and two pairs).
    #[test]
    fn stage_eigen_decomposition_reconstructs_a_and_abar() {
        for (method, real) in [(&GAUSS4, 0), (&GAUSS6, 1), (&RADAU5, 1), (&RADAU9, 1)] {
            let coefficients = StageMethod::new(method);
            let s = method.c.len();
            let eigen = StageEigen::new(&coefficients.a).unwrap();
            assert_eq!(eigen.real.len(), real, "{}", method.name);
            for (power, expected) in [(1, &coefficients.a), (2, &coefficients.abar)] {
                for i in 0..s {
                    for j in 0..s {
                        let mut value: f64 = eigen
                            .real
                            .iter()
                            .map(|(lambda, t, tinv)| t[i] * lambda.powi(power) * tinv[j])
                            .sum();
                        value += eigen
                            .complex
                            .iter()
                            .map(|(lambda, t, tinv)| 2.0 * (t[i] * lambda.powi(power) * tinv[j]).re)
                            .sum::<f64>();
                        assert!(
                            (value - expected[i][j]).abs() < 1e-14,
                            "{} power {power}: ({i}, {j}) {value} vs {}",
                            method.name,
                            expected[i][j]
                        );
                    }
                }
            }
        }
    }
}
