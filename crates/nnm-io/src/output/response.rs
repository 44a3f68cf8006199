//! The files of a forced response (docs/output.md): `<name>.csv` (its columns declared once in
//! [`RESPONSE_COLUMNS`]), `<name>.events.csv` ([`RESPONSE_EVENTS_HEADER`]) and `<name>.json`,
//! each holding every curve of the response (one per force level; the `curve` field tells
//! them apart), written point by point as [`super::BranchWriter`] writes a branch: an
//! interrupted run leaves every computed point on disk, the JSON a valid document with
//! `"status": "running"` throughout.

use std::fs::{File, OpenOptions};
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use nnm::forced::{ForcedStats, ResponseCurve, ResponseEvent, ResponsePoint};
use serde::Serialize;

use super::columns::{Column, ColumnFields, Kind, Value};
use super::{CsvFile, Number, OutputError, output_error};

/// What the columns of a response need besides its points.
#[derive(Debug, Clone, Copy)]
pub struct ResponseContext<'a> {
    /// The curve's index in the response (0 first; one curve per force level).
    pub curve: usize,
    /// The dofs of the `peak_x<d>` columns.
    pub output_dofs: &'a [usize],
}

/// How many fields a response column has, and how each is computed.
#[derive(Clone, Copy)]
pub enum ResponseFields {
    /// One field.
    One(fn(&ResponsePoint, &ResponseContext<'_>) -> Value),
    /// One per output dof (`<d>` in the name replaced by the dof), given its position.
    PerOutputDof(fn(&ResponsePoint, usize) -> Value),
}

impl ColumnFields for ResponseFields {
    fn per_output_dof(&self) -> bool {
        matches!(self, ResponseFields::PerOutputDof(_))
    }
}

/// One column of a response's points.
pub type ResponseColumn = Column<ResponseFields>;

impl ResponseColumn {
    /// The column's header fields.
    pub fn headers(&self, context: &ResponseContext<'_>) -> Vec<String> {
        self.header_names(context.output_dofs)
    }

    /// The column's fields at point `p`.
    pub fn values(&self, p: &ResponsePoint, context: &ResponseContext<'_>) -> Vec<Value> {
        match self.fields {
            ResponseFields::One(value) => vec![value(p, context)],
            ResponseFields::PerOutputDof(value) => (0..context.output_dofs.len())
                .map(|k| value(p, k))
                .collect(),
        }
    }
}

/// The columns of a response's points; `<name>.csv` has those marked [`ResponseColumn::csv`],
/// in this order.
pub const RESPONSE_COLUMNS: &[ResponseColumn] = &[
    ResponseColumn {
        name: "curve",
        unit: "—",
        doc: "the curve (0 first): one per force level of `amplitudes`, in their order",
        key: "curve",
        kind: Kind::Integer,
        csv: true,
        fields: ResponseFields::One(|_, c| Value::Integer(c.curve)),
    },
    ResponseColumn {
        name: "index",
        unit: "—",
        doc: "position on the curve (0 first: the linear response at its start)",
        key: "index",
        kind: Kind::Integer,
        csv: true,
        fields: ResponseFields::One(|p, _| Value::Integer(p.index)),
    },
    ResponseColumn {
        name: "frequency_rad_s",
        unit: "rad/s",
        doc: "the forcing frequency Ω",
        key: "frequency",
        kind: Kind::Float,
        csv: true,
        fields: ResponseFields::One(|p, _| Value::Float(p.frequency)),
    },
    ResponseColumn {
        name: "frequency_hz",
        unit: "Hz",
        doc: "Ω / 2π",
        key: "frequency_hz",
        kind: Kind::Float,
        csv: true,
        fields: ResponseFields::One(|p, _| Value::Float(p.frequency / std::f64::consts::TAU)),
    },
    ResponseColumn {
        name: "force_amplitude",
        unit: "force",
        doc: "the factor `a` on the force shape (the level of the curve, or the continued amplitude)",
        key: "force_amplitude",
        kind: Kind::Float,
        csv: true,
        fields: ResponseFields::One(|p, _| Value::Float(p.force_amplitude)),
    },
    ResponseColumn {
        name: "peak_x<d>",
        unit: "length",
        doc: "`max_t |x_d(t)|` over the forcing period, one column per output dof",
        key: "peaks",
        kind: Kind::Float,
        csv: true,
        fields: ResponseFields::PerOutputDof(|p, k| {
            p.peaks.get(k).map_or(Value::Empty, |&x| Value::Float(x))
        }),
    },
    ResponseColumn {
        name: "harmonic_amplitude",
        unit: "length",
        doc: "amplitude `A` of the first harmonic `A cos(Ωt − φ)` of the first forced dof",
        key: "harmonic_amplitude",
        kind: Kind::Float,
        csv: true,
        fields: ResponseFields::One(|p, _| Value::Float(p.harmonic_amplitude)),
    },
    ResponseColumn {
        name: "phase_lag_rad",
        unit: "rad",
        doc: "its phase lag `φ` behind `cos Ωt`, in (−π/2, 3π/2]",
        key: "phase_lag",
        kind: Kind::Float,
        csv: true,
        fields: ResponseFields::One(|p, _| Value::Float(p.phase_lag)),
    },
    ResponseColumn {
        name: "stable",
        unit: "—",
        doc: "every Floquet multiplier inside the unit circle",
        key: "stable",
        kind: Kind::Bool,
        csv: true,
        fields: ResponseFields::One(|p, _| Value::Bool(p.stable)),
    },
    ResponseColumn {
        name: "max_floquet_modulus",
        unit: "—",
        doc: "the largest `|μ|` (above 1: unstable)",
        key: "max_floquet_modulus",
        kind: Kind::Float,
        csv: true,
        fields: ResponseFields::One(|p, _| Value::Float(p.max_floquet_modulus)),
    },
    ResponseColumn {
        name: "relative_residual",
        unit: "—",
        doc: "the converged `‖z(2π/Ω) − z0‖ / ‖z0‖` in the scaled unknowns",
        key: "relative_residual",
        kind: Kind::Float,
        csv: true,
        fields: ResponseFields::One(|p, _| Value::Float(p.relative_residual)),
    },
    ResponseColumn {
        name: "iterations",
        unit: "—",
        doc: "Newton iterations of the point's corrector",
        key: "iterations",
        kind: Kind::Integer,
        csv: true,
        fields: ResponseFields::One(|p, _| Value::Integer(p.iterations)),
    },
    ResponseColumn {
        name: "integration_steps",
        unit: "—",
        doc: "time steps of one forcing period",
        key: "integration_steps",
        kind: Kind::Integer,
        csv: true,
        fields: ResponseFields::One(|p, _| Value::Integer(p.integration_steps)),
    },
    ResponseColumn {
        name: "step",
        unit: "—",
        doc: "the arclength step that led to the point, in the scaled unknowns",
        key: "step",
        kind: Kind::Float,
        csv: false,
        fields: ResponseFields::One(|p, _| Value::Float(p.step)),
    },
];

/// The columns `<name>.csv` has, in order.
pub fn response_csv_columns() -> impl Iterator<Item = &'static ResponseColumn> {
    RESPONSE_COLUMNS.iter().filter(|c| c.csv)
}

/// The header of a response's `<name>.csv`.
pub fn response_csv_header(context: &ResponseContext<'_>) -> Vec<String> {
    response_csv_columns()
        .flat_map(|c| c.headers(context))
        .collect()
}

/// One row of a response's `<name>.csv`.
pub fn response_csv_record(p: &ResponsePoint, context: &ResponseContext<'_>) -> Vec<String> {
    response_csv_columns()
        .flat_map(|c| c.values(p, context))
        .map(|v| v.csv_field())
        .collect()
}

/// Columns of a response's `<name>.events.csv`; `peak_x<d>` is the peak of the first output
/// dof.
pub const RESPONSE_EVENTS_HEADER: &str = "curve,type,frequency_rad_s,force_amplitude,peak_x<d>,critical_multiplier_re,critical_multiplier_im,critical_multiplier_modulus,backbone_peak";

/// What a response writes besides its name; a job's names are checked against these (and the
/// branches' files) before anything runs.
pub const RESPONSE_FILE_SUFFIXES: [&str; 6] =
    [".csv", ".json", ".json.tmp", ".events.csv", ".png", ".svg"];

/// The files of response `name` ([`RESPONSE_FILE_SUFFIXES`]).
pub fn response_files(name: &str) -> impl Iterator<Item = String> + '_ {
    RESPONSE_FILE_SUFFIXES
        .iter()
        .map(move |s| format!("{name}{s}"))
}

/// One point in `<name>.json`.
#[derive(Serialize)]
struct PointRecord<'a> {
    curve: usize,
    index: usize,
    frequency_rad_s: f64,
    force_amplitude: f64,
    /// `z(0) = [x; v]`, the force's phase 0 at `t = 0`.
    z0: &'a [f64],
    /// `max_t |x_d(t)|` of each output dof.
    peaks: &'a [f64],
    harmonic_amplitude: f64,
    phase_lag_rad: f64,
    stable: bool,
    max_floquet_modulus: f64,
    /// `[re, im]`, by decreasing modulus.
    multipliers: Vec<[f64; 2]>,
    relative_residual: f64,
    iterations: usize,
    step: f64,
    integration_steps: usize,
}

impl<'a> PointRecord<'a> {
    fn new(curve: usize, p: &'a ResponsePoint) -> Self {
        Self {
            curve,
            index: p.index,
            frequency_rad_s: p.frequency,
            force_amplitude: p.force_amplitude,
            z0: &p.z0,
            peaks: &p.peaks,
            harmonic_amplitude: p.harmonic_amplitude,
            phase_lag_rad: p.phase_lag,
            stable: p.stable,
            max_floquet_modulus: p.max_floquet_modulus,
            multipliers: p.multipliers.iter().map(|&(re, im)| [re, im]).collect(),
            relative_residual: p.relative_residual,
            iterations: p.iterations,
            step: p.step,
            integration_steps: p.integration_steps,
        }
    }
}

/// One event in `<name>.json`.
#[derive(Serialize)]
struct EventRecord<'a> {
    curve: usize,
    #[serde(rename = "type")]
    kind: &'static str,
    /// The event lies after this point of its curve.
    after_point: usize,
    critical_multiplier: [f64; 2],
    /// The peak on a backbone of the job at the event's frequency (phase resonances).
    #[serde(skip_serializing_if = "Option::is_none")]
    backbone_peak: Option<f64>,
    point: PointRecord<'a>,
}

/// A finished (or failed) curve in `<name>.json`.
#[derive(Debug, Clone, Serialize)]
pub struct CurveRecord {
    pub curve: usize,
    /// `frequency` or `amplitude`: what the curve is continued in.
    pub parameter: &'static str,
    /// The sweep's range of the parameter.
    pub from: f64,
    pub to: f64,
    /// The force amplitude (frequency sweeps) or the frequency (amplitude sweeps) held fixed.
    pub fixed: f64,
    pub points: usize,
    pub events: usize,
    /// How the curve ended, in words ([`stop_name`]): the end or start of the sweep,
    /// `max_points`, interrupted, closed on itself, or why it failed.
    pub stop_reason: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub integrator: Option<&'static str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stats: Option<ForcedStats>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wall_time_s: Option<f64>,
}

impl CurveRecord {
    /// The record of a curve that ended (`stop_reason` from its stop).
    pub fn finished(curve: usize, sweep: &nnm::forced::Sweep, c: &ResponseCurve, s: f64) -> Self {
        let mut record = Self::failed(curve, sweep, "");
        record.points = c.points.len();
        record.events = c.events.len();
        record.stop_reason = stop_name(&c.stop);
        record.integrator = Some(c.integrator);
        record.stats = Some(c.stats);
        record.wall_time_s = Some(s);
        record
    }

    /// The record of a curve that could not start.
    pub fn failed(curve: usize, sweep: &nnm::forced::Sweep, reason: &str) -> Self {
        let (parameter, fixed) = match *sweep {
            nnm::forced::Sweep::Frequency { amplitude, .. } => ("frequency", amplitude),
            nnm::forced::Sweep::Amplitude { frequency, .. } => ("amplitude", frequency),
        };
        let (from, to) = sweep.range();
        Self {
            curve,
            parameter,
            from,
            to,
            fixed,
            points: 0,
            events: 0,
            stop_reason: reason.to_string(),
            integrator: None,
            stats: None,
            wall_time_s: None,
        }
    }
}

/// How a curve ended, in words (the JSON's `stop_reason`, the summary).
pub fn stop_name(stop: &nnm::forced::ResponseStop) -> String {
    use nnm::forced::ResponseStop;
    match stop {
        ResponseStop::End => "reached the end of the sweep".into(),
        ResponseStop::Start => "turned back out of the start of the sweep".into(),
        ResponseStop::MaxPoints => "reached max_points".into(),
        ResponseStop::Stopped => "interrupted".into(),
        ResponseStop::Failed(why) => format!("failed: {why}"),
        ResponseStop::Closed(point) => format!(
            "closed on itself at point {point}: a step jumped onto an isolated loop of \
             responses, away from the curve of the sweep (a smaller max_step may keep it on)"
        ),
    }
}

#[derive(Serialize)]
struct Meta<'a> {
    name: &'a str,
    status: &'a str,
    /// The dofs of `peaks` (after `fixed_dofs`).
    output_dofs: &'a [usize],
    /// The force shape at unit amplitude, `F_c cos Ωt + F_s sin Ωt`.
    force_cosine: &'a [f64],
    force_sine: &'a [f64],
    curves: &'a [CurveRecord],
}

/// Streams one response to `<dir>/<name>.csv`, `<name>.events.csv` and `<name>.json`.
///
/// The JSON is `{...,"curves":[...],"points":[p0,...],"events":[e0,...]}`: a point is written
/// over the `],"events":[...]}` tail followed by the tail again, an event over the closing
/// `]}`; when a curve ends the document is rewritten whole with that curve's record (through
/// `<name>.json.tmp`).
pub struct ResponseWriter {
    name: String,
    output_dofs: Vec<usize>,
    force: nnm::model::HarmonicForce,
    csv: CsvFile,
    events_csv: CsvFile,
    json: File,
    json_path: PathBuf,
    points_end: u64,
    points_json: String,
    events_json: String,
    curves: Vec<CurveRecord>,
}

impl ResponseWriter {
    /// Creates the files of response `name` in `dir`.
    pub fn create(
        dir: &Path,
        name: &str,
        output_dofs: &[usize],
        force: &nnm::model::HarmonicForce,
    ) -> Result<Self, OutputError> {
        let context = ResponseContext {
            curve: 0,
            output_dofs,
        };
        let csv = CsvFile::create(
            dir.join(format!("{name}.csv")),
            &response_csv_header(&context),
        )?;
        let first = output_dofs.first().map_or(String::new(), |d| d.to_string());
        let events_header: Vec<String> = RESPONSE_EVENTS_HEADER
            .replace("<d>", &first)
            .split(',')
            .map(String::from)
            .collect();
        let events_csv = CsvFile::create(dir.join(format!("{name}.events.csv")), &events_header)?;
        let json_path = dir.join(format!("{name}.json"));
        let json = File::create(&json_path).map_err(output_error(&json_path))?;
        let mut writer = Self {
            name: name.to_string(),
            output_dofs: output_dofs.to_vec(),
            force: force.clone(),
            csv,
            events_csv,
            json,
            json_path,
            points_end: 0,
            points_json: String::new(),
            events_json: String::new(),
            curves: Vec::new(),
        };
        writer.rewrite("running")?;
        Ok(writer)
    }

    /// Writes the whole JSON document and reopens it for appending.
    fn rewrite(&mut self, status: &str) -> Result<(), OutputError> {
        let meta = serde_json::to_string(&Meta {
            name: &self.name,
            status,
            output_dofs: &self.output_dofs,
            force_cosine: &self.force.cosine,
            force_sine: &self.force.sine,
            curves: &self.curves,
        })
        .expect("serialisable");
        let head = format!(
            "{},\"points\":[{}",
            meta.strip_suffix('}').expect("an object"),
            self.points_json
        );
        let text = format!("{head}],\"events\":[{}]}}", self.events_json);
        let tmp = self.json_path.with_extension("json.tmp");
        std::fs::write(&tmp, text).map_err(output_error(&tmp))?;
        std::fs::rename(&tmp, &self.json_path).map_err(output_error(&self.json_path))?;
        self.json = OpenOptions::new()
            .write(true)
            .open(&self.json_path)
            .map_err(output_error(&self.json_path))?;
        self.points_end = head.len() as u64;
        Ok(())
    }

    /// Appends one point of curve `curve` to the CSV and the JSON (flushed before returning).
    pub fn write_point(&mut self, curve: usize, p: &ResponsePoint) -> Result<(), OutputError> {
        let context = ResponseContext {
            curve,
            output_dofs: &self.output_dofs,
        };
        self.csv.append(&response_csv_record(p, &context))?;
        let record = serde_json::to_string(&PointRecord::new(curve, p)).expect("serialisable");
        let separator = if self.points_json.is_empty() { "" } else { "," };
        let text = format!("{separator}{record}],\"events\":[{}]}}", self.events_json);
        let err = output_error(&self.json_path);
        self.json
            .seek(SeekFrom::Start(self.points_end))
            .map_err(&err)?;
        self.json.write_all(text.as_bytes()).map_err(&err)?;
        self.json.flush().map_err(&err)?;
        self.points_end += (separator.len() + record.len()) as u64;
        self.points_json.push_str(separator);
        self.points_json.push_str(&record);
        Ok(())
    }

    /// Appends one located event of curve `curve`; `backbone_peak`: the peak of the first
    /// output dof on a backbone of the job at the event's frequency, if one is beside it
    /// (written for phase resonances).
    pub fn write_event(
        &mut self,
        curve: usize,
        e: &ResponseEvent,
        backbone_peak: Option<f64>,
    ) -> Result<(), OutputError> {
        let (re, im) = e.critical_multiplier;
        let record = [
            curve.to_string(),
            e.kind.name().to_string(),
            Number(e.point.frequency).to_string(),
            Number(e.point.force_amplitude).to_string(),
            e.point
                .peaks
                .first()
                .map_or(String::new(), |&x| Number(x).to_string()),
            Number(re).to_string(),
            Number(im).to_string(),
            Number(re.hypot(im)).to_string(),
            backbone_peak.map_or(String::new(), |x| Number(x).to_string()),
        ];
        self.events_csv.append(&record)?;
        let record = serde_json::to_string(&EventRecord {
            curve,
            kind: e.kind.name(),
            after_point: e.point.index,
            critical_multiplier: [re, im],
            backbone_peak,
            point: PointRecord::new(curve, &e.point),
        })
        .expect("serialisable");
        let separator = if self.events_json.is_empty() { "" } else { "," };
        let err = output_error(&self.json_path);
        self.json.seek(SeekFrom::End(-2)).map_err(&err)?;
        self.json
            .write_all(format!("{separator}{record}]}}").as_bytes())
            .map_err(&err)?;
        self.json.flush().map_err(&err)?;
        self.events_json.push_str(separator);
        self.events_json.push_str(&record);
        Ok(())
    }

    /// Records a curve's end (the JSON rewritten with it, still running).
    pub fn end_curve(&mut self, record: CurveRecord) -> Result<(), OutputError> {
        self.curves.push(record);
        self.rewrite("running")
    }

    /// Marks the response finished: the JSON says `"status": "finished"`.
    pub fn finish(&mut self) -> Result<(), OutputError> {
        self.rewrite("finished")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// docs/output.md's table of `<response>.csv` has a row for every column, with the unit
    /// declared here.
    #[test]
    fn docs_output_md_lists_every_response_column_with_its_unit() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/output.md");
        let docs = std::fs::read_to_string(path).expect("docs/output.md");
        let section = &docs[docs
            .find("### `<response>.csv`")
            .expect("the response section")..];
        for c in response_csv_columns() {
            let row = format!("| `{}` | {} |", c.name, c.unit);
            assert!(section.contains(&row), "docs/output.md has no row `{row}`");
        }
    }

    /// The header holds the columns the issue asks for, a peak per output dof in their order,
    /// and a row a field per header, each of its column's kind.
    #[test]
    fn a_row_has_a_field_per_header_of_its_columns_kind() {
        let context = ResponseContext {
            curve: 2,
            output_dofs: &[4, 1],
        };
        assert_eq!(
            response_csv_header(&context).join(","),
            "curve,index,frequency_rad_s,frequency_hz,force_amplitude,peak_x4,peak_x1,harmonic_amplitude,phase_lag_rad,stable,max_floquet_modulus,relative_residual,iterations,integration_steps"
        );
        let p = ResponsePoint {
            index: 3,
            frequency: std::f64::consts::TAU,
            force_amplitude: 0.5,
            z0: vec![0.0; 4],
            peaks: vec![0.25, 0.125],
            harmonic_amplitude: 0.2,
            phase_lag: 1.5,
            multipliers: vec![],
            max_floquet_modulus: 1.5,
            stable: false,
            relative_residual: 1e-10,
            iterations: 2,
            step: 0.01,
            integration_steps: 40,
            unknowns: vec![],
            tangent: vec![],
        };
        assert_eq!(
            response_csv_record(&p, &context).join(","),
            "2,3,6.283185307179586,1,0.5,0.25,0.125,0.2,1.5,false,1.5,1e-10,2,40"
        );
        for c in RESPONSE_COLUMNS {
            for v in c.values(&p, &context) {
                let fits = matches!(
                    (c.kind, &v),
                    (Kind::Float, Value::Float(_) | Value::Empty)
                        | (Kind::Integer, Value::Integer(_))
                        | (Kind::Bool, Value::Bool(_))
                );
                assert!(fits, "column {} is {:?} but has {v:?}", c.name, c.kind);
            }
        }
    }
}
