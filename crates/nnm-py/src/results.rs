//! Results as Python values: a branch's points (and a response's) as numpy columns, a branch's
//! events, stop and counters, linear modes as arrays, and the names Python sees for patterns and stop reasons.

use nnm::forced::ResponsePoint;
use nnm::modes::{LinearMode, StandingWave};
use nnm::{Branch, BranchPoint, StopReason};
use nnm_io::output::columns::{
    BranchContext, Column, ColumnFields, Kind, POINT_COLUMNS, PointColumn, Value,
};
use nnm_io::output::{RESPONSE_COLUMNS, ResponseContext};
use numpy::ndarray::Array2;
use numpy::{Complex64, IntoPyArray};
use pyo3::prelude::*;
use pyo3::types::{PyComplex, PyDict, PyList};

/// `(key, name, unit, doc, kind, csv, per_output_dof)` of a column of points (a branch's or a
/// response's).
pub type ColumnInfo = (
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    &'static str,
    bool,
    bool,
);

/// The point columns as the Python `Branch` reads them (`_nnm.POINT_COLUMNS`), in declaration
/// order: `kind` is one of [`kind_name`]'s words, `name` the CSV header (`<d>` standing for the
/// dof where `per_output_dof`), `csv` whether `<name>.csv` (and so `Branch.to_pandas()`) has it.
pub fn point_columns() -> Vec<ColumnInfo> {
    POINT_COLUMNS.iter().map(column_info).collect()
}

/// The columns of a response's points as the Python `Response` reads them
/// (`_nnm.RESPONSE_COLUMNS`), as [`point_columns`] gives a branch's.
pub fn response_columns() -> Vec<ColumnInfo> {
    RESPONSE_COLUMNS.iter().map(column_info).collect()
}

fn column_info<F: ColumnFields>(c: &Column<F>) -> ColumnInfo {
    (
        c.key,
        c.name,
        c.unit,
        c.doc,
        kind_name(c.kind),
        c.csv,
        c.per_output_dof(),
    )
}

/// The name Python sees for a column's kind.
fn kind_name(kind: Kind) -> &'static str {
    match kind {
        Kind::Float => "float",
        Kind::Integer => "integer",
        Kind::OptionalInteger => "optional-integer",
        Kind::Bool => "bool",
        Kind::Text => "text",
    }
}

/// One column's array from its fields, one list a point: `float64` for a float (NaN where a
/// point has no value) and for a count a point may lack, `int64` for one every point has,
/// `bool`, a list of `str` for text (`""` where a point has none); a column with a field per
/// output dof (`per_output_dof`: their number) is `points × output_dofs`. `name` names the
/// column in a panic on a field not of the declared kind.
fn column_array<'py>(
    py: Python<'py>,
    name: &str,
    kind: Kind,
    per_output_dof: Option<usize>,
    rows: Vec<Vec<Value>>,
) -> PyResult<Bound<'py, PyAny>> {
    if let Some(width) = per_output_dof {
        let rows: Vec<Vec<f64>> = rows
            .iter()
            .map(|r| r.iter().map(|v| as_float(name, kind, v)).collect())
            .collect();
        let array = Array2::from_shape_fn((rows.len(), width), |(k, d)| rows[k][d]);
        return Ok(array.into_pyarray(py).into_any());
    }
    let fields = rows.into_iter().map(|mut v| {
        debug_assert_eq!(v.len(), 1);
        v.swap_remove(0)
    });
    Ok(match kind {
        Kind::Float | Kind::OptionalInteger => {
            let array: Vec<f64> = fields.map(|v| as_float(name, kind, &v)).collect();
            array.into_pyarray(py).into_any()
        }
        Kind::Integer => {
            let array: Vec<i64> = fields
                .map(|v| match v {
                    Value::Integer(n) => n as i64,
                    other => mismatch(name, kind, &other),
                })
                .collect();
            array.into_pyarray(py).into_any()
        }
        Kind::Bool => {
            let array: Vec<bool> = fields
                .map(|v| match v {
                    Value::Bool(b) => b,
                    other => mismatch(name, kind, &other),
                })
                .collect();
            array.into_pyarray(py).into_any()
        }
        Kind::Text => {
            let list: Vec<String> = fields
                .map(|v| match v {
                    Value::Text(s) => s,
                    Value::Empty => String::new(),
                    other => mismatch(name, kind, &other),
                })
                .collect();
            list.into_pyobject(py)?.into_any()
        }
    })
}

/// A float column's value, or a count's as a float; NaN where the point has none.
fn as_float(name: &str, kind: Kind, value: &Value) -> f64 {
    match value {
        Value::Float(x) => *x,
        Value::Integer(n) => *n as f64,
        Value::Empty => f64::NAN,
        other => mismatch(name, kind, other),
    }
}

/// A field not of its column's declared kind: a mistake in `POINT_COLUMNS` or
/// `RESPONSE_COLUMNS` (their tests `every_field_is_of_its_columns_kind` and
/// `a_row_has_a_field_per_header_of_its_columns_kind` keep it out).
fn mismatch(name: &str, kind: Kind, value: &Value) -> ! {
    panic!("column `{name}` is declared {kind:?} but a point gives {value:?}")
}

/// A branch's column `column` over `points`.
fn point_column<'py>(
    py: Python<'py>,
    column: &PointColumn,
    points: &[BranchPoint],
    context: &BranchContext<'_>,
) -> PyResult<Bound<'py, PyAny>> {
    let width = column.per_output_dof().then_some(context.output_dofs.len());
    let rows = points.iter().map(|p| column.values(p, context)).collect();
    column_array(py, column.name, column.kind, width, rows)
}

/// A response's columns over `points`, one array each into `out` under its key.
pub fn response_columns_into<'py>(
    py: Python<'py>,
    points: &[ResponsePoint],
    context: &ResponseContext<'_>,
    out: &Bound<'py, PyDict>,
) -> PyResult<()> {
    for column in RESPONSE_COLUMNS {
        let width = column.per_output_dof().then_some(context.output_dofs.len());
        let rows = points.iter().map(|p| column.values(p, context)).collect();
        out.set_item(
            column.key,
            column_array(py, column.name, column.kind, width, rows)?,
        )?;
    }
    Ok(())
}

pub fn wave_name(pattern: Option<StandingWave>) -> Option<&'static str> {
    pattern.map(|p| match p {
        StandingWave::Cos => "cos",
        StandingWave::Sin => "sin",
    })
}

/// Linear modes in ascending frequency as a dict of `frequency` (rad/s), `shapes` (`n` rows,
/// one mass-normalised column per mode), `rigid`, `label` (`"n,d"` or `None`) and `pattern`.
pub fn modes_dict<'py>(
    py: Python<'py>,
    modes: &[LinearMode],
    n: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let frequency: Vec<f64> = modes.iter().map(|m| m.frequency).collect();
    out.set_item("frequency", frequency.into_pyarray(py))?;
    let shapes = Array2::from_shape_fn((n, modes.len()), |(i, k)| modes[k].shape[i]);
    out.set_item("shapes", shapes.into_pyarray(py))?;
    let rigid: Vec<bool> = modes.iter().map(|m| m.rigid).collect();
    out.set_item("rigid", rigid.into_pyarray(py))?;
    let labels: Vec<Option<String>> = modes.iter().map(|m| m.cyclic.map(|_| m.label())).collect();
    out.set_item("label", labels)?;
    let patterns: Vec<Option<&str>> = modes
        .iter()
        .map(|m| wave_name(m.cyclic.and_then(|c| c.pattern)))
        .collect();
    out.set_item("pattern", patterns)?;
    Ok(out)
}

/// The machine-readable name of a stop reason (the text is `StopReason`'s `Display`).
pub fn stop_kind(stop: &StopReason) -> &'static str {
    match stop {
        StopReason::EnergyMax => "energy-max",
        StopReason::FrequencyShiftMax => "frequency-shift-max",
        StopReason::MaxPoints => "max-points",
        StopReason::Interrupted => "interrupted",
        StopReason::StepTooSmall(_) => "step-too-small",
    }
}

/// The branch's points as columns (numpy arrays), its events, stop reason and counters, into
/// `out`. One array per declared point column ([`point_column`]); multipliers are a
/// `points × m` complex array (NaN where a point has fewer).
pub fn branch_dict<'py>(
    py: Python<'py>,
    branch: &Branch,
    context: &BranchContext<'_>,
    out: &Bound<'py, PyDict>,
) -> PyResult<()> {
    let points = &branch.points;
    for column in POINT_COLUMNS {
        out.set_item(column.key, point_column(py, column, points, context)?)?;
    }
    let missed = PyList::empty(py);
    for m in &branch.missed_requests {
        let d = PyDict::new(py);
        d.set_item("label", m.label.name())?;
        d.set_item("value", m.value)?;
        d.set_item("why", &m.why)?;
        missed.append(d)?;
    }
    out.set_item("missed_requests", missed)?;
    let width = points.first().map_or(0, |p| p.z0.len());
    let state0 = Array2::from_shape_fn((points.len(), width), |(k, i)| points[k].z0[i]);
    out.set_item("state0", state0.into_pyarray(py))?;
    let m = points
        .iter()
        .map(|p| p.floquet.multipliers.len())
        .max()
        .unwrap_or(0);
    let multipliers = Array2::from_shape_fn((points.len(), m), |(k, i)| {
        points[k]
            .floquet
            .multipliers
            .get(i)
            .map_or(Complex64::new(f64::NAN, f64::NAN), |c| {
                Complex64::new(c.0, c.1)
            })
    });
    out.set_item("multipliers", multipliers.into_pyarray(py))?;
    let events = PyList::empty(py);
    for e in &branch.events {
        let d = PyDict::new(py);
        d.set_item("kind", e.kind.name())?;
        d.set_item("abbreviation", e.kind.abbreviation())?;
        d.set_item("energy", e.point.energy)?;
        d.set_item("frequency", e.point.frequency)?;
        d.set_item("period", e.point.period)?;
        d.set_item(
            "multiplier",
            PyComplex::from_doubles(py, e.multiplier.0, e.multiplier.1),
        )?;
        d.set_item("multiplicity", e.multiplicity)?;
        d.set_item("after_point", e.after)?;
        d.set_item("arclength_uncertainty", e.arclength_uncertainty)?;
        d.set_item("converged", e.converged)?;
        d.set_item("state0", e.point.z0.clone().into_pyarray(py))?;
        events.append(d)?;
    }
    out.set_item("events", events)?;
    out.set_item("stop", branch.stop.to_string())?;
    let stats = PyDict::new(py);
    let s = &branch.stats;
    stats.set_item("points", s.points)?;
    stats.set_item("events", s.events)?;
    stats.set_item("newton_iterations", s.newton_iterations)?;
    stats.set_item("rejected_steps", s.rejected_steps)?;
    stats.set_item("location_steps", s.location_steps)?;
    stats.set_item("integrations", s.shooting.integrations)?;
    stats.set_item("steps", s.shooting.integration.steps)?;
    stats.set_item("factorisations", s.shooting.integration.factorisations)?;
    out.set_item("stats", stats)?;
    Ok(())
}
