//! Probes: what a scene asks to observe, sampled at fixed output times through the integrators'
//! dense output, and summaries computed on the fly without storing histories.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::contact::{
    general_force, hertz_force, paper_contact_force, ContactParams, Damping, Thornton, POWER,
};
use std::time::Instant;

use crate::chain::model::{spec_err, Chain, ContactMap, SpecError};
use crate::integrate::{Control, DenseStep, StepObserver};
use crate::motion::balance::StaticBalance;
use crate::motion::system::{EnergyTerms, Ledger};
use crate::spectrum::SpectrumSpec;

use super::flow::{EnergyFlow, FlowRecorder};
use super::grid_instant;
use super::peaks::{hermite_max, maximise, PeakTracker, PulsePhase};
use super::steady::{SteadyRecorder, SteadyState, SteadyStateSpec};

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

/// A probe compiled against a chain: state indices and constants.
#[derive(Debug, Clone, Copy)]
enum Compiled {
    /// Mean of `n` contact forces starting at contact index `first` (n = 1 or 2).
    Contacts {
        first: usize,
        count: usize,
        /// `1/count`, exact for a count of 1 or 2: multiplying by it gives the quotient's bits
        /// without a division's latency on every probe sample.
        inv_count: f64,
        offset: f64,
    },
    Overlap {
        contact: usize,
    },
    Displacement {
        index: usize,
        origin: f64,
    },
    Velocity {
        index: usize,
    },
    /// A mounted wall's force on the ground, `offset + k u + c w` (`u` at `index`, `w` after it).
    Mount {
        index: usize,
        offset: f64,
        stiffness: f64,
        damping: f64,
    },
}

/// Exponents, viscoelastic, Hunt–Crossley and (when any contact has it) Tsuji coefficients.
type GeneralLaws = (Vec<f64>, Vec<f64>, Vec<f64>, Option<Vec<f64>>);

/// Evaluates probes from a dense step or a state.
#[derive(Debug, Clone)]
pub(crate) struct ProbeSet {
    compiled: Vec<Compiled>,
    stiffness: Vec<f64>,
    damping: Vec<f64>,
    /// Exponents and the viscoelastic, Hunt–Crossley and (when any) Tsuji coefficients, for
    /// chains that are not the paper's physics.
    general: Option<GeneralLaws>,
    /// Thornton's law and the index of its history, per contact, when any contact has it.
    plastic: Option<Vec<Option<(Thornton, usize)>>>,
    clip: bool,
    /// What each contact joins.
    contacts: ContactMap,
    /// Reference scale of each probe for leading-pulse detection.
    pub scale: Vec<f64>,
}

impl ProbeSet {
    pub fn new(
        chain: &Chain,
        probes: &[Probe],
        preload: Preload,
        force_scale: f64,
        velocity_scale: f64,
        length_scale: f64,
    ) -> Self {
        let n = chain.n_particles();
        let static_mean = |first: usize, count: usize| -> f64 {
            (first..first + count)
                .map(|c| chain.static_force(c))
                .sum::<f64>()
                / count as f64
        };
        let mut compiled = Vec::new();
        let mut scale = Vec::new();
        let cylinders = chain.cylinders();
        for p in probes {
            let (c, s) = match *p {
                Probe::GaugeForce { cylinder } => (cylinders[cylinder - 1] - 1, 2),
                Probe::ParticleForce { particle } => (particle - 2, 2),
                Probe::ContactForce { contact } => (contact - 1, 1),
                Probe::WallForce => (n - 1, 1),
                Probe::Overlap { contact } => {
                    compiled.push(Compiled::Overlap {
                        contact: contact - 1,
                    });
                    scale.push(length_scale);
                    continue;
                }
                Probe::Displacement { particle } => {
                    compiled.push(Compiled::Displacement {
                        index: particle - 1,
                        origin: chain.equilibrium_position[particle - 1],
                    });
                    scale.push(length_scale);
                    continue;
                }
                Probe::Velocity { particle } => {
                    compiled.push(Compiled::Velocity {
                        index: n + particle - 1,
                    });
                    scale.push(velocity_scale);
                    continue;
                }
                Probe::MountDisplacement => {
                    compiled.push(Compiled::Displacement {
                        index: chain.mount_state_index().expect("validated: a mount"),
                        origin: 0.0,
                    });
                    scale.push(length_scale);
                    continue;
                }
                Probe::MountForce => {
                    let mount = chain.wall_mount.expect("validated: a mount");
                    compiled.push(Compiled::Mount {
                        index: chain.mount_state_index().expect("a mount"),
                        offset: match preload {
                            Preload::Include => chain.static_force(n - 1),
                            Preload::Subtract => 0.0,
                        },
                        stiffness: mount.stiffness_n_m,
                        damping: mount.damping_kg_s,
                    });
                    scale.push(force_scale);
                    continue;
                }
            };
            let offset = match preload {
                Preload::Include => 0.0,
                Preload::Subtract => static_mean(c, s),
            };
            debug_assert!(s == 1 || s == 2, "a probe averages one or two contacts");
            compiled.push(Compiled::Contacts {
                first: c,
                count: s,
                inv_count: 1.0 / s as f64,
                offset,
            });
            scale.push(force_scale);
        }
        ProbeSet {
            compiled,
            stiffness: chain.stiffness.clone(),
            damping: chain.damping.clone(),
            general: (!chain.is_paper_physics()).then(|| {
                (
                    chain.exponent.clone(),
                    chain.viscoelastic_damping.clone(),
                    chain.hunt_crossley_damping.clone(),
                    chain
                        .has_tsuji_damping()
                        .then(|| chain.tsuji_damping.clone()),
                )
            }),
            plastic: chain.has_plasticity().then(|| {
                let mut laws = vec![None; chain.n_contacts()];
                for (c, t, h) in chain.plastic_contacts() {
                    laws[c] = Some((t, h));
                }
                laws
            }),
            clip: chain.clip_tensile,
            contacts: ContactMap::of(chain),
            scale,
        }
    }

    pub fn len(&self) -> usize {
        self.compiled.len()
    }

    /// The state components the probes read, sorted, each once.
    pub(crate) fn components(&self) -> Vec<usize> {
        let mut read: Vec<usize> = (0..self.len())
            .flat_map(|k| self.components_of(k))
            .collect();
        read.sort_unstable();
        read.dedup();
        read
    }

    /// The state components probe `k` reads, sorted, each once.
    pub(crate) fn components_of(&self, k: usize) -> Vec<usize> {
        let read = std::cell::RefCell::new(Vec::new());
        let get = |i: usize| {
            read.borrow_mut().push(i);
            0.0
        };
        self.value(k, &get);
        let mut read = read.into_inner();
        read.sort_unstable();
        read.dedup();
        read
    }

    /// An upper bound of every value probe `k` takes, as computed by [`ProbeSet::value`], while
    /// each component `i` it reads stays within `range(i)` (as computed values); `None` for the
    /// probes it is not derived for. Derived for the force probes of the paper's law between
    /// neighbours, whose every operation is monotone in the overlap and the rate (IEEE rounding
    /// is monotone too, so the bound holds for the rounded values): the elastic term grows with
    /// the overlap, the viscous term `μ Δv` (`μ ≥ 0`) with the rate while compressed and is
    /// absent while open, and clipping at zero only lowers a value.
    pub(crate) fn upper_bound(
        &self,
        k: usize,
        range: &impl Fn(usize) -> Option<(f64, f64)>,
    ) -> Option<f64> {
        let Compiled::Contacts {
            first,
            count,
            inv_count,
            offset,
        } = self.compiled[k]
        else {
            return None;
        };
        if self.general.is_some() || self.plastic.is_some() {
            return None;
        }
        let mut s = 0.0;
        for c in first..first + count {
            let ([above, below], [v_above, v_below]) = self.contacts.between(c)?;
            let (a, mu) = (self.stiffness[c], self.damping[c]);
            let ((_, above_hi), (below_lo, _)) = (range(above)?, range(below)?);
            let elastic = hertz_force(a, (above_hi - below_lo).max(0.0));
            s += if mu == 0.0 {
                elastic
            } else {
                let ((_, above_hi), (below_lo, _)) = (range(v_above)?, range(v_below)?);
                (elastic + mu * (above_hi - below_lo)).max(0.0)
            };
        }
        Some(s * inv_count - offset)
    }

    /// Force of contact `c`, by the same law as the equations of motion. A contact without
    /// damping is read from its overlap alone: its dissipative terms are zeros added to the
    /// elastic force, which leave it as it is, so its rate is neither read nor interpolated at
    /// every sample.
    #[inline]
    fn contact_force(&self, c: usize, get: &impl Fn(usize) -> f64) -> f64 {
        let Some((p, tsuji)) = self.general_params(c) else {
            let (a, mu) = (self.stiffness[c], self.damping[c]);
            if mu == 0.0 {
                let overlap = self.contacts.overlap_read(c, get);
                return if self.clip {
                    paper_contact_force::<false, true>(a, mu, overlap, 0.0).0
                } else {
                    paper_contact_force::<false, false>(a, mu, overlap, 0.0).0
                };
            }
            let (overlap, rel) = self.contacts.kinematics(c, get);
            return if self.clip {
                paper_contact_force::<true, true>(a, mu, overlap, rel).0
            } else {
                paper_contact_force::<true, false>(a, mu, overlap, rel).0
            };
        };
        // Thornton's contacts (never in the paper's physics, whose path stays as it was).
        if let Some((law, h)) = self.plastic.as_ref().and_then(|p| p[c].as_ref()) {
            return plastic_force(law, self.contacts.overlap_read(c, get), get(*h));
        }
        if p.damping == Damping::NONE {
            let overlap = self.contacts.overlap_read(c, get);
            return general_force::<POWER, false, false>(&p, overlap, 0.0, self.clip).0;
        }
        let (overlap, rel) = self.contacts.kinematics(c, get);
        if tsuji {
            general_force::<POWER, true, true>(&p, overlap, rel, self.clip).0
        } else {
            general_force::<POWER, true, false>(&p, overlap, rel, self.clip).0
        }
    }

    /// The general law's parameters of contact `c`, and whether the chain's contacts carry
    /// Tsuji's term; `None` in the paper's physics.
    #[inline]
    fn general_params(&self, c: usize) -> Option<(ContactParams, bool)> {
        let (exponent, gamma, lambda, beta) = self.general.as_ref()?;
        let p = ContactParams {
            a: self.stiffness[c],
            n: exponent[c],
            damping: Damping {
                linear: self.damping[c],
                viscoelastic: gamma[c],
                hunt_crossley: lambda[c],
                tsuji: beta.as_ref().map_or(0.0, |b| b[c]),
            },
        };
        Some((p, beta.is_some()))
    }

    /// Value of probe `k` with state components supplied by `get`.
    #[inline]
    pub fn value(&self, k: usize, get: &impl Fn(usize) -> f64) -> f64 {
        match self.compiled[k] {
            Compiled::Contacts {
                first,
                count,
                inv_count,
                offset,
            } => mean_force(first..first + count, inv_count, offset, |c| {
                self.contact_force(c, get)
            }),
            Compiled::Overlap { contact } => self.contacts.overlap_read(contact, get),
            Compiled::Displacement { index, origin } => get(index) - origin,
            Compiled::Velocity { index } => get(index),
            Compiled::Mount {
                index,
                offset,
                stiffness,
                damping,
            } => offset + stiffness * get(index) + damping * get(index + 1),
        }
    }
}

/// A force probe's value: the mean of the forces (`force`) of `contacts`, `inv_count` being one
/// over their number, less `offset` (the static preload, when it is subtracted).
#[inline(always)]
fn mean_force(
    contacts: std::ops::Range<usize>,
    inv_count: f64,
    offset: f64,
    force: impl Fn(usize) -> f64,
) -> f64 {
    let mut s = 0.0;
    for c in contacts {
        s += force(c);
    }
    s * inv_count - offset
}

/// Force of a contact with Thornton's law, kept out of line so that the probes of every other
/// chain compile as they did.
#[inline(never)]
fn plastic_force(law: &Thornton, overlap: f64, gap: f64) -> f64 {
    law.force(overlap, gap)
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

/// Options of the run observer.
#[derive(Debug, Clone)]
pub(crate) struct ObserverOptions {
    pub history: bool,
    pub history_interval: f64,
    pub summary_interval: f64,
    pub min_overlap: bool,
    pub arrival_fraction: f64,
    pub release_fraction: f64,
    pub stop_after_leading_pulses: bool,
    pub impact_energy: f64,
    pub impact_momentum: f64,
    /// Whether a drive feeds the chain for the whole run: its energy drift is then measured
    /// against the larger of `impact_energy` and the work the drive has done so far (a driven
    /// chain's energy grows far beyond the scale of one period).
    pub driven: bool,
    /// Space–time fields to record, with the preload setting of the force probes.
    pub fields: Option<(FieldSpec, Preload)>,
    /// The steady-state window to analyse, at its frequency (Hz).
    pub steady_state: Option<(SteadyStateSpec, f64)>,
    /// Whether to integrate the energy flow ([`crate::observe::flow`]).
    pub energy_flow: bool,
}

/// Samples a run's space–time fields: one probe per contact or particle of each quantity, on the
/// grid `t0 + i · interval`, with the probes' own sampling ([`sample_grid`]) and arithmetic
/// ([`ProbeSet::value`]).
struct FieldRecorder {
    probes: ProbeSet,
    interval: f64,
    /// The next instant's index on the grid.
    next: u64,
    components: Vec<usize>,
    state: Vec<f64>,
    batch: Vec<f64>,
    out: Fields,
}

impl FieldRecorder {
    fn new(chain: &Chain, spec: &FieldSpec, preload: Preload, t0: f64, t_end: f64) -> Self {
        let (n_p, n_c) = (chain.n_particles(), chain.n_contacts());
        let mut list = Vec::new();
        let mut series = Vec::new();
        for &q in &spec.quantities {
            let width = if q.per_contact() { n_c } else { n_p };
            list.extend((1..=width).map(|k| q.probe(k)));
            series.push(FieldSeries {
                quantity: q,
                width,
                values: Vec::new(),
            });
        }
        // (The reference scales only serve leading pulses, which fields do not track.)
        let probes = ProbeSet::new(chain, &list, preload, 1.0, 1.0, 1.0);
        let components = probes.components();
        let state = vec![0.0; components.last().map_or(0, |i| i + 1)];
        // Bounded whatever the caller validated: a longer record grows as it goes.
        let per_sample = list.len().max(1) as u64;
        let cap = samples_in(t0, spec.interval_s, t_end)
            .min((MAX_HISTORY_VALUES_PER_RUN / per_sample).max(1)) as usize;
        for s in &mut series {
            s.values.reserve_exact(cap * s.width);
        }
        // A batch of up to FIELD_BATCH_VALUES values (a long chain's batch holds fewer instants).
        let rows = (FIELD_BATCH_VALUES / components.len().max(1)).clamp(1, SAMPLE_BATCH);
        FieldRecorder {
            batch: vec![0.0; rows * components.len()],
            probes,
            interval: spec.interval_s,
            next: 0,
            components,
            state,
            out: Fields {
                time_s: Vec::with_capacity(cap),
                series,
            },
        }
    }

    /// Appends one sample at `t` from the state components `get` gives.
    #[inline]
    fn push(probes: &ProbeSet, out: &mut Fields, t: f64, get: &impl Fn(usize) -> f64) {
        out.time_s.push(t);
        let mut k = 0;
        for s in &mut out.series {
            for _ in 0..s.width {
                s.values.push(probes.value(k, get));
                k += 1;
            }
        }
    }

    fn start(&mut self, t0: f64, y0: &[f64]) {
        let get = |i: usize| y0[i];
        FieldRecorder::push(&self.probes, &mut self.out, t0, &get);
        self.next = 1;
    }

    fn step(&mut self, step: &dyn DenseStep, t0: f64, until: f64) {
        let (probes, out) = (&self.probes, &mut self.out);
        sample_grid(
            step,
            (t0, self.interval),
            &mut self.next,
            until,
            &self.components,
            &mut self.batch[..],
            &mut self.state,
            |t, state| {
                let g = |i: usize| state[i];
                FieldRecorder::push(probes, out, t, &g);
            },
        );
    }
}

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

/// The observer that feeds probes, summaries and the ledger from every accepted step. A run
/// integrated in legs ([`crate::scene::solve::run`]) calls `on_start` once per leg: the first call
/// starts the record, the later ones continue it from the state the previous leg ended in.
pub(crate) struct RunObserver {
    /// Whether the record has started (later `on_start` calls are continuations).
    started: bool,
    /// Whether the observer asked the integrator to stop.
    pub stopped: bool,
    /// The run stops once this instant has passed (checked every [`DEADLINE_CHECK_STEPS`]).
    pub deadline: Option<Instant>,
    /// Whether the run was stopped by its deadline.
    pub deadline_reached: bool,
    /// The run stops once this flag is set (read after every accepted step).
    pub stop_flag: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
    /// Whether the run was stopped by its stop flag.
    pub interrupted: bool,
    /// Accepted steps since the clock was last read.
    steps_since_clock: u32,
    /// The state at the end of the last accepted step, kept when the run has several legs.
    pub state: Option<Vec<f64>>,
    /// The ledger's terms at the start.
    pub first_energy: Option<EnergyTerms>,
    probes: ProbeSet,
    ledger: Ledger,
    opts: ObserverOptions,
    t0: f64,
    t_end: f64,
    e0: f64,
    p0: f64,
    /// The external term of the ledger at the start, and the largest work done since (driven
    /// chains).
    external0: f64,
    work_max: f64,
    trackers: Vec<PeakTracker>,
    next_summary: u64,
    next_history: u64,
    pub history: Option<History>,
    pub min_overlap: Option<Vec<f64>>,
    /// The space–time fields, when recorded.
    fields: Option<FieldRecorder>,
    /// The steady-state sums, when recorded.
    steady: Option<SteadyRecorder>,
    /// The energy flow, when recorded.
    flow: Option<FlowRecorder>,
    pub energy_drift_max: f64,
    pub energy_drift_final: f64,
    pub momentum_residual_max: f64,
    pub max_overlap: f64,
    pub last_energy: Option<EnergyTerms>,
    pub t_reached: f64,
    n: usize,
    n_contacts: usize,
    /// What each contact joins.
    contacts: ContactMap,
    /// The components the probes read ([`ProbeSet::components`]).
    probe_components: Vec<usize>,
    /// The components each probe reads ([`ProbeSet::components_of`]).
    components_of: Vec<Vec<usize>>,
    /// The probes whose samples in the current step provably change nothing they record
    /// ([`PeakTracker::settled_below`]), and the components the others read.
    settled: Vec<bool>,
    live_components: Vec<usize>,
    /// Per probe, the steps to pass before its bound is tried again, and how many it waited last
    /// ([`MAX_SETTLE_WAIT`]).
    settle_wait: Vec<(u8, u8)>,
    /// Those components at one sample time, at their indices in the state.
    probe_state: Vec<f64>,
    /// Particles integrated (the rest rest at their static equilibrium, [`crate::scene::active`]): the
    /// ledger sums over them and adds the constant energy of the rest, [`RunObserver::set_active`].
    active: usize,
    /// Elastic and gravitational energy of the particles at rest and their contacts, J.
    frozen_energy: (f64, f64),
    /// Largest overlap of the contacts between particles at rest, m.
    frozen_max_overlap: f64,
    /// Those components at up to [`SAMPLE_BATCH`] sample times, one row per time.
    batch_values: Vec<f64>,
    /// Each probe's value at the end of the last step (at the start, before the first).
    last_value: Vec<f64>,
    /// Each probe's smallest and largest sample in the current step.
    step_range: Vec<(f64, f64)>,
    /// The largest contact overlap at the end of the last step.
    last_max_overlap: f64,
    /// The energy balance above the static state, for chains whose static state holds energy
    /// ([`RunObserver::uses_static_balance`]): its total at the start, and the largest energy of
    /// the motion and work exchanged so far.
    balance: Option<(StaticBalance, f64)>,
    motion_max: f64,
}

/// Fills `times` with the sample times `t0 + j·interval`, `j = first, first + 1, …`, up to `until`
/// (at most `times.len()` of them) and returns how many there are: one sampling grid for the
/// summaries, the histories and the fields alike.
#[inline]
fn batch_times(t0: f64, first: u64, interval: f64, until: f64, times: &mut [f64]) -> usize {
    let mut count = 0;
    while count < times.len() {
        let t = grid_instant(t0, first + count as u64, interval);
        if t > until {
            break;
        }
        times[count] = t;
        count += 1;
    }
    count
}

/// How many instants `t0 + i·interval` (`i = 0, 1, …`) lie in `[t0, t_end]`, counted as the
/// sampling loop ([`batch_times`]) takes them: `i` while `t0 + i·interval ≤ t_end` in floating
/// point (which a quotient rounded down can miss by one either way). What a run that is not
/// stopped early records: the writer of the results sizes its time axis with it.
pub fn samples_in(t0: f64, interval: f64, t_end: f64) -> u64 {
    if interval.is_nan() || interval <= 0.0 || t_end.is_nan() || t_end < t0 {
        return u64::from(t_end >= t0);
    }
    let at = |i: u64| grid_instant(t0, i, interval);
    let mut last = ((t_end - t0) / interval).floor().max(0.0) as u64;
    while last > 0 && at(last) > t_end {
        last -= 1;
    }
    while at(last + 1) <= t_end {
        last += 1;
    }
    last + 1
}

/// Feeds `sink` the instants `t0 + i·interval` of `grid` from `i = *next` up to `until` (and
/// advances `*next` past them), each with the state whose `components` are interpolated in
/// `step` there: in batches of [`SAMPLE_BATCH`] (one interpolant set-up for all of a batch),
/// the samples then fed in time order exactly as one at a time (the values of a sample do not
/// depend on the batch it is in). `batch` holds a batch's values (as many rows of the components
/// as it has room for, at most [`SAMPLE_BATCH`]), `state` the components of one sample.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn sample_grid(
    step: &dyn DenseStep,
    (t0, interval): (f64, f64),
    next: &mut u64,
    until: f64,
    components: &[usize],
    batch: &mut [f64],
    state: &mut [f64],
    mut sink: impl FnMut(f64, &[f64]),
) {
    let m = components.len();
    let rows = batch
        .len()
        .checked_div(m)
        .map_or(SAMPLE_BATCH, |r| r.clamp(1, SAMPLE_BATCH));
    let mut times = [0.0f64; SAMPLE_BATCH];
    loop {
        let count = batch_times(t0, *next, interval, until, &mut times[..rows]);
        if count == 0 {
            break;
        }
        let values = &mut batch[..count * m];
        step.eval_components_at(&times[..count], components, values);
        for (&t, row) in times[..count].iter().zip(values.chunks_exact(m.max(1))) {
            for (&i, &v) in components.iter().zip(row) {
                state[i] = v;
            }
            sink(t, state);
        }
        *next += count as u64;
        if count < rows {
            break;
        }
    }
}

/// Most samples interpolated in one call ([`DenseStep::eval_components_at`]).
const SAMPLE_BATCH: usize = 32;

/// Most steps a probe whose bound failed waits before its bound is tried again
/// ([`RunObserver::settle`]): whether a probe settles changes no result, only what its samples
/// cost.
const MAX_SETTLE_WAIT: u8 = 15;

/// Most values in the fields' batch of samples (8 MiB): a chain of millions of particles
/// interpolates one instant at a time rather than holding [`SAMPLE_BATCH`] whole states.
const FIELD_BATCH_VALUES: usize = 1 << 20;

impl RunObserver {
    /// Marks the probes whose summary samples in this step (those up to `until`) provably change
    /// nothing but the last two samples their trackers keep: the step's enclosure of the
    /// components each reads ([`DenseStep::component_range`]) bounds its values
    /// ([`ProbeSet::upper_bound`]) below what could change its tracker
    /// ([`PeakTracker::settled_below`]). Collects the components of the others in
    /// `live_components`; returns whether any probe is settled. Only a step of at least three
    /// samples is looked at (below that nothing is saved).
    fn settle(&mut self, step: &dyn DenseStep, until: f64) -> bool {
        self.settled.fill(false);
        #[cfg(test)]
        if tests::NO_SETTLING.with(|c| c.get()) {
            return false;
        }
        // (The third instant from the next, as the sampling loop places it.)
        if grid_instant(self.t0, self.next_summary + 2, self.opts.summary_interval) > until {
            return false;
        }
        let mut any = false;
        for (k, tracker) in self.trackers.iter().enumerate() {
            if !tracker.may_settle() {
                continue;
            }
            let (wait, waited) = &mut self.settle_wait[k];
            if *wait > 0 {
                *wait -= 1;
                continue;
            }
            self.settled[k] = self
                .probes
                .upper_bound(k, &|i| step.component_range(i))
                .is_some_and(|u| tracker.settled_below(u));
            // A bound that fails is tried again after a wait that doubles while it keeps failing:
            // a probe whose signal keeps rising by round-off (a particle at rest, integrated)
            // costs the bound once in a while, not at every step.
            (*wait, *waited) = if self.settled[k] {
                (0, 0)
            } else {
                let next = (2 * *waited + 1).min(MAX_SETTLE_WAIT);
                (next, next)
            };
            any |= self.settled[k];
        }
        if any {
            self.live_components.clear();
            for (k, c) in self.components_of.iter().enumerate() {
                if !self.settled[k] {
                    self.live_components.extend_from_slice(c);
                }
            }
            self.live_components.sort_unstable();
            self.live_components.dedup();
        }
        any
    }

    /// Under test, the settled probes' trackers ([`RunObserver::settle`]) against copies that
    /// took every summary instant of the step from index `first` up to `until`: skipping them
    /// must change nothing, bitwise.
    #[cfg(test)]
    fn sample_settled(&mut self, step: &dyn DenseStep, first: u64, until: f64) {
        let interval = self.opts.summary_interval;
        let at = |j: u64| grid_instant(self.t0, j, interval);
        for k in 0..self.trackers.len() {
            if !self.settled[k] {
                continue;
            }
            let mut copy = self.trackers[k];
            let components = &self.components_of[k];
            let mut row = vec![0.0; components.len()];
            let mut j = first;
            while at(j) <= until {
                step.eval_components_at(&[at(j)], components, &mut row);
                for (&i, &v) in components.iter().zip(&row) {
                    self.probe_state[i] = v;
                }
                let state = &self.probe_state;
                copy.sample(at(j), self.probes.value(k, &|i: usize| state[i]));
                tests::SKIPPED.with(|c| c.set(c.get() + 1));
                j += 1;
            }
            tests::assert_same_tracker(&self.trackers[k], &copy);
        }
    }

    /// Locates each probe's peaks on the dense output over the step `[a, b]` (`b` the record's
    /// last instant in it) where they may lie (see [`super::peaks`]): a probe whose samples or
    /// ends in the step come within the step's own swing (and a thousandth of the excursion so
    /// far) of its largest value is maximised over the step, for its record maximum, and over the
    /// part of the step its leading pulse spans, for its leading peak. Settled probes are not:
    /// their every value in the step is below their record.
    fn locate_peaks(&mut self, step: &dyn DenseStep, a: f64, b: f64) {
        let exact_end = b == step.t_end();
        for k in 0..self.trackers.len() {
            let end_value = if exact_end {
                let y = step.y_end();
                self.probes.value(k, &|i: usize| y[i])
            } else {
                let components = &self.components_of[k];
                for &i in components {
                    self.probe_state[i] = step.eval_component(b, i);
                }
                let state = &self.probe_state;
                self.probes.value(k, &|i: usize| state[i])
            };
            let start_value = std::mem::replace(&mut self.last_value[k], end_value);
            let (lo, hi) =
                std::mem::replace(&mut self.step_range[k], (f64::INFINITY, f64::NEG_INFINITY));
            if self.settled[k] {
                continue;
            }
            let top = hi.max(start_value).max(end_value);
            let swing = top - lo.min(start_value).min(end_value);
            let tracker = &mut self.trackers[k];
            let near = |peak: f64| {
                let excursion = (peak - tracker.baseline).abs();
                top + swing + 1e-3 * excursion >= peak
            };
            let record = near(tracker.record.peak);
            let leading = tracker
                .leading_span(a, b, self.opts.summary_interval)
                .filter(|_| near(tracker.leading.peak));
            if !record && leading.is_none() {
                continue;
            }
            let components = &self.components_of[k];
            let probes = &self.probes;
            let state = &mut self.probe_state;
            let mut value_at = |t: f64| {
                for &i in components {
                    state[i] = step.eval_component(t, i);
                }
                let state = &*state;
                probes.value(k, &|i: usize| state[i])
            };
            let spacing = 0.5 * self.opts.summary_interval;
            let whole = record.then(|| maximise(a, b, spacing, &mut value_at));
            if let Some((v, t)) = whole {
                tracker.record.consider(t, v);
            }
            if let Some((lo, hi)) = leading {
                let (v, t) = match whole {
                    Some(found) if (lo, hi) == (a, b) => found,
                    _ => maximise(lo, hi, spacing, &mut value_at),
                };
                tracker.leading.consider(t, v);
            }
        }
    }

    /// Locates the largest contact overlap on the dense output over the step, where the largest
    /// overlap at either end of the step (`end_max` at its end) comes within a tenth of the
    /// largest so far: each contact of the moving part that is opening at the step's end from a
    /// peak that could lie above the largest so far (its overlap plus its rate over the step), and
    /// was closing at the step's start with the cubic through its ends' overlaps and rates
    /// reaching within a thousandth of it, is maximised over the step.
    fn locate_max_overlap(&mut self, step: &dyn DenseStep, end_max: f64) {
        let start_max = std::mem::replace(&mut self.last_max_overlap, end_max);
        let mut found = self.max_overlap;
        if found <= 0.0 || start_max.max(end_max) < 0.9 * found {
            return;
        }
        let (a, b) = (step.t_start(), step.t_end());
        let h = b - a;
        let y1 = step.y_end();
        let at_start = |i: usize| step.eval_component(a, i);
        for c in 0..self.n_contacts.min(self.active) {
            let (d1, r1) = self.contacts.kinematics(c, |i| y1[i]);
            if r1 >= 0.0 || d1 - r1 * h < 0.999 * found {
                continue;
            }
            let (d0, r0) = self.contacts.kinematics(c, at_start);
            if r0 <= 0.0 || hermite_max(h, (d0, r0), (d1, r1)) < 0.999 * found {
                continue;
            }
            let contacts = &self.contacts;
            let (d, _) = maximise(a, b, h, |t| {
                contacts.overlap_read(c, |i| step.eval_component(t, i))
            });
            found = found.max(d);
        }
        self.max_overlap = found;
    }

    pub fn new(
        chain: &Chain,
        probes: ProbeSet,
        opts: ObserverOptions,
        t0: f64,
        t_end: f64,
    ) -> Self {
        let n_probes = probes.len();
        let history = opts.history.then(|| {
            // Bounded whatever the caller validated: a history longer than this grows as it goes.
            let cap = ((t_end - t0) / opts.history_interval)
                .floor()
                .min(max_history_samples(n_probes) as f64) as usize
                + 1;
            History {
                time_s: Vec::with_capacity(cap),
                values: (0..n_probes).map(|_| Vec::with_capacity(cap)).collect(),
            }
        });
        let probe_components = probes.components();
        let probe_state = vec![0.0; probe_components.last().map_or(0, |i| i + 1)];
        let components_of = (0..n_probes).map(|k| probes.components_of(k)).collect();
        RunObserver {
            components_of,
            settled: vec![false; n_probes],
            settle_wait: vec![(0, 0); n_probes],
            live_components: Vec::with_capacity(probe_components.len()),
            batch_values: vec![0.0; SAMPLE_BATCH * probe_components.len()],
            probe_components,
            probe_state,
            started: false,
            stopped: false,
            first_energy: None,
            deadline: None,
            deadline_reached: false,
            stop_flag: None,
            interrupted: false,
            steps_since_clock: 0,
            state: None,
            ledger: Ledger::new(chain),
            probes,
            t0,
            t_end,
            e0: 0.0,
            p0: 0.0,
            external0: 0.0,
            work_max: 0.0,
            trackers: Vec::new(),
            next_summary: 0,
            next_history: 0,
            history,
            min_overlap: opts
                .min_overlap
                .then(|| vec![f64::INFINITY; chain.n_contacts()]),
            fields: opts
                .fields
                .as_ref()
                .map(|(spec, preload)| FieldRecorder::new(chain, spec, *preload, t0, t_end)),
            steady: opts
                .steady_state
                .as_ref()
                .map(|(spec, f)| SteadyRecorder::new(spec, *f, n_probes)),
            flow: opts
                .energy_flow
                .then(|| FlowRecorder::new(chain, opts.impact_energy)),
            energy_drift_max: 0.0,
            energy_drift_final: 0.0,
            momentum_residual_max: 0.0,
            max_overlap: 0.0,
            last_energy: None,
            t_reached: t0,
            n: chain.n_particles(),
            n_contacts: chain.n_contacts(),
            contacts: ContactMap::of(chain),
            opts,
            active: chain.n_particles(),
            frozen_energy: (0.0, 0.0),
            frozen_max_overlap: 0.0,
            last_value: vec![f64::NAN; n_probes],
            step_range: vec![(f64::INFINITY, f64::NEG_INFINITY); n_probes],
            last_max_overlap: 0.0,
            balance: Self::uses_static_balance(chain).then(|| (StaticBalance::new(chain), 0.0)),
            motion_max: 0.0,
        }
    }

    /// Whether the energy drift is measured from the static state ([`StaticBalance`]): where a
    /// precompression, a drive or a load cell loads the chain, whose static energy would otherwise
    /// bury a small motion's balance in its rounding. (The paper's chains, loaded by their weight
    /// alone, keep the ledger's total.)
    fn uses_static_balance(chain: &Chain) -> bool {
        chain.static_overlap.iter().any(|&d| d > 0.0)
            && (chain.precompression_force_n > 0.0
                || chain.drive.is_some()
                || chain.wall_mount.is_some())
    }

    /// Only the first `k` particles move from now on; the rest stay at rest at their positions
    /// in the full state `y` (and so does the wall impulse's rate): the ledger then sums over the
    /// moving part only and adds the constant terms of the rest, computed here once.
    pub fn set_active(&mut self, k: usize, y: &[f64]) {
        self.active = k;
        if k == self.n {
            return;
        }
        let whole = self.ledger.energy(y);
        let part = self.ledger.energy_prefix(y, k);
        self.frozen_energy = (
            whole.elastic - part.elastic,
            whole.gravitational - part.gravitational,
        );
        self.frozen_max_overlap = (k..self.n_contacts)
            .map(|c| self.contacts.overlap(c, y))
            .fold(0.0, f64::max);
    }

    pub fn summaries(&self) -> Vec<ProbeSummary> {
        self.trackers
            .iter()
            .map(|tr| {
                // A leading peak counts only once the signal has fallen after it: a run that ends
                // while the pulse is still rising has no leading peak yet.
                let (lv, lt) = if tr.leading.after >= 1 {
                    tr.leading.located()
                } else {
                    (f64::NAN, f64::NAN)
                };
                let (rv, rt) = tr.record.located();
                ProbeSummary {
                    leading_peak: lv,
                    leading_peak_time_s: lt,
                    record_max: rv,
                    record_max_time_s: rt,
                }
            })
            .collect()
    }

    fn update_ledger(&mut self, t: f64, y: &[f64]) {
        let k = self.active;
        let e = if k == self.n {
            self.ledger.energy(y)
        } else {
            let mut e = self.ledger.energy_prefix(y, k);
            e.elastic += self.frozen_energy.0;
            e.gravitational += self.frozen_energy.1;
            e.max_overlap = e.max_overlap.max(self.frozen_max_overlap);
            e
        };
        let drift = if let Some((balance, start)) = &self.balance {
            let b = balance.terms(y, k);
            self.motion_max = self.motion_max.max(b.motion);
            self.work_max = self.work_max.max(b.work.abs());
            let scale = if self.opts.driven {
                self.opts
                    .impact_energy
                    .max(self.work_max)
                    .max(self.motion_max)
            } else {
                self.opts.impact_energy
            };
            (b.total - start).abs() / scale
        } else {
            let scale = if self.opts.driven {
                self.work_max = self.work_max.max((e.external - self.external0).abs());
                self.opts.impact_energy.max(self.work_max)
            } else {
                self.opts.impact_energy
            };
            (e.total() - self.e0).abs() / scale
        };
        self.energy_drift_max = self.energy_drift_max.max(drift);
        self.energy_drift_final = drift;
        let r = self
            .ledger
            .momentum_residual_prefix(y, k, t, self.t0, self.p0)
            .abs()
            / self.opts.impact_momentum;
        self.momentum_residual_max = self.momentum_residual_max.max(r);
        self.last_energy = Some(e);
        self.max_overlap = self.max_overlap.max(e.max_overlap);
        if let Some(mins) = &mut self.min_overlap {
            // Contacts between particles at rest keep their overlap.
            for (c, m) in mins.iter_mut().enumerate().take(self.n_contacts.min(k)) {
                *m = m.min(self.contacts.overlap(c, y));
            }
        }
    }

    /// The space–time fields recorded, when asked for (taken: a second call gives `None`).
    pub fn take_fields(&mut self) -> Option<Fields> {
        self.fields.take().map(|f| f.out)
    }

    /// The energy flow, when asked for (taken: a second call gives `None`).
    pub fn take_energy_flow(&mut self) -> Option<EnergyFlow> {
        self.flow.take().map(FlowRecorder::finish)
    }

    /// The steady state analysed, when asked for (taken: a second call gives `None`).
    pub fn take_steady_state(&mut self) -> Option<SteadyState> {
        self.steady.take().map(|s| s.finish())
    }
}

impl StepObserver for RunObserver {
    fn on_start(&mut self, t0: f64, y0: &[f64]) {
        if self.started {
            // A new leg: it starts where the last accepted step ended, already recorded.
            debug_assert_eq!(t0, self.t_reached);
            return;
        }
        self.started = true;
        if let Some(s) = &mut self.state {
            s.copy_from_slice(y0);
        }
        let e0 = self.ledger.energy(y0);
        self.e0 = e0.total();
        self.first_energy = Some(e0);
        if let Some((balance, start)) = &mut self.balance {
            *start = balance.terms(y0, self.n).total;
        }
        self.external0 = e0.external;
        self.p0 = self.ledger.momentum(y0);
        let get = |i: usize| y0[i];
        self.trackers = (0..self.probes.len())
            .map(|k| {
                let base = self.probes.value(k, &get);
                PeakTracker::new(
                    base,
                    self.opts.arrival_fraction * self.probes.scale[k],
                    self.opts.release_fraction,
                )
            })
            .collect();
        // The initial state is whole: every contact's overlap enters the minima once.
        let active = std::mem::replace(&mut self.active, self.n);
        self.update_ledger(t0, y0);
        self.active = active;
        for (k, tr) in self.trackers.iter_mut().enumerate() {
            let v = self.probes.value(k, &get);
            tr.sample(t0, v);
            self.last_value[k] = v;
        }
        self.last_max_overlap = self.max_overlap;
        self.next_summary = 1;
        if let Some(h) = &mut self.history {
            h.time_s.push(t0);
            for (k, series) in h.values.iter_mut().enumerate() {
                series.push(self.probes.value(k, &get));
            }
        }
        self.next_history = 1;
        if let Some(f) = &mut self.fields {
            f.start(t0, y0);
        }
        if let Some(f) = &mut self.flow {
            f.start(y0);
        }
        self.t_reached = t0;
    }

    fn on_step(&mut self, step: &dyn DenseStep) -> Control {
        let t1 = step.t_end();
        let n_probes = self.probes.len();
        // The record's last instant in this step: the step's end, or, for a run that stops after
        // its leading pulses, the summary instant at which the last of them is seen to pass. The
        // step goes on past that instant by however far the integrator's step size took it, and
        // a record reaching beyond it would depend on the step sizes (a probe still rising there
        // would put its record maximum wherever the last step happened to end).
        let mut until = t1.min(self.t_end);
        let mut passed_at: Option<f64> = None;
        if n_probes > 0 {
            #[cfg(test)]
            let first_summary = self.next_summary;
            let any_settled = self.settle(step, until);
            let probes = &self.probes;
            let trackers = &mut self.trackers;
            let step_range = &mut self.step_range;
            let settled = &self.settled;
            let stop_when_passed = self.opts.stop_after_leading_pulses;
            let components = if any_settled {
                &self.live_components
            } else {
                &self.probe_components
            };
            sample_grid(
                step,
                (self.t0, self.opts.summary_interval),
                &mut self.next_summary,
                until,
                components,
                &mut self.batch_values[..],
                &mut self.probe_state,
                |ts, state| {
                    if passed_at.is_some() {
                        return;
                    }
                    let g = |i: usize| state[i];
                    for (k, tracker) in trackers.iter_mut().enumerate() {
                        if !settled[k] {
                            let v = probes.value(k, &g);
                            tracker.sample(ts, v);
                            let r = &mut step_range[k];
                            *r = (r.0.min(v), r.1.max(v));
                        }
                    }
                    // A settled tracker's phase stays as it is over the step.
                    if stop_when_passed && trackers.iter().all(|t| t.phase == PulsePhase::Passed) {
                        passed_at = Some(ts);
                    }
                },
            );
            if let Some(t) = passed_at {
                until = t;
            }
            #[cfg(test)]
            if any_settled {
                self.sample_settled(step, first_summary, until);
            }
            self.locate_peaks(step, step.t_start(), until);
            let probes = &self.probes;
            if let Some(h) = &mut self.history {
                sample_grid(
                    step,
                    (self.t0, self.opts.history_interval),
                    &mut self.next_history,
                    until,
                    &self.probe_components,
                    &mut self.batch_values[..],
                    &mut self.probe_state,
                    |th, state| {
                        let g = |i: usize| state[i];
                        h.time_s.push(th);
                        for (k, series) in h.values.iter_mut().enumerate() {
                            series.push(probes.value(k, &g));
                        }
                    },
                );
            }
            if let Some(s) = self.steady.as_mut().filter(|s| !s.complete()) {
                // Up to the window's last instant, so that nothing is sampled after it.
                let last = s.last_instant_s();
                let mut next = s.next;
                let mut j = next;
                sample_grid(
                    step,
                    (s.start_s, s.interval_s),
                    &mut next,
                    until.min(last),
                    &self.probe_components,
                    &mut self.batch_values[..],
                    &mut self.probe_state,
                    |t, state| {
                        let g = |i: usize| state[i];
                        s.sample(j, t, |k| probes.value(k, &g));
                        j += 1;
                    },
                );
                s.next = next;
            }
        }
        if let Some(f) = &mut self.fields {
            f.step(step, self.t0, until);
        }
        if let Some(f) = &mut self.flow {
            f.step(step);
        }
        self.update_ledger(t1, step.y_end());
        if let Some(e) = self.last_energy {
            self.locate_max_overlap(step, e.max_overlap);
        }
        self.t_reached = t1;
        if let Some(s) = &mut self.state {
            s.copy_from_slice(step.y_end());
        }
        if passed_at.is_some() {
            self.stopped = true;
            return Control::Stop;
        }
        if let Some(flag) = &self.stop_flag {
            if flag.load(std::sync::atomic::Ordering::Relaxed) {
                self.interrupted = true;
                self.stopped = true;
                return Control::Stop;
            }
        }
        if let Some(deadline) = self.deadline {
            self.steps_since_clock += 1;
            if self.steps_since_clock >= DEADLINE_CHECK_STEPS {
                self.steps_since_clock = 0;
                if Instant::now() >= deadline {
                    self.deadline_reached = true;
                    self.stopped = true;
                    return Control::Stop;
                }
            }
        }
        Control::Continue
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Two trackers in the same state, to the bit.
    pub(super) fn assert_same_tracker(a: &PeakTracker, b: &PeakTracker) {
        let window = |w: &super::super::peaks::PeakWindow| {
            vec![
                w.best.to_bits(),
                w.time.to_bits(),
                w.after as u64,
                w.peak.to_bits(),
                w.peak_time.to_bits(),
            ]
        };
        let bits = |t: &PeakTracker| {
            let mut v = window(&t.leading);
            v.extend(window(&t.record));
            v.extend([t.arrived_at.to_bits(), t.passed_at.to_bits()]);
            v
        };
        assert_eq!(a.phase, b.phase, "a settled tracker's phase changed");
        assert_eq!(
            bits(a),
            bits(b),
            "skipping a settled tracker's samples changed it"
        );
    }

    thread_local! {
        /// Set: no probe settles ([`RunObserver::settle`]), every sample is taken.
        pub(super) static NO_SETTLING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
        /// Samples settled probes skipped on this thread ([`RunObserver::sample_settled`]).
        pub(super) static SKIPPED: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
    }

    /// Samples skipped where a probe is settled change nothing: the Fig. 8 sweep's chain (the
    /// paper's 0.55 chain of 50 cylinders, gauges in cylinders 4 and 21, stopped after the leading
    /// pulses, DOP853 rtol 1e-8 with switch prediction), without and with damping and at a heavy
    /// and a light mass ratio, run as it is and with every sample taken gives every summary, the
    /// run's end, its counts and its ledger to the bit; and the first run did skip most of the
    /// gauge in cylinder 4's samples after its pulse passed, and cylinder 21's before the pulse
    /// came near.
    #[test]
    fn settled_probes_skip_samples_and_change_nothing() {
        use crate::chain::model::{ChainSpec, CylinderMass, DimerSpec};
        use crate::scene::solve::run;
        use crate::scene::{IntegratorSpec, Scene};
        use crate::AdaptiveOptions;
        /// Every summary, the run's end, its counts and its ledger, as bits.
        fn bits(o: &crate::scene::solve::RunOutput) -> Vec<u64> {
            let mut v: Vec<u64> = o
                .probes
                .iter()
                .flat_map(|p| {
                    [
                        p.leading_peak,
                        p.leading_peak_time_s,
                        p.record_max,
                        p.record_max_time_s,
                    ]
                })
                .map(f64::to_bits)
                .collect();
            v.extend(
                [
                    o.t_end_s,
                    o.energy_drift_max,
                    o.energy_drift_final,
                    o.momentum_residual_max,
                ]
                .map(f64::to_bits),
            );
            v.extend([o.stats.steps, o.stats.rejected, o.stats.rhs_evals]);
            v
        }
        /// The scene run as it is and with every sample taken, which must agree to the bit:
        /// the first run's output and how many samples it skipped.
        fn both_ways(s: &Scene, case: &str) -> (crate::scene::solve::RunOutput, u64) {
            SKIPPED.with(|c| c.set(0));
            let skipping = run(s).unwrap();
            let skipped = SKIPPED.with(|c| c.get());
            NO_SETTLING.with(|c| c.set(true));
            let every = run(s).unwrap();
            NO_SETTLING.with(|c| c.set(false));
            assert_eq!(
                SKIPPED.with(|c| c.get()),
                skipped,
                "{case}: skipped without settling"
            );
            assert_eq!(bits(&skipping), bits(&every), "{case}");
            (skipping, skipped)
        }
        let dop853 = IntegratorSpec::Dop853(AdaptiveOptions {
            predict_switches: true,
            ..AdaptiveOptions::new(1e-8)
        });
        for (mass_ratio, mu) in [(0.2, 0.0), (0.2, 6.0), (0.9, 0.0), (0.9, 6.0)] {
            let mut spec = DimerSpec::chain_055(50);
            spec.cylinder.mass = CylinderMass::HeavyCylinders { mass_ratio };
            spec.cylinder.height_m = None;
            let mut s = Scene::new(ChainSpec::Dimer(spec), 1.3, 3e-3);
            s.physics.damping_kg_s = mu;
            s.integrator = dop853;
            s.record.probes = vec![
                Probe::GaugeForce { cylinder: 4 },
                Probe::GaugeForce { cylinder: 21 },
            ];
            s.record.stop_after_leading_pulses = true;
            let case = format!("mass ratio {mass_ratio}, μ = {mu} kg/s");
            let (skipping, skipped) = both_ways(&s, &case);
            let samples = (skipping.t_end_s / s.record.summary_interval_s) as u64;
            assert!(
                skipped > samples / 2,
                "{case}: {skipped} of the two probes' {samples} samples each skipped"
            );
            assert!(
                skipping.probes.iter().all(|p| p.leading_peak.is_finite()),
                "{case}"
            );
        }
        // A short chain on its wall, integrated whole, a gauge next to the wall and run past the
        // leading pulse: the wave reflected there brings a record maximum above the leading peak
        // after samples were skipped, which the bound must let through.
        for mu in [0.0, 6.0] {
            let mut s = Scene::new(ChainSpec::chain_055(10), 1.3, 4e-4);
            s.physics.damping_kg_s = mu;
            s.integrator = dop853;
            s.record.probes = vec![
                Probe::GaugeForce { cylinder: 2 },
                Probe::GaugeForce { cylinder: 9 },
            ];
            // Sampled finely, so that the steps while the reflected wave rises hold samples
            // enough to be looked at.
            s.record.summary_interval_s = 2e-8;
            let case = format!("10 cylinders, μ = {mu} kg/s");
            let (skipping, skipped) = both_ways(&s, &case);
            assert!(skipped > 100, "{case}: {skipped} samples skipped");
            let near_wall = &skipping.probes[1];
            assert!(
                near_wall.record_max > 1.1 * near_wall.leading_peak
                    && near_wall.record_max_time_s > near_wall.leading_peak_time_s,
                "{case}: {near_wall:?}"
            );
        }
    }

    /// The force of contact `c` as it was computed before contacts without damping were read
    /// from their overlap alone: the law on the overlap and its rate, both always read.
    fn force_from_overlap_and_rate(probes: &ProbeSet, c: usize, get: impl Fn(usize) -> f64) -> f64 {
        let (overlap, rel) = probes.contacts.kinematics(c, get);
        let clip = probes.clip;
        let Some((p, tsuji)) = probes.general_params(c) else {
            let (a, mu) = (probes.stiffness[c], probes.damping[c]);
            return if clip {
                paper_contact_force::<true, true>(a, mu, overlap, rel).0
            } else {
                paper_contact_force::<true, false>(a, mu, overlap, rel).0
            };
        };
        if tsuji {
            general_force::<POWER, true, true>(&p, overlap, rel, clip).0
        } else {
            general_force::<POWER, true, false>(&p, overlap, rel, clip).0
        }
    }

    /// Without damping a contact's force does not depend on its rate: the force and overlap
    /// probes of an undamped chain read positions only (the sampling loop interpolates no
    /// velocity), those of a damped chain velocities too, and every probe gives, to the bit, the
    /// law evaluated on the contact's overlap and rate — the paper's chain with and without
    /// damping and clipping, and chains under a general law without damping and with each
    /// dissipation model.
    #[test]
    fn force_probes_read_velocities_only_where_damping_acts() {
        use crate::chain::model::{ChainSpec, PhysicsSpec};
        use crate::contact::DissipationSpec;
        use crate::problems::{chain, power_law, repeat, rule, sphere, STEEL};
        let paper = |damping_kg_s: f64, clip_tensile: bool| {
            let physics = PhysicsSpec {
                damping_kg_s,
                clip_tensile,
                ..PhysicsSpec::default()
            };
            let chain = Chain::build(&ChainSpec::chain_055(4), &physics).unwrap();
            (chain, damping_kg_s > 0.0, "the paper's chain")
        };
        let general = |dissipation: Option<DissipationSpec>, clip_tensile: bool| {
            let law = Some(power_law(2e9, 2.0));
            let spec = chain(
                &[("ball", sphere(STEEL, 8e-3, 2.085e-3))],
                vec![repeat(5, "ball")],
                Some("ball"),
                vec![
                    rule("ball", "ball", law, dissipation),
                    rule("ball", "wall", law, dissipation),
                ],
            );
            let physics = PhysicsSpec {
                clip_tensile,
                ..PhysicsSpec::default()
            };
            let chain = Chain::build(&ChainSpec::Sequence(spec), &physics).unwrap();
            assert!(!chain.is_paper_physics());
            (chain, dissipation.is_some(), "a chain under F = A δ²")
        };
        let chains = [
            paper(0.0, false),
            paper(0.0, true),
            paper(6.0, false),
            paper(6.0, true),
            general(None, false),
            general(None, true),
            general(
                Some(DissipationSpec::KuwabaraKono {
                    relaxation_time_s: 1e-6,
                }),
                true,
            ),
            general(
                Some(DissipationSpec::HuntCrossley {
                    restitution: 0.8,
                    impact_velocity_m_s: 1.0,
                }),
                false,
            ),
            general(Some(DissipationSpec::Tsuji { restitution: 0.8 }), false),
        ];
        let cylinder_probes = [
            Probe::GaugeForce { cylinder: 2 },
            Probe::ContactForce { contact: 4 },
            Probe::Overlap { contact: 2 },
            Probe::WallForce,
        ];
        let sphere_probes = [
            Probe::ParticleForce { particle: 3 },
            Probe::ContactForce { contact: 4 },
            Probe::Overlap { contact: 2 },
            Probe::WallForce,
        ];
        for (chain, damped, what) in chains {
            let list = if chain.cylinders().is_empty() {
                &sphere_probes
            } else {
                &cylinder_probes
            };
            let n = chain.n_particles();
            let probes = ProbeSet::new(&chain, list, Preload::Include, 1.0, 1.0, 1.0);
            let velocities = probes
                .components()
                .into_iter()
                .filter(|i| (n..2 * n).contains(i))
                .count();
            let clip = chain.clip_tensile;
            assert_eq!(velocities > 0, damped, "{what}, clip {clip}");
            // Contacts compressed, just touching and open, closing and opening.
            let mut y = chain.initial_state(0.0);
            let overlaps = [2e-6, 0.0, -1e-7, 3e-7, 1e-6];
            let rates = [-0.3, 0.2, -0.0, 1e-3, -2e-3];
            for c in 0..n - 1 {
                y[c + 1] = y[c] - overlaps[c % overlaps.len()];
                y[n + c + 1] = y[n + c] - rates[c % rates.len()];
            }
            let get = |i: usize| y[i];
            for (k, compiled) in probes.compiled.iter().enumerate() {
                let expected = match *compiled {
                    Compiled::Contacts {
                        first,
                        count,
                        inv_count,
                        offset,
                    } => mean_force(first..first + count, inv_count, offset, |c| {
                        force_from_overlap_and_rate(&probes, c, get)
                    }),
                    Compiled::Overlap { contact } => probes.contacts.kinematics(contact, get).0,
                    _ => unreachable!("only force and overlap probes here"),
                };
                let value = probes.value(k, &get);
                assert_eq!(
                    value.to_bits(),
                    expected.to_bits(),
                    "{what}, clip {clip}, probe {}: {value:e} against {expected:e}",
                    list[k].name()
                );
            }
        }
    }

    /// `samples_in` counts the instants the sampling loop takes, including where the quotient
    /// `t_end / interval` rounds to the wrong side of an integer (1e-3 / 1e-6, 0.3 / 0.1, …).
    #[test]
    fn samples_in_counts_what_the_sampling_loop_takes() {
        let mut rng = crate::contact::SplitMix64(7);
        let mut cases = vec![
            (1e-6, 1e-3),
            (0.1, 0.3),
            (1e-7, 2e-4),
            (3e-6, 1e-3),
            (1.0, 0.0),
        ];
        for _ in 0..2000 {
            let dt = 10f64.powf(-7.0 + 3.0 * (rng.symmetric() + 1.0) / 2.0);
            let k = (rng.next_u64() % 5000) as f64;
            cases.push((dt, k * dt));
            cases.push((dt, k * dt * (1.0 + 1e-15)));
        }
        for (dt, t_end) in cases {
            let mut count = 0u64;
            let mut times = [0.0; SAMPLE_BATCH];
            loop {
                let c = batch_times(0.0, count, dt, t_end, &mut times);
                count += c as u64;
                if c < SAMPLE_BATCH {
                    break;
                }
            }
            assert_eq!(
                samples_in(0.0, dt, t_end),
                count,
                "interval {dt:e}, end {t_end:e}"
            );
        }
    }
}
