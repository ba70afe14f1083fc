//! Dormand–Prince 8(5,3): the explicit Runge–Kutta method of Hairer, Nørsett & Wanner's `DOP853`.
//!
//! Twelve stages per attempted step (the first reused from the previous step, FSAL), an
//! 8th-order solution, a combined 5th/3rd-order error estimate, the PI step-size controller with
//! Hairer's defaults, and the 7th-order continuous extension (`CONTD8`), which costs three more
//! right-hand-side evaluations per accepted step. The coefficients are those of `dop853.f`
//! (identical to scipy's `dop853_coefficients.py`).
//!
//! DOP853 treats the `[x, v, q]` state as one plain first-order vector.

// The coefficients are kept with all the digits Hairer published, more than an f64 holds.
#![allow(clippy::excessive_precision)]
// The stage kernels combine up to a dozen equal-length slices element by element; index loops
// over slices re-sliced to a common length read more clearly than nested zips and let LLVM drop
// the bounds checks.
#![allow(clippy::needless_range_loop)]

use std::cell::Cell;

use chainsweep_cpu::MulAdd;

use super::adaptive::{Adaptive, Attempt, Controller, Method, RejectionForm, Rhs, Stepper};
use super::{all_finite, DenseStep};

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

/// h·|λ| above which a step is on DOP853's stability boundary (Hairer's `dop853.f`).
const STIFFNESS_BOUND: f64 = 6.1;

/// Adaptive Dormand–Prince 8(5,3) integrator with 7th-order dense output (Hairer's `DOP853`).
///
/// Right-hand-side evaluations counted in [`super::IntegrationStats::rhs_evals`]: one at `t0`, one
/// more for the automatic first step (`h_init = None`), 11 per attempted step, and 4 per step
/// that passes the error test (the FSAL stage at the new point plus 3 dense-output stages).
/// Without non-finite values that is `1 + [h_init is None] + 15 steps + 11 rejected`.
pub type Dop853 = Adaptive<Dop853Method>;

/// The DOP853 method: Hairer's coefficients, attempt and dense output, in the shared adaptive core.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Dop853Method;

impl Method for Dop853Method {
    const NAME: &'static str = "dop853";
    const ORDER: i32 = 8;
    /// Hairer's defaults for DOP853: safety 0.9, the step shrinks at most by 0.333 and grows at
    /// most by 6 per step, the plain integral controller on the 8th-order error (Lund
    /// stabilisation off, his default).
    const CONTROLLER: Controller = Controller {
        exponent: 1.0 / 8.0,
        safety: 0.9,
        max_shrink: 0.333,
        max_growth: 6.0,
        rejection: RejectionForm::DivideByInverse,
    };
    type Stepper = Work;
    fn stepper(y0: &[f64], _n_pos: usize) -> Work {
        Work::new(y0)
    }
}

// ---------------------------------------------------------------------------------------------
// Coefficients (Hairer, dop853.f). Stage k_j is evaluated at t + C_j h.
// ---------------------------------------------------------------------------------------------

const C2: f64 = 0.526001519587677318785587544488e-01;
const C3: f64 = 0.789002279381515978178381316732e-01;
const C4: f64 = 0.118350341907227396726757197510e+00;
const C5: f64 = 0.281649658092772603273242802490e+00;
const C6: f64 = 0.333333333333333333333333333333e+00;
const C7: f64 = 0.25e+00;
const C8: f64 = 0.307692307692307692307692307692e+00;
const C9: f64 = 0.651282051282051282051282051282e+00;
const C10: f64 = 0.6e+00;
const C11: f64 = 0.857142857142857142857142857142e+00;
const C14: f64 = 0.1e+00;
const C15: f64 = 0.2e+00;
const C16: f64 = 0.777777777777777777777777777778e+00;

const B1: f64 = 5.42937341165687622380535766363e-2;
const B6: f64 = 4.45031289275240888144113950566e0;
const B7: f64 = 1.89151789931450038304281599044e0;
const B8: f64 = -5.8012039600105847814672114227e0;
const B9: f64 = 3.1116436695781989440891606237e-1;
const B10: f64 = -1.52160949662516078556178806805e-1;
const B11: f64 = 2.01365400804030348374776537501e-1;
const B12: f64 = 4.47106157277725905176885569043e-2;

const BHH1: f64 = 0.244094488188976377952755905512e+00;
const BHH2: f64 = 0.733846688281611857341361741547e+00;
const BHH3: f64 = 0.220588235294117647058823529412e-01;

const ER1: f64 = 0.1312004499419488073250102996e-01;
const ER6: f64 = -0.1225156446376204440720569753e+01;
const ER7: f64 = -0.4957589496572501915214079952e+00;
const ER8: f64 = 0.1664377182454986536961530415e+01;
const ER9: f64 = -0.3503288487499736816886487290e+00;
const ER10: f64 = 0.3341791187130174790297318841e+00;
const ER11: f64 = 0.8192320648511571246570742613e-01;
const ER12: f64 = -0.2235530786388629525884427845e-01;

const A21: f64 = 5.26001519587677318785587544488e-2;
const A31: f64 = 1.97250569845378994544595329183e-2;
const A32: f64 = 5.91751709536136983633785987549e-2;
const A41: f64 = 2.95875854768068491816892993775e-2;
const A43: f64 = 8.87627564304205475450678981324e-2;
const A51: f64 = 2.41365134159266685502369798665e-1;
const A53: f64 = -8.84549479328286085344864962717e-1;
const A54: f64 = 9.24834003261792003115737966543e-1;
const A61: f64 = 3.7037037037037037037037037037e-2;
const A64: f64 = 1.70828608729473871279604482173e-1;
const A65: f64 = 1.25467687566822425016691814123e-1;
const A71: f64 = 3.7109375e-2;
const A74: f64 = 1.70252211019544039314978060272e-1;
const A75: f64 = 6.02165389804559606850219397283e-2;
const A76: f64 = -1.7578125e-2;
const A81: f64 = 3.70920001185047927108779319836e-2;
const A84: f64 = 1.70383925712239993810214054705e-1;
const A85: f64 = 1.07262030446373284651809199168e-1;
const A86: f64 = -1.53194377486244017527936158236e-2;
const A87: f64 = 8.27378916381402288758473766002e-3;
const A91: f64 = 6.24110958716075717114429577812e-1;
const A94: f64 = -3.36089262944694129406857109825e0;
const A95: f64 = -8.68219346841726006818189891453e-1;
const A96: f64 = 2.75920996994467083049415600797e1;
const A97: f64 = 2.01540675504778934086186788979e1;
const A98: f64 = -4.34898841810699588477366255144e1;
const A101: f64 = 4.77662536438264365890433908527e-1;
const A104: f64 = -2.48811461997166764192642586468e0;
const A105: f64 = -5.90290826836842996371446475743e-1;
const A106: f64 = 2.12300514481811942347288949897e1;
const A107: f64 = 1.52792336328824235832596922938e1;
const A108: f64 = -3.32882109689848629194453265587e1;
const A109: f64 = -2.03312017085086261358222928593e-2;
const A111: f64 = -9.3714243008598732571704021658e-1;
const A114: f64 = 5.18637242884406370830023853209e0;
const A115: f64 = 1.09143734899672957818500254654e0;
const A116: f64 = -8.14978701074692612513997267357e0;
const A117: f64 = -1.85200656599969598641566180701e1;
const A118: f64 = 2.27394870993505042818970056734e1;
const A119: f64 = 2.49360555267965238987089396762e0;
const A1110: f64 = -3.0467644718982195003823669022e0;
const A121: f64 = 2.27331014751653820792359768449e0;
const A124: f64 = -1.05344954667372501984066689879e1;
const A125: f64 = -2.00087205822486249909675718444e0;
const A126: f64 = -1.79589318631187989172765950534e1;
const A127: f64 = 2.79488845294199600508499808837e1;
const A128: f64 = -2.85899827713502369474065508674e0;
const A129: f64 = -8.87285693353062954433549289258e0;
const A1210: f64 = 1.23605671757943030647266201528e1;
const A1211: f64 = 6.43392746015763530355970484046e-1;

const A141: f64 = 5.61675022830479523392909219681e-2;
const A147: f64 = 2.53500210216624811088794765333e-1;
const A148: f64 = -2.46239037470802489917441475441e-1;
const A149: f64 = -1.24191423263816360469010140626e-1;
const A1410: f64 = 1.5329179827876569731206322685e-1;
const A1411: f64 = 8.20105229563468988491666602057e-3;
const A1412: f64 = 7.56789766054569976138603589584e-3;
const A1413: f64 = -8.298e-3;

const A151: f64 = 3.18346481635021405060768473261e-2;
const A156: f64 = 2.83009096723667755288322961402e-2;
const A157: f64 = 5.35419883074385676223797384372e-2;
const A158: f64 = -5.49237485713909884646569340306e-2;
const A1511: f64 = -1.08347328697249322858509316994e-4;
const A1512: f64 = 3.82571090835658412954920192323e-4;
const A1513: f64 = -3.40465008687404560802977114492e-4;
const A1514: f64 = 1.41312443674632500278074618366e-1;

const A161: f64 = -4.28896301583791923408573538692e-1;
const A166: f64 = -4.69762141536116384314449447206e0;
const A167: f64 = 7.68342119606259904184240953878e0;
const A168: f64 = 4.06898981839711007970213554331e0;
const A169: f64 = 3.56727187455281109270669543021e-1;
const A1613: f64 = -1.39902416515901462129418009734e-3;
const A1614: f64 = 2.9475147891527723389556272149e0;
const A1615: f64 = -9.15095847217987001081870187138e0;

const D41: f64 = -0.84289382761090128651353491142e+01;
const D46: f64 = 0.56671495351937776962531783590e+00;
const D47: f64 = -0.30689499459498916912797304727e+01;
const D48: f64 = 0.23846676565120698287728149680e+01;
const D49: f64 = 0.21170345824450282767155149946e+01;
const D410: f64 = -0.87139158377797299206789907490e+00;
const D411: f64 = 0.22404374302607882758541771650e+01;
const D412: f64 = 0.63157877876946881815570249290e+00;
const D413: f64 = -0.88990336451333310820698117400e-01;
const D414: f64 = 0.18148505520854727256656404962e+02;
const D415: f64 = -0.91946323924783554000451984436e+01;
const D416: f64 = -0.44360363875948939664310572000e+01;

const D51: f64 = 0.10427508642579134603413151009e+02;
const D56: f64 = 0.24228349177525818288430175319e+03;
const D57: f64 = 0.16520045171727028198505394887e+03;
const D58: f64 = -0.37454675472269020279518312152e+03;
const D59: f64 = -0.22113666853125306036270938578e+02;
const D510: f64 = 0.77334326684722638389603898808e+01;
const D511: f64 = -0.30674084731089398182061213626e+02;
const D512: f64 = -0.93321305264302278729567221706e+01;
const D513: f64 = 0.15697238121770843886131091075e+02;
const D514: f64 = -0.31139403219565177677282850411e+02;
const D515: f64 = -0.93529243588444783865713862664e+01;
const D516: f64 = 0.35816841486394083752465898540e+02;

const D61: f64 = 0.19985053242002433820987653617e+02;
const D66: f64 = -0.38703730874935176555105901742e+03;
const D67: f64 = -0.18917813819516756882830838328e+03;
const D68: f64 = 0.52780815920542364900561016686e+03;
const D69: f64 = -0.11573902539959630126141871134e+02;
const D610: f64 = 0.68812326946963000169666922661e+01;
const D611: f64 = -0.10006050966910838403183860980e+01;
const D612: f64 = 0.77771377980534432092869265740e+00;
const D613: f64 = -0.27782057523535084065932004339e+01;
const D614: f64 = -0.60196695231264120758267380846e+02;
const D615: f64 = 0.84320405506677161018159903784e+02;
const D616: f64 = 0.11992291136182789328035130030e+02;

const D71: f64 = -0.25693933462703749003312586129e+02;
const D76: f64 = -0.15418974869023643374053993627e+03;
const D77: f64 = -0.23152937917604549567536039109e+03;
const D78: f64 = 0.35763911791061412378285349910e+03;
const D79: f64 = 0.93405324183624310003907691704e+02;
const D710: f64 = -0.37458323136451633156875139351e+02;
const D711: f64 = 0.10409964950896230045147246184e+03;
const D712: f64 = 0.29840293426660503123344363579e+02;
const D713: f64 = -0.43533456590011143754432175058e+02;
const D714: f64 = 0.96324553959188282948394950600e+02;
const D715: f64 = -0.39177261675615439165231486172e+02;
const D716: f64 = -0.14972683625798562581422125276e+03;

// ---------------------------------------------------------------------------------------------
// Work space.
// ---------------------------------------------------------------------------------------------

/// Every vector the step loop touches, allocated once per run.
pub struct Work {
    /// Squared, scaled components of the 3rd-order error estimate (scratch).
    e3_sq: Vec<f64>,
    /// Squared, scaled components of the 5th-order error estimate (scratch).
    e5_sq: Vec<f64>,
    /// Hairer's stiffness estimate h·|λ| of the last accepted step.
    stiffness: f64,
    /// State at the start of the current step.
    y: Vec<f64>,
    /// 8th-order solution at the end of the current step.
    y_new: Vec<f64>,
    /// Argument of the stage being evaluated.
    ys: Vec<f64>,
    k1: Vec<f64>,
    /// Stage 2; reused for dense stage 14 after the step is accepted.
    k2: Vec<f64>,
    /// Stage 3; reused for dense stage 15.
    k3: Vec<f64>,
    /// Stage 4; reused for dense stage 16.
    k4: Vec<f64>,
    k5: Vec<f64>,
    k6: Vec<f64>,
    k7: Vec<f64>,
    k8: Vec<f64>,
    k9: Vec<f64>,
    k10: Vec<f64>,
    k11: Vec<f64>,
    k12: Vec<f64>,
    /// `f(t + h, y_new)`: stage 13, which becomes stage 1 of the next step (FSAL).
    k13: Vec<f64>,
    /// Dense-output coefficients of each component, computed on first use in a step: probes and
    /// event location read a handful of components, so building all of them every step would
    /// cost more than the stages themselves.
    cont: Vec<Cell<[f64; 8]>>,
    /// Step number for which `cont[i]` holds the coefficients.
    cont_epoch: Vec<Cell<u64>>,
    /// Number of the current dense step (starts at 1 so that no coefficient is valid initially).
    epoch: u64,
}

impl Work {
    fn new(y0: &[f64]) -> Self {
        let n = y0.len();
        let z = || vec![0.0; n];
        Work {
            y: y0.to_vec(),
            y_new: z(),
            ys: z(),
            k1: z(),
            k2: z(),
            k3: z(),
            k4: z(),
            k5: z(),
            k6: z(),
            k7: z(),
            k8: z(),
            k9: z(),
            k10: z(),
            k11: z(),
            k12: z(),
            k13: z(),
            cont: vec![Cell::new([0.0; 8]); n],
            cont_epoch: vec![Cell::new(0); n],
            epoch: 0,
            stiffness: 0.0,
            e3_sq: vec![0.0; n],
            e5_sq: vec![0.0; n],
        }
    }

    /// Stages 2 to 12 of a step of size `h` from `(t, y)` (stage 1 is `k1`), the 8th-order
    /// solution into `y_new`, and Hairer's combined 5th/3rd-order error norm. `t_new` is the end
    /// of the step (`t + h`, or exactly `t_end` for the last step). Exactly 11 right-hand-side
    /// evaluations. Returns `(err, y_new is finite)`.
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
            k1,
            k2,
            k3,
            k4,
            k5,
            k6,
            k7,
            k8,
            k9,
            k10,
            k11,
            k12,
            e3_sq,
            e5_sq,
            ..
        } = self;
        let y = &y[..n];
        let atol = &atol[..n];
        let k1 = &k1[..n];

        {
            let s = &mut ys[..n];
            for i in 0..n {
                s[i] = F::mul_add(h, A21 * k1[i], y[i]);
            }
        }
        sys.eval(t + C2 * h, ys, k2);
        let k2 = &k2[..n];

        {
            let s = &mut ys[..n];
            for i in 0..n {
                s[i] = F::mul_add(h, F::mul_add(A32, k2[i], A31 * k1[i]), y[i]);
            }
        }
        sys.eval(t + C3 * h, ys, k3);
        let k3 = &k3[..n];

        {
            let s = &mut ys[..n];
            for i in 0..n {
                s[i] = F::mul_add(h, F::mul_add(A43, k3[i], A41 * k1[i]), y[i]);
            }
        }
        sys.eval(t + C4 * h, ys, k4);
        let k4 = &k4[..n];

        {
            let s = &mut ys[..n];
            for i in 0..n {
                s[i] = F::mul_add(
                    h,
                    F::mul_add(A54, k4[i], F::mul_add(A53, k3[i], A51 * k1[i])),
                    y[i],
                );
            }
        }
        sys.eval(t + C5 * h, ys, k5);
        let k5 = &k5[..n];

        {
            let s = &mut ys[..n];
            for i in 0..n {
                s[i] = F::mul_add(
                    h,
                    F::mul_add(A65, k5[i], F::mul_add(A64, k4[i], A61 * k1[i])),
                    y[i],
                );
            }
        }
        sys.eval(t + C6 * h, ys, k6);
        let k6 = &k6[..n];

        {
            let s = &mut ys[..n];
            for i in 0..n {
                s[i] = F::mul_add(
                    h,
                    F::mul_add(
                        A76,
                        k6[i],
                        F::mul_add(A75, k5[i], F::mul_add(A74, k4[i], A71 * k1[i])),
                    ),
                    y[i],
                );
            }
        }
        sys.eval(t + C7 * h, ys, k7);
        let k7 = &k7[..n];

        {
            let s = &mut ys[..n];
            for i in 0..n {
                s[i] = F::mul_add(
                    h,
                    F::mul_add(
                        A87,
                        k7[i],
                        F::mul_add(
                            A86,
                            k6[i],
                            F::mul_add(A85, k5[i], F::mul_add(A84, k4[i], A81 * k1[i])),
                        ),
                    ),
                    y[i],
                );
            }
        }
        sys.eval(t + C8 * h, ys, k8);
        let k8 = &k8[..n];

        {
            let s = &mut ys[..n];
            for i in 0..n {
                s[i] = F::mul_add(
                    h,
                    F::mul_add(
                        A98,
                        k8[i],
                        F::mul_add(
                            A97,
                            k7[i],
                            F::mul_add(
                                A96,
                                k6[i],
                                F::mul_add(A95, k5[i], F::mul_add(A94, k4[i], A91 * k1[i])),
                            ),
                        ),
                    ),
                    y[i],
                );
            }
        }
        sys.eval(t + C9 * h, ys, k9);
        let k9 = &k9[..n];

        {
            let s = &mut ys[..n];
            for i in 0..n {
                s[i] = F::mul_add(
                    h,
                    F::mul_add(
                        A109,
                        k9[i],
                        F::mul_add(
                            A108,
                            k8[i],
                            F::mul_add(
                                A107,
                                k7[i],
                                F::mul_add(
                                    A106,
                                    k6[i],
                                    F::mul_add(A105, k5[i], F::mul_add(A104, k4[i], A101 * k1[i])),
                                ),
                            ),
                        ),
                    ),
                    y[i],
                );
            }
        }
        sys.eval(t + C10 * h, ys, k10);
        let k10 = &k10[..n];

        {
            let s = &mut ys[..n];
            for i in 0..n {
                s[i] = F::mul_add(
                    h,
                    F::mul_add(
                        A1110,
                        k10[i],
                        F::mul_add(
                            A119,
                            k9[i],
                            F::mul_add(
                                A118,
                                k8[i],
                                F::mul_add(
                                    A117,
                                    k7[i],
                                    F::mul_add(
                                        A116,
                                        k6[i],
                                        F::mul_add(
                                            A115,
                                            k5[i],
                                            F::mul_add(A114, k4[i], A111 * k1[i]),
                                        ),
                                    ),
                                ),
                            ),
                        ),
                    ),
                    y[i],
                );
            }
        }
        sys.eval(t + C11 * h, ys, k11);
        let k11 = &k11[..n];

        {
            let s = &mut ys[..n];
            for i in 0..n {
                s[i] = F::mul_add(
                    h,
                    F::mul_add(
                        A1211,
                        k11[i],
                        F::mul_add(
                            A1210,
                            k10[i],
                            F::mul_add(
                                A129,
                                k9[i],
                                F::mul_add(
                                    A128,
                                    k8[i],
                                    F::mul_add(
                                        A127,
                                        k7[i],
                                        F::mul_add(
                                            A126,
                                            k6[i],
                                            F::mul_add(
                                                A125,
                                                k5[i],
                                                F::mul_add(A124, k4[i], A121 * k1[i]),
                                            ),
                                        ),
                                    ),
                                ),
                            ),
                        ),
                    ),
                    y[i],
                );
            }
        }
        sys.eval(t_new, ys, k12);
        let k12 = &k12[..n];

        // 8th-order solution and the squared, scaled components of both error estimates in one
        // vectorised pass; their sums in a second pass over eight partial sums (running sums
        // would serialise the first loop).
        let y_new = &mut y_new[..n];
        let e3_sq = &mut e3_sq[..n];
        let e5_sq = &mut e5_sq[..n];
        let mut finite = true;
        for i in 0..n {
            let bk = B1 * k1[i]
                + B6 * k6[i]
                + B7 * k7[i]
                + B8 * k8[i]
                + B9 * k9[i]
                + B10 * k10[i]
                + B11 * k11[i]
                + B12 * k12[i];
            let yn = y[i] + h * bk;
            y_new[i] = yn;
            finite &= yn.is_finite();
            let sk = atol[i] + rtol * y[i].abs().max(yn.abs());
            // A component with no tolerance scale (exactly zero, atol 0) is left out.
            let inv = if sk > 0.0 { 1.0 / sk } else { 0.0 };
            let e3 = (bk - BHH1 * k1[i] - BHH2 * k9[i] - BHH3 * k12[i]) * inv;
            let e5 = (ER1 * k1[i]
                + ER6 * k6[i]
                + ER7 * k7[i]
                + ER8 * k8[i]
                + ER9 * k9[i]
                + ER10 * k10[i]
                + ER11 * k11[i]
                + ER12 * k12[i])
                * inv;
            e3_sq[i] = e3 * e3;
            e5_sq[i] = e5 * e5;
        }
        let err3 = lane_sum(e3_sq);
        let err5 = lane_sum(e5_sq);
        let mut deno = err5 + 0.01 * err3;
        if deno <= 0.0 {
            deno = 1.0;
        }
        let err = h.abs() * err5 * (1.0 / (n as f64 * deno)).sqrt();
        (err, finite)
    }

    /// After a step has passed the error test: `k13 = f(t_new, y_new)` (the next step's first
    /// stage), dense stages 14–16, and the eight dense-output coefficients of every component.
    /// Exactly 4 right-hand-side evaluations. Returns whether all coefficients are finite.
    #[inline(always)]
    fn prepare_dense<F: MulAdd>(&mut self, sys: &mut Rhs, t: f64, h: f64, t_new: f64) -> bool {
        let n = self.y.len();
        let Work {
            y,
            y_new,
            ys,
            k1,
            k2: k14,
            k3: k15,
            k4: k16,
            k6,
            k7,
            k8,
            k9,
            k10,
            k11,
            k12,
            k13,
            epoch,
            stiffness,
            ..
        } = self;
        let y = &y[..n];
        let y_new = &y_new[..n];
        let k1 = &k1[..n];
        let k6 = &k6[..n];
        let k7 = &k7[..n];
        let k8 = &k8[..n];
        let k9 = &k9[..n];
        let k10 = &k10[..n];
        let k11 = &k11[..n];
        let k12 = &k12[..n];

        sys.eval(t_new, y_new, k13);
        let k13 = &k13[..n];

        // Hairer's stiffness estimate h·|λ| ≈ h ‖f(y_new) − f(ys)‖ / ‖y_new − ys‖, where ys is the
        // argument of stage 12 (also at t_new): near 6.1 the step sits on the stability boundary.
        // Eight interleaved partial sums, so that the loop vectorises (a running sum would
        // serialise it); only a diagnostic depends on the rounding.
        let (mut num_lanes, mut den_lanes) = ([0.0f64; 8], [0.0f64; 8]);
        let ys_n = &ys[..n];
        let (c13, c12) = (k13.chunks_exact(8), k12.chunks_exact(8));
        let (cy, cs) = (y_new.chunks_exact(8), ys_n.chunks_exact(8));
        let rest = (
            c13.remainder(),
            c12.remainder(),
            cy.remainder(),
            cs.remainder(),
        );
        for (((a, b), c), d) in c13.zip(c12).zip(cy).zip(cs) {
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
        *stiffness = if den > 0.0 {
            h * (num / den).sqrt()
        } else {
            0.0
        };

        {
            let s = &mut ys[..n];
            for i in 0..n {
                s[i] = F::mul_add(
                    h,
                    F::mul_add(
                        A1413,
                        k13[i],
                        F::mul_add(
                            A1412,
                            k12[i],
                            F::mul_add(
                                A1411,
                                k11[i],
                                F::mul_add(
                                    A1410,
                                    k10[i],
                                    F::mul_add(
                                        A149,
                                        k9[i],
                                        F::mul_add(
                                            A148,
                                            k8[i],
                                            F::mul_add(A147, k7[i], A141 * k1[i]),
                                        ),
                                    ),
                                ),
                            ),
                        ),
                    ),
                    y[i],
                );
            }
        }
        sys.eval(t + C14 * h, ys, k14);
        let k14 = &k14[..n];

        {
            let s = &mut ys[..n];
            for i in 0..n {
                s[i] = F::mul_add(
                    h,
                    F::mul_add(
                        A1514,
                        k14[i],
                        F::mul_add(
                            A1513,
                            k13[i],
                            F::mul_add(
                                A1512,
                                k12[i],
                                F::mul_add(
                                    A1511,
                                    k11[i],
                                    F::mul_add(
                                        A158,
                                        k8[i],
                                        F::mul_add(
                                            A157,
                                            k7[i],
                                            F::mul_add(A156, k6[i], A151 * k1[i]),
                                        ),
                                    ),
                                ),
                            ),
                        ),
                    ),
                    y[i],
                );
            }
        }
        sys.eval(t + C15 * h, ys, k15);
        let k15 = &k15[..n];

        {
            let s = &mut ys[..n];
            for i in 0..n {
                s[i] = F::mul_add(
                    h,
                    F::mul_add(
                        A1615,
                        k15[i],
                        F::mul_add(
                            A1614,
                            k14[i],
                            F::mul_add(
                                A1613,
                                k13[i],
                                F::mul_add(
                                    A169,
                                    k9[i],
                                    F::mul_add(
                                        A168,
                                        k8[i],
                                        F::mul_add(
                                            A167,
                                            k7[i],
                                            F::mul_add(A166, k6[i], A161 * k1[i]),
                                        ),
                                    ),
                                ),
                            ),
                        ),
                    ),
                    y[i],
                );
            }
        }
        sys.eval(t + C16 * h, ys, k16);
        let k16 = &k16[..n];

        *epoch += 1;
        all_finite(k13) && all_finite(k14) && all_finite(k16) && all_finite(&k15[..n])
    }
}

/// The interpolant handed to the observer: Hairer's `CONTD8` on one accepted step.
pub struct Dop853Step<'a> {
    t0: f64,
    t1: f64,
    h: f64,
    w: &'a Work,
}

impl Dop853Step<'_> {
    /// The eight dense-output coefficients of component `i` (Hairer's `rcont1..8`), computed
    /// from the stages of this step on first use and cached until the next step.
    #[inline(always)]
    fn coefficients(&self, i: usize) -> [f64; 8] {
        let w = self.w;
        if w.cont_epoch[i].get() == w.epoch {
            return w.cont[i].get();
        }
        self.compute_coefficients(i)
    }

    /// [`Dop853Step::coefficients`] on first use in a step (kept out of line: the cached case is
    /// the frequent one, several samples per step).
    #[inline(never)]
    fn compute_coefficients(&self, i: usize) -> [f64; 8] {
        let w = self.w;
        let h = self.h;
        let (k1, k6, k7, k8, k9) = (w.k1[i], w.k6[i], w.k7[i], w.k8[i], w.k9[i]);
        let (k10, k11, k12, k13) = (w.k10[i], w.k11[i], w.k12[i], w.k13[i]);
        // Dense stages 14-16 live in the buffers of stages 2-4.
        let (k14, k15, k16) = (w.k2[i], w.k3[i], w.k4[i]);
        let ydiff = w.y_new[i] - w.y[i];
        let bspl = h * k1 - ydiff;
        let c = [
            w.y[i],
            ydiff,
            bspl,
            ydiff - h * k13 - bspl,
            h * (D41 * k1
                + D46 * k6
                + D47 * k7
                + D48 * k8
                + D49 * k9
                + D410 * k10
                + D411 * k11
                + D412 * k12
                + D413 * k13
                + D414 * k14
                + D415 * k15
                + D416 * k16),
            h * (D51 * k1
                + D56 * k6
                + D57 * k7
                + D58 * k8
                + D59 * k9
                + D510 * k10
                + D511 * k11
                + D512 * k12
                + D513 * k13
                + D514 * k14
                + D515 * k15
                + D516 * k16),
            h * (D61 * k1
                + D66 * k6
                + D67 * k7
                + D68 * k8
                + D69 * k9
                + D610 * k10
                + D611 * k11
                + D612 * k12
                + D613 * k13
                + D614 * k14
                + D615 * k15
                + D616 * k16),
            h * (D71 * k1
                + D76 * k6
                + D77 * k7
                + D78 * k8
                + D79 * k9
                + D710 * k10
                + D711 * k11
                + D712 * k12
                + D713 * k13
                + D714 * k14
                + D715 * k15
                + D716 * k16),
        ];
        w.cont[i].set(c);
        w.cont_epoch[i].set(w.epoch);
        c
    }

    #[inline(always)]
    fn contd8(c: &[f64; 8], s: f64) -> f64 {
        let s1 = 1.0 - s;
        let conpar = c[4] + s * (c[5] + s1 * (c[6] + s * c[7]));
        c[0] + s * (c[1] + s1 * (c[2] + s * (c[3] + s1 * conpar)))
    }
}

impl DenseStep for Dop853Step<'_> {
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
        Self::contd8(&self.coefficients(i), s)
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
            out[i] = Self::contd8(&self.coefficients(i), s);
        }
    }
    fn eval_components_at(&self, times: &[f64], indices: &[usize], out: &mut [f64]) {
        const MAX: usize = 16;
        let m = indices.len();
        if m > MAX || m == 0 {
            for (&t, row) in times.iter().zip(out.chunks_exact_mut(m.max(1))) {
                for (o, &i) in row.iter_mut().zip(indices) {
                    *o = self.eval_component(t, i);
                }
            }
            return;
        }
        // The coefficients of the components side by side (row r: coefficient r of each), so
        // that one sample evaluates `contd8` for all of them in vector lanes; the arithmetic of
        // each lane is `contd8`'s, operation for operation.
        let mut c = [[0.0f64; MAX]; 8];
        for (j, &i) in indices.iter().enumerate() {
            for (r, v) in self.coefficients(i).into_iter().enumerate() {
                c[r][j] = v;
            }
        }
        for (&t, row) in times.iter().zip(out.chunks_exact_mut(m)) {
            if t == self.t1 {
                for (o, &i) in row.iter_mut().zip(indices) {
                    *o = self.w.y_new[i];
                }
                continue;
            }
            let s = (t - self.t0) / self.h;
            let s1 = 1.0 - s;
            let mut lanes = [0.0f64; MAX];
            // Whole vectors of four lanes (the lanes past `m` hold zeros and are not read).
            for j in 0..m.div_ceil(4) * 4 {
                let conpar = c[4][j] + s * (c[5][j] + s1 * (c[6][j] + s * c[7][j]));
                lanes[j] = c[0][j] + s * (c[1][j] + s1 * (c[2][j] + s * (c[3][j] + s1 * conpar)));
            }
            row.copy_from_slice(&lanes[..m]);
        }
    }
}

impl Stepper for Work {
    type Dense<'a> = Dop853Step<'a>;

    fn start(&mut self, rhs: &mut Rhs, t0: f64) -> bool {
        rhs.eval(t0, &self.y, &mut self.k1);
        all_finite(&self.k1)
    }
    fn y(&self) -> &[f64] {
        &self.y
    }
    fn f0(&self) -> &[f64] {
        &self.k1
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
    fn prepare_dense<F: MulAdd>(&mut self, rhs: &mut Rhs, t: f64, h: f64, t_new: f64) -> bool {
        Work::prepare_dense::<F>(self, rhs, t, h, t_new)
    }
    fn finish(&mut self, _rhs: &mut Rhs, _t_new: f64) -> bool {
        true
    }
    fn dense(&self, t0: f64, t1: f64, h: f64) -> Dop853Step<'_> {
        Dop853Step { t0, t1, h, w: self }
    }
    fn advance(&mut self) {
        std::mem::swap(&mut self.y, &mut self.y_new);
        std::mem::swap(&mut self.k1, &mut self.k13);
    }
    fn on_stability_boundary(&self) -> Option<bool> {
        Some(self.stiffness > STIFFNESS_BOUND)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::OdeSystem;
    use crate::integrate::{
        Control, IntegrateError, IntegrationStats, Integrator, OdeSystemDyn, StepObserver,
    };
    use crate::problems::{run_recorded, ForcedDecay, HarmonicOscillator, StepRecord};

    /// Counts its own right-hand-side calls; optionally returns NaN for t > `nan_after`.
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

    fn run(
        solver: &Dop853,
        sys: &mut dyn OdeSystemDyn,
        y0: &[f64],
        t_end: f64,
    ) -> (Result<IntegrationStats, IntegrateError>, StepRecord) {
        run_recorded(solver, sys, y0, t_end)
    }

    fn osc_error(tol: f64, t_end: f64) -> (f64, IntegrationStats) {
        let (r, rec) = run(
            &Dop853::new(tol, tol),
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
    fn dop853_coefficients_are_consistent() {
        // Row sums equal the nodes.
        let rows: [(f64, &[f64]); 14] = [
            (C2, &[A21]),
            (C3, &[A31, A32]),
            (C4, &[A41, A43]),
            (C5, &[A51, A53, A54]),
            (C6, &[A61, A64, A65]),
            (C7, &[A71, A74, A75, A76]),
            (C8, &[A81, A84, A85, A86, A87]),
            (C9, &[A91, A94, A95, A96, A97, A98]),
            (C10, &[A101, A104, A105, A106, A107, A108, A109]),
            (C11, &[A111, A114, A115, A116, A117, A118, A119, A1110]),
            (
                1.0,
                &[A121, A124, A125, A126, A127, A128, A129, A1210, A1211],
            ),
            (C14, &[A141, A147, A148, A149, A1410, A1411, A1412, A1413]),
            (C15, &[A151, A156, A157, A158, A1511, A1512, A1513, A1514]),
            (C16, &[A161, A166, A167, A168, A169, A1613, A1614, A1615]),
        ];
        for (c, a) in rows {
            let s: f64 = a.iter().sum();
            assert!((s - c).abs() < 1e-14, "row sum {s} vs c {c}");
        }
        // Quadrature conditions sum b_i c_i^k = 1/(k+1), k = 0..7.
        let b = [B1, B6, B7, B8, B9, B10, B11, B12];
        let c = [0.0, C6, C7, C8, C9, C10, C11, 1.0];
        for k in 0..8 {
            let s: f64 = b.iter().zip(&c).map(|(b, c)| b * c.powi(k)).sum();
            assert!((s - 1.0 / f64::from(k + 1)).abs() < 1e-13, "k = {k}: {s}");
        }
        // The 5th-order error weights integrate polynomials up to degree 4 exactly (sum to 0).
        let er = [ER1, ER6, ER7, ER8, ER9, ER10, ER11, ER12];
        for k in 0..5 {
            let s: f64 = er.iter().zip(&c).map(|(e, c)| e * c.powi(k)).sum();
            assert!(s.abs() < 1e-13, "er moment {k}: {s}");
        }
        // The 3rd-order comparison weights (bhh on stages 1, 9, 12) are exact up to degree 2.
        let cb = [0.0, C9, 1.0];
        let bhh = [BHH1, BHH2, BHH3];
        for k in 0..3 {
            let s: f64 = bhh.iter().zip(&cb).map(|(b, c)| b * c.powi(k)).sum();
            assert!(
                (s - 1.0 / f64::from(k + 1)).abs() < 1e-13,
                "bhh moment {k}: {s}"
            );
        }
    }

    #[test]
    fn dop853_harmonic_oscillator_accuracy() {
        let (e, stats) = osc_error(1e-10, 20.0);
        eprintln!("oscillator tol 1e-10: error {e:e}, {stats:?}");
        assert!(e < 1e-8, "error {e:e}");
        assert!(stats.steps > 10);
    }

    #[test]
    fn dop853_error_scales_with_tolerance() {
        let (e6, s6) = osc_error(1e-6, 20.0);
        let (e9, s9) = osc_error(1e-9, 20.0);
        eprintln!("e(1e-6) = {e6:e}, e(1e-9) = {e9:e}, ratio {}", e6 / e9);
        assert!(e6 / e9 > 100.0, "e(1e-6) = {e6:e}, e(1e-9) = {e9:e}");
        assert!(s9.steps > s6.steps);
    }

    #[test]
    fn dop853_dense_output_accuracy() {
        struct Dense {
            grid: Vec<f64>,
            next: usize,
            max_err: f64,
            buf: Vec<f64>,
        }
        impl StepObserver for Dense {
            fn on_start(&mut self, _t0: f64, _y0: &[f64]) {}
            fn on_step(&mut self, step: &dyn DenseStep) -> Control {
                while self.next < self.grid.len() && self.grid[self.next] <= step.t_end() {
                    let t = self.grid[self.next];
                    assert!(t >= step.t_start());
                    let x = step.eval_component(t, 0);
                    let v = step.eval_component(t, 1);
                    step.eval(t, &mut self.buf);
                    assert_eq!(self.buf, [x, v]);
                    let e = (x - t.cos()).abs().max((v + t.sin()).abs());
                    self.max_err = self.max_err.max(e);
                    self.next += 1;
                }
                Control::Continue
            }
        }
        let t_end = 20.0;
        // 1000 points strictly inside (0, t_end), none on a grid that matches step ends.
        let grid: Vec<f64> = (0..1000)
            .map(|k| (k as f64 + 0.5) * t_end / 1000.0)
            .collect();
        let mut obs = Dense {
            grid,
            next: 0,
            max_err: 0.0,
            buf: vec![0.0; 2],
        };
        let stats = Dop853::new(1e-10, 1e-10)
            .integrate(
                &mut HarmonicOscillator { quadrature: false },
                0.0,
                &[1.0, 0.0],
                t_end,
                100_000,
                &mut obs,
            )
            .unwrap();
        assert_eq!(obs.next, 1000);
        // Far fewer steps than samples: the samples really are interpolated.
        assert!(stats.steps < 200, "{stats:?}");
        eprintln!(
            "dense: max error {:e} over 1000 points, {stats:?}",
            obs.max_err
        );
        assert!(obs.max_err < 1e-8, "dense error {:e}", obs.max_err);
    }

    /// Compares, on every step, the batched interpolation of a few components at several times
    /// (the step's end among them) with the per-component one, bit for bit.
    struct BatchCheck {
        steps: usize,
    }
    impl StepObserver for BatchCheck {
        fn on_start(&mut self, _t0: f64, _y0: &[f64]) {}
        fn on_step(&mut self, step: &dyn DenseStep) -> Control {
            let (t0, t1) = (step.t_start(), step.t_end());
            let times: Vec<f64> = (1..=7).map(|k| t0 + (t1 - t0) * k as f64 / 7.0).collect();
            let indices = [2, 0, 1];
            let mut out = vec![f64::NAN; times.len() * indices.len()];
            step.eval_components_at(&times, &indices, &mut out);
            for (r, &t) in times.iter().enumerate() {
                for (j, &i) in indices.iter().enumerate() {
                    let one = step.eval_component(t, i);
                    assert_eq!(
                        out[r * indices.len() + j].to_bits(),
                        one.to_bits(),
                        "t {t}, i {i}"
                    );
                }
            }
            self.steps += 1;
            Control::Continue
        }
    }

    #[test]
    fn dop853_batched_dense_output_is_bitwise_the_scalar_one() {
        let mut check = BatchCheck { steps: 0 };
        Dop853::new(1e-9, 1e-9)
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

    #[test]
    fn dop853_quadrature_component() {
        let t_end = 7.5;
        let (r, rec) = run(
            &Dop853::new(1e-10, 1e-10),
            &mut HarmonicOscillator { quadrature: true },
            &[1.0, 0.0, 0.0],
            t_end,
        );
        r.unwrap();
        // q = int_0^T cos^2 = T/2 + sin(2T)/4
        let exact = t_end / 2.0 + (2.0 * t_end).sin() / 4.0;
        let e = (rec.y[2] - exact).abs();
        eprintln!("quadrature error {e:e}");
        assert!(e < 1e-8, "quadrature error {e:e}");
    }

    #[test]
    fn dop853_step_budget() {
        let mut rec = StepRecord::default();
        let r = Dop853::new(1e-10, 1e-10).integrate(
            &mut HarmonicOscillator { quadrature: false },
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
    }

    #[test]
    fn dop853_nonfinite_rhs() {
        let mut sys = Counted {
            calls: 0,
            nan_after: 1.0,
        };
        let mut rec = StepRecord::default();
        let r =
            Dop853::new(1e-8, 1e-8).integrate(&mut sys, 0.0, &[1.0, 0.0], 5.0, 100_000, &mut rec);
        match r {
            Err(IntegrateError::NonFinite { t }) => {
                eprintln!("NonFinite at t = {t}, last observed t = {}", rec.t);
                assert!(t > 0.5 && t <= 1.0, "t = {t}");
                // Everything handed to the observer is finite and before the wall.
                assert!(rec.t <= 1.0);
                assert!(all_finite(&rec.y));
            }
            other => panic!("expected NonFinite, got {other:?}"),
        }
    }

    #[test]
    fn dop853_recovers_from_transient_nonfinite() {
        // y' = -10 y, with the right-hand side undefined for y < 0. A huge first step overshoots
        // into y < 0; the step is shrunk and the run completes accurately.
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
        let solver = Dop853 {
            h_init: Some(1.0),
            ..Dop853::new(1e-10, 1e-12)
        };
        let (r, rec) = run(&solver, &mut Guarded, &[1.0], 1.0);
        let stats = r.unwrap();
        eprintln!("transient NaN: {stats:?}");
        assert!(stats.rejected >= 1);
        let e = (rec.y[0] - (-10.0f64).exp()).abs();
        assert!(e < 1e-9, "error {e:e}");
    }

    #[test]
    fn dop853_rhs_eval_accounting() {
        // Automatic first step: 1 (at t0) + 1 (HINIT) + 15 per accepted + 11 per rejected.
        let mut sys = Counted {
            calls: 0,
            nan_after: f64::INFINITY,
        };
        let mut rec = StepRecord::default();
        let s = Dop853::new(1e-9, 1e-9)
            .integrate(&mut sys, 0.0, &[1.0, 0.0], 10.0, 100_000, &mut rec)
            .unwrap();
        assert_eq!(s.rhs_evals, sys.calls);
        assert_eq!(s.rhs_evals, 2 + 15 * s.steps + 11 * s.rejected);
        assert_eq!(s.steps as usize, rec.steps.len());

        // A far too large first step forces rejections; no HINIT evaluation.
        let mut sys = Counted {
            calls: 0,
            nan_after: f64::INFINITY,
        };
        let solver = Dop853 {
            h_init: Some(8.0),
            ..Dop853::new(1e-9, 1e-9)
        };
        let s = solver
            .integrate(
                &mut sys,
                0.0,
                &[1.0, 0.0],
                10.0,
                100_000,
                &mut StepRecord::default(),
            )
            .unwrap();
        eprintln!("forced rejections: {s:?}");
        assert!(s.rejected >= 1, "{s:?}");
        assert_eq!(s.rhs_evals, sys.calls);
        assert_eq!(s.rhs_evals, 1 + 15 * s.steps + 11 * s.rejected);
    }

    #[test]
    fn rejected_attempts_count_against_the_step_budget() {
        // A far too large first step forces rejections: with a budget one short of the attempts
        // the run needs (accepted + rejected) it fails, though it has more than enough for the
        // accepted steps alone; with exactly the attempts it needs it succeeds.
        let solver = Dop853 {
            h_init: Some(8.0),
            ..Dop853::new(1e-9, 1e-9)
        };
        let run = |budget: u64| {
            solver.integrate(
                &mut HarmonicOscillator { quadrature: false },
                0.0,
                &[1.0, 0.0],
                10.0,
                budget,
                &mut StepRecord::default(),
            )
        };
        let s = run(100_000).unwrap();
        assert!(s.rejected >= 3, "{s:?}");
        let attempts = s.steps + s.rejected;
        assert_eq!(run(attempts), Ok(s));
        match run(attempts - 1) {
            Err(IntegrateError::StepBudget { max_steps, .. }) => {
                assert_eq!(max_steps, attempts - 1)
            }
            other => panic!("expected StepBudget, got {other:?}"),
        }
        // Fewer accepted steps than the budget, even with every rejection: still refused.
        assert!(s.steps < attempts - 1);
    }

    /// Fixed steps: huge tolerances so the controller always wants to grow, capped at h_max.
    fn fixed_step_error(
        sys: &mut dyn OdeSystemDyn,
        y0: &[f64],
        t_end: f64,
        n: u32,
    ) -> (f64, Vec<f64>) {
        let h = t_end / f64::from(n);
        let solver = Dop853::new(1e3, 1e3).with_initial_step(h).with_max_step(h);
        let (r, rec) = run(&solver, sys, y0, t_end);
        let s = r.unwrap();
        assert_eq!(s.steps, u64::from(n));
        assert_eq!(s.rejected, 0);
        for &(a, b) in &rec.steps {
            assert!(((b - a) - h).abs() < 1e-12 * t_end);
        }
        (h, rec.y)
    }

    #[test]
    fn dop853_convergence_order() {
        // y' = -y + sin t on [0, 10].
        let t_end = 10.0;
        let (h1, y1) = fixed_step_error(&mut ForcedDecay, &[1.0], t_end, 10);
        let (h2, y2) = fixed_step_error(&mut ForcedDecay, &[1.0], t_end, 20);
        let e1 = (y1[0] - ForcedDecay::exact(t_end)).abs();
        let e2 = (y2[0] - ForcedDecay::exact(t_end)).abs();
        let p = (e1 / e2).ln() / (h1 / h2).ln();
        eprintln!("forced decay: order {p} (e1 {e1:e}, e2 {e2:e})");
        assert!(p > 7.5 && p < 9.0, "order {p} (e1 {e1:e}, e2 {e2:e})");

        // Harmonic oscillator on [0, 10].
        let (h1, y1) = fixed_step_error(
            &mut HarmonicOscillator { quadrature: false },
            &[1.0, 0.0],
            t_end,
            10,
        );
        let (h2, y2) = fixed_step_error(
            &mut HarmonicOscillator { quadrature: false },
            &[1.0, 0.0],
            t_end,
            20,
        );
        let err = |y: &[f64]| (y[0] - t_end.cos()).abs().max((y[1] + t_end.sin()).abs());
        let (e1, e2) = (err(&y1), err(&y2));
        let p = (e1 / e2).ln() / (h1 / h2).ln();
        eprintln!("oscillator: order {p} (e1 {e1:e}, e2 {e2:e})");
        assert!(p > 7.5 && p < 9.0, "order {p} (e1 {e1:e}, e2 {e2:e})");
    }

    #[test]
    fn dop853_dense_output_order() {
        // The continuous extension is 7th order: halving h divides the interpolation error of a
        // single step by about 2^8 (local error O(h^8)).
        struct Mid {
            max_err: f64,
        }
        impl StepObserver for Mid {
            fn on_start(&mut self, _t0: f64, _y0: &[f64]) {}
            fn on_step(&mut self, step: &dyn DenseStep) -> Control {
                let (a, b) = (step.t_start(), step.t_end());
                for j in 1..10 {
                    let t = a + (b - a) * f64::from(j) / 10.0;
                    // Compare with the exact solution through the step's own start value, so only
                    // the local (interpolation) error counts.
                    let e = (step.eval_component(t, 0) - ForcedDecay::exact(t)).abs();
                    self.max_err = self.max_err.max(e);
                }
                Control::Stop
            }
        }
        let err_for = |h: f64| {
            let solver = Dop853::new(1e3, 1e3).with_initial_step(h).with_max_step(h);
            let mut obs = Mid { max_err: 0.0 };
            solver
                .integrate(&mut ForcedDecay, 0.0, &[1.0], 10.0, 10, &mut obs)
                .unwrap();
            obs.max_err
        };
        let (e1, e2) = (err_for(1.0), err_for(0.5));
        let p = (e1 / e2).log2();
        eprintln!("dense local order {p} (e1 {e1:e}, e2 {e2:e})");
        assert!(
            p > 7.0 && p < 9.5,
            "local dense order {p} (e1 {e1:e}, e2 {e2:e})"
        );
    }

    #[test]
    fn dop853_stop_and_start() {
        struct StopAfter(usize, usize, bool);
        impl StepObserver for StopAfter {
            fn on_start(&mut self, t0: f64, y0: &[f64]) {
                assert_eq!(t0, 0.0);
                assert_eq!(y0, [1.0, 0.0]);
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
        let s = Dop853::new(1e-10, 1e-10)
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
        assert_eq!(s.steps, 3);
        assert_eq!(obs.1, 3);
    }

    #[test]
    fn dop853_h_max_is_respected() {
        let solver = Dop853::new(1e-6, 1e-6).with_max_step(0.1);
        let (r, rec) = run(
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
    }

    #[test]
    fn dop853_atol_scale() {
        // Pure absolute control (rtol tiny): scaling atol by 1e-3 on every component must give the
        // same steps as atol / 1e3, and a wrong-length scale vector is rejected.
        let base = Dop853::new(1e-14, 1e-9);
        let scaled = Dop853 {
            atol_scale: Some(vec![1e-3, 1e-3]),
            ..Dop853::new(1e-14, 1e-6)
        };
        let (ra, a) = run(
            &base,
            &mut HarmonicOscillator { quadrature: false },
            &[1.0, 0.0],
            5.0,
        );
        let (rb, b) = run(
            &scaled,
            &mut HarmonicOscillator { quadrature: false },
            &[1.0, 0.0],
            5.0,
        );
        assert_eq!(ra.unwrap(), rb.unwrap());
        assert_eq!(a.steps, b.steps);
        // Loosening only the velocity tolerance takes fewer steps than the uniform one.
        let loose_v = Dop853 {
            atol_scale: Some(vec![1.0, 1e3]),
            ..Dop853::new(1e-14, 1e-9)
        };
        let (rc, _) = run(
            &loose_v,
            &mut HarmonicOscillator { quadrature: false },
            &[1.0, 0.0],
            5.0,
        );
        assert!(rc.unwrap().steps <= a.steps.len() as u64);
        let bad = Dop853 {
            atol_scale: Some(vec![1.0]),
            ..Dop853::new(1e-6, 1e-6)
        };
        let (r, _) = run(
            &bad,
            &mut HarmonicOscillator { quadrature: false },
            &[1.0, 0.0],
            1.0,
        );
        assert!(matches!(r, Err(IntegrateError::InvalidSettings(_))));
        let bad = Dop853 {
            atol_scale: Some(vec![1.0, f64::NAN]),
            ..Dop853::new(1e-6, 1e-6)
        };
        let (r, _) = run(
            &bad,
            &mut HarmonicOscillator { quadrature: false },
            &[1.0, 0.0],
            1.0,
        );
        assert!(matches!(r, Err(IntegrateError::InvalidSettings(_))));
    }

    #[test]
    fn dop853_invalid_settings() {
        let mut sys = HarmonicOscillator { quadrature: false };
        let y0 = [1.0, 0.0];
        let bad = |s: Dop853, y0: &[f64], t_end: f64, sys: &mut HarmonicOscillator| {
            let r = s.integrate(sys, 0.0, y0, t_end, 100, &mut StepRecord::default());
            assert!(
                matches!(r, Err(IntegrateError::InvalidSettings(_))),
                "{r:?}"
            );
        };
        bad(Dop853::new(0.0, 1e-6), &y0, 1.0, &mut sys);
        bad(Dop853::new(-1e-6, 1e-6), &y0, 1.0, &mut sys);
        bad(Dop853::new(1e-6, -1e-6), &y0, 1.0, &mut sys);
        bad(Dop853::new(0.0, 0.0), &y0, 1.0, &mut sys);
        bad(Dop853::new(1e-6, 1e-6), &y0, 0.0, &mut sys);
        bad(Dop853::new(1e-6, 1e-6), &y0, -1.0, &mut sys);
        bad(Dop853::new(1e-6, 1e-6), &[f64::NAN, 0.0], 1.0, &mut sys);
        bad(Dop853::new(1e-6, 1e-6), &[1.0], 1.0, &mut sys);
        bad(
            Dop853::new(1e-6, 1e-6).with_max_step(0.0),
            &y0,
            1.0,
            &mut sys,
        );
        // Pure relative tolerance is allowed.
        let (r, _) = run(&Dop853::new(1e-8, 0.0), &mut sys, &y0, 1.0);
        r.unwrap();
        assert_eq!(Dop853::new(1e-6, 1e-6).name(), "dop853");
    }
}
