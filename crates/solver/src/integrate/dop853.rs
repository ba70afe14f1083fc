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

use chainsweep_cpu::MulAdd;

use super::adaptive::{Adaptive, Controller, Method, RejectionForm, Rhs};
use super::explicit::{
    gather, lane_sum, weighted_sum, ExplicitMethod, Stage, Tableau, Work, MAX_DENSE_COEFFICIENTS,
};

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
    type Stepper = Work<Self>;
    fn stepper(y0: &[f64], _n_pos: usize) -> Work<Self> {
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

/// The stages: stage j of Hairer's numbering is stage j − 1 here (0 is `f(t, y)`); stage 12 is
/// `f(t + h, y_new)` (Hairer's k13, the next step's first), 13–15 the continuous extension's.
const STAGES: &[Stage] = &[
    Stage { c: 0.0, a: &[] },
    Stage {
        c: C2,
        a: &[(0, A21)],
    },
    Stage {
        c: C3,
        a: &[(0, A31), (1, A32)],
    },
    Stage {
        c: C4,
        a: &[(0, A41), (2, A43)],
    },
    Stage {
        c: C5,
        a: &[(0, A51), (2, A53), (3, A54)],
    },
    Stage {
        c: C6,
        a: &[(0, A61), (3, A64), (4, A65)],
    },
    Stage {
        c: C7,
        a: &[(0, A71), (3, A74), (4, A75), (5, A76)],
    },
    Stage {
        c: C8,
        a: &[(0, A81), (3, A84), (4, A85), (5, A86), (6, A87)],
    },
    Stage {
        c: C9,
        a: &[(0, A91), (3, A94), (4, A95), (5, A96), (6, A97), (7, A98)],
    },
    Stage {
        c: C10,
        a: &[
            (0, A101),
            (3, A104),
            (4, A105),
            (5, A106),
            (6, A107),
            (7, A108),
            (8, A109),
        ],
    },
    Stage {
        c: C11,
        a: &[
            (0, A111),
            (3, A114),
            (4, A115),
            (5, A116),
            (6, A117),
            (7, A118),
            (8, A119),
            (9, A1110),
        ],
    },
    Stage {
        c: 1.0,
        a: &[
            (0, A121),
            (3, A124),
            (4, A125),
            (5, A126),
            (6, A127),
            (7, A128),
            (8, A129),
            (9, A1210),
            (10, A1211),
        ],
    },
    Stage { c: 1.0, a: WEIGHTS },
    Stage {
        c: C14,
        a: &[
            (0, A141),
            (6, A147),
            (7, A148),
            (8, A149),
            (9, A1410),
            (10, A1411),
            (11, A1412),
            (12, A1413),
        ],
    },
    Stage {
        c: C15,
        a: &[
            (0, A151),
            (5, A156),
            (6, A157),
            (7, A158),
            (10, A1511),
            (11, A1512),
            (12, A1513),
            (13, A1514),
        ],
    },
    Stage {
        c: C16,
        a: &[
            (0, A161),
            (5, A166),
            (6, A167),
            (7, A168),
            (8, A169),
            (12, A1613),
            (13, A1614),
            (14, A1615),
        ],
    },
];

/// The 8th-order weights.
const WEIGHTS: &[(usize, f64)] = &[
    (0, B1),
    (5, B6),
    (6, B7),
    (7, B8),
    (8, B9),
    (9, B10),
    (10, B11),
    (11, B12),
];

/// The 5th-order error weights: the 8th-order weights minus those of the embedded 5th-order
/// solution.
const ERROR5: &[(usize, f64)] = &[
    (0, ER1),
    (5, ER6),
    (6, ER7),
    (7, ER8),
    (8, ER9),
    (9, ER10),
    (10, ER11),
    (11, ER12),
];

/// The weights of the embedded 3rd-order solution.
const WEIGHTS3: &[(usize, f64)] = &[(0, BHH1), (8, BHH2), (11, BHH3)];

/// The continuous extension's rows: `d[r] = h Σ_j D_rj k_j` for r = 4..7.
const DENSE: [&[(usize, f64)]; 4] = [
    &[
        (0, D41),
        (5, D46),
        (6, D47),
        (7, D48),
        (8, D49),
        (9, D410),
        (10, D411),
        (11, D412),
        (12, D413),
        (13, D414),
        (14, D415),
        (15, D416),
    ],
    &[
        (0, D51),
        (5, D56),
        (6, D57),
        (7, D58),
        (8, D59),
        (9, D510),
        (10, D511),
        (11, D512),
        (12, D513),
        (13, D514),
        (14, D515),
        (15, D516),
    ],
    &[
        (0, D61),
        (5, D66),
        (6, D67),
        (7, D68),
        (8, D69),
        (9, D610),
        (10, D611),
        (11, D612),
        (12, D613),
        (13, D614),
        (14, D615),
        (15, D616),
    ],
    &[
        (0, D71),
        (5, D76),
        (6, D77),
        (7, D78),
        (8, D79),
        (9, D710),
        (10, D711),
        (11, D712),
        (12, D713),
        (13, D714),
        (14, D715),
        (15, D716),
    ],
];

/// Hairer's DOP853 as data: its twelve stages, the FSAL stage evaluated only once a step has
/// passed the error test (the error estimate does not use it), and the continuous extension's
/// stages kept in the buffers of stages 1–3, which nothing reads after the solution.
const TABLEAU: Tableau = Tableau {
    stages: STAGES,
    attempt: 11,
    fsal: 12,
    fsal_in_attempt: false,
    buffers: &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 1, 2, 3],
    // Hairer's combined 5th/3rd-order norm and `CONTD8` are DOP853's own (below), with an
    // operation order the standard ones do not have.
    error: &[],
    interpolant: &[],
};

impl ExplicitMethod for Dop853Method {
    const TABLEAU: Tableau = TABLEAU;
    const STIFFNESS_BOUND: Option<f64> = Some(STIFFNESS_BOUND);

    /// The 8th-order solution and the squared, scaled components of both error estimates in one
    /// vectorised pass (each a plain sum from the first stage on, Hairer's arithmetic); their
    /// sums in a second pass over eight partial sums (running sums would serialise the first
    /// loop); Hairer's combined 5th/3rd-order norm.
    #[inline(always)]
    fn solution_and_error<F: MulAdd>(
        w: &mut Work<Self>,
        _rhs: &mut Rhs,
        h: f64,
        _t_new: f64,
        rtol: f64,
        atol: &[f64],
    ) -> (f64, bool) {
        let n = w.y.len();
        let Work {
            y,
            y_new,
            k,
            err_sq: [e3_sq, e5_sq],
            ..
        } = w;
        let buffers = TABLEAU.buffers;
        let (b, kb) = gather::<8>(WEIGHTS, k, buffers);
        let (er, ke) = gather::<8>(ERROR5, k, buffers);
        let (b3, k3) = gather::<3>(WEIGHTS3, k, buffers);
        let (kb, ke, k3) = (
            kb.map(|s| &s[..n]),
            ke.map(|s| &s[..n]),
            k3.map(|s| &s[..n]),
        );
        let (y, y_new, atol) = (&y[..n], &mut y_new[..n], &atol[..n]);
        let (e3_sq, e5_sq) = (&mut e3_sq[..n], &mut e5_sq[..n]);
        let mut finite = true;
        for i in 0..n {
            let bk = weighted_sum(b, kb, i);
            let yn = y[i] + h * bk;
            y_new[i] = yn;
            finite &= yn.is_finite();
            let sk = atol[i] + rtol * y[i].abs().max(yn.abs());
            // A component with no tolerance scale (exactly zero, atol 0) is left out.
            let inv = if sk > 0.0 { 1.0 / sk } else { 0.0 };
            let mut e3 = bk;
            for m in 0..3 {
                e3 -= b3[m] * k3[m][i];
            }
            let e3 = e3 * inv;
            let e5 = weighted_sum(er, ke, i) * inv;
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

    /// Hairer's `rcont1..8` of `CONTD8`.
    #[inline(always)]
    fn dense_coefficients(h: f64, y: f64, y_new: f64, k: impl Fn(usize) -> f64) -> [f64; 8] {
        /// `h Σ_j D_j k_j`, a plain sum from the first stage on, over the stage values `kv` of
        /// the row's stages (every row reads the same ones).
        #[inline(always)]
        fn row(h: f64, d: &[(usize, f64)], kv: &[f64; 12]) -> f64 {
            let mut s = d[0].1 * kv[0];
            for q in 1..12 {
                s += d[q].1 * kv[q];
            }
            h * s
        }
        // Each stage's value read once.
        let mut kv = [0.0; 12];
        for (v, &(j, _)) in kv.iter_mut().zip(DENSE[0]) {
            *v = k(j);
        }
        let ydiff = y_new - y;
        let bspl = h * kv[0] - ydiff;
        [
            y,
            ydiff,
            bspl,
            ydiff - h * k(12) - bspl,
            row(h, DENSE[0], &kv),
            row(h, DENSE[1], &kv),
            row(h, DENSE[2], &kv),
            row(h, DENSE[3], &kv),
        ]
    }

    /// Hairer's `CONTD8`.
    #[inline(always)]
    fn interpolate(c: impl Fn(usize) -> f64, s: f64) -> f64 {
        let s1 = 1.0 - s;
        let conpar = c(4) + s * (c(5) + s1 * (c(6) + s * c(7)));
        c(0) + s * (c(1) + s1 * (c(2) + s * (c(3) + s1 * conpar)))
    }
    /// Each coefficient past the first is nested inside factors `s` and `1 − s`, both in
    /// `[0, 1]`: the interpolant strays from `c[0]` by at most the sum of their magnitudes.
    fn interpolant_radius(c: &[f64; MAX_DENSE_COEFFICIENTS]) -> Option<f64> {
        Some(c[1..8].iter().map(|x| x.abs()).sum())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::order_conditions::{dense_weights, matrix, worst_condition};

    #[test]
    fn the_continuous_extension_rows_read_the_same_stages() {
        for row in DENSE {
            assert_eq!(row.len(), 12);
            for (a, b) in row.iter().zip(DENSE[0]) {
                assert_eq!(a.0, b.0);
            }
        }
    }

    #[test]
    fn the_embedded_solutions_have_orders_five_and_three() {
        // The suite of every method (method_tests) checks the 8th-order weights and the
        // continuous extension; these are DOP853's own two error estimates.
        let (a, _) = matrix(&TABLEAU);
        let s = a.len();
        let b = dense_weights(WEIGHTS, s);
        let er = dense_weights(ERROR5, s);
        let b5: Vec<f64> = b.iter().zip(&er).map(|(b, e)| b - e).collect();
        let worst = worst_condition(&a, &b5, 1.0, 5);
        assert!(worst < 1e-13, "5th-order weights: {worst:e}");
        assert!(worst_condition(&a, &b5, 1.0, 6) > 1e-7);
        let b3 = dense_weights(WEIGHTS3, s);
        let worst = worst_condition(&a, &b3, 1.0, 3);
        assert!(worst < 1e-13, "3rd-order weights: {worst:e}");
        assert!(worst_condition(&a, &b3, 1.0, 4) > 1e-7);
    }
}
