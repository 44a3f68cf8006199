//! Built-in model families: the validation systems of docs/method.md §12 and the bladed disk of §11.

use super::{
    CyclicSymmetry, ModelError, NonlinearElement, PolynomialSpring, SparseMatrix, Structure,
};
use crate::linalg::Mat;
use crate::number::Number;
use serde::{Deserialize, Serialize};

fn positive(name: &str, value: f64) -> Result<(), ModelError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(ModelError::InvalidParameter(format!(
            "{name} must be positive and finite, got {}",
            Number(value)
        )))
    }
}

fn finite(name: &str, value: f64) -> Result<(), ModelError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(ModelError::InvalidParameter(format!(
            "{name} must be finite, got {}",
            Number(value)
        )))
    }
}

/// Duffing oscillator `x'' + ω₀² x + a x³ = 0` (unit mass). Its period is known exactly
/// (`duffing_period` in the crate's validation references).
pub fn duffing(natural_frequency: f64, cubic: f64) -> Result<Structure, ModelError> {
    positive("natural_frequency", natural_frequency)?;
    finite("cubic", cubic)?;
    Structure::new(
        Mat::from_fn(1, 1, |_, _| 1.0),
        Mat::from_fn(1, 1, |_, _| natural_frequency * natural_frequency),
        vec![Box::new(PolynomialSpring::cubic(0, None, cubic))],
    )
}

/// The [`duffing`] oscillator's parameters, as a job file's `family = "duffing"` takes them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Duffing {
    /// `ω₀`
    pub natural_frequency: f64,
    /// `a`
    pub cubic: f64,
}

impl Default for Duffing {
    /// `x'' + x + x³ = 0`.
    fn default() -> Self {
        Self {
            natural_frequency: 1.0,
            cubic: 1.0,
        }
    }
}

impl Duffing {
    /// The oscillator ([`duffing`]); rejects out-of-range parameters.
    pub fn build(&self) -> Result<Structure, ModelError> {
        duffing(self.natural_frequency, self.cubic)
    }
}

/// The 2-DOF system of Kerschen et al. (2009): `x1'' + (2 x1 - x2) + c x1³ = 0`,
/// `x2'' + (2 x2 - x1) = 0`, with `c = 0.5` in the reference.
pub fn two_dof(cubic: f64) -> Result<Structure, ModelError> {
    finite("cubic", cubic)?;
    Structure::new(
        Mat::<f64>::identity(2, 2),
        Mat::from_fn(2, 2, |i, j| if i == j { 2.0 } else { -1.0 }),
        vec![Box::new(PolynomialSpring::cubic(0, None, cubic))],
    )
}

/// The [`two_dof`] system's parameter, as a job file's `family = "two-dof"` takes it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TwoDof {
    /// `c`
    pub cubic: f64,
}

impl Default for TwoDof {
    /// The reference's `c = 0.5`.
    fn default() -> Self {
        Self { cubic: 0.5 }
    }
}

impl TwoDof {
    /// The system ([`two_dof`]); rejects a non-finite coefficient.
    pub fn build(&self) -> Result<Structure, ModelError> {
        two_dof(self.cubic)
    }
}

/// Largest number of sectors of a [`BladedDisk`] (its modal analysis is still dense).
pub const MAX_SECTORS: usize = 5_000;

/// The nonlinear bladed disk of docs/method.md §11: `sectors` sectors, each a disk mass `X_i` coupled to
/// its neighbours (cyclically) and a blade mass `x_i` attached by a linear spring plus a cubic
/// one. Dof `2i` is the disk of sector `i`, dof `2i+1` its blade. Missing keys of a job file
/// take the [`Default`] values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BladedDisk {
    /// Number of sectors `N` (30 in the paper; at most `MAX_SECTORS` = 5 000).
    pub sectors: usize,
    /// `M`
    pub disk_mass: f64,
    /// `m`
    pub blade_mass: f64,
    /// `K`
    pub disk_coupling: f64,
    /// `k`
    pub blade_stiffness: f64,
    /// `knl`
    pub cubic: f64,
    /// Blade mistuning: relative deviations `δ_i` of the blade stiffnesses, `k_i = k (1 + δ_i)`
    /// (docs/method.md eqs. (52) and (77)). Empty for the tuned disk; otherwise one
    /// per sector, each above −1. A mistuned disk has no cyclic symmetry, so none is declared
    /// (its modes carry no `(n, d)` labels: its degenerate pairs split).
    pub blade_stiffness_mistuning: Vec<f64>,
}

impl Default for BladedDisk {
    /// The paper's values: 30 sectors, M = 1, m = 0.3, K = 1, k = 1, knl = 0.1.
    fn default() -> Self {
        Self {
            sectors: 30,
            disk_mass: 1.0,
            blade_mass: 0.3,
            disk_coupling: 1.0,
            blade_stiffness: 1.0,
            cubic: 0.1,
            blade_stiffness_mistuning: Vec::new(),
        }
    }
}

impl BladedDisk {
    /// Assembles the model of docs/method.md eq. (52) with its cyclic symmetry declared;
    /// rejects out-of-range parameters.
    pub fn build(&self) -> Result<Structure, ModelError> {
        let n_s = self.sectors;
        if !(1..=MAX_SECTORS).contains(&n_s) {
            return Err(ModelError::InvalidParameter(format!(
                "sectors must be between 1 and {MAX_SECTORS}, got {n_s}"
            )));
        }
        positive("disk_mass", self.disk_mass)?;
        positive("blade_mass", self.blade_mass)?;
        finite("disk_coupling", self.disk_coupling)?;
        finite("blade_stiffness", self.blade_stiffness)?;
        finite("cubic", self.cubic)?;
        let mistuning = &self.blade_stiffness_mistuning;
        if !mistuning.is_empty() && mistuning.len() != n_s {
            return Err(ModelError::InvalidParameter(format!(
                "blade_stiffness_mistuning needs one deviation per sector ({n_s}), got {}",
                mistuning.len()
            )));
        }
        if let Some((i, d)) = mistuning
            .iter()
            .enumerate()
            .find(|(_, d)| !(d.is_finite() && **d > -1.0))
        {
            return Err(ModelError::InvalidParameter(format!(
                "blade_stiffness_mistuning[{i}] = {}: a deviation must be finite and above -1 (k_i = k (1 + deviation))",
                Number(*d)
            )));
        }
        let n = 2 * n_s;
        // Assembled sparse (duplicates summed): no dense n × n matrix for many sectors.
        let mass: Vec<(usize, usize, f64)> = (0..n)
            .map(|i| {
                let m = if i % 2 == 0 {
                    self.disk_mass
                } else {
                    self.blade_mass
                };
                (i, i, m)
            })
            .collect();
        let mut stiffness: Vec<(usize, usize, f64)> = Vec::with_capacity(8 * n_s);
        let mut spring = |a: usize, b: usize, k: f64| {
            stiffness.extend([(a, a, k), (b, b, k), (a, b, -k), (b, a, -k)]);
        };
        for i in 0..n_s {
            let (disk, blade) = (2 * i, 2 * i + 1);
            let deviation = mistuning.get(i).copied().unwrap_or(0.0);
            spring(disk, blade, self.blade_stiffness * (1.0 + deviation));
            // The ring of disk springs: sector i to sector i+1 (cyclically), once each.
            if n_s > 1 {
                spring(disk, 2 * ((i + 1) % n_s), self.disk_coupling);
            }
        }
        let elements: Vec<Box<dyn NonlinearElement>> = (0..n_s)
            .map(|i| {
                Box::new(PolynomialSpring::cubic(2 * i + 1, Some(2 * i), self.cubic))
                    as Box<dyn NonlinearElement>
            })
            .collect();
        let sparse = |t: &[(usize, usize, f64)]| {
            SparseMatrix::from_triplets(n, t).map_err(ModelError::InvalidParameter)
        };
        let structure = Structure::new(sparse(&mass)?, sparse(&stiffness)?, elements)?;
        let sectors = CyclicSymmetry {
            sectors: n_s,
            dofs_per_sector: 2,
        };
        if mistuning.iter().any(|&d| d != 0.0) {
            // Its sectors still are, an engine order drives them; the symmetry is gone.
            return structure.with_sector_layout(sectors);
        }
        structure.with_cyclic_symmetry(sectors)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::modes::linear_modes;

    fn frequencies(disk: &BladedDisk) -> Vec<f64> {
        let modes = linear_modes(&disk.build().unwrap()).unwrap();
        modes.iter().map(|m| m.frequency).collect()
    }

    /// The same deviation on every blade is a tuned disk of stiffer blades: the same
    /// frequencies (but declared without symmetry, so unlabelled); different deviations split
    /// every degenerate pair `(n, d)`, `0 < d < N/2`, into two distinct frequencies.
    #[test]
    fn mistuning_scales_the_blade_springs_and_splits_the_pairs() {
        let sectors = 8;
        let uniform = BladedDisk {
            sectors,
            blade_stiffness_mistuning: vec![0.05; sectors],
            ..Default::default()
        };
        let stiffer = BladedDisk {
            sectors,
            blade_stiffness: 1.05,
            ..Default::default()
        };
        for (a, b) in frequencies(&uniform).iter().zip(frequencies(&stiffer)) {
            assert!((a - b).abs() <= 1e-12 * b.max(1.0), "{a} vs {b}");
        }
        let modes = linear_modes(&uniform.build().unwrap()).unwrap();
        assert!(modes.iter().all(|m| m.cyclic.is_none()));

        let tuned = frequencies(&BladedDisk {
            sectors,
            ..Default::default()
        });
        let mistuned = frequencies(&BladedDisk {
            sectors,
            blade_stiffness_mistuning: (0..sectors).map(|i| 0.02 * (i as f64 - 3.5)).collect(),
            ..Default::default()
        });
        // The tuned disk's pairs are equal to round-off, the mistuned ones are not.
        let pairs = |f: &[f64]| f.windows(2).filter(|w| (w[1] - w[0]) < 1e-9).count();
        assert_eq!(pairs(&tuned), 2 * (sectors / 2 - 1));
        assert_eq!(pairs(&mistuned), 0);
    }
}
