//! Implicit Gauss–Legendre collocation with exact sensitivities, for stiff models
//! (docs/method.md eqs. (32a)–(32c): the same internal differentiation as the explicit pairs).
//!
//! **Why this method.** A finite-element model's highest frequency is thousands of times the
//! NNM's, and an explicit method's stability then dictates thousands of steps a period although
//! the motion is smooth. Gauss–Legendre collocation with `s` stages is A-stable (any step is
//! stable), of order `2s`, and symplectic: it neither damps nor amplifies the unresolved high
//! modes (`|R(iωh)| = 1` for every `ωh`), so Floquet multipliers stay on the unit circle
//! instead of being pulled inside it, as a damping scheme (Newmark with numerical dissipation,
//! BDF) would do.
//!
//! **Stage equations in second-order form.** With stage accelerations `W_i` (no `M⁻¹`
//! needed): `X_i = x + h c_i v + h² Σ_j Ā_ij W_j` (`Ā = A²`), `M W_i + f_int(X_i) = 0`, and the
//! step `x₁ = x + h v + h² Σ_j b̄_j W_j` (`b̄ = bᵀA`), `v₁ = v + h Σ_j b_j W_j`. Newton on `W`
//! uses the exact block Jacobian `M δ_ij + h² Ā_ij K_t(X_i)`, iterated to round-off.
//!
//! **Sensitivities.** Differentiating the converged stage equations along a direction
//! `(dx, dv)` gives `J dW = -[K_t(X_i)(dx + h c_i dv)]_i` with the *same* Jacobian `J` —
//! solved with the factorisation of the last Newton iteration, so `Φ` is the derivative of
//! the discrete flow that shooting's Newton solves (to the stage convergence, ~1e-13).
//!
//! **Steps.** Equal steps over the horizon; their number follows from a Richardson estimate
//! of the global error (`N` against `2N` steps, order `2s`; displacements in the mass norm at
//! the middle and the end of the horizon, relative to the motion's) against the integration
//! tolerance, and is reused while the
//! horizon stays within 20% of the one it was chosen for.
//!
//! **Stage solves.** When the system gives its tangent on a fixed pattern (a `Structure`
//! does), the `(s n) × (s n)` stage Jacobian is assembled on the union of `M`'s and `K_t`'s
//! patterns in every block and factorised by sparse LU, its symbolic analysis made once: on
//! the 38-dof ECL beam this took a branch from 38 s (dense) to 14.5 s. Otherwise it is dense.
//! When the nonlinearity lives on a few dofs ([`MechanicalSystem::nonlinear_dofs`]), the
//! stage Jacobian is a low-rank update of its linear part, factorised once per step size
//! (eq. (32e)): the ECL beam's branch 0.52 s → 0.31 s. When it is everywhere and the model
//! is large ([`SPLIT_DOFS`]), integrations without sensitivities split the stage system into
//! systems of the model's size and refine the recorded solves to round-off (eq. (32f),
//! `split.rs`): 2.5× less memory for the recorded linearisation of a matrix-free integration.

// Coefficients are quoted with all their digits.
#![allow(clippy::excessive_precision)]

use std::sync::Arc;

use super::split::{SplitLu, SplitStages, StageEigen};
use super::{
    Flow, IntegrationError, IntegrationStats, Integrator, LinearizedFlow, Steps, Tolerances,
};
use crate::linalg::{self, DenseLu, Mat, SparseLu, SparseLuPattern};
use crate::model::{
    Block, BlockMut, ExplicitForm, MechanicalSystem, SparseMatrix, SparsityPattern,
};

/// A Gauss–Legendre collocation method: nodes `c`, coefficients `A` (row-major) and weights
/// `b` of `s` stages.
#[derive(Debug)]
pub struct Collocation {
    /// Name in settings and reports.
    pub name: &'static str,
    /// Order `2s`.
    pub order: u32,
    /// Nodes `c_i`.
    pub c: &'static [f64],
    /// Row `i` holds `a_{i,0..s}`.
    pub a: &'static [&'static [f64]],
    /// Weights `b_i`.
    pub b: &'static [f64],
}

/// Two-stage Gauss–Legendre, order 4 (`c = ½ ∓ √3/6`).
pub static GAUSS4: Collocation = Collocation {
    name: "gauss4",
    order: 4,
    c: &[0.2113248654051871, 0.7886751345948129],
    a: &[&[0.25, -0.03867513459481288], &[0.5386751345948129, 0.25]],
    b: &[0.5, 0.5],
};

/// Three-stage Gauss–Legendre, order 6 (`c = ½ ∓ √15/10, ½`).
pub static GAUSS6: Collocation = Collocation {
    name: "gauss6",
    order: 6,
    c: &[0.11270166537925831, 0.5, 0.8872983346207417],
    a: &[
        &[
            0.1388888888888889,
            -0.0359766675249389,
            0.009789444015308325,
        ],
        &[
            0.30026319498086457,
            0.2222222222222222,
            -0.022485417203086815,
        ],
        &[0.26798833376246944, 0.48042111196938336, 0.1388888888888889],
    ],
    b: &[0.2777777777777778, 0.4444444444444444, 0.2777777777777778],
};

/// Three-stage Radau IIA collocation, order 5 (`c = (4 ∓ √6)/10, 1`): L-stable, so the
/// unresolved stiff modes are damped (`R(∞) = 0`) instead of carried with an aliased phase.
/// Not symplectic: resolved modes lose energy at the order of the tolerance.
pub static RADAU5: Collocation = Collocation {
    name: "radau5",
    order: 5,
    c: &[0.15505102572168222, 0.6449489742783178, 1.0],
    a: &[
        &[
            0.19681547722366044,
            -0.06553542585019838,
            0.02377097434822015,
        ],
        &[
            0.3944243147390873,
            0.29207341166522843,
            -0.04154875212599792,
        ],
        &[0.37640306270046725, 0.5124858261884216, 0.1111111111111111],
    ],
    b: &[0.37640306270046725, 0.5124858261884216, 0.1111111111111111],
};

/// Newton iterations allowed per step (times four, counting refactorisations) before the
/// step is declared failed.
const MAX_NEWTON: usize = 12;
/// The first step count tried when nothing is known yet; the count chosen is at least twice
/// this. Why not fewer: with `N` steps over a half period, the stiff modes that the stages do
/// not resolve rotate by nearly `π` a step, i.e. at nearly the `N`-th harmonic of the motion;
/// with `N` = 16 imposed, they met the motion's 15th harmonic on the ECL beam and the branch
/// left for a spurious, aliased one (the trap NLvib's Newmark shooting falls into). At 32 the
/// motion's content there is negligible.
const FIRST_STEPS: usize = 16;
/// Models of more dofs than this split their stage systems (eq. (32f)) in the integrations
/// that carry no sensitivity block. Why not all: refining every recorded solve to round-off
/// costs more than the whole factorisation saves. Measured on the von Kármán beam to +8%,
/// matrix-free: 3,000 dofs 154 s and 523 MB whole, 254 s and 268 MB split; 9,996 dofs 397 s
/// and 1.62 GB whole, 573 s and 655 MB split. Above 10⁴ dofs the whole factorisations a
/// matrix-free integration records grow past what a workstation holds (~16 GB at 10⁵ dofs,
/// ~6.5 GB split).
pub const SPLIT_DOFS: usize = 10_000;
/// Adaptive calls served by one error estimate before it is made again.
const REUSE: usize = 64;
/// The step count controls the error of the motion's components below this many cycles over
/// the horizon (16 harmonics of a half-period shot); faster ones are filtered out of the
/// estimate (eq. (32d)).
const CUTOFF_CYCLES: f64 = 8.0;

/// Gauss–Legendre collocation of a [`MechanicalSystem`] with its sensitivities.
pub struct GaussLegendre<'a, S: MechanicalSystem + ?Sized> {
    form: ExplicitForm<'a, S>,
    method: &'static Collocation,
    abar: Vec<Vec<f64>>,
    bbar: Vec<f64>,
    tolerances: Tolerances,
    /// The step size of the last estimate, the horizon it was made for, and how often it has
    /// been reused.
    chosen: Option<(f64, f64, usize)>,
    /// Most steps an integration may take.
    pub max_steps: usize,
    /// `M`'s entries (sparse: no dense `n × n` copy), and the identity block the dense
    /// tangents are built from (dense path only).
    mass: SparseMatrix,
    identity: Vec<f64>,
    /// The sparse stage system, when the system gives its tangent on a pattern.
    sparse: Option<SparseStages>,
    /// The stage system split into systems of the model's size (eq. (32f)), when it is
    /// sparse and its nonlinearity is not localised: used by integrations that carry no
    /// sensitivity block (matrix-free shooting records them, eq. (72)).
    split: Option<SplitStages>,
}

/// The stage Jacobian `J_ij = M δ_ij + h² Ā_ij K_t(X_i)` as a sparse matrix: its structure
/// (every block on the union of `M`'s and `K_t`'s patterns), analysed once, and for each entry
/// where its values come from.
struct SparseStages {
    /// `K_t`'s pattern (compressed rows), shared with the tangents a step records.
    tangent: Arc<SparsityPattern>,
    lu: SparseLuPattern,
    /// Per entry of `J` in compressed-column order: its blocks `(i, j)`, its `M` value (on
    /// diagonal blocks) and its position in `K_t`'s values, if there is one.
    entries: Vec<(usize, usize, f64, Option<usize>)>,
    /// When the nonlinearity is localised: the stage system as a low-rank update of its
    /// linear part (eq. (32e)).
    low_rank: Option<LowRank>,
}

/// Most nonlinear unknowns `s p` (stages × nonlinear dofs) for which the stage system is
/// solved as a low-rank update of its linear part. A bound, not a measured crossover: the
/// update costs a dense `s p × s p` factorisation a step and `s p` sparse solves an
/// integration, against one sparse factorisation a step without it; measured only at
/// `s p = 3` (one spring), where the ECL beam's branch took 42% (19 elements) to 59% (1,000
/// elements) less time.
const LOW_RANK_MAX: usize = 48;

/// A localised nonlinearity (eq. (32e)): `K_t(X_i) = K_t(0) + P D_i Pᵀ` with `P` the
/// nonlinear dofs' columns of the identity, so `J = J_lin + U D Vᵀ`, `J_lin` the stage
/// Jacobian of `K_t(0)`, `U = I_s ⊗ P`, `D = diag(D_i)`, `Vᵀ = h² Ā ⊗ Pᵀ`.
struct LowRank {
    /// The nonlinear dofs `P`.
    dofs: Vec<usize>,
    /// `K_t(0)` on the tangent's pattern.
    rest: Vec<f64>,
}

/// The linear part of the stage system at one step size, factorised, with what the low-rank
/// update needs of it: `Z = J_lin⁻¹ U` (`s n × s p`) and `Vᵀ Z` (`s p × s p`). One per step
/// size, shared by every step (and every recorded step) of an integration.
struct LinearStages {
    h: f64,
    lu: SparseLu,
    z: Vec<f64>,
    vtz: Vec<f64>,
    /// `h² Ā`, row-major `s × s`.
    hh_abar: Vec<f64>,
    dofs: Vec<usize>,
    n: usize,
}

impl LinearStages {
    /// `Vᵀ x` for `cols` columns of `x` (`s n` each): entry `(i, a)` is
    /// `h² Σ_j Ā_ij x_j[P_a]`; column-major `s p × cols`.
    fn project(&self, x: &[f64], cols: usize) -> Vec<f64> {
        let (n, p) = (self.n, self.dofs.len());
        let s = self.hh_abar.len().isqrt();
        let (m, sp) = (s * n, s * p);
        let mut out = vec![0.0; sp * cols];
        for col in 0..cols {
            let x = &x[col * m..(col + 1) * m];
            for i in 0..s {
                for (a, &dof) in self.dofs.iter().enumerate() {
                    out[col * sp + i * p + a] = (0..s)
                        .map(|j| self.hh_abar[i * s + j] * x[j * n + dof])
                        .sum();
                }
            }
        }
        out
    }
}

/// The stage Jacobian of one step as a low-rank update of [`LinearStages`]: the blocks `D_i`
/// (`p × p` each, row-major, stage after stage) and `S = I + D Vᵀ Z` factorised.
#[derive(Clone)]
struct UpdatedStages {
    linear: Arc<LinearStages>,
    d: Vec<f64>,
    s_lu: Option<DenseLu>,
}

impl UpdatedStages {
    /// `J⁻¹ B` by Woodbury's identity: `y = J_lin⁻¹ b`, then `y −= Z S⁻¹ D Vᵀ y`.
    fn solve_in_place(&self, b: &mut [f64], cols: usize) {
        let linear = &self.linear;
        linear.lu.solve_in_place(b, cols);
        let Some(s_lu) = &self.s_lu else { return };
        let p = linear.dofs.len();
        let sp = self.d.len() / p;
        let s = sp / p;
        let m = b.len() / cols.max(1);
        let projected = linear.project(b, cols);
        let mut t = vec![0.0; sp * cols];
        for col in 0..cols {
            for i in 0..s {
                for a in 0..p {
                    let row = &self.d[(i * p + a) * p..(i * p + a + 1) * p];
                    let x = &projected[col * sp + i * p..col * sp + (i + 1) * p];
                    t[col * sp + i * p + a] = row.iter().zip(x).map(|(d, x)| d * x).sum();
                }
            }
        }
        s_lu.solve_in_place(&mut t, cols);
        for col in 0..cols {
            let y = &mut b[col * m..(col + 1) * m];
            for (c, &tc) in t[col * sp..(col + 1) * sp].iter().enumerate() {
                if tc != 0.0 {
                    let z = &linear.z[c * m..(c + 1) * m];
                    y.iter_mut().zip(z).for_each(|(y, z)| *y -= z * tc);
                }
            }
        }
    }
}

impl SparseStages {
    fn new(tangent: &SparsityPattern, mass: &SparseMatrix, stages: usize) -> Option<Self> {
        let n = mass.dimension();
        let m_pattern = mass.pattern();
        // The union pattern, by columns (both patterns are those of symmetric matrices, but
        // the columns are collected explicitly all the same).
        let mut columns: Vec<Vec<usize>> = vec![Vec::new(); n];
        for r in 0..n {
            for pattern in [tangent, m_pattern] {
                for &c in &pattern.col[pattern.row_start[r]..pattern.row_start[r + 1]] {
                    columns[c].push(r);
                }
            }
        }
        for column in &mut columns {
            column.sort_unstable();
            column.dedup();
        }
        let (mut col_ptr, mut row_idx, mut entries) = (vec![0], Vec::new(), Vec::new());
        for bj in 0..stages {
            for (c, column) in columns.iter().enumerate() {
                for bi in 0..stages {
                    for &r in column {
                        row_idx.push(bi * n + r);
                        let m = match m_pattern.position(r, c) {
                            Some(p) if bi == bj => mass.values()[p],
                            _ => 0.0,
                        };
                        entries.push((bi, bj, m, tangent.position(r, c)));
                    }
                }
                col_ptr.push(row_idx.len());
            }
        }
        Some(Self {
            tangent: Arc::new(tangent.clone()),
            lu: SparseLuPattern::new(stages * n, col_ptr, row_idx)?,
            entries,
            low_rank: None,
        })
    }

    /// Solves the stage systems of `system` as low-rank updates (eq. (32e)) when its
    /// nonlinearity lives on few enough dofs.
    fn with_low_rank<S: MechanicalSystem + ?Sized>(mut self, system: &S, stages: usize) -> Self {
        let Some(dofs) = system.nonlinear_dofs() else {
            return self;
        };
        if stages * dofs.len() > LOW_RANK_MAX {
            return self;
        }
        let mut rest = vec![0.0; self.tangent.nonzeros()];
        system.tangent_values(&vec![0.0; system.dofs()], &mut rest);
        self.low_rank = Some(LowRank {
            dofs: dofs.to_vec(),
            rest,
        });
        self
    }

    /// The linear part of the stage system at step `h`, factorised ([`LinearStages`]).
    fn linear(&self, low_rank: &LowRank, h: f64, abar: &[Vec<f64>]) -> Option<LinearStages> {
        let s = abar.len();
        let n = self.tangent.row_start.len() - 1;
        let rest: Vec<Vec<f64>> = vec![low_rank.rest.clone(); s];
        let lu = self
            .lu
            .factorise(&self.values(|i, j| h * h * abar[i][j], &rest))?;
        let (p, m) = (low_rank.dofs.len(), s * n);
        let sp = s * p;
        let mut z = vec![0.0; m * sp];
        for i in 0..s {
            for (a, &dof) in low_rank.dofs.iter().enumerate() {
                z[(i * p + a) * m + i * n + dof] = 1.0;
            }
        }
        lu.solve_in_place(&mut z, sp);
        let mut linear = LinearStages {
            h,
            lu,
            z,
            vtz: Vec::new(),
            hh_abar: abar.iter().flatten().map(|a| h * h * a).collect(),
            dofs: low_rank.dofs.clone(),
            n,
        };
        linear.vtz = linear.project(&linear.z, sp);
        Some(linear)
    }
}

impl LowRank {
    /// The update of `linear` to the stage states `X_i` (`s × n`): `D_i` is the system's
    /// nonlinear tangent there.
    fn update<S: MechanicalSystem + ?Sized>(
        &self,
        system: &S,
        linear: Arc<LinearStages>,
        states: &[f64],
    ) -> Option<UpdatedStages> {
        let p = self.dofs.len();
        let n = system.dofs();
        let s = states.len() / n;
        let sp = s * p;
        // `d` holds each D_i row-major; the system writes it column-major.
        let mut d = vec![0.0; sp * p];
        let mut block = vec![0.0; p * p];
        for i in 0..s {
            system.nonlinear_tangent(&states[i * n..(i + 1) * n], &mut block);
            for a in 0..p {
                for c in 0..p {
                    d[(i * p + a) * p + c] = block[c * p + a];
                }
            }
        }
        if d.iter().any(|v| !v.is_finite()) {
            return None;
        }
        if d.iter().all(|&v| v == 0.0) {
            return Some(UpdatedStages {
                linear,
                d,
                s_lu: None,
            });
        }
        // S = I + D Vᵀ Z: row (i, a) of D Vᵀ Z is Σ_c D_i[a][c] (VᵀZ)[(i, c), ·].
        let matrix = Mat::<f64>::from_fn(sp, sp, |row, col| {
            let (i, a) = (row / p, row % p);
            let coupled: f64 = (0..p)
                .map(|c| d[(i * p + a) * p + c] * linear.vtz[col * sp + i * p + c])
                .sum();
            coupled + if row == col { 1.0 } else { 0.0 }
        });
        Some(UpdatedStages {
            linear,
            d,
            s_lu: Some(DenseLu::new(matrix.as_ref())),
        })
    }
}

impl SparseStages {
    /// The values of `J_ij = M δ_ij + scale(i, j) K_i` in the pattern's order, from the
    /// tangents `K_i` given on the system's pattern.
    fn values(&self, scale: impl Fn(usize, usize) -> f64, tangents: &[Vec<f64>]) -> Vec<f64> {
        self.entries
            .iter()
            .map(|&(bi, bj, m, slot)| m + slot.map_or(0.0, |p| scale(bi, bj) * tangents[bi][p]))
            .collect()
    }
}

/// What one integration keeps from step to step: the last factorised stage Jacobian with its
/// step size (the next step's Newton starts from it), and the buffers of the variational
/// step — `s n × k` and `n × k`, about 1.3 MB a step on a 100-element beam, where allocating
/// them afresh every step made 115,620 page faults in five points against 12,692 reused
/// (time within the noise, ~5%).
#[derive(Default)]
struct StepCache {
    lu: Option<(StageLu, f64)>,
    /// Whether the stage systems are split (eq. (32f)) in this integration.
    split: bool,
    /// The linear part of the stage system at the current step size (low-rank path).
    linear: Option<Arc<LinearStages>>,
    buffers: VariationalBuffers,
    /// Every step's stage factorisation, when the integration records its linearisation.
    record: Option<Vec<RecordedStep>>,
    /// The relative size of the Newton update at which the last freshly factorised stage
    /// system stalled: the round-off floor of the stage iteration (0 until one has).
    floor: f64,
}

/// The work buffers of [`variational_step`]: `s n × k`, `n × k` and `k`.
#[derive(Default)]
struct VariationalBuffers {
    rhs: Vec<f64>,
    directions: Vec<f64>,
    row: Vec<f64>,
}

/// One step of the variational equations (eq. (32c)) for `k` directions `phi` (`2n × k`,
/// column-major, in place): `J dW = -[K_t(X_i)(Φ_x + h c_i Φ_v)]_i` with the exact stage
/// Jacobian `J` at the converged stages (factorised in `lu`) and the tangents it was built
/// from, then `Φ_x += h Φ_v + h² Σ b̄_j dW_j`, `Φ_v += h Σ b_j dW_j`.
fn variational_step(
    method: &Collocation,
    bbar: &[f64],
    h: f64,
    (lu, tangents): (&StageLu, &StageTangents),
    phi: &mut [f64],
    k: usize,
    buffers: &mut VariationalBuffers,
) {
    let s = method.c.len();
    let n = phi.len() / (2 * k);
    let (m, n2) = (s * n, 2 * n);
    // Every entry of both is written below: resized, not cleared.
    let VariationalBuffers {
        rhs,
        directions,
        row,
    } = buffers;
    rhs.resize(m * k, 0.0);
    directions.resize(n * k, 0.0);
    for i in 0..s {
        let hc = h * method.c[i];
        // Φ_x + h c_i Φ_v for every column, stored direction-fastest.
        for col in 0..k {
            let (px, pv) = phi[col * n2..(col + 1) * n2].split_at(n);
            for r in 0..n {
                directions[r * k + col] = px[r] + hc * pv[r];
            }
        }
        if k == 1 {
            // One direction (a matrix-free product): the plain product, without the block
            // sweep's per-entry callback — a fifth of a product's time on a 100-element beam.
            let out = &mut rhs[i * n..(i + 1) * n];
            tangents.apply(i, directions, out);
            out.iter_mut().for_each(|v| *v = -*v);
        } else {
            tangents.apply_block(i, directions, k, row, |r, col, value| {
                rhs[col * m + i * n + r] = -value;
            });
        }
    }
    lu.solve_exact(rhs, k, tangents);
    for col in 0..k {
        let dw = &rhs[col * m..(col + 1) * m];
        let (px, pv) = phi[col * n2..(col + 1) * n2].split_at_mut(n);
        for r in 0..n {
            let bbar: f64 = (0..s).map(|j| bbar[j] * dw[j * n + r]).sum();
            let b: f64 = (0..s).map(|j| method.b[j] * dw[j * n + r]).sum();
            px[r] += h * pv[r] + h * h * bbar;
            pv[r] += h * b;
        }
    }
}

/// What a step keeps for later products with the monodromy: its size, its factorised stage
/// Jacobian and the tangents `K_t(X_i)` it was built from.
struct RecordedStep {
    h: f64,
    lu: StageLu,
    tangents: StageTangents,
}

/// The linearised discrete flow of one collocation integration (docs/method.md eq. (72)):
/// `Φ D` for any block `D` by [`variational_step`] over the recorded steps — the same
/// arithmetic as sensitivities integrated with the motion — without integrating the motion
/// again or factorising anything. Memory: per step one sparse LU of the `s n × s n` stage
/// system and `s` tangents, O(n · steps) for a banded model.
pub struct CollocationLinearization {
    method: &'static Collocation,
    bbar: Vec<f64>,
    dofs: usize,
    steps: Vec<RecordedStep>,
}

impl LinearizedFlow for CollocationLinearization {
    fn dimension(&self) -> usize {
        2 * self.dofs
    }

    fn apply(&self, directions: &[f64], columns: usize, out: &mut [f64]) {
        out.copy_from_slice(directions);
        if columns == 0 {
            return;
        }
        let mut buffers = VariationalBuffers::default();
        for step in &self.steps {
            variational_step(
                self.method,
                &self.bbar,
                step.h,
                (&step.lu, &step.tangents),
                out,
                columns,
                &mut buffers,
            );
        }
    }
}

/// A factorised stage Jacobian: exact, or the split approximation `P` (eq. (32f)).
#[derive(Clone)]
enum StageLu {
    Dense(DenseLu),
    Sparse(SparseLu),
    LowRank(UpdatedStages),
    Split(Arc<SplitLu>),
}

impl StageLu {
    /// `J⁻¹ B` (`P⁻¹ B` for the split approximation): what the stage Newton iteration needs.
    fn solve_in_place(&self, b: &mut [f64], cols: usize) {
        match self {
            StageLu::Dense(lu) => lu.solve_in_place(b, cols),
            StageLu::Sparse(lu) => lu.solve_in_place(b, cols),
            StageLu::LowRank(update) => update.solve_in_place(b, cols),
            StageLu::Split(split) => split.solve_in_place(b, cols),
        }
    }

    /// `J⁻¹ B` to round-off, `J` built from `tangents`: what the variational step needs.
    fn solve_exact(&self, b: &mut [f64], cols: usize, tangents: &StageTangents) {
        match self {
            StageLu::Split(split) => {
                split.solve_exact(b, cols, tangents);
            }
            exact => exact.solve_in_place(b, cols),
        }
    }
}

/// The tangents `K_t(X_i)` the stage Jacobian was built from: dense `n × n` each, or values on
/// the system's pattern.
pub(super) enum StageTangents {
    Dense(Vec<f64>),
    Sparse(Arc<SparsityPattern>, Vec<Vec<f64>>),
}

impl StageTangents {
    /// `K_t(X_i) D` for a block `D` of `k` directions stored direction-fastest (`D[r k + c]`),
    /// each entry handed to `out(row, column, value)`. On the sparse path one sweep over the
    /// tangent's rows serves every direction with contiguous, vectorisable updates: on a
    /// 100-element beam, where this product over the `n` sensitivity directions is the largest
    /// cost of a step, it was 18% of the branch applied direction by direction.
    fn apply_block(
        &self,
        i: usize,
        d: &[f64],
        k: usize,
        row: &mut Vec<f64>,
        mut out: impl FnMut(usize, usize, f64),
    ) {
        let n = d.len() / k.max(1);
        match self {
            StageTangents::Sparse(pattern, values) => {
                row.resize(k, 0.0);
                for r in 0..n {
                    row.fill(0.0);
                    let span = pattern.row_start[r]..pattern.row_start[r + 1];
                    for (&c, &v) in pattern.col[span.clone()].iter().zip(&values[i][span]) {
                        for (acc, x) in row.iter_mut().zip(&d[c * k..(c + 1) * k]) {
                            *acc += v * x;
                        }
                    }
                    for (col, &value) in row.iter().enumerate() {
                        out(r, col, value);
                    }
                }
            }
            StageTangents::Dense(_) => {
                let mut column = vec![0.0; n];
                let mut result = vec![0.0; n];
                for col in 0..k {
                    for r in 0..n {
                        column[r] = d[r * k + col];
                    }
                    self.apply(i, &column, &mut result);
                    for (r, &value) in result.iter().enumerate() {
                        out(r, col, value);
                    }
                }
            }
        }
    }

    /// `out = K_t(X_i) d` in plain sums: for the residuals of refined stage solves
    /// ([`super::split::SplitLu::solve_exact`]), whose floor need be no lower than the
    /// backward error of a factorisation of the whole stage system. (Summed accurately, as
    /// [`Self::apply`] does, these products were a third of a 1,000-element von Kármán
    /// branch.)
    pub(super) fn apply_plain(&self, i: usize, d: &[f64], out: &mut [f64]) {
        match self {
            StageTangents::Sparse(pattern, values) => {
                for (r, o) in out.iter_mut().enumerate() {
                    let span = pattern.row_start[r]..pattern.row_start[r + 1];
                    *o = pattern.col[span.clone()]
                        .iter()
                        .zip(&values[i][span])
                        .map(|(&c, v)| v * d[c])
                        .sum();
                }
            }
            StageTangents::Dense(_) => self.apply(i, d, out),
        }
    }

    /// `out = K_t(X_i) d`.
    fn apply(&self, i: usize, d: &[f64], out: &mut [f64]) {
        let n = d.len();
        match self {
            StageTangents::Dense(all) => {
                let k = &all[i * n * n..(i + 1) * n * n];
                for (r, o) in out.iter_mut().enumerate() {
                    *o = (0..n).map(|c| k[c * n + r] * d[c]).sum();
                }
            }
            StageTangents::Sparse(pattern, values) => {
                // Rows that cancel summed in twice the precision, as the internal force's
                // are (eq. (76c)): the monodromy–vector products then carry the slow modes'
                // part of a smooth direction without the rows' cancellation noise.
                for (r, o) in out.iter_mut().enumerate() {
                    let span = pattern.row_start[r]..pattern.row_start[r + 1];
                    *o = linalg::sparse_row_dot(
                        0.0,
                        &pattern.col[span.clone()],
                        &values[i][span],
                        d,
                    );
                }
            }
        }
    }
}

impl<S: MechanicalSystem + ?Sized> std::fmt::Debug for GaussLegendre<'_, S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GaussLegendre")
            .field("method", &self.method.name)
            .field("tolerances", &self.tolerances)
            .finish()
    }
}

impl<'a, S: MechanicalSystem + ?Sized> GaussLegendre<'a, S> {
    /// The method for `system` with the given tolerances.
    pub fn new(system: &'a S, method: &'static Collocation, tolerances: Tolerances) -> Self {
        let s = method.c.len();
        let a = |i: usize, j: usize| method.a[i][j];
        let abar: Vec<Vec<f64>> = (0..s)
            .map(|i| {
                (0..s)
                    .map(|j| (0..s).map(|l| a(i, l) * a(l, j)).sum())
                    .collect()
            })
            .collect();
        let bbar = (0..s)
            .map(|j| (0..s).map(|l| method.b[l] * a(l, j)).sum())
            .collect();
        let n = system.dofs();
        let mass = crate::model::mass_entries(system.mass());
        let sparse = system.tangent_pattern().and_then(|pattern| {
            SparseStages::new(pattern, &mass, method.c.len())
                .map(|stages| stages.with_low_rank(system, method.c.len()))
        });
        let split = if n > SPLIT_DOFS {
            Self::split_stages(system, sparse.as_ref(), &mass, &abar)
        } else {
            None
        };
        // The identity block the dense tangents are built from: the dense path only.
        let identity = if sparse.is_some() {
            Vec::new()
        } else {
            (0..n * n)
                .map(|k| if k % (n + 1) == 0 { 1.0 } else { 0.0 })
                .collect()
        };
        Self {
            form: ExplicitForm::new(system),
            method,
            abar,
            bbar,
            tolerances,
            chosen: None,
            max_steps: 1_000_000,
            mass,
            identity,
            sparse,
            split,
        }
    }

    /// The split stage systems (eq. (32f)) of a sparse stage system whose nonlinearity is
    /// not localised; `None` otherwise.
    fn split_stages(
        system: &S,
        sparse: Option<&SparseStages>,
        mass: &SparseMatrix,
        abar: &[Vec<f64>],
    ) -> Option<SplitStages> {
        let pattern = system.tangent_pattern()?;
        if sparse?.low_rank.is_some() {
            return None;
        }
        let single = SparseStages::new(pattern, mass, 1)?;
        let entries = single.entries.iter().map(|&(_, _, m, p)| (m, p)).collect();
        let eigen = StageEigen::new(abar)?;
        Some(SplitStages::new(
            eigen,
            single.lu,
            entries,
            mass.clone(),
            abar,
        ))
    }

    /// Splits the stage systems whatever the model's size (tests of eq. (32f) on small ones).
    #[cfg(test)]
    pub(super) fn with_split_stages(mut self) -> Self {
        self.split = Self::split_stages(
            self.form.system(),
            self.sparse.as_ref(),
            &self.mass,
            &self.abar,
        );
        assert!(self.split.is_some(), "a sparse model, nonlinear everywhere");
        self
    }

    /// Whether the stage systems are solved as low-rank updates (eq. (32e)).
    #[cfg(test)]
    pub(super) fn solves_low_rank(&self) -> bool {
        self.sparse.as_ref().is_some_and(|s| s.low_rank.is_some())
    }

    /// The stage states `X_i = x + h c_i v + h² Σ_j Ā_ij W_j` (eq. (32a)), `s × n`.
    fn stage_states(&self, x: &[f64], v: &[f64], w: &[f64], h: f64) -> Vec<f64> {
        let (n, s) = (x.len(), self.method.c.len());
        let mut states = vec![0.0; s * n];
        for i in 0..s {
            for r in 0..n {
                states[i * n + r] = x[r]
                    + h * self.method.c[i] * v[r]
                    + h * h * (0..s).map(|j| self.abar[i][j] * w[j * n + r]).sum::<f64>();
            }
        }
        states
    }

    /// The exact stage Jacobian `J_ij = M δ_ij + h² Ā_ij K_t(X_i)` at the stage states,
    /// factorised (sparse when the system gives its tangent on a pattern, dense otherwise),
    /// with the tangents `K_t(X_i)` it was built from.
    fn stage_jacobian(
        &self,
        states: &[f64],
        h: f64,
        linear: &mut Option<Arc<LinearStages>>,
        split: bool,
    ) -> Result<(StageLu, StageTangents), IntegrationError> {
        let system = self.form.system();
        let s = self.method.c.len();
        let n = states.len() / s;
        let singular = || {
            IntegrationError::InvalidInput(format!(
                "the implicit stage system is singular (step {h:.3e})"
            ))
        };
        if let Some(sparse) = &self.sparse {
            let tangents: Vec<Vec<f64>> = (0..s)
                .map(|i| {
                    let mut values = vec![0.0; sparse.tangent.nonzeros()];
                    system.tangent_values(&states[i * n..(i + 1) * n], &mut values);
                    values
                })
                .collect();
            let lu = match (&sparse.low_rank, self.split.as_ref().filter(|_| split)) {
                (None, Some(split)) => StageLu::Split(Arc::new(
                    split.factorise(h, &tangents).ok_or_else(singular)?,
                )),
                (Some(low_rank), _) => {
                    if linear.as_ref().is_none_or(|l| l.h != h) {
                        let stages = sparse.linear(low_rank, h, &self.abar);
                        *linear = Some(Arc::new(stages.ok_or_else(singular)?));
                    }
                    let base = linear.clone().expect("just made");
                    let update = low_rank.update(system, base, states);
                    StageLu::LowRank(update.ok_or_else(singular)?)
                }
                (None, None) => {
                    let values = sparse.values(|bi, bj| h * h * self.abar[bi][bj], &tangents);
                    StageLu::Sparse(sparse.lu.factorise(&values).ok_or_else(singular)?)
                }
            };
            return Ok((lu, StageTangents::Sparse(sparse.tangent.clone(), tangents)));
        }
        let m = s * n;
        let mut tangents = vec![0.0; s * n * n];
        for i in 0..s {
            system.tangent_stiffness(
                &states[i * n..(i + 1) * n],
                Block::new(&self.identity, n, n, n),
                BlockMut::new(&mut tangents[i * n * n..(i + 1) * n * n], n, n, n),
            );
        }
        let mut jacobian = Mat::<f64>::from_fn(m, m, |row, col| {
            let (bi, r, bj, c) = (row / n, row % n, col / n, col % n);
            h * h * self.abar[bi][bj] * tangents[bi * n * n + c * n + r]
        });
        for i in 0..s {
            self.add_mass(&mut jacobian, i * n);
        }
        Ok((
            StageLu::Dense(DenseLu::new(jacobian.as_ref())),
            StageTangents::Dense(tangents),
        ))
    }

    /// One step of size `h` from `z` (in place), with the sensitivities `phi` (`2n × k`
    /// column-major) carried along.
    ///
    /// Newton on the stage accelerations reuses the factorisation of the previous step (kept
    /// in `cache.lu` with its step size) and refactors only when it converges slowly; with
    /// sensitivities, the exact Jacobian at the converged stages is factorised once, used for
    /// the variational step (eq. (32c)), and kept for the next step's Newton.
    fn step(
        &self,
        z: &mut [f64],
        h: f64,
        phi: &mut [f64],
        k: usize,
        cache: &mut StepCache,
        stats: &mut IntegrationStats,
    ) -> Result<(), IntegrationError> {
        let system = self.form.system();
        let n = z.len() / 2;
        let s = self.method.c.len();
        let m = s * n;
        let (x, v) = z.split_at(n);
        // First guess: every stage accelerates as the start does. (Extrapolating the last
        // step's collocation polynomial was tried: its unresolved stiff components, amplified
        // by the extrapolation, moved the step-count estimate — 35 → 115 steps an
        // integration on the von Kármán example, 3.4 s → 7.6 s.)
        let mut w = vec![0.0; m];
        self.form.acceleration(x, &mut w[..n]);
        stats.rhs_evaluations += 1;
        for i in 1..s {
            w.copy_within(0..n, i * n);
        }
        if cache.lu.as_ref().is_none_or(|(_, size)| *size != h) {
            let (lu, _) = self.stage_jacobian(
                &self.stage_states(x, v, &w, h),
                h,
                &mut cache.linear,
                cache.split,
            )?;
            stats.tangent_evaluations += s;
            stats.factorisations += 1;
            cache.lu = Some((lu, h));
        }
        let mut fresh = false;
        let mut previous = f64::INFINITY;
        let mut residual = vec![0.0; m];
        let mut mw = vec![0.0; m];
        let mut iterations = 0;
        loop {
            let states = self.stage_states(x, v, &w, h);
            // M W_i for every stage in one product of the mass operator.
            system.mass().apply(&w, s, &mut mw);
            for i in 0..s {
                let ri = &mut residual[i * n..(i + 1) * n];
                system.internal_force(&states[i * n..(i + 1) * n], ri);
                ri.iter_mut()
                    .zip(&mw[i * n..(i + 1) * n])
                    .for_each(|(r, a)| *r += a);
            }
            stats.rhs_evaluations += s;
            let mut delta: Vec<f64> = residual.iter().map(|r| -r).collect();
            cache
                .lu
                .as_ref()
                .expect("factorised")
                .0
                .solve_in_place(&mut delta, 1);
            if delta.iter().any(|d| !d.is_finite()) {
                return Err(IntegrationError::NotFinite { t: f64::NAN });
            }
            w.iter_mut().zip(&delta).for_each(|(a, d)| *a += d);
            iterations += 1;
            let size = delta.iter().fold(0.0f64, |a, d| a.max(d.abs()));
            let scale = w.iter().fold(f64::MIN_POSITIVE, |a, d| a.max(d.abs()));
            if size <= 1e-14 * scale {
                break;
            }
            if iterations >= 2 && size >= 0.5 * previous {
                // Slow: with a stale matrix, refactor at the current stages; with a fresh
                // one, this is the round-off floor of the stage system (its condition grows
                // like (ω_max h)², in unresolved stiff components of W whose effect on the
                // state is h²-small) — ~1e-10 of W's largest entry on the ECL beam, where
                // the test above asks for 1e-14. A stale matrix that stalls no higher than
                // twice the floor the last fresh one met has reached it too: refactoring
                // there bought nothing but 0.7 factorisations and 3 iterations a step.
                if fresh {
                    cache.floor = size / scale;
                    break;
                }
                if size <= 2.0 * cache.floor * scale {
                    break;
                }
                let (lu, _) = self.stage_jacobian(
                    &self.stage_states(x, v, &w, h),
                    h,
                    &mut cache.linear,
                    cache.split,
                )?;
                stats.tangent_evaluations += s;
                stats.factorisations += 1;
                cache.lu = Some((lu, h));
                fresh = true;
                previous = f64::INFINITY;
                continue;
            }
            if iterations >= 4 * MAX_NEWTON {
                return Err(IntegrationError::InvalidInput(format!(
                    "implicit stages did not converge in {iterations} Newton iterations (step {h:.3e})"
                )));
            }
            previous = size;
        }
        if k > 0 || cache.record.is_some() {
            // The exact J at the converged stages: the variational step's matrix, kept for
            // the next step's Newton, and recorded for later products with Φ.
            let (lu, tangents) = self.stage_jacobian(
                &self.stage_states(x, v, &w, h),
                h,
                &mut cache.linear,
                cache.split,
            )?;
            stats.tangent_evaluations += s;
            stats.factorisations += 1;
            if k > 0 {
                variational_step(
                    self.method,
                    &self.bbar,
                    h,
                    (&lu, &tangents),
                    phi,
                    k,
                    &mut cache.buffers,
                );
            }
            if let Some(record) = &mut cache.record {
                // A copy, not a shared pointer: faer's factors carry the spare capacity of
                // their growth, and the copy holds only the entries. Sharing them instead
                // took the 200-element von Kármán branch from 122 to 174 MB, same time.
                record.push(RecordedStep {
                    h,
                    lu: lu.clone(),
                    tangents,
                });
            }
            cache.lu = Some((lu, h));
        }
        let (x1, v1) = z.split_at_mut(n);
        for r in 0..n {
            let bbar: f64 = (0..s).map(|j| self.bbar[j] * w[j * n + r]).sum();
            let b: f64 = (0..s).map(|j| self.method.b[j] * w[j * n + r]).sum();
            x1[r] += h * v1[r] + h * h * bbar;
            v1[r] += h * b;
        }
        if z.iter().any(|v| !v.is_finite()) {
            return Err(IntegrationError::NotFinite { t: f64::NAN });
        }
        Ok(())
    }

    /// The low-pass filter of the step-count estimate: `M + K₀/ω_c²` factorised, `K₀` the
    /// tangent at rest (docs/method.md eq. (32d)). Applied to `M d`, it passes a displacement
    /// `d`'s components in the linear modes with `ω_k ≪ ω_c` and attenuates those above by
    /// `(ω_c/ω_k)²`.
    fn low_pass(&self, cutoff: f64) -> Result<StageLu, IntegrationError> {
        let system = self.form.system();
        let n = system.dofs();
        let alpha = 1.0 / (cutoff * cutoff);
        let rest = vec![0.0; n];
        let singular = || {
            IntegrationError::InvalidInput(
                "M + K/ω² is singular: the stiffness at rest is not positive semi-definite".into(),
            )
        };
        if let Some(pattern) = system.tangent_pattern() {
            let single = SparseStages::new(pattern, &self.mass, 1).ok_or_else(singular)?;
            let mut tangent = vec![0.0; pattern.nonzeros()];
            system.tangent_values(&rest, &mut tangent);
            let values = single.values(|_, _| alpha, &[tangent]);
            return Ok(StageLu::Sparse(
                single.lu.factorise(&values).ok_or_else(singular)?,
            ));
        }
        let mut tangent = vec![0.0; n * n];
        system.tangent_stiffness(
            &rest,
            Block::new(&self.identity, n, n, n),
            BlockMut::new(&mut tangent, n, n, n),
        );
        let mut shifted = Mat::<f64>::from_fn(n, n, |r, c| alpha * tangent[c * n + r]);
        self.add_mass(&mut shifted, 0);
        Ok(StageLu::Dense(DenseLu::new(shifted.as_ref())))
    }

    /// Adds `M` to the diagonal block of a dense matrix that starts at `(offset, offset)`.
    fn add_mass(&self, a: &mut Mat<f64>, offset: usize) {
        let pattern = self.mass.pattern();
        for r in 0..self.mass.dimension() {
            for p in pattern.row_start[r]..pattern.row_start[r + 1] {
                a[(offset + r, offset + pattern.col[p])] += self.mass.values()[p];
            }
        }
    }

    /// `√(yᵀ M y)` with `(M + K₀/ω_c²) y = M x`, `x` the displacements of `z`: the mass norm
    /// of the displacements' slow part (eq. (32d)). The step count is chosen on this norm of
    /// the error, taken at the middle and at the end of the horizon (a phase error hides in
    /// the velocities at a turning point but shows in the displacements a quarter period
    /// away).
    ///
    /// Why filtered: the stiff end of a finite-element spectrum is not resolvable at an
    /// affordable step, and need not be: the A-stable, symplectic stages carry it with a
    /// bounded phase error. But a state on a computed orbit holds it at small amplitude, and
    /// the `N`- and `2N`-step runs rotate it by different phases, so an unfiltered difference
    /// measures that content instead of the error, and does not fall with `N` until `ω_max h`
    /// is small. On the ECL beam the unfiltered estimate asked for ~200 steps a half period;
    /// filtered, it takes ~32, and the backbone agrees with a 512-step one to 1e-10 in
    /// frequency. (Velocities are left out for the same reason: weighed in, the estimate asked
    /// for thousands of steps a period.)
    fn filtered_norm(&self, z: &[f64], filter: &StageLu) -> f64 {
        let x = &z[..z.len() / 2];
        let mass = self.form.system().mass();
        let mut y = vec![0.0; x.len()];
        mass.apply(x, 1, &mut y);
        filter.solve_in_place(&mut y, 1);
        let mut my = vec![0.0; x.len()];
        mass.apply(&y, 1, &mut my);
        linalg::dot(&y, &my).max(0.0).sqrt()
    }

    /// Integrates `steps` (even) equal steps of `duration / steps` without sensitivities: the
    /// states at the middle and at the end of the horizon.
    fn run(
        &self,
        z0: &[f64],
        duration: f64,
        steps: usize,
        stats: &mut IntegrationStats,
    ) -> Result<(Vec<f64>, Vec<f64>), IntegrationError> {
        let mut z = z0.to_vec();
        let mut middle = Vec::new();
        let sizes = vec![duration / steps as f64; steps];
        let mut cache = StepCache {
            split: true,
            ..StepCache::default()
        };
        self.march(
            &mut z,
            &sizes,
            (&mut [], 0),
            &mut cache,
            stats,
            |k, state| {
                if 2 * (k + 1) == steps {
                    middle = state.to_vec();
                }
            },
        )?;
        Ok((middle, z))
    }

    /// The number of equal steps over `duration` whose global error meets the tolerances:
    /// `N` and `2N` steps compared (Richardson, order `2s`), `N` grown until the estimate of
    /// the `2N` run's error is below one; then `2N`.
    fn choose_steps(
        &mut self,
        z0: &[f64],
        duration: f64,
        hint: Option<f64>,
        stats: &mut IntegrationStats,
    ) -> Result<usize, IntegrationError> {
        if let Some((h, horizon, uses)) = self.chosen
            && uses < REUSE
            && (duration / horizon - 1.0).abs() < 0.2
        {
            self.chosen = Some((h, horizon, uses + 1));
            return Ok((duration / h).ceil().max(1.0) as usize);
        }
        let even = |s: usize| s.max(2).next_multiple_of(2);
        let mut steps = even(
            hint.map(|h| (duration / h / 2.0).ceil() as usize)
                .unwrap_or(FIRST_STEPS),
        );
        let p = self.method.order as f64;
        // The motion's slow part: components below `CUTOFF_CYCLES` cycles over the horizon.
        let filter = self.low_pass(2.0 * std::f64::consts::PI * CUTOFF_CYCLES / duration)?;
        let mut trials: Vec<(usize, f64)> = Vec::new();
        loop {
            if 2 * steps > self.max_steps {
                return Err(IntegrationError::TooManySteps {
                    max_steps: self.max_steps,
                    t: 0.0,
                });
            }
            let coarse = self.run(z0, duration, steps, stats)?;
            let fine = self.run(z0, duration, 2 * steps, stats)?;
            let relative = |a: &[f64], b: &[f64]| {
                let d: Vec<f64> = a.iter().zip(b).map(|(a, b)| a - b).collect();
                let norm = |z: &[f64]| self.filtered_norm(z, &filter);
                let scale = norm(z0).max(norm(b));
                if scale > 0.0 { norm(&d) / scale } else { 0.0 }
            };
            let error = relative(&coarse.0, &fine.0).max(relative(&coarse.1, &fine.1))
                / (2f64.powf(p) - 1.0)
                / self.tolerances.relative;
            // The estimate's floor: once the steps have grown at least fourfold over two
            // trials, an error of order `p` has fallen a thousandfold; if it fell less than
            // tenfold, what is left is not the truncation error the step count controls —
            // the stage systems' round-off (their condition grows like (ω_max h)²), or the
            // unresolved stiff modes the N- and 2N-step runs treat differently — and more
            // steps do not reduce it. Measured on the 1,000-element ECL beam (ω_max/ω₁ ≈
            // 10⁷): estimates 5.6, 23, 5.4, 13, 2.6 times the tolerance at 16 to 646 steps;
            // on the 10⁴-dof von Kármán beam at +4.6%: 7.5, 3.1, 2.4 at 76, 182, 364 steps.
            // The fewest steps whose estimate is within twice the lowest are taken (taking
            // the lowest estimate's, as before, took the von Kármán beam from 156 to 728
            // steps an integration and 3.4 to 15 GB of recorded stage factorisations);
            // Newton's own residual still decides convergence.
            trials.push((steps, error));
            let floor = match trials[..] {
                [.., (s0, e0), _, (s2, e2)] if s2 >= 4 * s0 && e2 > 0.1 * e0 => {
                    let lowest = trials.iter().map(|t| t.1).fold(f64::INFINITY, f64::min);
                    trials
                        .iter()
                        .filter(|t| t.1 <= 2.0 * lowest)
                        .map(|t| t.0)
                        .min()
                }
                _ => None,
            };
            if let Some(trial) = (error <= 1.0).then_some(steps).or(floor) {
                let chosen = 2 * trial;
                self.chosen = Some((duration / chosen as f64, duration, 0));
                return Ok(chosen);
            }
            // Error ∝ N^-p: aim at a tenth of the tolerance, growing at least twofold.
            let factor = (10.0 * error).powf(1.0 / p).clamp(2.0, 16.0);
            steps = even((steps as f64 * factor).ceil() as usize);
        }
    }
}

impl<S: MechanicalSystem + ?Sized> GaussLegendre<'_, S> {
    /// [`Integrator::flow`]; with `record`, also each step's stage factorisation, for
    /// [`CollocationLinearization`].
    fn integrate(
        &mut self,
        z0: &[f64],
        duration: f64,
        sensitivity: Option<Block<'_>>,
        steps: Steps<'_>,
        record: bool,
    ) -> Result<(Flow, Vec<RecordedStep>), IntegrationError> {
        let n2 = 2 * self.form.dofs();
        super::check_request(z0, n2, duration, sensitivity)?;
        let mut stats = IntegrationStats::default();
        let sizes: Vec<f64> = match steps {
            Steps::Replay(list) => list.to_vec(),
            Steps::Adaptive { first_step } => {
                let count = self.choose_steps(z0, duration, first_step, &mut stats)?;
                vec![duration / count as f64; count]
            }
        };
        let k = sensitivity.map_or(0, |b| b.cols);
        let mut phi = vec![0.0; n2 * k];
        if let Some(b) = sensitivity {
            for c in 0..k {
                phi[c * n2..(c + 1) * n2].copy_from_slice(b.col(c));
            }
        }
        let mut z = z0.to_vec();
        let mut cache = StepCache {
            record: record.then(Vec::new),
            split: k == 0,
            ..StepCache::default()
        };
        self.march(
            &mut z,
            &sizes,
            (&mut phi, k),
            &mut cache,
            &mut stats,
            |_, _| {},
        )?;
        let flow = Flow {
            z,
            sensitivity: phi,
            columns: k,
            steps: sizes,
            stats,
        };
        Ok((flow, cache.record.unwrap_or_default()))
    }

    /// Takes the steps `sizes` from `z` (in place) with the sensitivities `phi` (`2n × k`),
    /// one stage factorisation carried from step to step in `cache`; `after(k, z)` sees the
    /// state after step `k`. A non-finite state is reported at the time its step started.
    fn march(
        &self,
        z: &mut [f64],
        sizes: &[f64],
        (phi, k): (&mut [f64], usize),
        cache: &mut StepCache,
        stats: &mut IntegrationStats,
        mut after: impl FnMut(usize, &[f64]),
    ) -> Result<(), IntegrationError> {
        let mut t = 0.0;
        for (index, &h) in sizes.iter().enumerate() {
            self.step(z, h, phi, k, cache, stats).map_err(|e| match e {
                IntegrationError::NotFinite { .. } => IntegrationError::NotFinite { t },
                other => other,
            })?;
            stats.steps += 1;
            t += h;
            after(index, z);
        }
        Ok(())
    }
}

impl<S: MechanicalSystem + ?Sized> Integrator for GaussLegendre<'_, S> {
    fn flow(
        &mut self,
        z0: &[f64],
        duration: f64,
        sensitivity: Option<Block<'_>>,
        steps: Steps<'_>,
    ) -> Result<Flow, IntegrationError> {
        Ok(self.integrate(z0, duration, sensitivity, steps, false)?.0)
    }

    fn flow_linearized(
        &mut self,
        z0: &[f64],
        duration: f64,
        steps: Steps<'_>,
    ) -> Result<(Flow, Arc<dyn LinearizedFlow>), IntegrationError> {
        let (flow, record) = self.integrate(z0, duration, None, steps, true)?;
        let linearization = CollocationLinearization {
            method: self.method,
            bbar: self.bbar.clone(),
            dofs: self.form.dofs(),
            steps: record,
        };
        Ok((flow, Arc::new(linearization)))
    }

    /// With replayed steps, one pass keeping the stage factorisation from step to step (a
    /// division at a time, each would start with a new one: on the ECL beam, sampling a period
    /// cost 14% of the branch that way).
    fn flow_sampled(
        &mut self,
        z0: &[f64],
        duration: f64,
        samples: usize,
        steps: Steps<'_>,
    ) -> Result<(Flow, Vec<Vec<f64>>), IntegrationError> {
        let Steps::Replay(division) = steps else {
            return super::sampled_by_divisions(self, z0, duration, samples, steps);
        };
        let n2 = 2 * self.form.dofs();
        super::check_request(z0, n2, duration, None)?;
        let mut stats = IntegrationStats::default();
        let mut z = z0.to_vec();
        let sizes = division.repeat(samples);
        let per_sample = division.len().max(1);
        let mut states = Vec::with_capacity(samples);
        self.march(
            &mut z,
            &sizes,
            (&mut [], 0),
            &mut StepCache {
                split: true,
                ..StepCache::default()
            },
            &mut stats,
            |index, state| {
                if (index + 1) % per_sample == 0 {
                    states.push(state.to_vec());
                }
            },
        )?;
        let flow = Flow {
            z,
            sensitivity: Vec::new(),
            columns: 0,
            steps: sizes,
            stats,
        };
        Ok((flow, states))
    }

    fn field(&self, z: &[f64], out: &mut [f64]) {
        self.form.field(z, out);
    }

    fn energy(&self, z: &[f64]) -> f64 {
        self.form.energy(z)
    }

    fn tolerances(&self) -> Tolerances {
        self.tolerances
    }

    fn set_tolerances(&mut self, tolerances: Tolerances) {
        self.tolerances = tolerances;
    }
}
