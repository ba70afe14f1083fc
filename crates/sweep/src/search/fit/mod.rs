//! A fit: weighted nonlinear least squares of scene fields against measured data.
//!
//! Every evaluation of a fit is the residuals of its runs against the data
//! ([`model::predict`]), `(model − data)/σ` per datum, with the nuisance parameters of recorded
//! signals (time shift, gain, offset) fitted at each evaluation (profiled out). The method, like
//! every search here, is a pure function of those evaluations, replayed over them:
//!
//! 1. **Scan**: quasi-random (Halton) points of the box (stream 0); the `starts` lowest in χ² are
//!    the starting points.
//! 2. **Levenberg–Marquardt in Moré's trust-region form** from each start (a stream each, so the
//!    starts advance together): each iteration asks for one batch, the trial point and the
//!    forward-difference points around it, so that an accepted step already has its Jacobian
//!    (one round per iteration). Steps are in the box's unit coordinates (every field weighs
//!    the same whatever its unit); a field at a bound whose gradient points out is held there.
//!    It ends when the Gauss–Newton step would lower χ² by less than `1e-4 · s²` (s² = 1 with σ
//!    given, χ²/ν when estimated), when every step is below the field's tolerance, or it stalls
//!    (the trust region collapses on noise, a difference run fails, 40 iterations).
//! 3. **Statistics** at the lowest minimum ([`stats::FitStats`]): covariance, standard errors,
//!    correlations, χ²/ν and its p-value, unidentifiable combinations.
//! 4. **Profile likelihood** (`profile`, default on): for each field and side, the field is held
//!    at points found by the secant method on `√(χ²_profile − χ²_min)` until that reaches the
//!    threshold (3.84, or `t² s²` with σ estimated), each point a fit of the other fields (its
//!    own Levenberg–Marquardt, from the linearised conditional optimum); the 2p sides advance
//!    together on streams of their own.
//!
//! Why Levenberg–Marquardt with Moré's trust region and not NL2SOL's adaptive model: a fit of a
//! chain's few fields to its data is a small-residual problem whenever the model describes the
//! data (the case the intervals are for), where Gauss–Newton converges quickly; NL2SOL's
//! quasi-Newton correction of the Hessian pays off for large residuals, and needs more
//! evaluations to build. The trust region, solved exactly by eigen-decomposition for six fields
//! at most, makes every step safe against a poor linear model.
//!
//! One Levenberg–Marquardt fit is `iterate`'s, one side of a profile `profile`'s.

pub mod lm;
pub mod model;
pub mod stats;

use std::sync::Arc;

use super::{Item, ItemStatus, Outcome, Point, SearchStatus, Streams};
use crate::sweep::fit::{FitSpec, SigmaRule};
use crate::sweep::search::{OnFailure, SearchSpec};
use stats::FitStats;

mod iterate;
mod profile;

use iterate::{levenberg_marquardt, Fitted};
use profile::profile_side;

/// What one evaluation of a fit gives: its residuals (weighted by 1/σ when σ is given) and the
/// nuisance parameters fitted with them, with their variances at fixed fields (in units of s²).
#[derive(Debug, Clone, PartialEq)]
pub struct FitEval {
    /// `(model − data)/σ` per datum (σ given), or `model − data`.
    pub residual: Vec<f64>,
    /// The nuisance parameters fitted with the fields held (per signal: shift, gain, offset).
    pub nuisance: Vec<f64>,
    /// Their variances with the fields held, per unit s².
    pub nuisance_variance: Vec<f64>,
}

/// An evaluation's residuals (`None`: a run failed or a datum has no number there).
pub type Residuals = Option<Arc<FitEval>>;

fn chi_square(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum()
}

/// A profile of one field: the interval where the profiled χ² stays within the threshold, and
/// the points computed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Profile {
    /// Lower end (field units; NaN: not computed).
    pub lower: f64,
    /// Upper end.
    pub upper: f64,
    /// Whether the profile stays below the threshold up to the bound (the interval reaches it).
    pub lower_open: bool,
    /// The same, at the upper end.
    pub upper_open: bool,
    /// (value of the field, profiled χ²) of every point computed, in increasing value.
    pub points: Vec<(f64, f64)>,
}

/// What a fit found.
#[derive(Debug, Clone, PartialEq)]
pub struct FitOutcome {
    /// The best fields (field units).
    pub x: Vec<f64>,
    /// χ² there.
    pub chi_square: f64,
    /// The best evaluation: (stream, index in the stream).
    pub best: (usize, usize),
    /// The statistics at the best (`None` while running).
    pub stats: Option<FitStats>,
    /// The nuisance parameters there, and their standard errors (the fields' uncertainty
    /// included).
    pub nuisance: Vec<(f64, f64)>,
    /// Linearised 95 % intervals per field.
    pub linear: Vec<[f64; 2]>,
    /// Profile-likelihood intervals per field (empty: not computed).
    pub profile: Vec<Profile>,
    /// Whether each field is at a bound of its interval.
    pub at_bound: Vec<bool>,
    /// What a user must know: unidentifiable combinations, strong correlations, bounds, other
    /// minima, a poor fit.
    pub warnings: Vec<String>,
}

/// The scales of the fit: unit coordinates, steps, tolerances.
struct Ctx<'a> {
    spec: &'a SearchSpec,
    /// Relative finite-difference step.
    h_rel: f64,
    /// σ estimated from the residuals.
    estimated: bool,
    /// Data count.
    n: usize,
    /// Nuisance parameters.
    nuisances: usize,
    stop_on_failure: bool,
}

/// A field within this fraction of its interval's width of a bound is at that bound: a step that
/// would end closer is taken to the bound itself ([`snap_to_box`]), so that rounding never leaves
/// a field a hair inside a bound it presses on (where it would neither be held at the bound nor
/// move), and [`at_lower`] and [`at_upper`] say so.
pub(super) const AT_BOUND: f64 = 1e-12;

/// `u` (a field in units of its interval, 0 at `min` and 1 at `max`) within the box, on a bound
/// when within [`AT_BOUND`] of it.
pub(super) fn snap_to_box(u: f64) -> f64 {
    if u <= AT_BOUND {
        0.0
    } else if u >= 1.0 - AT_BOUND {
        1.0
    } else {
        u
    }
}

/// Whether a field at unit coordinate `u` is at its lower bound.
pub(super) fn at_lower(u: f64) -> bool {
    u <= AT_BOUND
}

/// Whether a field at unit coordinate `u` is at its upper bound.
pub(super) fn at_upper(u: f64) -> bool {
    u >= 1.0 - AT_BOUND
}

impl Ctx<'_> {
    fn p(&self) -> usize {
        self.spec.fields.len()
    }
    fn width(&self, k: usize) -> f64 {
        self.spec.fields[k].max - self.spec.fields[k].min
    }
    fn to_fields(&self, u: &[f64]) -> Point {
        u.iter()
            .zip(&self.spec.fields)
            .map(|(&u, f)| {
                if u >= 1.0 {
                    f.max
                } else {
                    f.min + u * (f.max - f.min)
                }
            })
            .collect()
    }
    fn to_unit(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .zip(&self.spec.fields)
            .map(|(&x, f)| ((x - f.min) / (f.max - f.min)).clamp(0.0, 1.0))
            .collect()
    }
    /// The finite-difference step of field `k` at unit coordinate `u` (signed: backward near the
    /// upper bound), in unit coordinates.
    fn fd_step(&self, k: usize, u: f64) -> f64 {
        let f = &self.spec.fields[k];
        let x = f.min + u * (f.max - f.min);
        let h = self.h_rel * x.abs().max(0.01 * self.width(k)) / self.width(k);
        if u + h > 1.0 {
            -h
        } else {
            h
        }
    }
    /// The χ² decrease below which a fit has converged.
    fn converged_below(&self, chi2: f64) -> f64 {
        let dof = self.n.saturating_sub(self.p() + self.nuisances).max(1);
        let s2 = if self.estimated {
            chi2 / dof as f64
        } else {
            1.0
        };
        1e-4 * s2
    }
}

/// `x` to `digits` significant digits, as text (`6.0652`, `1.23e-7`).
pub fn significant(x: f64, digits: usize) -> String {
    if !x.is_finite() || x == 0.0 {
        return crate::error::number_text(x);
    }
    let e = x.abs().log10().floor() as i32;
    if (-4..6).contains(&e) {
        let decimals = (digits as i32 - 1 - e).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.prec$e}", prec = digits.saturating_sub(1))
    }
}

/// Point `i` (from 1) of the Halton sequence in `d` dimensions.
fn halton(i: usize, d: usize) -> Vec<f64> {
    const PRIMES: [usize; 6] = [2, 3, 5, 7, 11, 13];
    PRIMES[..d]
        .iter()
        .map(|&b| {
            let (mut f, mut r, mut k) = (1.0, 0.0, i);
            while k > 0 {
                f /= b as f64;
                r += f * (k % b) as f64;
                k /= b;
            }
            r
        })
        .collect()
}

/// The scan's points in unit coordinates: the box's centre, then Halton points (from the
/// second: the first is the centre again in one dimension).
fn scan_points(n: usize, d: usize) -> Vec<Vec<f64>> {
    let mut pts = vec![vec![0.5; d]];
    pts.extend((2..n + 1).map(|i| halton(i, d)));
    pts
}

/// One replay of the fit `spec` over the evaluations `known` (per stream); `h_rel` the relative
/// finite-difference step; `n_data` and `nuisances` the data set's sizes.
pub fn replay(
    spec: &SearchSpec,
    fit: &FitSpec,
    h_rel: f64,
    n_data: usize,
    nuisances: usize,
    known: &[Vec<Residuals>],
) -> (Outcome, Vec<(usize, Vec<Point>)>) {
    let mut s = Streams::new(known);
    let cx = Ctx {
        spec,
        h_rel,
        estimated: fit.sigma == SigmaRule::Estimated,
        n: n_data,
        nuisances,
        stop_on_failure: spec.on_failure == OnFailure::Stop,
    };
    let outcome = run(&cx, fit, &mut s, known);
    let asked = s.into_asked();
    let mut outcome = outcome;
    if !asked.is_empty() {
        outcome.status = SearchStatus::Running;
    }
    (outcome, asked)
}

/// The lowest χ² known so far (any stream).
fn best_known(known: &[Vec<Residuals>]) -> Option<f64> {
    known
        .iter()
        .flatten()
        .flatten()
        .map(|e| chi_square(&e.residual))
        .filter(|c| c.is_finite())
        .min_by(f64::total_cmp)
}

fn outcome(
    status: SearchStatus,
    items: Vec<Item>,
    note: String,
    fit: Option<FitOutcome>,
) -> Outcome {
    Outcome {
        status,
        items,
        refine_error: f64::NAN,
        note,
        fit: fit.map(Box::new),
    }
}

fn run(cx: &Ctx, fit: &FitSpec, s: &mut Streams<Residuals>, known: &[Vec<Residuals>]) -> Outcome {
    let p = cx.p();
    let spec = cx.spec;
    // (While it runs, the best χ² so far is its note; the item comes with the answer.)
    let running = |_: &Streams<Residuals>| -> Outcome {
        let note = match best_known(known) {
            Some(c) => format!("lowest chi_square so far {}", significant(c, 5)),
            None => String::new(),
        };
        outcome(SearchStatus::Running, Vec::new(), note, None)
    };
    // 1. The scan.
    let scan = scan_points(spec.scan[0], p);
    let scan_x: Vec<Point> = scan.iter().map(|u| cx.to_fields(u)).collect();
    let Some(vals) = s.eval(0, &scan_x) else {
        return running(s);
    };
    if cx.stop_on_failure {
        if let Some(i) = vals.iter().position(Option::is_none) {
            return Outcome::failed_at(spec, &scan_x[i]);
        }
    }
    let mut order: Vec<usize> = (0..scan.len()).filter(|&i| vals[i].is_some()).collect();
    if order.is_empty() {
        return outcome(
            SearchStatus::NotFound,
            Vec::new(),
            format!(
                "every run of the scan ({} points) failed or gave no number: no start to fit from",
                scan.len()
            ),
            None,
        );
    }
    let chi = |i: usize| chi_square(&vals[i].as_ref().expect("kept").residual);
    order.sort_by(|&a, &b| chi(a).total_cmp(&chi(b)).then(a.cmp(&b)));
    let starts: Vec<usize> = order.into_iter().take(spec.starts).collect();
    // 2. Levenberg–Marquardt from each start, together.
    let mut ends: Vec<Option<(Fitted, usize)>> = Vec::new();
    for (k, &i) in starts.iter().enumerate() {
        let mut n = 0;
        let e = vals[i].clone().expect("kept");
        // (The scan point's own evaluation is stream 0's; the start's stream holds the rest.)
        let mut r = levenberg_marquardt(
            cx,
            s,
            1 + k,
            scan[i].clone(),
            Some((e, usize::MAX)),
            &vec![false; p],
            &mut n,
        );
        if let Some(f) = &mut r {
            if f.index == usize::MAX {
                f.index = i;
            }
        }
        ends.push(r.map(|f| {
            // Which stream holds it: the scan's (its start) or the start's own.
            let stream = if f.index == i && f.u == scan[i] {
                0
            } else {
                1 + k
            };
            (f, stream)
        }));
    }
    if ends.iter().any(Option::is_none) {
        return running(s);
    }
    let ends: Vec<(Fitted, usize)> = ends.into_iter().flatten().collect();
    if cx.stop_on_failure {
        if let Some((f, _)) = ends.iter().find(|(f, _)| f.status == ItemStatus::Failed) {
            return Outcome::failed_at(spec, &cx.to_fields(&f.u));
        }
    }
    let Some((best, best_stream)) = ends
        .iter()
        .filter(|(f, _)| f.chi2.is_finite())
        .min_by(|a, b| a.0.chi2.total_cmp(&b.0.chi2))
        .cloned()
    else {
        return outcome(
            SearchStatus::NotFound,
            Vec::new(),
            "every start failed".into(),
            None,
        );
    };
    let x = cx.to_fields(&best.u);
    let mut warnings = Vec::new();
    // Other minima the starts found.
    for (f, _) in &ends {
        if f.chi2.is_finite() && f.status == ItemStatus::Converged {
            let far = f.u.iter().zip(&best.u).any(|(a, b)| (a - b).abs() > 0.05);
            let threshold: f64 = if cx.estimated { 0.0 } else { 3.84 };
            if far && f.chi2 - best.chi2 > threshold.max(1e-3 * best.chi2) {
                let at: Vec<String> = spec
                    .fields
                    .iter()
                    .zip(cx.to_fields(&f.u))
                    .map(|(fl, v)| format!("{} = {v:.6e}", fl.name))
                    .collect();
                warnings.push(format!(
                    "another local minimum at {} (chi_square {:.4e} against {:.4e})",
                    at.join(", "),
                    f.chi2,
                    best.chi2
                ));
            }
        }
    }
    // 3. Statistics: the Jacobian in field units.
    let n = best.eval.residual.len();
    let mut jx = best.ju.clone();
    if jx.len() != n * p {
        jx = vec![f64::NAN; n * p];
    }
    for k in 0..p {
        let w = cx.width(k);
        for v in &mut jx[k * n..(k + 1) * n] {
            *v /= w;
        }
    }
    let st = FitStats::new(&jx, &best.eval.residual, p, cx.nuisances, cx.estimated);
    let at_bound: Vec<bool> = best.u.iter().map(|&u| at_lower(u) || at_upper(u)).collect();
    let linear: Vec<[f64; 2]> = (0..p)
        .map(|k| {
            let (a, b) = st.linear_interval(k, x[k]);
            [a, b]
        })
        .collect();
    // Nuisances: their variance at fixed fields, and what the fields' uncertainty adds through
    // their derivatives B: var = s² v + (B C Bᵀ).
    let q = best.eval.nuisance.len();
    let nuisance: Vec<(f64, f64)> = (0..q)
        .map(|i| {
            let mut var = st.scale
                * best
                    .eval
                    .nuisance_variance
                    .get(i)
                    .copied()
                    .unwrap_or(f64::NAN);
            if best.jn.len() == q * p {
                for a in 0..p {
                    for b in 0..p {
                        let ba = best.jn[a * q + i] / cx.width(a);
                        let bb = best.jn[b * q + i] / cx.width(b);
                        var += ba * st.covariance[a * p + b] * bb;
                    }
                }
            }
            (best.eval.nuisance[i], var.sqrt())
        })
        .collect();
    let unidentifiable = st.unidentifiable();
    if unidentifiable {
        let dir: Vec<String> = spec
            .fields
            .iter()
            .zip(&st.weakest.0)
            .filter(|(_, &c)| c.abs() > 1e-3)
            .map(|(f, c)| format!("{c:+.3} {}", f.name))
            .collect();
        warnings.push(format!(
            "unidentifiable: the data do not determine the combination ({}) of the fields (its normalised information {:.2e}, condition number {:.2e}); fix a field or add data that tell them apart",
            dir.join(" "),
            st.weakest.1,
            st.condition
        ));
    }
    for a in 0..p {
        for b in a + 1..p {
            let c = st.correlation[a * p + b];
            if c.abs() > 0.99 && !unidentifiable {
                warnings.push(format!(
                    "{} and {} are correlated {c:+.4}: the data hardly tell them apart",
                    spec.fields[a].name, spec.fields[b].name
                ));
            }
        }
    }
    for (k, &b) in at_bound.iter().enumerate() {
        if b {
            warnings.push(format!(
                "{} is at a bound of its interval ({}): the best fit may lie beyond it, and its intervals are not the statistics of an interior minimum",
                spec.fields[k].name, x[k]
            ));
        }
    }
    if !cx.estimated && st.p_value < 0.001 {
        warnings.push(format!(
            "a poor fit: chi_square/dof = {:.3} (p = {:.2e}); the model misses the data beyond their sigma, and the intervals assume it does not",
            st.chi_square / st.dof.max(1) as f64,
            st.p_value
        ));
    }
    // 4. Profiles.
    let mut profiles = Vec::new();
    let mut profile_running = false;
    let want_profiles =
        fit.profile && !unidentifiable && st.standard_error.iter().all(|s| s.is_finite());
    if want_profiles {
        let first = 1 + spec.starts;
        for k in 0..p {
            let mut prof = Profile {
                lower: f64::NAN,
                upper: f64::NAN,
                ..Profile::default()
            };
            for (side_i, side) in [-1.0, 1.0].into_iter().enumerate() {
                let stream = first + 2 * k + side_i;
                match profile_side(cx, s, stream, &best, &x, &st, k, side) {
                    None => profile_running = true,
                    Some(side_end) => {
                        if let Some(w) = &side_end.lower_found {
                            warnings.push(w.clone());
                        }
                        if side < 0.0 {
                            prof.lower = side_end.end;
                            prof.lower_open = side_end.open;
                        } else {
                            prof.upper = side_end.end;
                            prof.upper_open = side_end.open;
                        }
                        prof.points.extend(side_end.points);
                    }
                }
            }
            prof.points.push((x[k], best.chi2));
            prof.points.sort_by(|a, b| a.0.total_cmp(&b.0));
            if prof.lower_open || prof.upper_open {
                warnings.push(format!(
                    "the profile of {} stays within the threshold up to a bound of its interval: the data bound it on one side only (widen the interval, or add data)",
                    spec.fields[k].name
                ));
            }
            profiles.push(prof);
        }
    }
    let status = if best.status == ItemStatus::Failed {
        SearchStatus::Failed
    } else if unidentifiable {
        SearchStatus::Unidentifiable
    } else if best.status == ItemStatus::Stalled {
        SearchStatus::Stalled
    } else {
        SearchStatus::Converged
    };
    let item_status = match status {
        SearchStatus::Unidentifiable => ItemStatus::Unidentifiable,
        _ if at_bound.iter().any(|&b| b) => ItemStatus::AtBound,
        _ => best.status,
    };
    let items = vec![Item {
        x: x.clone(),
        uncertainty: st.standard_error.clone(),
        value: Some(best.chi2),
        status: item_status,
    }];
    let answer: Vec<String> = spec
        .fields
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let mut t = format!(
                "{} = {} ± {} (95 %: [{}, {}] linearised",
                f.name,
                significant(x[k], 6),
                significant(st.standard_error[k], 3),
                significant(linear[k][0], 5),
                significant(linear[k][1], 5)
            );
            if let Some(pr) = profiles.get(k) {
                t.push_str(&format!(
                    ", [{}{}, {}{}] profile",
                    if pr.lower_open { "bound " } else { "" },
                    significant(pr.lower, 5),
                    if pr.upper_open { "bound " } else { "" },
                    significant(pr.upper, 5)
                ));
            }
            t.push(')');
            t
        })
        .collect();
    let mut note = format!(
        "{}; chi_square {} for {} degrees of freedom{}",
        answer.join(", "),
        significant(st.chi_square, 5),
        st.dof,
        if st.dof == 0 {
            " (as many data as fitted parameters: no test of the fit)".to_string()
        } else if cx.estimated {
            format!(
                " (sigma estimated from the residuals: {})",
                significant(st.scale.sqrt(), 4)
            )
        } else {
            format!(
                " (chi_square/dof {}, p = {})",
                significant(st.chi_square / st.dof.max(1) as f64, 4),
                significant(st.p_value, 3)
            )
        }
    );
    if !best.note.is_empty() {
        note.push_str(&format!("; {}", best.note));
    }
    for w in &warnings {
        note.push_str(&format!("; {w}"));
    }
    let fo = FitOutcome {
        x,
        chi_square: best.chi2,
        best: (best_stream, best.index),
        stats: Some(st),
        nuisance,
        linear,
        profile: profiles,
        at_bound,
        warnings,
    };
    let status = if profile_running {
        SearchStatus::Running
    } else {
        status
    };
    outcome(status, items, note, Some(fo))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::search::testing::spec;
    use crate::sweep::search::Goal;

    fn fit_spec(profile: bool, estimated: bool) -> FitSpec {
        FitSpec {
            sets: Vec::new(),
            sets_dim: None,
            sigma: if estimated {
                SigmaRule::Estimated
            } else {
                SigmaRule::Given
            },
            profile,
            variants: Vec::new(),
            variant_dim: None,
        }
    }

    /// Drives a fit over residuals `f` until it ends: its outcome and the evaluations made.
    fn solve(
        sp: &SearchSpec,
        fs: &FitSpec,
        n: usize,
        f: impl Fn(&[f64]) -> Option<Vec<f64>>,
    ) -> (Outcome, usize) {
        let mut known: Vec<Vec<Residuals>> = Vec::new();
        let mut runs = 0;
        loop {
            let (o, asked) = replay(sp, fs, 1e-6, n, 0, &known);
            if asked.is_empty() {
                return (o, runs);
            }
            for (st, b) in asked {
                if known.len() <= st {
                    known.resize(st + 1, Vec::new());
                }
                for x in b {
                    runs += 1;
                    known[st].push(f(&x).map(|r| {
                        Arc::new(FitEval {
                            residual: r,
                            nuisance: Vec::new(),
                            nuisance_variance: Vec::new(),
                        })
                    }));
                }
            }
            assert!(runs < 5000, "a fit that does not end");
        }
    }

    #[test]
    fn an_exponential_decay_is_fitted_with_its_textbook_intervals() {
        // y = A exp(-k t) at t = 0..9, σ = 0.01, data exactly at A = 2, k = 0.3 plus a fixed
        // perturbation; the answer is the linear least-squares one to first order.
        let t: Vec<f64> = (0..10).map(|i| i as f64).collect();
        let noise = [0.3, -0.5, 0.1, 0.8, -0.2, -0.9, 0.4, 0.0, -0.3, 0.6];
        let sigma = 0.01;
        let data: Vec<f64> = t
            .iter()
            .zip(noise)
            .map(|(t, e)| 2.0 * (-0.3 * t).exp() + sigma * e)
            .collect();
        let mut sp = spec(Goal::Fit, &[(0.5, 5.0, 0.0), (0.01, 1.0, 0.0)]);
        sp.scan = vec![10];
        sp.starts = 2;
        let fs = fit_spec(true, false);
        let (o, runs) = solve(&sp, &fs, 10, |x| {
            Some(
                t.iter()
                    .zip(&data)
                    .map(|(t, d)| (x[0] * (-x[1] * t).exp() - d) / sigma)
                    .collect(),
            )
        });
        assert_eq!(o.status, SearchStatus::Converged, "{}", o.note);
        let f = o.fit.expect("a fit");
        assert!(
            (f.x[0] - 2.0).abs() < 0.03 && (f.x[1] - 0.3).abs() < 0.01,
            "{:?}",
            f.x
        );
        let st = f.stats.expect("stats");
        assert_eq!(st.dof, 8);
        // The profile interval of a nearly linear problem is the linearised one.
        for k in 0..2 {
            let (lo, hi) = (f.profile[k].lower, f.profile[k].upper);
            let [a, b] = f.linear[k];
            let w = b - a;
            assert!(
                (lo - a).abs() < 0.05 * w && (hi - b).abs() < 0.05 * w,
                "{k}: {lo} {hi} vs {a} {b}"
            );
        }
        assert!(runs < 200, "{runs} runs");
    }

    #[test]
    fn a_sum_the_data_alone_determine_is_unidentifiable() {
        // Residuals depend on a + b only.
        let mut sp = spec(Goal::Fit, &[(0.0, 2.0, 0.0), (0.0, 2.0, 0.0)]);
        sp.scan = vec![6];
        let fs = fit_spec(true, false);
        let (o, _) = solve(&sp, &fs, 5, |x| {
            Some(
                (0..5)
                    .map(|i| (x[0] + x[1] - 1.3) * (1.0 + i as f64))
                    .collect(),
            )
        });
        assert_eq!(o.status, SearchStatus::Unidentifiable, "{}", o.note);
        assert!(o.note.contains("unidentifiable"), "{}", o.note);
    }

    #[test]
    fn the_points_do_not_depend_on_how_the_batches_are_answered() {
        let mut sp = spec(Goal::Fit, &[(0.0, 3.0, 0.0)]);
        sp.scan = vec![4];
        let fs = fit_spec(true, true);
        let f = |x: &[f64]| {
            Some(
                (0..6)
                    .map(|i| (x[0] - 1.1) * i as f64 + 0.01 * (i as f64).sin())
                    .collect(),
            )
        };
        let (a, ra) = solve(&sp, &fs, 6, f);
        let (b, rb) = solve(&sp, &fs, 6, f);
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
        assert_eq!(ra, rb);
        assert_eq!(a.status, SearchStatus::Converged, "{}", a.note);
    }
}
