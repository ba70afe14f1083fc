//! `merge`: shard files of one sweep assembled into one output file, identical to a
//! single-machine run. The merged output's work directory is filled with the shards' runs, so it
//! can be resumed like any output.

use std::collections::hash_map::Entry;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::identity::{hex, RunHash};
use crate::numerics::verify;
use crate::record::STATUS_PENDING;
use crate::store::hdf5::{self, Counts, Provenance};
use crate::store::published::{Check, PublishedFile};
use crate::store::{RunStore, WorkDir};
use crate::sweep::Sweep;

use super::assemble::{assemble, Assembly, VerifySource};
use super::status::{self, ShardSetStatus};
use super::{auto, check_output, DamageReport};

/// What a merge did.
#[derive(Debug, Clone)]
pub struct MergeReport {
    /// Shard files merged.
    pub shards: usize,
    /// Grid points of the sweep.
    pub points: usize,
    /// The state of those points in the merged file.
    pub counts: Counts,
    /// Shard files given that do not exist.
    pub absent: Vec<PathBuf>,
    /// Whether the sweep is a search's: `points` and `counts` are then its searches (ended,
    /// failed, unfinished), not runs.
    pub searches: bool,
    /// The state of every shard, when the files are shards of one shard count `N` (to name the
    /// missing and incomplete ones).
    pub shard_set: Option<ShardSetStatus>,
    /// Damage found in shard files (and the output's own file): each damaged run is left
    /// pending in the merged file, to be run again in its shard.
    pub damage: Vec<DamageReport>,
}

/// Merges `shards` (files made by `run --shard` from one sweep file) into `output`.
/// Shard files that do not exist are missing shards (named in the report), as long as one exists.
pub fn merge(output: &Path, given: &[PathBuf], provenance: &Provenance) -> Result<MergeReport> {
    let (shards, absent): (Vec<PathBuf>, Vec<PathBuf>) =
        given.iter().cloned().partition(|p| p.exists());
    if shards.is_empty() {
        return Err(Error::input(
            "SHARDS",
            format!(
                "none of the {} shard file(s) exists (first: {})",
                given.len(),
                given[0].display()
            ),
        ));
    }
    let shards = &shards[..];
    let text = common_sweep_text(shards)?;
    let first = shards[0].display().to_string();
    let mut sweep = Sweep::parse(&text).map_err(|e| e.in_file(&first))?;
    // Shards of an adaptive ensemble hold one round of it: the merge is of that round, and its
    // file says whether another is due.
    if let Some(k) = super::ensemble::round_of_shards(&sweep, shards)? {
        sweep = sweep.at_ensemble_round(k);
    }
    let mut grid = Grid::new(&sweep).map_err(|e| e.in_file(&first))?;
    auto::apply_from_shards(&mut sweep, &mut grid, shards)?;
    check_output(output, false)?;
    if shards
        .iter()
        .any(|s| s.canonicalize().ok() == output.canonicalize().ok() && output.exists())
    {
        return Err(Error::input(
            "--output",
            "must not be one of the shard files",
        ));
    }
    if sweep.search.is_some() {
        let work = WorkDir::open(output, None)?;
        auto::cache(&work, &sweep)?;
        let (searches, _, damage) =
            super::search::merge_searches(&work, &sweep, &grid, shards, provenance)?;
        // The searches are the points: ended, or not (a shard missing or stopped early).
        let ended = searches.iter().filter(|s| s.finished).count();
        return Ok(MergeReport {
            searches: true,
            shards: shards.len(),
            points: searches.len(),
            counts: Counts {
                ok: ended,
                pending: searches.len() - ended,
                ..Counts::default()
            },
            absent,
            shard_set: None,
            damage,
        });
    }
    let work = WorkDir::open(output, Some(&grid))?;
    auto::cache(&work, &sweep)?;
    let mut damage = Vec::new();
    let own = DamageReport::new(output, &work.damage(), &sweep, &grid);
    if own.any() {
        damage.push(own);
    }
    let mut done: HashMap<RunHash, bool> = HashMap::new();
    let mut vsrc = VerifySource::empty(0.0);
    for s in shards {
        let d = take_shard(s, &sweep, &grid, &work, &mut done, &mut vsrc)?;
        if d.any() {
            damage.push(d);
        }
    }
    // Runs already in the output's work directory count too.
    for &h in &grid.hashes {
        if let Entry::Vacant(slot) = done.entry(h) {
            if let Some(rec) = work.read(&h)? {
                slot.insert(rec.ok);
            }
        }
    }
    let points: Vec<usize> = (0..grid.len()).collect();
    // Points whose run was already in the output's work directory: their verification runs too.
    let index = work.index()?;
    for &i in &points {
        if vsrc.given.contains_key(&i) {
            continue;
        }
        let (_, vh, allowance) = verify::point_verification(&sweep, &grid, i);
        if let Some(&ok) = index.get(&vh) {
            vsrc.done.insert(vh, ok);
        }
        vsrc.insert(i, vh, allowance);
    }
    let counts = assemble(
        &work,
        &Assembly {
            sweep: &sweep,
            grid: &grid,
            points: &points,
            shard: None,
            done: &done,
            provenance,
            verify: &vsrc,
            search: None,
        },
    )?
    .counts;
    if counts.pending == 0 {
        // Complete: the logs beside the merged file shrink to what it lacks (verification runs).
        work.compact_after_publish(&grid)?;
    }
    // Which shards to run again: only when the files are shards of one `N` (a merge may also
    // combine outputs sharded differently, or whole runs).
    // (Unsharded files, of one shard of 1, are no shard set: there is no task to run again.)
    let shard_set = if counts.pending > 0 {
        status::of_shard_set(shards).ok().filter(|set| set.n > 1)
    } else {
        None
    };
    Ok(MergeReport {
        searches: false,
        shards: shards.len(),
        points: grid.len(),
        counts,
        absent,
        shard_set,
        damage,
    })
}

/// The sweep file's text every shard records; an input error naming the shard that is no
/// chainsweep output or was made from another sweep.
fn common_sweep_text(shards: &[PathBuf]) -> Result<String> {
    let mut text: Option<String> = None;
    for s in shards {
        let bad = |m: String| Error::Input {
            file: Some(s.display().to_string()),
            field: String::new(),
            message: m,
        };
        if !hdf5::is_hdf5(s) {
            return Err(bad("not an HDF5 file".into()));
        }
        let t = hdf5::read_sweep_text(s)
            .map_err(|e| bad(format!("not a chainsweep output file: {e}")))?;
        match &text {
            None => text = Some(t),
            Some(first) if *first != t => {
                return Err(bad(format!(
                    "was made from a different sweep file than {}; shards must come from the same sweep",
                    shards[0].display()
                )))
            }
            _ => {}
        }
    }
    Ok(text.expect("at least one shard"))
}

/// Copies the finished runs of shard file `path` into `work` (those not there yet), every value
/// checked, and takes their verification outcomes as they are. A damaged run the shard's snapshot
/// does not give back is left out (pending), and reported.
fn take_shard(
    path: &Path,
    sweep: &Sweep,
    grid: &Grid,
    work: &WorkDir,
    done: &mut HashMap<RunHash, bool>,
    vsrc: &mut VerifySource,
) -> Result<DamageReport> {
    let Some(p) = PublishedFile::open(path, Some(grid), Check::Everything) else {
        return Err(Error::Other(format!("{}: cannot be read", path.display())));
    };
    let report = DamageReport::new(path, &p.damage, sweep, grid);
    let Some(recs) = p.file() else {
        // Unreadable: what its snapshot holds is all there is (reported).
        take_runs(&p, grid, work, done, vsrc)?;
        return Ok(report);
    };
    vsrc.fraction = vsrc.fraction.max(recs.verify_fraction);
    if recs.len() != grid.len() {
        return Err(Error::Other(format!(
            "{}: holds {} grid points, the sweep has {}",
            path.display(),
            recs.len(),
            grid.len()
        )));
    }
    for i in 0..grid.len() {
        let h = grid.hashes[i];
        let finished = recs.damage(i).is_none() && recs.status(i) != STATUS_PENDING;
        if finished && !recs.holds(i, &h) {
            return Err(Error::Other(format!(
                "{}: point {i} has run hash {}, this chainsweep computes {}: the shard was made by a different engine version",
                path.display(),
                recs.hash_hex(i),
                hex(&h)
            )));
        }
    }
    take_runs(&p, grid, work, done, vsrc)?;
    Ok(report)
}

/// Takes every run of `grid` that the shard file `p` gives back and `done` does not hold yet.
fn take_runs(
    p: &PublishedFile,
    grid: &Grid,
    work: &WorkDir,
    done: &mut HashMap<RunHash, bool>,
    vsrc: &mut VerifySource,
) -> Result<()> {
    for i in 0..grid.len() {
        let h = grid.hashes[i];
        if done.contains_key(&h) || !p.holds(&h) {
            continue;
        }
        let Some(rec) = p.read(&h) else {
            continue;
        };
        if work.read(&h)?.is_none() {
            work.write(&rec)?;
        }
        done.insert(h, rec.ok);
        if let Some(v) = p.verify_info(&h) {
            vsrc.given.insert(i, v);
        }
    }
    Ok(())
}
