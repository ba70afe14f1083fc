//! `status`: what an output file holds, or what the work directory of a sweep's output holds.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::grid::{Grid, Shard};
use crate::identity::hex;
use crate::record::{STATUS_FAILED, STATUS_OK, STATUS_PENDING};
use crate::store::hdf5::{Counts, FileRecords};
use crate::store::{read_segment_in, scan_segments, work_dir_of};
use crate::sweep::auto::AutoChoice;
use crate::sweep::Sweep;

use super::auto::{apply_cached, CachedChoice};
use super::run::{Failure, LISTED_FAILURES};
use super::shard;

/// The status of an output file.
#[derive(Debug, Clone)]
pub struct FileStatus {
    /// Grid points of the file's shard (all of them when not sharded).
    pub total: usize,
    /// The grid's shape.
    pub shape: Vec<usize>,
    /// The file's `shard` attribute (`K/N`).
    pub shard: String,
    /// Successful, failed and pending points.
    pub counts: Counts,
    /// Points pending in the file whose run has finished since (a sweep is running, or was
    /// interrupted).
    pub newer: usize,
    /// Every failed point with its reason, in grid order.
    pub failures: Vec<(usize, String)>,
}

/// The status of the output file `file`.
pub fn of_file(file: &Path) -> Result<FileStatus> {
    let recs = FileRecords::open(file).map_err(|e| Error::Input {
        file: Some(file.display().to_string()),
        field: String::new(),
        message: format!("not a chainsweep output file: {e}"),
    })?;
    let sweep =
        Sweep::parse(&recs.sweep_text).map_err(|e| e.in_file(&file.display().to_string()))?;
    let shard = Some(Shard::parse(&recs.shard, "--shard")?).filter(|s| s.n > 1);
    let n = recs.len();
    let in_shard = |i: usize| shard::contains(shard, i);
    let counts = Counts {
        ok: (0..n).filter(|&i| recs.status(i) == STATUS_OK).count(),
        failed: (0..n).filter(|&i| recs.status(i) == STATUS_FAILED).count(),
        pending: (0..n)
            .filter(|&i| in_shard(i) && recs.status(i) == STATUS_PENDING)
            .count(),
    };
    // Runs finished since the file was last assembled (it is refreshed by `run`).
    let segs: HashSet<String> = scan_segments(&work_dir_of(file))?.keys().map(hex).collect();
    let newer = (0..n)
        .filter(|&i| in_shard(i) && recs.status(i) == STATUS_PENDING)
        .filter(|&i| segs.contains(recs.hash_hex(i)))
        .count();
    Ok(FileStatus {
        total: (0..n).filter(|&i| in_shard(i)).count(),
        shape: sweep.shape(),
        shard: recs.shard.clone(),
        counts,
        newer,
        failures: (0..n)
            .filter(|&i| recs.status(i) == STATUS_FAILED)
            .map(|i| (i, recs.reason(i).to_string()))
            .collect(),
    })
}

/// The status of a sweep file's output, from its work directory.
#[derive(Debug, Clone)]
pub struct SweepStatus {
    /// The output file.
    pub output: PathBuf,
    /// Grid points of this output (or shard).
    pub points: usize,
    /// `integrator: auto`'s choice, when the sweep uses it and it is made.
    pub auto: Option<AutoChoice>,
    /// Counts of finished and pending points; `None` when `integrator: auto` is not chosen yet
    /// (nothing can have run).
    pub counts: Option<Counts>,
    /// The cache file that holds no choice, when `integrator: auto` is not chosen yet.
    pub auto_cache: Option<PathBuf>,
    /// The first [`LISTED_FAILURES`] failed points, with their reasons.
    pub failures: Vec<Failure>,
}

/// The status of `sweep`'s output `output` (its work directory), for `shard`.
pub fn of_sweep(
    mut sweep: Sweep,
    mut grid: Grid,
    output: PathBuf,
    shard: Option<Shard>,
) -> Result<(SweepStatus, Sweep, Grid)> {
    let dir = work_dir_of(&output);
    let points = shard::points(grid.len(), shard);
    let mut status = SweepStatus {
        output,
        points: points.len(),
        auto: None,
        counts: None,
        auto_cache: None,
        failures: Vec::new(),
    };
    match apply_cached(&mut sweep, &mut grid, &dir)? {
        CachedChoice::NotAuto => {}
        CachedChoice::Chosen(c) => status.auto = Some(*c),
        CachedChoice::NotChosen(cache) => {
            status.auto_cache = Some(cache);
            return Ok((status, sweep, grid));
        }
    }
    let segs = scan_segments(&dir)?;
    let state = |i: usize| segs.get(&grid.hashes[i]).copied();
    let ok = points.iter().filter(|&&i| state(i) == Some(true)).count();
    let failed = points.iter().filter(|&&i| state(i) == Some(false)).count();
    status.counts = Some(Counts {
        ok,
        failed,
        pending: points.len() - ok - failed,
    });
    for &point in points
        .iter()
        .filter(|&&i| state(i) == Some(false))
        .take(LISTED_FAILURES)
    {
        let reason = read_segment_in(&dir, &grid.hashes[point])?
            .map(|r| r.reason)
            .unwrap_or_default();
        status.failures.push(Failure {
            point,
            reason: Some(reason),
        });
    }
    Ok((status, sweep, grid))
}
