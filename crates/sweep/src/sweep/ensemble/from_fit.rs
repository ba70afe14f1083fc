//! `from_fit` inputs: a fit's output file read into the multivariate normal of its best values
//! and covariance, written into the sweep file's text before it is parsed.

use serde_json::{Map, Value};

use super::dist::bad;
use crate::error::Result;
use crate::sweep::data_files::{hdf5_reader, values_in};

/// The least p-value (of the fit's χ² at its degrees of freedom) of a fit an ensemble is drawn
/// from.
const MIN_P_VALUE: f64 = 1e-3;

/// Reads `from_fit` inputs of the sweep file `text` (in folder `dir`) into the multivariate
/// normals they name, so that the sweep's text holds the numbers its runs depend on (a later
/// change of the fit's file changes nothing of a finished ensemble). `None`: nothing to read.
pub(crate) fn inline_text(text: &str, dir: &std::path::Path) -> Result<Option<String>> {
    let stripped = text.strip_prefix('\u{feff}').unwrap_or(text);
    let Ok(mut raw) = super::super::parse_without_duplicate_keys(stripped) else {
        return Ok(None);
    };
    let Some(Value::Array(inputs)) = raw.pointer_mut("/ensemble/inputs") else {
        return Ok(None);
    };
    let mut any = false;
    for (i, input) in inputs.iter_mut().enumerate() {
        let Some(Value::Object(m)) = Some(&*input) else {
            continue;
        };
        let Some(path) = m.get("from_fit") else {
            continue;
        };
        let at = format!("ensemble.inputs[{i}].from_fit");
        let path = path
            .as_str()
            .ok_or_else(|| bad(&at, "must be the path of a fit's output file (a string)"))?;
        if let Some(k) = m.keys().find(|k| *k != "from_fit" && *k != "name") {
            return Err(bad(
                format!("ensemble.inputs[{i}].{k}"),
                "a from_fit input takes only a name beside it",
            ));
        }
        let name = m.get("name").cloned();
        let mv = read_fit(&dir.join(path), path, &at)?;
        let mut out = Map::new();
        let mut mv = mv;
        if let (Some(n), Value::Object(o)) = (name, &mut mv) {
            o.insert("name".into(), n);
        }
        out.insert("multivariate_normal".into(), mv);
        *input = Value::Object(out);
        any = true;
    }
    Ok(any.then(|| serde_json::to_string_pretty(&raw).expect("JSON")))
}

/// A fit's result as a multivariate normal: its fields' paths (from the fit's sweep), names,
/// best values and covariance.
fn read_fit(path: &std::path::Path, shown: &str, at: &str) -> Result<Value> {
    let fail = |m: String| bad(at, format!("{shown}: {m}"));
    let h5 = hdf5_reader().map_err(&fail)?;
    let text: String = h5
        .root_string_attribute(path, "sweep")
        .map_err(|e| fail(format!("cannot be read as a fit's output file ({e})")))?
        .ok_or_else(|| fail("is no chainsweep output file (it has no sweep attribute)".into()))?;
    let sweep: Value = serde_json::from_str(&text)
        .map_err(|e| fail(format!("its sweep text does not read ({e})")))?;
    if sweep.pointer("/search/goal").and_then(Value::as_str) != Some("fit") {
        return Err(fail(
            "is not a fit's output file (its sweep has no search with goal fit)".into(),
        ));
    }
    let fields: Vec<(String, String)> = sweep
        .pointer("/search/fields")
        .and_then(Value::as_array)
        .map(|a| {
            a.iter()
                .filter_map(|f| {
                    let field = f.get("field")?.as_str()?.to_string();
                    let name = f
                        .get("name")
                        .and_then(Value::as_str)
                        .map(str::to_string)
                        .unwrap_or_else(|| super::super::field_name(&field));
                    Some((field, name))
                })
                .collect()
        })
        .unwrap_or_default();
    let k = fields.len();
    // `want` values of a dataset of the fit's result: its count when it holds another number
    // (a fit over several points of its axes), read only when it holds that many.
    let read = |name: &str, want: usize| -> Result<std::result::Result<Vec<f64>, usize>> {
        let wanted = |s: &[usize]| values_in(s) == want;
        let a = h5.read_f64(path, name, &wanted).map_err(|e| {
            fail(format!(
                "has no dataset `{name}` of numbers (a fit's result): {e}"
            ))
        })?;
        Ok(a.values.ok_or_else(|| values_in(&a.shape)))
    };
    let cov = read("fit_covariance", k * k)?.map_err(|n| {
        fail(format!(
            "holds a fit over several points of its axes ({n} covariance entries for {k} fields): an ensemble takes one fit's result"
        ))
    })?;
    if cov.iter().any(|x| !x.is_finite()) {
        return Err(fail(
            "has no covariance (its data do not determine every fitted field)".into(),
        ));
    }
    // Only a converged fit's covariance describes its fields' uncertainty: at a bound the best
    // value may lie beyond it, a stalled or unidentifiable fit has no confident answer.
    // (Each read where the file has it: files written before it was stored have not.)
    let optional =
        |name: &str| -> Vec<f64> { read(name, 1).ok().and_then(|r| r.ok()).unwrap_or_default() };
    let status = optional("fit_status");
    let converged = crate::record::ItemStatus::Converged.code();
    if let [s] = status.as_slice() {
        if *s != f64::from(converged) {
            let name = (*s >= 0.0 && *s <= 255.0)
                .then(|| crate::record::ItemStatus::from_code(*s as u8))
                .flatten()
                .map_or("of no known status", |st| st.name());
            return Err(fail(format!(
                "holds a fit that ended {name} (fit_status {s}), not converged: its covariance does not describe the fitted fields' uncertainty; fit again (a wider interval for a field at its bound, more or other data)"
            )));
        }
    }
    // A fit that misses its data far beyond their sigma: its covariance assumes it does not.
    if let [p] = optional("fit_p_value").as_slice() {
        if *p < MIN_P_VALUE {
            return Err(fail(format!(
                "holds a poor fit (fit_p_value {p:.3e}, below {MIN_P_VALUE}): the model misses the data beyond their sigma, and the covariance, which assumes it does not, understates the uncertainty; give the data's sigma as it is, or let the fit estimate it (sigma: estimated)"
            )));
        }
    }
    let mut mean = Vec::with_capacity(k);
    for (_, name) in &fields {
        let v = read(&format!("fit_{name}"), 1)?.unwrap_or_default();
        match v.as_slice() {
            [x] if x.is_finite() => mean.push(*x),
            _ => return Err(fail(format!("gives no single best value of `{name}`"))),
        }
    }
    let covariance: Vec<Value> = (0..k)
        .map(|i| Value::from(cov[i * k..(i + 1) * k].to_vec()))
        .collect();
    Ok(serde_json::json!({
        "fields": fields.iter().map(|f| f.0.clone()).collect::<Vec<_>>(),
        "names": fields.iter().map(|f| f.1.clone()).collect::<Vec<_>>(),
        "mean": mean,
        "covariance": covariance,
    }))
}
