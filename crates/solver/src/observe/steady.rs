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
    /// Largest settledness (the change of the fundamental between the window's halves, relative
    /// to the signal's amplitude) for which a probe is called settled (> 0, default 1e-3).
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
                "record.steady_state: not settled (settledness above {tolerance:e}) at {}: the window's halves differ; settle longer (settle_periods) or check the frequency",
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
    /// Samples in each half compared by the settledness (`⌊P/2⌋` periods).
    half: u64,
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
    /// Per probe: the fundamental's Σ y cos, Σ y sin over the first and the last half.
    halves: Vec<[f64; 4]>,
    reference: usize,
    tolerance: f64,
}

impl SteadyRecorder {
    /// A recorder of `probes` probes for `spec` at `frequency_hz` (validated).
    pub fn new(spec: &SteadyStateSpec, frequency_hz: f64, probes: usize) -> Self {
        let per_period = u64::from(spec.samples_per_period);
        let h = spec.harmonics as usize;
        SteadyRecorder {
            frequency: frequency_hz,
            harmonics: h,
            total: spec.window_periods * per_period,
            half: spec.window_periods / 2 * per_period,
            start_s: spec.settle_periods as f64 / frequency_hz,
            interval_s: 1.0 / (frequency_hz * per_period as f64),
            next: 0,
            taken: 0,
            sums: vec![[0.0; 3]; probes],
            fourier: vec![[0.0; 2]; probes * h],
            halves: vec![[0.0; 4]; probes],
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
        let first = j < self.half;
        let last = j >= self.total - self.half;
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
            for k in 0..h {
                let turns = ((k + 1) as f64 * ft).fract();
                let (s, c) = (std::f64::consts::TAU * turns).sin_cos();
                let acc = &mut self.fourier[p * h + k];
                acc[0] += y * c;
                acc[1] += y * s;
                if k == 0 {
                    let half = &mut self.halves[p];
                    if first {
                        half[0] += y * c;
                        half[1] += y * s;
                    }
                    if last {
                        half[2] += y * c;
                        half[3] += y * s;
                    }
                }
            }
        }
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
                let half = self.half as f64;
                let q = &self.halves[p];
                let change = (2.0 * (q[2] - q[0]) / half).hypot(2.0 * (q[3] - q[1]) / half);
                // The signal's amplitude: √2 σ is the amplitude of a sinusoid of its variance.
                let scale = (2.0 * variance).sqrt();
                let settledness = if change == 0.0 { 0.0 } else { change / scale };
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
