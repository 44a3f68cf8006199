//! Forced responses: `[model] damping` turned into `C`, and a `[[response]]` table into the
//! force shape, the sweeps (one curve per force level), the output dofs and the settings of
//! `nnm::forced::forced_response` — what job files and the Python bindings share, so that
//! both refuse the same input with the same one-line messages before any curve runs.
//!
//! Numbering: dofs and vectors that describe the model as the user gives it — the forced
//! `dofs`, a force `vector` or file, a damping `matrix` or file — are in the model's full
//! numbering (before `fixed_dofs`, like springs' `dofs` and the `mass` and `stiffness` files);
//! `output_dofs` and an engine order's `sector_dof` refer to the model computed, after
//! `fixed_dofs`, as a branch's `output_dofs` do (docs/job-files.md).

use std::path::Path;

use nnm::Settings;
use nnm::analysis::EnergyBalance;
use nnm::forced::damping::Damping;
use nnm::forced::{Force, ResponseSettings, Sweep, check_sweep};
use nnm::model::{
    FixedDofs, ForcedSystem, HarmonicForce, Matrix, MechanicalSystem, ModelError, Structure,
};

use super::matrices::load_matrix;
use super::schema::{DampingSpec, MatrixSpec};
use crate::matrix_market::{MarketMatrix, read_matrix_market};

/// The keys of a `[[response]]` table that are not settings.
pub const RESPONSE_KEYS: [&str; 10] = [
    "name",
    "force",
    "frequency_start",
    "frequency_end",
    "amplitudes",
    "parameter",
    "frequency",
    "amplitude_max",
    "amplitude_start",
    "output_dofs",
];

/// The settings a `[[response]]` table takes: the fields of `nnm::forced::ResponseSettings`
/// as serde reads them, flattened groups included (a test holds the list to the struct).
pub const RESPONSE_SETTINGS_KEYS: [&str; 14] = [
    "tolerance",
    "initial_step",
    "min_step",
    "max_step",
    "max_iterations",
    "target_iterations",
    "max_turn_angle",
    "integrator",
    "integration_factor",
    "events",
    "max_points",
    "half_period",
    "samples",
    "formulation",
];

/// The starting force amplitude of a curve in the force amplitude, relative to
/// `amplitude_max`, when `amplitude_start` is not given: low enough that the response there is
/// all but linear (the first point is the linear one).
pub const AMPLITUDE_START_RATIO: f64 = 1e-3;

/// One `[[response]]` of a job: its curves' common force shape and settings, and each curve's
/// sweep.
#[derive(Debug, Clone)]
pub struct ResponseJob {
    /// Names its files (`<name>.csv`, ...).
    pub name: String,
    /// The body of the table.
    pub body: ResponseBody,
    /// The table as written, without `name`, a force `file` read into its `vector`: what the
    /// Python bindings hand to `nnm.frequency_response` to run the job's response on a model
    /// of their own (a mistuned disk of a sweep).
    pub table: toml::Table,
}

/// What a `[[response]]` table says besides its `name`.
#[derive(Debug, Clone)]
pub struct ResponseBody {
    /// The force shape at unit amplitude, in the computed model's numbering.
    pub force: HarmonicForce,
    /// One sweep per curve: a frequency sweep per force level, or one sweep in the force
    /// amplitude at a fixed frequency.
    pub curves: Vec<Sweep>,
    /// The dofs whose peaks every point records (after `fixed_dofs`): given, or the forced
    /// dofs.
    pub output_dofs: Vec<usize>,
    /// The curve's settings, validated.
    pub settings: ResponseSettings,
}

/// The damping matrix `C` of `structure` (the model computed, after `fixed_dofs`) from
/// `[model] damping`, checked symmetric positive semi-definite (the message names the entry or
/// the eigenvalue). `fixed`: the model's fixed dofs, which a `matrix` or `file` (given in the
/// full numbering) loses; files are found relative to `base`.
pub fn damping_matrix(
    spec: &DampingSpec,
    structure: &Structure,
    fixed: Option<&FixedDofs>,
    base: &Path,
) -> Result<Matrix, String> {
    let full = fixed.map_or(structure.dofs(), FixedDofs::full_dofs);
    match spec {
        DampingSpec::Rayleigh(ab) => checked_damping(
            Damping::Rayleigh(*ab)
                .matrix(structure)
                .map_err(|e| e.to_string())?,
            structure,
        ),
        DampingSpec::Modal(ratios) => checked_damping(
            Damping::Modal(ratios.clone())
                .matrix(structure)
                .map_err(|e| e.to_string())?,
            structure,
        ),
        DampingSpec::Matrix(rows) => given_damping_matrix(
            load_matrix(
                &MatrixSpec::Rows(rows.clone()),
                "damping",
                None,
                base,
                Path::new(""),
            )
            .map_err(|e| match e {
                super::JobError::Invalid { message, .. } => message,
                other => other.to_string(),
            })?,
            structure,
            fixed,
        ),
        DampingSpec::File(file) => given_damping_matrix(
            load_matrix(
                &MatrixSpec::File { file: file.clone() },
                "damping",
                Some(full),
                base,
                Path::new(""),
            )
            .map_err(|e| e.to_string())?,
            structure,
            fixed,
        ),
    }
}

/// A damping matrix given whole (a `matrix` or `file` of `[model] damping`, a matrix from the
/// Python bindings) in the model's full numbering, as `mass` and `stiffness` are: its size
/// checked, the rows and columns of the `fixed` dofs removed, then checked as
/// [`damping_matrix`] checks every `C`.
pub fn given_damping_matrix(
    c: Matrix,
    structure: &Structure,
    fixed: Option<&FixedDofs>,
) -> Result<Matrix, String> {
    let full = fixed.map_or(structure.dofs(), FixedDofs::full_dofs);
    if c.nrows() != full || c.ncols() != full {
        return Err(format!(
            "the damping matrix is {}x{}, the model has {full} dofs{}",
            c.nrows(),
            c.ncols(),
            if fixed.is_some() {
                " (before `fixed_dofs`)"
            } else {
                ""
            }
        ));
    }
    let c = match fixed {
        Some(fixed) => fixed.reduce_matrix("damping", &c).map_err(model_message)?,
        None => c,
    };
    checked_damping(c, structure)
}

/// `C` checked (finite, symmetric, positive semi-definite) where the forced system is made:
/// with a unit force on dof 0 here.
fn checked_damping(c: Matrix, structure: &Structure) -> Result<Matrix, String> {
    let mut unit = vec![0.0; structure.dofs()];
    unit[0] = 1.0;
    ForcedSystem::new(structure, &c, HarmonicForce::cosine(unit)).map_err(model_message)?;
    Ok(c)
}

/// A `[[response]]` table (without `name`) for `structure` damped by `damping` (`None`: the
/// model has no `damping`, which a forced response needs): the force, the curves, the output
/// dofs and the settings, each checked. `fixed`: the model's fixed dofs (the force's dofs and
/// vector are in the full numbering); files are found relative to `base`.
pub fn response_body(
    mut table: toml::Table,
    structure: &Structure,
    damping: Option<&Matrix>,
    fixed: Option<&FixedDofs>,
    base: &Path,
) -> Result<ResponseBody, String> {
    let Some(damping) = damping else {
        return Err(
            "a forced response needs `[model] damping` (e.g. `damping = { rayleigh = [0.01, 0.0] }`; `{ rayleigh = [0.0, 0.0] }` for none)"
                .into(),
        );
    };
    known_keys(
        &table,
        RESPONSE_KEYS[1..].iter().chain(&RESPONSE_SETTINGS_KEYS),
    )?;
    let force = table
        .remove("force")
        .ok_or("missing `force` (e.g. `force = { dofs = [0], amplitude = 1.0 }`)")?;
    let force = force_shape(&force, structure, fixed, base)?;
    ForcedSystem::new(structure, damping, force.shape.clone()).map_err(model_message)?;

    let number = |key: &str, table: &mut toml::Table| -> Result<Option<f64>, String> {
        match table.remove(key) {
            None => Ok(None),
            Some(toml::Value::Float(x)) => Ok(Some(x)),
            Some(toml::Value::Integer(i)) => Ok(Some(i as f64)),
            Some(_) => Err(format!("`{key}` must be a number")),
        }
    };
    let parameter = match table.remove("parameter") {
        None => "frequency".to_string(),
        Some(toml::Value::String(s)) if s == "frequency" || s == "amplitude" => s,
        Some(_) => return Err("`parameter` must be \"frequency\" or \"amplitude\"".into()),
    };
    let curves = if parameter == "frequency" {
        for key in ["frequency", "amplitude_max", "amplitude_start"] {
            if table.contains_key(key) {
                return Err(format!(
                    "`{key}` applies only with `parameter = \"amplitude\"`"
                ));
            }
        }
        let from =
            number("frequency_start", &mut table)?.ok_or("missing `frequency_start` (rad/s)")?;
        let to = number("frequency_end", &mut table)?.ok_or("missing `frequency_end` (rad/s)")?;
        let levels = match table.remove("amplitudes") {
            None => match (force.amplitude, force.vector) {
                (Some(a), _) => vec![a],
                // A vector carries its own size.
                (None, true) => vec![1.0],
                (None, false) => {
                    return Err(
                        "the force needs an `amplitude` (or give the response `amplitudes = [...]`)"
                            .into(),
                    );
                }
            },
            Some(value) => {
                let levels: Vec<f64> = value
                    .try_into()
                    .map_err(|_| "`amplitudes` must be a list of numbers".to_string())?;
                if levels.is_empty() {
                    return Err("`amplitudes` is empty".into());
                }
                levels
            }
        };
        levels
            .into_iter()
            .map(|amplitude| Sweep::Frequency {
                from,
                to,
                amplitude,
            })
            .collect::<Vec<_>>()
    } else {
        for key in ["frequency_start", "frequency_end", "amplitudes"] {
            if table.contains_key(key) {
                return Err(format!(
                    "`{key}` does not apply with `parameter = \"amplitude\"` (give `frequency` and `amplitude_max`)"
                ));
            }
        }
        if force.amplitude.is_some() {
            return Err(
                "the force's `amplitude` does not apply with `parameter = \"amplitude\"` (the curve runs from `amplitude_start` to `amplitude_max`)"
                    .into(),
            );
        }
        let frequency = number("frequency", &mut table)?.ok_or("missing `frequency` (rad/s)")?;
        let to = number("amplitude_max", &mut table)?.ok_or("missing `amplitude_max`")?;
        let from = number("amplitude_start", &mut table)?.unwrap_or(AMPLITUDE_START_RATIO * to);
        vec![Sweep::Amplitude {
            from,
            to,
            frequency,
        }]
    };
    for sweep in &curves {
        check_sweep(sweep).map_err(|e| e.to_string())?;
    }
    let n = structure.dofs();
    let output_dofs = match table.remove("output_dofs") {
        None => (0..n)
            .filter(|&i| force.shape.cosine[i] != 0.0 || force.shape.sine[i] != 0.0)
            .collect(),
        Some(value) => {
            let dofs: Vec<usize> = value.try_into().map_err(|_| {
                "`output_dofs` must be a list of dofs (0-based, after `fixed_dofs`)".to_string()
            })?;
            if let Some(&d) = dofs.iter().find(|&&d| d >= n) {
                return Err(format!(
                    "output_dofs: dof {d} does not exist (the model has {n} dofs, numbered from 0)"
                ));
            }
            if let Some(k) = (1..dofs.len()).find(|&k| dofs[..k].contains(&dofs[k])) {
                return Err(format!("output_dofs: dof {} is listed twice", dofs[k]));
            }
            dofs
        }
    };
    // What is left are the settings.
    let settings = response_settings(table)?;
    Ok(ResponseBody {
        force: force.shape,
        curves,
        output_dofs,
        settings,
    })
}

/// The energy balance of a branch's `resonance_force = { ... }` (the forms of a response's
/// `force`, read by [`force_shape`]; an `amplitude` given there is not used, the amplitude
/// being what every point reports) against `damping`, the model's `[model] damping` (`None`:
/// refused, naming the key — the balance weighs the force's work against what damping
/// dissipates).
pub fn energy_balance(
    value: &toml::Value,
    structure: &Structure,
    damping: Option<&Matrix>,
    fixed: Option<&FixedDofs>,
    base: &Path,
) -> Result<EnergyBalance, String> {
    let Some(damping) = damping else {
        return Err(
            "`resonance_force` needs `[model] damping`: the energy balance weighs the force's work against what damping dissipates (e.g. `damping = { modal = [0.01] }`)"
                .into(),
        );
    };
    let form =
        force_shape(value, structure, fixed, base).map_err(|m| format!("resonance_force: {m}"))?;
    EnergyBalance::new(damping.clone(), form.shape).map_err(|m| format!("resonance_force: {m}"))
}

/// A force as the table gives it.
#[derive(Debug, Clone)]
pub struct ForceForm {
    /// At unit amplitude, in the computed model's numbering (after `fixed_dofs`).
    pub shape: HarmonicForce,
    /// The `amplitude` the table gives, if any.
    pub amplitude: Option<f64>,
    /// A `vector` or `file` force (which carries its own size).
    pub vector: bool,
}

const FORCE_FORMS: &str = "`force` must be { dofs = [..], amplitude = a }, { vector = [...] }, { file = \"f.mtx\" } or { engine_order = k, amplitude = a, sector_dof = j }";

/// The force shape of a `force = { ... }` value (a job file's, or the Python bindings'
/// `nnm.Force` keys) for `structure`, the model computed. `fixed`: the model's fixed dofs;
/// forced `dofs` and a `vector` or `file` are in the full numbering (before `fixed_dofs`, as
/// springs' `dofs` are), so a forced dof that is fixed, or a vector's non-zero entry on one,
/// is refused (a support takes that force); an engine order's `sector_dof` is in the computed
/// model's numbering (module notes). Files are found relative to `base`. One function for
/// both, so that a script and a job file number a forced dof alike and refuse the same
/// forces with the same one-line messages.
pub fn force_shape(
    value: &toml::Value,
    structure: &Structure,
    fixed: Option<&FixedDofs>,
    base: &Path,
) -> Result<ForceForm, String> {
    let table = value.as_table().ok_or(FORCE_FORMS)?;
    let full = fixed.map_or(structure.dofs(), FixedDofs::full_dofs);
    let form = ["dofs", "vector", "file", "engine_order"]
        .into_iter()
        .filter(|k| table.contains_key(*k))
        .collect::<Vec<_>>();
    let form = match form.as_slice() {
        [one] => *one,
        [] => return Err(FORCE_FORMS.into()),
        [a, b, ..] => {
            return Err(format!(
                "the force gives both `{a}` and `{b}`: {FORCE_FORMS}"
            ));
        }
    };
    let allowed: &[&str] = match form {
        "dofs" => &["dofs", "amplitude"],
        "engine_order" => &["engine_order", "amplitude", "sector_dof"],
        "vector" => &["vector"],
        _ => &["file"],
    };
    if let Some(key) = table.keys().find(|k| !allowed.contains(&k.as_str())) {
        let known = [
            "dofs",
            "amplitude",
            "vector",
            "file",
            "engine_order",
            "sector_dof",
        ];
        return Err(if known.contains(&key.as_str()) {
            format!("the force's `{key}` does not apply to a `{form}` force: {FORCE_FORMS}")
        } else {
            format!("the force has an unknown key `{key}`: {FORCE_FORMS}")
        });
    }
    let amplitude = match table.get("amplitude") {
        None => None,
        Some(toml::Value::Float(x)) => Some(*x),
        Some(toml::Value::Integer(i)) => Some(*i as f64),
        Some(_) => return Err("the force's `amplitude` must be a number".into()),
    };
    let index_list = |key: &str| -> Result<Vec<usize>, String> {
        table[key]
            .clone()
            .try_into()
            .map_err(|_| format!("the force's `{key}` must be a list of dofs (0-based)"))
    };
    let index = |key: &str| -> Result<usize, String> {
        match table.get(key) {
            Some(toml::Value::Integer(i)) if *i >= 0 => Ok(*i as usize),
            Some(_) => Err(format!(
                "the force's `{key}` must be a non-negative integer"
            )),
            None => Err(format!("the force needs `{key}`: {FORCE_FORMS}")),
        }
    };
    let shape = |force: Force| force.shape(structure).map_err(|e| e.to_string());
    match form {
        "dofs" => {
            let mut reduced = Vec::new();
            for d in index_list("dofs")? {
                if d >= full {
                    return Err(format!(
                        "forced dof {d} is out of range (the model has {full} dofs)"
                    ));
                }
                match fixed {
                    None => reduced.push(d),
                    Some(fixed) => reduced.push(fixed.reduced_index(d).ok_or_else(|| {
                        format!("forced dof {d} is fixed (`fixed_dofs`): a support takes the force")
                    })?),
                }
            }
            Ok(ForceForm {
                shape: shape(Force::Dofs {
                    dofs: reduced,
                    amplitude: 1.0,
                })?,
                amplitude,
                vector: false,
            })
        }
        "engine_order" => Ok(ForceForm {
            shape: shape(Force::EngineOrder {
                engine_order: index("engine_order")?,
                amplitude: 1.0,
                sector_dof: index("sector_dof")?,
            })?,
            amplitude,
            vector: false,
        }),
        _ => {
            let vector: Vec<f64> = if form == "vector" {
                table["vector"]
                    .clone()
                    .try_into()
                    .map_err(|_| "the force's `vector` must be a list of numbers".to_string())?
            } else {
                let file = table["file"]
                    .as_str()
                    .ok_or("the force's `file` must be a file name")?;
                read_vector(&base.join(file))?
            };
            if vector.len() != full {
                return Err(format!(
                    "the force vector has {} entries, the model {full} dofs{}",
                    vector.len(),
                    if fixed.is_some() {
                        " (before `fixed_dofs`)"
                    } else {
                        ""
                    }
                ));
            }
            let vector = match fixed {
                None => vector,
                Some(fixed) => {
                    if let Some(d) =
                        (0..full).find(|&d| fixed.reduced_index(d).is_none() && vector[d] != 0.0)
                    {
                        return Err(format!(
                            "the force vector has {} at dof {d}, which is fixed (`fixed_dofs`): a support takes the force",
                            vector[d]
                        ));
                    }
                    fixed.free_dofs().iter().map(|&d| vector[d]).collect()
                }
            };
            Ok(ForceForm {
                shape: shape(Force::Vector { vector })?,
                amplitude: None,
                vector: true,
            })
        }
    }
}

/// A force vector from a Matrix Market file: `n × 1`, array or coordinate (entries listed
/// more than once are summed, as in an assembly).
pub(super) fn read_vector(file: &Path) -> Result<Vec<f64>, String> {
    let m = read_matrix_market(file).map_err(|e| e.to_string())?;
    if m.cols() != 1 {
        return Err(format!(
            "{}: the force is {}x{}, not a vector (n x 1)",
            file.display(),
            m.rows(),
            m.cols()
        ));
    }
    Ok(match m {
        MarketMatrix::Array { data, .. } => data,
        MarketMatrix::Coordinate { rows, entries, .. } => {
            let mut v = vec![0.0; rows];
            for (i, _, x) in entries {
                v[i] += x;
            }
            v
        }
    })
}

/// A response's settings from their keys ([`RESPONSE_SETTINGS_KEYS`]; the job file's
/// `[[response]]` keys that are settings, the Python bindings' keyword arguments), merged over
/// the response's own defaults and checked as a branch's are (the same ranges and messages).
/// An unknown key is refused with the list of the known ones.
pub fn response_settings(table: toml::Table) -> Result<ResponseSettings, String> {
    known_keys(&table, RESPONSE_SETTINGS_KEYS.iter())?;
    // Over a response's own defaults: deserialized alone, the flattened continuation settings
    // would take a branch's (whose steps are relative to a modal amplitude, not absolute).
    let mut merged =
        toml::Table::try_from(ResponseSettings::default()).expect("settings are a table");
    merged.extend(table);
    let settings: ResponseSettings = toml::Value::Table(merged)
        .try_into()
        .map_err(|e: toml::de::Error| e.message().trim().to_string())?;
    check_settings(&settings)?;
    Ok(settings)
}

/// Refuses the first key of `table` that is not one of `known`, listing them (as serde words
/// an unknown field).
fn known_keys<'a>(
    table: &toml::Table,
    known: impl Iterator<Item = &'a &'static str> + Clone,
) -> Result<(), String> {
    match table
        .keys()
        .find(|k| !known.clone().any(|known| known == k))
    {
        None => Ok(()),
        Some(key) => {
            let expected: Vec<String> = known.map(|k| format!("`{k}`")).collect();
            Err(format!(
                "unknown field `{key}`, expected one of {}",
                expected.join(", ")
            ))
        }
    }
}

/// The settings checked as a branch's are (the same ranges and messages).
fn check_settings(settings: &ResponseSettings) -> Result<(), String> {
    let mut branch = Settings {
        continuation: settings.continuation.clone(),
        integration: settings.integration.clone(),
        ..Settings::default()
    };
    branch.limits.max_points = settings.max_points;
    branch.validate().map_err(|e| e.to_string())?;
    if settings.samples < 8 {
        return Err(format!(
            "samples must be at least 8, got {}",
            settings.samples
        ));
    }
    // Every point stores that many states: 10^12 aborted the process on the allocation.
    if settings.samples > MAX_SAMPLES {
        return Err(format!(
            "samples must be at most {MAX_SAMPLES} (each peak is refined between samples), got {}",
            settings.samples
        ));
    }
    Ok(())
}

/// The most samples of a period a response takes: each point keeps them all (`2n` values
/// each), and the peaks are refined between samples, so more only costs memory and time.
pub const MAX_SAMPLES: usize = 100_000;

/// The model's message without the "invalid model parameter: " its display starts with (the
/// caller says where the value was given).
fn model_message(e: ModelError) -> String {
    match e {
        ModelError::InvalidParameter(message) => message,
        other => other.to_string(),
    }
}
