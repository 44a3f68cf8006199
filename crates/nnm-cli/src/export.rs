//! `nnm export`: a job's model written as the files a finite-element code exports, with a job
//! file that reads them (nnm-io's `export`).

use std::path::Path;

use anyhow::Result;
use nnm_io::export::export_job;

/// Writes the model of `job` into `out` as `M.mtx`, `K.mtx`, `f2.txt`/`f3.txt` and
/// `<stem>.toml`; prints each file written (stderr) and how to run the exported job.
pub fn export(job: &Path, out: &Path) -> Result<()> {
    let exported = export_job(job)?;
    let paths = exported.write(out)?;
    for path in &paths {
        eprintln!("wrote {}", path.display());
    }
    if let Some(job_file) = paths.last() {
        println!("nnm run {} --out DIR", job_file.display());
    }
    Ok(())
}
