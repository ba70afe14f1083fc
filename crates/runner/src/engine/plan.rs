//! What a run of a sweep has to do: which of its grid points are finished already (resume),
//! which to run, and which verification runs `--verify` asks for.

use std::collections::{HashMap, HashSet};

use crate::error::Result;
use crate::grid::Grid;
use crate::identity::RunHash;
use crate::numerics::verify;
use crate::store::{RunStore, SegmentIndex};
use crate::sweep::Sweep;

use super::assemble::VerifySource;
use super::schedule::Task;

/// The plan of a run: the state of its grid points and verification runs, and the tasks left.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The grid points of this run (or shard), in grid order.
    pub points: Vec<usize>,
    /// Finished runs by hash (`true`: it succeeded); updated as runs finish.
    pub done: HashMap<RunHash, bool>,
    /// How many of `points` share each run hash (a run counts once per point).
    pub multiplicity: HashMap<RunHash, usize>,
    /// Verification: every point's verification hash, those stored, the fraction.
    pub verify: VerifySource,
    /// Which grid points the `--verify` sample holds (over the whole grid).
    pub sampled: Vec<bool>,
    /// Runs left to do: grid points first, then verification runs.
    pub tasks: Vec<Task>,
    /// Runs in all (grid points and sampled verification runs of these points).
    pub total: usize,
    /// Of `total`, the runs finished before this plan was made.
    pub done_before: usize,
    /// Of `done_before`, those that failed.
    pub failed_before: usize,
    /// Grid points finished before this plan was made.
    pub points_done_before: usize,
}

impl Plan {
    /// Plans the run of `points` of `grid` from what `store` holds: every point whose run is
    /// stored is done (a failed one too, unless `retry_failed`); the `fraction` sample of the
    /// grid is verified (see [`verify::sample`]).
    pub fn new(
        sweep: &Sweep,
        grid: &Grid,
        points: Vec<usize>,
        store: &dyn RunStore,
        retry_failed: bool,
        fraction: f64,
    ) -> Result<Plan> {
        // Every stored run of these points: the store's index lists only whole, checksummed
        // records (a corrupt one is run again).
        let index = store.index()?;
        let mut done: HashMap<RunHash, bool> = HashMap::new();
        let mut multiplicity: HashMap<RunHash, usize> = HashMap::new();
        let mut pending: Vec<usize> = Vec::new();
        for &i in &points {
            let h = grid.hashes[i];
            let seen = multiplicity.contains_key(&h);
            *multiplicity.entry(h).or_insert(0) += 1;
            if seen {
                continue;
            }
            match index.get(&h) {
                Some(&ok) if ok || !retry_failed => {
                    done.insert(h, ok);
                }
                _ => pending.push(i),
            }
        }
        let (verify, sampled, vpending, vcounts) =
            plan_verification(sweep, grid, &points, &index, retry_failed, fraction)?;
        let tasks: Vec<Task> = pending
            .iter()
            .map(|&i| Task::run(grid, i))
            .chain(vpending.iter().map(|&i| Task::verification(&verify, i)))
            .collect();
        let points_done_before = points
            .iter()
            .filter(|&&i| done.contains_key(&grid.hashes[i]))
            .count();
        let points_failed_before = points
            .iter()
            .filter(|&&i| done.get(&grid.hashes[i]) == Some(&false))
            .count();
        Ok(Plan {
            total: points.len() + vcounts.total,
            done_before: points_done_before + vcounts.done,
            failed_before: points_failed_before + vcounts.failed,
            points_done_before,
            points,
            done,
            multiplicity,
            verify,
            sampled,
            tasks,
        })
    }

    /// Records a finished task.
    pub fn finish(&mut self, task: &Task, ok: bool) {
        if task.verification {
            self.verify.done.insert(task.hash, ok);
        } else {
            self.done.insert(task.hash, ok);
        }
    }

    /// Whether every point of the plan and every sampled verification run is finished.
    pub fn complete(&self, grid: &Grid) -> bool {
        self.points
            .iter()
            .all(|&i| self.done.contains_key(&grid.hashes[i]))
            && self
                .points
                .iter()
                .filter(|&&i| self.sampled[i])
                .all(|i| self.verify.done.contains_key(&self.verify.hashes[i]))
    }

    /// The runs this sweep needs kept: every grid point's run and the verification run of every
    /// point of the plan (sampled now or not: a larger `--verify` later takes them).
    pub fn needed(&self, grid: &Grid) -> HashSet<RunHash> {
        grid.hashes
            .iter()
            .chain(self.verify.hashes.values())
            .copied()
            .collect()
    }

    /// How many runs of the progress count a finished task stands for: one per grid point
    /// sharing its hash, one for a verification run.
    pub fn weight(&self, task: &Task) -> usize {
        if task.verification {
            1
        } else {
            self.multiplicity[&task.hash]
        }
    }
}

/// Counts of the sampled verification runs of a plan.
#[derive(Debug, Clone, Copy, Default)]
struct VerifyCounts {
    total: usize,
    done: usize,
    failed: usize,
}

/// Whether `index` holds a run that is not one of `grid`'s points: a verification run (or the
/// run of a point an edited sweep no longer has), which only the verification hashes can name.
fn stores_other_runs(grid: &Grid, index: &SegmentIndex) -> bool {
    if index.is_empty() {
        return false;
    }
    let own: HashSet<&RunHash> = grid.hashes.iter().collect();
    index.keys().any(|h| !own.contains(h))
}

/// The verification hash of every point, the stored verification runs, the sample, the sampled
/// points still to verify and the counts.
fn plan_verification(
    sweep: &Sweep,
    grid: &Grid,
    points: &[usize],
    index: &SegmentIndex,
    retry_failed: bool,
    fraction: f64,
) -> Result<(VerifySource, Vec<bool>, Vec<usize>, VerifyCounts)> {
    let mut source = VerifySource::empty(fraction);
    let sampled = verify::sample(grid, fraction);
    let mut pending: Vec<usize> = Vec::new();
    let mut seen: HashSet<RunHash> = HashSet::new();
    let mut counts = VerifyCounts::default();
    if fraction == 0.0 && !stores_other_runs(grid, index) {
        // Nothing to verify, and nothing stored but the grid's own runs (a fresh sweep without
        // `--verify`, or one resumed or complete that never had one): there is no verification
        // run to find, keep or run, so no point's verification scene is expanded and hashed
        // (182 points: 36 M instructions before the first run starts; 100 000 points: about a
        // second). Every point then reads as not verified, as it would with the hashes.
        return Ok((source, sampled, pending, counts));
    }
    for &i in points {
        let (_, vh, allowance) = verify::point_verification(sweep, grid, i);
        source.insert(i, vh, allowance);
        let state = index.get(&vh).copied();
        if let Some(ok) = state {
            source.done.insert(vh, ok);
        }
        if !sampled[i] {
            continue;
        }
        counts.total += 1;
        match state {
            Some(ok) if ok || !retry_failed => {
                counts.done += 1;
                counts.failed += (!ok) as usize;
            }
            _ => {
                if seen.insert(vh) {
                    pending.push(i);
                } else {
                    counts.total -= 1;
                }
            }
        }
    }
    Ok((source, sampled, pending, counts))
}
