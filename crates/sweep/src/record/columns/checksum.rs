//! The checksums of stored values: of a run's arrays ([`history_checksum`]) and of every value
//! a point holds ([`Table::point_checksum`]), and the check of a point against its checksum.

use chainsweep_solver::observe::flow::EnergyFlow;
use chainsweep_solver::observe::probes::{Fields, History};
use sha2::{Digest, Sha256};

use super::super::STATUS_PENDING;
use super::{ColumnData, Fill, Table, COLUMNS};
use crate::identity::checksum64;

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
impl Table {
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
}

#[cfg(test)]
mod tests {
    use super::*;

    use super::super::super::RunRecord;
    use super::super::{PointOutcome, Presence};

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
