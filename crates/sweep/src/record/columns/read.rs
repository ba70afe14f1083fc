//! Reading a file's columns back: a [`Table`]'s values by name, what its points hold, and the
//! record (and verification outcome) of a point rebuilt from them.

use chainsweep_solver::observe::probes::ProbeSummary;
use chainsweep_solver::observe::steady::{SteadyProbe, SteadyState};

use super::super::{
    holds_values, RunRecord, VerifyInfo, INT_FILL, STATUS_FAILED, STATUS_PENDING, STATUS_UNSETTLED,
    VERIFY_NONE, VERIFY_OK,
};
use super::{Column, ColumnData, Fill, Table, Written, COLUMNS};
use crate::identity::RunHash;

impl Column {
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

impl Table {
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
            if flags[i] == VERIFY_OK {
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
