//! The physics switches of a scene ([`PhysicsSpec`]): gravity, damping, the wall, clipping,
//! precompression and the dissipation model. Apart from the chain's geometry because a sweep
//! varies them independently of it.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::contact::DissipationSpec;
use crate::spec::{spec_err, SpecError};

/// Standard gravity used by default, m/s².
pub const STANDARD_GRAVITY_M_S2: f64 = 9.81;

/// Which physics a scene switches on.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct PhysicsSpec {
    /// Gravity along +x on every particle, striker included, with the static-equilibrium initial state.
    pub gravity: bool,
    /// Gravitational acceleration, m/s².
    #[cfg_attr(feature = "serde", serde(default = "default_gravity"))]
    pub gravity_m_s2: f64,
    /// Viscous damping coefficient μ on every contact but the striker's, kg/s (Eqs. 9–12).
    pub damping_kg_s: f64,
    /// Damping μ₁ on the striker contact, kg/s (Eqs. 8–9). Absent: equal to `damping_kg_s`.
    #[cfg_attr(feature = "serde", serde(default))]
    pub striker_damping_kg_s: Option<f64>,
    /// The rigid wall under the last particle (Eq. 7). Without it the last particle is free.
    pub wall: bool,
    /// Clip the net (elastic + viscous) contact force at zero so a contact never pulls. The paper's
    /// equations allow a slightly tensile force at the end of unloading; that is the default.
    #[cfg_attr(feature = "serde", serde(default))]
    pub clip_tensile: bool,
    /// Static precompression force pressing the first chain particle towards the wall, N (needs
    /// the wall). The initial state is the exact static equilibrium under it and gravity.
    #[cfg_attr(feature = "serde", serde(default, skip_serializing_if = "is_zero"))]
    pub precompression_force_n: f64,
    /// Dissipation model of every contact (a sequence chain's contact rules may override it per
    /// pair). Absent: the paper's linear viscous term with `damping_kg_s` and
    /// `striker_damping_kg_s`, which must then be zero.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub dissipation: Option<DissipationSpec>,
}

#[cfg(feature = "serde")]
fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

#[cfg(feature = "serde")]
fn default_gravity() -> f64 {
    STANDARD_GRAVITY_M_S2
}

impl Default for PhysicsSpec {
    fn default() -> Self {
        PhysicsSpec {
            gravity: true,
            gravity_m_s2: STANDARD_GRAVITY_M_S2,
            damping_kg_s: 0.0,
            striker_damping_kg_s: None,
            wall: true,
            clip_tensile: false,
            precompression_force_n: 0.0,
            dissipation: None,
        }
    }
}

impl PhysicsSpec {
    /// Whether any contact carries the paper's linear viscous damping.
    pub fn has_damping(&self) -> bool {
        self.damping_kg_s != 0.0 || self.striker_damping_kg_s.is_some_and(|m| m != 0.0)
    }
}

impl PhysicsSpec {
    /// Checks every field for physical sense; the error names the field (relative to `physics`).
    pub fn validate(&self) -> Result<(), SpecError> {
        if !(self.gravity_m_s2.is_finite() && self.gravity_m_s2 >= 0.0) {
            return Err(spec_err(
                "physics.gravity_m_s2",
                format!("must be a finite number >= 0, got {}", self.gravity_m_s2),
            ));
        }
        if !(self.damping_kg_s.is_finite() && self.damping_kg_s >= 0.0) {
            return Err(spec_err(
                "physics.damping_kg_s",
                format!("must be a finite number >= 0, got {}", self.damping_kg_s),
            ));
        }
        if let Some(m) = self.striker_damping_kg_s {
            if !(m.is_finite() && m >= 0.0) {
                return Err(spec_err(
                    "physics.striker_damping_kg_s",
                    format!("must be a finite number >= 0, got {m}"),
                ));
            }
        }
        let f = self.precompression_force_n;
        if !(f.is_finite() && f >= 0.0) {
            return Err(spec_err(
                "physics.precompression_force_n",
                format!("must be a finite number >= 0, got {f}"),
            ));
        }
        if f > 0.0 && !self.wall {
            return Err(spec_err(
                "physics.precompression_force_n",
                "a static force needs a wall to push the chain against (physics.wall = true)",
            ));
        }
        if let Some(d) = &self.dissipation {
            d.validate("physics.dissipation")?;
            if self.damping_kg_s != 0.0 {
                return Err(spec_err(
                    "physics.damping_kg_s",
                    format!("must be 0 when physics.dissipation is given (the model replaces the linear viscous term; for both, give a contact rule {{\"linear_viscous\": …}}), got {}", self.damping_kg_s),
                ));
            }
            if self.striker_damping_kg_s.is_some() {
                return Err(spec_err(
                    "physics.striker_damping_kg_s",
                    "must be absent when physics.dissipation is given (give the striker contact its own model with a contact rule between \"striker\" and its neighbour)",
                ));
            }
        }
        Ok(())
    }
}
