//! A custom system in a few lines: the simple pendulum `θ'' + sin θ = 0`, which is neither
//! polynomial nor built from M, K and springs. Its NNM is continued from the linear mode to
//! an amplitude of 3 rad, close to the separatrix (θ0 = π), where the period grows without
//! bound. Prints one line per point: `θ0 T` (rad, s).
//!
//! Run: `cargo run --release -p nnm --example pendulum`
//! (`crates/nnm/tests/pendulum.rs` checks every point against `T = 4 K(sin²(θ0/2))`.)

use nnm::continuation::NoEvents;
use nnm::prelude::*;

/// `M θ'' + f_int(θ) = 0` with `M = 1`, `f_int = sin θ`, `K_t = cos θ`, `V = 1 - cos θ`.
pub struct Pendulum {
    mass: Mass,
}

impl MechanicalSystem for Pendulum {
    fn dofs(&self) -> usize {
        1
    }
    fn mass(&self) -> &dyn MassOperator {
        &self.mass
    }
    fn internal_force(&self, x: &[f64], f: &mut [f64]) {
        f[0] = x[0].sin();
    }
    fn tangent_stiffness(&self, x: &[f64], dx: Block<'_>, mut out: BlockMut<'_>) {
        for c in 0..dx.cols {
            out.col_mut(c)[0] = x[0].cos() * dx.col(c)[0];
        }
    }
    fn potential_energy(&self, x: &[f64]) -> f64 {
        1.0 - x[0].cos()
    }
}

/// The backbone `(θ0, T)` from the linear limit until `θ0 ≥ amplitude_max`.
pub fn backbone(amplitude_max: f64) -> Result<Vec<(f64, f64)>, Box<dyn std::error::Error>> {
    let pendulum = Pendulum {
        mass: Mass::identity(1),
    };
    let start = Start::from_mode(&pendulum, 0)?;
    let mut settings = Settings::default();
    settings.continuation.tolerance = 1e-11;
    settings.integration.integration_factor = 1e-2;
    let mut shooting = start.shooting(&pendulum, &settings);
    let (u0, pin) = start.first_guess(&shooting);
    let continuation =
        Continuation::new(&mut shooting, u0, &pin, &settings.continuation, NoEvents)?;
    let mut points = Vec::new();
    for item in continuation {
        // Without an event detector every item is a point.
        let Item::Point(point) = item?;
        points.push((point.z0[0], point.period));
        if point.z0[0] >= amplitude_max {
            break;
        }
    }
    Ok(points)
}

#[allow(dead_code)] // the test includes this file as a module
fn main() -> Result<(), Box<dyn std::error::Error>> {
    for (amplitude, period) in backbone(3.0)? {
        println!("{amplitude:.16e} {period:.16e}");
    }
    Ok(())
}
