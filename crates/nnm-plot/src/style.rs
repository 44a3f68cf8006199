//! Sizes, font name and colours shared by every kind of figure.

use plotters::style::{Color, HSLColor, RGBColor};

/// PNG size in pixels of a single plot; the SVG uses the same logical size.
pub(crate) const SIZE: (u32, u32) = (1200, 800);

/// Size of one panel of a [`PlotGrid`](crate::PlotGrid).
pub(crate) const PANEL: (u32, u32) = (640, 440);

/// Text and spacing scale of grid panels relative to a single plot.
pub(crate) const PANEL_SCALE: f64 = 0.72;

/// Height reserved for a grid's overall title.
pub(crate) const GRID_TITLE: u32 = 52;

/// Font family name under which DejaVu Sans is registered.
pub(crate) const FONT: &str = "sans-serif";

/// Above this many labelled curves a legend would hide the data, so none is drawn.
pub(crate) const MAX_LEGEND_ENTRIES: usize = 12;

/// Default colour of reference curves.
pub(crate) const REFERENCE_GREY: RGBColor = RGBColor(150, 150, 150);

/// Tableau-10 for up to 10 curves; beyond that golden-ratio hue steps with
/// cycling lightness keep ~35 curves (NNM branches) apart on white.
pub(crate) fn palette(i: usize, n: usize) -> RGBColor {
    const TAB10: [(u8, u8, u8); 10] = [
        (31, 119, 180),
        (255, 127, 14),
        (44, 160, 44),
        (214, 39, 40),
        (148, 103, 189),
        (140, 86, 75),
        (227, 119, 194),
        (127, 127, 127),
        (188, 189, 34),
        (23, 190, 207),
    ];
    if n <= TAB10.len() {
        let (r, g, b) = TAB10[i];
        return RGBColor(r, g, b);
    }
    let hue = (i as f64 * 0.618_033_988_75).fract();
    let c = HSLColor(hue, 0.8, [0.40, 0.28, 0.50][i % 3]).to_backend_color();
    RGBColor(c.rgb.0, c.rgb.1, c.rgb.2)
}
