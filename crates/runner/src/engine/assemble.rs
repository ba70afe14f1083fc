//! The output file, written from the stored runs in grid order and published atomically.

use std::collections::HashMap;

use crate::error::Result;
use crate::grid::{Grid, Shard};
use crate::identity::RunHash;
use crate::numerics::verify;
use crate::record::{RunRecord, VerifyInfo};
use crate::store::hdf5::{self, Counts, Provenance};
use crate::store::{RunStore, WorkDir};
use crate::sweep::Sweep;

/// Where the verification outcome of each point comes from when a file is assembled.
#[derive(Debug, Clone, Default)]
pub struct VerifySource {
    /// The `--verify` fraction (recorded as an attribute).
    pub fraction: f64,
    /// Verification hash of each grid point (computed for the points of this shard).
    pub hashes: HashMap<usize, RunHash>,
    /// Verification runs known to be stored (ok or failed), by hash.
    pub done: HashMap<RunHash, bool>,
    /// Outcomes taken as they are (from merged shard files), by point.
    pub given: HashMap<usize, VerifyInfo>,
}

impl VerifySource {
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
        Ok(verify::compare(rec, tight.as_ref(), np))
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
}

/// Writes the output file of `work` from the stored runs and publishes it atomically: the
/// output is always either its previous complete version or the new one. The runs it holds are
/// made durable in the work directory first.
pub fn assemble(work: &WorkDir, a: &Assembly<'_>) -> Result<Counts> {
    work.sync()?;
    let tmp = work.tmp_path("assemble.h5");
    let counts = hdf5::write_file(
        &tmp,
        a.sweep,
        a.grid,
        a.points,
        a.shard,
        a.provenance,
        a.verify.fraction,
        |i| {
            let h = a.grid.hashes[i];
            if a.done.contains_key(&h) {
                work.read(&h)
            } else {
                Ok(None)
            }
        },
        |i, rec| a.verify.info(work, a.grid, i, rec),
    );
    let counts = match counts {
        Ok(c) => c,
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
    };
    work.publish(&tmp)?;
    Ok(counts)
}
