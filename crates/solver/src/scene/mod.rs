//! A scene — chain, physics, impact, integrator and record block: a whole simulation as written,
//! and the scales of its excitation. Running one is [`solve`]; long chains are integrated only where they move ([`active`]).
//!
//! The scene itself ([`Scene`]) and its checks are here; what it is made of that stands on its own
//! has a file: `integrator` (the integrator spec and the one list of methods), `excitation` (how a
//! chain without a striker is set in motion) and `scales` (the natural scales of an excitation,
//! which tolerances and warnings are measured against).

pub mod active;
mod excitation;
mod integrator;
mod scales;
pub mod solve;

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::chain::model::{spec_err, Chain, ChainSpec, PhysicsSpec, SpecError};
use crate::observe::probes::RecordSpec;

pub use excitation::{Excitation, InitialState, ParticleStart, RandomVelocity};
pub(crate) use integrator::MethodVisitor;
pub use integrator::{IntegratorSpec, Method};
pub use scales::ImpactScales;

pub use crate::observe::probes::{
    max_history_samples, DEADLINE_CHECK_STEPS, MAX_HISTORY_SAMPLES_PER_RUN,
    MAX_HISTORY_VALUES_PER_RUN, MAX_SUMMARY_SAMPLES_PER_RUN,
};

/// One simulation: everything needed to reproduce a run.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Scene {
    /// Geometry and materials.
    pub chain: ChainSpec,
    /// Physics switches.
    pub physics: PhysicsSpec,
    /// Striker velocity towards the wall at impact, m/s: required when the chain has a striker
    /// (the paper's chain always has), absent otherwise.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub striker_velocity_m_s: Option<f64>,
    /// How a chain without a striker is set in motion (absent for a chain with one).
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub excitation: Option<Excitation>,
    /// Simulated time after impact, s.
    pub duration_s: f64,
    /// Integrator.
    #[cfg_attr(feature = "serde", serde(default))]
    pub integrator: IntegratorSpec,
    /// Largest number of step attempts, accepted and rejected, before the run is abandoned.
    #[cfg_attr(feature = "serde", serde(default = "default_max_steps"))]
    pub max_steps: u64,
    /// What to record.
    #[cfg_attr(feature = "serde", serde(default))]
    pub record: RecordSpec,
    /// Whether a long chain may integrate only its moving part ([`crate::scene::active`]); `auto` (the
    /// default, left out of the serialised scene so that run hashes stay as they were) or `off`.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "ActiveRegion::is_auto")
    )]
    pub active_region: ActiveRegion,
    /// Continuation along an axis of a sweep ([`Continuation`]): set by the sweep runner, never
    /// written in a sweep file nor serialised (the run's identity carries its predecessors').
    #[cfg_attr(feature = "serde", serde(skip))]
    #[cfg_attr(feature = "schema", schemars(skip))]
    pub continuation: Option<Continuation>,
}

/// A run on a continuation axis: it returns its final state ([`RunOutput::final_state`]), and
/// starts from `start_state`, the final state of the point before it on the axis
/// ([`Scene::continued_state`]), instead of its excitation's (`None`: the axis's first point).
///
/// [`RunOutput::final_state`]: crate::scene::solve::RunOutput::final_state
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Continuation {
    /// The state to start from.
    pub start_state: Option<Vec<f64>>,
}

/// Whether a run may integrate only the moving part of its chain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum ActiveRegion {
    /// Integrate only the moving part when the scene qualifies (see the module docs), else the
    /// whole chain.
    #[default]
    Auto,
    /// Always integrate the whole chain.
    Off,
}

impl ActiveRegion {
    /// Whether this is the default, [`ActiveRegion::Auto`] (which sweep files and run hashes leave
    /// out).
    pub fn is_auto(&self) -> bool {
        *self == ActiveRegion::Auto
    }
}

/// Largest overlap-to-radius ratio for which Hertz's law is taken as valid: the contact radius
/// `√(Rδ)` is then at most a tenth of the sphere's radius.
pub const MAX_HERTZ_OVERLAP_RATIO: f64 = 0.01;

/// Overlap-to-radius ratio of the two-body estimate beyond which a scene is called absurd before
/// it runs: ten times the limit of Hertz's law ([`MAX_HERTZ_OVERLAP_RATIO`]).
pub const ABSURD_OVERLAP_RATIO: f64 = 0.1;

/// Ratio of the contact time to an explicit method's damping-held stable step beyond which a
/// scene is called absurd before it runs: four orders of magnitude, ten thousand steps per
/// contact for stability alone.
pub const ABSURD_STIFFNESS_RATIO: f64 = 1e4;

/// Smallest ratio of the impact pulse duration to the longest sound transit time through a
/// particle for which the static Hertz law is taken as valid ("much longer", Sec. III).
pub const MIN_PULSE_TO_TRANSIT_RATIO: f64 = 10.0;

/// Default step budget: ample for any scene in the paper (a 1 ms run needs ~10⁴ adaptive steps).
pub const DEFAULT_MAX_STEPS: u64 = 100_000_000;

#[cfg(feature = "serde")]
fn default_max_steps() -> u64 {
    DEFAULT_MAX_STEPS
}

impl Scene {
    /// A scene with the paper's defaults: `chain` (which has a striker) struck at
    /// `striker_velocity_m_s`, gravity and wall on, no damping, DOP853 at rtol 1e-9, nothing
    /// recorded.
    pub fn new(chain: impl Into<ChainSpec>, striker_velocity_m_s: f64, duration_s: f64) -> Self {
        Scene {
            chain: chain.into(),
            physics: PhysicsSpec::default(),
            striker_velocity_m_s: Some(striker_velocity_m_s),
            excitation: None,
            duration_s,
            integrator: IntegratorSpec::default(),
            max_steps: DEFAULT_MAX_STEPS,
            record: RecordSpec::default(),
            active_region: ActiveRegion::Auto,
            continuation: None,
        }
    }

    /// A scene of a chain without a striker, set in motion by `excitation`; defaults as
    /// [`Scene::new`].
    pub fn excited(chain: impl Into<ChainSpec>, excitation: Excitation, duration_s: f64) -> Self {
        Scene {
            striker_velocity_m_s: None,
            excitation: Some(excitation),
            ..Scene::new(chain, 0.0, duration_s)
        }
    }

    /// A wall on a mount so stiff or so damped that an explicit method cannot cross the run in
    /// its step budget (its step is held below its period and below its dashpot's time
    /// `M/c`): refused naming the field, rather than run until its time limit.
    fn check_mount_steps(&self, chain: &Chain) -> Result<(), SpecError> {
        let Some(m) = chain.wall_mount else {
            return Ok(());
        };
        if matches!(self.integrator, IntegratorSpec::Ros34pw2(_)) {
            return Ok(());
        }
        // Explicit methods stay stable for steps up to about 3 / |λ|.
        let omega = (m.stiffness_n_m / m.mass_kg).sqrt();
        let rate = m.damping_kg_s / m.mass_kg;
        let steps = self.duration_s * omega.max(rate) / 3.0;
        if steps > self.max_steps as f64 {
            let (field, what) = if omega >= rate {
                (
                    "chain.wall_mount.stiffness_n_m",
                    format!(
                        "its natural frequency is {:.3e} Hz",
                        omega / std::f64::consts::TAU
                    ),
                )
            } else {
                (
                    "chain.wall_mount.damping_kg_s",
                    format!("its dashpot's rate c/M is {rate:.3e} /s"),
                )
            };
            return Err(spec_err(
                field,
                format!(
                    "the wall on its mount cannot be integrated: {what}, so a run of {} s takes at least {steps:.3e} steps, more than max_steps ({}); lower it, raise max_steps, or use ros34pw2",
                    self.duration_s, self.max_steps
                ),
            ));
        }
        Ok(())
    }

    /// Checks the whole scene before anything runs; the error names the field.
    pub fn validate(&self) -> Result<Chain, SpecError> {
        let mut chain = Chain::build(&self.chain, &self.physics)?;
        let positive = crate::spec::check_positive;
        match (chain.striker, self.striker_velocity_m_s, &self.excitation) {
            (true, Some(v0), None) => positive("striker_velocity_m_s", v0)?,
            (true, None, _) => {
                return Err(spec_err(
                    "striker_velocity_m_s",
                    "required: the chain has a striker",
                ))
            }
            (true, Some(_), Some(_)) => {
                return Err(spec_err(
                    "excitation",
                    "a chain with a striker is excited by the striker (striker_velocity_m_s); remove `excitation` or the chain's striker",
                ))
            }
            (false, Some(_), _) => {
                return Err(spec_err(
                    "striker_velocity_m_s",
                    "the chain has no striker (a sequence chain names one in chain.striker); excite it with `excitation` instead",
                ))
            }
            (false, None, None) => {
                return Err(spec_err(
                    "excitation",
                    "required for a chain without a striker: {\"impulse\": {\"velocity_m_s\": …}}, {\"half_sine_force\": {\"amplitude_n\": …, \"duration_s\": …}}, {\"initial_state\": {\"particles\": [{\"particle\": …, \"velocity_m_s\": …}]}} or {\"drive\": {\"force_n\" | \"actuator_m\" | \"base_m\": {\"harmonic\": {\"amplitude\": …, \"frequency_hz\": …}}}}",
                ))
            }
            (false, None, Some(Excitation::Impulse { velocity_m_s })) => {
                positive("excitation.impulse.velocity_m_s", *velocity_m_s)?
            }
            (false, None, Some(Excitation::InitialState(state))) => {
                state.validate(chain.n_particles())?
            }
            (false, None, Some(Excitation::Drive(drive))) => {
                let d = self.duration_s;
                if !(d.is_finite() && d > 0.0) {
                    return Err(spec_err(
                        "duration_s",
                        format!("must be a finite number > 0, got {d}"),
                    ));
                }
                chain = chain.with_drive(drive.validate(d)?)?;
            }
            (
                false,
                None,
                Some(Excitation::HalfSineForce {
                    amplitude_n,
                    duration_s,
                }),
            ) => {
                positive("excitation.half_sine_force.amplitude_n", *amplitude_n)?;
                positive("excitation.half_sine_force.duration_s", *duration_s)?;
                chain = chain.with_force_pulse(*amplitude_n, *duration_s);
            }
        }
        let d = self.duration_s;
        if !(d.is_finite() && d > 0.0) {
            return Err(spec_err(
                "duration_s",
                format!("must be a finite number > 0, got {d}"),
            ));
        }
        if self.max_steps == 0 {
            return Err(spec_err("max_steps", "must be at least 1"));
        }
        self.integrator.validate()?;
        self.check_mount_steps(&chain)?;
        self.record.validate(&chain)?;
        self.check_sample_counts()?;
        if let Some(fields) = &self.record.fields {
            fields.check_samples(&chain, self.duration_s)?;
        }
        self.steady_state_frequency_hz()?;
        Ok(chain)
    }

    /// The frequency `record.steady_state` analyses, Hz, its window checked against the run
    /// (`None` without the option); errors name the field.
    pub fn steady_state_frequency_hz(&self) -> Result<Option<f64>, SpecError> {
        let Some(spec) = &self.record.steady_state else {
            return Ok(None);
        };
        if self.record.stop_after_leading_pulses {
            return Err(spec_err(
                "record.stop_after_leading_pulses",
                "must be false with record.steady_state: the window needs the run to go on to its end",
            ));
        }
        spec.validate(
            self.record.probes.len(),
            self.duration_s,
            self.drive_frequency_hz(),
        )
        .map(Some)
    }

    /// The history and summary intervals against the duration: at most
    /// [`max_history_samples`] history samples per probe (when histories are recorded) and
    /// [`MAX_SUMMARY_SAMPLES_PER_RUN`] summary samples (when there are probes) per run, so that no
    /// interval can make a run allocate without bound or sample for hours.
    fn check_sample_counts(&self) -> Result<(), SpecError> {
        let r = &self.record;
        let bounds = [
            (
                "record.history_interval_s",
                r.history_interval_s,
                r.history && !r.probes.is_empty(),
                max_history_samples(r.probes.len()),
                format!("history samples per probe per run, and {MAX_HISTORY_VALUES_PER_RUN} values over all probes"),
            ),
            (
                "record.summary_interval_s",
                r.summary_interval_s,
                !r.probes.is_empty(),
                MAX_SUMMARY_SAMPLES_PER_RUN,
                "summary samples per run".to_string(),
            ),
        ];
        for (field, interval, applies, most, what) in bounds {
            let smallest = self.duration_s / most as f64;
            if applies && interval < smallest {
                return Err(spec_err(
                    field,
                    format!(
                        "must lie in [{smallest:e}, ∞) s: at least duration_s / {most} (at most {most} {what}), got {interval:e}"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Warnings about a scene that is valid but physically absurd, from estimates made before it
    /// runs on its built `chain` ([`Scene::validate`]): a two-body overlap beyond
    /// [`ABSURD_OVERLAP_RATIO`] of the sphere radius, or linear damping that holds an explicit
    /// method's steps more than [`ABSURD_STIFFNESS_RATIO`] times below the contact time.
    pub fn plausibility_warnings(&self, chain: &Chain) -> Vec<String> {
        let mut warnings = Vec::new();
        let scales = self.impact_scales(chain);
        if let Some(radius) = chain.smallest_sphere_radius_m() {
            let ratio = scales.overlap_m / radius;
            if ratio > ABSURD_OVERLAP_RATIO {
                warnings.push(format!(
                    "the two-body overlap estimate {:.3e} m is {ratio:.3} of the sphere radius {radius:.3e} m (Hertz's law assumes < {MAX_HERTZ_OVERLAP_RATIO}; beyond 1 the spheres would pass through each other)",
                    scales.overlap_m
                ));
            }
        }
        // A linear damper μ between masses m_a and m_b decays at μ (1/m_a + 1/m_b): an explicit
        // method's stable step is about its inverse.
        let explicit = !matches!(self.integrator, IntegratorSpec::Ros34pw2(_));
        let stable_step = chain
            .damping
            .iter()
            .enumerate()
            .filter(|(_, &mu)| mu > 0.0)
            .map(|(c, &mu)| {
                let e = chain.contact_ends(c);
                let inv_mass: f64 = [e.above, e.below]
                    .into_iter()
                    .flatten()
                    .map(|i| 1.0 / chain.mass[i])
                    .sum();
                1.0 / (mu * inv_mass)
            })
            .reduce(f64::min);
        if let (true, Some(h)) = (explicit, stable_step) {
            let contact = scales.contact_duration_s();
            let ratio = contact / h;
            if ratio > ABSURD_STIFFNESS_RATIO {
                let steps = self.duration_s / h;
                warnings.push(format!(
                    "damping holds {}'s steps near m/μ = {h:.3e} s, {ratio:.1e} times below the contact time {contact:.3e} s: about {steps:.1e} steps{} (ros34pw2 is not held by damping)",
                    self.integrator.method_name(),
                    if steps > self.max_steps as f64 {
                        format!(", more than the step budget max_steps = {}", self.max_steps)
                    } else {
                        String::new()
                    }
                ));
            }
        }
        warnings
    }

    /// Initial velocity of particle 1: the striker's, the impulse's, or zero under a force pulse
    /// (an initial state sets it in [`Scene::initial_state`]).
    pub fn initial_velocity_m_s(&self) -> f64 {
        match (self.striker_velocity_m_s, &self.excitation) {
            (Some(v0), _) => v0,
            (None, Some(Excitation::Impulse { velocity_m_s })) => *velocity_m_s,
            _ => 0.0,
        }
    }

    /// The state `[x, v, q, …]` the run starts from on the scene's built chain
    /// ([`Scene::validate`]): its excitation's, or the one continuation gave it
    /// ([`Continuation::start_state`]).
    pub fn initial_state(&self, chain: &Chain) -> Vec<f64> {
        if let Some(y) = self
            .continuation
            .as_ref()
            .and_then(|c| c.start_state.as_ref())
        {
            return y.clone();
        }
        let mut y = chain.initial_state(self.initial_velocity_m_s());
        if let Some(Excitation::InitialState(state)) = &self.excitation {
            state.apply(&mut y, chain.n_particles());
        }
        y
    }

    /// The state a run of this scene starts from when it continues from `previous`, the final
    /// state of a run of the same chain (the point before it on a continuation axis): every
    /// particle's position and velocity, every plastic contact's history and a mounted wall's
    /// displacement and velocity carried over; the
    /// quadratures (dissipated work, the walls' impulse, the drive's work) start again from zero,
    /// and a moving wall from where this scene's waveform puts it at `t = 0`. The error names
    /// `continuation` when the chains differ in size.
    pub fn continued_state(
        &self,
        chain: &Chain,
        previous: &[f64],
        previous_chain: &Chain,
    ) -> Result<Vec<f64>, SpecError> {
        let mut y = Scene {
            continuation: None,
            ..self.clone()
        }
        .initial_state(chain);
        let (plastic, was_plastic) = (chain.plastic_contacts(), previous_chain.plastic_contacts());
        let same_bodies = chain.n_particles() == previous_chain.n_particles()
            && previous.len() == previous_chain.state_len()
            && plastic
                .iter()
                .map(|p| p.0)
                .eq(was_plastic.iter().map(|p| p.0))
            && chain.wall_mount.is_some() == previous_chain.wall_mount.is_some();
        if !same_bodies {
            return Err(spec_err(
                "continuation",
                "a point continues from the final state of the point before it on the axis, whose bodies must be this point's: the same particles, plastic contacts and mounted wall",
            ));
        }
        // The bodies carry on as they were; the quadratures (dissipated work, impulses, a
        // drive's work), which may be laid out otherwise (damping on at one point, off at the
        // other), start again, and so does a moving wall, from its waveform.
        let n = chain.n_particles();
        y[..2 * n].copy_from_slice(&previous[..2 * n]);
        for ((_, _, h), (_, _, was)) in plastic.iter().zip(&was_plastic) {
            y[*h] = previous[*was];
            y[h + 1] = previous[was + 1];
        }
        if let (Some(k), Some(was)) = (
            chain.mount_state_index(),
            previous_chain.mount_state_index(),
        ) {
            // A mounted wall is a body of the chain's system: it carries on as it was.
            y[k] = previous[was];
            y[k + 1] = previous[was + 1];
        }
        Ok(y)
    }

    /// Natural scales of the scene's excitation on its built chain ([`Scene::validate`]).
    pub fn impact_scales(&self, chain: &Chain) -> ImpactScales {
        match &self.excitation {
            Some(Excitation::HalfSineForce {
                amplitude_n,
                duration_s,
            }) => ImpactScales::force_pulse(chain, *amplitude_n, *duration_s),
            Some(Excitation::InitialState(_)) => {
                ImpactScales::initial_state(chain, &self.initial_state(chain))
            }
            Some(Excitation::Drive(_)) => {
                ImpactScales::drive(chain, chain.drive.as_ref().expect("a driven chain"))
            }
            _ => ImpactScales::new(chain, self.initial_velocity_m_s()),
        }
    }

    /// Times at which the right-hand side is not smooth in time (the end of a force pulse, of a
    /// drive's ramp or of a chirp's sweep), strictly inside the run, on the scene's built `chain`
    /// ([`Scene::validate`], whose drive is compiled once): the run is integrated in legs between
    /// them.
    pub fn breakpoints_s(&self, chain: &Chain) -> Vec<f64> {
        match &self.excitation {
            Some(Excitation::HalfSineForce { duration_s, .. }) if *duration_s < self.duration_s => {
                vec![*duration_s]
            }
            _ => chain
                .drive
                .as_ref()
                .map_or_else(Vec::new, |d| d.breakpoints_s(self.duration_s)),
        }
    }

    /// The frequency a driven chain's steady response settles at, Hz: what `record.steady_state`
    /// analyses when it gives no `frequency_hz` of its own. A harmonic drive's; `None` for every
    /// other excitation (a chirp, a sum of harmonics or a recording has no single frequency).
    pub fn drive_frequency_hz(&self) -> Option<f64> {
        match &self.excitation {
            Some(Excitation::Drive(d)) => match d.waveform() {
                crate::chain::drive::Waveform::Harmonic(h) => Some(h.frequency_hz),
                _ => None,
            },
            _ => None,
        }
    }
}
