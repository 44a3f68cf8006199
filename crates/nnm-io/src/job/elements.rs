//! The nonlinear elements of a general model (`[[model.nonlinear]]`): springs, and
//! polynomial tensors from term files (docs/method.md eqs. (57)-(59)).

use std::path::Path;

use nnm::model::{FixedDofs, NonlinearElement, PolynomialSpring, PolynomialTensor, TensorError};

use super::JobError;
use super::schema::ElementSpec;
use crate::tensor_file::read_terms;

/// A nonlinear element of a general model, in the input's full numbering (before any
/// `fixed_dofs` are removed): what [`general_model`] takes.
#[derive(Debug)]
pub enum Element {
    /// A `cubic` or `polynomial` spring ([`spring`]).
    Spring(PolynomialSpring),
    /// Polynomial force terms (`tensor`).
    Tensor(PolynomialTensor),
}

impl Element {
    pub(super) fn dofs_used(&self) -> Vec<usize> {
        match self {
            Element::Spring(s) => s.dofs_used(),
            Element::Tensor(t) => t.dofs_used(),
        }
    }

    pub(super) fn boxed(self) -> Box<dyn NonlinearElement> {
        match self {
            Element::Spring(s) => Box::new(s),
            Element::Tensor(t) => Box::new(t),
        }
    }

    /// The element on the model without the fixed dofs (docs/method.md eq. (61)); `None`
    /// when nothing of it is left.
    pub(super) fn reduced(&self, fixed: &FixedDofs) -> Option<Box<dyn NonlinearElement>> {
        match self {
            Element::Spring(s) => s
                .reduced(fixed)
                .map(|s| Box::new(s) as Box<dyn NonlinearElement>),
            Element::Tensor(t) => Some(Box::new(t.reduced(fixed))),
        }
    }
}

/// Builds one `[[model.nonlinear]]` element for a model of `n` dofs. The outer error is a
/// tensor file's (it names that file); the inner one a message about the element itself.
pub(super) fn build_element(
    spec: &ElementSpec,
    n: usize,
    base: &Path,
) -> Result<Result<Element, String>, JobError> {
    if spec.kind == "tensor" {
        return build_tensor(spec, n, base);
    }
    if spec.quadratic.is_some() || spec.cubic.is_some() {
        return Ok(Err(format!(
            "`quadratic` and `cubic` files belong to a \"tensor\" element, not a \"{}\" one",
            spec.kind
        )));
    }
    Ok(spring(
        &spec.kind,
        spec.dofs.as_deref(),
        spec.coefficient,
        spec.exponent.map(i64::from),
    )
    .map(Element::Spring))
}

/// A spring element of type `kind` (`"cubic"` or `"polynomial"`) from its keys as a job file
/// gives them (each may be missing), checked with the job file's messages.
pub fn spring(
    kind: &str,
    dofs: Option<&[usize]>,
    coefficient: Option<f64>,
    exponent: Option<i64>,
) -> Result<PolynomialSpring, String> {
    let exponent = match (kind, exponent) {
        ("cubic", None | Some(3)) => 3,
        ("cubic", Some(p)) => return Err(format!("a cubic element has exponent 3, not {p}")),
        ("polynomial", Some(p)) if (2..=31).contains(&p) => p as u32,
        ("polynomial", Some(p)) => return Err(format!("exponent must be 2 to 31, got {p}")),
        ("polynomial", None) => return Err("a polynomial element needs `exponent`".into()),
        (other, _) => {
            return Err(format!(
                "unknown type `{other}` (expected \"cubic\", \"polynomial\" or \"tensor\")"
            ));
        }
    };
    let coefficient = coefficient.ok_or_else(|| format!("a {kind} element needs `coefficient`"))?;
    if !coefficient.is_finite() {
        return Err(format!(
            "coefficient must be finite, got {}",
            nnm::number::Number(coefficient)
        ));
    }
    let dofs = dofs.ok_or_else(|| format!("a {kind} element needs `dofs`"))?;
    let (i, j) = match dofs {
        [i] => (*i, None),
        [i, j] if i != j => (*i, Some(*j)),
        [_, _] => return Err("`dofs` must name two different dofs".into()),
        _ => return Err("`dofs` must be [i] (to ground) or [i, j]".into()),
    };
    Ok(PolynomialSpring::new(i, j, coefficient, exponent))
}

/// `type = "tensor"`: the terms of its `quadratic` and `cubic` files (1-based, relative to
/// the job file), refused unless they are a gradient (docs/method.md eq. (59)).
fn build_tensor(
    spec: &ElementSpec,
    n: usize,
    base: &Path,
) -> Result<Result<Element, String>, JobError> {
    let spring_keys = [
        ("dofs", spec.dofs.is_some()),
        ("coefficient", spec.coefficient.is_some()),
        ("exponent", spec.exponent.is_some()),
    ];
    if let Some((key, _)) = spring_keys.iter().find(|(_, given)| *given) {
        return Ok(Err(format!(
            "`{key}` does not apply to a tensor element (its terms are in its files)"
        )));
    }
    if spec.quadratic.is_none() && spec.cubic.is_none() {
        return Ok(Err(
            "a tensor element needs `quadratic = { file = \"...\" }` and/or `cubic = { file = \"...\" }`"
                .into(),
        ));
    }
    let file_error = |file: &Path, message: String| JobError::Invalid {
        path: file.to_owned(),
        message,
    };
    let quadratic_file = spec.quadratic.as_ref().map(|f| base.join(&f.file));
    let cubic_file = spec.cubic.as_ref().map(|f| base.join(&f.file));
    let quadratic = match &quadratic_file {
        Some(file) => read_terms::<2>(file, n).map_err(|m| file_error(file, m))?,
        None => Vec::new(),
    };
    let cubic = match &cubic_file {
        Some(file) => read_terms::<3>(file, n).map_err(|m| file_error(file, m))?,
        None => Vec::new(),
    };
    let tensor = PolynomialTensor::new(
        n,
        quadratic
            .into_iter()
            .map(|(i, [j, k], c)| (i, j, k, c))
            .collect(),
        cubic
            .into_iter()
            .map(|(i, [j, k, l], c)| (i, j, k, l, c))
            .collect(),
    )
    .map_err(|e| {
        // Name the file of the offending degree; indices as the files write them.
        let file = match &e {
            TensorError::OutOfRange { degree, .. }
            | TensorError::NotFinite { degree, .. }
            | TensorError::NotGradient { degree, .. } => {
                if *degree == "quadratic" {
                    &quadratic_file
                } else {
                    &cubic_file
                }
            }
        };
        file_error(file.as_deref().unwrap_or(base), e.describe(1))
    })?;
    Ok(Ok(Element::Tensor(tensor)))
}
