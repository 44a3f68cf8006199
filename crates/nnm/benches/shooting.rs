//! Criterion benchmarks of the shooting core, each with the sensitivity Jacobian and with
//! finite differences (steps replayed), side by side: `cargo bench -p nnm`.
//! `nnm bench` prints the same comparison as one table with work counters.

use std::hint::black_box;
use std::ops::ControlFlow;

use criterion::{Criterion, criterion_group, criterion_main};
use nnm::model::{BladedDisk, Structure, duffing};
use nnm::modes::{find_mode, linear_modes};
use nnm::shooting::JacobianMethod;
use nnm::{Settings, Start, continue_branch};

const METHODS: [(JacobianMethod, &str); 2] = [
    (JacobianMethod::Sensitivity, "sensitivity"),
    (JacobianMethod::FiniteDifference, "finite-difference"),
];

fn start(structure: &Structure, label: &str) -> Start {
    let modes = linear_modes(structure).unwrap();
    let (index, _) = find_mode(&modes, label, None).unwrap();
    Start::from_linear_mode(structure, &modes, index, None).unwrap()
}

/// One shooting evaluation (residual and Jacobian) plus the monodromy, at a converged point of
/// the bladed-disk (1,5) backbone near +5% frequency.
fn residual_and_monodromy(c: &mut Criterion) {
    let disk = BladedDisk::default().build().unwrap();
    let start = start(&disk, "1,5");
    let settings = {
        let mut s = Settings::default();
        s.limits.frequency_shift_max = 0.05;
        s
    };
    let branch = continue_branch(&disk, &start, &settings, |_| ControlFlow::Continue(())).unwrap();
    let point = branch.points.last().unwrap().clone();
    let mut group = c.benchmark_group("(1,5) residual+jacobian+monodromy");
    for (jacobian, name) in METHODS {
        let mut shooting = start.shooting(&disk, &{
            let mut s = settings.clone();
            s.shooting.jacobian = jacobian;
            s
        });
        group.bench_function(name, |b| {
            b.iter(|| {
                let evaluation = shooting
                    .evaluate_with_reference(black_box(&point.unknowns), &point.z0)
                    .unwrap();
                shooting.monodromy(&evaluation).unwrap()
            })
        });
    }
    group.finish();
}

/// Whole backbones: bladed-disk (1,5) to +10%, Duffing to +50% at tolerance 1e-10.
fn backbones(c: &mut Criterion) {
    let disk = BladedDisk::default().build().unwrap();
    let oscillator = duffing(1.0, 1.0).unwrap();
    let cases = [
        (
            "(1,5) backbone to +10%",
            &disk,
            start(&disk, "1,5"),
            0.10,
            1e-8,
        ),
        (
            "Duffing backbone to +50%",
            &oscillator,
            start(&oscillator, "0"),
            0.5,
            1e-10,
        ),
    ];
    for (case, structure, start, shift, tolerance) in cases {
        let mut group = c.benchmark_group(case);
        group.sample_size(10);
        for (jacobian, name) in METHODS {
            let settings = {
                let mut s = Settings::default();
                s.limits.frequency_shift_max = shift;
                s.continuation.tolerance = tolerance;
                s.shooting.jacobian = jacobian;
                s
            };
            group.bench_function(name, |b| {
                b.iter(|| {
                    continue_branch(structure, &start, &settings, |_| ControlFlow::Continue(()))
                        .unwrap()
                })
            });
        }
        group.finish();
    }
}

criterion_group!(benches, residual_and_monodromy, backbones);
criterion_main!(benches);
