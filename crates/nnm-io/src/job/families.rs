//! The built-in model families: one serde enum over the family structs of `nnm::model`,
//! named by `[model]`'s `family` key. A family's keys, their types and defaults are its
//! struct's (`#[serde(default)]` is its `Default`), so adding a family is its struct (with
//! `build`) and its name in [`families!`].

use std::ops::Range;

use nnm::model::{
    BladedDisk, CantileverBeam, Duffing, Layout, ModelError, Solid, Structure, TwoDof,
    VonKarmanBeam,
};
use serde::Deserialize;
use serde::de::{self, DeserializeSeed, EnumAccess, IntoDeserializer, MapAccess, VariantAccess};

use super::schema::Parameter;

/// Declares [`Family`] over the family structs, each variant named in kebab case
/// (`BladedDisk` is `family = "bladed-disk"`), with its `build`.
macro_rules! families {
    ($($variant:ident),* $(,)?) => {
        /// A built-in model family and its parameters (docs/job-files.md).
        ///
        /// Externally tagged for serde, the tag being the value of `family`: [`parse`] hands
        /// serde the name as the variant and the other keys as its struct, each value read
        /// from the file's text where it stands, so that a wrong type is reported at its line
        /// and column (an internally tagged enum buffers the values and loses their places).
        #[derive(Debug, Clone, PartialEq, Deserialize)]
        #[serde(rename_all = "kebab-case")]
        pub enum Family {
            $($variant($variant),)*
        }

        impl Family {
            /// The model, its parameters checked (positive sizes, finite values, ...).
            pub fn build(&self) -> Result<Structure, ModelError> {
                match self {
                    $(Family::$variant(p) => p.build(),)*
                }
            }

            /// Where the model's dofs sit in space (beams and structured solid boxes; a
            /// solid on a mesh file gets its layout where the file is read).
            pub fn layout(&self) -> Option<Layout> {
                match self {
                    Family::CantileverBeam(p) => Some(p.layout()),
                    Family::VonKarmanBeam(p) => Some(p.layout()),
                    Family::Solid(p) if p.mesh.is_none() => p.layout().ok(),
                    _ => None,
                }
            }

            /// The parameters as a TOML table (`family` left out).
            pub fn parameters(&self) -> toml::Table {
                match self {
                    $(Family::$variant(p) => toml::Table::try_from(p),)*
                }
                .expect("a family's parameters are a table")
            }
        }
    };
}

families!(
    BladedDisk,
    Duffing,
    TwoDof,
    CantileverBeam,
    VonKarmanBeam,
    Solid
);

/// The default parameters of `family` (e.g. `"bladed-disk"`) as a TOML table, every key
/// given (`family` left out): what a job with only `family = "..."` builds. `None` for an
/// unknown family. For front ends whose constructors show the defaults (the Python
/// bindings), so that they do not restate them.
pub fn family_defaults(family: &str) -> Option<toml::Table> {
    parse(family, &[], None).ok().map(|f| f.parameters())
}

/// The built-in families' names (`"bladed-disk"`, ...), in the order [`families!`] declares
/// them: what front ends offer and the unknown-family message lists.
pub fn family_names() -> &'static [&'static str] {
    match family_keys("") {
        Err(FamilyError::Unknown(names)) => names,
        _ => unreachable!("no family is named by the empty string"),
    }
}

/// The parameters `family` takes, in the order its struct declares them (`None` for an
/// unknown family): the order front ends show them in ([`family_defaults`]' table is sorted).
pub fn family_parameter_names(family: &str) -> Option<&'static [&'static str]> {
    family_keys(family).ok()
}

/// Why a family's parameters were refused.
#[derive(Debug)]
pub(super) enum FamilyError {
    /// No family of that name; the known ones.
    Unknown(&'static [&'static str]),
    /// The family's keys (the answer of [`family_keys`], not an error of the input).
    Keys(&'static [&'static str]),
    /// A value serde refused: its message, and where in the file's text (when known).
    Value {
        message: String,
        span: Option<Range<usize>>,
    },
}

impl std::fmt::Display for FamilyError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FamilyError::Unknown(_) => f.write_str("unknown model family"),
            FamilyError::Keys(_) => f.write_str("the family's keys"),
            FamilyError::Value { message, .. } => f.write_str(message),
        }
    }
}

impl std::error::Error for FamilyError {}

impl de::Error for FamilyError {
    fn custom<T: std::fmt::Display>(message: T) -> Self {
        FamilyError::Value {
            message: message.to_string(),
            span: None,
        }
    }
}

/// The keys `family` takes (its struct's fields), or [`FamilyError::Unknown`].
pub(super) fn family_keys(family: &str) -> Result<&'static [&'static str], FamilyError> {
    match Family::deserialize(Named {
        family,
        parameters: None,
        source: None,
    }) {
        Err(FamilyError::Keys(keys)) => Ok(keys),
        Err(e) => Err(e),
        Ok(_) => unreachable!("asking for the keys builds no family"),
    }
}

/// `family` with `parameters` (all of them keys of the family: see [`family_keys`]); when
/// `source` is the text they were read from, their values are read from it again, so that
/// an error has its place in the text, inside arrays too.
pub(super) fn parse(
    family: &str,
    parameters: &[Parameter],
    source: Option<&str>,
) -> Result<Family, FamilyError> {
    Family::deserialize(Named {
        family,
        parameters: Some(parameters),
        source,
    })
}

/// The deserializer of [`Family`]: the variant `family`, its struct from `parameters`
/// (`None`: answer the struct's keys instead).
struct Named<'a> {
    family: &'a str,
    parameters: Option<&'a [Parameter]>,
    source: Option<&'a str>,
}

impl<'de> de::Deserializer<'de> for Named<'de> {
    type Error = FamilyError;

    fn deserialize_any<V: de::Visitor<'de>>(self, _visitor: V) -> Result<V::Value, FamilyError> {
        Err(de::Error::custom("a model family is an enum"))
    }

    fn deserialize_enum<V: de::Visitor<'de>>(
        self,
        _name: &'static str,
        variants: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, FamilyError> {
        if !variants.contains(&self.family) {
            return Err(FamilyError::Unknown(variants));
        }
        visitor.visit_enum(self)
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
        option unit unit_struct newtype_struct seq tuple tuple_struct map struct identifier
        ignored_any
    }
}

impl<'de> EnumAccess<'de> for Named<'de> {
    type Error = FamilyError;
    type Variant = Self;

    fn variant_seed<V: DeserializeSeed<'de>>(
        self,
        seed: V,
    ) -> Result<(V::Value, Self), FamilyError> {
        let variant = seed.deserialize(self.family.into_deserializer())?;
        Ok((variant, self))
    }
}

impl<'de> VariantAccess<'de> for Named<'de> {
    type Error = FamilyError;

    fn unit_variant(self) -> Result<(), FamilyError> {
        Err(de::Error::custom("a model family has parameters"))
    }

    fn newtype_variant_seed<T: DeserializeSeed<'de>>(
        self,
        seed: T,
    ) -> Result<T::Value, FamilyError> {
        seed.deserialize(Parameters {
            parameters: self.parameters,
            source: self.source,
        })
    }

    fn tuple_variant<V: de::Visitor<'de>>(
        self,
        _len: usize,
        _visitor: V,
    ) -> Result<V::Value, FamilyError> {
        Err(de::Error::custom("a model family has parameters"))
    }

    fn struct_variant<V: de::Visitor<'de>>(
        self,
        _fields: &'static [&'static str],
        _visitor: V,
    ) -> Result<V::Value, FamilyError> {
        Err(de::Error::custom("a model family has parameters"))
    }
}

/// A family's struct from its parameters.
struct Parameters<'a> {
    parameters: Option<&'a [Parameter]>,
    source: Option<&'a str>,
}

impl<'de> de::Deserializer<'de> for Parameters<'de> {
    type Error = FamilyError;

    fn deserialize_any<V: de::Visitor<'de>>(self, _visitor: V) -> Result<V::Value, FamilyError> {
        Err(de::Error::custom(
            "a model family's parameters are a struct",
        ))
    }

    fn deserialize_struct<V: de::Visitor<'de>>(
        self,
        _name: &'static str,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, FamilyError> {
        match self.parameters {
            None => Err(FamilyError::Keys(fields)),
            Some(parameters) => visitor.visit_map(ParameterAccess {
                rest: parameters.iter(),
                value: None,
                source: self.source,
            }),
        }
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
        option unit unit_struct newtype_struct seq tuple tuple_struct map enum identifier
        ignored_any
    }
}

struct ParameterAccess<'a> {
    rest: std::slice::Iter<'a, Parameter>,
    value: Option<&'a toml::Spanned<toml::Value>>,
    source: Option<&'a str>,
}

impl<'de> MapAccess<'de> for ParameterAccess<'de> {
    type Error = FamilyError;

    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, FamilyError> {
        let Some(parameter) = self.rest.next() else {
            return Ok(None);
        };
        self.value = Some(&parameter.value);
        seed.deserialize(parameter.key.as_str().into_deserializer())
            .map(Some)
    }

    fn next_value_seed<V: DeserializeSeed<'de>>(
        &mut self,
        seed: V,
    ) -> Result<V::Value, FamilyError> {
        let value = self.value.take().expect("a value follows its key");
        let span = value.span();
        // The value's own text, read as a job file's value is (spans then relative to it).
        let raw = self
            .source
            .and_then(|text| text.get(span.clone()))
            .and_then(|raw| toml::de::ValueDeserializer::parse(raw).ok());
        match raw {
            Some(deserializer) => seed
                .deserialize(deserializer)
                .map_err(|e| FamilyError::Value {
                    message: e.message().to_string(),
                    span: Some(match e.span() {
                        Some(s) => span.start + s.start..span.start + s.end,
                        None => span,
                    }),
                }),
            None => seed
                .deserialize(value.get_ref().clone().into_deserializer())
                .map_err(|e: toml::de::Error| FamilyError::Value {
                    message: e.message().to_string(),
                    span: None,
                }),
        }
    }
}
