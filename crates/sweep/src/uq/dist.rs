//! The distributions an ensemble samples scene fields from, each as its quantile function (a
//! number in (0, 1) to a value), and their dependence: a Gaussian copula with a stated
//! correlation matrix, or a multivariate normal (a fit's best values and covariance).

use statrs::distribution::{ContinuousCDF, Normal};

/// One field's distribution.
#[derive(Debug, Clone, PartialEq)]
// Each variant's fields are the parameters its line names, in the field's unit.
#[allow(missing_docs)]
pub enum Dist {
    /// Uniform on `[min, max]`.
    Uniform { min: f64, max: f64 },
    /// `ln x` uniform on `[ln min, ln max]`.
    LogUniform { min: f64, max: f64 },
    /// Normal.
    Normal { mean: f64, sd: f64 },
    /// `ln x` normal with mean `ln median` and standard deviation `sigma_ln`.
    LogNormal { median: f64, sigma_ln: f64 },
    /// Normal restricted to `[min, max]`.
    TruncatedNormal {
        mean: f64,
        sd: f64,
        min: f64,
        max: f64,
    },
    /// Triangular on `[min, max]` with its peak at `mode`.
    Triangular { min: f64, mode: f64, max: f64 },
    /// Given values with weights (normalised to sum to one).
    Discrete { values: Vec<f64>, weights: Vec<f64> },
}

fn std_normal() -> Normal {
    Normal::new(0.0, 1.0).expect("the standard normal")
}

/// The standard normal's quantile function Φ⁻¹.
pub fn normal_quantile(u: f64) -> f64 {
    std_normal().inverse_cdf(u)
}

/// The standard normal's distribution function Φ.
pub fn normal_cdf(z: f64) -> f64 {
    std_normal().cdf(z)
}

impl Dist {
    /// The value at probability `u` in (0, 1).
    pub fn quantile(&self, u: f64) -> f64 {
        match self {
            Dist::Uniform { min, max } => min + u * (max - min),
            Dist::LogUniform { min, max } => (min.ln() + u * (max.ln() - min.ln())).exp(),
            Dist::Normal { mean, sd } => mean + sd * normal_quantile(u),
            Dist::LogNormal { median, sigma_ln } => {
                (median.ln() + sigma_ln * normal_quantile(u)).exp()
            }
            Dist::TruncatedNormal { mean, sd, min, max } => {
                let (a, b) = (normal_cdf((min - mean) / sd), normal_cdf((max - mean) / sd));
                (mean + sd * normal_quantile(a + u * (b - a))).clamp(*min, *max)
            }
            Dist::Triangular { min, mode, max } => {
                let (w, left) = (max - min, mode - min);
                let c = if w > 0.0 { left / w } else { 0.5 };
                if u < c {
                    min + (u * w * left).sqrt()
                } else {
                    max - ((1.0 - u) * w * (max - mode)).sqrt()
                }
            }
            Dist::Discrete { values, weights } => {
                let total: f64 = weights.iter().sum();
                let mut acc = 0.0;
                for (v, w) in values.iter().zip(weights) {
                    acc += w / total;
                    if u < acc {
                        return *v;
                    }
                }
                *values.last().expect("checked non-empty")
            }
        }
    }

    /// Checks the parameters; the message says what is wrong (the caller names the field).
    pub fn check(&self) -> Result<(), String> {
        let finite = |name: &str, x: f64| {
            if x.is_finite() {
                Ok(())
            } else {
                Err(format!("{name} must be a finite number, got {x}"))
            }
        };
        let interval = |min: f64, max: f64| {
            finite("min", min)?;
            finite("max", max)?;
            if min < max {
                Ok(())
            } else {
                Err(format!(
                    "the interval [min, max] = [{min}, {max}] is empty: min must be below max"
                ))
            }
        };
        let positive_sd = |name: &str, sd: f64| {
            if sd.is_finite() && sd > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be a finite number > 0, got {sd}"))
            }
        };
        match self {
            Dist::Uniform { min, max } => interval(*min, *max),
            Dist::LogUniform { min, max } => {
                interval(*min, *max)?;
                if *min > 0.0 {
                    Ok(())
                } else {
                    Err(format!(
                        "a log-uniform distribution needs min > 0, got {min}"
                    ))
                }
            }
            Dist::Normal { mean, sd } => {
                finite("mean", *mean)?;
                positive_sd("sd", *sd)
            }
            Dist::LogNormal { median, sigma_ln } => {
                if !(median.is_finite() && *median > 0.0) {
                    return Err(format!("median must be a finite number > 0, got {median}"));
                }
                positive_sd("sigma_ln", *sigma_ln)
            }
            Dist::TruncatedNormal { mean, sd, min, max } => {
                finite("mean", *mean)?;
                positive_sd("sd", *sd)?;
                interval(*min, *max)?;
                let mass = normal_cdf((max - mean) / sd) - normal_cdf((min - mean) / sd);
                if mass > 1e-12 {
                    Ok(())
                } else {
                    Err(format!("the interval [{min}, {max}] holds no probability of the normal ({mean}, {sd}): it lies beyond 7 standard deviations"))
                }
            }
            Dist::Triangular { min, mode, max } => {
                interval(*min, *max)?;
                finite("mode", *mode)?;
                if min <= mode && mode <= max {
                    Ok(())
                } else {
                    Err(format!(
                        "mode must lie in [min, max] = [{min}, {max}], got {mode}"
                    ))
                }
            }
            Dist::Discrete { values, weights } => {
                if values.is_empty() {
                    return Err("values must hold at least one value".into());
                }
                if weights.len() != values.len() {
                    return Err(format!(
                        "weights must give one weight per value ({} values), got {}",
                        values.len(),
                        weights.len()
                    ));
                }
                for v in values {
                    finite("every value", *v)?;
                }
                if weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
                    return Err("every weight must be a finite number >= 0".into());
                }
                if weights.iter().sum::<f64>() > 0.0 {
                    Ok(())
                } else {
                    Err("the weights must not all be zero".into())
                }
            }
        }
    }

    /// The exact mean.
    pub fn mean(&self) -> f64 {
        match self {
            Dist::Uniform { min, max } => 0.5 * (min + max),
            Dist::LogUniform { min, max } => (max - min) / (max.ln() - min.ln()),
            Dist::Normal { mean, .. } => *mean,
            Dist::LogNormal { median, sigma_ln } => median * (0.5 * sigma_ln * sigma_ln).exp(),
            Dist::TruncatedNormal { mean, sd, min, max } => {
                let (a, b) = ((min - mean) / sd, (max - mean) / sd);
                let pdf = |z: f64| (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt();
                mean + sd * (pdf(a) - pdf(b)) / (normal_cdf(b) - normal_cdf(a))
            }
            Dist::Triangular { min, mode, max } => (min + mode + max) / 3.0,
            Dist::Discrete { values, weights } => {
                let total: f64 = weights.iter().sum();
                values.iter().zip(weights).map(|(v, w)| v * w).sum::<f64>() / total
            }
        }
    }
}

/// The lower Cholesky factor `L` (row-major, `n × n`) of a symmetric matrix `a`, `a = L Lᵀ`;
/// `None` when `a` is not positive definite.
pub fn cholesky(a: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut l = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..=i {
            let s: f64 = (0..j).map(|k| l[i * n + k] * l[j * n + k]).sum();
            if i == j {
                let d = a[i * n + i] - s;
                if !(d > 0.0 && d.is_finite()) {
                    return None;
                }
                l[i * n + i] = d.sqrt();
            } else {
                l[i * n + j] = (a[i * n + j] - s) / l[j * n + j];
            }
        }
    }
    Some(l)
}

/// `L z` for a lower-triangular `L` (row-major, `n × n`).
pub fn lower_times(l: &[f64], z: &[f64]) -> Vec<f64> {
    let n = z.len();
    (0..n)
        .map(|i| (0..=i).map(|k| l[i * n + k] * z[k]).sum())
        .collect()
}

/// Gaussian copula: uniforms `u` (independent) to uniforms with the normal dependence whose
/// correlation matrix has the Cholesky factor `l`: `Φ(L Φ⁻¹(u))`.
pub fn correlate(l: &[f64], u: &[f64]) -> Vec<f64> {
    let z: Vec<f64> = u.iter().map(|&x| normal_quantile(x)).collect();
    lower_times(l, &z)
        .into_iter()
        .map(|x| normal_cdf(x).clamp(f64::MIN_POSITIVE, 1.0 - f64::EPSILON))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_closed_forms() {
        let n = Dist::Normal { mean: 2.0, sd: 3.0 };
        assert!((n.quantile(0.975) - (2.0 + 3.0 * 1.959963984540054)).abs() < 1e-9);
        let t = Dist::Triangular {
            min: 0.0,
            mode: 1.0,
            max: 2.0,
        };
        assert!((t.quantile(0.5) - 1.0).abs() < 1e-15);
        assert!((t.quantile(0.125) - 0.5).abs() < 1e-15);
        let lu = Dist::LogUniform {
            min: 1.0,
            max: 100.0,
        };
        assert!((lu.quantile(0.5) - 10.0).abs() < 1e-12);
        let d = Dist::Discrete {
            values: vec![1.0, 2.0, 3.0],
            weights: vec![1.0, 2.0, 1.0],
        };
        assert_eq!(d.quantile(0.2), 1.0);
        assert_eq!(d.quantile(0.5), 2.0);
        assert_eq!(d.quantile(0.9), 3.0);
        let tn = Dist::TruncatedNormal {
            mean: 0.0,
            sd: 1.0,
            min: 0.0,
            max: 10.0,
        };
        // The half-normal's median is Φ⁻¹(3/4).
        assert!((tn.quantile(0.5) - 0.674489750196082).abs() < 1e-9);
        assert!((tn.mean() - (2.0 / std::f64::consts::PI).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn bad_parameters_are_named() {
        assert!(Dist::Normal { mean: 1.0, sd: 0.0 }
            .check()
            .unwrap_err()
            .contains("sd"));
        assert!(Dist::Uniform { min: 2.0, max: 1.0 }
            .check()
            .unwrap_err()
            .contains("empty"));
        assert!(cholesky(&[1.0, 2.0, 2.0, 1.0], 2).is_none());
        let l = cholesky(&[4.0, 2.0, 2.0, 3.0], 2).unwrap();
        assert_eq!(l, vec![2.0, 0.0, 1.0, 2.0f64.sqrt()]);
    }
}
