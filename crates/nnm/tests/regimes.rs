//! What a branch did, said per point (docs/method.md §18): the regime (backbone, tongue, other
//! family) and the peak displacements, checked against an independent reading of the same
//! motions — explicit integration at 2,000 samples a period, its own projection on the linear
//! modes and its own discrete Fourier transform.
//!
//! The model: a fixed–free chain of five unit masses and unit springs with a cubic spring
//! `0.5 x_0³` from the first mass to ground. Its linear frequencies stand at 1 : 2.92 : 4.60 :
//! 5.91 : 6.74, so the hardening first backbone meets the second mode at three times its
//! frequency (+4% to +14%), and near +19% the fourth at seven times — where the branch turns
//! into that mode's family at a seventh of the period.

use std::f64::consts::PI;
use std::ops::ControlFlow;

use nnm::analysis::{RegimeKind, sample_motion};
use nnm::model::{PolynomialSpring, SparseMatrix, Structure};
use nnm::modes::linear_modes;
use nnm::{BranchPoint, Settings, Start, continue_branch};

fn fixed_free_chain() -> Structure {
    let n = 5;
    let mut k = Vec::new();
    for i in 0..n {
        k.push((i, i, if i + 1 < n { 2.0 } else { 1.0 }));
        if i + 1 < n {
            k.push((i, i + 1, -1.0));
            k.push((i + 1, i, -1.0));
        }
    }
    let mass = SparseMatrix::from_triplets(n, &(0..n).map(|i| (i, i, 1.0)).collect::<Vec<_>>());
    Structure::new(
        mass.unwrap(),
        SparseMatrix::from_triplets(n, &k).unwrap(),
        vec![Box::new(PolynomialSpring::cubic(0, None, 0.5))],
    )
    .unwrap()
}

/// Share of the time-averaged linear energy held by mode `c` at harmonic `k`, read from
/// `samples` states of one period (the closing one excluded) — written out here from the
/// definition, eq. (84), not with the library's `modal_content`.
fn independent_share(
    states: &[Vec<f64>],
    shapes: &[Vec<f64>],
    frequencies: &[f64],
    omega: f64,
    harmonics: usize,
    (c, k): (usize, usize),
) -> f64 {
    let count = states.len() - 1;
    let energy = |mode: usize, h: usize| {
        // M = I: the modal coordinate is the plain projection.
        let q: Vec<f64> = states[..count]
            .iter()
            .map(|z| (0..5).map(|i| shapes[mode][i] * z[i]).sum())
            .collect();
        let (re, im) = q.iter().enumerate().fold((0.0, 0.0), |(re, im), (j, qj)| {
            let phase = 2.0 * PI * (h * j) as f64 / count as f64;
            (re + qj * phase.cos(), im - qj * phase.sin())
        });
        let a = (re * re + im * im).sqrt() * if h == 0 { 1.0 } else { 2.0 } / count as f64;
        let w = frequencies[mode];
        if h == 0 {
            0.5 * w * w * a * a
        } else {
            0.25 * (w * w + (h as f64 * omega).powi(2)) * a * a
        }
    };
    let total: f64 = (0..5)
        .filter(|&m| frequencies[m] <= (harmonics as f64 + 0.5) * omega)
        .flat_map(|m| (0..=harmonics).map(move |h| (m, h)))
        .map(|(m, h)| energy(m, h))
        .sum();
    energy(c, k) / total
}

#[test]
fn the_chain_backbone_enters_a_3_to_1_tongue_then_leaves_for_a_7_to_1_family() {
    let chain = fixed_free_chain();
    let modes = linear_modes(&chain).unwrap();
    let start = Start::from_mode(&chain, 0).unwrap();
    let mut settings = Settings::default();
    settings.limits.max_points = 60;
    settings.limits.energy_max = 1e4;
    let branch = continue_branch(&chain, &start, &settings, |_| ControlFlow::Continue(())).unwrap();
    let points = &branch.points;
    let kind = |p: &BranchPoint| p.regime.unwrap().kind;
    let first = |wanted: RegimeKind| points.iter().position(|p| kind(p) == wanted).unwrap();
    let (tongue, other) = (first(RegimeKind::Tongue), first(RegimeKind::OtherFamily));
    assert!(tongue > 0 && kind(&points[0]) == RegimeKind::Backbone);
    assert!(
        tongue < other,
        "the 3:1 tongue comes first ({tongue}, {other})"
    );
    let t = points[tongue].regime.unwrap();
    assert_eq!((t.partner.unwrap().mode, t.ratio), (1, Some((3, 1))));
    let o = points[other].regime.unwrap();
    assert_eq!((o.partner.unwrap().mode, o.ratio), (3, Some((7, 1))));
    let shift = |p: &BranchPoint| p.frequency / start.omega - 1.0;
    assert!((0.03..0.06).contains(&shift(&points[tongue])));
    assert!((0.17..0.21).contains(&shift(&points[other])));

    // Independent reading of the motions at the backbone's start, the tongue and the other
    // family: shares to 1e-6 and peaks to the fine sampling's own accuracy.
    let shapes: Vec<Vec<f64>> = modes.iter().map(|m| m.shape.clone()).collect();
    let frequencies: Vec<f64> = modes.iter().map(|m| m.frequency).collect();
    for &index in &[0, tongue, other] {
        let p = &points[index];
        let samples = 2000;
        let states = sample_motion(&chain, &p.z0, p.period, samples, 1e-12).unwrap();
        for c in p.content.iter().take(3) {
            let share = independent_share(
                &states,
                &shapes,
                &frequencies,
                p.frequency,
                nnm::shooting::CONTENT_HARMONICS,
                (c.mode, c.harmonic),
            );
            assert!(
                (share - c.share).abs() < 1e-6,
                "point {index}: mode {} harmonic {}: {} vs independent {share}",
                c.mode,
                c.harmonic,
                c.share
            );
        }
        // The output dof is the first mode's largest entry: the free end.
        let sampled = states.iter().map(|z| z[4].abs()).fold(0.0, f64::max);
        let peak = p.peak_displacements[0];
        // Sampling misses the peak by at most ½|a|δt² ≈ ½ (7ω)² (T/2000/2)² relative.
        let resolution = 0.5 * (7.0 * PI / samples as f64).powi(2);
        assert!(
            peak >= sampled * (1.0 - 1e-9) && peak <= sampled * (1.0 + resolution),
            "point {index}: peak {peak} vs sampled {sampled}"
        );
        eprintln!(
            "point {index} ({:+.2}%): {:?}, peak {peak:.9} (sampled {sampled:.9})",
            100.0 * shift(p),
            p.regime.unwrap().kind
        );
    }
}
