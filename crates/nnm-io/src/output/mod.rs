//! Result files (docs/output.md): `modes.csv`, and per branch
//! `<name>.csv` (its columns declared in [`columns`]), `<name>.json` and `<name>.events.csv`
//! (folds, branch points, period doublings and Krein collisions).
//!
//! The branch files are written as each point converges or event is located, so an
//! interruption loses nothing:
//! the CSV gains a flushed row; the JSON stays a valid document throughout, holding every point
//! and event written so far — it ends `"points":[...],"events":[...]}`, each new event spliced
//! in before the closing `]}` and each new point before the `],"events":[...]}` tail — with
//! `"status": "running"` until the branch ends and the document is rewritten complete. Each
//! update of a file is one `write(2)` of one buffer, so a process killed between two updates
//! leaves a valid document.

use std::fs::File;
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use nnm::analysis::{ModalComponent, Regime};
use nnm::bifurcation::Event;
use nnm::modes::{LinearMode, StandingWave};
use nnm::shooting::Travel;
use nnm::symmetry::Parity;
use nnm::{Branch, BranchPoint, BranchStats};
use serde::Serialize;

use crate::error::io_reason;

pub mod columns;
pub mod response;

pub use response::{
    CurveRecord, RESPONSE_COLUMNS, RESPONSE_EVENTS_HEADER, RESPONSE_FILE_SUFFIXES, ResponseColumn,
    ResponseContext, ResponseFields, ResponseWriter, response_csv_columns, response_csv_header,
    response_csv_record, response_files, stop_name,
};

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

fn csv_error(path: &Path) -> impl Fn(csv::Error) -> OutputError + '_ {
    move |e| OutputError {
        path: path.to_owned(),
        reason: match e.into_kind() {
            csv::ErrorKind::Io(e) => io_reason(&e),
            other => format!("{other:?}"),
        },
    }
}

/// Writes a CSV table at once: `header`, then `rows` (each as many fields as the header; the
/// `csv` crate quotes a field where it must). The study's tables use it; branch files, which
/// grow point by point, have [`BranchWriter`].
pub fn write_table<R, F>(path: &Path, header: &[&str], rows: R) -> Result<(), OutputError>
where
    R: IntoIterator<Item = Vec<F>>,
    F: AsRef<[u8]>,
{
    let err = csv_error(path);
    let mut out = csv::Writer::from_path(path).map_err(&err)?;
    out.write_record(header).map_err(&err)?;
    for row in rows {
        out.write_record(&row).map_err(&err)?;
    }
    out.flush().map_err(output_error(path))
}

/// A float as the result files write it (shortest round-trip form, scientific for very small
/// or large magnitudes).
pub fn number(value: f64) -> String {
    Number(value).to_string()
}

/// Writes `modes.csv`: `index,frequency_rad_s,label,pattern,rigid,frequency_hz` (label `n,d`
/// for cyclic models, empty otherwise; pattern `cos`/`sin` for members of a degenerate pair).
/// Every column is described in docs/output.md.
pub fn write_modes_csv(path: &Path, modes: &[LinearMode]) -> Result<(), OutputError> {
    let header: Vec<&str> = MODES_CSV_HEADER.split(',').collect();
    let rows = modes.iter().enumerate().map(|(index, mode)| {
        vec![
            index.to_string(),
            number(mode.frequency),
            mode.label(),
            pattern_name(mode.cyclic.and_then(|c| c.pattern)).to_string(),
            mode.rigid.to_string(),
            number(mode.frequency / std::f64::consts::TAU),
        ]
    });
    write_table(path, &header, rows)
}

/// Columns of `modes.csv`, in order.
pub const MODES_CSV_HEADER: &str = "index,frequency_rad_s,label,pattern,rigid,frequency_hz";

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
    /// A travelling wave of the pair (`travelling`, `travelling-backward`) instead of a
    /// standing one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub travel: Option<Travel>,
    pub linear_frequency_rad_s: f64,
    /// Mirror-symmetry class the shooting unknowns were restricted to (`even`/`odd`), if any.
    pub symmetry: Option<Parity>,
    /// For a branch switched onto at an event of another: that branch and event.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub switched_from: Option<SwitchedFrom>,
    /// The dofs whose peak displacements the `peak_x<d>` columns hold.
    pub output_dofs: Vec<usize>,
}

impl BranchInfo {
    /// What the branch's point columns need besides its points.
    pub fn columns_context(&self) -> columns::BranchContext<'_> {
        columns::BranchContext {
            linear_frequency_rad_s: self.linear_frequency_rad_s,
            output_dofs: &self.output_dofs,
        }
    }
}

/// Where a switched branch came from.
#[derive(Debug, Clone, Serialize)]
pub struct SwitchedFrom {
    pub branch: String,
    /// Index of the event in the parent's `<name>.events.csv`.
    pub event: usize,
    /// Which new null direction was followed (0 unless the event is degenerate).
    pub direction: usize,
    /// The event's type (`branch-point`, `period-doubling`).
    #[serde(rename = "type")]
    pub kind: String,
    /// Phase condition the new branch was posed with.
    pub phase: String,
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
    /// Largest `|μ ν - 1|` over the pairs `(μ, ν)` of non-trivial multipliers: an accuracy
    /// estimate of the multipliers.
    reciprocity_defect: f64,
    /// Number of multiplier pairs off the unit circle.
    unstable_pairs: usize,
    /// `dE/ds` along the branch (changes sign at a fold).
    energy_slope: f64,
    /// `at_energy`, `at_frequency`, `energy_max` or `frequency_shift_max` for a point placed
    /// exactly on a value; absent for a continuation step.
    #[serde(skip_serializing_if = "Option::is_none")]
    label: Option<nnm::shooting::PointLabel>,
    /// Peak displacement over the period of each of the branch's `output_dofs`.
    peak_displacements: &'a [f64],
    /// Backbone, tongue or other family, with the partner mode (docs/output.md).
    regime: Option<&'a Regime>,
    /// The largest (mode, harmonic) components of the motion by share of its energy.
    modal_content: &'a [ModalComponent],
    /// The force of the motion's resonance peak (amplitude, phase, energy dissipated a
    /// period), when the branch's `resonance_force` asks for it.
    #[serde(skip_serializing_if = "Option::is_none")]
    resonance: Option<nnm::analysis::ResonanceForce>,
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
            unstable_pairs: p.floquet.unstable_pairs,
            energy_slope: p.energy_slope,
            label: p.label,
            peak_displacements: &p.peak_displacements,
            regime: p.regime.as_ref(),
            modal_content: &p.content,
            resonance: p.resonance,
        }
    }
}

/// One event as stored in `<name>.json`.
#[derive(Debug, Serialize)]
struct EventRecord<'a> {
    index: usize,
    #[serde(rename = "type")]
    kind: &'static str,
    energy: f64,
    frequency_rad_s: f64,
    period_s: f64,
    /// The critical multiplier `[re, im]`.
    multiplier: [f64; 2],
    multiplicity: usize,
    /// The event lies between this point and the next.
    after_point: usize,
    arclength_uncertainty: f64,
    converged: bool,
    /// Initial state `[x0; v0]` of the motion at the event.
    z0: &'a [f64],
}

impl<'a> EventRecord<'a> {
    fn new(index: usize, e: &'a Event) -> Self {
        Self {
            index,
            kind: e.kind.name(),
            energy: e.point.energy,
            frequency_rad_s: e.point.frequency,
            period_s: e.point.period,
            multiplier: [e.multiplier.0, e.multiplier.1],
            multiplicity: e.multiplicity,
            after_point: e.after,
            arclength_uncertainty: e.arclength_uncertainty,
            converged: e.converged,
            z0: &e.point.z0,
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
    /// Located events (while the branch runs, the writer keeps them after `points` instead,
    /// appended as they come: [`BranchWriter`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    events: Option<Vec<EventRecord<'a>>>,
    /// Requested values (`at_energies`, `at_frequencies`) without a point, and why.
    #[serde(skip_serializing_if = "Option::is_none")]
    missed_requests: Option<&'a [nnm::branch::MissedRequest]>,
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

/// Columns of `<name>.events.csv`, in order.
pub const EVENTS_CSV_HEADER: &str = "index,type,energy,frequency_rad_s,period_s,multiplier_re,multiplier_im,multiplier_modulus,multiplicity,after_point,arclength_uncertainty,converged";

/// A CSV file written a record at a time, each flushed to the OS before the call returns.
struct CsvFile {
    writer: csv::Writer<File>,
    path: PathBuf,
}

impl CsvFile {
    fn create(path: PathBuf, header: &[String]) -> Result<Self, OutputError> {
        let writer = csv::Writer::from_path(&path).map_err(csv_error(&path))?;
        let mut file = Self { writer, path };
        file.append(header)?;
        Ok(file)
    }

    fn append(&mut self, record: &[String]) -> Result<(), OutputError> {
        self.writer
            .write_record(record)
            .map_err(csv_error(&self.path))?;
        self.writer.flush().map_err(output_error(&self.path))
    }
}

/// What follows the last point in the JSON of a running branch: the end of the `points` array,
/// the `events` array holding `events` (records, comma-separated), the end of the document.
fn events_tail(events: &str) -> String {
    format!("],\"events\":[{events}]}}")
}

/// What a branch writes besides its name: `<name>.csv`, `<name>.json` (rewritten through
/// `<name>.json.tmp`), `<name>.events.csv`, and with `resonance_force` the figure of its
/// resonance peaks `<name>.resonance.png` / `.svg`. A job's branches are checked against these
/// before anything runs, so no two branches' files can be one file.
pub const BRANCH_FILE_SUFFIXES: [&str; 6] = [
    ".csv",
    ".json",
    ".json.tmp",
    ".events.csv",
    ".resonance.png",
    ".resonance.svg",
];

/// The files `nnm run` writes into its output folder beside the branches' (and its lock,
/// `.nnm.lock`): no branch may write one of them.
pub const RUN_FILES: [&str; 6] = [
    "modes.csv",
    "fep.png",
    "fep.svg",
    "amplitude.png",
    "amplitude.svg",
    ".nnm.lock",
];

/// The files of branch `name` ([`BRANCH_FILE_SUFFIXES`]).
pub fn branch_files(name: &str) -> impl Iterator<Item = String> + '_ {
    BRANCH_FILE_SUFFIXES
        .iter()
        .map(move |s| format!("{name}{s}"))
}

/// Streams one branch to `<dir>/<name>.csv` and `<dir>/<name>.json`.
///
/// While the branch runs the JSON ends `"points":[p0,...],"events":[e0,...]}`: an event is
/// appended over the closing `]}` (a write of the event alone), a point at the end of the
/// `points` array followed by the events' tail again (a write of the point and the events so
/// far: independent of the number of points, so a branch costs O(n) to write, not O(n²);
/// events are few). The events' records are kept in memory for that tail.
pub struct BranchWriter {
    info: BranchInfo,
    csv: CsvFile,
    json: File,
    json_path: PathBuf,
    /// Byte offset of the `]` that closes the JSON's `points` array.
    points_end: u64,
    /// The JSON's event records so far, comma-separated (what the tail's array holds).
    events_json: String,
    events_csv: CsvFile,
    points: usize,
    events: usize,
}

impl BranchWriter {
    pub fn create(dir: &Path, info: BranchInfo) -> Result<Self, OutputError> {
        let csv = CsvFile::create(
            dir.join(format!("{}.csv", info.name)),
            &columns::csv_header(&info.columns_context()),
        )?;
        let events_header: Vec<String> = EVENTS_CSV_HEADER.split(',').map(String::from).collect();
        let events_csv = CsvFile::create(
            dir.join(format!("{}.events.csv", info.name)),
            &events_header,
        )?;
        let json_path = dir.join(format!("{}.json", info.name));
        let mut json = File::create(&json_path).map_err(output_error(&json_path))?;
        let document = Document {
            info: &info,
            status: "running",
            stop_reason: None,
            stats: None,
            wall_time_s: None,
            events: None,
            missed_requests: None,
            points: vec![],
        };
        let text = serde_json::to_string(&document).expect("serialisable");
        // `...,"points":[]}` with the events' array after the points': `...,"points":[],"events":[]}`.
        let head = text
            .strip_suffix("]}")
            .expect("the document ends with its points");
        let points_end = head.len() as u64;
        let text = format!("{head}{}", events_tail(""));
        json.write_all(text.as_bytes())
            .map_err(output_error(&json_path))?;
        Ok(Self {
            info,
            csv,
            json,
            json_path,
            points_end,
            events_json: String::new(),
            events_csv,
            points: 0,
            events: 0,
        })
    }

    /// Appends one located event to `<name>.events.csv` (flushed before returning).
    pub fn write_event(&mut self, e: &Event) -> Result<(), OutputError> {
        let (re, im) = e.multiplier;
        let record = [
            self.events.to_string(),
            e.kind.name().to_string(),
            Number(e.point.energy).to_string(),
            Number(e.point.frequency).to_string(),
            Number(e.point.period).to_string(),
            Number(re).to_string(),
            Number(im).to_string(),
            Number(re.hypot(im)).to_string(),
            e.multiplicity.to_string(),
            e.after.to_string(),
            Number(e.arclength_uncertainty).to_string(),
            e.converged.to_string(),
        ];
        self.events_csv.append(&record)?;
        let record =
            serde_json::to_string(&EventRecord::new(self.events, e)).expect("serialisable");
        let separator = if self.events == 0 { "" } else { "," };
        let err = output_error(&self.json_path);
        // The document ends with `]}`: overwrite that with `[,]event]}`, in one write.
        self.json.seek(SeekFrom::End(-2)).map_err(&err)?;
        self.json
            .write_all(format!("{separator}{record}]}}").as_bytes())
            .map_err(&err)?;
        self.json.flush().map_err(&err)?;
        self.events_json.push_str(separator);
        self.events_json.push_str(&record);
        self.events += 1;
        Ok(())
    }

    /// Appends one converged point to both files (flushed to the OS before returning).
    pub fn write_point(&mut self, p: &BranchPoint) -> Result<(), OutputError> {
        let record = columns::csv_record(p, &self.info.columns_context());
        self.csv.append(&record)?;
        let record = serde_json::to_string(&PointRecord::from(p)).expect("serialisable");
        let err = output_error(&self.json_path);
        // The points' array closes at `points_end`, followed by the events' tail: overwrite
        // both with `[,]point` and the same tail, in one write (the file only grows).
        let separator = if self.points == 0 { "" } else { "," };
        let text = format!("{separator}{record}{}", events_tail(&self.events_json));
        self.json
            .seek(SeekFrom::Start(self.points_end))
            .map_err(&err)?;
        self.json.write_all(text.as_bytes()).map_err(&err)?;
        self.json.flush().map_err(&err)?;
        self.points_end += (separator.len() + record.len()) as u64;
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
            events: None,
            missed_requests: None,
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

    /// Rewrites the JSON complete, with the stop reason (`branch.stop` as text, or the
    /// caller's own words for a stop it asked for), work counters and wall time.
    pub fn finish(
        &mut self,
        branch: &Branch,
        stop_reason: &str,
        wall_time_s: f64,
    ) -> Result<(), OutputError> {
        let document = Document {
            info: &self.info,
            status: "finished",
            stop_reason: Some(stop_reason.to_string()),
            stats: Some(&branch.stats),
            wall_time_s: Some(wall_time_s),
            events: Some(
                branch
                    .events
                    .iter()
                    .enumerate()
                    .map(|(k, e)| EventRecord::new(k, e))
                    .collect(),
            ),
            missed_requests: (!branch.missed_requests.is_empty())
                .then_some(&branch.missed_requests[..]),
            points: branch.points.iter().map(PointRecord::from).collect(),
        };
        self.replace_json(&document)
    }
}

#[cfg(test)]
mod tests;
