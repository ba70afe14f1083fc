//! One Levenberg–Marquardt fit from its start, replayed over its stream: each iteration asks for
//! one batch (the trial point and a forward-difference point per free field), takes the Jacobian
//! from it, and steps within the trust region ([`lm`](super::lm)).

use std::sync::Arc;

use nalgebra::DVector;

use super::super::{ItemStatus, Point, Streams};
use super::{at_lower, at_upper, chi_square, lm, snap_to_box, Ctx, FitEval, Residuals};

/// Iterations of one Levenberg–Marquardt fit at most.
const MAX_ITERATIONS: usize = 40;

/// Initial trust radius, in the box's unit coordinates.
const INITIAL_RADIUS: f64 = 0.25;

/// One Levenberg–Marquardt fit's end.
#[derive(Debug, Clone)]
pub(super) struct Fitted {
    pub(super) u: Vec<f64>,
    pub(super) eval: Arc<FitEval>,
    pub(super) chi2: f64,
    /// Jacobian of the residuals in unit coordinates, column-major n × p (fixed fields' columns
    /// zero).
    pub(super) ju: Vec<f64>,
    /// The nuisances' derivatives, column-major (nuisances × p), unit coordinates.
    pub(super) jn: Vec<f64>,
    pub(super) status: ItemStatus,
    pub(super) note: String,
    /// Its evaluation: index in its stream.
    pub(super) index: usize,
}

/// The points of a batch: the trial point and a forward-difference point per free field.
fn fd_batch(cx: &Ctx, u: &[f64], free: &[usize], with_point: bool) -> (Vec<Point>, Vec<f64>) {
    let mut pts = Vec::new();
    if with_point {
        pts.push(cx.to_fields(u));
    }
    let mut steps = Vec::new();
    for &k in free {
        let h = cx.fd_step(k, u[k]);
        let mut v = u.to_vec();
        v[k] += h;
        pts.push(cx.to_fields(&v));
        steps.push(h);
    }
    (pts, steps)
}

/// The Jacobian (and the nuisances' derivatives) from the difference evaluations around `at`.
fn jacobian(
    cx: &Ctx,
    at: &FitEval,
    fd: &[Option<Arc<FitEval>>],
    free: &[usize],
    steps: &[f64],
) -> Option<(Vec<f64>, Vec<f64>)> {
    let n = at.residual.len();
    let q = at.nuisance.len();
    let p = cx.p();
    let mut ju = vec![0.0; n * p];
    let mut jn = vec![0.0; q * p];
    for ((&k, e), &h) in free.iter().zip(fd).zip(steps) {
        let e = e.as_ref()?;
        for i in 0..n {
            ju[k * n + i] = (e.residual[i] - at.residual[i]) / h;
        }
        for i in 0..q {
            jn[k * q + i] = (e.nuisance[i] - at.nuisance[i]) / h;
        }
    }
    Some((ju, jn))
}

/// Levenberg–Marquardt from `u0` on `stream`, fields with `fixed` held; `known0` the evaluation
/// at `u0` when the stream need not ask for it (a scan point). `None`: it asked for a batch.
pub(super) fn levenberg_marquardt(
    cx: &Ctx,
    s: &mut Streams<Residuals>,
    stream: usize,
    u0: Vec<f64>,
    known0: Option<(Arc<FitEval>, usize)>,
    fixed: &[bool],
    asked_so_far: &mut usize,
) -> Option<Fitted> {
    let p = cx.p();
    let free: Vec<usize> = (0..p).filter(|&k| !fixed[k]).collect();
    let u = u0;
    let (pts, mut steps) = fd_batch(cx, &u, &free, known0.is_none());
    let vals = s.eval(stream, &pts)?;
    let base = *asked_so_far;
    *asked_so_far += pts.len();
    let (mut cur, index, fd) = match known0 {
        Some((e, i)) => (Some(e), i, &vals[..]),
        None => (vals[0].clone(), base, &vals[1..]),
    };
    let fail = |u: &[f64], index: usize, why: &str| -> Fitted {
        Fitted {
            u: u.to_vec(),
            eval: Arc::new(FitEval {
                residual: Vec::new(),
                nuisance: Vec::new(),
                nuisance_variance: Vec::new(),
            }),
            chi2: f64::INFINITY,
            ju: Vec::new(),
            jn: Vec::new(),
            status: ItemStatus::Failed,
            note: why.to_string(),
            index,
        }
    };
    let Some(at) = cur.take() else {
        return Some(fail(&u, index, "its starting run failed"));
    };
    let mut here = Here {
        chi2: chi_square(&at.residual),
        jac: jacobian(cx, &at, fd, &free, &steps),
        u,
        eval: at,
        index,
    };
    let mut radius = INITIAL_RADIUS;
    for _ in 0..MAX_ITERATIONS {
        let Some((ju, _)) = &here.jac else {
            return Some(here.end(ItemStatus::Stalled, "a finite-difference run failed"));
        };
        if free.is_empty() {
            return Some(here.end(ItemStatus::Converged, ""));
        }
        let (u, r) = (&here.u, &here.eval.residual);
        // Active set: a field on a bound whose descent points out of the box is held.
        let (_, g_all) = lm::normal_equations(ju, r, &free);
        let act: Vec<usize> = free
            .iter()
            .enumerate()
            .filter(|&(i, &k)| {
                !((at_lower(u[k]) && g_all[i] > 0.0) || (at_upper(u[k]) && g_all[i] < 0.0))
            })
            .map(|(_, &k)| k)
            .collect();
        let (a, g) = lm::normal_equations(ju, r, &act);
        let gn = lm::trust_step(&a, &g, f64::INFINITY);
        let gn_decrease = lm::predicted_decrease(&a, &g, &gn);
        let small_step = act.iter().enumerate().all(|(i, &k)| {
            let tol = cx.spec.fields[k].tolerance;
            let dx = (gn[i] * cx.width(k)).abs();
            (tol > 0.0 && dx <= tol) || gn[i].abs() <= 1e-7
        });
        if act.is_empty() || gn_decrease <= cx.converged_below(here.chi2) || small_step {
            return Some(here.end(ItemStatus::Converged, ""));
        }
        let d = lm::trust_step(&a, &g, radius);
        let mut trial = u.clone();
        for (i, &k) in act.iter().enumerate() {
            trial[k] = snap_to_box(u[k] + d[i]);
        }
        let dp = DVector::from_iterator(act.len(), act.iter().map(|&k| trial[k] - u[k]));
        let step_norm = dp.norm();
        let predicted = lm::predicted_decrease(&a, &g, &dp);
        if step_norm <= 1e-12 || predicted <= 0.0 {
            return Some(here.end(
                ItemStatus::Stalled,
                "no step lowers the linear model within the box",
            ));
        }
        let (pts, new_steps) = fd_batch(cx, &trial, &free, true);
        let vals = s.eval(stream, &pts)?;
        let base = *asked_so_far;
        *asked_so_far += pts.len();
        // The actual decrease against the predicted one: accept, and size the region by it.
        let rho = vals[0].as_ref().map_or(f64::NEG_INFINITY, |e| {
            (here.chi2 - chi_square(&e.residual)) / predicted
        });
        if rho > 0.75 {
            radius = radius.max(2.0 * step_norm);
        } else if rho < 0.25 {
            radius = 0.25 * step_norm;
        }
        match &vals[0] {
            None if cx.stop_on_failure => {
                return Some(fail(&trial, base, "a run failed (failed: stop)"));
            }
            Some(e) if rho > 1e-4 => {
                steps = new_steps;
                here = Here {
                    chi2: chi_square(&e.residual),
                    jac: jacobian(cx, e, &vals[1..], &free, &steps),
                    u: trial,
                    eval: e.clone(),
                    index: base,
                };
            }
            _ if radius < 1e-9 => {
                return Some(here.end(
                    ItemStatus::Stalled,
                    "the trust region collapsed: χ² does not fall as the linear model predicts (the runs' noise, or a jump)",
                ));
            }
            _ => {}
        }
    }
    Some(here.end(
        ItemStatus::Stalled,
        format!("not converged in {MAX_ITERATIONS} iterations"),
    ))
}

/// Where a Levenberg–Marquardt fit stands: its point (unit coordinates), the evaluation there,
/// χ², the Jacobian (`None`: a difference run failed) and the evaluation's index in its stream.
struct Here {
    u: Vec<f64>,
    eval: Arc<FitEval>,
    chi2: f64,
    jac: Option<(Vec<f64>, Vec<f64>)>,
    index: usize,
}

impl Here {
    /// The fit ended here.
    fn end(self, status: ItemStatus, note: impl Into<String>) -> Fitted {
        let (ju, jn) = self.jac.unwrap_or_default();
        Fitted {
            u: self.u,
            eval: self.eval,
            chi2: self.chi2,
            ju,
            jn,
            status,
            note: note.into(),
            index: self.index,
        }
    }
}
