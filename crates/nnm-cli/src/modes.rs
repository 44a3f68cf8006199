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
            "{k:>5}  {:>16.9}  {:>6}  {:>7}",
            m.frequency,
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
