//! The 3:1 tongue: (0,6) continued past its fold, the harmonic content of every point, the
//! folds in energy, the junction where the fundamental vanishes (and the branch meets the
//! (1,12) family at a third of the period), and the motions at representative points. Numbers
//! only.

use crate::progress::say;
use std::f64::consts::PI;
use std::ops::ControlFlow;
use std::path::Path;
use std::time::Instant;

use anyhow::{Result, anyhow, bail};
use nnm::analysis::{harmonic_amplitudes, sample_motion};
use nnm::model::{MechanicalSystem, Structure};
use nnm::modes::{LinearMode, find_mode};
use nnm::shooting::JacobianMethod;
use nnm::{BranchPoint, BranchStats, Settings};
use nnm_io::job::BranchJob;

use super::SAMPLES;
use super::backbones::{lagrange, single_branch};
use crate::out_dir::create_dir;

/// Largest arclength step on the tongue (relative to the amplitude). The tongue runs close to
/// other branches near its root; with slow or far-off correctors rejected, steps of 0.02 to
/// 0.25 all follow it (fold at E = 1470.78, junction at 69.36). 0.05 resolves the junction well enough to see the energy minimum there and to
/// locate it to ~1e-8 (0.1: ~6e-7), for twice the cost of 0.1.
const TONGUE_MAX_STEP: f64 = 0.05;

/// A tongue point with the harmonic content of its motion.
pub(super) struct TonguePoint {
    pub point: BranchPoint,
    /// Fundamental, signed by its projection on the starting mode (its sign flips where it
    /// vanishes), that projection itself, and third harmonic.
    pub a1: f64,
    pub p1: f64,
    pub a3: f64,
}

pub(super) struct Tongue {
    pub points: Vec<TonguePoint>,
    /// Folds in energy (indices of local extrema) before the junction.
    pub folds: Vec<usize>,
    /// The junction: energy and frequency where the fundamental vanishes, by interpolation.
    pub junction: Option<(f64, f64)>,
    /// Wall time of the continuation (writing included, harmonic analysis excluded).
    pub seconds: f64,
    pub stats: BranchStats,
}

impl Tongue {
    /// Energy and frequency of the junction; `continue_tongue` fails without one.
    pub fn junction(&self) -> (f64, f64) {
        self.junction.expect("checked in continue_tongue()")
    }

    /// The tongue proper, from the first fold (where it leaves the backbone) to the junction:
    /// its start, its middle (where the third harmonic equals the fundamental) and its end,
    /// named M1–M3 (indices into `points`).
    pub fn representatives(&self) -> Result<[(&'static str, usize); 3]> {
        let first_fold = *self
            .folds
            .first()
            .ok_or_else(|| anyhow!("the tongue has no fold"))?;
        let last = self.points.len() - 1;
        let middle = (first_fold..=last)
            .min_by(|&a, &b| {
                let r = |k: usize| (self.points[k].a3 / self.points[k].a1.abs()).ln().abs();
                r(a).total_cmp(&r(b))
            })
            .unwrap_or(first_fold);
        let end = last.saturating_sub(1).max(first_fold);
        Ok([("M1", first_fold), ("M2", middle), ("M3", end)])
    }

    /// Lowest and highest energy of the tongue proper (from the first fold on), the
    /// junction's energy included.
    pub fn energy_span(&self) -> (f64, f64) {
        // The junction is only looked for once the branch has folded: there is a first fold.
        self.points[self.folds[0]..]
            .iter()
            .fold((self.junction().0, 0.0f64), |(a, b), t| {
                (a.min(t.point.energy), b.max(t.point.energy))
            })
    }
}

/// Relative difference of two runs' junction energies (`None` if either has none): how well
/// the two Jacobians agree on the result.
pub(super) fn junction_agreement(a: &Tongue, b: &Tongue) -> Option<f64> {
    let (a, b) = (a.junction?, b.junction?);
    Some((a.0 - b.0).abs() / a.0)
}

/// A motion over one period at a representative point of the tongue.
pub(super) struct Motion {
    pub name: &'static str,
    /// Index into `Tongue::points`.
    pub index: usize,
    pub energy: f64,
    pub frequency: f64,
    /// `SAMPLES + 1` states over the period.
    pub states: Vec<Vec<f64>>,
}

/// The motions at M1–M3 (see `Tongue::representatives`).
pub(super) fn representative_motions(
    structure: &Structure,
    tongue: &Tongue,
) -> Result<Vec<Motion>> {
    tongue
        .representatives()?
        .iter()
        .map(|&(name, k)| {
            let p = &tongue.points[k].point;
            Ok(Motion {
                name,
                index: k,
                energy: p.energy,
                frequency: p.frequency,
                states: sample_motion(structure, &p.z0, p.period, SAMPLES, 1e-10)?,
            })
        })
        .collect()
}

/// Real fundamental coefficient of the displacement (motions from rest are even in time, so
/// the coefficients are real) projected on `shape`, and the third-harmonic amplitude.
fn signed_harmonics(states: &[Vec<f64>], n: usize, shape: &[f64]) -> (f64, f64, f64) {
    let samples = states.len() - 1;
    let mut c1 = vec![0.0; n];
    for (j, z) in states[..samples].iter().enumerate() {
        let w = (2.0 * PI * j as f64 / samples as f64).cos() * 2.0 / samples as f64;
        for (c, x) in c1.iter_mut().zip(&z[..n]) {
            *c += w * x;
        }
    }
    let norm = shape.iter().map(|s| s * s).sum::<f64>().sqrt();
    let projection: f64 = c1.iter().zip(shape).map(|(c, s)| c * s).sum::<f64>() / norm;
    let magnitude = c1.iter().map(|c| c * c).sum::<f64>().sqrt();
    let a3 = harmonic_amplitudes(states, n, 3)[2];
    (magnitude.copysign(projection), projection, a3)
}

/// Where the fundamental's projection vanishes between the last two of `points` (and `next`),
/// by quadratic interpolation along the branch through the last three points: energy and
/// frequency there. The junction sits at the tongue's energy minimum, where linear
/// interpolation in energy would be biased upwards.
fn junction_between(points: &[TonguePoint], next: &TonguePoint) -> (f64, f64) {
    let mut chain: Vec<&TonguePoint> = points.iter().rev().take(2).collect();
    chain.reverse();
    chain.push(next);
    let along = |f: &dyn Fn(&TonguePoint) -> f64| -> Vec<(f64, f64)> {
        chain
            .iter()
            .enumerate()
            .map(|(k, t)| (k as f64, f(t)))
            .collect()
    };
    let projection = along(&|t| t.p1);
    let (mut lo, mut hi) = ((chain.len() - 2) as f64, (chain.len() - 1) as f64);
    let sign_lo = lagrange(&projection, lo).signum();
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if lagrange(&projection, mid).signum() == sign_lo {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let s = 0.5 * (lo + hi);
    (
        lagrange(&along(&|t| t.point.energy), s),
        lagrange(&along(&|t| t.point.frequency), s),
    )
}

/// Stop reason in the tongue's files: the continuation is stopped on purpose where the tongue
/// meets (1,12) (it would turn back onto a phase-shifted copy), which is not an interrupt.
const JUNCTION_STOP: &str = "reached the junction with (1,12)";

/// Continues (0,6) past its fold along the tongue until the fundamental changes sign (the
/// junction with the (1,12) family at a third of the period). Files go to `out`.
pub(super) fn continue_tongue(
    structure: &Structure,
    modes: &[LinearMode],
    settings: &Settings,
    jacobian: JacobianMethod,
    out: &Path,
) -> Result<Tongue> {
    create_dir(out)?;
    let n = structure.dofs();
    let (_, start_mode) = find_mode(modes, "0,6", None).expect("checked");
    let job = BranchJob {
        name: "tongue-0-6".into(),
        mode: "0,6".into(),
        from_event: None,
        pattern: None,
        travel: None,
        settings: {
            let mut s = settings.clone();
            s.limits.energy_max = f64::INFINITY;
            s.limits.frequency_shift_max = f64::INFINITY;
            s.limits.max_points = 1000;
            s.continuation.max_step = TONGUE_MAX_STEP;
            s.shooting.jacobian = jacobian;
            // The tongue's own fold and junction analysis follows; the cost comparison wants
            // the same work from both Jacobians.
            s.stability.events = false;
            s
        },
    };
    let mut points: Vec<TonguePoint> = Vec::new();
    let mut folds = Vec::new();
    let mut junction = None;
    let mut failure = None;
    let label = match jacobian {
        JacobianMethod::Sensitivity => "sensitivity",
        JacobianMethod::FiniteDifference => "finite differences",
    };
    say!("study: the (0,6) tongue ({label}) ...");
    let started = Instant::now();
    // Time spent on the harmonic analysis of each point, left out of the continuation's cost.
    let mut analysis_seconds = 0.0;
    let branch = single_branch(structure, modes, &job, out, |p| {
        let analysis_started = Instant::now();
        let states = match sample_motion(structure, &p.z0, p.period, SAMPLES, 1e-10) {
            Ok(s) => s,
            Err(e) => {
                failure = Some(e);
                return ControlFlow::Break("failed to sample the motion");
            }
        };
        let (a1, p1, a3) = signed_harmonics(&states, n, &start_mode.shape);
        let next = TonguePoint {
            point: p.clone(),
            a1,
            p1,
            a3,
        };
        if let [.., before, last] = points.as_slice() {
            let rising = |a: &TonguePoint, b: &TonguePoint| b.point.energy > a.point.energy;
            if rising(before, last) != rising(last, &next) {
                folds.push(points.len() - 1);
            }
        }
        let crossed = points
            .last()
            .is_some_and(|last| !folds.is_empty() && last.p1 * p1 < 0.0);
        if crossed {
            junction = Some(junction_between(&points, &next));
        }
        points.push(next);
        if points.len() % 20 == 0 {
            say!(
                "study: tongue ({label}) point {}: E = {:.4e}, f = {:.6}, A3/A1 = {:.3}",
                points.len(),
                p.energy,
                p.frequency,
                a3 / a1.abs()
            );
        }
        analysis_seconds += analysis_started.elapsed().as_secs_f64();
        if crossed {
            ControlFlow::Break(JUNCTION_STOP)
        } else {
            ControlFlow::Continue(())
        }
    })?;
    if let Some(e) = failure {
        return Err(e.into());
    }
    if junction.is_none() {
        bail!(
            "the (0,6) tongue did not reach the junction with (1,12) ({} points, {})",
            branch.points.len(),
            branch.stop
        );
    }
    Ok(Tongue {
        points,
        folds,
        junction,
        seconds: started.elapsed().as_secs_f64() - analysis_seconds,
        stats: branch.stats,
    })
}
