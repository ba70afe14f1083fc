//! The status of a set of shard files: each shard's state, and what they hold together.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::grid::{Grid, Shard};
use crate::record::{STATUS_FAILED, STATUS_OK, STATUS_PENDING, STATUS_UNSETTLED};
use crate::store::hdf5::{Counts, FileRecords};
use crate::store::writer_of;
use crate::sweep::Sweep;

use super::super::shard::Assignment;

/// The state of one shard of a shard set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShardState {
    /// Every point of the shard ran successfully.
    Done,
    /// Every point ran, some failed (`run --retry-failed` runs them again).
    Failed,
    /// Points pending and no process writing the shard (its task was stopped or killed, or has
    /// not started).
    Pending,
    /// A process is writing the shard now (it holds its work directory): not to be run again.
    Running,
    /// No file of this shard, and none being written.
    Missing,
}

impl ShardState {
    /// `done`, `failed`, `pending`, `running`, `missing`.
    pub fn name(self) -> &'static str {
        match self {
            ShardState::Done => "done",
            ShardState::Failed => "failed",
            ShardState::Pending => "pending",
            ShardState::Running => "running",
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
    /// The pid of the process writing it now, as its lock file names it (`Running`).
    pub writer: Option<String>,
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
    /// The shards (from 1) that are missing or have points pending, and that no process is
    /// writing: those to run (again).
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

/// The status of a shard set none of whose `files` (every shard's, in order) has been published
/// yet: each is being written (its work directory locked by a live process) or missing.
pub fn of_unstarted_shards(files: &[PathBuf]) -> ShardSetStatus {
    ShardSetStatus {
        n: files.len(),
        shards: files
            .iter()
            .enumerate()
            .map(|(i, p)| ShardEntry::unpublished(i + 1, Some(p)))
            .collect(),
    }
}

impl ShardEntry {
    /// Shard `k`, which has no published file: being written when a live process holds the
    /// work directory of its file `path` (named), else missing.
    fn unpublished(k: usize, path: Option<&Path>) -> ShardEntry {
        let writer = path.and_then(writer_of);
        ShardEntry {
            k,
            file: None,
            state: if writer.is_some() {
                ShardState::Running
            } else {
                ShardState::Missing
            },
            counts: None,
            writer,
        }
    }
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
    // Where a shard without a file would be written, by the naming of `run --shard` and
    // `chainsweep slurm` (beside the first shard file): a task that started but has not
    // published its file yet holds that path's work directory.
    let first_name = first.file_name().map(|f| f.to_string_lossy().into_owned());
    let suffix = format!(".shard-{}-of-{n}.h5", s0.k);
    let sibling = |k: usize| {
        let stem = first_name.as_deref()?.strip_suffix(&suffix)?;
        Some(first.with_file_name(format!("{stem}.shard-{k}-of-{n}.h5")))
    };
    let mut shards = Vec::with_capacity(n);
    for k in 1..=n {
        let Some((path, _, shard)) = found.iter().find(|(_, _, s)| s.k == k) else {
            shards.push(ShardEntry::unpublished(k, sibling(k).as_deref()));
            continue;
        };
        let recs = FileRecords::open(path)?;
        let points = assignment.points(Some(*shard), grid.len());
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
            unsettled: points
                .iter()
                .filter(|&&i| status(i) == STATUS_UNSETTLED)
                .count(),
        };
        let writer = writer_of(path);
        let state = if writer.is_some() {
            ShardState::Running
        } else if counts.pending > 0 {
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
            writer,
        });
    }
    Ok(ShardSetStatus { n, shards })
}
