//! Clipping polylines to the axis box.

use std::ops::Range;

pub(crate) fn contains(xr: &Range<f64>, yr: &Range<f64>, (x, y): (f64, f64)) -> bool {
    xr.start <= x && x <= xr.end && yr.start <= y && y <= yr.end
}

/// Parts of a polyline inside the closed box `xr` x `yr` (bounds may be
/// infinite), cut exactly at the frame (Liang-Barsky per segment).
pub(crate) fn clip_polyline(
    xy: &[(f64, f64)],
    xr: &Range<f64>,
    yr: &Range<f64>,
) -> Vec<Vec<(f64, f64)>> {
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
