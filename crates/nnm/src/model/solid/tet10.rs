//! The quadratic 10-node tetrahedron on the reference tetrahedron `ξ, η, ζ ≥ 0,
//! ξ + η + ζ ≤ 1` and its 14-point rule (docs/method.md §20, eq. (109)).
//!
//! Nodes in Gmsh's order: the vertices `(0,0,0)`, `(1,0,0)`, `(0,1,0)`, `(0,0,1)`, then the
//! mid-edge nodes of the edges 0–1, 1–2, 0–2, 0–3, 2–3, 1–3.

use super::element::ReferencePoint;

/// Nodes of the element.
pub(super) const NODES: usize = 10;

/// The vertices of each mid-edge node `4 + e`, in Gmsh's order.
pub(super) const EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [0, 2], [0, 3], [2, 3], [1, 3]];

/// The barycentric coordinates `L = (1 − ξ − η − ζ, ξ, η, ζ)` and their constant gradients.
const BARYCENTRIC_GRADIENT: [[f64; 3]; 4] = [
    [-1.0, -1.0, -1.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];

/// Shape functions and their gradients at `(ξ, η, ζ)`: `L_i (2 L_i − 1)` at the vertices,
/// `4 L_i L_j` at the mid-edge nodes.
fn shape(xi: [f64; 3]) -> ([f64; NODES], [[f64; 3]; NODES]) {
    let l = [1.0 - xi[0] - xi[1] - xi[2], xi[0], xi[1], xi[2]];
    let g = BARYCENTRIC_GRADIENT;
    let mut n = [0.0; NODES];
    let mut dn = [[0.0; 3]; NODES];
    for i in 0..4 {
        n[i] = l[i] * (2.0 * l[i] - 1.0);
        dn[i] = g[i].map(|d| (4.0 * l[i] - 1.0) * d);
    }
    for (e, &[i, j]) in EDGES.iter().enumerate() {
        n[4 + e] = 4.0 * l[i] * l[j];
        dn[4 + e] = std::array::from_fn(|d| 4.0 * (g[i][d] * l[j] + l[i] * g[j][d]));
    }
    (n, dn)
}

/// The symmetric 14-point rule of degree 5 with positive weights (the orbits of
/// `(a, a, a, 1 − 3a)` for two values of `a`, and of `(b, b, ½ − b, ½ − b)`), weights summing
/// to the reference volume 1/6. On a straight-sided element the Jacobian is constant, so the
/// rule integrates the mass (degree 4), the linear stiffness (degree 2), and the nonlinear
/// force, tangent and energy (degree 4) exactly; the same rule serves all four.
const RULE: [(f64, f64); 3] = [
    (0.09273525031089122, 0.012248840519393659),
    (0.3108859192633006, 0.018781320953002643),
    (0.04550370412564965, 0.007091003462846911),
];

/// The rule's points, with the shape functions evaluated there.
pub(super) fn quadrature_points() -> Vec<ReferencePoint> {
    let mut barycentric: Vec<([f64; 4], f64)> = Vec::with_capacity(14);
    for &(a, w) in &RULE[..2] {
        for i in 0..4 {
            let mut l = [a; 4];
            l[i] = 1.0 - 3.0 * a;
            barycentric.push((l, w));
        }
    }
    let (b, w) = RULE[2];
    for i in 0..4 {
        for j in i + 1..4 {
            let mut l = [0.5 - b; 4];
            l[i] = b;
            l[j] = b;
            barycentric.push((l, w));
        }
    }
    barycentric
        .into_iter()
        .map(|(l, weight)| {
            let (n, dn) = shape([l[1], l[2], l[3]]);
            ReferencePoint {
                weight,
                shape: n.to_vec(),
                gradient: dn.to_vec(),
            }
        })
        .collect()
}

/// The reference coordinates of the nodes.
pub(super) fn node_coordinates() -> [[f64; 3]; NODES] {
    with_edges(&EDGES)
}

/// The reference coordinates of a 10-node tetrahedron whose mid-edge nodes `4..10` lie on
/// `edges` in that order (the vertices first): how file formats, which differ only there,
/// declare their node orders.
pub(super) fn with_edges(edges: &[[usize; 2]; 6]) -> [[f64; 3]; NODES] {
    let vertices = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    std::array::from_fn(|a| {
        if a < 4 {
            vertices[a]
        } else {
            let [i, j] = edges[a - 4];
            std::array::from_fn(|d| 0.5 * (vertices[i][d] + vertices[j][d]))
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `∫ ξ^p η^q ζ^r` over the reference tetrahedron is `p! q! r! / (p + q + r + 3)!`: the
    /// rule matches it for every monomial of degree ≤ 5.
    #[test]
    fn rule_is_exact_to_degree_five() {
        let factorial = |n: u32| (1..=n).map(f64::from).product::<f64>();
        let points = quadrature_points();
        assert_eq!(points.len(), 14);
        // The points in reference coordinates, recovered from the linear shape functions.
        let coordinates: Vec<[f64; 3]> = points
            .iter()
            .map(|p| {
                let x = node_coordinates();
                std::array::from_fn(|d| (0..NODES).map(|a| p.shape[a] * x[a][d]).sum())
            })
            .collect();
        for p in 0..=5 {
            for q in 0..=5 - p {
                for r in 0..=5 - p - q {
                    let exact =
                        factorial(p) * factorial(q) * factorial(r) / factorial(p + q + r + 3);
                    let sum: f64 = points
                        .iter()
                        .zip(&coordinates)
                        .map(|(pt, x)| {
                            pt.weight
                                * x[0].powi(p as i32)
                                * x[1].powi(q as i32)
                                * x[2].powi(r as i32)
                        })
                        .sum();
                    assert!(
                        (sum - exact).abs() < 1e-14 * exact,
                        "{p} {q} {r}: {sum} vs {exact}"
                    );
                }
            }
        }
    }

    /// Each function is 1 at its node and 0 at the others; the gradients match central
    /// differences of the functions.
    #[test]
    fn shape_functions_interpolate_and_differentiate() {
        for (a, x) in node_coordinates().iter().enumerate() {
            let (n, _) = shape(*x);
            for (b, v) in n.iter().enumerate() {
                assert!((v - if a == b { 1.0 } else { 0.0 }).abs() < 1e-15);
            }
        }
        let x = [0.21, 0.17, 0.33];
        let (_, dn) = shape(x);
        let h = 1e-6;
        for d in 0..3 {
            let (mut up, mut down) = (x, x);
            up[d] += h;
            down[d] -= h;
            let (np, nm) = (shape(up).0, shape(down).0);
            for a in 0..NODES {
                assert!(((np[a] - nm[a]) / (2.0 * h) - dn[a][d]).abs() < 1e-9);
            }
        }
    }
}
