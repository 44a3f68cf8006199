//! The native model class `nnm._nnm.NativeModel` (built-in families, job files, general
//! models; modes, branches, switches, motions) and the opaque `NativeBranch` a switch starts
//! from. Its methods read their input through `convert`, run the library without the GIL
//! (through `errors::no_panic`), and hand their results to `results`.

use std::path::PathBuf;

use nnm::bifurcation::{Event, SwitchError};
use nnm::model::{CyclicSymmetry, FixedDofs, Layout, Matrix, Structure};
use nnm::modes::{LinearMode, linear_modes};
use nnm::{Branch, MechanicalSystem, Start, StopReason};
use nnm_io::job::{BranchBody, BranchJob, DampingSpec};
use nnm_io::output::columns::BranchContext;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyOSError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::convert::{self, element_from_py, matrix_from_py, table_from_dict};
use crate::errors::{input_error, job_error, no_panic, numerical_error, value_error};
use crate::observer::PyObserver;
use crate::results::{branch_dict, modes_dict, stop_kind, wave_name};

/// A model held by the library, with the branches of the job file it came from (if any).
#[pyclass(frozen, module = "nnm._nnm")]
pub struct NativeModel {
    pub(crate) structure: Structure,
    family: String,
    /// Where the dofs sit in space (beams and solids): what `to_vtk` draws on.
    layout: Option<Layout>,
    /// The `[[branch]]` entries of the job file (empty for other models).
    branches: Vec<BranchJob>,
    /// The `[[response]]` tables of the job file as written (`ResponseJob::table`), by name.
    responses: Vec<(String, toml::Table)>,
    /// The dofs removed from the model given (`fixed_dofs`): a damping matrix is given in the
    /// full numbering, as `mass` and `stiffness` are.
    pub(crate) fixed: Option<FixedDofs>,
    /// The job file's `[model] damping`: as written, and built.
    job_damping: Option<(DampingSpec, Matrix)>,
}

/// A damping matrix `C` built for one model and checked (size, symmetry, semi-definiteness)
/// when the Python model is made (`forced::damping`) or its job file read, kept beside it:
/// the conservative model does not hold it.
#[pyclass(frozen, module = "nnm._nnm")]
pub struct NativeDamping {
    pub(crate) matrix: Matrix,
}

/// What a switch at one of a computed branch's events needs from it: the start it was
/// computed from and its located events (kept in the library's types, opaque to Python).
#[pyclass(frozen, module = "nnm._nnm")]
pub struct NativeBranch {
    start: Start,
    events: Vec<Event>,
}

#[pymethods]
impl NativeModel {
    /// A built-in family from its job-file keys (`family` and its parameters).
    #[staticmethod]
    fn from_table(py: Python<'_>, table: &Bound<'_, PyDict>) -> PyResult<Self> {
        let table = table_from_dict(table)?;
        let built =
            py.detach(|| no_panic(|| nnm_io::job::model_from_table(table).map_err(input_error)))?;
        Ok(Self {
            structure: built.structure,
            family: built.family,
            layout: built.layout,
            branches: Vec::new(),
            responses: Vec::new(),
            fixed: None,
            job_damping: None,
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
            layout: job.layout,
            branches: job.branches,
            responses: job
                .responses
                .into_iter()
                .map(|r| (r.name, r.table))
                .collect(),
            fixed: job.fixed_dofs,
            job_damping: job.damping_spec.zip(job.damping),
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
        // Checked (with the job file's message) as the model is built below.
        let fixed = fixed_dofs
            .as_deref()
            .and_then(|dofs| FixedDofs::new(n, dofs).ok());
        let cyclic = cyclic.map(|(sectors, dofs_per_sector)| CyclicSymmetry {
            sectors,
            dofs_per_sector,
        });
        // Factorising a large mass can take a while: without the GIL.
        let structure = py.detach(|| {
            no_panic(|| {
                nnm_io::job::general_model(mass, stiffness, elements, fixed_dofs.as_deref(), cyclic)
                    .map_err(value_error)
            })
        })?;
        Ok(Self {
            structure,
            family: "general".into(),
            layout: None,
            branches: Vec::new(),
            responses: Vec::new(),
            fixed,
            job_damping: None,
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

    /// The job file's `[model] damping`: its form as the file gives it (a dict) and `C` built
    /// from it, or `None` (no damping, or not a job file's model).
    fn job_damping<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<Option<(Bound<'py, PyAny>, NativeDamping)>> {
        let Some((spec, matrix)) = &self.job_damping else {
            return Ok(None);
        };
        let form = toml::Value::try_from(spec).map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(Some((
            convert::from_toml(py, &form)?,
            NativeDamping {
                matrix: matrix.clone(),
            },
        )))
    }

    /// Whether the model's dofs sit on nodes (beams, solids): what `write_vtk` needs.
    #[getter]
    fn has_layout(&self) -> bool {
        self.layout.is_some()
    }

    /// Writes the frames (`times`, and displacements `x`, frames × n) of a motion as ParaView
    /// files: `path` (`.pvd`) and its folder of `.vtu` frames (`nnm_io::vtk::write_motion`).
    /// An I/O failure is an `OSError`.
    fn write_vtk(
        &self,
        py: Python<'_>,
        path: PathBuf,
        times: Vec<f64>,
        x: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<()> {
        let Some(layout) = &self.layout else {
            return Err(PyValueError::new_err(
                "to_vtk draws on a model's nodes: the beam and solid families have them, this model does not",
            ));
        };
        let x = x.as_array();
        let n = self.structure.dofs();
        if x.ncols() != n || x.nrows() != times.len() {
            return Err(PyValueError::new_err(format!(
                "write_vtk needs one row of {n} displacements per time, got {}x{} for {} times",
                x.nrows(),
                x.ncols(),
                times.len()
            )));
        }
        let frames: Vec<(f64, Vec<f64>)> = times
            .into_iter()
            .zip(x.rows())
            .map(|(t, row)| (t, row.to_vec()))
            .collect();
        py.detach(|| {
            no_panic(|| {
                nnm_io::vtk::write_motion(&path, layout, &frames)
                    .map_err(|e| PyOSError::new_err(e.to_string()))
            })
        })
    }

    /// The names of the job file's responses.
    #[getter]
    fn response_names(&self) -> Vec<String> {
        self.responses
            .iter()
            .map(|(name, _)| name.clone())
            .collect()
    }

    /// The job file's `[[response]]` `name` as written (without `name`; a force `file` read
    /// into its `vector`), for `Model.response` to run through `nnm.frequency_response`; a
    /// `ValueError` naming the job's responses when it has no such one.
    fn job_response<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let (_, table) = self
            .responses
            .iter()
            .find(|(n, _)| n == name)
            .ok_or_else(|| no_such("response", name, self.responses.iter().map(|(n, _)| n)))?;
        convert::from_toml(py, &toml::Value::Table(table.clone()))
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
            Matrix::Sparse(s) => compressed_rows(py, s.pattern(), s.values().to_vec())?,
            Matrix::Dense(_) => {
                let n = m.nrows();
                let a = Array2::from_shape_fn((n, n), |(i, j)| m.get(i, j));
                a.into_pyarray(py).into_any()
            }
        })
    }

    /// The internal force `f_int(x) = K x + f_nl(x)` at the displacement `x` (length `n`,
    /// finite): for checking a model against one's own code.
    fn internal_force<'py>(
        &self,
        py: Python<'py>,
        x: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let x = self.displacement(x)?;
        let mut f = vec![0.0; x.len()];
        self.structure.internal_force(&x, &mut f);
        Ok(f.into_pyarray(py).into_any())
    }

    /// The tangent stiffness `K_t(x) = ∂f_int/∂x` at `x`: `(n, indptr, indices, data)` of
    /// compressed sparse rows on the model's fixed pattern, or a dense 2-D array for a model
    /// without one.
    fn tangent_stiffness<'py>(
        &self,
        py: Python<'py>,
        x: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let x = self.displacement(x)?;
        let n = x.len();
        if let Some(pattern) = self.structure.tangent_pattern() {
            let mut values = vec![0.0; pattern.nonzeros()];
            self.structure.tangent_values(&x, &mut values);
            return compressed_rows(py, pattern, values);
        }
        let mut dense = vec![0.0; n * n];
        nnm::model::dense_tangent(&self.structure, &x, &mut dense, &mut Vec::new());
        // Column-major from the library; numpy's default is row-major.
        let a = Array2::from_shape_fn((n, n), |(i, j)| dense[j * n + i]);
        Ok(a.into_pyarray(py).into_any())
    }

    /// Linear modes in ascending frequency: a dict of `frequency` (rad/s), `shapes` (one
    /// mass-normalised column per mode), `rigid`, `label` (`"n,d"` or `None`) and `pattern`.
    fn modes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let modes = self.linear_modes(py)?;
        let n = self.structure.dofs();
        modes_dict(py, &modes, n)
    }

    /// Follows one branch. `mode` and `settings` take the keys of a job file's `[[branch]]`
    /// (settings merged over nothing: the library's defaults), or `branch` names one of the
    /// job file's. `callback(index, energy, frequency, stable)` is called after every point;
    /// returning `False` stops the branch there. Returns a dict (see `branch_dict`).
    /// `damping`: the Python model's, which a `resonance_force` setting is balanced against
    /// (`nnm_io::job::energy_balance`).
    #[pyo3(signature = (mode, settings, branch=None, callback=None, damping=None))]
    fn backbone<'py>(
        &self,
        py: Python<'py>,
        mode: Option<&Bound<'py, PyAny>>,
        settings: &Bound<'py, PyDict>,
        branch: Option<String>,
        callback: Option<Py<PyAny>>,
        damping: Option<PyRef<'py, NativeDamping>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let mut body = match branch {
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
        if let Some(value) = &body.resonance_force {
            let balance = nnm_io::job::energy_balance(
                value,
                &self.structure,
                damping.as_deref().map(|d| &d.matrix),
                self.fixed.as_ref(),
                std::path::Path::new(""),
            )
            .map_err(PyValueError::new_err)?;
            body.settings.output.energy_balance = Some(std::sync::Arc::new(balance));
        }
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
        if body.resonance_force.is_some() {
            return Err(PyValueError::new_err(
                "resonance_force on a switched branch runs with `nnm run` (a job's `start = { branch, event }`); from Python, give it to nnm.backbone",
            ));
        }
        let count = parent.events.len();
        let located = parent.events.get(event).ok_or_else(|| {
            // The Python layer checks first (Python-style, `-1` the last event): as it words it.
            PyValueError::new_err(format!(
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
    /// closes the orbit), integrated to relative `tolerance` (in the range of a job file's
    /// `tolerance`): a `(samples + 1) × 2n` array. The Python layer bounds `samples` by the
    /// machine's memory before it calls.
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
        nnm::settings::check_tolerance(tolerance).map_err(|e| PyValueError::new_err(e.0))?;
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
    /// A displacement of this model: `n` finite values, or a one-line `ValueError`.
    fn displacement(&self, x: PyReadonlyArray1<'_, f64>) -> PyResult<Vec<f64>> {
        let x = x.as_slice()?.to_vec();
        let n = self.structure.dofs();
        if x.len() != n {
            return Err(PyValueError::new_err(format!(
                "x has {} entries, the model has {n} dofs",
                x.len()
            )));
        }
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            return Err(PyValueError::new_err(format!("x[{i}] is not finite")));
        }
        Ok(x)
    }

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
        let mut observer = PyObserver::new(py, callback.as_ref())?;
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
        let context = BranchContext {
            linear_frequency_rad_s: start.omega,
            output_dofs: &output_dofs,
        };
        let branch = match result {
            Ok(branch) => {
                branch_dict(py, &branch, &context, &out)?;
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
                    integrator: None,
                };
                branch_dict(py, &empty, &context, &out)?;
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
            .ok_or_else(|| no_such("branch", name, self.branches.iter().map(|b| &b.name)))?;
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
            // Resolved when the job was read, against its `[model] damping`.
            settings: job.settings.clone(),
            resonance_force: None,
        })
    }
}

/// `ValueError`: the job has no `what` (`branch`, `response`) `name`, naming those it has.
fn no_such<'a>(what: &str, name: &str, names: impl Iterator<Item = &'a String>) -> PyErr {
    let names: Vec<String> = names.map(|n| format!("`{n}`")).collect();
    let plural = if what.ends_with('h') { "es" } else { "s" };
    PyValueError::new_err(format!(
        "the job has no {what} `{name}` (its {what}{plural}: {})",
        if names.is_empty() {
            "none".into()
        } else {
            names.join(", ")
        }
    ))
}

/// The default parameters of a built-in family (`"bladed-disk"`, ...) as the library declares
/// them (`nnm_io::job::family_defaults`), in the order its struct declares them: the Python
/// constructors take their keyword defaults from here instead of restating them.
#[pyfunction]
pub fn family_defaults<'py>(py: Python<'py>, family: &str) -> PyResult<Bound<'py, PyDict>> {
    let unknown = || PyValueError::new_err(format!("unknown model family `{family}`"));
    let table = nnm_io::job::family_defaults(family).ok_or_else(unknown)?;
    let names = nnm_io::job::family_parameter_names(family).ok_or_else(unknown)?;
    let dict = PyDict::new(py);
    for name in names {
        // A key without a default (a solid's `mesh`) is optional: None.
        match table.get(*name) {
            Some(value) => dict.set_item(name, convert::from_toml(py, value)?)?,
            None => dict.set_item(name, py.None())?,
        }
    }
    Ok(dict)
}

/// `(n, indptr, indices, data)` of a square matrix in compressed sparse rows, `values` on
/// `pattern`: what the Python side turns into a scipy CSR array (`_model._scipy_or_dense`).
fn compressed_rows<'py>(
    py: Python<'py>,
    pattern: &nnm::model::SparsityPattern,
    values: Vec<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    Ok((
        pattern.row_start.len() - 1,
        pattern.row_start.clone().into_pyarray(py),
        pattern.col.clone().into_pyarray(py),
        values.into_pyarray(py),
    )
        .into_pyobject(py)?
        .into_any())
}
