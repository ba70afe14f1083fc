//! The `ensemble` block's inputs, read one by one into the sampled columns: a field (or fields
//! that take one value), particles' mass or size factors, a multivariate normal; each checked against the
//! base scene.

use serde_json::{Map, Value};

use chainsweep_solver::chain::parts::ParticleKind;
use chainsweep_solver::{Chain, Scene};

use super::super::{from_ref_at, lookup, set_path, units_of};
use super::dist::{bad, dist_of, numbers, DISTRIBUTIONS};
use super::EnsembleSpec;
use super::{Column, Input, InputKind};
use crate::error::{Error, Result};
use crate::uq::dist::{cholesky, normal_quantile};
use crate::uq::{UNIT_HIGHEST, UNIT_LOWEST};

/// Which per-particle factor list of the chain an input draws.
#[derive(Clone, Copy)]
pub(super) enum ParticleFactors {
    /// `chain.mass_factors`.
    Mass,
    /// `chain.size_factors` (every length; the mass follows at constant density).
    Size,
}

impl ParticleFactors {
    /// The input's key, which is also the chain's field.
    pub(super) fn key(self) -> &'static str {
        match self {
            ParticleFactors::Mass => "mass_factors",
            ParticleFactors::Size => "size_factors",
        }
    }

    /// What the factor scales, in words.
    fn of(self) -> &'static str {
        match self {
            ParticleFactors::Mass => "mass",
            ParticleFactors::Size => "size",
        }
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
/// `field` of the base scene set to `value`, one the distribution of input `input` gives: an
/// error at `at` (the input's field) where the field is none the scene has or takes as a number,
/// at `input` (its distribution) where the scene refuses the value.
fn check_number_field(base: &Value, field: &str, value: f64, at: &str, input: &str) -> Result<()> {
    let mut v = base.clone();
    if let Err(e) = super::super::check_settable(&v, field) {
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
    // The scene's own checks too (a mass > 0 is the chain's, not the schema's), where the base
    // scene passes them: what the base scene gets wrong is said of the base, when it is built.
    if let Err(e) = scene.validate() {
        let base_valid = from_ref_at::<Scene>(base, "")
            .ok()
            .is_some_and(|b| b.validate().is_ok());
        if base_valid {
            return Err(bad(
                input,
                format!(
                    "its distribution reaches values the scene refuses (narrow or truncate it): `{field}` = {value}: `{}` {}",
                    e.field, e.message
                ),
            ));
        }
    }
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

/// Most values (samples × columns) [`check_reach`] draws to find each column's extremes; beyond,
/// it takes the farthest any design could draw.
const MAX_REACH_VALUES: usize = 1 << 22;

/// Every value the ensemble may draw is one the scene takes: its design's points of the last
/// round it may run (round 0 of a fixed size; of an adaptive ensemble the last within
/// `max_runs`, whose points hold every earlier round's and reach furthest into the tails), each
/// column checked at its least and greatest value. Checked when the sweep is read, so that no
/// later round stops the ensemble with a value the scene refuses (it could then never end).
pub(super) fn check_reach(spec: &EnsembleSpec, base: &Value) -> Result<()> {
    let d = spec.columns.len();
    if d == 0 {
        return Ok(());
    }
    let last = spec.last_round();
    let (lo, hi) = if spec.round_samples(last).saturating_mul(d) <= MAX_REACH_VALUES {
        let (u, _) = spec.unit_points(last);
        let mut lo = vec![f64::INFINITY; d];
        let mut hi = vec![f64::NEG_INFINITY; d];
        for row in u.chunks(d) {
            for (c, x) in spec.values(row).into_iter().enumerate() {
                lo[c] = lo[c].min(x);
                hi[c] = hi[c].max(x);
            }
        }
        (lo, hi)
    } else {
        farthest(spec)
    };
    for (i, input) in spec.inputs.iter().enumerate() {
        let at = format!("ensemble.inputs[{i}]");
        for c in input.columns.clone() {
            let field = &spec.columns[c].field;
            for x in [lo[c], hi[c]] {
                if field.contains("_factors.") && !(x > 1e-3 && x < 1e3) {
                    return Err(bad(
                        &at,
                        format!("draws the factor {x} for `{field}` (round {last}): a factor must lie in (1e-3, 1e3); take log_normal or truncated_normal"),
                    ));
                }
                check_number_field(base, field, x, &at, &at)?;
            }
        }
    }
    Ok(())
}

/// Each column's least and greatest value over every point any design could draw (probabilities
/// from [`UNIT_LOWEST`] to [`UNIT_HIGHEST`]; a multivariate normal's field `i` at its mean ± the
/// farthest score times `Σⱼ |L_ij|`).
fn farthest(spec: &EnsembleSpec) -> (Vec<f64>, Vec<f64>) {
    let d = spec.columns.len();
    let (mut lo, mut hi) = (vec![0.0; d], vec![0.0; d]);
    let (z_lo, z_hi) = (normal_quantile(UNIT_LOWEST), normal_quantile(UNIT_HIGHEST));
    for input in &spec.inputs {
        let cols = input.columns.clone();
        match &input.kind {
            InputKind::Independent(dists) => {
                for (c, dist) in cols.zip(dists) {
                    let (a, b) = (dist.quantile(UNIT_LOWEST), dist.quantile(UNIT_HIGHEST));
                    (lo[c], hi[c]) = (a.min(b), a.max(b));
                }
            }
            InputKind::Tied(dist) => {
                let (a, b) = (dist.quantile(UNIT_LOWEST), dist.quantile(UNIT_HIGHEST));
                for c in cols {
                    (lo[c], hi[c]) = (a.min(b), a.max(b));
                }
            }
            InputKind::Normal { mean, chol } => {
                let k = mean.len();
                for (i, c) in cols.enumerate() {
                    let spread = chol[i * k..i * k + i + 1]
                        .iter()
                        .map(|x| x.abs())
                        .sum::<f64>();
                    (lo[c], hi[c]) = (mean[i] + z_lo * spread, mean[i] + z_hi * spread);
                }
            }
        }
    }
    (lo, hi)
}

pub(super) struct Reader<'a> {
    pub(super) base: &'a mut Value,
    pub(super) inputs: Vec<Input>,
    pub(super) columns: Vec<Column>,
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

    pub(super) fn field(&mut self, m: &Map<String, Value>, at: &str) -> Result<()> {
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
        // A first look, at ±3.1 sd; [`check_reach`] checks every value the design draws.
        for f in &fields {
            for u in [0.001, 0.5, 0.999] {
                let x = dist.quantile(u);
                check_number_field(self.base, f, x, &format!("{at}.field"), at)?;
            }
        }
        let name = match m.get("name") {
            Some(Value::String(s)) => s.clone(),
            Some(_) => return Err(bad(format!("{at}.name"), "must be a string")),
            None => super::super::field_name(&fields[0]),
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

    /// `{"mass_factors" | "size_factors": WHICH, DISTRIBUTION: {…}}`: a factor on each chosen
    /// particle's mass or size, each drawn on its own.
    pub(super) fn particle_factors(
        &mut self,
        list: ParticleFactors,
        m: &Map<String, Value>,
        at: &str,
    ) -> Result<()> {
        let key = list.key();
        let of = list.of();
        if let Some(k) = m
            .keys()
            .find(|k| ![key, "name"].contains(&k.as_str()) && !DISTRIBUTIONS.contains(&k.as_str()))
        {
            return Err(bad(
                format!("{at}.{k}"),
                format!(
                    "unknown key of a {of}-factor input; allowed: {key}, name, and one of {}",
                    DISTRIBUTIONS.join(", ")
                ),
            ));
        }
        let scene: Scene = from_ref_at(self.base, "base")?;
        let chain = Chain::build(&scene.chain, &scene.physics).map_err(|e| {
            bad(
                format!("{at}.{key}"),
                format!("the base chain does not build ({}: {})", e.field, e.message),
            )
        })?;
        let n = chain.n_particles();
        let which = &m[key];
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
                        format!("{at}.{key}"),
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
                                format!("{at}.{key}[{i}]"),
                                format!("must be a particle number from 1 to {n}, got {v}"),
                            )
                        })
                })
                .collect::<Result<_>>()?,
            _ => {
                return Err(bad(
                    format!("{at}.{key}"),
                    "must be cylinders, spheres, chain, all, or a list of particle numbers",
                ))
            }
        };
        if chosen.is_empty() {
            return Err(bad(
                format!("{at}.{key}"),
                format!("chooses no particle of the base chain ({n} particles)"),
            ));
        }
        // The base holds one factor per particle, so that each chosen one is a field of its own.
        let existing: Vec<f64> = match self.base.pointer(&format!("/chain/{key}")) {
            Some(Value::Array(a)) if a.len() == n => {
                a.iter().map(|x| x.as_f64().unwrap_or(1.0)).collect()
            }
            _ => vec![1.0; n],
        };
        set_path(
            self.base,
            &format!("chain.{key}"),
            Value::from(existing.clone()),
        );
        let stem = match m.get("name") {
            Some(Value::String(s)) => s.clone(),
            Some(_) => return Err(bad(format!("{at}.name"), "must be a string")),
            None => format!("{of}_factor"),
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
                        format!("gives particle {}'s {of} factor {x} (at probability {u}): a factor must lie in (1e-3, 1e3); a normal tolerance wider than a few tens of per cent can give negative {of}s, take log_normal or truncated_normal", p + 1),
                    ));
                }
            }
            dists.push(d);
            columns.push(Column {
                field: format!("chain.{key}.{p}"),
                name: format!("{stem}_{}", p + 1),
                units: "1".into(),
            });
        }
        self.push(stem, columns, InputKind::Independent(dists));
        Ok(())
    }

    pub(super) fn multivariate(&mut self, mv: &Value, at: &str) -> Result<()> {
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
            None => fields.iter().map(|f| super::super::field_name(f)).collect(),
        };
        for (i, f) in fields.iter().enumerate() {
            // A first look, at ±3 sd; [`check_reach`] checks every value the design draws.
            let sd = chol[i * k..i * k + i + 1]
                .iter()
                .map(|x| x * x)
                .sum::<f64>()
                .sqrt();
            for x in [mean[i] - 3.0 * sd, mean[i], mean[i] + 3.0 * sd] {
                check_number_field(self.base, f, x, &format!("{at}.fields[{i}]"), at)?;
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
