//! The adaptive-integrator core shared by DOP853 and ROS34PW2: one options type, one step loop
//! with one step-size controller, the handling of non-finite attempts, the stiffness count, and the
//! location of the switches (contacts opening and closing) that a step crosses. A method brings
//! only what is its own ([`Method`], [`Stepper`]): its tableau, its attempt (the stages, the
//! solution and the error norm) and its dense output. (diffsol's model: one Runge–Kutta core
//! shared by its methods.)
//!
//! The stage arithmetic runs through [`chainsweep_cpu::dispatch`], compiled for the CPU's vector
//! instructions and fused multiply-add.

use chainsweep_cpu::{dispatch, Kernel, MulAdd};

use super::{
    all_finite, Control, DenseStep, IntegrateError, IntegrationStats, Integrator, OdeSystemDyn,
    StepObserver, Switch, Tridiagonal,
};

/// Settings of an adaptive method: the same for every method, in a scene's `integrator` block and
/// in the integrators.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
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
    evals: u64,
}

impl<'a> Rhs<'a> {
    fn new(sys: &'a mut dyn OdeSystemDyn) -> Self {
        Rhs { sys, evals: 0 }
    }

    /// `dy = f(t, y)`.
    #[inline]
    pub fn eval(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        self.evals += 1;
        self.sys.rhs(t, y, dy);
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
    /// Whether the last accepted step was held by the method's stability boundary rather than its
    /// accuracy (Hairer's stiffness test), for methods that estimate it.
    fn on_stability_boundary(&self) -> Option<bool> {
        None
    }
}

/// Fraction of the step before an event that the step after it starts from (`predict_switches`).
const RESUME_FRACTION: f64 = 0.5;
/// Predicted crossings closer than this fraction of the step are slivers (grazing contacts): the
/// step is not shortened to them (`predict_switches`).
const MIN_PREDICTED_FRACTION: f64 = 1e-9;
/// Consecutive accepted steps that end on events (predicted or located) after which prediction
/// and the resume rule pause until an ordinary step is accepted (`predict_switches`): the
/// anti-trap rule. Each predicted landing may halve the step, so a streak shrinks it by at most
/// 2^-16; the steps after it are those of the plain event location, whose controller regrows
/// the step from the landing step. Measured on the reference run (rtol 5e-8): 9 240 right-hand
/// sides with 16 (as many as with no bound, which traps on the grazing contact of
/// tests/dynamics.rs), 9 520 with 8, 9 999 with 4, 18 886 with 1.
const MAX_EVENT_STREAK: u32 = 16;
/// How far past a crossing a step that lands on it ends, and how much shorter than the step it
/// replaces it must be, relative.
const EVENT_MARGIN: f64 = 1e-6;
/// Consecutive steps on the stability boundary that flag the problem as stiff (Hairer).
const STIFF_STEPS_TO_FLAG: u32 = 15;
/// Calm steps that clear the count.
const CALM_STEPS_TO_CLEAR: u32 = 6;
/// Consecutive step failures with NaN/inf or a singular matrix (each shrinking the step tenfold)
/// before giving up.
const MAX_NONFINITE_RETRIES: u32 = 6;

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
        let switches: Vec<Switch> = if self.options.locate_events {
            sys.switches().to_vec()
        } else {
            Vec::new()
        };
        let predict = self.options.predict_switches && !switches.is_empty();
        let n_pos = sys.n_pos();
        let adjacent = adjacent_pairs(&switches, n_pos);
        let mut w = M::stepper(y0, n_pos);
        let mut rhs = Rhs::new(sys);
        let mut stats = IntegrationStats::default();

        obs.on_start(t0, y0);

        if !w.start(&mut rhs, t0) {
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
        // The current attempt ends on a located event: accept it even if it still crosses one.
        let mut landing = false;
        // `predict_switches`: the step the smooth stretch before an event allowed, to resume from
        // once the step that lands on the event is accepted; whether the current attempt was
        // shortened to a predicted crossing; how many consecutive accepted steps ended on events
        // (predicted or located).
        let mut resume_h: Option<f64> = None;
        let mut predicted = false;
        let mut event_streak = 0u32;
        let (mut stiff_steps, mut calm_steps) = (0u32, 0u32);
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
            // rather than have the attempt fail on it or be retaken. Anti-trap rule: not after
            // MAX_EVENT_STREAK consecutive event steps. Each predicted landing resumes from half
            // the step before it, so endless consecutive predicted landings on a grazing contact
            // (value and slope both near zero, a crossing predicted again at every step) would
            // halve the step without end; with the streak bounded, every streak is followed by
            // plain event location until an ordinary step, whose size only the error test
            // governs, is accepted.
            if predict && !landing && event_streak < MAX_EVENT_STREAK {
                if let Some(tau) = crossing_ahead(&switches, adjacent, n_pos, w.y(), w.f0(), h) {
                    // Slivers are taken as whole steps; the located-event path handles them.
                    let h_event = (tau >= MIN_PREDICTED_FRACTION * h)
                        .then(|| event_step(t, h, tau, h))
                        .flatten();
                    if let Some(h_event) = h_event {
                        resume_h = Some(h);
                        h = h_event;
                        predicted = true;
                    }
                }
            }
            // Land exactly on t_end, stretching the step by up to 1 % rather than leaving a
            // sliver.
            let (h_step, t_new, last) = if t + 1.01 * h >= t_end {
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

            if accepted && !landing && !switches.is_empty() {
                // With prediction, most accepted steps end just past a predicted crossing, which
                // needs no retake: only a crossing early enough for `event_step` to act on is
                // located (the plain event location looks over the whole step, as it always has).
                let horizon = if predict {
                    t + h_step * ((1.0 - EVENT_MARGIN) / (1.0 + EVENT_MARGIN))
                } else {
                    t_new
                };
                let t_event = earliest_event(
                    &switches,
                    adjacent,
                    w.y(),
                    &w.dense(t, t_new, h_step),
                    horizon,
                );
                if let Some(h_event) = t_event.and_then(|te| event_step(t, h_step, te - t, h_step))
                {
                    stats.rejected += 1;
                    stats.events += u64::from(!predicted);
                    predicted = false;
                    landing = true;
                    // This attempt passed the error test: the event does not change the step the
                    // smooth motion allows. Not at the end of a streak of events (the anti-trap rule
                    // above): there the controller regrows the step from the landing step.
                    if predict && event_streak < MAX_EVENT_STREAK {
                        resume_h = Some(resume_h.map_or(h_step, |r| r.max(h_step)));
                    }
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
                landing = false;
                resume_h = None;
                predicted = false;
                continue;
            }

            if accepted {
                if predicted {
                    stats.events += 1;
                }
                event_streak = if predicted || landing {
                    event_streak + 1
                } else {
                    0
                };
                predicted = false;
                landing = false;
                let mut h_new = controller.after_accept(h_step, err);
                stats.steps += 1;
                // Hairer's test: stiff once 15 accepted steps sit on the stability boundary
                // without 6 calm ones in between; the step is then held by stability, not by the
                // tolerance.
                if let Some(stiff) = w.on_stability_boundary() {
                    if stiff {
                        calm_steps = 0;
                        stiff_steps += 1;
                        if stiff_steps == STIFF_STEPS_TO_FLAG {
                            stats.stiffness_detections += 1;
                        }
                    } else {
                        calm_steps += 1;
                        if calm_steps == CALM_STEPS_TO_CLEAR {
                            stiff_steps = 0;
                        }
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
                h = h_new;
                // After landing on an event, go on with a step near the one the motion before
                // it allowed, not with the controller's growth from a short landing step (which
                // would take a handful of steps to recover, at every contact that opens or
                // closes). Half of it: just after a contact closes the motion is not smooth (the
                // force grows like δ^{3/2}) and the error estimate of a full step there falls
                // short of its true error.
                if let Some(r) = resume_h.take() {
                    h = h.max((RESUME_FRACTION * r).min(h_max));
                }
            } else {
                stats.rejected += 1;
                landing = false;
                resume_h = None;
                predicted = false;
                last_failure_nonfinite = false;
                h = controller.after_reject(h_step, err);
                // A step that fails because it crosses a switch (a re-collision, say) would shrink
                // by at most the controller's factor per try; aim the next try at the predicted
                // crossing instead.
                if !switches.is_empty() {
                    let tau = predicted_event(&switches, w.y(), w.f0(), w.y_new(), h_step);
                    if let Some(h_event) = tau.and_then(|tau| event_step(t, h_step, tau, h)) {
                        h = h_event;
                    }
                }
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

/// Earliest zero of a switching function inside an accepted step that starts at `y_start`,
/// located on the step's dense output by the Illinois variant of regula falsi. `None` if no switch
/// changes sign over the step. A switch exactly at zero at the start (the striker touching at
/// t = 0, or a step that just landed on an event) is where the step begins, not an event in it.
/// Only zeros before `horizon` (at most the end of the step) are sought: a switch whose sign at
/// `horizon` is still that of the start is passed over without root finding.
fn earliest_event<S: DenseStep + ?Sized>(
    switches: &[Switch],
    adjacent: usize,
    y_start: &[f64],
    step: &S,
    horizon: f64,
) -> Option<f64> {
    let (t0, t1) = (step.t_start(), step.t_end());
    let y_end = step.y_end();
    let mut earliest: Option<f64> = None;
    let changes_sign = |g0: f64, g1: f64| (g0 != 0.0) & ((g0 > 0.0) != (g1 > 0.0));
    // The first `adjacent` switches are contacts between neighbours (`x[k] − x[k+1]`, see
    // `adjacent_pairs`): eight at a time, from contiguous slices, a vectorised test finds the
    // windows where one changes sign; only those are looked at switch by switch, in the same
    // order as the rest, so the result is the same.
    let full = adjacent - adjacent % 8;
    let mut candidates = (0..full)
        .step_by(8)
        .filter(|&k0| {
            let window = |s: &[f64]| -> [f64; 9] { s[k0..k0 + 9].try_into().expect("nine values") };
            let (a, b) = (window(y_start), window(y_end));
            let mut any = false;
            for j in 0..8 {
                any |= changes_sign(a[j] - a[j + 1], b[j] - b[j + 1]);
            }
            any
        })
        .flat_map(|k0| &switches[k0..k0 + 8])
        .chain(&switches[full..]);
    for sw in &mut candidates {
        let g0 = sw.value(|i| y_start[i]);
        let g1 = sw.value(|i| y_end[i]);
        if !changes_sign(g0, g1) {
            continue;
        }
        let g = |t: f64| sw.value(|i| step.eval_component(t, i));
        let (mut a, mut b) = (t0, earliest.unwrap_or(horizon));
        let (mut ga, mut gb) = (g0, g(b));
        if (ga > 0.0) == (gb > 0.0) {
            // This switch crosses only after an earlier event already found.
            continue;
        }
        let mut side = 0i8;
        for _ in 0..100 {
            let m = (a * gb - b * ga) / (gb - ga);
            let m = if m.is_finite() && m > a && m < b {
                m
            } else {
                0.5 * (a + b)
            };
            let gm = g(m);
            if (gm > 0.0) == (ga > 0.0) {
                a = m;
                ga = gm;
                if side == -1 {
                    gb *= 0.5;
                }
                side = -1;
            } else {
                b = m;
                gb = gm;
                if side == 1 {
                    ga *= 0.5;
                }
                side = 1;
            }
            if b - a <= 1e-12 * (t1 - t0) {
                break;
            }
        }
        earliest = Some(b);
    }
    earliest
}

/// Earliest zero of a switch within `h` of the current point, predicted by its Taylor polynomial
/// there: value and slope (`f`), and, for switches on positions (whose second derivative is the
/// acceleration, the state being `[x, v, q]` with `x' = v`), curvature. `None` if no switch is
/// predicted to change sign within `h`. Contacts open and close where their overlap crosses zero;
/// ending the step there spares an attempt that would fail on the kink, or be retaken.
fn crossing_ahead(
    switches: &[Switch],
    adjacent: usize,
    n_pos: usize,
    y: &[f64],
    f: &[f64],
    h: f64,
) -> Option<f64> {
    let mut earliest: Option<f64> = None;
    let (x, v, a) = (&y[..n_pos], &f[..n_pos], &f[n_pos..2 * n_pos]);
    // Most switches are far from zero: |g(s) − g0| ≤ (|b| + |c| s) s rules them out cheaply.
    let far = |g0: f64, b: f64, c: f64| (g0 == 0.0) | ((b.abs() + c.abs() * h) * h < g0.abs());
    // The first `adjacent` switches are contacts between neighbours, `x[k] − x[k+1]`: their
    // values, slopes and half curvatures come from contiguous slices, eight at a time, so that
    // ruling them out vectorises; the few near a crossing are looked at one by one.
    let pair = |k: usize| (x[k] - x[k + 1], v[k] - v[k + 1], 0.5 * (a[k] - a[k + 1]));
    let full = adjacent - adjacent % 8;
    for k0 in (0..full).step_by(8) {
        // k0 + 8 <= adjacent <= n_pos − 1, so nine positions are there.
        let window = |s: &[f64]| -> [f64; 9] { s[k0..k0 + 9].try_into().expect("nine values") };
        let (xs, vs, as_) = (window(x), window(v), window(a));
        let mut near = false;
        for j in 0..8 {
            let (g0, b) = (xs[j] - xs[j + 1], vs[j] - vs[j + 1]);
            near |= !far(g0, b, 0.5 * (as_[j] - as_[j + 1]));
        }
        if near {
            for k in k0..k0 + 8 {
                let (g0, b, c) = pair(k);
                if !far(g0, b, c) {
                    earliest = quadratic_crossing(g0, b, c, earliest.unwrap_or(h)).or(earliest);
                }
            }
        }
    }
    for k in full..adjacent {
        let (g0, b, c) = pair(k);
        if !far(g0, b, c) {
            earliest = quadratic_crossing(g0, b, c, earliest.unwrap_or(h)).or(earliest);
        }
    }
    for sw in &switches[adjacent..] {
        let p = sw.plus;
        // Value, slope and half the curvature (for switches on positions).
        let (g0, b, c) = match sw.minus {
            Some(m) if p < n_pos && m < n_pos => (x[p] - x[m], v[p] - v[m], 0.5 * (a[p] - a[m])),
            Some(m) => (y[p] - y[m], f[p] - f[m], 0.0),
            None if p < n_pos => (x[p], v[p], 0.5 * a[p]),
            None => (y[p], f[p], 0.0),
        };
        if !far(g0, b, c) {
            earliest = quadratic_crossing(g0, b, c, earliest.unwrap_or(h)).or(earliest);
        }
    }
    earliest
}

/// The first leading switches that are contacts between neighbouring positions,
/// `y[k] − y[k+1]` for switch `k` (the layout of a chain's contacts), counted once per run for
/// [`crossing_ahead`].
fn adjacent_pairs(switches: &[Switch], n_pos: usize) -> usize {
    switches
        .iter()
        .enumerate()
        .take_while(|(k, sw)| sw.plus == *k && sw.minus == Some(k + 1) && k + 1 < n_pos)
        .count()
}

/// Smallest root in `(0, limit]` of `g(s) = g0 + b s + c s²`, if it changes sign there.
#[inline]
fn quadratic_crossing(g0: f64, b: f64, c: f64, limit: f64) -> Option<f64> {
    if (b.abs() + c.abs() * limit) * limit < g0.abs() {
        return None;
    }
    // Does g change sign in (0, limit], at the end or at its extremum?
    let changes_sign = |s: f64| (g0 + s * (b + c * s) > 0.0) != (g0 > 0.0);
    let extremum = if c != 0.0 { -b / (2.0 * c) } else { f64::NAN };
    if !(changes_sign(limit) || (extremum > 0.0 && extremum < limit && changes_sign(extremum))) {
        return None;
    }
    // Its smallest positive root (the numerically stable pair of quadratic roots).
    let disc = b * b - 4.0 * c * g0;
    let root = if c == 0.0 {
        -g0 / b
    } else if disc < 0.0 {
        return None;
    } else {
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        let r1 = q / c;
        let r2 = if q != 0.0 { g0 / q } else { f64::NAN };
        [r1, r2]
            .into_iter()
            .filter(|r| r.is_finite() && *r > 0.0)
            .fold(f64::NAN, f64::min)
    };
    (root.is_finite() && root > 0.0 && root <= limit).then_some(root)
}

/// Earliest crossing of a switch over a rejected attempt of length `h`, predicted from the values
/// at both ends and the slope at the start (a quadratic in time); `None` if no switch changes sign.
fn predicted_event(switches: &[Switch], y0: &[f64], f0: &[f64], y1: &[f64], h: f64) -> Option<f64> {
    let mut earliest: Option<f64> = None;
    for sw in switches {
        let g0 = sw.value(|i| y0[i]);
        let g1 = sw.value(|i| y1[i]);
        if g0 == 0.0 || (g0 > 0.0) == (g1 > 0.0) || !g1.is_finite() {
            continue;
        }
        // g(s) = g0 + b s + c s², s in [0, 1].
        let b = sw.value(|i| f0[i]) * h;
        let c = g1 - g0 - b;
        let linear = g0 / (g0 - g1);
        let s = if c.abs() > 1e-12 * (g0.abs() + g1.abs()) {
            let disc = b * b - 4.0 * c * g0;
            if disc >= 0.0 {
                let q = -0.5 * (b + b.signum() * disc.sqrt());
                let roots = [q / c, if q != 0.0 { g0 / q } else { f64::NAN }];
                roots
                    .into_iter()
                    .filter(|r| r.is_finite() && *r > 0.0 && *r <= 1.0)
                    .fold(f64::NAN, f64::min)
            } else {
                linear
            }
        } else {
            linear
        };
        let tau = if s.is_finite() { s } else { linear } * h;
        earliest = Some(earliest.map_or(tau, |e: f64| e.min(tau)));
    }
    earliest
}

/// The step that ends just past a crossing `tau` after `t` (a hair past, so the next step starts
/// in the new regime), or `None` when it would be no shorter than `limit` or too short for
/// floating point to move the state: then the step is taken as it is.
fn event_step(t: f64, h_step: f64, tau: f64, limit: f64) -> Option<f64> {
    let h_event = tau * (1.0 + EVENT_MARGIN);
    (h_event < limit * (1.0 - EVENT_MARGIN) && h_event > 100.0 * f64::EPSILON * t.abs().max(h_step))
        .then_some(h_event)
}
