//! Python exceptions for the library's errors.
//!
//! Numerical failures are returned as data (the message and the points computed so far), not
//! raised here: the Python layer raises `nnm.ContinuationError` with the partial branch on it.
//! Bad input raises `ValueError`/`TypeError` at once. A panic of the library is caught and
//! raised as `RuntimeError` ("internal error"), never as pyo3's `PanicException`, which is
//! not an `Exception` and would escape `except Exception`.

use std::panic::AssertUnwindSafe;

use nnm_io::job::JobError;
use pyo3::exceptions::{PyFileNotFoundError, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;

/// `nnm.NumericalError(message)`: a failure on valid input (the class is the Python layer's).
pub fn numerical_error(py: Python<'_>, message: String) -> PyErr {
    match py
        .import("nnm._errors")
        .and_then(|m| m.getattr("NumericalError"))
        .and_then(|class| class.call1((message,)))
    {
        Ok(error) => PyErr::from_value(error),
        Err(e) => e,
    }
}

/// A job-file message about keyword arguments: `TypeError` for a value of the wrong type
/// (serde's "invalid type: ..."), `ValueError` otherwise.
pub fn input_error(message: String) -> PyErr {
    if message.starts_with("invalid type:") {
        PyTypeError::new_err(message)
    } else {
        PyValueError::new_err(message)
    }
}

/// A library error's one-line message as a `ValueError`.
pub fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

pub fn job_error(path: &std::path::Path, e: JobError) -> PyErr {
    match &e {
        JobError::Read { .. } if !path.exists() => PyFileNotFoundError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// Runs `f` and turns a panic of the library into a `RuntimeError`.
pub fn no_panic<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
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
