//! Floquet multipliers and stability of a periodic motion (docs/method.md §7).
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

/// Floquet stability and bifurcation events: the tolerance of a point's verdict, which the
/// shooting problem applies to every point, whether the branch looks for events between
/// points, and how far the multipliers may move in one step (docs/method.md §7–8).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct StabilitySettings {
    /// Tolerance on `|μ| - 1` for calling a point stable (default
    /// [`DEFAULT_STABILITY_TOLERANCE`]).
    pub stability_tolerance: f64,
    /// Detect folds, branch points, period doublings and Krein collisions between points and
    /// locate them (default true).
    pub events: bool,
    /// With events on, the largest move of any pair invariant `σ = μ + 1/μ` in one step
    /// ([`Floquet::invariant_shift`], docs/method.md eq. (44c)): the next step is shortened
    /// to what the last one moved them at that rate. Changes of the multipliers' pattern
    /// that undo themselves between two points are seen only as far as the steps resolve
    /// them; on a dense spectrum (the bladed disk's 59 pairs in `[−2, 2]`) a bound below the
    /// pairs' spacing resolves most. Default `+∞`: the steps follow the curve alone — on a
    /// finite-element model the invariants of the high modes turn round the circle with any
    /// change of the period, and a bound would shrink every step.
    pub invariant_step: f64,
}

impl Default for StabilitySettings {
    fn default() -> Self {
        Self {
            stability_tolerance: DEFAULT_STABILITY_TOLERANCE,
            events: true,
            invariant_step: f64::INFINITY,
        }
    }
}

/// Multipliers of one periodic motion.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Floquet {
    /// All multipliers `(re, im)`: the non-trivial ones by decreasing modulus, then the two
    /// trivial ones.
    pub multipliers: Vec<Complex>,
    /// Indices (into `multipliers`) of the two trivial ones (at `+1`).
    pub trivial: [usize; 2],
    /// The non-trivial multipliers paired as `(μ, 1/μ)` (see [`MultiplierPair`]), the unstable
    /// pairs first.
    pub pairs: Vec<MultiplierPair>,
    /// Largest modulus among the non-trivial multipliers (1 when there are none).
    pub max_modulus: f64,
    /// `max_modulus ≤ 1 + tolerance`.
    pub stable: bool,
    /// Number of pairs off the unit circle (a complex quadruplet counts as two pairs).
    pub unstable_pairs: usize,
    /// Accuracy estimate: multipliers of a conservative system come in pairs `(μ, 1/μ)`, so
    /// this is the largest `|μ ν - 1|` over the computed pairs `(μ, ν)`.
    pub reciprocity_defect: f64,
}

impl Floquet {
    /// No multipliers (a point whose Floquet analysis was not done).
    pub fn empty() -> Self {
        Self {
            multipliers: Vec::new(),
            trivial: [0, 0],
            pairs: Vec::new(),
            max_modulus: f64::NAN,
            stable: false,
            unstable_pairs: 0,
            reciprocity_defect: f64::NAN,
        }
    }
}

/// Where [`Floquet::invariant_shift`] stops following an invariant: beyond `±2` by this, a
/// real pair off the circle matters again only once back at `±1`.
const SHIFT_LIMIT: f64 = 2.2;

impl Floquet {
    /// The largest distance the real part of a pair invariant `σ = μ + 1/μ` moved between
    /// two analyses (docs/method.md eq. (44c)): both sets sorted and matched in that order
    /// (on a line the sorted matching moves the farthest least), each clamped to `|σ| ≤ 2.2`.
    /// The real parts, because they move continuously through every event — two invariants
    /// colliding on the circle leave as a quadruplet whose real part is where they met, while
    /// its imaginary part grows like a square root — and because an invariant on the circle
    /// meets another, or `±2`, only by its real part moving there. `None` when the numbers of
    /// pairs differ (an Arnoldi analysis's partial spectra) or there are none.
    pub fn invariant_shift(&self, other: &Floquet) -> Option<f64> {
        if self.pairs.len() != other.pairs.len() || self.pairs.is_empty() {
            return None;
        }
        let sorted = |f: &Floquet| {
            let mut x: Vec<f64> = (f.pairs.iter())
                .map(|p| p.trace().0.clamp(-SHIFT_LIMIT, SHIFT_LIMIT))
                .collect();
            x.sort_by(f64::total_cmp);
            x
        };
        let (x, y) = (sorted(self), sorted(other));
        Some(
            x.iter()
                .zip(&y)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max),
        )
    }
}

impl Floquet {
    /// The same analysis without the multipliers a damping integrator made: those inside the
    /// unit circle by more than `tolerance` whose reciprocal partner is not among them
    /// (docs/method.md eq. (76)).
    ///
    /// Why: a conservative orbit's multipliers lie on the unit circle or in reciprocal pairs
    /// `(μ, 1/μ)` (`(μ, 1/μ̄)` for a quadruplet). A damping integrator (Radau IIA) moves every
    /// mode inward by its damping, `1 − |μ|` from ~1e-5 for a well-resolved mode to ~1 for
    /// the unresolved ones; a multiplier inside by more than the stability tolerance, alone,
    /// is that damping, not dynamics, and its modulus cannot be trusted to judge a crossing of
    /// `±1` or a Krein collision. An Arnoldi analysis finds a varying number of them from
    /// point to point — on the 1,000-element beam a real one near 0.002 came and went, read as
    /// a pair through `+1`, and each time a location of 30 s found nothing. A genuinely
    /// unstable pair keeps both members (Arnoldi finds the larger first), so the verdict loses
    /// nothing.
    pub fn without_damped(&self, tolerance: f64) -> Floquet {
        if self.multipliers.len() < 2 {
            return self.clone();
        }
        let trivial: Vec<Complex> = self.trivial.iter().map(|&i| self.multipliers[i]).collect();
        let rest: Vec<(usize, Complex)> = self
            .multipliers
            .iter()
            .copied()
            .enumerate()
            .filter(|(i, _)| !self.trivial.contains(i))
            .collect();
        let partnered = |i: usize, z: Complex| {
            rest.iter().any(|&(j, w)| {
                // w = 1/z (a real pair's partner, or a quadruplet's) or w = 1/z̄ (a
                // quadruplet's other): z w = 1 or z w̄ = 1.
                let product = (z.0 * w.0 - z.1 * w.1 - 1.0).hypot(z.0 * w.1 + z.1 * w.0);
                let conjugate = (z.0 * w.0 + z.1 * w.1 - 1.0).hypot(z.1 * w.0 - z.0 * w.1);
                j != i && product.min(conjugate) < RECIPROCAL_PARTNER
            })
        };
        let kept: Vec<Complex> = rest
            .iter()
            .filter(|&&(i, z)| modulus(z) >= 1.0 - tolerance || partnered(i, z))
            .map(|&(_, z)| z)
            .collect();
        assemble(kept, trivial, tolerance)
    }
}

/// How close `μ ν` (or `μ ν̄`) must come to 1 for `ν` to count as `μ`'s reciprocal partner in
/// [`Floquet::without_damped`]: loose, since the damping moves both members of an unstable
/// pair inward (by ~1e-5 to 1e-3 on the resolved modes), while a damped multiplier's would-be
/// partner lies outside the circle by as much as it lies inside — and none is there.
const RECIPROCAL_PARTNER: f64 = 0.1;

/// Computes the multipliers of a monodromy matrix: the plug-in point for the eigen-solver
/// (dense full spectrum today; multipliers of largest modulus by Arnoldi for large models).
pub trait FloquetSolver: Send + Sync {
    /// Multipliers and stability of `monodromy`, its trivial pair spanned by `directions`
    /// (the flow direction and the direction along the family); `class`, when given, lists
    /// the coordinates of an invariant block holding both directions (a symmetry class).
    ///
    /// `frequencies`, when given, are the modal frequencies `ω_c` of the energy-scaled
    /// coordinates `(ω_c q_c, q̇_c)` the monodromy is written in (eq. (33a)): they define its
    /// symplectic form, and with it the Krein signature of each pair on the circle (eq. (37a)).
    fn analyse(
        &self,
        monodromy: &Mat<f64>,
        directions: [&[f64]; 2],
        class: Option<&[usize]>,
        frequencies: Option<&[f64]>,
        tolerance: f64,
    ) -> Result<Floquet, LinalgError>;
}

/// The dense full-spectrum analysis: [`analyse_deflated`], or [`analyse_deflated_split`] on a
/// symmetry class.
#[derive(Debug, Clone, Copy, Default)]
pub struct DenseFloquet;

impl FloquetSolver for DenseFloquet {
    fn analyse(
        &self,
        monodromy: &Mat<f64>,
        directions: [&[f64]; 2],
        class: Option<&[usize]>,
        frequencies: Option<&[f64]>,
        tolerance: f64,
    ) -> Result<Floquet, LinalgError> {
        let (mut floquet, signs) = match class {
            Some(class) => split(monodromy, directions, class, frequencies, tolerance)?,
            None => deflated(monodromy, directions, frequencies, 0, tolerance)?,
        };
        annotate(&mut floquet, &signs);
        Ok(floquet)
    }
}

/// Where a pair `(μ, 1/μ)` sits. Multipliers of a conservative (Hamiltonian) system are
/// symmetric under `μ → 1/μ` and `μ → μ̄`, so a pair either lies on the unit circle or leaves
/// it along the real axis (through `+1` or `-1`) or, after a Krein collision, as a member of a
/// complex quadruplet `(μ, 1/μ, μ̄, 1/μ̄)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PairKind {
    /// On the unit circle (within the tolerance): neutrally stable.
    Elliptic,
    /// Real and positive, off the circle: left through `+1` (a fold or branch point).
    PositiveReal,
    /// Real and negative, off the circle: left through `-1` (a period doubling).
    NegativeReal,
    /// Complex, off the circle: half of a quadruplet born in a Krein collision.
    Complex,
}

/// One pair of non-trivial multipliers `(μ, ν ≈ 1/μ)`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MultiplierPair {
    /// The member with `|μ| ≥ 1`; for a pair on the unit circle, the one with `Im μ ≥ 0`.
    pub multiplier: Complex,
    /// The other member, `≈ 1/μ`.
    pub partner: Complex,
    /// Where the pair sits: on the unit circle, or which way it left it (docs/method.md eq. (37)).
    pub kind: PairKind,
    /// For a pair on the circle, the Krein signature of `multiplier` (docs/method.md eq.
    /// (37a)), when the analysis knew the symplectic form.
    #[serde(skip)]
    pub krein: Option<Krein>,
}

/// The Krein signature of a multiplier on the unit circle: the sign of the symplectic form's
/// Hermitian value `vᴴ G v / 2i` on its eigenvector (docs/method.md eq. (37a)). Two pairs on
/// the circle can collide and leave it (a Krein collision) only if their signatures differ;
/// a pair of one signature passes one of the same untouched. So two neighbouring pairs of
/// opposite signatures that have changed places between two points met in between: they
/// left the circle and came back, an event and its undoing inside one step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Krein {
    /// The invariant block of the monodromy the pair belongs to (a symmetry class or its
    /// complement): pairs of different blocks never interact.
    pub block: u8,
    /// `+1` or `−1`; `0` where it is too small to tell (a multiplier at `±1`).
    pub sign: i8,
    /// The modes its eigenvector moves (bit `c mod 128` for mode `c` of the block, where
    /// its share of the vector is above [`MODE_SHARE`]; beyond 128 modes, modes share bits,
    /// which can only link pairs that are apart — never separate linked ones). Pairs moving no mode in common
    /// lie in invariant subspaces of their own — a symmetry of the motion keeps them apart —
    /// and pass each other on the circle without meeting, whatever their signatures.
    pub modes: u128,
}

/// The share of an eigenvector's squared length (in the energy-scaled coordinates) above which
/// a mode counts as moved by it ([`Krein::modes`]): far above the round-off and the
/// symmetry breaking of a converged orbit (~1e-16 in this measure), far below the content a
/// mode has in a pair that it couples to.
pub const MODE_SHARE: f64 = 1e-12;

impl MultiplierPair {
    /// `σ = μ + ν`, the pair's invariant: the characteristic polynomial of a symplectic
    /// matrix is a polynomial in `μ + 1/μ`. It is real while the pair is on the circle
    /// (`2 cos θ`) or on the real axis, `2` at `+1` and `-2` at `-1`, and it is smooth where
    /// the multipliers themselves are not (`μ = 1 ± √δ` near a double root, `σ = 2 + δ`): the
    /// test functions of [`crate::bifurcation`] are built on it.
    pub fn trace(&self) -> Complex {
        add(self.multiplier, self.partner)
    }
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
    deflated(monodromy, directions, None, 0, tolerance).map(|(floquet, _)| floquet)
}

/// A multiplier with its Krein sign and block (see [`Krein`]), before pairing.
type Signed = (Complex, Krein);

/// [`analyse_deflated`], with the Krein signs of the non-trivial multipliers when the modal
/// `frequencies` of the coordinates are given (as block `block`).
fn deflated(
    monodromy: &Mat<f64>,
    directions: [&[f64]; 2],
    frequencies: Option<&[f64]>,
    block_id: u8,
    tolerance: f64,
) -> Result<(Floquet, Vec<Signed>), LinalgError> {
    let plain = |m: &Mat<f64>| analyse(m, tolerance).map(|f| (f, Vec::new()));
    let n = monodromy.nrows();
    // Q = H₁ H₂ from two Householder reflections: H₁ maps the first direction onto e₁, H₂
    // (acting on coordinates 1..n) maps the rest of H₁ d₂ onto e₂, so Q's first two columns
    // span the directions. QᵀΦQ = H₂ H₁ Φ H₁ H₂ costs four rank-one updates (O(n²)), where
    // Gram–Schmidt to a full basis cost O(n³) and was a third of the tongue's Floquet time.
    let (d1, d2) = (directions[0], directions[1]);
    let Some(v1) = reflector(d1, 0) else {
        return plain(monodromy);
    };
    let mut y = d2.to_vec();
    reflect_vector(&v1, &mut y);
    let rest = linalg::norm(&y[1..]);
    // Also true for NaN: a direction that is not usable falls back to the plain analysis.
    if rest.is_nan() || rest <= 1e-8 * linalg::norm(d2) {
        return plain(monodromy);
    }
    let Some(v2) = reflector(&y, 1) else {
        return plain(monodromy);
    };
    let mut projected = monodromy.clone();
    for v in [&v1, &v2] {
        reflect_both_sides(v, &mut projected);
    }
    let block =
        |lo: usize, size: usize| Mat::from_fn(size, size, |i, j| projected[(lo + i, lo + j)]);
    let trivial = linalg::eigenvalues(block(0, 2).as_ref())?;
    let Some(frequencies) = frequencies else {
        let rest = linalg::eigenvalues(block(2, n - 2).as_ref())?;
        return Ok((assemble(rest, trivial, tolerance), Vec::new()));
    };
    // An eigenvector `w` of the deflated block is the tail of one of `QᵀΦQ`: `u = [x; w]` with
    // `(μ I − P) x = C w` (P, C the first two rows); Φ's own is `Q u = H₁ H₂ u`.
    let (rest, vectors) = linalg::eigenpairs(block(2, n - 2).as_ref())?;
    let signed = rest
        .iter()
        .zip(&vectors)
        .map(|(&mu, w)| {
            let cw = |i: usize| {
                w.iter().enumerate().fold((0.0, 0.0), |acc, (j, &wj)| {
                    add(acc, mul((projected[(i, 2 + j)], 0.0), wj))
                })
            };
            let (r1, r2) = (cw(0), cw(1));
            let a11 = sub(mu, (projected[(0, 0)], 0.0));
            let a22 = sub(mu, (projected[(1, 1)], 0.0));
            let (a12, a21) = ((-projected[(0, 1)], 0.0), (-projected[(1, 0)], 0.0));
            let det = sub(mul(a11, a22), mul(a12, a21));
            let x1 = divide(sub(mul(a22, r1), mul(a12, r2)), det);
            let x2 = divide(sub(mul(a11, r2), mul(a21, r1)), det);
            let mut re: Vec<f64> = [x1.0, x2.0]
                .into_iter()
                .chain(w.iter().map(|z| z.0))
                .collect();
            let mut im: Vec<f64> = [x1.1, x2.1]
                .into_iter()
                .chain(w.iter().map(|z| z.1))
                .collect();
            for v in [&v2, &v1] {
                reflect_vector(v, &mut re);
                reflect_vector(v, &mut im);
            }
            let mut krein = krein(&re, &im, frequencies, block_id);
            if !(modulus(det).is_finite() && modulus(det) > 0.0) {
                krein.sign = 0;
            }
            (mu, krein)
        })
        .collect();
    Ok((assemble(rest, trivial, tolerance), signed))
}

/// The sign of `Im Σ_c conj(y_c) y_(m+c) / ω_c` for `y = re + i im` in the coordinates
/// `(ω_c q_c, q̇_c)` (`m` modes, displacements first): `vᴴ G v / 2i` with `G` the symplectic
/// form there, `[[0, Ω⁻¹], [−Ω⁻¹, 0]]` (docs/method.md eq. (37a)). Zero when it is below
/// 1e-6 of the vector's own scale (an eigenvector at `±1`, where the form vanishes). With it,
/// the modes the vector moves ([`Krein::modes`]).
fn krein(re: &[f64], im: &[f64], frequencies: &[f64], block: u8) -> Krein {
    let m = frequencies.len();
    if re.len() != 2 * m {
        return Krein {
            block,
            sign: 0,
            modes: u128::MAX,
        };
    }
    let share =
        |c: usize| re[c] * re[c] + im[c] * im[c] + re[m + c] * re[m + c] + im[m + c] * im[m + c];
    let length: f64 = (0..m).map(share).sum();
    let (mut form, mut scale, mut modes) = (0.0, 0.0, 0u128);
    for (c, &omega) in frequencies.iter().enumerate() {
        let (a, b) = ((re[c], im[c]), (re[m + c], im[m + c]));
        form += (a.0 * b.1 - a.1 * b.0) / omega;
        scale += share(c) / omega;
        if share(c) > MODE_SHARE * length {
            modes |= 1 << (c % 128);
        }
    }
    // (NaN from a non-finite vector gives 0 too.)
    let telling = form.abs() > 1e-6 * scale;
    let sign = match (telling, form > 0.0) {
        (false, _) => 0,
        (true, true) => 1,
        (true, false) => -1,
    };
    Krein { block, sign, modes }
}

/// Gives each pair on the circle the Krein sign of its multiplier (the same number, as the
/// analysis computed it).
fn annotate(floquet: &mut Floquet, signed: &[Signed]) {
    // Each computed multiplier serves one pair: equal values (identical decoupled blocks)
    // keep their own signatures.
    let mut used = vec![false; signed.len()];
    for pair in floquet
        .pairs
        .iter_mut()
        .filter(|p| p.kind == PairKind::Elliptic)
    {
        let found = (0..signed.len()).find(|&k| !used[k] && signed[k].0 == pair.multiplier);
        pair.krein = found.map(|k| {
            used[k] = true;
            signed[k].1
        });
    }
}

/// [`analyse_deflated`] on a monodromy that a symmetry splits into two invariant blocks:
/// `class` lists the coordinates of one (holding both trivial directions), the rest form the
/// other. The eigenvalue problems are then half the size (a quarter of the work each) and pairs
/// of different classes cannot mix through round-off. Falls back to the whole matrix when the
/// coupling between the blocks is not negligible (more than 1e-7 of the largest entry) or the
/// directions leave the class.
pub fn analyse_deflated_split(
    monodromy: &Mat<f64>,
    directions: [&[f64]; 2],
    class: &[usize],
    tolerance: f64,
) -> Result<Floquet, LinalgError> {
    split(monodromy, directions, class, None, tolerance).map(|(floquet, _)| floquet)
}

/// [`analyse_deflated_split`], with Krein signs as in [`deflated`]: the class is block 0, the
/// rest block 1.
fn split(
    monodromy: &Mat<f64>,
    directions: [&[f64]; 2],
    class: &[usize],
    frequencies: Option<&[f64]>,
    tolerance: f64,
) -> Result<(Floquet, Vec<Signed>), LinalgError> {
    let n = monodromy.nrows();
    let mut in_class = vec![false; n];
    class.iter().for_each(|&k| in_class[k] = true);
    let rest: Vec<usize> = (0..n).filter(|&k| !in_class[k]).collect();
    let largest = (0..n)
        .flat_map(|j| (0..n).map(move |i| (i, j)))
        .fold(0.0f64, |m, (i, j)| m.max(monodromy[(i, j)].abs()));
    let coupling = class
        .iter()
        .flat_map(|&i| rest.iter().map(move |&j| (i, j)))
        .fold(0.0f64, |m, (i, j)| {
            m.max(monodromy[(i, j)].abs()).max(monodromy[(j, i)].abs())
        });
    let outside = |d: &[f64]| {
        let out = rest.iter().map(|&k| d[k] * d[k]).sum::<f64>().sqrt();
        out > 1e-7 * linalg::norm(d)
    };
    if class.len() < 2
        || rest.is_empty()
        || coupling.is_nan()
        || coupling > 1e-7 * largest
        || directions.iter().any(|d| outside(d))
    {
        return deflated(monodromy, directions, frequencies, 0, tolerance);
    }
    let sub =
        |idx: &[usize]| Mat::from_fn(idx.len(), idx.len(), |i, j| monodromy[(idx[i], idx[j])]);
    let restrict = |d: &[f64]| -> Vec<f64> { class.iter().map(|&k| d[k]).collect() };
    // Both blocks hold their modes' displacements, then the same modes' velocities.
    let frequencies = frequencies.filter(|f| 2 * f.len() == n);
    let block_frequencies = |idx: &[usize]| -> Option<Vec<f64>> {
        frequencies.map(|f| idx[..idx.len() / 2].iter().map(|&k| f[k]).collect())
    };
    let (d1, d2) = (restrict(directions[0]), restrict(directions[1]));
    let class_frequencies = block_frequencies(class);
    let (in_block, mut signed) = deflated(
        &sub(class),
        [&d1, &d2],
        class_frequencies.as_deref(),
        0,
        tolerance,
    )?;
    let mut multipliers: Vec<Complex> = in_block
        .multipliers
        .iter()
        .enumerate()
        .filter(|(k, _)| !in_block.trivial.contains(k))
        .map(|(_, z)| *z)
        .collect();
    match block_frequencies(&rest) {
        Some(rest_frequencies) => {
            let (values, vectors) = linalg::eigenpairs(sub(&rest).as_ref())?;
            for (mu, v) in values.iter().zip(&vectors) {
                let re: Vec<f64> = v.iter().map(|z| z.0).collect();
                let im: Vec<f64> = v.iter().map(|z| z.1).collect();
                signed.push((*mu, krein(&re, &im, &rest_frequencies, 1)));
            }
            multipliers.extend(values);
        }
        None => multipliers.extend(linalg::eigenvalues(sub(&rest).as_ref())?),
    }
    let trivial = in_block
        .trivial
        .iter()
        .map(|&k| in_block.multipliers[k])
        .collect();
    Ok((assemble(multipliers, trivial, tolerance), signed))
}

/// The unit Householder vector `v` (zero before `start`) with `(I - 2vvᵀ) x` a multiple of
/// `e_start`; `None` when `x[start..]` vanishes.
fn reflector(x: &[f64], start: usize) -> Option<Vec<f64>> {
    let tail = linalg::norm(&x[start..]);
    if tail <= 0.0 || !tail.is_finite() {
        return None;
    }
    let mut v = vec![0.0; x.len()];
    v[start..].copy_from_slice(&x[start..]);
    // Add, not subtract, the norm: no cancellation.
    v[start] += tail.copysign(x[start]);
    let norm = linalg::norm(&v);
    v.iter_mut().for_each(|e| *e /= norm);
    Some(v)
}

fn reflect_vector(v: &[f64], x: &mut [f64]) {
    let c = 2.0 * linalg::dot(v, x);
    x.iter_mut().zip(v).for_each(|(e, w)| *e -= c * w);
}

/// `A ← H A H` with `H = I - 2vvᵀ`.
fn reflect_both_sides(v: &[f64], a: &mut Mat<f64>) {
    let n = a.nrows();
    // Left: A ← A - 2 v (vᵀA).
    let row: Vec<f64> = (0..n)
        .map(|j| (0..n).map(|i| v[i] * a[(i, j)]).sum::<f64>())
        .collect();
    for j in 0..n {
        for i in 0..n {
            a[(i, j)] -= 2.0 * v[i] * row[j];
        }
    }
    // Right: A ← A - 2 (A v) vᵀ.
    let column: Vec<f64> = (0..n)
        .map(|i| (0..n).map(|j| a[(i, j)] * v[j]).sum::<f64>())
        .collect();
    for j in 0..n {
        for i in 0..n {
            a[(i, j)] -= 2.0 * column[i] * v[j];
        }
    }
}

/// Multipliers of a monodromy that is block diagonal in known coordinates (the harmonics of
/// a cyclic structure, docs/method.md eq. (76e)): `with_trivial` holds both trivial
/// directions and is deflated as in [`analyse_deflated`]; every block of `others` must be
/// closed under `μ → 1/μ` on its own (a harmonic with its opposite), so the pairs are formed
/// within each block — `O(Σ size²)`, where pairing the whole spectrum at once is quadratic in
/// its size (2·10⁴ multipliers on a 5,000-sector disk).
pub fn analyse_blocks(
    with_trivial: &Mat<f64>,
    directions: [&[f64]; 2],
    others: &[Mat<f64>],
    tolerance: f64,
) -> Result<Floquet, LinalgError> {
    let first = analyse_deflated(with_trivial, directions, tolerance)?;
    let trivial: Vec<Complex> = first
        .trivial
        .iter()
        .map(|&i| first.multipliers[i])
        .collect();
    let mut rest: Vec<Complex> = (0..first.multipliers.len())
        .filter(|i| !first.trivial.contains(i))
        .map(|i| first.multipliers[i])
        .collect();
    let (mut pairs, mut defect) = (first.pairs, first.reciprocity_defect);
    for block in others {
        let mut values = linalg::eigenvalues(block.as_ref())?;
        values.sort_by(|a, b| modulus(*b).total_cmp(&modulus(*a)));
        let (block_pairs, block_defect) = pair_up(&values, tolerance);
        pairs.extend(block_pairs);
        defect = defect.max(block_defect);
        rest.extend(values);
    }
    pairs.sort_by_key(|p| p.kind == PairKind::Elliptic);
    rest.sort_by(|a, b| modulus(*b).total_cmp(&modulus(*a)));
    let max_modulus = rest.first().map_or(1.0, |z| modulus(*z));
    let count = rest.len();
    let mut multipliers = rest;
    multipliers.extend(trivial);
    Ok(Floquet {
        stable: max_modulus <= 1.0 + tolerance,
        unstable_pairs: pairs
            .iter()
            .filter(|p| p.kind != PairKind::Elliptic)
            .count(),
        trivial: [count, (count + 1).min(multipliers.len().saturating_sub(1))],
        multipliers,
        pairs,
        max_modulus,
        reciprocity_defect: defect,
    })
}

fn assemble(mut rest: Vec<Complex>, trivial: Vec<Complex>, tolerance: f64) -> Floquet {
    rest.sort_by(|a, b| modulus(*b).total_cmp(&modulus(*a)));
    let max_modulus = rest.first().map_or(1.0, |z| modulus(*z));
    let (pairs, reciprocity_defect) = pair_up(&rest, tolerance);
    let count = rest.len();
    let mut multipliers = rest;
    multipliers.extend(trivial);
    let trivial = [count, (count + 1).min(multipliers.len().saturating_sub(1))];
    Floquet {
        stable: max_modulus <= 1.0 + tolerance,
        unstable_pairs: pairs
            .iter()
            .filter(|p| p.kind != PairKind::Elliptic)
            .count(),
        multipliers,
        trivial,
        pairs,
        max_modulus,
        reciprocity_defect,
    }
}

/// Pairs the multipliers (sorted by decreasing modulus) greedily: each unpaired one with the
/// unpaired one whose product is closest to 1. Returns the pairs, unstable first, and the
/// largest `|μ ν - 1|`. An odd one out (only possible through round-off) is paired with its
/// exact reciprocal, and its defect counted as the distance of that to the spectrum (∞ if
/// there is nothing left to compare with).
fn pair_up(sorted: &[Complex], tolerance: f64) -> (Vec<MultiplierPair>, f64) {
    let mut used = vec![false; sorted.len()];
    let mut pairs = Vec::with_capacity(sorted.len() / 2);
    let mut defect = 0.0f64;
    for i in 0..sorted.len() {
        if used[i] {
            continue;
        }
        used[i] = true;
        let mu = sorted[i];
        let best = (0..sorted.len()).filter(|&j| !used[j]).min_by(|&a, &b| {
            let da = modulus(sub(mul(mu, sorted[a]), (1.0, 0.0)));
            let db = modulus(sub(mul(mu, sorted[b]), (1.0, 0.0)));
            da.total_cmp(&db)
        });
        let partner = match best {
            Some(j) => {
                used[j] = true;
                defect = defect.max(modulus(sub(mul(mu, sorted[j]), (1.0, 0.0))));
                sorted[j]
            }
            None => {
                defect = f64::INFINITY;
                reciprocal(mu)
            }
        };
        pairs.push(classify(mu, partner, tolerance));
    }
    pairs.sort_by_key(|p| p.kind == PairKind::Elliptic);
    (pairs, defect)
}

/// An unstable multiplier `μ = ρ e^{iφ}` counts as complex (half of a quadruplet) when its
/// angle from the real axis exceeds both this and a tenth of `ln ρ`. A real pair that is
/// double by symmetry comes out of the eigensolver as a conjugate pair split by about the
/// square root of the monodromy's error (1e-4 to 1e-3 seen on the bladed disk), while a
/// quadruplet from a Krein collision keeps the collision's angle as it leaves the circle, its
/// modulus growing from 1.
const COMPLEX_ANGLE: f64 = 1e-3;

fn classify(a: Complex, b: Complex, tolerance: f64) -> MultiplierPair {
    let (big, small) = if modulus(a) >= modulus(b) {
        (a, b)
    } else {
        (b, a)
    };
    let rho = modulus(big);
    if rho <= 1.0 + tolerance {
        // On the circle: the representative is the one in the upper half plane.
        let (multiplier, partner) = if a.1 >= b.1 { (a, b) } else { (b, a) };
        return MultiplierPair {
            multiplier,
            partner,
            kind: PairKind::Elliptic,
            krein: None,
        };
    }
    let angle = big.1.abs().atan2(big.0.abs());
    let kind = if angle > COMPLEX_ANGLE.max(0.1 * rho.ln()) {
        PairKind::Complex
    } else if big.0 > 0.0 {
        PairKind::PositiveReal
    } else {
        PairKind::NegativeReal
    };
    MultiplierPair {
        multiplier: big,
        partner: small,
        kind,
        krein: None,
    }
}

pub(crate) fn modulus(z: Complex) -> f64 {
    z.0.hypot(z.1)
}

pub(crate) fn add(a: Complex, b: Complex) -> Complex {
    (a.0 + b.0, a.1 + b.1)
}

pub(crate) fn sub(a: Complex, b: Complex) -> Complex {
    (a.0 - b.0, a.1 - b.1)
}

pub(crate) fn mul(a: Complex, b: Complex) -> Complex {
    (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0)
}

fn divide(a: Complex, b: Complex) -> Complex {
    mul(a, reciprocal(b))
}

fn reciprocal(z: Complex) -> Complex {
    let r2 = z.0 * z.0 + z.1 * z.1;
    (z.0 / r2, -z.1 / r2)
}

#[cfg(test)]
pub(crate) mod tests;
