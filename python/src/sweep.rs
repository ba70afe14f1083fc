//! A sweep file run into HDF5 in this process, exactly as `chainsweep run` runs it (resume,
//! run logs, exit codes), with progress for Python and a clean stop on Ctrl-C.
//!
//! The runner runs on a thread of its own; the calling thread waits with the GIL released and,
//! a few times a second, takes it to check Python's signals (Ctrl-C, a notebook's interrupt) and
//! to report progress to a Python callback. Ctrl-C asks the runner to stop cleanly: runs in
//! flight finish and are stored, the output is assembled with the rest pending, and the
//! `KeyboardInterrupt` is raised once the runner has returned, so the same call resumes.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

use pyo3::prelude::*;

use chainsweep::engine::{self, run, slurm};
use chainsweep::error::{Error, Result};
use chainsweep::progress::Terminal;
use chainsweep::store::hdf5::Provenance;
use chainsweep::{EXIT_OK, EXIT_PARTIAL};

use crate::watch::Watch;

/// What `chainsweep.sweep` asks for.
#[derive(Debug, Clone)]
pub struct SweepRequest {
    /// Sweep file.
    pub file: PathBuf,
    /// Output HDF5 file.
    pub output: PathBuf,
    /// Parallel runs (`None`: every CPU).
    pub jobs: Option<usize>,
    /// `K/N`: run only that shard.
    pub shard: Option<String>,
    /// Run again the points whose earlier run failed.
    pub retry_failed: bool,
    /// Fraction of points re-run at a tighter setting.
    pub verify: Option<f64>,
    /// Seconds between refreshes of the output while the sweep runs (0: only at the end).
    pub checkpoint_interval: f64,
}

/// The package's one call into the runner for a whole sweep: the engine's
/// [`run::run_sweep`], as `chainsweep run FILE -o OUTPUT --quiet …` calls it, with the same
/// checks of the options (errors name them as the command line does: `--jobs`, `--shard`, …).
/// The runner's own progress display stays quiet ([`Watch`] reports progress to Python instead;
/// only what `integrator: auto` chose is said on stderr), and `stop` is the engine's stop flag:
/// once set, no new run starts, the runs in flight are stored and the output is written with the
/// rest pending. Returns the exit code the command line would (0, or 3 with failed or pending
/// runs).
fn run_request(req: &SweepRequest, stop: &AtomicBool) -> Result<(i32, usize)> {
    let (mut sweep, mut grid) = engine::load(&req.file)?;
    let shard = req
        .shard
        .as_deref()
        .map(|s| slurm::parse_shard_env(s, "--shard"))
        .transpose()?;
    let fraction = req.verify.unwrap_or(0.0);
    let jobs = req.jobs.unwrap_or_else(engine::default_jobs);
    run::RunOptions::check(jobs, req.checkpoint_interval, fraction)?;
    let opts = run::RunOptions {
        output: req.output.clone(),
        jobs,
        shard,
        retry_failed: req.retry_failed,
        checkpoint_interval: Duration::from_secs_f64(req.checkpoint_interval),
        verify_fraction: fraction,
        overwrite: false,
        provenance: Provenance::of_this_process(),
    };
    let mut sink = Terminal::new(true, Duration::from_secs(10));
    let report = run::run_sweep(&mut sweep, &mut grid, &opts, &mut sink, stop)?;
    let c = &report.counts;
    let code = if c.failed > 0 || c.pending > 0 {
        EXIT_PARTIAL
    } else {
        EXIT_OK
    };
    Ok((code, report.ran))
}

/// How often Python's signals are checked while the sweep runs.
const SIGNAL_INTERVAL: Duration = Duration::from_millis(100);

/// Runs a sweep file into `output` (see the module docs). `progress`, when given, is called as
/// `progress(done, failed, total)` a few times a second and once at the end (counts of grid points
/// and verification runs, as the command line's progress bar counts them). Returns
/// `(exit_code, runs)`: the runner's exit code (0 all runs succeeded, 3 some failed or are
/// pending) and the number of runs this call made. Bad input raises `chainsweep.InputError`
/// (nothing run or written), anything else `chainsweep.SweepError`; Ctrl-C stops the sweep
/// cleanly and then raises `KeyboardInterrupt`; an exception raised by `progress` does the same
/// with that exception.
#[pyfunction]
#[pyo3(signature = (file, output, jobs=None, shard=None, retry_failed=false, verify=None, checkpoint_interval=300.0, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn run_sweep(
    py: Python<'_>,
    file: PathBuf,
    output: PathBuf,
    jobs: Option<usize>,
    shard: Option<String>,
    retry_failed: bool,
    verify: Option<f64>,
    checkpoint_interval: f64,
    progress: Option<Py<PyAny>>,
) -> PyResult<(i32, usize)> {
    let req = SweepRequest {
        file,
        output,
        jobs,
        shard,
        retry_failed,
        verify,
        checkpoint_interval,
    };
    // Before the runner starts, so that what exists already is not counted as run by this call.
    let mut watch = {
        let r = req.clone();
        py.detach(move || Watch::new(&r))
    };
    // The state before anything runs: what is done already is not counted in the rate.
    if let (Some(w), Some(cb)) = (watch.as_mut(), progress.as_ref()) {
        let p = py.detach(|| w.poll());
        cb.call1(py, (p.done, p.failed, p.total))?;
    }
    let stop = Arc::new(AtomicBool::new(false));
    let request_stop = || stop.store(true, Ordering::SeqCst);
    let (tx, rx) = mpsc::channel::<Result<(i32, usize)>>();
    let runner_req = req.clone();
    let runner_stop = Arc::clone(&stop);
    let runner = std::thread::spawn(move || {
        let _ = tx.send(run_request(&runner_req, &runner_stop));
    });
    // (A receiver is not `Sync`; the wait below borrows it from a thread without the GIL.)
    let rx = std::sync::Mutex::new(rx);
    let mut pending_error: Option<PyErr> = None;
    let mut next_report = Instant::now() + Duration::from_millis(250);
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
        if let (Some(w), Some(cb), true) = (
            watch.as_mut(),
            progress.as_ref(),
            Instant::now() >= next_report,
        ) {
            let t0 = Instant::now();
            let p = py.detach(|| w.poll());
            // Polling reads the work directory: keep it under a few per cent of the time.
            next_report = Instant::now() + (t0.elapsed() * 30).max(Duration::from_millis(250));
            if pending_error.is_none() {
                if let Err(e) = cb.call1(py, (p.done, p.failed, p.total)) {
                    request_stop();
                    pending_error = Some(e);
                }
            }
        }
    };
    let _ = runner.join();
    if let Some(w) = watch.as_mut() {
        let p = py.detach(|| w.poll());
        if let (Some(cb), None) = (progress.as_ref(), pending_error.as_ref()) {
            cb.call1(py, (p.done, p.failed, p.total))?;
        }
    }
    if let Some(e) = pending_error {
        return Err(e);
    }
    // What ran is the runner's count: the watch may not see a run whose record was compacted
    // into the output file before it looked (a retried failure that failed again).
    outcome.map_err(|e| crate::py_error(py, &e, "sweep"))
}
