//! The triquadratic 27-node hexahedron on the reference cube `[−1, 1]³` and its 3×3×3
//! Gauss–Legendre rule (docs/method.md §20, eq. (103)).

/// Nodes of the element, and of its Gauss rule.
pub(super) const NODES: usize = 27;

/// The 1-D quadratic Lagrange functions at `ξ = −1, 0, 1` and their derivatives.
fn lagrange(xi: f64) -> ([f64; 3], [f64; 3]) {
    (
        [0.5 * xi * (xi - 1.0), 1.0 - xi * xi, 0.5 * xi * (xi + 1.0)],
        [xi - 0.5, -2.0 * xi, xi + 0.5],
    )
}

/// Local node `(i, j, k)` (each 0, 1, 2, at `ξ = i − 1`, ...) is number `i + 3 (j + 3 k)`,
/// the order of the box's grid (eq. (104)).
pub(super) fn local_node(i: usize, j: usize, k: usize) -> usize {
    i + 3 * (j + 3 * k)
}

/// The 3-point Gauss–Legendre rule on `[−1, 1]`: exact to degree 5.
const GAUSS_3: [(f64, f64); 3] = [
    (-0.774_596_669_241_483_4, 5.0 / 9.0),
    (0.0, 8.0 / 9.0),
    (0.774_596_669_241_483_4, 5.0 / 9.0),
];

use super::element::ReferencePoint;

/// The 27 points of the tensor-product rule, with the shape functions evaluated there. The
/// rule integrates the mass (`N_a N_b`, degree 4 per direction) exactly, the linear stiffness
/// (degree 2 per direction on a parallelepiped) exactly, and the cubic and quartic terms of
/// the force and energy not exactly: mass, force, tangent and energy therefore all use this
/// one rule, so that the force is the exact gradient of the energy the rule computes.
pub(super) fn gauss_points() -> Vec<ReferencePoint> {
    let mut points = Vec::with_capacity(NODES);
    for &(z, wz) in &GAUSS_3 {
        for &(y, wy) in &GAUSS_3 {
            for &(x, wx) in &GAUSS_3 {
                let (lx, dx) = lagrange(x);
                let (ly, dy) = lagrange(y);
                let (lz, dz) = lagrange(z);
                let mut shape = vec![0.0; NODES];
                let mut gradient = vec![[0.0; 3]; NODES];
                for k in 0..3 {
                    for j in 0..3 {
                        for i in 0..3 {
                            let a = local_node(i, j, k);
                            shape[a] = lx[i] * ly[j] * lz[k];
                            gradient[a] = [
                                dx[i] * ly[j] * lz[k],
                                lx[i] * dy[j] * lz[k],
                                lx[i] * ly[j] * dz[k],
                            ];
                        }
                    }
                }
                points.push(ReferencePoint {
                    weight: wx * wy * wz,
                    shape,
                    gradient,
                });
            }
        }
    }
    points
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Partition of unity, zero gradient sum, and the rule's weights summing to the cube's
    /// volume 8: the element reproduces constant and rigid fields.
    #[test]
    fn shape_functions_partition_unity() {
        let points = gauss_points();
        assert_eq!(points.len(), NODES);
        let volume: f64 = points.iter().map(|p| p.weight).sum();
        assert!((volume - 8.0).abs() < 1e-14);
        for p in &points {
            assert!((p.shape.iter().sum::<f64>() - 1.0).abs() < 1e-14);
            for d in 0..3 {
                assert!(p.gradient.iter().map(|g| g[d]).sum::<f64>().abs() < 1e-14);
            }
        }
    }

    /// Each function is 1 at its node and 0 at the others (evaluated through the 1-D factors).
    #[test]
    fn shape_functions_interpolate_at_nodes() {
        for node in 0..3 {
            let (l, _) = lagrange(node as f64 - 1.0);
            for (i, v) in l.iter().enumerate() {
                assert_eq!(*v, if i == node { 1.0 } else { 0.0 });
            }
        }
    }
}
