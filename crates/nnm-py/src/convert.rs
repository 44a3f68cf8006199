//! Python values into the TOML values of a job file, so that keyword arguments go through
//! the job file's own parser (same keys, defaults and messages).

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyList, PyString, PyTuple};

/// A keyword-argument dict as a job-file table; keys whose value is `None` are left out (the
/// default applies), as if the key were not written.
pub fn table_from_dict(dict: &Bound<'_, PyDict>) -> PyResult<toml::Table> {
    let mut table = toml::Table::new();
    for (key, value) in dict.iter() {
        let key: String = key.extract()?;
        if value.is_none() {
            continue;
        }
        let value = to_toml(&key, &value)?;
        table.insert(key, value);
    }
    Ok(table)
}

/// One value: `bool`, integers (anything with `__index__`, numpy's too), floats (anything
/// with `__float__`), `str`, and lists, tuples and dicts of them.
pub fn to_toml(key: &str, value: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    if value.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(value.extract()?));
    }
    if value.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(value.extract()?));
    }
    if value.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(value.extract()?));
    }
    if value.hasattr("__index__")? {
        let index = value.call_method0("__index__")?;
        return index
            .extract::<i64>()
            .map(toml::Value::Integer)
            .map_err(|_| PyValueError::new_err(format!("`{key}` = {index} is out of range")));
    }
    if value.hasattr("__float__")? {
        return Ok(toml::Value::Float(value.extract()?));
    }
    if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
        return value
            .try_iter()?
            .map(|item| to_toml(key, &item?))
            .collect::<PyResult<Vec<_>>>()
            .map(toml::Value::Array);
    }
    if let Ok(dict) = value.cast::<PyDict>() {
        return table_from_dict(dict).map(toml::Value::Table);
    }
    Err(PyTypeError::new_err(format!(
        "`{key}` must be a number, a string or a boolean, got {}",
        value.get_type().name()?
    )))
}

/// A library error's one-line message as a `ValueError`.
pub fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Keyword arguments reach the job file's parser as the TOML a user would have written:
    /// Python's `True` is a boolean (not the integer 1), integer-like objects (numpy's scalars)
    /// are integers, `None` means "not given".
    #[test]
    fn keyword_values_become_job_file_values() {
        Python::initialize();
        Python::attach(|py| {
            let dict = PyDict::new(py);
            dict.set_item("events", true).unwrap();
            dict.set_item("max_points", 7).unwrap();
            dict.set_item("tolerance", 1e-9).unwrap();
            dict.set_item("phase", "flow-orthogonal").unwrap();
            dict.set_item("energy_start", py.None()).unwrap();
            // An integer that is not an `int`, as numpy's scalars are: it has `__index__`.
            let locals = PyDict::new(py);
            py.run(
                c"class Index:\n    def __index__(self):\n        return 5\nfive = Index()",
                None,
                Some(&locals),
            )
            .unwrap();
            let five = locals.get_item("five").unwrap().unwrap();
            dict.set_item("target_iterations", five).unwrap();
            let table = table_from_dict(&dict).unwrap();
            assert_eq!(table["events"], toml::Value::Boolean(true));
            assert_eq!(table["max_points"], toml::Value::Integer(7));
            assert_eq!(table["tolerance"], toml::Value::Float(1e-9));
            assert_eq!(
                table["phase"],
                toml::Value::String("flow-orthogonal".into())
            );
            assert!(!table.contains_key("energy_start"));
            assert_eq!(table["target_iterations"], toml::Value::Integer(5));
            let settings =
                nnm_io::job::branch_body(table, &toml::Table::new(), true).expect("valid settings");
            assert_eq!(settings.settings.limits.max_points, 7);
            assert!(settings.settings.stability.events);
        });
    }

    /// A value of no job-file type is a `TypeError` naming the key.
    #[test]
    fn other_values_are_type_errors() {
        Python::initialize();
        Python::attach(|py| {
            let dict = PyDict::new(py);
            dict.set_item("tolerance", py.eval(c"object()", None, None).unwrap())
                .unwrap();
            let e = table_from_dict(&dict).unwrap_err();
            assert!(e.is_instance_of::<PyTypeError>(py));
            assert!(e.to_string().contains("`tolerance`"), "{e}");
        });
    }
}
