//! `gc`: the records of runs a sweep no longer has (orphans of an edited sweep) removed from its
//! output's work directory. A record the sweep needs is never removed: every grid point's run
//! and every point's verification run are kept, whatever `--verify` fraction a later run asks.

use std::collections::HashSet;
use std::path::Path;

use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::identity::RunHash;
use crate::numerics::verify;
use crate::store::{work_dir_of, Compaction, WorkDir};
use crate::sweep::Sweep;

use super::auto::{apply_cached, CachedChoice};

/// Every run `sweep` may need stored: each grid point's run and its verification run.
pub fn needed_runs(sweep: &Sweep, grid: &Grid) -> HashSet<RunHash> {
    let mut needed: HashSet<RunHash> = grid.hashes.iter().copied().collect();
    for i in 0..grid.len() {
        needed.insert(verify::point_verification(sweep, grid, i).1);
    }
    needed
}

/// Removes from the work directory of `output` every record `sweep` does not need. With
/// `integrator: auto` not chosen yet, nothing of this sweep can have run and the hashes it
/// needs are unknown: nothing is removed (an input error says so).
pub fn collect(mut sweep: Sweep, mut grid: Grid, output: &Path) -> Result<Compaction> {
    let dir = work_dir_of(output);
    if !dir.is_dir() {
        return Err(Error::input(
            "--output",
            format!(
                "{} has no work directory {}",
                output.display(),
                dir.display()
            ),
        ));
    }
    if let CachedChoice::NotChosen(cache) = apply_cached(&mut sweep, &mut grid, &dir)? {
        return Err(Error::input(
            "integrator",
            format!(
                "`auto` is not chosen yet for this sweep ({} holds no choice): the runs it needs are unknown, nothing was removed",
                cache.display()
            ),
        ));
    }
    let needed = needed_runs(&sweep, &grid);
    let work = WorkDir::open(output)?;
    work.prune(&|h| needed.contains(h))
}
