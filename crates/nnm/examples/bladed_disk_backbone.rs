//! One backbone of the paper's bladed disk, printed point by point.
//!
//! Run: `cargo run --release -p nnm --example bladed_disk_backbone -- 1,5 0.15 [ENERGY_MAX]`
//! (mode label `n,d`, the relative frequency rise at which to stop, optionally an energy cap).

use std::ops::ControlFlow;
use std::time::Instant;

use nnm::model::BladedDisk;
use nnm::modes::{find_mode, linear_modes};
use nnm::{Settings, Start, continue_branch};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let label = args.next().unwrap_or_else(|| "1,5".into());
    let shift: f64 = args.next().map_or(Ok(0.15), |s| s.parse())?;
    let energy_max: f64 = args.next().map_or(Ok(f64::INFINITY), |s| s.parse())?;
    let structure = BladedDisk::default().build()?;
    let modes = linear_modes(&structure)?;
    let (index, mode) = find_mode(&modes, &label, None).ok_or("unknown mode label")?;
    let start = Start::from_linear_mode(&structure, &modes, index, None)?;
    let settings = {
        let mut s = Settings::default();
        s.limits.frequency_shift_max = shift;
        s.limits.energy_max = energy_max;
        s
    };
    let clock = Instant::now();
    println!(
        "mode ({label}), linear frequency {:.6} rad/s",
        mode.frequency
    );
    println!(
        "{:>12} {:>12} {:>8} {:>10} {:>5}",
        "energy", "frequency", "shift", "max|mu|", "iter"
    );
    let branch = continue_branch(&structure, &start, &settings, |p| {
        println!(
            "{:12.5e} {:12.8} {:7.3}% {:10.6} {:5}",
            p.energy,
            p.frequency,
            100.0 * (p.frequency / mode.frequency - 1.0),
            p.floquet.max_modulus,
            p.iterations
        );
        ControlFlow::Continue(())
    })?;
    for e in &branch.events {
        println!(
            "event {:>15} after point {:3}: E = {:.9e}, w = {:.9} rad/s, mu = ({:.6}, {:.6}) x{}, \
             bracket {:.1e} in {} trials, converged {}",
            e.kind.name(),
            e.after,
            e.point.energy,
            e.point.frequency,
            e.multiplier.0,
            e.multiplier.1,
            e.multiplicity,
            e.arclength_uncertainty,
            e.location_steps,
            e.converged
        );
    }
    println!("stop: {} after {:.2?}", branch.stop, clock.elapsed());
    println!("{:?}", branch.stats);
    Ok(())
}
