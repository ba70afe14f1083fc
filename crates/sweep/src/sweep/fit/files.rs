//! The data files a fit names by `path`, CSV or HDF5, read into the sweep file's text: their
//! columns, checked, become the data themselves.

use std::path::Path;

use serde_json::Value;

use super::{bad, MAX_DATA, MAX_FILE_BYTES, MAX_FILE_LINES};
use crate::error::Result;
use crate::sweep::data_files::{hdf5_reader, is_hdf5, values_in, Object};

/// The sweep file's `text` with every data file a fit names by `path` read into its data
/// (relative paths from `dir`), so that the output file keeps the data themselves. `None` when
/// it names none.
pub(crate) fn inline_text(text: &str, dir: &Path) -> Result<Option<String>> {
    let stripped = text.strip_prefix('\u{feff}').unwrap_or(text);
    let Ok(mut raw) = super::super::parse_without_duplicate_keys(stripped) else {
        return Ok(None);
    };
    let Some(search) = raw.get_mut("search").and_then(Value::as_object_mut) else {
        return Ok(None);
    };
    let mut any = false;
    let mut sets: Vec<(String, &mut Value)> = Vec::new();
    if search.contains_key("data") {
        sets.push((
            "search.data".into(),
            search.get_mut("data").expect("present"),
        ));
    } else if let Some(Value::Array(list)) = search.get_mut("data_sets") {
        for (k, d) in list.iter_mut().enumerate() {
            sets.push((format!("search.data_sets[{k}]"), d));
        }
    }
    for (at, set) in sets {
        let Some(items) = set.as_array_mut() else {
            continue;
        };
        for (i, item) in items.iter_mut().enumerate() {
            for kind in ["signal", "spectrum"] {
                let Some(Value::Object(m)) = item.get_mut(kind) else {
                    continue;
                };
                let Some(path) = m.get("path").cloned() else {
                    continue;
                };
                let field = format!("{at}[{i}].{kind}");
                let path = path.as_str().ok_or_else(|| {
                    bad(format!("{field}.path"), "must be a file name (a string)")
                })?;
                let group = match m.get("dataset") {
                    None => None,
                    Some(Value::String(g)) => Some(g.clone()),
                    Some(_) => return Err(bad(format!("{field}.dataset"), "must be a string")),
                };
                let columns: &[&str] = if kind == "signal" {
                    &["time_s", "value", "sigma"]
                } else {
                    &[
                        "frequency_hz",
                        "amplitude",
                        "sigma",
                        "phase_rad",
                        "phase_sigma_rad",
                        "transmission_db",
                    ]
                };
                // A spectrum's second column is its amplitude or its transmission in dB: a CSV
                // file names which in its header (without one, dB would be read as amplitude).
                let header = if kind == "signal" {
                    Header::Optional
                } else {
                    Header::Required
                };
                let table = read_table(&dir.join(path), group.as_deref(), columns, header, &field)?;
                for (name, _) in &table {
                    if m.contains_key(name) {
                        return Err(bad(
                            format!("{field}.{name}"),
                            format!("given both here and as a column of {path}: give it once"),
                        ));
                    }
                }
                // What the data need, from the file or beside it in the sweep: a missing column
                // (a dataset named `values`) said of the file, not as a key the sweep lacks.
                let needed: &[&[&str]] = if kind == "signal" {
                    &[&["time_s"], &["value"]]
                } else {
                    &[&["frequency_hz"], &["amplitude", "transmission_db"]]
                };
                for any_of in needed {
                    let given = |c: &&str| m.contains_key(*c) || table.iter().any(|(n, _)| n == c);
                    if !any_of.iter().any(given) {
                        let within = group
                            .as_deref()
                            .map_or(String::new(), |g| format!(" (group `{g}`)"));
                        return Err(bad(
                            format!("{field}.path"),
                            format!(
                                "{path}{within} holds no {} column (its columns are named {}), nor does the sweep give it",
                                any_of.join(" or "),
                                columns.join(", ")
                            ),
                        ));
                    }
                }
                m.remove("path");
                m.remove("dataset");
                for (name, values) in table {
                    m.insert(name, values);
                }
                any = true;
            }
        }
    }
    Ok(any.then(|| serde_json::to_string_pretty(&raw).expect("a JSON value serialises")))
}

/// Whether a CSV data file must name its columns in a header line.
#[derive(Clone, Copy, PartialEq)]
enum Header {
    /// Without one, the columns are the listed ones, in order.
    Optional,
    /// Its columns could be read more than one way without one.
    Required,
}

/// The named columns of a data file (CSV: a header line naming them, or the first columns in the
/// order of `columns` without one; HDF5: a group, `group` or the root, holding one dataset per
/// column, a scalar dataset one number for every datum, as a number in the sweep gives it).
fn read_table(
    path: &Path,
    group: Option<&str>,
    columns: &[&str],
    header_rule: Header,
    field: &str,
) -> Result<Vec<(String, Value)>> {
    let shown = path.display().to_string();
    let pat = format!("{field}.path");
    let meta = std::fs::metadata(path)
        .map_err(|e| bad(&pat, format!("cannot read the data file {shown}: {e}")))?;
    if !meta.is_file() {
        return Err(bad(&pat, format!("{shown} is not a regular file")));
    }
    if meta.len() > MAX_FILE_BYTES {
        return Err(bad(
            &pat,
            format!(
                "{shown} holds {} bytes, more than {MAX_FILE_BYTES}",
                meta.len()
            ),
        ));
    }
    let table = if is_hdf5(path) {
        let hdf = |e: String| bad(&pat, format!("{shown}: {e}"));
        let h5 = hdf5_reader().map_err(hdf)?;
        let prefix = match group {
            Some(g) => {
                if h5.object(path, g).map_err(hdf)? != Object::Group {
                    return Err(bad(
                        format!("{field}.dataset"),
                        format!("{shown}: it has no group `{g}`"),
                    ));
                }
                format!("{g}/")
            }
            // Opened once here, so that a file that cannot be opened says why rather than
            // holding none of the columns.
            None => {
                h5.object(path, "/").map_err(hdf)?;
                String::new()
            }
        };
        let mut table = Vec::new();
        for c in columns {
            let at = format!("{prefix}{c}");
            if h5.object(path, &at).map_err(hdf)? == Object::Dataset {
                let fits = |s: &[usize]| values_in(s) <= MAX_DATA * 4;
                let a = h5.read_f64(path, &at, &fits).map_err(hdf)?;
                let Some(values) = a.values else {
                    let size = values_in(&a.shape);
                    return Err(bad(
                        &pat,
                        format!("{shown}: {c} holds {size} values, more than a fit takes"),
                    ));
                };
                if let Some(i) = values.iter().position(|x| !x.is_finite()) {
                    return Err(bad(
                        &pat,
                        format!(
                            "{shown}: {c}[{i}] is {}: every datum must be a finite number",
                            values[i]
                        ),
                    ));
                }
                // A scalar dataset: one number for every datum (a sigma).
                let value = match (a.shape.is_empty(), values.as_slice()) {
                    (true, [x]) => Value::from(*x),
                    _ => Value::from(values),
                };
                table.push((c.to_string(), value));
            }
        }
        table
    } else {
        if group.is_some() {
            return Err(bad(
                format!("{field}.dataset"),
                format!("{shown} is not an HDF5 file: a CSV file has no dataset"),
            ));
        }
        let text = std::fs::read_to_string(path)
            .map_err(|e| bad(&pat, format!("cannot read the data file {shown}: {e}")))?;
        read_csv_table(&text, columns, header_rule, &pat, &shown)?
            .into_iter()
            .map(|(c, v)| (c, Value::from(v)))
            .collect()
    };
    let empty = |v: &Value| v.as_array().is_some_and(Vec::is_empty);
    if table.is_empty() || empty(&table[0].1) {
        return Err(bad(
            &pat,
            format!("{shown} holds no data (columns: {})", columns.join(", ")),
        ));
    }
    Ok(table)
}

fn read_csv_table(
    text: &str,
    columns: &[&str],
    header_rule: Header,
    field: &str,
    shown: &str,
) -> Result<Vec<(String, Vec<f64>)>> {
    let mut header: Option<Vec<String>> = None;
    let mut rows: Vec<Vec<f64>> = Vec::new();
    for (line_no, line, cells, numbers) in super::super::recording::csv_lines(text) {
        match numbers {
            Some(n) => {
                if let Some(c) = n.iter().position(|x| !x.is_finite()) {
                    let names = header.as_ref().map_or_else(
                        || columns.iter().map(|c| c.to_string()).collect::<Vec<_>>(),
                        Clone::clone,
                    );
                    return Err(bad(
                        field,
                        format!(
                            "{shown}, line {line_no}: {} in column {}: every datum must be a finite number",
                            n[c],
                            names.get(c).map_or("?", String::as_str)
                        ),
                    ));
                }
                let want = header.as_ref().map_or(n.len(), Vec::len);
                if n.len() != want || (header.is_none() && n.len() > columns.len()) {
                    return Err(bad(
                        field,
                        format!(
                            "{shown}, line {line_no}: {} numbers where the file's columns are {}",
                            n.len(),
                            header
                                .as_ref()
                                .map_or_else(|| columns.join(", "), |h| h.join(", "))
                        ),
                    ));
                }
                if header.is_none() && rows.is_empty() {
                    if header_rule == Header::Required {
                        return Err(bad(
                            field,
                            format!(
                                "{shown}, line {line_no}: numbers without a header line naming the columns ({}): a spectrum's second column could be either",
                                columns.join(", ")
                            ),
                        ));
                    }
                    header = Some(columns[..n.len()].iter().map(|c| c.to_string()).collect());
                }
                rows.push(n);
            }
            None if header.is_none() && rows.is_empty() => {
                let names: Vec<String> = cells
                    .iter()
                    .map(|c| c.trim_matches('"').to_string())
                    .collect();
                if let Some(u) = names.iter().find(|n| !columns.contains(&n.as_str())) {
                    return Err(bad(
                        field,
                        format!(
                            "{shown}, line {line_no}: column `{u}` is none of {}",
                            columns.join(", ")
                        ),
                    ));
                }
                header = Some(names);
            }
            None => {
                return Err(bad(
                    field,
                    format!("{shown}, line {line_no}: want numbers, got {line:?}"),
                ))
            }
        }
        if rows.len() > MAX_FILE_LINES {
            return Err(bad(
                field,
                format!("{shown} holds more than {MAX_FILE_LINES} lines of data"),
            ));
        }
    }
    let Some(header) = header else {
        return Ok(Vec::new());
    };
    Ok(header
        .iter()
        .enumerate()
        .map(|(c, name)| (name.clone(), rows.iter().map(|r| r[c]).collect()))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_tables_with_and_without_a_header() {
        let t = read_csv_table(
            "# gauge 4\ntime_s,value\n0,1\n1e-6, 2\n",
            &["time_s", "value", "sigma"],
            Header::Optional,
            "f",
            "x",
        )
        .unwrap();
        assert_eq!(t[0], ("time_s".into(), vec![0.0, 1e-6]));
        assert_eq!(t[1], ("value".into(), vec![1.0, 2.0]));
        let t = read_csv_table(
            "0 1 0.1\n1 2 0.1\n",
            &["time_s", "value", "sigma"],
            Header::Optional,
            "f",
            "x",
        )
        .unwrap();
        assert_eq!(t.len(), 3);
        assert_eq!(t[2].1, vec![0.1, 0.1]);
        let e = read_csv_table(
            "time_s,volts\n0,1\n",
            &["time_s", "value"],
            Header::Optional,
            "f",
            "x",
        )
        .unwrap_err();
        assert!(e.to_string().contains("`volts` is none of"), "{e}");
        let e = read_csv_table("0,1\n1\n", &["time_s", "value"], Header::Optional, "f", "x")
            .unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
        // A spectrum's columns are named in a header: without one its second column could be
        // an amplitude or a transmission in dB.
        let spectrum = ["frequency_hz", "amplitude", "sigma", "transmission_db"];
        let e =
            read_csv_table("2500,7.97,0.5\n", &spectrum, Header::Required, "f", "x").unwrap_err();
        assert!(e.to_string().contains("without a header line"), "{e}");
        let t = read_csv_table(
            "frequency_hz,transmission_db,sigma\n2500,7.97,0.5\n",
            &spectrum,
            Header::Required,
            "f",
            "x",
        )
        .unwrap();
        assert_eq!(t[1], ("transmission_db".into(), vec![7.97]));
    }
}
