//! Peaks: the leading pulse and the record maximum of every probe, found on the summary samples
//! and located on the integrator's dense output.
//!
//! The samples (every `record.summary_interval_s`) decide *which* peak is which: when the leading
//! pulse arrives and when it has passed. Its value and time come from the dense output: in every
//! step whose samples or ends come near the largest value seen so far, the probe is maximised
//! over the step (a scan, then Brent's method around the scan's best point, [`maximise`]), so a
//! peak is the largest value of the integrated solution, as accurate as the integration and
//! independent of the sampling interval, whatever the signal's shape at its top (a smooth
//! maximum, or the kink where a plastic contact turns from loading to elastic unloading, which no
//! polynomial through samples fits).

/// Peak of a sampled signal: the best sample (which the pulse logic reads), how many samples have
/// followed it, and the largest value found on the dense output, with its time.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PeakWindow {
    /// The largest sample (`-∞` before any).
    pub best: f64,
    /// Its time.
    pub time: f64,
    /// How many samples after the best one have arrived (0..=2).
    pub after: usize,
    /// The largest value seen, a sample's or the dense output's (`-∞` before any).
    pub peak: f64,
    /// Its time.
    pub peak_time: f64,
}

impl PeakWindow {
    pub fn empty() -> Self {
        PeakWindow {
            best: f64::NEG_INFINITY,
            time: f64::NAN,
            after: 0,
            peak: f64::NEG_INFINITY,
            peak_time: f64::NAN,
        }
    }

    /// Offers a sample.
    #[inline]
    pub fn offer(&mut self, t: f64, s: f64) {
        if s > self.best {
            self.best = s;
            self.time = t;
            self.after = 0;
        } else if self.after < 2 && self.time.is_finite() {
            self.after += 1;
        }
        self.consider(t, s);
    }

    /// Offers a value of the dense output (or a sample): kept when larger than every one before.
    #[inline]
    pub fn consider(&mut self, t: f64, s: f64) {
        if s > self.peak {
            self.peak = s;
            self.peak_time = t;
        }
    }

    /// The peak `(value, time)`; NaN before any sample.
    pub fn located(&self) -> (f64, f64) {
        if self.peak_time.is_nan() {
            (f64::NAN, f64::NAN)
        } else {
            (self.peak, self.peak_time)
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum PulsePhase {
    Waiting,
    InPulse,
    Passed,
}

/// Per-probe on-the-fly tracker of the leading pulse and the record maximum.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PeakTracker {
    pub baseline: f64,
    arrival: f64,
    release_fraction: f64,
    pub phase: PulsePhase,
    pub leading: PeakWindow,
    pub record: PeakWindow,
    /// Time of the sample at which the leading pulse was seen to arrive, and of the one at which
    /// it was seen to have passed (NaN until then): the leading pulse's peak lies between the
    /// sample before the first and the second.
    pub arrived_at: f64,
    pub passed_at: f64,
}

impl PeakTracker {
    pub fn new(baseline: f64, arrival: f64, release_fraction: f64) -> Self {
        PeakTracker {
            baseline,
            arrival,
            release_fraction,
            phase: PulsePhase::Waiting,
            leading: PeakWindow::empty(),
            record: PeakWindow::empty(),
            arrived_at: f64::NAN,
            passed_at: f64::NAN,
        }
    }

    /// Whether samples no larger than `upper` change nothing this tracker records: its record
    /// maximum and the two samples after it are in (a sample replaces the maximum only when
    /// larger), and its leading pulse has passed or is not seen to arrive below `upper`.
    pub fn settled_below(&self, upper: f64) -> bool {
        let leading = match self.phase {
            PulsePhase::Passed => true,
            PulsePhase::Waiting => upper - self.baseline <= self.arrival,
            PulsePhase::InPulse => false,
        };
        self.may_settle() && upper <= self.record.best && leading
    }

    /// Whether some bound could settle this tracker ([`PeakTracker::settled_below`]): not while
    /// its leading pulse is in progress or its record maximum still takes the samples after it.
    pub fn may_settle(&self) -> bool {
        self.record.time.is_finite() && self.record.after >= 2 && self.phase != PulsePhase::InPulse
    }

    #[inline]
    pub fn sample(&mut self, t: f64, s: f64) {
        self.record.offer(t, s);
        match self.phase {
            PulsePhase::Waiting => {
                if s - self.baseline > self.arrival {
                    self.phase = PulsePhase::InPulse;
                    self.arrived_at = t;
                    self.leading.offer(t, s);
                }
            }
            PulsePhase::InPulse => {
                self.leading.offer(t, s);
                let peak = self.leading.best - self.baseline;
                if s - self.baseline < self.release_fraction * peak && self.leading.after >= 2 {
                    self.phase = PulsePhase::Passed;
                    self.passed_at = t;
                }
            }
            PulsePhase::Passed => {}
        }
    }

    /// Where in `[a, b]` (a step, up to the record's end) the leading pulse's peak may lie: from
    /// the sample before its arrival to the sample at which it had passed; `None` while it has not
    /// arrived or after it passed before `a`.
    pub fn leading_span(&self, a: f64, b: f64, interval: f64) -> Option<(f64, f64)> {
        if self.arrived_at.is_nan() || self.passed_at < a {
            return None;
        }
        let lo = a.max(self.arrived_at - interval);
        let hi = if self.passed_at.is_nan() {
            b
        } else {
            b.min(self.passed_at)
        };
        (lo <= hi).then_some((lo, hi))
    }
}

/// Most points of the scan that starts a maximisation over a step.
const SCAN_POINTS: usize = 64;

/// Where, as a fraction of the step from its end, a maximisation tells whether the signal rises
/// into an end of the step ([`maximise`]).
const END_PROBE: f64 = 1e-8;

/// The largest value of `f` over `[a, b]` and where it is, to `f`'s own rounding: a scan of
/// equally spaced points no further apart than `spacing` (at least 4 intervals, at most
/// [`SCAN_POINTS`]), then Brent's method (golden sections and parabolic steps, robust to a kink at
/// the top) on the two intervals around the scan's best point, until the bracket is within a few
/// ulps of the time. Ends included: a maximum at an end is found there, without Brent where the
/// signal rises into that end.
pub(super) fn maximise(a: f64, b: f64, spacing: f64, mut f: impl FnMut(f64) -> f64) -> (f64, f64) {
    maximise_batched(a, b, spacing, |times, values| {
        for (v, &t) in values.iter_mut().zip(times) {
            *v = f(t);
        }
    })
}

/// [`maximise`] of a signal evaluated by `eval(times, values)` (`values[r]` the signal at
/// `times[r]`), called once with every point of the scan (a method's interpolant can evaluate
/// several instants at once, [`crate::integrate::DenseStep::eval_components_at`]) and then with
/// one instant at a time. The same result as [`maximise`] of the same values.
pub(super) fn maximise_batched(
    a: f64,
    b: f64,
    spacing: f64,
    mut eval: impl FnMut(&[f64], &mut [f64]),
) -> (f64, f64) {
    if b <= a {
        let mut v = [0.0];
        eval(&[a], &mut v);
        return (v[0], a);
    }
    let intervals = (((b - a) / spacing).ceil() as usize).clamp(4, SCAN_POINTS - 1);
    let h = (b - a) / intervals as f64;
    let mut times = [0.0; SCAN_POINTS];
    for (j, t) in times.iter_mut().enumerate().take(intervals) {
        *t = a + j as f64 * h;
    }
    times[intervals] = b;
    let mut scanned = [0.0; SCAN_POINTS];
    eval(&times[..=intervals], &mut scanned[..=intervals]);
    let (mut best, mut best_t, mut best_j) = (f64::NEG_INFINITY, a, 0);
    let mut least = f64::INFINITY;
    for (j, &v) in scanned[..=intervals].iter().enumerate() {
        least = least.min(v);
        if v > best {
            (best, best_t, best_j) = (v, times[j], j);
        }
    }
    let mut f = |t: f64| {
        let mut v = [0.0];
        eval(&[t], &mut v);
        v[0]
    };
    // Constant over the scan (a probe before its pulse arrives, a contact at rest): Brent would
    // only walk its bracket down to rounding and find the same value.
    if least == best {
        return (best, best_t);
    }
    // The scan's best at an end of the step, the scan rising into that end over its last two
    // intervals and the signal rising, to rounding, over the hundred-millionth of the step next to
    // the end (two probes, since a method's interpolant need not meet the step's end value that
    // the end reads exactly): the end is the maximum, where Brent would only shrink its bracket
    // onto it by golden sections (some fifty evaluations, on every step of a pulse's rise and
    // fall and of a slow creep). A maximum inside the last interval passes this test only within
    // a hundred-millionth of the step of the end, or where the signal's slope there is below
    // rounding: within rounding of the end's value.
    let inside = END_PROBE * (b - a);
    if best_j == intervals && scanned[intervals - 2] <= scanned[intervals - 1] {
        let near = f(b - inside);
        if near <= best && f(b - 2.0 * inside) <= near {
            return (best, best_t);
        }
    }
    if best_j == 0 && scanned[2] <= scanned[1] {
        let near = f(a + inside);
        if near <= best && f(a + 2.0 * inside) <= near {
            return (best, best_t);
        }
    }
    let lo = times[best_j.saturating_sub(1)];
    let hi = times[(best_j + 1).min(intervals)];
    let (v, t) = brent_max(lo, hi, best_t, best, &mut f);
    if v > best {
        (v, t)
    } else {
        (best, best_t)
    }
}

/// Brent's localmin (Brent 1973, ch. 5) applied to `−f` on `[lo, hi]`, started at `x` with
/// `f(x) = fx`: the largest value found and where (to rounding, in at most 80 evaluations).
pub fn brent_max(
    mut lo: f64,
    mut hi: f64,
    x: f64,
    fx: f64,
    f: &mut impl FnMut(f64) -> f64,
) -> (f64, f64) {
    const GOLD: f64 = 0.381_966_011_250_105_1;
    const MAX_EVALUATIONS: usize = 80;
    let (mut x, mut w, mut v) = (x, x, x);
    let (mut fx, mut fw, mut fv) = (-fx, -fx, -fx);
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 0..MAX_EVALUATIONS {
        let m = 0.5 * (lo + hi);
        let tol = 4.0 * f64::EPSILON * x.abs().max((hi - lo).abs()) + f64::MIN_POSITIVE;
        let t2 = 2.0 * tol;
        if (x - m).abs() <= t2 - 0.5 * (hi - lo) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol {
            // A parabola through x, w and v.
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            } else {
                q = -q;
            }
            let r = e;
            e = d;
            if p.abs() < (0.5 * q * r).abs() && p > q * (lo - x) && p < q * (hi - x) {
                d = p / q;
                let u = x + d;
                if u - lo < t2 || hi - u < t2 {
                    d = if x < m { tol } else { -tol };
                }
                golden = false;
            }
        }
        if golden {
            e = if x < m { hi - x } else { lo - x };
            d = GOLD * e;
        }
        let u = if d.abs() >= tol {
            x + d
        } else if d > 0.0 {
            x + tol
        } else {
            x - tol
        };
        let fu = -f(u);
        if fu <= fx {
            if u < x {
                hi = x;
            } else {
                lo = x;
            }
            (v, fv, w, fw, x, fx) = (w, fw, x, fx, u, fu);
        } else {
            if u < x {
                lo = u;
            } else {
                hi = u;
            }
            if fu <= fw || w == x {
                (v, fv, w, fw) = (w, fw, u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    (-fx, x)
}

/// The largest value on `[0, h]` of the cubic Hermite interpolant of `(p0, m0)` at 0 and `(p1,
/// m1)` at `h` (values and derivatives): a cheap estimate of a smooth signal's maximum over a step
/// from its ends alone.
pub(super) fn hermite_max(h: f64, (p0, m0): (f64, f64), (p1, m1): (f64, f64)) -> f64 {
    // On s ∈ [0, 1]: H(s) = p0 h00 + h m0 h10 + p1 h01 + h m1 h11.
    let (a0, a1) = (m0 * h, m1 * h);
    let c3 = 2.0 * p0 + a0 - 2.0 * p1 + a1;
    let c2 = -3.0 * p0 - 2.0 * a0 + 3.0 * p1 - a1;
    let c1 = a0;
    let hs = |s: f64| p0 + s * (c1 + s * (c2 + s * c3));
    let mut best = p0.max(p1);
    // H'(s) = 3 c3 s² + 2 c2 s + c1.
    let (qa, qb, qc) = (3.0 * c3, 2.0 * c2, c1);
    let mut roots = [f64::NAN; 2];
    if qa.abs() < 1e-300 {
        if qb != 0.0 {
            roots[0] = -qc / qb;
        }
    } else {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc >= 0.0 {
            let sq = disc.sqrt();
            roots = [(-qb - sq) / (2.0 * qa), (-qb + sq) / (2.0 * qa)];
        }
    }
    for s in roots {
        if s > 0.0 && s < 1.0 {
            best = best.max(hs(s));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maxima_are_found_to_rounding_smooth_kinked_and_at_an_end() {
        // A smooth peak.
        let (v, t) = maximise(0.0, 1.0, 0.3, |t| 1.0 - (t - 0.3137).powi(2));
        assert!(
            (v - 1.0).abs() < 1e-15 && (t - 0.3137).abs() < 1e-7,
            "{v} {t}"
        );
        // A kink: rising at slope 2, falling at slope −7 (loading, then elastic unloading).
        let kink = |t: f64| {
            if t < 0.6180 {
                2.0 * t
            } else {
                2.0 * 0.6180 - 7.0 * (t - 0.6180)
            }
        };
        let (v, t) = maximise(0.0, 1.0, 0.25, kink);
        assert!(
            (v - 1.2360).abs() < 1e-13 && (t - 0.6180).abs() < 1e-13,
            "{v} {t}"
        );
        // Monotone: the end, from the scan and two probes inside it, either way round.
        let mut calls = 0;
        let (v, t) = maximise(2.0, 3.0, 0.1, |t| {
            calls += 1;
            t * t
        });
        assert_eq!((v, t, calls), (9.0, 3.0, 13));
        let (v, t) = maximise(2.0, 3.0, 0.1, |t| 1.0 / t);
        assert_eq!((v, t), (0.5, 2.0));
        // A peak just inside an end, falling into it: found inside, not at the end.
        for (peak, end) in [(0.9999, 1.0), (1e-4, 0.0)] {
            let (v, t) = maximise(0.0, 1.0, 0.1, |t| 1.0 - (t - peak).powi(2));
            assert!(
                v == 1.0 && (t - peak).abs() < 1e-7 && t != end,
                "{peak}: {v} {t}"
            );
        }
        // An end read exactly, above where the interpolant tends there but below a hump just
        // inside (a method's interpolant need not meet the step's end value): the hump.
        let (v, t) = maximise(0.0, 1.0, 0.1, |t| {
            if t == 1.0 {
                0.999
            } else {
                1.0 - 100.0 * (t - 0.995).powi(2)
            }
        });
        assert!(v == 1.0 && (t - 0.995).abs() < 1e-7, "{v} {t}");
        // Two humps in one interval: the higher.
        let (v, t) = maximise(0.0, 1.0, 0.05, |t| {
            (-(t - 0.2f64).powi(2) / 0.002).exp() + 1.1 * (-(t - 0.8f64).powi(2) / 0.002).exp()
        });
        assert!((v - 1.1).abs() < 1e-14 && (t - 0.8).abs() < 1e-7, "{v} {t}");
    }

    #[test]
    fn the_hermite_estimate_of_a_parabola_is_exact() {
        // p(t) = 1 − (t − 0.4)², h = 1: p(0) = 0.84, p'(0) = 0.8, p(1) = 0.64, p'(1) = −1.2.
        let m = hermite_max(1.0, (0.84, 0.8), (0.64, -1.2));
        assert!((m - 1.0).abs() < 1e-15, "{m}");
        assert_eq!(hermite_max(1.0, (0.0, 1.0), (1.0, 1.0)), 1.0);
    }
}
