//! Self-checks of the forced harmonic-balance reference (tests/common/forced_harmonic_balance.rs)
//! before it serves as the independent check of the shooting frequency-response curves: exact
//! against the linear complex solve, convergent in the number of harmonics on the damped
//! Duffing oscillator and a two-DOF system, close to the classical one-harmonic result, and
//! with Hill's stability agreeing with the folds.

#[path = "common/forced_harmonic_balance.rs"]
mod forced_harmonic_balance;

use forced_harmonic_balance::{
    Coefficients, CurvePoint, ForcedProblem, Steps, first_harmonic_amplitude, floquet_exponents,
    folds, frequency_response, peak, solve,
};
use nnm::Mat;
use nnm::prelude::*;

type C64 = (f64, f64);

fn cmul(a: C64, b: C64) -> C64 {
    (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0)
}

fn cdiv(a: C64, b: C64) -> C64 {
    let d = b.0 * b.0 + b.1 * b.1;
    ((a.0 * b.0 + a.1 * b.1) / d, (a.1 * b.0 - a.0 * b.1) / d)
}

/// `X = (K − Ω²M + iΩC)⁻¹ (F_c − i F_s)` by complex Gaussian elimination with partial pivoting:
/// the steady state `x = Re(X e^{iΩt}) = Re X cos Ωt − Im X sin Ωt` of the linear system forced
/// by `F_c cos Ωt + F_s sin Ωt`.
fn complex_response(
    k: &Mat<f64>,
    m: &Mat<f64>,
    c: &Mat<f64>,
    fc: &[f64],
    fs: &[f64],
    w: f64,
) -> Vec<C64> {
    let n = fc.len();
    let mut a: Vec<Vec<C64>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| (k[(i, j)] - w * w * m[(i, j)], w * c[(i, j)]))
                .collect()
        })
        .collect();
    let mut b: Vec<C64> = (0..n).map(|i| (fc[i], -fs[i])).collect();
    for col in 0..n {
        let p = (col..n)
            .max_by(|&i, &j| {
                a[i][col]
                    .0
                    .hypot(a[i][col].1)
                    .total_cmp(&a[j][col].0.hypot(a[j][col].1))
            })
            .unwrap();
        a.swap(col, p);
        b.swap(col, p);
        for row in col + 1..n {
            let f = cdiv(a[row][col], a[col][col]);
            for j in col..n {
                let t = cmul(f, a[col][j]);
                a[row][j] = (a[row][j].0 - t.0, a[row][j].1 - t.1);
            }
            let t = cmul(f, b[col]);
            b[row] = (b[row].0 - t.0, b[row].1 - t.1);
        }
    }
    let mut x = vec![(0.0, 0.0); n];
    for row in (0..n).rev() {
        let mut s = b[row];
        for j in row + 1..n {
            let t = cmul(a[row][j], x[j]);
            s = (s.0 - t.0, s.1 - t.1);
        }
        x[row] = cdiv(s, a[row][row]);
    }
    x
}

/// The largest deviation of an HB response from the linear one, relative to `max |X|`.
fn linear_error(c: &Coefficients, x: &[C64]) -> f64 {
    let scale = x.iter().fold(0.0f64, |s, v| s.max(v.0.hypot(v.1)));
    let mut worst = 0.0f64;
    for h in 0..=c.harmonics {
        for d in 0..x.len() {
            let (a, b) = if h == 1 {
                (x[d].0, -x[d].1)
            } else {
                (0.0, 0.0)
            };
            worst = worst.max((c.cosine(h)[d] - a).abs());
            if h > 0 {
                worst = worst.max((c.sine(h)[d] - b).abs());
            }
        }
    }
    worst / scale
}

const STEPS: Steps = Steps {
    initial: 0.02,
    min: 1e-8,
    max: 0.1,
    max_points: 5000,
};

fn check_linear<S: MechanicalSystem>(
    system: &S,
    k: &Mat<f64>,
    c: Mat<f64>,
    fc: &[f64],
    fs: &[f64],
) {
    let amplitude = 0.3;
    let problem = ForcedProblem::new(system, c.clone(), fc, fs, amplitude);
    let m = problem.mass().clone();
    let (fc, fs): (Vec<f64>, Vec<f64>) = (
        fc.iter().map(|v| amplitude * v).collect(),
        fs.iter().map(|v| amplitude * v).collect(),
    );
    for omega in [0.2, 0.9, 0.99, 1.0, 1.3, 1.7, 2.5] {
        let hb = solve(&problem, omega, 3, None).unwrap();
        assert!(hb.relative_residual < 1e-13 && hb.iterations < 10, "{hb:?}");
        let exact = complex_response(k, &m, &c, &fc, &fs, omega);
        let error = linear_error(&hb, &exact);
        assert!(error < 1e-12, "Ω = {omega}: {error:e}");
    }
    let curve = frequency_response(&problem, 2, 0.2, 3.0, &STEPS).unwrap();
    assert!(curve.len() > 20);
    assert!((curve.last().unwrap().solution.omega - 3.0).abs() < 1e-14);
    for p in &curve {
        let exact = complex_response(k, &m, &c, &fc, &fs, p.solution.omega);
        let error = linear_error(&p.solution, &exact);
        assert!(error < 1e-12, "Ω = {}: {error:e}", p.solution.omega);
    }
    assert!(folds(&problem, &curve).unwrap().is_empty());
}

/// With no nonlinearity the HB is the linear response, exactly: every harmonic but the first
/// vanishes and the first is the complex solve, at fixed frequencies and along the continued
/// curve, on one DOF and on two with a full mass matrix and non-proportional damping.
#[test]
fn linear_response_equals_the_complex_solve() {
    let one = nnm::model::duffing(1.0, 0.0).unwrap();
    let k1 = Mat::from_fn(1, 1, |_, _| 1.0);
    check_linear(&one, &k1, Mat::from_fn(1, 1, |_, _| 0.1), &[1.0], &[0.4]);

    let m = Mat::from_fn(2, 2, |i, j| [[2.0, 0.3], [0.3, 1.0]][i][j]);
    let k = Mat::from_fn(2, 2, |i, j| [[3.0, -1.0], [-1.0, 2.0]][i][j]);
    let c = Mat::from_fn(2, 2, |i, j| [[0.05, -0.02], [-0.02, 0.08]][i][j]);
    let two = Structure::new(m, k.clone(), vec![]).unwrap();
    check_linear(&two, &k, c, &[1.0, -0.5], &[0.2, 0.7]);
}

/// The damped forced Duffing oscillator `x'' + c x' + x + x³ = F cos Ωt` (m = k = k3 = 1).
const DAMPING: f64 = 0.02;
const FORCE: f64 = 0.1;

fn duffing_problem(system: &Structure) -> ForcedProblem<'_, Structure> {
    ForcedProblem::new(
        system,
        Mat::from_fn(1, 1, |_, _| DAMPING),
        &[1.0],
        &[0.0],
        FORCE,
    )
}

/// The HB curve of `problem` from Ω = 0.5 to 3.5 and its folds.
fn curve_and_folds(
    problem: &ForcedProblem<'_, Structure>,
    harmonics: usize,
    end: f64,
) -> (Vec<CurvePoint>, Vec<Coefficients>) {
    let curve = frequency_response(problem, harmonics, 0.5, end, &STEPS).unwrap();
    let folds = folds(problem, &curve).unwrap();
    (curve, folds)
}

/// The classical one-harmonic balance of the Duffing oscillator, in closed form:
/// `x = A cos(Ωt − φ)` gives `G(u, v) = u ((κ − v)² + c² v) − F² = 0` with `u = A²`,
/// `v = Ω²`, `κ = 1 + ¾u`. A fold in Ω is where `∂G/∂u = 0` as well; with `w = κ − v` that
/// is the quadratic `w² + (3u/2 − c²) w + c² κ = 0`, whose two roots give the two folds (near
/// the backbone `v ≈ κ`, and on the lower branch `v ≈ κ + 3u/2`). Each is found by bisection
/// of `G(u, κ − w(u))` in `u`. Returns `(Ω, A)` of both.
fn one_harmonic_folds(c: f64, force: f64) -> Vec<(f64, f64)> {
    let g = |u: f64, root: f64| -> Option<(f64, f64)> {
        let kappa = 1.0 + 0.75 * u;
        let b = 1.5 * u - c * c;
        let disc = b * b - 4.0 * c * c * kappa;
        if disc < 0.0 {
            return None;
        }
        let w = 0.5 * (-b + root * disc.sqrt());
        let v = kappa - w;
        (v > 0.0).then(|| (u * (w * w + c * c * v) - force * force, v))
    };
    let mut found = Vec::new();
    for root in [1.0, -1.0] {
        let grid: Vec<f64> = (0..=4000)
            .map(|i| 10f64.powf(-4.0 + 6.0 * i as f64 / 4000.0))
            .collect();
        for pair in grid.windows(2) {
            let (Some((ga, _)), Some((gb, _))) = (g(pair[0], root), g(pair[1], root)) else {
                continue;
            };
            if ga * gb > 0.0 {
                continue;
            }
            let (mut lo, mut hi, mut glo) = (pair[0], pair[1], ga);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                let gm = g(mid, root).unwrap().0;
                if gm * glo > 0.0 {
                    (lo, glo) = (mid, gm);
                } else {
                    hi = mid;
                }
            }
            let u = 0.5 * (lo + hi);
            found.push((g(u, root).unwrap().1.sqrt(), u.sqrt()));
        }
    }
    found
}

/// With one harmonic the HB is the classical amplitude–phase equation, so its folds (located
/// by the tangent chart) must be the closed-form ones to rounding: a check of the fold
/// location against algebra that shares nothing with it.
#[test]
fn one_harmonic_folds_are_the_closed_form_ones() {
    let system = nnm::model::duffing(1.0, 1.0).unwrap();
    let (_, folds) = curve_and_folds(&duffing_problem(&system), 1, 3.5);
    let exact = one_harmonic_folds(DAMPING, FORCE);
    assert_eq!(folds.len(), 2);
    assert_eq!(exact.len(), 2);
    for (omega, amplitude) in exact {
        let hb = folds
            .iter()
            .min_by(|a, b| (a.omega - omega).abs().total_cmp(&(b.omega - omega).abs()))
            .unwrap();
        assert!(
            (hb.omega - omega).abs() < 1e-12 * omega,
            "{} against {omega}",
            hb.omega
        );
        let a1 = first_harmonic_amplitude(hb, 0);
        assert!(
            (a1 - amplitude).abs() < 1e-9 * amplitude,
            "{a1} against {amplitude}"
        );
    }
}

/// The folds of the damped Duffing oscillator converge geometrically in the number of
/// harmonics (every two more gain a factor 10 at least, until rounding), H = 9 agrees with
/// H = 15 to 1e-11, and the numbers are sane: within 1 % of the one-harmonic folds, the upper
/// one within 3 % of the backbone `ω² = 1 + ¾A²` at its first-harmonic amplitude.
#[test]
fn duffing_folds_converge_in_harmonics() {
    let system = nnm::model::duffing(1.0, 1.0).unwrap();
    let problem = duffing_problem(&system);
    let all: Vec<Vec<Coefficients>> = [3, 5, 7, 9, 11, 13, 15]
        .iter()
        .map(|&h| curve_and_folds(&problem, h, 3.5).1)
        .collect();
    let reference = all.last().unwrap();
    assert_eq!(reference.len(), 2);
    for (i, fold) in reference.iter().enumerate() {
        let gaps: Vec<f64> = all
            .iter()
            .map(|f| (f[i].omega - fold.omega).abs())
            .collect();
        let shown: Vec<String> = gaps.iter().map(|g| format!("{g:.1e}")).collect();
        println!(
            "fold Ω = {:.15}: |Ω_H − Ω_15|, H = 3, 5, …, 15: {shown:?}",
            fold.omega
        );
        for pair in gaps[..gaps.len() - 1].windows(2) {
            assert!(pair[1] <= (0.1 * pair[0]).max(1e-13), "{gaps:?}");
        }
        assert!(gaps[3] < 1e-11, "H = 9: {:e}", gaps[3]);
        // The peak converges more slowly: every harmonic adds to it directly.
        let peaks: Vec<f64> = all[4..].iter().map(|f| peak(&f[i], 0)).collect();
        assert!((peaks[1] - peaks[2]).abs() < 1e-9 * peaks[2], "{peaks:?}");
    }
    let single = one_harmonic_folds(DAMPING, FORCE);
    for (omega, _) in single {
        let near = reference
            .iter()
            .map(|f| (f.omega - omega).abs() / omega)
            .fold(f64::INFINITY, f64::min);
        assert!(near < 0.01, "one-harmonic fold {omega}: {near}");
    }
    let upper = reference
        .iter()
        .max_by(|a, b| a.omega.total_cmp(&b.omega))
        .unwrap();
    let a1 = first_harmonic_amplitude(upper, 0);
    let backbone = (1.0 + 0.75 * a1 * a1).sqrt();
    assert!(
        (upper.omega - backbone).abs() < 0.03 * backbone,
        "{} against {backbone}",
        upper.omega
    );
}

/// The two-DOF system with its cubic spring and Rayleigh damping `C = αM + βK`, forced at
/// dof 0 across both resonances: each bends over into a fold pair, and the four folds and the
/// responses at fixed frequencies converge in the number of harmonics.
#[test]
fn two_dof_converges_in_harmonics() {
    let system = nnm::model::two_dof(0.5).unwrap();
    let undamped = ForcedProblem::new(&system, Mat::zeros(2, 2), &[1.0, 0.0], &[0.0, 0.0], 1.0);
    let (k, m) = (undamped.tangent(&[0.0, 0.0]), undamped.mass().clone());
    let (alpha, beta) = (0.01, 0.01);
    let c = Mat::from_fn(2, 2, |i, j| alpha * m[(i, j)] + beta * k[(i, j)]);
    let problem = ForcedProblem::new(&system, c, &[1.0, 0.0], &[0.0, 0.0], 0.1);
    let all: Vec<Vec<Coefficients>> = [5, 7, 9, 13]
        .iter()
        .map(|&h| curve_and_folds(&problem, h, 2.5).1)
        .collect();
    let reference = all.last().unwrap();
    assert_eq!(reference.len(), 4);
    for (i, fold) in reference.iter().enumerate() {
        let gaps: Vec<f64> = all
            .iter()
            .map(|f| (f[i].omega - fold.omega).abs())
            .collect();
        let shown: Vec<String> = gaps.iter().map(|g| format!("{g:.1e}")).collect();
        println!(
            "fold Ω = {:.15}: |Ω_H − Ω_13|, H = 5, 7, 9, 13: {shown:?}",
            fold.omega
        );
        assert!(gaps[2] < 1e-11, "{gaps:?}");
    }
    for omega in [0.8, 1.3, 1.6, 2.2] {
        let amplitudes: Vec<Vec<f64>> = [7, 9, 13]
            .iter()
            .map(|&h| {
                let x = solve(&problem, omega, h, None).unwrap();
                vec![
                    first_harmonic_amplitude(&x, 0),
                    first_harmonic_amplitude(&x, 1),
                ]
            })
            .collect();
        for d in 0..2 {
            assert!(
                (amplitudes[1][d] - amplitudes[2][d]).abs() < 1e-11,
                "{amplitudes:?}"
            );
        }
    }
}

/// Hill's method against the curve's geometry: the branch between the folds (travelled
/// backwards in Ω) is unstable with a real positive exponent, the outer branches are stable,
/// and an exponent passes through zero at each fold. On the linear oscillator every exponent
/// has the real part `−c/2`.
#[test]
fn hill_stability_agrees_with_the_folds() {
    let linear = nnm::model::duffing(1.0, 0.0).unwrap();
    let problem = ForcedProblem::new(&linear, Mat::from_fn(1, 1, |_, _| 0.1), &[1.0], &[0.0], 1.0);
    for omega in [0.5, 1.0, 1.9] {
        let x = solve(&problem, omega, 5, None).unwrap();
        for (re, _) in floquet_exponents(&problem, &x).unwrap() {
            assert!((re + 0.05).abs() < 1e-12, "Ω = {omega}: {re}");
        }
    }

    let system = nnm::model::duffing(1.0, 1.0).unwrap();
    let problem = duffing_problem(&system);
    let (curve, folds) = curve_and_folds(&problem, 9, 3.5);
    let size = curve[0].solution.z.len();
    let mut unstable = 0;
    for p in &curve {
        let lambda = floquet_exponents(&problem, &p.solution).unwrap();
        let growth = lambda.iter().map(|l| l.0).fold(f64::NEG_INFINITY, f64::max);
        let backwards = p.tangent[size] < 0.0;
        assert_eq!(
            growth > 0.0,
            backwards,
            "Ω = {}: {lambda:?}",
            p.solution.omega
        );
        if backwards {
            unstable += 1;
            assert!(lambda.iter().any(|l| l.0 > 0.0 && l.1 == 0.0), "{lambda:?}");
        }
    }
    assert!(unstable > 3);
    for fold in &folds {
        let lambda = floquet_exponents(&problem, fold).unwrap();
        let smallest = lambda
            .iter()
            .map(|l| l.0.hypot(l.1))
            .fold(f64::INFINITY, f64::min);
        println!(
            "fold at Ω = {:.15}: smallest |λ| = {smallest:.1e}",
            fold.omega
        );
        assert!(smallest < 1e-9, "fold at {}: {lambda:?}", fold.omega);
    }
}

/// The peak helper against brute force: no sample of a fine grid exceeds it, and the grid's
/// best is within its spacing's second-order error.
#[test]
fn peak_is_the_maximum_over_the_period() {
    let system = nnm::model::duffing(1.0, 1.0).unwrap();
    let problem = ForcedProblem::new(
        &system,
        Mat::from_fn(1, 1, |_, _| 0.05),
        &[0.6],
        &[0.8],
        1.0,
    );
    let x = solve(&problem, 0.7, 9, None).unwrap();
    let p = peak(&x, 0);
    let samples = 200_000;
    let best = (0..samples)
        .map(|j| x.dof_at(0, 2.0 * std::f64::consts::PI * j as f64 / samples as f64)[0].abs())
        .fold(0.0f64, f64::max);
    assert!(
        best <= p * (1.0 + 1e-15) && p - best < 1e-8,
        "{p} against {best}"
    );
    assert!(
        p > 1.01 * first_harmonic_amplitude(&x, 0),
        "a case with visible harmonics"
    );
}
