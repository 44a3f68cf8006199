//! The mechanical model `M x'' + f_int(x) = 0`, `f_int(x) = K x + f_nl(x)` (docs/method.md
//! eqs. (1), (3)), in the form finite-element users have it.
//!
//! The plug-in points:
//! - [`MechanicalSystem`]: any conservative structure — a mass operator, the internal force,
//!   the tangent stiffness applied to a block of vectors (optionally its values on a fixed
//!   sparse pattern) and the potential energy. Shooting, continuation and stability work on
//!   this trait alone; `examples/pendulum.rs` implements it in a few lines.
//! - [`NonlinearElement`]: one nonlinear restoring-force law, to put into a [`Structure`]
//!   with your own `M` and `K`: [`PolynomialSpring`] between two dofs, [`PolynomialTensor`]
//!   for quadratic and cubic forces over a whole finite-element model (docs/method.md
//!   eqs. (57)–(60)). [`FixedDofs`] removes clamped dofs from both (eq. (61)).
//!
//! The explicit form `x'' = a(x) = -M⁻¹ f_int(x)` (eq. (3)) is what explicit integrators
//! need; it is derived from the trait by [`ExplicitForm`], not implemented by users.

mod beams;
mod block;
#[cfg(test)]
pub(crate) mod checks;
mod constraints;
mod elements;
mod explicit;
mod families;
mod forcing;
mod layout;
mod mass;
mod matrix;
mod solid;
mod structure;
mod tensor;
mod von_karman;

pub use beams::CantileverBeam;
pub use block::{Block, BlockMut};
pub use constraints::FixedDofs;
pub use elements::PolynomialSpring;
pub use explicit::ExplicitForm;
pub use families::{BladedDisk, Duffing, TwoDof, duffing, two_dof};
pub use forcing::{ForcedSystem, HarmonicForce};
pub use layout::{Cell, CellKind, Layout};
pub use mass::{Mass, MassNotPositiveDefinite, MassOperator, dense_mass_matrix, mass_entries};
pub use matrix::{Matrix, SparseMatrix, SparsityPattern};
pub use solid::{Mesh, MeshElement, MeshElementKind, MeshFile, NodeGroup, Solid, SolidElementKind};
pub use structure::{CyclicSymmetry, ModelError, Structure};
pub use tensor::{PolynomialTensor, PolynomialTerms, TensorError};
pub use von_karman::VonKarmanBeam;

/// A conservative structure `M x'' + f_int(x) = 0` (docs/method.md eqs. (1), (3)).
///
/// Required: the number of dofs, the mass operator, the internal force, its tangent applied
/// to a block of directions, and the potential. Optional: the tangent's values on a fixed
/// sparse pattern (an assembled operator, much faster for many directions), and a cyclic
/// symmetry for `(n, d)` mode labels.
pub trait MechanicalSystem: Sync {
    /// Number of degrees of freedom `n`.
    fn dofs(&self) -> usize;

    /// The mass matrix `M` as an operator (factorised once).
    fn mass(&self) -> &dyn MassOperator;

    /// Writes `f = f_int(x)` (same sign as `K x`: the restoring force).
    fn internal_force(&self, x: &[f64], f: &mut [f64]);

    /// Writes `out[:, c] = K_t(x) dx[:, c]` for every column, `K_t = ∂f_int/∂x` (eq. (12)).
    fn tangent_stiffness(&self, x: &[f64], dx: Block<'_>, out: BlockMut<'_>);

    /// Potential energy `V(x)` with `∂V/∂x = f_int(x)`, `V(0) = 0`.
    fn potential_energy(&self, x: &[f64]) -> f64;

    /// The fixed sparsity pattern of `K_t(x)` (for every `x`), if the system can give its
    /// values there ([`Self::tangent_values`]).
    fn tangent_pattern(&self) -> Option<&SparsityPattern> {
        None
    }

    /// Writes the values of `K_t(x)` on [`Self::tangent_pattern`]. Called only when the
    /// pattern is given.
    fn tangent_values(&self, _x: &[f64], _values: &mut [f64]) {
        unimplemented!("tangent_values is required when tangent_pattern returns a pattern")
    }

    /// The dofs the nonlinearity lives on, when it is localised (joints, contact or cubic
    /// springs on a linear finite-element model): `K_t(x) − K_t(0)` must vanish outside these
    /// rows and columns for every `x`. `None` (the default): anywhere. With a
    /// [`Self::tangent_pattern`], the implicit integrator then factorises its stage system
    /// once per step size and updates it by the nonlinear dofs' low-rank part every step
    /// (docs/method.md eq. (32e)).
    fn nonlinear_dofs(&self) -> Option<&[usize]> {
        None
    }

    /// Writes `K_t(x) − K_t(0)` on [`Self::nonlinear_dofs`] (`p × p`, column-major, in their
    /// order), computed from the nonlinear part alone. Why not as a difference of whole
    /// tangents: a fine mesh's diagonal stiffness there can be 10⁸ times the nonlinear
    /// spring's (2·10¹³ against 3·10⁵ N/m at the tip of the 1,000-element ECL beam), and the
    /// difference would keep only half its digits. Called only when the dofs are given.
    fn nonlinear_tangent(&self, _x: &[f64], _out: &mut [f64]) {
        unimplemented!("nonlinear_tangent is required when nonlinear_dofs returns the dofs")
    }

    /// Cyclic symmetry (sector-major dof numbering), for `(n, d)` labels and mirror classes.
    fn cyclic_symmetry(&self) -> Option<CyclicSymmetry> {
        None
    }

    /// The sectors of a structure made of equal-sized sectors in sector-major numbering, with
    /// or without the symmetry: a mistuned disk keeps its sectors (an engine order drives
    /// them, [`crate::forced::Force`]) though its blades differ. The symmetry's, by default.
    fn sector_layout(&self) -> Option<CyclicSymmetry> {
        self.cyclic_symmetry()
    }

    /// Total energy `E = ½ vᵀ M v + V(x)` (eq. (2)).
    fn energy(&self, x: &[f64], v: &[f64]) -> f64 {
        let mut mv = vec![0.0; v.len()];
        self.mass().apply(v, 1, &mut mv);
        0.5 * crate::linalg::dot(v, &mv) + self.potential_energy(x)
    }
}

/// Writes `K_t(x)` of `system` into `out` as a dense column-major `n × n` matrix: from the
/// system's tangent pattern when it gives one, else by products with the unit vectors (small
/// models: the forced integrators' dense stage systems and the linear forced response).
/// `scratch` keeps the pattern's values, or the identity block, between calls.
pub fn dense_tangent<S: MechanicalSystem + ?Sized>(
    system: &S,
    x: &[f64],
    out: &mut [f64],
    scratch: &mut Vec<f64>,
) {
    let n = x.len();
    out[..n * n].fill(0.0);
    if let Some(pattern) = system.tangent_pattern() {
        scratch.resize(pattern.nonzeros(), 0.0);
        system.tangent_values(x, scratch);
        for (i, bounds) in pattern.row_start.windows(2).enumerate() {
            for (&j, &k) in pattern.col[bounds[0]..bounds[1]]
                .iter()
                .zip(&scratch[bounds[0]..bounds[1]])
            {
                out[j * n + i] += k;
            }
        }
        return;
    }
    if scratch.len() != n * n {
        scratch.clear();
        scratch.extend((0..n * n).map(|k| if k % n == k / n { 1.0 } else { 0.0 }));
    }
    system.tangent_stiffness(x, Block::new(scratch, n, n, n), BlockMut::new(out, n, n, n));
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
    /// `true`. It must then be the whole tangent (zero outside those dofs): a [`Structure`]
    /// whose elements all provide it assembles one sparse tangent per evaluation instead of
    /// applying the elements one by one.
    fn tangent_matrix(&self, _x: &[f64], _out: &mut [f64]) -> bool {
        false
    }
    /// Optional, for speed when the element touches many dofs sparsely (a polynomial tensor
    /// over a whole finite-element model, whose `m × m` [`Self::tangent_matrix`] would cost
    /// `O(m²)`): the positions `(row, column)` (global dofs) where `∂f_e/∂x` can be non-zero,
    /// for every `x`. When it returns a pattern, [`Self::tangent_values`] must write the
    /// tangent there, and a [`Structure`] assembles it on that pattern instead of calling
    /// [`Self::tangent_matrix`]. Positions may repeat (their values are summed).
    fn tangent_pattern(&self) -> Option<Vec<(usize, usize)>> {
        None
    }
    /// Writes `∂f_e/∂x(x)` at the positions of [`Self::tangent_pattern`] (same order), and
    /// must be the whole tangent. Called only when the pattern is given.
    fn tangent_values(&self, _x: &[f64], _out: &mut [f64]) {
        unimplemented!("tangent_values is required when tangent_pattern returns a pattern")
    }
    /// The element's potential energy `V_e(x)`.
    fn potential(&self, x: &[f64]) -> f64;
    /// Optional: the force as exact quadratic and cubic terms in global dofs
    /// (docs/method.md eq. (57)), when it is such a polynomial — what a finite-element code
    /// exports and a [`PolynomialTensor`] reads back, so that `nnm export` can write a model as
    /// files. `None` (the default): not a polynomial of degrees 2 and 3, or not known to be.
    /// The terms must give [`Self::add_force`] up to round-off.
    fn polynomial_terms(&self) -> Option<PolynomialTerms> {
        None
    }
    /// The degrees of freedom the element touches (for validation against the model size).
    fn dofs_used(&self) -> Vec<usize>;
}
