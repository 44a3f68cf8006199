//! Grids of line plots in one image.

use std::path::Path;

use crate::page::Page;
use crate::style::{GRID_TITLE, PANEL, PANEL_SCALE};
use crate::{LinePlot, PlotError};

/// Several line plots in one image, filled row by row, e.g. mode shapes of
/// four NNMs or the time series of three motions. Each panel keeps its own
/// title, axis labels, ranges, markers and legend.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotGrid {
    /// Overall title above the panels (none drawn if empty).
    pub title: String,
    /// Panels per row; 0 counts as 1, more than `panels.len()` as that many.
    pub columns: usize,
    /// The plots, filled row by row.
    pub panels: Vec<LinePlot>,
}

impl PlotGrid {
    /// Writes `<stem>.png` and `<stem>.svg` (stem is a path without
    /// extension); each panel is 640x440 pixels. Errors if there are no
    /// panels or any panel has nothing to draw.
    pub fn write(&self, stem: &Path) -> Result<(), PlotError> {
        if self.panels.is_empty() {
            return Err(PlotError::NoData(" (grid has no panels)"));
        }
        let panels = self
            .panels
            .iter()
            .map(LinePlot::figure)
            .collect::<Result<Vec<_>, _>>()?;
        let columns = self.columns.clamp(1, panels.len());
        let rows = panels.len().div_ceil(columns);
        let title = (!self.title.is_empty()).then_some(self.title.as_str());
        let size = (
            PANEL.0 * columns as u32,
            PANEL.1 * rows as u32 + if title.is_some() { GRID_TITLE } else { 0 },
        );
        Page {
            title,
            columns,
            rows,
            size,
            scale: PANEL_SCALE,
            panels,
        }
        .write(stem)
    }
}
