//! The one table of stored summary columns: every dataset the output file holds per grid point,
//! with its name, dtype, shape, units, description, and how it is filled from a point's run and
//! verification (and read back into a run record). The HDF5 writer and reader, the store's
//! snapshot, the check that no axis takes a stored name, and the table in `docs/REFERENCE.md` all
//! come from [`COLUMNS`].
//!
//! Every stored value of a point is covered by its checksum ([`Table::point_checksum`]): the
//! `summary_checksum` column holds, per point, the first 8 bytes of the SHA-256 of every other
//! column's value at that point (the `history_checksum` of its run group included), so that a
//! reader finds out which points of a damaged file it can still trust. A pending point holds no
//! run: no run hash, checksum 0 and nothing but fill values, which is what it is checked for.
//!
//! Its parts: [`COLUMNS`] itself, pure data (`table`); filling a [`Table`] from the grid points'
//! runs (`fill`); reading a table back into run records (`read`); the checksums of a run's arrays
//! and of a point's values (`checksum`).

#[cfg(doc)]
use chainsweep_solver::observe::flow::EnergyFlow;
use chainsweep_solver::observe::probes::ProbeSummary;
use chainsweep_solver::observe::steady::SteadyProbe;

use super::{RunRecord, INT_FILL};
#[cfg(doc)]
use super::{VerifyInfo, STATUS_FAILED, STATUS_OK, STATUS_PENDING, VERIFY_NONE};

mod checksum;
mod fill;
mod read;
mod table;

pub use checksum::history_checksum;
pub use fill::{ColumnData, PointOutcome, Table};
pub use table::COLUMNS;

/// Element type of a column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dtype {
    /// 64-bit float.
    F64,
    /// 64-bit signed integer.
    I64,
    /// 8-bit unsigned integer (a flag).
    U8,
    /// 64-bit unsigned integer (a checksum).
    U64,
    /// Variable-length UTF-8 string.
    Str,
}

impl Dtype {
    /// The name numpy gives it.
    pub fn numpy(self) -> &'static str {
        match self {
            Dtype::F64 => "float64",
            Dtype::I64 => "int64",
            Dtype::U8 => "uint8",
            Dtype::U64 => "uint64",
            Dtype::Str => "str",
        }
    }
}

/// What the `units` attribute of a column says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Units {
    /// No `units` attribute (text, and flags: their values are codes, not quantities).
    None,
    /// This unit.
    Fixed(&'static str),
    /// The unit of the probes. Where the probes' units differ, the column is stored once per unit
    /// ([`split_name`]), each dataset in its one unit.
    OfProbes,
}

/// The part of a variable's name that stands for a unit: its letters and digits, `/` as `_per_`
/// and anything else as `_` (`N`, `m`, `m_per_s`).
pub fn unit_suffix(unit: &str) -> String {
    unit.split('/')
        .map(|part| {
            part.chars()
                .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                .collect::<String>()
        })
        .collect::<Vec<_>>()
        .join("_per_")
}

/// The dataset holding per-probe column `column` (one of [`Units::OfProbes`]) for the probes
/// measured in `unit`, in a file whose probes' units differ (`leading_peak_N`,
/// `leading_peak_m_per_s`): over every probe like the column, NaN at the probes of other units.
pub fn split_name(column: &str, unit: &str) -> String {
    format!("{column}_{}", unit_suffix(unit))
}

/// Every unit a probe measures in (the solver's [`Probe::unit`] of each kind of probe).
///
/// [`Probe::unit`]: chainsweep_solver::observe::probes::Probe::unit
pub const PROBE_UNITS: &[&str] = &["N", "m", "m/s"];

/// The datasets ([`split_name`]) of the columns in the probes' unit for every unit of
/// [`PROBE_UNITS`]: names no axis may take.
pub const SPLIT_NAMES: &[&str] = &[
    "leading_peak_N",
    "leading_peak_m",
    "leading_peak_m_per_s",
    "record_max_N",
    "record_max_m",
    "record_max_m_per_s",
    "steady_mean_N",
    "steady_mean_m",
    "steady_mean_m_per_s",
    "steady_rms_N",
    "steady_rms_m",
    "steady_rms_m_per_s",
    "steady_amplitude_N",
    "steady_amplitude_m",
    "steady_amplitude_m_per_s",
];

/// The distinct units of `probe_units`, in the order they first appear.
pub fn distinct_units(probe_units: &[String]) -> Vec<&str> {
    let mut out: Vec<&str> = Vec::new();
    for u in probe_units {
        if !out.contains(&u.as_str()) {
            out.push(u);
        }
    }
    out
}

/// Whether root dataset `name` holds a column: named like one, or one of [`SPLIT_NAMES`].
pub fn is_column_dataset(name: &str) -> bool {
    column(name).is_some() || SPLIT_NAMES.contains(&name)
}

/// How a column is filled from a grid point's outcome, and how it is read back into a record.
#[derive(Clone, Copy)]
pub enum Fill {
    /// A number of a successful run; NaN elsewhere.
    OkF64 {
        /// The value in a record.
        get: fn(&RunRecord) -> f64,
        /// Puts it back.
        set: fn(&mut RunRecord, f64),
    },
    /// A number of every finished run, failed ones included; NaN where pending.
    RunF64 {
        /// The value in a record.
        get: fn(&RunRecord) -> f64,
        /// Puts it back.
        set: fn(&mut RunRecord, f64),
    },
    /// A count of a successful run; [`INT_FILL`] elsewhere.
    OkCount {
        /// The value in a record.
        get: fn(&RunRecord) -> u64,
        /// Puts it back.
        set: fn(&mut RunRecord, u64),
    },
    /// A count of a successful run where it is known; [`INT_FILL`] elsewhere.
    OkOptCount {
        /// The value in a record.
        get: fn(&RunRecord) -> Option<u64>,
        /// Puts it back.
        set: fn(&mut RunRecord, Option<u64>),
    },
    /// A flag of a successful run; 0 elsewhere.
    OkFlag {
        /// The value in a record.
        get: fn(&RunRecord) -> u8,
        /// Puts it back.
        set: fn(&mut RunRecord, u8),
    },
    /// Text of a successful run; empty elsewhere.
    OkText {
        /// The value in a record.
        get: fn(&RunRecord) -> &str,
        /// Puts it back.
        set: fn(&mut RunRecord, String),
    },
    /// Why a failed run failed; empty elsewhere.
    Reason,
    /// A number per probe of a successful run; NaN elsewhere.
    ProbeF64 {
        /// The value in a probe's summary.
        get: fn(&ProbeSummary) -> f64,
        /// Puts it back.
        set: fn(&mut ProbeSummary, f64),
    },
    /// A flag per probe of a successful run, derived from its summary (nothing to read back);
    /// 0 elsewhere.
    ProbeFlag {
        /// The flag of a probe's summary.
        get: fn(&ProbeSummary) -> u8,
    },
    /// A number per probe of a successful run's steady state; NaN elsewhere.
    SteadyF64 {
        /// The value in a probe's steady state.
        get: fn(&SteadyProbe) -> f64,
        /// Puts it back.
        set: fn(&mut SteadyProbe, f64),
    },
    /// A flag per probe of a successful run's steady state; 0 elsewhere.
    SteadyFlag {
        /// The flag of a probe's steady state.
        get: fn(&SteadyProbe) -> u8,
        /// Puts it back.
        set: fn(&mut SteadyProbe, u8),
    },
    /// A number per probe and harmonic of a successful run's steady state; NaN elsewhere.
    SteadyHarmonic {
        /// The values of a probe's steady state, one per harmonic.
        get: fn(&SteadyProbe) -> &[f64],
        /// The same, to put them back.
        set: fn(&mut SteadyProbe) -> &mut Vec<f64>,
    },
    /// The point's status: [`STATUS_PENDING`], [`STATUS_OK`] or [`STATUS_FAILED`].
    Status,
    /// The point's run hash (hex); empty where the point is pending.
    RunHash,
    /// The verification flag of a finished point ([`VERIFY_NONE`] elsewhere).
    Verified,
    /// The largest verification error of a verified point; NaN elsewhere.
    VerifyMax,
    /// The checksum of a successful run's group under `runs/` ([`history_checksum`]); 0 elsewhere.
    HistoryChecksum,
    /// The checksum of every other column's value at the point ([`Table::point_checksum`]),
    /// computed once the point's other columns are filled.
    SummaryChecksum,
    /// Verification error `k` of [`VerifyInfo::errors`] per probe of a verified point; NaN
    /// elsewhere.
    VerifyProbe(usize),
    /// Verification error `k` of [`VerifyInfo::run_errors`] of a verified point; NaN elsewhere.
    VerifyRun(usize),
    /// Term `term` of the energy ledger of a successful run ([`super::LEDGER_TERMS`]), at its
    /// end or its start; NaN elsewhere.
    Ledger {
        /// Which term.
        term: usize,
        /// At the end (else at the start).
        end: bool,
    },
}

impl Fill {
    /// Its name, for readers outside Rust (the Python package builds its labels from the table):
    /// what kind of value the column holds and where from.
    pub fn kind(&self) -> &'static str {
        match self {
            Fill::OkF64 { .. } => "ok_f64",
            Fill::RunF64 { .. } => "run_f64",
            Fill::OkCount { .. } => "ok_count",
            Fill::OkOptCount { .. } => "ok_opt_count",
            Fill::OkFlag { .. } => "ok_flag",
            Fill::OkText { .. } => "ok_text",
            Fill::Reason => "reason",
            Fill::ProbeF64 { .. } => "probe_f64",
            Fill::ProbeFlag { .. } => "probe_flag",
            Fill::SteadyF64 { .. } => "steady_f64",
            Fill::SteadyFlag { .. } => "steady_flag",
            Fill::SteadyHarmonic { .. } => "steady_harmonic",
            Fill::Status => "status",
            Fill::RunHash => "run_hash",
            Fill::Verified => "verified",
            Fill::VerifyMax => "verify_max",
            Fill::HistoryChecksum => "history_checksum",
            Fill::SummaryChecksum => "summary_checksum",
            Fill::VerifyProbe(_) => "verify_probe",
            Fill::VerifyRun(_) => "verify_run",
            Fill::Ledger { .. } => "ledger",
        }
    }
}

impl Written {
    /// Its name, for readers outside Rust.
    pub fn name(self) -> &'static str {
        match self {
            Written::Always => "always",
            Written::WithMovingPart => "with_moving_part",
            Written::WithRunGroups => "with_run_groups",
            Written::WithSpectrum => "with_spectrum",
            Written::WithSteadyState => "with_steady_state",
            Written::WithEnergyLedger => "with_energy_ledger",
        }
    }
}

/// Which output files have a column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Written {
    /// Every file (per-probe columns: every file with probes).
    Always,
    /// Files of grids where some point integrates only the moving part of its chain
    /// ([`chainsweep_solver::integrates_moving_part`]): elsewhere every run integrates its whole
    /// chain, and the column would repeat the chain's length (nothing on disk for a path not
    /// taken).
    WithMovingPart,
    /// Files whose runs record histories or minimum overlaps.
    WithRunGroups,
    /// Files of grids that record the linear spectrum (`record.spectrum`): nothing on disk for
    /// a result not asked for.
    WithSpectrum,
    /// Files of grids that record the steady state (`record.steady_state`).
    WithSteadyState,
    /// Files of grids that record the energy ledger (`record.energy_ledger`).
    WithEnergyLedger,
}

/// What decides which columns a file has: its grid's probes and recorded arrays.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Presence {
    /// Probes per point (per-probe columns only when there are some).
    pub probes: usize,
    /// Whether some point integrates only the moving part of its chain.
    pub moving_part: bool,
    /// Whether runs record histories or minimum overlaps (in layouts 4 and earlier: a group
    /// under `runs/`).
    pub run_groups: bool,
    /// Whether the grid records the linear spectrum.
    pub spectrum: bool,
    /// Harmonics of the steady state the grid records (0: none recorded).
    pub harmonics: usize,
    /// Whether the grid records the energy ledger.
    pub energy_ledger: bool,
}

/// One stored column.
#[derive(Clone, Copy)]
pub struct Column {
    /// Dataset name at the root of the file.
    pub name: &'static str,
    /// Element type.
    pub dtype: Dtype,
    /// One value per grid point and probe (shape `grid + (P,)`), else one per grid point.
    pub per_probe: bool,
    /// One value per grid point, probe and harmonic (shape `grid + (P, H)`, `per_probe` too):
    /// the steady state's amplitudes and phases.
    pub per_harmonic: bool,
    /// The `units` attribute.
    pub units: Units,
    /// What it holds, in words: written as the `comment` attribute when `long_name` is set.
    pub description: &'static str,
    /// Whether it has a `long_name` ([`Column::label`], what a plot labels it by) and a
    /// `comment` (`description`).
    pub long_name: bool,
    /// `flag_values` and `flag_meanings` attributes of a flag.
    pub flags: Option<(&'static [u8], &'static str)>,
    /// More for the documentation.
    pub note: &'static str,
    /// Whether every output file has it; the others read as their fill where absent (files
    /// without probes have no per-probe columns, older files lack later columns).
    pub required: bool,
    /// Which files have it.
    pub written: Written,
    /// How it is filled.
    pub fill: Fill,
}

/// The value a column holds where a point has none (a failed or pending run, a point not
/// verified): the dataset's HDF5 fill value and `_FillValue` attribute, by which xarray masks it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FillValue {
    /// NaN, in a float column.
    F64(f64),
    /// [`INT_FILL`], in a count.
    I64(i64),
}

impl Column {
    /// Its short name, the `long_name` a plot labels it by: its name without the unit suffix,
    /// words apart (`leading_peak_time_s` → `leading peak time`); what it is, in words, is its
    /// `description`.
    pub fn label(&self) -> String {
        crate::record::names::human_name(self.name)
    }

    /// Whether a file of this `presence` has this column (files of layout 3 and later: earlier
    /// layouts lack the checksum columns, and their readers take absent columns as fills).
    pub fn is_written(&self, presence: Presence) -> bool {
        (!self.per_probe || presence.probes > 0)
            && match self.written {
                Written::Always => true,
                Written::WithMovingPart => presence.moving_part,
                Written::WithRunGroups => presence.run_groups,
                Written::WithSpectrum => presence.spectrum,
                Written::WithSteadyState => presence.harmonics > 0,
                Written::WithEnergyLedger => presence.energy_ledger,
            }
    }

    /// Values per grid point: 1, the probes `np`, or probes × harmonics `np · nh`.
    pub fn width(&self, np: usize, nh: usize) -> usize {
        match (self.per_probe, self.per_harmonic) {
            (_, true) => np * nh,
            (true, false) => np,
            (false, false) => 1,
        }
    }

    /// The marker of a missing value: NaN in a float column, [`INT_FILL`] in a count. Flags
    /// (`status`, `verified`) and text have none: every point has a flag (0 says pending or not
    /// verified), and an empty text is a value.
    pub fn fill_value(&self) -> Option<FillValue> {
        match self.dtype {
            Dtype::F64 => Some(FillValue::F64(f64::NAN)),
            Dtype::I64 => Some(FillValue::I64(INT_FILL)),
            Dtype::U8 | Dtype::U64 | Dtype::Str => None,
        }
    }
}

/// Names the file uses at its root beside the columns: the probe coordinate, the probes' units,
/// the harmonic coordinate of the steady state, the group of full histories, and the dimensions
/// of the characters of the text columns and coordinates (`<name>_strlen`).
pub const LAYOUT_NAMES: &[&str] = &[
    "probe",
    HARMONIC,
    "probe_units",
    "runs",
    "reason_strlen",
    "warnings_strlen",
    "run_hash_strlen",
    "probe_strlen",
    "probe_units_strlen",
];

/// The coordinate of the steady state's harmonics (1, 2, …).
pub const HARMONIC: &str = "harmonic";

/// The histories of every probe (or of the probes of one unit: [`split_name`]).
pub const HISTORY: &str = "history";
/// How many history samples each run recorded.
pub const HISTORY_SAMPLES: &str = "history_samples";
/// The time axis (or, where the runs' intervals differ, every run's instants).
pub const TIME: &str = "time_s";
/// The dimension of the samples where the runs' intervals differ.
pub const SAMPLE: &str = "sample";
/// Minimum overlaps of every contact.
pub const MIN_OVERLAP: &str = "min_overlap_m";
/// The energy flow (`record.energy_flow`): each variable's name, whether it is over the contacts
/// (else the particles) and its long name, in the order of the [`EnergyFlow`] fields.
pub const ENERGY_FLOW: [(&str, bool, &str); 3] = [
    ("energy_passed_max_j", true, "largest energy passed"),
    ("energy_passed_final_j", true, "energy passed at the end"),
    ("max_kinetic_energy_j", false, "largest kinetic energy"),
];
/// What each of [`ENERGY_FLOW`]'s variables is (its `comment`; the long name is short, a plot's
/// label), in the same order.
pub const ENERGY_FLOW_COMMENTS: [&str; 3] = [
    "largest energy that had passed into the contact from the side of the struck end (contact N: the energy that reached the wall)",
    "energy that had passed into the contact from the side of the struck end by the end of the run",
    "largest kinetic energy of the particle over the run",
];
/// The contacts' coordinate.
pub const CONTACT: &str = "contact";
/// The particles' coordinate (of the particle fields).
pub const PARTICLE: &str = "particle";
/// The time axis of the space–time fields (`i · record.fields.interval_s`).
pub const FIELD_TIME: &str = "field_time_s";
/// How many field samples each run recorded.
pub const FIELD_SAMPLES: &str = "field_samples";
/// The variables of the space–time fields, one per quantity (`field_contact_force`,
/// `field_displacement`, `field_velocity`).
pub const FIELD_NAMES: &[&str] = &[
    "field_contact_force",
    "field_displacement",
    "field_velocity",
];

/// The variable of the space–time field of `quantity`.
pub fn field_name(quantity: chainsweep_solver::observe::probes::FieldQuantity) -> &'static str {
    FIELD_NAMES[usize::from(quantity.code())]
}

/// The names of the runs' arrays at a file's root (layout 5: the store's `hdf5::arrays`): no
/// axis may take them.
pub const ARRAY_NAMES: &[&str] = &[
    HISTORY,
    "history_N",
    "history_m",
    "history_m_per_s",
    HISTORY_SAMPLES,
    TIME,
    SAMPLE,
    MIN_OVERLAP,
    CONTACT,
    PARTICLE,
    FIELD_TIME,
    FIELD_SAMPLES,
    "field_contact_force",
    "field_displacement",
    "field_velocity",
];

/// Names a search's file adds at its root: its evaluations, objective and outcome.
pub const SEARCH_LAYOUT_NAMES: &[&str] = &[
    "evaluation",
    "objective",
    "evaluation_round",
    "search_status",
    "search_runs",
    "search_reason",
    "search_reason_strlen",
    "refine_error",
    "minimum",
    "maximum",
    "root",
];

/// Every name an axis may not take: the columns' and the layout's.
pub fn reserved_names() -> Vec<&'static str> {
    let mut names: Vec<&str> = COLUMNS.iter().map(|c| c.name).collect();
    names.extend_from_slice(LAYOUT_NAMES);
    names.extend_from_slice(ARRAY_NAMES);
    names.extend_from_slice(SEARCH_LAYOUT_NAMES);
    names.extend_from_slice(SPLIT_NAMES);
    names
}

/// The column named `name`.
pub fn column(name: &str) -> Option<&'static Column> {
    COLUMNS.iter().find(|c| c.name == name)
}

/// The table of columns as `docs/REFERENCE.md` shows it (a Markdown table).
pub fn markdown_table() -> String {
    let mut out =
        String::from("| dataset | shape | dtype | units | content |\n|---|---|---|---|---|\n");
    for c in COLUMNS {
        let shape = match (c.per_probe, c.per_harmonic) {
            (_, true) => "`(n0, n1, …, P, H)`",
            (true, false) => "`(n0, n1, …, P)`",
            (false, false) => "`(n0, n1, …)`",
        };
        let units = match c.units {
            Units::None => "—".to_string(),
            Units::Fixed(u) => format!("`{u}`"),
            Units::OfProbes => "the probes' unit¹".to_string(),
        };
        let mut content = c.description.to_string();
        if let Some(FillValue::I64(fill)) = c.fill_value() {
            content.push_str(&format!(" ({fill} where failed or pending: `_FillValue`)"));
        }
        if c.flags.is_some() {
            content.push_str(" (attrs `flag_values`, `flag_meanings`)");
        }
        if !c.note.is_empty() {
            content.push_str(&format!("; {}", c.note));
        }
        match c.written {
            Written::Always => {}
            Written::WithMovingPart => content.push_str(
                "; only in files where some point integrates only the moving part of its chain",
            ),
            Written::WithRunGroups => {
                content.push_str("; only in files that record histories or minimum overlaps")
            }
            Written::WithSpectrum => {
                content.push_str("; only in files that record the spectrum (`record.spectrum`)")
            }
            Written::WithSteadyState => content
                .push_str("; only in files that record the steady state (`record.steady_state`)"),
            Written::WithEnergyLedger => content
                .push_str("; only in files that record the energy ledger (`record.energy_ledger`)"),
        }
        let content = content.replace('|', "\\|");
        let dtype = match c.dtype {
            // (one byte per character along a last dimension `<name>_strlen`, UTF-8)
            Dtype::Str => "text²",
            d => d.numpy(),
        };
        out.push_str(&format!(
            "| `{}` | {shape} | {dtype} | {units} | {content} |\n",
            c.name
        ));
    }
    out.push_str(
        "\n¹ Where the probes' units differ (a force probe and a velocity probe), a variable has no one \
         unit: the column is stored once per unit, named `<column>_<unit>` (`leading_peak_N`, \
         `leading_peak_m_per_s`, `leading_peak_m`: `/` as `_per_`), each over every probe like the \
         column, its values at the probes of that unit and NaN at the others.\n\n\
         ² netCDF `char`: the UTF-8 bytes of each text along a last dimension `<dataset>_strlen` \
         (as long as the longest, NUL-padded; attribute `_Encoding = \"utf-8\"`); xarray reads \
         it as strings.\n",
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_distinct_and_typed_as_filled() {
        let names = reserved_names();
        let mut sorted = names.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), names.len());
        for c in COLUMNS {
            let dtype = match c.fill {
                Fill::OkF64 { .. }
                | Fill::RunF64 { .. }
                | Fill::ProbeF64 { .. }
                | Fill::SteadyF64 { .. }
                | Fill::SteadyHarmonic { .. }
                | Fill::VerifyMax
                | Fill::VerifyProbe(_)
                | Fill::VerifyRun(_)
                | Fill::Ledger { .. } => Dtype::F64,
                Fill::OkCount { .. } | Fill::OkOptCount { .. } => Dtype::I64,
                Fill::OkText { .. } | Fill::Reason | Fill::RunHash => Dtype::Str,
                Fill::Status
                | Fill::Verified
                | Fill::OkFlag { .. }
                | Fill::ProbeFlag { .. }
                | Fill::SteadyFlag { .. } => Dtype::U8,
                Fill::HistoryChecksum | Fill::SummaryChecksum => Dtype::U64,
            };
            assert_eq!(c.dtype, dtype, "{}", c.name);
            let per_probe = matches!(
                c.fill,
                Fill::ProbeF64 { .. }
                    | Fill::ProbeFlag { .. }
                    | Fill::VerifyProbe(_)
                    | Fill::SteadyF64 { .. }
                    | Fill::SteadyFlag { .. }
                    | Fill::SteadyHarmonic { .. }
            );
            assert_eq!(c.per_probe, per_probe, "{}", c.name);
            let per_harmonic = matches!(c.fill, Fill::SteadyHarmonic { .. });
            assert_eq!(c.per_harmonic, per_harmonic, "{}", c.name);
        }
    }

    #[test]
    fn split_names_are_every_probe_unit_of_every_column_in_the_probes_unit() {
        use chainsweep_solver::observe::probes::Probe;
        let kinds = [
            Probe::GaugeForce { cylinder: 1 },
            Probe::ParticleForce { particle: 1 },
            Probe::ContactForce { contact: 1 },
            Probe::Overlap { contact: 1 },
            Probe::Displacement { particle: 1 },
            Probe::Velocity { particle: 1 },
            Probe::WallForce,
        ];
        let units: Vec<String> = kinds.iter().map(|p| p.unit().to_string()).collect();
        assert_eq!(distinct_units(&units), PROBE_UNITS);
        let mut want = Vec::new();
        for c in COLUMNS.iter().filter(|c| c.units == Units::OfProbes) {
            assert!(c.per_probe && c.dtype == Dtype::F64, "{}", c.name);
            want.extend(PROBE_UNITS.iter().map(|u| split_name(c.name, u)));
        }
        assert_eq!(want, SPLIT_NAMES);
        // The histories are split alike, and their split names reserved.
        for u in PROBE_UNITS {
            assert!(
                ARRAY_NAMES.contains(&split_name(HISTORY, u).as_str()),
                "{u}"
            );
        }
        assert_eq!(unit_suffix("m/s"), "m_per_s");
        assert_eq!(unit_suffix("kg m-2"), "kg_m_2");
    }

    #[test]
    fn every_text_column_has_its_characters_dimension_reserved() {
        for c in COLUMNS.iter().filter(|c| c.dtype == Dtype::Str) {
            assert!(
                LAYOUT_NAMES.contains(&format!("{}_strlen", c.name).as_str()),
                "{}",
                c.name
            );
        }
    }
}
