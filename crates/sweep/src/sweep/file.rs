//! The sweep file's model as written: its serde types (from which the JSON Schema is derived
//! too), and the reading of its JSON text (a repeated key refused, a syntax error named by the
//! field near it, with a hint at its cause).

use serde::Deserialize;
use serde_json::{Map, Value};

use super::paths::from_value_at;
use super::{
    ensemble, periodic, schema, search, DEFAULT_ENERGY_DRIFT_MAX, DEFAULT_MAX_RUN_SECONDS,
};
use crate::error::{Error, Result};

/// `continuation` as written.
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub(super) struct ContinuationFile {
    /// The name of the dimension along which each point starts from the final state of the one
    /// before it.
    pub(super) axis: String,
    /// `up` (from the dimension's first value to its last, the default) or `down`.
    #[serde(default)]
    pub(super) direction: Direction,
}

/// The direction of a continuation.
#[derive(Deserialize, schemars::JsonSchema, Default, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub(super) enum Direction {
    /// From the dimension's first value to its last.
    #[default]
    Up,
    /// From the dimension's last value to its first.
    Down,
}

/// A chainsweep sweep file: a base scene, what to record, the axes of its grid, failure limits
/// and an optional search.
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(title = "chainsweep sweep file")]
pub(super) struct SweepFile {
    /// The JSON Schema the file follows (for editors); not read otherwise.
    #[serde(default, rename = "$schema")]
    #[allow(dead_code)]
    pub(super) schema: Option<String>,
    /// What the sweep is for.
    #[serde(default)]
    pub(super) description: String,
    /// The scene every grid point starts from.
    #[schemars(with = "schema::BaseScene")]
    pub(super) base: Map<String, Value>,
    /// What is recorded, the same for every run.
    #[serde(default)]
    #[schemars(with = "Option<chainsweep_solver::RecordSpec>")]
    pub(super) record: Option<Map<String, Value>>,
    /// The grid's dimensions.
    #[serde(default)]
    pub(super) axes: Vec<AxisFile>,
    /// When a run counts as failed.
    #[serde(default)]
    pub(super) limits: Option<LimitsFile>,
    /// A search over continuous fields at every point of the axes.
    #[serde(default)]
    pub(super) search: Option<search::SearchFile>,
    /// An ensemble: scene fields drawn from distributions at every point of the axes, and the
    /// statistics (or sensitivities) of chosen summaries over them.
    #[serde(default)]
    pub(super) ensemble: Option<ensemble::EnsembleFile>,
    /// Continuation along one dimension: each point starts from the final state of the one
    /// before it (hysteresis, bistability).
    #[serde(default)]
    pub(super) continuation: Option<ContinuationFile>,
    /// At every point of the axes, the branch of periodic orbits of the driven scene continued in
    /// one scene field, with its stability and bifurcations.
    #[serde(default)]
    pub(super) periodic: Option<periodic::PeriodicFile>,
}

/// When a run counts as failed.
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub(super) struct LimitsFile {
    /// The largest relative energy drift of a run (null: no limit).
    #[serde(default = "default_drift")]
    pub(super) energy_drift_max: Option<f64>,
    /// The wall time, s, after which a run is given up and recorded as failed.
    #[serde(default = "default_max_run_seconds")]
    pub(super) max_run_seconds: Option<f64>,
}

fn default_max_run_seconds() -> Option<f64> {
    Some(DEFAULT_MAX_RUN_SECONDS)
}

fn default_drift() -> Option<f64> {
    Some(DEFAULT_ENERGY_DRIFT_MAX)
}

/// A grid dimension: an axis `{field, values | range, name?}` or a group of axes that advance
/// together, `{zip: [axis, …]}`.
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(extend("oneOf" = [
    {"required": ["field", "values"], "not": {"anyOf": [{"required": ["range"]}, {"required": ["zip"]}]}},
    {"required": ["field", "range"], "not": {"anyOf": [{"required": ["values"]}, {"required": ["zip"]}]}},
    {"required": ["zip"], "not": {"anyOf": [{"required": ["field"]}, {"required": ["values"]}, {"required": ["range"]}]}}
]))]
pub(super) struct AxisFile {
    /// The axis's name in the output (default: the field's last part).
    #[serde(default)]
    pub(super) name: Option<String>,
    /// The scene field the axis sets, as a dotted path (`physics.damping_kg_s`).
    #[serde(default)]
    pub(super) field: Option<String>,
    /// The values the field takes.
    #[serde(default)]
    #[schemars(length(min = 1))]
    pub(super) values: Option<Vec<Value>>,
    /// Evenly spaced values.
    #[serde(default)]
    pub(super) range: Option<RangeFile>,
    /// Axes that advance together (all of one length).
    #[serde(default)]
    #[schemars(length(min = 1))]
    pub(super) zip: Option<Vec<AxisFile>>,
}

/// Evenly spaced values: `step` (stop included when reached) or `num` (both ends included).
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(extend("oneOf" = [{"required": ["step"]}, {"required": ["num"]}]))]
pub(super) struct RangeFile {
    /// The first value.
    pub(super) start: serde_json::Number,
    /// The last value (reached by `num`; by `step` when it divides the span).
    pub(super) stop: serde_json::Number,
    /// The spacing, with the sign of stop − start.
    #[serde(default)]
    pub(super) step: Option<serde_json::Number>,
    /// The number of values.
    #[serde(default)]
    #[schemars(range(min = 1))]
    pub(super) num: Option<u64>,
}

/// The key of the innermost `"key": value` pair that starts before line `line`, column `column`
/// (1-based): names the field where a syntax error sits.
fn field_near(text: &str, offset: usize) -> Option<String> {
    let mut prefix = &text[..offset];
    while let Some(colon) = prefix.rfind(':') {
        let before = prefix[..colon].trim_end();
        if let Some(body) = before.strip_suffix('"') {
            if let Some(start) = body.rfind('"') {
                return Some(body[start + 1..].to_string());
            }
        }
        prefix = &prefix[..colon];
    }
    None
}

/// The byte offset in `text` of serde_json's (1-based line, byte column) position, moved back to
/// the start of the character it falls in: a column may point inside a multi-byte character
/// (typographic quotes, `µ`), and slicing there would panic.
fn error_offset(text: &str, line: usize, column: usize) -> usize {
    let mut offset = 0;
    for (i, l) in text.split_inclusive('\n').enumerate() {
        if i + 1 == line {
            offset += column.min(l.len());
            break;
        }
        offset += l.len();
    }
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    offset
}

/// What to add to serde_json's message so that the user sees the cause.
fn syntax_hint(text: &str, offset: usize, error: &serde_json::Error) -> Option<String> {
    if error.classify() == serde_json::error::Category::Eof {
        return Some("the file ends before its JSON is complete: is it truncated?".into());
    }
    // The offending token starts at or shortly before the reported position.
    let start = text[..offset]
        .char_indices()
        .rev()
        .take(12)
        .last()
        .map_or(offset, |(i, _)| i);
    let mut end = (offset + 16).min(text.len());
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    let near = &text[start..end];
    let out_of_range = error.to_string().starts_with("number out of range");
    if out_of_range
        || ["NaN", "Infinity", "inf", "nan"]
            .iter()
            .any(|w| near.contains(w))
    {
        return Some("numbers must be finite: NaN and infinities are not JSON".into());
    }
    let bad = text[offset..].chars().next()?;
    if matches!(bad, '\u{201c}' | '\u{201d}' | '\u{2018}' | '\u{2019}') {
        return Some(format!(
            "`{bad}` is a typographic quote: JSON strings take plain double quotes (\")"
        ));
    }
    if !bad.is_ascii() {
        return Some(format!(
            "`{bad}` (U+{:04X}) cannot stand there: outside strings JSON is plain ASCII (units belong in field names, not after numbers)",
            bad as u32
        ));
    }
    None
}

/// JSON text as a [`Value`], refusing an object that repeats a key: serde_json keeps the last
/// one silently, so `"gravity": true, "gravity": false` would run without gravity unnoticed.
pub(super) fn parse_without_duplicate_keys(text: &str) -> serde_json::Result<Value> {
    use serde::de::{DeserializeSeed, Deserializer, Error as _, MapAccess, SeqAccess, Visitor};

    struct Strict;

    impl<'de> DeserializeSeed<'de> for Strict {
        type Value = Value;
        fn deserialize<D: Deserializer<'de>>(self, d: D) -> std::result::Result<Value, D::Error> {
            d.deserialize_any(self)
        }
    }

    impl<'de> Visitor<'de> for Strict {
        type Value = Value;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a JSON value")
        }
        fn visit_bool<E>(self, b: bool) -> std::result::Result<Value, E> {
            Ok(Value::Bool(b))
        }
        fn visit_i64<E>(self, n: i64) -> std::result::Result<Value, E> {
            Ok(Value::from(n))
        }
        fn visit_u64<E>(self, n: u64) -> std::result::Result<Value, E> {
            Ok(Value::from(n))
        }
        fn visit_f64<E: serde::de::Error>(self, x: f64) -> std::result::Result<Value, E> {
            serde_json::Number::from_f64(x)
                .map(Value::Number)
                .ok_or_else(|| E::custom("numbers must be finite"))
        }
        fn visit_str<E>(self, s: &str) -> std::result::Result<Value, E> {
            Ok(Value::String(s.to_owned()))
        }
        fn visit_string<E>(self, s: String) -> std::result::Result<Value, E> {
            Ok(Value::String(s))
        }
        fn visit_unit<E>(self) -> std::result::Result<Value, E> {
            Ok(Value::Null)
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> std::result::Result<Value, A::Error> {
            let mut items = Vec::new();
            while let Some(v) = seq.next_element_seed(Strict)? {
                items.push(v);
            }
            Ok(Value::Array(items))
        }
        fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> std::result::Result<Value, A::Error> {
            let mut object = Map::new();
            while let Some(key) = map.next_key::<String>()? {
                if object.contains_key(&key) {
                    return Err(A::Error::custom(format!(
                        "duplicate key `{key}` (each key may appear once in an object)"
                    )));
                }
                let value = map.next_value_seed(Strict)?;
                object.insert(key, value);
            }
            Ok(Value::Object(object))
        }
    }

    let mut de = serde_json::Deserializer::from_str(text);
    let value = Strict.deserialize(&mut de)?;
    de.end()?;
    Ok(value)
}

/// The sweep file's JSON, refusing unknown fields; a syntax error names the field near it.
pub(super) fn read_json(text: &str) -> Result<SweepFile> {
    // Editors on Windows may start a UTF-8 file with a byte-order mark, which JSON does not allow.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let raw: Value = parse_without_duplicate_keys(text).map_err(|e| {
        let offset = error_offset(text, e.line(), e.column());
        let field = match e.classify() {
            serde_json::error::Category::Eof => String::new(),
            _ => field_near(text, offset).unwrap_or_default(),
        };
        let message = match syntax_hint(text, offset, &e) {
            Some(hint) => format!("not valid JSON: {e} ({hint})"),
            None => format!("not valid JSON: {e}"),
        };
        Error::input(field, message)
    })?;
    from_value_at(raw, "")
}
