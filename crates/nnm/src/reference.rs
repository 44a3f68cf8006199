//! Exact reference solutions, for validation and for users checking their own setups.

use std::f64::consts::PI;

/// Complete elliptic integral of the first kind `K(m) = ∫₀^{π/2} dθ / √(1 - m sin²θ)`
/// (parameter `m = k²`, `m < 1`), by the arithmetic–geometric mean: `K = π / (2 AGM(1, √(1-m)))`.
/// Quadratically convergent; exact to round-off.
pub fn elliptic_k(m: f64) -> f64 {
    assert!(m < 1.0, "elliptic_k needs m < 1");
    let (mut a, mut b) = (1.0f64, (1.0 - m).sqrt());
    for _ in 0..64 {
        if (a - b).abs() <= 1e-16 * a {
            break;
        }
        let next = (0.5 * (a + b), (a * b).sqrt());
        a = next.0;
        b = next.1;
    }
    PI / (a + b)
}

/// Exact period of the Duffing oscillator `x'' + ω₀² x + α x³ = 0` released from rest at
/// amplitude `A`: with `ω² = ω₀² + α A²` and `m = α A² / (2 ω²)`, `x = A cn(ω t | m)` and
/// `T = 4 K(m) / ω` (valid for hardening `α ≥ 0`, and softening while `m > -∞`, i.e. `ω² > 0`).
pub fn duffing_period(natural_frequency: f64, cubic: f64, amplitude: f64) -> f64 {
    let w2 = natural_frequency.powi(2) + cubic * amplitude.powi(2);
    let m = cubic * amplitude.powi(2) / (2.0 * w2);
    4.0 * elliptic_k(m) / w2.sqrt()
}

/// Amplitude of the Duffing oscillator with energy `E = ½ ω₀² A² + ¼ α A⁴` (hardening `α > 0`
/// or linear `α = 0`).
pub fn duffing_amplitude(natural_frequency: f64, cubic: f64, energy: f64) -> f64 {
    let w2 = natural_frequency.powi(2);
    if cubic == 0.0 {
        return (2.0 * energy / w2).sqrt();
    }
    // α/4 s² + ω₀²/2 s - E = 0 in s = A², the positive root written without cancellation.
    let s = 2.0 * energy / (0.5 * w2 + (0.25 * w2 * w2 + cubic * energy).sqrt());
    s.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn elliptic_k_known_values() {
        assert!((elliptic_k(0.0) - PI / 2.0).abs() < 1e-15);
        // K(1/2) = Γ(1/4)² / (4 √π)
        let gamma_quarter = 3.625_609_908_221_908_3_f64;
        let exact = gamma_quarter.powi(2) / (4.0 * PI.sqrt());
        assert!((elliptic_k(0.5) - exact).abs() < 1e-14);
    }

    #[test]
    fn duffing_period_limits() {
        // Linear limit, and the energy/amplitude relation inverts.
        assert!((duffing_period(2.0, 0.0, 1.0) - PI).abs() < 1e-14);
        let a = duffing_amplitude(1.3, 0.7, 2.5);
        assert!((0.5 * 1.69 * a * a + 0.25 * 0.7 * a.powi(4) - 2.5).abs() < 1e-14);
        // Small-amplitude Lindstedt–Poincaré: ω ≈ ω₀ + 3αA²/(8ω₀).
        let (w0, alpha, amp) = (1.0, 1.0, 1e-3);
        let w = 2.0 * PI / duffing_period(w0, alpha, amp);
        assert!((w - (w0 + 3.0 * alpha * amp * amp / (8.0 * w0))).abs() < 1e-11);
    }
}
