//! Linear modal analysis: `K v = ω² M v`, rigid-body modes, and for cyclic structures the
//! `(n, d)` labels and sector-aligned standing waves of degenerate pairs (docs/method.md §11,
//! eq. (53) and Table 1).

use std::f64::consts::PI;

use crate::linalg::{self, LinalgError, Mat};
use crate::model::{Block, BlockMut, CyclicSymmetry, MechanicalSystem};

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
}

/// Relative threshold below which `ω²` counts as zero (rigid-body mode): a few hundred times
/// the round-off of the eigensolver (`~n ε λ_max`), so that slow elastic modes of stiff models
/// (ω/ω_max down to ~1e-6) are not mistaken for rigid ones.
pub const RIGID_TOLERANCE: f64 = 1e-12;

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
    let n = system.dofs();
    let eye: Vec<f64> = (0..n * n)
        .map(|k| if k % (n + 1) == 0 { 1.0 } else { 0.0 })
        .collect();
    let mut m = vec![0.0; n * n];
    system.mass().apply(&eye, n, &mut m);
    Mat::from_fn(n, n, |i, j| m[j * n + i])
}

/// All linear modes of `system` (its linearisation at rest), in ascending frequency.
///
/// Solves the generalized symmetric problem through the Cholesky factor `M = L Lᵀ`:
/// `(L⁻¹ K L⁻ᵀ) w = ω² w`, `v = L⁻ᵀ w` (faer has no generalized symmetric solver).
pub fn linear_modes<S: MechanicalSystem + ?Sized>(
    system: &S,
) -> Result<Vec<LinearMode>, ModesError> {
    let n = system.dofs();
    let (mass, stiffness) = linearised_matrices(system);
    let l =
        linalg::cholesky_lower(mass.as_ref()).map_err(|_| ModesError::MassNotPositiveDefinite)?;
    // A = L⁻¹ K L⁻ᵀ, built as L⁻¹ (L⁻¹ K)ᵀ since K is symmetric.
    let mut a = stiffness;
    linalg::solve_lower_in_place(l.as_ref(), &mut a);
    let mut a = a.transpose().to_owned();
    linalg::solve_lower_in_place(l.as_ref(), &mut a);
    let a = Mat::from_fn(n, n, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    let (eigenvalues, w) = linalg::symmetric_eigen(a.as_ref())?;
    let mut shapes = w;
    linalg::solve_lower_transpose_in_place(l.as_ref(), &mut shapes);

    let scale = eigenvalues.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let threshold = RIGID_TOLERANCE * scale.max(f64::MIN_POSITIVE);
    let mut modes = Vec::with_capacity(n);
    for (k, &lambda) in eigenvalues.iter().enumerate() {
        if lambda < -threshold {
            return Err(ModesError::NegativeStiffness(lambda));
        }
        let rigid = lambda <= threshold;
        modes.push(LinearMode {
            frequency: if rigid { 0.0 } else { lambda.sqrt() },
            shape: (0..n).map(|i| shapes[(i, k)]).collect(),
            rigid,
            cyclic: None,
        });
    }
    if let Some(cyclic) = system.cyclic_symmetry() {
        label_cyclic(&mut modes, cyclic, &mass);
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

/// Labels every mode `(n, d)`; rotates each degenerate pair into its cos and sin standing waves.
fn label_cyclic(modes: &mut [LinearMode], cyclic: CyclicSymmetry, mass: &Mat<f64>) {
    let n_s = cyclic.sectors;
    let diameters: Vec<usize> = modes
        .iter()
        .map(|m| {
            let content: Vec<f64> = (0..=n_s / 2)
                .map(|d| harmonic_content(&m.shape, cyclic, d))
                .collect();
            (0..content.len())
                .max_by(|&a, &b| content[a].total_cmp(&content[b]))
                .unwrap_or(0)
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
    mass: &Mat<f64>,
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
        let m = mass_norm(v, mass);
        v.iter_mut().for_each(|x| *x /= m);
    }
    (cos, sin)
}

fn mass_norm(v: &[f64], mass: &Mat<f64>) -> f64 {
    linalg::dot(v, &linalg::times(mass.as_ref(), v)).sqrt()
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
}
