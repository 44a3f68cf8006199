//! The native module `nnm._nnm` of the Python package `nnm`.
//!
//! This crate only converts: Python values into the library's models and settings, results
//! into numpy arrays and dicts. Every rule about what a model or a setting may be, and every
//! message about it, is the job file's (`nnm_io::job`), so that a script and a job file are
//! refused for the same reasons with the same one-line messages. The pure-Python layer
//! (`python/nnm`) gives the API its shape: classes, defaults, exceptions, progress bars, plots.
//!
//! - `convert`: Python values into job-file values, matrices and nonlinear elements;
//! - `model`: the native classes `NativeModel` (the model API), `NativeDamping` (the damping
//!   kept beside it) and `NativeBranch`, and the built-in families' default parameters
//!   (`family_defaults`);
//! - `forced`: forced, damped responses (the damping built, the force, the curve and a
//!   point's motion);
//! - `observer`: the continuation's points handed to a Python callback, Ctrl-C checked;
//! - `results`: branches and modes as numpy arrays and dicts;
//! - `errors`: library errors and panics as Python exceptions.

mod convert;
mod errors;
mod forced;
mod model;
mod observer;
mod results;

use pyo3::prelude::*;

use model::{NativeBranch, NativeModel, family_defaults};

/// The native module. Its contents are private to the package (`nnm/__init__.py` wraps them).
#[pymodule]
fn _nnm(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<NativeModel>()?;
    m.add_class::<NativeBranch>()?;
    m.add_function(wrap_pyfunction!(family_defaults, m)?)?;
    m.add_class::<model::NativeDamping>()?;
    m.add_function(wrap_pyfunction!(forced::damping, m)?)?;
    m.add_function(wrap_pyfunction!(forced::response, m)?)?;
    m.add_function(wrap_pyfunction!(forced::forced_motion, m)?)?;
    m.add_function(wrap_pyfunction!(forced::force_amplitude, m)?)?;
    m.add(
        "RESPONSE_SETTINGS_KEYS",
        nnm_io::job::RESPONSE_SETTINGS_KEYS.to_vec(),
    )?;
    let response_defaults = toml::Table::try_from(nnm::forced::ResponseSettings::default())
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
    m.add(
        "RESPONSE_DEFAULTS",
        convert::from_toml(m.py(), &toml::Value::Table(response_defaults))?,
    )?;
    m.add("SETTINGS_KEYS", nnm::Settings::KEYS.to_vec())?;
    m.add("FAMILIES", nnm_io::job::family_names().to_vec())?;
    m.add("POINT_COLUMNS", results::point_columns())?;
    m.add("RESPONSE_COLUMNS", results::response_columns())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
