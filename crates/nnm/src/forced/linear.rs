//! The linear forced response `X = (K − Ω²M + iΩC)⁻¹ a (F_c − i F_s)` (docs/method.md
//! eq. (98)): the first point of a curve, where the motion is small or far from resonance,
//! and the scale of the response that the unknowns are measured in.
//!
//! A model that gives its tangent on a pattern is solved by a complex sparse LU on the union
//! of `K`'s, `M`'s and `C`'s patterns (its symbolic analysis made once, a numeric
//! factorisation per frequency), and its rigid-body modes come from the sparse modal
//! analysis: nothing `n × n` is formed, which at 2,000 dofs took minutes (two hundred dense
//! `2n` solves for the scales). Other models are small and solved dense.

use faer::c64;

use crate::linalg::{DenseLu, Mat, SparseLuPattern};
use crate::model::{
    ForcedSystem, MechanicalSystem, dense_mass_matrix, dense_tangent, mass_entries,
};

/// The model's linear operators at rest (`K = K_t(0)`, `M`, `C`) and the force shape.
pub(crate) struct LinearOperators {
    operators: Operators,
    cosine: Vec<f64>,
    sine: Vec<f64>,
}

enum Operators {
    Dense {
        stiffness: Mat<f64>,
        mass: Mat<f64>,
        damping: Mat<f64>,
    },
    /// `K`, `M`, `C` on their union pattern (compressed columns), in the pattern's order,
    /// and the rigid-body shapes.
    Sparse {
        pattern: SparseLuPattern,
        stiffness: Vec<f64>,
        mass: Vec<f64>,
        damping: Vec<f64>,
        rigid: Vec<Vec<f64>>,
    },
}

impl LinearOperators {
    pub(crate) fn new<S: MechanicalSystem + ?Sized>(system: &ForcedSystem<'_, S>) -> Self {
        let operators = Self::sparse(system).unwrap_or_else(|| Self::dense(system));
        Self {
            operators,
            cosine: system.force().cosine.clone(),
            sine: system.force().sine.clone(),
        }
    }

    fn dense<S: MechanicalSystem + ?Sized>(system: &ForcedSystem<'_, S>) -> Operators {
        let n = system.dofs();
        let mut columns = vec![0.0; n * n];
        dense_tangent(
            system.system(),
            &vec![0.0; n],
            &mut columns,
            &mut Vec::new(),
        );
        Operators::Dense {
            stiffness: Mat::from_fn(n, n, |i, j| columns[j * n + i]),
            mass: dense_mass_matrix(system.system().mass()),
            damping: crate::model::Matrix::Sparse(system.damping().clone()).to_dense(),
        }
    }

    /// The sparse operators, when the system gives its tangent on a pattern and its sparse
    /// modal analysis succeeds.
    fn sparse<S: MechanicalSystem + ?Sized>(system: &ForcedSystem<'_, S>) -> Option<Operators> {
        let inner = system.system();
        let n = inner.dofs();
        let tangent = inner.tangent_pattern()?;
        let mut k_values = vec![0.0; tangent.nonzeros()];
        inner.tangent_values(&vec![0.0; n], &mut k_values);
        let mass = mass_entries(inner.mass());
        // Each column's entries (the matrices are symmetric: a row's entries are its
        // column's), summed per matrix.
        let mut columns: Vec<Vec<(usize, [f64; 3])>> = vec![Vec::new(); n];
        let sources = [
            (tangent, k_values.as_slice()),
            (mass.pattern(), mass.values()),
            (system.damping().pattern(), system.damping().values()),
        ];
        for (which, (pattern, values)) in sources.iter().enumerate() {
            for r in 0..n {
                for p in pattern.row_start[r]..pattern.row_start[r + 1] {
                    let mut entry = [0.0; 3];
                    entry[which] = values[p];
                    columns[pattern.col[p]].push((r, entry));
                }
            }
        }
        let (mut col_ptr, mut row_idx) = (vec![0], Vec::new());
        let (mut stiffness, mut mass_values, mut damping) = (Vec::new(), Vec::new(), Vec::new());
        for column in &mut columns {
            column.sort_by_key(|e| e.0);
            let mut k = 0;
            while k < column.len() {
                let row = column[k].0;
                let mut sum = [0.0; 3];
                while k < column.len() && column[k].0 == row {
                    (0..3).for_each(|m| sum[m] += column[k].1[m]);
                    k += 1;
                }
                row_idx.push(row);
                stiffness.push(sum[0]);
                mass_values.push(sum[1]);
                damping.push(sum[2]);
            }
            col_ptr.push(row_idx.len());
        }
        let pattern = SparseLuPattern::new(n, col_ptr, row_idx)?;
        let rigid = rigid_shapes(inner)?;
        Some(Operators::Sparse {
            pattern,
            stiffness,
            mass: mass_values,
            damping,
            rigid,
        })
    }

    /// The null space of `K` (rigid-body displacement shapes): dense, from its eigenvalues
    /// below `1e-10` of the largest; sparse, the modes the modal analysis finds rigid.
    pub(crate) fn rigid_modes(&self) -> Vec<Vec<f64>> {
        match &self.operators {
            Operators::Sparse { rigid, .. } => rigid.clone(),
            Operators::Dense { stiffness, .. } => {
                let Ok((values, vectors)) = crate::linalg::symmetric_eigen(stiffness.as_ref())
                else {
                    return Vec::new();
                };
                let largest = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let n = stiffness.nrows();
                (0..values.len())
                    .filter(|&k| values[k].abs() <= 1e-10 * largest)
                    .map(|k| (0..n).map(|i| vectors[(i, k)]).collect())
                    .collect()
            }
        }
    }

    /// The periodic state `z(0) = [Re X; −Ω Im X]` of the linear response at `omega` to the
    /// force scaled by `amplitude` (`x(t) = Re(X e^{iΩt})`). Dense: by a real `2n` solve of
    /// `[[D, −ΩC], [ΩC, D]] [Re X; Im X] = a [F_c; −F_s]`, `D = K − Ω²M`; sparse: by the
    /// complex solve itself.
    pub(crate) fn response(&self, omega: f64, amplitude: f64) -> Vec<f64> {
        let n = self.cosine.len();
        let (re, im): (Vec<f64>, Vec<f64>) = match &self.operators {
            Operators::Dense {
                stiffness,
                mass,
                damping,
            } => {
                let d = |i: usize, j: usize| stiffness[(i, j)] - omega * omega * mass[(i, j)];
                let system = Mat::from_fn(2 * n, 2 * n, |r, c| {
                    let (i, j) = (r % n, c % n);
                    match (r < n, c < n) {
                        (true, true) | (false, false) => d(i, j),
                        (true, false) => -omega * damping[(i, j)],
                        (false, true) => omega * damping[(i, j)],
                    }
                });
                let mut x: Vec<f64> = self
                    .cosine
                    .iter()
                    .map(|f| amplitude * f)
                    .chain(self.sine.iter().map(|f| -amplitude * f))
                    .collect();
                DenseLu::new(system.as_ref()).solve_in_place(&mut x, 1);
                let im = x.split_off(n);
                (x, im)
            }
            Operators::Sparse {
                pattern,
                stiffness,
                mass,
                damping,
                ..
            } => {
                let values: Vec<c64> = (0..stiffness.len())
                    .map(|p| c64::new(stiffness[p] - omega * omega * mass[p], omega * damping[p]))
                    .collect();
                let mut x: Vec<c64> = self
                    .cosine
                    .iter()
                    .zip(&self.sine)
                    .map(|(c, s)| c64::new(amplitude * c, -amplitude * s))
                    .collect();
                match pattern.factorise(&values) {
                    Some(lu) => lu.solve_in_place(&mut x, 1),
                    // Singular (an undamped resonance, a free structure driven statically):
                    // no finite response.
                    None => x.fill(c64::new(f64::NAN, f64::NAN)),
                }
                x.iter().map(|v| (v.re, v.im)).unzip()
            }
        };
        re.iter()
            .copied()
            .chain(im.iter().map(|v| -omega * v))
            .collect()
    }
}

/// The rigid-body displacement shapes of `system` from its sparse modal analysis, the lowest
/// modes asked for in growing numbers until one is elastic; `None` if the analysis fails.
fn rigid_shapes<S: MechanicalSystem + ?Sized>(system: &S) -> Option<Vec<Vec<f64>>> {
    let n = system.dofs();
    let mut count = 7.min(n);
    loop {
        let modes = crate::modes::lowest_modes(system, count).ok()?;
        let rigid: Vec<Vec<f64>> = modes
            .iter()
            .filter(|m| m.rigid)
            .map(|m| m.shape.clone())
            .collect();
        if rigid.len() < modes.len() || count >= n {
            return Some(rigid);
        }
        count = (2 * count).min(n);
    }
}
