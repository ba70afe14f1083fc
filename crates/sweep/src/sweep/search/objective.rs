//! The objective of a search: one summary of a run (a stored column, of one probe where it has
//! one value per probe), or two combined; read from a sweep file, and evaluated on a run's
//! record. Ensembles' statistics and fits' scalar data are read alike.

use serde_json::Value;

use chainsweep_solver::Probe;

use super::bad;
use crate::error::Result;
use crate::record::columns::{column, Fill, Units, COLUMNS};
use crate::record::RunRecord;

/// How two values are combined.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Combine {
    /// a / b.
    Ratio,
    /// a - b.
    Difference,
    /// ln(a / b).
    LogRatio,
}

impl Combine {
    /// The unit of two values of units `a` and `b` combined: a ratio (plain or logarithmic) has
    /// none ("1"), a difference its values' unit; `None` where that is not known or they differ.
    pub fn units(self, a: Option<&'static str>, b: Option<&'static str>) -> Option<&'static str> {
        match self {
            Combine::Ratio | Combine::LogRatio => Some("1"),
            Combine::Difference => a.filter(|_| a == b),
        }
    }

    pub(super) fn parse(name: &str) -> Option<Combine> {
        match name {
            "ratio" => Some(Combine::Ratio),
            "difference" => Some(Combine::Difference),
            "log_ratio" => Some(Combine::LogRatio),
            _ => None,
        }
    }

    /// Its name in a sweep file.
    pub fn name(self) -> &'static str {
        match self {
            Combine::Ratio => "ratio",
            Combine::Difference => "difference",
            Combine::LogRatio => "log_ratio",
        }
    }

    /// `a` combined with `b`; `None` (no value) where either is missing or the result is not
    /// finite (a ratio over 0, the logarithm of a negative ratio).
    pub fn apply(self, a: Option<f64>, b: Option<f64>) -> Option<f64> {
        let (a, b) = (a?, b?);
        let v = match self {
            Combine::Ratio => a / b,
            Combine::Difference => a - b,
            Combine::LogRatio => (a / b).ln(),
        };
        v.is_finite().then_some(v)
    }
}

/// One summary of a run: a stored column, of one probe where the column has one value per probe.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// The column's name (`leading_peak`, `t_end_s`, …).
    pub column: &'static str,
    /// The probe's index in the record block, and its name, for per-probe columns.
    pub probe: Option<(usize, String)>,
}

impl Summary {
    /// The value in `rec`; `None` for a failed run, or a value that is not finite (NaN).
    pub fn of(&self, rec: &RunRecord) -> Option<f64> {
        if !rec.ok {
            return None;
        }
        let c = column(self.column).expect("checked at parse time");
        let v = match (c.fill, &self.probe) {
            (Fill::ProbeF64 { get, .. }, Some((p, _))) => get(rec.probes.get(*p)?),
            (Fill::OkF64 { get, .. }, None) => get(rec),
            (Fill::OkCount { get, .. }, None) => get(rec) as f64,
            _ => unreachable!("checked at parse time"),
        };
        v.is_finite().then_some(v)
    }

    /// Its unit, the column's (or its probe's, given the record block's `probes`); `None` for a
    /// column without one.
    pub fn units(&self, probes: &[Probe]) -> Option<&'static str> {
        match column(self.column)?.units {
            Units::Fixed(u) => Some(u),
            Units::OfProbes => Some(probes.get(self.probe.as_ref()?.0)?.unit()),
            Units::None => None,
        }
    }

    /// How it reads: `leading_peak[gauge_force_cyl21]`, `t_end_s`.
    pub fn describe(&self) -> String {
        match &self.probe {
            Some((_, name)) => format!("{}[{name}]", self.column),
            None => self.column.to_string(),
        }
    }
}

/// The objective of a search: one summary of a run, or two combined.
#[derive(Debug, Clone, PartialEq)]
pub enum Objective {
    /// One summary.
    One(Summary),
    /// Two summaries of the same run, combined.
    Two(Combine, Summary, Summary),
    /// A fit's χ² against its data (computed by the fit from all the runs of an evaluation, not
    /// from one run).
    ChiSquare,
}

impl Objective {
    /// Its value for the run `rec`; `None` where the run failed or the value is not finite.
    pub fn of(&self, rec: &RunRecord) -> Option<f64> {
        match self {
            Objective::One(s) => s.of(rec),
            Objective::Two(c, a, b) => c.apply(a.of(rec), b.of(rec)),
            Objective::ChiSquare => None,
        }
    }

    /// Its unit, given the record block's `probes` (see [`Summary::units`], [`Combine::units`]).
    pub fn units(&self, probes: &[Probe]) -> Option<&'static str> {
        match self {
            Objective::One(s) => s.units(probes),
            Objective::Two(c, a, b) => c.units(a.units(probes), b.units(probes)),
            Objective::ChiSquare => Some("1"),
        }
    }

    /// How it reads: `leading_peak[gauge_force_cyl21] / leading_peak[gauge_force_cyl4]`.
    pub fn describe(&self) -> String {
        match self {
            Objective::One(s) => s.describe(),
            Objective::Two(Combine::Ratio, a, b) => format!("{} / {}", a.describe(), b.describe()),
            Objective::Two(Combine::Difference, a, b) => {
                format!("{} - {}", a.describe(), b.describe())
            }
            Objective::Two(Combine::LogRatio, a, b) => {
                format!("ln({} / {})", a.describe(), b.describe())
            }
            Objective::ChiSquare => "chi_square".to_string(),
        }
    }
}

fn parse_summary(v: &Value, at: &str, probes: &[String]) -> Result<Summary> {
    let Value::Object(m) = v else {
        return Err(bad(at, "must be an object: {\"summary\": …, \"probe\": …}"));
    };
    if let Some(k) = m.keys().find(|k| *k != "summary" && *k != "probe") {
        return Err(bad(
            format!("{at}.{k}"),
            "unknown key: a summary is {\"summary\": NAME} or {\"summary\": NAME, \"probe\": PROBE}",
        ));
    }
    let allowed: Vec<&str> = COLUMNS
        .iter()
        .filter(|c| {
            matches!(
                c.fill,
                Fill::ProbeF64 { .. } | Fill::OkF64 { .. } | Fill::OkCount { .. }
            )
        })
        .map(|c| c.name)
        .collect();
    let name = m.get("summary").and_then(|s| s.as_str()).ok_or_else(|| {
        bad(
            format!("{at}.summary"),
            format!(
                "missing: the name of a run's summary, one of {}",
                allowed.join(", ")
            ),
        )
    })?;
    let c = COLUMNS
        .iter()
        .find(|c| c.name == name && allowed.contains(&c.name))
        .ok_or_else(|| {
            bad(
                format!("{at}.summary"),
                format!(
                    "`{name}` is no summary of a run; one of {}",
                    allowed.join(", ")
                ),
            )
        })?;
    let probe = match (c.per_probe, m.get("probe")) {
        (true, Some(p)) => {
            let p = p
                .as_str()
                .ok_or_else(|| bad(format!("{at}.probe"), "must be a probe's name"))?;
            let i = probes.iter().position(|n| n == p).ok_or_else(|| {
                bad(
                    format!("{at}.probe"),
                    format!(
                        "`{p}` is not a probe of the record block; its probes: {}",
                        if probes.is_empty() {
                            "none".to_string()
                        } else {
                            probes.join(", ")
                        }
                    ),
                )
            })?;
            Some((i, p.to_string()))
        }
        (true, None) => {
            return Err(bad(
                format!("{at}.probe"),
                format!(
                    "missing: `{name}` has a value per probe; name one of {}",
                    probes.join(", ")
                ),
            ))
        }
        (false, Some(_)) => {
            return Err(bad(
                format!("{at}.probe"),
                format!("`{name}` is one value per run: it takes no probe"),
            ))
        }
        (false, None) => None,
    };
    Ok(Summary {
        column: c.name,
        probe,
    })
}

pub(super) fn parse_objective(v: &Value, probes: &[String]) -> Result<Objective> {
    parse_objective_at(v, "search.objective", probes)
}

/// Reads a summary or a combination of two (an objective, a fit's scalar datum) at `at`, against
/// the record block's probe names.
pub(crate) fn parse_objective_at(v: &Value, at: &str, probes: &[String]) -> Result<Objective> {
    let Value::Object(m) = v else {
        return Err(bad(at, "must be an object: a summary {\"summary\": …, \"probe\": …}, or {\"ratio\" | \"difference\" | \"log_ratio\": [summary, summary]}"));
    };
    if m.contains_key("summary") {
        return Ok(Objective::One(parse_summary(v, at, probes)?));
    }
    if m.len() != 1 {
        return Err(bad(
            at,
            "give one summary, or one of `ratio`, `difference`, `log_ratio` of two summaries",
        ));
    }
    let (op, pair) = m.iter().next().expect("one key");
    let combine = Combine::parse(op).ok_or_else(|| {
        bad(
            format!("{at}.{op}"),
            "unknown: an objective is a summary, or `ratio`, `difference` or `log_ratio` of two",
        )
    })?;
    let items = pair
        .as_array()
        .filter(|a| a.len() == 2)
        .ok_or_else(|| bad(format!("{at}.{op}"), "must be a list of two summaries"))?;
    Ok(Objective::Two(
        combine,
        parse_summary(&items[0], &format!("{at}.{op}[0]"), probes)?,
        parse_summary(&items[1], &format!("{at}.{op}[1]"), probes)?,
    ))
}
