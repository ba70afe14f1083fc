//! What a finished run leaves behind ([`RunRecord`]), the verification outcome of a grid point
//! ([`VerifyInfo`]), and the status codes the output file stores for them.
//!
//! Everything here is plain data: the store writes and reads it, the executor fills it, the
//! numerics compare it. [`columns`] is the one table of what the output file stores of it.

pub mod columns;
pub mod names;

use chainsweep_solver::observe::flow::EnergyFlow;
use chainsweep_solver::observe::probes::{Fields, History, ProbeSummary};
use chainsweep_solver::observe::steady::{SteadyProbe, SteadyState};
use chainsweep_solver::spectrum::SpectrumSummary;

use crate::identity::RunHash;

/// Status code of a pending grid point (not run, or not in this shard).
pub const STATUS_PENDING: u8 = 0;
/// Status code of a successful run.
pub const STATUS_OK: u8 = 1;
/// Status code of a failed run.
pub const STATUS_FAILED: u8 = 2;
/// Status code of a run that finished but whose steady state did not settle
/// (`record.steady_state`: some probe's `steady_settled` is 2): its values are stored, but they
/// are not the steady state asked for.
pub const STATUS_UNSETTLED: u8 = 3;

/// Whether a point of status `st` holds a finished run's values (ok or unsettled).
pub fn holds_values(st: u8) -> bool {
    st == STATUS_OK || st == STATUS_UNSETTLED
}

/// Fill value of the integer summaries (steps, …) where a run failed or is pending.
pub const INT_FILL: i64 = -1;

/// `moving_part` flag: not known (a failed or pending run, or one stored before it was kept).
pub const MOVING_PART_UNKNOWN: u8 = 0;
/// `moving_part` flag: the whole chain was integrated.
pub const MOVING_PART_WHOLE_CHAIN: u8 = 1;
/// `moving_part` flag: only the moving part of the chain was integrated.
pub const MOVING_PART_ONLY: u8 = 2;

/// `leading_pulse` flag: no run (pending or failed).
pub const LEADING_NO_RUN: u8 = 0;
/// `leading_pulse` flag: the leading pulse passed the probe; `leading_peak` is its peak.
pub const LEADING_PASSED: u8 = 1;
/// `leading_pulse` flag: the leading pulse had not passed the probe by the end of the run (it had
/// not arrived, or was still rising): `leading_peak` and `leading_peak_time_s` are NaN.
pub const LEADING_NOT_PASSED: u8 = 2;

/// `steady_settled`: no run (pending or failed).
pub const STEADY_NO_RUN: u8 = 0;
/// `steady_settled`: the probe had settled within `record.steady_state.settled_tolerance`.
pub const STEADY_SETTLED: u8 = 1;
/// `steady_settled`: the probe had not settled.
pub const STEADY_NOT_SETTLED: u8 = 2;

/// `verified` flag: the point was not verified.
pub const VERIFY_NONE: u8 = 0;
/// `verified` flag: verified; the errors are stored.
pub const VERIFY_OK: u8 = 1;
/// `verified` flag: the verification run itself failed (its reason is printed by `run`).
pub const VERIFY_FAILED: u8 = 2;

/// A run's own arrays as stored: its histories, minimum overlaps, space–time fields and energy
/// flow, each when recorded.
pub type RunArrays = (
    Option<History>,
    Option<Vec<f64>>,
    Option<Fields>,
    Option<EnergyFlow>,
);

/// One finished run, successful or failed.
#[derive(Debug, Clone, PartialEq)]
pub struct RunRecord {
    /// Run hash.
    pub hash: RunHash,
    /// Whether the run succeeded.
    pub ok: bool,
    /// Why it failed (empty when it succeeded).
    pub reason: String,
    /// Accepted steps.
    pub steps: u64,
    /// Rejected steps.
    pub rejected: u64,
    /// Right-hand-side evaluations.
    pub rhs_evals: u64,
    /// Steps retaken to end on a located event (a contact opening or closing).
    pub events: u64,
    /// Time reached, s.
    pub t_end_s: f64,
    /// Largest relative energy drift.
    pub energy_drift_max: f64,
    /// Final relative energy drift.
    pub energy_drift_final: f64,
    /// Largest relative momentum residual.
    pub momentum_residual_max: f64,
    /// Striker kinetic energy, J.
    pub impact_energy_j: f64,
    /// Wall time of the run, s.
    pub wall_time_s: f64,
    /// Largest contact overlap over the run (located on the dense output), m (NaN for failed runs).
    pub max_overlap_m: f64,
    /// Physical-validity warnings of the solver, one per line (empty when none).
    pub warnings: String,
    /// Particles integrated at the end of the run (striker included): the chain's particle count
    /// when the whole chain was integrated, the final length of the integrated prefix when only
    /// its moving part was (it may have grown to the whole chain). `None` for failed runs and for
    /// runs stored before it was kept (segment format 2, files without the column).
    pub integrated_particles: Option<u64>,
    /// Whether the run integrated only the moving part of its chain (a growing prefix, see the
    /// solver's `active` module) rather than the whole chain; `None` where `integrated_particles`
    /// is (the two are kept together).
    pub moving_part: Option<bool>,
    /// Summary of each probe (empty for failed runs).
    pub probes: Vec<ProbeSummary>,
    /// Minimum overlap of every contact, m, when recorded.
    pub min_overlap_m: Option<Vec<f64>>,
    /// Histories, when recorded.
    pub history: Option<History>,
    /// Space–time fields, when recorded (`record.fields`).
    pub fields: Option<Fields>,
    /// The energy through every contact and each particle's largest kinetic energy, when
    /// recorded (`record.energy_flow`).
    pub energy_flow: Option<EnergyFlow>,
    /// The linear spectrum at the static state, when recorded (`record.spectrum`).
    pub spectrum: Option<SpectrumSummary>,
    /// Steady-state observables of every probe, when recorded (`record.steady_state`).
    pub steady_state: Option<SteadyState>,
    /// The energy ledger's terms at the start and at the end, when recorded
    /// (`record.energy_ledger`), in the order of [`LEDGER_TERMS`].
    pub energy_ledger: Option<[LedgerTerms; 2]>,
}

/// The energy ledger's terms of one instant, J, in the order of [`LEDGER_TERMS`].
pub type LedgerTerms = [f64; 7];

/// The energy ledger's terms: the name each column takes, and what it holds. Their sum is
/// constant along an exact solution.
pub const LEDGER_TERMS: [(&str, &str); 7] = [
    ("kinetic", "kinetic energy of the particles"),
    (
        "elastic",
        "elastic energy of the contacts (the recoverable part, for plastic ones)",
    ),
    ("gravitational", "gravitational potential -g Σ m x (x positive downwards)"),
    ("dissipated", "work dissipated by the contacts' dissipation so far"),
    ("plastic", "plastic work of Thornton's contacts so far"),
    (
        "external",
        "minus the external forces' work: the precompression's potential -F_p x, less the work of a force pulse or drive so far",
    ),
    (
        "mount",
        "a mounted wall's kinetic energy and its spring's energy over its loaded state",
    ),
];

/// The ledger's terms of `e` in the order of [`LEDGER_TERMS`].
pub fn ledger_terms(e: &chainsweep_solver::motion::system::EnergyTerms) -> LedgerTerms {
    [
        e.kinetic,
        e.elastic,
        e.gravitational,
        e.dissipated,
        e.plastic,
        e.external,
        e.mount,
    ]
}

impl RunRecord {
    /// Whether the run finished but its steady state did not settle at some probe.
    pub fn unsettled(&self) -> bool {
        self.ok
            && self
                .steady_state
                .as_ref()
                .is_some_and(|s| s.probes.iter().any(|p| !p.settled))
    }

    /// Its status code: [`STATUS_OK`], [`STATUS_UNSETTLED`] or [`STATUS_FAILED`].
    pub fn status(&self) -> u8 {
        if !self.ok {
            STATUS_FAILED
        } else if self.unsettled() {
            STATUS_UNSETTLED
        } else {
            STATUS_OK
        }
    }

    /// The `moving_part` flag of this record: [`MOVING_PART_UNKNOWN`], [`MOVING_PART_WHOLE_CHAIN`]
    /// or [`MOVING_PART_ONLY`].
    pub fn moving_part_flag(&self) -> u8 {
        match self.moving_part {
            None => MOVING_PART_UNKNOWN,
            Some(false) => MOVING_PART_WHOLE_CHAIN,
            Some(true) => MOVING_PART_ONLY,
        }
    }

    /// Sets [`RunRecord::moving_part`] from its flag (an unknown value reads as not known).
    pub fn set_moving_part_flag(&mut self, flag: u8) {
        self.moving_part = match flag {
            MOVING_PART_WHOLE_CHAIN => Some(false),
            MOVING_PART_ONLY => Some(true),
            _ => None,
        };
    }

    /// A failed run: only its reason and wall time are kept.
    pub fn failed(hash: RunHash, reason: String, wall_time_s: f64) -> Self {
        RunRecord {
            hash,
            ok: false,
            reason,
            steps: 0,
            rejected: 0,
            rhs_evals: 0,
            events: 0,
            t_end_s: f64::NAN,
            energy_drift_max: f64::NAN,
            energy_drift_final: f64::NAN,
            momentum_residual_max: f64::NAN,
            impact_energy_j: f64::NAN,
            wall_time_s,
            max_overlap_m: f64::NAN,
            warnings: String::new(),
            integrated_particles: None,
            moving_part: None,
            probes: Vec::new(),
            min_overlap_m: None,
            history: None,
            fields: None,
            energy_flow: None,
            spectrum: None,
            steady_state: None,
            energy_ledger: None,
        }
    }

    /// The recorded spectrum's value `get`, NaN where the spectrum was not recorded.
    pub fn spectrum_value(&self, get: fn(&SpectrumSummary) -> f64) -> f64 {
        self.spectrum.as_ref().map_or(f64::NAN, get)
    }

    /// Puts back a value of the recorded spectrum (a NaN where none was recorded leaves none).
    pub fn set_spectrum_value(&mut self, set: fn(&mut SpectrumSummary, f64), x: f64) {
        if self.spectrum.is_none() && x.is_nan() {
            return;
        }
        set(self.spectrum.get_or_insert(SpectrumSummary::NAN), x);
    }
}

impl RunRecord {
    /// The steady state's frequency, NaN where none was recorded.
    pub fn steady_frequency_hz(&self) -> f64 {
        self.steady_state
            .as_ref()
            .map_or(f64::NAN, |s| s.frequency_hz)
    }

    /// Puts back the steady state's frequency (a NaN where none was recorded leaves none).
    pub fn set_steady_frequency_hz(&mut self, x: f64) {
        if let Some(s) = &mut self.steady_state {
            s.frequency_hz = x;
        }
    }

    /// The steady state of probe `p`, where recorded.
    pub fn steady_probe(&self, p: usize) -> Option<&SteadyProbe> {
        self.steady_state.as_ref().and_then(|s| s.probes.get(p))
    }

    /// The steady state of probe `p` to put values back into, where recorded.
    pub fn steady_probe_mut(&mut self, p: usize) -> Option<&mut SteadyProbe> {
        self.steady_state.as_mut().and_then(|s| s.probes.get_mut(p))
    }
}

/// Verification errors per probe ([`VerifyInfo::errors`]): the leading peak, its time, the record
/// maximum, its time, and the steady state (its complex harmonic amplitudes, mean and RMS).
pub const VERIFY_PROBE_ERRORS: usize = 5;

/// Verification errors per run ([`VerifyInfo::run_errors`]): the largest overlap, and the energy
/// flow.
pub const VERIFY_RUN_ERRORS: usize = 2;

/// The verification outcome of one grid point.
#[derive(Debug, Clone, PartialEq)]
pub struct VerifyInfo {
    /// [`VERIFY_NONE`], [`VERIFY_OK`] or [`VERIFY_FAILED`].
    pub status: u8,
    /// Per probe: the relative errors of the leading peak, its time, the record maximum, its
    /// time and the steady state (NaN where not verified, or where neither run has the value).
    pub errors: Vec<[f64; VERIFY_PROBE_ERRORS]>,
    /// The relative errors of the largest overlap and of the energy flow (NaN where not
    /// verified or not recorded).
    pub run_errors: [f64; VERIFY_RUN_ERRORS],
}

impl VerifyInfo {
    /// Not verified: NaN errors for `n_probes` probes.
    pub fn none(n_probes: usize) -> Self {
        VerifyInfo {
            status: VERIFY_NONE,
            errors: vec![[f64::NAN; VERIFY_PROBE_ERRORS]; n_probes],
            run_errors: [f64::NAN; VERIFY_RUN_ERRORS],
        }
    }

    /// The largest error over probes, summaries and the run's own values, NaN where there is
    /// none (stored as `verify_rel_error_max`).
    pub fn max_error(&self) -> f64 {
        max_ignoring_nan(
            self.errors
                .iter()
                .flatten()
                .chain(&self.run_errors)
                .copied(),
        )
    }
}

/// Largest of a set of errors, ignoring NaN (values neither run has); NaN when all are NaN.
pub fn max_ignoring_nan(xs: impl IntoIterator<Item = f64>) -> f64 {
    let mut m = f64::NAN;
    for x in xs {
        if !x.is_nan() && (m.is_nan() || x > m) {
            m = x;
        }
    }
    m
}

/// How a found item (a minimum, a root) stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ItemStatus {
    /// Located within the tolerance.
    Converged,
    /// Still being located (or stopped by the budget before it was).
    Open,
    /// At an end of the interval: the objective is lowest (highest) there in the scan.
    AtBound,
    /// No further progress possible within the tolerance (the objective's own noise, or the
    /// search's points collapsed).
    Stalled,
    /// A run it needed failed (or gave no number) under the rule `failed: stop`.
    Failed,
    /// A fit whose data do not determine some combination of its fields.
    Unidentifiable,
}

impl ItemStatus {
    /// The status of a code in the output file ([`ItemStatus::code`]).
    pub fn from_code(code: u8) -> Option<ItemStatus> {
        [
            ItemStatus::Converged,
            ItemStatus::Open,
            ItemStatus::AtBound,
            ItemStatus::Stalled,
            ItemStatus::Failed,
            ItemStatus::Unidentifiable,
        ]
        .into_iter()
        .find(|s| s.code() == code)
    }

    /// Its code in the output file.
    pub fn code(self) -> u8 {
        match self {
            ItemStatus::Converged => 1,
            ItemStatus::Open => 2,
            ItemStatus::AtBound => 3,
            ItemStatus::Stalled => 4,
            ItemStatus::Failed => 5,
            ItemStatus::Unidentifiable => 6,
        }
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            ItemStatus::Converged => "converged",
            ItemStatus::Open => "open",
            ItemStatus::AtBound => "at_bound",
            ItemStatus::Stalled => "stalled",
            ItemStatus::Failed => "failed_run",
            ItemStatus::Unidentifiable => "unidentifiable",
        }
    }
}

/// The codes and names of [`ItemStatus`] (0: no item), for the file's `flag_values`.
pub const ITEM_FLAGS: (&[u8], &str) = (
    &[0, 1, 2, 3, 4, 5, 6],
    "none converged open at_bound stalled failed_run unidentifiable",
);
