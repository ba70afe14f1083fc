//! `status`: what an output file holds, or what the work directory of a sweep's output holds.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::grid::{Grid, Shard};
use crate::identity::hex;
use crate::record::{STATUS_FAILED, STATUS_OK, STATUS_PENDING};
use crate::store::hdf5::{Counts, FileRecords};
use crate::store::{scan_segments, work_dir_of, Stored};
use crate::sweep::auto::AutoChoice;
use crate::sweep::Sweep;

use super::auto::{apply_cached, CachedChoice};
use super::run::{Failure, LISTED_FAILURES};
use super::shard::{self, Assignment};

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
    let grid = Grid::new(&sweep).map_err(|e| e.in_file(&file.display().to_string()))?;
    let assignment = Assignment::new(&sweep, &grid, shard);
    let in_shard = |i: usize| i < grid.len() && assignment.contains(shard, i);
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
    /// What the work directory holds that is not a regular file where a log or segment is
    /// expected (left out).
    pub ignored: Vec<PathBuf>,
}

/// The status of `sweep`'s output `output` (its work directory), for `shard`.
pub fn of_sweep(
    mut sweep: Sweep,
    mut grid: Grid,
    output: PathBuf,
    shard: Option<Shard>,
) -> Result<(SweepStatus, Sweep, Grid)> {
    let dir = work_dir_of(&output);
    let points = shard::points(&sweep, &grid, shard);
    let mut status = SweepStatus {
        output,
        points: points.len(),
        auto: None,
        counts: None,
        auto_cache: None,
        failures: Vec::new(),
        ignored: Vec::new(),
    };
    match apply_cached(&mut sweep, &mut grid, &dir)? {
        CachedChoice::NotAuto => {}
        CachedChoice::Chosen(c) => status.auto = Some(*c),
        CachedChoice::NotChosen(cache) => {
            status.auto_cache = Some(cache);
            return Ok((status, sweep, grid));
        }
    }
    // Only whole, checksummed records count: the runs `run` finds done.
    let stored = Stored::scan(&dir, Some(&status.output))?;
    let state = |i: usize| stored.get(&grid.hashes[i]);
    let ok = points.iter().filter(|&&i| state(i) == Some(true)).count();
    let failed = points.iter().filter(|&&i| state(i) == Some(false)).count();
    status.ignored = stored.ignored().to_vec();
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
        let reason = stored
            .read(&grid.hashes[point])?
            .map(|r| r.reason)
            .unwrap_or_default();
        status.failures.push(Failure {
            point,
            reason: Some(reason),
        });
    }
    Ok((status, sweep, grid))
}

/// The state of one shard of a shard set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShardState {
    /// Every point of the shard ran successfully.
    Done,
    /// Every point ran, some failed (`run --retry-failed` runs them again).
    Failed,
    /// The file exists with points pending (the task is running, was stopped, or was killed).
    Pending,
    /// No file of this shard.
    Missing,
}

impl ShardState {
    /// `done`, `failed`, `pending`, `missing`.
    pub fn name(self) -> &'static str {
        match self {
            ShardState::Done => "done",
            ShardState::Failed => "failed",
            ShardState::Pending => "pending",
            ShardState::Missing => "missing",
        }
    }
}

/// One shard of a shard set.
#[derive(Debug, Clone)]
pub struct ShardEntry {
    /// The shard, from 1.
    pub k: usize,
    /// Its file, when there is one.
    pub file: Option<PathBuf>,
    /// Its state.
    pub state: ShardState,
    /// The state of its points (none when missing).
    pub counts: Option<Counts>,
}

/// The status of the shard files of one sweep in `n` shards.
#[derive(Debug, Clone)]
pub struct ShardSetStatus {
    /// Number of shards.
    pub n: usize,
    /// Every shard, 1 to `n`.
    pub shards: Vec<ShardEntry>,
}

impl ShardSetStatus {
    /// The shards (from 1) that are missing or have points pending: those to run (again).
    pub fn to_run(&self) -> Vec<usize> {
        self.shards
            .iter()
            .filter(|s| matches!(s.state, ShardState::Missing | ShardState::Pending))
            .map(|s| s.k)
            .collect()
    }
}

/// The shard files among `files` (those that exist; others are ignored): the sweep text and
/// `K/N` of each; an input error naming a file that is no shard file of the same sweep and `N`
/// as the first.
pub fn shard_files(files: &[PathBuf]) -> Result<Vec<(PathBuf, String, Shard)>> {
    let mut out: Vec<(PathBuf, String, Shard)> = Vec::new();
    for f in files.iter().filter(|f| f.exists()) {
        let bad = |m: String| Error::Input {
            file: Some(f.display().to_string()),
            field: String::new(),
            message: m,
        };
        let recs =
            FileRecords::open(f).map_err(|e| bad(format!("not a chainsweep output file: {e}")))?;
        let shard = Shard::parse(&recs.shard, "shard")
            .map_err(|_| bad(format!("records shard `{}`, not K/N", recs.shard)))?;
        if let Some((first, text, s0)) = out.first() {
            if *text != recs.sweep_text || s0.n != shard.n {
                return Err(bad(format!(
                    "is shard {shard} of {}, not of the sweep and shard count of {} (shard {s0})",
                    if *text == recs.sweep_text {
                        "the same sweep"
                    } else {
                        "another sweep"
                    },
                    first.display()
                )));
            }
        }
        out.push((f.clone(), recs.sweep_text.clone(), shard));
    }
    Ok(out)
}

/// The status of a shard set: `files` (those that exist) hold shards of one sweep in `N` shards;
/// every shard from 1 to `N` is done, failed, pending or missing.
pub fn of_shard_set(files: &[PathBuf]) -> Result<ShardSetStatus> {
    let found = shard_files(files)?;
    let Some((first, text, s0)) = found.first() else {
        return Err(Error::input(
            "FILE",
            format!("none of the {} shard file(s) given exists", files.len()),
        ));
    };
    let name = first.display().to_string();
    let sweep = Sweep::parse(text).map_err(|e| e.in_file(&name))?;
    let grid = Grid::new(&sweep).map_err(|e| e.in_file(&name))?;
    let n = s0.n;
    let assignment = Assignment::new(&sweep, &grid, Some(*s0));
    let mut shards = Vec::with_capacity(n);
    for k in 1..=n {
        let Some((path, _, shard)) = found.iter().find(|(_, _, s)| s.k == k) else {
            shards.push(ShardEntry {
                k,
                file: None,
                state: ShardState::Missing,
                counts: None,
            });
            continue;
        };
        let recs = FileRecords::open(path)?;
        let points = assignment.points(Some(*shard));
        let status = |i: usize| {
            if i < recs.len() {
                recs.status(i)
            } else {
                STATUS_PENDING
            }
        };
        let counts = Counts {
            ok: points.iter().filter(|&&i| status(i) == STATUS_OK).count(),
            failed: points
                .iter()
                .filter(|&&i| status(i) == STATUS_FAILED)
                .count(),
            pending: points
                .iter()
                .filter(|&&i| status(i) == STATUS_PENDING)
                .count(),
        };
        let state = if counts.pending > 0 {
            ShardState::Pending
        } else if counts.failed > 0 {
            ShardState::Failed
        } else {
            ShardState::Done
        };
        shards.push(ShardEntry {
            k,
            file: Some(path.clone()),
            state,
            counts: Some(counts),
        });
    }
    Ok(ShardSetStatus { n, shards })
}
