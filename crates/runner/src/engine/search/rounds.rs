//! Running a sweep's searches in rounds on the scheduler, each run stored as it finishes, with
//! checkpoints of the output file; the `--verify` runs; the output file published (and the
//! shards' searches merged into one).

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};

use chainsweep_solver::Scene;

use crate::error::{Error, Result};
use crate::exec;
use crate::grid::Grid;
use crate::identity::RunHash;
use crate::numerics::verify;
use crate::record::{RunRecord, VERIFY_OK};
use crate::store::hdf5::Counts;
use crate::store::{RunStore, WorkDir};
use crate::sweep::Sweep;

use super::super::assemble::{assemble, Assembly, VerifySource};
use super::super::run::RunOptions;
use super::super::schedule::{run_tasks, Coordinator, Executor, Schedule, Task};
use super::super::{check_output, thread_pool, DamageReport, ProgressSink, Start};
use super::driver::{Driver, Wanted};
use super::outer_points;
use super::{Search, SearchReport};

/// Runs the scenes of a round.
struct SceneExecutor<'a> {
    scenes: &'a HashMap<RunHash, (Scene, usize)>,
    limits: &'a crate::sweep::Limits,
}

impl Executor for SceneExecutor<'_> {
    fn execute(&self, task: &Task) -> RunRecord {
        let (scene, own) = &self.scenes[&task.hash];
        exec::execute(scene, task.hash, self.limits, *own)
    }
}

/// The scheduler's coordinator during a round: progress, and checkpoints of the output file.
struct Round<'a, 'b> {
    sink: &'a mut dyn ProgressSink,
    ran: usize,
    failed: usize,
    publish: &'b mut dyn FnMut() -> Result<()>,
}

impl Coordinator for Round<'_, '_> {
    fn finished(&mut self, _task: &Task, ok: bool) {
        self.ran += 1;
        self.failed += usize::from(!ok);
        self.sink.run_finished(!ok);
    }
    fn idle(&mut self) {
        self.sink.idle();
    }
    fn checkpoint(&mut self) -> Result<()> {
        (self.publish)()?;
        self.sink.checkpoint();
        Ok(())
    }
    fn stopping(&mut self, in_flight: usize) -> Result<()> {
        self.sink.stopping(in_flight);
        Ok(())
    }
    fn checkpoint_failed(&mut self, error: &Error, in_flight: usize) {
        self.sink.checkpoint_failed(&format!(
            "writing the output file failed: {error}. The sweep stops now: no new run starts, {in_flight} run(s) in flight (at most) finish; every finished run stays stored."
        ));
    }
    fn ended(&mut self) {}
}

/// Runs (or resumes) the searches of `sweep` (of `opts.shard`'s outer points) into
/// `opts.output`.
pub fn run_search(
    sweep: &mut Sweep,
    grid: &mut Grid,
    opts: &RunOptions,
    sink: &mut dyn ProgressSink,
    stop: &AtomicBool,
) -> Result<SearchReport> {
    check_output(&opts.output, opts.overwrite)?;
    let pool = thread_pool(opts.jobs)?;
    let origin = super::super::auto::resolve(
        sweep,
        grid,
        Some(&crate::store::work_dir_of(&opts.output)),
        &pool,
        sink,
    )?;
    let work = WorkDir::open(&opts.output, None)?;
    if origin == super::super::auto::AutoOrigin::Pilot {
        super::super::auto::cache(&work, sweep)?;
    }
    let damage = DamageReport::new(&opts.output, &work.damage(), sweep, grid);
    if damage.any() {
        sink.damage_found(&damage);
    }
    let driver = Driver::new(sweep, grid);
    let outer = outer_points(&driver.layout, opts.shard);
    let mut searches = driver.replay_stored(&outer, &work)?;
    let done_before: usize = searches.iter().map(|s| s.runs()).sum();
    // (What they wait for is asked again by the next round of runs.)
    for s in &mut searches {
        s.waiting.clear();
    }
    let most: usize = driver.spec.budget * outer.len();
    sink.started(&Start {
        total: most,
        done: done_before,
        failed: 0,
        points: outer.len(),
        resumed_points: searches.iter().filter(|s| s.finished).count(),
        output: &opts.output,
    });
    let mut ran = 0;
    let mut failed = 0;
    loop {
        let mut wanted: HashMap<RunHash, Wanted> = HashMap::new();
        for s in &mut searches {
            driver.advance(s, &work, &mut wanted)?;
        }
        if wanted.is_empty() || stop.load(Ordering::Relaxed) {
            break;
        }
        // Invalid scenes are failed runs at once; the others run.
        let mut scenes: HashMap<RunHash, (Scene, usize)> = HashMap::new();
        for (h, (scene, own)) in wanted {
            match scene {
                Ok(scene) => {
                    scenes.insert(h, (scene, own));
                }
                Err(why) => work.write(&RunRecord::failed(h, why, 0.0))?,
            }
        }
        let mut tasks: Vec<Task> = scenes
            .iter()
            .map(|(&hash, &(_, own))| Task {
                point: own,
                hash,
                verification: false,
            })
            .collect();
        tasks.sort_by_key(|t| (t.point, t.hash));
        let executor = SceneExecutor {
            scenes: &scenes,
            limits: &sweep.limits,
        };
        let schedule = Schedule {
            pool: &pool,
            checkpoint_every: opts.checkpoint_interval,
            stop,
        };
        {
            let snapshot = &searches;
            let mut publish = || -> Result<()> {
                publish_searches(&work, &driver, snapshot, opts, &VerifySource::empty(0.0))
                    .map(|_| ())
            };
            let mut coordinator = Round {
                sink: &mut *sink,
                ran: 0,
                failed: 0,
                publish: &mut publish,
            };
            run_tasks(&tasks, &executor, &work, &schedule, &mut coordinator)?;
            ran += coordinator.ran;
            failed += coordinator.failed;
        }
        for s in &mut searches {
            if !s.waiting.is_empty() {
                driver.absorb(s, &work)?;
            }
        }
    }
    sink.runs_ended();
    let stopped = stop.load(Ordering::Relaxed) && searches.iter().any(|s| !s.finished);
    // --verify: a sample of the evaluations' points, run at a tighter setting.
    let file_grid = driver.file_grid(&searches);
    let mut vsrc = VerifySource::empty(opts.verify_fraction);
    let mut verified = (0, None);
    if opts.verify_fraction > 0.0 && !stopped {
        // (The file grid's points name their point of the sweep's own grid: their scenes are
        // built from the sweep itself, not from the file's, which has `evaluation` beside.)
        verified = verify_searches(
            &work,
            driver.sweep,
            &file_grid,
            opts,
            &pool,
            sink,
            stop,
            &mut vsrc,
            &mut ran,
        )?;
    }
    let counts = publish_searches(&work, &driver, &searches, opts, &vsrc)?;
    if searches.iter().all(|s| s.finished) && !stopped {
        // Every search has ended and the file holds its runs: the logs beside it (one per
        // process that took part, interrupted ones included) shrink to what it lacks.
        work.compact_after_publish(&file_grid)?;
    }
    Ok(SearchReport {
        searches,
        ran,
        failed,
        stopped,
        counts,
        damage,
        verified,
    })
}

/// Runs the verification runs of the `--verify` sample of the file's points; the number
/// verified and the largest relative error.
#[allow(clippy::too_many_arguments)]
fn verify_searches(
    work: &WorkDir,
    sweep: &Sweep,
    grid: &Grid,
    opts: &RunOptions,
    pool: &rayon::ThreadPool,
    sink: &mut dyn ProgressSink,
    stop: &AtomicBool,
    vsrc: &mut VerifySource,
    ran: &mut usize,
) -> Result<(usize, Option<f64>)> {
    let sampled = verify::sample(grid, opts.verify_fraction);
    let mut tasks = Vec::new();
    let mut scenes: HashMap<RunHash, (Scene, usize)> = HashMap::new();
    for i in (0..grid.len()).filter(|&i| sampled[i] && grid.hashes[i] != [0; 32]) {
        // A failed run (an invalid scene among them: it has no scene to tighten) is not verified.
        if !work.read(&grid.hashes[i])?.is_some_and(|r| r.ok) {
            continue;
        }
        let (tight, vh, allowance) = verify::point_verification(sweep, grid, i);
        vsrc.insert(i, vh, allowance);
        if work.read(&vh)?.is_some() {
            vsrc.done.insert(vh, true);
            continue;
        }
        if scenes.insert(vh, (tight, i)).is_none() {
            tasks.push(Task {
                point: i,
                hash: vh,
                verification: true,
            });
        }
    }
    struct Tight<'a>(
        &'a HashMap<RunHash, (Scene, usize)>,
        &'a crate::sweep::Limits,
    );
    impl Executor for Tight<'_> {
        fn execute(&self, task: &Task) -> RunRecord {
            exec::execute_verification(&self.0[&task.hash].0, task.hash, self.1)
        }
    }
    let schedule = Schedule {
        pool,
        checkpoint_every: std::time::Duration::ZERO,
        stop,
    };
    let mut nothing = || Ok(());
    let mut coordinator = Round {
        sink: &mut *sink,
        ran: 0,
        failed: 0,
        publish: &mut nothing,
    };
    run_tasks(
        &tasks,
        &Tight(&scenes, &sweep.limits),
        work,
        &schedule,
        &mut coordinator,
    )?;
    *ran += coordinator.ran;
    let mut worst: Option<f64> = None;
    let mut n = 0;
    for (&i, vh) in &vsrc.hashes.clone() {
        let Some(tight) = work.read(vh)? else {
            continue;
        };
        vsrc.done.insert(*vh, tight.ok);
        let Some(rec) = work.read(&grid.hashes[i])? else {
            continue;
        };
        let info = verify::compare(&rec, Some(&tight), grid.probes.len(), vsrc.allowances[&i]);
        if info.status == VERIFY_OK {
            n += 1;
            let e = info.max_error();
            if !e.is_nan() && worst.map_or(true, |w| e > w) {
                worst = Some(e);
            }
        }
    }
    Ok((n, worst))
}

/// Writes and publishes the output file of the searches as they stand.
fn publish_searches(
    work: &WorkDir,
    driver: &Driver<'_>,
    searches: &[Search],
    opts: &RunOptions,
    vsrc: &VerifySource,
) -> Result<Counts> {
    publish_as(work, driver, searches, opts.shard, &opts.provenance, vsrc)
}

/// [`publish_searches`] with the file's shard and provenance.
fn publish_as(
    work: &WorkDir,
    driver: &Driver<'_>,
    searches: &[Search],
    shard: Option<crate::grid::Shard>,
    provenance: &crate::store::hdf5::Provenance,
    vsrc: &VerifySource,
) -> Result<Counts> {
    let grid = driver.file_grid(searches);
    let sweep = driver.file_sweep(searches);
    let tables = driver.tables(searches, work)?;
    let points: Vec<usize> = (0..grid.len())
        .filter(|&i| grid.hashes[i] != [0; 32])
        .collect();
    let index = work.index()?;
    let done: HashMap<RunHash, bool> = points
        .iter()
        .filter_map(|&i| {
            let h = grid.hashes[i];
            index.get(&h).map(|&ok| (h, ok))
        })
        .collect();
    assemble(
        work,
        &Assembly {
            sweep: &sweep,
            grid: &grid,
            points: &points,
            shard,
            done: &done,
            provenance,
            verify: vsrc,
            search: Some(&tables),
        },
    )
    .map(|written| written.counts)
}

/// `merge` of the shard files of a sweep with a search: every run they give back is taken into
/// the output's work directory, and every search is replayed through them (nothing runs): those
/// whose shard is missing or stopped early stay unfinished. The searches, the merged file's
/// counts, and the damage found in the shard files.
pub fn merge_searches(
    work: &WorkDir,
    sweep: &Sweep,
    grid: &Grid,
    shards: &[std::path::PathBuf],
    provenance: &crate::store::hdf5::Provenance,
) -> Result<(Vec<Search>, Counts, Vec<DamageReport>)> {
    use crate::store::published::{Check, PublishedFile};
    let mut damage = Vec::new();
    for path in shards {
        let Some(p) = PublishedFile::open(path, None, Check::Everything) else {
            return Err(Error::Other(format!("{}: cannot be read", path.display())));
        };
        let d = DamageReport::new(path, &p.damage, sweep, grid);
        if d.any() {
            damage.push(d);
        }
        let hashes: Vec<RunHash> = p.runs().map(|(h, _, _)| *h).collect();
        for h in hashes {
            if work.read(&h)?.is_none() {
                if let Some(rec) = p.read(&h) {
                    work.write(&rec)?;
                }
            }
        }
    }
    let driver = Driver::new(sweep, grid);
    let outer: Vec<usize> = (0..driver.layout.n_outer()).collect();
    let searches = driver.replay_stored(&outer, work)?;
    let counts = publish_as(
        work,
        &driver,
        &searches,
        None,
        provenance,
        &VerifySource::empty(0.0),
    )?;
    Ok((searches, counts, damage))
}
