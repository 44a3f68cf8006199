//! A branch's keys: its `mode` and `pattern`, and its settings, the `[settings]` section
//! overridden key by key by the branch's own (what job files and the Python bindings share).

use nnm::Settings;
use nnm::modes::{LinearMode, StandingWave, find_mode};
use nnm::shooting::{PhaseCondition, Travel};

/// The branch keys that are not settings.
const BRANCH_KEYS: [&str; 4] = ["name", "mode", "pattern", "start"];

/// The setting that needs the model to be read (its force shape and `[model] damping`):
/// taken out of the table here, resolved by [`super::energy_balance`] once the model is built.
pub const RESONANCE_FORCE: &str = "resonance_force";

/// Settings from a flat table (`[settings]` overridden by a branch's keys): a key that is
/// neither a setting nor a branch key is refused (a typo must not fall back to a default).
/// [`RESONANCE_FORCE`] is left for the caller to take out first.
pub(super) fn settings_from(mut table: toml::Table) -> Result<Settings, String> {
    table.remove(RESONANCE_FORCE);
    if let Some(key) = table.keys().find(|k| !Settings::KEYS.contains(&k.as_str())) {
        let mut expected: Vec<&str> = Settings::KEYS.to_vec();
        expected.push(RESONANCE_FORCE);
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
    /// `resonance_force = { ... }` as written (the force shape whose resonance force every
    /// point reports), for [`super::energy_balance`] to resolve against the model; `None`
    /// if not given.
    pub resonance_force: Option<toml::Value>,
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
    let resonance_force = merged.remove(RESONANCE_FORCE);
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
        resonance_force,
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
