//! The malformed-sweep corpus `tests/malformed/` through the library, without the binary: every
//! sweep file there is refused by what `chainsweep validate` calls as bad input (exit code 2),
//! naming the field its expectation names. The expectations are `tests/malformed/expected.json`,
//! which `tests/test_malformed.py` reads too (it runs the same files through the binary): one
//! definition of each. A new file of the corpus is picked up here without a change; it needs an
//! entry in `expected.json`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use chainsweep::engine;
use chainsweep::error::Error;
use chainsweep::numerics::auto::pilot_points;
use chainsweep::EXIT_BAD_INPUT;

/// The corpus folder.
const CORPUS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/malformed");

/// The expectations file in the corpus folder (the one `.json` file there that is no sweep).
const EXPECTATIONS: &str = "expected.json";

/// How one file must be refused.
#[derive(Debug)]
struct Expected {
    /// The exact field the error names (empty where it names none).
    field: String,
    /// Text the error (`field `FIELD`: MESSAGE`, without the file name) must contain.
    contains: String,
}

/// The expectations, by file stem.
fn expectations() -> BTreeMap<String, Expected> {
    let path = Path::new(CORPUS).join(EXPECTATIONS);
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let doc: serde_json::Value = serde_json::from_str(&text)
        .unwrap_or_else(|e| panic!("{} is not valid JSON: {e}", path.display()));
    let files = doc
        .get("files")
        .and_then(|f| f.as_object())
        .unwrap_or_else(|| panic!("{}: no object `files`", path.display()));
    files
        .iter()
        .map(|(stem, e)| {
            let text = |key: &str| {
                e.get(key)
                    .and_then(|v| v.as_str())
                    .unwrap_or_else(|| {
                        panic!("{}: `files.{stem}.{key}` is not a string", path.display())
                    })
                    .to_string()
            };
            let expected = Expected {
                field: text("field"),
                contains: text("contains"),
            };
            (stem.clone(), expected)
        })
        .collect()
}

/// The sweep files of the corpus (every `.json` file but the expectations), sorted.
fn corpus() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(CORPUS)
        .unwrap_or_else(|e| panic!("cannot list {CORPUS}: {e}"))
        .map(|entry| entry.expect("a directory entry").path())
        .filter(|p| p.is_file() && p.extension().is_some_and(|x| x == "json"))
        .filter(|p| p.file_name().is_some_and(|n| n != EXPECTATIONS))
        .collect();
    files.sort();
    files
}

fn stem(path: &Path) -> String {
    path.file_stem()
        .expect("a file name")
        .to_string_lossy()
        .into_owned()
}

/// What `chainsweep validate FILE` does (`cli::cmd_validate`), printing nothing: load the sweep
/// and expand its grid (`engine::load_showing`), then, for `integrator: auto`, choose the pilot
/// points (the one step of its report that can fail).
fn validate(path: &Path) -> Result<(), Error> {
    let (sweep, grid) = engine::load_showing(path, &|_, _| {})?;
    if let Some(spec) = sweep.auto {
        pilot_points(&sweep, &grid, spec.pilot_points)?;
    }
    Ok(())
}

/// Why `path` is not refused as `expected` says, if it is not.
fn check(path: &Path, expected: &Expected) -> Option<String> {
    let name = path.display();
    let err = match validate(path) {
        Ok(()) => {
            return Some(format!(
                "{name}: accepted, expected a refusal naming field `{}`",
                expected.field
            ))
        }
        Err(e) => e,
    };
    if err.exit_code() != EXIT_BAD_INPUT {
        return Some(format!(
            "{name}: refused with exit code {} (expected {EXIT_BAD_INPUT}, bad input): {err}",
            err.exit_code()
        ));
    }
    let Error::Input { field, message, .. } = err else {
        return Some(format!("{name}: refused, but not as bad input: {err}"));
    };
    // The error as the command prints it, less the file name (which could hold the text sought).
    let text = Error::Input {
        file: None,
        field: field.clone(),
        message,
    }
    .to_string();
    if field != expected.field {
        return Some(format!(
            "{name}: refused naming field `{field}`, expected field `{}`: {text}",
            expected.field
        ));
    }
    if !text.contains(&expected.contains) {
        return Some(format!(
            "{name}: the error does not contain {:?}: {text}",
            expected.contains
        ));
    }
    None
}

#[test]
fn every_file_has_an_expectation_and_every_expectation_a_file() {
    let files = corpus();
    assert!(
        !files.is_empty(),
        "the corpus {CORPUS} holds no sweep files"
    );
    let expected = expectations();
    assert!(
        !expected.is_empty(),
        "{CORPUS}/{EXPECTATIONS} lists no files"
    );
    let stems: Vec<String> = files.iter().map(|p| stem(p)).collect();
    let unexpected: Vec<&String> = stems
        .iter()
        .filter(|s| !expected.contains_key(*s))
        .collect();
    let missing: Vec<&String> = expected.keys().filter(|s| !stems.contains(s)).collect();
    assert!(
        unexpected.is_empty(),
        "corpus files without an entry in {CORPUS}/{EXPECTATIONS}: {unexpected:?}"
    );
    assert!(
        missing.is_empty(),
        "entries of {CORPUS}/{EXPECTATIONS} without a file {CORPUS}/NAME.json: {missing:?}"
    );
}

#[test]
fn every_malformed_file_is_refused_naming_its_field() {
    let files = corpus();
    assert!(
        !files.is_empty(),
        "the corpus {CORPUS} holds no sweep files"
    );
    let expected = expectations();
    let mut failures = Vec::new();
    for path in &files {
        match expected.get(&stem(path)) {
            None => failures.push(format!("{}: no entry in {EXPECTATIONS}", path.display())),
            Some(e) => failures.extend(check(path, e)),
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} malformed sweep files not refused as expected:\n  {}",
        failures.len(),
        files.len(),
        failures.join("\n  ")
    );
    eprintln!("{} malformed sweep files refused as expected", files.len());
}
