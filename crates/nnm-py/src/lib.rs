//! The native module `nnm._nnm` of the Python package `nnm`.
//!
//! This crate only converts: Python values into the library's models and settings, results
//! into numpy arrays and dicts. Every rule about what a model or a setting may be, and every
//! message about it, is the job file's (`nnm_io::job`), so that a script and a job file are
//! refused for the same reasons with the same one-line messages. The pure-Python layer
//! (`python/nnm`) gives the API its shape: classes, defaults, exceptions, progress bars, plots.
//!
//! Numerical failures are returned as data (the message and the points computed so far), not
//! raised here: the Python layer raises `nnm.ContinuationError` with the partial branch on it.
//! Bad input raises `ValueError`/`TypeError` at once. A panic of the library is caught and
//! raised as `RuntimeError` ("internal error"), never as pyo3's `PanicException`, which is
//! not an `Exception` and would escape `except Exception`.

use std::ops::ControlFlow;
use std::panic::AssertUnwindSafe;
use std::path::PathBuf;

use nnm::analysis::ModalComponent;
use nnm::bifurcation::{Event, SwitchError};
use nnm::model::{CyclicSymmetry, Matrix, ModelError, PolynomialTensor, SparseMatrix, Structure};
use nnm::modes::{LinearMode, StandingWave, linear_modes};
use nnm::shooting::EvaluationProgress;
use nnm::{Branch, BranchPoint, MechanicalSystem, Observer, Start, StopReason};
use nnm_io::job::{BranchBody, BranchJob, Element, JobError};
use numpy::ndarray::Array2;
use numpy::{Complex64, IntoPyArray, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{
    PyFileNotFoundError, PyIndexError, PyRuntimeError, PyTypeError, PyValueError,
};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyComplex, PyDict, PyList, PyTuple};

mod convert;

use convert::{table_from_dict, value_error};

/// A model held by the library, with the branches of the job file it came from (if any).
#[pyclass(frozen, module = "nnm._nnm")]
struct NativeModel {
    structure: Structure,
    family: String,
    /// The `[[branch]]` entries of the job file (empty for other models).
    branches: Vec<BranchJob>,
}

/// What a switch at one of a computed branch's events needs from it: the start it was
/// computed from and its located events (kept in the library's types, opaque to Python).
#[pyclass(frozen, module = "nnm._nnm")]
struct NativeBranch {
    start: Start,
    events: Vec<Event>,
}

/// `nnm.NumericalError(message)`: a failure on valid input (the class is the Python layer's).
fn numerical_error(py: Python<'_>, message: String) -> PyErr {
    match py
        .import("nnm._errors")
        .and_then(|m| m.getattr("NumericalError"))
        .and_then(|class| class.call1((message,)))
    {
        Ok(error) => PyErr::from_value(error),
        Err(e) => e,
    }
}

/// One matrix as the Python layer hands it over: a 2-D float64 array, or a sparse matrix's
/// triplets `(rows, cols, row_indices, col_indices, values)` (duplicates are summed).
fn matrix_from_py(name: &'static str, value: &Bound<'_, PyAny>) -> PyResult<Matrix> {
    if let Ok(tuple) = value.cast::<PyTuple>() {
        let (rows, cols, i, j, v): (
            usize,
            usize,
            PyReadonlyArray1<'_, i64>,
            PyReadonlyArray1<'_, i64>,
            PyReadonlyArray1<'_, f64>,
        ) = tuple.extract()?;
        if rows != cols {
            // As for a Matrix Market file that is not square.
            return Err(PyValueError::new_err(format!(
                "{name} matrix is {rows}x{cols}, not square"
            )));
        }
        let (i, j, v) = (i.as_slice()?, j.as_slice()?, v.as_slice()?);
        let triplets: Vec<(usize, usize, f64)> = i
            .iter()
            .zip(j)
            .zip(v)
            .map(|((&i, &j), &v)| (dof_index(i), dof_index(j), v))
            .collect();
        let sparse = SparseMatrix::from_triplets(rows, &triplets)
            .map_err(|m| PyValueError::new_err(format!("{name} matrix {m}")))?;
        return Ok(Matrix::Sparse(sparse));
    }
    let array: PyReadonlyArray2<'_, f64> = value.extract()?;
    let a = array.as_array();
    let (rows, cols) = a.dim();
    Ok(Matrix::from_fn(rows, cols, |i, j| a[(i, j)]))
}

/// A 0-based index from Python; a negative one becomes an index out of every range, which the
/// library's own checks then refuse by name.
fn dof_index(k: i64) -> usize {
    usize::try_from(k).unwrap_or(usize::MAX)
}

/// A job-file message about keyword arguments: `TypeError` for a value of the wrong type
/// (serde's "invalid type: ..."), `ValueError` otherwise.
fn input_error(message: String) -> PyErr {
    if message.starts_with("invalid type:") {
        PyTypeError::new_err(message)
    } else {
        PyValueError::new_err(message)
    }
}

fn model_error(e: ModelError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// One nonlinear element as the Python layer hands it over:
/// `("cubic" | "polynomial", dofs, coefficient, exponent)` or
/// `("tensor", quadratic_subs, quadratic_values, cubic_subs, cubic_values)` (subs `m × 3` and
/// `m × 4`, 0-based). Messages are the job file's for the same element.
fn element_from_py(index: usize, n: usize, value: &Bound<'_, PyAny>) -> PyResult<Element> {
    let tuple = value.cast::<PyTuple>()?;
    let kind: String = tuple.get_item(0)?.extract()?;
    let element_error =
        |m: String| PyValueError::new_err(format!("nonlinear element {}: {m}", index + 1));
    if kind != "tensor" {
        let (_, dofs, coefficient, exponent): (String, Vec<usize>, f64, Option<i64>) =
            tuple.extract()?;
        return nnm_io::job::spring(&kind, Some(&dofs), Some(coefficient), exponent)
            .map(Element::Spring)
            .map_err(element_error);
    }
    let (_, q_subs, q_vals, c_subs, c_vals): (
        String,
        PyReadonlyArray2<'_, i64>,
        PyReadonlyArray1<'_, f64>,
        PyReadonlyArray2<'_, i64>,
        PyReadonlyArray1<'_, f64>,
    ) = tuple.extract()?;
    let (q, c) = (q_subs.as_array(), c_subs.as_array());
    let quadratic = q
        .rows()
        .into_iter()
        .zip(q_vals.as_array())
        .map(|(r, &v)| (dof_index(r[0]), dof_index(r[1]), dof_index(r[2]), v))
        .collect();
    let cubic = c
        .rows()
        .into_iter()
        .zip(c_vals.as_array())
        .map(|(r, &v)| {
            (
                dof_index(r[0]),
                dof_index(r[1]),
                dof_index(r[2]),
                dof_index(r[3]),
                v,
            )
        })
        .collect();
    PolynomialTensor::new(n, quadratic, cubic)
        .map(Element::Tensor)
        .map_err(|e| element_error(e.describe(0)))
}

fn job_error(path: &std::path::Path, e: JobError) -> PyErr {
    match &e {
        JobError::Read { .. } if !path.exists() => PyFileNotFoundError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// Runs `f` and turns a panic of the library into a `RuntimeError`.
fn no_panic<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    std::panic::catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|payload| {
        let message = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown".into());
        Err(PyRuntimeError::new_err(format!(
            "internal error (please report): {message}"
        )))
    })
}

fn wave_name(pattern: Option<StandingWave>) -> Option<&'static str> {
    pattern.map(|p| match p {
        StandingWave::Cos => "cos",
        StandingWave::Sin => "sin",
    })
}

#[pymethods]
impl NativeModel {
    /// A built-in family from its job-file keys (`family` and its parameters).
    #[staticmethod]
    fn from_table(py: Python<'_>, table: &Bound<'_, PyDict>) -> PyResult<Self> {
        let table = table_from_dict(table)?;
        let (structure, family) =
            py.detach(|| no_panic(|| nnm_io::job::model_from_table(table).map_err(input_error)))?;
        Ok(Self {
            structure,
            family,
            branches: Vec::new(),
        })
    }

    /// The model (and branches) of a job file, read as `nnm run` reads it (without the GIL:
    /// a finite-element export can take a while to read), with `overrides` (dotted keys,
    /// `nnm_io::job::load_job_with`) replacing keys of the file.
    #[staticmethod]
    #[pyo3(signature = (path, overrides=None))]
    fn from_job(
        py: Python<'_>,
        path: PathBuf,
        overrides: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let mut replaced = Vec::new();
        for (key, value) in overrides.iter().flat_map(|d| d.iter()) {
            let key: String = key.extract()?;
            let value = convert::to_toml(&key, &value)?;
            replaced.push((key, value));
        }
        let job = py.detach(|| {
            no_panic(|| {
                nnm_io::job::load_job_with(&path, &replaced).map_err(|e| job_error(&path, e))
            })
        })?;
        Ok(Self {
            structure: job.structure,
            family: job.family,
            branches: job.branches,
        })
    }

    /// A general model: matrices (see `matrix_from_py`), elements (`element_from_py`), fixed
    /// dofs and a cyclic symmetry `(sectors, dofs_per_sector)`.
    #[staticmethod]
    #[pyo3(signature = (mass, stiffness, elements, fixed_dofs=None, cyclic=None))]
    fn general(
        py: Python<'_>,
        mass: &Bound<'_, PyAny>,
        stiffness: &Bound<'_, PyAny>,
        elements: &Bound<'_, PyList>,
        fixed_dofs: Option<Vec<usize>>,
        cyclic: Option<(usize, usize)>,
    ) -> PyResult<Self> {
        let mass = matrix_from_py("mass", mass)?;
        let stiffness = matrix_from_py("stiffness", stiffness)?;
        let n = mass.nrows();
        let elements = elements
            .iter()
            .enumerate()
            .map(|(k, e)| element_from_py(k, n, &e))
            .collect::<PyResult<Vec<_>>>()?;
        let cyclic = cyclic.map(|(sectors, dofs_per_sector)| CyclicSymmetry {
            sectors,
            dofs_per_sector,
        });
        // Factorising a large mass can take a while: without the GIL.
        let structure = py.detach(|| {
            no_panic(|| {
                nnm_io::job::general_model(mass, stiffness, elements, fixed_dofs.as_deref(), cyclic)
                    .map_err(model_error)
            })
        })?;
        Ok(Self {
            structure,
            family: "general".into(),
            branches: Vec::new(),
        })
    }

    /// Number of degrees of freedom.
    #[getter]
    fn dofs(&self) -> usize {
        self.structure.dofs()
    }

    /// `"bladed-disk"`, `"duffing"`, ..., or `"general"`.
    #[getter]
    fn family(&self) -> &str {
        &self.family
    }

    /// `(sectors, dofs_per_sector)` of a cyclic model, else `None`.
    #[getter]
    fn cyclic(&self) -> Option<(usize, usize)> {
        self.structure
            .cyclic_symmetry()
            .map(|c| (c.sectors, c.dofs_per_sector))
    }

    /// The names of the job file's branches.
    #[getter]
    fn branch_names(&self) -> Vec<String> {
        self.branches.iter().map(|b| b.name.clone()).collect()
    }

    /// The starting mode of the job's branch `name`, as written (`"n,d"` or an index), and its
    /// pattern (`cos`/`sin`, `travelling`...): `None` for a branch switched from an event.
    fn branch_mode(&self, name: &str) -> PyResult<Option<(String, Option<&'static str>)>> {
        let body = match self.branches.iter().find(|b| b.name == name) {
            Some(b) if b.from_event.is_some() => return Ok(None),
            Some(_) => self.job_branch(name, false)?,
            None => return self.job_branch(name, false).map(|_| None),
        };
        let pattern = body.travel.map(|t| t.name()).or(wave_name(body.pattern));
        Ok(Some((body.mode, pattern)))
    }

    /// `"mass"` or `"stiffness"` as given: a 2-D array, or `(n, indptr, indices, data)` of
    /// compressed sparse rows.
    fn matrix<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let m = match name {
            "mass" => self.structure.mass_matrix(),
            "stiffness" => self.structure.stiffness(),
            _ => return Err(PyValueError::new_err(format!("no matrix `{name}`"))),
        };
        Ok(match m {
            Matrix::Sparse(s) => {
                let p = s.pattern();
                (
                    s.dimension(),
                    p.row_start.clone().into_pyarray(py),
                    p.col.clone().into_pyarray(py),
                    s.values().to_vec().into_pyarray(py),
                )
                    .into_pyobject(py)?
                    .into_any()
            }
            Matrix::Dense(_) => {
                let n = m.nrows();
                let a = Array2::from_shape_fn((n, n), |(i, j)| m.get(i, j));
                a.into_pyarray(py).into_any()
            }
        })
    }

    /// Linear modes in ascending frequency: a dict of `frequency` (rad/s), `shapes` (one
    /// mass-normalised column per mode), `rigid`, `label` (`"n,d"` or `None`) and `pattern`.
    fn modes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let modes = self.linear_modes(py)?;
        let n = self.structure.dofs();
        let out = PyDict::new(py);
        let frequency: Vec<f64> = modes.iter().map(|m| m.frequency).collect();
        out.set_item("frequency", frequency.into_pyarray(py))?;
        let shapes = Array2::from_shape_fn((n, modes.len()), |(i, k)| modes[k].shape[i]);
        out.set_item("shapes", shapes.into_pyarray(py))?;
        let rigid: Vec<bool> = modes.iter().map(|m| m.rigid).collect();
        out.set_item("rigid", rigid.into_pyarray(py))?;
        let labels: Vec<Option<String>> =
            modes.iter().map(|m| m.cyclic.map(|_| m.label())).collect();
        out.set_item("label", labels)?;
        let patterns: Vec<Option<&str>> = modes
            .iter()
            .map(|m| wave_name(m.cyclic.and_then(|c| c.pattern)))
            .collect();
        out.set_item("pattern", patterns)?;
        Ok(out)
    }

    /// Follows one branch. `mode` and `settings` take the keys of a job file's `[[branch]]`
    /// (settings merged over nothing: the library's defaults), or `branch` names one of the
    /// job file's. `callback(index, energy, frequency, stable)` is called after every point;
    /// returning `False` stops the branch there. Returns a dict (see `branch_dict`).
    #[pyo3(signature = (mode, settings, branch=None, callback=None))]
    fn backbone<'py>(
        &self,
        py: Python<'py>,
        mode: Option<&Bound<'py, PyAny>>,
        settings: &Bound<'py, PyDict>,
        branch: Option<String>,
        callback: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let body = match branch {
            Some(name) => {
                let mut body = self.job_branch(&name, !settings.is_empty())?;
                if let Some(mode) = mode {
                    // The branch's settings from another mode: a sweep follows the job's
                    // branch on a mistuned model, whose mode is found by its shape.
                    let mut table = toml::Table::from_iter([(
                        "mode".to_string(),
                        convert::to_toml("mode", mode)?,
                    )]);
                    (body.mode, body.pattern, body.travel) =
                        nnm_io::job::branch_mode(&mut table, false).map_err(input_error)?;
                }
                body
            }
            None => {
                let mut table = table_from_dict(settings)?;
                if let Some(mode) = mode {
                    table.insert("mode".into(), convert::to_toml("mode", mode)?);
                }
                nnm_io::job::branch_body(table, &toml::Table::new(), false).map_err(input_error)?
            }
        };
        let mut modes = self.linear_modes(py)?;
        nnm::modes::add_labelled_mode(&self.structure, &mut modes, &body.mode, body.pattern)
            .map_err(|e| PyValueError::new_err(format!("modal analysis failed: {e}")))?;
        let index = nnm_io::job::resolve_mode(&modes, &body.mode, body.pattern)
            .map_err(PyValueError::new_err)?;
        let structure = &self.structure;
        let start = no_panic(|| {
            Start::for_branch(structure, &modes, index, body.travel, &body.settings)
                .map_err(value_error)
        })?;
        let mode = &modes[index];
        self.follow(py, start, &body.settings, callback, |out| {
            out.set_item("mode_index", index)?;
            out.set_item("mode_label", mode.cyclic.map(|_| mode.label()))?;
            match body.travel {
                Some(travel) => out.set_item("pattern", travel.name()),
                None => out.set_item("pattern", wave_name(mode.cyclic.and_then(|c| c.pattern))),
            }
        })
    }

    /// Follows the family through event `event` of a computed branch (`parent`, the
    /// `"native"` entry of its dict): a branch point's other family, or a period doubling's
    /// family of twice the period, started `SWITCH_AMPLITUDE` of the amplitude away along
    /// null direction `direction` (docs/method.md §9), as `nnm run` does for
    /// `start = { branch, event }`. `settings` are a switched `[[branch]]`'s keys.
    #[pyo3(signature = (parent, event, direction, settings, callback=None))]
    fn switch<'py>(
        &self,
        py: Python<'py>,
        parent: PyRef<'py, NativeBranch>,
        event: usize,
        direction: usize,
        settings: &Bound<'py, PyDict>,
        callback: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let table = table_from_dict(settings)?;
        let body =
            nnm_io::job::branch_body(table, &toml::Table::new(), true).map_err(input_error)?;
        let count = parent.events.len();
        let located = parent.events.get(event).ok_or_else(|| {
            PyIndexError::new_err(format!(
                "the branch has {count} event{}, so no event {event}",
                if count == 1 { "" } else { "s" }
            ))
        })?;
        let (structure, parent_start) = (&self.structure, &parent.start);
        let switch = py.detach(|| {
            no_panic(|| {
                Ok(nnm::bifurcation::switch_branch(
                    structure,
                    parent_start,
                    located,
                    &body.settings,
                    nnm_io::job::SWITCH_AMPLITUDE,
                    direction,
                ))
            })
        })?;
        let switch = switch.map_err(|e| match e {
            // Asking to switch at a fold or a Krein collision is the caller's mistake.
            SwitchError::NotABifurcation(_) | SwitchError::NoSuchDirection { .. } => {
                PyValueError::new_err(e.to_string())
            }
            _ => numerical_error(py, format!("cannot switch at event {event}: {e}")),
        })?;
        let phase = switch.start.phase.unwrap_or(body.settings.shooting.phase);
        self.follow(py, switch.start, &body.settings, callback, |out| {
            let from = PyDict::new(py);
            from.set_item("event", event)?;
            from.set_item("direction", direction)?;
            from.set_item("kind", located.kind.name())?;
            from.set_item("phase", nnm_io::job::phase_name(phase))?;
            out.set_item("switched_from", from)
        })
    }

    /// The motion from `state0` over `period`, sampled at `samples + 1` equal times (the last
    /// closes the orbit), integrated to relative `tolerance`: a `(samples + 1) × 2n` array.
    fn motion<'py>(
        &self,
        py: Python<'py>,
        state0: PyReadonlyArray1<'py, f64>,
        period: f64,
        samples: usize,
        tolerance: f64,
    ) -> PyResult<Bound<'py, PyAny>> {
        let n = self.structure.dofs();
        let z0 = state0.as_slice()?.to_vec();
        if z0.len() != 2 * n || !(period.is_finite() && period > 0.0) || samples == 0 {
            return Err(PyValueError::new_err(format!(
                "motion needs a state of 2 x {n} values, a positive period and at least one sample"
            )));
        }
        let structure = &self.structure;
        let states = py.detach(|| {
            no_panic(|| {
                Ok(nnm::analysis::sample_motion(
                    structure, &z0, period, samples, tolerance,
                ))
            })
        })?;
        match states {
            Ok(states) => {
                let a = Array2::from_shape_fn((states.len(), 2 * n), |(k, i)| states[k][i]);
                Ok(a.into_pyarray(py).into_any())
            }
            Err(e) => Err(numerical_error(py, e.to_string())),
        }
    }
}

impl NativeModel {
    /// Follows the branch from `start` without the GIL, handing points to `callback`:
    /// the result dict of `branch_dict` with the stop, the failure (if any) as data, and the
    /// native state a switch at one of its events needs. `describe` adds what the caller
    /// knows of the branch (its mode, where it was switched from) — also to the partial
    /// result that an exception (Ctrl-C, the callback's) carries as `partial`.
    fn follow<'py>(
        &self,
        py: Python<'py>,
        start: Start,
        settings: &nnm::Settings,
        callback: Option<Py<PyAny>>,
        describe: impl FnOnce(&Bound<'py, PyDict>) -> PyResult<()>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let structure = &self.structure;
        let threading = py.import("threading")?;
        let main_thread = threading
            .call_method0("current_thread")?
            .is(&threading.call_method0("main_thread")?);
        let mut observer = PyObserver {
            callback: callback.as_ref(),
            main_thread,
            error: None,
            stopped: false,
        };
        let clock = std::time::Instant::now();
        let result = py.detach(|| {
            no_panic(|| {
                Ok(nnm::continue_branch_observed(
                    structure,
                    &start,
                    settings,
                    &mut observer,
                ))
            })
        })?;
        let wall_time = clock.elapsed().as_secs_f64();
        let out = PyDict::new(py);
        out.set_item("linear_frequency", start.omega)?;
        out.set_item("wall_time", wall_time)?;
        let output_dofs = start.output_dofs(settings);
        out.set_item("output_dofs", output_dofs.clone())?;
        let branch = match result {
            Ok(branch) => {
                branch_dict(py, &branch, output_dofs.len(), &out)?;
                let stopped_by_callback =
                    observer.stopped && branch.stop == StopReason::Interrupted;
                out.set_item(
                    "stop_kind",
                    if stopped_by_callback {
                        "callback"
                    } else {
                        stop_kind(&branch.stop)
                    },
                )?;
                let failure = match &branch.stop {
                    StopReason::StepTooSmall(_) => Some(branch.stop.to_string()),
                    _ => None,
                };
                out.set_item("error", failure)?;
                branch
            }
            Err(e) => {
                let empty = Branch {
                    points: Vec::new(),
                    events: Vec::new(),
                    stop: StopReason::StepTooSmall(String::new()),
                    stats: Default::default(),
                    omega: start.omega,
                    missed_requests: Vec::new(),
                };
                branch_dict(py, &empty, output_dofs.len(), &out)?;
                out.set_item("stop", e.to_string())?;
                out.set_item("stop_kind", "first-point")?;
                out.set_item("error", e.to_string())?;
                empty
            }
        };
        let native = NativeBranch {
            start,
            events: branch.events,
        };
        out.set_item("native", Py::new(py, native)?)?;
        describe(&out)?;
        if let Some(error) = observer.error {
            // Ctrl-C or the callback's own exception: raised with the points computed before
            // it (`partial`, made a `Branch` by the Python side), so an interruption loses
            // nothing.
            error.value(py).setattr("partial", out)?;
            return Err(error);
        }
        Ok(out)
    }

    /// Linear modes with the GIL released, failures as the command line words them.
    fn linear_modes(&self, py: Python<'_>) -> PyResult<Vec<LinearMode>> {
        let structure = &self.structure;
        py.detach(|| no_panic(|| Ok(linear_modes(structure))))?
            .map_err(|e| PyValueError::new_err(format!("modal analysis failed: {e}")))
    }

    /// The job file's branch `name` as the command line would run it (a branch switched from
    /// an event of another needs that branch's results: not available here).
    fn job_branch(&self, name: &str, overridden: bool) -> PyResult<BranchBody> {
        if overridden {
            return Err(PyTypeError::new_err(
                "give either `branch` (a branch of the job file, with its settings, and optionally another `mode`) or `mode` and settings",
            ));
        }
        let job = self
            .branches
            .iter()
            .find(|b| b.name == name)
            .ok_or_else(|| {
                let names: Vec<String> = self
                    .branches
                    .iter()
                    .map(|b| format!("`{}`", b.name))
                    .collect();
                PyValueError::new_err(format!(
                    "the job has no branch `{name}` (its branches: {})",
                    if names.is_empty() {
                        "none".into()
                    } else {
                        names.join(", ")
                    }
                ))
            })?;
        if let Some(from) = &job.from_event {
            return Err(PyValueError::new_err(format!(
                "branch `{name}` starts from event {} of branch `{}`: branch switching is not available from Python yet (run the job with `nnm run`)",
                from.event, from.branch
            )));
        }
        Ok(BranchBody {
            mode: job.mode.clone(),
            pattern: job.pattern,
            travel: job.travel,
            settings: job.settings.clone(),
        })
    }
}

/// The machine-readable name of a stop reason (the text is `StopReason`'s `Display`).
fn stop_kind(stop: &StopReason) -> &'static str {
    match stop {
        StopReason::EnergyMax => "energy-max",
        StopReason::FrequencyShiftMax => "frequency-shift-max",
        StopReason::MaxPoints => "max-points",
        StopReason::Interrupted => "interrupted",
        StopReason::StepTooSmall(_) => "step-too-small",
    }
}

/// Hands every point to the Python callback and checks for Ctrl-C between points and between
/// the evaluations within one (a large model's point can take seconds). A Python error (the
/// `KeyboardInterrupt` of a Ctrl-C, or the callback's own) is kept and stops the branch at the
/// next point; the caller raises it.
///
/// Python runs signal handlers on its main thread only, so a branch computed on another thread
/// (a thread pool, a Dask worker) never takes the GIL to check for them: each acquisition
/// would wait for the thread holding it (up to the 5 ms switch interval), once per evaluation.
struct PyObserver<'a> {
    callback: Option<&'a Py<PyAny>>,
    /// Whether the branch runs on Python's main thread (where Ctrl-C can be checked).
    main_thread: bool,
    error: Option<PyErr>,
    /// The callback returned `False`.
    stopped: bool,
}

impl Observer for &mut PyObserver<'_> {
    fn point(&mut self, p: &BranchPoint) -> ControlFlow<()> {
        if self.error.is_some() {
            return ControlFlow::Break(());
        }
        if self.callback.is_none() && !self.main_thread {
            return ControlFlow::Continue(());
        }
        Python::attach(|py| {
            if let Err(e) = py.check_signals() {
                self.error = Some(e);
                return ControlFlow::Break(());
            }
            let Some(callback) = self.callback else {
                return ControlFlow::Continue(());
            };
            match callback.call1(py, (p.index, p.energy, p.frequency, p.floquet.stable)) {
                Err(e) => {
                    self.error = Some(e);
                    ControlFlow::Break(())
                }
                Ok(answer)
                    if answer.bind(py).is_instance_of::<PyBool>()
                        && !answer.extract::<bool>(py).unwrap_or(true) =>
                {
                    self.stopped = true;
                    ControlFlow::Break(())
                }
                Ok(_) => ControlFlow::Continue(()),
            }
        })
    }

    fn event(&mut self, _event: &Event) -> ControlFlow<()> {
        if self.error.is_some() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }

    fn evaluation(&mut self, _progress: &EvaluationProgress) {
        if self.error.is_none() && self.main_thread {
            Python::attach(|py| {
                if let Err(e) = py.check_signals() {
                    self.error = Some(e);
                }
            });
        }
    }
}

/// The branch's points as columns (numpy arrays), its events, stop reason and counters, into
/// `out`. Multipliers are a `points × m` complex array (NaN where a point has fewer); peak
/// displacements `points × output_dofs`; the regime's partner columns NaN (strings empty)
/// where a point has no partner.
fn branch_dict<'py>(
    py: Python<'py>,
    branch: &Branch,
    output_dofs: usize,
    out: &Bound<'py, PyDict>,
) -> PyResult<()> {
    let points = &branch.points;
    type Column = (&'static str, fn(&BranchPoint) -> f64);
    let columns: [Column; 9] = [
        ("energy", |p| p.energy),
        ("frequency", |p| p.frequency),
        ("period", |p| p.period),
        ("energy_slope", |p| p.energy_slope),
        ("max_floquet_modulus", |p| p.floquet.max_modulus),
        ("relative_residual", |p| p.relative_residual),
        ("full_period_residual", |p| p.full_period_residual),
        ("reciprocity_defect", |p| p.floquet.reciprocity_defect),
        ("step", |p| p.step),
    ];
    for (name, value) in columns {
        let values: Vec<f64> = points.iter().map(value).collect();
        out.set_item(name, values.into_pyarray(py))?;
    }
    type Count = (&'static str, fn(&BranchPoint) -> usize);
    let counts: [Count; 3] = [
        ("index", |p| p.index),
        ("iterations", |p| p.iterations),
        ("unstable_pairs", |p| p.floquet.unstable_pairs),
    ];
    for (name, value) in counts {
        let values: Vec<i64> = points.iter().map(|p| value(p) as i64).collect();
        out.set_item(name, values.into_pyarray(py))?;
    }
    let stable: Vec<bool> = points.iter().map(|p| p.floquet.stable).collect();
    out.set_item("stable", stable.into_pyarray(py))?;
    let labels: Vec<&str> = points
        .iter()
        .map(|p| p.label.map_or("", |l| l.name()))
        .collect();
    out.set_item("label", labels)?;
    let peaks = Array2::from_shape_fn((points.len(), output_dofs), |(k, d)| {
        points[k]
            .peak_displacements
            .get(d)
            .copied()
            .unwrap_or(f64::NAN)
    });
    out.set_item("peak_displacement", peaks.into_pyarray(py))?;
    let regimes: Vec<&str> = points
        .iter()
        .map(|p| p.regime.map_or("", |r| r.kind.name()))
        .collect();
    out.set_item("regime", regimes)?;
    type Partner = (&'static str, fn(&ModalComponent) -> f64);
    let partner_columns: [Partner; 3] = [
        ("partner_mode", |c| c.mode as f64),
        ("partner_harmonic", |c| c.harmonic as f64),
        ("partner_share", |c| c.share),
    ];
    for (name, value) in partner_columns {
        let values: Vec<f64> = points
            .iter()
            .map(|p| {
                p.regime
                    .and_then(|r| r.partner)
                    .map_or(f64::NAN, |c| value(&c))
            })
            .collect();
        out.set_item(name, values.into_pyarray(py))?;
    }
    let ratios: Vec<String> = points
        .iter()
        .map(|p| {
            p.regime
                .and_then(|r| r.ratio)
                .map_or(String::new(), |(m, n)| format!("{m}:{n}"))
        })
        .collect();
    out.set_item("ratio", ratios)?;
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

/// The native module. Its contents are private to the package (`nnm/__init__.py` wraps them).
#[pymodule]
fn _nnm(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<NativeModel>()?;
    m.add_class::<NativeBranch>()?;
    m.add("SETTINGS_KEYS", nnm::Settings::KEYS.to_vec())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A panic inside the library reaches Python as a `RuntimeError` with its message, not as
    /// pyo3's `PanicException` (a `BaseException`, which `except Exception` would not catch).
    #[test]
    fn a_panic_becomes_a_runtime_error() {
        Python::initialize();
        let error = no_panic::<()>(|| panic!("index out of bounds")).unwrap_err();
        Python::attach(|py| {
            assert!(error.is_instance_of::<PyRuntimeError>(py));
            assert_eq!(
                error.value(py).to_string(),
                "internal error (please report): index out of bounds"
            );
        });
        assert_eq!(no_panic(|| Ok(7)).unwrap(), 7);
    }
}
