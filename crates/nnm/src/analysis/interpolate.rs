//! Values along a computed branch between its points: where it reaches a frequency or a force
//! level, and its peak there — for the predicted resonance peaks and the backbone beside a
//! forced curve (docs/method.md §21). A branch's points are geometric in energy, so its own
//! smooth parameter is `s = ln E`: frequencies, log-peaks and log-forces are interpolated as
//! functions of `s` by the cubic through the four points around the bracket (the four nearest
//! at the ends), and a level is reached where that cubic reaches it.

/// The cubic through the four points of `(s, y)` around `[s_i, s_{i+1}]` (shifted inwards at
/// the ends; fewer if there are fewer points), at `s`.
fn cubic(s_points: &[f64], y_points: &[f64], i: usize, s: f64) -> f64 {
    let count = s_points.len().min(y_points.len());
    let from = i.saturating_sub(1).min(count.saturating_sub(4));
    let to = (from + 4).min(count);
    (from..to)
        .map(|j| {
            let weight: f64 = (from..to)
                .filter(|&k| k != j)
                .map(|k| (s - s_points[k]) / (s_points[j] - s_points[k]))
                .product();
            weight * y_points[j]
        })
        .sum()
}

/// Whether the four points around bracket `i` can carry a cubic: finite and distinct `s`.
fn interpolable(s_points: &[f64], y_points: &[f64], i: usize) -> bool {
    let count = s_points.len().min(y_points.len());
    let from = i.saturating_sub(1).min(count.saturating_sub(4));
    let to = (from + 4).min(count);
    let (s, y) = (&s_points[from..to], &y_points[from..to]);
    s.iter().chain(y).all(|v| v.is_finite()) && (0..s.len()).all(|j| (0..j).all(|k| s[j] != s[k]))
}

/// The first `i` with `value` between `values[i]` and `values[i + 1]`.
fn bracket(values: &[f64], count: usize, value: f64) -> Option<usize> {
    (0..count.saturating_sub(1)).find(|&i| {
        let (a, b) = (values[i], values[i + 1]);
        a.min(b) <= value && value <= a.max(b)
    })
}

/// `y(s)` between the points (`s` within their range, the first bracket that holds it).
pub fn value_at(s_points: &[f64], y_points: &[f64], s: f64) -> Option<f64> {
    let count = s_points.len().min(y_points.len());
    let i = bracket(s_points, count, s)?;
    value_in(s_points, y_points, Reached { s, bracket: i })
}

/// Where a level is reached along the points: `s`, in bracket `[s_i, s_{i+1}]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reached {
    /// The parameter `s` there.
    pub s: f64,
    /// `i` of the bracket `[s_i, s_{i+1}]` it is in.
    pub bracket: usize,
}

/// `y` at a [`Reached`] place, by the cubic of its own bracket — not the first bracket that
/// holds its `s`, which on a branch whose energy turns back (a tongue) is another stretch.
pub fn value_in(s_points: &[f64], y_points: &[f64], at: Reached) -> Option<f64> {
    let count = s_points.len().min(y_points.len());
    (at.bracket + 1 < count && interpolable(s_points, y_points, at.bracket))
        .then(|| cubic(s_points, y_points, at.bracket, at.s))
}

/// Where `y` first reaches `target`: the first bracket `[s_i, s_{i+1}]` whose ends `y_i`,
/// `y_{i+1}` hold it, and there the root of the cubic `y(s) = target` by bisection.
pub fn first_reached(s_points: &[f64], y_points: &[f64], target: f64) -> Option<Reached> {
    let count = s_points.len().min(y_points.len());
    let bracket = bracket(y_points, count, target)?;
    let s = root_in(s_points, y_points, bracket, target)?;
    Some(Reached { s, bracket })
}

/// The root of the cubic `y(s) = target` in bracket `i`, by bisection.
fn root_in(s_points: &[f64], y_points: &[f64], i: usize, target: f64) -> Option<f64> {
    if !interpolable(s_points, y_points, i) {
        return None;
    }
    let f = |s: f64| cubic(s_points, y_points, i, s) - target;
    let (mut a, mut b) = (s_points[i], s_points[i + 1]);
    let mut fa = y_points[i] - target;
    if fa == 0.0 {
        return Some(a);
    }
    if y_points[i + 1] == target {
        return Some(b);
    }
    for _ in 0..100 {
        let m = 0.5 * (a + b);
        let fm = f(m);
        if fm == 0.0 || (b - a).abs() <= 1e-15 * m.abs().max(1.0) {
            return Some(m);
        }
        if fm.signum() == fa.signum() {
            (a, fa) = (m, fm);
        } else {
            b = m;
        }
    }
    Some(0.5 * (a + b))
}

#[cfg(test)]
mod tests {
    use super::{first_reached, value_at, value_in};

    /// A cubic is interpolated and inverted exactly, wherever the bracket is; a level the
    /// points never reach gives nothing; the first crossing counts.
    #[test]
    fn cubics_are_exact_and_the_first_crossing_counts() {
        let s = [0.0, 0.3, 0.7, 1.2, 2.0, 2.1];
        let cubic = |x: f64| 1.0 + 2.0 * x + 0.5 * x * x * x;
        let y: Vec<f64> = s.iter().map(|&x| cubic(x)).collect();
        for at in [0.0, 0.1, 0.5, 1.0, 1.9, 2.05, 2.1] {
            let v = value_at(&s, &y, at).unwrap();
            assert!((v - cubic(at)).abs() < 1e-13, "{at}: {v}");
            let back = first_reached(&s, &y, cubic(at)).unwrap();
            assert!((back.s - at).abs() < 1e-13, "{at}: {back:?}");
            assert!((value_in(&s, &y, back).unwrap() - cubic(at)).abs() < 1e-12);
        }
        assert!(value_at(&s, &y, 2.5).is_none());
        assert!(first_reached(&s, &y, cubic(2.5)).is_none());
        // y goes up and back: the first crossing of 0.5 is on the way up.
        let (s, y) = ([0.0, 1.0, 2.0], [0.0, 1.0, 0.0]);
        assert!(first_reached(&s, &y, 0.5).unwrap().s < 1.0);
    }
}
