//! The one adaptive step loop, shared by every adaptive method: one options type, one step-size
//! controller, the handling of non-finite attempts, the step budget and Hairer's stiffness count;
//! the switches a step crosses are located by [`super::events`]. A method brings only what is its
//! own ([`Method`], [`Stepper`]): its attempt (the stages, the solution and the error norm) and its
//! dense output; the explicit ones through the one Runge–Kutta core of [`super::explicit`], as
//! tableaus. (diffsol's model: one Runge–Kutta core shared by its methods.)
//!
//! The stage arithmetic runs through [`chainsweep_cpu::dispatch`], compiled for the CPU's vector
//! instructions and fused multiply-add.

use chainsweep_cpu::{dispatch, Kernel, MulAdd};

use super::events::{Events, Next};
use super::sliver::{Sliver, SLIVER_MAX_ERROR};
use super::{
    all_finite, Control, DenseStep, IntegrateError, IntegrationStats, Integrator, OdeSystemDyn,
    StepObserver, Tridiagonal,
};

/// Settings of an adaptive method: the same for every method, in a scene's `integrator` block and
/// in the integrators.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct AdaptiveOptions {
    /// Relative tolerance (must be positive).
    pub rtol: f64,
    /// Absolute tolerance (must be non-negative); absent: equal to `rtol`. The integrators multiply
    /// it by each component's scale when they are given scales ([`Adaptive::atol_scale`]); a scene
    /// gives the natural scale of each quantity (the two-body peak overlap for positions, the
    /// striker velocity for velocities, the impact energy and momentum for the ledger's
    /// quadratures).
    #[cfg_attr(feature = "serde", serde(default))]
    pub atol: Option<f64>,
    /// Largest step, s. Absent: no bound but the interval. The last step may stretch up to 1 %
    /// beyond it so as to land exactly on the end time (Hairer's rule).
    #[cfg_attr(feature = "serde", serde(default))]
    pub max_step_s: Option<f64>,
    /// Put step boundaries on the zeros of the system's switching functions (contacts opening and
    /// closing), where the right-hand side is not smooth (default). A step that passes the error
    /// test but crosses a switch is retaken to end just past the earliest crossing, located on the
    /// dense output; the retaken step is accepted.
    #[cfg_attr(feature = "serde", serde(default = "default_true"))]
    pub locate_events: bool,
    /// With `locate_events`: also end a step just past a switch crossing predicted at its start
    /// (from the value, slope and curvature of each switch), rather than let the attempt fail on
    /// the kink or be retaken, and go on after such a landing from half the step before it rather
    /// than regrow from the short landing step. Off by default (results of existing sweeps stay
    /// bit for bit those of earlier versions; absent from the JSON when off, so their run hashes
    /// stay too). About a third of the attempts and right-hand-side evaluations of a chain whose
    /// contacts open and close often (docs/NUMERICS.md).
    #[cfg_attr(feature = "serde", serde(default, skip_serializing_if = "is_false"))]
    pub predict_switches: bool,
}

#[cfg(feature = "serde")]
fn default_true() -> bool {
    true
}

#[cfg(feature = "serde")]
fn is_false(b: &bool) -> bool {
    !*b
}

impl AdaptiveOptions {
    /// Options with relative tolerance `rtol`, `atol` equal to it, no step bound, events located.
    pub fn new(rtol: f64) -> Self {
        AdaptiveOptions {
            rtol,
            atol: None,
            max_step_s: None,
            locate_events: true,
            predict_switches: false,
        }
    }

    /// The absolute tolerance in force: `atol`, or `rtol` when absent.
    pub fn atol(&self) -> f64 {
        self.atol.unwrap_or(self.rtol)
    }
}

/// An adaptive integrator: the shared step loop with method `M`'s tableau, attempt and dense
/// output. Use it through [`super::Dop853`] and [`super::Ros34pw2`].
///
/// The error of each step is measured component-wise against
/// `atol_i + rtol * max(|y_old|, |y_new|)`, where `atol_i = atol * atol_scale[i]` (or `atol` without
/// scales), and combined into an RMS norm; a step is accepted when that norm is at most one. A
/// component whose absolute tolerance is zero and that is exactly zero at both ends of a step is
/// left out of the norm.
#[derive(Debug, Clone, PartialEq)]
pub struct Adaptive<M> {
    /// Tolerances, step bound, event location.
    pub options: AdaptiveOptions,
    /// Optional per-component scales of the absolute tolerance (length `2 n_pos + n_quad`, each
    /// finite and non-negative): component `i` gets the absolute tolerance `atol * atol_scale[i]`,
    /// so `atol` can be given relative to the natural scale of each quantity.
    pub atol_scale: Option<Vec<f64>>,
    /// First step size to try. `None` uses Hairer's starting-step heuristic (one extra
    /// right-hand-side evaluation). A given value is capped at the largest step.
    pub h_init: Option<f64>,
    /// The method.
    pub method: M,
}

impl<M: Method> Adaptive<M> {
    /// Integrator with the given tolerances, the automatic first step, no step-size cap and event
    /// location on.
    pub fn new(rtol: f64, atol: f64) -> Self {
        Self::with_options(AdaptiveOptions {
            atol: Some(atol),
            ..AdaptiveOptions::new(rtol)
        })
    }

    /// Integrator with the given options, the automatic first step and no tolerance scales.
    pub fn with_options(options: AdaptiveOptions) -> Self {
        Adaptive {
            options,
            atol_scale: None,
            h_init: None,
            method: M::default(),
        }
    }

    /// The same with the largest step set to `h`.
    pub fn with_max_step(mut self, h: f64) -> Self {
        self.options.max_step_s = Some(h);
        self
    }

    /// The same with the first step set to `h`.
    pub fn with_initial_step(mut self, h: f64) -> Self {
        self.h_init = Some(h);
        self
    }

    /// The same with the first step set to `h` when given (else chosen by the integrator).
    pub fn with_initial_step_if(self, h: Option<f64>) -> Self {
        match h {
            Some(h) => self.with_initial_step(h),
            None => self,
        }
    }

    /// The same with per-component scales of the absolute tolerance.
    pub fn with_atol_scale(mut self, scale: Vec<f64>) -> Self {
        self.atol_scale = Some(scale);
        self
    }

    /// The same with event location switched on or off.
    pub fn with_events(mut self, locate_events: bool) -> Self {
        self.options.locate_events = locate_events;
        self
    }
}

/// What a method brings to the core: its name, order and controller constants, and its stepper.
pub trait Method: Copy + Default + std::fmt::Debug {
    /// Stable name (`"dop853"`, `"ros34pw2"`).
    const NAME: &'static str;
    /// Order used by the starting-step heuristic.
    const ORDER: i32;
    /// Step-size controller constants.
    const CONTROLLER: Controller;
    /// The method's work space for one run.
    type Stepper: Stepper;
    /// Work space for a run from `y0` of a system with `n_pos` positions.
    fn stepper(y0: &[f64], n_pos: usize) -> Self::Stepper;
}

/// The integral step-size controller `h_new = h · clamp(safety · err^(−exponent))`, with the
/// change per step bounded by `max_shrink` and `max_growth` (Hairer's form).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Controller {
    /// `1 / (q + 1)` for an error estimate of order `q`.
    pub exponent: f64,
    /// Safety factor.
    pub safety: f64,
    /// Smallest factor a rejection shrinks the step by.
    pub max_shrink: f64,
    /// Largest factor an accepted step grows the next by.
    pub max_growth: f64,
    /// How a rejection computes its factor (the same value, rounded differently).
    pub rejection: RejectionForm,
}

/// The two roundings of the rejection factor `max(max_shrink, safety · err^(−exponent))` found in
/// the published codes. Mathematically equal, they differ in the last bit; each method keeps the
/// one it has always used so that stored results stay bitwise those of earlier versions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RejectionForm {
    /// `h / min(1/max_shrink, err^exponent / safety)` (Hairer's DOP853).
    DivideByInverse,
    /// `h · max(max_shrink, safety / err^exponent)` (the form of our ROS34PW2).
    MultiplyByFactor,
}

impl Controller {
    /// Next step after an accepted step of size `h` with error norm `err` (at most 1).
    #[inline]
    fn after_accept(&self, h: f64, err: f64) -> f64 {
        let fac = (err.powf(self.exponent) / self.safety)
            .clamp(1.0 / self.max_growth, 1.0 / self.max_shrink);
        h / fac
    }

    /// Next try after a rejected step of size `h` with error norm `err` (above 1, or infinite).
    #[inline]
    fn after_reject(&self, h: f64, err: f64) -> f64 {
        match self.rejection {
            RejectionForm::DivideByInverse => {
                h / (1.0 / self.max_shrink).min(err.powf(self.exponent) / self.safety)
            }
            RejectionForm::MultiplyByFactor => {
                h * (self.safety / err.powf(self.exponent)).max(self.max_shrink)
            }
        }
    }
}

/// The right-hand side as the steppers see it: the system, and a count of its evaluations.
pub struct Rhs<'a> {
    sys: &'a mut dyn OdeSystemDyn,
    pub(super) evals: u64,
    /// The switch the current attempt ends a hair past, and its side before the crossing: the
    /// attempt's last stage is evaluated with that switch held on that side
    /// ([`OdeSystem::hold_switch`]), as is the first derivative of a run that starts on a switch.
    pub(super) held: Option<(usize, bool)>,
}

impl<'a> Rhs<'a> {
    pub(super) fn new(sys: &'a mut dyn OdeSystemDyn) -> Self {
        Rhs {
            sys,
            evals: 0,
            held: None,
        }
    }

    /// `dy = f(t, y)`.
    #[inline]
    pub fn eval(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        self.evals += 1;
        self.sys.rhs(t, y, dy);
    }

    /// `dy = f(t, y)` at the end of an attempt (or the start of a run), with the switch it lands
    /// on (or starts on) held on its side before the crossing (or the side it enters).
    #[inline]
    pub fn eval_end(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        self.eval(t, y, dy);
        if let Some((switch, positive)) = self.held {
            self.sys.hold_switch(switch, positive, y, dy);
        }
    }

    /// The system's acceleration Jacobian at `(t, y)`, if it has one.
    pub fn acceleration_jacobian(
        &self,
        t: f64,
        y: &[f64],
        kx: &mut Tridiagonal,
        kv: &mut Tridiagonal,
    ) -> bool {
        self.sys.acceleration_jacobian(t, y, kx, kv)
    }
}

/// The outcome of one attempted step.
#[derive(Debug, Clone, Copy)]
pub struct Attempt {
    /// Error norm (accepted when at most 1).
    pub err: f64,
    /// Whether the attempt produced a finite solution (false also when it could not be made,
    /// such as a singular iteration matrix).
    pub finite: bool,
}

/// A method's work space for one run: its state vectors, stages and dense output.
pub trait Stepper {
    /// Interpolant over the last accepted step.
    type Dense<'a>: DenseStep
    where
        Self: 'a;
    /// Evaluates the derivative at the start, `f(t0, y0)`; returns whether it is finite.
    fn start(&mut self, rhs: &mut Rhs, t0: f64) -> bool;
    /// State at the start of the current step.
    fn y(&self) -> &[f64];
    /// Derivative at the start of the current step.
    fn f0(&self) -> &[f64];
    /// Solution of the last attempt.
    fn y_new(&self) -> &[f64];
    /// One attempt of size `h` from `(t, y)` ending at `t_new`: the solution into `y_new` and its
    /// error norm. Must be `#[inline(always)]` (it runs inside [`chainsweep_cpu::dispatch`]).
    fn attempt<F: MulAdd>(
        &mut self,
        rhs: &mut Rhs,
        t: f64,
        h: f64,
        t_new: f64,
        rtol: f64,
        atol: &[f64],
    ) -> Attempt;
    /// After an attempt passed the error test: what the dense output needs. Returns whether it is
    /// finite. Must be `#[inline(always)]`.
    fn prepare_dense<F: MulAdd>(&mut self, rhs: &mut Rhs, t: f64, h: f64, t_new: f64) -> bool;
    /// The step is final (not retaken for an event): what the next step needs. Returns whether it
    /// is finite.
    fn finish(&mut self, rhs: &mut Rhs, t_new: f64) -> bool;
    /// The interpolant over the attempt just made, `[t0, t1]` with `h = t1 − t0` as stepped.
    fn dense(&self, t0: f64, t1: f64, h: f64) -> Self::Dense<'_>;
    /// Moves to the end of the accepted step.
    fn advance(&mut self);
    /// The state at the start of the current step and its derivative there, for moving the
    /// method to another point without an attempt (a sliver across a switch).
    fn state_mut(&mut self) -> (&mut [f64], &mut [f64]);
    /// Whether the last accepted step was held by the method's stability boundary rather than its
    /// accuracy (Hairer's stiffness test), for methods that estimate it.
    fn on_stability_boundary(&self) -> Option<bool> {
        None
    }
}

/// Consecutive steps on the stability boundary that flag the problem as stiff (Hairer).
const STIFF_STEPS_TO_FLAG: u32 = 15;
/// Calm steps that clear the count.
const CALM_STEPS_TO_CLEAR: u32 = 6;
/// Consecutive step failures with NaN/inf or a singular matrix (each shrinking the step tenfold)
/// before giving up.
const MAX_NONFINITE_RETRIES: u32 = 6;

/// Hairer's stiffness test: stiff once [`STIFF_STEPS_TO_FLAG`] accepted steps sit on the
/// stability boundary without [`CALM_STEPS_TO_CLEAR`] calm ones in between; the step is then held
/// by stability, not by the tolerance.
#[derive(Default)]
struct StiffnessCount {
    stiff_steps: u32,
    calm_steps: u32,
}

impl StiffnessCount {
    /// Records whether an accepted step sat on the stability boundary; true when this step flags
    /// the problem as stiff.
    fn record(&mut self, on_boundary: bool) -> bool {
        if on_boundary {
            self.calm_steps = 0;
            self.stiff_steps += 1;
            self.stiff_steps == STIFF_STEPS_TO_FLAG
        } else {
            self.calm_steps += 1;
            if self.calm_steps == CALM_STEPS_TO_CLEAR {
                self.stiff_steps = 0;
            }
            false
        }
    }
}

/// [`Stepper::attempt`] as a dispatched kernel.
struct AttemptKernel<'a, 'b, S> {
    stepper: &'a mut S,
    rhs: &'a mut Rhs<'b>,
    t: f64,
    h: f64,
    t_new: f64,
    rtol: f64,
    atol: &'a [f64],
}

impl<S: Stepper> Kernel for AttemptKernel<'_, '_, S> {
    type Output = Attempt;
    #[inline(always)]
    fn run<F: MulAdd>(self) -> Attempt {
        self.stepper
            .attempt::<F>(self.rhs, self.t, self.h, self.t_new, self.rtol, self.atol)
    }
}

/// [`Stepper::prepare_dense`] as a dispatched kernel.
struct DenseKernel<'a, 'b, S> {
    stepper: &'a mut S,
    rhs: &'a mut Rhs<'b>,
    t: f64,
    h: f64,
    t_new: f64,
}

impl<S: Stepper> Kernel for DenseKernel<'_, '_, S> {
    type Output = bool;
    #[inline(always)]
    fn run<F: MulAdd>(self) -> bool {
        self.stepper
            .prepare_dense::<F>(self.rhs, self.t, self.h, self.t_new)
    }
}

impl<M: Method> Integrator for Adaptive<M> {
    fn name(&self) -> &'static str {
        M::NAME
    }

    /// Adaptive integration from `t0` to exactly `t_end`; see the methods for what each step
    /// evaluates.
    fn integrate(
        &self,
        sys: &mut dyn OdeSystemDyn,
        t0: f64,
        y0: &[f64],
        t_end: f64,
        max_steps: u64,
        obs: &mut dyn StepObserver,
    ) -> Result<IntegrationStats, IntegrateError> {
        let rtol = self.options.rtol;
        let atol = validate(M::NAME, self, sys, t0, y0, t_end)?;
        let h_max = self.options.max_step_s.unwrap_or(t_end - t0);
        let controller = M::CONTROLLER;
        let mut events = Events::new(
            sys,
            self.options.locate_events,
            self.options.predict_switches,
        );
        let mut w = M::stepper(y0, sys.n_pos());
        let mut sliver = Sliver::new(y0.len(), sys.n_pos());
        let mut rhs = Rhs::new(sys);
        let mut stats = IntegrationStats::default();

        obs.on_start(t0, y0);

        // A run that starts on a switch (a striker touching at t = 0): its first derivative is
        // the one on the side the motion enters, as every stage of the first step sees it.
        rhs.held = events.entering(y0);
        let started = w.start(&mut rhs, t0);
        rhs.held = None;
        if !started {
            return Err(IntegrateError::NonFinite { t: t0 });
        }

        let mut h = match self.h_init {
            Some(h0) => h0.min(h_max),
            None => {
                let mut scratch = vec![0.0; 2 * y0.len()];
                let (y1, f1) = scratch.split_at_mut(y0.len());
                initial_step(
                    M::ORDER,
                    &mut rhs,
                    t0,
                    w.y(),
                    w.f0(),
                    y1,
                    f1,
                    (rtol, &atol),
                    h_max,
                )
            }
        };

        let mut t = t0;
        // The last attempt failed: the next step may not grow beyond it.
        let mut reject = false;
        let mut nonfinite_streak = 0u32;
        let mut stiffness = StiffnessCount::default();
        let mut last_failure_nonfinite = false;

        loop {
            // Rejected attempts count: a run that only retries must end too.
            if stats.attempts() >= max_steps {
                return Err(IntegrateError::StepBudget { max_steps, t });
            }
            if h < 10.0 * f64::EPSILON * t.abs() || h < f64::MIN_POSITIVE {
                return Err(if last_failure_nonfinite {
                    IntegrateError::NonFinite { t }
                } else {
                    IntegrateError::StepTooSmall { t, h }
                });
            }
            // A switch predicted to cross within the step: end the step just past the crossing
            // rather than have the attempt fail on it or be retaken; one predicted just ahead is
            // crossed by a sliver, unless that fails its error test.
            h = match events.before_attempt(t, h, w.y(), w.f0()) {
                Next::Attempt(h) => h,
                Next::Sliver(eps) => {
                    let err = if t + eps < t_end {
                        sliver.attempt(&mut rhs, t, eps, w.y(), w.f0(), rtol, &atol)
                    } else {
                        f64::INFINITY
                    };
                    if err <= SLIVER_MAX_ERROR {
                        let (y, f) = w.state_mut();
                        sliver.commit(y, f);
                        stats.steps += 1;
                        h = events.on_sliver(h, &mut stats);
                        t = sliver.t_end();
                        // An accepted step: what failed before it is behind it.
                        reject = false;
                        nonfinite_streak = 0;
                        last_failure_nonfinite = false;
                        if obs.on_step(&sliver) == Control::Stop {
                            stats.rhs_evals = rhs.evals;
                            return Ok(stats);
                        }
                        continue;
                    }
                    events.sliver_failed()
                }
            };
            // The switch it lands on is held on its side before the crossing at the attempt's last
            // stage, evaluated a hair past it: the right-hand side stays smooth over the attempt.
            rhs.held = events.held();
            // Land exactly on t_end, stretching the step by up to 1 % rather than leaving a
            // sliver; not a step that lands on a held switch, which would then hold it over the
            // last hundredth of the step, past its crossing, where no test would see it.
            let stretch = if rhs.held.is_some() { 1.0 } else { 1.01 };
            let (h_step, t_new, last) = if t + stretch * h >= t_end {
                (t_end - t, t_end, true)
            } else {
                (h, t + h, false)
            };

            let attempt = dispatch(AttemptKernel {
                stepper: &mut w,
                rhs: &mut rhs,
                t,
                h: h_step,
                t_new,
                rtol,
                atol: &atol,
            });
            // A NaN error norm with a finite solution can only come from 0/0-type scaling; treat
            // it as "too large".
            let err = if attempt.err.is_nan() {
                f64::INFINITY
            } else {
                attempt.err
            };
            let mut nonfinite = !attempt.finite;
            let mut accepted = false;
            if !nonfinite && err <= 1.0 {
                nonfinite = !dispatch(DenseKernel {
                    stepper: &mut w,
                    rhs: &mut rhs,
                    t,
                    h: h_step,
                    t_new,
                });
                accepted = !nonfinite;
            }

            if accepted {
                let step = w.dense(t, t_new, h_step);
                if let Some(h_event) = events.retake(t, h_step, t_new, w.y(), &step, &mut stats) {
                    h = h_event;
                    continue;
                }
            }
            if accepted && !w.finish(&mut rhs, t_new) {
                nonfinite = true;
                accepted = false;
            }

            if nonfinite {
                stats.rejected += 1;
                nonfinite_streak += 1;
                last_failure_nonfinite = true;
                if nonfinite_streak > MAX_NONFINITE_RETRIES {
                    return Err(IntegrateError::NonFinite { t });
                }
                h = 0.1 * h_step;
                reject = true;
                events.on_failure();
                continue;
            }

            if accepted {
                events.on_accept(&mut stats);
                let mut h_new = controller.after_accept(h_step, err);
                stats.steps += 1;
                // A step that held a switch is left out of the stiffness test: its last stage and
                // the derivative at its end differ by the jump held off, which the test would read
                // as a large eigenvalue.
                if let Some(on_boundary) = w.on_stability_boundary().filter(|_| rhs.held.is_none())
                {
                    if stiffness.record(on_boundary) {
                        stats.stiffness_detections += 1;
                    }
                }
                nonfinite_streak = 0;
                last_failure_nonfinite = false;

                let control = obs.on_step(&w.dense(t, t_new, h_step));
                w.advance();
                t = t_new;
                if last || control == Control::Stop {
                    stats.rhs_evals = rhs.evals;
                    return Ok(stats);
                }
                h_new = h_new.min(h_max);
                if reject {
                    h_new = h_new.min(h_step);
                }
                reject = false;
                h = events.resume(h_new, h_max);
            } else {
                stats.rejected += 1;
                events.on_failure();
                last_failure_nonfinite = false;
                h = controller.after_reject(h_step, err);
                h = events.after_rejection(t, h_step, h, w.y(), w.f0(), w.y_new());
                reject = true;
            }
        }
    }
}

/// Checks the settings against the problem and returns the absolute tolerance of every
/// component, `atol * atol_scale[i]`.
fn validate<M>(
    name: &str,
    settings: &Adaptive<M>,
    sys: &dyn OdeSystemDyn,
    t0: f64,
    y0: &[f64],
    t_end: f64,
) -> Result<Vec<f64>, IntegrateError> {
    let bad = |s: String| Err(IntegrateError::InvalidSettings(format!("{name}: {s}")));
    let (rtol, atol) = (settings.options.rtol, settings.options.atol());
    if !(rtol.is_finite() && rtol > 0.0) {
        return bad(format!("rtol must be positive and finite, got {rtol}"));
    }
    if !(atol.is_finite() && atol >= 0.0) {
        return bad(format!("atol must be non-negative and finite, got {atol}"));
    }
    if !(t0.is_finite() && t_end.is_finite() && t_end > t0) {
        return bad(format!(
            "need finite t_end > t0, got t0 = {t0}, t_end = {t_end}"
        ));
    }
    for (what, value) in [
        ("h_max", settings.options.max_step_s),
        ("h_init", settings.h_init),
    ] {
        if let Some(h) = value {
            if !(h.is_finite() && h > 0.0) {
                return bad(format!("{what} must be positive and finite, got {h}"));
            }
        }
    }
    let n = 2 * sys.n_pos() + sys.n_quad();
    if y0.len() != n {
        return bad(format!(
            "y0 has length {} but the system has dimension {n}",
            y0.len()
        ));
    }
    if !all_finite(y0) {
        return bad("initial state is not finite".to_string());
    }
    match settings.atol_scale.as_deref() {
        None => Ok(vec![atol; n]),
        Some(scale) if scale.len() != n => bad(format!(
            "atol_scale has length {} but the system has dimension {n}",
            scale.len()
        )),
        Some(scale) if !scale.iter().all(|s| s.is_finite() && *s >= 0.0) => {
            bad("atol_scale entries must be finite and non-negative".to_string())
        }
        Some(scale) => Ok(scale.iter().map(|s| atol * s).collect()),
    }
}

/// Hairer's `HINIT` for a method of order `order`: a first step such that an explicit Euler step
/// changes the solution by about 1 % and `h^order max(|f|, |f'|) ≈ 0.01` in the tolerance-weighted
/// norm. One evaluation of `f` (into `f1`, with `y1` as scratch).
#[allow(clippy::too_many_arguments)]
fn initial_step(
    order: i32,
    rhs: &mut Rhs,
    t0: f64,
    y: &[f64],
    f0: &[f64],
    y1: &mut [f64],
    f1: &mut [f64],
    (rtol, atol): (f64, &[f64]),
    h_max: f64,
) -> f64 {
    let mut dnf = 0.0;
    let mut dny = 0.0;
    for ((yi, fi), ai) in y.iter().zip(f0).zip(atol) {
        let sk = ai + rtol * yi.abs();
        if sk > 0.0 {
            dnf += (fi / sk) * (fi / sk);
            dny += (yi / sk) * (yi / sk);
        }
    }
    let mut h = if dnf <= 1e-10 || dny <= 1e-10 {
        1e-6
    } else {
        (dny / dnf).sqrt() * 0.01
    };
    if !(h > 0.0 && h.is_finite()) {
        h = 1e-6;
    }
    h = h.min(h_max);
    for ((o, yi), fi) in y1.iter_mut().zip(y).zip(f0) {
        *o = yi + h * fi;
    }
    rhs.eval(t0 + h, y1, f1);
    let mut der2 = 0.0;
    for (((yi, a), b), ai) in y.iter().zip(f0).zip(f1.iter()).zip(atol) {
        let sk = ai + rtol * yi.abs();
        if sk > 0.0 {
            let d = (b - a) / sk;
            der2 += d * d;
        }
    }
    let der2 = der2.sqrt() / h;
    let der12 = der2.abs().max(dnf.sqrt());
    let h1 = if der12 <= 1e-15 || !der12.is_finite() {
        (h * 1e-3).max(1e-6)
    } else {
        (0.01 / der12).powf(1.0 / order as f64)
    };
    let h = (100.0 * h).min(h1).min(h_max);
    if h > 0.0 && h.is_finite() {
        h
    } else {
        1e-6_f64.min(h_max)
    }
}
