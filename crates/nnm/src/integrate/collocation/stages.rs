//! The stage system `J_ij = M δ_ij + h² Ā_ij K_t(X_i)` of a collocation step (docs/method.md
//! eqs. (32a)–(32f)): its sparse pattern, analysed once, and its factorisation — whole (sparse,
//! or dense when the system gives no tangent pattern), as a low-rank update of its linear part
//! (`low_rank.rs`), or split into systems of the model's size (`split.rs`).

use std::sync::Arc;

use super::GaussLegendre;
use super::low_rank::{LOW_RANK_MAX, LinearStages, LowRank, UpdatedStages};
use super::split::{SplitLu, SplitStages, StageEigen};
use super::tangents::StageTangents;
use crate::integrate::IntegrationError;
use crate::linalg::{DenseLu, Mat, SparseLu, SparseLuPattern};
use crate::model::{Block, BlockMut, MechanicalSystem, SparseMatrix, SparsityPattern};

/// The stage Jacobian `J_ij = M δ_ij + h² Ā_ij K_t(X_i)` as a sparse matrix: its structure
/// (every block on the union of `M`'s and `K_t`'s patterns), analysed once, and for each entry
/// where its values come from.
pub(super) struct SparseStages {
    /// `K_t`'s pattern (compressed rows), shared with the tangents a step records.
    tangent: Arc<SparsityPattern>,
    pub(super) lu: SparseLuPattern,
    /// Per entry of `J` in compressed-column order: its blocks `(i, j)`, its `M` value (on
    /// diagonal blocks) and its position in `K_t`'s values, if there is one.
    entries: Vec<(usize, usize, f64, Option<usize>)>,
    /// When the nonlinearity is localised: the stage system as a low-rank update of its
    /// linear part (eq. (32e)).
    low_rank: Option<LowRank>,
}

impl SparseStages {
    pub(super) fn new(
        tangent: &SparsityPattern,
        mass: &SparseMatrix,
        stages: usize,
    ) -> Option<Self> {
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
    pub(super) fn with_low_rank<S: MechanicalSystem + ?Sized>(
        mut self,
        system: &S,
        stages: usize,
    ) -> Self {
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

    /// The values of `J_ij = M δ_ij + scale(i, j) K_i` in the pattern's order, from the
    /// tangents `K_i` given on the system's pattern.
    pub(super) fn values(
        &self,
        scale: impl Fn(usize, usize) -> f64,
        tangents: &[Vec<f64>],
    ) -> Vec<f64> {
        self.entries
            .iter()
            .map(|&(bi, bj, m, slot)| m + slot.map_or(0.0, |p| scale(bi, bj) * tangents[bi][p]))
            .collect()
    }
}

/// A factorised stage Jacobian: exact, or the split approximation `P` (eq. (32f)).
#[derive(Clone)]
pub(super) enum StageLu {
    Dense(DenseLu),
    Sparse(SparseLu),
    LowRank(UpdatedStages),
    Split(Arc<SplitLu>),
}

impl StageLu {
    /// `J⁻¹ B` (`P⁻¹ B` for the split approximation): what the stage Newton iteration needs.
    pub(super) fn solve_in_place(&self, b: &mut [f64], cols: usize) {
        match self {
            StageLu::Dense(lu) => lu.solve_in_place(b, cols),
            StageLu::Sparse(lu) => lu.solve_in_place(b, cols),
            StageLu::LowRank(update) => update.solve_in_place(b, cols),
            StageLu::Split(split) => split.solve_in_place(b, cols),
        }
    }

    /// `J⁻¹ B` to round-off, `J` built from `tangents`: what the variational step needs.
    pub(super) fn solve_exact(&self, b: &mut [f64], cols: usize, tangents: &StageTangents) {
        match self {
            StageLu::Split(split) => {
                split.solve_exact(b, cols, tangents);
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
    pub(in crate::integrate) fn with_split_stages(mut self) -> Self {
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
