//! Numbers in messages: a refused value is shown as it was written, short. `{}` of an `f64`
//! never switches to an exponent (`1e300` prints as 301 digits, `1e-300` as 300 zeros and a
//! one), so every message that shows a value a user gave goes through [`Number`] instead.

use std::fmt;

/// An `f64` for a message: Rust's shortest round-trip digits (the value read back is the value
/// shown), as a plain decimal from 1e-4 to 1e16 (`-1`, `0.25`, `NaN`, `inf`: what `{}` prints)
/// and in scientific notation outside (`1e300`, `-2.5e-310`), so at most 24 characters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Number(pub f64);

impl fmt::Display for Number {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if v.is_finite() && v != 0.0 && !(1e-4..1e16).contains(&v.abs()) {
            write!(f, "{v:e}")
        } else {
            write!(f, "{v}")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Number;

    #[test]
    fn numbers_are_short_and_exact() {
        for (v, shown) in [
            (1e300, "1e300"),
            (-1e300, "-1e300"),
            (1e-300, "1e-300"),
            (-2.5e-310, "-2.5e-310"),
            (f64::MAX, "1.7976931348623157e308"),
            (f64::MIN_POSITIVE, "2.2250738585072014e-308"),
            (1e16, "1e16"),
            (9.5e15, "9500000000000000"),
            (1e-4, "0.0001"),
            (9e-5, "9e-5"),
            (-1.0, "-1"),
            (0.0, "0"),
            (-0.1, "-0.1"),
            (5.0, "5"),
            (0.1 + 0.2, "0.30000000000000004"),
            (f64::NAN, "NaN"),
            (f64::INFINITY, "inf"),
            (f64::NEG_INFINITY, "-inf"),
        ] {
            assert_eq!(Number(v).to_string(), shown);
        }
        // Every value reads back as itself, in at most 24 characters.
        let mut x = 1.234_567_890_123_456_7e-320_f64;
        while x.is_finite() {
            let s = Number(-x).to_string();
            assert!(s.len() <= 24, "{s}");
            assert_eq!(s.parse::<f64>().unwrap(), -x, "{s}");
            x *= 7.3;
        }
    }
}
