//! The integrator a scene asks for ([`IntegratorSpec`], a sweep file's `integrator` block) and
//! the one list of methods and their names ([`Method`]). Apart from the scene because adding an
//! integrator touches this file and its tableau, not the scene.
//!
//! Both enums, and every mapping between a method, its spec, its name and its integrator, are
//! written out from one list (the `integrators!` invocation below): adding a method is one entry
//! there (its documentation, its variant and its integrator's type) and its place in
//! [`Method::ALL`], the order the docs list the methods in, which the compiler checks.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::chain::model::{spec_err, SpecError};
use crate::integrate::{
    AdaptiveMethod, AdaptiveOptions, Dop853Method, Integrator, Rk4, Ros34pw2Method, VelocityVerlet,
    Vern6Method,
};

/// Writes out [`IntegratorSpec`], [`Method`] and the mappings between them from the list of
/// methods: the fixed-step ones (a variant `{ dt_s }`, built as `Scheme { dt }`), then the
/// adaptive ones (a variant holding [`AdaptiveOptions`], run as [`crate::integrate::Adaptive`] of
/// the method's type). Each entry is `Variant = Type, "what Method's variant says";` under the
/// documentation of the spec's variant; the variants keep the list's order, which is the order of
/// the sweep files' JSON Schema, and their snake_case names are the sweep files' method names.
macro_rules! integrators {
    (
        fixed: {
            $( $(#[$fixed_doc:meta])* $fixed:ident = $scheme:ident, $fixed_brief:literal; )*
        }
        adaptive: {
            $( $(#[$adaptive_doc:meta])* $adaptive:ident = $method:ident, $adaptive_brief:literal; )*
        }
    ) => {
        /// Integrator and its accuracy settings.
        #[derive(Debug, Clone, Copy, PartialEq)]
        #[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
        #[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
        #[cfg_attr(
            feature = "serde",
            serde(tag = "method", rename_all = "snake_case", deny_unknown_fields)
        )]
        pub enum IntegratorSpec {
            $(
                $(#[$fixed_doc])*
                $fixed {
                    /// Step, s.
                    dt_s: f64,
                },
            )*
            $(
                $(#[$adaptive_doc])*
                $adaptive(AdaptiveOptions),
            )*
        }

        /// An integration method: the one list of the methods and their names (a sweep file's
        /// `integrator.method`, which [`IntegratorSpec`]'s serde tag reads with the same names).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum Method {
            $( #[doc = $fixed_brief] $fixed, )*
            $( #[doc = $adaptive_brief] $adaptive, )*
        }

        /// How many methods the list holds.
        const COUNT: usize = [$(Method::$fixed,)* $(Method::$adaptive,)*].len();

        impl Method {
            /// Its name in a sweep file.
            pub fn name(self) -> &'static str {
                match self {
                    $(Method::$fixed => $scheme::NAME,)*
                    $(Method::$adaptive => <$method as AdaptiveMethod>::NAME,)*
                }
            }

            /// Whether it controls its step by an error estimate (and takes `rtol`), rather than
            /// a fixed step `dt_s`.
            pub fn is_adaptive(self) -> bool {
                match self {
                    $(Method::$fixed => false,)*
                    $(Method::$adaptive => true,)*
                }
            }

            /// Its order of accuracy (an adaptive method's: that of the solution it steps with).
            pub fn order(self) -> i32 {
                match self {
                    $(Method::$fixed => $scheme::ORDER,)*
                    $(Method::$adaptive => <$method as AdaptiveMethod>::ORDER,)*
                }
            }

            /// Right-hand-side evaluations per step of a fixed-step method (`None` for an
            /// adaptive one).
            pub fn rhs_per_fixed_step(self) -> Option<f64> {
                match self {
                    $(Method::$fixed => Some($scheme::RHS_PER_STEP as f64),)*
                    $(Method::$adaptive => None,)*
                }
            }

            /// The adaptive method with `options` (`None` for a fixed-step method).
            pub fn with_options(self, options: AdaptiveOptions) -> Option<IntegratorSpec> {
                match self {
                    $(Method::$fixed => None,)*
                    $(Method::$adaptive => Some(IntegratorSpec::$adaptive(options)),)*
                }
            }

            /// The fixed-step method at step `dt_s` (`None` for an adaptive method).
            pub fn fixed(self, dt_s: f64) -> Option<IntegratorSpec> {
                match self {
                    $(Method::$fixed => Some(IntegratorSpec::$fixed { dt_s }),)*
                    $(Method::$adaptive => None,)*
                }
            }
        }

        impl IntegratorSpec {
            /// Its method.
            pub fn method(&self) -> Method {
                match self {
                    $(IntegratorSpec::$fixed { .. } => Method::$fixed,)*
                    $(IntegratorSpec::$adaptive(_) => Method::$adaptive,)*
                }
            }

            /// The options of an adaptive method (`None` for the fixed-step ones).
            pub fn adaptive_options(&self) -> Option<&AdaptiveOptions> {
                match self {
                    $(IntegratorSpec::$fixed { .. } => None,)*
                    $(IntegratorSpec::$adaptive(o) => Some(o),)*
                }
            }

            /// The options of an adaptive method, to change (`None` for the fixed-step ones).
            pub fn adaptive_options_mut(&mut self) -> Option<&mut AdaptiveOptions> {
                match self {
                    $(IntegratorSpec::$fixed { .. } => None,)*
                    $(IntegratorSpec::$adaptive(o) => Some(o),)*
                }
            }

            /// The step of a fixed-step method, s (`None` for the adaptive ones).
            pub fn fixed_step_s(&self) -> Option<f64> {
                match *self {
                    $(IntegratorSpec::$fixed { dt_s } => Some(dt_s),)*
                    $(IntegratorSpec::$adaptive(_) => None,)*
                }
            }

            /// Checks the settings; errors name the field (relative to `integrator`).
            pub fn validate(&self) -> Result<(), SpecError> {
                match *self {
                    $(IntegratorSpec::$fixed { dt_s } => {
                        crate::spec::check_positive("integrator.dt_s", dt_s)
                    })*
                    $(IntegratorSpec::$adaptive(options) => validate_adaptive(options),)*
                }
            }

            /// Hands `visitor` the method's integrator: a fixed-step scheme built at its step, or
            /// an adaptive method's type with its options.
            pub(crate) fn visit<V: MethodVisitor>(&self, visitor: V) -> V::Output {
                match *self {
                    $(IntegratorSpec::$fixed { dt_s } => visitor.fixed($scheme { dt: dt_s }),)*
                    $(IntegratorSpec::$adaptive(options) => {
                        visitor.adaptive::<$method>(options)
                    })*
                }
            }
        }
    };
}

// The one list of methods.
integrators! {
    fixed: {
        /// Velocity Verlet, fixed step (second order).
        Verlet = VelocityVerlet, "Velocity Verlet, fixed step.";
        /// Classic Runge–Kutta, fixed step (fourth order).
        Rk4 = Rk4, "Classic Runge–Kutta, fixed step.";
    }
    adaptive: {
        /// Dormand–Prince 8(5,3), adaptive, 7th-order dense output. `atol` is relative to each
        /// component's natural scale (the two-body peak overlap for positions, the striker velocity for
        /// velocities, the impact energy and momentum for the ledger's quadratures).
        Dop853 = Dop853Method, "Dormand–Prince 8(5,3), adaptive.";
        /// ROS34PW2, a linearly implicit (Rosenbrock-W) method of order 3, L-stable, with the chain's
        /// tridiagonal Jacobian: for damping-dominated chains (μ ≳ 1000 kg/s with light particles),
        /// where explicit methods are held to steps of order m/μ. Options as for DOP853.
        Ros34pw2 = Ros34pw2Method, "ROS34PW2 (Rosenbrock-W), adaptive, for damping-dominated chains.";
        /// Verner's "most efficient" 6(5) pair, adaptive, 6th-order dense output: eight right-hand
        /// sides per attempted step and three more per accepted one, against DOP853's eleven and
        /// four. Options as for DOP853.
        Vern6 = Vern6Method, "Verner's 6(5) pair, adaptive.";
    }
}

/// What is done with the integrator a spec names ([`IntegratorSpec::visit`]): the one way from a
/// spec to its integrator's type, so that running a scene names no method.
pub(crate) trait MethodVisitor {
    /// What the visit gives.
    type Output;
    /// A fixed-step method, built at its step.
    fn fixed<S: Integrator + 'static>(self, scheme: S) -> Self::Output;
    /// An adaptive method, with its options.
    fn adaptive<M: AdaptiveMethod + 'static>(self, options: AdaptiveOptions) -> Self::Output;
}

impl Default for IntegratorSpec {
    fn default() -> Self {
        IntegratorSpec::Dop853(AdaptiveOptions::new(1e-9))
    }
}

impl Method {
    /// Every method, in the order the docs list them.
    pub const ALL: [Method; COUNT] = [
        Method::Dop853,
        Method::Vern6,
        Method::Ros34pw2,
        Method::Rk4,
        Method::Verlet,
    ];

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

    /// The adaptive method at `rtol`, its other options the defaults (`None` for a fixed-step
    /// method).
    pub fn adaptive(self, rtol: f64) -> Option<IntegratorSpec> {
        self.with_options(AdaptiveOptions::new(rtol))
    }
}

// `Method::ALL` has as many entries as the list (its type says so); none twice, so each once.
const _: () = {
    let mut i = 0;
    while i < COUNT {
        let mut j = 0;
        while j < i {
            assert!(
                Method::ALL[i] as u8 != Method::ALL[j] as u8,
                "Method::ALL lists a method twice"
            );
            j += 1;
        }
        i += 1;
    }
};

impl IntegratorSpec {
    /// Stable name of the method.
    pub fn method_name(&self) -> &'static str {
        self.method().name()
    }
}

/// An adaptive method's options checked; errors name the field (relative to `integrator`).
fn validate_adaptive(options: AdaptiveOptions) -> Result<(), SpecError> {
    let pos = crate::spec::check_positive;
    let AdaptiveOptions {
        rtol,
        atol,
        max_step_s,
        ..
    } = options;
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

    /// Each spec reaches its own integrator: the integrator a visit builds has the method's
    /// name, and an adaptive one the spec's options.
    #[test]
    fn every_spec_visits_its_own_integrator() {
        use crate::integrate::Adaptive;
        /// The integrator's name, and an adaptive one's relative tolerance.
        struct Name;
        impl MethodVisitor for Name {
            type Output = (&'static str, Option<f64>);
            fn fixed<S: Integrator + 'static>(self, scheme: S) -> Self::Output {
                (scheme.name(), None)
            }
            fn adaptive<M: AdaptiveMethod + 'static>(
                self,
                options: AdaptiveOptions,
            ) -> Self::Output {
                let integrator = Adaptive::<M>::with_options(options);
                (integrator.name(), Some(integrator.options.rtol))
            }
        }
        for method in Method::ALL {
            let spec = method
                .adaptive(3e-7)
                .or_else(|| method.fixed(2.5e-8))
                .unwrap();
            assert_eq!(spec.method(), method);
            let rtol = method.is_adaptive().then_some(3e-7);
            assert_eq!(spec.visit(Name), (method.name(), rtol));
            assert_eq!(spec.adaptive_options().map(|o| o.rtol), rtol);
        }
    }
}
