//! The coefficients of ROS34PW2 as published, and the tables of the transformed formulation the
//! step uses, derived from them once at run time. Apart from the step so that the coefficients
//! and their order conditions read together, with nothing else in between.

// ---------------------------------------------------------------------------------------------
// Coefficients of ROS34PW2 (Rang & Angermann 2005), as registered by PETSc (TSROSWRA34PW2), in the
// k-form: k_i = h f(y0 + Σ_j α_ij k_j) + h W Σ_j γ_ij k_j, y1 = y0 + Σ b_i k_i.
// ---------------------------------------------------------------------------------------------

/// Number of stages.
pub(super) const S: usize = 4;
/// Degree of the dense-output polynomials in θ.
pub(super) const P: usize = 3;
/// Diagonal of Γ.
pub(super) const GAMMA: f64 = 4.358_665_215_084_59e-1;

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
pub(super) struct Tableau {
    /// `A = α Γ⁻¹`: `Y_i = y0 + Σ_{j<i} a_ij u_j`.
    pub(super) a: [[f64; S]; S],
    /// `C = diag(1/γ) − Γ⁻¹` (strictly lower part): `+ Σ_{j<i} (c_ij/h) u_j` on the right.
    pub(super) c: [[f64; S]; S],
    /// `m = b Γ⁻¹`: `y1 = y0 + Σ m_j u_j`.
    pub(super) m: [f64; S],
    /// `m − m̂`: the error estimate `y1 − ŷ1 = Σ e_j u_j`.
    pub(super) e: [f64; S],
    /// Stage abscissae `α_i = Σ_j α_ij`.
    pub(super) alpha: [f64; S],
    /// Dense output: `y(θ) = y0 + Σ_j (Σ_p d[j][p] θ^{p+1}) u_j`.
    pub(super) d: [[f64; P]; S],
}

impl Tableau {
    pub(super) fn new() -> Self {
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
