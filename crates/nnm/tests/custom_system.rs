//! A system defined from scratch against `MechanicalSystem` — its own compressed-row storage,
//! a lumped mass, and its tangent given on a sparse pattern — continued like any other, and
//! checked against the same model built independently as a `Structure` (dense matrices and
//! polynomial springs).
//!
//! The model: a fixed–fixed chain of `N` masses `m_i`, neighbours joined by linear springs `k`
//! and each mass tied to ground by a cubic spring `c x_i³`.

use std::ops::ControlFlow;

use nnm::Mat;
use nnm::prelude::*;

mod common;
use common::Unassembled;

const N: usize = 6;
const K: f64 = 1.0;
const CUBIC: f64 = 0.4;

fn masses() -> Vec<f64> {
    (0..N).map(|i| 1.0 + 0.1 * i as f64).collect()
}

/// The chain with hand-written sparse storage: `K_t(x) = K + diag(3 c x_i²)` on the
/// tridiagonal pattern.
struct SparseChain {
    mass: Mass,
    pattern: SparsityPattern,
    /// `K` on the pattern, and the position of each diagonal entry.
    stiffness: Vec<f64>,
    diagonal: Vec<usize>,
}

impl SparseChain {
    fn new() -> Self {
        let (mut row_start, mut col, mut stiffness, mut diagonal) =
            (vec![0], vec![], vec![], vec![]);
        for i in 0..N {
            for j in i.saturating_sub(1)..(i + 2).min(N) {
                if i == j {
                    diagonal.push(col.len());
                }
                col.push(j);
                stiffness.push(if i == j { 2.0 * K } else { -K });
            }
            row_start.push(col.len());
        }
        let mass = Mass::new(&Matrix::from_fn(N, N, |i, j| {
            if i == j { masses()[i] } else { 0.0 }
        }))
        .unwrap();
        Self {
            mass,
            pattern: SparsityPattern { row_start, col },
            stiffness,
            diagonal,
        }
    }

    fn times(&self, values: &[f64], x: &[f64], out: &mut [f64]) {
        let p = &self.pattern;
        for (i, o) in out.iter_mut().enumerate().take(N) {
            *o = (p.row_start[i]..p.row_start[i + 1])
                .map(|k| values[k] * x[p.col[k]])
                .sum();
        }
    }
}

impl MechanicalSystem for SparseChain {
    fn dofs(&self) -> usize {
        N
    }
    fn mass(&self) -> &dyn MassOperator {
        &self.mass
    }
    fn internal_force(&self, x: &[f64], f: &mut [f64]) {
        self.times(&self.stiffness, x, f);
        for i in 0..N {
            f[i] += CUBIC * x[i].powi(3);
        }
    }
    fn tangent_stiffness(&self, x: &[f64], dx: Block<'_>, mut out: BlockMut<'_>) {
        let mut values = vec![0.0; self.pattern.nonzeros()];
        self.tangent_values(x, &mut values);
        for c in 0..dx.cols {
            self.times(&values, dx.col(c), out.col_mut(c));
        }
    }
    fn potential_energy(&self, x: &[f64]) -> f64 {
        let mut kx = vec![0.0; N];
        self.times(&self.stiffness, x, &mut kx);
        (0..N)
            .map(|i| 0.5 * x[i] * kx[i] + 0.25 * CUBIC * x[i].powi(4))
            .sum()
    }
    fn tangent_pattern(&self) -> Option<&SparsityPattern> {
        Some(&self.pattern)
    }
    fn tangent_values(&self, x: &[f64], values: &mut [f64]) {
        values.copy_from_slice(&self.stiffness);
        for i in 0..N {
            values[self.diagonal[i]] += 3.0 * CUBIC * x[i] * x[i];
        }
    }
}

/// The same chain as a `Structure`: dense `M` and `K`, one grounded cubic spring per mass.
fn structure() -> Structure {
    let m = masses();
    let mass = Mat::from_fn(N, N, |i, j| if i == j { m[i] } else { 0.0 });
    let stiffness = Mat::from_fn(N, N, |i, j| match i.abs_diff(j) {
        0 => 2.0 * K,
        1 => -K,
        _ => 0.0,
    });
    let springs = (0..N)
        .map(|i| Box::new(PolynomialSpring::cubic(i, None, CUBIC)) as Box<dyn NonlinearElement>)
        .collect();
    Structure::new(mass, stiffness, springs).unwrap()
}

fn backbone<S: MechanicalSystem>(system: &S, mode: usize) -> Branch {
    let start = Start::from_mode(system, mode).unwrap();
    let mut settings = Settings::default();
    settings.continuation.tolerance = 1e-10;
    settings.limits.frequency_shift_max = 0.15;
    continue_branch(system, &start, &settings, |_| ControlFlow::Continue(())).unwrap()
}

/// The custom system's linear frequencies, its first backbone (energies and frequencies at
/// every point) and its stability verdicts agree with the independently built `Structure`.
#[test]
fn custom_sparse_system_matches_the_same_model_as_a_structure() {
    let custom = SparseChain::new();
    let reference = structure();
    let (a, b) = (
        linear_modes(&custom).unwrap(),
        linear_modes(&reference).unwrap(),
    );
    for (p, q) in a.iter().zip(&b) {
        assert!((p.frequency - q.frequency).abs() < 1e-12 * q.frequency);
    }
    for mode in [0, 2] {
        let (p, q) = (backbone(&custom, mode), backbone(&reference, mode));
        assert_eq!(p.stop, StopReason::FrequencyShiftMax);
        assert_eq!(p.points.len(), q.points.len(), "mode {mode}");
        assert!(p.points.len() > 5);
        for (x, y) in p.points.iter().zip(&q.points) {
            assert!((x.energy - y.energy).abs() < 1e-8 * y.energy, "mode {mode}");
            assert!(
                (x.frequency - y.frequency).abs() < 1e-9 * y.frequency,
                "mode {mode}"
            );
            assert_eq!(x.floquet.stable, y.floquet.stable, "mode {mode}");
        }
        let last = p.points.last().unwrap();
        eprintln!(
            "custom chain, mode {mode}: {} points to {:+.1}% frequency, E = {:.4}",
            p.points.len(),
            100.0 * (last.frequency / p.omega - 1.0),
            last.energy
        );
    }
}

/// The assembled-pattern path and the block-product path of the same system give the same
/// branch (the pattern is an optimisation only).
#[test]
fn tangent_pattern_is_only_an_optimisation() {
    let (p, q) = (
        backbone(&SparseChain::new(), 1),
        backbone(&Unassembled(SparseChain::new()), 1),
    );
    assert_eq!(p.points.len(), q.points.len());
    for (x, y) in p.points.iter().zip(&q.points) {
        assert!((x.frequency - y.frequency).abs() < 1e-12 * y.frequency);
        assert!((x.floquet.max_modulus - y.floquet.max_modulus).abs() < 1e-9);
    }
}
