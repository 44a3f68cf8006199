//! Any mode of a large cyclic structure by its label, from one sector (docs/method.md
//! eq. (53b)).
//!
//! Above [`super::DENSE_MODES_LIMIT`] dofs only the lowest modes are computed, and on a disk of
//! thousands of sectors they are all of the lowest family with few nodal diameters: the
//! `(1, 0)` mode of a 5,000-sector disk is the 5,001st. Its Bloch form `x_i = a e^{iθ i}`
//! (sector `i`, `θ = 2π d/N`) turns `K x = ω² M x` into an `s × s` Hermitian problem per
//! harmonic, `K_d a = ω² M_d a` with `K_d = Σ_j K_(0j) e^{iθ j}` summed over sector 0's rows:
//! `O(nnz)` to assemble, `O(s³)` to solve, and the `n`-dof shape built from `a` is then checked
//! against `K` and `M` themselves like every other mode (eq. (69)).

use std::f64::consts::PI;

use super::shift_invert::{self, Operators, Scale};
use super::{
    CyclicLabel, LinearMode, ModesError, StandingWave, find_mode, standing_waves, symmetric_pencil,
};
use crate::linalg::{self, Mat};
use crate::model::MechanicalSystem;

/// Appends to `modes` the mode `selector` names when it is a label `"n,d"` that `modes` lacks
/// and `system` is a sparse cyclic structure: the mode, with its partner if it is one of a
/// degenerate pair (cos wave first). Nothing happens otherwise (an index, a label present, a
/// model without cyclic symmetry or sparse matrices, `n` beyond the sector's dofs or `d`
/// beyond `N/2`: the caller's lookup then reports the label as unknown).
///
/// Why not in [`super::linear_modes`]: all `n` shapes of a large model are `O(n²)` memory; a
/// job needs the few it starts from.
pub fn add_labelled_mode<S: MechanicalSystem + ?Sized>(
    system: &S,
    modes: &mut Vec<LinearMode>,
    selector: &str,
    pattern: Option<StandingWave>,
) -> Result<(), ModesError> {
    if find_mode(modes, selector, pattern).is_some() {
        return Ok(());
    }
    let Some((circles, diameters)) = parse_label(selector) else {
        return Ok(());
    };
    let (Some(cyclic), Some(ops)) = (system.cyclic_symmetry(), Operators::sparse(system)) else {
        return Ok(());
    };
    // Checked on the scaled pencil, as every other mode (`Scale`).
    let scale = Scale::of(&ops);
    let ops = scale.operators(ops);
    let (sectors, s) = (cyclic.sectors, cyclic.dofs_per_sector);
    if diameters > sectors / 2 || circles >= s {
        return Ok(());
    }
    let theta = 2.0 * PI * diameters as f64 / sectors as f64;
    let single = diameters == 0 || 2 * diameters == sectors;
    let (k_d, m_d) = (
        harmonic_block(&ops.k, s, theta),
        harmonic_block(&ops.m, s, theta),
    );
    let a = sector_shape(&k_d, &m_d, s, circles, single)?;
    // The Bloch wave's real and imaginary parts over every sector.
    let n = sectors * s;
    let (mut real, mut imaginary) = (vec![0.0; n], vec![0.0; n]);
    for i in 0..sectors {
        let (c, sn) = ((theta * i as f64).cos(), (theta * i as f64).sin());
        for r in 0..s {
            let (ar, ai) = a[r];
            real[i * s + r] = ar * c - ai * sn;
            imaginary[i * s + r] = ar * sn + ai * c;
        }
    }
    let mass = system.mass();
    let normalised = |mut v: Vec<f64>| {
        let norm = shift_invert::mass_norm(mass, &v);
        v.iter_mut().for_each(|x| *x /= norm);
        v
    };
    let shapes: Vec<(Vec<f64>, Option<StandingWave>)> = if single {
        // a is real for d = 0 and d = N/2 (K_d, M_d are), up to a complex phase: take the
        // larger part.
        let v = if linalg::norm(&real) >= linalg::norm(&imaginary) {
            real
        } else {
            imaginary
        };
        vec![(normalised(v), None)]
    } else {
        // Real and imaginary parts of a Bloch wave are M-orthogonal with equal norms (the
        // sum of e^{2iθ i} over the circle vanishes for 2d ≠ 0, N).
        let (cos, sin) = standing_waves(
            &normalised(real),
            &normalised(imaginary),
            cyclic,
            diameters,
            mass,
        );
        vec![
            (cos, Some(StandingWave::Cos)),
            (sin, Some(StandingWave::Sin)),
        ]
    };
    let mut residual = vec![0.0; n];
    for (mut shape, wave) in shapes {
        scale.scale_shape(&mut shape);
        let check = shift_invert::check(&ops, &shape, &mut residual);
        if !check.converged() {
            return Err(ModesError::NotConverged {
                iterations: 0,
                residual: check.residual,
            });
        }
        let mut mode = scale
            .unscale(shift_invert::to_modes(vec![(check, shape)]))?
            .pop()
            .expect("one mode in, one out");
        mode.cyclic = Some(CyclicLabel {
            circles,
            diameters,
            pattern: wave,
        });
        modes.push(mode);
    }
    Ok(())
}

/// `(n, d)` from `"n,d"` (spaces ignored).
fn parse_label(selector: &str) -> Option<(usize, usize)> {
    let label: String = selector.chars().filter(|c| !c.is_whitespace()).collect();
    let (n, d) = label.split_once(',')?;
    Some((n.parse().ok()?, d.parse().ok()?))
}

/// `A_d = Σ_j A_(0j) e^{iθ j}` over sector 0's rows of a sector-major matrix: `s × s`
/// complex, `(re, im)` row-major.
fn harmonic_block(a: &shift_invert::Csr, s: usize, theta: f64) -> Vec<(f64, f64)> {
    let mut block = vec![(0.0, 0.0); s * s];
    for r in 0..s {
        for p in a.row_start[r]..a.row_start[r + 1] {
            let (sector, l) = (a.col[p] / s, a.col[p] % s);
            let phase = theta * sector as f64;
            let entry = &mut block[r * s + l];
            entry.0 += a.value[p] * phase.cos();
            entry.1 += a.value[p] * phase.sin();
        }
    }
    block
}

/// The eigenvector `a` (complex, `s` entries) of `K_d a = ω² M_d a` at level `circles` in
/// ascending `ω²`. The Hermitian pencil is solved as the real symmetric one of twice the size,
/// `[[Re, −Im], [Im, Re]]`, whose eigenvalues come in equal pairs (just `Re` when `single`,
/// `d = 0` or `N/2`, where the blocks are real).
fn sector_shape(
    k_d: &[(f64, f64)],
    m_d: &[(f64, f64)],
    s: usize,
    circles: usize,
    single: bool,
) -> Result<Vec<(f64, f64)>, ModesError> {
    let size = if single { s } else { 2 * s };
    let real_form = |block: &[(f64, f64)]| {
        Mat::from_fn(size, size, |row, col| {
            let (r, c) = (row % s, col % s);
            let (re, im) = block[r * s + c];
            match (row < s, col < s) {
                (true, true) | (false, false) => re,
                (true, false) => -im,
                (false, true) => im,
            }
        })
    };
    let (_, vectors) = symmetric_pencil(&real_form(k_d), &real_form(m_d))?;
    let column = if single { circles } else { 2 * circles };
    Ok((0..s)
        .map(|r| {
            let re = vectors[(r, column)];
            let im = if single {
                0.0
            } else {
                vectors[(s + r, column)]
            };
            (re, im)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::BladedDisk;
    use crate::modes::linear_modes;

    /// Every labelled mode of the paper's 30-sector disk, rebuilt from one sector, is the
    /// dense analysis's: frequency to 1e-12, shape to 1e-9 (single modes up to sign).
    #[test]
    fn every_mode_of_the_30_sector_disk_from_one_sector() {
        let disk = BladedDisk::default().build().unwrap();
        let dense = linear_modes(&disk).unwrap();
        for mode in dense.iter().filter(|m| !m.rigid) {
            let label = mode.cyclic.unwrap();
            let mut modes = Vec::new();
            add_labelled_mode(&disk, &mut modes, &mode.label(), label.pattern).unwrap();
            assert_eq!(modes.len(), if label.pattern.is_some() { 2 } else { 1 });
            let (_, found) = find_mode(&modes, &mode.label(), label.pattern).unwrap();
            assert!(
                (found.frequency / mode.frequency - 1.0).abs() < 1e-12,
                "{}: {} vs {}",
                mode.label(),
                found.frequency,
                mode.frequency
            );
            let sign = if label.pattern.is_none() && linalg::dot(&found.shape, &mode.shape) < 0.0 {
                -1.0
            } else {
                1.0
            };
            for (a, b) in found.shape.iter().zip(&mode.shape) {
                assert!((sign * a - b).abs() < 1e-9, "{}: {a} vs {b}", mode.label());
            }
        }
    }

    /// On 5,000 sectors (10⁴ dofs) the lowest 20 modes hold no `n = 1` mode; `(1,0)` and the
    /// `(1,7)` pair come from the sector problem at the frequencies of the two-mass sector,
    /// `K_d = [[k + 2K(1 − cos θ), −k], [−k, k]]`, `M_d = diag(M, m)`, with every sector alike
    /// for `d = 0`. Labels present, or beyond the sector's two levels, add nothing.
    #[test]
    fn modes_beyond_the_lowest_of_a_5000_sector_disk() {
        let disk = BladedDisk {
            sectors: 5000,
            ..BladedDisk::default()
        };
        let (big_m, m, big_k, k) = (
            disk.disk_mass,
            disk.blade_mass,
            disk.disk_coupling,
            disk.blade_stiffness,
        );
        let disk = disk.build().unwrap();
        let mut modes = linear_modes(&disk).unwrap();
        let lowest = modes.len();
        assert!(find_mode(&modes, "1,0", None).is_none());
        let exact = |d: usize| {
            let coupling = 2.0 * big_k * (1.0 - (2.0 * PI * d as f64 / 5000.0).cos());
            // det(K_d − λ M_d) = 0: M m λ² − (m (k + c) + M k) λ + k c = 0, upper root.
            let (a, b, c) = (big_m * m, m * (k + coupling) + big_m * k, k * coupling);
            ((b + (b * b - 4.0 * a * c).sqrt()) / (2.0 * a)).sqrt()
        };
        add_labelled_mode(&disk, &mut modes, "1,0", None).unwrap();
        add_labelled_mode(&disk, &mut modes, " 1, 7", Some(StandingWave::Sin)).unwrap();
        assert_eq!(modes.len(), lowest + 3);
        let (_, one_zero) = find_mode(&modes, "1,0", None).unwrap();
        assert!((one_zero.frequency / exact(0) - 1.0).abs() < 1e-12);
        let sector = &one_zero.shape[..2];
        assert!(sector[0] * sector[1] < 0.0, "blade against disk");
        for other in one_zero.shape.chunks(2) {
            assert!((other[0] - sector[0]).abs() < 1e-14 && (other[1] - sector[1]).abs() < 1e-14);
        }
        for wave in [StandingWave::Cos, StandingWave::Sin] {
            let (_, pair) = find_mode(&modes, "1,7", Some(wave)).unwrap();
            assert_eq!(pair.cyclic.unwrap().pattern, Some(wave));
            assert!((pair.frequency / exact(7) - 1.0).abs() < 1e-12);
        }
        for (label, pattern) in [
            ("1,0", None),
            ("0,3", None),
            ("2,0", None),
            ("1,2501", None),
            ("7", None),
        ] {
            add_labelled_mode(&disk, &mut modes, label, pattern).unwrap();
        }
        assert_eq!(modes.len(), lowest + 3);
    }
}
