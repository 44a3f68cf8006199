//! The 3:1 internal resonance of the bladed disk (docs/method.md §11): the (0,6) backbone,
//! continued past its fold, travels along a tongue on which a third harmonic grows until the
//! fundamental vanishes — where it meets the (1,12) family at a third of its period.
//!
//! Run: `cargo run --release -p nnm --example tongue [-- MAX_STEP]`

use std::ops::ControlFlow;
use std::time::Instant;

use nnm::analysis::{harmonic_amplitudes, sample_motion};
use nnm::model::{BladedDisk, MechanicalSystem};
use nnm::modes::{find_mode, linear_modes};
use nnm::{Settings, Start, continue_branch};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let max_step: f64 = std::env::args().nth(1).map_or(Ok(0.25), |s| s.parse())?;
    let structure = BladedDisk::default().build()?;
    let modes = linear_modes(&structure)?;
    let (index, _) = find_mode(&modes, "0,6", None).ok_or("no (0,6)")?;
    let start = Start::from_linear_mode(&structure, &modes, index, None)?;
    let settings = {
        let mut s = Settings::default();
        s.limits.max_points = 400;
        s.continuation.max_step = max_step;
        s
    };
    let n = structure.dofs();
    let clock = Instant::now();
    let mut folded = false;
    let mut previous_energy = 0.0;
    let mut previous_a1 = f64::INFINITY;
    println!(
        "{:>4} {:>12} {:>12} {:>10} {:>10} {:>9}",
        "pt", "energy", "frequency", "A1", "A3", "max|mu|"
    );
    let branch = continue_branch(&structure, &start, &settings, |p| {
        let states = sample_motion(&structure, &p.z0, p.period, 128, 1e-10).expect("sampling");
        let h = harmonic_amplitudes(&states, n, 3);
        println!(
            "{:4} {:12.5e} {:12.8} {:10.3e} {:10.3e} {:9.5}",
            p.index, p.energy, p.frequency, h[0], h[2], p.floquet.max_modulus
        );
        folded |= p.energy < previous_energy;
        previous_energy = p.energy;
        // Past the fold, the fundamental falls to zero at the junction with (1,12) and grows
        // again beyond it: stop once it has passed its minimum.
        let passed_junction = folded && previous_a1 < 0.05 * h[2] && h[0] > previous_a1;
        previous_a1 = h[0];
        if passed_junction {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })?;
    println!(
        "{} points, stop: {}, {:.2?}",
        branch.points.len(),
        branch.stop,
        clock.elapsed()
    );
    Ok(())
}
