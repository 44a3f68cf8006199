//! Forced response curves by shooting against references that share none of their code:
//! the harmonic-balance reference (tests/common/forced_harmonic_balance.rs) for the folds,
//! peaks and stability of nonlinear curves; an independent fixed-step integration of the
//! variational equations for the multipliers; the cyclic symmetry of a tuned disk for an
//! engine-order response.

#[path = "common/forced_harmonic_balance.rs"]
mod forced_harmonic_balance;

use std::ops::ControlFlow;

use forced_harmonic_balance::{ForcedProblem, Steps, folds, frequency_response, peak};
use nnm::Mat;
use nnm::forced::{
    Force, ResponseCurve, ResponseEventKind, ResponseSettings, ResponseStop, Sweep, forced_response,
};
use nnm::integrate::IntegrationMethod;
use nnm::model::{ForcedSystem, HarmonicForce, Matrix};
use nnm::prelude::*;

fn curve(
    system: &ForcedSystem<'_, Structure>,
    sweep: Sweep,
    settings: &ResponseSettings,
) -> ResponseCurve {
    forced_response(system, sweep, &[], settings, |_| ControlFlow::Continue(())).unwrap()
}

/// The frequencies of a curve's folds, in order.
fn fold_frequencies(c: &ResponseCurve) -> Vec<f64> {
    (c.events.iter())
        .filter(|e| e.kind == ResponseEventKind::Fold)
        .map(|e| e.point.frequency)
        .collect()
}

/// Two folds on `c`, each within `relative` of the reference curve's two.
fn assert_same_two_folds(c: &ResponseCurve, reference: &ResponseCurve, relative: f64) {
    let (a, b) = (fold_frequencies(c), fold_frequencies(reference));
    assert_eq!(a.len(), 2, "folds {a:?}");
    assert_eq!(b.len(), 2, "reference folds {b:?}");
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() < relative * y, "folds {a:?} vs {b:?}");
    }
}

/// Between the two folds (the points after the first fold's, up to the second's) the
/// response is unstable, elsewhere stable.
fn assert_unstable_exactly_between_folds(c: &ResponseCurve) {
    let at: Vec<usize> = (c.events.iter())
        .filter(|e| e.kind == ResponseEventKind::Fold)
        .map(|e| e.point.index)
        .collect();
    for (k, point) in c.points.iter().enumerate() {
        let middle = k > at[0] && k <= at[1];
        assert_eq!(point.stable, !middle, "point {k} of {}", c.points.len());
    }
}

/// `x'' + 0.02 x' + x + x³ = 0.1 cos Ωt` from Ω = 0.5 to 3.5, at default settings: the two
/// folds where harmonic balance (15 harmonics, converged to 1e-12) puts them, to 1e-8 in Ω;
/// the branch between them unstable and the others stable; peaks as harmonic balance's.
fn duffing_against_harmonic_balance(method: IntegrationMethod) {
    let duffing = nnm::model::duffing(1.0, 1.0).unwrap();
    let damping = Matrix::from_rows(&[vec![0.02]]).unwrap();
    let system = ForcedSystem::new(&duffing, &damping, HarmonicForce::cosine(vec![1.0])).unwrap();
    let mut settings = ResponseSettings::default();
    settings.integration.integrator = method;
    let sweep = Sweep::Frequency {
        from: 0.5,
        to: 3.5,
        amplitude: 0.1,
    };
    let shooting = curve(&system, sweep, &settings);
    assert_eq!(shooting.stop, ResponseStop::End);

    let problem = ForcedProblem::new(
        &duffing,
        Mat::from_fn(1, 1, |_, _| 0.02),
        &[1.0],
        &[0.0],
        0.1,
    );
    let steps = Steps {
        initial: 0.02,
        min: 1e-8,
        max: 0.1,
        max_points: 5000,
    };
    let harmonics = 15;
    let reference = frequency_response(&problem, harmonics, 0.5, 3.5, &steps).unwrap();
    let reference_folds = folds(&problem, &reference).unwrap();
    assert_eq!(reference_folds.len(), 2);

    let located: Vec<_> = shooting
        .events
        .iter()
        .filter(|e| e.kind == ResponseEventKind::Fold)
        .collect();
    assert_eq!(
        located.len(),
        2,
        "{:?}",
        shooting
            .events
            .iter()
            .map(|e| (e.kind, e.point.frequency))
            .collect::<Vec<_>>()
    );
    for (event, fold) in located.iter().zip(&reference_folds) {
        let error = (event.point.frequency - fold.omega).abs();
        assert!(
            error < 1e-8,
            "fold at {} vs {} ({error:e}, {})",
            event.point.frequency,
            fold.omega,
            shooting.integrator
        );
        let relative = (event.point.peaks[0] - peak(fold, 0)).abs() / peak(fold, 0);
        assert!(
            relative < 1e-5,
            "fold peak {} vs {}",
            event.point.peaks[0],
            peak(fold, 0)
        );
        // At a fold one multiplier is at +1.
        let m = event.critical_multiplier;
        assert!(
            (m.0 - 1.0).abs() < 1e-4 && m.1 == 0.0,
            "critical multiplier {m:?}"
        );
    }
    let (upper, lower) = (reference_folds[0].omega, reference_folds[1].omega);
    // Points are on the middle (unstable) branch exactly between the two folds in arclength.
    let mut passed = 0;
    for point in &shooting.points {
        passed = shooting
            .events
            .iter()
            .filter(|e| e.kind == ResponseEventKind::Fold && e.point.index < point.index)
            .count();
        let on_middle = passed == 1;
        let near_fold =
            (point.frequency - upper).abs() < 1e-4 || (point.frequency - lower).abs() < 1e-4;
        if !near_fold {
            assert_eq!(
                point.stable, !on_middle,
                "at Ω = {} (folds passed: {passed}), |μ| {}",
                point.frequency, point.max_floquet_modulus
            );
        }
    }
    assert_eq!(passed, 2);
    // Peaks off the folds against harmonic balance at the same frequency on the same branch:
    // the stable points below the lower fold and above the upper.
    for point in shooting
        .points
        .iter()
        .filter(|p| p.frequency < 1.0 || p.frequency > 2.5)
    {
        let guess = reference
            .iter()
            .min_by(|a, b| {
                (a.solution.omega - point.frequency)
                    .abs()
                    .total_cmp(&(b.solution.omega - point.frequency).abs())
            })
            .unwrap();
        let hb = forced_harmonic_balance::solve(
            &problem,
            point.frequency,
            harmonics,
            Some(&guess.solution),
        )
        .unwrap();
        let relative = (point.peaks[0] - peak(&hb, 0)).abs() / peak(&hb, 0);
        assert!(
            relative < 1e-6,
            "peak at Ω = {}: {} vs {}",
            point.frequency,
            point.peaks[0],
            peak(&hb, 0)
        );
    }
}

#[test]
fn duffing_folds_and_stability_match_harmonic_balance_explicit() {
    duffing_against_harmonic_balance(IntegrationMethod::Auto);
}

#[test]
fn duffing_folds_and_stability_match_harmonic_balance_implicit() {
    duffing_against_harmonic_balance(IntegrationMethod::Radau5);
}

/// Order 9, the stiff models' default for forced curves.
#[test]
fn duffing_folds_and_stability_match_harmonic_balance_radau9() {
    duffing_against_harmonic_balance(IntegrationMethod::Radau9);
}

/// The multipliers of a point on the unstable middle branch and of a stable one against the
/// monodromy integrated independently: classical fixed-step RK4 of the Duffing motion and its
/// variational equations `δx'' = −(1 + 3x²) δx − c δx'` over `T = 2π/Ω` (the scheme, the
/// step and the time variable all differ from the solver's). Liouville's formula gives
/// `det Φ = e^{−cT}` exactly, which checks the reference itself.
#[test]
fn multipliers_equal_an_independent_variational_integration() {
    let duffing = nnm::model::duffing(1.0, 1.0).unwrap();
    let c = 0.02;
    let damping = Matrix::from_rows(&[vec![c]]).unwrap();
    let system = ForcedSystem::new(&duffing, &damping, HarmonicForce::cosine(vec![1.0])).unwrap();
    let sweep = Sweep::Frequency {
        from: 0.5,
        to: 3.5,
        amplitude: 0.1,
    };
    let shooting = curve(&system, sweep, &ResponseSettings::default());
    let unstable = shooting
        .points
        .iter()
        .find(|p| !p.stable && p.max_floquet_modulus > 1.01)
        .expect("an unstable point");
    let stable = shooting
        .points
        .iter()
        .find(|p| p.stable && p.frequency > 1.5)
        .expect("a stable point");
    for point in [unstable, stable] {
        let omega = point.frequency;
        let period = 2.0 * std::f64::consts::PI / omega;
        let field = |t: f64, s: [f64; 6]| {
            let [x, v, a, b, cc, d] = s;
            let k = 1.0 + 3.0 * x * x;
            // Φ = [[a, cc], [b, d]] by columns (δx, δv) of each.
            [
                v,
                0.1 * (omega * t).cos() - c * v - x - x * x * x,
                b,
                -k * a - c * b,
                d,
                -k * cc - c * d,
            ]
        };
        let steps = 20_000;
        let h = period / steps as f64;
        let mut s = [point.z0[0], point.z0[1], 1.0, 0.0, 0.0, 1.0];
        for i in 0..steps {
            let t = i as f64 * h;
            let add = |s: [f64; 6], k: [f64; 6], w: f64| {
                std::array::from_fn::<f64, 6, _>(|j| s[j] + w * k[j])
            };
            let k1 = field(t, s);
            let k2 = field(t + 0.5 * h, add(s, k1, 0.5 * h));
            let k3 = field(t + 0.5 * h, add(s, k2, 0.5 * h));
            let k4 = field(t + h, add(s, k3, h));
            s = std::array::from_fn(|j| {
                s[j] + h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
            });
        }
        // The point is periodic by the reference integration too.
        assert!(
            (s[0] - point.z0[0]).abs() < 1e-7 && (s[1] - point.z0[1]).abs() < 1e-7,
            "{s:?} vs {:?}",
            point.z0
        );
        let (a, b, cc, d) = (s[2], s[3], s[4], s[5]);
        let det = a * d - b * cc;
        assert!(
            (det - (-c * period).exp()).abs() < 1e-9,
            "Liouville: {det} vs {}",
            (-c * period).exp()
        );
        let trace = a + d;
        let discriminant = trace * trace / 4.0 - det;
        let mut reference: Vec<(f64, f64)> = if discriminant >= 0.0 {
            vec![
                (trace / 2.0 + discriminant.sqrt(), 0.0),
                (trace / 2.0 - discriminant.sqrt(), 0.0),
            ]
        } else {
            vec![
                (trace / 2.0, (-discriminant).sqrt()),
                (trace / 2.0, -(-discriminant).sqrt()),
            ]
        };
        reference.sort_by(|p, q| q.0.hypot(q.1).total_cmp(&p.0.hypot(p.1)));
        for (m, r) in point.multipliers.iter().zip(&reference) {
            let error = (m.0 - r.0).hypot(m.1.abs() - r.1.abs());
            assert!(error < 1e-6, "multiplier {m:?} vs {r:?} at Ω = {omega}");
        }
    }
}

/// A tuned disk driven in engine order k answers with a travelling wave: sector `s` repeats
/// sector 0 delayed by `s k T/N` (`x_s(t) = x_0(t − s k T/N)`), which the solver does not
/// impose — it shoots the whole disk. Checked on the bladed disk with light Rayleigh damping
/// across its first engine-order-3 resonance.
#[test]
fn engine_order_response_is_a_travelling_wave() {
    let disk = nnm::model::BladedDisk {
        sectors: 6,
        ..Default::default()
    }
    .build()
    .unwrap();
    let modes = nnm::modes::linear_modes(&disk).unwrap();
    let k = 2;
    let resonance = modes
        .iter()
        .find(|m| m.cyclic.as_ref().is_some_and(|c| c.diameters == k))
        .unwrap()
        .frequency;
    let force = Force::EngineOrder {
        engine_order: k,
        amplitude: 0.05,
        sector_dof: 1,
    };
    let damping = nnm::forced::damping::Damping::Rayleigh([0.0, 2e-3])
        .matrix(&disk)
        .unwrap();
    let system = ForcedSystem::new(&disk, &damping, force.shape(&disk).unwrap()).unwrap();
    let sweep = Sweep::Frequency {
        from: 0.8 * resonance,
        to: 1.2 * resonance,
        amplitude: force.amplitude(),
    };
    let response = curve(&system, sweep, &ResponseSettings::default());
    assert_eq!(response.stop, ResponseStop::End);
    let (sectors, per) = (6, disk.dofs() / 6);
    let n = disk.dofs();
    let peak_point = response
        .points
        .iter()
        .max_by(|a, b| a.peaks[0].total_cmp(&b.peaks[0]))
        .unwrap();
    for point in [peak_point, &response.points[0]] {
        let drive = nnm::integrate::forced::Drive {
            frequency: point.frequency,
            amplitude: point.force_amplitude,
        };
        let tolerances = nnm::integrate::Tolerances {
            relative: 1e-12,
            absolute: 1e-14,
            velocity_scale: point.frequency,
        };
        let mut integrator = nnm::integrate::forced::ForcedRungeKutta::new(
            &system,
            &nnm::integrate::DOP853,
            tolerances,
        );
        let samples =
            nnm::integrate::forced::sample(&mut integrator, &point.z0, drive, sectors).unwrap();
        let size = point.z0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for s in 0..sectors {
            // x_s(0) = x_0(−s k T/N) = x_0 at sample (−s k mod N).
            let j = (sectors - (s * k) % sectors) % sectors;
            for d in 0..per {
                for offset in [0, n] {
                    let (a, b) = (point.z0[offset + s * per + d], samples[j][offset + d]);
                    assert!(
                        (a - b).abs() < 1e-6 * size,
                        "sector {s} dof {d}: {a} vs {b}"
                    );
                }
            }
        }
        // Every blade peaks alike.
        let blades = &point.peaks;
        assert_eq!(blades.len(), sectors);
        for p in blades {
            assert!((p - blades[0]).abs() < 1e-6 * blades[0]);
        }
    }
}

/// Shooting over half the forcing period (`−z(π) = z0`, an odd system) against the whole
/// period, on the damped Duffing curve: the same folds and, point for point at equal
/// frequencies, the same multipliers (the half map's squared).
#[test]
fn half_period_shooting_equals_whole_period_shooting() {
    let duffing = nnm::model::duffing(1.0, 1.0).unwrap();
    let damping = Matrix::from_rows(&[vec![0.02]]).unwrap();
    let system = ForcedSystem::new(&duffing, &damping, HarmonicForce::cosine(vec![1.0])).unwrap();
    let sweep = Sweep::Frequency {
        from: 0.5,
        to: 3.5,
        amplitude: 0.1,
    };
    let mut whole = ResponseSettings::default();
    whole.half_period = false;
    let (half, whole) = (
        curve(&system, sweep, &ResponseSettings::default()),
        curve(&system, sweep, &whole),
    );
    assert!(half.half_period && !whole.half_period);
    let (a, b) = (fold_frequencies(&half), fold_frequencies(&whole));
    assert_eq!(a.len(), 2);
    assert_eq!(b.len(), 2);
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() < 1e-9, "folds {a:?} vs {b:?}");
    }
    // The last points, both at the end of the sweep (3.5 rad/s): the same state and
    // multipliers.
    let (p, q) = (half.points.last().unwrap(), whole.points.last().unwrap());
    assert!((p.frequency - q.frequency).abs() < 1e-12);
    for (x, y) in p.z0.iter().zip(&q.z0) {
        assert!(
            (x - y).abs() < 1e-9 * p.peaks[0],
            "{:?} vs {:?}",
            p.z0,
            q.z0
        );
    }
    for (m, n) in p.multipliers.iter().zip(&q.multipliers) {
        assert!(
            (m.0 - n.0).hypot(m.1.abs() - n.1.abs()) < 1e-7,
            "{m:?} vs {n:?}"
        );
    }
}

/// Matrix-free forced shooting (GMRES corrections and Arnoldi multipliers on the recorded
/// flow, docs/method.md eq. (102a)) against the dense formulation (the whole Jacobian
/// factorised, every eigenvalue of the monodromy) on a damped 8-element ECL beam driven
/// through its two folds: the same folds, the same stability verdict at every point of the
/// matrix-free curve, and the same leading multipliers at the end of the sweep — by Radau
/// IIA of order 5 and of order 9 (the default). Each curve sets its own step count from its
/// own path: the critical pair is the same to 1e-7 whatever the steps; the next (|μ| = 0.87,
/// the second bending mode) is the same to 1e-7 when both curves end on the same steps a
/// period, and otherwise only to its discretisation error at `ω₂ h ≈ 2`, 1e-4 (at order 9,
/// 16 against 18 steps differed by 1e-5; at order 5, 35 against 39 steps by 2.3e-5).
#[test]
fn matrix_free_shooting_equals_dense_shooting() {
    for (method, second_pair) in [
        (IntegrationMethod::Radau5, 1e-4),
        (IntegrationMethod::Radau9, 1e-4),
    ] {
        matrix_free_equals_dense(method, second_pair);
    }
}

fn matrix_free_equals_dense(method: IntegrationMethod, second_pair: f64) {
    use nnm::forced::damping::Damping;
    use nnm::model::CantileverBeam;
    use nnm::shooting::Formulation;
    let beam = CantileverBeam {
        elements: 8,
        ..CantileverBeam::default()
    }
    .build()
    .unwrap();
    let damping = Damping::Rayleigh([0.0, 1e-5]).matrix(&beam).unwrap();
    let tip = beam.dofs() - 2;
    let mut shape = vec![0.0; beam.dofs()];
    shape[tip] = 1.0;
    let system = ForcedSystem::new(&beam, &damping, HarmonicForce::cosine(shape)).unwrap();
    let sweep = Sweep::Frequency {
        from: 135.0,
        to: 193.0,
        amplitude: 0.01,
    };
    // A tolerance tight enough that the two corrections (GMRES and Newton, dense LU and
    // chords) leave the same states to well below the multipliers' bound.
    let with = |formulation| {
        let mut settings = ResponseSettings::default();
        settings.formulation = formulation;
        settings.continuation.tolerance = 1e-9;
        settings.integration.integrator = method;
        curve(&system, sweep, &settings)
    };
    let (free, dense) = (with(Formulation::MatrixFree), with(Formulation::Dense));
    assert_eq!(free.stop, ResponseStop::End);
    assert_eq!(dense.stop, ResponseStop::End);
    assert_same_two_folds(&free, &dense, 1e-8);
    for c in [&free, &dense] {
        assert_unstable_exactly_between_folds(c);
    }
    let (p, q) = (free.points.last().unwrap(), dense.points.last().unwrap());
    assert!((p.frequency - q.frequency).abs() < 1e-9 * q.frequency);
    assert_eq!(p.stable, q.stable);
    assert!(p.multipliers.len() >= 4, "{:?}", p.multipliers);
    let same_steps = p.integration_steps == q.integration_steps;
    for (k, (m, n)) in p.multipliers.iter().zip(&q.multipliers).take(4).enumerate() {
        let bound = if k < 2 || same_steps {
            1e-7
        } else {
            second_pair
        };
        assert!(
            (m.0 - n.0).hypot(m.1.abs() - n.1.abs()) < bound,
            "{method:?} ({} against {} steps): {:?} vs {:?}",
            p.integration_steps,
            q.integration_steps,
            &p.multipliers[..4],
            &q.multipliers[..4]
        );
    }
}

/// A von Kármán beam (10 elements) is not odd — its membrane force is even in the transverse
/// displacement — but flipping the transverse dofs and keeping the axial ones is a symmetry
/// that the Rayleigh damping and a transverse force at the middle respect, so its responses
/// are half-wave symmetric in that sense and are shot over half the period (eq. (99b) with
/// the parity's signs). Against whole periods (`half_period = false`, no symmetry used): the
/// same two folds of the hardening peak to 1e-7 in frequency, the same stable and unstable
/// stretches, the same largest multiplier modulus at the sweep's end — and so for the
/// half-period curve shot matrix-free (GMRES corrections, Arnoldi multipliers stopped once
/// those above a tenth in modulus have converged: the lightly damped beam has many more).
#[test]
fn von_karman_half_wave_parity_equals_whole_periods() {
    use nnm::forced::damping::Damping;
    use nnm::model::VonKarmanBeam;
    use nnm::shooting::Formulation;
    let beam = VonKarmanBeam {
        elements: 10,
        ..VonKarmanBeam::default()
    }
    .build()
    .unwrap();
    let damping = Damping::Rayleigh([0.0, 1e-5]).matrix(&beam).unwrap();
    let mut shape = vec![0.0; beam.dofs()];
    shape[3 * 4 + 1] = 1.0; // node 5 of 10: the middle's transverse displacement
    let system = ForcedSystem::new(&beam, &damping, HarmonicForce::cosine(shape)).unwrap();
    let sweep = Sweep::Frequency {
        from: 315.0,
        to: 370.0,
        amplitude: 3.0,
    };
    let with = |half_period, formulation| {
        let mut settings = ResponseSettings::default();
        settings.half_period = half_period;
        settings.formulation = formulation;
        curve(&system, sweep, &settings)
    };
    let whole = with(false, Formulation::Dense);
    let half = with(true, Formulation::Dense);
    let matrix_free = with(true, Formulation::MatrixFree);
    assert!(
        half.half_period && matrix_free.half_period,
        "the parity is found"
    );
    assert!(!whole.half_period);
    assert!(matrix_free.stats.krylov_products > 0, "shot matrix-free");
    for c in [&half, &whole, &matrix_free] {
        assert_eq!(c.stop, ResponseStop::End);
    }
    for c in [&half, &matrix_free] {
        assert_same_two_folds(c, &whole, 1e-7);
    }
    for c in [&half, &whole, &matrix_free] {
        assert_unstable_exactly_between_folds(c);
    }
    // The motions sampled over half a period and mirrored by the parity: the same peak and
    // first harmonic at the sweep's end as sampled over the whole one.
    let q = whole.points.last().unwrap();
    for c in [&half, &matrix_free] {
        let p = c.points.last().unwrap();
        assert!(
            (p.peaks[0] - q.peaks[0]).abs() < 1e-7 * q.peaks[0]
                && (p.harmonic_amplitude - q.harmonic_amplitude).abs()
                    < 1e-7 * q.harmonic_amplitude,
            "peak {} and first harmonic {} vs {} and {}",
            p.peaks[0],
            p.harmonic_amplitude,
            q.peaks[0],
            q.harmonic_amplitude
        );
        assert!(
            (p.max_floquet_modulus - q.max_floquet_modulus).abs() < 1e-7,
            "{} vs {}",
            p.max_floquet_modulus,
            q.max_floquet_modulus
        );
    }
}

/// The damping force of a fine mesh is summed as its internal force is (docs/method.md §19,
/// eq. (76c)): a Rayleigh `C = βK` cancels like `K` on a smooth velocity field. Summed
/// plainly, its round-off was the floor of the shooting residual — 1.3e-10 on this
/// 1,000-element von Kármán beam (2,997 dofs), growing like the mesh's `(ω_max/ω)²` to
/// 4e-9–1e-8 at 10⁴ dofs, where the default tolerance could not be met. Here the first point
/// must converge to a tolerance of 1e-11 (measured 1.4e-13).
#[test]
fn fine_mesh_forced_residual_goes_below_the_plain_damping_round_off() {
    use nnm::forced::damping::Damping;
    use nnm::model::VonKarmanBeam;
    let beam = VonKarmanBeam {
        elements: 1000,
        ..VonKarmanBeam::default()
    }
    .build()
    .unwrap();
    let damping = Damping::Rayleigh([0.0, 1e-5]).matrix(&beam).unwrap();
    let mut shape = vec![0.0; beam.dofs()];
    shape[3 * (500 - 1) + 1] = 1.0; // node 500 of 1,000: the middle's transverse displacement
    let system = ForcedSystem::new(&beam, &damping, HarmonicForce::cosine(shape)).unwrap();
    let sweep = Sweep::Frequency {
        from: 315.0,
        to: 316.0,
        amplitude: 3.0,
    };
    let mut settings = ResponseSettings::default();
    settings.continuation.tolerance = 1e-11;
    settings.max_points = 1;
    let first = curve(&system, sweep, &settings);
    assert_eq!(first.stop, ResponseStop::MaxPoints, "{:?}", first.stop);
    let point = &first.points[0];
    assert!(
        point.relative_residual < 1e-11,
        "residual {:e}",
        point.relative_residual
    );
}
