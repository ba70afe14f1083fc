//! The one explicit Runge–Kutta core: every explicit adaptive method is a [`Tableau`] (data) and
//! the little that is truly its own ([`ExplicitMethod`]: how it forms its solution and error norm
//! from the stages, and its continuous extension); the stage loop, the batched dense output with
//! its cached per-component coefficients, FSAL and the [`Stepper`] are written here once.
//!
//! A method whose error estimate is the standard embedded one (the RMS norm of `h Σ e_m k_m`) and
//! whose continuous extension is the standard `y + h Σ_j b_j(θ) k_j` is data alone: its tableau
//! gives the error weights ([`Tableau::error`]) and the interpolant's polynomials
//! ([`Tableau::interpolant`]), and the trait's default methods do the arithmetic, here once, as
//! every such method's published code does it. A method with another norm or another extension
//! (DOP853's combined 5th/3rd-order norm and `CONTD8`) overrides them.
//!
//! Stage `j` of a step of size `h` from `(t, y)` is `k_j = f(t + c_j h, y + h Σ_m a_jm k_m)`,
//! the sum over the non-zero entries of its row in ascending `m`, each term one fused
//! multiply-add where the CPU has it ([`combine`]). Stage 0 is `f(t, y)`, the last stage of the
//! previous step (FSAL); the stage `f(t + h, y_new)` becomes it when a step is accepted.

// Index loops over slices re-sliced to a common length read more clearly than nested zips and let
// LLVM drop the bounds checks.
#![allow(clippy::needless_range_loop)]

use std::cell::Cell;
use std::marker::PhantomData;

use chainsweep_cpu::MulAdd;

use super::adaptive::{Attempt, Rhs, Stepper};
use super::{all_finite, eval_each_at, DenseStep, BATCH_COMPONENTS};

/// One stage of an explicit tableau: its node and the non-zero entries of its row of `A`.
#[derive(Debug, Clone, Copy)]
pub struct Stage {
    /// Node `c`: the stage is evaluated at `t + c·h`, and at exactly the step's end when `c = 1`
    /// (which may differ from `t + h` in the last bit, or be `t_end` itself).
    pub c: f64,
    /// The non-zero `(m, a_m)` of the row, ascending in the stage number `m` (0 is `f(t, y)`).
    pub a: &'static [(usize, f64)],
}

/// An explicit Runge–Kutta method as data: its stages (the weights of its propagated solution are
/// the row of the stage that becomes the next step's first), and where each stage's values are kept.
#[derive(Debug, Clone, Copy)]
pub struct Tableau {
    /// Every stage, in the order they are computed: stage 0 (`f(t, y)`, no row), stages
    /// `1..=attempt` (each attempt), the stage `fsal` (`f(t + h, y_new)`, whose row is the
    /// solution's weights), then the stages of the continuous extension (once a step is accepted).
    pub stages: &'static [Stage],
    /// The last stage an attempt computes before its solution.
    pub attempt: usize,
    /// The stage `f(t + h, y_new)`, the next step's stage 0.
    pub fsal: usize,
    /// Whether each attempt evaluates stage `fsal` (its error estimate uses it) rather than only a
    /// step that passes the error test.
    pub fsal_in_attempt: bool,
    /// The buffer each stage's values are kept in: stages never read together may share one.
    pub buffers: &'static [usize],
    /// The error weights `e` of the standard embedded estimate `h Σ_m e_m k_m` (the embedded
    /// solution's weights less the propagated ones; non-zero entries, ascending in `m`), which
    /// the default [`ExplicitMethod::solution_and_error`] reads; empty for a method that forms
    /// its own error norm.
    pub error: &'static [(usize, f64)],
    /// The standard continuous extension `y(t + θh) = y + h Σ_j b_j(θ) k_j`: for each stage `j`
    /// that enters it (ascending), the coefficients of `θ, θ², …` in `b_j(θ)`, every stage with
    /// as many; the default [`ExplicitMethod::dense_coefficients`] and
    /// [`ExplicitMethod::interpolate`] read it. Empty for a method with its own extension.
    pub interpolant: &'static [(usize, &'static [f64])],
}

impl Tableau {
    /// The weights `b` of the propagated solution `y_new = y + h Σ b_m k_m` (non-zero entries):
    /// the row of the stage `f(t + h, y_new)`.
    pub fn weights(&self) -> &'static [(usize, f64)] {
        self.stages[self.fsal].a
    }

    /// Number of buffers the stages are kept in.
    pub fn n_buffers(&self) -> usize {
        self.buffers.iter().max().map_or(0, |b| b + 1)
    }

    /// The stages of the continuous extension.
    pub fn dense_stages(&self) -> std::ops::Range<usize> {
        self.fsal + 1..self.stages.len()
    }

    /// Right-hand sides per attempt (the stages it computes).
    pub const fn rhs_per_attempt(&self) -> u64 {
        (self.attempt + self.fsal_in_attempt as usize) as u64
    }

    /// Right-hand sides a step that passes the error test adds to its attempt.
    pub const fn rhs_per_acceptance(&self) -> u64 {
        (self.stages.len() - 1 - self.attempt - self.fsal_in_attempt as usize) as u64
    }

    /// Degree in `θ` of the standard continuous extension ([`Tableau::interpolant`]), checked
    /// when the tableau is compiled: every stage's polynomial has as many coefficients, and the
    /// coefficients of the extension fit in [`MAX_DENSE_COEFFICIENTS`].
    pub const fn interpolant_degree(&self) -> usize {
        assert!(
            !self.interpolant.is_empty(),
            "the tableau has no standard continuous extension: the method brings its own"
        );
        let degree = self.interpolant[0].1.len();
        assert!(
            degree >= 1 && degree < MAX_DENSE_COEFFICIENTS && self.interpolant.len() <= MAX_STAGES,
            "the interpolant's coefficients do not fit"
        );
        let mut q = 1;
        while q < self.interpolant.len() {
            assert!(
                self.interpolant[q].1.len() == degree,
                "every stage's polynomial has the same degree"
            );
            q += 1;
        }
        degree
    }
}

/// Largest number of stages a tableau may have (stage 0 and fifteen more).
pub const MAX_STAGES: usize = 16;

/// Largest number of coefficients per component a continuous extension may have.
pub const MAX_DENSE_COEFFICIENTS: usize = 8;

/// What an explicit method brings beyond its tableau.
pub trait ExplicitMethod: Copy + Default + std::fmt::Debug + 'static {
    /// The method's coefficients.
    const TABLEAU: Tableau;
    /// `h·|λ|` above which a step is on the method's stability boundary, for methods that
    /// estimate it (Hairer's test, from the last attempt stage and the FSAL stage, both at the
    /// step's end).
    const STIFFNESS_BOUND: Option<f64> = None;

    /// After stages `1..=attempt` of an attempt of size `h` ending at `t_new`: the solution into
    /// `w.y_new`, stage `fsal` when [`Tableau::fsal_in_attempt`], and the error norm. Returns
    /// `(err, the solution and every stage it evaluated are finite)`. Must be
    /// `#[inline(always)]`.
    ///
    /// By default the standard embedded estimate ([`embedded_error_norm`]): the propagated
    /// solution (fused, as the stages) and the RMS norm of `h Σ e_m k_m` ([`Tableau::error`]).
    #[inline(always)]
    fn solution_and_error<F: MulAdd>(
        w: &mut Work<Self>,
        rhs: &mut Rhs,
        h: f64,
        t_new: f64,
        rtol: f64,
        atol: &[f64],
    ) -> (f64, bool) {
        embedded_error_norm::<Self, F>(w, rhs, h, t_new, rtol, atol)
    }

    /// The continuous extension's coefficients of one component, from its value `y` at the
    /// step's start, `y_new` at its end, and its stage values `k(j)` (every stage, by number).
    /// Linear in `(y, y_new, k)`.
    ///
    /// By default those of the standard extension ([`Tableau::interpolant`]): `y`, then the
    /// coefficient of each power `θ^p`, `h Σ_j b_jp k_j`.
    #[inline(always)]
    fn dense_coefficients(
        h: f64,
        y: f64,
        _y_new: f64,
        k: impl Fn(usize) -> f64,
    ) -> [f64; MAX_DENSE_COEFFICIENTS] {
        standard_dense_coefficients::<Self>(h, y, k)
    }

    /// The interpolant at `s = (t − t0)/h` from a component's coefficients `c(r)`.
    ///
    /// By default the standard extension's polynomial in `s` by Horner's scheme.
    #[inline(always)]
    fn interpolate(c: impl Fn(usize) -> f64, s: f64) -> f64 {
        horner(const { Self::TABLEAU.interpolant_degree() }, c, s)
    }

    /// A bound on how far the interpolant strays from `c[0]` for `s` in `[0, 1]`, exact
    /// arithmetic (`|y(s) − c[0]|`), from a component's coefficients; `None` where the method
    /// gives none ([`DenseStep::component_range`] is then `None`).
    fn interpolant_radius(_c: &[f64; MAX_DENSE_COEFFICIENTS]) -> Option<f64> {
        None
    }
}

/// Units of `f64::EPSILON` of the interpolant's magnitude allowed for the rounding of its
/// evaluation in [`DenseStep::component_range`]: a nested evaluation of degree `d` rounds by at
/// most about `2d` of them (14 for DOP853's degree 7), so this is a wide margin, and still about
/// 1e-14 of the value: far below anything a sample could be told apart by.
const RANGE_ROUNDING_EPS: f64 = 128.0;

/// `out = y + h Σ_m a[m] k[m]`, element by element: the sum from the first entry on, each term one
/// fused multiply-add where the CPU has it.
#[inline(always)]
pub fn combine<F: MulAdd, const S: usize>(
    out: &mut [f64],
    y: &[f64],
    h: f64,
    a: [f64; S],
    k: [&[f64]; S],
) {
    let n = out.len();
    let y = &y[..n];
    let k = k.map(|s| &s[..n]);
    for i in 0..n {
        let mut acc = a[0] * k[0][i];
        for j in 1..S {
            acc = F::mul_add(a[j], k[j][i], acc);
        }
        out[i] = F::mul_add(h, acc, y[i]);
    }
}

/// A row's coefficients and the buffers of its stages, as arrays of a length known at compile time.
#[inline(always)]
pub fn gather<'a, const S: usize>(
    row: &[(usize, f64)],
    k: &'a [Vec<f64>],
    buffers: &[usize],
) -> ([f64; S], [&'a [f64]; S]) {
    // Plain loops: `std::array::from_fn` is not always inlined into the dispatched kernel.
    let mut a = [0.0; S];
    let mut ks: [&[f64]; S] = [&[]; S];
    for m in 0..S {
        a[m] = row[m].1;
        ks[m] = &k[buffers[row[m].0]];
    }
    (a, ks)
}

/// `Σ_m a[m] k[m][i]` as a plain sum from the first entry on (no fused multiply-add): the
/// arithmetic of the published codes' weighted sums.
#[inline(always)]
pub fn weighted_sum<const S: usize>(a: [f64; S], k: [&[f64]; S], i: usize) -> f64 {
    let mut s = a[0] * k[0][i];
    for m in 1..S {
        s += a[m] * k[m][i];
    }
    s
}

/// [`combine`] over a row of a tableau.
#[inline(always)]
pub fn combine_row<F: MulAdd>(
    out: &mut [f64],
    y: &[f64],
    h: f64,
    row: &[(usize, f64)],
    k: &[Vec<f64>],
    buffers: &[usize],
) {
    macro_rules! by_length {
        ($($s:literal)*) => {
            match row.len() {
                $($s => {
                    let (a, ks) = gather::<$s>(row, k, buffers);
                    combine::<F, $s>(out, y, h, a, ks)
                })*
                len => unreachable!("a tableau row of {len} entries"),
            }
        };
    }
    by_length!(1 2 3 4 5 6 7 8 9 10 11 12)
}

/// The standard embedded error estimate of an attempt, the default of
/// [`ExplicitMethod::solution_and_error`]: the propagated solution `y + h Σ b_m k_m` (fused, as the
/// stages) into `w.y_new`, stage `fsal` at `(t_new, y_new)` when the attempt makes it, and the RMS
/// norm of the embedded estimate `h Σ e_m k_m` ([`Tableau::error`]), each component scaled by
/// `atol + rtol max(|y|, |y_new|)`: the scaled components in one vectorised pass, their sum in a
/// second over eight partial sums (a running sum would serialise the first loop).
#[inline(always)]
pub fn embedded_error_norm<M: ExplicitMethod, F: MulAdd>(
    w: &mut Work<M>,
    rhs: &mut Rhs,
    h: f64,
    t_new: f64,
    rtol: f64,
    atol: &[f64],
) -> (f64, bool) {
    let tableau = &M::TABLEAU;
    const {
        assert!(
            !M::TABLEAU.error.is_empty(),
            "the tableau has no error weights: the method brings its own error norm"
        )
    };
    let n = w.y.len();
    let Work {
        y,
        y_new,
        k,
        err_sq: [e_sq, _],
        ..
    } = w;
    let buffers = tableau.buffers;
    combine_row::<F>(&mut y_new[..n], y, h, tableau.weights(), k, buffers);
    let mut finite = all_finite(y_new);
    if tableau.fsal_in_attempt {
        let fsal = buffers[tableau.fsal];
        rhs.eval(t_new, y_new, &mut k[fsal]);
        finite = finite && all_finite(&k[fsal]);
    }
    let scaled = (&y[..n], &y_new[..n], &atol[..n], rtol);
    macro_rules! by_length {
        ($($s:literal)*) => {
            match tableau.error.len() {
                $($s => {
                    let (e, ke) = gather::<$s>(tableau.error, k, buffers);
                    scaled_error_squares(&mut e_sq[..n], scaled, e, ke)
                })*
                len => unreachable!("error weights of {len} entries"),
            }
        };
    }
    by_length!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15);
    let err = h.abs() * (lane_sum(&e_sq[..n]) / n as f64).sqrt();
    (err, finite)
}

/// `e_sq[i] = (Σ_m e[m] k[m][i] / (atol[i] + rtol max(|y[i]|, |y_new[i]|)))²`, the weighted sum
/// plain from the first entry on ([`weighted_sum`]); a component with no tolerance scale (exactly
/// zero, atol 0) is left out (zero).
#[inline(always)]
fn scaled_error_squares<const S: usize>(
    e_sq: &mut [f64],
    (y, y_new, atol, rtol): (&[f64], &[f64], &[f64], f64),
    e: [f64; S],
    ke: [&[f64]; S],
) {
    let n = e_sq.len();
    let ke = ke.map(|s| &s[..n]);
    let (y, y_new, atol) = (&y[..n], &y_new[..n], &atol[..n]);
    for i in 0..n {
        let sk = atol[i] + rtol * y[i].abs().max(y_new[i].abs());
        let inv = if sk > 0.0 { 1.0 / sk } else { 0.0 };
        let e = weighted_sum(e, ke, i) * inv;
        e_sq[i] = e * e;
    }
}

/// The standard continuous extension's coefficients of one component (the default of
/// [`ExplicitMethod::dense_coefficients`]): `y`, then for each power `θ^p` of
/// [`Tableau::interpolant`] `h Σ_j b_jp k_j`, a plain sum over the stages whose coefficient is not
/// zero, from the first on.
#[inline(always)]
pub fn standard_dense_coefficients<M: ExplicitMethod>(
    h: f64,
    y: f64,
    k: impl Fn(usize) -> f64,
) -> [f64; MAX_DENSE_COEFFICIENTS] {
    let degree = const { M::TABLEAU.interpolant_degree() };
    let interpolant = M::TABLEAU.interpolant;
    // Each stage's value read once.
    let mut kv = [0.0; MAX_STAGES];
    for (v, &(j, _)) in kv.iter_mut().zip(interpolant) {
        *v = k(j);
    }
    let mut c = [0.0; MAX_DENSE_COEFFICIENTS];
    c[0] = y;
    for p in 0..degree {
        let mut sum: Option<f64> = None;
        for (q, (_, b)) in interpolant.iter().enumerate() {
            if b[p] != 0.0 {
                let term = b[p] * kv[q];
                sum = Some(sum.map_or(term, |s| s + term));
            }
        }
        c[p + 1] = h * sum.unwrap_or(0.0);
    }
    c
}

/// `c(0) + s (c(1) + s (c(2) + … + s c(degree)))`, the polynomial of degree `degree` in `s` by
/// Horner's scheme (the default of [`ExplicitMethod::interpolate`]).
#[inline(always)]
pub fn horner(degree: usize, c: impl Fn(usize) -> f64, s: f64) -> f64 {
    let mut acc = c(degree);
    for r in (1..degree).rev() {
        acc = c(r) + s * acc;
    }
    c(0) + s * acc
}

/// Sum of a slice in eight interleaved partial sums, which vectorises.
pub fn lane_sum(v: &[f64]) -> f64 {
    let chunks = v.chunks_exact(8);
    let mut acc = [0.0f64; 8];
    let rest: f64 = chunks.remainder().iter().sum();
    for c in chunks {
        for k in 0..8 {
            acc[k] += c[k];
        }
    }
    acc.iter().sum::<f64>() + rest
}

/// An explicit method's work space for one run: every vector the step loop touches, allocated once.
pub struct Work<M> {
    /// State at the start of the current step.
    pub y: Vec<f64>,
    /// Solution at the end of the current step.
    pub y_new: Vec<f64>,
    /// Argument of the stage being evaluated.
    pub ys: Vec<f64>,
    /// The stages' values, in the buffers of [`Tableau::buffers`].
    pub k: Vec<Vec<f64>>,
    /// Scratch for the squared, scaled components of error estimates.
    pub err_sq: [Vec<f64>; 2],
    /// `h·|λ|` of the last accepted step, for methods with a [`ExplicitMethod::STIFFNESS_BOUND`].
    stiffness: f64,
    /// Dense-output coefficients of each component, computed on first use in a step: probes and
    /// event location read a handful of components, so building all of them every step would
    /// cost more than the stages themselves.
    cont: Vec<Cell<[f64; MAX_DENSE_COEFFICIENTS]>>,
    /// Step number for which `cont[i]` holds the coefficients.
    cont_epoch: Vec<Cell<u64>>,
    /// Number of the current dense step (starts at 1 so that no coefficient is valid initially).
    epoch: u64,
    method: PhantomData<M>,
}

impl<M: ExplicitMethod> Work<M> {
    /// Work space for a run from `y0`.
    pub fn new(y0: &[f64]) -> Self {
        const {
            assert!(
                M::TABLEAU.stages.len() <= MAX_STAGES,
                "more stages than the core writes out"
            )
        };
        let n = y0.len();
        let z = || vec![0.0; n];
        Work {
            y: y0.to_vec(),
            y_new: z(),
            ys: z(),
            k: (0..M::TABLEAU.n_buffers()).map(|_| z()).collect(),
            err_sq: [z(), z()],
            stiffness: 0.0,
            cont: vec![Cell::new([0.0; MAX_DENSE_COEFFICIENTS]); n],
            cont_epoch: vec![Cell::new(0); n],
            epoch: 0,
            method: PhantomData,
        }
    }

    /// The values of stage `j`.
    #[inline(always)]
    pub fn stage(&self, j: usize) -> &[f64] {
        &self.k[M::TABLEAU.buffers[j]]
    }

    /// Stages `first..=last` of a step of size `h` from `(t, y)`, in order. Written out stage by
    /// stage for every stage number a tableau may have ([`MAX_STAGES`]), so that each stage's row,
    /// node and buffers are constants of the compiled code, as in a hand-written method.
    #[inline(always)]
    fn stages<F: MulAdd>(
        &mut self,
        rhs: &mut Rhs,
        (first, last): (usize, usize),
        t: f64,
        h: f64,
        t_new: f64,
    ) {
        macro_rules! each_stage {
            ($($j:literal)*) => {
                $(
                    if $j >= first && $j <= last {
                        self.evaluate_stage::<F>(rhs, $j, t, h, t_new);
                    }
                )*
            };
        }
        each_stage!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15);
    }

    /// Stage `j`, evaluated at `t + c·h` (at `t_new` when `c = 1`, with a switch the attempt
    /// lands on held on its side before the crossing; not the FSAL stage, which is the next
    /// step's first derivative, on the side after it).
    #[inline(always)]
    fn evaluate_stage<F: MulAdd>(&mut self, rhs: &mut Rhs, j: usize, t: f64, h: f64, t_new: f64) {
        let tableau = &M::TABLEAU;
        let stage = &tableau.stages[j];
        combine_row::<F>(&mut self.ys, &self.y, h, stage.a, &self.k, tableau.buffers);
        let t_stage = if stage.c == 1.0 {
            t_new
        } else {
            t + stage.c * h
        };
        if stage.c == 1.0 && j != tableau.fsal {
            rhs.eval_end(t_stage, &self.ys, &mut self.k[tableau.buffers[j]]);
        } else {
            rhs.eval(t_stage, &self.ys, &mut self.k[tableau.buffers[j]]);
        }
    }

    /// Hairer's stiffness estimate `h·|λ| ≈ h ‖f(y_new) − f(ys)‖ / ‖y_new − ys‖`, where `ys` is
    /// the argument of the last attempt stage (also at the step's end). Eight interleaved partial
    /// sums, so that the loop vectorises (a running sum would serialise it); only a diagnostic
    /// depends on the rounding. Inlined into the dispatched kernel, for its vector width.
    #[inline(always)]
    fn stiffness_estimate(&self, h: f64) -> f64 {
        let n = self.y.len();
        let tableau = &M::TABLEAU;
        let (f_end, f_last) = (
            &self.stage(tableau.fsal)[..n],
            &self.stage(tableau.attempt)[..n],
        );
        let (y_new, ys) = (&self.y_new[..n], &self.ys[..n]);
        let (mut num_lanes, mut den_lanes) = ([0.0f64; 8], [0.0f64; 8]);
        let (ca, cb) = (f_end.chunks_exact(8), f_last.chunks_exact(8));
        let (cy, cs) = (y_new.chunks_exact(8), ys.chunks_exact(8));
        let rest = (
            ca.remainder(),
            cb.remainder(),
            cy.remainder(),
            cs.remainder(),
        );
        for (((a, b), c), d) in ca.zip(cb).zip(cy).zip(cs) {
            for k in 0..8 {
                num_lanes[k] += (a[k] - b[k]) * (a[k] - b[k]);
                den_lanes[k] += (c[k] - d[k]) * (c[k] - d[k]);
            }
        }
        for (((a, b), c), d) in rest.0.iter().zip(rest.1).zip(rest.2).zip(rest.3) {
            num_lanes[0] += (a - b) * (a - b);
            den_lanes[0] += (c - d) * (c - d);
        }
        let num: f64 = num_lanes.iter().sum();
        let den: f64 = den_lanes.iter().sum();
        if den > 0.0 {
            h * (num / den).sqrt()
        } else {
            0.0
        }
    }
}

impl<M: ExplicitMethod> Stepper for Work<M> {
    type Dense<'a> = ExplicitStep<'a, M>;

    fn start(&mut self, rhs: &mut Rhs, t0: f64) -> bool {
        let first = M::TABLEAU.buffers[0];
        rhs.eval_end(t0, &self.y, &mut self.k[first]);
        all_finite(&self.k[first])
    }
    fn y(&self) -> &[f64] {
        &self.y
    }
    fn f0(&self) -> &[f64] {
        self.stage(0)
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
        t_new: f64,
        rtol: f64,
        atol: &[f64],
    ) -> Attempt {
        self.stages::<F>(rhs, (1, M::TABLEAU.attempt), t, h, t_new);
        let (err, finite) = M::solution_and_error::<F>(self, rhs, h, t_new, rtol, atol);
        Attempt { err, finite }
    }
    /// The FSAL stage (unless the attempt made it), the stiffness estimate, and the stages of the
    /// continuous extension.
    #[inline(always)]
    fn prepare_dense<F: MulAdd>(&mut self, rhs: &mut Rhs, t: f64, h: f64, t_new: f64) -> bool {
        let tableau = &M::TABLEAU;
        let mut finite = true;
        if !tableau.fsal_in_attempt {
            let fsal = tableau.buffers[tableau.fsal];
            rhs.eval(t_new, &self.y_new, &mut self.k[fsal]);
            finite = all_finite(&self.k[fsal]);
        }
        if M::STIFFNESS_BOUND.is_some() {
            self.stiffness = self.stiffness_estimate(h);
        }
        let dense = tableau.dense_stages();
        if !dense.is_empty() {
            self.stages::<F>(rhs, (dense.start, dense.end - 1), t, h, t_new);
        }
        self.epoch += 1;
        finite && dense.clone().all(|j| all_finite(self.stage(j)))
    }
    fn finish(&mut self, _rhs: &mut Rhs, _t_new: f64) -> bool {
        true
    }
    fn dense(&self, t0: f64, t1: f64, h: f64) -> ExplicitStep<'_, M> {
        ExplicitStep { t0, t1, h, w: self }
    }
    fn advance(&mut self) {
        let tableau = &M::TABLEAU;
        std::mem::swap(&mut self.y, &mut self.y_new);
        self.k
            .swap(tableau.buffers[0], tableau.buffers[tableau.fsal]);
    }
    fn state_mut(&mut self) -> (&mut [f64], &mut [f64]) {
        let first = M::TABLEAU.buffers[0];
        (&mut self.y, &mut self.k[first])
    }
    fn on_stability_boundary(&self) -> Option<bool> {
        M::STIFFNESS_BOUND.map(|bound| self.stiffness > bound)
    }
}

/// The interpolant handed to the observer: the method's continuous extension on one accepted step.
pub struct ExplicitStep<'a, M> {
    t0: f64,
    t1: f64,
    h: f64,
    w: &'a Work<M>,
}

impl<M: ExplicitMethod> ExplicitStep<'_, M> {
    /// The continuous extension's coefficients of component `i`, computed from the stages of
    /// this step on first use and cached until the next step.
    #[inline(always)]
    fn coefficients(&self, i: usize) -> [f64; MAX_DENSE_COEFFICIENTS] {
        let w = self.w;
        if w.cont_epoch[i].get() == w.epoch {
            return w.cont[i].get();
        }
        self.compute_coefficients(i)
    }

    /// [`ExplicitStep::coefficients`] on first use in a step (kept out of line: the cached case
    /// is the frequent one, several samples per step).
    #[inline(never)]
    fn compute_coefficients(&self, i: usize) -> [f64; MAX_DENSE_COEFFICIENTS] {
        let w = self.w;
        let buffers = M::TABLEAU.buffers;
        let c = M::dense_coefficients(self.h, w.y[i], w.y_new[i], |j| w.k[buffers[j]][i]);
        w.cont[i].set(c);
        w.cont_epoch[i].set(w.epoch);
        c
    }
}

impl<M: ExplicitMethod> DenseStep for ExplicitStep<'_, M> {
    fn t_start(&self) -> f64 {
        self.t0
    }
    fn t_end(&self) -> f64 {
        self.t1
    }
    fn y_end(&self) -> &[f64] {
        &self.w.y_new
    }
    fn eval_component(&self, t: f64, i: usize) -> f64 {
        if t == self.t1 {
            return self.w.y_new[i];
        }
        let s = (t - self.t0) / self.h;
        let c = self.coefficients(i);
        M::interpolate(|r| c[r], s)
    }
    fn eval_components(&self, t: f64, indices: &[usize], out: &mut [f64]) {
        if t == self.t1 {
            for &i in indices {
                out[i] = self.w.y_new[i];
            }
            return;
        }
        let s = (t - self.t0) / self.h;
        for &i in indices {
            let c = self.coefficients(i);
            out[i] = M::interpolate(|r| c[r], s);
        }
    }
    fn component_range(&self, i: usize) -> Option<(f64, f64)> {
        let c = self.coefficients(i);
        let r = M::interpolant_radius(&c)?;
        let slack = RANGE_ROUNDING_EPS * f64::EPSILON * (c[0].abs() + r);
        let (lo, hi) = (c[0] - r - slack, c[0] + r + slack);
        if !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        // The step's end is read as it is, not interpolated.
        let end = self.w.y_new[i];
        Some((lo.min(end), hi.max(end)))
    }
    fn eval_components_at(&self, times: &[f64], indices: &[usize], out: &mut [f64]) {
        let m = indices.len();
        if m > BATCH_COMPONENTS || m == 0 {
            return eval_each_at(self, times, indices, out);
        }
        // The coefficients of the components side by side (row r: coefficient r of each), so
        // that one sample evaluates the interpolant for all of them in vector lanes; the
        // arithmetic of each lane is the scalar interpolant's, operation for operation (sums
        // and products, no fused ones: the same bits at every vector width).
        let mut c = [[0.0f64; BATCH_COMPONENTS]; MAX_DENSE_COEFFICIENTS];
        for (j, &i) in indices.iter().enumerate() {
            for (r, v) in self.coefficients(i).into_iter().enumerate() {
                c[r][j] = v;
            }
        }
        chainsweep_cpu::dispatch(InterpolateKernel::<M> {
            step: self,
            c: &c,
            times,
            indices,
            out,
        });
    }
}

/// The batched interpolant's loop over the samples, compiled for the CPU's vector width.
struct InterpolateKernel<'a, 'w, M> {
    step: &'a ExplicitStep<'w, M>,
    c: &'a [[f64; BATCH_COMPONENTS]; MAX_DENSE_COEFFICIENTS],
    times: &'a [f64],
    indices: &'a [usize],
    out: &'a mut [f64],
}

impl<M: ExplicitMethod> chainsweep_cpu::Kernel for InterpolateKernel<'_, '_, M> {
    type Output = ();
    #[inline(always)]
    fn run<F: MulAdd>(self) {
        let (step, c, indices) = (self.step, self.c, self.indices);
        let m = indices.len();
        // Whole vectors of eight lanes (the lanes past `m` hold zeros and are not read).
        let width = m.div_ceil(8) * 8;
        for (&t, row) in self.times.iter().zip(self.out.chunks_exact_mut(m)) {
            if t == step.t1 {
                for (o, &i) in row.iter_mut().zip(indices) {
                    *o = step.w.y_new[i];
                }
                continue;
            }
            let s = (t - step.t0) / step.h;
            let mut lanes = [0.0f64; BATCH_COMPONENTS];
            for (j, lane) in lanes[..width].iter_mut().enumerate() {
                *lane = M::interpolate(|r| c[r][j], s);
            }
            row.copy_from_slice(&lanes[..m]);
        }
    }
}
