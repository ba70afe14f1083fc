//! Probes: what a scene asks to observe, sampled at fixed output times through the integrators'
//! dense output, and summaries computed on the fly without storing histories.
//!
//! This file is the specification a scene writes (the probes, the record block, the space–time
//! fields) and what a run hands back (summaries, histories) with the limits on both. What
//! evaluates and samples them lives in submodules, each apart because it changes for its own
//! reasons and is read on its own: `compiled` (probes compiled against a chain, by the contact
//! laws of the equations of motion), `sampling` (the one sampling grid and its batched
//! interpolation), `field_recorder` (space–time fields) and `observer` (the run observer that
//! feeds them all from every accepted step).

mod compiled;
mod field_recorder;
mod observer;
mod sampling;

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::chain::model::{spec_err, Chain, SpecError};
use crate::spectrum::SpectrumSpec;

use super::steady::SteadyStateSpec;

pub(crate) use compiled::ProbeSet;
pub(crate) use observer::{ObserverOptions, RunObserver};
pub use sampling::samples_in;

/// One observable. Indices are 1-based as in the paper and `docs/MODEL.md`: particle 1 is the
/// striker when the chain has one, else the first particle of the sequence; contact `j` joins
/// particles `j` and `j+1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(
    feature = "serde",
    serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)
)]
pub enum Probe {
    /// Force read by a gauge embedded in cylinder `k`, the `k`-th cylinder from the top
    /// (particle `2k+1` of the paper's chain): the mean of the total (elastic + dissipative) forces
    /// at its two contacts, N.
    GaugeForce {
        /// Cylinder number, 1..=n.
        cylinder: usize,
    },
    /// Force read by a gauge embedded in particle `i` of any shape: the mean of the total forces
    /// at its two contacts (with particles `i−1` and `i+1`, or the wall), N. The particle needs
    /// both: not particle 1 (a striker, or the top of a chain without one, has one contact), nor the
    /// last of a chain without a wall.
    ParticleForce {
        /// Particle number.
        particle: usize,
    },
    /// Total force of contact `j` (between particles `j` and `j+1`; `j = N` is the wall), N.
    ContactForce {
        /// Contact number, 1..=N (N only with a wall).
        contact: usize,
    },
    /// Overlap δ of contact `j`, static part included, m.
    Overlap {
        /// Contact number, 1..=N (N only with a wall).
        contact: usize,
    },
    /// Dynamic displacement of particle `i` (from its static-equilibrium position), m.
    Displacement {
        /// Particle number, 1..=N.
        particle: usize,
    },
    /// Velocity of particle `i`, m/s.
    Velocity {
        /// Particle number, 1..=N.
        particle: usize,
    },
    /// Total force on the wall, N.
    WallForce,
    /// Force a mounted wall's spring and dashpot pass to the ground, what a load cell under the
    /// wall reads: `F_s + k u + c u̇`, N (needs `chain.wall_mount`).
    MountForce,
    /// Displacement of a mounted wall from its static equilibrium, positive away from the chain,
    /// m (needs `chain.wall_mount`).
    MountDisplacement,
}

impl Probe {
    /// Short name used for dataset names, e.g. `gauge_force_21`.
    pub fn name(&self) -> String {
        match self {
            Probe::GaugeForce { cylinder } => format!("gauge_force_cyl{cylinder}"),
            Probe::ParticleForce { particle } => format!("particle_force_p{particle}"),
            Probe::ContactForce { contact } => format!("contact_force_{contact}"),
            Probe::Overlap { contact } => format!("overlap_{contact}"),
            Probe::Displacement { particle } => format!("displacement_p{particle}"),
            Probe::Velocity { particle } => format!("velocity_p{particle}"),
            Probe::WallForce => "wall_force".to_string(),
            Probe::MountForce => "mount_force".to_string(),
            Probe::MountDisplacement => "mount_displacement".to_string(),
        }
    }

    /// SI unit of the probe's values.
    pub fn unit(&self) -> &'static str {
        match self {
            Probe::GaugeForce { .. }
            | Probe::ParticleForce { .. }
            | Probe::ContactForce { .. }
            | Probe::WallForce
            | Probe::MountForce => "N",
            Probe::Overlap { .. } | Probe::Displacement { .. } | Probe::MountDisplacement => "m",
            Probe::Velocity { .. } => "m/s",
        }
    }
}

/// Whether force probes include the static (gravitational) preload.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Preload {
    /// Total force, as the equations give it (default).
    #[default]
    Include,
    /// Dynamic part only, as an AC-coupled piezo gauge reads it.
    Subtract,
}

/// How the leading pulse is told apart from what follows it.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct LeadingPulseSpec {
    /// The pulse has arrived once the signal exceeds its initial value by this fraction of the
    /// probe's reference scale (the two-body striker impact's peak force, the striker velocity, or
    /// the two-body peak overlap).
    pub arrival_fraction: f64,
    /// The leading pulse has passed once the signal falls below this fraction of its peak (both
    /// measured from the initial value).
    pub release_fraction: f64,
}

impl Default for LeadingPulseSpec {
    fn default() -> Self {
        LeadingPulseSpec {
            arrival_fraction: 0.01,
            release_fraction: 0.5,
        }
    }
}

/// A quantity of a space–time field ([`FieldSpec`]): one value per contact or per particle at
/// every field instant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum FieldQuantity {
    /// The total force of every contact, N: what a `contact_force` probe on it reads (the preload
    /// subtracted with `record.preload: subtract`).
    ContactForce,
    /// The dynamic displacement of every particle, m: what a `displacement` probe reads.
    Displacement,
    /// The velocity of every particle, m/s: what a `velocity` probe reads.
    Velocity,
}

impl FieldQuantity {
    /// Every quantity, in the order a run stores them.
    pub const ALL: [FieldQuantity; 3] = [
        FieldQuantity::ContactForce,
        FieldQuantity::Displacement,
        FieldQuantity::Velocity,
    ];

    /// Its name in a scene (`contact_force`, `displacement`, `velocity`).
    pub fn name(self) -> &'static str {
        match self {
            FieldQuantity::ContactForce => "contact_force",
            FieldQuantity::Displacement => "displacement",
            FieldQuantity::Velocity => "velocity",
        }
    }

    /// SI unit of its values.
    pub fn unit(self) -> &'static str {
        match self {
            FieldQuantity::ContactForce => "N",
            FieldQuantity::Displacement => "m",
            FieldQuantity::Velocity => "m/s",
        }
    }

    /// Whether it has one value per contact (else one per particle).
    pub fn per_contact(self) -> bool {
        self == FieldQuantity::ContactForce
    }

    /// Its code in stored records (0, 1, 2).
    pub fn code(self) -> u8 {
        match self {
            FieldQuantity::ContactForce => 0,
            FieldQuantity::Displacement => 1,
            FieldQuantity::Velocity => 2,
        }
    }

    /// The quantity of a code ([`FieldQuantity::code`]).
    pub fn from_code(code: u8) -> Option<FieldQuantity> {
        FieldQuantity::ALL.into_iter().find(|q| q.code() == code)
    }

    /// The probe that reads this quantity at contact or particle `k` (1-based).
    pub fn probe(self, k: usize) -> Probe {
        match self {
            FieldQuantity::ContactForce => Probe::ContactForce { contact: k },
            FieldQuantity::Displacement => Probe::Displacement { particle: k },
            FieldQuantity::Velocity => Probe::Velocity { particle: k },
        }
    }
}

/// Space–time fields: quantities of every contact or particle sampled every `interval_s` from
/// the start, on the grid the histories use (`t = i · interval_s`), through the same dense output
/// and the same arithmetic as the probes: a field of contact forces at the history interval holds
/// bitwise the history of a `contact_force` probe on each contact.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct FieldSpec {
    /// What to record: any of `contact_force`, `displacement`, `velocity`, each once.
    pub quantities: Vec<FieldQuantity>,
    /// Sampling interval, s (> 0; at most [`MAX_HISTORY_VALUES_PER_RUN`] values per run over
    /// every quantity).
    pub interval_s: f64,
}

impl FieldSpec {
    /// Values one sample holds over every quantity, for a chain of `particles` particles and
    /// `contacts` contacts.
    pub fn values_per_sample(&self, particles: usize, contacts: usize) -> usize {
        self.quantities
            .iter()
            .map(|q| if q.per_contact() { contacts } else { particles })
            .sum()
    }

    /// Checks the quantities and the interval; errors name the field.
    pub fn validate(&self) -> Result<(), SpecError> {
        if self.quantities.is_empty() {
            return Err(spec_err(
                "record.fields.quantities",
                "must name at least one of contact_force, displacement, velocity",
            ));
        }
        for (i, q) in self.quantities.iter().enumerate() {
            if self.quantities[..i].contains(q) {
                return Err(spec_err(
                    &format!("record.fields.quantities[{i}]"),
                    format!("{} is listed twice", q.name()),
                ));
            }
        }
        let v = self.interval_s;
        if !(v.is_finite() && v > 0.0) {
            return Err(spec_err(
                "record.fields.interval_s",
                format!("must be a finite number > 0, got {v}"),
            ));
        }
        Ok(())
    }

    /// The interval against the run's duration on the built `chain`: at most
    /// [`MAX_HISTORY_VALUES_PER_RUN`] values per run over every quantity, so that no interval can
    /// make a run allocate without bound.
    pub fn check_samples(&self, chain: &Chain, duration_s: f64) -> Result<(), SpecError> {
        let per_sample = self
            .values_per_sample(chain.n_particles(), chain.n_contacts())
            .max(1) as u64;
        let most = (MAX_HISTORY_VALUES_PER_RUN / per_sample).max(1);
        if samples_in(0.0, self.interval_s, duration_s) > most {
            let smallest = duration_s / (most.max(2) - 1) as f64;
            return Err(spec_err(
                "record.fields.interval_s",
                format!(
                    "must be at least {smallest:e} s for this chain and duration (at most {MAX_HISTORY_VALUES_PER_RUN} field values per run, {per_sample} per sample), got {:e}",
                    self.interval_s
                ),
            ));
        }
        Ok(())
    }
}

/// A run's space–time fields ([`FieldSpec`]).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
pub struct Fields {
    /// Sample times, s: `i · interval_s`, `i = 0, 1, …`.
    pub time_s: Vec<f64>,
    /// One series per quantity, in the order of the record block.
    pub series: Vec<FieldSeries>,
}

/// One quantity of a run's fields.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
pub struct FieldSeries {
    /// The quantity.
    pub quantity: FieldQuantity,
    /// Contacts or particles: values per sample.
    pub width: usize,
    /// Row-major over (time, contact or particle): `values[i · width + k]` is contact or
    /// particle `k + 1` at `time_s[i]`.
    pub values: Vec<f64>,
}

/// What a run records: nothing is computed or stored that is not asked for here.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct RecordSpec {
    /// Probes to observe.
    #[cfg_attr(feature = "serde", serde(default))]
    pub probes: Vec<Probe>,
    /// Store full histories of the probes at `history_interval_s`.
    #[cfg_attr(feature = "serde", serde(default))]
    pub history: bool,
    /// Output interval of histories, s.
    #[cfg_attr(feature = "serde", serde(default = "default_history_interval"))]
    pub history_interval_s: f64,
    /// Sampling interval of the on-the-fly peak summaries, s: the samples tell the leading pulse
    /// from later ones; every peak is then located on the integrator's dense output.
    #[cfg_attr(feature = "serde", serde(default = "default_summary_interval"))]
    pub summary_interval_s: f64,
    /// Track the minimum overlap of every contact (gaps open where it falls to zero or below).
    #[cfg_attr(feature = "serde", serde(default))]
    pub min_overlap: bool,
    /// Static preload in force probes.
    #[cfg_attr(feature = "serde", serde(default))]
    pub preload: Preload,
    /// Leading-pulse detection.
    #[cfg_attr(feature = "serde", serde(default))]
    pub leading_pulse: LeadingPulseSpec,
    /// End the run as soon as every probe's leading pulse has passed (sweeps that need only
    /// leading peaks). The record (summaries, histories, fields) ends at the summary instant at
    /// which the last of them was seen to pass, whatever the step sizes; the integration, and so
    /// `t_end_s` and the ledger, at the end of the step that contains that instant.
    #[cfg_attr(feature = "serde", serde(default))]
    pub stop_after_leading_pulses: bool,
    /// Record the linear spectrum at the static state (lowest and highest natural frequency and,
    /// for a periodic chain, its band edges). A run that records nothing else (no probes,
    /// histories or minimum overlaps) is not integrated in time.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub spectrum: Option<SpectrumSpec>,
    /// Space–time fields of every contact or particle (none by default; nothing is sampled
    /// without them).
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub fields: Option<FieldSpec>,
    /// Steady-state mean, RMS, harmonic amplitudes and phases and transmission of every probe
    /// over a window of whole periods (none by default; nothing is sampled without it).
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub steady_state: Option<SteadyStateSpec>,
    /// The energy that has passed into every contact from the side of the struck end (its
    /// largest value and its value at the end; the wall's contact: the energy that reached the
    /// wall) and each particle's largest kinetic energy (see [`crate::observe::flow`]).
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "std::ops::Not::not")
    )]
    pub energy_flow: bool,
    /// Store the energy ledger's terms (kinetic, elastic, gravitational, dissipated, plastic,
    /// external, a mounted wall's) at the start and at the end of the run, so that where the
    /// energy went can be read term by term.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "std::ops::Not::not")
    )]
    pub energy_ledger: bool,
}

#[cfg(feature = "serde")]
fn default_history_interval() -> f64 {
    1e-6
}
#[cfg(feature = "serde")]
fn default_summary_interval() -> f64 {
    2e-7
}

impl Default for RecordSpec {
    fn default() -> Self {
        RecordSpec {
            probes: Vec::new(),
            history: false,
            history_interval_s: 1e-6,
            summary_interval_s: 2e-7,
            min_overlap: false,
            preload: Preload::Include,
            leading_pulse: LeadingPulseSpec::default(),
            stop_after_leading_pulses: false,
            spectrum: None,
            fields: None,
            steady_state: None,
            energy_flow: false,
            energy_ledger: false,
        }
    }
}

impl RecordSpec {
    /// Whether a run needs its time integration: it records probes, histories or minimum
    /// overlaps, or nothing at all (a run with only `spectrum` is not integrated).
    pub fn needs_integration(&self) -> bool {
        self.spectrum.is_none()
            || !self.probes.is_empty()
            || self.history
            || self.min_overlap
            || self.fields.is_some()
            || self.steady_state.is_some()
            || self.energy_flow
    }

    /// Checks the record block against a built chain; errors name the field (relative to `record`).
    pub fn validate(&self, chain: &Chain) -> Result<(), SpecError> {
        if let Some(spectrum) = &self.spectrum {
            spectrum.validate(chain)?;
        }
        if let Some(fields) = &self.fields {
            fields.validate()?;
        }
        let n_p = chain.n_particles();
        let n_c = chain.n_contacts();
        let cylinders = chain.cylinders();
        let n_cyl = cylinders.len();
        // A gauge reads the two contacts of its particle: the one above and the one below (the
        // last particle's is the wall's or the ring's closing contact; the first particle's top
        // wall is not read by a gauge).
        let two_contacts =
            |index: usize| index >= 1 && (index + 1 < n_p || chain.wall || chain.ring);
        for (i, p) in self.probes.iter().enumerate() {
            let field = format!("record.probes[{i}]");
            match *p {
                Probe::GaugeForce { .. } if n_cyl == 0 => {
                    return Err(spec_err(
                        &format!("{field}.cylinder"),
                        "the chain has no cylinders; a gauge in any particle is {\"kind\": \"particle_force\", \"particle\": i}",
                    ))
                }
                Probe::GaugeForce { cylinder } if cylinder == 0 || cylinder > n_cyl => {
                    return Err(spec_err(
                        &format!("{field}.cylinder"),
                        format!("must be from 1 to {n_cyl} (the chain's cylinders), got {cylinder}"),
                    ))
                }
                Probe::GaugeForce { cylinder } if !two_contacts(cylinders[cylinder - 1]) => {
                    return Err(spec_err(
                        &format!("{field}.cylinder"),
                        format!("cylinder {cylinder} is particle {}, which has a contact on one side only", cylinders[cylinder - 1] + 1),
                    ))
                }
                Probe::ParticleForce { particle } if particle == 0 || particle > n_p => {
                    return Err(spec_err(
                        &format!("{field}.particle"),
                        format!("must be from 1 to {n_p} (the chain's particles), got {particle}"),
                    ))
                }
                Probe::ParticleForce { particle } if !two_contacts(particle - 1) => {
                    return Err(spec_err(
                        &format!("{field}.particle"),
                        format!("particle {particle} has a contact on one side only (the first particle of a chain without a striker, or the last without a wall); read its contact with contact_force"),
                    ))
                }
                Probe::ContactForce { contact } | Probe::Overlap { contact }
                    if contact == 0 || contact > n_c =>
                {
                    return Err(spec_err(
                        &format!("{field}.contact"),
                        format!("must be from 1 to {n_c} (the chain's contacts), got {contact}"),
                    ))
                }
                Probe::Displacement { particle } | Probe::Velocity { particle }
                    if particle == 0 || particle > n_p =>
                {
                    return Err(spec_err(
                        &format!("{field}.particle"),
                        format!("must be from 1 to {n_p} (the chain's particles), got {particle}"),
                    ))
                }
                Probe::WallForce if !chain.wall => {
                    return Err(spec_err(
                        &format!("{field}.kind"),
                        "wall_force needs physics.wall = true",
                    ))
                }
                Probe::MountForce | Probe::MountDisplacement if chain.wall_mount.is_none() => {
                    return Err(spec_err(
                        &format!("{field}.kind"),
                        format!(
                            "{} reads the wall's mount: give the chain one (chain.wall_mount)",
                            p.name()
                        ),
                    ))
                }
                _ => {}
            }
        }
        for (name, v) in [
            ("record.history_interval_s", self.history_interval_s),
            ("record.summary_interval_s", self.summary_interval_s),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(spec_err(
                    name,
                    format!("must be a finite number > 0, got {v}"),
                ));
            }
        }
        let lp = &self.leading_pulse;
        if !(lp.arrival_fraction.is_finite()
            && lp.arrival_fraction > 0.0
            && lp.arrival_fraction < 1.0)
        {
            return Err(spec_err(
                "record.leading_pulse.arrival_fraction",
                format!("must lie in (0, 1), got {}", lp.arrival_fraction),
            ));
        }
        if !(lp.release_fraction.is_finite()
            && lp.release_fraction > 0.0
            && lp.release_fraction < 1.0)
        {
            return Err(spec_err(
                "record.leading_pulse.release_fraction",
                format!("must lie in (0, 1), got {}", lp.release_fraction),
            ));
        }
        Ok(())
    }
}

/// Summary of one probe over a run.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
pub struct ProbeSummary {
    /// Peak of the leading pulse (first excursion), located on the dense output; NaN if the pulse never
    /// arrived or was still rising when the run ended.
    pub leading_peak: f64,
    /// Time of the leading peak, s; NaN if it never arrived.
    pub leading_peak_time_s: f64,
    /// Maximum over the whole record, located on the dense output.
    pub record_max: f64,
    /// Time of the record maximum, s.
    pub record_max_time_s: f64,
}

/// A run with a deadline reads the clock once every this many accepted steps: a few
/// nanoseconds per step at most, and a run ends within this many steps of its deadline.
pub const DEADLINE_CHECK_STEPS: u32 = 64;

/// Time histories of the probes.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
pub struct History {
    /// Sample times, s.
    pub time_s: Vec<f64>,
    /// One series per probe, in the order of the record block.
    pub values: Vec<Vec<f64>>,
}

/// Most history samples per probe in one run (`duration_s / history_interval_s`): 8 MB per probe,
/// a thousand times the paper's histories (1 µs over 1 ms).
pub const MAX_HISTORY_SAMPLES_PER_RUN: u64 = 1_000_000;

/// Most history values in one run, over all its probes: 80 MB, so that many probes cannot
/// multiply [`MAX_HISTORY_SAMPLES_PER_RUN`] beyond what a worker holds.
pub const MAX_HISTORY_VALUES_PER_RUN: u64 = 10_000_000;

/// Most history samples per probe in a run recording `n_probes` probes: at most
/// [`MAX_HISTORY_SAMPLES_PER_RUN`], and [`MAX_HISTORY_VALUES_PER_RUN`] over all probes.
pub fn max_history_samples(n_probes: usize) -> u64 {
    MAX_HISTORY_SAMPLES_PER_RUN.min(MAX_HISTORY_VALUES_PER_RUN / n_probes.max(1) as u64)
}

/// Most summary samples in one run (`duration_s / summary_interval_s`): a few seconds of
/// sampling, two thousand times the paper's summaries (0.2 µs over 1 ms).
pub const MAX_SUMMARY_SAMPLES_PER_RUN: u64 = 10_000_000;
