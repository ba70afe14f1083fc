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
//!
//! The spec and its parsing are here; the data sets' parsing is `data`'s, and the reading of the
//! data files (CSV, HDF5) `files`'.

use serde_json::Value;

use super::search::Objective;
use super::{lookup, split_path, Dim};
use crate::error::{Error, Result};

mod data;
mod files;

use data::{parse_set, Context};
pub(crate) use files::inline_text;

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

/// The variables the output file holds for each block of data (a signal, a spectrum, a
/// spectrum's phases, the scalars), `<prefix>_<suffix>`: the measured values, their sigma, the
/// best fit's prediction, the residual and the normalised residual. One list for the file's
/// writer and the check that no two variables share a name.
pub const BLOCK_SUFFIXES: [&str; 5] = ["data", "sigma", "model", "residual", "normalised_residual"];

/// The prefix of the scalars' block of variables (`scalar_data`, …).
pub const SCALAR_PREFIX: &str = "scalar";

impl Datum {
    /// The names of the output file's variables and dimensions that a signal or spectrum gives
    /// (empty for a scalar: the scalars share one block, [`SCALAR_PREFIX`]).
    pub fn variable_names(&self) -> Vec<String> {
        let block = |prefix: &str| BLOCK_SUFFIXES.map(|s| format!("{prefix}_{s}"));
        let mut names = Vec::new();
        match self {
            Datum::Scalar(_) => {}
            Datum::Signal(s) => {
                names.extend(block(&s.name));
                names.push(format!("{}_time_s", s.name));
                names.push(format!("{}_interpolation_error", s.name));
                for kind in s.nuisance_names() {
                    names.push(format!("{}_{kind}", s.name));
                    names.push(format!("{}_{kind}_standard_error", s.name));
                }
            }
            Datum::Spectrum(s) => {
                names.extend(block(&s.name));
                names.push(format!("{}_frequency_hz", s.name));
                if s.phase.is_some() {
                    names.extend(block(&format!("{}_phase", s.name)));
                }
            }
        }
        names
    }

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
