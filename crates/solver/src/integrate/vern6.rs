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
//!
//! The method is data alone: its error norm (the RMS norm of the 5th-order estimate) and its
//! interpolant are the explicit core's standard ones ([`super::explicit`]).

// Most coefficients are given with the 17 significant digits of the nearest f64.
#![allow(clippy::excessive_precision)]

use super::adaptive::{Adaptive, Controller, Method, RejectionForm};
use super::explicit::{ExplicitMethod, Stage, Tableau, Work};

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
    type Stepper = Work<Self>;
    fn stepper(y0: &[f64], _n_pos: usize) -> Work<Self> {
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

/// The stages (0 is `f(t, y)`; 8 is `f(t + h, y_new)`, the next step's first; 9–11 are the
/// interpolant's).
const STAGES: &[Stage] = &[
    Stage { c: 0.0, a: &[] },
    Stage {
        c: C2,
        a: &[(0, A2_1)],
    },
    Stage {
        c: C3,
        a: &[(0, A3_1), (1, A3_2)],
    },
    Stage {
        c: C4,
        a: &[(0, A4_1), (2, A4_3)],
    },
    Stage {
        c: C5,
        a: &[(0, A5_1), (2, A5_3), (3, A5_4)],
    },
    Stage {
        c: C6,
        a: &[(0, A6_1), (2, A6_3), (3, A6_4), (4, A6_5)],
    },
    Stage {
        c: C7,
        a: &[(0, A7_1), (2, A7_3), (3, A7_4), (4, A7_5), (5, A7_6)],
    },
    Stage {
        c: 1.0,
        a: &[
            (0, A8_1),
            (2, A8_3),
            (3, A8_4),
            (4, A8_5),
            (5, A8_6),
            (6, A8_7),
        ],
    },
    Stage { c: 1.0, a: WEIGHTS },
    Stage {
        c: C10,
        a: &[
            (0, A10_1),
            (3, A10_4),
            (4, A10_5),
            (5, A10_6),
            (6, A10_7),
            (7, A10_8),
            (8, A10_9),
        ],
    },
    Stage {
        c: C11,
        a: &[
            (0, A11_1),
            (3, A11_4),
            (4, A11_5),
            (5, A11_6),
            (6, A11_7),
            (7, A11_8),
            (8, A11_9),
            (9, A11_10),
        ],
    },
    Stage {
        c: C12,
        a: &[
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
    },
];

/// The 6th-order weights.
const WEIGHTS: &[(usize, f64)] = &[(0, B1), (3, B4), (4, B5), (5, B6), (6, B7), (7, B8)];

/// The error weights: those of the embedded 5th-order solution minus the 6th-order ones.
const ERROR: &[(usize, f64)] = &[
    (0, E1),
    (3, E4),
    (4, E5),
    (5, E6),
    (6, E7),
    (7, E8),
    (8, E9),
];

/// The interpolant's weights: `(j, R_j)`, the polynomial in θ of stage j.
const INTERPOLANT: &[(usize, &[f64])] = &[
    (0, &R1),
    (3, &R4),
    (4, &R5),
    (5, &R6),
    (6, &R7),
    (7, &R8),
    (8, &R9),
    (9, &R10),
    (10, &R11),
    (11, &R12),
];

/// Verner's pair as data: eight stages per attempt, the ninth (FSAL) among them because the
/// error estimate uses it, three more for the interpolant. Its error norm (the RMS norm of the
/// 5th-order estimate) and its interpolant are the standard ones of the explicit core.
const TABLEAU: Tableau = Tableau {
    stages: STAGES,
    attempt: 7,
    fsal: 8,
    fsal_in_attempt: true,
    buffers: &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11],
    error: ERROR,
    interpolant: INTERPOLANT,
};

impl ExplicitMethod for Vern6Method {
    const TABLEAU: Tableau = TABLEAU;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::order_conditions::{dense_weights, matrix, worst_condition};

    #[test]
    fn the_embedded_solution_has_order_five() {
        // The suite of every method (method_tests) checks the 6th-order weights and the
        // interpolant; this is the error estimate's.
        let (a, _) = matrix(&TABLEAU);
        let s = a.len();
        let b = dense_weights(WEIGHTS, s);
        let e = dense_weights(ERROR, s);
        let bhat: Vec<f64> = b.iter().zip(&e).map(|(b, e)| b + e).collect();
        let worst = worst_condition(&a, &bhat, 1.0, 5);
        assert!(worst < 1e-14, "5th-order weights: {worst:e}");
        assert!(worst_condition(&a, &bhat, 1.0, 6) > 1e-7);
    }
}
