//! Plots for nnm: frequency-energy plots (FEPs) of NNM backbones and generic
//! line plots, each written as both PNG (quick look) and SVG (papers, zooming).
//!
//! The machines this runs on may have no system fonts, so all text is drawn
//! with plotters' `ab_glyph` backend from DejaVu Sans embedded in the binary
//! (see [`register_fonts`]). Both public plot types are lowered to one
//! internal [`Figure`] that a single drawing routine renders, so the FEP and
//! the generic plot share axes, fonts, palette and legend handling.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::ranged1d::{BoldPoints, KeyPointHint, NoDefaultFormatting, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::element::{DashedPathElement, IntoDynElement};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{FontStyle, register_font};

/// PNG size in pixels; the SVG uses the same logical size.
const SIZE: (u32, u32) = (1200, 800);
/// Font family name under which DejaVu Sans is registered.
const FONT: &str = "sans-serif";
/// Above this many series a legend would hide the data, so none is drawn.
const MAX_LEGEND_ENTRIES: usize = 12;

/// Errors from building or writing a plot. Bad data never panics.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// Nothing drawable: no series/lines, or every point was skipped
    /// (NaN/infinite, or non-positive on a log axis).
    #[error("nothing to plot: no finite points{0}")]
    NoData(&'static str),
    /// The embedded font could not be registered with plotters.
    #[error("could not register the embedded DejaVu font")]
    Font,
    /// plotters failed while drawing or writing a file.
    #[error("failed to draw {path}: {message}")]
    Draw { path: PathBuf, message: String },
}

/// One NNM branch of a frequency-energy plot.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub label: String,
    /// Points in continuation order; consecutive points are joined.
    pub points: Vec<SeriesPoint>,
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
#[derive(Debug, Clone, PartialEq)]
pub struct FrequencyEnergyPlot {
    pub title: String,
    pub series: Vec<Series>,
    /// y-axis label, e.g. `"frequency (rad/s)"`.
    pub frequency_label: String,
}

impl FrequencyEnergyPlot {
    /// Writes `<stem>.png` and `<stem>.svg` (stem is a path without extension).
    ///
    /// Points with non-finite values or energy <= 0 are skipped and break the
    /// line there. A segment between two points is drawn stable only if both
    /// ends are stable, so a stability change is never hidden.
    pub fn write(&self, stem: &Path) -> Result<(), PlotError> {
        let curves = self
            .series
            .iter()
            .map(|s| Curve {
                label: s.label.clone(),
                legend_dashed: false,
                pieces: stability_pieces(&s.points),
            })
            .collect();
        Figure {
            title: &self.title,
            x_label: "total energy",
            y_label: &self.frequency_label,
            log_x: true,
            curves,
            note: Some("solid: stable    dashed: unstable"),
        }
        .write(stem)
    }
}

/// Generic line plot (time series, mode shapes per sector, ...).
#[derive(Debug, Clone, PartialEq)]
pub struct LinePlot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    /// Log10 x axis; points with x <= 0 are then skipped.
    pub log_x: bool,
    pub lines: Vec<Line>,
}

/// One line of a [`LinePlot`].
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    pub label: String,
    /// Points joined in order; non-finite points break the line.
    pub xy: Vec<(f64, f64)>,
    pub dashed: bool,
}

impl LinePlot {
    /// Writes `<stem>.png` and `<stem>.svg` (stem is a path without extension).
    pub fn write(&self, stem: &Path) -> Result<(), PlotError> {
        let curves = self
            .lines
            .iter()
            .map(|l| Curve {
                label: l.label.clone(),
                legend_dashed: l.dashed,
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
            note: None,
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
struct Curve {
    label: String,
    /// Legend swatch style: FEP branches show their colour solid (dashes
    /// mean instability there), generic lines show their own style.
    legend_dashed: bool,
    pieces: Vec<Piece>,
}

/// What the single drawing routine renders; both public plots lower to this.
struct Figure<'a> {
    title: &'a str,
    x_label: &'a str,
    y_label: &'a str,
    log_x: bool,
    curves: Vec<Curve>,
    note: Option<&'a str>,
}

/// A curve in plot coordinates (x already log10'd), split at invalid points.
struct Prepared {
    color: RGBColor,
    pieces: Vec<(Vec<(f64, f64)>, bool)>,
}

impl Figure<'_> {
    fn write(&self, stem: &Path) -> Result<(), PlotError> {
        register_fonts()?;
        let curves = self.prepare();
        let pts = || {
            curves
                .iter()
                .flat_map(|c| c.pieces.iter().flat_map(|p| p.0.iter()))
        };
        if pts().next().is_none() {
            return Err(PlotError::NoData(if self.log_x {
                " (log axis needs x > 0)"
            } else {
                ""
            }));
        }
        let xr = padded_range(pts().map(|p| p.0), 0.03, if self.log_x { 0.5 } else { 0.0 });
        let yr = padded_range(pts().map(|p| p.1), 0.06, 0.0);

        let png = with_suffix(stem, ".png");
        let root = BitMapBackend::new(&png, SIZE).into_drawing_area();
        self.draw(&root, &curves, xr.clone(), yr.clone())
            .and_then(|()| root.present().map_err(|e| e.to_string()))
            .map_err(|message| PlotError::Draw {
                path: png.clone(),
                message,
            })?;
        let svg = with_suffix(stem, ".svg");
        let root = SVGBackend::new(&svg, SIZE).into_drawing_area();
        self.draw(&root, &curves, xr, yr)
            .and_then(|()| root.present().map_err(|e| e.to_string()))
            .map_err(|message| PlotError::Draw {
                path: svg.clone(),
                message,
            })
    }

    /// Maps to plot coordinates, assigns colours, and splits lines wherever a
    /// point cannot be drawn (so no segment bridges a gap).
    fn prepare(&self) -> Vec<Prepared> {
        let n = self.curves.len();
        let map = |&(x, y): &(f64, f64)| {
            let x = if self.log_x {
                if x > 0.0 { x.log10() } else { f64::NAN }
            } else {
                x
            };
            (x.is_finite() && y.is_finite()).then_some((x, y))
        };
        let mut out = Vec::with_capacity(n);
        for (i, c) in self.curves.iter().enumerate() {
            let mut pieces = Vec::new();
            for p in &c.pieces {
                let mut run = Vec::new();
                for q in &p.xy {
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
            out.push(Prepared {
                color: palette(i, n),
                pieces,
            });
        }
        out
    }

    /// The one drawing routine, generic over the PNG and SVG backends.
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, plotters::coord::Shift>,
        curves: &[Prepared],
        xr: Range<f64>,
        yr: Range<f64>,
    ) -> Result<(), String> {
        let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        root.fill(&WHITE).map_err(err)?;
        let mut area = root
            .margin(10, 0, 0, 0)
            .titled(self.title, (FONT, 30))
            .map_err(err)?;
        if let Some(note) = self.note {
            let (h, w) = (area.dim_in_pixel().1, area.dim_in_pixel().0);
            let (main, foot) = area.split_vertically(h.saturating_sub(34));
            let grey = BLACK.mix(0.75);
            let style = TextStyle::from((FONT, 18).into_font()).color(&grey);
            let anchor = style.pos(Pos::new(HPos::Center, VPos::Center));
            foot.draw_text(note, &anchor, (w as i32 / 2, 12))
                .map_err(err)?;
            area = main;
        }

        let x_axis = XAxis {
            lin: xr.into(),
            log: self.log_x,
        };
        let mut chart = ChartBuilder::on(&area)
            .margin(20)
            .x_label_area_size(60)
            .y_label_area_size(90)
            .build_cartesian_2d(x_axis, yr)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(self.x_label)
            .y_desc(self.y_label)
            .axis_desc_style((FONT, 22))
            .label_style((FONT, 18))
            .x_labels(12)
            .y_labels(10)
            .light_line_style(BLACK.mix(0.05))
            .bold_line_style(BLACK.mix(0.15))
            .draw()
            .map_err(err)?;

        let legend = curves.len() <= MAX_LEGEND_ENTRIES;
        for (c, curve) in curves.iter().zip(&self.curves) {
            let style = c.color.stroke_width(2);
            for (k, (xy, is_dashed)) in c.pieces.iter().enumerate() {
                let ann = if xy.len() == 1 {
                    // A lone point has no segment to show, so mark it.
                    chart.draw_series(std::iter::once(Circle::new(xy[0], 4, c.color.filled())))
                } else if *is_dashed {
                    chart.draw_series(DashedLineSeries::new(xy.iter().copied(), 8, 6, style))
                } else {
                    chart.draw_series(LineSeries::new(xy.iter().copied(), style))
                }
                .map_err(err)?;
                if legend && k == 0 && !curve.label.is_empty() {
                    let (style, dashed) = (c.color.stroke_width(3), curve.legend_dashed);
                    ann.label(curve.label.as_str()).legend(move |(x, y)| {
                        let ends = [(x, y), (x + 22, y)];
                        match dashed {
                            true => DashedPathElement::new(ends, 6, 4, style).into_dyn(),
                            false => PathElement::new(ends, style).into_dyn(),
                        }
                    });
                }
            }
        }
        if legend
            && curves
                .iter()
                .zip(&self.curves)
                .any(|(c, l)| !c.pieces.is_empty() && !l.label.is_empty())
        {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperLeft)
                .label_font((FONT, 18))
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK.mix(0.4))
                .draw()
                .map_err(err)?;
        }
        Ok(())
    }
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
        let r = self.lin.range();
        let plain = r.end.floor() - r.start.ceil() < 2.0;
        x_tick_label(self.log, *v, plain)
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
