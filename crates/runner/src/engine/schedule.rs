//! The scheduler: tasks run on a thread pool through an [`Executor`], each finished run stored at
//! once, and the coordinating thread told of every finished run and of when a checkpoint is due.
//!
//! A panic of the executor is a failed run with its message, never the end of the sweep. Workers
//! take no new task once the stop flag is set (by the caller, e.g. on a signal) or once storing a
//! run or writing a checkpoint failed; the tasks already running finish and are stored.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{mpsc, Arc, Condvar, Mutex, OnceLock};
use std::time::{Duration, Instant};

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::exec;
use crate::grid::Grid;
use crate::identity::RunHash;
use crate::numerics::verify;
use crate::record::RunRecord;
use crate::store::RunStore;
use crate::sweep::Sweep;
use chainsweep_solver::scene::Continuation;

use super::assemble::VerifySource;

/// One unit of work: a grid point's run, or its verification run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Task {
    /// The grid point (flat index).
    pub point: usize,
    /// The run's hash: the point's run hash, or its verification hash.
    pub hash: RunHash,
    /// Whether this is the verification run of the point.
    pub verification: bool,
}

impl Task {
    /// The run of grid point `point`.
    pub fn run(grid: &Grid, point: usize) -> Task {
        Task {
            point,
            hash: grid.hashes[point],
            verification: false,
        }
    }

    /// The verification run of grid point `point` (its hash from `verify`).
    pub fn verification(verify: &VerifySource, point: usize) -> Task {
        Task {
            point,
            hash: verify.hashes[&point],
            verification: true,
        }
    }
}

/// Runs one task into its record (whose hash must be the task's). It may panic: the scheduler
/// records a panic as the run's failure, with the panic's message.
pub trait Executor: Sync {
    /// Runs `task`.
    fn execute(&self, task: &Task) -> RunRecord;
}

/// The executor of a sweep: each task's scene built from the grid and run by the solver.
pub struct SolverExecutor<'a> {
    /// The sweep.
    pub sweep: &'a Sweep,
    /// Its grid.
    pub grid: &'a Grid,
    /// The final states of the points of a continuation axis, when the sweep has one.
    continued: Option<ContinuedStates>,
}

/// The final states of a continuation axis's points, each point run once: a point's task waits
/// for (or runs) the point before it on its line, whose record it keeps for that point's own
/// task. Only points that ran are held (a state is `16 N` bytes for `N` particles).
#[derive(Default)]
struct ContinuedStates {
    /// Per point: its final state, or why there is none (the run failed).
    states: Mutex<HashMap<usize, Arc<FinalState>>>,
    /// Records of points run ahead of their own task (as the predecessor of another), each taken
    /// by that task.
    ahead: Mutex<HashMap<usize, RunRecord>>,
}

/// A point's final state once it has run, or why it has none.
type FinalState = OnceLock<std::result::Result<Vec<f64>, String>>;

impl<'a> SolverExecutor<'a> {
    /// The executor of `sweep` over `grid`.
    pub fn new(sweep: &'a Sweep, grid: &'a Grid) -> Self {
        SolverExecutor {
            sweep,
            grid,
            continued: sweep.continuation.map(|_| ContinuedStates::default()),
        }
    }

    /// The final state of point `p` of a continuation axis, running it (and, first, the points
    /// before it on its line that have not run in this process, in order: a loop, not a
    /// recursion, so a line of any length runs and resumes) when it has not run yet; each record
    /// is kept for its own task. Where there is none, the line's first failure, named: the same
    /// few words for every point after it, whatever the line's length.
    fn final_state(&self, p: usize) -> std::result::Result<Vec<f64>, String> {
        let states = self.continued.as_ref().expect("a continuation axis");
        let c = self.sweep.continuation.expect("a continuation axis");
        let cell = |q: usize| {
            Arc::clone(
                states
                    .states
                    .lock()
                    .expect("no panic holds the lock")
                    .entry(q)
                    .or_default(),
            )
        };
        // The points of the line back from `p` to the last one whose state is known.
        let mut todo = vec![p];
        while let Some(q) = c.predecessor(&self.grid.shape, *todo.last().expect("one")) {
            if cell(q).get().is_some() {
                break;
            }
            todo.push(q);
        }
        for &q in todo.iter().rev() {
            cell(q).get_or_init(|| {
                let (record, state) = self.run_continued(q, self.grid.hashes[q], false);
                states
                    .ahead
                    .lock()
                    .expect("no panic holds the lock")
                    .insert(q, record);
                state
            });
        }
        cell(p).get().expect("just run").clone()
    }

    /// Runs point `p` of a continuation axis (its verification run when `verification`) from
    /// the final state of the point before it on its line: its record under `hash`, and its
    /// final state or the line's first failure (this point's own, or the one that left its
    /// predecessor without a state). A point whose predecessor has no state fails, naming the
    /// line's first failure.
    fn run_continued(
        &self,
        p: usize,
        hash: RunHash,
        verification: bool,
    ) -> (RunRecord, std::result::Result<Vec<f64>, String>) {
        let (sweep, grid) = (self.sweep, self.grid);
        let c = sweep.continuation.expect("a continuation axis");
        let mut scene = if verification {
            verify::point_verification(sweep, grid, p).0
        } else {
            grid.build(sweep, p).expect("every point was validated")
        };
        let failed_here = |reason: String| {
            let first = format!(
                "point {p} ({}) failed: {reason}",
                grid.point_label(sweep, p)
            );
            (RunRecord::failed(hash, reason, 0.0), Err(first))
        };
        let start = match c.predecessor(&grid.shape, p) {
            None => None,
            Some(q) => match self.final_state(q) {
                Err(first) => {
                    let reason = format!(
                        "the point before it on the continuation axis ({}) has no state to start from; the line's first failure: {first}",
                        grid.point_label(sweep, q)
                    );
                    return (RunRecord::failed(hash, reason, 0.0), Err(first));
                }
                Ok(previous) => {
                    let chain = scene.validate().expect("every point was validated");
                    let before = grid
                        .build(sweep, q)
                        .expect("every point was validated")
                        .validate()
                        .expect("every point was validated");
                    match scene.continued_state(&chain, &previous, &before) {
                        Ok(y) => Some(y),
                        Err(e) => return failed_here(e.to_string()),
                    }
                }
            },
        };
        scene.continuation = Some(Continuation { start_state: start });
        let (record, state) =
            exec::execute_continued(&scene, hash, &sweep.limits, (!verification).then_some(p));
        match state {
            Some(y) => (record, Ok(y)),
            None => {
                let first = format!(
                    "point {p} ({}) failed: {}",
                    grid.point_label(sweep, p),
                    record.reason
                );
                (record, Err(first))
            }
        }
    }
}

impl Executor for SolverExecutor<'_> {
    fn execute(&self, task: &Task) -> RunRecord {
        let (sweep, grid, i) = (self.sweep, self.grid, task.point);
        if let Some(states) = &self.continued {
            if task.verification {
                return self.run_continued(i, task.hash, true).0;
            }
            // Run here, or by the task of a later point on the line that needed this state.
            let _ = self.final_state(i);
            return states
                .ahead
                .lock()
                .expect("no panic holds the lock")
                .remove(&i)
                .expect("each point's task runs once");
        }
        if task.verification {
            let (tight, vh, _) = verify::point_verification(sweep, grid, i);
            debug_assert_eq!(vh, task.hash);
            exec::execute_verification(&tight, vh, &sweep.limits)
        } else {
            let scene = grid.build(sweep, i).expect("every point was validated");
            exec::execute(&scene, task.hash, &sweep.limits, i)
        }
    }
}

/// The coordinating thread's side of a run: it hears of every finished run and writes
/// checkpoints. Its methods run on the thread that called [`run_tasks`], one at a time.
pub trait Coordinator {
    /// The workers have been handed the tasks: work that must come before any task's record is
    /// stored but need not hold the computations back (writing the output file as it stands) is
    /// done here, on the coordinator's thread, while they run. The records of runs that end
    /// before it returns are held (up to [`HELD_RECORDS`]; a worker with one more waits) and
    /// stored as soon as it has. An error is handled as a failed [`Coordinator::checkpoint`]:
    /// no new task starts, and the runs already finished or in flight are stored all the same
    /// (nothing computed is thrown away; the next run of the same command resumes from them).
    fn begun(&mut self) -> Result<()> {
        Ok(())
    }
    /// `task` finished and its record is stored (`ok`: the run succeeded).
    fn finished(&mut self, task: &Task, ok: bool);
    /// Nothing finished for a while.
    fn idle(&mut self);
    /// A checkpoint is due: write the output with everything finished so far.
    fn checkpoint(&mut self) -> Result<()>;
    /// The stop flag was seen set (once per run of the tasks): no new task starts, the
    /// `in_flight` tasks running now finish and are stored. A good moment to write the output
    /// with everything finished so far.
    fn stopping(&mut self, _in_flight: usize) -> Result<()> {
        Ok(())
    }
    /// A checkpoint (or the write at [`Coordinator::stopping`]) failed with `error`: no new task
    /// starts, the `in_flight` tasks running now finish and are stored, and [`run_tasks`] then
    /// returns the error. Called at once, so that the user hears of it now, not when the tasks
    /// in flight have finished.
    fn checkpoint_failed(&mut self, _error: &Error, _in_flight: usize) {}
    /// Every worker is done (also after a run could not be stored or a checkpoint failed).
    fn ended(&mut self);
}

/// How the scheduler runs.
pub struct Schedule<'a> {
    /// The worker threads.
    pub pool: &'a rayon::ThreadPool,
    /// Time between checkpoints (zero: none).
    pub checkpoint_every: Duration,
    /// Set by the caller to take no new task.
    pub stop: &'a AtomicBool,
}

/// How often the coordinator is woken when nothing finishes.
const IDLE_TICK: Duration = Duration::from_millis(250);

/// What a worker sends the coordinator.
struct Finished {
    task: Task,
    ok: bool,
    stored: Result<()>,
}

/// Runs `tasks` on `schedule.pool` through `executor`, storing each record in `store` as it
/// finishes. Returns the first error storing a run or writing a checkpoint (the runs stored
/// before it stay stored). After either no new task starts: a sweep whose output cannot be
/// written must not compute for hours into nothing; the tasks in flight finish and are stored.
pub fn run_tasks(
    tasks: &[Task],
    executor: &dyn Executor,
    store: &dyn RunStore,
    schedule: &Schedule<'_>,
    coordinator: &mut dyn Coordinator,
) -> Result<()> {
    let store_failed = AtomicBool::new(false);
    let started = AtomicUsize::new(0);
    let mut finished = 0usize;
    let mut stopping_said = false;
    let mut store_error: Option<Error> = None;
    let mut checkpoint_error: Option<Error> = None;
    let held = Held::default();
    std::thread::scope(|s| -> Result<()> {
        let (tx, rx) = mpsc::channel::<Finished>();
        let store_failed = &store_failed;
        let started = &started;
        let held = &held;
        let tx_held = tx.clone();
        s.spawn(move || {
            schedule.pool.install(|| {
                tasks.par_iter().for_each_with(tx, |tx, task| {
                    if schedule.stop.load(Ordering::Relaxed) || store_failed.load(Ordering::Relaxed)
                    {
                        return;
                    }
                    started.fetch_add(1, Ordering::SeqCst);
                    let rec = run_one(executor, task);
                    if let Some(rec) = held.hold(*task, rec) {
                        store_one(store, store_failed, tx, *task, &rec);
                    }
                });
            });
        });
        {
            // Opened however this block ends: a worker waiting at it would otherwise hold the
            // scope (and the process) forever.
            let mut open = OpenOnDrop { held, store_failed };
            if let Err(e) = coordinator.begun() {
                store_failed.store(true, Ordering::Relaxed);
                coordinator.checkpoint_failed(&e, started.load(Ordering::SeqCst));
                checkpoint_error = Some(e);
            }
            for (task, rec) in open.open() {
                store_one(store, store_failed, &tx_held, task, &rec);
            }
        }
        drop(tx_held);
        // The first checkpoint interval counts from here, not from before that work.
        let mut last_checkpoint = Instant::now();
        loop {
            let received = rx.recv_timeout(IDLE_TICK);
            if received.is_ok() {
                finished += 1;
            }
            match received {
                Ok(f) => match f.stored {
                    Err(e) => {
                        store_error.get_or_insert(e);
                        continue;
                    }
                    Ok(()) => coordinator.finished(&f.task, f.ok),
                },
                Err(mpsc::RecvTimeoutError::Timeout) => coordinator.idle(),
                Err(mpsc::RecvTimeoutError::Disconnected) => break,
            }
            let healthy = store_error.is_none() && checkpoint_error.is_none();
            // (A task counted as started may not have begun yet: an upper bound.)
            let in_flight = || started.load(Ordering::SeqCst).saturating_sub(finished);
            let mut written = Ok(());
            if !stopping_said && schedule.stop.load(Ordering::Relaxed) && healthy {
                stopping_said = true;
                written = coordinator.stopping(in_flight());
                last_checkpoint = Instant::now();
            }
            let due = !schedule.checkpoint_every.is_zero()
                && last_checkpoint.elapsed() >= schedule.checkpoint_every;
            if due && healthy && written.is_ok() {
                written = coordinator.checkpoint();
                last_checkpoint = Instant::now();
            }
            if let Err(e) = written {
                store_failed.store(true, Ordering::Relaxed);
                coordinator.checkpoint_failed(&e, in_flight());
                checkpoint_error = Some(e);
            }
        }
        Ok(())
    })?;
    coordinator.ended();
    match (checkpoint_error, store_error) {
        (Some(e), _) => Err(Error::Other(format!(
            "writing the output file failed: {e}; the sweep stopped (every finished run is stored in the work directory; fix the cause and run the same command again to resume)"
        ))),
        (None, Some(e)) => Err(e),
        (None, None) => Ok(()),
    }
}

/// Stores one finished run's record and tells the coordinator (a store that fails stops new
/// tasks from starting).
fn store_one(
    store: &dyn RunStore,
    store_failed: &AtomicBool,
    tx: &mpsc::Sender<Finished>,
    task: Task,
    rec: &RunRecord,
) {
    let stored = store.write(rec);
    if stored.is_err() {
        store_failed.store(true, Ordering::Relaxed);
    }
    let _ = tx.send(Finished {
        task,
        ok: rec.ok,
        stored,
    });
}

/// Records of runs that ended before [`Coordinator::begun`] returned, at most this many: a
/// worker with one more waits (memory stays bounded however short the runs and long the wait).
pub const HELD_RECORDS: usize = 64;

/// Where finished runs' records wait until the coordinator has begun ([`Coordinator::begun`]).
/// Once open it costs a worker one atomic load.
#[derive(Default)]
struct Held {
    open: AtomicBool,
    /// The records held. A worker adds one only under this lock and after finding `open` unset
    /// under it, so none is added after [`Held::open`] has taken them.
    records: Mutex<Vec<(Task, RunRecord)>>,
    opened: Condvar,
}

impl Held {
    /// `rec` back to be stored now (open), or `None`: held, to be stored by whoever opens.
    fn hold(&self, task: Task, rec: RunRecord) -> Option<RunRecord> {
        if self.open.load(Ordering::Acquire) {
            return Some(rec);
        }
        let mut records = self.records.lock().unwrap_or_else(|e| e.into_inner());
        loop {
            if self.open.load(Ordering::Acquire) {
                return Some(rec);
            }
            if records.len() < HELD_RECORDS {
                records.push((task, rec));
                return None;
            }
            records = self.opened.wait(records).unwrap_or_else(|e| e.into_inner());
        }
    }

    /// Opens: the records held until now, to be stored by the caller (once; later calls get none).
    fn open(&self) -> Vec<(Task, RunRecord)> {
        let mut records = self.records.lock().unwrap_or_else(|e| e.into_inner());
        self.open.store(true, Ordering::Release);
        self.opened.notify_all();
        std::mem::take(&mut *records)
    }
}

/// Opens its [`Held`] when dropped, so that no worker waits forever. Dropped by a panic in
/// [`Coordinator::begun`], it also stops new tasks from starting (the panic ends the call once
/// the runs in flight are done); the records it held then are not stored, and are computed
/// again by the next run of the same command.
struct OpenOnDrop<'a> {
    held: &'a Held,
    store_failed: &'a AtomicBool,
}

impl OpenOnDrop<'_> {
    fn open(&mut self) -> Vec<(Task, RunRecord)> {
        self.held.open()
    }
}

impl Drop for OpenOnDrop<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.store_failed.store(true, Ordering::Relaxed);
        }
        self.held.open();
    }
}

/// Runs one task, a panic becoming a failed record.
fn run_one(executor: &dyn Executor, task: &Task) -> RunRecord {
    let start = Instant::now();
    match exec::guarded(|| executor.execute(task)) {
        Ok(rec) => rec,
        Err(reason) => RunRecord::failed(task.hash, reason, start.elapsed().as_secs_f64()),
    }
}
