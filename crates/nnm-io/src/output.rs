//! Result files (SPEC §5): `modes.csv`, and per branch `<name>.csv` and `<name>.json`.
//!
//! Both branch files are written as each point converges, so an interruption loses nothing:
//! the CSV gains a flushed row; the JSON stays a valid document throughout — its `points`
//! array is last, and each new point is spliced in before the closing `]}` — with
//! `"status": "running"` until the branch ends and the document is rewritten complete.

use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use nnm::continuation::{Branch, BranchPoint, BranchStats};
use nnm::modes::{LinearMode, StandingWave};
use nnm::symmetry::Parity;
use serde::Serialize;

use crate::job::io_reason;

/// Why a result file could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {path}: {reason}")]
pub struct OutputError {
    pub path: PathBuf,
    pub reason: String,
}

fn output_error(path: &Path) -> impl Fn(std::io::Error) -> OutputError + '_ {
    move |e| OutputError {
        path: path.to_owned(),
        reason: io_reason(&e),
    }
}

/// Writes `modes.csv`: `index,frequency_rad_s,label,pattern,rigid` (label `"n,d"` for cyclic
/// models, empty otherwise; pattern `cos`/`sin` for members of a degenerate pair).
pub fn write_modes_csv(path: &Path, modes: &[LinearMode]) -> Result<(), OutputError> {
    let err = output_error(path);
    let mut out = BufWriter::new(File::create(path).map_err(&err)?);
    writeln!(out, "index,frequency_rad_s,label,pattern,rigid").map_err(&err)?;
    for (index, mode) in modes.iter().enumerate() {
        let label = mode.label();
        let label = if label.is_empty() {
            String::new()
        } else {
            format!("\"{label}\"")
        };
        writeln!(
            out,
            "{index},{},{label},{},{}",
            Number(mode.frequency),
            pattern_name(mode.cyclic.and_then(|c| c.pattern)),
            mode.rigid
        )
        .map_err(&err)?;
    }
    out.flush().map_err(&err)
}

fn pattern_name(pattern: Option<StandingWave>) -> &'static str {
    match pattern {
        Some(StandingWave::Cos) => "cos",
        Some(StandingWave::Sin) => "sin",
        None => "",
    }
}

/// Which mode a branch starts from.
#[derive(Debug, Clone, Serialize)]
pub struct BranchInfo {
    pub name: String,
    pub mode_index: usize,
    pub mode_label: String,
    pub pattern: Option<StandingWave>,
    pub linear_frequency_rad_s: f64,
    /// Mirror-symmetry class the shooting unknowns were restricted to (`even`/`odd`), if any.
    pub symmetry: Option<Parity>,
}

/// One point as stored in `<name>.json`.
#[derive(Debug, Serialize)]
struct PointRecord<'a> {
    index: usize,
    energy: f64,
    frequency_rad_s: f64,
    period_s: f64,
    stable: bool,
    max_floquet_modulus: f64,
    relative_residual: f64,
    full_period_residual: f64,
    iterations: usize,
    step: f64,
    /// Initial state `[x0; v0]`.
    z0: &'a [f64],
    /// Floquet multipliers `[re, im]`, by decreasing modulus.
    multipliers: Vec<[f64; 2]>,
    /// Indices into `multipliers` of the two trivial ones (at +1).
    trivial_multipliers: [usize; 2],
    /// Largest deviation of the non-trivial pairs from `ρ_k ρ_{N-1-k} = 1`: an accuracy
    /// estimate of the multipliers.
    reciprocity_defect: f64,
}

impl<'a> From<&'a BranchPoint> for PointRecord<'a> {
    fn from(p: &'a BranchPoint) -> Self {
        Self {
            index: p.index,
            energy: p.energy,
            frequency_rad_s: p.frequency,
            period_s: p.period,
            stable: p.floquet.stable,
            max_floquet_modulus: p.floquet.max_modulus,
            relative_residual: p.relative_residual,
            full_period_residual: p.full_period_residual,
            iterations: p.iterations,
            step: p.step,
            z0: &p.z0,
            multipliers: p
                .floquet
                .multipliers
                .iter()
                .map(|&(re, im)| [re, im])
                .collect(),
            trivial_multipliers: p.floquet.trivial,
            reciprocity_defect: p.floquet.reciprocity_defect,
        }
    }
}

#[derive(Serialize)]
struct Document<'a> {
    #[serde(flatten)]
    info: &'a BranchInfo,
    status: &'a str,
    #[serde(skip_serializing_if = "Option::is_none")]
    stop_reason: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    stats: Option<&'a BranchStats>,
    #[serde(skip_serializing_if = "Option::is_none")]
    wall_time_s: Option<f64>,
    points: Vec<PointRecord<'a>>,
}

/// A float written in the shortest form that round-trips: plain for moderate magnitudes,
/// scientific otherwise (Rust's `{}` never switches to an exponent, so 1e-300 would print 300
/// digits).
struct Number(f64);

impl std::fmt::Display for Number {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || (1e-4..1e15).contains(&a) || !a.is_finite() {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

/// Columns of `<name>.csv`, in order.
pub const BRANCH_CSV_HEADER: &str = "index,energy,frequency_rad_s,period_s,stable,max_floquet_modulus,relative_residual,iterations,step,full_period_residual";

/// Streams one branch to `<dir>/<name>.csv` and `<dir>/<name>.json`.
pub struct BranchWriter {
    info: BranchInfo,
    csv: File,
    csv_path: PathBuf,
    json: File,
    json_path: PathBuf,
    points: usize,
}

impl BranchWriter {
    pub fn create(dir: &Path, info: BranchInfo) -> Result<Self, OutputError> {
        let csv_path = dir.join(format!("{}.csv", info.name));
        let json_path = dir.join(format!("{}.json", info.name));
        let mut csv = File::create(&csv_path).map_err(output_error(&csv_path))?;
        writeln!(csv, "{BRANCH_CSV_HEADER}").map_err(output_error(&csv_path))?;
        let mut json = File::create(&json_path).map_err(output_error(&json_path))?;
        let document = Document {
            info: &info,
            status: "running",
            stop_reason: None,
            stats: None,
            wall_time_s: None,
            points: vec![],
        };
        let text = serde_json::to_string(&document).expect("serialisable");
        json.write_all(text.as_bytes())
            .map_err(output_error(&json_path))?;
        Ok(Self {
            info,
            csv,
            csv_path,
            json,
            json_path,
            points: 0,
        })
    }

    /// Appends one converged point to both files (flushed to the OS before returning).
    pub fn write_point(&mut self, p: &BranchPoint) -> Result<(), OutputError> {
        writeln!(
            self.csv,
            "{},{},{},{},{},{},{},{},{},{}",
            p.index,
            Number(p.energy),
            Number(p.frequency),
            Number(p.period),
            p.floquet.stable,
            Number(p.floquet.max_modulus),
            Number(p.relative_residual),
            p.iterations,
            Number(p.step),
            Number(p.full_period_residual)
        )
        .map_err(output_error(&self.csv_path))?;
        let record = serde_json::to_string(&PointRecord::from(p)).expect("serialisable");
        let err = output_error(&self.json_path);
        // The document ends with `]}`: overwrite that with `[,]point]}`.
        self.json.seek(SeekFrom::End(-2)).map_err(&err)?;
        let separator = if self.points == 0 { "" } else { "," };
        write!(self.json, "{separator}{record}]}}").map_err(&err)?;
        self.json.flush().map_err(&err)?;
        self.points += 1;
        Ok(())
    }

    /// Marks the branch as failed before its first point (the JSON keeps the reason).
    pub fn fail(&mut self, reason: &str) -> Result<(), OutputError> {
        let document = Document {
            info: &self.info,
            status: "failed",
            stop_reason: Some(reason.to_string()),
            stats: None,
            wall_time_s: None,
            points: vec![],
        };
        self.replace_json(&document)
    }

    fn replace_json(&self, document: &Document<'_>) -> Result<(), OutputError> {
        let text = serde_json::to_string_pretty(document).expect("serialisable");
        let tmp = self.json_path.with_extension("json.tmp");
        std::fs::write(&tmp, text).map_err(output_error(&tmp))?;
        std::fs::rename(&tmp, &self.json_path).map_err(output_error(&self.json_path))
    }

    /// Rewrites the JSON complete, with the stop reason, work counters and wall time.
    pub fn finish(&mut self, branch: &Branch, wall_time_s: f64) -> Result<(), OutputError> {
        let document = Document {
            info: &self.info,
            status: "finished",
            stop_reason: Some(branch.stop.to_string()),
            stats: Some(&branch.stats),
            wall_time_s: Some(wall_time_s),
            points: branch.points.iter().map(PointRecord::from).collect(),
        };
        self.replace_json(&document)
    }
}
