//! Forced response curves: the peak of a dof against the forcing frequency (or the force
//! amplitude), one curve per force level, unstable stretches dashed, folds marked.

use std::path::Path;

use crate::figure::{Curve, Figure, Piece};
use crate::page::Page;
use crate::{Marker, PlotError};

/// One curve of a response plot.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ResponseSeries {
    /// Legend entry (e.g. `"F = 0.1"`).
    pub label: String,
    /// `(x, y, stable)` in continuation order: a curve may run back in `x` between folds.
    pub points: Vec<(f64, f64, bool)>,
    /// Its colour; `None`: the palette's next.
    pub color: Option<(u8, u8, u8)>,
}

/// Response curves on linear axes: solid where stable, dashed where unstable (a segment is
/// solid only when both its ends are stable, so a stability change is never hidden).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ResponsePlot {
    /// Title above the chart (none drawn if empty).
    pub title: String,
    /// x-axis label, e.g. `"forcing frequency (rad/s)"`.
    pub x_label: String,
    /// y-axis label, e.g. `"peak of x0"`.
    pub y_label: String,
    /// The curves, in palette colours in this order.
    pub series: Vec<ResponseSeries>,
    /// Folds and bifurcations.
    pub markers: Vec<Marker>,
    /// What the markers mean, after the note on line styles; empty: nothing.
    pub marker_key: String,
}

impl ResponsePlot {
    /// Writes `<stem>.png` and `<stem>.svg`.
    pub fn write(&self, stem: &Path) -> Result<(), PlotError> {
        let curves = self
            .series
            .iter()
            .map(|s| Curve {
                label: &s.label,
                legend_dashed: false,
                reference: false,
                color: s.color,
                width: None,
                pieces: pieces(&s.points),
            })
            .collect();
        let note = "solid: stable    dashed: unstable";
        let figure = Figure {
            title: &self.title,
            x_label: &self.x_label,
            y_label: &self.y_label,
            log_x: false,
            curves,
            markers: &self.markers,
            x_range: None,
            y_range: None,
            note: Some(if self.marker_key.is_empty() {
                note.to_string()
            } else {
                format!("{note}      {}", self.marker_key)
            }),
            end_labels: false,
        }
        .prepare()?;
        Page::single(figure).write(stem)
    }
}

/// Runs of equal stability sharing their end points.
fn pieces(points: &[(f64, f64, bool)]) -> Vec<Piece> {
    let mut pieces: Vec<Piece> = Vec::new();
    for w in points.windows(2) {
        let dashed = !(w[0].2 && w[1].2);
        let (a, b) = ((w[0].0, w[0].1), (w[1].0, w[1].1));
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
            xy: vec![(p.0, p.1)],
            dashed: !p.2,
        });
    }
    pieces
}
