//! Matrix-free shooting of a bladed disk's `(1, 0)` mode, every sector alike (docs/method.md
//! §15, eq. (76e)): its Floquet multipliers from the harmonics of the sectors against the
//! monodromy integrated by an explicit method along the same orbit, and its backbone against
//! the exact period of its Duffing reduction.

use std::ops::ControlFlow;

use nnm::floquet;
use nnm::integrate::{IntegrationMethod, Steps, Tolerances};
use nnm::model::{BladedDisk, Block, MechanicalSystem, Structure};
use nnm::modes::{add_labelled_mode, find_mode, linear_modes};
use nnm::shooting::Formulation;
use nnm::{Branch, Mat, Settings, Start, continue_branch};
#[path = "../src/reference.rs"]
mod reference;
use reference::duffing_period;

fn disk(sectors: usize) -> Structure {
    BladedDisk {
        sectors,
        ..BladedDisk::default()
    }
    .build()
    .unwrap()
}

/// The `(1, 0)` backbone to `shift` in frequency, matrix-free, in the full space of unknowns.
fn one_zero(system: &Structure, shift: f64) -> Branch {
    let mut modes = linear_modes(system).unwrap();
    add_labelled_mode(system, &mut modes, "1,0", None).unwrap();
    let (index, _) = find_mode(&modes, "1,0", None).unwrap();
    let mut settings = Settings::default();
    settings.shooting.formulation = Formulation::MatrixFree;
    settings.start.symmetry = false;
    settings.stability.events = false;
    settings.limits.frequency_shift_max = shift;
    let start = Start::for_branch(system, &modes, index, None, &settings).unwrap();
    continue_branch(system, &start, &settings, |_| ControlFlow::Continue(())).unwrap()
}

/// On the paper's 30-sector disk (60 dofs), every one of the 120 multipliers of the
/// matrix-free points, found from four impulse responses, is an eigenvalue of the monodromy
/// that DOP853 integrates with its 120 sensitivities along the same orbit (an explicit
/// against an implicit integration), to 1e-7 (1e-5 near +1); and the verdicts agree.
#[test]
fn sector_harmonics_give_the_monodromy_s_multipliers() {
    let system = disk(30);
    let branch = one_zero(&system, 0.1);
    assert!(branch.points.len() >= 5);
    let n2 = 2 * system.dofs();
    let identity: Vec<f64> = (0..n2 * n2)
        .map(|k| if k % (n2 + 1) == 0 { 1.0 } else { 0.0 })
        .collect();
    for point in branch.points.iter().step_by(3) {
        let multipliers = &point.floquet.multipliers;
        assert_eq!(multipliers.len(), n2);
        let scale = point.z0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let tolerances = Tolerances {
            relative: 1e-13,
            absolute: 1e-13 * scale,
            velocity_scale: point.frequency,
        };
        let mut integrator = IntegrationMethod::Dop853.integrator(&system, tolerances);
        let flow = integrator
            .flow(
                &point.z0,
                point.period,
                Some(Block::new(&identity, n2, n2, n2)),
                Steps::Adaptive { first_step: None },
            )
            .unwrap();
        let monodromy = Mat::from_fn(n2, n2, |r, c| flow.sensitivity[c * n2 + r]);
        let explicit = floquet::analyse(&monodromy, 1e-6).unwrap();
        let distance = |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).hypot(a.1 - b.1);
        for &mu in multipliers {
            let nearest = explicit
                .multipliers
                .iter()
                .map(|&nu| distance(mu, nu))
                .fold(f64::INFINITY, f64::min);
            // Near +1 sit the rigid rotation's Jordan block and the trivial pair's: defective
            // eigenvalues, split by the square root of any error in the matrix.
            let tolerance = if distance(mu, (1.0, 0.0)) < 1e-3 {
                1e-5
            } else {
                1e-7
            };
            assert!(
                nearest < tolerance,
                "E = {}: {mu:?} is {nearest:e} from the explicit spectrum",
                point.energy
            );
        }
        assert_eq!(
            point.floquet.stable, explicit.stable,
            "E = {}",
            point.energy
        );
    }
}

/// Every sector of the `(1, 0)` orbit moves alike and the disk ring is not stretched, so the
/// blade's motion relative to its disk, `y`, is the Duffing oscillator
/// `μ y'' + k y + k_nl y³ = 0`, `1/μ = 1/m + 1/M`: on 200 sectors (400 dofs, full space,
/// matrix-free) every point's frequency is its exact elliptic one to 1e-8, and every point
/// is stable with all 800 multipliers computed.
#[test]
fn the_1_0_backbone_of_200_sectors_is_its_duffing_oscillator() {
    let system = disk(200);
    let p = BladedDisk::default();
    let reduced_mass = 1.0 / (1.0 / p.blade_mass + 1.0 / p.disk_mass);
    let natural = (p.blade_stiffness / reduced_mass).sqrt();
    let cubic = p.cubic / reduced_mass;
    let branch = one_zero(&system, 0.2);
    let last = branch.points.last().unwrap();
    assert!(
        last.frequency / natural > 1.199,
        "{}",
        last.frequency / natural
    );
    for point in &branch.points {
        let amplitude = (point.z0[1] - point.z0[0]).abs();
        let exact = 2.0 * std::f64::consts::PI / duffing_period(natural, cubic, amplitude);
        assert!(
            (point.frequency / exact - 1.0).abs() < 1e-8,
            "E = {}: {} vs {exact}",
            point.energy,
            point.frequency
        );
        assert!(
            point.floquet.stable,
            "E = {}: {:?}",
            point.energy,
            point.floquet.pairs.first()
        );
        assert_eq!(point.floquet.multipliers.len(), 2 * system.dofs());
    }
}
