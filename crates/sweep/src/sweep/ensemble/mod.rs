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
//!
//! Its parts: the block's spec and its parsing here; the distributions (`dist`), the inputs read
//! into sampled columns (`inputs`), the rounds of an adaptive ensemble (`rounds`) and inputs taken
//! from a fit's output file (`from_fit`) beside it.

use std::ops::Range;

use serde::Deserialize;
use serde_json::{Map, Value};

use chainsweep_solver::observe::probes::Probe;

use super::search::{parse_objective_at, Objective};
use super::{check_field, check_name, Axis, Dim};
use crate::error::Result;
use crate::uq::design::{Kind, MorrisStep, MAX_SOBOL_DIMS};
use crate::uq::dist::{cholesky, Dist};

mod dist;
mod from_fit;
mod inputs;
mod rounds;

use dist::{bad, number, numbers};
pub(crate) use from_fit::inline_text;
use inputs::{ParticleFactors, Reader};

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
    /// factor drawn independently: a manufacturing tolerance), the same with `size_factors`
    /// (every length of the particle, its mass following at constant density), `{"multivariate_normal": {"fields":
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
        } else if let Some(list) = [ParticleFactors::Mass, ParticleFactors::Size]
            .into_iter()
            .find(|l| m.contains_key(l.key()))
        {
            r.particle_factors(list, m, &at)?;
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
                "must be {\"field\": PATH, DISTRIBUTION: {…}}, {\"mass_factors\" or \"size_factors\": WHICH, DISTRIBUTION: {…}}, {\"multivariate_normal\": {…}} or {\"from_fit\": FILE}",
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
