//! `chainsweep examples`: the example sweep files, embedded in the binary when it is built (so
//! that every documented command works wherever `chainsweep` is installed, the wheel included),
//! listed with their description or copied into a folder with the data files they read.

use std::path::{Path, PathBuf};

use chainsweep::error::{Error, Result};

include!(concat!(env!("OUT_DIR"), "/examples.rs"));

/// An example's name: its path under `sweeps/` without `.json` (`mass-damping`,
/// `examples/trimer`), as `chainsweep.example_path` names it.
fn names() -> impl Iterator<Item = (&'static str, &'static [u8])> {
    EMBEDDED
        .iter()
        .filter_map(|(p, b)| p.strip_suffix(".json").map(|n| (n, *b)))
}

/// The file named `rel` (under `sweeps/`).
fn file(rel: &str) -> Option<&'static [u8]> {
    EMBEDDED.iter().find(|(p, _)| *p == rel).map(|(_, b)| *b)
}

/// Widest description `list` gives, characters (a line of a terminal beside the name).
const DESCRIPTION_CHARS: usize = 90;

/// Every example: its name and the start of its description (to a word, within
/// [`DESCRIPTION_CHARS`]).
pub fn list() -> Vec<(String, String)> {
    names()
        .map(|(name, bytes)| {
            let description = serde_json::from_slice::<serde_json::Value>(bytes)
                .ok()
                .and_then(|v| v.get("description")?.as_str().map(str::to_string))
                .unwrap_or_default();
            let mut shown = String::new();
            for word in description.split_whitespace() {
                if shown.chars().count() + word.chars().count() + 1 > DESCRIPTION_CHARS {
                    shown.push_str(" …");
                    break;
                }
                if !shown.is_empty() {
                    shown.push(' ');
                }
                shown.push_str(word);
            }
            (name.to_string(), shown)
        })
        .collect()
}

/// Every data file a sweep file reads (`path` anywhere in it), relative to it.
fn data_files(v: &serde_json::Value, out: &mut Vec<String>) {
    match v {
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                match (k.as_str(), x) {
                    ("path", serde_json::Value::String(p)) => out.push(p.clone()),
                    _ => data_files(x, out),
                }
            }
        }
        serde_json::Value::Array(a) => a.iter().for_each(|x| data_files(x, out)),
        _ => {}
    }
}

/// Copies the example `name` (or every one, `all`) into `dir` (created if missing), with the data
/// files each reads beside it; the files written. An existing file is never overwritten: the copy
/// is refused before anything is written, naming it.
pub fn copy(name: &str, dir: &Path) -> Result<Vec<PathBuf>> {
    let chosen: Vec<&str> = if name == "all" {
        names().map(|(n, _)| n).collect()
    } else {
        match names().find(|(n, _)| *n == name || n.rsplit('/').next() == Some(name)) {
            Some((n, _)) => vec![n],
            None => {
                let all: Vec<&str> = names().map(|(n, _)| n).collect();
                return Err(Error::input(
                    "NAME",
                    format!(
                        "no example `{name}`; `chainsweep examples` lists them: all, {}",
                        all.join(", ")
                    ),
                ));
            }
        }
    };
    // (source under sweeps/, destination) of every file, all checked before any is written.
    let mut plan: Vec<(String, PathBuf)> = Vec::new();
    for n in chosen {
        let rel = format!("{n}.json");
        // Copied flat into `dir` when one is asked for; `all` keeps the folders.
        let target = |r: &str| -> PathBuf {
            if name == "all" {
                dir.join(r)
            } else {
                dir.join(Path::new(r).file_name().expect("a file name"))
            }
        };
        plan.push((rel.clone(), target(&rel)));
        let v: serde_json::Value =
            serde_json::from_slice(file(&rel).expect("listed")).expect("examples are JSON");
        let mut reads = Vec::new();
        data_files(&v, &mut reads);
        let folder = Path::new(&rel)
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default();
        for r in reads {
            let src = folder.join(&r).to_string_lossy().replace('\\', "/");
            if file(&src).is_some() {
                plan.push((src.clone(), target(&src)));
            }
        }
    }
    if let Some((_, dest)) = plan.iter().find(|(_, d)| d.exists()) {
        return Err(Error::input(
            "DIR",
            format!(
                "{} exists: chainsweep never overwrites a file; copy into another folder, or move it away",
                dest.display()
            ),
        ));
    }
    let mut written = Vec::new();
    for (src, dest) in plan {
        if let Some(parent) = dest.parent() {
            std::fs::create_dir_all(parent).map_err(Error::io("create", parent))?;
        }
        std::fs::write(&dest, file(&src).expect("planned from the embedded files"))
            .map_err(Error::io("write", &dest))?;
        written.push(dest);
    }
    Ok(written)
}
