//! Frequency-energy plots: NNM branches with their stability over a log
//! energy axis.

use std::path::Path;

use crate::figure::{Curve, Figure, Piece};
use crate::page::Page;
use crate::panel::Panel;
use crate::style::MAX_LEGEND_ENTRIES;

/// The note under every frequency–energy plot.
const STABILITY_NOTE: &str = "solid: stable    dashed: unstable";
use crate::{Marker, PlotError};

/// One NNM branch of a frequency-energy plot.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Series {
    /// Legend entry; an empty label leaves the branch out of the legend.
    pub label: String,
    /// Points in continuation order; consecutive points are joined.
    pub points: Vec<SeriesPoint>,
    /// Draw as a thin background curve (grey unless `color` is set), e.g. a
    /// backbone at a third of its frequency next to a 1:3 tongue. Reference
    /// curves take no palette colour and are drawn beneath the others;
    /// stability is still shown (dashed = unstable).
    pub reference: bool,
    /// RGB colour replacing the palette colour.
    pub color: Option<(u8, u8, u8)>,
    /// Line width in pixels (at 1200 × 800; default 2, 1 for a reference curve). Wider curves
    /// are drawn first: a branch drawn wide and light stays visible under a narrower one that
    /// follows it (a backbone under the branch continued from it).
    pub width: Option<u32>,
}

/// How the curves of a frequency–energy plot are named.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum CurveLabels {
    /// A legend for up to 12 labelled curves, labels at the curves' ends beyond.
    #[default]
    Auto,
    /// A legend (none beyond 12 labelled curves: it would hide the data).
    Legend,
    /// Each label written at its curve's end, in the curve's colour, where it hides least.
    AtEnds,
}

/// A point of a branch: total energy, frequency and (Floquet) stability.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeriesPoint {
    /// Total energy (x, log axis); points with energy <= 0 are skipped.
    pub energy: f64,
    /// Frequency (y).
    pub frequency: f64,
    /// Stable in the Floquet sense; unstable stretches are drawn dashed.
    pub stable: bool,
}

/// Frequency-energy plot: energy on a log10 x axis (NNM energies span many
/// decades), frequency on a linear y axis. Stable stretches are solid,
/// unstable ones dashed; the figure carries a note saying so.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrequencyEnergyPlot {
    /// Title above the chart (none drawn if empty).
    pub title: String,
    /// Branches; those without `color` or `reference` take palette colours
    /// in this order.
    pub series: Vec<Series>,
    /// y-axis label, e.g. `"frequency (rad/s)"`.
    pub frequency_label: String,
    /// x-axis label, e.g. `"total energy (J)"`; empty: `"total energy"` (no unit, for models
    /// in arbitrary units).
    pub energy_label: String,
    /// Labelled points (x = energy, y = frequency).
    pub markers: Vec<Marker>,
    /// Fixed energy range (energies, not their logarithms; both > 0);
    /// `None` fits the data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed frequency range; `None` fits the data inside `x_range`.
    pub y_range: Option<(f64, f64)>,
    /// Legend or labels at the curves' ends.
    pub curve_labels: CurveLabels,
    /// What the markers' labels mean (e.g. `"F fold   BP branch point"`), written after the
    /// note on line styles; empty: nothing.
    pub marker_key: String,
}

impl FrequencyEnergyPlot {
    /// Writes `<stem>.png` and `<stem>.svg` (stem is a path without extension).
    ///
    /// Points with non-finite values or energy <= 0 are skipped and break the
    /// line there. A segment between two points is drawn stable only if both
    /// ends are stable, so a stability change is never hidden.
    pub fn write(&self, stem: &Path) -> Result<(), PlotError> {
        Page::single(self.figure()?).write(stem)
    }

    pub(crate) fn figure(&self) -> Result<Panel<'_>, PlotError> {
        let curves = self
            .series
            .iter()
            .map(|s| Curve {
                label: &s.label,
                legend_dashed: false,
                reference: s.reference,
                color: s.color,
                width: s.width,
                pieces: stability_pieces(&s.points),
            })
            .collect();
        Figure {
            title: &self.title,
            x_label: if self.energy_label.is_empty() {
                "total energy"
            } else {
                &self.energy_label
            },
            y_label: &self.frequency_label,
            log_x: true,
            curves,
            markers: &self.markers,
            x_range: self.x_range,
            y_range: self.y_range,
            note: Some(if self.marker_key.is_empty() {
                STABILITY_NOTE.to_string()
            } else {
                format!("{STABILITY_NOTE}      {}", self.marker_key)
            }),
            end_labels: match self.curve_labels {
                CurveLabels::Legend => false,
                CurveLabels::AtEnds => true,
                CurveLabels::Auto => {
                    let labelled = self.series.iter().filter(|s| !s.label.is_empty());
                    labelled.count() > MAX_LEGEND_ENTRIES
                }
            },
        }
        .prepare()
    }
}

/// Splits a branch into runs of equal stability sharing their end points,
/// so the drawn curve stays continuous across a stability change.
fn stability_pieces(points: &[SeriesPoint]) -> Vec<Piece> {
    let mut pieces: Vec<Piece> = Vec::new();
    for w in points.windows(2) {
        let dashed = !(w[0].stable && w[1].stable);
        let (a, b) = ((w[0].energy, w[0].frequency), (w[1].energy, w[1].frequency));
        match pieces.last_mut() {
            Some(p) if p.dashed == dashed && p.xy.last() == Some(&a) => p.xy.push(b),
            _ => pieces.push(Piece {
                xy: vec![a, b],
                dashed,
            }),
        }
    }
    if let [p] = points {
        pieces.push(Piece {
            xy: vec![(p.energy, p.frequency)],
            dashed: !p.stable,
        });
    }
    pieces
}
