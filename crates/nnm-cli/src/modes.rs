//! `nnm modes`: a model's linear modes, printed and optionally written to `modes.csv`.

use std::path::Path;

use anyhow::{Context, Result};
use nnm::modes::linear_modes;
use nnm_io::job::load_job;
use nnm_io::output::write_modes_csv;

use crate::out_dir::create_dir;

/// Prints the linear modes of the model in `file`, and writes `DIR/modes.csv` when `out` is given.
pub fn modes(file: &Path, out: Option<&Path>) -> Result<()> {
    let job = load_job(file)?;
    let modes = linear_modes(&job.structure).context("modal analysis failed")?;
    println!(
        "{:>5}  {:>16}  {:>6}  {:>7}",
        "index", "frequency_rad_s", "label", "pattern"
    );
    for (k, m) in modes.iter().enumerate() {
        let pattern = match m.cyclic.and_then(|c| c.pattern) {
            Some(p) => format!("{p:?}").to_lowercase(),
            None if m.rigid => "rigid".into(),
            None => String::new(),
        };
        println!(
            "{k:>5}  {:>16}  {:>6}  {:>7}",
            frequency_cell(m.frequency),
            m.label(),
            pattern
        );
    }
    if let Some(dir) = out {
        create_dir(dir)?;
        let path = dir.join("modes.csv");
        write_modes_csv(&path, &modes)?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

/// A frequency for the table: nine decimals from 1e-3 up to 1e7 rad/s (and a rigid mode's 0),
/// where they are seven to sixteen significant digits; ten significant digits in scientific
/// notation outside, where nine decimals would print dozens of digits double precision does not
/// hold (`K` of order 1e154 gives ω of order 1e77) or none at all (ω of order 1e-12).
fn frequency_cell(omega: f64) -> String {
    if omega == 0.0 || !omega.is_finite() || (1e-3..1e7).contains(&omega.abs()) {
        format!("{omega:.9}")
    } else {
        format!("{omega:.9e}")
    }
}

#[cfg(test)]
mod tests {
    use super::frequency_cell;

    #[test]
    fn frequencies_are_short_and_keep_ten_digits() {
        for (omega, shown) in [
            (0.0, "0.000000000"),
            (1.0, "1.000000000"),
            (148.67, "148.670000000"),
            (1e-3, "0.001000000"),
            (1414213.562373095, "1414213.562373095"),
            (1e7, "1.000000000e7"),
            (1.2345678901234e77, "1.234567890e77"),
            (2.5e-12, "2.500000000e-12"),
        ] {
            assert_eq!(frequency_cell(omega), shown);
        }
    }
}
