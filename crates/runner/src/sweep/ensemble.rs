//! The `ensemble` block: scene fields drawn from distributions, the design that places the
//! samples, and the statistics asked of them.
//!
//! ```json
//! "ensemble": {
//!   "inputs": [
//!     {"field": "physics.damping_kg_s", "normal": {"mean": 6.1, "sd": 0.3}},
//!     {"field": "striker_velocity_m_s", "normal": {"relative_sd": 0.02}},
//!     {"mass_factors": "cylinders", "normal": {"sd": 0.01}}
//!   ],
//!   "design": "sobol", "samples": 64, "replicates": 8, "seed": 1,
//!   "statistics": [{"name": "f21_f4", "of": {"ratio": [{"summary": "leading_peak", "probe": "gauge_force_cyl21"},
//!                                                     {"summary": "leading_peak", "probe": "gauge_force_cyl4"}]},
//!                   "tolerance": {"mean": 0.002}}]
//! }
//! ```
//!
//! The samples are ordinary runs: the ensemble adds one dimension to the grid, `member` (`sample`
//! is a history's), along
//! which every sampled field is a zipped axis (a coordinate of the output file), beside index
//! axes that say where each sample sits in the design (`replicate`; Saltelli's `block`;
//! Morris's `trajectory` and `step`). An adaptive ensemble grows that dimension in rounds
//! ([`EnsembleSpec::dim`]); each round's samples are its predecessor's and as many more.

use std::ops::Range;

use serde::Deserialize;
use serde_json::{Map, Value};

use chainsweep_solver::chain::parts::ParticleKind;
use chainsweep_solver::observe::probes::Probe;
use chainsweep_solver::{Chain, Scene};

use super::search::{parse_objective_at, Objective};
use super::{check_field, check_name, from_ref_at, lookup, set_path, units_of, Axis, Dim};
use crate::error::{Error, Result};
use crate::uq::design::{self, Kind, MorrisStep, MAX_SOBOL_DIMS};
use crate::uq::dist::{cholesky, correlate, lower_times, normal_quantile, Dist};

/// The most samples (runs per point of the ordinary axes) one round may have.
pub const MAX_SAMPLES: usize = 1 << 22;

/// The budget of an adaptive ensemble that names none, in runs.
pub const DEFAULT_MAX_RUNS: usize = 65_536;

/// `ensemble` as written.
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct EnsembleFile {
    /// The sampled fields, each with its distribution (independent unless `correlation` ties
    /// them): `{"field": PATH or [PATHS that take one value], DISTRIBUTION: {…}}`, `{"mass_factors": "cylinders" | "spheres" |
    /// "chain" | "all" | [particle numbers], DISTRIBUTION: {…}}` (every chosen particle's mass
    /// factor drawn independently: a manufacturing tolerance), `{"multivariate_normal": {"fields":
    /// […], "mean": […], "covariance": [[…]]}}` or `{"from_fit": "FIT.h5"}` (a fit's best values
    /// and covariance). A distribution is one of `uniform {min, max}`, `log_uniform {min, max}`,
    /// `normal {mean, sd | relative_sd}`, `log_normal {median, sigma_ln}`, `truncated_normal
    /// {mean, sd | relative_sd, min, max}`, `triangular {min, mode, max}`, `discrete {values,
    /// weights}`; a missing `mean`, `median` or `mode` is the base scene's value.
    pub inputs: Vec<Map<String, Value>>,
    /// Dependence between scalar inputs by a Gaussian copula: `{"inputs": [names], "matrix":
    /// [[…]]}`, a correlation matrix (symmetric, unit diagonal, positive definite).
    #[serde(default)]
    pub correlation: Option<CorrelationFile>,
    /// `sobol` (scrambled Sobol' points, the default), `latin_hypercube`, `monte_carlo`,
    /// `saltelli` (Sobol' indices of every input) or `morris` (elementary effects, screening).
    #[serde(default)]
    pub design: Option<String>,
    /// The seed every random choice of the design follows (default 0).
    #[serde(default)]
    pub seed: u64,
    /// Samples of each replicate (Sobol': a power of two; default 64, Monte Carlo 512), base
    /// rows of Saltelli's matrices (a power of two, default 256), or Morris trajectories
    /// (default 20). An adaptive ensemble starts there.
    #[serde(default)]
    pub samples: Option<u64>,
    /// Independent randomisations of the design, whose spread gives the statistics' intervals
    /// (default 8 for Sobol' and Latin hypercube, 1 for Monte Carlo).
    #[serde(default)]
    pub replicates: Option<u64>,
    /// The most runs an adaptive ensemble may take, over all points of the axes (default 65536).
    #[serde(default)]
    pub max_runs: Option<u64>,
    /// Levels of a Morris design's grid (even, default 4).
    #[serde(default)]
    pub levels: Option<u64>,
    /// The quantities whose statistics are computed: `{"of": SUMMARY or {"ratio" | "difference"
    /// | "log_ratio": [SUMMARY, SUMMARY]}, "name": …, "exceed": [levels], "tolerance": {"mean",
    /// "sd", "quantiles", "exceed": largest widths of their 95 % intervals}}`. A tolerance makes
    /// the ensemble adaptive: it doubles until every interval is narrower, or the budget is spent.
    pub statistics: Vec<Map<String, Value>>,
    /// Probabilities of the quantiles computed (default 0.05, 0.5, 0.95).
    #[serde(default)]
    pub quantiles: Option<Vec<f64>>,
    /// Bins of each statistic's histogram (default 20; 0: none).
    #[serde(default)]
    pub histogram_bins: Option<u64>,
}

/// `ensemble.correlation` as written.
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CorrelationFile {
    /// The correlated inputs, by name.
    pub inputs: Vec<String>,
    /// Their correlation matrix.
    pub matrix: Vec<Vec<f64>>,
}

/// How an ensemble's samples are placed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Design {
    /// Replicates of a design for statistics.
    Sample(Kind),
    /// Saltelli's matrices, for Sobol' indices.
    Saltelli,
    /// Morris trajectories on a grid of `levels` levels.
    Morris {
        /// The grid's levels.
        levels: usize,
    },
}

impl Design {
    /// Its name in the sweep file.
    pub fn name(self) -> &'static str {
        match self {
            Design::Sample(Kind::Sobol) => "sobol",
            Design::Sample(Kind::LatinHypercube) => "latin_hypercube",
            Design::Sample(Kind::MonteCarlo) => "monte_carlo",
            Design::Saltelli => "saltelli",
            Design::Morris { .. } => "morris",
        }
    }
}

/// One input: a group of sampled columns (a field, a particle's mass factors, a fit's fields).
#[derive(Debug, Clone, PartialEq)]
pub struct Input {
    /// Its name (a sensitivity's label).
    pub name: String,
    /// Its columns of the unit design (a range of [`EnsembleSpec::columns`]).
    pub columns: Range<usize>,
    /// How its columns become values.
    pub kind: InputKind,
}

/// How an input's uniforms become field values.
#[derive(Debug, Clone, PartialEq)]
pub enum InputKind {
    /// Each column its own distribution (a field, or each chosen particle's mass factor).
    Independent(Vec<Dist>),
    /// One value for every column (one quantity several fields hold, e.g. the coefficient of
    /// two contact rules).
    Tied(Dist),
    /// A multivariate normal: `mean + L z`, `z` the columns' standard normals.
    Normal {
        /// Its mean.
        mean: Vec<f64>,
        /// The lower Cholesky factor of its covariance (row-major).
        chol: Vec<f64>,
    },
}

/// One sampled column: the field it sets and its coordinate.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    /// Dotted path of the field.
    pub field: String,
    /// Coordinate name.
    pub name: String,
    /// Unit.
    pub units: String,
}

/// Widths the 95 % intervals of a statistic must fall under (`None`: not asked).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Tolerance {
    /// Of the mean.
    pub mean: Option<f64>,
    /// Of the standard deviation.
    pub sd: Option<f64>,
    /// Of every quantile.
    pub quantiles: Option<f64>,
    /// Of every probability of exceeding.
    pub exceed: Option<f64>,
}

impl Tolerance {
    /// Whether any width is asked.
    pub fn any(&self) -> bool {
        self.mean.is_some()
            || self.sd.is_some()
            || self.quantiles.is_some()
            || self.exceed.is_some()
    }
}

/// A quantity whose statistics are computed.
#[derive(Debug, Clone, PartialEq)]
pub struct Statistic {
    /// Its name (the stem of its variables).
    pub name: String,
    /// The summary (or combination) of a run it is.
    pub of: Objective,
    /// Its unit.
    pub units: String,
    /// Levels whose probability of being exceeded is estimated.
    pub exceed: Vec<f64>,
    /// The adaptive rule's widths.
    pub tolerance: Tolerance,
}

/// A parsed, checked `ensemble` block.
#[derive(Debug, Clone, PartialEq)]
pub struct EnsembleSpec {
    /// The inputs, in order.
    pub inputs: Vec<Input>,
    /// Every sampled column, in order.
    pub columns: Vec<Column>,
    /// The Gaussian copula: the correlated columns and their correlation's Cholesky factor.
    pub copula: Option<(Vec<usize>, Vec<f64>)>,
    /// The design.
    pub design: Design,
    /// Its seed.
    pub seed: u64,
    /// Samples per replicate, Saltelli's base rows or Morris trajectories, in round 0 (the start).
    pub samples: usize,
    /// Replicates in round 0 (the start).
    pub replicates: usize,
    /// The budget in runs when adaptive (`None`: a fixed size).
    pub max_runs: Option<usize>,
    /// The statistics.
    pub statistics: Vec<Statistic>,
    /// Quantile probabilities.
    pub quantiles: Vec<f64>,
    /// Histogram bins.
    pub bins: usize,
    /// Points of the ordinary axes (each runs every sample).
    pub outer_points: usize,
}

/// Where each sample of a round lies in its design.
#[derive(Debug, Clone, PartialEq)]
pub enum Layout {
    /// `replicates` blocks of `per` samples.
    Replicates {
        /// Samples per replicate.
        per: usize,
        /// Replicates.
        replicates: usize,
    },
    /// Saltelli's blocks of `n` rows: A, B, then one per input.
    Saltelli {
        /// Rows per block.
        n: usize,
    },
    /// Morris trajectories, one row each step.
    Morris(Vec<MorrisStep>),
}

fn bad(field: impl Into<String>, message: impl Into<String>) -> Error {
    Error::input(field, message)
}

fn number(v: &Value, at: &str) -> Result<f64> {
    v.as_f64()
        .filter(|x| x.is_finite())
        .ok_or_else(|| bad(at, format!("must be a finite number, got {v}")))
}

fn numbers(v: &Value, at: &str) -> Result<Vec<f64>> {
    v.as_array()
        .ok_or_else(|| bad(at, "must be a list of numbers"))?
        .iter()
        .enumerate()
        .map(|(i, x)| number(x, &format!("{at}[{i}]")))
        .collect()
}

const DISTRIBUTIONS: &[&str] = &[
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
fn dist_of(m: &Map<String, Value>, at: &str, nominal: Option<f64>) -> Result<Dist> {
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

/// The base scene's number at `field`, if it holds one.
fn nominal(base: &Value, field: &str) -> Option<f64> {
    let scene: Scene = from_ref_at(base, "").ok()?;
    let v = serde_json::to_value(&scene).ok()?;
    lookup(&v, field).ok()?.as_f64()
}

/// Checks that `field` is a number of the scene that takes `value` (the scene built with it reads
/// it back unchanged).
fn check_number_field(base: &Value, field: &str, value: f64, at: &str) -> Result<()> {
    let mut v = base.clone();
    if let Err(e) = super::check_settable(&v, field) {
        return Err(bad(at, e));
    }
    set_path(&mut v, field, Value::from(value));
    let scene: Scene = from_ref_at(&v, "").map_err(|e| match e {
        Error::Input { message, .. } => bad(
            at,
            format!(
                "`{field}` cannot be set to {value} (a value the distribution gives): {message}"
            ),
        ),
        other => other,
    })?;
    let back = serde_json::to_value(&scene).expect("Scene serialises");
    let got = lookup(&back, field).ok().and_then(Value::as_f64);
    if got != Some(value) {
        return Err(bad(
            at,
            format!(
                "`{field}` is not a continuous number of the scene: set to {value}, the scene holds {}",
                got.map_or("no number".to_string(), |g| g.to_string())
            ),
        ));
    }
    Ok(())
}

struct Reader<'a> {
    base: &'a mut Value,
    inputs: Vec<Input>,
    columns: Vec<Column>,
}

impl Reader<'_> {
    fn push(&mut self, name: String, columns: Vec<Column>, kind: InputKind) {
        let start = self.columns.len();
        self.columns.extend(columns);
        self.inputs.push(Input {
            name,
            columns: start..self.columns.len(),
            kind,
        });
    }

    fn field(&mut self, m: &Map<String, Value>, at: &str) -> Result<()> {
        let path_error = || {
            bad(
                format!("{at}.field"),
                "must be a dotted field path (a string), or a list of them that take one value",
            )
        };
        let fields: Vec<String> = match &m["field"] {
            Value::String(f) => vec![f.clone()],
            Value::Array(a) if !a.is_empty() => a
                .iter()
                .map(|f| f.as_str().map(str::to_string))
                .collect::<Option<_>>()
                .ok_or_else(path_error)?,
            _ => return Err(path_error()),
        };
        if let Some(k) = m.keys().find(|k| {
            !["field", "name"].contains(&k.as_str()) && !DISTRIBUTIONS.contains(&k.as_str())
        }) {
            return Err(bad(
                format!("{at}.{k}"),
                format!(
                    "unknown key of a field's input; allowed: field, name, and one of {}",
                    DISTRIBUTIONS.join(", ")
                ),
            ));
        }
        let dist = dist_of(m, at, nominal(self.base, &fields[0]))?;
        for f in &fields {
            for u in [0.001, 0.5, 0.999] {
                check_number_field(self.base, f, dist.quantile(u), &format!("{at}.field"))?;
            }
        }
        let name = match m.get("name") {
            Some(Value::String(s)) => s.clone(),
            Some(_) => return Err(bad(format!("{at}.name"), "must be a string")),
            None => super::field_name(&fields[0]),
        };
        let columns = fields
            .iter()
            .enumerate()
            .map(|(j, f)| Column {
                field: f.clone(),
                name: if j == 0 {
                    name.clone()
                } else {
                    format!("{name}_{}", j + 1)
                },
                units: units_of(f),
            })
            .collect();
        let kind = if fields.len() == 1 {
            InputKind::Independent(vec![dist])
        } else {
            InputKind::Tied(dist)
        };
        self.push(name, columns, kind);
        Ok(())
    }

    fn mass_factors(&mut self, m: &Map<String, Value>, at: &str) -> Result<()> {
        if let Some(k) = m.keys().find(|k| {
            !["mass_factors", "name"].contains(&k.as_str()) && !DISTRIBUTIONS.contains(&k.as_str())
        }) {
            return Err(bad(
                format!("{at}.{k}"),
                format!("unknown key of a mass-factor input; allowed: mass_factors, name, and one of {}", DISTRIBUTIONS.join(", ")),
            ));
        }
        let scene: Scene = from_ref_at(self.base, "base")?;
        let chain = Chain::build(&scene.chain, &scene.physics).map_err(|e| {
            bad(
                format!("{at}.mass_factors"),
                format!("the base chain does not build ({}: {})", e.field, e.message),
            )
        })?;
        let n = chain.n_particles();
        let which = &m["mass_factors"];
        let chosen: Vec<usize> = match which {
            Value::String(s) => {
                let keep = |k: ParticleKind| match s.as_str() {
                    "cylinders" => Some(k == ParticleKind::Cylinder),
                    "spheres" => Some(k == ParticleKind::Sphere),
                    "chain" => Some(k != ParticleKind::Striker),
                    "all" => Some(true),
                    _ => None,
                };
                if keep(ParticleKind::Sphere).is_none() {
                    return Err(bad(
                        format!("{at}.mass_factors"),
                        format!("`{s}` is none of cylinders, spheres, chain (all but the striker), all, or a list of particle numbers"),
                    ));
                }
                (0..n)
                    .filter(|&p| keep(chain.kind[p]) == Some(true))
                    .collect()
            }
            Value::Array(list) => list
                .iter()
                .enumerate()
                .map(|(i, v)| {
                    v.as_u64()
                        .map(|p| p as usize)
                        .filter(|p| (1..=n).contains(p))
                        .map(|p| p - 1)
                        .ok_or_else(|| {
                            bad(
                                format!("{at}.mass_factors[{i}]"),
                                format!("must be a particle number from 1 to {n}, got {v}"),
                            )
                        })
                })
                .collect::<Result<_>>()?,
            _ => {
                return Err(bad(
                    format!("{at}.mass_factors"),
                    "must be cylinders, spheres, chain, all, or a list of particle numbers",
                ))
            }
        };
        if chosen.is_empty() {
            return Err(bad(
                format!("{at}.mass_factors"),
                format!("chooses no particle of the base chain ({n} particles)"),
            ));
        }
        // The base holds one factor per particle, so that each chosen one is a field of its own.
        let existing: Vec<f64> = match self.base.pointer("/chain/mass_factors") {
            Some(Value::Array(a)) if a.len() == n => {
                a.iter().map(|x| x.as_f64().unwrap_or(1.0)).collect()
            }
            _ => vec![1.0; n],
        };
        set_path(
            self.base,
            "chain.mass_factors",
            Value::from(existing.clone()),
        );
        let stem = match m.get("name") {
            Some(Value::String(s)) => s.clone(),
            Some(_) => return Err(bad(format!("{at}.name"), "must be a string")),
            None => "mass_factor".to_string(),
        };
        let mut dists = Vec::new();
        let mut columns = Vec::new();
        for &p in &chosen {
            let d = dist_of(m, at, Some(existing[p]))?;
            for u in [1e-6, 1.0 - 1e-6] {
                let x = d.quantile(u);
                if !(x > 1e-3 && x < 1e3) {
                    return Err(bad(
                        at,
                        format!("gives particle {}'s mass factor {x} (at probability {u}): a factor must lie in (1e-3, 1e3); a normal tolerance wider than a few tens of per cent can give negative masses, take log_normal or truncated_normal", p + 1),
                    ));
                }
            }
            dists.push(d);
            columns.push(Column {
                field: format!("chain.mass_factors.{p}"),
                name: format!("{stem}_{}", p + 1),
                units: "1".into(),
            });
        }
        self.push(stem, columns, InputKind::Independent(dists));
        Ok(())
    }

    fn multivariate(&mut self, mv: &Value, at: &str) -> Result<()> {
        let Value::Object(m) = mv else {
            return Err(bad(
                at,
                "must be {\"fields\": […], \"mean\": […], \"covariance\": [[…]]}",
            ));
        };
        if let Some(k) = m
            .keys()
            .find(|k| !["fields", "names", "mean", "covariance", "name"].contains(&k.as_str()))
        {
            return Err(bad(
                format!("{at}.{k}"),
                "unknown key; allowed: fields, names, mean, covariance, name",
            ));
        }
        let fields: Vec<String> = m
            .get("fields")
            .and_then(Value::as_array)
            .ok_or_else(|| {
                bad(
                    format!("{at}.fields"),
                    "missing: the dotted paths of the fields",
                )
            })?
            .iter()
            .map(|f| f.as_str().map(str::to_string))
            .collect::<Option<_>>()
            .ok_or_else(|| bad(format!("{at}.fields"), "must be a list of dotted paths"))?;
        let k = fields.len();
        if k == 0 {
            return Err(bad(format!("{at}.fields"), "must name at least one field"));
        }
        let mean = numbers(
            m.get("mean")
                .ok_or_else(|| bad(format!("{at}.mean"), "missing"))?,
            &format!("{at}.mean"),
        )?;
        if mean.len() != k {
            return Err(bad(
                format!("{at}.mean"),
                format!("must give one mean per field ({k}), got {}", mean.len()),
            ));
        }
        let rows = m
            .get("covariance")
            .and_then(Value::as_array)
            .ok_or_else(|| {
                bad(
                    format!("{at}.covariance"),
                    "missing: a k × k covariance matrix",
                )
            })?;
        let mut cov = Vec::with_capacity(k * k);
        for (i, r) in rows.iter().enumerate() {
            let r = numbers(r, &format!("{at}.covariance[{i}]"))?;
            if r.len() != k {
                return Err(bad(
                    format!("{at}.covariance[{i}]"),
                    format!("must hold {k} numbers (one per field)"),
                ));
            }
            cov.extend(r);
        }
        if rows.len() != k {
            return Err(bad(
                format!("{at}.covariance"),
                format!(
                    "must be {k} × {k} (one row per field), got {} rows",
                    rows.len()
                ),
            ));
        }
        for i in 0..k {
            for j in 0..i {
                if (cov[i * k + j] - cov[j * k + i]).abs()
                    > 1e-12 * (cov[i * k + i] * cov[j * k + j]).sqrt()
                {
                    return Err(bad(
                        format!("{at}.covariance"),
                        format!("is not symmetric: element ({i}, {j}) differs from ({j}, {i})"),
                    ));
                }
            }
        }
        let chol = cholesky(&cov, k).ok_or_else(|| {
            bad(
                format!("{at}.covariance"),
                "is not positive definite (a fit that leaves a combination of its fields undetermined has no such covariance: fix or drop a field)",
            )
        })?;
        let names: Vec<String> = match m.get("names") {
            Some(Value::Array(a)) if a.len() == k => a
                .iter()
                .map(|v| v.as_str().map(str::to_string))
                .collect::<Option<_>>()
                .ok_or_else(|| bad(format!("{at}.names"), "must be a list of names"))?,
            Some(_) => {
                return Err(bad(
                    format!("{at}.names"),
                    format!("must be a list of {k} names"),
                ))
            }
            None => fields.iter().map(|f| super::field_name(f)).collect(),
        };
        for (i, f) in fields.iter().enumerate() {
            let sd = chol[i * k..i * k + i + 1]
                .iter()
                .map(|x| x * x)
                .sum::<f64>()
                .sqrt();
            for z in [-3.0, 0.0, 3.0] {
                check_number_field(self.base, f, mean[i] + z * sd, &format!("{at}.fields[{i}]"))?;
            }
        }
        let columns = fields
            .iter()
            .zip(&names)
            .map(|(f, n)| Column {
                field: f.clone(),
                name: n.clone(),
                units: units_of(f),
            })
            .collect();
        let name = match m.get("name") {
            Some(Value::String(s)) => s.clone(),
            _ => names.join("+"),
        };
        self.push(name, columns, InputKind::Normal { mean, chol });
        Ok(())
    }
}

/// Reads and checks the `ensemble` block against the normalised `base` (which gains one mass
/// factor per particle when an input draws them) and the ordinary dimensions `dims`; pushes the
/// `member` dimension of round 0.
pub(super) fn parse(
    f: EnsembleFile,
    base: &mut Value,
    dims: &mut Vec<Dim>,
) -> Result<EnsembleSpec> {
    let design = match f.design.as_deref().unwrap_or("sobol") {
        "sobol" => Design::Sample(Kind::Sobol),
        "latin_hypercube" => Design::Sample(Kind::LatinHypercube),
        "monte_carlo" => Design::Sample(Kind::MonteCarlo),
        "saltelli" => Design::Saltelli,
        "morris" => {
            let levels = f.levels.unwrap_or(4) as usize;
            if levels < 2 || levels % 2 != 0 || levels > 1000 {
                return Err(bad(
                    "ensemble.levels",
                    format!("must be an even number from 2 to 1000, got {levels}"),
                ));
            }
            Design::Morris { levels }
        }
        other => {
            return Err(bad(
                "ensemble.design",
                format!(
                    "`{other}` is none of sobol, latin_hypercube, monte_carlo, saltelli, morris"
                ),
            ))
        }
    };
    if f.levels.is_some() && !matches!(design, Design::Morris { .. }) {
        return Err(bad(
            "ensemble.levels",
            "is a Morris design's: remove it, or take design morris",
        ));
    }
    if f.inputs.is_empty() {
        return Err(bad(
            "ensemble.inputs",
            "must name at least one sampled field",
        ));
    }
    let mut r = Reader {
        base,
        inputs: Vec::new(),
        columns: Vec::new(),
    };
    for (i, m) in f.inputs.iter().enumerate() {
        let at = format!("ensemble.inputs[{i}]");
        if m.contains_key("field") {
            r.field(m, &at)?;
        } else if m.contains_key("mass_factors") {
            r.mass_factors(m, &at)?;
        } else if let Some(mv) = m.get("multivariate_normal") {
            if m.len() > 1 {
                return Err(bad(at, "a multivariate_normal input has no other key"));
            }
            r.multivariate(mv, &format!("{at}.multivariate_normal"))?;
        } else if m.contains_key("from_fit") {
            return Err(bad(
                format!("{at}.from_fit"),
                "names a fit's output file, which is read when the sweep file is (run or validate the sweep file itself, not its text)",
            ));
        } else {
            return Err(bad(
                at,
                "must be {\"field\": PATH, DISTRIBUTION: {…}}, {\"mass_factors\": WHICH, DISTRIBUTION: {…}}, {\"multivariate_normal\": {…}} or {\"from_fit\": FILE}",
            ));
        }
    }
    let (inputs, columns) = (r.inputs, r.columns);
    let d = columns.len();
    let most = match design {
        Design::Saltelli => MAX_SOBOL_DIMS / 2,
        _ => MAX_SOBOL_DIMS,
    };
    if d > most {
        return Err(bad(
            "ensemble.inputs",
            format!(
                "sample {d} fields; a {} design takes at most {most}",
                design.name()
            ),
        ));
    }
    // Names and fields: distinct from each other and from the ordinary axes.
    let mut taken_names: Vec<(String, String)> = Vec::new();
    let mut taken_fields: Vec<(String, String)> = Vec::new();
    for dim in dims.iter() {
        for a in &dim.axes {
            taken_names.push((a.name.clone(), a.origin.clone()));
            taken_fields.push((a.field.clone(), a.origin.clone()));
        }
        if !dim.axes.iter().any(|a| a.name == dim.name) {
            taken_names.push((dim.name.clone(), String::new()));
        }
    }
    let mut index_names = vec!["member"];
    match design {
        Design::Sample(_) => index_names.push("replicate"),
        Design::Saltelli => index_names.push("block"),
        Design::Morris { .. } => index_names.extend(["trajectory", "step"]),
    }
    let mut all_names: Vec<(String, String)> = index_names
        .iter()
        .map(|n| (n.to_string(), "ensemble".to_string()))
        .collect();
    for (k, c) in columns.iter().enumerate() {
        let input = inputs
            .iter()
            .position(|i| i.columns.contains(&k))
            .expect("every column has an input");
        all_names.push((c.name.clone(), format!("ensemble.inputs[{input}]")));
    }
    for (name, origin) in &all_names {
        let taken: Vec<(&str, &str)> = taken_names
            .iter()
            .map(|(a, b)| (a.as_str(), b.as_str()))
            .collect();
        check_name(name, origin, &taken)?;
        taken_names.push((name.clone(), origin.clone()));
    }
    for (k, c) in columns.iter().enumerate() {
        let input = inputs
            .iter()
            .position(|i| i.columns.contains(&k))
            .expect("every column has an input");
        let axis = Axis {
            name: c.name.clone(),
            field: c.field.clone(),
            values: Vec::new(),
            units: c.units.clone(),
            origin: format!("ensemble.inputs[{input}]"),
        };
        let taken: Vec<(&str, &str)> = taken_fields
            .iter()
            .filter(|(f, _)| !f.is_empty())
            .map(|(a, b)| (a.as_str(), b.as_str()))
            .collect();
        check_field(&axis, &taken)?;
        taken_fields.push((c.field.clone(), axis.origin));
    }
    let copula = match f.correlation {
        None => None,
        Some(c) => {
            if !matches!(design, Design::Sample(_)) {
                return Err(bad(
                    "ensemble.correlation",
                    "Sobol' indices and elementary effects assume independent inputs: drop the correlation, or give the correlated fields as one multivariate_normal input",
                ));
            }
            let k = c.inputs.len();
            if k < 2 {
                return Err(bad(
                    "ensemble.correlation.inputs",
                    "must name at least two inputs",
                ));
            }
            let mut cols = Vec::with_capacity(k);
            for (i, name) in c.inputs.iter().enumerate() {
                let input = inputs.iter().find(|x| &x.name == name).ok_or_else(|| {
                    bad(
                        format!("ensemble.correlation.inputs[{i}]"),
                        format!(
                            "`{name}` is no input; inputs: {}",
                            inputs
                                .iter()
                                .map(|x| x.name.as_str())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    )
                })?;
                if !matches!(input.kind, InputKind::Independent(_) | InputKind::Tied(_))
                    || (input.columns.len() != 1 && !matches!(input.kind, InputKind::Tied(_)))
                {
                    return Err(bad(
                        format!("ensemble.correlation.inputs[{i}]"),
                        format!("`{name}` is not one field: only single-field inputs are correlated (a multivariate normal has its own covariance)"),
                    ));
                }
                if cols.contains(&input.columns.start) {
                    return Err(bad(
                        format!("ensemble.correlation.inputs[{i}]"),
                        format!("`{name}` is named twice"),
                    ));
                }
                cols.push(input.columns.start);
            }
            if c.matrix.len() != k || c.matrix.iter().any(|r| r.len() != k) {
                return Err(bad(
                    "ensemble.correlation.matrix",
                    format!("must be {k} × {k}, one row and column per input named"),
                ));
            }
            let a: Vec<f64> = c.matrix.iter().flatten().copied().collect();
            for i in 0..k {
                if a[i * k + i] != 1.0 {
                    return Err(bad(
                        format!("ensemble.correlation.matrix[{i}][{i}]"),
                        format!(
                            "a correlation matrix has ones on its diagonal, got {}",
                            a[i * k + i]
                        ),
                    ));
                }
                for j in 0..k {
                    let x = a[i * k + j];
                    if !(x.is_finite() && x.abs() <= 1.0) || x != a[j * k + i] {
                        return Err(bad(
                            format!("ensemble.correlation.matrix[{i}][{j}]"),
                            format!("must be a correlation in [-1, 1] equal to element [{j}][{i}], got {x}"),
                        ));
                    }
                }
            }
            let l = cholesky(&a, k).ok_or_else(|| {
                bad(
                    "ensemble.correlation.matrix",
                    "is not positive definite: no joint distribution has these correlations",
                )
            })?;
            Some((cols, l))
        }
    };
    let default_samples = match design {
        Design::Sample(Kind::MonteCarlo) => 512,
        Design::Sample(_) => 64,
        Design::Saltelli => 256,
        Design::Morris { .. } => 20,
    };
    let samples = f.samples.unwrap_or(default_samples) as usize;
    let replicates = match design {
        Design::Sample(Kind::MonteCarlo) => f.replicates.unwrap_or(1),
        Design::Sample(_) => f.replicates.unwrap_or(8),
        _ => {
            if f.replicates.is_some() {
                return Err(bad(
                    "ensemble.replicates",
                    "is a design for statistics' (sobol, latin_hypercube, monte_carlo): Saltelli's and Morris's intervals come from the bootstrap",
                ));
            }
            1
        }
    } as usize;
    if replicates == 0 || replicates > 1024 {
        return Err(bad(
            "ensemble.replicates",
            format!("must be from 1 to 1024, got {replicates}"),
        ));
    }
    let needs_power = matches!(design, Design::Sample(Kind::Sobol) | Design::Saltelli);
    if samples < 2 || (needs_power && !samples.is_power_of_two()) {
        return Err(bad(
            "ensemble.samples",
            if needs_power {
                format!("must be a power of two, at least 2 (a Sobol' net's balance holds at powers of two), got {samples}")
            } else {
                format!("must be at least 2, got {samples}")
            },
        ));
    }
    let probes = super::search::probes_of(r.base);
    let names: Vec<String> = probes.iter().map(Probe::name).collect();
    if f.statistics.is_empty() {
        return Err(bad(
            "ensemble.statistics",
            "must name at least one quantity: {\"of\": {\"summary\": …, \"probe\": …}}",
        ));
    }
    let mut statistics: Vec<Statistic> = Vec::new();
    for (i, m) in f.statistics.iter().enumerate() {
        let at = format!("ensemble.statistics[{i}]");
        if let Some(k) = m
            .keys()
            .find(|k| !["of", "name", "exceed", "tolerance"].contains(&k.as_str()))
        {
            return Err(bad(
                format!("{at}.{k}"),
                "unknown key; allowed: of, name, exceed, tolerance",
            ));
        }
        let of_v = m.get("of").ok_or_else(|| {
            bad(
                format!("{at}.of"),
                "missing: the summary (or ratio of two) whose statistics are computed",
            )
        })?;
        let of = parse_objective_at(of_v, &format!("{at}.of"), &names)?;
        let name = match m.get("name") {
            Some(Value::String(s)) => s.clone(),
            Some(_) => return Err(bad(format!("{at}.name"), "must be a string")),
            None => match &of {
                Objective::One(s) => match &s.probe {
                    Some((_, p)) => format!("{}_{p}", s.column),
                    None => s.column.to_string(),
                },
                _ => format!("statistic_{i}"),
            },
        };
        if statistics.iter().any(|s| s.name == name) {
            return Err(bad(
                format!("{at}.name"),
                format!("`{name}` names an earlier statistic too: give each its own name"),
            ));
        }
        let taken: Vec<(&str, &str)> = taken_names
            .iter()
            .map(|(a, b)| (a.as_str(), b.as_str()))
            .collect();
        check_name(&name, &at, &taken)?;
        let exceed = match m.get("exceed") {
            Some(v) => numbers(v, &format!("{at}.exceed"))?,
            None => Vec::new(),
        };
        let mut tolerance = Tolerance::default();
        if let Some(t) = m.get("tolerance") {
            let Value::Object(t) = t else {
                return Err(bad(format!("{at}.tolerance"), "must be {\"mean\" | \"sd\" | \"quantiles\" | \"exceed\": largest width of the 95 % interval}"));
            };
            for (k, v) in t {
                let w = number(v, &format!("{at}.tolerance.{k}"))?;
                if w <= 0.0 {
                    return Err(bad(
                        format!("{at}.tolerance.{k}"),
                        format!("must be a width > 0, got {w}"),
                    ));
                }
                match k.as_str() {
                    "mean" => tolerance.mean = Some(w),
                    "sd" => tolerance.sd = Some(w),
                    "quantiles" => tolerance.quantiles = Some(w),
                    "exceed" => tolerance.exceed = Some(w),
                    _ => {
                        return Err(bad(
                            format!("{at}.tolerance.{k}"),
                            "unknown; allowed: mean, sd, quantiles, exceed",
                        ))
                    }
                }
            }
            if tolerance.exceed.is_some() && exceed.is_empty() {
                return Err(bad(
                    format!("{at}.tolerance.exceed"),
                    "asks a width of probabilities of exceeding, but `exceed` names no level",
                ));
            }
            if matches!(design, Design::Morris { .. }) {
                return Err(bad(format!("{at}.tolerance"), "a Morris design screens and computes no statistics: drop the tolerance, or take another design"));
            }
        }
        statistics.push(Statistic {
            name,
            units: of.units(&probes).unwrap_or("1").to_string(),
            of,
            exceed,
            tolerance,
        });
    }
    let quantiles = f.quantiles.unwrap_or_else(|| vec![0.05, 0.5, 0.95]);
    for (i, &p) in quantiles.iter().enumerate() {
        if !(p > 0.0 && p < 1.0) {
            return Err(bad(
                format!("ensemble.quantiles[{i}]"),
                format!("must be a probability in (0, 1), got {p}"),
            ));
        }
    }
    let bins = f.histogram_bins.unwrap_or(20) as usize;
    if bins > 10_000 {
        return Err(bad(
            "ensemble.histogram_bins",
            format!("must be at most 10000, got {bins}"),
        ));
    }
    let adaptive = statistics.iter().any(|s| s.tolerance.any());
    let max_runs =
        match (adaptive, f.max_runs) {
            (true, m) => Some(m.map_or(DEFAULT_MAX_RUNS, |m| m as usize)),
            (false, None) => None,
            (false, Some(_)) => return Err(bad(
                "ensemble.max_runs",
                "is an adaptive ensemble's budget: give a statistic a tolerance, or drop max_runs",
            )),
        };
    let outer_points: usize = dims.iter().map(Dim::len).product();
    let spec = EnsembleSpec {
        inputs,
        columns,
        copula,
        design,
        seed: f.seed,
        samples,
        replicates,
        max_runs,
        statistics,
        quantiles,
        bins,
        outer_points,
    };
    if spec.round_samples(0) > MAX_SAMPLES {
        return Err(bad(
            "ensemble.samples",
            format!(
                "asks {} runs per point; at most {MAX_SAMPLES}",
                spec.round_samples(0)
            ),
        ));
    }
    if let Some(m) = max_runs {
        if spec.round_samples(0) * outer_points > m {
            return Err(bad(
                "ensemble.max_runs",
                format!(
                    "is {m} runs, below round 0's {} ({} samples at {outer_points} points), where every ensemble starts",
                    spec.round_samples(0) * outer_points,
                    spec.round_samples(0)
                ),
            ));
        }
    }
    dims.push(spec.dim(0));
    Ok(spec)
}

impl EnsembleSpec {
    /// Samples per replicate (or Saltelli's rows, Morris's trajectories) and replicates in round
    /// `k`: each round doubles its predecessor, Latin hypercubes by replicates (a Latin
    /// hypercube of `2n` points is not one of `n` and `n` more), the others by points.
    pub fn round_size(&self, k: usize) -> (usize, usize) {
        let grow = 1usize << k.min(40);
        match self.design {
            Design::Sample(Kind::LatinHypercube) => {
                (self.samples, self.replicates.saturating_mul(grow))
            }
            _ => (self.samples.saturating_mul(grow), self.replicates),
        }
    }

    /// Runs per point of the ordinary axes in round `k`.
    pub fn round_samples(&self, k: usize) -> usize {
        let (n, r) = self.round_size(k);
        match self.design {
            Design::Sample(_) => n.saturating_mul(r),
            Design::Saltelli => n.saturating_mul(self.inputs.len() + 2),
            Design::Morris { .. } => n.saturating_mul(self.inputs.len() + 1),
        }
    }

    /// Runs of round `k` over all points of the ordinary axes.
    pub fn round_runs(&self, k: usize) -> usize {
        self.round_samples(k).saturating_mul(self.outer_points)
    }

    /// Whether the ensemble grows until its statistics are within their tolerances.
    pub fn adaptive(&self) -> bool {
        self.max_runs.is_some()
    }

    /// The round whose samples are `n` per point, if one is (a file's round from its size).
    pub fn round_of_samples(&self, n: usize) -> Option<usize> {
        (0..41).find(|&k| self.round_samples(k) == n)
    }

    /// The design's points in the unit hypercube in round `k`, and where each lies.
    pub fn unit_points(&self, k: usize) -> (Vec<f64>, Layout) {
        let (n, r) = self.round_size(k);
        let d = self.columns.len();
        let groups: Vec<Range<usize>> = self.inputs.iter().map(|i| i.columns.clone()).collect();
        match self.design {
            Design::Sample(kind) => (
                design::sample(kind, d, n, r, self.seed),
                Layout::Replicates {
                    per: n,
                    replicates: r,
                },
            ),
            Design::Saltelli => (
                design::saltelli(d, &groups, n, self.seed).0,
                Layout::Saltelli { n },
            ),
            Design::Morris { levels } => {
                let (x, steps) = design::morris(d, &groups, n, levels, self.seed);
                (x, Layout::Morris(steps))
            }
        }
    }

    /// The field values of one unit point (`columns.len()` numbers).
    pub fn values(&self, u: &[f64]) -> Vec<f64> {
        let mut u = u.to_vec();
        if let Some((cols, l)) = &self.copula {
            let picked: Vec<f64> = cols.iter().map(|&c| u[c]).collect();
            for (c, v) in cols.iter().zip(correlate(l, &picked)) {
                u[*c] = v;
            }
        }
        let mut out = vec![0.0; u.len()];
        for input in &self.inputs {
            let cols = input.columns.clone();
            match &input.kind {
                InputKind::Independent(dists) => {
                    for (c, d) in cols.zip(dists) {
                        out[c] = d.quantile(u[c]);
                    }
                }
                InputKind::Tied(d) => {
                    let x = d.quantile(u[cols.start]);
                    for c in cols {
                        out[c] = x;
                    }
                }
                InputKind::Normal { mean, chol } => {
                    let z: Vec<f64> = cols.clone().map(|c| normal_quantile(u[c])).collect();
                    for ((c, m), x) in cols.zip(mean).zip(lower_times(chol, &z)) {
                        out[c] = m + x;
                    }
                }
            }
        }
        out
    }

    /// The `member` dimension of round `k`: its index axes and one axis per sampled column.
    pub fn dim(&self, k: usize) -> Dim {
        let (u, layout) = self.unit_points(k);
        let d = self.columns.len();
        let rows = u.len() / d.max(1);
        let index = |name: &str, values: Vec<i64>| Axis {
            name: name.to_string(),
            field: String::new(),
            values: values.into_iter().map(Value::from).collect(),
            units: "1".into(),
            origin: "ensemble".into(),
        };
        let mut axes = vec![index("member", (0..rows as i64).collect())];
        match &layout {
            Layout::Replicates { per, .. } => axes.push(index(
                "replicate",
                (0..rows).map(|s| (s / per) as i64).collect(),
            )),
            Layout::Saltelli { n } => {
                axes.push(index("block", (0..rows).map(|s| (s / n) as i64).collect()))
            }
            Layout::Morris(steps) => {
                axes.push(index(
                    "trajectory",
                    steps.iter().map(|s| s.trajectory as i64).collect(),
                ));
                axes.push(index("step", steps.iter().map(|s| s.step as i64).collect()));
            }
        }
        let mut columns: Vec<Vec<Value>> = vec![Vec::with_capacity(rows); d];
        for row in u.chunks(d) {
            for (c, x) in self.values(row).into_iter().enumerate() {
                columns[c].push(Value::from(x));
            }
        }
        let mut values = columns.into_iter();
        for (k, input) in self.inputs.iter().enumerate() {
            for c in input.columns.clone() {
                let col = &self.columns[c];
                axes.push(Axis {
                    name: col.name.clone(),
                    field: col.field.clone(),
                    values: values.next().expect("one list per column"),
                    units: col.units.clone(),
                    origin: format!("ensemble.inputs[{k}]"),
                });
            }
        }
        Dim {
            name: "member".into(),
            axes,
        }
    }

    /// Where each sample of round `k` lies in the design.
    pub fn layout(&self, k: usize) -> Layout {
        let (n, r) = self.round_size(k);
        match self.design {
            Design::Sample(_) => Layout::Replicates {
                per: n,
                replicates: r,
            },
            Design::Saltelli => Layout::Saltelli { n },
            Design::Morris { levels } => {
                let groups: Vec<Range<usize>> =
                    self.inputs.iter().map(|i| i.columns.clone()).collect();
                Layout::Morris(design::morris(self.columns.len(), &groups, n, levels, self.seed).1)
            }
        }
    }
}

/// Reads `from_fit` inputs of the sweep file `text` (in folder `dir`) into the multivariate
/// normals they name, so that the sweep's text holds the numbers its runs depend on (a later
/// change of the fit's file changes nothing of a finished ensemble). `None`: nothing to read.
pub(crate) fn inline_text(text: &str, dir: &std::path::Path) -> Result<Option<String>> {
    let stripped = text.strip_prefix('\u{feff}').unwrap_or(text);
    let Ok(mut raw) = super::parse_without_duplicate_keys(stripped) else {
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
    let file = hdf5::File::open(path)
        .map_err(|e| fail(format!("cannot be read as a fit's output file ({e})")))?;
    let text: String = file
        .attr("sweep")
        .and_then(|a| a.read_scalar::<hdf5::types::VarLenUnicode>())
        .map(|s| s.to_string())
        .map_err(|_| fail("is no chainsweep output file (it has no sweep attribute)".into()))?;
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
                        .unwrap_or_else(|| super::field_name(&field));
                    Some((field, name))
                })
                .collect()
        })
        .unwrap_or_default();
    let k = fields.len();
    let read = |name: &str| -> Result<Vec<f64>> {
        file.dataset(name)
            .and_then(|d| d.read_raw::<f64>())
            .map_err(|_| fail(format!("has no dataset `{name}` (a fit's result)")))
    };
    let cov = read("fit_covariance")?;
    if cov.len() != k * k {
        return Err(fail(format!(
            "holds a fit over several points of its axes ({} covariance entries for {k} fields): an ensemble takes one fit's result",
            cov.len()
        )));
    }
    if cov.iter().any(|x| !x.is_finite()) {
        return Err(fail(
            "has no covariance (its data do not determine every fitted field)".into(),
        ));
    }
    let mut mean = Vec::with_capacity(k);
    for (_, name) in &fields {
        let v = read(&format!("fit_{name}"))?;
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
