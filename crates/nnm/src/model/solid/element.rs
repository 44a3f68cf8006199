//! One solid finite element of a St. Venant–Kirchhoff body as a [`NonlinearElement`]: its
//! geometry at the quadrature points, the consistent mass and linear stiffness that go into
//! `M` and `K`, and the nonlinear force, tangent and energy evaluated at every call from the
//! element's own displacements — exactly cubic, never expanded into a global tensor
//! (docs/method.md §20, eqs. (105)–(108)).

use std::sync::Arc;

use super::material::{PointState, StVenantKirchhoff, Tensor};
use crate::model::{Block, BlockMut, NonlinearElement, PolynomialTerms};

/// The most nodes an element has (the 27-node hexahedron).
pub(super) const MAX_NODES: usize = 27;
/// The most dofs an element has.
const MAX_DOFS: usize = 3 * MAX_NODES;

/// A quadrature point on the reference element: weight, shape functions and their gradients
/// in the reference coordinates.
#[derive(Debug, Clone)]
pub(super) struct ReferencePoint {
    pub weight: f64,
    pub shape: Vec<f64>,
    pub gradient: Vec<[f64; 3]>,
}

/// A quadrature point of an element in space: `weight · det J`, the shape functions and their
/// gradients `∂N_a/∂X`.
#[derive(Debug, Clone)]
pub(super) struct Point {
    pub weight: f64,
    pub shape: Vec<f64>,
    pub gradient: Vec<[f64; 3]>,
}

/// An element's geometry at its quadrature points. Elements of the same shape and size (every
/// element of a structured box) share one.
#[derive(Debug, Clone)]
pub(super) struct Geometry {
    pub nodes: usize,
    pub points: Vec<Point>,
}

impl Geometry {
    /// The element with node coordinates `coordinates` (in the reference element's node
    /// order); `Err(det J)` at the first quadrature point where the map from the reference
    /// element is inverted or degenerate (`det J ≤ 0`, or below `1e-12` of the element's size
    /// cubed).
    pub fn new(reference: &[ReferencePoint], coordinates: &[[f64; 3]]) -> Result<Self, f64> {
        let size = bounding_size(coordinates);
        let points = reference
            .iter()
            .map(|p| {
                // J_ij = ∂X_i/∂ξ_j.
                let mut jacobian = [[0.0; 3]; 3];
                for (x, g) in coordinates.iter().zip(&p.gradient) {
                    for i in 0..3 {
                        for j in 0..3 {
                            jacobian[i][j] += x[i] * g[j];
                        }
                    }
                }
                let (det, inverse) = invert(&jacobian);
                // Negated so that a NaN determinant is refused too.
                #[allow(clippy::neg_cmp_op_on_partial_ord)]
                if !(det > 1e-12 * size.powi(3)) {
                    return Err(det);
                }
                // ∂N/∂X = J⁻ᵀ ∂N/∂ξ.
                let gradient = p
                    .gradient
                    .iter()
                    .map(|g| std::array::from_fn(|i| (0..3).map(|j| inverse[j][i] * g[j]).sum()))
                    .collect();
                Ok(Point {
                    weight: p.weight * det,
                    shape: p.shape.clone(),
                    gradient,
                })
            })
            .collect::<Result<Vec<_>, f64>>()?;
        Ok(Self {
            nodes: coordinates.len(),
            points,
        })
    }

    /// The consistent mass `ρ ∫ N_a N_b dV δ_ij` (eq. (108)), row-major `3N × 3N` in the local
    /// dof order `3 a + i`.
    pub fn mass(&self, density: f64) -> Vec<f64> {
        let m = 3 * self.nodes;
        let mut out = vec![0.0; m * m];
        for p in &self.points {
            for a in 0..self.nodes {
                for b in 0..self.nodes {
                    let v = density * p.weight * p.shape[a] * p.shape[b];
                    for i in 0..3 {
                        out[(3 * a + i) * m + 3 * b + i] += v;
                    }
                }
            }
        }
        out
    }

    /// The linear stiffness (eq. (108)):
    /// `K_ab,ij = ∫ λ ∂_i N_a ∂_j N_b + μ ∂_j N_a ∂_i N_b + μ (∇N_a · ∇N_b) δ_ij dV`.
    pub fn stiffness(&self, material: &StVenantKirchhoff) -> Vec<f64> {
        let m = 3 * self.nodes;
        let (lambda, mu) = (material.lambda, material.mu);
        let mut out = vec![0.0; m * m];
        for p in &self.points {
            for (a, ga) in p.gradient.iter().enumerate() {
                for (b, gb) in p.gradient.iter().enumerate() {
                    let c = dot(ga, gb);
                    for i in 0..3 {
                        for j in 0..3 {
                            let delta = if i == j { mu * c } else { 0.0 };
                            out[(3 * a + i) * m + 3 * b + j] +=
                                p.weight * (lambda * ga[i] * gb[j] + mu * ga[j] * gb[i] + delta);
                        }
                    }
                }
            }
        }
        out
    }
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The largest extent of the nodes along the axes.
fn bounding_size(coordinates: &[[f64; 3]]) -> f64 {
    (0..3)
        .map(|i| {
            let (lo, hi) = coordinates
                .iter()
                .fold((f64::MAX, f64::MIN), |(lo, hi), x| {
                    (lo.min(x[i]), hi.max(x[i]))
                });
            hi - lo
        })
        .fold(0.0, f64::max)
}

/// `(det A, A⁻¹)` of a 3×3 matrix (the inverse is meaningless when `det A = 0`).
fn invert(a: &Tensor) -> (f64, Tensor) {
    let cofactor = |i: usize, j: usize| {
        let (r0, r1) = ((i + 1) % 3, (i + 2) % 3);
        let (c0, c1) = ((j + 1) % 3, (j + 2) % 3);
        a[r0][c0] * a[r1][c1] - a[r0][c1] * a[r1][c0]
    };
    let det = (0..3).map(|j| a[0][j] * cofactor(0, j)).sum::<f64>();
    (
        det,
        std::array::from_fn(|i| std::array::from_fn(|j| cofactor(j, i) / det)),
    )
}

/// One element: where its local dofs `3 a + i` go (`None` where clamped), its geometry and
/// material.
#[derive(Debug)]
pub(super) struct SolidElement {
    dofs: Vec<Option<usize>>,
    /// The local dofs that are not clamped, ascending: the rows and columns of
    /// [`NonlinearElement::tangent_matrix`] (kept, since it is called for every element at
    /// every tangent evaluation).
    free: Vec<usize>,
    geometry: Arc<Geometry>,
    material: StVenantKirchhoff,
}

impl SolidElement {
    pub fn new(
        dofs: Vec<Option<usize>>,
        geometry: Arc<Geometry>,
        material: StVenantKirchhoff,
    ) -> Self {
        let free = (0..dofs.len()).filter(|&a| dofs[a].is_some()).collect();
        Self {
            dofs,
            free,
            geometry,
            material,
        }
    }

    /// The local displacements (zero at clamped dofs).
    fn local(&self, x: &[f64]) -> [f64; MAX_DOFS] {
        let mut q = [0.0; MAX_DOFS];
        for (v, d) in q.iter_mut().zip(&self.dofs) {
            *v = d.map_or(0.0, |i| x[i]);
        }
        q
    }

    /// The stresses at a point for local displacements `q`: `H = Σ_a q_a ⊗ ∇N_a`.
    fn state(&self, point: &Point, q: &[f64]) -> PointState {
        let mut h = [[0.0; 3]; 3];
        for (qa, g) in q.chunks_exact(3).zip(&point.gradient) {
            for i in 0..3 {
                for j in 0..3 {
                    h[i][j] += qa[i] * g[j];
                }
            }
        }
        self.material.state(h)
    }

    /// The local nonlinear force `∫ (P − S_L) ∇N_a dV` (eq. (106)).
    fn local_force(&self, q: &[f64; MAX_DOFS]) -> [f64; MAX_DOFS] {
        let mut f = [0.0; MAX_DOFS];
        let m = self.dofs.len();
        for point in &self.geometry.points {
            let p = self.state(point, &q[..m]).nonlinear_first_stress();
            for (fa, g) in f.chunks_exact_mut(3).zip(&point.gradient) {
                for i in 0..3 {
                    fa[i] += point.weight * dot(&p[i], g);
                }
            }
        }
        f
    }

    /// The local nonlinear tangent, row-major `m × m` into `k` (eq. (107)): per point, with
    /// `g_a = ∇N_a`, `h_a = H g_a`, `G_a = g_a + h_a` and `A = H + Hᵀ + HHᵀ`,
    ///
    /// `K_ab = (g_a · S g_b) I + λ (G_a h_bᵀ + h_a g_bᵀ) + μ (h_b G_aᵀ + g_b h_aᵀ) + μ (g_a · g_b) A`
    ///
    /// — the full tangent `(g_a·S g_b) I + λ F g_a (F g_b)ᵀ + μ F g_b (F g_a)ᵀ + μ (g_a·g_b) F Fᵀ`
    /// less its value at rest, expanded so that nothing is subtracted.
    fn local_tangent(&self, q: &[f64; MAX_DOFS], k: &mut [f64]) {
        let m = self.dofs.len();
        let nodes = self.geometry.nodes;
        let (lambda, mu) = (self.material.lambda, self.material.mu);
        k[..m * m].fill(0.0);
        let mut h = [[0.0; 3]; MAX_NODES];
        let mut big = [[0.0; 3]; MAX_NODES];
        let mut sg = [[0.0; 3]; MAX_NODES];
        for point in &self.geometry.points {
            let state = self.state(point, &q[..m]);
            let s = state.total_stress();
            let a_excess = state.stretch_excess();
            let w = point.weight;
            for (a, g) in point.gradient.iter().enumerate() {
                h[a] = std::array::from_fn(|i| dot(&state.gradient[i], g));
                big[a] = std::array::from_fn(|i| g[i] + h[a][i]);
                sg[a] = std::array::from_fn(|i| dot(&s[i], g));
            }
            for a in 0..nodes {
                let ga = &point.gradient[a];
                for b in a..nodes {
                    let gb = &point.gradient[b];
                    let geometric = w * dot(ga, &sg[b]);
                    let c = w * mu * dot(ga, gb);
                    for i in 0..3 {
                        let row = (3 * a + i) * m + 3 * b;
                        for j in 0..3 {
                            let mut v = w
                                * (lambda * (big[a][i] * h[b][j] + h[a][i] * gb[j])
                                    + mu * (h[b][i] * big[a][j] + gb[i] * h[a][j]))
                                + c * a_excess[i][j];
                            if i == j {
                                v += geometric;
                            }
                            k[row + j] += v;
                        }
                    }
                }
            }
        }
        // The lower blocks from the upper ones (K is symmetric).
        for a in 0..nodes {
            for b in 0..a {
                for i in 0..3 {
                    for j in 0..3 {
                        k[(3 * a + i) * m + 3 * b + j] = k[(3 * b + j) * m + 3 * a + i];
                    }
                }
            }
        }
    }
}

thread_local! {
    /// One element's local tangent, reused across calls.
    static TANGENT: std::cell::RefCell<Vec<f64>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

impl NonlinearElement for SolidElement {
    fn add_force(&self, x: &[f64], f: &mut [f64]) {
        let local = self.local_force(&self.local(x));
        crate::model::elements::add_local(&self.dofs, &local, f);
    }

    fn add_tangent_product(&self, x: &[f64], dx: Block<'_>, out: &mut BlockMut<'_>) {
        let m = self.dofs.len();
        TANGENT.with_borrow_mut(|k| {
            k.resize(m * m, 0.0);
            self.local_tangent(&self.local(x), k);
            for c in 0..dx.cols {
                let d = self.local(dx.col(c));
                let o = out.col_mut(c);
                for (row, dof) in k.chunks_exact(m).zip(&self.dofs) {
                    if let Some(i) = *dof {
                        o[i] += row.iter().zip(&d[..m]).map(|(a, b)| a * b).sum::<f64>();
                    }
                }
            }
        });
    }

    fn tangent_matrix(&self, x: &[f64], out: &mut [f64]) -> bool {
        let m = self.dofs.len();
        TANGENT.with_borrow_mut(|k| {
            k.resize(m * m, 0.0);
            self.local_tangent(&self.local(x), k);
            // Symmetric: the free rows of the free columns, in either order.
            let u = self.free.len();
            for (jb, &b) in self.free.iter().enumerate() {
                for (ia, &a) in self.free.iter().enumerate() {
                    out[jb * u + ia] = k[a * m + b];
                }
            }
        });
        true
    }

    fn potential(&self, x: &[f64]) -> f64 {
        let q = self.local(x);
        let m = self.dofs.len();
        self.geometry
            .points
            .iter()
            .map(|p| p.weight * self.state(p, &q[..m]).nonlinear_energy())
            .sum()
    }

    /// The force as quadratic and cubic terms in the element's dofs (eq. (106) expanded), by
    /// the same quadrature, with `Γ_ab = ∇N_a · ∇N_b` at each point:
    /// - cubic, row `(a, i)`: `Σ_{b,c,e} q_b,i (q_c · q_e) (½ λ Γ_ab Γ_ce + μ Γ_bc Γ_ea)`;
    /// - quadratic, row `(a, i)`: `Σ_{b,c} q_b,i Σ_k q_c,k (λ Γ_ab ∂_k N_c + μ ∂_k N_b Γ_ca
    ///   + μ ∂_k N_a Γ_cb)` (from `H S_L`) and `Σ_{c,e} (q_c · q_e) (½ λ Γ_ce ∂_i N_a
    ///   + μ ∂_i N_c Γ_ea)` (from `S_N`).
    ///
    /// `O(N⁴)` terms per element: for exporting small models and for checking the element
    /// against the tensor path, not for computing.
    fn polynomial_terms(&self) -> Option<PolynomialTerms> {
        let nodes = self.geometry.nodes;
        let m = 3 * nodes;
        let (lambda, mu) = (self.material.lambda, self.material.mu);
        // quadratic[(row · m + r) · m + s], cubic[((a · N + b) · N + c) · N + e].
        let mut quadratic = vec![0.0; m * m * m];
        let mut cubic = vec![0.0; nodes.pow(4)];
        for p in &self.geometry.points {
            let (w, g) = (p.weight, &p.gradient);
            let gram: Vec<f64> = (0..nodes * nodes)
                .map(|ab| dot(&g[ab / nodes], &g[ab % nodes]))
                .collect();
            let gm = |a: usize, b: usize| gram[a * nodes + b];
            for a in 0..nodes {
                for b in 0..nodes {
                    for c in 0..nodes {
                        for e in 0..nodes {
                            cubic[((a * nodes + b) * nodes + c) * nodes + e] +=
                                w * (0.5 * lambda * gm(a, b) * gm(c, e) + mu * gm(b, c) * gm(e, a));
                        }
                    }
                }
            }
            for a in 0..nodes {
                for i in 0..3 {
                    let row = 3 * a + i;
                    for b in 0..nodes {
                        for c in 0..nodes {
                            for k in 0..3 {
                                // q_b,i q_c,k
                                quadratic[(row * m + 3 * b + i) * m + 3 * c + k] += w
                                    * (lambda * gm(a, b) * g[c][k]
                                        + mu * g[b][k] * gm(c, a)
                                        + mu * g[a][k] * gm(c, b));
                                // q_b,k q_c,k (b plays c, c plays e of the formula)
                                quadratic[(row * m + 3 * b + k) * m + 3 * c + k] += w
                                    * (0.5 * lambda * gm(b, c) * g[a][i] + mu * g[b][i] * gm(c, a));
                            }
                        }
                    }
                }
            }
        }
        let mut terms = PolynomialTerms::default();
        for (row, &dof) in self.dofs.iter().enumerate() {
            let Some(i) = dof else { continue };
            for r in 0..m {
                for s in 0..m {
                    let v = quadratic[(row * m + r) * m + s];
                    if let (Some(j), Some(k), true) = (self.dofs[r], self.dofs[s], v != 0.0) {
                        terms.quadratic.push((i, [j, k], v));
                    }
                }
            }
        }
        for a in 0..nodes {
            for b in 0..nodes {
                for c in 0..nodes {
                    for e in 0..nodes {
                        let v = cubic[((a * nodes + b) * nodes + c) * nodes + e];
                        if v == 0.0 {
                            continue;
                        }
                        for i in 0..3 {
                            let (Some(row), Some(j)) = (self.dofs[3 * a + i], self.dofs[3 * b + i])
                            else {
                                continue;
                            };
                            for k in 0..3 {
                                if let (Some(l), Some(n)) =
                                    (self.dofs[3 * c + k], self.dofs[3 * e + k])
                                {
                                    terms.cubic.push((row, [j, l, n], v));
                                }
                            }
                        }
                    }
                }
            }
        }
        Some(terms.summed())
    }

    fn dofs_used(&self) -> Vec<usize> {
        self.dofs.iter().flatten().copied().collect()
    }
}
