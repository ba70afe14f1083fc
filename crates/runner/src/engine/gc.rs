//! `gc`: the records of runs a sweep no longer has (orphans of an edited sweep) removed from its
//! output's work directory, and the damaged output files kept there. A record the sweep needs is
//! never removed: every grid point's run and every point's verification run are kept, whatever
//! `--verify` fraction a later run asks. The only command that removes finished runs: it says
//! which, and with `dry_run` only says so.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::identity::RunHash;
use crate::numerics::verify;
use crate::store::{work_dir_of, Compaction, WorkDir, DAMAGED_DIR};
use crate::sweep::Sweep;

use super::auto::{apply_cached, CachedChoice};
use super::DamageReport;

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
pub fn collect(mut sweep: Sweep, mut grid: Grid, output: &Path, dry_run: bool) -> Result<GcReport> {
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
    let work = WorkDir::open(output, Some(&grid))?;
    let needed = if sweep.search.is_some() {
        // A search needs the runs its replay reaches (and their verification runs).
        let driver = super::search::Driver::new(&sweep, &grid);
        let outer: Vec<usize> = (0..driver.layout.n_outer()).collect();
        let reached = super::search::reached_runs(&driver, &outer, &work)?;
        let searches = driver.replay_stored(&outer, &work)?;
        let file_grid = driver.file_grid(&searches);
        let file_sweep = driver.file_sweep(&searches);
        let mut needed = reached;
        for i in (0..file_grid.len()).filter(|&i| file_grid.hashes[i] != [0; 32]) {
            needed.insert(verify::point_verification(&file_sweep, &file_grid, i).1);
        }
        needed
    } else {
        let mut needed = needed_runs(&sweep, &grid);
        // An adaptive ensemble's later rounds (each holding the ones before): a sweep stopped
        // in round 6 has stored runs round 0 does not have, which resuming takes up.
        if let Some(last) = sweep
            .ensemble
            .as_ref()
            .map(|e| e.last_round())
            .filter(|&k| k > 0)
        {
            let round = sweep.at_ensemble_round(last);
            let round_grid = Grid::new(&round)?;
            needed.extend(needed_runs(&round, &round_grid));
        }
        needed
    };
    let damage = DamageReport::new(output, &work.damage(), &sweep, &grid);
    // Never through a link (the work directory's other paths are refused so too): refused before
    // anything is removed.
    let damaged_dir = crate::store::no_link(&dir.join(DAMAGED_DIR))?;
    let compaction = work.prune(&|h| needed.contains(h), dry_run)?;
    let mut damaged_files: Vec<PathBuf> = match std::fs::read_dir(&damaged_dir) {
        Ok(entries) => entries
            .filter_map(|e| e.ok())
            .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
            .map(|e| e.path())
            .collect(),
        Err(_) => Vec::new(),
    };
    damaged_files.sort();
    if !dry_run {
        for f in &damaged_files {
            std::fs::remove_file(f).map_err(Error::io("remove", f))?;
        }
    }
    Ok(GcReport {
        compaction,
        damaged_files,
        damage,
        dry_run,
    })
}

/// What `gc` removed (or, with `--dry-run`, would remove).
#[derive(Debug, Clone)]
pub struct GcReport {
    /// The records of runs the sweep does not have.
    pub compaction: Compaction,
    /// Damaged output files kept in the work directory's `damaged/`.
    pub damaged_files: Vec<PathBuf>,
    /// Damage found in the output file (its damaged runs are computed again by `run`).
    pub damage: DamageReport,
    /// Whether nothing was removed (a dry run).
    pub dry_run: bool,
}
