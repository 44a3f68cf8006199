//! The bifurcations along the backbones: the events located on each backbone, the
//! folds and Krein collisions of (1,14), and the family switched onto at the first branch
//! point of (1,5), a branch point made double by the degenerate pair (cos and sin waves), with
//! what the new motions are made of. Numbers only.

use crate::progress::say;
use std::path::Path;
use std::sync::Mutex;

use anyhow::{Context, Result, anyhow};
use nnm::analysis::sample_motion;
use nnm::bifurcation::{Event, EventKind, Switch, switch_branch};
use nnm::model::{MechanicalSystem, Structure};
use nnm::modes::{LinearMode, StandingWave, find_mode};
use nnm::{Branch, Settings};
use nnm_io::job::{BranchJob, SWITCH_AMPLITUDE, phase_name};
use nnm_io::output::SwitchedFrom;

use super::backbones::Backbones;
use crate::compute::{Outcome, compute_branch};

/// How far the switched family is followed (relative frequency rise).
pub(super) const SWITCHED_SHIFT: f64 = 0.06;

/// The events of one backbone, by kind.
pub(super) struct EventCounts {
    pub label: String,
    pub folds: usize,
    pub branch_points: usize,
    pub period_doublings: usize,
    pub krein_collisions: usize,
    /// The first event along the branch: its kind's name and energy.
    pub first: (&'static str, f64),
}

pub(super) struct Bifurcations<'a> {
    /// Backbones with at least one event, in the order computed.
    pub counts: Vec<EventCounts>,
    /// How many backbones have none.
    pub quiet: usize,
    /// Energies of the folds and Krein collisions of (1,14): its S-fold.
    pub s_folds: Vec<f64>,
    pub s_krein_collisions: Vec<f64>,
    /// The switch at the first branch point of (1,5); `None` if it has none.
    pub switched: Option<Switched<'a>>,
}

/// The family switched onto at a branch point, and what its motions are made of.
pub(super) struct Switched<'a> {
    pub parent: &'a Branch,
    pub event: &'a Event,
    pub switch: Switch,
    /// Name of the phase condition the new family is posed with.
    pub phase: &'static str,
    pub branch: Branch,
    /// Linear frequency of the parent's mode (the cos wave of the pair).
    pub linear_frequency: f64,
    /// The pair content on the parent at the event.
    pub parent_content: PairContent,
    /// The strongest mode besides the parent's at the event, and its share of the energy.
    pub parent_other: (String, f64),
    /// Every other point of the new family.
    pub points: Vec<SwitchedPoint>,
    /// Linear frequency of the strongest other mode at the family's last tabulated point.
    pub partner_frequency: f64,
}

impl Switched<'_> {
    /// Whether every new motion carries the sin wave, which the cos-wave backbone never does.
    pub fn breaks_mirror(&self) -> bool {
        self.points.iter().all(|p| p.content.sin_share > 1e-3)
    }

    pub fn last_point(&self) -> &SwitchedPoint {
        self.points.last().expect("at least one point")
    }
}

/// How a motion shares the degenerate pair of standing waves.
pub(super) struct PairContent {
    /// `⟨q_s²⟩ / ⟨q_c² + q_s²⟩`: the sin partner's share of the pair's modal amplitude.
    pub sin_share: f64,
    /// `⟨q_c q̇_s - q_s q̇_c⟩ / (ω ⟨q_c² + q_s²⟩)`: 0 for a standing wave (the two in phase),
    /// ±1 for a wave travelling round the disk (a quarter period apart, equal amplitudes).
    pub travelling: f64,
}

pub(super) struct SwitchedPoint {
    pub index: usize,
    pub energy: f64,
    pub frequency: f64,
    pub stable: bool,
    pub content: PairContent,
    /// The strongest mode besides the parent's and its share of the modal energy.
    pub other_label: String,
    pub other_share: f64,
}

fn count(branch: &Branch, kind: EventKind) -> usize {
    branch.events.iter().filter(|e| e.kind == kind).count()
}

fn energies(branch: &Branch, kind: EventKind) -> Vec<f64> {
    branch
        .events
        .iter()
        .filter(|e| e.kind == kind)
        .map(|e| e.point.energy)
        .collect()
}

/// Over a motion: the pair content of the cos and sin waves (see `PairContent`).
fn pair_content(
    structure: &Structure,
    cos: &LinearMode,
    sin: &LinearMode,
    z0: &[f64],
    period: f64,
) -> Result<PairContent> {
    let n = structure.dofs();
    let mass_times = |v: &[f64]| structure.mass_matrix().times(v);
    let (mc, ms) = (mass_times(&cos.shape), mass_times(&sin.shape));
    let states = sample_motion(structure, z0, period, 64, 1e-10)?;
    let (mut sin_power, mut power, mut momentum) = (0.0, 0.0, 0.0);
    for z in &states[..states.len() - 1] {
        let (x, v) = z.split_at(n);
        let (qc, qs) = (dot(&mc, x), dot(&ms, x));
        let (vc, vs) = (dot(&mc, v), dot(&ms, v));
        sin_power += qs * qs;
        power += qc * qc + qs * qs;
        momentum += qc * vs - qs * vc;
    }
    let omega = 2.0 * std::f64::consts::PI / period;
    Ok(PairContent {
        sin_share: sin_power / power,
        travelling: momentum / (omega * power),
    })
}

/// The linear mode other than `skip` that carries the largest share of the modal energy
/// `½ (ω_k² q_k² + q̇_k²)` at the state `z0`, and that share.
fn strongest_other_mode<'m>(
    structure: &Structure,
    modes: &'m [LinearMode],
    skip: &LinearMode,
    z0: &[f64],
) -> (&'m LinearMode, f64) {
    let (x, v) = z0.split_at(structure.dofs());
    let mass_times = |v: &[f64]| structure.mass_matrix().times(v);
    let (mx, mv) = (mass_times(x), mass_times(v));
    let energies: Vec<f64> = modes
        .iter()
        .map(|m| {
            let (q, w) = (dot(&m.shape, &mx), dot(&m.shape, &mv));
            0.5 * (m.frequency * m.frequency * q * q + w * w)
        })
        .collect();
    let total: f64 = energies.iter().sum();
    let (k, e) = energies
        .iter()
        .enumerate()
        .filter(|(k, _)| !std::ptr::eq(&modes[*k], skip))
        .max_by(|a, b| a.1.total_cmp(b.1))
        .expect("more than one mode");
    (&modes[k], e / total)
}

/// The events of every backbone, the S-fold of (1,14), and the switch at (1,5)'s first branch
/// point (its family computed into `out`).
pub(super) fn analyse<'a>(
    structure: &Structure,
    modes: &[LinearMode],
    backbones: &'a Backbones,
    settings: &Settings,
    out: &Path,
) -> Result<Bifurcations<'a>> {
    let counts = backbones
        .computed()
        .filter(|(_, b)| !b.events.is_empty())
        .map(|(o, branch)| {
            let first = &branch.events[0];
            EventCounts {
                label: o.info.mode_label.clone(),
                folds: count(branch, EventKind::Fold),
                branch_points: count(branch, EventKind::BranchPoint),
                period_doublings: count(branch, EventKind::PeriodDoubling),
                krein_collisions: count(branch, EventKind::NeimarkSacker),
                first: (first.kind.name(), first.point.energy),
            }
        })
        .collect();
    let quiet = backbones
        .computed()
        .filter(|(_, b)| b.events.is_empty())
        .count();
    let find = |label: &str| {
        backbones
            .outcomes
            .iter()
            .find(|o| o.info.mode_label == label)
            .ok_or_else(|| anyhow!("backbone ({label}) missing"))
    };
    let b14 = find("1,14")?
        .result
        .as_ref()
        .map_err(|e| anyhow!("{e:#}"))?;
    Ok(Bifurcations {
        counts,
        quiet,
        s_folds: energies(b14, EventKind::Fold),
        s_krein_collisions: energies(b14, EventKind::NeimarkSacker),
        switched: switch_at_first_branch_point(structure, modes, find("1,5")?, settings, out)?,
    })
}

/// Switches at the first branch point of the (1,5) backbone `parent` and follows the new
/// family a little (to `SWITCHED_SHIFT`); `None` if the backbone has no branch point.
fn switch_at_first_branch_point<'a>(
    structure: &Structure,
    modes: &[LinearMode],
    parent: &'a Outcome,
    settings: &Settings,
    out: &Path,
) -> Result<Option<Switched<'a>>> {
    let branch = parent.result.as_ref().map_err(|e| anyhow!("{e:#}"))?;
    let Some((k, event)) = branch
        .events
        .iter()
        .enumerate()
        .find(|(_, e)| e.kind == EventKind::BranchPoint)
    else {
        return Ok(None);
    };
    let parent_start = parent.start.as_ref().context("the (1,5) start")?;
    let switch = switch_branch(
        structure,
        parent_start,
        event,
        settings,
        SWITCH_AMPLITUDE,
        0,
    )
    .context("switching at the (1,5) branch point")?;
    let job = BranchJob {
        name: "mode-1-5-switched".into(),
        mode: String::new(),
        from_event: None,
        pattern: None,
        travel: None,
        settings: {
            let mut s = settings.clone();
            s.start.symmetry = false;
            s.limits.frequency_shift_max = SWITCHED_SHIFT;
            s.limits.energy_max = f64::INFINITY;
            s.limits.max_points = 60;
            s
        },
    };
    let phase = phase_name(switch.start.phase.unwrap_or(settings.shooting.phase));
    let mut info = parent.info.clone();
    info.name = job.name.clone();
    info.symmetry = switch.start.symmetry;
    info.linear_frequency_rad_s = switch.start.omega;
    info.switched_from = Some(SwitchedFrom {
        branch: parent.info.name.clone(),
        event: k,
        direction: 0,
        kind: event.kind.name().into(),
        phase: phase.into(),
    });
    say!("study: switching at the (1,5) branch point ...");
    let switched = compute_branch(
        structure,
        &switch.start,
        &job,
        &info,
        out,
        true,
        &Mutex::new(()),
        |_| std::ops::ControlFlow::Continue(()),
    )?;
    let (_, cos) = find_mode(modes, "1,5", Some(StandingWave::Cos)).context("(1,5) cos")?;
    let (_, sin) = find_mode(modes, "1,5", Some(StandingWave::Sin)).context("(1,5) sin")?;
    let parent_content = pair_content(structure, cos, sin, &event.point.z0, event.point.period)?;
    let points = switched
        .points
        .iter()
        .step_by(2)
        .map(|p| {
            let content = pair_content(structure, cos, sin, &p.z0, p.period)?;
            let (other, other_share) = strongest_other_mode(structure, modes, cos, &p.z0);
            Ok(SwitchedPoint {
                index: p.index,
                energy: p.energy,
                frequency: p.frequency,
                stable: p.floquet.stable,
                content,
                other_label: other.label(),
                other_share,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let (parent_other, parent_share) = strongest_other_mode(structure, modes, cos, &event.point.z0);
    // The first mode with the last point's label, as `modes.csv` lists it.
    let last = &points.last().expect("at least one point").other_label;
    let partner_frequency = modes
        .iter()
        .find(|m| m.label() == *last)
        .map_or(f64::NAN, |m| m.frequency);
    Ok(Some(Switched {
        parent: branch,
        event,
        switch,
        phase,
        branch: switched,
        linear_frequency: cos.frequency,
        parent_content,
        parent_other: (parent_other.label(), parent_share),
        points,
        partner_frequency,
    }))
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
