//! A wall under the chain that is not rigid: a body of mass `M` on a linear spring `k` and a
//! dashpot `c` to the ground — a load cell, a force plate or a soft support.
//!
//! The wall's displacement `u` (positive downwards, away from the chain) is measured from its
//! static equilibrium under the chain at rest, so that the chain's static state is unchanged and
//! `u = 0` at the start. The mount's equation of motion is
//!
//! `M ü = F_w − F_s − k u − c u̇`,
//!
//! `F_w` the force of the chain's last contact on the wall and `F_s` its static value (the chain's
//! weight and the precompression); the wall's own weight is carried by the spring's preload and
//! cancels. The force the mount passes to the ground, what a load cell under the wall reads, is
//! `F_s + k u + c u̇`. In the energy ledger the wall's kinetic energy `M u̇²/2` joins the kinetic
//! term, its potential `F_s u + k u²/2` (the spring's energy over its loaded state, the wall's
//! weight included) the elastic one, and the dashpot's work `∫ c u̇² dt` the dissipated one.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::spec::{check_positive, spec_err, SpecError};

/// A wall on a spring and a dashpot (`chain.wall_mount`).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct WallMount {
    /// Mass of the wall (the load cell's moving part, the plate), kg.
    pub mass_kg: f64,
    /// Stiffness of the spring that holds it, N/m.
    pub stiffness_n_m: f64,
    /// Viscous coefficient of the dashpot beside the spring, kg/s (0: none).
    #[cfg_attr(feature = "serde", serde(default))]
    pub damping_kg_s: f64,
}

impl WallMount {
    /// Checks every field, naming it.
    pub fn validate(&self) -> Result<(), SpecError> {
        check_positive("chain.wall_mount.mass_kg", self.mass_kg)?;
        check_positive("chain.wall_mount.stiffness_n_m", self.stiffness_n_m)?;
        if !(self.damping_kg_s.is_finite() && self.damping_kg_s >= 0.0) {
            return Err(spec_err(
                "chain.wall_mount.damping_kg_s",
                format!("must be finite and >= 0, got {}", self.damping_kg_s),
            ));
        }
        Ok(())
    }

    /// Natural frequency of the wall alone on its spring, Hz: `√(k/M)/2π`.
    pub fn natural_frequency_hz(&self) -> f64 {
        (self.stiffness_n_m / self.mass_kg).sqrt() / (2.0 * std::f64::consts::PI)
    }
}
