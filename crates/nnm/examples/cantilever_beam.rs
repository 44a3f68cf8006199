//! The ECL cantilever beam (clamped, cubic spring at the tip; NLvib's example 09), first NNM
//! from the linear limit to +20% frequency with the implicit Gauss–Legendre integrator.
//!
//! Run: `cargo run --release -p nnm --example cantilever_beam [ELEMENTS]` (default 19).
//! Prints `energy  frequency_Hz  stable` per point and the work on stderr.

use std::ops::ControlFlow;
use std::time::Instant;

use nnm::integrate::IntegrationMethod;
use nnm::model::CantileverBeam;
use nnm::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let elements = std::env::args()
        .nth(1)
        .map(|a| a.parse())
        .transpose()?
        .unwrap_or(19);
    let beam = CantileverBeam {
        elements,
        ..CantileverBeam::default()
    }
    .build()?;
    let clock = Instant::now();
    let start = Start::from_mode(&beam, 0)?;
    let mut settings = Settings::default();
    settings.limits.frequency_shift_max = 0.2;
    settings.integration.integrator = IntegrationMethod::Gauss6;
    let branch = continue_branch(&beam, &start, &settings, |p: &BranchPoint| {
        println!(
            "{:.10e} {:.10} {}",
            p.energy,
            p.frequency / (2.0 * std::f64::consts::PI),
            p.floquet.stable
        );
        ControlFlow::Continue(())
    })?;
    let s = branch.stats;
    eprintln!(
        "{elements} elements ({} dofs): {} points, {} events, {} Newton iterations, {} integrations, \
         {:.0} steps per integration, {:.3} s ({})",
        2 * elements,
        s.points,
        s.events,
        s.newton_iterations,
        s.shooting.integrations,
        s.shooting.integration.steps as f64 / s.shooting.integrations as f64,
        clock.elapsed().as_secs_f64(),
        branch.stop
    );
    Ok(())
}
