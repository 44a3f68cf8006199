//! Forced, damped responses from Python (`nnm.frequency_response`, `nnm.force_response`):
//! the damping built and the settings read by the job file's own functions
//! (`nnm_io::job::damping_matrix`, `response_settings`) and the force shaped by the job
//! file's own function too (`nnm_io::job::force_shape`: forced dofs and vectors in the
//! model's full numbering, before `fixed_dofs`, as springs' dofs are), so that a script and a
//! job file accept the same forms, number them alike and refuse them with the same messages;
//! the curve computed by `nnm::forced::forced_response` without the GIL, Ctrl-C checked
//! between points; the points handed back as numpy columns.

use std::ops::ControlFlow;
use std::path::Path;

use nnm::forced::{
    Force, ResponseCurve, ResponseError, ResponseItem, ResponseStop, Sweep, forced_response,
};
use nnm::integrate::forced::{Drive, ForcedIntegrator, ForcedRungeKutta};
use nnm::integrate::{DOP853, Tolerances};
use nnm::model::{ForcedSystem, HarmonicForce, Matrix, SparseMatrix};
use nnm::{Item, MechanicalSystem, Structure};
use nnm_io::job::{
    DampingSpec, damping_matrix, force_shape, given_damping_matrix, response_settings,
};
use nnm_io::output::ResponseContext;
use numpy::ndarray::Array2;
use numpy::{Complex64, IntoPyArray, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyComplex, PyDict, PyList};

use crate::convert::{matrix_from_py, table_from_dict};
use crate::errors::{no_panic, numerical_error, value_error};
use crate::model::{NativeDamping, NativeModel};
use crate::results::response_columns_into;

/// `C` of `model` from a Python damping: a dict of one of the job file's `[model] damping`
/// forms (`{"rayleigh": [α, β]}`, `{"modal": [ζ, ...]}`, `{"file": "C.mtx"}`, relative to
/// the working directory), read and built as the job file's (`nnm_io::job::damping_matrix`),
/// or a matrix as `convert::matrix_from_py` takes it, checked as a job file's `matrix`
/// (`nnm_io::job::given_damping_matrix`). Matrices are in the model's full numbering (before
/// `fixed_dofs`). Every refusal is the job file's message, as a `ValueError`.
#[pyfunction]
pub fn damping(
    py: Python<'_>,
    model: PyRef<'_, NativeModel>,
    spec: &Bound<'_, PyAny>,
) -> PyResult<NativeDamping> {
    let form = if let Ok(dict) = spec.cast::<PyDict>() {
        let value = toml::Value::Table(table_from_dict(dict)?);
        Ok(value
            .try_into::<DampingSpec>()
            .map_err(|e| PyValueError::new_err(format!("damping: {}", e.message())))?)
    } else {
        Err(matrix_from_py("damping", spec)?)
    };
    let (structure, fixed) = (&model.structure, model.fixed.as_ref());
    let matrix = py.detach(|| {
        no_panic(|| {
            match form {
                Ok(spec) => damping_matrix(&spec, structure, fixed, Path::new("")),
                Err(matrix) => given_damping_matrix(matrix, structure, fixed),
            }
            .map_err(PyValueError::new_err)
        })
    })?;
    Ok(NativeDamping { matrix })
}

/// The force of a Python dict (the job file's `force = { ... }` keys) as the core reads it,
/// without a model: for the Python `Force`'s own checks ([`force_amplitude`]).
fn force_from(dict: &Bound<'_, PyDict>) -> PyResult<Force> {
    toml::Value::Table(table_from_dict(dict)?)
        .try_into::<Force>()
        .map_err(|e| PyValueError::new_err(format!("force: {}", e.message())))
}

/// The force shape at unit amplitude of a Python dict (the job file's `force = { ... }`
/// keys) on `model`, by the job file's rule (`nnm_io::job::force_shape`): forced dofs and a
/// vector in the full numbering (before `fixed_dofs`), the shape in the computed model's; a
/// forced dof that is fixed refused with the job file's message, as a `ValueError`.
fn force_of(model: &NativeModel, force: &Bound<'_, PyDict>) -> PyResult<HarmonicForce> {
    let value = toml::Value::Table(table_from_dict(force)?);
    force_shape(
        &value,
        &model.structure,
        model.fixed.as_ref(),
        Path::new(""),
    )
    .map(|form| form.shape)
    .map_err(PyValueError::new_err)
}

/// `model` with `damping` (none: `C = 0`) driven by `shape` at unit amplitude.
fn forced_system<'a>(
    structure: &'a Structure,
    damping: Option<&NativeDamping>,
    shape: HarmonicForce,
) -> PyResult<ForcedSystem<'a, Structure>> {
    let n = structure.dofs();
    let zero;
    let c = match damping {
        Some(d) => &d.matrix,
        None => {
            zero = Matrix::Sparse(SparseMatrix::from_triplets(n, &[]).map_err(value_error)?);
            &zero
        }
    };
    ForcedSystem::new(structure, c, shape).map_err(value_error)
}

/// Hands each point to the Python callback `(index, frequency, force_amplitude, stable)` and
/// checks for Ctrl-C between points (on Python's main thread only, as `observer::PyObserver`).
struct ResponseObserver<'a> {
    callback: Option<&'a Py<PyAny>>,
    main_thread: bool,
    error: Option<PyErr>,
    stopped: bool,
}

impl ResponseObserver<'_> {
    fn see(&mut self, item: &ResponseItem) -> ControlFlow<()> {
        if self.error.is_some() {
            return ControlFlow::Break(());
        }
        let Item::Point(p) = item else {
            return ControlFlow::Continue(());
        };
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
            match callback.call1(py, (p.index, p.frequency, p.force_amplitude, p.stable)) {
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
}

/// One curve: `sweep` is `("frequency", Ω0, Ω1, a)` or `("amplitude", a0, a1, Ω)`; `force`
/// the job file's force keys, `settings` a response's keys, `curve` the curve's place among
/// the force levels (the CSV's `curve` column). Returns a dict of numpy columns (see
/// `curve_dict`); a first point that does not converge is data (`error`), bad input a
/// `ValueError`, Ctrl-C or the callback's exception raised with the points so far on
/// `partial`.
#[pyfunction]
#[pyo3(signature = (model, damping, force, sweep, output_dofs, settings, curve=0, callback=None))]
#[allow(clippy::too_many_arguments)]
pub fn response<'py>(
    py: Python<'py>,
    model: PyRef<'py, NativeModel>,
    damping: Option<PyRef<'py, NativeDamping>>,
    force: &Bound<'py, PyDict>,
    sweep: (String, f64, f64, f64),
    output_dofs: Option<Vec<usize>>,
    settings: &Bound<'py, PyDict>,
    curve: usize,
    callback: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let shape = force_of(&model, force)?;
    let settings = response_settings(table_from_dict(settings)?).map_err(PyValueError::new_err)?;
    let index = curve;
    let sweep = match sweep.0.as_str() {
        "frequency" => Sweep::Frequency {
            from: sweep.1,
            to: sweep.2,
            amplitude: sweep.3,
        },
        "amplitude" => Sweep::Amplitude {
            from: sweep.1,
            to: sweep.2,
            frequency: sweep.3,
        },
        other => return Err(PyValueError::new_err(format!("unknown sweep `{other}`"))),
    };
    let structure = &model.structure;
    let system = forced_system(structure, damping.as_deref(), shape)?;
    let output_dofs = output_dofs.unwrap_or_default();
    let threading = py.import("threading")?;
    let main_thread = threading
        .call_method0("current_thread")?
        .is(&threading.call_method0("main_thread")?);
    let mut observer = ResponseObserver {
        callback: callback.as_ref(),
        main_thread,
        error: None,
        stopped: false,
    };
    let clock = std::time::Instant::now();
    let result = py.detach(|| {
        no_panic(|| {
            Ok(forced_response(
                &system,
                sweep,
                &output_dofs,
                &settings,
                |item| observer.see(item),
            ))
        })
    })?;
    let wall_time = clock.elapsed().as_secs_f64();
    let out = PyDict::new(py);
    out.set_item("wall_time", wall_time)?;
    out.set_item("dofs", structure.dofs())?;
    match result {
        Ok(curve) => {
            curve_dict(py, index, &curve, &out)?;
            let kind = match &curve.stop {
                ResponseStop::Stopped if observer.stopped => "callback",
                ResponseStop::Stopped => "interrupted",
                ResponseStop::End => "end",
                ResponseStop::Start => "start",
                ResponseStop::MaxPoints => "max-points",
                ResponseStop::Failed(_) => "failed",
                ResponseStop::Closed(_) => "closed",
            };
            out.set_item("stop_kind", kind)?;
            // The words are the files' (`stop_name`), but for the two a Python caller is
            // told more about: the point limit's value and a stop asked by its callback.
            let stop = match &curve.stop {
                ResponseStop::MaxPoints => format!("max_points ({}) reached", settings.max_points),
                ResponseStop::Stopped if observer.stopped => "stopped by the callback".into(),
                other => nnm_io::output::stop_name(other),
            };
            let error = match &curve.stop {
                ResponseStop::Failed(m) => Some(m.clone()),
                _ => None,
            };
            out.set_item("stop", stop)?;
            out.set_item("error", error)?;
        }
        Err(ResponseError::Invalid(m)) => return Err(PyValueError::new_err(m)),
        Err(e @ ResponseError::Continuation(_)) => {
            let empty = ResponseCurve {
                points: Vec::new(),
                events: Vec::new(),
                stop: ResponseStop::Failed(e.to_string()),
                integrator: "",
                // The forced dofs in the computed model's numbering, as the curve (and a job
                // file's `output_dofs`) would have them.
                output_dofs: if output_dofs.is_empty() {
                    let force = system.force();
                    (0..structure.dofs())
                        .filter(|&i| force.cosine[i] != 0.0 || force.sine[i] != 0.0)
                        .collect()
                } else {
                    output_dofs.clone()
                },
                phase_dof: 0,
                half_period: false,
                stats: Default::default(),
                continuation: Default::default(),
            };
            curve_dict(py, index, &empty, &out)?;
            out.set_item("stop_kind", "first-point")?;
            out.set_item("stop", format!("the first point failed: {e}"))?;
            out.set_item("error", format!("the first point failed: {e}"))?;
        }
    }
    if let Some(error) = observer.error {
        error.value(py).setattr("partial", &out)?;
        return Err(error);
    }
    Ok(out)
}

/// Curve `index`'s points as numpy columns (one per declared response column, with the
/// states and the multipliers), its events as dicts, why it ended and its counters.
fn curve_dict<'py>(
    py: Python<'py>,
    index: usize,
    curve: &ResponseCurve,
    out: &Bound<'py, PyDict>,
) -> PyResult<()> {
    let points = &curve.points;
    let context = ResponseContext {
        curve: index,
        output_dofs: &curve.output_dofs,
    };
    response_columns_into(py, points, &context, out)?;
    let m = points.len();
    let n2 = points.first().map_or(0, |p| p.z0.len());
    out.set_item(
        "state0",
        Array2::from_shape_fn((m, n2), |(k, i)| points[k].z0[i]).into_pyarray(py),
    )?;
    let mu = points
        .iter()
        .map(|p| p.multipliers.len())
        .max()
        .unwrap_or(0);
    let multipliers = Array2::from_shape_fn((m, mu), |(k, i)| {
        points[k]
            .multipliers
            .get(i)
            .map_or(Complex64::new(f64::NAN, f64::NAN), |c| {
                Complex64::new(c.0, c.1)
            })
    });
    out.set_item("multipliers", multipliers.into_pyarray(py))?;
    out.set_item("output_dofs", curve.output_dofs.clone())?;
    out.set_item("phase_dof", curve.phase_dof)?;
    out.set_item("integrator", curve.integrator)?;
    let events = PyList::empty(py);
    for e in &curve.events {
        let d = PyDict::new(py);
        d.set_item("kind", e.kind.name())?;
        d.set_item("after_point", e.point.index)?;
        d.set_item("frequency", e.point.frequency)?;
        d.set_item("force_amplitude", e.point.force_amplitude)?;
        d.set_item("peaks", e.point.peaks.clone().into_pyarray(py))?;
        d.set_item("harmonic_amplitude", e.point.harmonic_amplitude)?;
        d.set_item("phase_lag", e.point.phase_lag)?;
        d.set_item(
            "critical_multiplier",
            PyComplex::from_doubles(py, e.critical_multiplier.0, e.critical_multiplier.1),
        )?;
        d.set_item("state0", e.point.z0.clone().into_pyarray(py))?;
        events.append(d)?;
    }
    out.set_item("events", events)?;
    let stats = PyDict::new(py);
    stats.set_item("points", curve.continuation.points)?;
    stats.set_item("newton_iterations", curve.continuation.newton_iterations)?;
    stats.set_item("rejected_steps", curve.continuation.rejected_steps)?;
    stats.set_item("location_steps", curve.continuation.location_steps)?;
    stats.set_item("evaluations", curve.stats.evaluations)?;
    stats.set_item("integrations", curve.stats.integrations)?;
    stats.set_item("integration_steps", curve.stats.integration.steps)?;
    stats.set_item("factorisations", curve.stats.integration.factorisations)?;
    out.set_item("stats", stats)?;
    Ok(())
}

/// The forced motion from `state0` over one forcing period `2π/Ω` at force amplitude
/// `amplitude`, at `samples + 1` equal times (the last closes the orbit), each segment
/// integrated by DOP853 to relative `tolerance`: a `(samples + 1) × 2n` array.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn forced_motion<'py>(
    py: Python<'py>,
    model: PyRef<'py, NativeModel>,
    damping: Option<PyRef<'py, NativeDamping>>,
    force: &Bound<'py, PyDict>,
    state0: PyReadonlyArray1<'py, f64>,
    frequency: f64,
    amplitude: f64,
    samples: usize,
    tolerance: f64,
) -> PyResult<Bound<'py, PyAny>> {
    let shape = force_of(&model, force)?;
    let structure = &model.structure;
    let n = structure.dofs();
    let z0 = state0.as_slice()?.to_vec();
    if z0.len() != 2 * n || !(frequency.is_finite() && frequency > 0.0) || samples == 0 {
        return Err(PyValueError::new_err(format!(
            "motion needs a state of 2 x {n} values, a positive frequency and at least one sample"
        )));
    }
    nnm::settings::check_tolerance(tolerance).map_err(|e| PyValueError::new_err(e.0))?;
    let system = forced_system(structure, damping.as_deref(), shape)?;
    let size = z0[..n].iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let tolerances = Tolerances {
        relative: tolerance,
        absolute: tolerance * if size > 0.0 { size } else { 1.0 },
        velocity_scale: frequency,
    };
    let states = py.detach(|| {
        no_panic(|| {
            let mut integrator = ForcedRungeKutta::new(&system, &DOP853, tolerances);
            let drive = Drive {
                frequency,
                amplitude,
            };
            let span = 2.0 * std::f64::consts::PI / samples as f64;
            let mut states = vec![z0.clone()];
            for k in 0..samples {
                let next = integrator.advance(&states[k], k as f64 * span, span, drive);
                match next {
                    Ok(z) => states.push(z),
                    Err(e) => return Ok(Err(e)),
                }
            }
            Ok(Ok(states))
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

/// A force dict's value as the core reads it, for the Python `Force`'s checks: the force's
/// own amplitude (1 for a vector).
#[pyfunction]
pub fn force_amplitude(force: &Bound<'_, PyDict>) -> PyResult<f64> {
    Ok(force_from(force)?.amplitude())
}
