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

use chainsweep_solver::observe::flow::EnergyFlow;
use chainsweep_solver::observe::probes::{Fields, History, ProbeSummary};
use chainsweep_solver::observe::steady::{SteadyProbe, SteadyState};
use sha2::{Digest, Sha256};

use super::{
    holds_values, RunRecord, VerifyInfo, INT_FILL, STATUS_FAILED, STATUS_OK, STATUS_PENDING,
    STATUS_UNSETTLED,
};
use super::{LEADING_NOT_PASSED, LEADING_NO_RUN, LEADING_PASSED};
use super::{MOVING_PART_ONLY, MOVING_PART_UNKNOWN, MOVING_PART_WHOLE_CHAIN};
use super::{STEADY_NOT_SETTLED, STEADY_NO_RUN, STEADY_SETTLED};
use super::{VERIFY_FAILED, VERIFY_NONE, VERIFY_OK};
use crate::identity::{checksum64, RunHash};

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
    /// What it holds; written as the `long_name` attribute when `long_name` is set.
    pub description: &'static str,
    /// Whether `description` is written as the `long_name` attribute.
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

const STATUS_FLAGS: &[u8] = &[STATUS_PENDING, STATUS_OK, STATUS_FAILED, STATUS_UNSETTLED];
const VERIFY_ERROR_NOTE: &str =
    "NaN where not verified or where neither run has the value, inf where only one has it";
const VERIFY_FLAGS: &[u8] = &[VERIFY_NONE, VERIFY_OK, VERIFY_FAILED];
const LEADING_FLAGS: &[u8] = &[LEADING_NO_RUN, LEADING_PASSED, LEADING_NOT_PASSED];
const STEADY_FLAGS: &[u8] = &[STEADY_NO_RUN, STEADY_SETTLED, STEADY_NOT_SETTLED];
const MOVING_PART_FLAGS: &[u8] = &[
    MOVING_PART_UNKNOWN,
    MOVING_PART_WHOLE_CHAIN,
    MOVING_PART_ONLY,
];

/// Every stored column, in the order the writer creates them.
pub const COLUMNS: &[Column] = &[
    Column {
        name: "t_end_s",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("s"),
        description: "time the run reached",
        long_name: true,
        flags: None,
        note: "",
        required: true,
        written: Written::Always,
        fill: Fill::OkF64 {
            get: |r| r.t_end_s,
            set: |r, x| r.t_end_s = x,
        },
    },
    Column {
        name: "energy_drift_max",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "largest |E(t) - E(0)| over the run, relative to the impact energy",
        long_name: true,
        flags: None,
        note: "",
        required: true,
        written: Written::Always,
        fill: Fill::OkF64 {
            get: |r| r.energy_drift_max,
            set: |r, x| r.energy_drift_max = x,
        },
    },
    Column {
        name: "energy_drift_final",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "|E(t_end) - E(0)| relative to the impact energy",
        long_name: true,
        flags: None,
        note: "",
        required: true,
        written: Written::Always,
        fill: Fill::OkF64 {
            get: |r| r.energy_drift_final,
            set: |r, x| r.energy_drift_final = x,
        },
    },
    Column {
        name: "momentum_residual_max",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "largest momentum-balance residual, relative to the striker momentum",
        long_name: true,
        flags: None,
        note: "",
        required: true,
        written: Written::Always,
        fill: Fill::OkF64 {
            get: |r| r.momentum_residual_max,
            set: |r, x| r.momentum_residual_max = x,
        },
    },
    Column {
        name: "impact_energy_j",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("J"),
        description: "striker kinetic energy",
        long_name: true,
        flags: None,
        note: "",
        required: true,
        written: Written::Always,
        fill: Fill::OkF64 {
            get: |r| r.impact_energy_j,
            set: |r, x| r.impact_energy_j = x,
        },
    },
    Column {
        name: "wall_time_s",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("s"),
        description: "wall-clock time of the run (kept for failed runs)",
        long_name: true,
        flags: None,
        note: "the one summary that differs between otherwise identical files",
        required: true,
        written: Written::Always,
        fill: Fill::RunF64 {
            get: |r| r.wall_time_s,
            set: |r, x| r.wall_time_s = x,
        },
    },
    Column {
        name: "max_overlap_m",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("m"),
        description: "largest contact overlap over the run, located on the dense output",
        long_name: true,
        flags: None,
        note: "its error falls with the integrator's tolerance (docs/SOLVER.md, Observables)",
        required: false,
        written: Written::Always,
        fill: Fill::OkF64 {
            get: |r| r.max_overlap_m,
            set: |r, x| r.max_overlap_m = x,
        },
    },
    Column {
        name: "steps",
        dtype: Dtype::I64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "accepted integrator steps",
        long_name: true,
        flags: None,
        note: "",
        required: true,
        written: Written::Always,
        fill: Fill::OkCount {
            get: |r| r.steps,
            set: |r, x| r.steps = x,
        },
    },
    Column {
        name: "rejected_steps",
        dtype: Dtype::I64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "rejected step attempts",
        long_name: true,
        flags: None,
        note: "",
        required: true,
        written: Written::Always,
        fill: Fill::OkCount {
            get: |r| r.rejected,
            set: |r, x| r.rejected = x,
        },
    },
    Column {
        name: "rhs_evals",
        dtype: Dtype::I64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "right-hand-side evaluations",
        long_name: true,
        flags: None,
        note: "",
        required: true,
        written: Written::Always,
        fill: Fill::OkCount {
            get: |r| r.rhs_evals,
            set: |r, x| r.rhs_evals = x,
        },
    },
    Column {
        name: "events",
        dtype: Dtype::I64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "steps retaken to end on a contact opening or closing (located events)",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::Always,
        fill: Fill::OkCount {
            get: |r| r.events,
            set: |r, x| r.events = x,
        },
    },
    Column {
        name: "integrated_particles",
        dtype: Dtype::I64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "particles integrated at the end of the run (striker included): the chain's count when the whole chain was integrated, the final length of the growing prefix when only its moving part was",
        long_name: true,
        flags: None,
        note: "-1 also where not known (a run stored by a version that did not keep it)",
        required: false,
        written: Written::WithMovingPart,
        fill: Fill::OkOptCount {
            get: |r| r.integrated_particles,
            set: |r, x| r.integrated_particles = x,
        },
    },
    Column {
        name: "moving_part",
        dtype: Dtype::U8,
        per_probe: false,
        per_harmonic: false,
        units: Units::None,
        description: "whether the run integrated only the moving part of its chain",
        long_name: true,
        flags: Some((MOVING_PART_FLAGS, "not_known whole_chain moving_part")),
        note: "0 failed, pending or not known, 1 the whole chain, 2 only the moving part (a prefix that grew with the front, possibly to the whole chain)",
        required: false,
        written: Written::WithMovingPart,
        fill: Fill::OkFlag {
            get: RunRecord::moving_part_flag,
            set: RunRecord::set_moving_part_flag,
        },
    },
    Column {
        name: "lowest_frequency_hz",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("Hz"),
        description: "lowest natural frequency of the chain linearised about its static state",
        long_name: true,
        flags: None,
        note: "record.spectrum; NaN where the run failed",
        required: false,
        written: Written::WithSpectrum,
        fill: Fill::OkF64 {
            get: |r| r.spectrum_value(|s| s.lowest_frequency_hz),
            set: |r, x| r.set_spectrum_value(|s, x| s.lowest_frequency_hz = x, x),
        },
    },
    Column {
        name: "highest_frequency_hz",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("Hz"),
        description: "highest natural frequency of the chain linearised about its static state",
        long_name: true,
        flags: None,
        note: "record.spectrum; NaN where the run failed",
        required: false,
        written: Written::WithSpectrum,
        fill: Fill::OkF64 {
            get: |r| r.spectrum_value(|s| s.highest_frequency_hz),
            set: |r, x| r.set_spectrum_value(|s, x| s.highest_frequency_hz = x, x),
        },
    },
    Column {
        name: "gap_lower_hz",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("Hz"),
        description: "lower edge of the periodic chain's first band gap (top of the acoustic band)",
        long_name: true,
        flags: None,
        note: "record.spectrum.cell_particles; NaN where not recorded (no cell given), without a gap, or the run failed",
        required: false,
        written: Written::WithSpectrum,
        fill: Fill::OkF64 {
            get: |r| r.spectrum_value(|s| s.gap_lower_hz),
            set: |r, x| r.set_spectrum_value(|s, x| s.gap_lower_hz = x, x),
        },
    },
    Column {
        name: "gap_upper_hz",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("Hz"),
        description: "upper edge of the periodic chain's first band gap (bottom of the next band)",
        long_name: true,
        flags: None,
        note: "record.spectrum.cell_particles; NaN where not recorded (no cell given), without a gap, or the run failed",
        required: false,
        written: Written::WithSpectrum,
        fill: Fill::OkF64 {
            get: |r| r.spectrum_value(|s| s.gap_upper_hz),
            set: |r, x| r.set_spectrum_value(|s, x| s.gap_upper_hz = x, x),
        },
    },
    Column {
        name: "band_top_hz",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("Hz"),
        description: "upper edge of the periodic chain's highest band (its cut-off frequency)",
        long_name: true,
        flags: None,
        note: "record.spectrum.cell_particles; NaN where not recorded (no cell given) or the run failed",
        required: false,
        written: Written::WithSpectrum,
        fill: Fill::OkF64 {
            get: |r| r.spectrum_value(|s| s.band_top_hz),
            set: |r, x| r.set_spectrum_value(|s, x| s.band_top_hz = x, x),
        },
    },
    Column {
        name: "steady_frequency_hz",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("Hz"),
        description: "frequency f of the steady-state analysis (record.steady_state)",
        long_name: true,
        flags: None,
        note: "record.steady_state.frequency_hz, or the scene's drive frequency; NaN where the run failed",
        required: false,
        written: Written::WithSteadyState,
        fill: Fill::OkF64 {
            get: RunRecord::steady_frequency_hz,
            set: RunRecord::set_steady_frequency_hz,
        },
    },
    Column {
        name: "status",
        dtype: Dtype::U8,
        per_probe: false,
        per_harmonic: false,
        units: Units::None,
        description: "state of the point's run: 0 pending, 1 ok, 2 failed, 3 unsettled",
        long_name: true,
        flags: Some((STATUS_FLAGS, "pending ok failed unsettled")),
        note: "unsettled: the run finished and its values are stored, but its steady state (`record.steady_state`) had not settled at some probe (`steady_settled` = 2): lengthen `settle_periods`",
        required: true,
        written: Written::Always,
        fill: Fill::Status,
    },
    Column {
        name: "reason",
        dtype: Dtype::Str,
        per_probe: false,
        per_harmonic: false,
        units: Units::None,
        description: "why the run failed (empty unless status == 2)",
        long_name: true,
        flags: None,
        note: "",
        required: true,
        written: Written::Always,
        fill: Fill::Reason,
    },
    Column {
        name: "warnings",
        dtype: Dtype::Str,
        per_probe: false,
        per_harmonic: false,
        units: Units::None,
        description: "physical-validity warnings of the run, one per line (empty when none)",
        long_name: true,
        flags: None,
        note: "overlaps over 1 % of the radius (Hertz's law stretched), impact pulse shorter than 10 sound transit times through a particle; not failures",
        required: false,
        written: Written::Always,
        fill: Fill::OkText {
            get: |r| &r.warnings,
            set: |r, x| r.warnings = x,
        },
    },
    Column {
        name: "verified",
        dtype: Dtype::U8,
        per_probe: false,
        per_harmonic: false,
        units: Units::None,
        description: "whether the point was re-run at a tighter setting (run --verify)",
        long_name: true,
        flags: Some((VERIFY_FLAGS, "not_verified verified verification_failed")),
        note: "0 not verified, 1 verified, 2 the verification run failed",
        required: false,
        written: Written::Always,
        fill: Fill::Verified,
    },
    Column {
        name: "verify_rel_error_max",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "largest verify_rel_error_* of the point (NaN where not verified)",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::Always,
        fill: Fill::VerifyMax,
    },
    Column {
        name: "run_hash",
        dtype: Dtype::Str,
        per_probe: false,
        per_harmonic: false,
        units: Units::None,
        description:
            "SHA-256 identity of the run: numerics version, solver version, limits, full scene",
        long_name: true,
        flags: None,
        note: "empty where the point is pending (it holds no run)",
        required: true,
        written: Written::Always,
        fill: Fill::RunHash,
    },
    Column {
        name: "leading_peak",
        dtype: Dtype::F64,
        per_probe: true,
        per_harmonic: false,
        units: Units::OfProbes,
        description: "peak of the leading pulse (first excursion), located on the dense output",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::Always,
        fill: Fill::ProbeF64 {
            get: |s| s.leading_peak,
            set: |s, x| s.leading_peak = x,
        },
    },
    Column {
        name: "leading_peak_time_s",
        dtype: Dtype::F64,
        per_probe: true,
        per_harmonic: false,
        units: Units::Fixed("s"),
        description: "time of the leading peak",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::Always,
        fill: Fill::ProbeF64 {
            get: |s| s.leading_peak_time_s,
            set: |s, x| s.leading_peak_time_s = x,
        },
    },
    Column {
        name: "leading_pulse",
        dtype: Dtype::U8,
        per_probe: true,
        per_harmonic: false,
        units: Units::None,
        description: "whether the leading pulse had passed the probe by the end of the run",
        long_name: true,
        flags: Some((LEADING_FLAGS, "no_run passed not_passed_by_t_end")),
        note: "0 no run (pending or failed), 1 passed, 2 not passed by t_end: the pulse had not arrived, or was still rising, when the run ended, so leading_peak and leading_peak_time_s are NaN (lengthen duration_s)",
        required: false,
        written: Written::Always,
        fill: Fill::ProbeFlag {
            get: |s| {
                if s.leading_peak.is_nan() {
                    LEADING_NOT_PASSED
                } else {
                    LEADING_PASSED
                }
            },
        },
    },
    Column {
        name: "record_max",
        dtype: Dtype::F64,
        per_probe: true,
        per_harmonic: false,
        units: Units::OfProbes,
        description: "maximum over the whole record, located on the dense output",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::Always,
        fill: Fill::ProbeF64 {
            get: |s| s.record_max,
            set: |s, x| s.record_max = x,
        },
    },
    Column {
        name: "record_max_time_s",
        dtype: Dtype::F64,
        per_probe: true,
        per_harmonic: false,
        units: Units::Fixed("s"),
        description: "time of the record maximum",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::Always,
        fill: Fill::ProbeF64 {
            get: |s| s.record_max_time_s,
            set: |s, x| s.record_max_time_s = x,
        },
    },
    Column {
        name: "steady_mean",
        dtype: Dtype::F64,
        per_probe: true,
        per_harmonic: false,
        units: Units::OfProbes,
        description: "mean of the probe over the steady-state window",
        long_name: true,
        flags: None,
        note: "the window: record.steady_state.window_periods whole periods after settle_periods",
        required: false,
        written: Written::WithSteadyState,
        fill: Fill::SteadyF64 {
            get: |p| p.mean,
            set: |p, x| p.mean = x,
        },
    },
    Column {
        name: "steady_rms",
        dtype: Dtype::F64,
        per_probe: true,
        per_harmonic: false,
        units: Units::OfProbes,
        description: "root mean square of the probe over the steady-state window (the mean included)",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::WithSteadyState,
        fill: Fill::SteadyF64 {
            get: |p| p.rms,
            set: |p, x| p.rms = x,
        },
    },
    Column {
        name: "steady_amplitude",
        dtype: Dtype::F64,
        per_probe: true,
        per_harmonic: true,
        units: Units::OfProbes,
        description: "amplitude A_k of the probe at harmonic k (frequency k f) over the steady-state window",
        long_name: true,
        flags: None,
        note: "y = mean + sum over k of A_k cos(2 pi k f t + phase_k), t from the run's start; harmonic 1 is the fundamental",
        required: false,
        written: Written::WithSteadyState,
        fill: Fill::SteadyHarmonic {
            get: |p| &p.amplitude,
            set: |p| &mut p.amplitude,
        },
    },
    Column {
        name: "steady_phase_rad",
        dtype: Dtype::F64,
        per_probe: true,
        per_harmonic: true,
        units: Units::Fixed("rad"),
        description: "phase of the probe at harmonic k, of a cosine referenced to the run's start (t = 0)",
        long_name: true,
        flags: None,
        note: "in (-pi, pi]",
        required: false,
        written: Written::WithSteadyState,
        fill: Fill::SteadyHarmonic {
            get: |p| &p.phase_rad,
            set: |p| &mut p.phase_rad,
        },
    },
    Column {
        name: "steady_settledness",
        dtype: Dtype::F64,
        per_probe: true,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "change of the fundamental's complex amplitude between the window's first and last halves, relative to the probe's amplitude (sqrt(2) times its standard deviation)",
        long_name: true,
        flags: None,
        note: "0 for a constant signal",
        required: false,
        written: Written::WithSteadyState,
        fill: Fill::SteadyF64 {
            get: |p| p.settledness,
            set: |p, x| p.settledness = x,
        },
    },
    Column {
        name: "steady_settled",
        dtype: Dtype::U8,
        per_probe: true,
        per_harmonic: false,
        units: Units::None,
        description: "whether the probe had settled: steady_settledness <= record.steady_state.settled_tolerance",
        long_name: true,
        flags: Some((STEADY_FLAGS, "no_run settled not_settled")),
        note: "0 no run (pending or failed), 1 settled, 2 not settled (the run's warnings say so too)",
        required: false,
        written: Written::WithSteadyState,
        fill: Fill::SteadyFlag {
            get: |p| if p.settled { STEADY_SETTLED } else { STEADY_NOT_SETTLED },
            set: |p, x| p.settled = x == STEADY_SETTLED,
        },
    },
    Column {
        name: "steady_transmission_db",
        dtype: Dtype::F64,
        per_probe: true,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "transmission in dB: 20 log10 of the probe's fundamental amplitude over the reference probe's (record.steady_state.reference_probe)",
        long_name: true,
        flags: None,
        note: "decibels; 0 at the reference probe",
        required: false,
        written: Written::WithSteadyState,
        fill: Fill::SteadyF64 {
            get: |p| p.transmission_db,
            set: |p, x| p.transmission_db = x,
        },
    },
    Column {
        name: "verify_rel_error_leading_peak",
        dtype: Dtype::F64,
        per_probe: true,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "relative error of leading_peak against the verification run",
        long_name: true,
        flags: None,
        note: VERIFY_ERROR_NOTE,
        required: false,
        written: Written::Always,
        fill: Fill::VerifyProbe(0),
    },
    Column {
        name: "verify_rel_error_leading_peak_time",
        dtype: Dtype::F64,
        per_probe: true,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "relative error of leading_peak_time_s against the verification run",
        long_name: true,
        flags: None,
        note: VERIFY_ERROR_NOTE,
        required: false,
        written: Written::Always,
        fill: Fill::VerifyProbe(1),
    },
    Column {
        name: "verify_rel_error_record_max",
        dtype: Dtype::F64,
        per_probe: true,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "relative error of record_max against the verification run",
        long_name: true,
        flags: None,
        note: VERIFY_ERROR_NOTE,
        required: false,
        written: Written::Always,
        fill: Fill::VerifyProbe(2),
    },
    Column {
        name: "verify_rel_error_record_max_time",
        dtype: Dtype::F64,
        per_probe: true,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "relative error of record_max_time_s against the verification run",
        long_name: true,
        flags: None,
        note: VERIFY_ERROR_NOTE,
        required: false,
        written: Written::Always,
        fill: Fill::VerifyProbe(3),
    },
    Column {
        name: "verify_rel_error_steady",
        dtype: Dtype::F64,
        per_probe: true,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "error of the steady state against the verification run: the largest of each harmonic's complex amplitude, the mean and the RMS, relative to the fundamental's amplitude (or the RMS where larger)",
        long_name: true,
        flags: None,
        note: VERIFY_ERROR_NOTE,
        required: false,
        written: Written::WithSteadyState,
        fill: Fill::VerifyProbe(4),
    },
    Column {
        name: "verify_rel_error_max_overlap",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "relative error of max_overlap_m against the verification run",
        long_name: true,
        flags: None,
        note: VERIFY_ERROR_NOTE,
        required: false,
        written: Written::Always,
        fill: Fill::VerifyRun(0),
    },
    Column {
        name: "verify_rel_error_energy_flow",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "error of the energy flow against the verification run: the largest difference of any energy_passed_max_j, energy_passed_final_j or max_kinetic_energy_j, relative to the largest of them",
        long_name: true,
        flags: None,
        note: "NaN where not verified or where the energy flow is not recorded",
        required: false,
        written: Written::WithRunGroups,
        fill: Fill::VerifyRun(1),
    },
    Column {
        name: "ledger_kinetic_start_j",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("J"),
        description: "energy ledger at the start of the run: kinetic energy of the particles",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::WithEnergyLedger,
        fill: Fill::Ledger { term: 0, end: false },
    },
    Column {
        name: "ledger_elastic_start_j",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("J"),
        description: "energy ledger at the start of the run: elastic energy of the contacts (the recoverable part, for plastic ones)",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::WithEnergyLedger,
        fill: Fill::Ledger { term: 1, end: false },
    },
    Column {
        name: "ledger_gravitational_start_j",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("J"),
        description: "energy ledger at the start of the run: gravitational potential -g Σ m x (x positive downwards)",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::WithEnergyLedger,
        fill: Fill::Ledger { term: 2, end: false },
    },
    Column {
        name: "ledger_dissipated_start_j",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("J"),
        description: "energy ledger at the start of the run: work dissipated by the contacts' dissipation so far",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::WithEnergyLedger,
        fill: Fill::Ledger { term: 3, end: false },
    },
    Column {
        name: "ledger_plastic_start_j",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("J"),
        description: "energy ledger at the start of the run: plastic work of Thornton's contacts so far",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::WithEnergyLedger,
        fill: Fill::Ledger { term: 4, end: false },
    },
    Column {
        name: "ledger_external_start_j",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("J"),
        description: "energy ledger at the start of the run: minus the external forces' work: the precompression's potential -F_p x, less the work of a force pulse or drive so far",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::WithEnergyLedger,
        fill: Fill::Ledger { term: 5, end: false },
    },
    Column {
        name: "ledger_mount_start_j",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("J"),
        description: "energy ledger at the start of the run: a mounted wall's kinetic energy and its spring's energy over its loaded state",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::WithEnergyLedger,
        fill: Fill::Ledger { term: 6, end: false },
    },
    Column {
        name: "ledger_kinetic_j",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("J"),
        description: "energy ledger at the end of the run: kinetic energy of the particles",
        long_name: true,
        flags: None,
        note: "the terms sum to a constant along an exact solution: their sum at the end less at the start is the ledger's drift (energy_drift_max, relative)",
        required: false,
        written: Written::WithEnergyLedger,
        fill: Fill::Ledger { term: 0, end: true },
    },
    Column {
        name: "ledger_elastic_j",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("J"),
        description: "energy ledger at the end of the run: elastic energy of the contacts (the recoverable part, for plastic ones)",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::WithEnergyLedger,
        fill: Fill::Ledger { term: 1, end: true },
    },
    Column {
        name: "ledger_gravitational_j",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("J"),
        description: "energy ledger at the end of the run: gravitational potential -g Σ m x (x positive downwards)",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::WithEnergyLedger,
        fill: Fill::Ledger { term: 2, end: true },
    },
    Column {
        name: "ledger_dissipated_j",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("J"),
        description: "energy ledger at the end of the run: work dissipated by the contacts' dissipation so far",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::WithEnergyLedger,
        fill: Fill::Ledger { term: 3, end: true },
    },
    Column {
        name: "ledger_plastic_j",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("J"),
        description: "energy ledger at the end of the run: plastic work of Thornton's contacts so far",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::WithEnergyLedger,
        fill: Fill::Ledger { term: 4, end: true },
    },
    Column {
        name: "ledger_external_j",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("J"),
        description: "energy ledger at the end of the run: minus the external forces' work: the precompression's potential -F_p x, less the work of a force pulse or drive so far",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::WithEnergyLedger,
        fill: Fill::Ledger { term: 5, end: true },
    },
    Column {
        name: "ledger_mount_j",
        dtype: Dtype::F64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("J"),
        description: "energy ledger at the end of the run: a mounted wall's kinetic energy and its spring's energy over its loaded state",
        long_name: true,
        flags: None,
        note: "",
        required: false,
        written: Written::WithEnergyLedger,
        fill: Fill::Ledger { term: 6, end: true },
    },
    Column {
        name: "history_checksum",
        dtype: Dtype::U64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "checksum of the run's group under runs/ (its histories and minimum overlaps)",
        long_name: true,
        flags: None,
        note: "the first 8 bytes of a SHA-256, little endian; 0 where the run has no group (failed or pending)",
        required: false,
        written: Written::WithRunGroups,
        fill: Fill::HistoryChecksum,
    },
    Column {
        name: "summary_checksum",
        dtype: Dtype::U64,
        per_probe: false,
        per_harmonic: false,
        units: Units::Fixed("1"),
        description: "checksum of every other value the file stores for the point (run hash, status, summaries, verification, history_checksum)",
        long_name: true,
        flags: None,
        note: "the first 8 bytes of a SHA-256, little endian; 0 where the point is pending, which then holds nothing but fill values (checked too). A point whose values do not match it is damaged: chainsweep reports it and computes it again",
        required: false,
        written: Written::Always,
        fill: Fill::SummaryChecksum,
    },
];

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

/// The values of one column over the grid (row-major; probe fastest for per-probe columns).
#[derive(Debug, Clone, PartialEq)]
pub enum ColumnData {
    /// [`Dtype::F64`].
    F64(Vec<f64>),
    /// [`Dtype::I64`].
    I64(Vec<i64>),
    /// [`Dtype::U8`].
    U8(Vec<u8>),
    /// [`Dtype::U64`].
    U64(Vec<u64>),
    /// [`Dtype::Str`].
    Str(Vec<String>),
}

/// What a grid point holds when the file is written: its run hash, its run's record (none while
/// pending) and, for a finished run, its verification outcome.
#[derive(Debug, Clone, Copy)]
pub struct PointOutcome<'a> {
    /// The point's run hash (hex), stored only with its run.
    pub hash_hex: &'a str,
    /// The finished run.
    pub record: Option<&'a RunRecord>,
    /// The verification outcome of a finished run.
    pub verify: Option<&'a VerifyInfo>,
}

impl Column {
    /// The column for `n_points` points of `n_probes` probes and `n_harmonics` harmonics, every
    /// value its fill.
    pub fn empty(&self, n_points: usize, n_probes: usize, n_harmonics: usize) -> ColumnData {
        let n = n_points * self.width(n_probes, n_harmonics);
        match (self.dtype, self.fill_value()) {
            (Dtype::F64, Some(FillValue::F64(x))) => ColumnData::F64(vec![x; n]),
            (Dtype::I64, Some(FillValue::I64(x))) => ColumnData::I64(vec![x; n]),
            (Dtype::U8, None) => ColumnData::U8(vec![0; n]),
            (Dtype::U64, None) => ColumnData::U64(vec![0; n]),
            (Dtype::Str, None) => ColumnData::Str(vec![String::new(); n]),
            _ => unreachable!("column {} has a fill value of another type", self.name),
        }
    }

    /// Fills in point `i` (of `n_probes` probes and `nh` harmonics) of `data` from its outcome
    /// `o`.
    pub fn fill_point(
        &self,
        data: &mut ColumnData,
        i: usize,
        n_probes: usize,
        nh: usize,
        o: &PointOutcome,
    ) {
        let ok = o.record.filter(|r| r.ok);
        let verified = o.verify.filter(|v| v.status == VERIFY_OK);
        match (self.fill, data) {
            (Fill::OkF64 { get, .. }, ColumnData::F64(d)) => {
                if let Some(r) = ok {
                    d[i] = get(r);
                }
            }
            (Fill::RunF64 { get, .. }, ColumnData::F64(d)) => {
                if let Some(r) = o.record {
                    d[i] = get(r);
                }
            }
            (Fill::OkCount { get, .. }, ColumnData::I64(d)) => {
                if let Some(r) = ok {
                    d[i] = get(r) as i64;
                }
            }
            (Fill::OkOptCount { get, .. }, ColumnData::I64(d)) => {
                if let Some(x) = ok.and_then(get) {
                    d[i] = x as i64;
                }
            }
            (Fill::OkFlag { get, .. }, ColumnData::U8(d)) => {
                if let Some(r) = ok {
                    d[i] = get(r);
                }
            }
            (Fill::OkText { get, .. }, ColumnData::Str(d)) => {
                if let Some(r) = ok {
                    d[i] = get(r).to_string();
                }
            }
            (Fill::Reason, ColumnData::Str(d)) => {
                if let Some(r) = o.record.filter(|r| !r.ok) {
                    d[i] = r.reason.clone();
                }
            }
            (Fill::ProbeF64 { get, .. }, ColumnData::F64(d)) => {
                if let Some(r) = ok {
                    for (p, s) in r.probes.iter().enumerate().take(n_probes) {
                        d[i * n_probes + p] = get(s);
                    }
                }
            }
            (Fill::ProbeFlag { get }, ColumnData::U8(d)) => {
                if let Some(r) = ok {
                    for (p, s) in r.probes.iter().enumerate().take(n_probes) {
                        d[i * n_probes + p] = get(s);
                    }
                }
            }
            (Fill::SteadyF64 { get, .. }, ColumnData::F64(d)) => {
                if let Some(st) = ok.and_then(|r| r.steady_state.as_ref()) {
                    for (p, s) in st.probes.iter().enumerate().take(n_probes) {
                        d[i * n_probes + p] = get(s);
                    }
                }
            }
            (Fill::SteadyFlag { get, .. }, ColumnData::U8(d)) => {
                if let Some(st) = ok.and_then(|r| r.steady_state.as_ref()) {
                    for (p, s) in st.probes.iter().enumerate().take(n_probes) {
                        d[i * n_probes + p] = get(s);
                    }
                }
            }
            (Fill::SteadyHarmonic { get, .. }, ColumnData::F64(d)) => {
                if let Some(st) = ok.and_then(|r| r.steady_state.as_ref()) {
                    for (p, s) in st.probes.iter().enumerate().take(n_probes) {
                        for (k, &x) in get(s).iter().enumerate().take(nh) {
                            d[(i * n_probes + p) * nh + k] = x;
                        }
                    }
                }
            }
            (Fill::Status, ColumnData::U8(d)) => {
                d[i] = o.record.map_or(STATUS_PENDING, RunRecord::status);
            }
            // A pending point holds no run, so it names none: its run hash is empty, the fill.
            (Fill::RunHash, ColumnData::Str(d)) => {
                if o.record.is_some() {
                    d[i] = o.hash_hex.to_string();
                }
            }
            (Fill::Verified, ColumnData::U8(d)) => {
                if let Some(v) = o.verify {
                    d[i] = v.status;
                }
            }
            (Fill::VerifyMax, ColumnData::F64(d)) => {
                if let Some(v) = verified {
                    d[i] = v.max_error();
                }
            }
            (Fill::VerifyProbe(k), ColumnData::F64(d)) => {
                if let Some(v) = verified {
                    for (p, e) in v.errors.iter().enumerate().take(n_probes) {
                        d[i * n_probes + p] = e[k];
                    }
                }
            }
            (Fill::VerifyRun(k), ColumnData::F64(d)) => {
                if let Some(v) = verified {
                    d[i] = v.run_errors[k];
                }
            }
            (Fill::Ledger { term, end }, ColumnData::F64(d)) => {
                if let Some(terms) = ok.and_then(|r| r.energy_ledger.as_ref()) {
                    d[i] = terms[end as usize][term];
                }
            }
            (Fill::HistoryChecksum, ColumnData::U64(d)) => {
                if let Some(r) = ok {
                    d[i] = history_checksum(
                        r.history.as_ref(),
                        r.min_overlap_m.as_deref(),
                        r.fields.as_ref(),
                        r.energy_flow.as_ref(),
                    );
                }
            }
            (Fill::SummaryChecksum, ColumnData::U64(_)) => {}
            _ => unreachable!("column {} holds data of another type", self.name),
        }
    }

    /// Puts the value of point `i` of `data` back into `rec` (a record read from the file):
    /// columns of successful runs when `rec.ok`, those of every finished run always.
    pub fn restore(
        &self,
        data: &ColumnData,
        i: usize,
        n_probes: usize,
        nh: usize,
        rec: &mut RunRecord,
    ) {
        match (self.fill, data) {
            (Fill::OkF64 { set, .. }, ColumnData::F64(d)) if rec.ok => set(rec, d[i]),
            (Fill::RunF64 { set, .. }, ColumnData::F64(d)) => set(rec, d[i]),
            (Fill::OkCount { set, .. }, ColumnData::I64(d)) if rec.ok => set(rec, d[i] as u64),
            (Fill::OkOptCount { set, .. }, ColumnData::I64(d)) if rec.ok => {
                set(rec, (d[i] != INT_FILL).then_some(d[i] as u64))
            }
            (Fill::OkFlag { set, .. }, ColumnData::U8(d)) if rec.ok => set(rec, d[i]),
            (Fill::OkText { set, .. }, ColumnData::Str(d)) if rec.ok => set(rec, d[i].clone()),
            (Fill::Reason, ColumnData::Str(d)) if !rec.ok => rec.reason = d[i].clone(),
            (Fill::ProbeF64 { set, .. }, ColumnData::F64(d)) if rec.ok => {
                for (p, s) in rec.probes.iter_mut().enumerate().take(n_probes) {
                    set(s, d[i * n_probes + p]);
                }
            }
            (Fill::SteadyF64 { set, .. }, ColumnData::F64(d)) if rec.ok => {
                for p in 0..n_probes {
                    if let Some(s) = rec.steady_probe_mut(p) {
                        set(s, d[i * n_probes + p]);
                    }
                }
            }
            (Fill::SteadyFlag { set, .. }, ColumnData::U8(d)) if rec.ok => {
                for p in 0..n_probes {
                    if let Some(s) = rec.steady_probe_mut(p) {
                        set(s, d[i * n_probes + p]);
                    }
                }
            }
            (Fill::SteadyHarmonic { set, .. }, ColumnData::F64(d)) if rec.ok => {
                for p in 0..n_probes {
                    if let Some(s) = rec.steady_probe_mut(p) {
                        let at = (i * n_probes + p) * nh;
                        *set(s) = d[at..at + nh].to_vec();
                    }
                }
            }
            (Fill::Ledger { term, end }, ColumnData::F64(d)) if rec.ok => {
                rec.energy_ledger.get_or_insert([[f64::NAN; 7]; 2])[end as usize][term] = d[i];
            }
            _ => {}
        }
    }
}

/// The checksum of a run's arrays (in layouts 4 and earlier its group under `runs/`): its time
/// samples and history per probe, its minimum overlaps, its space–time fields and its energy
/// flow, as stored (bit for bit); 0 for a run without any (never 0 otherwise). A run without
/// fields or energy flow has the checksum it had before they existed.
pub fn history_checksum(
    history: Option<&History>,
    min_overlap_m: Option<&[f64]>,
    fields: Option<&Fields>,
    energy_flow: Option<&EnergyFlow>,
) -> u64 {
    if history.is_none() && min_overlap_m.is_none() && fields.is_none() && energy_flow.is_none() {
        return 0;
    }
    let sum = checksum64(|h| {
        h.update(b"chainsweep run group checksum v1\n");
        let series = |h: &mut Sha256, name: &[u8], v: &[f64]| {
            h.update(name);
            h.update((v.len() as u64).to_le_bytes());
            for x in v {
                h.update(x.to_bits().to_le_bytes());
            }
        };
        if let Some(hist) = history {
            series(h, b"time_s", &hist.time_s);
            for v in &hist.values {
                series(h, b"probe", v);
            }
        }
        if let Some(m) = min_overlap_m {
            series(h, b"min_overlap_m", m);
        }
        if let Some(f) = fields {
            series(h, b"field_time_s", &f.time_s);
            for s in &f.series {
                h.update([s.quantity.code()]);
                h.update((s.width as u64).to_le_bytes());
                series(h, b"field", &s.values);
            }
        }
        if let Some(f) = energy_flow {
            series(h, b"energy_passed_max_j", &f.energy_passed_max_j);
            series(h, b"energy_passed_final_j", &f.energy_passed_final_j);
            series(h, b"max_kinetic_energy_j", &f.max_kinetic_energy_j);
        }
    });
    sum.max(1)
}

/// A file's columns in memory: every column of [`COLUMNS`] the file has, in the table's order
/// (`None` where it has not), over `n` grid points of `np` probes. What the writer fills, the
/// reader reads back and the snapshot keeps.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Grid points.
    pub n: usize,
    /// Probes per point.
    pub np: usize,
    /// Harmonics of the steady state per probe (0 without).
    pub nh: usize,
    /// Every column, in [`COLUMNS`] order.
    pub columns: Vec<Option<ColumnData>>,
}

impl Table {
    /// The columns a file of `presence` has over `n` points, every value its fill (status
    /// pending).
    pub fn empty(n: usize, presence: Presence) -> Table {
        Table {
            n,
            np: presence.probes,
            nh: presence.harmonics,
            columns: COLUMNS
                .iter()
                .map(|c| {
                    c.is_written(presence)
                        .then(|| c.empty(n, presence.probes, presence.harmonics))
                })
                .collect(),
        }
    }

    /// The points whose run succeeded but left a probe's leading peak NaN: the leading pulse had
    /// not passed the probe by the end of the run (`leading_pulse` = 2). From `leading_peak`, so
    /// that files written before `leading_pulse` was kept are read alike.
    pub fn unpassed_points(&self) -> Vec<usize> {
        let Some(ColumnData::F64(peaks)) = self.get("leading_peak") else {
            return Vec::new();
        };
        (0..self.n)
            .filter(|&i| {
                holds_values(self.status(i))
                    && peaks[i * self.np..(i + 1) * self.np]
                        .iter()
                        .any(|v| v.is_nan())
            })
            .collect()
    }

    /// The points whose run finished without its steady state settling
    /// ([`STATUS_UNSETTLED`]).
    pub fn unsettled_points(&self) -> Vec<usize> {
        (0..self.n)
            .filter(|&i| self.status(i) == STATUS_UNSETTLED)
            .collect()
    }

    /// The data of column `name`, if the table has it.
    pub fn get(&self, name: &str) -> Option<&ColumnData> {
        let at = COLUMNS
            .iter()
            .position(|c| c.name == name)
            .expect("a column of the table");
        self.columns[at].as_ref()
    }

    /// The status code stored for point `i` (pending where the table has no status).
    pub fn status(&self, i: usize) -> u8 {
        match self.get("status") {
            Some(ColumnData::U8(s)) => s[i],
            _ => STATUS_PENDING,
        }
    }

    /// What `--verify` found among `points`: how many were verified, and the largest bound on
    /// the error with its point (`verify_rel_error_max`), if any.
    pub fn verification(&self, points: &[usize]) -> (usize, Option<(f64, usize)>) {
        let (Some(ColumnData::U8(flags)), Some(ColumnData::F64(errors))) =
            (self.get("verified"), self.get("verify_rel_error_max"))
        else {
            return (0, None);
        };
        let mut verified = 0;
        let mut worst: Option<(f64, usize)> = None;
        for &i in points.iter().filter(|&&i| i < self.n) {
            if flags[i] == super::VERIFY_OK {
                verified += 1;
                let e = errors[i];
                if !e.is_nan() && worst.map_or(true, |(w, _)| e > w) {
                    worst = Some((e, i));
                }
            }
        }
        (verified, worst)
    }

    /// The text of string column `name` at point `i` (empty where the table has no such column).
    pub fn str_at(&self, name: &str, i: usize) -> &str {
        match self.get(name) {
            Some(ColumnData::Str(v)) => &v[i],
            _ => "",
        }
    }

    /// The value of checksum column `name` at point `i` (0 where the table has no such column).
    pub fn checksum_at(&self, name: &str, i: usize) -> u64 {
        match self.get(name) {
            Some(ColumnData::U64(v)) => v[i],
            _ => 0,
        }
    }

    /// Fills in point `i` from its outcome `o`: every column, then the point's checksum. A
    /// pending point (no record) holds nothing but fill values, and its checksum is 0 too, what
    /// HDF5 gives back from a chunk never written: a block of pending points costs the file
    /// nothing ([`Table::checks_out`] says how such a point is checked).
    pub fn fill_point(&mut self, i: usize, o: &PointOutcome) {
        let (np, nh) = (self.np, self.nh);
        for (c, data) in COLUMNS.iter().zip(&mut self.columns) {
            if let Some(d) = data {
                c.fill_point(d, i, np, nh, o);
            }
        }
        let sum = match o.record {
            Some(_) => self.point_checksum(i),
            None => 0,
        };
        let at = COLUMNS
            .iter()
            .position(|c| matches!(c.fill, Fill::SummaryChecksum))
            .expect("the summary checksum is a column");
        if let Some(ColumnData::U64(v)) = &mut self.columns[at] {
            v[i] = sum;
        }
    }

    /// The checksum of every value the table holds for point `i` but the checksum itself: each
    /// column's name and its values at the point (a string as its length and UTF-8 bytes, a
    /// number as its bits), in [`COLUMNS`] order. What `summary_checksum` stores.
    pub fn point_checksum(&self, i: usize) -> u64 {
        checksum64(|h| {
            h.update(b"chainsweep point checksum v1\n");
            for (c, data) in COLUMNS.iter().zip(&self.columns) {
                let Some(d) = data else { continue };
                if matches!(c.fill, Fill::SummaryChecksum) {
                    continue;
                }
                h.update(c.name.as_bytes());
                h.update(b"=");
                let k = c.width(self.np, self.nh);
                let at = i * k..(i + 1) * k;
                match d {
                    ColumnData::F64(v) => v[at]
                        .iter()
                        .for_each(|x| h.update(x.to_bits().to_le_bytes())),
                    ColumnData::I64(v) => v[at].iter().for_each(|x| h.update(x.to_le_bytes())),
                    ColumnData::U8(v) => h.update(&v[at]),
                    ColumnData::U64(v) => v[at].iter().for_each(|x| h.update(x.to_le_bytes())),
                    ColumnData::Str(v) => v[at].iter().for_each(|s| {
                        h.update((s.len() as u64).to_le_bytes());
                        h.update(s.as_bytes());
                    }),
                }
                h.update(b"\n");
            }
        })
    }

    /// The checksum [`Table::point_checksum`] of a pending point as [`Table::fill_point`] leaves
    /// it in a table with this one's columns: every value its fill, no run hash.
    pub fn pending_checksum(&self) -> u64 {
        let one = Table {
            n: 1,
            np: self.np,
            nh: self.nh,
            columns: COLUMNS
                .iter()
                .zip(&self.columns)
                .map(|(c, d)| d.as_ref().map(|_| c.empty(1, self.np, self.nh)))
                .collect(),
        };
        one.point_checksum(0)
    }

    /// Whether point `i`'s values match its `summary_checksum`. A point's checksum covers every
    /// value it holds (a pending point's run hash included, as layouts 3 to 5 stored it). With
    /// `pending` (the table's [`Table::pending_checksum`], for a file of layout 6 or later), a
    /// pending point may instead have checksum 0 and hold nothing but fill values.
    pub fn checks_out(&self, i: usize, pending: Option<u64>) -> bool {
        let stored = self.checksum_at("summary_checksum", i);
        let sum = self.point_checksum(i);
        sum == stored || (stored == 0 && self.status(i) == STATUS_PENDING && Some(sum) == pending)
    }

    /// The verification outcome stored for point `i`.
    pub fn verify_info(&self, i: usize) -> VerifyInfo {
        let np = self.np;
        let status = match self.get("verified") {
            Some(ColumnData::U8(v)) => v[i],
            _ => VERIFY_NONE,
        };
        let mut info = VerifyInfo::none(np);
        info.status = status;
        let stored: Vec<(Fill, &Vec<f64>)> = COLUMNS
            .iter()
            .zip(&self.columns)
            .filter_map(|(c, data)| match (c.fill, data) {
                (f @ (Fill::VerifyProbe(_) | Fill::VerifyRun(_)), Some(ColumnData::F64(v))) => {
                    Some((f, v))
                }
                _ => None,
            })
            .collect();
        // (Files written before the later errors were kept hold the first three.)
        let base = stored
            .iter()
            .filter(|(f, _)| matches!(f, Fill::VerifyProbe(k) if *k < 3))
            .count();
        if status == VERIFY_OK && base == 3 {
            for &(f, v) in &stored {
                match f {
                    Fill::VerifyProbe(k) => {
                        for (p, e) in info.errors.iter_mut().enumerate() {
                            e[k] = v[i * np + p];
                        }
                    }
                    Fill::VerifyRun(k) => info.run_errors[k] = v[i],
                    _ => {}
                }
            }
        }
        info
    }

    /// The record of point `i` as the table holds it (without the run's group: histories and
    /// minimum overlaps), under the run hash `hash`; `None` where pending. `whole_chain`: the
    /// particles of the point's chain when no point of its grid integrates only its moving part
    /// (a table without the moving-part columns then says its runs integrated the whole chain).
    pub fn record(&self, i: usize, hash: RunHash, whole_chain: Option<u64>) -> Option<RunRecord> {
        let st = self.status(i);
        if st == STATUS_PENDING {
            return None;
        }
        let np = self.np;
        let mut rec = RunRecord::failed(hash, String::new(), f64::NAN);
        if st != STATUS_FAILED {
            rec.ok = true;
            rec.probes = vec![
                ProbeSummary {
                    leading_peak: f64::NAN,
                    leading_peak_time_s: f64::NAN,
                    record_max: f64::NAN,
                    record_max_time_s: f64::NAN,
                };
                np
            ];
        }
        // The steady state's values go back into one of the table's shape.
        let steady = COLUMNS
            .iter()
            .zip(&self.columns)
            .any(|(c, d)| c.written == Written::WithSteadyState && d.is_some());
        if rec.ok && steady {
            rec.steady_state = Some(SteadyState {
                frequency_hz: f64::NAN,
                probes: vec![
                    SteadyProbe {
                        mean: f64::NAN,
                        rms: f64::NAN,
                        amplitude: vec![f64::NAN; self.nh],
                        phase_rad: vec![f64::NAN; self.nh],
                        settledness: f64::NAN,
                        settled: false,
                        transmission_db: f64::NAN,
                    };
                    np
                ],
            });
        }
        // A column the table lacks leaves the value of a failed run's record (NaN, 0, empty).
        for (c, data) in COLUMNS.iter().zip(&self.columns) {
            if let Some(d) = data {
                c.restore(d, i, np, self.nh, &mut rec);
            }
        }
        // Tables of grids where no point integrates only its moving part leave out how much each
        // run integrated: its whole chain, whichever version ran it. (A table of a grid where
        // some point does, without the columns, was written before they existed: not known.)
        let has_moving_part = COLUMNS
            .iter()
            .zip(&self.columns)
            .any(|(c, d)| c.written == Written::WithMovingPart && d.is_some());
        if let (true, false, Some(n)) = (rec.ok, has_moving_part, whole_chain) {
            rec.moving_part = Some(false);
            rec.integrated_particles = Some(n);
        }
        Some(rec)
    }
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

    #[test]
    fn a_pending_point_names_no_run_and_holds_nothing_else() {
        let presence = Presence {
            probes: 2,
            moving_part: true,
            run_groups: false,
            spectrum: false,
            harmonics: 0,
            energy_ledger: false,
        };
        let mut t = Table::empty(3, presence);
        let hash = [7u8; 32];
        let hex = crate::identity::hex(&hash);
        let first = RunRecord::failed(hash, "no".into(), 0.5);
        let third = RunRecord::failed(hash, "also no".into(), 0.5);
        for (i, record) in [Some(&first), None, Some(&third)].into_iter().enumerate() {
            let outcome = PointOutcome {
                hash_hex: &hex,
                record,
                verify: None,
            };
            t.fill_point(i, &outcome);
        }
        // The run and the pending point: named or not, the checksum 0 only where pending.
        assert_eq!(t.str_at("run_hash", 0), hex);
        assert_eq!(t.str_at("run_hash", 1), "");
        assert_eq!(t.checksum_at("summary_checksum", 1), 0);
        assert_ne!(t.checksum_at("summary_checksum", 0), 0);
        let pending = t.pending_checksum();
        assert!((0..3).all(|i| t.checks_out(i, Some(pending))));
        // A pending point is an empty row: what a fresh table holds.
        assert_eq!(Table::empty(1, presence).point_checksum(0), pending);
        // A value in a pending point, a run hash in it, or a run's checksum zeroed: damage.
        let damaged = |edit: &dyn Fn(&mut Table)| {
            let mut u = Table::empty(3, presence);
            u.columns.clone_from(&t.columns);
            edit(&mut u);
            (0..3)
                .filter(|&i| !u.checks_out(i, Some(pending)))
                .collect::<Vec<_>>()
        };
        assert_eq!(
            damaged(&|u| match u.columns[col("steps")].as_mut() {
                Some(ColumnData::I64(v)) => v[1] = 5,
                _ => unreachable!(),
            }),
            [1]
        );
        assert_eq!(
            damaged(&|u| match u.columns[col("run_hash")].as_mut() {
                Some(ColumnData::Str(v)) => v[1] = "ab".repeat(32),
                _ => unreachable!(),
            }),
            [1]
        );
        assert_eq!(
            damaged(&|u| match u.columns[col("summary_checksum")].as_mut() {
                Some(ColumnData::U64(v)) => v[2] = 0,
                _ => unreachable!(),
            }),
            [2]
        );
        // As layouts 3 to 5 stored a pending point: its run hash, and the checksum over it.
        let old = damaged(&|u| {
            if let Some(ColumnData::Str(v)) = u.columns[col("run_hash")].as_mut() {
                v[1].clone_from(&hex);
            }
            let sum = u.point_checksum(1);
            if let Some(ColumnData::U64(v)) = u.columns[col("summary_checksum")].as_mut() {
                v[1] = sum;
            }
        });
        assert!(old.is_empty(), "{old:?}");
        // In a file of layout 5 or earlier a pending point always had its checksum.
        assert!(!t.checks_out(1, None));
    }

    fn col(name: &str) -> usize {
        COLUMNS.iter().position(|c| c.name == name).unwrap()
    }
}
