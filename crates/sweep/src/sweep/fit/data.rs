//! The data sets of a `fit` search read from the sweep file: each datum (a scalar, a signal, a
//! spectrum) checked against the base scene's probes, with its uncertainties.

use std::collections::HashMap;

use serde_json::{Map, Value};

use chainsweep_solver::Probe;

use super::super::lookup;
use super::super::search::parse_objective_at;
use super::{
    bad, DataSet, Datum, Interval, Scalar, Signal, Spectrum, SpectrumQuantity, BLOCK_SUFFIXES,
    MAX_DATA, SCALAR_PREFIX,
};
use crate::error::Result;

/// The probes of the normalised base scene's record block.
fn probe_at(v: Option<&Value>, at: &str, probes: &[Probe]) -> Result<(usize, String)> {
    let names: Vec<String> = probes.iter().map(|p| p.name()).collect();
    let Some(v) = v else {
        return Err(bad(
            at,
            format!(
                "missing: the probe compared, one of {}",
                if names.is_empty() {
                    "the record block's probes (it has none)".to_string()
                } else {
                    names.join(", ")
                }
            ),
        ));
    };
    let name = v
        .as_str()
        .ok_or_else(|| bad(at, "must be a probe's name"))?;
    let i = names.iter().position(|n| n == name).ok_or_else(|| {
        bad(
            at,
            format!(
                "`{name}` is not a probe of the record block; its probes: {}",
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                }
            ),
        )
    })?;
    Ok((i, name.to_string()))
}

/// A finite number.
fn number(v: &Value, at: &str) -> Result<f64> {
    match v.as_f64() {
        Some(x) if x.is_finite() => Ok(x),
        _ => Err(bad(at, format!("must be a finite number, got {v}"))),
    }
}

/// A list of finite numbers (at least one).
fn numbers(v: &Value, at: &str) -> Result<Vec<f64>> {
    let a = v
        .as_array()
        .ok_or_else(|| bad(at, "must be a list of numbers"))?;
    if a.is_empty() {
        return Err(bad(at, "is empty: give at least one number"));
    }
    a.iter()
        .enumerate()
        .map(|(i, x)| number(x, &format!("{at}[{i}]")))
        .collect()
}

/// Standard uncertainties: one number for all, or one per datum; each > 0.
fn sigmas(v: &Value, n: usize, at: &str) -> Result<Vec<f64>> {
    let s = match v {
        Value::Array(_) => {
            let s = numbers(v, at)?;
            if s.len() != n {
                return Err(bad(
                    at,
                    format!("gives {} uncertainties for {n} data: give one per datum, or one number for all", s.len()),
                ));
            }
            s
        }
        _ => vec![number(v, at)?; n],
    };
    if let Some((i, x)) = s.iter().enumerate().find(|(_, &x)| x <= 0.0) {
        return Err(bad(
            if matches!(v, Value::Array(_)) {
                format!("{at}[{i}]")
            } else {
                at.to_string()
            },
            format!("a standard uncertainty must be > 0, got {x}"),
        ));
    }
    Ok(s)
}

fn increasing(x: &[f64], at: &str, what: &str) -> Result<()> {
    if let Some(i) = (1..x.len()).find(|&i| x[i] <= x[i - 1]) {
        return Err(bad(
            format!("{at}[{i}]"),
            format!(
                "{what} must increase strictly: {} follows {}",
                x[i],
                x[i - 1]
            ),
        ));
    }
    Ok(())
}

fn check_keys(m: &Map<String, Value>, at: &str, allowed: &[&str]) -> Result<()> {
    if let Some(k) = m.keys().find(|k| !allowed.contains(&k.as_str())) {
        return Err(bad(
            format!("{at}.{k}"),
            format!("unknown key; allowed: {}", allowed.join(", ")),
        ));
    }
    Ok(())
}

fn flag(m: &Map<String, Value>, key: &str, at: &str) -> Result<bool> {
    match m.get(key) {
        None => Ok(false),
        Some(Value::Bool(b)) => Ok(*b),
        Some(_) => Err(bad(format!("{at}.{key}"), "must be true or false")),
    }
}

fn name_of(m: &Map<String, Value>, at: &str, default: String) -> Result<String> {
    match m.get("name") {
        None => Ok(default),
        Some(Value::String(s))
            if !s.is_empty()
                && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
                && !s.starts_with(|c: char| c.is_ascii_digit()) =>
        {
            Ok(s.clone())
        }
        Some(v) => Err(bad(
            format!("{at}.name"),
            format!("must be a name of letters, digits and _ (not starting with a digit), got {v}"),
        )),
    }
}

/// Where a spectrum's frequency is set: the harmonic drive's `frequency_hz`.
fn drive_frequency_field(base: &Value) -> Option<String> {
    ["force_n", "actuator_m", "base_m"].iter().find_map(|k| {
        let path = format!("excitation.drive.{k}.harmonic.frequency_hz");
        lookup(base, &path)
            .ok()
            .filter(|v| v.is_number())
            .map(|_| path)
    })
}

/// What the parse needs of the sweep: the normalised base scene and the dimensions.
pub(super) struct Context<'a> {
    pub(super) base: &'a Value,
    pub(super) probes: Vec<Probe>,
    pub(super) sigma_given: Option<(bool, String)>,
}

impl Context<'_> {
    /// Every datum has σ, or none has: the first one decides, the others must agree.
    fn sigma(&mut self, given: bool, at: &str) -> Result<()> {
        match &self.sigma_given {
            None => {
                self.sigma_given = Some((given, at.to_string()));
                Ok(())
            }
            Some((g, _)) if *g == given => Ok(()),
            Some((g, first)) => Err(bad(
                at,
                format!(
                    "{} while {first} {}: give every datum its standard uncertainty (sigma or relative_sigma), or none (then one σ common to all is estimated from the residuals)",
                    if given { "has an uncertainty" } else { "has no uncertainty" },
                    if *g { "has one" } else { "has none" }
                ),
            )),
        }
    }
}

fn parse_scalar(m: &Map<String, Value>, at: &str, cx: &mut Context) -> Result<Scalar> {
    let mut quantity = Map::new();
    for (k, v) in m {
        if !["value", "sigma", "relative_sigma", "name"].contains(&k.as_str()) {
            quantity.insert(k.clone(), v.clone());
        }
    }
    let names: Vec<String> = cx.probes.iter().map(|p| p.name()).collect();
    let quantity = parse_objective_at(&Value::Object(quantity), at, &names)?;
    let value = number(
        m.get("value")
            .ok_or_else(|| bad(format!("{at}.value"), "missing: the measured value"))?,
        &format!("{at}.value"),
    )?;
    let sigma = match (m.get("sigma"), m.get("relative_sigma")) {
        (Some(_), Some(_)) => {
            return Err(bad(
                format!("{at}.relative_sigma"),
                "give sigma (absolute) or relative_sigma (a fraction of the value), not both",
            ))
        }
        (Some(s), None) => Some(sigmas(s, 1, &format!("{at}.sigma"))?[0]),
        (None, Some(r)) => {
            let r = sigmas(r, 1, &format!("{at}.relative_sigma"))?[0];
            let s = r * value.abs();
            if s <= 0.0 {
                return Err(bad(
                    format!("{at}.relative_sigma"),
                    "a relative uncertainty of a value of 0 is 0: give sigma",
                ));
            }
            Some(s)
        }
        (None, None) => None,
    };
    cx.sigma(sigma.is_some(), &format!("{at}.sigma"))?;
    Ok(Scalar {
        name: name_of(m, at, quantity.describe())?,
        quantity,
        value,
        sigma,
    })
}

fn parse_signal(v: &Value, at: &str, cx: &mut Context) -> Result<Signal> {
    let Value::Object(m) = v else {
        return Err(bad(
            at,
            "must be an object: {\"probe\": …, \"time_s\": […], \"value\": […], \"sigma\": …}",
        ));
    };
    check_keys(
        m,
        at,
        &[
            "probe",
            "time_s",
            "value",
            "sigma",
            "time_shift_s",
            "gain",
            "offset",
            "window_s",
            "name",
        ],
    )?;
    let probe = probe_at(m.get("probe"), &format!("{at}.probe"), &cx.probes)?;
    let units = cx.probes[probe.0].unit();
    let time_s = numbers(
        m.get("time_s")
            .ok_or_else(|| bad(format!("{at}.time_s"), "missing: the data instants, s"))?,
        &format!("{at}.time_s"),
    )?;
    increasing(&time_s, &format!("{at}.time_s"), "the data instants")?;
    let value = numbers(
        m.get("value")
            .ok_or_else(|| bad(format!("{at}.value"), "missing: the measured values"))?,
        &format!("{at}.value"),
    )?;
    if value.len() != time_s.len() {
        return Err(bad(
            format!("{at}.value"),
            format!("{} values for {} instants", value.len(), time_s.len()),
        ));
    }
    let mut sigma = m
        .get("sigma")
        .map(|s| sigmas(s, time_s.len(), &format!("{at}.sigma")))
        .transpose()?;
    cx.sigma(sigma.is_some(), &format!("{at}.sigma"))?;
    let shift = match m.get("time_shift_s") {
        None => None,
        Some(Value::Object(s)) => {
            let sat = format!("{at}.time_shift_s");
            check_keys(s, &sat, &["min", "max"])?;
            let min = number(
                s.get("min")
                    .ok_or_else(|| bad(format!("{sat}.min"), "missing"))?,
                &format!("{sat}.min"),
            )?;
            let max = number(
                s.get("max")
                    .ok_or_else(|| bad(format!("{sat}.max"), "missing"))?,
                &format!("{sat}.max"),
            )?;
            if min >= max {
                return Err(bad(
                    format!("{sat}.max"),
                    format!("the interval [{min}, {max}] is empty: give min < max"),
                ));
            }
            Some(Interval { min, max })
        }
        Some(_) => {
            return Err(bad(
                format!("{at}.time_shift_s"),
                "must be {\"min\": …, \"max\": …}: the interval of the run's instant of the data's zero, s",
            ))
        }
    };
    let (mut time_s, mut value) = (time_s, value);
    if let Some(w) = m.get("window_s") {
        let wat = format!("{at}.window_s");
        let w = numbers(w, &wat)?;
        if w.len() != 2 || w[0] >= w[1] {
            return Err(bad(
                wat,
                format!("must be [start, end] with start < end, s, got {w:?}"),
            ));
        }
        let keep: Vec<usize> = (0..time_s.len())
            .filter(|&i| time_s[i] >= w[0] && time_s[i] <= w[1])
            .collect();
        if keep.is_empty() {
            return Err(bad(
                wat,
                format!(
                    "holds none of the data instants ({} to {} s)",
                    time_s[0],
                    time_s[time_s.len() - 1]
                ),
            ));
        }
        time_s = keep.iter().map(|&i| time_s[i]).collect();
        value = keep.iter().map(|&i| value[i]).collect();
        sigma = sigma.map(|s| keep.iter().map(|&i| s[i]).collect());
    }
    let signal = Signal {
        name: name_of(m, at, format!("signal_{}", probe.1))?,
        probe,
        units,
        time_s,
        value,
        sigma,
        shift,
        gain: flag(m, "gain", at)?,
        offset: flag(m, "offset", at)?,
    };
    let n_free = signal.nuisance_names().len();
    if signal.time_s.len() <= n_free {
        return Err(bad(
            format!("{at}.time_s"),
            format!(
                "{} instant(s) cannot fit {n_free} nuisance parameter(s) of the signal ({}) and tell anything of the fields",
                signal.time_s.len(),
                signal.nuisance_names().join(", ")
            ),
        ));
    }
    // The history the signal is compared with.
    let history = cx
        .base
        .pointer("/record/history")
        .and_then(Value::as_bool)
        .unwrap_or(false);
    if !history {
        return Err(bad(
            format!("{at}.probe"),
            "a signal is compared with the probe's history: set record.history to true (and record.history_interval_s well below the data's sampling interval)",
        ));
    }
    if cx
        .base
        .pointer("/record/stop_after_leading_pulses")
        .and_then(Value::as_bool)
        .unwrap_or(false)
    {
        return Err(bad(
            format!("{at}.probe"),
            "a signal needs the whole history: record.stop_after_leading_pulses ends runs early",
        ));
    }
    Ok(signal)
}

fn parse_spectrum(v: &Value, at: &str, cx: &mut Context) -> Result<Spectrum> {
    let Value::Object(m) = v else {
        return Err(bad(at, "must be an object: {\"probe\": …, \"frequency_hz\": […], \"amplitude\": […], \"sigma\": …}"));
    };
    check_keys(
        m,
        at,
        &[
            "probe",
            "frequency_hz",
            "amplitude",
            "transmission_db",
            "sigma",
            "phase_rad",
            "phase_sigma_rad",
            "frequency_field",
            "name",
        ],
    )?;
    let probe = probe_at(m.get("probe"), &format!("{at}.probe"), &cx.probes)?;
    let f = numbers(
        m.get("frequency_hz").ok_or_else(|| {
            bad(
                format!("{at}.frequency_hz"),
                "missing: the data's frequencies, Hz",
            )
        })?,
        &format!("{at}.frequency_hz"),
    )?;
    increasing(&f, &format!("{at}.frequency_hz"), "the frequencies")?;
    if let Some((i, x)) = f.iter().enumerate().find(|(_, &x)| x <= 0.0) {
        return Err(bad(
            format!("{at}.frequency_hz[{i}]"),
            format!("a frequency must be > 0, got {x}"),
        ));
    }
    let (quantity, values) = match (m.get("amplitude"), m.get("transmission_db")) {
        (Some(a), None) => (SpectrumQuantity::Amplitude, a),
        (None, Some(t)) => (SpectrumQuantity::TransmissionDb, t),
        _ => {
            return Err(bad(
                format!("{at}.amplitude"),
                "give one of amplitude (the probe's steady amplitude, its unit) or transmission_db (over the reference probe's)",
            ))
        }
    };
    let vat = format!("{at}.{}", quantity.key());
    let value = numbers(values, &vat)?;
    if value.len() != f.len() {
        return Err(bad(
            vat,
            format!("{} values for {} frequencies", value.len(), f.len()),
        ));
    }
    if quantity == SpectrumQuantity::Amplitude {
        if let Some((i, x)) = value.iter().enumerate().find(|(_, &x)| x < 0.0) {
            return Err(bad(
                format!("{vat}[{i}]"),
                format!("an amplitude is ≥ 0, got {x} (a transmission in dB is given as transmission_db)"),
            ));
        }
    }
    let sigma = m
        .get("sigma")
        .map(|s| sigmas(s, f.len(), &format!("{at}.sigma")))
        .transpose()?;
    cx.sigma(sigma.is_some(), &format!("{at}.sigma"))?;
    let phase = match m.get("phase_rad") {
        None => {
            if m.contains_key("phase_sigma_rad") {
                return Err(bad(
                    format!("{at}.phase_sigma_rad"),
                    "given without phase_rad",
                ));
            }
            None
        }
        Some(p) => {
            let p = numbers(p, &format!("{at}.phase_rad"))?;
            if p.len() != f.len() {
                return Err(bad(
                    format!("{at}.phase_rad"),
                    format!("{} phases for {} frequencies", p.len(), f.len()),
                ));
            }
            let ps = m
                .get("phase_sigma_rad")
                .map(|s| sigmas(s, f.len(), &format!("{at}.phase_sigma_rad")))
                .transpose()?;
            cx.sigma(ps.is_some(), &format!("{at}.phase_sigma_rad"))?;
            Some((p, ps))
        }
    };
    let steady = cx.base.pointer("/record/steady_state");
    match steady {
        Some(s) if !s.is_null() => {
            if s.get("frequency_hz").is_some_and(|f| !f.is_null()) {
                return Err(bad(
                    format!("{at}.probe"),
                    "record.steady_state.frequency_hz is fixed: leave it out, so that each run analyses the frequency its drive is set to",
                ));
            }
        }
        _ => {
            return Err(bad(
                format!("{at}.probe"),
                "a spectrum is compared with the runs' steady state: give record.steady_state",
            ))
        }
    }
    let frequency_field = match m.get("frequency_field") {
        Some(Value::String(s)) => {
            let ok = lookup(cx.base, s).is_ok_and(|v| v.is_number());
            if !ok {
                return Err(bad(
                    format!("{at}.frequency_field"),
                    format!("`{s}` is no number of the scene: name the field that sets the drive's frequency"),
                ));
            }
            s.clone()
        }
        Some(_) => {
            return Err(bad(
                format!("{at}.frequency_field"),
                "must be a field's dotted path",
            ))
        }
        None => drive_frequency_field(cx.base).ok_or_else(|| {
            bad(
                format!("{at}.frequency_field"),
                "the scene has no harmonic drive whose frequency a spectrum could set: give the field that sets it",
            )
        })?,
    };
    let reference = cx
        .base
        .pointer("/record/steady_state/reference_probe")
        .and_then(Value::as_u64)
        .unwrap_or(0) as usize;
    if (quantity == SpectrumQuantity::TransmissionDb || phase.is_some()) && reference == probe.0 {
        {
            return Err(bad(
                format!("{at}.probe"),
                format!("`{}` is the steady state's reference probe: its transmission and relative phase are 0 whatever the fields", probe.1),
            ));
        }
    }
    let units = match quantity {
        SpectrumQuantity::Amplitude => cx.probes[probe.0].unit(),
        SpectrumQuantity::TransmissionDb => "dB",
    };
    Ok(Spectrum {
        name: name_of(m, at, format!("spectrum_{}", probe.1))?,
        probe,
        quantity,
        units,
        frequency_field,
        frequency_hz: f,
        value,
        sigma,
        phase,
        variant: Vec::new(),
        reference,
    })
}

pub(super) fn parse_set(v: &Value, at: &str, cx: &mut Context) -> Result<DataSet> {
    let a = v.as_array().ok_or_else(|| {
        bad(
            at,
            "must be a list of data: scalars {\"summary\": …, \"value\": …, \"sigma\": …}, {\"signal\": {…}}, {\"spectrum\": {…}}",
        )
    })?;
    if a.is_empty() {
        return Err(bad(at, "is empty: a fit needs data"));
    }
    let mut data = Vec::new();
    for (i, d) in a.iter().enumerate() {
        let dat = format!("{at}[{i}]");
        let Value::Object(m) = d else {
            return Err(bad(
                &dat,
                "must be an object: a scalar, {\"signal\": {…}} or {\"spectrum\": {…}}",
            ));
        };
        let datum = if let Some(s) = m.get("signal") {
            check_keys(m, &dat, &["signal"])?;
            Datum::Signal(parse_signal(s, &format!("{dat}.signal"), cx)?)
        } else if let Some(s) = m.get("spectrum") {
            check_keys(m, &dat, &["spectrum"])?;
            Datum::Spectrum(parse_spectrum(s, &format!("{dat}.spectrum"), cx)?)
        } else {
            Datum::Scalar(parse_scalar(m, &dat, cx)?)
        };
        data.push(datum);
    }
    let set = DataSet { data };
    if set.len() > MAX_DATA {
        return Err(bad(
            at,
            format!(
                "holds {} data, more than {MAX_DATA}: thin the recorded signals (a fit keeps every evaluation's residuals)",
                set.len()
            ),
        ));
    }
    check_names(&set, at)?;
    Ok(set)
}

/// No two signals or spectra share a name, and none of the output file's variables that one
/// gives (`<name>_data`, `<name>_time_s`, …) takes the name of another's, of a summary column
/// or array of the file (`leading_peak` would give `leading_peak_time_s`, a summary), of the
/// scalars' block or of the fit's and search's own variables (`fit_…`, `search_…`): checked when
/// the sweep is read, not when the file is written after every run.
fn check_names(set: &DataSet, at: &str) -> Result<()> {
    let reserved = crate::record::columns::reserved_names();
    let scalar_block: Vec<String> = BLOCK_SUFFIXES
        .iter()
        .map(|s| format!("{SCALAR_PREFIX}_{s}"))
        .collect();
    let mut given: HashMap<String, usize> = HashMap::new();
    for (i, d) in set.data.iter().enumerate() {
        let (kind, name) = match d {
            Datum::Signal(s) => ("signal", &s.name),
            Datum::Spectrum(s) => ("spectrum", &s.name),
            Datum::Scalar(_) => continue,
        };
        let field = format!("{at}[{i}].{kind}.name");
        for v in d.variable_names() {
            let clash = if let Some(&j) = given.get(&v) {
                Some(format!("the variable `{v}` of data[{j}]"))
            } else if reserved.contains(&v.as_str()) || scalar_block.contains(&v) {
                Some(format!("`{v}`, a variable of every such file"))
            } else if v.starts_with("fit_") || v.starts_with("search_") {
                Some(format!(
                    "`{v}`, a name the fit's own variables take (fit_…, search_…)"
                ))
            } else {
                None
            };
            if let Some(clash) = clash {
                return Err(bad(
                    &field,
                    format!(
                        "`{name}` would name the output file's variable `{v}`, which clashes with {clash}: give this {kind} another `name`"
                    ),
                ));
            }
            given.insert(v, i);
        }
    }
    Ok(())
}
