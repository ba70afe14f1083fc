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

// The coefficients are kept with all the digits published, more than an f64 always holds.
#![allow(clippy::excessive_precision)]
// Index loops over equal-length slices read more clearly here than nested zips.
#![allow(clippy::needless_range_loop)]

use chainsweep_cpu::MulAdd;

use super::adaptive::{Adaptive, Attempt, Controller, Method, RejectionForm, Rhs, Stepper};
use super::{all_finite, DenseStep, Tridiagonal};

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

// ---------------------------------------------------------------------------------------------
// Coefficients of ROS34PW2 (Rang & Angermann 2005), as registered by PETSc (TSROSWRA34PW2), in the
// k-form: k_i = h f(y0 + Σ_j α_ij k_j) + h W Σ_j γ_ij k_j, y1 = y0 + Σ b_i k_i.
// ---------------------------------------------------------------------------------------------

/// Number of stages.
const S: usize = 4;
/// Degree of the dense-output polynomials in θ.
const P: usize = 3;
/// Diagonal of Γ.
const GAMMA: f64 = 4.358_665_215_084_59e-1;

const ALPHA: [[f64; S]; S] = [
    [0.0, 0.0, 0.0, 0.0],
    [8.717_330_430_169_180_1e-1, 0.0, 0.0, 0.0],
    [
        8.445_706_001_536_942_3e-1,
        -1.129_906_423_648_418_5e-1,
        0.0,
        0.0,
    ],
    [0.0, 0.0, 1.0, 0.0],
];

const GAMMA_TABLE: [[f64; S]; S] = [
    [GAMMA, 0.0, 0.0, 0.0],
    [-8.717_330_430_169_180_1e-1, GAMMA, 0.0, 0.0],
    [
        -9.033_805_701_304_408_2e-1,
        5.418_067_238_809_532_6e-2,
        GAMMA,
        0.0,
    ],
    [
        2.421_238_070_609_534_6e-1,
        -1.223_250_583_904_514_7,
        5.452_602_553_351_021_4e-1,
        GAMMA,
    ],
];

const B: [f64; S] = [
    2.421_238_070_609_534_6e-1,
    -1.223_250_583_904_514_7,
    1.545_260_255_335_102,
    GAMMA,
];

const B_EMBEDDED: [f64; S] = [
    3.781_090_314_581_936_9e-1,
    -9.604_229_221_242_317_8e-2,
    0.5,
    2.179_332_607_542_295e-1,
];

/// Dense output in the k-form: `y(θ) = y0 + Σ_i (Σ_p BINTERP[i][p] θ^{p+1}) k_i`.
const BINTERP: [[f64; P]; S] = [
    [
        1.056_429_845_579_409_4,
        -1.386_488_269_975_957_3,
        0.572_182_231_457_501_6,
    ],
    [
        2.296_429_974_281_067,
        -8.262_611_700_275_677,
        4.742_931_142_090_097,
    ],
    [
        -1.307_599_564_525_376,
        7.250_979_895_056_055,
        -4.398_120_075_195_578,
    ],
    [
        -1.045_260_255_335_102,
        2.398_120_075_195_581,
        -0.916_993_298_352_019_9,
    ],
];

/// The tables of the transformed formulation (stage vectors `u = Γ k`), derived from the k-form.
#[derive(Debug, Clone, Copy)]
struct Tableau {
    /// `A = α Γ⁻¹`: `Y_i = y0 + Σ_{j<i} a_ij u_j`.
    a: [[f64; S]; S],
    /// `C = diag(1/γ) − Γ⁻¹` (strictly lower part): `+ Σ_{j<i} (c_ij/h) u_j` on the right.
    c: [[f64; S]; S],
    /// `m = b Γ⁻¹`: `y1 = y0 + Σ m_j u_j`.
    m: [f64; S],
    /// `m − m̂`: the error estimate `y1 − ŷ1 = Σ e_j u_j`.
    e: [f64; S],
    /// Stage abscissae `α_i = Σ_j α_ij`.
    alpha: [f64; S],
    /// Dense output: `y(θ) = y0 + Σ_j (Σ_p d[j][p] θ^{p+1}) u_j`.
    d: [[f64; P]; S],
}

impl Tableau {
    fn new() -> Self {
        // Γ⁻¹ of the lower-triangular Γ by forward substitution, column by column.
        let mut ginv = [[0.0; S]; S];
        for col in 0..S {
            for i in 0..S {
                let mut s = if i == col { 1.0 } else { 0.0 };
                for k in 0..i {
                    s -= GAMMA_TABLE[i][k] * ginv[k][col];
                }
                ginv[i][col] = s / GAMMA_TABLE[i][i];
            }
        }
        let mut t = Tableau {
            a: [[0.0; S]; S],
            c: [[0.0; S]; S],
            m: [0.0; S],
            e: [0.0; S],
            alpha: [0.0; S],
            d: [[0.0; P]; S],
        };
        for i in 0..S {
            for j in 0..S {
                t.a[i][j] = (0..S).map(|k| ALPHA[i][k] * ginv[k][j]).sum();
                if j < i {
                    t.c[i][j] = -ginv[i][j];
                }
            }
            t.alpha[i] = ALPHA[i].iter().sum();
        }
        for j in 0..S {
            t.m[j] = (0..S).map(|i| B[i] * ginv[i][j]).sum();
            let m_hat: f64 = (0..S).map(|i| B_EMBEDDED[i] * ginv[i][j]).sum();
            t.e[j] = t.m[j] - m_hat;
            for p in 0..P {
                t.d[j][p] = (0..S).map(|i| BINTERP[i][p] * ginv[i][j]).sum();
            }
        }
        t
    }
}

// ---------------------------------------------------------------------------------------------
// Tridiagonal LU with partial pivoting (LAPACK dgttrf/dgtts2), factor once, solve per stage.
// ---------------------------------------------------------------------------------------------

/// LU factors of a tridiagonal matrix of order `n`.
#[derive(Debug, Clone, Default)]
struct TriLu {
    /// Multipliers (`n-1`).
    dl: Vec<f64>,
    /// Diagonal of U (`n`).
    d: Vec<f64>,
    /// First super-diagonal of U (`n-1`).
    du: Vec<f64>,
    /// Second super-diagonal of U, fill-in from interchanges (`n-2`).
    du2: Vec<f64>,
    /// Whether rows `i` and `i+1` were interchanged at step `i`.
    swap: Vec<bool>,
}

impl TriLu {
    fn new(n: usize) -> Self {
        TriLu {
            dl: vec![0.0; n.saturating_sub(1)],
            d: vec![0.0; n],
            du: vec![0.0; n.saturating_sub(1)],
            du2: vec![0.0; n.saturating_sub(2)],
            swap: vec![false; n.saturating_sub(1)],
        }
    }

    /// Factorises `I − a Kv − b Kx`. Returns `false` if a pivot is zero or not finite.
    fn factor(&mut self, kx: &Tridiagonal, kv: &Tridiagonal, a: f64, b: f64) -> bool {
        let n = self.d.len();
        for i in 0..n {
            self.d[i] = 1.0 - a * kv.diag[i] - b * kx.diag[i];
        }
        for i in 0..n.saturating_sub(1) {
            self.dl[i] = -a * kv.lower[i] - b * kx.lower[i];
            self.du[i] = -a * kv.upper[i] - b * kx.upper[i];
            self.swap[i] = false;
        }
        self.du2.iter_mut().for_each(|x| *x = 0.0);
        for i in 0..n.saturating_sub(1) {
            if self.d[i].abs() >= self.dl[i].abs() {
                // No interchange (always the case for a diagonally dominant matrix): Thomas.
                if self.d[i] != 0.0 {
                    let fact = self.dl[i] / self.d[i];
                    self.dl[i] = fact;
                    self.d[i + 1] -= fact * self.du[i];
                }
            } else {
                let fact = self.d[i] / self.dl[i];
                self.d[i] = self.dl[i];
                self.dl[i] = fact;
                let temp = self.du[i];
                self.du[i] = self.d[i + 1];
                self.d[i + 1] = temp - fact * self.d[i + 1];
                if i + 2 < n {
                    self.du2[i] = self.du[i + 1];
                    self.du[i + 1] *= -fact;
                }
                self.swap[i] = true;
            }
        }
        self.d.iter().all(|p| *p != 0.0 && p.is_finite())
    }

    /// Solves in place with the factors.
    fn solve(&self, b: &mut [f64]) {
        let n = self.d.len();
        if n == 0 {
            return;
        }
        for i in 0..n - 1 {
            if self.swap[i] {
                let temp = b[i];
                b[i] = b[i + 1];
                b[i + 1] = temp - self.dl[i] * b[i];
            } else {
                b[i + 1] -= self.dl[i] * b[i];
            }
        }
        b[n - 1] /= self.d[n - 1];
        if n > 1 {
            b[n - 2] = (b[n - 2] - self.du[n - 2] * b[n - 1]) / self.d[n - 2];
        }
        for i in (0..n.saturating_sub(2)).rev() {
            b[i] = (b[i] - self.du[i] * b[i + 1] - self.du2[i] * b[i + 2]) / self.d[i];
        }
    }
}

/// `out = M r` for a tridiagonal `M`.
fn tri_mul(m: &Tridiagonal, r: &[f64], out: &mut [f64]) {
    let n = m.diag.len();
    for i in 0..n {
        let mut s = m.diag[i] * r[i];
        if i > 0 {
            s += m.lower[i - 1] * r[i - 1];
        }
        if i + 1 < n {
            s += m.upper[i] * r[i + 1];
        }
        out[i] = s;
    }
}

// ---------------------------------------------------------------------------------------------
// Work space.
// ---------------------------------------------------------------------------------------------

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
    fn new(y0: &[f64], np: usize) -> Self {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::OdeSystem;
    use crate::integrate::{Control, IntegrateError, Integrator, StepObserver};

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
    fn tableau_satisfies_the_order_conditions() {
        // k-form conditions with β_ij = α_ij + γ_ij: order 3 (Hairer & Wanner, Table IV.7.1).
        let beta = |i: usize, j: usize| ALPHA[i][j] + GAMMA_TABLE[i][j];
        let alpha: Vec<f64> = (0..S).map(|i| ALPHA[i].iter().sum()).collect();
        let beta_sum: Vec<f64> = (0..S).map(|i| (0..i).map(|j| beta(i, j)).sum()).collect();
        let sb: f64 = B.iter().sum();
        assert!((sb - 1.0).abs() < 1e-14);
        let o2: f64 = (0..S).map(|i| B[i] * beta_sum[i]).sum();
        assert!((o2 - (0.5 - GAMMA)).abs() < 1e-14, "{o2}");
        let o3a: f64 = (0..S).map(|i| B[i] * alpha[i] * alpha[i]).sum();
        assert!((o3a - 1.0 / 3.0).abs() < 1e-14, "{o3a}");
        let o3b: f64 = (0..S)
            .map(|i| B[i] * (0..i).map(|k| beta(i, k) * beta_sum[k]).sum::<f64>())
            .sum();
        let rhs = 1.0 / 6.0 - GAMMA + GAMMA * GAMMA;
        assert!((o3b - rhs).abs() < 1e-14, "{o3b} vs {rhs}");
        // W-method: the explicit part alone is a third-order Runge–Kutta method, which is what
        // keeps the quadratures (zero rows of W) third-order.
        let w2: f64 = (0..S).map(|i| B[i] * alpha[i]).sum();
        assert!((w2 - 0.5).abs() < 1e-14, "{w2}");
        let w3: f64 = (0..S)
            .map(|i| B[i] * (0..i).map(|k| ALPHA[i][k] * alpha[k]).sum::<f64>())
            .sum();
        assert!((w3 - 1.0 / 6.0).abs() < 1e-14, "{w3}");
        // Embedded method: order 2.
        let sbh: f64 = B_EMBEDDED.iter().sum();
        assert!((sbh - 1.0).abs() < 1e-14);
        let o2h: f64 = (0..S).map(|i| B_EMBEDDED[i] * beta_sum[i]).sum();
        assert!((o2h - (0.5 - GAMMA)).abs() < 1e-14);
        // Dense output reproduces b at θ = 1; transformed tables are consistent.
        let tab = Tableau::new();
        for i in 0..S {
            let s: f64 = BINTERP[i].iter().sum();
            assert!((s - B[i]).abs() < 1e-14, "binterp row {i}: {s}");
            let d1: f64 = tab.d[i].iter().sum();
            assert!((d1 - tab.m[i]).abs() < 1e-12 * tab.m[i].abs().max(1.0));
        }
        // L-stability: R(∞) = 1 − bᵀ β⁻¹ 1 = 0 with β = α + Γ (lower triangular).
        let r_inf = |b: &[f64; S]| {
            let mut x = [0.0; S];
            for i in 0..S {
                x[i] = (1.0 - (0..i).map(|j| beta(i, j) * x[j]).sum::<f64>()) / beta(i, i);
            }
            1.0 - (0..S).map(|i| b[i] * x[i]).sum::<f64>()
        };
        let (r, r_hat) = (r_inf(&B), r_inf(&B_EMBEDDED));
        eprintln!("R(inf) = {r:e}, embedded {r_hat}");
        assert!(r.abs() < 1e-13, "R(inf) = {r}");
    }

    #[test]
    fn tridiagonal_solver_with_and_without_pivoting() {
        let kx = Tridiagonal {
            lower: vec![3.0, -1.0, 2.0],
            diag: vec![0.5, -2.0, 1.0, 4.0],
            upper: vec![5.0, 0.25, -3.0],
        };
        let kv = Tridiagonal::zeros(4);
        // M = I − b kx with b = 1: not diagonally dominant, rows get interchanged.
        let mut lu = TriLu::new(4);
        assert!(lu.factor(&kx, &kv, 0.0, 1.0));
        assert!(lu.swap.iter().any(|s| *s));
        let x = [1.0, -2.0, 0.5, 3.0];
        let m = |i: usize, j: usize| {
            let k = if i == j {
                kx.diag[i]
            } else if j == i + 1 {
                kx.upper[i]
            } else if i == j + 1 {
                kx.lower[j]
            } else {
                0.0
            };
            f64::from(u8::from(i == j)) - k
        };
        let mut b: Vec<f64> = (0..4)
            .map(|i| (0..4).map(|j| m(i, j) * x[j]).sum())
            .collect();
        lu.solve(&mut b);
        for i in 0..4 {
            assert!((b[i] - x[i]).abs() < 1e-13, "{b:?}");
        }
        // A singular matrix is reported.
        let one = Tridiagonal {
            lower: vec![0.0],
            diag: vec![1.0, 1.0],
            upper: vec![0.0],
        };
        let mut lu = TriLu::new(2);
        assert!(!lu.factor(&one, &Tridiagonal::zeros(2), 0.0, 1.0));
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
