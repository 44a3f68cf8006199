//! Generic line plots (time series, mode shapes per sector, ...).

use std::path::Path;

use crate::figure::{Curve, Figure, Piece};
use crate::page::Page;
use crate::panel::Panel;
use crate::{Marker, PlotError};

/// Generic line plot (time series, mode shapes per sector, ...).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LinePlot {
    /// Title above the chart (none drawn if empty).
    pub title: String,
    /// x-axis label.
    pub x_label: String,
    /// y-axis label.
    pub y_label: String,
    /// Log10 x axis; points with x <= 0 are then skipped.
    pub log_x: bool,
    /// Lines; those without `color` or `reference` take palette colours in
    /// this order.
    pub lines: Vec<Line>,
    /// Labelled points in data units.
    pub markers: Vec<Marker>,
    /// Fixed x range (data units, both > 0 on a log axis); `None` fits the data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range; `None` fits the data inside `x_range`.
    pub y_range: Option<(f64, f64)>,
}

/// One line of a [`LinePlot`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Line {
    /// Legend entry; an empty label leaves the line out of the legend.
    pub label: String,
    /// Points joined in order; non-finite points break the line.
    pub xy: Vec<(f64, f64)>,
    /// Draw dashed instead of solid (the legend swatch too).
    pub dashed: bool,
    /// Thin background line (grey unless `color` is set), taking no palette
    /// colour; see [`Series::reference`](crate::Series::reference).
    pub reference: bool,
    /// RGB colour replacing the palette colour.
    pub color: Option<(u8, u8, u8)>,
}

impl LinePlot {
    /// Writes `<stem>.png` and `<stem>.svg` (stem is a path without extension).
    pub fn write(&self, stem: &Path) -> Result<(), PlotError> {
        Page::single(self.figure()?).write(stem)
    }

    pub(crate) fn figure(&self) -> Result<Panel<'_>, PlotError> {
        let curves = self
            .lines
            .iter()
            .map(|l| Curve {
                label: &l.label,
                legend_dashed: l.dashed,
                reference: l.reference,
                color: l.color,
                width: None,
                pieces: vec![Piece {
                    xy: l.xy.clone(),
                    dashed: l.dashed,
                }],
            })
            .collect();
        Figure {
            title: &self.title,
            x_label: &self.x_label,
            y_label: &self.y_label,
            log_x: self.log_x,
            curves,
            markers: &self.markers,
            x_range: self.x_range,
            y_range: self.y_range,
            note: None,
            end_labels: false,
        }
        .prepare()
    }
}
