//! The measured data of a `fit` search: what the runs are compared with.
//!
//! ```json
//! "search": {
//!   "goal": "fit",
//!   "fields": [{"field": "physics.damping_kg_s", "min": 1, "max": 20}],
//!   "data": [
//!     {"summary": "leading_peak", "probe": "gauge_force_cyl4", "value": 110, "sigma": 3},
//!     {"ratio": [{"summary": "leading_peak", "probe": "gauge_force_cyl21"},
//!                {"summary": "leading_peak", "probe": "gauge_force_cyl4"}],
//!      "value": 0.62, "relative_sigma": 0.03},
//!     {"signal": {"probe": "gauge_force_cyl5", "path": "gauge5.csv", "sigma": 1.5,
//!                 "time_shift_s": {"min": -5e-6, "max": 5e-6}, "gain": true}},
//!     {"spectrum": {"probe": "contact_force_9", "path": "transmission.csv", "sigma": 0.5}}
//!   ]
//! }
//! ```
//!
//! Three kinds of datum:
//!
//! - a **scalar**: any summary of a run a search objective can name (or a ratio, difference or
//!   log-ratio of two), with the measured value and its standard uncertainty;
//! - a **signal**: a recorded series `(t, value[, σ])` compared with a probe's history at the data
//!   instants, with nuisance parameters fitted with it: a time shift (the recording's arbitrary
//!   zero), a gain and an offset;
//! - a **spectrum**: frequency → steady amplitude (or transmission in dB) and optionally phase,
//!   compared with `record.steady_state` of a run at each frequency (the drive's frequency set to
//!   it).
//!
//! Files named by `path` (relative to the sweep file) are read into the sweep's text when it is
//! read, as recorded drives are: the output file keeps the data themselves, and a changed file is
//! a different fit.

use std::path::Path;

use serde_json::{Map, Value};

use chainsweep_solver::Probe;

use super::search::{parse_objective_at, Objective};
use super::{lookup, split_path, Dim};
use crate::error::{Error, Result};

/// Most data of one data set (every scalar, signal sample and spectrum line together): each
/// evaluation of a fit keeps its residuals, and a fit replays them.
pub const MAX_DATA: usize = 20_000;
/// Most data sets (fits per point of the sweep's axes).
pub const MAX_DATA_SETS: usize = 10_000;
/// Most lines of one data file.
const MAX_FILE_LINES: usize = 200_000;
/// Largest data file, bytes.
const MAX_FILE_BYTES: u64 = 64 << 20;

/// How a datum's uncertainty is known.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SigmaRule {
    /// Every datum has its standard uncertainty σ: the residuals are weighted by 1/σ, χ² is a
    /// statistic with a p-value, and the covariance is (JᵀWJ)⁻¹.
    Given,
    /// No datum has one: σ is taken equal for all of them and estimated from the residuals at the
    /// best fit (s² = χ²/ν); the covariance is scaled by it and the intervals use Student's t.
    Estimated,
}

/// What a spectrum compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpectrumQuantity {
    /// The fundamental's amplitude at the probe, in its unit (`steady_amplitude`).
    Amplitude,
    /// The fundamental's amplitude over the reference probe's, dB (`steady_transmission_db`).
    TransmissionDb,
}

impl SpectrumQuantity {
    /// Its key in a sweep file (and a data file's column).
    pub fn key(self) -> &'static str {
        match self {
            SpectrumQuantity::Amplitude => "amplitude",
            SpectrumQuantity::TransmissionDb => "transmission_db",
        }
    }
}

/// A nuisance parameter's interval (a signal's time shift).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// Lower end.
    pub min: f64,
    /// Upper end.
    pub max: f64,
}

/// A recorded signal.
#[derive(Debug, Clone, PartialEq)]
pub struct Signal {
    /// Its name (the output file's variables `<name>_…`).
    pub name: String,
    /// The probe it is compared with: index in the record block, and name.
    pub probe: (usize, String),
    /// Unit of its values (the probe's).
    pub units: &'static str,
    /// Data instants, s (increasing; the window applied).
    pub time_s: Vec<f64>,
    /// Measured values.
    pub value: Vec<f64>,
    /// Standard uncertainties (`None`: estimated).
    pub sigma: Option<Vec<f64>>,
    /// The time shift fitted with it: the data's instant `t` is the run's `t + shift` (`None`:
    /// none, the data's zero is the run's).
    pub shift: Option<Interval>,
    /// Whether a gain multiplies the probe (a gauge's calibration factor).
    pub gain: bool,
    /// Whether an offset is added (a gauge's zero).
    pub offset: bool,
}

impl Signal {
    /// The nuisance parameters fitted with it, by name, in order: shift, gain, offset.
    pub fn nuisance_names(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        if self.shift.is_some() {
            v.push("time_shift_s");
        }
        if self.gain {
            v.push("gain");
        }
        if self.offset {
            v.push("offset");
        }
        v
    }
}

/// A measured steady-state spectrum.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    /// Its name.
    pub name: String,
    /// The probe it is compared with.
    pub probe: (usize, String),
    /// What it compares.
    pub quantity: SpectrumQuantity,
    /// Unit of its values.
    pub units: &'static str,
    /// The scene field set to each frequency (the drive's frequency).
    pub frequency_field: String,
    /// Frequencies, Hz (increasing).
    pub frequency_hz: Vec<f64>,
    /// Measured amplitudes (or transmissions).
    pub value: Vec<f64>,
    /// Their standard uncertainties (`None`: estimated).
    pub sigma: Option<Vec<f64>>,
    /// Measured phases against the reference probe, rad, and their uncertainties.
    pub phase: Option<(Vec<f64>, Option<Vec<f64>>)>,
    /// The run of each frequency (index into [`FitSpec::variants`]).
    pub variant: Vec<usize>,
    /// The steady state's reference probe (transmission and phase are against it).
    pub reference: usize,
}

/// A measured scalar.
#[derive(Debug, Clone, PartialEq)]
pub struct Scalar {
    /// How it reads (`leading_peak[gauge_force_cyl4]`), or the name given.
    pub name: String,
    /// The summary (or combination) of the run it is compared with.
    pub quantity: Objective,
    /// The measured value.
    pub value: f64,
    /// Its standard uncertainty (`None`: estimated).
    pub sigma: Option<f64>,
}

/// One datum of a data set.
#[derive(Debug, Clone, PartialEq)]
pub enum Datum {
    /// A scalar.
    Scalar(Scalar),
    /// A recorded signal.
    Signal(Signal),
    /// A spectrum.
    Spectrum(Spectrum),
}

impl Datum {
    /// Whether it contributes no residual (never, once parsed).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The residuals it contributes.
    pub fn len(&self) -> usize {
        match self {
            Datum::Scalar(_) => 1,
            Datum::Signal(s) => s.time_s.len(),
            Datum::Spectrum(s) => s.frequency_hz.len() * (1 + s.phase.is_some() as usize),
        }
    }

    /// Its nuisance parameters.
    pub fn nuisances(&self) -> usize {
        match self {
            Datum::Signal(s) => s.nuisance_names().len(),
            _ => 0,
        }
    }
}

/// The data one fit compares its runs with.
#[derive(Debug, Clone, PartialEq)]
pub struct DataSet {
    /// Its data, in the order given.
    pub data: Vec<Datum>,
}

impl DataSet {
    /// Residuals.
    pub fn len(&self) -> usize {
        self.data.iter().map(Datum::len).sum()
    }

    /// Whether it holds nothing.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Nuisance parameters.
    pub fn nuisances(&self) -> usize {
        self.data.iter().map(Datum::nuisances).sum()
    }
}

/// One run of every evaluation of a fit: the scene with some fields set (a spectrum's frequency);
/// the first, with none, is the scene itself.
#[derive(Debug, Clone, PartialEq)]
pub struct Variant {
    /// (dotted path, value) of each field set.
    pub set: Vec<(String, f64)>,
}

/// A parsed, checked fit: its data, and the runs each evaluation takes.
#[derive(Debug, Clone, PartialEq)]
pub struct FitSpec {
    /// The data sets: one, or one per value of the data-set dimension.
    pub sets: Vec<DataSet>,
    /// The sweep dimension of the data sets (`data_sets`), when several.
    pub sets_dim: Option<usize>,
    /// How the uncertainties are known.
    pub sigma: SigmaRule,
    /// Whether each field's profile likelihood is computed (intervals by re-fitting).
    pub profile: bool,
    /// The runs of each evaluation.
    pub variants: Vec<Variant>,
    /// The sweep dimension of the runs of an evaluation, when it has several (a spectrum's
    /// frequencies, and the scene's own where a scalar or signal needs it).
    pub variant_dim: Option<usize>,
}

fn bad(field: impl Into<String>, message: impl Into<String>) -> Error {
    Error::input(field, message)
}

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
struct Context<'a> {
    base: &'a Value,
    probes: Vec<Probe>,
    sigma_given: Option<(bool, String)>,
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

fn parse_set(v: &Value, at: &str, cx: &mut Context) -> Result<DataSet> {
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
    let mut names: Vec<&str> = Vec::new();
    for d in &set.data {
        let n = match d {
            Datum::Signal(s) => &s.name,
            Datum::Spectrum(s) => &s.name,
            Datum::Scalar(_) => continue,
        };
        if names.contains(&n.as_str()) {
            return Err(bad(
                at,
                format!("two signals or spectra are named `{n}`: give each its own `name`"),
            ));
        }
        names.push(n);
    }
    Ok(set)
}

/// Reads the `data` (or `data_sets`) of a fit against the normalised `base` scene and the sweep's
/// dimensions; `p` the number of fitted fields. The data-set dimension, when there are several,
/// is appended to `dims` (a dimension that sets no field: its runs are the same scenes).
pub(super) fn parse(
    data: Option<&Value>,
    data_sets: Option<&Value>,
    sets_name: Option<&str>,
    profile: Option<bool>,
    base: &Value,
    dims: &mut Vec<Dim>,
    p: usize,
) -> Result<FitSpec> {
    let mut cx = Context {
        base,
        probes: super::search::probes_of(base),
        sigma_given: None,
    };
    let (mut sets, sets_dim) = match (data, data_sets) {
        (Some(d), None) => (vec![parse_set(d, "search.data", &mut cx)?], None),
        (None, Some(Value::Array(list))) => {
            if list.is_empty() || list.len() > MAX_DATA_SETS {
                return Err(bad(
                    "search.data_sets",
                    format!(
                        "must hold 1 to {MAX_DATA_SETS} data sets, got {}",
                        list.len()
                    ),
                ));
            }
            let mut sets = Vec::new();
            for (k, s) in list.iter().enumerate() {
                sets.push(parse_set(s, &format!("search.data_sets[{k}]"), &mut cx)?);
            }
            let name = sets_name.unwrap_or("data_set").to_string();
            super::check_name(&name, "search.data_set_name", &[])?;
            if dims
                .iter()
                .any(|d| d.name == name || d.axes.iter().any(|a| a.name == name))
            {
                return Err(bad(
                    "search.data_set_name",
                    format!("`{name}` is already an axis of the sweep"),
                ));
            }
            dims.push(Dim {
                name: name.clone(),
                axes: vec![super::Axis {
                    name,
                    field: String::new(),
                    values: (0..list.len() as i64).map(Value::from).collect(),
                    units: "1".into(),
                    origin: "search.data_sets".into(),
                }],
            });
            (sets, Some(dims.len() - 1))
        }
        (None, Some(_)) => {
            return Err(bad(
                "search.data_sets",
                "must be a list of data sets, each a list of data",
            ))
        }
        (Some(_), Some(_)) => {
            return Err(bad(
                "search.data_sets",
                "give data (one data set) or data_sets (a fit for each), not both",
            ))
        }
        (None, None) => {
            return Err(bad(
                "search.data",
                "missing: the measured data the fit compares the runs with",
            ))
        }
    };
    if sets_name.is_some() && sets_dim.is_none() {
        return Err(bad(
            "search.data_set_name",
            "names the dimension of data_sets: give data_sets",
        ));
    }
    let sigma = match cx.sigma_given {
        Some((true, _)) => SigmaRule::Given,
        _ => SigmaRule::Estimated,
    };
    // Every data set has the same kinds of data (its runs and variables are the same).
    let shape = |s: &DataSet| -> Vec<String> {
        s.data
            .iter()
            .map(|d| match d {
                Datum::Scalar(x) => format!("scalar {}", x.name),
                Datum::Signal(x) => format!("signal {} {:?}", x.name, x.time_s),
                Datum::Spectrum(x) => format!("spectrum {} {:?}", x.name, x.frequency_hz),
            })
            .collect()
    };
    if let Some(k) = (1..sets.len()).find(|&k| shape(&sets[k]) != shape(&sets[0])) {
        return Err(bad(
            format!("search.data_sets[{k}]"),
            "differs from the first data set in its data: every data set gives the same scalars, signals and spectra (their values differ), the signals at the same instants and the spectra at the same frequencies",
        ));
    }
    for (k, s) in sets.iter().enumerate() {
        let free = s.len() as i64 - p as i64 - s.nuisances() as i64;
        let needed = if sigma == SigmaRule::Estimated { 1 } else { 0 };
        if free < needed {
            let at = if sets.len() > 1 {
                format!("search.data_sets[{k}]")
            } else {
                "search.data".into()
            };
            return Err(bad(
                at,
                format!(
                    "{} data cannot fit {p} field(s) and {} nuisance parameter(s){}",
                    s.len(),
                    s.nuisances(),
                    if needed > 0 {
                        " and estimate their uncertainty (give each datum its sigma, or more data)"
                    } else {
                        ""
                    }
                ),
            ));
        }
    }
    // Estimated σ is one σ for every datum: they must share a unit.
    if sigma == SigmaRule::Estimated {
        let mut units: Vec<String> = Vec::new();
        for d in &sets[0].data {
            match d {
                Datum::Signal(s) => units.push(s.units.into()),
                Datum::Spectrum(s) => {
                    units.push(s.units.into());
                    if s.phase.is_some() {
                        units.push("rad".into());
                    }
                }
                Datum::Scalar(s) => {
                    units.push(s.quantity.units(&cx.probes).unwrap_or("?").to_string())
                }
            }
        }
        units.dedup();
        if units.len() > 1 {
            return Err(bad(
                "search.data",
                format!(
                    "no datum has an uncertainty, and they differ in unit ({}): one σ estimated for all cannot weigh them; give each its sigma",
                    units.join(", ")
                ),
            ));
        }
    }
    // The runs of an evaluation: the scene itself where a scalar or signal needs it, and one per
    // frequency of the spectra. Several make a dimension of the sweep that sets the frequency
    // field: an evaluation runs every point of it.
    let mut variants: Vec<Variant> = Vec::new();
    let mut values: Vec<f64> = Vec::new();
    let mut variant_field: Option<String> = None;
    let needs_base = sets[0]
        .data
        .iter()
        .any(|d| !matches!(d, Datum::Spectrum(_)));
    for s in &mut sets {
        for d in &mut s.data {
            let Datum::Spectrum(sp) = d else { continue };
            match &variant_field {
                None => variant_field = Some(sp.frequency_field.clone()),
                Some(f) if *f == sp.frequency_field => {}
                Some(f) => {
                    return Err(bad(
                        "search.data",
                        format!(
                            "the spectra set different fields ({f} and {}): give them the same frequency_field",
                            sp.frequency_field
                        ),
                    ))
                }
            }
        }
    }
    let mut variant_dim = None;
    if let Some(field) = &variant_field {
        if needs_base {
            let f0 = lookup(base, field)
                .ok()
                .and_then(|v| v.as_f64())
                .unwrap_or(f64::NAN);
            values.push(f0);
        }
        for s in &mut sets {
            for d in &mut s.data {
                let Datum::Spectrum(sp) = d else { continue };
                sp.variant.clear();
                for &f in &sp.frequency_hz {
                    let k = match values.iter().position(|&v| v == f) {
                        Some(k) => k,
                        None => {
                            values.push(f);
                            values.len() - 1
                        }
                    };
                    sp.variant.push(k);
                }
            }
        }
        if let Some(d) = dims
            .iter()
            .find(|d| d.axes.iter().any(|a| a.field == *field))
        {
            return Err(bad(
                "search.data",
                format!(
                    "the spectra set {field}, which the sweep's axis `{}` sets too: a spectrum's frequencies are its own",
                    d.name
                ),
            ));
        }
        let mut name = split_path(field).last().cloned().unwrap_or_default();
        if dims
            .iter()
            .any(|d| d.name == name || d.axes.iter().any(|a| a.name == name))
        {
            name = format!("data_{name}");
        }
        dims.push(Dim {
            name: name.clone(),
            axes: vec![super::Axis {
                name,
                field: field.clone(),
                values: values.iter().map(|&f| Value::from(f)).collect(),
                units: "Hz".into(),
                origin: "search.data".into(),
            }],
        });
        variant_dim = Some(dims.len() - 1);
        variants = values
            .iter()
            .map(|&f| Variant {
                set: vec![(field.clone(), f)],
            })
            .collect();
    } else {
        variants.push(Variant { set: Vec::new() });
    }
    Ok(FitSpec {
        sets,
        sets_dim,
        sigma,
        profile: profile.unwrap_or(true),
        variants,
        variant_dim,
    })
}

/// The sweep file's `text` with every data file a fit names by `path` read into its data
/// (relative paths from `dir`), so that the output file keeps the data themselves. `None` when
/// it names none.
pub(crate) fn inline_text(text: &str, dir: &Path) -> Result<Option<String>> {
    let stripped = text.strip_prefix('\u{feff}').unwrap_or(text);
    let Ok(mut raw) = super::parse_without_duplicate_keys(stripped) else {
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
                let table = read_table(&dir.join(path), group.as_deref(), columns, &field)?;
                for (name, _) in &table {
                    if m.contains_key(name) {
                        return Err(bad(
                            format!("{field}.{name}"),
                            format!("given both here and as a column of {path}: give it once"),
                        ));
                    }
                }
                m.remove("path");
                m.remove("dataset");
                for (name, values) in table {
                    m.insert(name, values.into());
                }
                any = true;
            }
        }
    }
    Ok(any.then(|| serde_json::to_string_pretty(&raw).expect("a JSON value serialises")))
}

/// The named columns of a data file (CSV: a header line naming them, or the first columns in the
/// order of `columns` without one; HDF5: a group, `group` or the root, holding one dataset per
/// column).
fn read_table(
    path: &Path,
    group: Option<&str>,
    columns: &[&str],
    field: &str,
) -> Result<Vec<(String, Vec<f64>)>> {
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
    let mut head = [0u8; 8];
    let is_hdf5 = std::fs::File::open(path)
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head))
        .is_ok()
        && head == *b"\x89HDF\r\n\x1a\n";
    let table = if is_hdf5 {
        let hdf = |e: hdf5::Error| bad(&pat, format!("{shown}: {e}"));
        let file = hdf5::File::open(path).map_err(hdf)?;
        let g = match group {
            Some(g) => file
                .group(g)
                .map_err(|e| bad(format!("{field}.dataset"), format!("{shown}: {e}")))?,
            None => file.group("/").map_err(hdf)?,
        };
        let mut table = Vec::new();
        for c in columns {
            if let Ok(d) = g.dataset(c) {
                if d.size() > MAX_DATA * 4 {
                    return Err(bad(
                        &pat,
                        format!(
                            "{shown}: {c} holds {} values, more than a fit takes",
                            d.size()
                        ),
                    ));
                }
                let values = d.read_raw::<f64>().map_err(hdf)?;
                if let Some(i) = values.iter().position(|x| !x.is_finite()) {
                    return Err(bad(
                        &pat,
                        format!(
                            "{shown}: {c}[{i}] is {}: every datum must be a finite number",
                            values[i]
                        ),
                    ));
                }
                table.push((c.to_string(), values));
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
        read_csv_table(&text, columns, &pat, &shown)?
    };
    if table.is_empty() || table[0].1.is_empty() {
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
    field: &str,
    shown: &str,
) -> Result<Vec<(String, Vec<f64>)>> {
    let mut header: Option<Vec<String>> = None;
    let mut rows: Vec<Vec<f64>> = Vec::new();
    for (line_no, line, cells, numbers) in super::recording::csv_lines(text) {
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
            "f",
            "x",
        )
        .unwrap();
        assert_eq!(t[0], ("time_s".into(), vec![0.0, 1e-6]));
        assert_eq!(t[1], ("value".into(), vec![1.0, 2.0]));
        let t = read_csv_table(
            "0 1 0.1\n1 2 0.1\n",
            &["time_s", "value", "sigma"],
            "f",
            "x",
        )
        .unwrap();
        assert_eq!(t.len(), 3);
        assert_eq!(t[2].1, vec![0.1, 0.1]);
        let e = read_csv_table("time_s,volts\n0,1\n", &["time_s", "value"], "f", "x").unwrap_err();
        assert!(e.to_string().contains("`volts` is none of"), "{e}");
        let e = read_csv_table("0,1\n1\n", &["time_s", "value"], "f", "x").unwrap_err();
        assert!(e.to_string().contains("line 2"), "{e}");
    }
}
