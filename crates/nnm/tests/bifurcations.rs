//! Bifurcations along NNM branches: events located independently of the step size,
//! checked against an independent monodromy, and a switched branch that is a different family.
//!
//! Run in the release profile: `cargo test --release -p nnm --test bifurcations -- --nocapture`
//! (the figures are printed with `eprintln!`).

use std::ops::ControlFlow;

use nnm::Mat;
use nnm::bifurcation::{Event, EventKind, switch_branch};
use nnm::floquet;
use nnm::integrate::{DOP853, Integrator, RungeKutta, Steps, Tolerances};
use nnm::model::{BladedDisk, PolynomialSpring, Structure, duffing, two_dof};
use nnm::modes::{StandingWave, find_mode, linear_modes};
use nnm::shooting::JacobianMethod;
use nnm::{Branch, Settings, Start, continue_branch};

fn branch(structure: &Structure, start: &Start, settings: &Settings) -> Branch {
    continue_branch(structure, start, settings, |_| ControlFlow::Continue(())).unwrap()
}

/// The default bladed disk and the start of its cos standing wave `label`.
fn disk_and_start(label: &str) -> (Structure, Start) {
    let disk = BladedDisk::default().build().unwrap();
    let modes = linear_modes(&disk).unwrap();
    let (index, _) = find_mode(&modes, label, Some(StandingWave::Cos)).unwrap();
    let start = Start::from_linear_mode(&disk, &modes, index, None).unwrap();
    (disk, start)
}

fn of_kind(branch: &Branch, kind: EventKind) -> Vec<&Event> {
    branch.events.iter().filter(|e| e.kind == kind).collect()
}

fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// The pair invariant `σ = μ + 1/μ` nearest `target` (±2).
fn sigma_nearest(f: &floquet::Floquet, target: f64) -> f64 {
    f.pairs
        .iter()
        .map(|p| p.trace().0)
        .min_by(|a, b| (a - target).abs().total_cmp(&(b - target).abs()))
        .expect("non-trivial multipliers")
}

/// How far in energy (relative) the located event is from where an independent monodromy
/// puts the crossing: `|σ_fd − target| / |dσ/dE| / E`, the slope taken from the branch points
/// on either side of the event.
fn energy_offset(branch: &Branch, event: &Event, sigma_fd: f64, target: f64) -> f64 {
    let (a, b) = (&branch.points[event.after], &branch.points[event.after + 1]);
    let slope = (sigma_nearest(&b.floquet, target) - sigma_nearest(&a.floquet, target))
        / (b.energy - a.energy);
    (sigma_fd - target).abs() / slope.abs() / event.point.energy
}

/// The in-phase backbone of the two-DOF system to E = 100 at a given largest step.
fn in_phase(max_step: f64) -> (Structure, Start, Settings, Branch) {
    let structure = two_dof(0.5).unwrap();
    let modes = linear_modes(&structure).unwrap();
    let start = Start::from_linear_mode(&structure, &modes, 0, None).unwrap();
    let settings = {
        let mut s = Settings::default();
        s.limits.energy_max = 100.0;
        s.continuation.max_step = max_step;
        s
    };
    let b = branch(&structure, &start, &settings);
    (structure, start, settings, b)
}

/// docs/method.md §12: the in-phase branch loses stability at a branch point near E = 41. Its
/// location must not depend on the step that happened to bracket it, and the critical
/// multiplier must sit at +1 in an independently computed (finite-difference, full-period)
/// monodromy at the located point.
#[test]
fn two_dof_branch_point_is_located_independently_of_the_step() {
    let (structure, start, settings, coarse) = in_phase(0.25);
    let (_, _, _, fine) = in_phase(0.05);
    let (a, b) = (
        of_kind(&coarse, EventKind::BranchPoint),
        of_kind(&fine, EventKind::BranchPoint),
    );
    assert_eq!((a.len(), b.len()), (1, 1), "one branch point each");
    let (a, b) = (a[0], b[0]);
    let gap = relative(a.point.energy, b.point.energy);
    eprintln!(
        "two-DOF branch point: E = {:.10} (max step 0.25, {} points) vs {:.10} (0.05, {} points), \
         relative gap {gap:.1e}",
        a.point.energy,
        coarse.points.len(),
        b.point.energy,
        fine.points.len()
    );
    assert!(gap < 1e-6, "located energies differ by {gap:.1e}");
    assert!(a.converged && b.converged);
    // The same branch point on a different problem: full period, velocities among the
    // unknowns (flow-orthogonal phase), where the crossing family is representable.
    let general = branch(&structure, &start, &{
        let mut s = settings.clone();
        s.shooting.phase = nnm::shooting::PhaseCondition::FlowOrthogonal;
        s
    });
    let c = of_kind(&general, EventKind::BranchPoint);
    assert_eq!(c.len(), 1);
    let gap = relative(c[0].point.energy, a.point.energy);
    eprintln!(
        "  full-period, flow-orthogonal problem: E = {:.10}, {gap:.1e} away",
        c[0].point.energy
    );
    assert!(gap < 1e-6);
    assert!((39.6..41.3).contains(&a.point.energy));
    // Stable before, unstable after, on both branches.
    for (branch, event) in [(&coarse, a), (&fine, b)] {
        assert!(branch.points[event.after].floquet.stable);
        assert!(!branch.points[event.after + 1].floquet.stable);
    }
    // Independent check: finite-difference monodromy over the full period.
    let fd_settings = {
        let mut s = settings.clone();
        s.shooting.jacobian = JacobianMethod::FiniteDifference;
        s.shooting.half_period = false;
        s
    };
    let mut shooting = start.shooting(&structure, &fd_settings);
    let u = shooting.unknowns_from_state(&a.point.z0, a.point.period);
    let evaluation = shooting.evaluate_with_reference(&u, &a.point.z0).unwrap();
    assert!(evaluation.relative_residual < 1e-7);
    let monodromy = shooting.monodromy(&evaluation).unwrap();
    // All four multipliers sit near +1 here: deflate the trivial pair along the flow and the
    // family's direction rather than guess it.
    let flow = shooting.modal_coordinates(&shooting.field(&a.point.z0));
    let family = shooting.modal_coordinates(&a.state_tangent);
    let f = floquet::analyse_deflated(
        &monodromy,
        [&flow, &family],
        settings.stability.stability_tolerance,
    )
    .unwrap();
    let sigma = sigma_nearest(&f, 2.0);
    let offset = energy_offset(&coarse, a, sigma, 2.0);
    eprintln!(
        "  finite-difference monodromy at the located point: |σ - 2| = {:.1e}, i.e. the \
         crossing is {offset:.1e} (relative energy) away",
        (sigma - 2.0).abs()
    );
    assert!(offset < 1e-6, "{offset:.1e}");
}

/// The state after `duration` from `z0`, integrated independently of the shooting (tight
/// tolerance, fresh adaptive steps).
fn state_after(structure: &Structure, z0: &[f64], duration: f64) -> Vec<f64> {
    let tolerances = Tolerances {
        relative: 1e-12,
        absolute: 1e-12,
        velocity_scale: 1.0,
    };
    RungeKutta::new(structure, &DOP853, tolerances)
        .flow(z0, duration, None, Steps::Adaptive { first_step: None })
        .unwrap()
        .z
}

/// `‖z(T/2) + z0‖ / ‖z0‖`: zero for a motion with the half-wave symmetry of the in-phase
/// backbone.
fn half_wave_asymmetry(structure: &Structure, z0: &[f64], period: f64) -> f64 {
    let half = state_after(structure, z0, 0.5 * period);
    let sum: Vec<f64> = half.iter().zip(z0).map(|(a, b)| a + b).collect();
    norm(&sum) / norm(z0)
}

/// switching at the two-DOF branch point gives converged motions of another family:
/// they break the half-wave symmetry that every motion of the parent has, and they lie off
/// the parent's frequency-energy curve.
#[test]
fn switched_branch_is_a_new_family() {
    let (structure, start, settings, parent) = in_phase(0.25);
    let event = of_kind(&parent, EventKind::BranchPoint)[0];
    let switch = switch_branch(&structure, &start, event, &settings, 0.05, 0).unwrap();
    eprintln!(
        "switch: singular values {:?}, phase {:?}",
        switch.singular_values, switch.start.phase
    );
    assert_eq!(switch.null_directions, 1);
    let child = branch(&structure, &switch.start, &{
        let mut s = settings.clone();
        s.limits.max_points = 12;
        s
    });
    assert!(child.points.len() >= 5, "{} points", child.points.len());
    // The parent's frequency at energy E, interpolated in log E.
    let parent_frequency = |e: f64| {
        let w = parent
            .points
            .windows(2)
            .find(|w| w[0].energy <= e && e <= w[1].energy)
            .expect("within the parent's range");
        let t = (e.ln() - w[0].energy.ln()) / (w[1].energy.ln() - w[0].energy.ln());
        w[0].frequency + t * (w[1].frequency - w[0].frequency)
    };
    let parent_asymmetry = half_wave_asymmetry(&structure, &event.point.z0, event.point.period);
    eprintln!("  parent at the event: half-wave asymmetry {parent_asymmetry:.1e}");
    assert!(parent_asymmetry < 1e-6);
    for p in &child.points {
        assert!(p.relative_residual < settings.continuation.tolerance);
        let asymmetry = half_wave_asymmetry(&structure, &p.z0, p.period);
        let off = p.energy < 100.0 && p.index > 0;
        let gap = if off {
            relative(p.frequency, parent_frequency(p.energy))
        } else {
            f64::NAN
        };
        eprintln!(
            "  child point {}: E = {:.4}, f = {:.6}, half-wave asymmetry {asymmetry:.2e}, \
             frequency off the parent by {gap:.1e}",
            p.index, p.energy, p.frequency
        );
        assert!(asymmetry > 1e-3, "point {} is half-wave symmetric", p.index);
        if off {
            assert!(gap > 1e-4, "point {} lies on the parent's curve", p.index);
        }
    }
}

/// No events where there are none: the Duffing oscillator has no non-trivial multipliers and
/// its energy grows monotonically along the backbone.
#[test]
fn duffing_backbone_has_no_events() {
    let structure = duffing(1.0, 1.0).unwrap();
    let modes = linear_modes(&structure).unwrap();
    let start = Start::from_linear_mode(&structure, &modes, 0, None).unwrap();
    let settings = {
        let mut s = Settings::default();
        s.limits.frequency_shift_max = 0.5;
        s
    };
    let b = branch(&structure, &start, &settings);
    assert!(b.points.len() > 10);
    assert!(b.events.is_empty(), "{:?}", b.events);
}

/// the (1,14) backbone's S-shaped fold before it localizes, and the Krein collisions
/// where it loses and regains stability, located to better than 1e-6 in energy whatever the
/// step.
#[test]
fn bladed_disk_1_14_folds_and_krein_collisions_do_not_depend_on_the_step() {
    let (structure, start) = disk_and_start("1,14");
    let run = |max_step: f64| {
        branch(&structure, &start, &{
            let mut s = Settings::default();
            s.limits.frequency_shift_max = 0.15;
            s.continuation.max_step = max_step;
            s
        })
    };
    let (coarse, fine) = (run(0.25), run(0.15));
    for kind in [EventKind::Fold, EventKind::NeimarkSacker] {
        let converged = |b: &Branch| -> Vec<f64> {
            of_kind(b, kind)
                .iter()
                .filter(|e| e.converged)
                .map(|e| e.point.energy)
                .collect()
        };
        let (a, b) = (converged(&coarse), converged(&fine));
        eprintln!(
            "(1,14) {}: {a:.9?} (max step 0.25) vs {b:.9?} (0.15)",
            kind.name()
        );
        // Every event of the coarse run is found again by the fine one at the same energy.
        // (A finer step may also resolve events that a coarse step hides: two collisions
        // within one step, one making a quadruplet and one undoing it, change no count.)
        for x in &a {
            let nearest = b
                .iter()
                .map(|y| relative(*x, *y))
                .fold(f64::INFINITY, f64::min);
            assert!(
                nearest < 1e-6,
                "{} at E = {x} not found again ({nearest:.1e})",
                kind.name()
            );
        }
        if kind == EventKind::Fold {
            // The S: up to a maximum of the energy, back down, up again, around E ≈ 8.6.
            assert_eq!((a.len(), b.len()), (2, 2));
            assert!(a[0] > a[1] && (8.0..9.5).contains(&a[0]));
        } else {
            assert!(a.len() >= 3);
        }
    }
}

/// A system with a period doubling: oscillator 0 (ω = 1, hardening) drives oscillator 1
/// (ω = 0.55) through a quadratic spring between them, whose tangent pumps oscillator 1 at
/// the motion's own frequency — a Mathieu equation whose principal instability tongue sits
/// where 0.55 is half the frequency, so a multiplier pair passes -1.
fn parametric_pair() -> Structure {
    Structure::new(
        Mat::<f64>::identity(2, 2),
        Mat::from_fn(2, 2, |i, j| match (i, j) {
            (0, 0) => 1.0,
            (1, 1) => 0.3025,
            _ => 0.0,
        }),
        vec![
            Box::new(PolynomialSpring::cubic(0, None, 1.0)),
            Box::new(PolynomialSpring::new(0, Some(1), 0.3, 2)),
        ],
    )
    .unwrap()
}

/// a period doubling located independently of the step, confirmed by an independent
/// (finite-difference) monodromy, and the switched branch: converged motions of twice the
/// period that do not repeat after one parent period.
#[test]
fn period_doubling_is_located_and_switched() {
    let structure = parametric_pair();
    let modes = linear_modes(&structure).unwrap();
    let start = Start::from_linear_mode(&structure, &modes, 1, None).unwrap();
    let run = |max_step: f64| {
        let settings = {
            let mut s = Settings::default();
            s.limits.energy_max = 0.2;
            s.continuation.max_step = max_step;
            s
        };
        let b = branch(&structure, &start, &settings);
        (settings, b)
    };
    let ((settings, coarse), (_, fine)) = (run(0.25), run(0.1));
    let (a, b) = (
        of_kind(&coarse, EventKind::PeriodDoubling),
        of_kind(&fine, EventKind::PeriodDoubling),
    );
    assert_eq!((a.len(), b.len()), (1, 1));
    let (a, b) = (a[0], b[0]);
    let gap = relative(a.point.energy, b.point.energy);
    eprintln!(
        "period doubling: E = {:.12} (max step 0.25) vs {:.12} (0.1), gap {gap:.1e}, f = {:.9}",
        a.point.energy, b.point.energy, a.point.frequency
    );
    assert!(gap < 1e-6);
    // Independent check: the finite-difference monodromy has a pair at -1 there.
    let fd = {
        let mut s = settings.clone();
        s.shooting.jacobian = JacobianMethod::FiniteDifference;
        s
    };
    let mut shooting = start.shooting(&structure, &fd);
    let u = shooting.unknowns_from_state(&a.point.z0, a.point.period);
    let evaluation = shooting.evaluate_with_reference(&u, &a.point.z0).unwrap();
    let f = floquet::analyse(&shooting.monodromy(&evaluation).unwrap(), 1e-4).unwrap();
    let sigma = sigma_nearest(&f, -2.0);
    let offset = energy_offset(&coarse, a, sigma, -2.0);
    eprintln!(
        "  finite-difference monodromy: |σ + 2| = {:.1e}, crossing {offset:.1e} (relative \
         energy) away",
        (sigma + 2.0).abs()
    );
    assert!(offset < 1e-6, "{offset:.1e}");

    let switch = switch_branch(&structure, &start, a, &settings, 0.05, 0).unwrap();
    let child = branch(&structure, &switch.start, &{
        let mut s = settings.clone();
        s.limits.max_points = 10;
        s.limits.energy_max = f64::INFINITY;
        s
    });
    assert!(child.points.len() >= 5);
    for p in &child.points {
        assert!(p.relative_residual < settings.continuation.tolerance);
        // Twice the parent's period near the event, ...
        let ratio = p.period / a.point.period;
        // ... and after one parent period the motion is elsewhere.
        let half = state_after(&structure, &p.z0, 0.5 * p.period);
        let mismatch: Vec<f64> = half.iter().zip(&p.z0).map(|(a, b)| a - b).collect();
        let repeat = norm(&mismatch) / norm(&p.z0);
        eprintln!(
            "  child point {}: E = {:.6}, period / parent period = {ratio:.6}, \
             ‖z(T/2) - z0‖/‖z0‖ = {repeat:.2e}",
            p.index, p.energy
        );
        assert!((1.8..2.2).contains(&ratio));
        assert!(
            repeat > 1e-3,
            "point {} repeats after half its period",
            p.index
        );
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The events of a branch, as `(kind, energy)`, at several largest steps and tolerances.
fn event_lists(
    structure: &Structure,
    start: &Start,
    base: &Settings,
) -> Vec<((f64, f64), Vec<(EventKind, f64, bool)>)> {
    let mut out = Vec::new();
    for max_step in [base.continuation.max_step, 0.05, 0.02] {
        for tolerance in [1e-8, 1e-10] {
            let mut settings = base.clone();
            settings.continuation.max_step = max_step;
            settings.continuation.tolerance = tolerance;
            let b = branch(structure, start, &settings);
            let events = b
                .events
                .iter()
                .map(|e| (e.kind, e.point.energy, e.converged))
                .collect::<Vec<_>>();
            eprintln!("max_step {max_step}, tolerance {tolerance:e}: {events:?}");
            out.push(((max_step, tolerance), events));
        }
    }
    out
}

/// Whatever the largest step (the default 0.25, 0.05, 0.02) and tolerance (1e-8, 1e-10), the
/// same events at the same energies, each located (`converged`): the bladed disk's (1,14)
/// family to E = 9 — three Krein collisions, two folds of its S-shaped turn and a collision
/// between them (coarse steps without the located refinement put the second collision at
/// E = 5.90 instead of 6.46, and add collisions that finer steps do not find) — and the two-DOF in-phase
/// family to E = 100. The energies agree within 1e-6 (relative) across settings; the (1,14)
/// ones are those of the paper's study at fine steps.
#[test]
fn events_do_not_depend_on_the_step_or_the_tolerance() {
    let (disk, start) = disk_and_start("1,14");
    let mut settings = Settings::default();
    settings.limits.energy_max = 9.0;
    let expected = [
        (EventKind::NeimarkSacker, 3.335098),
        (EventKind::NeimarkSacker, 6.463673),
        (EventKind::NeimarkSacker, 8.534340),
        (EventKind::Fold, 8.653833),
        (EventKind::Fold, 8.513630),
        (EventKind::NeimarkSacker, 8.521180),
    ];
    let lists = event_lists(&disk, &start, &settings);
    for (setting, events) in &lists {
        assert_eq!(events.len(), expected.len(), "{setting:?}: {events:?}");
        for ((kind, energy, converged), (want, at)) in events.iter().zip(expected) {
            assert_eq!(*kind, want, "{setting:?}");
            assert!(
                relative(*energy, at) < 1e-6,
                "{setting:?}: {kind:?} at {energy}, not {at}"
            );
            assert!(converged, "{setting:?}: {kind:?} at {energy} not located");
        }
    }
    let reference = &lists[0].1;
    for (setting, events) in &lists[1..] {
        for (a, b) in events.iter().zip(reference) {
            assert!(
                relative(a.1, b.1) < 1e-6,
                "{setting:?}: {} against {}",
                a.1,
                b.1
            );
        }
    }

    let structure = two_dof(0.5).unwrap();
    let modes = linear_modes(&structure).unwrap();
    let start = Start::from_linear_mode(&structure, &modes, 0, None).unwrap();
    let mut settings = Settings::default();
    settings.limits.energy_max = 100.0;
    let lists = event_lists(&structure, &start, &settings);
    let reference = &lists[0].1;
    assert!(!reference.is_empty());
    for (setting, events) in &lists {
        assert_eq!(events.len(), reference.len(), "{setting:?}: {events:?}");
        for (a, b) in events.iter().zip(reference) {
            assert_eq!(a.0, b.0, "{setting:?}");
            assert!(a.2, "{setting:?}: {a:?} not located");
            assert!(
                relative(a.1, b.1) < 1e-6,
                "{setting:?}: {} against {}",
                a.1,
                b.1
            );
        }
    }
}

/// `invariant_step` bounds how far the pair invariants move between consecutive points (the
/// cap extrapolates the last step's rate, so a step may exceed it where the motion speeds up:
/// allowed 2×), where the curve alone lets a step move them by several times the bound; and
/// the bounded branch, whose steps resolve more, finds at least the events the unbounded one
/// does on the bladed disk's (1,8) family to E = 40 (docs/method.md eq. (44c)).
#[test]
fn invariant_step_bounds_how_far_the_multipliers_move_in_a_step() {
    let (disk, start) = disk_and_start("1,8");
    let run = |bound: f64| {
        let mut settings = Settings::default();
        settings.limits.energy_max = 40.0;
        settings.stability.invariant_step = bound;
        branch(&disk, &start, &settings)
    };
    let largest_shift = |b: &Branch| {
        let shifts: Vec<f64> = (b.points.windows(2))
            .filter_map(|w| w[0].floquet.invariant_shift(&w[1].floquet))
            .collect();
        // Every two consecutive points compare (dense analyses, all pairs).
        assert_eq!(shifts.len(), b.points.len() - 1);
        shifts.into_iter().fold(0.0, f64::max)
    };
    let bound = 0.05;
    let (free, bounded) = (run(f64::INFINITY), run(bound));
    let (a, b) = (largest_shift(&free), largest_shift(&bounded));
    eprintln!(
        "(1,8) to E = 40: unbounded {} points, largest shift {a:.3}, {} events; bounded by {bound}: {} points, largest shift {b:.3}, {} events",
        free.points.len(),
        free.events.len(),
        bounded.points.len(),
        bounded.events.len()
    );
    assert!(
        a > 3.0 * bound,
        "the unbounded branch moved its invariants by {a} at most"
    );
    assert!(b <= 2.0 * bound, "a bounded step moved an invariant by {b}");
    assert!(bounded.events.len() >= free.events.len());
}
