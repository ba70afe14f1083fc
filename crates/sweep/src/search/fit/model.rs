//! What the runs of one evaluation predict for each datum of a data set, and the residuals.
//!
//! - a scalar: the run's summary (or combination of two), as a search objective reads it;
//! - a signal: the probe's history, interpolated by a natural cubic spline at the data instants
//!   moved by the time shift; the shift, gain and offset are fitted at every evaluation (gain
//!   and offset in closed form by weighted least squares, the shift on a grid of the history's
//!   half-intervals refined by Brent's method), so that the fields' fit sees their optimum;
//! - a spectrum: the run at each frequency's steady state: the fundamental's amplitude (or
//!   transmission in dB against the reference probe) and its phase against the reference
//!   probe's, wrapped into (−π, π].

use chainsweep_solver::observe::brent_max;

use super::FitEval;
use crate::record::RunRecord;
use crate::sweep::fit::{DataSet, Datum, FitSpec, SigmaRule, Signal, Spectrum, SpectrumQuantity};

/// What an evaluation predicts: per datum row (in the residuals' order) the model's value, and
/// the evaluation.
#[derive(Debug, Clone, PartialEq)]
pub struct Prediction {
    /// The model at every datum (signals: after shift, gain and offset).
    pub model: Vec<f64>,
    /// Residuals and nuisance parameters.
    pub eval: FitEval,
}

/// The measured values and uncertainties of a data set, in the residuals' order (σ NaN when
/// estimated).
pub fn data_rows(set: &DataSet) -> (Vec<f64>, Vec<f64>) {
    let mut v = Vec::with_capacity(set.len());
    let mut s = Vec::with_capacity(set.len());
    for d in &set.data {
        match d {
            Datum::Scalar(x) => {
                v.push(x.value);
                s.push(x.sigma.unwrap_or(f64::NAN));
            }
            Datum::Signal(x) => {
                v.extend_from_slice(&x.value);
                match &x.sigma {
                    Some(sg) => s.extend_from_slice(sg),
                    None => s.extend(std::iter::repeat(f64::NAN).take(x.value.len())),
                }
            }
            Datum::Spectrum(x) => {
                v.extend_from_slice(&x.value);
                match &x.sigma {
                    Some(sg) => s.extend_from_slice(sg),
                    None => s.extend(std::iter::repeat(f64::NAN).take(x.value.len())),
                }
                if let Some((ph, ps)) = &x.phase {
                    v.extend_from_slice(ph);
                    match ps {
                        Some(sg) => s.extend_from_slice(sg),
                        None => s.extend(std::iter::repeat(f64::NAN).take(ph.len())),
                    }
                }
            }
        }
    }
    (v, s)
}

/// The prediction of data set `set` by the runs `records` (one per run of the evaluation, in
/// the order of the fit's variants). `Err`: why there is none (a failed run, a summary without
/// a number, a steady state that did not settle, data beyond the run).
pub fn predict(
    fit: &FitSpec,
    set: &DataSet,
    records: &[Option<&RunRecord>],
) -> Result<Prediction, String> {
    let mut model = Vec::with_capacity(set.len());
    let mut nuisance = Vec::new();
    let mut nuisance_variance = Vec::new();
    let rec = |k: usize| -> Result<&RunRecord, String> {
        let r = records
            .get(k)
            .copied()
            .flatten()
            .ok_or_else(|| "a run is missing".to_string())?;
        if !r.ok {
            return Err(format!("a run failed: {}", r.reason));
        }
        Ok(r)
    };
    let (values, sigmas) = data_rows(set);
    for d in &set.data {
        match d {
            Datum::Scalar(x) => {
                let r = rec(0)?;
                let v = x
                    .quantity
                    .of(r)
                    .ok_or_else(|| format!("{}: the run gives no number", x.name))?;
                model.push(v);
            }
            Datum::Signal(x) => {
                let r = rec(0)?;
                let (m, nu, var) = signal(x, r)?;
                model.extend(m);
                nuisance.extend(nu);
                nuisance_variance.extend(var);
            }
            Datum::Spectrum(x) => {
                let (a, ph) = spectrum(x, &rec)?;
                model.extend(a);
                model.extend(ph);
            }
        }
    }
    let mut residual = Vec::with_capacity(model.len());
    let mut row = 0;
    for d in &set.data {
        let phases = match d {
            Datum::Spectrum(x) if x.phase.is_some() => Some((row + x.value.len(), x.value.len())),
            _ => None,
        };
        for _ in 0..d.len() {
            let mut e = model[row] - values[row];
            if phases.is_some_and(|(start, n)| row >= start && row < start + n) {
                e = wrap(e);
            }
            residual.push(match fit.sigma {
                SigmaRule::Given => e / sigmas[row],
                SigmaRule::Estimated => e,
            });
            row += 1;
        }
    }
    if let Some(i) = residual.iter().position(|r| !r.is_finite()) {
        return Err(format!("datum row {i}: the model gives no number"));
    }
    // (A signal's nuisance variances are per unit σ² of its own weights; with σ estimated the
    // weights are 1 and s² scales them later.)
    Ok(Prediction {
        model,
        eval: FitEval {
            residual,
            nuisance,
            nuisance_variance,
        },
    })
}

/// Per recorded signal of `set` (in order), the estimated error of interpolating the probe's
/// history at the data instants (shifted by `shifts`, one per signal, and scaled by `gains`):
/// the spline through every second sample against the spline through all, over 15 (the cubic
/// spline's error falls 16-fold when its interval halves). NaN where the run has no history.
pub fn interpolation_errors(
    set: &DataSet,
    record: Option<&RunRecord>,
    shifts: &[f64],
    gains: &[f64],
) -> Vec<f64> {
    let mut out = Vec::new();
    let mut k = 0;
    for d in &set.data {
        let Datum::Signal(x) = d else { continue };
        let (shift, gain) = (
            shifts.get(k).copied().unwrap_or(0.0),
            gains.get(k).copied().unwrap_or(1.0),
        );
        k += 1;
        let Some(h) = record.and_then(|r| r.history.as_ref()) else {
            out.push(f64::NAN);
            continue;
        };
        let Some(y) = h.values.get(x.probe.0) else {
            out.push(f64::NAN);
            continue;
        };
        let t = &h.time_s;
        if t.len() < 5 {
            out.push(f64::NAN);
            continue;
        }
        let half_t: Vec<f64> = t.iter().step_by(2).copied().collect();
        let half_y: Vec<f64> = y.iter().step_by(2).copied().collect();
        let (full, half) = (Spline::new(t, y), Spline::new(&half_t, &half_y));
        let (t0, t1) = (half_t[0], half_t[half_t.len() - 1]);
        let e = x
            .time_s
            .iter()
            .map(|&ti| {
                let at = (ti + shift).clamp(t0, t1);
                (gain * (full.at(at).0 - half.at(at).0)).abs() / 15.0
            })
            .fold(0.0, f64::max);
        out.push(e);
    }
    out
}

/// An angle wrapped into (−π, π].
pub fn wrap(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    let w = a - t * (a / t).round();
    if w <= -std::f64::consts::PI {
        w + t
    } else {
        w
    }
}

/// A natural cubic spline through `(t, y)`.
pub struct Spline<'a> {
    t: &'a [f64],
    y: &'a [f64],
    /// Second derivatives at the knots.
    m: Vec<f64>,
}

impl<'a> Spline<'a> {
    /// The spline through the samples (increasing `t`, at least two).
    pub fn new(t: &'a [f64], y: &'a [f64]) -> Spline<'a> {
        let n = t.len();
        let mut m = vec![0.0; n];
        if n > 2 {
            // Tridiagonal system for the interior second derivatives (Thomas algorithm).
            let mut c = vec![0.0; n];
            let mut d = vec![0.0; n];
            for i in 1..n - 1 {
                let h0 = t[i] - t[i - 1];
                let h1 = t[i + 1] - t[i];
                let a = h0 / 6.0;
                let b = (h0 + h1) / 3.0;
                let cc = h1 / 6.0;
                let rhs = (y[i + 1] - y[i]) / h1 - (y[i] - y[i - 1]) / h0;
                let denom = b - a * c[i - 1];
                c[i] = cc / denom;
                d[i] = (rhs - a * d[i - 1]) / denom;
            }
            for i in (1..n - 1).rev() {
                m[i] = d[i] - c[i] * m[i + 1];
            }
        }
        Spline { t, y, m }
    }

    /// Its value and derivative at `x` (within the knots).
    pub fn at(&self, x: f64) -> (f64, f64) {
        let t = self.t;
        let n = t.len();
        let i = t.partition_point(|&v| v <= x).clamp(1, n - 1) - 1;
        let h = t[i + 1] - t[i];
        let a = (t[i + 1] - x) / h;
        let b = (x - t[i]) / h;
        let (m0, m1) = (self.m[i], self.m[i + 1]);
        let v = a * self.y[i]
            + b * self.y[i + 1]
            + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * h * h / 6.0;
        let dv = (self.y[i + 1] - self.y[i]) / h
            + (-(3.0 * a * a - 1.0) * m0 + (3.0 * b * b - 1.0) * m1) * h / 6.0;
        (v, dv)
    }
}

/// Weighted least-squares gain and offset of `m` against `d` (weights `w`); 1 and 0 where not
/// fitted.
fn gain_offset(m: &[f64], d: &[f64], w: &[f64], gain: bool, offset: bool) -> (f64, f64) {
    let sw: f64 = w.iter().sum();
    let swm: f64 = w.iter().zip(m).map(|(w, m)| w * m).sum();
    let swd: f64 = w.iter().zip(d).map(|(w, d)| w * d).sum();
    let swmm: f64 = w.iter().zip(m).map(|(w, m)| w * m * m).sum();
    let swmd: f64 = w.iter().zip(m).zip(d).map(|((w, m), d)| w * m * d).sum();
    match (gain, offset) {
        (false, false) => (1.0, 0.0),
        (true, false) => (if swmm > 0.0 { swmd / swmm } else { 1.0 }, 0.0),
        (false, true) => (1.0, (swd - swm) / sw),
        (true, true) => {
            let det = sw * swmm - swm * swm;
            if det.abs() <= 1e-300 {
                (1.0, (swd - swm) / sw)
            } else {
                (
                    (sw * swmd - swm * swd) / det,
                    (swmm * swd - swm * swmd) / det,
                )
            }
        }
    }
}

/// A signal's model at its instants with its nuisance parameters fitted: the model, the
/// nuisances (shift, gain, offset as fitted) and their variances at fixed fields.
/// A signal's model, its nuisance parameters and their variances at fixed fields.
type SignalFit = (Vec<f64>, Vec<f64>, Vec<f64>);

fn signal(x: &Signal, r: &RunRecord) -> Result<SignalFit, String> {
    let h = r
        .history
        .as_ref()
        .ok_or_else(|| format!("{}: the run recorded no history", x.name))?;
    let t = &h.time_s;
    let y = h
        .values
        .get(x.probe.0)
        .ok_or_else(|| format!("{}: no history of probe {}", x.name, x.probe.1))?;
    if t.len() < 2 {
        return Err(format!(
            "{}: the history holds fewer than two samples",
            x.name
        ));
    }
    let (t0, t1) = (t[0], t[t.len() - 1]);
    let (smin, smax) = x.shift.map_or((0.0, 0.0), |s| (s.min, s.max));
    let first = x.time_s[0];
    let last = x.time_s[x.time_s.len() - 1];
    if first + smin < t0 - 1e-12 * t1.abs() || last + smax > t1 * (1.0 + 1e-12) {
        return Err(format!(
            "{}: the data instants (shifted by up to [{smin}, {smax}] s) reach {} to {} s, beyond the run's history ({t0} to {t1} s)",
            x.name,
            first + smin,
            last + smax
        ));
    }
    let spline = Spline::new(t, y);
    let w: Vec<f64> = match &x.sigma {
        Some(s) => s.iter().map(|s| 1.0 / (s * s)).collect(),
        None => vec![1.0; x.time_s.len()],
    };
    let fit_at = |shift: f64| -> (f64, f64, f64, Vec<f64>) {
        let m: Vec<f64> = x
            .time_s
            .iter()
            .map(|&ti| spline.at((ti + shift).clamp(t0, t1)).0)
            .collect();
        let (g, o) = gain_offset(&m, &x.value, &w, x.gain, x.offset);
        let chi: f64 = m
            .iter()
            .zip(&x.value)
            .zip(&w)
            .map(|((m, d), w)| w * (g * m + o - d).powi(2))
            .sum();
        (chi, g, o, m)
    };
    let shift = match x.shift {
        None => 0.0,
        Some(iv) => {
            let dt = (t1 - t0) / (t.len() - 1) as f64;
            let k = (((iv.max - iv.min) / (0.5 * dt)).ceil() as usize).clamp(16, 400);
            let grid: Vec<f64> = (0..=k)
                .map(|i| iv.min + (iv.max - iv.min) * i as f64 / k as f64)
                .collect();
            let vals: Vec<f64> = grid.iter().map(|&s| fit_at(s).0).collect();
            let j = (0..vals.len())
                .min_by(|&a, &b| vals[a].total_cmp(&vals[b]).then(a.cmp(&b)))
                .expect("a grid");
            let lo = grid[j.saturating_sub(1)];
            let hi = grid[(j + 1).min(k)];
            // (The solver's Brent maximiser, of −χ², from the best grid point.)
            brent_max(lo, hi, grid[j], -vals[j], &mut |s| -fit_at(s).0).1
        }
    };
    let (_, g, o, m) = fit_at(shift);
    let model: Vec<f64> = m.iter().map(|m| g * m + o).collect();
    // Nuisances and their variance at fixed fields: (J_νᵀ W J_ν)⁻¹.
    let mut nu = Vec::new();
    let mut cols: Vec<Vec<f64>> = Vec::new();
    if x.shift.is_some() {
        nu.push(shift);
        cols.push(
            x.time_s
                .iter()
                .map(|&ti| g * spline.at((ti + shift).clamp(t0, t1)).1)
                .collect(),
        );
    }
    if x.gain {
        nu.push(g);
        cols.push(m.clone());
    }
    if x.offset {
        nu.push(o);
        cols.push(vec![1.0; m.len()]);
    }
    let q = cols.len();
    let mut a = nalgebra::DMatrix::<f64>::zeros(q, q);
    for i in 0..q {
        for j in 0..q {
            a[(i, j)] = cols[i]
                .iter()
                .zip(&cols[j])
                .zip(&w)
                .map(|((p, q), w)| w * p * q)
                .sum();
        }
    }
    let var = match a.try_inverse() {
        Some(inv) => (0..q).map(|i| inv[(i, i)]).collect(),
        None => vec![f64::INFINITY; q],
    };
    Ok((model, nu, var))
}

/// A spectrum's model: amplitudes (or transmissions) and, when measured, phases.
fn spectrum<'r>(
    x: &Spectrum,
    rec: &dyn Fn(usize) -> Result<&'r RunRecord, String>,
) -> Result<(Vec<f64>, Vec<f64>), String> {
    let mut amp = Vec::new();
    let mut phase = Vec::new();
    for (&f, &k) in x.frequency_hz.iter().zip(&x.variant) {
        let r = rec(k)?;
        if r.unsettled() {
            return Err(format!(
                "{}: the steady state at {f} Hz did not settle",
                x.name
            ));
        }
        let ss = r
            .steady_state
            .as_ref()
            .ok_or_else(|| format!("{}: the run at {f} Hz has no steady state", x.name))?;
        let p = ss
            .probes
            .get(x.probe.0)
            .ok_or_else(|| format!("{}: no steady state of {}", x.name, x.probe.1))?;
        amp.push(match x.quantity {
            SpectrumQuantity::Amplitude => p.amplitude.first().copied().unwrap_or(f64::NAN),
            SpectrumQuantity::TransmissionDb => p.transmission_db,
        });
        if x.phase.is_some() {
            let r0 = ss
                .probes
                .get(x.reference)
                .and_then(|q| q.phase_rad.first().copied())
                .unwrap_or(f64::NAN);
            phase.push(wrap(p.phase_rad.first().copied().unwrap_or(f64::NAN) - r0));
        }
    }
    Ok((amp, phase))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spline_is_exact_on_a_line_and_close_on_a_sine() {
        let t: Vec<f64> = (0..50).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| 3.0 * t - 1.0).collect();
        let s = Spline::new(&t, &y);
        let (v, d) = s.at(2.345);
        assert!((v - (3.0 * 2.345 - 1.0)).abs() < 1e-12 && (d - 3.0).abs() < 1e-12);
        let y: Vec<f64> = t.iter().map(|t| t.sin()).collect();
        let s = Spline::new(&t, &y);
        for x in [0.73, 1.55, 3.01] {
            let (v, d) = s.at(x);
            assert!((v - f64::sin(x)).abs() < 2e-5, "{x}: {v}");
            assert!((d - f64::cos(x)).abs() < 1e-3, "{x}: {d}");
        }
    }

    #[test]
    fn gain_and_offset_are_the_least_squares_ones() {
        let m = [1.0, 2.0, 3.0, 4.0];
        let d: Vec<f64> = m.iter().map(|m| 1.5 * m + 0.25).collect();
        let (g, o) = gain_offset(&m, &d, &[1.0; 4], true, true);
        assert!((g - 1.5).abs() < 1e-12 && (o - 0.25).abs() < 1e-12);
        assert!((wrap(3.5 * std::f64::consts::PI) + 0.5 * std::f64::consts::PI).abs() < 1e-12);
    }
}
