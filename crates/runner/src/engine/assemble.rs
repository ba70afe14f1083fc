//! The output file, written from the stored runs in grid order and published atomically.

use std::collections::{HashMap, HashSet};

use crate::error::Result;
use crate::grid::{Grid, Shard};
use crate::identity::RunHash;
use crate::numerics::verify;
use crate::record::{RunRecord, VerifyInfo, STATUS_PENDING};
use crate::store::hdf5::{self, Provenance};
use crate::store::{published, RunStore, WorkDir};
use crate::sweep::Sweep;

/// Where the verification outcome of each point comes from when a file is assembled.
#[derive(Debug, Clone, Default)]
pub struct VerifySource {
    /// The `--verify` fraction (recorded as an attribute).
    pub fraction: f64,
    /// Verification hash of each grid point (computed for the points of this shard).
    pub hashes: HashMap<usize, RunHash>,
    /// What each point's verification run's own error adds to its difference from the run.
    pub allowances: HashMap<usize, verify::Allowance>,
    /// Verification runs known to be stored (ok or failed), by hash.
    pub done: HashMap<RunHash, bool>,
    /// Outcomes taken as they are (from merged shard files), by point.
    pub given: HashMap<usize, VerifyInfo>,
}

impl VerifySource {
    /// Records point `i`'s verification run: its hash and its allowance.
    pub fn insert(&mut self, i: usize, hash: RunHash, allowance: verify::Allowance) {
        self.hashes.insert(i, hash);
        self.allowances.insert(i, allowance);
    }

    /// No verification outcome known yet; `fraction` is recorded.
    pub fn empty(fraction: f64) -> Self {
        VerifySource {
            fraction,
            ..VerifySource::default()
        }
    }

    /// The verification outcome of point `i`, whose run is `rec`.
    pub fn info(
        &self,
        store: &dyn RunStore,
        grid: &Grid,
        i: usize,
        rec: &RunRecord,
    ) -> Result<VerifyInfo> {
        let np = grid.probes.len();
        if let Some(v) = self.given.get(&i) {
            return Ok(v.clone());
        }
        let Some(h) = self.hashes.get(&i) else {
            return Ok(VerifyInfo::none(np));
        };
        if !self.done.contains_key(h) {
            return Ok(VerifyInfo::none(np));
        }
        let tight = store.read(h)?;
        let allowance = self.allowances[&i];
        Ok(verify::compare(rec, tight.as_ref(), np, allowance))
    }
}

/// Everything the output file is assembled from.
pub struct Assembly<'a> {
    /// The sweep.
    pub sweep: &'a Sweep,
    /// Its grid.
    pub grid: &'a Grid,
    /// The grid points of this output (others are pending).
    pub points: &'a [usize],
    /// The shard, recorded as an attribute.
    pub shard: Option<Shard>,
    /// Finished runs (ok or failed) by hash: only these are read from the store.
    pub done: &'a HashMap<RunHash, bool>,
    /// Provenance attributes.
    pub provenance: &'a Provenance,
    /// Verification outcomes.
    pub verify: &'a VerifySource,
    /// What a search adds to the file (its evaluations' coordinates, its outcome).
    pub search: Option<&'a hdf5::search::SearchTables>,
}

/// Writes the output file of `work` from the stored runs and publishes it atomically, with its
/// snapshot: the output is always either its previous complete version or the new one. The runs
/// it holds are made durable in the work directory first. It holds every finished run of its
/// points, and every other point of the grid whose run the work directory holds (a shard run
/// into an output that holds other shards' runs keeps them); `Counts` are of its points.
pub fn assemble(work: &WorkDir, a: &Assembly<'_>) -> Result<hdf5::Written> {
    work.sync()?;
    let tmp = work.tmp_path("assemble.h5");
    let mut in_points = vec![false; a.grid.len()];
    for &i in a.points {
        in_points[i] = true;
    }
    // An ensemble's statistics take their values from the records as the columns are filled
    // (each run read once), and are computed once they all have passed.
    let values = a
        .sweep
        .ensemble
        .as_ref()
        .map(|_| std::cell::RefCell::new(super::ensemble::Values::new(a.sweep, a.grid)));
    let read = |i: usize| {
        let h = a.grid.hashes[i];
        let rec = if a.done.contains_key(&h) || !in_points[i] {
            work.read(&h)
        } else {
            Ok(None)
        };
        if let (Some(v), Ok(r)) = (&values, &rec) {
            v.borrow_mut().take(a.sweep, i, r.as_ref());
        }
        rec
    };
    let tables = || {
        let v = values.as_ref().expect("an ensemble").borrow();
        super::ensemble::tables(a.sweep, &v.values, v.pending).0
    };
    let written = hdf5::write_file(
        &tmp,
        a.sweep,
        a.grid,
        a.points,
        a.shard,
        a.provenance,
        a.verify.fraction,
        read,
        |i, rec| a.verify.info(work, a.grid, i, rec),
        a.search,
        values
            .is_some()
            .then_some(&tables as &dyn Fn() -> hdf5::fit::EnsembleTables),
    );
    let written = match written {
        Ok(w) => w,
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
    };
    // Read back, every point's values against their checksums, before the snapshot vouches for
    // the file (once published its values are not checked again): a write that failed unseen —
    // a chunk HDF5 wrote out when its dataset was closed, on a full or failing disk — left fill
    // values where the runs' are, and such a file is never published.
    let whole = match hdf5::FileRecords::open(&tmp) {
        Ok(r) => r
            .header_damage
            .clone()
            .or_else(|| {
                r.unreadable()
                    .first()
                    .map(|(name, why)| format!("{name}: {why}"))
            })
            .or_else(|| {
                r.damaged()
                    .next()
                    .map(|(i, why)| format!("point {i}: {why}"))
            })
            .map_or(Ok(()), Err),
        Err(e) => Err(e.to_string()),
    };
    if let Err(why) = whole {
        let _ = std::fs::remove_file(&tmp);
        return Err(crate::error::Error::Other(format!(
            "{}: the file just written does not read back whole ({why}): a write failed unseen (a full or failing disk?); nothing was published, the runs stay stored, and the same command writes it again",
            tmp.display()
        )));
    }
    let shard = a.shard.unwrap_or(Shard { k: 1, n: 1 }).to_string();
    let Some(digest) = published::file_sha256(&tmp) else {
        let _ = std::fs::remove_file(&tmp);
        return Err(crate::error::Error::Other(format!(
            "{}: the file just written cannot be read back",
            tmp.display()
        )));
    };
    let snapshot = published::snapshot_of(
        a.sweep,
        a.grid,
        &written.table,
        &shard,
        &a.provenance.created_utc,
        digest,
    );
    let held: HashSet<RunHash> = (0..a.grid.len())
        .filter(|&i| written.table.status(i) != STATUS_PENDING)
        .map(|i| a.grid.hashes[i])
        .collect();
    if let Err(e) = work.publish(&tmp, &snapshot, &|h| held.contains(h)) {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    Ok(written)
}
