//! The job file as TOML: the serde structs of its sections, before anything is checked
//! against anything else.

use serde::Deserialize;
use serde::de::{self, DeserializeSeed, MapAccess, Visitor};

/// The whole file: `[model]`, `[settings]`, `[[branch]]`, `[[response]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct JobFile {
    pub model: ModelSpec,
    #[serde(default)]
    pub settings: Option<toml::Table>,
    #[serde(default)]
    pub branch: Vec<toml::Table>,
    #[serde(default)]
    pub response: Vec<toml::Table>,
}

/// Every key of `[model]`, in the order the message about an unknown key lists them:
/// `family`, the families' parameters, then a general model's ([`GENERAL_KEYS`]). Which
/// parameters a family takes, their types and defaults are its struct's
/// (`super::families`); a test checks that this list holds exactly their keys. `damping`
/// ([`COMMON_KEYS`]) applies to every model.
pub(super) const MODEL_KEYS: [&str; 27] = [
    "family",
    "sectors",
    "disk_mass",
    "blade_mass",
    "disk_coupling",
    "blade_stiffness",
    "cubic",
    "blade_stiffness_mistuning",
    "natural_frequency",
    "elements",
    "length",
    "width",
    "height",
    "thickness",
    "youngs_modulus",
    "density",
    "element",
    "box",
    "clamped",
    "poisson_ratio",
    "mesh",
    "mass",
    "stiffness",
    "nonlinear",
    "cyclic",
    "fixed_dofs",
    "damping",
];

/// The keys of a general model (no `family`).
pub(super) const GENERAL_KEYS: [&str; 6] = [
    "mass",
    "stiffness",
    "nonlinear",
    "cyclic",
    "fixed_dofs",
    "damping",
];

/// The keys every model takes, a family or a general one: the damping of forced responses.
pub(super) const COMMON_KEYS: [&str; 1] = ["damping"];

/// `[model]`: a family's name and parameters, or a general model's matrices and elements.
/// The parameters stay untyped until the family is known (it may come after them), each
/// with its place in the file so that a wrong type is still reported at its line.
#[derive(Debug, Default)]
pub(super) struct ModelSpec {
    pub family: Option<String>,
    /// A family's parameters, in the order written.
    pub parameters: Vec<Parameter>,
    pub mass: Option<MatrixSpec>,
    pub stiffness: Option<MatrixSpec>,
    pub nonlinear: Vec<ElementSpec>,
    pub cyclic: Option<CyclicSpec>,
    /// Dofs held at zero (0-based, like an element's `dofs`), removed from the model.
    pub fixed_dofs: Option<Vec<usize>>,
    /// Viscous damping of forced responses (`[[response]]`).
    pub damping: Option<DampingSpec>,
}

/// One family parameter as written: `key = value`, the value's span in the file's text.
#[derive(Debug)]
pub(super) struct Parameter {
    pub key: String,
    pub value: toml::Spanned<toml::Value>,
}

impl ModelSpec {
    /// Whether `key` (one of [`MODEL_KEYS`]) is given; an empty `nonlinear` list counts as
    /// not given.
    pub fn gives(&self, key: &str) -> bool {
        match key {
            "family" => self.family.is_some(),
            "mass" => self.mass.is_some(),
            "stiffness" => self.stiffness.is_some(),
            "nonlinear" => !self.nonlinear.is_empty(),
            "cyclic" => self.cyclic.is_some(),
            "fixed_dofs" => self.fixed_dofs.is_some(),
            "damping" => self.damping.is_some(),
            _ => self.parameters.iter().any(|p| p.key == key),
        }
    }
}

impl<'de> Deserialize<'de> for ModelSpec {
    fn deserialize<D: de::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_struct("ModelSpec", &MODEL_KEYS, ModelVisitor)
    }
}

struct ModelVisitor;

impl<'de> Visitor<'de> for ModelVisitor {
    type Value = ModelSpec;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("struct ModelSpec")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<ModelSpec, A::Error> {
        let mut spec = ModelSpec::default();
        while let Some(key) = map.next_key_seed(ModelKey)? {
            // TOML has no duplicate keys, so each is seen once.
            match key.as_str() {
                "family" => spec.family = Some(map.next_value()?),
                "mass" => spec.mass = Some(map.next_value()?),
                "stiffness" => spec.stiffness = Some(map.next_value()?),
                "nonlinear" => spec.nonlinear = map.next_value()?,
                "cyclic" => spec.cyclic = Some(map.next_value()?),
                "fixed_dofs" => spec.fixed_dofs = Some(map.next_value()?),
                "damping" => spec.damping = Some(map.next_value()?),
                _ => spec.parameters.push(Parameter {
                    key,
                    value: map.next_value()?,
                }),
            }
        }
        Ok(spec)
    }
}

/// A key of `[model]`, refused (at the key) unless it is one of [`MODEL_KEYS`]: a typo must
/// not silently fall back to a default.
struct ModelKey;

impl<'de> DeserializeSeed<'de> for ModelKey {
    type Value = String;

    fn deserialize<D: de::Deserializer<'de>>(self, deserializer: D) -> Result<String, D::Error> {
        let key = String::deserialize(deserializer)?;
        if MODEL_KEYS.contains(&key.as_str()) {
            Ok(key)
        } else {
            Err(de::Error::unknown_field(&key, &MODEL_KEYS))
        }
    }
}

/// `mass`/`stiffness`: rows, or a file. Untagged, so serde's own message on a mismatch
/// ("did not match any variant of untagged enum") would name a type the user never sees:
/// `expecting` says what forms are accepted instead.
#[derive(Debug, Deserialize)]
#[serde(
    untagged,
    expecting = "expected a matrix as rows of numbers, e.g. [[2.0, -1.0], [-1.0, 2.0]], or as a Matrix Market file, { file = \"K.mtx\" }"
)]
pub(super) enum MatrixSpec {
    Rows(Vec<Vec<f64>>),
    File { file: String },
}

/// `[model] damping`: `{ rayleigh = [α, β] }` (`C = αM + βK`), `{ modal = [ζ0, ...] }`
/// (ratios of the lowest elastic modes), `{ matrix = [[...]] }` or `{ file = "C.mtx" }` (in
/// the model's full numbering, as `mass` and `stiffness`). Turned into `C` by
/// [`super::damping_matrix`].
#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum DampingSpec {
    Rayleigh([f64; 2]),
    Modal(Vec<f64>),
    Matrix(Vec<Vec<f64>>),
    File(String),
}

/// One `[[model.nonlinear]]` element.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ElementSpec {
    #[serde(rename = "type")]
    pub kind: String,
    /// Springs (`cubic`, `polynomial`): the dofs, 0-based.
    pub dofs: Option<Vec<usize>>,
    pub coefficient: Option<f64>,
    pub exponent: Option<u32>,
    /// `tensor`: the file of quadratic terms `i j k c`, 1-based.
    pub quadratic: Option<FileSpec>,
    /// `tensor`: the file of cubic terms `i j k l c`, 1-based.
    pub cubic: Option<FileSpec>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct FileSpec {
    pub file: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CyclicSpec {
    pub sectors: usize,
    pub dofs_per_sector: usize,
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

/// A section given as a table rather than text (the Python bindings' keyword arguments, a
/// job file with keys overridden), read as if a file said so. Through TOML text, because
/// [`ModelSpec`] keeps each parameter's span, which only the text deserializer gives; the
/// spans are then of that text, and its errors are reported without a line.
pub(super) fn from_table<T: de::DeserializeOwned>(
    table: &toml::Table,
) -> Result<T, toml::de::Error> {
    let text = toml::to_string(table).map_err(|e| de::Error::custom(e.to_string()))?;
    toml::from_str(&text)
}
