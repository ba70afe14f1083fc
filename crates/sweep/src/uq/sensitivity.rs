//! Global sensitivities of a quantity to its input groups.
//!
//! - **Sobol' indices** from Saltelli's design (matrices A, B and `AB_g`), with Jansen's
//!   estimators (Saltelli et al., *Comput. Phys. Commun.* 181, 259, 2010, Table 2):
//!   `V_T,g = Σ (f(A) − f(AB_g))² / 2N` (total), `V_g = V − Σ (f(B) − f(AB_g))² / 2N`
//!   (first order), over `V` the variance of `f(A) ∪ f(B)`; 95 % intervals by the bootstrap
//!   over the design's rows (percentile, 1 000 resamples, seeded).
//! - **Morris's elementary effects** (Morris 1991; Campolongo, Cariboni & Saltelli 2007): per
//!   group the mean `μ`, the mean of absolute values `μ*` (with a bootstrap interval over the
//!   trajectories) and the standard deviation `σ` of `(f(x + Δ) − f(x)) / Δ`.

use super::stats::{quantile_sorted, Estimate};
use super::Stream;

/// Bootstrap resamples of every interval.
pub const BOOTSTRAP: usize = 1000;

/// The Sobol' indices of one group.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SobolIndex {
    /// First order.
    pub first: Estimate,
    /// Total.
    pub total: Estimate,
}

fn variance(a: impl Iterator<Item = f64> + Clone) -> f64 {
    let (n, s) = a.clone().fold((0.0, 0.0), |(n, s), x| (n + 1.0, s + x));
    let m = s / n;
    a.map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0)
}

fn indices(fa: &[f64], fb: &[f64], fab: &[&[f64]], rows: &[usize]) -> Vec<(f64, f64)> {
    let n = rows.len() as f64;
    let v = variance(
        rows.iter()
            .map(|&i| fa[i])
            .chain(rows.iter().map(|&i| fb[i])),
    );
    fab.iter()
        .map(|g| {
            let total = rows.iter().map(|&i| (fa[i] - g[i]).powi(2)).sum::<f64>() / (2.0 * n);
            let first = v - rows.iter().map(|&i| (fb[i] - g[i]).powi(2)).sum::<f64>() / (2.0 * n);
            (first / v, total / v)
        })
        .collect()
}

fn percentile(mut x: Vec<f64>, value: f64) -> Estimate {
    x.retain(|v| v.is_finite());
    x.sort_by(f64::total_cmp);
    Estimate {
        value,
        lower: quantile_sorted(&x, 0.025),
        upper: quantile_sorted(&x, 0.975),
    }
}

/// The first-order and total indices of each group from the values of a Saltelli design: `fa`,
/// `fb` and `fab[g]` over the same `n` rows (NaN: a run without a number; its row is left out of
/// every block).
pub fn sobol_indices(fa: &[f64], fb: &[f64], fab: &[&[f64]], seed: u64) -> Vec<SobolIndex> {
    let rows: Vec<usize> = (0..fa.len())
        .filter(|&i| fa[i].is_finite() && fb[i].is_finite() && fab.iter().all(|g| g[i].is_finite()))
        .collect();
    if rows.len() < 3 {
        return vec![
            SobolIndex {
                first: Estimate::NONE,
                total: Estimate::NONE
            };
            fab.len()
        ];
    }
    let point = indices(fa, fb, fab, &rows);
    let mut boot: Vec<Vec<(f64, f64)>> = Vec::with_capacity(BOOTSTRAP);
    let mut rng = Stream::new(&[seed, 6]);
    let mut pick = vec![0; rows.len()];
    for _ in 0..BOOTSTRAP {
        for p in pick.iter_mut() {
            *p = rows[rng.below(rows.len())];
        }
        boot.push(indices(fa, fb, fab, &pick));
    }
    (0..fab.len())
        .map(|g| SobolIndex {
            first: percentile(boot.iter().map(|b| b[g].0).collect(), point[g].0),
            total: percentile(boot.iter().map(|b| b[g].1).collect(), point[g].1),
        })
        .collect()
}

/// Morris's measures of one group.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Morris {
    /// Mean elementary effect.
    pub mu: f64,
    /// Mean absolute elementary effect, with its bootstrap interval.
    pub mu_star: Estimate,
    /// Standard deviation of the elementary effects.
    pub sigma: f64,
}

/// Morris's measures of `groups` groups from `effects[t][g]`, the elementary effect of group `g`
/// on trajectory `t` (NaN: none, left out).
pub fn morris(effects: &[Vec<f64>], groups: usize, seed: u64) -> Vec<Morris> {
    let mut rng = Stream::new(&[seed, 7]);
    let picks: Vec<Vec<usize>> = (0..BOOTSTRAP)
        .map(|_| {
            (0..effects.len())
                .map(|_| rng.below(effects.len().max(1)))
                .collect()
        })
        .collect();
    (0..groups)
        .map(|g| {
            let e: Vec<f64> = effects.iter().map(|t| t[g]).collect();
            let finite: Vec<f64> = e.iter().copied().filter(|x| x.is_finite()).collect();
            let n = finite.len() as f64;
            if finite.is_empty() {
                return Morris {
                    mu: f64::NAN,
                    mu_star: Estimate::NONE,
                    sigma: f64::NAN,
                };
            }
            let mu = finite.iter().sum::<f64>() / n;
            let mu_star = finite.iter().map(|x| x.abs()).sum::<f64>() / n;
            let sigma = if finite.len() > 1 {
                (finite.iter().map(|x| (x - mu).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
            } else {
                f64::NAN
            };
            let boot: Vec<f64> = picks
                .iter()
                .map(|p| {
                    let (s, k) = p
                        .iter()
                        .map(|&t| e[t])
                        .filter(|x| x.is_finite())
                        .fold((0.0, 0.0), |(s, k), x| (s + x.abs(), k + 1.0));
                    s / k
                })
                .collect();
            Morris {
                mu,
                mu_star: percentile(boot, mu_star),
                sigma,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::uq::design::{morris as morris_design, saltelli, MORRIS_STEP};

    /// Ishigami's function (Ishigami & Homma 1990), the standard check of Sobol' estimators:
    /// `sin x₁ + 7 sin² x₂ + 0.1 x₃⁴ sin x₁` on `[−π, π]³`, with closed-form indices.
    #[test]
    fn ishigami_indices_match_their_closed_forms() {
        let pi = std::f64::consts::PI;
        let f = |u: &[f64]| {
            let x: Vec<f64> = u.iter().map(|&u| -pi + 2.0 * pi * u).collect();
            x[0].sin() + 7.0 * x[1].sin().powi(2) + 0.1 * x[2].powi(4) * x[0].sin()
        };
        let (a, b) = (7.0f64, 0.1f64);
        let v = 0.5 + a * a / 8.0 + b * pi.powi(4) / 5.0 + b * b * pi.powi(8) / 18.0;
        let v1 = 0.5 * (1.0 + b * pi.powi(4) / 5.0).powi(2);
        let v2 = a * a / 8.0;
        let v13 = b * b * pi.powi(8) * (1.0 / 18.0 - 1.0 / 50.0);
        let exact_first = [v1 / v, v2 / v, 0.0];
        let exact_total = [(v1 + v13) / v, v2 / v, v13 / v];
        let groups = [0..1, 1..2, 2..3];
        let n = 4096;
        let (x, _) = saltelli(3, &groups, n, 11);
        let y: Vec<f64> = x.chunks(3).map(f).collect();
        let fab: Vec<&[f64]> = (0..3).map(|g| &y[(2 + g) * n..(3 + g) * n]).collect();
        let s = sobol_indices(&y[..n], &y[n..2 * n], &fab, 1);
        for g in 0..3 {
            for (e, exact) in [(s[g].first, exact_first[g]), (s[g].total, exact_total[g])] {
                assert!(
                    (e.value - exact).abs() < 0.03
                        && e.lower - 0.01 <= exact
                        && exact <= e.upper + 0.01,
                    "group {g}: {e:?} against {exact}"
                );
            }
        }
    }

    #[test]
    fn morris_effects_of_a_linear_function_are_its_slopes() {
        let groups = [0..1, 1..2, 2..3];
        let (x, steps) = morris_design(3, &groups, 10, 4, 3);
        let slope = [2.0, -1.0, 0.0];
        let f = |u: &[f64]| u.iter().zip(slope).map(|(u, s)| u * s).sum::<f64>();
        let y: Vec<f64> = x.chunks(3).map(f).collect();
        let mut effects = vec![vec![f64::NAN; 3]; 10];
        for k in 1..steps.len() {
            if let Some(g) = steps[k].moved {
                effects[steps[k].trajectory][g] = (y[k] - y[k - 1]) / MORRIS_STEP;
            }
        }
        let m = morris(&effects, 3, 1);
        for g in 0..3 {
            assert!((m[g].mu - slope[g]).abs() < 1e-12, "{:?}", m[g]);
            assert!((m[g].mu_star.value - slope[g].abs()).abs() < 1e-12);
        }
    }
}
