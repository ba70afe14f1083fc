//! A sweep run (or resumed) into its output file: plan, schedule with checkpoints, assemble, and
//! the report of what happened.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use crate::error::{Error, Result};
use crate::grid::{Grid, Shard};
use crate::identity::RunHash;
use crate::record::columns::Table;
use crate::record::VERIFY_OK;
use crate::store::hdf5::{Counts, Provenance, Written};
use crate::store::{work_dir_of, RunStore, WorkDir};
use crate::sweep::Sweep;

use super::assemble::{assemble, Assembly};
use super::auto::{self, AutoOrigin};
use super::plan::Plan;
use super::schedule::{run_tasks, Coordinator, Executor, Schedule, SolverExecutor, Task};
use super::{
    check_output, max_jobs, number_text, shard, thread_pool, DamageReport, ProgressSink, Start,
    MAX_JOBS_PER_CPU,
};

/// The longest `--checkpoint-interval`, s (a week): longer is never refreshed in practice, and
/// the interval must stay a representable duration.
pub const MAX_CHECKPOINT_INTERVAL_S: f64 = 7.0 * 24.0 * 3600.0;

/// Seconds between refreshes of the output file while a sweep runs, unless asked otherwise
/// (`--checkpoint-interval`, Python's `checkpoint_interval`).
pub const DEFAULT_CHECKPOINT_INTERVAL_S: f64 = 300.0;

/// Seconds between plain progress lines when the display is not a terminal, unless asked
/// otherwise (`--progress-interval`; Python's plain lines).
pub const DEFAULT_PROGRESS_INTERVAL_S: f64 = 10.0;

/// How many failed runs a report lists with their reasons (it counts them all).
pub const LISTED_FAILURES: usize = 20;

/// Options of a sweep run.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// The output file.
    pub output: PathBuf,
    /// Parallel runs (at least 1).
    pub jobs: usize,
    /// Run only this shard.
    pub shard: Option<Shard>,
    /// The round of an adaptive ensemble a shard runs (`None`: round 0). Its rounds depend on
    /// every sample, so a shard runs one round and `merge` of every shard's file decides whether
    /// another is due (`chainsweep slurm` submits it).
    pub ensemble_round: Option<usize>,
    /// Run again the points whose earlier run failed.
    pub retry_failed: bool,
    /// Time between refreshes of the output file while the sweep runs (zero: only at the end).
    pub checkpoint_interval: Duration,
    /// Fraction of the grid verified at a tighter setting (0: none).
    pub verify_fraction: f64,
    /// Replace an existing output file that has no work directory.
    pub overwrite: bool,
    /// Provenance attributes of the output file.
    pub provenance: Provenance,
}

/// What a caller asks of a sweep run, as given: the command line's options and the Python
/// package's arguments alike (the one options type of both). [`RunRequest::options`] checks it
/// and makes the engine's [`RunOptions`]; errors name the command line's option.
#[derive(Debug, Clone)]
pub struct RunRequest {
    /// The sweep file (names the default output).
    pub file: PathBuf,
    /// The output file (`None`: next to the sweep file, [`super::default_output`]).
    pub output: Option<PathBuf>,
    /// Parallel runs (`None`: [`super::default_jobs`]).
    pub jobs: Option<usize>,
    /// `K/N` (or `slurm/N`): run only that shard.
    pub shard: Option<String>,
    /// With `shard`, the round of an adaptive ensemble to run (`None`: round 0).
    pub ensemble_round: Option<usize>,
    /// Run again the points whose earlier run failed.
    pub retry_failed: bool,
    /// Fraction of points re-run at a tighter setting (`None`: none).
    pub verify: Option<f64>,
    /// Seconds between refreshes of the output while the sweep runs (0: only at the end).
    pub checkpoint_interval_s: f64,
    /// Replace an existing output file that has no work directory.
    pub overwrite: bool,
}

impl RunRequest {
    /// A request for `file` with every option at its default.
    pub fn new(file: PathBuf) -> RunRequest {
        RunRequest {
            file,
            output: None,
            jobs: None,
            shard: None,
            ensemble_round: None,
            retry_failed: false,
            verify: None,
            checkpoint_interval_s: DEFAULT_CHECKPOINT_INTERVAL_S,
            overwrite: false,
        }
    }

    /// The checked options of the run.
    pub fn options(&self) -> Result<RunOptions> {
        let shard = self
            .shard
            .as_deref()
            .map(|s| super::slurm::parse_shard_env(s, "--shard"))
            .transpose()?;
        let verify_fraction = self.verify.unwrap_or(0.0);
        let jobs = self.jobs.unwrap_or_else(super::default_jobs);
        RunOptions::check(jobs, self.checkpoint_interval_s, verify_fraction)?;
        Ok(RunOptions {
            output: self
                .output
                .clone()
                .unwrap_or_else(|| super::default_output(&self.file, shard)),
            jobs,
            shard,
            ensemble_round: self.ensemble_round,
            retry_failed: self.retry_failed,
            checkpoint_interval: Duration::from_secs_f64(self.checkpoint_interval_s),
            verify_fraction,
            overwrite: self.overwrite,
            provenance: Provenance::of_this_process(),
        })
    }
}

impl RunOptions {
    /// Checks the options that do not depend on the sweep; an input error naming the option.
    pub fn check(jobs: usize, checkpoint_interval_s: f64, verify_fraction: f64) -> Result<()> {
        let most = max_jobs();
        if jobs == 0 || jobs > most {
            return Err(Error::input(
                "--jobs",
                format!(
                    "must be in [1, {most}] ({MAX_JOBS_PER_CPU} per CPU this process may use), got {jobs}"
                ),
            ));
        }
        if !(0.0..=MAX_CHECKPOINT_INTERVAL_S).contains(&checkpoint_interval_s) {
            return Err(Error::input(
                "--checkpoint-interval",
                format!(
                    "must be a number of seconds in [0, {MAX_CHECKPOINT_INTERVAL_S}] (0: only at the end; at most a week), got {}",
                    number_text(checkpoint_interval_s)
                ),
            ));
        }
        if !(0.0..=1.0).contains(&verify_fraction) {
            return Err(Error::input(
                "--verify",
                format!("must be a fraction in [0, 1], got {verify_fraction}"),
            ));
        }
        Ok(())
    }
}

/// A failed run: its grid point and why it failed (`None`: its record could not be read).
#[derive(Debug, Clone, PartialEq)]
pub struct Failure {
    /// The grid point.
    pub point: usize,
    /// Its reason.
    pub reason: Option<String>,
}

/// A sweep's health at a glance, as `run` ends and `status` reports it: what is not right, and
/// how well what is right was verified.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Health {
    /// Failed runs.
    pub failed: usize,
    /// Of them, those stopped by one of the sweep's `limits` (the energy drift, the run time, …).
    pub over_limit: usize,
    /// Runs whose steady state did not settle.
    pub unsettled: usize,
    /// Successful runs with a NaN leading peak (where the sweep asks for leading pulses).
    pub nan_leading: usize,
    /// Points verified at a tighter setting, and the largest bound on an error with its point.
    pub verified: usize,
    /// (See `verified`.)
    pub worst_verified: Option<(f64, usize)>,
}

impl Health {
    /// Whether a failure's `reason` is a limit's.
    pub fn is_limit(reason: &str) -> bool {
        reason.contains("limits.")
    }
}

/// What `--verify` found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VerificationReport {
    /// Sampled points of this run.
    pub requested: usize,
    /// Points verified.
    pub verified: usize,
    /// The largest verified error and its point.
    pub worst: Option<(f64, usize)>,
    /// Points whose verification run failed.
    pub failed: usize,
    /// The first [`LISTED_FAILURES`] of them, with their reasons.
    pub failures: Vec<Failure>,
    /// What this sweep records that verification does not compare, each with why
    /// ([`crate::numerics::verify::NOT_VERIFIED`]).
    pub not_verified: Vec<(&'static str, &'static str)>,
}

/// What a sweep run did.
#[derive(Debug, Clone)]
pub struct RunReport {
    /// Grid points of this run (or shard).
    pub points: usize,
    /// The state of those points in the output file.
    pub counts: Counts,
    /// Failed grid points.
    pub failed: usize,
    /// The first [`LISTED_FAILURES`] of them, with their reasons.
    pub failures: Vec<Failure>,
    /// What `--verify` found.
    pub verification: VerificationReport,
    /// Whether the sweep was stopped (by the stop flag) before every run finished.
    pub stopped: bool,
    /// Runs computed by this call (grid runs and verification runs).
    pub ran: usize,
    /// What was found damaged in the output file when the sweep started.
    pub damage: DamageReport,
    /// Grid points of this run whose run succeeded but left a probe's leading peak NaN (the
    /// leading pulse had not passed it by the end of the run), from the output file; none for a
    /// driven sweep, where no one asks for a leading pulse.
    pub unpassed: Vec<usize>,
    /// Grid points of this run whose run finished but whose steady state did not settle, from
    /// the output file.
    pub unsettled: Vec<usize>,
    /// The sweep's health at a glance.
    pub health: Health,
    /// The output file already held every run of the sweep and nothing was to be done: it was
    /// left as it was (a shard run into a complete output, a complete sweep run again).
    pub nothing_to_do: bool,
    /// A sweep with a search: what its searches did. `counts` are then of its searches: ok
    /// those that ended (located everything, found nothing, or stalled), failed those a failed
    /// run stopped, pending those stopped by their budget or by a signal.
    pub search: Option<super::search::SearchReport>,
}

impl RunReport {
    /// The exit code of the run: as its points stand ([`Counts::exit_code`]), and partial where
    /// some run failed, even one a search went on without (`status` counts it so too).
    pub fn exit_code(&self) -> i32 {
        if self.health.failed > 0 {
            crate::EXIT_PARTIAL
        } else {
            self.counts.exit_code()
        }
    }

    /// The report of a search sweep: its searches counted as the points.
    fn of_search(r: super::search::SearchReport) -> RunReport {
        use crate::search::SearchStatus;
        let mut counts = Counts::default();
        for s in &r.searches {
            match s.outcome.status {
                SearchStatus::Converged
                | SearchStatus::NotFound
                | SearchStatus::Stalled
                | SearchStatus::Unidentifiable => counts.ok += 1,
                SearchStatus::Failed => counts.failed += 1,
                SearchStatus::Budget | SearchStatus::Running => counts.pending += 1,
            }
        }
        RunReport {
            health: Health {
                // The runs that failed, whether or not a search ended on them.
                failed: r.counts.failed,
                verified: r.verified.0,
                worst_verified: r.verified.1.map(|e| (e, 0)),
                ..Health::default()
            },
            unpassed: Vec::new(),
            unsettled: Vec::new(),
            points: r.searches.len(),
            counts,
            failed: counts.failed,
            failures: Vec::new(),
            verification: VerificationReport {
                requested: 0,
                verified: r.verified.0,
                worst: r.verified.1.map(|e| (e, 0)),
                failed: 0,
                failures: Vec::new(),
                not_verified: Vec::new(),
            },
            stopped: r.stopped,
            ran: r.ran,
            damage: r.damage.clone(),
            nothing_to_do: false,
            search: Some(r),
        }
    }
}

/// Runs (or resumes) `sweep` into `opts.output` with the solver: checks the output, resolves
/// `integrator: auto` (in `sweep` and `grid`), locks the work directory and runs the plan. `stop` may be set from another
/// thread to take no new run; the output is then written with everything finished.
pub fn run_sweep(
    sweep: &mut Sweep,
    grid: &mut Grid,
    opts: &RunOptions,
    sink: &mut dyn ProgressSink,
    stop: &AtomicBool,
) -> Result<RunReport> {
    // Checked first: `--ensemble-round` is refused for every sweep that is not an adaptive
    // ensemble run in shards, a search's or a periodic block's too.
    let shard_round = super::ensemble::shard_round(sweep, opts)?;
    if sweep.periodic.is_some() {
        return super::periodic::run_periodic(sweep, grid, opts, sink, stop);
    }
    if sweep.search.is_some() {
        let r = super::search::run_search(sweep, grid, opts, sink, stop)?;
        return Ok(RunReport::of_search(r));
    }
    if let Some(k) = shard_round {
        // One round of an adaptive ensemble, this shard's part of it.
        *sweep = sweep.at_ensemble_round(k);
        *grid = Grid::new(sweep)?;
        return run_grid(sweep, grid, opts, sink, stop);
    }
    if sweep.adaptive_ensemble().is_some() {
        check_output(&opts.output, opts.overwrite)?;
        let (report, _) = super::ensemble::run_rounds(sweep, opts, sink, stop, run_grid)?;
        *grid = Grid::new(sweep)?;
        return Ok(report);
    }
    run_grid(sweep, grid, opts, sink, stop)
}

/// [`run_sweep`] for a sweep of a grid (no search; an ensemble of a fixed size, or one round of
/// an adaptive one).
fn run_grid(
    sweep: &mut Sweep,
    grid: &mut Grid,
    opts: &RunOptions,
    sink: &mut dyn ProgressSink,
    stop: &AtomicBool,
) -> Result<RunReport> {
    check_output(&opts.output, opts.overwrite)?;
    // Never more threads than grid points (a pool of idle threads costs time to start).
    let points = shard::points(sweep, grid, opts.shard);
    let pool = thread_pool(opts.jobs.min(points.len()).max(1))?;
    // `integrator: auto`: the cached choice, or a pilot (before the work directory is created,
    // so that a target no setting meets leaves nothing behind).
    let origin = auto::resolve(sweep, grid, Some(&work_dir_of(&opts.output)), &pool, sink)?;
    let work = WorkDir::open(&opts.output, Some(grid))?;
    if origin == AutoOrigin::Pilot {
        auto::cache(&work, sweep)?;
    }
    let executor = SolverExecutor::new(sweep, grid);
    run_points(
        &work, sweep, grid, points, opts, &pool, &executor, sink, stop,
    )
}

/// Runs (or resumes) `points` of `sweep` into the locked work directory `work` through
/// `executor`, with checkpoints, and writes the output file.
#[allow(clippy::too_many_arguments)]
pub fn run_points(
    work: &WorkDir,
    sweep: &Sweep,
    grid: &Grid,
    points: Vec<usize>,
    opts: &RunOptions,
    pool: &rayon::ThreadPool,
    executor: &dyn Executor,
    sink: &mut dyn ProgressSink,
    stop: &AtomicBool,
) -> Result<RunReport> {
    let damage = DamageReport::new(&opts.output, &work.damage(), sweep, grid);
    if damage.any() {
        sink.damage_found(&damage);
    }
    let plan = Plan::new(
        sweep,
        grid,
        points,
        work,
        opts.retry_failed,
        opts.verify_fraction,
    )?;
    if plan.tasks.is_empty() && !damage.any() && holds_every_run(work, sweep, grid, &plan) {
        // Nothing to run, and the file already holds it all (as written by this version, with
        // its snapshot): it is left as it is, whatever shard was asked for. (Logs a process
        // killed after publishing it left beside it are compacted, as that process would have.)
        if work.store_files() > 0 {
            work.compact_after_publish(grid)?;
        }
        let (failed, failures, over_limit) = failures(work, grid, &plan.points, &plan.done);
        let (unpassed, unsettled) = work
            .published_file()
            .and_then(|p| p.file().map(|f| flagged(f.table(), &plan.points, grid)))
            .unwrap_or_default();
        let counts = Counts {
            ok: plan.points.len() - failed - unsettled.len(),
            failed,
            pending: 0,
            unsettled: unsettled.len(),
        };
        let verification = verification_report(work, grid, &plan)?;
        return Ok(RunReport {
            points: plan.points.len(),
            health: health(failed, over_limit, &unsettled, &unpassed, &verification),
            unpassed,
            unsettled,
            counts,
            failed,
            failures,
            verification,
            stopped: false,
            ran: 0,
            damage,
            nothing_to_do: true,
            search: None,
        });
    }
    sink.started(&Start {
        total: plan.total,
        done: plan.done_before,
        failed: plan.failed_before,
        points: plan.points.len(),
        resumed_points: plan.points_done_before,
        output: &opts.output,
    });
    let tasks = plan.tasks.clone();
    let mut run = Running {
        work,
        sweep,
        grid,
        opts,
        plan,
        sink,
        published: 0,
        ran: 0,
    };
    // An output file from before holds at most the runs stored now (and so does the one
    // written at the start, [`Coordinator::begun`], when there is none).
    run.published = run.stored();
    let schedule = Schedule {
        pool,
        checkpoint_every: opts.checkpoint_interval,
        stop,
    };
    run_tasks(&tasks, executor, work, &schedule, &mut run)?;
    let written = run.assemble()?;
    let counts = written.counts;
    let plan = &run.plan;
    if plan.complete(grid) {
        // The file holds every run of the sweep: the logs beside it shrink to what it lacks.
        work.compact_after_publish(grid)?;
    }
    let (failed, failures, over_limit) = failures(work, grid, &plan.points, &plan.done);
    let (unpassed, unsettled) = flagged(&written.table, &plan.points, grid);
    let verification = verification_report(work, grid, plan)?;
    Ok(RunReport {
        points: plan.points.len(),
        health: health(failed, over_limit, &unsettled, &unpassed, &verification),
        unpassed,
        unsettled,
        counts,
        failed,
        failures,
        verification,
        stopped: stop.load(Ordering::Relaxed) && counts.pending > 0,
        ran: run.ran,
        damage,
        nothing_to_do: false,
        search: None,
    })
}

/// Whether the published output file is of this grid and holds every run of it (and every
/// verification run the plan samples, with its outcome), as written by this version (with its
/// snapshot) and with `--verify` no larger than it was: then running again changes nothing.
fn holds_every_run(work: &WorkDir, sweep: &Sweep, grid: &Grid, plan: &Plan) -> bool {
    // (Taken first: the published file's guard below holds the work directory's state.)
    let Ok(stored) = crate::store::RunStore::index(work) else {
        return false;
    };
    let Some(p) = work.published_file() else {
        return false;
    };
    // Its bytes exactly as published with its snapshot (so by this version, and undamaged even
    // where no checksum of a value reaches: scales, coordinates, padding).
    let current = p.intact();
    let fraction_kept = p
        .file()
        .is_some_and(|f| f.verify_fraction >= plan.verify.fraction);
    // The file's grid must be this sweep's (an edited sweep's file is written again).
    let same_grid = p.grid().is_some_and(|g| g.hashes == grid.hashes);
    // An ensemble's statistics follow from its sweep's text too (statistics, tolerances,
    // quantiles), not from its runs alone: an edited one is written again from the same runs.
    let same_tables =
        sweep.ensemble.is_none() || p.file().is_some_and(|f| f.sweep_text == sweep.text);
    // Each run as the file holds it: a run computed again since (`--retry-failed` killed before
    // it published) is in the logs with another outcome, and the file must be written again.
    let as_stored = |h: &RunHash| stored.get(h).map_or(true, |&ok| p.ok(h) == Some(ok));
    current
        && same_tables
        && fraction_kept
        && same_grid
        && grid.hashes.iter().all(|h| p.holds(h) && as_stored(h))
        && plan.points.iter().all(|&i| {
            !plan.sampled[i]
                || p.verify_info(&grid.hashes[i])
                    .is_some_and(|v| v.status != crate::record::VERIFY_NONE)
        })
}

/// The state of a run while its tasks execute: the coordinator of the scheduler.
struct Running<'a> {
    work: &'a WorkDir,
    sweep: &'a Sweep,
    grid: &'a Grid,
    opts: &'a RunOptions,
    plan: Plan,
    sink: &'a mut dyn ProgressSink,
    /// Runs stored when the output file was last published (at the start: those stored then,
    /// which an output file from before holds at most).
    published: usize,
    /// Tasks finished by this call.
    ran: usize,
}

/// A checkpoint publishes the output file again only once the stored runs have grown by this
/// factor since it was last published (and the end of the run always does): a file holds the
/// chunks of its finished points only (a chunk of nothing but the fill value, as every chunk of
/// pending points is, is not written: `store::hdf5::write_points`), so its size follows the runs
/// it holds, and the publishes of a
/// sweep write about `GROWTH / (GROWTH - 1)` times the final file in all, whatever the
/// checkpoint interval (a pending point names no run: nothing of it is written), while every
/// checkpoint makes the runs stored so far durable.
pub const PUBLISH_GROWTH: usize = 2;

impl Running<'_> {
    /// Runs stored (grid runs and verification runs), the measure of the output file's size.
    fn stored(&self) -> usize {
        self.plan.done.len() + self.plan.verify.done.len()
    }

    fn assemble(&mut self) -> Result<Written> {
        self.published = self.stored();
        assemble(
            self.work,
            &Assembly {
                sweep: self.sweep,
                grid: self.grid,
                points: &self.plan.points,
                shard: self.opts.shard,
                done: &self.plan.done,
                provenance: &self.opts.provenance,
                verify: &self.plan.verify,
                search: None,
            },
        )
    }
}

impl Coordinator for Running<'_> {
    /// A readable output file from the start (every point pending or resumed), so that a run
    /// killed before its first checkpoint still leaves one that `status` and h5py read: written
    /// as soon as the workers have their tasks, while they run, rather than holding them back
    /// for the time it takes. (No other process writes it: this one holds the work directory.)
    fn begun(&mut self) -> Result<()> {
        if !self.opts.output.exists() {
            self.assemble()?;
        }
        Ok(())
    }

    fn finished(&mut self, task: &Task, ok: bool) {
        self.ran += 1;
        self.plan.finish(task, ok);
        for _ in 0..self.plan.weight(task) {
            self.sink.run_finished(!ok);
        }
    }

    fn idle(&mut self) {
        self.sink.idle();
    }

    fn checkpoint(&mut self) -> Result<()> {
        let stored = self.stored();
        if stored < PUBLISH_GROWTH * self.published.max(1) {
            self.work.sync()?;
        } else {
            self.assemble()?;
        }
        self.sink.checkpoint();
        Ok(())
    }

    fn stopping(&mut self, in_flight: usize) -> Result<()> {
        // Written at once: a SIGKILL after the SIGTERM (SLURM's KillWait) then loses only the
        // runs in flight, which a resume recomputes.
        self.assemble()?;
        self.sink.stopping(in_flight);
        Ok(())
    }

    fn checkpoint_failed(&mut self, error: &Error, in_flight: usize) {
        self.sink.checkpoint_failed(&format!(
            "writing {} failed: {error}. The sweep stops now: no new run starts, {in_flight} run(s) in flight (at most) finish. Every finished run stays stored in {}; fix the cause and run the same command again to resume from them.",
            self.opts.output.display(),
            work_dir_of(&self.opts.output).display()
        ));
    }

    fn ended(&mut self) {
        self.sink.runs_ended();
    }
}

/// The health of a run's points from what the report holds.
fn health(
    failed: usize,
    over_limit: usize,
    unsettled: &[usize],
    unpassed: &[usize],
    v: &VerificationReport,
) -> Health {
    Health {
        failed,
        over_limit,
        unsettled: unsettled.len(),
        nan_leading: unpassed.len(),
        verified: v.verified,
        worst_verified: v.worst,
    }
}

/// The failed grid points among `points` (counted once per point), how many of them a limit
/// stopped, and the first [`LISTED_FAILURES`] with their reasons.
fn failures(
    store: &dyn RunStore,
    grid: &Grid,
    points: &[usize],
    done: &HashMap<RunHash, bool>,
) -> (usize, Vec<Failure>, usize) {
    let failed_points: Vec<usize> = points
        .iter()
        .copied()
        .filter(|&i| done.get(&grid.hashes[i]) == Some(&false))
        .collect();
    let reason = |point: usize| {
        store
            .read(&grid.hashes[point])
            .ok()
            .flatten()
            .map(|r| r.reason)
    };
    let listed = failed_points
        .iter()
        .take(LISTED_FAILURES)
        .map(|&point| Failure {
            point,
            reason: reason(point),
        })
        .collect();
    let over_limit = failed_points
        .iter()
        .filter(|&&i| reason(i).is_some_and(|r| Health::is_limit(&r)))
        .count();
    (failed_points.len(), listed, over_limit)
}

/// Which of `points` hold a succeeded run whose leading peak is NaN at some probe, of a file's
/// `table` ([`crate::record::columns::Table::unpassed_points`]).
pub(super) fn unpassed(table: &Table, points: &[usize]) -> Vec<usize> {
    among(table.unpassed_points(), points, table.n)
}

/// The points of `points` (of `grid`) that `table` flags: those whose leading peak is NaN
/// ([`unpassed`]; none where the grid does not ask for leading pulses,
/// [`Grid::asks_leading_pulses`]) and those whose steady state did not settle.
pub(super) fn flagged(table: &Table, points: &[usize], grid: &Grid) -> (Vec<usize>, Vec<usize>) {
    let unpassed = if grid.asks_leading_pulses() {
        unpassed(table, points)
    } else {
        Vec::new()
    };
    (unpassed, among(table.unsettled_points(), points, table.n))
}

/// Those of `found` (points of a table of `n`) that are among `points`.
fn among(found: Vec<usize>, points: &[usize], n: usize) -> Vec<usize> {
    let mut wanted = vec![false; n];
    for &i in points {
        if let Some(w) = wanted.get_mut(i) {
            *w = true;
        }
    }
    found.into_iter().filter(|&i| wanted[i]).collect()
}

/// What the verification runs of `plan` found.
fn verification_report(
    store: &dyn RunStore,
    grid: &Grid,
    plan: &Plan,
) -> Result<VerificationReport> {
    let mut report = VerificationReport::default();
    let mut failed_points = Vec::new();
    for &i in &plan.points {
        let Some(h) = plan.verify.hashes.get(&i) else {
            continue;
        };
        match plan.verify.done.get(h) {
            Some(false) => failed_points.push(i),
            Some(true) => {
                let Some(rec) = store.read(&grid.hashes[i])? else {
                    continue;
                };
                let info = plan.verify.info(store, grid, i, &rec)?;
                if info.status == VERIFY_OK {
                    report.verified += 1;
                    let e = info.max_error();
                    if !e.is_nan() && report.worst.map_or(true, |(w, _)| e > w) {
                        report.worst = Some((e, i));
                    }
                }
            }
            None => {}
        }
    }
    report.failed = failed_points.len();
    for &point in failed_points.iter().take(LISTED_FAILURES) {
        let reason = store
            .read(&plan.verify.hashes[&point])?
            .map(|r| r.reason)
            .unwrap_or_default();
        report.failures.push(Failure {
            point,
            reason: Some(reason),
        });
    }
    report.requested = plan.points.iter().filter(|&&i| plan.sampled[i]).count();
    let recorded = [
        grid.history,
        grid.min_overlap,
        grid.fields.is_some(),
        grid.spectrum,
        grid.energy_ledger,
    ];
    report.not_verified = crate::numerics::verify::NOT_VERIFIED
        .iter()
        .zip(recorded)
        .filter_map(|(&what, on)| on.then_some(what))
        .collect();
    Ok(report)
}
