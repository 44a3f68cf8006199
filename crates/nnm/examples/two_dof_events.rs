//! Events along the two-DOF backbones (scratch while developing detection).
use std::ops::ControlFlow;

use nnm::bifurcation::{EventKind, switch_branch};
use nnm::continuation::{Settings, Start, continue_branch};
use nnm::model::two_dof;
use nnm::modes::linear_modes;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let max_step: f64 = std::env::args().nth(1).map_or(Ok(0.25), |s| s.parse())?;
    let structure = two_dof(0.5)?;
    let modes = linear_modes(&structure)?;
    let start = Start::from_linear_mode(&structure, &modes, 0, None)?;
    let settings = Settings {
        energy_max: 100.0,
        max_step,
        ..Settings::default()
    };
    let branch = continue_branch(&structure, &start, &settings, |_| ControlFlow::Continue(()))?;
    println!("{} points, {:?}", branch.points.len(), branch.stats);
    for e in &branch.events {
        println!(
            "  {:>15} after {:3}: E = {:.10e} w = {:.9} mu = ({:.6},{:.6}) x{} bracket {:.1e} trials {}",
            e.kind.name(),
            e.after,
            e.point.energy,
            e.point.frequency,
            e.multiplier.0,
            e.multiplier.1,
            e.multiplicity,
            e.arclength_uncertainty,
            e.location_steps
        );
    }
    let event = branch
        .events
        .iter()
        .find(|e| e.kind == EventKind::BranchPoint)
        .ok_or("no BP")?;
    let switch = switch_branch(&structure, &start, event, &settings, 0.05)?;
    println!(
        "singular values {:?}, null directions {}",
        switch.singular_values, switch.null_directions
    );
    let child = continue_branch(
        &structure,
        &switch.start,
        &Settings {
            max_points: 60,
            ..settings.clone()
        },
        |p| {
            println!(
                "  E {:.6e} w {:.6} stable {} z0 {:?} res {:.1e}",
                p.energy,
                p.frequency,
                p.floquet.stable,
                &p.z0[..2],
                p.relative_residual
            );
            ControlFlow::Continue(())
        },
    )?;
    println!("child: {} points, stop {}", child.points.len(), child.stop);
    for e in &child.events {
        println!("  child event {} E = {:.8e}", e.kind.name(), e.point.energy);
    }
    Ok(())
}
