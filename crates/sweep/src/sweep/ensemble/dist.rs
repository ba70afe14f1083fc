//! The distributions of the `ensemble` block's inputs as written (`uniform {min, max}`, `normal
//! {mean, sd | relative_sd}`, …), read and checked, and the numbers they take.

use serde_json::{Map, Value};

use crate::error::{Error, Result};
use crate::uq::dist::Dist;

pub(super) fn bad(field: impl Into<String>, message: impl Into<String>) -> Error {
    Error::input(field, message)
}

pub(super) fn number(v: &Value, at: &str) -> Result<f64> {
    v.as_f64()
        .filter(|x| x.is_finite())
        .ok_or_else(|| bad(at, format!("must be a finite number, got {v}")))
}

pub(super) fn numbers(v: &Value, at: &str) -> Result<Vec<f64>> {
    v.as_array()
        .ok_or_else(|| bad(at, "must be a list of numbers"))?
        .iter()
        .enumerate()
        .map(|(i, x)| number(x, &format!("{at}[{i}]")))
        .collect()
}

pub(super) const DISTRIBUTIONS: &[&str] = &[
    "uniform",
    "log_uniform",
    "normal",
    "log_normal",
    "truncated_normal",
    "triangular",
    "discrete",
];

/// Reads the distribution `kind` with parameters `p` at `at`, `nominal` the base scene's value
/// (the default centre, and the scale of `relative_sd`).
fn parse_dist(kind: &str, p: &Value, at: &str, nominal: Option<f64>) -> Result<Dist> {
    let Value::Object(m) = p else {
        return Err(bad(
            at,
            "must be an object of the distribution's parameters",
        ));
    };
    let allowed: &[&str] = match kind {
        "uniform" | "log_uniform" => &["min", "max"],
        "normal" => &["mean", "sd", "relative_sd"],
        "log_normal" => &["median", "sigma_ln"],
        "truncated_normal" => &["mean", "sd", "relative_sd", "min", "max"],
        "triangular" => &["min", "mode", "max"],
        _ => &["values", "weights"],
    };
    if let Some(k) = m.keys().find(|k| !allowed.contains(&k.as_str())) {
        return Err(bad(
            format!("{at}.{k}"),
            format!(
                "unknown parameter of `{kind}`; allowed: {}",
                allowed.join(", ")
            ),
        ));
    }
    let get = |k: &str| {
        m.get(k)
            .map(|v| number(v, &format!("{at}.{k}")))
            .transpose()
    };
    let need = |k: &str| -> Result<f64> {
        get(k)?.ok_or_else(|| bad(format!("{at}.{k}"), format!("missing: `{kind}` needs {k}")))
    };
    let centre = |k: &str| -> Result<f64> {
        match get(k)? {
            Some(x) => Ok(x),
            None => nominal.ok_or_else(|| {
                bad(
                    format!("{at}.{k}"),
                    "missing, and the base scene gives the field no number to centre on",
                )
            }),
        }
    };
    let sd = |mean: f64| -> Result<f64> {
        match (get("sd")?, get("relative_sd")?) {
            (Some(s), None) => Ok(s),
            // A fraction of a mean of 0 is no spread: said of relative_sd, not as an sd of 0.
            (None, Some(_)) if mean == 0.0 => Err(bad(
                format!("{at}.relative_sd"),
                format!("is a fraction of the mean, which is 0 here{}: give sd (in the field's unit)", if get("mean")?.is_none() { " (the base scene's value)" } else { "" }),
            )),
            (None, Some(r)) => Ok(r * mean.abs()),
            _ => Err(bad(
                format!("{at}.sd"),
                "give exactly one of sd (in the field's unit) and relative_sd (a fraction of the mean)",
            )),
        }
    };
    let dist = match kind {
        "uniform" => Dist::Uniform {
            min: need("min")?,
            max: need("max")?,
        },
        "log_uniform" => Dist::LogUniform {
            min: need("min")?,
            max: need("max")?,
        },
        "normal" => {
            let mean = centre("mean")?;
            Dist::Normal {
                mean,
                sd: sd(mean)?,
            }
        }
        "log_normal" => Dist::LogNormal {
            median: centre("median")?,
            sigma_ln: need("sigma_ln")?,
        },
        "truncated_normal" => {
            let mean = centre("mean")?;
            Dist::TruncatedNormal {
                mean,
                sd: sd(mean)?,
                min: need("min")?,
                max: need("max")?,
            }
        }
        "triangular" => Dist::Triangular {
            min: need("min")?,
            mode: centre("mode")?,
            max: need("max")?,
        },
        _ => {
            let values = numbers(
                m.get("values")
                    .ok_or_else(|| bad(format!("{at}.values"), "missing: the values"))?,
                &format!("{at}.values"),
            )?;
            let weights = match m.get("weights") {
                Some(w) => numbers(w, &format!("{at}.weights"))?,
                None => vec![1.0; values.len()],
            };
            Dist::Discrete { values, weights }
        }
    };
    dist.check().map_err(|e| {
        let param = [
            "sd", "sigma_ln", "min", "max", "mode", "median", "mean", "weights", "values",
        ]
        .into_iter()
        // A message about one parameter starts with its name; one about several (an empty
        // interval) names the distribution.
        .find(|p| e.starts_with(&format!("{p} ")))
        .filter(|p| m.contains_key(*p));
        bad(param.map_or(at.to_string(), |p| format!("{at}.{p}")), e)
    })?;
    Ok(dist)
}

/// The distribution an input map names (one key of [`DISTRIBUTIONS`]), with its key.
pub(super) fn dist_of(m: &Map<String, Value>, at: &str, nominal: Option<f64>) -> Result<Dist> {
    let named: Vec<&str> = DISTRIBUTIONS
        .iter()
        .copied()
        .filter(|k| m.contains_key(*k))
        .collect();
    match named.as_slice() {
        [k] => parse_dist(k, &m[*k], &format!("{at}.{k}"), nominal),
        [] => Err(bad(
            at,
            format!(
                "names no distribution: give one of {}",
                DISTRIBUTIONS.join(", ")
            ),
        )),
        _ => Err(bad(
            at,
            format!(
                "names several distributions ({}): give one",
                named.join(", ")
            ),
        )),
    }
}
