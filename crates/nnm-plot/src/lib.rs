//! Plots for nnm: frequency-energy plots (FEPs) of NNM backbones, generic
//! line plots and grids of line plots, each written as both PNG (quick look)
//! and SVG (papers, zooming).
//!
//! The machines this runs on may have no system fonts, so all text is drawn
//! with plotters' `ab_glyph` backend from DejaVu Sans embedded in the binary
//! (see `register_fonts`). Every public plot type is lowered to internal
//! `Figure`s laid out on a `Page`, and one drawing routine
//! (`Panel::draw`) renders every chart, so the FEP, the generic plot and the
//! grid share axes, fonts, palette, markers and legend handling.
//!
//! Plots may carry [`Marker`]s (a labelled black dot, e.g. motions "M1".."M3"
//! or a fold) and fixed axis ranges for zoomed views; data outside the ranges
//! is clipped at the frame.

#![warn(missing_docs)]

use std::path::PathBuf;
use std::sync::OnceLock;

use plotters::style::{FontStyle, register_font};

mod axes;
mod clip;
mod fep;
mod figure;
mod grid;
mod line;
mod occupancy;
mod page;
mod panel;
mod response;
mod style;

pub use fep::{CurveLabels, FrequencyEnergyPlot, Series, SeriesPoint};
pub use grid::PlotGrid;
pub use line::{Line, LinePlot};
pub use response::{ResponsePlot, ResponseSeries};

/// The palette colour of curve `i` of `n` (what a curve without `color` gets), for a caller
/// that draws one branch as several lines of one colour.
pub fn palette_color(i: usize, n: usize) -> (u8, u8, u8) {
    let c = style::palette(i, n);
    (c.0, c.1, c.2)
}

use style::FONT;

/// Errors from building or writing a plot. Bad data never panics.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// Nothing drawable: no series/lines/panels, or every point was skipped
    /// (NaN/infinite, or non-positive on a log axis).
    #[error("nothing to plot: no finite points{0}")]
    NoData(&'static str),
    /// A fixed axis range that cannot be drawn.
    #[error("invalid {axis} range ({lo}, {hi}): {reason}")]
    BadRange {
        /// Which axis: `"x"` or `"y"`.
        axis: &'static str,
        /// The first bound as given.
        lo: f64,
        /// The second bound as given.
        hi: f64,
        /// What is wrong with the bounds.
        reason: &'static str,
    },
    /// The embedded font could not be registered with plotters.
    #[error("could not register the embedded DejaVu font")]
    Font,
    /// plotters failed while drawing or writing a file.
    #[error("failed to draw {path}: {message}")]
    Draw {
        /// The file being written.
        path: PathBuf,
        /// plotters' error message.
        message: String,
    },
}

/// A labelled point drawn as a black dot with its label beside it, e.g. the
/// motions "M1", "M2", "M3" on a tongue or a "fold". In plot data units: on a
/// frequency-energy plot `x` is the energy and `y` the frequency. Markers
/// with non-finite coordinates, outside the axis ranges or with `x <= 0` on a
/// log axis are not drawn; the label may be empty.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Marker {
    /// Horizontal position (the energy on a frequency-energy plot).
    pub x: f64,
    /// Vertical position (the frequency on a frequency-energy plot).
    pub y: f64,
    /// Text beside the dot; empty for a bare dot.
    pub label: String,
    /// The symbol drawn (a dot unless set): different kinds of points on one plot (folds,
    /// branch points, ...) get different symbols, explained in the plot's key.
    pub shape: MarkerShape,
}

/// The symbol of a [`Marker`], black in a white outline; [`MarkerShape::glyph`] is the
/// character that stands for it in a key.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum MarkerShape {
    /// A filled disc.
    #[default]
    Dot,
    /// A filled square.
    Square,
    /// A filled triangle, pointing up.
    Triangle,
    /// A filled diamond.
    Diamond,
    /// A hollow circle.
    Ring,
}

impl MarkerShape {
    /// The character for the symbol in a key (DejaVu Sans has them all).
    pub fn glyph(self) -> char {
        match self {
            MarkerShape::Dot => '●',
            MarkerShape::Square => '■',
            MarkerShape::Triangle => '▲',
            MarkerShape::Diamond => '◆',
            MarkerShape::Ring => '○',
        }
    }
}

/// Registers DejaVu Sans as "sans-serif" once per process. plotters keeps a
/// global font table and, with `ab_glyph`, knows no font unless registered;
/// without this every text draw (even SVG, which measures text) fails.
pub(crate) fn register_fonts() -> Result<(), PlotError> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE
        .get_or_init(|| register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_ok());
    if ok { Ok(()) } else { Err(PlotError::Font) }
}

#[cfg(test)]
mod tests;
