//! Travelling-wave NNMs of the bladed disk (docs/method.md §17), each checked by something
//! the reduced shooting does not impose: the exact rotating wave in the linear limit, the
//! periodicity over the whole period (only `T/q` is shot), the same orbit found again by
//! full-period shooting without the symmetry, and the pattern's invariance under every
//! sector shift combined with its time shift (not only the one shot with).

use std::ops::ControlFlow;

use nnm::analysis::sample_motion;
use nnm::model::{BladedDisk, Structure};
use nnm::modes::{LinearMode, StandingWave, find_mode, linear_modes};
use nnm::shooting::{PhaseCondition, Travel};
use nnm::{Branch, MechanicalSystem, Settings, Start, continue_branch};

fn disk() -> (Structure, Vec<LinearMode>) {
    let disk = BladedDisk::default().build().unwrap();
    let modes = linear_modes(&disk).unwrap();
    (disk, modes)
}

fn travelling(disk: &Structure, modes: &[LinearMode], label: &str, shift: f64) -> Branch {
    let (index, _) = find_mode(modes, label, Some(StandingWave::Cos)).unwrap();
    let start = Start::travelling_wave(disk, modes, index, Travel::Forward, None).unwrap();
    let mut settings = Settings::default();
    settings.limits.frequency_shift_max = shift;
    settings.stability.events = false;
    continue_branch(disk, &start, &settings, |_| ControlFlow::Continue(())).unwrap()
}

fn norm(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum::<f64>().sqrt()
}

fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// The mode shapes of the pair (cos, sin) of `label`.
fn pair<'a>(modes: &'a [LinearMode], label: &str) -> (&'a LinearMode, &'a LinearMode) {
    let cos = find_mode(modes, label, Some(StandingWave::Cos)).unwrap().1;
    let sin = find_mode(modes, label, Some(StandingWave::Sin)).unwrap().1;
    (cos, sin)
}

/// At the first point the motion is the linear rotating wave `a (φ_c cos ωt + φ_s sin ωt)`
/// to the size of the nonlinear correction, at the linear frequency.
#[test]
fn the_first_point_is_the_linear_rotating_wave() {
    let (disk, modes) = disk();
    let branch = travelling(&disk, &modes, "1,5", 0.01);
    let first = &branch.points[0];
    let (cos, sin) = pair(&modes, "1,5");
    let omega = cos.frequency;
    assert!(
        relative(first.frequency, omega) < 1e-4,
        "{}",
        first.frequency
    );
    let n = disk.dofs();
    let states = sample_motion(&disk, &first.z0, first.period, 16, 1e-12).unwrap();
    let a = norm(&first.z0[..n]) / norm(&cos.shape);
    let scale = a * norm(&cos.shape);
    for (k, z) in states.iter().enumerate() {
        let t = first.period * k as f64 / 16.0;
        let (c, s) = ((omega * t).cos(), (omega * t).sin());
        let error = (0..n)
            .map(|i| (z[i] - a * (c * cos.shape[i] + s * sin.shape[i])).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(error < 1e-3 * scale, "t = {t}: {error:e} against {scale:e}");
    }
}

/// Along the (1,5) and (1,14) branches to +5%: every point periodic over its whole period
/// (`full_period_residual`, integrated apart from the `T/q` shot), and at the last point each
/// sector shift `k` maps the motion onto itself `k d T/N` later (sampled over the period:
/// the shot symmetry is one of these; the others follow only if the orbit is the wave).
#[test]
fn the_wave_is_periodic_and_turns_at_constant_shape() {
    let (disk, modes) = disk();
    for (label, diameters) in [("1,5", 5), ("1,14", 14)] {
        let branch = travelling(&disk, &modes, label, 0.05);
        assert!(branch.points.len() > 5, "{label}");
        let settings = Settings::default();
        for p in &branch.points {
            assert!(
                p.full_period_residual < 100.0 * settings.continuation.tolerance,
                "{label}: point {} has full-period residual {:e}",
                p.index,
                p.full_period_residual
            );
        }
        let last = branch.points.last().unwrap();
        assert!(relative(last.frequency, modes[branch_mode(&modes, label)].frequency) > 0.049);
        let (sectors, p) = (30, 2);
        let samples = 30 * 4;
        let states = sample_motion(&disk, &last.z0, last.period, samples, 1e-12).unwrap();
        let n = disk.dofs();
        let scale = states
            .iter()
            .flat_map(|z| z[..n].iter())
            .fold(0.0f64, |m, x| m.max(x.abs()));
        for k in 1..sectors {
            // Sector j at time t is sector j + k at time t + k d T / N (forward wave); the
            // time shift is a whole number of samples (samples = 4 N).
            let lag = (k * diameters * 4) % samples;
            let mut worst = 0.0f64;
            for t in 0..samples {
                let later = &states[(t + lag) % samples];
                for j in 0..sectors {
                    for r in 0..p {
                        let now = states[t][j * p + r];
                        let moved = later[((j + k) % sectors) * p + r];
                        worst = worst.max((now - moved).abs());
                    }
                }
            }
            assert!(
                worst < 1e-7 * scale,
                "{label}: shift by {k} sectors off by {worst:e} (scale {scale:e})"
            );
        }
    }
}

fn branch_mode(modes: &[LinearMode], label: &str) -> usize {
    find_mode(modes, label, Some(StandingWave::Cos)).unwrap().0
}

/// The last point of the (1,5) wave is found again by full-period shooting with every mode
/// unknown and no symmetry, from a guess 1e-4 off in period: the same period to 1e-9.
#[test]
fn full_period_shooting_finds_the_same_orbit() {
    let (disk, modes) = disk();
    let branch = travelling(&disk, &modes, "1,5", 0.05);
    let last = branch.points.last().unwrap();
    let start = Start::from_state(&disk, &last.z0, last.period * (1.0 + 1e-4)).unwrap();
    assert_eq!(start.phase, Some(PhaseCondition::FlowOrthogonal));
    assert!(start.shift.is_none());
    let mut settings = Settings::default();
    settings.limits.max_points = 1;
    settings.stability.events = false;
    let again = continue_branch(&disk, &start, &settings, |_| ControlFlow::Continue(())).unwrap();
    let point = &again.points[0];
    assert!(
        relative(point.period, last.period) < 1e-9,
        "{} against {}",
        point.period,
        last.period
    );
    assert!(relative(point.energy, last.energy) < 1e-8);
}

/// The backward wave is the forward one mirrored: the same frequencies at the same energies.
/// Travelling needs a degenerate pair: a single mode is refused with a clear message.
#[test]
fn backward_waves_mirror_forward_ones_and_single_modes_are_refused() {
    let (disk, modes) = disk();
    let (index, _) = find_mode(&modes, "1,5", Some(StandingWave::Cos)).unwrap();
    let backward = Start::travelling_wave(&disk, &modes, index, Travel::Backward, None).unwrap();
    let mut settings = Settings::default();
    settings.limits.frequency_shift_max = 0.03;
    settings.stability.events = false;
    let backward =
        continue_branch(&disk, &backward, &settings, |_| ControlFlow::Continue(())).unwrap();
    let forward = travelling(&disk, &modes, "1,5", 0.03);
    let (f, b) = (
        forward.points.last().unwrap(),
        backward.points.last().unwrap(),
    );
    assert!(relative(b.frequency, f.frequency) < 1e-10);
    assert!(
        relative(b.energy, f.energy) < 1e-8,
        "{} {}",
        b.energy,
        f.energy
    );
    let (single, _) = find_mode(&modes, "1,0", None).unwrap();
    let refused = Start::travelling_wave(&disk, &modes, single, Travel::Forward, None)
        .unwrap_err()
        .to_string();
    assert!(refused.contains("degenerate pair"), "{refused}");
}
