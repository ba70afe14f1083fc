//! Recorded drive waveforms named by path: a CSV file of two columns (time in s, value) or an HDF5
//! file (`dataset`: an `(n, 2)` array, or a group holding `times_s` and `values`), read into the
//! scene's samples when the sweep is read, so that the scene a run hashes and stores holds the
//! samples themselves (a changed file is a different run), the sweep text an output file keeps
//! holds them too (it is read again without the file), and the solver never reads files.

use std::path::Path;

use serde_json::Value;

use super::data_files::{hdf5_reader, is_hdf5, values_in, Object};
use crate::error::{Error, Result};
use chainsweep_solver::chain::drive::MAX_RECORDED_SAMPLES;

/// The drive keys whose waveform may be a recording.
const DRIVE_KEYS: [&str; 3] = ["force_n", "actuator_m", "base_m"];

/// Reads every recording of `base` named by `path` (relative paths from `dir`) into its
/// `times_s` and `values`, and says whether there was one; errors name the field under `base`.
pub(crate) fn resolve(base: &mut Value, dir: &Path) -> Result<bool> {
    let mut read_any = false;
    for key in DRIVE_KEYS {
        let Some(recorded) = base
            .pointer_mut(&format!("/excitation/drive/{key}/recorded"))
            .and_then(Value::as_object_mut)
        else {
            continue;
        };
        let field = format!("base.excitation.drive.{key}.recorded");
        let Some(path) = recorded.get("path") else {
            continue;
        };
        let Some(path) = path.as_str().map(str::to_string) else {
            return Err(input(
                &format!("{field}.path"),
                "must be a file name (a string)",
            ));
        };
        if recorded.contains_key("times_s") || recorded.contains_key("values") {
            return Err(input(
                &field,
                "give either path (a file holding the samples) or times_s and values, not both",
            ));
        }
        let dataset = match recorded.get("dataset") {
            None => None,
            Some(Value::String(d)) => Some(d.clone()),
            Some(_) => return Err(input(&format!("{field}.dataset"), "must be a string")),
        };
        let full = dir.join(&path);
        let (times, values) = read(&full, dataset.as_deref(), &field)?;
        recorded.remove("path");
        recorded.remove("dataset");
        recorded.insert("times_s".into(), times.into());
        recorded.insert("values".into(), values.into());
        read_any = true;
    }
    Ok(read_any)
}

/// The sweep file `text` with every recording it names by path read into its samples (relative
/// paths from `dir`), as the text the sweep keeps and stores: so that an output file, re-read by
/// `status`, `merge` or a resume anywhere, needs no file beside it and holds what was run.
/// `None` when the file names no recording (or is not JSON: the parser reports that).
pub(crate) fn inline_text(text: &str, dir: &Path) -> Result<Option<String>> {
    let stripped = text.strip_prefix('\u{feff}').unwrap_or(text);
    let Ok(mut raw) = super::parse_without_duplicate_keys(stripped) else {
        return Ok(None);
    };
    let Some(base) = raw.get_mut("base") else {
        return Ok(None);
    };
    let names_a_file = DRIVE_KEYS.iter().any(|key| {
        base.pointer(&format!("/excitation/drive/{key}/recorded/path"))
            .is_some()
    });
    if !names_a_file {
        return Ok(None);
    }
    resolve(base, dir)?;
    Ok(Some(
        serde_json::to_string_pretty(&raw).expect("a JSON value serialises"),
    ))
}

fn input(field: &str, message: impl Into<String>) -> Error {
    Error::Input {
        file: None,
        field: field.to_string(),
        message: message.into(),
    }
}

/// The samples of the file at `path`: HDF5 by its signature, else CSV.
fn read(path: &Path, dataset: Option<&str>, field: &str) -> Result<(Vec<f64>, Vec<f64>)> {
    let shown = path.display();
    let meta = std::fs::metadata(path).map_err(|e| {
        input(
            &format!("{field}.path"),
            format!("cannot read the recording {shown}: {e}"),
        )
    })?;
    if !meta.is_file() {
        return Err(input(
            &format!("{field}.path"),
            format!("{shown} is not a regular file"),
        ));
    }
    if is_hdf5(path) {
        read_hdf5(path, dataset, field)
    } else {
        if dataset.is_some() {
            return Err(input(
                &format!("{field}.dataset"),
                format!("{shown} is not an HDF5 file: a CSV recording has no dataset"),
            ));
        }
        // Two numbers a line of at most ~60 bytes: a file larger than this cannot hold a recording
        // within the sample limit, and is refused before it is read.
        let most = 64 * MAX_RECORDED_SAMPLES as u64;
        if meta.len() > most {
            return Err(input(
                &format!("{field}.path"),
                format!("{shown} holds {} bytes, more than a recording of at most {MAX_RECORDED_SAMPLES} samples can ({most})", meta.len()),
            ));
        }
        let text = std::fs::read_to_string(path).map_err(|e| {
            input(
                &format!("{field}.path"),
                format!("cannot read the recording {shown}: {e}"),
            )
        })?;
        read_csv(&text, &format!("{field}.path"), &shown.to_string())
    }
}

/// The lines of a data file that hold something (blank lines and lines starting with `#`
/// skipped): the line's number from 1, its text, its cells (split at commas, semicolons or white
/// space) and their numbers (`None`: a cell is no number, as in a header). Recorded drives and a
/// fit's data files are read through it.
pub(super) fn csv_lines(
    text: &str,
) -> impl Iterator<Item = (usize, &str, Vec<&str>, Option<Vec<f64>>)> {
    text.lines().enumerate().filter_map(|(k, line)| {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            return None;
        }
        let cells: Vec<&str> = line
            .split(|c: char| c == ',' || c == ';' || c.is_whitespace())
            .filter(|c| !c.is_empty())
            .collect();
        let numbers = cells.iter().map(|c| c.parse::<f64>().ok()).collect();
        Some((k + 1, line, cells, numbers))
    })
}

/// Two columns, time in s and value, separated by a comma (or white space); blank lines and lines
/// starting with `#` are skipped, and so is one header line before the first numbers.
fn read_csv(text: &str, field: &str, shown: &str) -> Result<(Vec<f64>, Vec<f64>)> {
    let (mut times, mut values) = (Vec::new(), Vec::new());
    let mut header_allowed = true;
    for (line_no, line, _, numbers) in csv_lines(text) {
        match numbers {
            Some(n) if n.len() == 2 => {
                times.push(n[0]);
                values.push(n[1]);
                header_allowed = false;
            }
            None if header_allowed => header_allowed = false,
            _ => {
                return Err(input(
                    field,
                    format!(
                    "{shown}, line {line_no}: want two numbers, time in s and value, got {line:?}"
                ),
                ))
            }
        }
        if times.len() > MAX_RECORDED_SAMPLES {
            return Err(input(
                field,
                format!("{shown} holds more than {MAX_RECORDED_SAMPLES} samples"),
            ));
        }
    }
    Ok((times, values))
}

fn read_hdf5(path: &Path, dataset: Option<&str>, field: &str) -> Result<(Vec<f64>, Vec<f64>)> {
    let shown = path.display().to_string();
    let dataset_field = format!("{field}.dataset");
    let Some(name) = dataset else {
        return Err(input(
            &dataset_field,
            format!("{shown} is an HDF5 file: name the dataset ((n, 2): time in s, value) or the group (holding times_s and values) that holds the recording"),
        ));
    };
    let hdf = |e: String| input(&dataset_field, format!("{shown}: {e}"));
    let h5 = hdf5_reader().map_err(hdf)?;
    let too_many = |n: usize| {
        input(
            &dataset_field,
            format!("{shown}:{name} holds {n} samples, more than {MAX_RECORDED_SAMPLES}"),
        )
    };
    if h5.object(path, name).map_err(hdf)? == Object::Group {
        let column = |c: &str| -> Result<Vec<f64>> {
            let fits = |s: &[usize]| values_in(s) <= MAX_RECORDED_SAMPLES;
            let a = h5
                .read_f64(path, &format!("{name}/{c}"), &fits)
                .map_err(hdf)?;
            a.values.ok_or_else(|| too_many(values_in(&a.shape)))
        };
        return Ok((column("times_s")?, column("values")?));
    }
    let is_recording = |s: &[usize]| s.len() == 2 && s[1] == 2 && s[0] <= MAX_RECORDED_SAMPLES;
    let a = h5.read_f64(path, name, &is_recording).map_err(hdf)?;
    let shape = a.shape;
    if shape.len() != 2 || shape[1] != 2 {
        return Err(input(
            &dataset_field,
            format!("{shown}:{name} has shape {shape:?}: want (n, 2), time in s and value"),
        ));
    }
    let Some(flat) = a.values else {
        return Err(too_many(shape[0]));
    };
    Ok((
        flat.iter().step_by(2).copied().collect(),
        flat.iter().skip(1).step_by(2).copied().collect(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_with_a_header_and_comments() {
        let (t, v) = read_csv("# a drive\ntime_s,value\n0,1\n0.5, 2\n\n1 3\n", "f", "x").unwrap();
        assert_eq!(t, vec![0.0, 0.5, 1.0]);
        assert_eq!(v, vec![1.0, 2.0, 3.0]);
        let e = read_csv("0,1\n0.5\n", "f", "x").unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
    }
}
