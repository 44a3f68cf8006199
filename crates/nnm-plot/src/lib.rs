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

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::coord::ranged1d::{BoldPoints, KeyPointHint, NoDefaultFormatting, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::element::{DashedPathElement, IntoDynElement, MultiLineText};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{FontStyle, register_font};

/// PNG size in pixels of a single plot; the SVG uses the same logical size.
const SIZE: (u32, u32) = (1200, 800);
/// Size of one panel of a [`PlotGrid`].
const PANEL: (u32, u32) = (640, 440);
/// Text and spacing scale of grid panels relative to a single plot.
const PANEL_SCALE: f64 = 0.72;
/// Height reserved for a grid's overall title.
const GRID_TITLE: u32 = 52;
/// Font family name under which DejaVu Sans is registered.
const FONT: &str = "sans-serif";
/// Above this many labelled curves a legend would hide the data, so none is drawn.
const MAX_LEGEND_ENTRIES: usize = 12;
/// Default colour of reference curves.
const REFERENCE_GREY: RGBColor = RGBColor(150, 150, 150);

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
        axis: &'static str,
        lo: f64,
        hi: f64,
        reason: &'static str,
    },
    /// The embedded font could not be registered with plotters.
    #[error("could not register the embedded DejaVu font")]
    Font,
    /// plotters failed while drawing or writing a file.
    #[error("failed to draw {path}: {message}")]
    Draw { path: PathBuf, message: String },
}

/// A labelled point drawn as a black dot with its label beside it, e.g. the
/// motions "M1", "M2", "M3" on a tongue or a "fold". In plot data units: on a
/// frequency-energy plot `x` is the energy and `y` the frequency. Markers
/// with non-finite coordinates, outside the axis ranges or with `x <= 0` on a
/// log axis are not drawn; the label may be empty.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Marker {
    pub x: f64,
    pub y: f64,
    pub label: String,
}

/// One NNM branch of a frequency-energy plot.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Series {
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
}

/// A point of a branch: total energy, frequency and (Floquet) stability.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeriesPoint {
    pub energy: f64,
    pub frequency: f64,
    pub stable: bool,
}

/// Frequency-energy plot: energy on a log10 x axis (NNM energies span many
/// decades), frequency on a linear y axis. Stable stretches are solid,
/// unstable ones dashed; the figure carries a note saying so.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrequencyEnergyPlot {
    pub title: String,
    pub series: Vec<Series>,
    /// y-axis label, e.g. `"frequency (rad/s)"`.
    pub frequency_label: String,
    /// Labelled points (x = energy, y = frequency).
    pub markers: Vec<Marker>,
    /// Fixed energy range (energies, not their logarithms; both > 0);
    /// `None` fits the data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed frequency range; `None` fits the data inside `x_range`.
    pub y_range: Option<(f64, f64)>,
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

    fn figure(&self) -> Result<Panel<'_>, PlotError> {
        let curves = self
            .series
            .iter()
            .map(|s| Curve {
                label: &s.label,
                legend_dashed: false,
                reference: s.reference,
                color: s.color,
                pieces: stability_pieces(&s.points),
            })
            .collect();
        Figure {
            title: &self.title,
            x_label: "total energy",
            y_label: &self.frequency_label,
            log_x: true,
            curves,
            markers: &self.markers,
            x_range: self.x_range,
            y_range: self.y_range,
            note: Some("solid: stable    dashed: unstable"),
        }
        .prepare()
    }
}

/// Generic line plot (time series, mode shapes per sector, ...).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LinePlot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    /// Log10 x axis; points with x <= 0 are then skipped.
    pub log_x: bool,
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
    pub label: String,
    /// Points joined in order; non-finite points break the line.
    pub xy: Vec<(f64, f64)>,
    pub dashed: bool,
    /// Thin background line (grey unless `color` is set), taking no palette
    /// colour; see [`Series::reference`].
    pub reference: bool,
    /// RGB colour replacing the palette colour.
    pub color: Option<(u8, u8, u8)>,
}

impl LinePlot {
    /// Writes `<stem>.png` and `<stem>.svg` (stem is a path without extension).
    pub fn write(&self, stem: &Path) -> Result<(), PlotError> {
        Page::single(self.figure()?).write(stem)
    }

    fn figure(&self) -> Result<Panel<'_>, PlotError> {
        let curves = self
            .lines
            .iter()
            .map(|l| Curve {
                label: &l.label,
                legend_dashed: l.dashed,
                reference: l.reference,
                color: l.color,
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
        }
        .prepare()
    }
}

/// Several line plots in one image, filled row by row, e.g. mode shapes of
/// four NNMs or the time series of three motions. Each panel keeps its own
/// title, axis labels, ranges, markers and legend.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotGrid {
    /// Overall title above the panels (none drawn if empty).
    pub title: String,
    /// Panels per row; 0 counts as 1, more than `panels.len()` as that many.
    pub columns: usize,
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

/// Registers DejaVu Sans as "sans-serif" once per process. plotters keeps a
/// global font table and, with `ab_glyph`, knows no font unless registered;
/// without this every text draw (even SVG, which measures text) fails.
fn register_fonts() -> Result<(), PlotError> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE
        .get_or_init(|| register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_ok());
    if ok { Ok(()) } else { Err(PlotError::Font) }
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

/// A polyline drawn in one style.
struct Piece {
    xy: Vec<(f64, f64)>,
    dashed: bool,
}

/// A labelled curve, one colour, possibly several pieces.
struct Curve<'a> {
    label: &'a str,
    /// Legend swatch style: FEP branches show their colour solid (dashes
    /// mean instability there), generic lines show their own style.
    legend_dashed: bool,
    reference: bool,
    color: Option<(u8, u8, u8)>,
    pieces: Vec<Piece>,
}

/// One chart as the public types describe it, in data units.
struct Figure<'a> {
    title: &'a str,
    x_label: &'a str,
    y_label: &'a str,
    log_x: bool,
    curves: Vec<Curve<'a>>,
    markers: &'a [Marker],
    x_range: Option<(f64, f64)>,
    y_range: Option<(f64, f64)>,
    note: Option<&'a str>,
}

/// A curve in plot coordinates (x already log10'd), split at invalid points
/// and clipped to the axis ranges.
struct Prepared<'a> {
    label: &'a str,
    legend_dashed: bool,
    reference: bool,
    color: RGBColor,
    pieces: Vec<(Vec<(f64, f64)>, bool)>,
}

/// A chart ready to draw: plot coordinates, final axis ranges, colours.
struct Panel<'a> {
    title: &'a str,
    x_label: &'a str,
    y_label: &'a str,
    log_x: bool,
    note: Option<&'a str>,
    curves: Vec<Prepared<'a>>,
    markers: Vec<((f64, f64), &'a str)>,
    xr: Range<f64>,
    yr: Range<f64>,
}

type Pieces = Vec<(Vec<(f64, f64)>, bool)>;

impl<'a> Figure<'a> {
    /// Maps to plot coordinates, splits lines wherever a point cannot be
    /// drawn (so no segment bridges a gap), fixes the axis ranges (a free
    /// axis fits the data inside the other axis' fixed range) and clips.
    fn prepare(self) -> Result<Panel<'a>, PlotError> {
        let log = self.log_x;
        let user_x = axis_range(self.x_range, log, "x")?;
        let user_y = axis_range(self.y_range, false, "y")?;
        let map = |(x, y): (f64, f64)| {
            let x = if log {
                if x > 0.0 { x.log10() } else { f64::NAN }
            } else {
                x
            };
            // Clamped so that differences of coordinates stay finite.
            (x.is_finite() && y.is_finite())
                .then(|| (x.clamp(-1e300, 1e300), y.clamp(-1e300, 1e300)))
        };
        let mapped: Vec<Pieces> = self
            .curves
            .iter()
            .map(|c| {
                let mut pieces = Vec::new();
                for p in &c.pieces {
                    let mut run = Vec::new();
                    for &q in &p.xy {
                        match map(q) {
                            Some(q) => run.push(q),
                            None if !run.is_empty() => {
                                pieces.push((std::mem::take(&mut run), p.dashed))
                            }
                            None => {}
                        }
                    }
                    if !run.is_empty() {
                        pieces.push((run, p.dashed));
                    }
                }
                pieces
            })
            .collect();
        let markers: Vec<_> = self
            .markers
            .iter()
            .filter_map(|m| Some((map((m.x, m.y))?, m.label.as_str())))
            .collect();
        let all = || {
            let curve_pts = mapped.iter().flatten().flat_map(|p| p.0.iter().copied());
            curve_pts.chain(markers.iter().map(|m| m.0))
        };
        if all().next().is_none() {
            return Err(PlotError::NoData(if log {
                " (log axis needs x > 0)"
            } else {
                ""
            }));
        }

        // Fit free axes to what lies inside the fixed ranges (or to
        // everything, if nothing does).
        let inf = f64::NEG_INFINITY..f64::INFINITY;
        let wx = user_x.clone().unwrap_or(inf.clone());
        let wy = user_y.clone().unwrap_or(inf);
        let inside: Vec<(f64, f64)> = mapped
            .iter()
            .flatten()
            .flat_map(|p| clip_polyline(&p.0, &wx, &wy))
            .flatten()
            .chain(
                markers
                    .iter()
                    .map(|m| m.0)
                    .filter(|p| contains(&wx, &wy, *p)),
            )
            .collect();
        let fit: Vec<(f64, f64)> = if inside.is_empty() {
            all().collect()
        } else {
            inside
        };
        let xr = user_x.unwrap_or_else(|| {
            padded_range(fit.iter().map(|p| p.0), 0.03, if log { 0.5 } else { 0.0 })
        });
        let yr = user_y.unwrap_or_else(|| padded_range(fit.iter().map(|p| p.1), 0.06, 0.0));

        let free = self
            .curves
            .iter()
            .filter(|c| c.color.is_none() && !c.reference)
            .count();
        let mut k = 0;
        let curves = self
            .curves
            .iter()
            .zip(mapped)
            .map(|(c, pieces)| {
                let color = match (c.color, c.reference) {
                    (Some((r, g, b)), _) => RGBColor(r, g, b),
                    (None, true) => REFERENCE_GREY,
                    (None, false) => {
                        k += 1;
                        palette(k - 1, free)
                    }
                };
                let pieces = pieces
                    .iter()
                    .flat_map(|(xy, dashed)| {
                        clip_polyline(xy, &xr, &yr)
                            .into_iter()
                            .map(move |run| (run, *dashed))
                    })
                    .collect();
                Prepared {
                    label: c.label,
                    legend_dashed: c.legend_dashed,
                    reference: c.reference,
                    color,
                    pieces,
                }
            })
            .collect();
        let markers = markers
            .into_iter()
            .filter(|m| contains(&xr, &yr, m.0))
            .collect();
        Ok(Panel {
            title: self.title,
            x_label: self.x_label,
            y_label: self.y_label,
            log_x: log,
            note: self.note,
            curves,
            markers,
            xr,
            yr,
        })
    }
}

/// Validates a fixed range (either order) and maps it to plot coordinates.
fn axis_range(
    r: Option<(f64, f64)>,
    log: bool,
    axis: &'static str,
) -> Result<Option<Range<f64>>, PlotError> {
    let Some((a, b)) = r else { return Ok(None) };
    let bad = |reason| PlotError::BadRange {
        axis,
        lo: a,
        hi: b,
        reason,
    };
    let (lo, hi) = (a.min(b), a.max(b));
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(bad("bounds must be finite"));
    }
    if log && lo <= 0.0 {
        return Err(bad("a log axis needs bounds > 0"));
    }
    let (lo, hi) = if log {
        (lo.log10(), hi.log10())
    } else {
        (lo, hi)
    };
    // Both finite here, so the span is a number (maybe infinite).
    if hi - lo <= 1e-12 * lo.abs().max(hi.abs()) || hi - lo > 1e300 {
        return Err(bad("bounds must differ (and not be huge)"));
    }
    Ok(Some(lo..hi))
}

fn contains(xr: &Range<f64>, yr: &Range<f64>, (x, y): (f64, f64)) -> bool {
    xr.start <= x && x <= xr.end && yr.start <= y && y <= yr.end
}

/// Parts of a polyline inside the closed box `xr` x `yr` (bounds may be
/// infinite), cut exactly at the frame (Liang-Barsky per segment).
fn clip_polyline(xy: &[(f64, f64)], xr: &Range<f64>, yr: &Range<f64>) -> Vec<Vec<(f64, f64)>> {
    if let [p] = xy {
        return if contains(xr, yr, *p) {
            vec![vec![*p]]
        } else {
            Vec::new()
        };
    }
    let mut out = Vec::new();
    let mut run: Vec<(f64, f64)> = Vec::new();
    for w in xy.windows(2) {
        let (a, b) = (w[0], w[1]);
        let Some((t0, t1)) = clip_segment(a, b, xr, yr) else {
            if run.len() > 1 {
                out.push(std::mem::take(&mut run));
            }
            run.clear();
            continue;
        };
        let at = |t: f64| (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
        if t0 > 0.0 || run.is_empty() {
            if run.len() > 1 {
                out.push(std::mem::take(&mut run));
            }
            run.clear();
            run.push(if t0 > 0.0 { at(t0) } else { a });
        }
        run.push(if t1 < 1.0 { at(t1) } else { b });
        if t1 < 1.0 {
            out.push(std::mem::take(&mut run));
        }
    }
    if run.len() > 1 {
        out.push(run);
    }
    out
}

/// Parameter interval `t0..=t1` of the segment a-b inside the box, if any.
fn clip_segment(
    a: (f64, f64),
    b: (f64, f64),
    xr: &Range<f64>,
    yr: &Range<f64>,
) -> Option<(f64, f64)> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 - xr.start),
        (dx, xr.end - a.0),
        (-dy, a.1 - yr.start),
        (dy, yr.end - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
            continue;
        }
        let r = q / p;
        if p < 0.0 {
            t0 = t0.max(r);
        } else {
            t1 = t1.min(r);
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

/// Pixel rectangle `[x0, x1) x [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Rect {
    x0: i32,
    y0: i32,
    x1: i32,
    y1: i32,
}

impl Rect {
    fn overlaps(&self, o: &Rect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }
    /// Squared distance from a point to the rectangle (0 inside).
    fn distance2(&self, (x, y): (i32, i32)) -> i64 {
        let dx = i64::from((self.x0 - x).max(x - self.x1).max(0));
        let dy = i64::from((self.y0 - y).max(y - self.y1).max(0));
        dx * dx + dy * dy
    }
    fn within(&self, o: &Rect) -> bool {
        self.x0 >= o.x0 && self.x1 <= o.x1 && self.y0 >= o.y0 && self.y1 <= o.y1
    }
}

/// Which cells (of `CELL` pixels) of the plotting area curves pass through,
/// so the legend and marker labels can be put where they hide least data.
struct Occupancy {
    w: usize,
    h: usize,
    cells: Vec<bool>,
}

const CELL: i32 = 4;

impl Occupancy {
    fn new(w: i32, h: i32) -> Self {
        let (w, h) = (
            (w / CELL + 1).max(1) as usize,
            (h / CELL + 1).max(1) as usize,
        );
        Self {
            w,
            h,
            cells: vec![false; w * h],
        }
    }
    fn mark(&mut self, (x, y): (f64, f64)) {
        let (cx, cy) = ((x / f64::from(CELL)).floor(), (y / f64::from(CELL)).floor());
        if cx >= 0.0 && cy >= 0.0 && (cx as usize) < self.w && (cy as usize) < self.h {
            self.cells[cy as usize * self.w + cx as usize] = true;
        }
    }
    /// Marks the pixel polyline densely enough to leave no gaps.
    fn mark_path(&mut self, pts: &[(i32, i32)]) {
        if let [p] = pts {
            self.mark((f64::from(p.0), f64::from(p.1)));
        }
        for w in pts.windows(2) {
            let (a, b) = (w[0], w[1]);
            let len = f64::from((b.0 - a.0).abs().max((b.1 - a.1).abs()));
            let n = (len / f64::from(CELL) * 2.0).ceil().max(1.0) as i32;
            for i in 0..=n {
                let t = f64::from(i) / f64::from(n);
                self.mark((
                    f64::from(a.0) + t * f64::from(b.0 - a.0),
                    f64::from(a.1) + t * f64::from(b.1 - a.1),
                ));
            }
        }
    }
    fn count(&self, r: &Rect) -> usize {
        let cx = |x: i32| (x / CELL).clamp(0, self.w as i32 - 1) as usize;
        let cy = |y: i32| (y / CELL).clamp(0, self.h as i32 - 1) as usize;
        let mut n = 0;
        for y in cy(r.y0)..=cy(r.y1 - 1) {
            n += self.cells[y * self.w + cx(r.x0)..=y * self.w + cx(r.x1 - 1)]
                .iter()
                .filter(|&&c| c)
                .count();
        }
        n
    }
}

/// One image: an optional overall title and panels filled row by row.
struct Page<'a> {
    title: Option<&'a str>,
    columns: usize,
    rows: usize,
    size: (u32, u32),
    /// Text and spacing scale of the panels.
    scale: f64,
    panels: Vec<Panel<'a>>,
}

impl<'a> Page<'a> {
    fn single(panel: Panel<'a>) -> Self {
        Page {
            title: None,
            columns: 1,
            rows: 1,
            size: SIZE,
            scale: 1.0,
            panels: vec![panel],
        }
    }

    fn write(&self, stem: &Path) -> Result<(), PlotError> {
        register_fonts()?;
        let png = with_suffix(stem, ".png");
        let root = BitMapBackend::new(&png, self.size).into_drawing_area();
        self.draw(&root, true)
            .and_then(|()| root.present().map_err(|e| e.to_string()))
            .map_err(|message| PlotError::Draw {
                path: png.clone(),
                message,
            })?;
        let svg = with_suffix(stem, ".svg");
        let root = SVGBackend::new(&svg, self.size).into_drawing_area();
        self.draw(&root, false)
            .and_then(|()| root.present().map_err(|e| e.to_string()))
            .map_err(|message| PlotError::Draw {
                path: svg.clone(),
                message,
            })
    }

    /// `bitmap`: see [`Panel::draw`].
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        bitmap: bool,
    ) -> Result<(), String> {
        let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        root.fill(&WHITE).map_err(err)?;
        let area = match self.title {
            Some(t) => {
                let (top, rest) = root.split_vertically(GRID_TITLE);
                let style = TextStyle::from((FONT, 32).into_font())
                    .pos(Pos::new(HPos::Center, VPos::Center));
                let w = top.dim_in_pixel().0 as i32;
                top.draw_text(t, &style, (w / 2, GRID_TITLE as i32 / 2 + 4))
                    .map_err(err)?;
                rest
            }
            None => root.clone(),
        };
        let cells = area.split_evenly((self.rows, self.columns));
        for (panel, cell) in self.panels.iter().zip(&cells) {
            panel.draw(cell, self.scale, bitmap)?;
        }
        Ok(())
    }
}

impl Panel<'_> {
    /// The one chart-drawing routine, generic over the PNG and SVG backends:
    /// title, note, axes, curves, legend, markers. `s` scales text and
    /// spacing (1 for a 1200x800 plot). With `bitmap`, 2 px lines are
    /// stroked as three anti-aliased 1 px lines offset by a pixel: plotters
    /// fills wide lines as unsmoothed polygons whose thickness varies with
    /// the slope, which looks ragged in a PNG (an SVG gets true strokes).
    fn draw<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        s: f64,
        bitmap: bool,
    ) -> Result<(), String> {
        let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        let px = |v: f64| (v * s).round() as i32;
        let font = |size: f64| (FONT, size * s).into_font();
        let mut area = area.margin(px(10.0), 0, 0, 0);
        if !self.title.is_empty() {
            area = area.titled(self.title, font(30.0)).map_err(err)?;
        }
        if let Some(note) = self.note {
            let (w, h) = area.dim_in_pixel();
            let (main, foot) = area.split_vertically(h.saturating_sub(px(34.0) as u32));
            let grey = BLACK.mix(0.75);
            let style = TextStyle::from(font(18.0)).color(&grey);
            let anchor = style.pos(Pos::new(HPos::Center, VPos::Center));
            foot.draw_text(note, &anchor, (w as i32 / 2, px(12.0)))
                .map_err(err)?;
            area = main;
        }

        let (x_labels, y_labels) = if s < 1.0 { (7, 6) } else { (12, 10) };
        let x_axis = XAxis {
            lin: self.xr.clone().into(),
            log: self.log_x,
            decimals: tick_decimals(&x_ticks(false, self.xr.start, self.xr.end, x_labels, false)),
        };
        let y_decimals =
            tick_decimals(&x_ticks(false, self.yr.start, self.yr.end, y_labels, false));
        let y_format = |v: &f64| tick_label(*v, y_decimals);
        let mut chart = ChartBuilder::on(&area)
            .margin(px(20.0))
            .x_label_area_size(px(60.0))
            .y_label_area_size(px(90.0))
            .build_cartesian_2d(x_axis, self.yr.clone())
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(self.x_label)
            .y_desc(self.y_label)
            .axis_desc_style(font(22.0))
            .label_style(font(18.0))
            .x_labels(x_labels)
            .y_labels(y_labels)
            .y_label_formatter(&y_format)
            .light_line_style(BLACK.mix(0.05))
            .bold_line_style(BLACK.mix(0.15))
            .draw()
            .map_err(err)?;

        // Pixel geometry of the plotting area, for placing legend and labels.
        let (xpix, ypix) = chart.plotting_area().get_pixel_range();
        let origin = (xpix.start, ypix.start);
        let frame = Rect {
            x0: 0,
            y0: 0,
            x1: xpix.end - xpix.start,
            y1: ypix.end - ypix.start,
        };
        let spec = chart.as_coord_spec().clone();
        let to_px = |p: &(f64, f64)| {
            let (x, y) = spec.translate(p);
            (x - origin.0, y - origin.1)
        };
        let mut occupied = Occupancy::new(frame.x1, frame.y1);

        // Reference curves first, so the others are drawn over them. Lines
        // are drawn in pixels by `polyline_paths`, not plotters' line
        // series: see there.
        let plot = chart.plotting_area().strip_coord_spec();
        let order = self.curves.iter().filter(|c| c.reference);
        let order = order.chain(self.curves.iter().filter(|c| !c.reference));
        let dash = (f64::from(px(8.0).max(2)), f64::from(px(6.0).max(2)));
        for c in order {
            let width = if c.reference { 1 } else { 2 };
            let style = c.color.stroke_width(width);
            for (xy, is_dashed) in &c.pieces {
                let pixels: Vec<_> = xy.iter().map(to_px).collect();
                occupied.mark_path(&pixels);
                if let [p] = pixels[..] {
                    // A lone point has no segment to show, so mark it.
                    let r = px(4.0).max(2);
                    plot.draw(&Circle::new(p, r, c.color.filled()))
                        .map_err(err)?;
                }
                for path in polyline_paths(&pixels, is_dashed.then_some(dash)) {
                    if bitmap && width == 2 {
                        for (dx, dy) in [(0, 0), (1, 0), (0, 1)] {
                            let moved = path.iter().map(|&(x, y)| (x + dx, y + dy));
                            let thin = c.color.stroke_width(1);
                            plot.draw(&PathElement::new(moved.collect::<Vec<_>>(), thin))
                                .map_err(err)?;
                        }
                    } else {
                        plot.draw(&PathElement::new(path, style)).map_err(err)?;
                    }
                }
            }
        }
        let markers: Vec<(i32, i32)> = self.markers.iter().map(|m| to_px(&m.0)).collect();

        // Legend: curves in their given order, in the corner hiding least.
        let entries: Vec<&Prepared> = self
            .curves
            .iter()
            .filter(|c| !c.pieces.is_empty() && !c.label.is_empty())
            .collect();
        let mut legend_box = None;
        if !entries.is_empty() && entries.len() <= MAX_LEGEND_ENTRIES {
            let label_style = TextStyle::from(font(18.0));
            let mut text = MultiLineText::<_, &str>::new((0, 0), &label_style);
            for c in &entries {
                text.push_line(c.label);
            }
            let (tw, th) = text.estimate_dimension().map_err(|e| e.to_string())?;
            let (margin, swatch) = (px(10.0), px(30.0));
            let (w, h) = (tw + swatch + 2 * margin, th + 2 * margin);
            let gap = px(5.0);
            // Corners first, then edge middles and the centre: a legend may
            // leave a corner only to hide less data.
            let (xl, xm, xr) = (gap, (frame.x1 - w) / 2, frame.x1 - w - gap);
            let (yt, ym, yb) = (gap, (frame.y1 - h) / 2, frame.y1 - h - gap);
            let spots = [
                (xl, yt),
                (xr, yt),
                (xr, yb),
                (xl, yb),
                (xm, yt),
                (xm, yb),
                (xl, ym),
                (xr, ym),
                (xm, ym),
            ];
            let hidden = |r: &Rect| {
                let dots = markers
                    .iter()
                    .filter(|&&(x, y)| r.x0 <= x && x < r.x1 && r.y0 <= y && y < r.y1)
                    .count();
                occupied.count(r) + 50 * dots
            };
            let rect = spots
                .iter()
                .map(|&(x, y)| Rect {
                    x0: x,
                    y0: y,
                    x1: x + w,
                    y1: y + h,
                })
                .enumerate()
                .min_by_key(|(i, r)| {
                    let corner = if *i < 4 { 0 } else { 3 };
                    (hidden(r) + corner, *i)
                })
                .map_or(
                    Rect {
                        x0: xl,
                        y0: yt,
                        x1: xl + w,
                        y1: yt + h,
                    },
                    |(_, r)| r,
                );
            for c in &entries {
                let width = if c.reference { 2 } else { 3 };
                let style = c.color.stroke_width(width);
                let dashed = c.legend_dashed;
                let (seg, on, off) = (px(22.0), dash.0 as u32, dash.1 as u32);
                chart
                    .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
                    .map_err(err)?
                    .label(c.label)
                    .legend(move |(x, y)| {
                        let ends = [(x, y), (x + seg, y)];
                        match dashed {
                            true => DashedPathElement::new(ends, on, off, style).into_dyn(),
                            false => PathElement::new(ends, style).into_dyn(),
                        }
                    });
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::Coordinate(rect.x0, rect.y0))
                .margin(margin)
                .legend_area_size(swatch)
                .label_font(label_style)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK.mix(0.4))
                .draw()
                .map_err(err)?;
            legend_box = Some(rect);
        }

        // Markers: black dot in a white ring, label beside it where it
        // collides least with the frame, legend, other labels and curves.
        let r = px(6.0).max(3);
        let symbols: Vec<Rect> = markers
            .iter()
            .map(|&(x, y)| Rect {
                x0: x - r,
                y0: y - r,
                x1: x + r + 1,
                y1: y + r + 1,
            })
            .collect();
        for &(x, y) in &markers {
            plot.draw(&Circle::new((x, y), r, WHITE.filled()))
                .map_err(err)?;
            plot.draw(&Circle::new((x, y), r - px(1.5).max(1), BLACK.filled()))
                .map_err(err)?;
        }
        let label_style = TextStyle::from(font(20.0)).color(&BLACK);
        let mut placed: Vec<Rect> = legend_box.into_iter().collect();
        for (j, (&(x, y), m)) in markers.iter().zip(&self.markers).enumerate() {
            if m.1.is_empty() {
                continue;
            }
            let (w, h) = plot.estimate_text_size(m.1, &label_style).map_err(err)?;
            let (w, h, pad, g) = (w as i32, h as i32, px(3.0), r + px(4.0));
            // Right/left, above/below, then straight above/below.
            let spots = [
                (x + g, y - g - h),
                (x + g, y + g),
                (x - g - w, y - g - h),
                (x - g - w, y + g),
                (x + g, y - h / 2),
                (x - g - w, y - h / 2),
                (x - w / 2, y - g - h),
                (x - w / 2, y + g),
            ];
            let boxed = |&(lx, ly): &(i32, i32)| Rect {
                x0: lx - pad,
                y0: ly - pad,
                x1: lx + w + pad,
                y1: ly + h + pad,
            };
            let cost = |b: &Rect, i: usize| {
                let outside = usize::from(!b.within(&frame)) * 100_000;
                let labels = placed.iter().filter(|p| p.overlaps(b)).count() * 10_000;
                let dots = symbols.iter().filter(|p| p.overlaps(b)).count() * 5_000;
                // A label nearer to another marker than to its own misleads.
                let own = b.distance2((x, y));
                let closer = markers
                    .iter()
                    .enumerate()
                    .filter(|&(k, &p)| k != j && b.distance2(p) < own)
                    .count();
                outside + labels + dots + closer * 5_000 + occupied.count(b) * 10 + i
            };
            let (i, b) = spots
                .iter()
                .map(boxed)
                .enumerate()
                .min_by_key(|(i, b)| cost(b, *i))
                .unwrap_or((0, boxed(&spots[0])));
            let (lx, ly) = spots[i];
            plot.draw(&Rectangle::new(
                [(b.x0, b.y0), (b.x1, b.y1)],
                WHITE.mix(0.8).filled(),
            ))
            .map_err(err)?;
            plot.draw(&Text::new(m.1, (lx, ly), &label_style))
                .map_err(err)?;
            placed.push(b);
        }
        Ok(())
    }
}

/// Splits a pixel polyline into the paths to stroke (after thinning out
/// points closer than 2 px): its dashes (`dash` =
/// on/off lengths in pixels, phase kept across vertices) or the whole line,
/// each further cut wherever it turns by more than 120 degrees. plotters'
/// bitmap backend strokes a wide path as one polygon with unlimited inner
/// miters, so a sharp turn (a fold of a branch, doubling back) would draw a
/// long spike; cutting there leaves plain butt ends instead.
fn polyline_paths(pixels: &[(i32, i32)], dash: Option<(f64, f64)>) -> Vec<Vec<(i32, i32)>> {
    // Thin out points closer than 2 px to the last kept one: dense data
    // rounded to whole pixels zigzags, which a wide stroke shows as a
    // ragged edge. The last point is always kept.
    let far = |p: (i32, i32), q: (i32, i32)| {
        let (dx, dy) = (i64::from(p.0 - q.0), i64::from(p.1 - q.1));
        dx * dx + dy * dy >= 4
    };
    let mut pts: Vec<(i32, i32)> = Vec::with_capacity(pixels.len());
    for &p in pixels {
        if pts.last().is_none_or(|&q| far(p, q)) {
            pts.push(p);
        }
    }
    // Keep the exact end, dropping a kept point right before it.
    if let (Some(&end), Some(&kept)) = (pixels.last(), pts.last()) {
        if end != kept {
            if pts.len() > 1 {
                pts.pop();
            }
            pts.push(end);
        }
    }
    if pts.len() < 2 {
        return Vec::new();
    }
    let lines = match dash {
        None => vec![pts],
        Some((on, off)) => {
            let f = |p: (i32, i32)| (f64::from(p.0), f64::from(p.1));
            let round = |p: (f64, f64)| (p.0.round() as i32, p.1.round() as i32);
            let (mut solid, mut left) = (true, on);
            let mut out = Vec::new();
            let mut cur = vec![pts[0]];
            for w in pts.windows(2) {
                let (mut a, b) = (f(w[0]), f(w[1]));
                loop {
                    let d = (b.0 - a.0).hypot(b.1 - a.1);
                    if d <= left {
                        left -= d;
                        if solid {
                            cur.push(w[1]);
                        }
                        break;
                    }
                    let t = left / d;
                    a = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
                    if solid {
                        cur.push(round(a));
                        out.push(std::mem::take(&mut cur));
                    } else {
                        cur = vec![round(a)];
                    }
                    solid = !solid;
                    left = if solid { on } else { off };
                }
            }
            if solid {
                out.push(cur);
            }
            out
        }
    };
    let mut out = Vec::new();
    for mut line in lines {
        line.dedup();
        let mut start = 0;
        for i in 1..line.len().saturating_sub(1) {
            let (a, b, c) = (line[i - 1], line[i], line[i + 1]);
            let (u, v) = ((b.0 - a.0, b.1 - a.1), (c.0 - b.0, c.1 - b.1));
            let dot = f64::from(u.0 * v.0 + u.1 * v.1);
            let norms =
                f64::from(u.0 * u.0 + u.1 * u.1).sqrt() * f64::from(v.0 * v.0 + v.1 * v.1).sqrt();
            if dot < -0.5 * norms {
                out.push(line[start..=i].to_vec());
                start = i;
            }
        }
        if line.len() - start >= 2 {
            out.push(line[start..].to_vec());
        }
    }
    out
}

/// `stem` + suffix. Not `Path::with_extension`, which would turn a stem like
/// `fep_amp0.5` into `fep_amp0.png`.
fn with_suffix(stem: &Path, suffix: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// min..max with a relative margin; a degenerate span gets `min_half` (or a
/// size relative to the value) on each side so a single point stays visible.
fn padded_range(values: impl Iterator<Item = f64>, margin: f64, min_half: f64) -> Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    // Clamp so spans near f64::MAX cannot overflow to an infinite range.
    let (lo, hi) = (lo.clamp(-1e300, 1e300), hi.clamp(-1e300, 1e300));
    let span = hi - lo;
    if span > 1e-12 * lo.abs().max(hi.abs()) && span > 0.0 {
        return lo - margin * span..hi + margin * span;
    }
    let half = if min_half > 0.0 {
        min_half
    } else if lo != 0.0 {
        0.1 * lo.abs()
    } else {
        1.0
    };
    lo - half..hi + half
}

/// x axis in plot coordinates (log10 values when `log`): linear mapping,
/// with tick placement and labels that know about the log transform.
/// (plotters' own `LogCoord` labels every minor tick, hence this type.)
#[derive(Clone)]
struct XAxis {
    lin: RangedCoordf64,
    log: bool,
    /// Linear axis: decimals of the tick labels, see [`tick_decimals`].
    decimals: Option<usize>,
}

impl Ranged for XAxis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;
    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        self.lin.map(v, limit)
    }
    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        let r = self.lin.range();
        let light = hint.weight().allow_light_points();
        x_ticks(self.log, r.start, r.end, hint.max_num_points(), light)
    }
    fn range(&self) -> Range<f64> {
        self.lin.range()
    }
}

impl ValueFormatter<f64> for XAxis {
    fn format_ext(&self, v: &f64) -> String {
        // Mirrors `x_ticks`: fewer than 3 whole decades means mantissa ticks,
        // which read better as plain numbers when those are short.
        if !self.log {
            return tick_label(*v, self.decimals);
        }
        let r = self.lin.range();
        let plain = r.end.floor() - r.start.ceil() < 2.0;
        x_tick_label(true, *v, plain)
    }
}

/// Tick positions. Linear axes use plotters' own nice numbers. Log axes
/// (positions are log10 values) tick whole decades, or 1-2-5 / 1..9 mantissas
/// when the range covers too few decades to be readable; `light` gives the
/// minor grid at 1..9 x 10^k.
fn x_ticks(log: bool, lo: f64, hi: f64, n: usize, light: bool) -> Vec<f64> {
    if !log {
        let lin = RangedCoordf64::from(lo..hi);
        return if light {
            lin.key_points(n.max(1))
        } else {
            lin.key_points(BoldPoints(n.max(1)))
        };
    }
    let (k0, k1) = (lo.floor() as i32, hi.ceil() as i32);
    let with = |ms: &[f64]| -> Vec<f64> {
        (k0..=k1)
            .flat_map(|k| ms.iter().map(move |m| m.log10() + f64::from(k)))
            .filter(|u| (lo..=hi).contains(u))
            .collect()
    };
    let all: Vec<f64> = (1..=9).map(f64::from).collect();
    if light {
        return if k1 - k0 <= 20 {
            with(&all)
        } else {
            Vec::new()
        };
    }
    let decades = with(&[1.0]);
    if decades.len() >= 3 {
        let step = decades.len().div_ceil(n.max(1)).max(1);
        return decades.into_iter().step_by(step).collect();
    }
    let ticks = with(&[1.0, 2.0, 5.0]);
    if ticks.len() >= 3 { ticks } else { with(&all) }
}

/// Tick text: decades as 10ⁿ (superscripts, which DejaVu has), other log
/// ticks as m×10ⁿ or, if `plain` and short, as plain numbers (0.05, 2, 300);
/// linear ticks with plotters' float formatting, like the y axis.
fn x_tick_label(log: bool, u: f64, plain: bool) -> String {
    if !log {
        return RangedCoordf64::format(&u);
    }
    let k = (u + 1e-9).floor();
    let m = 10f64.powf(u - k).round();
    if plain && (-3.0..4.0).contains(&k) {
        return format!("{:.*}", (-k).max(0.0) as usize, m * 10f64.powf(k));
    }
    let sup: String = format!("{}", k as i32)
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            d => ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹']
                [d.to_digit(10).unwrap_or(0) as usize],
        })
        .collect();
    if m == 1.0 {
        format!("10{sup}")
    } else {
        format!("{m}×10{sup}")
    }
}

/// Decimals that print every tick of a linear axis exactly and alike
/// (`0.0 0.5 1.0`, `0 2 4`), or `None` where plotters' own format reads
/// better (huge or tiny numbers).
fn tick_decimals(ticks: &[f64]) -> Option<usize> {
    let big = ticks.iter().fold(0.0f64, |m, t| m.max(t.abs()));
    let step = ticks
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(f64::INFINITY, f64::min);
    if ticks.len() < 2 || !step.is_finite() || step <= 0.0 || big >= 1e6 {
        return None;
    }
    (0..=5).find(|&d| {
        let k = 10f64.powi(d as i32);
        ticks
            .iter()
            .all(|t| ((t * k).round() - t * k).abs() <= 1e-3 * step * k)
    })
}

/// A linear tick label with `decimals` places, else plotters' format.
fn tick_label(v: f64, decimals: Option<usize>) -> String {
    match decimals {
        Some(d) => {
            let k = 10f64.powi(d as i32);
            let r = (v * k).round() / k;
            // No "-0.0".
            format!("{:.d$}", if r == 0.0 { 0.0 } else { r })
        }
        None => RangedCoordf64::format(&v),
    }
}

/// Tableau-10 for up to 10 curves; beyond that golden-ratio hue steps with
/// cycling lightness keep ~35 curves (NNM branches) apart on white.
fn palette(i: usize, n: usize) -> RGBColor {
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

#[cfg(test)]
mod tests;
