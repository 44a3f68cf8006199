//! The linear forced response `X = (K − Ω²M + iΩC)⁻¹ a (F_c − i F_s)` (docs/method.md
//! eq. (98)): the first point of a curve, where the motion is small or far from resonance,
//! and the scale of the response that the unknowns are measured in.

use crate::linalg::{DenseLu, Mat};
use crate::model::{ForcedSystem, MechanicalSystem, dense_mass_matrix, dense_tangent};

/// The model's linear operators at rest, dense (`K = K_t(0)`, `M`, `C`).
pub(crate) struct LinearOperators {
    stiffness: Mat<f64>,
    mass: Mat<f64>,
    damping: Mat<f64>,
    cosine: Vec<f64>,
    sine: Vec<f64>,
}

impl LinearOperators {
    pub(crate) fn new<S: MechanicalSystem + ?Sized>(system: &ForcedSystem<'_, S>) -> Self {
        let n = system.dofs();
        let mut columns = vec![0.0; n * n];
        dense_tangent(
            system.system(),
            &vec![0.0; n],
            &mut columns,
            &mut Vec::new(),
        );
        Self {
            stiffness: Mat::from_fn(n, n, |i, j| columns[j * n + i]),
            mass: dense_mass_matrix(system.system().mass()),
            damping: crate::model::Matrix::Sparse(system.damping().clone()).to_dense(),
            cosine: system.force().cosine.clone(),
            sine: system.force().sine.clone(),
        }
    }

    /// The null space of `K` (rigid-body displacement shapes), from its eigenvalues below
    /// `1e-10` of the largest.
    pub(crate) fn rigid_modes(&self) -> Vec<Vec<f64>> {
        let Ok((values, vectors)) = crate::linalg::symmetric_eigen(self.stiffness.as_ref()) else {
            return Vec::new();
        };
        let largest = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let n = self.stiffness.nrows();
        (0..values.len())
            .filter(|&k| values[k].abs() <= 1e-10 * largest)
            .map(|k| (0..n).map(|i| vectors[(i, k)]).collect())
            .collect()
    }

    /// The periodic state `z(0) = [Re X; −Ω Im X]` of the linear response at `omega` to the
    /// force scaled by `amplitude` (`x(t) = Re(X e^{iΩt})`), by a real `2n` solve of
    /// `[[D, −ΩC], [ΩC, D]] [Re X; Im X] = a [F_c; −F_s]`, `D = K − Ω²M`.
    pub(crate) fn response(&self, omega: f64, amplitude: f64) -> Vec<f64> {
        let n = self.mass.nrows();
        let d = |i: usize, j: usize| self.stiffness[(i, j)] - omega * omega * self.mass[(i, j)];
        let system = Mat::from_fn(2 * n, 2 * n, |r, c| {
            let (i, j) = (r % n, c % n);
            match (r < n, c < n) {
                (true, true) | (false, false) => d(i, j),
                (true, false) => -omega * self.damping[(i, j)],
                (false, true) => omega * self.damping[(i, j)],
            }
        });
        let mut x: Vec<f64> = self
            .cosine
            .iter()
            .map(|f| amplitude * f)
            .chain(self.sine.iter().map(|f| -amplitude * f))
            .collect();
        DenseLu::new(system.as_ref()).solve_in_place(&mut x, 1);
        let (re, im) = x.split_at(n);
        re.iter()
            .copied()
            .chain(im.iter().map(|v| -omega * v))
            .collect()
    }
}
