//! A sliver across a switch: a step a tiny fraction of the step size long that ends just past a
//! predicted crossing, taken as one Taylor step rather than as an attempt of the method.
//!
//! Why: a step that lands on a predicted crossing ends where the quadratic prediction put it. That
//! prediction is exact only to its next order, so about as often as not the contact has not quite
//! crossed at the landing point: the crossing is then predicted again a ten-thousandth of the step
//! ahead, and a full attempt (all the stages of an eighth-order method, its error test and its
//! dense output) would be spent on that sliver. Over the Fig. 8 sweep that was one accepted step
//! in six. Over so short a stretch a Taylor step of the second-order system is far more accurate
//! than the tolerance asks: positions from their velocity and acceleration
//! (`x + ε v + ε²/2 a`), velocities and quadratures from their rate (`v + ε a`, `q + ε q'`), and
//! one evaluation of the right-hand side at its end, which is also the next step's first
//! derivative. Its error is estimated from the change of that derivative over the sliver and
//! bounded by a tenth of what an ordinary step may commit; a sliver that fails that bound is
//! taken as the method's attempt, as before.
//!
//! The interpolant over the sliver, for probes sampled inside it, is the cubic Hermite polynomial
//! through the state and its derivative at both ends.

use super::adaptive::Rhs;
use super::{all_finite, DenseStep};

/// Largest error norm a sliver is accepted with, in units of the tolerance an ordinary step is
/// accepted with: slivers are many (one step in six before they were taken this way), so each
/// commits at most a tenth of an ordinary step's error. Measured on the Fig. 8 sweep: accepting
/// them up to the full tolerance took 2–3 % fewer right-hand sides at rtol 1e-8 … 1e-10 but
/// doubled the F21/F4 error at 1e-9 and 1e-10 (a first-order step's error estimate is its error,
/// not a bound far above it).
pub(super) const SLIVER_MAX_ERROR: f64 = 0.1;

/// A Taylor step over a sliver and its interpolant: the state and derivative at both ends.
pub(super) struct Sliver {
    n_pos: usize,
    t0: f64,
    t1: f64,
    y0: Vec<f64>,
    f0: Vec<f64>,
    y1: Vec<f64>,
    f1: Vec<f64>,
}

impl Sliver {
    /// Work space for a system of dimension `dim` with `n_pos` positions.
    pub(super) fn new(dim: usize, n_pos: usize) -> Self {
        Sliver {
            n_pos,
            t0: 0.0,
            t1: 0.0,
            y0: vec![0.0; dim],
            f0: vec![0.0; dim],
            y1: vec![0.0; dim],
            f1: vec![0.0; dim],
        }
    }

    /// The Taylor step from `(t, y)` with derivative `f` to `t + eps`, and the derivative at its
    /// end (one evaluation of the right-hand side): returns its error norm (RMS over the
    /// components, each scaled by `atol[i] + rtol · max(|y[i]|, |y1[i]|)` as the methods' norms
    /// are), infinite when the result is not finite.
    ///
    /// The local error of the positions' update is `ε³/6 x'''`, estimated as `ε²/2 |a(ε) − a(0)|`
    /// (three times its size when the acceleration is smooth over the sliver); that of the
    /// velocities and quadratures is `ε²/2 y''`, estimated as `ε |f(ε) − f(0)|` (twice its size).
    /// The factors cover a force that jumps inside the sliver (a viscous term that starts where a
    /// contact closes), whose error the difference of the end derivatives measures in full only
    /// for a jump at the sliver's start.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn attempt(
        &mut self,
        rhs: &mut Rhs,
        t: f64,
        eps: f64,
        y: &[f64],
        f: &[f64],
        rtol: f64,
        atol: &[f64],
    ) -> f64 {
        let n = self.n_pos;
        let (x, v) = (&y[..n], &f[..n]);
        let a = &f[n..2 * n];
        for i in 0..n {
            self.y1[i] = x[i] + eps * (v[i] + 0.5 * eps * a[i]);
        }
        for i in n..y.len() {
            self.y1[i] = y[i] + eps * f[i];
        }
        self.t0 = t;
        self.t1 = t + eps;
        rhs.eval(self.t1, &self.y1, &mut self.f1);
        if !(all_finite(&self.y1) && all_finite(&self.f1)) {
            return f64::INFINITY;
        }
        let mut sum = 0.0;
        for i in 0..y.len() {
            let e = if i < n {
                0.5 * eps * eps * (self.f1[n + i] - f[n + i])
            } else {
                eps * (self.f1[i] - f[i])
            };
            let scale = atol[i] + rtol * y[i].abs().max(self.y1[i].abs());
            if scale > 0.0 {
                sum += (e / scale) * (e / scale);
            }
        }
        (sum / y.len() as f64).sqrt()
    }

    /// Moves the method's state `(y, f)` to the end of the sliver just attempted, keeping the
    /// start for the interpolant.
    pub(super) fn commit(&mut self, y: &mut [f64], f: &mut [f64]) {
        self.y0.copy_from_slice(y);
        self.f0.copy_from_slice(f);
        y.copy_from_slice(&self.y1);
        f.copy_from_slice(&self.f1);
    }
}

impl DenseStep for Sliver {
    fn t_start(&self) -> f64 {
        self.t0
    }
    fn t_end(&self) -> f64 {
        self.t1
    }
    fn y_end(&self) -> &[f64] {
        &self.y1
    }
    fn eval_component(&self, t: f64, i: usize) -> f64 {
        if t == self.t1 {
            return self.y1[i];
        }
        let h = self.t1 - self.t0;
        let s = (t - self.t0) / h;
        let r = 1.0 - s;
        let (h00, h10) = ((1.0 + 2.0 * s) * r * r, s * r * r);
        let (h01, h11) = (s * s * (3.0 - 2.0 * s), -s * s * r);
        h00 * self.y0[i] + h10 * h * self.f0[i] + h01 * self.y1[i] + h11 * h * self.f1[i]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::{AdaptiveOptions, Control, Dop853, Integrator, OdeSystem, StepObserver};
    use crate::problems::{ConstantJerk, PushedFall};
    use std::cell::Cell;
    use std::rc::Rc;

    #[test]
    fn a_sliver_is_a_taylor_step_whose_error_it_bounds() {
        let mut sys = ConstantJerk { c0: 2.0, c1: 6.0 };
        let (x0, v0) = (0.5, -1.0);
        let y = [x0, v0, 0.0];
        let mut f = [0.0; 3];
        sys.rhs(0.0, &y, &mut f);
        let mut rhs = Rhs::new(&mut sys);
        let mut sliver = Sliver::new(3, 1);
        let eps = 1e-3;
        let (rtol, atol) = (1e-9, [1e-12; 3]);
        let err = sliver.attempt(&mut rhs, 0.0, eps, &y, &f, rtol, &atol);
        assert_eq!(rhs.evals, 1);
        // Exact: x = x0 + v0 t + t² + t³, v = v0 + 2t + 3t², q = x0 t + v0 t²/2 + t³/3 + t⁴/4.
        let exact = [
            x0 + v0 * eps + eps * eps + eps.powi(3),
            v0 + 2.0 * eps + 3.0 * eps * eps,
            x0 * eps + 0.5 * v0 * eps * eps + eps.powi(3) / 3.0 + eps.powi(4) / 4.0,
        ];
        // Positions miss only the jerk's ε³ (estimated three times over), velocities 3ε² (twice
        // over), the quadrature the rest of its Taylor series.
        let true_err = [
            eps.powi(3),
            3.0 * eps * eps,
            (0.5 * v0 * eps * eps + eps.powi(3) / 3.0 + eps.powi(4) / 4.0).abs(),
        ];
        for i in 0..3 {
            let miss = (exact[i] - sliver.y1[i]).abs();
            assert!(
                (miss - true_err[i]).abs() < 1e-6 * true_err[i],
                "component {i}: {miss} against {}",
                true_err[i]
            );
        }
        let scale = |i: usize| atol[i] + rtol * y[i].abs().max(sliver.y1[i].abs());
        let estimated = [
            0.5 * eps * eps * (6.0 * eps),
            eps * (6.0 * eps),
            eps * (sliver.y1[0] - y[0]),
        ];
        let norm = (estimated
            .iter()
            .enumerate()
            .map(|(i, e)| (e / scale(i)).powi(2))
            .sum::<f64>()
            / 3.0)
            .sqrt();
        assert!((err - norm).abs() < 1e-9 * norm, "{err} against {norm}");
        for i in 0..3 {
            assert!(
                estimated[i].abs() >= true_err[i] * 0.99,
                "component {i}: the estimate {} falls short of the error {}",
                estimated[i],
                true_err[i]
            );
        }
    }

    #[test]
    fn the_sliver_interpolant_is_hermite_through_both_ends() {
        let mut sys = ConstantJerk { c0: 2.0, c1: 6.0 };
        let y = [0.5, -1.0, 0.25];
        let mut f = [0.0; 3];
        sys.rhs(1.0, &y, &mut f);
        let mut rhs = Rhs::new(&mut sys);
        let mut sliver = Sliver::new(3, 1);
        let eps = 0.25;
        sliver.attempt(&mut rhs, 1.0, eps, &y, &f, 1e-6, &[1e-6; 3]);
        let (mut ys, mut fs) = (y, f);
        sliver.commit(&mut ys, &mut fs);
        assert_eq!(ys.as_slice(), sliver.y_end());
        assert_eq!((sliver.t_start(), sliver.t_end()), (1.0, 1.25));
        for i in 0..3 {
            assert_eq!(sliver.eval_component(1.0, i), y[i]);
            assert_eq!(sliver.eval_component(1.25, i), ys[i]);
            // Its slope at both ends is the derivative there (one-sided differences of second
            // order).
            let d = 1e-5;
            let p = |t: f64| sliver.eval_component(t, i);
            let slope0 = (-3.0 * y[i] + 4.0 * p(1.0 + d) - p(1.0 + 2.0 * d)) / (2.0 * d);
            let slope1 = (3.0 * ys[i] - 4.0 * p(1.25 - d) + p(1.25 - 2.0 * d)) / (2.0 * d);
            assert!(
                (slope0 - f[i]).abs() < 1e-7,
                "{i}: {slope0} against {}",
                f[i]
            );
            assert!(
                (slope1 - fs[i]).abs() < 1e-7,
                "{i}: {slope1} against {}",
                fs[i]
            );
        }
    }

    /// Each accepted step: its ends, the state `(x, v)` at both, and the evaluations made since
    /// the step before.
    struct Steps {
        evals: Rc<Cell<u64>>,
        last_evals: u64,
        steps: Vec<Step>,
        y_start: [f64; 2],
    }
    type Step = (f64, f64, [f64; 2], [f64; 2], u64);
    impl StepObserver for Steps {
        fn on_start(&mut self, _t0: f64, y0: &[f64]) {
            self.y_start = [y0[0], y0[1]];
        }
        fn on_step(&mut self, step: &dyn DenseStep) -> Control {
            let evals = self.evals.get();
            let y1 = [step.y_end()[0], step.y_end()[1]];
            self.steps.push((
                step.t_start(),
                step.t_end(),
                self.y_start,
                y1,
                evals - self.last_evals,
            ));
            self.last_evals = evals;
            self.y_start = y1;
            Control::Continue
        }
    }

    const PUSH_RATE: f64 = 0.005;

    fn fall(predict: bool, rtol: f64) -> (Vec<Step>, f64) {
        let mut sys = PushedFall::new(PUSH_RATE, 1e4);
        let mut options = AdaptiveOptions::new(rtol);
        options.predict_switches = predict;
        let integrator = Dop853::with_options(options);
        let mut obs = Steps {
            evals: Rc::clone(&sys.evals),
            last_evals: 0,
            steps: Vec::new(),
            y_start: [0.0; 2],
        };
        let y0 = [1.0, -1.0];
        integrator
            .integrate(&mut sys, 0.0, &y0, 3.0, 1_000_000, &mut obs)
            .expect("the fall runs");
        let x_end = obs.steps.last().expect("steps").3[0];
        (obs.steps, x_end)
    }

    #[test]
    fn a_crossing_just_ahead_is_crossed_by_one_evaluation() {
        let (steps, x_end) = fall(true, 1e-6);
        // The result is the tolerance's.
        let (_, x_ref) = fall(false, 1e-12);
        assert!(
            (x_end - x_ref).abs() < 1e-5,
            "{x_end} against {x_ref} (rtol 1e-6)"
        );
        // The slivers: steps of one evaluation, each just past a crossing of the floor.
        let slivers: Vec<_> = steps.iter().filter(|s| s.4 == 1).collect();
        assert!(
            !slivers.is_empty(),
            "no sliver among {} steps: {:?}",
            steps.len(),
            steps
        );
        let mut entering = 0;
        for sliver in &slivers {
            let (t0, t1, [x0, v0], [x1, v1], _) = **sliver;
            assert!(
                (x0 > 0.0) != (x1 > 0.0),
                "a sliver from {t0} to {t1} crosses no switch: {x0} → {x1}"
            );
            let e = t1 - t0;
            // Into the floor, its force is at most k |x1|^{3/2} (below 1e-10) over the sliver:
            // the motion is the cubic of the push, and the Taylor step misses only its jerk's
            // terms.
            if x0 < 0.0 {
                continue;
            }
            entering += 1;
            let c = PUSH_RATE;
            let x_exact = x0 + v0 * e + 0.5 * c * t0 * e * e + c * e.powi(3) / 6.0;
            let v_exact = v0 + c * t0 * e + 0.5 * c * e * e;
            // (t1 − t0 carries the rounding of t1, a few ulps of it.)
            let dt = 4.0 * f64::EPSILON * t1;
            assert!(
                (x1 - x_exact).abs() <= c * e.powi(3) + dt * v0.abs()
                    && (v1 - v_exact).abs() <= c * e * e + dt * c * t1,
                "sliver {sliver:?}: x off by {:e}, v off by {:e} (ε = {e:e})",
                x1 - x_exact,
                v1 - v_exact
            );
        }
        assert!(entering > 0, "no sliver into the floor: {slivers:?}");
    }

    /// `state_mut` moves the method: what is written there is the state and the first derivative
    /// its next attempt starts from, for every kind of stepper.
    #[test]
    fn a_stepper_moved_by_state_mut_starts_from_there() {
        use super::super::adaptive::{Method, Stepper};
        use crate::integrate::{Dop853Method, Ros34pw2Method, Vern6Method};
        fn check<M: Method>() {
            let mut sys = ConstantJerk { c0: 2.0, c1: 6.0 };
            let mut w = M::stepper(&[0.5, -1.0, 0.0], 1);
            let mut rhs = Rhs::new(&mut sys);
            assert!(w.start(&mut rhs, 0.0));
            let (y, f) = w.state_mut();
            y.copy_from_slice(&[1.5, 2.5, 3.5]);
            f.copy_from_slice(&[-1.0, -2.0, -3.0]);
            assert_eq!(w.y(), &[1.5, 2.5, 3.5], "{}", M::NAME);
            assert_eq!(w.f0(), &[-1.0, -2.0, -3.0], "{}", M::NAME);
        }
        check::<Dop853Method>();
        check::<Vern6Method>();
        check::<Ros34pw2Method>();
    }
}
