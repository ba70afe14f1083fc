//! Event location and switch prediction for the adaptive step loop: where the right-hand side is
//! not smooth (a contact opens or closes, the zero of a switching function), a step boundary is
//! put on the crossing. A step that passes the error test but crosses a switch is retaken to end
//! just past the earliest crossing, located on its dense output; with `predict_switches`, a step
//! also ends just past a crossing predicted at its start, and the step after an event resumes
//! from the step the motion before it allowed; a crossing predicted a tiny fraction of the step
//! ahead is crossed by a Taylor step instead (see [`super::sliver`]). An attempt that lands on a
//! switch holds it on its side before the crossing for its last stage (see
//! [`super::OdeSystem::hold_switch`]), so that a force that jumps there does not fail the
//! attempt. [`Events`] holds that state between steps; the loop asks it before an attempt, after
//! an accepted attempt, after a sliver, and after a failure.

use super::{DenseStep, IntegrationStats, OdeSystemDyn, Switch};

/// Fraction of the step before an event that the step after it starts from (`predict_switches`),
/// unless the crossing is into the side where the switch's terms vanish (a contact that opens),
/// after which the step before it is resumed whole ([`super::OdeSystem::vanishes_below`]).
/// Measured again on the Fig. 8 sweep with slivers (numerics version 5), for every event alike:
/// 0.7 and 1 took 7 % fewer right-hand sides at rtol 1e-8, 2 % at 1e-10, but the largest F21/F4
/// error at 1e-10 grew from 2.7e-9 to 5.4e-9 and 4.4e-9 (and at 1e-8 moved from 3.7e-7 to 3.2e-7
/// and 4.5e-7). Whole after openings only (numerics version 6): 6–7 % fewer right-hand sides at
/// rtol 1e-8 … 1e-10, the largest errors 2.2e-7 / 3.7e-7 → 1.8e-7 / 3.0e-7 (μ = 0 / 6 kg/s) at
/// 1e-8, 2.8e-8 / 4.6e-8 → 3.1e-8 / 4.0e-8 at 1e-9, 2.6e-9 / 2.7e-9 → 2.8e-9 / 2.8e-9 at 1e-10.
/// Past closings too, after that: 0.7 took 2.2 % fewer right-hand sides at 1e-8 but 1.4 % more at
/// 1e-10, 1 as many at 1e-8 and 4.4 % more at 1e-10, the largest 1e-10 errors 1.3× and 1.6×.
const RESUME_FRACTION: f64 = 0.5;
/// Predicted crossings closer than this fraction of the step are grazing (a contact touching at
/// its turning point): the step is not shortened to them (`predict_switches`).
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
/// Predicted crossings closer than this fraction of the step (and not grazing, above) are
/// crossed by a Taylor step rather than an attempt of the method
/// (`predict_switches`; see [`super::sliver`]). Most are the crossing a landing step aimed at a
/// hair too early, a ten-thousandth of the step ahead (measured on the Fig. 8 sweep: nine in ten
/// between 3e-6 and 7e-4 of the landing step); the Taylor step's own error test decides.
const SLIVER_FRACTION: f64 = 1e-3;

/// What the step loop does next from the current point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Next {
    /// An attempt of the method of this size.
    Attempt(f64),
    /// A Taylor step of this size, across a crossing just ahead ([`super::sliver`]); if it fails
    /// its error test, [`Events::sliver_failed`] gives the attempt to make instead.
    Sliver(f64),
}
/// The switches of a run and what event location carries from one step to the next.
pub(super) struct Events {
    /// The switching functions located (none when event location is off).
    switches: Vec<Switch>,
    /// How many leading switches are contacts between adjacent positions.
    adjacent: usize,
    /// Number of positions of the system.
    n_pos: usize,
    /// `predict_switches` is on and there is something to predict.
    predict: bool,
    /// The current attempt ends on a located event: accept it even if it still crosses one.
    landing: bool,
    /// The step the smooth stretch before an event allowed, to resume from once the step that
    /// lands on the event is accepted (`predict_switches`).
    resume_h: Option<f64>,
    /// The fraction of `resume_h` to resume from, set by the event the last accepted step landed
    /// on ([`Events::fraction_past`]).
    resume_fraction: f64,
    /// For each switch, whether its terms vanish on its negative side
    /// ([`super::OdeSystem::vanishes_below`]).
    vanishes_below: Vec<bool>,
    /// The current attempt was shortened to a predicted crossing.
    predicted: bool,
    /// How many consecutive accepted steps ended on events (predicted or located).
    streak: u32,
    /// The switch the current attempt lands on, and its side before the crossing.
    held: Option<(usize, bool)>,
    /// The switch a rejected attempt crossed, predicted for the next try.
    aimed: Option<(usize, bool)>,
    /// The sliver proposed (the step that ends just past its crossing, the switch and its side
    /// before it) and the step the controller wanted.
    sliver: Option<(f64, usize, bool, f64)>,
}

impl Events {
    /// The events of a run of `sys`: its switches when `locate`, predicted ahead when `predict`.
    pub(super) fn new(sys: &dyn OdeSystemDyn, locate: bool, predict: bool) -> Self {
        let switches: Vec<Switch> = if locate {
            sys.switches().to_vec()
        } else {
            Vec::new()
        };
        let n_pos = sys.n_pos();
        let vanishes_below = (0..switches.len()).map(|k| sys.vanishes_below(k)).collect();
        Events {
            adjacent: adjacent_pairs(&switches, n_pos),
            predict: predict && !switches.is_empty(),
            switches,
            n_pos,
            landing: false,
            resume_h: None,
            resume_fraction: RESUME_FRACTION,
            vanishes_below,
            predicted: false,
            streak: 0,
            held: None,
            aimed: None,
            sliver: None,
        }
    }

    /// What to do from `(t, y)` with derivative `f0`, given the step `h` the controller wants:
    /// an attempt shortened to end just past a switch crossing predicted within it, or a sliver
    /// across a crossing predicted just ahead.
    ///
    /// Anti-trap rule: not after [`MAX_EVENT_STREAK`] consecutive event steps. Each predicted
    /// landing resumes from half the step before it, so endless consecutive predicted landings
    /// on a grazing contact (value and slope both near zero, a crossing predicted again at every
    /// step) would halve the step without end; with the streak bounded, every streak is followed
    /// by plain event location until an ordinary step, whose size only the error test governs,
    /// is accepted. Slivers count in the streak.
    pub(super) fn before_attempt(&mut self, t: f64, h: f64, y: &[f64], f0: &[f64]) -> Next {
        if self.landing {
            return Next::Attempt(h);
        }
        if !(self.predict && self.streak < MAX_EVENT_STREAK) {
            self.held = self.aimed.take();
            return Next::Attempt(h);
        }
        let Some((tau, switch, positive)) =
            crossing_ahead(&self.switches, self.adjacent, self.n_pos, y, f0, h)
        else {
            self.held = self.aimed.take();
            return Next::Attempt(h);
        };
        // Grazing crossings are taken inside whole steps; the located-event path handles them.
        let h_event = (tau >= MIN_PREDICTED_FRACTION * h)
            .then(|| event_step(t, h, tau, h))
            .flatten();
        match h_event {
            Some(eps) if tau < SLIVER_FRACTION * h => {
                self.sliver = Some((eps, switch, positive, h));
                Next::Sliver(eps)
            }
            Some(h_event) => Next::Attempt(self.land(h, h_event, switch, positive)),
            None => {
                self.held = self.aimed.take();
                Next::Attempt(h)
            }
        }
    }

    /// The attempt to make instead of a sliver that failed its error test (or would pass the
    /// run's end): the predicted landing on its crossing.
    pub(super) fn sliver_failed(&mut self) -> f64 {
        let (h_event, switch, positive, h) = self.sliver.take().expect("a sliver was proposed");
        self.land(h, h_event, switch, positive)
    }

    /// A sliver was taken, instead of an attempt of the controller's `h`: it ends on an event,
    /// in the streak of event steps, and the step after it, the first past the crossing, starts
    /// from the fraction of `h` the step after a landing on that crossing would
    /// ([`Events::fraction_past`], [`Events::resume`]). A switch aimed at after a rejection is
    /// not aimed at any more: the step after the sliver is not the one that lands on it, and the
    /// crossing the rejected attempt met is most often the one the sliver has just crossed, whose
    /// held side would be the side it left.
    ///
    /// Measured on the Fig. 8 sweep at rtol 1e-8 / 1e-9 / 1e-10: going on with `h` itself takes
    /// 5 %, 4 % and 1 % fewer right-hand sides but its F21/F4 errors grow 1.1×, 1.4× and 2×;
    /// with half of it they are those of a full attempt over the sliver, to the digits printed
    /// (numerics version 5, before the step after an opening went on whole).
    pub(super) fn on_sliver(&mut self, h: f64, stats: &mut IntegrationStats) -> f64 {
        let (_, switch, positive, _) = self.sliver.take().expect("a sliver was proposed");
        self.aimed = None;
        stats.events += 1;
        self.streak += 1;
        self.fraction_past((switch, positive)) * h
    }

    /// The fraction of the step before a crossing of `switch` from its side `positive` that the
    /// step after it starts from: all of it past a crossing into the side where the switch's
    /// terms vanish (a contact that opens: nothing starts there, and the motion is as smooth as
    /// before it), [`RESUME_FRACTION`] past any other (a contact that closes: its force grows like
    /// δ^{3/2}, and the error estimate of a full step just past it falls short of its error).
    fn fraction_past(&self, (switch, positive): (usize, bool)) -> f64 {
        if positive && self.vanishes_below[switch] {
            1.0
        } else {
            RESUME_FRACTION
        }
    }

    /// An attempt of `h_event` that lands on a predicted crossing of `switch`, from its side
    /// `positive`, instead of the controller's `h`.
    fn land(&mut self, h: f64, h_event: f64, switch: usize, positive: bool) -> f64 {
        self.aimed = None;
        self.resume_h = Some(h);
        self.predicted = true;
        self.held = Some((switch, positive));
        h_event
    }

    /// After an attempt of size `h_step` from `(t, y_start)` to `t_new` passed the error test,
    /// with its interpolant `step`: the step to retake it with when it crosses a switch early
    /// enough to land on, counted as a rejected attempt (and a located event).
    pub(super) fn retake<S: DenseStep + ?Sized>(
        &mut self,
        t: f64,
        h_step: f64,
        t_new: f64,
        y_start: &[f64],
        step: &S,
        stats: &mut IntegrationStats,
    ) -> Option<f64> {
        if self.landing || self.switches.is_empty() {
            return None;
        }
        // With prediction, most accepted steps end just past a predicted crossing, which needs
        // no retake: only a crossing early enough for `event_step` to act on is located (the
        // plain event location looks over the whole step, as it always has).
        let horizon = if self.predict {
            t + h_step * ((1.0 - EVENT_MARGIN) / (1.0 + EVENT_MARGIN))
        } else {
            t_new
        };
        let (t_event, switch, positive) =
            earliest_event(&self.switches, self.adjacent, y_start, step, horizon)?;
        let h_event = event_step(t, h_step, t_event - t, h_step)?;
        self.held = Some((switch, positive));
        stats.rejected += 1;
        stats.events += u64::from(!self.predicted);
        self.predicted = false;
        self.landing = true;
        // This attempt passed the error test: the event does not change the step the smooth
        // motion allows. Not at the end of a streak of events (the anti-trap rule): there the
        // controller regrows the step from the landing step.
        if self.predict && self.streak < MAX_EVENT_STREAK {
            self.resume_h = Some(self.resume_h.map_or(h_step, |r| r.max(h_step)));
        }
        Some(h_event)
    }

    /// The switch the current attempt lands on, and its side before the crossing.
    pub(super) fn held(&self) -> Option<(usize, bool)> {
        self.held
    }

    /// A switch on positions exactly at zero at the start of a run (a striker touching at
    /// t = 0) and moving off it: the side it enters, where the first derivative is taken.
    pub(super) fn entering(&self, y: &[f64]) -> Option<(usize, bool)> {
        let n = self.n_pos;
        self.switches.iter().enumerate().find_map(|(k, sw)| {
            let on_positions = sw.plus < n && sw.minus.map_or(true, |m| m < n);
            if !on_positions || sw.value(|i| y[i]) != 0.0 {
                return None;
            }
            let rate = sw.rate(|i| y[n + i]);
            (rate != 0.0).then_some((k, rate > 0.0))
        })
    }

    /// The attempt failed (error test or non-finite values): no landing, nothing to resume from.
    pub(super) fn on_failure(&mut self) {
        self.landing = false;
        self.held = None;
        self.resume_h = None;
        self.predicted = false;
    }

    /// The step to try after a rejected attempt of size `h_step` from `(t, y)` (derivative
    /// `f0`, solution `y_new`), given the controller's `h`: a step that fails because it crosses
    /// a switch (a re-collision, say) would shrink by at most the controller's factor per try;
    /// the next try aims at the predicted crossing instead.
    pub(super) fn after_rejection(
        &mut self,
        t: f64,
        h_step: f64,
        h: f64,
        y: &[f64],
        f0: &[f64],
        y_new: &[f64],
    ) -> f64 {
        if self.switches.is_empty() {
            return h;
        }
        let Some((tau, switch, positive)) = predicted_event(&self.switches, y, f0, y_new, h_step)
        else {
            return h;
        };
        match event_step(t, h_step, tau, h) {
            Some(h_event) => {
                self.aimed = Some((switch, positive));
                h_event
            }
            None => h,
        }
    }

    /// The attempt was accepted: counts a predicted event, and the streak of steps ending on
    /// events.
    pub(super) fn on_accept(&mut self, stats: &mut IntegrationStats) {
        if self.predicted {
            stats.events += 1;
        }
        self.streak = if self.predicted || self.landing {
            self.streak + 1
        } else {
            0
        };
        self.predicted = false;
        self.landing = false;
        self.resume_fraction = self
            .held
            .take()
            .map_or(RESUME_FRACTION, |held| self.fraction_past(held));
    }

    /// The step after an accepted one, given the controller's `h`: after landing on an event, go
    /// on with a step near the one the motion before it allowed, not with the controller's
    /// growth from a short landing step (which would take a handful of steps to recover, at
    /// every contact that opens or closes): the whole of it past an opening, half of it past a
    /// closing ([`Events::fraction_past`]).
    pub(super) fn resume(&mut self, h: f64, h_max: f64) -> f64 {
        match self.resume_h.take() {
            Some(r) => h.max((self.resume_fraction * r).min(h_max)),
            None => h,
        }
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
) -> Option<(f64, usize, bool)> {
    let (t0, t1) = (step.t_start(), step.t_end());
    let y_end = step.y_end();
    let mut earliest: Option<(f64, usize, bool)> = None;
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
        .flat_map(|k0| k0..k0 + 8)
        .chain(full..switches.len());
    for k in &mut candidates {
        let sw = &switches[k];
        let g0 = sw.value(|i| y_start[i]);
        let g1 = sw.value(|i| y_end[i]);
        if !changes_sign(g0, g1) {
            continue;
        }
        let g = |t: f64| sw.value(|i| step.eval_component(t, i));
        let (mut a, mut b) = (t0, earliest.map_or(horizon, |e| e.0));
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
        earliest = Some((b, k, g0 > 0.0));
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
) -> Option<(f64, usize, bool)> {
    let mut earliest: Option<(f64, usize, bool)> = None;
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
        let (mut g0s, mut bs, mut cs, mut nears) = ([0.0; 8], [0.0; 8], [0.0; 8], [false; 8]);
        let mut near = false;
        for j in 0..8 {
            // The same values `pair` gives, kept for the lanes looked at below.
            (g0s[j], bs[j], cs[j]) = (
                xs[j] - xs[j + 1],
                vs[j] - vs[j + 1],
                0.5 * (as_[j] - as_[j + 1]),
            );
            nears[j] = !far(g0s[j], bs[j], cs[j]);
            near |= nears[j];
        }
        if near {
            for j in (0..8).filter(|&j| nears[j]) {
                let (g0, b, c) = (g0s[j], bs[j], cs[j]);
                if let Some(r) = quadratic_crossing(g0, b, c, earliest.map_or(h, |e| e.0)) {
                    earliest = Some((r, k0 + j, g0 > 0.0));
                }
            }
        }
    }
    for k in full..adjacent {
        let (g0, b, c) = pair(k);
        if !far(g0, b, c) {
            if let Some(r) = quadratic_crossing(g0, b, c, earliest.map_or(h, |e| e.0)) {
                earliest = Some((r, k, g0 > 0.0));
            }
        }
    }
    for (k, sw) in switches.iter().enumerate().skip(adjacent) {
        let p = sw.plus;
        // Value, slope and half the curvature (for switches on positions).
        let (g0, b, c) = match sw.minus {
            Some(m) if p < n_pos && m < n_pos => (x[p] - x[m], v[p] - v[m], 0.5 * (a[p] - a[m])),
            Some(m) => (y[p] - y[m], f[p] - f[m], 0.0),
            None if p < n_pos => (x[p], v[p], 0.5 * a[p]),
            None => (y[p], f[p], 0.0),
        };
        let g0 = g0 + sw.offset;
        if !far(g0, b, c) {
            if let Some(r) = quadratic_crossing(g0, b, c, earliest.map_or(h, |e| e.0)) {
                earliest = Some((r, k, g0 > 0.0));
            }
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
        .take_while(|(k, sw)| {
            sw.plus == *k && sw.minus == Some(k + 1) && sw.offset == 0.0 && k + 1 < n_pos
        })
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
fn predicted_event(
    switches: &[Switch],
    y0: &[f64],
    f0: &[f64],
    y1: &[f64],
    h: f64,
) -> Option<(f64, usize, bool)> {
    let mut earliest: Option<(f64, usize, bool)> = None;
    for (k, sw) in switches.iter().enumerate() {
        let g0 = sw.value(|i| y0[i]);
        let g1 = sw.value(|i| y1[i]);
        if g0 == 0.0 || (g0 > 0.0) == (g1 > 0.0) || !g1.is_finite() {
            continue;
        }
        // g(s) = g0 + b s + c s², s in [0, 1].
        let b = sw.rate(|i| f0[i]) * h;
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
        if earliest.map_or(true, |e| tau < e.0) {
            earliest = Some((tau, k, g0 > 0.0));
        }
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

#[cfg(test)]
mod tests {
    use super::{Events, Next, RESUME_FRACTION};
    use crate::chain::model::{Chain, ChainSpec, PhysicsSpec};
    use crate::integrate::IntegrationStats;
    use crate::motion::system::ChainSystem;
    use crate::problems::PushedFall;

    /// A 0.55 chain at rest but for contact 1, whose overlap `overlap` (positive: compressed)
    /// changes at `rate`, every other contact compressed by 1 mm and not moving: the system, the
    /// state and its derivative (no accelerations).
    fn one_contact_moving(
        overlap: f64,
        rate: f64,
    ) -> (ChainSystem<true, true, true, false>, Vec<f64>, Vec<f64>) {
        let physics = PhysicsSpec {
            damping_kg_s: 6.0,
            ..PhysicsSpec::default()
        };
        let chain = Chain::build(&ChainSpec::chain_055(4), &physics).unwrap();
        let sys = ChainSystem::<true, true, true, false>::new(&chain);
        let n = chain.n_particles();
        let mut y = chain.initial_state(0.0);
        for c in 0..n - 1 {
            y[c + 1] = y[c] - if c == 1 { overlap } else { 1e-3 };
            y[n + c + 1] = if c >= 1 { -rate } else { 0.0 };
        }
        let mut f0 = vec![0.0; y.len()];
        f0[..n].copy_from_slice(&y[n..2 * n]);
        (sys, y, f0)
    }

    /// The step after landing on the crossing predicted at 0.4, from its side `held`, given a
    /// controller step of 1 before it and a short one after it.
    fn steps_after(events: &mut Events, y: &[f64], f0: &[f64], held: (usize, bool)) -> f64 {
        let mut stats = IntegrationStats::default();
        match events.before_attempt(0.0, 1.0, y, f0) {
            Next::Attempt(h) => assert!((h - 0.4).abs() < 1e-3, "lands at 0.4, not {h}"),
            other => panic!("a landing, not {other:?}"),
        }
        assert_eq!(events.held(), Some(held));
        events.on_accept(&mut stats);
        events.resume(1e-3, 10.0)
    }

    /// Past a contact that opens the step before it is resumed whole; past one that closes, half
    /// of it; past a switch whose terms do not vanish on its negative side, half of it too. A
    /// sliver across the crossing is followed by the same step.
    #[test]
    fn the_step_after_an_opening_goes_on_whole_after_a_closing_from_half() {
        for (opening, expected) in [(true, 1.0), (false, RESUME_FRACTION)] {
            let sign = if opening { 1.0 } else { -1.0 };
            // Overlap ±1e-6 m, crossing zero at t = 0.4 at 2.5e-6 m per unit time.
            let (sys, y, f0) = one_contact_moving(sign * 1e-6, -sign * 2.5e-6);
            let mut events = Events::new(&sys, true, true);
            let resumed = steps_after(&mut events, &y, &f0, (1, opening));
            assert_eq!(resumed, expected, "opening: {opening}");

            // A crossing 4e-5 of the step ahead: a sliver.
            let (sys, y, f0) = one_contact_moving(sign * 1e-10, -sign * 2.5e-6);
            let mut events = Events::new(&sys, true, true);
            let Next::Sliver(eps) = events.before_attempt(0.0, 1.0, &y, &f0) else {
                panic!("a sliver");
            };
            assert!(
                (eps - 4e-5).abs() < 1e-8,
                "the sliver ends past the crossing: {eps}"
            );
            let mut stats = IntegrationStats::default();
            assert_eq!(
                events.on_sliver(1.0, &mut stats),
                expected,
                "opening: {opening}"
            );
        }

        // The floor of the pushed fall acts below its switch, not above: leaving the positive side
        // starts its force, and the step after resumes from half.
        let sys = PushedFall::new(0.0, 1e6);
        let (y, f0) = ([1e-6, -2.5e-6], [-2.5e-6, 0.0]);
        let mut events = Events::new(&sys, true, true);
        assert_eq!(
            steps_after(&mut events, &y, &f0, (0, true)),
            RESUME_FRACTION
        );
    }
}
