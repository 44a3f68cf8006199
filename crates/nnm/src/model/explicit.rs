//! The explicit form `x'' = a(x) = -M⁻¹ f_int(x)` of a [`MechanicalSystem`] and its tangent
//! `A(x) = -M⁻¹ K_t(x)` (docs/method.md eqs. (3), (12)), derived once per problem for the
//! explicit integrators.
//!
//! With a diagonal mass and a tangent given on a sparse pattern, `A(x)` is assembled as one
//! compressed-row operator per evaluation (the rows scaled by `-1/m_i`) and applied to all
//! directions at once: for the bladed disk this is what makes the variational pass cheap
//! (integrate/runge_kutta.rs notes). Otherwise the tangent is applied column by column and
//! the mass solved with its factorisation.

use std::cell::RefCell;

use super::{Block, BlockMut, MechanicalSystem, SparsityPattern};
use crate::linalg;

/// `x'' = a(x)` derived from a [`MechanicalSystem`]; holds its scratch, so one per thread.
pub struct ExplicitForm<'a, S: MechanicalSystem + ?Sized> {
    system: &'a S,
    n: usize,
    /// `1/m_i` of a diagonal mass.
    inverse_mass: Option<Vec<f64>>,
    /// The tangent's pattern, used when the mass is diagonal, and `-1/m_i` of each entry's
    /// row (one multiplication per entry turns `K_t` into `A = -M⁻¹ K_t`).
    assembled: Option<(&'a SparsityPattern, Vec<f64>)>,
    scratch: RefCell<Scratch>,
}

#[derive(Default)]
struct Scratch {
    values: Vec<f64>,
    columns_in: Vec<f64>,
    columns_out: Vec<f64>,
}

impl<S: MechanicalSystem + ?Sized> std::fmt::Debug for ExplicitForm<'_, S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ExplicitForm")
            .field("dofs", &self.n)
            .field("diagonal_mass", &self.inverse_mass.is_some())
            .field("assembled_tangent", &self.assembled.is_some())
            .finish()
    }
}

impl<'a, S: MechanicalSystem + ?Sized> ExplicitForm<'a, S> {
    /// The explicit form of `system`: a diagonal mass inverted once and, when the system gives
    /// a tangent pattern, `A = -M⁻¹ K_t` assembled on it (docs/method.md eq. (12)).
    pub fn new(system: &'a S) -> Self {
        let inverse_mass = system
            .mass()
            .diagonal()
            .map(|d| d.iter().map(|m| 1.0 / m).collect::<Vec<f64>>());
        let assembled = inverse_mass.as_ref().and_then(|d| {
            let pattern = system.tangent_pattern()?;
            let scale = pattern
                .row_start
                .windows(2)
                .enumerate()
                .flat_map(|(i, b)| std::iter::repeat_n(-d[i], b[1] - b[0]))
                .collect();
            Some((pattern, scale))
        });
        Self {
            system,
            n: system.dofs(),
            inverse_mass,
            assembled,
            scratch: RefCell::new(Scratch::default()),
        }
    }

    /// The underlying system.
    pub fn system(&self) -> &'a S {
        self.system
    }

    /// Number of dofs `n` (a state has `2n` components).
    pub fn dofs(&self) -> usize {
        self.n
    }

    /// `a = -M⁻¹ f_int(x)`.
    #[inline]
    pub fn acceleration(&self, x: &[f64], a: &mut [f64]) {
        self.system.internal_force(x, a);
        match &self.inverse_mass {
            Some(d) => {
                for (ai, di) in a.iter_mut().zip(d) {
                    *ai *= -di;
                }
            }
            None => {
                self.system.mass().solve_in_place(a, 1);
                a.iter_mut().for_each(|v| *v = -*v);
            }
        }
    }

    /// `g(z) = [v; a(x)]`, the state-form vector field (eq. (3)).
    #[inline]
    pub fn field(&self, z: &[f64], out: &mut [f64]) {
        let n = self.n;
        let (dx, dv) = out.split_at_mut(n);
        dx.copy_from_slice(&z[n..]);
        self.acceleration(&z[..n], dv);
    }

    /// `out = A(x) dx = -M⁻¹ K_t(x) dx` for `k` contiguous column-major columns.
    pub fn acceleration_tangent(&self, x: &[f64], dx: &[f64], k: usize, out: &mut [f64]) {
        let n = self.n;
        self.system
            .tangent_stiffness(x, Block::new(dx, n, k, n), BlockMut::new(out, n, k, n));
        match &self.inverse_mass {
            Some(d) => {
                for column in out[..n * k].chunks_mut(n) {
                    for (o, di) in column.iter_mut().zip(d) {
                        *o *= -di;
                    }
                }
            }
            None => {
                self.system.mass().solve_in_place(out, k);
                out[..n * k].iter_mut().for_each(|v| *v = -*v);
            }
        }
    }

    /// The same product on *interleaved* blocks, the integrator's layout: `dx` and `out` are
    /// `n × k` row-major (direction `c` of dof `i` at `[i * k + c]`), so that a row of the
    /// assembled operator combines contiguous rows of `dx`.
    pub fn acceleration_tangent_interleaved(
        &self,
        x: &[f64],
        dx: &[f64],
        k: usize,
        out: &mut [f64],
    ) {
        let n = self.n;
        let mut scratch = self.scratch.borrow_mut();
        let scratch = &mut *scratch;
        if let Some((pattern, scale)) = &self.assembled {
            let values = &mut scratch.values;
            values.resize(pattern.nonzeros(), 0.0);
            self.system.tangent_values(x, values);
            for (v, s) in values.iter_mut().zip(scale) {
                *v *= s;
            }
            linalg::sparse_times_interleaved(&pattern.row_start, &pattern.col, values, dx, k, out);
            return;
        }
        let (a, b) = (&mut scratch.columns_in, &mut scratch.columns_out);
        a.resize(n * k, 0.0);
        b.resize(n * k, 0.0);
        for i in 0..n {
            for c in 0..k {
                a[c * n + i] = dx[i * k + c];
            }
        }
        self.acceleration_tangent(x, a, k, b);
        for i in 0..n {
            for c in 0..k {
                out[i * k + c] = b[c * n + i];
            }
        }
    }

    /// Total energy of the state `z = [x; v]`.
    pub fn energy(&self, z: &[f64]) -> f64 {
        self.system.energy(&z[..self.n], &z[self.n..])
    }
}
