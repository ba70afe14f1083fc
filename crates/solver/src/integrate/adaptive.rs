//! What the adaptive integrators share: checking their settings, Hairer's starting step, and
//! locating the switches (contacts opening and closing) that a step crosses.

use super::{all_finite, DenseStep, IntegrateError, OdeSystemDyn, Switch};

/// Settings common to the adaptive methods, as the user gave them.
pub(crate) struct AdaptiveSettings<'a> {
    /// Method name, for error messages.
    pub name: &'static str,
    pub rtol: f64,
    pub atol: f64,
    pub atol_scale: Option<&'a [f64]>,
    pub h_init: Option<f64>,
    pub h_max: Option<f64>,
}

impl AdaptiveSettings<'_> {
    /// Checks the settings against the problem and returns the absolute tolerance of every
    /// component, `atol * atol_scale[i]`.
    pub fn validate(
        &self,
        sys: &dyn OdeSystemDyn,
        t0: f64,
        y0: &[f64],
        t_end: f64,
    ) -> Result<Vec<f64>, IntegrateError> {
        let bad = |s: String| {
            Err(IntegrateError::InvalidSettings(format!(
                "{}: {s}",
                self.name
            )))
        };
        let (rtol, atol) = (self.rtol, self.atol);
        if !(rtol.is_finite() && rtol > 0.0) {
            return bad(format!("rtol must be positive and finite, got {rtol}"));
        }
        if !(atol.is_finite() && atol >= 0.0) {
            return bad(format!("atol must be non-negative and finite, got {atol}"));
        }
        if !(t0.is_finite() && t_end.is_finite() && t_end > t0) {
            return bad(format!(
                "need finite t_end > t0, got t0 = {t0}, t_end = {t_end}"
            ));
        }
        for (what, value) in [("h_max", self.h_max), ("h_init", self.h_init)] {
            if let Some(h) = value {
                if !(h.is_finite() && h > 0.0) {
                    return bad(format!("{what} must be positive and finite, got {h}"));
                }
            }
        }
        let n = 2 * sys.n_pos() + sys.n_quad();
        if y0.len() != n {
            return bad(format!(
                "y0 has length {} but the system has dimension {n}",
                y0.len()
            ));
        }
        if !all_finite(y0) {
            return bad("initial state is not finite".to_string());
        }
        match self.atol_scale {
            None => Ok(vec![atol; n]),
            Some(scale) if scale.len() != n => bad(format!(
                "atol_scale has length {} but the system has dimension {n}",
                scale.len()
            )),
            Some(scale) if !scale.iter().all(|s| s.is_finite() && *s >= 0.0) => {
                bad("atol_scale entries must be finite and non-negative".to_string())
            }
            Some(scale) => Ok(scale.iter().map(|s| atol * s).collect()),
        }
    }
}

/// Hairer's `HINIT` for a method of order `order`: a first step such that an explicit Euler step
/// changes the solution by about 1 % and `h^order max(|f|, |f'|) ≈ 0.01` in the tolerance-weighted
/// norm. One evaluation of `f` (into `f1`, with `y1` as scratch).
#[allow(clippy::too_many_arguments)]
pub(crate) fn initial_step(
    order: i32,
    sys: &mut dyn OdeSystemDyn,
    t0: f64,
    y: &[f64],
    f0: &[f64],
    y1: &mut [f64],
    f1: &mut [f64],
    (rtol, atol): (f64, &[f64]),
    h_max: f64,
) -> f64 {
    let mut dnf = 0.0;
    let mut dny = 0.0;
    for ((yi, fi), ai) in y.iter().zip(f0).zip(atol) {
        let sk = ai + rtol * yi.abs();
        if sk > 0.0 {
            dnf += (fi / sk) * (fi / sk);
            dny += (yi / sk) * (yi / sk);
        }
    }
    let mut h = if dnf <= 1e-10 || dny <= 1e-10 {
        1e-6
    } else {
        (dny / dnf).sqrt() * 0.01
    };
    if !(h > 0.0 && h.is_finite()) {
        h = 1e-6;
    }
    h = h.min(h_max);
    for ((o, yi), fi) in y1.iter_mut().zip(y).zip(f0) {
        *o = yi + h * fi;
    }
    sys.rhs(t0 + h, y1, f1);
    let mut der2 = 0.0;
    for (((yi, a), b), ai) in y.iter().zip(f0).zip(f1.iter()).zip(atol) {
        let sk = ai + rtol * yi.abs();
        if sk > 0.0 {
            let d = (b - a) / sk;
            der2 += d * d;
        }
    }
    let der2 = der2.sqrt() / h;
    let der12 = der2.abs().max(dnf.sqrt());
    let h1 = if der12 <= 1e-15 || !der12.is_finite() {
        (h * 1e-3).max(1e-6)
    } else {
        (0.01 / der12).powf(1.0 / order as f64)
    };
    let h = (100.0 * h).min(h1).min(h_max);
    if h > 0.0 && h.is_finite() {
        h
    } else {
        1e-6_f64.min(h_max)
    }
}

/// Earliest zero of a switching function inside an accepted step that starts at `y_start`,
/// located on the step's dense output by the Illinois variant of regula falsi. `None` if no switch
/// changes sign over the step. A switch exactly at zero at the start (the striker touching at
/// t = 0, or a step that just landed on an event) is where the step begins, not an event in it.
pub(crate) fn earliest_event<S: DenseStep + ?Sized>(
    switches: &[Switch],
    y_start: &[f64],
    step: &S,
) -> Option<f64> {
    let (t0, t1) = (step.t_start(), step.t_end());
    let y_end = step.y_end();
    let mut earliest: Option<f64> = None;
    for sw in switches {
        let g0 = sw.value(|i| y_start[i]);
        let g1 = sw.value(|i| y_end[i]);
        if g0 == 0.0 || (g0 > 0.0) == (g1 > 0.0) {
            continue;
        }
        let g = |t: f64| sw.value(|i| step.eval_component(t, i));
        let (mut a, mut b) = (t0, earliest.unwrap_or(t1));
        let (mut ga, mut gb) = (g0, g(b));
        if (ga > 0.0) == (gb > 0.0) {
            // This switch crosses only after an earlier event already found.
            continue;
        }
        let mut side = 0i8;
        for _ in 0..100 {
            let m = (a * gb - b * ga) / (gb - ga);
            let m = if m.is_finite() && m > a && m < b {
                m
            } else {
                0.5 * (a + b)
            };
            let gm = g(m);
            if (gm > 0.0) == (ga > 0.0) {
                a = m;
                ga = gm;
                if side == -1 {
                    gb *= 0.5;
                }
                side = -1;
            } else {
                b = m;
                gb = gm;
                if side == 1 {
                    ga *= 0.5;
                }
                side = 1;
            }
            if b - a <= 1e-12 * (t1 - t0) {
                break;
            }
        }
        earliest = Some(b);
    }
    earliest
}

/// Earliest crossing of a switch over a rejected attempt of length `h`, predicted from the values
/// at both ends and the slope at the start (a quadratic in time); `None` if no switch changes sign.
pub(crate) fn predicted_event(
    switches: &[Switch],
    y0: &[f64],
    f0: &[f64],
    y1: &[f64],
    h: f64,
) -> Option<f64> {
    let mut earliest: Option<f64> = None;
    for sw in switches {
        let g0 = sw.value(|i| y0[i]);
        let g1 = sw.value(|i| y1[i]);
        if g0 == 0.0 || (g0 > 0.0) == (g1 > 0.0) || !g1.is_finite() {
            continue;
        }
        // g(s) = g0 + b s + c s², s in [0, 1].
        let b = sw.value(|i| f0[i]) * h;
        let c = g1 - g0 - b;
        let linear = g0 / (g0 - g1);
        let s = if c.abs() > 1e-12 * (g0.abs() + g1.abs()) {
            let disc = b * b - 4.0 * c * g0;
            if disc >= 0.0 {
                let q = -0.5 * (b + b.signum() * disc.sqrt());
                let roots = [q / c, if q != 0.0 { g0 / q } else { f64::NAN }];
                roots
                    .into_iter()
                    .filter(|r| r.is_finite() && *r > 0.0 && *r <= 1.0)
                    .fold(f64::NAN, f64::min)
            } else {
                linear
            }
        } else {
            linear
        };
        let tau = if s.is_finite() { s } else { linear } * h;
        earliest = Some(earliest.map_or(tau, |e: f64| e.min(tau)));
    }
    earliest
}

/// The step that ends just past a crossing `tau` after `t` (a hair past, so the next step starts
/// in the new regime), or `None` when it would be no shorter than `limit` or too short for
/// floating point to move the state: then the step is taken as it is.
pub(crate) fn event_step(t: f64, h_step: f64, tau: f64, limit: f64) -> Option<f64> {
    let h_event = tau * (1.0 + 1e-6);
    (h_event < limit * (1.0 - 1e-6) && h_event > 100.0 * f64::EPSILON * t.abs().max(h_step))
        .then_some(h_event)
}
