//! The forced resonance of (1,5) (docs/method.md §21): the travelling (1,5) backbone under
//! Rayleigh damping, each point's resonance force for an engine-order-5 excitation of the
//! blades by energy balance, and the forced response curves at three force levels chosen from
//! it — their phase resonances set beside the backbone and the predicted peaks. Numbers only;
//! the figure is `nnm run`'s response figure, the table is `report_forced`'s.

use std::path::Path;
use std::sync::Arc;

use anyhow::{Context, Result};
use nnm::analysis::EnergyBalance;
use nnm::forced::damping::Damping;
use nnm::forced::{
    Force, ResponseCurve, ResponseEventKind, ResponseSettings, Sweep, forced_response,
};
use nnm::model::{ForcedSystem, Structure};
use nnm::modes::LinearMode;
use nnm::shooting::Travel;
use nnm::{Branch, Settings};
use nnm_io::job::BranchJob;

use super::backbones::single_branch;
use crate::out_dir::create_dir;
use crate::resonance::{Backbone, ComputedBranch};

/// The pair, the engine order that drives it, and the blade dof of a sector.
pub(super) const PAIR: &str = "1,5";
const ENGINE_ORDER: usize = 5;
const BLADE: usize = 1;
/// Rayleigh damping `C = βK`: ζ = βω/2 ≈ 0.2% at (1,5).
pub(super) const BETA: f64 = 2e-3;
/// The frequency shifts of the backbone points whose resonance forces are the three levels.
pub(super) const SHIFTS: [f64; 3] = [0.01, 0.02, 0.03];
/// The sweep around the linear frequency, and how far the backbone is followed.
const SWEEP: (f64, f64) = (0.97, 1.05);
const BACKBONE_SHIFT: f64 = 0.04;

/// One force level: its curve and what it is compared with.
pub(super) struct Level {
    /// The backbone's frequency shift whose resonance force this level is.
    pub shift: f64,
    pub force: f64,
    /// `(frequency, blade peak)` of the backbone point energy balance predicts.
    pub predicted: (f64, f64),
    /// `(frequency, blade peak)` of the curve's phase resonance, and the backbone's peak
    /// at that frequency.
    pub phase_resonance: Option<(f64, f64, Option<f64>)>,
    pub curve: ResponseCurve,
    pub seconds: f64,
}

pub(super) struct Forced {
    pub backbone: Branch,
    pub linear_frequency: f64,
    /// ζ of (1,5) under `C = βK`.
    pub zeta: f64,
    pub levels: Vec<Level>,
}

/// The (1,5) travelling backbone with its resonance forces, then a forced curve at each of
/// the resonance forces of its points at [`SHIFTS`], into `out/forced`.
pub(super) fn compute(
    structure: &Structure,
    modes: &[LinearMode],
    settings: &Settings,
    out: &Path,
) -> Result<Forced> {
    let dir = out.join("forced");
    create_dir(&dir)?;
    let damping = Damping::Rayleigh([0.0, BETA])
        .matrix(structure)
        .map_err(anyhow::Error::msg)?;
    let force = Force::EngineOrder {
        engine_order: ENGINE_ORDER,
        amplitude: 1.0,
        sector_dof: BLADE,
    }
    .shape(structure)
    .map_err(anyhow::Error::msg)?;
    // To +4% whatever the study's energy limit (the levels are those of +1% to +3%).
    let mut settings = settings.clone();
    settings.limits.frequency_shift_max = BACKBONE_SHIFT;
    settings.limits.energy_max = f64::INFINITY;
    settings.output.output_dofs = vec![BLADE];
    settings.output.energy_balance = Some(Arc::new(
        EnergyBalance::new(damping.clone(), force.clone()).map_err(anyhow::Error::msg)?,
    ));
    let job = BranchJob {
        name: format!("travelling-{}", PAIR.replace(',', "-")),
        mode: PAIR.into(),
        from_event: None,
        pattern: None,
        travel: Some(Travel::Forward),
        settings: settings.clone(),
    };
    let backbone = single_branch(structure, modes, &job, &dir, |_| {
        std::ops::ControlFlow::Continue(())
    })?;
    let linear_frequency = nnm::modes::find_mode(modes, PAIR, None)
        .context("the pair (1,5)")?
        .1
        .frequency;
    // The backbone as `nnm run` sets it beside a response (the same interpolation, the same
    // figure), found once for the sweep's range.
    let computed = [ComputedBranch {
        name: &job.name,
        output_dofs: &[BLADE],
        points: &backbone.points,
        balance: settings.output.energy_balance.as_deref(),
    }];
    let range = |amplitude| Sweep::Frequency {
        from: SWEEP.0 * linear_frequency,
        to: SWEEP.1 * linear_frequency,
        amplitude,
    };
    let beside = Backbone::find(&computed, &range(1.0), BLADE, &force)
        .context("the (1,5) backbone has no point in the sweep's range")?;
    let system = ForcedSystem::new(structure, &damping, force.clone())?;
    let mut levels = Vec::new();
    let mut curves = Vec::new();
    for shift in SHIFTS {
        let target = linear_frequency * (1.0 + shift);
        let (force_level, peak) = beside
            .at_frequency(target)
            .with_context(|| format!("the (1,5) backbone does not reach +{shift}"))?;
        let sweep = range(force_level);
        let clock = std::time::Instant::now();
        let curve = forced_response(
            &system,
            sweep,
            &[BLADE],
            &ResponseSettings::default(),
            |_| std::ops::ControlFlow::Continue(()),
        )?;
        let seconds = clock.elapsed().as_secs_f64();
        let phase_resonance = curve
            .events
            .iter()
            .find(|e| e.kind == ResponseEventKind::PhaseResonance)
            .and_then(|e| {
                let peak = *e.point.peaks.first()?;
                let on = beside.peak_at(e.point.frequency);
                Some((e.point.frequency, peak, on))
            });
        curves.push((sweep, curve.clone()));
        levels.push(Level {
            shift,
            force: force_level,
            predicted: (target, peak),
            phase_resonance,
            curve,
            seconds,
        });
    }
    crate::response::plot(
        &format!("forced-{}", PAIR.replace(',', "-")),
        Some(BLADE),
        &curves,
        Some(&beside),
        out,
    )?;
    let zeta = 0.5 * BETA * linear_frequency;
    Ok(Forced {
        backbone,
        linear_frequency,
        zeta,
        levels,
    })
}
