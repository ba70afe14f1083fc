//! A sweep file run into HDF5 in this process, exactly as `chainsweep run` runs it (resume,
//! run logs, exit codes), with progress for Python and a clean stop on Ctrl-C.
//!
//! The runner runs on a thread of its own; the calling thread waits with the GIL released and,
//! a few times a second, takes it to check Python's signals (Ctrl-C, a notebook's interrupt) and
//! to report progress to a Python callback. Progress is what the engine's [`ProgressSink`] hears
//! (the runs to do when they start, each run as it finishes), kept in atomics the calling thread
//! reads: the same counts as the command line's progress bar, a search's included. Ctrl-C asks
//! the runner to stop cleanly: runs in flight finish and are stored, the output is assembled with
//! the rest pending, and the `KeyboardInterrupt` is raised once the runner has returned, so the
//! same call resumes.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{mpsc, Arc, Mutex};
use std::time::{Duration, Instant};

use pyo3::prelude::*;

use chainsweep::engine::run::RunRequest;
use chainsweep::engine::{self, run, AutoResolution, DamageReport, ProgressSink, Start};
use chainsweep::error::{Error, Result};
use chainsweep_cli::progress::Terminal;

/// Counts of a sweep's runs (grid points and verification runs, or a search's runs against its
/// budgets), as the engine reports them to [`Counting`].
#[derive(Debug, Default)]
struct Counts {
    /// The runs have started: the counts below mean something.
    started: AtomicBool,
    /// What was done when they started (done, failed, total), for the first report.
    at_start: Mutex<Option<(usize, usize, usize)>>,
    done: AtomicUsize,
    failed: AtomicUsize,
    total: AtomicUsize,
}

impl Counts {
    /// (done, failed, total) now; `None` before the runs start.
    fn now(&self) -> Option<(usize, usize, usize)> {
        self.started.load(Ordering::SeqCst).then(|| {
            (
                self.done.load(Ordering::SeqCst),
                self.failed.load(Ordering::SeqCst),
                self.total.load(Ordering::SeqCst),
            )
        })
    }
}

/// The engine's [`ProgressSink`] for Python: counts runs into [`Counts`] and leaves what the
/// command line says (what `integrator: auto` chose, damage found, a checkpoint that failed) to
/// the command line's quiet display.
struct Counting {
    counts: Arc<Counts>,
    terminal: Terminal,
}

impl ProgressSink for Counting {
    fn pilot(&mut self, line: &str) {
        self.terminal.pilot(line);
    }
    fn damage_found(&mut self, report: &DamageReport) {
        self.terminal.damage_found(report);
    }
    fn auto_resolved(&mut self, resolution: AutoResolution<'_>) {
        self.terminal.auto_resolved(resolution);
    }
    fn started(&mut self, start: &Start<'_>) {
        let c = &self.counts;
        c.done.store(start.done, Ordering::SeqCst);
        c.failed.store(start.failed, Ordering::SeqCst);
        c.total.store(start.total, Ordering::SeqCst);
        *c.at_start.lock().expect("never poisoned") = Some((start.done, start.failed, start.total));
        c.started.store(true, Ordering::SeqCst);
        self.terminal.started(start);
    }
    fn run_finished(&mut self, failed: bool) {
        self.counts.done.fetch_add(1, Ordering::SeqCst);
        if failed {
            self.counts.failed.fetch_add(1, Ordering::SeqCst);
        }
        self.terminal.run_finished(failed);
    }
    fn stopping(&mut self, in_flight: usize) {
        self.terminal.stopping(in_flight);
    }
    fn checkpoint_failed(&mut self, message: &str) {
        self.terminal.checkpoint_failed(message);
    }
    fn runs_ended(&mut self) {
        self.terminal.runs_ended();
    }
}

/// What the runner's thread gives back: the exit code, the runs made, and the final counts.
struct Finished {
    code: i32,
    ran: usize,
    /// (done, failed, total) at the end.
    counts: (usize, usize, usize),
}

/// The package's one call into the runner for a whole sweep: the engine's
/// [`run::run_sweep`], as `chainsweep run FILE -o OUTPUT --quiet …` calls it, with the same
/// checks of the options (errors name them as the command line does: `--jobs`, `--shard`, …).
/// Progress goes to `counts`; `stop` is the engine's stop flag: once set, no new run starts, the
/// runs in flight are stored and the output is written with the rest pending. The exit code is
/// the command line's (0, or 3 with failed or pending runs).
fn run_request(req: &RunRequest, stop: &AtomicBool, counts: &Arc<Counts>) -> Result<Finished> {
    let (mut sweep, mut grid) = engine::load(&req.file)?;
    let opts = req.options()?;
    let mut sink = Counting {
        counts: Arc::clone(counts),
        terminal: Terminal::new(
            true,
            Duration::from_secs_f64(run::DEFAULT_PROGRESS_INTERVAL_S),
        ),
    };
    let report = run::run_sweep(&mut sweep, &mut grid, &opts, &mut sink, stop)?;
    let c = &report.counts;
    let code = report.exit_code();
    let v = &report.verification;
    let end = match counts.now() {
        // A search ends below its budgets: what it did is the whole of it.
        Some((done, failed, _)) if report.search.is_some() && !report.stopped => {
            (done, failed, done)
        }
        Some(now) => now,
        // Nothing was to be done: the output held every run.
        None => {
            let total = report.points + v.requested;
            (total, c.failed + v.failed, total)
        }
    };
    Ok(Finished {
        code,
        ran: report.ran,
        counts: end,
    })
}

/// How often Python's signals are checked while the sweep runs.
const SIGNAL_INTERVAL: Duration = Duration::from_millis(100);

/// Runs a sweep file into `output` (see the module docs). `progress`, when given, is called as
/// `progress(done, failed, total)` when the runs start, a few times a second while they change,
/// and once at the end (counts of grid points and verification runs, as the command line's
/// progress bar counts them; for a search, its runs against its budgets, the total the runs it
/// made once it has ended). Returns
/// `(exit_code, runs)`: the runner's exit code (0 all runs succeeded, 3 some failed or are
/// pending) and the number of runs this call made. Bad input raises `chainsweep.InputError`
/// (nothing run or written), anything else `chainsweep.SweepError`; Ctrl-C stops the sweep
/// cleanly and then raises `KeyboardInterrupt`; an exception raised by `progress` does the same
/// with that exception.
#[pyfunction]
#[pyo3(signature = (file, output, jobs=None, shard=None, retry_failed=false, verify=None, checkpoint_interval=None, progress=None, ensemble_round=None))]
#[allow(clippy::too_many_arguments)]
pub fn run_sweep(
    py: Python<'_>,
    file: PathBuf,
    output: PathBuf,
    jobs: Option<usize>,
    shard: Option<String>,
    retry_failed: bool,
    verify: Option<f64>,
    checkpoint_interval: Option<f64>,
    progress: Option<Py<PyAny>>,
    ensemble_round: Option<usize>,
) -> PyResult<(i32, usize)> {
    let req = RunRequest {
        output: Some(output),
        jobs,
        shard,
        ensemble_round,
        retry_failed,
        verify,
        checkpoint_interval_s: checkpoint_interval.unwrap_or(run::DEFAULT_CHECKPOINT_INTERVAL_S),
        ..RunRequest::new(file)
    };
    let counts = Arc::new(Counts::default());
    let stop = Arc::new(AtomicBool::new(false));
    let request_stop = || stop.store(true, Ordering::SeqCst);
    let (tx, rx) = mpsc::channel::<Result<Finished>>();
    let runner_req = req.clone();
    let runner_stop = Arc::clone(&stop);
    let runner_counts = Arc::clone(&counts);
    let runner = std::thread::spawn(move || {
        let _ = tx.send(run_request(&runner_req, &runner_stop, &runner_counts));
    });
    // (A receiver is not `Sync`; the wait below borrows it from a thread without the GIL.)
    let rx = std::sync::Mutex::new(rx);
    let mut pending_error: Option<PyErr> = None;
    let mut reported_start = false;
    let mut last: Option<(usize, usize, usize)> = None;
    let mut next_report = Instant::now();
    let report = |py: Python<'_>, c: (usize, usize, usize), pending: &mut Option<PyErr>| {
        if let (Some(cb), None) = (progress.as_ref(), pending.as_ref()) {
            if let Err(e) = cb.call1(py, c) {
                *pending = Some(e);
                return true;
            }
        }
        false
    };
    let outcome = loop {
        match py.detach(|| {
            rx.lock()
                .expect("only this thread locks it")
                .recv_timeout(SIGNAL_INTERVAL)
        }) {
            Ok(r) => break r,
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                break Err(Error::Other(
                    "the sweep's thread ended without a result (a panic outside the runs)".into(),
                ))
            }
        }
        if pending_error.is_none() {
            if let Err(e) = py.check_signals() {
                request_stop();
                pending_error = Some(e);
            }
        }
        // The state when the runs started first (what was done before is not counted in a
        // rate), then the counts a few times a second when they change.
        if !reported_start {
            let start = *counts.at_start.lock().expect("never poisoned");
            if let Some(s) = start {
                reported_start = true;
                last = Some(s);
                if report(py, s, &mut pending_error) {
                    request_stop();
                }
            }
        } else if Instant::now() >= next_report {
            next_report = Instant::now() + Duration::from_millis(250);
            if let Some(now) = counts.now().filter(|&now| Some(now) != last) {
                last = Some(now);
                if report(py, now, &mut pending_error) {
                    request_stop();
                }
            }
        }
    };
    let _ = runner.join();
    let finished = outcome.map_err(|e| {
        pending_error
            .take()
            .unwrap_or_else(|| crate::py_error(py, &e, "sweep"))
    })?;
    if let Some(e) = pending_error {
        return Err(e);
    }
    // The state when the runs started, if the runs ended before it was reported.
    if !reported_start {
        if let Some(s) = *counts.at_start.lock().expect("never poisoned") {
            if report(py, s, &mut pending_error) {
                return Err(pending_error.expect("just set"));
            }
        }
    }
    if report(py, finished.counts, &mut pending_error) {
        return Err(pending_error.expect("just set"));
    }
    Ok((finished.code, finished.ran))
}
