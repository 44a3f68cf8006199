//! Checks shared by the families' tests.

use super::{Block, BlockMut, MechanicalSystem, NonlinearElement, PolynomialTensor, Structure};

/// Asserts that `tensor` (the elements' polynomial terms read back as one global tensor) gives
/// the elements' own force and tangent of `s` at `x`, to 1e-12 of their largest entries.
pub(crate) fn assert_tensor_gives_the_elements(
    s: &Structure,
    tensor: &PolynomialTensor,
    x: &[f64],
) {
    let n = s.dofs();
    let max_abs = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let (mut f, mut g) = (vec![0.0; n], vec![0.0; n]);
    s.nonlinear_force(x, &mut f);
    tensor.add_force(x, &mut g);
    let scale = max_abs(&f);
    for i in 0..n {
        assert!(
            (f[i] - g[i]).abs() < 1e-12 * scale,
            "dof {i}: {} vs {}",
            f[i],
            g[i]
        );
    }
    let eye: Vec<f64> = (0..n * n)
        .map(|k| if k % (n + 1) == 0 { 1.0 } else { 0.0 })
        .collect();
    let (mut kt, mut kg) = (vec![0.0; n * n], vec![0.0; n * n]);
    for e in s.elements() {
        e.add_tangent_product(
            x,
            Block::new(&eye, n, n, n),
            &mut BlockMut::new(&mut kt, n, n, n),
        );
    }
    tensor.add_tangent_product(
        x,
        Block::new(&eye, n, n, n),
        &mut BlockMut::new(&mut kg, n, n, n),
    );
    let scale = max_abs(&kt);
    for (k, (a, b)) in kt.iter().zip(&kg).enumerate() {
        assert!(
            (a - b).abs() < 1e-12 * scale,
            "({}, {}): {a} vs {b}",
            k % n,
            k / n
        );
    }
}
