//! ROS34PW2: the L-stable, stiffly accurate Rosenbrock-W method of order 3(2) of Rang & Angermann
//! (*New Rosenbrock W-methods of order 3 for partial differential algebraic equations of index 1*,
//! BIT 45, 2005), with its third-order dense output, for stiff chains (strong damping on light
//! particles), exploiting the tridiagonal structure of the chain's Jacobian.
//!
//! # Why this method
//!
//! - **L-stable and stiffly accurate**: the viscous modes of a light cylinder between two heavy
//!   spheres decay at rates `~ μ/m_c` (10⁷–10⁹ s⁻¹ for μ = 10³–10⁴ kg/s and 0.1 g cylinders) far
//!   above the pulse's own time scale; the method damps them in one step, so the step size follows
//!   the accuracy of the slow motion instead of the explicit stability limit `~ 1/λ`.
//! - **A W-method**: its order conditions hold for *any* matrix `W` in place of the exact
//!   Jacobian. Two things rest on that here. (1) The quadratures `q' = P(x, v)` (dissipated work,
//!   wall impulse) have no Jacobian rows through the [`OdeSystemDyn`] interface; their rows of `W` are
//!   taken as zero, and the method stays of order 3 on them, so the energy ledger closes at the
//!   method's order. A classical Rosenbrock method (Rodas4, Rodas5P) needs the exact `∂P/∂y` rows:
//!   without them the quadrature `Σ b_i P(Y_i)` over its stage values is only first-order accurate
//!   in general (`Σ b_i α_i ≠ 1/2`). (2) The Jacobian of the chain jumps where a contact opens or
//!   closes; a step that starts on one side but whose stages peek at the other keeps its order.
//!   Non-autonomous right-hand sides are handled the same way (the `∂f/∂t` term is left out,
//!   which a W-method tolerates).
//! - **Cheap**: four stages and four right-hand-side evaluations per accepted step (the derivative
//!   at the end of a step is the next step's first stage); one tridiagonal factorisation per
//!   attempt, O(N).
//!
//! The coefficients (α, Γ, b, b̂ and the dense-output table) are those PETSc registers as
//! `TSROSWRA34PW2` (`src/ts/impls/rosw/rosw.c`); the transformed tables the step uses are derived
//! from them once, at run time, so no derived coefficient is typed in.
//!
//! # Linear algebra
//!
//! With `u_i = Σ_j γ_ij k_j` (Hairer & Wanner's transformed stages) each stage solves
//! `(I/(γh) − W) u_i = f(Y_i) + Σ_{j<i} (c_ij/h) u_j` with `Y_i = y₀ + Σ_{j<i} a_ij u_j`, where for
//! the state `[x, v, q]`
//!
//! ```text
//!     [ 0   I   0 ]
//! W = [ Kx  Kv  0 ]      Kx = ∂a/∂x, Kv = ∂a/∂v (tridiagonal, from `acceleration_jacobian`).
//!     [ 0   0   0 ]
//! ```
//!
//! Eliminating `z_x = γh (r_x + z_v)` leaves `(I − γh Kv − γ²h² Kx) z_v = γh (r_v + γh Kx r_x)`,
//! tridiagonal of order `n_pos`, and `z_q = γh r_q`. The tridiagonal matrix is factorised once per
//! attempted step by Gaussian elimination with partial pivoting (LAPACK's `dgttrf`): for a chain it
//! is a strictly diagonally dominant M-matrix, no row is ever interchanged and this *is* the Thomas
//! algorithm; for a general system with a non-dominant Jacobian the interchanges keep it stable. A
//! zero or non-finite pivot fails the attempt, which is retried with a ten times smaller step. A
//! system without a Jacobian (`acceleration_jacobian` returns `false`) gets `Kx = Kv = 0`: still
//! third order (W-method), but without the stiff stability.
//!
//! # Cost accounting
//!
//! Right-hand-side evaluations: one at `t0`, one more for the automatic first step
//! (`h_init = None`), three per attempted step (stages 2–4; stage 1 is `f(y₀)`, already known) and
//! one per step that passes the error test and is not retaken for an event (`f(y₁)`, the next
//! step's first stage). Without non-finite values: `1 + [h_init is None] + 4 steps + 3 rejected`.
//! The Jacobian is evaluated once per accepted step, at its start (rejected attempts and event
//! retakes from the same point reuse it): exactly `steps` evaluations. It is O(N), costs less than
//! one right-hand side, and changes a lot between steps when contacts open and close, so it is
//! never kept across steps.
//!
//! # Dense output
//!
//! The method's own continuous extension (PETSc's `binterpt`, cubic in `θ`), third order, built
//! from the stage vectors: `y(t₀ + θh) = y₀ + Σ_j d_j(θ) u_j`, O(1) per component and no extra
//! evaluation. It is exact at both ends of the step.
//!
//! # Where it lives
//!
//! The method's coefficients and the transformed tables derived from them are `tableau`; the
//! tridiagonal factorisation is `linalg`; the step (its work space, attempt and dense output) is
//! `stepper`. Apart because each is checked on its own: the tables against the order conditions,
//! the factorisation against a dense solve, the step by the integration tests here.

// The coefficients are kept with all the digits published, more than an f64 always holds.
#![allow(clippy::excessive_precision)]
// Index loops over equal-length slices read more clearly here than nested zips.
#![allow(clippy::needless_range_loop)]

mod linalg;
mod stepper;
mod tableau;

use super::adaptive::{Adaptive, Controller, Method, RejectionForm};

use stepper::Work;

/// Adaptive, L-stable Rosenbrock-W integrator ROS34PW2 (order 3, embedded order 2, third-order
/// dense output) using the system's tridiagonal acceleration Jacobian. Settings mean what they mean
/// for [`super::Dop853`]; the module docs give the cost of a step.
pub type Ros34pw2 = Adaptive<Ros34pw2Method>;

/// The ROS34PW2 method: its tableau, attempt and dense output, in the shared adaptive core.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Ros34pw2Method;

impl Method for Ros34pw2Method {
    const NAME: &'static str = "ros34pw2";
    const ORDER: i32 = 3;
    /// Safety 0.9, the step shrinks at most fivefold and grows at most fivefold per step, on the
    /// embedded second-order error.
    const CONTROLLER: Controller = Controller {
        exponent: 1.0 / 3.0,
        safety: 0.9,
        max_shrink: 0.2,
        max_growth: 5.0,
        rejection: RejectionForm::MultiplyByFactor,
    };
    type Stepper = Work;
    fn stepper(y0: &[f64], n_pos: usize) -> Work {
        Work::new(y0, n_pos)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::{Control, IntegrateError, Integrator, StepObserver};
    use crate::integrate::{DenseStep, OdeSystem, Tridiagonal};

    /// `x'' = -x` (with an optional quadrature `q' = x²`), Jacobian provided.
    struct Osc {
        quad: bool,
    }
    impl OdeSystem for Osc {
        fn n_pos(&self) -> usize {
            1
        }
        fn n_quad(&self) -> usize {
            self.quad as usize
        }
        fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
            dy[0] = y[1];
            dy[1] = -y[0];
            if self.quad {
                dy[2] = y[0] * y[0];
            }
        }
        fn acceleration_jacobian(
            &self,
            _t: f64,
            _y: &[f64],
            kx: &mut Tridiagonal,
            kv: &mut Tridiagonal,
        ) -> bool {
            kx.diag[0] = -1.0;
            kv.diag[0] = 0.0;
            true
        }
    }

    /// A stiff damped chain of three unit masses: `a = Kx x + Kv v` with springs `k` and dampers
    /// `c`, plus the dissipated power `q' = c Σ Δv²`; the fast modes decay at rates `~ 3c`.
    struct Stiff {
        k: f64,
        c: f64,
        jac_calls: std::cell::Cell<u64>,
        provide: bool,
    }
    impl Stiff {
        fn forces(&self, y: &[f64]) -> [f64; 2] {
            [
                self.k * (y[0] - y[1]) + self.c * (y[3] - y[4]),
                self.k * (y[1] - y[2]) + self.c * (y[4] - y[5]),
            ]
        }
    }
    impl OdeSystem for Stiff {
        fn n_pos(&self) -> usize {
            3
        }
        fn n_quad(&self) -> usize {
            1
        }
        fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
            let f = self.forces(y);
            dy[..3].copy_from_slice(&y[3..6]);
            dy[3] = -f[0];
            dy[4] = f[0] - f[1];
            dy[5] = f[1];
            dy[6] = self.c * ((y[3] - y[4]).powi(2) + (y[4] - y[5]).powi(2));
        }
        fn acceleration_jacobian(
            &self,
            _t: f64,
            _y: &[f64],
            kx: &mut Tridiagonal,
            kv: &mut Tridiagonal,
        ) -> bool {
            if !self.provide {
                return false;
            }
            self.jac_calls.set(self.jac_calls.get() + 1);
            for (m, s) in [(kx, self.k), (kv, self.c)] {
                m.diag.copy_from_slice(&[-s, -2.0 * s, -s]);
                m.lower.copy_from_slice(&[s, s]);
                m.upper.copy_from_slice(&[s, s]);
            }
            true
        }
    }

    struct Record {
        steps: Vec<(f64, f64)>,
        y: Vec<f64>,
        t: f64,
    }
    impl StepObserver for Record {
        fn on_start(&mut self, t0: f64, y0: &[f64]) {
            self.t = t0;
            self.y = y0.to_vec();
        }
        fn on_step(&mut self, s: &dyn DenseStep) -> Control {
            self.steps.push((s.t_start(), s.t_end()));
            self.t = s.t_end();
            self.y = s.y_end().to_vec();
            Control::Continue
        }
    }
    fn record() -> Record {
        Record {
            steps: vec![],
            y: vec![],
            t: 0.0,
        }
    }

    fn fixed(h: f64) -> Ros34pw2 {
        Ros34pw2::new(1e6, 1e6)
            .with_initial_step(h)
            .with_max_step(h)
    }

    #[test]
    fn convergence_order_is_three_on_state_and_quadrature() {
        let t_end = 10.0;
        let err = |nsteps: u32| {
            let mut rec = record();
            let s = fixed(t_end / f64::from(nsteps))
                .integrate(
                    &mut Osc { quad: true },
                    0.0,
                    &[1.0, 0.0, 0.0],
                    t_end,
                    100_000,
                    &mut rec,
                )
                .unwrap();
            assert_eq!(s.steps, u64::from(nsteps));
            let ex = (rec.y[0] - t_end.cos())
                .abs()
                .max((rec.y[1] + t_end.sin()).abs());
            let q = t_end / 2.0 + (2.0 * t_end).sin() / 4.0;
            (ex, (rec.y[2] - q).abs())
        };
        let (x1, q1) = err(100);
        let (x2, q2) = err(200);
        let (px, pq) = ((x1 / x2).log2(), (q1 / q2).log2());
        eprintln!("state order {px} ({x1:e}, {x2:e}); quadrature order {pq} ({q1:e}, {q2:e})");
        assert!((2.7..3.4).contains(&px), "state order {px}");
        assert!((2.7..3.4).contains(&pq), "quadrature order {pq}");
    }

    #[test]
    fn dense_output_is_third_order_and_exact_at_the_ends() {
        struct Mid(f64);
        impl StepObserver for Mid {
            fn on_start(&mut self, _t0: f64, _y0: &[f64]) {}
            fn on_step(&mut self, step: &dyn DenseStep) -> Control {
                let (a, b) = (step.t_start(), step.t_end());
                assert_eq!(step.eval_component(b, 0), step.y_end()[0]);
                assert!((step.eval_component(a, 0) - 1.0).abs() < 1e-15);
                for j in 1..10 {
                    let t = a + (b - a) * f64::from(j) / 10.0;
                    self.0 = self.0.max((step.eval_component(t, 0) - t.cos()).abs());
                }
                Control::Stop
            }
        }
        let e = |h: f64| {
            let mut m = Mid(0.0);
            fixed(h)
                .integrate(&mut Osc { quad: false }, 0.0, &[1.0, 0.0], 10.0, 10, &mut m)
                .unwrap();
            m.0
        };
        let (e1, e2) = (e(0.2), e(0.1));
        let p = (e1 / e2).log2();
        eprintln!("dense local order {p} ({e1:e}, {e2:e})");
        assert!((3.5..4.6).contains(&p), "local dense order {p}");
    }

    #[test]
    fn stiff_decay_takes_large_steps_and_counts_evaluations() {
        // Dampers so strong (rates ~3e8) that an explicit method would need steps ~1e-8; the
        // slow motion (free drift of the centre of mass) is linear, so few steps suffice.
        let mut sys = Stiff {
            k: 1e4,
            c: 1e8,
            jac_calls: Default::default(),
            provide: true,
        };
        let y0 = [1e-3, 0.0, -1e-3, 1.0, -0.5, 0.2, 0.0];
        let mut rec = record();
        let ig = Ros34pw2::new(1e-8, 1e-10);
        let s = ig
            .integrate(&mut sys, 0.0, &y0, 1.0, 100_000, &mut rec)
            .unwrap();
        eprintln!("stiff damped: {s:?}");
        // The ~1e-8 s transient is resolved (it carries the dissipated energy), then the steps
        // grow geometrically: an explicit method would need ~1e8 steps for t = 1.
        assert!(s.steps < 2_000, "{s:?}");
        let (a, b) = *rec.steps.last().unwrap();
        assert!(b - a > 0.05, "last step {}", b - a);
        assert_eq!(s.rhs_evals, 2 + 4 * s.steps + 3 * s.rejected);
        // Common velocity (momentum conservation) and the energy balance: kinetic + spring energy
        // + dissipated work (a quadrature, zero row of W) is conserved.
        let vc = (1.0 - 0.5 + 0.2) / 3.0;
        for i in 3..6 {
            assert!((rec.y[i] - vc).abs() < 1e-7, "{:?}", rec.y);
        }
        let e0 = 0.5 * (1.0 + 0.25 + 0.04) + 0.5 * 1e4 * (1e-6 + 1e-6);
        let y = &rec.y;
        let e1 = 0.5 * (y[3] * y[3] + y[4] * y[4] + y[5] * y[5])
            + 0.5 * 1e4 * ((y[0] - y[1]).powi(2) + (y[1] - y[2]).powi(2))
            + y[6];
        assert!((e1 / e0 - 1.0).abs() < 1e-6, "energy {e0} -> {e1}");
        assert_eq!(
            sys.jac_calls.get(),
            s.steps,
            "one Jacobian per accepted step"
        );

        // Without a Jacobian the same problem is not stiffly stable: far more steps.
        let mut plain = Stiff {
            provide: false,
            ..sys
        };
        let r = ig.integrate(&mut plain, 0.0, &y0, 1e-4, 1_000, &mut record());
        assert!(
            matches!(r, Err(IntegrateError::StepBudget { .. })) || r.unwrap().steps > 10 * s.steps
        );
    }

    #[test]
    fn settings_budget_and_non_finite() {
        let y0 = [1.0, 0.0];
        let run = |ig: Ros34pw2, y0: &[f64], t_end: f64| {
            ig.integrate(&mut Osc { quad: false }, 0.0, y0, t_end, 100, &mut record())
        };
        for ig in [
            Ros34pw2::new(0.0, 1e-6),
            Ros34pw2::new(1e-6, -1.0),
            Ros34pw2::new(1e-6, 1e-6).with_max_step(0.0),
            Ros34pw2 {
                atol_scale: Some(vec![1.0]),
                ..Ros34pw2::new(1e-6, 1e-6)
            },
        ] {
            assert!(matches!(
                run(ig, &y0, 1.0),
                Err(IntegrateError::InvalidSettings(_))
            ));
        }
        assert!(matches!(
            run(Ros34pw2::new(1e-6, 1e-6), &[f64::NAN, 0.0], 1.0),
            Err(IntegrateError::InvalidSettings(_))
        ));
        assert!(matches!(
            run(Ros34pw2::new(1e-6, 1e-6), &y0, 0.0),
            Err(IntegrateError::InvalidSettings(_))
        ));
        let mut rec = record();
        let r = Ros34pw2::new(1e-10, 1e-10).integrate(
            &mut Osc { quad: false },
            0.0,
            &y0,
            20.0,
            5,
            &mut rec,
        );
        assert!(matches!(
            r,
            Err(IntegrateError::StepBudget { max_steps: 5, .. })
        ));
        assert_eq!(rec.steps.len(), 5);

        struct Blow;
        impl OdeSystem for Blow {
            fn n_pos(&self) -> usize {
                0
            }
            fn n_quad(&self) -> usize {
                1
            }
            fn rhs(&mut self, t: f64, _y: &[f64], dy: &mut [f64]) {
                dy[0] = if t > 0.5 { f64::NAN } else { 1.0 };
            }
        }
        let r = Ros34pw2::new(1e-8, 1e-8).integrate(&mut Blow, 0.0, &[0.0], 1.0, 1000, &mut rec);
        assert!(
            matches!(r, Err(IntegrateError::NonFinite { t }) if t <= 0.5),
            "{r:?}"
        );
        assert_eq!(Ros34pw2::new(1e-6, 1e-6).name(), "ros34pw2");
    }

    #[test]
    fn h_max_and_landing_on_t_end() {
        let ig = Ros34pw2::new(1e-4, 1e-4).with_max_step(0.1);
        let mut rec = record();
        ig.integrate(
            &mut Osc { quad: false },
            0.0,
            &[1.0, 0.0],
            3.05,
            1000,
            &mut rec,
        )
        .unwrap();
        for &(a, b) in &rec.steps {
            assert!(b - a <= 0.1 * 1.01 + 1e-15);
        }
        assert_eq!(rec.t, 3.05);
    }
}
