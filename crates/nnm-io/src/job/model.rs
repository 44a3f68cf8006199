//! `[model]`: a built-in family and its parameters, or a general model (matrices,
//! nonlinear elements, fixed dofs, cyclic symmetry). The checks run in the order a reader
//! meets the mistakes: an unknown family, keys that do not apply to it, values of the wrong
//! type, then the model's own checks of the values.

use std::ops::Range;
use std::path::Path;

use nnm::model::{
    CyclicSymmetry, FixedDofs, Layout, Matrix, ModelError, NonlinearElement, Solid, Structure,
};

use super::JobError;
use super::elements::{Element, build_element};
use super::families::{Family, FamilyError, family_keys, parse};
use super::matrices::load_matrix;
use super::schema::{COMMON_KEYS, GENERAL_KEYS, MODEL_KEYS, ModelSpec, from_table};
use crate::gmsh::read_mesh;

/// Why `[model]` was refused before anything was built.
#[derive(Debug)]
pub(super) enum SpecError {
    /// A one-line message (unknown family, a key that does not apply).
    Invalid(String),
    /// A value of the wrong type: serde's message and its place in the file's text.
    Value {
        message: String,
        span: Option<Range<usize>>,
    },
}

/// The family of `spec` with its parameters typed (`None`: a general model), after checking
/// that the family exists and that every key given applies to it. `source` is the text
/// `spec` was read from, for the place of a wrong value.
pub(super) fn typed_family(
    spec: &ModelSpec,
    source: Option<&str>,
) -> Result<Option<Family>, SpecError> {
    let name = spec.family.as_deref().unwrap_or("general");
    let allowed: &[&str] = if name == "general" {
        &GENERAL_KEYS
    } else {
        match family_keys(name) {
            Ok(keys) => keys,
            Err(FamilyError::Unknown(families)) => {
                let families: Vec<String> = families.iter().map(|f| format!("\"{f}\"")).collect();
                return Err(SpecError::Invalid(format!(
                    "unknown model family `{name}` (expected {}, or no family with mass and stiffness)",
                    families.join(", ")
                )));
            }
            Err(e) => return Err(value_error(e)),
        }
    };
    // Keys that only make sense for some families must not be silently ignored.
    if let Some(key) = MODEL_KEYS[1..]
        .iter()
        .find(|k| spec.gives(k) && !allowed.contains(k) && !COMMON_KEYS.contains(k))
    {
        return Err(SpecError::Invalid(format!(
            "[model] key `{key}` does not apply to family `{name}`"
        )));
    }
    if name == "general" {
        return Ok(None);
    }
    parse(name, &spec.parameters, source)
        .map(Some)
        .map_err(value_error)
}

fn value_error(e: FamilyError) -> SpecError {
    match e {
        FamilyError::Value { message, span } => SpecError::Value { message, span },
        other => SpecError::Value {
            message: other.to_string(),
            span: None,
        },
    }
}

/// A model as a job describes it: the structure, the family's name (`"general"` for none),
/// and where its dofs sit in space when the family has a mesh (beams and solids).
#[derive(Debug)]
pub struct BuiltModel {
    /// The structure.
    pub structure: Structure,
    /// The family (`"bladed-disk"`, ..., or `"general"`).
    pub family: String,
    /// The points, cells and dofs a viewer draws (`None`: a family without geometry, or a
    /// general model).
    pub layout: Option<Layout>,
}

/// The model of `spec`, whose family [`typed_family`] gave. Matrix and term files are
/// found relative to `base`; `path` names the job in errors.
pub(super) fn build_model(
    spec: &ModelSpec,
    family: Option<&Family>,
    base: &Path,
    path: &Path,
) -> Result<BuiltModel, JobError> {
    let invalid = |message: String| JobError::Invalid {
        path: path.to_owned(),
        message,
    };
    let model_error = |error: ModelError| JobError::Model {
        path: path.to_owned(),
        error,
    };
    let name = spec.family.clone().unwrap_or_else(|| "general".into());
    if let Some(Family::Solid(solid)) = family
        && let Some(mesh) = &solid.mesh
    {
        let (structure, layout) = solid_on_mesh(spec, solid, &mesh.file, base, path)?;
        return Ok(BuiltModel {
            structure,
            family: name,
            layout: Some(layout),
        });
    }
    if let Some(family) = family {
        return Ok(BuiltModel {
            structure: family.build().map_err(model_error)?,
            family: name,
            layout: family.layout(),
        });
    }
    let mass = spec
        .mass
        .as_ref()
        .ok_or_else(|| invalid("[model] needs `mass` (or a `family`)".into()))?;
    let stiffness = spec
        .stiffness
        .as_ref()
        .ok_or_else(|| invalid("[model] needs `stiffness`".into()))?;
    let mass = load_matrix(mass, "mass", None, base, path)?;
    let n = mass.nrows();
    let stiffness = load_matrix(stiffness, "stiffness", Some(n), base, path)?;
    let mut elements = Vec::with_capacity(spec.nonlinear.len());
    for (k, e) in spec.nonlinear.iter().enumerate() {
        elements.push(
            build_element(e, n, base)?
                .map_err(|m| invalid(format!("nonlinear element {}: {m}", k + 1)))?,
        );
    }
    let cyclic = spec.cyclic.as_ref().map(|c| CyclicSymmetry {
        sectors: c.sectors,
        dofs_per_sector: c.dofs_per_sector,
    });
    let structure = general_model(
        mass,
        stiffness,
        elements,
        spec.fixed_dofs.as_deref(),
        cyclic,
    )
    .map_err(model_error)?;
    Ok(BuiltModel {
        structure,
        family: name,
        layout: None,
    })
}

/// A model from a `[model]` table that names no files (a family and its parameters, or
/// matrices as rows), with the job file's keys, defaults and messages: for front ends that
/// take a model from elsewhere than a job file (the Python bindings' keyword arguments).
/// Messages are those of a job file without the file's name.
pub fn model_from_table(table: toml::Table) -> Result<BuiltModel, String> {
    let spec: ModelSpec =
        from_table(&table).map_err(|e: toml::de::Error| e.message().trim().to_string())?;
    let family = typed_family(&spec, None).map_err(|e| match e {
        SpecError::Invalid(message) => message,
        SpecError::Value { message, .. } => message.trim().to_string(),
    })?;
    build_model(&spec, family.as_ref(), Path::new("."), Path::new("")).map_err(|e| match e {
        JobError::Invalid { message, .. } => message,
        JobError::Model { error, .. } => error.to_string(),
        other => other.to_string(),
    })
}

/// A solid on the Gmsh mesh `file` (relative to `base`): the box's keys refused, `clamped`
/// (the physical groups held) required, before the file is read.
fn solid_on_mesh(
    spec: &ModelSpec,
    solid: &Solid,
    file: &str,
    base: &Path,
    path: &Path,
) -> Result<(Structure, Layout), JobError> {
    let invalid = |message: String| JobError::Invalid {
        path: path.to_owned(),
        message,
    };
    if let Some(key) = ["box", "elements", "element"]
        .iter()
        .find(|k| spec.gives(k))
    {
        return Err(invalid(format!(
            "[model] key `{key}` describes a structured box: it does not apply with `mesh` (the mesh gives the elements)"
        )));
    }
    if !spec.gives("clamped") {
        return Err(invalid(
            "a solid on a mesh needs `clamped`: the physical groups whose nodes are held (`[]` for a free body)".into(),
        ));
    }
    let mesh = read_mesh(&base.join(file)).map_err(|e| invalid(e.to_string()))?;
    solid.model_on_mesh(&mesh).map_err(|error| JobError::Model {
        path: path.to_owned(),
        error,
    })
}

/// A general model from its parts in the input's full numbering: the elements' dofs are
/// checked against the size of `mass`, then `fixed_dofs` (if any) are removed from the
/// matrices and elements (docs/method.md eq. (61)), and the cyclic symmetry (if any) is
/// declared on the reduced model. Shared by job files and the Python bindings, so that both
/// refuse the same models with the same messages.
pub fn general_model(
    mass: Matrix,
    stiffness: Matrix,
    elements: Vec<Element>,
    fixed_dofs: Option<&[usize]>,
    cyclic: Option<CyclicSymmetry>,
) -> Result<Structure, ModelError> {
    let n = mass.nrows();
    for (index, element) in elements.iter().enumerate() {
        // Checked here, in the numbering of the input: a reduction would take an
        // out-of-range dof for a fixed one.
        if let Some(&dof) = element.dofs_used().iter().find(|&&d| d >= n) {
            return Err(ModelError::ElementDofOutOfRange {
                index,
                dof,
                dofs: n,
            });
        }
    }
    let (mass, stiffness, elements) = match fixed_dofs {
        None => (
            mass,
            stiffness,
            elements.into_iter().map(Element::boxed).collect(),
        ),
        Some(fixed) => {
            let fixed = FixedDofs::new(n, fixed)?;
            let elements: Vec<Box<dyn NonlinearElement>> =
                elements.iter().filter_map(|e| e.reduced(&fixed)).collect();
            (
                fixed.reduce_matrix("mass", &mass)?,
                fixed.reduce_matrix("stiffness", &stiffness)?,
                elements,
            )
        }
    };
    let structure = Structure::new(mass, stiffness, elements)?;
    match cyclic {
        Some(cyclic) => structure.with_cyclic_symmetry(cyclic),
        None => Ok(structure),
    }
}
