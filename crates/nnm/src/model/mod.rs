//! The mechanical model: `M x'' + K x + f_nl(x) = 0` (SPEC §1).
//!
//! Two small traits are the plug-in points:
//! - [`NonlinearElement`]: one nonlinear restoring force law (force, tangent, potential).
//!   Put elements in a [`Structure`] with your own `M` and `K`.
//! - [`SecondOrderSystem`]: what the integrator needs from *any* conservative system
//!   (acceleration, its tangent applied to a block of directions, energy). [`Structure`]
//!   implements it with dense or compressed-row operators; a sparse finite-element model or a
//!   matrix-free one implements it directly, and shooting/continuation code does not change.

mod block;
mod elements;
mod families;
mod structure;

pub use block::{Block, BlockMut};
pub use elements::PolynomialSpring;
pub use families::{BladedDisk, duffing, two_dof};
pub use structure::{CyclicSymmetry, ModelError, Structure};

/// A conservative system `x'' = a(x)` with `a(x) = -M⁻¹ (K x + f_nl(x))` (SPEC §1, state form).
pub trait SecondOrderSystem: Sync {
    /// Number of degrees of freedom `n`.
    fn dofs(&self) -> usize;

    /// Writes `a = -M⁻¹ (K x + f_nl(x))`.
    fn acceleration(&self, x: &[f64], a: &mut [f64]);

    /// Writes `out = -M⁻¹ (K + ∂f_nl/∂x(x)) dx` for each column of `dx` — the lower block row
    /// of the variational equations `Φ' = J Φ` (SPEC §2), applied to the position block of Φ.
    fn acceleration_tangent(&self, x: &[f64], dx: Block<'_>, out: BlockMut<'_>);

    /// The same product on *interleaved* blocks, the integrator's layout: `dx` and `out` are
    /// `n × k` row-major, direction `c` of dof `i` at `[i * k + c]`, so that a row of a sparse
    /// operator combines contiguous rows of `dx`. The default transposes to and from
    /// [`Self::acceleration_tangent`]; override it for speed.
    fn acceleration_tangent_interleaved(&self, x: &[f64], dx: &[f64], k: usize, out: &mut [f64]) {
        tangent_through_columns(self, x, dx, k, out);
    }

    /// Total energy `E = ½ vᵀMv + ½ xᵀKx + V_nl(x)` (SPEC §1).
    fn energy(&self, x: &[f64], v: &[f64]) -> f64;
}

/// [`SecondOrderSystem::acceleration_tangent_interleaved`] through the column-major
/// [`SecondOrderSystem::acceleration_tangent`] (two transpositions into reused scratch).
pub fn tangent_through_columns<S: SecondOrderSystem + ?Sized>(
    system: &S,
    x: &[f64],
    dx: &[f64],
    k: usize,
    out: &mut [f64],
) {
    thread_local! {
        static COLUMNS: std::cell::RefCell<(Vec<f64>, Vec<f64>)> =
            const { std::cell::RefCell::new((Vec::new(), Vec::new())) };
    }
    let n = system.dofs();
    COLUMNS.with_borrow_mut(|(a, b)| {
        a.resize(n * k, 0.0);
        b.resize(n * k, 0.0);
        for i in 0..n {
            for c in 0..k {
                a[c * n + i] = dx[i * k + c];
            }
        }
        system.acceleration_tangent(x, Block::new(a, n, k, n), BlockMut::new(b, n, k, n));
        for i in 0..n {
            for c in 0..k {
                out[i * k + c] = b[c * n + i];
            }
        }
    });
}

/// One nonlinear restoring force `f_e(x)` with potential `V_e` (`f_e = ∂V_e/∂x`).
///
/// Elements must be conservative and depend on displacements only; [`Structure`] adds them up.
pub trait NonlinearElement: Send + Sync + std::fmt::Debug {
    /// Adds the element's force to `f` (same sign convention as `K x`).
    fn add_force(&self, x: &[f64], f: &mut [f64]);
    /// Adds `∂f_e/∂x(x) · dx[:, c]` to `out[:, c]` for every column.
    fn add_tangent_product(&self, x: &[f64], dx: Block<'_>, out: &mut BlockMut<'_>);
    /// Optional, for speed: writes the tangent `∂f_e/∂x(x)` restricted to the rows and columns
    /// [`Self::dofs_used`] (in that order; column-major, `m × m` for `m` dofs) and returns
    /// `true`. It must then be the whole tangent (zero outside those dofs), and the answer must
    /// not depend on `x`: a [`Structure`] whose elements all provide it assembles one sparse
    /// tangent operator per evaluation instead of applying the elements one by one.
    fn tangent_matrix(&self, _x: &[f64], _out: &mut [f64]) -> bool {
        false
    }
    /// The element's potential energy `V_e(x)`.
    fn potential(&self, x: &[f64]) -> f64;
    /// The degrees of freedom the element touches (for validation against the model size).
    fn dofs_used(&self) -> Vec<usize>;
}
