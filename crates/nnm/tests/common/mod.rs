//! Shared test systems.

use nnm::prelude::*;

/// A system with its tangent pattern withheld: the same forces and tangents, but every
/// consumer must take its unassembled (block-product or dense) path.
pub struct Unassembled<S>(pub S);

impl<S: MechanicalSystem> MechanicalSystem for Unassembled<S> {
    fn dofs(&self) -> usize {
        self.0.dofs()
    }
    fn mass(&self) -> &dyn MassOperator {
        self.0.mass()
    }
    fn internal_force(&self, x: &[f64], f: &mut [f64]) {
        self.0.internal_force(x, f)
    }
    fn tangent_stiffness(&self, x: &[f64], dx: Block<'_>, out: BlockMut<'_>) {
        self.0.tangent_stiffness(x, dx, out)
    }
    fn potential_energy(&self, x: &[f64]) -> f64 {
        self.0.potential_energy(x)
    }
}
