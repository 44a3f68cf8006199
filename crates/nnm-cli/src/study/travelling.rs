//! Travelling waves of the study (docs/method.md §17): the (1,5) and (1,14) travelling-wave
//! branches beside their standing waves, and how each motion moves in the plane of its pair's
//! two standing waves. Numbers only; `figures` and `report` present them.

use std::path::Path;

use anyhow::Result;
use nnm::analysis::sample_motion;
use nnm::model::{MechanicalSystem, Structure};
use nnm::modes::{LinearMode, StandingWave, find_mode};
use nnm::shooting::Travel;
use nnm::{Branch, BranchPoint, Settings};
use nnm_io::job::BranchJob;

use super::backbones::{Backbones, frequency_at, single_branch};
use super::{SAMPLES, StudyOptions};
use crate::out_dir::create_dir;

/// The pairs whose travelling waves are computed: the switch's (1,5) and the localizing (1,14).
pub(super) const TRAVELLING_MODES: [&str; 2] = ["1,5", "1,14"];

/// One pair's travelling wave and its standing wave.
pub(super) struct Wave {
    pub label: String,
    pub branch: Branch,
    pub seconds: f64,
    /// Energy at which the two are compared: the travelling wave's last point, or the
    /// standing wave's last energy if lower.
    pub energy: f64,
    /// Frequencies there (rad/s): travelling, standing (`None` where a branch folds there:
    /// its frequency at that energy is not unique).
    pub frequencies: (Option<f64>, Option<f64>),
    /// The motions over one period at `energy` in the pair's plane, `(q_cos, q_sin)` with
    /// `q = φᵀ M x` (mass-normalised modes): the travelling wave's and the standing wave's.
    pub orbits: [Vec<(f64, f64)>; 2],
}

pub(super) struct Travelling {
    pub waves: Vec<Wave>,
}

/// Continues the forward travelling wave of each of [`TRAVELLING_MODES`] with the study's
/// settings (to at most +10% frequency in quick mode), into `out/travelling`.
pub(super) fn compute(
    structure: &Structure,
    modes: &[LinearMode],
    backbones: &Backbones,
    settings: &Settings,
    options: &StudyOptions,
    out: &Path,
) -> Result<Travelling> {
    let dir = out.join("travelling");
    create_dir(&dir)?;
    let mut settings = settings.clone();
    if options.quick {
        settings.limits.frequency_shift_max = settings.limits.frequency_shift_max.min(0.1);
    }
    let mut waves = Vec::new();
    for label in TRAVELLING_MODES {
        let job = BranchJob {
            name: format!("travelling-{}", label.replace(',', "-")),
            mode: label.into(),
            from_event: None,
            pattern: None,
            travel: Some(Travel::Forward),
            settings: settings.clone(),
        };
        let clock = std::time::Instant::now();
        let branch = single_branch(structure, modes, &job, &dir, |_| {
            std::ops::ControlFlow::Continue(())
        })?;
        let seconds = clock.elapsed().as_secs_f64();
        let standing = backbones.branch(label);
        let last = branch.points.last().expect("a branch has points");
        let standing_last = standing.points.last().expect("a branch has points");
        let energy = last.energy.min(standing_last.energy);
        let frequencies = (
            frequency_at(&branch, energy),
            frequency_at(standing, energy),
        );
        let pair = |wave| find_mode(modes, label, Some(wave)).expect("a pair").1;
        let (cos, sin) = (pair(StandingWave::Cos), pair(StandingWave::Sin));
        let orbit = |point: &BranchPoint| plane_orbit(structure, point, cos, sin);
        let orbits = [
            orbit(nearest(&branch, energy))?,
            orbit(nearest(standing, energy))?,
        ];
        waves.push(Wave {
            label: label.into(),
            branch,
            seconds,
            energy,
            frequencies,
            orbits,
        });
    }
    Ok(Travelling { waves })
}

/// The point of `branch` whose energy is nearest `energy` (in `log E`).
fn nearest(branch: &Branch, energy: f64) -> &BranchPoint {
    branch
        .points
        .iter()
        .min_by(|a, b| {
            let d = |p: &BranchPoint| (p.energy / energy).ln().abs();
            d(a).total_cmp(&d(b))
        })
        .expect("a branch has points")
}

/// `(φ_cosᵀ M x(t), φ_sinᵀ M x(t))` over one period: a line for a standing wave, a closed
/// curve round the origin (a circle in the linear limit) for a travelling one.
fn plane_orbit(
    structure: &Structure,
    point: &BranchPoint,
    cos: &LinearMode,
    sin: &LinearMode,
) -> Result<Vec<(f64, f64)>> {
    let states = sample_motion(structure, &point.z0, point.period, SAMPLES, 1e-10)?;
    let n = structure.dofs();
    let mass = structure.mass_matrix();
    let (m_cos, m_sin) = (mass.times(&cos.shape), mass.times(&sin.shape));
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    Ok(states
        .iter()
        .map(|z| (dot(&m_cos, &z[..n]), dot(&m_sin, &z[..n])))
        .collect())
}
