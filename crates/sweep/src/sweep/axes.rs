//! The grid's axes: each axis of the sweep file checked and its values expanded (a list, or a
//! range), zipped groups of axes as one dimension, and the checks on the axes' names and fields.

use serde_json::Value;

use super::file::{AxisFile, RangeFile};
use super::paths::{check_settable, split_path, units_of};
use super::{Axis, Dim, MAX_GRID_POINTS};
use crate::error::{Error, Result};
use crate::record::columns::reserved_names;

/// The `axes` list of a sweep file's text as JSON (empty where it has none or does not read).
pub(super) fn raw_axes(text: &str) -> Vec<Value> {
    let stripped = text.strip_prefix('\u{feff}').unwrap_or(text);
    serde_json::from_str::<Value>(stripped)
        .ok()
        .and_then(|v| v.get("axes").and_then(Value::as_array).cloned())
        .unwrap_or_default()
}

/// A range value: integers stay integers; floats are rounded to 15 significant digits, so that
/// `0.1 + 2 × 0.1` is 0.3 and not 0.30000000000000004.
fn num_to_value(x: f64, as_int: bool) -> Value {
    if as_int {
        Value::from(x.round() as i64)
    } else {
        let rounded: f64 = format!("{x:.14e}").parse().unwrap_or(x);
        Value::from(rounded)
    }
}

fn expand_range(r: &RangeFile, origin: &str) -> Result<Vec<Value>> {
    let start = r.start.as_f64().unwrap_or(f64::NAN);
    let stop = r.stop.as_f64().unwrap_or(f64::NAN);
    for (name, v) in [("start", start), ("stop", stop)] {
        if !v.is_finite() {
            return Err(Error::input(
                format!("{origin}.range.{name}"),
                "must be a finite number",
            ));
        }
    }
    let ints = r.start.is_i64() && r.stop.is_i64();
    match (&r.step, r.num) {
        (Some(_), Some(_)) | (None, None) => Err(Error::input(
            format!("{origin}.range"),
            "give exactly one of `step` (spacing, stop included when reached) or `num` (number of evenly spaced values, both ends included)",
        )),
        (Some(step_n), None) => {
            let step = step_n.as_f64().unwrap_or(f64::NAN);
            if !(step.is_finite() && step != 0.0) || (stop - start) * step < 0.0 {
                return Err(Error::input(
                    format!("{origin}.range.step"),
                    format!("must be a finite non-zero number with the sign of stop - start, got {step_n}"),
                ));
            }
            let ints = ints && step_n.is_i64();
            let span = (stop - start) / step;
            // Counted in floating point and checked before it becomes an integer: a tiny step
            // gives a count far beyond any integer (a cast would saturate, and + 1 wrap to 0).
            let count = (span + 1e-9 * span.abs().max(1.0)).floor() + 1.0;
            if count.is_nan() || count > MAX_GRID_POINTS as f64 {
                return Err(Error::input(
                    format!("{origin}.range.step"),
                    format!(
                        "gives {} values from {} to {} in steps of {step_n}; a range may give at most {MAX_GRID_POINTS} (make the step larger)",
                        crate::error::number_text(span.abs().floor() + 1.0),
                        crate::error::number_text(start),
                        crate::error::number_text(stop)
                    ),
                ));
            }
            let n = count as u64;
            Ok((0..n).map(|i| num_to_value(start + i as f64 * step, ints)).collect())
        }
        (None, Some(num)) => {
            if num == 0 || num > MAX_GRID_POINTS as u64 {
                return Err(Error::input(
                    format!("{origin}.range.num"),
                    format!("must be a whole number from 1 to {MAX_GRID_POINTS}, got {num}"),
                ));
            }
            if num == 1 {
                return Ok(vec![num_to_value(start, ints)]);
            }
            let ints = ints && (r.stop.as_i64().unwrap_or(0) - r.start.as_i64().unwrap_or(0)) % (num as i64 - 1) == 0;
            let last = (num - 1) as f64;
            Ok((0..num)
                .map(|i| {
                    let x = if i == num - 1 {
                        stop
                    } else {
                        start + (stop - start) * (i as f64 / last)
                    };
                    num_to_value(x, ints)
                })
                .collect())
        }
    }
}

fn parse_axis(a: AxisFile, origin: &str, base: &Value, auto: bool) -> Result<Axis> {
    if a.zip.is_some() {
        return Err(Error::input(
            format!("{origin}.zip"),
            "zipped groups cannot be nested",
        ));
    }
    let field = a.field.ok_or_else(|| {
        Error::input(
            format!("{origin}.field"),
            "missing: an axis needs `field` (the dotted path of a scene field, e.g. physics.damping_kg_s)",
        )
    })?;
    if auto && split_path(&field)[0] == "integrator" {
        return Err(Error::input(
            format!("{origin}.field"),
            format!("`{field}`: the base integrator is `auto`, which chooses one setting for the whole grid; an axis may not set integrator fields (give a fixed integrator in `base` to sweep over integrator settings)"),
        ));
    }
    check_settable(base, &field).map_err(|m| Error::input(format!("{origin}.field"), m))?;
    let values = match (a.values, a.range) {
        (Some(v), None) => {
            if v.is_empty() {
                return Err(Error::input(format!("{origin}.values"), "must hold at least one value"));
            }
            v
        }
        (None, Some(r)) => expand_range(&r, origin)?,
        _ => {
            return Err(Error::input(
                origin.to_string(),
                "give exactly one of `values` (a list) or `range` ({start, stop, step} or {start, stop, num})",
            ))
        }
    };
    let name = a
        .name
        .unwrap_or_else(|| split_path(&field).last().cloned().unwrap_or_default());
    Ok(Axis {
        units: units_of(&field),
        name,
        field,
        values,
        origin: origin.to_string(),
    })
}

fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= 64
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        && !name.starts_with(|c: char| c.is_ascii_digit())
}

/// The grid's dimensions from the `axes` list: one per axis or zipped group.
/// The grid's dimensions; `every`: the errors are those of every axis (each read on its own),
/// else the first alone.
pub(super) fn parse_dims(
    axes: Vec<AxisFile>,
    base: &Value,
    auto: bool,
    search: bool,
    every: bool,
) -> std::result::Result<Vec<Dim>, Vec<Error>> {
    if axes.is_empty() && !search {
        return Err(vec![Error::input(
            "axes",
            "at least one axis is required (a single run is an axis with one value), unless the sweep has a `search`, an `ensemble` or a `periodic` block",
        )]);
    }
    let mut dims = Vec::new();
    let mut errors = Vec::new();
    for (i, mut a) in axes.into_iter().enumerate() {
        let origin = format!("axes[{i}]");
        let dim = match a.zip.take() {
            Some(zip) => parse_zip(a, zip, &origin, base, auto),
            None => parse_axis(a, &origin, base, auto).map(|axis| Dim {
                name: axis.name.clone(),
                axes: vec![axis],
            }),
        };
        match dim {
            Ok(d) => dims.push(d),
            Err(e) if every => errors.push(e),
            Err(e) => return Err(vec![e]),
        }
    }
    if errors.is_empty() {
        Ok(dims)
    } else {
        Err(errors)
    }
}

/// A zipped group `group` (its `zip` list taken out as `zip`) at `origin`: axes of equal length.
fn parse_zip(
    group: AxisFile,
    zip: Vec<AxisFile>,
    origin: &str,
    base: &Value,
    auto: bool,
) -> Result<Dim> {
    if group.field.is_some() || group.values.is_some() || group.range.is_some() {
        return Err(Error::input(
            origin,
            "a zipped group holds only `zip` (a list of axes) and an optional `name`",
        ));
    }
    if zip.is_empty() {
        return Err(Error::input(
            format!("{origin}.zip"),
            "must hold at least one axis",
        ));
    }
    let mut axes = Vec::new();
    for (j, z) in zip.into_iter().enumerate() {
        axes.push(parse_axis(z, &format!("{origin}.zip[{j}]"), base, auto)?);
    }
    let n = axes[0].values.len();
    for ax in &axes[1..] {
        if ax.values.len() != n {
            return Err(Error::input(
                format!("{}.values", ax.origin),
                format!(
                    "zipped axes advance together and need equal lengths: this one has {}, `{}` has {n}",
                    ax.values.len(),
                    axes[0].name
                ),
            ));
        }
    }
    let name = group.name.unwrap_or_else(|| axes[0].name.clone());
    Ok(Dim { name, axes })
}

/// Names and fields must be distinct, names usable as dataset names and not reserved; checked
/// dimension by dimension.
pub(super) fn check_names_and_fields(dims: &[Dim]) -> Result<()> {
    let mut names: Vec<(&str, &str)> = Vec::new();
    let mut fields: Vec<(&str, &str)> = Vec::new();
    for d in dims {
        let mut all: Vec<(&str, &str)> = d
            .axes
            .iter()
            .map(|a| (a.name.as_str(), a.origin.as_str()))
            .collect();
        if d.axes.len() > 1 && !d.axes.iter().any(|a| a.name == d.name) {
            all.push((d.name.as_str(), ""));
        }
        for (name, origin) in all {
            check_name(name, origin, &names)?;
            names.push((name, origin));
        }
        for a in &d.axes {
            check_field(a, &fields)?;
            fields.push((a.field.as_str(), a.origin.as_str()));
        }
    }
    Ok(())
}

/// `name` (of the axis at `origin`, or of a zipped dimension when `origin` is empty) is usable,
/// not reserved, and not among `taken`.
pub(crate) fn check_name(name: &str, origin: &str, taken: &[(&str, &str)]) -> Result<()> {
    let at = if origin.is_empty() {
        "axes".to_string()
    } else {
        format!("{origin}.name")
    };
    if !valid_name(name) {
        return Err(Error::input(
            at,
            format!("`{name}` is not a usable name: letters, digits, `_` and `-`, not starting with a digit, at most 64 characters"),
        ));
    }
    let reserved = reserved_names();
    if reserved.contains(&name) {
        return Err(Error::input(
            at,
            format!(
                "`{name}` is a reserved dataset name; reserved: {}",
                reserved.join(", ")
            ),
        ));
    }
    if let Some((_, other)) = taken.iter().find(|(n, _)| *n == name) {
        return Err(Error::input(
            at,
            format!("name `{name}` is already used by {other}"),
        ));
    }
    Ok(())
}

/// The field of axis `a` overlaps none of the fields `taken` (a field, or one inside it).
pub(super) fn check_field(a: &Axis, taken: &[(&str, &str)]) -> Result<()> {
    let segs = split_path(&a.field);
    for (f, other) in taken {
        let o = split_path(f);
        let overlap = segs.len().min(o.len());
        if segs[..overlap] == o[..overlap] {
            return Err(Error::input(
                format!("{}.field", a.origin),
                format!(
                    "`{}` overlaps `{f}` set by {other}; each field may be set by one axis only",
                    a.field
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_include_their_ends() {
        let r = RangeFile {
            start: 0.into(),
            stop: 100.into(),
            step: Some(10.into()),
            num: None,
        };
        let v = expand_range(&r, "axes[0]").unwrap();
        assert_eq!(v.len(), 11);
        assert_eq!(v[10], Value::from(100));
        let r = RangeFile {
            start: serde_json::Number::from_f64(0.1).unwrap(),
            stop: serde_json::Number::from_f64(1.0).unwrap(),
            step: None,
            num: Some(10),
        };
        let v = expand_range(&r, "axes[0]").unwrap();
        assert_eq!(v.len(), 10);
        assert_eq!(v[9].as_f64(), Some(1.0));
        assert_eq!(v[0].as_f64(), Some(0.1));
    }
}
