//! Duffing backbone `x'' + x + x³ = 0` computed by the library, against the exact period.
//!
//! Run: `cargo run --release -p nnm --example duffing_backbone`

use std::ops::ControlFlow;

use nnm::model::duffing;
use nnm::modes::linear_modes;
use nnm::{Settings, Start, continue_branch};
#[path = "../src/reference.rs"]
mod reference;
use reference::{duffing_amplitude, duffing_period};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (w0, alpha) = (1.0, 1.0);
    let structure = duffing(w0, alpha)?;
    let modes = linear_modes(&structure)?;
    let start = Start::from_linear_mode(&structure, &modes, 0, None)?;
    let settings = {
        let mut s = Settings::default();
        s.continuation.tolerance = 1e-9;
        s.limits.frequency_shift_max = 0.6;
        s
    };
    println!(
        "{:>12} {:>12} {:>12} {:>5}",
        "energy", "frequency", "rel. error", "iter"
    );
    let branch = continue_branch(&structure, &start, &settings, |p| {
        let exact = duffing_period(w0, alpha, duffing_amplitude(w0, alpha, p.energy));
        println!(
            "{:12.5e} {:12.8} {:12.2e} {:5}",
            p.energy,
            p.frequency,
            (p.period - exact).abs() / exact,
            p.iterations
        );
        ControlFlow::Continue(())
    })?;
    println!("stop: {}; {:?}", branch.stop, branch.stats);
    Ok(())
}
