//! The `search` block of a sweep file: instead of a value of each field at every grid point, a
//! search over continuous fields, run once for every point of the sweep's axes.
//!
//! ```json
//! "search": {
//!   "goal": "minimise",
//!   "fields": [{"field": "chain.cylinder.mass.heavy_cylinders.mass_ratio", "name": "mass_ratio",
//!               "min": 0.4, "max": 0.8, "tolerance": 1e-4}],
//!   "objective": {"ratio": [{"summary": "leading_peak", "probe": "gauge_force_cyl21"},
//!                           {"summary": "leading_peak", "probe": "gauge_force_cyl4"}]},
//!   "budget": 60
//! }
//! ```
//!
//! This module reads and checks the block ([`SearchSpec`]); the methods themselves are in
//! [`crate::search`].
//!
//! The objective, its parsing and its value for a run, are in `objective`.

use serde::Deserialize;
use serde_json::Value;

use chainsweep_solver::{Probe, Scene};

use super::{check_settable, from_ref_at, set_path, split_path, units_of, Dim};
use crate::error::{Error, Result};

mod objective;

use objective::parse_objective;
pub(super) use objective::parse_objective_at;
pub use objective::{Combine, Objective, Summary};

/// What a search looks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Goal {
    /// Every local minimum (one field), or the lowest point (several fields).
    Minimise,
    /// The same for the largest values.
    Maximise,
    /// Every crossing of a level (one field).
    Root,
    /// The objective over one or two fields, sampled until its interpolation is accurate.
    Refine,
    /// The fields that fit measured data best (weighted least squares), with their uncertainty.
    Fit,
}

impl Goal {
    /// The goal's name in a sweep file.
    pub fn name(self) -> &'static str {
        match self {
            Goal::Minimise => "minimise",
            Goal::Maximise => "maximise",
            Goal::Root => "root",
            Goal::Refine => "refine",
            Goal::Fit => "fit",
        }
    }

    /// The name of what it finds, one of each per found item (the output file's dimension):
    /// `minimum`, `maximum`, `root`; refine finds no items.
    pub fn item(self) -> &'static str {
        match self {
            Goal::Minimise => "minimum",
            Goal::Maximise => "maximum",
            Goal::Root => "root",
            Goal::Refine => "sample",
            Goal::Fit => "fit",
        }
    }
}

/// One searched field: a continuous scene field and its interval.
#[derive(Debug, Clone, PartialEq)]
pub struct SearchField {
    /// Its name (coordinate name in the output file).
    pub name: String,
    /// Dotted path of the scene field.
    pub field: String,
    /// Lower end of the interval.
    pub min: f64,
    /// Upper end.
    pub max: f64,
    /// Tolerance in the field: how closely a minimum or root is located (minimise, maximise,
    /// root), or the smallest spacing a refinement goes down to (refine).
    pub tolerance: f64,
    /// Unit from the field's name.
    pub units: String,
}

/// The objective taken across two values of an axis: each evaluation runs the scene at both, and
/// combines the objective of the two runs (the attenuation of one chain against another's).
#[derive(Debug, Clone, PartialEq)]
pub struct Across {
    /// The dimension (index into the sweep's dimensions) of the axis.
    pub dim: usize,
    /// Its name.
    pub name: String,
    /// How the two values combine: `combine(objective at points[0], objective at points[1])`.
    pub combine: Combine,
    /// The two indices along the dimension.
    pub points: [usize; 2],
}

/// What a failed run, or one whose objective is not a number, counts as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OnFailure {
    /// It ends its search (or the part of it that asked for it), recorded as `failed_run`.
    Stop,
    /// Worse than any number (minimise, maximise): the search goes on around it.
    Worst,
    /// A gap in a refined curve or surface: the intervals or cells next to it are not refined.
    Gap,
}

impl OnFailure {
    /// Its name in a sweep file.
    pub fn name(self) -> &'static str {
        match self {
            OnFailure::Stop => "stop",
            OnFailure::Worst => "worst",
            OnFailure::Gap => "gap",
        }
    }
}

/// A parsed, checked `search` block.
#[derive(Debug, Clone, PartialEq)]
pub struct SearchSpec {
    /// What it looks for.
    pub goal: Goal,
    /// The searched fields.
    pub fields: Vec<SearchField>,
    /// The objective.
    pub objective: Objective,
    /// The objective across two values of an axis, if so.
    pub across: Option<Across>,
    /// The level whose crossings a root search finds.
    pub level: f64,
    /// How accurately a refinement interpolates the objective (its units).
    pub objective_tolerance: f64,
    /// Points of the first scan along each field (one number per field).
    pub scan: Vec<usize>,
    /// Most runs of one search.
    pub budget: usize,
    /// Most points a search proposes at once (the same whatever the number of parallel runs).
    pub round: usize,
    /// What a failed run counts as.
    pub on_failure: OnFailure,
    /// Starting points of a search over several fields (the best local minima of its scan), or
    /// of a fit (the best points of its scan).
    pub starts: usize,
    /// A fit's data.
    pub fit: Option<super::fit::FitSpec>,
}

impl SearchSpec {
    /// Runs each evaluation takes: one, or two with `across`.
    pub fn runs_per_evaluation(&self) -> usize {
        match (&self.across, &self.fit) {
            (Some(_), _) => 2,
            (None, Some(f)) => f.variants.len(),
            (None, None) => 1,
        }
    }

    /// Evaluations of the first scan.
    pub fn scan_evaluations(&self) -> usize {
        self.scan.iter().fold(1usize, |n, &k| n.saturating_mul(k))
    }

    /// How it reads in one line: `minimise leading_peak[…] over mass_ratio in [0.4, 0.8] to ±0.0001`.
    pub fn describe(&self) -> String {
        use crate::error::number_text as num;
        let fields: Vec<String> = self
            .fields
            .iter()
            .map(|f| format!("{} in [{}, {}]", f.name, num(f.min), num(f.max)))
            .collect();
        let what = match &self.across {
            Some(a) => format!(
                "{} of ({}) between points {} and {} of {}",
                a.combine.name(),
                self.objective.describe(),
                a.points[0],
                a.points[1],
                a.name
            ),
            None => self.objective.describe(),
        };
        if let Some(fit) = &self.fit {
            let set = &fit.sets[0];
            let kinds: Vec<String> = set
                .data
                .iter()
                .map(|d| match d {
                    super::fit::Datum::Scalar(s) => s.name.clone(),
                    super::fit::Datum::Signal(s) => {
                        format!("signal {} ({} samples)", s.name, s.time_s.len())
                    }
                    super::fit::Datum::Spectrum(s) => {
                        format!("spectrum {} ({} frequencies)", s.name, s.frequency_hz.len())
                    }
                })
                .collect();
            return format!(
                "fit {} to {} datum(s){} ({}), σ {}, at most {} runs",
                fields.join(" × "),
                set.len(),
                if fit.sets.len() > 1 {
                    format!(" in each of {} data sets", fit.sets.len())
                } else {
                    String::new()
                },
                kinds.join(", "),
                match fit.sigma {
                    super::fit::SigmaRule::Given => "given",
                    super::fit::SigmaRule::Estimated => "estimated from the residuals",
                },
                self.budget
            );
        }
        let to = match self.goal {
            Goal::Refine => format!("to ±{} in the objective", num(self.objective_tolerance)),
            _ => {
                let t: Vec<String> = self
                    .fields
                    .iter()
                    .map(|f| format!("±{} in {}", num(f.tolerance), f.name))
                    .collect();
                format!("to {}", t.join(", "))
            }
        };
        let level = if self.goal == Goal::Root {
            format!(" = {}", self.level)
        } else {
            String::new()
        };
        format!(
            "{} {what}{level} over {} {to}, at most {} runs",
            self.goal.name(),
            fields.join(" × "),
            self.budget
        )
    }
}

/// Default points of the first scan along each field.
pub const DEFAULT_SCAN: usize = 10;

/// Default points proposed at once.
pub const DEFAULT_ROUND: usize = 4;

/// Default most runs of one search.
pub const DEFAULT_BUDGET: usize = 200;

/// Default starting points of a search over several fields.
pub const DEFAULT_STARTS: usize = 2;

/// Most runs of one search.
pub const MAX_BUDGET: usize = 1_000_000;

/// Most fields of a minimisation (Nelder–Mead is for a few).
pub const MAX_MINIMISE_FIELDS: usize = 4;

/// Most fields of a fit.
pub const MAX_FIT_FIELDS: usize = 6;

/// A search run at every point of the axes.
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub(super) struct SearchFile {
    /// What to find.
    #[schemars(extend("enum" = ["minimise", "minimize", "maximise", "maximize", "root", "refine", "fit"]))]
    goal: String,
    /// The continuous fields searched, each within [min, max].
    fields: Vec<FieldFile>,
    /// The quantity searched: a summary `{"summary": NAME, "probe": PROBE}`, or two combined
    /// `{"ratio" | "difference" | "log_ratio": [summary, summary]}` (not for a fit: it compares
    /// its data).
    #[serde(default)]
    objective: Option<Value>,
    /// A fit's measured data: a list of scalars `{"summary": …, "probe": …, "value": …, "sigma":
    /// …}` (or a ratio, difference, log_ratio of two summaries), recorded signals `{"signal":
    /// {"probe": …, "time_s": […] | "path": FILE, "value": […], "sigma": …, "time_shift_s":
    /// {"min": …, "max": …}, "gain": BOOL, "offset": BOOL, "window_s": [t0, t1]}}` and spectra
    /// `{"spectrum": {"probe": …, "frequency_hz": […] | "path": FILE, "amplitude" |
    /// "transmission_db": […], "sigma": …, "phase_rad": […], "phase_sigma_rad": …}}`.
    #[serde(default)]
    data: Option<Value>,
    /// Several data sets (a list of such lists): a fit for each, along a dimension of the output.
    #[serde(default)]
    data_sets: Option<Value>,
    /// The name of the data sets' dimension (default `data_set`).
    #[serde(default)]
    data_set_name: Option<String>,
    /// Whether a fit computes each field's profile likelihood (95 % intervals by re-fitting the
    /// others; default true).
    #[serde(default)]
    profile: Option<bool>,
    /// The objective taken across two values of an axis.
    #[serde(default)]
    across: Option<AcrossFile>,
    #[serde(default)]
    level: Option<f64>,
    #[serde(default)]
    objective_tolerance: Option<f64>,
    #[serde(default)]
    scan: Option<ScanFile>,
    #[serde(default)]
    budget: Option<u64>,
    #[serde(default)]
    round: Option<u64>,
    /// What a failed run counts as.
    #[serde(default)]
    #[schemars(extend("enum" = ["worst", "stop", "gap", null]))]
    failed: Option<String>,
    #[serde(default)]
    starts: Option<u64>,
}

/// `scan`: one number for every field, or a list of one per field.
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(untagged)]
enum ScanFile {
    Every(u64),
    Each(Vec<u64>),
}

/// A searched field and its bounds.
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
struct FieldFile {
    field: String,
    #[serde(default)]
    name: Option<String>,
    min: f64,
    max: f64,
    #[serde(default)]
    tolerance: Option<f64>,
}

/// Two values of an axis whose objectives combine.
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
struct AcrossFile {
    axis: String,
    #[schemars(extend("enum" = ["ratio", "difference", "log_ratio"]))]
    op: String,
    points: Vec<usize>,
}

fn bad(field: impl Into<String>, message: impl Into<String>) -> Error {
    Error::input(field, message)
}

/// The probes of the base scene's record block (none where it has none).
pub(super) fn probes_of(base: &Value) -> Vec<Probe> {
    base.get("record")
        .and_then(|r| r.get("probes"))
        .and_then(|p| serde_json::from_value::<Vec<Probe>>(p.clone()).ok())
        .unwrap_or_default()
}

/// The probe names of the base scene's record block.
fn probe_names(base: &Value) -> Vec<String> {
    probes_of(base).iter().map(|p| p.name()).collect()
}

/// Whether `field` takes any number in `[min, max]` in the scene `base` (a continuous field):
/// the scene built with the field at both ends and between reads the value back unchanged.
fn check_continuous(base: &Value, field: &str, min: f64, max: f64, at: &str) -> Result<()> {
    // A field that holds something other than a number in the scene (a list, a flag, a name)
    // is named as the wrong field, not as a wrong end of its interval.
    if let Ok(scene) = from_ref_at::<Scene>(base, "") {
        let current = serde_json::to_value(&scene).expect("Scene serialises");
        if let Ok(v) = super::lookup(&current, field) {
            if !v.is_number() && !v.is_null() {
                let kind = match v {
                    Value::Bool(_) => "a flag (true or false)",
                    Value::String(_) => "a name",
                    Value::Array(_) => "a list",
                    _ => "an object",
                };
                return Err(bad(
                    format!("{at}.field"),
                    format!("`{field}` is {kind}, not a number: a search needs a continuous field, a number that may take any value in its interval"),
                ));
            }
        }
    }
    for (x, end) in [(min, "min"), (max, "max"), (0.5 * (min + max), "min")] {
        let mut v = base.clone();
        set_path(&mut v, field, Value::from(x));
        let scene: Scene = from_ref_at(&v, "").map_err(|e| match e {
            // A misspelt field is the field's fault, not its interval's.
            Error::Input { message, .. } if message.contains("unknown field") => bad(
                format!("{at}.field"),
                format!("`{field}` is no field of the scene: {message}"),
            ),
            Error::Input { message, .. } => bad(
                format!("{at}.{end}"),
                format!(
                    "`{field}` cannot be set to {x}: {message} (a search needs a continuous field: a number that may take any value in its interval)"
                ),
            ),
            other => other,
        })?;
        let back = serde_json::to_value(&scene).expect("Scene serialises");
        let got = super::lookup(&back, field).ok().and_then(|v| v.as_f64());
        if got != Some(x) {
            return Err(bad(
                format!("{at}.field"),
                format!(
                    "`{field}` is not a continuous field: set to {x}, the scene holds {} (a search needs a number that may take any value in its interval)",
                    got.map_or("no number".to_string(), |g| g.to_string())
                ),
            ));
        }
    }
    Ok(())
}

/// Reads and checks the `search` block against the normalised `base` scene and the sweep's
/// dimensions `dims` (a fit's data sets add theirs).
pub(super) fn parse(f: SearchFile, base: &Value, dims: &mut Vec<Dim>) -> Result<SearchSpec> {
    let goal = match f.goal.as_str() {
        "minimise" | "minimize" => Goal::Minimise,
        "maximise" | "maximize" => Goal::Maximise,
        "root" => Goal::Root,
        "refine" => Goal::Refine,
        "fit" => Goal::Fit,
        other => {
            return Err(bad(
                "search.goal",
                format!("`{other}` is none of minimise, maximise, root, refine, fit"),
            ))
        }
    };
    let most = match goal {
        Goal::Root => 1,
        Goal::Refine => 2,
        Goal::Minimise | Goal::Maximise => MAX_MINIMISE_FIELDS,
        Goal::Fit => MAX_FIT_FIELDS,
    };
    if goal != Goal::Fit {
        for (key, given) in [
            ("data", f.data.is_some()),
            ("data_sets", f.data_sets.is_some()),
            ("data_set_name", f.data_set_name.is_some()),
            ("profile", f.profile.is_some()),
        ] {
            if given {
                return Err(bad(
                    format!("search.{key}"),
                    format!(
                        "only a fit has {key} (this search's goal is {})",
                        goal.name()
                    ),
                ));
            }
        }
    }
    if f.fields.is_empty() || f.fields.len() > most {
        return Err(bad(
            "search.fields",
            format!(
                "a {} search takes 1 to {most} field(s), got {}",
                goal.name(),
                f.fields.len()
            ),
        ));
    }
    let mut fields: Vec<SearchField> = Vec::new();
    for (i, ff) in f.fields.into_iter().enumerate() {
        let at = format!("search.fields[{i}]");
        check_settable(base, &ff.field).map_err(|m| bad(format!("{at}.field"), m))?;
        if split_path(&ff.field)[0] == "record" {
            return Err(bad(
                format!("{at}.field"),
                "the record block is the same for every run: it cannot be searched",
            ));
        }
        if !(ff.min.is_finite() && ff.max.is_finite() && ff.min < ff.max) {
            return Err(bad(
                format!("{at}.max"),
                format!(
                    "the interval [{}, {}] is empty: give finite numbers with min < max",
                    ff.min, ff.max
                ),
            ));
        }
        let width = ff.max - ff.min;
        let tolerance = match (goal, ff.tolerance) {
            (_, Some(t)) if t.is_finite() && t > 0.0 && t < width => t,
            (_, Some(t)) => {
                return Err(bad(
                    format!("{at}.tolerance"),
                    format!("must be a number > 0 and below the interval's width {width}, got {t}"),
                ))
            }
            (Goal::Refine, None) => width * 1e-3,
            // A fit ends when its steps are statistically negligible; a tolerance, when given,
            // ends it also once every step is below it.
            (Goal::Fit, None) => 0.0,
            (_, None) => {
                return Err(bad(
                    format!("{at}.tolerance"),
                    format!(
                        "missing: how closely to locate the {} in this field (its units)",
                        goal.item()
                    ),
                ))
            }
        };
        check_continuous(base, &ff.field, ff.min, ff.max, &at)?;
        let name = ff
            .name
            .unwrap_or_else(|| split_path(&ff.field).last().cloned().unwrap_or_default());
        // A searched field is a coordinate of the output file, as an axis is: its name must be
        // usable there (not `status`, `objective`, …), checked here, not when the file is written.
        super::check_name(&name, &at, &[])?;
        let field_segs = split_path(&ff.field);
        for d in dims.iter() {
            for a in &d.axes {
                let a_segs = split_path(&a.field);
                let n = a_segs.len().min(field_segs.len());
                if a_segs[..n] == field_segs[..n] {
                    return Err(bad(
                        format!("{at}.field"),
                        format!(
                            "`{}` overlaps `{}` set by {}: a field is searched or swept, not both",
                            ff.field, a.field, a.origin
                        ),
                    ));
                }
                if a.name == name {
                    return Err(bad(
                        format!("{at}.name"),
                        format!("name `{name}` is already used by {}", a.origin),
                    ));
                }
            }
        }
        if let Some(other) = fields.iter().find(|g| {
            let s = split_path(&g.field);
            let n = s.len().min(field_segs.len());
            s[..n] == field_segs[..n] || g.name == name
        }) {
            return Err(bad(
                format!("{at}.field"),
                format!(
                    "overlaps the searched field `{}` (each field once)",
                    other.field
                ),
            ));
        }
        fields.push(SearchField {
            units: units_of(&ff.field),
            name,
            field: ff.field,
            min: ff.min,
            max: ff.max,
            tolerance,
        });
    }
    let probes = probe_names(base);
    let objective = match (goal, &f.objective) {
        (Goal::Fit, None) => Objective::ChiSquare,
        (Goal::Fit, Some(_)) => {
            return Err(bad(
                "search.objective",
                "a fit has no objective: it minimises χ² against its data (search.data)",
            ))
        }
        (_, Some(o)) => parse_objective(o, &probes)?,
        (_, None) => {
            return Err(bad(
                "search.objective",
                "missing: the quantity searched, a summary {\"summary\": NAME, \"probe\": PROBE} or two combined",
            ))
        }
    };
    let across = match f.across {
        None => None,
        Some(_) if goal == Goal::Fit => {
            return Err(bad(
                "search.across",
                "a fit compares its runs with data: it takes no objective across an axis",
            ))
        }
        Some(a) => {
            let dim = dims
                .iter()
                .position(|d| d.name == a.axis || d.axes.iter().any(|x| x.name == a.axis))
                .ok_or_else(|| {
                    let names: Vec<&str> = dims.iter().map(|d| d.name.as_str()).collect();
                    bad(
                        "search.across.axis",
                        format!(
                            "`{}` names no axis of the sweep; its dimensions: {}",
                            a.axis,
                            if names.is_empty() {
                                "none".to_string()
                            } else {
                                names.join(", ")
                            }
                        ),
                    )
                })?;
            let combine = Combine::parse(&a.op).ok_or_else(|| {
                bad(
                    "search.across.op",
                    format!("`{}` is none of ratio, difference, log_ratio", a.op),
                )
            })?;
            let n = dims[dim].len();
            if a.points.len() != 2 || a.points[0] == a.points[1] || a.points.iter().any(|&p| p >= n)
            {
                return Err(bad(
                    "search.across.points",
                    format!(
                        "must be two different indices along `{}` (0 to {}), got {:?}",
                        a.axis,
                        n - 1,
                        a.points
                    ),
                ));
            }
            Some(Across {
                dim,
                name: dims[dim].name.clone(),
                combine,
                points: [a.points[0], a.points[1]],
            })
        }
    };
    let level = match (goal, f.level) {
        (Goal::Root, Some(l)) if l.is_finite() => l,
        (Goal::Root, Some(l)) => {
            return Err(bad(
                "search.level",
                format!("must be a finite number, got {l}"),
            ))
        }
        (Goal::Root, None) => 0.0,
        (_, Some(_)) => return Err(bad("search.level", "only a root search has a level")),
        (_, None) => f64::NAN,
    };
    let objective_tolerance = match (goal, f.objective_tolerance) {
        (Goal::Refine, Some(t)) if t.is_finite() && t > 0.0 => t,
        (Goal::Refine, Some(t)) => {
            return Err(bad("search.objective_tolerance", format!("must be a number > 0, got {t}")))
        }
        (Goal::Refine, None) => {
            return Err(bad(
                "search.objective_tolerance",
                "missing: how accurately the refined samples must interpolate the objective (its units)",
            ))
        }
        (_, Some(_)) => {
            return Err(bad(
                "search.objective_tolerance",
                "only a refine search has one (the others locate to `tolerance` in each field)",
            ))
        }
        (_, None) => f64::NAN,
    };
    let d = fields.len();
    // A bracket needs a point on either side (one-field minimum); a refined surface's edges need
    // a neighbouring line along each field.
    let min_scan = match (goal, d) {
        (Goal::Minimise | Goal::Maximise | Goal::Refine, _) if d == 1 => 3,
        (Goal::Refine, _) => 3,
        _ => 2,
    };
    let default_scan = match goal {
        // Quasi-random points of the box, from which the fit starts.
        Goal::Fit => (4 * d + 2) as u64,
        _ if d == 1 => DEFAULT_SCAN as u64,
        _ => 5,
    };
    let scan: Vec<u64> = match f.scan {
        // A fit's scan is a number of quasi-random points, not a lattice.
        None if goal == Goal::Fit => vec![default_scan],
        Some(ScanFile::Every(n)) if goal == Goal::Fit => vec![n],
        Some(ScanFile::Each(_)) if goal == Goal::Fit => {
            return Err(bad(
                "search.scan",
                "a fit's scan is one number: the quasi-random points of the box its starts are chosen from",
            ))
        }
        None => vec![default_scan; d],
        Some(ScanFile::Every(n)) => vec![n; d],
        Some(ScanFile::Each(list)) if list.len() == d => list,
        Some(ScanFile::Each(list)) => {
            return Err(bad(
                "search.scan",
                format!(
                    "a list gives one number per searched field: {d} here, got {}",
                    list.len()
                ),
            ))
        }
    };
    let min_scan = if goal == Goal::Fit { 1 } else { min_scan };
    if let Some(&n) = scan.iter().find(|&&n| n < min_scan || n > 100_000) {
        return Err(bad(
            "search.scan",
            format!("must be a whole number from {min_scan} to 100000 (or a list of such, one per field), got {n}"),
        ));
    }
    let round = f.round.unwrap_or(DEFAULT_ROUND as u64);
    if !(1..=10_000).contains(&round) {
        return Err(bad(
            "search.round",
            format!("must be a whole number from 1 to 10000, got {round}"),
        ));
    }
    let starts = f.starts.unwrap_or(DEFAULT_STARTS as u64);
    if goal == Goal::Fit && starts > scan[0] {
        return Err(bad(
            "search.starts",
            format!(
                "{starts} starts cannot be chosen from a scan of {} point(s)",
                scan[0]
            ),
        ));
    }
    if !(1..=100).contains(&starts) {
        return Err(bad(
            "search.starts",
            format!("must be a whole number from 1 to 100, got {starts}"),
        ));
    }
    if f.starts.is_some()
        && !(goal == Goal::Fit || d > 1 && matches!(goal, Goal::Minimise | Goal::Maximise))
    {
        return Err(bad(
            "search.starts",
            "only a fit, or a minimisation or maximisation over several fields, has starting points",
        ));
    }
    let on_failure = match (goal, f.failed.as_deref()) {
        (Goal::Minimise | Goal::Maximise | Goal::Fit, None | Some("worst")) => OnFailure::Worst,
        (Goal::Root, None) | (_, Some("stop")) => OnFailure::Stop,
        (Goal::Refine, None | Some("gap")) => OnFailure::Gap,
        (_, Some(other)) => {
            let allowed = match goal {
                Goal::Minimise | Goal::Maximise | Goal::Fit => "worst, stop",
                Goal::Root => "stop",
                Goal::Refine => "gap, stop",
            };
            return Err(bad(
                "search.failed",
                format!(
                    "`{other}` is not a rule of a {} search; allowed: {allowed}",
                    goal.name()
                ),
            ));
        }
    };
    let fit = match goal {
        Goal::Fit => Some(super::fit::parse(
            f.data.as_ref(),
            f.data_sets.as_ref(),
            f.data_set_name.as_deref(),
            f.profile,
            base,
            dims,
            d,
        )?),
        _ => None,
    };
    let mut spec = SearchSpec {
        fit,
        goal,
        fields,
        objective,
        across,
        level,
        objective_tolerance,
        scan: scan.iter().map(|&n| n as usize).collect(),
        budget: 0,
        round: round as usize,
        on_failure,
        starts: starts as usize,
    };
    // A fit's default: room for its scan, its starts' iterations and its profiles, in
    // evaluations, each of the runs it takes (a spectrum's frequencies).
    let default_budget = match goal {
        Goal::Fit => ((60 + 40 * spec.fields.len()) * spec.runs_per_evaluation()).min(MAX_BUDGET),
        _ => DEFAULT_BUDGET,
    };
    let budget = f.budget.unwrap_or(default_budget as u64);
    let first = spec
        .scan_evaluations()
        .saturating_mul(spec.runs_per_evaluation());
    if budget == 0 || budget > MAX_BUDGET as u64 {
        return Err(bad(
            "search.budget",
            format!("must be a whole number of runs from 1 to {MAX_BUDGET}, got {budget}"),
        ));
    }
    if (budget as usize) < first {
        return Err(bad(
            "search.budget",
            format!(
                "{budget} runs do not cover the first scan: {} point(s){} take {first} runs (lower `scan` or raise the budget)",
                spec.scan_evaluations(),
                match spec.runs_per_evaluation() {
                    1 => String::new(),
                    k => format!(" of {k} runs each"),
                }
            ),
        ));
    }
    spec.budget = budget as usize;
    Ok(spec)
}

/// `base` with the searched `fields` set to `values` (one per field).
pub fn set_fields(base: &mut Value, fields: &[SearchField], values: &[f64]) {
    for (f, &x) in fields.iter().zip(values) {
        set_path(base, &f.field, Value::from(x));
    }
}
