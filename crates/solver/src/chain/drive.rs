//! Boundary drives: a prescribed force on the first chain particle, a prescribed displacement of
//! an actuator at the top (a wall that moves, touching the first particle through its contact
//! law, so that contact can be lost), or a prescribed displacement of the wall under the chain
//! (a moving base); each follows a waveform (harmonic, chirp, a sum of harmonics, a recorded
//! signal) that gives its value and its first two time derivatives in closed form.
//!
//! A displacement drive's wall position is part of the state (a quadrature of its velocity), so
//! that every overlap, switch and energy reads the state alone; the work the drive does is a
//! quadrature too, and enters the energy ledger.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::spec::{check_positive, spec_err, SpecError};

/// Longest recorded waveform, in samples: a recording larger than this is refused rather than
/// held in every run's memory (a million samples is 16 MB per run).
pub const MAX_RECORDED_SAMPLES: usize = 1_000_000;

/// A drive as written: where it acts, and its waveform. The key says the unit of the waveform's
/// values: `force_n` (newtons, on the first chain particle), `actuator_m` (metres: the
/// displacement towards the chain of a wall at the top, from the position where it touches the
/// first particle at its static overlap), `base_m` (metres: the displacement of the wall under the
/// chain, positive downwards, away from the chain).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(
    feature = "serde",
    serde(rename_all = "snake_case", deny_unknown_fields)
)]
pub enum DriveSpec {
    /// A prescribed force on the first chain particle, N, positive towards the chain's bottom.
    ForceN(Waveform),
    /// A prescribed displacement of an actuator at the top, m, positive into the chain.
    ActuatorM(Waveform),
    /// A prescribed displacement of the wall under the chain, m, positive downwards.
    BaseM(Waveform),
}

/// Where a drive acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DrivePoint {
    /// A force on the first chain particle.
    Force,
    /// A moving wall at the top.
    Actuator,
    /// A moving wall under the chain.
    Base,
}

impl DrivePoint {
    /// The field name of the drive in a sweep file.
    pub fn key(self) -> &'static str {
        match self {
            DrivePoint::Force => "force_n",
            DrivePoint::Actuator => "actuator_m",
            DrivePoint::Base => "base_m",
        }
    }

    /// Whether the drive moves a wall (its position and velocity are then in the state).
    pub fn moves_a_wall(self) -> bool {
        !matches!(self, DrivePoint::Force)
    }
}

impl DriveSpec {
    /// Where the drive acts.
    pub fn point(&self) -> DrivePoint {
        match self {
            DriveSpec::ForceN(_) => DrivePoint::Force,
            DriveSpec::ActuatorM(_) => DrivePoint::Actuator,
            DriveSpec::BaseM(_) => DrivePoint::Base,
        }
    }

    /// The waveform.
    pub fn waveform(&self) -> &Waveform {
        match self {
            DriveSpec::ForceN(w) | DriveSpec::ActuatorM(w) | DriveSpec::BaseM(w) => w,
        }
    }

    /// The waveform, to fill in (a recording read from a file).
    pub fn waveform_mut(&mut self) -> &mut Waveform {
        match self {
            DriveSpec::ForceN(w) | DriveSpec::ActuatorM(w) | DriveSpec::BaseM(w) => w,
        }
    }

    /// Field path of the waveform, `excitation.drive.<key>`.
    pub fn field(&self) -> String {
        format!("excitation.drive.{}", self.point().key())
    }

    /// Checks the drive for a run of `duration_s`; the error names the field.
    pub fn validate(&self, duration_s: f64) -> Result<Drive, SpecError> {
        let base = self.field();
        let waveform = self.waveform().compile(&base, duration_s)?;
        // A drive that moves nothing (a force of zero, a wall held still) gives no excitation
        // and no scale to measure the motion by: refused here, not as runs that fail.
        let still = match self.point() {
            DrivePoint::Force => waveform.peak() == 0.0,
            DrivePoint::Actuator | DrivePoint::Base => waveform.peak_rate() == 0.0,
        };
        if still {
            let (field, what) = match self.waveform() {
                Waveform::Harmonic(_) => ("harmonic.amplitude", "its amplitude is 0"),
                Waveform::Chirp(_) => ("chirp.amplitude", "its amplitude is 0"),
                Waveform::Sum(_) => ("sum.tones", "every tone's amplitude is 0"),
                Waveform::Recorded(_) => (
                    "recorded.values",
                    match self.point() {
                        DrivePoint::Force => "every value is 0",
                        _ => "every value is the same: the wall is held still",
                    },
                ),
            };
            return Err(spec_err(
                &format!("{base}.{field}"),
                format!("moves nothing ({what}): a drive must excite the chain; start a sweep of its amplitude above 0, or leave the drive out"),
            ));
        }
        Ok(Drive {
            point: self.point(),
            waveform,
        })
    }
}

/// A waveform as written. Every periodic waveform may start with a smooth ramp: its amplitude
/// rises as `(1 − cos(π t / T_r))/2` over `T_r = ramp_periods` periods, so that the drive, its
/// velocity and its force start from zero.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(
    feature = "serde",
    serde(rename_all = "snake_case", deny_unknown_fields)
)]
pub enum Waveform {
    /// `amplitude · sin(2π f t + φ)`.
    Harmonic(Harmonic),
    /// `amplitude · sin θ(t)`, the frequency sweeping from `start_hz` to `end_hz` over
    /// `duration_s` (linearly, or logarithmically: a constant number of periods per octave), then
    /// holding `end_hz`.
    Chirp(Chirp),
    /// `Σ amplitude_k · sin(2π f_k t + φ_k)`.
    Sum(SumOfHarmonics),
    /// A recorded signal, interpolated by a natural cubic spline (continuous to its second
    /// derivative); the run must lie within its times.
    Recorded(Recorded),
}

/// One harmonic.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Harmonic {
    /// Amplitude, in the drive's unit (N or m).
    pub amplitude: f64,
    /// Frequency, Hz.
    pub frequency_hz: f64,
    /// Phase at `t = 0`, rad.
    #[cfg_attr(feature = "serde", serde(default))]
    pub phase_rad: f64,
    /// Periods over which the amplitude ramps up smoothly from zero (0: none).
    #[cfg_attr(feature = "serde", serde(default))]
    pub ramp_periods: f64,
}

/// How a chirp's frequency moves between its ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum ChirpSpacing {
    /// `f(t) = f₀ + (f₁ − f₀) t / T`.
    #[default]
    Linear,
    /// `f(t) = f₀ (f₁/f₀)^{t/T}`.
    Logarithmic,
}

/// A chirp.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Chirp {
    /// Amplitude, in the drive's unit (N or m).
    pub amplitude: f64,
    /// Frequency at `t = 0`, Hz.
    pub start_hz: f64,
    /// Frequency at `t = duration_s` and after, Hz.
    pub end_hz: f64,
    /// Duration of the sweep, s.
    pub duration_s: f64,
    /// Linear or logarithmic.
    #[cfg_attr(feature = "serde", serde(default))]
    pub spacing: ChirpSpacing,
    /// Periods of the start frequency over which the amplitude ramps up (0: none).
    #[cfg_attr(feature = "serde", serde(default))]
    pub ramp_periods: f64,
}

/// One tone of a sum.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Tone {
    /// Amplitude, in the drive's unit (N or m).
    pub amplitude: f64,
    /// Frequency, Hz.
    pub frequency_hz: f64,
    /// Phase at `t = 0`, rad.
    #[cfg_attr(feature = "serde", serde(default))]
    pub phase_rad: f64,
}

/// A sum of harmonics.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SumOfHarmonics {
    /// The tones (at least one).
    pub tones: Vec<Tone>,
    /// Periods of the lowest tone over which the amplitude ramps up (0: none).
    #[cfg_attr(feature = "serde", serde(default))]
    pub ramp_periods: f64,
}

/// A recorded signal: its samples inline (`times_s`, `values`), or a file that holds them (`path`:
/// a CSV file of two columns, time in s and value, or an HDF5 file with `dataset` naming an
/// `(n, 2)` array or a group holding `times_s` and `values`), which the sweep runner reads into the
/// samples before the scene runs (relative paths from the sweep file's folder).
#[derive(Debug, Clone, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Recorded {
    /// Sample times, s, strictly increasing.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Vec::is_empty")
    )]
    pub times_s: Vec<f64>,
    /// Values at the sample times, in the drive's unit (N or m).
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Vec::is_empty")
    )]
    pub values: Vec<f64>,
    /// A file holding the samples, instead of `times_s` and `values`.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub path: Option<String>,
    /// In an HDF5 file, the dataset or group holding the samples.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub dataset: Option<String>,
}

/// A built drive: where it acts and its compiled waveform.
#[derive(Debug, Clone, PartialEq)]
pub struct Drive {
    /// Where it acts.
    pub point: DrivePoint,
    /// Its waveform.
    pub waveform: Signal,
}

impl Drive {
    /// Times strictly inside `(0, duration)` at which the waveform's second derivative jumps (the
    /// end of a ramp or of a chirp's sweep): the run is integrated in legs between them.
    pub fn breakpoints_s(&self, duration_s: f64) -> Vec<f64> {
        self.waveform
            .kinks
            .iter()
            .copied()
            .filter(|&t| t > 0.0 && t < duration_s)
            .collect()
    }
}

/// A compiled waveform: value, velocity and acceleration at any time, in closed form.
#[derive(Debug, Clone, PartialEq)]
pub struct Signal {
    shape: Shape,
    /// Duration of the ramp, s (0: none).
    ramp_s: f64,
    /// Times where the second derivative jumps.
    kinks: Vec<f64>,
    /// The frequency a steady response settles at, Hz (a single harmonic's).
    steady_hz: Option<f64>,
    /// Largest amplitude the waveform reaches, its largest rate (per second) and its highest
    /// frequency, Hz (scales).
    peak: f64,
    peak_rate: f64,
    highest_hz: f64,
}

#[derive(Debug, Clone, PartialEq)]
enum Shape {
    /// Tones `(amplitude, angular frequency, phase)`.
    Tones(Vec<(f64, f64, f64)>),
    /// A chirp: amplitude, start and end angular frequencies, sweep duration, logarithmic.
    Chirp {
        amplitude: f64,
        w0: f64,
        w1: f64,
        duration: f64,
        logarithmic: bool,
    },
    /// A natural cubic spline: knots, values and second derivatives at the knots.
    Spline {
        t: Vec<f64>,
        y: Vec<f64>,
        m: Vec<f64>,
    },
}

impl Waveform {
    /// Compiles the waveform for a run of `duration_s`, checking every value; errors name the
    /// field under `base`.
    pub fn compile(&self, base: &str, duration_s: f64) -> Result<Signal, SpecError> {
        let finite = |field: String, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(spec_err(
                    &field,
                    format!("must be a finite number, got {v}"),
                ))
            }
        };
        let ramp = |field: String, periods: f64| {
            if periods.is_finite() && periods >= 0.0 {
                Ok(())
            } else {
                Err(spec_err(
                    &field,
                    format!("must be a finite number >= 0, got {periods}"),
                ))
            }
        };
        let tau = std::f64::consts::TAU;
        let (shape, ramp_s, steady_hz, peak, highest_hz) = match self {
            Waveform::Harmonic(h) => {
                let b = format!("{base}.harmonic");
                finite(format!("{b}.amplitude"), h.amplitude)?;
                check_positive(&format!("{b}.frequency_hz"), h.frequency_hz)?;
                finite(format!("{b}.phase_rad"), h.phase_rad)?;
                ramp(format!("{b}.ramp_periods"), h.ramp_periods)?;
                (
                    Shape::Tones(vec![(h.amplitude, tau * h.frequency_hz, h.phase_rad)]),
                    h.ramp_periods / h.frequency_hz,
                    Some(h.frequency_hz),
                    h.amplitude.abs(),
                    h.frequency_hz,
                )
            }
            Waveform::Chirp(c) => {
                let b = format!("{base}.chirp");
                finite(format!("{b}.amplitude"), c.amplitude)?;
                check_positive(&format!("{b}.start_hz"), c.start_hz)?;
                check_positive(&format!("{b}.end_hz"), c.end_hz)?;
                check_positive(&format!("{b}.duration_s"), c.duration_s)?;
                ramp(format!("{b}.ramp_periods"), c.ramp_periods)?;
                (
                    Shape::Chirp {
                        amplitude: c.amplitude,
                        w0: tau * c.start_hz,
                        w1: tau * c.end_hz,
                        duration: c.duration_s,
                        logarithmic: c.spacing == ChirpSpacing::Logarithmic,
                    },
                    c.ramp_periods / c.start_hz,
                    None,
                    c.amplitude.abs(),
                    c.start_hz.max(c.end_hz),
                )
            }
            Waveform::Sum(s) => {
                let b = format!("{base}.sum");
                if s.tones.is_empty() {
                    return Err(spec_err(
                        &format!("{b}.tones"),
                        "must hold at least one tone {\"amplitude\": …, \"frequency_hz\": …}",
                    ));
                }
                for (k, t) in s.tones.iter().enumerate() {
                    finite(format!("{b}.tones[{k}].amplitude"), t.amplitude)?;
                    check_positive(&format!("{b}.tones[{k}].frequency_hz"), t.frequency_hz)?;
                    finite(format!("{b}.tones[{k}].phase_rad"), t.phase_rad)?;
                }
                ramp(format!("{b}.ramp_periods"), s.ramp_periods)?;
                let lowest = s
                    .tones
                    .iter()
                    .map(|t| t.frequency_hz)
                    .fold(f64::MAX, f64::min);
                let highest = s.tones.iter().map(|t| t.frequency_hz).fold(0.0, f64::max);
                (
                    Shape::Tones(
                        s.tones
                            .iter()
                            .map(|t| (t.amplitude, tau * t.frequency_hz, t.phase_rad))
                            .collect(),
                    ),
                    s.ramp_periods / lowest,
                    None,
                    s.tones.iter().map(|t| t.amplitude.abs()).sum(),
                    highest,
                )
            }
            Waveform::Recorded(r) => {
                let b = format!("{base}.recorded");
                if r.path.is_some() {
                    return Err(spec_err(
                        &format!("{b}.path"),
                        "a recording named by path is read by the sweep runner (chainsweep run, point or the Python package); here give its samples as times_s and values",
                    ));
                }
                let (t, y) = (&r.times_s, &r.values);
                if t.len() < 2 || t.len() > MAX_RECORDED_SAMPLES {
                    return Err(spec_err(
                        &format!("{b}.times_s"),
                        format!(
                            "must hold between 2 and {MAX_RECORDED_SAMPLES} sample times, got {}",
                            t.len()
                        ),
                    ));
                }
                if y.len() != t.len() {
                    return Err(spec_err(
                        &format!("{b}.values"),
                        format!(
                            "must hold one value per sample time ({}), got {}",
                            t.len(),
                            y.len()
                        ),
                    ));
                }
                for (k, &v) in y.iter().enumerate() {
                    finite(format!("{b}.values[{k}]"), v)?;
                }
                for k in 0..t.len() {
                    finite(format!("{b}.times_s[{k}]"), t[k])?;
                    if k > 0 && t[k] <= t[k - 1] {
                        return Err(spec_err(
                            &format!("{b}.times_s[{k}]"),
                            format!(
                                "sample times must increase strictly, got {} after {}",
                                t[k],
                                t[k - 1]
                            ),
                        ));
                    }
                }
                let (first, last) = (t[0], t[t.len() - 1]);
                if first > 0.0 || last < duration_s {
                    return Err(spec_err(
                        &format!("{b}.times_s"),
                        format!(
                            "must cover the run [0, duration_s = {duration_s:e}] s: the recording spans [{first:e}, {last:e}] s, and a drive is never extrapolated"
                        ),
                    ));
                }
                let shortest = t.windows(2).map(|w| w[1] - w[0]).fold(f64::MAX, f64::min);
                (
                    Shape::Spline {
                        m: natural_spline(t, y),
                        t: t.clone(),
                        y: y.clone(),
                    },
                    0.0,
                    None,
                    y.iter().fold(0.0f64, |a, v| a.max(v.abs())),
                    0.5 / shortest,
                )
            }
        };
        let mut kinks = Vec::new();
        if ramp_s > 0.0 {
            kinks.push(ramp_s);
        }
        if let Shape::Chirp { duration, .. } = &shape {
            kinks.push(*duration);
        }
        let peak_rate = match &shape {
            Shape::Tones(tones) => tones.iter().map(|(a, w, _)| (a * w).abs()).sum(),
            Shape::Chirp {
                amplitude, w0, w1, ..
            } => (amplitude * w0.max(*w1)).abs(),
            Shape::Spline { t, y, .. } => t
                .windows(2)
                .zip(y.windows(2))
                .map(|(t, y)| ((y[1] - y[0]) / (t[1] - t[0])).abs())
                .fold(0.0, f64::max),
        };
        Ok(Signal {
            shape,
            ramp_s,
            kinks,
            steady_hz,
            peak,
            peak_rate,
            highest_hz,
        })
    }
}

/// Second derivatives of the natural cubic spline through `(t, y)` (zero at both ends), by the
/// tridiagonal (Thomas) solve.
fn natural_spline(t: &[f64], y: &[f64]) -> Vec<f64> {
    let n = t.len();
    let mut m = vec![0.0; n];
    if n < 3 {
        return m;
    }
    // Interior equations: h₀ m₀ + 2(h₀+h₁) m₁ + h₁ m₂ = 6 (Δ₁ − Δ₀), with m at both ends zero.
    let mut c = vec![0.0; n];
    let mut d = vec![0.0; n];
    for i in 1..n - 1 {
        let (h0, h1) = (t[i] - t[i - 1], t[i + 1] - t[i]);
        let rhs = 6.0 * ((y[i + 1] - y[i]) / h1 - (y[i] - y[i - 1]) / h0);
        let diag = 2.0 * (h0 + h1) - h0 * c[i - 1];
        c[i] = h1 / diag;
        d[i] = (rhs - h0 * d[i - 1]) / diag;
    }
    for i in (1..n - 1).rev() {
        m[i] = d[i] - c[i] * m[i + 1];
    }
    m
}

impl Signal {
    /// Value, first and second time derivatives at `t`.
    #[inline]
    pub fn eval(&self, t: f64) -> (f64, f64, f64) {
        let (u, du, ddu) = self.shape_eval(t);
        if t >= self.ramp_s {
            return (u, du, ddu);
        }
        // r(t) = (1 − cos(π t / T))/2, and the product rule.
        let k = std::f64::consts::PI / self.ramp_s;
        let (s, c) = (k * t).sin_cos();
        let (r, dr, ddr) = (0.5 * (1.0 - c), 0.5 * k * s, 0.5 * k * k * c);
        (r * u, dr * u + r * du, ddr * u + 2.0 * dr * du + r * ddu)
    }

    /// Value at `t`.
    #[inline]
    pub fn value(&self, t: f64) -> f64 {
        self.eval(t).0
    }

    fn shape_eval(&self, t: f64) -> (f64, f64, f64) {
        match &self.shape {
            Shape::Tones(tones) => {
                let (mut u, mut du, mut ddu) = (0.0, 0.0, 0.0);
                for &(a, w, phase) in tones {
                    let (s, c) = (w * t + phase).sin_cos();
                    u += a * s;
                    du += a * w * c;
                    ddu -= a * w * w * s;
                }
                (u, du, ddu)
            }
            &Shape::Chirp {
                amplitude,
                w0,
                w1,
                duration,
                logarithmic,
            } => {
                // Phase θ, its rate ω = θ' and ω' over the sweep; past it, ω = ω₁ held.
                let ts = t.min(duration);
                let (theta_s, w, dw) = if logarithmic && w1 != w0 {
                    let k = (w1 / w0).ln() / duration;
                    let w = w0 * (k * ts).exp();
                    ((w - w0) / k, w, k * w)
                } else {
                    let rate = (w1 - w0) / duration;
                    (w0 * ts + 0.5 * rate * ts * ts, w0 + rate * ts, rate)
                };
                let (theta, dw) = if t > duration {
                    (theta_s + w1 * (t - duration), 0.0)
                } else {
                    (theta_s, dw)
                };
                let w = if t > duration { w1 } else { w };
                let (s, c) = theta.sin_cos();
                (
                    amplitude * s,
                    amplitude * w * c,
                    amplitude * (dw * c - w * w * s),
                )
            }
            Shape::Spline { t: knots, y, m } => {
                let n = knots.len();
                // Interval [t_i, t_{i+1}] holding t (the run lies within the knots).
                let i = knots.partition_point(|&k| k <= t).clamp(1, n - 1) - 1;
                let h = knots[i + 1] - knots[i];
                let (a, b) = ((knots[i + 1] - t) / h, (t - knots[i]) / h);
                let u = a * y[i]
                    + b * y[i + 1]
                    + ((a * a * a - a) * m[i] + (b * b * b - b) * m[i + 1]) * h * h / 6.0;
                let du = (y[i + 1] - y[i]) / h
                    + ((1.0 - 3.0 * a * a) * m[i] + (3.0 * b * b - 1.0) * m[i + 1]) * h / 6.0;
                let ddu = a * m[i] + b * m[i + 1];
                (u, du, ddu)
            }
        }
    }

    /// The frequency a steady response settles at, Hz: a single harmonic's; `None` for a chirp, a
    /// sum or a recording.
    pub fn steady_frequency_hz(&self) -> Option<f64> {
        self.steady_hz
    }

    /// Largest value the waveform reaches (an upper bound for a sum: its amplitudes' sum).
    pub fn peak(&self) -> f64 {
        self.peak
    }

    /// Largest rate of the waveform, its unit per second (an upper bound for a sum; a
    /// recording's steepest slope between samples).
    pub fn peak_rate(&self) -> f64 {
        self.peak_rate
    }

    /// Highest frequency in the waveform, Hz (a recording's: half its finest sampling rate).
    pub fn highest_frequency_hz(&self) -> f64 {
        self.highest_hz
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn compile(w: Waveform) -> Signal {
        w.compile("excitation.drive.force_n", 1.0).unwrap()
    }

    /// Each waveform's derivatives against central differences of its value and velocity.
    #[test]
    fn derivatives_match_differences() {
        let waves = [
            Waveform::Harmonic(Harmonic {
                amplitude: 2.0,
                frequency_hz: 3.0,
                phase_rad: 0.3,
                ramp_periods: 1.5,
            }),
            Waveform::Chirp(Chirp {
                amplitude: 1.0,
                start_hz: 1.0,
                end_hz: 5.0,
                duration_s: 0.6,
                spacing: ChirpSpacing::Linear,
                ramp_periods: 0.2,
            }),
            Waveform::Chirp(Chirp {
                amplitude: 1.0,
                start_hz: 1.0,
                end_hz: 5.0,
                duration_s: 0.6,
                spacing: ChirpSpacing::Logarithmic,
                ramp_periods: 0.0,
            }),
            Waveform::Sum(SumOfHarmonics {
                tones: vec![
                    Tone {
                        amplitude: 1.0,
                        frequency_hz: 2.0,
                        phase_rad: 0.0,
                    },
                    Tone {
                        amplitude: 0.5,
                        frequency_hz: 7.0,
                        phase_rad: 1.0,
                    },
                ],
                ramp_periods: 0.5,
            }),
            Waveform::Recorded(Recorded {
                times_s: (0..=40).map(|k| k as f64 / 39.0).collect(),
                values: (0..=40).map(|k| (k as f64 * 0.3).sin()).collect(),
                ..Recorded::default()
            }),
        ];
        for w in waves {
            let s = compile(w.clone());
            let h = 1e-6;
            for &t in &[0.05, 0.23, 0.41, 0.77, 0.93] {
                let (_, du, ddu) = s.eval(t);
                let fd = (s.eval(t + h).0 - s.eval(t - h).0) / (2.0 * h);
                let fdd = (s.eval(t + h).1 - s.eval(t - h).1) / (2.0 * h);
                assert!(
                    (du - fd).abs() < 1e-6 * (1.0 + du.abs()),
                    "{w:?} at {t}: {du} {fd}"
                );
                assert!(
                    (ddu - fdd).abs() < 1e-5 * (1.0 + ddu.abs()),
                    "{w:?} at {t}: {ddu} {fdd}"
                );
            }
        }
    }

    /// A chirp's instantaneous frequency is `f₀ + (f₁ − f₀) t/T` (linear) or `f₀ (f₁/f₀)^{t/T}`
    /// (logarithmic), and it holds `f₁` after the sweep, its phase continuous.
    #[test]
    fn chirp_frequency_follows_its_law() {
        for (spacing, mid) in [
            (ChirpSpacing::Linear, 3.0),
            (ChirpSpacing::Logarithmic, 5f64.sqrt()),
        ] {
            let s = compile(Waveform::Chirp(Chirp {
                amplitude: 1.0,
                start_hz: 1.0,
                end_hz: 5.0,
                duration_s: 0.5,
                spacing,
                ramp_periods: 0.0,
            }));
            let w_at = |t: f64| {
                // u = sin θ, u' = ω cos θ (A = 1): ω = |u'| / √(1 − u²).
                let (u, du, _) = s.eval(t);
                (du * du / (1.0 - u * u).max(1e-12)).sqrt()
            };
            let f_mid = w_at(0.25) / std::f64::consts::TAU;
            assert!((f_mid - mid).abs() < 1e-9 * mid, "{spacing:?}: {f_mid}");
            let after = w_at(0.7) / std::f64::consts::TAU;
            assert!((after - 5.0).abs() < 1e-9, "{spacing:?}: {after}");
        }
    }

    /// The natural spline reproduces a cubic's values between knots only approximately, but a
    /// straight line exactly, and it passes through every sample.
    #[test]
    fn spline_interpolates() {
        let t: Vec<f64> = (0..11).map(|k| k as f64 * 0.1).collect();
        let line: Vec<f64> = t.iter().map(|t| 2.0 * t - 0.5).collect();
        let s = compile(Waveform::Recorded(Recorded {
            times_s: t.clone(),
            values: line,
            ..Recorded::default()
        }));
        for &x in &[0.0, 0.13, 0.5, 0.999, 1.0] {
            let (u, du, ddu) = s.eval(x);
            assert!((u - (2.0 * x - 0.5)).abs() < 1e-14);
            assert!((du - 2.0).abs() < 1e-12 && ddu.abs() < 1e-12);
        }
        let y: Vec<f64> = t.iter().map(|t| (3.0 * t).sin()).collect();
        let s = compile(Waveform::Recorded(Recorded {
            times_s: t.clone(),
            values: y.clone(),
            ..Recorded::default()
        }));
        for (ti, yi) in t.iter().zip(&y) {
            assert!((s.value(*ti) - yi).abs() < 1e-14);
        }
        assert!((s.value(0.55) - (1.65f64).sin()).abs() < 1e-3);
    }

    /// Bad values name their field.
    #[test]
    fn bad_waveforms_name_the_field() {
        let bad = |w: Waveform, field: &str| {
            let e = w.compile("excitation.drive.actuator_m", 1.0).unwrap_err();
            assert_eq!(e.field, field, "{e}");
        };
        bad(
            Waveform::Harmonic(Harmonic {
                amplitude: 1.0,
                frequency_hz: -3.0,
                phase_rad: 0.0,
                ramp_periods: 0.0,
            }),
            "excitation.drive.actuator_m.harmonic.frequency_hz",
        );
        bad(
            Waveform::Recorded(Recorded {
                times_s: vec![0.0, 0.5, 0.5, 1.0],
                values: vec![0.0; 4],
                ..Recorded::default()
            }),
            "excitation.drive.actuator_m.recorded.times_s[2]",
        );
        bad(
            Waveform::Recorded(Recorded {
                times_s: vec![0.0, 0.5],
                values: vec![0.0; 2],
                ..Recorded::default()
            }),
            "excitation.drive.actuator_m.recorded.times_s",
        );
        bad(
            Waveform::Sum(SumOfHarmonics {
                tones: vec![],
                ramp_periods: 0.0,
            }),
            "excitation.drive.actuator_m.sum.tones",
        );
    }
}
