//! The `ensemble` block's inputs, read one by one into the sampled columns: a field (or fields
//! that take one value), particles' mass or size factors, a multivariate normal; each checked against the
//! base scene.

use serde_json::{Map, Value};

use chainsweep_solver::chain::parts::ParticleKind;
use chainsweep_solver::{Chain, Scene};

use super::super::{from_ref_at, lookup, set_path, units_of};
use super::dist::{bad, dist_of, numbers, DISTRIBUTIONS};
use super::{Column, Input, InputKind};
use crate::error::{Error, Result};
use crate::uq::dist::cholesky;

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
fn check_number_field(base: &Value, field: &str, value: f64, at: &str) -> Result<()> {
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
        for f in &fields {
            for u in [0.001, 0.5, 0.999] {
                check_number_field(self.base, f, dist.quantile(u), &format!("{at}.field"))?;
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
