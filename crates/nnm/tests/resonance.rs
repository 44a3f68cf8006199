//! Resonance peaks predicted from backbones by energy balance (docs/method.md §21) against
//! forced response curves computed by shooting the damped, forced system at the predicted
//! force — a computation that shares nothing with the prediction but the model. The peak of
//! the forced curve must approach the backbone point as the damping goes to zero, and at the
//! rate the method's derivation gives (second order in the damping). And the phase-resonance
//! event of forced curves (eq. (113)): exact for a linear oscillator, on the backbone to second
//! order in the damping for a nonlinear one.

use std::ops::ControlFlow;

use nnm::analysis::EnergyBalance;
use nnm::forced::{
    Force, ResponseCurve, ResponseEventKind, ResponseSettings, Sweep, forced_response,
};
use nnm::model::{ForcedSystem, HarmonicForce, Matrix, Structure};
use nnm::modes::{StandingWave, find_mode, linear_modes};
use nnm::shooting::{PointLabel, Travel};
use nnm::{BranchPoint, Settings, Start, continue_branch};

/// The last point of `system`'s branch from `start` to `shift` above its linear frequency,
/// with the resonance force of `balance` and the peaks of `output_dof`.
fn backbone_point(
    system: &Structure,
    start: &Start,
    shift: f64,
    output_dof: usize,
    balance: EnergyBalance,
) -> BranchPoint {
    let mut settings = Settings::default();
    settings.limits.frequency_shift_max = shift;
    settings.stability.events = false;
    settings.output.output_dofs = vec![output_dof];
    settings.output.energy_balance = Some(std::sync::Arc::new(balance));
    let branch = continue_branch(system, start, &settings, |_| ControlFlow::Continue(())).unwrap();
    let last = branch.points.last().unwrap().clone();
    assert_eq!(last.label, Some(PointLabel::FrequencyShiftMax));
    last
}

/// The forced curve of `system` over `sweep` (peaks of `output_dofs`; none: the forced dofs).
fn curve(
    system: &ForcedSystem<'_, Structure>,
    sweep: Sweep,
    output_dofs: &[usize],
    settings: &ResponseSettings,
) -> ResponseCurve {
    forced_response(system, sweep, output_dofs, settings, |_| {
        ControlFlow::Continue(())
    })
    .unwrap()
}

/// Errors at dampings halved each time fall like the damping squared: each ratio 4 ± 5%.
fn assert_second_order(errors: &[f64]) {
    for pair in errors.windows(2) {
        let ratio = pair[0] / pair[1];
        assert!((3.8..=4.2).contains(&ratio), "errors {errors:?}");
    }
}

/// The largest peak of the first output dof along `curve`, refined between its points: the
/// peak as a function of the response's phase lag (smooth through the resonance, where the
/// curve turns sharply in the frequency–amplitude plane) interpolated through the five points
/// around the largest, maximised on a fine grid.
fn refined_peak(curve: &ResponseCurve) -> f64 {
    let points = &curve.points;
    let k = (0..points.len())
        .max_by(|&a, &b| points[a].peaks[0].total_cmp(&points[b].peaks[0]))
        .unwrap();
    assert!(
        k >= 2 && k + 2 < points.len(),
        "the peak is at an end of the curve"
    );
    let (phase, peak): (Vec<f64>, Vec<f64>) = points[k - 2..=k + 2]
        .iter()
        .map(|p| (p.phase_lag, p.peaks[0]))
        .unzip();
    let lagrange = |x: f64| -> f64 {
        (0..5)
            .map(|i| {
                let weight: f64 = (0..5)
                    .filter(|&j| j != i)
                    .map(|j| (x - phase[j]) / (phase[i] - phase[j]))
                    .product();
                weight * peak[i]
            })
            .sum()
    };
    let (from, to) = (phase[1], phase[3]);
    (0..=4000)
        .map(|s| lagrange(from + (to - from) * s as f64 / 4000.0))
        .fold(peak[2], f64::max)
}

/// `x'' + c x' + x + x³ = a cos Ωt`: the backbone's point at +30% (peak 0.9676) predicts a
/// force for each damping `c`; the forced curve at that force peaks above the backbone point
/// by `e(c)`, which must shrink like `c²` (halving `c` divides it by 4 ± 5%) and be below
/// 1e-5 at `c = 0.01`. Measured: 9.03e-5, 2.26e-5, 5.64e-6 at `c` = 0.04, 0.02, 0.01.
#[test]
fn duffing_forced_peaks_approach_the_backbone_as_damping_squared() {
    let duffing = nnm::model::duffing(1.0, 1.0).unwrap();
    let start = Start::from_mode(&duffing, 0).unwrap();
    let unit = HarmonicForce::cosine(vec![1.0]);
    let mut errors = Vec::new();
    for c in [0.04, 0.02, 0.01] {
        let damping = Matrix::from_rows(&[vec![c]]).unwrap();
        let balance = EnergyBalance::new(damping.clone(), unit.clone()).unwrap();
        let point = backbone_point(&duffing, &start, 0.3, 0, balance);
        let resonance = point.resonance.unwrap();
        // The first harmonic's share: a ≈ c ω X to the motion's third harmonic.
        let linear_estimate = c * point.frequency * point.peak_displacements[0];
        assert!((resonance.amplitude / linear_estimate - 1.0).abs() < 0.05);

        let system = ForcedSystem::new(&duffing, &damping, unit.clone()).unwrap();
        let mut settings = ResponseSettings::default();
        settings.continuation.max_step = 0.02;
        // Peaks to ~1e-9: at the default 1e-8 they carry ~2e-7, a fifth of the smallest error.
        settings.continuation.tolerance = 1e-10;
        let sweep = Sweep::Frequency {
            from: 0.5,
            to: 2.0,
            amplitude: resonance.amplitude,
        };
        let curve = curve(&system, sweep, &[], &settings);
        let error = refined_peak(&curve) / point.peak_displacements[0] - 1.0;
        errors.push(error);
    }
    assert_second_order(&errors);
    assert!(errors[2].abs() < 1e-5, "errors {errors:?}");
}

/// A linear system driven by the modal force `M φ` of its first mode under Rayleigh damping
/// answers in that mode alone, `x = Q φ` with `Q = a / ((α + β ω²) ω)` at `Ω = ω`: the
/// energy balance of every backbone point (whatever its amplitude) must give that `a`
/// exactly, with the force in phase with the velocity.
#[test]
fn a_linear_modal_force_is_predicted_exactly() {
    let mass = Matrix::from_rows(&[vec![1.0, 0.0], vec![0.0, 2.0]]).unwrap();
    let stiffness = Matrix::from_rows(&[vec![3.0, -1.0], vec![-1.0, 2.0]]).unwrap();
    let linear = Structure::new(mass, stiffness, Vec::new()).unwrap();
    let modes = linear_modes(&linear).unwrap();
    let mode = &modes[0];
    let (alpha, beta) = (0.01, 0.002);
    let damping = nnm::forced::damping::Damping::Rayleigh([alpha, beta])
        .matrix(&linear)
        .unwrap();
    let modal_force = vec![mode.shape[0], 2.0 * mode.shape[1]];
    let balance = EnergyBalance::new(damping, HarmonicForce::cosine(modal_force)).unwrap();
    let mut settings = Settings::default();
    settings.limits.energy_max = 10.0;
    settings.stability.events = false;
    settings.output.output_dofs = vec![0];
    settings.output.energy_balance = Some(std::sync::Arc::new(balance));
    let start = Start::from_mode(&linear, 0).unwrap();
    let branch =
        continue_branch(&linear, &start, &settings, |_| ControlFlow::Continue(())).unwrap();
    assert!(branch.points.len() > 3);
    let omega = mode.frequency;
    for p in &branch.points {
        let modal_amplitude = p.peak_displacements[0] / mode.shape[0].abs();
        let exact = (alpha + beta * omega * omega) * omega * modal_amplitude;
        let r = p.resonance.unwrap();
        assert!(
            (r.amplitude / exact - 1.0).abs() < 1e-9,
            "{} vs {exact}",
            r.amplitude
        );
        // The force in phase with the velocity: at t = 0 (zero velocity, the displacement
        // at its extreme) the force is zero, so φ = ±π/2.
        assert!(
            (r.phase.abs() - std::f64::consts::FRAC_PI_2).abs() < 1e-9,
            "{r:?}"
        );
    }
}

/// The bladed disk's (1,5) travelling wave under engine order 5 at the blades (Rayleigh
/// damping `βK`): the forced curve at the force the backbone's +3% point predicts peaks at
/// that point's blade amplitude, to an error that shrinks like `β²` (measured: 1.82e-5,
/// 4.55e-6, 1.14e-6 at β = 4e-3, 2e-3, 1e-3 — 0.43% to 0.11% of critical damping at the
/// resonance). The backward wave, on
/// which a forward engine order does no work, needs no finite force.
#[test]
fn bladed_disk_engine_order_peaks_approach_the_travelling_backbone() {
    let disk = nnm::model::BladedDisk::default().build().unwrap();
    let modes = linear_modes(&disk).unwrap();
    let (index, mode) = find_mode(&modes, "1,5", Some(StandingWave::Cos)).unwrap();
    let omega = mode.frequency;
    let force = Force::EngineOrder {
        engine_order: 5,
        amplitude: 1.0,
        sector_dof: 1,
    };
    let shape = force.shape(&disk).unwrap();
    let forward = Start::travelling_wave(&disk, &modes, index, Travel::Forward, None).unwrap();
    let backward = Start::travelling_wave(&disk, &modes, index, Travel::Backward, None).unwrap();
    let mut errors = Vec::new();
    for beta in [4e-3, 2e-3, 1e-3] {
        let damping = nnm::forced::damping::Damping::Rayleigh([0.0, beta])
            .matrix(&disk)
            .unwrap();
        let balance = EnergyBalance::new(damping.clone(), shape.clone()).unwrap();
        let point = backbone_point(&disk, &forward, 0.03, 1, balance.clone());
        let a = point.resonance.unwrap().amplitude;
        let against = backbone_point(&disk, &backward, 0.03, 1, balance);
        assert!(against.resonance.unwrap().amplitude > 1e6 * a);

        let system = ForcedSystem::new(&disk, &damping, shape.clone()).unwrap();
        let mut settings = ResponseSettings::default();
        settings.continuation.max_step = 0.02;
        // Peaks to ~1e-9: at the default 1e-8 they carry ~2e-7, a fifth of the smallest error.
        settings.continuation.tolerance = 1e-10;
        let sweep = Sweep::Frequency {
            from: 0.98 * omega,
            to: 1.06 * omega,
            amplitude: a,
        };
        let curve = curve(&system, sweep, &[1], &settings);
        errors.push(refined_peak(&curve) / point.peak_displacements[0] - 1.0);
    }
    assert_second_order(&errors);
}

/// The phase-resonance event of a forced curve (`φ = π/2`, eq. (113)).
fn phase_resonances(curve: &ResponseCurve) -> Vec<&nnm::forced::ResponseEvent> {
    curve
        .events
        .iter()
        .filter(|e| e.kind == ResponseEventKind::PhaseResonance)
        .collect()
}

/// `m x'' + c x' + k x = a cos Ωt` lags the force by exactly `π/2` at `Ω = √(k/m)` (the
/// undamped natural frequency, whatever the damping: `tan φ = cΩ / (k − mΩ²)`), where its
/// amplitude is `a / (c Ω)`: the event finds the frequency to 1e-10 and the amplitude to 1e-9
/// (the point's peak is measured to that) at three damping levels.
#[test]
fn a_linear_oscillator_is_in_phase_resonance_at_its_natural_frequency() {
    let omega = 1.3;
    let linear = nnm::model::duffing(omega, 0.0).unwrap();
    for c in [0.1, 0.02, 0.004] {
        let damping = Matrix::from_rows(&[vec![c]]).unwrap();
        let system =
            ForcedSystem::new(&linear, &damping, HarmonicForce::cosine(vec![1.0])).unwrap();
        let sweep = Sweep::Frequency {
            from: 0.5,
            to: 2.0,
            amplitude: 0.01,
        };
        let settings = ResponseSettings::default();
        let curve = curve(&system, sweep, &[], &settings);
        let found = phase_resonances(&curve);
        assert_eq!(found.len(), 1, "c = {c}");
        let point = &found[0].point;
        assert!(
            (point.frequency / omega - 1.0).abs() < 1e-10,
            "c = {c}: {}",
            point.frequency
        );
        let amplitude = 0.01 / (c * omega);
        assert!(
            (point.peaks[0] / amplitude - 1.0).abs() < 1e-9,
            "c = {c}: {}",
            point.peaks[0]
        );
        assert!(found[0].point.stable);
    }
}

/// The Duffing oscillator's phase-resonance point lies on the backbone at its own frequency
/// (the backbone's point placed exactly there by `at_frequencies`), closer as the damping
/// goes down: the distance falls like `c²` and is below 1e-7 at `c = 0.01` (measured: −1.10e-6,
/// −2.76e-7, −6.90e-8 at c = 0.04, 0.02, 0.01, the force `1.25 c` putting the point at +30%, peak 0.97).
#[test]
fn duffing_phase_resonance_lies_on_the_backbone() {
    let duffing = nnm::model::duffing(1.0, 1.0).unwrap();
    let start = Start::from_mode(&duffing, 0).unwrap();
    let mut distances = Vec::new();
    for c in [0.04, 0.02, 0.01] {
        let damping = Matrix::from_rows(&[vec![c]]).unwrap();
        let system =
            ForcedSystem::new(&duffing, &damping, HarmonicForce::cosine(vec![1.0])).unwrap();
        let sweep = Sweep::Frequency {
            from: 0.5,
            to: 2.0,
            amplitude: 1.25 * c,
        };
        let curve = curve(&system, sweep, &[], &ResponseSettings::default());
        let found = phase_resonances(&curve);
        assert_eq!(found.len(), 1, "c = {c}");
        let resonance = &found[0].point;

        let mut settings = Settings::default();
        settings.limits.frequency_shift_max = 0.6;
        settings.requests.at_frequencies = vec![resonance.frequency];
        settings.stability.events = false;
        let branch =
            continue_branch(&duffing, &start, &settings, |_| ControlFlow::Continue(())).unwrap();
        let on = branch
            .points
            .iter()
            .find(|p| p.label == Some(PointLabel::AtFrequency))
            .unwrap();
        distances.push(resonance.peaks[0] / on.peak_displacements[0] - 1.0);
    }
    assert_second_order(&distances);
    assert!(distances[2].abs() < 1e-7, "distances {distances:?}");
}
