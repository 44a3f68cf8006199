//! Python values into the library's inputs: keyword arguments into the TOML values of a job
//! file, so that they go through the job file's own parser (same keys, defaults and messages),
//! and the matrices and nonlinear elements of a general model.

use nnm::model::{Matrix, PolynomialTensor, SparseMatrix};
use nnm_io::job::Element;
use numpy::{PyReadonlyArray1, PyReadonlyArray2};
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
            .map_err(|_| {
                PyValueError::new_err(format!("`{key}` = {} is out of range", number(&index)))
            });
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

/// A number a caller gave, for a message: as the Python layer shows it (`nnm._checks.number`,
/// short as `nnm::number::Number`: `10**400` is `1e400`, not its 401 digits), or as `str`
/// gives it where that module cannot be imported (the unit tests, run without the package).
fn number(value: &Bound<'_, PyAny>) -> String {
    value
        .py()
        .import("nnm._checks")
        .and_then(|m| m.getattr("number"))
        .and_then(|number| number.call1((value,)))
        .and_then(|shown| shown.extract::<String>())
        .unwrap_or_else(|_| value.to_string())
}

/// A job-file value as a Python one (integers, floats, booleans, strings, lists, dicts): what
/// the library declares (a family's defaults) handed to the Python layer as plain values.
pub fn from_toml<'py>(py: Python<'py>, value: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        toml::Value::Float(x) => x.into_pyobject(py)?.into_any(),
        toml::Value::Boolean(b) => PyBool::new(py, *b).to_owned().into_any(),
        toml::Value::String(s) => PyString::new(py, s).into_any(),
        toml::Value::Array(items) => PyList::new(
            py,
            items
                .iter()
                .map(|item| from_toml(py, item))
                .collect::<PyResult<Vec<_>>>()?,
        )?
        .into_any(),
        toml::Value::Table(table) => dict_from_table(py, table)?.into_any(),
        toml::Value::Datetime(d) => PyString::new(py, &d.to_string()).into_any(),
    })
}

/// A job-file table as a Python dict.
fn dict_from_table<'py>(py: Python<'py>, table: &toml::Table) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for (key, value) in table {
        dict.set_item(key, from_toml(py, value)?)?;
    }
    Ok(dict)
}

/// One matrix as the Python layer hands it over: a 2-D float64 array, or a sparse matrix's
/// triplets `(rows, cols, row_indices, col_indices, values)` (duplicates are summed).
pub fn matrix_from_py(name: &'static str, value: &Bound<'_, PyAny>) -> PyResult<Matrix> {
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
pub fn dof_index(k: i64) -> usize {
    usize::try_from(k).unwrap_or(usize::MAX)
}

/// One nonlinear element as the Python layer hands it over:
/// `("cubic" | "polynomial", dofs, coefficient, exponent)` or
/// `("tensor", quadratic_subs, quadratic_values, cubic_subs, cubic_values)` (subs `m × 3` and
/// `m × 4`, 0-based). Messages are the job file's for the same element.
pub fn element_from_py(index: usize, n: usize, value: &Bound<'_, PyAny>) -> PyResult<Element> {
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
