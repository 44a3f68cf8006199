//! The stage system `J_ij = M δ_ij + h A_ij C + h² Ā_ij K_t(X_i)` of a collocation step
//! (docs/method.md eqs. (32a)–(32f); `C = 0` for free motions, eq. (96) for forced ones): its
//! sparse pattern, analysed once, and its factorisation — whole (sparse, or dense when the
//! system gives no tangent pattern), as a low-rank update of its linear part (`low_rank.rs`),
//! or split into systems of the model's size (`split.rs`).

use std::sync::Arc;

use super::GaussLegendre;
use super::low_rank::{LOW_RANK_MAX, LinearLu, LinearStages, LowRank, UpdatedStages};
use super::split::{Scratch, SplitLu, SplitStages, StageEigen, StepImage};
use super::tableaux::StageMethod;
use super::tangents::StageTangents;
use crate::integrate::IntegrationError;
use crate::linalg::{DenseLu, Mat, SparseLu, SparseLuPattern};
use crate::model::{Block, BlockMut, MechanicalSystem, SparseMatrix, SparsityPattern};

/// The stage Jacobian `J_ij = M δ_ij + h A_ij C + h² Ā_ij K_t(X_i)` as a sparse matrix: its
/// structure (every block on the union of `M`'s, `C`'s and `K_t`'s patterns), analysed once,
/// and for each entry where its values come from.
pub(in crate::integrate) struct SparseStages {
    /// `K_t`'s pattern (compressed rows), shared with the tangents a step records.
    tangent: Arc<SparsityPattern>,
    pub(super) lu: SparseLuPattern,
    /// Per entry of `J` in compressed-column order: its blocks `(i, j)`, its `M` value (on
    /// diagonal blocks), its `C` value and its position in `K_t`'s values, if there is one.
    entries: Vec<StageEntry>,
    /// When the nonlinearity is localised: the stage system as a low-rank update of its
    /// linear part (eq. (32e)).
    low_rank: Option<LowRank>,
}

/// Where one entry of the stage Jacobian takes its value from.
#[derive(Clone, Copy)]
struct StageEntry {
    /// Its block row and column `(i, j)`.
    block: (usize, usize),
    /// `M`'s entry (diagonal blocks only) and `C`'s at its place in the block.
    mass: f64,
    damping: f64,
    /// Its position in `K_t`'s values, if the tangent's pattern has it.
    slot: Option<usize>,
}

impl SparseStages {
    /// The pattern of the `stages`-stage system of `M`, `K_t` (on `tangent`) and, for forced
    /// motions, `C`.
    pub(in crate::integrate) fn new(
        tangent: &SparsityPattern,
        mass: &SparseMatrix,
        damping: Option<&SparseMatrix>,
        stages: usize,
    ) -> Option<Self> {
        let n = mass.dimension();
        let m_pattern = mass.pattern();
        // The union pattern, by columns (the patterns are those of symmetric matrices, but
        // the columns are collected explicitly all the same).
        let mut columns: Vec<Vec<usize>> = vec![Vec::new(); n];
        let patterns = [Some(tangent), Some(m_pattern), damping.map(|c| c.pattern())];
        for r in 0..n {
            for pattern in patterns.iter().flatten() {
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
                        let damping = damping
                            .and_then(|d| Some(d.values()[d.pattern().position(r, c)?]))
                            .unwrap_or(0.0);
                        entries.push(StageEntry {
                            block: (bi, bj),
                            mass: m,
                            damping,
                            slot: tangent.position(r, c),
                        });
                    }
                }
                col_ptr.push(row_idx.len());
            }
        }
        Some(Self {
            tangent: Arc::new(tangent.clone()),
            // A single stage's system has the model's thin pattern (see `simplicial`).
            lu: if stages == 1 {
                SparseLuPattern::chosen_by_fill(n, col_ptr, row_idx)?
            } else {
                SparseLuPattern::new(stages * n, col_ptr, row_idx)?
            },
            entries,
            low_rank: None,
        })
    }

    /// The stage systems of `method` split into systems of the model's size (eq. (32f)), on
    /// the single-stage pattern of `M`, `C` and `K_t` (`tangent`); `None` if `A` has no
    /// well-conditioned eigenbasis.
    pub(in crate::integrate) fn split(
        tangent: &SparsityPattern,
        (mass, damping): (&SparseMatrix, Option<&SparseMatrix>),
        method: &StageMethod,
    ) -> Option<SplitStages> {
        let single = Self::new(tangent, mass, damping, 1)?;
        Some(SplitStages::new(
            StageEigen::new(&method.a)?,
            single.lu,
            (single.entries.iter())
                .map(|e| (e.mass, e.damping, e.slot))
                .collect(),
            (mass, damping),
            method,
        ))
    }

    /// Solves the stage systems of `system` as low-rank updates (eq. (32e)) when its
    /// nonlinearity lives on few enough dofs, their linear part split exactly (eq. (32f):
    /// every stage has the same tangent there) — `mass` and `damping` are the ones the
    /// stage system was built with.
    pub(in crate::integrate) fn with_low_rank<S: MechanicalSystem + ?Sized>(
        mut self,
        system: &S,
        (mass, damping): (&SparseMatrix, Option<&SparseMatrix>),
        method: &StageMethod,
    ) -> Self {
        let Some(dofs) = system.nonlinear_dofs() else {
            return self;
        };
        if method.a.len() * dofs.len() > LOW_RANK_MAX {
            return self;
        }
        let mut rest = vec![0.0; self.tangent.nonzeros()];
        system.tangent_values(&vec![0.0; system.dofs()], &mut rest);
        self.low_rank = Some(LowRank {
            dofs: dofs.to_vec(),
            rest,
            split: Self::split(&self.tangent, (mass, damping), method),
        });
        self
    }

    /// Whether the nonlinearity is localised (the stage systems are low-rank updates).
    pub(in crate::integrate) fn is_low_rank(&self) -> bool {
        self.low_rank.is_some()
    }

    /// `P` of eq. (32f) at the stage states (the split approximation of the exact stage
    /// Jacobian, `split` made by [`Self::split`] on this system's pattern), with the tangents
    /// it was built from; `None` when a split system is singular.
    pub(in crate::integrate) fn factorise_split<S: MechanicalSystem + ?Sized>(
        &self,
        split: &SplitStages,
        system: &S,
        states: &[f64],
        h: f64,
    ) -> Option<(StageLu, StageTangents)> {
        let tangents = self.tangents(system, states);
        let lu = split.factorise(h, &tangents)?;
        Some((
            StageLu::Split(Arc::new(lu)),
            StageTangents::Sparse(self.tangent.clone(), tangents),
        ))
    }

    /// The linear part of the stage system at step `h`, factorised ([`LinearStages`]).
    fn linear(&self, low_rank: &LowRank, h: f64, method: &StageMethod) -> Option<LinearStages> {
        let abar = &method.abar;
        let s = abar.len();
        let n = self.tangent.row_start.len() - 1;
        let lu = match &low_rank.split {
            Some(split) => {
                LinearLu::Split(split.factorise(h, std::slice::from_ref(&low_rank.rest))?)
            }
            None => {
                let rest: Vec<Vec<f64>> = vec![low_rank.rest.clone(); s];
                LinearLu::Whole(self.lu.factorise(&self.damped_values(
                    |i, j| h * h * abar[i][j],
                    |i, j| h * method.a[i][j],
                    &rest,
                ))?)
            }
        };
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

    /// The values of `J_ij = M δ_ij + scale(i, j) K_i` in the pattern's order, from the
    /// tangents `K_i` given on the system's pattern (free motions: no `C`).
    pub(super) fn values(
        &self,
        scale: impl Fn(usize, usize) -> f64,
        tangents: &[Vec<f64>],
    ) -> Vec<f64> {
        self.entries
            .iter()
            .map(|e| {
                let (bi, bj) = e.block;
                e.mass + e.slot.map_or(0.0, |p| scale(bi, bj) * tangents[bi][p])
            })
            .collect()
    }

    /// The values of `J_ij = M δ_ij + damping(i, j) C + scale(i, j) K_i` (eq. (96)).
    fn damped_values(
        &self,
        scale: impl Fn(usize, usize) -> f64,
        damping: impl Fn(usize, usize) -> f64,
        tangents: &[Vec<f64>],
    ) -> Vec<f64> {
        self.entries
            .iter()
            .map(|e| {
                let (bi, bj) = e.block;
                let c = if e.damping == 0.0 {
                    0.0
                } else {
                    damping(bi, bj) * e.damping
                };
                e.mass + c + e.slot.map_or(0.0, |p| scale(bi, bj) * tangents[bi][p])
            })
            .collect()
    }

    /// The tangents `K_t(X_i)` at the stage states (`s × n`), on the system's pattern.
    fn tangents<S: MechanicalSystem + ?Sized>(&self, system: &S, states: &[f64]) -> Vec<Vec<f64>> {
        let n = system.dofs();
        states
            .chunks(n)
            .map(|x| {
                let mut values = vec![0.0; self.tangent.nonzeros()];
                system.tangent_values(x, &mut values);
                values
            })
            .collect()
    }

    /// The exact stage Jacobian `J_ij = M δ_ij + h A_ij C + h² Ā_ij K_t(X_i)` at the stage
    /// states, factorised whole or, for a localised nonlinearity, as a low-rank update of its
    /// linear part at `h` (kept in `linear` for the steps of the same size); with the tangents
    /// it was built from. `None` when it is singular.
    pub(in crate::integrate) fn factorise<S: MechanicalSystem + ?Sized>(
        &self,
        system: &S,
        states: &[f64],
        h: f64,
        method: &StageMethod,
        linear: &mut Option<Arc<LinearStages>>,
    ) -> Option<(StageLu, StageTangents)> {
        let tangents = self.tangents(system, states);
        let lu = match &self.low_rank {
            Some(low_rank) => {
                if linear.as_ref().is_none_or(|l| l.h != h) {
                    *linear = Some(Arc::new(self.linear(low_rank, h, method)?));
                }
                let base = linear.clone().expect("just made");
                StageLu::LowRank(low_rank.update(system, base, states)?)
            }
            None => {
                let values = self.damped_values(
                    |bi, bj| h * h * method.abar[bi][bj],
                    |bi, bj| h * method.a[bi][bj],
                    &tangents,
                );
                StageLu::Sparse(self.lu.factorise(&values)?)
            }
        };
        Some((lu, StageTangents::Sparse(self.tangent.clone(), tangents)))
    }
}

/// A factorised stage Jacobian: exact, or the split approximation `P` (eq. (32f)).
#[derive(Clone)]
pub(in crate::integrate) enum StageLu {
    Dense(DenseLu),
    Sparse(SparseLu),
    LowRank(UpdatedStages),
    Split(Arc<SplitLu>),
}

impl StageLu {
    /// `J⁻¹ B` (`P⁻¹ B` for the split approximation): what the stage Newton iteration needs.
    pub(in crate::integrate) fn solve_in_place(&self, b: &mut [f64], cols: usize) {
        match self {
            StageLu::Dense(lu) => lu.solve_in_place(b, cols),
            StageLu::Sparse(lu) => lu.solve_in_place(b, cols),
            StageLu::LowRank(update) => update.solve_in_place(b, cols),
            StageLu::Split(split) => split.solve_in_place(b, cols),
        }
    }

    /// `J⁻¹ B` to round-off (`accuracy` 0) or to `accuracy` relative, `J` built from
    /// `tangents`, as it moves the state `image` says: what the variational step needs. A
    /// split solve's buffers come from `scratch`.
    pub(in crate::integrate) fn solve_exact(
        &self,
        b: &mut [f64],
        cols: usize,
        tangents: &StageTangents,
        target: (f64, &StepImage),
        scratch: &mut Scratch,
    ) {
        match self {
            StageLu::Split(split) => {
                split.solve_exact(b, cols, tangents, target, scratch);
            }
            exact => exact.solve_in_place(b, cols),
        }
    }
}

impl<S: MechanicalSystem + ?Sized> GaussLegendre<'_, S> {
    /// The split stage systems (eq. (32f)) of a sparse stage system whose nonlinearity is
    /// not localised; `None` otherwise.
    pub(super) fn split_stages(
        system: &S,
        sparse: Option<&SparseStages>,
        mass: &SparseMatrix,
        method: &StageMethod,
    ) -> Option<SplitStages> {
        if sparse?.is_low_rank() {
            return None;
        }
        SparseStages::split(system.tangent_pattern()?, (mass, None), method)
    }

    /// Splits the stage systems whatever the model's size (tests of eq. (32f) on small ones).
    #[cfg(test)]
    pub(in crate::integrate) fn with_split_stages(mut self) -> Self {
        self.split = Self::split_stages(
            self.form.system(),
            self.sparse.as_ref(),
            &self.mass,
            &self.coefficients,
        );
        assert!(self.split.is_some(), "a sparse model, nonlinear everywhere");
        self
    }

    /// Whether the stage systems are solved as low-rank updates (eq. (32e)).
    #[cfg(test)]
    pub(in crate::integrate) fn solves_low_rank(&self) -> bool {
        self.sparse.as_ref().is_some_and(|s| s.low_rank.is_some())
    }

    /// The exact stage Jacobian `J_ij = M δ_ij + h² Ā_ij K_t(X_i)` at the stage states,
    /// factorised (sparse when the system gives its tangent on a pattern, dense otherwise),
    /// with the tangents `K_t(X_i)` it was built from.
    pub(super) fn stage_jacobian(
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
            if let Some(split) = self
                .split
                .as_ref()
                .filter(|_| split && sparse.low_rank.is_none())
            {
                return sparse
                    .factorise_split(split, system, states, h)
                    .ok_or_else(singular);
            }
            return sparse
                .factorise(system, states, h, &self.coefficients, linear)
                .ok_or_else(singular);
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
            h * h * self.coefficients.abar[bi][bj] * tangents[bi * n * n + c * n + r]
        });
        for i in 0..s {
            self.add_mass(&mut jacobian, i * n);
        }
        Ok((
            StageLu::Dense(DenseLu::new(jacobian.as_ref())),
            StageTangents::Dense(tangents),
        ))
    }

    /// Adds `M` to the diagonal block of a dense matrix that starts at `(offset, offset)`.
    pub(super) fn add_mass(&self, a: &mut Mat<f64>, offset: usize) {
        let pattern = self.mass.pattern();
        for r in 0..self.mass.dimension() {
            for p in pattern.row_start[r]..pattern.row_start[r + 1] {
                a[(offset + r, offset + pattern.col[p])] += self.mass.values()[p];
            }
        }
    }
}
