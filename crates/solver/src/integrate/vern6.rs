//! Verner's "most efficient" 6(5) pair with its 6th-order interpolant: J. H. Verner,
//! *Numerically optimal Runge–Kutta pairs with interpolants*, Numer. Algorithms 53 (2010)
//! 383–396, the pair `RKV65.IIIXb` ("efficient") of his published tableaus.
//!
//! Nine stages, the ninth `f(t + h, y_new)` being the first of the next step (FSAL): eight
//! right-hand sides per attempted step. The 6th-order solution is propagated; the 5th-order
//! embedded solution (which uses the ninth stage) gives the error estimate, controlled with the
//! exponent 1/6. The continuous extension of order 6 needs three more stages (at `t + h/2`,
//! `t + 0.828 h` and `t + 0.28 h`), computed once a step passes the error test: eleven right-hand
//! sides per accepted step. They are not deferred to the first read of the dense output: every
//! accepted step of a run with probes is read (the probes sample every 0.2 µs by default), and so
//! is every step that an event check looks into (docs/NUMERICS.md).
//!
//! Coefficients: the exact rationals of Verner's tableau rounded to the nearest `f64`; the unit
//! tests check the order conditions of every rooted tree (of the 6th-order weights up to order 6,
//! of the 5th-order weights up to order 5, of the interpolant up to order 6 at several points) on
//! these values.

// Most coefficients are given with the 17 significant digits of the nearest f64.
#![allow(clippy::excessive_precision)]
#![allow(clippy::needless_range_loop)]

use std::cell::Cell;

use chainsweep_cpu::MulAdd;

use super::adaptive::{Adaptive, Attempt, Controller, Method, RejectionForm, Rhs, Stepper};
use super::{all_finite, DenseStep};

/// Adaptive Verner 6(5) integrator with 6th-order dense output.
///
/// Right-hand-side evaluations counted in [`super::IntegrationStats::rhs_evals`]: one at `t0`, one
/// more for the automatic first step (`h_init = None`), 8 per attempted step (stages 2–9, the
/// ninth at the end of the step) and 3 more per step that passes the error test (the interpolant's
/// stages). Without non-finite values that is `1 + [h_init is None] + 11 steps + 8 rejected`.
pub type Vern6 = Adaptive<Vern6Method>;

/// Verner's 6(5) method: its coefficients, attempt and dense output, in the shared adaptive core.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Vern6Method;

impl Method for Vern6Method {
    const NAME: &'static str = "vern6";
    const ORDER: i32 = 6;
    /// The integral controller on the 5th-order estimate (exponent 1/6) with the bounds of
    /// Hairer's `DOPRI5`: safety 0.9, the step shrinks at most fivefold and grows at most tenfold.
    const CONTROLLER: Controller = Controller {
        exponent: 1.0 / 6.0,
        safety: 0.9,
        max_shrink: 0.2,
        max_growth: 10.0,
        rejection: RejectionForm::DivideByInverse,
    };
    type Stepper = Work;
    fn stepper(y0: &[f64], _n_pos: usize) -> Work {
        Work::new(y0)
    }
}

// ---------------------------------------------------------------------------------------------
// Coefficients (Verner, RKV65.IIIXb). Stage k_j is evaluated at t + C_j h; C8 = C9 = 1. The
// ninth row of A is the weights B (FSAL). E = (5th-order weights) − B, the error estimate.
// R_j[m] is the coefficient of θ^(m+1) in the interpolant's weight of stage j:
// y(t + θh) = y + h Σ_j (Σ_m R_j[m] θ^(m+1)) k_j.
// ---------------------------------------------------------------------------------------------

const C2: f64 = 0.06;
const C3: f64 = 0.09593333333333333;
const C4: f64 = 0.1439;
const C5: f64 = 0.4973;
const C6: f64 = 0.9725;
const C7: f64 = 0.9995;
const C10: f64 = 0.5;
const C11: f64 = 0.828;
const C12: f64 = 0.28;
const A2_1: f64 = 0.06;
const A3_1: f64 = 0.019239962962962962;
const A3_2: f64 = 0.07669337037037037;
const A4_1: f64 = 0.035975;
const A4_3: f64 = 0.107925;
const A5_1: f64 = 1.3186834152331484;
const A5_3: f64 = -5.042058063628562;
const A5_4: f64 = 4.220674648395414;
const A6_1: f64 = -41.872591664327516;
const A6_3: f64 = 159.4325621631375;
const A6_4: f64 = -122.11921356501003;
const A6_5: f64 = 5.531743066200054;
const A7_1: f64 = -54.430156935316504;
const A7_3: f64 = 207.06725136501848;
const A7_4: f64 = -158.61081378459;
const A7_5: f64 = 6.991816585950242;
const A7_6: f64 = -0.018597231062203234;
const A8_1: f64 = -54.66374178728198;
const A8_3: f64 = 207.95280625538936;
const A8_4: f64 = -159.2889574744995;
const A8_5: f64 = 7.018743740796944;
const A8_6: f64 = -0.018338785905045722;
const A8_7: f64 = -0.0005119484997882099;
const A10_1: f64 = 0.016524159013572806;
const A10_4: f64 = 0.3053128187514179;
const A10_5: f64 = 0.2071200938201979;
const A10_6: f64 = -1.293879140655123;
const A10_7: f64 = 57.11988411588149;
const A10_8: f64 = -55.87979207510932;
const A10_9: f64 = 0.024830028297766014;
const A11_1: f64 = 0.038150081818627744;
const A11_4: f64 = 0.2502358252513705;
const A11_5: f64 = 0.3249441447817608;
const A11_6: f64 = 1.8224606658327962;
const A11_7: f64 = -67.7137233269262;
const A11_8: f64 = 66.03587911808127;
const A11_9: f64 = -0.0363881087495127;
const A11_10: f64 = 0.106441599909888;
const A12_1: f64 = 0.11178168039666012;
const A12_4: f64 = 0.025757505109345213;
const A12_5: f64 = 3.785140856363646;
const A12_6: f64 = 92.34088993695727;
const A12_7: f64 = -3819.461508432344;
const A12_8: f64 = 3732.492711530704;
const A12_9: f64 = -1.0756940209963033;
const A12_10: f64 = -3.231539970732086;
const A12_11: f64 = -4.7075390854586345;
const B1: f64 = 0.03438957868357036;
const B4: f64 = 0.2582624555633503;
const B5: f64 = 0.4209371189673537;
const B6: f64 = 4.40539646966931;
const B7: f64 = -176.48311902429865;
const B8: f64 = 172.36413340141507;
const E1: f64 = 0.008623404282200852;
const E4: f64 = -0.019434029953152708;
const E5: f64 = 0.028450072588037983;
const E6: f64 = -2.109711061065291;
const E7: f64 = 103.45854289996399;
const E8: f64 = -101.39980461914911;
const E9: f64 = 0.03333333333333333;
const R1: [f64; 6] = [
    1.0,
    -7.778593856495575,
    27.0524385722671,
    -45.780190114576975,
    36.72377741043638,
    -11.183042432947357,
];
const R4: [f64; 6] = [
    0.0,
    16.632102138279762,
    -86.25583404770623,
    171.7330546182696,
    -149.67744091315947,
    47.826380659879696,
];
const R5: [f64; 6] = [
    0.0,
    27.10835046149758,
    -140.58676162962996,
    279.9044757968917,
    -243.95644583707966,
    77.95131832728772,
];
const R6: [f64; 6] = [
    0.0,
    283.70753264670356,
    -1471.3371557366656,
    2929.3928569314394,
    -2553.17199842168,
    815.8141610498723,
];
const R7: [f64; 6] = [
    0.0,
    -11365.512865164834,
    58942.74718938947,
    -117353.43045697975,
    102281.77209230464,
    -32682.059078573824,
];
const R8: [f64; 6] = [
    0.0,
    11100.250191051131,
    -57567.067013355576,
    114614.48808378985,
    -99894.591091309,
    31919.283963225014,
];
const R9: [f64; 6] = [
    0.0,
    -3.0022825150732126,
    14.946122435958785,
    -27.826954732510288,
    21.824672217437076,
    -5.941557405812358,
];
const R10: [f64; 6] = [
    0.0,
    -19.610347376201034,
    93.13370014508226,
    -165.3493635542416,
    129.73901617804057,
    -37.91300539268019,
];
const R11: [f64; 6] = [
    0.0,
    -18.23029074639409,
    96.74593449012313,
    -199.08634973839895,
    180.85605899200485,
    -60.285352997334954,
];
const R12: [f64; 6] = [
    0.0,
    -13.563796638614157,
    90.62137973668116,
    -204.04515601697273,
    190.48135937835858,
    -63.493786459452856,
];

/// Degree of the interpolant in θ.
const SIX: usize = 6;

// ---------------------------------------------------------------------------------------------
// Work space.
// ---------------------------------------------------------------------------------------------

/// Every vector the step loop touches, allocated once per run.
pub struct Work {
    /// State at the start of the current step.
    y: Vec<f64>,
    /// 6th-order solution at the end of the current step.
    y_new: Vec<f64>,
    /// Argument of the stage being evaluated.
    ys: Vec<f64>,
    /// Stages 1 to 12 (`k[0]` is `f(t, y)`; `k[8]` is `f(t + h, y_new)`, the next step's first;
    /// `k[9..12]` are the interpolant's).
    k: [Vec<f64>; 12],
    /// Squared, scaled components of the error estimate (scratch).
    e_sq: Vec<f64>,
    /// Dense-output coefficients of each component (`y` and the six powers of θ), computed on
    /// first use in a step: probes and event location read a handful of components.
    cont: Vec<Cell<[f64; 7]>>,
    /// Step number for which `cont[i]` holds the coefficients.
    cont_epoch: Vec<Cell<u64>>,
    /// Number of the current dense step (starts at 1 so that no coefficient is valid initially).
    epoch: u64,
}

/// `out = y + h Σ_j a[j] k[j]`, element by element (the sum from the first stage on, each term
/// one fused multiply-add where the CPU has it).
#[inline(always)]
fn combine<F: MulAdd, const S: usize>(
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

impl Work {
    fn new(y0: &[f64]) -> Self {
        let n = y0.len();
        Work {
            y: y0.to_vec(),
            y_new: vec![0.0; n],
            ys: vec![0.0; n],
            k: std::array::from_fn(|_| vec![0.0; n]),
            e_sq: vec![0.0; n],
            cont: vec![Cell::new([0.0; 7]); n],
            cont_epoch: vec![Cell::new(0); n],
            epoch: 0,
        }
    }

    /// Stages 2 to 8 of a step of size `h` from `(t, y)`, the 6th-order solution into `y_new`,
    /// stage 9 at `(t_new, y_new)`, and the RMS norm of the 5th-order error estimate. Exactly 8
    /// right-hand-side evaluations. Returns `(err, y_new and stage 9 are finite)`.
    #[inline(always)]
    fn attempt<F: MulAdd>(
        &mut self,
        sys: &mut Rhs,
        t: f64,
        h: f64,
        t_new: f64,
        rtol: f64,
        atol: &[f64],
    ) -> (f64, bool) {
        let n = self.y.len();
        let Work {
            y,
            y_new,
            ys,
            k,
            e_sq,
            ..
        } = self;
        let y = &y[..n];
        let ys = &mut ys[..n];
        let [k1, k2, k3, k4, k5, k6, k7, k8, k9, ..] = k;

        combine::<F, 1>(ys, y, h, [A2_1], [k1]);
        sys.eval(t + C2 * h, ys, k2);
        combine::<F, 2>(ys, y, h, [A3_1, A3_2], [k1, k2]);
        sys.eval(t + C3 * h, ys, k3);
        combine::<F, 2>(ys, y, h, [A4_1, A4_3], [k1, k3]);
        sys.eval(t + C4 * h, ys, k4);
        combine::<F, 3>(ys, y, h, [A5_1, A5_3, A5_4], [k1, k3, k4]);
        sys.eval(t + C5 * h, ys, k5);
        combine::<F, 4>(ys, y, h, [A6_1, A6_3, A6_4, A6_5], [k1, k3, k4, k5]);
        sys.eval(t + C6 * h, ys, k6);
        combine::<F, 5>(
            ys,
            y,
            h,
            [A7_1, A7_3, A7_4, A7_5, A7_6],
            [k1, k3, k4, k5, k6],
        );
        sys.eval(t + C7 * h, ys, k7);
        combine::<F, 6>(
            ys,
            y,
            h,
            [A8_1, A8_3, A8_4, A8_5, A8_6, A8_7],
            [k1, k3, k4, k5, k6, k7],
        );
        sys.eval(t_new, ys, k8);
        let y_new = &mut y_new[..n];
        combine::<F, 6>(
            y_new,
            y,
            h,
            [B1, B4, B5, B6, B7, B8],
            [k1, k4, k5, k6, k7, k8],
        );
        let finite = all_finite(y_new);
        sys.eval(t_new, y_new, k9);
        let finite = finite && all_finite(k9);

        // The scaled components of the error estimate in one vectorised pass; their sum in a
        // second over eight partial sums (a running sum would serialise the first loop).
        let (k1, k4, k5, k6) = (&k1[..n], &k4[..n], &k5[..n], &k6[..n]);
        let (k7, k8, k9) = (&k7[..n], &k8[..n], &k9[..n]);
        let atol = &atol[..n];
        let e_sq = &mut e_sq[..n];
        for i in 0..n {
            let sk = atol[i] + rtol * y[i].abs().max(y_new[i].abs());
            // A component with no tolerance scale (exactly zero, atol 0) is left out.
            let inv = if sk > 0.0 { 1.0 / sk } else { 0.0 };
            let e = (E1 * k1[i]
                + E4 * k4[i]
                + E5 * k5[i]
                + E6 * k6[i]
                + E7 * k7[i]
                + E8 * k8[i]
                + E9 * k9[i])
                * inv;
            e_sq[i] = e * e;
        }
        let err = h.abs() * (lane_sum(e_sq) / n as f64).sqrt();
        (err, finite)
    }

    /// After a step has passed the error test: the interpolant's stages 10–12. Exactly 3
    /// right-hand-side evaluations. Returns whether they are finite.
    #[inline(always)]
    fn prepare_dense<F: MulAdd>(&mut self, sys: &mut Rhs, t: f64, h: f64) -> bool {
        let n = self.y.len();
        let Work {
            y, ys, k, epoch, ..
        } = self;
        let y = &y[..n];
        let ys = &mut ys[..n];
        let [k1, _, _, k4, k5, k6, k7, k8, k9, k10, k11, k12] = k;
        combine::<F, 7>(
            ys,
            y,
            h,
            [A10_1, A10_4, A10_5, A10_6, A10_7, A10_8, A10_9],
            [k1, k4, k5, k6, k7, k8, k9],
        );
        sys.eval(t + C10 * h, ys, k10);
        combine::<F, 8>(
            ys,
            y,
            h,
            [A11_1, A11_4, A11_5, A11_6, A11_7, A11_8, A11_9, A11_10],
            [k1, k4, k5, k6, k7, k8, k9, k10],
        );
        sys.eval(t + C11 * h, ys, k11);
        combine::<F, 9>(
            ys,
            y,
            h,
            [
                A12_1, A12_4, A12_5, A12_6, A12_7, A12_8, A12_9, A12_10, A12_11,
            ],
            [k1, k4, k5, k6, k7, k8, k9, k10, k11],
        );
        sys.eval(t + C12 * h, ys, k12);
        *epoch += 1;
        all_finite(k10) && all_finite(k11) && all_finite(k12)
    }
}

/// Sum of a slice in eight interleaved partial sums, which vectorises.
fn lane_sum(v: &[f64]) -> f64 {
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

/// The interpolant handed to the observer: Verner's 6th-order continuous extension on one
/// accepted step.
pub struct Vern6Step<'a> {
    t0: f64,
    t1: f64,
    h: f64,
    w: &'a Work,
}

impl Vern6Step<'_> {
    /// `y` and the coefficients of θ, …, θ⁶ of component `i`, computed from the stages of this
    /// step on first use and cached until the next step.
    #[inline(always)]
    fn coefficients(&self, i: usize) -> [f64; 7] {
        let w = self.w;
        if w.cont_epoch[i].get() == w.epoch {
            return w.cont[i].get();
        }
        self.compute_coefficients(i)
    }

    /// [`Vern6Step::coefficients`] on first use in a step (out of line: the cached case is the
    /// frequent one, several samples per step).
    #[inline(never)]
    fn compute_coefficients(&self, i: usize) -> [f64; 7] {
        let w = self.w;
        let h = self.h;
        let k = |j: usize| w.k[j][i];
        let (k1, k4, k5, k6, k7, k8) = (k(0), k(3), k(4), k(5), k(6), k(7));
        let (k9, k10, k11, k12) = (k(8), k(9), k(10), k(11));
        let mut c = [w.y[i], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        // θ¹ involves only the first stage (R_j[0] = 0 for j > 1).
        c[1] = h * k1;
        for m in 1..SIX {
            c[m + 1] = h
                * (R1[m] * k1
                    + R4[m] * k4
                    + R5[m] * k5
                    + R6[m] * k6
                    + R7[m] * k7
                    + R8[m] * k8
                    + R9[m] * k9
                    + R10[m] * k10
                    + R11[m] * k11
                    + R12[m] * k12);
        }
        w.cont[i].set(c);
        w.cont_epoch[i].set(w.epoch);
        c
    }

    #[inline(always)]
    fn horner(c: &[f64; 7], s: f64) -> f64 {
        c[0] + s * (c[1] + s * (c[2] + s * (c[3] + s * (c[4] + s * (c[5] + s * c[6])))))
    }
}

impl DenseStep for Vern6Step<'_> {
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
        Self::horner(&self.coefficients(i), s)
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
            out[i] = Self::horner(&self.coefficients(i), s);
        }
    }
}

impl Stepper for Work {
    type Dense<'a> = Vern6Step<'a>;

    fn start(&mut self, rhs: &mut Rhs, t0: f64) -> bool {
        rhs.eval(t0, &self.y, &mut self.k[0]);
        all_finite(&self.k[0])
    }
    fn y(&self) -> &[f64] {
        &self.y
    }
    fn f0(&self) -> &[f64] {
        &self.k[0]
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
        let (err, finite) = Work::attempt::<F>(self, rhs, t, h, t_new, rtol, atol);
        Attempt { err, finite }
    }
    #[inline(always)]
    fn prepare_dense<F: MulAdd>(&mut self, rhs: &mut Rhs, t: f64, h: f64, _t_new: f64) -> bool {
        Work::prepare_dense::<F>(self, rhs, t, h)
    }
    fn finish(&mut self, _rhs: &mut Rhs, _t_new: f64) -> bool {
        true
    }
    fn dense(&self, t0: f64, t1: f64, h: f64) -> Vern6Step<'_> {
        Vern6Step { t0, t1, h, w: self }
    }
    fn advance(&mut self) {
        std::mem::swap(&mut self.y, &mut self.y_new);
        self.k.swap(0, 8);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::{
        Control, IntegrateError, IntegrationStats, Integrator, OdeSystem, OdeSystemDyn,
        StepObserver,
    };
    use crate::problems::{run_recorded, HarmonicOscillator, QuadraticGrowth, StepRecord};

    /// The twelve-stage tableau (stages 10–12 are the interpolant's), rows `A[i][j]`, nodes.
    fn tableau() -> ([[f64; 12]; 12], [f64; 12]) {
        let mut a = [[0.0; 12]; 12];
        let rows: [(usize, &[(usize, f64)]); 11] = [
            (1, &[(0, A2_1)]),
            (2, &[(0, A3_1), (1, A3_2)]),
            (3, &[(0, A4_1), (2, A4_3)]),
            (4, &[(0, A5_1), (2, A5_3), (3, A5_4)]),
            (5, &[(0, A6_1), (2, A6_3), (3, A6_4), (4, A6_5)]),
            (6, &[(0, A7_1), (2, A7_3), (3, A7_4), (4, A7_5), (5, A7_6)]),
            (
                7,
                &[
                    (0, A8_1),
                    (2, A8_3),
                    (3, A8_4),
                    (4, A8_5),
                    (5, A8_6),
                    (6, A8_7),
                ],
            ),
            (8, &[(0, B1), (3, B4), (4, B5), (5, B6), (6, B7), (7, B8)]),
            (
                9,
                &[
                    (0, A10_1),
                    (3, A10_4),
                    (4, A10_5),
                    (5, A10_6),
                    (6, A10_7),
                    (7, A10_8),
                    (8, A10_9),
                ],
            ),
            (
                10,
                &[
                    (0, A11_1),
                    (3, A11_4),
                    (4, A11_5),
                    (5, A11_6),
                    (6, A11_7),
                    (7, A11_8),
                    (8, A11_9),
                    (9, A11_10),
                ],
            ),
            (
                11,
                &[
                    (0, A12_1),
                    (3, A12_4),
                    (4, A12_5),
                    (5, A12_6),
                    (6, A12_7),
                    (7, A12_8),
                    (8, A12_9),
                    (9, A12_10),
                    (10, A12_11),
                ],
            ),
        ];
        for (i, row) in rows {
            for &(j, v) in row {
                a[i][j] = v;
            }
        }
        let c = [0.0, C2, C3, C4, C5, C6, C7, 1.0, 1.0, C10, C11, C12];
        (a, c)
    }

    /// A rooted tree as the list of its root's subtrees (sorted, so that each tree has one form).
    #[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
    struct Tree(Vec<Tree>);

    impl Tree {
        fn order(&self) -> usize {
            1 + self.0.iter().map(Tree::order).sum::<usize>()
        }
        /// γ(t) = |t| Π γ(subtrees).
        fn density(&self) -> f64 {
            self.order() as f64 * self.0.iter().map(Tree::density).product::<f64>()
        }
        /// Φ_i(t) for every stage: Π over subtrees of (A Φ(subtree))_i, with its magnitude (the
        /// same with |A|) to scale the rounding tolerance.
        fn stage_weights(&self, a: &[[f64; 12]; 12]) -> ([f64; 12], [f64; 12]) {
            let (mut phi, mut mag) = ([1.0; 12], [1.0; 12]);
            for sub in &self.0 {
                let (p, m) = sub.stage_weights(a);
                for i in 0..12 {
                    phi[i] *= (0..12).map(|j| a[i][j] * p[j]).sum::<f64>();
                    mag[i] *= (0..12).map(|j| (a[i][j] * m[j]).abs()).sum::<f64>();
                }
            }
            (phi, mag)
        }
    }

    /// Every rooted tree with at most `max` vertices (1, 1, 2, 4, 9, 20, 48 of each order).
    fn trees(max: usize) -> Vec<Tree> {
        let mut all = vec![Tree(vec![])];
        for order in 2..=max {
            // Grafting a leaf onto every vertex of every tree one smaller gives all of them.
            fn graft(t: &Tree) -> Vec<Tree> {
                let mut out = vec![];
                let mut with_leaf = t.0.clone();
                with_leaf.push(Tree(vec![]));
                with_leaf.sort();
                out.push(Tree(with_leaf));
                for (k, sub) in t.0.iter().enumerate() {
                    for g in graft(sub) {
                        let mut subs = t.0.clone();
                        subs[k] = g;
                        subs.sort();
                        out.push(Tree(subs));
                    }
                }
                out
            }
            let mut new: Vec<Tree> = all
                .iter()
                .filter(|t| t.order() == order - 1)
                .flat_map(graft)
                .collect();
            new.sort();
            new.dedup();
            all.extend(new);
        }
        all
    }

    /// The largest violation of `Σ w_i Φ_i(t) = θ^|t| / γ(t)` over the trees up to `order`,
    /// relative to the size of the terms.
    fn worst_condition(w: &[f64; 12], theta: f64, order: usize) -> f64 {
        let (a, _) = tableau();
        trees(order)
            .iter()
            .map(|t| {
                let (phi, mag) = t.stage_weights(&a);
                let lhs: f64 = w.iter().zip(&phi).map(|(w, p)| w * p).sum();
                let scale: f64 = w.iter().zip(&mag).map(|(w, m)| (w * m).abs()).sum();
                let rhs = theta.powi(t.order() as i32) / t.density();
                (lhs - rhs).abs() / scale.max(1.0)
            })
            .fold(0.0, f64::max)
    }

    fn weights(stages: &[(usize, f64)]) -> [f64; 12] {
        let mut w = [0.0; 12];
        for &(j, v) in stages {
            w[j] = v;
        }
        w
    }

    #[test]
    fn vern6_coefficients_satisfy_the_order_conditions() {
        let counts: Vec<usize> = (1..=7)
            .map(|p| trees(7).iter().filter(|t| t.order() == p).count())
            .collect();
        assert_eq!(counts, [1, 1, 2, 4, 9, 20, 48]);

        // Row sums equal the nodes.
        let (a, c) = tableau();
        for i in 0..12 {
            let s: f64 = a[i].iter().sum();
            assert!(
                (s - c[i]).abs() < 1e-12,
                "row {}: sum {s} vs c {}",
                i + 1,
                c[i]
            );
        }
        // The propagated weights: order 6 (all 37 trees), not 7.
        let b = weights(&[(0, B1), (3, B4), (4, B5), (5, B6), (6, B7), (7, B8)]);
        let worst = worst_condition(&b, 1.0, 6);
        assert!(worst < 1e-14, "6th-order weights: {worst:e}");
        assert!(worst_condition(&b, 1.0, 7) > 1e-7);
        // The embedded weights b + e: order 5 (17 trees), not 6.
        let e = weights(&[
            (0, E1),
            (3, E4),
            (4, E5),
            (5, E6),
            (6, E7),
            (7, E8),
            (8, E9),
        ]);
        let bhat: [f64; 12] = std::array::from_fn(|j| b[j] + e[j]);
        let worst = worst_condition(&bhat, 1.0, 5);
        assert!(worst < 1e-14, "5th-order weights: {worst:e}");
        assert!(worst_condition(&bhat, 1.0, 6) > 1e-7);
        // The interpolant b(θ): order 6 at every θ, and b(1) = b.
        let r = [
            R1, [0.0; 6], [0.0; 6], R4, R5, R6, R7, R8, R9, R10, R11, R12,
        ];
        for theta in [0.1f64, 0.28, 0.5, 0.77, 1.0] {
            let w: [f64; 12] =
                std::array::from_fn(|j| (0..SIX).map(|m| r[j][m] * theta.powi(m as i32 + 1)).sum());
            let worst = worst_condition(&w, theta, 6);
            assert!(worst < 1e-13, "interpolant at θ = {theta}: {worst:e}");
            if theta == 1.0 {
                for j in 0..12 {
                    assert!((w[j] - b[j]).abs() < 1e-10, "b({theta})_{j} = {}", w[j]);
                }
            }
        }
    }

    fn run(
        solver: &Vern6,
        sys: &mut dyn OdeSystemDyn,
        y0: &[f64],
        t_end: f64,
    ) -> (Result<IntegrationStats, IntegrateError>, StepRecord) {
        run_recorded(solver, sys, y0, t_end)
    }

    fn oscillator_error(tol: f64, t_end: f64) -> (f64, IntegrationStats) {
        let (r, rec) = run(
            &Vern6::new(tol, tol),
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

    #[test]
    fn vern6_error_follows_the_tolerance() {
        let (e10, s10) = oscillator_error(1e-10, 20.0);
        assert!(e10 < 1e-8, "error {e10:e} at tol 1e-10");
        let (e6, s6) = oscillator_error(1e-6, 20.0);
        assert!(e6 < 1e-4, "error {e6:e} at tol 1e-6");
        // A 6th-order method: four decades of tolerance cost about 10^(4/6) ≈ 4.6 times the steps.
        let ratio = s10.steps as f64 / s6.steps as f64;
        assert!(e6 / e10 > 300.0, "e(1e-6) = {e6:e}, e(1e-10) = {e10:e}");
        assert!(
            ratio > 3.0 && ratio < 7.0,
            "step ratio {ratio} ({s6:?}, {s10:?})"
        );
    }

    /// Fixed steps: huge tolerances so the controller always wants to grow, capped at `h`.
    fn fixed_step_run(sys: &mut dyn OdeSystemDyn, y0: &[f64], t_end: f64, n: u32) -> Vec<f64> {
        let h = t_end / f64::from(n);
        let solver = Vern6::new(1e3, 1e3).with_initial_step(h).with_max_step(h);
        let (r, rec) = run(&solver, sys, y0, t_end);
        let s = r.unwrap();
        assert_eq!((s.steps, s.rejected), (u64::from(n), 0));
        rec.y
    }

    #[test]
    fn vern6_convergence_order_is_six() {
        // y' = y² from 1 to t = 0.8 (y = 5), with 10, 20, 40 steps. Nonlinear, so that the error
        // involves every order condition (on y' = −y + sin t this pair converges at order 7).
        // Verner chose the pair for a small 6th-order error constant: at these steps the
        // 7th-order terms still weigh in and the slope lies between 6 and 7.5 (measured 6.9 and
        // 7.5); at smaller steps rounding takes over (the weights reach ±176). A wrong
        // coefficient would drop it to 5 or below.
        let t_end = 0.8;
        let e = |n: u32| {
            (fixed_step_run(&mut QuadraticGrowth, &[1.0], t_end, n)[0]
                - QuadraticGrowth::exact(1.0, t_end))
            .abs()
        };
        let (e1, e2, e3) = (e(10), e(20), e(40));
        for (p, what) in [((e1 / e2).log2(), "10/20"), ((e2 / e3).log2(), "20/40")] {
            assert!(
                p > 5.7 && p < 7.8,
                "y' = y², steps {what}: order {p} (errors {e1:e} {e2:e} {e3:e})"
            );
        }
    }

    #[test]
    fn vern6_dense_output_order_is_six() {
        // A continuous extension of order 6 has local error O(h^7) everywhere in the step:
        // halving h divides the interpolation error of the first step by about 2^7.
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
            let solver = Vern6::new(1e3, 1e3).with_initial_step(h).with_max_step(h);
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
        // On y' = y² from 1 the slope falls towards 7 as h shrinks (10.5 from 0.4 to 0.2, 8.6 from
        // 0.2 to 0.1, 6.9 from 0.1 to 0.05); below that rounding takes over (the interpolant's
        // weights reach 10^5). A 5th-order interpolant would give 6.
        let (e1, e2) = (err_for(0.1), err_for(0.05));
        let p = (e1 / e2).log2();
        assert!(
            p > 6.5 && p < 7.5,
            "dense local order {p} (e1 {e1:e}, e2 {e2:e})"
        );
    }

    #[test]
    fn vern6_dense_output_accuracy() {
        // 1000 samples over 20 s, none on a step end, against the exact solution.
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
                    let mut both = [f64::NAN; 2];
                    step.eval_components(t, &[0, 1], &mut both);
                    assert_eq!(both, [step.eval_component(t, 0), step.eval_component(t, 1)]);
                    let e = (both[0] - t.cos()).abs().max((both[1] + t.sin()).abs());
                    self.max_err = self.max_err.max(e);
                    self.next += 1;
                }
            }
        }
        let mut obs = Dense {
            next: 0,
            max_err: 0.0,
        };
        let stats = Vern6::new(1e-10, 1e-10)
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
        assert!(stats.steps < 500, "{stats:?}");
        assert!(obs.max_err < 1e-8, "dense error {:e}", obs.max_err);
    }

    /// Counts its own right-hand-side calls.
    struct Counted(u64);
    impl OdeSystem for Counted {
        fn n_pos(&self) -> usize {
            1
        }
        fn n_quad(&self) -> usize {
            0
        }
        fn rhs(&mut self, _t: f64, y: &[f64], dy: &mut [f64]) {
            self.0 += 1;
            dy[0] = y[1];
            dy[1] = -y[0];
        }
    }

    #[test]
    fn vern6_rhs_eval_accounting() {
        // Automatic first step: 1 (at t0) + 1 (HINIT) + 11 per accepted + 8 per rejected.
        let mut sys = Counted(0);
        let s = Vern6::new(1e-9, 1e-9)
            .integrate(
                &mut sys,
                0.0,
                &[1.0, 0.0],
                10.0,
                100_000,
                &mut StepRecord::default(),
            )
            .unwrap();
        assert_eq!(s.rhs_evals, sys.0);
        assert_eq!(s.rhs_evals, 2 + 11 * s.steps + 8 * s.rejected);
        // A far too large first step forces rejections; no HINIT evaluation.
        let mut sys = Counted(0);
        let s = Vern6::new(1e-9, 1e-9)
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
        assert_eq!(s.rhs_evals, sys.0);
        assert_eq!(s.rhs_evals, 1 + 11 * s.steps + 8 * s.rejected);
    }

    #[test]
    fn vern6_recovers_from_transient_nonfinite() {
        // y' = -10 y, undefined for y < 0: a huge first step overshoots, is shrunk, and the run
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
        let solver = Vern6::new(1e-10, 1e-12).with_initial_step(1.0);
        let (r, rec) = run(&solver, &mut Guarded, &[1.0], 1.0);
        let stats = r.unwrap();
        assert!(stats.rejected >= 1);
        let e = (rec.y[0] - (-10.0f64).exp()).abs();
        assert!(e < 1e-9, "error {e:e}");
        assert_eq!(solver.name(), "vern6");
    }
}
