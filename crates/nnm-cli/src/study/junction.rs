//! The tongue's junction checked from the other side: the (1,12) backbone, finely sampled, at
//! the junction's energy (three times the tongue's frequency should match it), and the energies
//! where a (1,12) Floquet multiplier passes exp(±2πi/3) — period tripling, the bifurcation the
//! tongue ends at. Numbers only.

use crate::progress::say;
use std::f64::consts::PI;
use std::ops::ControlFlow;
use std::path::Path;

use anyhow::{Result, anyhow};
use nnm::model::Structure;
use nnm::modes::{LinearMode, find_mode};
use nnm::{Branch, BranchPoint, Settings};
use nnm_io::job::BranchJob;

use super::backbones::{frequency_at, single_branch};
use super::tongue::Tongue;

/// Largest step on the (1,12) backbone the tongue is compared with: finely sampled, so that
/// interpolating its frequency at the junction's energy is accurate to ~1e-8.
const REFERENCE_MAX_STEP: f64 = 0.03;

pub(super) struct JunctionCheck {
    /// The (1,12) backbone, finely sampled up to three times the junction's energy.
    pub reference: Branch,
    /// Its frequency at the junction's energy.
    pub reference_frequency: f64,
    /// Three times the tongue's frequency at the junction minus `reference_frequency`.
    pub mismatch: f64,
    /// Energies along `reference` where a multiplier pair passes exp(±2πi/3), each once.
    pub tripling_crossings: Vec<f64>,
    /// The crossing nearest the junction: the bifurcation the tongue ends at (the others
    /// belong to other perturbation directions).
    pub tripling: Option<f64>,
    /// Ratio of the (1,12) and (0,6) linear frequencies: far from 3, the resonance is made by
    /// the hardening.
    pub linear_ratio: f64,
}

/// Checks `tongue`'s junction against the (1,12) backbone, computed into `out`.
pub(super) fn check(
    structure: &Structure,
    modes: &[LinearMode],
    tongue: &Tongue,
    settings: &Settings,
    out: &Path,
) -> Result<JunctionCheck> {
    let (e_junction, f_junction) = tongue.junction();
    say!("study: the (1,12) backbone near the junction ...");
    let job = BranchJob {
        name: "mode-1-12-fine".into(),
        mode: "1,12".into(),
        from_event: None,
        pattern: None,
        travel: None,
        settings: {
            let mut s = settings.clone();
            s.limits.energy_max = 3.0 * e_junction;
            s.limits.frequency_shift_max = f64::INFINITY;
            s.continuation.max_step = REFERENCE_MAX_STEP;
            s.stability.events = false;
            s
        },
    };
    let reference = single_branch(structure, modes, &job, out, |_| ControlFlow::Continue(()))?;
    let reference_frequency = frequency_at(&reference, e_junction)
        .ok_or_else(|| anyhow!("the (1,12) backbone does not reach E = {e_junction}"))?;
    let tripling_crossings = tripling_crossings(&reference);
    let tripling = tripling_crossings
        .iter()
        .copied()
        .min_by(|a, b| (a - e_junction).abs().total_cmp(&(b - e_junction).abs()));
    let frequency =
        |label: &str| modes[find_mode(modes, label, None).expect("checked").0].frequency;
    Ok(JunctionCheck {
        mismatch: 3.0 * f_junction - reference_frequency,
        reference,
        reference_frequency,
        tripling_crossings,
        tripling,
        linear_ratio: frequency("1,12") / frequency("0,6"),
    })
}

/// Energies along `branch` where a non-trivial Floquet multiplier on the unit circle passes
/// exp(±2πi/3), by linear interpolation of its angle between consecutive points.
fn tripling_crossings(branch: &Branch) -> Vec<f64> {
    let angle_offset = |p: &BranchPoint, k: usize| -> f64 {
        let (re, im) = p.floquet.multipliers[k];
        im.atan2(re).abs() - 2.0 * PI / 3.0
    };
    let mut crossings = Vec::new();
    for w in branch.points.windows(2) {
        let count = w[0]
            .floquet
            .multipliers
            .len()
            .min(w[1].floquet.multipliers.len());
        // Multipliers are sorted by modulus, so index k is not the same multiplier on both
        // sides; pair each of the first point's with the nearest of the second's.
        // One member of each conjugate pair, on the unit circle (a period-tripling
        // multiplier of a conservative orbit lies on it).
        let on_circle = |p: &BranchPoint, k: usize| {
            let (re, im) = p.floquet.multipliers[k];
            !p.floquet.trivial.contains(&k) && im > 0.0 && (re.hypot(im) - 1.0).abs() < 1e-3
        };
        for k in (0..count).filter(|&k| on_circle(&w[0], k)) {
            let (re, im) = w[0].floquet.multipliers[k];
            let Some(j) = (0..count)
                .filter(|&j| on_circle(&w[1], j))
                .min_by(|&a, &b| {
                    let d = |j: usize| {
                        let (r2, i2) = w[1].floquet.multipliers[j];
                        (r2 - re).hypot(i2 - im)
                    };
                    d(a).total_cmp(&d(b))
                })
            else {
                continue;
            };
            let (a, b) = (angle_offset(&w[0], k), angle_offset(&w[1], j));
            if a * b < 0.0 {
                let t = a / (a - b);
                let e = w[0].energy + t * (w[1].energy - w[0].energy);
                // Degenerate (±d) pairs cross together: count each energy once.
                if !crossings
                    .iter()
                    .any(|&c: &f64| (c - e).abs() <= 1e-6 * e.abs())
                {
                    crossings.push(e);
                }
            }
        }
    }
    crossings
}
