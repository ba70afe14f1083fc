//! One test suite for every adaptive method, generic over the method: accuracy against the
//! tolerance, convergence order, dense-output order and accuracy, the batched dense output bit
//! for bit the scalar one, quadratures, right-hand-side accounting, non-finite values (transient
//! and persistent), step budgets, `h_max`, stopping, tolerance scales and invalid settings. Each
//! method states what it must meet in an [`Expect`]; the explicit ones' tableaus are checked
//! against Butcher's order conditions on every rooted tree.

use super::adaptive::{Adaptive, Method};
use super::explicit::{ExplicitMethod, MAX_STAGES};
use super::order_conditions::{
    dense_weights, interpolant_weights, matrix, worst_condition, worst_row_sum,
};
use super::{
    all_finite, Control, DenseStep, Dop853Method, IntegrateError, IntegrationStats, Integrator,
    OdeSystem, OdeSystemDyn, Ros34pw2Method, StepObserver, Vern6Method, BATCH_COMPONENTS,
};
use crate::problems::{run_recorded, HarmonicOscillator, QuadraticGrowth, StepRecord};

/// What a method must meet.
struct Expect {
    /// Bounds of the global error's slope with fixed steps on y' = y² from 1 over [0, 0.8]
    /// (10 → 20 and 20 → 40 steps).
    order: (f64, f64),
    /// Bounds of the local slope of the dense output's error over the first step (h 0.1 → 0.05)
    /// on the same problem.
    dense_order: (f64, f64),
    /// Largest error on the harmonic oscillator over 20 s at tolerance 1e-10, at the end and at
    /// 1 000 interpolated points.
    error_at_1e10: f64,
    /// The dense-output check on the oscillator: tolerance, largest error at 1 000 points, most
    /// steps (fewer than the points, so that they really are interpolated).
    dense_check: (f64, f64, u64),
    /// Right-hand sides a run should take, from its statistics and whether the first step was
    /// chosen automatically (one more evaluation).
    rhs_evals: fn(&IntegrationStats, bool) -> u64,
}

/// The right-hand sides of an explicit method, from its tableau: one at the start, one for the
/// automatic first step, the attempt's stages for every attempt, and the rest for every accepted
/// step.
fn explicit_rhs_evals<M: ExplicitMethod>(s: &IntegrationStats, automatic: bool) -> u64 {
    let t = M::TABLEAU;
    1 + u64::from(automatic) + t.rhs_per_attempt() * s.attempts() + t.rhs_per_acceptance() * s.steps
}

/// DOP853: 8th order; its 7th-order continuous extension has local error O(h⁸). On y' = y² at
/// these steps the global slope measures 7.7 and 7.9, the dense one 8.3.
const DOP853: Expect = Expect {
    order: (7.3, 9.5),
    dense_order: (7.3, 9.0),
    error_at_1e10: 1e-8,
    dense_check: (1e-10, 1e-8, 200),
    rhs_evals: explicit_rhs_evals::<Dop853Method>,
};

/// Vern6: 6th order. Verner chose the pair for a small 6th-order error constant: at these steps
/// the 7th-order terms still weigh in and the slope lies between 6 and 7.5 (measured 6.9 and 7.5);
/// at smaller steps rounding takes over (the weights reach ±176). A wrong coefficient drops it to
/// 5 or below. The interpolant's slope falls towards 7 as h shrinks (6.9 from 0.1 to 0.05).
const VERN6: Expect = Expect {
    order: (5.7, 7.8),
    dense_order: (6.5, 7.5),
    error_at_1e10: 1e-8,
    dense_check: (1e-10, 1e-8, 500),
    rhs_evals: explicit_rhs_evals::<Vern6Method>,
};

/// ROS34PW2: 3rd order; three right-hand sides per attempt, one more (at the new point) per
/// accepted step. Its continuous extension is 3rd order with the exact Jacobian (slope 4 on the
/// oscillator, its own test), but y' = y² is a quadrature, which gets no Jacobian (a W-method
/// with J = 0): there it is 2nd order, slope 3.1. The global slopes measure 2.70 and 2.84,
/// approaching 3 as the step shrinks.
const ROS34PW2: Expect = Expect {
    order: (2.5, 3.5),
    dense_order: (2.7, 3.6),
    error_at_1e10: 1e-7,
    dense_check: (1e-6, 1e-4, 1000),
    rhs_evals: |s, automatic| 1 + u64::from(automatic) + 3 * s.attempts() + s.steps,
};

/// Counts its own right-hand-side calls; a harmonic oscillator that returns NaN for t > `nan_after`.
struct Counted {
    calls: u64,
    nan_after: f64,
}

impl OdeSystem for Counted {
    fn n_pos(&self) -> usize {
        1
    }
    fn n_quad(&self) -> usize {
        0
    }
    fn rhs(&mut self, t: f64, y: &[f64], dy: &mut [f64]) {
        self.calls += 1;
        if t > self.nan_after {
            dy[0] = f64::NAN;
            dy[1] = f64::NAN;
        } else {
            dy[0] = y[1];
            dy[1] = -y[0];
        }
    }
}

fn oscillator_error<M: Method>(tol: f64, t_end: f64) -> (f64, IntegrationStats) {
    let (r, rec) = run_recorded(
        &Adaptive::<M>::new(tol, tol),
        &mut HarmonicOscillator { quadrature: false },
        &[1.0, 0.0],
        t_end,
    );
    let stats = r.unwrap();
    assert_eq!(rec.t, t_end, "must land exactly on t_end");
    let e = (rec.y[0] - t_end.cos())
        .abs()
        .max((rec.y[1] + t_end.sin()).abs());
    (e, stats)
}

fn error_follows_the_tolerance<M: Method>(expect: &Expect) {
    let (e10, s10) = oscillator_error::<M>(1e-10, 20.0);
    let (e6, s6) = oscillator_error::<M>(1e-6, 20.0);
    assert!(e10 < expect.error_at_1e10, "error {e10:e} at tol 1e-10");
    assert!(e6 / e10 > 100.0, "e(1e-6) = {e6:e}, e(1e-10) = {e10:e}");
    assert!(s10.steps > s6.steps, "{s6:?} {s10:?}");
}

/// Fixed steps of `t_end / n`: huge tolerances so that the controller always wants to grow,
/// capped at the step.
fn fixed_step_run<M: Method>(
    sys: &mut dyn OdeSystemDyn,
    y0: &[f64],
    t_end: f64,
    n: u32,
) -> Vec<f64> {
    let h = t_end / f64::from(n);
    let solver = Adaptive::<M>::new(1e3, 1e3)
        .with_initial_step(h)
        .with_max_step(h);
    let (r, rec) = run_recorded(&solver, sys, y0, t_end);
    let s = r.unwrap();
    assert_eq!((s.steps, s.rejected), (u64::from(n), 0));
    for &(a, b) in &rec.steps {
        assert!(((b - a) - h).abs() < 1e-12 * t_end);
    }
    rec.y
}

fn convergence_order<M: Method>(expect: &Expect) {
    // Nonlinear, so that the error involves every order condition.
    let t_end = 0.8;
    let e = |n: u32| {
        (fixed_step_run::<M>(&mut QuadraticGrowth, &[1.0], t_end, n)[0]
            - QuadraticGrowth::exact(1.0, t_end))
        .abs()
    };
    let (e1, e2, e3) = (e(10), e(20), e(40));
    for (p, what) in [((e1 / e2).log2(), "10/20"), ((e2 / e3).log2(), "20/40")] {
        eprintln!("{}: y' = y², steps {what}: order {p}", M::NAME);
        assert!(
            p > expect.order.0 && p < expect.order.1,
            "y' = y², steps {what}: order {p} (errors {e1:e} {e2:e} {e3:e})"
        );
    }
}

fn dense_output_order<M: Method>(expect: &Expect) {
    // Only the first step's interpolation error counts: the exact solution through the step's
    // own start value.
    struct FirstStep {
        max_err: f64,
        ends: (f64, f64),
    }
    impl StepObserver for FirstStep {
        fn on_start(&mut self, _t0: f64, _y0: &[f64]) {}
        fn on_step(&mut self, step: &dyn DenseStep) -> Control {
            let (a, b) = (step.t_start(), step.t_end());
            for j in 1..10 {
                let t = a + (b - a) * f64::from(j) / 10.0;
                let e = (step.eval_component(t, 0) - QuadraticGrowth::exact(1.0, t)).abs();
                self.max_err = self.max_err.max(e);
            }
            // The interpolant meets the step's ends.
            self.ends = (
                step.eval_component(a, 0),
                step.eval_component(b, 0) - step.y_end()[0],
            );
            Control::Stop
        }
    }
    let err_for = |h: f64| {
        let solver = Adaptive::<M>::new(1e3, 1e3)
            .with_initial_step(h)
            .with_max_step(h);
        let mut obs = FirstStep {
            max_err: 0.0,
            ends: (f64::NAN, f64::NAN),
        };
        solver
            .integrate(&mut QuadraticGrowth, 0.0, &[1.0], 0.9, 10, &mut obs)
            .unwrap();
        assert_eq!(obs.ends, (1.0, 0.0));
        obs.max_err
    };
    let (e1, e2) = (err_for(0.1), err_for(0.05));
    let p = (e1 / e2).log2();
    eprintln!("{}: dense local order {p}", M::NAME);
    assert!(
        p > expect.dense_order.0 && p < expect.dense_order.1,
        "dense local order {p} (e1 {e1:e}, e2 {e2:e})"
    );
}

fn dense_output_accuracy<M: Method>(expect: &Expect) {
    // 1000 samples over 20 s, none on a step end, against the exact solution; every way of
    // reading the interpolant gives the same bits.
    struct Dense {
        next: usize,
        max_err: f64,
    }
    impl StepObserver for Dense {
        fn on_start(&mut self, _t0: f64, _y0: &[f64]) {}
        fn on_step(&mut self, step: &dyn DenseStep) -> Control {
            loop {
                let t = (self.next as f64 + 0.5) * 0.02;
                if self.next == 1000 || t > step.t_end() {
                    return Control::Continue;
                }
                assert!(t >= step.t_start());
                let one = [step.eval_component(t, 0), step.eval_component(t, 1)];
                let mut both = [f64::NAN; 2];
                step.eval_components(t, &[0, 1], &mut both);
                let mut full = [f64::NAN; 2];
                step.eval(t, &mut full);
                let mut batched = [f64::NAN; 2];
                step.eval_components_at(&[t], &[0, 1], &mut batched);
                assert_eq!(both, one);
                assert_eq!(full, one);
                assert_eq!(batched, one);
                let e = (one[0] - t.cos()).abs().max((one[1] + t.sin()).abs());
                self.max_err = self.max_err.max(e);
                self.next += 1;
            }
        }
    }
    let mut obs = Dense {
        next: 0,
        max_err: 0.0,
    };
    let (tol, max_err, max_steps) = expect.dense_check;
    let stats = Adaptive::<M>::new(tol, tol)
        .integrate(
            &mut HarmonicOscillator { quadrature: false },
            0.0,
            &[1.0, 0.0],
            20.0,
            100_000,
            &mut obs,
        )
        .unwrap();
    assert_eq!(obs.next, 1000);
    eprintln!("{}: dense error {:e} in {stats:?}", M::NAME, obs.max_err);
    assert!(stats.steps < max_steps, "{stats:?}");
    assert!(obs.max_err < max_err, "dense error {:e}", obs.max_err);
}

fn batched_dense_output_is_bitwise_the_scalar_one<M: Method>() {
    // On every step, a few components at several times (the step's end among them).
    struct BatchCheck {
        steps: usize,
    }
    impl StepObserver for BatchCheck {
        fn on_start(&mut self, _t0: f64, _y0: &[f64]) {}
        fn on_step(&mut self, step: &dyn DenseStep) -> Control {
            let (t0, t1) = (step.t_start(), step.t_end());
            let times: Vec<f64> = (1..=7).map(|k| t0 + (t1 - t0) * k as f64 / 7.0).collect();
            // Three components, and lists of them (repeated) as wide as a batch holds at
            // most, one past it (interpolated one by one), and odd widths between.
            for width in [3, 9, 17, BATCH_COMPONENTS, BATCH_COMPONENTS + 1] {
                let indices: Vec<usize> = [2, 0, 1].into_iter().cycle().take(width).collect();
                let mut out = vec![f64::NAN; times.len() * indices.len()];
                step.eval_components_at(&times, &indices, &mut out);
                for (r, &t) in times.iter().enumerate() {
                    for (j, &i) in indices.iter().enumerate() {
                        let one = step.eval_component(t, i);
                        assert_eq!(
                            out[r * indices.len() + j].to_bits(),
                            one.to_bits(),
                            "t {t}, i {i}, {width} components"
                        );
                    }
                }
            }
            self.steps += 1;
            Control::Continue
        }
    }
    let mut check = BatchCheck { steps: 0 };
    Adaptive::<M>::new(1e-9, 1e-9)
        .integrate(
            &mut HarmonicOscillator { quadrature: true },
            0.0,
            &[1.0, 0.0, 0.0],
            6.0,
            100_000,
            &mut check,
        )
        .unwrap();
    assert!(check.steps > 10, "{} steps", check.steps);
}

fn quadrature_component<M: Method>(expect: &Expect) {
    let t_end = 7.5;
    let (r, rec) = run_recorded(
        &Adaptive::<M>::new(1e-10, 1e-10),
        &mut HarmonicOscillator { quadrature: true },
        &[1.0, 0.0, 0.0],
        t_end,
    );
    r.unwrap();
    // q = ∫₀ᵀ cos² = T/2 + sin(2T)/4.
    let exact = t_end / 2.0 + (2.0 * t_end).sin() / 4.0;
    let e = (rec.y[2] - exact).abs();
    assert!(e < expect.error_at_1e10, "quadrature error {e:e}");
}

fn rhs_eval_accounting<M: Method>(expect: &Expect) {
    let counted = || Counted {
        calls: 0,
        nan_after: f64::INFINITY,
    };
    // Automatic first step.
    let mut sys = counted();
    let mut rec = StepRecord::default();
    let s = Adaptive::<M>::new(1e-9, 1e-9)
        .integrate(&mut sys, 0.0, &[1.0, 0.0], 10.0, 100_000, &mut rec)
        .unwrap();
    assert_eq!(s.rhs_evals, sys.calls);
    assert_eq!(s.rhs_evals, (expect.rhs_evals)(&s, true), "{s:?}");
    assert_eq!(s.steps as usize, rec.steps.len());
    // A far too large first step forces rejections.
    let mut sys = counted();
    let s = Adaptive::<M>::new(1e-9, 1e-9)
        .with_initial_step(8.0)
        .integrate(
            &mut sys,
            0.0,
            &[1.0, 0.0],
            10.0,
            100_000,
            &mut StepRecord::default(),
        )
        .unwrap();
    assert!(s.rejected >= 1, "{s:?}");
    assert_eq!(s.rhs_evals, sys.calls);
    assert_eq!(s.rhs_evals, (expect.rhs_evals)(&s, false), "{s:?}");
}

fn persistent_nonfinite_is_an_error<M: Method>() {
    let mut sys = Counted {
        calls: 0,
        nan_after: 1.0,
    };
    let mut rec = StepRecord::default();
    let r = Adaptive::<M>::new(1e-8, 1e-8).integrate(
        &mut sys,
        0.0,
        &[1.0, 0.0],
        5.0,
        100_000,
        &mut rec,
    );
    match r {
        Err(IntegrateError::NonFinite { t }) => {
            assert!(t > 0.5 && t <= 1.0, "t = {t}");
            // Everything handed to the observer is finite and before the wall.
            assert!(rec.t <= 1.0);
            assert!(all_finite(&rec.y));
        }
        other => panic!("expected NonFinite, got {other:?}"),
    }
}

fn recovers_from_transient_nonfinite<M: Method>() {
    // y' = −10 y, undefined for y < 0: a huge first step overshoots, is shrunk, and the run
    // completes accurately.
    struct Guarded;
    impl OdeSystem for Guarded {
        fn n_pos(&self) -> usize {
            0
        }
        fn n_quad(&self) -> usize {
            1
        }
        fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
            dy[0] = if y[0] < 0.0 { f64::NAN } else { -10.0 * y[0] };
        }
    }
    let solver = Adaptive::<M>::new(1e-10, 1e-12).with_initial_step(1.0);
    let (r, rec) = run_recorded(&solver, &mut Guarded, &[1.0], 1.0);
    let stats = r.unwrap();
    assert!(stats.rejected >= 1);
    let e = (rec.y[0] - (-10.0f64).exp()).abs();
    assert!(e < 1e-8, "error {e:e}");
}

fn step_budgets<M: Method>() {
    let oscillator = || HarmonicOscillator { quadrature: false };
    let mut rec = StepRecord::default();
    let r = Adaptive::<M>::new(1e-10, 1e-10).integrate(
        &mut oscillator(),
        0.0,
        &[1.0, 0.0],
        20.0,
        5,
        &mut rec,
    );
    match r {
        Err(IntegrateError::StepBudget { max_steps: 5, t }) => {
            assert!(t > 0.0 && t < 20.0);
            assert_eq!(t, rec.t);
        }
        other => panic!("expected StepBudget, got {other:?}"),
    }
    assert_eq!(rec.steps.len(), 5);

    // Rejected attempts count: with a budget one short of the attempts the run needs it fails,
    // though it has more than enough for the accepted steps alone.
    let solver = Adaptive::<M>::new(1e-9, 1e-9).with_initial_step(8.0);
    let run = |budget: u64| {
        solver.integrate(
            &mut oscillator(),
            0.0,
            &[1.0, 0.0],
            10.0,
            budget,
            &mut StepRecord::default(),
        )
    };
    let s = run(100_000).unwrap();
    assert!(s.rejected >= 1, "{s:?}");
    let attempts = s.steps + s.rejected;
    assert_eq!(run(attempts), Ok(s));
    match run(attempts - 1) {
        Err(IntegrateError::StepBudget { max_steps, .. }) => assert_eq!(max_steps, attempts - 1),
        other => panic!("expected StepBudget, got {other:?}"),
    }
    assert!(s.steps < attempts - 1);
}

fn h_max_stop_and_start<M: Method>() {
    let solver = Adaptive::<M>::new(1e-6, 1e-6).with_max_step(0.1);
    let (r, rec) = run_recorded(
        &solver,
        &mut HarmonicOscillator { quadrature: false },
        &[1.0, 0.0],
        3.05,
    );
    r.unwrap();
    for &(a, b) in &rec.steps {
        assert!(b - a <= 0.1 * 1.01 + 1e-15, "step {}", b - a);
    }
    assert_eq!(rec.t, 3.05);

    struct StopAfter(usize, usize, bool);
    impl StepObserver for StopAfter {
        fn on_start(&mut self, t0: f64, y0: &[f64]) {
            assert_eq!((t0, y0), (0.0, &[1.0, 0.0][..]));
            self.2 = true;
        }
        fn on_step(&mut self, _step: &dyn DenseStep) -> Control {
            self.1 += 1;
            if self.1 == self.0 {
                Control::Stop
            } else {
                Control::Continue
            }
        }
    }
    let mut obs = StopAfter(3, 0, false);
    let s = Adaptive::<M>::new(1e-10, 1e-10)
        .integrate(
            &mut HarmonicOscillator { quadrature: false },
            0.0,
            &[1.0, 0.0],
            20.0,
            1000,
            &mut obs,
        )
        .unwrap();
    assert!(obs.2);
    assert_eq!((s.steps, obs.1), (3, 3));
}

fn tolerance_scales_and_invalid_settings<M: Method>() {
    let run = |solver: &Adaptive<M>, t_end: f64| {
        run_recorded(
            solver,
            &mut HarmonicOscillator { quadrature: false },
            &[1.0, 0.0],
            t_end,
        )
    };
    // Pure absolute control (rtol tiny): scaling atol by 1e-3 on every component gives the same
    // steps as atol / 1e3.
    let (ra, a) = run(&Adaptive::<M>::new(1e-14, 1e-9), 5.0);
    let (rb, b) = run(
        &Adaptive::<M>::new(1e-14, 1e-6).with_atol_scale(vec![1e-3, 1e-3]),
        5.0,
    );
    assert_eq!(ra.unwrap(), rb.unwrap());
    assert_eq!(a.steps, b.steps);
    // Loosening only the velocity tolerance takes no more steps than the uniform one.
    let (rc, _) = run(
        &Adaptive::<M>::new(1e-14, 1e-9).with_atol_scale(vec![1.0, 1e3]),
        5.0,
    );
    assert!(rc.unwrap().steps <= a.steps.len() as u64);
    // Pure relative tolerance is allowed.
    run(&Adaptive::<M>::new(1e-8, 0.0), 1.0).0.unwrap();

    let bad = |s: Adaptive<M>, y0: &[f64], t_end: f64| {
        let r = s.integrate(
            &mut HarmonicOscillator { quadrature: false },
            0.0,
            y0,
            t_end,
            100,
            &mut StepRecord::default(),
        );
        assert!(
            matches!(r, Err(IntegrateError::InvalidSettings(_))),
            "{r:?}"
        );
    };
    let y0 = [1.0, 0.0];
    bad(
        Adaptive::new(1e-6, 1e-6).with_atol_scale(vec![1.0]),
        &y0,
        1.0,
    );
    bad(
        Adaptive::new(1e-6, 1e-6).with_atol_scale(vec![1.0, f64::NAN]),
        &y0,
        1.0,
    );
    bad(Adaptive::new(0.0, 1e-6), &y0, 1.0);
    bad(Adaptive::new(-1e-6, 1e-6), &y0, 1.0);
    bad(Adaptive::new(1e-6, -1e-6), &y0, 1.0);
    bad(Adaptive::new(0.0, 0.0), &y0, 1.0);
    bad(Adaptive::new(1e-6, 1e-6), &y0, 0.0);
    bad(Adaptive::new(1e-6, 1e-6), &y0, -1.0);
    bad(Adaptive::new(1e-6, 1e-6), &[f64::NAN, 0.0], 1.0);
    bad(Adaptive::new(1e-6, 1e-6), &[1.0], 1.0);
    bad(Adaptive::new(1e-6, 1e-6).with_max_step(0.0), &y0, 1.0);
    assert_eq!(Adaptive::<M>::new(1e-6, 1e-6).name(), M::NAME);
}

/// An explicit tableau's consistency: row sums equal the nodes; the weights have order `order`
/// and not one more; the method's own continuous extension has order `dense_order` at several
/// points of the step, is zero at its start and the weights at its end.
fn explicit_tableau_has_its_orders<M: ExplicitMethod>(order: usize, dense_order: usize) {
    let tableau = M::TABLEAU;
    assert!(tableau.stages.len() <= MAX_STAGES);
    assert_eq!(tableau.buffers.len(), tableau.stages.len());
    let (a, c) = matrix(&tableau);
    let s = c.len();
    assert!(worst_row_sum(&a, &c) < 1e-12, "row sums");
    assert_eq!(tableau.stages[tableau.fsal].c, 1.0);
    assert_eq!(tableau.stages[tableau.attempt].c, 1.0);
    // Stages that share a buffer are never needed together: the later one reads none of the
    // earlier one's buffer-mates, and nothing after it reads the earlier one.
    for (j, &bj) in tableau.buffers.iter().enumerate() {
        for (m, &bm) in tableau.buffers.iter().enumerate().take(j) {
            if bj == bm {
                for later in &tableau.stages[j..] {
                    assert!(
                        later.a.iter().all(|&(r, _)| r != m),
                        "stage {m} is read after stage {j} took its buffer"
                    );
                }
                assert!(
                    m != 0 && m <= tableau.attempt,
                    "only attempt stages may be overwritten"
                );
            }
        }
    }
    let b = dense_weights(tableau.weights(), s);
    let worst = worst_condition(&a, &b, 1.0, order);
    assert!(worst < 1e-13, "order-{order} weights: {worst:e}");
    assert!(worst_condition(&a, &b, 1.0, order + 1) > 1e-7);
    for theta in [0.1f64, 0.28, 0.5, 0.77, 1.0] {
        let w = interpolant_weights::<M>(theta);
        let worst = worst_condition(&a, &w, theta, dense_order);
        assert!(worst < 1e-12, "interpolant at θ = {theta}: {worst:e}");
        if theta == 1.0 {
            for j in 0..s {
                assert!((w[j] - b[j]).abs() < 1e-10, "b(1)_{j} = {}", w[j]);
            }
        }
    }
    assert!(interpolant_weights::<M>(0.0).iter().all(|&w| w == 0.0));
}

macro_rules! suite {
    ($name:ident, $method:ty, $expect:expr) => {
        mod $name {
            use super::*;
            #[test]
            fn error_follows_the_tolerance() {
                super::error_follows_the_tolerance::<$method>(&$expect)
            }
            #[test]
            fn convergence_order() {
                super::convergence_order::<$method>(&$expect)
            }
            #[test]
            fn dense_output_order() {
                super::dense_output_order::<$method>(&$expect)
            }
            #[test]
            fn dense_output_accuracy() {
                super::dense_output_accuracy::<$method>(&$expect)
            }
            #[test]
            fn batched_dense_output_is_bitwise_the_scalar_one() {
                super::batched_dense_output_is_bitwise_the_scalar_one::<$method>()
            }
            #[test]
            fn quadrature_component() {
                super::quadrature_component::<$method>(&$expect)
            }
            #[test]
            fn rhs_eval_accounting() {
                super::rhs_eval_accounting::<$method>(&$expect)
            }
            #[test]
            fn persistent_nonfinite_is_an_error() {
                super::persistent_nonfinite_is_an_error::<$method>()
            }
            #[test]
            fn recovers_from_transient_nonfinite() {
                super::recovers_from_transient_nonfinite::<$method>()
            }
            #[test]
            fn step_budgets() {
                super::step_budgets::<$method>()
            }
            #[test]
            fn h_max_stop_and_start() {
                super::h_max_stop_and_start::<$method>()
            }
            #[test]
            fn tolerance_scales_and_invalid_settings() {
                super::tolerance_scales_and_invalid_settings::<$method>()
            }
        }
    };
}

suite!(dop853, Dop853Method, DOP853);
suite!(vern6, Vern6Method, VERN6);
suite!(ros34pw2, Ros34pw2Method, ROS34PW2);

#[test]
fn dop853_tableau_has_its_orders() {
    explicit_tableau_has_its_orders::<Dop853Method>(8, 7);
}

#[test]
fn vern6_tableau_has_its_orders() {
    explicit_tableau_has_its_orders::<Vern6Method>(6, 6);
}

/// The fixed-step schemes through the one fixed-step loop: their order on the harmonic
/// oscillator (RK4 4, Verlet 2), their dense output (cubic Hermite, local error O(h⁴)), the
/// right-hand sides they take, the step budget and a bad step.
#[test]
fn fixed_step_schemes_have_their_orders_budgets_and_accounting() {
    use super::{Rk4, VelocityVerlet};
    let t_end = 10.0;
    let error = |solver: &dyn Integrator| {
        let mut sys = Counted {
            calls: 0,
            nan_after: f64::INFINITY,
        };
        let mut rec = StepRecord::default();
        let s = solver
            .integrate(&mut sys, 0.0, &[1.0, 0.0], t_end, 1_000_000, &mut rec)
            .unwrap();
        assert_eq!(rec.t, t_end);
        assert_eq!(s.rhs_evals, sys.calls);
        let e = (rec.y[0] - t_end.cos())
            .abs()
            .max((rec.y[1] + t_end.sin()).abs());
        (e, s)
    };
    for (name, order, per_step, make) in [
        (
            "rk4",
            4.0,
            4,
            (|dt| Box::new(Rk4 { dt }) as Box<dyn Integrator>) as fn(f64) -> Box<dyn Integrator>,
        ),
        ("verlet", 2.0, 1, |dt| Box::new(VelocityVerlet { dt })),
    ] {
        let (e1, s1) = error(make(0.02).as_ref());
        let (e2, s2) = error(make(0.01).as_ref());
        let p = (e1 / e2).log2();
        assert!(
            (p - order).abs() < 0.2,
            "{name}: order {p} ({e1:e}, {e2:e})"
        );
        assert_eq!(s1.steps, 500);
        assert_eq!(s2.steps, 1000);
        assert_eq!(s2.rhs_evals, 1 + per_step * s2.steps, "{name}: {s2:?}");

        // The dense output between step ends: O(h⁴) locally, so at least the scheme's accuracy.
        struct Mid(f64);
        impl StepObserver for Mid {
            fn on_start(&mut self, _t0: f64, _y0: &[f64]) {}
            fn on_step(&mut self, step: &dyn DenseStep) -> Control {
                let (a, b) = (step.t_start(), step.t_end());
                assert_eq!(step.eval_component(b, 0), step.y_end()[0]);
                let t = 0.5 * (a + b);
                self.0 = self.0.max((step.eval_component(t, 0) - t.cos()).abs());
                Control::Continue
            }
        }
        let mut mid = Mid(0.0);
        make(0.01)
            .integrate(
                &mut HarmonicOscillator { quadrature: false },
                0.0,
                &[1.0, 0.0],
                t_end,
                1_000_000,
                &mut mid,
            )
            .unwrap();
        assert!(
            mid.0 < 2.0 * e2,
            "{name}: midpoint error {:e} vs {e2:e}",
            mid.0
        );

        let mut rec = StepRecord::default();
        match make(0.01).integrate(
            &mut HarmonicOscillator { quadrature: false },
            0.0,
            &[1.0, 0.0],
            t_end,
            5,
            &mut rec,
        ) {
            Err(IntegrateError::StepBudget { max_steps: 5, t }) => {
                assert!((t - 0.05).abs() < 1e-12, "{name}: budget at {t}");
                assert_eq!(rec.steps.len(), 5);
            }
            other => panic!("{name}: expected StepBudget, got {other:?}"),
        }
        for bad in [0.0, -1.0, f64::NAN] {
            let r = make(bad).integrate(
                &mut HarmonicOscillator { quadrature: false },
                0.0,
                &[1.0, 0.0],
                t_end,
                100,
                &mut StepRecord::default(),
            );
            assert!(
                matches!(r, Err(IntegrateError::InvalidSettings(_))),
                "{name}: {r:?}"
            );
        }
    }
}
