//! Every error of a sweep file in one pass (`chainsweep validate`), where [`super::Sweep::parse`]
//! stops at the first.
//!
//! serde stops at the first error of a value, so a value is read again after each error with the
//! offending part taken out ([`from_value_collecting`]): a misspelt field is dropped, a value of
//! the wrong type is dropped, a list element that cannot be read is dropped. The next read then
//! finds the next error. Errors a removal itself causes (a required field taken out) are not
//! reported; the removal moves up to the enclosing object or list element instead.
//!
//! Sections whose structure is sound are then checked as the parser checks them (the base
//! scene, limits, every axis on its own, the search). The grid points of a file that parses are
//! the grid's to check (`Grid::point_errors`).

use serde::de::DeserializeOwned;
use serde_json::Value;
use serde_path_to_error::Segment;

use super::{join_path, parse_limits, read_json, Sweep, SweepFile};
use crate::error::Error;

/// Most errors listed: beyond this the file is better fixed and validated again.
pub const MOST_ERRORS: usize = 50;

/// Most reads of one value: every read drops a part of it, so this bounds the work on a file of
/// many errors (each found error costs one read).
const MOST_READS: usize = MOST_ERRORS + 10;

/// One step of a path into a JSON value.
#[derive(Debug, Clone, PartialEq)]
enum Step {
    Key(String),
    Index(usize),
}

/// The steps of an error's path, up to a tagged enum's variant or an unknown segment (the error
/// lies within what precedes them).
fn steps(path: &serde_path_to_error::Path) -> Vec<Step> {
    let mut out = Vec::new();
    for s in path.iter() {
        match s {
            Segment::Seq { index } => out.push(Step::Index(*index)),
            Segment::Map { key } => out.push(Step::Key(key.clone())),
            Segment::Enum { .. } | Segment::Unknown => break,
        }
    }
    out
}

fn path_text(steps: &[Step]) -> String {
    let mut out = String::new();
    for s in steps {
        match s {
            Step::Key(k) => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(k);
            }
            Step::Index(i) => out.push_str(&format!("[{i}]")),
        }
    }
    out
}

/// List elements taken out so far, to name later errors by their index in the file.
#[derive(Default)]
struct Removed {
    /// (the list's path in the file, the element's index in the file)
    elements: Vec<(Vec<Step>, usize)>,
}

impl Removed {
    /// `steps` (indices in the value as it is now) as indices in the file.
    fn original(&self, steps: &[Step]) -> Vec<Step> {
        let mut out: Vec<Step> = Vec::with_capacity(steps.len());
        for s in steps {
            match s {
                Step::Key(k) => out.push(Step::Key(k.clone())),
                Step::Index(i) => {
                    let mut gone: Vec<usize> = self
                        .elements
                        .iter()
                        .filter(|(list, _)| *list == out)
                        .map(|(_, j)| *j)
                        .collect();
                    gone.sort_unstable();
                    let mut j = *i;
                    for g in gone {
                        if g <= j {
                            j += 1;
                        }
                    }
                    out.push(Step::Index(j));
                }
            }
        }
        out
    }
}

/// Takes out of `root` the part at `steps` (current indices); whether there was one.
fn take_out(root: &mut Value, steps: &[Step]) -> bool {
    let Some((last, parent)) = steps.split_last() else {
        return false;
    };
    let mut cur = root;
    for s in parent {
        cur = match (cur, s) {
            (Value::Object(m), Step::Key(k)) => match m.get_mut(k) {
                Some(v) => v,
                None => return false,
            },
            (Value::Array(a), Step::Index(i)) => match a.get_mut(*i) {
                Some(v) => v,
                None => return false,
            },
            _ => return false,
        };
    }
    match (cur, last) {
        (Value::Object(m), Step::Key(k)) => m.remove(k).is_some(),
        (Value::Array(a), Step::Index(i)) if *i < a.len() => {
            a.remove(*i);
            true
        }
        _ => false,
    }
}

/// The field an "unknown field `x`, expected …" message names.
fn unknown_field(message: &str) -> Option<&str> {
    message
        .strip_prefix("unknown field `")
        .and_then(|rest| rest.split('`').next())
}

/// The part of `root` at `steps`.
fn value_at<'a>(root: &'a Value, steps: &[Step]) -> Option<&'a Value> {
    steps.iter().try_fold(root, |cur, s| match (cur, s) {
        (Value::Object(m), Step::Key(k)) => m.get(k),
        (Value::Array(a), Step::Index(i)) => a.get(*i),
        _ => None,
    })
}

/// The field a "missing field `x`" message names.
fn missing_field(message: &str) -> Option<&str> {
    message
        .strip_prefix("missing field `")
        .and_then(|rest| rest.split('`').next())
}

/// Reads `value` as `T`, pushing onto `errors` every error found (fields named with `prefix`,
/// as [`super::from_value_at`] names them) and taking the offending parts out between reads.
/// What could be read once they were out (`None` when nothing could).
pub fn from_value_collecting<T: DeserializeOwned>(
    mut value: Value,
    prefix: &str,
    errors: &mut Vec<Error>,
) -> Option<T> {
    let mut removed = Removed::default();
    // Parts taken out (paths in the file): a later "missing field" of one is the removal's
    // doing, not the file's.
    let mut taken: Vec<Vec<Step>> = Vec::new();
    let found_before = errors.len();
    for _ in 0..MOST_READS {
        let e = match serde_path_to_error::deserialize::<_, T>(&value) {
            Ok(t) => return Some(t),
            Err(e) => e,
        };
        let mut at = steps(e.path());
        let message = e.into_inner().to_string();
        // Inside a tagged enum (a probe, an integrator) the path stops at the enum: an unknown
        // field is named by the message, and is the part to take out.
        if let Some(key) = unknown_field(&message) {
            if at.last() != Some(&Step::Key(key.to_string()))
                && value_at(&value, &at).is_some_and(|v| v.get(key).is_some())
            {
                at.push(Step::Key(key.to_string()));
            }
        }
        // The same for a field of the wrong type: the field whose value the message describes.
        if let Some(key) =
            value_at(&value, &at).and_then(|v| super::paths::offending_key(v, &message))
        {
            at.push(Step::Key(key));
        }
        let in_file = removed.original(&at);
        // A missing field is reported at the object that lacks it: that object goes.
        let caused_by_removal = missing_field(&message).is_some_and(|field| {
            let mut p = in_file.clone();
            p.push(Step::Key(field.to_string()));
            taken.contains(&p)
        });
        if !caused_by_removal {
            errors.push(Error::input(
                join_path(prefix, &path_text(&in_file)),
                message.clone(),
            ));
            if errors.len() - found_before >= MOST_ERRORS {
                return None;
            }
        }
        if at.is_empty() || !take_out(&mut value, &at) {
            return None;
        }
        if let Some((Step::Index(i), list)) = in_file.split_last() {
            removed.elements.push((list.to_vec(), *i));
        }
        taken.push(in_file);
    }
    None
}

/// Every error of the sweep file `text` that can be found in one pass: syntax (the first only,
/// as nothing after it can be read), structure, and each section's values. Empty when the file
/// parses ([`Sweep::parse_in`], the paths it names read from `dir`, the file's folder); its grid
/// points are checked then ([`crate::grid`]).
pub fn diagnose(text: &str, dir: &std::path::Path) -> Vec<Error> {
    // The files the sweep names are read first, as `Sweep::parse_in` reads them: an error in one
    // is the error to report (checked without them, the file's `path` keys would be unknown).
    let inlined = match super::inline_files(text, dir) {
        Ok(inlined) => inlined,
        Err(e) => return vec![e],
    };
    let text = inlined.as_deref().unwrap_or(text);
    let stripped = text.strip_prefix('\u{feff}').unwrap_or(text);
    let raw = match super::parse_without_duplicate_keys(stripped) {
        Ok(raw) => raw,
        Err(_) => return read_json(text).err().into_iter().collect(),
    };
    let mut errors = Vec::new();
    let file = from_value_collecting::<SweepFile>(raw, "", &mut errors);
    let well_formed = errors.is_empty();
    if let Some(file) = file {
        check_sections(file, well_formed, &mut errors);
    }
    if errors.is_empty() {
        // What only the whole file shows (a zipped group's lengths, names shared by axes).
        if let Err(e) = Sweep::parse_in(text, dir) {
            errors.push(e);
        }
    }
    errors.truncate(MOST_ERRORS);
    errors
}

/// The sweep of `text` read without its `limits` block, when that is all that stops it being
/// read: the grid points do not depend on the limits, so their errors can be listed beside the
/// limits' own.
pub fn parse_without_limits(text: &str, dir: &std::path::Path) -> Option<Sweep> {
    let stripped = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut raw = super::parse_without_duplicate_keys(stripped).ok()?;
    raw.as_object_mut()?.remove("limits")?;
    Sweep::parse_in(&raw.to_string(), dir).ok()
}

/// The sections of a file read as far as its structure allows (`well_formed`: wholly), each
/// checked as the parser checks it.
fn check_sections(mut file: SweepFile, well_formed: bool, errors: &mut Vec<Error>) {
    // Derived fields stand in as numbers while the base is checked; one that does not parse is
    // the base's error.
    if let Err(e) = super::expr::extract(&mut file.base, &[]) {
        errors.push(e);
        return;
    }
    let base = match super::normalise_base(file.base, file.record, true) {
        Ok(b) => Some(b),
        Err(es) => {
            errors.extend(es);
            None
        }
    };
    if let Err(e) = parse_limits(file.limits) {
        errors.push(e);
    }
    let Some((base, _, auto)) = base else {
        return;
    };
    let has_search = file.search.is_some() || file.ensemble.is_some() || file.periodic.is_some();
    match super::parse_dims(file.axes, &base, auto.is_some(), has_search, true) {
        Ok(dims) => {
            if let Err(e) = super::check_names_and_fields(&dims) {
                errors.push(e);
            } else if let (Some(s), true) = (file.search, well_formed) {
                // (A search whose structure lost a part names fields by their index: only a
                // whole one is checked further.)
                if let Err(e) = super::search::parse(s, &base, &mut dims.clone()) {
                    errors.push(e);
                }
            } else if let Some(en) = file.ensemble {
                if let Err(e) = super::ensemble::parse(en, &mut base.clone(), &mut dims.clone()) {
                    errors.push(e);
                }
            } else if let Some(p) = file.periodic {
                if let Err(e) = super::periodic::parse(Some(p), &mut base.clone(), &dims, None) {
                    errors.push(e);
                }
            }
        }
        Err(es) => errors.extend(es),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn fields(errors: &[Error]) -> Vec<String> {
        errors
            .iter()
            .map(|e| match e {
                Error::Input { field, .. } => field.clone(),
                other => panic!("not an input error: {other}"),
            })
            .collect()
    }

    #[test]
    fn every_misspelt_field_and_wrong_type_is_named() {
        let text = json!({
            "base": {
                "chain": {"preset": "chain_055", "cylinders": 10},
                "physics": {"gravity": "yes", "damping_kg_s": 0.0, "dampng": 1},
                "striker_velocity_m_s": 1.0,
                "duration_s": 1e-4
            },
            "record": {"probes": [
                {"kind": "gauge_forse", "cylinder": 2},
                {"kind": "gauge_force", "cylinder": 2, "colour": "red"}
            ]},
            "axes": [
                {"field": "physics.damping_kg_s", "values": [0, 1], "nmae": "x"},
                {"field": "striker_velocity_m_s", "range": {"start": 1, "stop": 2, "stpe": 1}}
            ],
            "limits": {"energy_drift_max": -1},
            "axis": []
        })
        .to_string();
        let errors = diagnose(&text, std::path::Path::new("."));
        let f = fields(&errors);
        for expected in [
            "axis",
            "axes[0].nmae",
            "axes[1].range.stpe",
            "base.physics.gravity",
            "base.physics.dampng",
            "record.probes[0].kind",
            "record.probes[1].colour",
            "limits.energy_drift_max",
        ] {
            assert!(
                f.iter().any(|x| x == expected),
                "{expected} not in {errors:?}"
            );
        }
    }

    #[test]
    fn errors_after_a_removed_list_element_keep_their_index_in_the_file() {
        let mut errors = Vec::new();
        let v = json!({"probes": [{"kind": "nope"}, {"kind": "gauge_force", "cylinder": "two"}]});
        let r: Option<chainsweep_solver::RecordSpec> =
            from_value_collecting(v, "record", &mut errors);
        assert_eq!(r.map(|r| r.probes.len()), Some(0));
        let f = fields(&errors);
        assert!(f.contains(&"record.probes[0].kind".to_string()), "{f:?}");
        // (Within a probe, a tagged enum, a wrong type is named at its field, the one holding
        // the value the message describes.)
        assert!(
            f.contains(&"record.probes[1].cylinder".to_string()),
            "{f:?}"
        );
        // The removal of a required field is not reported as the file's missing field.
        assert!(errors
            .iter()
            .all(|e| !e.to_string().contains("missing field")));
    }

    #[test]
    fn a_valid_file_has_no_errors() {
        let ok = json!({
            "base": {
                "chain": {"preset": "chain_055", "cylinders": 10},
                "physics": {"gravity": false, "damping_kg_s": 0.0, "wall": true},
                "striker_velocity_m_s": 1.0,
                "duration_s": 1e-4
            },
            "record": {"probes": [{"kind": "gauge_force", "cylinder": 2}]},
            "axes": [{"field": "physics.damping_kg_s", "values": [0, -1, 2, -3]}]
        });
        // (Its negative dampings are the grid points' errors, found by the grid.)
        let errors = diagnose(&ok.to_string(), std::path::Path::new("."));
        assert!(errors.is_empty(), "{errors:?}");
    }

    #[test]
    fn a_syntax_error_is_the_only_error() {
        let errors = diagnose("{\"base\": {,}", std::path::Path::new("."));
        assert_eq!(errors.len(), 1);
        assert!(errors[0].to_string().contains("not valid JSON"));
    }
}
