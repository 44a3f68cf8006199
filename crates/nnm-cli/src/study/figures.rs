//! Every figure the study draws (PNG and SVG through nnm-plot), from the sections' numbers.
//! Ranges, labels and markers are chosen here; what is plotted is computed elsewhere.

use std::path::Path;

use anyhow::Result;
use nnm::model::{MechanicalSystem, Structure};
use nnm::modes::{LinearMode, find_mode};
use nnm::{Branch, BranchPoint};
use nnm_plot::{
    FrequencyEnergyPlot, Line, LinePlot, Marker, MarkerShape, PlotGrid, Series, SeriesPoint,
};

use super::SAMPLES;
use super::backbones::Backbones;
use super::bifurcations::{SWITCHED_SHIFT, Switched};
use super::junction::JunctionCheck;
use super::localization::Localization;
use super::tongue::{Motion, Tongue};
use crate::fep::{
    FREQUENCY_AXIS, branches_plot, event_markers, marker_key, regime_markers, series_of,
};

/// Modes whose shapes are drawn (the paper's Figure 3).
pub(super) const SHAPE_MODES: [&str; 4] = ["0,1", "0,15", "1,5", "1,14"];

/// The energy axis of the study's plots: the disk's model is dimensionless (`M = K = 1`).
const ENERGY_AXIS: &str = "total energy E = kinetic + potential (dimensionless)";

/// `mode-shapes`: disk and blade amplitude per sector of each of `SHAPE_MODES`.
pub(super) fn mode_shapes(structure: &Structure, modes: &[LinearMode], out: &Path) -> Result<()> {
    let sectors = structure.dofs() / 2;
    let panels = SHAPE_MODES
        .iter()
        .map(|label| {
            let (_, m) = find_mode(modes, label, None).expect("checked");
            let line = |name: &str, offset: usize| Line {
                label: name.into(),
                xy: (0..sectors)
                    .map(|i| ((i + 1) as f64, m.shape[2 * i + offset]))
                    .collect(),
                ..Default::default()
            };
            LinePlot {
                title: format!("mode ({label}), {:.3} rad/s", m.frequency),
                x_label: "sector".into(),
                y_label: "amplitude".into(),
                lines: vec![line("disk", 0), line("blade", 1)],
                ..Default::default()
            }
        })
        .collect();
    PlotGrid {
        title: "Linear mode shapes (mass-normalised)".into(),
        columns: 2,
        panels,
    }
    .write(&out.join("mode-shapes"))?;
    Ok(())
}

/// `fep-backbones`: the frequency–energy plot of every backbone, each named `(n,d)` (at its
/// end when there are too many for a legend), with its events and regime changes marked.
pub(super) fn backbones(backbones: &Backbones, out: &Path) -> Result<()> {
    let named: Vec<(String, &Branch)> = backbones
        .computed()
        .map(|(o, branch)| (format!("({})", o.info.mode_label), branch))
        .collect();
    FrequencyEnergyPlot {
        energy_label: ENERGY_AXIS.into(),
        ..branches_plot(&named, "Backbones of the bladed disk", 1.0)
    }
    .write(&out.join("fep-backbones"))?;
    Ok(())
}

/// `localization`: the top-3 share along the backbone against the standing wave's;
/// `localized-motion`: every blade and disk over one period at the most localized point.
pub(super) fn localization(localization: &Localization, out: &Path) -> Result<()> {
    let shares = &localization.points;
    let base = localization.standing_wave_share;
    LinePlot {
        title: "Localization along the (1,14) backbone".into(),
        x_label: ENERGY_AXIS.into(),
        y_label: "share of energy in the 3 most energetic sectors".into(),
        log_x: true,
        lines: vec![
            Line {
                label: "(1,14)".into(),
                xy: shares.iter().map(|s| (s.energy, s.top3_share)).collect(),
                ..Default::default()
            },
            Line {
                label: "linear standing wave".into(),
                xy: vec![
                    (shares[0].energy, base),
                    (shares[shares.len() - 1].energy, base),
                ],
                reference: true,
                ..Default::default()
            },
        ],
        ..Default::default()
    }
    .write(&out.join("localization"))?;
    let (states, sectors, peak) = (
        &localization.peak_motion,
        localization.sectors,
        &localization.peak,
    );
    // Only the sectors that move are named: the legend stays short and says where the motion
    // is localized.
    let amplitude = |i: usize, offset: usize| {
        states
            .iter()
            .map(|z| z[2 * i + offset].abs())
            .fold(0.0, f64::max)
    };
    let panel = |offset: usize, what: &str| {
        let largest = (0..sectors)
            .map(|i| amplitude(i, offset))
            .fold(0.0, f64::max);
        LinePlot {
            title: format!("{what} displacements, {sectors} sectors (named: the moving ones)"),
            x_label: "t / T".into(),
            y_label: "displacement".into(),
            lines: (0..sectors)
                .map(|i| Line {
                    label: if amplitude(i, offset) >= 0.1 * largest {
                        format!("sector {}", i + 1)
                    } else {
                        String::new()
                    },
                    xy: states
                        .iter()
                        .enumerate()
                        .map(|(k, z)| (k as f64 / SAMPLES as f64, z[2 * i + offset]))
                        .collect(),
                    ..Default::default()
                })
                .collect(),
            ..Default::default()
        }
    };
    PlotGrid {
        title: format!(
            "Localized NNM motion of (1,14) at E = {:.3}, {:.4} rad/s",
            peak.energy, peak.frequency
        ),
        columns: 2,
        panels: vec![panel(1, "blade"), panel(0, "disk")],
    }
    .write(&out.join("localized-motion"))?;
    Ok(())
}

/// `bifurcations`: the parent backbone, the switched family and their events, zoomed on the
/// switch.
pub(super) fn bifurcations(switched: &Switched, out: &Path) -> Result<()> {
    let (event, linear) = (switched.event, switched.linear_frequency);
    let markers = event_markers(
        switched
            .parent
            .events
            .iter()
            .chain(&switched.branch.events)
            .filter(|e| e.point.frequency < linear * (1.0 + SWITCHED_SHIFT + 0.01)),
        true,
    );
    FrequencyEnergyPlot {
        title: "(1,5): backbone, branch points and the switched family".into(),
        series: vec![
            series_of("(1,5) backbone", switched.parent, 1.0),
            series_of("switched at the first BP", &switched.branch, 1.0),
        ],
        frequency_label: FREQUENCY_AXIS.into(),
        energy_label: ENERGY_AXIS.into(),
        marker_key: marker_key(&markers),
        markers,
        // Zoom on the switch: from a third of the branch point's energy to past the end of
        // the switched family.
        x_range: Some((
            event.point.energy / 3.0,
            2.0 * switched
                .branch
                .points
                .last()
                .map_or(event.point.energy, |p| p.energy),
        )),
        y_range: Some((linear * 0.995, linear * (1.0 + SWITCHED_SHIFT + 0.02))),
        ..Default::default()
    }
    .write(&out.join("bifurcations"))?;
    Ok(())
}

/// `tongue`: the (0,6) backbone, the tongue and the (1,12) backbone at a third of its
/// frequency, zoomed on the tongue; `tongue-harmonics`: fundamental and third harmonic along
/// the branch; `tongue-motions`: the motions at M1–M3.
pub(super) fn tongue(
    tongue: &Tongue,
    junction: &JunctionCheck,
    motions: &[Motion],
    backbone_0_6: &Branch,
    out: &Path,
) -> Result<()> {
    let (e_junction, _) = tongue.junction();
    let tongue_points: Vec<BranchPoint> = tongue.points.iter().map(|t| t.point.clone()).collect();
    let mut markers: Vec<Marker> = motions
        .iter()
        .map(|m| Marker {
            x: m.energy,
            y: m.frequency,
            label: m.name.to_string(),
            shape: MarkerShape::Dot,
        })
        .collect();
    let motions_key = format!(
        "{} M1–M3 motions (tongue-motions.png)",
        MarkerShape::Dot.glyph()
    );
    let regimes = regime_markers(&tongue_points);
    let key = format!("{motions_key}   {}", marker_key(&regimes));
    markers.extend(regimes);
    let tongue_branch_series = Series {
        label: "(0,6) continued: tongue".into(),
        color: Some((230, 110, 10)),
        points: tongue
            .points
            .iter()
            .map(|t| SeriesPoint {
                energy: t.point.energy,
                frequency: t.point.frequency,
                stable: t.point.floquet.stable,
            })
            .collect(),
        ..Default::default()
    };
    // Energies: the tongue and a little around it (down to a third of the junction's energy
    // at most); frequencies: whatever of the branches falls in that window, padded.
    let (e_min, e_max) = tongue
        .points
        .iter()
        .map(|t| t.point.energy)
        .fold((f64::INFINITY, 0.0f64), |(a, b), e| (a.min(e), b.max(e)));
    let x_range = (0.5 * e_min.max(e_junction / 3.0), 2.0 * e_max);
    let (f_lo, f_hi) = tongue
        .points
        .iter()
        .map(|t| &t.point)
        .chain(&backbone_0_6.points)
        .filter(|p| p.energy >= x_range.0 && p.energy <= x_range.1)
        .map(|p| p.frequency)
        .fold((f64::INFINITY, 0.0f64), |(a, b), f| (a.min(f), b.max(f)));
    let pad = 0.15 * (f_hi - f_lo).max(1e-3);
    FrequencyEnergyPlot {
        title: "3:1 internal resonance between (0,6) and (1,12)".into(),
        series: vec![
            // Drawn wide and light under the tongue's branch, which starts on it.
            Series {
                width: Some(7),
                color: Some((160, 200, 232)),
                ..series_of("(0,6) backbone", backbone_0_6, 1.0)
            },
            tongue_branch_series,
            Series {
                reference: true,
                ..series_of(
                    "(1,12) backbone at 1/3 of its frequency",
                    &junction.reference,
                    1.0 / 3.0,
                )
            },
        ],
        frequency_label: FREQUENCY_AXIS.into(),
        energy_label: ENERGY_AXIS.into(),
        marker_key: key,
        markers,
        x_range: Some(x_range),
        y_range: Some((f_lo - pad, f_hi + pad)),
        ..Default::default()
    }
    .write(&out.join("tongue"))?;
    let along = |value: &dyn Fn(f64, f64) -> f64| -> Vec<(f64, f64)> {
        tongue
            .points
            .iter()
            .map(|t| (t.point.energy, value(t.a1, t.a3)))
            .collect()
    };
    // Against the energy: the branch rises to the tongue's far fold and comes back down, so
    // each harmonic traces a loop; M1–M3 mark where the motions are drawn.
    LinePlot {
        title: "Harmonic content along the (0,6) branch and its tongue".into(),
        x_label: ENERGY_AXIS.into(),
        y_label: "harmonic amplitude (norm over all dofs)".into(),
        log_x: true,
        lines: vec![
            Line {
                label: "fundamental |A1|".into(),
                xy: along(&|a1, _| a1.abs()),
                ..Default::default()
            },
            Line {
                label: "third harmonic A3".into(),
                xy: along(&|_, a3| a3),
                dashed: true,
                ..Default::default()
            },
        ],
        markers: motions
            .iter()
            .map(|m| Marker {
                x: tongue.points[m.index].point.energy,
                y: tongue.points[m.index].a1.abs(),
                label: m.name.to_string(),
                shape: MarkerShape::Dot,
            })
            .collect(),
        ..Default::default()
    }
    .write(&out.join("tongue-harmonics"))?;
    let panels = motions
        .iter()
        .map(|m| {
            let line = |label: &str, dof: usize| Line {
                label: label.into(),
                xy: m
                    .states
                    .iter()
                    .enumerate()
                    .map(|(j, z)| (j as f64 / SAMPLES as f64, z[dof]))
                    .collect(),
                ..Default::default()
            };
            LinePlot {
                title: format!("{}: E = {:.4e}, {:.5} rad/s", m.name, m.energy, m.frequency),
                x_label: "t / T".into(),
                y_label: "displacement, sector 1".into(),
                lines: vec![line("disk", 0), line("blade", 1)],
                ..Default::default()
            }
        })
        .collect();
    PlotGrid {
        title: "Motions along the tongue".into(),
        columns: 3,
        panels,
    }
    .write(&out.join("tongue-motions"))?;
    Ok(())
}

/// `fep-travelling`: each travelling wave beside its standing wave; `travelling-orbits`: the
/// motions in the plane of the pair's standing waves.
pub(super) fn travelling(
    travelling: &super::travelling::Travelling,
    backbones: &Backbones,
    out: &Path,
) -> Result<()> {
    // Each standing wave wide and light, its travelling wave narrow and dark over it: the two
    // coincide in the linear limit, and both stay visible there.
    type Rgb = (u8, u8, u8);
    const PAIRS: [(Rgb, Rgb); 2] = [
        ((31, 119, 180), (160, 200, 232)),
        ((200, 40, 40), (244, 170, 165)),
    ];
    let mut series = Vec::new();
    for (k, w) in travelling.waves.iter().enumerate() {
        let (dark, light) = PAIRS[k % PAIRS.len()];
        series.push(Series {
            color: Some(dark),
            ..series_of(&format!("({}) travelling", w.label), &w.branch, 1.0)
        });
        series.push(Series {
            color: Some(light),
            width: Some(7),
            ..series_of(
                &format!("({}) standing", w.label),
                backbones.branch(&w.label),
                1.0,
            )
        });
    }
    FrequencyEnergyPlot {
        title: "Travelling and standing waves".into(),
        series,
        frequency_label: FREQUENCY_AXIS.into(),
        energy_label: ENERGY_AXIS.into(),
        ..Default::default()
    }
    .write(&out.join("fep-travelling"))?;
    let panels = travelling
        .waves
        .iter()
        .map(|w| {
            let line = |label: &str, xy: &[(f64, f64)]| Line {
                label: label.into(),
                xy: xy.to_vec(),
                ..Default::default()
            };
            LinePlot {
                title: format!("({}) at E = {:.3}", w.label, w.energy),
                x_label: "q_c = φ_cᵀ M x (cos standing wave)".into(),
                y_label: "q_s = φ_sᵀ M x (sin standing wave)".into(),
                lines: vec![
                    line("travelling", &w.orbits[0]),
                    line("standing", &w.orbits[1]),
                ],
                ..Default::default()
            }
        })
        .collect();
    PlotGrid {
        title: "Travelling and standing waves in the plane of their pair".into(),
        columns: 2,
        panels,
    }
    .write(&out.join("travelling-orbits"))?;
    Ok(())
}
