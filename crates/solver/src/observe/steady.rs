//! Steady-state and spectral observables of each probe (`record.steady_state`): over a window of
//! whole periods of a frequency `f` after a settling time, each probe's mean, RMS, and the
//! amplitude and phase of its harmonics `f, 2f, …, kf`, with a measure of how settled the response
//! is and the transmission of every probe against a reference probe.
//!
//! The window is sampled at `samples_per_period` instants per period through the integrator's
//! dense output, exactly as the probes' summaries are ([`super::probes`]), never from stored
//! coarse samples. Over whole periods the discrete Fourier sums are exact for a signal whose
//! harmonics lie below half the sampling rate: for `y = m + Σ A_k cos(2π k f t + φ_k)`, `K`
//! samples per period over `P` periods give back `m`, `A_k` and `φ_k` to rounding.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use super::grid_instant;
use crate::chain::model::{spec_err, SpecError};

/// Most samples of the window per run (`window_periods × samples_per_period`): as many as the
/// summaries may take ([`super::probes::MAX_SUMMARY_SAMPLES_PER_RUN`]), so that no window makes a
/// run sample for hours. Nothing is allocated per sample: the sums are accumulated as it goes.
pub const MAX_STEADY_SAMPLES_PER_RUN: u64 = super::probes::MAX_SUMMARY_SAMPLES_PER_RUN;

/// Most harmonics per probe.
pub const MAX_HARMONICS: u32 = 64;

/// Most samples per period.
pub const MAX_SAMPLES_PER_PERIOD: u32 = 4096;

/// The record option: which window of which frequency to analyse.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SteadyStateSpec {
    /// Frequency analysed, Hz (> 0). Absent: the frequency of the scene's drive; a scene without
    /// one (a striker, an impulse, a half-sine pulse, an initial state) must give it here.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub frequency_hz: Option<f64>,
    /// Whole periods skipped from the start before the window (default 0).
    #[cfg_attr(feature = "serde", serde(default))]
    pub settle_periods: u64,
    /// Whole periods analysed (at least 2: the settledness compares the window's two halves).
    pub window_periods: u64,
    /// Harmonics analysed: the amplitude and phase at `f, 2f, …, harmonics·f` (1 to 64, default
    /// 3).
    #[cfg_attr(feature = "serde", serde(default = "default_harmonics"))]
    pub harmonics: u32,
    /// Instants sampled per period (more than twice `harmonics`, at most 4096; default 64): the
    /// sums are exact for harmonics below half of it.
    #[cfg_attr(feature = "serde", serde(default = "default_samples_per_period"))]
    pub samples_per_period: u32,
    /// Largest settledness (how far the fundamental over the window may be from where it
    /// settles, and how far the signal is from periodic at the drive's period, relative to the
    /// signal's amplitude) for which a probe is called settled (> 0, default 1e-3).
    #[cfg_attr(feature = "serde", serde(default = "default_settled_tolerance"))]
    pub settled_tolerance: f64,
    /// The probe (its index in `record.probes`, from 0) against whose fundamental every probe's
    /// transmission is given, in dB (default 0).
    #[cfg_attr(feature = "serde", serde(default))]
    pub reference_probe: usize,
}

#[cfg(feature = "serde")]
fn default_harmonics() -> u32 {
    3
}
#[cfg(feature = "serde")]
fn default_samples_per_period() -> u32 {
    64
}
#[cfg(feature = "serde")]
fn default_settled_tolerance() -> f64 {
    1e-3
}

impl SteadyStateSpec {
    /// A window of `window_periods` periods of `frequency_hz` after `settle_periods`, with the
    /// defaults of a sweep file (3 harmonics, 64 samples per period, tolerance 1e-3, reference
    /// probe 0).
    pub fn new(frequency_hz: Option<f64>, settle_periods: u64, window_periods: u64) -> Self {
        SteadyStateSpec {
            frequency_hz,
            settle_periods,
            window_periods,
            harmonics: 3,
            samples_per_period: 64,
            settled_tolerance: 1e-3,
            reference_probe: 0,
        }
    }

    /// Checks the option against the run: `probes` probes, `duration_s`, and the scene's drive
    /// frequency `drive_hz`; returns the frequency analysed. Errors name the field.
    pub fn validate(
        &self,
        probes: usize,
        duration_s: f64,
        drive_hz: Option<f64>,
    ) -> Result<f64, SpecError> {
        let f = match (self.frequency_hz, drive_hz) {
            (Some(f), _) => {
                if !(f.is_finite() && f > 0.0) {
                    return Err(spec_err(
                        "record.steady_state.frequency_hz",
                        format!("must be a finite number > 0, got {f}"),
                    ));
                }
                f
            }
            (None, Some(f)) => f,
            (None, None) => {
                return Err(spec_err(
                    "record.steady_state.frequency_hz",
                    "required: the scene has no drive frequency (a finite number > 0, Hz)",
                ))
            }
        };
        if probes == 0 {
            return Err(spec_err(
                "record.probes",
                "record.steady_state analyses the probes: give at least one",
            ));
        }
        if self.window_periods < 2 {
            return Err(spec_err(
                "record.steady_state.window_periods",
                format!(
                    "must be at least 2 (the settledness compares the window's halves), got {}",
                    self.window_periods
                ),
            ));
        }
        let h = self.harmonics;
        if !(1..=MAX_HARMONICS).contains(&h) {
            return Err(spec_err(
                "record.steady_state.harmonics",
                format!("must be from 1 to {MAX_HARMONICS}, got {h}"),
            ));
        }
        let m = self.samples_per_period;
        if m <= 2 * h || m > MAX_SAMPLES_PER_PERIOD {
            return Err(spec_err(
                "record.steady_state.samples_per_period",
                format!(
                    "must be from {} (more than twice harmonics = {h}) to {MAX_SAMPLES_PER_PERIOD}, got {m}",
                    2 * h + 1
                ),
            ));
        }
        let tol = self.settled_tolerance;
        if !(tol.is_finite() && tol > 0.0) {
            return Err(spec_err(
                "record.steady_state.settled_tolerance",
                format!("must be a finite number > 0, got {tol}"),
            ));
        }
        if self.reference_probe >= probes {
            return Err(spec_err(
                "record.steady_state.reference_probe",
                format!(
                    "must be from 0 to {} (an index into record.probes), got {}",
                    probes - 1,
                    self.reference_probe
                ),
            ));
        }
        let samples = self.window_periods.saturating_mul(u64::from(m));
        if samples > MAX_STEADY_SAMPLES_PER_RUN {
            return Err(spec_err(
                "record.steady_state.window_periods",
                format!(
                    "window_periods × samples_per_period must be at most {MAX_STEADY_SAMPLES_PER_RUN}, got {} × {m}",
                    self.window_periods
                ),
            ));
        }
        // The window must end within the run; a relative 1e-12 lets a duration written as
        // exactly the periods' length pass its own rounding.
        let periods = self.settle_periods as f64 + self.window_periods as f64;
        let fits = duration_s * f;
        if periods > fits * (1.0 + 1e-12) {
            return Err(spec_err(
                "record.steady_state.window_periods",
                format!(
                    "settle_periods + window_periods = {periods} periods of {f} Hz must fit in duration_s = {duration_s} s ({fits} periods)"
                ),
            ));
        }
        Ok(f)
    }
}

/// One probe's steady state.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
pub struct SteadyProbe {
    /// Mean over the window, in the probe's unit.
    pub mean: f64,
    /// Root mean square over the window (the mean included), in the probe's unit.
    pub rms: f64,
    /// Amplitude `A_k` at `k f`, `k = 1, …, harmonics`, in the probe's unit.
    pub amplitude: Vec<f64>,
    /// Phase `φ_k` at `k f`, rad in (−π, π], of `A_k cos(2π k f t + φ_k)` with `t` from the run's
    /// start.
    pub phase_rad: Vec<f64>,
    /// The change of the fundamental's complex amplitude between the window's first and last
    /// `⌊P/2⌋` periods, relative to the signal's amplitude `√2 σ` (σ its standard deviation over
    /// the window); 0 for a constant signal.
    pub settledness: f64,
    /// Whether `settledness ≤ settled_tolerance`.
    pub settled: bool,
    /// `20 log10(A_1 / A_1 of the reference probe)`, dB.
    pub transmission_db: f64,
}

/// A run's steady state (`record.steady_state`).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
pub struct SteadyState {
    /// Frequency analysed, Hz.
    pub frequency_hz: f64,
    /// One per probe, in the record block's order.
    pub probes: Vec<SteadyProbe>,
}

impl SteadyState {
    /// The run's warning when a probe has not settled (`None` when every probe has).
    pub fn warning(&self, probe_names: &[String], tolerance: f64) -> Option<String> {
        let unsettled: Vec<String> = self
            .probes
            .iter()
            .zip(probe_names)
            .filter(|(p, _)| !p.settled)
            .map(|(p, name)| format!("{name} ({:.3e})", p.settledness))
            .collect();
        (!unsettled.is_empty()).then(|| {
            format!(
                "record.steady_state: not settled (settledness above {tolerance:e}) at {}: the fundamental is still changing over the window, or the response is not periodic at the drive's period; settle longer (settle_periods) or check the frequency",
                unsettled.join(", ")
            )
        })
    }
}

/// Accumulates the window's sums, one sample of every probe at a time.
#[derive(Debug, Clone)]
pub(crate) struct SteadyRecorder {
    frequency: f64,
    harmonics: usize,
    /// Samples in the window.
    total: u64,
    /// Samples per drive period.
    per_period: u64,
    /// Samples in each of the segments at the window's end whose fundamentals the settledness
    /// compares: three of `⌊P/3⌋` periods (two of one period when `P` is 2).
    segment: u64,
    /// Those segments: 3, or 2 when the window holds 2 periods.
    segments: u64,
    /// The window's first instant, s.
    pub start_s: f64,
    /// Interval between instants, s.
    pub interval_s: f64,
    /// The next sample's index in the window.
    pub next: u64,
    /// Samples taken.
    taken: u64,
    /// Per probe: its first sample `c`, then Σ(y − c), Σ(y − c)²: shifted by the first value so
    /// that a small oscillation about a large mean (a preloaded contact) keeps its variance's
    /// digits.
    sums: Vec<[f64; 3]>,
    /// Per probe and harmonic: Σ y cos, Σ y sin.
    fourier: Vec<[f64; 2]>,
    /// Per probe and segment: the fundamental's Σ y cos, Σ y sin.
    parts: Vec<[[f64; 2]; 3]>,
    /// Per probe, the last period's samples (a ring), to compare each sample with the one a
    /// period before it.
    ring: Vec<f64>,
    /// Per probe: Σ (y_j − y_{j−per_period})² over the window after its first period.
    period_change: Vec<f64>,
    reference: usize,
    tolerance: f64,
}

impl SteadyRecorder {
    /// A recorder of `probes` probes for `spec` at `frequency_hz` (validated).
    pub fn new(spec: &SteadyStateSpec, frequency_hz: f64, probes: usize) -> Self {
        let per_period = u64::from(spec.samples_per_period);
        let h = spec.harmonics as usize;
        let segments = if spec.window_periods >= 3 { 3 } else { 2 };
        SteadyRecorder {
            frequency: frequency_hz,
            harmonics: h,
            total: spec.window_periods * per_period,
            per_period,
            segment: (spec.window_periods / segments) * per_period,
            segments,
            start_s: spec.settle_periods as f64 / frequency_hz,
            interval_s: 1.0 / (frequency_hz * per_period as f64),
            next: 0,
            taken: 0,
            sums: vec![[0.0; 3]; probes],
            fourier: vec![[0.0; 2]; probes * h],
            parts: vec![[[0.0; 2]; 3]; probes],
            ring: vec![0.0; probes * per_period as usize],
            period_change: vec![0.0; probes],
            reference: spec.reference_probe,
            tolerance: spec.settled_tolerance,
        }
    }

    /// The window's last instant, s, computed as the sampling loop computes its instants.
    pub fn last_instant_s(&self) -> f64 {
        grid_instant(self.start_s, self.total - 1, self.interval_s)
    }

    /// Whether every instant of the window has been sampled.
    pub fn complete(&self) -> bool {
        self.taken >= self.total
    }

    /// Takes the sample of index `j` in the window at time `t`, probe `k`'s value `value(k)`.
    #[inline]
    pub fn sample(&mut self, j: u64, t: f64, value: impl Fn(usize) -> f64) {
        if j >= self.total {
            return;
        }
        let start = self.taken == 0;
        self.taken += 1;
        // The segment at the window's end the sample lies in, if any.
        let from_end = self.total - j;
        let part = (from_end <= self.segments * self.segment)
            .then(|| (self.segments - from_end.div_ceil(self.segment)) as usize);
        let pp = self.per_period as usize;
        let phase = (j % self.per_period) as usize;
        // The phase of harmonic k at t, reduced to one turn before the sine so that a long run
        // loses no digits: ft = frac(f t).
        let ft = self.frequency * t;
        let h = self.harmonics;
        for (p, sums) in self.sums.iter_mut().enumerate() {
            let y = value(p);
            if start {
                sums[0] = y;
            }
            let d = y - sums[0];
            sums[1] += d;
            sums[2] += d * d;
            let before = &mut self.ring[p * pp + phase];
            if j >= self.per_period {
                let change = y - *before;
                self.period_change[p] += change * change;
            }
            *before = y;
            for k in 0..h {
                let turns = ((k + 1) as f64 * ft).fract();
                let (s, c) = (std::f64::consts::TAU * turns).sin_cos();
                let acc = &mut self.fourier[p * h + k];
                acc[0] += y * c;
                acc[1] += y * s;
                if k == 0 {
                    if let Some(part) = part {
                        let z = &mut self.parts[p][part];
                        z[0] += y * c;
                        z[1] += y * s;
                    }
                }
            }
        }
    }

    /// How far probe `p`'s fundamental over the window may be from where it settles: its
    /// complex amplitude over the segments at the window's end, `Z₁, Z₂, Z₃`, taken as a
    /// transient decaying (or turning) by a factor `ρ = (Z₃ − Z₂)/(Z₂ − Z₁)` a segment, whose
    /// part in the window's average is `|Z₂ − Z₁| |1 + ρ + ρ²| / (3 |1 − ρ|)` — large where it
    /// barely decays (ρ near 1), which the change between two segments alone did not say (a
    /// resonance at ζ = 4e-4, 6 % off, changed by 8e-4). With two segments (a window of two
    /// periods) only their change, `|Z₂ − Z₁|`.
    fn transient_left(&self, p: usize) -> f64 {
        let n = self.segment as f64;
        let z: Vec<(f64, f64)> = self.parts[p]
            .iter()
            .map(|q| (2.0 * q[0] / n, -2.0 * q[1] / n))
            .collect();
        let diff = |a: (f64, f64), b: (f64, f64)| (b.0 - a.0, b.1 - a.1);
        let d1 = diff(z[0], z[1]);
        let d1_size = d1.0.hypot(d1.1);
        if self.segments < 3 {
            return d1_size;
        }
        let d2 = diff(z[1], z[2]);
        if d1_size == 0.0 {
            return d2.0.hypot(d2.1);
        }
        // ρ = d2 / d1, complex.
        let den = d1.0 * d1.0 + d1.1 * d1.1;
        let rho = (
            (d2.0 * d1.0 + d2.1 * d1.1) / den,
            (d2.1 * d1.0 - d2.0 * d1.1) / den,
        );
        let sum = (
            1.0 + rho.0 + rho.0 * rho.0 - rho.1 * rho.1,
            rho.1 + 2.0 * rho.0 * rho.1,
        );
        let gap = (1.0 - rho.0).hypot(rho.1).max(1e-9);
        d1_size * sum.0.hypot(sum.1) / (3.0 * gap)
    }

    /// How far probe `p`'s signal is from periodic at the drive's period: the RMS of each
    /// sample less the one a period before, `√2 |sin(π g/f)|` times the amplitude of a response
    /// at another frequency `g` (a second tone, a subharmonic), whose projection on the
    /// fundamental may vanish over the window's halves (g/f ⌊P/2⌋ whole).
    fn not_periodic(&self, p: usize) -> f64 {
        let compared = self.total.saturating_sub(self.per_period);
        if compared == 0 {
            return 0.0;
        }
        (self.period_change[p] / compared as f64).sqrt()
    }

    /// The results; NaN (and not settled) where the window was not sampled whole (a run that
    /// ended before it).
    pub fn finish(&self) -> SteadyState {
        let h = self.harmonics;
        let complete = self.complete();
        let n = self.total as f64;
        let mut probes: Vec<SteadyProbe> = (0..self.sums.len())
            .map(|p| {
                if !complete {
                    return SteadyProbe {
                        mean: f64::NAN,
                        rms: f64::NAN,
                        amplitude: vec![f64::NAN; h],
                        phase_rad: vec![f64::NAN; h],
                        settledness: f64::NAN,
                        settled: false,
                        transmission_db: f64::NAN,
                    };
                }
                let [c, s1, s2] = self.sums[p];
                let variance = (s2 / n - (s1 / n) * (s1 / n)).max(0.0);
                let mean = c + s1 / n;
                let rms = (variance + mean * mean).sqrt();
                let (mut amplitude, mut phase_rad) = (Vec::with_capacity(h), Vec::with_capacity(h));
                for k in 0..h {
                    // y = A cos(ωt + φ) = A cos φ cos ωt − A sin φ sin ωt.
                    let a = 2.0 * self.fourier[p * h + k][0] / n;
                    let b = 2.0 * self.fourier[p * h + k][1] / n;
                    amplitude.push(a.hypot(b));
                    phase_rad.push((-b).atan2(a));
                }
                // The signal's amplitude: √2 σ is the amplitude of a sinusoid of its variance.
                let scale = (2.0 * variance).sqrt();
                let unsettled = self.transient_left(p).max(self.not_periodic(p));
                let settledness = if unsettled == 0.0 {
                    0.0
                } else {
                    unsettled / scale
                };
                SteadyProbe {
                    mean,
                    rms,
                    amplitude,
                    phase_rad,
                    settledness,
                    settled: settledness <= self.tolerance,
                    transmission_db: f64::NAN,
                }
            })
            .collect();
        if let Some(reference) = probes.get(self.reference).map(|p| p.amplitude[0]) {
            for p in &mut probes {
                p.transmission_db = 20.0 * (p.amplitude[0] / reference).log10();
            }
        }
        SteadyState {
            frequency_hz: self.frequency,
            probes,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The steady state of `y(t)` sampled over a window of `window` periods of 1 Hz after
    /// `settle` periods, as a run samples it.
    fn analyse(settle: u64, window: u64, y: impl Fn(f64) -> f64) -> SteadyProbe {
        let spec = SteadyStateSpec::new(Some(1.0), settle, window);
        let mut r = SteadyRecorder::new(&spec, 1.0, 1);
        for j in 0..r.total {
            let t = grid_instant(r.start_s, j, r.interval_s);
            r.sample(j, t, |_| y(t));
        }
        r.finish().probes.remove(0)
    }

    #[test]
    fn a_settled_sinusoid_with_harmonics_is_settled_and_exact() {
        let tau = std::f64::consts::TAU;
        let p = analyse(50, 10, |t| {
            2.0 + 1.5 * (tau * t + 0.3).cos() + 0.2 * (2.0 * tau * t).cos()
        });
        assert!(p.settled && p.settledness < 1e-12, "{}", p.settledness);
        assert!((p.amplitude[0] - 1.5).abs() < 1e-12 && (p.phase_rad[0] - 0.3).abs() < 1e-12);
    }

    #[test]
    fn a_transient_that_barely_decays_is_not_settled() {
        // A resonance's transient decaying over 300 periods: the window's fundamental is 4 %
        // off, and changes by only 3e-4 of it over the window's halves (settled by that test).
        let tau = std::f64::consts::TAU;
        let p = analyse(1000, 10, |t| (1.0 - (-t / 300.0).exp()) * (tau * t).cos());
        let error = (p.amplitude[0] - 1.0).abs();
        assert!(error > 0.03, "{error}");
        assert!(
            !p.settled && p.settledness > error / 3.0,
            "{} {error}",
            p.settledness
        );
    }

    #[test]
    fn a_response_at_another_frequency_is_not_settled() {
        // 1.1 Hz analysed at 1 Hz over 20 periods: its projection on 1 Hz is the same over both
        // halves (1.1 × 10 periods is whole), but it is not periodic at 1 Hz.
        let tau = std::f64::consts::TAU;
        for (g, window) in [(1.1, 20), (0.5, 4), (1.5, 10)] {
            let p = analyse(10, window, |t| (tau * g * t).cos());
            assert!(!p.settled && p.settledness > 0.1, "{g}: {}", p.settledness);
        }
        // A second tone beside the drive's.
        let p = analyse(10, 10, |t| (tau * t).cos() + 0.5 * (tau * 1.2 * t).cos());
        assert!(!p.settled, "{}", p.settledness);
    }
}
