//! Stage parameters: the scalar-or-array values of `[stage.<name>.params]`, and their three
//! renderings — the plain text passed on a stage's command line, the canonical JSON kept in
//! the lock file, and the type-tagged form hashed into the cache key.

use std::collections::BTreeMap;

use serde::Serialize;

/// One scalar parameter value.
#[derive(Debug, Clone, PartialEq)]
pub enum Scalar {
    /// A TOML string.
    Str(String),
    /// A TOML integer.
    Int(i64),
    /// A TOML float.
    Float(f64),
    /// A TOML boolean.
    Bool(bool),
    /// A TOML date/time, kept as its RFC 3339 text.
    Datetime(String),
}

/// A parameter value: a scalar or a flat array of scalars.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    /// A single value.
    Scalar(Scalar),
    /// An array, passed to the stage joined by commas.
    Array(Vec<Scalar>),
}

/// Why a TOML value cannot be a parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum NotAParam {
    Table,
    NestedArray,
    ArrayOfTables,
}

impl NotAParam {
    pub(crate) fn describe(self) -> &'static str {
        match self {
            Self::Table => "a table",
            Self::NestedArray => "an array of arrays",
            Self::ArrayOfTables => "an array of tables",
        }
    }
}

impl Scalar {
    fn from_toml(value: &toml::Value) -> Result<Self, NotAParam> {
        Ok(match value {
            toml::Value::String(s) => Self::Str(s.clone()),
            toml::Value::Integer(i) => Self::Int(*i),
            toml::Value::Float(f) => Self::Float(*f),
            toml::Value::Boolean(b) => Self::Bool(*b),
            toml::Value::Datetime(d) => Self::Datetime(d.to_string()),
            toml::Value::Array(_) => return Err(NotAParam::NestedArray),
            toml::Value::Table(_) => return Err(NotAParam::ArrayOfTables),
        })
    }

    /// The value as the stage sees it on its command line: strings raw, bools
    /// `true`/`false`, floats via `{}` (shortest text that round-trips).
    #[must_use]
    pub fn plain(&self) -> String {
        match self {
            Self::Str(s) | Self::Datetime(s) => s.clone(),
            Self::Int(i) => i.to_string(),
            Self::Float(f) => f.to_string(),
            Self::Bool(b) => b.to_string(),
        }
    }

    fn json(&self) -> serde_json::Value {
        match self {
            Self::Str(s) | Self::Datetime(s) => serde_json::Value::String(s.clone()),
            Self::Int(i) => (*i).into(),
            // JSON has no NaN or infinity: those are kept as their text.
            Self::Float(f) => serde_json::Number::from_f64(*f)
                .map_or_else(|| serde_json::Value::String(f.to_string()), serde_json::Value::Number),
            Self::Bool(b) => (*b).into(),
        }
    }

    fn tagged(&self) -> Tagged {
        match self {
            Self::Str(s) => Tagged::Str(s.clone()),
            Self::Int(i) => Tagged::Int(*i),
            // `{}` round-trips and keeps -0.0, NaN and infinities distinct.
            Self::Float(f) => Tagged::Float(f.to_string()),
            Self::Bool(b) => Tagged::Bool(*b),
            Self::Datetime(d) => Tagged::Datetime(d.clone()),
        }
    }
}

impl ParamValue {
    /// Converts a TOML value, refusing tables and nested arrays.
    pub(crate) fn from_toml(value: &toml::Value) -> Result<Self, NotAParam> {
        match value {
            toml::Value::Table(_) => Err(NotAParam::Table),
            toml::Value::Array(items) => items.iter().map(Scalar::from_toml).collect::<Result<_, _>>().map(Self::Array),
            scalar => Scalar::from_toml(scalar).map(Self::Scalar),
        }
    }

    /// The command-line text: a scalar plainly, an array joined by commas.
    #[must_use]
    pub fn plain(&self) -> String {
        match self {
            Self::Scalar(s) => s.plain(),
            Self::Array(items) => items.iter().map(Scalar::plain).collect::<Vec<_>>().join(","),
        }
    }

    /// The JSON form recorded in the lock file.
    #[must_use]
    pub fn json(&self) -> serde_json::Value {
        match self {
            Self::Scalar(s) => s.json(),
            Self::Array(items) => serde_json::Value::Array(items.iter().map(Scalar::json).collect()),
        }
    }

    pub(crate) fn tagged(&self) -> Tagged {
        match self {
            Self::Scalar(s) => s.tagged(),
            Self::Array(items) => Tagged::Array(items.iter().map(Scalar::tagged).collect()),
        }
    }
}

/// The type-tagged form hashed into the cache key, so that `1`, `1.0` and `"1"` differ.
#[derive(Debug, Serialize)]
#[serde(rename_all = "snake_case")]
pub(crate) enum Tagged {
    Str(String),
    Int(i64),
    Float(String),
    Bool(bool),
    Datetime(String),
    Array(Vec<Tagged>),
}

/// A stage's parameters in declaration order.
pub type Params = Vec<(String, ParamValue)>;

/// The canonical JSON object of a stage's parameters: keys sorted, whatever the order in
/// `pipeline.toml`.
#[must_use]
pub fn canonical_json(params: &Params) -> BTreeMap<String, serde_json::Value> {
    params.iter().map(|(name, value)| (name.clone(), value.json())).collect()
}

/// The parameters in the form the cache key hashes: keys sorted, values type-tagged.
pub(crate) fn canonical_tagged(params: &Params) -> BTreeMap<&str, Tagged> {
    params.iter().map(|(name, value)| (name.as_str(), value.tagged())).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn param(src: &str) -> Result<ParamValue, NotAParam> {
        let table: toml::Table = toml::from_str(&format!("v = {src}")).unwrap();
        ParamValue::from_toml(&table["v"])
    }

    #[test]
    fn plain_formatting() {
        assert_eq!(param("\"eye_*\"").unwrap().plain(), "eye_*");
        assert_eq!(param("12").unwrap().plain(), "12");
        assert_eq!(param("-3").unwrap().plain(), "-3");
        assert_eq!(param("0.85").unwrap().plain(), "0.85");
        assert_eq!(param("1e-7").unwrap().plain(), "0.0000001");
        assert_eq!(param("2.0").unwrap().plain(), "2");
        assert_eq!(param("true").unwrap().plain(), "true");
        assert_eq!(param("[\"eye_*\", \"lid_*\"]").unwrap().plain(), "eye_*,lid_*");
        assert_eq!(param("[1, 2.5]").unwrap().plain(), "1,2.5");
        assert_eq!(param("[]").unwrap().plain(), "");
        assert_eq!(param("1979-05-27T07:32:00Z").unwrap().plain(), "1979-05-27T07:32:00Z");
    }

    #[test]
    fn floats_round_trip_through_plain_text() {
        for f in [0.1, 1.0 / 3.0, 1e-300, 6.02e23, -0.0] {
            let text = ParamValue::Scalar(Scalar::Float(f)).plain();
            assert_eq!(text.parse::<f64>().unwrap().to_bits(), f.to_bits(), "{text}");
        }
    }

    #[test]
    fn nested_values_are_refused() {
        assert_eq!(param("{ a = 1 }"), Err(NotAParam::Table));
        assert_eq!(param("[[1], [2]]"), Err(NotAParam::NestedArray));
        assert_eq!(param("[{ a = 1 }]"), Err(NotAParam::ArrayOfTables));
    }

    #[test]
    fn canonical_forms_ignore_declaration_order() {
        let a: Params = vec![("b".into(), param("1").unwrap()), ("a".into(), param("\"x\"").unwrap())];
        let b: Params = vec![("a".into(), param("\"x\"").unwrap()), ("b".into(), param("1").unwrap())];
        assert_eq!(canonical_json(&a), canonical_json(&b));
        assert_eq!(
            serde_json::to_string(&canonical_tagged(&a)).unwrap(),
            serde_json::to_string(&canonical_tagged(&b)).unwrap()
        );
    }

    #[test]
    fn tagged_form_distinguishes_types() {
        let int = serde_json::to_string(&param("1").unwrap().tagged()).unwrap();
        let float = serde_json::to_string(&param("1.0").unwrap().tagged()).unwrap();
        let string = serde_json::to_string(&param("\"1\"").unwrap().tagged()).unwrap();
        assert_ne!(int, float);
        assert_ne!(int, string);
        assert_ne!(float, string);
    }

    #[test]
    fn non_finite_floats_survive_json() {
        assert_eq!(param("nan").unwrap().json(), serde_json::json!("NaN"));
        assert_eq!(param("-inf").unwrap().json(), serde_json::json!("-inf"));
    }
}
