//! The integrator a scene asks for ([`IntegratorSpec`], a sweep file's `integrator` block) and
//! the one list of methods and their names ([`Method`]). Apart from the scene because adding an
//! integrator touches this file and its tableau, not the scene.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::chain::model::{spec_err, SpecError};
use crate::integrate::AdaptiveMethod as _;
use crate::integrate::{
    AdaptiveOptions, Dop853Method, Rk4, Ros34pw2Method, VelocityVerlet, Vern6Method,
};

/// Integrator and its accuracy settings.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(
    feature = "serde",
    serde(tag = "method", rename_all = "snake_case", deny_unknown_fields)
)]
pub enum IntegratorSpec {
    /// Velocity Verlet, fixed step (second order).
    Verlet {
        /// Step, s.
        dt_s: f64,
    },
    /// Classic Runge–Kutta, fixed step (fourth order).
    Rk4 {
        /// Step, s.
        dt_s: f64,
    },
    /// Dormand–Prince 8(5,3), adaptive, 7th-order dense output. `atol` is relative to each
    /// component's natural scale (the two-body peak overlap for positions, the striker velocity for
    /// velocities, the impact energy and momentum for the ledger's quadratures).
    Dop853(AdaptiveOptions),
    /// ROS34PW2, a linearly implicit (Rosenbrock-W) method of order 3, L-stable, with the chain's
    /// tridiagonal Jacobian: for damping-dominated chains (μ ≳ 1000 kg/s with light particles),
    /// where explicit methods are held to steps of order m/μ. Options as for DOP853.
    Ros34pw2(AdaptiveOptions),
    /// Verner's "most efficient" 6(5) pair, adaptive, 6th-order dense output: eight right-hand
    /// sides per attempted step and three more per accepted one, against DOP853's eleven and
    /// four. Options as for DOP853.
    Vern6(AdaptiveOptions),
}

impl Default for IntegratorSpec {
    fn default() -> Self {
        IntegratorSpec::Dop853(AdaptiveOptions::new(1e-9))
    }
}

/// An integration method: the one list of the methods and their names (a sweep file's
/// `integrator.method`, which [`IntegratorSpec`]'s serde tag reads with the same names).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// Velocity Verlet, fixed step.
    Verlet,
    /// Classic Runge–Kutta, fixed step.
    Rk4,
    /// Dormand–Prince 8(5,3), adaptive.
    Dop853,
    /// ROS34PW2 (Rosenbrock-W), adaptive, for damping-dominated chains.
    Ros34pw2,
    /// Verner's 6(5) pair, adaptive.
    Vern6,
}

impl Method {
    /// Every method, in the order the docs list them.
    pub const ALL: [Method; 5] = [
        Method::Dop853,
        Method::Vern6,
        Method::Ros34pw2,
        Method::Rk4,
        Method::Verlet,
    ];

    /// Its name in a sweep file.
    pub fn name(self) -> &'static str {
        match self {
            Method::Verlet => VelocityVerlet::NAME,
            Method::Rk4 => Rk4::NAME,
            Method::Dop853 => Dop853Method::NAME,
            Method::Ros34pw2 => Ros34pw2Method::NAME,
            Method::Vern6 => Vern6Method::NAME,
        }
    }

    /// The method of `name`; an unknown name is an error listing the methods.
    pub fn parse(name: &str) -> Result<Method, String> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == name)
            .ok_or_else(|| {
                let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
                format!("unknown method `{name}`; allowed: {}", names.join(", "))
            })
    }

    /// Whether it controls its step by an error estimate (and takes `rtol`), rather than a fixed
    /// step `dt_s`.
    pub fn is_adaptive(self) -> bool {
        matches!(self, Method::Dop853 | Method::Ros34pw2 | Method::Vern6)
    }

    /// Right-hand-side evaluations per step of a fixed-step method (`None` for an adaptive one).
    pub fn rhs_per_fixed_step(self) -> Option<f64> {
        match self {
            Method::Rk4 => Some(Rk4::RHS_PER_STEP as f64),
            Method::Verlet => Some(VelocityVerlet::RHS_PER_STEP as f64),
            _ => None,
        }
    }

    /// The adaptive method at `rtol`, its other options the defaults (`None` for a fixed-step
    /// method).
    pub fn adaptive(self, rtol: f64) -> Option<IntegratorSpec> {
        self.with_options(AdaptiveOptions::new(rtol))
    }

    /// The adaptive method with `options` (`None` for a fixed-step method).
    pub fn with_options(self, options: AdaptiveOptions) -> Option<IntegratorSpec> {
        match self {
            Method::Dop853 => Some(IntegratorSpec::Dop853(options)),
            Method::Ros34pw2 => Some(IntegratorSpec::Ros34pw2(options)),
            Method::Vern6 => Some(IntegratorSpec::Vern6(options)),
            Method::Rk4 | Method::Verlet => None,
        }
    }

    /// The fixed-step method at step `dt_s` (`None` for an adaptive method).
    pub fn fixed(self, dt_s: f64) -> Option<IntegratorSpec> {
        match self {
            Method::Rk4 => Some(IntegratorSpec::Rk4 { dt_s }),
            Method::Verlet => Some(IntegratorSpec::Verlet { dt_s }),
            _ => None,
        }
    }
}

impl IntegratorSpec {
    /// Its method.
    pub fn method(&self) -> Method {
        match self {
            IntegratorSpec::Verlet { .. } => Method::Verlet,
            IntegratorSpec::Rk4 { .. } => Method::Rk4,
            IntegratorSpec::Dop853(_) => Method::Dop853,
            IntegratorSpec::Ros34pw2(_) => Method::Ros34pw2,
            IntegratorSpec::Vern6(_) => Method::Vern6,
        }
    }

    /// Stable name of the method.
    pub fn method_name(&self) -> &'static str {
        self.method().name()
    }

    /// The options of an adaptive method (`None` for the fixed-step ones).
    pub fn adaptive_options(&self) -> Option<&AdaptiveOptions> {
        match self {
            IntegratorSpec::Dop853(o) | IntegratorSpec::Ros34pw2(o) | IntegratorSpec::Vern6(o) => {
                Some(o)
            }
            IntegratorSpec::Verlet { .. } | IntegratorSpec::Rk4 { .. } => None,
        }
    }

    /// Checks the settings; errors name the field (relative to `integrator`).
    pub fn validate(&self) -> Result<(), SpecError> {
        let pos = crate::spec::check_positive;
        match *self {
            IntegratorSpec::Verlet { dt_s } | IntegratorSpec::Rk4 { dt_s } => {
                pos("integrator.dt_s", dt_s)
            }
            IntegratorSpec::Dop853(AdaptiveOptions {
                rtol,
                atol,
                max_step_s,
                ..
            })
            | IntegratorSpec::Ros34pw2(AdaptiveOptions {
                rtol,
                atol,
                max_step_s,
                ..
            })
            | IntegratorSpec::Vern6(AdaptiveOptions {
                rtol,
                atol,
                max_step_s,
                ..
            }) => {
                if !(rtol.is_finite() && (1e-15..=1e-1).contains(&rtol)) {
                    return Err(spec_err(
                        "integrator.rtol",
                        format!("must lie in [1e-15, 0.1], got {rtol}"),
                    ));
                }
                if let Some(a) = atol {
                    if !(a.is_finite() && (1e-18..=1e-1).contains(&a)) {
                        return Err(spec_err(
                            "integrator.atol",
                            format!("must lie in [1e-18, 0.1], got {a}"),
                        ));
                    }
                }
                if let Some(h) = max_step_s {
                    pos("integrator.max_step_s", h)?;
                }
                Ok(())
            }
        }
    }
}

#[cfg(all(test, feature = "serde"))]
mod tests {
    use super::*;

    /// A method's name (its integrator's, by construction) is the tag a sweep file writes; an
    /// unknown name is an error listing them.
    #[test]
    fn every_method_name_is_its_sweep_file_tag() {
        for method in Method::ALL {
            let json = if method.is_adaptive() {
                serde_json::json!({"method": method.name(), "rtol": 1e-8})
            } else {
                serde_json::json!({"method": method.name(), "dt_s": 1e-8})
            };
            let spec: IntegratorSpec = serde_json::from_value(json).unwrap();
            assert_eq!(spec.method(), method);
            assert_eq!(Method::parse(method.name()), Ok(method));
        }
        let err = Method::parse("dopri5").unwrap_err();
        assert!(
            err.contains("dop853, vern6, ros34pw2, rk4, verlet"),
            "{err}"
        );
    }
}
