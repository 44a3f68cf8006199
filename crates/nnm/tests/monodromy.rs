//! A monodromy accurate in every mode (docs/method.md eq. (31b)).
//!
//! Models whose frequencies spread widely, followed on a slow mode in the linear regime: the
//! motion hardly excites the fast modes, but the monodromy must still propagate them exactly,
//! or stability verdicts and events come from integration error. References are closed-form:
//! a chain's monodromy in its sine modes, and multipliers of modulus exactly 1.
//!
//! Run in the release profile: `cargo test --release -p nnm --test monodromy`.

use std::f64::consts::PI;
use std::ops::ControlFlow;

use nnm::integrate::{
    DOP853, DOPRI5, IntegrationMethod, Integrator, RungeKutta, Steps, Tolerances,
};
use nnm::model::{Block, PolynomialSpring, SparseMatrix, Structure};
use nnm::modes::linear_modes;
use nnm::{Branch, Settings, Start, continue_branch};

/// A fixed-fixed chain of `n` unit masses and unit springs (M = I, K = tridiag(−1, 2, −1)),
/// with a cubic spring `c x_0³` on the first mass; its frequencies `2 sin(kπ / 2(n+1))`
/// spread from `π/(n+1)` to nearly 2.
fn chain(n: usize, cubic: f64) -> Structure {
    let mut k = Vec::new();
    for i in 0..n {
        k.push((i, i, 2.0));
        if i + 1 < n {
            k.push((i, i + 1, -1.0));
            k.push((i + 1, i, -1.0));
        }
    }
    let mass = SparseMatrix::from_triplets(n, &(0..n).map(|i| (i, i, 1.0)).collect::<Vec<_>>());
    let stiffness = SparseMatrix::from_triplets(n, &k);
    Structure::new(
        mass.unwrap(),
        stiffness.unwrap(),
        vec![Box::new(PolynomialSpring::cubic(0, None, cubic))],
    )
    .unwrap()
}

/// The chain's exact monodromy over `t` (column-major, `2n × 2n`): in the sine modes
/// `v_k(j) = √(2/(n+1)) sin(jkπ/(n+1))` each mode is a rotation, `[[cos, sin/ω], [−ω sin, cos]]`.
fn chain_monodromy(n: usize, t: f64) -> Vec<f64> {
    let n2 = 2 * n;
    let mut phi = vec![0.0; n2 * n2];
    let norm = (2.0 / (n + 1) as f64).sqrt();
    let v = |j: usize, k: usize| norm * (((j + 1) * (k + 1)) as f64 * PI / (n + 1) as f64).sin();
    for k in 0..n {
        let w = 2.0 * ((k + 1) as f64 * PI / (2 * (n + 1)) as f64).sin();
        let (c, s) = ((w * t).cos(), (w * t).sin());
        let block = [[c, s / w], [-w * s, c]];
        for i in 0..n {
            for j in 0..n {
                let vv = v(i, k) * v(j, k);
                for (a, row) in block.iter().enumerate() {
                    for (b, &value) in row.iter().enumerate() {
                        phi[(b * n + j) * n2 + a * n + i] += vv * value;
                    }
                }
            }
        }
    }
    phi
}

/// The explicit pairs integrate the monodromy of chains of 20, 50 and 200 masses over the
/// slowest mode's period, started on that mode at a linear-regime amplitude, to 1e-6 of the
/// exact one in every entry (relative to its block's size): before the variational equations'
/// error was controlled, the step grew with the slow motion until the fast modes of `Φ` were
/// integrated at the edge of stability (a multiplier of modulus 3.18 on the 50-mass chain).
#[test]
fn explicit_monodromy_of_chains_is_exact_in_every_mode() {
    for (n, tableaus) in [
        (20, vec![&DOP853, &DOPRI5]),
        (50, vec![&DOP853, &DOPRI5]),
        (200, vec![&DOP853]),
    ] {
        let system = chain(n, 0.5);
        let n2 = 2 * n;
        let w0 = 2.0 * (PI / (2 * (n + 1)) as f64).sin();
        let period = 2.0 * PI / w0;
        let amplitude = 1e-6;
        let norm = (2.0 / (n + 1) as f64).sqrt();
        let mut z0 = vec![0.0; n2];
        for (j, x) in z0[..n].iter_mut().enumerate() {
            *x = amplitude * norm * ((j + 1) as f64 * PI / (n + 1) as f64).sin();
        }
        let eye: Vec<f64> = (0..n2 * n2)
            .map(|k| if k % (n2 + 1) == 0 { 1.0 } else { 0.0 })
            .collect();
        let exact = chain_monodromy(n, period);
        for tableau in tableaus {
            // The shooting's tolerances at its defaults: 1e-3 × the 1e-8 corrector tolerance.
            let tolerances = Tolerances {
                relative: 1e-11,
                absolute: 1e-11 * amplitude,
                velocity_scale: w0,
            };
            let mut integrator = RungeKutta::new(&system, tableau, tolerances);
            let flow = integrator
                .flow(
                    &z0,
                    period,
                    Some(Block::new(&eye, n2, n2, n2)),
                    Steps::Adaptive { first_step: None },
                )
                .unwrap();
            // Blocks: ∂x/∂x and ∂v/∂v are O(1), ∂x/∂v is O(1/ω), ∂v/∂x O(ω): each entry
            // against its block's largest exact entry.
            let mut worst = 0.0f64;
            for col in 0..n2 {
                for row in 0..n2 {
                    let scale = (0..n)
                        .flat_map(|i| (0..n).map(move |j| (i, j)))
                        .map(|(i, j)| {
                            let (r, c) = (row / n * n + i, col / n * n + j);
                            exact[c * n2 + r].abs()
                        })
                        .fold(0.0, f64::max);
                    let k = col * n2 + row;
                    worst = worst.max((flow.sensitivity[k] - exact[k]).abs() / scale);
                }
            }
            eprintln!(
                "chain of {n}, {}: {} steps ({} rejected by the sensitivities), worst relative entry error {worst:.2e}",
                tableau.name, flow.stats.steps, flow.stats.variational_rejections
            );
            assert!(worst < 1e-6, "chain of {n}, {}: {worst:.2e}", tableau.name);
        }
    }
}

/// Moduli of every non-trivial multiplier of every point.
fn moduli(branch: &Branch) -> Vec<f64> {
    branch
        .points
        .iter()
        .flat_map(|p| {
            let f = &p.floquet;
            f.multipliers
                .iter()
                .enumerate()
                .filter(|(i, _)| !f.trivial.contains(i))
                .map(|(_, z)| z.0.hypot(z.1))
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Two DOF with ω = 1 and √401 ≈ 20 (M = I, K = [[201, −200], [−200, 201]], a cubic spring on the
/// first), the slow mode in the linear regime: the fast pair's multipliers have modulus 1 to
/// 1e-6 under every integrator the automatic choice may take and every setting that changes
/// the integration (before: 0.012 with DOP853), and no event is reported. Radau IIA is not
/// among them: it damps unresolved fast modes by design (L-stable), the trade it makes for
/// fine finite-element meshes (docs/method.md §6).
#[test]
fn fast_pair_of_two_dof_stays_on_the_unit_circle_under_every_integrator() {
    let structure = Structure::new(
        nnm::Mat::identity(2, 2),
        nnm::Mat::from_fn(2, 2, |i, j| if i == j { 201.0 } else { -200.0 }),
        vec![Box::new(PolynomialSpring::cubic(0, None, 0.1))],
    )
    .unwrap();
    let modes = linear_modes(&structure).unwrap();
    assert!((modes[0].frequency - 1.0).abs() < 1e-12);
    assert!((modes[1].frequency - 401f64.sqrt()).abs() < 1e-12);
    let start = Start::from_linear_mode(&structure, &modes, 0, None).unwrap();
    for integrator in [
        IntegrationMethod::Auto,
        IntegrationMethod::Dop853,
        IntegrationMethod::Dopri5,
        IntegrationMethod::Gauss6,
        IntegrationMethod::Gauss4,
    ] {
        for (half_period, factor) in [(true, 1e-3), (false, 1e-3), (true, 1e-1)] {
            let mut settings = Settings::default();
            settings.limits.frequency_shift_max = 1e-4;
            settings.limits.max_points = 4;
            settings.integration.integrator = integrator;
            settings.integration.integration_factor = factor;
            settings.shooting.half_period = half_period;
            let branch =
                continue_branch(&structure, &start, &settings, |_| ControlFlow::Continue(()))
                    .unwrap();
            let worst = moduli(&branch)
                .iter()
                .map(|m| (m - 1.0).abs())
                .fold(0.0, f64::max);
            eprintln!(
                "{integrator:?}, half_period {half_period}, factor {factor:e}: worst | |μ| − 1 | = {worst:.1e}"
            );
            assert!(
                worst < 1e-6,
                "{integrator:?} {half_period} {factor}: {worst:.2e}"
            );
            assert!(
                branch.events.is_empty(),
                "{integrator:?}: {:?}",
                branch.events
            );
            assert!(branch.points.iter().all(|p| p.floquet.stable));
        }
    }
}
