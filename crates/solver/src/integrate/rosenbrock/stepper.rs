//! One step of ROS34PW2 on the adaptive core: the work space allocated once per run ([`Work`]),
//! an attempt (four stages, three right-hand sides, one factorisation), the error norm, and the
//! third-order dense output ([`RosStep`]). Apart from the coefficients and the linear algebra
//! because it is where the state is touched, which the integration tests check as a whole.

use chainsweep_cpu::MulAdd;

use crate::integrate::adaptive::{Attempt, Rhs, Stepper};
use crate::integrate::{all_finite, DenseStep, Tridiagonal};

use super::linalg::{tri_mul, TriLu};
use super::tableau::{Tableau, GAMMA, S};

/// Every vector the step loop touches, allocated once per run.
pub struct Work {
    /// Number of positions.
    np: usize,
    /// State at the start of the current step.
    y: Vec<f64>,
    /// Solution at the end of the current step.
    y_new: Vec<f64>,
    /// `f(t, y)`: stage 1.
    f0: Vec<f64>,
    /// `f(t_new, y_new)`, the next step's stage 1.
    f_new: Vec<f64>,
    /// Argument of the stage being evaluated.
    ys: Vec<f64>,
    /// Right-hand side of the stage being evaluated, then of its linear system.
    r: Vec<f64>,
    /// Transformed stage vectors.
    u: [Vec<f64>; S],
    /// `Kx r_x`, scratch of length `np`.
    kr: Vec<f64>,
    kx: Tridiagonal,
    kv: Tridiagonal,
    /// Whether the system provides a Jacobian.
    has_jacobian: bool,
    lu: TriLu,
    /// The Jacobian in `kx`, `kv` is the one at the current step's start point (rejected attempts
    /// and event retakes from the same point reuse it).
    jacobian_current: bool,
    tab: Tableau,
}

impl Work {
    pub(super) fn new(y0: &[f64], np: usize) -> Self {
        let n = y0.len();
        let z = || vec![0.0; n];
        Work {
            np,
            y: y0.to_vec(),
            y_new: z(),
            f0: z(),
            f_new: z(),
            ys: z(),
            r: z(),
            u: [z(), z(), z(), z()],
            kr: vec![0.0; np],
            kx: Tridiagonal::zeros(np),
            kv: Tridiagonal::zeros(np),
            has_jacobian: false,
            lu: TriLu::new(np),
            jacobian_current: false,
            tab: Tableau::new(),
        }
    }

    /// Solves `(I/(γh) − W) z = r` in place in `r`, with the factorisation of
    /// `I − γh Kv − (γh)² Kx` done for this `h`.
    fn solve_in_place(&mut self, gh: f64) {
        let np = self.np;
        let Work { r, kr, kx, lu, .. } = self;
        let (rx, rest) = r.split_at_mut(np);
        let (rv, rq) = rest.split_at_mut(np);
        if np > 0 {
            tri_mul(kx, rx, kr);
            for i in 0..np {
                rv[i] = gh * (rv[i] + gh * kr[i]);
            }
            lu.solve(rv);
            for i in 0..np {
                rx[i] = gh * (rx[i] + rv[i]);
            }
        }
        for q in rq.iter_mut() {
            *q *= gh;
        }
    }

    /// The Jacobian at the step's start into `kx`, `kv`, unless it is there already.
    fn update_jacobian(&mut self, rhs: &Rhs, t: f64) {
        if self.jacobian_current {
            return;
        }
        self.has_jacobian =
            self.np > 0 && rhs.acceleration_jacobian(t, &self.y, &mut self.kx, &mut self.kv);
        if !self.has_jacobian {
            // No Jacobian: W = [[0, I], [0, 0]], still a third-order W-method.
            for m in [&mut self.kx, &mut self.kv] {
                m.lower.iter_mut().for_each(|e| *e = 0.0);
                m.diag.iter_mut().for_each(|e| *e = 0.0);
                m.upper.iter_mut().for_each(|e| *e = 0.0);
            }
        }
        self.jacobian_current = true;
    }

    /// One attempt of size `h` from `(t, y)` with `f0 = f(t, y)` and the Jacobian at `y` in
    /// `kx`, `kv`: the solution into `y_new` and the RMS error norm. Exactly three right-hand-side
    /// evaluations. Returns `None` if the iteration matrix is singular or not finite, else
    /// `Some((err, y_new is finite))`.
    #[inline(always)]
    fn attempt(
        &mut self,
        sys: &mut Rhs,
        t: f64,
        h: f64,
        rtol: f64,
        atol: &[f64],
    ) -> Option<(f64, bool)> {
        self.update_jacobian(sys, t);
        let tab = self.tab;
        let n = self.y.len();
        let gh = GAMMA * h;
        let factored = self.lu.factor(&self.kx, &self.kv, gh, gh * gh);
        for i in 0..S {
            if i == 0 {
                self.r.copy_from_slice(&self.f0);
            } else {
                for k in 0..n {
                    let mut s = self.y[k];
                    for j in 0..i {
                        s += tab.a[i][j] * self.u[j][k];
                    }
                    self.ys[k] = s;
                }
                sys.eval(t + tab.alpha[i] * h, &self.ys, &mut self.r);
                for j in 0..i {
                    let cj = tab.c[i][j] / h;
                    let (r, u) = (&mut self.r, &self.u[j]);
                    for k in 0..n {
                        r[k] += cj * u[k];
                    }
                }
            }
            self.solve_in_place(gh);
            std::mem::swap(&mut self.r, &mut self.u[i]);
        }
        if !factored {
            return None;
        }
        let mut err = 0.0;
        let mut counted = 0usize;
        let mut finite = true;
        for k in 0..n {
            let mut yn = self.y[k];
            let mut e = 0.0;
            for j in 0..S {
                yn += tab.m[j] * self.u[j][k];
                e += tab.e[j] * self.u[j][k];
            }
            self.y_new[k] = yn;
            finite &= yn.is_finite();
            let sk = atol[k] + rtol * self.y[k].abs().max(yn.abs());
            if sk > 0.0 {
                let x = e / sk;
                err += x * x;
                counted += 1;
            }
        }
        let err = if counted == 0 {
            0.0
        } else {
            (err / n as f64).sqrt()
        };
        Some((err, finite))
    }
}

/// The interpolant handed to the observer: the method's third-order continuous extension.
pub struct RosStep<'a> {
    t0: f64,
    t1: f64,
    h: f64,
    w: &'a Work,
}

impl DenseStep for RosStep<'_> {
    fn t_start(&self) -> f64 {
        self.t0
    }
    fn t_end(&self) -> f64 {
        self.t1
    }
    fn y_end(&self) -> &[f64] {
        &self.w.y_new
    }
    #[inline]
    fn eval_component(&self, t: f64, i: usize) -> f64 {
        if t == self.t1 {
            return self.w.y_new[i];
        }
        let th = (t - self.t0) / self.h;
        let mut s = self.w.y[i];
        for j in 0..S {
            let d = &self.w.tab.d[j];
            s += th * (d[0] + th * (d[1] + th * d[2])) * self.w.u[j][i];
        }
        s
    }
}

impl Stepper for Work {
    type Dense<'a> = RosStep<'a>;

    fn start(&mut self, rhs: &mut Rhs, t0: f64) -> bool {
        rhs.eval(t0, &self.y, &mut self.f0);
        all_finite(&self.f0)
    }
    fn y(&self) -> &[f64] {
        &self.y
    }
    fn f0(&self) -> &[f64] {
        &self.f0
    }
    fn y_new(&self) -> &[f64] {
        &self.y_new
    }
    #[inline(always)]
    fn attempt<F: MulAdd>(
        &mut self,
        rhs: &mut Rhs,
        t: f64,
        h: f64,
        _t_new: f64,
        rtol: f64,
        atol: &[f64],
    ) -> Attempt {
        match Work::attempt(self, rhs, t, h, rtol, atol) {
            Some((err, finite)) => Attempt { err, finite },
            None => Attempt {
                err: f64::INFINITY,
                finite: false,
            },
        }
    }
    #[inline(always)]
    fn prepare_dense<F: MulAdd>(&mut self, _rhs: &mut Rhs, _t: f64, _h: f64, _t_new: f64) -> bool {
        // The dense output is built from the stage vectors alone.
        true
    }
    fn finish(&mut self, rhs: &mut Rhs, t_new: f64) -> bool {
        rhs.eval(t_new, &self.y_new, &mut self.f_new);
        all_finite(&self.f_new)
    }
    fn dense(&self, t0: f64, t1: f64, h: f64) -> RosStep<'_> {
        RosStep { t0, t1, h, w: self }
    }
    fn advance(&mut self) {
        std::mem::swap(&mut self.y, &mut self.y_new);
        std::mem::swap(&mut self.f0, &mut self.f_new);
        self.jacobian_current = false;
    }
    fn state_mut(&mut self) -> (&mut [f64], &mut [f64]) {
        self.jacobian_current = false;
        (&mut self.y, &mut self.f0)
    }
}
