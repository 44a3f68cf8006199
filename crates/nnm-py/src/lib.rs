//! The native module `nnm._nnm` of the Python package `nnm`.
//!
//! This crate only converts: Python values into the library's models and settings, results
//! into numpy arrays and dicts. Every rule about what a model or a setting may be, and every
//! message about it, is the job file's (`nnm_io::job`), so that a script and a job file are
//! refused for the same reasons with the same one-line messages. The pure-Python layer
//! (`python/nnm`) gives the API its shape: classes, defaults, exceptions, progress bars, plots.
//!
//! - `convert`: Python values into job-file values, matrices and nonlinear elements;
//! - `model`: the native classes `NativeModel` (the model API) and `NativeBranch`;
//! - `observer`: the continuation's points handed to a Python callback, Ctrl-C checked;
//! - `results`: branches and modes as numpy arrays and dicts;
//! - `errors`: library errors and panics as Python exceptions.

mod convert;
mod errors;
mod model;
mod observer;
mod results;

use pyo3::prelude::*;

use model::{NativeBranch, NativeModel};
use pyo3::exceptions::PyValueError;
use pyo3::types::PyDict;

/// The default parameters of a built-in family (`"bladed-disk"`, ...) as the library declares
/// them (`nnm_io::job::family_defaults`), in the order its struct declares them: the Python
/// constructors take their keyword defaults from here instead of restating them.
#[pyfunction]
fn family_defaults<'py>(py: Python<'py>, family: &str) -> PyResult<Bound<'py, PyDict>> {
    let unknown = || PyValueError::new_err(format!("unknown model family `{family}`"));
    let table = nnm_io::job::family_defaults(family).ok_or_else(unknown)?;
    let names = nnm_io::job::family_parameter_names(family).ok_or_else(unknown)?;
    let dict = PyDict::new(py);
    for name in names {
        dict.set_item(name, convert::from_toml(py, &table[*name])?)?;
    }
    Ok(dict)
}

/// The native module. Its contents are private to the package (`nnm/__init__.py` wraps them).
#[pymodule]
fn _nnm(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<NativeModel>()?;
    m.add_class::<NativeBranch>()?;
    m.add_function(wrap_pyfunction!(family_defaults, m)?)?;
    m.add("SETTINGS_KEYS", nnm::Settings::KEYS.to_vec())?;
    m.add("POINT_COLUMNS", results::point_columns())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
