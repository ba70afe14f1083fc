//! Periodic orbits of chains: the responses of harmonically driven chains by shooting, their
//! Floquet multipliers, and branches of them continued in one scene field through folds, with
//! their bifurcations located and the branch of twice the period followed from a period
//! doubling; and the free orbits of chains left to themselves (breathers, backbone curves).
//!
//! **Shooting** ([`shooting`]). A chain driven at frequency `f` with period `T = periods/f` (one
//! drive period, or several for a sub-harmonic response) has a periodic orbit where the period map
//! `P`, the state after `T` from a state `x` at `t = 0` under the full (unramped) drive, returns to
//! its start: `P(x) = x`. Newton's method solves it, each step `(M − I) Δx = x − P(x)` with the
//! monodromy matrix `M = ∂P/∂x`, from a first guess integrated from rest over `settle_periods`
//! drive periods (the scene's own ramp included). `M` comes from the variational equations
//! `Φ' = J(t) Φ`, `Φ(0) = I`, integrated alongside the orbit with the chain's tridiagonal
//! Jacobian (the one the Rosenbrock method uses), where they hold; where a force jumps during the
//! period (a viscous contact opening while its ends move apart), or the chain has no Jacobian (a
//! mounted wall), by central differences of the period map, with steps `rtol^{1/3}` of each
//! component's scale. The orbit converges when `max_i |P(x)_i − x_i| / s_i ≤ tolerance`, `s_i`
//! the integrator's own scale of the component (the overlap scale for positions, the velocity
//! scale for velocities); the tolerance must lie above the integrator's error over a period.
//!
//! **Stability.** The Floquet multipliers are the eigenvalues of `M`; the orbit is stable when
//! all lie inside the unit circle. A real multiplier through `+1` is a fold (saddle-node) or a
//! branch point, through `−1` a period doubling, a complex pair through the circle a
//! Neimark–Sacker bifurcation.
//!
//! **Continuation** ([`branch`]). Pseudo-arclength continuation in one scalar parameter `p` (any
//! scene field, through a function that builds the scene at `p`): the unknowns `u = (x/s, p/s_p)`
//! scaled (`s_p` the parameter's range), a predictor along the unit tangent, a Newton corrector
//! on the hyperplane orthogonal to it, `∂P/∂p` by a forward difference. The step grows after easy
//! corrections and is halved after failed ones or sharp turns. Folds (the tangent's parameter
//! component changes sign), branch points (the bordered Jacobian's determinant changes sign),
//! period doublings (`det(M + I)`) and Neimark–Sacker points (`Π(|μ|² − 1)` over complex pairs)
//! are detected between consecutive points and located by the Illinois method on the arclength.
//! [`continue_branch`] starts from an orbit settled by time integration,
//! [`continue_branch_from`] from a given one (an unstable orbit, a point of another branch).
//!
//! **Period doubling** ([`doubling`]). At a located period doubling a real multiplier is `−1`;
//! its eigenvector `v` (`M v = −v`, by inverse iteration with the LU factors of `M − μ I`, `μ`
//! the computed multiplier) is the direction in which the orbits of twice the period leave the
//! single-period orbit: to the period map over `2T`, whose multiplier there is `+1`, the
//! doubling is a pitchfork, and the doubled branch leaves it orthogonally to the single-period
//! branch. [`continue_period_doubled`] corrects its first orbit from the doubling's orbit moved by
//! one step along `v` (made orthogonal to the parent branch's tangent), on the hyperplane
//! orthogonal to that step, which leaves the parameter free; where the correction falls back
//! onto the single-period orbit (its split `|P_T(x) − x|` under a tenth of the step) it tries
//! `−v`. The branch then goes on as any other, in `2 × periods` drive periods, to either side
//! of the doubling: into the range where the single-period orbit is unstable when the doubling is
//! supercritical (its split growing as the square root of the distance to it, the doubled
//! orbits stable), into the other when it is subcritical (the doubled orbits unstable).
//!
//! **Free orbits** ([`autonomous`]). A chain without drive or dissipation has families of
//! periodic orbits (a breather in a gap of a periodic chain's spectrum, the free oscillation of
//! a precompressed contact along its backbone curve) that no forcing period fixes: each period
//! `T` has its own. Its equations are reversible (unchanged by `t → −t`, `v → −v`), so a motion
//! that stops at `t = 0` and again at `T/2` (every velocity zero: turning points) retraces itself
//! backwards and is periodic with period `T`. [`AutonomousMap::shoot`] solves the `N` conditions
//! `v(T/2) = 0` in the `N` unknowns `x(0)` by Newton's method, with `∂v(T/2)/∂x(0)` from the
//! variational equations over half the period (the approach of Flach & Willis, Phys. Rep. 295,
//! 181, 1998, and Marin & Aubry, Nonlinearity 9, 1501, 1996): the turning point fixes the phase,
//! the period the member of the family. The static state is such an orbit at every period, so
//! the first guess must lie nearer the orbit sought (for a breather: the particle it is centred
//! on displaced, its neighbours a little). [`continue_autonomous`] follows a family through a
//! list of frequencies by natural-parameter continuation (each orbit from a guess extrapolated
//! linearly from the two before it), which needs steps small enough that the guess stays in the
//! orbit's basin: near a band edge, where the breathers widen and their families lie close
//! together, smaller ones. The multipliers come from the monodromy over the whole period: two are
//! `+1` (a shift along the orbit and a change of its energy, of its frequency, persist), computed
//! as a pair split by about the square root of the monodromy's error (a Jordan block), and are
//! left out of the stability, for which every other multiplier must lie on the unit circle
//! (they come in pairs `μ`, `1/μ̄`) to a tolerance.

pub mod autonomous;
pub mod branch;
pub mod dense;
pub mod doubling;
pub mod shooting;

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::spec::{spec_err, SpecError};

pub use autonomous::{
    continue_autonomous, resume_autonomous, AutonomousFamily, AutonomousMap, AutonomousOrbit,
};
pub use branch::{
    continue_branch, continue_branch_from, continue_branch_stoppable, resume_branch, Branch,
    BranchOptions, BranchPoint, PointKind, Progress,
};
pub use doubling::{
    continue_period_doubled, continue_period_doubled_stoppable, doubled_orbits,
    period_doubling_vector, resume_period_doubled,
};
pub use shooting::{MapOutput, Orbit, PeriodMap, ShootingError};

/// How the monodromy matrix is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Monodromy {
    /// The variational equations where they hold, else finite differences.
    #[default]
    Auto,
    /// The variational equations always (wrong by the missing saltation where a force jumps).
    Variational,
    /// Central differences of the period map.
    FiniteDifference,
}

impl Monodromy {
    /// Its name, as in a sweep file.
    pub fn name(self) -> &'static str {
        match self {
            Monodromy::Auto => "auto",
            Monodromy::Variational => "variational",
            Monodromy::FiniteDifference => "finite_difference",
        }
    }
}

/// How periodic orbits are found.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct PeriodicOptions {
    /// Drive periods in one orbit period: 1 for a response at the drive's frequency, 2 for a
    /// period-doubled one (1 to 64, default 1).
    #[cfg_attr(feature = "serde", serde(default = "default_periods"))]
    pub periods: u32,
    /// Drive periods integrated from rest (the scene's ramp included) for the first guess
    /// (default 50).
    #[cfg_attr(feature = "serde", serde(default = "default_settle_periods"))]
    pub settle_periods: u32,
    /// Largest scaled residual `max_i |P(x)_i − x_i| / s_i` of a converged orbit (default 1e-7;
    /// above the integrator's error over one period).
    #[cfg_attr(feature = "serde", serde(default = "default_tolerance"))]
    pub tolerance: f64,
    /// Most Newton iterations per orbit (default 12).
    #[cfg_attr(feature = "serde", serde(default = "default_max_iterations"))]
    pub max_iterations: u32,
    /// How the monodromy matrix is computed (default `auto`).
    #[cfg_attr(feature = "serde", serde(default))]
    pub monodromy: Monodromy,
}

#[cfg(feature = "serde")]
fn default_periods() -> u32 {
    1
}
#[cfg(feature = "serde")]
fn default_settle_periods() -> u32 {
    50
}
#[cfg(feature = "serde")]
fn default_tolerance() -> f64 {
    1e-7
}
#[cfg(feature = "serde")]
fn default_max_iterations() -> u32 {
    12
}

impl Default for PeriodicOptions {
    fn default() -> Self {
        PeriodicOptions {
            periods: 1,
            settle_periods: 50,
            tolerance: 1e-7,
            max_iterations: 12,
            monodromy: Monodromy::Auto,
        }
    }
}

impl PeriodicOptions {
    /// Checks the options; errors name the field under `periodic`.
    pub fn validate(&self) -> Result<(), SpecError> {
        if !(1..=64).contains(&self.periods) {
            return Err(spec_err(
                "periodic.periods",
                format!("must lie in 1..=64, got {}", self.periods),
            ));
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(spec_err(
                "periodic.tolerance",
                format!("must lie in (0, 1), got {}", self.tolerance),
            ));
        }
        if !(1..=100).contains(&self.max_iterations) {
            return Err(spec_err(
                "periodic.max_iterations",
                format!("must lie in 1..=100, got {}", self.max_iterations),
            ));
        }
        if self.settle_periods == 0 {
            return Err(spec_err(
                "periodic.settle_periods",
                "must be at least 1: the first orbit is guessed from the response after that many drive periods from rest",
            ));
        }
        Ok(())
    }
}
