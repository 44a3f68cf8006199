//! Polynomial internal forces given as sparse tensors: the quadratic and cubic terms of a
//! geometrically nonlinear finite-element model reduced or exported term by term
//! (docs/method.md eqs. (57)–(60)).

use std::collections::BTreeMap;

use super::{Block, BlockMut, FixedDofs, NonlinearElement};
use crate::linalg;

/// `f_i(x) = Σ c x_j x_k` over the quadratic terms `(i, j, k, c)` plus `Σ c x_j x_k x_l` over
/// the cubic terms `(i, j, k, l, c)` (0-based dofs; docs/method.md eq. (57)).
///
/// Built only when the force derives from a potential (eq. (59): the coefficients averaged
/// over the trailing indices form a fully symmetric tensor), so that
/// `V = ⅓ xᵀ f₂(x) + ¼ xᵀ f₃(x)` (eq. (58), Euler's theorem for homogeneous forms) is its
/// potential and the energy the continuation plots is conserved. Terms are kept as given,
/// grouped by row (repeated positions add up); force, tangent and potential cost `O(terms)`,
/// and the tangent is given on the element's own sparse pattern (eq. (60)), never as a dense
/// block over the dofs it touches.
#[derive(Debug, Clone, PartialEq)]
pub struct PolynomialTensor {
    dofs: usize,
    quadratic: Terms<2>,
    cubic: Terms<3>,
    /// Tangent positions `(i, t_p)` of every term, quadratic then cubic (eq. (60)).
    pattern: Vec<(usize, usize)>,
}

/// A force given term by term in global dofs (0-based; docs/method.md eq. (57)):
/// `f_i += c x_j x_k` for each quadratic term `(i, [j, k], c)` and `f_i += c x_j x_k x_l` for
/// each cubic term `(i, [j, k, l], c)`, a position repeated adding up. What
/// [`NonlinearElement::polynomial_terms`] gives and a [`PolynomialTensor`] is built from: the
/// form in which a model's nonlinear force is written to term files (`nnm export`) and read
/// back by a `tensor` element.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PolynomialTerms {
    /// `(i, [j, k], c)`: `f_i += c x_j x_k`.
    pub quadratic: Vec<(usize, [usize; 2], f64)>,
    /// `(i, [j, k, l], c)`: `f_i += c x_j x_k x_l`.
    pub cubic: Vec<(usize, [usize; 3], f64)>,
}

impl PolynomialTerms {
    /// Adds `other`'s terms to these (the forces add up).
    pub fn append(&mut self, mut other: PolynomialTerms) {
        self.quadratic.append(&mut other.quadratic);
        self.cubic.append(&mut other.cubic);
    }

    /// The same force with one term per position: the trailing indices sorted (the monomial
    /// `x_j x_k` does not depend on their order), the coefficients of a position summed,
    /// positions ascending. Why: the elements of a mesh share dofs, and a file of one term per
    /// monomial is several times shorter than the elements' terms side by side.
    ///
    /// A position whose sum `Σ c` cancels to within its round-off, `|Σ c| ≤ (16 + m) u Σ |c|`
    /// for `m` contributions (`u` the unit round-off), is left out: it is zero as far as the
    /// coefficients can tell. Each carries up to `16 u` of its own computation (a von Kármán
    /// element's quadrature of products) and the sum adds `m u`; the `x_w x_θ³` terms of two
    /// neighbouring von Kármán elements, for one, cancel exactly in theory and to `5 u` of their
    /// size in floating point, and would otherwise be written as noise.
    pub fn summed(self) -> Self {
        fn sum<const N: usize>(
            terms: Vec<(usize, [usize; N], f64)>,
        ) -> Vec<(usize, [usize; N], f64)> {
            // Per position: the sum, the sum of magnitudes and the number of contributions.
            let mut by_key: BTreeMap<(usize, [usize; N]), (f64, f64, f64)> = BTreeMap::new();
            for (i, mut t, c) in terms {
                t.sort_unstable();
                let entry = by_key.entry((i, t)).or_insert((0.0, 0.0, 0.0));
                *entry = (entry.0 + c, entry.1 + c.abs(), entry.2 + 1.0);
            }
            by_key
                .into_iter()
                .filter(|&(_, (c, size, m))| c.abs() > (16.0 + m) * f64::EPSILON * size)
                .map(|((i, t), (c, _, _))| (i, t, c))
                .collect()
        }
        Self {
            quadratic: sum(self.quadratic),
            cubic: sum(self.cubic),
        }
    }

    /// Whether there are no terms (no nonlinear force).
    pub fn is_empty(&self) -> bool {
        self.quadratic.is_empty() && self.cubic.is_empty()
    }

    /// The tensor element of these terms on a model of `dofs` dofs, checked as
    /// [`PolynomialTensor::new`] checks them (range, finiteness, eq. (59)).
    pub fn into_tensor(self, dofs: usize) -> Result<PolynomialTensor, TensorError> {
        Ok(PolynomialTensor::from_terms(
            dofs,
            Terms::new(dofs, self.quadratic)?,
            Terms::new(dofs, self.cubic)?,
        ))
    }
}

/// One term `(i, [t_1 … t_N], c)`: `f_i += c Π_p x_{t_p}`.
type Term<const N: usize> = (usize, [usize; N], f64);

/// Terms `f_i += c Π_p x_{t_p}` of one degree `N`.
#[derive(Debug, Clone, PartialEq)]
struct Terms<const N: usize> {
    /// `(i, [t_1 … t_N], c)`, grouped by row.
    terms: Vec<(usize, [usize; N], f64)>,
    /// The same terms as the force and the tangent read them (`terms` serves validation,
    /// reduction and export).
    compact: CompactTerms<N>,
}

/// Terms grouped by row in the fewest bytes, each naming its monomial among the distinct
/// ones: a row's index once, a 32-bit monomial index and the coefficient a term, the
/// monomials' 32-bit factors once. Why: a force evaluation streams every term, at 10⁴ dofs
/// 330k of them, beyond the per-core cache; and a mesh's terms share their monomials (the
/// rows of an element's dofs all hold its products) — the exported 10⁴-dof von Kármán beam
/// has 193k cubic terms on 53k monomials and 137k quadratic ones on 43k — so that each
/// monomial is formed once an evaluation, to twice the precision where the row sums need
/// it (eq. (57a)), rather than once a term: the imported 1,000-element beam's first six
/// points 31.6 → 31.0 s (three runs each, alternated), where the row sums' accurate pass,
/// not the products, is the cost.
#[derive(Debug, Clone, PartialEq)]
struct CompactTerms<const N: usize> {
    /// `(i, end)`: row `i`'s terms end at `end` (and start at the previous row's end).
    rows: Vec<(u32, u32)>,
    /// Each term's monomial: an index into `monomials`.
    monomial: Vec<u32>,
    coefficients: Vec<f64>,
    /// The distinct monomials' factors (sorted), in the order the rows first name them.
    monomials: Vec<[u32; N]>,
}

impl<const N: usize> CompactTerms<N> {
    /// From terms grouped by row; indices must fit 32 bits (a model of fewer than 2³²
    /// dofs, and as many terms).
    fn new(terms: &[Term<N>]) -> Self {
        let index = |i: usize| u32::try_from(i).expect("a dof index below 2^32");
        let mut rows: Vec<(u32, u32)> = Vec::new();
        let mut numbering: std::collections::HashMap<[u32; N], u32> =
            std::collections::HashMap::new();
        let mut monomials = Vec::new();
        let mut monomial = Vec::with_capacity(terms.len());
        for (k, &(i, t, _)) in terms.iter().enumerate() {
            let end = index(k + 1);
            match rows.last_mut() {
                Some(last) if last.0 == index(i) => last.1 = end,
                _ => rows.push((index(i), end)),
            }
            let mut factors = t.map(index);
            factors.sort_unstable();
            let next = index(monomials.len());
            let m = *numbering.entry(factors).or_insert(next);
            if m == next {
                monomials.push(factors);
            }
            monomial.push(m);
        }
        Self {
            rows,
            monomial,
            coefficients: terms.iter().map(|&(_, _, c)| c).collect(),
            monomials,
        }
    }

    /// Each row's index with its terms' monomials and coefficients.
    fn rows(&self) -> impl Iterator<Item = (usize, &[u32], &[f64])> {
        let starts = std::iter::once(0).chain(self.rows.iter().map(|&(_, end)| end as usize));
        self.rows.iter().zip(starts).map(|(&(i, end), start)| {
            let span = start..end as usize;
            (
                i as usize,
                &self.monomial[span.clone()],
                &self.coefficients[span],
            )
        })
    }

    /// Each term's factors and coefficient, in the terms' order.
    fn terms(&self) -> impl Iterator<Item = (&[u32; N], f64)> {
        (self.monomial.iter().zip(&self.coefficients))
            .map(|(&m, &c)| (&self.monomials[m as usize], c))
    }

    /// Every monomial's value at `x` to twice the working precision, `head + tail`
    /// (`|tail| ≤ N u |head|`; error-free products, the tails carried plainly), into
    /// `values`. Heads and tails apart: a row's plain sum reads only the heads. Inlined into
    /// [`linalg::with_fused_multiply_add`], as its error-free products need.
    #[inline(always)]
    fn monomial_values(&self, x: &[f64], values: &mut MonomialValues) {
        let (heads, tails) = values;
        heads.clear();
        tails.clear();
        for t in &self.monomials {
            let (head, tail) =
                t[1..]
                    .iter()
                    .fold((x[t[0] as usize], 0.0f64), |(head, tail), &d| {
                        let (p, e) = linalg::exact_product(head, x[d as usize]);
                        (p, tail.mul_add(x[d as usize], e))
                    });
            heads.push(head);
            tails.push(tail);
        }
    }
}

/// The monomials' values, heads and tails ([`CompactTerms::monomial_values`]).
type MonomialValues = (Vec<f64>, Vec<f64>);

thread_local! {
    /// The monomials' values of the last evaluation on this thread: ~1.5 MB at 10⁴ dofs,
    /// allocated once a thread rather than once an evaluation.
    static MONOMIALS: std::cell::RefCell<MonomialValues> =
        const { std::cell::RefCell::new((Vec::new(), Vec::new())) };
}

/// Why a polynomial tensor is refused. Indices are 0-based in the library;
/// [`TensorError::describe`] writes them in another base (job files count from 1).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TensorError {
    /// A term names a dof the model does not have.
    #[error("{}", self.describe(0))]
    OutOfRange {
        /// `"quadratic"` or `"cubic"`.
        degree: &'static str,
        /// The term's position among the terms of its degree (0-based).
        term: usize,
        /// The offending dof.
        dof: usize,
        /// The model's number of dofs.
        dofs: usize,
    },
    /// A coefficient is NaN or infinite.
    #[error("{}", self.describe(0))]
    NotFinite {
        /// `"quadratic"` or `"cubic"`.
        degree: &'static str,
        /// The term's position among the terms of its degree (0-based).
        term: usize,
        /// The coefficient.
        value: f64,
    },
    /// The force is not a gradient (eq. (59) fails): two averaged coefficients that must be
    /// equal differ.
    #[error("{}", self.describe(0))]
    NotGradient {
        /// `"quadratic"` or `"cubic"`.
        degree: &'static str,
        /// `[i, j, k]` (or `[i, j, k, l]`) of the first averaged coefficient.
        first: Vec<usize>,
        /// Its value `S_ijk…`.
        first_value: f64,
        /// The index permutation whose coefficient should equal it.
        second: Vec<usize>,
        /// Its value.
        second_value: f64,
    },
}

impl TensorError {
    /// The message with indices counted from `base` (0 in the library, 1 in job files).
    pub fn describe(&self, base: usize) -> String {
        let list = |v: &[usize]| {
            v.iter()
                .map(|d| (d + base).to_string())
                .collect::<Vec<_>>()
                .join(", ")
        };
        match self {
            TensorError::OutOfRange {
                degree,
                term,
                dof,
                dofs,
            } => format!(
                "{degree} term {} uses dof {}, but the model has {dofs} dofs ({base}-based)",
                term + base,
                dof + base
            ),
            TensorError::NotFinite {
                degree,
                term,
                value,
            } => format!(
                "{degree} term {} has a non-finite coefficient {}",
                term + base,
                crate::number::Number(*value)
            ),
            TensorError::NotGradient {
                degree,
                first,
                first_value,
                second,
                second_value,
            } => format!(
                "{degree} terms are not the gradient of a potential: the coefficients averaged over \
                 the trailing indices must be symmetric in all indices, but S({}) = {first_value:e} \
                 and S({}) = {second_value:e} ({base}-based)",
                list(first),
                list(second)
            ),
        }
    }
}

/// A row of the force cancelling more than this factor is summed again in twice the
/// precision (eq. (57a)). Lower than a stiffness row's [`linalg::CANCELLATION`] because the
/// plain round-off of the rows under it, not of the few above, is what remains: on a smooth
/// field of the 1,000-element von Kármán beam's exported terms the force kept 4.3e-6 (of
/// its largest entry) of noise summed plainly, 4e-8 redone above 10⁸-fold, 2.2e-10 above
/// 10⁶ (1,912 of 1,998 cubic rows redone), 6e-13 above 10⁴. At 20 elements 10⁶ redoes 11
/// rows of 95 (those that vanish by symmetry among them).
const ROW_CANCELLATION: f64 = 1e6;

/// Relative tolerance of the gradient check (eq. (59)), on the largest `|c|` of the degree:
/// coefficients computed in floating point by a finite-element code carry round-off.
const GRADIENT_TOLERANCE: f64 = 1e-10;

impl<const N: usize> Terms<N> {
    const DEGREE: &'static str = if N == 2 { "quadratic" } else { "cubic" };

    /// Validates range and finiteness, then the gradient condition (eq. (59)).
    fn new(dofs: usize, terms: Vec<(usize, [usize; N], f64)>) -> Result<Self, TensorError> {
        let degree = Self::DEGREE;
        for (term, &(i, t, c)) in terms.iter().enumerate() {
            if let Some(&dof) = std::iter::once(&i).chain(&t).find(|&&d| d >= dofs) {
                return Err(TensorError::OutOfRange {
                    degree,
                    term,
                    dof,
                    dofs,
                });
            }
            if !c.is_finite() {
                return Err(TensorError::NotFinite {
                    degree,
                    term,
                    value: c,
                });
            }
        }
        let terms = Self::by_row(terms);
        terms.check_gradient()?;
        Ok(terms)
    }

    /// Eq. (59): `S_{i t}` — the coefficients averaged over the orderings of the trailing
    /// indices `t` — must not change when `i` is swapped with any trailing index. Each term
    /// adds `c / (number of distinct orderings of t)` to the key `(i, sorted t)`; then every
    /// key is compared with the keys of the same index multiset led by each other index (a
    /// missing key is a zero). `O(terms log terms)`.
    fn check_gradient(&self) -> Result<(), TensorError> {
        let mut averaged: BTreeMap<(usize, [usize; N]), f64> = BTreeMap::new();
        let mut scale: f64 = 0.0;
        for &(i, mut t, c) in &self.terms {
            t.sort_unstable();
            *averaged.entry((i, t)).or_insert(0.0) += c / orderings(&t);
            scale = scale.max(c.abs());
        }
        for (&(i, t), &value) in &averaged {
            for p in 0..N {
                if t[p] == i || (p > 0 && t[p] == t[p - 1]) {
                    continue;
                }
                // Swap i with t[p]: lead index t[p], trailing t with t[p] replaced by i.
                let mut swapped = t;
                swapped[p] = i;
                swapped.sort_unstable();
                let other = averaged.get(&(t[p], swapped)).copied().unwrap_or(0.0);
                if (value - other).abs() > GRADIENT_TOLERANCE * scale {
                    return Err(TensorError::NotGradient {
                        degree: Self::DEGREE,
                        first: std::iter::once(i).chain(t).collect(),
                        first_value: value,
                        second: std::iter::once(t[p]).chain(swapped).collect(),
                        second_value: other,
                    });
                }
            }
        }
        Ok(())
    }

    /// The terms without the fixed dofs (docs/method.md eq. (61)): a term that contains a
    /// fixed dof among its factors vanishes (`x = 0` there), a term on a fixed dof's row is
    /// the support's reaction, not a force on the reduced model.
    fn reduced(&self, fixed: &FixedDofs) -> Self {
        let terms = self
            .terms
            .iter()
            .filter_map(|&(i, t, c)| {
                let i = fixed.reduced_index(i)?;
                let mut r = [0; N];
                for (r, &d) in r.iter_mut().zip(&t) {
                    *r = fixed.reduced_index(d)?;
                }
                Some((i, r, c))
            })
            .collect();
        Self::by_row(terms)
    }

    /// The terms grouped by row (stably: a row's terms in the order given), so that a row's
    /// sum is formed in one place and can be redone when it cancels ([`Self::row_force`]).
    fn by_row(mut terms: Vec<Term<N>>) -> Self {
        terms.sort_by_key(|&(i, _, _)| i);
        let compact = CompactTerms::new(&terms);
        Self { terms, compact }
    }

    /// `Π_{q ≠ p} x_{t_q}`: the derivative of the term's monomial by its `p`-th factor.
    #[inline]
    fn others(t: &[u32; N], p: usize, x: &[f64]) -> f64 {
        (0..N)
            .filter(|&q| q != p)
            .map(|q| x[t[q] as usize])
            .product()
    }

    /// `init + Σ c m` over one row's terms, `m` their monomials' values (`head + tail`, twice
    /// the working precision), the sum redone in twice the working precision when the terms
    /// cancel (eq. (57a)): the expanded polynomial of a fine mesh spells a strain's power — a
    /// difference of neighbouring dofs cubed — as monomials, which on a smooth field cancel
    /// like `(λ/h)³`, ~1e9 at 10⁴ dofs, where the element forms the difference first. Summed
    /// plainly, that round-off (3e-7–9e-7 of the shooting residual at 10⁴ dofs) was what the
    /// corrector stalled on.
    #[inline]
    fn row_force(
        init: f64,
        (monomials, coefficients): (&[u32], &[f64]),
        (heads, tails): (&[f64], &[f64]),
    ) -> f64 {
        let row = || monomials.iter().zip(coefficients);
        linalg::cancelling_sum(
            init,
            row().map(|(&m, &c)| c * heads[m as usize]),
            || {
                row().map(|(&m, &c)| {
                    let (p, e) = linalg::exact_product(c, heads[m as usize]);
                    (p, c.mul_add(tails[m as usize], e))
                })
            },
            ROW_CANCELLATION,
        )
    }

    /// `work` on the monomials' values at `x`, formed on this thread's buffer.
    fn with_monomials<R>(&self, x: &[f64], work: impl FnOnce((&[f64], &[f64])) -> R) -> R {
        MONOMIALS.with(|values| {
            let values = &mut *values.borrow_mut();
            linalg::with_fused_multiply_add(
                #[inline(always)]
                || self.compact.monomial_values(x, values),
            );
            work((&values.0, &values.1))
        })
    }

    fn add_force(&self, x: &[f64], f: &mut [f64]) {
        self.with_monomials(x, |values| {
            for (i, monomials, coefficients) in self.compact.rows() {
                f[i] = Self::row_force(f[i], (monomials, coefficients), values);
            }
        })
    }

    /// `xᵀ f_N(x)`, i.e. `(N + 1) V_N` (eq. (58)), from the rows' sums (which cancel as the
    /// force's do).
    fn x_dot_force(&self, x: &[f64]) -> f64 {
        self.with_monomials(x, |values| {
            (self.compact.rows())
                .map(|(i, monomials, coefficients)| {
                    x[i] * Self::row_force(0.0, (monomials, coefficients), values)
                })
                .sum()
        })
    }

    fn add_tangent_product(&self, x: &[f64], dx: &[f64], out: &mut [f64]) {
        let compact = &self.compact;
        for (i, monomials, coefficients) in compact.rows() {
            for (&m, &c) in monomials.iter().zip(coefficients) {
                let t = &compact.monomials[m as usize];
                let d: f64 = (0..N)
                    .map(|p| dx[t[p] as usize] * Self::others(t, p, x))
                    .sum();
                out[i] += c * d;
            }
        }
    }

    /// Tangent positions `(i, t_p)` of every term, in the order of [`Self::tangent_values`].
    fn pattern(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        let compact = &self.compact;
        compact.rows().flat_map(move |(i, monomials, _)| {
            monomials
                .iter()
                .flat_map(move |&m| compact.monomials[m as usize].map(|d| (i, d as usize)))
        })
    }

    /// `∂(c Π x_t)/∂x_{t_p} = c Π_{q≠p} x_{t_q}` at each position of [`Self::pattern`].
    fn tangent_values(&self, x: &[f64], out: &mut [f64]) {
        for ((t, c), o) in self.compact.terms().zip(out.chunks_exact_mut(N)) {
            for (p, o) in o.iter_mut().enumerate() {
                *o = c * Self::others(t, p, x);
            }
        }
    }
}

/// Number of distinct orderings of a sorted index list (`N! / Π multiplicity!`).
fn orderings(t: &[usize]) -> f64 {
    let mut count = 1.0;
    let mut denominator = 1.0;
    let mut run = 1.0;
    for (p, w) in t.iter().enumerate() {
        count *= (p + 1) as f64;
        if p > 0 && t[p - 1] == *w {
            run += 1.0;
            denominator *= run;
        } else {
            run = 1.0;
        }
    }
    count / denominator
}

impl PolynomialTensor {
    /// The force of quadratic terms `(i, j, k, c)`: `f_i += c x_j x_k` and cubic terms
    /// `(i, j, k, l, c)`: `f_i += c x_j x_k x_l` on a model of `dofs` dofs (0-based indices).
    /// Refused: an index `≥ dofs`, a non-finite coefficient, or a force that is not a
    /// gradient (eq. (59), to `1e-10` of the degree's largest `|c|`).
    pub fn new(
        dofs: usize,
        quadratic: Vec<(usize, usize, usize, f64)>,
        cubic: Vec<(usize, usize, usize, usize, f64)>,
    ) -> Result<Self, TensorError> {
        let quadratic = quadratic
            .into_iter()
            .map(|(i, j, k, c)| (i, [j, k], c))
            .collect();
        let cubic = cubic
            .into_iter()
            .map(|(i, j, k, l, c)| (i, [j, k, l], c))
            .collect();
        Ok(Self::from_terms(
            dofs,
            Terms::new(dofs, quadratic)?,
            Terms::new(dofs, cubic)?,
        ))
    }

    fn from_terms(dofs: usize, quadratic: Terms<2>, cubic: Terms<3>) -> Self {
        let pattern = quadratic.pattern().chain(cubic.pattern()).collect();
        Self {
            dofs,
            quadratic,
            cubic,
            pattern,
        }
    }

    /// Number of dofs of the model the tensor was built for.
    pub fn dofs(&self) -> usize {
        self.dofs
    }

    /// Number of quadratic and of cubic terms.
    pub fn terms(&self) -> (usize, usize) {
        (self.quadratic.terms.len(), self.cubic.terms.len())
    }

    /// The same force on the model with `fixed`'s dofs held at zero and removed
    /// (docs/method.md eq. (61)), in the reduced numbering. It is again a gradient: the
    /// potential restricted to the free dofs.
    pub fn reduced(&self, fixed: &FixedDofs) -> Self {
        Self::from_terms(
            fixed.free_dofs().len(),
            self.quadratic.reduced(fixed),
            self.cubic.reduced(fixed),
        )
    }
}

impl NonlinearElement for PolynomialTensor {
    fn add_force(&self, x: &[f64], f: &mut [f64]) {
        self.quadratic.add_force(x, f);
        self.cubic.add_force(x, f);
    }

    fn add_tangent_product(&self, x: &[f64], dx: Block<'_>, out: &mut BlockMut<'_>) {
        for c in 0..dx.cols {
            let (d, o) = (dx.col(c), out.col_mut(c));
            self.quadratic.add_tangent_product(x, d, o);
            self.cubic.add_tangent_product(x, d, o);
        }
    }

    fn tangent_pattern(&self) -> Option<Vec<(usize, usize)>> {
        Some(self.pattern.clone())
    }

    fn tangent_values(&self, x: &[f64], out: &mut [f64]) {
        let split = 2 * self.quadratic.terms.len();
        self.quadratic.tangent_values(x, &mut out[..split]);
        self.cubic.tangent_values(x, &mut out[split..]);
    }

    fn potential(&self, x: &[f64]) -> f64 {
        self.quadratic.x_dot_force(x) / 3.0 + self.cubic.x_dot_force(x) / 4.0
    }

    /// Its own terms, as given (grouped by row): the force is this polynomial by definition.
    fn polynomial_terms(&self) -> Option<PolynomialTerms> {
        Some(PolynomialTerms {
            quadratic: self.quadratic.terms.clone(),
            cubic: self.cubic.terms.clone(),
        })
    }

    fn dofs_used(&self) -> Vec<usize> {
        let mut used: Vec<usize> = self.pattern.iter().flat_map(|&(i, j)| [i, j]).collect();
        used.sort_unstable();
        used.dedup();
        used
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Matrix, MechanicalSystem, SparseMatrix, Structure};

    /// Deterministic pseudo-random numbers in `[-1, 1)` (xorshift; no test dependency).
    struct Random(u64);
    impl Random {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        }
        fn index(&mut self, n: usize) -> usize {
            ((self.next() + 1.0) * 0.5 * n as f64) as usize % n
        }
    }

    /// The gradient of random monomials `a Π x_{m_q}` (repeated factors included): for each
    /// factor `p`, the term `(m_p; the others, a)`, with the trailing indices in a random order
    /// and the coefficient sometimes split over two orderings. A gradient by construction.
    fn random_gradient(n: usize, monomials: usize, rng: &mut Random) -> PolynomialTensor {
        let (mut quadratic, mut cubic) = (Vec::new(), Vec::new());
        for m in 0..monomials {
            let a = rng.next() + 2.0 * rng.next().signum();
            let degree = 3 + m % 2;
            let factors: Vec<usize> = (0..degree).map(|_| rng.index(n)).collect();
            for p in 0..degree {
                let mut others: Vec<usize> = (0..degree)
                    .filter(|&q| q != p)
                    .map(|q| factors[q])
                    .collect();
                if rng.next() > 0.0 {
                    others.reverse();
                }
                let share = if rng.next() > 0.0 { 0.3 } else { 1.0 };
                for (c, o) in [
                    (share * a, others.clone()),
                    ((1.0 - share) * a, {
                        others.rotate_left(1);
                        others
                    }),
                ] {
                    if c == 0.0 {
                        continue;
                    }
                    match o[..] {
                        [j, k] => quadratic.push((factors[p], j, k, c)),
                        [j, k, l] => cubic.push((factors[p], j, k, l, c)),
                        _ => unreachable!(),
                    }
                }
            }
        }
        PolynomialTensor::new(n, quadratic, cubic).expect("a gradient by construction")
    }

    fn force(e: &dyn NonlinearElement, x: &[f64]) -> Vec<f64> {
        let mut f = vec![0.0; x.len()];
        e.add_force(x, &mut f);
        f
    }

    /// Force = gradient of the potential (eq. (58)) and tangent = Jacobian of the force
    /// (eq. (60)), by central differences at random states; the tangent on the element's own
    /// pattern and its product with a block agree with each other.
    #[test]
    fn force_and_tangent_are_derivatives() {
        let mut rng = Random(0x9e37_79b9_7f4a_7c15);
        let n = 6;
        for trial in 0..5 {
            let e = random_gradient(n, 8, &mut rng);
            assert!(e.terms().0 > 0 && e.terms().1 > 0);
            let x: Vec<f64> = (0..n).map(|_| rng.next()).collect();
            let f = force(&e, &x);
            let h = 1e-5;
            // Dense tangent from the pattern values.
            let pattern = e.tangent_pattern().unwrap();
            let mut values = vec![f64::NAN; pattern.len()];
            e.tangent_values(&x, &mut values);
            let mut tangent = vec![0.0; n * n];
            for (&(i, j), v) in pattern.iter().zip(&values) {
                tangent[j * n + i] += v;
            }
            let eye: Vec<f64> = (0..n * n)
                .map(|k| if k % (n + 1) == 0 { 1.0 } else { 0.0 })
                .collect();
            let mut product = vec![0.0; n * n];
            e.add_tangent_product(
                &x,
                Block::new(&eye, n, n, n),
                &mut BlockMut::new(&mut product, n, n, n),
            );
            let scale = f.iter().fold(1.0_f64, |s, v| s.max(v.abs()));
            for m in 0..n {
                let (mut xp, mut xm) = (x.clone(), x.clone());
                xp[m] += h;
                xm[m] -= h;
                let dv = (e.potential(&xp) - e.potential(&xm)) / (2.0 * h);
                assert!(
                    (dv - f[m]).abs() < 1e-8 * scale,
                    "trial {trial}, dof {m}: dV = {dv}, f = {}",
                    f[m]
                );
                let (fp, fm) = (force(&e, &xp), force(&e, &xm));
                for i in 0..n {
                    let fd = (fp[i] - fm[i]) / (2.0 * h);
                    let t = tangent[m * n + i];
                    assert!((fd - t).abs() < 1e-8 * scale, "trial {trial}: {fd} vs {t}");
                    assert!((product[m * n + i] - t).abs() < 1e-13 * scale);
                }
            }
            // The tangent of a gradient is symmetric.
            for i in 0..n {
                for j in 0..n {
                    assert!((tangent[j * n + i] - tangent[i * n + j]).abs() < 1e-13 * scale);
                }
            }
        }
    }

    /// A tensor's own terms, one per position once summed (fewer than given: the random
    /// gradients split coefficients over orderings), read back give its force.
    #[test]
    fn summed_terms_give_the_same_force() {
        let mut rng = Random(7);
        let n = 5;
        for _ in 0..3 {
            let e = random_gradient(n, 10, &mut rng);
            let terms = e.polynomial_terms().expect("its own terms");
            assert_eq!((terms.quadratic.len(), terms.cubic.len()), e.terms());
            let summed = terms.summed();
            assert!(summed.quadratic.len() + summed.cubic.len() < e.terms().0 + e.terms().1);
            for (_, t, c) in &summed.quadratic {
                assert!(t[0] <= t[1] && *c != 0.0);
            }
            let back = summed.into_tensor(n).expect("a gradient");
            let x: Vec<f64> = (0..n).map(|_| rng.next()).collect();
            let (f, g) = (force(&e, &x), force(&back, &x));
            let scale = f.iter().fold(1.0_f64, |s, v| s.max(v.abs()));
            for (a, b) in f.iter().zip(&g) {
                assert!((a - b).abs() < 1e-14 * scale, "{a} vs {b}");
            }
        }
    }

    /// A position that cancels to round-off is dropped, a small one that does not is kept.
    #[test]
    fn summed_terms_drop_round_off_cancellation() {
        let terms = PolynomialTerms {
            quadratic: vec![
                (0, [1, 0], 0.1 + 0.2),
                (0, [0, 1], -0.3),
                (1, [1, 1], 1e-20),
                (1, [0, 0], 0.0),
            ],
            cubic: vec![(2, [2, 1, 0], 3.0), (2, [0, 1, 2], -1.0)],
        }
        .summed();
        assert_eq!(terms.quadratic, vec![(1, [1, 1], 1e-20)]);
        assert_eq!(terms.cubic, vec![(2, [0, 1, 2], 2.0)]);
    }

    /// `f_0 = x_1²` alone is not a gradient (`f_1 = 2 x_0 x_1` is missing); the error names
    /// the two averaged coefficients. Completed, it is accepted; a 1e-14 relative perturbation
    /// is round-off and accepted, a 1e-6 one is not.
    #[test]
    fn non_gradient_tensors_are_refused() {
        let e = PolynomialTensor::new(3, vec![(0, 1, 1, 1.0)], vec![]).unwrap_err();
        assert_eq!(
            e,
            TensorError::NotGradient {
                degree: "quadratic",
                first: vec![0, 1, 1],
                first_value: 1.0,
                second: vec![1, 0, 1],
                second_value: 0.0,
            }
        );
        let message = e.describe(1);
        assert!(!message.contains('\n'));
        assert!(
            message.contains("S(1, 2, 2) = 1e0 and S(2, 1, 2) = 0e0 (1-based)"),
            "{message}"
        );
        // f_1 = 2 x_0 x_1 given as two orderings.
        for (c, ok) in [(1.0, true), (1.0 + 1e-14, true), (1.0 + 1e-6, false)] {
            let t = PolynomialTensor::new(
                3,
                vec![(0, 1, 1, 1.0), (1, 0, 1, c), (1, 1, 0, 1.0)],
                vec![],
            );
            assert_eq!(t.is_ok(), ok, "{c}: {t:?}");
        }
        // Cubic: f_0 = x_1 x_2 x_2 needs f_1 = x_0 x_2² and f_2 = 2 x_0 x_1 x_2.
        let partial = vec![(0, 1, 2, 2, 1.0), (1, 0, 2, 2, 1.0)];
        let e = PolynomialTensor::new(3, vec![], partial.clone()).unwrap_err();
        assert!(
            matches!(&e, TensorError::NotGradient { degree: "cubic", second, .. } if second[0] == 2),
            "{e}"
        );
        let mut full = partial;
        full.push((2, 0, 1, 2, 1.0));
        full.push((2, 2, 1, 0, 1.0));
        assert!(PolynomialTensor::new(3, vec![], full).is_ok());
    }

    #[test]
    fn out_of_range_and_non_finite_terms_are_refused() {
        assert_eq!(
            PolynomialTensor::new(2, vec![(0, 0, 2, 1.0)], vec![]).unwrap_err(),
            TensorError::OutOfRange {
                degree: "quadratic",
                term: 0,
                dof: 2,
                dofs: 2
            }
        );
        let e = PolynomialTensor::new(2, vec![], vec![(0, 0, 0, 0, 1.0), (1, 1, 1, 1, f64::NAN)])
            .unwrap_err();
        assert!(
            matches!(
                e,
                TensorError::NotFinite {
                    degree: "cubic",
                    term: 1,
                    ..
                }
            ),
            "{e}"
        );
        let e = PolynomialTensor::new(2, vec![], vec![(5, 0, 0, 0, f64::INFINITY)]).unwrap_err();
        assert!(matches!(e, TensorError::OutOfRange { dof: 5, .. }), "{e}");
    }

    /// A `Structure` with a sparse `K` and a tensor keeps an assembled tangent pattern
    /// (the implicit integrator's sparse LU needs it), whose values are `K + ∂f/∂x`.
    #[test]
    fn structure_assembles_the_tensor_tangent_on_its_pattern() {
        let mut rng = Random(42);
        let n = 7;
        let chain: Vec<(usize, usize, f64)> = (0..n)
            .flat_map(|i| {
                let mut t = vec![(i, i, 2.0)];
                if i + 1 < n {
                    t.extend([(i, i + 1, -1.0), (i + 1, i, -1.0)]);
                }
                t
            })
            .collect();
        let k = SparseMatrix::from_triplets(n, &chain).unwrap();
        let tensor = random_gradient(n, 6, &mut rng);
        let s = Structure::new(
            Matrix::identity(n),
            k,
            vec![
                Box::new(tensor),
                Box::new(crate::model::PolynomialSpring::cubic(0, Some(3), 0.4)),
            ],
        )
        .unwrap();
        let pattern = s.tangent_pattern().expect("an assembled pattern").clone();
        let x: Vec<f64> = (0..n).map(|_| rng.next()).collect();
        let mut values = vec![f64::NAN; pattern.nonzeros()];
        s.tangent_values(&x, &mut values);
        let eye = Matrix::identity(n).to_dense();
        let eye: Vec<f64> = (0..n * n).map(|k| eye[(k % n, k / n)]).collect();
        let mut dense = vec![0.0; n * n];
        s.tangent_stiffness(
            &x,
            Block::new(&eye, n, n, n),
            BlockMut::new(&mut dense, n, n, n),
        );
        for i in 0..n {
            for j in 0..n {
                let assembled = pattern.position(i, j).map_or(0.0, |p| values[p]);
                let expected = dense[j * n + i];
                assert!(
                    (assembled - expected).abs() < 1e-13 * (1.0 + expected.abs()),
                    "({i}, {j})"
                );
            }
        }
    }
}
