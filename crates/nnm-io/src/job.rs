//! Job files (TOML, README "Job files"): the model, and the branches to compute.
//!
//! ```toml
//! [model]
//! family = "bladed-disk"          # or "duffing", "two-dof"; omit for a general model
//! sectors = 30
//!
//! [settings]                      # optional defaults for every branch
//! tolerance = 1e-8
//!
//! [[branch]]
//! name = "mode-1-5"
//! mode = "1,5"                    # label "n,d", or 0-based index into the ascending modes
//! energy_max = 10.0
//!
//! [[branch]]                      # switch onto the family through an event of a branch above
//! name = "switched"
//! start = { branch = "mode-1-5", event = 0 }   # row `index` of mode-1-5.events.csv
//! energy_max = 10.0
//! ```
//!
//! A general model (no `family`) takes `mass` and `stiffness` (rows, or Matrix Market files),
//! `fixed_dofs` (0-based, like springs' `dofs`; removed from the model, docs/method.md
//! eq. (61)) and `[[model.nonlinear]]` elements: `cubic`/`polynomial` springs and `tensor`
//! terms from files (1-based, like Matrix Market; eq. (57)).
//!
//! Unknown keys are errors (a typo must not silently fall back to a default), and every error
//! is one line naming the file and, where it can, the line and column.

use std::path::{Path, PathBuf};

use nnm::MechanicalSystem;
use nnm::Settings;
use nnm::model::{
    BladedDisk, CantileverBeam, CyclicSymmetry, FixedDofs, Matrix, ModelError, NonlinearElement,
    PolynomialSpring, PolynomialTensor, Structure, TensorError, VonKarmanBeam, duffing, two_dof,
};
use nnm::modes::{LinearMode, StandingWave, find_mode};
use nnm::shooting::{PhaseCondition, Travel};
use serde::Deserialize;

use crate::error::io_reason;
use crate::matrix_market::{MarketMatrix, MatrixMarketError, read_matrix_market};
use crate::tensor_file::read_terms;

/// Why a job file was rejected.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    #[error("cannot read {path}: {reason}")]
    Read { path: PathBuf, reason: String },
    #[error("{path}:{line}:{column}: {message}")]
    Syntax {
        path: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    // The model's own message says what is wrong ("invalid model parameter: …", "mass matrix
    // is not positive definite"); a second "invalid model:" only stuttered.
    #[error("{path}: {error}")]
    Model { path: PathBuf, error: ModelError },
    // Transparent: with `{0}` and `#[from]` (a source), error chains printed the message twice.
    #[error(transparent)]
    Matrix(#[from] MatrixMarketError),
}

/// A parsed job: the model and the branches asked for.
#[derive(Debug)]
pub struct Job {
    pub structure: Structure,
    /// The model family (`"bladed-disk"`, `"duffing"`, `"two-dof"`, `"cantilever-beam"`,
    /// `"von-karman-beam"`, or `"general"`).
    pub family: String,
    pub branches: Vec<BranchJob>,
    /// The `[settings]` section alone (what a branch gets when it sets nothing itself).
    pub default_settings: Settings,
}

/// One branch to compute.
#[derive(Debug, Clone)]
pub struct BranchJob {
    pub name: String,
    /// Mode label `"n,d"` or index, as written (empty for a branch started from an event).
    pub mode: String,
    /// Start from an event of an earlier branch instead of a linear mode.
    pub from_event: Option<EventStart>,
    pub pattern: Option<StandingWave>,
    /// `pattern = "travelling"` (or `"travelling-backward"`): the travelling wave of the pair.
    pub travel: Option<Travel>,
    /// Every setting of the branch: the `[settings]` section overridden key by key by the
    /// branch's own (the start energy and symmetry restriction are in `settings.start`).
    pub settings: Settings,
}

/// `start = { branch = "NAME", event = K }`: the family through event `K` (0-based, the
/// `index` column of `NAME.events.csv`) of branch `NAME`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EventStart {
    pub branch: String,
    pub event: usize,
    /// Which new null direction to follow at a degenerate event (0-based, default 0).
    #[serde(default)]
    pub direction: usize,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct JobFile {
    model: ModelSpec,
    #[serde(default)]
    settings: Option<toml::Table>,
    #[serde(default)]
    branch: Vec<toml::Table>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelSpec {
    family: Option<String>,
    sectors: Option<usize>,
    disk_mass: Option<f64>,
    blade_mass: Option<f64>,
    disk_coupling: Option<f64>,
    blade_stiffness: Option<f64>,
    cubic: Option<f64>,
    /// `bladed-disk`: relative blade-stiffness deviations, one per sector.
    blade_stiffness_mistuning: Option<Vec<f64>>,
    natural_frequency: Option<f64>,
    elements: Option<usize>,
    length: Option<f64>,
    width: Option<f64>,
    height: Option<f64>,
    thickness: Option<f64>,
    youngs_modulus: Option<f64>,
    density: Option<f64>,
    mass: Option<MatrixSpec>,
    stiffness: Option<MatrixSpec>,
    #[serde(default)]
    nonlinear: Vec<ElementSpec>,
    cyclic: Option<CyclicSpec>,
    /// Dofs held at zero (0-based, like an element's `dofs`), removed from the model.
    fixed_dofs: Option<Vec<usize>>,
}

/// `mass`/`stiffness`: rows, or a file. Untagged, so serde's own message on a mismatch
/// ("did not match any variant of untagged enum") would name a type the user never sees:
/// `expecting` says what forms are accepted instead.
#[derive(Debug, Deserialize)]
#[serde(
    untagged,
    expecting = "expected a matrix as rows of numbers, e.g. [[2.0, -1.0], [-1.0, 2.0]], or as a Matrix Market file, { file = \"K.mtx\" }"
)]
enum MatrixSpec {
    Rows(Vec<Vec<f64>>),
    File { file: String },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ElementSpec {
    #[serde(rename = "type")]
    kind: String,
    /// Springs (`cubic`, `polynomial`): the dofs, 0-based.
    dofs: Option<Vec<usize>>,
    coefficient: Option<f64>,
    exponent: Option<u32>,
    /// `tensor`: the file of quadratic terms `i j k c`, 1-based.
    quadratic: Option<FileSpec>,
    /// `tensor`: the file of cubic terms `i j k l c`, 1-based.
    cubic: Option<FileSpec>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSpec {
    file: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CyclicSpec {
    sectors: usize,
    dofs_per_sector: usize,
}

/// The branch keys that are not settings.
const BRANCH_KEYS: [&str; 4] = ["name", "mode", "pattern", "start"];

/// Settings from a flat table (`[settings]` overridden by a branch's keys): a key that is
/// neither a setting nor a branch key is refused (a typo must not fall back to a default).
fn settings_from(table: toml::Table) -> Result<Settings, String> {
    if let Some(key) = table.keys().find(|k| !Settings::KEYS.contains(&k.as_str())) {
        let mut expected: Vec<&str> = Settings::KEYS.to_vec();
        expected.extend(BRANCH_KEYS);
        return Err(format!(
            "unknown field `{key}`, expected one of {}",
            expected
                .iter()
                .map(|k| format!("`{k}`"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    table
        .try_into()
        .map_err(|e: toml::de::Error| e.message().to_string())
}

/// What a `[[branch]]` table says besides its `name` and `start`.
#[derive(Debug, Clone)]
pub struct BranchBody {
    /// Mode label `"n,d"` or index, as written (empty for a branch started from an event).
    pub mode: String,
    /// The standing wave of a degenerate pair, when given (the cos one for a travelling wave).
    pub pattern: Option<StandingWave>,
    /// The travelling wave of the pair instead of a standing one.
    pub travel: Option<Travel>,
    /// `defaults` overridden key by key by the table's own settings, validated.
    pub settings: Settings,
}

/// The mode, pattern and settings of one branch from its table (without `name` and `start`),
/// its settings merged over `defaults` (a `[settings]` section). Front ends that take a
/// branch from elsewhere than a job file (the Python bindings' keyword arguments) call it so
/// that their keys, defaults and one-line messages are the job file's.
pub fn branch_body(
    mut table: toml::Table,
    defaults: &toml::Table,
    from_event: bool,
) -> Result<BranchBody, String> {
    let (mode, pattern, travel) = branch_mode(&mut table, from_event)?;
    if from_event {
        // A switched branch takes its start, unknowns and period from the switch.
        let ignored = [
            ("pattern", pattern.is_some() || travel.is_some()),
            ("energy_start", table.contains_key("energy_start")),
            ("symmetry", table.contains_key("symmetry")),
            ("half_period", table.contains_key("half_period")),
        ];
        if let Some((key, _)) = ignored.iter().find(|(_, given)| *given) {
            return Err(format!(
                "`{key}` does not apply to a branch that starts from an event"
            ));
        }
    }
    let mut merged = defaults.clone();
    merged.extend(table);
    let has_limit = ["energy_max", "frequency_shift_max", "max_points"]
        .iter()
        .any(|k| merged.contains_key(*k));
    let settings = settings_from(merged)?;
    settings.validate().map_err(|e| e.to_string())?;
    if !has_limit {
        return Err(
            "give a stop limit: `energy_max`, `frequency_shift_max` or `max_points`".into(),
        );
    }
    Ok(BranchBody {
        mode,
        pattern,
        travel,
        settings,
    })
}

const PATTERN_VALUES: &str =
    "`pattern` must be \"cos\", \"sin\", \"travelling\" or \"travelling-backward\"";

/// A branch's `mode` and `pattern`, taken out of its table (see [`branch_body`]); also for
/// front ends that run a job's branch from another mode.
pub fn branch_mode(
    table: &mut toml::Table,
    from_event: bool,
) -> Result<(String, Option<StandingWave>, Option<Travel>), String> {
    let mode = match (table.remove("mode"), from_event) {
        (Some(_), true) => return Err("give either `mode` or `start`, not both".into()),
        (None, true) => String::new(),
        (Some(toml::Value::String(s)), false) => s,
        (Some(toml::Value::Integer(i)), false) if i >= 0 => i.to_string(),
        (Some(_), false) => {
            return Err("`mode` must be a label \"n,d\" or a non-negative index".into());
        }
        (None, false) => {
            return Err("missing `mode` (or `start = { branch = \"NAME\", event = K }`)".into());
        }
    };
    let (pattern, travel) = match table.remove("pattern") {
        None => (None, None),
        Some(toml::Value::String(s)) => match s.as_str() {
            "cos" => (Some(StandingWave::Cos), None),
            "sin" => (Some(StandingWave::Sin), None),
            "travelling" => (None, Some(Travel::Forward)),
            "travelling-backward" => (None, Some(Travel::Backward)),
            _ => return Err(PATTERN_VALUES.into()),
        },
        Some(_) => return Err(PATTERN_VALUES.into()),
    };
    Ok((mode, pattern, travel))
}

/// The index of the starting mode of a branch asked for as `mode` (a label `"n,d"` or an
/// index) and `pattern` among `modes`, refused with a one-line message when there is no such
/// mode, it is a rigid-body mode, or the pattern does not fit it. Shared by the command line
/// (which prefixes the branch's name) and the Python bindings.
pub fn resolve_mode(
    modes: &[LinearMode],
    mode: &str,
    pattern: Option<StandingWave>,
) -> Result<usize, String> {
    let (index, found) = find_mode(modes, mode, pattern).ok_or_else(|| {
        let labels = modes.iter().any(|m| m.cyclic.is_some());
        let hint = if labels {
            "a label \"n,d\" listed by `nnm modes`, or an index"
        } else {
            "an index from 0 to the number of modes - 1 (this model has no (n,d) labels)"
        };
        format!("unknown mode `{mode}` (expected {hint})")
    })?;
    if found.rigid {
        return Err(format!(
            "mode `{mode}` is a rigid-body mode and has no nonlinear normal mode"
        ));
    }
    let wave = found.cyclic.and_then(|c| c.pattern);
    if pattern.is_some() && wave.is_some() && pattern != wave {
        return Err(format!(
            "mode {mode} is the {} wave of its pair, but `pattern` asks for the other",
            if wave == Some(StandingWave::Cos) {
                "cos"
            } else {
                "sin"
            }
        ));
    }
    if pattern.is_some() && wave.is_none() {
        return Err(format!(
            "`pattern` applies only to a degenerate pair, and mode `{mode}` is single"
        ));
    }
    Ok(index)
}

/// The phase condition's name in job files (`phase = "..."`).
pub fn phase_name(phase: PhaseCondition) -> &'static str {
    match phase {
        PhaseCondition::ZeroVelocity => "zero-velocity",
        PhaseCondition::FlowOrthogonal => "flow-orthogonal",
    }
}

/// Offset along the new family's direction at a switch (`start = { branch, event }`),
/// relative to the event's amplitude: what `nnm run` and the Python bindings both use, so
/// that a switched branch is the same from either.
pub const SWITCH_AMPLITUDE: f64 = 0.05;

/// Reads and validates a job file. Matrix files are resolved relative to the job's folder.
pub fn load_job(path: &Path) -> Result<Job, JobError> {
    let text = std::fs::read_to_string(path).map_err(|e| JobError::Read {
        path: path.to_owned(),
        reason: io_reason(&e),
    })?;
    parse_job(&text, path)
}

/// Parses a job from text; `path` names it in errors and anchors relative matrix files.
pub fn parse_job(text: &str, path: &Path) -> Result<Job, JobError> {
    let file: JobFile = toml::from_str(text).map_err(|e| syntax_error(&e, text, path))?;
    job_from_file(file, path)
}

/// Reads a job file with some of its keys replaced: the parameter studies' way of varying a
/// job (`python -m nnm sweep --grid model.cubic=...`, mistuning as
/// `model.blade_stiffness_mistuning`). Each override is a dotted key, `model.KEY`,
/// `settings.KEY` or `branch.NAME.KEY`, and a value of the type the key takes; the job is then
/// validated as if the file said so (messages name the file, without a line).
pub fn load_job_with(path: &Path, overrides: &[(String, toml::Value)]) -> Result<Job, JobError> {
    if overrides.is_empty() {
        return load_job(path);
    }
    let text = std::fs::read_to_string(path).map_err(|e| JobError::Read {
        path: path.to_owned(),
        reason: io_reason(&e),
    })?;
    let original: toml::Table = text.parse().map_err(|e| syntax_error(&e, &text, path))?;
    let invalid = |key: &str, message: String| JobError::Invalid {
        path: path.to_owned(),
        message: format!("override `{key}`: {message}"),
    };
    let mut table = original.clone();
    for (key, value) in overrides {
        override_key(&mut table, key, value.clone()).map_err(|m| invalid(key, m))?;
    }
    let file: JobFile = table.try_into().map_err(|e: toml::de::Error| {
        // serde's message names the type, not the key: find the override that breaks the
        // file on its own (the file itself parsed).
        let message = e.message().trim().to_string();
        let culprit = overrides.iter().find(|(key, value)| {
            let mut alone = original.clone();
            override_key(&mut alone, key, value.clone()).is_ok()
                && alone.try_into::<JobFile>().is_err()
        });
        match culprit {
            Some((key, _)) => invalid(key, message),
            None => JobError::Invalid {
                path: path.to_owned(),
                message,
            },
        }
    })?;
    job_from_file(file, path)
}

/// Sets `key` (see [`load_job_with`]) in a job file's table, creating `[settings]` or the
/// `[model]` key if absent; a branch must exist.
fn override_key(table: &mut toml::Table, key: &str, value: toml::Value) -> Result<(), String> {
    let parts: Vec<&str> = key.split('.').collect();
    let target = match parts.as_slice() {
        ["model" | "settings", _] => {
            let section = table
                .entry(parts[0])
                .or_insert_with(|| toml::Value::Table(toml::Table::new()));
            section
                .as_table_mut()
                .ok_or_else(|| format!("[{}] is not a table", parts[0]))?
        }
        ["branch", name, _] => table
            .get_mut("branch")
            .and_then(|b| b.as_array_mut())
            .and_then(|branches| {
                branches.iter_mut().find_map(|b| {
                    b.as_table_mut()
                        .filter(|t| t.get("name").and_then(|n| n.as_str()) == Some(*name))
                })
            })
            .ok_or_else(|| format!("the job has no branch `{name}`"))?,
        _ => {
            return Err("expected `model.KEY`, `settings.KEY` or `branch.NAME.KEY`".to_string());
        }
    };
    let last = parts[parts.len() - 1];
    if last == "name" || last == "family" {
        return Err(format!("`{last}` cannot be overridden"));
    }
    target.insert(last.to_string(), value);
    Ok(())
}

/// A parsed job file, checked and built.
fn job_from_file(file: JobFile, path: &Path) -> Result<Job, JobError> {
    let invalid = |message: String| JobError::Invalid {
        path: path.to_owned(),
        message,
    };
    let base = path.parent().unwrap_or(Path::new("."));
    let (structure, family) = build_model(&file.model, base, path)?;

    let defaults: toml::Table = file.settings.unwrap_or_default();
    let default_settings =
        settings_from(defaults.clone()).map_err(|m| invalid(format!("[settings]: {m}")))?;
    default_settings
        .validate_for(structure.dofs())
        .map_err(|e| invalid(format!("[settings]: {e}")))?;
    let mut branches = Vec::new();
    for (k, mut table) in file.branch.into_iter().enumerate() {
        let context = |what: &str| format!("branch {}: {what}", k + 1);
        let name = match table.remove("name") {
            Some(toml::Value::String(s)) => s,
            Some(_) => return Err(invalid(context("`name` must be a string"))),
            None => return Err(invalid(context("missing `name`"))),
        };
        let valid_name = name != "modes"
            && !name.is_empty()
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
            && !name.starts_with('.');
        if !valid_name {
            return Err(invalid(context(&format!(
                "name `{name}` must be non-empty, not `modes`, and use only letters, digits, '-', '_', '.'"
            ))));
        }
        if branches.iter().any(|b: &BranchJob| b.name == name) {
            return Err(invalid(format!("duplicate branch name `{name}`")));
        }
        let from_event: Option<EventStart> = match table.remove("start") {
            None => None,
            Some(value) => Some(value.try_into().map_err(|e: toml::de::Error| {
                invalid(context(&format!(
                    "`start` must be {{ branch = \"NAME\", event = K }}: {}",
                    e.message()
                )))
            })?),
        };
        if let Some(start) = &from_event
            && !branches.iter().any(|b: &BranchJob| b.name == start.branch)
        {
            return Err(invalid(context(&format!(
                "`start` refers to branch `{}`, which must be defined above this one",
                start.branch
            ))));
        }
        let BranchBody {
            mode,
            pattern,
            travel,
            settings,
        } = branch_body(table, &defaults, from_event.is_some())
            .map_err(|m| invalid(context(&m)))?;
        settings
            .validate_for(structure.dofs())
            .map_err(|e| invalid(context(&e.to_string())))?;
        branches.push(BranchJob {
            name,
            mode,
            from_event,
            pattern,
            travel,
            settings,
        });
    }
    Ok(Job {
        structure,
        family,
        branches,
        default_settings,
    })
}

fn build_model(
    spec: &ModelSpec,
    base: &Path,
    path: &Path,
) -> Result<(Structure, String), JobError> {
    let invalid = |message: String| JobError::Invalid {
        path: path.to_owned(),
        message,
    };
    let model_error = |error: ModelError| JobError::Model {
        path: path.to_owned(),
        error,
    };
    let family = spec.family.clone().unwrap_or_else(|| "general".into());
    // Keys that only make sense for some families must not be silently ignored.
    let given: Vec<(&str, bool)> = vec![
        ("sectors", spec.sectors.is_some()),
        ("disk_mass", spec.disk_mass.is_some()),
        ("blade_mass", spec.blade_mass.is_some()),
        ("disk_coupling", spec.disk_coupling.is_some()),
        ("blade_stiffness", spec.blade_stiffness.is_some()),
        ("cubic", spec.cubic.is_some()),
        (
            "blade_stiffness_mistuning",
            spec.blade_stiffness_mistuning.is_some(),
        ),
        ("natural_frequency", spec.natural_frequency.is_some()),
        ("elements", spec.elements.is_some()),
        ("length", spec.length.is_some()),
        ("width", spec.width.is_some()),
        ("height", spec.height.is_some()),
        ("thickness", spec.thickness.is_some()),
        ("youngs_modulus", spec.youngs_modulus.is_some()),
        ("density", spec.density.is_some()),
        ("mass", spec.mass.is_some()),
        ("stiffness", spec.stiffness.is_some()),
        ("nonlinear", !spec.nonlinear.is_empty()),
        ("cyclic", spec.cyclic.is_some()),
        ("fixed_dofs", spec.fixed_dofs.is_some()),
    ];
    let allowed: &[&str] = match family.as_str() {
        "bladed-disk" => &[
            "sectors",
            "disk_mass",
            "blade_mass",
            "disk_coupling",
            "blade_stiffness",
            "cubic",
            "blade_stiffness_mistuning",
        ],
        "duffing" => &["natural_frequency", "cubic"],
        "two-dof" => &["cubic"],
        "cantilever-beam" => &[
            "elements",
            "length",
            "width",
            "height",
            "youngs_modulus",
            "density",
            "cubic",
        ],
        "von-karman-beam" => &[
            "elements",
            "length",
            "width",
            "thickness",
            "youngs_modulus",
            "density",
        ],
        "general" => &["mass", "stiffness", "nonlinear", "cyclic", "fixed_dofs"],
        other => {
            return Err(invalid(format!(
                "unknown model family `{other}` (expected \"bladed-disk\", \"duffing\", \"two-dof\", \"cantilever-beam\", \"von-karman-beam\", or no family with mass and stiffness)"
            )));
        }
    };
    if let Some((key, _)) = given.iter().find(|(k, g)| *g && !allowed.contains(k)) {
        return Err(invalid(format!(
            "[model] key `{key}` does not apply to family `{family}`"
        )));
    }
    let structure = match family.as_str() {
        "bladed-disk" => {
            let d = BladedDisk::default();
            BladedDisk {
                sectors: spec.sectors.unwrap_or(d.sectors),
                disk_mass: spec.disk_mass.unwrap_or(d.disk_mass),
                blade_mass: spec.blade_mass.unwrap_or(d.blade_mass),
                disk_coupling: spec.disk_coupling.unwrap_or(d.disk_coupling),
                blade_stiffness: spec.blade_stiffness.unwrap_or(d.blade_stiffness),
                cubic: spec.cubic.unwrap_or(d.cubic),
                blade_stiffness_mistuning: spec
                    .blade_stiffness_mistuning
                    .clone()
                    .unwrap_or_default(),
            }
            .build()
            .map_err(model_error)?
        }
        "duffing" => duffing(
            spec.natural_frequency.unwrap_or(1.0),
            spec.cubic.unwrap_or(1.0),
        )
        .map_err(model_error)?,
        "two-dof" => two_dof(spec.cubic.unwrap_or(0.5)).map_err(model_error)?,
        "cantilever-beam" => {
            let d = CantileverBeam::default();
            CantileverBeam {
                elements: spec.elements.unwrap_or(d.elements),
                length: spec.length.unwrap_or(d.length),
                width: spec.width.unwrap_or(d.width),
                height: spec.height.unwrap_or(d.height),
                youngs_modulus: spec.youngs_modulus.unwrap_or(d.youngs_modulus),
                density: spec.density.unwrap_or(d.density),
                cubic: spec.cubic.unwrap_or(d.cubic),
            }
            .build()
            .map_err(model_error)?
        }
        "von-karman-beam" => {
            let d = VonKarmanBeam::default();
            VonKarmanBeam {
                elements: spec.elements.unwrap_or(d.elements),
                length: spec.length.unwrap_or(d.length),
                width: spec.width.unwrap_or(d.width),
                thickness: spec.thickness.unwrap_or(d.thickness),
                youngs_modulus: spec.youngs_modulus.unwrap_or(d.youngs_modulus),
                density: spec.density.unwrap_or(d.density),
            }
            .build()
            .map_err(model_error)?
        }
        _ => {
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
            general_model(
                mass,
                stiffness,
                elements,
                spec.fixed_dofs.as_deref(),
                cyclic,
            )
            .map_err(model_error)?
        }
    };
    Ok((structure, family))
}

/// A model from a `[model]` table that names no files (a family and its parameters, or
/// matrices as rows), with the job file's keys, defaults and messages: for front ends that
/// take a model from elsewhere than a job file (the Python bindings' keyword arguments).
/// Messages are those of a job file without the file's name.
pub fn model_from_table(table: toml::Table) -> Result<(Structure, String), String> {
    let spec: ModelSpec = table
        .try_into()
        .map_err(|e: toml::de::Error| e.message().trim().to_string())?;
    build_model(&spec, Path::new("."), Path::new("")).map_err(|e| match e {
        JobError::Invalid { message, .. } => message,
        JobError::Model { error, .. } => error.to_string(),
        other => other.to_string(),
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
    fn dofs_used(&self) -> Vec<usize> {
        match self {
            Element::Spring(s) => s.dofs_used(),
            Element::Tensor(t) => t.dofs_used(),
        }
    }

    fn boxed(self) -> Box<dyn NonlinearElement> {
        match self {
            Element::Spring(s) => Box::new(s),
            Element::Tensor(t) => Box::new(t),
        }
    }

    /// The element on the model without the fixed dofs (docs/method.md eq. (61)); `None`
    /// when nothing of it is left.
    fn reduced(&self, fixed: &FixedDofs) -> Option<Box<dyn NonlinearElement>> {
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
fn build_element(
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
        return Err(format!("coefficient must be finite, got {coefficient}"));
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

/// Reads `mass` (`expected` = `None`) or `stiffness` (`Some(n)`, the mass's size). A file's
/// matrix is checked before it is stored: square, of the expected size, symmetric and finite
/// (errors name the file and the entry, 1-based as in the file); a coordinate file stays
/// sparse (`O(nnz)`, no size limit).
fn load_matrix(
    spec: &MatrixSpec,
    name: &'static str,
    expected: Option<usize>,
    base: &Path,
    path: &Path,
) -> Result<Matrix, JobError> {
    match spec {
        MatrixSpec::Rows(rows) => {
            let n = rows.len();
            if let Some((i, row)) = rows.iter().enumerate().find(|(_, r)| r.len() != n) {
                return Err(JobError::Invalid {
                    path: path.to_owned(),
                    message: format!(
                        "{name} matrix row {} has {} entries, expected {n} (a square matrix)",
                        i + 1,
                        row.len()
                    ),
                });
            }
            Ok(Matrix::from_fn(n, n, |i, j| rows[i][j]))
        }
        MatrixSpec::File { file } => {
            let file = base.join(file);
            let m = read_matrix_market(&file)?;
            check_file_matrix(name, expected, &file, m)
        }
    }
}

/// Relative tolerance of the symmetry check of matrix files, on the largest entry: values
/// written to full precision carry round-off of ~1e-16, so anything above 1e-12 is a
/// modelling or export error, not noise.
const FILE_SYMMETRY_TOLERANCE: f64 = 1e-12;

fn check_file_matrix(
    name: &'static str,
    expected: Option<usize>,
    file: &Path,
    m: MarketMatrix,
) -> Result<Matrix, JobError> {
    let invalid = |message: String| JobError::Invalid {
        path: file.to_owned(),
        message: format!("{name} matrix {message}"),
    };
    let (rows, cols) = (m.rows(), m.cols());
    if rows != cols {
        return Err(invalid(format!("is {rows}x{cols}, not square")));
    }
    if let Some(n) = expected
        && n != rows
    {
        return Err(invalid(format!(
            "is {rows}x{rows}, expected {n}x{n} (the size of the mass matrix)"
        )));
    }
    // A positive definite mass has every diagonal entry: a size beyond the stored entries is
    // refused before any O(n) storage is made for it (the stiffness's size must then match).
    if expected.is_none() && m.stored() < rows {
        return Err(invalid(format!(
            "is {rows}x{rows} but stores {} entries: it cannot be positive definite (every diagonal entry must be positive)",
            m.stored()
        )));
    }
    let m = m.into_matrix().expect("square");
    // Duplicates summed in a coordinate file may overflow.
    if let Matrix::Sparse(a) = &m {
        let p = a.pattern();
        if let Some(k) = a.values().iter().position(|v| !v.is_finite()) {
            let row = p.row_start.partition_point(|&s| s <= k);
            return Err(invalid(format!(
                "entry ({row}, {}) is not finite after summing duplicates",
                p.col[k] + 1
            )));
        }
    }
    if let Some((i, j, a, b)) = m.asymmetry(FILE_SYMMETRY_TOLERANCE) {
        return Err(invalid(format!(
            "is not symmetric: entry ({}, {}) = {a:e} but ({}, {}) = {b:e} (1-based; tolerance {FILE_SYMMETRY_TOLERANCE:e} of the largest entry)",
            i + 1,
            j + 1,
            j + 1,
            i + 1
        )));
    }
    Ok(m)
}

fn syntax_error(e: &toml::de::Error, text: &str, path: &Path) -> JobError {
    let (line, column) = e
        .span()
        .map(|span| {
            let before = &text[..span.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let column = before.len() - before.rfind('\n').map_or(0, |k| k + 1) + 1;
            (line, column)
        })
        .unwrap_or((1, 1));
    JobError::Syntax {
        path: path.to_owned(),
        line,
        column,
        message: e
            .message()
            .lines()
            .next()
            .unwrap_or("syntax error")
            .to_string(),
    }
}

#[cfg(test)]
mod tests;
