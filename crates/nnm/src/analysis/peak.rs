//! The peak displacement of a dof over a period, from samples refined to the integrator's
//! accuracy (docs/method.md §18, eq. (87)).
//!
//! Between samples the peak is found where the velocity vanishes: first on the cubic Hermite
//! interpolant of the neighbouring samples (displacement and velocity at both ends), then —
//! after integrating the motion to that instant — by the extremum of the local Taylor
//! quadratic `x + v δ + ½ a δ²`, which leaves an error of third order in the Hermite
//! estimate's (already small) time error.

/// Where `|x|` may peak over a period sampled at `x[j], v[j]` (`t_j = j h`, cyclic: sample
/// `N` is sample 0): for each local maximum of `|x_j|` within 10% of the largest, the sample
/// the peak follows and the time after it where the Hermite interpolant's velocity vanishes.
pub fn peak_candidates(x: &[f64], v: &[f64], h: f64) -> Vec<(usize, f64)> {
    let count = x.len();
    let largest = x.iter().fold(0.0f64, |m, a| m.max(a.abs()));
    if count == 0 || largest == 0.0 {
        return Vec::new();
    }
    let (next, previous) = (
        |j: usize| (j + 1) % count,
        |j: usize| (j + count - 1) % count,
    );
    (0..count)
        .filter(|&j| {
            let a = x[j].abs();
            a >= 0.9 * largest && a >= x[previous(j)].abs() && a >= x[next(j)].abs()
        })
        .map(|j| {
            // |x| still grows after t_j if x and v share a sign: the peak is on [t_j, t_j+1].
            let sign = x[j].signum() * v[j].signum();
            let start = if sign > 0.0 { j } else { previous(j) };
            if v[j] == 0.0 {
                return (j, 0.0);
            }
            let end = next(start);
            let tau = hermite_stationary(x[start], v[start], x[end], v[end], h)
                .unwrap_or(if start == j { 0.0 } else { h });
            (start, tau)
        })
        .collect()
}

/// The time in `[0, h]` where the cubic Hermite interpolant of `(x0, v0)` at 0 and `(x1, v1)`
/// at `h` is stationary, the one of largest `|x|` if there are two; `None` if none is.
fn hermite_stationary(x0: f64, v0: f64, x1: f64, v1: f64, h: f64) -> Option<f64> {
    let slope = (x1 - x0) / h;
    let c2 = (3.0 * slope - 2.0 * v0 - v1) / h;
    let c3 = (v0 + v1 - 2.0 * slope) / (h * h);
    let value = |s: f64| x0 + s * (v0 + s * (c2 + s * c3));
    // p'(s) = v0 + 2 c2 s + 3 c3 s² = 0.
    let (a, b, c) = (3.0 * c3, 2.0 * c2, v0);
    let roots: Vec<f64> = if a.abs() <= 1e-12 * (b.abs() + c.abs() / h) / h {
        if b == 0.0 { vec![] } else { vec![-c / b] }
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            vec![]
        } else {
            // Stable quadratic roots.
            let q = -0.5 * (b + b.signum() * disc.sqrt());
            let mut r = vec![];
            if q != 0.0 {
                r.push(c / q);
            }
            r.push(q / a);
            r
        }
    };
    roots
        .into_iter()
        .filter(|s| (0.0..=h).contains(s))
        .max_by(|p, q| value(*p).abs().total_cmp(&value(*q).abs()))
}

/// `|x|` at its peak near a state with displacement `x`, velocity `v` and acceleration `a`:
/// the extremum `x − v²/(2a)` of the local quadratic when `a` turns `x` back (a maximum of
/// `|x|`), else `|x|` itself.
pub fn local_peak(x: f64, v: f64, a: f64) -> f64 {
    if a != 0.0 && a.signum() != x.signum() {
        (x - v * v / (2.0 * a)).abs()
    } else {
        x.abs()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn peaks_of_a_sampled_harmonic_motion_are_refined_to_round_off() {
        // x = 0.7 cos(t − 0.3) + 0.1 cos(3t): sampled coarsely, its peak refined by the
        // Hermite estimate then the local quadratic at the exact state there.
        let x = |t: f64| 0.7 * (t - 0.3).cos() + 0.1 * (3.0 * t).cos();
        let v = |t: f64| -0.7 * (t - 0.3).sin() - 0.3 * (3.0 * t).sin();
        let a = |t: f64| -0.7 * (t - 0.3).cos() - 0.9 * (3.0 * t).cos();
        let count = 32;
        let h = 2.0 * PI / count as f64;
        let xs: Vec<f64> = (0..count).map(|j| x(j as f64 * h)).collect();
        let vs: Vec<f64> = (0..count).map(|j| v(j as f64 * h)).collect();
        let fine = (0..200_000)
            .map(|j| x(2.0 * PI * j as f64 / 200_000.0).abs())
            .fold(0.0f64, f64::max);
        let refined = peak_candidates(&xs, &vs, h)
            .into_iter()
            .map(|(j, tau)| {
                let t = j as f64 * h + tau;
                local_peak(x(t), v(t), a(t))
            })
            .fold(0.0f64, f64::max);
        let sampled = xs.iter().fold(0.0f64, |m, s| m.max(s.abs()));
        assert!(
            (sampled - fine).abs() > 1e-4,
            "the samples alone miss the peak"
        );
        // The fine grid itself is only good to ~(2π/2e5)² ≈ 1e-9.
        assert!((refined - fine).abs() < 2e-9, "{refined} vs {fine}");
        assert!(refined >= fine);
    }

    #[test]
    fn a_dof_at_rest_has_no_peak() {
        assert!(peak_candidates(&[0.0; 8], &[0.0; 8], 0.1).is_empty());
        assert_eq!(local_peak(-2.0, 0.0, 3.0), 2.0);
    }
}
