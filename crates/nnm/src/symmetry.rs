//! Mirror symmetry of cyclic structures, and the invariant subspaces it gives.
//!
//! The reflection `R`: sector `i ↦ sector (N − i) mod N` (dofs within a sector kept) maps a
//! cos standing wave `cos(2π d i/N)` to itself and a sin wave to minus itself. When `R` is a
//! symmetry of the system (`R M Rᵀ = M`, `R K Rᵀ = K`, `f_nl(R x) = R f_nl(x)`), the
//! subspace of mirror-even states (`R x = x`, `R v = v`) is invariant under the motion; the
//! mirror-odd subspace is too when `f_nl` is odd. A branch started on a cos wave therefore
//! lives in the even subspace, and restricting the shooting unknowns to it removes the
//! degenerate partner (the sin wave, whose Floquet multipliers sit at +1 at low energy and
//! make the Jacobian nearly singular in a second direction; docs/method.md §10 and §13) from
//! the problem exactly:
//! without it the least-squares corrector lets the branch drift onto the partner.
//!
//! Every property is *checked* numerically on the model (the mass and the internal force at
//! sample states), so a cyclic model whose sectors are not themselves mirror-symmetric is
//! simply not restricted.

use crate::linalg;
use crate::model::MechanicalSystem;
use crate::modes::LinearMode;

/// Whether a mode is even or odd under the mirror reflection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Parity {
    /// `R φ = φ` (cos standing waves).
    Even,
    /// `R φ = -φ` (sin standing waves).
    Odd,
}

/// Relative tolerance of the symmetry checks.
const TOLERANCE: f64 = 1e-10;

/// The dof permutation of the mirror reflection (`None` for non-cyclic structures).
fn mirror_permutation<S: MechanicalSystem + ?Sized>(system: &S) -> Option<Vec<usize>> {
    let cyclic = system.cyclic_symmetry()?;
    let (n_s, s) = (cyclic.sectors, cyclic.dofs_per_sector);
    Some(
        (0..n_s * s)
            .map(|dof| ((n_s - dof / s) % n_s) * s + dof % s)
            .collect(),
    )
}

/// `R x` for the permutation `p`.
fn reflect(p: &[usize], x: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; x.len()];
    for (i, &j) in p.iter().enumerate() {
        y[j] = x[i];
    }
    y
}

fn close(a: &[f64], b: &[f64], scale: f64) -> bool {
    a.iter()
        .zip(b)
        .all(|(x, y)| (x - y).abs() <= TOLERANCE * scale.max(f64::MIN_POSITIVE))
}

/// Deterministic sample states for checks of the forces at sample points (no random-number
/// dependency needed): three irregular patterns with peak displacement `amplitude`, 2 and 3
/// times `amplitude`. Callers pass an amplitude where the nonlinearity matters, so that the
/// verdicts do not depend on the model's length unit.
pub(crate) fn sample_states(n: usize, amplitude: f64) -> Vec<Vec<f64>> {
    (1..=3)
        .map(|k| {
            let pattern: Vec<f64> = (0..n)
                .map(|i| ((i * 7 + k * 13) as f64 * 0.618_033_988_75).sin())
                .collect();
            let peak = pattern
                .iter()
                .fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()));
            pattern
                .iter()
                .map(|v| v / peak * amplitude * k as f64)
                .collect()
        })
        .collect()
}

/// Whether the internal force is odd, `f(-x) = -f(x)` (cubic and quintic springs: yes;
/// quadratic: no), checked at sample states of size `amplitude` (where the nonlinearity is
/// significant, so the verdict does not depend on the length unit). The even part
/// `f(x) + f(-x)` must vanish relative to the nonlinear part, estimated by `f(x) - 2 f(x/2)`
/// (the linear part cancels in both). Then the vector field is odd too (`M⁻¹` is linear).
pub(crate) fn is_odd<S: MechanicalSystem + ?Sized>(system: &S, amplitude: f64) -> bool {
    let n = system.dofs();
    sample_states(n, amplitude).into_iter().all(|x| {
        let minus: Vec<f64> = x.iter().map(|v| -v).collect();
        let half: Vec<f64> = x.iter().map(|v| 0.5 * v).collect();
        let (mut a, mut b, mut c) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        system.internal_force(&x, &mut a);
        system.internal_force(&minus, &mut b);
        system.internal_force(&half, &mut c);
        let norm = |v: Vec<f64>| linalg::norm(&v);
        let even = norm(a.iter().zip(&b).map(|(p, q)| p + q).collect());
        let nonlinear = norm(a.iter().zip(&c).map(|(p, q)| p - 2.0 * q).collect());
        even <= 1e-10 * nonlinear + 1e-14 * linalg::norm(&a)
    })
}

/// The signs `S` (on the displacements; the velocities alike) of a forced system's half-wave
/// symmetric responses, `z(τ + π) = S z(τ)` (docs/method.md eq. (99b)): `−1` everywhere when
/// the internal force is odd; otherwise a parity of the system under which the force is odd
/// ([`parity_of`]: a von Kármán model driven in bending flips its transverse dofs and keeps
/// its in-plane ones) and which the damping respects (`S C = C S`: `C` couples no dofs of
/// opposite signs). `None` when neither holds: whole periods are shot.
pub(crate) fn half_wave_signs<S: MechanicalSystem + ?Sized>(
    system: &crate::model::ForcedSystem<'_, S>,
    amplitude: f64,
) -> Option<Vec<f64>> {
    let n = system.dofs();
    if is_odd(system.system(), amplitude) {
        return Some(vec![-1.0; n]);
    }
    let force = system.force();
    let shape: Vec<f64> = (force.cosine.iter().zip(&force.sine))
        .map(|(c, s)| c.abs() + s.abs())
        .collect();
    let signs = parity_of(system.system(), &shape, amplitude)?;
    // `S F = −F` exactly: no force at all on a kept dof (`parity_of` counts a group as moved
    // only above 1e-6 of the largest entry).
    if (shape.iter().zip(&signs)).any(|(&f, &s)| s > 0.0 && f != 0.0) {
        return None;
    }
    let damping = system.damping();
    let pattern = damping.pattern();
    let commutes = (0..n).all(|r| {
        let span = pattern.row_start[r]..pattern.row_start[r + 1];
        (pattern.col[span.clone()]
            .iter()
            .zip(&damping.values()[span]))
        .all(|(&c, &v)| v == 0.0 || signs[r] == signs[c])
    });
    commutes.then_some(signs)
}

/// A parity of the system under which `shape` is odd (docs/method.md eq. (9b)): the signs
/// `s_i = −1` on every group of dofs that the linear `M` and `K_t(0)` couple to a dof where
/// `shape` moves, `+1` on the others, when the internal force then commutes with `S = diag(s)`
/// (`f(S x) = S f(x)` at sample states of size `amplitude`; `S M = M S` and `S K S = K` hold
/// by construction). `None` when `shape` moves every group (the odd case, [`is_odd`]) or the
/// force breaks the parity.
///
/// Why: a von Kármán beam or plate is not odd (its membrane force is even in the transverse
/// displacement), but flipping the transverse dofs and keeping the in-plane ones is a
/// symmetry; a bending mode's motion is then half-wave symmetric in that sense,
/// `z(T/2) = S z0`, and is shot over half its period.
pub(crate) fn parity_of<S: MechanicalSystem + ?Sized>(
    system: &S,
    shape: &[f64],
    amplitude: f64,
) -> Option<Vec<f64>> {
    let n = system.dofs();
    // Groups: connected components of the linear coupling graph (union–find).
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let mut join = |i: usize, j: usize| {
        let (a, b) = (root(&mut parent, i), root(&mut parent, j));
        if a != b {
            parent[a] = b;
        }
    };
    let mass = crate::model::mass_entries(system.mass());
    let rest = vec![0.0; n];
    let mut couple = |pattern: &crate::model::SparsityPattern, values: &[f64]| {
        for r in 0..n {
            for p in pattern.row_start[r]..pattern.row_start[r + 1] {
                if values[p] != 0.0 {
                    join(r, pattern.col[p]);
                }
            }
        }
    };
    couple(mass.pattern(), mass.values());
    if let Some(pattern) = system.tangent_pattern() {
        let mut values = vec![0.0; pattern.nonzeros()];
        system.tangent_values(&rest, &mut values);
        couple(pattern, &values);
    } else {
        // A model without a tangent pattern is small: its dense `K_t(0)`.
        let (_, k) = crate::modes::linearised_matrices(system);
        for c in 0..n {
            for r in 0..n {
                if k[(r, c)] != 0.0 {
                    join(r, c);
                }
            }
        }
    }
    let peak = shape[..n].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if peak == 0.0 {
        return None;
    }
    let mut moving = vec![false; n];
    for (i, v) in shape[..n].iter().enumerate() {
        if v.abs() > 1e-6 * peak {
            moving[root(&mut parent, i)] = true;
        }
    }
    let signs: Vec<f64> = (0..n)
        .map(|i| {
            if moving[root(&mut parent, i)] {
                -1.0
            } else {
                1.0
            }
        })
        .collect();
    if signs.iter().all(|&s| s < 0.0) {
        return None;
    }
    let flip = |x: &[f64]| {
        x.iter()
            .zip(&signs)
            .map(|(x, s)| x * s)
            .collect::<Vec<f64>>()
    };
    sample_states(n, amplitude)
        .into_iter()
        .all(|x| {
            let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
            system.internal_force(&flip(&x), &mut a);
            system.internal_force(&x, &mut b);
            let scale = b.iter().fold(0.0f64, |s, v| s.max(v.abs()));
            close(&a, &flip(&b), scale)
        })
        .then_some(signs)
}

/// Checks that the mirror reflection is a symmetry of the whole system (`M R v = R M v` and
/// `f_int(R x) = R f_int(x)` at sample states, which checks `K` and the nonlinear forces
/// together); returns it.
fn verified_mirror<S: MechanicalSystem + ?Sized>(system: &S, amplitude: f64) -> Option<Vec<usize>> {
    let p = mirror_permutation(system)?;
    let n = p.len();
    for x in sample_states(n, amplitude) {
        let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
        system.mass().apply(&reflect(&p, &x), 1, &mut a);
        system.mass().apply(&x, 1, &mut b);
        let scale = b.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        if !close(&a, &reflect(&p, &b), scale) {
            return None;
        }
        system.internal_force(&reflect(&p, &x), &mut a);
        system.internal_force(&x, &mut b);
        let scale = b.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        if !close(&a, &reflect(&p, &b), scale) {
            return None;
        }
    }
    Some(p)
}

/// Parity of a shape under `R`: `Some(Even)` if `R φ = φ`, `Some(Odd)` if `R φ = -φ`.
fn parity(p: &[usize], shape: &[f64]) -> Option<Parity> {
    let r = reflect(p, shape);
    let scale = shape.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    let tol = 1e-8 * scale;
    if r.iter().zip(shape).all(|(a, b)| (a - b).abs() <= tol) {
        Some(Parity::Even)
    } else if r.iter().zip(shape).all(|(a, b)| (a + b).abs() <= tol) {
        Some(Parity::Odd)
    } else {
        None
    }
}

/// The invariant subspace a branch from `modes[start]` lives in: its parity and the indices of
/// the elastic modes of that parity. `None` when the structure has no verified mirror
/// symmetry, when a mode is not of pure parity, or for an odd start with a nonlinearity that
/// is not odd. `amplitude`: a displacement size where the nonlinearity matters (the force
/// checks are made there).
pub fn invariant_class<S: MechanicalSystem + ?Sized>(
    structure: &S,
    modes: &[LinearMode],
    start: usize,
    amplitude: f64,
) -> Option<(Parity, Vec<usize>)> {
    let p = verified_mirror(structure, amplitude)?;
    let parities: Vec<Option<Parity>> = modes.iter().map(|m| parity(&p, &m.shape)).collect();
    let wanted = parities.get(start).copied().flatten()?;
    if parities
        .iter()
        .zip(modes)
        .any(|(q, m)| q.is_none() && !m.rigid)
    {
        return None;
    }
    if wanted == Parity::Odd && !is_odd(structure, amplitude) {
        return None;
    }
    let members = (0..modes.len())
        .filter(|&k| !modes[k].rigid && parities[k] == Some(wanted))
        .collect();
    Some((wanted, members))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{BladedDisk, MechanicalSystem, PolynomialSpring, two_dof};
    use crate::modes::{StandingWave, find_mode, linear_modes};

    #[test]
    fn bladed_disk_cos_and_sin_waves_have_opposite_parity() {
        let s = BladedDisk::default().build().unwrap();
        let modes = linear_modes(&s).unwrap();
        let (cos, _) = find_mode(&modes, "1,5", Some(StandingWave::Cos)).unwrap();
        let (sin, _) = find_mode(&modes, "1,5", Some(StandingWave::Sin)).unwrap();
        let (pc, even) = invariant_class(&s, &modes, cos, 1.0).unwrap();
        let (ps, odd) = invariant_class(&s, &modes, sin, 1.0).unwrap();
        assert_eq!((pc, ps), (Parity::Even, Parity::Odd));
        // 16 cos-type shapes per sector dof minus the rigid mode; 14 sin-type per sector dof.
        assert_eq!((even.len(), odd.len()), (31, 28));
        assert!(even.contains(&cos) && !even.contains(&sin) && odd.contains(&sin));
    }

    #[test]
    fn no_class_without_cyclic_symmetry_or_with_even_power_for_odd_start() {
        let s = two_dof(0.5).unwrap();
        let modes = linear_modes(&s).unwrap();
        assert!(invariant_class(&s, &modes, 0, 1.0).is_none());
        // A bladed disk with a quadratic blade spring: the even class stays invariant, the
        // odd one does not.
        let base = BladedDisk::default().build().unwrap();
        let elements: Vec<Box<dyn crate::model::NonlinearElement>> = (0..30)
            .map(|i| {
                Box::new(PolynomialSpring::new(2 * i + 1, Some(2 * i), 0.1, 2))
                    as Box<dyn crate::model::NonlinearElement>
            })
            .collect();
        let quadratic = crate::model::Structure::new(
            base.mass_matrix().clone(),
            base.stiffness().clone(),
            elements,
        )
        .unwrap()
        .with_cyclic_symmetry(base.cyclic_symmetry().unwrap())
        .unwrap();
        let modes = linear_modes(&quadratic).unwrap();
        let (cos, _) = find_mode(&modes, "1,5", Some(StandingWave::Cos)).unwrap();
        let (sin, _) = find_mode(&modes, "1,5", Some(StandingWave::Sin)).unwrap();
        assert!(invariant_class(&quadratic, &modes, cos, 1.0).is_some());
        assert!(invariant_class(&quadratic, &modes, sin, 1.0).is_none());
    }
}
