//! The engine's orchestration through a test executor, without subprocesses: resume,
//! checkpoints, failed runs, panics, the stop flag, verification, and a store that fails.

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Duration;

use chainsweep::engine::run::{run_points, RunOptions, RunReport, PUBLISH_GROWTH};
use chainsweep::engine::schedule::{
    run_tasks, Coordinator, Executor, Schedule, Task, HELD_RECORDS,
};
use chainsweep::engine::{shard, thread_pool, ProgressSink, Silent, Start};
use chainsweep::error::{Error, Result};
use chainsweep::grid::{Grid, Shard};
use chainsweep::identity::RunHash;
use chainsweep::record::{RunRecord, STATUS_FAILED, STATUS_OK, STATUS_PENDING, VERIFY_OK};
use chainsweep::store::hdf5::read::PointRead;
use chainsweep::store::hdf5::{FileRecords, Provenance};
use chainsweep::store::segment::encode;
use chainsweep::store::{RunStore, SegmentIndex, WorkDir};
use chainsweep::sweep::Sweep;
use chainsweep_solver::observe::probes::ProbeSummary;

const SWEEP: &str = r#"{
  "base": {
    "chain": {"preset": "chain_055", "cylinders": 8},
    "physics": {"gravity": true, "damping_kg_s": 0.0, "wall": true},
    "striker_velocity_m_s": 1.3,
    "duration_s": 1e-4
  },
  "record": {"probes": [{"kind": "gauge_force", "cylinder": 2}, {"kind": "gauge_force", "cylinder": 5}]},
  "axes": [
    {"field": "physics.damping_kg_s", "values": [0, 3, 6]},
    {"field": "striker_velocity_m_s", "values": [1.0, 1.3]}
  ]
}"#;

fn sweep_and_grid() -> (Sweep, Grid) {
    let sweep = Sweep::parse(SWEEP).unwrap();
    let grid = Grid::new(&sweep).unwrap();
    assert_eq!(grid.len(), 6);
    (sweep, grid)
}

/// A test executor: a deterministic record per task (the verification run differs from the run
/// by a relative 1e-6), failing or panicking on the points it is told, and counting its calls.
#[derive(Default)]
struct Fake {
    fail: HashSet<usize>,
    panic: HashSet<usize>,
    sleep: Duration,
    /// Sets `stop_flag` after this many calls.
    stop_after: Option<(usize, &'static AtomicBool)>,
    calls: Mutex<Vec<Task>>,
}

impl Fake {
    fn calls(&self) -> Vec<Task> {
        let mut c = self.calls.lock().unwrap().clone();
        c.sort_by_key(|t| (t.verification, t.point));
        c
    }
}

fn record(task: &Task) -> RunRecord {
    let scale = if task.verification { 1.0 + 1e-6 } else { 1.0 };
    let p = task.point as f64;
    let mut rec = RunRecord::failed(task.hash, String::new(), 0.001);
    rec.ok = true;
    rec.steps = 100 + task.point as u64;
    rec.rejected = 3;
    rec.rhs_evals = 1300 + task.point as u64;
    rec.events = 7;
    rec.t_end_s = 1e-4;
    rec.energy_drift_max = 1e-9;
    rec.energy_drift_final = 5e-10;
    rec.momentum_residual_max = 1e-12;
    rec.impact_energy_j = 0.0017 + p;
    rec.max_overlap_m = 2e-6;
    // The whole 8-cylinder chain (18 particles), as the runner records it: too short for the
    // moving part.
    rec.integrated_particles = Some(18);
    rec.moving_part = Some(false);
    rec.probes = (0..2)
        .map(|k| ProbeSummary {
            leading_peak: (100.0 + p + k as f64) * scale,
            leading_peak_time_s: 2e-5 * (1.0 + p),
            record_max: (110.0 + p) * scale,
            record_max_time_s: 3e-5,
        })
        .collect();
    rec
}

impl Executor for Fake {
    fn execute(&self, task: &Task) -> RunRecord {
        let n = {
            let mut calls = self.calls.lock().unwrap();
            calls.push(*task);
            calls.len()
        };
        if let Some((after, flag)) = self.stop_after {
            if n >= after {
                flag.store(true, Ordering::Relaxed);
            }
        }
        std::thread::sleep(self.sleep);
        if !task.verification && self.panic.contains(&task.point) {
            panic!("boom at point {}", task.point);
        }
        if !task.verification && self.fail.contains(&task.point) {
            return RunRecord::failed(task.hash, "made to fail".into(), 0.002);
        }
        record(task)
    }
}

struct Setup {
    _dir: tempfile::TempDir,
    output: PathBuf,
    sweep: Sweep,
    grid: Grid,
}

fn setup() -> Setup {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("out.h5");
    let (sweep, grid) = sweep_and_grid();
    Setup {
        _dir: dir,
        output,
        sweep,
        grid,
    }
}

fn options(output: &Path) -> RunOptions {
    RunOptions {
        output: output.to_path_buf(),
        jobs: 2,
        shard: None,
        ensemble_round: None,
        retry_failed: false,
        checkpoint_interval: Duration::ZERO,
        verify_fraction: 0.0,
        overwrite: false,
        provenance: Provenance {
            created_utc: "2026-01-01T00:00:00Z".into(),
            command_line: "test".into(),
        },
    }
}

fn run_with(
    s: &Setup,
    opts: &RunOptions,
    executor: &dyn Executor,
    sink: &mut dyn ProgressSink,
    stop: &AtomicBool,
) -> RunReport {
    let work = WorkDir::open(&opts.output, None).unwrap();
    let pool = thread_pool(opts.jobs).unwrap();
    let points = shard::points(&s.sweep, &s.grid, opts.shard);
    run_points(
        &work, &s.sweep, &s.grid, points, opts, &pool, executor, sink, stop,
    )
    .unwrap()
}

fn run(s: &Setup, opts: &RunOptions, executor: &dyn Executor) -> RunReport {
    run_with(s, opts, executor, &mut Silent, &AtomicBool::new(false))
}

/// Every point's record as stored in the output file (segment bytes), `None` where pending.
fn file_records(s: &Setup) -> Vec<Option<Vec<u8>>> {
    let recs = FileRecords::open(&s.output).unwrap();
    (0..s.grid.len())
        .map(|i| match recs.record(i, s.grid.hashes[i], &s.grid) {
            PointRead::Run(r) => Some(encode(&r)),
            PointRead::Pending => None,
            PointRead::Damaged(why) => panic!("point {i} damaged: {why}"),
        })
        .collect()
}

#[test]
fn a_sweep_runs_every_point_once_and_a_rerun_resumes_with_nothing_left() {
    let s = setup();
    let opts = options(&s.output);
    let fake = Fake::default();
    let report = run(&s, &opts, &fake);
    assert_eq!(
        (
            report.counts.ok,
            report.counts.failed,
            report.counts.pending
        ),
        (6, 0, 0)
    );
    let calls: Vec<usize> = fake.calls().iter().map(|t| t.point).collect();
    assert_eq!(calls, vec![0, 1, 2, 3, 4, 5]);
    let first = file_records(&s);
    for (i, r) in first.iter().enumerate() {
        let want = record(&Task::run(&s.grid, i));
        assert_eq!(r.as_deref(), Some(&encode(&want)[..]), "point {i}");
    }

    let again = Fake::default();
    let report = run(&s, &opts, &again);
    assert!(again.calls().is_empty(), "{:?}", again.calls());
    assert_eq!(report.counts.ok, 6);
    assert_eq!(file_records(&s), first);
}

#[test]
fn failed_runs_keep_their_reason_and_are_retried_only_on_request() {
    let s = setup();
    let mut opts = options(&s.output);
    let fake = Fake {
        fail: [1, 4].into(),
        ..Fake::default()
    };
    let report = run(&s, &opts, &fake);
    assert_eq!((report.counts.ok, report.counts.failed), (4, 2));
    assert_eq!(report.failed, 2);
    let listed: Vec<(usize, Option<&str>)> = report
        .failures
        .iter()
        .map(|f| (f.point, f.reason.as_deref()))
        .collect();
    assert_eq!(
        listed,
        vec![(1, Some("made to fail")), (4, Some("made to fail"))]
    );
    let recs = FileRecords::open(&s.output).unwrap();
    assert_eq!(recs.status(1), STATUS_FAILED);
    assert_eq!(recs.reason(1), "made to fail");

    // Failed runs are finished runs: not run again...
    let again = Fake::default();
    run(&s, &opts, &again);
    assert!(again.calls().is_empty());
    // ...unless asked.
    opts.retry_failed = true;
    let retry = Fake::default();
    let report = run(&s, &opts, &retry);
    let calls: Vec<usize> = retry.calls().iter().map(|t| t.point).collect();
    assert_eq!(calls, vec![1, 4]);
    assert_eq!((report.counts.ok, report.counts.failed), (6, 0));
}

#[test]
fn a_panicking_run_fails_alone_with_the_panic_message() {
    let s = setup();
    let opts = options(&s.output);
    let fake = Fake {
        panic: [2].into(),
        ..Fake::default()
    };
    let report = run(&s, &opts, &fake);
    assert_eq!((report.counts.ok, report.counts.failed), (5, 1));
    let reason = report.failures[0].reason.clone().unwrap();
    assert_eq!(report.failures[0].point, 2);
    assert!(reason.starts_with("panic at "), "{reason}");
    assert!(reason.ends_with("boom at point 2"), "{reason}");
    let recs = FileRecords::open(&s.output).unwrap();
    assert_eq!(recs.reason(2), reason);
    assert_eq!(recs.status(3), STATUS_OK);
}

/// Opens the output file at every checkpoint and notes how many points it holds.
#[derive(Default)]
struct CheckpointSpy {
    output: PathBuf,
    seen_ok: Vec<usize>,
    finished: usize,
    started: Option<(usize, usize)>,
    ended: bool,
}

impl ProgressSink for CheckpointSpy {
    fn started(&mut self, s: &Start<'_>) {
        self.started = Some((s.total, s.done));
    }
    fn run_finished(&mut self, _failed: bool) {
        self.finished += 1;
    }
    fn checkpoint(&mut self) {
        let recs = FileRecords::open(&self.output).unwrap();
        let ok = (0..recs.len())
            .filter(|&i| recs.status(i) == STATUS_OK)
            .count();
        self.seen_ok.push(ok);
    }
    fn runs_ended(&mut self) {
        self.ended = true;
    }
}

#[test]
fn checkpoints_publish_the_finished_runs_while_the_sweep_goes_on() {
    let s = setup();
    let mut opts = options(&s.output);
    opts.jobs = 1;
    opts.checkpoint_interval = Duration::from_millis(5);
    // Each run takes much longer than the checkpoint interval: a checkpoint follows every run
    // (and, unless the machine is loaded, one comes before the first run ends).
    let fake = Fake {
        sleep: Duration::from_millis(80),
        ..Fake::default()
    };
    let mut spy = CheckpointSpy {
        output: s.output.clone(),
        ..CheckpointSpy::default()
    };
    let report = run_with(&s, &opts, &fake, &mut spy, &AtomicBool::new(false));
    assert_eq!(report.counts.ok, 6);
    assert_eq!(spy.started, Some((6, 0)));
    assert_eq!(spy.finished, 6);
    assert!(spy.ended);
    assert!(
        spy.seen_ok.iter().any(|&ok| ok > 0 && ok < 6),
        "checkpoints saw {:?}",
        spy.seen_ok
    );
    assert!(spy.seen_ok.windows(2).all(|w| w[0] <= w[1]));
    // A checkpoint publishes the file again only once the stored runs have doubled since the
    // last publish (the others only sync the log): 2 and 4 of 6 here, then the end. The first
    // checkpoint comes once the file written at the start is there, which on a loaded machine
    // can be after the first runs: from whichever run it follows, the file it sees holds at
    // least twice the runs of the one before.
    let mut published: Vec<usize> = spy.seen_ok.clone();
    published.dedup();
    published.retain(|&ok| ok > 0);
    assert!(
        published.first().is_some_and(|&ok| ok >= PUBLISH_GROWTH)
            && published.windows(2).all(|w| w[1] >= PUBLISH_GROWTH * w[0]),
        "checkpoints saw {:?}",
        spy.seen_ok
    );
    // Some checkpoints only synced the log: the file they saw was the one seen before.
    assert!(
        spy.seen_ok.windows(2).any(|w| w[0] == w[1]),
        "checkpoints saw {:?}",
        spy.seen_ok
    );
}

#[test]
fn a_stopped_sweep_writes_what_finished_and_resumes_to_the_same_file() {
    static STOP: AtomicBool = AtomicBool::new(false);
    let s = setup();
    let mut opts = options(&s.output);
    opts.jobs = 1;
    let fake = Fake {
        stop_after: Some((2, &STOP)),
        ..Fake::default()
    };
    let report = run_with(&s, &opts, &fake, &mut Silent, &STOP);
    assert!(report.stopped);
    assert_eq!(fake.calls().len(), 2);
    assert_eq!(
        (report.counts.ok, report.counts.pending),
        (2, 4),
        "{report:?}"
    );
    let recs = FileRecords::open(&s.output).unwrap();
    let pending = (0..6).filter(|&i| recs.status(i) == STATUS_PENDING).count();
    assert_eq!(pending, 4);

    let rest = Fake::default();
    let report = run(&s, &opts, &rest);
    assert!(!report.stopped);
    assert_eq!(rest.calls().len(), 4);
    assert_eq!(report.counts.ok, 6);
    let resumed = file_records(&s);

    let whole = setup();
    run(&whole, &options(&whole.output), &Fake::default());
    assert_eq!(resumed, file_records(&whole));
}

#[test]
fn verification_runs_are_tasks_like_the_others_and_resume() {
    let s = setup();
    let mut opts = options(&s.output);
    opts.verify_fraction = 0.5;
    let fake = Fake::default();
    let report = run(&s, &opts, &fake);
    let verifications = fake.calls().iter().filter(|t| t.verification).count();
    assert_eq!(verifications, 3); // ceil(0.5 × 6)
    assert_eq!(report.verification.requested, 3);
    assert_eq!(report.verification.verified, 3);
    // The fake verification runs differ by 1e-6 (relative): the bound on the error adds the
    // tighter run's share and floor (DOP853 at rtol 1e-9, verified at 1e-11).
    let (worst, _) = report.verification.worst.unwrap();
    let bound = 1e-6 / (1.0 - 0.1) + 100.0 * 1e-11;
    assert!(
        (worst / bound - 1.0).abs() < 1e-6,
        "{worst} against {bound}"
    );
    let recs = FileRecords::open(&s.output).unwrap();
    let verified: Vec<usize> = (0..6)
        .filter(|&i| recs.verify_info(i).status == VERIFY_OK)
        .collect();
    assert_eq!(verified.len(), 3);
    assert_eq!(recs.verify_fraction, 0.5);

    // Raising the fraction runs only the missing verifications.
    opts.verify_fraction = 1.0;
    let more = Fake::default();
    let report = run(&s, &opts, &more);
    assert!(more.calls().iter().all(|t| t.verification));
    assert_eq!(more.calls().len(), 3);
    assert_eq!(report.verification.verified, 6);
}

#[test]
fn shards_run_their_own_points() {
    let s = setup();
    let mut opts = options(&s.output);
    opts.shard = Some(Shard { k: 2, n: 4 });
    let fake = Fake::default();
    let report = run(&s, &opts, &fake);
    let mut calls: Vec<usize> = fake.calls().iter().map(|t| t.point).collect();
    calls.sort();
    // The shard's points are the engine's assignment, and only those ran.
    assert_eq!(calls, shard::points(&s.sweep, &s.grid, opts.shard));
    assert_eq!(
        (report.points, report.counts.ok),
        (calls.len(), calls.len())
    );
    // The four shards partition the grid.
    let mut all: Vec<usize> = (1..=4)
        .flat_map(|k| shard::points(&s.sweep, &s.grid, Some(Shard { k, n: 4 })))
        .collect();
    all.sort();
    assert_eq!(all, (0..s.grid.len()).collect::<Vec<_>>());
    let recs = FileRecords::open(&s.output).unwrap();
    assert_eq!(recs.shard, "2/4");
}

/// A store that refuses its `fail_at`-th write.
struct FailingStore {
    fail_at: usize,
    writes: AtomicUsize,
}

impl FailingStore {
    /// Refuses its `fail_at`-th write (`usize::MAX`: none), counting them all.
    fn failing_at(fail_at: usize) -> Self {
        FailingStore {
            fail_at,
            writes: AtomicUsize::new(0),
        }
    }
}

/// The scheduler on `pool`, checkpoints every `checkpoint_every` (zero: none), stopped by `stop`.
fn schedule<'a>(
    pool: &'a rayon::ThreadPool,
    checkpoint_every: Duration,
    stop: &'a AtomicBool,
) -> Schedule<'a> {
    Schedule {
        pool,
        checkpoint_every,
        stop,
    }
}

impl RunStore for FailingStore {
    fn read(&self, _hash: &RunHash) -> Result<Option<RunRecord>> {
        Ok(None)
    }
    fn write(&self, _rec: &RunRecord) -> Result<()> {
        let n = self.writes.fetch_add(1, Ordering::SeqCst) + 1;
        if n == self.fail_at {
            return Err(Error::Other("no space left on device".into()));
        }
        Ok(())
    }
    fn index(&self) -> Result<SegmentIndex> {
        Ok(SegmentIndex::new())
    }
}

#[derive(Default)]
struct Tally {
    finished: Vec<usize>,
    checkpoints: usize,
    fail_checkpoint: bool,
    /// How many runs had finished when the failed checkpoint was reported.
    failure_heard_after: Option<usize>,
    ended: bool,
}

impl Coordinator for Tally {
    fn finished(&mut self, task: &Task, _ok: bool) {
        self.finished.push(task.point);
    }
    fn idle(&mut self) {}
    fn checkpoint(&mut self) -> Result<()> {
        self.checkpoints += 1;
        if self.fail_checkpoint {
            return Err(Error::Other("checkpoint refused".into()));
        }
        Ok(())
    }
    fn checkpoint_failed(&mut self, error: &Error, _in_flight: usize) {
        assert!(error.to_string().contains("checkpoint refused"));
        self.failure_heard_after = Some(self.finished.len());
    }
    fn ended(&mut self) {
        self.ended = true;
    }
}

#[test]
fn a_run_that_cannot_be_stored_stops_the_sweep_with_its_error() {
    let (_, grid) = sweep_and_grid();
    let tasks: Vec<Task> = (0..6).map(|i| Task::run(&grid, i)).collect();
    let store = FailingStore::failing_at(3);
    let fake = Fake::default();
    let pool = thread_pool(1).unwrap();
    let stop = AtomicBool::new(false);
    let schedule = schedule(&pool, Duration::ZERO, &stop);
    let mut tally = Tally::default();
    let err = run_tasks(&tasks, &fake, &store, &schedule, &mut tally).unwrap_err();
    assert!(err.to_string().contains("no space left"), "{err}");
    // The two stored runs were reported; no task started after the failed write.
    assert_eq!(tally.finished, vec![0, 1]);
    assert_eq!(fake.calls().len(), 3);
    assert!(tally.ended);
}

/// A coordinator whose [`Coordinator::begun`] (the output file written before any run is
/// stored) takes until the workers have had time to run more tasks than can be held.
struct SlowToBegin<'a> {
    fake: &'a Fake,
    store: &'a FailingStore,
    /// Runs computed, and records stored, when `begun` returned.
    at_begun: Option<(usize, usize)>,
    finished: usize,
}

impl Coordinator for SlowToBegin<'_> {
    fn begun(&mut self) -> Result<()> {
        let deadline = std::time::Instant::now() + Duration::from_secs(20);
        while self.fake.calls().len() < HELD_RECORDS && std::time::Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(1));
        }
        // Time for the workers to run past the bound, were there none.
        std::thread::sleep(Duration::from_millis(100));
        self.at_begun = Some((
            self.fake.calls().len(),
            self.store.writes.load(Ordering::SeqCst),
        ));
        Ok(())
    }
    fn finished(&mut self, _task: &Task, _ok: bool) {
        self.finished += 1;
    }
    fn idle(&mut self) {}
    fn checkpoint(&mut self) -> Result<()> {
        Ok(())
    }
    fn ended(&mut self) {}
}

#[test]
fn runs_go_on_while_the_coordinator_begins_and_are_stored_only_after_it() {
    let (_, grid) = sweep_and_grid();
    let tasks: Vec<Task> = (0..3 * HELD_RECORDS)
        .map(|i| Task::run(&grid, i % grid.len()))
        .collect();
    let store = FailingStore::failing_at(usize::MAX);
    let fake = Fake::default();
    let jobs = 2;
    let pool = thread_pool(jobs).unwrap();
    let stop = AtomicBool::new(false);
    let schedule = schedule(&pool, Duration::ZERO, &stop);
    let mut coordinator = SlowToBegin {
        fake: &fake,
        store: &store,
        at_begun: None,
        finished: 0,
    };
    run_tasks(&tasks, &fake, &store, &schedule, &mut coordinator).unwrap();
    let (ran, stored) = coordinator.at_begun.unwrap();
    // The workers ran while the coordinator began, up to the records that may be held (and one
    // more run each, waiting to be held), and stored none of them before it was done.
    assert_eq!(stored, 0);
    assert!(
        (HELD_RECORDS..=HELD_RECORDS + jobs).contains(&ran),
        "{ran} runs computed while the coordinator began"
    );
    // Every run was then stored and reported, the held ones included.
    assert_eq!(store.writes.load(Ordering::SeqCst), tasks.len());
    assert_eq!(coordinator.finished, tasks.len());
    assert_eq!(fake.calls().len(), tasks.len());
}

/// A coordinator whose [`Coordinator::begun`] fails, with an error or a panic, once the
/// workers have run a few tasks (held, as no record may be stored before it returns).
struct FailsToBegin<'a> {
    fake: &'a Fake,
    panic: bool,
    finished: usize,
    failure_heard: bool,
}

impl Coordinator for FailsToBegin<'_> {
    fn begun(&mut self) -> Result<()> {
        let deadline = std::time::Instant::now() + Duration::from_secs(20);
        while self.fake.calls().len() < 4 && std::time::Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(1));
        }
        if self.panic {
            panic!("the first write panicked");
        }
        Err(Error::Other("checkpoint refused".into()))
    }
    fn finished(&mut self, _task: &Task, _ok: bool) {
        self.finished += 1;
    }
    fn idle(&mut self) {}
    fn checkpoint(&mut self) -> Result<()> {
        Ok(())
    }
    fn checkpoint_failed(&mut self, error: &Error, _in_flight: usize) {
        assert!(error.to_string().contains("checkpoint refused"));
        self.failure_heard = true;
    }
    fn ended(&mut self) {}
}

#[test]
fn a_coordinator_that_fails_to_begin_stops_the_sweep_and_keeps_what_finished() {
    let (_, grid) = sweep_and_grid();
    let tasks: Vec<Task> = (0..40 * HELD_RECORDS)
        .map(|i| Task::run(&grid, i % grid.len()))
        .collect();
    for panic in [false, true] {
        let store = FailingStore::failing_at(usize::MAX);
        let fake = Fake {
            sleep: Duration::from_millis(1),
            ..Fake::default()
        };
        let pool = thread_pool(2).unwrap();
        let stop = AtomicBool::new(false);
        let schedule = schedule(&pool, Duration::ZERO, &stop);
        let mut coordinator = FailsToBegin {
            fake: &fake,
            panic,
            finished: 0,
            failure_heard: false,
        };
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            run_tasks(&tasks, &fake, &store, &schedule, &mut coordinator)
        }));
        let ran = fake.calls().len();
        let stored = store.writes.load(Ordering::SeqCst);
        // It returned (no worker waits forever), and no new task started after the failure:
        // at most the runs that could be held and those in flight, not the 2 560 of the sweep.
        assert!(
            (4..=HELD_RECORDS + 2 * 2).contains(&ran),
            "{ran} runs (panic: {panic})"
        );
        if panic {
            assert!(outcome.is_err(), "the panic goes on");
            // Runs finished after the panic are stored; those held at it are not.
            assert!(stored <= ran);
        } else {
            let err = outcome.unwrap().unwrap_err();
            assert!(err.to_string().contains("checkpoint refused"), "{err}");
            assert!(coordinator.failure_heard);
            // Every run computed is stored and reported, the held ones included.
            assert_eq!((stored, coordinator.finished), (ran, ran));
        }
    }
}

#[test]
fn a_failed_checkpoint_is_reported_at_once_and_stops_the_sweep() {
    let (_, grid) = sweep_and_grid();
    let tasks: Vec<Task> = (0..6).map(|i| Task::run(&grid, i)).collect();
    let store = FailingStore::failing_at(usize::MAX);
    let fake = Fake {
        sleep: Duration::from_millis(20),
        ..Fake::default()
    };
    let pool = thread_pool(1).unwrap();
    let stop = AtomicBool::new(false);
    let schedule = schedule(&pool, Duration::from_millis(1), &stop);
    let mut tally = Tally {
        fail_checkpoint: true,
        ..Tally::default()
    };
    let err = run_tasks(&tasks, &fake, &store, &schedule, &mut tally).unwrap_err();
    assert!(err.to_string().contains("checkpoint refused"), "{err}");
    assert!(
        err.to_string()
            .contains("run the same command again to resume"),
        "{err}"
    );
    assert_eq!(tally.checkpoints, 1);
    // Heard right after the first finished run (the checkpoint then due), not at the end; the
    // run in flight then finished and was stored, and no new one started.
    assert_eq!(tally.failure_heard_after, Some(1));
    assert!(fake.calls().len() <= 2, "{:?}", fake.calls());
    assert!(tally.finished.len() <= 2, "{:?}", tally.finished);
    assert!(tally.ended);
}
