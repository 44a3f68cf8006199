//! Axis ranges (fixed or fitted), the x axis type with its log-aware ticks,
//! and tick labels.

use std::ops::Range;

use plotters::coord::ranged1d::{
    BoldPoints, KeyPointHint, NoDefaultFormatting, Ranged, ValueFormatter,
};
use plotters::coord::types::RangedCoordf64;

use crate::PlotError;

/// Validates a fixed range (either order) and maps it to plot coordinates.
pub(crate) fn axis_range(
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

/// min..max with a relative margin; a degenerate span gets `min_half` (or a
/// size relative to the value) on each side so a single point stays visible.
pub(crate) fn padded_range(
    values: impl Iterator<Item = f64>,
    margin: f64,
    min_half: f64,
) -> Range<f64> {
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
pub(crate) struct XAxis {
    pub(crate) lin: RangedCoordf64,
    pub(crate) log: bool,
    /// Linear axis: decimals of the tick labels, see [`tick_decimals`].
    pub(crate) decimals: Option<usize>,
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
pub(crate) fn x_ticks(log: bool, lo: f64, hi: f64, n: usize, light: bool) -> Vec<f64> {
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
pub(crate) fn x_tick_label(log: bool, u: f64, plain: bool) -> String {
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
pub(crate) fn tick_decimals(ticks: &[f64]) -> Option<usize> {
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
pub(crate) fn tick_label(v: f64, decimals: Option<usize>) -> String {
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
