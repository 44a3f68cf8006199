//! The study's bifurcation section (issue 4): the events located along the backbones, the
//! folds and Krein collisions of (1,14), and the family switched onto at the first branch
//! point of (1,5), a branch point made double by the degenerate pair (cos and sin waves).

use std::fmt::Write as _;
use std::path::Path;
use std::sync::Mutex;

use anyhow::{Context, Result, anyhow};
use nnm::analysis::sample_motion;
use nnm::bifurcation::{EventKind, switch_branch};
use nnm::continuation::{Branch, Settings};
use nnm::linalg;
use nnm::model::{SecondOrderSystem, Structure};
use nnm::modes::{LinearMode, StandingWave, find_mode};
use nnm_io::job::BranchJob;
use nnm_io::output::SwitchedFrom;
use nnm_plot::FrequencyEnergyPlot;

use super::{Report, series_of};
use crate::run::{Outcome, SWITCH_AMPLITUDE, compute_branch, event_markers, phase_name};

/// How far the switched family is followed (relative frequency rise).
const SWITCHED_SHIFT: f64 = 0.06;

fn count(branch: &Branch, kind: EventKind) -> usize {
    branch.events.iter().filter(|e| e.kind == kind).count()
}

fn energies(branch: &Branch, kind: EventKind) -> String {
    let list: Vec<String> = branch
        .events
        .iter()
        .filter(|e| e.kind == kind)
        .map(|e| format!("{:.6}", e.point.energy))
        .collect();
    if list.is_empty() {
        "none".into()
    } else {
        list.join(", ")
    }
}

/// Over a motion: the share of the sin partner's modal amplitude in the pair,
/// `⟨q_s²⟩ / ⟨q_c² + q_s²⟩`, and the travelling index `⟨q_c q̇_s - q_s q̇_c⟩ / (ω ⟨q_c² + q_s²⟩)`,
/// 0 for a standing wave (the two in phase) and ±1 for a wave travelling round the disk (the two
/// a quarter period apart with equal amplitudes).
fn pair_content(
    structure: &Structure,
    cos: &LinearMode,
    sin: &LinearMode,
    z0: &[f64],
    period: f64,
) -> Result<(f64, f64)> {
    let n = structure.dofs();
    let mass_times = |v: &[f64]| linalg::times(structure.mass().as_ref(), v);
    let (mc, ms) = (mass_times(&cos.shape), mass_times(&sin.shape));
    let states = sample_motion(structure, z0, period, 64, 1e-10)?;
    let (mut sin_power, mut power, mut momentum) = (0.0, 0.0, 0.0);
    for z in &states[..states.len() - 1] {
        let (x, v) = z.split_at(n);
        let (qc, qs) = (linalg::dot(&mc, x), linalg::dot(&ms, x));
        let (vc, vs) = (linalg::dot(&mc, v), linalg::dot(&ms, v));
        sin_power += qs * qs;
        power += qc * qc + qs * qs;
        momentum += qc * vs - qs * vc;
    }
    let omega = 2.0 * std::f64::consts::PI / period;
    Ok((sin_power / power, momentum / (omega * power)))
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
    let mass_times = |v: &[f64]| linalg::times(structure.mass().as_ref(), v);
    let (mx, mv) = (mass_times(x), mass_times(v));
    let energies: Vec<f64> = modes
        .iter()
        .map(|m| {
            let (q, w) = (linalg::dot(&m.shape, &mx), linalg::dot(&m.shape, &mv));
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

pub(super) fn bifurcations(
    structure: &Structure,
    modes: &[LinearMode],
    outcomes: &[Outcome],
    settings: &Settings,
    out: &Path,
    report: &mut Report,
) -> Result<()> {
    report.heading("Bifurcations along the backbones");
    report.line(
        "Every backbone was scanned for events between consecutive points: folds (sign of dE/ds), \
         branch points (a multiplier pair through +1), period doublings (through -1) and Krein \
         collisions (two pairs meeting on the unit circle and leaving it as a complex quadruplet, \
         listed as `neimark-sacker`). Each event was located by regula falsi on a smooth test \
         function, every trial corrected onto the branch, to 1e-8 in arclength. The events of \
         each branch are in `backbones/<name>.events.csv`.",
    );
    let mut table = String::from(
        "| backbone | folds | branch points | period doublings | Krein collisions | first event |\n|---|---|---|---|---|---|\n",
    );
    for o in outcomes {
        let Ok(branch) = &o.result else { continue };
        if branch.events.is_empty() {
            continue;
        }
        let first = &branch.events[0];
        let _ = writeln!(
            table,
            "| ({}) | {} | {} | {} | {} | {} at E = {:.6} |",
            o.info.mode_label,
            count(branch, EventKind::Fold),
            count(branch, EventKind::BranchPoint),
            count(branch, EventKind::PeriodDoubling),
            count(branch, EventKind::NeimarkSacker),
            first.kind.name(),
            first.point.energy
        );
    }
    let quiet = outcomes
        .iter()
        .filter(|o| o.result.as_ref().is_ok_and(|b| b.events.is_empty()))
        .count();
    report.line(&table);
    report.line(&format!(
        "{quiet} backbones have no event in the computed range."
    ));

    let find = |label: &str| {
        outcomes
            .iter()
            .find(|o| o.info.mode_label == label)
            .ok_or_else(|| anyhow!("backbone ({label}) missing"))
    };
    let b14 = find("1,14")?
        .result
        .as_ref()
        .map_err(|e| anyhow!("{e:#}"))?;
    report.line(&format!(
        "**(1,14): the S-fold and its stability changes.** Folds at E = {}; Krein collisions at \
         E = {}. Between the two folds the energy decreases along the branch (the middle, \
         unstable part of the S).",
        energies(b14, EventKind::Fold),
        energies(b14, EventKind::NeimarkSacker)
    ));

    // Switching at the first branch point of (1,5).
    let parent = find("1,5")?;
    let branch = parent.result.as_ref().map_err(|e| anyhow!("{e:#}"))?;
    let Some((k, event)) = branch
        .events
        .iter()
        .enumerate()
        .find(|(_, e)| e.kind == EventKind::BranchPoint)
    else {
        report.line("(1,5) has no branch point in the computed range: no switch.");
        return Ok(());
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
        energy_start: None,
        symmetry: false,
        settings: Settings {
            frequency_shift_max: SWITCHED_SHIFT,
            energy_max: f64::INFINITY,
            max_points: 60,
            ..settings.clone()
        },
    };
    let mut info = parent.info.clone();
    info.name = job.name.clone();
    info.symmetry = switch.start.symmetry;
    info.linear_frequency_rad_s = switch.start.omega;
    info.switched_from = Some(SwitchedFrom {
        branch: parent.info.name.clone(),
        event: k,
        direction: 0,
        kind: event.kind.name().into(),
        phase: phase_name(switch.start.phase.unwrap_or(settings.phase)).into(),
    });
    eprintln!("study: switching at the (1,5) branch point ...");
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
    let (parent_sin, parent_travel) =
        pair_content(structure, cos, sin, &event.point.z0, event.point.period)?;
    let mut rows = String::from(
        "| point | energy | frequency | sin share | travelling index | strongest other mode (energy share) | stable |\n|---|---|---|---|---|---|---|\n",
    );
    let mut contents = Vec::new();
    for p in switched.points.iter().step_by(2) {
        let (share, travel) = pair_content(structure, cos, sin, &p.z0, p.period)?;
        let (other, other_share) = strongest_other_mode(structure, modes, cos, &p.z0);
        contents.push((share, travel, other.label(), other_share));
        let _ = writeln!(
            rows,
            "| {} | {:.5} | {:.6} | {share:.3} | {travel:+.3} | ({}) {other_share:.3} | {} |",
            p.index,
            p.energy,
            p.frequency,
            other.label(),
            p.floquet.stable
        );
    }
    let multiplicity = event.multiplicity;
    report.line(&format!(
        "**(1,5): branch switching.** The first branch point of the (1,5) cos wave is at \
         E = {:.8}, f = {:.8} rad/s, where {} multiplier pair{} reach +1{}. The switch found {} null \
         direction{} of the unrestricted, full-period shooting Jacobian beside the parent's \
         tangent (smallest singular values {}), and followed the family along the first, posed \
         with the {} phase condition: {} points to +{:.0}% frequency. On the parent the sin wave's share of the (1,5) pair is \
         {parent_sin:.1e} and the travelling index {parent_travel:+.1e}; on the new family:",
        event.point.energy,
        event.point.frequency,
        multiplicity,
        if multiplicity == 1 { "" } else { "s" },
        if multiplicity == 1 {
            ""
        } else {
            " together (a bifurcation made degenerate by a symmetry; the first null direction \
             is followed, the others lead to further families)"
        },
        switch.null_directions,
        if switch.null_directions == 1 { "" } else { "s" },
        switch
            .singular_values
            .iter()
            .map(|v| format!("{v:.1e}"))
            .collect::<Vec<_>>()
            .join(", "),
        phase_name(switch.start.phase.unwrap_or(settings.phase)),
        switched.points.len(),
        100.0 * SWITCHED_SHIFT
    ));
    report.line(&rows);
    let breaks_mirror = contents.iter().all(|c| c.0 > 1e-3);
    let (parent_other, parent_share) = strongest_other_mode(structure, modes, cos, &event.point.z0);
    let last = contents.last().expect("at least one point");
    report.line(&if breaks_mirror {
        "The new motions carry the sin wave, which the cos-wave backbone never does: they break \
         the mirror symmetry of the standing wave. A travelling index between 0 and 1 means the \
         cos and sin parts are out of phase, so the vibration pattern turns round the disk as it \
         oscillates."
            .to_string()
    } else {
        let partner = modes
            .iter()
            .find(|m| m.label() == last.2)
            .map_or(f64::NAN, |m| m.frequency);
        format!(
            "The new motions leave the sin wave alone but mix in another standing wave: on the \
             backbone at the branch point the strongest mode besides the (1,5) cos wave is ({}) \
             with {parent_share:.1e} of the energy, while along the new family ({}) grows to \
             {:.3} of it. The new family is a coupled (1,5)–({}) motion ({} has the linear \
             frequency {partner:.6} rad/s, below the backbone's {:.6} at the branch point), \
             so it breaks the backbone's single-wave pattern.",
            parent_other.label(),
            last.2,
            last.3,
            last.2,
            last.2,
            event.point.frequency
        )
    });
    // The figure: (1,5), the switched family, the events as markers.
    let markers = event_markers(
        branch
            .events
            .iter()
            .chain(&switched.events)
            .filter(|e| e.point.frequency < cos.frequency * (1.0 + SWITCHED_SHIFT + 0.01)),
    );
    FrequencyEnergyPlot {
        title: "(1,5): backbone, branch points and the switched family".into(),
        series: vec![
            series_of("(1,5) backbone", branch, 1.0),
            series_of("switched at the first BP", &switched, 1.0),
        ],
        frequency_label: "frequency (rad/s)".into(),
        markers,
        // Zoom on the switch: from a third of the branch point's energy to past the end of
        // the switched family.
        x_range: Some((
            event.point.energy / 3.0,
            2.0 * switched
                .points
                .last()
                .map_or(event.point.energy, |p| p.energy),
        )),
        y_range: Some((
            cos.frequency * 0.995,
            cos.frequency * (1.0 + SWITCHED_SHIFT + 0.02),
        )),
    }
    .write(&out.join("bifurcations"))?;
    report.figure(
        "bifurcations.png",
        "The (1,5) backbone (dashed where unstable), its branch points (BP), and the family \
         switched onto at the first one, with its own Krein collisions (NS).",
    );
    Ok(())
}
