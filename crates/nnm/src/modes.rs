//! Linear modal analysis: `K v = ω² M v`, rigid-body modes, and for cyclic structures the
//! `(n, d)` labels and sector-aligned standing waves of degenerate pairs (docs/method.md §11,
//! eq. (53) and Table 1).
//!
//! Every returned mode is checked against the matrices as given (docs/method.md §10,
//! eqs. (67)–(71)): an elastic mode has `‖K v − ω² M v‖ ≤ 1e-10 ‖K v‖` (residual in
//! double-double arithmetic), a rigid one has `K v = 0` to the rounding of `K`'s entries, and a
//! mode that round-off cannot place on either side is an error, never a silent answer.

use std::f64::consts::PI;

use crate::linalg::{self, LinalgError, Mat};
use crate::model::{Block, BlockMut, CyclicSymmetry, MassOperator, MechanicalSystem};

mod sectors;
mod shift_invert;

pub use sectors::add_labelled_mode;
use shift_invert::{Csr, Operators, Scale};
pub use shift_invert::{ELASTIC_ROUNDING, RESIDUAL_ROUNDING, RESIDUAL_TOLERANCE, RIGID_ROUNDING};

/// A linear normal mode.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearMode {
    /// Natural frequency ω (rad/s); 0 for rigid-body modes.
    pub frequency: f64,
    /// Mass-normalised shape (`vᵀ M v = 1`).
    pub shape: Vec<f64>,
    /// A rigid-body mode (null space of K).
    pub rigid: bool,
    /// For cyclic structures: nodal circles `n`, nodal diameters `d`, and which standing wave of
    /// a degenerate pair this is.
    pub cyclic: Option<CyclicLabel>,
}

/// `(n, d)` label of a mode of a cyclic structure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CyclicLabel {
    /// Index of the frequency level among the modes with `d` nodal diameters (the paper's
    /// nodal circles: 0 = blade and disk in phase, 1 = out of phase, for the bladed disk).
    pub circles: usize,
    /// Nodal diameters `d`: the dominant spatial harmonic over the sectors (docs/method.md
    /// eq. (53)).
    pub diameters: usize,
    /// `None` for single modes (d = 0, or d = N/2); `Some` for each member of a pair.
    pub pattern: Option<StandingWave>,
}

/// The two real standing waves spanning a degenerate pair: sector `i` moves as
/// `cos(2π d i / N)` or `sin(2π d i / N)` times the sector shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StandingWave {
    /// Sector `i` moves as `cos(2π d i / N)`: mirror-even (the default pattern).
    Cos,
    /// Sector `i` moves as `sin(2π d i / N)`: mirror-odd.
    Sin,
}

impl LinearMode {
    /// The label `"n,d"` of cyclic models, empty otherwise (the `modes.csv` convention).
    pub fn label(&self) -> String {
        self.cyclic
            .map(|c| format!("{},{}", c.circles, c.diameters))
            .unwrap_or_default()
    }
}

/// Why modal analysis failed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ModesError {
    /// The mass matrix has no Cholesky factor.
    #[error("mass matrix is not positive definite")]
    MassNotPositiveDefinite,
    /// `K` has an eigenvalue `ω²` below zero beyond round-off (the value held): the rest state
    /// is unstable.
    #[error(
        "stiffness matrix has a negative eigenvalue ({0:.3e}): the equilibrium is unstable and has no normal modes"
    )]
    NegativeStiffness(f64),
    /// The eigensolver failed.
    #[error("eigenvalue computation failed: {0}")]
    Eigen(#[from] LinalgError),
    /// A mode's `K v` is too few round-offs away from zero to tell an elastic mode from a
    /// rigid one in double precision (docs/method.md eq. (70)): the stiffness spread of the
    /// model (a penalty spring, a very fine mesh) defeats the arithmetic.
    #[error(
        "mode {mode} (omega^2 = {omega_squared:.3e}) cannot be told from a rigid-body mode in double precision: K v is only {rounding_units:.0} round-offs of K's entries away from zero (the model's stiffness spread is too large; soften penalty springs or coarsen the mesh)"
    )]
    IllConditioned {
        /// Index of the mode in ascending order (0-based).
        mode: usize,
        /// Its `ω²` for the matrices as given.
        omega_squared: f64,
        /// `ρ = ‖K v‖ / (u ‖|K| |v|‖)` (eq. (70)).
        rounding_units: f64,
    },
    /// The shift-invert iteration did not bring every wanted mode below the residual
    /// tolerance (eq. (69)).
    #[error(
        "modal analysis did not converge in {iterations} iterations (worst relative residual {residual:.1e})"
    )]
    NotConverged {
        /// Iterations made.
        iterations: usize,
        /// The worst relative residual `‖K v − ω² M v‖ / ‖K v‖` of the wanted modes.
        residual: f64,
    },
    /// `K + τ M` (eq. (67)) could not be factorised.
    #[error("the shifted stiffness K + tau M is singular or not finite")]
    Singular,
    /// [`lowest_modes`] on a large model without a sparse tangent and a sparse or diagonal
    /// mass.
    #[error(
        "the model has {0} dofs but no sparse stiffness and mass: the lowest modes need them (MechanicalSystem::tangent_pattern, a sparse or diagonal mass)"
    )]
    NotSparse(usize),
}

/// Above this many dofs, a model with sparse `K` and `M` gets only its lowest
/// [`LARGE_MODEL_MODES`] modes from [`linear_modes`] (shift-invert, `O(n)` memory) instead of
/// all `n` from a dense `O(n²)`-memory, `O(n³)`-time eigen-decomposition. Measured on the
/// ECL beam: at 1,000 dofs (500 elements) every dense mode passes the residual check (69)
/// after refinement; at 1,400 and 1,800 the stiffest clusters (condition ~10¹⁴) did not
/// within 100 refinement iterations. Shooting needs only the lowest modes above this size (it
/// is matrix-free there, docs/method.md §15).
pub const DENSE_MODES_LIMIT: usize = 1000;

/// How many lowest modes [`linear_modes`] returns for a sparse model above
/// [`DENSE_MODES_LIMIT`] dofs (more when the last one is part of a degenerate pair).
pub const LARGE_MODEL_MODES: usize = 20;

/// The dense matrices `M` and `K = K_t(0)` of a system's linearisation at rest, from its
/// operators (`n` products each: for the full-spectrum analysis of small and medium models).
pub fn linearised_matrices<S: MechanicalSystem + ?Sized>(system: &S) -> (Mat<f64>, Mat<f64>) {
    let n = system.dofs();
    let eye: Vec<f64> = (0..n * n)
        .map(|k| if k % (n + 1) == 0 { 1.0 } else { 0.0 })
        .collect();
    let (mut m, mut k) = (vec![0.0; n * n], vec![0.0; n * n]);
    system.mass().apply(&eye, n, &mut m);
    system.tangent_stiffness(
        &vec![0.0; n],
        Block::new(&eye, n, n, n),
        BlockMut::new(&mut k, n, n, n),
    );
    let dense = |v: &[f64]| Mat::from_fn(n, n, |i, j| 0.5 * (v[j * n + i] + v[i * n + j]));
    (dense(&m), dense(&k))
}

/// The dense mass matrix of a system, from its operator (`n` products).
pub fn dense_mass<S: MechanicalSystem + ?Sized>(system: &S) -> Mat<f64> {
    crate::model::dense_mass_matrix(system.mass())
}

/// All linear modes of `system` (its linearisation at rest), in ascending frequency; for a
/// sparse model above [`DENSE_MODES_LIMIT`] dofs only the lowest [`LARGE_MODEL_MODES`]
/// ([`lowest_modes`]).
///
/// Solves the generalized symmetric problem through the Cholesky factor `M = L Lᵀ`:
/// `(L⁻¹ K L⁻ᵀ) w = ω² w`, `v = L⁻ᵀ w` (faer has no generalized symmetric solver), then checks
/// every mode against `K` and `M` themselves (docs/method.md eqs. (69), (70)). The dense
/// solver's errors are `ε λ_max`, so on a stiff model the low modes fail that check; each
/// cluster of failing modes is then refined by shift-invert iteration (eq. (68)) until it
/// passes. Rigid-body modes are those whose `K v` vanishes to round-off (eq. (70)), not
/// those below a fraction of the largest eigenvalue.
pub fn linear_modes<S: MechanicalSystem + ?Sized>(
    system: &S,
) -> Result<Vec<LinearMode>, ModesError> {
    let n = system.dofs();
    let sparse = Operators::sparse(system).map(|ops| {
        let scale = Scale::of(&ops);
        (scale.operators(ops), scale)
    });
    let lowest =
        |ops: &Operators| shift_invert::to_modes(shift_invert::lowest(ops, LARGE_MODEL_MODES)?);
    let mut modes = match sparse {
        Some((ops, scale)) if n > DENSE_MODES_LIMIT => scale.unscale(lowest(&ops))?,
        sparse => all_modes(system, sparse, lowest)?,
    };
    if let Some(cyclic) = system.cyclic_symmetry() {
        label_cyclic(&mut modes, cyclic, system.mass());
    }
    Ok(modes)
}

/// Every mode of `system` by a dense eigen-decomposition refined against `K` and `M`
/// ([`linear_modes`]), or `lowest` of its sparse operators when the stiff end cannot be
/// refined to the residual check. `sparse` comes scaled, with its scale; the dense matrices
/// get the same one (or their own), and the modes are returned for the model as given.
fn all_modes<S: MechanicalSystem + ?Sized>(
    system: &S,
    sparse: Option<(Operators, Scale)>,
    lowest: impl Fn(&Operators) -> Result<Vec<LinearMode>, ModesError>,
) -> Result<Vec<LinearMode>, ModesError> {
    let (mass, stiffness) = linearised_matrices(system);
    let largest = |a: &Mat<f64>| {
        (0..a.ncols())
            .flat_map(|j| (0..a.nrows()).map(move |i| (i, j)))
            .fold(0.0f64, |m, (i, j)| m.max(a[(i, j)].abs()))
    };
    let scale = sparse.as_ref().map_or_else(
        || Scale::new(largest(&stiffness), largest(&mass)),
        |(_, s)| *s,
    );
    let (sk, sm) = scale.factors();
    let n = mass.nrows();
    let stiffness = Mat::from_fn(n, n, |i, j| sk * stiffness[(i, j)]);
    let mass = Mat::from_fn(n, n, |i, j| sm * mass[(i, j)]);
    scale.unscale(scaled_modes(&stiffness, &mass, sparse.map(|s| s.0), lowest))
}

/// [`all_modes`] on the scaled pencil.
fn scaled_modes(
    stiffness: &Mat<f64>,
    mass: &Mat<f64>,
    sparse: Option<Operators>,
    lowest: impl Fn(&Operators) -> Result<Vec<LinearMode>, ModesError>,
) -> Result<Vec<LinearMode>, ModesError> {
    let n = mass.nrows();
    let (eigenvalues, shapes) = symmetric_pencil(stiffness, mass)?;
    let shapes: Vec<f64> = (0..n)
        .flat_map(|k| (0..n).map(move |i| (i, k)))
        .map(|(i, k)| shapes[(i, k)])
        .collect();
    let is_sparse = sparse.is_some();
    let ops =
        sparse.unwrap_or_else(|| Operators::new(Csr::from_dense(stiffness), Csr::from_dense(mass)));
    match shift_invert::refine_dense(&ops, &shapes, eigenvalues.len()) {
        // The stiffest clusters of a very stiff model (a von Kármán beam's axial modes) can
        // stay above the residual tolerance (69) however long they are refined — measured:
        // 150 to 333 von Kármán elements (447–999 dofs) failed here, with worst residuals
        // from 6.5e-12 to 3.6e-3 — while the lowest modes, all that matrix-free shooting
        // needs, converge by shift-invert alone. A sparse model then gets those, as above
        // DENSE_MODES_LIMIT; a dense one has no such way out.
        Err(ModesError::NotConverged { .. }) if is_sparse => lowest(&ops),
        pairs => shift_invert::to_modes(pairs?),
    }
}

/// `K v = λ M v` for dense symmetric `K` and positive definite `M`: the eigenvalues in
/// ascending order and the `M`-orthonormal eigenvectors as columns, by the reduction
/// `L⁻¹ K L⁻ᵀ` (`M = L Lᵀ`) to a standard symmetric problem.
fn symmetric_pencil(
    stiffness: &Mat<f64>,
    mass: &Mat<f64>,
) -> Result<(Vec<f64>, Mat<f64>), ModesError> {
    let n = mass.nrows();
    let l =
        linalg::cholesky_lower(mass.as_ref()).map_err(|_| ModesError::MassNotPositiveDefinite)?;
    // A = L⁻¹ K L⁻ᵀ, built as L⁻¹ (L⁻¹ K)ᵀ since K is symmetric.
    let mut a = stiffness.clone();
    linalg::solve_lower_in_place(l.as_ref(), &mut a);
    let mut a = a.transpose().to_owned();
    linalg::solve_lower_in_place(l.as_ref(), &mut a);
    let a = Mat::from_fn(n, n, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    let (eigenvalues, mut vectors) = linalg::symmetric_eigen(a.as_ref())?;
    linalg::solve_lower_transpose_in_place(l.as_ref(), &mut vectors);
    Ok((eigenvalues, vectors))
}

/// The `count` lowest modes of `system`, in ascending frequency, by shift-invert subspace
/// iteration on sparse factorisations only (docs/method.md eqs. (67)–(71)): memory
/// `O(nnz(factor) + n · count)`, never `n × n`. More than `count` are returned when the last
/// one belongs to a degenerate pair (cyclic models), so that a pair is never cut in half.
///
/// `K` comes from [`MechanicalSystem::tangent_pattern`] and `tangent_values` at `x = 0`, `M`
/// from the mass operator's sparse or diagonal entries. A small model without them (up to
/// [`DENSE_MODES_LIMIT`] dofs) is solved by [`linear_modes`] instead; a large one is an error.
/// Every mode passes the residual check (eq. (69)) or the rigid-body test (eq. (70)).
pub fn lowest_modes<S: MechanicalSystem + ?Sized>(
    system: &S,
    count: usize,
) -> Result<Vec<LinearMode>, ModesError> {
    let n = system.dofs();
    let mut modes = match Operators::sparse(system) {
        Some(ops) => {
            let scale = Scale::of(&ops);
            let ops = scale.operators(ops);
            scale.unscale(shift_invert::to_modes(shift_invert::lowest(&ops, count)?))?
        }
        None if n <= DENSE_MODES_LIMIT => {
            let mut all = linear_modes(system)?;
            all.truncate(count.min(n));
            return Ok(all);
        }
        None => return Err(ModesError::NotSparse(n)),
    };
    if let Some(cyclic) = system.cyclic_symmetry() {
        label_cyclic(&mut modes, cyclic, system.mass());
    }
    Ok(modes)
}

/// Finds a mode by its label `"n,d"` (with `pattern` choosing within a pair, `Cos` by default)
/// or by a 0-based index into the ascending list.
pub fn find_mode<'a>(
    modes: &'a [LinearMode],
    selector: &str,
    pattern: Option<StandingWave>,
) -> Option<(usize, &'a LinearMode)> {
    let selector = selector.trim();
    if let Ok(index) = selector.parse::<usize>() {
        return modes.get(index).map(|m| (index, m));
    }
    let wanted = pattern.unwrap_or(StandingWave::Cos);
    let label: String = selector.chars().filter(|c| !c.is_whitespace()).collect();
    modes.iter().enumerate().find(|(_, m)| {
        m.label() == label
            && m.cyclic
                .is_some_and(|c| c.pattern.is_none_or(|p| p == wanted))
    })
}

/// Harmonic content of a shape over the sectors: `|Σ_i v_{i,r} e^{-2πi d i/N}|²` summed over
/// the dofs `r` of a sector, for `d = 0..=N/2`.
fn harmonic_content(shape: &[f64], cyclic: CyclicSymmetry, d: usize) -> f64 {
    let (n_s, s) = (cyclic.sectors, cyclic.dofs_per_sector);
    (0..s)
        .map(|r| {
            let (mut re, mut im) = (0.0, 0.0);
            for i in 0..n_s {
                let theta = 2.0 * PI * (d * i) as f64 / n_s as f64;
                re += shape[i * s + r] * theta.cos();
                im += shape[i * s + r] * theta.sin();
            }
            re * re + im * im
        })
        .sum()
}

/// The harmonic `d` whose `cos(2π d/N)` is the correlation of the shape with itself shifted by
/// one sector, `Σ_i v_i · v_{i+1} / Σ_i v_i · v_i` (sector blocks).
fn harmonic_guess(shape: &[f64], cyclic: CyclicSymmetry) -> usize {
    let (n_s, s) = (cyclic.sectors, cyclic.dofs_per_sector);
    let (mut cross, mut auto) = (0.0, 0.0);
    for i in 0..n_s {
        let next = (i + 1) % n_s;
        for r in 0..s {
            cross += shape[i * s + r] * shape[next * s + r];
            auto += shape[i * s + r] * shape[i * s + r];
        }
    }
    let c = if auto > 0.0 {
        (cross / auto).clamp(-1.0, 1.0)
    } else {
        1.0
    };
    ((c.acos() * n_s as f64 / (2.0 * PI)).round() as usize).min(n_s / 2)
}

/// Labels every mode `(n, d)`; rotates each degenerate pair into its cos and sin standing waves.
fn label_cyclic(modes: &mut [LinearMode], cyclic: CyclicSymmetry, mass: &dyn MassOperator) {
    let n_s = cyclic.sectors;
    let diameters: Vec<usize> = modes
        .iter()
        .map(|m| {
            // Every mode of a cyclic structure is one harmonic d (or a combination of ±d), for
            // which the sector-to-sector correlation is cos(2π d/N): that places d in O(N),
            // and the content is then compared near it only (a full scan is O(N²) per mode,
            // half a minute for the 21 lowest modes of 5,000 sectors).
            let guess = harmonic_guess(&m.shape, cyclic);
            let candidates: Vec<usize> = if n_s <= 64 {
                (0..=n_s / 2).collect()
            } else {
                (guess.saturating_sub(2)..=(guess + 2).min(n_s / 2)).collect()
            };
            candidates
                .into_iter()
                .map(|d| (d, harmonic_content(&m.shape, cyclic, d)))
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map_or(0, |(d, _)| d)
        })
        .collect();
    for d in 0..=n_s / 2 {
        // Indices are in ascending frequency already.
        let members: Vec<usize> = (0..modes.len()).filter(|&k| diameters[k] == d).collect();
        let paired = d != 0 && 2 * d != n_s;
        let group = if paired { 2 } else { 1 };
        for (level, chunk) in members.chunks(group).enumerate() {
            if let [a, b] = *chunk {
                let (cos, sin) = standing_waves(&modes[a].shape, &modes[b].shape, cyclic, d, mass);
                modes[a].shape = cos;
                modes[b].shape = sin;
            }
            for (k, &index) in chunk.iter().enumerate() {
                modes[index].cyclic = Some(CyclicLabel {
                    circles: level,
                    diameters: d,
                    pattern: (chunk.len() == 2).then_some(if k == 0 {
                        StandingWave::Cos
                    } else {
                        StandingWave::Sin
                    }),
                });
            }
        }
    }
}

/// Rotates an M-orthonormal pair `(u, w)` of harmonic `d` into the standing wave whose sin
/// content vanishes (cos wave) and its M-orthogonal partner (sin wave), signs fixed so that the
/// shapes correlate positively with `cos(θ_i)·a_r` and `sin(θ_i)·a_r`, `a` = sector 0 of the
/// cos wave.
fn standing_waves(
    u: &[f64],
    w: &[f64],
    cyclic: CyclicSymmetry,
    d: usize,
    mass: &dyn MassOperator,
) -> (Vec<f64>, Vec<f64>) {
    let (n_s, s) = (cyclic.sectors, cyclic.dofs_per_sector);
    let theta = |i: usize| 2.0 * PI * (d * i) as f64 / n_s as f64;
    let sin_content = |v: &[f64]| -> Vec<f64> {
        (0..s)
            .map(|r| (0..n_s).map(|i| v[i * s + r] * theta(i).sin()).sum())
            .collect()
    };
    let (su, sw) = (sin_content(u), sin_content(w));
    // Minimise |α su + β sw| over α² + β² = 1: smallest eigenvector of the 2×2 Gram matrix.
    let (g11, g12, g22) = (
        linalg::dot(&su, &su),
        linalg::dot(&su, &sw),
        linalg::dot(&sw, &sw),
    );
    let angle = 0.5 * (2.0 * g12).atan2(g11 - g22) + 0.5 * PI;
    let (alpha, beta) = (angle.cos(), angle.sin());
    let mut cos: Vec<f64> = u.iter().zip(w).map(|(a, b)| alpha * a + beta * b).collect();
    let mut sin: Vec<f64> = u
        .iter()
        .zip(w)
        .map(|(a, b)| -beta * a + alpha * b)
        .collect();
    // Orient: the cos wave's largest sector-0 dof positive, then the sin wave along sin θ·a.
    let r_max = (0..s)
        .max_by(|&a, &b| cos[a].abs().total_cmp(&cos[b].abs()))
        .unwrap_or(0);
    if cos[r_max] < 0.0 {
        cos.iter_mut().for_each(|v| *v = -*v);
    }
    let template_dot = |v: &[f64]| -> f64 {
        (0..n_s)
            .map(|i| (0..s).map(|r| v[i * s + r] * cos[r]).sum::<f64>() * theta(i).sin())
            .sum()
    };
    if template_dot(&sin) < 0.0 {
        sin.iter_mut().for_each(|v| *v = -*v);
    }
    // Re-normalise against round-off (the rotation is orthogonal, so this is a polish).
    for v in [&mut cos, &mut sin] {
        let m = shift_invert::mass_norm(mass, v);
        v.iter_mut().for_each(|x| *x /= m);
    }
    (cos, sin)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{BladedDisk, two_dof};

    /// Table 1 of the paper: all 60 frequencies of the bladed disk with their (n, d) labels, to
    /// the three printed decimals.
    #[test]
    fn bladed_disk_reproduces_table_1() {
        const TABLE_1: [[f64; 16]; 2] = [
            [
                0.000, 0.183, 0.363, 0.536, 0.700, 0.850, 0.985, 1.103, 1.202, 1.282, 1.346, 1.394,
                1.428, 1.452, 1.465, 1.470,
            ],
            [
                2.082, 2.084, 2.092, 2.104, 2.123, 2.147, 2.178, 2.215, 2.258, 2.304, 2.350, 2.394,
                2.431, 2.460, 2.478, 2.485,
            ],
        ];
        let modes = linear_modes(&BladedDisk::default().build().unwrap()).unwrap();
        assert_eq!(modes.len(), 60);
        let mut seen = [[0usize; 16]; 2];
        for m in &modes {
            let c = m.cyclic.expect("every bladed-disk mode is labelled");
            let expected = TABLE_1[c.circles][c.diameters];
            assert!(
                (m.frequency - expected).abs() <= 0.0005 + 1e-12,
                "({},{}): {} vs {expected}",
                c.circles,
                c.diameters,
                m.frequency
            );
            seen[c.circles][c.diameters] += 1;
        }
        for (n, row) in seen.iter().enumerate() {
            for (d, &count) in row.iter().enumerate() {
                let pair = d != 0 && d != 15;
                assert_eq!(count, if pair { 2 } else { 1 }, "mode ({n},{d})");
            }
        }
        assert!(modes[0].rigid && modes.iter().filter(|m| m.rigid).count() == 1);
    }

    /// The cos and sin waves of a pair follow cos(2π d i/N) and sin(2π d i/N) sector by sector.
    #[test]
    fn degenerate_pairs_are_sector_aligned_standing_waves() {
        let structure = BladedDisk::default().build().unwrap();
        let modes = linear_modes(&structure).unwrap();
        for (label, d) in [("1,5", 5usize), ("0,14", 14), ("0,1", 1)] {
            for pattern in [StandingWave::Cos, StandingWave::Sin] {
                let (_, m) = find_mode(&modes, label, Some(pattern)).unwrap();
                let a = [m.shape[0], m.shape[1]];
                let reference = if pattern == StandingWave::Cos {
                    a
                } else {
                    // sector 0 of the sin wave is zero: take its sector-shape from the cos wave.
                    let (_, c) = find_mode(&modes, label, Some(StandingWave::Cos)).unwrap();
                    [c.shape[0], c.shape[1]]
                };
                for i in 0..30 {
                    let theta = 2.0 * PI * (d * i) as f64 / 30.0;
                    let factor = match pattern {
                        StandingWave::Cos => theta.cos(),
                        StandingWave::Sin => theta.sin(),
                    };
                    for r in 0..2 {
                        let expected = reference[r] * factor;
                        assert!(
                            (m.shape[2 * i + r] - expected).abs() < 1e-9,
                            "{label} {pattern:?} sector {i} dof {r}"
                        );
                    }
                }
            }
        }
    }

    /// Two-DOF system: ω² = 1 and 3, shapes (1,1)/√2 and (1,-1)/√2.
    #[test]
    fn two_dof_modes() {
        let modes = linear_modes(&two_dof(0.5).unwrap()).unwrap();
        assert!((modes[0].frequency - 1.0).abs() < 1e-14);
        assert!((modes[1].frequency - 3f64.sqrt()).abs() < 1e-14);
        let s = &modes[0].shape;
        assert!((s[0].abs() - 0.5f64.sqrt()).abs() < 1e-14 && (s[0] - s[1]).abs() < 1e-14);
        assert!(
            modes
                .iter()
                .all(|m| m.cyclic.is_none() && m.label().is_empty())
        );
    }

    #[test]
    fn mode_selection() {
        let modes = linear_modes(&BladedDisk::default().build().unwrap()).unwrap();
        assert_eq!(find_mode(&modes, "0", None).unwrap().0, 0);
        assert!(find_mode(&modes, "1, 5", None).is_some());
        assert!(find_mode(&modes, "2,5", None).is_none());
        assert!(find_mode(&modes, "60", None).is_none());
        let (i_cos, _) = find_mode(&modes, "1,5", Some(StandingWave::Cos)).unwrap();
        let (i_sin, _) = find_mode(&modes, "1,5", Some(StandingWave::Sin)).unwrap();
        assert_ne!(i_cos, i_sin);
    }

    /// Residual of each mode against the system's own operators, in double: what a user can
    /// check without our double-double arithmetic (loose where `K v` cancels).
    fn max_relative_residual<S: MechanicalSystem + ?Sized>(s: &S, modes: &[LinearMode]) -> f64 {
        let (m, k) = linearised_matrices(s);
        modes
            .iter()
            .filter(|mode| !mode.rigid)
            .map(|mode| {
                let kv =
                    linalg::product(k.as_ref(), linalg::view(&mode.shape, s.dofs(), 1, s.dofs()));
                let mv =
                    linalg::product(m.as_ref(), linalg::view(&mode.shape, s.dofs(), 1, s.dofs()));
                let w2 = mode.frequency * mode.frequency;
                let r: Vec<f64> = (0..s.dofs())
                    .map(|i| kv[(i, 0)] - w2 * mv[(i, 0)])
                    .collect();
                let kv: Vec<f64> = (0..s.dofs()).map(|i| kv[(i, 0)]).collect();
                linalg::norm(&r) / linalg::norm(&kv)
            })
            .fold(0.0, f64::max)
    }

    fn spring_pair(k: f64, mass: [f64; 2]) -> crate::model::Structure {
        crate::model::Structure::new(
            Matrix::from_fn(2, 2, |i, j| if i == j { mass[i] } else { 0.0 }),
            Matrix::from_fn(2, 2, |i, j| if i == j { k + 1.0 } else { -k }),
            vec![],
        )
        .unwrap()
    }

    use crate::model::Matrix;

    /// A penalty spring k = 1e12 between two unit masses tied to ground by unit springs:
    /// ω² = 1 and 1 + 2k, both elastic (the old threshold, 1e-12 λ_max, called the first
    /// rigid). With k = 1e14 the soft mode is 45 round-offs of K's entries from zero: refused
    /// (eq. (70)). With k = 1e16, k + 1 rounds to k and K is singular as given: rigid.
    #[test]
    fn penalty_spring_gives_the_soft_mode_or_an_error() {
        let modes = linear_modes(&spring_pair(1e12, [1.0, 1.0])).unwrap();
        assert!(!modes[0].rigid && !modes[1].rigid);
        assert!(
            (modes[0].frequency - 1.0).abs() < 1e-14,
            "{}",
            modes[0].frequency
        );
        let w2 = modes[1].frequency.powi(2);
        assert!((w2 - (1.0 + 2e12)).abs() < 1e-14 * w2, "{w2}");
        assert!((modes[0].shape[0] - modes[0].shape[1]).abs() < 1e-14);
        let lowest = lowest_modes(&spring_pair(1e12, [1.0, 1.0]), 1).unwrap();
        assert!((lowest[0].frequency - 1.0).abs() < 1e-14 && !lowest[0].rigid);
        match linear_modes(&spring_pair(1e14, [1.0, 1.0])) {
            Err(ModesError::IllConditioned {
                mode: 0,
                omega_squared,
                rounding_units,
            }) => {
                assert!((omega_squared - 1.0).abs() < 1e-10 && rounding_units < 100.0);
            }
            other => panic!("expected IllConditioned, got {other:?}"),
        }
        let singular = linear_modes(&spring_pair(1e16, [1.0, 1.0])).unwrap();
        assert!(singular[0].rigid && !singular[1].rigid);
    }

    /// `M = diag(1, 1e-12)`, `K = I`: ω² = 1 and 1e12 (the old threshold made the first
    /// rigid).
    #[test]
    fn tiny_mass_keeps_both_modes_elastic() {
        let s = crate::model::Structure::new(
            Matrix::from_fn(2, 2, |i, j| {
                if i != j {
                    0.0
                } else if i == 0 {
                    1.0
                } else {
                    1e-12
                }
            }),
            Matrix::identity(2),
            vec![],
        )
        .unwrap();
        for modes in [linear_modes(&s).unwrap(), lowest_modes(&s, 2).unwrap()] {
            assert!(modes.iter().all(|m| !m.rigid));
            assert!((modes[0].frequency - 1.0).abs() < 1e-15);
            assert!((modes[1].frequency - 1e6).abs() < 1e-9);
        }
    }

    /// A model's modes do not depend on its units: `K0 = [[1, -0.5], [-0.5, 1]]` and `M0`
    /// (diagonal, then full) scaled by `a` and `b` from 1e-300 to 1e154 give `ω = √(a/b) ω0`
    /// and `v = v0 / √b`, every mode elastic, from both paths. (The checks of eqs. (69)–(70)
    /// formed squares of `K v` that overflowed or underflowed, and read the modes as rigid.)
    #[test]
    fn modes_do_not_depend_on_the_units() {
        use crate::model::Structure;
        let scaled = |a: &Matrix, c: f64| Matrix::from_fn(2, 2, |i, j| c * a.get(i, j));
        let k0 = Matrix::from_fn(2, 2, |i, j| if i == j { 1.0 } else { -0.5 });
        let diagonal =
            Matrix::from_fn(2, 2, |i, j| if i == j { 1.0 / (i + 1) as f64 } else { 0.0 });
        let full = Matrix::from_fn(2, 2, |i, j| if i == j { 1.0 } else { 0.25 });
        for m0 in [diagonal, full] {
            let reference =
                linear_modes(&Structure::new(m0.clone(), k0.clone(), vec![]).unwrap()).unwrap();
            for (a, b) in [
                (1e154, 1.0),
                (1e154, 1e154),
                (1.0, 1e-300),
                (1e-300, 1e-300),
                (1e-300, 1.0),
                (1e100, 1e-200),
            ] {
                let s = Structure::new(scaled(&m0, b), scaled(&k0, a), vec![]).unwrap();
                for modes in [linear_modes(&s).unwrap(), lowest_modes(&s, 2).unwrap()] {
                    assert_eq!(modes.len(), 2);
                    for (m, r) in modes.iter().zip(&reference) {
                        let expected = r.frequency * (a / b).sqrt();
                        assert!(!m.rigid, "K x {a:e}, M x {b:e}: {modes:?}");
                        assert!(
                            (m.frequency / expected - 1.0).abs() < 1e-12,
                            "K x {a:e}, M x {b:e}: {} vs {expected}",
                            m.frequency
                        );
                        let sign = linalg::dot(&m.shape, &r.shape).signum();
                        for (x, y) in m.shape.iter().zip(&r.shape) {
                            assert!((sign * x * b.sqrt() - y).abs() < 1e-12, "{x} vs {y}");
                        }
                    }
                }
            }
        }
    }

    /// A free–free chain of `n` unit masses and unit springs: exactly one rigid mode, and
    /// `ω_k = 2 sin(kπ/(2n))` for the elastic ones, to round-off, from both paths.
    #[test]
    fn free_free_chain_has_one_rigid_mode_and_exact_frequencies() {
        let n = 40;
        let mut t = Vec::new();
        for i in 0..n - 1 {
            t.extend([
                (i, i, 1.0),
                (i + 1, i + 1, 1.0),
                (i, i + 1, -1.0),
                (i + 1, i, -1.0),
            ]);
        }
        let k = crate::model::SparseMatrix::from_triplets(n, &t).unwrap();
        let chain = crate::model::Structure::new(Matrix::identity(n), k, vec![]).unwrap();
        let all = linear_modes(&chain).unwrap();
        let low = lowest_modes(&chain, 6).unwrap();
        assert_eq!(all.iter().filter(|m| m.rigid).count(), 1);
        assert_eq!(low.iter().filter(|m| m.rigid).count(), 1);
        assert!(all[0].rigid && low[0].rigid && all[0].frequency == 0.0);
        for modes in [&all, &low] {
            for (k, m) in modes.iter().enumerate().skip(1) {
                let exact = 2.0 * (k as f64 * PI / (2.0 * n as f64)).sin();
                assert!(
                    (m.frequency - exact).abs() < 1e-14 * exact.max(1.0),
                    "{k}: {}",
                    m.frequency
                );
            }
        }
        assert!(max_relative_residual(&chain, &all) < 1e-12);
    }

    /// The ECL cantilever against Euler–Bernoulli theory: 100 elements through `linear_modes`
    /// (dense, refined), 500 through `lowest_modes` (sparse). Hermite elements converge like
    /// h⁴: the exact discrete first frequency (40-digit arithmetic on the exact-decimal model,
    /// mpmath) is 148.66944295998768 rad/s at 100 elements, 8.58e-11 above theory, and
    /// 1.4e-13 above it at 500. At 100 elements we reproduce the discrete value to 1e-12; at
    /// 500 the rounding of the model's entries to double moves it by 8.8e-11 (docs/method.md
    /// eq. (71)) — the floor for this beam in double precision, whatever the solver.
    #[test]
    fn cantilever_lowest_frequencies_match_euler_bernoulli() {
        let beta = [
            1.875_104_068_711_961,
            4.694_091_132_974_175,
            7.854_757_438_237_613,
        ];
        for (elements, tolerances) in [(100, [9e-11, 4e-9, 3e-8]), (500, [1e-10, 3e-11, 6e-11])] {
            let beam = crate::model::CantileverBeam {
                elements,
                ..Default::default()
            };
            let (area, inertia) = (
                beam.width * beam.height,
                beam.width * beam.height.powi(3) / 12.0,
            );
            let scale = (beam.youngs_modulus * inertia
                / (beam.density * area * beam.length.powi(4)))
            .sqrt();
            let model = beam.build().unwrap();
            let modes = if elements == 100 {
                linear_modes(&model).unwrap()
            } else {
                lowest_modes(&model, 3).unwrap()
            };
            for k in 0..3 {
                let exact = beta[k] * beta[k] * scale;
                let error = (modes[k].frequency - exact).abs() / exact;
                assert!(
                    error < tolerances[k],
                    "{elements} el., mode {k}: {error:.2e}"
                );
            }
            if elements == 100 {
                let discrete = 148.669_442_959_987_7;
                assert!((modes[0].frequency - discrete).abs() < 1e-12 * discrete);
            }
        }
    }

    /// The 64-element von Kármán beam (189 dofs): every mode's residual against the model's
    /// own K and M (faer's dense solver alone left one at 7e-5 of ‖K v‖).
    #[test]
    fn von_karman_beam_modes_have_small_residuals() {
        let s = crate::model::VonKarmanBeam {
            elements: 64,
            ..Default::default()
        }
        .build()
        .unwrap();
        let modes = linear_modes(&s).unwrap();
        assert_eq!(modes.len(), 189);
        assert!(modes.iter().all(|m| !m.rigid));
        let worst = max_relative_residual(&s, &modes);
        assert!(worst < 1e-9, "{worst:.2e}");
        // M-orthonormal.
        let m = dense_mass(&s);
        for (a, b) in [(0, 0), (0, 1), (3, 7), (188, 188)] {
            let d = linalg::dot(
                &modes[a].shape,
                &linalg::product(m.as_ref(), linalg::view(&modes[b].shape, 189, 1, 189))
                    .col(0)
                    .iter()
                    .copied()
                    .collect::<Vec<_>>(),
            );
            assert!(
                (d - if a == b { 1.0 } else { 0.0 }).abs() < 1e-10,
                "({a},{b}): {d}"
            );
        }
    }

    /// A 1,500-sector bladed disk (3,000 dofs) goes through `lowest_modes`: the rigid mode,
    /// then the pairs (0,1), (0,2), ... with their labels, against the per-diameter 2 × 2
    /// problem `[[2K(1 − cos θ_d) + k, −k], [−k, k]] = ω² diag(M, m)`.
    #[test]
    fn large_bladed_disk_gets_lowest_modes_with_labels() {
        let disk = BladedDisk {
            sectors: 1500,
            ..Default::default()
        };
        let modes = linear_modes(&disk.build().unwrap()).unwrap();
        assert!(modes.len() >= LARGE_MODEL_MODES && modes.len() <= LARGE_MODEL_MODES + 1);
        assert!(modes[0].rigid && modes.iter().filter(|m| m.rigid).count() == 1);
        for m in &modes[1..] {
            let c = m.cyclic.expect("labelled");
            assert_eq!(c.circles, 0);
            assert!(c.pattern.is_some());
            let theta = 2.0 * PI * c.diameters as f64 / 1500.0;
            let (a, b, k) = (2.0 * (1.0 - theta.cos()) + 1.0, 1.0, 1.0);
            // det([[a − ω², −k], [−k, b − 0.3 ω²]]) = 0, the lower root.
            let (qa, qb, qc) = (0.3, -(0.3 * a + b), a * b - k * k);
            let large = (-qb + (qb * qb - 4.0 * qa * qc).sqrt()) / (2.0 * qa);
            let w2 = qc / (qa * large); // the small root, without cancellation
            assert!(
                (m.frequency.powi(2) - w2).abs() < 1e-9 * w2,
                "d = {}: {} vs {}",
                c.diameters,
                m.frequency.powi(2),
                w2
            );
        }
        // Pairs complete: every diameter appears twice.
        for d in 1..=(modes.len() - 1) / 2 {
            assert_eq!(
                modes
                    .iter()
                    .filter(|m| m.cyclic.is_some_and(|c| c.diameters == d))
                    .count(),
                2,
                "d = {d}"
            );
        }
    }
}
