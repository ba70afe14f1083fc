//! Filling a file's columns from its grid points' runs: [`Table`] (the columns in memory),
//! [`ColumnData`], [`PointOutcome`], and how each column takes a point's value.

use super::super::{RunRecord, VerifyInfo, STATUS_PENDING, VERIFY_OK};
use super::{history_checksum, Column, Dtype, Fill, FillValue, Presence, COLUMNS};

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
}
