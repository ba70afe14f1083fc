//! The profile likelihood of a fitted field, one side at a time: the field held at points found
//! by the secant method until χ² has risen by the threshold, each point a fit of the other fields.

use super::super::Streams;
use super::iterate::{levenberg_marquardt, Fitted};
use super::stats::FitStats;
use super::{Ctx, Residuals};

/// Points of one side of a profile at most.
const MAX_PROFILE_POINTS: usize = 8;

/// One side's end of a profile.
pub(super) struct SideEnd {
    pub(super) end: f64,
    pub(super) open: bool,
    pub(super) points: Vec<(f64, f64)>,
    pub(super) lower_found: Option<String>,
}

/// One side (`side` −1 or +1) of field `k`'s profile on `stream` (`None`: it asked for a batch).
#[allow(clippy::too_many_arguments)]
pub(super) fn profile_side(
    cx: &Ctx,
    s: &mut Streams<Residuals>,
    stream: usize,
    best: &Fitted,
    x: &[f64],
    st: &FitStats,
    k: usize,
    side: f64,
) -> Option<SideEnd> {
    let p = cx.p();
    let f = &cx.spec.fields[k];
    let bound = if side < 0.0 { f.min } else { f.max };
    let threshold = st.profile_threshold;
    let target = threshold.sqrt();
    let mut points = Vec::new();
    let mut lower_found = None;
    if x[k] == bound {
        return Some(SideEnd {
            end: bound,
            open: true,
            points,
            lower_found,
        });
    }
    let se = st.standard_error[k];
    let mut theta = (x[k] + side * st.quantile * se).clamp(f.min, f.max);
    // (θ, D = √(χ² − χ²_min)) of the points so far, the minimum first.
    let mut ds: Vec<(f64, f64)> = vec![(x[k], 0.0)];
    let mut asked = 0usize;
    let mut fixed = vec![false; p];
    fixed[k] = true;
    let mut others_from: Vec<f64> = best.u.clone();
    let mut others_theta = x[k];
    for _ in 0..MAX_PROFILE_POINTS {
        // The other fields start at their conditional optimum (linear in θ from the last
        // profile point).
        let mut u0 = others_from.clone();
        for j in 0..p {
            if j != k {
                let c = st.covariance[j * p + k] / st.covariance[k * p + k];
                let xj = cx.to_fields(&others_from)[j] + c * (theta - others_theta);
                u0[j] = cx.to_unit(&{
                    let mut v = x.to_vec();
                    v[j] = xj;
                    v
                })[j];
            }
        }
        u0[k] = cx.to_unit(&{
            let mut v = x.to_vec();
            v[k] = theta;
            v
        })[k];
        let fitted = levenberg_marquardt(cx, s, stream, u0, None, &fixed, &mut asked)?;
        if !fitted.chi2.is_finite() {
            // A failed profile point: the side ends where it is known.
            break;
        }
        points.push((theta, fitted.chi2));
        if fitted.chi2 < best.chi2 - 1e-6 * best.chi2.max(1.0) && lower_found.is_none() {
            lower_found = Some(format!(
                "the profile of {} found a lower chi_square ({:.4e} < {:.4e}) at {} = {theta}: the minimum reported is not the global one (more starts, a larger scan)",
                f.name, fitted.chi2, best.chi2, f.name
            ));
        }
        let d = (fitted.chi2 - best.chi2).max(0.0).sqrt();
        ds.push((theta, d));
        others_from = fitted.u.clone();
        others_theta = theta;
        if (d - target).abs() <= 0.01 * target {
            // (√Δχ² is nearly linear in θ: the secant from the minimum puts the end on the
            // threshold itself.)
            return Some(SideEnd {
                end: (x[k] + (theta - x[k]) * target / d).clamp(f.min, f.max),
                open: false,
                points,
                lower_found,
            });
        }
        if d < target && theta == bound {
            return Some(SideEnd {
                end: bound,
                open: true,
                points,
                lower_found,
            });
        }
        // The next θ: inside the bracket by the secant of D, or beyond the last point.
        let below = ds
            .iter()
            .filter(|q| q.1 < target)
            .max_by(|a, b| ((a.0 - x[k]) * side).total_cmp(&((b.0 - x[k]) * side)))
            .copied()
            .expect("the minimum is below");
        let above = ds
            .iter()
            .filter(|q| q.1 >= target)
            .min_by(|a, b| ((a.0 - x[k]) * side).total_cmp(&((b.0 - x[k]) * side)))
            .copied();
        theta = match above {
            Some(a) => below.0 + (a.0 - below.0) * (target - below.1) / (a.1 - below.1),
            None => {
                let (t, dd) = (theta, d);
                let reach = if dd > 1e-12 * target {
                    x[k] + (t - x[k]) * target / dd
                } else {
                    x[k] + 4.0 * (t - x[k])
                };
                let limited =
                    x[k] + (reach - x[k]).clamp(-4.0 * (t - x[k]).abs(), 4.0 * (t - x[k]).abs());
                limited.clamp(f.min, f.max)
            }
        };
    }
    // Out of points: the end where the secant of the bracket puts it (or the last point).
    let below = ds
        .iter()
        .filter(|q| q.1 < target)
        .max_by(|a, b| ((a.0 - x[k]) * side).total_cmp(&((b.0 - x[k]) * side)))
        .copied()
        .unwrap_or((x[k], 0.0));
    let above = ds
        .iter()
        .filter(|q| q.1 >= target)
        .min_by(|a, b| ((a.0 - x[k]) * side).total_cmp(&((b.0 - x[k]) * side)))
        .copied();
    let end = match above {
        Some(a) => below.0 + (a.0 - below.0) * (target - below.1) / (a.1 - below.1),
        None => f64::NAN,
    };
    Some(SideEnd {
        end,
        open: false,
        points,
        lower_found,
    })
}
