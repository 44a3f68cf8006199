//! The St. Venant–Kirchhoff material at one point (docs/method.md §20, eqs. (105)–(107)):
//! Green–Lagrange strain `E = ½ (H + Hᵀ + HᵀH)` of the displacement gradient `H = ∂u/∂X`,
//! second Piola–Kirchhoff stress `S = λ tr(E) I + 2 μ E`. Everything here is the part beyond
//! the linear one, written so that no linear term is computed and subtracted again: on a fine
//! mesh the linear stresses are many decades above the nonlinear ones, and a difference would
//! keep only the nonlinear part's last digits.

/// A 3×3 matrix, row-major.
pub(super) type Tensor = [[f64; 3]; 3];

/// Lamé's constants of an isotropic material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct StVenantKirchhoff {
    /// `λ = E ν / ((1 + ν)(1 − 2ν))`.
    pub lambda: f64,
    /// `μ = E / (2 (1 + ν))`.
    pub mu: f64,
}

/// The strains and stresses at one point, split into their linear and nonlinear parts.
pub(super) struct PointState {
    /// `H`.
    pub gradient: Tensor,
    /// `S_L = λ tr(ε) I + 2 μ ε`, `ε = ½ (H + Hᵀ)`.
    pub linear_stress: Tensor,
    /// `S_N = λ tr(E_N) I + 2 μ E_N`, `E_N = ½ HᵀH`.
    pub nonlinear_stress: Tensor,
}

impl StVenantKirchhoff {
    /// From Young's modulus and Poisson's ratio.
    pub fn new(youngs_modulus: f64, poisson_ratio: f64) -> Self {
        let (e, nu) = (youngs_modulus, poisson_ratio);
        Self {
            lambda: e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
            mu: e / (2.0 * (1.0 + nu)),
        }
    }

    /// `λ tr(T) I + 2 μ T` for a symmetric strain `T`.
    fn stress(&self, strain: &Tensor) -> Tensor {
        let trace = strain[0][0] + strain[1][1] + strain[2][2];
        std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                2.0 * self.mu * strain[i][j] + if i == j { self.lambda * trace } else { 0.0 }
            })
        })
    }

    /// The point's stresses for the displacement gradient `h`.
    pub fn state(&self, h: Tensor) -> PointState {
        let linear_strain =
            std::array::from_fn(|i| std::array::from_fn(|j| 0.5 * (h[i][j] + h[j][i])));
        let nonlinear_strain = std::array::from_fn(|i| {
            std::array::from_fn(|j| 0.5 * (0..3).map(|k| h[k][i] * h[k][j]).sum::<f64>())
        });
        PointState {
            gradient: h,
            linear_stress: self.stress(&linear_strain),
            nonlinear_stress: self.stress(&nonlinear_strain),
        }
    }
}

impl PointState {
    /// The nonlinear part of the first Piola–Kirchhoff stress `P = (I + H) S` (eq. (106)):
    /// `P − S_L = S_N + H (S_L + S_N)`, quadratic plus cubic in `H`.
    pub fn nonlinear_first_stress(&self) -> Tensor {
        let s = self.total_stress();
        std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                self.nonlinear_stress[i][j]
                    + (0..3).map(|k| self.gradient[i][k] * s[k][j]).sum::<f64>()
            })
        })
    }

    /// `S = S_L + S_N`.
    pub fn total_stress(&self) -> Tensor {
        std::array::from_fn(|i| {
            std::array::from_fn(|j| self.linear_stress[i][j] + self.nonlinear_stress[i][j])
        })
    }

    /// The nonlinear part of the strain energy density `W = ½ S : E` (eq. (105)):
    /// `W − ½ S_L : ε = S_L : E_N + ½ S_N : E_N` (`S_L : E_N = ε : S_N` by the symmetry of
    /// the elasticity tensor, hence the single cross term).
    pub fn nonlinear_energy(&self) -> f64 {
        let h = &self.gradient;
        let mut energy = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                let e_n = 0.5 * (0..3).map(|k| h[k][i] * h[k][j]).sum::<f64>();
                energy += (self.linear_stress[i][j] + 0.5 * self.nonlinear_stress[i][j]) * e_n;
            }
        }
        energy
    }

    /// `A = (I + H)(I + H)ᵀ − I = H + Hᵀ + H Hᵀ`, the nonlinear part of the material tangent's
    /// `F Fᵀ` (eq. (107)).
    pub fn stretch_excess(&self) -> Tensor {
        let h = &self.gradient;
        std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                h[i][j] + h[j][i] + (0..3).map(|k| h[i][k] * h[j][k]).sum::<f64>()
            })
        })
    }
}
