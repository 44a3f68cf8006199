//! The common description every public plot type is lowered to
//! ([`Figure`]: curves of pieces in data units) and its preparation into a
//! [`Panel`] in plot coordinates: invalid points dropped, axis ranges fixed,
//! curves clipped and coloured.

use plotters::style::RGBColor;

use crate::axes::{axis_range, padded_range};
use crate::clip::{clip_polyline, contains};
use crate::panel::{Panel, Prepared};
use crate::style::{REFERENCE_GREY, palette};
use crate::{Marker, PlotError};

/// A polyline drawn in one style.
pub(crate) struct Piece {
    pub(crate) xy: Vec<(f64, f64)>,
    pub(crate) dashed: bool,
}

/// A labelled curve, one colour, possibly several pieces.
pub(crate) struct Curve<'a> {
    pub(crate) label: &'a str,
    /// Legend swatch style: FEP branches show their colour solid (dashes
    /// mean instability there), generic lines show their own style.
    pub(crate) legend_dashed: bool,
    pub(crate) reference: bool,
    pub(crate) color: Option<(u8, u8, u8)>,
    /// Line width in pixels at the single-plot size; `None`: 1 for a reference, else 2.
    pub(crate) width: Option<u32>,
    pub(crate) pieces: Vec<Piece>,
}

/// One chart as the public types describe it, in data units.
pub(crate) struct Figure<'a> {
    pub(crate) title: &'a str,
    pub(crate) x_label: &'a str,
    pub(crate) y_label: &'a str,
    pub(crate) log_x: bool,
    pub(crate) curves: Vec<Curve<'a>>,
    pub(crate) markers: &'a [Marker],
    pub(crate) x_range: Option<(f64, f64)>,
    pub(crate) y_range: Option<(f64, f64)>,
    pub(crate) note: Option<String>,
    /// Label each curve at its end instead of drawing a legend.
    pub(crate) end_labels: bool,
}

type Pieces = Vec<(Vec<(f64, f64)>, bool)>;

impl<'a> Figure<'a> {
    /// Maps to plot coordinates, splits lines wherever a point cannot be
    /// drawn (so no segment bridges a gap), fixes the axis ranges (a free
    /// axis fits the data inside the other axis' fixed range) and clips.
    pub(crate) fn prepare(self) -> Result<Panel<'a>, PlotError> {
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
            .filter_map(|m| Some((map((m.x, m.y))?, m.label.as_str(), m.shape)))
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
                    width: c.width.unwrap_or(if c.reference { 1 } else { 2 }),
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
            end_labels: self.end_labels,
            curves,
            markers,
            xr,
            yr,
        })
    }
}
