//! Dotted field paths into the base scene (`physics.damping_kg_s`, `record.probes[1].cylinder`):
//! splitting, looking up, checking and setting them; the unit and the name a field's path gives;
//! reading a JSON value with the failing field named.

use serde_json::{Map, Value};

use crate::error::{Error, Result};

/// Deserialises `value` as `T`, naming the failing field (prefixed by `prefix`) on error
/// ([`from_ref_at`] of it).
pub fn from_value_at<T: serde::de::DeserializeOwned>(value: Value, prefix: &str) -> Result<T> {
    from_ref_at(&value, prefix)
}

/// [`from_value_at`] reading a borrowed value (no copy of it is made). Read plainly first, and
/// again tracking the path only when that fails (tracking it costs a third of a grid's expansion).
pub fn from_ref_at<'de, T: serde::de::Deserialize<'de>>(
    value: &'de Value,
    prefix: &str,
) -> Result<T> {
    if let Ok(t) = T::deserialize(value) {
        return Ok(t);
    }
    serde_path_to_error::deserialize::<_, T>(value).map_err(|e| {
        use serde_path_to_error::Segment;
        let mut path = e.path().to_string();
        if path == "." {
            path.clear();
        }
        // Inside a tagged enum (an integrator, a probe) the path stops at the enum: the field
        // whose value the message describes is named when it is the only one.
        let mut at = Some(value);
        for s in e.path().iter() {
            at = match (at, s) {
                (Some(Value::Object(m)), Segment::Map { key }) => m.get(key),
                (Some(Value::Array(a)), Segment::Seq { index }) => a.get(*index),
                _ => None,
            };
        }
        let message = e.into_inner().to_string();
        if let Some(key) = at.and_then(|v| offending_key(v, &message)) {
            path = join_path(&path, &key);
        }
        Error::input(join_path(prefix, &path), message)
    })
}

/// The one field of the object `object` whose value a serde "invalid type" or "invalid value"
/// `message` describes (`invalid type: string "x", expected f64` names the field holding `"x"`);
/// `None` when the message is of another kind, or no field or several fit it.
pub(super) fn offending_key(object: &Value, message: &str) -> Option<String> {
    let Value::Object(fields) = object else {
        return None;
    };
    let rest = message
        .strip_prefix("invalid type: ")
        .or_else(|| message.strip_prefix("invalid value: "))?;
    let (unexpected, _) = rest.rsplit_once(", expected ")?;
    let fits = |v: &Value| match v {
        Value::String(s) => unexpected == format!("string {s:?}"),
        Value::Bool(b) => unexpected == format!("boolean `{b}`"),
        Value::Number(n) => {
            let shown = unexpected
                .strip_prefix("integer `")
                .or_else(|| unexpected.strip_prefix("floating point `"))
                .and_then(|t| t.strip_suffix('`'))
                .and_then(|t| t.parse::<f64>().ok());
            shown.is_some() && n.as_f64() == shown
        }
        Value::Array(_) => unexpected == "sequence",
        Value::Object(_) => unexpected == "map",
        Value::Null => unexpected == "null" || unexpected == "unit value",
    };
    let mut found = fields.iter().filter(|(_, v)| fits(v)).map(|(k, _)| k);
    match (found.next(), found.next()) {
        (Some(k), None) => Some(k.clone()),
        _ => None,
    }
}

pub(super) fn join_path(prefix: &str, path: &str) -> String {
    match (prefix.is_empty(), path.is_empty()) {
        (true, _) => path.to_string(),
        (false, true) => prefix.to_string(),
        (false, false) if path.starts_with('[') => format!("{prefix}{path}"),
        (false, false) => format!("{prefix}.{path}"),
    }
}

pub use crate::record::names::{human_name, units_of};

/// The name a field goes by where none is given: its path's last part that is not an index
/// (`chain.mass_factors.3` → `mass_factors`).
pub fn field_name(field: &str) -> String {
    split_path(field)
        .into_iter()
        .rev()
        .find(|s| s.parse::<usize>().is_err())
        .unwrap_or_default()
}

/// Splits a dotted field path into segments; `a.b[2].c` and `a.b.2.c` are the same path.
pub fn split_path(path: &str) -> Vec<String> {
    let mut out = Vec::new();
    for part in path.split('.') {
        let mut rest = part;
        if let Some(i) = rest.find('[') {
            out.push(rest[..i].to_string());
            rest = &rest[i..];
            while let Some(stripped) = rest.strip_prefix('[') {
                match stripped.find(']') {
                    Some(j) => {
                        out.push(stripped[..j].to_string());
                        rest = &stripped[j + 1..];
                    }
                    None => {
                        out.push(stripped.to_string());
                        rest = "";
                    }
                }
            }
            if !rest.is_empty() {
                out.push(rest.to_string());
            }
        } else {
            out.push(rest.to_string());
        }
    }
    out
}

fn describe_keys(v: &Value) -> String {
    match v {
        Value::Object(m) => {
            let keys: Vec<&str> = m.keys().map(|k| k.as_str()).collect();
            format!("the fields there are: {}", keys.join(", "))
        }
        Value::Array(a) => format!(
            "it is a list of {} entries (indices 0..{})",
            a.len(),
            a.len()
        ),
        _ => "it is a plain value with no fields".to_string(),
    }
}

/// Finds the value at `path` in `root`, or explains where the path stops existing.
pub fn lookup<'a>(root: &'a Value, path: &str) -> std::result::Result<&'a Value, String> {
    let mut cur = root;
    let mut walked = String::new();
    for seg in split_path(path) {
        let next = match cur {
            Value::Object(m) => m.get(&seg),
            Value::Array(a) => seg.parse::<usize>().ok().and_then(|i| a.get(i)),
            _ => None,
        };
        match next {
            Some(n) => {
                cur = n;
                if !walked.is_empty() {
                    walked.push('.');
                }
                walked.push_str(&seg);
            }
            None => {
                let at = if walked.is_empty() {
                    "the scene".to_string()
                } else {
                    format!("`{walked}`")
                };
                return Err(format!(
                    "`{path}` is not a field of the base scene: `{seg}` does not exist in {at}; {}",
                    describe_keys(cur)
                ));
            }
        }
    }
    Ok(cur)
}

/// Checks that an axis can set `path` in `root`: along it every existing value is an object (a
/// missing key is created when values are applied: the normalised base leaves out fields that hold
/// their defaults) or a list that has the index. Whether the field exists in the scene is then
/// decided at every grid point, which names the axis and the allowed fields.
pub fn check_settable(root: &Value, path: &str) -> std::result::Result<(), String> {
    let mut cur = root;
    for seg in split_path(path) {
        cur = match cur {
            Value::Object(m) => match m.get(&seg) {
                Some(next) => next,
                None => return Ok(()),
            },
            Value::Null => return Ok(()),
            Value::Array(a) => match seg.parse::<usize>().ok().and_then(|i| a.get(i)) {
                Some(next) => next,
                None => return lookup(root, path).map(|_| ()),
            },
            _ => return lookup(root, path).map(|_| ()),
        };
    }
    Ok(())
}

/// Sets the value at `path` in `root` (checked by [`check_settable`]), creating the objects
/// missing along it.
pub fn set_path(root: &mut Value, path: &str, value: Value) {
    // An axis that sets no field (a fit's data sets, a search's evaluations) sets nothing.
    if path.is_empty() {
        return;
    }
    let mut cur = root;
    for seg in split_path(path) {
        if cur.is_null() {
            *cur = Value::Object(Map::new());
        }
        cur = match cur {
            Value::Object(m) => m.entry(seg).or_insert(Value::Null),
            Value::Array(a) => {
                let i: usize = seg.parse().expect("path checked at parse time");
                &mut a[i]
            }
            _ => unreachable!("path checked at parse time"),
        };
    }
    *cur = value;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fields_name_says_its_unit_and_its_words() {
        assert_eq!(
            units_of("excitation.drive.force_n.harmonic.frequency_hz"),
            "Hz"
        );
        assert_eq!(units_of("physics.damping_kg_s"), "kg/s");
        assert_eq!(units_of("striker_velocity_m_s"), "m/s");
        assert_eq!(
            units_of("chain.cylinder.mass.heavy_cylinders.mass_ratio"),
            "1"
        );
        assert_eq!(human_name("damping_kg_s"), "damping");
        assert_eq!(human_name("frequency_hz"), "frequency");
        assert_eq!(human_name("mass_ratio"), "mass ratio");
        assert_eq!(human_name("seed"), "seed");
    }

    #[test]
    fn units_follow_suffixes() {
        assert_eq!(units_of("physics.damping_kg_s"), "kg/s");
        assert_eq!(units_of("striker_velocity_m_s"), "m/s");
        assert_eq!(units_of("duration_s"), "s");
        assert_eq!(units_of("chain.cylinders"), "1");
        assert_eq!(units_of("chain.cylinder.density_kg_m3"), "kg/m^3");
    }

    #[test]
    fn paths_split_on_dots_and_brackets() {
        assert_eq!(
            split_path("record.probes[1].cylinder"),
            vec!["record", "probes", "1", "cylinder"]
        );
        assert_eq!(split_path("a.b"), vec!["a", "b"]);
    }
}
