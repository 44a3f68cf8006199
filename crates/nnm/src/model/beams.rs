//! Finite-element beam families: stiff models with consistent mass, the case the implicit
//! integrators are for.

use super::{Layout, ModelError, NonlinearElement, PolynomialSpring, SparseMatrix, Structure};
use crate::number::Number;

/// A clamped–free Euler–Bernoulli beam of `elements` two-node Hermite elements (transverse
/// displacement `w` and rotation `θ` per node, consistent mass), with a cubic spring
/// `cubic · w_tip³` from the free end's displacement to ground.
///
/// The defaults are the ECL benchmark (NLvib's example 09): a steel beam 0.7 m long with a
/// 14 × 14 mm square section, E = 205 GPa, ρ = 7800 kg/m³, and a 6e9 N/m³ tip spring; with 19
/// elements its first linear frequencies are 23.66, 148.3, 415.2, 813.7 Hz. Dofs: node `i`
/// (`1..=elements`, the clamped node 0 removed) has `w` at `2(i−1)` and `θ` at `2(i−1)+1`; the
/// tip displacement is dof `2·elements − 2`.
///
/// Missing keys of a job file take the [`Default`] values.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CantileverBeam {
    /// Number of elements (at least 1).
    pub elements: usize,
    /// Length `L` (m).
    pub length: f64,
    /// Section width `b` (m).
    pub width: f64,
    /// Section height `h` (m), in the bending direction.
    pub height: f64,
    /// Young's modulus `E` (Pa).
    pub youngs_modulus: f64,
    /// Density `ρ` (kg/m³).
    pub density: f64,
    /// Tip spring coefficient (N/m³).
    pub cubic: f64,
}

impl Default for CantileverBeam {
    /// The ECL benchmark with 19 elements (38 dofs).
    fn default() -> Self {
        Self {
            elements: 19,
            length: 0.7,
            width: 0.014,
            height: 0.014,
            youngs_modulus: 2.05e11,
            density: 7800.0,
            cubic: 6e9,
        }
    }
}

impl CantileverBeam {
    /// The beam as points along x, its deflection `w` along z (the rotations move no point).
    pub fn layout(&self) -> Layout {
        Layout::beam(self.elements + 1, self.length, |i| {
            [None, None, (i > 0).then(|| 2 * (i - 1))]
        })
    }

    /// The tip's transverse displacement dof.
    pub fn tip(&self) -> usize {
        2 * self.elements - 2
    }

    /// Assembles the sparse (banded) mass and stiffness matrices and the tip spring.
    pub fn build(&self) -> Result<Structure, ModelError> {
        if self.elements == 0 || self.elements > 1_000_000 {
            return Err(ModelError::InvalidParameter(format!(
                "elements must be between 1 and 1000000, got {}",
                self.elements
            )));
        }
        for (name, value) in [
            ("length", self.length),
            ("width", self.width),
            ("height", self.height),
            ("youngs_modulus", self.youngs_modulus),
            ("density", self.density),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(ModelError::InvalidParameter(format!(
                    "{name} must be positive and finite, got {}",
                    Number(value)
                )));
            }
        }
        if !self.cubic.is_finite() {
            return Err(ModelError::InvalidParameter(format!(
                "cubic must be finite, got {}",
                Number(self.cubic)
            )));
        }
        let le = self.length / self.elements as f64;
        let area = self.width * self.height;
        let inertia = self.width * self.height.powi(3) / 12.0;
        let k = self.youngs_modulus * inertia / le.powi(3);
        let m = self.density * area * le / 420.0;
        let stiffness_e = [
            [12.0, 6.0 * le, -12.0, 6.0 * le],
            [6.0 * le, 4.0 * le * le, -6.0 * le, 2.0 * le * le],
            [-12.0, -6.0 * le, 12.0, -6.0 * le],
            [6.0 * le, 2.0 * le * le, -6.0 * le, 4.0 * le * le],
        ];
        let mass_e = [
            [156.0, 22.0 * le, 54.0, -13.0 * le],
            [22.0 * le, 4.0 * le * le, 13.0 * le, -3.0 * le * le],
            [54.0, 13.0 * le, 156.0, -22.0 * le],
            [-13.0 * le, -3.0 * le * le, -22.0 * le, 4.0 * le * le],
        ];
        let n = 2 * self.elements;
        let (mut mass, mut stiffness) = (Vec::new(), Vec::new());
        for e in 0..self.elements {
            // Element e joins nodes e and e+1; global dof of local a, node 0's removed.
            let dof = |a: usize| (2 * e + a).checked_sub(2);
            for a in 0..4 {
                for b in 0..4 {
                    if let (Some(i), Some(j)) = (dof(a), dof(b)) {
                        mass.push((i, j, m * mass_e[a][b]));
                        stiffness.push((i, j, k * stiffness_e[a][b]));
                    }
                }
            }
        }
        let sparse = |t: &[(usize, usize, f64)]| {
            SparseMatrix::from_triplets(n, t).map_err(ModelError::InvalidParameter)
        };
        let spring: Vec<Box<dyn NonlinearElement>> = vec![Box::new(PolynomialSpring::cubic(
            self.tip(),
            None,
            self.cubic,
        ))];
        Structure::new(sparse(&mass)?, sparse(&stiffness)?, spring)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::modes::linear_modes;

    /// The first three frequencies converge to Euler–Bernoulli theory,
    /// `ω_k = (β_k L)² √(EI / (ρ A L⁴))` with `β_k L = 1.87510, 4.69409, 7.85476`, as elements
    /// are added (Hermite elements converge like `h⁴`), and the ECL defaults give the published
    /// 23.6615 Hz.
    #[test]
    fn cantilever_frequencies_converge_to_euler_bernoulli() {
        let beta = [
            1.875_104_068_711_961,
            4.694_091_132_974_175,
            7.854_757_438_237_613,
        ];
        let beam = CantileverBeam::default();
        let (area, inertia) = (
            beam.width * beam.height,
            beam.width * beam.height.powi(3) / 12.0,
        );
        let scale =
            (beam.youngs_modulus * inertia / (beam.density * area * beam.length.powi(4))).sqrt();
        let mut previous = [f64::INFINITY; 3];
        for elements in [4, 8, 16, 32] {
            let model = CantileverBeam {
                elements,
                ..beam.clone()
            }
            .build()
            .unwrap();
            let modes = linear_modes(&model).unwrap();
            for k in 0..3 {
                let exact = beta[k] * beta[k] * scale;
                let error = (modes[k].frequency - exact).abs() / exact;
                assert!(
                    error < previous[k] / 8.0 || error < 1e-9,
                    "mode {k}, {elements} el.: {error:.2e}"
                );
                previous[k] = error;
            }
        }
        assert!(previous[0] < 2e-8 && previous[2] < 5e-6, "{previous:?}");
        let ecl = linear_modes(&beam.build().unwrap()).unwrap();
        let hz = ecl[0].frequency / (2.0 * std::f64::consts::PI);
        assert!((hz - 23.6615).abs() < 1e-4, "{hz} Hz");
    }
}
