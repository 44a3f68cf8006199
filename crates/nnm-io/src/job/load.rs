//! Reading a job file: the text parsed, overrides applied, then checked in the order of
//! the file (the model, `[settings]`, each branch), every error one line naming the file.

use std::ops::Range;
use std::path::Path;

use nnm::MechanicalSystem;

use super::branch::{BranchBody, branch_body, settings_from};
use super::families::Family;
use super::model::{BuiltModel, SpecError, build_model, typed_family};
use super::response::{ResponseJob, damping_matrix, energy_balance, response_body};
use super::schema::{EventStart, JobFile, from_table};
use super::{BranchJob, Job, JobError};
use crate::error::io_reason;
use crate::output::{BRANCH_FILE_SUFFIXES, RUN_FILES, branch_files, response_files};

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
    let family = typed_family(&file.model, Some(text)).map_err(|e| match e {
        SpecError::Invalid(message) => JobError::Invalid {
            path: path.to_owned(),
            message,
        },
        SpecError::Value { message, span } => located(&message, span, text, path),
    })?;
    job_from_file(file, family, path)
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
    // serde's message on a value of the wrong type names the type, not the key: name the
    // override that `breaks` the file on its own (the file itself parsed).
    let refused = |message: String, breaks: &dyn Fn(&toml::Table) -> bool| {
        let culprit = overrides.iter().find(|(key, value)| {
            let mut alone = original.clone();
            override_key(&mut alone, key, value.clone()).is_ok() && breaks(&alone)
        });
        match culprit {
            Some((key, _)) => invalid(key, message),
            None => JobError::Invalid {
                path: path.to_owned(),
                message,
            },
        }
    };
    let file: JobFile = from_table(&table).map_err(|e: toml::de::Error| {
        refused(e.message().trim().to_string(), &|alone| {
            from_table::<JobFile>(alone).is_err()
        })
    })?;
    let family = typed_family(&file.model, None).map_err(|e| match e {
        SpecError::Invalid(message) => JobError::Invalid {
            path: path.to_owned(),
            message,
        },
        SpecError::Value { message, .. } => refused(message, &|alone| {
            from_table::<JobFile>(alone)
                .is_ok_and(|f| matches!(typed_family(&f.model, None), Err(SpecError::Value { .. })))
        }),
    })?;
    job_from_file(file, family, path)
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
fn job_from_file(file: JobFile, family: Option<Family>, path: &Path) -> Result<Job, JobError> {
    let invalid = |message: String| JobError::Invalid {
        path: path.to_owned(),
        message,
    };
    let base = path.parent().unwrap_or(Path::new("."));
    let BuiltModel {
        structure,
        family,
        layout,
    } = build_model(&file.model, family.as_ref(), base, path)?;

    let defaults: toml::Table = file.settings.unwrap_or_default();
    let default_settings =
        settings_from(defaults.clone()).map_err(|m| invalid(format!("[settings]: {m}")))?;
    default_settings
        .validate_for(structure.dofs())
        .map_err(|e| invalid(format!("[settings]: {e}")))?;
    let fixed = file.model.fixed_dofs.as_ref().map(|dofs| {
        nnm::model::FixedDofs::new(structure.dofs() + dofs.len(), dofs)
            .expect("checked when the model was built")
    });
    let damping = match &file.model.damping {
        Some(spec) => Some(
            damping_matrix(spec, &structure, fixed.as_ref(), base)
                .map_err(|m| invalid(format!("[model] damping: {m}")))?,
        ),
        None => None,
    };
    let mut branches = Vec::new();
    for (k, mut table) in file.branch.into_iter().enumerate() {
        let context = |what: &str| format!("branch {}: {what}", k + 1);
        let name = match table.remove("name") {
            Some(toml::Value::String(s)) => s,
            Some(_) => return Err(invalid(context("`name` must be a string"))),
            None => return Err(invalid(context("missing `name`"))),
        };
        if let Err(why) = check_name(&name, "branch") {
            return Err(invalid(context(&why)));
        }
        if branches.iter().any(|b: &BranchJob| b.name == name) {
            return Err(invalid(format!("duplicate branch name `{name}`")));
        }
        check_name_length(&name).map_err(|m| invalid(context(&m)))?;
        let earlier: Vec<(&str, &str)> = branches
            .iter()
            .map(|b: &BranchJob| ("branch", b.name.as_str()))
            .collect();
        if let Some(m) = file_collision(("branch", &name), &earlier) {
            return Err(invalid(m));
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
            mut settings,
            resonance_force,
        } = branch_body(table, &defaults, from_event.is_some())
            .map_err(|m| invalid(context(&m)))?;
        if let Some(value) = &resonance_force {
            let balance = energy_balance(value, &structure, damping.as_ref(), fixed.as_ref(), base)
                .map_err(|m| invalid(context(&m)))?;
            settings.output.energy_balance = Some(std::sync::Arc::new(balance));
        }
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
    let mut responses: Vec<ResponseJob> = Vec::new();
    for (k, mut table) in file.response.into_iter().enumerate() {
        let context = |what: &str| format!("response {}: {what}", k + 1);
        let name = match table.remove("name") {
            Some(toml::Value::String(s)) => s,
            Some(_) => return Err(invalid(context("`name` must be a string"))),
            None => return Err(invalid(context("missing `name`"))),
        };
        check_name(&name, "response").map_err(|m| invalid(context(&m)))?;
        if responses.iter().any(|r| r.name == name) {
            return Err(invalid(format!("duplicate response name `{name}`")));
        }
        let earlier: Vec<(&str, &str)> = branches
            .iter()
            .map(|b| ("branch", b.name.as_str()))
            .chain(responses.iter().map(|r| ("response", r.name.as_str())))
            .collect();
        if let Some(m) = file_collision(("response", &name), &earlier) {
            return Err(invalid(m));
        }
        let written = with_force_vector(&table, base);
        let body = response_body(table, &structure, damping.as_ref(), fixed.as_ref(), base)
            .map_err(|m| invalid(format!("response `{name}`: {m}")))?;
        responses.push(ResponseJob {
            name,
            body,
            table: written,
        });
    }
    Ok(Job {
        structure,
        family,
        branches,
        default_settings,
        damping,
        damping_spec: file.model.damping,
        fixed_dofs: fixed,
        responses,
        layout,
    })
}

/// A `[[response]]` table with its force's `file`, if any, read into the `vector` it holds
/// (what the Python bindings' `Force` takes); left as written when it cannot be read, for
/// [`response_body`] to refuse.
fn with_force_vector(table: &toml::Table, base: &Path) -> toml::Table {
    let mut table = table.clone();
    if let Some(toml::Value::Table(force)) = table.get_mut("force")
        && let Some(toml::Value::String(file)) = force.get("file")
        && let Ok(vector) = super::response::read_vector(&base.join(file))
    {
        force.remove("file");
        force.insert(
            "vector".into(),
            toml::Value::Array(vector.into_iter().map(toml::Value::Float).collect()),
        );
    }
    table
}

/// A branch's (or response's: `what`) name names its files (`NAME.csv`, `NAME.json`, ...):
/// refused, with the rule it breaks and the characters at fault (none the name may use), when
/// it is empty, `modes` (the linear modes' file), starts with '.' (a hidden file), or holds a
/// character other than an ASCII letter, digit, '-', '_' or '.'.
fn check_name(name: &str, what: &str) -> Result<(), String> {
    let mut refused: Vec<char> = Vec::new();
    for c in name.chars() {
        if !(c.is_ascii_alphanumeric() || "-_.".contains(c) || refused.contains(&c)) {
            refused.push(c);
        }
    }
    if name.is_empty() {
        Err(format!("`name` is empty; a {what}'s name names its files"))
    } else if name == "modes" {
        Err("name `modes` would overwrite the linear modes' file modes.csv: use a name that is not `modes`".into())
    } else if !refused.is_empty() {
        let listed: Vec<String> = refused.iter().map(|c| format!("{c:?}")).collect();
        Err(format!(
            "name `{}` holds {}, which a {what} name cannot: it names the {what}'s files, so it may use only ASCII letters, digits, '-', '_' and '.'",
            name.escape_debug(),
            listed.join(", ")
        ))
    } else if name.starts_with('.') {
        Err(format!(
            "name `{name}` starts with '.', which would hide the {what}'s files: start it with a letter, a digit, '-' or '_'"
        ))
    } else {
        check_name_length(name)
    }
}

/// The longest name whose files fit the 255 bytes a file name may have (ext4, APFS, NTFS):
/// a longer one would fail when its branch starts, after other branches' files are written.
pub const MAX_BRANCH_NAME: usize = 255 - longest_suffix();

const fn longest_suffix() -> usize {
    let mut longest = 0;
    let mut k = 0;
    while k < BRANCH_FILE_SUFFIXES.len() {
        if BRANCH_FILE_SUFFIXES[k].len() > longest {
            longest = BRANCH_FILE_SUFFIXES[k].len();
        }
        k += 1;
    }
    longest
}

/// Refuses branch `name` (a valid name) when its files would not fit a file name.
fn check_name_length(name: &str) -> Result<(), String> {
    if name.len() > MAX_BRANCH_NAME {
        let start: String = name.chars().take(16).collect();
        // The first of the longest (`max_by_key` keeps the last of equals).
        let longest = BRANCH_FILE_SUFFIXES
            .iter()
            .rev()
            .max_by_key(|s| s.len())
            .expect("suffixes");
        return Err(format!(
            "name `{start}...` has {} characters, more than the {MAX_BRANCH_NAME} that leave room for its files' suffixes (`{longest}`) in a file name",
            name.len()
        ));
    }
    Ok(())
}

/// Why branch `name` cannot be written beside the `earlier` ones: one of its files would be
/// a file of an earlier branch (`b.events` writes `b.events.csv`, as `b` does) or of the run
/// (`modes.csv`, ...). Names are compared ignoring case: on the file systems of macOS and
/// Windows `B.csv` is `b.csv`, and a job must not overwrite its own results on the machine
/// it is copied to.
fn file_collision((kind, name): (&str, &str), earlier: &[(&str, &str)]) -> Option<String> {
    let case_note = |a: &str, b: &str| {
        if a == b {
            String::new()
        } else {
            format!(" ({a} and {b} are one file where names ignore case, as on macOS and Windows)")
        }
    };
    let files = |kind: &str, name: &str| -> Vec<String> {
        if kind == "branch" {
            branch_files(name).collect()
        } else {
            response_files(name).collect()
        }
    };
    for file in files(kind, name) {
        let same = |other: &str| other.eq_ignore_ascii_case(&file);
        if let Some(run_file) = RUN_FILES.iter().find(|f| same(f)) {
            return Some(format!(
                "{kind} `{name}` would write {file} over the run's own {run_file}{}",
                case_note(run_file, &file)
            ));
        }
        let theirs = earlier
            .iter()
            .find_map(|&(k, b)| Some((k, b, files(k, b).into_iter().find(|f| same(f))?)));
        if let Some((their_kind, b, theirs)) = theirs {
            let who = if their_kind == kind {
                let kinds = if kind == "branch" {
                    "branches"
                } else {
                    "responses"
                };
                format!("{kinds} `{b}` and `{name}`")
            } else {
                format!("{their_kind} `{b}` and {kind} `{name}`")
            };
            return Some(format!(
                "{who} would both write {theirs}{}",
                case_note(&theirs, &file)
            ));
        }
    }
    None
}

fn syntax_error(e: &toml::de::Error, text: &str, path: &Path) -> JobError {
    located(e.message(), e.span(), text, path)
}

/// An error at `span` of the job's `text` (its start's line and column, 1-based), with the
/// first line of `message`.
fn located(message: &str, span: Option<Range<usize>>, text: &str, path: &Path) -> JobError {
    let (line, column) = span
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
        message: message.lines().next().unwrap_or("syntax error").to_string(),
    }
}
