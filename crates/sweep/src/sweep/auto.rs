//! `integrator: auto` as a sweep file states it ([`AutoSpec`]) and as it is resolved
//! ([`AutoChoice`]): plain data. The resolution itself, a pilot on a few grid points, is
//! `chainsweep::numerics::auto` (in the engine).
//!
//! A sweep asks for it in its base scene:
//!
//! ```json
//! "integrator": {"method": "auto", "target_rel_error": 1e-6, "pilot_points": 5}
//! ```
//!
//! (`pilot_points` is optional, default [`DEFAULT_PILOT_POINTS`].)

use chainsweep_solver::{IntegratorSpec, Method};
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::error::{Error, Result};

/// Smallest target relative error. Candidates are measured at `target / SAFETY_FACTOR` against
/// the DOP853 reference at rtol 1e-12, whose own error is a few 1e-10 (DOP853 at rtol 1e-11
/// differs from it by up to 2.9e-9 on the Fig. 8 pilot points, leading-peak times included), so
/// smaller targets could not be told apart from the reference's error.
pub const TARGET_MIN: f64 = 1e-8;

/// Largest target relative error.
pub const TARGET_MAX: f64 = 1e-2;

/// Default number of pilot points.
pub const DEFAULT_PILOT_POINTS: usize = 5;

/// Largest number of pilot points.
pub const MAX_PILOT_POINTS: usize = 64;

/// An `integrator: auto` request of a sweep file.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AutoSpec {
    /// Largest relative error allowed at every grid point.
    pub target_rel_error: f64,
    /// Largest number of pilot points.
    pub pilot_points: usize,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AutoFile {
    #[allow(dead_code)]
    method: String,
    target_rel_error: Option<f64>,
    #[serde(default)]
    pilot_points: Option<u64>,
}

impl AutoSpec {
    /// Reads `base.integrator` (`value`) when its method is `auto`: `Ok(None)` for any other
    /// integrator; an input error naming the field for a malformed request.
    pub fn from_integrator(value: &Value) -> Result<Option<AutoSpec>> {
        if value.get("method").and_then(Value::as_str) != Some("auto") {
            return Ok(None);
        }
        let f: AutoFile =
            super::from_value_at(value.clone(), "base.integrator").map_err(|e| match e {
                Error::Input { field, message, .. } => Error::input(
                    field,
                    format!(
                        "{message} (`auto` takes `target_rel_error` and optionally `pilot_points`)"
                    ),
                ),
                other => other,
            })?;
        let target = f.target_rel_error.ok_or_else(|| {
            Error::input(
                "base.integrator.target_rel_error",
                format!("missing: `auto` needs the largest relative error allowed at every grid point, a number in [{TARGET_MIN:e}, {TARGET_MAX:e}]"),
            )
        })?;
        if !(target.is_finite() && (TARGET_MIN..=TARGET_MAX).contains(&target)) {
            return Err(Error::input(
                "base.integrator.target_rel_error",
                format!("must lie in [{TARGET_MIN:e}, {TARGET_MAX:e}], got {target}"),
            ));
        }
        let pilot_points = match f.pilot_points {
            None => DEFAULT_PILOT_POINTS,
            Some(n) if (1..=MAX_PILOT_POINTS as u64).contains(&n) => n as usize,
            Some(n) => {
                return Err(Error::input(
                    "base.integrator.pilot_points",
                    format!("must be a whole number from 1 to {MAX_PILOT_POINTS}, got {n}"),
                ))
            }
        };
        Ok(Some(AutoSpec {
            target_rel_error: target,
            pilot_points,
        }))
    }

    /// The concrete integrator that stands in for `auto` while the sweep is parsed and its grid
    /// validated (DOP853 at rtol = target); never run.
    pub fn placeholder(&self) -> IntegratorSpec {
        adaptive(Method::Dop853, self.target_rel_error)
    }
}

/// The adaptive `method` at `rtol` with defaults otherwise.
///
/// # Panics
/// For a fixed-step method (a caller's mistake: every caller names an adaptive one).
pub fn adaptive(method: Method, rtol: f64) -> IntegratorSpec {
    method
        .adaptive(rtol)
        .unwrap_or_else(|| panic!("`{}` is no adaptive method", method.name()))
}

/// The setting of an integrator as a number (rtol or dt_s) and its name.
pub fn setting_of(spec: &IntegratorSpec) -> (f64, &'static str) {
    match (spec.adaptive_options(), spec.fixed_step_s()) {
        (Some(o), _) => (o.rtol, "rtol"),
        (None, dt_s) => (dt_s.expect("a method with a fixed step"), "dt_s"),
    }
}

/// A setting in words: `dop853 rtol 3e-8`.
pub fn describe(spec: &IntegratorSpec) -> String {
    let (x, name) = setting_of(spec);
    let predicting = spec.adaptive_options().is_some_and(|o| o.predict_switches);
    format!(
        "{} {name} {x:e}{}",
        spec.method_name(),
        if predicting { " predict_switches" } else { "" }
    )
}

/// One candidate setting tried by the pilot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// The setting.
    pub integrator: IntegratorSpec,
    /// Relative error at each pilot point (`null`: the run failed, or found a leading pulse the
    /// reference did not, or the other way round).
    pub errors: Vec<Option<f64>>,
    /// RHS evaluations at each pilot point (`null`: the run failed).
    pub rhs_evals: Vec<Option<u64>>,
    /// Weighted RHS evaluations over the pilot points (`null` when a run failed).
    pub cost: Option<f64>,
    /// Whether every pilot run succeeded within `target / safety_factor`.
    pub meets_target: bool,
    /// Why a pilot run failed, when one did.
    pub failure: Option<String>,
}

impl Candidate {
    /// Largest error over the pilot points (infinite when a run failed).
    pub fn max_error(&self) -> f64 {
        self.errors
            .iter()
            .map(|e| e.unwrap_or(f64::INFINITY))
            .fold(0.0, f64::max)
    }
}

/// What `auto` chose, and the pilot it chose from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AutoChoice {
    /// The cache key of the unresolved sweep (the engine's `chainsweep::numerics::auto::cache_key`).
    pub key: String,
    /// Version of the procedure that chose (the engine's `chainsweep::numerics::auto::AUTO_VERSION`).
    pub version: u32,
    /// The requested target relative error.
    pub target_rel_error: f64,
    /// The pilot required `target / safety_factor`.
    pub safety_factor: f64,
    /// The chosen setting, used at every grid point.
    pub integrator: IntegratorSpec,
    /// Flat indices of the pilot points.
    pub pilot_points: Vec<usize>,
    /// Reference setting at each pilot point.
    pub pilot_references: Vec<IntegratorSpec>,
    /// Error of the chosen setting at each pilot point.
    pub pilot_errors: Vec<f64>,
    /// RHS evaluations of the chosen setting at each pilot point.
    pub pilot_rhs_evals: Vec<u64>,
    /// RHS evaluations the whole pilot took (references and every candidate).
    pub pilot_cost_rhs_evals: u64,
    /// Every candidate tried, in the order tried.
    pub candidates: Vec<Candidate>,
}

impl AutoChoice {
    /// The choice in one line: setting, pilot points, largest pilot error, pilot cost.
    pub fn summary(&self) -> String {
        format!(
            "{} (pilot on points {:?}: largest error {:.2e} <= {:e}/{}, {} RHS evaluations there; the pilot took {} RHS evaluations in all)",
            describe(&self.integrator),
            self.pilot_points,
            self.pilot_errors.iter().cloned().fold(0.0, f64::max),
            self.target_rel_error,
            self.safety_factor,
            self.pilot_rhs_evals.iter().sum::<u64>(),
            self.pilot_cost_rhs_evals
        )
    }

    /// The choice as cached and stored (JSON).
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("AutoChoice serialises")
    }

    /// Reads a choice from its JSON (`auto` attribute of an output file, or the cache file).
    pub fn from_json(text: &str) -> Result<AutoChoice> {
        serde_json::from_str(text).map_err(|source| Error::Json {
            what: "`auto` record".into(),
            source,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn every_method_is_named_as_a_sweep_file_names_it() {
        for m in Method::ALL {
            let spec = m
                .adaptive(1e-6)
                .or_else(|| m.fixed(1e-9))
                .expect("adaptive or fixed");
            assert_eq!(spec.method(), m);
            let v = serde_json::to_value(spec).unwrap();
            assert_eq!(v["method"], m.name());
            let back: IntegratorSpec = serde_json::from_value(v).unwrap();
            assert_eq!(back, spec);
            assert_eq!(Method::parse(m.name()), Ok(m));
            assert_eq!(m.is_adaptive(), m.rhs_per_fixed_step().is_none());
        }
        let err = Method::parse("dop835").unwrap_err();
        assert!(
            err.contains("dop835") && err.contains("dop853, vern6, ros34pw2, rk4, verlet"),
            "{err}"
        );
    }

    #[test]
    fn requests_parse_strictly() {
        let ok = AutoSpec::from_integrator(&json!({"method": "auto", "target_rel_error": 1e-6}))
            .unwrap()
            .unwrap();
        assert_eq!(ok.target_rel_error, 1e-6);
        assert_eq!(ok.pilot_points, DEFAULT_PILOT_POINTS);
        assert!(
            AutoSpec::from_integrator(&json!({"method": "dop853", "rtol": 1e-9}))
                .unwrap()
                .is_none()
        );
        for (bad, field) in [
            (
                json!({"method": "auto"}),
                "base.integrator.target_rel_error",
            ),
            (
                json!({"method": "auto", "target_rel_error": 1e-9}),
                "base.integrator.target_rel_error",
            ),
            (
                json!({"method": "auto", "target_rel_error": 0.5}),
                "base.integrator.target_rel_error",
            ),
            (
                json!({"method": "auto", "target_rel_error": 1e-6, "rtol": 1e-9}),
                "base.integrator.rtol",
            ),
            (
                json!({"method": "auto", "target_rel_error": 1e-6, "pilot_points": 0}),
                "base.integrator.pilot_points",
            ),
            (
                json!({"method": "auto", "target_rel_error": "1e-6"}),
                "base.integrator.target_rel_error",
            ),
        ] {
            match AutoSpec::from_integrator(&bad) {
                Err(Error::Input { field: f, .. }) => assert_eq!(f, field, "{bad}"),
                other => panic!("{bad}: {other:?}"),
            }
        }
    }

    #[test]
    fn choices_round_trip_through_json() {
        let c = AutoChoice {
            key: "k".into(),
            version: 1,
            target_rel_error: 1e-6,
            safety_factor: 5.0,
            integrator: adaptive(Method::Dop853, 3e-8),
            pilot_points: vec![0, 3],
            pilot_references: vec![adaptive(Method::Dop853, 1e-12); 2],
            pilot_errors: vec![1.5e-7, 2.25e-7],
            pilot_rhs_evals: vec![1000, 2000],
            pilot_cost_rhs_evals: 12345,
            candidates: vec![Candidate {
                integrator: adaptive(Method::Dop853, 1e-6),
                errors: vec![Some(3e-6), None],
                rhs_evals: vec![Some(10), None],
                cost: None,
                meets_target: false,
                failure: Some("at grid point 3: step budget".into()),
            }],
        };
        assert_eq!(AutoChoice::from_json(&c.to_json()).unwrap(), c);
        assert!(c.summary().contains("dop853 rtol 3e-8"));
    }
}
