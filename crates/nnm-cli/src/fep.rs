//! Frequency–energy plots of computed branches: their series, the events and regime changes
//! marked on them, and the key that says what the marks mean (docs/output.md).

use std::path::Path;

use anyhow::Result;
use nnm::analysis::{RegimeKind, regime_changes};
use nnm::bifurcation::{Event, EventKind};
use nnm::modes::LinearMode;
use nnm::{Branch, BranchPoint};
use nnm_plot::{
    FrequencyEnergyPlot, Line, LinePlot, Marker, MarkerShape, Series, SeriesPoint, palette_color,
};

use crate::compute::Outcome;

/// The energy axis of every frequency–energy plot: what the energy is, in the model's units.
pub const ENERGY_AXIS: &str = "total energy E = kinetic + potential (units of the model)";

/// The frequency axis in rad/s (rad per time unit of the model).
pub const FREQUENCY_AXIS: &str = "frequency ω (rad/s)";

/// The symbol of each kind of event.
fn event_shape(kind: EventKind) -> MarkerShape {
    match kind {
        EventKind::Fold => MarkerShape::Square,
        EventKind::BranchPoint => MarkerShape::Diamond,
        EventKind::PeriodDoubling => MarkerShape::Triangle,
        EventKind::NeimarkSacker => MarkerShape::Dot,
    }
}

/// Events as symbols on a frequency–energy plot (square fold, diamond branch point, triangle
/// period doubling, dot Krein collision), labelled F, BP, PD, NS when `labelled` (a plot of
/// a few branches; on one of dozens the labels would hide the curves).
pub fn event_markers<'a>(events: impl Iterator<Item = &'a Event>, labelled: bool) -> Vec<Marker> {
    events
        .map(|e| Marker {
            x: e.point.energy,
            y: e.point.frequency,
            label: if labelled {
                e.kind.abbreviation().into()
            } else {
                String::new()
            },
            shape: event_shape(e.kind),
        })
        .collect()
}

/// Where a branch enters an internal-resonance tongue or another family (docs/method.md eq.
/// (86)): a ring at the first point of each such stretch, labelled with the ratio (`3:1`,
/// `→3:1` for another family).
pub fn regime_markers(points: &[BranchPoint]) -> Vec<Marker> {
    regime_changes(points.iter().map(|p| p.regime.as_ref()))
        .into_iter()
        .filter_map(|k| {
            let (p, regime) = (&points[k], points[k].regime?);
            let ratio = regime
                .ratio
                .map_or(String::new(), |(m, n)| format!("{m}:{n}"));
            let label = match regime.kind {
                RegimeKind::Backbone => return None,
                RegimeKind::OtherFamily => format!("→{ratio}"),
                RegimeKind::Tongue => ratio,
            };
            Some(Marker {
                x: p.energy,
                y: p.frequency,
                label,
                shape: MarkerShape::Ring,
            })
        })
        .collect()
}

/// What the symbols present among `markers` mean, for the plot's key.
pub fn marker_key(markers: &[Marker]) -> String {
    let meanings = [
        (MarkerShape::Square, "F fold"),
        (MarkerShape::Diamond, "BP branch point"),
        (MarkerShape::Triangle, "PD period doubling"),
        (MarkerShape::Dot, "NS Krein collision"),
        (
            MarkerShape::Ring,
            "m:n internal resonance (→ onto its family)",
        ),
    ];
    meanings
        .iter()
        .filter(|(shape, _)| markers.iter().any(|m| m.shape == *shape))
        .map(|(shape, text)| format!("{} {text}", shape.glyph()))
        .collect::<Vec<_>>()
        .join("   ")
}

/// A branch as a frequency–energy series named `label`, its frequencies multiplied by `scale`.
pub fn series_of(label: &str, branch: &Branch, scale: f64) -> Series {
    Series {
        label: label.into(),
        points: branch
            .points
            .iter()
            .map(|p| SeriesPoint {
                energy: p.energy,
                frequency: p.frequency * scale,
                stable: p.floquet.stable,
            })
            .collect(),
        ..Default::default()
    }
}

/// The name of a branch on a plot: its mode's `(n,d)` label on a cyclic model, else its name.
fn curve_name(o: &Outcome, modes: &[LinearMode]) -> String {
    let cyclic = modes.iter().any(|m| m.cyclic.is_some());
    if cyclic && !o.info.mode_label.is_empty() && o.info.switched_from.is_none() {
        format!("{} ({})", o.info.name, o.info.mode_label)
    } else {
        o.info.name.clone()
    }
}

/// One frequency–energy plot of every branch that has points: `<stem>.png` and `<stem>.svg`.
pub fn plot(outcomes: &[Outcome], modes: &[LinearMode], stem: &Path, title: &str) -> Result<()> {
    if let Some(fep) = frequency_energy_plot(outcomes, modes, title, 1.0) {
        fep.write(stem)?;
    }
    Ok(())
}

/// `<stem>.png`/`.svg`: the amplitude–frequency backbone of every branch that has points, the
/// peak displacement of its first output dof against frequency (docs/output.md), stable
/// stretches solid and unstable ones dashed; nothing when no branch has a point.
pub fn amplitude_plot(outcomes: &[Outcome], modes: &[LinearMode], stem: &Path) -> Result<()> {
    let computed: Vec<(&Outcome, &Branch)> = outcomes
        .iter()
        .filter_map(|o| Some((o, o.result.as_ref().ok()?)))
        .filter(|(o, b)| !b.points.is_empty() && !o.info.output_dofs.is_empty())
        .collect();
    let mut lines = Vec::new();
    for (k, (o, branch)) in computed.iter().enumerate() {
        let color = Some(palette_color(k, computed.len()));
        let label = format!("{}, x{}", curve_name(o, modes), o.info.output_dofs[0]);
        let points = &branch.points;
        let mut start = 0;
        // Runs of equal stability sharing their end points, as on the frequency–energy plot.
        for end in 1..=points.len() {
            let stable = points[start].floquet.stable;
            if end < points.len() && points[end].floquet.stable == stable {
                continue;
            }
            let last = end.min(points.len() - 1);
            lines.push(Line {
                label: if start == 0 {
                    label.clone()
                } else {
                    String::new()
                },
                xy: points[start..=last]
                    .iter()
                    .map(|p| {
                        (
                            p.frequency,
                            p.peak_displacements.first().copied().unwrap_or(f64::NAN),
                        )
                    })
                    .collect(),
                dashed: !stable,
                color,
                ..Default::default()
            });
            start = end;
        }
    }
    if lines.is_empty() {
        return Ok(());
    }
    LinePlot {
        title: "Amplitude–frequency backbones (dashed: unstable)".into(),
        x_label: FREQUENCY_AXIS.into(),
        y_label: "peak displacement over the period (units of the model)".into(),
        lines,
        ..Default::default()
    }
    .write(stem)?;
    Ok(())
}

/// The frequency–energy plot of every branch that has points, one series per branch (named,
/// with its `(n,d)` on a cyclic model), its events and regime changes marked and explained,
/// frequencies multiplied by `scale` (1: rad/s, labelled so); `None` when no branch has a
/// point.
pub fn frequency_energy_plot(
    outcomes: &[Outcome],
    modes: &[LinearMode],
    title: &str,
    scale: f64,
) -> Option<FrequencyEnergyPlot> {
    let computed: Vec<(&Outcome, &Branch)> = outcomes
        .iter()
        .filter_map(|o| Some((o, o.result.as_ref().ok()?)))
        .filter(|(_, b)| !b.points.is_empty())
        .collect();
    if computed.is_empty() {
        return None;
    }
    let named: Vec<(String, &Branch)> = computed
        .iter()
        .map(|(o, branch)| (curve_name(o, modes), *branch))
        .collect();
    Some(branches_plot(&named, title, scale))
}

/// Events are labelled (F, BP, ...) on a plot with at most this many; beyond, their symbols
/// alone say what they are.
const LABELLED_EVENTS: usize = 20;

/// The frequency–energy plot of named branches: one series each, frequencies multiplied by
/// `scale`, their events and regime changes marked and explained in the key, the axes titled
/// with [`ENERGY_AXIS`] and [`FREQUENCY_AXIS`].
pub fn branches_plot(named: &[(String, &Branch)], title: &str, scale: f64) -> FrequencyEnergyPlot {
    let series = named
        .iter()
        .map(|(name, branch)| series_of(name, branch, scale))
        .collect();
    let events = named.iter().map(|(_, b)| b.events.len()).sum::<usize>();
    let mut markers = event_markers(
        named.iter().flat_map(|(_, b)| &b.events),
        events <= LABELLED_EVENTS,
    );
    markers.extend(named.iter().flat_map(|(_, b)| regime_markers(&b.points)));
    for m in &mut markers {
        m.y *= scale;
    }
    FrequencyEnergyPlot {
        title: title.into(),
        series,
        frequency_label: FREQUENCY_AXIS.into(),
        energy_label: ENERGY_AXIS.into(),
        marker_key: marker_key(&markers),
        markers,
        ..Default::default()
    }
}
