//! Time integrators behind one interface.
//!
//! Every integrator advances an [`OdeSystem`] whose state is laid out as
//! `[x (n_pos), v (n_pos), q (n_quad)]`: positions, velocities and quadratures (quantities such as
//! dissipated work that are integrated along with the motion but never feed back into it). After
//! each accepted step the integrator hands the observer a [`DenseStep`], an interpolant valid on
//! that step, so that probes are sampled at their own output times rather than at step ends.

mod adaptive;
mod dop853;
mod events;
mod explicit;
mod fixed;
#[cfg(test)]
mod method_tests;
#[cfg(test)]
mod order_conditions;
mod rk4;
mod rosenbrock;
mod sliver;
mod verlet;
mod vern6;

pub use adaptive::{Adaptive, AdaptiveOptions, Method as AdaptiveMethod};
pub use dop853::{Dop853, Dop853Method};
pub use rk4::Rk4;
pub use rosenbrock::{Ros34pw2, Ros34pw2Method};
pub use verlet::VelocityVerlet;
pub use vern6::{Vern6, Vern6Method};

/// A first-order system `y' = f(t, y)` with the state layout `[x, v, q]` described in the module docs.
pub trait OdeSystem {
    /// Number of positions (equal to the number of velocities).
    fn n_pos(&self) -> usize;
    /// Number of quadrature components after the velocities.
    fn n_quad(&self) -> usize;
    /// Length of the state vector, `2 n_pos + n_quad`.
    fn dim(&self) -> usize {
        2 * self.n_pos() + self.n_quad()
    }
    /// Writes `f(t, y)` into `dy`. Must not allocate: it is the hot loop.
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]);
    /// Switching functions across whose zeros `f` is not smooth (contacts opening and closing).
    /// Integrators that locate events put step boundaries on them. None by default.
    fn switches(&self) -> &[Switch] {
        &[]
    }
    /// Corrects `dy = f(t, y)` so that switch number `switch` acts as on its `positive` side (the
    /// side where its value is positive) or the other, whichever side `y` is on, every other term
    /// unchanged: the right-hand side of one side continued a hair across the switch. An attempt
    /// that lands on a switch ends a hair past its crossing, where its last stage is evaluated;
    /// a term that jumps there (a viscous force that acts only while a contact is compressed)
    /// would give that stage the other side's value, an error of the order of the jump times the
    /// step, which the error test rejects. The default does nothing: right for a right-hand side
    /// that is continuous across its switches.
    fn hold_switch(&self, _switch: usize, _positive: bool, _y: &[f64], _dy: &mut [f64]) {}
    /// Whether every term that switch number `switch` turns on and off vanishes identically while
    /// its value is `≤ 0` (a contact's force once it has opened): past a crossing into that side
    /// the motion is as smooth as it was before, with no term starting there. The step after
    /// landing on such a crossing goes on with the step the motion before it allowed; after any
    /// other (a contact that closes, whose force starts like δ^{3/2}) it starts from half of it.
    /// The default, `false`, is safe for any system: it only costs steps.
    fn vanishes_below(&self, _switch: usize) -> bool {
        false
    }
    /// Jacobian of the accelerations `a(x, v)` at state `y`, for implicit methods: `kx = ∂a/∂x` and
    /// `kv = ∂a/∂v`, both tridiagonal for a chain (particle `i` feels only its neighbours).
    /// Returns `false` when the system does not provide one (the default).
    fn acceleration_jacobian(
        &self,
        _t: f64,
        _y: &[f64],
        _kx: &mut Tridiagonal,
        _kv: &mut Tridiagonal,
    ) -> bool {
        false
    }
}

/// A tridiagonal matrix of order `n`: `lower[i] = M[i+1][i]`, `diag[i] = M[i][i]`,
/// `upper[i] = M[i][i+1]` (`lower` and `upper` have `n-1` entries).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Tridiagonal {
    /// Sub-diagonal, `n-1` entries.
    pub lower: Vec<f64>,
    /// Diagonal, `n` entries.
    pub diag: Vec<f64>,
    /// Super-diagonal, `n-1` entries.
    pub upper: Vec<f64>,
}

impl Tridiagonal {
    /// The zero matrix of order `n`.
    pub fn zeros(n: usize) -> Self {
        Tridiagonal {
            lower: vec![0.0; n.saturating_sub(1)],
            diag: vec![0.0; n],
            upper: vec![0.0; n.saturating_sub(1)],
        }
    }
}

/// A switching function `g(y) = y[plus] − y[minus] + offset` (or `y[plus] + offset`), linear
/// in the state so that it can be evaluated on any interpolant. The right-hand side is smooth
/// while `g > 0` and while `g <= 0`, but not across `g = 0`. The offset places a fixed body
/// (a wall at the top of a chain) away from the origin of the positions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Switch {
    /// Component entering with a plus sign.
    pub plus: usize,
    /// Component entering with a minus sign, if any.
    pub minus: Option<usize>,
    /// Constant added to the difference.
    pub offset: f64,
}

impl Switch {
    /// The switch `y[plus] − y[minus]` (or `y[plus]`), without offset.
    pub const fn between(plus: usize, minus: Option<usize>) -> Self {
        Switch {
            plus,
            minus,
            offset: 0.0,
        }
    }

    /// Value of the switching function for a component accessor.
    #[inline(always)]
    pub fn value(&self, y: impl Fn(usize) -> f64) -> f64 {
        self.rate(y) + self.offset
    }

    /// Rate of the switching function for an accessor of the components' rates (the offset is
    /// constant).
    #[inline(always)]
    pub fn rate(&self, f: impl Fn(usize) -> f64) -> f64 {
        match self.minus {
            Some(m) => f(self.plus) - f(m),
            None => f(self.plus),
        }
    }
}

/// Interpolant over the last accepted step `[t_start, t_end]`.
pub trait DenseStep {
    /// Start of the step.
    fn t_start(&self) -> f64;
    /// End of the step.
    fn t_end(&self) -> f64;
    /// State at the end of the step (exact step result, not interpolated).
    fn y_end(&self) -> &[f64];
    /// Interpolated component `i` of the state at `t` in `[t_start, t_end]`.
    fn eval_component(&self, t: f64, i: usize) -> f64;
    /// Interpolated full state at `t`, written into `out` (length `dim`).
    fn eval(&self, t: f64, out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.eval_component(t, i);
        }
    }
    /// Interpolated components `indices` at `t`, each written to `out[i]` (the same values as
    /// [`DenseStep::eval_component`]); one call for the handful of components probes read.
    fn eval_components(&self, t: f64, indices: &[usize], out: &mut [f64]) {
        eval_each(self, t, indices, out);
    }
    /// Interpolated components `indices` at each of `times`: row `r` of `out` (the `indices.len()`
    /// values from `out[r * indices.len()]`) holds them at `times[r]`, in the order of `indices`
    /// (the same values as [`DenseStep::eval_component`]). One call for all the samples a step
    /// holds lets a method set up its interpolant once and evaluate it for several components at
    /// a time.
    fn eval_components_at(&self, times: &[f64], indices: &[usize], out: &mut [f64]) {
        eval_each_at(self, times, indices, out);
    }
    /// An enclosure `(lo, hi)` of every value the step's interpolant gives for component `i`
    /// anywhere in `[t_start, t_end]`, as computed (rounding included), through
    /// [`DenseStep::eval_component`] and the batched evaluations alike; `None` where the
    /// interpolant has no such bound. What lets an observer skip samples that provably change
    /// nothing it records.
    fn component_range(&self, _i: usize) -> Option<(f64, f64)> {
        None
    }
}

/// [`DenseStep::eval_components`] one component at a time, through
/// [`DenseStep::eval_component`]: its default, and what a batched implementation does with more
/// components than it batches.
pub fn eval_each<S: DenseStep + ?Sized>(step: &S, t: f64, indices: &[usize], out: &mut [f64]) {
    for &i in indices {
        out[i] = step.eval_component(t, i);
    }
}

/// [`DenseStep::eval_components_at`] one time and one component at a time, through
/// [`DenseStep::eval_component`]: its default, and what a batched implementation does with more
/// components than it batches.
pub fn eval_each_at<S: DenseStep + ?Sized>(
    step: &S,
    times: &[f64],
    indices: &[usize],
    out: &mut [f64],
) {
    let m = indices.len();
    for (&t, row) in times.iter().zip(out.chunks_exact_mut(m.max(1))) {
        for (o, &i) in row.iter_mut().zip(indices) {
            *o = step.eval_component(t, i);
        }
    }
}

/// Most components a step interpolates side by side in [`DenseStep::eval_components_at`] (the
/// probes of a run read a few dozen at most; more are interpolated one by one).
pub const BATCH_COMPONENTS: usize = 32;

/// What an observer tells the integrator after a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Control {
    /// Keep integrating.
    Continue,
    /// Stop now; the run ends successfully at the end of this step.
    Stop,
}

/// Receives every accepted step.
pub trait StepObserver {
    /// Called once with the initial state before the first step.
    fn on_start(&mut self, t0: f64, y0: &[f64]);
    /// Called after every accepted step.
    fn on_step(&mut self, step: &dyn DenseStep) -> Control;
}

/// Counters that make an integrator's work observable (for work-precision studies).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
pub struct IntegrationStats {
    /// Accepted steps.
    pub steps: u64,
    /// Rejected step attempts (adaptive methods only), event retakes included.
    pub rejected: u64,
    /// Steps retaken to end on a located event (a contact opening or closing).
    pub events: u64,
    /// Evaluations of the right-hand side.
    pub rhs_evals: u64,
    /// Times an explicit adaptive method found its step held by stability rather than accuracy
    /// for a sustained stretch (Hairer's stiffness test): an implicit method would be cheaper.
    pub stiffness_detections: u64,
}

impl IntegrationStats {
    /// Step attempts, accepted and rejected: what a step budget (`max_steps`) counts.
    pub fn attempts(&self) -> u64 {
        self.steps + self.rejected
    }

    /// Adds the counters of a further stretch of the same run (a leg, or a restart).
    pub fn add(&mut self, more: &IntegrationStats) {
        self.steps += more.steps;
        self.rejected += more.rejected;
        self.events += more.events;
        self.rhs_evals += more.rhs_evals;
        self.stiffness_detections += more.stiffness_detections;
    }
}

/// Why an integration stopped before reaching its end time.
#[derive(Debug, Clone, PartialEq)]
pub enum IntegrateError {
    /// The state or its derivative became NaN or infinite at time `t`.
    NonFinite {
        /// Time of the failed step.
        t: f64,
    },
    /// More than `max_steps` step attempts (accepted and rejected) were needed.
    StepBudget {
        /// The budget that was exceeded.
        max_steps: u64,
        /// Time reached.
        t: f64,
    },
    /// An adaptive method's step size fell below what floating point can resolve.
    StepTooSmall {
        /// Time at which the step collapsed.
        t: f64,
        /// The step size tried.
        h: f64,
    },
    /// Settings that cannot work (non-positive step, tolerance, or interval).
    InvalidSettings(String),
}

impl std::fmt::Display for IntegrateError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            IntegrateError::NonFinite { t } => {
                write!(f, "state became NaN or infinite at t = {t:.6e} s")
            }
            IntegrateError::StepBudget { max_steps, t } => write!(
                f,
                "step budget of {max_steps} steps exhausted at t = {t:.6e} s (max_steps: accepted and rejected attempts both count)"
            ),
            IntegrateError::StepTooSmall { t, h } => write!(
                f,
                "step size collapsed to {h:.3e} s at t = {t:.6e} s (problem too stiff or non-smooth for this method)"
            ),
            IntegrateError::InvalidSettings(s) => write!(f, "invalid integrator settings: {s}"),
        }
    }
}

impl std::error::Error for IntegrateError {}

/// Common interface of all integrators.
pub trait Integrator {
    /// Short stable name (`"verlet"`, `"rk4"`, `"dop853"`).
    fn name(&self) -> &'static str;
    /// Integrates `sys` from `(t0, y0)` to `t_end`, calling `obs` after every accepted step.
    /// `max_steps` bounds the number of step attempts, accepted and rejected (event retakes
    /// included), so that a run which keeps retrying ends too.
    fn integrate(
        &self,
        sys: &mut dyn OdeSystemDyn,
        t0: f64,
        y0: &[f64],
        t_end: f64,
        max_steps: u64,
        obs: &mut dyn StepObserver,
    ) -> Result<IntegrationStats, IntegrateError>;
}

/// Object-safe alias of [`OdeSystem`] so integrators can be chosen at run time; the
/// right-hand side itself stays monomorphised inside the concrete system.
pub trait OdeSystemDyn {
    /// See [`OdeSystem::n_pos`].
    fn n_pos(&self) -> usize;
    /// See [`OdeSystem::n_quad`].
    fn n_quad(&self) -> usize;
    /// See [`OdeSystem::rhs`].
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]);
    /// See [`OdeSystem::switches`].
    fn switches(&self) -> &[Switch];
    /// See [`OdeSystem::hold_switch`].
    fn hold_switch(&self, switch: usize, positive: bool, y: &[f64], dy: &mut [f64]);
    /// See [`OdeSystem::vanishes_below`].
    fn vanishes_below(&self, switch: usize) -> bool;
    /// See [`OdeSystem::acceleration_jacobian`].
    fn acceleration_jacobian(
        &self,
        t: f64,
        y: &[f64],
        kx: &mut Tridiagonal,
        kv: &mut Tridiagonal,
    ) -> bool;
}

impl<S: OdeSystem> OdeSystemDyn for S {
    fn n_pos(&self) -> usize {
        OdeSystem::n_pos(self)
    }
    fn n_quad(&self) -> usize {
        OdeSystem::n_quad(self)
    }
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        OdeSystem::rhs(self, t, y, dy)
    }
    fn switches(&self) -> &[Switch] {
        OdeSystem::switches(self)
    }
    fn hold_switch(&self, switch: usize, positive: bool, y: &[f64], dy: &mut [f64]) {
        OdeSystem::hold_switch(self, switch, positive, y, dy)
    }
    fn vanishes_below(&self, switch: usize) -> bool {
        OdeSystem::vanishes_below(self, switch)
    }
    fn acceleration_jacobian(
        &self,
        t: f64,
        y: &[f64],
        kx: &mut Tridiagonal,
        kv: &mut Tridiagonal,
    ) -> bool {
        OdeSystem::acceleration_jacobian(self, t, y, kx, kv)
    }
}

pub(crate) fn all_finite(y: &[f64]) -> bool {
    // Branch-free so that it vectorises (it runs on several state-sized vectors every step): a
    // value is NaN or infinite exactly when its exponent bits are all ones.
    const EXPONENT: u64 = 0x7ff0_0000_0000_0000;
    !y.iter()
        .fold(false, |bad, v| bad | (v.to_bits() & EXPONENT == EXPONENT))
}
