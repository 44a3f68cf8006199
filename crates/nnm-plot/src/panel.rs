//! A chart ready to draw ([`Panel`]) and the one routine that draws every
//! chart: axes, curves (stroked in pixels), legend and markers.

use std::ops::Range;

use plotters::coord::Shift;
use plotters::element::{DashedPathElement, IntoDynElement, MultiLineText};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::axes::{XAxis, tick_decimals, tick_label, x_ticks};
use crate::occupancy::{Occupancy, Rect};
use crate::style::{FONT, MAX_LEGEND_ENTRIES};

/// A curve in plot coordinates (x already log10'd), split at invalid points
/// and clipped to the axis ranges.
pub(crate) struct Prepared<'a> {
    pub(crate) label: &'a str,
    pub(crate) legend_dashed: bool,
    pub(crate) reference: bool,
    pub(crate) color: RGBColor,
    /// Line width in pixels at scale 1.
    pub(crate) width: u32,
    pub(crate) pieces: Vec<(Vec<(f64, f64)>, bool)>,
}

/// A chart ready to draw: plot coordinates, final axis ranges, colours.
pub(crate) struct Panel<'a> {
    pub(crate) title: &'a str,
    pub(crate) x_label: &'a str,
    pub(crate) y_label: &'a str,
    pub(crate) log_x: bool,
    pub(crate) note: Option<String>,
    /// Label each curve at its end instead of drawing a legend.
    pub(crate) end_labels: bool,
    pub(crate) curves: Vec<Prepared<'a>>,
    pub(crate) markers: Vec<((f64, f64), &'a str, crate::MarkerShape)>,
    pub(crate) xr: Range<f64>,
    pub(crate) yr: Range<f64>,
}

impl Panel<'_> {
    /// The one chart-drawing routine, generic over the PNG and SVG backends:
    /// title, note, axes, curves, legend, markers. `s` scales text and
    /// spacing (1 for a 1200x800 plot). With `bitmap`, 2 px lines are
    /// stroked as three anti-aliased 1 px lines offset by a pixel: plotters
    /// fills wide lines as unsmoothed polygons whose thickness varies with
    /// the slope, which looks ragged in a PNG (an SVG gets true strokes).
    pub(crate) fn draw<DB: DrawingBackend>(
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
        if let Some(note) = self.note.as_deref() {
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

        // Reference curves first, then the others from the widest down, so that a narrow
        // curve lying on a wide one leaves it visible. Lines are drawn in pixels by
        // `polyline_paths`, not plotters' line series: see there.
        let plot = chart.plotting_area().strip_coord_spec();
        let mut order: Vec<&Prepared> = self.curves.iter().collect();
        order.sort_by_key(|c| (!c.reference, std::cmp::Reverse(c.width)));
        let dash = (f64::from(px(8.0).max(2)), f64::from(px(6.0).max(2)));
        for c in order {
            let width = c.width;
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
                    if bitmap && width >= 2 {
                        for (dx, dy) in stroke_offsets(width) {
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
        if !self.end_labels && !entries.is_empty() && entries.len() <= MAX_LEGEND_ENTRIES {
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
                let width = c.width + 1;
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
        for (&(x, y), m) in markers.iter().zip(&self.markers) {
            draw_symbol(&plot, (x, y), r, px(1.5).max(1), m.2).map_err(err)?;
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
            // A label nearer to another marker than to its own misleads.
            let closer = |b: &Rect| {
                let own = b.distance2((x, y));
                let nearer = markers
                    .iter()
                    .enumerate()
                    .filter(|&(k, &p)| k != j && b.distance2(p) < own)
                    .count();
                nearer * 5_000
            };
            let crowd = Crowd {
                frame: &frame,
                placed: &placed,
                symbols: &symbols,
                occupied: &occupied,
            };
            let ((lx, ly), b) = crowd.best_spot(&spots, (w, h), pad, closer);
            plot.draw(&Rectangle::new(
                [(b.x0, b.y0), (b.x1, b.y1)],
                WHITE.mix(0.8).filled(),
            ))
            .map_err(err)?;
            plot.draw(&Text::new(m.1, (lx, ly), &label_style))
                .map_err(err)?;
            placed.push(b);
        }

        // Curve labels at the curves' ends, in their colours: beside the last point, where
        // they overlap least with other labels, markers and curves.
        if self.end_labels {
            let style = TextStyle::from(font(17.0));
            for c in &entries {
                let Some(&end) = c.pieces.last().and_then(|p| p.0.last()) else {
                    continue;
                };
                let (x, y) = to_px(&end);
                let (w, h) = plot.estimate_text_size(c.label, &style).map_err(err)?;
                let (w, h, pad, g) = (w as i32, h as i32, px(2.0), px(5.0));
                let mut spots = vec![
                    (x + g, y - h / 2),
                    (x + g, y - h - g),
                    (x + g, y + g),
                    (x - g - w, y - h - g),
                    (x - g - w, y + g),
                    (x - g - w, y - h / 2),
                    (x - w / 2, y - h - g),
                    (x - w / 2, y + g),
                ];
                // Where curves end close together, further out, joined to the end by a
                // leader line.
                let near = spots.len();
                for k in 1..=6 {
                    let step = k * (h + 2 * pad);
                    for dx in [x + 3 * g, x - 3 * g - w] {
                        spots.push((dx, y - h / 2 - step));
                        spots.push((dx, y - h / 2 + step));
                    }
                }
                let crowd = Crowd {
                    frame: &frame,
                    placed: &placed,
                    symbols: &symbols,
                    occupied: &occupied,
                };
                // A distant spot only to avoid an overlap: it costs more than any curve it
                // would hide near the end.
                let far = |b: &Rect| {
                    let d2 = b.distance2((x, y));
                    usize::from(d2 > i64::from(3 * (h + g)).pow(2)) * 600
                };
                let ((lx, ly), b) = crowd.best_spot(&spots, (w, h), pad, far);
                let chosen = spots.iter().position(|&p| p == (lx, ly)).unwrap_or(0);
                if chosen >= near {
                    // From the curve's end to the middle of the label's nearer side.
                    let side = if lx > x { b.x0 } else { b.x1 };
                    let leader = [(x, y), (side, (b.y0 + b.y1) / 2)];
                    plot.draw(&PathElement::new(leader, c.color.stroke_width(1)))
                        .map_err(err)?;
                }
                plot.draw(&Rectangle::new(
                    [(b.x0, b.y0), (b.x1, b.y1)],
                    WHITE.mix(0.75).filled(),
                ))
                .map_err(err)?;
                let darker = RGBColor(c.color.0 / 4 * 3, c.color.1 / 4 * 3, c.color.2 / 4 * 3);
                let text = style.clone().color(&darker);
                plot.draw(&Text::new(c.label, (lx, ly), &text))
                    .map_err(err)?;
                placed.push(b);
            }
        }
        Ok(())
    }
}

/// What a label placed on a chart should not cover, most important first: the frame's
/// outside, labels already placed, marker symbols, and curves.
struct Crowd<'a> {
    frame: &'a Rect,
    placed: &'a [Rect],
    symbols: &'a [Rect],
    occupied: &'a Occupancy,
}

impl Crowd<'_> {
    /// Of `spots` (top-left corners of a `w × h` text), the one whose box, padded by `pad`,
    /// covers least (`extra` adds a cost of its own; ties go to the earlier spot), with the box.
    fn best_spot(
        &self,
        spots: &[(i32, i32)],
        (w, h): (i32, i32),
        pad: i32,
        extra: impl Fn(&Rect) -> usize,
    ) -> ((i32, i32), Rect) {
        let boxed = |&(lx, ly): &(i32, i32)| Rect {
            x0: lx - pad,
            y0: ly - pad,
            x1: lx + w + pad,
            y1: ly + h + pad,
        };
        let cost = |b: &Rect, i: usize| {
            let outside = usize::from(!b.within(self.frame)) * 100_000;
            let labels = self.placed.iter().filter(|p| p.overlaps(b)).count() * 10_000;
            let dots = self.symbols.iter().filter(|p| p.overlaps(b)).count() * 5_000;
            outside + labels + dots + extra(b) + self.occupied.count(b) * 10 + i
        };
        spots
            .iter()
            .map(|spot| (*spot, boxed(spot)))
            .enumerate()
            .min_by_key(|(i, (_, b))| cost(b, *i))
            .map_or((spots[0], boxed(&spots[0])), |(_, best)| best)
    }
}

/// A marker's symbol of radius `r` at `(x, y)`: black, in a white outline `outline` wide.
fn draw_symbol<DB: DrawingBackend>(
    plot: &DrawingArea<DB, Shift>,
    (x, y): (i32, i32),
    r: i32,
    outline: i32,
    shape: crate::MarkerShape,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    use crate::MarkerShape as S;
    let polygon = |r: i32| -> Vec<(i32, i32)> {
        match shape {
            S::Square => vec![
                (x - r, y - r),
                (x + r, y - r),
                (x + r, y + r),
                (x - r, y + r),
            ],
            S::Triangle => vec![
                (x, y - r - r / 3),
                (x + r + r / 6, y + r),
                (x - r - r / 6, y + r),
            ],
            _ => vec![
                (x, y - r - r / 4),
                (x + r, y),
                (x, y + r + r / 4),
                (x - r, y),
            ],
        }
    };
    match shape {
        S::Dot => {
            plot.draw(&Circle::new((x, y), r, WHITE.filled()))?;
            plot.draw(&Circle::new((x, y), r - outline, BLACK.filled()))
        }
        S::Ring => {
            plot.draw(&Circle::new((x, y), r, WHITE.filled()))?;
            plot.draw(&Circle::new((x, y), r - outline, BLACK.stroke_width(2)))
        }
        _ => {
            plot.draw(&Polygon::new(polygon(r), WHITE.filled()))?;
            plot.draw(&Polygon::new(polygon(r - outline), BLACK.filled()))
        }
    }
}

/// Pixel offsets of the 1 px lines that stroke a line `width` px wide in a bitmap (see
/// [`Panel::draw`]): an L of three for 2 px, a filled square beyond.
fn stroke_offsets(width: u32) -> Vec<(i32, i32)> {
    if width <= 2 {
        return vec![(0, 0), (1, 0), (0, 1)];
    }
    let w = width as i32;
    (0..w)
        .flat_map(|dx| (0..w).map(move |dy| (dx - w / 2, dy - w / 2)))
        .collect()
}

/// Splits a pixel polyline into the paths to stroke (after thinning out
/// points closer than 2 px): its dashes (`dash` =
/// on/off lengths in pixels, phase kept across vertices) or the whole line,
/// each further cut wherever it turns by more than 120 degrees. plotters'
/// bitmap backend strokes a wide path as one polygon with unlimited inner
/// miters, so a sharp turn (a fold of a branch, doubling back) would draw a
/// long spike; cutting there leaves plain butt ends instead.
pub(crate) fn polyline_paths(
    pixels: &[(i32, i32)],
    dash: Option<(f64, f64)>,
) -> Vec<Vec<(i32, i32)>> {
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
