//! What a fit's minimum says about the fields: the covariance `(JᵀWJ)⁻¹` (scaled by `χ²/ν` when
//! σ is estimated), standard errors, correlations, linearised 95 % intervals, χ² with its p-value,
//! and the combinations of fields the data hardly determine.

use nalgebra::{DMatrix, SymmetricEigen};
use statrs::distribution::{ChiSquared, ContinuousCDF, StudentsT};

/// Two-sided level of every interval.
pub const LEVEL: f64 = 0.95;

/// The smallest eigenvalue of the column-normalised information matrix below which a combination
/// of fields counts as unidentifiable: for two fields, |correlation| > 0.99.
pub const UNIDENTIFIABLE_EIGENVALUE: f64 = 0.01;

/// The statistics of a fit at its minimum.
#[derive(Debug, Clone, PartialEq)]
pub struct FitStats {
    /// χ²: the sum of the squared (weighted) residuals.
    pub chi_square: f64,
    /// Degrees of freedom: data less fields less nuisance parameters.
    pub dof: usize,
    /// σ² of the residuals: 1 with σ given, χ²/ν when estimated.
    pub scale: f64,
    /// Upper-tail probability of χ² with ν degrees of freedom (σ given; NaN when estimated).
    pub p_value: f64,
    /// Covariance of the fields, row-major p × p, field units (infinite along directions the data
    /// do not determine).
    pub covariance: Vec<f64>,
    /// Standard errors.
    pub standard_error: Vec<f64>,
    /// Correlations, row-major p × p.
    pub correlation: Vec<f64>,
    /// The quantile the linearised interval is `± quantile · standard_error` (1.96, or Student's
    /// t with ν degrees of freedom when σ is estimated).
    pub quantile: f64,
    /// The rise of χ² that bounds a profile-likelihood interval: 3.84, or `F(1, ν) · s²` when σ is
    /// estimated.
    pub profile_threshold: f64,
    /// Condition number of the column-normalised Jacobian.
    pub condition: f64,
    /// The direction (field units, largest component ±1) the data determine least, and its
    /// normalised information (below [`UNIDENTIFIABLE_EIGENVALUE`]: unidentifiable).
    pub weakest: (Vec<f64>, f64),
}

impl FitStats {
    /// The statistics of residuals `r` with Jacobian `j` (column-major, field units, n × p) and
    /// `nuisances` further parameters fitted; `estimated`: σ estimated from the residuals.
    pub fn new(j: &[f64], r: &[f64], p: usize, nuisances: usize, estimated: bool) -> FitStats {
        let n = r.len();
        let chi_square: f64 = r.iter().map(|x| x * x).sum();
        let dof = n.saturating_sub(p + nuisances);
        let scale = if estimated {
            if dof > 0 {
                chi_square / dof as f64
            } else {
                f64::NAN
            }
        } else {
            1.0
        };
        let p_value = if !estimated && dof > 0 {
            ChiSquared::new(dof as f64).map_or(f64::NAN, |d| d.sf(chi_square))
        } else {
            f64::NAN
        };
        let (quantile, profile_threshold) = if estimated {
            let t = StudentsT::new(0.0, 1.0, dof.max(1) as f64)
                .map_or(f64::NAN, |d| d.inverse_cdf(0.5 + LEVEL / 2.0));
            (t, t * t * scale)
        } else {
            let c = ChiSquared::new(1.0).map_or(f64::NAN, |d| d.inverse_cdf(LEVEL));
            (c.sqrt(), c)
        };
        // Information matrix, normalised to a unit diagonal.
        let mut a = DMatrix::zeros(p, p);
        for u in 0..p {
            for v in 0..p {
                a[(u, v)] = (0..n).map(|i| j[u * n + i] * j[v * n + i]).sum::<f64>();
            }
        }
        let d: Vec<f64> = (0..p).map(|u| a[(u, u)].sqrt()).collect();
        let mut c = DMatrix::zeros(p, p);
        for u in 0..p {
            for v in 0..p {
                c[(u, v)] = if d[u] > 0.0 && d[v] > 0.0 {
                    a[(u, v)] / (d[u] * d[v])
                } else {
                    0.0
                };
            }
        }
        let eig = SymmetricEigen::new(c);
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        let mut weakest_k = 0;
        for k in 0..p {
            let l = eig.eigenvalues[k];
            if l < lo {
                lo = l;
                weakest_k = k;
            }
            hi = hi.max(l);
        }
        let condition = if lo > 0.0 {
            (hi / lo).sqrt()
        } else {
            f64::INFINITY
        };
        // Covariance: s² D⁻¹ C⁻¹ D⁻¹, directions of no information infinite.
        let mut cov = vec![0.0; p * p];
        // The null directions' own correlation: the limit of the correlation as their
        // information goes to 0.
        let mut null = vec![0.0; p * p];
        let tiny = hi * 1e-14;
        for k in 0..p {
            let l = eig.eigenvalues[k];
            let q = eig.eigenvectors.column(k);
            for u in 0..p {
                for v in 0..p {
                    let w = q[u] * q[v];
                    if l <= tiny {
                        null[u * p + v] += w;
                    }
                    let add = if l > tiny {
                        w / l
                    } else if w != 0.0 {
                        f64::INFINITY * w.signum()
                    } else {
                        0.0
                    };
                    cov[u * p + v] += add;
                }
            }
        }
        for u in 0..p {
            for v in 0..p {
                let s = d[u] * d[v];
                cov[u * p + v] = if s > 0.0 {
                    scale * cov[u * p + v] / s
                } else if u == v {
                    f64::INFINITY
                } else {
                    f64::NAN
                };
            }
        }
        let standard_error: Vec<f64> = (0..p).map(|u| cov[u * p + u].sqrt()).collect();
        let mut correlation = vec![f64::NAN; p * p];
        for u in 0..p {
            for v in 0..p {
                let s = standard_error[u] * standard_error[v];
                correlation[u * p + v] = if u == v {
                    1.0
                } else if s.is_finite() && s > 0.0 {
                    (cov[u * p + v] / s).clamp(-1.0, 1.0)
                } else if null[u * p + u] > 0.0 && null[v * p + v] > 0.0 {
                    (null[u * p + v] / (null[u * p + u] * null[v * p + v]).sqrt()).clamp(-1.0, 1.0)
                } else {
                    f64::NAN
                };
            }
        }
        // The weakest direction in field units: D⁻¹ q, scaled to a largest component of ±1.
        let q = eig.eigenvectors.column(weakest_k);
        let mut dir: Vec<f64> = (0..p)
            .map(|u| if d[u] > 0.0 { q[u] / d[u] } else { q[u] })
            .collect();
        let big = dir.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if big > 0.0 {
            let k = dir
                .iter()
                .position(|x| x.abs() == big)
                .expect("the largest is there");
            let s = dir[k].signum() / big;
            for x in &mut dir {
                *x *= s;
            }
        }
        FitStats {
            chi_square,
            dof,
            scale,
            p_value,
            covariance: cov,
            standard_error,
            correlation,
            quantile,
            profile_threshold,
            condition,
            weakest: (dir, lo.max(0.0)),
        }
    }

    /// Whether some combination of the fields is beyond what the data determine.
    pub fn unidentifiable(&self) -> bool {
        self.weakest.1 < UNIDENTIFIABLE_EIGENVALUE
            || !self.standard_error.iter().all(|s| s.is_finite())
    }

    /// The linearised interval of field `k` at `x`.
    pub fn linear_interval(&self, k: usize, x: f64) -> (f64, f64) {
        let h = self.quantile * self.standard_error[k];
        (x - h, x + h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_straight_line_fit_has_the_textbook_covariance() {
        // y = a + b t at t = 0..4, σ = 1: (XᵀX)⁻¹ = [[0.6, -0.2], [-0.2, 0.1]].
        let t = [0.0, 1.0, 2.0, 3.0, 4.0];
        let mut j = vec![1.0; 5];
        j.extend_from_slice(&t);
        let r = [0.5, -0.5, 0.5, -0.5, 0.0];
        let s = FitStats::new(&j, &r, 2, 0, false);
        let want = [0.6, -0.2, -0.2, 0.1];
        for (a, b) in s.covariance.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{:?}", s.covariance);
        }
        assert_eq!(s.dof, 3);
        assert!((s.chi_square - 1.0).abs() < 1e-15);
        // P(χ²₃ > 1) = 0.80125...
        assert!((s.p_value - 0.801_251_9).abs() < 1e-6, "{}", s.p_value);
        assert!((s.quantile - 1.959_964).abs() < 1e-6);
        assert!((s.profile_threshold - 3.841_459).abs() < 1e-6);
        assert!((s.correlation[1] + 0.2 / (0.6f64 * 0.1).sqrt()).abs() < 1e-12);
        assert!(!s.unidentifiable());
        // Estimated σ: s² = χ²/ν scales the covariance; Student's t with 3 degrees of freedom.
        let e = FitStats::new(&j, &r, 2, 0, true);
        assert!((e.covariance[0] - 0.6 / 3.0).abs() < 1e-12);
        assert!((e.quantile - 3.182_446).abs() < 1e-5, "{}", e.quantile);
        assert!(e.p_value.is_nan());
    }

    #[test]
    fn proportional_columns_are_named_unidentifiable() {
        // Columns (1, 2, 3) and (2, 4, 6.000001): only a + 2b is told.
        let j = vec![1.0, 2.0, 3.0, 2.0, 4.0, 6.000_001];
        let s = FitStats::new(&j, &[0.1, -0.1, 0.0], 2, 0, false);
        assert!(s.unidentifiable());
        let (dir, _) = &s.weakest;
        // The direction that changes nothing: δa = -2 δb.
        assert!((dir[0] / dir[1] + 2.0).abs() < 1e-3, "{dir:?}");
        assert!(s.correlation[1] < -0.99);
    }
}
